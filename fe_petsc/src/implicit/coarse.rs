//! A coarse-grid correction for the rank-independent CG ([`super::exact_cg`]): the two-level
//! additive preconditioner
//!
//! ```text
//! M^-1 r = D^-1 r + P Phi A_c^-1 Phi^T P r,      A_c = Phi^T P A P Phi
//! ```
//!
//! (additive Schwarz with a coarse space: Toselli & Widlund, *Domain Decomposition Methods*,
//! 2005, ch. 2; Smith, Bjorstad & Gropp 1996). `D` is the diagonal of `A`; `Phi` interpolates a
//! coarse nodal field trilinearly onto the mesh's reference coordinates, from a structured grid
//! over the mesh's bounding box (three components per coarse node, one weight per component);
//! `P` is each node's constraint projection (fixed nodes take nothing, symmetry planes their
//! free directions). The diagonal alone leaves the smooth, long-wave modes (a plate's bending)
//! to many iterations: Jacobi's count grows with the mesh. The coarse solve takes them at once.
//!
//! Why by hand, not PETSc's GAMG or PCMG: those follow the partition (aggregates, smoothers
//! and reductions per rank), and the default implicit solve must give the same bits at any
//! rank count. Here every step is rank-independent: the grid is the bounding box's (exact
//! minima and maxima), each node's weights are its own coordinates', `A_c` is summed exactly
//! ([`binsum`]: each element's `Phi_e^T K_e Phi_e` and each owned node's mass term, on one
//! grid of quanta, reduced over ranks), every rank factors the same `A_c` the same way
//! (banded Cholesky, the grid's longest axis slowest), and the restriction `Phi^T P r` is an
//! exact sum over owned nodes and ranks. Its costs: one reduction of the band of `A_c` per
//! tangent assembly, and one of the coarse vector per CG iteration.
use super::*;
use crate::exact::{flatten, values, Folds, Grid};

/// Mesh nodes per coarse node aimed at (the grid's node count is the mesh's over this,
/// between [`MIN_COARSE`] and [`MAX_COARSE`]).
const NODES_PER_COARSE: f64 = 4.0;
/// Fewest coarse nodes.
const MIN_COARSE: f64 = 8.0;
/// Most coarse nodes (the band's Cholesky costs n b^2 on every rank).
const MAX_COARSE: f64 = 600.0;
/// Most entries of the coarse matrix's band (each reduced as three doubles per assembly).
const MAX_BAND_ENTRIES: usize = 4_000_000;

/// The coarse grid, the local nodes' interpolation weights and the factored coarse matrix.
pub(super) struct Coarse {
    comm: SimpleCommunicator,
    /// Per local node: its 8 coarse nodes (numbered) and trilinear weights.
    node_corners: Vec<[u32; 8]>,
    node_weights: Vec<[f64; 8]>,
    /// Coarse unknowns (3 per coarse node) and the band's half width in unknowns.
    n: usize,
    bw: usize,
    /// The Cholesky factor L of A_c in band storage: `l[i * (bw + 1) + (i - j)]`, j <= i.
    l: Vec<f64>,
    /// Whether the factor is usable (`A_c` positive definite).
    ready: bool,
    /// Whether the band is small enough to use at all ([`MAX_BAND_ENTRIES`]).
    usable: bool,
}

