//! `tdyn sweep`: accuracy against cost over a ladder of resolutions of one scene.
//!
//! The scene runs once per value of the swept parameter(s), in this process and on the same
//! ranks (each run is a full [`driver::run`], or the particles-only run, with the parameter
//! replaced through [`RunOverrides`]). A parameter is a mesh parameter (`N`, `1:N` for
//! `[[mesh]]` number 1; the scene's `params` table must have it) or a particle spacing
//! (`particles.spacing` for every `[[particles]]`, `particles[i].spacing` for one); several
//! parameters are swept together, value k of each in run k. For each run it records:
//!
//! - cost: the time-step loop's wall time and the whole run's (report.json, max over ranks);
//! - memory: the model's arrays (report.json's `bytes_per_element` x `elements`, the FE stage's
//!   nodal and element arrays) and the process's peak resident set (`VmHWM` of
//!   /proc/self/status, reset through /proc/self/clear_refs before each run, max over ranks;
//!   it includes MPI, PETSc and HDF5, tens of MB however small the model);
//! - accuracy, for each measure `COLUMN[:peak|final][=REFERENCE]`: COLUMN is a probes.csv column
//!   (`probe.field`) or a history.csv column; `peak` is the value of largest magnitude over the
//!   run, `final` the last row's. The error is |q - REFERENCE| / |REFERENCE| with a reference
//!   given, else |q - q_finest| / max |COLUMN of the finest run| where the finest run is the
//!   finished one with the most elements + particles (its own error, 0, is not drawn).
//!
//! The first value runs once more before the ladder, unrecorded (warm-up). A run that is
//! refused, stops (energy check, inverted element) or fails (a mesh that gmsh
//! cannot make at that value) is a row with its status and message, not an error. Rank 0 writes
//! `accuracy_cost.csv` and draws `accuracy_cost.png` / `.svg`: error against loop wall time,
//! against model memory and against peak RSS, log-log, one point per run labelled with its
//! parameter value, one curve per measure.
use crate::chart::{self, Figure};
use crate::compare::{read_column, say};
use coupling::driver::{self, FailureKind, RunOptions, RunOverrides, HISTORY_COLUMNS};
use coupling::input::scene::{self, Scene};
use coupling::kernels::collective::{self, first_error};
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::path::{Path, PathBuf};

mod figure;
use figure::SweepChart;

/// What `tdyn sweep` was asked.
#[derive(Debug, Clone, Default)]
pub struct SweepOptions {
    /// The scene file.
    pub scene: PathBuf,
    /// `--param` specs, `[K:]NAME=v1,v2,...` (empty: the scene's `[sweep] param`).
    pub params: Vec<String>,
    /// The `[[mesh]]` a parameter without `K:` belongs to.
    pub mesh: usize,
    /// `--measure` specs, `COLUMN[:peak|final][=REFERENCE]` (empty: the scene's `[sweep]
    /// measure`, else the peak of the first probe column).
    pub measures: Vec<String>,
    /// Output directory (default `out/<scene stem>/sweep`).
    pub out: Option<PathBuf>,
    /// No progress lines.
    pub quiet: bool,
}

/// What a swept parameter replaces.
#[derive(Debug, Clone, PartialEq)]
pub enum Target {
    /// `mesh[mesh].params.name`.
    Mesh {
        /// Index of the `[[mesh]]`.
        mesh: usize,
        /// The gmsh parameter.
        name: String,
    },
    /// `particles[i].spacing` (None: every `[[particles]]`).
    Spacing(Option<usize>),
}

impl Target {
    /// The name as the user writes it (mesh 0's parameters without the `0:`).
    pub fn name(&self) -> String {
        match self {
            Target::Mesh { mesh: 0, name } => name.clone(),
            Target::Mesh { mesh, name } => format!("{mesh}:{name}"),
            Target::Spacing(None) => "particles.spacing".into(),
            Target::Spacing(Some(i)) => format!("particles[{i}].spacing"),
        }
    }

    /// Adds "this target = v" to `ov`.
    pub fn set(&self, ov: &mut RunOverrides, v: f64) {
        match self {
            Target::Mesh { mesh, name } => ov.mesh_params.push((*mesh, name.clone(), v)),
            Target::Spacing(i) => ov.particle_spacing.push((*i, v)),
        }
    }
}

