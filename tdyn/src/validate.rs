//! `tdyn validate`: the validation suite. Each case is a folder `validation/<case>/` holding a
//! `reference.toml` (what to run, what to measure, the reference with its source, the tolerance
//! and why) and any reference curve it names. The suite runs every case (`mpirun -np N tdyn run`
//! per resolution of the case's ladder, or `tdyn crosscheck` for a case against LIGGGHTS),
//! measures the outputs, and writes `report.md` with one row per (case, resolution, measure):
//! ours, the reference, the error, the allowed error and pass/fail, and one chart per case (the
//! measure against resolution inside the reference's band, PNG and SVG). It fails when a judged
//! measure is out of its tolerance or a run fails.
//!
//! Like `tdyn crosscheck`, this process does not join MPI: it launches its runs as children.
//!
//! reference.toml (docs/validation.md has the full format):
//!
//! ```toml
//! title = "Copper Taylor bar"
//! fast = true                       # runs under --fast (default true)
//! [run]
//! scene = "../../scenes/taylor_copper.toml"   # relative to this file
//! params = []                       # extra `tdyn run --param` specs for every run
//! # crosscheck = { deck = "../../scenes/liggghts/in.random1step" }   (instead of tdyn run)
//! [ladder]                          # optional: resolutions, swept together like `tdyn sweep`
//! params = ["N=4,6,8,12"]
//! fast = [6]                        # the first parameter's values run under --fast
//! [[measure]]
//! name = "final length"
//! column = "tail.displacement_z"    # probes.csv, else history.csv (or `file = ...`)
//! how = "final"                     # final | peak | max | min | arrival | plateau | period
//! # particles = { of = "z", reduce = "max", near_min_z = 2e-4 }   (instead of column and how:
//! #   a reduction over the last frame's particles; of = x | y | z | radius_z)
//! offset = 0.0324                   # the value is offset + scale x what `how` finds
//! range = [0.02142, 0.02147]        # the reference: `reference = x`, `range` (its midpoint),
//!                                   # or `curve = { file, x, y, at }` (interpolated at `at`)
//! allowed = 0.02                    # relative (or `allowed_abs`); one per `at` rung if a list
//! at = [6]                          # rungs judged (the first ladder parameter's values)
//! source = "Simo & Armero 1992 ..."
//! why = "..."
//! ```
use crate::chart::{self, Figure};
use crate::compare::{period, read_column};
use crate::launch::{run_logged, tdyn, tdyn_run};
use crate::sweep::parse_param;
use serde::Deserialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

mod figure;
mod report;
use figure::CaseChart;
use report::report_md;

/// What `tdyn validate` was asked.
#[derive(Debug, Clone)]
pub struct ValidateOptions {
    /// The cases' folder (default `validation`).
    pub dir: PathBuf,
    /// Case names to run (empty: all, in name order).
    pub cases: Vec<String>,
    /// Ranks per run.
    pub np: usize,
    /// Coarse meshes: the ladder's `fast` rungs, and only the cases with `fast = true`.
    pub fast: bool,
    /// Output directory (default `out/validation`).
    pub out: PathBuf,
    /// No progress lines.
    pub quiet: bool,
}

/// A case's reference.toml.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseDef {
    /// One line: what the case is.
    pub title: String,
    /// Runs under `--fast` (default true).
    #[serde(default = "yes")]
    pub fast: bool,
    /// What to run.
    pub run: RunDef,
    /// Resolutions (none: one run).
    pub ladder: Option<LadderDef>,
    /// What to measure.
    pub measure: Vec<MeasureDef>,
}

fn yes() -> bool {
    true
}

fn one() -> f64 {
    1.0
}

/// What a case runs.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunDef {
    /// The scene, relative to reference.toml.
    pub scene: PathBuf,
    /// `tdyn run --param` specs for every run.
    #[serde(default)]
    pub params: Vec<String>,
    /// Replaces the scene's `run.end_time`.
    pub end_time: Option<f64>,
    /// Run `tdyn crosscheck` with this LIGGGHTS deck instead of `tdyn run`.
    pub crosscheck: Option<CrosscheckDef>,
}

