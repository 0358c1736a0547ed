//! Log–log plots of studies, as SVG.
//!
//! The SVG is written directly (axes, decade ticks, points, fitted lines, legend) rather than
//! through `plotters`: `plotters` lays text out with font metrics and fails without a
//! registered font file, whereas an SVG `<text>` element is laid out by the viewer, so these
//! plots need no font on the machine that draws them.

use super::{OrderFit, StudyError};
use crate::svg::{escape, PALETTE};
use std::fmt::Write as _;
use std::path::Path;

/// One set of points of a log–log plot, with its fitted power law.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend.
    pub label: String,
    /// `(x, y)`, both positive (others are skipped).
    pub points: Vec<(f64, f64)>,
    /// A fitted `y = C x^p`, drawn as a line over the points' range, with `p` in the legend.
    pub fit: Option<OrderFit>,
}

const WIDTH: f64 = 900.0;
const HEIGHT: f64 = 650.0;
const LEFT: f64 = 90.0;
const RIGHT: f64 = 30.0;
const TOP: f64 = 50.0;
const BOTTOM: f64 = 60.0;

fn positive(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
        .collect()
}

/// Tick values for a log axis over `[lo, hi]`: every decade, or 1-2-5 steps when the range
/// spans less than two decades.
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let (a, b) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let mults: &[f64] = if b - a <= 2 { &[1.0, 2.0, 5.0] } else { &[1.0] };
    let mut out = Vec::new();
    for e in a..=b {
        for m in mults {
            let v = m * 10f64.powi(e);
            if v >= lo * (1.0 - 1e-12) && v <= hi * (1.0 + 1e-12) {
                out.push(v);
            }
        }
    }
    out
}

