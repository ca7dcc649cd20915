//! Mesh load, METIS partition and DMPlex distribution, and the flat arrays the element loop uses.
//!
//! Rank 0 reads the gmsh file into a DMPlex (PETSc's reader), checks that every cell is a
//! hexahedron or a tetrahedron, marks the vertices of each physical surface, and partitions the
//! cells' dual graph with METIS; PETSc's shell partitioner applies that partition and
//! `DMPlexDistribute` moves the mesh (no overlap). After distribution everything the time loop
//! needs is extracted once into contiguous arrays ([`LocalMesh`]: the hexahedra and the
//! tetrahedra in arrays of their own); only the DM's star forest stays alive, for the ghost
//! exchange ([`NodeExchange`]).
use crate::objects::{Dm, Section, StarForest};
use crate::petsc::{Petsc, PetscError};
use crate::petsc_call;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use petsc_sys as sys;
use std::ffi::CString;
use std::path::Path;

mod exchange;
use exchange::*;

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

/// gmsh tetrahedron node order from PETSc's closure order of a tet's vertices.
///
/// PETSc's reference tetrahedron lists its first face clockwise seen from outside (inward
/// normal, as the hexahedron's bottom face): (-1,-1,-1) (-1,1,-1) (1,-1,-1) (-1,-1,1), so
/// det[x1-x0, x2-x0, x3-x0] < 0; gmsh's is (0,0,0) (1,0,0) (0,1,0) (0,0,1), positive. PETSc's
/// gmsh reader turns a file's tetrahedron into its own orientation by swapping the first two
/// vertices (as it swaps the hexahedron's 1 and 3, undone by [`PETSC_TO_VTK_HEX`]); swapping
/// them back gives the file's node order exactly (checked against the files, with the volumes'
/// sign, in tests/tet_mesh.rs).
const PETSC_TO_GMSH_TET: [usize; 4] = [1, 0, 2, 3];

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
    /// Connectivity of the local hexahedra, local node indices, gmsh/VTK hexahedron order
    /// (the `elem_*` arrays are the hexahedra's; the tetrahedra's are `tet*`).
    pub elems: Vec<[u32; 8]>,
    /// Global id of each local hexahedron (the mesh's cell number over all cells, 0-based,
    /// rank-independent).
    pub elem_id: Vec<u64>,
    /// gmsh tag of the physical volume each element belongs to (-1: none).
    pub elem_block: Vec<i32>,
    /// Each element's place in the canonical order (block, Morton key of its centroid on the
    /// whole mesh's box, global id), the same on every rank count: the local elements are in
    /// this order ([`crate::locality::order_elements`]).
    pub elem_key: Vec<[u64; 3]>,
    /// Connectivity of the local tetrahedra, local node indices, gmsh order (positive volume:
    /// det[x1-x0, x2-x0, x3-x0] > 0 for a valid element).
    pub tets: Vec<[u32; 4]>,
    /// Global id of each local tetrahedron: the mesh's cell number over all cells (0-based,
    /// rank-independent), the numbering `elem_id` takes from too, so the two never collide.
    pub tet_id: Vec<u64>,
    /// gmsh tag of the physical volume each tetrahedron belongs to (-1: none).
    pub tet_block: Vec<i32>,
    /// Each tetrahedron's place in the canonical order, as `elem_key` (block, Morton key of its
    /// centroid on the whole mesh's box of all cells' centroids, global id): the local
    /// tetrahedra are in this order.
    pub tet_key: Vec<[u64; 3]>,
    /// Nodes in the whole mesh.
    pub global_nodes: u64,
    /// Cells (elements) in the whole mesh, of both kinds: `global_hexes + global_tets`, and
    /// one more than the largest `elem_id` or `tet_id`. For a mesh of hexahedra alone, its
    /// hexahedra, as before tetrahedra were read.
    pub global_elems: u64,
    /// Hexahedra in the whole mesh.
    pub global_hexes: u64,
    /// Tetrahedra in the whole mesh.
    pub global_tets: u64,
    /// Whether this rank put its elements in a new order and renumbered its nodes for memory
    /// locality (`crate::locality`: only where the file's order is poor).
    pub reordered: [bool; 2],
}

