//! The tetrahedron's two passes on a group of elements at once, one element per lane (the
//! parent module's lane type `F`).
//!
//! Pass 1 (`rates_inline`) runs [`crate::tet::rates`]'s operations in its order: the same
//! bits. Pass 2 (`update_inline`) runs [`crate::tet::update`]'s in its order, except for
//! the element kernel's Hughes-Winget rotation and lane laws (`hex.rs`, `law.rs`: elastic and
//! J2 in lanes; the other models' scalar functions lane by lane through `pointwise.rs`) and
//! 1/V and 1/V(n+1/2) from one reciprocal: round-off apart, so pass 2 agrees with
//! [`crate::tet::update`] to round-off (`tests/tet_lanes.rs`: 1e-12 relative required, about
//! 1e-15 measured). Every width runs the same IEEE operations in the same order (no fused
//! multiply-adds), so every width gives the same bits, and this kernel (one lane for
//! `--kernel scalar`) is what the explicit loop runs: [`crate::tet::update`] is the tests'
//! reference, as [`crate::hex::update`] is the hexahedron's.
//!
//! Cost per element: 2 x 50 for the volume gradients, 12 for the mid-step positions, 40 for
//! L, 45 + 90 for the rotation, 20 for Dbar dt, 12-70 for the material in lanes, 40 for the
//! gradients and their sum of squares, 40 for the frequency bound, 25 for the bulk viscosity
//! and stable step, 40 for the forces: about 500 operations, 7 quotients and 5 square roots.
use super::hex::{first_inverted, hughes_winget, rotate, valid_volume};
use super::law;
use super::pointwise::{LaneHistory, Pointwise};
use super::{F, LANES};
use crate::batch::{GroupInverted, LaneMaterial};
use crate::hex::HexControls;
use crate::hourglass::THIRD;
use crate::material::{Material, MAX_STATE};
use crate::batch::TetBatch;
use crate::tet::{TetAverages, TetOutput, TetRates, NODES, ROUNDING_MARGIN, SQRT_2_3};

/// Nodal vectors of a group's tetrahedra in lanes: `[node][component]`.
pub type TetNodes = [[F; 3]; NODES];

/// A group of tetrahedra in lanes: their nodal values, reference volumes, nodal averages and
/// state going in, their output coming out. One buffer serves group after group:
/// [`crate::batch::TetBatch::load`] writes every input of its lane.
#[derive(Clone, Copy, Debug, Default)]
pub struct TetGroup {
    /// Nodal coordinates at t(n+1), m.
    x: TetNodes,
    /// Nodal velocities at t(n+1/2), m/s.
    v: TetNodes,
    /// Reference volumes, m^3.
    vol0: F,
    /// The nodal averages' dilatation rates theta, 1/s.
    theta: F,
    /// The nodal averages' volume ratios J.
    j: F,
    /// Cauchy stress (Voigt), Pa.
    stress: [F; 6],
    /// A lane law's history value (J2's plastic strain; 0 for elastic).
    plastic: F,
    /// Each lane's history values (a pointwise model's; a lane law's one copied from
    /// `plastic` after each update).
    history: LaneHistory,
    /// Force on each node, N.
    force: TetNodes,
    /// Volumes at t(n+1), m^3.
    volume: F,
    /// Stable steps (no safety factor), s.
    dt_stable: F,
    /// Pressures without bulk viscosity, Pa.
    pressure: F,
    /// Pass 1's mid-step volumes, m^3 (its end-of-step volumes in `volume`).
    vol_mid: F,
    /// Pass 1's volume rates V(n+1/2) tr D, m^3/s.
    vol_rate: F,
}

