//! The FE side of contact: which mesh faces and nodes take part, and each step's records.
//!
//! Set-up (once): every rank sends its elements (global ids of the element and its 8 nodes) and
//! its owned nodes' surface bits to rank 0, which finds the boundary faces of the whole mesh and
//! the bodies (the `contact` crate), keeps the faces of the scene's `[contact] surfaces` (a
//! boundary face all four of whose nodes lie on one of the named physical surfaces; every
//! boundary face for `"exterior"`), and sends each face to the rank of its element and each
//! contact node's body to the node's owner; the master bodies of a one-pass search (`[contact]
//! passes = 1`: the bodies with an element in a `master` volume) go to every rank. Each step the
//! FE rank then hands the contact stage its owned contact nodes and its faces with their nodes'
//! records (flagged `contact::FLAG_MASTER` on a master body), and at a rebuild each face goes
//! to the contact owner of its first node (`faces_to_owners`); on a kept decomposition the
//! nodes' records go straight to the boxes holding them (`send_mesh_records`).
//!
//! Where a material fails, the faces inside the mesh that a failed element opens are found at
//! set-up too, and every node of an element that may fail is a contact node; each step lends
//! only the active faces ([`openings`]).
pub mod openings;

use super::is_particle;
use crate::kernels::comm::CommPlan;
use crate::kernels::rcb::CutTree;
use crate::stages::contact::{LentSurfaces, SurfaceFigures};
use bytemuck::{Pod, Zeroable};
use contact::{ContactNodes, FaceRecord, NodeRecord};
use fe_petsc::explicit::ExplicitFe;
use fe_petsc::mesh::LocalMesh;
use mpi::datatype::PartitionMut;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use openings::Openings;
use std::collections::HashMap;
use std::rc::Rc;

/// A face with the records of its four nodes: what the FE owners send the contact stage.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct FullFace {
    /// The face.
    pub face: FaceRecord,
    /// Its corner nodes, in the face's order.
    pub nodes: [NodeRecord; 4],
}

/// This rank's part of the contact surfaces.
#[derive(Debug, Clone, Default)]
pub struct FeContact {
    /// Faces of this rank's elements: the record and the local indices of its nodes.
    pub faces: Vec<(FaceRecord, [u32; 4])>,
    /// Owned contact nodes: local index and body.
    pub nodes: Vec<(u32, u32)>,
    /// Body of every local node in a face (for face-node records), by local index.
    body_of: HashMap<u32, u32>,
    /// Faces over all ranks.
    pub global_faces: u64,
    /// Bodies in the mesh.
    pub n_bodies: u32,
    /// Bodies with a contact face or an element that may fail (every rank the same).
    pub bodies_in_contact: u32,
    /// Whether each body is a master of the one-pass search (all false with two passes).
    pub master_body: Vec<bool>,
    /// Each body's block (index in `block_tags` of `build`: the scene's `[[block]]` order):
    /// the first block in that order among its elements' (contact_forces.csv).
    pub body_block: Vec<u32>,
    /// Whether each block has a contact face (its pairs are columns of contact_forces.csv).
    pub block_in_contact: Vec<bool>,
    /// Which of `faces` are active after the failures so far (all where nothing fails).
    pub openings: Openings,
}

impl FeContact {
    /// What the contact stage is told of these surfaces when it starts.
    pub fn lent(&self) -> LentSurfaces {
        LentSurfaces {
            figures: SurfaceFigures {
                nodes: self.nodes.len(),
                global_faces: self.global_faces,
                n_bodies: self.n_bodies,
                masters: self.master_body.iter().filter(|&&m| m).count(),
            },
            body_block: self.body_block.clone(),
            block_in_contact: self.block_in_contact.clone(),
        }
    }
}

fn gatherv_u64(comm: &SimpleCommunicator, mine: &[u64]) -> (Vec<u64>, Vec<i32>, Vec<i32>) {
    let root = comm.process_at_rank(0);
    let n = mine.len() as i32;
    if comm.rank() == 0 {
        let mut counts = vec![0i32; comm.size() as usize];
        root.gather_into_root(&n, &mut counts[..]);
        let displs: Vec<i32> = counts
            .iter()
            .scan(0, |s, &c| {
                let d = *s;
                *s += c;
                Some(d)
            })
            .collect();
        let mut all = vec![0u64; counts.iter().sum::<i32>() as usize];
        {
            let mut part = PartitionMut::new(&mut all[..], &counts[..], &displs[..]);
            root.gather_varcount_into_root(mine, &mut part);
        }
        (all, counts, displs)
    } else {
        root.gather_into(&n);
        root.gather_varcount_into(mine);
        (Vec::new(), Vec::new(), Vec::new())
    }
}

