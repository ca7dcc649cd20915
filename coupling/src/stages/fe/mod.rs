//! The FE stage (Fig. 3, step 1): the mesh on PETSc's static distribution (METIS), integrated
//! explicitly (central differences) or implicitly (Newmark average acceleration, Newton and
//! PETSc KSP: `run.mode = "implicit"`). The element kernels, materials and integrators are in
//! `fe_petsc`; this stage builds them from the scene (`setup`) and runs them under the driver.
use super::{Stage, StageEnergies, StageError};
use crate::input::scene::Scene;
use crate::kernels::collective::{self, first_error};
use crate::output::state::{StateReader, StateWriter};
use crate::output::{Report, StageStats};
use fe_petsc::explicit::{ExplicitFe, ExplicitSetup, StepError};
use fe_petsc::hex::HexControls;
use fe_petsc::implicit::{ImplicitError, ImplicitFe};
use fe_petsc::mesh::DistributedMesh;
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::time::Instant;

mod contact_body;
mod loads;
mod remap;
pub mod setup;

pub use contact_body::apply_contact;

/// The integrator of the scene's mode. Both keep their state in an [`ExplicitFe`], which
/// contact, probes and output read.
pub enum Integrator {
    /// Central differences (the paper's).
    Explicit(Box<ExplicitFe>),
    /// Newmark average acceleration with Newton iterations and KSP.
    Implicit(Box<ImplicitFe>),
}

/// The FE stage of a run.
pub struct Fe {
    /// The integrator and its state.
    pub integrator: Integrator,
    /// This rank's part of the distributed mesh and its ghost exchange.
    pub mesh: DistributedMesh,
    /// The scene file, for messages.
    file: String,
    /// The stage's own wall time in the time loop (drift, element forces, exchange, nodal
    /// updates, its reduction), s.
    wall_s: f64,
    /// The `fixed` and `velocity` groups of reactions.csv, in scene order.
    pub reaction_groups: Vec<setup::ReactionGroup>,
    /// The contact surfaces a `[contact]` table names (`Fe::set_contact_surfaces`): the
    /// nodes and faces the FE stage lends the contact stage.
    contact_surfaces: Option<crate::transfer::fe_contact::FeContact>,
    /// Failed elements released to particles since the driver last took them
    /// ([`Fe::take_released`]), the global count of released elements, and of failed
    /// elements waiting for their release (`ExplicitFe::release_failed`).
    released: (Vec<fe_petsc::explicit::failure::Released>, u64, u64),
    /// The global count of failed elements at the last release.
    eroded_seen: u64,
    /// Whether the note on slow default implicit solves was printed ([`SLOW_SOLVE_ITERATIONS`]).
    slow_solve_noted: bool,
}

/// CG iterations per Newton solve past which an implicit run with the default solver says once
/// that a PETSc preconditioner would be faster: the coarse grid has at most 600 nodes, so on
/// far finer meshes the count grows again where GAMG's stays flat (docs/running.md).
pub const SLOW_SOLVE_ITERATIONS: f64 = 500.0;

