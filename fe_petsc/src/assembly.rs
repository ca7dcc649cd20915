//! Nodal assembly in an order fixed by the mesh, not by the partition: the same bits at any
//! rank count.
//!
//! A node's force (or lumped mass) is the sum of its elements' contributions, and a sum in
//! floating point depends on its order. Summed as each rank's element loop meets them, and a
//! node several ranks hold as one partial sum per rank added over the ranks, the bits change
//! with the rank count, and contact then amplifies that into another answer. Here every node's
//! sum is `0 + c_1 + c_2 + ...` over its elements in the canonical element order (block, Morton
//! key of the centroid on the whole mesh's box, global id: `LocalMesh::elem_key`), on every
//! rank count (the rule of OpenRadioss's `/PARITH/ON`: per-node sums in a fixed order).
//!
//! Each rank's elements are in that order (`crate::locality::order_elements`), so the element
//! loop's scatter-add already sums a node one rank alone holds in the canonical order. A node
//! several ranks hold is summed by its owner: the element loop also records each contribution
//! to such a node ([`Assembly::record`]), each rank sends them one by one (not summed) to the
//! contribution's own slot at the owner, the node's slots in canonical order, through a PETSc
//! star forest (leaves: the recorded contributions; roots: the owner's slots); the owner sums
//! the slots in order, and the node exchange's forest broadcasts the sum to every copy. The
//! forest is built once: each rank gathers its shared nodes' element keys to their owners (a
//! multi-root gather of fixed-size lists), the owner merges them into slots and scatters each
//! contribution's slot back.
//!
//! Cost per step: 24 B copied per contribution to a shared node (the partition's faces), and
//! between ranks 24 B per such contribution sent where the partial sums sent 24 B per copy
//! (about four times as many bytes on a hexahedral partition face); the nodes one rank holds
//! cost nothing more.
use crate::mesh::{slice_or_empty, NodeExchange};
use crate::objects::StarForest;
use crate::petsc::PetscError;
use crate::petsc_call;
use petsc_sys as sys;
use std::ffi::c_void;

/// The plan of the ordered nodal sum of a mesh's element contributions (see the module
/// documentation).
pub struct Assembly {
    /// Per element, its first recorded contribution in `contrib` (its corners at shared
    /// nodes, in corner order), and which corners those are (bit k: corner k).
    first: Vec<u32>,
    corners: Vec<u8>,
    /// The recorded contributions to shared nodes, three doubles each.
    contrib: Vec<[f64; 3]>,
    /// The node exchange's leaves: nodes that several ranks hold, summed by their owners.
    shared: Vec<u32>,
    /// The contributions' forest (leaves: `contrib`; roots: the owner's slots); `None` when
    /// no node of the mesh is shared (one rank).
    sf: Option<StarForest>,
    /// The owner's slots, three doubles each.
    recv: Vec<f64>,
    /// Per owned shared node: its root index, first slot and slot count.
    root_slots: Vec<(u32, u32, u32)>,
    /// Contributions this rank sends to another rank's slots per sum.
    remote_contributions: usize,
    /// Bytes this rank sent in sums so far (24 per remote contribution, and 24 per shared copy
    /// of the broadcast back).
    pub bytes_sent: u64,
}

/// `MPI_Type_contiguous(n, base)`, committed.
fn contiguous(n: i32, base: mpi_sys::MPI_Datatype) -> Result<mpi_sys::MPI_Datatype, PetscError> {
    // SAFETY: FFI; MPI is initialised (a mesh was distributed over it), and the handle is
    // written by MPI_Type_contiguous before it is committed.
    unsafe {
        let mut t: mpi_sys::MPI_Datatype = std::mem::zeroed();
        if mpi_sys::MPI_Type_contiguous(n, base, &mut t) == 0
            && mpi_sys::MPI_Type_commit(&mut t) == 0
        {
            Ok(t)
        } else {
            Err(PetscError {
                code: -1,
                call: "MPI_Type_contiguous",
                message: "the assembly's datatype could not be made".into(),
            })
        }
    }
}

