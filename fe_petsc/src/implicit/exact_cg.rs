//! The implicit step's linear solve with the same bits at any rank count: conjugate gradients
//! preconditioned by the diagonal (Jacobi) and a coarse grid ([`super::coarse`]), on the
//! element matrices themselves.
//!
//! Why not KSP by default. A PETSc solve is rank-independent only to round-off: its dot
//! products add one partial sum per rank, its matrix rows are summed in the order of a global
//! numbering that follows the partition, the entries are assembled from element blocks in the
//! order the ranks send them, and block-Jacobi or GAMG preconditioners change with the
//! partition. Newton then converges to another ulp-level answer at every rank count, and
//! docs/scene.md's "one answer" (history.csv, probes.csv and fields.h5 byte-identical at any
//! rank count) fails for implicit runs. Here every operation is one the explicit mode already
//! makes rank-independent:
//!
//! - the product `y = A p`, `A = 4 M / dt^2 + sum_e P K_e P`, is formed element by element
//!   (`K_e` kept from the tangent's assembly, 24 x 24) and summed per node in the canonical
//!   element order ([`crate::assembly::Assembly`], as the element forces are), the mass term
//!   added after;
//! - the diagonal (the preconditioner) is summed the same way, and the coarse grid's matrix and
//!   restrictions exactly ([`super::coarse`]);
//! - every dot product is an exact sum over the owned nodes and the ranks
//!   ([`crate::exact::totals`]);
//! - the vector updates are per node, the same on every copy of a shared node.
//!
//! The cost: about 7 reductions per iteration (the coarse restriction one of them), and an
//! iteration count a few times GAMG's (docs/running.md: 93.5 against 35.5 on a plate of 12,800
//! elements; the diagonal alone took 1,609). A user who prefers speed to the guarantee chooses a PETSc solver
//! with `-ksp_type` / `-pc_type` (docs/cli.md); its answers then agree to round-off only.
//!
//! CG (Hestenes & Stiefel 1952; Saad, *Iterative Methods for Sparse Linear Systems*, 2003,
//! Alg. 9.1) for the symmetric positive definite `A`: `x0 = 0`, `r0 = b`, `z = M^-1 r` (the diagonal and the coarse correction),
//! `p0 = z0`; `alpha = (r.z) / (p.A p)`, `x += alpha p`, `r -= alpha A p`, `beta = (r'.z') /
//! (r.z)`, `p = z' + beta p`; stopped when `||r||_2 <= rtol ||b||_2` (the unpreconditioned
//! residual, PETSc's `KSP_NORM_UNPRECONDITIONED` test with KSP's default rtol here).
use super::*;
use crate::assembly::Assembly;
use crate::exact;

/// Most CG iterations of one solve (PETSc's default `-ksp_max_it`).
pub const CG_MAX_IT: usize = 10_000;

/// The element matrices and the work vectors of the rank-independent CG.
pub(super) struct ExactCg {
    /// Each local element's `P K_e P`, 24 x 24 row-major (the tangent's last assembly).
    ke: Vec<f64>,
    /// Each local node's diagonal of `A` (the assembled element diagonals plus the mass term).
    diag: Vec<[f64; 3]>,
    r: Vec<[f64; 3]>,
    z: Vec<[f64; 3]>,
    p: Vec<[f64; 3]>,
    q: Vec<[f64; 3]>,
    /// The coarse-grid correction of the preconditioner ([`super::coarse`]).
    pub(super) coarse: Option<super::coarse::Coarse>,
}

/// The vectors and operators a solve reads.
pub(super) struct CgSystem<'a> {
    pub elems: &'a [[u32; 8]],
    pub owned: &'a [bool],
    /// `4 m / dt^2` per local node.
    pub mass_term: &'a [f64],
    /// Each local node's constraint projection.
    pub dofs: &'a [NodeDof],
}

impl ExactCg {
    pub(super) fn new(n_elems: usize, n_nodes: usize) -> ExactCg {
        let v = vec![[0.0; 3]; n_nodes];
        ExactCg {
            ke: vec![0.0; 576 * n_elems],
            diag: v.clone(),
            r: v.clone(),
            z: v.clone(),
            p: v.clone(),
            q: v,
            coarse: None,
        }
    }

    /// Keeps element `e`'s matrix (the tangent's assembly calls it for every element).
    pub(super) fn store(&mut self, e: usize, ke: &[f64; 576]) {
        self.ke[576 * e..576 * (e + 1)].copy_from_slice(ke);
    }

    /// The stored element matrices, 576 values per local element (a checkpoint keeps them).
    pub(super) fn matrices(&self) -> &[f64] {
        &self.ke
    }

    /// Sets the element matrices a checkpoint kept ([`ExactCg::matrices`]); the diagonal
    /// follows with [`ExactCg::set_diagonal`].
    pub(super) fn set_matrices(&mut self, ke: &[f64]) {
        self.ke.copy_from_slice(ke);
    }

