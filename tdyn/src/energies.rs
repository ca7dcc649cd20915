//! The energies of a run over time, and the block `tdyn run` ends with.
//!
//! [`plot`] draws `energies.png` and `energies.svg` in an output folder from its `history.csv`
//! (docs/scene.md's energy columns): kinetic, internal, hourglass and contact energy, the external
//! work, and their balance `K + I + H + C - W`, which stays at the initial energy E(0) when the
//! run conserves energy; below, the balance's relative error over time. `tdyn run` calls it at
//! the end of a run, `tdyn plot OUT_DIR` for an existing folder. [`closing`] is the text that
//! names what the run wrote.
use crate::chart::{self, Figure};
use plotters::coord::Shift;
use plotters::prelude::{DrawingArea, DrawingBackend};
use std::path::{Path, PathBuf};

/// The history.csv columns drawn, with their legend text, in drawing order. The contact,
/// conversion and external-work columns are absent from runs without contact, without failed
/// elements that become particles, or without supports; a column that is zero throughout is
/// not drawn.
const CURVES: [(&str, &str); 6] = [
    ("kinetic_energy", "kinetic"),
    ("internal_energy", "internal (stress work)"),
    ("hourglass_energy", "hourglass"),
    ("contact_energy", "contact (taken by push-back)"),
    (
        "conversion_energy",
        "conversion (taken by failed elements turned into particles)",
    ),
    ("external_work", "external work (gravity, supports)"),
];

/// The index of the internal energy in [`CURVES`].
const INTERNAL: usize = 1;

/// The columns the balance adds up (E = K + I + H + C, C what contact and the conversions of
/// failed elements to particles took, as history.csv's `energy_error` counts them) and the one
/// it subtracts (W).
const BALANCE_TERMS: [&str; 5] = [
    "kinetic_energy",
    "internal_energy",
    "hourglass_energy",
    "contact_energy",
    "conversion_energy",
];

/// Dash and gap of the balance's line and of the blocks' lines, pixels.
const BALANCE_DASH: (u32, u32) = (10, 6);
const BLOCK_DASH: (u32, u32) = (5, 4);

/// The prefix of a block's internal-energy column (`internal_energy.plate`).
const BLOCK_INTERNAL: &str = "internal_energy.";

/// A block's internal energy within this fraction of the total's largest value at every row is
/// the whole internal energy, and not drawn again.
const SAME_CURVE: f64 = 1e-3;

/// Points drawn per curve at most (longer histories are thinned evenly, keeping the last row):
/// more than a chart's width in pixels, few enough to keep the SVG small.
const MAX_POINTS: usize = 2000;

/// Chart size, pixels.
const CHART_SIZE: (u32, u32) = (1200, 820);

/// Height of the energies panel, pixels (the error panel takes the rest below the title).
const ENERGY_PANEL_HEIGHT: u32 = 540;

/// The energy axis's top over the largest value: room for the legend above the curves.
const LEGEND_HEADROOM: f64 = 1.55;

/// The file names, in the output folder.
pub const CHART_STEM: &str = "energies";

