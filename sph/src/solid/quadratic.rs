//! The quadratically consistent velocity gradient of solid particles near a free surface.
//!
//! Why: the corrected gradient of [`super::settle_gradients`] (Randles & Libersky 1996) is
//! exact for linear fields only. Where a particle's neighbourhood is one-sided (a free surface,
//! a corner) the quadratic part of a field leaves an error of the order of h: for
//! f = f_a + grad f . d + d . H d / 2 (d = x_b - x_a),
//!
//! ```text
//! L_a = grad f + (1/2) H : (sum_b V_b |gr| d (x) d (x) d) S_a^-1,   S_a = sum_b V_b |gr| d (x) d
//! ```
//!
//! whose third moment vanishes in a symmetric neighbourhood and not at a surface: a surface
//! particle's strain is that of a point about a third of h inside it. In bending, where the
//! strain grows linearly towards the surfaces, the outer layers then carry too little stress
//! and a plate is as stiff as one about 0.6 spacings thinner (Gray, Monaghan & Swift 2001's
//! oscillating plate: its period 6.8 % long at 10 particles through the thickness, 26 % at 4).
//!
//! What: at a surface particle the gradient is the linear part of a weighted least-squares fit
//! of a quadratic (the moving least squares of Lancaster & Salkauskas 1981, as in the finite
//! particle method of Liu & Liu, Comput. Mech. 2006, and Zhang & Batra's MSPH, Comput. Mech.
//! 2004) with the kernel-gradient weight the linear correction uses. Basis
//! P(d) = (d_x, d_y, d_z, d_x^2, d_y^2, d_z^2, d_x d_y, d_y d_z, d_z d_x), weight
//! w_ab = V_b |gr_ab| (gr = dW/dr / r, 1/m^5, h = (h_a + h_b)/2), and
//!
//! ```text
//! A_a = sum_b w_ab P(d) P(d)^T                  (9 x 9; its linear block is S_a)
//! theta_a = A_a^-1 sum_b w_ab P(d) (v_b - v_a)^T (9 x 3)
//! L_a[k][l] = theta_a[l][k],  l < 3             (exact for quadratic velocity fields)
//! ```
//!
//! That is L_a = sum_b (v_b - v_a) (x) omega_ab with the pair weight
//! omega_ab = w_ab (C_lin d + C_quad q(d)), where (C_lin C_quad) are the first three rows of
//! A_a^-1 and q(d) the quadratic part of P. The force pass uses the same omega (the transpose
//! of the gradient, so the pair forces stay equal and opposite and the stress work is the
//! forces' work): with the linear correction alone C_lin = S_a^-1 = B_a, C_quad = 0, and in a
//! symmetric neighbourhood the third moments vanish and so does C_quad. Only surface particles
//! need the fit (flagged by [`super::settle_gradients`]: a moving solid whose S_a is more than
//! [`SURFACE_SHAPE_TOL`] from the identity), so an interior particle costs what it did; the
//! fit is blended in over [`SURFACE_BLEND`] past that, so no particle's operator jumps.
//!
//! The sums are exact, as the gradient pass's (`crate::exact`): per flagged entry 18 velocity
//! lanes (sum w q(d) (x) (v_b - v_a)), 10 third moments and 15 fourth moments of d, each a
//! lane of [`QuadSums`], ghosts' sums merged into their owners in any order.
use super::tensor::{Mat3, IDENTITY};
use super::{PairGeom, Solids};
use crate::exact::{note, PassGrids, TermMax};
use crate::particles::Particles;
use bytemuck::{Pod, Zeroable};

/// How far the shape sum S_a of a moving solid may be from the identity (largest entry of
/// S_a - I) before it is fitted with the quadratic basis (blended in over [`SURFACE_BLEND`]).
/// Inside a lattice with the cubic spline at h = 1.2 spacings S is 0.982 I; at a flat surface
/// its normal entry is 0.49, one layer under it 0.94.
pub const SURFACE_SHAPE_TOL: f64 = 0.1;

