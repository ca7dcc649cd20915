//! The physical hourglass control of [`crate::hourglass`] (whose module comment derives it) on
//! a group of elements at once, for the batched kernel (`batch::hex`): the same operations in
//! the same order in each lane, the branches (loading or unloading, the yield bound's cases, the
//! tangent ratio's round-off guard) as masked lane operations.
use super::hex::dot3;
use super::{F, M};
use crate::hourglass::{YieldBound, MIN_STRAIN_INCREMENT, THIRD};

type V3 = [F; 3];
type M3 = [[F; 3]; 3];

/// One step of a group's hourglass control (what [`crate::hourglass::HourglassStep`] and
/// [`crate::hourglass::HourglassMaterial`] hold for one element; the shear modulus is positive:
/// the physical kind), its geometry in mode space (`modes.rs`).
pub struct LaneHourglass<'a> {
    /// The element's hourglass rates and frame ([`ModeGeometry`]).
    pub geo: &'a ModeGeometry,
    /// Current volumes, m^3.
    pub vol: F,
    /// The step, s.
    pub dt: f64,
    /// Elastic shear modulus (positive), Pa.
    pub mu: f64,
    /// Poisson's ratio.
    pub nu: f64,
    /// Multiplier of the physical stiffness.
    pub scale: f64,
    /// Tangent ratios in [0, 1].
    pub tangent_ratio: F,
    /// Current yield stresses, for materials with a yield surface.
    pub yield_stress: Option<F>,
    /// How the yield stress bounds the amplitudes.
    pub bound: YieldBound,
    /// The elements' centre stresses (global axes, Voigt), Pa.
    pub stress: [F; 6],
}

/// What the hourglass control needs of the element's geometry and motion, in mode space: the
/// hourglass rates q_a and the Jacobian at the centre (for the element frame).
pub struct ModeGeometry {
    /// q_a = sum_I v_I gamma_aI (global axes), m/s.
    pub q: [V3; 4],
    /// 8 times the Jacobian's rows dx/dxi, dx/deta, dx/dzeta at the centre.
    pub jac: M3,
}

impl ModeGeometry {
    /// The hourglass rates from the modes X = 8 a of the coordinates and `u` of the velocities
    /// for the hourglass modes (eta zeta, zeta xi, xi eta, xi eta zeta), the matrix `lg` =
    /// 64 sum_k U_k (x) G_k (64 V times the end-of-step velocity gradient) and `iv` 1/(64 V):
    /// (8/V) lg a_a = iv (64 lg) X_a, exactly (powers of two). `jac`: 8 times the centre
    /// Jacobian's rows (the frame's directions are the same; its inverse half-lengths 1/8).
    ///
    /// `crate::hourglass::vectors` forms gamma_aI = Gamma_aI - (Gamma_a . x) . b_I node by node;
    /// in mode space sum_I v_I Gamma_aI = U_a and sum_I v_I ((Gamma_a . x) . b_I)
    /// = (1/V) sum_k U_k (G_k . X_a) = (8/V) lg a_a, so q_a = U_a - (8/V) lg a_a.
    /// 4 x 12 operations per element (the node-by-node form: 4 x 120).
    #[inline(always)]
    pub fn new(a: &[V3; 4], u: &[V3; 4], lg: &M3, iv: F, jac: M3) -> ModeGeometry {
        let s8 = iv;
        let mut q = [[F::ZERO; 3]; 4];
        for al in 0..4 {
            for c in 0..3 {
                let t = dot3(lg[c][0], a[al][0], lg[c][1], a[al][1], lg[c][2], a[al][2]);
                q[al][c] = s8.neg_mul_add(t, u[al][c]);
            }
        }
        ModeGeometry { q, jac }
    }
}

#[inline(always)]
fn dot(a: &V3, b: &V3) -> F {
    dot3(a[0], b[0], a[1], b[1], a[2], b[2])
}

