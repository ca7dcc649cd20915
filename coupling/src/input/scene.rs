//! The scene file (SCENE.md): parsed with serde (unknown keys refused, with their path), then
//! checked as a whole. Every error names the file, the key and what was expected.
use fe_petsc::material::{EosSpec, MaterialSpec};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A mistake in a scene file: `<file>: <key>: <what was expected>`.
#[derive(Debug, Clone, thiserror::Error)]
#[error("{file}: {key}: {message}")]
pub struct SceneError {
    /// The scene file.
    pub file: String,
    /// The key path, e.g. `run.end_time` or `material[1].model`.
    pub key: String,
    /// What is wrong and what was expected.
    pub message: String,
}

/// Integration mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Central differences.
    Explicit,
    /// Newmark through PETSc KSP.
    Implicit,
}

/// Bulk-viscosity coefficients.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BulkViscosity {
    /// Linear coefficient (default 0.06).
    #[serde(default = "d_bv_lin")]
    pub linear: f64,
    /// Quadratic coefficient (default 1.2).
    #[serde(default = "d_bv_quad")]
    pub quadratic: f64,
}

/// `run.hourglass`: the kind of hourglass control and its coefficient (docs/scene.md).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Hourglass {
    /// "physical" (default), "stiffness" or "viscous".
    #[serde(default = "d_hg_kind")]
    pub kind: String,
    /// The kind's coefficient: physical 1 (a multiplier of the physical stiffness), stiffness
    /// 0.05, viscous 0.1 by default.
    #[serde(default)]
    pub coefficient: Option<f64>,
}

/// The hourglass kinds a scene may name.
pub const HOURGLASS_KINDS: [&str; 3] = ["physical", "stiffness", "viscous"];

impl Hourglass {
    /// The element's hourglass control (the kind checked by `parse`).
    pub fn control(&self) -> fe_petsc::hourglass::Hourglass {
        use fe_petsc::hourglass::{Hourglass as H, DEFAULT_STIFFNESS, DEFAULT_VISCOUS};
        match self.kind.as_str() {
            "stiffness" => H::Stiffness {
                coefficient: self.coefficient.unwrap_or(DEFAULT_STIFFNESS),
            },
            "viscous" => H::Viscous {
                coefficient: self.coefficient.unwrap_or(DEFAULT_VISCOUS),
            },
            _ => H::Physical {
                scale: self.coefficient.unwrap_or(1.0),
            },
        }
    }
}

fn d_bv_lin() -> f64 {
    0.06
}
fn d_bv_quad() -> f64 {
    1.2
}
fn d_hg_kind() -> String {
    "physical".into()
}
fn d_safety() -> f64 {
    0.9
}
fn d_max_err() -> f64 {
    0.05
}
fn d_mode() -> Mode {
    Mode::Explicit
}
fn d_bv() -> BulkViscosity {
    BulkViscosity {
        linear: d_bv_lin(),
        quadratic: d_bv_quad(),
    }
}
fn d_hg() -> Hourglass {
    Hourglass {
        kind: d_hg_kind(),
        coefficient: None,
    }
}
fn d_h_factor() -> f64 {
    1.2
}

/// `[run]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Run {
    /// End time, s.
    pub end_time: f64,
    /// Explicit or implicit.
    #[serde(default = "d_mode")]
    pub mode: Mode,
    /// Fraction of the stable step (explicit).
    #[serde(default = "d_safety")]
    pub dt_safety: f64,
    /// Fixed step, s.
    #[serde(default)]
    pub dt: Option<f64>,
    /// `force_dt = true` (explicit): run a fixed `dt` above the stable limit instead of refusing
    /// it (with a warning); the energy check then stops the run when it blows up. Default false.
    #[serde(default)]
    pub force_dt: bool,
    /// Seconds between field frames (None: first and last only).
    #[serde(default)]
    pub output_every: Option<f64>,
    /// Seconds between history rows (0: every step).
    #[serde(default)]
    pub history_every: f64,
    /// Stop past this energy error.
    #[serde(default = "d_max_err")]
    pub max_energy_error: f64,
    /// Bulk viscosity.
    #[serde(default = "d_bv")]
    pub bulk_viscosity: BulkViscosity,
    /// Hourglass control.
    #[serde(default = "d_hg")]
    pub hourglass: Hourglass,
}

