//! Explicit central-difference (velocity-Verlet form) integration of the distributed hex mesh.
//!
//! Every rank integrates all its local nodes, owned and ghost, with the same summed nodal force,
//! so that copies of a node stay identical without a second exchange: one ghost exchange
//! (local-to-global ADD, global-to-local INSERT) per step. The driver in `coupling` owns the order
//! of the stages; this type offers them one by one:
//!
//! ```text
//! v(n+1/2) = v(n) + dt/2 a(n)          (kick, then constraints)
//! x(n+1)   = x(n) + dt v(n+1/2)        (drift)
//! f(n+1)   = sum over elements          (element loop, ghost exchange)
//! a(n+1)   = f/m + g                    (constraints)
//! v(n+1)   = v(n+1/2) + dt/2 a(n+1)     (kick)
//! ```
//!
//! Energy bookkeeping uses the work of the nodal forces over each step's displacement,
//! W += (f(n) + f(n+1))/2 . (x(n+1) - x(n)), which velocity Verlet balances against the kinetic
//! energy to O(dt^2) without drift.
//!
//! This file holds the types; the stage's methods are in `explicit/`, one concern a file:
//! `setup` (construction, lumped masses), `integrator` (kick and drift, the closing kick),
//! `elements` (the element loop and its kernel dispatch), `constraints` (boundary conditions,
//! gravity, reactions), `loads` (pressure loads), `contact` (the push-back's impulses),
//! `energies` (the reduced sums), `restart` and `queries` (what output reads).
use crate::assembly::Assembly;
use crate::batch::{self, Batch, LaneMaterial, Width};
use crate::blocks::BlockWork;
use crate::curve::Curve;
use crate::exact::{self as exact_sum, Folds};
use crate::exact::{StepFolds, SumGrids};
use crate::hex::{self, HexControls, HexState};
use crate::material::Material;
use crate::mesh::{LocalMesh, NodeExchange};
use crate::nodal::{self, NodalSums};
use crate::petsc::PetscError;
use crate::states::HexStates;
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

mod constraints;
mod contact;
mod elements;
mod energies;
pub mod failure;
mod integrator;
mod loads;
mod queries;
mod restart;
pub use contact::ContactCorrection;
mod setup;
mod tets;
mod wall_hold;
pub use loads::{face_forces, Loads, PressureLoad};
pub use queries::ElementRef;
pub use restart::{restart_layout, RestartLayout, RESTART_DT_STABLE};
pub use tets::{TetPart, TetSums};
pub use wall_hold::WallHold;

/// A nodal constraint from a boundary condition.
#[derive(Debug, Clone, PartialEq)]
pub enum Constraint {
    /// All components zero.
    Fixed,
    /// All three components prescribed, m/s.
    Velocity([f64; 3]),
    /// The velocity components along these orthonormal directions are zero.
    Planes(Vec<[f64; 3]>),
}

/// What the element loop found wrong.
#[derive(Debug, Clone, thiserror::Error)]
pub enum StepError {
    /// An element's volume became zero or negative.
    #[error("element {elem} inverted (volume {volume:e} m^3) at t = {time:e} s, step {step}, near ({:.6e}, {:.6e}, {:.6e}) m", .at[0], .at[1], .at[2])]
    Inverted {
        /// Global element id.
        elem: u64,
        /// Its volume.
        volume: f64,
        /// Its centroid.
        at: [f64; 3],
        /// Time.
        time: f64,
        /// Step.
        step: u64,
    },
    /// A non-finite value appeared.
    #[error("non-finite value in {what} at t = {time:e} s, step {step}")]
    NonFinite {
        /// Which quantity.
        what: &'static str,
        /// Time.
        time: f64,
        /// Step.
        step: u64,
    },
    /// PETSc failed.
    #[error("{0}")]
    Petsc(#[from] PetscError),
}

/// Global energies and momentum (sums over ranks), J and kg m/s.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Energies {
    /// Kinetic energy.
    pub kinetic: f64,
    /// Stress work (elastic, plastic, bulk viscosity).
    pub internal: f64,
    /// Hourglass-force work.
    pub hourglass: f64,
    /// Work of gravity and of the reactions at constrained nodes.
    pub external_work: f64,
    /// Total linear momentum.
    pub momentum: [f64; 3],
}

/// Energies of one element block (a scene's `[[block]]`), global, J.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BlockEnergy {
    /// Stress work in the block's elements (elastic, plastic, bulk viscosity).
    pub internal: f64,
    /// Hourglass-force work in the block's elements.
    pub hourglass: f64,
    /// Kinetic energy of the block's share of the lumped masses at t = 0 (after boundary
    /// conditions act).
    pub kinetic0: f64,
    internal_plus_hg: f64,
}

