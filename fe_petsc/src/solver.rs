//! Owning wrappers for the PETSc linear-algebra objects of the implicit mode: a blocked sparse
//! matrix assembled element by element ([`BlockMatrix`]) and a Krylov solver ([`Solver`]).
//!
//! Numbering: the matrix has 3 rows per node (block size 3); its rows are the owned nodes of
//! each rank, rank after rank, in the order the caller gives. The caller hands every local node
//! (owned and ghost) its global block index once; the matrix keeps it as an
//! `ISLocalToGlobalMapping`, and element blocks are added with `MatSetValuesBlockedLocal` on
//! local node indices (PETSc moves the rows of ghost nodes to their owners at assembly).
//! The sparsity is found exactly before the first assembly with a `MATPREALLOCATOR` pass.
use crate::objects::Vector;
use crate::petsc::PetscError;
use crate::petsc_call;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use petsc_sys as sys;
use std::ffi::{CStr, CString};

/// Unknowns per node.
pub const BS: usize = 3;

/// An owned `Mat`.
pub struct Matrix(pub(crate) sys::Mat);
/// An owned `KSP`.
pub struct Ksp(pub(crate) sys::KSP);
/// An owned `ISLocalToGlobalMapping`.
pub struct LocalToGlobal(pub(crate) sys::ISLocalToGlobalMapping);
/// An owned `MatNullSpace`.
pub struct NullSpace(pub(crate) sys::MatNullSpace);

impl Drop for Matrix {
    fn drop(&mut self) {
        if !self.0.is_null() {
            unsafe { sys::MatDestroy(&mut self.0) };
        }
    }
}
impl Drop for Ksp {
    fn drop(&mut self) {
        if !self.0.is_null() {
            unsafe { sys::KSPDestroy(&mut self.0) };
        }
    }
}
impl Drop for LocalToGlobal {
    fn drop(&mut self) {
        if !self.0.is_null() {
            unsafe { sys::ISLocalToGlobalMappingDestroy(&mut self.0) };
        }
    }
}
impl Drop for NullSpace {
    fn drop(&mut self) {
        if !self.0.is_null() {
            unsafe { sys::MatNullSpaceDestroy(&mut self.0) };
        }
    }
}

fn type_name(t: &'static [u8]) -> *const std::os::raw::c_char {
    CStr::from_bytes_with_nul(t)
        .expect("PETSc type names are NUL-terminated")
        .as_ptr()
}

/// A symmetric sparse matrix with 3 x 3 node blocks, distributed by owned nodes.
pub struct BlockMatrix {
    mat: Matrix,
    _l2g: LocalToGlobal,
    _near_null: Option<NullSpace>,
    n_owned: usize,
}

