//! `tdyn chart-scaling DIR`: the figures of a scaling study (`scripts/scaling.sh`) from the
//! runs' report.json files, as `scaling.csv` and `scaling.png` / `.svg`.
//!
//! DIR holds one output directory per run, named `<series>_np<P>` (`strong_np4`, `weak_np8`):
//! a strong series (one problem at every rank count) and a weak one (the problem grown with
//! the rank count). Per run and per stage of report.json (fe, sph, contact, transfer, rcb,
//! output) it takes the wall time per step, the imbalance (max/mean of the stage's work) and
//! the bytes sent per rank per step (report.json's `bytes_sent` is summed over ranks; for
//! output it is the bytes written). The chart: time per step split by stage, strong and weak
//! (the stages' times are maxima over ranks; "other" is the loop's time per step less the
//! stages inside it: history rows, probes, the energy sums), then the two figures that do not
//! depend on the machine: imbalance per stage and bytes per rank per step, against the rank
//! count.
use crate::chart::{self, Figure};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::{
    Cartesian2d, ChartContext, DrawingArea, DrawingBackend, IntoLogRange, Rectangle,
    SeriesLabelPosition,
};
use plotters::style::Color;
use std::path::Path;

/// Stages of report.json, in the order they are charted. "pushback" is the contact stage's
/// step 7b, inside "contact" (its bytes and imbalance from report.json's
/// `contact_pushback_*` keys; no time of its own).
pub const STAGES: [&str; 7] = [
    "fe", "sph", "contact", "transfer", "rcb", "output", "pushback",
];

/// The stages inside the time-step loop (their times add up to at most the loop's).
const LOOP_STAGES: [&str; 3] = ["fe", "sph", "contact"];

/// One stage of one run.
#[derive(Debug, Clone, Copy, Default)]
pub struct StageRow {
    /// Wall time per step, s.
    pub per_step_s: f64,
    /// Max/mean over ranks of the stage's work.
    pub imbalance: f64,
    /// Bytes sent per rank per step.
    pub bytes_per_rank_step: f64,
}

/// One run of the study.
#[derive(Debug, Clone)]
pub struct ScalingRow {
    /// "strong" or "weak".
    pub series: String,
    /// Ranks.
    pub np: usize,
    /// Mesh elements.
    pub elements: u64,
    /// SPH particles.
    pub particles: u64,
    /// Steps.
    pub steps: u64,
    /// Whole run, s.
    pub wall_s: f64,
    /// Time-step loop per step, s.
    pub loop_per_step_s: f64,
    /// Per stage of [`STAGES`] (None: the stage did not run).
    pub stages: Vec<Option<StageRow>>,
}

/// Reads the runs under `dir`.
pub fn read_runs(dir: &Path) -> Result<Vec<ScalingRow>, String> {
    let mut rows = Vec::new();
    let entries = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for ent in entries.flatten() {
        let name = ent.file_name().to_string_lossy().into_owned();
        let Some((series, np)) = name.rsplit_once("_np") else {
            continue;
        };
        let Ok(np) = np.parse::<usize>() else {
            continue;
        };
        let path = ent.path().join("report.json");
        if !path.exists() {
            continue;
        }
        let text =
            std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let r: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
        let f = |v: &serde_json::Value, k: &str| v.get(k).and_then(|x| x.as_f64());
        let steps = r.get("steps").and_then(|x| x.as_u64()).unwrap_or(0);
        let per = steps.max(1) as f64;
        let ranks = r
            .get("ranks")
            .and_then(|x| x.as_u64())
            .unwrap_or(np as u64)
            .max(1) as f64;
        let stages = STAGES
            .iter()
            .map(|s| {
                if *s == "pushback" {
                    return pushback_row(&r, ranks, per);
                }
                let st = r.get(*s).filter(|v| v.is_object())?;
                Some(StageRow {
                    per_step_s: f(st, "wall_s")? / per,
                    imbalance: f(st, "imbalance").unwrap_or(f64::NAN),
                    bytes_per_rank_step: f(st, "bytes_sent").unwrap_or(0.0) / ranks / per,
                })
            })
            .collect();
        rows.push(ScalingRow {
            series: series.to_string(),
            np,
            elements: r.get("elements").and_then(|x| x.as_u64()).unwrap_or(0),
            particles: r.get("particles").and_then(|x| x.as_u64()).unwrap_or(0),
            steps,
            wall_s: f(&r, "wall_s").unwrap_or(f64::NAN),
            loop_per_step_s: f(&r, "loop_s").unwrap_or(f64::NAN) / per,
            stages,
        });
    }
    if rows.is_empty() {
        return Err(format!(
            "{}: no run directories named <series>_np<P> with a report.json",
            dir.display()
        ));
    }
    rows.sort_by(|a, b| a.series.cmp(&b.series).then(a.np.cmp(&b.np)));
    Ok(rows)
}