/// A run's energy history: time and the drawn columns, thinned to [`MAX_POINTS`].
struct History {
    time: Vec<f64>,
    /// (legend text, values) of each column present and not zero throughout.
    curves: Vec<(&'static str, Vec<f64>)>,
    /// (block name, values) of the blocks' internal energies (`internal_energy.<group>`), when
    /// they are not the whole internal energy (a run with particles, or several blocks).
    blocks: Vec<(String, Vec<f64>)>,
    /// K + I + H + C - W at each row.
    balance: Vec<f64>,
    /// The relative error of the balance, as history.csv's `energy_error`.
    error: Vec<f64>,
}

/// Reads `history.csv`: header row, numbers, `#` comment lines skipped.
fn read_history(path: &Path) -> Result<History, String> {
    let table = crate::csv::Table::read(path)?;
    let rows = &table.rows;
    if rows.is_empty() {
        return Err(format!("{}: no rows", path.display()));
    }
    let column = |name: &str| table.column(name);
    let need =
        |name: &str| column(name).ok_or_else(|| format!("{}: no column {name}", path.display()));
    let time = need("time")?;
    let zeros = vec![0.0; rows.len()];
    let term = |name: &str| column(name).unwrap_or_else(|| zeros.clone());
    let mut energy = zeros.clone();
    for name in BALANCE_TERMS {
        for (e, v) in energy.iter_mut().zip(term(name)) {
            *e += v;
        }
    }
    let work = term("external_work");
    let balance: Vec<f64> = energy.iter().zip(&work).map(|(e, w)| e - w).collect();
    // docs/scene.md: |E(t) - E(0) - W(t)| / max(E(0) + |W(t)|, 1e-30); history.csv has it, but a
    // particle-only history may not: the same formula from the columns.
    let error = column("energy_error").unwrap_or_else(|| {
        energy
            .iter()
            .zip(&work)
            .map(|(e, w)| (e - energy[0] - w).abs() / (energy[0] + w.abs()).max(1e-30))
            .collect()
    });
    let curves: Vec<(&'static str, Vec<f64>)> = CURVES
        .iter()
        .filter_map(|(name, label)| {
            let v = column(name)?;
            v.iter().any(|x| *x != 0.0).then_some((*label, v))
        })
        .collect();
    let internal = term("internal_energy");
    let internal_max = internal.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let blocks: Vec<(String, Vec<f64>)> = table
        .header
        .iter()
        .filter_map(|h| h.strip_prefix(BLOCK_INTERNAL))
        .filter_map(|name| {
            Some((
                name.to_string(),
                column(&format!("{BLOCK_INTERNAL}{name}"))?,
            ))
        })
        .filter(|(_, v)| {
            v.iter()
                .zip(&internal)
                .any(|(b, i)| (i - b).abs() > SAME_CURVE * internal_max)
        })
        .collect();
    let keep = thin(rows.len(), MAX_POINTS);
    let pick = |v: &[f64]| keep.iter().map(|&i| v[i]).collect::<Vec<f64>>();
    Ok(History {
        time: pick(&time),
        curves: curves.into_iter().map(|(l, v)| (l, pick(&v))).collect(),
        blocks: blocks.into_iter().map(|(n, v)| (n, pick(&v))).collect(),
        balance: pick(&balance),
        error: pick(&error),
    })
}

/// Indices of at most `max` rows of `n`, evenly spaced, the first and the last included.
fn thin(n: usize, max: usize) -> Vec<usize> {
    if n <= max {
        return (0..n).collect();
    }
    let stride = n.div_ceil(max - 1);
    let mut keep: Vec<usize> = (0..n).step_by(stride).collect();
    if keep.last() != Some(&(n - 1)) {
        keep.push(n - 1);
    }
    keep
}

/// The chart of one run's energies.
struct EnergyChart {
    title: String,
    history: History,
}

/// Each panel's margin and label areas, pixels.
const FRAME: chart::Frame = chart::Frame {
    margin: 15,
    x_labels: 45,
    y_labels: 80,
};

/// The time axis both panels share.
struct TimeAxis {
    /// The rows' times, in the axis's unit.
    t: Vec<f64>,
    /// The axis's end, in its unit.
    max: f64,
    /// Its description, with the unit ("time (ms)").
    desc: String,
}

impl EnergyChart {
    /// The time axis: the history's times with an SI prefix.
    fn time_axis(&self) -> TimeAxis {
        let h = &self.history;
        let t_end = h.time.last().copied().unwrap_or(0.0);
        let (t_scale, t_prefix) = chart::si_prefix(t_end);
        TimeAxis {
            t: h.time.iter().map(|x| x / t_scale).collect(),
            max: if t_end > 0.0 { t_end / t_scale } else { 1.0 },
            desc: format!("time ({t_prefix}s)"),
        }
    }

    /// The energy axis: (factor to divide by, SI prefix, range), the range over the curves and
    /// the balance with room for the legend above.
    fn energy_axis(&self) -> (f64, &'static str, (f64, f64)) {
        let h = &self.history;
        let finite = |v: &[f64]| {
            v.iter()
                .copied()
                .filter(|x| x.is_finite())
                .collect::<Vec<_>>()
        };
        let all: Vec<f64> = h
            .curves
            .iter()
            .flat_map(|(_, v)| finite(v))
            .chain(finite(&h.balance))
            .collect();
        let hi = all.iter().copied().fold(0.0f64, f64::max);
        let lo = all.iter().copied().fold(0.0f64, f64::min);
        let (e_scale, e_prefix) = chart::si_prefix(hi.max(-lo));
        let y = if hi > lo {
            (lo / e_scale, (lo + (hi - lo) * LEGEND_HEADROOM) / e_scale)
        } else {
            (0.0, 1.0)
        };
        (e_scale, e_prefix, y)
    }

    /// The upper panel: each energy, the blocks' shares of the internal energy (dashed, each
    /// block in its own colour, after the energies' colours) and the balance (dashed, black).
    fn energies<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        time: &TimeAxis,
        text: bool,
    ) -> Result<(), String> {
        use plotters::prelude::*;
        let h = &self.history;
        let (e_scale, e_prefix, (y0, y1)) = self.energy_axis();
        let mut ch = chart::panel(area, FRAME, text)
            .build_cartesian_2d(0.0..time.max, y0..y1)
            .map_err(chart::err)?;
        chart::axes(&mut ch, text, |mesh| {
            mesh.x_desc(time.desc.as_str())
                .y_desc(format!("energy ({e_prefix}J)"))
                .x_label_formatter(&chart::plain)
                .y_label_formatter(&chart::plain)
                .axis_desc_style(("sans-serif", 16))
                .label_style(("sans-serif", 14));
        })?;
        let line = |v: &[f64]| -> Vec<(f64, f64)> {
            time.t
                .iter()
                .zip(v)
                .filter(|(_, y)| y.is_finite())
                .map(|(x, y)| (*x, y / e_scale))
                .collect()
        };
        for (k, (label, v)) in h.curves.iter().enumerate() {
            let c = chart::colour(k);
            let s = ch
                .draw_series(LineSeries::new(line(v), c.stroke_width(2)))
                .map_err(chart::err)?;
            if text {
                s.label(*label).legend(chart::line_key(c));
            }
            if *label != CURVES[INTERNAL].1 {
                continue;
            }
            for (j, (name, v)) in h.blocks.iter().enumerate() {
                let c = chart::colour(h.curves.len() + j);
                let s = ch
                    .draw_series(DashedLineSeries::new(
                        line(v),
                        BLOCK_DASH.0,
                        BLOCK_DASH.1,
                        c.stroke_width(2),
                    ))
                    .map_err(chart::err)?;
                if text {
                    s.label(format!("internal of block \"{name}\""))
                        .legend(chart::dashed_key(c, BLOCK_DASH.0, BLOCK_DASH.1));
                }
            }
        }
        let s = ch
            .draw_series(DashedLineSeries::new(
                line(&h.balance),
                BALANCE_DASH.0,
                BALANCE_DASH.1,
                BLACK.stroke_width(2),
            ))
            .map_err(chart::err)?;
        if text {
            s.label("balance K + I + H + C - W (stays at E(0))")
                .legend(chart::dashed_key(BLACK, BALANCE_DASH.0, BALANCE_DASH.1));
            chart::legend(&mut ch, SeriesLabelPosition::UpperRight, 15)?;
        }
        Ok(())
    }

    /// The lower panel: the balance's relative error, %.
    fn balance_error<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        time: &TimeAxis,
        text: bool,
    ) -> Result<(), String> {
        use plotters::prelude::*;
        let err: Vec<(f64, f64)> = time
            .t
            .iter()
            .zip(&self.history.error)
            .filter(|(_, e)| e.is_finite())
            .map(|(x, e)| (*x, 100.0 * e))
            .collect();
        let e_max = err.iter().map(|p| p.1).fold(0.0f64, f64::max);
        let e_top = if e_max > 0.0 { e_max * 1.3 } else { 1e-3 };
        let mut ch = chart::panel(area, FRAME, text)
            .build_cartesian_2d(0.0..time.max, 0.0..e_top)
            .map_err(chart::err)?;
        chart::axes(&mut ch, text, |mesh| {
            mesh.x_desc(time.desc.as_str())
                .y_desc("energy error (%)")
                .x_label_formatter(&chart::plain)
                .y_label_formatter(&chart::plain)
                .y_labels(5)
                .axis_desc_style(("sans-serif", 16))
                .label_style(("sans-serif", 14));
        })?;
        let c = BLACK;
        let s = ch
            .draw_series(LineSeries::new(err, c.stroke_width(2)))
            .map_err(chart::err)?;
        if text {
            s.label("|K + I + H + C - E(0) - W| / S (energy scale)")
                .legend(chart::line_key(c));
            chart::legend(&mut ch, SeriesLabelPosition::LowerRight, 15)?;
        }
        Ok(())
    }
}

