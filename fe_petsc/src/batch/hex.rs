//! The hexahedron of [`crate::hex`] on a group of elements at once, one element per lane (the
//! parent module's lane type `F`, four or eight lanes): the same operations in every lane, the scalar kernel's branches as
//! masked lane operations, the nodal values gathered into lanes and the forces handed back per
//! element. Each lane computes what [`crate::hex::update`] computes for its element: the same
//! material law, hourglass control and stable step in the same order, but the geometry (volume,
//! gradients, hourglass rates, nodal forces) in mode space (`modes.rs`), about 700 fewer
//! operations per element than the scalar kernel's node-by-node forms, so the kernels agree to
//! round-off (`tests/lanes.rs`: 1e-12 relative required, 2e-13 measured).
//!
//! Why: the scalar update is one serial dependency chain of about 4,500 instructions per
//! element at about 1.5 flops per cycle (DESIGN.md section 7); independent elements in lanes
//! fill the vector units and hide the latencies.
//!
//! Scope: every material and hourglass control. The elastic and J2 laws run in lanes
//! ([`crate::material::LaneLaw`]); the other models' stress updates, wave moduli, heating and
//! yield stresses are their own scalar functions called lane by lane (`pointwise.rs`), the rest
//! of the element in lanes. A group with an element whose volume (end of step or mid-step) is
//! not positive and finite returns an error naming the lane before it changes any state.
use super::hourglass::{self as hourglass_lanes, LaneHourglass};
use super::law;
use super::modes;
use super::pointwise::{self, LaneHistory, Pointwise};
use super::{F, LANES, M};
use crate::batch::{GroupInverted, LaneHourglassKind, LaneMaterial};
use crate::hex::{HexControls, HexOutput, HexState, NODES, SQRT_3};
use crate::material::{Material, MAX_STATE};

type V3 = [F; 3];

/// The mode sums of a nodal field ([`modes::modes`]): xi .. xi eta, and xi eta zeta.
type Modes = ([V3; 6], V3);

/// Nodal vectors of a group's elements in lanes: `[node][component]`.
pub type LaneNodes = [[F; 3]; NODES];

/// The state of a group's elements ([`HexState`] and the material's history variable) in lanes.
#[derive(Clone, Copy, Debug, Default)]
pub struct LaneState {
    /// Cauchy stress (Voigt), Pa.
    pub(crate) stress: [F; 6],
    /// Hourglass stress amplitudes in each element's frame, Pa.
    pub(crate) hg: [[F; 3]; 4],
    /// The material's history variable (the plastic strain of J2), 0 for elastic.
    pub(crate) history: F,
}

impl LaneState {
    /// Writes element state `s` and history value `h` into lane `l`.
    #[inline]
    pub fn set_lane(&mut self, l: usize, s: &HexState, h: f64) {
        for k in 0..6 {
            self.stress[k].0[l] = s.stress[k];
        }
        for a in 0..4 {
            for i in 0..3 {
                self.hg[a][i].0[l] = s.hg[a][i];
            }
        }
        self.history.0[l] = h;
    }

    /// The element state and history value of lane `l`.
    #[inline]
    pub fn lane(&self, l: usize) -> (HexState, f64) {
        let s = HexState {
            stress: std::array::from_fn(|k| self.stress[k].0[l]),
            hg: std::array::from_fn(|a| std::array::from_fn(|i| self.hg[a][i].0[l])),
        };
        (s, self.history.0[l])
    }
}

/// What one update of a group produced ([`HexOutput`] in lanes).
#[derive(Clone, Copy, Debug, Default)]
pub struct LaneOutput {
    /// Force on each node from each element, N.
    pub(crate) force: LaneNodes,
    /// Hourglass work of each element this step, J.
    pub(crate) hg_work: F,
    /// Current volumes, m^3.
    pub(crate) volume: F,
    /// Stable steps (no safety factor), s.
    pub(crate) dt_stable: F,
    /// Pressures without bulk viscosity, Pa.
    pub(crate) pressure: F,
}

