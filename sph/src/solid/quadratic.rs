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

/// The factors of a pair's products ([`products`]), indices into this list: d_x, d_y, d_z,
/// d_x^2, d_y^2, d_z^2, d_x d_y, d_y d_z, d_z d_x, d_x^3, d_y^3, d_z^3, (v_b - v_a)_{x,y,z},
/// and a zero.
const FACTORS: usize = 16;
const X: u8 = 0;
const Y: u8 = 1;
const Z: u8 = 2;
const XX: u8 = 3;
const YY: u8 = 4;
const ZZ: u8 = 5;
const XY: u8 = 6;
const YZ: u8 = 7;
const ZX: u8 = 8;
const XXX: u8 = 9;
const YYY: u8 = 10;
const ZZZ: u8 = 11;
const DV: u8 = 12;
const NIL: u8 = 15;

/// Lane l of a pair's products is `factor[PRODUCT[l].0] * factor[PRODUCT[l].1]`: the
/// velocity lanes q_m(d) (v_b - v_a)_k (at 3 m + k, [`QUAD`] order), the third moments
/// ([`CUBIC`] order), the fourth ([`QUARTIC`] order; d_x^3 d_y as (d_x^2 d_x) d_y, d_x^2 d_y d_z
/// as d_x^2 (d_y d_z)), zero in the unused lanes (checked by a test).
const PRODUCT: [(u8, u8); QLANES] = [
    (XX, DV),
    (XX, DV + 1),
    (XX, DV + 2),
    (YY, DV),
    (YY, DV + 1),
    (YY, DV + 2),
    (ZZ, DV),
    (ZZ, DV + 1),
    (ZZ, DV + 2),
    (XY, DV),
    (XY, DV + 1),
    (XY, DV + 2),
    (YZ, DV),
    (YZ, DV + 1),
    (YZ, DV + 2),
    (ZX, DV),
    (ZX, DV + 1),
    (ZX, DV + 2),
    (XX, X),
    (YY, Y),
    (ZZ, Z),
    (XX, Y),
    (XX, Z),
    (YY, X),
    (YY, Z),
    (ZZ, X),
    (ZZ, Y),
    (XY, Z),
    (XX, XX),
    (YY, YY),
    (ZZ, ZZ),
    (XXX, Y),
    (XXX, Z),
    (YYY, X),
    (YYY, Z),
    (ZZZ, X),
    (ZZZ, Y),
    (XX, YY),
    (YY, ZZ),
    (XX, ZZ),
    (XX, YZ),
    (YY, ZX),
    (ZZ, XY),
    (NIL, NIL),
    (NIL, NIL),
    (NIL, NIL),
    (NIL, NIL),
    (NIL, NIL),
];

/// The sign of each lane's product at the pair's other end (d and v_b - v_a negated): odd in
/// d and v (velocity lanes, third moments) -1, even (fourth moments) +1. Round to nearest is
/// symmetric, so the other end's products are these signs times this end's, to the bit.
const OTHER_END: [f64; QLANES] = {
    let mut s = [1.0; QLANES];
    let mut l = 0;
    while l < FOURTH0 {
        s[l] = -1.0;
        l += 1;
    }
    s
};

/// The products of one pair end ([`PRODUCT`]): `d` = x_other - x_me, `dv` = v_other - v_me.
/// Its terms are w = V_other |gr| times these.
#[inline(always)]
fn products(d: &[f64; 3], dv: &[f64; 3]) -> [f64; QLANES] {
    let [x, y, z] = *d;
    let (xx, yy, zz) = (x * x, y * y, z * z);
    let f: [f64; FACTORS] = [
        x,
        y,
        z,
        xx,
        yy,
        zz,
        x * y,
        y * z,
        z * x,
        xx * x,
        yy * y,
        zz * z,
        dv[0],
        dv[1],
        dv[2],
        0.0,
    ];
    let p = |l: usize| f[PRODUCT[l].0 as usize] * f[PRODUCT[l].1 as usize];
    [
        p(0),
        p(1),
        p(2),
        p(3),
        p(4),
        p(5),
        p(6),
        p(7),
        p(8),
        p(9),
        p(10),
        p(11),
        p(12),
        p(13),
        p(14),
        p(15),
        p(16),
        p(17),
        p(18),
        p(19),
        p(20),
        p(21),
        p(22),
        p(23),
        p(24),
        p(25),
        p(26),
        p(27),
        p(28),
        p(29),
        p(30),
        p(31),
        p(32),
        p(33),
        p(34),
        p(35),
        p(36),
        p(37),
        p(38),
        p(39),
        p(40),
        p(41),
        p(42),
        p(43),
        p(44),
        p(45),
        p(46),
        p(47),
    ]
}

