//! Hourglass control of the one-point hexahedron: the forces that resist the four hourglass modes
//! per direction that one-point integration does not see.
//!
//! Notation. The FB hourglass vectors gamma_a = Gamma_a - (Gamma_a . x_i) b_i (FB 1981 eq. 41,
//! without FB's 1/8) are orthogonal to every linear field; the hourglass rates are
//! qd_ia = sum_I v_iI gamma_aI (m/s), and the element applies the nodal forces
//! f_iI = -sum_a H_ia gamma_aI with generalised hourglass forces H (N), kept between steps in the
//! element's own frame (so they turn with it). The work rate is sum H_ia qd_ia.
//!
//! Three kinds (`run.hourglass.kind`):
//!
//! * **physical** (default): assumed-strain stabilisation after Belytschko & Bindeman 1993 (CMAME
//!   105:225, the ASQBI idea) with the stiffness of the material's *current* tangent. Derivation
//!   (a parallelepiped with half-lengths a_0, a_1, a_2 along its natural axes, local axes e_j along
//!   dx/dxi_j; nodal amplitudes q_ia = qd_ia / 8 of the fields v_i = q_ia h_a with
//!   h_0 = eta zeta, h_1 = zeta xi, h_2 = xi eta, h_3 = xi eta zeta): the strains of the first three
//!   modes are linear in one natural coordinate xi_g. Group them by g, with (p, r) the other two
//!   axes: eps_pp = q_pr / a_p, eps_rr = q_rp / a_r and gamma_pr = q_rr / a_p + q_pp / a_r, each
//!   times xi_g. The remaining shear terms (gamma_pg from q_pr, ...) are the parasitic shears of
//!   bending and are dropped (this is what makes one element through the depth exact in bending,
//!   instead of shear-locked). The strain linear in xi_g along g itself (eps_gg ~ xi_g) needs a
//!   quadratic field the element lacks, so each group is taken in plane stress (sigma_gg = 0):
//!   the energy is (V/3) [Ebar/2 (eps_pp^2 + 2 nu eps_pp eps_rr + eps_rr^2) + mu/2 gamma_pr^2]
//!   with Ebar = E / (1 - nu^2) = 2 mu / (1 - nu). A beam bent about an element axis with its
//!   sides free then gets exactly E I (the Poisson mode relaxes eps_rr = -nu eps_pp), a plate
//!   (eps_rr held) exactly E I / (1 - nu^2). Mode 3 (xi eta zeta) gets its normal strains with the
//!   deviatoric modulus: energy (V/9) mu sum_i q_i3^2 / a_i^2. Q = dEnergy/dq, H = Q / 8 (chain
//!   rule through q = qd / 8), so dH/dt = K qd / 64.
//!   *Current stiffness*: both moduli are scaled by the element's tangent ratio
//!   s = (dsigma' : deps') / (2 mu deps' : deps') measured from this step's stress update (primes:
//!   deviators; 1 while elastic, about H / (H + 3 mu) while a J2 material flows with hardening
//!   modulus H) while the hourglass forces are loading (sum H . qd > 0); unloading is elastic,
//!   as in an elastic-plastic spring, so the modes dissipate and never create energy. Yielded
//!   material is not held by elastic hourglass springs (the copper Taylor bar came out 27 %
//!   narrow with the elastic FB stiffness). A material without shear stiffness (a fluid) has no physical
//!   hourglass stiffness: it gets the viscous form with its default coefficient instead.
//! * **stiffness**: FB's stiffness form as PRONTO-3D / Presto write it,
//!   dH/dt = kappa 2 mu V (b . b) / 8 qd, kappa = `coefficient` (default 0.05), elastic.
//! * **viscous**: FB's viscous form in LS-DYNA's normalisation (type 1),
//!   H = kappa rho c V^(2/3) / 4 qd, kappa = `coefficient` (default 0.1), c the current wave
//!   speed.
use crate::hex::NODE_XI;

/// FB hourglass base vectors Gamma_alpha at the nodes: eta zeta, zeta xi, xi eta, xi eta zeta.
/// They are orthogonal to 1, xi, eta, zeta over the nodes (the linear fields).
pub const GAMMA: [[f64; 8]; 4] = {
    let mut g = [[0.0; 8]; 4];
    let mut i = 0;
    while i < 8 {
        let [x, y, z] = NODE_XI[i];
        g[0][i] = y * z;
        g[1][i] = z * x;
        g[2][i] = x * y;
        g[3][i] = x * y * z;
        i += 1;
    }
    g
};

