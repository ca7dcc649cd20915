//! From a scene and a distributed mesh to the FE stage's set-up: materials per element, initial
//! velocities, and nodal constraints (with the scene errors docs/scene.md lists for shared nodes).
use crate::input::scene::{BoundaryKind, Scene};
use crate::kernels::collective::first_error;
use fe_petsc::curve::Curve;
use fe_petsc::explicit::Constraint;
use fe_petsc::material::{build_material, Material};
use fe_petsc::mesh::{DistributedMesh, LocalMesh};
use mpi::topology::SimpleCommunicator;
use std::collections::BTreeMap;

/// gmsh physical groups: name -> tag, per dimension.
#[derive(Debug, Clone, Default)]
pub struct Groups {
    /// Physical volumes.
    pub volumes: BTreeMap<String, i32>,
    /// Physical surfaces.
    pub surfaces: BTreeMap<String, i32>,
}

/// What the FE stage needs besides the mesh.
pub struct FeInputs {
    /// Material index of each local element.
    pub elem_material: Vec<usize>,
    /// Block of each local element: its index in the scene's `[[block]]` list.
    pub elem_block: Vec<u32>,
    /// Material index of each local native tetrahedron (`LocalMesh::tets`).
    pub tet_material: Vec<usize>,
    /// Block of each local native tetrahedron.
    pub tet_block: Vec<u32>,
    /// Materials, in scene order.
    pub materials: Vec<Box<dyn Material>>,
    /// Initial velocity of each local node.
    pub velocity: Vec<[f64; 3]>,
    /// Constraints on local nodes.
    pub constraints: Vec<(u32, Constraint)>,
    /// The curve of each constraint (by index), where its velocity boundary has one.
    pub velocity_curves: Vec<Option<Curve>>,
    /// The `fixed` and `velocity` groups whose reactions reactions.csv writes.
    pub reaction_groups: Vec<ReactionGroup>,
}

/// A `fixed` or `velocity` `[[boundary]]` group, for reactions.csv: its name and the owned
/// local nodes whose reactions it sums. A node in several such groups counts in the first of
/// them in scene order (docs/output.md), so that the groups' forces add up to the total.
#[derive(Debug, Clone, PartialEq)]
pub struct ReactionGroup {
    /// The physical surface's name.
    pub name: String,
    /// Owned local nodes, ascending.
    pub nodes: Vec<u32>,
}