/// The distributed mesh: its flat arrays and the DM that keeps ghost nodes in sync.
pub struct DistributedMesh {
    /// The arrays the element loop uses.
    pub local: LocalMesh,
    /// Sums nodal contributions over the ranks sharing a node.
    pub exchange: NodeExchange,
}

/// Ghost exchange for 3 values per node, on the star forest of PETSc's DM for a section of 3
/// dofs per vertex (its local-to-global map): a reduction with a sum into the owners' values
/// (what `DMLocalToGlobal` with `ADD_VALUES` does), then a broadcast back to every copy (what
/// `DMGlobalToLocal` with `INSERT_VALUES` does), over the caller's own flat array. Only the star
/// forest is kept: the DM, its sections and vectors are freed once the arrays are extracted
/// (measured: about 260 bytes per element of a 110,592-element block's peak memory).
pub struct NodeExchange {
    pub(crate) sf: StarForest,
    /// Three contiguous doubles, a node's values (committed; never freed: one small datatype,
    /// and the exchange may outlive MPI's own tear-down).
    pub(crate) unit: mpi_sys::MPI_Datatype,
    /// The owners' values (roots): 3 per owned node.
    pub(crate) roots: Vec<f64>,
    /// The leaves the star forest keeps (nodes more than one rank holds), local node indices.
    pub(crate) shared_leaves: Vec<u32>,
    /// The root (owner rank, root index) of each of `shared_leaves`.
    pub(crate) shared_remotes: Vec<sys::PetscSFNode>,
    /// The roots with leaves on other ranks.
    shared_roots: Vec<u32>,
    pub(crate) n_local_nodes: usize,
    /// Bytes this rank sent in ghost exchanges so far (estimate: 2 x 24 bytes per ghost node).
    pub bytes_sent: u64,
    ghosts: usize,
}

impl NodeExchange {
    /// Sums each node's 3 values over every rank that holds the node and writes the sum back to
    /// every copy. `data` is `3 * n_local_nodes` long, node-major.
    pub fn sum_shared(&mut self, data: &mut [f64]) -> Result<(), PetscError> {
        assert_eq!(data.len(), 3 * self.n_local_nodes);
        // Only the shared nodes take part (`shared_forest`): their roots are zeroed, the
        // leaves' values summed into them and sent back; every other node keeps its value.
        for &r in &self.shared_roots {
            self.roots[3 * r as usize..3 * r as usize + 3].fill(0.0);
        }
        let (leaves, roots) = (data.as_mut_ptr(), self.roots.as_mut_ptr());
        // SAFETY: reading MPI's predefined handle (a constant after MPI_Init).
        let (unit, sum) = (self.unit, unsafe { mpi_sys::RSMPI_SUM });
        // SAFETY: FFI on the section's star forest: `data` holds its n_local_nodes leaves and
        // `roots` its roots, three doubles each (checked when it was built), both alive
        // across Begin and End.
        unsafe {
            crate::petsc::check(
                sys::PetscSFReduceBegin(self.sf.0, unit, leaves as *const _, roots as *mut _, sum),
                "PetscSFReduceBegin",
            )?;
            crate::petsc::check(
                sys::PetscSFReduceEnd(self.sf.0, unit, leaves as *const _, roots as *mut _, sum),
                "PetscSFReduceEnd",
            )?;
        }
        // Every copy takes its owner's sum: leaves zeroed, then root + 0 (a broadcast without
        // MPI_REPLACE, which mpi-sys does not export; a -0.0 sum comes back as +0.0).
        for &l in &self.shared_leaves {
            data[3 * l as usize..3 * l as usize + 3].fill(0.0);
        }
        self.broadcast_roots(data)?;
        self.bytes_sent += (2 * 24 * self.ghosts) as u64;
        Ok(())
    }