impl LaneOutput {
    /// The output of the element in lane `l`.
    #[inline]
    pub fn lane(&self, l: usize) -> HexOutput {
        HexOutput {
            force: std::array::from_fn(|k| std::array::from_fn(|c| self.force[k][c].0[l])),
            hg_work: self.hg_work.0[l],
            volume: self.volume.0[l],
            dt_stable: self.dt_stable.0[l],
            pressure: self.pressure.0[l],
        }
    }
}

/// Writes the nodal vectors `xs` of the group's elements `conn` into the lanes `out` (every entry:
/// a buffer can be reused from group to group without clearing).
///
/// Cost: 24 doubles read per element from `xs` (192 B, scattered over the nodes' cache lines),
/// 24 written to the lanes; no flops.
#[inline]
pub fn gather(xs: &[[f64; 3]], conn: [&[u32; NODES]; LANES], out: &mut LaneNodes) {
    for (l, c) in conn.iter().enumerate() {
        for (k, &n) in c.iter().enumerate() {
            let p = &xs[n as usize];
            for d in 0..3 {
                out[k][d].0[l] = p[d];
            }
        }
    }
}

/// Lanes whose volume is positive and finite.
#[inline(always)]
pub(super) fn valid_volume(v: F) -> M {
    v.gt(F::ZERO).and(v.is_finite())
}

/// The kinematics of one step in lanes, in mode space (`modes.rs`): the coordinates' and
/// velocities' modes, the end-of-step volume gradient, the rate of deformation and the
/// Hughes-Winget rotation of the step.
struct Kinematics {
    /// Modes of the coordinates at t(n+1), X_k (xi .. xi eta): 8 a_k, a_k the modes over 8
    /// (the module comment's); their first three are 8 times the rows of the Jacobian at the
    /// centre. (Here and below the factors of 8 and 64 are powers of two carried exactly to
    /// where a product already forms: every value has the bits of the unscaled form's.)
    xk: [V3; 6],
    /// The xi eta zeta mode of the coordinates, X_7.
    xk7: V3,
    /// Modes of the velocities U_k (xi .. xi eta), and the xi eta zeta one.
    u: [V3; 6],
    u7: V3,
    /// 64 dV/dX_k at t(n+1) (64 G_k: the gradient of the modes X rather than a): the mean
    /// gradient B_I = sum_k phi_k(I) G_k.
    g64: [V3; 6],
    /// Sum over the nodes of |b_I|^2, b = B / V.
    bb: F,
    vol: F,
    iv: F,
    /// Rate of deformation (Voigt, tensor shears), 1/s.
    d: [F; 6],
    /// The incremental rotation R.
    r: [[F; 3]; 3],
}

