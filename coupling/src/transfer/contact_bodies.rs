//! The push-back forces from the contact owners of a rebuild back to the bodies' owners (the
//! FE and SPH ranks that lent the nodes: Fig. 10, step 8), mesh nodes and particles in one
//! exchange, with the particles that immovable faces alone hold flagged.
use super::Back;
use crate::kernels::comm::CommPlan;
use mpi::topology::SimpleCommunicator;
use std::rc::Rc;

/// Step 8: each owned node's nonzero force to its home; returns the force on each of the
/// home's `n_home` input nodes and the bytes sent (collective).
pub(crate) fn send_home(
    comm: &Rc<SimpleCommunicator>,
    owned_force: &[[f64; 3]],
    owned_home: &[(i32, u64)],
    (held, n_home): (&[bool], usize),
) -> (Vec<[f64; 3]>, Vec<bool>, u64) {
    let mut dest = Vec::new();
    let mut back = Vec::new();
    for (i, (f, &(home, idx))) in owned_force.iter().zip(owned_home).enumerate() {
        if f.iter().any(|c| *c != 0.0) {
            dest.push(home);
            // A particle held by immovable faces only (`held_particles`): the key's top bit.
            let flag = if held.get(i).copied().unwrap_or(false) {
                HELD_BIT
            } else {
                0
            };
            back.push(Back {
                key: idx | flag,
                f: *f,
            });
        }
    }
    let mut plan = CommPlan::new_shared(comm, &dest);
    let got = plan.exchange(&back);
    let mut force = vec![[0.0; 3]; n_home];
    let mut held_home = vec![false; n_home];
    for bk in &got {
        let k = (bk.key & !HELD_BIT) as usize;
        held_home[k] |= bk.key & HELD_BIT != 0;
        let f = &mut force[k];
        for c in 0..3 {
            f[c] += bk.f[c];
        }
    }
    (force, held_home, plan.bytes_sent)
}

/// The top bit of a [`Back`] record's key: the node is a particle held by immovable faces only.
const HELD_BIT: u64 = 1 << 63;
