//! The stages of one time step (Fig. 3), each on its own decomposition: the finite elements on
//! PETSc's static distribution ([`fe`]), the SPH particles on a dynamic RCB ([`sph`], Fig. 8),
//! the contact search and push-back on a second dynamic RCB ([`contact`], Fig. 10).
//!
//! The FE and SPH stages move material and compute its forces; both implement [`Stage`], the
//! interface the driver's step is written against. The contact stage works between them: it
//! takes both stages' contact nodes after the drift and corrects them
//! (`contact::Contact::step`). The rigid walls ([`walls`]) correct them after it.
use crate::output::state::{StateReader, StateWriter};
use crate::output::Report;
use mpi::topology::SimpleCommunicator;

pub mod contact;
pub mod fe;
pub mod sph;
pub mod walls;

/// A stage's energies and momentum, summed over ranks (J, kg m/s).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageEnergies {
    /// Kinetic energy.
    pub kinetic: f64,
    /// Internal (strain and thermal) energy, without the hourglass energy.
    pub internal: f64,
    /// Energy stored and dissipated by hourglass control (FE only).
    pub hourglass: f64,
    /// Work done on the stage by gravity and prescribed motion since t = 0.
    pub external_work: f64,
    /// Linear momentum.
    pub momentum: [f64; 3],
    /// The internal energy of the solid particles alone (part of `internal`; SPH only): the
    /// work their stresses stored or dissipated from a stress-free start, never negative but
    /// where the run goes unstable (`driver::energy_check`).
    pub solid_internal: f64,
}

impl StageEnergies {
    /// Kinetic + internal + hourglass.
    pub fn total(&self) -> f64 {
        self.kinetic + self.internal + self.hourglass
    }
}

/// Why a step failed, the same on every rank.
#[derive(Debug, Clone, PartialEq)]
pub struct StageError {
    /// A numerical blow-up (non-finite state, inverted element): the step is too large for the
    /// model; otherwise a failure of another kind (no Newton convergence, bad input).
    pub unstable: bool,
    /// The message, naming the file and where.
    pub message: String,
}

impl From<String> for StageError {
    fn from(message: String) -> Self {
        StageError {
            unstable: false,
            message,
        }
    }
}

/// What the driver's step needs from a stage that moves material (FE nodes, SPH particles). All
/// methods taking `world` are collective and agree on failure.
pub trait Stage {
    /// The stage's name in the report (`"fe"`, `"sph"`).
    fn name(&self) -> &'static str;
    /// Fig. 3 step 3: the first half-kick and the move to t + dt, on the stage's own
    /// decomposition (no communication).
    fn drift(&mut self, dt: f64);
    /// Fig. 3 steps 1-2 and 6: forces at the new positions, the closing half-kick, the global
    /// energy sums. Returns the stable step for the next step (min over ranks, no safety
    /// factor).
    fn forces(&mut self, world: &SimpleCommunicator, dt: f64) -> Result<f64, StageError>;
    /// The stable step of the present state (min over ranks, no safety factor).
    fn stable_dt(&self, world: &SimpleCommunicator) -> f64;
    /// Energies and momentum now (global; the same on every rank).
    fn energies(&self) -> StageEnergies;
    /// The stage's own wall time in the time loop so far (this rank), s.
    fn wall_s(&self) -> f64;
    /// Writes the stage's section and figures into the report (collective). `loop_s` is the
    /// time loop's wall time without output (max over ranks).
    fn report(&self, world: &SimpleCommunicator, report: &mut Report, loop_s: f64);
    /// Tells the stage the time at the start of the next step, s (the driver's clock), where
    /// it reads time-dependent input (a curve) without keeping its own clock. Default: nothing.
    fn set_clock(&mut self, _t: f64) {}
    /// Writes this rank's restart state (`driver::checkpoint`).
    fn save(&self, w: &mut StateWriter);
    /// Sets the state `save` wrote, on the same ranks.
    fn restore(&mut self, r: &StateReader) -> Result<(), String>;
    /// Sets the state `save` wrote on another rank count (collective): `pieces` holds every
    /// writing rank's sections, in rank order; each rank takes what its part of the new
    /// decomposition needs, by global id. An error names what did not fit.
    fn restore_remapped(
        &mut self,
        world: &SimpleCommunicator,
        pieces: &[StateReader],
    ) -> Result<(), String>;
}
