//! The particles from their SPH owners to the boxes of a kept contact decomposition: each to the
//! box its predicted position falls in, every step (they are not in the kept plan).
use super::{is_particle, CNode};
use crate::kernels::comm::CommPlan;
use crate::kernels::rcb::CutTree;
use contact::NodeRecord;
use mpi::topology::SimpleCommunicator;
use std::rc::Rc;

/// Particles (never face corners) to the box their predicted position falls in (collective):
/// the records sent, the plan (for the forces' way back), the records this rank received.
pub(crate) fn particles_to_boxes(
    comm: &Rc<SimpleCommunicator>,
    tree: &CutTree,
    nodes: &[NodeRecord],
    me: i32,
) -> (Vec<CNode>, CommPlan, Vec<CNode>) {
    let mut dest = Vec::new();
    let mut items = Vec::new();
    for (i, r) in nodes.iter().enumerate().filter(|(_, r)| is_particle(r)) {
        dest.push(tree.owner_of_item(&r.x1, r.gid));
        items.push(CNode {
            rec: *r,
            home: me as u64,
            home_idx: i as u64,
            fe_idx: u64::MAX,
        });
    }
    let mut plan = CommPlan::new_shared(comm, &dest);
    let got = plan.exchange(&items);
    (items, plan, got)
}
