//! Neighbour search (a cell list) and the centre-of-interaction (COI) rule that decides which
//! box computes a pair.
//!
//! Two particles interact iff their spheres (radius h) overlap: r < h_a + h_b. The pair is
//! computed by the box whose half-open region holds the COI, the midpoint of the point of
//! sphere A closest to B's centre and the point of sphere B closest to A's centre
//! (Plimpton et al., "Transient dynamics simulations: parallel algorithms for contact detection
//! and smoothed particle hydrodynamics", §5). The COI is computed so that every copy of the pair,
//! on any rank, gives the same bits: from the real positions (`Particles::x_real`, never
//! recomputed as x - shift, which can differ in the last bit) of the particle with the smaller
//! global id ("a") and its partner, the partner placed by the relative periodic image of the
//! copies (the minimum image whenever the period exceeds twice the largest interaction
//! distance), and wrapped into the periodic box.
//!
//! Periodic images mean one box can hold several copies of one physical pair (a, b, relative
//! image). Exactly one is listed: the copy whose "a" has image index n_a = -k, where k is the
//! image count the wrap removed from the COI, i.e. the copy whose own COI lies inside the box.
//!
//! When a period is shorter than a particle's interaction distance 2h, the particle interacts
//! with its own images: the physical pairs (a, a, m) and (a, a, -m) are one pair (listed once,
//! with "a" the copy of smaller image index); folded back onto the owner, a pass adds both ends'
//! contributions to the particle, i.e. the m and -m terms of its periodic sums. Two copies of
//! one particle with the same image index are never a pair.
use crate::exact::{PassGrids, TermMax};
use crate::params::Params;
use crate::particles::Particles;
use crate::passes::{kept_continuity_and_force_pass, pos_part, PairWork, PassBuffers};
use crate::periodic::Periodic;

mod kept;
pub use kept::*;

/// Options of the pair search.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SearchOptions {
    /// The periodic box, if any (COI wrapping and copy selection).
    pub periodic: Option<Periodic>,
    /// Skip pairs of two fixed particles.
    pub skip_fixed_pairs: bool,
}

/// One end of a pair for the COI: global id, real position, image index of this copy, h.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairEnd {
    /// Global id.
    pub id: u64,
    /// Real position (bitwise as the owner holds it).
    pub x_real: [f64; 3],
    /// Image index of this copy (0 for real copies).
    pub image: [i64; 3],
    /// Smoothing length (sphere radius).
    pub h: f64,
}

/// A pair's centre of interaction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coi {
    /// The COI, wrapped into the periodic box on periodic axes.
    pub point: [f64; 3],
    /// The image index that the canonical "a" copy (see `canonical`) must have for this copy of
    /// the pair to be the listed one (minus the image count removed by the wrap).
    pub a_image: [i64; 3],
    /// Whether the spheres overlap, |d|^2 < (h_a + h_b)^2 with d the centre difference (real
    /// positions, relative image applied).
    pub overlap: bool,
}

/// The canonical order of a pair of copies: "a" is the one with the smaller id; for two copies
/// of one particle (a particle and its own periodic image, when the period is shorter than its
/// interaction distance 2h), the one with the lexicographically smaller image index.
#[inline]
pub fn canonical<'e>(p: &'e PairEnd, q: &'e PairEnd) -> (&'e PairEnd, &'e PairEnd) {
    if (p.id, p.image) <= (q.id, q.image) {
        (p, q)
    } else {
        (q, p)
    }
}

/// [f(0), f(1), f(2)], written out (`[0, 1, 2].map(f)` is not always inlined, and `coi` runs
/// for every candidate at every step on several ranks).
#[inline(always)]
fn each_axis(f: impl Fn(usize) -> f64) -> [f64; 3] {
    [f(0), f(1), f(2)]
}