impl Coarse {
    /// The grid over the owned nodes' reference coordinates `x0` of all ranks (collective).
    pub(super) fn new(
        comm: &SimpleCommunicator,
        x0: &[[f64; 3]],
        owned: &[bool],
        elems: &[[u32; 8]],
    ) -> Coarse {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for (x, _) in x0.iter().zip(owned).filter(|(_, &o)| o) {
            for c in 0..3 {
                lo[c] = lo[c].min(x[c]);
                hi[c] = hi[c].max(x[c]);
            }
        }
        let (mut glo, mut ghi) = ([0.0f64; 3], [0.0f64; 3]);
        comm.all_reduce_into(&lo[..], &mut glo[..], SystemOperation::min());
        comm.all_reduce_into(&hi[..], &mut ghi[..], SystemOperation::max());
        let count = owned.iter().filter(|&&o| o).count() as u64;
        let mut total = 0u64;
        comm.all_reduce_into(&count, &mut total, SystemOperation::sum());
        let target = (total as f64 / NODES_PER_COARSE).clamp(MIN_COARSE, MAX_COARSE);
        let len: [f64; 3] = std::array::from_fn(|c| (ghi[c] - glo[c]).max(0.0));
        let size = len
            .iter()
            .cloned()
            .fold(0.0f64, f64::max)
            .max(f64::MIN_POSITIVE);
        // cells of side H with (L_x / H + 1)(L_y / H + 1)(L_z / H + 1) about `target`
        let (mut a, mut b) = (size * 1e-6, size);
        for _ in 0..60 {
            let h = 0.5 * (a + b);
            let n: f64 = len.iter().map(|l| (l / h).round().max(1.0) + 1.0).product();
            if n > target {
                a = h;
            } else {
                b = h;
            }
        }
        let cells: [usize; 3] = std::array::from_fn(|c| (len[c] / b).round().max(1.0) as usize);
        let nd: [usize; 3] = std::array::from_fn(|c| cells[c] + 1);
        let mut axes = [0, 1, 2];
        axes.sort_by(|&p, &q| nd[q].cmp(&nd[p]).then(p.cmp(&q)));
        let number = |i: [usize; 3]| -> u32 {
            ((i[axes[0]] * nd[axes[1]] + i[axes[1]]) * nd[axes[2]] + i[axes[2]]) as u32
        };
        let mut node_corners = Vec::with_capacity(x0.len());
        let mut node_weights = Vec::with_capacity(x0.len());
        for x in x0 {
            let mut base = [0usize; 3];
            let mut t = [0.0f64; 3];
            for c in 0..3 {
                let s = if len[c] > 0.0 {
                    (x[c] - glo[c]) / len[c] * cells[c] as f64
                } else {
                    0.0
                };
                let k = (s.floor().max(0.0) as usize).min(cells[c] - 1);
                base[c] = k;
                t[c] = (s - k as f64).clamp(0.0, 1.0);
            }
            let corners: [u32; 8] =
                std::array::from_fn(|q| number(std::array::from_fn(|c| base[c] + ((q >> c) & 1))));
            let weights: [f64; 8] = std::array::from_fn(|q| {
                (0..3)
                    .map(|c| if (q >> c) & 1 == 1 { t[c] } else { 1.0 - t[c] })
                    .product()
            });
            node_corners.push(corners);
            node_weights.push(weights);
        }
        let n = 3 * nd.iter().product::<usize>();
        // the band: the widest spread of coarse numbers one element's nodes reach
        let mut spread = 0u64;
        for conn in elems {
            let (mut a, mut b) = (u32::MAX, 0u32);
            for &nn in conn {
                for &c in &node_corners[nn as usize] {
                    a = a.min(c);
                    b = b.max(c);
                }
            }
            spread = spread.max(u64::from(b - a));
        }
        let mut g_spread = 0u64;
        comm.all_reduce_into(&spread, &mut g_spread, SystemOperation::max());
        let bw = 3 * g_spread as usize + 2;
        // a band too wide to reduce and factor each assembly (cells smaller than elements):
        // the diagonal alone, as without the coarse grid
        let usable = n * (bw + 1) <= MAX_BAND_ENTRIES;
        Coarse {
            comm: comm.duplicate(),
            node_corners,
            node_weights,
            n,
            bw,
            l: Vec::new(),
            ready: false,
            usable,
        }
    }

