//! The scene's `[[load]]`s as the FE integrator's pressure loads: each load's faces (the
//! boundary faces all four of whose nodes lie on its physical surface, found as the contact
//! surfaces are: [`FeContact::build`]) on the rank of their elements, each with its element (a
//! failed element's faces carry no load).
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
    let local_elem: std::collections::HashMap<u64, u32> = mesh
        .elem_id
        .iter()
        .enumerate()
        .map(|(i, &g)| (g, i as u32))
        .collect();
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
            let fc = FeContact::build(comm, mesh, Some(bit), (&[], &[]), &[]);
            let faces = fc
                .faces
                .iter()
                .map(|(rec, local)| (rec.gid, *local))
                .collect();
            // each face's element as the FE stage's local index (hexahedra; a native
            // tetrahedron's face has none, and such elements do not fail)
            let elements = fc
                .face_element_ids()
                .iter()
                .map(|g| local_elem.get(g).copied().unwrap_or(u32::MAX))
                .collect();
            PressureLoad {
                pressure: l.pressure,
                curve: l.curve.clone(),
                faces,
                elements,
            }
        })
        .collect()
}
