//! A self-contained HTML animation: inline SVG, the frames as JSON, a few lines of
//! JavaScript (play/pause, time slider, speed). Opens in any browser, offline.

use super::svg::{frame, obstacle_element, static_layer, PALETTE, PALETTE_DARK, PRESSURE_SCALE};
use crate::crowd::Population;
use crate::error::SweepError;
use crate::scene::SceneGeometry;
use crate::stepper::{Observer, ObserverError, StepReport};
use std::fmt::Write;
use std::path::PathBuf;
use std::sync::Arc;

/// Records at most `max_frames` frames, evenly spaced in time over the horizon, and writes
/// the page at the end of the run (also after a failure: the page shows what was computed).
pub struct AnimationWriter {
    path: PathBuf,
    geometry: SceneGeometry,
    population: Arc<Population>,
    group_of: Vec<usize>,
    title: String,
    interval: f64,
    next: f64,
    times: Vec<f64>,
    frames: Vec<Vec<Option<[i64; 2]>>>,
    offsets: Vec<Vec<[f64; 2]>>,
    /// Each frame's pressures in thousandths of m/s, when asked for.
    pressures: Option<Vec<Vec<i64>>>,
    last: Option<(f64, Vec<f64>, Option<Vec<f64>>)>,
}

impl AnimationWriter {
    /// An animation of a run over `[0, t_end]` with steps of `h`, into `path`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        path: impl Into<PathBuf>,
        geometry: SceneGeometry,
        population: Arc<Population>,
        group_of: Vec<usize>,
        title: &str,
        t_end: f64,
        h: f64,
        max_frames: usize,
    ) -> Self {
        let interval = (t_end / (max_frames.max(2) - 1) as f64).max(h);
        Self {
            path: path.into(),
            geometry,
            population,
            group_of,
            title: title.to_string(),
            interval,
            next: 0.0,
            times: Vec::new(),
            frames: Vec::new(),
            offsets: Vec::new(),
            pressures: None,
            last: None,
        }
    }

    /// Fills people by their pressure, on a scale from 0 to the largest of the run, with a
    /// legend (the run must keep its contacts,
    /// [`StepperSettings::record_contacts`](crate::stepper::StepperSettings::record_contacts)).
    #[must_use]
    pub fn with_pressure(mut self, on: bool) -> Self {
        self.pressures = on.then(Vec::new);
        self
    }

    /// Each person's pressure at the step of `r`, when asked for.
    fn pressure_of(&self, r: &StepReport) -> Option<Vec<f64>> {
        self.pressures.as_ref().map(|_| {
            let mut p = Vec::new();
            super::pressures(r, self.population.len(), &mut p);
            p
        })
    }

    fn record(&mut self, t: f64, q: &[f64], pressure: Option<&[f64]>) {
        if let Some(frames) = self.pressures.as_mut() {
            let n = self.population.len();
            frames.push(
                (0..n)
                    .map(|i| {
                        let p = pressure.and_then(|p| p.get(i).copied()).unwrap_or(0.0);
                        (p * 1000.0).round() as i64
                    })
                    .collect(),
            );
        }
        let pop = &self.population;
        let frame = (0..pop.len())
            .map(|i| {
                pop.is_present(q, i).then(|| {
                    [
                        (q[2 * i] * 1000.0).round() as i64,
                        (q[2 * i + 1] * 1000.0).round() as i64,
                    ]
                })
            })
            .collect();
        self.times.push(t);
        self.frames.push(frame);
        self.offsets.push(
            self.geometry
                .obstacles
                .iter()
                .map(|o| o.offset(t))
                .collect(),
        );
    }

    /// The page: the scene as inline SVG (`svg_scene`), the frames as JSON
    /// (`frames_json`), the group colours, and the player script (`page`).
    pub fn html(&self) -> String {
        let (unit, _, _) = frame(&self.geometry);
        let svg = self.svg_scene();
        let data = self.frames_json();
        let palette = js_string_array(&PALETTE);
        let palette_dark = js_string_array(&PALETTE_DARK);
        let title = crate::svg::escape(&self.title);
        let stroke = 0.4 * unit;
        let scale = js_string_array(&PRESSURE_SCALE);
        page(&title, &svg, &data, &palette, &palette_dark, &scale, stroke)
    }

    /// The scene's SVG: the static layer (walls, exits), one group `ob{k}` per obstacle
    /// (moved by the script) and the empty `people` group the script fills.
    fn svg_scene(&self) -> String {
        let g = &self.geometry;
        let (unit, w, h) = frame(g);
        let mut svg = String::new();
        let _ = writeln!(
            svg,
            r#"<svg id="scene" xmlns="http://www.w3.org/2000/svg" viewBox="{:.4} {:.4} {:.4} {:.4}">"#,
            g.bounds[0], -g.bounds[3], w, h
        );
        svg.push_str(&static_layer(g, unit));
        for (k, o) in g.obstacles.iter().enumerate() {
            let _ = writeln!(
                svg,
                r#"<g id="ob{k}">{}</g>"#,
                obstacle_element(&o.shape, [0.0, 0.0], unit)
            );
        }
        svg.push_str("<g id=\"people\"></g>\n</svg>\n");
        svg
    }

    /// The recorded run as JSON: times `t`, radii `r`, colour index `g` of each person's
    /// group, positions `f` per frame (in thousandths, `null` for who has left),
    /// obstacle offsets `o` per frame and, with the pressure, each frame's pressures `p` and
    /// the largest `pmax` (in thousandths of m/s).
    fn frames_json(&self) -> String {
        let mut data = String::new();
        data.push_str("{\"t\":[");
        data.push_str(&comma_separated(&self.times, |t| format!("{t:.4}")));
        data.push_str("],\"r\":[");
        data.push_str(&comma_separated(self.population.radii(), |r| {
            format!("{r:.4}")
        }));
        data.push_str("],\"g\":[");
        data.push_str(&comma_separated(0..self.population.len(), |i| {
            (self.group_of.get(i).copied().unwrap_or(0) % PALETTE.len()).to_string()
        }));
        data.push_str("],\"f\":[");
        for (k, f) in self.frames.iter().enumerate() {
            if k > 0 {
                data.push(',');
            }
            data.push('[');
            for (i, p) in f.iter().enumerate() {
                if i > 0 {
                    data.push(',');
                }
                match p {
                    Some([x, y]) => {
                        let _ = write!(data, "{x},{y}");
                    }
                    None => data.push_str("null,null"),
                }
            }
            data.push(']');
        }
        data.push_str("],\"o\":[");
        data.push_str(&comma_separated(&self.offsets, |f| {
            format!(
                "[{}]",
                comma_separated(f, |o| format!("{:.4},{:.4}", o[0], o[1]))
            )
        }));
        data.push(']');
        if let Some(frames) = &self.pressures {
            // Pressures in thousandths of m/s, per frame; `pmax` the run's largest.
            let max = frames.iter().flatten().copied().max().unwrap_or(0);
            let _ = write!(data, ",\"pmax\":{max},\"p\":[");
            data.push_str(&comma_separated(frames, |f| {
                format!("[{}]", comma_separated(f, |p| p.to_string()))
            }));
            data.push(']');
        }
        data.push('}');
        data
    }
}