/// A cross-check against LIGGGHTS.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CrosscheckDef {
    /// The deck, relative to reference.toml.
    pub deck: PathBuf,
    /// LIGGGHTS's ranks.
    #[serde(default = "one_rank")]
    pub liggghts_np: usize,
}

fn one_rank() -> usize {
    1
}

/// A refinement ladder.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LadderDef {
    /// `NAME=v1,v2,...` specs (as `tdyn sweep --param`), swept together.
    pub params: Vec<String>,
    /// Values of the first parameter run under `--fast` (default: the first).
    #[serde(default)]
    pub fast: Vec<f64>,
}

/// A tolerance: one for every judged rung, or one per rung of `at`.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum Allowed {
    /// The same at every judged rung.
    One(f64),
    /// One per value of `at`.
    PerRung(Vec<f64>),
}

/// A reference curve: `y` interpolated at `at` in the column `x` of a CSV beside the case.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurveDef {
    /// The CSV file (header row; `#` lines are comments), relative to reference.toml.
    pub file: PathBuf,
    /// The abscissa's column.
    pub x: String,
    /// The ordinate's column.
    pub y: String,
    /// Where the reference is read.
    pub at: f64,
}

/// A judged measure's tolerance: (relative to the reference, absolute).
pub type Tolerance = (Option<f64>, Option<f64>);

/// One measure of a case.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasureDef {
    /// As the report shows it.
    pub name: String,
    /// The column (probes.csv, else history.csv, unless `file` says); empty with `particles`.
    #[serde(default)]
    pub column: String,
    /// The output file holding the column (e.g. crosscheck.csv).
    pub file: Option<String>,
    /// final | peak | max | min | arrival | plateau | period (not with `particles`).
    #[serde(default)]
    pub how: String,
    /// Instead of a column: a reduction over the particles of the last frame of fields.h5.
    pub particles: Option<ParticlesMeasure>,
    /// arrival: the level the column crosses (after `offset` and `scale`).
    pub level: Option<f64>,
    /// plateau: the time window averaged, s.
    pub window: Option<[f64; 2]>,
    /// Added to the value (e.g. the initial length to a displacement).
    #[serde(default)]
    pub offset: f64,
    /// Multiplies the column before `offset` is added.
    #[serde(default = "one")]
    pub scale: f64,
    /// The reference value.
    pub reference: Option<f64>,
    /// A reference range (published values that differ): its midpoint is the reference.
    pub range: Option<[f64; 2]>,
    /// A reference curve read at one point.
    pub curve: Option<CurveDef>,
    /// Unit, for the report.
    #[serde(default)]
    pub unit: String,
    /// Relative tolerance (of the reference).
    pub allowed: Option<Allowed>,
    /// Absolute tolerance (for references of zero).
    pub allowed_abs: Option<f64>,
    /// Rungs judged, as values of the ladder's first parameter (default: every rung).
    pub at: Option<Vec<f64>>,
    /// Where the reference comes from.
    pub source: String,
    /// Why the tolerance is what it is.
    pub why: String,
}

/// A measure over the particles of a run's last frame (`particles/position` in fields.h5):
/// `reduce` of `of` over the particles (those whose z lies within `near_min_z` of the lowest
/// one's, if given); then `offset` and `scale` as for a column.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParticlesMeasure {
    /// "x", "y", "z" (a coordinate, m) or "radius_z" (the distance from the z axis, m).
    pub of: String,
    /// "max" or "min".
    pub reduce: String,
    /// Only the particles with z <= (the lowest z) + this, m (e.g. a bar's foot layer).
    pub near_min_z: Option<f64>,
}