/// a x b in lanes (`crate::tet`'s `cross`).
#[inline(always)]
fn cross(a: [F; 3], b: [F; 3]) -> [F; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// dV/dx_a (m^2) and the signed volume V (m^3) in lanes, `crate::tet`'s `volume_gradient` (its
/// comment derives it) in its order: dV/dx_{1,2,3} the edges' cross products over 6,
/// dV/dx_0 = 0 - their sum, V = e1 . dV/dx_1.
#[inline(always)]
fn volume_gradient(x: &TetNodes) -> (TetNodes, F) {
    let mut e = [[F::ZERO; 3]; 3];
    for i in 0..3 {
        for k in 0..3 {
            e[i][k] = x[i + 1][k] - x[0][k];
        }
    }
    const SIXTH: f64 = 1.0 / 6.0;
    let c = [cross(e[1], e[2]), cross(e[2], e[0]), cross(e[0], e[1])];
    let mut bv = [[F::ZERO; 3]; 4];
    for i in 0..3 {
        for k in 0..3 {
            bv[i + 1][k] = c[i][k] * SIXTH;
            bv[0][k] -= bv[i + 1][k];
        }
    }
    let vol = e[0][0] * bv[1][0] + e[0][1] * bv[1][1] + e[0][2] * bv[1][2];
    (bv, vol)
}

/// The mid-step positions x(n+1) - dt/2 v(n+1/2) (`crate::tet`'s `mid_step`).
#[inline(always)]
fn mid_step(x: &TetNodes, v: &TetNodes, dt: f64) -> TetNodes {
    let h = F::splat(0.5 * dt);
    let mut xh = [[F::ZERO; 3]; 4];
    for a in 0..4 {
        for k in 0..3 {
            xh[a][k] = x[a][k] - h * v[a][k];
        }
    }
    xh
}

/// Pass 1 ([`crate::tet::rates`]) in lanes, its operations in its order, so the same bits:
/// the volumes at t(n+1) (`volume`) and at mid-step (`vol_mid`) and
/// `vol_rate` = sum_a v_a . dV/dx_a(n+1/2), the nodes summed in order. No check: the loop
/// checks each lane's volumes as [`crate::tet::rates`] does.
#[inline(always)]
pub(super) fn rates_inline(g: &mut TetGroup, dt: f64) {
    let (_, vol) = volume_gradient(&g.x);
    let (bvh, vol_mid) = volume_gradient(&mid_step(&g.x, &g.v, dt));
    let v = &g.v;
    let node = |a: usize| v[a][0] * bvh[a][0] + v[a][1] * bvh[a][1] + v[a][2] * bvh[a][2];
    g.vol_rate = node(0) + node(1) + node(2) + node(3);
    g.volume = vol;
    g.vol_mid = vol_mid;
}

/// L = (sum_a v_a (x) V grad N_a) / V (`ivh` = 1/V at the geometry of `bvh`), the nodes summed
/// in order (`crate::tet`'s `velocity_gradient`).
#[inline(always)]
fn velocity_gradient(v: &TetNodes, bvh: &TetNodes, ivh: F) -> [[F; 3]; 3] {
    let mut l = [[F::ZERO; 3]; 3];
    for (i, row) in l.iter_mut().enumerate() {
        for (j, e) in row.iter_mut().enumerate() {
            let mut s = v[0][i] * bvh[0][j];
            for a in 1..4 {
                s = v[a][i].mul_add(bvh[a][j], s);
            }
            *e = s * ivh;
        }
    }
    l
}

/// Dbar dt = (sym L + (theta - tr L) / 3 I) dt (Voigt, tensor shears), `crate::tet`'s
/// `averaged_increment`.
#[inline(always)]
fn averaged_increment(l: &[[F; 3]; 3], theta: F, dt: f64) -> [F; 6] {
    let shift = (theta - (l[0][0] + l[1][1] + l[2][2])) * THIRD;
    [
        (l[0][0] + shift) * dt,
        (l[1][1] + shift) * dt,
        (l[2][2] + shift) * dt,
        0.5 * (l[0][1] + l[1][0]) * dt,
        0.5 * (l[1][2] + l[2][1]) * dt,
        0.5 * (l[2][0] + l[0][2]) * dt,
    ]
}

/// The bound of the highest frequency (rad/s) of [`crate::tet::max_frequency`] (its comment
/// derives it) in lanes, in its order: `g` the gradients, `gg` their sum of squares, `rho_e`
/// the lumped density, `modulus` the wave modulus, `mu` the shear modulus.
#[inline(always)]
fn max_frequency(g: &TetNodes, gg: F, rho_e: F, modulus: F, mu: f64) -> F {
    // The upper triangle of G G^T = sum_a g_a g_a^T: xx, yy, zz, xy, yz, zx.
    const IJ: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0)];
    let mut s = [F::ZERO; 6];
    for (sk, &(i, j)) in s.iter_mut().zip(&IJ) {
        let mut t = g[0][i] * g[0][j];
        for a in 1..4 {
            t = g[a][i].mul_add(g[a][j], t);
        }
        *sk = t;
    }
    let m = gg * THIRD;
    let (d0, d1, d2) = (s[0] - m, s[1] - m, s[2] - m);
    let dev2 =
        d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]);
    let lmax = (m + SQRT_2_3 * dev2.sqrt()).min(gg);
    let lambda = (modulus - 2.0 * mu).max(F::ZERO);
    (4.0 / rho_e * (lambda * gg + 2.0 * mu * lmax) * ROUNDING_MARGIN).sqrt()
}

