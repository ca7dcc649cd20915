//! Stress and hourglass work per element block (a scene's `[[block]]`), for the per-block
//! energies of history.csv and report.json.
//!
//! The totals are measured on the summed nodal forces, W += (f(n) + f(n+1))/2 . dx over owned
//! nodes (`explicit`). Per block the same trapezoid is taken element by element on each
//! element's own corner forces, `W_e = sum_k (f_k(n) + f_k(n+1))/2 . dx_k`: every element lives
//! on exactly one rank and its corner forces and its nodes' dx are the same at any rank count,
//! so each element's work is too, and a block's is their sum on the grid of [`crate::exact`]
//! (the same bits at any rank count, in any element order). The sum over blocks is the total
//! (to round-off). The hourglass work is summed per element (`HexOutput::hg_work`), as for the
//! total. The sums ride in the reduction the totals use.
//!
//! Cost, with more than one block: each element's corner forces at the last accepted state
//! and at the current evaluation (384 B per element), 48 flops and 24 terms binned per element
//! and step. With one block the totals are the block's and nothing is kept.
use crate::exact::{Folds, Grid};

/// Per-block bookkeeping of one rank's elements.
#[derive(Debug, Clone)]
pub struct BlockWork {
    n_blocks: usize,
    /// Block of each local element.
    elem_block: Vec<u32>,
    /// Each element's corner nodes (local; empty with one block).
    corners: Vec<[u32; 8]>,
    /// Each element's corner forces at the last accepted state, and now (empty with one block).
    f_old: Vec<[[f64; 3]; 8]>,
    f_new: Vec<[[f64; 3]; 8]>,
    /// Hourglass work per block of the current force evaluation, J.
    hg_new: Vec<Folds>,
    /// The grid of the sums (the FE stage's energy grid).
    pub grid: Grid,
    /// The last step's local sums: `n_blocks` increments of stress + hourglass work stored in
    /// the elements (minus the work of the element forces on the nodes), then `n_blocks`
    /// increments of hourglass work, J.
    pub step_sums: Vec<Folds>,
}

impl BlockWork {
    /// Bookkeeping for elements `elems` (local node indices) in blocks `elem_block` (each below
    /// `n_blocks`).
    pub fn new(elems: &[[u32; 8]], elem_block: Vec<u32>, n_blocks: usize) -> BlockWork {
        assert_eq!(elems.len(), elem_block.len(), "one block per element");
        assert!(
            elem_block.iter().all(|&b| (b as usize) < n_blocks.max(1)),
            "block index out of range"
        );
        let n_blocks = n_blocks.max(1);
        let kept = if n_blocks > 1 { elems.len() } else { 0 };
        BlockWork {
            n_blocks,
            elem_block,
            corners: elems[..kept].to_vec(),
            f_old: vec![[[0.0; 3]; 8]; kept],
            f_new: vec![[[0.0; 3]; 8]; kept],
            hg_new: vec![[0.0; 3]; n_blocks],
            grid: Grid::covering(1.0),
            step_sums: vec![[0.0; 3]; 2 * n_blocks],
        }
    }

    /// Number of blocks (at least 1).
    pub fn n_blocks(&self) -> usize {
        self.n_blocks
    }

    /// Block of local element `e`.
    #[inline]
    pub fn block_of(&self, e: usize) -> usize {
        self.elem_block[e] as usize
    }

    /// Whether work is kept per block (more than one block).
    pub fn active(&self) -> bool {
        self.n_blocks > 1
    }

    /// Starts a force evaluation.
    pub fn begin(&mut self) {
        if self.active() {
            self.hg_new.iter_mut().for_each(|h| *h = [0.0; 3]);
        }
    }

    /// Adds element `e`'s corner forces and hourglass work.
    #[inline]
    pub fn add(&mut self, e: usize, force: &[[f64; 3]; 8], hg_work: f64) {
        if !self.active() {
            return;
        }
        self.f_new[e] = *force;
        let b = self.elem_block[e] as usize;
        self.grid.add(&mut self.hg_new[b], hg_work);
    }

