//! The momentum and energy pass with the full stress tensor, and Monaghan's artificial stress.
use super::tensor::{from_voigt, mul, symmetric_eigen, transpose, Mat3};
use super::Solids;
use crate::exact::{note, q, PassGrids, TermMax};
use crate::params::Params;
use crate::particles::{PairSums, Particles};
use crate::passes::PairWork;

/// Monaghan's artificial stress against the tensile instability of solids (Gray, Monaghan &
/// Swift, CMAME 190 (2001) 6641, §3; Monaghan, J. Comput. Phys. 159 (2000) 290).
///
/// Per particle, in the principal frame of sigma_a (sigma_a = Q diag(s_1, s_2, s_3) Q^T):
///
/// ```text
/// R'_kk = -epsilon s_k / rho_a^2   if s_k > 0 (tension), else 0     (Gray et al. 2001, eq. 25)
/// R_a   = Q diag(R'_11, R'_22, R'_33) Q^T                            Pa m^6/kg^2 = m^5/(kg s^2)
/// ```
///
/// and per pair the term (R_a + R_b) f_ab^n added to sigma_a/rho_a^2 + sigma_b/rho_b^2, with
/// f_ab = W(r_ab, h) / W(delta_p, h) (dimensionless, 1 at the initial spacing delta_p, so the
/// correction acts where particles close up beyond the lattice: a repulsion that stops the
/// clumping of particles in tension). A fluid's stress is -p I: its R is epsilon p/rho^2 I
/// where p < 0 (Monaghan 2000's correction without the compression term).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArtificialStress {
    /// epsilon (Gray et al. 2001 use 0.3).
    pub epsilon: f64,
    /// Exponent n of f_ab^n (Gray et al. 2001: n = 4).
    pub n: i32,
    /// The initial particle spacing delta_p, m.
    pub delta_p: f64,
}

/// Gray et al. (2001)'s epsilon of the artificial stress.
pub const ARTIFICIAL_STRESS_EPSILON: f64 = 0.3;
/// Gray et al. (2001)'s exponent n of the artificial stress.
pub const ARTIFICIAL_STRESS_EXPONENT: i32 = 4;

impl ArtificialStress {
    /// epsilon = 0.3, n = 4 (Gray et al. 2001) at the spacing `delta_p`, m.
    pub fn new(delta_p: f64) -> Self {
        Self {
            epsilon: ARTIFICIAL_STRESS_EPSILON,
            n: ARTIFICIAL_STRESS_EXPONENT,
            delta_p,
        }
    }

    /// R_a of a particle with stress `sigma` (Voigt, Pa) and density `rho` (kg/m^3). Zero,
    /// without the eigen-decomposition, where Gershgorin's discs show every principal stress
    /// <= 0 (each diagonal entry plus its row's off-diagonal magnitudes <= 0: compression).
    pub fn tensor(&self, sigma: &[f64; 6], rho: f64) -> Mat3 {
        let a = from_voigt(sigma);
        let tension = (0..3).any(|k| {
            let off: f64 = (0..3).filter(|&l| l != k).map(|l| a[k][l].abs()).sum();
            a[k][k] + off > 0.0
        });
        if !tension {
            return [[0.0; 3]; 3];
        }
        let (lam, q) = symmetric_eigen(&a);
        let scale = -self.epsilon / (rho * rho);
        let d: Mat3 = std::array::from_fn(|k| {
            std::array::from_fn(|l| if k == l { scale * lam[k].max(0.0) } else { 0.0 })
        });
        mul(&mul(&q, &d), &transpose(&q))
    }
}

/// The stress of entry `i` as a matrix: a solid's sigma, a fluid's -p I, Pa.
fn stress_of(p: &Particles, s: &Solids, i: usize) -> Mat3 {
    if s.is_solid(p.mat[i]) {
        from_voigt(&s.stress[i])
    } else {
        let q = -p.p[i];
        [[q, 0.0, 0.0], [0.0, q, 0.0], [0.0, 0.0, q]]
    }
}