/// The gradients at the end and the middle of the step, the velocity gradient at mid-step and
/// its split, as [`crate::hex::update`] defines them, computed in mode space; `Err` when a
/// lane's volume (end or middle) is not positive and finite.
///
/// The mid-step coordinates are x(n+1/2) = x(n+1) - dt/2 v(n+1/2); the transform is linear, so
/// their modes are a_k - dt/16 U_k. The velocity gradient L = sum_I v_I (x) B_I(n+1/2) / V(n+1/2)
/// = sum_k U_k (x) G_k(n+1/2) / V(n+1/2).
///
/// Cost per element: 18 (a) + 18 (mid-step modes) + 2 x 100 (volume gradients) + 54 + 9 (L) +
/// 20 (sum b^2) + 60 (the rotation) = about 380 operations, after the 2 x 69 of the modes of
/// x and v (`xm`, `um`, formed by the caller); nothing read or written outside the lanes.
#[inline(always)]
fn kinematics(xm: &Modes, um: &Modes, dt: f64) -> Result<Kinematics, GroupInverted> {
    let (xk, xk7) = *xm;
    let (u, u7) = *um;
    // The mid-step modes X - dt/2 U (8 times a - dt/16 U).
    let mut xh = [[F::ZERO; 3]; 6];
    let h2 = F::splat(0.5 * dt);
    for m in 0..6 {
        for c in 0..3 {
            xh[m][c] = h2.neg_mul_add(u[m][c], xk[m][c]);
        }
    }
    let (g64, vol) = modes::volume_gradient(&xk);
    let (gh64, volh) = modes::volume_gradient(&xh);
    if !(valid_volume(vol).all() && valid_volume(volh).all()) {
        return Err(first_inverted(vol, volh));
    }
    // 1/V and 1/V(n+1/2) from one reciprocal.
    let inv = (vol * volh).recip();
    let (iv, ivh) = (volh * inv, vol * inv);
    // sum_I |B_I|^2 = 8 sum_k |G_k|^2 (the modes are orthogonal over the nodes), the sum
    // formed on 64 G (4096 times).
    let mut gg = g64[0][0] * g64[0][0];
    for m in 0..6 {
        for c in 0..3 {
            if m + c > 0 {
                gg = g64[m][c].mul_add(g64[m][c], gg);
            }
        }
    }
    let bb = (8.0 / 4096.0) * gg * (iv * iv);
    let ivh64 = ivh * (1.0 / 64.0);
    let mut l = outer_sum(&u, &gh64);
    for row in l.iter_mut() {
        for e in row.iter_mut() {
            *e *= ivh64;
        }
    }
    let d = [
        l[0][0],
        l[1][1],
        l[2][2],
        0.5 * (l[0][1] + l[1][0]),
        0.5 * (l[1][2] + l[2][1]),
        0.5 * (l[2][0] + l[0][2]),
    ];
    let w01 = 0.5 * (l[0][1] - l[1][0]);
    let w12 = 0.5 * (l[1][2] - l[2][1]);
    let w20 = 0.5 * (l[2][0] - l[0][2]);
    let r = hughes_winget(w01, w12, w20, dt);
    Ok(Kinematics {
        xk,
        xk7,
        u,
        u7,
        g64,
        bb,
        vol,
        iv,
        d,
        r,
    })
}

/// sum_m a_m (x) b_m over the six modes: entry (i, j) is a_0i b_0j, then + a_mi b_mj for m = 1
/// .. 5 in turn (`F::mul_add`). Written mode by mode, the nine sums held while each mode's six
/// values are read once (fifteen registers: AVX2's sixteen hold them without spilling); each
/// entry's operations are the same, in the same order, as entry by entry.
#[inline(always)]
fn outer_sum(a: &[V3; 6], b: &[V3; 6]) -> [[F; 3]; 3] {
    let mut s = [[F::ZERO; 3]; 3];
    for (i, row) in s.iter_mut().enumerate() {
        for (j, e) in row.iter_mut().enumerate() {
            *e = a[0][i] * b[0][j];
        }
    }
    for m in 1..6 {
        let (am, bm) = (a[m], b[m]);
        for (i, row) in s.iter_mut().enumerate() {
            for (j, e) in row.iter_mut().enumerate() {
                *e = am[i].mul_add(bm[j], *e);
            }
        }
    }
    s
}

/// The first lane whose end-of-step volume `vol` or mid-step volume `volh` is not positive and
/// finite, with that volume (the end-of-step one first, as [`crate::hex::update`] checks them).
#[cold]
#[inline(never)]
pub(super) fn first_inverted(vol: F, volh: F) -> GroupInverted {
    let bad = |v: f64| !(v > 0.0 && v.is_finite());
    (0..LANES)
        .find_map(|lane| {
            [vol.0[lane], volh.0[lane]]
                .into_iter()
                .find(|&v| bad(v))
                .map(|volume| GroupInverted { lane, volume })
        })
        .expect("a lane with a bad volume")
}

/// a0 b0 + a1 b1 + a2 b2 summed left to right, each product added by `F::mul_add` (two
/// roundings in every width, as the scalar kernel).
#[inline(always)]
pub(super) fn dot3(a0: F, b0: F, a1: F, b1: F, a2: F, b2: F) -> F {
    a2.mul_add(b2, a1.mul_add(b1, a0 * b0))
}

