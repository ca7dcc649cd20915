//! Bucket search: a uniform grid of cells over the faces' search boxes.
//!
//! Each face is listed in every cell its box overlaps (compressed rows: `start`, `items`). A query
//! box visits the cells it overlaps and reports the faces listed there. Cell size: the mean extent
//! of the faces' boxes, enlarged until the grid has at most `CELLS_PER_OBJECT` cells per face (so a
//! few far-apart faces do not make a huge empty grid). Building costs O(faces x cells per face),
//! a query O(cells visited + faces reported): the search grows with the number of objects, not its
//! square, as long as faces have comparable sizes.

use crate::data::Aabb;

/// Upper bound on grid cells per face (plus [`MIN_CELLS`]).
const CELLS_PER_OBJECT: usize = 4;
/// Cells always allowed, whatever the number of faces.
const MIN_CELLS: usize = 64;
/// Growth of the cell size per refusal of a too-fine grid.
const CELL_GROWTH: f64 = 1.25;

pub(crate) struct Grid {
    lo: [f64; 3],
    inv_h: f64,
    dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Grid {
    /// A grid over `boxes` (one per face, indexed as the faces are).
    pub(crate) fn build(boxes: &[Aabb]) -> Grid {
        let mut domain = Aabb::EMPTY;
        let mut extent_sum = 0.0;
        for b in boxes {
            domain.include(b.min);
            domain.include(b.max);
            extent_sum += (0..3).map(|k| b.max[k] - b.min[k]).fold(0.0, f64::max);
        }
        if boxes.is_empty() {
            return Grid {
                lo: [0.0; 3],
                inv_h: 1.0,
                dims: [1, 1, 1],
                start: vec![0, 0],
                items: Vec::new(),
            };
        }
        let span: Vec<f64> = (0..3).map(|k| domain.max[k] - domain.min[k]).collect();
        let span_max = span.iter().fold(0.0, |a: f64, &s| a.max(s));
        let mut h = (extent_sum / boxes.len() as f64).max(span_max * 1e-9);
        if h.is_nan() || h <= 0.0 || !h.is_finite() {
            h = 1.0;
        }
        let cap = CELLS_PER_OBJECT * boxes.len() + MIN_CELLS;
        let dims = loop {
            let d: Vec<usize> = span
                .iter()
                .map(|&s| ((s / h).floor() as usize + 1).max(1))
                .collect();
            if d[0].saturating_mul(d[1]).saturating_mul(d[2]) <= cap {
                break [d[0], d[1], d[2]];
            }
            h *= CELL_GROWTH;
        };
        let mut g = Grid {
            lo: domain.min,
            inv_h: 1.0 / h,
            dims,
            start: vec![0; dims[0] * dims[1] * dims[2] + 1],
            items: Vec::new(),
        };
        // Counting sort into cells: count, prefix sum, fill.
        for b in boxes {
            if let Some((lo, hi)) = g.cell_range(b) {
                let mut counts = std::mem::take(&mut g.start);
                g.each_cell(lo, hi, |c| counts[c + 1] += 1);
                g.start = counts;
            }
        }
        for c in 0..g.start.len() - 1 {
            g.start[c + 1] += g.start[c];
        }
        let mut fill = g.start.clone();
        let mut items = vec![0u32; g.start[g.start.len() - 1] as usize];
        for (f, b) in boxes.iter().enumerate() {
            if let Some((lo, hi)) = g.cell_range(b) {
                g.each_cell(lo, hi, |c| {
                    items[fill[c] as usize] = f as u32;
                    fill[c] += 1;
                });
            }
        }
        g.items = items;
        g
    }

    fn cell(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.dims[1] + j) * self.dims[0] + i
    }

    /// The range of cells a box overlaps, clamped to the grid; `None` if it misses the grid.
    fn cell_range(&self, b: &Aabb) -> Option<([usize; 3], [usize; 3])> {
        let mut lo = [0usize; 3];
        let mut hi = [0usize; 3];
        for k in 0..3 {
            let a = (b.min[k] - self.lo[k]) * self.inv_h;
            let z = (b.max[k] - self.lo[k]) * self.inv_h;
            let top = (self.dims[k] - 1) as f64;
            // Cell `top` covers [top, top + 1) in grid units; NaN boxes miss.
            if z.is_nan() || a.is_nan() || z < 0.0 || a >= top + 1.0 {
                return None;
            }
            lo[k] = a.max(0.0).min(top) as usize;
            hi[k] = z.max(0.0).min(top) as usize;
        }
        Some((lo, hi))
    }

    /// Calls `f` with the index of every cell in the inclusive range `lo..=hi`.
    fn each_cell(&self, lo: [usize; 3], hi: [usize; 3], mut f: impl FnMut(usize)) {
        for k in lo[2]..=hi[2] {
            for j in lo[1]..=hi[1] {
                for i in lo[0]..=hi[0] {
                    f(self.cell(i, j, k));
                }
            }
        }
    }

    /// Calls `visit` with every face listed in a cell that `q` overlaps (a face may come several
    /// times; the caller removes repeats).
    pub(crate) fn query(&self, q: &Aabb, mut visit: impl FnMut(u32)) {
        let Some((lo, hi)) = self.cell_range(q) else {
            return;
        };
        self.each_cell(lo, hi, |c| {
            for &f in &self.items[self.start[c] as usize..self.start[c + 1] as usize] {
                visit(f);
            }
        });
    }
}
