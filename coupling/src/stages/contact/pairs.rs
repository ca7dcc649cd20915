//! contact_forces.csv: the contact force between each pair of bodies (docs/output.md), from
//! each body's total contact force and which pairs touched in the step.
//!
//! The push-back returns one force per contact node (its accumulated impulse over dt^2,
//! `contact::pushback`), the sum of what every contact touching the node gives it. Summed over
//! a body's nodes this is the body's total contact force F_a (exact over ranks), and F_a =
//! sum over the bodies b it touched of f_ab, the force on a from b (f_ba = -f_ab: each contact's
//! weights sum to zero, so it conserves momentum; a body's contacts with itself add nothing).
//! Given the graph of the pairs that touched in the step (an edge per pair with a contact),
//! the f_ab follow from the F_a by these balances alone where the graph has no cycle (two
//! bodies; a stack; a body between two others), the usual case. Where bodies touch in a ring
//! (three or more bodies each touching the next) the balances leave one force per ring
//! undetermined; the code then takes the smallest set of pair forces that balances every
//! body (least squares): exact on every acyclic part, an estimate on the ring (docs/output.md).
//!
//! The least-squares solution: with B the incidence matrix (B[a, e] = 1, B[b, e] = -1 for
//! the pair e = (a, b) oriented a < b, f_e its force on a), minimise |f|^2 subject to B f = F:
//! f = B^T phi with L phi = F, L = B B^T the graph's Laplacian (Lagrange multipliers phi), so
//! f_ab = phi_a - phi_b. L is singular on each connected part (phi up to a constant); its row
//! of the part's first body is dropped and that phi set to 0 (the dropped balance holds to
//! round-off as the part's forces sum to zero). On a tree this is the unique solution.

/// The force on body a from body b for each pair (a, b) of `pairs` (a < b), N, given each
/// body's total contact force `total` and whether each pair touched (`touched`, aligned with
/// `pairs`); zero for a pair that did not touch.
pub fn pair_forces(
    total: &[[f64; 3]],
    pairs: &[(usize, usize)],
    touched: &[bool],
) -> Vec<[f64; 3]> {
    let n = total.len();
    let edges: Vec<(usize, usize)> = pairs
        .iter()
        .zip(touched)
        .filter(|(_, &t)| t)
        .map(|(p, _)| *p)
        .collect();
    // The connected parts of the touching graph, each body labelled by its part's first body.
    let mut part: Vec<usize> = (0..n).collect();
    fn root(part: &mut [usize], mut a: usize) -> usize {
        while part[a] != a {
            a = part[a];
        }
        a
    }
    for &(a, b) in &edges {
        let (ra, rb) = (root(&mut part, a), root(&mut part, b));
        part[ra.max(rb)] = ra.min(rb);
    }
    let mut phi = vec![[0.0; 3]; n];
    for r in 0..n {
        if root(&mut part, r) != r {
            continue;
        }
        let members: Vec<usize> = (0..n).filter(|&a| root(&mut part, a) == r).collect();
        if members.len() < 2 {
            continue;
        }
        // The reduced Laplacian of this part (its first body dropped) and the totals.
        let rest = &members[1..];
        let idx = |a: usize| rest.iter().position(|&m| m == a);
        let k = rest.len();
        let mut l = vec![vec![0.0; k]; k];
        for &(a, b) in &edges {
            if root(&mut part, a) != r {
                continue;
            }
            let (ia, ib) = (idx(a), idx(b));
            if let Some(i) = ia {
                l[i][i] += 1.0;
            }
            if let Some(j) = ib {
                l[j][j] += 1.0;
            }
            if let (Some(i), Some(j)) = (ia, ib) {
                l[i][j] -= 1.0;
                l[j][i] -= 1.0;
            }
        }
        let rhs: Vec<[f64; 3]> = rest.iter().map(|&a| total[a]).collect();
        let x = solve(l, rhs);
        for (&a, xa) in rest.iter().zip(x) {
            phi[a] = xa;
        }
    }
    pairs
        .iter()
        .zip(touched)
        .map(|(&(a, b), &t)| {
            if t {
                std::array::from_fn(|c| phi[a][c] - phi[b][c])
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

/// Solves `l x = rhs` (symmetric positive definite: a connected graph's Laplacian with one
/// row and column dropped) by Gaussian elimination without pivoting, for three right-hand
/// sides at once. Small: one row per body of a touching group.
fn solve(mut l: Vec<Vec<f64>>, mut rhs: Vec<[f64; 3]>) -> Vec<[f64; 3]> {
    let k = l.len();
    for p in 0..k {
        for i in p + 1..k {
            let s = l[i][p] / l[p][p];
            if s == 0.0 {
                continue;
            }
            for j in p..k {
                l[i][j] -= s * l[p][j];
            }
            let rp = rhs[p];
            for c in 0..3 {
                rhs[i][c] -= s * rp[c];
            }
        }
    }
    let mut x = vec![[0.0; 3]; k];
    for p in (0..k).rev() {
        for c in 0..3 {
            let mut v = rhs[p][c];
            for j in p + 1..k {
                v -= l[p][j] * x[j][c];
            }
            x[p][c] = v / l[p][p];
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two bodies: the pair's force is the first body's total.
    #[test]
    fn two_bodies() {
        let f = pair_forces(&[[1.0, 2.0, 3.0], [-1.0, -2.0, -3.0]], &[(0, 1)], &[true]);
        assert_eq!(f, vec![[1.0, 2.0, 3.0]]);
    }

    /// A stack (0 on 1 on 2): the balances give each pair's force; an untouched pair is zero.
    #[test]
    fn stack() {
        // f01 = 1 (on 0 from 1), f12 = 3 (on 1 from 2): F0 = 1, F1 = -1 + 3, F2 = -3.
        let pairs = [(0, 1), (0, 2), (1, 2)];
        let f = pair_forces(
            &[[1.0; 3], [2.0; 3], [-3.0; 3]],
            &pairs,
            &[true, false, true],
        );
        assert_eq!(f, vec![[1.0; 3], [0.0; 3], [3.0; 3]]);
    }

    /// A ring of three: the balances hold and the solution is the least-squares one (a
    /// circulation added to it only lengthens it).
    #[test]
    fn ring_balances() {
        let total = [[1.0, 0.0, 0.5], [2.0, -1.0, 0.0], [-3.0, 1.0, -0.5]];
        let pairs = [(0, 1), (0, 2), (1, 2)];
        let f = pair_forces(&total, &pairs, &[true; 3]);
        for c in 0..3 {
            let f0 = f[0][c] + f[1][c];
            let f1 = -f[0][c] + f[2][c];
            let f2 = -f[1][c] - f[2][c];
            assert!((f0 - total[0][c]).abs() < 1e-12);
            assert!((f1 - total[1][c]).abs() < 1e-12);
            assert!((f2 - total[2][c]).abs() < 1e-12);
            // Orthogonal to the ring's circulation (1, -1, 1) on (01, 02, 12).
            assert!((f[0][c] - f[1][c] + f[2][c]).abs() < 1e-12);
        }
    }
}