impl Fe {
    /// The FE stage of `scene` on the distributed mesh `mesh` (collective): explicit, or with
    /// `implicit_dt` implicit with that fixed step. Initial energies summed.
    pub fn new(
        world: &SimpleCommunicator,
        scene: &Scene,
        groups: &setup::Groups,
        mut mesh: DistributedMesh,
        implicit_dt: Option<f64>,
        split: bool,
    ) -> Result<Fe, String> {
        let file = scene.file.display().to_string();
        let mut inputs = setup::prepare(world, scene, groups, &mut mesh)?;
        let reaction_groups = std::mem::take(&mut inputs.reaction_groups);
        // A mesh split from tetrahedra or prisms bounds the physical hourglass stresses'
        // tangential part by the fibres' radial return (`fe_petsc::hourglass::YieldBound`):
        // with the whole-amplitude bound its distorted hexahedra let a spurious pattern grow in
        // plastic flow. Explicit mode only (the implicit tangent is the whole-amplitude
        // bound's).
        let mut hourglass = scene.run.hourglass.control();
        if let fe_petsc::hourglass::Hourglass::Physical { bound, .. } = &mut hourglass {
            if split && implicit_dt.is_none() {
                *bound = fe_petsc::hourglass::YieldBound::Tangential;
            }
        }
        let controls = HexControls {
            hourglass,
            bv_linear: scene.run.bulk_viscosity.linear,
            bv_quadratic: scene.run.bulk_viscosity.quadratic,
        };
        let setup = ExplicitSetup {
            mesh: &mesh.local,
            elem_material: inputs.elem_material,
            elem_block: inputs.elem_block,
            tet_material: inputs.tet_material,
            tet_block: inputs.tet_block,
            n_blocks: scene.blocks.len(),
            materials: inputs.materials,
            velocity: inputs.velocity,
            constraints: inputs.constraints,
            controls,
            gravity: scene.gravity,
            gravity_curve: scene.gravity_curve.clone(),
            velocity_curves: inputs.velocity_curves,
        };
        let mut integrator = match implicit_dt {
            None => {
                let res = ExplicitFe::new(setup, &mut mesh.exchange);
                first_error(world, res.as_ref().err().map(|e| format!("{file}: {e}")))?;
                Integrator::Explicit(Box::new(res.map_err(|e| e.to_string())?))
            }
            Some(dt) => {
                let res = ImplicitFe::new(world, setup, dt, &mut mesh.exchange);
                let mine = match &res {
                    Ok(_) | Err(ImplicitError::OtherRank) => None,
                    // The command line's, not the scene's.
                    Err(ImplicitError::Option(e)) => Some(e.clone()),
                    Err(e) => Some(format!("{file}: {e}")),
                };
                first_error(world, mine)?;
                Integrator::Implicit(Box::new(res.map_err(|e| e.to_string())?))
            }
        };
        let loads = loads::pressure_loads(world, scene, groups, &mesh.local);
        let res = match &mut integrator {
            Integrator::Explicit(fe) => fe.set_loads(loads, &mut mesh.exchange),
            Integrator::Implicit(imp) => imp.set_loads(loads, &mut mesh.exchange),
        };
        first_error(world, res.err().map(|e| format!("{file}: {e}")))?;
        if let (Integrator::Implicit(imp), false) = (&mut integrator, scene.rigid_walls.is_empty())
        {
            imp.set_walls(scene.rigid_walls.len());
        }
        if let Integrator::Explicit(fe) = &mut integrator {
            // Each element material's failure criterion, in the materials' order (`prepare`:
            // the materials the blocks use, in scene order).
            let criteria = scene
                .materials
                .iter()
                .zip(&scene.failures)
                .filter(|(m, _)| scene.blocks.iter().any(|b| b.material == m.name))
                .map(|(_, f)| *f)
                .collect();
            fe.set_failure(criteria);
            let release = (0..scene.materials.len())
                .filter(|&m| {
                    scene
                        .blocks
                        .iter()
                        .any(|b| b.material == scene.materials[m].name)
                })
                .map(|m| scene.releases(m))
                .collect();
            fe.set_release(release);
        }
        match &mut integrator {
            Integrator::Explicit(fe) => fe.initial_energies(world),
            Integrator::Implicit(imp) => imp.fe.initial_energies(world),
        }
        Ok(Fe {
            integrator,
            mesh,
            file,
            wall_s: 0.0,
            reaction_groups,
            contact_surfaces: None,
            released: (Vec::new(), 0, 0),
            eroded_seen: 0,
            slow_solve_noted: false,
        })
    }

    /// This rank's terms of each reaction group's force ([`Fe::reaction_groups`]): for group
    /// k, `terms[3 k + c]` holds component c of the constraint reaction of each owned node of
    /// the group, now (after the last step), N. Summed exactly over ranks by the caller (`output::exact_forces`).
    pub fn reaction_terms(&self) -> Vec<Vec<f64>> {
        let r: Vec<(u32, [f64; 3])> = match &self.integrator {
            Integrator::Explicit(fe) => fe.constraint_reactions().collect(),
            Integrator::Implicit(imp) => imp.constraint_reactions().collect(),
        };
        let mut terms = vec![Vec::new(); 3 * self.reaction_groups.len()];
        for (k, g) in self.reaction_groups.iter().enumerate() {
            for n in &g.nodes {
                // Both lists are in ascending node order; a group node is always constrained.
                if let Ok(i) = r.binary_search_by_key(n, |e| e.0) {
                    for c in 0..3 {
                        terms[3 * k + c].push(r[i].1[c]);
                    }
                }
            }
        }
        terms
    }