impl ParticlesMeasure {
    /// The value over the last frame's particles of `dir/fields.h5`.
    fn value(&self, dir: &Path) -> Result<f64, String> {
        let file = dir.join("fields.h5");
        let e = |x: hdf5::Error| format!("{}: {x}", file.display());
        let f = hdf5::File::open(&file).map_err(e)?;
        let mut names = f.group("frames").map_err(e)?.member_names().map_err(e)?;
        names.sort();
        let last = names
            .last()
            .ok_or_else(|| format!("{}: no frames", file.display()))?;
        let x: Vec<f64> = f
            .dataset(&format!("frames/{last}/particles/position"))
            .map_err(e)?
            .read_raw()
            .map_err(e)?;
        let pts: Vec<&[f64]> = x.chunks_exact(3).collect();
        let zmin = pts.iter().map(|p| p[2]).fold(f64::INFINITY, f64::min);
        let of = |p: &[f64]| -> Result<f64, String> {
            Ok(match self.of.as_str() {
                "x" => p[0],
                "y" => p[1],
                "z" => p[2],
                "radius_z" => p[0].hypot(p[1]),
                o => return Err(format!("particles.of = \"{o}\" (x, y, z, radius_z)")),
            })
        };
        let mut vals = Vec::with_capacity(pts.len());
        for p in pts
            .iter()
            .filter(|p| self.near_min_z.is_none_or(|d| p[2] <= zmin + d))
        {
            vals.push(of(p)?);
        }
        let v = match self.reduce.as_str() {
            "max" => vals.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            "min" => vals.iter().copied().fold(f64::INFINITY, f64::min),
            r => return Err(format!("particles.reduce = \"{r}\" (max, min)")),
        };
        v.is_finite()
            .then_some(v)
            .ok_or_else(|| format!("{}: no particles in the last frame", file.display()))
    }
}

impl MeasureDef {
    /// What is measured, for the report: "final of `tail.displacement_z`", or the particles'.
    pub fn what(&self) -> String {
        match &self.particles {
            Some(p) => format!(
                "{} of the particles' {} in the last frame{}",
                p.reduce,
                p.of,
                p.near_min_z
                    .map(|d| format!(", those within {d} m of the lowest"))
                    .unwrap_or_default()
            ),
            None => format!("{} of `{}`", self.how, self.column),
        }
    }

    /// The chart's axis label: `how`, or the particles' reduction.
    pub fn axis(&self) -> String {
        match &self.particles {
            Some(p) => format!("{} {}", p.reduce, p.of),
            None => self.how.clone(),
        }
    }

    /// The reference value, its band (range, else the value itself) and a description.
    fn reference(&self, case_dir: &Path) -> Result<(f64, [f64; 2]), String> {
        match (self.reference, self.range, &self.curve) {
            (Some(r), None, None) => Ok((r, [r, r])),
            (None, Some([a, b]), None) => Ok((0.5 * (a + b), [a.min(b), a.max(b)])),
            (None, None, Some(c)) => {
                let path = case_dir.join(&c.file);
                let (x, y) = (read_column(&path, &c.x)?, read_column(&path, &c.y)?);
                let r = interpolate_inside(&x, &y, c.at).ok_or_else(|| {
                    format!(
                        "{}: {} = {} is outside the curve",
                        path.display(),
                        c.x,
                        c.at
                    )
                })?;
                Ok((r, [r, r]))
            }
            _ => Err(format!(
                "measure \"{}\": give exactly one of reference, range, curve",
                self.name
            )),
        }
    }

    /// Whether rung `v` (the ladder's first value; None without a ladder) is judged, and with
    /// which tolerance: (relative, absolute).
    fn tolerance(&self, v: Option<f64>) -> Result<Option<Tolerance>, String> {
        let k = match (&self.at, v) {
            (None, _) => None,
            (Some(at), Some(v)) => match at.iter().position(|a| *a == v) {
                Some(k) => Some(k),
                None => return Ok(None),
            },
            (Some(_), None) => None,
        };
        let rel = match (&self.allowed, k) {
            (None, _) => None,
            (Some(Allowed::One(a)), _) => Some(*a),
            (Some(Allowed::PerRung(a)), Some(k)) => Some(*a.get(k).ok_or_else(|| {
                format!(
                    "measure \"{}\": allowed has fewer values than at",
                    self.name
                )
            })?),
            (Some(Allowed::PerRung(_)), None) => {
                return Err(format!(
                    "measure \"{}\": a list of allowed values needs at = [...] (one per rung)",
                    self.name
                ))
            }
        };
        if rel.is_none() && self.allowed_abs.is_none() {
            return Err(format!(
                "measure \"{}\": no tolerance (allowed or allowed_abs)",
                self.name
            ));
        }
        Ok(Some((rel, self.allowed_abs)))
    }