/// `[compare]` (optional): what `tdyn compare` measures.
///
/// ```toml
/// [compare]
/// quantity = "tip.displacement_x"   # a probes.csv column; default: the first probe column
/// measure = "period"                 # "period" | "history" | "final"; default "history"
/// reference_period = 6.827e-4        # s, an analytic period (measure = "period"); without it
///                                    # the reference is the run with the smallest step
/// ```
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CompareDef {
    /// The probes.csv column compared, `probe.field`.
    #[serde(default)]
    pub quantity: Option<String>,
    /// How runs are compared.
    #[serde(default = "d_measure")]
    pub measure: String,
    /// Analytic period, s.
    #[serde(default)]
    pub reference_period: Option<f64>,
}

/// `[compare] measure` values.
pub const COMPARE_MEASURES: [&str; 3] = ["period", "history", "final"];

fn d_measure() -> String {
    "history".into()
}

/// `[sweep]` (optional, beyond SCENE.md): the ladder `tdyn sweep` runs when the command line
/// gives none, in the command line's syntax (parsed and checked by `tdyn sweep`).
///
/// ```toml
/// [sweep]
/// param = ["N=10,20,40,80"]                   # as --param: [K:]NAME=v1,v2,... or particles.spacing=...
/// measure = ["mid.stress_xx:final=-4.599e7"]  # as --measure: COLUMN[:peak|final][=REFERENCE]
/// ```
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepDef {
    /// Swept parameters (several: swept together, the same number of values each).
    #[serde(default)]
    pub param: Vec<String>,
    /// Accuracy measures.
    #[serde(default)]
    pub measure: Vec<String>,
}

/// `[[mesh]]`.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshDef {
    /// The .geo or .msh file, resolved against the scene's directory.
    pub file: PathBuf,
    /// gmsh `-setnumber` parameters.
    pub params: BTreeMap<String, f64>,
    /// Translation, m.
    pub translate: [f64; 3],
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMesh {
    file: PathBuf,
    #[serde(default)]
    params: BTreeMap<String, f64>,
    #[serde(default)]
    translate: [f64; 3],
}

/// `[[block]]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Block {
    /// Physical volume name.
    pub group: String,
    /// Material name.
    pub material: String,
    /// Initial velocity, m/s.
    #[serde(default)]
    pub velocity: [f64; 3],
}

/// Boundary condition kinds.
#[derive(Debug, Clone, PartialEq)]
pub enum BoundaryKind {
    /// All components zero.
    Fixed,
    /// All three components prescribed.
    Velocity([f64; 3]),
    /// Zero normal velocity on a plane.
    Symmetry,
}

/// `[[boundary]]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Boundary {
    /// Physical surface name.
    pub group: String,
    /// The condition.
    pub kind: BoundaryKind,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBoundary {
    group: String,
    kind: String,
    #[serde(default)]
    velocity: Option<[f64; 3]>,
}

/// A probe field (SCENE.md list).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
#[allow(missing_docs)]
pub enum ProbeField {
    DisplacementX,
    DisplacementY,
    DisplacementZ,
    VelocityX,
    VelocityY,
    VelocityZ,
    StressXx,
    StressYy,
    StressZz,
    StressXy,
    StressYz,
    StressZx,
    Pressure,
    PlasticStrain,
    Density,
}

impl ProbeField {
    /// Every field with its column name.
    pub const ALL: [(ProbeField, &'static str); 15] = [
        (ProbeField::DisplacementX, "displacement_x"),
        (ProbeField::DisplacementY, "displacement_y"),
        (ProbeField::DisplacementZ, "displacement_z"),
        (ProbeField::VelocityX, "velocity_x"),
        (ProbeField::VelocityY, "velocity_y"),
        (ProbeField::VelocityZ, "velocity_z"),
        (ProbeField::StressXx, "stress_xx"),
        (ProbeField::StressYy, "stress_yy"),
        (ProbeField::StressZz, "stress_zz"),
        (ProbeField::StressXy, "stress_xy"),
        (ProbeField::StressYz, "stress_yz"),
        (ProbeField::StressZx, "stress_zx"),
        (ProbeField::Pressure, "pressure"),
        (ProbeField::PlasticStrain, "plastic_strain"),
        (ProbeField::Density, "density"),
    ];
    /// The column suffix.
    pub fn name(&self) -> &'static str {
        ProbeField::ALL.iter().find(|(f, _)| f == self).unwrap().1
    }
}

