//! The scene file (docs/scene.md): parsed with serde (unknown keys refused, with their path), then
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

/// `run.tetrahedra`: how a mesh's tetrahedra run (docs/scene.md, docs/element.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Tetrahedra {
    /// Each tetrahedron as 4 hexahedra (`input::split`): no locking in plastic flow or in
    /// bending, at about 4 hexahedra per tetrahedron and a shorter step.
    #[default]
    Split,
    /// The native 4-node tetrahedron with a nodal-averaged volumetric strain
    /// (`fe_petsc::tet`): no locking in plastic flow, one element per tetrahedron at the
    /// tetrahedron's own step; stiff in bending at a coarse size.
    NodalPressure,
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
                bound: fe_petsc::hourglass::YieldBound::Fibres,
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
    /// How the mesh's tetrahedra run.
    #[serde(default)]
    pub tetrahedra: Tetrahedra,
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

/// `[sweep]` (optional, beyond docs/scene.md): the ladder `tdyn sweep` runs when the command line
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
    /// What a failed element becomes (`"delete"`; `"particles"`, the default where the material
    /// has `failure`), checked by `failure::check_failed`.
    #[serde(default)]
    pub failed: Option<toml::Value>,
}

impl Block {
    /// Whether the block says `failed = "delete"` (else its failed elements become particles).
    pub fn deletes(&self) -> bool {
        matches!(&self.failed, Some(toml::Value::String(s)) if s == "delete")
    }
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
    /// `kind = "velocity"`: the velocity's scale in time (none: 1).
    pub curve: Option<crate::input::curve::Curve>,
}

