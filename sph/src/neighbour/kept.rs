//! Pair lists kept between steps: [`KeptPairs`] on one rank (rebuilt when a particle has moved
//! half its skin), [`KeptBoxPairs`] for a box of a kept decomposition, and the candidates of
//! one box.
use super::*;

/// Skin of [`KeptPairs`], in smoothing lengths (the smallest h): the list is rebuilt when a
/// particle has moved half of it. Measured on the dam break (one rank): 0.1 ... 0.3 h alike.
pub const KEPT_PAIRS_SKIN_H: f64 = 0.2;

/// Pair candidates kept over several steps (a Verlet list) for a box whose every pair is
/// interior (no periodic box, no ghosts, the box all of space): every pair whose spheres,
/// each grown by half the skin, overlapped at the build. While no particle has moved half the
/// skin since (and h and the particles are the same), every overlapping pair is among them
/// (a pair's distance changes by at most the two motions), and [`KeptPairs::filter`] with the
/// search's own overlap test gives the pairs a fresh [`pairs_in_box`] gives (in another order);
/// [`KeptPairs::continuity_and_force_pass`] applies the same test inside the pass.
///
/// The candidates are held as slots of a packing order: the entries in the order in which
/// they first appear in the candidate list (the search's cell order), so that the pass reads
/// its packed inputs nearly in sequence (a pair's ends are mostly a few slots from the last
/// pair's). Entries without candidates are not packed.
#[derive(Clone, Debug)]
pub struct KeptPairs {
    /// Candidates as slot indices, in the search's order.
    pairs: Vec<(u32, u32)>,
    /// Entry of each slot.
    order: Vec<u32>,
    x_ref: Vec<[f64; 3]>,
    h_ref: Vec<f64>,
    id_ref: Vec<u64>,
    skin: f64,
    /// The fused pass's packed inputs and sums, reused.
    buf: PassBuffers,
}

impl KeptPairs {
    /// The kept list as plain arrays (a restart continues with the very same list, so the
    /// pairs are summed in the same order): pairs (entry indices), reference positions,
    /// smoothing lengths and ids, and the skin.
    #[allow(clippy::type_complexity)]
    pub fn to_parts(&self) -> (Vec<[u32; 2]>, Vec<[f64; 3]>, Vec<f64>, Vec<u64>, f64) {
        (
            self.entry_pairs().map(|(a, b)| [a, b]).collect(),
            self.x_ref.clone(),
            self.h_ref.clone(),
            self.id_ref.clone(),
            self.skin,
        )
    }

    /// The list [`KeptPairs::to_parts`] gave.
    pub fn from_parts(
        pairs: Vec<[u32; 2]>,
        x_ref: Vec<[f64; 3]>,
        h_ref: Vec<f64>,
        id_ref: Vec<u64>,
        skin: f64,
    ) -> Self {
        let n = id_ref.len();
        Self::from_entry_pairs(
            pairs.into_iter().map(|[a, b]| (a, b)).collect(),
            n,
            x_ref,
            h_ref,
            id_ref,
            skin,
        )
    }

    /// The candidates `pairs` (entry indices, `n` entries) as slots of their first-appearance
    /// order.
    fn from_entry_pairs(
        mut pairs: Vec<(u32, u32)>,
        n: usize,
        x_ref: Vec<[f64; 3]>,
        h_ref: Vec<f64>,
        id_ref: Vec<u64>,
        skin: f64,
    ) -> Self {
        let mut slot = vec![u32::MAX; n];
        let mut order = Vec::new();
        let mut slot_of = |e: u32| {
            let s = &mut slot[e as usize];
            if *s == u32::MAX {
                *s = order.len() as u32;
                order.push(e);
            }
            *s
        };
        for pr in pairs.iter_mut() {
            *pr = (slot_of(pr.0), slot_of(pr.1));
        }
        KeptPairs {
            pairs,
            order,
            x_ref,
            h_ref,
            id_ref,
            skin,
            buf: PassBuffers::default(),
        }
    }

