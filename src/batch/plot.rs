//! An output of the results table against a parameter, as SVG: each trial a dot, and per
//! value of the parameter the mean over the trials that share it (the seeds) with one standard
//! deviation either side; one series per combination of the other parameters.
//!
//! Written directly, as the study plots are (`study::plot`): SVG text is laid out by the
//! viewer, so no font is needed on the machine that draws it.

use super::{BatchError, PlotBand, PlotSpec, ResultsTable};
use crate::svg::{escape, PALETTE};
use std::collections::BTreeMap;
use std::fmt::Write as _;

const WIDTH: f64 = 900.0;
const HEIGHT: f64 = 600.0;
const LEFT: f64 = 90.0;
const RIGHT: f64 = 30.0;
const TOP: f64 = 70.0;
const BOTTOM: f64 = 60.0;

/// What the output on the vertical axis is divided by.
#[derive(Clone, Copy)]
enum Divisor<'a> {
    /// Another output of the trial.
    Output(&'a str),
    /// A parameter: its name and column.
    Parameter(&'a str, usize),
}

/// The mean and spread of the trials at one value of the parameter.
#[derive(Debug, Clone, PartialEq)]
struct Point {
    x: f64,
    mean: f64,
    /// Sample standard deviation (0 for one trial).
    sd: f64,
    n: usize,
}

/// `values`' mean and sample standard deviation.
fn mean_sd(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    if values.len() < 2 {
        return (mean, 0.0);
    }
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

/// Ticks at 1-2-5 steps over `[lo, hi]`.
fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let raw = (hi - lo) / 8.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

fn label(v: f64) -> String {
    let s = format!("{:.6}", v);
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// The range `[lo, hi]` of `values` widened by 5 % (a single value, by 1 or 10 % of it).
fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if hi > lo {
        let pad = 0.05 * (hi - lo);
        (lo - pad, hi + pad)
    } else {
        let pad = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
        (lo - pad, hi + pad)
    }
}

/// Draws `plot.y` (an output, or an output divided by a parameter or another output) against
/// parameter `plot.x` (a column of the table: a parameter or `seed`) of the trials that have
/// both, over `plot.band` when it has one.
///
/// # Errors
/// [`BatchError::Plot`] when `x` or the divisor is not a column, a trial's `x` or divisor is
/// not a number, or no trial has both.
pub fn plot_svg(table: &ResultsTable, plot: &PlotSpec) -> Result<String, BatchError> {
    let (x, y) = (plot.x.as_str(), plot.y.as_str());
    let column = if x == "seed" {
        None
    } else {
        Some(
            table
                .parameters
                .iter()
                .position(|p| p == x)
                .ok_or_else(|| {
                    BatchError::Plot(format!("`{x}` is not a parameter of the table"))
                })?,
        )
    };
    let (output, per) = plot.y_terms();
    if !super::OUTPUTS.contains(&output) {
        return Err(BatchError::Plot(format!(
            "`{output}` is not an output of the table"
        )));
    }
    let per = match per {
        None => None,
        Some(p) if super::OUTPUTS.contains(&p) => Some(Divisor::Output(p)),
        Some(p) => Some(Divisor::Parameter(
            p,
            table
                .parameters
                .iter()
                .position(|q| q == p)
                .ok_or_else(|| {
                    BatchError::Plot(format!(
                        "`{p}` is neither a parameter nor an output of the table"
                    ))
                })?,
        )),
    };
    // The trial's value of y: its output, over the divisor's value (none where that is 0).
    let y_of = |row: &super::ResultsRow| -> Result<Option<f64>, BatchError> {
        let Some(v) = row.output(output) else {
            return Ok(None);
        };
        let d = match per {
            None => return Ok(Some(v)),
            Some(Divisor::Output(o)) => row.output(o),
            Some(Divisor::Parameter(p, c)) => match &row.parameters[c] {
                None => None,
                Some(text) => Some(text.trim().parse::<f64>().map_err(|_| {
                    BatchError::Plot(format!(
                        "trial {}: {p} = {text} is not a number to divide {output} by",
                        row.trial
                    ))
                })?),
            },
        };
        Ok(d.filter(|d| *d != 0.0).map(|d| v / d))
    };
    let x_of = |row: &super::ResultsRow| match column {
        None => row.seed.map(|s| s.to_string()),
        Some(c) => row.parameters[c].clone(),
    };
    // A column splits the trials into series only where it varies at one value of x: one
    // that moves with x (a door's ends, with its width as x) is the same series.
    let varies_at_one_x = |value: &dyn Fn(&super::ResultsRow) -> Option<String>| {
        let mut seen: BTreeMap<Option<String>, Option<String>> = BTreeMap::new();
        table
            .rows
            .iter()
            .any(|r| *seen.entry(x_of(r)).or_insert_with(|| value(r)) != value(r))
    };
    let several_scenes = varies_at_one_x(&|r| Some(r.scene.clone()));
    let splitting: Vec<bool> = (0..table.parameters.len())
        .map(|c| Some(c) != column && varies_at_one_x(&|r| r.parameters[c].clone()))
        .collect();
    // series label → x → the trials' values.
    let mut series: BTreeMap<String, BTreeMap<u64, Vec<f64>>> = BTreeMap::new();
    let mut dots: Vec<(String, f64, f64)> = Vec::new();
    let mut left_out = 0;
    for row in &table.rows {
        let xv = x_of(row);
        let (Some(xv), Some(yv)) = (xv, y_of(row)?) else {
            left_out += 1;
            continue;
        };
        let xv: f64 = xv.trim().parse().map_err(|_| {
            BatchError::Plot(format!(
                "trial {}: {x} = {xv} is not a number (tag the trials with a number to plot against, `tags = {{ width = 1.2 }}`)",
                row.trial
            ))
        })?;
        let mut others: Vec<String> = Vec::new();
        if several_scenes {
            others.push(row.scene.clone());
        }
        for ((p, v), split) in table.parameters.iter().zip(&row.parameters).zip(&splitting) {
            if let (true, Some(v)) = (split, v) {
                others.push(format!("{p} = {v}"));
            }
        }
        let name = others.join(", ");
        series
            .entry(name.clone())
            .or_default()
            .entry(xv.to_bits())
            .or_default()
            .push(yv);
        dots.push((name, xv, yv));
    }
    if dots.is_empty() {
        return Err(BatchError::Plot(format!(
            "no trial has both {x} and {y} (trials not run, failed before running, or without an evacuation)"
        )));
    }
    let lines: Vec<(String, Vec<Point>)> = series
        .into_iter()
        .map(|(name, by_x)| {
            let mut points: Vec<Point> = by_x
                .into_iter()
                .map(|(bits, ys)| {
                    let (mean, sd) = mean_sd(&ys);
                    Point {
                        x: f64::from_bits(bits),
                        mean,
                        sd,
                        n: ys.len(),
                    }
                })
                .collect();
            points.sort_by(|a, b| a.x.total_cmp(&b.x));
            (name, points)
        })
        .collect();
    Ok(draw(&lines, &dots, x, y, plot.band.as_ref(), left_out))
}

fn draw(
    lines: &[(String, Vec<Point>)],
    dots: &[(String, f64, f64)],
    x: &str,
    y: &str,
    band: Option<&PlotBand>,
    left_out: usize,
) -> String {
    let (x0, x1) = range(dots.iter().map(|d| d.1));
    let (y0, y1) = range(
        dots.iter()
            .map(|d| d.2)
            .chain(
                lines
                    .iter()
                    .flat_map(|(_, p)| p.iter().flat_map(|p| [p.mean - p.sd, p.mean + p.sd])),
            )
            .chain(band.into_iter().flat_map(|b| [b.from, b.to])),
    );
    let px = |v: f64| LEFT + (v - x0) / (x1 - x0) * (WIDTH - LEFT - RIGHT);
    let py = |v: f64| HEIGHT - BOTTOM - (v - y0) / (y1 - y0) * (HEIGHT - TOP - BOTTOM);
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" viewBox="0 0 {WIDTH} {HEIGHT}" font-family="sans-serif" font-size="13">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let most = lines
        .iter()
        .flat_map(|(_, p)| p.iter().map(|p| p.n))
        .max()
        .unwrap_or(1);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="24" text-anchor="middle" font-size="16">{} against {}</text>"#,
        WIDTH / 2.0,
        escape(y),
        escape(x)
    );
    let note = if left_out > 0 {
        format!("; {left_out} trial(s) without a value left out")
    } else {
        String::new()
    };
    let _ = writeln!(
        s,
        r##"<text x="{}" y="44" text-anchor="middle" fill="#555">dots: trials; line: mean, bars: ± one standard deviation (up to {most} trials per value){}</text>"##,
        WIDTH / 2.0,
        escape(&note)
    );
    let (bx, by, bw, bh) = (LEFT, TOP, WIDTH - LEFT - RIGHT, HEIGHT - TOP - BOTTOM);
    let _ = writeln!(
        s,
        r#"<rect x="{bx}" y="{by}" width="{bw}" height="{bh}" fill="none" stroke="black"/>"#
    );
    if let Some(b) = band {
        let (top, bottom) = (py(b.to), py(b.from));
        let _ = writeln!(
            s,
            r##"<rect x="{bx}" y="{top:.1}" width="{bw}" height="{:.1}" fill="#2ca02c" fill-opacity="0.15"/><text x="{:.1}" y="{:.1}" fill="#2a7a2a">{}</text>"##,
            bottom - top,
            bx + 8.0,
            top + 16.0,
            escape(&b.label)
        );
    }
    for t in ticks(x0, x1) {
        let _ = writeln!(
            s,
            r##"<line x1="{0:.1}" y1="{1}" x2="{0:.1}" y2="{2}" stroke="#ddd"/><text x="{0:.1}" y="{3}" text-anchor="middle">{4}</text>"##,
            px(t),
            TOP,
            HEIGHT - BOTTOM,
            HEIGHT - BOTTOM + 18.0,
            label(t)
        );
    }
    for t in ticks(y0, y1) {
        let _ = writeln!(
            s,
            r##"<line x1="{1}" y1="{0:.1}" x2="{2}" y2="{0:.1}" stroke="#ddd"/><text x="{3}" y="{4:.1}" text-anchor="end">{5}</text>"##,
            py(t),
            LEFT,
            WIDTH - RIGHT,
            LEFT - 6.0,
            py(t) + 4.0,
            label(t)
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
        LEFT + bw / 2.0,
        HEIGHT - 15.0,
        escape(x)
    );
    let _ = writeln!(
        s,
        r#"<text x="20" y="{0}" text-anchor="middle" transform="rotate(-90 20 {0})">{1}</text>"#,
        TOP + bh / 2.0,
        escape(y)
    );
    for (k, (name, points)) in lines.iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        for (n, dx, dy) in dots {
            if n == name {
                let _ = writeln!(
                    s,
                    r#"<circle cx="{:.1}" cy="{:.1}" r="2.5" fill="{color}" fill-opacity="0.35"/>"#,
                    px(*dx),
                    py(*dy)
                );
            }
        }
        let path: Vec<String> = points
            .iter()
            .map(|p| format!("{:.1},{:.1}", px(p.x), py(p.mean)))
            .collect();
        let _ = writeln!(
            s,
            r#"<polyline points="{}" fill="none" stroke="{color}" stroke-width="2"/>"#,
            path.join(" ")
        );
        for p in points {
            let (cx, lo, hi) = (px(p.x), py(p.mean - p.sd), py(p.mean + p.sd));
            let _ = writeln!(
                s,
                r#"<g stroke="{color}"><line x1="{cx:.1}" y1="{lo:.1}" x2="{cx:.1}" y2="{hi:.1}"/><line x1="{:.1}" y1="{lo:.1}" x2="{:.1}" y2="{lo:.1}"/><line x1="{:.1}" y1="{hi:.1}" x2="{:.1}" y2="{hi:.1}"/></g><circle cx="{cx:.1}" cy="{:.1}" r="4" fill="{color}"><title>{} = {}: mean {} ± {} over {} trial(s)</title></circle>"#,
                cx - 5.0,
                cx + 5.0,
                cx - 5.0,
                cx + 5.0,
                py(p.mean),
                escape(x),
                label(p.x),
                label(p.mean),
                label(p.sd),
                p.n
            );
        }
        if !name.is_empty() {
            let ly = TOP + 18.0 + 18.0 * k as f64;
            let _ = writeln!(
                s,
                r#"<line x1="{0}" y1="{1}" x2="{2}" y2="{1}" stroke="{color}" stroke-width="2"/><text x="{3}" y="{4}" text-anchor="end">{5}</text>"#,
                WIDTH - RIGHT - 30.0,
                ly,
                WIDTH - RIGHT - 10.0,
                WIDTH - RIGHT - 36.0,
                ly + 4.0,
                escape(name)
            );
        }
    }
    s.push_str("</svg>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_sample_sd_of_known_values() {
        let (m, sd) = mean_sd(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]);
        assert_eq!(m, 5.0);
        // Sum of squares 32 over n − 1 = 7.
        assert!((sd - (32.0f64 / 7.0).sqrt()).abs() < 1e-15);
        assert_eq!(mean_sd(&[3.0]), (3.0, 0.0));
    }

    /// A table of one parameter `w` whose trials have `people_out` people out at `t_final`.
    fn table(rows: &[(&str, f64, usize)]) -> ResultsTable {
        let rows = rows
            .iter()
            .enumerate()
            .map(|(trial, &(w, t_final, out))| super::super::ResultsRow {
                trial,
                scene: "room.toml".into(),
                seed: Some(trial as u64),
                parameters: vec![Some(w.to_string())],
                status: "completed".into(),
                error: None,
                summary: Some(crate::output::RunSummary {
                    people: out,
                    t_final,
                    ..Default::default()
                }),
                wall_seconds: None,
                dir: String::new(),
            })
            .collect();
        ResultsTable {
            parameters: vec!["w".into()],
            rows,
        }
    }

    fn spec(y: &str, band: Option<PlotBand>) -> PlotSpec {
        PlotSpec {
            x: "w".into(),
            y: y.into(),
            band,
        }
    }

    #[test]
    fn an_output_over_a_parameter_is_plotted_per_trial() {
        let t = table(&[("1", 4.0, 4), ("2", 8.0, 4), ("2", 6.0, 4)]);
        let svg = plot_svg(&t, &spec("people / w", None)).unwrap();
        // Means of 4/1 and of (4/2, 4/2); of t_final over people, 1 and (1, 0.75).
        assert!(
            svg.contains("<title>w = 1: mean 4 ± 0 over 1 trial(s)</title>"),
            "{svg}"
        );
        assert!(
            svg.contains("<title>w = 2: mean 2 ± 0 over 2 trial(s)</title>"),
            "{svg}"
        );
        let svg = plot_svg(&t, &spec("t_final / people", None)).unwrap();
        assert!(svg.contains("w = 2: mean 1.75 ±"), "{svg}");
        // A zero divisor leaves the trial out.
        let t = table(&[("0", 4.0, 4), ("2", 8.0, 4)]);
        let svg = plot_svg(&t, &spec("people / w", None)).unwrap();
        assert!(svg.contains("1 trial(s) without a value left out"), "{svg}");
        // A divisor that is not a column.
        let e = plot_svg(&t, &spec("people / width", None)).unwrap_err();
        assert!(e.to_string().contains("`width` is neither"), "{e}");
    }

    #[test]
    fn a_band_is_drawn_and_the_axis_reaches_it() {
        let t = table(&[("1", 4.0, 4), ("2", 8.0, 4)]);
        let band = PlotBand {
            from: 10.0,
            to: 12.0,
            label: "experiments <2009>".into(),
        };
        let svg = plot_svg(&t, &spec("t_final", Some(band))).unwrap();
        assert!(svg.contains("experiments &lt;2009&gt;</text>"), "{svg}");
        assert!(svg.contains(r#"fill-opacity="0.15""#), "{svg}");
        // The vertical axis runs from the lowest value (4) to the band's top (12).
        assert!(
            svg.contains(">12</text>") && svg.contains(">4</text>"),
            "{svg}"
        );
        assert!(!plot_svg(&t, &spec("t_final", None))
            .unwrap()
            .contains("fill-opacity=\"0.15\""));
    }

    #[test]
    fn ticks_are_round_and_inside_the_range() {
        assert_eq!(ticks(0.75, 2.45), vec![1.0, 1.5, 2.0]);
        assert_eq!(ticks(0.0, 100.0), vec![0.0, 20.0, 40.0, 60.0, 80.0, 100.0]);
        assert_eq!(ticks(-3.0, 3.0), vec![-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0]);
    }
}
