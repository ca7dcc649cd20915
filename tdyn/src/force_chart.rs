//! The force-displacement chart of `tdyn plot DIR --force NAME --displacement PROBE`: a
//! constraint's or a contact pair's force (reactions.csv, contact_forces.csv) against a probe's
//! displacement (probes.csv), row by row. The three files have the same rows (docs/output.md),
//! so row k of each is the same step.
//!
//! `NAME` is a column stem (`wall`, `plate-projectile`) or a whole column (`wall.force_z`);
//! `PROBE` a probe name (`gauge`) or a whole column (`gauge.displacement_z`). A bare stem takes
//! the component whose largest magnitude over the run is largest. Each series is drawn with
//! the sign of its largest-magnitude value made positive (a crush force against a crush
//! distance), and the chart's axis labels say so.
use crate::chart::{self, Figure};
use plotters::coord::Shift;
use plotters::prelude::{DrawingArea, DrawingBackend};
use std::path::{Path, PathBuf};

/// Chart size, pixels.
const SIZE: (u32, u32) = (1000, 700);

/// The file names, in the output folder.
pub const STEM: &str = "force_displacement";

/// The room around the plot, pixels.
const FRAME: chart::Frame = chart::Frame {
    margin: 20,
    x_labels: 50,
    y_labels: 90,
};

/// A CSV file's header and its rows of numbers (`#` lines skipped).
use crate::csv::Table;

fn read_table(path: &Path) -> Result<Table, String> {
    Table::read(path)
}

/// The column `name` of `t`, or of the columns `name.<kind>_{x,y,z}` the one whose largest
/// magnitude is largest. `Err` naming the columns there are.
fn pick(t: &Table, file: &str, name: &str, kind: &str) -> Result<(String, Vec<f64>), String> {
    let col = |j: usize| -> Vec<f64> { t.at(j) };
    let of_kind = |h: &str| {
        ["x", "y", "z"]
            .iter()
            .any(|c| h.ends_with(&format!(".{kind}_{c}")))
    };
    if let Some(j) = t.header.iter().position(|h| h == name) {
        if !of_kind(name) {
            let names: Vec<&str> = t
                .header
                .iter()
                .map(String::as_str)
                .filter(|h| of_kind(h))
                .collect();
            return Err(format!(
                "{file}: {name} is not a {kind} column (<name>.{kind}_{{x,y,z}}); its {kind} columns: {}",
                if names.is_empty() { "none".to_string() } else { names.join(", ") }
            ));
        }
        return Ok((name.to_string(), col(j)));
    }
    let mut best: Option<(f64, String, Vec<f64>)> = None;
    for c in ["x", "y", "z"] {
        let h = format!("{name}.{kind}_{c}");
        if let Some(j) = t.header.iter().position(|x| *x == h) {
            let v = col(j);
            let peak = v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
            if best.as_ref().is_none_or(|b| peak > b.0) {
                best = Some((peak, h, v));
            }
        }
    }
    best.map(|(_, h, v)| (h, v)).ok_or_else(|| {
        let names: Vec<&str> = t.header.iter().skip(1).map(String::as_str).collect();
        let there = if names.is_empty() {
            // reactions.csv of a scene without supports or walls, probes.csv without probes
            "it has no column but time".to_string()
        } else {
            format!("its columns: {}", names.join(", "))
        };
        format!("{file}: no column {name} or {name}.{kind}_{{x,y,z}}; {there}")
    })
}

/// `v` times the sign of its largest-magnitude value (so that value is positive), and whether
/// it was flipped.
fn positive(v: Vec<f64>) -> (Vec<f64>, bool) {
    let peak = v
        .iter()
        .copied()
        .fold(0.0f64, |a, x| if x.abs() > a.abs() { x } else { a });
    if peak < 0.0 {
        (v.into_iter().map(|x| -x).collect(), true)
    } else {
        (v, false)
    }
}

/// The chart's two series.
struct ForceChart {
    title: String,
    x_desc: String,
    y_desc: String,
    points: Vec<(f64, f64)>,
}