    /// The measured value from one run's output directory.
    fn value(&self, dir: &Path) -> Result<f64, String> {
        if let Some(pm) = &self.particles {
            if !self.column.is_empty() || !self.how.is_empty() {
                return Err(format!(
                    "measure \"{}\": particles replaces column and how",
                    self.name
                ));
            }
            return Ok(self.offset + self.scale * pm.value(dir)?);
        }
        let file = match &self.file {
            Some(f) => dir.join(f),
            None => {
                let probes = dir.join("probes.csv");
                let has = std::fs::read_to_string(&probes)
                    .ok()
                    .and_then(|t| {
                        t.lines()
                            .next()
                            .map(|h| h.split(',').any(|c| c == self.column))
                    })
                    .unwrap_or(false);
                if has {
                    probes
                } else {
                    dir.join("history.csv")
                }
            }
        };
        let q: Vec<f64> = read_column(&file, &self.column)?
            .into_iter()
            .map(|v| self.offset + self.scale * v)
            .collect();
        let t = || read_column(&file, "time");
        let none = || {
            format!(
                "{}: {}: no value ({})",
                file.display(),
                self.column,
                self.how
            )
        };
        let v = match self.how.as_str() {
            "final" => q.last().copied(),
            "peak" => q.iter().copied().max_by(|a, b| a.abs().total_cmp(&b.abs())),
            "max" => q.iter().copied().max_by(f64::total_cmp),
            "min" => q.iter().copied().min_by(f64::total_cmp),
            "arrival" => {
                let level = self
                    .level
                    .ok_or_else(|| format!("measure \"{}\": arrival needs level", self.name))?;
                arrival(&t()?, &q, level)
            }
            "plateau" => {
                let [a, b] = self
                    .window
                    .ok_or_else(|| format!("measure \"{}\": plateau needs window", self.name))?;
                let t = t()?;
                let inside: Vec<f64> = t
                    .iter()
                    .zip(&q)
                    .filter(|(s, _)| (a..=b).contains(*s))
                    .map(|(_, v)| *v)
                    .collect();
                (!inside.is_empty()).then(|| inside.iter().sum::<f64>() / inside.len() as f64)
            }
            "period" => period(&t()?, &q),
            h => {
                return Err(format!(
                    "measure \"{}\": unknown how = \"{h}\" (final, peak, max, min, arrival, plateau, period)",
                    self.name
                ))
            }
        };
        v.filter(|v| v.is_finite()).ok_or_else(none)
    }
}

/// The first time the series crosses `level` from the side it starts on (linear interpolation).
pub fn arrival(t: &[f64], q: &[f64], level: f64) -> Option<f64> {
    let start = (*q.first()? - level).signum();
    let k = q.iter().position(|v| (v - level).signum() != start)?;
    if k == 0 {
        return None;
    }
    let (a, b) = (q[k - 1] - level, q[k] - level);
    Some(t[k - 1] + (t[k] - t[k - 1]) * a / (a - b))
}

/// Linear interpolation of (x, y) at `at` (x increasing); None outside.
fn interpolate_inside(x: &[f64], y: &[f64], at: f64) -> Option<f64> {
    let k = x.windows(2).position(|w| w[0] <= at && at <= w[1])?;
    let w = (at - x[k]) / (x[k + 1] - x[k]);
    Some(y[k] + w * (y[k + 1] - y[k]))
}

/// One rung of a case's ladder: its label and `--param` specs.
#[derive(Debug, Clone)]
struct Rung {
    /// The first parameter's value (None without a ladder).
    value: Option<f64>,
    /// "N=6" (every swept parameter: "N=6, A=0.01"), "run" without a ladder.
    label: String,
    /// `NAME=v` for `tdyn run --param`.
    params: Vec<String>,
}