/// Parses `[K:]NAME=v1,v2,...`, `particles.spacing=...` or `particles[i].spacing=...`.
pub fn parse_param(spec: &str, default_mesh: usize) -> Result<(Target, Vec<f64>), String> {
    let (name, values) = spec
        .split_once('=')
        .ok_or_else(|| format!("\"{spec}\": expected NAME=v1,v2,..."))?;
    let name = name.trim();
    let target = if name == "particles.spacing" {
        Target::Spacing(None)
    } else if let Some(i) = name
        .strip_prefix("particles[")
        .and_then(|r| r.strip_suffix("].spacing"))
    {
        Target::Spacing(Some(i.parse().map_err(|_| {
            format!("\"{spec}\": expected particles[i].spacing with i an index")
        })?))
    } else {
        let (mesh, n) = match name.split_once(':') {
            Some((k, n)) => (
                k.trim()
                    .parse()
                    .map_err(|_| format!("\"{spec}\": expected K:NAME with K a mesh index"))?,
                n.trim(),
            ),
            None => (default_mesh, name),
        };
        if n.is_empty() || !n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(format!(
                "\"{spec}\": \"{n}\" is not a gmsh parameter name (letters, digits, _)"
            ));
        }
        Target::Mesh {
            mesh,
            name: n.to_string(),
        }
    };
    let values = values
        .split(',')
        .map(|v| {
            let v = v.trim();
            v.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("\"{spec}\": \"{v}\" is not a number"))
        })
        .collect::<Result<Vec<f64>, String>>()?;
    Ok((target, values))
}

/// How a column becomes one number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// The value of largest magnitude over the run.
    Peak,
    /// The last row's value.
    Final,
}

/// One accuracy measure.
#[derive(Debug, Clone, PartialEq)]
pub struct Measure {
    /// The column.
    pub column: String,
    /// `probes.csv` or `history.csv`.
    pub file: &'static str,
    /// Peak or final.
    pub kind: Kind,
    /// An analytic or published value (None: the finest run).
    pub reference: Option<f64>,
}

impl Measure {
    /// `column:kind`.
    pub fn name(&self) -> String {
        format!(
            "{}:{}",
            self.column,
            match self.kind {
                Kind::Peak => "peak",
                Kind::Final => "final",
            }
        )
    }

    /// The measured number from one run's output.
    fn value(&self, dir: &Path) -> Result<(f64, f64), String> {
        let q = read_column(&dir.join(self.file), &self.column)?;
        let scale = q.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let v = match self.kind {
            Kind::Final => q.last().copied(),
            Kind::Peak => q.iter().copied().max_by(|a, b| a.abs().total_cmp(&b.abs())),
        };
        v.map(|v| (v, scale))
            .ok_or_else(|| format!("{}: no rows", dir.join(self.file).display()))
    }
}

/// Parses `COLUMN[:peak|final][=REFERENCE]` against the scene's probe columns and
/// history.csv's columns.
pub fn parse_measure(spec: &str, probe_columns: &[String]) -> Result<Measure, String> {
    let (head, reference) = match spec.split_once('=') {
        Some((h, r)) => (
            h.trim(),
            Some(
                r.trim()
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite() && *x != 0.0)
                    .ok_or_else(|| {
                        format!("\"{spec}\": the reference \"{r}\" is not a non-zero number")
                    })?,
            ),
        ),
        None => (spec.trim(), None),
    };
    let (column, kind) = match head.rsplit_once(':') {
        Some((c, "peak")) => (c, Kind::Peak),
        Some((c, "final")) => (c, Kind::Final),
        Some((_, k)) => {
            return Err(format!(
                "\"{spec}\": unknown measure \"{k}\" (expected peak or final)"
            ))
        }
        None => (head, Kind::Peak),
    };
    let file = if probe_columns.iter().any(|c| c == column) {
        "probes.csv"
    } else if HISTORY_COLUMNS.contains(&column)
        || column.starts_with("hourglass_energy.")
        || column.starts_with("internal_energy.")
    {
        // the docs/scene.md columns, and the per-block energies (`hourglass_energy.<group>`)
        "history.csv"
    } else {
        return Err(format!(
            "\"{spec}\": \"{column}\" is neither a probe column ({}) nor a history column ({})",
            if probe_columns.is_empty() {
                "the scene has no [[probe]]".to_string()
            } else {
                probe_columns.join(", ")
            },
            HISTORY_COLUMNS.join(", ")
        ));
    };
    Ok(Measure {
        column: column.to_string(),
        file,
        kind,
        reference,
    })
}