fn scatterv_u64(comm: &SimpleCommunicator, per_rank: Vec<Vec<u64>>) -> Vec<u64> {
    let root = comm.process_at_rank(0);
    let mut n = 0i32;
    if comm.rank() == 0 {
        let counts: Vec<i32> = per_rank.iter().map(|v| v.len() as i32).collect();
        root.scatter_into_root(&counts[..], &mut n);
        let displs: Vec<i32> = counts
            .iter()
            .scan(0, |s, &c| {
                let d = *s;
                *s += c;
                Some(d)
            })
            .collect();
        let flat: Vec<u64> = per_rank.into_iter().flatten().collect();
        let mut out = vec![0u64; n as usize];
        let part = mpi::datatype::Partition::new(&flat[..], &counts[..], &displs[..]);
        root.scatter_varcount_into_root(&part, &mut out[..]);
        out
    } else {
        root.scatter_into(&mut n);
        let mut out = vec![0u64; n as usize];
        root.scatter_varcount_into(&mut out[..]);
        out
    }
}

/// What [`FeContact::build`] gathers from each rank: its elements (element gid, 8 node gids),
/// its owned nodes (gid, surface bits), each element's flag of a master volume and block
/// (the index in `block_tags`; `block_tags.len()` for none), and each element's flag of a
/// material that may fail (`can_fail`, per hexahedron; a native tetrahedron does not fail).
fn local_inputs(
    mesh: &LocalMesh,
    master_volumes: &[i32],
    block_tags: &[i32],
    can_fail: &[bool],
) -> [Vec<u64>; 5] {
    // Native tetrahedra as collapsed hexahedra (a, b, c, c, d, d, d, d): their triangles are
    // the faces with a repeated corner (`contact::face_key`).
    let tets = mesh
        .tets
        .iter()
        .map(|&[a, b, c, d]| [a, b, c, c, d, d, d, d]);
    let elems: Vec<u64> = mesh
        .elems
        .iter()
        .copied()
        .chain(tets)
        .zip(mesh.elem_id.iter().chain(&mesh.tet_id))
        .flat_map(|(c, &id)| std::iter::once(id).chain(c.map(|n| mesh.node_id[n as usize])))
        .collect();
    let nodes: Vec<u64> = (0..mesh.node_id.len())
        .filter(|&n| mesh.owned[n])
        .flat_map(|n| [mesh.node_id[n], mesh.node_surfaces[n] as u64])
        .collect();
    let in_master: Vec<u64> = mesh
        .elem_block
        .iter()
        .chain(&mesh.tet_block)
        .map(|t| master_volumes.contains(t) as u64)
        .collect();
    let nb = block_tags.len();
    let in_block: Vec<u64> = mesh
        .elem_block
        .iter()
        .chain(&mesh.tet_block)
        .map(|t| block_tags.iter().position(|b| b == t).unwrap_or(nb) as u64)
        .collect();
    let fails: Vec<u64> = (0..mesh.elems.len() + mesh.tets.len())
        .map(|e| can_fail.get(e).copied().unwrap_or(false) as u64)
        .collect();
    [elems, nodes, in_master, in_block, fails]
}

/// What rank 0 finds of the whole mesh's contact surfaces ([`root_surfaces`]).
#[derive(Default)]
struct RootSurfaces {
    /// For each rank: its faces (gid, element gid, side, 4 node gids, body, the gid of the
    /// element that opens it or the element's own for a boundary face), a `u64::MAX` marker,
    /// then its contact nodes (gid, body).
    per_rank: Vec<Vec<u64>>,
    /// Bodies in the mesh.
    n_bodies: u32,
    /// Each body's master flag (0 or 1).
    master_body: Vec<u64>,
    /// Faces kept.
    global_faces: u64,
    /// Each body's block (the first in scene order among its elements').
    body_block: Vec<u64>,
    /// Each block's flag of a contact face (0 or 1).
    block_in_contact: Vec<u64>,
    /// Bodies with a contact face or a failing element (whose faces may open).
    bodies_in_contact: u64,
}

