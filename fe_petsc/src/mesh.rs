//! Mesh load, METIS partition and DMPlex distribution, and the flat arrays the element loop uses.
//!
//! Rank 0 reads the gmsh file into a DMPlex (PETSc's reader), checks that every cell is a
//! hexahedron, marks the vertices of each physical surface, and partitions the cells' dual graph
//! with METIS; PETSc's shell partitioner applies that partition and `DMPlexDistribute` moves the
//! mesh (no overlap). After distribution everything the time loop needs is extracted once into
//! contiguous arrays ([`LocalMesh`]); the DM stays alive only for the ghost exchange
//! ([`NodeExchange`]).
use crate::objects::{Dm, Section, StarForest, Vector};
use crate::petsc::{Petsc, PetscError};
use crate::petsc_call;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use petsc_sys as sys;
use std::ffi::CString;
use std::path::Path;

/// Errors while reading or distributing a mesh.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// PETSc failed.
    #[error("{0}")]
    Petsc(#[from] PetscError),
    /// The mesh is not what the element supports, or cannot be read.
    #[error("{0}")]
    Invalid(String),
}

/// gmsh/VTK hexahedron node order from PETSc's closure order of a hex's vertices.
///
/// PETSc's reference hex lists the bottom face clockwise seen from outside (inward normal) and
/// the top face counter-clockwise: (-1,-1,-1) (-1,1,-1) (1,1,-1) (1,-1,-1) then (-1,-1,1)
/// (1,-1,1) (1,1,1) (-1,1,1). gmsh/VTK lists both faces counter-clockwise seen from +z.
const PETSC_TO_VTK_HEX: [usize; 8] = [0, 3, 2, 1, 4, 5, 6, 7];

/// Most physical surfaces a mesh may have (one bit each in a node's surface mask).
pub const MAX_SURFACES: usize = 31;

/// The part of the mesh one rank holds, as flat arrays (no PETSc objects).
#[derive(Debug, Clone, Default)]
pub struct LocalMesh {
    /// Reference coordinates of the local nodes (owned and ghost), m.
    pub coords: Vec<[f64; 3]>,
    /// Global id of each local node (the mesh's vertex number, 0-based, rank-independent).
    pub node_id: Vec<u64>,
    /// Whether this rank owns the node (each node has exactly one owner).
    pub owned: Vec<bool>,
    /// Bit `k` set when the node lies on physical surface `surface_tags[k]`.
    pub node_surfaces: Vec<u32>,
    /// gmsh tags of the physical surfaces, in bit order (the same on every rank).
    pub surface_tags: Vec<i32>,
    /// Unit normal of each physical surface (bit order) when all its faces are parallel
    /// (one plane, or parallel planes); `None` for a curved or bent surface.
    pub surface_normals: Vec<Option<[f64; 3]>>,
    /// Connectivity of the local elements, local node indices, gmsh/VTK hexahedron order.
    pub elems: Vec<[u32; 8]>,
    /// Global id of each local element (the mesh's cell number, 0-based, rank-independent).
    pub elem_id: Vec<u64>,
    /// gmsh tag of the physical volume each element belongs to (-1: none).
    pub elem_block: Vec<i32>,
    /// Nodes in the whole mesh.
    pub global_nodes: u64,
    /// Elements in the whole mesh.
    pub global_elems: u64,
}

/// The distributed mesh: its flat arrays and the DM that keeps ghost nodes in sync.
pub struct DistributedMesh {
    /// The arrays the element loop uses.
    pub local: LocalMesh,
    /// Sums nodal contributions over the ranks sharing a node.
    pub exchange: NodeExchange,
}

/// Ghost exchange for 3 values per node, on PETSc's DM: local-to-global ADD (assembly), then
/// global-to-local INSERT (refresh), over the caller's own flat array (no copy: `VecPlaceArray`).
pub struct NodeExchange {
    local: Vector,
    global: Vector,
    _section: Section,
    dm: Dm,
    n_local_nodes: usize,
    /// Bytes this rank sent in ghost exchanges so far (estimate: 2 x 24 bytes per ghost node).
    pub bytes_sent: u64,
    ghosts: usize,
}