/// Hughes-Winget: R = (I - dt/2 W)^-1 (I + dt/2 W), incrementally objective, in the Cayley
/// transform's closed form: with A = dt/2 W = skew(omega) (A x = omega x x) and A^3 =
/// -theta^2 A (theta = |omega|), (I - A)(I + c (A + A^2)) = I + (c (1 + theta^2) - 1) A = I + A
/// for c = 2 / (1 + theta^2), so R = I + c (A + omega omega^T - theta^2 I). The scalar kernel
/// inverts I - A by cofactors (the same R to round-off; `tests/lanes.rs`); its identity for a
/// singular or non-finite determinant, det(I - A) = 1 + theta^2, is kept. About 45 operations
/// per element (the cofactor form: 60).
#[inline(always)]
pub(super) fn hughes_winget(w01: F, w12: F, w20: F, dt: f64) -> [[F; 3]; 3] {
    let h = F::splat(-0.5 * dt);
    // A = [[0, h w01, -h w20], [-h w01, 0, h w12], [h w20, -h w12, 0]] (h = dt/2) = skew(om).
    let om = [w12 * h, w20 * h, w01 * h];
    let th2 = dot3(om[0], om[0], om[1], om[1], om[2], om[2]);
    let det = 1.0 + th2;
    let c = 2.0 * det.recip();
    let diag = |i: usize| c.mul_add(om[i].mul_sub(om[i], th2), F::splat(1.0));
    let off = |i: usize, j: usize, k: usize, plus: bool| {
        // c (om_i om_j +- om_k): A_ij = -om_k for (i, j, k) cyclic, +om_k otherwise.
        let t = if plus {
            om[i].mul_add(om[j], om[k])
        } else {
            om[i].mul_sub(om[j], om[k])
        };
        c * t
    };
    let r = [
        [diag(0), off(0, 1, 2, false), off(0, 2, 1, true)],
        [off(1, 0, 2, true), diag(1), off(1, 2, 0, false)],
        [off(2, 0, 1, false), off(2, 1, 0, true), diag(2)],
    ];
    let bad = !det.is_finite();
    let mut out = [[F::ZERO; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let eye = F::splat(if i == j { 1.0 } else { 0.0 });
            out[i][j] = F::select(bad, eye, r[i][j]);
        }
    }
    out
}

/// sigma <- R sigma R^T (Voigt in, Voigt out). 90 flops per element.
#[inline(always)]
pub(super) fn rotate(r: &[[F; 3]; 3], s: &[F; 6]) -> [F; 6] {
    let sm = [[s[0], s[3], s[5]], [s[3], s[1], s[4]], [s[5], s[4], s[2]]];
    let mut rs = [[F::ZERO; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            rs[i][j] = dot3(r[i][0], sm[0][j], r[i][1], sm[1][j], r[i][2], sm[2][j]);
        }
    }
    let rot = |i: usize, j: usize| dot3(rs[i][0], r[j][0], rs[i][1], r[j][1], rs[i][2], r[j][2]);
    [
        rot(0, 0),
        rot(1, 1),
        rot(2, 2),
        rot(0, 1),
        rot(1, 2),
        rot(2, 0),
    ]
}

/// The bulk viscosity's pressure q and damping ratio xi ([`crate::hex`]'s `bulk_viscosity`, whose
/// comment derives them) and the element's stable step (its `critical_dt`), in lanes, for the
/// density `rho`, sound speed `c`, sum(b^2) `bb` and volumetric rate `ev`. The square roots
/// here stay IEEE (`vsqrtpd`; reciprocal square roots gained nothing measurable here). With
/// reciprocal square roots for s and sqrt(1 + xi^2), `block_flat_drop` with its nodes exactly
/// over the plate's edge midpoints left np 1's history at np 3 by 3e-8 (the rank tests' limit
/// is 1e-10): in that exactly tied contact the push-back follows last-bit differences in the
/// positions, which the ghost sums' order makes rank-dependent once forces are not zero, and
/// this form of the step happened to let them in a step before the tie was settled. (Moved by
/// 1e-7 m off the tie, np 1 and np 3 agree to 1e-16 either way.)
#[inline(always)]
fn bulk_viscosity_and_dt(ctl: &HexControls, bb: F, rho: F, c: F, ev: F) -> (F, F) {
    let s = (2.0 * bb).sqrt();
    let ics = (c * s).recip();
    let len = SQRT_3 * (c * ics);
    let comp = (-ev).max(F::ZERO);
    let lin_quad = ctl.bv_linear + ctl.bv_quadratic * ctl.bv_quadratic * len * comp * (s * ics);
    let q = rho * len * c * ev * lin_quad;
    let xi = lin_quad * len * s;
    let dt = ics * ((1.0 + xi * xi).sqrt() - xi);
    (q, dt)
}

