//! The velocity-gradient pass of the solids (with the continuity density rate of every
//! entry), its exact sums, and the corrected gradient.
//!
//! The sums are exact ([`binsum`] two-fold sums, 40 bits apart, on the grids of a
//! [`PassGrids`] of their own: quantity [`gq::GRAD`] for the velocity-gradient terms,
//! [`gq::SHAPE`] for the shape terms, [`gq::DENSITY`] for the density rate), as the fluid
//! passes' (see [`crate::exact`]): every entry's sums are the same bits whatever the order of
//! the pairs, whichever rank computed a pair and however the ghosts' partial sums are merged
//! into their owners. The 16 sums of an entry lie side by side, fold by fold ([`GradSums`]), so
//! that a pair's terms are split and added lane by lane (the operations of `Grid2::add` on
//! each, in vector registers).
use super::tensor::{self, inverse, mul, Mat3};
use super::{Solids, CORRECTION_MAX, CORRECTION_SINGULAR, SURFACE_SHAPE_TOL};
use crate::exact::{note, PassGrids, TermMax};
use crate::kernel::{Kernel, SmoothingKernel};
use crate::particles::Particles;
use bytemuck::{Pod, Zeroable};

/// The quantities of the gradient pass's sums, as indices of its [`TermMax`] and
/// [`PassGrids::grid`].
pub mod gq {
    /// Velocity-gradient terms V_b (v_b - v_a)_k (grad_a W)_l, 1/s.
    pub const GRAD: usize = 0;
    /// Shape terms V_b (x_b - x_a)_k (grad_a W)_l (dimensionless).
    pub const SHAPE: usize = 1;
    /// Continuity density-rate terms, kg/(m^3 s).
    pub const DENSITY: usize = 2;
}

/// Sums of one entry: 9 velocity-gradient lanes, 6 shape lanes, the density rate.
pub const LANES: usize = 16;
/// The first shape lane.
const SHAPE0: usize = 9;
/// The density-rate lane.
const DENS: usize = 15;

/// What the gradient pass added to one entry, as exact sums, fold by fold (`fold[k][l]`: the
/// part on grid k of lane l): lanes 0-8 sum_b V_b (v_b - v_a) (x) grad_a W_ab row by row (lane
/// 3 k + l is the (k, l) entry), 1/s; lanes 9-14 sum_b V_b (x_b - x_a) (x) grad_a W_ab
/// (symmetric: each term is -gr d (x) d) in Voigt order xx, yy, zz, xy, yz, zx; lane 15 the
/// continuity density rate, kg/(m^3 s). A ghost copy's go to its owner (copies -> owner), who
/// merges them (exact, in any order) and settles them ([`settle_gradients`]). 256 bytes.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GradSums {
    /// The parts on the top grid (index 0) and the lower grid (index 1) of each lane.
    pub fold: [[f64; LANES]; 2],
}

/// One pair's geometry as the gradient pass computed it, kept for the force pass over the same
/// pairs at the same positions (`Solids::pair_geom`): the force pass reads gr and r rather than
/// computing them again (a square root, the kernel derivative and a division per pair), the
/// very same bits. `i`, `j`: the pair's entries (the force pass checks them against its list);
/// `r` = |x_i - x_j|, m (0: coincident, skipped by both passes); `gr` = (dW/dr)(r, h) / r,
/// 1/m^5, with h = (h_i + h_j)/2. 24 bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PairGeom {
    /// The pair's first entry.
    pub i: u32,
    /// The pair's second entry.
    pub j: u32,
    /// The distance, m.
    pub r: f64,
    /// dW/dr / r, 1/m^5 (0 where `r` = 0).
    pub gr: f64,
}

/// Pairs whose geometry the gradient pass computes before their terms (a few kB, in L1).
const PAIR_CHUNK: usize = 256;