/// The Monaghan (1992) artificial viscosity Pi_ab, m^5/(kg s^2), as the fluid pass has it
/// (`passes::pair_viscosity`, `params::ArtificialViscosity`): mu = h min(vr, 0)/(r^2 + eta^2),
/// Pi = (-alpha c_mean mu + beta mu^2)/rho_mean.
fn viscosity(params: &Params, a: &Slot, b: &Slot, h: f64, vr: f64, r2: f64) -> f64 {
    match params.viscosity {
        Some(av) => {
            let mu = h * vr.min(0.0) / (r2 + av.eta_factor * h * h);
            let c_mean = 0.5 * (a.c + b.c);
            let rho_mean = 0.5 * (a.rho + b.rho);
            (-av.alpha * c_mean * mu + av.beta * mu * mu) / rho_mean
        }
        None => 0.0,
    }
}

/// Force pass with the stress tensor, over every pair (solids and fluids: a fluid's stress is
/// -p I and its B = I). With g = grad_a W_ab = (dW/dr / r)(x_a - x_b), 1/m^4, B_a the
/// kernel-gradient correction (`Solids::correction`, Randles & Libersky 1996) and
///
/// ```text
/// T_ab g = (sigma_a/rho_a^2 B_a + sigma_b/rho_b^2 B_b) g + (R_a + R_b) f_ab^n g - Pi_ab g
/// f_a  += m_a m_b T_ab g,   f_b -= the same                   N    (Gray et al. 2001, eq. 10,
///                                                                   with Bonet & Lok, CMAME 180
///                                                                   (1999) 97, eq. 50's B g)
/// de_a += -1/2 m_b v^_ab . (T_ab g),  de_b += -1/2 m_a (same)  W/kg
/// ```
///
/// (T in m^5/(kg s^2)). The pair term is the same tensor applied to g for a and to -g for b,
/// so the forces are equal and opposite (momentum conserved) whatever B. B makes a linear
/// stress field's divergence exact at the free surface too; without it (B = I, Gray et al.'s
/// form) a surface particle's truncated kernel carries only part of its stress, and a bent
/// plate is as stiff as one (n_y - 1) particle spacings thick rather than n_y. For a fluid pair
/// T g = -(p_a/rho_a^2 + p_b/rho_b^2 + Pi) g: the fluid pass's Monaghan (1992) eqs. 3.3-3.4.
/// The two halves of -m_a m_b v^_ab . (T g) given to a and b are what the forces take from the
/// kinetic energy (d/dt sum 1/2 m v^2 = sum_pairs m_a m_b v^_ab . T g at v = v^), so kinetic +
/// sum m e is conserved as in the fluid pass. Sets the force and energy-rate sums and the
/// partner counts of every entry (`Particles::sums`: exact, on `g`'s force and energy grids,
/// largest terms into `m`; a pair listed as (b, a) gives each entry the same bits, as T g
/// changes sign with g) and the owned entries' `f` and `de` from them (the caller merges the
/// ghosts' sums into their owners and settles again). Returns the work rate: `pressure` from
/// the stress and artificial stress, `viscosity` from Pi. Flops per pair ~150 + 8 x 8 for the
/// sums.
pub fn stress_force_pass(
    pairs: &[(u32, u32)],
    p: &mut Particles,
    s: &Solids,
    params: &Params,
    art: Option<&ArtificialStress>,
    grids: &PassGrids,
    m: &mut TermMax,
) -> PairWork {
    let n = p.len();
    let k = params.smoothing_kernel();
    let slots: Vec<Slot> = (0..n).map(|i| Slot::of(p, s, art, i)).collect();
    // the kernel at the pair's h and 1/W(delta_p, h) (0 without artificial stress or with
    // delta_p beyond the support), remade where h changes (mostly the same for every pair)
    let at = |h: f64| {
        let sk = k.at(h);
        let inv_w_dp = match art {
            Some(a) if sk.w(a.delta_p) > 0.0 => 1.0 / sk.w(a.delta_p),
            _ => 0.0,
        };
        (sk, inv_w_dp)
    };
    let mut kern = at(f64::NAN);
    p.sums.resize(n, PairSums::default());
    for e in p.sums.iter_mut() {
        e.f = [[0.0; 2]; 3];
        e.de = [0.0; 2];
        e.partners = 0.0;
    }
    let (gf, ge) = (grids.grid(q::FORCE), grids.grid(q::ENERGY));
    let (mut mf, mut me) = (m[q::FORCE], m[q::ENERGY]);
    let mut work = PairWork::default();
    for &(i, j) in pairs {
        let (i, j) = (i as usize, j as usize);
        p.sums[i].partners += 1.0;
        p.sums[j].partners += 1.0;
        let (a, b) = (&slots[i], &slots[j]);
        let d: [f64; 3] = std::array::from_fn(|c| a.x[c] - b.x[c]);
        let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let r = r2.sqrt();
        if r == 0.0 {
            continue;
        }
        let h = 0.5 * (a.h + b.h);
        if kern.0.h != h {
            kern = at(h);
        }
        let gr = kern.0.dw_dr(r) / r;
        let g = [gr * d[0], gr * d[1], gr * d[2]];
        let dv: [f64; 3] = std::array::from_fn(|c| a.vhat[c] - b.vhat[c]);
        let vr = dv[0] * d[0] + dv[1] * d[1] + dv[2] * d[2];
        let pi = viscosity(params, a, b, h, vr, r2);
        // T g without the viscous part: (S_a + S_b) g, plus (R_a + R_b) f_ab^n g where either
        // particle has a tensile principal stress (f_ab^n = (W(r)/W(delta_p))^n)
        let mut tg = mat_vec_sum(&a.sr, &b.sr, g);
        if let (Some(an), true) = (art, a.tension || b.tension) {
            if kern.1 > 0.0 {
                let fn_ab = (kern.0.w(r) * kern.1).powi(an.n);
                let rg = mat_vec_sum(&a.rt, &b.rt, g);
                for c in 0..3 {
                    tg[c] += fn_ab * rg[c];
                }
            }
        }
        let mm = a.m * b.m;
        // the viscous part -Pi I g, kept apart for the work split
        let full: [f64; 3] = std::array::from_fn(|c| tg[c] - pi * g[c]);
        let e = dv[0] * full[0] + dv[1] * full[1] + dv[2] * full[2];
        let (de_i, de_j) = (-0.5 * b.m * e, -0.5 * a.m * e);
        work.pressure -= mm * (dv[0] * tg[0] + dv[1] * tg[1] + dv[2] * tg[2]);
        work.viscosity += mm * pi * gr * vr;
        let [si, sj] = p
            .sums
            .get_disjoint_mut([i, j])
            .expect("a pair of two entries");
        for (c, &fc) in full.iter().enumerate() {
            let t = mm * fc;
            gf.add(&mut si.f[c], t);
            gf.add(&mut sj.f[c], -t);
            note(&mut mf, t);
        }
        ge.add(&mut si.de, de_i);
        ge.add(&mut sj.de, de_j);
        note(&mut me, de_i);
        note(&mut me, de_j);
    }
    m[q::FORCE] = mf;
    m[q::ENERGY] = me;
    p.settle_forces();
    work
}

