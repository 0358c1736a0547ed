//! SVG pictures of a crowd at one time.

use crate::crowd::Population;
use crate::error::SweepError;
use crate::scene::{ObstacleShape, SceneGeometry};
use crate::stepper::{Observer, ObserverError, StepReport};
use std::fmt::Write;
use std::path::PathBuf;
use std::sync::Arc;

/// Fill colours of the groups of people, in order.
pub(crate) const PALETTE: [&str; 8] = [
    "#3b75af", "#e07b39", "#519e3e", "#c53a32", "#8d69b8", "#84584e", "#d57dbe", "#7f7f7f",
];
/// Outline colours matching [`PALETTE`].
pub(crate) const PALETTE_DARK: [&str; 8] = [
    "#1f4e7a", "#9c4f1c", "#2f6a22", "#86211b", "#5b3f82", "#573830", "#9c4a87", "#4d4d4d",
];

/// The colour scale of pressure, from none to the largest (a sequential yellow–red scale).
pub(crate) const PRESSURE_SCALE: [&str; 5] =
    ["#ffffcc", "#fed976", "#fd8d3c", "#e31a1c", "#800026"];

/// The colour of pressure `p` on a scale from 0 to `max`: [`PRESSURE_SCALE`] interpolated.
pub(crate) fn pressure_colour(p: f64, max: f64) -> String {
    let rgb = |c: &str| {
        let v = u32::from_str_radix(&c[1..], 16).unwrap_or(0);
        [(v >> 16) & 255, (v >> 8) & 255, v & 255].map(f64::from)
    };
    let s = if max > 0.0 {
        (p / max).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = s * (PRESSURE_SCALE.len() - 1) as f64;
    let k = (x.floor() as usize).min(PRESSURE_SCALE.len() - 2);
    let (a, b) = (rgb(PRESSURE_SCALE[k]), rgb(PRESSURE_SCALE[k + 1]));
    let w = x - k as f64;
    let c: Vec<u32> = (0..3)
        .map(|i| (a[i] + w * (b[i] - a[i])).round() as u32)
        .collect();
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// A legend of the pressure scale at `(x, y)` (SVG coordinates), `width` long and
/// `height` high, from 0 to `max` m/s.
fn pressure_legend(x: f64, y: f64, width: f64, height: f64, max: f64) -> String {
    let stops: String = PRESSURE_SCALE
        .iter()
        .enumerate()
        .map(|(k, c)| {
            format!(
                r#"<stop offset="{}" stop-color="{c}"/>"#,
                k as f64 / (PRESSURE_SCALE.len() - 1) as f64
            )
        })
        .collect();
    let font = r#"font-family="Helvetica, Arial, sans-serif""#;
    format!(
        r#"<defs><linearGradient id="pressure-scale">{stops}</linearGradient></defs>
<rect x="{x:.4}" y="{y:.4}" width="{width:.4}" height="{height:.4}" fill="url(#pressure-scale)" stroke="{WALL}" stroke-width="{:.4}"/>
<text x="{:.4}" y="{:.4}" {font} font-size="{:.4}" fill="{WALL}" text-anchor="end">pressure 0</text>
<text x="{:.4}" y="{:.4}" {font} font-size="{:.4}" fill="{WALL}">{max:.3} m/s</text>
"#,
        0.02 * height,
        x - 0.3 * height,
        y + 0.85 * height,
        height,
        x + width + 0.3 * height,
        y + 0.85 * height,
        height,
    )
}

pub(crate) const ROOM_FILL: &str = "#f5f2eb";
pub(crate) const WALL: &str = "#2b2b2b";
pub(crate) const EXIT: &str = "#19a35b";
pub(crate) const OBSTACLE: &str = "#9a9a9a";

/// The static part of a picture (room floor, walls, exits), in metres with `y` pointing up
/// (the SVG's `y` is `−y`).
pub(crate) fn static_layer(g: &SceneGeometry, unit: f64) -> String {
    let mut s = String::new();
    let pts: Vec<String> = g
        .room
        .iter()
        .map(|p| format!("{:.4},{:.4}", p[0], -p[1]))
        .collect();
    let _ = writeln!(
        s,
        r#"<polygon points="{}" fill="{ROOM_FILL}" stroke="none"/>"#,
        pts.join(" ")
    );
    for (a, b) in &g.walls {
        let _ = writeln!(
            s,
            r#"<line x1="{:.4}" y1="{:.4}" x2="{:.4}" y2="{:.4}" stroke="{WALL}" stroke-width="{:.4}" stroke-linecap="square"/>"#,
            a[0],
            -a[1],
            b[0],
            -b[1],
            1.6 * unit
        );
    }
    if let Some(arena) = &g.arena {
        let _ = writeln!(
            s,
            r#"<circle cx="{:.4}" cy="{:.4}" r="{:.4}" fill="none" stroke="{WALL}" stroke-width="{:.4}"/>"#,
            arena.center[0],
            -arena.center[1],
            arena.radius,
            1.6 * unit
        );
    }
    for e in &g.exits {
        let _ = writeln!(
            s,
            r#"<line x1="{:.4}" y1="{:.4}" x2="{:.4}" y2="{:.4}" stroke="{EXIT}" stroke-width="{:.4}" stroke-dasharray="{:.4} {:.4}"/>"#,
            e.a[0],
            -e.a[1],
            e.b[0],
            -e.b[1],
            3.0 * unit,
            3.0 * unit,
            1.5 * unit
        );
    }
    s
}

/// One obstacle displaced by `offset`, as an SVG element.
pub(crate) fn obstacle_element(shape: &ObstacleShape, offset: [f64; 2], unit: f64) -> String {
    match shape {
        ObstacleShape::Disk { center, radius } => format!(
            r#"<circle cx="{:.4}" cy="{:.4}" r="{:.4}" fill="{OBSTACLE}" stroke="{WALL}" stroke-width="{:.4}"/>"#,
            center[0] + offset[0],
            -(center[1] + offset[1]),
            radius,
            0.5 * unit
        ),
        ObstacleShape::Segment { a, b } => format!(
            r#"<line x1="{:.4}" y1="{:.4}" x2="{:.4}" y2="{:.4}" stroke="{WALL}" stroke-width="{:.4}" stroke-linecap="round"/>"#,
            a[0] + offset[0],
            -(a[1] + offset[1]),
            b[0] + offset[0],
            -(b[1] + offset[1]),
            1.6 * unit
        ),
        ObstacleShape::Polygon(p) => {
            let pts: Vec<String> = p
                .iter()
                .map(|v| format!("{:.4},{:.4}", v[0] + offset[0], -(v[1] + offset[1])))
                .collect();
            format!(
                r#"<polygon points="{}" fill="{OBSTACLE}" stroke="{WALL}" stroke-width="{:.4}"/>"#,
                pts.join(" "),
                0.5 * unit
            )
        }
    }
}

/// `(unit, width, height)`: a line-width unit in metres and the picture's size in metres.
pub(crate) fn frame(g: &SceneGeometry) -> (f64, f64, f64) {
    let w = g.bounds[2] - g.bounds[0];
    let h = g.bounds[3] - g.bounds[1];
    (w.max(h) / 400.0, w, h)
}

/// An SVG picture of the crowd at time `t`: the room, its walls (dark) and exits (green,
/// dashed), the obstacles where they are at `t`, and every person still in the room as a disk
/// coloured by group, or, given each person's `pressure` (m/s), filled by it on a scale from 0
/// to the largest in the picture (a legend says it) and outlined by group.
pub fn render_svg(
    g: &SceneGeometry,
    population: &Population,
    group_of: &[usize],
    q: &[f64],
    t: f64,
    title: &str,
    pressure: Option<&[f64]>,
) -> String {
    let (unit, w, h) = frame(g);
    let header = 0.07 * w.max(h);
    let px_w = 800.0;
    let px_h = px_w * (h + header) / w;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{px_w:.0}" height="{px_h:.0}" viewBox="{:.4} {:.4} {:.4} {:.4}">"#,
        g.bounds[0],
        -g.bounds[3] - header,
        w,
        h + header
    );
    let _ = writeln!(
        s,
        r#"<rect x="{:.4}" y="{:.4}" width="{:.4}" height="{:.4}" fill="white"/>"#,
        g.bounds[0],
        -g.bounds[3] - header,
        w,
        h + header
    );
    s.push_str(&static_layer(g, unit));
    for o in &g.obstacles {
        s.push_str(&obstacle_element(&o.shape, o.offset(t), unit));
        s.push('\n');
    }
    let present = population.present_count(q);
    let largest = pressure.map(|p| {
        (0..population.len())
            .filter(|&i| population.is_present(q, i))
            .filter_map(|i| p.get(i).copied())
            .fold(0.0, f64::max)
    });
    for i in 0..population.len() {
        if !population.is_present(q, i) {
            continue;
        }
        let c = group_of.get(i).copied().unwrap_or(0) % PALETTE.len();
        let fill = match (pressure, largest) {
            (Some(p), Some(max)) => pressure_colour(p.get(i).copied().unwrap_or(0.0), max),
            _ => PALETTE[c].to_string(),
        };
        let _ = writeln!(
            s,
            r#"<circle cx="{:.4}" cy="{:.4}" r="{:.4}" fill="{fill}" stroke="{}" stroke-width="{:.4}"/>"#,
            q[2 * i],
            -q[2 * i + 1],
            population.radius(i),
            PALETTE_DARK[c],
            0.4 * unit
        );
    }
    if let Some(max) = largest {
        s.push_str(&pressure_legend(
            g.bounds[0] + 0.62 * w,
            -g.bounds[3] - 0.55 * header,
            0.2 * w,
            0.3 * header,
            max,
        ));
    }
    let _ = writeln!(
        s,
        r#"<text x="{:.4}" y="{:.4}" font-family="Helvetica, Arial, sans-serif" font-size="{:.4}" fill="{WALL}">{} — t = {:.2} s — in the room: {} / {}</text>"#,
        g.bounds[0] + 0.02 * w,
        -g.bounds[3] - 0.3 * header,
        0.45 * header,
        crate::svg::escape(title),
        t,
        present,
        population.len()
    );
    s.push_str("</svg>\n");
    s
}

/// Writes an SVG snapshot at `t₀`, every `every` seconds, and at the end of the run, into a
/// directory (files `t0000.00.svg`, … and `final.svg`).
pub struct SnapshotWriter {
    dir: PathBuf,
    geometry: SceneGeometry,
    population: Arc<Population>,
    group_of: Vec<usize>,
    title: String,
    every: f64,
    next: f64,
    last: Option<(f64, Vec<f64>, Option<Vec<f64>>)>,
    written: Vec<PathBuf>,
    pressure: bool,
}

impl SnapshotWriter {
    /// Snapshots of a scene every `every` seconds into `dir` (created if needed).
    pub fn new(
        dir: impl Into<PathBuf>,
        geometry: SceneGeometry,
        population: Arc<Population>,
        group_of: Vec<usize>,
        title: &str,
        every: f64,
    ) -> Self {
        Self {
            dir: dir.into(),
            geometry,
            population,
            group_of,
            title: title.to_string(),
            every,
            next: 0.0,
            last: None,
            written: Vec::new(),
            pressure: false,
        }
    }

    /// Fills people by their pressure (the run must keep its contacts,
    /// [`StepperSettings::record_contacts`](crate::stepper::StepperSettings::record_contacts));
    /// the first picture, before any step, shows none.
    #[must_use]
    pub fn with_pressure(mut self, on: bool) -> Self {
        self.pressure = on;
        self
    }

    /// Each person's pressure at the step of `r`, when asked for.
    fn pressure_of(&self, r: &StepReport) -> Option<Vec<f64>> {
        self.pressure.then(|| {
            let mut p = Vec::new();
            super::pressures(r, self.population.len(), &mut p);
            p
        })
    }

    /// The files written so far.
    pub fn written(&self) -> &[PathBuf] {
        &self.written
    }

    fn write(
        &mut self,
        name: &str,
        t: f64,
        q: &[f64],
        pressure: Option<&[f64]>,
    ) -> Result<(), String> {
        // Before any step there is no force: nobody is coloured by one.
        let zeros = vec![0.0; self.population.len()];
        let pressure = pressure.or(self.pressure.then_some(zeros.as_slice()));
        let svg = render_svg(
            &self.geometry,
            &self.population,
            &self.group_of,
            q,
            t,
            &self.title,
            pressure,
        );
        let path = self.dir.join(name);
        super::write_whole(&path, svg).map_err(|e| format!("{}: {e}", path.display()))?;
        self.written.push(path);
        Ok(())
    }
}

impl Observer for SnapshotWriter {
    fn name(&self) -> &str {
        "snapshot writer"
    }

    fn on_start(&mut self, t: f64, q: &[f64]) -> Result<(), ObserverError> {
        std::fs::create_dir_all(&self.dir).map_err(|e| format!("{}: {e}", self.dir.display()))?;
        self.write(&format!("t{t:07.2}.svg"), t, q, None)?;
        self.next = t + self.every;
        Ok(())
    }

    fn on_step(&mut self, r: &StepReport, q: &[f64]) -> Result<(), ObserverError> {
        let pressure = self.pressure_of(r);
        if r.t >= self.next - 1e-9 * self.next.abs().max(1.0) {
            self.write(&format!("t{:07.2}.svg", r.t), r.t, q, pressure.as_deref())?;
            self.next = super::next_time_after(self.next, self.every, r.t);
        }
        self.last = Some((r.t, q.to_vec(), pressure));
        Ok(())
    }

    fn on_finish(&mut self, _error: Option<&SweepError>) -> Result<(), ObserverError> {
        if let Some((t, q, pressure)) = self.last.take() {
            self.write("final.svg", t, &q, pressure.as_deref())?;
        }
        Ok(())
    }
}
