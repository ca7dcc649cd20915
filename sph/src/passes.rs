//! The pair passes and the per-particle updates between them.
//!
//! A pass walks a pair list (from `neighbour::pairs`) and adds each pair's contribution to BOTH
//! entries, owned or ghost; the parallel layer then adds the ghosts' sums to their owners
//! (`Particles::pair_sums` / `add_pair_sums`). Order within one step (the parallel layer does the
//! communication between the lines):
//!
//! ```text
//! reset_density_sums; density_pass;  ghosts -> owners (drho, or rho with summation)
//! update_eos (owned);                owners -> ghosts (rho, p, c)
//! reset_force_sums; force_pass;      ghosts -> owners (f, de)
//! add_gravity (owned)
//! ```
//!
//! Notation: r_ab = x_a - x_b, r = |r_ab|, h = (h_a + h_b)/2, v^_ab = v^_a - v^_b,
//! grad_a W_ab = dW/dr r_ab/r. Passes skip coincident pairs (r = 0: no direction).
use crate::eos::Eos;
use crate::kernel::ScaledKernel;
use crate::params::{DensityMode, Params, Profile};
use crate::particles::Particles;

/// The rate at which the pair forces of one pass turn kinetic into internal energy, W (J/s):
/// sum over pairs of m_a m_b X (dW/dr/r)(v^_ab . r_ab) with X the pressure (with tensile
/// correction) or the viscous term. The kinetic-energy rate of the pair forces is minus the
/// total; `Particles::de` holds the same split per particle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PairWork {
    /// From p_a/rho_a^2 + p_b/rho_b^2 and the tensile correction.
    pub pressure: f64,
    /// From the artificial viscosity (>= 0: viscosity only dissipates).
    pub viscosity: f64,
}

impl PairWork {
    /// pressure + viscosity.
    pub fn total(&self) -> f64 {
        self.pressure + self.viscosity
    }

    /// Adds another pass's (or rank's) work.
    pub fn add(&mut self, o: &PairWork) {
        self.pressure += o.pressure;
        self.viscosity += o.viscosity;
    }
}

/// The tensile-correction factor on positive pressures (Monaghan 2000, §4; LIGGGHTS hard-codes
/// the same 0.01 for pairs with both pressures positive).
pub const POSITIVE_PRESSURE_TENSILE_FACTOR: f64 = 0.01;
/// Exponent n of f_ab^n in the tensile correction (Monaghan 2000).
pub const TENSILE_EXPONENT: i32 = 4;

#[inline]
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Zeroes what the density pass accumulates, on every entry: continuity: drho = 0;
/// summation: rho = m W(0, h) (the self term) on owned entries and 0 on ghosts.
pub fn reset_density_sums(p: &mut Particles, params: &Params) {
    p.drho.iter_mut().for_each(|d| *d = 0.0);
    if params.density == DensityMode::Summation {
        let k = params.smoothing_kernel();
        for i in 0..p.len() {
            p.rho[i] = if i < p.n_owned {
                p.m[i] * k.w(0.0, p.h[i])
            } else {
                0.0
            };
        }
    }
}

/// Density pass. Continuity: adds m_b (dW/dr)(r_ab . v^_ab)/r to drho_a and m_a (...) to drho_b
/// (Monaghan 1992, eq. 2.16; LIGGGHTS `fix sph/density/continuity`). Summation: adds m_b W_ab to
/// rho_a and m_a W_ab to rho_b. Flops per pair ~30, bytes ~200 (positions, velocities, h, m).
pub fn density_pass(pairs: &[(u32, u32)], p: &mut Particles, params: &Params) {
    let k = params.smoothing_kernel();
    match params.density {
        DensityMode::Continuity => {
            for &(i, j) in pairs {
                let (i, j) = (i as usize, j as usize);
                let d = sub(p.x[i], p.x[j]);
                let r = dot(d, d).sqrt();
                if r == 0.0 {
                    continue;
                }
                let h = 0.5 * (p.h[i] + p.h[j]);
                let t = k.dw_dr(r, h) * dot(d, sub(p.vhat[i], p.vhat[j])) / r;
                p.drho[i] += p.m[j] * t;
                p.drho[j] += p.m[i] * t;
            }
        }
        DensityMode::Summation => {
            for &(i, j) in pairs {
                let (i, j) = (i as usize, j as usize);
                let d = sub(p.x[i], p.x[j]);
                let r = dot(d, d).sqrt();
                let w = k.w(r, 0.5 * (p.h[i] + p.h[j]));
                p.rho[i] += p.m[j] * w;
                p.rho[j] += p.m[i] * w;
            }
        }
    }
}

