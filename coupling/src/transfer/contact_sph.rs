//! The particles' push-back forces from the boxes of a kept contact decomposition back to their
//! SPH owners, along the plan that brought them (`sph_contact`; Fig. 10, step 8).
use super::CNode;
use crate::kernels::comm::CommPlan;

/// Step 8 for the particles of a kept decomposition: each received particle's force
/// (`owned_force`, in the order `plan` brought them) and whether immovable faces alone hold it
/// (`flags`) back along `plan` (collective), written into the home's slots (`items`: the
/// records this rank sent, with their home indices) of `force` and `held`. Returns the bytes
/// sent.
pub(crate) fn particle_forces_home(
    plan: &mut CommPlan,
    items: &[CNode],
    (owned_force, flags): (&[[f64; 3]], &[bool]),
    (force, held): (&mut [[f64; 3]], &mut [bool]),
) -> u64 {
    let before = plan.bytes_sent;
    // Each particle's force and whether immovable faces alone hold it (1 or 0).
    let out: Vec<[f64; 4]> = owned_force
        .iter()
        .zip(flags)
        .map(|(f, &h)| [f[0], f[1], f[2], f64::from(u8::from(h))])
        .collect();
    let back = plan.reverse(&out);
    for (item, f) in items.iter().zip(&back) {
        force[item.home_idx as usize] = [f[0], f[1], f[2]];
        held[item.home_idx as usize] = f[3] != 0.0;
    }
    plan.bytes_sent - before
}
