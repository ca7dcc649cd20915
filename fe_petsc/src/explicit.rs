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

mod contact;
mod elements;
mod loads;
mod queries;
mod restart;
pub use contact::ContactCorrection;
pub use loads::{face_forces, PressureLoad};
pub use restart::{restart_layout, RestartLayout, RESTART_DT_STABLE};

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
    /// Which element kernel the element loop runs (default: batched).
    pub kernel: ElementKernel,
    /// The batched kernel's group size: the widest this CPU runs ([`batch::widest`]).
    pub width: Width,
    /// The lane form of each material, where it has one under the controls.
    lane_materials: Vec<Option<LaneMaterial>>,
    /// Whether each node has a constraint (its reactions are the only ones not zero).
    constrained: Vec<bool>,
}

/// The element kernel of the explicit element loop.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum ElementKernel {
    /// One element at a time: the batched kernel's source ([`Batch::update`]) on a group of
    /// one element (its other lanes padding, their results dropped), so the same operations in
    /// the same order as in a group of four or eight, and the same bits (about four times the
    /// four-lane kernel's time per element); [`hex::update`] for a material without a lane form.
    Scalar,
    /// [`Batch::update`] on groups of consecutive elements of one material with a lane form
    /// (four or eight: [`ExplicitFe::width`]); the scalar kernel for the others.
    #[default]
    Batched,
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

impl ExplicitFe {
    /// Builds the solver: reference volumes, lumped masses (summed over ranks), initial state.
    pub fn new(setup: ExplicitSetup, exchange: &mut NodeExchange) -> Result<ExplicitFe, StepError> {
        let m = setup.mesh;
        let nn = m.coords.len();
        let ne = m.elems.len();
        let mat_stride = setup
            .materials
            .iter()
            .map(|mm| mm.n_state())
            .max()
            .unwrap_or(0);
        let mut mass3 = vec![[0.0; 3]; nn];
        // The lumped masses summed as the forces are ([`crate::assembly`]).
        let mut assembly = Assembly::new(&m.elems, &m.elem_key, exchange)?;
        let mut vol0 = Vec::with_capacity(ne);
        let mut mat_state = vec![0.0; ne * mat_stride];
        let mut inverted = None;
        for (e, conn) in m.elems.iter().enumerate() {
            let xe = gather(&m.coords, conn);
            let vol = hex::volume(&xe);
            if vol <= 0.0 || !vol.is_finite() {
                // Keep the first, finish the loop: the mass exchange below is collective, and
                // a rank that left before it would hang the others in it.
                inverted.get_or_insert(StepError::Inverted {
                    elem: m.elem_id[e],
                    volume: vol,
                    at: centroid(&xe),
                    time: 0.0,
                    step: 0,
                });
                vol0.push(0.0);
                continue;
            }
            vol0.push(vol);
            let mat = &setup.materials[setup.elem_material[e]];
            let me = mat.density() * vol / 8.0;
            for &n in conn {
                for c in 0..3 {
                    mass3[n as usize][c] += me;
                }
            }
            assembly.record(e, |_| [me; 3]);
            if mat_stride > 0 {
                mat.init_state(&mut mat_state[e * mat_stride..(e + 1) * mat_stride]);
            }
        }
        assembly.finish(&mut mass3, exchange)?;
        if let Some(e) = inverted {
            return Err(e);
        }
        let mass: Vec<f64> = mass3.iter().map(|m| m[0]).collect();
        let blocks = BlockWork::new(&m.elems, setup.elem_block, setup.n_blocks);
        let mut fe = ExplicitFe {
            elems: m.elems.clone(),
            elem_id: m.elem_id.clone(),
            x0: m.coords.clone(),
            x: m.coords.clone(),
            v: setup.velocity,
            a: vec![[0.0; 3]; nn],
            mass,
            force: vec![[0.0; 3]; nn],
            assembly,
            kick_work: [0.0; 3],
            grids: SumGrids::for_mass(1.0),
            constrained_nodes: Vec::new(),
            constrained_force: Vec::new(),
            reaction: vec![[0.0; 3]; nn],
            reaction_old: vec![[0.0; 3]; nn],
            contact_reaction: vec![[0.0; 3]; setup.constraints.len()],
            x_old: m.coords.clone(),
            pushed: vec![0; nn],
            contact: true,
            kick_dt: 0.0,
            forces_zeroed: false,
            constrained_start: Vec::new(),
            owned: m.owned.clone(),
            state: HexStates::new(ne),
            mat_state,
            mat_stride,
            vol0,
            elem_material: setup.elem_material,
            materials: setup.materials,
            velocity_curves: scaled_velocities(&setup.constraints, setup.velocity_curves),
            constraints: setup.constraints,
            controls: setup.controls,
            gravity: setup.gravity,
            gravity0: setup.gravity,
            gravity_curve: setup.gravity_curve,
            loads: None,
            energies: Energies::default(),
            internal_plus_hg: 0.0,
            block_energies: vec![BlockEnergy::default(); blocks.n_blocks()],
            blocks,
            dt_stable_local: f64::INFINITY,
            time: 0.0,
            step: 0,
            timers: FeTimers::default(),
            kernel: ElementKernel::default(),
            lane_materials: Vec::new(),
            width: batch::widest(),
            constrained: vec![false; nn],
        };
        fe.lane_materials = fe
            .materials
            .iter()
            .map(|m| LaneMaterial::new(&**m, &fe.controls))
            .collect();
        for (n, _) in &fe.constraints {
            fe.constrained[*n as usize] = true;
        }
        fe.constrained_nodes = (0..nn as u32)
            .filter(|&n| fe.constrained[n as usize])
            .collect();
        // Boundary conditions act on the initial velocities (a curve's value at t = 0); the
        // initial acceleration is gravity (zero stress), constrained.
        fe.gravity = fe.gravity_at(0.0);
        fe.scale_velocities(0.0, 0.0);
        fe.constrain_velocities();
        for n in 0..nn {
            fe.a[n] = fe.gravity;
        }
        fe.constrain_accelerations();
        fe.start_curved_velocities();
        fe.dt_stable_local = fe.initial_stable_dt();
        Ok(fe)
    }