/// The width of the blend from the linear correction to the quadratic fit, in the largest
/// entry of S_a - I past [`SURFACE_SHAPE_TOL`]: a particle's operator changes continuously as
/// its neighbourhood opens (a flag switching on and off from step to step, near a threshold,
/// softened the oscillating plate by 7 % at 10 particles through the thickness).
pub const SURFACE_BLEND: f64 = 0.2;

/// The blend factor of a flagged particle with shape sum `shape`: 0 at [`SURFACE_SHAPE_TOL`],
/// 1 from [`SURFACE_SHAPE_TOL`] + [`SURFACE_BLEND`] on (a flat surface's 0.51 included).
pub fn surface_blend(shape: &Mat3) -> f64 {
    let mut dev = 0.0f64;
    for k in 0..3 {
        for l in 0..3 {
            dev = dev.max((shape[k][l] - IDENTITY[k][l]).abs());
        }
    }
    ((dev - SURFACE_SHAPE_TOL) / SURFACE_BLEND).clamp(0.0, 1.0)
}

/// The largest entry of the first three rows of A'^-1 (the scaled fit's gradient rows) that a
/// particle uses; past it the linear correction stays. A flat surface with h = 1.2 spacings has
/// 34 in the normal direction (the one-sided quadratic fit through two layers, as the
/// difference (3 f_0 - 4 f_1 + f_2) / 2); a particle with too few partners for nine unknowns
/// (a failed element's among a handful) is near-singular, with entries in the thousands.
pub const QUAD_CORRECTION_MAX: f64 = 100.0;

/// The largest entry of the fit's rows below which it is taken whole; from here to
/// [`QUAD_CORRECTION_MAX`] it fades out linearly ([`amplification_blend`]).
pub const QUAD_CORRECTION_FULL: f64 = 40.0;

/// The share of the fit a particle takes by the largest entry `amp` of its scaled rows: 1 up
/// to [`QUAD_CORRECTION_FULL`] (a flat surface's 34), falling linearly to 0 at
/// [`QUAD_CORRECTION_MAX`]. A fit whose weights are that large stiffens its particle's
/// stencil (its highest frequency grows with them) beyond what the stable step allows for
/// (the rubber rings, three particles across the wall, lost 1.4 % of their energy with the
/// fit taken whole up to 100, 0.02 % without it); fading it, rather than cutting it, keeps
/// each particle's operator continuous in time.
pub fn amplification_blend(amp: f64) -> f64 {
    ((QUAD_CORRECTION_MAX - amp) / (QUAD_CORRECTION_MAX - QUAD_CORRECTION_FULL)).clamp(0.0, 1.0)
}

/// The quantities of the quadratic pass's sums, as indices of its [`TermMax`] and
/// [`PassGrids::grid`].
pub mod qq {
    /// Velocity terms w q(d) (v_b - v_a), m/s (w in 1/m^2, q in m^2, v in m/s).
    pub const VELOCITY: usize = 0;
    /// Third moments w d_k d_l d_m, m (w in 1/m^2).
    pub const THIRD: usize = 1;
    /// Fourth moments w d_k d_l d_m d_n, m^2.
    pub const FOURTH: usize = 2;
}

/// Lanes of the velocity sums: q(d)_m (v_b - v_a)_k at lane 3 m + k.
const VEL: usize = 18;
/// The first third-moment lane.
const THIRD0: usize = VEL;
/// The number of third moments (monomials of degree 3 in three variables).
const N3: usize = 10;
/// The first fourth-moment lane.
const FOURTH0: usize = THIRD0 + N3;
/// The number of fourth moments (monomials of degree 4).
const N4: usize = 15;
/// Lanes per entry (43 used, padded to 48).
pub const QLANES: usize = 48;