/// `[[probe]]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Probe {
    /// Name (column prefix).
    pub name: String,
    /// Point, m.
    pub point: [f64; 3],
    /// Fields.
    pub fields: Vec<ProbeField>,
}

/// Output fields (SCENE.md `[output] fields`).
pub const OUTPUT_FIELDS: [&str; 7] = [
    "displacement",
    "velocity",
    "stress",
    "plastic_strain",
    "pressure",
    "density",
    "rank",
];

/// `[output]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputDef {
    /// Fields to write (default: all).
    #[serde(default = "d_fields")]
    pub fields: Vec<String>,
    /// Beyond SCENE.md: every this many steps (and at step 0), the particles as a LIGGGHTS
    /// `dump custom` text file `dumps/dump.tdyn.<step>`; 0 (default) = none.
    #[serde(default)]
    pub dump_every: u64,
    /// Every this many seconds of simulated time, a restart checkpoint in `checkpoint/` (also
    /// at the end, and always at a clean stop); None (default): only at a clean stop.
    #[serde(default)]
    pub checkpoint_every: Option<f64>,
}

fn d_fields() -> Vec<String> {
    OUTPUT_FIELDS.iter().map(|s| s.to_string()).collect()
}

impl Default for OutputDef {
    fn default() -> Self {
        OutputDef {
            fields: d_fields(),
            dump_every: 0,
            checkpoint_every: None,
        }
    }
}

/// A particle region.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
#[allow(missing_docs)]
pub enum Region {
    Box {
        min: [f64; 3],
        max: [f64; 3],
    },
    Cylinder {
        base: [f64; 3],
        axis: [f64; 3],
        radius: f64,
    },
    Sphere {
        center: [f64; 3],
        radius: f64,
    },
    File(PathBuf),
}

/// `[[particles]]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParticlesDef {
    /// Name.
    pub name: String,
    /// Material (with an eos).
    pub material: String,
    /// Region.
    pub region: Region,
    /// Lattice spacing, m.
    pub spacing: f64,
    /// h = h_factor * spacing.
    #[serde(default = "d_h_factor")]
    pub h_factor: f64,
    /// Initial velocity.
    #[serde(default)]
    pub velocity: [f64; 3],
    /// Boundary particles.
    #[serde(default)]
    pub fixed: bool,
    /// Beyond SCENE.md: `region.file` is a LIGGGHTS `atom_style sph` data file (Atoms lines
    /// `id type rho 0 x y z 0 0`, Masses, optional Velocities) and this entry takes its atoms of
    /// this type (for the cross-check against LIGGGHTS on the very same particles).
    #[serde(default)]
    pub liggghts_type: Option<u32>,
}

/// Monaghan viscosity.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct ArtificialViscosity {
    pub alpha: f64,
    #[serde(default)]
    pub beta: f64,
}

/// Tensile correction.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct TensileCorrection {
    pub epsilon: f64,
}

/// Periodic box.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct Periodic {
    pub axes: [bool; 3],
    pub min: [f64; 3],
    pub max: [f64; 3],
}

/// `[sph]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct SphDef {
    #[serde(default = "d_kernel")]
    pub kernel: String,
    #[serde(default = "d_density")]
    pub density: String,
    #[serde(default)]
    pub energy: bool,
    #[serde(default)]
    pub artificial_viscosity: Option<ArtificialViscosity>,
    #[serde(default)]
    pub tensile_correction: Option<TensileCorrection>,
    #[serde(default)]
    pub periodic: Option<Periodic>,
    #[serde(default = "d_profile")]
    pub profile: String,
    /// Beyond SCENE.md: h = adaptive_h (m/rho)^(1/3) after every step (standard profile).
    #[serde(default)]
    pub adaptive_h: Option<f64>,
    /// Beyond SCENE.md: artificial thermal conductivity alpha_u (Price 2008), energy equation on.
    #[serde(default)]
    pub conductivity: Option<f64>,
}
fn d_kernel() -> String {
    "cubic_spline".into()
}
fn d_density() -> String {
    "continuity".into()
}
fn d_profile() -> String {
    "standard".into()
}

