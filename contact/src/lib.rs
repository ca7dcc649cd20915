//! Serial contact physics inside one box (no MPI).
//!
//! The parallel layer (`coupling`) cuts space into boxes (RCB over the contact nodes), gives each box
//! the nodes it owns plus copies of every node a face in or near the box uses, and asks this crate
//! the same question in every box: which owned node crossed which face during the step, and what
//! push-back removes the penetrations. A step in one box:
//!
//! ```
//! use contact::{push_back, search, ContactBox, NodeRecord, FaceRecord, PushBackParams, SearchParams};
//! # let (nodes, n_owned, faces): (Vec<NodeRecord>, usize, Vec<FaceRecord>) = (vec![], 0, vec![]);
//! let b = ContactBox::from_records(&nodes, n_owned, &faces).unwrap();
//! let contacts = search(&b, &SearchParams::default());
//! let pb = push_back(&b, &contacts, &PushBackParams::new(1e-6));
//! for (gid, force) in pb.contributions(&b) {
//!     // send (gid, force) to the owner of node gid, which sums them
//! #   let _ = (gid, force);
//! }
//! ```
//!
//! - [`data`]: nodes (struct-of-arrays) and faces of one box, `Pod` records to move them as bytes.
//! - [`search()`]: bucket-grid broad phase, node-face crossing narrow phase ([`pair`]), a
//!   node's contacts chosen deterministically (the deepest, and those on faces at an angle).
//! - [`push_back()`]: kinematic contact (Taylor and Flanagan), momentum-conserving to round-off.
//! - [`surfaces()`]: boundary faces and bodies of a hexahedral mesh.
//! - [`energy`]: the push-back's energy bookkeeping (what a correction books, what the guard
//!   weighs), the same for mesh nodes and particles.
//! - [`wall`]: a rigid wall (an infinite plane, moving or not), its push-back in closed form.
//!
//! Units are SI. Determinism: results depend only on geometry and global ids, never on the order
//! in which nodes or faces are stored.
#![warn(missing_docs)]

pub mod data;
pub mod energy;
pub mod geometry;
mod grid;
pub mod pair;
pub mod pushback;
pub mod recheck;
pub mod search;
pub mod surfaces;
mod vec3;
pub mod wall;

pub use data::{
    Aabb, Config, ContactBox, ContactFaces, ContactNodes, FaceRecord, NodeRecord, FLAG_MASTER,
    FLAG_PARTICLE,
};
pub use geometry::{shape, Projection, Quad};
pub use pushback::{
    anchor, cells_of, push_back, push_back_in, reach, Alone, Cells, Exchange, PushBack,
    PushBackParams, COLOURS,
};
pub use recheck::{recheck, RECHECK_TOL};
pub use search::{
    face_records_search_aabb, face_search_aabb, node_search_aabb, search, search_candidates,
    within_skin, Candidates, Contact, SearchParams,
};
pub use surfaces::{bodies, face_key, surfaces, BoundaryFace, Surfaces, HEX_FACES};
pub use vec3::V3;
pub use wall::Wall;

/// Errors building a box.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ContactError {
    /// A face's corner is not among the box's nodes.
    #[error("contact face {face}: its node {node} is not in the box")]
    MissingFaceNode {
        /// Face gid.
        face: u64,
        /// Node gid.
        node: u64,
    },
    /// Two nodes with one gid.
    #[error("contact node {gid} appears twice in the box")]
    DuplicateNode {
        /// Node gid.
        gid: u64,
    },
    /// More owned nodes than nodes.
    #[error("{n_owned} owned contact nodes but only {len} nodes")]
    OwnedCount {
        /// Asked.
        n_owned: usize,
        /// Held.
        len: usize,
    },
}
