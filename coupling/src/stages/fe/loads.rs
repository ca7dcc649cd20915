//! The scene's `[[load]]`s as the FE integrator's pressure loads: each load's faces (the
//! boundary faces all four of whose nodes lie on its physical surface, found as the contact
//! surfaces are: [`FeContact::build`]) on the rank of their elements.
use super::setup::Groups;
use crate::input::scene::Scene;
use crate::transfer::fe_contact::FeContact;
use fe_petsc::explicit::PressureLoad;
use fe_petsc::mesh::LocalMesh;
use mpi::topology::SimpleCommunicator;

/// This rank's part of every `[[load]]` of `scene`, in scene order (collective: one gather of
/// the mesh to rank 0 per load). The groups were checked against the mesh (`validate_groups`).
pub fn pressure_loads(
    comm: &SimpleCommunicator,
    scene: &Scene,
    groups: &Groups,
    mesh: &LocalMesh,
) -> Vec<PressureLoad> {
    scene
        .loads
        .iter()
        .map(|l| {
            let tag = groups.surfaces[&l.group];
            let bit = mesh
                .surface_tags
                .iter()
                .position(|&t| t == tag)
                .map_or(0, |b| 1u32 << b);
            let faces = FeContact::build(comm, mesh, Some(bit), (&[], &[]), &[])
                .faces
                .iter()
                .map(|(rec, local)| (rec.gid, *local))
                .collect();
            PressureLoad {
                pressure: l.pressure,
                curve: l.curve.clone(),
                faces,
            }
        })
        .collect()
}