/// A chunk's pair geometry, lane by lane (one lane per pair of the chunk): what
/// [`gradient_pairs`] gathers of each pair (`d` = x_a - x_b, `dvh` = v^_a - v^_b, the kernel's
/// 1/h and grad_sigma/h^4 at the pair's h) and what [`GeomLanes::settle`] computes from it.
struct GeomLanes {
    d: [[f64; PAIR_CHUNK]; 3],
    dvh: [[f64; PAIR_CHUNK]; 3],
    inv_h: [f64; PAIR_CHUNK],
    dw_norm: [f64; PAIR_CHUNK],
    r: [f64; PAIR_CHUNK],
    gr: [f64; PAIR_CHUNK],
}

impl Default for GeomLanes {
    fn default() -> Self {
        let z = [0.0; PAIR_CHUNK];
        GeomLanes {
            d: [z; 3],
            dvh: [z; 3],
            inv_h: z,
            dw_norm: z,
            r: z,
            gr: z,
        }
    }
}

impl GeomLanes {
    /// For the first `n` lanes: r = |d|, dW/dr = grad_sigma/h^4 f'(r (1/h))
    /// (`ScaledKernel::dw_dr`), gr = dW/dr / r (0 where r = 0: a coincident pair, skipped by
    /// both passes) and the continuity term dW/dr (v^_ab . d) / r into `t_rho`. Each lane's
    /// operations are those of one pair, in the order the scalar form has them (the same bits);
    /// the loop over the lanes is what the wider builds do several lanes at a time.
    #[inline(always)]
    fn settle(&mut self, kind: Kernel, n: usize, t_rho: &mut [f64; PAIR_CHUNK]) {
        // one loop per kernel shape, so that each is a straight loop over the lanes
        match kind {
            Kernel::CubicSpline => {
                self.settle_with(n, t_rho, |s| Kernel::CubicSpline.shape_derivative(s))
            }
            Kernel::Wendland => {
                self.settle_with(n, t_rho, |s| Kernel::Wendland.shape_derivative(s))
            }
        }
    }

    /// [`GeomLanes::settle`] with the shape's derivative f'.
    #[inline(always)]
    fn settle_with(&mut self, n: usize, t_rho: &mut [f64; PAIR_CHUNK], df: impl Fn(f64) -> f64) {
        let [dx, dy, dz] = &self.d;
        let [vx, vy, vz] = &self.dvh;
        for p in 0..n.min(PAIR_CHUNK) {
            let r = (dx[p] * dx[p] + dy[p] * dy[p] + dz[p] * dz[p]).sqrt();
            let dw = self.dw_norm[p] * df(r * self.inv_h[p]);
            let gr = dw / r;
            t_rho[p] = dw * (vx[p] * dx[p] + vy[p] * dy[p] + vz[p] * dz[p]) / r;
            self.r[p] = r;
            self.gr[p] = if r == 0.0 { 0.0 } else { gr };
        }
    }
}

/// The (row, column) of each Voigt component xx, yy, zz, xy, yz, zx.
const VOIGT: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0)];

impl GradSums {
    /// Merges `o` into these sums (exact).
    #[inline]
    pub fn merge(&mut self, o: &GradSums) {
        for k in 0..2 {
            for l in 0..LANES {
                self.fold[k][l] += o.fold[k][l];
            }
        }
    }

    /// The value of lane `l` (the folds added top first, as `binsum::value2`).
    #[inline]
    fn value(&self, l: usize) -> f64 {
        self.fold[0][l] + self.fold[1][l]
    }

    /// The sums' values: the velocity-gradient sum, the shape sum, the density rate.
    pub fn values(&self) -> (Mat3, Mat3, f64) {
        let grad = std::array::from_fn(|k| std::array::from_fn(|l| self.value(3 * k + l)));
        let v: [f64; 6] = std::array::from_fn(|c| self.value(SHAPE0 + c));
        (grad, tensor::from_voigt(&v), self.value(DENS))
    }

    /// Adds the terms `x` lane by lane, each split on its lane's grids: t = (r + C_k) - C_k,
    /// r -= t, fold k += t (`binsum::Grid2::split`, the same operations in the same order).
    #[inline(always)]
    fn add(&mut self, x: &[f64; LANES], c: &[[f64; LANES]; 2]) {
        let mut r = *x;
        for (fold, ck) in self.fold.iter_mut().zip(c) {
            for l in 0..LANES {
                let t = (r[l] + ck[l]) - ck[l];
                r[l] -= t;
                fold[l] += t;
            }
        }
    }
}

