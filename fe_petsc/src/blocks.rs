//! Stress and hourglass work per element block (a scene's `[[block]]`), for the per-block
//! energies of history.csv and report.json.
//!
//! The totals are measured on the summed nodal forces, W += (f(n) + f(n+1))/2 . dx over owned
//! nodes (`explicit`). Per block the same trapezoid is taken on each rank's own element forces
//! before the ghost exchange, kept per (local node, block) "slot": a node touched by elements of
//! one block has one slot, a node on an interface between blocks one per block. Every element
//! lives on exactly one rank and every copy of a node moves by the same dx, so the sum over
//! ranks and slots of a block is that block's share of the total, and the sum over blocks is the
//! total (to round-off): no second exchange, and the sums ride in the reduction the totals use.
//! The hourglass work is summed per element (`HexOutput::hg_work`), as for the total.
//!
//! Cost: one more scatter-add of the 8 corner forces per element (24 flops, 192 bytes to a
//! slot array about the size of the nodal force array) and one pass over the slots per step.
//! With one block the totals are the block's and nothing is kept.

/// Per-block bookkeeping of one rank's elements.
#[derive(Debug, Clone, Default)]
pub struct BlockWork {
    n_blocks: usize,
    /// Block of each local element.
    elem_block: Vec<u32>,
    /// Slot of each element corner (empty with one block).
    corner_slot: Vec<[u32; 8]>,
    /// Local node and block of each slot.
    slot_node: Vec<u32>,
    slot_block: Vec<u32>,
    /// This rank's element forces per slot at the last accepted state, and now.
    f_old: Vec<[f64; 3]>,
    f_new: Vec<[f64; 3]>,
    /// Hourglass work per block of the current force evaluation, J.
    hg_new: Vec<f64>,
    /// The last step's local sums: `n_blocks` increments of stress + hourglass work stored in
    /// the elements (minus the work of the element forces on the nodes), then `n_blocks`
    /// increments of hourglass work, J.
    pub step_sums: Vec<f64>,
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
        let mut w = BlockWork {
            n_blocks,
            step_sums: vec![0.0; 2 * n_blocks],
            hg_new: vec![0.0; n_blocks],
            ..Default::default()
        };
        if n_blocks > 1 {
            let nn = elems
                .iter()
                .flatten()
                .map(|&n| n as usize + 1)
                .max()
                .unwrap_or(0);
            // (node) -> [(block, slot)]: few entries per node.
            let mut at: Vec<Vec<(u32, u32)>> = vec![Vec::new(); nn];
            for (conn, &b) in elems.iter().zip(&elem_block) {
                let mut slots = [0u32; 8];
                for (k, &n) in conn.iter().enumerate() {
                    let list = &mut at[n as usize];
                    slots[k] = match list.iter().find(|(bb, _)| *bb == b) {
                        Some(&(_, s)) => s,
                        None => {
                            let s = w.slot_node.len() as u32;
                            w.slot_node.push(n);
                            w.slot_block.push(b);
                            list.push((b, s));
                            s
                        }
                    };
                }
                w.corner_slot.push(slots);
            }
            w.f_old = vec![[0.0; 3]; w.slot_node.len()];
            w.f_new = w.f_old.clone();
        }
        w.elem_block = elem_block;
        w
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
            self.f_new.iter_mut().for_each(|f| *f = [0.0; 3]);
            self.hg_new.iter_mut().for_each(|h| *h = 0.0);
        }
    }

    /// Adds element `e`'s corner forces and hourglass work.
    #[inline]
    pub fn add(&mut self, e: usize, force: &[[f64; 3]; 8], hg_work: f64) {
        if !self.active() {
            return;
        }
        for (k, &s) in self.corner_slot[e].iter().enumerate() {
            let f = &mut self.f_new[s as usize];
            f[0] += force[k][0];
            f[1] += force[k][1];
            f[2] += force[k][2];
        }
        self.hg_new[self.elem_block[e] as usize] += hg_work;
    }

    /// Accepts the evaluation as the new state, the nodes having moved by `dx(node)` since the
    /// last accepted one: fills `step_sums` (local, to be summed over ranks).
    pub fn accept(&mut self, dx: impl Fn(usize) -> [f64; 3]) {
        let nb = self.n_blocks;
        self.step_sums.iter_mut().for_each(|s| *s = 0.0);
        if !self.active() {
            return;
        }
        for s in 0..self.slot_node.len() {
            let d = dx(self.slot_node[s] as usize);
            let (fo, fnew) = (self.f_old[s], self.f_new[s]);
            let w = 0.5
                * ((fo[0] + fnew[0]) * d[0] + (fo[1] + fnew[1]) * d[1] + (fo[2] + fnew[2]) * d[2]);
            self.step_sums[self.slot_block[s] as usize] -= w;
        }
        self.step_sums[nb..].copy_from_slice(&self.hg_new);
        std::mem::swap(&mut self.f_old, &mut self.f_new);
    }

    /// The state a restart needs: the element forces per slot at the last accepted state.
    pub fn restart_state(&self) -> Vec<f64> {
        self.f_old.as_flattened().to_vec()
    }

    /// The local node and the block of each slot (the keys of `restart_state`'s forces: a
    /// restart on another rank count remaps them by global node id and block).
    pub fn slots(&self) -> (&[u32], &[u32]) {
        (&self.slot_node, &self.slot_block)
    }

    /// Sets the state `restart_state` gave; `false` when the length does not fit.
    pub fn set_restart_state(&mut self, f_old: &[f64]) -> bool {
        if f_old.len() != 3 * self.f_old.len() {
            return false;
        }
        self.f_old.as_flattened_mut().copy_from_slice(f_old);
        true
    }

    /// Bytes held (for the report).
    pub fn bytes(&self) -> usize {
        self.elem_block.len() * 4
            + self.corner_slot.len() * 32
            + self.slot_node.len() * (8 + 48)
            + self.hg_new.len() * 24
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two unit cubes sharing a face (nodes 4..7), blocks 0 and 1: the shared face gets two
    /// slots per node; the per-block work sums to the total trapezoid over nodes, computed by
    /// hand from the summed nodal forces.
    #[test]
    fn blocks_sum_to_the_nodal_total() {
        let elems = [[0, 1, 2, 3, 4, 5, 6, 7], [4, 5, 6, 7, 8, 9, 10, 11]];
        let mut w = BlockWork::new(&elems, vec![0, 1], 2);
        assert_eq!(w.slot_node.len(), 16, "8 + 8 slots (4 shared nodes twice)");
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
            let sum = w.step_sums[0] + w.step_sums[1];
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
                (w.step_sums[0] - own0).abs() <= 1e-14,
                "block 0 is element 0's work"
            );
            assert_eq!(&w.step_sums[2..], &[0.5, 0.25], "hourglass work per block");
        }
    }
}