/// `items` written by `write`, comma-separated: the inside of a JSON array.
fn comma_separated<T>(
    items: impl IntoIterator<Item = T>,
    write: impl FnMut(T) -> String,
) -> String {
    items.into_iter().map(write).collect::<Vec<_>>().join(",")
}

/// A JavaScript array of the given strings, quoted (the palette's colours).
fn js_string_array(colors: &[&str]) -> String {
    format!(
        "[{}]",
        colors
            .iter()
            .map(|c| format!("\"{c}\""))
            .collect::<Vec<_>>()
            .join(",")
    )
}

/// The HTML page around `svg` and the frame data: style, controls (play/pause, time
/// slider, speed) and the player script; `stroke` is the people's outline width.
fn page(
    title: &str,
    svg: &str,
    data: &str,
    palette: &str,
    palette_dark: &str,
    scale: &str,
    stroke: f64,
) -> String {
    format!(
        r##"<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{title}</title>
<style>
  body {{ font-family: Helvetica, Arial, sans-serif; margin: 1.5em auto; max-width: 900px; color: #222; }}
  h1 {{ font-size: 1.3em; font-weight: 600; margin: 0 0 .5em 0; }}
  #scene {{ width: 100%; max-height: 75vh; background: white; border: 1px solid #ddd; }}
  .controls {{ display: flex; gap: .8em; align-items: center; margin-top: .6em; }}
  .controls input[type=range] {{ flex: 1; }}
  button {{ font-size: 1em; padding: .3em .9em; min-width: 6em; }}
  #label {{ font-variant-numeric: tabular-nums; min-width: 15em; }}
  .legend {{ color: #666; font-size: .9em; margin-top: .4em; }}
  #pressure {{ display: none; align-items: center; gap: .5em; color: #444; font-size: .9em; margin-top: .4em; }}
  #pressure .bar {{ width: 12em; height: .9em; border: 1px solid #888; }}
</style>
</head>
<body>
<h1>{title}</h1>
{svg}<div class="controls">
  <button id="play">▶ Play</button>
  <input type="range" id="slider" min="0" value="0">
  <span id="label"></span>
  <label>speed <select id="speed"><option>0.25</option><option>0.5</option><option selected>1</option><option>2</option><option>5</option><option>10</option></select></label>
</div>
<div id="pressure">pressure (sum of contact forces) 0 <span class="bar"></span> <span id="pmax"></span> m/s</div>
<div class="legend">Walls in black, exits dashed green, obstacles grey; people who have left are not drawn. Space: play/pause; ←/→: step.</div>
<script>
const D = {data};
const PAL = {palette}, PALD = {palette_dark}, SCALE = {scale};
function hex(c) {{ const v = parseInt(c.slice(1), 16); return [v >> 16 & 255, v >> 8 & 255, v & 255]; }}
function pressureColour(p) {{
  const s = D.pmax > 0 ? Math.min(Math.max(p / D.pmax, 0), 1) : 0;
  const x = s * (SCALE.length - 1), k = Math.min(Math.floor(x), SCALE.length - 2), w = x - k;
  const a = hex(SCALE[k]), b = hex(SCALE[k + 1]);
  return "rgb(" + a.map((v, i) => Math.round(v + w * (b[i] - v))).join(",") + ")";
}}
if (D.p) {{
  const box = document.getElementById("pressure");
  box.style.display = "flex";
  box.querySelector(".bar").style.background = "linear-gradient(to right," + SCALE.join(",") + ")";
  document.getElementById("pmax").textContent = (D.pmax / 1000).toFixed(3);
}}
const NS = "http://www.w3.org/2000/svg";
const layer = document.getElementById("people");
const circles = D.r.map((r, i) => {{
  const c = document.createElementNS(NS, "circle");
  c.setAttribute("r", r);
  c.setAttribute("fill", PAL[D.g[i]]);
  c.setAttribute("stroke", PALD[D.g[i]]);
  c.setAttribute("stroke-width", {stroke:.4});
  layer.appendChild(c);
  return c;
}});
const obs = D.o.length ? D.o[0].length / 2 : 0;
const slider = document.getElementById("slider"), label = document.getElementById("label");
const button = document.getElementById("play"), speed = document.getElementById("speed");
slider.max = D.t.length - 1;
let k = 0, playing = false, simT = D.t[0], last = null;
function show(i) {{
  k = i; slider.value = i;
  const f = D.f[i];
  let inside = 0;
  for (let p = 0; p < circles.length; p++) {{
    const x = f[2 * p], y = f[2 * p + 1];
    if (x === null) {{ circles[p].setAttribute("display", "none"); continue; }}
    inside++;
    circles[p].setAttribute("display", "inline");
    if (D.p) circles[p].setAttribute("fill", pressureColour(D.p[i][p]));
    circles[p].setAttribute("cx", x / 1000);
    circles[p].setAttribute("cy", -y / 1000);
  }}
  for (let o = 0; o < obs; o++) {{
    document.getElementById("ob" + o).setAttribute("transform",
      "translate(" + D.o[i][2 * o] + "," + (-D.o[i][2 * o + 1]) + ")");
  }}
  label.textContent = "t = " + D.t[i].toFixed(2) + " s   in the room: " + inside + " / " + circles.length;
}}
function tick(now) {{
  if (!playing) return;
  if (last !== null) simT += (now - last) / 1000 * parseFloat(speed.value);
  last = now;
  let i = k;
  while (i + 1 < D.t.length && D.t[i + 1] <= simT) i++;
  show(i);
  if (i + 1 >= D.t.length) {{ setPlaying(false); return; }}
  requestAnimationFrame(tick);
}}
function setPlaying(p) {{
  playing = p;
  button.textContent = p ? "❚❚ Pause" : "▶ Play";
  if (p) {{
    if (k + 1 >= D.t.length) show(0);
    simT = D.t[k]; last = null; requestAnimationFrame(tick);
  }}
}}
button.onclick = () => setPlaying(!playing);
slider.oninput = () => {{ show(parseInt(slider.value)); simT = D.t[k]; last = null; }};
document.addEventListener("keydown", e => {{
  if (e.key === " ") {{ e.preventDefault(); setPlaying(!playing); }}
  if (e.key === "ArrowRight") {{ show(Math.min(k + 1, D.t.length - 1)); simT = D.t[k]; }}
  if (e.key === "ArrowLeft") {{ show(Math.max(k - 1, 0)); simT = D.t[k]; }}
}});
show(0);
</script>
</body>
</html>
"##
    )
}

impl Observer for AnimationWriter {
    fn name(&self) -> &str {
        "animation writer"
    }

    fn on_start(&mut self, t: f64, q: &[f64]) -> Result<(), ObserverError> {
        self.record(t, q, None);
        self.next = t + self.interval;
        Ok(())
    }

    fn on_step(&mut self, r: &StepReport, q: &[f64]) -> Result<(), ObserverError> {
        let pressure = self.pressure_of(r);
        if r.t >= self.next - 1e-9 * self.next.abs().max(1.0) {
            self.record(r.t, q, pressure.as_deref());
            self.last = None;
            self.next = super::next_time_after(self.next, self.interval, r.t);
        } else {
            self.last = Some((r.t, q.to_vec(), pressure));
        }
        Ok(())
    }

    fn on_finish(&mut self, _error: Option<&SweepError>) -> Result<(), ObserverError> {
        if let Some((t, q, pressure)) = self.last.take() {
            self.record(t, &q, pressure.as_deref());
        }
        super::write_whole(&self.path, self.html())
            .map_err(|e| format!("{}: {e}", self.path.display()).into())
    }
}