/// One row of accuracy_cost.csv.
#[derive(Debug, Clone)]
pub struct SweepRow {
    /// The parameters' values in this run.
    pub values: Vec<f64>,
    /// "N=20" (the first parameter; all of them when several).
    pub label: String,
    /// "ok", "refused", "unstable" or "failed".
    pub status: &'static str,
    /// The driver's message for a run that did not finish.
    pub message: String,
    /// Mesh elements.
    pub elements: u64,
    /// SPH particles.
    pub particles: u64,
    /// Steps taken.
    pub steps: u64,
    /// Whole run, s.
    pub wall_s: f64,
    /// Time-step loop without output, s.
    pub loop_s: f64,
    /// bytes_per_element x elements (NaN without a mesh).
    pub model_bytes: f64,
    /// Peak resident set of the process during the run, max over ranks, bytes.
    pub rss_peak_bytes: f64,
    /// Largest energy error of the run.
    pub energy_error_max: f64,
    /// Per measure: the measured number and the column's largest magnitude.
    pub measured: Vec<(f64, f64)>,
    /// Per measure: the relative error (NaN when not measured).
    pub errors: Vec<f64>,
    /// This run is the reference of the measures that have no given reference.
    pub reference: bool,
    /// Its output directory.
    pub out: PathBuf,
}

/// A value as a short label: 20, 0.002, 1.5.
fn value_label(v: f64) -> String {
    if v == v.round() && v.abs() < 1e9 {
        format!("{v:.0}")
    } else {
        format!("{v}")
    }
}

/// One swept parameter and its values.
type Ladder = (Target, Vec<f64>);

/// The ladder and the measures: from the command line, else the scene's `[sweep]`.
fn plan(opts: &SweepOptions, scene: &Scene) -> Result<(Vec<Ladder>, Vec<Measure>), String> {
    let file = scene.file.display().to_string();
    let def = scene.sweep.clone().unwrap_or_default();
    let (specs, from) = if opts.params.is_empty() {
        (def.param.clone(), "[sweep] param")
    } else {
        (opts.params.clone(), "--param")
    };
    if specs.is_empty() {
        return Err(format!(
            "{file}: nothing to sweep: give --param NAME=v1,v2,... (a mesh parameter, or particles.spacing), or a [sweep] param list in the scene"
        ));
    }
    let params = specs
        .iter()
        .map(|s| parse_param(s, opts.mesh).map_err(|e| format!("{file}: {from}: {e}")))
        .collect::<Result<Vec<_>, _>>()?;
    let n = params[0].1.len();
    if let Some((t, v)) = params.iter().find(|(_, v)| v.len() != n) {
        return Err(format!(
            "{file}: {from}: {} has {} values and {} has {n}: parameters swept together need as many values each",
            t.name(),
            v.len(),
            params[0].0.name()
        ));
    }
    let columns: Vec<String> = scene.probes.iter().flat_map(|p| p.columns()).collect();
    let (specs, from) = if !opts.measures.is_empty() {
        (opts.measures.clone(), "--measure")
    } else if !def.measure.is_empty() {
        (def.measure.clone(), "[sweep] measure")
    } else {
        match columns.first() {
            Some(c) => (vec![format!("{c}:peak")], "the first probe column"),
            None => {
                return Err(format!(
                    "{file}: nothing to measure: give --measure COLUMN[:peak|final] (a probe or history.csv column) or add a [[probe]]"
                ))
            }
        }
    };
    let measures = specs
        .iter()
        .map(|s| parse_measure(s, &columns).map_err(|e| format!("{file}: {from}: {e}")))
        .collect::<Result<Vec<Measure>, _>>()?;
    for (i, m) in measures.iter().enumerate() {
        if measures[..i].iter().any(|p| p.name() == m.name()) {
            return Err(format!(
                "{file}: {from}: {} is given twice (one reference per measure)",
                m.name()
            ));
        }
    }
    Ok((params, measures))
}