/// Sets p and c of every owned entry from its rho and e with its material's EOS. In the
/// LIGGGHTS profile a Tait fluid's c is its constant c0 (LIGGGHTS's per-type `speedOfSound`).
pub fn update_eos(p: &mut Particles, params: &Params) {
    for i in 0..p.n_owned {
        let eos = &params.eos[p.mat[i] as usize];
        let (pr, c) = eos.pressure_and_sound_speed(p.rho[i], p.e[i]);
        p.p[i] = pr;
        p.c[i] = match (params.profile, liggghts_sound_speed(eos)) {
            (Profile::Liggghts, Some(c0)) => c0,
            _ => c,
        };
    }
}

/// The sound speed LIGGGHTS's artificial viscosity uses: the per-type constant `speedOfSound`,
/// which for a Tait fluid is c0; `None` for the other materials (their EOS sound speed is used).
#[inline]
fn liggghts_sound_speed(eos: &Eos) -> Option<f64> {
    match *eos {
        Eos::Tait { c0, .. } => Some(c0),
        _ => None,
    }
}

/// Zeroes f and de on every entry.
pub fn reset_force_sums(p: &mut Particles) {
    p.f.iter_mut().for_each(|f| *f = [0.0; 3]);
    p.de.iter_mut().for_each(|d| *d = 0.0);
}

/// Force pass: for each pair, with P = p_a/rho_a^2 + p_b/rho_b^2 + R_ab f_ab^4 and Pi_ab the
/// viscous term,
///
/// ```text
/// f_a += -m_a m_b (P + Pi) grad_a W_ab,      f_b -= the same          (Monaghan 1992, eq. 3.3)
/// de_a += 1/2 m_b (P + Pi) v^_ab . grad_a W_ab, de_b += 1/2 m_a (...)   (Monaghan 1992, eq. 3.4)
/// ```
///
/// Pi_ab = (-alpha c_mean mu + beta mu^2)/rho_mean with mu = h (v^_ab . r_ab)/(r^2 + eta^2) when
/// v^_ab . r_ab < 0, else 0. Tensile correction f_ab = W(r)/W(delta_p) and R_ab: LIGGGHTS profile:
/// 0.01 (p_a/rho_a^2 + p_b/rho_b^2) if both pressures are positive, otherwise the sum of
/// epsilon |p|/rho^2 over those of a, b in tension; standard profile: R_a + R_b with R = epsilon
/// |p|/rho^2 in tension and 0.01 p/rho^2 in compression (Monaghan 2000; Gray et al. 2001).
/// With `Params::conductivity` (and the energy equation) it also adds Price's (2008)
/// artificial conductivity to de (see there). Returns the pair work rate. Flops per pair ~80,
/// bytes ~250.
pub fn force_pass(pairs: &[(u32, u32)], p: &mut Particles, params: &Params) -> PairWork {
    let ctx = ForceCtx::new(p, params);
    let mut work = PairWork::default();
    for &(i, j) in pairs {
        if let Some(g) = PairGeom::new(p, &ctx, params, i, j) {
            force_pair(p, params, &ctx, &g, &mut work);
        }
    }
    work
}