/// The hourglass control (SCENE.md `run.hourglass`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Hourglass {
    /// Assumed-strain physical stabilisation with the material's current tangent; `scale`
    /// multiplies the physical stiffness (default 1: the element is then exact in bending).
    Physical {
        /// Multiplier of the physical stiffness.
        scale: f64,
    },
    /// FB/PRONTO stiffness form with coefficient kappa.
    Stiffness {
        /// kappa.
        coefficient: f64,
    },
    /// FB viscous form (LS-DYNA normalisation) with coefficient kappa.
    Viscous {
        /// kappa.
        coefficient: f64,
    },
}

/// Default coefficient of the stiffness kind.
pub const DEFAULT_STIFFNESS: f64 = 0.05;
/// Default coefficient of the viscous kind (and of fluids under the physical kind).
pub const DEFAULT_VISCOUS: f64 = 0.1;

impl Default for Hourglass {
    fn default() -> Self {
        Hourglass::Physical { scale: 1.0 }
    }
}

/// What the hourglass force of one element needs to know about its material this step.
#[derive(Clone, Copy, Debug)]
pub struct HourglassMaterial {
    /// Elastic shear modulus mu, Pa.
    pub mu: f64,
    /// Poisson's ratio of the elastic moduli.
    pub nu: f64,
    /// Current density, kg/m^3.
    pub rho: f64,
    /// Current wave speed sqrt(rho c^2 / rho), m/s.
    pub c: f64,
    /// Tangent ratio s in [0, 1] (see the module comment).
    pub tangent_ratio: f64,
}

/// The element's frame and sizes for the physical kind: rows e_j (unit, orthonormal, e_0 along
/// dx/dxi, e_1 in the (xi, eta) plane), half-lengths a_j = |dx/dxi_j| at the centre.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// Orthonormal axes (rows).
    pub e: [[f64; 3]; 3],
    /// Half-lengths along the natural axes, m.
    pub a: [f64; 3],
}

impl Frame {
    /// Frame of the element with nodal coordinates `x` (Gram-Schmidt on the centre Jacobian's
    /// columns J_j = sum_I x_I xi_Ij / 8; a parallelepiped's edges are 2 J_j).
    pub fn new(x: &[[f64; 3]; 8]) -> Frame {
        let mut j = [[0.0; 3]; 3];
        for (xi, xn) in NODE_XI.iter().zip(x.iter()) {
            for d in 0..3 {
                for c in 0..3 {
                    j[d][c] += 0.125 * xi[d] * xn[c];
                }
            }
        }
        let a = [norm(&j[0]), norm(&j[1]), norm(&j[2])];
        let e0 = scale(&j[0], 1.0 / a[0]);
        let d01 = dot(&j[1], &e0);
        let t = [
            j[1][0] - d01 * e0[0],
            j[1][1] - d01 * e0[1],
            j[1][2] - d01 * e0[2],
        ];
        let e1 = scale(&t, 1.0 / norm(&t));
        let e2 = [
            e0[1] * e1[2] - e0[2] * e1[1],
            e0[2] * e1[0] - e0[0] * e1[2],
            e0[0] * e1[1] - e0[1] * e1[0],
        ];
        Frame { e: [e0, e1, e2], a }
    }

    /// Global components of `v` into this frame.
    #[inline]
    pub fn to_local(&self, v: &[f64; 3]) -> [f64; 3] {
        [dot(&self.e[0], v), dot(&self.e[1], v), dot(&self.e[2], v)]
    }