impl BlockMatrix {
    /// Creates the matrix for `n_owned` owned nodes on this rank, with `global_block[i]` the
    /// global node (block) index of local node `i`, and preallocates it exactly for the given
    /// node blocks (each a list of local nodes whose pairs couple, e.g. an element's nodes).
    /// Collective.
    pub fn new(
        comm: &SimpleCommunicator,
        n_owned: usize,
        global_block: &[i32],
        blocks: &[[u32; 8]],
    ) -> Result<BlockMatrix, PetscError> {
        let mut l2g = LocalToGlobal(std::ptr::null_mut());
        petsc_call!(ISLocalToGlobalMappingCreate(
            comm.as_raw(),
            BS as i32,
            global_block.len() as i32,
            global_block.as_ptr(),
            sys::PETSC_COPY_VALUES,
            &mut l2g.0
        ))?;
        let create = |kind: &'static [u8]| -> Result<Matrix, PetscError> {
            let mut m = Matrix(std::ptr::null_mut());
            let n = (BS * n_owned) as i32;
            petsc_call!(MatCreate(comm.as_raw(), &mut m.0))?;
            petsc_call!(MatSetSizes(
                m.0,
                n,
                n,
                sys::PETSC_DETERMINE,
                sys::PETSC_DETERMINE
            ))?;
            petsc_call!(MatSetType(m.0, type_name(kind)))?;
            petsc_call!(MatSetBlockSize(m.0, BS as i32))?;
            petsc_call!(MatSetLocalToGlobalMapping(m.0, l2g.0, l2g.0))?;
            Ok(m)
        };
        // Pass 1: record the pattern of the element blocks (they hold every node's diagonal block).
        let pre = create(sys::MATPREALLOCATOR)?;
        petsc_call!(MatSetUp(pre.0))?;
        let zeros = vec![0.0; 64 * BS * BS];
        for conn in blocks {
            let rows: [i32; 8] = std::array::from_fn(|k| conn[k] as i32);
            petsc_call!(MatSetValuesBlockedLocal(
                pre.0,
                8,
                rows.as_ptr(),
                8,
                rows.as_ptr(),
                zeros.as_ptr(),
                sys::ADD_VALUES
            ))?;
        }
        petsc_call!(MatAssemblyBegin(pre.0, sys::MAT_FINAL_ASSEMBLY))?;
        petsc_call!(MatAssemblyEnd(pre.0, sys::MAT_FINAL_ASSEMBLY))?;
        // Pass 2: the real matrix with exactly that pattern (filled with zeros).
        let mat = create(sys::MATAIJ)?;
        petsc_call!(MatPreallocatorPreallocate(pre.0, sys::PETSC_TRUE, mat.0))?;
        petsc_call!(MatSetOption(
            mat.0,
            sys::MAT_NEW_NONZERO_ALLOCATION_ERR,
            sys::PETSC_TRUE
        ))?;
        petsc_call!(MatSetOption(mat.0, sys::MAT_SYMMETRIC, sys::PETSC_TRUE))?;
        petsc_call!(MatSetOption(mat.0, sys::MAT_SPD, sys::PETSC_TRUE))?;
        Ok(BlockMatrix {
            mat,
            _l2g: l2g,
            _near_null: None,
            n_owned,
        })
    }

    /// Zeroes every entry (the pattern stays).
    pub fn zero(&mut self) -> Result<(), PetscError> {
        petsc_call!(MatZeroEntries(self.mat.0))
    }

    /// Adds a dense block coupling the local nodes `nodes` with themselves: `values` is the
    /// (3n x 3n) matrix, row-major, rows and columns node-major (node, component).
    pub fn add_local(&mut self, nodes: &[i32], values: &[f64]) -> Result<(), PetscError> {
        let n = nodes.len();
        assert_eq!(values.len(), BS * BS * n * n);
        petsc_call!(MatSetValuesBlockedLocal(
            self.mat.0,
            n as i32,
            nodes.as_ptr(),
            n as i32,
            nodes.as_ptr(),
            values.as_ptr(),
            sys::ADD_VALUES
        ))
    }

    /// Finishes an assembly (collective: moves ghost rows to their owners).
    pub fn assemble(&mut self) -> Result<(), PetscError> {
        petsc_call!(MatAssemblyBegin(self.mat.0, sys::MAT_FINAL_ASSEMBLY))?;
        petsc_call!(MatAssemblyEnd(self.mat.0, sys::MAT_FINAL_ASSEMBLY))
    }

    /// A vector laid out like the matrix rows (3 entries per owned node).
    pub fn vector(&self) -> Result<Vector, PetscError> {
        let mut v = Vector(std::ptr::null_mut());
        petsc_call!(MatCreateVecs(self.mat.0, &mut v.0, std::ptr::null_mut()))?;
        Ok(v)
    }

    /// Gives the preconditioner the six rigid-body modes of the owned nodes at `coords`
    /// (owned nodes in row order) as the near null space (what smoothed aggregation needs for
    /// elasticity). Collective.
    pub fn set_rigid_body_modes(&mut self, coords: &[[f64; 3]]) -> Result<(), PetscError> {
        assert_eq!(coords.len(), self.n_owned);
        let v = self.vector()?;
        write_vector(&v, coords.as_flattened())?;
        let mut ns = NullSpace(std::ptr::null_mut());
        petsc_call!(MatNullSpaceCreateRigidBody(v.0, &mut ns.0))?;
        petsc_call!(MatSetNearNullSpace(self.mat.0, ns.0))?;
        self._near_null = Some(ns);
        Ok(())
    }
}

/// Copies `data` (this rank's entries) into a vector.
pub fn write_vector(v: &Vector, data: &[f64]) -> Result<(), PetscError> {
    let mut n = 0;
    petsc_call!(VecGetLocalSize(v.0, &mut n))?;
    assert_eq!(n as usize, data.len());
    let mut p: *mut f64 = std::ptr::null_mut();
    petsc_call!(VecGetArray(v.0, &mut p))?;
    if n > 0 {
        // SAFETY: PETSc's local array of n entries, valid until restored.
        unsafe { std::slice::from_raw_parts_mut(p, n as usize) }.copy_from_slice(data);
    }
    petsc_call!(VecRestoreArray(v.0, &mut p))
}

/// Copies a vector's entries on this rank into `out`.
pub fn read_vector(v: &Vector, out: &mut [f64]) -> Result<(), PetscError> {
    let mut n = 0;
    petsc_call!(VecGetLocalSize(v.0, &mut n))?;
    assert_eq!(n as usize, out.len());
    let mut p: *const f64 = std::ptr::null();
    petsc_call!(VecGetArrayRead(v.0, &mut p))?;
    if n > 0 {
        // SAFETY: PETSc's local array of n entries, valid until restored.
        out.copy_from_slice(unsafe { std::slice::from_raw_parts(p, n as usize) });
    }
    petsc_call!(VecRestoreArrayRead(v.0, &mut p))
}

/// Default relative tolerance of the Krylov solve (`-ksp_rtol` overrides).
pub const KSP_RTOL: f64 = 1e-10;