/// What the quadratic pass reads of one entry: position, velocity, volume, its slot.
#[derive(Clone, Copy)]
pub(super) struct QSlot {
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
    let Solids {
        pair_geom,
        quad_sums,
        quad_slot,
        build,
        buffers,
        ..
    } = s;
    let slots = &mut buffers.quad_slots;
    slots.clear();
    slots.extend((0..n).map(|i| QSlot {
        x: p.x[i],
        v: p.v[i],
        vol: p.m[i] / p.rho[i],
        slot: quad_slot[i],
    }));
    let shifts = lane_shifts(g);
    quad_pairs_built(*build, pair_geom, slots, quad_sums, &shifts, m);
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

/// Adds one pair end's terms `term(l)` to its sums and their sizes to the lanes' largest `mx`
/// (NaN terms left out, as `f64::max` would, in one instruction).
#[inline(always)]
fn add_end(
    sums: &mut QuadSums,
    mx: &mut [f64; QLANES],
    shifts: &[[f64; QLANES]; 2],
    term: impl Fn(usize) -> f64,
) {
    let x: [f64; QLANES] = std::array::from_fn(term);
    for l in 0..QLANES {
        let t = x[l].abs();
        mx[l] = if t > mx[l] { t } else { mx[l] };
    }
    sums.add(&x, shifts);
}

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
        let pa = products(&d, &dv);
        if a.slot != u32::MAX {
            let w = b.vol * ag;
            add_end(&mut sums[a.slot as usize], &mut mx, shifts, |l| w * pa[l]);
        }
        if b.slot != u32::MAX {
            let w = a.vol * ag;
            add_end(&mut sums[b.slot as usize], &mut mx, shifts, |l| {
                w * (OTHER_END[l] * pa[l])
            });
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

/// Flagged entries settled together (`settle_lanes`): one per f64 lane of an AVX-512
/// register.
pub const SETTLE_LANES: usize = 8;

/// One value per lane of a [`settle_lanes`] batch.
type Lanes<const N: usize> = [f64; N];

/// What [`settle_lanes`] reads of each entry of a batch (the folds' values), lane by lane.
#[derive(Clone, Copy)]
struct SettleIn<const N: usize> {
    /// The shape sum S_a (the linear block of A).
    shape: [[Lanes<N>; 3]; 3],
    /// The third moments of d_k q_m(d) ([`LQ`]), m^3 / m^2 (w in 1/m^2).
    third: [[Lanes<N>; 6]; 3],
    /// The fourth moments of q_m(d) q_n(d) ([`QQ`]).
    fourth: [[Lanes<N>; 6]; 6],
    /// The gradient pass's sum grad_sum[k][n] (the linear rows of R).
    grad: [[Lanes<N>; 3]; 3],
    /// The velocity lanes q_m(d) (v_b - v_a)_k, `vel[m][k]`.
    vel: [[Lanes<N>; 3]; 6],
    /// The smoothing length, m.
    h: Lanes<N>,
}

/// What [`settle_lanes`] gives each entry: the first three rows of A'^-1, the fitted gradient,
/// the rows' largest entry, and whether the fit stands (A' regular, its rows finite and below
/// [`QUAD_CORRECTION_MAX`]).
#[derive(Clone, Copy)]
struct SettleOut<const N: usize> {
    inv: [[Lanes<N>; 9]; 3],
    l: [[Lanes<N>; 3]; 3],
    amp: Lanes<N>,
    ok: [bool; N],
}

/// Solves the 9 x 9 system of every flagged owned entry (scaled by its h: the quadratic basis
/// over h, so that A is dimensionless) and sets its velocity gradient, its correction C_lin
/// (`Solids::correction`, in the place of B) and C_quad (`Solids::quad`, 1/m). An entry whose A
/// is singular or whose C has an entry past [`QUAD_CORRECTION_MAX`] keeps the linear correction.
/// The solves run [`SETTLE_LANES`] entries at a time (`settle_lanes`, in the widest build:
/// each lane's operations are one entry's, in its order, so the bits do not depend on the
/// batch or the build).
pub fn settle_quadratic(p: &Particles, s: &mut Solids) {
    let flagged: Vec<usize> = (0..p.n_owned).filter(|&i| s.quad_flag[i]).collect();
    for batch in flagged.chunks(SETTLE_LANES) {
        let inp = gather_settle(p, s, batch);
        let out = settle_lanes_built(s.build, &inp);
        for (lane, &i) in batch.iter().enumerate() {
            if out.ok[lane] {
                apply_fit(s, i, &out, lane);
            }
        }
    }
}

/// The inputs of the entries `batch` (at most [`SETTLE_LANES`]; the lanes past its end repeat
/// its first entry and are not used).
#[allow(clippy::needless_range_loop)] // index algebra: the lanes of A and R
fn gather_settle(p: &Particles, s: &Solids, batch: &[usize]) -> SettleIn<SETTLE_LANES> {
    let z = [0.0; SETTLE_LANES];
    let mut inp = SettleIn {
        shape: [[z; 3]; 3],
        third: [[z; 6]; 3],
        fourth: [[z; 6]; 6],
        grad: [[z; 3]; 3],
        vel: [[z; 3]; 6],
        h: z,
    };
    for lane in 0..SETTLE_LANES {
        let i = batch.get(lane).copied().unwrap_or(batch[0]);
        let sums = &s.quad_sums[s.quad_slot[i] as usize];
        inp.h[lane] = p.h[i];
        for k in 0..3 {
            for c in 0..3 {
                inp.shape[k][c][lane] = s.shape_sum[i][k][c];
                inp.grad[k][c][lane] = s.grad_sum[i][k][c];
            }
            for m in 0..6 {
                inp.third[k][m][lane] = sums.value(THIRD0 + LQ[k][m]);
                inp.vel[m][k][lane] = sums.value(3 * m + k);
            }
        }
        for m in 0..6 {
            for n in 0..6 {
                inp.fourth[m][n][lane] = sums.value(FOURTH0 + QQ[m][n]);
            }
        }
    }
    inp
}

/// Sets entry `i`'s gradient, correction and C_quad from lane `lane` of `out`, blended with the
/// linear correction by beta (0 at [`SURFACE_SHAPE_TOL`], 1 from [`SURFACE_SHAPE_TOL`] +
/// [`SURFACE_BLEND`] on, faded by [`amplification_blend`]): the pair weight
/// omega = (1 - beta) B g + beta (C_lin |gr| d + C_quad |gr| q(d)), g = grad_a W = |gr| d, so
/// `correction` is (1 - beta) B + beta C_lin and `quad` beta C_quad.
fn apply_fit(s: &mut Solids, i: usize, out: &SettleOut<SETTLE_LANES>, lane: usize) {
    let beta = surface_blend(&s.shape_sum[i]) * amplification_blend(out.amp[lane]);
    let (l1, b1) = (s.grad_v[i], s.correction[i]);
    s.grad_v[i] = std::array::from_fn(|k| {
        std::array::from_fn(|c| l1[k][c] + beta * (out.l[k][c][lane] - l1[k][c]))
    });
    s.correction[i] = std::array::from_fn(|k| {
        std::array::from_fn(|c| b1[k][c] + beta * (out.inv[k][c][lane] - b1[k][c]))
    });
    s.quad[i] = std::array::from_fn(|e| beta * out.inv[e / 6][3 + e % 6][lane]);
    s.quad_share[i] = beta;
}

super::build::builds!(
    /// [`settle_lanes`] in the build of the pass.
    settle_lanes_built,
    settle_lanes::<SETTLE_LANES>,
    (inp: &SettleIn<SETTLE_LANES>) -> SettleOut<SETTLE_LANES>
);

/// `f` of every lane.
#[inline(always)]
fn each<const N: usize>(f: impl Fn(usize) -> f64) -> Lanes<N> {
    std::array::from_fn(f)
}

/// The fit of `N` entries, lane by lane: A' = D A D and R' = D R with D = diag(1, 1, 1, 1/h x
/// 6), the first three rows of A'^-1 ([`inverse_rows`]), L[k][c] = sum_n A'^-1[c][n] R'[n][k],
/// and the rows scaled back (C_quad = A'^-1[k][3 + m] / h, 1/m).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // index algebra: rows and columns of A and R
fn settle_lanes<const N: usize>(inp: &SettleIn<N>) -> SettleOut<N> {
    let h = &inp.h;
    let hh: Lanes<N> = each(|l| h[l] * h[l]);
    let mut a = [[[0.0f64; N]; 9]; 9];
    for k in 0..3 {
        for c in 0..3 {
            a[k][c] = inp.shape[k][c];
        }
        for m in 0..6 {
            let v: Lanes<N> = each(|l| inp.third[k][m][l] / h[l]);
            a[k][3 + m] = v;
            a[3 + m][k] = v;
        }
    }
    for m in 0..6 {
        for n in 0..6 {
            a[3 + m][3 + n] = each(|l| inp.fourth[m][n][l] / hh[l]);
        }
    }
    let (mut inv, mut ok) = inverse_rows(&a);
    let amp: Lanes<N> = each(|l| inv.iter().flatten().fold(0.0f64, |m, x| m.max(x[l].abs())));
    for l in 0..N {
        ok[l] &= amp[l].is_finite() && amp[l] < QUAD_CORRECTION_MAX;
    }
    // R' rows: linear (grad_sum transposed), quadratic (velocity lanes / h)
    let mut r = [[[0.0f64; N]; 3]; 9];
    for k in 0..3 {
        for n in 0..3 {
            r[n][k] = inp.grad[k][n];
        }
        for m in 0..6 {
            r[3 + m][k] = each(|l| inp.vel[m][k][l] / h[l]);
        }
    }
    let mut lg = [[[0.0f64; N]; 3]; 3];
    for k in 0..3 {
        for c in 0..3 {
            let mut t = [0.0f64; N];
            for n in 0..9 {
                t = each(|l| t[l] + inv[c][n][l] * r[n][k][l]);
            }
            lg[k][c] = t;
        }
    }
    for row in inv.iter_mut() {
        for x in row[3..].iter_mut() {
            *x = each(|l| x[l] / h[l]);
        }
    }
    SettleOut {
        inv,
        l: lg,
        amp,
        ok,
    }
}

/// The first three rows of the inverse of the symmetric positive definite 9 x 9 matrix `a`
/// (A = sum w P P^T with w > 0) of each lane, by Cholesky's factorisation A = G G^T (Golub &
/// Van Loan, Matrix Computations, 4th ed., §4.2) and three solves against the unit vectors
/// e_0, e_1, e_2 (A symmetric: the columns are the rows); a lane is not `ok` where a pivot
/// G_jj^2 falls below 1e-10 of its largest entry (singular to the fit's accuracy: too few
/// partners for nine unknowns), and its rows are then meaningless.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // index algebra of the factorisation
fn inverse_rows<const N: usize>(a: &[[Lanes<N>; 9]; 9]) -> ([[Lanes<N>; 9]; 3], [bool; N]) {
    let scale: Lanes<N> = each(|l| a.iter().flatten().fold(0.0f64, |s, x| s.max(x[l].abs())));
    let mut ok: [bool; N] = std::array::from_fn(|l| scale[l].is_finite() && scale[l] > 0.0);
    // G row by row, and the reciprocals of its diagonal (one division per pivot)
    let mut g = [[[0.0f64; N]; 9]; 9];
    let mut inv_d = [[0.0f64; N]; 9];
    for j in 0..9 {
        let mut d = a[j][j];
        for k in 0..j {
            d = each(|l| d[l] - g[j][k][l] * g[j][k][l]);
        }
        for l in 0..N {
            ok[l] &= !(d[l].is_nan() || d[l] <= 1e-10 * scale[l]);
        }
        let gjj: Lanes<N> = each(|l| d[l].sqrt());
        g[j][j] = gjj;
        inv_d[j] = each(|l| 1.0 / gjj[l]);
        for i in j + 1..9 {
            let mut x = a[i][j];
            for k in 0..j {
                x = each(|l| x[l] - g[i][k][l] * g[j][k][l]);
            }
            g[i][j] = each(|l| x[l] * inv_d[j][l]);
        }
    }
    let mut rows = [[[0.0f64; N]; 9]; 3];
    for (c, row) in rows.iter_mut().enumerate() {
        // G y = e_c, then G^T x = y
        let mut y = [[0.0f64; N]; 9];
        for i in c..9 {
            let mut x = [if i == c { 1.0 } else { 0.0 }; N];
            for k in c..i {
                x = each(|l| x[l] - g[i][k][l] * y[k][l]);
            }
            y[i] = each(|l| x[l] * inv_d[i][l]);
        }
        for i in (0..9).rev() {
            let mut x = y[i];
            for k in i + 1..9 {
                x = each(|l| x[l] - g[k][i][l] * row[k][l]);
            }
            row[i] = each(|l| x[l] * inv_d[i][l]);
        }
    }
    (rows, ok)
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
        // the products are the monomials the lists name, in their order (exact on small
        // integers), times the velocity components in the velocity lanes
        let (d, dv) = ([2.0, 3.0, 5.0], [7.0, 11.0, 13.0]);
        let p = products(&d, &dv);
        let mono = |e: &[u8; 3]| (0..3).map(|c| d[c].powi(e[c] as i32)).product::<f64>();
        for (m, e) in QUAD.iter().enumerate() {
            for k in 0..3 {
                assert_eq!(p[3 * m + k], mono(e) * dv[k], "velocity lane q_{m} dv_{k}");
            }
        }
        for (l, e) in CUBIC.iter().enumerate() {
            assert_eq!(p[THIRD0 + l], mono(e), "cubic lane {l}");
        }
        for (l, e) in QUARTIC.iter().enumerate() {
            assert_eq!(p[FOURTH0 + l], mono(e), "quartic lane {l}");
        }
        assert!(p[FOURTH0 + N4..].iter().all(|&x| x == 0.0), "unused lanes");
        let q = quad_basis(&d);
        for (m, e) in QUAD.iter().enumerate() {
            assert_eq!(q[m], mono(e), "quadratic basis {m}");
        }
    }

    /// The other end's products are the signs [`OTHER_END`] times this end's, to the bit (d and
    /// v_b - v_a negated), on random values.
    #[test]
    fn the_other_ends_products_are_the_signed_products() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for _ in 0..1000 {
            let d = [rnd(), rnd(), rnd()].map(|x| x * 1e-3);
            let dv = [rnd(), rnd(), rnd()].map(|x| x * 40.0);
            let (pa, pb) = (products(&d, &dv), products(&d.map(|x| -x), &dv.map(|x| -x)));
            for l in 0..QLANES {
                assert_eq!(
                    (OTHER_END[l] * pa[l]).to_bits(),
                    pb[l].to_bits(),
                    "lane {l}: {} against {}",
                    OTHER_END[l] * pa[l],
                    pb[l]
                );
            }
        }
    }
}