/// The shifts of the lanes on each fold: velocity gradient, shape, density rate.
fn lane_shifts(g: &PassGrids) -> [[f64; LANES]; 2] {
    let (gv, gs, gd) = (g.grid(gq::GRAD), g.grid(gq::SHAPE), g.grid(gq::DENSITY));
    std::array::from_fn(|k| {
        std::array::from_fn(|l| match l {
            DENS => gd.shift[k],
            l if l >= SHAPE0 => gs.shift[k],
            _ => gv.shift[k],
        })
    })
}

/// What the gradient pass reads of one entry, packed: position, h, velocity, predicted
/// velocity, mass, volume m/rho, and whether it is a solid.
pub(super) struct Slot {
    x: [f64; 3],
    h: f64,
    v: [f64; 3],
    vhat: [f64; 3],
    m: f64,
    vol: f64,
    solid: bool,
}

/// Velocity-gradient pass over the pairs, for every entry (owned or ghost) that is a solid:
///
/// ```text
/// grad_sum_a  += V_b (v_b - v_a) (x) grad_a W_ab      (Libersky & Petschek 1991), 1/s
/// shape_sum_a += V_b (x_b - x_a) (x) grad_a W_ab      (Randles & Libersky 1996, eq. 29)
/// ```
///
/// with V_b = m_b / rho_b, grad_a W_ab = (dW/dr / r) (x_a - x_b), h = (h_a + h_b)/2, and the
/// same for b with a and b swapped (grad_b W_ba = -grad_a W_ab: b gets V_a times the same
/// tensor, and a pair listed as (b, a) gives each entry the same bits: both factors of each
/// product change sign). The velocity is `Particles::v`, which between the halves of a step is
/// the half-step velocity v^(n+1/2): the stress increment over the step is then centred (the
/// central difference of PRONTO-3D; Taylor & Flanagan, SAND87-1912). The positions are
/// x^(n+1). With them, for every entry (solid or fluid), the continuity density rate of
/// `passes::density_pass`, m_b (dW/dr)(r_ab . v^_ab)/r (Monaghan 1992, eq. 2.16): the same
/// walk over the pairs, one fold-back for both. Zeroes the sums (`Solids::sums`) of every entry
/// first, adds every term exactly on `g` (quantities [`gq`]) and notes the largest terms in
/// `m`; coincident pairs are skipped. Keeps each pair's r and dW/dr / r in
/// `Solids::pair_geom` for the force pass. Flops per pair: ~50 for the geometry and the terms
/// (one square root, two divisions), 2 x 16 x 6 for the exact sums (in lanes: 2 x 12 vector
/// operations of 8 lanes in the AVX-512F build, `super::build`); bytes: 2 x 112 of packed
/// inputs read, 2 x 256 of sums read and written, 24 of geometry written. The pairs go in
/// chunks of `PAIR_CHUNK`: the geometry of the chunk first (its square roots and divisions
/// overlap from pair to pair), then the terms; each pair's operations are the same.
pub fn velocity_gradient_pass(
    pairs: &[(u32, u32)],
    p: &Particles,
    s: &mut Solids,
    k: &SmoothingKernel,
    g: &PassGrids,
    m: &mut TermMax,
) {
    s.resize(p.len());
    s.sums.iter_mut().for_each(|e| *e = GradSums::default());
    let mut slots = std::mem::take(&mut s.buffers.grad_slots);
    slots.clear();
    slots.extend((0..p.len()).map(|i| Slot {
        x: p.x[i],
        h: p.h[i],
        v: p.v[i],
        vhat: p.vhat[i],
        m: p.m[i],
        vol: p.m[i] / p.rho[i],
        solid: s.is_solid(p.mat[i]),
    }));
    let shifts = lane_shifts(g);
    let (sums, geom) = (&mut s.sums[..], &mut s.pair_geom);
    let build = s.build;
    gradient_pairs_built(build, pairs, &slots, sums, geom, k, &shifts, m);
    s.buffers.grad_slots = slots;
}