    /// Local components of `v` back to global axes.
    #[inline]
    pub fn to_global(&self, v: &[f64; 3]) -> [f64; 3] {
        std::array::from_fn(|c| self.e[0][c] * v[0] + self.e[1][c] * v[1] + self.e[2][c] * v[2])
    }
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn norm(a: &[f64; 3]) -> f64 {
    dot(a, a).sqrt()
}
fn scale(a: &[f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// Physical kind: the rate of the generalised forces, dH/dt = K qd / 64, for hourglass rates
/// `qd` in the element frame (`qd[a][i]`: mode a, local direction i), element volume `vol`,
/// half-lengths `a`, shear modulus `mu` and Poisson's ratio `nu` already scaled by the tangent
/// ratio and the `scale` coefficient. About 60 flops.
pub fn physical_rate(
    qd: &[[f64; 3]; 4],
    a: &[f64; 3],
    vol: f64,
    mu: f64,
    nu: f64,
) -> [[f64; 3]; 4] {
    // q = qd / 8 and H = Q / 8: the factor 1/64 goes into the moduli.
    let ebar = 2.0 * mu / (1.0 - nu) / 64.0;
    let g = mu / 64.0;
    let third = vol / 3.0;
    let mut h = [[0.0; 3]; 4];
    for gi in 0..3 {
        let p = (gi + 1) % 3;
        let r = (gi + 2) % 3;
        // Strains linear in xi_g (the factor xi_g itself is in the integral V/3).
        let epp = qd[r][p] / a[p];
        let err = qd[p][r] / a[r];
        let gpr = qd[r][r] / a[p] + qd[p][p] / a[r];
        // Plane-stress generalised stresses of the group, times V/3.
        let spp = third * ebar * (epp + nu * err);
        let srr = third * ebar * (err + nu * epp);
        let spr = third * g * gpr;
        // dEnergy/dq by the chain rule through the strains above.
        h[r][p] += spp / a[p];
        h[p][r] += srr / a[r];
        h[r][r] += spr / a[p];
        h[p][p] += spr / a[r];
    }
    // Mode 3: normal strains q_i3 (eta zeta / a_i, ...), integral of (eta zeta)^2 = V / 9.
    for i in 0..3 {
        h[3][i] = 2.0 * g * vol / 9.0 * qd[3][i] / (a[i] * a[i]);
    }
    h
}

/// Poisson's ratio from lambda + 2 mu and mu (0 for a fluid).
pub fn poisson_ratio(dilatational: f64, mu: f64) -> f64 {
    if mu <= 0.0 {
        return 0.0;
    }
    let lambda = dilatational - 2.0 * mu;
    lambda / (2.0 * (lambda + mu))
}

/// Tangent ratio s = (dsigma' : deps') / (2 mu deps' : deps') in [0, 1] from the stress change
/// of the material update `dsig` and the strain increment `deps` (Voigt, tensor shears): how
/// stiff the material was in the direction it was strained, relative to elastic. 1 when the
/// increment is below round-off (1e-14 in strain) or the material has no shear modulus.
pub fn tangent_ratio(dsig: &[f64; 6], deps: &[f64; 6], mu: f64) -> f64 {
    /// Strain increments below this norm are round-off: no ratio can be measured.
    const MIN_STRAIN_INCREMENT: f64 = 1e-14;
    if mu <= 0.0 {
        return 1.0;
    }
    let es = (deps[0] + deps[1] + deps[2]) / 3.0;
    let ss = (dsig[0] + dsig[1] + dsig[2]) / 3.0;
    let de = [deps[0] - es, deps[1] - es, deps[2] - es];
    let ds = [dsig[0] - ss, dsig[1] - ss, dsig[2] - ss];
    let ee = de[0] * de[0]
        + de[1] * de[1]
        + de[2] * de[2]
        + 2.0 * (deps[3] * deps[3] + deps[4] * deps[4] + deps[5] * deps[5]);
    if ee < MIN_STRAIN_INCREMENT * MIN_STRAIN_INCREMENT {
        return 1.0;
    }
    let se = ds[0] * de[0]
        + ds[1] * de[1]
        + ds[2] * de[2]
        + 2.0 * (dsig[3] * deps[3] + dsig[4] * deps[4] + dsig[5] * deps[5]);
    (se / (2.0 * mu * ee)).clamp(0.0, 1.0)
}

/// One element's hourglass forces for one step.
pub struct HourglassStep<'a> {
    /// Nodal coordinates at the end of the step.
    pub x: &'a [[f64; 3]; 8],
    /// Nodal velocities over the step.
    pub v: &'a [[f64; 3]; 8],
    /// Mean gradient b = (1/V) dV/dx at the end of the step.
    pub b: &'a [[f64; 3]; 8],
    /// Sum of b^2 over nodes and components, 1/m^2.
    pub bb: f64,
    /// Current volume, m^3.
    pub vol: f64,
    /// The step, s.
    pub dt: f64,
}

/// The hourglass vectors gamma_a (FB) of an element: gamma_aI = Gamma_aI - (Gamma_a . x) . b_I.
#[inline]
pub fn vectors(x: &[[f64; 3]; 8], b: &[[f64; 3]; 8]) -> [[f64; 8]; 4] {
    std::array::from_fn(|al| {
        let g = &GAMMA[al];
        let mut gx = [0.0; 3];
        for k in 0..8 {
            for c in 0..3 {
                gx[c] += g[k] * x[k][c];
            }
        }
        std::array::from_fn(|k| g[k] - (gx[0] * b[k][0] + gx[1] * b[k][1] + gx[2] * b[k][2]))
    })
}

impl Hourglass {
    /// The effective form for a material: fluids (no shear modulus) under the physical kind get
    /// the viscous form with its default coefficient.
    pub fn for_material(&self, mu: f64) -> Hourglass {
        match *self {
            Hourglass::Physical { .. } if mu <= 0.0 => Hourglass::Viscous {
                coefficient: DEFAULT_VISCOUS,
            },
            h => h,
        }
    }

    /// Adds the hourglass forces of one step to `force`, updates the element-frame generalised
    /// forces `hg` and returns the hourglass work of the step, J. The stiffness parts integrate
    /// H(n+1) = H(n) + dt dH/dt and count the work with the trapezoid (H(n) + H(n+1))/2 . qd dt.
    pub fn apply(
        &self,
        s: &HourglassStep,
        mat: &HourglassMaterial,
        hg: &mut [[f64; 3]; 4],
        force: &mut [[f64; 3]; 8],
    ) -> f64 {
        let kind = self.for_material(mat.mu);
        let gam = vectors(s.x, s.b);
        let frame = Frame::new(s.x);
        // Hourglass rates in the element frame.
        let qd: [[f64; 3]; 4] = std::array::from_fn(|al| {
            let mut q = [0.0; 3];
            for k in 0..8 {
                for c in 0..3 {
                    q[c] += s.v[k][c] * gam[al][k];
                }
            }
            frame.to_local(&q)
        });
        // Rate of the stiffness part and the viscous part (both per unit qd already applied).
        let (rate, visc): ([[f64; 3]; 4], f64) = match kind {
            Hourglass::Physical { scale } => {
                // Loading (the hourglass forces do positive work: sum H . qd > 0) follows the
                // material's tangent; unloading is elastic. Per mode this is a 1D
                // elastic-plastic spring: with dH = s K dq its dissipation
                // H dq - d(H K^-1 H)/2 = (1 - s) H . dq >= 0, so the hourglass forces never give
                // back more energy than they took. (Scaling unloading as well let a mode stiffen
                // while the centre was elastic and unload softly once it yielded: the container
                // crush then drew 9 J out of its hourglass modes.)
                let power: f64 = (0..4).map(|al| dot(&hg[al], &qd[al])).sum();
                let s_eff = if power > 0.0 { mat.tangent_ratio } else { 1.0 };
                let mu = scale * s_eff * mat.mu;
                (physical_rate(&qd, &frame.a, s.vol, mu, mat.nu), 0.0)
            }
            Hourglass::Stiffness { coefficient } => {
                let k = coefficient * 2.0 * mat.mu * s.vol * s.bb / 8.0;
                (std::array::from_fn(|al| scale(&qd[al], k)), 0.0)
            }
            Hourglass::Viscous { coefficient } => (
                [[0.0; 3]; 4],
                0.25 * coefficient * mat.rho * mat.c * s.vol.cbrt().powi(2),
            ),
        };
        let mut work = 0.0;
        for al in 0..4 {
            let mut tot = [0.0; 3];
            for i in 0..3 {
                let old = hg[al][i];
                let new = old + s.dt * rate[al][i];
                let qv = visc * qd[al][i];
                work += s.dt * (0.5 * (old + new) + qv) * qd[al][i];
                hg[al][i] = new;
                tot[i] = new + qv;
            }
            let tg = frame.to_global(&tot);
            for k in 0..8 {
                for c in 0..3 {
                    force[k][c] -= tg[c] * gam[al][k];
                }
            }
        }
        work
    }

    /// The hourglass tangent of an element, K[3 I + i][3 J + j] = d(-f_iI)/d(u_jJ) for a
    /// displacement increment u over a step `dt` (the viscous part as c / dt), with the elastic
    /// moduli (tangent ratio 1): for the implicit Newmark solver.
    pub fn tangent(
        &self,
        s: &HourglassStep,
        mat: &HourglassMaterial,
        dt: f64,
    ) -> Box<[[f64; 24]; 24]> {
        let mut k = Box::new([[0.0; 24]; 24]);
        // Column by column: the force of a unit displacement of one dof, as the rate form
        // gives it (linear in qd), with no stored forces.
        for col in 0..24 {
            let mut v = [[0.0; 3]; 8];
            v[col / 3][col % 3] = 1.0 / dt;
            let step = HourglassStep { v: &v, dt, ..*s };
            let mut hg = [[0.0; 3]; 4];
            let mut f = [[0.0; 3]; 8];
            let m = HourglassMaterial {
                tangent_ratio: 1.0,
                ..*mat
            };
            // The stiffness part's H(n+1) = dt dH/dt = K u; the viscous part's c u / dt.
            self.apply(&step, &m, &mut hg, &mut f);
            for row in 0..24 {
                k[row][col] = -f[row / 3][row % 3];
            }
        }
        k
    }
}