    /// Adds each shared node's root value (the owner's, in `roots`) to every copy of the node
    /// in `data` (`3 * n_local_nodes` long, node-major): on copies the caller zeroed, the
    /// broadcast of the owner's value.
    pub(crate) fn broadcast_roots(&mut self, data: &mut [f64]) -> Result<(), PetscError> {
        assert_eq!(data.len(), 3 * self.n_local_nodes);
        let (leaves, roots) = (data.as_mut_ptr(), self.roots.as_ptr());
        // SAFETY: reading MPI's predefined handle (a constant after MPI_Init).
        let (unit, sum) = (self.unit, unsafe { mpi_sys::RSMPI_SUM });
        // SAFETY: FFI on the section's star forest: `data` holds its n_local_nodes leaves and
        // `roots` its roots, three doubles each, both alive across Begin and End.
        unsafe {
            crate::petsc::check(
                sys::PetscSFBcastBegin(self.sf.0, unit, roots as *const _, leaves as *mut _, sum),
                "PetscSFBcastBegin",
            )?;
            crate::petsc::check(
                sys::PetscSFBcastEnd(self.sf.0, unit, roots as *const _, leaves as *mut _, sum),
                "PetscSFBcastEnd",
            )?;
        }
        Ok(())
    }
}

fn cstr(s: &str) -> CString {
    CString::new(s).unwrap()
}

/// The agreement step on a mesh error: every rank returns the lowest failing rank's message.
fn agree(comm: &SimpleCommunicator, err: Option<String>) -> Result<(), MeshError> {
    crate::agree::first_error(comm, err).map_err(MeshError::Invalid)
}

/// What rank 0 learns from the whole mesh before it is distributed; the other ranks hold the
/// defaults until [`share_root_facts`].
#[derive(Default)]
struct RootFacts {
    /// gmsh tags of the physical surfaces, sorted (bit order of the surface masks).
    surface_tags: Vec<i32>,
    /// The unit normal of each surface when it is planar.
    surface_normals: Vec<Option<[f64; 3]>>,
    /// The original (file) number of each point of rank 0's DM: cells and vertices.
    orig: Vec<i32>,
    /// The surface bit mask of each point.
    mask: Vec<i32>,
    /// METIS's part of each cell (none: one rank, or the user chose a PETSc partitioner).
    partition: Option<Vec<i32>>,
    /// Cells, vertices, hexahedra and tetrahedra in the whole mesh.
    totals: [u64; 4],
}

/// The physical surfaces as rank 0's check of the mesh file found them: the DM is read
/// without faces, so the surfaces' faces come from the file's surface elements.
#[derive(Debug, Clone, Default)]
pub struct FileSurfaces {
    /// Nodes in the file: PETSc makes a vertex of each, in the file's order (0: not checked).
    pub nodes: usize,
    /// The faces of each physical surface: its gmsh tag, and each face's corners as indices of
    /// the file's nodes in their order.
    pub surfaces: Vec<(i32, Vec<Vec<usize>>)>,
}

