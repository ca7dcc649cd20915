//! `tdyn compare`: accuracy against cost of explicit and implicit integration on one scene.
//!
//! The scene runs once per (mode, step) in this process, on the same ranks (each run is a full
//! [`driver::run`] with `run.mode` and `run.dt` replaced), with dt = factor x the explicit stable
//! limit (the Flanagan-Belytschko estimate at t = 0), rounded down so that a whole number of
//! steps ends exactly at `end_time`. An explicit step above the limit is first run as given
//! (the driver refuses it: `refused`), then forced (`run.force_dt`): the energy check stops it
//! when it blows up (`unstable`). Cost is the time-step loop's wall time (max over ranks,
//! without set-up or output). Error is that of one probe column (`[compare] quantity`, default
//! the first) measured as `[compare] measure` says:
//!
//! - `period`: the period of the signal's dominant oscillation (least-squares sinusoid fit,
//!   started from the crossings of its mid-range level), relative to `[compare]
//!   reference_period` (an analytic value) or else to the finest run's;
//! - `history`: the RMS difference from the finest run's history (interpolated at this run's
//!   times), relative to that history's largest magnitude;
//! - `final`: the difference of the final values, relative to the same magnitude.
//!
//! "Finest run" = the finished run with the smallest step (either mode). Rank 0 writes
//! `compare.csv` and draws `compare.png` and `compare.svg`: error against cost (left) and
//! against the step with the explicit stable limit marked (right), one curve per mode.
use crate::chart;
use coupling::driver::{self, FailureKind, RunOptions, RunOverrides};
use coupling::input::scene::{self, Mode};
use coupling::kernels::collective::first_error;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::path::{Path, PathBuf};

mod figure;
use figure::Chart;

/// Steps tried when the user gives none, as multiples of the explicit stable limit: three
/// below it (explicit runs there are stable), six above (explicit runs are refused, then
/// forced: stable while the estimate's margin lasts, then caught blowing up; implicit runs stay
/// bounded).
pub const DEFAULT_DT_FACTORS: [f64; 9] = [0.25, 0.5, 0.9, 1.5, 2.0, 5.0, 10.0, 30.0, 100.0];

/// What `tdyn compare` was asked.
#[derive(Debug, Clone, Default)]
pub struct CompareOptions {
    /// The scene file.
    pub scene: PathBuf,
    /// "explicit", "implicit".
    pub modes: Vec<String>,
    /// Steps as multiples of the explicit stable limit (None: [`DEFAULT_DT_FACTORS`]).
    pub dt_factors: Option<Vec<f64>>,
    /// Output directory (default `out/<scene stem>/compare`).
    pub out: Option<PathBuf>,
    /// No progress lines.
    pub quiet: bool,
}

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Reached end_time.
    Finished,
    /// Refused before the first step (explicit step above the limit, not forced).
    Refused,
    /// Stopped by the energy check or non-finite values.
    Unstable,
    /// Another numerical failure (inverted element, Newton or KSP).
    Failed,
}

impl Outcome {
    fn name(self) -> &'static str {
        match self {
            Outcome::Finished => "ok",
            Outcome::Refused => "refused",
            Outcome::Unstable => "unstable",
            Outcome::Failed => "failed",
        }
    }
}

/// One row of compare.csv.
#[derive(Debug, Clone)]
pub struct CompareRow {
    /// The mode.
    pub mode: Mode,
    /// dt / explicit stable limit (after rounding to whole steps).
    pub dt_factor: f64,
    /// The step, s.
    pub dt: f64,
    /// Steps taken.
    pub steps: u64,
    /// Whole run, s.
    pub wall_s: f64,
    /// Time-step loop, s.
    pub loop_s: f64,
    /// Relative error of the measured quantity (NaN when not measured).
    pub error: f64,
    /// The plain run was refused (the forced one then ran).
    pub refused: bool,
    /// The run went unstable.
    pub unstable: bool,
    /// How the (last) run ended.
    pub outcome: Outcome,
    /// This run is the reference of the others.
    pub reference: bool,
    /// The driver's message for a run that stopped.
    pub message: String,
    /// Its output directory.
    pub out: PathBuf,
}