impl NodeExchange {
    /// Sums each node's 3 values over every rank that holds the node and writes the sum back to
    /// every copy. `data` is `3 * n_local_nodes` long, node-major.
    pub fn sum_shared(&mut self, data: &mut [f64]) -> Result<(), PetscError> {
        assert_eq!(data.len(), 3 * self.n_local_nodes);
        petsc_call!(VecPlaceArray(self.local.0, data.as_ptr()))?;
        petsc_call!(VecZeroEntries(self.global.0))?;
        petsc_call!(DMLocalToGlobal(
            self.dm.0,
            self.local.0,
            sys::ADD_VALUES,
            self.global.0
        ))?;
        petsc_call!(DMGlobalToLocal(
            self.dm.0,
            self.global.0,
            sys::INSERT_VALUES,
            self.local.0
        ))?;
        petsc_call!(VecResetArray(self.local.0))?;
        self.bytes_sent += (2 * 24 * self.ghosts) as u64;
        Ok(())
    }
}

fn cstr(s: &str) -> CString {
    CString::new(s).unwrap()
}

/// Broadcasts rank 0's error (if any) so that every rank returns the same error together.
fn agree_on_error(comm: &SimpleCommunicator, err: Option<String>) -> Result<(), MeshError> {
    let mut len = err.as_ref().map(|e| e.len() as u64).unwrap_or(0);
    let root = comm.process_at_rank(0);
    root.broadcast_into(&mut len);
    if len == 0 {
        return Ok(());
    }
    let mut buf = err
        .map(|e| e.into_bytes())
        .unwrap_or_else(|| vec![0u8; len as usize]);
    root.broadcast_into(&mut buf[..]);
    Err(MeshError::Invalid(
        String::from_utf8_lossy(&buf).into_owned(),
    ))
}