/// The exponents (of d_x, d_y, d_z) of the quadratic basis q(d), in its order:
/// xx, yy, zz, xy, yz, zx.
#[cfg_attr(not(test), allow(dead_code))]
const QUAD: [[u8; 3]; 6] = [
    [2, 0, 0],
    [0, 2, 0],
    [0, 0, 2],
    [1, 1, 0],
    [0, 1, 1],
    [1, 0, 1],
];

/// The exponents of the third moments, in lane order.
#[cfg_attr(not(test), allow(dead_code))]
const CUBIC: [[u8; 3]; N3] = [
    [3, 0, 0],
    [0, 3, 0],
    [0, 0, 3],
    [2, 1, 0],
    [2, 0, 1],
    [1, 2, 0],
    [0, 2, 1],
    [1, 0, 2],
    [0, 1, 2],
    [1, 1, 1],
];

/// The exponents of the fourth moments, in lane order.
#[cfg_attr(not(test), allow(dead_code))]
const QUARTIC: [[u8; 3]; N4] = [
    [4, 0, 0],
    [0, 4, 0],
    [0, 0, 4],
    [3, 1, 0],
    [3, 0, 1],
    [1, 3, 0],
    [0, 3, 1],
    [1, 0, 3],
    [0, 1, 3],
    [2, 2, 0],
    [0, 2, 2],
    [2, 0, 2],
    [2, 1, 1],
    [1, 2, 1],
    [1, 1, 2],
];

/// The third moment of the linear basis function k times the quadratic one m: the lane (past
/// the first third-moment lane) of d_k q_m(d) in [`CUBIC`] (checked by a test).
const LQ: [[usize; 6]; 3] = [[0, 5, 7, 3, 9, 4], [3, 1, 8, 5, 6, 9], [4, 6, 2, 9, 8, 7]];

/// The fourth moment of the quadratic basis functions m and n: the lane of q_m(d) q_n(d) in
/// [`QUARTIC`] (checked by a test).
const QQ: [[usize; 6]; 6] = [
    [0, 9, 11, 3, 12, 4],
    [9, 1, 10, 5, 6, 13],
    [11, 10, 2, 14, 8, 7],
    [3, 5, 14, 9, 13, 12],
    [12, 6, 8, 13, 10, 14],
    [4, 13, 7, 12, 14, 11],
];

/// q(d): the quadratic part of the basis, xx, yy, zz, xy, yz, zx, m^2.
#[inline(always)]
pub fn quad_basis(d: &[f64; 3]) -> [f64; 6] {
    [
        d[0] * d[0],
        d[1] * d[1],
        d[2] * d[2],
        d[0] * d[1],
        d[1] * d[2],
        d[2] * d[0],
    ]
}

/// The quadratic pass's sums of one flagged entry, fold by fold (`fold[k][l]`: the part on grid
/// k of lane l; lanes: 18 velocity, 10 third moments, 15 fourth moments, 5 unused). 768 bytes.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct QuadSums {
    /// The parts on the top grid (index 0) and the lower grid (index 1) of each lane.
    pub fold: [[f64; QLANES]; 2],
}

impl Default for QuadSums {
    fn default() -> Self {
        Self::zeroed()
    }
}

impl QuadSums {
    /// Merges `o` into these sums (exact).
    pub fn merge(&mut self, o: &QuadSums) {
        for k in 0..2 {
            for l in 0..QLANES {
                self.fold[k][l] += o.fold[k][l];
            }
        }
    }

    /// The value of lane `l` (the folds added top first, as `binsum::value2`).
    fn value(&self, l: usize) -> f64 {
        self.fold[0][l] + self.fold[1][l]
    }

    /// Adds the terms `x` lane by lane, each split on its lane's grids (the operations of
    /// `binsum::Grid2::split`, as `GradSums::add`).
    #[inline(always)]
    fn add(&mut self, x: &[f64; QLANES], c: &[[f64; QLANES]; 2]) {
        let mut r = *x;
        for (fold, ck) in self.fold.iter_mut().zip(c) {
            for l in 0..QLANES {
                let t = (r[l] + ck[l]) - ck[l];
                r[l] -= t;
                fold[l] += t;
            }
        }
    }
}

