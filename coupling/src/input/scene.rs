//! The scene file (SCENE.md): parsed with serde (unknown keys refused, with their path), then
//! checked as a whole. Every error names the file, the key and what was expected.
use fe_petsc::material::{EosSpec, MaterialSpec};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A mistake in a scene file: `<file>: <key>: <what was expected>`, on one line (a line break
/// the scene put in a name or a path shows as `\n`).
#[derive(Debug, Clone, thiserror::Error)]
#[error("{}: {}: {}", one_line(file), one_line(key), one_line(message))]
pub struct SceneError {
    /// The scene file.
    pub file: String,
    /// The key path, e.g. `run.end_time` or `material[1].model`.
    pub key: String,
    /// What is wrong and what was expected.
    pub message: String,
}

/// `s` with its line breaks escaped.
fn one_line(s: &str) -> String {
    s.replace('\r', "\\r").replace('\n', "\\n")
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

/// `[x, y, z]` keys: exactly three values, each a finite number (serde's fixed arrays would take
/// the first three of a longer list, and NaN or inf would pass).
mod vec3 {
    use serde::de::{Deserializer, Error};
    use serde::Deserialize;

    fn three<T: Copy>(v: Vec<T>) -> Result<[T; 3], String> {
        match v.as_slice() {
            [a, b, c] => Ok([*a, *b, *c]),
            _ => Err(format!("expected [x, y, z], got {} values", v.len())),
        }
    }

    fn finite(v: Vec<f64>) -> Result<[f64; 3], String> {
        let x = three(v)?;
        match x.iter().find(|c| !c.is_finite()) {
            Some(c) => Err(format!(
                "expected three finite numbers, got {c} in [{}, {}, {}]",
                x[0], x[1], x[2]
            )),
            None => Ok(x),
        }
    }

    /// Three finite numbers.
    pub fn exact<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
        finite(Vec::deserialize(d)?).map_err(D::Error::custom)
    }

    /// Three finite numbers, when given.
    pub fn option<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[f64; 3]>, D::Error> {
        Option::<Vec<f64>>::deserialize(d)?
            .map(finite)
            .transpose()
            .map_err(D::Error::custom)
    }

    /// Three booleans.
    pub fn bools<'de, D: Deserializer<'de>>(d: D) -> Result<[bool; 3], D::Error> {
        three(Vec::deserialize(d)?).map_err(D::Error::custom)
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
fn d_max_steps() -> f64 {
    MAX_STEPS
}

/// Default `run.max_steps`: more steps than any run of this code could mean (10^9 steps of even
/// the smallest mesh take hours).
pub const MAX_STEPS: f64 = 1e9;
/// The most field frames a run may ask for (`end_time / output_every`).
pub const MAX_FRAMES: f64 = 1e6;
/// The most history rows a run may ask for with `history_every > 0` (`end_time /
/// history_every`); `history_every = 0` writes a row every step.
pub const MAX_ROWS: f64 = 1e6;
/// Frames or rows asked per step beyond which the interval cannot be meant: they come at most
/// once a step.
pub const MAX_OUTPUTS_PER_STEP: f64 = 1e3;
/// The most particles a `[[particles]]` lattice may visit (its region's bounding box at its
/// spacing), checked before anything is allocated.
pub const MAX_PARTICLES: f64 = 1e9;
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
    /// The most steps the run may take (default [`MAX_STEPS`]): a run that would take more is
    /// refused before it starts (a wrong unit or a typo in `end_time` or `dt`); raise it to run
    /// one deliberately.
    #[serde(default = "d_max_steps")]
    pub max_steps: f64,
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
    #[serde(deserialize_with = "vec3::exact")]
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
    #[serde(deserialize_with = "vec3::exact")]
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
    #[serde(deserialize_with = "vec3::option")]
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
    #[serde(deserialize_with = "vec3::exact")]
    pub point: [f64; 3],
    /// Fields.
    pub fields: Vec<ProbeField>,
}

impl Probe {
    /// Its columns in probes.csv, `probe.field`, in field order.
    pub fn columns(&self) -> impl Iterator<Item = String> + '_ {
        self.fields
            .iter()
            .map(move |f| format!("{}.{}", self.name, f.name()))
    }
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
        #[serde(deserialize_with = "vec3::exact")]
        min: [f64; 3],
        #[serde(deserialize_with = "vec3::exact")]
        max: [f64; 3],
    },
    Cylinder {
        #[serde(deserialize_with = "vec3::exact")]
        base: [f64; 3],
        #[serde(deserialize_with = "vec3::exact")]
        axis: [f64; 3],
        radius: f64,
    },
    Sphere {
        #[serde(deserialize_with = "vec3::exact")]
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
    #[serde(deserialize_with = "vec3::exact")]
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
    #[serde(deserialize_with = "vec3::bools")]
    pub axes: [bool; 3],
    #[serde(deserialize_with = "vec3::exact")]
    pub min: [f64; 3],
    #[serde(deserialize_with = "vec3::exact")]
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
    #[serde(deserialize_with = "vec3::exact")]
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

/// Names the scene file in every error.
struct Ctx {
    file: String,
}

impl Ctx {
    /// An error at `key`.
    fn err(&self, key: &str, message: String) -> SceneError {
        SceneError {
            file: self.file.clone(),
            key: key.to_string(),
            message,
        }
    }
}

/// A number as a message shows it: plain when short, in exponent form when very large or
/// very small.
pub fn num_text(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// A positive finite number.
fn pos(v: f64) -> bool {
    v > 0.0 && v.is_finite()
}

/// Parses scene text; `file` names it in errors and anchors relative paths. The tables are
/// checked in the order they are documented (SCENE.md); the first mistake is reported.
pub fn parse(text: &str, file: &Path) -> Result<Scene, SceneError> {
    let cx = Ctx {
        file: file.display().to_string(),
    };
    let raw = deserialize(&cx, text)?;
    let dir = file.parent().unwrap_or(Path::new(".")).to_path_buf();
    check_run(&cx, &raw.run)?;
    let meshes = check_meshes(&cx, &dir, &raw.mesh, raw.particles.is_empty())?;
    let materials = check_materials(&cx, &raw.material)?;
    check_blocks(&cx, &raw.block, &materials)?;
    let boundaries = check_boundaries(&cx, &raw.boundary)?;
    check_particles(&cx, &raw.particles, &materials)?;
    if let Some(s) = &raw.sph {
        check_sph(&cx, s)?;
    }
    if let Some(c) = &raw.contact {
        check_contact(&cx, c)?;
    }
    check_probes(&cx, &raw.probe)?;
    check_output(&cx, &raw.output)?;
    if let Some(c) = &raw.compare {
        check_compare(&cx, c, &raw.probe)?;
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

/// The TOML text into the raw tables (serde: unknown keys and wrong types refused, with their
/// path).
fn deserialize(cx: &Ctx, text: &str) -> Result<RawScene, SceneError> {
    let de = toml::Deserializer::new(text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        // One line (toml's parse messages run over several).
        let mut msg = inner
            .message()
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .collect::<Vec<_>>()
            .join("; ");
        if msg.is_empty() {
            // toml says nothing at some ends of input (`model = ` as the last line).
            msg = "invalid TOML (a value missing?)".into();
        }
        if let Some(r) = inner.span() {
            let (line, column) = line_column(text, r.start);
            msg = format!("{msg} (line {line}, column {column})");
        }
        let key = if path.is_empty() || path == "." {
            "(scene)".to_string()
        } else {
            path
        };
        cx.err(&key, msg)
    })
}

/// The 1-based line and column (in characters) of byte `at` of `text`.
fn line_column(text: &str, at: usize) -> (usize, usize) {
    let mut at = at.min(text.len());
    while !text.is_char_boundary(at) {
        at -= 1;
    }
    let before = &text[..at];
    let line = before.matches('\n').count() + 1;
    let start = before.rfind('\n').map_or(0, |i| i + 1);
    (line, before[start..].chars().count() + 1)
}

/// `[run]`: times, step, intervals, energy limit, bulk viscosity and hourglass control.
fn check_run(cx: &Ctx, r: &Run) -> Result<(), SceneError> {
    if !pos(r.end_time) {
        return Err(cx.err(
            "run.end_time",
            format!("expected a positive number of seconds, got {}", r.end_time),
        ));
    }
    if !(r.dt_safety > 0.0 && r.dt_safety <= 1.0) {
        return Err(cx.err(
            "run.dt_safety",
            format!("expected a fraction in (0, 1], got {}", r.dt_safety),
        ));
    }
    if let Some(dt) = r.dt {
        if !pos(dt) {
            return Err(cx.err(
                "run.dt",
                format!("expected a positive step in seconds, got {dt}"),
            ));
        }
    } else if r.mode == Mode::Implicit {
        return Err(cx.err(
            "run.dt",
            "mode = \"implicit\" needs a fixed step run.dt (seconds)".into(),
        ));
    }
    if let Some(o) = r.output_every {
        if !pos(o) {
            return Err(cx.err(
                "run.output_every",
                format!("expected a positive interval in seconds, got {o}"),
            ));
        }
    }
    if !(r.history_every >= 0.0 && r.history_every.is_finite()) {
        return Err(cx.err(
            "run.history_every",
            format!("expected seconds >= 0, got {}", r.history_every),
        ));
    }
    if !pos(r.max_energy_error) {
        return Err(cx.err(
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
            return Err(cx.err(k, format!("expected a coefficient >= 0, got {v}")));
        }
    }
    if !HOURGLASS_KINDS.contains(&r.hourglass.kind.as_str()) {
        return Err(cx.err(
            "run.hourglass.kind",
            format!(
                "expected one of {}, got \"{}\"",
                HOURGLASS_KINDS.join(", "),
                r.hourglass.kind
            ),
        ));
    }
    if !(r.max_steps >= 1.0 && r.max_steps.is_finite()) {
        return Err(cx.err(
            "run.max_steps",
            format!("expected a number of steps >= 1, got {}", r.max_steps),
        ));
    }
    work_bounds(cx, r, r.dt)
}

/// The work a run asks for, refused with its numbers before it starts (SCENE.md "Exit
/// status"): more than `run.max_steps` steps, more than [`MAX_FRAMES`] frames or [`MAX_ROWS`]
/// rows, or intervals [`MAX_OUTPUTS_PER_STEP`] times shorter than the step. `dt` is the step
/// when known (a fixed `run.dt`, or the first step the run takes); the scene check passes the
/// fixed one, the run the one it starts with ([`check_work`]).
fn work_bounds(cx: &Ctx, r: &Run, dt: Option<f64>) -> Result<(), SceneError> {
    let end = r.end_time;
    if let Some(dt) = dt {
        let steps = end / dt;
        if !(steps <= r.max_steps) {
            let (key, step) = match r.dt {
                Some(_) => ("run.dt", "run.dt"),
                None => ("run.end_time", "the stable step times run.dt_safety"),
            };
            return Err(cx.err(
                key,
                format!(
                    "run.end_time = {end:e} s in steps of {dt:.3e} s ({step}) is {steps:.3e} steps, more than run.max_steps = {:e}: check the units (SI: m, kg, s) and the values; raise run.max_steps to run it anyway",
                    r.max_steps
                ),
            ));
        }
    }
    let intervals = [
        ("run.output_every", "frames", r.output_every, MAX_FRAMES),
        (
            "run.history_every",
            "rows",
            Some(r.history_every).filter(|h| *h > 0.0),
            MAX_ROWS,
        ),
    ];
    for (key, what, every, max) in intervals {
        let Some(every) = every else { continue };
        let every_step = if what == "rows" {
            " (history_every = 0 writes a row every step)"
        } else {
            ""
        };
        let count = end / every;
        if count > max {
            return Err(cx.err(
                key,
                format!(
                    "{every:e} s over run.end_time = {end:e} s is {count:.3e} {what}, more than the {max:e} a run may write: use a longer interval{every_step}"
                ),
            ));
        }
        if let Some(dt) = dt.filter(|dt| every * MAX_OUTPUTS_PER_STEP < *dt) {
            return Err(cx.err(
                key,
                format!(
                    "{every:e} s is {:.3e} times shorter than the step {dt:e} s: {what} come at most once a step; use an interval of at least the step{every_step}",
                    dt / every
                ),
            ));
        }
    }
    Ok(())
}

/// The work bounds of `work_bounds` at the step the run starts with (`dt`: the fixed step,
/// or the safety factor times the stable step), once it is known.
pub fn check_work(scene: &Scene, dt: f64) -> Result<(), SceneError> {
    let cx = Ctx {
        file: scene.file.display().to_string(),
    };
    work_bounds(&cx, &scene.run, Some(dt))
}

/// `[[mesh]]`: each file a .geo or .msh that exists (relative to the scene's directory); a
/// scene needs a mesh unless it has particles.
fn check_meshes(
    cx: &Ctx,
    dir: &Path,
    raw: &[RawMesh],
    no_particles: bool,
) -> Result<Vec<MeshDef>, SceneError> {
    let mut meshes = Vec::new();
    for (i, m) in raw.iter().enumerate() {
        let f = dir.join(&m.file);
        let ext = f.extension().and_then(|e| e.to_str()).unwrap_or("");
        if ext != "geo" && ext != "msh" {
            return Err(cx.err(
                &format!("mesh[{i}].file"),
                format!("expected a .geo or .msh file, got {}", m.file.display()),
            ));
        }
        if !f.exists() {
            return Err(cx.err(
                &format!("mesh[{i}].file"),
                format!("no such file: {}", f.display()),
            ));
        }
        let def = MeshDef {
            file: f,
            params: m.params.clone(),
            translate: m.translate,
        };
        crate::input::gmsh::check_params(&def)
            .map_err(|(name, why)| cx.err(&format!("mesh[{i}].params.{name}"), why))?;
        meshes.push(def);
    }
    if meshes.is_empty() && no_particles {
        return Err(cx.err(
            "mesh",
            "a scene needs at least one [[mesh]] or [[particles]]".into(),
        ));
    }
    Ok(meshes)
}

/// `[[material]]`: each table checked against its model's keys and built once (a fluid is
/// built when a block meshes it: [`check_blocks`]).
fn check_materials(cx: &Ctx, raw: &[toml::Table]) -> Result<Vec<MaterialSpec>, SceneError> {
    let mut materials: Vec<MaterialSpec> = Vec::new();
    for (i, t) in raw.iter().enumerate() {
        let spec = check_material(cx, i, t, &materials)?;
        if spec.model != "fluid" {
            if let Err(e) = fe_petsc::material::build_material(&spec) {
                return Err(cx.err(&format!("material[{i}]"), e.to_string()));
            }
        }
        materials.push(spec);
    }
    Ok(materials)
}

/// One `[[material]]` table (the `i`-th): name (unique among `earlier`), model, density, the
/// model's keys, and a fluid's `eos`.
fn check_material(
    cx: &Ctx,
    i: usize,
    t: &toml::Table,
    earlier: &[MaterialSpec],
) -> Result<MaterialSpec, SceneError> {
    let key = |k: &str| format!("material[{i}].{k}");
    let name = match t.get("name") {
        Some(toml::Value::String(s)) => s.clone(),
        Some(_) => return Err(cx.err(&key("name"), "expected a string".into())),
        None => return Err(cx.err(&key("name"), "missing (every material needs a name)".into())),
    };
    if earlier.iter().any(|m| m.name == name) {
        return Err(cx.err(
            &key("name"),
            format!("material \"{name}\" is defined twice"),
        ));
    }
    let model = match t.get("model") {
        Some(toml::Value::String(s)) => s.clone(),
        Some(_) => return Err(cx.err(&key("model"), "expected a string".into())),
        None => {
            return Err(cx.err(
                &key("model"),
                "missing (elastic, j2_plastic, johnson_cook or fluid)".into(),
            ))
        }
    };
    let Some((_, keys)) = MODEL_KEYS.iter().find(|(m, _)| *m == model) else {
        return Err(cx.err(&key("model"), format!("unknown model \"{model}\" (expected one of elastic, j2_plastic, johnson_cook, fluid)")));
    };
    let density = match t.get("density").map(number) {
        Some(Ok(d)) if pos(d) => d,
        Some(Ok(d)) => {
            return Err(cx.err(
                &key("density"),
                format!("expected a positive density in kg/m^3, got {d}"),
            ))
        }
        Some(Err(e)) => return Err(cx.err(&key("density"), e)),
        None => return Err(cx.err(&key("density"), "missing (kg/m^3)".into())),
    };
    let mut params = BTreeMap::new();
    let mut eos = None;
    for (k, v) in t {
        match k.as_str() {
            "name" | "model" | "density" => {}
            "eos" if model == "fluid" => eos = Some(check_eos(cx, i, v)?),
            _ => {
                if !keys.contains(&k.as_str()) {
                    let mut all: Vec<&str> = vec!["name", "model", "density"];
                    all.extend(keys.iter());
                    if model == "fluid" {
                        all.push("eos");
                    }
                    return Err(cx.err(
                        &key(k),
                        format!(
                            "unknown key for model {model} (expected one of {})",
                            all.join(", ")
                        ),
                    ));
                }
                let x = number(v).map_err(|e| cx.err(&key(k), e))?;
                params.insert(k.clone(), x);
            }
        }
    }
    for need in keys.iter() {
        if !params.contains_key(*need) {
            return Err(cx.err(
                &key(need),
                format!("missing (model {model} needs {})", keys.join(", ")),
            ));
        }
    }
    if model == "fluid" && eos.is_none() {
        return Err(cx.err(
            &key("eos"),
            "missing: a fluid needs eos = { kind = ..., ... }".into(),
        ));
    }
    Ok(MaterialSpec {
        name,
        model,
        density,
        params,
        eos,
    })
}

/// The `eos` table of fluid material `i`: a kind from the eos crate's name table and exactly
/// that kind's keys, each a number.
fn check_eos(cx: &Ctx, i: usize, v: &toml::Value) -> Result<EosSpec, SceneError> {
    let key = |k: &str| format!("material[{i}].{k}");
    let Some(et) = v.as_table() else {
        return Err(cx.err(&key("eos"), "expected a table { kind = ..., ... }".into()));
    };
    let kind = et
        .get("kind")
        .and_then(|k| k.as_str())
        .unwrap_or("")
        .to_string();
    // the equation-of-state keys by kind: the eos crate's table
    let Some(ek) = ::eos::kind(&kind).map(|k| k.keys) else {
        return Err(cx.err(
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
            return Err(cx.err(
                &key(&format!("eos.{ekk}")),
                format!("unknown key for eos {kind} (expected {})", ek.join(", ")),
            ));
        }
        let x = number(ev).map_err(|e| cx.err(&key(&format!("eos.{ekk}")), e))?;
        ep.insert(ekk.clone(), x);
    }
    for need in ek.iter() {
        if !ep.contains_key(*need) {
            return Err(cx.err(
                &key(&format!("eos.{need}")),
                format!("missing (eos {kind} needs {})", ek.join(", ")),
            ));
        }
    }
    Ok(EosSpec { kind, params: ep })
}

/// The material names, for messages.
fn material_names(materials: &[MaterialSpec]) -> String {
    materials
        .iter()
        .map(|m| m.name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// `[[block]]`: each names a defined material; a fluid meshed by a block is built here (its
/// EOS keys and values checked); particles take their EOS from the SPH side.
fn check_blocks(cx: &Ctx, blocks: &[Block], materials: &[MaterialSpec]) -> Result<(), SceneError> {
    for (i, b) in blocks.iter().enumerate() {
        if let Some(j) = blocks[..i].iter().position(|o| o.group == b.group) {
            return Err(cx.err(
                &format!("block[{i}].group"),
                format!(
                    "group \"{}\" already has a block (block[{j}]): one [[block]] per physical volume",
                    b.group
                ),
            ));
        }
        if !materials.iter().any(|m| m.name == b.material) {
            return Err(cx.err(
                &format!("block[{i}].material"),
                format!(
                    "no material named \"{}\" (materials: {})",
                    b.material,
                    material_names(materials)
                ),
            ));
        }
    }
    for (i, m) in materials.iter().enumerate() {
        if m.model == "fluid" && blocks.iter().any(|b| b.material == m.name) {
            if let Err(e) = fe_petsc::material::build_material(m) {
                return Err(cx.err(&format!("material[{i}]"), e.to_string()));
            }
        }
    }
    Ok(())
}

/// `[[boundary]]`: the kind, and a velocity exactly when the kind is `velocity`.
fn check_boundaries(cx: &Ctx, raw: &[RawBoundary]) -> Result<Vec<Boundary>, SceneError> {
    let mut boundaries = Vec::new();
    for (i, b) in raw.iter().enumerate() {
        let kind = match (b.kind.as_str(), b.velocity) {
            ("fixed", None) => BoundaryKind::Fixed,
            ("symmetry", None) => BoundaryKind::Symmetry,
            ("velocity", Some(v)) => BoundaryKind::Velocity(v),
            ("velocity", None) => {
                return Err(cx.err(
                    &format!("boundary[{i}].velocity"),
                    "missing: kind = \"velocity\" needs velocity = [vx, vy, vz]".into(),
                ))
            }
            ("fixed" | "symmetry", Some(_)) => {
                return Err(cx.err(
                    &format!("boundary[{i}].velocity"),
                    format!(
                        "only kind = \"velocity\" takes a velocity (this boundary is \"{}\")",
                        b.kind
                    ),
                ))
            }
            (k, _) => {
                return Err(cx.err(
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
    Ok(boundaries)
}

/// `[[particles]]`: a material with an eos, a positive spacing and h factor, `liggghts_type`
/// only with a data file.
fn check_particles(
    cx: &Ctx,
    particles: &[ParticlesDef],
    materials: &[MaterialSpec],
) -> Result<(), SceneError> {
    for (i, p) in particles.iter().enumerate() {
        match materials.iter().find(|m| m.name == p.material) {
            None => {
                return Err(cx.err(
                    &format!("particles[{i}].material"),
                    format!(
                        "no material named \"{}\" (materials: {})",
                        p.material,
                        material_names(materials)
                    ),
                ))
            }
            Some(m) if m.eos.is_none() => {
                return Err(cx.err(
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
            return Err(cx.err(
                &format!("particles[{i}].spacing"),
                format!("expected a positive spacing in m, got {}", p.spacing),
            ));
        }
        if !pos(p.h_factor) {
            return Err(cx.err(
                &format!("particles[{i}].h_factor"),
                format!("expected a positive factor, got {}", p.h_factor),
            ));
        }
        check_region(cx, i, p)?;
        if p.liggghts_type.is_some() && !matches!(p.region, Region::File(_)) {
            return Err(cx.err(
                &format!("particles[{i}].liggghts_type"),
                "only with region = { file = \"<LIGGGHTS data file>\" }".into(),
            ));
        }
    }
    Ok(())
}

/// A lattice region: a box with min < max, a positive radius, a non-zero axis, and no more than
/// [`MAX_PARTICLES`] lattice points to visit at the entry's spacing (counted before anything
/// is allocated).
fn check_region(cx: &Ctx, i: usize, p: &ParticlesDef) -> Result<(), SceneError> {
    let key = |k: &str| format!("particles[{i}].region.{k}");
    match &p.region {
        Region::Box { min, max } => {
            if let Some(d) = (0..3).find(|&d| !(min[d] < max[d])) {
                return Err(cx.err(
                    &key("box"),
                    format!(
                        "expected min < max on every axis, got min[{d}] = {} and max[{d}] = {}",
                        num_text(min[d]),
                        num_text(max[d])
                    ),
                ));
            }
        }
        Region::Sphere { radius, .. } if !pos(*radius) => {
            return Err(cx.err(
                &key("sphere.radius"),
                format!("expected a positive radius in m, got {radius}"),
            ));
        }
        Region::Cylinder { radius, .. } if !pos(*radius) => {
            return Err(cx.err(
                &key("cylinder.radius"),
                format!("expected a positive radius in m, got {radius}"),
            ));
        }
        Region::Cylinder { axis, .. } if axis.iter().all(|a| *a == 0.0) => {
            return Err(cx.err(
                &key("cylinder.axis"),
                "expected a non-zero axis (from the base to the top, m)".into(),
            ));
        }
        _ => {}
    }
    let n = crate::input::particles::lattice_points_bound(&p.region, p.spacing);
    if !(n <= MAX_PARTICLES) {
        return Err(cx.err(
            &format!("particles[{i}].spacing"),
            format!(
                "the region at a spacing of {:e} m is a lattice of {n:.3e} points, more than the {MAX_PARTICLES:e} particles a run may hold: use a larger spacing or a smaller region",
                p.spacing
            ),
        ));
    }
    Ok(())
}

/// `[sph]`: positive optional coefficients, coefficients >= 0, and known names.
fn check_sph(cx: &Ctx, s: &SphDef) -> Result<(), SceneError> {
    let av = s.artificial_viscosity.as_ref();
    for (k, v) in [
        ("sph.artificial_viscosity.alpha", av.map(|a| a.alpha)),
        ("sph.artificial_viscosity.beta", av.map(|a| a.beta)),
        (
            "sph.tensile_correction.epsilon",
            s.tensile_correction.as_ref().map(|t| t.epsilon),
        ),
    ] {
        if let Some(v) = v.filter(|v| !(*v >= 0.0 && v.is_finite())) {
            return Err(cx.err(k, format!("expected a coefficient >= 0, got {v}")));
        }
    }
    for (k, v) in [
        ("sph.adaptive_h", s.adaptive_h),
        ("sph.conductivity", s.conductivity),
    ] {
        if let Some(v) = v {
            if !(v > 0.0 && v.is_finite()) {
                return Err(cx.err(k, format!("expected a positive number, got {v}")));
            }
        }
    }
    for (k, v, ok) in [
        ("sph.kernel", &s.kernel, &["cubic_spline", "wendland"][..]),
        ("sph.density", &s.density, &["continuity", "summation"][..]),
        ("sph.profile", &s.profile, &["standard", "liggghts"][..]),
    ] {
        if !ok.contains(&v.as_str()) {
            return Err(cx.err(
                k,
                format!("unknown value \"{v}\" (expected one of {})", ok.join(", ")),
            ));
        }
    }
    Ok(())
}

/// `[contact]`: one pass with master bodies or two without, a Coulomb coefficient >= 0.
fn check_contact(cx: &Ctx, c: &ContactDef) -> Result<(), SceneError> {
    match c.passes {
        1 if c.master.is_empty() => {
            return Err(cx.err(
                "contact.master",
                "passes = 1 needs the master bodies: master = [\"<physical volume>\", ...] \
                 (the other bodies' nodes are searched against their faces)"
                    .into(),
            ))
        }
        2 if !c.master.is_empty() => {
            return Err(cx.err(
                "contact.master",
                "a master is only read with passes = 1 (two passes search every pair of \
                 bodies both ways)"
                    .into(),
            ))
        }
        1 | 2 => {}
        n => {
            return Err(cx.err(
                "contact.passes",
                format!(
                    "expected 1 (one pass, master/slave) or 2 (both ways, the default), got {n}"
                ),
            ))
        }
    }
    if !(c.friction >= 0.0 && c.friction.is_finite()) {
        return Err(cx.err(
            "contact.friction",
            format!("expected Coulomb's coefficient >= 0, got {}", c.friction),
        ));
    }
    Ok(())
}

/// `[[probe]]`: unique names, at least one field each.
fn check_probes(cx: &Ctx, probes: &[Probe]) -> Result<(), SceneError> {
    let mut names: Vec<&str> = Vec::new();
    for (i, p) in probes.iter().enumerate() {
        if names.contains(&p.name.as_str()) {
            return Err(cx.err(
                &format!("probe[{i}].name"),
                format!("probe \"{}\" is defined twice", p.name),
            ));
        }
        names.push(&p.name);
        if p.fields.is_empty() {
            return Err(cx.err(
                &format!("probe[{i}].fields"),
                "expected at least one field".into(),
            ));
        }
    }
    Ok(())
}

/// `[output]`: a positive checkpoint interval, known field names.
fn check_output(cx: &Ctx, output: &OutputDef) -> Result<(), SceneError> {
    if let Some(c) = output.checkpoint_every {
        if !(c > 0.0 && c.is_finite()) {
            return Err(cx.err(
                "output.checkpoint_every",
                format!("expected a positive interval in seconds, got {c}"),
            ));
        }
    }
    for (i, f) in output.fields.iter().enumerate() {
        if !OUTPUT_FIELDS.contains(&f.as_str()) {
            return Err(cx.err(
                &format!("output.fields[{i}]"),
                format!(
                    "unknown field \"{f}\" (expected one of {})",
                    OUTPUT_FIELDS.join(", ")
                ),
            ));
        }
    }
    Ok(())
}

/// `[compare]`: a known measure, a quantity that is a probe column, a positive period.
fn check_compare(cx: &Ctx, c: &CompareDef, probes: &[Probe]) -> Result<(), SceneError> {
    if !COMPARE_MEASURES.contains(&c.measure.as_str()) {
        return Err(cx.err(
            "compare.measure",
            format!(
                "unknown value \"{}\" (expected one of {})",
                c.measure,
                COMPARE_MEASURES.join(", ")
            ),
        ));
    }
    if let Some(q) = &c.quantity {
        let known = probes.iter().flat_map(Probe::columns).any(|col| &col == q);
        if !known {
            return Err(cx.err(
                "compare.quantity",
                format!("\"{q}\" is not a probe column (expected probe.field of a [[probe]])"),
            ));
        }
    }
    if let Some(t) = c.reference_period {
        if !pos(t) {
            return Err(cx.err(
                "compare.reference_period",
                format!("expected a positive period in seconds, got {t}"),
            ));
        }
    }
    Ok(())
}

/// A material's number: an integer or a finite float; anything else named by its type.
fn number(v: &toml::Value) -> Result<f64, String> {
    match v {
        toml::Value::Float(f) if f.is_finite() => Ok(*f),
        toml::Value::Float(f) => Err(format!("expected a finite number, got {f}")),
        toml::Value::Integer(i) => Ok(*i as f64),
        toml::Value::String(s) => Err(format!(
            "expected a number, got a string (\"{s}\": write it without quotes)"
        )),
        other => Err(format!("expected a number, got {}", other.type_str())),
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A valid scene: the bundled bar, steel, one block, one boundary.
    fn base() -> String {
        let geo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../meshes/bar.geo");
        format!(
            "[run]\nend_time = 1.0e-5\n\n[[mesh]]\nfile = \"{}\"\nparams = {{ N = 4, M = 1 }}\n\n\
             [[material]]\nname = \"steel\"\nmodel = \"elastic\"\ndensity = 7850.0\n\
             youngs_modulus = 200.0e9\npoisson_ratio = 0.3\n\n\
             [[block]]\ngroup = \"bar\"\nmaterial = \"steel\"\nvelocity = [1.0, 0.0, 0.0]\n\n\
             [[boundary]]\ngroup = \"left\"\nkind = \"fixed\"\n",
            geo.display()
        )
    }

    fn refused(text: &str) -> SceneError {
        parse(text, Path::new("scene.toml")).expect_err("must be refused")
    }

    /// Each silent input of issue 16 and each new bound: the key and what the message must say
    /// (SCENE.md: the file, the key, what was expected; one line).
    #[test]
    fn silent_inputs_and_absurd_work_are_refused_by_key() {
        assert!(parse(&base(), Path::new("scene.toml")).is_ok());
        let water = "[[material]]\nname = \"water\"\nmodel = \"fluid\"\ndensity = 1000.0\n\
                     eos = { kind = \"tait\", rho0 = 1000.0, sound_speed = 1480.0, gamma = 7.0 }\n\
                     [[particles]]\nname = \"p\"\nmaterial = \"water\"\nspacing = 0.01\n\
                     region = { box = { min = [-9.2e18, 0.0, 0.0], max = [0.1, 0.1, 0.1] } }\n";
        let b = base();
        let cases: Vec<(String, &str, &[&str])> = vec![
            (
                b.replace("[1.0, 0.0, 0.0]", "[1.0, 0.0, 0.0, 4.0]"),
                "block[0].velocity",
                &["got 4 values", "(line 18, column 12)"],
            ),
            (
                b.replace("[1.0, 0.0, 0.0]", "[nan, 0.0, 0.0]"),
                "block[0].velocity",
                &["finite"],
            ),
            (
                b.replace("7850.0", "\"7850\""),
                "material[0].density",
                &["expected a number, got a string"],
            ),
            (
                b.replace("200.0e9", "inf"),
                "material[0].youngs_modulus",
                &["expected a finite number, got inf"],
            ),
            (
                b.clone() + "[[block]]\ngroup = \"bar\"\nmaterial = \"steel\"\n",
                "block[1].group",
                &["already has a block (block[0])"],
            ),
            (
                b.replace("[run]", "[run"),
                "(scene)",
                &["(line 1, column 5)"],
            ),
            (
                b.clone() + "[[material]]\nname = \"x\"\nmodel = ",
                "(scene)",
                &["invalid TOML (a value missing?) (line 25, column 9)"],
            ),
            (
                b.replace("end_time = 1.0e-5", "end_time = 1.0e-5\ndt = 1e-300"),
                "run.dt",
                &["1.000e295 steps", "run.max_steps = 1e9"],
            ),
            (
                b.replace("end_time = 1.0e-5", "end_time = 1.0e-5\nmax_steps = 0"),
                "run.max_steps",
                &["got 0"],
            ),
            (
                b.replace(
                    "end_time = 1.0e-5",
                    "end_time = 1.0e-5\noutput_every = 1e-18",
                ),
                "run.output_every",
                &["1.000e13 frames"],
            ),
            (
                b.replace(
                    "end_time = 1.0e-5",
                    "end_time = 1.0e-5\nhistory_every = 1e-18",
                ),
                "run.history_every",
                &["1.000e13 rows"],
            ),
            (
                b.replace(
                    "end_time = 1.0e-5",
                    "end_time = 1.0e-5\ndt = 1e-6\nhistory_every = 1e-10",
                ),
                "run.history_every",
                &["1.000e4 times shorter than the step"],
            ),
            (
                b.replace("N = 4", "N = 10.5"),
                "mesh[0].params.N",
                &["got 10.5"],
            ),
            (b.replace("N = 4", "N = 0"), "mesh[0].params.N", &["got 0"]),
            (
                b.replace("N = 4", "N = 1e12"),
                "mesh[0].params.N",
                &["got 1e12"],
            ),
            (
                b.replace("N = 4", "N = nan"),
                "mesh[0].params.N",
                &["finite"],
            ),
            (
                b.clone() + water,
                "particles[0].spacing",
                &["9.200e22 points"],
            ),
        ];
        for (text, key, needles) in cases {
            let e = refused(&text);
            let line = e.to_string();
            assert_eq!(e.key, key, "{line}");
            for n in needles {
                assert!(line.contains(n), "{key}: expected {n:?} in {line:?}");
            }
            assert!(!line.contains('\n'), "one line: {line:?}");
        }
    }

    /// A line break inside a value (a path) shows as `\n`: the error stays one line (found by
    /// the fuzz harness, seed 2024 case 387109).
    #[test]
    fn an_error_is_one_line_whatever_the_scene_holds() {
        let e = refused(&base().replace("bar.geo", "b\\nar.geo"));
        assert_eq!(e.key, "mesh[0].file");
        assert!(e.to_string().contains("b\\nar.geo"), "{e}");
        assert!(!e.to_string().contains('\n'), "{e}");
    }
}