/// On rank 0: the boundary faces and bodies of the whole mesh (elements `all_e` gathered from
/// `p` ranks in `counts_e`, owned nodes `all_n` in `counts_n`, each element's master flag,
/// block and flag of a material that may fail), the faces kept (all four nodes on a surface of
/// `surface_bits`; every boundary face for `None`) and the faces failing elements may open
/// ([`openings`]), numbered by (element gid, side), and what each rank gets.
fn root_surfaces(
    p: usize,
    (all_e, counts_e): (&[u64], &[i32]),
    (all_n, counts_n): (&[u64], &[i32]),
    (all_master, all_block, all_fail): (&[u64], &[u64], &[u64]),
    (surface_bits, nb): (Option<u32>, usize),
) -> RootSurfaces {
    // Element k of the gathered list came from rank elem_rank[k].
    let mut elem_rank = Vec::new();
    for (r, &c) in counts_e.iter().enumerate() {
        elem_rank.extend(std::iter::repeat_n(r, c as usize / 9));
    }
    // In element gid order, so that bodies (numbered by their first element) do not
    // depend on the rank count.
    let mut order: Vec<usize> = (0..elem_rank.len()).collect();
    order.sort_unstable_by_key(|&k| all_e[9 * k]);
    let elem_rank: Vec<usize> = order.iter().map(|&k| elem_rank[k]).collect();
    let hexes: Vec<[u64; 8]> = order
        .iter()
        .map(|&k| std::array::from_fn(|j| all_e[9 * k + 1 + j]))
        .collect();
    let elem_gid: Vec<u64> = order.iter().map(|&k| all_e[9 * k]).collect();
    let mut bits: HashMap<u64, u32> = HashMap::new();
    let mut node_rank: HashMap<u64, usize> = HashMap::new();
    let mut off = 0;
    for (r, &c) in counts_n.iter().enumerate() {
        for pair in all_n[off..off + c as usize].chunks(2) {
            bits.insert(pair[0], pair[1] as u32);
            node_rank.insert(pair[0], r);
        }
        off += c as usize;
    }
    let surf = contact::surfaces(&hexes, |_| true);
    let n_bodies = surf.n_bodies;
    let mut master_body = vec![0u64; n_bodies as usize];
    let mut body_block = vec![nb as u64; n_bodies as usize];
    for (e, &k) in order.iter().enumerate() {
        let body = surf.element_body[e] as usize;
        master_body[body] |= all_master[k];
        body_block[body] = body_block[body].min(all_block[k]);
    }
    // Keep a face when all four nodes share a named surface bit.
    let mut kept = Vec::new();
    for f in &surf.faces {
        let keep = match surface_bits {
            None => true,
            Some(b) => {
                let common = f
                    .nodes
                    .iter()
                    .fold(u32::MAX, |a, n| a & bits.get(n).copied().unwrap_or(0));
                common & b != 0
            }
        };
        if keep {
            // A boundary face: its element is its own opener.
            kept.push((*f, f.element));
        }
    }
    // The faces a failing neighbour opens, and every node of a failing element.
    let fail: Vec<bool> = order.iter().map(|&k| all_fail[k] != 0).collect();
    kept.extend(openings::opening_faces(&hexes, &fail, &surf.element_body));
    // Deterministic face gids: by (element gid, side), independent of the rank count.
    kept.sort_by_key(|(f, _)| (elem_gid[f.element], f.side));
    let mut in_contact: Vec<u32> = kept.iter().map(|(f, _)| f.body).collect();
    in_contact.extend(
        (0..hexes.len())
            .filter(|&e| fail[e])
            .map(|e| surf.element_body[e]),
    );
    in_contact.sort_unstable();
    in_contact.dedup();
    let mut block_in_contact = vec![0u64; nb];
    for (f, _) in &kept {
        let b = all_block[order[f.element]] as usize;
        if b < nb {
            block_in_contact[b] = 1;
        }
    }
    // Per rank: faces (gid, elem gid, side, 4 node gids, body) then contact nodes of
    // that rank (gid, body), after a marker.
    let mut per_rank = vec![Vec::new(); p];
    let mut node_body: HashMap<u64, u32> = HashMap::new();
    for (k, (f, opener)) in kept.iter().enumerate() {
        let r = elem_rank[f.element];
        per_rank[r].extend([k as u64, elem_gid[f.element], f.side as u64]);
        per_rank[r].extend(f.nodes);
        per_rank[r].extend([f.body as u64, elem_gid[*opener]]);
        for n in f.nodes {
            node_body.insert(n, f.body);
        }
    }
    for e in (0..hexes.len()).filter(|&e| fail[e]) {
        for n in hexes[e] {
            node_body.insert(n, surf.element_body[e]);
        }
    }
    let mut cn: Vec<(u64, u32)> = node_body.into_iter().collect();
    cn.sort_unstable();
    for r in per_rank.iter_mut() {
        r.push(u64::MAX);
    }
    for (gid, body) in cn {
        let r = node_rank[&gid];
        per_rank[r].extend([gid, body as u64]);
    }
    RootSurfaces {
        per_rank,
        n_bodies,
        master_body,
        global_faces: kept.len() as u64,
        body_block,
        block_in_contact,
        bodies_in_contact: in_contact.len() as u64,
    }
}