/// `[contact]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct ContactDef {
    pub surfaces: Vec<String>,
    #[serde(default)]
    pub self_contact: bool,
    #[serde(default)]
    pub particles: bool,
    /// Coulomb's coefficient between all contact pairs (static and kinetic), default 0.
    #[serde(default)]
    pub friction: f64,
    /// 2 (default): every pair of bodies searched both ways; 1: one pass, the other bodies'
    /// nodes against the faces of the `master` bodies only.
    #[serde(default = "d_passes")]
    pub passes: i64,
    /// With `passes = 1`: the physical volumes whose bodies are masters.
    #[serde(default)]
    pub master: Vec<String>,
}
fn d_passes() -> i64 {
    2
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    #[serde(default)]
    title: String,
    #[serde(default)]
    gravity: [f64; 3],
    run: Run,
    #[serde(default)]
    mesh: Vec<RawMesh>,
    #[serde(default)]
    material: Vec<toml::Table>,
    #[serde(default)]
    block: Vec<Block>,
    #[serde(default)]
    boundary: Vec<RawBoundary>,
    #[serde(default)]
    particles: Vec<ParticlesDef>,
    #[serde(default)]
    sph: Option<SphDef>,
    #[serde(default)]
    contact: Option<ContactDef>,
    #[serde(default)]
    probe: Vec<Probe>,
    #[serde(default)]
    output: OutputDef,
    #[serde(default)]
    compare: Option<CompareDef>,
    #[serde(default)]
    sweep: Option<SweepDef>,
}

/// A checked scene.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The scene file.
    pub file: PathBuf,
    /// Its directory (relative paths start here).
    pub dir: PathBuf,
    /// Title.
    pub title: String,
    /// Gravity, m/s^2.
    pub gravity: [f64; 3],
    /// `[run]`.
    pub run: Run,
    /// `[[mesh]]`.
    pub meshes: Vec<MeshDef>,
    /// `[[material]]`.
    pub materials: Vec<MaterialSpec>,
    /// `[[block]]`.
    pub blocks: Vec<Block>,
    /// `[[boundary]]`.
    pub boundaries: Vec<Boundary>,
    /// `[[particles]]`.
    pub particles: Vec<ParticlesDef>,
    /// `[sph]`.
    pub sph: Option<SphDef>,
    /// `[contact]`.
    pub contact: Option<ContactDef>,
    /// `[[probe]]`.
    pub probes: Vec<Probe>,
    /// `[output]`.
    pub output: OutputDef,
    /// `[compare]`.
    pub compare: Option<CompareDef>,
    /// `[sweep]` (beyond SCENE.md).
    pub sweep: Option<SweepDef>,
}

/// Reads and checks a scene file.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|e| SceneError {
        file: path.display().to_string(),
        key: "(file)".into(),
        message: format!("cannot read the scene file: {e}"),
    })?;
    parse(&text, path)
}

/// Model keys by model (besides `name`, `model`, `density`, `eos`).
const MODEL_KEYS: &[(&str, &[&str])] = &[
    ("elastic", &["youngs_modulus", "poisson_ratio"]),
    (
        "j2_plastic",
        &[
            "youngs_modulus",
            "poisson_ratio",
            "yield_stress",
            "hardening_modulus",
        ],
    ),
    (
        "johnson_cook",
        &[
            "youngs_modulus",
            "poisson_ratio",
            "a",
            "b",
            "n",
            "c",
            "eps_dot0",
        ],
    ),
    ("fluid", &[]),
];