/// The linear solver did not converge.
#[derive(Debug, Clone, thiserror::Error)]
pub enum SolveError {
    /// PETSc failed.
    #[error("{0}")]
    Petsc(#[from] PetscError),
    /// KSP stopped without converging.
    #[error("the linear solver (KSP) did not converge: {reason} after {iterations} iterations (choose another with -ksp_type / -pc_type, or loosen -ksp_rtol)")]
    Diverged {
        /// PETSc's reason, e.g. `DIVERGED_ITS`.
        reason: String,
        /// Iterations taken.
        iterations: i32,
    },
}

/// A Krylov solver for a [`BlockMatrix`]: conjugate gradients preconditioned by smoothed
/// aggregation (GAMG, with the rigid-body modes as near null space), relative tolerance
/// [`KSP_RTOL`]; every choice can be changed from the PETSc options database (`-ksp_type`,
/// `-pc_type`, `-ksp_rtol`, `-ksp_monitor`, ...), which is read last. GAMG rebuilds its
/// hierarchy whenever the matrix changed (`-pc_gamg_reuse_interpolation` keeps it).
pub struct Solver {
    ksp: Ksp,
    /// Krylov iterations of the last solve.
    pub last_iterations: i32,
}

impl Solver {
    /// Sets up the solver for `a` (collective).
    pub fn new(comm: &SimpleCommunicator, a: &BlockMatrix) -> Result<Solver, PetscError> {
        let mut ksp = Ksp(std::ptr::null_mut());
        petsc_call!(KSPCreate(comm.as_raw(), &mut ksp.0))?;
        petsc_call!(KSPSetOperators(ksp.0, a.mat.0, a.mat.0))?;
        petsc_call!(KSPSetType(ksp.0, type_name(sys::KSPCG)))?;
        let mut pc: sys::PC = std::ptr::null_mut();
        petsc_call!(KSPGetPC(ksp.0, &mut pc))?;
        petsc_call!(PCSetType(pc, type_name(sys::PCGAMG)))?;
        // The Chebyshev smoothers estimate their own eigenvalues: the estimate left over from
        // smoothing the prolongator was too low after plastic changes of the tangent (the
        // Taylor impact's preconditioner became indefinite).
        petsc_call!(PCGAMGSetUseSAEstEig(pc, sys::PETSC_FALSE))?;
        petsc_call!(KSPSetTolerances(
            ksp.0,
            KSP_RTOL,
            sys::PETSC_DEFAULT as f64,
            sys::PETSC_DEFAULT as f64,
            sys::PETSC_DEFAULT
        ))?;
        petsc_call!(KSPSetFromOptions(ksp.0))?;
        Ok(Solver {
            ksp,
            last_iterations: 0,
        })
    }

    /// Solves A x = b with the matrix's current values (the preconditioner is rebuilt when
    /// they changed since the last solve). Collective.
    pub fn solve(&mut self, b: &Vector, x: &mut Vector) -> Result<i32, SolveError> {
        petsc_call!(KSPSolve(self.ksp.0, b.0, x.0))?;
        let mut its = 0;
        petsc_call!(KSPGetIterationNumber(self.ksp.0, &mut its))?;
        self.last_iterations = its;
        let mut reason: sys::KSPConvergedReason = 0;
        petsc_call!(KSPGetConvergedReason(self.ksp.0, &mut reason))?;
        if reason < 0 {
            let mut s: *const std::os::raw::c_char = std::ptr::null();
            petsc_call!(KSPGetConvergedReasonString(self.ksp.0, &mut s))?;
            let reason = if s.is_null() {
                format!("reason {reason}")
            } else {
                // SAFETY: a static NUL-terminated string owned by PETSc.
                unsafe { CStr::from_ptr(s) }.to_string_lossy().into_owned()
            };
            return Err(SolveError::Diverged {
                reason,
                iterations: its,
            });
        }
        Ok(its)
    }
}

/// A real option from the PETSc options database (e.g. `-tdyn_newton_rtol 1e-9`), if given.
pub fn option_real(name: &str) -> Result<Option<f64>, PetscError> {
    let c = CString::new(name).unwrap();
    let mut v = 0.0;
    let mut set: sys::PetscBool = 0;
    petsc_call!(PetscOptionsGetReal(
        std::ptr::null_mut(),
        std::ptr::null(),
        c.as_ptr(),
        &mut v,
        &mut set
    ))?;
    Ok((set != 0).then_some(v))
}

/// An integer option from the PETSc options database, if given.
pub fn option_int(name: &str) -> Result<Option<i32>, PetscError> {
    let c = CString::new(name).unwrap();
    let mut v = 0;
    let mut set: sys::PetscBool = 0;
    petsc_call!(PetscOptionsGetInt(
        std::ptr::null_mut(),
        std::ptr::null(),
        c.as_ptr(),
        &mut v,
        &mut set
    ))?;
    Ok((set != 0).then_some(v))
}