/// Runs the sweep; returns the output directory. Collective; every rank returns the same
/// error. Runs that stop or fail are rows, not errors.
pub fn sweep(world: &SimpleCommunicator, opts: &SweepOptions) -> Result<PathBuf, String> {
    let scene = scene::load(&opts.scene).map_err(|e| e.to_string())?;
    let file = scene.file.display().to_string();
    let (params, measures) = plan(opts, &scene)?;
    let overrides = run_overrides(&params, &scene)?;
    let out_dir = opts.out.clone().unwrap_or_else(|| {
        PathBuf::from("out")
            .join(scene.file.file_stem().unwrap_or_default())
            .join("sweep")
    });
    say(
        world,
        opts.quiet,
        header(&file, &params, &measures, world.size()),
    );
    warm_up(world, &opts.scene, &out_dir, &overrides[0]);
    let names: Vec<String> = params.iter().map(|(t, _)| t.name()).collect();
    let mut rows = Vec::with_capacity(overrides.len());
    for (k, ov) in overrides.into_iter().enumerate() {
        let values: Vec<f64> = params.iter().map(|(_, v)| v[k]).collect();
        let label = run_label(&names, &values);
        let rung = Rung {
            dir: out_dir.join("runs").join(dir_name(&label)),
            values,
            label,
            overrides: ov,
        };
        let row = run_rung(world, &opts.scene, &measures, rung);
        say(world, opts.quiet, progress(&row));
        rows.push(row);
    }

    let mut result = Ok(());
    if world.rank() == 0 {
        let notes = errors(&mut rows, &measures);
        let fig = SweepChart {
            title: format!(
                "{}: accuracy against cost, {} ranks",
                if scene.title.is_empty() {
                    file.clone()
                } else {
                    scene.title.clone()
                },
                world.size()
            ),
            measures: &measures,
            rows: &rows,
            notes,
        };
        result = write_csv(&out_dir.join("accuracy_cost.csv"), &names, &measures, &rows)
            .and_then(|()| chart::save(&fig, &out_dir.join("accuracy_cost")));
        if !opts.quiet {
            print_errors(&rows, &measures);
        }
        result = result.map_err(|e| format!("{file}: {e}"));
    }
    first_error(world, result.err())?;
    Ok(out_dir)
}

/// The overrides of each run (value k of every parameter in run k). A parameter the scene does
/// not have would fail every run: an error, before running.
fn run_overrides(params: &[Ladder], scene: &Scene) -> Result<Vec<RunOverrides>, String> {
    let overrides: Vec<RunOverrides> = (0..params[0].1.len())
        .map(|k| {
            let mut ov = RunOverrides::default();
            for (t, v) in params {
                t.set(&mut ov, v[k]);
            }
            ov
        })
        .collect();
    for ov in &overrides {
        ov.apply(&mut scene.clone())?;
    }
    Ok(overrides)
}