/// The centre of interaction of the pair of copies `p`, `q` (in either order: see `canonical`).
/// Bit-identical for every copy of the same physical pair. Inlined always: it is the body of
/// `KeptBoxPairs::filter`'s loop over every candidate at every step on several ranks (a call
/// there made the dam break at np 2 1.5x slower when the module grew and LLVM stopped
/// inlining it).
#[inline(always)]
pub fn coi(p: &PairEnd, q: &PairEnd, periodic: Option<&Periodic>) -> Coi {
    let (a, b) = canonical(p, q);
    // d = x_b - x_a with the relative image of the copies
    let d = each_axis(|k| {
        let mut dk = b.x_real[k] - a.x_real[k];
        if let Some(per) = periodic {
            let m = b.image[k] - a.image[k];
            if per.axes[k] && m != 0 {
                dk += m as f64 * per.period(k);
            }
        }
        dk
    });
    let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    let reach = a.h + b.h;
    let overlap = r2 < reach * reach;
    // p_a = x_a + min(h_a, r) e, p_b = x_a + d - min(h_b, r) e with e = d/r, so
    // COI = x_a + (1 + t) d/2 with t = (min(h_a, r) - min(h_b, r))/r. t = 0 (no sqrt, no
    // division) when h_a = h_b or when r <= both radii.
    let (ha2, hb2) = (a.h * a.h, b.h * b.h);
    let t = if a.h == b.h || (r2 <= ha2 && r2 <= hb2) || r2 == 0.0 {
        0.0
    } else {
        let r = r2.sqrt();
        (a.h.min(r) - b.h.min(r)) / r
    };
    let s = 0.5 * (1.0 + t);
    let c = each_axis(|k| a.x_real[k] + s * d[k]);
    let (point, a_image) = match periodic {
        Some(per) => {
            let (w, n) = per.wrap_with_index(c);
            (w, [-n[0], -n[1], -n[2]])
        }
        None => (c, [0; 3]),
    };
    Coi {
        point,
        a_image,
        overlap,
    }
}

impl Particles {
    /// Entry `i` as a pair end for the COI.
    pub fn pair_end(&self, i: usize, periodic: Option<&Periodic>) -> PairEnd {
        PairEnd {
            id: self.id[i],
            x_real: self.x_real[i],
            image: periodic.map_or([0; 3], |per| per.image_index(self.shift[i])),
            h: self.h[i],
        }
    }
}

/// A uniform grid of cells over the bounding box of the particles, each cell 2 h_max wide and
/// searched one cell deep, or, where h varies by more than 1.5 between entries, h_max wide and
/// searched two cells deep, so that every pair with r < h_a + h_b <= 2 h_max is reached. Each
/// cell records the largest h it holds, so a cell pair (or a particle and a cell) farther apart
/// than their radii can reach is skipped: where h varies (a shock tube, density ratio 8) the
/// small-h regions are then searched as if their cells were 2 h_local wide. Positions and radii are
/// copied in cell order so that the candidate loop reads contiguous memory.
#[derive(Clone, Debug)]
pub struct CellList {
    dims: [usize; 3],
    /// Cell width, m.
    size: f64,
    /// How many cells deep the stencil reaches (1 or 2).
    reach: i64,
    /// `start[c]..start[c+1]`: the sorted slots of cell c.
    start: Vec<usize>,
    /// Largest h in each cell (0 when empty).
    cell_hmax: Vec<f64>,
    /// Entry index of each sorted slot.
    order: Vec<u32>,
    /// Position of each sorted slot.
    xs: Vec<[f64; 3]>,
    /// Smoothing length of each sorted slot.
    hs: Vec<f64>,
    /// Whether each sorted slot may take part in a pair with a non-primary slot (see
    /// `CellList::with_primary`); all true by default.
    primary: Vec<bool>,
    /// Number of primary slots in each cell.
    cell_primaries: Vec<u32>,
}

/// Cap on the number of cells per particle (a few far-flung particles must not make a huge grid).
const MAX_CELLS_PER_PARTICLE: usize = 4;

/// Relative slack on the overlap distance in the cell-list pre-filter, so that it keeps every
/// pair the exact test on real positions accepts.
const PREFILTER_SLACK: f64 = 1e-12;

/// Above this ratio h_max / h_min the cells are h_max wide and searched two cells deep (so that
/// small-h regions can be pruned); below it they are 2 h_max wide and searched one cell deep
/// (fewer, fuller cells: faster for uniform h, 1.2 against 1.4 us per particle-step on the dam
/// break example).
const FINE_CELLS_H_RATIO: f64 = 1.5;