fn mode_name(m: Mode) -> &'static str {
    match m {
        Mode::Explicit => "explicit",
        Mode::Implicit => "implicit",
    }
}

/// Runs the comparison; returns the output directory. Collective; every rank returns the same
/// error. Refused or unstable runs are results, not errors.
pub fn compare(world: &SimpleCommunicator, opts: &CompareOptions) -> Result<PathBuf, String> {
    let scene = scene::load(&opts.scene).map_err(|e| e.to_string())?;
    let plan = plan(world, opts, &scene)?;
    let limit = explicit_limit(world, opts, &plan.out_dir)?;
    say(
        world,
        opts.quiet,
        format!(
            "tdyn compare: {}: explicit stable limit {limit:.4e} s, end time {:e} s, quantity {} ({}), {} ranks",
            plan.file,
            plan.end,
            plan.quantity,
            plan.def.measure,
            world.size()
        ),
    );
    let mut rows = run_ladder(world, opts, &plan, limit)?;

    // Errors, CSV and charts on rank 0; every rank learns the outcome.
    let mut result = Ok(());
    if world.rank() == 0 {
        let title = format!(
            "{}: {} ({}), {} ranks",
            if scene.title.is_empty() {
                plan.file.clone()
            } else {
                scene.title.clone()
            },
            plan.quantity,
            plan.def.measure,
            world.size()
        );
        result = write_outputs(&mut rows, &plan, title, limit)
            .map_err(|e| format!("{}: {e}", plan.file));
    }
    first_error(world, result.err())?;
    if world.rank() == 0 && !opts.quiet {
        for r in &rows {
            if r.outcome != Outcome::Finished {
                println!("  {} x{:.3}: {}", mode_name(r.mode), r.dt_factor, r.message);
            }
        }
    }
    Ok(plan.out_dir)
}

/// Prints `s` on rank 0 unless `quiet` (the tools' progress lines).
pub(crate) fn say(world: &SimpleCommunicator, quiet: bool, s: String) {
    if world.rank() == 0 && !quiet {
        println!("{s}");
    }
}

/// What a comparison runs and measures, from the options and the scene.
struct Plan {
    /// The scene file as loaded, for messages.
    file: String,
    /// The modes, in order.
    modes: Vec<Mode>,
    /// The steps, as multiples of the explicit stable limit.
    factors: Vec<f64>,
    /// The scene's `[compare]` table (or its defaults).
    def: scene::CompareDef,
    /// The probe column measured.
    quantity: String,
    /// `run.end_time`, s.
    end: f64,
    /// The output directory.
    out_dir: PathBuf,
}

/// The plan of `opts` on `scene`: an error for an unknown mode, a step factor that is not
/// positive, or a scene with no probe to measure.
fn plan(
    world: &SimpleCommunicator,
    opts: &CompareOptions,
    scene: &scene::Scene,
) -> Result<Plan, String> {
    let file = scene.file.display().to_string();
    let modes = modes(world, opts, scene)?;
    let factors = opts
        .dt_factors
        .clone()
        .unwrap_or_else(|| DEFAULT_DT_FACTORS.to_vec());
    if factors.is_empty() || factors.iter().any(|f| !(*f > 0.0 && f.is_finite())) {
        return Err(format!(
            "--dt-factors: expected positive multiples of the stable step, got {factors:?}"
        ));
    }
    let columns: Vec<String> = scene.probes.iter().flat_map(|p| p.columns()).collect();
    let def = scene.compare.clone().unwrap_or(scene::CompareDef {
        quantity: None,
        measure: "history".into(),
        reference_period: None,
    });
    let quantity = match (&def.quantity, columns.first()) {
        (Some(q), _) => q.clone(),
        (None, Some(c)) => c.clone(),
        (None, None) => {
            return Err(format!(
                "{file}: probe: tdyn compare measures a probe's history: add a [[probe]] (and optionally [compare] quantity = \"probe.field\")"
            ))
        }
    };
    let out_dir = opts.out.clone().unwrap_or_else(|| {
        PathBuf::from("out")
            .join(scene.file.file_stem().unwrap_or_default())
            .join("compare")
    });
    Ok(Plan {
        file,
        modes,
        factors,
        def,
        quantity,
        end: scene.run.end_time,
        out_dir,
    })
}