/// [`crate::hourglass::tangent_ratio`] in lanes, for a positive `mu`. About 40 flops.
#[inline(always)]
pub fn tangent_ratio(dsig: &[F; 6], deps: &[F; 6], mu: f64) -> F {
    let es = (deps[0] + deps[1] + deps[2]) * THIRD;
    let ss = (dsig[0] + dsig[1] + dsig[2]) * THIRD;
    let de = [deps[0] - es, deps[1] - es, deps[2] - es];
    let ds = [dsig[0] - ss, dsig[1] - ss, dsig[2] - ss];
    let ee = de[0] * de[0]
        + de[1] * de[1]
        + de[2] * de[2]
        + 2.0 * (deps[3] * deps[3] + deps[4] * deps[4] + deps[5] * deps[5]);
    let round_off = ee.lt(F::splat(MIN_STRAIN_INCREMENT * MIN_STRAIN_INCREMENT));
    let se = ds[0] * de[0]
        + ds[1] * de[1]
        + ds[2] * de[2]
        + 2.0 * (dsig[3] * deps[3] + dsig[4] * deps[4] + dsig[5] * deps[5]);
    let ratio = (se * (2.0 * mu * ee).recip()).clamp(0.0, 1.0);
    F::select(round_off, F::splat(1.0), ratio)
}

/// [`crate::hourglass::Frame`] in lanes: rows e_j and inverse lengths 1 / (8 a_j) of the
/// centre Jacobian's rows given 8 times (`ModeGeometry::jac`; a_j the half-lengths): the
/// (1/8) 1/a_j the strain rates take, exactly.
struct Frame {
    e: M3,
    ia: V3,
}

impl Frame {
    /// Gram-Schmidt on the centre Jacobian's rows `j` (j[d] = dx/dxi_d), as `Frame::new`.
    /// About 50 flops.
    #[inline(always)]
    fn new(j: &M3) -> Frame {
        // 1 / |v| as one reciprocal square root (`F::rsqrt`).
        let inv_norm = |v: &V3| dot(v, v).rsqrt();
        let scale = |v: &V3, s: F| [v[0] * s, v[1] * s, v[2] * s];
        let ia = [inv_norm(&j[0]), inv_norm(&j[1]), inv_norm(&j[2])];
        let e0 = scale(&j[0], ia[0]);
        let d01 = dot(&j[1], &e0);
        let t = [
            j[1][0] - d01 * e0[0],
            j[1][1] - d01 * e0[1],
            j[1][2] - d01 * e0[2],
        ];
        let e1 = scale(&t, inv_norm(&t));
        let e2 = [
            e0[1] * e1[2] - e0[2] * e1[1],
            e0[2] * e1[0] - e0[0] * e1[2],
            e0[0] * e1[1] - e0[1] * e1[0],
        ];
        Frame {
            e: [e0, e1, e2],
            ia,
        }
    }

    #[inline(always)]
    fn to_local(&self, v: &V3) -> V3 {
        [dot(&self.e[0], v), dot(&self.e[1], v), dot(&self.e[2], v)]
    }

    #[inline(always)]
    fn to_global(&self, v: &V3) -> V3 {
        let e = &self.e;
        [
            dot3(e[0][0], v[0], e[1][0], v[1], e[2][0], v[2]),
            dot3(e[0][1], v[0], e[1][1], v[1], e[2][1], v[2]),
            dot3(e[0][2], v[0], e[1][2], v[1], e[2][2], v[2]),
        ]
    }
}

/// [`crate::hourglass::physical_strain_rates`] in lanes. 30 flops, no division.
#[inline(always)]
fn strain_rates(qd: &[V3; 4], ia: &V3) -> [V3; 4] {
    // 1/8 in the frame's 1/(8 a_j): a power of two scales exactly, so each product and sum
    // has the scalar kernel's bits.
    let ia8 = ia;
    let mut e = [[F::ZERO; 3]; 4];
    for g in 0..3 {
        let (p, r) = ((g + 1) % 3, (g + 2) % 3);
        e[g] = [
            qd[r][p] * ia8[p],
            qd[p][r] * ia8[r],
            qd[r][r].mul_add(ia8[p], qd[p][p] * ia8[r]),
        ];
    }
    for i in 0..3 {
        e[3][i] = qd[3][i] * ia8[i];
    }
    e
}

/// [`crate::hourglass::physical_forces`] in lanes. About 45 flops, no division.
#[inline(always)]
fn forces(sig: &[V3; 4], ia: &V3, vol: F) -> [V3; 4] {
    // w = V/24 on the half-lengths' 1/a_j; 8 w on the frame's 1/(8 a_j).
    let w = vol * THIRD;
    let wia = [w * ia[0], w * ia[1], w * ia[2]];
    let mut h = [[F::ZERO; 3]; 4];
    for g in 0..3 {
        let (p, r) = ((g + 1) % 3, (g + 2) % 3);
        let [spp, srr, spr] = sig[g];
        h[r][p] = spp.mul_add(wia[p], h[r][p]);
        h[p][r] = srr.mul_add(wia[r], h[p][r]);
        h[r][r] = spr.mul_add(wia[p], h[r][r]);
        h[p][p] = spr.mul_add(wia[r], h[p][p]);
    }
    for i in 0..3 {
        h[3][i] = sig[3][i] * (wia[i] * THIRD);
    }
    h
}

