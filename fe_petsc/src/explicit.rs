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

/// How a named restart array ([`ExplicitFe::restart_state`], `ImplicitFe::restart_state`)
/// lies over the ranks: what a restart on another rank count needs to move it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RestartLayout {
    /// A fixed number of values per local node, in local order; every copy of a node holds the
    /// same values (each rank integrates its ghosts with the same summed force), so any copy
    /// serves.
    Node,
    /// A fixed number of values per local element, in local order.
    Element,
    /// The same on every rank (global energies, the clock), except the entry
    /// [`RESTART_DT_STABLE`] of `fe.scalars`: this rank's smallest stable step.
    Global,
}

/// The index in `fe.scalars` of the rank's own smallest stable step (the others are global).
pub const RESTART_DT_STABLE: usize = 8;

/// The layout of the restart array `name`; `None` for a name neither integrator writes.
pub fn restart_layout(name: &str) -> Option<RestartLayout> {
    use RestartLayout::*;
    Some(match name {
        "fe.x"
        | "fe.x_old"
        | "fe.v"
        | "fe.a"
        | "fe.force"
        | "fe.reaction"
        | "fe.reaction_old"
        | "implicit.force_n"
        | "implicit.reaction_n" => Node,
        "fe.hex_state" | "fe.mat_state" | "fe.block_forces" => Element,
        "fe.scalars" | "fe.block_energies" | "implicit.force_scale_max" => Global,
        _ => return None,
    })
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
    assembly: Assembly,
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
    /// Start positions of the step, where a contact stage reads them
    /// ([`ExplicitFe::set_contact_stage`]).
    x_old: Vec<[f64; 3]>,
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
    controls: HexControls,
    gravity: [f64; 3],
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
            x_old: m.coords.clone(),
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
            constraints: setup.constraints,
            controls: setup.controls,
            gravity: setup.gravity,
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
        // Boundary conditions act on the initial velocities; the initial acceleration is
        // gravity (zero stress), constrained.
        fe.constrain_velocities();
        for n in 0..nn {
            fe.a[n] = fe.gravity;
        }
        fe.constrain_accelerations();
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

    /// Positions at the start of the step (before `kick_drift` moved them). Panics without a
    /// contact stage ([`ExplicitFe::set_contact_stage`]): they are not kept then.
    pub fn x_start(&self) -> &[[f64; 3]] {
        assert!(
            self.contact,
            "the start positions are not kept (no contact stage)"
        );
        &self.x_old
    }

    /// Whether a contact stage runs between `kick_drift` and `element_forces` (the default).
    /// It reads every node's start position ([`ExplicitFe::x_start`]) and the start-of-step
    /// forces ([`ExplicitFe::acceleration`], the push-back's work). A model without contact
    /// turns it off: the kick then neither copies nor holds the start positions (48 B per
    /// node-step with the line's fill, 24 B per node) and zeroes the forces as it reads them,
    /// so that the element loop needs no pass to clear them (about 1.5 ns per element-cycle).
    pub fn set_contact_stage(&mut self, present: bool) {
        self.contact = present;
        self.x_old = if present { self.x.clone() } else { Vec::new() };
    }

    /// Whether local node `n` has a constraint that prescribes all its velocity components
    /// (fixed or velocity): contact treats it as an infinite mass.
    pub fn fully_constrained(&self) -> Vec<bool> {
        let mut out = vec![false; self.x.len()];
        for (n, c) in &self.constraints {
            if matches!(c, Constraint::Fixed | Constraint::Velocity(_)) {
                out[*n as usize] = true;
            }
        }
        out
    }

    /// Sums contact push-back forces over ranks: `force` holds each node's force on this
    /// rank's owned nodes (zero on the others); after the call every copy holds the sum.
    pub fn sum_contact_forces(
        &mut self,
        force: &mut [[f64; 3]],
        exchange: &mut NodeExchange,
    ) -> Result<(), StepError> {
        exchange.sum_shared(flat(force))?;
        Ok(())
    }

    /// The terms `[A, B]` of the change of the half-step kinetic energy that the summed
    /// contact forces `force` scaled by `alpha` make, `dK(alpha) = alpha A + alpha^2 B`, over
    /// owned nodes: `A = sum m dv . v(n+1/2)`, `B = sum m |dv|^2 / 2` for the constrained
    /// velocity corrections `dv = F dt / m` (J). Called after `kick_drift`, before
    /// `apply_contact`.
    pub fn contact_energy_terms(&self, force: &[[f64; 3]], dt: f64) -> [Folds; 2] {
        let mut t = [[0.0; 3]; 2];
        let e = &self.grids.energy;
        for n in 0..self.x.len() {
            let f = force[n];
            if f == [0.0; 3] || !self.owned[n] {
                continue;
            }
            let dv = self.contact_dv(n, f, dt);
            let v = self.v[n];
            for c in 0..3 {
                e.add(&mut t[0], self.mass[n] * dv[c] * v[c]);
                e.add(&mut t[1], 0.5 * self.mass[n] * dv[c] * dv[c]);
            }
        }
        t
    }

    /// Node `n`'s velocity correction for contact force `f` over `dt`, its constraints applied.
    fn contact_dv(&self, n: usize, f: [f64; 3], dt: f64) -> [f64; 3] {
        let mut dv = [
            f[0] * dt / self.mass[n],
            f[1] * dt / self.mass[n],
            f[2] * dt / self.mass[n],
        ];
        if self.constrained[n] {
            for (m, c) in &self.constraints {
                if *m as usize == n {
                    apply(c, &mut dv, false);
                }
            }
        }
        dv
    }

    /// Applies contact push-back forces after `kick_drift`: `force` holds each node's force
    /// summed over ranks ([`ExplicitFe::sum_contact_forces`]); the half-step velocity gets
    /// `F dt / m` and the position `F dt^2 / m`, with the nodal constraints applied to the
    /// correction. Returns the local work of the push-back over owned nodes,
    /// `m dv . (v + dv/2 - a_n dt/2)` with `dv` the velocity correction: what closes the energy
    /// balance of the step with the element and external work.
    pub fn apply_contact(&mut self, force: &[[f64; 3]], dt: f64) -> Folds {
        let mut cons: Vec<Option<usize>> = vec![None; self.x.len()];
        for (i, (n, _)) in self.constraints.iter().enumerate() {
            cons[*n as usize] = Some(i);
        }
        let mut work = [0.0; 3];
        let grid = self.grids.energy;
        for n in 0..self.x.len() {
            let f = force[n];
            if f == [0.0; 3] {
                continue;
            }
            let mut dv = [
                f[0] * dt / self.mass[n],
                f[1] * dt / self.mass[n],
                f[2] * dt / self.mass[n],
            ];
            if let Some(i) = cons[n] {
                apply(&self.constraints[i].1, &mut dv, false);
            }
            let a_n = self.acceleration(n);
            if self.owned[n] {
                // The old forces' half of the element work over the push-back's dt dv.
                let f = self.force[n];
                for c in 0..3 {
                    grid.add(&mut self.kick_work, f[c] * (dt * dv[c]));
                }
            }
            for c in 0..3 {
                if self.owned[n] {
                    // The change of the half-step kinetic energy, less the part of the start
                    // kick that the element and external work (trapezoids over the corrected
                    // displacement) already count: velocity Verlet with an impulse dv between
                    // the kicks gives dKE = W_trapezoid + m dv.(v + dv/2) - (dt/2) m a_n.dv.
                    let w = self.mass[n] * dv[c] * (self.v[n][c] + 0.5 * dv[c] - 0.5 * dt * a_n[c]);
                    grid.add(&mut work, w);
                }
                self.v[n][c] += dv[c];
                self.x[n][c] += dv[c] * dt;
            }
        }
        work
    }

    /// Node `n`'s velocity at the start of the step (between `kick_drift` and the element
    /// loop), `v(n) = v(n+1/2) - a(n) dt / 2` with the kick's `dt`, m/s: the velocity against
    /// which the step's energy balance measures a contact correction
    /// ([`ExplicitFe::apply_contact`]'s work is `m dv . (v(n) + dv/2)`).
    pub fn start_velocity(&self, n: usize) -> [f64; 3] {
        let (a, h) = (self.acceleration(n), 0.5 * self.kick_dt);
        let v = self.v[n];
        [v[0] - h * a[0], v[1] - h * a[1], v[2] - h * a[2]]
    }

    /// Node `n`'s acceleration at the start of the step (between `kick_drift` and the element
    /// loop: the forces are the last step's), m/s^2: f / m + g, as the kick formed it; a
    /// constrained node's as its constraints left it in the last `finish_step` (kept in `a`).
    pub fn acceleration(&self, n: usize) -> [f64; 3] {
        assert!(
            !self.forces_zeroed,
            "the kick cleared the forces (no contact stage: `set_contact_stage`)"
        );
        if self.constrained[n] {
            return self.a[n];
        }
        let (f, im, g) = (self.force[n], 1.0 / self.mass[n], self.gravity);
        [f[0] * im + g[0], f[1] * im + g[1], f[2] * im + g[2]]
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

    /// Element loop at the new positions with the half-step velocities, then the ghost
    /// exchange. Returns the local hourglass work of this step; sets `dt_stable_local`.
    ///
    /// With [`ElementKernel::Batched`] (the default), groups of consecutive elements of one
    /// material with a lane form ([`LaneMaterial`]) are updated together by [`Batch::update`]
    /// (four or eight at once: [`ExplicitFe::width`]); the other elements, and a group with an
    /// inverted element, go through [`hex::update`] one by one. Either way each element's forces are added to the nodes in element order (the
    /// canonical order, [`crate::assembly`]), so the two kernels' sums are the same.
    pub fn element_forces(
        &mut self,
        dt: f64,
        exchange: &mut NodeExchange,
    ) -> Result<Folds, StepError> {
        let t0 = std::time::Instant::now();
        // The last step's forces were last read by the kick and the contact push-back; the
        // kick zeroed them where no contact stage reads them after it.
        if !std::mem::take(&mut self.forces_zeroed) {
            for f in self.force.iter_mut() {
                *f = [0.0; 3];
            }
        }
        let mut sums = LoopSums {
            hg_work: [0.0; 3],
            grid: self.grids.energy,
            dt_min: f64::INFINITY,
            inverted: None,
        };
        self.blocks.begin();
        match self.width {
            Width::W4 => self.element_loop::<batch::w4::LaneGroup>(dt, &mut sums),
            #[cfg(target_arch = "x86_64")]
            Width::W8 => self.element_loop::<batch::w8::LaneGroup>(dt, &mut sums),
        }
        self.dt_stable_local = sums.dt_min;
        if sums.inverted.is_none() {
            // The nodes' displacement over the step, dt v(n+1/2) (see `NodalSums::add`).
            let v = &self.v;
            self.blocks
                .accept(|n| std::array::from_fn(|c| dt * v[n][c]));
        }
        let t1 = std::time::Instant::now();
        self.timers.elements += (t1 - t0).as_secs_f64();
        // The shared nodes' forces in canonical element order over all ranks holding them.
        self.assembly.finish(&mut self.force, exchange)?;
        self.timers.exchange += t1.elapsed().as_secs_f64();
        match sums.inverted {
            Some(e) => Err(e),
            None => Ok(sums.hg_work),
        }
    }

    /// Every element's update, in element order. Each run of consecutive elements of one
    /// material with a lane form goes through the batched kernel in groups of `B::LANES`, the
    /// run's last group padded (see [`Self::group_update`]); other elements, and a group with
    /// an inverted element, through the scalar kernel.
    ///
    /// So every element of a lane material is updated by the same kernel source however the
    /// elements are dealt to ranks and whatever the width: every width runs the same IEEE
    /// operations in the same order (no fused multiply-adds), so an element's result does not
    /// depend on its group, its lane or its rank's share (SCENE.md, "One answer").
    fn element_loop<B: Batch>(&mut self, dt: f64, sums: &mut LoopSums) {
        let mut group = Box::<B>::default();
        let mut e = 0;
        while e < self.elems.len() {
            let n = self.lane_run(e, B::LANES);
            if n == 0 {
                self.element_update(e, dt, sums);
                e += 1;
                continue;
            }
            let m = self.lane_materials[self.elem_material[e]].expect("a lane run");
            if !self.group_update(e, n, &m, dt, &mut *group, sums) {
                // An inverted element in the group: the scalar kernel names it.
                for k in e..e + n {
                    self.element_update(k, dt, sums);
                }
            }
            e += n;
        }
    }

    /// How many of the elements `e..` go into one batched group: those that exist, lie before
    /// the next multiple of `lanes` and share `e`'s material, when that material has a lane
    /// form (one with [`ElementKernel::Scalar`]); 0 otherwise. (Groups end at multiples of
    /// `lanes` so that a whole group finds its state as whole vectors in [`HexStates`].)
    fn lane_run(&self, e: usize, lanes: usize) -> usize {
        let mi = self.elem_material[e];
        if self.lane_materials[mi].is_none() {
            return 0;
        }
        if self.kernel == ElementKernel::Scalar {
            return 1;
        }
        let end = ((e / lanes + 1) * lanes).min(self.elems.len());
        (e..end)
            .take_while(|&k| self.elem_material[k] == mi)
            .count()
    }

    /// Updates element `e` with the scalar kernel and adds its output (an inverted element is
    /// recorded in `sums`, the first one kept: the ghost exchange after the loop is
    /// collective, and a rank that left before it would hang the others in it).
    fn element_update(&mut self, e: usize, dt: f64, sums: &mut LoopSums) {
        let conn = &self.elems[e];
        let xe = gather(&self.x, conn);
        let ve = gather(&self.v, conn);
        let mat = &*self.materials[self.elem_material[e]];
        let stride = self.mat_stride;
        let ms = &mut self.mat_state[e * stride..(e + 1) * stride];
        let mut st = self.state.get(e);
        match hex::update(
            &xe,
            &ve,
            dt,
            mat.density(),
            self.vol0[e],
            mat,
            &self.controls,
            &mut st,
            ms,
        ) {
            Ok(out) => {
                self.state.set(e, &st);
                self.add_output(e, &out, sums)
            }
            Err(hex::ElementError::Inverted { volume }) => {
                sums.inverted.get_or_insert(StepError::Inverted {
                    elem: self.elem_id[e],
                    volume,
                    at: centroid(&xe),
                    time: self.time + dt,
                    step: self.step + 1,
                });
            }
        }
    }

    /// Updates elements `e0..e0 + n` (material `m`, `n` at most `B::LANES`, the group not
    /// crossing a multiple of `B::LANES`) with the batched kernel in the buffer `g` and adds
    /// their outputs in element order; `false`, with nothing changed, when one of them is
    /// inverted. A whole group moves its state as whole vectors ([`Batch::update_lanes`]); a
    /// group of fewer than `B::LANES` elements fills its other lanes with copies of element
    /// `e0`, whose results are dropped (lanes are independent: each computes its own element
    /// only).
    fn group_update<B: Batch>(
        &mut self,
        e0: usize,
        n: usize,
        m: &LaneMaterial,
        dt: f64,
        g: &mut B,
        sums: &mut LoopSums,
    ) -> bool {
        let stride = self.mat_stride;
        let history = m.n_state() > 0;
        let ok = if n == B::LANES && (stride == 1 || !history) {
            let lanes = e0..e0 + n;
            let mut io = batch::GroupLanes {
                xs: &self.x,
                vs: &self.v,
                conn: &self.elems[lanes.clone()],
                vol0: &self.vol0[lanes.clone()],
                state: self.state.lanes_mut(e0),
                history: history.then(|| &mut self.mat_state[lanes]),
                force: Some(&mut self.force),
            };
            // The forces added to the nodes in the kernel.
            g.update_lanes(&mut io, dt, m, &self.controls)
                .is_ok()
                .then_some(true)
        } else {
            self.group_update_by_lane(e0, n, m, dt, g).then_some(false)
        };
        let Some(added) = ok else {
            return false;
        };
        self.add_group_output(e0, n, g, !added, sums);
        true
    }

    /// [`ExplicitFe::group_update`]'s path for a part group or materials with several
    /// history values per element: the lanes loaded and stored one element at a time.
    fn group_update_by_lane<B: Batch>(
        &mut self,
        e0: usize,
        n: usize,
        m: &LaneMaterial,
        dt: f64,
        g: &mut B,
    ) -> bool {
        let stride = self.mat_stride;
        let history = m.n_state() > 0;
        let elem = |l: usize| e0 + if l < n { l } else { 0 };
        let ms = &self.mat_state;
        let hist = |l: usize| if history { ms[elem(l) * stride] } else { 0.0 };
        let conn: Vec<[u32; 8]> = (0..B::LANES).map(|l| self.elems[elem(l)]).collect();
        let vol0: Vec<f64> = (0..B::LANES).map(|l| self.vol0[elem(l)]).collect();
        let state: Vec<HexState> = (0..B::LANES).map(|l| self.state.get(elem(l))).collect();
        g.load(&self.x, &self.v, &conn, &vol0, &state, hist);
        if g.update(dt, m, &self.controls).is_err() {
            return false;
        }
        for l in 0..n {
            let e = e0 + l;
            let (s, h) = g.lane_state(l);
            self.state.set(e, &s);
            if history {
                self.mat_state[e * stride] = h;
            }
        }
        true
    }

    /// Adds the outputs of a group's first `n` lanes (elements `e0..e0 + n`), as
    /// [`ExplicitFe::add_output`] for each, read straight from the lanes; their forces only
    /// where `forces` (a whole group's were added in the kernel: [`batch::GroupLanes`]).
    ///
    /// Cost per element: the scatter-add of 24 force doubles (192 B read and written) through
    /// the connectivity (32 B); 26 flops. (The volumes and pressures are not kept: see
    /// [`ExplicitFe::density`] and [`ExplicitFe::pressure`].)
    #[inline]
    fn add_group_output<B: Batch>(
        &mut self,
        e0: usize,
        n: usize,
        g: &B,
        forces: bool,
        sums: &mut LoopSums,
    ) {
        for l in (0..n).filter(|_| forces) {
            let e = e0 + l;
            for (k, &node) in self.elems[e].iter().enumerate() {
                let f = &mut self.force[node as usize];
                let fe = g.force(l, k);
                f[0] += fe[0];
                f[1] += fe[1];
                f[2] += fe[2];
            }
        }
        for l in 0..n {
            self.assembly.record(e0 + l, |k| g.force(l, k));
        }
        let [hg_work, _, dt_stable, _] = g.scalars();
        if self.blocks.active() {
            for l in 0..n {
                let out = g.lane_output(l);
                self.blocks.add(e0 + l, &out.force, out.hg_work);
            }
        }
        for l in 0..n {
            sums.grid.add(&mut sums.hg_work, hg_work[l]);
            sums.dt_min = sums.dt_min.min(dt_stable[l]);
        }
    }

    /// Adds element `e`'s output: its forces to its nodes and its block, its hourglass work and
    /// stable step to `sums`.
    #[inline]
    fn add_output(&mut self, e: usize, out: &hex::HexOutput, sums: &mut LoopSums) {
        for (k, &n) in self.elems[e].iter().enumerate() {
            let f = &mut self.force[n as usize];
            f[0] += out.force[k][0];
            f[1] += out.force[k][1];
            f[2] += out.force[k][2];
        }
        self.assembly.record(e, |k| out.force[k]);
        sums.grid.add(&mut sums.hg_work, out.hg_work);
        self.blocks.add(e, &out.force, out.hg_work);
        sums.dt_min = sums.dt_min.min(out.dt_stable);
    }

    /// Second half of the step: accelerations, constraints and reactions, the closing kick, and
    /// the local energy increments. Returns the local sums to be reduced, raw
    /// ([`StepFolds`]: [`ExplicitFe::accumulate`] scales them).
    pub fn finish_step(&mut self, dt: f64) -> StepFolds {
        let t0 = std::time::Instant::now();
        let g = self.gravity;
        let h = 0.5 * dt;
        let mut sums = [[0.0; 3]; 6];
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
        for (node, con) in &self.constraints {
            let n = *node as usize;
            let free = a[n];
            apply(con, &mut a[n], false);
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

    /// The state a restart needs to continue bit-identically on the same ranks, as named
    /// arrays of this rank's local nodes and elements in their local order: positions (now and
    /// at the step's start), velocities, accelerations, forces and reactions (now and at the
    /// last step: the energy sums use both), element stress and hourglass state, material
    /// history, volumes, pressures, the per-block bookkeeping, the global energies and the
    /// clock.
    pub fn restart_state(&self) -> Vec<(&'static str, Vec<f64>)> {
        let flat = |v: &Vec<[f64; 3]>| v.as_flattened().to_vec();
        let hex = self.state.to_flat();
        let e = &self.energies;
        let scalars = vec![
            e.kinetic,
            e.internal,
            e.hourglass,
            e.external_work,
            e.momentum[0],
            e.momentum[1],
            e.momentum[2],
            self.internal_plus_hg,
            self.dt_stable_local, // RESTART_DT_STABLE
            self.time,
            self.step as f64,
        ];
        let blocks: Vec<f64> = self
            .block_energies
            .iter()
            .flat_map(|b| [b.internal, b.hourglass, b.kinetic0, b.internal_plus_hg])
            .collect();
        vec![
            ("fe.x", flat(&self.x)),
            // Without kept start positions, the positions (read back only where kept).
            (
                "fe.x_old",
                flat(if self.contact { &self.x_old } else { &self.x }),
            ),
            ("fe.v", flat(&self.v)),
            ("fe.a", flat(&self.a)),
            ("fe.force", flat(&self.force)),
            ("fe.reaction", flat(&self.reaction)),
            ("fe.reaction_old", flat(&self.reaction_old)),
            ("fe.hex_state", hex),
            ("fe.mat_state", self.mat_state.clone()),
            ("fe.scalars", scalars),
            ("fe.block_energies", blocks),
            ("fe.block_forces", self.blocks.restart_state()),
        ]
    }

    /// Sets the state [`ExplicitFe::restart_state`] gave (the same mesh on the same ranks);
    /// `get` returns each named array. An array missing or of the wrong length is an error
    /// naming it.
    pub fn set_restart_state(
        &mut self,
        get: &mut dyn FnMut(&str) -> Option<Vec<f64>>,
    ) -> Result<(), String> {
        let mut take = |name: &str, len: usize| -> Result<Vec<f64>, String> {
            let v = get(name).ok_or_else(|| format!("{name}: missing"))?;
            if v.len() != len {
                return Err(format!(
                    "{name}: {} values where this rank's mesh needs {len}",
                    v.len()
                ));
            }
            Ok(v)
        };
        let n3 = 3 * self.x.len();
        let ne = self.state.len();
        let unflat = |v: Vec<f64>| -> Vec<[f64; 3]> {
            v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
        };
        self.x = unflat(take("fe.x", n3)?);
        let x_old = unflat(take("fe.x_old", n3)?);
        if self.contact {
            self.x_old = x_old;
        }
        self.v = unflat(take("fe.v", n3)?);
        self.a = unflat(take("fe.a", n3)?);
        self.force = unflat(take("fe.force", n3)?);
        self.reaction = unflat(take("fe.reaction", n3)?);
        self.reaction_old = unflat(take("fe.reaction_old", n3)?);
        self.state.set_flat(&take("fe.hex_state", 18 * ne)?);
        self.mat_state = take("fe.mat_state", self.mat_state.len())?;
        let s = take("fe.scalars", 11)?;
        self.energies = Energies {
            kinetic: s[0],
            internal: s[1],
            hourglass: s[2],
            external_work: s[3],
            momentum: [s[4], s[5], s[6]],
        };
        self.internal_plus_hg = s[7];
        self.dt_stable_local = s[RESTART_DT_STABLE];
        self.time = s[9];
        self.step = s[10] as u64;
        let nb = self.block_energies.len();
        let b = take("fe.block_energies", 4 * nb)?;
        for (be, c) in self.block_energies.iter_mut().zip(b.chunks_exact(4)) {
            be.internal = c[0];
            be.hourglass = c[1];
            be.kinetic0 = c[2];
            be.internal_plus_hg = c[3];
        }
        // The step sums are filled by the next force evaluation before they are read.
        let w = get("fe.block_forces").ok_or("fe.block_forces: missing")?;
        if !self.blocks.set_restart_state(&w) {
            return Err("fe.block_forces: does not fit this rank's mesh".into());
        }
        Ok(())
    }

    /// Equivalent plastic strain of element `e`.
    pub fn plastic_strain(&self, e: usize) -> f64 {
        let s = self.mat_stride;
        self.materials[self.elem_material[e]].plastic_strain(&self.mat_state[e * s..(e + 1) * s])
    }

    /// Current density of element `e`, kg/m^3: its mass over its volume at the current
    /// positions ([`hex::volume`]; the element loop's own volume differs from it at round-off
    /// and is not kept: formed on demand here, for output, not written every step).
    pub fn density(&self, e: usize) -> f64 {
        let v = hex::volume(&gather(&self.x, &self.elems[e]));
        self.materials[self.elem_material[e]].density() * self.vol0[e] / v
    }

    /// Pressure (without bulk viscosity) of element `e`, Pa: -tr(sigma) / 3 of its stress, as
    /// the element update reports it (formed on demand, not written every step).
    pub fn pressure(&self, e: usize) -> f64 {
        let s = self.state.stress(e);
        -(s[0] + s[1] + s[2]) * crate::hourglass::THIRD
    }

    /// Bytes of the per-node and per-element arrays on this rank.
    pub fn bytes(&self) -> usize {
        let nn = self.x.len();
        let ne = self.elems.len();
        nn * (7 * 24 + 8 + 1)
            + 24 * self.x_old.len()
            + ne * (std::mem::size_of::<[u32; 8]>()
                + 8
                + std::mem::size_of::<HexState>()
                + 8 * (1 + self.mat_stride)
                + 8)
            + self.blocks.bytes()
    }
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