/// The index of the cell at offset `d` from cell `c` in a grid of `n` cells per axis (x
/// fastest), or `None` outside the grid. Always inlined: it sits in the searches' inner loops.
#[inline(always)]
fn neighbour_cell(c: [usize; 3], d: [i64; 3], n: [usize; 3]) -> Option<usize> {
    let o: [i64; 3] = std::array::from_fn(|a| c[a] as i64 + d[a]);
    if (0..3).any(|a| o[a] < 0 || o[a] >= n[a] as i64) {
        return None;
    }
    Some((o[2] as usize * n[1] + o[1] as usize) * n[0] + o[0] as usize)
}

/// The offsets of the half stencil: those in -reach..=reach per axis that come after (0, 0, 0)
/// in (z, y, x) lexicographic order, so that each pair of distinct cells is visited once; with
/// the smallest distance between two cells at that offset, in cell widths.
fn half_stencil(r: i64) -> Vec<([i64; 3], f64)> {
    let mut out = Vec::new();
    for dz in -r..=r {
        for dy in -r..=r {
            for dx in -r..=r {
                if (dz, dy, dx) <= (0, 0, 0) {
                    continue;
                }
                let gap = |d: i64| (d.abs() - 1).max(0) as f64;
                let g = (gap(dx).powi(2) + gap(dy).powi(2) + gap(dz).powi(2)).sqrt();
                out.push(([dx, dy, dz], g));
            }
        }
    }
    out
}

/// The geometry of a cell list: the grid over the bounding box of the positions, its cell
/// width and stencil depth (see [`CellList`]).
#[derive(Clone, Copy, Debug)]
struct Grid {
    lo: [f64; 3],
    dims: [usize; 3],
    size: f64,
    inv: f64,
    reach: i64,
}

impl Grid {
    /// The grid of the positions `x` with smoothing lengths `h`.
    fn new(x: &[[f64; 3]], h: &[f64]) -> Self {
        let n = x.len();
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for x in x {
            for k in 0..3 {
                lo[k] = lo[k].min(x[k]);
                hi[k] = hi[k].max(x[k]);
            }
        }
        if n == 0 {
            lo = [0.0; 3];
            hi = [0.0; 3];
        }
        let h_max = h.iter().fold(0.0, |a: f64, &b| a.max(b));
        let h_min = h.iter().fold(f64::INFINITY, |a, &b| a.min(b));
        let reach = if h_max > FINE_CELLS_H_RATIO * h_min {
            2
        } else {
            1
        };
        let mut size = 2.0 * h_max / reach as f64;
        let ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
        if size.is_nan() || size <= 0.0 {
            size = ext[0].max(ext[1]).max(ext[2]).max(1.0);
        }
        let cap = MAX_CELLS_PER_PARTICLE * n + 64;
        let dims_for = |s: f64| ext.map(|e| ((e / s) as usize + 1).max(1));
        let mut dims = dims_for(size);
        while dims[0] * dims[1] * dims[2] > cap {
            size *= 1.5;
            dims = dims_for(size);
        }
        Grid {
            lo,
            dims,
            size,
            inv: 1.0 / size,
            reach,
        }
    }

