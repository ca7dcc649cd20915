//! The mesh nodes' push-back forces from the boxes of a kept contact decomposition back to their
//! FE owners, along the kept plan's own pairs of ranks (Fig. 10, step 8).
use super::Back;
use crate::kernels::comm::CommPlan;

/// Step 8 for a kept box's mesh nodes: the nonzero forces of its owned nodes (`owned_force`;
/// `owned_home`: each one's home rank and index) back to their FE homes along the kept plan's
/// own pairs of ranks (`source_of_home`: each rank's position among the plan's sources;
/// collective), summed there into the input nodes' slots (`fe_inputs`: the input index of
/// each mesh input, `n_inputs` in all). Returns the forces on the inputs and the bytes sent.
pub(crate) fn mesh_forces_home(
    (plan, owned_home, source_of_home): (&mut CommPlan, &[(i32, u64)], &[u32]),
    owned_force: &[[f64; 3]],
    fe_inputs: &[u32],
    n_inputs: usize,
) -> (Vec<[f64; 3]>, u64) {
    let mut lists: Vec<Vec<Back>> = vec![Vec::new(); plan.sources().count()];
    for (f, &(home, idx)) in owned_force.iter().zip(owned_home) {
        if f.iter().any(|c| *c != 0.0) {
            let k = source_of_home[home as usize];
            lists[k as usize].push(Back { key: idx, f: *f });
        }
    }
    let before = plan.bytes_sent;
    let got = plan.reverse_lists(&lists);
    let back_bytes = plan.bytes_sent - before;
    let mut force = vec![[0.0; 3]; n_inputs];
    for bk in &got {
        let f = &mut force[fe_inputs[bk.key as usize] as usize];
        for k in 0..3 {
            f[k] += bk.f[k];
        }
    }
    (force, back_bytes)
}