impl FeContact {
    /// Finds the contact faces and nodes (collective). `surface_bits`: the bits (in
    /// `mesh.node_surfaces`) of the named surfaces; `None` for `"exterior"`. `master_volumes`:
    /// the gmsh tags of the physical volumes whose bodies are masters (`[contact] master`).
    ///
    /// `block_tags`: the gmsh tag of each scene block, in scene order (an element of another
    /// volume counts in no block). `can_fail`: whether each hexahedron's material may fail.
    pub fn build(
        comm: &SimpleCommunicator,
        mesh: &LocalMesh,
        surface_bits: Option<u32>,
        (master_volumes, block_tags): (&[i32], &[i32]),
        can_fail: &[bool],
    ) -> FeContact {
        let nb = block_tags.len();
        let [elems, nodes, in_master, in_block, fails] =
            local_inputs(mesh, master_volumes, block_tags, can_fail);
        let (all_block, _, _) = gatherv_u64(comm, &in_block);
        let (all_fail, _, _) = gatherv_u64(comm, &fails);
        let (all_e, counts_e, _) = gatherv_u64(comm, &elems);
        let (all_master, _, _) = gatherv_u64(comm, &in_master);
        let (all_n, counts_n, _) = gatherv_u64(comm, &nodes);
        let mut root = RootSurfaces {
            block_in_contact: vec![0u64; nb],
            ..RootSurfaces::default()
        };
        if comm.rank() == 0 {
            root = root_surfaces(
                comm.size() as usize,
                (&all_e, &counts_e),
                (&all_n, &counts_n),
                (&all_master, &all_block, &all_fail),
                (surface_bits, nb),
            );
        }
        let mine = scatterv_u64(comm, std::mem::take(&mut root.per_rank));
        let mut gf = [
            root.global_faces,
            root.n_bodies as u64,
            root.bodies_in_contact,
        ];
        comm.process_at_rank(0).broadcast_into(&mut gf[..]);
        root.master_body.resize(gf[1] as usize, 0);
        comm.process_at_rank(0)
            .broadcast_into(&mut root.master_body[..]);
        root.body_block.resize(gf[1] as usize, 0);
        comm.process_at_rank(0)
            .broadcast_into(&mut root.body_block[..]);
        comm.process_at_rank(0)
            .broadcast_into(&mut root.block_in_contact[..]);
        let out = FeContact {
            global_faces: gf[0],
            n_bodies: gf[1] as u32,
            bodies_in_contact: gf[2] as u32,
            master_body: root.master_body.iter().map(|&m| m != 0).collect(),
            body_block: root.body_block.iter().map(|&b| b as u32).collect(),
            block_in_contact: root.block_in_contact.iter().map(|&b| b != 0).collect(),
            ..Default::default()
        };
        out.with_mine(mesh, &mine)
    }

    /// This rank's faces and contact nodes from what rank 0 sent it (`mine`: faces as (gid,
    /// element gid, side, 4 node gids, body, opener's gid), a `u64::MAX` marker, then contact
    /// nodes as (gid, body)), in local indices of `mesh`.
    fn with_mine(mut self, mesh: &LocalMesh, mine: &[u64]) -> FeContact {
        let local: HashMap<u64, u32> = mesh
            .node_id
            .iter()
            .enumerate()
            .map(|(i, &g)| (g, i as u32))
            .collect();
        let split = mine
            .iter()
            .position(|&v| v == u64::MAX)
            .unwrap_or(mine.len());
        let mut elems = Vec::new();
        for c in mine[..split].chunks(9) {
            elems.push((c[1], c[8]));
            let node_gids = [c[3], c[4], c[5], c[6]];
            let loc = node_gids.map(|g| local[&g]);
            let body = c[7] as u32;
            for &l in &loc {
                self.body_of.insert(l, body);
            }
            self.faces.push((
                FaceRecord {
                    gid: c[0],
                    nodes: node_gids,
                    body,
                    reserved: 0,
                },
                loc,
            ));
        }
        self.openings = Openings::new(elems);
        for c in mine[split.saturating_add(1).min(mine.len())..].chunks(2) {
            let l = local[&c[0]];
            self.nodes.push((l, c[1] as u32));
            self.body_of.insert(l, c[1] as u32);
        }
        self
    }