/// The sweep's first line: the ladder, the measures and the ranks.
fn header(file: &str, params: &[Ladder], measures: &[Measure], ranks: i32) -> String {
    format!(
        "tdyn sweep: {file}: {}; measures {}; {ranks} ranks",
        params
            .iter()
            .map(|(t, v)| format!(
                "{} = {}",
                t.name(),
                v.iter()
                    .map(|x| value_label(*x))
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
            .collect::<Vec<_>>()
            .join("; "),
        measures
            .iter()
            .map(|m| match m.reference {
                Some(r) => format!("{} (against {r:e})", m.name()),
                None => format!("{} (against the finest run)", m.name()),
            })
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// Runs the first value once, unrecorded. The first run of a process pays MPI's connection
/// set-up and the first touches of memory (measured: 10 ms of loop for 25 steps of 10
/// elements, then 0.5 ms).
fn warm_up(world: &SimpleCommunicator, scene: &Path, out_dir: &Path, first: &RunOverrides) {
    let warm = RunOptions {
        scene: scene.to_path_buf(),
        out: Some(out_dir.join("runs").join("warm-up")),
        quiet: true,
        overrides: first.clone(),
        setup_only: false,
        algorithms: Default::default(),
        overwrite: true,
        restart: None,
        stop: None,
    };
    let _ = driver::run(world, &warm);
}

/// A run's label: "N=20 L=1", every parameter with its value.
fn run_label(names: &[String], values: &[f64]) -> String {
    names
        .iter()
        .zip(values)
        .map(|(n, v)| format!("{n}={}", value_label(*v)))
        .collect::<Vec<_>>()
        .join(" ")
}

/// A run's folder name: its label with every character but letters, digits, `.` and `-` as
/// `_`.
fn dir_name(label: &str) -> String {
    label
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '.' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// One run of the ladder.
struct Rung {
    /// The parameters' values.
    values: Vec<f64>,
    /// Its label.
    label: String,
    /// The scene values it replaces.
    overrides: RunOverrides,
    /// Its output directory.
    dir: PathBuf,
}

/// Runs `scene` at `rung` (the peak RSS reset before, read after, max over ranks); its row,
/// with report.json's figures and the measured values on rank 0 when it finished.
fn run_rung(
    world: &SimpleCommunicator,
    scene: &Path,
    measures: &[Measure],
    rung: Rung,
) -> SweepRow {
    let o = RunOptions {
        scene: scene.to_path_buf(),
        out: Some(rung.dir.clone()),
        quiet: true,
        overrides: rung.overrides,
        setup_only: false,
        algorithms: Default::default(),
        overwrite: true,
        restart: None,
        stop: None,
    };
    world.barrier();
    coupling::driver::report::reset_peak_rss();
    let res = driver::run(world, &o)
        .map(|_| ())
        .map_err(|e| (e.kind, e.message));
    let rss = collective::max(world, coupling::driver::report::peak_rss());
    let mut row = SweepRow {
        values: rung.values,
        label: rung.label,
        status: "ok",
        message: String::new(),
        elements: 0,
        particles: 0,
        steps: 0,
        wall_s: f64::NAN,
        loop_s: f64::NAN,
        model_bytes: f64::NAN,
        rss_peak_bytes: rss,
        energy_error_max: f64::NAN,
        measured: Vec::new(),
        errors: vec![f64::NAN; measures.len()],
        reference: false,
        out: rung.dir,
    };
    match res {
        Ok(()) => {
            if world.rank() == 0 {
                if let Err(e) = read_report(&mut row, measures) {
                    row.status = "failed";
                    row.message = e;
                }
            }
        }
        Err((kind, message)) => {
            row.status = match kind {
                FailureKind::Refused => "refused",
                FailureKind::Unstable => "unstable",
                FailureKind::Failed | FailureKind::Input => "failed",
                FailureKind::Stopped => "stopped",
            };
            row.message = message;
        }
    }
    row
}

/// A run's progress line: its cost, or how it stopped.
fn progress(row: &SweepRow) -> String {
    format!(
        "  {:>16}: {}",
        row.label,
        if row.status == "ok" {
            format!(
                "ok, {} elements, {} particles, {} steps, loop {:.3e} s, wall {:.3e} s, model {:.3} MB, peak RSS {:.0} MB",
                row.elements,
                row.particles,
                row.steps,
                row.loop_s,
                row.wall_s,
                row.model_bytes / 1e6,
                row.rss_peak_bytes / 1e6
            )
        } else {
            format!("{}: {}", row.status, row.message)
        }
    )
}

/// Prints each finished run's errors, one line per run.
fn print_errors(rows: &[SweepRow], measures: &[Measure]) {
    for r in rows.iter().filter(|r| r.status == "ok") {
        let e: Vec<String> = measures
            .iter()
            .zip(&r.errors)
            .map(|(m, e)| format!("{} {}", m.name(), fmt_error(*e, r.reference)))
            .collect();
        println!("  {:>16}: error {}", r.label, e.join(", "));
    }
}

/// An error as the terminal shows it: "(reference)" for the reference run's 0, "-" when not
/// measured.
fn fmt_error(e: f64, reference: bool) -> String {
    if reference && e == 0.0 {
        "(reference)".into()
    } else if e.is_finite() {
        format!("{e:.3e}")
    } else {
        "-".into()
    }
}

/// Fills a finished row from its report.json and outputs (rank 0).
fn read_report(row: &mut SweepRow, measures: &[Measure]) -> Result<(), String> {
    let path = row.out.join("report.json");
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let r: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    let f = |k: &str| r.get(k).and_then(|v| v.as_f64()).unwrap_or(f64::NAN);
    let u = |k: &str| r.get(k).and_then(|v| v.as_u64()).unwrap_or(0);
    row.elements = u("elements");
    row.particles = u("particles");
    row.steps = u("steps");
    row.wall_s = f("wall_s");
    row.loop_s = f("loop_s");
    row.energy_error_max = f("energy_error_max");
    row.model_bytes = if row.elements > 0 {
        f("bytes_per_element") * row.elements as f64
    } else {
        f64::NAN
    };
    row.measured = measures
        .iter()
        .map(|m| m.value(&row.out))
        .collect::<Result<_, _>>()?;
    Ok(())
}

/// Fills the errors; returns one note per measure saying what it is compared with.
fn errors(rows: &mut [SweepRow], measures: &[Measure]) -> Vec<String> {
    let finest = rows
        .iter()
        .enumerate()
        .filter(|(_, r)| r.status == "ok")
        .max_by_key(|(_, r)| r.elements + r.particles)
        .map(|(i, _)| i);
    let mut notes = Vec::new();
    let mut against_finest = Vec::new();
    for (j, m) in measures.iter().enumerate() {
        let (reference, scale) = match (m.reference, finest) {
            (Some(r), _) => {
                notes.push(format!("{}: against {r:e}", m.name()));
                (r, r.abs())
            }
            (None, Some(i)) => {
                rows[i].reference = true;
                against_finest.push(m.name());
                let (q, s) = rows[i].measured[j];
                (q, s.max(1e-300))
            }
            (None, None) => {
                notes.push(format!("{}: no run finished", m.name()));
                continue;
            }
        };
        for r in rows.iter_mut().filter(|r| r.status == "ok") {
            r.errors[j] = (r.measured[j].0 - reference).abs() / scale;
        }
    }
    if let (Some(i), false) = (finest, against_finest.is_empty()) {
        notes.push(format!(
            "{} against the finest run, {} (dashed)",
            if against_finest.len() == measures.len() {
                "all".to_string()
            } else {
                against_finest.join(", ")
            },
            rows[i].label
        ));
    }
    notes
}

fn write_csv(
    path: &Path,
    names: &[String],
    measures: &[Measure],
    rows: &[SweepRow],
) -> Result<(), String> {
    use std::fmt::Write as _;
    if let Some(d) = path.parent() {
        std::fs::create_dir_all(d).map_err(|e| format!("{}: {e}", d.display()))?;
    }
    let mut s = String::from("label");
    for n in names {
        let _ = write!(s, ",{n}");
    }
    s.push_str(",status,elements,particles,steps,wall_s,loop_s,model_bytes,rss_peak_bytes,energy_error_max");
    for m in measures {
        let _ = write!(s, ",{0}_value,{0}_error", m.name());
    }
    s.push_str(",reference,dir,message\n");
    let num = |v: f64| {
        if v.is_finite() {
            format!("{v:e}")
        } else {
            String::new()
        }
    };
    for r in rows {
        let _ = write!(s, "\"{}\"", r.label);
        for v in &r.values {
            let _ = write!(s, ",{v}");
        }
        let _ = write!(
            s,
            ",{},{},{},{},{},{},{},{},{}",
            r.status,
            r.elements,
            r.particles,
            r.steps,
            num(r.wall_s),
            num(r.loop_s),
            num(r.model_bytes),
            num(r.rss_peak_bytes),
            num(r.energy_error_max)
        );
        for (j, _) in measures.iter().enumerate() {
            let v = r.measured.get(j).map(|m| m.0).unwrap_or(f64::NAN);
            let _ = write!(s, ",{},{}", num(v), num(r.errors[j]));
        }
        let _ = writeln!(
            s,
            ",{},\"{}\",\"{}\"",
            r.reference,
            r.out.display(),
            r.message.replace('"', "'")
        );
    }
    std::fs::write(path, s).map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests;