super::build::builds!(
    /// [`gradient_pairs`] in the build of the pass.
    gradient_pairs_built,
    gradient_pairs,
    (
        pairs: &[(u32, u32)],
        slots: &[Slot],
        sums: &mut [GradSums],
        geom: &mut Vec<PairGeom>,
        k: &SmoothingKernel,
        shifts: &[[f64; LANES]; 2],
        m: &mut TermMax
    ) -> ()
);

/// The pair loop of [`velocity_gradient_pass`] (inlined into each build,
/// [`super::build`]): adds every pair's terms to `sums`, its geometry to `geom`, its
/// largest terms to `m`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn gradient_pairs(
    pairs: &[(u32, u32)],
    slots: &[Slot],
    sums: &mut [GradSums],
    geom: &mut Vec<PairGeom>,
    k: &SmoothingKernel,
    shifts: &[[f64; LANES]; 2],
    m: &mut TermMax,
) {
    // the largest sizes of the terms, lane by lane: velocity gradient, shape, density rate and
    // an unused lane, of the pair's first entry and of its second
    let mut noted = [0.0f64; 8];
    // the volume of the partner `other` in the terms of `me` (0 where `me` is a fluid)
    let vol = |me: &Slot, other: &Slot| if me.solid { other.vol } else { 0.0 };
    // h is mostly the same for every pair: the kernel's factors are remade when it changes
    let mut kern = k.at(f64::NAN);
    geom.clear();
    geom.resize(pairs.len(), PairGeom::default());
    let mut t_rho = [0.0; PAIR_CHUNK];
    let mut lanes = GeomLanes::default();
    for (chunk, geom) in pairs.chunks(PAIR_CHUNK).zip(geom.chunks_mut(PAIR_CHUNK)) {
        // the geometry of the chunk's pairs first, in three short loops: the inputs gathered
        // pair by pair, then the arithmetic lane by lane over the chunk (its square roots and
        // divisions, a chain in each pair, in vector registers), then the geometry kept
        let n = chunk.len();
        for (p, &(i, j)) in chunk.iter().enumerate() {
            let (a, b) = (&slots[i as usize], &slots[j as usize]);
            for c in 0..3 {
                lanes.d[c][p] = a.x[c] - b.x[c];
                lanes.dvh[c][p] = a.vhat[c] - b.vhat[c];
            }
            let h = 0.5 * (a.h + b.h);
            if kern.h != h {
                kern = k.at(h);
            }
            let (inv_h, _, dw_norm) = kern.factors();
            lanes.inv_h[p] = inv_h;
            lanes.dw_norm[p] = dw_norm;
        }
        lanes.settle(k.kind, n, &mut t_rho);
        for (p, (&(i, j), g)) in chunk.iter().zip(geom.iter_mut()).enumerate() {
            *g = PairGeom {
                i,
                j,
                r: lanes.r[p],
                gr: lanes.gr[p],
            };
        }
        for (g, &t_rho) in geom.iter().zip(&t_rho) {
            let (r, gr) = (g.r, g.gr);
            if r == 0.0 {
                continue;
            }
            let (i, j) = (g.i as usize, g.j as usize);
            let (a, b) = (&slots[i], &slots[j]);
            let d: [f64; 3] = std::array::from_fn(|c| a.x[c] - b.x[c]);
            let mut x = [0.0; LANES];
            let (mut bv, mut bx) = (0.0, 0.0);
            if a.solid || b.solid {
                let dv: [f64; 3] = std::array::from_fn(|c| a.v[c] - b.v[c]);
                // (v_b - v_a) (x) grad_a W = -(v_a - v_b) (x) gr d; (x_b - x_a) (x) grad_a W = -gr d (x) d
                for e in 0..9 {
                    x[e] = -dv[e / 3] * gr * d[e % 3];
                }
                for (c, &(k, l)) in VOIGT.iter().enumerate() {
                    x[SHAPE0 + c] = -d[k] * gr * d[l];
                }
                // bounds of the entries' terms (a function of the pair: |d_b| <= r)
                let dv_max = dv.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                (bv, bx) = ((gr * r * dv_max).abs(), (gr * r * r).abs());
            }
            let terms = |me: &Slot, other: &Slot| -> [f64; LANES] {
                let vol = vol(me, other);
                let mut y: [f64; LANES] = std::array::from_fn(|l| vol * x[l]);
                y[DENS] = other.m * t_rho;
                y
            };
            let (yi, yj) = (terms(a, b), terms(b, a));
            sums[i].add(&yi, shifts);
            sums[j].add(&yj, shifts);
            // the sizes of the entries' terms, lane by lane (velocity gradient, shape, density
            // rate of i, then of j), into their largest (the maxima `note` would give: a
            // maximum does not depend on the order, and a NaN is passed over)
            let (vi, vj) = (vol(a, b), vol(b, a));
            let sizes = [
                vi * bv,
                vi * bx,
                yi[DENS],
                0.0,
                vj * bv,
                vj * bx,
                yj[DENS],
                0.0,
            ];
            for (mx, x) in noted.iter_mut().zip(sizes) {
                let x = x.abs();
                *mx = if x > *mx { x } else { *mx };
            }
        }
    }
    for end in noted.chunks(4) {
        note(&mut m[gq::GRAD], end[0]);
        note(&mut m[gq::SHAPE], end[1]);
        note(&mut m[gq::DENSITY], end[2]);
    }
}