/// (A + B) g for two matrices stored row by row, summed entry by entry first.
#[inline(always)]
fn mat_vec_sum(a: &[f64; 9], b: &[f64; 9], g: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|r| {
        let t = |c: usize| a[3 * r + c] + b[3 * r + c];
        t(0) * g[0] + t(1) * g[1] + t(2) * g[2]
    })
}

/// What the force pass reads of one entry, packed: position, h, predicted velocity, mass,
/// density, sound speed, S = sigma/rho^2 B and the artificial stress R (row by row), and
/// whether R is not zero.
struct Slot {
    x: [f64; 3],
    h: f64,
    vhat: [f64; 3],
    m: f64,
    rho: f64,
    c: f64,
    sr: [f64; 9],
    rt: [f64; 9],
    tension: bool,
}

impl Slot {
    /// Entry `i`: sigma_a / rho_a^2 B_a (B = I for fluids) and R_a.
    fn of(p: &Particles, s: &Solids, art: Option<&ArtificialStress>, i: usize) -> Slot {
        let t = stress_of(p, s, i);
        let inv_rho2 = 1.0 / (p.rho[i] * p.rho[i]);
        let sb = mul(&t, &s.correction[i]);
        let rt = match art {
            Some(a) => a.tensor(&super::tensor::to_voigt(&t), p.rho[i]),
            None => [[0.0; 3]; 3],
        };
        Slot {
            x: p.x[i],
            h: p.h[i],
            vhat: p.vhat[i],
            m: p.m[i],
            rho: p.rho[i],
            c: p.c[i],
            sr: std::array::from_fn(|e| sb[e / 3][e % 3] * inv_rho2),
            rt: std::array::from_fn(|e| rt[e / 3][e % 3]),
            tension: rt.iter().flatten().any(|&x| x != 0.0),
        }
    }
}
