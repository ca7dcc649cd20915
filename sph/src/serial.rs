//! A complete single-box SPH run: the reference sequence of calls that the parallel layer
//! reproduces with communication between them. Periodic images are made here as ghosts (what the
//! parallel layer does for a rank that spans a periodic box), and ghost sums are folded back into
//! their owners.
use crate::exact::{exact_pass, PassGrids};
use crate::integrate::{book_work_at_step_velocity, first_half, second_half, setup_state};
use crate::neighbour::pairs;
use crate::params::{DensityMode, Params};
use crate::particles::Particles;
use crate::passes::{add_gravity, density_pass, force_pass, update_eos, PairWork};
use crate::periodic::periodic_images;

/// A serial SPH run over owned particles (no ghosts other than periodic images).
#[derive(Clone, Debug)]
pub struct SerialSim {
    /// The particles (owned first; periodic images after, rebuilt every evaluation).
    pub parts: Particles,
    /// The model.
    pub params: Params,
    /// Simulated time, s.
    pub time: f64,
    /// Steps taken.
    pub steps: u64,
    /// Pairs computed in the last evaluation.
    pub n_pairs: usize,
    /// Owner of each ghost entry (index `i - n_owned`).
    pub(crate) ghost_owner: Vec<usize>,
    /// The grids of the pair sums.
    pub(crate) grids: PassGrids,
}

impl SerialSim {
    /// A run over `parts` (owned entries only). Call `setup` before the first `step`.
    pub fn new(mut parts: Particles, params: Params) -> Self {
        parts.truncate_ghosts();
        Self {
            parts,
            params,
            time: 0.0,
            steps: 0,
            n_pairs: 0,
            ghost_owner: Vec::new(),
            grids: PassGrids::default(),
        }
    }

    /// The set-up evaluation: state at t = 0 and the first rates (see `setup_state`).
    pub fn setup(&mut self) -> PairWork {
        setup_state(&mut self.parts, &self.params);
        self.evaluate(self.params.profile.setup_evaluates_density_and_eos())
    }

    /// One step of `dt`; returns the pair work rate of its evaluation.
    pub fn step(&mut self, dt: f64) -> PairWork {
        first_half(&mut self.parts, dt, &self.params);
        let work = self.evaluate(true);
        second_half(&mut self.parts, dt, &self.params);
        book_work_at_step_velocity(&mut self.parts, &self.params, dt);
        self.time += dt;
        self.steps += 1;
        work
    }

    /// Rebuilds the periodic images, finds the pairs and runs the passes.
    pub fn evaluate(&mut self, density_and_eos: bool) -> PairWork {
        self.make_images();
        let pairs = pairs(&self.parts, &self.params.search_options(), |_| true);
        self.n_pairs = pairs.len();
        let p = &mut self.parts;
        let params = &self.params;
        let one_box = |m: &[f64; 3]| *m;
        if density_and_eos {
            exact_pass(&mut self.grids, one_box, |g, m| {
                density_pass(&pairs, p, params, g, m)
            });
            for (g, &o) in self.ghost_owner.iter().enumerate() {
                let s = p.pair_sums(p.n_owned + g);
                p.add_pair_sums(o, &s);
            }
            p.settle_density(params.density == DensityMode::Summation);
            update_eos(p, params);
            for (g, &o) in self.ghost_owner.iter().enumerate() {
                let s = p.eos_state(o);
                p.set_eos_state(p.n_owned + g, &s);
            }
        }
        let (work, _) = exact_pass(&mut self.grids, one_box, |g, m| {
            force_pass(&pairs, p, params, g, m)
        });
        for (g, &o) in self.ghost_owner.iter().enumerate() {
            let s = p.pair_sums(p.n_owned + g);
            p.add_pair_sums(o, &s);
        }
        p.settle_forces();
        let partners = (0..p.n_owned)
            .map(|i| p.sums[i].partners)
            .fold(0.0, f64::max);
        assert!(
            partners <= crate::exact::MAX_PARTNERS,
            "a particle has {partners} pair partners, more than the exact sums hold"
        );
        add_gravity(p, params);
        work
    }

    /// Periodic images of the owned particles within 2 h_max of the box.
    pub(crate) fn make_images(&mut self) {
        self.parts.truncate_ghosts();
        self.ghost_owner.clear();
        let Some(per) = self.params.periodic else {
            return;
        };
        let reach = 2.0 * self.parts.max_h();
        for i in 0..self.parts.n_owned {
            for shift in periodic_images(self.parts.x_real[i], reach, &per) {
                let mut r = self.parts.record(i);
                r.shift = shift;
                self.parts.push_ghost(&r);
                self.ghost_owner.push(i);
            }
        }
    }
}