/// Sets the density rate `drho` of every owned entry and the corrected velocity gradient of
/// every owned solid from its (merged) sums:
///
/// ```text
/// L_a = grad_sum_a shape_sum_a^-1         (Randles & Libersky 1996, eqs. 29-30), 1/s
/// ```
///
/// For a linear field v = G x, v_b - v_a = G (x_b - x_a), so grad_sum_a = G shape_sum_a and
/// L_a = G exactly, at the free surface too (where the uncorrected sum is short of neighbours).
/// A singular `shape_sum` (see [`CORRECTION_SINGULAR`]), or a moving particle's whose inverse
/// has an entry past [`CORRECTION_MAX`], leaves the uncorrected sum. Also sets
/// `correction` = shape_sum^-T: L_kl = sum_b V_b (v_b - v_a)_k (shape_sum^-T grad_a W)_l, so
/// B grad_a W is the corrected kernel gradient. Flags (`Solids::quad_flag`) the moving solids
/// whose shape sum is more than [`SURFACE_SHAPE_TOL`] from the identity for the quadratic fit
/// ([`super::quadratic`]) and zeroes every owned entry's C_quad.
pub fn settle_gradients(p: &mut Particles, s: &mut Solids) {
    s.resize(p.len());
    for i in 0..p.n_owned {
        let (grad, shape, drho) = s.sums[i].values();
        p.drho[i] = drho;
        if !s.is_solid(p.mat[i]) {
            continue;
        }
        s.grad_sum[i] = grad;
        s.shape_sum[i] = shape;
        // (a fixed particle's B stays as it is: a clamp's last layers have entries past 1,000
        // and are part of the clamp's stiffness; they never move)
        let inv = inverse(&shape, CORRECTION_SINGULAR)
            .filter(|inv| p.fixed[i] || inv.iter().flatten().all(|x| x.abs() <= CORRECTION_MAX));
        s.quad[i] = [0.0; 18];
        s.quad_share[i] = 0.0;
        s.quad_flag[i] = false;
        match inv {
            Some(inv) => {
                s.grad_v[i] = mul(&grad, &inv);
                s.correction[i] = tensor::transpose(&inv);
                // a moving particle whose neighbourhood is one-sided: the quadratic fit
                // (`super::quadratic`) replaces the linear correction
                let off = (0..3)
                    .flat_map(|k| (0..3).map(move |l| (k, l)))
                    .map(|(k, l)| (shape[k][l] - tensor::IDENTITY[k][l]).abs())
                    .fold(0.0f64, f64::max);
                s.quad_flag[i] = !p.fixed[i] && off > SURFACE_SHAPE_TOL;
            }
            None => {
                s.grad_v[i] = grad;
                s.correction[i] = tensor::IDENTITY;
            }
        }
    }
}