/// The push-back's row (see [`STAGES`]): bytes per rank per step over all ranks, and the
/// imbalance of its work, the contacts the busiest rank solved per step over the mean per rank
/// (contacts found per step over the ranks).
fn pushback_row(r: &serde_json::Value, ranks: f64, steps: f64) -> Option<StageRow> {
    let f = |k: &str| r.get(k).and_then(|x| x.as_f64());
    let bytes = f("contact_pushback_bytes_per_step")?;
    let mean_rows = f("contacts_found_total").unwrap_or(0.0) / steps / ranks;
    let max_rows = f("contact_pushback_rows_per_rank_step_max").unwrap_or(f64::NAN);
    Some(StageRow {
        per_step_s: f64::NAN,
        imbalance: if mean_rows > 0.0 {
            max_rows / mean_rows
        } else {
            f64::NAN
        },
        bytes_per_rank_step: bytes / ranks,
    })
}

/// Writes scaling.csv.
pub fn write_csv(path: &Path, rows: &[ScalingRow]) -> Result<(), String> {
    use std::fmt::Write as _;
    let mut s = String::from("series,np,elements,particles,steps,wall_s,loop_per_step_s");
    for st in STAGES {
        let _ = write!(
            s,
            ",{st}_per_step_s,{st}_imbalance,{st}_bytes_per_rank_step"
        );
    }
    s.push('\n');
    let num = |v: f64| {
        if v.is_finite() {
            format!("{v:e}")
        } else {
            String::new()
        }
    };
    for r in rows {
        let _ = write!(
            s,
            "{},{},{},{},{},{},{}",
            r.series,
            r.np,
            r.elements,
            r.particles,
            r.steps,
            num(r.wall_s),
            num(r.loop_per_step_s)
        );
        for st in &r.stages {
            match st {
                Some(x) => {
                    let _ = write!(
                        s,
                        ",{},{},{}",
                        num(x.per_step_s),
                        num(x.imbalance),
                        num(x.bytes_per_rank_step)
                    );
                }
                None => s.push_str(",,,"),
            }
        }
        s.push('\n');
    }
    std::fs::write(path, s).map_err(|e| format!("{}: {e}", path.display()))
}

/// Reads the runs under `dir`, writes `dir`/scaling.csv and the charts; returns the rows.
pub fn chart_scaling(dir: &Path, title: &str) -> Result<Vec<ScalingRow>, String> {
    let rows = read_runs(dir)?;
    write_csv(&dir.join("scaling.csv"), &rows)?;
    let fig = ScalingChart {
        title: title.to_string(),
        rows: &rows,
    };
    chart::save(&fig, &dir.join("scaling"))?;
    Ok(rows)
}

/// A short table of the study for the terminal.
pub fn table(rows: &[ScalingRow]) -> String {
    use std::fmt::Write as _;
    let mut s = String::from(
        "series  np  elements particles steps  loop/step ms  stage: ms/step imbalance bytes/rank/step\n",
    );
    for r in rows {
        let _ = write!(
            s,
            "{:6} {:3} {:9} {:9} {:5} {:13.4} ",
            r.series,
            r.np,
            r.elements,
            r.particles,
            r.steps,
            r.loop_per_step_s * 1e3
        );
        for (name, st) in STAGES.iter().zip(&r.stages) {
            if let Some(x) = st {
                let ms = if x.per_step_s.is_finite() {
                    format!("{:.4}", x.per_step_s * 1e3)
                } else {
                    "-".to_string()
                };
                let _ = write!(
                    s,
                    " {name}: {ms} {:.3} {:.0}",
                    x.imbalance, x.bytes_per_rank_step
                );
            }
        }
        s.push('\n');
    }
    s
}