impl DistributedMesh {
    /// Reads `path` (gmsh .msh) on rank 0, partitions it with METIS (unless the user chose a
    /// PETSc partitioner with `-petscpartitioner_type`), distributes it and extracts the flat
    /// arrays. Collective.
    pub fn load(comm: &SimpleCommunicator, path: &Path) -> Result<Self, MeshError> {
        let rank = comm.rank();
        let size = comm.size();
        let cpath = cstr(&path.to_string_lossy());
        let mut dm = Dm(std::ptr::null_mut());
        // SAFETY: FFI; PETSc reads the file on rank 0 of the communicator.
        let code = unsafe {
            sys::DMPlexCreateGmshFromFile(comm.as_raw(), cpath.as_ptr(), sys::PETSC_TRUE, &mut dm.0)
        };
        crate::petsc::check(code, "DMPlexCreateGmshFromFile").map_err(|e| {
            MeshError::Invalid(format!(
                "cannot read mesh {}: {}",
                path.display(),
                e.message
            ))
        })?;
        let cell_sets = cstr("Cell Sets");
        let face_sets = cstr("Face Sets");

        // --- rank 0: checks, surface masks, original numbers, METIS partition -------------
        let (p0, p1) = dm.chart()?;
        let (c0, c1) = dm.height_stratum(0)?;
        let (v0, v1) = dm.depth_stratum(0)?;
        let mut err = None;
        let mut surface_tags: Vec<i32> = Vec::new();
        let mut surface_normals: Vec<Option<[f64; 3]>> = Vec::new();
        let npts = (p1 - p0) as usize;
        let mut orig = vec![-1i32; npts];
        let mut mask = vec![0i32; npts];
        let mut partition: Option<Vec<i32>> = None;
        if rank == 0 {
            let mut dim = 0;
            petsc_call!(DMGetDimension(dm.0, &mut dim))?;
            if c1 == c0 {
                err = Some(format!("mesh {} has no cells", path.display()));
            } else if dim != 3 {
                err = Some(format!(
                    "mesh {} is {}-dimensional: a 3D hexahedral mesh is needed",
                    path.display(),
                    dim
                ));
            }
            if err.is_none() {
                let (mut nhex, mut other) = (0usize, 0usize);
                let mut first_other = None;
                for c in c0..c1 {
                    let mut t: sys::DMPolytopeType = 0;
                    petsc_call!(DMPlexGetCellType(dm.0, c, &mut t))?;
                    if t == sys::DM_POLYTOPE_HEXAHEDRON {
                        nhex += 1;
                    } else {
                        other += 1;
                        first_other.get_or_insert((c - c0, t));
                    }
                }
                if other > 0 {
                    let (c, t) = first_other.unwrap();
                    let kind = match t {
                        sys::DM_POLYTOPE_TETRAHEDRON => "tetrahedron",
                        _ => "non-hexahedral cell",
                    };
                    err = Some(format!(
                        "mesh {}: element {} is a {} ({} hexahedra, {} other cells): only 8-node hexahedral meshes are supported for now (mesh with Transfinite + Recombine in gmsh)",
                        path.display(), c, kind, nhex, other
                    ));
                }
            }
            if err.is_none() {
                surface_tags = dm.label_values(&face_sets)?;
                surface_tags.sort_unstable();
                if surface_tags.len() > MAX_SURFACES {
                    err = Some(format!(
                        "mesh {} has {} physical surfaces; at most {} are supported",
                        path.display(),
                        surface_tags.len(),
                        MAX_SURFACES
                    ));
                }
            }
            if err.is_none() {
                let mut cl = Vec::new();
                let coords = vertex_coords(&dm, v0, v1)?;
                for (bit, &tag) in surface_tags.iter().enumerate() {
                    let mut normal: Option<[f64; 3]> = None;
                    let mut planar = true;
                    for f in dm.label_stratum(&face_sets, tag)? {
                        dm.closure(f, &mut cl)?;
                        let mut fv = Vec::with_capacity(4);
                        for &q in &cl {
                            if q >= v0 && q < v1 {
                                mask[(q - p0) as usize] |= 1 << bit;
                                fv.push(coords[(q - v0) as usize]);
                            }
                        }
                        if let Some(n) = face_normal(&fv) {
                            if n[0].is_nan() {
                                planar = false;
                                continue;
                            }
                            match normal {
                                None => normal = Some(n),
                                Some(m) => {
                                    let d = n[0] * m[0] + n[1] * m[1] + n[2] * m[2];
                                    if d.abs() < 1.0 - PARALLEL_TOL {
                                        planar = false;
                                    }
                                }
                            }
                        }
                    }
                    surface_normals.push(if planar { normal } else { None });
                }
                for c in c0..c1 {
                    orig[(c - p0) as usize] = c - c0;
                }
                for v in v0..v1 {
                    orig[(v - p0) as usize] = v - v0;
                }
                if size > 1 && !Petsc::has_option("-petscpartitioner_type") {
                    partition =
                        Some(metis_partition(&dm, c0, c1, size).map_err(MeshError::Invalid)?);
                }
            }
        }
        agree_on_error(comm, err)?;
        // Every rank learns the surface tags (bit order).
        let mut ntags = surface_tags.len() as u64;
        comm.process_at_rank(0).broadcast_into(&mut ntags);
        surface_tags.resize(ntags as usize, 0);
        if ntags > 0 {
            comm.process_at_rank(0)
                .broadcast_into(&mut surface_tags[..]);
        }
        // ... and the surface normals: [flag, nx, ny, nz] per surface.
        let mut nbuf: Vec<f64> = (0..ntags as usize)
            .map(|k| match surface_normals.get(k).copied().flatten() {
                Some(n) => [1.0, n[0], n[1], n[2]],
                None => [0.0; 4],
            })
            .flat_map(|a| a.into_iter())
            .collect();
        if ntags > 0 {
            comm.process_at_rank(0).broadcast_into(&mut nbuf[..]);
        }
        let surface_normals: Vec<Option<[f64; 3]>> = nbuf
            .chunks(4)
            .map(|c| (c[0] > 0.5).then_some([c[1], c[2], c[3]]))
            .collect();
        let mut totals = [(c1 - c0) as u64, (v1 - v0) as u64];
        comm.process_at_rank(0).broadcast_into(&mut totals[..]);

        // --- distribution ----------------------------------------------------------------
        let mut part = std::ptr::null_mut();
        petsc_call!(DMPlexGetPartitioner(dm.0, &mut part))?;
        if let Some(p) = &partition {
            let nparts = size as usize;
            let mut sizes = vec![0i32; nparts];
            for &r in p {
                sizes[r as usize] += 1;
            }
            let mut points: Vec<i32> = Vec::with_capacity(p.len());
            for r in 0..nparts as i32 {
                points.extend(
                    p.iter()
                        .enumerate()
                        .filter(|(_, &q)| q == r)
                        .map(|(c, _)| c0 + c as i32),
                );
            }
            let shell = cstr("shell");
            petsc_call!(PetscPartitionerSetType(part, shell.as_ptr()))?;
            petsc_call!(PetscPartitionerShellSetPartition(
                part,
                size,
                sizes.as_ptr(),
                points.as_ptr()
            ))?;
        } else if rank != 0 && size > 1 && !Petsc::has_option("-petscpartitioner_type") {
            // Other ranks hold no cells; the shell partitioner must be set everywhere.
            let shell = cstr("shell");
            petsc_call!(PetscPartitionerSetType(part, shell.as_ptr()))?;
            let sizes = vec![0i32; size as usize];
            petsc_call!(PetscPartitionerShellSetPartition(
                part,
                size,
                sizes.as_ptr(),
                std::ptr::null()
            ))?;
        } else {
            petsc_call!(PetscPartitionerSetFromOptions(part))?;
        }
        let mut sf = StarForest(std::ptr::null_mut());
        let mut dist = Dm(std::ptr::null_mut());
        if size > 1 {
            petsc_call!(DMPlexDistribute(dm.0, 0, &mut sf.0, &mut dist.0))?;
        }
        let (dm, orig, mask) = if dist.0.is_null() {
            (dm, orig, mask)
        } else {
            // Carry the original numbers and surface masks from rank 0's points to the new ones.
            let (q0, q1) = dist.chart()?;
            let n = (q1 - q0) as usize;
            let mut o = vec![0i32; n];
            let mut m = vec![0i32; n];
            // Leaves start at zero and receive root + 0 (each leaf has exactly one root): a
            // broadcast without MPI_REPLACE, which mpi-sys does not export.
            for (root, leaf) in [(&orig, &mut o), (&mask, &mut m)] {
                unsafe {
                    crate::petsc::check(
                        sys::PetscSFBcastBegin(
                            sf.0,
                            mpi_sys::RSMPI_INT32_T,
                            root.as_ptr() as *const _,
                            leaf.as_mut_ptr() as *mut _,
                            mpi_sys::RSMPI_SUM,
                        ),
                        "PetscSFBcastBegin",
                    )?;
                    crate::petsc::check(
                        sys::PetscSFBcastEnd(
                            sf.0,
                            mpi_sys::RSMPI_INT32_T,
                            root.as_ptr() as *const _,
                            leaf.as_mut_ptr() as *mut _,
                            mpi_sys::RSMPI_SUM,
                        ),
                        "PetscSFBcastEnd",
                    )?;
                }
            }
            drop(dm);
            (dist, o, m)
        };
        drop(sf);

        // --- flat arrays -------------------------------------------------------------------
        let (p0, _) = dm.chart()?;
        let (c0, c1) = dm.height_stratum(0)?;
        let (v0, v1) = dm.depth_stratum(0)?;
        let nv = (v1 - v0) as usize;
        let mut local = LocalMesh {
            surface_tags,
            surface_normals,
            global_elems: totals[0],
            global_nodes: totals[1],
            ..Default::default()
        };
        let mut cl = Vec::new();
        for c in c0..c1 {
            dm.closure(c, &mut cl)?;
            let verts: Vec<i32> = cl.iter().copied().filter(|&q| q >= v0 && q < v1).collect();
            if verts.len() != 8 {
                return Err(MeshError::Invalid(format!(
                    "element {} has {} vertices, expected 8",
                    orig[(c - p0) as usize],
                    verts.len()
                )));
            }
            let mut conn = [0u32; 8];
            for (k, &j) in PETSC_TO_VTK_HEX.iter().enumerate() {
                conn[k] = (verts[j] - v0) as u32;
            }
            local.elems.push(conn);
            local.elem_id.push(orig[(c - p0) as usize] as u64);
            local.elem_block.push(dm.label_value(&cell_sets, c)?);
        }
        local.node_id = (v0..v1).map(|v| orig[(v - p0) as usize] as u64).collect();
        local.node_surfaces = (v0..v1).map(|v| mask[(v - p0) as usize] as u32).collect();

        // Coordinates of every local vertex.
        local.coords = vertex_coords(&dm, v0, v1)?;

        // Section with 3 dofs per vertex: the layout of nodal vectors.
        let mut sec = Section(std::ptr::null_mut());
        petsc_call!(PetscSectionCreate(comm.as_raw(), &mut sec.0))?;
        let (q0, q1) = dm.chart()?;
        petsc_call!(PetscSectionSetChart(sec.0, q0, q1))?;
        for v in v0..v1 {
            petsc_call!(PetscSectionSetDof(sec.0, v, 3))?;
        }
        petsc_call!(PetscSectionSetUp(sec.0))?;
        petsc_call!(DMSetLocalSection(dm.0, sec.0))?;
        for v in v0..v1 {
            let mut off = 0;
            petsc_call!(PetscSectionGetOffset(sec.0, v, &mut off))?;
            if off != 3 * (v - v0) {
                return Err(MeshError::Invalid(
                    "unexpected local section layout (vertex offsets not contiguous)".into(),
                ));
            }
        }
        let mut gsec: sys::PetscSection = std::ptr::null_mut();
        petsc_call!(DMGetGlobalSection(dm.0, &mut gsec))?;
        local.owned = Vec::with_capacity(nv);
        for v in v0..v1 {
            let mut off = 0;
            petsc_call!(PetscSectionGetOffset(gsec, v, &mut off))?;
            local.owned.push(off >= 0);
        }
        let mut lvec = Vector(std::ptr::null_mut());
        let mut gvec = Vector(std::ptr::null_mut());
        petsc_call!(DMCreateLocalVector(dm.0, &mut lvec.0))?;
        petsc_call!(DMCreateGlobalVector(dm.0, &mut gvec.0))?;
        let ghosts = local.owned.iter().filter(|o| !**o).count();
        let exchange = NodeExchange {
            local: lvec,
            global: gvec,
            _section: sec,
            dm,
            n_local_nodes: nv,
            bytes_sent: 0,
            ghosts,
        };
        Ok(DistributedMesh { local, exchange })
    }
}