    /// Node `n`'s record (gid 0) as a node of `body`.
    fn record(&self, fe: &ExplicitFe, n: u32, body: u32, infinite: &[bool]) -> NodeRecord {
        let i = n as usize;
        NodeRecord {
            gid: 0,
            body,
            flags: if self.master_body[body as usize] {
                contact::FLAG_MASTER
            } else {
                0
            },
            mass: if infinite[i] {
                f64::INFINITY
            } else {
                fe.mass[i]
            },
            radius: 0.0,
            x0: fe.x_start()[i],
            x1: fe.x[i],
            v: fe.start_velocity(i),
        }
    }

    /// The global id of each face's element, aligned with `faces`.
    pub fn face_element_ids(&self) -> Vec<u64> {
        self.openings.elems.iter().map(|&(e, _)| e).collect()
    }

    /// This step's records of the owned contact nodes, after `kick_drift`. `node_gid`: global
    /// id of each local node.
    pub fn node_records(&self, fe: &ExplicitFe, node_gid: &[u64]) -> Vec<NodeRecord> {
        let infinite = fe.fully_constrained();
        self.nodes
            .iter()
            .map(|&(n, body)| NodeRecord {
                gid: node_gid[n as usize],
                ..self.record(fe, n, body, &infinite)
            })
            .collect()
    }

    /// This step's active faces ([`Openings`]) with their nodes' records, after `kick_drift`.
    pub fn face_records(&self, fe: &ExplicitFe, node_gid: &[u64]) -> Vec<FullFace> {
        let infinite = fe.fully_constrained();
        self.faces
            .iter()
            .zip(&self.openings.active)
            .filter(|(_, &a)| a)
            .map(|((f, loc), _)| FullFace {
                face: *f,
                nodes: std::array::from_fn(|k| NodeRecord {
                    gid: node_gid[loc[k] as usize],
                    ..self.record(fe, loc[k], f.body, &infinite)
                }),
            })
            .collect()
    }

    /// [`FeContact::node_records`] and [`FeContact::face_records`].
    pub fn records(&self, fe: &ExplicitFe, node_gid: &[u64]) -> (Vec<NodeRecord>, Vec<FullFace>) {
        (
            self.node_records(fe, node_gid),
            self.face_records(fe, node_gid),
        )
    }

    /// Spreads the forces the contact stage returned (aligned with `records`' nodes) onto a
    /// per-local-node array.
    pub fn forces_on_nodes(&self, n_local: usize, force: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut out = vec![[0.0; 3]; n_local];
        for (k, &(n, _)) in self.nodes.iter().enumerate() {
            out[n as usize] = force[k];
        }
        out
    }
}

/// Step 3 of a rebuild: each face with its nodes to the contact owner of its first node in the
/// new cuts `tree` (collective). Returns the faces this rank now holds and the bytes it sent.
pub(crate) fn faces_to_owners(
    comm: &Rc<SimpleCommunicator>,
    tree: &CutTree,
    faces: &[FullFace],
) -> (Vec<FullFace>, u64) {
    let dest: Vec<i32> = faces
        .iter()
        .map(|f| tree.owner_of_item(&f.nodes[0].x1, f.nodes[0].gid))
        .collect();
    let mut plan = CommPlan::new_shared(comm, &dest);
    let my_faces = plan.exchange(faces);
    (my_faces, plan.bytes_sent)
}

/// Step 1 (and 3, 5-6) on a kept contact decomposition: the mesh nodes' records (`nodes`, the
/// records lent this step; particles skipped) straight to the boxes holding them along the
/// kept plan (`send_idx[k]`: the mesh input sent as the plan's item k; `recv_slot`: the box
/// slot of each record received, in arrival order), written in place into the kept box's
/// nodes `into` (collective). `send_buf` keeps the records in plan order (its memory reused).
/// Returns the input index of each mesh input and the bytes sent.
pub(crate) fn send_mesh_records(
    (plan, send_idx, recv_slot): (&mut CommPlan, &[u32], &[u32]),
    send_buf: &mut Vec<NodeRecord>,
    nodes: &[NodeRecord],
    into: &mut ContactNodes,
) -> (Vec<u32>, u64) {
    let fe_inputs: Vec<u32> = (0..nodes.len() as u32)
        .filter(|&i| !is_particle(&nodes[i as usize]))
        .collect();
    send_buf.clear();
    send_buf.extend(
        send_idx
            .iter()
            .map(|&k| nodes[fe_inputs[k as usize] as usize]),
    );
    let before = plan.bytes_sent;
    let got = plan.exchange(send_buf);
    let sent = plan.bytes_sent - before;
    for (r, &slot) in got.iter().zip(recv_slot) {
        into.set_motion(slot as usize, r);
    }
    (fe_inputs, sent)
}