/// Chart size, pixels.
const SCALING_CHART_SIZE: (u32, u32) = (1400, 1000);

/// The bar panels' height over the tallest bar (room for the legend above the bars).
const BAR_HEADROOM: f64 = 1.7;

/// Bar width, in units of log2(ranks).
const BAR_WIDTH: f64 = 0.6;

/// Each panel's margin and label areas, pixels.
const FRAME: chart::Frame = chart::Frame {
    margin: 15,
    x_labels: 40,
    y_labels: 70,
};

/// Panel captions' text height, pixels.
const CAPTION_PX: u32 = 17;

/// The study's series, in panel order.
const SERIES: [&str; 2] = ["strong", "weak"];

/// The study's chart: (a) strong and (b) weak time per step by stage, (c) imbalance and (d)
/// bytes per rank per step against the rank count.
struct ScalingChart<'a> {
    title: String,
    rows: &'a [ScalingRow],
}

/// x of a rank count: log2(np).
fn xpos(np: usize) -> f64 {
    (np.max(1) as f64).log2()
}

/// A rank-count axis's tick label at x = log2(np): np at whole powers of two, else none.
fn np_label(v: &f64) -> String {
    let p = 2f64.powf(*v);
    if (p - p.round()).abs() < 1e-6 && *v >= -1e-9 {
        format!("{}", p.round())
    } else {
        String::new()
    }
}

/// The caption of `name`'s bar panel (`rows` its runs): the weak series says its size per rank.
fn bar_caption(name: &str, rows: &[&ScalingRow]) -> String {
    if rows.is_empty() {
        return format!("{name} scaling: no runs in this study");
    }
    if name == "strong" {
        return "strong scaling: time per step by stage (max over ranks)".to_string();
    }
    let per =
        |f: fn(&ScalingRow) -> u64| rows.first().map(|r| f(r) / r.np.max(1) as u64).unwrap_or(0);
    let parts = per(|r| r.particles);
    format!(
        "weak scaling ({} elements{} per rank): time per step by stage",
        per(|r| r.elements),
        if parts > 0 {
            format!(", {parts} particles")
        } else {
            String::new()
        }
    )
}

/// What the two lower panels draw per (series, stage).
#[derive(Clone, Copy)]
enum PerStage {
    /// (c) max/mean of the stage's work over ranks.
    Imbalance,
    /// (d) bytes sent per rank per step.
    Bytes,
}

impl PerStage {
    /// The value of one stage of one run.
    fn value(self, s: &StageRow) -> f64 {
        match self {
            PerStage::Imbalance => s.imbalance,
            PerStage::Bytes => s.bytes_per_rank_step,
        }
    }

    /// The panel's caption.
    fn caption(self) -> &'static str {
        match self {
            PerStage::Imbalance => "imbalance per stage (max/mean of its work over ranks)",
            PerStage::Bytes => "bytes sent per rank per step (output: bytes written)",
        }
    }
}