    /// Sums `A_c` from the element matrices `ke` (24 x 24 each, `P K_e P`) and the mass term,
    /// exactly over ranks, and factors it (collective).
    pub(super) fn assemble(&mut self, sys: &CgSystem, ke: &[f64]) {
        if !self.usable {
            return;
        }
        let w = self.bw + 1;
        // a bound of every entry's magnitude (the weights are at most 1 and sum to 1)
        let mut bound: f64 = ke.iter().map(|v| v.abs()).sum();
        for (node, &m) in sys.mass_term.iter().enumerate() {
            if sys.owned[node] {
                bound += 3.0 * m;
            }
        }
        let grid = Grid::covering(crate::exact::total(&self.comm, &[bound]));
        let mut folds: Vec<Folds> = vec![[0.0; 3]; self.n * w];
        let mut add = |r: usize, c: usize, v: f64| {
            if c <= r && v != 0.0 {
                grid.add(&mut folds[r * w + (r - c)], v);
            }
        };
        for (e, conn) in sys.elems.iter().enumerate() {
            let k = &ke[576 * e..576 * (e + 1)];
            // the element's coarse nodes and its 8 nodes' weights on them
            let mut set: Vec<u32> = Vec::with_capacity(27);
            for &n in conn {
                for &c in &self.node_corners[n as usize] {
                    if !set.contains(&c) {
                        set.push(c);
                    }
                }
            }
            let m = set.len();
            let mut wts = vec![0.0f64; 8 * m];
            for (i, &n) in conn.iter().enumerate() {
                for (q, &c) in self.node_corners[n as usize].iter().enumerate() {
                    let p = set.iter().position(|&s| s == c).unwrap();
                    wts[i * m + p] += self.node_weights[n as usize][q];
                }
            }
            // T = W^T K (3m x 24), then B = T W (3m x 3m)
            let mut t = vec![0.0f64; 3 * m * 24];
            for i in 0..8 {
                for p in 0..m {
                    let wp = wts[i * m + p];
                    if wp == 0.0 {
                        continue;
                    }
                    for a in 0..3 {
                        let row = &k[(3 * i + a) * 24..(3 * i + a + 1) * 24];
                        let tr = &mut t[(3 * p + a) * 24..(3 * p + a + 1) * 24];
                        for (x, &y) in tr.iter_mut().zip(row) {
                            *x += wp * y;
                        }
                    }
                }
            }
            for pa in 0..3 * m {
                let r = 3 * set[pa / 3] as usize + pa % 3;
                for q in 0..m {
                    let c0 = 3 * set[q] as usize;
                    for b in 0..3 {
                        let mut v = 0.0;
                        for j in 0..8 {
                            v += t[pa * 24 + 3 * j + b] * wts[j * m + q];
                        }
                        add(r, c0 + b, v);
                    }
                }
            }
        }
        for (node, &m) in sys.mass_term.iter().enumerate() {
            if !sys.owned[node] {
                continue;
            }
            let p = sys.dofs[node].matrix();
            for a in 0..3 {
                for b in 0..3 {
                    let pab = match p {
                        None => f64::from(u8::from(a == b)),
                        Some(p) => p[a][b],
                    };
                    if pab == 0.0 {
                        continue;
                    }
                    for (i, &wi) in self.node_weights[node].iter().enumerate() {
                        let r = 3 * self.node_corners[node][i] as usize + a;
                        for (j, &wj) in self.node_weights[node].iter().enumerate() {
                            let c = 3 * self.node_corners[node][j] as usize + b;
                            add(r, c, m * wi * wj * pab);
                        }
                    }
                }
            }
        }
        let flat = flatten(&folds);
        let mut red = vec![0.0; flat.len()];
        self.comm
            .all_reduce_into(&flat[..], &mut red[..], SystemOperation::sum());
        self.l = values(&red);
        self.ready = cholesky_band(&mut self.l, self.n, self.bw);
    }

    /// `z += P Phi A_c^-1 Phi^T P r` (collective).
    pub(super) fn correct(&self, sys: &CgSystem, r: &[[f64; 3]], z: &mut [[f64; 3]]) {
        if !self.ready {
            return;
        }
        let mut terms: Vec<(u32, f64)> = Vec::with_capacity(24 * r.len());
        let mut bound = 0.0f64;
        for (node, rn) in r.iter().enumerate() {
            if !sys.owned[node] {
                continue;
            }
            let pr = sys.dofs[node].free(*rn);
            bound += pr.iter().map(|v| v.abs()).sum::<f64>();
            for (q, &wq) in self.node_weights[node].iter().enumerate() {
                for a in 0..3 {
                    if pr[a] != 0.0 {
                        terms.push((
                            (3 * self.node_corners[node][q] as usize + a) as u32,
                            wq * pr[a],
                        ));
                    }
                }
            }
        }
        let mut y = exact_band(&self.comm, &terms, self.n, bound);
        solve_band(&self.l, self.n, self.bw, &mut y);
        for (node, zn) in z.iter_mut().enumerate() {
            let mut v = [0.0; 3];
            for (q, &wq) in self.node_weights[node].iter().enumerate() {
                let k = 3 * self.node_corners[node][q] as usize;
                for a in 0..3 {
                    v[a] += wq * y[k + a];
                }
            }
            let pv = sys.dofs[node].free(v);
            for a in 0..3 {
                zn[a] += pv[a];
            }
        }
    }
}