/// A group of elements in lanes: their nodal values, reference volumes and state going in, their
/// output coming out. One buffer serves group after group without clearing: [`gather`] and
/// [`LaneState::set_lane`] write every entry, and [`crate::batch::Batch::update`] every output.
#[derive(Clone, Copy, Debug, Default)]
pub struct LaneGroup {
    /// Nodal coordinates at t(n+1), m.
    pub(crate) x: LaneNodes,
    /// Nodal velocities at t(n+1/2), m/s.
    pub(crate) v: LaneNodes,
    /// Reference volumes, m^3.
    pub(crate) vol0: F,
    /// The elements' state.
    pub(crate) state: LaneState,
    /// What the last update produced.
    pub(crate) out: LaneOutput,
    /// Each lane's history values (all of a pointwise model's; a lane law's one is copied here
    /// from `state` after each update).
    pub(crate) history: LaneHistory,
}

/// One explicit update over the step `dt` of the group's elements of the material `m`: in
/// each lane what [`crate::hex::update`] computes for its element; writes `state` and `out`.
/// `Err`, with `state` and `out` untouched, when a lane's volume is not positive and finite.
/// Inlined into each build of the parent module (its entry has the target features).
#[inline(always)]
pub(super) fn update_inline(
    g: &mut LaneGroup,
    dt: f64,
    m: &LaneMaterial,
    model: &dyn Material,
    ctl: &HexControls,
) -> Result<(), GroupInverted> {
    let LaneGroup {
        x,
        v,
        vol0,
        state,
        out,
        history,
    } = g;
    let (xm, um) = (modes::modes(x), modes::modes(v));
    let pw = m.law.is_pointwise().then_some(Pointwise {
        model,
        n_state: m.n_state(),
        history,
    });
    update_core(&xm, &um, *vol0, state, out, dt, m, ctl, pw)
}