impl ScalingChart<'_> {
    /// The runs of series `name`, by rank count.
    fn series(&self, name: &str) -> Vec<&ScalingRow> {
        self.rows.iter().filter(|r| r.series == name).collect()
    }

    /// The rank axis: log2(np) from half a bar left of 1 to half a bar right of the most.
    fn x_range(&self) -> std::ops::Range<f64> {
        -0.6..xpos(self.max_np()) + 0.6
    }

    /// Labels asked of the rank axis: two per power of two.
    fn x_labels(&self) -> usize {
        2 * (xpos(self.max_np()) as usize + 2)
    }

    /// The largest rank count of the study.
    fn max_np(&self) -> usize {
        self.rows.iter().map(|r| r.np).max().unwrap_or(1)
    }

    /// (a), (b): `name`'s time per step, one bar per run stacked by stage.
    fn bars<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        name: &str,
        text: bool,
    ) -> Result<(), String> {
        let rows = self.series(name);
        let top = rows
            .iter()
            .map(|r| bar_parts(r).iter().map(|p| p.1).sum::<f64>())
            .fold(0.0f64, f64::max)
            .max(1e-12)
            * 1e3
            * BAR_HEADROOM;
        let mut b = chart::panel(area, FRAME, text);
        b.caption(bar_caption(name, &rows), ("sans-serif", CAPTION_PX));
        let mut ch = b
            .build_cartesian_2d(self.x_range(), 0.0..top)
            .map_err(chart::err)?;
        chart::axes(&mut ch, text, |mesh| {
            mesh.disable_x_mesh()
                .x_desc("MPI ranks")
                .y_desc("ms per step")
                .x_labels(self.x_labels())
                .x_label_formatter(&np_label);
        })?;
        stacked_bars(&mut ch, &rows, top, text)?;
        if text && !rows.is_empty() {
            chart::legend(&mut ch, SeriesLabelPosition::UpperRight, 13)?;
        }
        Ok(())
    }

    /// (c) or (d): `what` against the rank count, one curve per (series, stage).
    fn per_stage<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        what: PerStage,
        text: bool,
    ) -> Result<(), String> {
        let value = |s: &StageRow| what.value(s);
        let vals: Vec<f64> = self
            .rows
            .iter()
            .flat_map(|r| r.stages.iter().flatten().map(value))
            .filter(|v| v.is_finite())
            .collect();
        let mut b = chart::panel(area, FRAME, text);
        b.caption(what.caption(), ("sans-serif", CAPTION_PX));
        let x_desc = "MPI ranks (solid: strong, dashed: weak)";
        match what {
            PerStage::Imbalance => {
                let hi = vals.iter().copied().fold(1.0f64, f64::max);
                let mut ch = b
                    .build_cartesian_2d(self.x_range(), 0.95..(1.0 + (hi - 1.0) * 1.3).max(1.1))
                    .map_err(chart::err)?;
                chart::axes(&mut ch, text, |mesh| {
                    mesh.x_desc(x_desc)
                        .y_desc("max / mean")
                        .x_labels(self.x_labels())
                        .x_label_formatter(&np_label);
                })?;
                self.curves(&mut ch, &value, text)
            }
            PerStage::Bytes => {
                let (lo, hi) = chart::log_span(vals.iter().copied(), 2.0, (1.0, 1e6));
                let mut ch = b
                    .build_cartesian_2d(self.x_range(), (lo..hi).log_scale())
                    .map_err(chart::err)?;
                chart::axes(&mut ch, text, |mesh| {
                    mesh.x_desc(x_desc)
                        .y_desc("bytes per rank per step")
                        .x_labels(self.x_labels())
                        .x_label_formatter(&np_label)
                        .y_label_formatter(&chart::sci);
                })?;
                self.curves(&mut ch, &value, text)
            }
        }
    }
}

/// One bar per run of `rows` on `ch` (ms, up to `top`), stacked by stage, each stage's colour
/// in the legend once; with text, the run's element count above its bar.
fn stacked_bars<DB: DrawingBackend>(
    ch: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    rows: &[&ScalingRow],
    top: f64,
    text: bool,
) -> Result<(), String> {
    let mut labelled = [false; STAGES.len() + 1];
    for r in rows {
        let x = xpos(r.np);
        let mut y = 0.0;
        for (k, v) in bar_parts(r) {
            let c = chart::colour(k);
            let s = ch
                .draw_series(std::iter::once(Rectangle::new(
                    [
                        (x - BAR_WIDTH / 2.0, y * 1e3),
                        (x + BAR_WIDTH / 2.0, (y + v) * 1e3),
                    ],
                    c.filled(),
                )))
                .map_err(chart::err)?;
            if text && !labelled[k] {
                labelled[k] = true;
                let label = if k < STAGES.len() {
                    STAGES[k].to_string()
                } else {
                    "other (loop less stages)".to_string()
                };
                s.label(label).legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 14, y + 5)], c.filled())
                });
            }
            y += v;
        }
        if text {
            chart::note(
                ch,
                format!("{} el.", r.elements),
                (x - BAR_WIDTH / 2.0, y * 1e3 + top * 0.02),
                12,
            )?;
        }
    }
    Ok(())
}