impl DistributedMesh {
    /// Reads `path` (gmsh .msh) on rank 0, partitions it with METIS (unless the user chose a
    /// PETSc partitioner with `-petscpartitioner_type`), distributes it and extracts the flat
    /// arrays. Collective; every rank returns the same error. The caller checks the file first
    /// (PETSc's reader fails on rank 0 alone, inside a collective call) and hands rank 0 the
    /// file's physical surfaces ([`FileSurfaces`]); other ranks pass the default.
    pub fn load(
        comm: &SimpleCommunicator,
        path: &Path,
        file: &FileSurfaces,
    ) -> Result<Self, MeshError> {
        let dm = read_gmsh(comm, path)?;
        let facts = if comm.rank() == 0 {
            inspect_on_root(&dm, path, comm.size(), file)
        } else {
            Ok(RootFacts::default())
        };
        let (mut facts, err) = match facts {
            Ok(f) => (f, None),
            Err(e) => (RootFacts::default(), Some(e)),
        };
        agree(comm, err)?;
        share_root_facts(comm, &mut facts);
        set_partition(comm, &dm, facts.partition.as_deref())?;
        let (dm, orig, mask) = distribute(comm, dm, facts.orig, facts.mask)?;
        let mut local = LocalMesh {
            surface_tags: facts.surface_tags,
            surface_normals: facts.surface_normals,
            global_elems: facts.totals[0],
            global_nodes: facts.totals[1],
            global_hexes: facts.totals[2],
            global_tets: facts.totals[3],
            ..Default::default()
        };
        let extracted = extract_local(&dm, &orig, &mask, &mut local);
        agree(comm, extracted.err())?;
        // Elements along a space-filling curve, nodes in the order the elements first touch
        // them, each where the file's order is poor (`locality`).
        let (mut lo, mut hi) = crate::locality::centroid_bounds(&local);
        let (l0, h0) = (lo, hi);
        comm.all_reduce_into(
            &l0[..],
            &mut lo[..],
            mpi::collective::SystemOperation::min(),
        );
        comm.all_reduce_into(
            &h0[..],
            &mut hi[..],
            mpi::collective::SystemOperation::max(),
        );
        crate::locality::order_elements(&mut local, lo, hi);
        let elements = true;
        let renumbered = crate::locality::node_order(&local);
        if let Some(p) = &renumbered {
            crate::locality::renumber_nodes(&mut local, p);
        }
        local.reordered = [elements, renumbered.is_some()];
        let exchange = node_exchange(comm, dm, &mut local, renumbered.as_deref())?;
        Ok(DistributedMesh { local, exchange })
    }
}

/// PETSc's gmsh reader: the whole mesh into rank 0's DM (collective).
fn read_gmsh(comm: &SimpleCommunicator, path: &Path) -> Result<Dm, MeshError> {
    let cpath = cstr(&path.to_string_lossy());
    let mut dm = Dm(std::ptr::null_mut());
    // Cells and vertices only (not interpolated): faces and edges would be most of the
    // mesh's memory (measured on a 110,592-hexahedron block: peak resident set 2.24 KB per
    // element with them, 0.62 KB without), and nothing here needs them: the surfaces come
    // from the file's surface elements (`surfaces`), the element loop reads the cells'
    // vertices, the ghost exchange is a section on the vertices.
    // SAFETY: FFI; PETSc reads the file on rank 0 of the communicator.
    let code = unsafe {
        sys::DMPlexCreateGmshFromFile(comm.as_raw(), cpath.as_ptr(), sys::PETSC_FALSE, &mut dm.0)
    };
    crate::petsc::check(code, "DMPlexCreateGmshFromFile").map_err(|e| {
        MeshError::Invalid(format!(
            "cannot read mesh {}: {}",
            path.display(),
            e.message
        ))
    })?;
    Ok(dm)
}