/// The update of [`update_inline`] on the modes of the nodal coordinates `xm` and velocities
/// `um` ([`modes::modes`]), reference volumes `vol0` and the state `st`, its output in `out`;
/// `pw` the model and its lanes' history for a pointwise law (`None` for a lane law).
///
/// Cost per element: about 520 operations of kinematics in mode space (the modes and
/// `kinematics`), 200 for
/// the stress (rotation, Hooke, the radial return's both sides), 40 for the bulk viscosity and
/// stable step, 400-1,100 for the hourglass control (FB stiffness form, physical with the
/// yield bound) and 200 for the nodal forces; memory: the 48 gathered nodal doubles (384 B),
/// 19 state doubles read and written (304 B), the 24 force doubles handed back (192 B).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn update_core(
    xm: &Modes,
    um: &Modes,
    vol0: F,
    st: &mut LaneState,
    out: &mut LaneOutput,
    dt: f64,
    m: &LaneMaterial,
    ctl: &HexControls,
    mut pw: Option<Pointwise<'_>>,
) -> Result<(), GroupInverted> {
    let k = kinematics(xm, um, dt)?;
    // The hourglass rates first (the velocities' modes are dead after them: fewer live
    // vectors through the stress update): the hourglass modes of the coordinates (over 8)
    // and velocities, and
    // sum_k U_k (x) G_k (V times the velocity gradient at the end of the step).
    let x_hg = [k.xk[3], k.xk[4], k.xk[5], k.xk7];
    let u_hg = [k.u[3], k.u[4], k.u[5], k.u7];
    // 64 lg.
    let lg = outer_sum(&k.u, &k.g64);
    let geo = hourglass_lanes::ModeGeometry::new(
        &x_hg,
        &u_hg,
        &lg,
        k.iv * (1.0 / 64.0),
        [k.xk[0], k.xk[1], k.xk[2]],
    );
    let mut stress = rotate(&k.r, &st.stress);
    let mut deps = [F::ZERO; 6];
    for i in 0..6 {
        deps[i] = k.d[i] * dt;
    }
    // rho = m / V with the exact volume.
    let rho = m.rho0 * vol0 * k.iv;
    let rotated = stress;
    match pw.as_mut() {
        Some(p) => p.update_stress(&mut stress, &deps, dt, rho),
        None => law::update_stress(&m.law, &mut stress, &mut st.history, &deps),
    }
    st.stress = stress;

    // Bulk viscosity on the normal stresses for the force only, with c from the material's
    // current wave modulus: the constant lambda + 2 mu of a lane law, the model's own otherwise.
    let c = match &pw {
        Some(p) => p.sound_speed(rho),
        None => (m.dilatational * rho.recip()).sqrt(),
    };
    let ev = k.d[0] + k.d[1] + k.d[2];
    let (q, dt_stable) = bulk_viscosity_and_dt(ctl, k.bb, rho, c, ev);
    // Its work heats the material (a fluid's EOS keeps it; a lane law keeps no heat).
    if let Some(p) = pw.as_mut() {
        p.add_heat(q, ev, dt, rho);
    }
    let yield_stress = match &pw {
        Some(p) => p.yield_stress(),
        None => law::yield_stress(&m.law, st.history),
    };

    let mut dsig = [F::ZERO; 6];
    for i in 0..6 {
        dsig[i] = stress[i] - rotated[i];
    }
    let (hg_work, tg) = match m.hourglass {
        LaneHourglassKind::Physical { scale, bound } => {
            let hg = LaneHourglass {
                geo: &geo,
                vol: k.vol,
                dt,
                mu: m.mu,
                nu: m.nu,
                scale,
                tangent_ratio: hourglass_lanes::tangent_ratio(&dsig, &deps, m.mu),
                yield_stress,
                bound,
                stress,
            };
            hourglass_lanes::physical(&hg, &mut st.hg)
        }
        LaneHourglassKind::Stiffness { coefficient } => {
            // The scalar kernel's rate, kappa 2 mu V sum(b^2) / 8, in its order of operations.
            let rate = coefficient * 2.0 * m.mu * k.vol * k.bb * 0.125;
            hourglass_lanes::fb(&geo, rate, F::ZERO, dt, &mut st.hg)
        }
        LaneHourglassKind::Viscous { coefficient } => {
            let visc = pointwise::viscous_coefficient(coefficient, rho, c, k.vol);
            hourglass_lanes::fb(&geo, F::ZERO, visc, dt, &mut st.hg)
        }
    };
    out.force = nodal_forces(&k, &stress, q, &tg);
    out.hg_work = hg_work;
    out.volume = k.vol;
    out.dt_stable = dt_stable;
    out.pressure = -(stress[0] + stress[1] + stress[2]) * crate::hourglass::THIRD;
    Ok(())
}