    /// The candidates as entry indices, in their order.
    fn entry_pairs(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        let o = &self.order;
        self.pairs
            .iter()
            .map(|&(a, b)| (o[a as usize], o[b as usize]))
    }

    /// Candidates of `parts` in the box `lo..hi` (which must hold every sphere: all of space).
    /// One box of all of space with no periodic box and no ghosts (the one-rank case) takes
    /// `one_box_candidates`, else the general search ([`KeptPairs::build_by_search`]): the
    /// same candidates in the same order.
    pub fn build(parts: &Particles, opts: &SearchOptions, lo: [f64; 3], hi: [f64; 3]) -> Self {
        let all_space =
            lo.iter().all(|c| *c == f64::NEG_INFINITY) && hi.iter().all(|c| *c == f64::INFINITY);
        // every pair interior (no COI), positions as the search bins them
        let one_box = all_space
            && opts.periodic.is_none()
            && parts.n_owned == parts.len()
            && parts.x == parts.x_real;
        if !one_box {
            return Self::build_by_search(parts, opts, lo, hi);
        }
        let skin = kept_pairs_skin(parts);
        let grown: Vec<f64> = parts.h.iter().map(|h| h + 0.5 * skin).collect();
        let primary: Vec<bool> = if opts.skip_fixed_pairs {
            parts.fixed.iter().map(|f| !f).collect()
        } else {
            Vec::new()
        };
        Self::from_entry_pairs(
            one_box_candidates(&parts.x, &grown, &parts.id, &primary),
            parts.len(),
            parts.x_real.clone(),
            parts.h.clone(),
            parts.id.clone(),
            skin,
        )
    }

    /// [`KeptPairs::build`] through the general search ([`pairs_in_box`] on the particles
    /// with grown spheres), whatever the box.
    pub fn build_by_search(
        parts: &Particles,
        opts: &SearchOptions,
        lo: [f64; 3],
        hi: [f64; 3],
    ) -> Self {
        let skin = kept_pairs_skin(parts);
        let mut grown = parts.clone();
        for h in grown.h.iter_mut() {
            *h += 0.5 * skin;
        }
        Self::from_entry_pairs(
            pairs_in_box(&grown, opts, lo, hi),
            parts.len(),
            parts.x_real.clone(),
            parts.h.clone(),
            parts.id.clone(),
            skin,
        )
    }

    /// Whether the candidates still hold every overlapping pair of `parts`: the same entries
    /// (ids) with the same h, none moved half the skin. One sweep over the entries with the
    /// three tests and-ed, no early exit (a list is valid at almost every step, so every entry
    /// is looked at anyway, and the sweep has no jump to mispredict). "Moved half the skin" is
    /// 2 |d| >= skin, tested as |d|^2 >= the smallest |d|^2 for which the rounded
    /// 2 sqrt(|d|^2) reaches the skin (found once per call): the same answer, bit for bit,
    /// without a square root per entry (~17 instructions and 80 bytes per entry).
    pub fn still_valid(&self, parts: &Particles) -> bool {
        let n = parts.len();
        if self.id_ref.len() != n || self.h_ref.len() != n || self.x_ref.len() != n {
            return false;
        }
        let (id, h, x) = (&parts.id[..n], &parts.h[..n], &parts.x_real[..n]);
        let (id_ref, h_ref, x_ref) = (&self.id_ref[..n], &self.h_ref[..n], &self.x_ref[..n]);
        let limit = moved_limit(self.skin);
        (0..n).fold(true, |ok, i| {
            let (a, b) = (x[i], x_ref[i]);
            let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
            let near = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < limit;
            ok & (id[i] == id_ref[i]) & (h[i] == h_ref[i]) & near
        })
    }