/// Two face normals closer than this (1 - |cos|) count as parallel.
const PARALLEL_TOL: f64 = 1e-8;

/// Coordinates of the vertices v0..v1.
fn vertex_coords(dm: &Dm, v0: i32, v1: i32) -> Result<Vec<[f64; 3]>, PetscError> {
    let mut cvec: sys::Vec = std::ptr::null_mut();
    petsc_call!(DMGetCoordinatesLocal(dm.0, &mut cvec))?;
    let mut csec: sys::PetscSection = std::ptr::null_mut();
    petsc_call!(DMGetCoordinateSection(dm.0, &mut csec))?;
    let mut arr: *const f64 = std::ptr::null();
    petsc_call!(VecGetArrayRead(cvec, &mut arr))?;
    let mut len = 0;
    petsc_call!(VecGetLocalSize(cvec, &mut len))?;
    let carr: &[f64] = if len > 0 {
        // SAFETY: PETSc's local coordinate array of `len` values, valid until restored.
        unsafe { std::slice::from_raw_parts(arr, len as usize) }
    } else {
        &[]
    };
    let mut out = Vec::with_capacity((v1 - v0).max(0) as usize);
    for v in v0..v1 {
        let mut off = 0;
        petsc_call!(PetscSectionGetOffset(csec, v, &mut off))?;
        let o = off as usize;
        out.push([carr[o], carr[o + 1], carr[o + 2]]);
    }
    petsc_call!(VecRestoreArrayRead(cvec, &mut arr))?;
    Ok(out)
}