/// The largest of `x` over the star forest's communicator (collective).
fn max_over_ranks(sf: &StarForest, x: u64) -> Result<u64, PetscError> {
    let mut out = 0u64;
    // SAFETY: FFI on the live forest's communicator; one u64 in, one out.
    let rc = unsafe {
        let comm = sys::PetscObjectComm(sf.0 as sys::PetscObject);
        mpi_sys::MPI_Allreduce(
            &x as *const u64 as *const c_void,
            &mut out as *mut u64 as *mut c_void,
            1,
            mpi_sys::RSMPI_UINT64_T,
            mpi_sys::RSMPI_MAX,
            comm,
        )
    };
    if rc != 0 {
        return Err(PetscError {
            code: rc,
            call: "MPI_Allreduce",
            message: "the assembly's set-up reduction failed".into(),
        });
    }
    Ok(out)
}

/// The multi-root gather (`gather`: each leaf's unit of `from` to its own place among its
/// root's in `to`) or scatter (the other way) of forest `sf` (collective).
///
/// # Safety
/// `unit` is a committed datatype of the same size on every rank; `from` and `to` hold the
/// units the forest's leaves (gather: `from`) and multi-roots (gather: `to`) need.
unsafe fn multi_root(
    sf: &StarForest,
    unit: mpi_sys::MPI_Datatype,
    from: &[u64],
    to: &mut [u64],
    gather: bool,
) -> Result<(), PetscError> {
    let (f, t) = (
        from.as_ptr() as *const c_void,
        to.as_mut_ptr() as *mut c_void,
    );
    // SAFETY: as the caller promises.
    unsafe {
        if gather {
            crate::petsc::check(
                sys::PetscSFGatherBegin(sf.0, unit, f, t),
                "PetscSFGatherBegin",
            )?;
            crate::petsc::check(sys::PetscSFGatherEnd(sf.0, unit, f, t), "PetscSFGatherEnd")
        } else {
            crate::petsc::check(
                sys::PetscSFScatterBegin(sf.0, unit, f, t),
                "PetscSFScatterBegin",
            )?;
            crate::petsc::check(
                sys::PetscSFScatterEnd(sf.0, unit, f, t),
                "PetscSFScatterEnd",
            )
        }
    }
}

impl Assembly {
    /// The plan for elements `elems` (local node indices, `N` per element: 8 for the hexahedra,
    /// 4 for the faces of a pressure load; in canonical order) with canonical keys `elem_key`,
    /// over the node exchange `ex` (collective: every rank of the mesh calls it).
    pub fn new<const N: usize>(
        elems: &[[u32; N]],
        elem_key: &[[u64; 3]],
        ex: &NodeExchange,
    ) -> Result<Self, PetscError> {
        assert!(N <= 8, "at most 8 corners (one bit each)");
        let nv = ex.n_local_nodes;
        let mut leaf_of = vec![u32::MAX; nv];
        for (i, &l) in ex.shared_leaves.iter().enumerate() {
            leaf_of[l as usize] = i as u32;
        }
        // The recorded contributions, and each shared copy's (contribution, element).
        let (mut first, mut corners) = (Vec::with_capacity(elems.len()), Vec::new());
        let mut per_leaf: Vec<Vec<(u32, u32)>> = vec![Vec::new(); ex.shared_leaves.len()];
        let mut next = 0u32;
        for (e, conn) in elems.iter().enumerate() {
            first.push(next);
            let mut mask = 0u8;
            for (k, &n) in conn.iter().enumerate() {
                let i = leaf_of[n as usize];
                if i != u32::MAX {
                    mask |= 1 << k;
                    per_leaf[i as usize].push((next, e as u32));
                    next += 1;
                }
            }
            corners.push(mask);
        }
        let most = per_leaf.iter().map(|v| v.len() as u64).max().unwrap_or(0);
        let width = max_over_ranks(&ex.sf, most)?;
        let mut plan = Assembly {
            first,
            corners,
            contrib: vec![[0.0; 3]; next as usize],
            shared: ex.shared_leaves.clone(),
            sf: None,
            recv: Vec::new(),
            root_slots: Vec::new(),
            remote_contributions: 0,
            bytes_sent: 0,
        };
        if width > 0 {
            plan.build_forest(ex, elem_key, &per_leaf, width as usize)?;
        }
        Ok(plan)
    }