/// The modes of `--modes`; without it both where the scene can run implicitly, else explicit
/// alone (particles, contact, a meshed fluid: explicit only), said once.
fn modes(
    world: &SimpleCommunicator,
    opts: &CompareOptions,
    scene: &scene::Scene,
) -> Result<Vec<Mode>, String> {
    let mut modes = Vec::new();
    for m in &opts.modes {
        modes.push(match m.as_str() {
            "explicit" => Mode::Explicit,
            "implicit" => Mode::Implicit,
            _ => {
                return Err(format!(
                    "--modes: unknown mode \"{m}\" (expected explicit and/or implicit)"
                ))
            }
        });
    }
    if modes.is_empty() {
        modes.push(Mode::Explicit);
        let mut implicit = scene.clone();
        implicit.run.mode = Mode::Implicit;
        implicit.run.dt = Some(implicit.run.end_time);
        match driver::setup::check_scene(&implicit) {
            Ok(()) => modes.push(Mode::Implicit),
            Err(why) => say(
                world,
                opts.quiet,
                format!("tdyn compare: explicit only: {why}"),
            ),
        }
    }
    Ok(modes)
}

/// The explicit stable limit, s: set-up only (a fixed dt in the scene must not be refused).
fn explicit_limit(
    world: &SimpleCommunicator,
    opts: &CompareOptions,
    out_dir: &Path,
) -> Result<f64, String> {
    let probe_opts = RunOptions {
        scene: opts.scene.clone(),
        out: Some(out_dir.join("runs").join("setup")),
        quiet: true,
        overrides: RunOverrides {
            mode: Some(Mode::Explicit),
            force_dt: Some(true),
            ..Default::default()
        },
        setup_only: true,
        algorithms: Default::default(),
        // the tool's own run folders: a new comparison replaces the last one's runs
        overwrite: true,
        restart: None,
        stop: None,
    };
    Ok(driver::run(world, &probe_opts)
        .map_err(|e| e.message)?
        .dt_stable)
}

/// Runs every (mode, step factor) of `plan`, a progress line each; a row per run (errors not
/// measured yet). An input error stops the ladder.
fn run_ladder(
    world: &SimpleCommunicator,
    opts: &CompareOptions,
    plan: &Plan,
    limit: f64,
) -> Result<Vec<CompareRow>, String> {
    let mut rows = Vec::new();
    for &mode in &plan.modes {
        for &f in &plan.factors {
            // A whole number of steps ends at end_time exactly.
            let n = (plan.end / (f * limit)).ceil().max(1.0);
            let dt = plan.end / n;
            let rung = Rung {
                mode,
                dt,
                dt_factor: dt / limit,
                dir: plan
                    .out_dir
                    .join("runs")
                    .join(format!("{}_x{}", mode_name(mode), f)),
            };
            let row = run_rung(world, &opts.scene, rung)?;
            say(world, opts.quiet, progress(&row));
            rows.push(row);
        }
    }
    Ok(rows)
}

/// One run of the ladder.
struct Rung {
    /// The mode.
    mode: Mode,
    /// The step, s.
    dt: f64,
    /// dt / explicit stable limit.
    dt_factor: f64,
    /// Its output directory.
    dir: PathBuf,
}