/// Set-up of the explicit solver.
pub struct ExplicitSetup<'a> {
    /// The local mesh.
    pub mesh: &'a LocalMesh,
    /// One material per element (index into `materials`).
    pub elem_material: Vec<usize>,
    /// One material per native tetrahedron (`LocalMesh::tets`; index into `materials`).
    pub tet_material: Vec<usize>,
    /// One block per native tetrahedron (below `n_blocks`).
    pub tet_block: Vec<u32>,
    /// One block per element (below `n_blocks`): energies are also kept per block.
    pub elem_block: Vec<u32>,
    /// Number of blocks (at least 1).
    pub n_blocks: usize,
    /// The materials.
    pub materials: Vec<Box<dyn Material>>,
    /// Initial velocity of each local node (already consistent across ranks).
    pub velocity: Vec<[f64; 3]>,
    /// Constraints: (local node, constraint), at most one entry per node.
    pub constraints: Vec<(u32, Constraint)>,
    /// Hourglass and bulk-viscosity coefficients.
    pub controls: HexControls,
    /// Gravity, m/s^2.
    pub gravity: [f64; 3],
    /// The scale of gravity in time (none: 1).
    pub gravity_curve: Option<Curve>,
    /// The scale in time of each `Constraint::Velocity` in `constraints` (by index; empty or
    /// `None`: constant).
    pub velocity_curves: Vec<Option<Curve>>,
}

/// State and arrays of the explicit FE stage on one rank.
pub struct ExplicitFe {
    /// Connectivity (local node indices).
    pub elems: Vec<[u32; 8]>,
    /// Global element ids.
    pub elem_id: Vec<u64>,
    /// Reference coordinates.
    pub x0: Vec<[f64; 3]>,
    /// Current coordinates.
    pub x: Vec<[f64; 3]>,
    /// Velocities (at full steps between calls of `step`).
    pub v: Vec<[f64; 3]>,
    /// Accelerations: the implicit integrator's (its Newmark state); in the explicit step only
    /// the constrained nodes' (as their constraints leave them) and the initial ones, the free
    /// nodes' formed from the forces where needed ([`ExplicitFe::acceleration`]: 48 B per node
    /// and step not written and read back).
    pub a: Vec<[f64; 3]>,
    /// Lumped nodal masses.
    pub mass: Vec<f64>,
    /// Summed element forces on each node (incl. hourglass and bulk viscosity), N.
    pub force: Vec<[f64; 3]>,
    /// The nodal sums in canonical element order at any rank count ([`crate::assembly`]).
    pub(crate) assembly: Assembly,
    /// The old forces' sum f(n) . dx of this step's element work over the owned nodes (twice
    /// their half of the trapezoids), J: counted by the kick and the contact push-back, taken by
    /// `finish_step` (zero between steps).
    kick_work: Folds,
    /// The work of the constraints' reactions to the contact push-back over the owned nodes
    /// ([`ExplicitFe::apply_contact`]), J: taken by `finish_step` into the external work
    /// (zero between steps).
    contact_reaction_work: Folds,
    /// The grids of the energy and momentum sums ([`crate::exact`]), from the mass
    /// ([`ExplicitFe::initial_energies`]).
    pub grids: SumGrids,
    /// The constrained nodes, once each, in order.
    constrained_nodes: Vec<u32>,
    /// Their forces at the step's start (scratch of `kick_drift`).
    constrained_force: Vec<[f64; 3]>,
    reaction: Vec<[f64; 3]>,
    reaction_old: Vec<[f64; 3]>,
    /// The force each constraint (in `constraints`' order) took from this step's contact
    /// push-back ([`ExplicitFe::apply_contact`]), N: zero between steps without contact.
    contact_reaction: Vec<[f64; 3]>,
    /// Start positions of the step, where a contact stage reads them
    /// ([`ExplicitFe::set_contact_stage`]).
    x_old: Vec<[f64; 3]>,
    /// Each node's contact corrections: bit 0 set when a push-back or a wall moved it in the
    /// last step, bit 1 in this one (`kick_drift` shifts bit 1 into bit 0); what
    /// [`ExplicitFe::apply_contact`] books depends on it.
    pub(crate) pushed: Vec<u8>,
    /// Whether a contact stage runs between the kick and the element loop (it reads the start
    /// positions and the start-of-step forces there).
    contact: bool,
    /// The last kick's step, s ([`ExplicitFe::start_velocity`]).
    kick_dt: f64,
    /// Whether the kick left the forces zero for the element loop (no contact stage).
    forces_zeroed: bool,
    /// The constrained nodes' start positions, in `constraints`' order (scratch).
    constrained_start: Vec<[f64; 3]>,
    /// Whether this rank owns each node.
    pub owned: Vec<bool>,
    /// Element state (stress, hourglass forces), in the batched kernel's lane layout.
    pub state: HexStates,
    /// Material history variables, `mat_stride` per element.
    pub mat_state: Vec<f64>,
    mat_stride: usize,
    /// Reference volume of each element.
    pub vol0: Vec<f64>,
    /// Material index of each element.
    pub elem_material: Vec<usize>,
    /// The materials.
    pub materials: Vec<Box<dyn Material>>,
    constraints: Vec<(u32, Constraint)>,
    /// Each constraint's prescribed velocity and its scale in time, where it has a curve
    /// (index into `constraints`).
    velocity_curves: Vec<(usize, [f64; 3], Curve)>,
    controls: HexControls,
    /// Gravity now (at `time`), m/s^2: `gravity0` times its curve's value.
    gravity: [f64; 3],
    gravity0: [f64; 3],
    gravity_curve: Option<Curve>,
    /// The pressure loads, where the scene has any ([`ExplicitFe::set_loads`]).
    loads: Option<loads::Loads>,
    /// Accumulated energies (global).
    pub energies: Energies,
    internal_plus_hg: f64,
    /// Accumulated energies per block (global).
    pub block_energies: Vec<BlockEnergy>,
    /// This rank's per-block work bookkeeping.
    pub blocks: BlockWork,
    /// Smallest stable step over local elements from the last force evaluation (no safety).
    pub dt_stable_local: f64,
    /// Time.
    pub time: f64,
    /// Steps taken.
    pub step: u64,
    /// Seconds spent in the element loop, and in the ghost exchange, on this rank.
    pub timers: FeTimers,
    /// The element kernel's group size (default: the widest this CPU runs,
    /// [`batch::widest`]; [`Width::W1`] runs one element at a time).
    pub width: Width,
    /// The lane form of each material under the controls.
    lane_materials: Vec<LaneMaterial>,
    /// Whether each node has a constraint (its reactions are the only ones not zero).
    constrained: Vec<bool>,
    /// The native tetrahedra (`crate::tet`), where the mesh has any (on any rank).
    pub tets: Option<TetPart>,
    /// Element failure and erosion, where a material fails ([`ExplicitFe::set_failure`]).
    pub(crate) erosion: Option<Box<failure::Erosion>>,
    /// The rigid walls' holds of this step's closing kick ([`ExplicitFe::set_wall_holds`]).
    wall_holds: wall_hold::WallHolds,
}

