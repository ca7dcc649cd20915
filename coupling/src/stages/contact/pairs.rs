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

/// contact_forces.csv's bookkeeping. Its bodies ("vertices") are the scene's blocks, then its
/// `[[particles]]` entries (where particles take part in contact), then one for particles of
/// failed elements; its columns the pairs (block, block) of blocks with contact faces, then
/// (block, particles entry), then (where failed elements become particles that take part)
/// (block, failed particles) named `<block>-failed_particles`, each in scene order.
#[derive(Debug, Clone, Default)]
pub struct PairForces {
    /// The columns' pairs of vertices, and their names.
    pairs: Vec<(usize, usize)>,
    /// See `pairs`.
    pub names: Vec<String>,
    /// Blocks + particle entries + 1.
    n_vertices: usize,
    /// The vertex of each contact body (its block).
    body_vertex: Vec<usize>,
    /// The first particle entry's vertex (the number of blocks) and the entries.
    first_entry: usize,
    /// See `first_entry`.
    n_entries: usize,
    /// The last step's nonzero push-back forces on this rank's owned contact nodes and
    /// particles, by vertex, N.
    last_forces: Vec<(usize, [f64; 3])>,
    /// The pairs of vertices (a < b) this rank's contacts touched in the last step.
    last_edges: Vec<(usize, usize)>,
}

impl PairForces {
    /// The columns of a scene's `blocks` (those with contact faces: `in_contact`) and, where
    /// particles take part, its `particle_sets`; `body_block`: each contact body's block.
    pub fn new(
        blocks: &[String],
        in_contact: &[bool],
        body_block: &[u32],
        (particle_sets, failed_particles): (&[String], bool),
    ) -> PairForces {
        let nb = blocks.len();
        let mut pairs = Vec::new();
        let mut names = Vec::new();
        let with_faces = (0..nb).filter(|&a| in_contact[a]);
        for a in with_faces.clone() {
            for b in a + 1..nb {
                if in_contact[b] {
                    pairs.push((a, b));
                    names.push(format!("{}-{}", blocks[a], blocks[b]));
                }
            }
        }
        for a in with_faces.clone() {
            for (k, set) in particle_sets.iter().enumerate() {
                pairs.push((a, nb + k));
                names.push(format!("{}-{set}", blocks[a]));
            }
        }
        if failed_particles {
            for a in with_faces {
                pairs.push((a, nb + particle_sets.len()));
                names.push(format!("{}-failed_particles", blocks[a]));
            }
        }
        PairForces {
            pairs,
            names,
            n_vertices: nb + particle_sets.len() + 1,
            // a body outside every block (not in a scene) counts with the failed particles
            body_vertex: body_block
                .iter()
                .map(|&b| (b as usize).min(nb + particle_sets.len()))
                .collect(),
            first_entry: nb,
            n_entries: particle_sets.len(),
            ..PairForces::default()
        }
    }

    /// The vertex of a particle of `[[particles]]` entry `entry` (`None`: a failed element's).
    pub fn particle_vertex(&self, entry: Option<u32>) -> usize {
        match entry {
            Some(k) if (k as usize) < self.n_entries => self.first_entry + k as usize,
            _ => self.first_entry + self.n_entries,
        }
    }

    /// Keeps a step's forces and touching pairs: `nodes` the owned contact nodes' (body,
    /// force as applied), `particles` the owned particles' (vertex, force), `body_pairs` and
    /// `particle_faces` (a particle's vertex, the face's body) the pairs this rank's contacts
    /// touched.
    pub fn record(
        &mut self,
        nodes: impl Iterator<Item = (u32, [f64; 3])>,
        particles: impl Iterator<Item = (usize, [f64; 3])>,
        body_pairs: &[(u32, u32)],
        particle_faces: impl Iterator<Item = (usize, u32)>,
    ) {
        let bv = &self.body_vertex;
        self.last_forces.clear();
        self.last_forces.extend(
            nodes
                .map(|(b, f)| (bv[b as usize], f))
                .chain(particles)
                .filter(|(_, f)| *f != [0.0; 3]),
        );
        self.last_edges.clear();
        let mesh = body_pairs
            .iter()
            .map(|&(p, q)| (bv[p as usize], bv[q as usize]));
        let held = particle_faces.map(|(v, q)| (v, bv[q as usize]));
        self.last_edges.extend(
            mesh.chain(held)
                .filter(|(a, b)| a != b)
                .map(|(a, b)| (a.min(b), a.max(b))),
        );
        self.last_edges.sort_unstable();
        self.last_edges.dedup();
    }