    /// The overlapping pairs (the search's test for interior pairs: r^2 < (h_a + h_b)^2 on real
    /// positions), counting each pair's two entries in `count` (one per entry, zeroed first).
    pub fn filter(&self, parts: &Particles, count: &mut Vec<u32>) -> Vec<(u32, u32)> {
        let (x, h) = (&parts.x_real, &parts.h);
        count.clear();
        count.resize(parts.len(), 0);
        // each slot's position and h packed in slot order (read nearly in sequence), then every
        // candidate tested without a jump: written, and kept (the end advanced, the counts
        // raised) by the test's outcome, 0 or 1
        let xh: Vec<[f64; 4]> = self
            .order
            .iter()
            .map(|&e| {
                let (p, r) = (x[e as usize], h[e as usize]);
                [p[0], p[1], p[2], r]
            })
            .collect();
        let mut list = vec![(0u32, 0u32); self.pairs.len()];
        let mut n = 0;
        for &(sa, sb) in &self.pairs {
            let (a, b) = (xh[sa as usize], xh[sb as usize]);
            let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let reach = a[3] + b[3];
            let close = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < reach * reach;
            let (i, j) = (self.order[sa as usize], self.order[sb as usize]);
            list[n] = (i, j);
            n += close as usize;
            count[i as usize] += close as u32;
            count[j as usize] += close as u32;
        }
        list.truncate(n);
        list
    }

    /// `continuity_and_force_pass` over the pairs [`KeptPairs::filter`] gives, in its order
    /// (the same sums, bit for bit), with the filter's test applied to each candidate inside
    /// the pass (no filtered list is written), counting each pair's two entries in `count`
    /// (zeroed first). Returns the pair work rate and the number of pairs.
    /// Sums exact on `g` ([`crate::exact`]), largest terms into `m`.
    pub fn continuity_and_force_pass(
        &mut self,
        parts: &mut Particles,
        params: &Params,
        count: &mut Vec<u32>,
        g: &PassGrids,
        m: &mut TermMax,
    ) -> (PairWork, usize) {
        let out = kept_continuity_and_force_pass(
            &self.pairs,
            &self.order,
            parts,
            params,
            &mut self.buf,
            g,
            m,
        );
        count.clear();
        count.resize(parts.len(), 0);
        for (&e, &c) in self.order.iter().zip(self.buf.counts()) {
            count[e as usize] = c;
        }
        out
    }
}

/// The smallest q >= 0 with 2 sqrt(q) >= `skin` in floating point (sqrt correctly rounded,
/// so monotone): for every q, including NaN, `q < moved_limit(skin)` is `2 sqrt(q) < skin`.
pub(super) fn moved_limit(skin: f64) -> f64 {
    let near = |q: f64| 2.0 * q.sqrt() < skin;
    if skin.is_nan() || skin <= 0.0 || skin.is_infinite() {
        // no q is near (skin 0 or NaN; q < 0 never holds for a sum of squares) or every
        // finite q is (2 sqrt(inf) = inf is not below an infinite skin)
        return if skin == f64::INFINITY {
            f64::INFINITY
        } else {
            0.0
        };
    }
    let step = |q: f64, up: bool| {
        let b = q.to_bits();
        f64::from_bits(if up { b + 1 } else { b - 1 })
    };
    let mut t = 0.25 * skin * skin;
    if t == f64::INFINITY {
        t = f64::MAX;
    }
    while t > 0.0 && !near(step(t, false)) {
        t = step(t, false);
    }
    while near(t) {
        t = step(t, true);
    }
    t
}

/// The skin of a kept list for `parts`, m: `KEPT_PAIRS_SKIN_H` times the smallest h.
pub(super) fn kept_pairs_skin(parts: &Particles) -> f64 {
    let h_min = parts.h.iter().fold(f64::INFINITY, |a, &b| a.min(b));
    if h_min.is_finite() {
        KEPT_PAIRS_SKIN_H * h_min
    } else {
        0.0
    }
}