/// The power of the amplitudes `sig` on the strain rates `e`, sum_g sig_g . e_g + sig_3 . e_3 / 3
/// (the sign that picks loading or unloading). With the generalised forces H = [`forces`] of
/// `sig`, sum_a H_a . qd_a = (V / 3) times this power: each force term w (1/a_p) s qd_a/8 there
/// is V/3 times a product s e here (w = V / 24, e = qd (1/a) / 8; mode 3 with the same 1/3 on
/// both sides). 13 operations per element.
#[inline(always)]
fn power(sig: &[V3; 4], e: &[V3; 4]) -> F {
    dot(&sig[0], &e[0]) + dot(&sig[1], &e[1]) + dot(&sig[2], &e[2]) + dot(&sig[3], &e[3]) * THIRD
}

/// The physical stress-amplitude rates (`physical_stress_rates`: plane stress per group with
/// Ebar = 2 mu / (1 - nu), 2 mu on mode 3) for the lanes' moduli `mu`.
#[inline(always)]
fn stress_rates(e: &[V3; 4], mu: F, nu: f64) -> [V3; 4] {
    // 2 / (1 - nu) once per group, not a division in the lanes.
    let ebar = mu * (2.0 / (1.0 - nu));
    let mut r = [[F::ZERO; 3]; 4];
    for g in 0..3 {
        let [epp, err, gpr] = e[g];
        r[g] = [ebar * (epp + nu * err), ebar * (err + nu * epp), mu * gpr];
    }
    r[3] = [2.0 * mu * e[3][0], 2.0 * mu * e[3][1], 2.0 * mu * e[3][2]];
    r
}

/// `crate::hourglass`'s `Centre` in lanes: the centre stress, its deviator's diagonal and its
/// Mises form with itself. 25 flops.
struct Centre {
    a: M3,
    da: V3,
    mises_sq: F,
}

impl Centre {
    #[inline(always)]
    fn new(a: &M3) -> Centre {
        let ta = (a[0][0] + a[1][1] + a[2][2]) * THIRD;
        let da = [a[0][0] - ta, a[1][1] - ta, a[2][2] - ta];
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        let mises_sq = 1.5 * (da[0] * da[0] + da[1] * da[1] + da[2] * da[2] + 2.0 * off);
        Centre {
            a: *a,
            da,
            mises_sq,
        }
    }

    /// (B, C) of group g's amplitudes (`Centre::group`). 20 flops.
    #[inline(always)]
    fn group(&self, g: usize, tau: &V3) -> (F, F) {
        let (p, r) = ((g + 1) % 3, (g + 2) % 3);
        let [tpp, trr, tpr] = *tau;
        let b = 1.5 * (self.da[p] * tpp + self.da[r] * trr + 2.0 * self.a[p][r] * tpr);
        let tm = (tpp + trr) * THIRD;
        let (dp, dr) = (tpp - tm, trr - tm);
        let c = 1.5 * (dp * dp + dr * dr + tm * tm + 2.0 * tpr * tpr);
        (b, c)
    }

    /// The gradient g of B over group g's amplitudes (`g == 3`: mode 3's) and m = Q^+ g
    /// (`Centre::normal`). 10 flops.
    #[inline(always)]
    fn normal(&self, g: usize) -> (V3, V3) {
        if g < 3 {
            let (p, r) = ((g + 1) % 3, (g + 2) % 3);
            let gb = [1.5 * self.da[p], 1.5 * self.da[r], 3.0 * self.a[p][r]];
            let m = [
                gb[0] * (4.0 * THIRD) + gb[1] * (2.0 * THIRD),
                gb[0] * (2.0 * THIRD) + gb[1] * (4.0 * THIRD),
                gb[2] * THIRD,
            ];
            (gb, m)
        } else {
            let gb = [1.5 * self.da[0], 1.5 * self.da[1], 1.5 * self.da[2]];
            (gb, self.da)
        }
    }

