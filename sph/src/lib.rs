//! Serial SPH physics inside one box (no MPI): particles (struct-of-arrays, owned then ghosts),
//! kernels, equations of state, the neighbour search with the centre-of-interaction rule, the
//! density and force passes, and the two halves of a time step.
//!
//! # For the parallel layer
//!
//! One step on a rank, with communication where the list says so (`SerialSim` is exactly this
//! sequence for a single box, with periodic images as its only ghosts):
//!
//! 1. `first_half` on the owned particles (it wraps them into the periodic box, if any);
//!    migrate (`Particles::record`, `select_owned`, `push_owned`).
//! 2. Ghosts: every copy of another particle, or periodic image (`periodic_images`, then
//!    `record` with `shift` set, `push_ghost`), lying within 2 h_max of this rank's box. That
//!    reach suffices: a pair's COI is closer than r < h_a + h_b <= 2 h_max to both centres.
//! 3. `pairs(&parts, &params.search_options(), |x| my_box.contains(x))` with the box half-open.
//!    Each physical pair is then listed on exactly one rank, and only once there, whatever
//!    copies (images) the rank holds.
//! 4. `density_pass` (its sums exact on the grids of `exact::PassGrids`, redone by
//!    `exact::exact_pass` where its terms did not fit them); send `pair_sums` of ghosts to their
//!    owners, who `add_pair_sums` and `settle_density`.
//! 5. `update_eos`; send `eos_state` of owners to their ghosts (`set_eos_state`).
//! 6. `force_pass` (the same way; returns the pair work rate); send ghost `pair_sums` to
//!    owners, who `add_pair_sums` and `settle_forces`; `add_gravity`.
//! 7. `second_half`.
//!
//! The pair sums are exact, so every particle's force, energy rate and density are the same
//! bits whatever the order of the pairs and however they are shared between ranks.
//!
//! Before step 1: `setup_state`, then steps 2-6, with 4-5 only if
//! `Profile::setup_evaluates_density_and_eos`. The stable step is the minimum of `stable_dt`
//! over ranks. `energies` and `gravity_power` give per-rank sums for the energy balance.
//!
//! Solid particles (`solid`, `strength`): a particle whose material has a `StressModel`
//! carries the Cauchy stress; steps 4-6 are then `solid::velocity_gradient_pass` (which takes
//! every entry's continuity density rate along; ghost `GradSums` to owners,
//! `settle_gradients`), `update_eos` and `solid::update_stress`, the owners' `SolidGhost` to
//! their ghosts, and `solid::stress_force_pass` (ghost `PairSums` to owners), all sums exact;
//! after step 7 `solid::solid_pressure` (see the `solid` module doc; `SolidSim` is the serial
//! sequence). A run without solids never calls them.
//!
//! Two profiles: `Profile::Standard` (textbook forms, second-order leapfrog) and
//! `Profile::Liggghts`, which reproduces LIGGGHTS-PUBLIC 3.8.0's `sph/artVisc/tensCorr` pair
//! style and `nve/sph` integrator to round-off (checked by `tests/liggghts.rs`).
#![warn(missing_docs)]

pub mod diagnostics;
pub mod exact;
/// The equations of state: the `eos` crate, shared with the meshed fluid (`fe_petsc`).
pub use ::eos;
pub mod integrate;
pub mod kernel;
pub mod neighbour;
pub mod params;
pub mod particles;
pub mod passes;
pub mod periodic;
pub mod serial;
pub mod solid;
pub mod strength;

pub use diagnostics::{energies, gravity_power, interpolate, Energies};
pub use eos::Eos;
pub use integrate::{
    book_work_at_step_velocity, first_half, second_half, setup_state, stable_dt, CFL_FACTOR,
};
pub use kernel::{Kernel, SmoothingKernel};
pub use neighbour::{
    canonical, coi, pairs, pairs_in_box, CellList, Coi, KeptBoxPairs, KeptPairs, PairEnd,
    SearchOptions, KEPT_PAIRS_SKIN_H,
};
pub use params::{ArtificialViscosity, DensityMode, Params, Profile, TensileCorrection};
pub use particles::{EosState, NewParticle, PairSums, ParticleRecord, Particles};
pub use passes::{
    add_gravity, continuity_and_force_pass, continuity_and_force_pass_with, density_pass,
    force_pass, update_eos, PairWork, PassBuffers,
};
pub use periodic::{periodic_images, Periodic};
pub use serial::SerialSim;
pub use solid::{ArtificialStress, SolidSim, Solids};
pub use strength::StressModel;