/// The pairs [`pairs_in_box`] gives for one box of all of space without a periodic box, the
/// particles at `x` (real positions: no ghosts, no images) with radii `h`, ids `id` and, when
/// `primary` is not empty, at least one primary entry per pair: the same pairs in the same
/// order, found by the same cell list visited in the same order, without its general parts.
/// Every pair is interior, so the search's tests reduce to the overlap r^2 < (h_a + h_b)^2
/// (the pre-filter with slack accepts a superset); the cells are filled by one counting sort
/// on (cell, not primary), which gives the slot order of `CellList::new` then
/// `CellList::with_primary`; each slot's position and radius are packed in 32 bytes; a slot
/// skips a neighbour cell whose slots' bounding box lies beyond its reach (see below); and
/// each run of candidates is tested without a jump per candidate (the index written to a small
/// buffer, the count advanced by the test), the ~70 % that fail costing no mispredicted jump.
/// Per candidate ~16 instructions and 32 bytes (in L1: a cell's slots are contiguous); per
/// listed pair ~10 more (the id test, min/max, push). Measured on the dam break's last state
/// (18,568 particles, 169,000 candidates listed, one core of this machine): 2.6 ms against
/// 5.2 ms for the general search, 580,000 candidates tested against 1.26 million.
pub(super) fn one_box_candidates(
    x: &[[f64; 3]],
    h: &[f64],
    id: &[u64],
    primary: &[bool],
) -> Vec<(u32, u32)> {
    let n = x.len();
    let grid = Grid::new(x, h);
    let ncell = grid.n_cells();
    let CellSort {
        start,
        order,
        slots,
        cell_hmax,
    } = sort_by_cell(x, h, primary, &grid);
    let bounds = cell_bounds(&start, &slots, ncell);
    let most = (0..ncell)
        .map(|c| start[2 * c + 2] - start[2 * c])
        .max()
        .unwrap_or(0) as usize;
    let mut hit = vec![0u32; most];
    let mut out = Vec::with_capacity(PAIRS_PER_ENTRY_HINT * n);
    // the candidates sj of slot si that overlap it, listed as entry pairs (i < j)
    let mut scan = |si: usize, sj: std::ops::Range<usize>, out: &mut Vec<(u32, u32)>| {
        let a = slots[si];
        let mut m = 0;
        for (k, b) in slots[sj.clone()].iter().enumerate() {
            let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let reach = a[3] + b[3];
            hit[m] = (sj.start + k) as u32;
            m += (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < reach * reach) as usize;
        }
        let i = order[si];
        for &s in &hit[..m] {
            let j = order[s as usize];
            if id[i as usize] != id[j as usize] {
                out.push((i.min(j), i.max(j)));
            }
        }
    };
    let [nx, ny, nz] = grid.dims;
    let stencil = half_stencil(grid.reach);
    for cz in 0..nz {
        for cy in 0..ny {
            for cx in 0..nx {
                let c = (cz * ny + cy) * nx + cx;
                let (s0, p1, s1) = (
                    start[2 * c] as usize,
                    start[2 * c + 1] as usize,
                    start[2 * c + 2] as usize,
                );
                if s0 == s1 {
                    continue;
                }
                for si in s0..p1 {
                    scan(si, si + 1..s1, &mut out);
                }
                let hc = cell_hmax[c];
                for &([dx, dy, dz], gap) in &stencil {
                    let Some(o) = neighbour_cell([cx, cy, cz], [dx, dy, dz], [nx, ny, nz]) else {
                        continue;
                    };
                    let (t0, q1, t1) = (
                        start[2 * o] as usize,
                        start[2 * o + 1] as usize,
                        start[2 * o + 2] as usize,
                    );
                    let ho = cell_hmax[o];
                    // the general search's skips (`CellList::for_each_close_pair`)
                    let dist = gap * grid.size;
                    if t0 == t1
                        || (p1 == s0 && q1 == t0)
                        || dist >= (hc + ho) * (1.0 + PREFILTER_SLACK)
                    {
                        continue;
                    }
                    for (si, a) in (s0..s1).zip(&slots[s0..s1]) {
                        if dist >= (a[3] + ho) * (1.0 + PREFILTER_SLACK) {
                            continue;
                        }
                        // a non-primary slot meets the other cell's primary prefix only
                        let (t_end, b) = if si < p1 {
                            (t1, &bounds[2 * o + 1])
                        } else {
                            (q1, &bounds[2 * o])
                        };
                        // None of them when the slot is at least its radius plus the cell's
                        // largest from the box of their positions: fl(x - y) is monotone in x
                        // and in y, so each candidate's |d_k| is at least the box's gap g_k
                        // computed below, and the overlap test, made of the same operations,
                        // fails for all. ~25 instructions per slot and cell; on the dam break
                        // it drops half the candidates (57 % of the slot-cell visits, most
                        // near the thin boxes of the walls' cells), for ~16 each.
                        let g = [
                            pos_part(b[0] - a[0]) + pos_part(a[0] - b[3]),
                            pos_part(b[1] - a[1]) + pos_part(a[1] - b[4]),
                            pos_part(b[2] - a[2]) + pos_part(a[2] - b[5]),
                        ];
                        let reach = a[3] + ho;
                        if g[0] * g[0] + g[1] * g[1] + g[2] * g[2] >= reach * reach {
                            continue;
                        }
                        scan(si, t0..t_end, &mut out);
                    }
                }
            }
        }
    }
    out
}