    fn initial_stable_dt(&self) -> f64 {
        let mut dt = f64::INFINITY;
        for (e, conn) in self.elems.iter().enumerate() {
            let xe = gather(&self.x, conn);
            let mat = &*self.materials[self.elem_material[e]];
            // The initial volumetric rate (an impact at t = 0 compresses some elements from
            // the first step: a cold gas has almost no sound speed, and only the bulk
            // viscosity's damping, which grows with the rate, limits its step).
            let ve = gather(&self.v, conn);
            let (b, _) = hex::gradient(&xe);
            let div_v: f64 = (0..8)
                .map(|k| ve[k][0] * b[k][0] + ve[k][1] * b[k][1] + ve[k][2] * b[k][2])
                .sum();
            dt = dt.min(hex::stable_dt(
                &xe,
                mat.density(),
                mat,
                &self.controls,
                div_v,
            ));
        }
        dt
    }

    /// Gravity at time `t`: the scene's times its curve's value, m/s^2.
    fn gravity_at(&self, t: f64) -> [f64; 3] {
        match &self.gravity_curve {
            Some(c) => {
                let s = c.value(t);
                self.gravity0.map(|g| g * s)
            }
            None => self.gravity0,
        }
    }

    /// Sets each velocity constraint with a curve to its velocity times the curve's mean
    /// over the step `[t, t + dt]` (its value at `t` for `dt = 0`): in central differences
    /// the velocity of the half step, which moves the node by exactly the curve's integral.
    fn scale_velocities(&mut self, t: f64, dt: f64) {
        for (i, v, c) in &self.velocity_curves {
            let s = c.mean(t, dt);
            self.constraints[*i].1 = Constraint::Velocity(v.map(|x| x * s));
        }
    }