/// The shifts of the lanes on each fold.
fn lane_shifts(g: &PassGrids) -> [[f64; QLANES]; 2] {
    let (gv, g3, g4) = (g.grid(qq::VELOCITY), g.grid(qq::THIRD), g.grid(qq::FOURTH));
    std::array::from_fn(|k| {
        std::array::from_fn(|l| match l {
            l if l < THIRD0 => gv.shift[k],
            l if l < FOURTH0 => g3.shift[k],
            _ => g4.shift[k],
        })
    })
}

/// The third and fourth moments of `d` in lane order ([`CUBIC`], [`QUARTIC`]), m^3 and m^4.
#[inline(always)]
fn moments(d: &[f64; 3]) -> ([f64; N3], [f64; N4]) {
    let [x, y, z] = *d;
    let (xx, yy, zz) = (x * x, y * y, z * z);
    let cubic = [
        xx * x,
        yy * y,
        zz * z,
        xx * y,
        xx * z,
        yy * x,
        yy * z,
        zz * x,
        zz * y,
        (x * y) * z,
    ];
    let quartic = [
        xx * xx,
        yy * yy,
        zz * zz,
        (xx * x) * y,
        (xx * x) * z,
        (yy * y) * x,
        (yy * y) * z,
        (zz * z) * x,
        (zz * z) * y,
        xx * yy,
        yy * zz,
        xx * zz,
        xx * (y * z),
        yy * (x * z),
        zz * (x * y),
    ];
    (cubic, quartic)
}

/// The terms one entry gets from a pair: `w` = V_other |gr|, `d` = x_other - x_me,
/// `dv` = v_other - v_me.
#[inline(always)]
fn terms(w: f64, d: &[f64; 3], dv: &[f64; 3]) -> [f64; QLANES] {
    let mut x = [0.0; QLANES];
    let q = quad_basis(d);
    for m in 0..6 {
        for k in 0..3 {
            x[3 * m + k] = w * (q[m] * dv[k]);
        }
    }
    let (c3, c4) = moments(d);
    for l in 0..N3 {
        x[THIRD0 + l] = w * c3[l];
    }
    for l in 0..N4 {
        x[FOURTH0 + l] = w * c4[l];
    }
    x
}

/// What the quadratic pass reads of one entry: position, velocity, volume, its slot.
#[derive(Clone, Copy)]
struct QSlot {
    x: [f64; 3],
    v: [f64; 3],
    vol: f64,
    slot: u32,
}

/// The quadratic pass over the pairs of the last gradient pass (`Solids::pair_geom`, the same
/// positions): for every pair with a flagged end (`Solids::quad_flag`, owners' and ghosts'),
/// the flagged end's velocity and moment terms ([`QuadSums`]), exact on `g` (quantities
/// [`qq`]), largest terms into `m`. Sizes and zeroes `Solids::quad_sums` (one per flagged
/// entry, `Solids::quad_slot`) first. Velocities `Particles::v`, as the gradient pass. Flops
/// per flagged end: ~80 for the terms, 2 x 48 x 4 for the exact sums (in the widest build,
/// `super::build`: the same operations, the same bits).
pub fn quadratic_pass(p: &Particles, s: &mut Solids, g: &PassGrids, m: &mut TermMax) {
    let n = p.len();
    s.quad_slot.clear();
    s.quad_slot.resize(n, u32::MAX);
    let mut k = 0u32;
    for i in 0..n {
        if s.quad_flag[i] {
            s.quad_slot[i] = k;
            k += 1;
        }
    }
    s.quad_sums.clear();
    s.quad_sums.resize(k as usize, QuadSums::default());
    if k == 0 {
        return;
    }
    let slots: Vec<QSlot> = (0..n)
        .map(|i| QSlot {
            x: p.x[i],
            v: p.v[i],
            vol: p.m[i] / p.rho[i],
            slot: s.quad_slot[i],
        })
        .collect();
    let shifts = lane_shifts(g);
    let Solids {
        pair_geom,
        quad_sums,
        build,
        ..
    } = s;
    quad_pairs_built(*build, pair_geom, &slots, quad_sums, &shifts, m);
}