/// The outcome of one measure at one rung.
#[derive(Debug, Clone)]
pub struct Row {
    /// Case name.
    pub case: String,
    /// Rung label.
    pub rung: String,
    /// Measure name.
    pub measure: String,
    /// Ours (NaN when not measured).
    pub ours: f64,
    /// The reference value.
    pub reference: f64,
    /// Its band (a published range, else the value).
    pub band: [f64; 2],
    /// Unit.
    pub unit: String,
    /// |ours - reference| / |reference| (absolute when the reference is 0).
    pub error: f64,
    /// The tolerance when judged: (relative, absolute).
    pub allowed: Option<Tolerance>,
    /// "pass", "FAIL", "info" (not judged at this rung) or "FAIL (run)" with a message.
    pub status: String,
    /// The message of a run or measure that failed.
    pub message: String,
}

impl Row {
    /// Judged and failed.
    pub fn failed(&self) -> bool {
        self.status.starts_with("FAIL")
    }
}

/// Everything the suite found.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// One row per (case, rung, measure).
    pub rows: Vec<Row>,
    /// Cases skipped (by --fast).
    pub skipped: Vec<String>,
    /// The report's path.
    pub report: PathBuf,
}

impl Outcome {
    /// Whether every judged measure passed.
    pub fn passed(&self) -> bool {
        !self.rows.iter().any(Row::failed)
    }
}

/// The case names in `dir` (folders holding a reference.toml), sorted.
pub fn case_names(dir: &Path) -> Result<Vec<String>, String> {
    let rd = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut names: Vec<String> = rd
        .flatten()
        .filter(|e| e.path().join("reference.toml").is_file())
        .map(|e| e.file_name().to_string_lossy().to_string())
        .collect();
    names.sort();
    Ok(names)
}

/// Reads and checks `dir/<name>/reference.toml`.
pub fn load_case(dir: &Path, name: &str) -> Result<CaseDef, String> {
    let path = dir.join(name).join("reference.toml");
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let de = toml::Deserializer::new(&text);
    let case: CaseDef = serde_path_to_error::deserialize(de)
        .map_err(|e| format!("{}: {}: {}", path.display(), e.path(), e.inner().message()))?;
    if case.measure.is_empty() {
        return Err(format!("{}: no [[measure]]", path.display()));
    }
    for m in &case.measure {
        m.reference(&dir.join(name))
            .map_err(|e| format!("{}: {e}", path.display()))?;
        m.tolerance(m.at.as_ref().and_then(|a| a.first().copied()))
            .map_err(|e| format!("{}: {e}", path.display()))?;
    }
    Ok(case)
}

/// The rungs a case runs.
fn rungs(case: &CaseDef, fast: bool) -> Result<Vec<Rung>, String> {
    let Some(ladder) = &case.ladder else {
        return Ok(vec![Rung {
            value: None,
            label: "run".into(),
            params: Vec::new(),
        }]);
    };
    let params = ladder
        .params
        .iter()
        .map(|s| parse_param(s, 0))
        .collect::<Result<Vec<_>, _>>()?;
    let n = params.first().map(|p| p.1.len()).unwrap_or(0);
    if n == 0 || params.iter().any(|p| p.1.len() != n) {
        return Err(
            "ladder.params: give one or more NAME=v1,v2,... with as many values each".into(),
        );
    }
    let mut out = Vec::new();
    for k in 0..n {
        let v0 = params[0].1[k];
        let chosen = if ladder.fast.is_empty() {
            k == 0
        } else {
            ladder.fast.contains(&v0)
        };
        if fast && !chosen {
            continue;
        }
        let specs: Vec<String> = params
            .iter()
            .map(|(t, v)| format!("{}={}", t.name(), v[k]))
            .collect();
        out.push(Rung {
            value: Some(v0),
            label: specs[0].clone(),
            params: specs,
        });
    }
    Ok(out)
}