    /// Records element `e`'s contributions `f` (one per corner) to the shared nodes: call
    /// it for every element in each sum, with what the scatter-add added.
    #[inline]
    pub fn record(&mut self, e: usize, f: impl Fn(usize) -> [f64; 3]) {
        let mask = self.corners[e];
        if mask == 0 {
            return;
        }
        let mut at = self.first[e] as usize;
        for k in 0..8 {
            if mask & (1 << k) != 0 {
                self.contrib[at] = f(k);
                at += 1;
            }
        }
    }

    /// The contributions' forest (see the module documentation), every shared node's list at
    /// most `width` long (collective).
    fn build_forest(
        &mut self,
        ex: &NodeExchange,
        elem_key: &[[u64; 3]],
        per_leaf: &[Vec<(u32, u32)>],
        width: usize,
    ) -> Result<(), PetscError> {
        let nroots = ex.roots.len() / 3;
        let nleaves = ex.shared_leaves.len();
        // SAFETY: reading the communicator of a live PETSc object.
        let comm = unsafe { sys::PetscObjectComm(ex.sf.0 as sys::PetscObject) };
        // The node exchange's forest with its leaves numbered 0.. (one list each).
        let mut raw: sys::PetscSF = std::ptr::null_mut();
        petsc_call!(PetscSFCreate(comm, &mut raw))?;
        let lists = StarForest(raw);
        let mut remotes = ex.shared_remotes.clone();
        petsc_call!(PetscSFSetGraph(
            lists.0,
            nroots as sys::PetscInt,
            nleaves as sys::PetscInt,
            std::ptr::null_mut(),
            sys::PETSC_COPY_VALUES,
            remotes.as_mut_ptr(),
            sys::PETSC_COPY_VALUES
        ))?;
        petsc_call!(PetscSFSetUp(lists.0))?;
        let mut degree: *const sys::PetscInt = std::ptr::null();
        petsc_call!(PetscSFComputeDegreeBegin(lists.0, &mut degree))?;
        petsc_call!(PetscSFComputeDegreeEnd(lists.0, &mut degree))?;
        // SAFETY: the forest owns `nroots` degrees and outlives the slice.
        let deg: Vec<usize> = unsafe { slice_or_empty(degree, nroots) }
            .iter()
            .map(|&d| d.max(0) as usize)
            .collect();
        // Each shared copy's element keys (three u64 each), padded to `width`, gathered to
        // its owner.
        let w = 3 * width;
        let mut ids = vec![u64::MAX; nleaves * w];
        for (i, list) in per_leaf.iter().enumerate() {
            for (j, &(_, e)) in list.iter().enumerate() {
                ids[i * w + 3 * j..i * w + 3 * j + 3].copy_from_slice(&elem_key[e as usize]);
                debug_assert!(elem_key[e as usize] != [u64::MAX; 3]);
            }
        }
        let total: usize = deg.iter().sum();
        let mut gathered = vec![u64::MAX; total * w];
        // SAFETY: reading MPI's predefined handle (a constant after MPI_Init).
        let unit = contiguous(w as i32, unsafe { mpi_sys::RSMPI_UINT64_T })?;
        // SAFETY: `ids` holds one unit per leaf and `gathered` one per root's leaf (the
        // degrees' sum).
        unsafe { multi_root(&lists, unit, &ids, &mut gathered, true)? };
        // The owner: each shared node's slots are its elements in canonical order; each
        // gathered key's first word becomes its slot.
        let key = |c: &[u64]| [c[0], c[1], c[2]];
        let mut next = 0u32;
        let mut at = 0usize;
        for (r, &d) in deg.iter().enumerate() {
            if d == 0 {
                continue;
            }
            let seg = &mut gathered[at * w..(at + d) * w];
            let mut merged: Vec<[u64; 3]> = seg
                .chunks_exact(3)
                .map(key)
                .filter(|k| *k != [u64::MAX; 3])
                .collect();
            merged.sort_unstable();
            merged.dedup();
            for c in seg.chunks_exact_mut(3) {
                if key(c) != [u64::MAX; 3] {
                    c[0] = next as u64 + merged.binary_search(&key(c)).expect("merged") as u64;
                }
            }
            self.root_slots.push((r as u32, next, merged.len() as u32));
            next += merged.len() as u32;
            at += d;
        }
        let mut slot_of = vec![u64::MAX; nleaves * w];
        // SAFETY: as the gather, the other way; the unit is not used after.
        unsafe {
            multi_root(&lists, unit, &gathered, &mut slot_of, false)?;
            let mut u = unit;
            mpi_sys::MPI_Type_free(&mut u);
        }
        // The contributions' forest: each shared copy's contributions to their slots.
        let mut ilocal = Vec::new();
        let mut iremote = Vec::new();
        for (i, list) in per_leaf.iter().enumerate() {
            for (j, &(c, _)) in list.iter().enumerate() {
                ilocal.push(c as sys::PetscInt);
                iremote.push(sys::PetscSFNode {
                    rank: ex.shared_remotes[i].rank,
                    index: slot_of[i * w + 3 * j] as sys::PetscInt,
                });
            }
        }
        // SAFETY: reading the rank of a live communicator.
        let rank = unsafe {
            let mut r = 0;
            mpi_sys::MPI_Comm_rank(comm, &mut r);
            r
        };
        self.remote_contributions = iremote.iter().filter(|n| n.rank != rank).count();
        let mut raw: sys::PetscSF = std::ptr::null_mut();
        petsc_call!(PetscSFCreate(comm, &mut raw))?;
        let sf = StarForest(raw);
        petsc_call!(PetscSFSetGraph(
            sf.0,
            next as sys::PetscInt,
            ilocal.len() as sys::PetscInt,
            ilocal.as_mut_ptr(),
            sys::PETSC_COPY_VALUES,
            iremote.as_mut_ptr(),
            sys::PETSC_COPY_VALUES
        ))?;
        petsc_call!(PetscSFSetUp(sf.0))?;
        self.sf = Some(sf);
        self.recv = vec![0.0; 3 * next as usize];
        Ok(())
    }