/// The `len` sums of the indexed `terms` of every rank, exact (the same bits at any rank
/// count): one grid for all, covering the reduced `bound` (a bound of every sum's magnitude
/// that every rank computes the same: reduced exactly). Collective.
fn exact_band(comm: &SimpleCommunicator, terms: &[(u32, f64)], len: usize, bound: f64) -> Vec<f64> {
    let top = crate::exact::total(comm, &[bound]);
    let grid = Grid::covering(top);
    let mut folds: Vec<Folds> = vec![[0.0; 3]; len];
    for &(i, v) in terms {
        grid.add(&mut folds[i as usize], v);
    }
    let flat = flatten(&folds);
    let mut red = vec![0.0; flat.len()];
    comm.all_reduce_into(&flat[..], &mut red[..], SystemOperation::sum());
    values(&red)
}

/// In-place Cholesky `A = L L^T` of the symmetric band `a` (`a[i * (bw + 1) + (i - j)]` =
/// `A_ij`, j <= i), rows with no entry set to the identity first (coarse nodes no mesh node
/// reaches). Returns false where a pivot is not positive (the correction is then left out).
fn cholesky_band(a: &mut [f64], n: usize, bw: usize) -> bool {
    let w = bw + 1;
    for i in 0..n {
        let row = &a[i * w..(i + 1) * w];
        if row.iter().all(|&v| v == 0.0) {
            let below_zero = (i + 1..n.min(i + w)).all(|k| a[k * w + (k - i)] == 0.0);
            if below_zero {
                a[i * w] = 1.0;
            }
        }
    }
    for j in 0..n {
        let mut d = a[j * w];
        for k in j.saturating_sub(bw)..j {
            let l = a[j * w + (j - k)];
            d -= l * l;
        }
        if !(d > 0.0) {
            return false;
        }
        let d = d.sqrt();
        a[j * w] = d;
        for i in j + 1..n.min(j + w) {
            let mut s = a[i * w + (i - j)];
            for k in i.saturating_sub(bw)..j {
                s -= a[i * w + (i - k)] * a[j * w + (j - k)];
            }
            a[i * w + (i - j)] = s / d;
        }
    }
    true
}

/// Solves `L L^T y = b` in place with the band factor `l`.
fn solve_band(l: &[f64], n: usize, bw: usize, y: &mut [f64]) {
    let w = bw + 1;
    for i in 0..n {
        let mut s = y[i];
        for k in i.saturating_sub(bw)..i {
            s -= l[i * w + (i - k)] * y[k];
        }
        y[i] = s / l[i * w];
    }
    for i in (0..n).rev() {
        let mut s = y[i];
        for k in i + 1..n.min(i + w) {
            s -= l[k * w + (k - i)] * y[k];
        }
        y[i] = s / l[i * w];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The band Cholesky solves a random symmetric positive definite band system (A = B B^T +
    /// n I with B banded) to 1e-12 relative, against the product A y.
    #[test]
    fn band_cholesky_solves_a_band_system() {
        let (n, bw) = (40usize, 5usize);
        let w = bw + 1;
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut full = vec![vec![0.0f64; n]; n];
        for i in 0..n {
            for j in i.saturating_sub(bw)..=i {
                let v = if i == j { n as f64 + rnd() } else { rnd() };
                full[i][j] = v;
                full[j][i] = v;
            }
        }
        let mut band = vec![0.0; n * w];
        for i in 0..n {
            for j in i.saturating_sub(bw)..=i {
                band[i * w + (i - j)] = full[i][j];
            }
        }
        let b: Vec<f64> = (0..n).map(|_| rnd()).collect();
        assert!(cholesky_band(&mut band, n, bw));
        let mut y = b.clone();
        solve_band(&band, n, bw, &mut y);
        for i in 0..n {
            let ay: f64 = (0..n).map(|j| full[i][j] * y[j]).sum();
            assert!(
                (ay - b[i]).abs() < 1e-12 * (1.0 + b[i].abs()),
                "row {i}: {ay} vs {}",
                b[i]
            );
        }
    }
}