super::build::builds!(
    /// [`quad_pairs`] in the build of the pass.
    quad_pairs_built,
    quad_pairs,
    (
        geom: &[PairGeom],
        slots: &[QSlot],
        sums: &mut [QuadSums],
        shifts: &[[f64; QLANES]; 2],
        m: &mut TermMax
    ) -> ()
);

/// The pair loop of [`quadratic_pass`] (inlined into each build).
#[inline(always)]
fn quad_pairs(
    geom: &[PairGeom],
    slots: &[QSlot],
    sums: &mut [QuadSums],
    shifts: &[[f64; QLANES]; 2],
    m: &mut TermMax,
) {
    let mut mx = [0.0f64; QLANES];
    for pg in geom {
        let (a, b) = (&slots[pg.i as usize], &slots[pg.j as usize]);
        if pg.r == 0.0 || (a.slot == u32::MAX && b.slot == u32::MAX) {
            continue;
        }
        // |gr| = -gr: dW/dr <= 0 over the support
        let ag = -pg.gr;
        let d: [f64; 3] = std::array::from_fn(|c| b.x[c] - a.x[c]);
        let dv: [f64; 3] = std::array::from_fn(|c| b.v[c] - a.v[c]);
        for (slot, w, d, dv) in [
            (a.slot, b.vol * ag, d, dv),
            (b.slot, a.vol * ag, d.map(|x| -x), dv.map(|x| -x)),
        ] {
            if slot == u32::MAX {
                continue;
            }
            let x = terms(w, &d, &dv);
            for l in 0..QLANES {
                mx[l] = mx[l].max(x[l].abs());
            }
            sums[slot as usize].add(&x, shifts);
        }
    }
    let group = |r: std::ops::Range<usize>| mx[r].iter().fold(0.0f64, |a, &x| a.max(x));
    note(&mut m[qq::VELOCITY], group(0..THIRD0));
    note(&mut m[qq::THIRD], group(THIRD0..FOURTH0));
    note(&mut m[qq::FOURTH], group(FOURTH0..QLANES));
}

/// Adds a ghost's quadratic sums to its owner's (exact; both flagged).
pub fn fold_quad_ghost(s: &mut Solids, g: usize, o: usize) {
    let (sg, so) = (s.quad_slot[g], s.quad_slot[o]);
    if sg != u32::MAX && so != u32::MAX {
        let x = s.quad_sums[sg as usize];
        s.quad_sums[so as usize].merge(&x);
    }
}

/// The quadratic sums of entry `i` (zero where it is not flagged): what a ghost sends its owner.
pub fn quad_sums_of(s: &Solids, i: usize) -> QuadSums {
    match s.quad_slot.get(i) {
        Some(&k) if k != u32::MAX => s.quad_sums[k as usize],
        _ => QuadSums::default(),
    }
}