    /// Replaces each shared node's value in `out` (the scatter-add's partial sum) by the sum
    /// of its recorded contributions over every rank, in canonical order (collective).
    pub fn finish(
        &mut self,
        out: &mut [[f64; 3]],
        ex: &mut NodeExchange,
    ) -> Result<(), PetscError> {
        let Some(sf) = &self.sf else {
            return Ok(());
        };
        self.recv.fill(0.0);
        let (leaves, slots) = (
            self.contrib.as_ptr() as *const c_void,
            self.recv.as_mut_ptr() as *mut c_void,
        );
        // SAFETY: reading MPI's predefined handle (a constant after MPI_Init).
        let sum = unsafe { mpi_sys::RSMPI_SUM };
        // SAFETY: FFI on the contributions' forest: `contrib` holds every leaf and `recv` its
        // roots, three doubles each.
        unsafe {
            crate::petsc::check(
                sys::PetscSFReduceBegin(sf.0, ex.unit, leaves, slots, sum),
                "PetscSFReduceBegin",
            )?;
            crate::petsc::check(
                sys::PetscSFReduceEnd(sf.0, ex.unit, leaves, slots, sum),
                "PetscSFReduceEnd",
            )?;
        }
        // Each slot holds 0 + its contribution (exact): the owner's sum in slot order.
        for &(r, first, n) in &self.root_slots {
            let mut acc = [0.0f64; 3];
            for s in first as usize..(first + n) as usize {
                acc[0] += self.recv[3 * s];
                acc[1] += self.recv[3 * s + 1];
                acc[2] += self.recv[3 * s + 2];
            }
            ex.roots[3 * r as usize..3 * r as usize + 3].copy_from_slice(&acc);
        }
        for &l in &self.shared {
            out[l as usize] = [0.0; 3];
        }
        ex.broadcast_roots(out.as_flattened_mut())?;
        self.bytes_sent += 24 * (self.remote_contributions + self.shared.len()) as u64;
        Ok(())
    }
}
