//! How the contact stage sees the bodies it couples: through [`ContactBody`], which the FE
//! stage (its contact surfaces' nodes and faces) and the SPH stage (its particles) implement.
//! The stage lends their records to its own decomposition, searches, solves the push-back, and
//! hands each body the forces on its records back; what a body does with them (sum them over
//! the ranks that hold copies of a node, apply its constraints) is the body's. The energy
//! bookkeeping of a correction is one definition for all bodies, `contact::energy`.
use crate::transfer::fe_contact::FullFace;
use contact::NodeRecord;
use fe_petsc::exact::Folds;
use mpi::topology::SimpleCommunicator;

/// A body in contact: a lender of contact nodes (and faces) that takes the push-back's forces
/// back. Between the drift and the element or pair forces of a step (Fig. 3, steps 4-5); the
/// stage calls, in this order, [`ContactBody::update_faces`], [`ContactBody::contact_nodes`] and
/// [`ContactBody::contact_faces`], [`ContactBody::take_forces`], [`ContactBody::energy_terms`],
/// [`ContactBody::forces_on_records`], [`ContactBody::apply_impulses`].
pub trait ContactBody {
    /// This rank's contact nodes after the drift, as the search reads them: start and
    /// predicted positions, start-of-step velocity `v(n)`, mass (infinite for a node whose
    /// velocity is prescribed), radius, body and flags. Each record's id is the body's own id
    /// of the node plus `gid_offset` (so that no two bodies' ids meet), `dt` the step. Each
    /// node is lent by one rank (its owner).
    fn contact_nodes(&self, gid_offset: u64, dt: f64) -> Vec<NodeRecord>;

    /// Brings the faces [`ContactBody::contact_faces`] lends up to date (collective) and says
    /// whether they may have changed since the last call, the same on every rank (the stage
    /// then rebuilds its decomposition). Called first in each step; by default the faces
    /// never change.
    fn update_faces(&mut self, _world: &SimpleCommunicator) -> bool {
        false
    }

    /// This rank's contact faces with their corners' records (as [`ContactBody::contact_nodes`]
    /// writes them, ids without an offset), each face lent by one rank; empty for a body
    /// without faces.
    fn contact_faces(&self) -> Vec<FullFace>;

    /// From the push-back forces on this rank's records (aligned with
    /// [`ContactBody::contact_nodes`]), N, the body's own force array, which
    /// [`ContactBody::energy_terms`] and [`ContactBody::apply_impulses`] take: for a mesh, a
    /// force per local node with every copy holding the sum over the ranks (collective); for
    /// particles, the forces as given.
    fn take_forces(&mut self, on_records: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, String>;

    /// This rank's exact folds of the terms `[A, B]` of the change of the half-step kinetic
    /// energy that `force` (the body's array, [`ContactBody::take_forces`]) scaled by `alpha`
    /// makes over `dt`, `dK(alpha) = alpha A + alpha^2 B`: `A = sum m dv . v(n+1/2)`, `B = sum m
    /// |dv|^2 / 2` over the owned nodes that can move, `dv = F dt / m` with the nodes'
    /// constraints applied (`contact::energy::half_step_terms`), J. Called after the drift and
    /// before [`ContactBody::apply_impulses`].
    fn energy_terms(&self, force: &[[f64; 3]], dt: f64) -> [Folds; 2];

    /// The forces as applied on this rank's records (aligned with
    /// [`ContactBody::contact_nodes`]) from the body's array `force`, N: contact_forces.csv's.
    fn forces_on_records(&self, force: &[[f64; 3]]) -> Vec<[f64; 3]>;

    /// Applies the push-back: each node's half-step velocity gets `dv = F dt / m` (its
    /// constraints applied) and its position `dv dt`. `held`: the records (aligned with
    /// [`ContactBody::contact_nodes`]) that immovable faces alone hold in this step (a body
    /// that can be held keeps them for its closing kick; others ignore it). Returns this
    /// rank's exact fold of the work the corrections book in the step's energy balance, over
    /// owned nodes (`contact::energy::booked_work`), J.
    fn apply_impulses(&mut self, force: &[[f64; 3]], held: &[bool], dt: f64) -> Folds;

    /// contact_forces.csv: the scene's `[[particles]]` entry of the node whose id (less the
    /// body's offset) is `id`, or `None` where the node belongs to none (every mesh node:
    /// those count by their record's body).
    fn particle_entry(&self, _id: u64) -> Option<u32> {
        None
    }
}