/// Rank 0, on the whole mesh: it is 3D and all hexahedra and tetrahedra (prisms were split
/// into hexahedra before, `coupling::input::split`), its physical surfaces (tags,
/// planar normals, vertex masks), the original numbers, and the METIS partition. Any failure
/// (PETSc's included) is a message for the agreement step.
fn inspect_on_root(
    dm: &Dm,
    path: &Path,
    size: i32,
    file: &FileSurfaces,
) -> Result<RootFacts, String> {
    let surfaces = &file.surfaces;
    let s = |e: PetscError| e.to_string();
    let (p0, p1) = dm.chart().map_err(s)?;
    let (c0, c1) = dm.height_stratum(0).map_err(s)?;
    let (v0, v1) = dm.depth_stratum(0).map_err(s)?;
    let [nhex, ntet] = check_cells(dm, path, c0, c1)?;
    if file.nodes != 0 && file.nodes != (v1 - v0) as usize {
        return Err(format!(
            "mesh {}: PETSc read {} vertices from a file of {} nodes: its surfaces cannot be matched to them",
            path.display(),
            v1 - v0,
            file.nodes
        ));
    }
    let npts = (p1 - p0) as usize;
    let mut facts = RootFacts {
        orig: vec![-1i32; npts],
        mask: vec![0i32; npts],
        totals: [(c1 - c0) as u64, (v1 - v0) as u64, nhex, ntet],
        ..Default::default()
    };
    facts.surface_tags = surfaces.iter().map(|(t, _)| *t).collect();
    facts.surface_tags.sort_unstable();
    facts.surface_tags.dedup();
    if facts.surface_tags.len() > MAX_SURFACES {
        return Err(format!(
            "mesh {} has {} physical surfaces; at most {} are supported",
            path.display(),
            facts.surface_tags.len(),
            MAX_SURFACES
        ));
    }
    let verts = Vertices {
        p0,
        v0,
        v1,
        coords: vertex_coords(dm, v0, v1).map_err(s)?,
    };
    for (bit, &tag) in facts.surface_tags.iter().enumerate() {
        let faces = surfaces
            .iter()
            .filter(|(t, _)| *t == tag)
            .flat_map(|(_, f)| f);
        let normal = mark_surface(faces, bit, &verts, &mut facts.mask)?;
        facts.surface_normals.push(normal);
    }
    for c in c0..c1 {
        facts.orig[(c - p0) as usize] = c - c0;
    }
    for v in v0..v1 {
        facts.orig[(v - p0) as usize] = v - v0;
    }
    // Asked first: the option counts as read at any rank count (no unused-option warning).
    if !Petsc::has_option("-petscpartitioner_type") && size > 1 {
        facts.partition = Some(metis_partition(dm, c0, c1, size)?);
    }
    Ok(facts)
}

/// The mesh has cells, is 3D, and every cell is a hexahedron or a tetrahedron; returns how
/// many of each. Prisms, pyramids and anything else are refused (the driver splits prisms into
/// hexahedra before this read: coupling/src/input/split.rs).
fn check_cells(dm: &Dm, path: &Path, c0: i32, c1: i32) -> Result<[u64; 2], String> {
    let mut dim = 0;
    petsc_call!(DMGetDimension(dm.0, &mut dim)).map_err(|e| e.to_string())?;
    if c1 == c0 {
        return Err(format!("mesh {} has no cells", path.display()));
    }
    if dim != 3 {
        return Err(format!(
            "mesh {} is {}-dimensional: a 3D mesh of hexahedra and tetrahedra is needed",
            path.display(),
            dim
        ));
    }
    let (mut counts, mut other) = ([0u64; 2], 0usize);
    let mut first_other = None;
    for c in c0..c1 {
        let mut t: sys::DMPolytopeType = 0;
        petsc_call!(DMPlexGetCellType(dm.0, c, &mut t)).map_err(|e| e.to_string())?;
        match t {
            sys::DM_POLYTOPE_HEXAHEDRON => counts[0] += 1,
            sys::DM_POLYTOPE_TETRAHEDRON => counts[1] += 1,
            _ => {
                other += 1;
                first_other.get_or_insert((c - c0, t));
            }
        }
    }
    if let Some((c, t)) = first_other {
        let kind = match t {
            sys::DM_POLYTOPE_TRI_PRISM | sys::DM_POLYTOPE_TRI_PRISM_TENSOR => "prism",
            sys::DM_POLYTOPE_PYRAMID => "pyramid",
            _ => "cell of another kind",
        };
        return Err(format!(
            "mesh {}: element {} is a {} ({} hexahedra, {} tetrahedra, {} other cells): the FE stage reads 8-node hexahedra and 4-node tetrahedra (the driver splits prisms into hexahedra before this read: coupling/src/input/split.rs)",
            path.display(), c, kind, counts[0], counts[1], other
        ));
    }
    Ok(counts)
}

