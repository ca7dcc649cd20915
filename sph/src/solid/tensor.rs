//! Small 3 x 3 tensor helpers of the solid passes: Voigt <-> matrix, products, the inverse, and
//! the eigen-decomposition of a symmetric matrix (cyclic Jacobi).

/// A 3 x 3 matrix, row-major: `m[k][l]`.
pub type Mat3 = [[f64; 3]; 3];

/// The identity.
pub const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The symmetric matrix of Voigt components xx, yy, zz, xy, yz, zx.
#[inline]
pub fn from_voigt(s: &[f64; 6]) -> Mat3 {
    [[s[0], s[3], s[5]], [s[3], s[1], s[4]], [s[5], s[4], s[2]]]
}

/// Voigt components xx, yy, zz, xy, yz, zx of `m` (its symmetric part's off-diagonals).
#[inline]
pub fn to_voigt(m: &Mat3) -> [f64; 6] {
    [
        m[0][0],
        m[1][1],
        m[2][2],
        0.5 * (m[0][1] + m[1][0]),
        0.5 * (m[1][2] + m[2][1]),
        0.5 * (m[2][0] + m[0][2]),
    ]
}

/// a b.
#[inline]
pub fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// a^T.
#[inline]
pub fn transpose(a: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| a[j][i]))
}

/// m v.
#[inline]
pub fn mul_vec(m: &Mat3, v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

/// The inverse of `a` by cofactors, or `None` when |det a| <= `tol` (max |a_kl|)^3.
pub fn inverse(a: &Mat3, tol: f64) -> Option<Mat3> {
    let c = |i: usize, j: usize| {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
        a[i1][j1] * a[i2][j2] - a[i1][j2] * a[i2][j1]
    };
    let det = a[0][0] * c(0, 0) + a[0][1] * c(0, 1) + a[0][2] * c(0, 2);
    let scale = a.iter().flatten().fold(0.0f64, |s, x| s.max(x.abs()));
    if det.is_nan() || det.abs() <= tol * scale * scale * scale {
        return None;
    }
    // inverse = adjugate / det, adjugate = cofactor matrix transposed
    Some(std::array::from_fn(|i| {
        std::array::from_fn(|j| c(j, i) / det)
    }))
}

/// Sweeps of the cyclic Jacobi method: each sweep squares the off-diagonal norm (quadratic
/// convergence); 3 x 3 matrices reach round-off in 4-6 sweeps.
const JACOBI_MAX_SWEEPS: usize = 30;

/// Eigenvalues `lam` and eigenvectors (the COLUMNS of `q`) of the symmetric matrix `a`, so that
/// a = q diag(lam) q^T, by cyclic Jacobi rotations (Golub & Van Loan, Matrix Computations, 4th
/// ed., §8.5.2: each rotation zeroes a_pq with t = sgn(theta)/(|theta| + sqrt(theta^2 + 1)),
/// theta = (a_qq - a_pp)/(2 a_pq)). Stops when the off-diagonal part is below 1e-15 of the
/// matrix's norm (round-off).
pub fn symmetric_eigen(a: &Mat3) -> ([f64; 3], Mat3) {
    let mut a = *a;
    let mut q = IDENTITY;
    let norm: f64 = a.iter().flatten().map(|x| x * x).sum::<f64>().sqrt();
    for _ in 0..JACOBI_MAX_SWEEPS {
        let off = a[0][1] * a[0][1] + a[1][2] * a[1][2] + a[0][2] * a[0][2];
        if off.sqrt() <= 1e-15 * norm {
            break;
        }
        for (p, r) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][r] == 0.0 {
                continue;
            }
            let theta = (a[r][r] - a[p][p]) / (2.0 * a[p][r]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // a <- J^T a J with J the rotation in the (p, r) plane
            for row in a.iter_mut() {
                let (akp, akr) = (row[p], row[r]);
                row[p] = c * akp - s * akr;
                row[r] = s * akp + c * akr;
            }
            let (ap, ar) = (a[p], a[r]);
            a[p] = std::array::from_fn(|k| c * ap[k] - s * ar[k]);
            a[r] = std::array::from_fn(|k| s * ap[k] + c * ar[k]);
            for row in q.iter_mut() {
                let (qp, qr) = (row[p], row[r]);
                row[p] = c * qp - s * qr;
                row[r] = s * qp + c * qr;
            }
        }
    }
    ([a[0][0], a[1][1], a[2][2]], q)
}

/// `L` symmetric 3 x 3 matrices side by side, entry by entry: `m[k][l][lane]`.
pub type Mat3Lanes<const L: usize> = [[[f64; L]; 3]; 3];