/// `[[load]]`: a pressure on a physical surface, following the deformed faces.
#[derive(Debug, Clone, PartialEq)]
pub struct Load {
    /// Physical surface name.
    pub group: String,
    /// Pressure, Pa (positive pushes into the body).
    pub pressure: f64,
    /// Its scale in time (none: 1).
    pub curve: Option<crate::input::curve::Curve>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLoad {
    group: String,
    pressure: f64,
    #[serde(default)]
    curve: Option<Vec<Vec<f64>>>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBoundary {
    group: String,
    kind: String,
    #[serde(default)]
    #[serde(deserialize_with = "vec3::option")]
    velocity: Option<[f64; 3]>,
    #[serde(default)]
    curve: Option<Vec<Vec<f64>>>,
}

/// A probe field (docs/scene.md list).
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
    Temperature,
}

impl ProbeField {
    /// Every field with its column name.
    pub const ALL: [(ProbeField, &'static str); 16] = [
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
        (ProbeField::Temperature, "temperature"),
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

/// Output fields (docs/scene.md `[output] fields`).
pub const OUTPUT_FIELDS: [&str; 9] = [
    "displacement",
    "velocity",
    "stress",
    "plastic_strain",
    "pressure",
    "density",
    "rank",
    "temperature",
    "failed",
];

/// `[output]`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputDef {
    /// Fields to write (default: all; `temperature` where a material has one).
    #[serde(default = "d_fields")]
    pub fields: Vec<String>,
    /// Beyond docs/scene.md: every this many steps (and at step 0), the particles as a LIGGGHTS
    /// `dump custom` text file `dumps/dump.tdyn.<step>`; 0 (default) = none.
    #[serde(default)]
    pub dump_every: u64,
    /// Every this many seconds of simulated time, a restart checkpoint in `checkpoint/` (also
    /// at the end, and always at a clean stop); None (default): only at a clean stop.
    #[serde(default)]
    pub checkpoint_every: Option<f64>,
}

/// The default `[output] fields`: all but `temperature` and `failed`, which the scene check adds
/// where a material has thermal softening or failure.
pub(crate) fn d_fields() -> Vec<String> {
    OUTPUT_FIELDS
        .iter()
        .filter(|s| **s != "temperature" && **s != "failed")
        .map(|s| s.to_string())
        .collect()
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
        // (the British spelling the manual uses elsewhere is taken too)
        #[serde(deserialize_with = "vec3::exact", alias = "centre")]
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
    /// Beyond docs/scene.md: `region.file` is a LIGGGHTS `atom_style sph` data file (Atoms lines
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

/// `[sph] artificial_stress` (solid particles; Gray, Monaghan & Swift 2001).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArtificialStressDef {
    /// epsilon >= 0 (0: off), default 0.3.
    #[serde(default = "d_art_epsilon")]
    pub epsilon: f64,
    /// The exponent n >= 1 of f_ab^n, default 4.
    #[serde(default = "d_art_n")]
    pub n: i64,
}
fn d_art_epsilon() -> f64 {
    sph::solid::ARTIFICIAL_STRESS_EPSILON
}
fn d_art_n() -> i64 {
    sph::solid::ARTIFICIAL_STRESS_EXPONENT as i64
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
    /// Whether particles evolve their specific internal energy; omitted: where a particle
    /// material's eos depends on it ([`particles_needing_energy`]).
    #[serde(default)]
    pub energy: Option<bool>,
    #[serde(default)]
    pub artificial_viscosity: Option<ArtificialViscosity>,
    #[serde(default)]
    pub tensile_correction: Option<TensileCorrection>,
    /// Monaghan's artificial stress of solid particles (docs/scene.md); omitted: Gray et al.'s
    /// epsilon 0.3, n 4 where a `[[particles]]` entry is of a solid material.
    #[serde(default)]
    pub artificial_stress: Option<ArtificialStressDef>,
    #[serde(default)]
    pub periodic: Option<Periodic>,
    #[serde(default = "d_profile")]
    pub profile: String,
    /// Beyond docs/scene.md: h = adaptive_h (m/rho)^(1/3) after every step (standard profile).
    #[serde(default)]
    pub adaptive_h: Option<f64>,
    /// Beyond docs/scene.md: artificial thermal conductivity alpha_u (Price 2008), energy equation on.
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
    /// Whether particle centres are contact nodes; omitted: only where failed elements become
    /// particles (`ContactDef::particles_on`).
    #[serde(default)]
    pub particles: Option<bool>,
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

/// `[[rigid_wall]]`: an infinite plane that no node and no particle passes.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigidWallDef {
    /// Its name in reactions.csv (`<name>.force_x`, ...).
    pub name: String,
    /// A point of the plane at t = 0, m.
    #[serde(deserialize_with = "vec3::exact")]
    pub point: [f64; 3],
    /// The normal, towards the bodies (a unit vector once the scene is checked).
    #[serde(deserialize_with = "vec3::exact")]
    pub normal: [f64; 3],
    /// Coulomb's coefficient between the wall and everything on it (default 0).
    #[serde(default)]
    pub friction: f64,
    /// The wall's velocity (a translation), m/s; default at rest.
    #[serde(default, deserialize_with = "vec3::option")]
    pub velocity: Option<[f64; 3]>,
    /// A load curve `[[t, s], ...]` scaling `velocity` in time (docs/scene.md `curve`): the
    /// wall moves at `s(t) velocity`, its plane through `point + velocity * (the integral of s
    /// from 0 to t)`. Checked by [`crate::input::curve::check`]; none: `s = 1`.
    #[serde(default)]
    pub curve: Option<Vec<Vec<f64>>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    #[serde(default)]
    title: String,
    #[serde(default)]
    #[serde(deserialize_with = "vec3::exact")]
    gravity: [f64; 3],
    #[serde(default)]
    gravity_curve: Option<Vec<Vec<f64>>>,
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
    load: Vec<RawLoad>,
    #[serde(default)]
    particles: Vec<ParticlesDef>,
    #[serde(default)]
    sph: Option<SphDef>,
    #[serde(default)]
    contact: Option<ContactDef>,
    #[serde(default)]
    rigid_wall: Vec<RigidWallDef>,
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
    /// `gravity_curve`: gravity's scale in time (none: 1).
    pub gravity_curve: Option<crate::input::curve::Curve>,
    /// `[run]`.
    pub run: Run,
    /// `[[mesh]]`.
    pub meshes: Vec<MeshDef>,
    /// `[[material]]`.
    pub materials: Vec<MaterialSpec>,
    /// Each material's failure criterion (`failure`), in `materials`' order.
    pub failures: Vec<Option<fe_petsc::explicit::failure::Failure>>,
    /// `[[block]]`.
    pub blocks: Vec<Block>,
    /// `[[boundary]]`.
    pub boundaries: Vec<Boundary>,
    /// `[[load]]`.
    pub loads: Vec<Load>,
    /// `[[particles]]`.
    pub particles: Vec<ParticlesDef>,
    /// `[sph]`.
    pub sph: Option<SphDef>,
    /// `[contact]`.
    pub contact: Option<ContactDef>,
    /// `[[rigid_wall]]`, normals of unit length.
    pub rigid_walls: Vec<RigidWallDef>,
    /// `[[probe]]`.
    pub probes: Vec<Probe>,
    /// `[output]`.
    pub output: OutputDef,
    /// `[compare]`.
    pub compare: Option<CompareDef>,
    /// `[sweep]` (beyond docs/scene.md).
    pub sweep: Option<SweepDef>,
}

impl ContactDef {
    /// `particles`, or where omitted whether failed elements of `scene` become particles (they
    /// must meet the mesh they broke from).
    pub fn particles_on(&self, scene: &Scene) -> bool {
        self.particles.unwrap_or_else(|| scene.releases_any())
    }
}

impl Scene {
    /// Whether material `m` (index into `materials`) fails and its failed elements become
    /// particles (its blocks do not say `failed = "delete"`).
    pub fn releases(&self, m: usize) -> bool {
        let name = &self.materials[m].name;
        self.failures[m].is_some()
            && self
                .blocks
                .iter()
                .any(|b| &b.material == name && !b.deletes())
    }

    /// Whether any failed element becomes particles.
    pub fn releases_any(&self) -> bool {
        (0..self.materials.len()).any(|m| self.releases(m))
    }

    /// Whether the particles evolve their specific internal energy: `[sph] energy` where given,
    /// else where a particle material's eos depends on it ([`particles_needing_energy`]).
    pub fn sph_energy(&self) -> bool {
        self.sph
            .as_ref()
            .and_then(|s| s.energy)
            .unwrap_or_else(|| particles_needing_energy(&self.particles, &self.materials).is_some())
    }
}

/// The eos kinds whose pressure depends on the specific internal energy (`tait` does not).
pub const ENERGY_EOS: [&str; 3] = ["ideal_gas", "jwl", "mie_gruneisen"];

/// The first `[[particles]]` entry whose material's eos is of [`ENERGY_EOS`]: its index, its
/// material's name and the eos kind.
pub fn particles_needing_energy(
    particles: &[ParticlesDef],
    materials: &[MaterialSpec],
) -> Option<(usize, String, String)> {
    particles.iter().enumerate().find_map(|(i, p)| {
        let m = materials.iter().find(|m| m.name == p.material)?;
        let kind = &m.eos.as_ref()?.kind;
        ENERGY_EOS
            .contains(&kind.as_str())
            .then(|| (i, m.name.clone(), kind.clone()))
    })
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

mod check;
pub use check::{
    check_work, interaction_warnings, mode_warnings, num_text, parse, sph_warnings, unit_warnings,
    validate_groups, validate_groups_hold_elements, LOW_SOLID_DENSITY, LOW_YOUNGS_MODULUS,
};

#[cfg(test)]
mod tests;