/// Runs `scene` at `rung`: an explicit step the driver refuses is run again forced. Its row,
/// or the message of an input error.
fn run_rung(world: &SimpleCommunicator, scene: &Path, rung: Rung) -> Result<CompareRow, String> {
    let run = |force: bool| {
        let o = RunOptions {
            scene: scene.to_path_buf(),
            out: Some(rung.dir.clone()),
            quiet: true,
            overrides: RunOverrides {
                mode: Some(rung.mode),
                dt: Some(rung.dt),
                force_dt: Some(force),
                ..Default::default()
            },
            setup_only: false,
            algorithms: Default::default(),
            overwrite: true,
            restart: None,
            stop: None,
        };
        driver::run(world, &o)
    };
    let mut res = run(false);
    let mut refused = false;
    if let Err(e) = &res {
        if e.kind == FailureKind::Refused {
            refused = true;
            res = run(true);
        }
    }
    let mut row = CompareRow {
        mode: rung.mode,
        dt_factor: rung.dt_factor,
        dt: rung.dt,
        steps: 0,
        wall_s: f64::NAN,
        loop_s: f64::NAN,
        error: f64::NAN,
        refused,
        unstable: false,
        outcome: Outcome::Finished,
        reference: false,
        message: String::new(),
        out: rung.dir,
    };
    match res {
        Ok(s) => (row.steps, row.wall_s, row.loop_s) = (s.steps, s.wall_s, s.loop_s),
        Err(e) => {
            row.outcome = match e.kind {
                FailureKind::Unstable => Outcome::Unstable,
                FailureKind::Refused => Outcome::Refused,
                FailureKind::Failed => Outcome::Failed,
                FailureKind::Input | FailureKind::Stopped => return Err(e.message),
            };
            row.unstable = row.outcome == Outcome::Unstable;
            row.message = e.message;
        }
    }
    Ok(row)
}

/// A run's progress line: its step and how it ended.
fn progress(row: &CompareRow) -> String {
    format!(
        "  {:8} dt = {:.4e} s ({:>7.3} x limit): {}{}",
        mode_name(row.mode),
        row.dt,
        row.dt_factor,
        if row.refused { "refused, forced: " } else { "" },
        match row.outcome {
            Outcome::Finished => format!("ok, {} steps, loop {:.3} s", row.steps, row.loop_s),
            o => o.name().to_string(),
        }
    )
}

/// Rank 0's outputs: measures the rows, writes compare.csv and draws the chart titled
/// `title`.
fn write_outputs(
    rows: &mut [CompareRow],
    plan: &Plan,
    title: String,
    limit: f64,
) -> Result<(), String> {
    let reference = measure(rows, &plan.quantity, &plan.def)?;
    write_csv(&plan.out_dir.join("compare.csv"), rows)?;
    let chart = Chart {
        title,
        y_desc: format!("relative error of the {}", plan.def.measure),
        reference,
        limit,
        rows,
    };
    chart::save(&chart, &plan.out_dir.join("compare"))
}

/// A probes.csv column: (times, values).
fn read_series(dir: &Path, column: &str) -> Result<(Vec<f64>, Vec<f64>), String> {
    let path = dir.join("probes.csv");
    Ok((read_column(&path, "time")?, read_column(&path, column)?))
}

pub(crate) use crate::csv::read_column;