/// Unit normal of a (quadrilateral) face from the cross product of its diagonals' span, or
/// None for a degenerate face. Any vertex order: the normal's sign is irrelevant here.
fn face_normal(v: &[[f64; 3]]) -> Option<[f64; 3]> {
    if v.len() < 3 {
        return None;
    }
    // Newell's method over the polygon (the vertex order of a closure may not be cyclic, so use
    // the largest cross product among vertex triples instead).
    let mut best = [0.0; 3];
    let mut bl = 0.0;
    for i in 1..v.len() {
        for j in (i + 1)..v.len() {
            let a = [v[i][0] - v[0][0], v[i][1] - v[0][1], v[i][2] - v[0][2]];
            let b = [v[j][0] - v[0][0], v[j][1] - v[0][1], v[j][2] - v[0][2]];
            let c = [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ];
            let l = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
            if l > bl {
                bl = l;
                best = c;
            }
        }
    }
    if bl <= 0.0 {
        return None;
    }
    let l = bl.sqrt();
    // A warped face: its other vertices must lie in the plane too.
    let n = [best[0] / l, best[1] / l, best[2] / l];
    let size = l.sqrt();
    for p in v {
        let d = (p[0] - v[0][0]) * n[0] + (p[1] - v[0][1]) * n[1] + (p[2] - v[0][2]) * n[2];
        if d.abs() > 1e-8 * size {
            // Warped: no single normal (NaN marks it for the caller).
            return Some([f64::NAN; 3]);
        }
    }
    Some(n)
}