/// Parses scene text; `file` names it in errors and anchors relative paths.
pub fn parse(text: &str, file: &Path) -> Result<Scene, SceneError> {
    let fname = file.display().to_string();
    let err = |key: &str, message: String| SceneError {
        file: fname.clone(),
        key: key.to_string(),
        message,
    };
    let de = toml::Deserializer::new(text);
    let raw: RawScene = serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        let msg = inner.message().trim().to_string();
        let key = if path.is_empty() || path == "." {
            "(scene)".to_string()
        } else {
            path
        };
        err(&key, msg)
    })?;
    let dir = file.parent().unwrap_or(Path::new(".")).to_path_buf();

    let r = &raw.run;
    let pos = |v: f64| v > 0.0 && v.is_finite();
    if !pos(r.end_time) {
        return Err(err(
            "run.end_time",
            format!("expected a positive number of seconds, got {}", r.end_time),
        ));
    }
    if !(r.dt_safety > 0.0 && r.dt_safety <= 1.0) {
        return Err(err(
            "run.dt_safety",
            format!("expected a fraction in (0, 1], got {}", r.dt_safety),
        ));
    }
    if let Some(dt) = r.dt {
        if !pos(dt) {
            return Err(err(
                "run.dt",
                format!("expected a positive step in seconds, got {dt}"),
            ));
        }
    } else if r.mode == Mode::Implicit {
        return Err(err(
            "run.dt",
            "mode = \"implicit\" needs a fixed step run.dt (seconds)".into(),
        ));
    }
    if let Some(o) = r.output_every {
        if !pos(o) {
            return Err(err(
                "run.output_every",
                format!("expected a positive interval in seconds, got {o}"),
            ));
        }
    }
    if !(r.history_every >= 0.0 && r.history_every.is_finite()) {
        return Err(err(
            "run.history_every",
            format!("expected seconds >= 0, got {}", r.history_every),
        ));
    }
    if !pos(r.max_energy_error) {
        return Err(err(
            "run.max_energy_error",
            format!("expected a positive fraction, got {}", r.max_energy_error),
        ));
    }
    for (k, v) in [
        ("run.bulk_viscosity.linear", r.bulk_viscosity.linear),
        ("run.bulk_viscosity.quadratic", r.bulk_viscosity.quadratic),
        (
            "run.hourglass.coefficient",
            r.hourglass.coefficient.unwrap_or(0.0),
        ),
    ] {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(err(k, format!("expected a coefficient >= 0, got {v}")));
        }
    }

    if !HOURGLASS_KINDS.contains(&r.hourglass.kind.as_str()) {
        return Err(err(
            "run.hourglass.kind",
            format!(
                "expected one of {}, got \"{}\"",
                HOURGLASS_KINDS.join(", "),
                r.hourglass.kind
            ),
        ));
    }

    let mut meshes = Vec::new();
    for (i, m) in raw.mesh.iter().enumerate() {
        let f = dir.join(&m.file);
        let ext = f.extension().and_then(|e| e.to_str()).unwrap_or("");
        if ext != "geo" && ext != "msh" {
            return Err(err(
                &format!("mesh[{i}].file"),
                format!("expected a .geo or .msh file, got {}", m.file.display()),
            ));
        }
        if !f.exists() {
            return Err(err(
                &format!("mesh[{i}].file"),
                format!("no such file: {}", f.display()),
            ));
        }
        meshes.push(MeshDef {
            file: f,
            params: m.params.clone(),
            translate: m.translate,
        });
    }
    if meshes.is_empty() && raw.particles.is_empty() {
        return Err(err(
            "mesh",
            "a scene needs at least one [[mesh]] or [[particles]]".into(),
        ));
    }

    let mut materials: Vec<MaterialSpec> = Vec::new();
    for (i, t) in raw.material.iter().enumerate() {
        let key = |k: &str| format!("material[{i}].{k}");
        let name = match t.get("name") {
            Some(toml::Value::String(s)) => s.clone(),
            Some(_) => return Err(err(&key("name"), "expected a string".into())),
            None => {
                return Err(err(
                    &key("name"),
                    "missing (every material needs a name)".into(),
                ))
            }
        };
        if materials.iter().any(|m| m.name == name) {
            return Err(err(
                &key("name"),
                format!("material \"{name}\" is defined twice"),
            ));
        }
        let model = match t.get("model") {
            Some(toml::Value::String(s)) => s.clone(),
            Some(_) => return Err(err(&key("model"), "expected a string".into())),
            None => {
                return Err(err(
                    &key("model"),
                    "missing (elastic, j2_plastic, johnson_cook or fluid)".into(),
                ))
            }
        };
        let Some((_, keys)) = MODEL_KEYS.iter().find(|(m, _)| *m == model) else {
            return Err(err(&key("model"), format!("unknown model \"{model}\" (expected one of elastic, j2_plastic, johnson_cook, fluid)")));
        };
        let density = match t.get("density").and_then(num) {
            Some(d) if pos(d) => d,
            Some(d) => {
                return Err(err(
                    &key("density"),
                    format!("expected a positive density in kg/m^3, got {d}"),
                ))
            }
            None => return Err(err(&key("density"), "missing (kg/m^3)".into())),
        };
        let mut params = BTreeMap::new();
        let mut eos = None;
        for (k, v) in t {
            match k.as_str() {
                "name" | "model" | "density" => {}
                "eos" if model == "fluid" => {
                    let Some(et) = v.as_table() else {
                        return Err(err(
                            &key("eos"),
                            "expected a table { kind = ..., ... }".into(),
                        ));
                    };
                    let kind = et
                        .get("kind")
                        .and_then(|k| k.as_str())
                        .unwrap_or("")
                        .to_string();
                    // the equation-of-state keys by kind: the eos crate's table
                    let Some(ek) = ::eos::kind(&kind).map(|k| k.keys) else {
                        return Err(err(
                            &key("eos.kind"),
                            format!(
                                "unknown or missing eos kind \"{kind}\" (expected one of {})",
                                ::eos::kind_names()
                            ),
                        ));
                    };
                    let mut ep = BTreeMap::new();
                    for (ekk, ev) in et {
                        if ekk == "kind" {
                            continue;
                        }
                        if !ek.contains(&ekk.as_str()) {
                            return Err(err(
                                &key(&format!("eos.{ekk}")),
                                format!("unknown key for eos {kind} (expected {})", ek.join(", ")),
                            ));
                        }
                        let Some(x) = num(ev) else {
                            return Err(err(
                                &key(&format!("eos.{ekk}")),
                                "expected a number".into(),
                            ));
                        };
                        ep.insert(ekk.clone(), x);
                    }
                    for need in ek.iter() {
                        if !ep.contains_key(*need) {
                            return Err(err(
                                &key(&format!("eos.{need}")),
                                format!("missing (eos {kind} needs {})", ek.join(", ")),
                            ));
                        }
                    }
                    eos = Some(EosSpec { kind, params: ep });
                }
                _ => {
                    if !keys.contains(&k.as_str()) {
                        let mut all: Vec<&str> = vec!["name", "model", "density"];
                        all.extend(keys.iter());
                        if model == "fluid" {
                            all.push("eos");
                        }
                        return Err(err(
                            &key(k),
                            format!(
                                "unknown key for model {model} (expected one of {})",
                                all.join(", ")
                            ),
                        ));
                    }
                    let Some(x) = num(v) else {
                        return Err(err(&key(k), "expected a number".into()));
                    };
                    params.insert(k.clone(), x);
                }
            }
        }
        for need in keys.iter() {
            if !params.contains_key(*need) {
                return Err(err(
                    &key(need),
                    format!("missing (model {model} needs {})", keys.join(", ")),
                ));
            }
        }
        if model == "fluid" && eos.is_none() {
            return Err(err(
                &key("eos"),
                "missing: a fluid needs eos = { kind = ..., ... }".into(),
            ));
        }
        let spec = MaterialSpec {
            name: name.clone(),
            model: model.clone(),
            density,
            params,
            eos,
        };
        if model != "fluid" {
            if let Err(e) = fe_petsc::material::build_material(&spec) {
                return Err(err(&format!("material[{i}]"), e.to_string()));
            }
        }
        materials.push(spec);
    }
    let mat_names = || {
        materials
            .iter()
            .map(|m| m.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    for (i, b) in raw.block.iter().enumerate() {
        if !materials.iter().any(|m| m.name == b.material) {
            return Err(err(
                &format!("block[{i}].material"),
                format!(
                    "no material named \"{}\" (materials: {})",
                    b.material,
                    mat_names()
                ),
            ));
        }
    }
    // A fluid is built (EOS keys and values checked) when a block meshes it; particles take
    // their EOS from the SPH side.
    for (i, m) in materials.iter().enumerate() {
        if m.model == "fluid" && raw.block.iter().any(|b| b.material == m.name) {
            if let Err(e) = fe_petsc::material::build_material(m) {
                return Err(err(&format!("material[{i}]"), e.to_string()));
            }
        }
    }
    let mut boundaries = Vec::new();
    for (i, b) in raw.boundary.iter().enumerate() {
        let kind = match (b.kind.as_str(), b.velocity) {
            ("fixed", None) => BoundaryKind::Fixed,
            ("symmetry", None) => BoundaryKind::Symmetry,
            ("velocity", Some(v)) => BoundaryKind::Velocity(v),
            ("velocity", None) => {
                return Err(err(
                    &format!("boundary[{i}].velocity"),
                    "missing: kind = \"velocity\" needs velocity = [vx, vy, vz]".into(),
                ))
            }
            ("fixed" | "symmetry", Some(_)) => {
                return Err(err(
                    &format!("boundary[{i}].velocity"),
                    format!(
                        "only kind = \"velocity\" takes a velocity (this boundary is \"{}\")",
                        b.kind
                    ),
                ))
            }
            (k, _) => {
                return Err(err(
                    &format!("boundary[{i}].kind"),
                    format!("unknown kind \"{k}\" (expected fixed, velocity or symmetry)"),
                ))
            }
        };
        boundaries.push(Boundary {
            group: b.group.clone(),
            kind,
        });
    }
    for (i, p) in raw.particles.iter().enumerate() {
        match materials.iter().find(|m| m.name == p.material) {
            None => {
                return Err(err(
                    &format!("particles[{i}].material"),
                    format!(
                        "no material named \"{}\" (materials: {})",
                        p.material,
                        mat_names()
                    ),
                ))
            }
            Some(m) if m.eos.is_none() => {
                return Err(err(
                    &format!("particles[{i}].material"),
                    format!(
                        "material \"{}\" has no eos: particles need a fluid material with an eos",
                        p.material
                    ),
                ))
            }
            _ => {}
        }
        if !pos(p.spacing) {
            return Err(err(
                &format!("particles[{i}].spacing"),
                format!("expected a positive spacing in m, got {}", p.spacing),
            ));
        }
        if !pos(p.h_factor) {
            return Err(err(
                &format!("particles[{i}].h_factor"),
                format!("expected a positive factor, got {}", p.h_factor),
            ));
        }
        if p.liggghts_type.is_some() && !matches!(p.region, Region::File(_)) {
            return Err(err(
                &format!("particles[{i}].liggghts_type"),
                "only with region = { file = \"<LIGGGHTS data file>\" }".into(),
            ));
        }
    }
    if let Some(s) = &raw.sph {
        for (k, v) in [
            ("sph.adaptive_h", s.adaptive_h),
            ("sph.conductivity", s.conductivity),
        ] {
            if let Some(v) = v {
                if !(v > 0.0 && v.is_finite()) {
                    return Err(err(k, format!("expected a positive number, got {v}")));
                }
            }
        }
        for (k, v, ok) in [
            ("sph.kernel", &s.kernel, &["cubic_spline", "wendland"][..]),
            ("sph.density", &s.density, &["continuity", "summation"][..]),
            ("sph.profile", &s.profile, &["standard", "liggghts"][..]),
        ] {
            if !ok.contains(&v.as_str()) {
                return Err(err(
                    k,
                    format!("unknown value \"{v}\" (expected one of {})", ok.join(", ")),
                ));
            }
        }
    }
    if let Some(c) = &raw.contact {
        match c.passes {
            1 if c.master.is_empty() => {
                return Err(err(
                    "contact.master",
                    "passes = 1 needs the master bodies: master = [\"<physical volume>\", ...] \
                     (the other bodies' nodes are searched against their faces)"
                        .into(),
                ))
            }
            2 if !c.master.is_empty() => {
                return Err(err(
                    "contact.master",
                    "a master is only read with passes = 1 (two passes search every pair of \
                     bodies both ways)"
                        .into(),
                ))
            }
            1 | 2 => {}
            n => {
                return Err(err(
                    "contact.passes",
                    format!(
                    "expected 1 (one pass, master/slave) or 2 (both ways, the default), got {n}"
                ),
                ))
            }
        }
    }
    let mut names: Vec<&str> = Vec::new();
    for (i, p) in raw.probe.iter().enumerate() {
        if names.contains(&p.name.as_str()) {
            return Err(err(
                &format!("probe[{i}].name"),
                format!("probe \"{}\" is defined twice", p.name),
            ));
        }
        names.push(&p.name);
        if p.fields.is_empty() {
            return Err(err(
                &format!("probe[{i}].fields"),
                "expected at least one field".into(),
            ));
        }
    }
    if let Some(c) = &raw.contact {
        if !(c.friction >= 0.0 && c.friction.is_finite()) {
            return Err(err(
                "contact.friction",
                format!("expected Coulomb's coefficient >= 0, got {}", c.friction),
            ));
        }
    }
    if let Some(c) = raw.output.checkpoint_every {
        if !(c > 0.0 && c.is_finite()) {
            return Err(err(
                "output.checkpoint_every",
                format!("expected a positive interval in seconds, got {c}"),
            ));
        }
    }
    for (i, f) in raw.output.fields.iter().enumerate() {
        if !OUTPUT_FIELDS.contains(&f.as_str()) {
            return Err(err(
                &format!("output.fields[{i}]"),
                format!(
                    "unknown field \"{f}\" (expected one of {})",
                    OUTPUT_FIELDS.join(", ")
                ),
            ));
        }
    }
    if let Some(c) = &raw.compare {
        if !COMPARE_MEASURES.contains(&c.measure.as_str()) {
            return Err(err(
                "compare.measure",
                format!(
                    "unknown value \"{}\" (expected one of {})",
                    c.measure,
                    COMPARE_MEASURES.join(", ")
                ),
            ));
        }
        if let Some(q) = &c.quantity {
            let known = raw
                .probe
                .iter()
                .flat_map(|p| {
                    p.fields
                        .iter()
                        .map(move |f| format!("{}.{}", p.name, f.name()))
                })
                .any(|col| &col == q);
            if !known {
                return Err(err(
                    "compare.quantity",
                    format!("\"{q}\" is not a probe column (expected probe.field of a [[probe]])"),
                ));
            }
        }
        if let Some(t) = c.reference_period {
            if !pos(t) {
                return Err(err(
                    "compare.reference_period",
                    format!("expected a positive period in seconds, got {t}"),
                ));
            }
        }
    }
    Ok(Scene {
        file: file.to_path_buf(),
        dir,
        title: raw.title,
        gravity: raw.gravity,
        run: raw.run,
        meshes,
        materials,
        blocks: raw.block,
        boundaries,
        particles: raw.particles,
        sph: raw.sph,
        contact: raw.contact,
        probes: raw.probe,
        output: raw.output,
        compare: raw.compare,
        sweep: raw.sweep,
    })
}

fn num(v: &toml::Value) -> Option<f64> {
    match v {
        toml::Value::Float(f) => Some(*f),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

/// Checks that every group the scene names exists in the mesh.
pub fn validate_groups(
    scene: &Scene,
    volumes: &[String],
    surfaces: &[String],
) -> Result<(), SceneError> {
    let file = scene.file.display().to_string();
    let list = |v: &[String]| {
        if v.is_empty() {
            "none".to_string()
        } else {
            v.join(", ")
        }
    };
    for (i, b) in scene.blocks.iter().enumerate() {
        if !volumes.contains(&b.group) {
            return Err(SceneError {
                file,
                key: format!("block[{i}].group"),
                message: format!(
                    "no physical volume \"{}\" in the mesh (physical volumes: {})",
                    b.group,
                    list(volumes)
                ),
            });
        }
    }
    for (i, b) in scene.boundaries.iter().enumerate() {
        if !surfaces.contains(&b.group) {
            return Err(SceneError {
                file,
                key: format!("boundary[{i}].group"),
                message: format!(
                    "no physical surface \"{}\" in the mesh (physical surfaces: {})",
                    b.group,
                    list(surfaces)
                ),
            });
        }
    }
    if let Some(c) = &scene.contact {
        for (i, s) in c.surfaces.iter().enumerate() {
            if s != "exterior" && !surfaces.contains(s) {
                return Err(SceneError {
                    file,
                    key: format!("contact.surfaces[{i}]"),
                    message: format!("no physical surface \"{s}\" in the mesh (physical surfaces: {}; or \"exterior\")", list(surfaces)),
                });
            }
        }
        for (i, m) in c.master.iter().enumerate() {
            if !volumes.contains(m) {
                return Err(SceneError {
                    file,
                    key: format!("contact.master[{i}]"),
                    message: format!(
                        "no physical volume \"{m}\" in the mesh (physical volumes: {})",
                        list(volumes)
                    ),
                });
            }
        }
    }
    Ok(())
}