    fn n_cells(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// The cell of position `x` (the edge cells hold what lies beyond).
    #[inline(always)]
    fn cell_of(&self, x: &[f64; 3]) -> usize {
        let mut c = [0usize; 3];
        for k in 0..3 {
            c[k] = (((x[k] - self.lo[k]) * self.inv) as usize).min(self.dims[k] - 1);
        }
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }
}

impl CellList {
    /// Bins every entry (owned and ghost) of `parts` by its position `x`.
    pub fn new(parts: &Particles) -> Self {
        let n = parts.len();
        let grid = Grid::new(&parts.x, &parts.h);
        let Grid {
            dims, size, reach, ..
        } = grid;
        let ncell = grid.n_cells();
        let cells: Vec<usize> = parts.x.iter().map(|x| grid.cell_of(x)).collect();
        let mut start = vec![0usize; ncell + 1];
        let mut cell_hmax = vec![0.0f64; ncell];
        for (i, &c) in cells.iter().enumerate() {
            start[c + 1] += 1;
            cell_hmax[c] = cell_hmax[c].max(parts.h[i]);
        }
        for c in 0..ncell {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut order = vec![0u32; n];
        for (i, &c) in cells.iter().enumerate() {
            order[fill[c]] = i as u32;
            fill[c] += 1;
        }
        let xs = order.iter().map(|&i| parts.x[i as usize]).collect();
        let hs = order.iter().map(|&i| parts.h[i as usize]).collect();
        let cell_primaries = (0..ncell)
            .map(|c| (start[c + 1] - start[c]) as u32)
            .collect();
        Self {
            dims,
            size,
            reach,
            start,
            cell_hmax,
            order,
            xs,
            hs,
            primary: vec![true; n],
            cell_primaries,
        }
    }

    /// Restricts the search to pairs with at least one primary entry (`primary[i]` per entry).
    pub fn with_primary(mut self, primary: &[bool]) -> Self {
        // Within each cell, primary slots first (each group in its previous order), so that a
        // non-primary slot's candidates are the primary prefix of the other cell: pairs of two
        // non-primary slots (a wall against a wall) are never even looked at.
        let mut perm: Vec<usize> = Vec::with_capacity(self.order.len()); // new slot -> old
        for c in 0..self.cell_primaries.len() {
            let slots = self.start[c]..self.start[c + 1];
            let before = perm.len();
            let is_p = |sl: &usize| primary[self.order[*sl] as usize];
            perm.extend(slots.clone().filter(is_p));
            self.cell_primaries[c] = (perm.len() - before) as u32;
            perm.extend(slots.filter(|sl| !is_p(sl)));
        }
        self.order = perm.iter().map(|&k| self.order[k]).collect();
        self.xs = perm.iter().map(|&k| self.xs[k]).collect();
        self.hs = perm.iter().map(|&k| self.hs[k]).collect();
        self.primary = self.order.iter().map(|&i| primary[i as usize]).collect();
        self
    }

    /// Whether sorted slots si, sj are closer than (h_i + h_j)(1 + slack).
    #[inline(always)]
    fn close(&self, si: usize, sj: usize) -> bool {
        let (a, b) = (self.xs[si], self.xs[sj]);
        let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        let reach = (self.hs[si] + self.hs[sj]) * (1.0 + PREFILTER_SLACK);
        d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < reach * reach
    }

    /// Calls `visit(i, j)` (entry indices) once for every unordered pair of entries whose
    /// positions are closer than (h_i + h_j)(1 + 1e-12) and of which at least one is primary, in
    /// a deterministic order. Flops per candidate ~10, bytes ~32 (contiguous).
    pub fn for_each_close_pair(&self, mut visit: impl FnMut(u32, u32)) {
        let [nx, ny, nz] = self.dims;
        let stencil = half_stencil(self.reach);
        for cz in 0..nz {
            for cy in 0..ny {
                for cx in 0..nx {
                    let c = (cz * ny + cy) * nx + cx;
                    let (s0, s1) = (self.start[c], self.start[c + 1]);
                    if s0 == s1 {
                        continue;
                    }
                    let pc = self.cell_primaries[c];
                    // primary slots are s0..s0 + pc: a pair needs one of them
                    for si in s0..s0 + pc as usize {
                        for sj in si + 1..s1 {
                            if self.close(si, sj) {
                                visit(self.order[si], self.order[sj]);
                            }
                        }
                    }
                    let hc = self.cell_hmax[c];
                    for &([dx, dy, dz], gap) in &stencil {
                        let Some(o) = neighbour_cell([cx, cy, cz], [dx, dy, dz], [nx, ny, nz])
                        else {
                            continue;
                        };
                        let (t0, t1) = (self.start[o], self.start[o + 1]);
                        let ho = self.cell_hmax[o];
                        // cells farther apart than any pair of their spheres can reach
                        let dist = gap * self.size;
                        let po = self.cell_primaries[o];
                        if t0 == t1
                            || (pc == 0 && po == 0)
                            || dist >= (hc + ho) * (1.0 + PREFILTER_SLACK)
                        {
                            continue;
                        }
                        for si in s0..s1 {
                            if dist >= (self.hs[si] + ho) * (1.0 + PREFILTER_SLACK) {
                                continue;
                            }
                            // a non-primary slot meets the other cell's primary prefix only
                            let t_end = if self.primary[si] {
                                t1
                            } else {
                                t0 + po as usize
                            };
                            for sj in t0..t_end {
                                if self.close(si, sj) {
                                    visit(self.order[si], self.order[sj]);
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Relative margin beyond a periodic face in the cheap copy filter of `pairs` (far above the
/// round-off that separates a copy's own COI from the canonical one).
const FACE_MARGIN: f64 = 1e-9;

/// Whether the copy pair (x_i, h_i), (x_j, h_j) may be the listed copy of its physical pair:
/// its own COI lies on the segment between the copies within |h_i - h_j|/2 of the midpoint
/// (|t| r <= |h_a - h_b| in `coi`), and the listed copy is the one whose own COI is in the box;
/// so a midpoint farther than that (plus a round-off margin) outside the box on a periodic axis
/// rules the copy out without a square root.
#[inline]
fn may_be_listed_copy(xi: [f64; 3], hi: f64, xj: [f64; 3], hj: f64, per: &Periodic) -> bool {
    let slack = 0.5 * (hi - hj).abs();
    (0..3).all(|k| {
        if !per.axes[k] {
            return true;
        }
        let tol = slack + FACE_MARGIN * (per.period(k) + per.min[k].abs() + per.max[k].abs());
        let mid = 0.5 * (xi[k] + xj[k]);
        mid >= per.min[k] - tol && mid < per.max[k] + tol
    })
}

/// Every pair this box computes, as entry indices (i, j) with i < j, in a deterministic order:
/// the spheres overlap, the two entries are copies of different particles (or of one particle
/// at different periodic images, see the module doc), `owns(coi)` holds
/// (the COI of the pair, wrapped into the periodic box), the copy is the listed copy of its
/// physical pair (see the module doc), and, with `skip_fixed_pairs`, not both are fixed.
/// Owned and ghost entries alike take part. Cost ~ N (cell list), not N^2.
pub fn pairs(
    parts: &Particles,
    opts: &SearchOptions,
    owns: impl Fn([f64; 3]) -> bool,
) -> Vec<(u32, u32)> {
    pairs_with_interior(parts, opts, owns, &[])
}

/// Pairs listed per entry reserved up front (half of ~31 neighbours in 3D with 2h = 2.4 dx).
const PAIRS_PER_ENTRY_HINT: usize = 16;

/// Relative margin on h when deciding that a sphere lies strictly inside a box (so that the
/// rounding of a COI computed from it cannot fall outside).
const INTERIOR_MARGIN: f64 = 1e-9;

/// `pairs` for the box [lo, hi) (half-open): a pair is this box's when its COI lies in it. Owned
/// entries whose sphere lies strictly inside the box (without a periodic box) skip the COI:
/// the COI is the midpoint of a point of each sphere, so when both spheres lie inside the
/// (convex) box, so does the COI. The list is the same as `pairs` with `owns` = "inside
/// [lo, hi)"; the COI is only computed for pairs near the box's faces.
pub fn pairs_in_box(
    parts: &Particles,
    opts: &SearchOptions,
    lo: [f64; 3],
    hi: [f64; 3],
) -> Vec<(u32, u32)> {
    let owns = |c: [f64; 3]| (0..3).all(|k| lo[k] <= c[k] && c[k] < hi[k]);
    let interior: Vec<bool> = if opts.periodic.is_some() {
        Vec::new()
    } else {
        (0..parts.n_owned)
            .map(|i| {
                let (x, r) = (parts.x_real[i], parts.h[i] * (1.0 + INTERIOR_MARGIN));
                (0..3).all(|k| lo[k] < x[k] - r && x[k] + r < hi[k])
            })
            .collect()
    };
    pairs_with_interior(parts, opts, owns, &interior)
}

/// `pairs`, with `interior[i]` (for the first `interior.len()` entries) saying that entry i's
/// sphere lies inside the region `owns` accepts, so a pair of two such entries is listed when
/// the spheres overlap, without its COI.
fn pairs_with_interior(
    parts: &Particles,
    opts: &SearchOptions,
    owns: impl Fn([f64; 3]) -> bool,
    interior: &[bool],
) -> Vec<(u32, u32)> {
    let per = opts.periodic.as_ref();
    // Primary entries: a pair needs at least one. With skip_fixed_pairs, fixed particles are
    // not primary (wall-only cells are then skipped whole). With a periodic box, every listed
    // copy has an end within max(h_a, h_b) <= h_max of its COI, which is in the box, so entries
    // farther than h_max from the box are not primary either.
    let h_max = parts.max_h();
    let near_box = |x: &[f64; 3]| match per {
        Some(per) => (0..3).all(|k| {
            let tol = h_max + FACE_MARGIN * (per.period(k) + per.min[k].abs() + per.max[k].abs());
            !per.axes[k] || (x[k] >= per.min[k] - tol && x[k] < per.max[k] + tol)
        }),
        None => true,
    };
    let mut cells = CellList::new(parts);
    if per.is_some() || opts.skip_fixed_pairs {
        let primary: Vec<bool> = (0..parts.len())
            .map(|i| !(opts.skip_fixed_pairs && parts.fixed[i]) && near_box(&parts.x[i]))
            .collect();
        cells = cells.with_primary(&primary);
    }
    // Image indices (all zero, and not stored, without a periodic box).
    let images: Vec<[i64; 3]> = match per {
        Some(per) => parts.shift.iter().map(|s| per.image_index(*s)).collect(),
        None => Vec::new(),
    };
    let image = |i: usize| images.get(i).copied().unwrap_or([0; 3]);
    let end = |i: usize| PairEnd {
        id: parts.id[i],
        x_real: parts.x_real[i],
        image: image(i),
        h: parts.h[i],
    };
    // room for the typical ~16 listed pairs per entry (3D, support 2h = 2.4 spacings) up
    // front, instead of growing (and copying) the list step by step
    let mut out = Vec::with_capacity(PAIRS_PER_ENTRY_HINT * parts.len());
    cells.for_each_close_pair(|i, j| {
        let (i, j) = if i < j { (i, j) } else { (j, i) };
        let (iu, ju) = (i as usize, j as usize);
        if parts.id[iu] == parts.id[ju] && image(iu) == image(ju) {
            return; // two copies of one particle at the same place
        }
        if opts.skip_fixed_pairs && parts.fixed[iu] && parts.fixed[ju] {
            return;
        }
        if ju < interior.len() && interior[iu] && interior[ju] {
            // the same overlap test as `coi`'s (r^2 and h_a + h_b do not depend on the order)
            let (a, b) = (parts.x_real[iu], parts.x_real[ju]);
            let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let reach = parts.h[iu] + parts.h[ju];
            if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < reach * reach {
                out.push((i, j));
            }
            return;
        }
        if let Some(per) = per {
            if !may_be_listed_copy(parts.x[iu], parts.h[iu], parts.x[ju], parts.h[ju], per) {
                return;
            }
        }
        let (a, b) = (end(iu), end(ju));
        let c = coi(&a, &b, per);
        if !c.overlap {
            return;
        }
        if canonical(&a, &b).0.image != c.a_image {
            return;
        }
        if owns(c.point) {
            out.push((i, j));
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::moved_limit;

    /// `q < moved_limit(skin)` is `2 sqrt(q) < skin` for q at and around the limit (each side
    /// a few hundred ulps), for skins across the range, and at the edges (0, NaN, infinity).
    #[test]
    fn moved_limit_is_the_square_root_test() {
        let skins = [
            0.0024,
            1.0,
            0.1,
            3.0e-7,
            7.3e5,
            1e-300,
            5e-324,
            1e300,
            f64::MAX,
            0.0,
            f64::NAN,
            f64::INFINITY,
        ];
        for skin in skins {
            let t = moved_limit(skin);
            let near = |q: f64| 2.0 * q.sqrt() < skin;
            let mut qs = vec![0.0, -0.0, f64::NAN, f64::INFINITY, f64::MAX, 5e-324, 1.0];
            for base in [t, 0.25 * skin * skin] {
                if base.is_finite() && base > 0.0 {
                    for k in 0..400u64 {
                        qs.push(f64::from_bits(base.to_bits() + k));
                        qs.push(f64::from_bits(base.to_bits().saturating_sub(k)));
                    }
                }
            }
            for q in qs {
                assert_eq!(q < t, near(q), "skin {skin:e}, q {q:e}, limit {t:e}");
            }
        }
    }
}