    /// Sets the element kernel every rank runs (collective). `Auto` takes the widest group
    /// every rank's CPU offers (a rank without AVX-512F makes all run four lanes, one without
    /// AVX2 one lane: one answer, one arithmetic); `Lanes8` on a rank without AVX-512F, or
    /// `Lanes4` on an x86-64 rank without AVX2, is an error on every rank.
    pub fn choose_kernel(
        &mut self,
        world: &SimpleCommunicator,
        choice: crate::driver::KernelChoice,
    ) -> Result<(), String> {
        use crate::driver::KernelChoice;
        use fe_petsc::batch::{widest, Width};
        let mine: i32 = match widest() {
            Width::W1 => 1,
            Width::W4 => 4,
            #[cfg(target_arch = "x86_64")]
            Width::W8 => 8,
        };
        let mut all = 0i32;
        world.all_reduce_into(&mine, &mut all, SystemOperation::min());
        if choice == KernelChoice::Lanes8 && all < 8 {
            return Err(
                "--kernel lanes8 needs AVX-512F, which this CPU (or another rank's) \
                        does not have: use --kernel auto, lanes4 or scalar"
                    .into(),
            );
        }
        if choice == KernelChoice::Lanes4 && all < 4 {
            return Err(
                "--kernel lanes4 needs AVX2, which this CPU (or another rank's) does not \
                        have: use --kernel auto or scalar"
                    .into(),
            );
        }
        let wide = match all {
            8.. => widest(),
            4..8 => Width::W4,
            _ => Width::W1,
        };
        self.state_mut().width = match choice {
            KernelChoice::Auto | KernelChoice::Lanes8 => wide,
            KernelChoice::Lanes4 => Width::W4,
            KernelChoice::Scalar => Width::W1,
        };
        Ok(())
    }

    /// The failed elements released to particles since the last call (this rank's), in
    /// element order.
    pub fn take_released(&mut self) -> Vec<fe_petsc::explicit::failure::Released> {
        std::mem::take(&mut self.released.0)
    }

    /// The global count of failed elements released to particles.
    pub fn released_count(&self) -> u64 {
        self.released.1
    }

    /// After a restart (collective): the counts of released and waiting elements, and of
    /// failed ones.
    pub fn restore_release_counts(&mut self, world: &SimpleCommunicator) {
        if let Integrator::Explicit(fe) = &mut self.integrator {
            if fe.releases() {
                fe.count_failed(world);
                self.eroded_seen = fe.eroded();
                (self.released.1, self.released.2) = fe.count_released(world);
            }
        }
    }

    /// The state (nodes, elements, energies).
    pub fn state(&self) -> &ExplicitFe {
        match &self.integrator {
            Integrator::Explicit(fe) => fe,
            Integrator::Implicit(imp) => &imp.fe,
        }
    }

    /// The state, mutable (the contact push-back).
    pub fn state_mut(&mut self) -> &mut ExplicitFe {
        match &mut self.integrator {
            Integrator::Explicit(fe) => fe,
            Integrator::Implicit(imp) => &mut imp.fe,
        }
    }

    /// After a restart: the time-dependent loads and gravity at the restored time
    /// (collective).
    fn refresh_after_restart(&mut self) -> Result<(), String> {
        let ex = &mut self.mesh.exchange;
        match &mut self.integrator {
            Integrator::Explicit(fe) => {
                // the released elements' mass off their nodes again
                fe.refresh_after_restart(ex)
                    .and_then(|_| fe.restore_released_masses(ex))
            }
            Integrator::Implicit(imp) => imp.refresh_after_restart(ex),
        }
        .map_err(|e| format!("checkpoint: {e}"))
    }

    /// Sets the clock (with a fixed step the driver keeps t = step dt exactly).
    pub fn set_time(&mut self, t: f64) {
        self.state_mut().time = t;
    }

    /// One explicit step after the drift and the contact correction (Fig. 3 step 1 and the
    /// closing kick): element forces with the ghost exchange, then the energy sums in one
    /// reduction. Agrees on failure (an inverted element) with the same reduction as the next
    /// step size: a failing rank proposes a negative step.
    fn explicit_forces(
        world: &SimpleCommunicator,
        file: &str,
        fe: &mut ExplicitFe,
        mesh: &mut DistributedMesh,
        dt: f64,
    ) -> Result<f64, StageError> {
        let hg = fe.element_forces(dt, &mut mesh.exchange);
        let (local_dt, local_err, hg_work) = match hg {
            Ok(w) => (fe.dt_stable_local, None, w),
            Err(e) => (-1.0 - world.rank() as f64, Some(e), [0.0; 3]),
        };
        let next = collective::min(world, local_dt);
        if next < 0.0 {
            let msg = local_err.map(|e: StepError| format!("{file}: {e}"));
            first_error(world, msg).map_err(|message| StageError {
                unstable: true,
                message,
            })?;
        }
        let sums = fe.finish_step(dt);
        // The totals and the per-block sums in one reduction.
        let local = fe.step_sums(&sums, &hg_work);
        let mut global = vec![0.0; local.len()];
        world.all_reduce_into(&local[..], &mut global[..], SystemOperation::sum());
        fe.accumulate(&global, dt);
        if fe.erodes() {
            fe.count_failed(world);
        }
        Ok(next)
    }