    /// (B, C) of mode 3's amplitudes (`Centre::mode3`). 20 flops.
    #[inline(always)]
    fn mode3(&self, tau: &V3) -> (F, F) {
        let b = 1.5 * (self.da[0] * tau[0] + self.da[1] * tau[1] + self.da[2] * tau[2]);
        let tm = (tau[0] + tau[1] + tau[2]) * THIRD;
        let d = [tau[0] - tm, tau[1] - tm, tau[2] - tm];
        let c = 1.5 * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        (b, c)
    }
}

/// The factor lambda of one group with the Mises forms `(b, c)` of its amplitudes (a function,
/// not a closure, so that it inlines into the target-feature builds): `a` the Mises form of the
/// centre stress, `sy2` the squared yield stress.
#[inline(always)]
fn group_scale((b, c): (F, F), a: F, sy2: F) -> F {
    // sqrt(d) as d / sqrt(d) (`F::rsqrt`); d > 0 in every lane the selects below keep.
    let d = b.mul_add(b, c * (sy2 - a));
    let f = ((-b.abs() + d * d.rsqrt()) * c.recip()).min(F::splat(1.0));
    let f = F::select(a.ge(sy2), F::ZERO, f);
    F::select(c.le(F::ZERO), F::splat(1.0), f)
}

/// `yield_bound` in lanes. [`YieldBound::Fibres`]: each group's amplitudes scaled by lambda in
/// [0, 1] so that the fibre stresses sigma_c +- lambda tau stay inside the von Mises surface of
/// radius `sy`; lambda = 1 in a lane whose tau has no deviator, 0 in a lane whose centre is on
/// or outside the surface. [`YieldBound::Tangential`]: the part of tau normal to the surface at
/// the centre bounded so, the tangential part returned radially with the fibre
/// (`crate::hourglass`'s module comment).
#[inline(always)]
fn yield_bound(sig: &mut [V3; 4], centre: &M3, sy: F, bound: YieldBound) {
    let centre = Centre::new(centre);
    let a = centre.mises_sq;
    let sy2 = sy * sy;
    for g in 0..4 {
        let bc = if g < 3 {
            centre.group(g, &sig[g])
        } else {
            centre.mode3(&sig[3])
        };
        if bound == YieldBound::Tangential {
            let (gb, m) = centre.normal(g);
            let gg = dot(&gb, &m);
            let (b, c) = bc;
            // The normal part (B / G) m and its Mises form B^2 / G; none in a lane whose
            // centre has no deviator on these entries (B = 0 there too).
            let some = gg.gt(F::splat(1e-300));
            let igg = gg.recip();
            let coef = F::select(some, b * igg, F::ZERO);
            let cn = F::select(some, b * b * igg, F::ZERO);
            let ct = (c - cn).max(F::ZERO);
            let ln = group_scale((b, cn), a, sy2);
            let an = a + 2.0 * ln * b.abs() + ln * ln * cn;
            let lt = (sy2 * (an + ct).recip()).sqrt().min(F::splat(1.0));
            let lt = F::select(ct.le(F::ZERO), F::splat(1.0), lt);
            for i in 0..3 {
                let tn = coef * m[i];
                sig[g][i] = ln * tn + lt * (sig[g][i] - tn);
            }
            continue;
        }
        let f = group_scale(bc, a, sy2);
        for v in sig[g].iter_mut() {
            *v *= f;
        }
    }
}

/// The centre stress in the element frame, E sigma E^T (`crate::hourglass::centre_stress`:
/// T = E sigma, then the upper triangle of T E^T, mirrored). 75 flops.
#[inline(always)]
fn centre_stress(st: &[F; 6], e: &M3) -> M3 {
    let g = [
        [st[0], st[3], st[5]],
        [st[3], st[1], st[4]],
        [st[5], st[4], st[2]],
    ];
    let mut t = [[F::ZERO; 3]; 3];
    for i in 0..3 {
        for l in 0..3 {
            t[i][l] = dot3(e[i][0], g[0][l], e[i][1], g[1][l], e[i][2], g[2][l]);
        }
    }
    let m = |i: usize, j: usize| dot3(t[i][0], e[j][0], t[i][1], e[j][1], t[i][2], e[j][2]);
    let (m01, m02, m12) = (m(0, 1), m(0, 2), m(1, 2));
    [
        [m(0, 0), m01, m02],
        [m01, m(1, 1), m12],
        [m02, m12, m(2, 2)],
    ]
}

