//! Every body's contact nodes from their owners (the FE and SPH ranks that lend them, their
//! homes) to the contact decomposition of a rebuild (Fig. 10, step 1), mesh nodes and particles
//! in one exchange.
use super::{is_particle, CNode};
use crate::kernels::comm::CommPlan;
use crate::kernels::rcb::CutTree;
use contact::NodeRecord;
use mpi::topology::SimpleCommunicator;
use std::rc::Rc;

/// The contact nodes this rank hands in, each with its home (rank and index) and its index
/// among the mesh nodes (`u64::MAX` for a particle).
pub(crate) fn home_items(nodes: &[NodeRecord], me: i32) -> Vec<CNode> {
    let mut n_fe = 0u64;
    nodes
        .iter()
        .enumerate()
        .map(|(i, r)| CNode {
            rec: *r,
            home: me as u64,
            home_idx: i as u64,
            fe_idx: if is_particle(r) {
                u64::MAX
            } else {
                n_fe += 1;
                n_fe - 1
            },
        })
        .collect()
}

/// Step 1 of a rebuild: the contact nodes' records (`items`) to their contact owners in the
/// previous step's cut tree (`tree`; none at the first step: they stay), so that the RCB that
/// follows starts near its answer (collective). Returns the records this rank now holds and
/// the bytes it sent.
pub(crate) fn to_owners(
    comm: &Rc<SimpleCommunicator>,
    tree: Option<&CutTree>,
    items: Vec<CNode>,
) -> (Vec<CNode>, u64) {
    let Some(t) = tree else {
        return (items, 0);
    };
    let dest: Vec<i32> = items
        .iter()
        .map(|n| t.owner_of_item(&n.rec.x1, n.rec.gid))
        .collect();
    let mut plan = CommPlan::new_shared(comm, &dest);
    let got = plan.exchange(&items);
    (got, plan.bytes_sent)
}