impl Figure for EnergyChart {
    fn size(&self) -> (u32, u32) {
        CHART_SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String> {
        let (root, text) = chart::canvas(root, &self.title)?;
        let (top, bottom) = root.split_vertically(ENERGY_PANEL_HEIGHT);
        let time = self.time_axis();
        self.energies(&top, &time, text)?;
        self.balance_error(&bottom, &time, text)?;
        root.present().map_err(chart::err)?;
        Ok(())
    }
}

/// Draws `energies.png` and `energies.svg` in `dir` from its `history.csv`, titled with
/// `report.json`'s title when there is one; returns the PNG's path.
pub fn plot(dir: &Path) -> Result<PathBuf, String> {
    let history = read_history(&dir.join("history.csv"))?;
    let title = std::fs::read_to_string(dir.join("report.json"))
        .ok()
        .and_then(|s| serde_json::from_str::<serde_json::Value>(&s).ok())
        .and_then(|r| r.get("title").and_then(|t| t.as_str()).map(str::to_string))
        .filter(|t| !t.is_empty())
        .unwrap_or_else(|| dir.display().to_string());
    let fig = EnergyChart {
        title: format!("{title}: energies"),
        history,
    };
    let stem = dir.join(CHART_STEM);
    chart::save(&fig, &stem)?;
    Ok(stem.with_extension("png"))
}

/// What a finished run reports in its closing block.
pub struct Finished {
    /// The output folder.
    pub out: PathBuf,
    /// Steps taken.
    pub steps: u64,
    /// Whole run, s, when known.
    pub wall_s: Option<f64>,
    /// The largest relative energy error.
    pub energy_error_max: f64,
    /// The largest from the energy check's first step (100) on, and the last.
    pub energy_error_max_checked: f64,
    /// See `energy_error_max_checked`.
    pub energy_error_last: f64,
}

/// `report.json`'s `wall_s` in `dir`, when it has one.
pub fn report_wall_s(dir: &Path) -> Option<f64> {
    let text = std::fs::read_to_string(dir.join("report.json")).ok()?;
    serde_json::from_str::<serde_json::Value>(&text)
        .ok()?
        .get("wall_s")?
        .as_f64()
}

/// The files of an output folder the closing block names, with what each is for.
const OUTPUTS: [(&str, &str); 6] = [
    ("fields.xmf", "open in ParaView (the fields over time)"),
    ("history.csv", "energies, momentum and contacts, per step"),
    ("probes.csv", "the probes' values, per step"),
    (
        "reactions.csv",
        "the supports' and rigid walls' forces, per step",
    ),
    (
        "contact_forces.csv",
        "the forces between bodies in contact, per step",
    ),
    ("report.json", "timings, balance and bytes per stage"),
];

/// What the output file `path` holds: `what`, or, for a force history with no column but
/// `time` (a scene with no supports or walls, no pairs of contact bodies), that it holds none.
fn what_holds(path: &Path, what: &str) -> String {
    let header = std::fs::read_to_string(path)
        .ok()
        .and_then(|t| t.lines().next().map(|l| l.trim().to_string()));
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
    match (name, header.as_deref()) {
        ("reactions.csv", Some("time")) => "no supports or walls: time only".to_string(),
        ("contact_forces.csv", Some("time")) => {
            "no pairs of bodies in contact: time only".to_string()
        }
        _ => what.to_string(),
    }
}

/// The step from which the run's energy check applies.
const CHECKED_FROM_STEP: u64 = coupling::driver::ENERGY_CHECK_FROM_STEP;

/// A relative error as a percentage with two decimals, or in scientific notation when smaller.
fn percent(x: f64) -> String {
    if 100.0 * x >= 0.01 {
        format!("{:.2} %", 100.0 * x)
    } else {
        format!("{:.1e} %", 100.0 * x)
    }
}

/// The closing block: steps, wall time, energy error, then each output file that exists with
/// what it is for, and the chart (or why it was not drawn).
pub fn closing(f: &Finished, chart: &Result<PathBuf, String>) -> String {
    let wall = f
        .wall_s
        .map(|s| format!(" in {s:.1} s"))
        .unwrap_or_default();
    // The largest error from step 100 (the checked one: before it the error of a start from
    // rest divides round-off-sized energies, docs/scene.md), and the error at the end.
    let largest = if f.steps >= CHECKED_FROM_STEP {
        format!(
            "at most {} from step {CHECKED_FROM_STEP}",
            percent(f.energy_error_max_checked)
        )
    } else {
        format!("at most {}", percent(f.energy_error_max))
    };
    let mut s = format!(
        "tdyn: done: {} steps{wall}, energy error {} at the end, {largest}\n",
        f.steps,
        percent(f.energy_error_last)
    );
    let mut rows: Vec<(String, String)> = OUTPUTS
        .iter()
        .map(|(name, what)| (f.out.join(name), *what))
        .filter(|(p, _)| p.is_file())
        .map(|(p, what)| (p.display().to_string(), what_holds(&p, what)))
        .collect();
    match chart {
        Ok(png) => rows.push((
            png.display().to_string(),
            format!("the energies over time (also {CHART_STEM}.svg)"),
        )),
        Err(e) => rows.push(("energies chart".into(), format!("not drawn: {e}"))),
    }
    let width = rows.iter().map(|r| r.0.len()).max().unwrap_or(0);
    for (path, what) in rows {
        s.push_str(&format!("  {path:<width$}  {what}\n"));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thinning_keeps_the_ends_and_at_most_max_rows() {
        assert_eq!(thin(5, 10), vec![0, 1, 2, 3, 4]);
        for n in [11, 1999, 2001, 100_000, 100_001] {
            let k = thin(n, 2000);
            assert!(k.len() <= 2000, "{n}: {} rows", k.len());
            assert_eq!((k[0], *k.last().unwrap()), (0, n - 1));
            assert!(k.windows(2).all(|w| w[0] < w[1]));
        }
    }

    #[test]
    fn the_chart_is_drawn_from_a_history_and_the_block_names_it() {
        let dir = std::env::temp_dir().join(format!("tdyn_energies_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // A body slowing on a support: K falls, I and C rise, W = 0; then the error computed
        // from the columns when energy_error is absent.
        let mut csv = String::from("step,time,kinetic_energy,internal_energy,contact_energy\n");
        for k in 0..=100 {
            let f = k as f64 / 100.0;
            csv.push_str(&format!(
                "{k},{},{},{},{}\n",
                f * 1e-4,
                10.0 * (1.0 - f),
                7.0 * f,
                3.0 * f
            ));
        }
        std::fs::write(dir.join("history.csv"), csv).unwrap();
        std::fs::write(dir.join("report.json"), "{\"title\": \"test\"}").unwrap();
        let h = read_history(&dir.join("history.csv")).unwrap();
        assert_eq!(h.curves.len(), 3, "three non-zero columns");
        assert!(h.balance.iter().all(|b| (b - 10.0).abs() < 1e-12));
        assert!(h.error.iter().all(|e| *e < 1e-12));
        let png = plot(&dir).unwrap();
        assert!(png.is_file() && dir.join("energies.svg").is_file());
        let text = closing(
            &Finished {
                out: dir.clone(),
                steps: 100,
                wall_s: Some(1.25),
                energy_error_max: 0.2,
                energy_error_max_checked: 3.9e-3,
                energy_error_last: 1.5e-3,
            },
            &Ok(png.clone()),
        );
        assert!(text.contains("100 steps in 1.2 s") || text.contains("100 steps in 1.3 s"));
        assert!(
            text.contains("energy error 0.15 % at the end, at most 0.39 % from step 100"),
            "{text}"
        );
        assert!(text.contains(&png.display().to_string()), "{text}");
        assert!(
            text.contains("report.json") && !text.contains("fields.xmf"),
            "{text}"
        );
        // A force history with no force column says so.
        assert!(!text.contains("reactions.csv"), "{text}");
        std::fs::write(dir.join("reactions.csv"), "time\n0\n1e-4\n").unwrap();
        let f = Finished {
            out: dir.clone(),
            steps: 100,
            wall_s: None,
            energy_error_max: 0.0,
            energy_error_max_checked: 0.0,
            energy_error_last: 0.0,
        };
        let text = closing(&f, &Ok(png.clone()));
        assert!(text.contains("no supports or walls: time only"), "{text}");
        std::fs::write(dir.join("reactions.csv"), "time,left.force_x\n0,0\n").unwrap();
        let text = closing(&f, &Ok(png.clone()));
        assert!(
            text.contains("the supports' and rigid walls' forces"),
            "{text}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