/// The FB forms' step on a group of elements ([`crate::hourglass`]'s `Hourglass::apply` for
/// `Stiffness` and `Viscous`): the generalised forces `hg` (element frame, N) grow by dt `rate`
/// qd, and the viscous part `visc` qd is added to them for the force. Returns the work of the
/// step (the trapezoid on the stiffness part), J, and the generalised forces in global axes,
/// whose nodal forces are -H_a gamma_aI (the caller adds them in mode space). `rate`: kappa
/// 2 mu V sum(b^2) / 8 of each lane, N/m (zero for the viscous form); `visc`: kappa rho c
/// V^(2/3) / 4, kg/s (zero for the stiffness form).
///
/// Cost per element: 50 (frame) + 4 x 15 (to local) + 12 x 9 (update and work) + 4 x 15
/// (to global) = about 280 operations; 12 state doubles read and written.
#[inline(always)]
pub fn fb(geo: &ModeGeometry, rate: F, visc: F, dt: f64, hg: &mut [V3; 4]) -> (F, [V3; 4]) {
    let frame = Frame::new(&geo.jac);
    let dt_rate = dt * rate;
    let mut work = F::ZERO;
    let mut tg = [[F::ZERO; 3]; 4];
    for al in 0..4 {
        let qd = frame.to_local(&geo.q[al]);
        let mut h = [F::ZERO; 3];
        for i in 0..3 {
            // As the scalar kernel: new = old + dt rate qd, qv = visc qd (a zero coefficient
            // still multiplied, so that a -0.0 comes out as it does there).
            let old = hg[al][i];
            let new = dt_rate.mul_add(qd[i], old);
            let qv = visc * qd[i];
            work = (dt * (0.5 * (old + new) + qv)).mul_add(qd[i], work);
            hg[al][i] = new;
            h[i] = new + qv;
        }
        tg[al] = frame.to_global(&h);
    }
    (work, tg)
}

/// The physical kind's step on a group of elements ([`crate::hourglass`]'s `physical_step`):
/// updates the stress amplitudes `sig` and returns the hourglass work of the step, J, and the
/// generalised forces H_a in global axes, whose nodal forces are -H_a gamma_aI (the caller adds
/// them in mode space).
///
/// Cost per element: about 50 (frame) + 4 x 15 (to local) + 4 x 51 (rates) + 24 + 30 + 26 + 60
/// (amplitudes and work) + 162 + 4 x 110 (yield bound) + 4 x 15 (to global) = about 1,050
/// flops with the yield bound, on 12 state doubles (read and written).
#[inline(always)]
pub fn physical(s: &LaneHourglass, sig: &mut [V3; 4]) -> (F, [V3; 4]) {
    let frame = Frame::new(&s.geo.jac);
    let qd = [
        frame.to_local(&s.geo.q[0]),
        frame.to_local(&s.geo.q[1]),
        frame.to_local(&s.geo.q[2]),
        frame.to_local(&s.geo.q[3]),
    ];
    let e = strain_rates(&qd, &frame.ia);
    // Loading (positive power of the amplitudes) follows the tangent, unloading is elastic.
    let power_old = power(sig, &e);
    let loading: M = power_old.gt(F::ZERO);
    let s_eff = F::select(loading, s.tangent_ratio, F::splat(1.0));
    let rate = stress_rates(&e, s.scale * s_eff * s.mu, s.nu);
    for al in 0..4 {
        for i in 0..3 {
            sig[al][i] = rate[al][i].mul_add(F::splat(s.dt), sig[al][i]);
        }
    }
    if let Some(sy) = s.yield_stress {
        yield_bound(sig, &centre_stress(&s.stress, &frame.e), sy, s.bound);
    }
    let h = forces(sig, &frame.ia, s.vol);
    // The work of the step, the trapezoid dt/2 sum_a (H_a(n) + H_a(n+1)) . qd_a, through
    // [`power`]: sum_a H_a . qd_a = (V / 3) power (see there), so no forces of the old
    // amplitudes.
    let work = (s.dt * 0.5) * (s.vol * THIRD) * (power_old + power(sig, &e));
    let tg = [
        frame.to_global(&h[0]),
        frame.to_global(&h[1]),
        frame.to_global(&h[2]),
        frame.to_global(&h[3]),
    ];
    (work, tg)
}