/// Runs one rung of a case into `out`; Err with the run's message when it fails.
fn run_rung(
    case_dir: &Path,
    case: &CaseDef,
    rung: &Rung,
    np: usize,
    out: &Path,
) -> Result<(), String> {
    let _ = std::fs::remove_dir_all(out);
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let scene = case_dir.join(&case.run.scene);
    let log = out.join("run.log");
    match &case.run.crosscheck {
        None => {
            let mut cmd = tdyn_run(np, &scene, out)?;
            for p in case.run.params.iter().chain(&rung.params) {
                cmd.args(["--param", p]);
            }
            if let Some(t) = case.run.end_time {
                cmd.args(["--end-time", &format!("{t:e}")]);
            }
            run_logged(cmd, &log, "tdyn run")
        }
        Some(cc) => {
            let np_s = np.to_string();
            let lnp = cc.liggghts_np.to_string();
            let mut cmd = tdyn(&["crosscheck"])?;
            cmd.arg(&scene)
                .arg("--deck")
                .arg(case_dir.join(&cc.deck))
                .args(["--np", &np_s, "--liggghts-np", &lnp, "--out"])
                .arg(out);
            run_logged(cmd, &log, "tdyn crosscheck")
        }
    }
}

/// Runs the suite; writes the report and charts. Err only for what stops the suite itself (a
/// broken reference.toml, an unknown case, an unwritable output); failed runs and measures
/// are rows.
pub fn validate(o: &ValidateOptions) -> Result<Outcome, String> {
    if o.np < 1 {
        return Err(format!("--np {}: expected at least 1 rank per run", o.np));
    }
    let all = case_names(&o.dir)?;
    // The cases --fast runs, named in the refusals below.
    let fast_cases = || -> Result<String, String> {
        let mut fast = Vec::new();
        for n in &all {
            if load_case(&o.dir, n)?.fast {
                fast.push(n.clone());
            }
        }
        Ok(fast.join(", "))
    };
    let names = if o.cases.is_empty() {
        all.clone()
    } else {
        for c in &o.cases {
            if !all.contains(c) {
                let fast = if o.fast {
                    format!("; with --fast: {}", fast_cases()?)
                } else {
                    String::new()
                };
                return Err(format!(
                    "--cases: no case \"{c}\" in {} (cases: {}{fast})",
                    o.dir.display(),
                    all.join(", ")
                ));
            }
        }
        o.cases.clone()
    };
    let cases = names
        .iter()
        .map(|n| load_case(&o.dir, n).map(|c| (n.clone(), c)))
        .collect::<Result<Vec<_>, _>>()?;
    // Nothing to run is a mistake, not an empty report over the last one.
    if o.fast && cases.iter().all(|(_, c)| !c.fast) {
        let what = if o.cases.is_empty() {
            format!("no case in {} is marked fast", o.dir.display())
        } else {
            format!(
                "--cases {}: none of them runs with --fast",
                o.cases.join(",")
            )
        };
        return Err(format!(
            "{what} (cases with --fast: {}); leave out --fast, or name one of those",
            fast_cases()?
        ));
    }
    if cases.is_empty() {
        return Err(format!("no cases in {}", o.dir.display()));
    }
    std::fs::create_dir_all(&o.out).map_err(|e| format!("{}: {e}", o.out.display()))?;
    let mut rows = Vec::new();
    let mut skipped = Vec::new();
    let mut charts = Vec::new();
    for (name, case) in &cases {
        if o.fast && !case.fast {
            skipped.push(name.clone());
            continue;
        }
        let case_dir = o.dir.join(name);
        let rungs = rungs(case, o.fast).map_err(|e| format!("{name}: {e}"))?;
        let first = rows.len();
        for rung in &rungs {
            let out = o
                .out
                .join(name)
                .join(rung.label.replace(['=', ' ', ','], "_"));
            let t0 = std::time::Instant::now();
            let ran = run_rung(&case_dir, case, rung, o.np, &out);
            if !o.quiet {
                println!(
                    "tdyn validate: {name} {}: {} ({:.1} s)",
                    rung.label,
                    if ran.is_ok() { "ran" } else { "failed" },
                    t0.elapsed().as_secs_f64()
                );
            }
            for m in &case.measure {
                rows.push(measure_row(
                    name,
                    &case_dir,
                    m,
                    rung,
                    &out,
                    ran.as_ref().err(),
                )?);
            }
        }
        let chart = CaseChart {
            title: format!("{name}: {} ({} ranks)", case.title, o.np),
            measures: &case.measure,
            rows: &rows[first..],
        };
        let stem = o.out.join(name);
        chart::save(&chart, &stem)?;
        charts.push(name.clone());
    }
    let report = o.out.join("report.md");
    std::fs::write(&report, report_md(o, &cases, &rows, &skipped, &charts))
        .map_err(|e| format!("{}: {e}", report.display()))?;
    Ok(Outcome {
        rows,
        skipped,
        report,
    })
}