/// The entries of one box sorted by cell ([`one_box_candidates`]).
struct CellSort {
    /// Cell c's slots: start[2c]..start[2c + 2], its primary ones start[2c]..start[2c + 1].
    start: Vec<u32>,
    /// The entry in each slot.
    order: Vec<u32>,
    /// Each slot's position and smoothing length.
    slots: Vec<[f64; 4]>,
    /// Each cell's largest smoothing length.
    cell_hmax: Vec<f64>,
}

/// Sorts the entries by cell of `grid`, the primary ones first in each cell, each group in
/// entry order (a stable counting sort).
fn sort_by_cell(x: &[[f64; 3]], h: &[f64], primary: &[bool], grid: &Grid) -> CellSort {
    let n = x.len();
    let ncell = grid.n_cells();
    // key 2 c for a primary entry of cell c, 2 c + 1 for another: primary slots first in
    // each cell, each group in entry order (a stable counting sort)
    let keys: Vec<u32> = x
        .iter()
        .enumerate()
        .map(|(i, x)| {
            let late = !primary.is_empty() && !primary[i];
            (2 * grid.cell_of(x) + late as usize) as u32
        })
        .collect();
    let mut start = vec![0u32; 2 * ncell + 1];
    for &k in &keys {
        start[k as usize + 1] += 1;
    }
    for k in 0..2 * ncell {
        start[k + 1] += start[k];
    }
    let mut fill = start.clone();
    let mut order = vec![0u32; n];
    let mut slots = vec![[0.0f64; 4]; n];
    let mut cell_hmax = vec![0.0f64; ncell];
    for (i, &k) in keys.iter().enumerate() {
        let s = fill[k as usize] as usize;
        fill[k as usize] += 1;
        order[s] = i as u32;
        slots[s] = [x[i][0], x[i][1], x[i][2], h[i]];
        let c = k as usize / 2;
        cell_hmax[c] = cell_hmax[c].max(h[i]);
    }
    CellSort {
        start,
        order,
        slots,
        cell_hmax,
    }
}

/// Each cell's boxes of its slots' positions ([`sort_by_cell`]'s `start` and `slots`).
fn cell_bounds(start: &[u32], slots: &[[f64; 4]], ncell: usize) -> Vec<[f64; 6]> {
    // cell c: slots start[2c]..start[2c + 2], the primary ones start[2c]..start[2c + 1];
    // bounds[2c]: the box of its primary slots' positions (lower corner, upper corner),
    // bounds[2c + 1]: of all its slots' (empty: lower +inf, upper -inf)
    let mut bounds = vec![
        [
            f64::INFINITY,
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY
        ];
        2 * ncell
    ];
    for c in 0..ncell {
        let (s0, p1, s1) = (
            start[2 * c] as usize,
            start[2 * c + 1] as usize,
            start[2 * c + 2] as usize,
        );
        let mut b = bounds[2 * c];
        for (s, a) in (s0..s1).zip(&slots[s0..s1]) {
            for k in 0..3 {
                b[k] = b[k].min(a[k]);
                b[k + 3] = b[k + 3].max(a[k]);
            }
            if s + 1 == p1 {
                bounds[2 * c] = b;
            }
        }
        bounds[2 * c + 1] = b;
    }
    bounds
}

