//! The ghost exchange's set-up: which nodes this rank owns and shares, from the DMPlex's point
//! star forest over the vertices.
use super::*;

/// The nodal layout (3 dofs per vertex, offsets contiguous), which nodes this rank owns, and
/// the ghost exchange over it (collective). `renumbered`: the local nodes' new numbers
/// (`new_of_old`, by the DM's vertex order) when `local`'s nodes were renumbered.
pub(super) fn node_exchange(
    comm: &SimpleCommunicator,
    dm: Dm,
    local: &mut LocalMesh,
    renumbered: Option<&[u32]>,
) -> Result<NodeExchange, MeshError> {
    let (v0, v1) = dm.depth_stratum(0)?;
    let nv = (v1 - v0) as usize;
    let mut sec = Section(std::ptr::null_mut());
    petsc_call!(PetscSectionCreate(comm.as_raw(), &mut sec.0))?;
    let (q0, q1) = dm.chart()?;
    petsc_call!(PetscSectionSetChart(sec.0, q0, q1))?;
    // One dof per vertex: the star forest then has one leaf per node, and the exchange moves a
    // node's three values as one unit of three doubles (a third of the graph a section of 3
    // dofs would keep).
    for v in v0..v1 {
        petsc_call!(PetscSectionSetDof(sec.0, v, 1))?;
    }
    petsc_call!(PetscSectionSetUp(sec.0))?;
    petsc_call!(DMSetLocalSection(dm.0, sec.0))?;
    let mut contiguous = true;
    for v in v0..v1 {
        let mut off = 0;
        petsc_call!(PetscSectionGetOffset(sec.0, v, &mut off))?;
        contiguous &= off == v - v0;
    }
    agree(
        comm,
        (!contiguous)
            .then(|| "unexpected local section layout (vertex offsets not contiguous)".into()),
    )?;
    let mut gsec: sys::PetscSection = std::ptr::null_mut();
    petsc_call!(DMGetGlobalSection(dm.0, &mut gsec))?;
    local.owned = Vec::with_capacity(nv);
    for v in v0..v1 {
        let mut off = 0;
        petsc_call!(PetscSectionGetOffset(gsec, v, &mut off))?;
        local.owned.push(off >= 0);
    }
    if let Some(p) = renumbered {
        crate::locality::permute(&mut local.owned, p);
    }
    // The section's star forest (every local node a leaf, every owned node a root), kept by a
    // reference of our own when the DM goes.
    let mut sf_raw: sys::PetscSF = std::ptr::null_mut();
    petsc_call!(DMGetSectionSF(dm.0, &mut sf_raw))?;
    petsc_call!(PetscObjectReference(sf_raw as sys::PetscObject))?;
    let sf = StarForest(sf_raw);
    petsc_call!(PetscSFSetUp(sf.0))?;
    let (mut nroots, mut nleaves) = (0, 0);
    petsc_call!(PetscSFGetGraph(
        sf.0,
        &mut nroots,
        &mut nleaves,
        std::ptr::null_mut(),
        std::ptr::null_mut()
    ))?;
    let n_owned = local.owned.iter().filter(|o| **o).count();
    agree(
        comm,
        (nleaves as usize != nv || nroots as usize != n_owned).then(|| {
            format!(
                "unexpected ghost exchange layout: {nleaves} leaves for {nv} nodes, {nroots} roots for {n_owned} owned"
            )
        }),
    )?;
    let ghosts = nv - n_owned;
    drop(sec);
    drop(dm);
    let shared = shared_forest(&sf, comm.rank(), renumbered)?;
    Ok(NodeExchange {
        sf: shared.sf,
        unit: three_doubles()?,
        roots: vec![0.0; 3 * nroots as usize],
        shared_leaves: shared.leaves,
        shared_remotes: shared.remotes,
        shared_roots: shared.roots,
        n_local_nodes: nv,
        bytes_sent: 0,
        ghosts,
    })
}