/// The bulk viscosity's pressure q and coefficient eta ([`crate::tet`]'s `bulk_viscosity`) and
/// the stable step (its `critical_dt` with the damping 2 eta sum|g|^2 / rho_e), in lanes.
#[inline(always)]
fn viscosity_and_dt(ctl: &HexControls, gg: F, rho: F, c: F, theta: F, omega: F, rho_e: F) -> (F, F) {
    let len = 2.0 / gg.sqrt();
    let quad = ctl.bv_quadratic * ctl.bv_quadratic * len * (-theta).max(F::ZERO);
    let eta = rho * len * (ctl.bv_linear * c + quad);
    let gamma = 2.0 * eta * gg / rho_e;
    let dt = 2.0 / ((omega * omega + gamma * gamma).sqrt() + gamma);
    (eta * theta, dt)
}

/// The nodal forces -V (sigma + q I) grad N_a (`bv` = V grad N_a), `crate::tet`'s
/// `stress_forces`.
#[inline(always)]
fn stress_forces(bv: &TetNodes, s: &[F; 6], q: F) -> TetNodes {
    let t = [s[0] + q, s[1] + q, s[2] + q, s[3], s[4], s[5]];
    let mut f = [[F::ZERO; 3]; 4];
    for (fa, b) in f.iter_mut().zip(bv) {
        fa[0] = -(t[0] * b[0] + t[3] * b[1] + t[5] * b[2]);
        fa[1] = -(t[3] * b[0] + t[1] * b[1] + t[4] * b[2]);
        fa[2] = -(t[5] * b[0] + t[4] * b[1] + t[2] * b[2]);
    }
    f
}

