//! Implicit dynamics: Newmark's average-acceleration (trapezoidal) rule, Newton iterations on the
//! same hexahedron the explicit mode uses, the tangent solved by conjugate gradients on the
//! element matrices with the same bits at any rank count (`exact_cg`, the default), or
//! assembled in a PETSc matrix and solved by KSP when the user chooses a PETSc solver
//! (`-ksp_type` / `-pc_type`: CG with smoothed aggregation unless told otherwise).
//!
//! **Time integration** (Newmark, beta = 1/4, gamma = 1/2; Hughes, *The Finite Element Method*,
//! 2000, §9.1): with du = u(n+1) - u(n),
//!
//! ```text
//! du       = dt v(n) + dt^2/4 (a(n) + a(n+1))   =>  a(n+1) = 4/dt^2 (du - dt v(n)) - a(n)
//! v(n+1)   = v(n) + dt/2 (a(n) + a(n+1))
//! M a(n+1) = f(u(n+1)) + M g + reactions
//! ```
//!
//! unconditionally stable and without numerical damping for a linear system, whose energy it
//! conserves; its period elongation is (omega dt)^2 / 12 to leading order. Gravity g and the
//! pressure loads L (`[[load]]`, on the faces at the trial positions) are taken at t(n+1) with
//! their curves' values then: M a(n+1) = f(u(n+1)) + L(u(n+1), t(n+1)) + M g(t(n+1)) + R, and
//! their work over the step is the trapezoid of their values at t(n) and t(n+1). The tangent
//! leaves out the follower pressure's own stiffness (of relative size p / modulus; Newton then
//! converges linearly at that rate).
//!
//! **Element.** The nodal forces f(u(n+1)) come from the explicit loop's element kernel
//! ([`crate::batch`]: mean-gradient hexahedron, hourglass control, Hughes-Winget incremental
//! rotation), given the trial positions x(n) + du and the step's mean velocity du/dt, starting
//! from the element state at t(n): the two modes differ only in time integration. Bulk viscosity is off (docs/scene.md:
//! explicit only).
//!
//! **Tangent** (per element, 24 x 24): K = V S^T C S + K_hg, with S the strain-displacement
//! matrix of the mean gradient at the trial geometry, C the algorithmic tangent of the
//! material's own stress update, found by forward differences of `Material::update_stress`
//! about the step's strain increment (exact for linear elasticity to round-off, the consistent
//! tangent of the radial return for J2 plasticity), and K_hg the hourglass control's own map.
//! For an elastic material (and the FB forms) K_hg is the control's linear map
//! (`Hourglass::tangent`: elastic moduli, viscous part as c / dt). For a material with a yield
//! surface under the physical control it is the linearised hourglass step of the trial state
//! (`Hourglass::tangent_at`): the loading ratio the residual used, and the yield bound's factor
//! per mode group, so that an element whose centre flows, whose hourglass stresses the bound
//! sets to zero, has no hourglass stiffness either. (The elastic hourglass stiffness, about a third
//! of the element's, in every yielded element made each Newton iteration gain only the mass
//! term's share, 4 m / dt^2 against the stiffness: 155-258 iterations a step on a bar pressed
//! past yield, against 5-7 with it.) Left out (stated approximations): the geometric
//! (initial-stress) stiffness and the derivative of the rotation, of relative size
//! |stress| / modulus (1e-3 at most for metals); and where the yield bound only partly holds an
//! element's hourglass stresses (fibres at the surface, the centre inside), the bound's
//! dependence on the centre stress (not symmetric) and its own slope, taken there in a
//! symmetric positive semi-definite form. Newton converges linearly at about the first ratio per
//! iteration, and more slowly in the steps where elements cross from elastic to plastic
//! (up to 25 iterations a step on a bar whose end is held laterally, docs/status.md).
//!
//! **Newton** (modified, with refresh): the tangent is assembled on the first iteration of the
//! run and again whenever an iteration reduced the residual by less than [`REFRESH_RATIO`]
//! (`-tdyn_newton_full` rebuilds it every iteration). Convergence test:
//! ||P r||_2 <= rtol * max(F, 1e-3 F_max), with r = M (a(n+1) - g) - f(u(n+1)) over all nodes,
//! P the constraint projection, F = ||f||_2 + ||M (a(n+1) - g)||_2 now and F_max the largest F
//! of the run; rtol = [`NEWTON_RTOL`] (`-tdyn_newton_rtol`), at most [`NEWTON_MAX_IT`] iterations
//! (`-tdyn_newton_max_it`); or the residual within the round-off of the increment's own terms
//! (`ROUNDOFF_FLOOR`, 64: a body moving nearly rigidly under a small load).
//!
//! **Constraints** act as projections: at node I, P_I = 0 for `fixed` and `velocity` (du is
//! prescribed: 0 or dt v), P_I = I - sum n n^T for symmetry planes. Element blocks enter as
//! P_I K_IJ P_J, the mass term 4 m / dt^2 I is added whole, so the matrix stays symmetric
//! positive definite and the Newton update has no component along a constraint.
//!
//! **Matrix numbering**: owned nodes are numbered rank after rank (an exclusive sum of the owned
//! counts), ghost copies learn their owner's number through the DM's local-to-global sum
//! (`NodeExchange::sum_shared`); the matrix keeps these block indices as its
//! `ISLocalToGlobalMapping` and elements add their blocks with `MatSetValuesBlockedLocal`.
//!
//! **Energies** as in explicit mode: the work of the element forces and of the reactions over
//! each step's displacement by the trapezoidal rule, W += (f(n) + f(n+1))/2 . du. The scheme's
//! own identity du = dt (v(n) + v(n+1))/2 makes kinetic energy + that work balance exactly for
//! any force law, so the energy error measures how well Newton and KSP converged.
use crate::curve::Curve;
use crate::explicit::{centroid, Constraint, ExplicitFe, ExplicitSetup, StepError};
use crate::hex::{self, HexControls};
use crate::hourglass::{self, Hourglass, HourglassMaterial, HourglassStep, YieldBound};
use crate::material::Material;
use crate::mesh::NodeExchange;
use crate::objects::Vector;
use crate::petsc::PetscError;
use crate::solver::{self, BlockMatrix, SolveError, Solver};
use crate::states::HexStates;
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::time::Instant;