    /// Accepts the evaluation as the new state, the nodes having moved by `dx(node)` since the
    /// last accepted one: fills `step_sums` (local, to be summed over ranks).
    pub fn accept(&mut self, dx: impl Fn(usize) -> [f64; 3]) {
        let nb = self.n_blocks;
        self.step_sums.iter_mut().for_each(|s| *s = [0.0; 3]);
        if !self.active() {
            return;
        }
        for e in 0..self.corners.len() {
            let (fo, fnew) = (&self.f_old[e], &self.f_new[e]);
            let b = self.elem_block[e] as usize;
            for (k, &n) in self.corners[e].iter().enumerate() {
                let d = dx(n as usize);
                for c in 0..3 {
                    let w = 0.5 * ((fo[k][c] + fnew[k][c]) * d[c]);
                    self.grid.add(&mut self.step_sums[b], -w);
                }
            }
        }
        self.step_sums[nb..].copy_from_slice(&self.hg_new);
        std::mem::swap(&mut self.f_old, &mut self.f_new);
    }

    /// The state a restart needs: each element's corner forces at the last accepted state (24
    /// values per element; none with one block).
    pub fn restart_state(&self) -> Vec<f64> {
        self.f_old.as_flattened().as_flattened().to_vec()
    }

    /// Sets the state `restart_state` gave; `false` when the length does not fit.
    pub fn set_restart_state(&mut self, f_old: &[f64]) -> bool {
        if f_old.len() != 24 * self.f_old.len() {
            return false;
        }
        self.f_old
            .as_flattened_mut()
            .as_flattened_mut()
            .copy_from_slice(f_old);
        true
    }

    /// Bytes held (for the report).
    pub fn bytes(&self) -> usize {
        self.elem_block.len() * 4 + self.corners.len() * (32 + 384) + self.hg_new.len() * 24
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact::value;

    /// Two unit cubes sharing a face (nodes 4..7), blocks 0 and 1: the per-block work sums to
    /// the total trapezoid over nodes, computed by hand from the summed nodal forces, and
    /// block 0's is element 0's own.
    #[test]
    fn blocks_sum_to_the_nodal_total() {
        let elems = [[0, 1, 2, 3, 4, 5, 6, 7], [4, 5, 6, 7, 8, 9, 10, 11]];
        let mut w = BlockWork::new(&elems, vec![0, 1], 2);
        let fa: [[f64; 3]; 8] = std::array::from_fn(|k| [k as f64, 1.0, -0.5 * k as f64]);
        let fb: [[f64; 3]; 8] = std::array::from_fn(|k| [0.25, -(k as f64), 2.0]);
        let dx = |n: usize| [0.01 * n as f64, -0.002, 0.003 * (n % 3) as f64];
        // Step 1 from zero forces, step 2 with the same forces: work = (0 + f)/2 . dx, then f . dx.
        for step in 1..=2 {
            w.begin();
            w.add(0, &fa, 0.5);
            w.add(1, &fb, 0.25);
            w.accept(dx);
            let mut nodal = [[0.0; 3]; 12];
            for (conn, f) in elems.iter().zip([fa, fb]) {
                for k in 0..8 {
                    for c in 0..3 {
                        nodal[conn[k] as usize][c] += f[k][c];
                    }
                }
            }
            let factor = if step == 1 { 0.5 } else { 1.0 };
            let total: f64 = (0..12)
                .map(|n| -factor * (0..3).map(|c| nodal[n][c] * dx(n)[c]).sum::<f64>())
                .sum();
            let sum = value(&w.step_sums[0]) + value(&w.step_sums[1]);
            assert!(
                (sum - total).abs() <= 1e-14 * total.abs().max(1.0),
                "step {step}: blocks {sum} vs nodal total {total} (round-off)"
            );
            let own0: f64 = (0..8)
                .map(|k| {
                    -factor
                        * (0..3)
                            .map(|c| fa[k][c] * dx(elems[0][k] as usize)[c])
                            .sum::<f64>()
                })
                .sum();
            assert!(
                (value(&w.step_sums[0]) - own0).abs() <= 1e-14,
                "block 0 is element 0's work"
            );
            let hg = [value(&w.step_sums[2]), value(&w.step_sums[3])];
            assert_eq!(hg, [0.5, 0.25], "hourglass work per block");
        }
    }
}