/// Measures `m` on a run (or records why not).
fn measure_row(
    case: &str,
    case_dir: &Path,
    m: &MeasureDef,
    rung: &Rung,
    out: &Path,
    run_error: Option<&String>,
) -> Result<Row, String> {
    let (reference, band) = m.reference(case_dir)?;
    let allowed = m.tolerance(rung.value)?;
    let mut row = Row {
        case: case.to_string(),
        rung: rung.label.clone(),
        measure: m.name.clone(),
        ours: f64::NAN,
        reference,
        band,
        unit: m.unit.clone(),
        error: f64::NAN,
        allowed,
        status: String::new(),
        message: String::new(),
    };
    let measured = match run_error {
        Some(e) => Err(e.clone()),
        None => m.value(out),
    };
    match measured {
        Err(e) => {
            row.status = if allowed.is_some() {
                "FAIL (not measured)".into()
            } else {
                "not measured".into()
            };
            row.message = e;
        }
        Ok(v) => {
            row.ours = v;
            let d = (v - reference).abs();
            row.error = if reference != 0.0 {
                d / reference.abs()
            } else {
                d
            };
            row.status = match allowed {
                None => "info".into(),
                Some((rel, abs)) => {
                    let ok =
                        rel.is_none_or(|a| d <= a * reference.abs()) && abs.is_none_or(|a| d <= a);
                    if ok { "pass" } else { "FAIL" }.into()
                }
            };
        }
    }
    Ok(row)
}

/// A number for the report: 4 significant digits.
fn num(v: f64) -> String {
    if !v.is_finite() {
        "-".into()
    } else if v == 0.0 {
        "0".into()
    } else if (1e-3..1e5).contains(&v.abs()) {
        let digits = (3 - v.abs().log10().floor() as i32).max(0) as usize;
        format!("{v:.digits$}")
    } else {
        format!("{v:.3e}")
    }
}

/// The tolerance as the report shows it.
fn allowed_text(a: Option<Tolerance>, unit: &str) -> String {
    match a {
        None => "(not judged)".into(),
        Some((rel, abs)) => {
            let mut parts = Vec::new();
            if let Some(r) = rel {
                parts.push(format!("{} %", num(100.0 * r)));
            }
            if let Some(a) = abs {
                parts.push(format!("{} {unit}", num(a)).trim_end().to_string());
            }
            parts.join(" and ")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arrival_interpolates_the_first_crossing() {
        let t = [0.0, 1.0, 2.0, 3.0];
        let q = [0.0, 0.0, -2.0, -2.0];
        assert_eq!(arrival(&t, &q, -1.0), Some(1.5));
        assert_eq!(arrival(&t, &q, -3.0), None);
    }

    #[test]
    fn every_case_in_the_repository_loads() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../validation");
        let names = case_names(&dir).unwrap();
        assert!(names.len() >= 5, "cases: {names:?}");
        for n in &names {
            let c = load_case(&dir, n).unwrap();
            assert!(
                dir.join(n).join(&c.run.scene).is_file(),
                "{n}: scene {}",
                c.run.scene.display()
            );
            rungs(&c, false).unwrap();
            rungs(&c, true).unwrap();
        }
    }
}