/// Period of the dominant oscillation of a sampled signal: a first estimate from the crossings
/// of its mid-range level (linear interpolation between samples; same-direction crossings when
/// there are two upward ones, else twice the mean spacing of at least three), refined by the
/// least-squares fit of q ~ A cos(w t) + B sin(w t) + C, minimised over w within a factor
/// [`PERIOD_SEARCH`] of the first estimate (a scan, then golden-section search). The fit weighs the whole
/// record, so faster components (higher modes, dispersion noise) shift it far less than they
/// shift single crossings. None when the signal does not oscillate enough.
pub fn period(t: &[f64], q: &[f64]) -> Option<f64> {
    let first = crossing_period(t, q)?;
    let w0 = 2.0 * std::f64::consts::PI / first;
    // A scan first (the residual has side lobes when the record holds few periods), then a
    // golden-section search between the best scan point's neighbours.
    let grid: Vec<f64> = (0..=SCAN_POINTS)
        .map(|k| w0 * PERIOD_SEARCH.powf(2.0 * k as f64 / SCAN_POINTS as f64 - 1.0))
        .collect();
    let best = (0..grid.len())
        .min_by(|&i, &j| fit_residual(t, q, grid[i]).total_cmp(&fit_residual(t, q, grid[j])))?;
    let (mut a, mut b) = (
        grid[best.saturating_sub(1)],
        grid[(best + 1).min(SCAN_POINTS)],
    );
    let ratio = 0.5 * (5.0f64.sqrt() - 1.0);
    let mut x1 = b - ratio * (b - a);
    let mut x2 = a + ratio * (b - a);
    let (mut f1, mut f2) = (fit_residual(t, q, x1), fit_residual(t, q, x2));
    for _ in 0..GOLDEN_STEPS {
        if f1 <= f2 {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - ratio * (b - a);
            f1 = fit_residual(t, q, x1);
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + ratio * (b - a);
            f2 = fit_residual(t, q, x2);
        }
    }
    let w = 0.5 * (a + b);
    w.is_finite().then(|| 2.0 * std::f64::consts::PI / w)
}

/// The fit searches angular frequencies within this factor of the crossings' estimate.
const PERIOD_SEARCH: f64 = 1.25;
/// Points of the scan over that range.
const SCAN_POINTS: usize = 80;
/// Golden-section steps: the bracket shrinks by 0.618 per step, to 1e-12 of its width.
const GOLDEN_STEPS: usize = 60;

/// Sum of squared residuals of the least-squares fit q ~ A cos(w t) + B sin(w t) + C.
fn fit_residual(t: &[f64], q: &[f64], w: f64) -> f64 {
    // Normal equations of the 3 basis functions (c, s, 1).
    let mut m = [[0.0f64; 3]; 3];
    let mut r = [0.0f64; 3];
    for (&x, &y) in t.iter().zip(q) {
        let f = [(w * x).cos(), (w * x).sin(), 1.0];
        for i in 0..3 {
            r[i] += f[i] * y;
            for j in 0..3 {
                m[i][j] += f[i] * f[j];
            }
        }
    }
    let Some(c) = solve3(m, r) else {
        return f64::INFINITY;
    };
    t.iter()
        .zip(q)
        .map(|(&x, &y)| {
            let e = y - (c[0] * (w * x).cos() + c[1] * (w * x).sin() + c[2]);
            e * e
        })
        .sum()
}

/// Solves a 3 x 3 system by Cramer's rule (None when singular).
fn solve3(m: [[f64; 3]; 3], r: [f64; 3]) -> Option<[f64; 3]> {
    let det = |a: &[[f64; 3]; 3]| {
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    };
    let d = det(&m);
    if d == 0.0 || !d.is_finite() {
        return None;
    }
    Some(std::array::from_fn(|k| {
        let mut a = m;
        for i in 0..3 {
            a[i][k] = r[i];
        }
        det(&a) / d
    }))
}

/// Mean period from the crossings of the mid-range level.
fn crossing_period(t: &[f64], q: &[f64]) -> Option<f64> {
    let lo = q.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = q.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    if !(hi > lo) {
        return None;
    }
    let level = 0.5 * (lo + hi);
    let (mut up, mut all) = (Vec::new(), Vec::new());
    for i in 1..q.len() {
        let (a, b) = (q[i - 1] - level, q[i] - level);
        if (a < 0.0 && b >= 0.0) || (a > 0.0 && b <= 0.0) {
            let tc = t[i - 1] + (t[i] - t[i - 1]) * a / (a - b);
            all.push(tc);
            if a < 0.0 {
                up.push(tc);
            }
        }
    }
    if up.len() >= 2 {
        Some((up[up.len() - 1] - up[0]) / (up.len() - 1) as f64)
    } else if all.len() >= 3 {
        Some(2.0 * (all[all.len() - 1] - all[0]) / (all.len() - 1) as f64)
    } else {
        None
    }
}