fn tick_label(v: f64) -> String {
    let e = v.log10();
    if (-3.0..=3.0).contains(&e) {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

/// Draws `series` on log–log axes into the SVG file `path`; with `reference_slope`, adds a
/// dashed line of that slope through the geometric centre of the first series.
///
/// # Errors
/// [`StudyError::Plot`] when there is nothing positive to draw, and [`StudyError::Io`] when
/// the file cannot be written.
pub fn log_log(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    reference_slope: Option<f64>,
) -> Result<(), StudyError> {
    let all: Vec<(f64, f64)> = series.iter().flat_map(|s| positive(&s.points)).collect();
    if all.is_empty() {
        return Err(StudyError::Plot {
            path: path.to_path_buf(),
            message: "no positive points to draw".into(),
        });
    }
    let frame = Frame::around(&all);
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" viewBox="0 0 {WIDTH} {HEIGHT}" font-family="sans-serif">"#
    );
    let _ = writeln!(svg, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        svg,
        r#"<text x="{}" y="30" font-size="20" text-anchor="middle">{}</text>"#,
        WIDTH / 2.0,
        escape(title)
    );
    frame.draw_axes(&mut svg, x_label, y_label);
    let mut legend = frame.draw_series(&mut svg, series);
    if let (Some(p), Some(first)) = (reference_slope, series.first()) {
        let pts = positive(&first.points);
        if !pts.is_empty() {
            let n = pts.len() as f64;
            let gx = (pts.iter().map(|(x, _)| x.ln()).sum::<f64>() / n).exp();
            let gy = (pts.iter().map(|(_, y)| y.ln()).sum::<f64>() / n).exp();
            let (x0, x1) = (frame.x0, frame.x1);
            let line = [(x0, gy * (x0 / gx).powf(p)), (x1, gy * (x1 / gx).powf(p))];
            let _ = writeln!(
                svg,
                "{}",
                frame.polyline(
                    &line,
                    "#777",
                    r#"stroke-dasharray="8 6" stroke-width="1.5""#
                )
            );
            legend.push((format!("slope {p} (reference)"), "#777".into(), true));
        }
    }
    frame.draw_legend(&mut svg, &legend);
    svg.push_str("</svg>\n");
    super::write_file(path, &svg)
}

/// A legend entry: label, colour, dashed line (else a dot).
type LegendEntry = (String, String, bool);

/// The plotting area and its log–log ranges.
struct Frame {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    pw: f64,
    ph: f64,
}

impl Frame {
    fn around(points: &[(f64, f64)]) -> Frame {
        let (x0, x1, y0, y1) = points.iter().fold(
            (f64::INFINITY, 0.0f64, f64::INFINITY, 0.0f64),
            |(a, b, c, d), (x, y)| (a.min(*x), b.max(*x), c.min(*y), d.max(*y)),
        );
        // Pad in log space so that points sit inside the frame (and a single point has a range).
        Frame {
            x0: x0 / 1.25,
            x1: x1 * 1.25,
            y0: y0 / 1.6,
            y1: y1 * 1.6,
            pw: WIDTH - LEFT - RIGHT,
            ph: HEIGHT - TOP - BOTTOM,
        }
    }

    fn px(&self, x: f64) -> f64 {
        LEFT + (x.ln() - self.x0.ln()) / (self.x1.ln() - self.x0.ln()) * self.pw
    }

    fn py(&self, y: f64) -> f64 {
        TOP + (self.y1.ln() - y.ln()) / (self.y1.ln() - self.y0.ln()) * self.ph
    }

    fn polyline(&self, pts: &[(f64, f64)], color: &str, extra: &str) -> String {
        let coords: Vec<String> = pts
            .iter()
            .map(|&(x, y)| {
                format!(
                    "{:.1},{:.1}",
                    self.px(x),
                    self.py(y.clamp(self.y0, self.y1))
                )
            })
            .collect();
        format!(
            r#"<polyline points="{}" fill="none" stroke="{color}" {extra}/>"#,
            coords.join(" ")
        )
    }

    /// Grid, ticks, tick labels, the frame and the axis labels.
    fn draw_axes(&self, svg: &mut String, x_label: &str, y_label: &str) {
        let (pw, ph) = (self.pw, self.ph);
        for v in log_ticks(self.x0, self.x1) {
            let x = self.px(v);
            let _ = writeln!(
                svg,
                r##"<line x1="{x:.1}" y1="{TOP}" x2="{x:.1}" y2="{:.1}" stroke="#ddd"/><text x="{x:.1}" y="{:.1}" font-size="13" text-anchor="middle">{}</text>"##,
                TOP + ph,
                TOP + ph + 18.0,
                tick_label(v)
            );
        }
        for v in log_ticks(self.y0, self.y1) {
            let y = self.py(v);
            let _ = writeln!(
                svg,
                r##"<line x1="{LEFT}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" font-size="13" text-anchor="end">{}</text>"##,
                LEFT + pw,
                LEFT - 6.0,
                y + 4.0,
                tick_label(v)
            );
        }
        let _ = writeln!(
            svg,
            r#"<rect x="{LEFT}" y="{TOP}" width="{pw}" height="{ph}" fill="none" stroke="black"/>"#
        );
        let _ = writeln!(
            svg,
            r#"<text x="{:.1}" y="{:.1}" font-size="15" text-anchor="middle">{} (log scale)</text>"#,
            LEFT + pw / 2.0,
            HEIGHT - 15.0,
            escape(x_label)
        );
        let _ = writeln!(
            svg,
            r#"<text x="20" y="{:.1}" font-size="15" text-anchor="middle" transform="rotate(-90 20 {:.1})">{} (log scale)</text>"#,
            TOP + ph / 2.0,
            TOP + ph / 2.0,
            escape(y_label)
        );
    }

    /// Each series' points and fitted line; returns their legend entries.
    fn draw_series(&self, svg: &mut String, series: &[Series]) -> Vec<LegendEntry> {
        let mut legend = Vec::new();
        for (k, s) in series.iter().enumerate() {
            let color = PALETTE[k % PALETTE.len()];
            let pts = positive(&s.points);
            for &(x, y) in &pts {
                let _ = writeln!(
                    svg,
                    r#"<circle cx="{:.1}" cy="{:.1}" r="5" fill="{color}"/>"#,
                    self.px(x),
                    self.py(y)
                );
            }
            if let Some(f) = s.fit {
                let (a, b) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), (x, _)| {
                    (a.min(*x), b.max(*x))
                });
                if a < b {
                    let line = [(a, f.predict(a)), (b, f.predict(b))];
                    let _ = writeln!(
                        svg,
                        "{}",
                        self.polyline(&line, color, r#"stroke-width="2""#)
                    );
                }
            }
            let label = match s.fit {
                Some(f) => format!("{} — fitted slope {:.2}", s.label, f.order),
                None => s.label.clone(),
            };
            legend.push((label, color.to_string(), false));
        }
        legend
    }

    /// The legend, lower right.
    fn draw_legend(&self, svg: &mut String, legend: &[LegendEntry]) {
        let lw = 20.0
            + 8.0
                * legend
                    .iter()
                    .map(|(l, _, _)| l.chars().count())
                    .max()
                    .unwrap_or(0) as f64;
        let lh = 22.0 * legend.len() as f64 + 8.0;
        let (lx, ly) = (LEFT + self.pw - lw - 10.0, TOP + self.ph - lh - 10.0);
        let _ = writeln!(
            svg,
            r#"<rect x="{lx:.1}" y="{ly:.1}" width="{lw:.1}" height="{lh:.1}" fill="white" fill-opacity="0.85" stroke="black"/>"#
        );
        for (i, (label, color, dashed)) in legend.iter().enumerate() {
            let y = ly + 18.0 + 22.0 * i as f64;
            if *dashed {
                let _ = writeln!(
                    svg,
                    r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{color}" stroke-dasharray="6 4"/>"#,
                    lx + 6.0,
                    y - 4.0,
                    lx + 24.0,
                    y - 4.0
                );
            } else {
                let _ = writeln!(
                    svg,
                    r#"<circle cx="{:.1}" cy="{:.1}" r="5" fill="{color}"/>"#,
                    lx + 15.0,
                    y - 4.0
                );
            }
            let _ = writeln!(
                svg,
                r#"<text x="{:.1}" y="{y:.1}" font-size="13">{}</text>"#,
                lx + 30.0,
                escape(label)
            );
        }
    }
}