    /// Sums the diagonal of `A` from the stored element matrices (collective).
    pub(super) fn set_diagonal(
        &mut self,
        sys: &CgSystem,
        assembly: &mut Assembly,
        exchange: &mut NodeExchange,
    ) -> Result<(), PetscError> {
        self.diag.fill([0.0; 3]);
        for (e, conn) in sys.elems.iter().enumerate() {
            let ke = &self.ke[576 * e..576 * (e + 1)];
            let d: [[f64; 3]; 8] =
                std::array::from_fn(|k| std::array::from_fn(|c| ke[(3 * k + c) * 25]));
            for (k, &n) in conn.iter().enumerate() {
                for c in 0..3 {
                    self.diag[n as usize][c] += d[k][c];
                }
            }
            assembly.record(e, |k| d[k]);
        }
        assembly.finish(&mut self.diag, exchange)?;
        for (d, &m) in self.diag.iter_mut().zip(sys.mass_term) {
            for x in d.iter_mut() {
                *x += m;
            }
        }
        if let Some(c) = &mut self.coarse {
            c.assemble(sys, &self.ke);
        }
        Ok(())
    }

    /// `q = A p` (collective).
    fn apply(
        &mut self,
        sys: &CgSystem,
        assembly: &mut Assembly,
        exchange: &mut NodeExchange,
    ) -> Result<(), PetscError> {
        self.q.fill([0.0; 3]);
        for (e, conn) in sys.elems.iter().enumerate() {
            let ke = &self.ke[576 * e..576 * (e + 1)];
            let pe: [f64; 24] = std::array::from_fn(|i| self.p[conn[i / 3] as usize][i % 3]);
            let qe: [[f64; 3]; 8] = std::array::from_fn(|k| {
                std::array::from_fn(|c| {
                    let row = &ke[24 * (3 * k + c)..24 * (3 * k + c + 1)];
                    row.iter().zip(&pe).map(|(a, b)| a * b).sum()
                })
            });
            for (k, &n) in conn.iter().enumerate() {
                for c in 0..3 {
                    self.q[n as usize][c] += qe[k][c];
                }
            }
            assembly.record(e, |k| qe[k]);
        }
        assembly.finish(&mut self.q, exchange)?;
        for ((q, p), &m) in self.q.iter_mut().zip(&self.p).zip(sys.mass_term) {
            for c in 0..3 {
                q[c] += m * p[c];
            }
        }
        Ok(())
    }

    /// Solves `A x = b` (`b` and `x` on every local node, each copy the same), `x` from zero.
    /// Returns the iterations (collective; every rank the same result).
    pub(super) fn solve(
        &mut self,
        comm: &SimpleCommunicator,
        sys: &CgSystem,
        (assembly, exchange): (&mut Assembly, &mut NodeExchange),
        (b, x): (&[[f64; 3]], &mut [[f64; 3]]),
        rtol: f64,
    ) -> Result<usize, SolveError> {
        x.fill([0.0; 3]);
        self.r.copy_from_slice(b);
        self.precondition(sys);
        self.p.copy_from_slice(&self.z);
        let [bb, mut rz] = dots(comm, sys.owned, [(&self.r, &self.r), (&self.r, &self.z)]);
        let target = rtol * bb.sqrt();
        if bb == 0.0 {
            return Ok(0);
        }
        for it in 1..=CG_MAX_IT {
            self.apply(sys, assembly, exchange)?;
            let [pq] = dots(comm, sys.owned, [(&self.p, &self.q)]);
            if !(pq > 0.0) {
                return Err(SolveError::Diverged {
                    reason: format!("the tangent is not positive definite (p.A p = {pq:e})"),
                    iterations: it as i32,
                });
            }
            let alpha = rz / pq;
            for n in 0..x.len() {
                for c in 0..3 {
                    x[n][c] += alpha * self.p[n][c];
                    self.r[n][c] -= alpha * self.q[n][c];
                }
            }
            self.precondition(sys);
            let [rr, rz_new] = dots(comm, sys.owned, [(&self.r, &self.r), (&self.r, &self.z)]);
            if rr.sqrt() <= target {
                return Ok(it);
            }
            let beta = rz_new / rz;
            rz = rz_new;
            for (p, z) in self.p.iter_mut().zip(&self.z) {
                for c in 0..3 {
                    p[c] = z[c] + beta * p[c];
                }
            }
        }
        Err(SolveError::Diverged {
            reason: "DIVERGED_ITS".into(),
            iterations: CG_MAX_IT as i32,
        })
    }

    /// `z = D^-1 r`, plus the coarse grid's correction where there is one (collective).
    fn precondition(&mut self, sys: &CgSystem) {
        for ((z, r), d) in self.z.iter_mut().zip(&self.r).zip(&self.diag) {
            for c in 0..3 {
                z[c] = r[c] / d[c];
            }
        }
        if let Some(c) = &self.coarse {
            c.correct(sys, &self.r, &mut self.z);
        }
    }
}

/// A nodal vector, three components per local node.
type Nodal<'a> = &'a [[f64; 3]];

/// Exact dot products over the owned nodes and the ranks (collective).
fn dots<const K: usize>(
    comm: &SimpleCommunicator,
    owned: &[bool],
    pairs: [(Nodal, Nodal); K],
) -> [f64; K] {
    let terms: Vec<Vec<f64>> = pairs
        .iter()
        .map(|(a, b)| {
            let mut t = Vec::with_capacity(3 * a.len());
            for n in (0..a.len()).filter(|&n| owned[n]) {
                t.extend((0..3).map(|c| a[n][c] * b[n][c]));
            }
            t
        })
        .collect();
    let v = exact::totals(comm, &terms);
    std::array::from_fn(|k| v[k])
}