/// Rank 0's vertices: the chart's first point, the vertex range, their coordinates.
struct Vertices {
    p0: i32,
    v0: i32,
    v1: i32,
    coords: Vec<[f64; 3]>,
}

/// Marks the vertices of one physical surface's `faces` (corner indices in the file's node
/// order = vertex order) with bit `bit`, and returns the surface's unit normal when all its
/// faces are parallel (a plane, or parallel planes), else `None`.
fn mark_surface<'a>(
    faces: impl Iterator<Item = &'a Vec<usize>>,
    bit: usize,
    verts: &Vertices,
    mask: &mut [i32],
) -> Result<Option<[f64; 3]>, String> {
    let Vertices { p0, v0, v1, .. } = *verts;
    let mut normal: Option<[f64; 3]> = None;
    let mut planar = true;
    for f in faces {
        let mut fv = Vec::with_capacity(f.len());
        for &k in f {
            let q = v0 + k as i32;
            if q >= v1 {
                return Err(format!(
                    "a surface element refers to node {} of {} in the mesh",
                    k + 1,
                    v1 - v0
                ));
            }
            mask[(q - p0) as usize] |= 1 << bit;
            fv.push(verts.coords[k]);
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
    Ok(if planar { normal } else { None })
}

/// Every rank learns rank 0's surface tags (bit order), surface normals ([flag, nx, ny, nz]
/// per surface) and totals.
fn share_root_facts(comm: &SimpleCommunicator, facts: &mut RootFacts) {
    let root = comm.process_at_rank(0);
    let mut ntags = facts.surface_tags.len() as u64;
    root.broadcast_into(&mut ntags);
    facts.surface_tags.resize(ntags as usize, 0);
    if ntags > 0 {
        root.broadcast_into(&mut facts.surface_tags[..]);
    }
    let mut nbuf: Vec<f64> = (0..ntags as usize)
        .map(|k| match facts.surface_normals.get(k).copied().flatten() {
            Some(n) => [1.0, n[0], n[1], n[2]],
            None => [0.0; 4],
        })
        .flat_map(|a| a.into_iter())
        .collect();
    if ntags > 0 {
        root.broadcast_into(&mut nbuf[..]);
    }
    facts.surface_normals = nbuf
        .chunks(4)
        .map(|c| (c[0] > 0.5).then_some([c[1], c[2], c[3]]))
        .collect();
    root.broadcast_into(&mut facts.totals[..]);
}

/// The partitioner: METIS's parts through PETSc's shell partitioner (every rank sets it; only
/// rank 0 holds cells), or PETSc's own from the options.
fn set_partition(
    comm: &SimpleCommunicator,
    dm: &Dm,
    partition: Option<&[i32]>,
) -> Result<(), MeshError> {
    let (rank, size) = (comm.rank(), comm.size());
    let mut part = std::ptr::null_mut();
    petsc_call!(DMPlexGetPartitioner(dm.0, &mut part))?;
    let shell = cstr("shell");
    if let Some(p) = partition {
        let (c0, _) = dm.height_stratum(0)?;
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
        petsc_call!(PetscPartitionerSetType(part, shell.as_ptr()))?;
        petsc_call!(PetscPartitionerShellSetPartition(
            part,
            size,
            sizes.as_ptr(),
            points.as_ptr()
        ))?;
    } else if rank != 0 && size > 1 && !Petsc::has_option("-petscpartitioner_type") {
        // Other ranks hold no cells; the shell partitioner must be set everywhere.
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
    Ok(())
}

/// `DMPlexDistribute` (no overlap) on more than one rank, carrying the original numbers and
/// surface masks from rank 0's points to the distributed ones.
fn distribute(
    comm: &SimpleCommunicator,
    dm: Dm,
    orig: Vec<i32>,
    mask: Vec<i32>,
) -> Result<(Dm, Vec<i32>, Vec<i32>), MeshError> {
    let mut sf = StarForest(std::ptr::null_mut());
    let mut dist = Dm(std::ptr::null_mut());
    if comm.size() > 1 {
        petsc_call!(DMPlexDistribute(dm.0, 0, &mut sf.0, &mut dist.0))?;
    }
    if dist.0.is_null() {
        return Ok((dm, orig, mask));
    }
    let (q0, q1) = dist.chart()?;
    let n = (q1 - q0) as usize;
    let mut o = vec![0i32; n];
    let mut m = vec![0i32; n];
    // Leaves start at zero and receive root + 0 (each leaf has exactly one root): a broadcast
    // without MPI_REPLACE, which mpi-sys does not export.
    for (root, leaf) in [(&orig, &mut o), (&mask, &mut m)] {
        // SAFETY: FFI on the distribution's star forest; `root` covers rank 0's chart and
        // `leaf` the distributed chart, as the SF's roots and leaves.
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
    Ok((dist, o, m))
}

/// This rank's hexahedra (gmsh/VTK hex order) and tetrahedra (gmsh order), as local node
/// indices, with their original ids and blocks; its node
/// ids, surface masks and coordinates into `local`. Local: the caller agrees on its error.
fn extract_local(dm: &Dm, orig: &[i32], mask: &[i32], local: &mut LocalMesh) -> Result<(), String> {
    let s = |e: PetscError| e.to_string();
    let cell_sets = cstr("Cell Sets");
    let (p0, _) = dm.chart().map_err(s)?;
    let (c0, c1) = dm.height_stratum(0).map_err(s)?;
    let (v0, v1) = dm.depth_stratum(0).map_err(s)?;
    let mut cl = Vec::new();
    for c in c0..c1 {
        dm.closure(c, &mut cl).map_err(s)?;
        let verts: Vec<i32> = cl.iter().copied().filter(|&q| q >= v0 && q < v1).collect();
        let id = orig[(c - p0) as usize] as u64;
        let block = dm.label_value(&cell_sets, c).map_err(s)?;
        // The kind by the vertex count: rank 0 checked every cell is a hexahedron or a
        // tetrahedron (`check_cells`).
        match verts.len() {
            8 => {
                local
                    .elems
                    .push(PETSC_TO_VTK_HEX.map(|j| (verts[j] - v0) as u32));
                local.elem_id.push(id);
                local.elem_block.push(block);
            }
            4 => {
                local
                    .tets
                    .push(PETSC_TO_GMSH_TET.map(|j| (verts[j] - v0) as u32));
                local.tet_id.push(id);
                local.tet_block.push(block);
            }
            n => return Err(format!("element {id} has {n} vertices, expected 8 or 4")),
        }
    }
    local.node_id = (v0..v1).map(|v| orig[(v - p0) as usize] as u64).collect();
    local.node_surfaces = (v0..v1).map(|v| mask[(v - p0) as usize] as u32).collect();
    local.coords = vertex_coords(dm, v0, v1).map_err(s)?;
    Ok(())
}

/// `n` elements at `p`, or none when `p` is null.
///
/// # Safety
/// A non-null `p` points to `n` initialised elements that outlive the slice.
pub(crate) unsafe fn slice_or_empty<'a, T>(p: *const T, n: usize) -> &'a [T] {
    if p.is_null() || n == 0 {
        &[]
    } else {
        // SAFETY: as the caller promises.
        unsafe { std::slice::from_raw_parts(p, n) }
    }
}

/// The MPI datatype of three contiguous doubles (committed).
fn three_doubles() -> Result<mpi_sys::MPI_Datatype, MeshError> {
    // SAFETY: FFI; MPI is initialised (the mesh was just distributed over it), and the
    // handle is written by MPI_Type_contiguous before it is committed.
    unsafe {
        let mut t: mpi_sys::MPI_Datatype = std::mem::zeroed();
        let ok = mpi_sys::MPI_Type_contiguous(3, mpi_sys::RSMPI_DOUBLE, &mut t) == 0
            && mpi_sys::MPI_Type_commit(&mut t) == 0;
        if ok {
            Ok(t)
        } else {
            Err(MeshError::Invalid(
                "MPI_Type_contiguous for the ghost exchange failed".into(),
            ))
        }
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

/// Unit normal of a face (a triangle or a quadrilateral: any corner count) from the largest
/// cross product of its edges from the first corner, or None for a degenerate face. Any vertex order: the normal's sign is irrelevant here.
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

/// A hexahedron's faces as positions in its DMPlex vertex cone, in the order of the faces in
/// an interpolated DMPlex's cell cone (PETSc's `DMPlexGetRawFaces_Internal`).
const HEX_CONE_FACES: [[usize; 4]; 6] = [
    [0, 1, 2, 3],
    [4, 5, 6, 7],
    [0, 3, 5, 4],
    [2, 1, 7, 6],
    [3, 2, 6, 5],
    [0, 4, 7, 1],
];

/// A tetrahedron's faces as positions in its DMPlex vertex cone, in the same function's order
/// for a tetrahedron.
const TET_CONE_FACES: [[usize; 3]; 4] = [[0, 1, 2], [0, 3, 1], [0, 2, 3], [2, 1, 3]];

/// METIS k-way partition of the cells' dual graph (cells sharing a face), on rank 0.
fn metis_partition(dm: &Dm, c0: i32, c1: i32, nparts: i32) -> Result<Vec<i32>, String> {
    // The cell dual graph: two hexahedra are neighbours when they share a face, i.e. four
    // vertices, two tetrahedra when they share three (the DM holds cells and vertices only: no
    // face points to walk through). A hexahedron and a tetrahedron share no face in a
    // conforming mesh, so a neighbour is sought among cells of the face's own kind only; on a
    // mesh of hexahedra alone the graph is the one before tetrahedra were read.
    let nc = (c1 - c0) as usize;
    let s = |e: PetscError| e.to_string();
    let (v0, v1) = dm.depth_stratum(0).map_err(s)?;
    let mut cones = Vec::with_capacity(nc);
    let mut cells_of: Vec<Vec<i32>> = vec![Vec::new(); (v1 - v0).max(0) as usize];
    for c in c0..c1 {
        let cone = dm.cone(c).map_err(s)?;
        for &v in &cone {
            if v >= v0 && v < v1 {
                cells_of[(v - v0) as usize].push(c - c0);
            }
        }
        cones.push(cone);
    }
    let mut xadj: Vec<i32> = Vec::with_capacity(nc + 1);
    let mut adj: Vec<i32> = Vec::with_capacity(6 * nc);
    xadj.push(0);
    for (c, cone) in cones.iter().enumerate() {
        // The faces in the order PETSc's interpolation gives a cell's cone (for a hexahedron:
        // bottom, top, front, back, right, left), so the graph, and METIS's partition, are
        // those of the interpolated mesh the code read before.
        // Each face's corners, padded to four (a tetrahedron's face uses three).
        let mut faces = [[0usize; 4]; 6];
        let (nf, nv) = match cone.len() {
            8 => {
                faces = HEX_CONE_FACES;
                (6, 4)
            }
            4 => {
                for (f, t) in faces.iter_mut().zip(TET_CONE_FACES) {
                    f[..3].copy_from_slice(&t);
                }
                (4, 3)
            }
            n => return Err(format!("cell {c} has {n} vertices, not 8 or 4")),
        };
        for face in &faces[..nf] {
            let mut corners = [0i32; 4];
            for (x, &k) in corners.iter_mut().zip(&face[..nv]) {
                *x = cone[k];
            }
            let v = &corners[..nv];
            if v.iter().any(|&x| x < v0 || x >= v1) {
                continue;
            }
            let first = &cells_of[(v[0] - v0) as usize];
            let n = first.iter().copied().find(|&n| {
                n as usize != c
                    && cones[n as usize].len() == cone.len()
                    && v[1..]
                        .iter()
                        .all(|&x| cells_of[(x - v0) as usize].contains(&n))
            });
            if let Some(n) = n {
                adj.push(n);
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