/// Linear interpolation of (t, q) at `x` (clamped to the ends).
fn interpolate(t: &[f64], q: &[f64], x: f64) -> f64 {
    let k = t.partition_point(|&s| s < x);
    if k == 0 {
        return q[0];
    }
    if k >= t.len() {
        return q[t.len() - 1];
    }
    let w = (x - t[k - 1]) / (t[k] - t[k - 1]);
    q[k - 1] + w * (q[k] - q[k - 1])
}

/// Fills each finished row's error; returns a description of the reference.
fn measure(
    rows: &mut [CompareRow],
    quantity: &str,
    def: &scene::CompareDef,
) -> Result<String, String> {
    let finest = rows
        .iter()
        .enumerate()
        .filter(|(_, r)| r.outcome == Outcome::Finished)
        .min_by(|a, b| a.1.dt.total_cmp(&b.1.dt))
        .map(|(i, _)| i);
    let mut series = Vec::with_capacity(rows.len());
    for r in rows.iter() {
        series.push(if r.outcome == Outcome::Finished {
            Some(read_series(&r.out, quantity)?)
        } else {
            None
        });
    }
    let finest_name = finest
        .map(|i| {
            format!(
                "against the finest run: {} dt = {:.3e} s",
                mode_name(rows[i].mode),
                rows[i].dt
            )
        })
        .unwrap_or_default();
    match def.measure.as_str() {
        "period" => {
            let (t_ref, what) = match def.reference_period {
                Some(t) => (t, format!("against the analytic period {t:.5e} s")),
                None => {
                    let i = finest.ok_or("no run finished: nothing to compare")?;
                    let (t, q) = series[i].as_ref().unwrap();
                    let p = period(t, q).ok_or(
                        "the finest run's quantity does not oscillate: no period (use measure = \"history\")",
                    )?;
                    rows[i].reference = true;
                    (p, finest_name)
                }
            };
            for (r, s) in rows.iter_mut().zip(&series) {
                if let Some((t, q)) = s {
                    r.error = period(t, q)
                        .map(|p| (p - t_ref).abs() / t_ref)
                        .unwrap_or(f64::NAN);
                }
            }
            Ok(format!("period, {what}"))
        }
        kind => {
            let i = finest.ok_or("no run finished: nothing to compare")?;
            rows[i].reference = true;
            let (tr, qr) = series[i].clone().unwrap();
            let scale = qr.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
            for (r, s) in rows.iter_mut().zip(&series) {
                if let Some((t, q)) = s {
                    r.error = if kind == "final" {
                        (q[q.len() - 1] - qr[qr.len() - 1]).abs() / scale
                    } else {
                        let ss: f64 = t
                            .iter()
                            .zip(q)
                            .map(|(&x, &v)| (v - interpolate(&tr, &qr, x)).powi(2))
                            .sum();
                        (ss / t.len() as f64).sqrt() / scale
                    };
                }
            }
            Ok(format!("{kind}, {finest_name}"))
        }
    }
}

fn write_csv(path: &Path, rows: &[CompareRow]) -> Result<(), String> {
    use std::fmt::Write as _;
    let mut s = String::from(
        "mode,dt,dt_factor,steps,wall_s,loop_s,error,refused,unstable,status,reference,message\n",
    );
    let num = |v: f64| {
        if v.is_finite() {
            format!("{v:e}")
        } else {
            String::new()
        }
    };
    for r in rows {
        let _ = writeln!(
            s,
            "{},{:e},{},{},{},{},{},{},{},{},{},\"{}\"",
            mode_name(r.mode),
            r.dt,
            r.dt_factor,
            r.steps,
            num(r.wall_s),
            num(r.loop_s),
            num(r.error),
            r.refused,
            r.unstable,
            r.outcome.name(),
            r.reference,
            r.message.replace('"', "'")
        );
    }
    std::fs::write(path, s).map_err(|e| format!("{}: {e}", path.display()))
}
