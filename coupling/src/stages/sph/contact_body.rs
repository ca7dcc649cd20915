//! The SPH stage as a body of the contact stage ([`ContactBody`]): its owned particles lent
//! as contact nodes (spheres, no faces), the push-back forces applied on them as given (a
//! particle has one owner), booked as the contact stage books every correction
//! (`contact::energy`, in `SphStage::apply_contact`).
use super::Sph;
use crate::stages::contact::body::ContactBody;
use crate::transfer::fe_contact::FullFace;
use contact::NodeRecord;
use fe_petsc::exact::Folds;

impl ContactBody for Sph {
    /// The owned particles' records (`SphStage::contact_records`), ids `gid_offset +` the
    /// particle's id.
    fn contact_nodes(&self, gid_offset: u64, dt: f64) -> Vec<NodeRecord> {
        self.stage.contact_records(gid_offset, dt)
    }

    /// Particles have no faces.
    fn contact_faces(&self) -> Vec<FullFace> {
        Vec::new()
    }

    /// The forces on the records are the forces on the owned particles, in their order.
    fn take_forces(&mut self, on_records: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, String> {
        Ok(on_records.to_vec())
    }

    fn energy_terms(&self, force: &[[f64; 3]], dt: f64) -> [Folds; 2] {
        self.stage.contact_energy_terms(force, dt)
    }

    fn forces_on_records(&self, force: &[[f64; 3]]) -> Vec<[f64; 3]> {
        force.to_vec()
    }

    /// `held`: the particles immovable faces alone hold, kept for the closing kick
    /// (`SphStage::hold_on_faces`).
    fn apply_impulses(&mut self, force: &[[f64; 3]], held: &[bool], dt: f64) -> Folds {
        let tags: Vec<u8> = held.iter().map(|&h| u8::from(h)).collect();
        self.stage.apply_contact(force, &tags, dt)
    }

    /// The particle file's entry of particle `id` (`ParticleIds::entry`).
    fn particle_entry(&self, id: u64) -> Option<u32> {
        self.ids.entry(id)
    }
}