/// What the element loop sums over elements.
struct LoopSums {
    hg_work: Folds,
    grid: exact_sum::Grid,
    dt_min: f64,
    /// The first inverted element.
    inverted: Option<StepError>,
}

/// Where the FE stage's time goes on this rank.
#[derive(Debug, Clone, Copy, Default)]
pub struct FeTimers {
    /// Element kernel (gather, element update, scatter-add).
    pub elements: f64,
    /// Ghost exchange through PETSc.
    pub exchange: f64,
    /// Nodal updates and energy sums.
    pub nodal: f64,
}

#[inline]
fn gather(xs: &[[f64; 3]], conn: &[u32; 8]) -> [[f64; 3]; 8] {
    let mut out = [[0.0; 3]; 8];
    for (o, &n) in out.iter_mut().zip(conn.iter()) {
        *o = xs[n as usize];
    }
    out
}

fn flat(v: &mut [[f64; 3]]) -> &mut [f64] {
    v.as_flattened_mut()
}

/// Applies a constraint to a velocity (`is_velocity`) or an acceleration.
#[inline]
fn apply(c: &Constraint, v: &mut [f64; 3], is_velocity: bool) {
    match c {
        Constraint::Fixed => *v = [0.0; 3],
        Constraint::Velocity(p) => *v = if is_velocity { *p } else { [0.0; 3] },
        Constraint::Planes(ns) => {
            for n in ns {
                let d = v[0] * n[0] + v[1] * n[1] + v[2] * n[2];
                for c in 0..3 {
                    v[c] -= d * n[c];
                }
            }
        }
    }
}

/// Centroid of an element's nodes.
pub fn centroid(x: &[[f64; 3]; 8]) -> [f64; 3] {
    let mut c = [0.0; 3];
    for p in x {
        for k in 0..3 {
            c[k] += p[k] / 8.0;
        }
    }
    c
}