/// The nodal forces f_I = -sigma_tot . B_I - sum_a H_a gamma_aI of the stress with bulk
/// viscosity `q` on its normal components and of the hourglass control's generalised forces
/// `tg` (global axes), in mode space (`modes.rs`): B_I = sum_k phi_k(I) G_k and
/// gamma_aI = Gamma_aI - (1/V) sum_k phi_k(I) (X_a . G_k), so f_I = sum_k phi_k(I) F_k with
/// F_k = (N - sigma_tot) G_k for k = xi .. xi eta, less H_a on the hourglass modes, and
/// N = (1/V) sum_a H_a (x) X_a. 9 x 8 + 9 + 6 x 9 + 12 + 69 = about 220 operations per element
/// (node by node: 8 x 15 for the stress, 4 x 24 for the hourglass, and the 4 x 56 of the
/// gamma vectors).
#[inline(always)]
fn nodal_forces(k: &Kinematics, stress: &[F; 6], q: F, tg: &[V3; 4]) -> LaneNodes {
    // (N - sigma_tot) / 64, to multiply 64 G (exact: powers of two).
    let s = 1.0 / 64.0;
    let (d0, d1, d2) = (
        (stress[0] + q) * s,
        (stress[1] + q) * s,
        (stress[2] + q) * s,
    );
    let (o3, o4, o5) = (stress[3] * s, stress[4] * s, stress[5] * s);
    let sig = [[d0, o3, o5], [o3, d1, o4], [o5, o4, d2]];
    let x_hg = [&k.xk[3], &k.xk[4], &k.xk[5], &k.xk7];
    // N = (1/V) sum_a H_a (x) X_a = (8/V) sum_a H_a (x) a_a; over 64.
    let s8 = k.iv * (1.0 / 64.0);
    let mut nm = [[F::ZERO; 3]; 3];
    for c in 0..3 {
        for j in 0..3 {
            let mut n = tg[0][c] * x_hg[0][j];
            for al in 1..4 {
                n = tg[al][c].mul_add(x_hg[al][j], n);
            }
            nm[c][j] = s8.mul_sub(n, sig[c][j]);
        }
    }
    let mut fm = [[F::ZERO; 3]; 6];
    for (f, g) in fm.iter_mut().zip(&k.g64) {
        for c in 0..3 {
            f[c] = dot3(nm[c][0], g[0], nm[c][1], g[1], nm[c][2], g[2]);
        }
    }
    for al in 0..3 {
        for c in 0..3 {
            fm[3 + al][c] -= tg[al][c];
        }
    }
    let f7 = [-tg[3][0], -tg[3][1], -tg[3][2]];
    modes::nodal(&fm, &f7)
}

/// [`crate::batch::Batch::update_lanes`]: the group's nodal values gathered, its state and
/// reference volumes loaded as whole vectors, [`update_inline`], the state stored back as
/// whole vectors. Inlined into each build's entry (its target features).
///
/// Cost per element beyond [`update_inline`]: the gather of 48 nodal doubles (384 B through
/// 32 B of connectivity), 19 state doubles and the reference volume loaded (160 B), 19 stored
/// (152 B); no flops.
#[inline(always)]
pub(super) fn update_lanes_inline(
    g: &mut LaneGroup,
    io: &mut crate::batch::GroupLanes<'_>,
    dt: f64,
    m: &LaneMaterial,
    ctl: &HexControls,
) -> Result<(), GroupInverted> {
    use crate::states::BLOCK;
    let conn = &io.conn[..LANES];
    // The corners' points, then the coordinates gathered and turned into modes, then the
    // velocities (24 vectors live at a time, not 48), into local arrays, not the group's `x`
    // and `v` (which this path leaves as they were: stores through `g` would have to be kept).
    let n = io.xs.len();
    assert_eq!(io.vs.len(), n, "one velocity per point");
    let mut at = [F::corner(conn, 0, n); NODES];
    for (k, c) in at.iter_mut().enumerate().skip(1) {
        *c = F::corner(conn, k, n);
    }
    let mut y = [[F::ZERO; 3]; NODES];
    for k in 0..NODES {
        y[k] = F::gather(io.xs, at[k]);
    }
    let xm = modes::modes(&y);
    for k in 0..NODES {
        y[k] = F::gather(io.vs, at[k]);
    }
    let um = modes::modes(&y);
    let vol0 = F::load(io.vol0);
    let src = &*io.state;
    let mut st = LaneState::default();
    for k in 0..6 {
        st.stress[k] = F::load(&src[k * BLOCK..]);
    }
    for a in 0..4 {
        for i in 0..3 {
            st.hg[a][i] = F::load(&src[(6 + 3 * a + i) * BLOCK..]);
        }
    }
    st.history = match &io.history {
        Some(h) => F::load(h),
        None => F::ZERO,
    };
    assert!(
        !m.law.is_pointwise(),
        "a pointwise law's history is loaded lane by lane (Batch::load)"
    );
    update_core(&xm, &um, vol0, &mut st, &mut g.out, dt, m, ctl, None)?;
    let dst = &mut *io.state;
    for k in 0..6 {
        st.stress[k].store(&mut dst[k * BLOCK..]);
    }
    for a in 0..4 {
        for i in 0..3 {
            st.hg[a][i].store(&mut dst[(6 + 3 * a + i) * BLOCK..]);
        }
    }
    if let Some(h) = &mut io.history {
        st.history.store(h);
    }
    if let Some(force) = io.force.as_deref_mut() {
        assert_eq!(force.len(), n, "one force per point");
        // SAFETY: every node of `conn` is below n (`F::corner` checked each corner above).
        unsafe { add_forces(&g.out.force, conn, force) };
    }
    Ok(())
}