    /// The pressure loads of this rank (collective: every rank calls it, with the same
    /// number of loads; none: nothing to do): their forces at the present positions and
    /// time are added to the nodal forces the next kick reads.
    pub fn set_loads(
        &mut self,
        sets: Vec<PressureLoad>,
        exchange: &mut NodeExchange,
    ) -> Result<(), StepError> {
        if sets.is_empty() {
            return Ok(());
        }
        let mut l = loads::Loads::new(sets, self.x.len(), exchange)?;
        l.evaluate(&self.x, self.time, exchange)?;
        for &n in &l.nodes {
            let n = n as usize;
            for c in 0..3 {
                self.force[n][c] += l.now[n][c];
            }
        }
        self.loads = Some(l);
        Ok(())
    }

    /// After a restart: the loads at the restored positions and time, as the step that
    /// wrote the checkpoint left them (its forces, restored, already hold them); gravity at
    /// the restored time (collective).
    pub fn refresh_after_restart(&mut self, exchange: &mut NodeExchange) -> Result<(), StepError> {
        self.gravity = self.gravity_at(self.time);
        if let Some(l) = &mut self.loads {
            l.evaluate(&self.x, self.time, exchange)?;
        }
        Ok(())
    }

    /// The loads at the step's end (time `t`, the present positions) added to the summed
    /// element forces; the last step's kept for the work (collective).
    fn add_loads(&mut self, t: f64, exchange: &mut NodeExchange) -> Result<(), PetscError> {
        let Some(l) = &mut self.loads else {
            return Ok(());
        };
        l.keep();
        l.evaluate(&self.x, t, exchange)?;
        for &n in &l.nodes {
            let n = n as usize;
            for c in 0..3 {
                self.force[n][c] += l.now[n][c];
            }
        }
        Ok(())
    }

    /// The loads' work over the step on the owned loaded nodes, with the displacement dt v
    /// (`v` the half-step velocities): the trapezoid (L(n) + L(n+1))/2 . dx into the external
    /// work, and the same forces' f . dx taken out of the element work's sum (the nodal
    /// forces the kick and the closing pass summed include the loads).
    fn load_work(&self, dt: f64, sums: &mut StepFolds) {
        let Some(l) = &self.loads else {
            return;
        };
        let e = &self.grids.energy;
        for (old, &n) in l.old.iter().zip(&l.nodes) {
            let n = n as usize;
            if !self.owned[n] {
                continue;
            }
            let now = l.now[n];
            for c in 0..3 {
                let dx = dt * self.v[n][c];
                let both = old[c] + now[c];
                e.add(&mut sums[2], (0.5 * both) * dx);
                e.add(&mut sums[1], -(both * dx));
            }
        }
    }

    /// The velocity constraints with a curve at t = 0: their acceleration v ds/dt (the
    /// slope just after the start), and the reaction that gives it (m a - m g: no element
    /// force yet), the first step's trapezoid of the reaction's work starting from it.
    fn start_curved_velocities(&mut self) {
        for (i, v, c) in &self.velocity_curves {
            let n = self.constraints[*i].0 as usize;
            let rate = c.slope_after(0.0);
            self.a[n] = v.map(|x| x * rate);
            for k in 0..3 {
                self.reaction[n][k] = self.mass[n] * (self.a[n][k] - self.gravity[k]);
            }
        }
    }

    fn constrain_velocities(&mut self) {
        for (n, c) in &self.constraints {
            let v = &mut self.v[*n as usize];
            apply(c, v, true);
        }
    }

    fn constrain_accelerations(&mut self) {
        for (n, c) in &self.constraints {
            let a = &mut self.a[*n as usize];
            apply(c, a, false);
        }
    }