mod coarse;
mod elements;
mod exact_cg;
mod restart;
mod tangent;
mod walls;

use exact_cg::{CgSystem, ExactCg};
pub use tangent::material_tangent;
pub use walls::{WallPlane, MAX_ROUNDS as MAX_WALL_ROUNDS};

/// Default Newton tolerance on the residual relative to the force scale (`-tdyn_newton_rtol`).
pub const NEWTON_RTOL: f64 = 1e-8;
/// Default largest number of Newton iterations in one step (`-tdyn_newton_max_it`).
pub const NEWTON_MAX_IT: u32 = 30;
/// The tangent is rebuilt when an iteration reduced the residual by less than this factor.
pub const REFRESH_RATIO: f64 = 0.1;
/// Below this fraction of the run's largest force scale a residual counts as zero.
const FORCE_FLOOR: f64 = 1e-3;
/// A residual within this many f64 epsilons of the increment's force scale R counts as
/// converged (the round-off floor of the Newton test).
///
/// Why: the residual of a node is formed from terms of size k |du|, where du is the step's
/// increment and k the node's stiffness against it: the inertia m 4/dt^2 (du - dt v), whose
/// difference cancels to round-off, eps |du|, when the node moves with little acceleration;
/// and the element forces, whose strain increments come from differences of the increments of
/// neighbouring nodes, again eps |du| when the element hardly deforms, times a stiffness of at
/// most m (2/dt_c)^2 (dt_c the explicit stable step: omega_max <= 2/dt_c). A body translating
/// under a small load (a free cube at 2 m/s under 1 kPa, dt = 1e-4 s) has a force scale F of
/// 1e-3 N and a residual that stops at 4e-10 N, above rtol F = 4e-11 N, whatever Newton does.
/// So the test is ||P r|| <= max(rtol max(F, 1e-3 F_max), ROUNDOFF_FLOOR eps R) with
/// R = (sum over the nodes of (m (4/dt^2 + 4/dt_c^2) |du|)^2)^(1/2), dt_c the smallest stable
/// step of the trial's elements. R bounds the terms' sizes; 64 eps of it covers the rounding of
/// an element's eight nodes and of the stress update. In a deforming body R is of the order of F
/// (the increment is the deformation), and 64 eps R is far below rtol F: the floor takes over
/// only where the motion is a rigid body's.
const ROUNDOFF_FLOOR: f64 = 64.0;
/// Most history variables a material may have (the tangent's scratch space).
const MAX_MAT_STATE: usize = 8;

/// Newton settings, from the PETSc options database.
#[derive(Debug, Clone, Copy)]
pub struct NewtonOptions {
    /// Relative residual tolerance.
    pub rtol: f64,
    /// Most iterations per step.
    pub max_iterations: u32,
    /// Rebuild the tangent every iteration (full Newton).
    pub full: bool,
}

impl NewtonOptions {
    /// Defaults, overridden by `-tdyn_newton_rtol`, `-tdyn_newton_max_it`, `-tdyn_newton_full`.
    /// A tolerance that is not a positive number or fewer than one iteration is refused
    /// (`ImplicitError::Option`).
    pub fn from_options() -> Result<NewtonOptions, ImplicitError> {
        let rtol = solver::option_real("-tdyn_newton_rtol")?;
        if let Some(r) = rtol.filter(|r| !(*r > 0.0 && r.is_finite())) {
            return Err(ImplicitError::Option(format!(
                "-tdyn_newton_rtol {r}: expected a positive tolerance (default {NEWTON_RTOL:e})"
            )));
        }
        let max_it = solver::option_int("-tdyn_newton_max_it")?;
        if let Some(n) = max_it.filter(|n| *n < 1) {
            return Err(ImplicitError::Option(format!(
                "-tdyn_newton_max_it {n}: expected at least 1 Newton iteration per step (default {NEWTON_MAX_IT})"
            )));
        }
        Ok(NewtonOptions {
            rtol: rtol.unwrap_or(NEWTON_RTOL),
            max_iterations: max_it.map_or(NEWTON_MAX_IT, |v| v as u32),
            full: crate::petsc::Petsc::has_option("-tdyn_newton_full"),
        })
    }
}

/// Counters and timers of the implicit stage on this rank.
#[derive(Debug, Clone, Copy, Default)]
pub struct ImplicitStats {
    /// Newton iterations (linear solves) so far.
    pub newton_iterations: u64,
    /// Krylov iterations so far.
    pub ksp_iterations: u64,
    /// Tangent assemblies so far.
    pub assemblies: u64,
    /// Residual evaluations so far.
    pub residuals: u64,
    /// Seconds assembling the tangent.
    pub assembly_s: f64,
    /// Seconds in KSP (preconditioner set-up and solve).
    pub solve_s: f64,
    /// Largest Newton iteration count of one step.
    pub max_step_iterations: u32,
}