/// Reads the force `force` (reactions.csv, else contact_forces.csv) and the displacement
/// `displacement` (probes.csv) of the run in `dir`, draws force_displacement.png and .svg
/// there. Returns the PNG's path.
pub fn plot(dir: &Path, force: &str, displacement: &str) -> Result<PathBuf, String> {
    let mut found = None;
    let mut tried = Vec::new();
    for file in ["reactions.csv", "contact_forces.csv"] {
        let path = dir.join(file);
        if !path.exists() {
            tried.push(format!("{file}: not in {}", dir.display()));
            continue;
        }
        match pick(&read_table(&path)?, file, force, "force") {
            Ok(c) => {
                found = Some(c);
                break;
            }
            Err(e) => tried.push(e),
        }
    }
    let (f_name, f) = found.ok_or_else(|| format!("--force {force}: {}", tried.join("; ")))?;
    let probes = read_table(&dir.join("probes.csv"))?;
    let (d_name, d) = pick(&probes, "probes.csv", displacement, "displacement")
        .map_err(|e| format!("--displacement {displacement}: {e}"))?;
    if d.len() != f.len() {
        return Err(format!(
            "probes.csv has {} rows and the force's file {}: not the same run's",
            d.len(),
            f.len()
        ));
    }
    let (f, f_flip) = positive(f);
    let (d, d_flip) = positive(d);
    let (f_scale, f_prefix) = chart::si_prefix(f.iter().fold(0.0f64, |a, x| a.max(x.abs())));
    let (d_scale, d_prefix) = chart::si_prefix(d.iter().fold(0.0f64, |a, x| a.max(x.abs())));
    let sign = |flip: bool| if flip { "-" } else { "" };
    let fig = ForceChart {
        title: format!("{}: force against displacement", dir.display()),
        x_desc: format!("{}{d_name} ({d_prefix}m)", sign(d_flip)),
        y_desc: format!("{}{f_name} ({f_prefix}N)", sign(f_flip)),
        points: d
            .iter()
            .zip(&f)
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .map(|(x, y)| (x / d_scale, y / f_scale))
            .collect(),
    };
    let stem = dir.join(STEM);
    chart::save(&fig, &stem)?;
    Ok(stem.with_extension("png"))
}

impl Figure for ForceChart {
    fn size(&self) -> (u32, u32) {
        SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String> {
        use plotters::prelude::*;
        let (area, text) = chart::canvas(root, &self.title)?;
        let span = |k: usize| {
            let (lo, hi) = self.points.iter().fold((0.0f64, 0.0f64), |(a, b), p| {
                let v = if k == 0 { p.0 } else { p.1 };
                (a.min(v), b.max(v))
            });
            let pad = 0.05 * (hi - lo).max(1e-300);
            (lo - pad)..(hi + pad)
        };
        let mut ch = chart::panel(&area, FRAME, text)
            .build_cartesian_2d(span(0), span(1))
            .map_err(chart::err)?;
        chart::axes(&mut ch, text, |mesh| {
            mesh.x_desc(self.x_desc.as_str())
                .y_desc(self.y_desc.as_str())
                .x_label_formatter(&chart::plain)
                .y_label_formatter(&chart::plain)
                .axis_desc_style(("sans-serif", 16))
                .label_style(("sans-serif", 14));
        })?;
        // (one pixel wide: the bitmap backend draws a wider line's vertical segments (a force
        // jumping where the displacement does not move) down past the plot area, to the
        // image's edge, a negative force the data do not have)
        ch.draw_series(LineSeries::new(
            self.points.iter().copied(),
            chart::colour(0).stroke_width(1),
        ))
        .map_err(chart::err)?;
        area.present().map_err(chart::err)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(header: &[&str], rows: Vec<Vec<f64>>) -> Table {
        Table {
            path: "r.csv".into(),
            header: header.iter().map(|s| s.to_string()).collect(),
            rows,
        }
    }

    /// A bare stem takes the component with the largest magnitude; a whole column is taken as
    /// named; an unknown name lists the columns.
    #[test]
    fn picks_the_named_or_largest_component() {
        let t = table(
            &["time", "w.force_x", "w.force_y", "w.force_z"],
            vec![vec![0.0, 1.0, -5.0, 2.0], vec![1.0, 0.5, 3.0, 4.0]],
        );
        let (n, v) = pick(&t, "r.csv", "w", "force").unwrap();
        assert_eq!((n.as_str(), v), ("w.force_y", vec![-5.0, 3.0]));
        let (n, _) = pick(&t, "r.csv", "w.force_z", "force").unwrap();
        assert_eq!(n, "w.force_z");
        let e = pick(&t, "r.csv", "floor", "force").unwrap_err();
        assert!(e.contains("w.force_x"), "{e}");
        // A file with only `time` (no supports or walls, no probes) says so, not an empty list.
        let e = pick(&table(&["time"], vec![vec![0.0]]), "r.csv", "w", "force").unwrap_err();
        assert!(e.ends_with("; it has no column but time"), "{e}");
    }

    /// The sign flip makes the largest-magnitude value positive and keeps the others' ratios.
    #[test]
    fn largest_magnitude_is_made_positive() {
        assert_eq!(
            positive(vec![1.0, -3.0, 2.0]),
            (vec![-1.0, 3.0, -2.0], true)
        );
        assert_eq!(positive(vec![1.0, 3.0]), (vec![1.0, 3.0], false));
    }
}