impl Figure for ScalingChart<'_> {
    fn size(&self) -> (u32, u32) {
        SCALING_CHART_SIZE
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String> {
        let (root, text) = chart::canvas(root, &self.title)?;
        let panels = root.split_evenly((2, 2));
        for (area, name) in panels.iter().zip(SERIES) {
            self.bars(area, name, text)?;
        }
        for (area, what) in panels[2..]
            .iter()
            .zip([PerStage::Imbalance, PerStage::Bytes])
        {
            self.per_stage(area, what, text)?;
        }
        root.present().map_err(chart::err)?;
        Ok(())
    }
}

/// The stacked parts of a run's bar: (stage index, s per step); index STAGES.len() = other.
fn bar_parts(r: &ScalingRow) -> Vec<(usize, f64)> {
    let mut parts = Vec::new();
    let mut inside = 0.0;
    for (k, st) in r.stages.iter().enumerate() {
        if let Some(s) = st {
            if s.per_step_s.is_finite() && s.per_step_s > 0.0 {
                parts.push((k, s.per_step_s));
                if LOOP_STAGES.contains(&STAGES[k]) {
                    inside += s.per_step_s;
                }
            }
        }
    }
    let other = r.loop_per_step_s - inside;
    if other.is_finite() && other > 0.0 {
        parts.push((STAGES.len(), other));
    }
    parts
}

impl ScalingChart<'_> {
    /// One curve per (series, stage) of `value` against the rank count: strong solid with
    /// dots, weak dashed with triangles; one legend entry per stage.
    fn curves<'a, DB, Y>(
        &self,
        ch: &mut plotters::prelude::ChartContext<
            'a,
            DB,
            plotters::prelude::Cartesian2d<plotters::coord::types::RangedCoordf64, Y>,
        >,
        value: &dyn Fn(&StageRow) -> f64,
        text: bool,
    ) -> Result<(), String>
    where
        DB: plotters::prelude::DrawingBackend + 'a,
        Y: plotters::coord::ranged1d::Ranged<ValueType = f64>,
    {
        use plotters::prelude::*;
        let mut labelled = [false; STAGES.len()];
        for name in SERIES {
            let rows = self.series(name);
            for (k, stage) in STAGES.iter().enumerate() {
                let pts: Vec<(f64, f64)> = rows
                    .iter()
                    .filter_map(|r| r.stages[k].as_ref().map(|s| (xpos(r.np), value(s))))
                    .filter(|(_, v)| v.is_finite() && *v > 0.0)
                    .collect();
                if pts.is_empty() {
                    continue;
                }
                let c = chart::colour(k);
                let style = c.stroke_width(2);
                let s = if name == "weak" {
                    ch.draw_series(DashedLineSeries::new(pts.clone(), 8, 5, style))
                        .map_err(chart::err)?;
                    ch.draw_series(pts.iter().map(|p| TriangleMarker::new(*p, 6, c.filled())))
                        .map_err(chart::err)?
                } else {
                    ch.draw_series(LineSeries::new(pts.clone(), style))
                        .map_err(chart::err)?;
                    ch.draw_series(pts.iter().map(|p| Circle::new(*p, 4, c.filled())))
                        .map_err(chart::err)?
                };
                if text && !labelled[k] {
                    labelled[k] = true;
                    s.label(*stage).legend(chart::line_key(c));
                }
            }
        }
        if text && labelled.iter().any(|l| *l) {
            chart::legend(ch, SeriesLabelPosition::UpperLeft, 13)?;
        }
        Ok(())
    }
}