/// [`symmetric_eigen`] of `L` matrices at once (`a[k][l][lane]`), each lane's the same bits as
/// `symmetric_eigen` of its matrix: every lane performs the same operations in the same order,
/// and a lane that has converged, or whose pivot is zero, keeps its values (a select, not a
/// jump) while the others go on (the sweeps run until every lane has converged). The lanes'
/// divisions and square roots, a chain of five per rotation in one matrix, then overlap (and
/// share a vector register in the wider builds, `super::build`). Returns the eigenvalues
/// (`lam[k][lane]`) and the eigenvectors as the columns of `q` (`q[k][l][lane]`).
#[inline(always)]
pub fn symmetric_eigen_lanes<const L: usize>(a: &Mat3Lanes<L>) -> ([[f64; L]; 3], Mat3Lanes<L>) {
    let mut a = *a;
    let mut q = [[[0.0; L]; 3]; 3];
    for (k, row) in q.iter_mut().enumerate() {
        row[k] = [1.0; L];
    }
    // norm: the square root of the squares summed row by row (symmetric_eigen's sum)
    let mut sq = [0.0; L];
    for (e, x) in a.iter().flatten().enumerate() {
        for l in 0..L {
            sq[l] = if e == 0 {
                x[l] * x[l]
            } else {
                sq[l] + x[l] * x[l]
            };
        }
    }
    let norm: [f64; L] = std::array::from_fn(|l| sq[l].sqrt());
    let mut done = [false; L];
    for _ in 0..JACOBI_MAX_SWEEPS {
        for l in 0..L {
            let off = a[0][1][l] * a[0][1][l] + a[1][2][l] * a[1][2][l] + a[0][2][l] * a[0][2][l];
            done[l] |= off.sqrt() <= 1e-15 * norm[l];
        }
        if done.iter().all(|&d| d) {
            break;
        }
        for (p, r) in [(0, 1), (0, 2), (1, 2)] {
            let mut c = [0.0; L];
            let mut s = [0.0; L];
            let mut turn = [false; L];
            for l in 0..L {
                let apr = a[p][r][l];
                turn[l] = !done[l] & (apr != 0.0);
                let theta = (a[r][r][l] - a[p][p][l]) / (2.0 * apr);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                c[l] = 1.0 / (t * t + 1.0).sqrt();
                s[l] = t * c[l];
            }
            // a <- J^T a J with J the rotation in the (p, r) plane, where `turn`
            for row in a.iter_mut() {
                for l in 0..L {
                    let (akp, akr) = (row[p][l], row[r][l]);
                    let np = c[l] * akp - s[l] * akr;
                    let nr = s[l] * akp + c[l] * akr;
                    row[p][l] = if turn[l] { np } else { akp };
                    row[r][l] = if turn[l] { nr } else { akr };
                }
            }
            let (ap, ar) = (a[p], a[r]);
            for k in 0..3 {
                for l in 0..L {
                    let np = c[l] * ap[k][l] - s[l] * ar[k][l];
                    let nr = s[l] * ap[k][l] + c[l] * ar[k][l];
                    a[p][k][l] = if turn[l] { np } else { ap[k][l] };
                    a[r][k][l] = if turn[l] { nr } else { ar[k][l] };
                }
            }
            for row in q.iter_mut() {
                for l in 0..L {
                    let (qp, qr) = (row[p][l], row[r][l]);
                    let np = c[l] * qp - s[l] * qr;
                    let nr = s[l] * qp + c[l] * qr;
                    row[p][l] = if turn[l] { np } else { qp };
                    row[r][l] = if turn[l] { nr } else { qr };
                }
            }
        }
    }
    ([a[0][0], a[1][1], a[2][2]], q)
}

/// a b of `L` matrices at once, each lane's entry the sum `(a_i0 b_0j + a_i1 b_1j) + a_i2 b_2j`
/// of [`mul`] (the same bits).
#[inline(always)]
pub fn mul_lanes<const L: usize>(a: &Mat3Lanes<L>, b: &Mat3Lanes<L>) -> Mat3Lanes<L> {
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            std::array::from_fn(|l| {
                a[i][0][l] * b[0][j][l] + a[i][1][l] * b[1][j][l] + a[i][2][l] * b[2][j][l]
            })
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigen_reconstructs_and_inverse_inverts() {
        let s = [3.0, -1.0, 0.5, 0.7, -0.2, 1.1];
        let a = from_voigt(&s);
        let (lam, q) = symmetric_eigen(&a);
        let d = [[lam[0], 0.0, 0.0], [0.0, lam[1], 0.0], [0.0, 0.0, lam[2]]];
        let back = mul(&mul(&q, &d), &transpose(&q));
        let qtq = mul(&transpose(&q), &q);
        for i in 0..3 {
            for j in 0..3 {
                // round-off of a few rotations on entries of size ~3
                assert!((back[i][j] - a[i][j]).abs() < 1e-13, "q L q^T = a");
                assert!((qtq[i][j] - IDENTITY[i][j]).abs() < 1e-14, "q orthogonal");
            }
        }
        let inv = inverse(&a, 1e-12).unwrap();
        let id = mul(&a, &inv);
        for i in 0..3 {
            for j in 0..3 {
                assert!((id[i][j] - IDENTITY[i][j]).abs() < 1e-14, "a a^-1 = I");
            }
        }
    }
}