/// Solves the 9 x 9 system of every flagged owned entry (scaled by its h: the quadratic basis
/// over h, so that A is dimensionless) and sets its velocity gradient, its correction C_lin
/// (`Solids::correction`, in the place of B) and C_quad (`Solids::quad`, 1/m). An entry whose A
/// is singular or whose C has an entry past [`QUAD_CORRECTION_MAX`] keeps the linear correction.
#[allow(clippy::needless_range_loop)] // index algebra: rows and columns of A and R
pub fn settle_quadratic(p: &Particles, s: &mut Solids) {
    for i in 0..p.n_owned {
        if !s.quad_flag[i] {
            continue;
        }
        let sums = s.quad_sums[s.quad_slot[i] as usize];
        let h = p.h[i];
        // A' = D A D, D = diag(1, 1, 1, 1/h x 6); R' = D R
        let mut a = [[0.0f64; 9]; 9];
        let shape = &s.shape_sum[i];
        for k in 0..3 {
            for l in 0..3 {
                a[k][l] = shape[k][l];
            }
        }
        for k in 0..3 {
            for m in 0..6 {
                let v = sums.value(THIRD0 + LQ[k][m]) / h;
                a[k][3 + m] = v;
                a[3 + m][k] = v;
            }
        }
        for m in 0..6 {
            for n in 0..6 {
                a[3 + m][3 + n] = sums.value(FOURTH0 + QQ[m][n]) / (h * h);
            }
        }
        let Some(inv) = inverse_rows(&a) else {
            continue;
        };
        let amp = inv.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
        if !(amp.is_finite() && amp < QUAD_CORRECTION_MAX) {
            continue;
        }
        // R' rows: linear (grad_sum transposed), quadratic (velocity lanes / h)
        let grad = &s.grad_sum[i];
        let r = |n: usize, k: usize| -> f64 {
            if n < 3 {
                grad[k][n]
            } else {
                sums.value(3 * (n - 3) + k) / h
            }
        };
        let mut l = [[0.0; 3]; 3];
        for (k, row) in l.iter_mut().enumerate() {
            for (c, x) in row.iter_mut().enumerate() {
                let mut t = 0.0;
                for n in 0..9 {
                    t += inv[c][n] * r(n, k);
                }
                *x = t;
            }
        }
        // blended with the linear correction by beta (0 at SURFACE_SHAPE_TOL, 1 from
        // SURFACE_SHAPE_TOL + SURFACE_BLEND on): the pair weight
        // omega = (1 - beta) B g + beta (C_lin |gr| d + C_quad |gr| q(d)), g = grad_a W = |gr| d,
        // so `correction` is (1 - beta) B + beta C_lin and `quad` beta C_quad
        let beta = surface_blend(&s.shape_sum[i]) * amplification_blend(amp);
        let (l1, b1) = (s.grad_v[i], s.correction[i]);
        s.grad_v[i] = std::array::from_fn(|k| {
            std::array::from_fn(|c| l1[k][c] + beta * (l[k][c] - l1[k][c]))
        });
        s.correction[i] = std::array::from_fn(|k| {
            std::array::from_fn(|c| b1[k][c] + beta * (inv[k][c] - b1[k][c]))
        });
        s.quad[i] = std::array::from_fn(|e| beta * (inv[e / 6][3 + e % 6] / h));
        s.quad_share[i] = beta;
    }
}