/// One explicit update over the step `dt` of the group's tetrahedra of the material `m` (its
/// model `model`): in each lane what [`crate::tet::update`] computes for its element (module
/// comment). `Err`, with the state and output untouched, when a lane's volume (end of step or
/// mid-step) is not positive and finite. Inlined into each build of the parent module.
#[inline(always)]
pub(super) fn update_inline(
    g: &mut TetGroup,
    dt: f64,
    m: &LaneMaterial,
    model: &dyn Material,
    ctl: &HexControls,
) -> Result<(), GroupInverted> {
    let (bv, vol) = volume_gradient(&g.x);
    let (bvh, volh) = volume_gradient(&mid_step(&g.x, &g.v, dt));
    if !(valid_volume(vol).all() && valid_volume(volh).all()) {
        return Err(first_inverted(vol, volh));
    }
    // 1/V and 1/V(n+1/2) from one reciprocal.
    let inv = (vol * volh).recip();
    let (iv, ivh) = (volh * inv, vol * inv);
    let l = velocity_gradient(&g.v, &bvh, ivh);
    let w01 = 0.5 * (l[0][1] - l[1][0]);
    let w12 = 0.5 * (l[1][2] - l[2][1]);
    let w20 = 0.5 * (l[2][0] - l[0][2]);
    let mut stress = rotate(&hughes_winget(w01, w12, w20, dt), &g.stress);
    let deps = averaged_increment(&l, g.theta, dt);
    let rho = m.rho0 / g.j;
    let mut pw = m.law.is_pointwise().then_some(Pointwise {
        model,
        n_state: m.n_state(),
        history: &mut g.history,
    });
    let modulus = match pw.as_mut() {
        Some(p) => {
            p.update_stress(&mut stress, &deps, dt, rho);
            p.wave_modulus(rho)
        }
        None => {
            law::update_stress(&m.law, &mut stress, &mut g.plastic, &deps);
            F::splat(m.dilatational)
        }
    };
    g.stress = stress;

    let mut gr = [[F::ZERO; 3]; 4];
    for a in 0..4 {
        for k in 0..3 {
            gr[a][k] = bv[a][k] * iv;
        }
    }
    let mut gg = gr[0][0] * gr[0][0];
    for a in 0..4 {
        for k in 0..3 {
            if a + k > 0 {
                gg = gr[a][k].mul_add(gr[a][k], gg);
            }
        }
    }
    let c = (modulus / rho).sqrt();
    let rho_e = m.rho0 * g.vol0 * iv;
    let omega = max_frequency(&gr, gg, rho_e, modulus, m.mu);
    let (q, dt_stable) = viscosity_and_dt(ctl, gg, rho, c, g.theta, omega, rho_e);
    // The bulk viscosity's work heats the material (a pointwise model's history keeps it).
    if let Some(p) = pw.as_mut() {
        p.add_heat(q, g.theta, dt, rho);
    }
    g.force = stress_forces(&bv, &stress, q);
    g.volume = vol;
    g.dt_stable = dt_stable;
    g.pressure = -(stress[0] + stress[1] + stress[2]) * THIRD;
    Ok(())
}

impl TetBatch for TetGroup {
    const LANES: usize = LANES;

    #[inline]
    fn load(&mut self, l: usize, input: &crate::batch::TetInput<'_>) {
        self.load_nodes(l, input.x, input.v);
        self.vol0.0[l] = input.vol0;
        let TetAverages { theta, j } = input.avg;
        self.theta.0[l] = theta;
        self.j.0[l] = j;
        for k in 0..6 {
            self.stress[k].0[l] = input.stress[k];
        }
        let h = &mut self.history[l];
        *h = [0.0; MAX_STATE];
        h[..input.history.len()].copy_from_slice(input.history);
        self.plastic.0[l] = h[0];
    }

    #[inline]
    fn load_nodes(&mut self, l: usize, x: &[[f64; 3]; 4], v: &[[f64; 3]; 4]) {
        for a in 0..NODES {
            for k in 0..3 {
                self.x[a][k].0[l] = x[a][k];
                self.v[a][k].0[l] = v[a][k];
            }
        }
    }

    #[inline]
    fn rates(&mut self, dt: f64) {
        super::tet_rates_entry(self, dt);
    }

    #[inline]
    fn lane_rates(&self, l: usize) -> TetRates {
        TetRates {
            vol: self.volume.0[l],
            vol_mid: self.vol_mid.0[l],
            vol_rate: self.vol_rate.0[l],
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
        super::tet_entry(self, dt, m, model, ctl)?;
        if !m.law.is_pointwise() {
            for l in 0..LANES {
                self.history[l][0] = self.plastic.0[l];
            }
        }
        Ok(())
    }

    #[inline]
    fn lane_state(&self, l: usize) -> ([f64; 6], [f64; MAX_STATE]) {
        let mut s = [0.0; 6];
        for (k, sk) in s.iter_mut().enumerate() {
            *sk = self.stress[k].0[l];
        }
        (s, self.history[l])
    }

    #[inline]
    fn lane_output(&self, l: usize) -> TetOutput {
        let mut force = [[0.0; 3]; NODES];
        for (a, fa) in force.iter_mut().enumerate() {
            for (k, c) in fa.iter_mut().enumerate() {
                *c = self.force[a][k].0[l];
            }
        }
        TetOutput {
            force,
            volume: self.volume.0[l],
            dt_stable: self.dt_stable.0[l],
            pressure: self.pressure.0[l],
        }
    }
}