/// Builds materials, per-element material indices, initial velocities and constraints.
/// Collective: every rank returns the same error.
pub fn prepare(
    comm: &SimpleCommunicator,
    scene: &Scene,
    groups: &Groups,
    dm: &mut DistributedMesh,
) -> Result<FeInputs, String> {
    let file = scene.file.display().to_string();
    // The materials the blocks use, in scene order (a material only SPH particles use, such
    // as a fluid with an EOS, is not an element material).
    let mut materials = Vec::new();
    let mut mat_index: BTreeMap<&str, usize> = BTreeMap::new();
    for (i, spec) in scene.materials.iter().enumerate() {
        if !scene.blocks.iter().any(|b| b.material == spec.name) {
            continue;
        }
        match build_material(spec) {
            Ok(m) => {
                mat_index.insert(spec.name.as_str(), materials.len());
                materials.push(m);
            }
            Err(e) => return Err(format!("{file}: material[{i}]: {e}")),
        }
    }
    // block tag -> (material, velocity, block index)
    let mut by_tag: BTreeMap<i32, (usize, [f64; 3], u32)> = BTreeMap::new();
    for (i, b) in scene.blocks.iter().enumerate() {
        let tag = groups.volumes[&b.group];
        by_tag.insert(tag, (mat_index[b.material.as_str()], b.velocity, i as u32));
    }
    let m: &LocalMesh = &dm.local;
    let mut err = None;
    let (elem_material, elem_block) =
        block_materials(&m.elem_block, &m.elem_id, &by_tag, groups, &file, &mut err);
    let (tet_material, tet_block) =
        block_materials(&m.tet_block, &m.tet_id, &by_tag, groups, &file, &mut err);
    first_error(comm, err)?;

    // Initial velocity: the mean over the blocks of the elements around the node (weighted by
    // element count). Each node's elements are counted per block (integers, summed over all
    // ranks exactly) and the mean is then formed in block order, so every copy of a node and
    // every rank count gives the same bits (a sum of the velocities themselves would round in
    // the partition's order).
    let nn = m.coords.len();
    let nb = scene.blocks.len().max(1);
    // the exchange sums three values per node: the counts go in groups of three blocks
    let groups_of_3 = nb.div_ceil(3);
    let mut parts = vec![vec![0.0; 3 * nn]; groups_of_3];
    let hexes = m.elems.iter().zip(&elem_block).map(|(c, &b)| (&c[..], b));
    let tets = m.tets.iter().zip(&tet_block).map(|(c, &b)| (&c[..], b));
    for (conn, b) in hexes.chain(tets) {
        let b = b as usize;
        for &n in conn {
            parts[b / 3][3 * n as usize + b % 3] += 1.0;
        }
    }
    for part in parts.iter_mut() {
        dm.exchange.sum_shared(part).map_err(|e| e.to_string())?;
    }
    let cnt: Vec<f64> = (0..nn)
        .flat_map(|n| (0..nb).map(move |b| (n, b)))
        .map(|(n, b)| parts[b / 3][3 * n + b % 3])
        .collect();
    let block_v: Vec<[f64; 3]> = scene.blocks.iter().map(|b| b.velocity).collect();
    let velocity: Vec<[f64; 3]> = cnt
        .chunks_exact(nb)
        .map(|c| {
            let total: f64 = c.iter().sum();
            if total == 0.0 {
                return [0.0; 3];
            }
            // inside one block: its velocity exactly
            let mut present = c.iter().enumerate().filter(|(_, &ck)| ck > 0.0);
            if let (Some((k, _)), None) = (present.next(), present.next()) {
                return block_v[k];
            }
            let mut v = [0.0; 3];
            for (k, &ck) in c.iter().enumerate().filter(|(_, &ck)| ck > 0.0) {
                for (vc, bc) in v.iter_mut().zip(block_v[k]) {
                    *vc += ck * bc;
                }
            }
            v.map(|x| x / total)
        })
        .collect();

    let (constraints, velocity_curves) = constraints(comm, scene, groups, &dm.local)?;
    let reaction_groups = reaction_groups(scene, groups, &dm.local);
    Ok(FeInputs {
        elem_material,
        elem_block,
        tet_material,
        tet_block,
        materials,
        velocity,
        constraints,
        reaction_groups,
        velocity_curves,
    })
}

/// Each element's material index and block (its index in the scene's `[[block]]` list) from
/// its physical volume `tags` (`by_tag`: tag -> (material, velocity, block)); the first element
/// no block covers is kept in `err`.
fn block_materials(
    tags: &[i32],
    ids: &[u64],
    by_tag: &BTreeMap<i32, (usize, [f64; 3], u32)>,
    groups: &Groups,
    file: &str,
    err: &mut Option<String>,
) -> (Vec<usize>, Vec<u32>) {
    let mut material = Vec::with_capacity(tags.len());
    let mut block = Vec::with_capacity(tags.len());
    for (e, &tag) in tags.iter().enumerate() {
        match by_tag.get(&tag) {
            Some((mi, _, bi)) => {
                material.push(*mi);
                block.push(*bi);
            }
            None => {
                block.push(0);
                let name = groups
                    .volumes
                    .iter()
                    .find(|(_, &t)| t == tag)
                    .map(|(n, _)| format!("physical volume \"{n}\""))
                    .unwrap_or_else(|| "no physical volume".to_string());
                err.get_or_insert(format!(
                    "{file}: element {} is in {name}, which no [[block]] gives a material (add a [[block]] with group = ...)",
                    ids[e]
                ));
                material.push(0);
            }
        }
    }
    (material, block)
}

/// The `fixed` and `velocity` groups in scene order (each name once), each with the owned
/// local nodes no earlier such group took.
fn reaction_groups(scene: &Scene, groups: &Groups, m: &LocalMesh) -> Vec<ReactionGroup> {
    let mut taken = vec![false; m.coords.len()];
    let mut out: Vec<ReactionGroup> = Vec::new();
    for b in &scene.boundaries {
        if matches!(b.kind, BoundaryKind::Symmetry) || out.iter().any(|g| g.name == b.group) {
            continue;
        }
        let tag = groups.surfaces[&b.group];
        let bit = m
            .surface_tags
            .iter()
            .position(|&t| t == tag)
            .map_or(0, |k| 1u32 << k);
        let nodes: Vec<u32> = (0..m.coords.len())
            .filter(|&n| m.owned[n] && m.node_surfaces[n] & bit != 0 && !taken[n])
            .map(|n| n as u32)
            .collect();
        for &n in &nodes {
            taken[n as usize] = true;
        }
        out.push(ReactionGroup {
            name: b.group.clone(),
            nodes,
        });
    }
    out
}

