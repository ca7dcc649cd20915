//! One explicit time step of the stages a run has: the paper's Fig. 3, one line per stage.
//!
//! The order is velocity Verlet's: every stage kicks and drifts its nodes or particles to
//! t + dt on its own decomposition (Fig. 3 step 3); the contact stage finds the nodes and
//! particles that crossed a face on its decomposition and pushes them back (steps 4-5), and the
//! rigid walls put back what is behind them; then the
//! FE stage computes element forces (step 1) and the SPH stage its pairwise passes (step 2) at
//! the corrected positions, each ending with its closing kick (step 6). An implicit FE stage
//! takes its whole Newton step in `forces`.
use super::setup::Model;
use crate::stages::contact::body::ContactBody;
use crate::stages::StageError;
use mpi::topology::SimpleCommunicator;

/// One step of `dt` from time `t` (collective). Returns the stable step for the next one (min
/// over stages and ranks, no safety factor).
pub fn step(
    world: &SimpleCommunicator,
    model: &mut Model,
    t: f64,
    dt: f64,
) -> Result<f64, StageError> {
    // 3. Move nodes and particles, each on its own decomposition.
    for stage in model.stages_mut() {
        stage.drift(dt);
    }
    // 4-5. Contact detection on the contact decomposition; push-back on nodes and particles.
    if let (Some(contact), Some(fe)) = (&mut model.contact, &mut model.fe) {
        let particles = model.sph.as_mut().map(|s| s as &mut dyn ContactBody);
        contact.step(world, (fe, particles), (t, dt))?;
    }
    // The rigid walls put back what the drift or the push-back left behind them.
    if let Some(walls) = &mut model.walls {
        walls.step(world, model.fe.as_mut(), model.sph.as_mut(), (t + dt, dt));
    }
    // 1-2, 6. FE forces, SPH forces, the closing kicks and the energy sums.
    let mut next = f64::INFINITY;
    for stage in model.stages_mut() {
        next = next.min(stage.forces(world, dt)?);
    }
    // The walls' holds of nodes and particles through the closing kick: their impulses.
    if let Some(walls) = &mut model.walls {
        walls.after_holds(world, model.fe.as_ref(), model.sph.as_ref());
    }
    // Failed elements become particles (FE -> SPH), in the SPH stage's rates from now on.
    if let (Some(rel), Some(fe), Some(sph)) = (&mut model.releases, &mut model.fe, &mut model.sph) {
        let born = crate::transfer::fe_sph::transfer(world, (fe, sph), rel).map_err(|message| {
            StageError {
                unstable: false,
                message,
            }
        })?;
        if born {
            model.sum_erosion_masses(world);
        }
    }
    // An implicit step held nodes on the walls inside Newton: their impulses and energy.
    if let Some(walls) = &mut model.walls {
        walls.after_implicit(model.fe.as_ref());
    }
    Ok(next)
}