#[cfg(test)]
mod inverse_tests {
    use super::*;

    /// A batch of random fits (40 random partners each, one lane with too few) settled eight
    /// at a time gives, in every build this CPU runs, each lane the bits of that entry settled
    /// alone: the batch and the build do not change a particle's gradient.
    #[test]
    #[allow(clippy::needless_range_loop)]
    fn settled_lanes_are_the_bits_of_one_entry_in_every_build() {
        use crate::solid::build::Build;
        let mut seed = 0x1234_5678_9abc_def1u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let z = [0.0; SETTLE_LANES];
        let mut inp = SettleIn {
            shape: [[z; 3]; 3],
            third: [[z; 6]; 3],
            fourth: [[z; 6]; 6],
            grad: [[z; 3]; 3],
            vel: [[z; 3]; 6],
            h: z,
        };
        for l in 0..SETTLE_LANES {
            let h = 1e-3 * (1.0 + 0.1 * rnd());
            inp.h[l] = h;
            let partners = if l == 3 { 5 } else { 40 };
            for _ in 0..partners {
                let d = [rnd(), rnd(), rnd()].map(|x| 4.0 * h * x);
                let dv = [rnd(), rnd(), rnd()];
                let w = 1e6 * (1.0 + rnd());
                let p = products(&d, &dv);
                for k in 0..3 {
                    for c in 0..3 {
                        inp.shape[k][c][l] += w * d[k] * d[c] / (h * h);
                        inp.grad[k][c][l] += w * dv[k] * d[c];
                    }
                    for m in 0..6 {
                        inp.third[k][m][l] += w * p[THIRD0 + LQ[k][m]];
                        inp.vel[m][k][l] += w * p[3 * m + k];
                    }
                }
                for m in 0..6 {
                    for n in 0..6 {
                        inp.fourth[m][n][l] += w * p[FOURTH0 + QQ[m][n]];
                    }
                }
            }
        }
        let lane = |l: usize| SettleIn::<1> {
            shape: inp.shape.map(|r| r.map(|x| [x[l]])),
            third: inp.third.map(|r| r.map(|x| [x[l]])),
            fourth: inp.fourth.map(|r| r.map(|x| [x[l]])),
            grad: inp.grad.map(|r| r.map(|x| [x[l]])),
            vel: inp.vel.map(|r| r.map(|x| [x[l]])),
            h: [inp.h[l]],
        };
        for build in Build::available() {
            let out = settle_lanes_built(build, &inp);
            for l in 0..SETTLE_LANES {
                let one = settle_lanes(&lane(l));
                assert_eq!(out.ok[l], one.ok[0], "{build:?} lane {l}: ok");
                assert_eq!(out.ok[l], l != 3, "lane {l}: five partners are too few");
                let bits = |o: &SettleOut<SETTLE_LANES>| {
                    let mut v: Vec<u64> = o.inv.iter().flatten().map(|x| x[l].to_bits()).collect();
                    v.extend(o.l.iter().flatten().map(|x| x[l].to_bits()));
                    v.push(o.amp[l].to_bits());
                    v
                };
                let mut want: Vec<u64> = one.inv.iter().flatten().map(|x| x[0].to_bits()).collect();
                want.extend(one.l.iter().flatten().map(|x| x[0].to_bits()));
                want.push(one.amp[0].to_bits());
                if one.ok[0] {
                    assert_eq!(bits(&out), want, "{build:?} lane {l}");
                }
            }
        }
    }

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
        let one = |a: &[[f64; 9]; 9]| {
            let lanes: [[Lanes<1>; 9]; 9] = a.map(|row| row.map(|x| [x]));
            let (rows, ok) = inverse_rows(&lanes);
            ok[0].then(|| rows.map(|row| row.map(|x| x[0])))
        };
        let a = points(40, &mut rnd);
        let rows = one(&a).expect("regular");
        for (c, row) in rows.iter().enumerate() {
            for i in 0..9 {
                let x: f64 = (0..9).map(|k| a[i][k] * row[k]).sum();
                let want = if i == c { 1.0 } else { 0.0 };
                assert!((x - want).abs() < 1e-9, "(A x_{c})_{i} = {x}");
            }
        }
        assert!(
            one(&points(6, &mut rnd)).is_none(),
            "six points, nine unknowns"
        );
    }
}
