//! Moving records between the decompositions, one file per pair joined (the first name the
//! sender's side, the second the receiver's):
//!
//! - [`fe_contact`]: the FE owners' contact surfaces, their nodes' and faces' records to the
//!   contact owners;
//! - [`bodies_contact`]: every body's contact nodes (mesh nodes and particles, in one
//!   exchange) from their FE and SPH owners to the contact owners of a rebuild;
//! - [`sph_contact`]: the particles to the boxes of a kept contact decomposition;
//! - [`contact_bodies`]: the push-back forces back from the contact owners to the FE and SPH
//!   owners after a rebuild (mesh nodes and particles in one exchange);
//! - [`contact_fe`]: the mesh nodes' forces back along a kept decomposition's plan;
//! - [`contact_sph`]: the particles' forces back along their plan of a kept decomposition;
//! - [`fe_sph`]: the particles of failed elements, from the FE owners to the SPH
//!   decomposition.
use crate::kernels::rcb::RcbItem;
use bytemuck::{Pod, Zeroable};
use contact::NodeRecord;

pub mod bodies_contact;
pub mod contact_bodies;
pub mod contact_fe;
pub mod contact_sph;
pub mod fe_contact;
pub mod fe_sph;
pub mod sph_contact;

/// A contact node travelling between the decompositions: its record and where its owner (its
/// home: the FE or SPH rank that lent it) keeps it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct CNode {
    /// The node's record.
    pub rec: NodeRecord,
    /// The home rank.
    pub home: u64,
    /// Position among the records the home lent.
    pub home_idx: u64,
    /// Position among the home's mesh (non-particle) nodes; `u64::MAX` for a particle.
    pub fe_idx: u64,
}

impl RcbItem for CNode {
    fn position(&self) -> [f64; 3] {
        self.rec.x1
    }
    fn id(&self) -> u64 {
        self.rec.gid
    }
}

/// A force for one node, keyed by an index or a gid.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct Back {
    /// The node's index (or gid) where the force goes.
    pub key: u64,
    /// The force, N.
    pub f: [f64; 3],
}

/// Whether a contact node's record is a particle's (`contact::FLAG_PARTICLE`).
pub(crate) fn is_particle(r: &NodeRecord) -> bool {
    r.flags & contact::FLAG_PARTICLE != 0
}