/// The first three rows of the inverse of the symmetric positive definite 9 x 9 matrix `a`
/// (A = sum w P P^T with w > 0), by Cholesky's factorisation A = G G^T (Golub & Van Loan,
/// Matrix Computations, 4th ed., §4.2) and three solves against the unit vectors e_0, e_1,
/// e_2 (A symmetric: the columns are the rows); `None` where a pivot G_jj^2 falls below 1e-10
/// of the largest entry (singular to the fit's accuracy: too few partners for nine unknowns).
#[allow(clippy::needless_range_loop)] // index algebra of the factorisation
fn inverse_rows(a: &[[f64; 9]; 9]) -> Option<[[f64; 9]; 3]> {
    let scale = a.iter().flatten().fold(0.0f64, |s, x| s.max(x.abs()));
    if !(scale.is_finite() && scale > 0.0) {
        return None;
    }
    // G row by row, and the reciprocals of its diagonal (one division per pivot)
    let mut g = [[0.0f64; 9]; 9];
    let mut inv_d = [0.0f64; 9];
    for j in 0..9 {
        let mut d = a[j][j];
        for k in 0..j {
            d -= g[j][k] * g[j][k];
        }
        if d.is_nan() || d <= 1e-10 * scale {
            return None;
        }
        let gjj = d.sqrt();
        g[j][j] = gjj;
        inv_d[j] = 1.0 / gjj;
        for i in j + 1..9 {
            let mut x = a[i][j];
            for k in 0..j {
                x -= g[i][k] * g[j][k];
            }
            g[i][j] = x * inv_d[j];
        }
    }
    let mut rows = [[0.0f64; 9]; 3];
    for (c, row) in rows.iter_mut().enumerate() {
        // G y = e_c, then G^T x = y
        let mut y = [0.0f64; 9];
        for i in c..9 {
            let mut x = if i == c { 1.0 } else { 0.0 };
            for k in c..i {
                x -= g[i][k] * y[k];
            }
            y[i] = x * inv_d[i];
        }
        for i in (0..9).rev() {
            let mut x = y[i];
            for k in i + 1..9 {
                x -= g[k][i] * row[k];
            }
            row[i] = x * inv_d[i];
        }
    }
    Some(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lane of the monomial with exponents `e` in `list`.
    fn lane_of(list: &[[u8; 3]], e: [u8; 3]) -> usize {
        list.iter().position(|&x| x == e).expect("a monomial")
    }

    #[test]
    fn the_moment_tables_name_the_products_of_the_basis() {
        for k in 0..3 {
            for (m, q) in QUAD.iter().enumerate() {
                let mut e = *q;
                e[k] += 1;
                assert_eq!(LQ[k][m], lane_of(&CUBIC, e), "d_{k} q_{m}");
            }
        }
        for (m, a) in QUAD.iter().enumerate() {
            for (n, b) in QUAD.iter().enumerate() {
                let e = [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
                assert_eq!(QQ[m][n], lane_of(&QUARTIC, e), "q_{m} q_{n}");
            }
        }
        // the monomials in `moments` are those the lists name, in their order
        let d = [2.0, 3.0, 5.0];
        let (c3, c4) = moments(&d);
        let mono = |e: &[u8; 3]| (0..3).map(|c| d[c].powi(e[c] as i32)).product::<f64>();
        for (l, e) in CUBIC.iter().enumerate() {
            assert_eq!(c3[l], mono(e), "cubic lane {l}");
        }
        for (l, e) in QUARTIC.iter().enumerate() {
            assert_eq!(c4[l], mono(e), "quartic lane {l}");
        }
        let q = quad_basis(&d);
        for (m, e) in QUAD.iter().enumerate() {
            assert_eq!(q[m], mono(e), "quadratic basis {m}");
        }
    }
}

#[cfg(test)]
mod inverse_tests {
    use super::*;

    /// The rows solve A x_c = e_c (to 1e-9, the random A's conditioning) for an SPD A of 40 points,
    /// and a rank-deficient A (fewer than nine points) refused.
    #[test]
    #[allow(clippy::needless_range_loop)]
    fn inverse_rows_solve_the_first_three_unit_vectors() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let points = |n: usize, rnd: &mut dyn FnMut() -> f64| {
            let mut a = [[0.0; 9]; 9];
            for _ in 0..n {
                let d = [rnd(), rnd(), rnd()];
                let q = quad_basis(&d);
                let p = [d[0], d[1], d[2], q[0], q[1], q[2], q[3], q[4], q[5]];
                for i in 0..9 {
                    for j in 0..9 {
                        a[i][j] += p[i] * p[j];
                    }
                }
            }
            a
        };
        let a = points(40, &mut rnd);
        let rows = inverse_rows(&a).expect("regular");
        for (c, row) in rows.iter().enumerate() {
            for i in 0..9 {
                let x: f64 = (0..9).map(|k| a[i][k] * row[k]).sum();
                let want = if i == c { 1.0 } else { 0.0 };
                assert!((x - want).abs() < 1e-9, "(A x_{c})_{i} = {x}");
            }
        }
        assert!(
            inverse_rows(&points(6, &mut rnd)).is_none(),
            "six points, nine unknowns"
        );
    }
}