/// Why an implicit step failed.
#[derive(Debug, Clone, thiserror::Error)]
pub enum ImplicitError {
    /// The element loop failed (inverted element, non-finite value) or PETSc failed.
    #[error("{0}")]
    Step(#[from] StepError),
    /// The linear solve failed.
    #[error("{0}")]
    Solve(#[from] SolveError),
    /// Newton did not reach its tolerance.
    #[error("Newton iterations did not converge at t = {time:e} s, step {step}: residual {residual:e} N after {iterations} iterations, tolerance {tolerance:e} N (reduce run.dt, or raise -tdyn_newton_max_it / -tdyn_newton_rtol)")]
    NoConvergence {
        /// Time at the end of the step.
        time: f64,
        /// The step.
        step: u64,
        /// Final residual norm.
        residual: f64,
        /// The tolerance it had to reach.
        tolerance: f64,
        /// Iterations taken.
        iterations: u32,
    },
    /// The nodes in contact with the rigid walls did not settle.
    #[error("the nodes in contact with the rigid walls did not settle at t = {time:e} s, step {step}: their set changed in {MAX_WALL_ROUNDS} solves of the step (reduce run.dt)")]
    WallSet {
        /// Time at the end of the step.
        time: f64,
        /// The step.
        step: u64,
    },
    /// This rank is fine; another one failed (its message is the one to report).
    #[error("another rank failed")]
    OtherRank,
    /// A command-line option (`-tdyn_newton_*`) with a value it cannot take.
    #[error("{0}")]
    Option(String),
}

impl From<PetscError> for ImplicitError {
    fn from(e: PetscError) -> Self {
        ImplicitError::Step(StepError::Petsc(e))
    }
}

/// A node's constraint as a projection.
#[derive(Debug, Clone, Copy)]
enum NodeDof {
    Free,
    /// The increment lies in the range of `p` (symmetry planes: I - sum n n^T).
    Projected([[f64; 3]; 3]),
    /// The velocity is prescribed (fixed: zero); no free component.
    Prescribed([f64; 3]),
    /// On rigid walls (`walls`): the increment is `p d + du`, the velocity at the step's end
    /// `p v' + v`, with `du` and `v` along the constrained directions (symmetry planes and
    /// walls) and `p` the projection on the free ones.
    Walled {
        p: [[f64; 3]; 3],
        du: [f64; 3],
        v: [f64; 3],
    },
}

impl NodeDof {
    fn from_constraint(c: &Constraint) -> NodeDof {
        match c {
            Constraint::Fixed => NodeDof::Prescribed([0.0; 3]),
            Constraint::Velocity(v) => NodeDof::Prescribed(*v),
            Constraint::Planes(ns) => {
                let mut p = [[0.0; 3]; 3];
                for i in 0..3 {
                    p[i][i] = 1.0;
                }
                for n in ns {
                    for i in 0..3 {
                        for j in 0..3 {
                            p[i][j] -= n[i] * n[j];
                        }
                    }
                }
                NodeDof::Projected(p)
            }
        }
    }

    /// The free part P w of a nodal vector.
    #[inline]
    fn free(&self, w: [f64; 3]) -> [f64; 3] {
        match self {
            NodeDof::Free => w,
            NodeDof::Projected(p) | NodeDof::Walled { p, .. } => mat3_vec(p, &w),
            NodeDof::Prescribed(_) => [0.0; 3],
        }
    }

    /// The velocity at the step's end from Newmark's `v`: prescribed, walled or free part.
    #[inline]
    fn velocity(&self, v: [f64; 3]) -> [f64; 3] {
        match self {
            NodeDof::Prescribed(p) => *p,
            NodeDof::Walled { p, v: c, .. } => {
                let f = mat3_vec(p, &v);
                std::array::from_fn(|k| f[k] + c[k])
            }
            dof => dof.free(v),
        }
    }

    /// The projection matrix, or `None` for the identity.
    #[inline]
    fn matrix(&self) -> Option<[[f64; 3]; 3]> {
        match self {
            NodeDof::Free => None,
            NodeDof::Projected(p) | NodeDof::Walled { p, .. } => Some(*p),
            NodeDof::Prescribed(_) => Some([[0.0; 3]; 3]),
        }
    }
}

#[inline]
fn mat3_vec(p: &[[f64; 3]; 3], w: &[f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| p[i][0] * w[0] + p[i][1] * w[1] + p[i][2] * w[2])
}

#[inline]
fn gather(xs: &[[f64; 3]], conn: &[u32; 8]) -> [[f64; 3]; 8] {
    std::array::from_fn(|k| xs[conn[k] as usize])
}

/// The linear solver of the Newton updates.
enum Linear {
    /// The default: CG with the same bits at any rank count ([`exact_cg`]).
    Exact {
        cg: Box<ExactCg>,
        delta: Vec<[f64; 3]>,
        rtol: f64,
    },
    /// KSP on an assembled PETSc matrix, when the user chose a solver (`-ksp_type` or
    /// `-pc_type`): rank-independent to round-off only.
    Petsc {
        matrix: BlockMatrix,
        solver: Solver,
        rhs: Vector,
        sol: Vector,
    },
}

/// Whether the user chose a PETSc solver for the Newton updates (docs/cli.md).
pub fn petsc_solver_chosen() -> bool {
    crate::petsc::Petsc::has_option("-ksp_type") || crate::petsc::Petsc::has_option("-pc_type")
}

/// The implicit FE stage on one rank. Its nodal and element state lives in an [`ExplicitFe`]
/// (`fe`: the same arrays, element state and energy bookkeeping that probes and output read);
/// this type replaces the time step.
pub struct ImplicitFe {
    /// Nodal and element state, energies, time and step count.
    pub fe: ExplicitFe,
    /// The step, s.
    pub dt: f64,
    /// Newton settings.
    pub options: NewtonOptions,
    /// Counters and timers.
    pub stats: ImplicitStats,
    controls: HexControls,
    /// Gravity at the step's end (its curve's value there) and at its start, m/s^2.
    gravity: [f64; 3],
    gravity_n: [f64; 3],
    dofs: Vec<NodeDof>,
    /// The velocity constraints with a curve: (local node, velocity, curve); and each node's
    /// index among them (`u32::MAX`: none).
    curved: Vec<(usize, [f64; 3], Curve)>,
    curve_of: Vec<u32>,
    mat_stride: usize,
    owned_nodes: Vec<usize>,
    linear: Linear,
    /// `4 m / dt^2` per local node (the tangent's mass term).
    mass_term: Vec<f64>,
    du: Vec<[f64; 3]>,
    x_trial: Vec<[f64; 3]>,
    v_mean: Vec<[f64; 3]>,
    force: Vec<[f64; 3]>,
    force_n: Vec<[f64; 3]>,
    residual: Vec<[f64; 3]>,
    reaction: Vec<[f64; 3]>,
    reaction_n: Vec<[f64; 3]>,
    state_trial: HexStates,
    mat_trial: Vec<f64>,
    hg_work_trial: crate::exact::Folds,
    /// The smallest stable step of the trial's elements on this rank (`HexOutput::dt_stable`),
    /// s: the stiffness of the round-off floor ([`ROUNDOFF_FLOOR`]).
    trial_dt_min: f64,
    owned_buf: Vec<f64>,
    local_buf: Vec<f64>,
    tangent_stale: bool,
    /// The element matrices came back from a checkpoint (`set_restart_state`): the diagonal
    /// and the coarse grid are summed from them before the next solve, as the tangent's
    /// assembly would have.
    tangent_restored: bool,
    force_scale_max: f64,
    /// The symmetry-plane normals of the nodes that have them (until the walls take them).
    plane_normals: std::collections::HashMap<usize, Vec<[f64; 3]>>,
    /// The rigid walls and their nodes in contact (`set_walls`).
    walls: Option<Box<walls::WallSet>>,
}

impl ImplicitFe {
    /// Builds the stage: the explicit arrays (lumped masses, initial velocities and
    /// constraints), the global node numbering, the matrix pattern and the solver. `setup`'s
    /// controls are kept for the explicit stable-step estimate (reported for comparison); the
    /// element itself runs without bulk viscosity. Collective.
    pub fn new(
        comm: &SimpleCommunicator,
        setup: ExplicitSetup,
        dt: f64,
        exchange: &mut NodeExchange,
    ) -> Result<ImplicitFe, ImplicitError> {
        // The hourglass tangent (`Hourglass::tangent_at`) is the whole-amplitude yield bound's.
        let hourglass = match setup.controls.hourglass {
            Hourglass::Physical { scale, .. } => Hourglass::Physical {
                scale,
                bound: YieldBound::Fibres,
            },
            h => h,
        };
        let controls = HexControls {
            hourglass,
            bv_linear: 0.0,
            bv_quadratic: 0.0,
        };
        let nn = setup.mesh.coords.len();
        let mut dofs = vec![NodeDof::Free; nn];
        let mut plane_normals = std::collections::HashMap::new();
        for (n, c) in &setup.constraints {
            dofs[*n as usize] = NodeDof::from_constraint(c);
            if let Constraint::Planes(ns) = c {
                plane_normals.insert(*n as usize, ns.clone());
            }
        }
        let mut curve_of = vec![u32::MAX; nn];
        let mut curved = Vec::new();
        for ((n, con), c) in setup.constraints.iter().zip(&setup.velocity_curves) {
            if let (Constraint::Velocity(v), Some(c)) = (con, c) {
                curve_of[*n as usize] = curved.len() as u32;
                curved.push((*n as usize, *v, c.clone()));
            }
        }
        let fe = ExplicitFe::new(setup, exchange);
        // The agreement step before the collective numbering: a rank whose set-up failed
        // returns its error, the others [`ImplicitError::OtherRank`].
        let failed = crate::agree::first_error(comm, fe.as_ref().err().map(|e| e.to_string()));
        let fe = match (fe, failed) {
            (Ok(_), Err(_)) => return Err(ImplicitError::OtherRank),
            (fe, _) => fe?,
        };
        let mat_stride = fe.materials.iter().map(|m| m.n_state()).max().unwrap_or(0);
        assert!(
            mat_stride <= MAX_MAT_STATE,
            "a material with more than {MAX_MAT_STATE} history variables"
        );

        // Global block numbers: owned nodes rank after rank, ghosts from their owners.
        let owned_nodes: Vec<usize> = (0..nn).filter(|&n| fe.owned[n]).collect();
        let mut counts = vec![0u64; comm.size() as usize];
        comm.all_gather_into(&(owned_nodes.len() as u64), &mut counts[..]);
        let offset: u64 = counts[..comm.rank() as usize].iter().sum();
        let mut ids = vec![0.0; 3 * nn];
        for (k, &n) in owned_nodes.iter().enumerate() {
            ids[3 * n] = (offset + k as u64) as f64;
        }
        exchange.sum_shared(&mut ids)?;
        let global_block: Vec<i32> = (0..nn).map(|n| ids[3 * n].round() as i32).collect();

        let linear = if petsc_solver_chosen() {
            let mut matrix = BlockMatrix::new(comm, owned_nodes.len(), &global_block, &fe.elems)?;
            let owned_coords: Vec<[f64; 3]> = owned_nodes.iter().map(|&n| fe.x0[n]).collect();
            matrix.set_rigid_body_modes(&owned_coords)?;
            let solver = Solver::new(comm, &matrix)?;
            let rhs = matrix.vector()?;
            let sol = matrix.vector()?;
            Linear::Petsc {
                matrix,
                solver,
                rhs,
                sol,
            }
        } else {
            let mut cg = Box::new(ExactCg::new(fe.elems.len(), nn));
            cg.coarse = Some(coarse::Coarse::new(comm, &fe.x0, &fe.owned, &fe.elems));
            Linear::Exact {
                cg,
                delta: vec![[0.0; 3]; nn],
                rtol: solver::option_real("-ksp_rtol")?.unwrap_or(solver::KSP_RTOL),
            }
        };
        let mass_term = fe.mass.iter().map(|m| 4.0 * m / (dt * dt)).collect();
        let mut imp = ImplicitFe {
            dt,
            options: NewtonOptions::from_options()?,
            stats: ImplicitStats::default(),
            controls,
            gravity: fe.gravity_at(0.0),
            gravity_n: fe.gravity_at(0.0),
            dofs,
            curved,
            curve_of,
            mat_stride,
            linear,
            mass_term,
            du: vec![[0.0; 3]; nn],
            x_trial: fe.x.clone(),
            v_mean: vec![[0.0; 3]; nn],
            force: vec![[0.0; 3]; nn],
            force_n: vec![[0.0; 3]; nn],
            residual: vec![[0.0; 3]; nn],
            reaction: vec![[0.0; 3]; nn],
            reaction_n: vec![[0.0; 3]; nn],
            state_trial: fe.state.clone(),
            mat_trial: fe.mat_state.clone(),
            hg_work_trial: [0.0; 3],
            trial_dt_min: f64::INFINITY,
            owned_buf: vec![0.0; 3 * owned_nodes.len()],
            local_buf: vec![0.0; 3 * nn],
            owned_nodes,
            tangent_stale: true,
            tangent_restored: false,
            force_scale_max: 0.0,
            plane_normals,
            walls: None,
            fe,
        };
        // The reactions at t = 0 (zero stress: M a(0) = M g + R(0)).
        for n in 0..nn {
            imp.reaction_n[n] = imp.constraint_force(n, imp.fe.a[n], [0.0; 3]);
        }
        Ok(imp)
    }

    /// The pressure loads of this rank (collective), as [`ExplicitFe::set_loads`]: their
    /// forces at t = 0 on the initial positions join the forces and accelerations of t = 0,
    /// M a(0) = L(0) + M g(0) + R(0) (the stress is zero).
    pub fn set_loads(
        &mut self,
        sets: Vec<crate::explicit::PressureLoad>,
        exchange: &mut NodeExchange,
    ) -> Result<(), StepError> {
        self.fe.set_loads(sets, exchange)?;
        let Some(l) = self.fe.loads() else {
            return Ok(());
        };
        l.add_to(&mut self.force_n);
        for n in l.nodes.clone() {
            let n = n as usize;
            if matches!(self.dofs[n], NodeDof::Prescribed(_)) {
                continue;
            }
            let (m, f, a) = (self.fe.mass[n], self.force_n[n], self.fe.a[n]);
            let a0: [f64; 3] = std::array::from_fn(|c| a[c] + f[c] / m);
            self.fe.a[n] = self.dofs[n].free(a0);
            self.reaction_n[n] = self.constraint_force(n, self.fe.a[n], f);
        }
        Ok(())
    }

    /// After a restart: the pressure loads at the restored positions and time and gravity at
    /// that time, as the step that wrote the checkpoint left them (collective).
    pub fn refresh_after_restart(&mut self, exchange: &mut NodeExchange) -> Result<(), StepError> {
        self.fe.refresh_after_restart(exchange)?;
        self.gravity = self.fe.gravity_at(self.fe.time);
        self.gravity_n = self.gravity;
        Ok(())
    }

    /// The force a node's constraint applies: (I - P)(m (a - g) - f).
    #[inline]
    fn constraint_force(&self, n: usize, a: [f64; 3], f: [f64; 3]) -> [f64; 3] {
        if let NodeDof::Free = self.dofs[n] {
            return [0.0; 3];
        }
        let m = self.fe.mass[n];
        let g = self.gravity;
        let r: [f64; 3] = std::array::from_fn(|c| m * (a[c] - g[c]) - f[c]);
        let free = self.dofs[n].free(r);
        std::array::from_fn(|c| r[c] - free[c])
    }

    /// The force each constraint applies to its node in the accepted state, N, for the
    /// constrained local nodes in node order: the residual of the equation of motion at the
    /// constrained degrees of freedom, (I - P)(M (a(n+1) - g) - f(u(n+1))) (Newmark's
    /// M a = f + M g + R solved for R where P removes the constrained directions).
    pub fn constraint_reactions(&self) -> impl Iterator<Item = (u32, [f64; 3])> + '_ {
        (0..self.n_nodes())
            .filter(|&n| !matches!(self.support_dof(n), NodeDof::Free))
            .map(|n| (n as u32, self.reaction_n[n]))
    }

    /// Node `n`'s constraint by its supports (boundary groups), without the walls'.
    fn support_dof(&self, n: usize) -> &NodeDof {
        self.walls.as_ref().map_or(&self.dofs[n], |w| w.base(n))
    }

    /// The step from now on, s (the run's last step, shortened onto the end time when the
    /// fixed step does not divide it): the mass term 4 M / dt^2, the walls' increments and the
    /// tangent (rebuilt at the next Newton iteration) follow it.
    pub fn set_dt(&mut self, dt: f64) {
        if dt == self.dt {
            return;
        }
        self.dt = dt;
        self.mass_term = self.fe.mass.iter().map(|m| 4.0 * m / (dt * dt)).collect();
        if let Some(w) = self.walls.as_mut() {
            w.set_dt(dt);
        }
        self.tangent_stale = true;
    }

    /// Number of local nodes.
    pub fn n_nodes(&self) -> usize {
        self.fe.x.len()
    }

    /// One Newmark step of `self.dt`: predictor, Newton iterations, update of positions,
    /// velocities, accelerations, element state and energies (collective; every rank returns an
    /// error together, the failing ones their own and the others [`ImplicitError::OtherRank`]).
    pub fn step(
        &mut self,
        comm: &SimpleCommunicator,
        exchange: &mut NodeExchange,
    ) -> Result<(), ImplicitError> {
        let dt = self.dt;
        let t0 = Instant::now();
        // A velocity with a curve prescribes the increment dt v times the curve's mean over
        // the step (the curve's integral: exact displacement).
        let t = self.fe.time;
        for (n, v, c) in &self.curved {
            let s = c.mean(t, dt);
            self.dofs[*n] = NodeDof::Prescribed(v.map(|x| x * s));
        }
        // Gravity at the step's end; the loads at its start kept for their work.
        self.gravity_n = self.gravity;
        self.gravity = self.fe.gravity_at(t + dt);
        if let Some(l) = self.fe.loads_mut() {
            l.keep();
        }
        // The walls' nodes in contact at the step's start held on their planes at its end.
        self.apply_walls();
        // Predictor: a(n+1) = a(n).
        for n in 0..self.n_nodes() {
            let (v, a) = (self.fe.v[n], self.fe.a[n]);
            let d: [f64; 3] = std::array::from_fn(|c| dt * v[c] + 0.5 * dt * dt * a[c]);
            self.du[n] = self.constrained_increment(n, d);
        }
        self.fe.timers.nodal += t0.elapsed().as_secs_f64();
        let mut iterations = 0u32;
        let mut rounds = 0u32;
        loop {
            let tol = self.newton(comm, exchange, &mut iterations)?;
            if !self.update_wall_sets(comm, tol) {
                break;
            }
            // The set changed: its constraints on the converged increment, and Newton again.
            rounds += 1;
            if rounds > walls::MAX_ROUNDS {
                return Err(ImplicitError::WallSet {
                    time: self.fe.time + dt,
                    step: self.fe.step + 1,
                });
            }
            self.apply_walls();
            for n in 0..self.n_nodes() {
                self.du[n] = self.constrained_increment(n, self.du[n]);
            }
            self.tangent_stale = true;
        }
        self.stats.newton_iterations += iterations as u64;
        self.stats.max_step_iterations = self.stats.max_step_iterations.max(iterations);
        let sums = self.accept();
        let mut global = vec![0.0; sums.len()];
        comm.all_reduce_into(&sums[..], &mut global[..], SystemOperation::sum());
        self.fe.accumulate(&global, dt);
        self.finish_wall_step(comm);
        Ok(())
    }

    /// Newton iterations to convergence from the present increment, counting them in
    /// `iterations`; returns the force below which a residual counts as converged, N
    /// (collective).
    fn newton(
        &mut self,
        comm: &SimpleCommunicator,
        exchange: &mut NodeExchange,
        iterations: &mut u32,
    ) -> Result<f64, ImplicitError> {
        let dt = self.dt;
        let mut prev: Option<f64> = None;
        let mut solves = 0u32;
        loop {
            let (rnorm, scale, roundoff) = self.evaluate(comm, exchange)?;
            self.force_scale_max = self.force_scale_max.max(scale);
            let tol = (self.options.rtol * scale.max(FORCE_FLOOR * self.force_scale_max))
                .max(ROUNDOFF_FLOOR * f64::EPSILON * roundoff);
            if rnorm <= tol {
                return Ok(tol);
            }
            if solves >= self.options.max_iterations {
                return Err(ImplicitError::NoConvergence {
                    time: self.fe.time + dt,
                    step: self.fe.step + 1,
                    residual: rnorm,
                    tolerance: tol,
                    iterations: solves,
                });
            }
            if prev.is_some_and(|p| rnorm > REFRESH_RATIO * p) {
                self.tangent_stale = true;
            }
            if self.tangent_stale || self.options.full {
                self.assemble_tangent(exchange)?;
                self.tangent_stale = false;
                self.tangent_restored = false;
            } else if self.tangent_restored {
                self.restore_diagonal(exchange)?;
                self.tangent_restored = false;
            }
            self.newton_update(comm, exchange)?;
            prev = Some(rnorm);
            solves += 1;
            *iterations += 1;
        }
    }

    /// A node's increment with its constraint applied: prescribed dt v, or the free part.
    #[inline]
    fn constrained_increment(&self, n: usize, d: [f64; 3]) -> [f64; 3] {
        match self.dofs[n] {
            NodeDof::Prescribed(v) => std::array::from_fn(|c| self.dt * v[c]),
            NodeDof::Walled { p, du, .. } => {
                let f = mat3_vec(&p, &d);
                std::array::from_fn(|c| f[c] + du[c])
            }
            ref dof => dof.free(d),
        }
    }

    /// Element forces at x(n) + du from the state at t(n), the projected residual, and the
    /// global norms (||P r||_2, F, R: the round-off scale of [`ROUNDOFF_FLOOR`]). Collective.
    fn evaluate(
        &mut self,
        comm: &SimpleCommunicator,
        exchange: &mut NodeExchange,
    ) -> Result<(f64, f64, f64), ImplicitError> {
        let dt = self.dt;
        let t0 = Instant::now();
        let inv_dt = 1.0 / dt;
        for n in 0..self.n_nodes() {
            for c in 0..3 {
                self.x_trial[n][c] = self.fe.x[n][c] + self.du[n][c];
                self.v_mean[n][c] = self.du[n][c] * inv_dt;
            }
        }
        for f in self.force.iter_mut() {
            *f = [0.0; 3];
        }
        self.fe.blocks.begin();
        let failure = match self.trial_element_forces(dt) {
            Ok(hg_work) => {
                self.hg_work_trial = hg_work;
                None
            }
            Err(e) => Some(e),
        };
        self.stats.residuals += 1;
        let t1 = Instant::now();
        self.fe.timers.elements += (t1 - t0).as_secs_f64();
        // Every rank learns whether one failed before the collective exchange.
        let failed = {
            let mine = failure.is_some() as i32;
            let mut any = 0;
            comm.all_reduce_into(&mine, &mut any, SystemOperation::max());
            any > 0
        };
        if failed {
            return Err(failure
                .map(ImplicitError::Step)
                .unwrap_or(ImplicitError::OtherRank));
        }
        // Each node's force summed in the canonical element order (`crate::assembly`), then
        // the pressure loads on the faces at the trial positions (`explicit::loads`).
        self.fe.assembly.finish(&mut self.force, exchange)?;
        let t_end = self.fe.time + dt;
        if let Some(l) = self.fe.loads_mut() {
            // (implicit mode has no erosion)
            l.evaluate(&self.x_trial, t_end, None, exchange)?;
            l.add_to(&mut self.force);
        }
        let t2 = Instant::now();
        self.fe.timers.exchange += (t2 - t1).as_secs_f64();
        let c_mass = 4.0 / (dt * dt);
        let g = self.gravity;
        // The stiffness of the round-off floor, 4/dt^2 + 4/dt_c^2 per unit mass, with the
        // smallest stable step over every rank (a minimum: the same at any rank count).
        let mut dt_c = self.trial_dt_min;
        comm.all_reduce_into(&self.trial_dt_min, &mut dt_c, SystemOperation::min());
        let c_floor = if dt_c.is_finite() && dt_c > 0.0 {
            c_mass + 4.0 / (dt_c * dt_c)
        } else {
            c_mass
        };
        // The norms' squares as exact sums (`exact::totals`): the same bits at any rank count,
        // so every rank count takes the same Newton iterations.
        let mut sums: [Vec<f64>; 4] = Default::default();
        for n in 0..self.n_nodes() {
            let m = self.fe.mass[n];
            let (v, a, du, f) = (self.fe.v[n], self.fe.a[n], self.du[n], self.force[n]);
            let inertia: [f64; 3] =
                std::array::from_fn(|c| m * (c_mass * (du[c] - dt * v[c]) - a[c] - g[c]));
            self.residual[n] = std::array::from_fn(|c| inertia[c] - f[c]);
            if self.fe.owned[n] {
                for c in 0..3 {
                    sums[1].push(f[c] * f[c]);
                    sums[2].push(inertia[c] * inertia[c]);
                    let k = m * c_floor * du[c];
                    sums[3].push(k * k);
                }
            }
        }
        // Friction on the nodes slipping on walls, from their normal force at this iterate.
        self.add_wall_friction();
        for n in 0..self.n_nodes() {
            let pr = self.dofs[n].free(self.residual[n]);
            self.residual[n] = pr;
            if self.fe.owned[n] {
                for c in 0..3 {
                    sums[0].push(pr[c] * pr[c]);
                }
            }
        }
        let global = crate::exact::totals(comm, &sums);
        self.fe.timers.nodal += t2.elapsed().as_secs_f64();
        let rnorm = global[0].sqrt();
        if !rnorm.is_finite() {
            return Err(ImplicitError::Step(StepError::NonFinite {
                what: "the implicit residual",
                time: self.fe.time + dt,
                step: self.fe.step + 1,
            }));
        }
        Ok((rnorm, global[1].sqrt() + global[2].sqrt(), global[3].sqrt()))
    }

    /// Solves (4 M / dt^2 + K) delta = -P r and adds P delta to du on every local node.
    fn newton_update(
        &mut self,
        comm: &SimpleCommunicator,
        exchange: &mut NodeExchange,
    ) -> Result<(), ImplicitError> {
        let t0 = Instant::now();
        if let Linear::Exact { cg, delta, rtol } = &mut self.linear {
            let b: Vec<[f64; 3]> = self.residual.iter().map(|r| r.map(|x| -x)).collect();
            let sys = CgSystem {
                elems: &self.fe.elems,
                owned: &self.fe.owned,
                mass_term: &self.mass_term,
                dofs: &self.dofs,
            };
            let its = cg.solve(
                comm,
                &sys,
                (&mut self.fe.assembly, exchange),
                (&b, delta),
                *rtol,
            )?;
            self.stats.ksp_iterations += its as u64;
            self.stats.solve_s += t0.elapsed().as_secs_f64();
            for (n, d) in delta.iter().enumerate() {
                let d = self.dofs[n].free(*d);
                for c in 0..3 {
                    self.du[n][c] += d[c];
                }
            }
            return Ok(());
        }
        let Linear::Petsc {
            solver, rhs, sol, ..
        } = &mut self.linear
        else {
            unreachable!("the exact solve returned above")
        };
        for (k, &n) in self.owned_nodes.iter().enumerate() {
            for c in 0..3 {
                self.owned_buf[3 * k + c] = -self.residual[n][c];
            }
        }
        solver::write_vector(rhs, &self.owned_buf)?;
        let its = solver.solve(rhs, sol)?;
        self.stats.ksp_iterations += its as u64;
        solver::read_vector(sol, &mut self.owned_buf)?;
        self.stats.solve_s += t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        self.local_buf.fill(0.0);
        for (k, &n) in self.owned_nodes.iter().enumerate() {
            self.local_buf[3 * n..3 * n + 3].copy_from_slice(&self.owned_buf[3 * k..3 * k + 3]);
        }
        // Ghost copies contribute zero: the sum gives every copy its owner's value.
        exchange.sum_shared(&mut self.local_buf)?;
        self.fe.timers.exchange += t1.elapsed().as_secs_f64();
        for n in 0..self.n_nodes() {
            let d = [
                self.local_buf[3 * n],
                self.local_buf[3 * n + 1],
                self.local_buf[3 * n + 2],
            ];
            let d = self.dofs[n].free(d);
            for c in 0..3 {
                self.du[n][c] += d[c];
            }
        }
        Ok(())
    }

    /// Takes the converged increment: new accelerations, velocities, positions, reactions and
    /// element state. Returns the local sums `[kinetic, d(internal+hourglass), d(external
    /// work), px, py, pz, hourglass work]` and the per-block sums (`ExplicitFe::step_sums`) to
    /// be reduced.
    fn accept(&mut self) -> Vec<f64> {
        let t0 = Instant::now();
        let dt = self.dt;
        let t1 = self.fe.time + dt;
        let c_mass = 4.0 / (dt * dt);
        // Gravity's mean over the step (the same bits as g itself when it is constant).
        let g: [f64; 3] = std::array::from_fn(|c| 0.5 * (self.gravity_n[c] + self.gravity[c]));
        let mut sums = [[0.0; 3]; 6];
        let (ge, gp) = (self.fe.grids.energy, self.fe.grids.momentum);
        for n in 0..self.n_nodes() {
            let (v, a, du, f) = (self.fe.v[n], self.fe.a[n], self.du[n], self.force[n]);
            let a_raw: [f64; 3] = std::array::from_fn(|c| c_mass * (du[c] - dt * v[c]) - a[c]);
            let mut a_new = self.dofs[n].free(a_raw);
            let v_raw: [f64; 3] = std::array::from_fn(|c| v[c] + 0.5 * dt * (a[c] + a_new[c]));
            let mut v_new = self.dofs[n].velocity(v_raw);
            // A velocity with a curve: v s(t + dt) and its acceleration v ds/dt at the step's
            // end (the reaction then holds the force that changes the node's momentum).
            if let Some((_, pv, c)) = self.curved.get(self.curve_of[n] as usize) {
                let (s, rate) = (c.value(t1), c.slope(t1));
                v_new = pv.map(|x| x * s);
                a_new = pv.map(|x| x * rate);
            }
            let full = self.constraint_force(n, a_new, f);
            // The walls' part of it is theirs (their impulse and energy, and friction's
            // change of the velocity), the rest the supports' (reactions.csv, external work).
            let gravity = (self.gravity_n, self.gravity);
            (self.reaction[n], v_new) = self.book_wall_node(n, full, (v_raw, v_new), gravity);
            // (a curve's kink inside the step: the trapezoid of the end slopes, dt/2 (a(n) +
            // a(n+1)), is not the velocity's change s(t + dt) - s(t); the rest, m dv, is an
            // impulse of the constraint too, booked as its force over the step, m dv / dt, so
            // that the rows of reactions.csv add up to the momentum the constraint gave)
            if self.curve_of[n] != u32::MAX {
                let m = self.fe.mass[n];
                for c in 0..3 {
                    let dv = v_new[c] - v[c] - 0.5 * dt * (a[c] + a_new[c]);
                    self.reaction[n][c] += m * dv / dt;
                }
            }
            for c in 0..3 {
                self.fe.x[n][c] += du[c];
            }
            self.fe.a[n] = a_new;
            self.fe.v[n] = v_new;
            if !self.fe.owned[n] {
                continue;
            }
            let m = self.fe.mass[n];
            // The raw terms of `nodal::StepFolds`.
            for c in 0..3 {
                ge.add(&mut sums[0], m * (v_new[c] * v_new[c]));
                ge.add(&mut sums[1], (f[c] + self.force_n[n][c]) * du[c]);
                let r = 0.5 * (self.reaction[n][c] + self.reaction_n[n][c]);
                ge.add(&mut sums[2], (r + m * g[c]) * du[c]);
                gp.add(&mut sums[3 + c], m * v_new[c]);
            }
        }
        let du = &self.du;
        if let Some(l) = self.fe.loads() {
            l.book_work(&self.fe.owned, &ge, |n, c| du[n][c], &mut sums);
        }
        self.fe.blocks.accept(|n| du[n]);
        let sums = self.fe.step_sums(&sums, &self.hg_work_trial);
        std::mem::swap(&mut self.force_n, &mut self.force);
        std::mem::swap(&mut self.reaction_n, &mut self.reaction);
        self.fe.force.copy_from_slice(&self.force_n);
        std::mem::swap(&mut self.fe.state, &mut self.state_trial);
        std::mem::swap(&mut self.fe.mat_state, &mut self.mat_trial);
        self.fe.timers.nodal += t0.elapsed().as_secs_f64();
        sums
    }
}