    /// One implicit step (Newton on the whole step); every rank returns the failing rank's
    /// message, and whether it was a blow-up.
    fn implicit_step(
        world: &SimpleCommunicator,
        file: &str,
        imp: &mut ImplicitFe,
        mesh: &mut DistributedMesh,
    ) -> Result<(), StageError> {
        let res = imp.step(world, &mut mesh.exchange);
        let unstable = matches!(&res, Err(ImplicitError::Step(StepError::NonFinite { .. })));
        let any_unstable = collective::max(world, if unstable { 1.0 } else { 0.0 }) > 0.0;
        let msg = match res {
            Ok(()) | Err(ImplicitError::OtherRank) => None,
            Err(e) => Some(format!("{file}: {e}")),
        };
        first_error(world, msg).map_err(|message| StageError {
            unstable: any_unstable,
            message,
        })
    }
}

impl Stage for Fe {
    fn name(&self) -> &'static str {
        "fe"
    }

    fn drift(&mut self, dt: f64) {
        let t0 = Instant::now();
        if let Integrator::Explicit(fe) = &mut self.integrator {
            fe.kick_drift(dt);
        }
        self.wall_s += t0.elapsed().as_secs_f64();
    }

    fn forces(&mut self, world: &SimpleCommunicator, dt: f64) -> Result<f64, StageError> {
        let t0 = Instant::now();
        let next = match &mut self.integrator {
            Integrator::Explicit(fe) => {
                let next = Self::explicit_forces(world, &self.file, fe, &mut self.mesh, dt)?;
                // The same counts on every rank: every rank releases (a collective nodal sum).
                if fe.releases() && (fe.eroded() != self.eroded_seen || self.released.2 > 0) {
                    self.eroded_seen = fe.eroded();
                    let born =
                        fe.release_failed(&mut self.mesh.exchange)
                            .map_err(|e| StageError {
                                unstable: false,
                                message: format!("{}: {e}", self.file),
                            })?;
                    self.released.0.extend(born);
                    (self.released.1, self.released.2) = fe.count_released(world);
                    fe.refresh_kinetic(world);
                }
                next
            }
            Integrator::Implicit(imp) => {
                imp.set_dt(dt);
                Self::implicit_step(world, &self.file, imp, &mut self.mesh)?;
                let st = imp.stats;
                let per_solve = st.ksp_iterations as f64 / st.newton_iterations.max(1) as f64;
                // the counts are the same on every rank (collective solves)
                if !self.slow_solve_noted
                    && per_solve > SLOW_SOLVE_ITERATIONS
                    && !fe_petsc::implicit::petsc_solver_chosen()
                {
                    self.slow_solve_noted = true;
                    if world.rank() == 0 {
                        eprintln!(
                            "tdyn: note: the default implicit solver (CG preconditioned by the diagonal and a coarse grid, the same bytes at any rank count) takes {per_solve:.0} iterations per Newton solve on this mesh; add -pc_type gamg to the command line for PETSc's multigrid, usually many times faster on large meshes, its answers the same to round-off only (docs/cli.md)"
                        );
                    }
                }
                collective::min(world, imp.fe.dt_stable_local)
            }
        };
        self.wall_s += t0.elapsed().as_secs_f64();
        Ok(next)
    }

    fn stable_dt(&self, world: &SimpleCommunicator) -> f64 {
        collective::min(world, self.state().dt_stable_local)
    }

    fn energies(&self) -> StageEnergies {
        let e = &self.state().energies;
        StageEnergies {
            kinetic: e.kinetic,
            internal: e.internal,
            hourglass: e.hourglass,
            external_work: e.external_work,
            momentum: e.momentum,
            solid_internal: 0.0,
        }
    }

    fn wall_s(&self) -> f64 {
        self.wall_s
    }

    fn save(&self, w: &mut StateWriter) {
        let arrays = match &self.integrator {
            Integrator::Explicit(fe) => fe.restart_state(),
            Integrator::Implicit(imp) => imp.restart_state(),
        };
        for (name, a) in arrays {
            w.put(name, &a);
        }
        remap::save_ids(w, &self.mesh.local, self.state());
    }

    fn restore(&mut self, r: &StateReader) -> Result<(), String> {
        let mut get = |name: &str| r.get::<f64>(name).ok();
        match &mut self.integrator {
            Integrator::Explicit(fe) => fe.set_restart_state(&mut get),
            Integrator::Implicit(imp) => imp.set_restart_state(&mut get),
        }
        .map_err(|e| format!("checkpoint: {e}"))?;
        self.refresh_after_restart()
    }

    fn restore_remapped(
        &mut self,
        _world: &SimpleCommunicator,
        pieces: &[StateReader],
    ) -> Result<(), String> {
        let arrays = remap::arrays(self, pieces)?;
        let mut get = |name: &str| arrays.get(name).cloned();
        match &mut self.integrator {
            Integrator::Explicit(fe) => fe.set_restart_state(&mut get),
            Integrator::Implicit(imp) => imp.set_restart_state(&mut get),
        }
        .map_err(|e| format!("checkpoint: {e}"))?;
        self.refresh_after_restart()
    }

    fn report(&self, world: &SimpleCommunicator, report: &mut Report, loop_s: f64) {
        let fe = self.state();
        let size = world.size() as f64;
        let elements = self.mesh.local.global_elems;
        let steps = report.steps;
        report.fe = Some(StageStats::reduce(
            world,
            self.wall_s,
            fe.n_elements() as f64,
            self.mesh.exchange.bytes_sent as f64,
        ));
        report.ns_per_element_cycle = Some(if elements > 0 && steps > 0 {
            loop_s * 1e9 * size / (elements as f64 * steps as f64)
        } else {
            0.0
        });
        let mem_bytes = collective::sum(world, fe.bytes() as f64);
        let ex = &mut report.extra;
        ex.insert(
            "bytes_per_element".into(),
            (mem_bytes / elements.max(1) as f64).into(),
        );
        let t = fe.timers;
        ex.insert(
            "fe_element_kernel_s".into(),
            collective::max(world, t.elements).into(),
        );
        ex.insert(
            "fe_ghost_exchange_s".into(),
            collective::max(world, t.exchange).into(),
        );
        ex.insert("fe_nodal_s".into(), collective::max(world, t.nodal).into());
        if let Integrator::Explicit(e) = &self.integrator {
            ex.insert("fe_kernel".into(), kernel_name(e).into());
        }
        if let Integrator::Implicit(imp) = &self.integrator {
            implicit_report(world, imp, report, steps);
        }
    }
}