/// The section's star forest cut to the nodes more than one rank holds.
pub(super) struct SharedForest {
    sf: StarForest,
    /// Local node index of each leaf kept (ghosts, and owned nodes with ghosts elsewhere).
    leaves: Vec<u32>,
    /// Root index of each owned node with ghosts elsewhere.
    roots: Vec<u32>,
    /// The root of each leaf kept.
    remotes: Vec<sys::PetscSFNode>,
}

/// The star forest without the leaves of nodes only this rank holds: such a node's sum is its
/// own value, and sending it to its own root and back copied every node twice a step (7 ns per
/// element-cycle of the 103,823-element block at np 1, 5 % of the loop). A leaf stays when its
/// root is on another rank (a ghost) or its root has more than one leaf (an owned node that
/// other ranks hold too). The kept leaves' local indices go through `renumbered`
/// (`new_of_old`) when the nodes were renumbered.
pub(super) fn shared_forest(
    sf: &StarForest,
    rank: i32,
    renumbered: Option<&[u32]>,
) -> Result<SharedForest, PetscError> {
    let (mut nroots, mut nleaves) = (0, 0);
    let mut ilocal: *const sys::PetscInt = std::ptr::null();
    let mut iremote: *const sys::PetscSFNode = std::ptr::null();
    petsc_call!(PetscSFGetGraph(
        sf.0,
        &mut nroots,
        &mut nleaves,
        &mut ilocal,
        &mut iremote
    ))?;
    let mut degree: *const sys::PetscInt = std::ptr::null();
    petsc_call!(PetscSFComputeDegreeBegin(sf.0, &mut degree))?;
    petsc_call!(PetscSFComputeDegreeEnd(sf.0, &mut degree))?;
    let (nroots, nleaves) = (nroots.max(0) as usize, nleaves.max(0) as usize);
    // SAFETY: the star forest owns these arrays (nleaves remote locations, ilocal null or
    // nleaves long, nroots degrees) and outlives the slices.
    let (remote, deg, local) = unsafe {
        (
            slice_or_empty(iremote, nleaves),
            slice_or_empty(degree, nroots),
            slice_or_empty(ilocal, nleaves),
        )
    };
    let mut remotes = Vec::new();
    let mut leaves = Vec::new();
    for (i, r) in remote.iter().enumerate() {
        if r.rank != rank as sys::PetscInt || deg[r.index as usize] > 1 {
            remotes.push(*r);
            let old = if local.is_empty() {
                i
            } else {
                local[i] as usize
            };
            leaves.push(renumbered.map_or(old as u32, |p| p[old]));
        }
    }
    let roots = (0..nroots)
        .filter(|&r| deg[r] > 1)
        .map(|r| r as u32)
        .collect();
    // The cut forest: the kept leaves at their (new) local indices, each with its root.
    let kept = remotes.clone();
    let mut ilocal: Vec<sys::PetscInt> = leaves.iter().map(|&l| l as sys::PetscInt).collect();
    let mut cut: sys::PetscSF = std::ptr::null_mut();
    // SAFETY: reading the communicator of a live PETSc object.
    let comm = unsafe { sys::PetscObjectComm(sf.0 as sys::PetscObject) };
    petsc_call!(PetscSFCreate(comm, &mut cut))?;
    let cut = StarForest(cut);
    petsc_call!(PetscSFSetGraph(
        cut.0,
        nroots as sys::PetscInt,
        ilocal.len() as sys::PetscInt,
        ilocal.as_mut_ptr(),
        sys::PETSC_COPY_VALUES,
        remotes.as_mut_ptr(),
        sys::PETSC_COPY_VALUES
    ))?;
    petsc_call!(PetscSFSetUp(cut.0))?;
    Ok(SharedForest {
        sf: cut,
        leaves,
        roots,
        remotes: kept,
    })
}