    /// This rank's terms of each vertex's total force (`terms[3 v + c]`, component c of
    /// vertex v) and its flags of the pairs of vertices touched (`flags[a n + b]`, 1 for a
    /// pair this rank's contacts touched), for [`crate::output::exact_forces`].
    pub fn terms(&self) -> (Vec<Vec<f64>>, Vec<f64>) {
        let nv = self.n_vertices;
        let mut terms = vec![Vec::new(); 3 * nv];
        for (v, f) in &self.last_forces {
            for c in 0..3 {
                terms[3 * v + c].push(f[c]);
            }
        }
        let mut touched = vec![0.0; nv * nv];
        for &(a, b) in &self.last_edges {
            touched[a * nv + b] = 1.0;
        }
        (terms, touched)
    }

    /// The row: the force on a from b for each column's pair (a, b) in the last step, N, from
    /// the vertices' totals and the pairs touched on any rank ([`PairForces::terms`] reduced).
    pub fn row(&self, total: &[[f64; 3]], touched: &[f64]) -> Vec<[f64; 3]> {
        let nv = self.n_vertices;
        let edges: Vec<(usize, usize)> = (0..nv * nv)
            .filter(|&k| touched[k] != 0.0)
            .map(|k| (k / nv, k % nv))
            .collect();
        let f = pair_forces(total, &edges);
        self.pairs
            .iter()
            .map(|p| edges.binary_search(p).map_or([0.0; 3], |k| f[k]))
            .collect()
    }
}

/// The force on body a from body b for each pair (a, b) of `edges` (a < b, each once: the
/// pairs that touched), N, given each body's total contact force `total`.
pub fn pair_forces(total: &[[f64; 3]], edges: &[(usize, usize)]) -> Vec<[f64; 3]> {
    let n = total.len();
    // The connected parts of the touching graph, each body labelled by its part's first body.
    let mut part: Vec<usize> = (0..n).collect();
    fn root(part: &mut [usize], mut a: usize) -> usize {
        while part[a] != a {
            a = part[a];
        }
        a
    }
    for &(a, b) in edges {
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
        for &(a, b) in edges {
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
    edges
        .iter()
        .map(|&(a, b)| std::array::from_fn(|c| phi[a][c] - phi[b][c]))
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
        let f = pair_forces(&[[1.0, 2.0, 3.0], [-1.0, -2.0, -3.0]], &[(0, 1)]);
        assert_eq!(f, vec![[1.0, 2.0, 3.0]]);
    }

    /// A stack (0 on 1 on 2) and a body touching nothing: the balances give each pair's force.
    #[test]
    fn stack() {
        // f01 = 1 (on 0 from 1), f12 = 3 (on 1 from 2): F0 = 1, F1 = -1 + 3, F2 = -3.
        let f = pair_forces(
            &[[1.0; 3], [2.0; 3], [-3.0; 3], [0.0; 3]],
            &[(0, 1), (1, 2)],
        );
        assert_eq!(f, vec![[1.0; 3], [3.0; 3]]);
    }

    /// A ring of three: the balances hold and the solution is the least-squares one (a
    /// circulation added to it only lengthens it).
    #[test]
    fn ring_balances() {
        let total = [[1.0, 0.0, 0.5], [2.0, -1.0, 0.0], [-3.0, 1.0, -0.5]];
        let pairs = [(0, 1), (0, 2), (1, 2)];
        let f = pair_forces(&total, &pairs);
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