/// Adds the forces `f` of the group's elements `conn` to the nodal forces `force`, element by
/// element in lane order, corner by corner: the order (and so the sums) of adding each lane's
/// output in the element loop. Here, inside the kernel's build, rather than in the loop: there,
/// compiled for the baseline x86-64, each of the 64 (element, corner) additions took 14
/// instructions (the index checked, the memory operands not folded; about 8 ns per element);
/// here the nodes were checked by the gathers ([`F::corner`]), and the additions take VEX
/// instructions with folded loads.
///
/// Cost per element: 24 doubles read and written at the nodes (through 32 B of connectivity),
/// 24 additions.
///
/// # Safety
/// Every node of the first `LANES` rows of `conn` must be below `force.len()`.
#[inline(always)]
unsafe fn add_forces(f: &LaneNodes, conn: &[[u32; NODES]], force: &mut [[f64; 3]]) {
    for (l, c) in conn[..LANES].iter().enumerate() {
        for (k, &node) in c.iter().enumerate() {
            // SAFETY: node < force.len() (the caller's promise).
            let p = unsafe { force.get_unchecked_mut(node as usize) };
            p[0] += f[k][0].0[l];
            p[1] += f[k][1].0[l];
            p[2] += f[k][2].0[l];
        }
    }
}

impl crate::batch::Batch for LaneGroup {
    const LANES: usize = LANES;

    #[inline]
    fn load(
        &mut self,
        xs: &[[f64; 3]],
        vs: &[[f64; 3]],
        conn: &[[u32; NODES]],
        vol0: &[f64],
        state: &[HexState],
        history: impl Fn(usize) -> [f64; MAX_STATE],
    ) {
        let lanes: [&[u32; NODES]; LANES] = std::array::from_fn(|l| &conn[l]);
        gather(xs, lanes, &mut self.x);
        gather(vs, lanes, &mut self.v);
        self.vol0 = F(std::array::from_fn(|l| vol0[l]));
        for (l, s) in state[..LANES].iter().enumerate() {
            let h = history(l);
            self.state.set_lane(l, s, h[0]);
            self.history[l] = h;
        }
    }

    #[inline]
    fn update(
        &mut self,
        dt: f64,
        m: &LaneMaterial,
        model: &dyn Material,
        ctl: &HexControls,
    ) -> Result<(), GroupInverted> {
        super::entry(self, dt, m, model, ctl)?;
        if !m.law.is_pointwise() {
            for l in 0..LANES {
                self.history[l][0] = self.state.history.0[l];
            }
        }
        Ok(())
    }

    #[inline]
    fn lane_state(&self, l: usize) -> (HexState, [f64; MAX_STATE]) {
        (self.state.lane(l).0, self.history[l])
    }

    #[inline]
    fn lane_output(&self, l: usize) -> HexOutput {
        self.out.lane(l)
    }

    #[inline]
    fn update_lanes(
        &mut self,
        io: &mut crate::batch::GroupLanes<'_>,
        dt: f64,
        m: &LaneMaterial,
        ctl: &HexControls,
    ) -> Result<(), GroupInverted> {
        super::entry_lanes(self, io, dt, m, ctl)
    }

    #[inline(always)]
    fn force(&self, l: usize, k: usize) -> [f64; 3] {
        let f = &self.out.force[k];
        [f[0].0[l], f[1].0[l], f[2].0[l]]
    }

    #[inline(always)]
    fn scalars(&self) -> [&[f64]; 4] {
        let o = &self.out;
        [&o.hg_work.0, &o.volume.0, &o.dt_stable.0, &o.pressure.0]
    }
}