/// The continuity density pass and the force pass in one walk over the pairs: what
/// `density_pass` (continuity) then `force_pass` add, with the pair geometry and dW/dr computed
/// once. Valid when the forces do not need this pass's density rates, i.e. with continuity
/// density, whose rates only enter the next update of rho: call `update_eos` on the owners
/// first and give the ghosts those (rho, p, c). Saves one walk over the pairs (~30 of ~110
/// flops per pair) and, in parallel, one reverse communication and one ghost refresh.
pub fn continuity_and_force_pass(
    pairs: &[(u32, u32)],
    p: &mut Particles,
    params: &Params,
) -> PairWork {
    assert_eq!(
        params.density,
        DensityMode::Continuity,
        "the fused pass needs continuity density"
    );
    let ctx = ForceCtx::new(p, params);
    let mut work = PairWork::default();
    for &(i, j) in pairs {
        if let Some(g) = PairGeom::new(p, &ctx, params, i, j) {
            // Monaghan 1992, eq. 2.16, as in density_pass
            let t = g.dw * dot(g.d, sub(p.vhat[g.i], p.vhat[g.j])) * g.inv_r;
            p.drho[g.i] += p.m[g.j] * t;
            p.drho[g.j] += p.m[g.i] * t;
            force_pair(p, params, &ctx, &g, &mut work);
        }
    }
    work
}

/// What every pair of a force pass shares.
struct ForceCtx {
    k: crate::kernel::SmoothingKernel,
    liggghts: bool,
    conductivity: Option<f64>,
    /// p / rho^2 of every entry (computed once per entry rather than twice per pair).
    p_rho2: Vec<f64>,
    /// The kernel at the last pair's h, with 1/W(delta_p, h) of the tensile correction (h is
    /// mostly the same for every pair, and these depend on h only).
    at_h: std::cell::Cell<(ScaledKernel, f64)>,
}

impl ForceCtx {
    /// The kernel at h and 1/W(delta_p, h) (0 without tensile correction or when delta_p is
    /// beyond the support).
    #[inline(always)]
    fn kernel_at(&self, h: f64, params: &Params) -> (ScaledKernel, f64) {
        let cached = self.at_h.get();
        if cached.0.h == h {
            return cached;
        }
        let sk = self.k.at(h);
        let inv_w_dp = match params.tensile {
            Some(tc) => {
                let w_dp = sk.w(tc.delta_p);
                if w_dp > 0.0 {
                    1.0 / w_dp
                } else {
                    0.0
                }
            }
            None => 0.0,
        };
        self.at_h.set((sk, inv_w_dp));
        (sk, inv_w_dp)
    }
}

impl ForceCtx {
    fn new(p: &Particles, params: &Params) -> Self {
        ForceCtx {
            p_rho2: (0..p.len())
                .map(|i| p.p[i] / (p.rho[i] * p.rho[i]))
                .collect(),
            at_h: std::cell::Cell::new((params.smoothing_kernel().at(f64::NAN), 0.0)),
            k: params.smoothing_kernel(),
            liggghts: params.profile == Profile::Liggghts,
            conductivity: if params.energy {
                params.conductivity
            } else {
                None
            },
        }
    }
}

/// One pair's geometry: entries, r_ab, r^2, r, mean h, dW/dr.
struct PairGeom {
    i: usize,
    j: usize,
    d: [f64; 3],
    r2: f64,
    r: f64,
    /// 1/r.
    inv_r: f64,
    h: f64,
    dw: f64,
    /// The kernel at h and 1/W(delta_p, h).
    kernel: (ScaledKernel, f64),
}

impl PairGeom {
    /// None for coincident entries (r = 0: no direction).
    #[inline(always)]
    fn new(p: &Particles, ctx: &ForceCtx, params: &Params, i: u32, j: u32) -> Option<Self> {
        let (i, j) = (i as usize, j as usize);
        let d = sub(p.x[i], p.x[j]);
        let r2 = dot(d, d);
        let r = r2.sqrt();
        if r == 0.0 {
            return None;
        }
        let h = 0.5 * (p.h[i] + p.h[j]);
        let kernel = ctx.kernel_at(h, params);
        Some(PairGeom {
            i,
            j,
            d,
            r2,
            r,
            inv_r: 1.0 / r,
            h,
            dw: kernel.0.dw_dr(r),
            kernel,
        })
    }
}