/// METIS k-way partition of the cells' dual graph (cells sharing a face), on rank 0.
fn metis_partition(dm: &Dm, c0: i32, c1: i32, nparts: i32) -> Result<Vec<i32>, String> {
    let nc = (c1 - c0) as usize;
    let mut xadj: Vec<i32> = Vec::with_capacity(nc + 1);
    let mut adj: Vec<i32> = Vec::with_capacity(6 * nc);
    xadj.push(0);
    for c in c0..c1 {
        for f in dm.cone(c).map_err(|e| e.to_string())? {
            for n in dm.support(f).map_err(|e| e.to_string())? {
                if n != c && n >= c0 && n < c1 {
                    adj.push(n - c0);
                }
            }
        }
        xadj.push(adj.len() as i32);
    }
    let mut part = vec![0i32; nc];
    if nparts as usize >= nc {
        // Fewer cells than ranks: METIS refuses; give one cell to each of the first ranks.
        for (c, p) in part.iter_mut().enumerate() {
            *p = c as i32;
        }
        return Ok(part);
    }
    metis::Graph::new(1, nparts, &xadj, &adj)
        .map_err(|e| format!("METIS: {e:?}"))?
        .part_kway(&mut part)
        .map_err(|e| format!("METIS partition failed: {e:?}"))?;
    Ok(part)
}