/// The implicit integrator's counters (the same on every rank: collective solves) and timers
/// (maxima) in the report.
fn implicit_report(world: &SimpleCommunicator, imp: &ImplicitFe, report: &mut Report, steps: u64) {
    let s = imp.stats;
    let ex = &mut report.extra;
    ex.insert("newton_iterations".into(), s.newton_iterations.into());
    ex.insert(
        "newton_iterations_per_step".into(),
        (s.newton_iterations as f64 / steps.max(1) as f64).into(),
    );
    ex.insert(
        "newton_iterations_max_step".into(),
        s.max_step_iterations.into(),
    );
    ex.insert("ksp_iterations".into(), s.ksp_iterations.into());
    ex.insert(
        "ksp_iterations_per_solve".into(),
        (s.ksp_iterations as f64 / s.newton_iterations.max(1) as f64).into(),
    );
    ex.insert("tangent_assemblies".into(), s.assemblies.into());
    ex.insert("residual_evaluations".into(), s.residuals.into());
    ex.insert(
        "implicit_assembly_s".into(),
        collective::max(world, s.assembly_s).into(),
    );
    ex.insert(
        "implicit_ksp_s".into(),
        collective::max(world, s.solve_s).into(),
    );
    ex.insert("newton_rtol".into(), imp.options.rtol.into());
}

/// The element kernel an explicit run took (report.json `fe_kernel`), with the instructions it
/// was built for: `scalar`, `lanes4 (AVX2)` (`lanes4` off x86-64) or `lanes8 (AVX-512F)`; every
/// rank runs the same one (`Fe::choose_kernel`).
fn kernel_name(fe: &ExplicitFe) -> &'static str {
    use fe_petsc::batch::Width;
    match fe.width {
        Width::W1 => "scalar",
        #[cfg(target_arch = "x86_64")]
        Width::W8 => "lanes8 (AVX-512F)",
        #[cfg(target_arch = "x86_64")]
        Width::W4 => "lanes4 (AVX2)",
        #[cfg(not(target_arch = "x86_64"))]
        Width::W4 => "lanes4",
    }
}