    /// The force each constraint applies to its node at the end of the last step, N, for the
    /// constrained local nodes in `constraints`' order (the explicit mode's; the implicit
    /// integrator has its own, `ImplicitFe::constraint_reactions`).
    ///
    /// Central differences at a constrained node n (mass m, element force f: stress, hourglass
    /// and bulk viscosity, gravity g): m a(n+1) = f(n+1) + m g + R(n+1), and the constraint
    /// prescribes a(n+1) (0 for `fixed` and `velocity`, its tangential part for symmetry
    /// planes), so R = m a_prescribed - f - m g = m (a_constrained - a_free), a_free = f/m + g
    /// (`finish_step` keeps it). The contact push-back between the kicks adds the impulse
    /// F_c dt, of which the constraint removes the part it does not allow: its force over the
    /// step is m (dv_constrained - dv_free) / dt (-F_c at a fixed node), added here
    /// ([`ExplicitFe::apply_contact`]). With R at every step, the bodies' momentum changes over
    /// a step by dt/2 (R(n) + R(n+1)) summed over nodes, plus M g dt (velocity Verlet's two
    /// half kicks; the element forces sum to zero): the trapezoid rule over the rows of
    /// reactions.csv integrates the reactions exactly.
    pub fn constraint_reactions(&self) -> impl Iterator<Item = (u32, [f64; 3])> + '_ {
        self.constraints
            .iter()
            .zip(&self.contact_reaction)
            .map(|((n, _), rc)| {
                let i = *n as usize;
                // Before the first step: the initial state's (`new`: a(0) constrained).
                let r = if self.step == 0 {
                    let (m, a, f, g) = (self.mass[i], self.a[i], self.force[i], self.gravity);
                    std::array::from_fn(|c| m * (a[c] - g[c]) - f[c])
                } else {
                    self.reaction[i]
                };
                (*n, std::array::from_fn(|c| r[c] + rc[c]))
            })
    }

    /// Number of local nodes.
    pub fn n_nodes(&self) -> usize {
        self.x.len()
    }

    /// Whether the nodal passes go eight nodes at a time (`nodal`): where the element kernel
    /// runs eight lanes (the CPU has AVX-512F).
    fn wide_nodes(&self) -> bool {
        #[cfg(target_arch = "x86_64")]
        return self.width == Width::W8;
        #[cfg(not(target_arch = "x86_64"))]
        return false;
    }

    /// First half of the step: kick to the half step, apply constraints, drift the positions.
    pub fn kick_drift(&mut self, dt: f64) {
        let t0 = std::time::Instant::now();
        // One pass: kick, keep the start position, drift (`nodal::kick_drift`); then the
        // constrained nodes' velocities and drifts again.
        let wide = self.wide_nodes();
        // The constrained nodes' start positions (every node's where they are kept).
        self.constrained_start.clear();
        let x = &self.x;
        let starts = self.constraints.iter().map(|(n, _)| x[*n as usize]);
        self.constrained_start.extend(starts);
        let t = self.time;
        self.gravity = self.gravity_at(t);
        for p in &mut self.pushed {
            *p >>= 1;
        }
        let x_old = self.contact.then_some(&mut self.x_old[..]);
        // The constrained owned nodes' forces, read below after the kick may have zeroed them.
        self.constrained_force.clear();
        let f = &self.force;
        let kept = self.constrained_nodes.iter().map(|&n| f[n as usize]);
        self.constrained_force.extend(kept);
        let input = nodal::KickInput {
            energy: self.grids.energy,
            mass: &self.mass,
            gravity: self.gravity,
            owned: &self.owned,
            constrained: &self.constrained,
        };
        let zero = !self.contact;
        self.kick_dt = dt;
        let mut work = nodal::kick_drift(
            &mut self.v,
            &mut self.force,
            zero,
            &input,
            &mut self.x,
            x_old,
            dt,
            wide,
        );
        self.forces_zeroed = zero;
        self.contact_reaction.fill([0.0; 3]);
        self.scale_velocities(t, dt);
        self.constrain_velocities();
        for ((n, _), x0) in self.constraints.iter().zip(&self.constrained_start) {
            let n = *n as usize;
            for c in 0..3 {
                self.x[n][c] = x0[c] + dt * self.v[n][c];
            }
        }
        // The constrained owned nodes' f(n) . dt v(n+1/2), with their constrained velocities.
        for (&n, f) in self.constrained_nodes.iter().zip(&self.constrained_force) {
            let n = n as usize;
            if self.owned[n] {
                let v = self.v[n];
                for c in 0..3 {
                    self.grids.energy.add(&mut work, f[c] * (dt * v[c]));
                }
            }
        }
        self.kick_work = work;
        self.timers.nodal += t0.elapsed().as_secs_f64();
    }

    /// Second half of the step: accelerations, constraints and reactions, the closing kick, and
    /// the local energy increments. Returns the local sums to be reduced, raw
    /// ([`StepFolds`]: [`ExplicitFe::accumulate`] scales them).
    pub fn finish_step(&mut self, dt: f64) -> StepFolds {
        let t0 = std::time::Instant::now();
        // Gravity at the step's end; its work over the step with the mean of both ends
        // (the trapezoid of m g . dx; g itself when it does not change).
        let g_old = self.gravity;
        self.gravity = self.gravity_at(self.time + dt);
        let g = self.gravity;
        let gravity_work = if g == g_old {
            g
        } else {
            std::array::from_fn(|c| 0.5 * (g_old[c] + g[c]))
        };
        let h = 0.5 * dt;
        let mut sums = [[0.0; 3]; 6];
        self.load_work(dt, &mut sums);
        let nn = self.x.len();
        // The arrays as slices of one length, borrowed field by field (the loops below index
        // them without bounds checks and keep the sums in registers: through `&self` methods
        // this pass took about 235 instructions per node, the sums not inlined).
        let read = NodalSums {
            dt,
            force: &self.force[..nn],
            mass: &self.mass[..nn],
            owned: &self.owned[..nn],
            gravity: g,
            gravity_work,
            grids: self.grids,
        };
        let constrained = &self.constrained[..nn];
        let wide = self.wide_nodes();
        let (a, v) = (&mut self.a[..nn], &mut self.v[..nn]);
        // One pass over the free nodes: closing kick and sums (their accelerations are not
        // kept: the next kick forms them from the same forces).
        nodal::close_free(&read, constrained, v, &mut sums, wide);
        // The constrained nodes: their free accelerations, then reaction = m a(constrained) -
        // m a(free), the force the constraint adds; then their kick and sums.
        for (node, _) in &self.constraints {
            let n = *node as usize;
            let (f, im) = (read.force[n], 1.0 / read.mass[n]);
            a[n] = [f[0] * im + g[0], f[1] * im + g[1], f[2] * im + g[2]];
        }
        std::mem::swap(&mut self.reaction, &mut self.reaction_old);
        // A velocity with a curve: its acceleration v ds/dt at the step's end, so the
        // reaction holds the force that changes the driven nodes' momentum.
        let t1 = self.time + dt;
        let mut curved = self.velocity_curves.iter().peekable();
        for (i, (node, con)) in self.constraints.iter().enumerate() {
            let n = *node as usize;
            let free = a[n];
            apply(con, &mut a[n], false);
            if let Some((_, v, curve)) = curved.next_if(|(k, _, _)| *k == i) {
                let rate = curve.slope(t1);
                a[n] = v.map(|x| x * rate);
            }
            for c in 0..3 {
                self.reaction[n][c] = read.mass[n] * (a[n][c] - free[c]);
            }
        }
        for &n in &self.constrained_nodes {
            let n = n as usize;
            let vn = &mut v[n];
            let half = *vn;
            for c in 0..3 {
                vn[c] += h * a[n][c];
            }
            read.add(
                n,
                *vn,
                half,
                self.reaction[n],
                self.reaction_old[n],
                &mut sums,
            );
        }
        // The element work's other half, counted at the kick (`nodal::kick_drift`).
        exact_sum::merge(&mut sums[1], &std::mem::take(&mut self.kick_work));
        self.timers.nodal += t0.elapsed().as_secs_f64();
        sums
    }

    /// The local sums of a step to be reduced over ranks (one reduction, MPI's sum), as
    /// folds laid out flat ([`exact_sum::flatten`]): `finish_step`'s six, the element loop's
    /// hourglass work, then with several blocks `blocks.step_sums`.
    pub fn step_sums(&self, finish: &StepFolds, hg_work: &Folds) -> Vec<f64> {
        let mut v = finish.to_vec();
        v.push(*hg_work);
        if self.blocks.active() {
            v.extend_from_slice(&self.blocks.step_sums);
        }
        exact_sum::flatten(&v)
    }

    /// Applies the reduced sums of a step (`step_sums` summed over ranks) to the global
    /// energies: the kinetic energy is half the sum of m v.v, the change of internal plus
    /// hourglass energy minus half the sum of f . dx over both halves of the trapezoids.
    pub fn accumulate(&mut self, global_folds: &[f64], dt: f64) {
        let global = exact_sum::values(global_folds);
        self.energies.kinetic = 0.5 * global[0];
        self.internal_plus_hg += -0.5 * global[1];
        self.energies.external_work += global[2];
        self.energies.momentum = [global[3], global[4], global[5]];
        self.energies.hourglass += global[6];
        self.energies.internal = self.internal_plus_hg - self.energies.hourglass;
        let nb = self.block_energies.len();
        if self.blocks.active() {
            for (b, be) in self.block_energies.iter_mut().enumerate() {
                be.internal_plus_hg += global[7 + b];
                be.hourglass += global[7 + nb + b];
                be.internal = be.internal_plus_hg - be.hourglass;
            }
        } else if let Some(be) = self.block_energies.first_mut() {
            be.internal = self.energies.internal;
            be.hourglass = self.energies.hourglass;
        }
        self.time += dt;
        self.step += 1;
    }

    /// Global kinetic energy and momentum now (collective); used at step 0. Also each block's
    /// kinetic energy: its elements' lumped masses (rho V0 / 8 per corner) at their nodes'
    /// velocities, so that a node between blocks counts in each by its share of mass.
    pub fn initial_energies(&mut self, comm: &SimpleCommunicator) {
        // The grids of every energy and momentum sum, from the mass summed exactly.
        let owned_mass: Vec<f64> = (0..self.x.len())
            .filter(|&n| self.owned[n] && self.mass[n].is_finite())
            .map(|n| self.mass[n])
            .collect();
        self.grids = SumGrids::for_mass(exact_sum::total(comm, &owned_mass));
        self.blocks.grid = self.grids.energy;
        let (ge, gp) = (self.grids.energy, self.grids.momentum);
        let nb = self.block_energies.len();
        let mut s = vec![[0.0; 3]; 4 + nb];
        for n in 0..self.x.len() {
            if self.owned[n] {
                let m = self.mass[n];
                let v = self.v[n];
                for c in 0..3 {
                    ge.add(&mut s[0], m * (v[c] * v[c]));
                    gp.add(&mut s[1 + c], m * v[c]);
                }
            }
        }
        for (e, conn) in self.elems.iter().enumerate() {
            let me = self.materials[self.elem_material[e]].density() * self.vol0[e] / 8.0;
            let b = self.blocks.block_of(e);
            for &n in conn {
                let v = self.v[n as usize];
                for c in 0..3 {
                    ge.add(&mut s[4 + b], me * (v[c] * v[c]));
                }
            }
        }
        let flat = exact_sum::flatten(&s);
        let mut g = vec![0.0; flat.len()];
        comm.all_reduce_into(&flat[..], &mut g[..], SystemOperation::sum());
        let g = exact_sum::values(&g);
        self.energies.kinetic = 0.5 * g[0];
        self.energies.momentum = [g[1], g[2], g[3]];
        for (b, be) in self.block_energies.iter_mut().enumerate() {
            be.kinetic0 = 0.5 * g[4 + b];
        }
    }
}

/// Each velocity constraint with a curve: (index in `constraints`, velocity, curve), in
/// index order.
fn scaled_velocities(
    constraints: &[(u32, Constraint)],
    curves: Vec<Option<Curve>>,
) -> Vec<(usize, [f64; 3], Curve)> {
    curves
        .into_iter()
        .enumerate()
        .filter_map(|(i, c)| match (&constraints[i].1, c) {
            (Constraint::Velocity(v), Some(c)) => Some((i, *v, c)),
            _ => None,
        })
        .collect()
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