/// Adds one pair's force, energy rate and work (see `force_pass`). Flops ~80, bytes ~250.
#[inline(always)]
fn force_pair(
    p: &mut Particles,
    params: &Params,
    ctx: &ForceCtx,
    g: &PairGeom,
    work: &mut PairWork,
) {
    let (i, j, d, r2, r, h, dw) = (g.i, g.j, g.d, g.r2, g.r, g.h, g.dw);
    let (pa, pb) = (ctx.p_rho2[i], ctx.p_rho2[j]);
    let vr = dot(sub(p.vhat[i], p.vhat[j]), d);
    let visc = match params.viscosity {
        Some(av) if vr < 0.0 => {
            let mu = h * vr / (r2 + av.eta_factor * h * h);
            let c_mean = 0.5 * (p.c[i] + p.c[j]);
            let rho_mean = 0.5 * (p.rho[i] + p.rho[j]);
            (-av.alpha * c_mean * mu + av.beta * mu * mu) / rho_mean
        }
        _ => 0.0,
    };
    let tensile = match params.tensile {
        Some(tc) => {
            let (sk, inv_w_dp) = g.kernel;
            if inv_w_dp > 0.0 {
                let fab = sk.w(r) * inv_w_dp;
                let r_ab = if ctx.liggghts {
                    if p.p[i] > 0.0 && p.p[j] > 0.0 {
                        POSITIVE_PRESSURE_TENSILE_FACTOR * (pa + pb)
                    } else {
                        let neg = |x: f64| if x < 0.0 { tc.epsilon * x.abs() } else { 0.0 };
                        neg(pa) + neg(pb)
                    }
                } else {
                    let one = |x: f64| {
                        if x < 0.0 {
                            tc.epsilon * x.abs()
                        } else {
                            POSITIVE_PRESSURE_TENSILE_FACTOR * x
                        }
                    };
                    one(pa) + one(pb)
                };
                r_ab * fab.powi(TENSILE_EXPONENT)
            } else {
                0.0
            }
        }
        None => 0.0,
    };
    let press = pa + pb + tensile;
    let gr = dw * g.inv_r; // grad_a W_ab = gr r_ab
    let mm = p.m[i] * p.m[j];
    let fs = mm * (press + visc) * gr;
    for (c, dc) in d.into_iter().enumerate() {
        p.f[i][c] -= fs * dc;
        p.f[j][c] += fs * dc;
    }
    let de = (press + visc) * gr * vr;
    p.de[i] += 0.5 * p.m[j] * de;
    p.de[j] += 0.5 * p.m[i] * de;
    work.pressure += mm * press * gr * vr;
    work.viscosity += mm * visc * gr * vr;
    if let Some(alpha_u) = ctx.conductivity {
        // de_a += m_b alpha_u v_sig (e_a - e_b)/rho_mean dW/dr, v_sig = sqrt(|p_a - p_b|/rho_mean)
        let rho_mean = 0.5 * (p.rho[i] + p.rho[j]);
        let v_sig = ((p.p[i] - p.p[j]).abs() / rho_mean).sqrt();
        let q = alpha_u * v_sig * (p.e[i] - p.e[j]) / rho_mean * dw;
        p.de[i] += p.m[j] * q;
        p.de[j] -= p.m[i] * q;
    }
}

/// Adds m g to the force of every owned entry that moves.
pub fn add_gravity(p: &mut Particles, params: &Params) {
    if params.gravity == [0.0; 3] {
        return;
    }
    for i in 0..p.n_owned {
        if !p.fixed[i] {
            for c in 0..3 {
                p.f[i][c] += p.m[i] * params.gravity[c];
            }
        }
    }
}
