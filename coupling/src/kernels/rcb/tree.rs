//! The tree of P-1 cuts that every rank holds after a balance (the paper's "expand"), and the
//! queries on it: which rank owns a point, which ranks a box overlaps.
//!
//! The tree's shape depends on P only: the group of ranks `[lo, hi)` splits into `[lo, mid)` and
//! `[mid, hi)` with `mid = lo + (hi - lo) / 2`, down to single ranks. Each split is a plane
//! `x[dim] = value`; the lower group owns `x[dim] < value`, the upper group `x[dim] >= value`
//! (half-open, so a point on a cut has exactly one owner). When many points share the cut
//! coordinate (a lattice plane, identical points), the split between them goes by global id:
//! a point with `x[dim] == value` belongs to the lower group when its id is below `tie_id`.
//! Point queries without an id treat such a plane as an ordinary half-open cut.

/// One cut: a plane normal to axis `dim`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cut {
    /// Axis (0, 1, 2).
    pub dim: usize,
    /// Coordinate of the plane.
    pub value: f64,
    /// Points exactly on the plane with an id below this go to the lower group (0: none do).
    pub tie_id: u64,
}

impl Cut {
    /// Whether a point with this position and id goes to the lower group.
    #[inline]
    pub fn is_low(&self, x: &[f64; 3], id: u64) -> bool {
        let c = x[self.dim];
        c < self.value || (c == self.value && id < self.tie_id)
    }
}

/// A node of the tree: the group `[lo, hi)` split at `mid`.
#[derive(Clone, Debug)]
pub(crate) struct Node {
    pub lo: i32,
    pub mid: i32,
    pub hi: i32,
    /// Child node of `[lo, mid)`, None when that is a single rank.
    pub left: Option<usize>,
    /// Child node of `[mid, hi)`, None when that is a single rank.
    pub right: Option<usize>,
    pub cut: Cut,
}

/// The cut tree of a P-rank decomposition (P-1 cuts).
#[derive(Clone, Debug)]
pub struct CutTree {
    nranks: i32,
    pub(crate) nodes: Vec<Node>,
}

impl CutTree {
    /// The tree's shape for `nranks` ranks, all cuts at 0 along x.
    pub fn skeleton(nranks: i32) -> CutTree {
        fn build(lo: i32, hi: i32, nodes: &mut Vec<Node>) -> Option<usize> {
            if hi - lo < 2 {
                return None;
            }
            let mid = lo + (hi - lo) / 2;
            let idx = nodes.len();
            nodes.push(Node {
                lo,
                mid,
                hi,
                left: None,
                right: None,
                cut: Cut {
                    dim: 0,
                    value: 0.0,
                    tie_id: 0,
                },
            });
            let l = build(lo, mid, nodes);
            let r = build(mid, hi, nodes);
            nodes[idx].left = l;
            nodes[idx].right = r;
            Some(idx)
        }
        let mut nodes = Vec::with_capacity(nranks.max(1) as usize - 1);
        build(0, nranks, &mut nodes);
        CutTree { nranks, nodes }
    }

    /// Number of ranks.
    pub fn nranks(&self) -> i32 {
        self.nranks
    }

    /// The cuts, in the tree's pre-order (the root first).
    pub fn cuts(&self) -> impl Iterator<Item = &Cut> {
        self.nodes.iter().map(|n| &n.cut)
    }

    /// The rank whose half-open box contains `x`.
    pub fn owner(&self, x: &[f64; 3]) -> i32 {
        self.walk(|c| x[c.dim] < c.value)
    }

    /// The rank that owns an item at `x` with global id `id` (ties on a cut go by id).
    pub fn owner_of_item(&self, x: &[f64; 3], id: u64) -> i32 {
        self.walk(|c| c.is_low(x, id))
    }

    fn walk(&self, go_low: impl Fn(&Cut) -> bool) -> i32 {
        if self.nodes.is_empty() {
            return 0;
        }
        let mut i = 0;
        loop {
            let n = &self.nodes[i];
            let next = if go_low(&n.cut) {
                n.left.ok_or(n.lo)
            } else {
                n.right.ok_or(n.mid)
            };
            match next {
                Ok(child) => i = child,
                Err(rank) => return rank,
            }
        }
    }

    /// Appends to `out` (ascending) every rank whose closed box overlaps the closed box
    /// `[min, max]`: the ranks a particle's sphere or a face's bounding box must be sent to.
    pub fn ranks_overlapping(&self, min: &[f64; 3], max: &[f64; 3], out: &mut Vec<i32>) {
        if self.nodes.is_empty() {
            out.push(0);
            return;
        }
        // Depth-first, lower side first, so ranks come out ascending.
        let mut stack: Vec<Result<usize, i32>> = vec![Ok(0)];
        while let Some(top) = stack.pop() {
            let i = match top {
                Ok(i) => i,
                Err(rank) => {
                    out.push(rank);
                    continue;
                }
            };
            let n = &self.nodes[i];
            let c = &n.cut;
            if max[c.dim] >= c.value {
                stack.push(n.right.ok_or(n.mid));
            }
            if min[c.dim] <= c.value {
                stack.push(n.left.ok_or(n.lo));
            }
        }
    }

    /// The box of `rank`: lower and upper bounds per axis (infinite at the outside). The rank
    /// owns the points with `lo <= x < hi`, plus points on a tie cut as [`Cut`] says.
    pub fn rank_box(&self, rank: i32) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::NEG_INFINITY; 3];
        let mut hi = [f64::INFINITY; 3];
        if self.nodes.is_empty() {
            return (lo, hi);
        }
        let mut i = 0;
        loop {
            let n = &self.nodes[i];
            let c = &n.cut;
            let next = if rank < n.mid {
                hi[c.dim] = hi[c.dim].min(c.value);
                n.left
            } else {
                lo[c.dim] = lo[c.dim].max(c.value);
                n.right
            };
            match next {
                Some(child) => i = child,
                None => return (lo, hi),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 5-rank tree with hand-placed cuts: queries against the boxes, checked point by point.
    #[test]
    fn queries_agree_with_boxes() {
        let mut t = CutTree::skeleton(5);
        assert_eq!(t.nodes.len(), 4, "P-1 cuts");
        for (k, n) in t.nodes.iter_mut().enumerate() {
            n.cut = Cut {
                dim: k % 3,
                value: 0.1 * k as f64,
                tie_id: 0,
            };
        }
        let mut s = 12345u64;
        let mut rnd = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for _ in 0..2000 {
            let x = [rnd(), rnd(), rnd()];
            let inside: Vec<i32> = (0..5)
                .filter(|&r| {
                    let (lo, hi) = t.rank_box(r);
                    (0..3).all(|d| lo[d] <= x[d] && x[d] < hi[d])
                })
                .collect();
            assert_eq!(
                inside,
                vec![t.owner(&x)],
                "exactly one half-open box holds {x:?}"
            );
            let h = [rnd().abs() * 0.3, rnd().abs() * 0.3, rnd().abs() * 0.3];
            let (bmin, bmax) = (
                [x[0] - h[0], x[1] - h[1], x[2] - h[2]],
                [x[0] + h[0], x[1] + h[1], x[2] + h[2]],
            );
            let brute: Vec<i32> = (0..5)
                .filter(|&r| {
                    let (lo, hi) = t.rank_box(r);
                    (0..3).all(|d| bmin[d] <= hi[d] && bmax[d] >= lo[d])
                })
                .collect();
            let mut got = Vec::new();
            t.ranks_overlapping(&bmin, &bmax, &mut got);
            assert_eq!(got, brute, "box {bmin:?}..{bmax:?}");
        }
    }
}