/// Pair candidates kept over several steps by one box of a decomposition (a Verlet list for
/// a rank of several, no periodic box): the pairs of the box's entries, owned and ghosts, whose
/// spheres grown by half the skin overlapped at the build and whose centre of interaction,
/// for the grown spheres, lay within `2 h_max + skin` of the box. While no particle has moved
/// half the skin since (and h and the entries are the same), every pair whose COI lies in the
/// box now is among them: the pair's distance changed by at most the two motions, and its COI
/// now lies within `h_a` of `a` now, within `h_a + skin / 2` of `a` at the build, within
/// `2 h_a + skin` of the grown COI then. [`KeptBoxPairs::filter`] applies the search's own
/// tests (overlap, COI in the half-open box) to them: the pairs [`pairs_in_box`] gives, in
/// another order.
#[derive(Clone, Debug)]
pub struct KeptBoxPairs {
    pairs: Vec<(u32, u32)>,
    skin: f64,
}

impl KeptBoxPairs {
    /// Candidates of `parts` (owned and ghosts) for the box `lo..hi`, skin `skin` (m).
    pub fn build(
        parts: &Particles,
        opts: &SearchOptions,
        lo: [f64; 3],
        hi: [f64; 3],
        skin: f64,
    ) -> Self {
        assert!(
            opts.periodic.is_none(),
            "kept box pairs without a periodic box"
        );
        let mut grown = parts.clone();
        for h in grown.h.iter_mut() {
            *h += 0.5 * skin;
        }
        let reach = 2.0 * parts.max_h() + skin;
        let near = |c: [f64; 3]| (0..3).all(|k| lo[k] - reach <= c[k] && c[k] < hi[k] + reach);
        KeptBoxPairs {
            pairs: pairs_with_interior(&grown, opts, near, &[]),
            skin,
        }
    }

    /// The skin the list was built with, m.
    pub fn skin(&self) -> f64 {
        self.skin
    }

    /// The candidates as plain arrays (a restart continues with the very same list): pairs
    /// and skin.
    pub fn to_parts(&self) -> (Vec<[u32; 2]>, f64) {
        (self.pairs.iter().map(|&(a, b)| [a, b]).collect(), self.skin)
    }

    /// The list [`KeptBoxPairs::to_parts`] gave.
    pub fn from_parts(pairs: Vec<[u32; 2]>, skin: f64) -> Self {
        KeptBoxPairs {
            pairs: pairs.into_iter().map(|[a, b]| (a, b)).collect(),
            skin,
        }
    }

    /// Candidate pairs.
    pub fn len(&self) -> usize {
        self.pairs.len()
    }

    /// Whether there is no candidate.
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }

    /// The pairs whose spheres overlap and whose COI lies in the half-open box `lo..hi` now,
    /// counting the owned entries' pairs in `count` (zeroed first, `n_owned` long).
    pub fn filter(
        &self,
        parts: &Particles,
        lo: [f64; 3],
        hi: [f64; 3],
        count: &mut Vec<u32>,
    ) -> Vec<(u32, u32)> {
        let owns = |c: [f64; 3]| (0..3).all(|k| lo[k] <= c[k] && c[k] < hi[k]);
        let end = |i: usize| PairEnd {
            id: parts.id[i],
            x_real: parts.x_real[i],
            image: [0; 3],
            h: parts.h[i],
        };
        let n = parts.n_owned;
        count.clear();
        count.resize(n, 0);
        let mut list = Vec::with_capacity(self.pairs.len());
        for &(i, j) in &self.pairs {
            let c = coi(&end(i as usize), &end(j as usize), None);
            if c.overlap && owns(c.point) {
                list.push((i, j));
                for e in [i as usize, j as usize] {
                    if e < n {
                        count[e] += 1;
                    }
                }
            }
        }
        list
    }
}
