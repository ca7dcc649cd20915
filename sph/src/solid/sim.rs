//! A complete single-box run with solid particles: the serial reference sequence of one step
//! with the solid passes (see the parent module), over `SerialSim`'s particles and periodic
//! images.
use super::{
    fold_quad_ghost, quadratic_pass, settle_gradients, settle_quadratic, solid_pressure,
    stress_force_pass, update_stress, velocity_gradient_pass, ArtificialStress, Solids,
};
use crate::exact::{exact_pass, PassGrids};
use crate::integrate::{book_work_at_step_velocity, first_half, second_half, setup_state};
use crate::neighbour::pairs;
use crate::params::{DensityMode, Params};
use crate::particles::Particles;
use crate::passes::{add_gravity, update_eos, PairWork};
use crate::serial::SerialSim;
use crate::strength::StressModel;
use std::sync::Arc;

/// A serial SPH run with solids (the standard profile, continuity density). `params.eos` must
/// hold an entry for every material index; a solid's is not used (its p and c come from its
/// stress and model). Fluids in the same run see the stress pass with sigma = -p I (the same
/// physics as `force_pass`, other round-off; a run without solids uses `SerialSim`).
#[derive(Clone, Debug)]
pub struct SolidSim {
    /// The particles, the model, the time and the periodic images.
    pub sim: SerialSim,
    /// The solid state beside the particles.
    pub solids: Solids,
    /// Monaghan's artificial stress, if any.
    pub art: Option<ArtificialStress>,
    /// The grids of the gradient pass's exact sums.
    pub grad_grids: PassGrids,
    /// The grids of the quadratic pass's exact sums (`super::quadratic`).
    pub quad_grids: PassGrids,
}

impl SolidSim {
    /// A run over `parts` (owned entries), with the stress model of each material index
    /// (`None`: a fluid). Call `setup` before the first `step`.
    pub fn new(
        parts: Particles,
        params: Params,
        models: Vec<Option<Arc<dyn StressModel>>>,
        art: Option<ArtificialStress>,
    ) -> Self {
        assert_eq!(
            params.density,
            DensityMode::Continuity,
            "solids need continuity"
        );
        let sim = SerialSim::new(parts, params);
        let solids = Solids::new(models, &sim.parts);
        Self {
            sim,
            solids,
            art,
            grad_grids: PassGrids::default(),
            quad_grids: PassGrids::default(),
        }
    }

    /// The owned particles' state and rates at t = 0 (zero stress unless set before).
    pub fn setup(&mut self) -> PairWork {
        setup_state(&mut self.sim.parts, &self.sim.params);
        solid_pressure(&mut self.sim.parts, &self.solids);
        self.evaluate(None)
    }

    /// One step of `dt`, s; returns the pair work rate of its evaluation.
    pub fn step(&mut self, dt: f64) -> PairWork {
        first_half(&mut self.sim.parts, dt, &self.sim.params);
        let work = self.evaluate(Some(dt));
        second_half(&mut self.sim.parts, dt, &self.sim.params);
        book_work_at_step_velocity(&mut self.sim.parts, &self.sim.params, dt);
        // second_half ran the EOS on every owned particle: the solids' p, c from their stress
        solid_pressure(&mut self.sim.parts, &self.solids);
        self.sim.time += dt;
        self.sim.steps += 1;
        work
    }

    /// Images, pairs, the velocity gradient and density rates, (with `dt`) the stress update,
    /// then the stress force pass and gravity.
    fn evaluate(&mut self, dt: Option<f64>) -> PairWork {
        let sim = &mut self.sim;
        sim.make_images();
        let pairs = pairs(&sim.parts, &sim.params.search_options(), |_| true);
        sim.n_pairs = pairs.len();
        let (p, params, owners) = (&mut sim.parts, &sim.params, &sim.ghost_owner);
        update_eos(p, params);
        let s = &mut self.solids;
        let k = params.smoothing_kernel();
        // the gradient pass also gives the density rates and the correction B of the force
        // pass (set-up included)
        exact_pass(
            &mut self.grad_grids,
            |m| *m,
            |g, m| velocity_gradient_pass(&pairs, p, s, &k, g, m),
        );
        for (g, &o) in owners.iter().enumerate() {
            s.fold_ghost(p.n_owned + g, o);
        }
        settle_gradients(p, s);
        // the surface particles' quadratic fit: flags to the images, the pass, fold, settle
        for (g, &o) in owners.iter().enumerate() {
            s.quad_flag[p.n_owned + g] = s.quad_flag[o];
        }
        exact_pass(
            &mut self.quad_grids,
            |m| *m,
            |g, m| quadratic_pass(p, s, g, m),
        );
        for (g, &o) in owners.iter().enumerate() {
            fold_quad_ghost(s, p.n_owned + g, o);
        }
        settle_quadratic(p, s);
        match dt {
            Some(dt) => update_stress(p, s, dt),
            None => solid_pressure(p, s),
        }
        for (g, &o) in owners.iter().enumerate() {
            s.copy_to_ghost(p, p.n_owned + g, o);
        }
        let art = self.art.as_ref();
        let (work, _) = exact_pass(
            &mut sim.grids,
            |m| *m,
            |g, m| stress_force_pass(&pairs, p, s, params, art, g, m),
        );
        for (g, &o) in owners.iter().enumerate() {
            let sums = p.pair_sums(p.n_owned + g);
            p.add_pair_sums(o, &sums);
        }
        p.settle_forces();
        add_gravity(p, params);
        work
    }
}