/// The constraints on local nodes, and the curve of each (by index) where its velocity
/// boundary has one.
type Constraints = (Vec<(u32, Constraint)>, Vec<Option<Curve>>);

fn constraints(
    comm: &SimpleCommunicator,
    scene: &Scene,
    groups: &Groups,
    m: &LocalMesh,
) -> Result<Constraints, String> {
    let file = scene.file.display().to_string();
    let bit_of = |name: &str| -> u32 {
        let tag = groups.surfaces[name];
        m.surface_tags
            .iter()
            .position(|&t| t == tag)
            .map(|b| 1u32 << b)
            .unwrap_or(0)
    };
    let nn = m.coords.len();
    let mut fixed = vec![false; nn];
    let mut vel: Vec<Option<([f64; 3], usize)>> = vec![None; nn];
    let mut planes: Vec<Vec<[f64; 3]>> = vec![Vec::new(); nn];
    let mut err: Option<String> = None;
    for (i, b) in scene.boundaries.iter().enumerate() {
        let bit = bit_of(&b.group);
        let nodes: Vec<usize> = (0..nn).filter(|&n| m.node_surfaces[n] & bit != 0).collect();
        match &b.kind {
            BoundaryKind::Fixed => nodes.iter().for_each(|&n| fixed[n] = true),
            BoundaryKind::Velocity(v) => {
                for &n in &nodes {
                    if let Some((w, j)) = vel[n] {
                        let same = w == *v && scene.boundaries[j].curve == b.curve;
                        if !same && err.is_none() {
                            err = Some(format!(
                                "{file}: boundary[{i}]: node {} is in velocity groups \"{}\" and \"{}\" with different velocities (or curves)",
                                m.node_id[n], scene.boundaries[j].group, b.group
                            ));
                        }
                    }
                    vel[n] = Some((*v, i));
                }
            }
            BoundaryKind::Symmetry => {
                let k = m
                    .surface_tags
                    .iter()
                    .position(|&t| t == groups.surfaces[&b.group]);
                let Some(normal) = k.and_then(|k| m.surface_normals[k]) else {
                    return Err(format!(
                        "{file}: boundary[{i}]: symmetry surface \"{}\" is not planar (its faces are not all parallel): a symmetry boundary must be a plane (or parallel planes)",
                        b.group
                    ));
                };
                nodes.iter().for_each(|&n| planes[n].push(normal));
            }
        }
    }
    let mut out = Vec::new();
    let mut curves = Vec::new();
    for n in 0..nn {
        if let Some((v, i)) = vel[n] {
            if fixed[n] && err.is_none() {
                err = Some(format!(
                    "{file}: boundary[{i}]: node {} at ({:.6e}, {:.6e}, {:.6e}) is in a velocity group (\"{}\") and a fixed group",
                    m.node_id[n], m.coords[n][0], m.coords[n][1], m.coords[n][2], scene.boundaries[i].group
                ));
            }
            for p in &planes[n] {
                let d = v[0] * p[0] + v[1] * p[1] + v[2] * p[2];
                let vm = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                if d.abs() > 1e-12 * vm.max(1e-300) && err.is_none() {
                    err = Some(format!(
                        "{file}: boundary[{i}]: node {} has prescribed velocity ({}, {}, {}) with a component along the normal of a symmetry plane through it",
                        m.node_id[n], v[0], v[1], v[2]
                    ));
                }
            }
            out.push((n as u32, Constraint::Velocity(v)));
            curves.push(scene.boundaries[i].curve.clone());
        } else if fixed[n] {
            out.push((n as u32, Constraint::Fixed));
            curves.push(None);
        } else if !planes[n].is_empty() {
            // Orthonormalise the plane normals (Gram-Schmidt); parallel planes add nothing.
            let mut basis: Vec<[f64; 3]> = Vec::new();
            for p in &planes[n] {
                let mut q = *p;
                for b in &basis {
                    let d = q[0] * b[0] + q[1] * b[1] + q[2] * b[2];
                    for c in 0..3 {
                        q[c] -= d * b[c];
                    }
                }
                let l = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
                if l > 1e-8 {
                    basis.push([q[0] / l, q[1] / l, q[2] / l]);
                }
            }
            out.push((n as u32, Constraint::Planes(basis)));
            curves.push(None);
        }
    }
    first_error(comm, err)?;
    Ok((out, curves))
}
