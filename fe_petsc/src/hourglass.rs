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
//!   rule through q = qd / 8).
//!   *Current stiffness*: both moduli are scaled by the element's tangent ratio
//!   s = (dsigma' : deps') / (2 mu deps' : deps') measured from this step's stress update (primes:
//!   deviators; 1 while elastic, about H / (H + 3 mu) while a J2 material flows with hardening
//!   modulus H) while the modes are loading; unloading is elastic, as in an elastic-plastic
//!   spring, so the modes dissipate and never create energy. The state is the stress amplitudes
//!   (sig_pp, sig_rr, tau_pr per group, the three normal stresses of mode 3), bounded so that
//!   the stresses at the group's fibres, sigma_centre +- sig_group (xi_g = +-1), stay inside the
//!   von Mises surface of the material's current yield stress (`Material::yield_stress`): the
//!   middle element of a bent wall, whose centre stays elastic, carries at most a yield stress
//!   at its fibres, and an element whose centre flows carries no hourglass stress that would
//!   push a fibre outside the surface (the container crush's hourglass share fell from 13-22 %
//!   to 3-9 % with this bound; with a bound on the hourglass stress alone it did not fall with
//!   refinement).
//!   Yielded material is thus not held by elastic hourglass springs (the copper Taylor bar came
//!   out 27 % narrow with the elastic FB stiffness).
//!   *The tangential bound* ([`YieldBound::Tangential`], meshes split from tetrahedra or prisms):
//!   the bound above scales a group's whole amplitude tau, so an element whose centre flows
//!   (its centre stress on the surface, A = sy^2) keeps no hourglass stress at all, and its
//!   modes have no stiffness. On the distorted hexahedra of a split (never parallelepipeds)
//!   that let a spurious pattern grow geometrically during plastic flow: a split tetrahedral
//!   cube in homogeneous compression (tests/tests/tet_scenes.rs) came out with plastic strain
//!   0.25..0.43 where the exact answer is 0.3397 everywhere, and tension in a compressed
//!   specimen. Only the part of tau that pushes a fibre outside at first order needs bounding.
//!   With C(tau) = tau^T Q tau the Mises form of the amplitudes (Q = [[1, -1/2, 0], [-1/2, 1,
//!   0], [0, 0, 3]] on a group's [tau_pp, tau_rr, tau_pr], the plane-stress Mises form; 3/2 times
//!   the deviatoric projector on mode 3's normal entries) and B(tau) = g . tau (g = grad B =
//!   3/2 [s_pp, s_rr, 2 s_pr] of the centre's deviator s; 3/2 [s_00, s_11, s_22] on mode 3),
//!   split tau Q-orthogonally into a normal part tau_n = (B / G) m, m = Q^+ g, G = g . m, and a
//!   tangential part tau_t = tau - tau_n: B(tau_t) = 0 and C = B^2 / G + C_t. The normal part
//!   is bounded as before, on its own Mises form: lambda_n from A + 2 lambda_n |B| +
//!   lambda_n^2 B^2 / G <= sy^2 (0 where the centre flows). The tangential part moves a fibre
//!   along the surface: a fibre sigma_c + tau_t of a flowing centre lies outside by the second
//!   order only (A + C_t), and the radial return the material applies to the centre scales its
//!   deviator by sy / sqrt(A + C_t), so the tangential part keeps lambda_t = min(1, sy /
//!   sqrt(A_n + C_t)), A_n = A + 2 lambda_n |B| + lambda_n^2 B^2 / G the Mises form of the fibre
//!   with its bounded normal part. Where no fibre passes the surface both factors are 1, as the
//!   whole-amplitude bound's. With it the cube's plastic strain is uniform (0.3396..0.3397) and
//!   the platen force within 0.1 % of sigma(ep) A. Hexahedral meshes keep the whole-amplitude
//!   bound ([`YieldBound::Fibres`]): the tangential one changes their plastic runs (the Taylor
//!   bars, container_crush) and has not been validated on them. Implicit mode keeps it too
//!   (its tangent, `Hourglass::tangent_at`, is the whole-amplitude bound's slope).
//!   A material without shear stiffness (a fluid) has no physical hourglass stiffness: it gets
//!   the viscous form with its default coefficient instead.
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

/// The hourglass control (docs/scene.md `run.hourglass`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Hourglass {
    /// Assumed-strain physical stabilisation with the material's current tangent; `scale`
    /// multiplies the physical stiffness (default 1: the element is then exact in bending).
    Physical {
        /// Multiplier of the physical stiffness.
        scale: f64,
        /// How the yield stress bounds the amplitudes.
        bound: YieldBound,
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
        Hourglass::Physical {
            scale: 1.0,
            bound: YieldBound::Fibres,
        }
    }
}

/// How the physical kind bounds its stress amplitudes by the yield stress (the module
/// comment derives both).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum YieldBound {
    /// Each group's whole amplitude scaled so that its fibres stay inside the surface
    /// (hexahedral meshes).
    #[default]
    Fibres,
    /// The part normal to the surface at the centre bounded so, the tangential part returned
    /// radially with the fibre (meshes split from tetrahedra or prisms, explicit mode).
    Tangential,
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
    /// Current yield stress, Pa, for materials with a yield surface (bounds the physical
    /// hourglass stresses).
    pub yield_stress: Option<f64>,
    /// The element's centre stress (global axes, Voigt, tension positive), Pa.
    pub stress: [f64; 6],
}

/// The element's frame and sizes for the physical kind: rows e_j (unit, orthonormal, e_0 along
/// dx/dxi, e_1 in the (xi, eta) plane), half-lengths a_j = |dx/dxi_j| at the centre.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// Orthonormal axes (rows).
    pub e: [[f64; 3]; 3],
    /// Half-lengths along the natural axes, m.
    pub a: [f64; 3],
    /// Their inverses 1 / a_j, 1/m: each divides several of the hourglass rates and forces,
    /// so one division each and multiplications after (a division costs 8-16 multiplications'
    /// throughput on x86-64).
    pub ia: [f64; 3],
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
        // 1 / a_j from one division.
        let (a01, inv) = (a[0] * a[1], 1.0 / (a[0] * a[1] * a[2]));
        let ia = [a[1] * a[2] * inv, a[0] * a[2] * inv, a01 * inv];
        let e0 = scale(&j[0], ia[0]);
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
        Frame {
            e: [e0, e1, e2],
            a,
            ia,
        }
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

/// Physical kind: the amplitudes of the strain rates the hourglass rates `qd` (element frame,
/// `qd[a][i]`: mode a, local direction i) give the element with half-lengths `a`, 1/s. Group g
/// (strains linear in xi_g, (p, r) the other two axes): [eps_pp, eps_rr, gamma_pr]; mode 3
/// (`[3]`): the normal strains [eps_00, eps_11, eps_22] (times eta zeta, zeta xi, xi eta). The
/// nodal amplitudes are q = qd / 8. `ia`: the inverse half-lengths 1 / a_j ([`Frame::ia`]).
pub fn physical_strain_rates(qd: &[[f64; 3]; 4], ia: &[f64; 3]) -> [[f64; 3]; 4] {
    let mut e = [[0.0; 3]; 4];
    for g in 0..3 {
        let (p, r) = ((g + 1) % 3, (g + 2) % 3);
        e[g] = [
            0.125 * qd[r][p] * ia[p],
            0.125 * qd[p][r] * ia[r],
            0.125 * (qd[r][r] * ia[p] + qd[p][p] * ia[r]),
        ];
    }
    for i in 0..3 {
        e[3][i] = 0.125 * qd[3][i] * ia[i];
    }
    e
}

/// Physical kind: the generalised forces H (element frame) of the hourglass stress amplitudes
/// `sig` (laid out as [`physical_strain_rates`], Pa): H = Q / 8 with Q = dEnergy/dq, the energy
/// rate being (V/3) sum_g sig_g . e_g + (V/9) sig_3 . e_3; `ia` the inverse half-lengths.
/// About 45 flops, no division.
pub fn physical_forces(sig: &[[f64; 3]; 4], ia: &[f64; 3], vol: f64) -> [[f64; 3]; 4] {
    // The weights w / a_j (and w / (3 a_j) for mode 3) once per element, one product per term.
    let w = 0.125 * vol * THIRD;
    let wia = [w * ia[0], w * ia[1], w * ia[2]];
    let mut h = [[0.0; 3]; 4];
    for g in 0..3 {
        let (p, r) = ((g + 1) % 3, (g + 2) % 3);
        let [spp, srr, spr] = sig[g];
        h[r][p] += spp * wia[p];
        h[p][r] += srr * wia[r];
        h[r][r] += spr * wia[p];
        h[p][p] += spr * wia[r];
    }
    for i in 0..3 {
        h[3][i] = sig[3][i] * (wia[i] * THIRD);
    }
    h
}

/// 1/3 rounded: the kernels multiply by it where a mean of three or a third is taken (one
/// multiplication instead of a division; the scalar and batched kernels alike, so they agree
/// to the bit).
pub(crate) const THIRD: f64 = 1.0 / 3.0;

/// Physical kind: the rates of the stress amplitudes for strain-rate amplitudes `e`, with shear
/// modulus `mu` and Poisson's ratio `nu`: plane stress in each group
/// (Ebar = 2 mu / (1 - nu)), 2 mu on mode 3's normal strains.
fn physical_stress_rates(e: &[[f64; 3]; 4], mu: f64, nu: f64) -> [[f64; 3]; 4] {
    let ebar = 2.0 * mu / (1.0 - nu);
    let mut r = [[0.0; 3]; 4];
    for g in 0..3 {
        let [epp, err, gpr] = e[g];
        r[g] = [ebar * (epp + nu * err), ebar * (err + nu * epp), mu * gpr];
    }
    r[3] = [2.0 * mu * e[3][0], 2.0 * mu * e[3][1], 2.0 * mu * e[3][2]];
    r
}

/// The centre stress `st` (global axes, Voigt) in the element frame with rows `e`: E sigma E^T
/// as T = E sigma (45 flops), then the upper triangle of T E^T (30 flops), mirrored.
pub(crate) fn centre_stress(st: &[f64; 6], e: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let g = [
        [st[0], st[3], st[5]],
        [st[3], st[1], st[4]],
        [st[5], st[4], st[2]],
    ];
    let mut t = [[0.0; 3]; 3];
    for i in 0..3 {
        for l in 0..3 {
            t[i][l] = e[i][0] * g[0][l] + e[i][1] * g[1][l] + e[i][2] * g[2][l];
        }
    }
    let m = |i: usize, j: usize| t[i][0] * e[j][0] + t[i][1] * e[j][1] + t[i][2] * e[j][2];
    let (m01, m02, m12) = (m(0, 1), m(0, 2), m(1, 2));
    [
        [m(0, 0), m01, m02],
        [m01, m(1, 1), m12],
        [m02, m12, m(2, 2)],
    ]
}

/// The Mises forms of the yield bound, from the deviator: 3/2 dev(a) : dev(b) = 3/2 dev(a) : b,
/// each written on the entries that are not zero (a group's amplitudes have four, mode 3's
/// three) and on deviators, so that a large mean stress cancels exactly and not by
/// subtraction of large squares.
struct Centre {
    /// The centre stress in the element frame.
    a: [[f64; 3]; 3],
    /// Its deviator's diagonal.
    da: [f64; 3],
    /// 3/2 dev(a) : dev(a).
    mises_sq: f64,
}

impl Centre {
    /// 25 flops.
    fn new(a: &[[f64; 3]; 3]) -> Centre {
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

    /// (B, C) of group g's amplitudes [tau_pp, tau_rr, tau_pr] ((p, r) the axes after g):
    /// B = 3/2 dev(a) : tau, C = 3/2 dev(tau) : dev(tau). 20 flops.
    fn group(&self, g: usize, tau: &[f64; 3]) -> (f64, f64) {
        let (p, r) = ((g + 1) % 3, (g + 2) % 3);
        let [tpp, trr, tpr] = *tau;
        let b = 1.5 * (self.da[p] * tpp + self.da[r] * trr + 2.0 * self.a[p][r] * tpr);
        let tm = (tpp + trr) * THIRD;
        let (dp, dr) = (tpp - tm, trr - tm);
        let c = 1.5 * (dp * dp + dr * dr + tm * tm + 2.0 * tpr * tpr);
        (b, c)
    }

    /// The gradient g of B over group g's amplitudes (`g == 3`: mode 3's) and m = Q^+ g
    /// (the module comment).
    fn normal(&self, g: usize) -> ([f64; 3], [f64; 3]) {
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

    /// (B, C) of mode 3's amplitudes, the normal entries [tau_00, tau_11, tau_22]. 20 flops.
    fn mode3(&self, tau: &[f64; 3]) -> (f64, f64) {
        let b = 1.5 * (self.da[0] * tau[0] + self.da[1] * tau[1] + self.da[2] * tau[2]);
        let tm = (tau[0] + tau[1] + tau[2]) * THIRD;
        let d = [tau[0] - tm, tau[1] - tm, tau[2] - tm];
        let c = 1.5 * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        (b, c)
    }
}

/// Bounds each group's hourglass stress amplitude `tau` by the von Mises surface of radius
/// `sy`. [`YieldBound::Fibres`]: the stresses at its fibres, sigma_c +- lambda tau, stay
/// inside: lambda in [0, 1] from A + 2 lambda |B| + lambda^2 C <= sy^2 (A, B, C: the Mises
/// forms of sigma_c and tau). [`YieldBound::Tangential`]: the normal part so, the tangential
/// part returned radially with the fibre (the module comment).
fn yield_bound(sig: &mut [[f64; 3]; 4], centre: &[[f64; 3]; 3], sy: f64, bound: YieldBound) {
    let centre = Centre::new(centre);
    let a = centre.mises_sq;
    let lambda = |(b, c): (f64, f64)| -> f64 {
        if c <= 0.0 {
            return 1.0;
        }
        if a >= sy * sy {
            return 0.0;
        }
        ((-b.abs() + (b * b + c * (sy * sy - a)).sqrt()) / c).min(1.0)
    };
    for g in 0..4 {
        let (b, c) = if g < 3 {
            centre.group(g, &sig[g])
        } else {
            centre.mode3(&sig[3])
        };
        if bound == YieldBound::Tangential {
            let (gb, m) = centre.normal(g);
            let gg = dot(&gb, &m);
            // The normal part (B / G) m and its Mises form B^2 / G; none where the centre
            // has no deviator on these entries (then B = 0 too).
            let (coef, cn) = if gg > 1e-300 {
                let igg = 1.0 / gg;
                (b * igg, b * b * igg)
            } else {
                (0.0, 0.0)
            };
            let ct = (c - cn).max(0.0);
            let ln = lambda((b, cn));
            let an = a + 2.0 * ln * b.abs() + ln * ln * cn;
            let lt = if ct <= 0.0 {
                1.0
            } else {
                (sy * sy * (1.0 / (an + ct))).sqrt().min(1.0)
            };
            for i in 0..3 {
                let tn = coef * m[i];
                sig[g][i] = ln * tn + lt * (sig[g][i] - tn);
            }
            continue;
        }
        let f = lambda((b, c));
        for v in sig[g].iter_mut() {
            *v *= f;
        }
    }
}

/// Poisson's ratio from lambda + 2 mu and mu (0 for a fluid).
pub fn poisson_ratio(dilatational: f64, mu: f64) -> f64 {
    if mu <= 0.0 {
        return 0.0;
    }
    let lambda = dilatational - 2.0 * mu;
    lambda / (2.0 * (lambda + mu))
}

/// Strain increments below this norm are round-off: no tangent ratio can be measured.
pub(crate) const MIN_STRAIN_INCREMENT: f64 = 1e-14;

/// Tangent ratio s = (dsigma' : deps') / (2 mu deps' : deps') in [0, 1] from the stress change
/// of the material update `dsig` and the strain increment `deps` (Voigt, tensor shears): how
/// stiff the material was in the direction it was strained, relative to elastic. 1 when the
/// increment is below round-off (1e-14 in strain) or the material has no shear modulus.
pub fn tangent_ratio(dsig: &[f64; 6], deps: &[f64; 6], mu: f64) -> f64 {
    if mu <= 0.0 {
        return 1.0;
    }
    let es = (deps[0] + deps[1] + deps[2]) * THIRD;
    let ss = (dsig[0] + dsig[1] + dsig[2]) * THIRD;
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
    let mut out = [[0.0; 8]; 4];
    for (g, o) in GAMMA.iter().zip(out.iter_mut()) {
        let mut gx = [0.0; 3];
        for k in 0..8 {
            for c in 0..3 {
                gx[c] += g[k] * x[k][c];
            }
        }
        for k in 0..8 {
            o[k] = g[k] - (gx[0] * b[k][0] + gx[1] * b[k][1] + gx[2] * b[k][2]);
        }
    }
    out
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
        // Hourglass rates in the element frame (a plain loop rather than `array::from_fn`,
        // whose closure LLVM left out of line in some builds: ~12 % more instructions here).
        let mut qd = [[0.0; 3]; 4];
        for (al, qa) in qd.iter_mut().enumerate() {
            let mut q = [0.0; 3];
            for k in 0..8 {
                for c in 0..3 {
                    q[c] += s.v[k][c] * gam[al][k];
                }
            }
            *qa = frame.to_local(&q);
        }
        if let Hourglass::Physical { scale, bound } = kind {
            return physical_step(s, mat, scale, bound, &frame, &gam, &qd, hg, force);
        }
        // The FB forms: H itself is the state.
        let (rate, visc): (f64, f64) = match kind {
            Hourglass::Stiffness { coefficient } => {
                (coefficient * 2.0 * mat.mu * s.vol * s.bb / 8.0, 0.0)
            }
            Hourglass::Viscous { coefficient } => (
                0.0,
                0.25 * coefficient * mat.rho * mat.c * libm::cbrt(s.vol).powi(2),
            ),
            Hourglass::Physical { .. } => unreachable!(),
        };
        let mut work = 0.0;
        let mut h = [[0.0; 3]; 4];
        for al in 0..4 {
            for i in 0..3 {
                let old = hg[al][i];
                let new = old + s.dt * rate * qd[al][i];
                let qv = visc * qd[al][i];
                work += s.dt * (0.5 * (old + new) + qv) * qd[al][i];
                hg[al][i] = new;
                h[al][i] = new + qv;
            }
        }
        add_forces(&frame, &gam, &h, force);
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
                yield_stress: None,
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

    /// The hourglass tangent of an element at its step's own state, K[3 I + i][3 J + j] =
    /// d(-f_iI)/d(u_jJ) for the physical kind as [`Hourglass::apply`] computes its force: the
    /// amplitudes `hg` at the step's start, the step's motion `s.v` (the displacement increment
    /// over `s.dt`), `mat`'s tangent ratio on loading (held), and the yield bound's factor
    /// lambda of each group at the trial amplitudes (`BoundSlope`: the map's own derivative
    /// where lambda is 0 or 1, a symmetric positive semi-definite form of it in between). The
    /// other kinds: [`Hourglass::tangent`]. For the implicit Newmark solver.
    pub fn tangent_at(
        &self,
        s: &HourglassStep,
        mat: &HourglassMaterial,
        hg: &[[f64; 3]; 4],
    ) -> Box<[[f64; 24]; 24]> {
        // (The bound's slope is the whole-amplitude bound's: the implicit solver runs with
        // `YieldBound::Fibres`.)
        let Hourglass::Physical { scale, .. } = self.for_material(mat.mu) else {
            return self.tangent(s, mat, s.dt);
        };
        let gam = vectors(s.x, s.b);
        let frame = Frame::new(s.x);
        let rates = |v: &[[f64; 3]; 8]| -> [[f64; 3]; 4] {
            let qd: [[f64; 3]; 4] = std::array::from_fn(|al| {
                let mut q = [0.0; 3];
                for k in 0..8 {
                    for c in 0..3 {
                        q[c] += v[k][c] * gam[al][k];
                    }
                }
                frame.to_local(&q)
            });
            physical_strain_rates(&qd, &frame.ia)
        };
        // The step's own amplitudes before the bound, as `physical_step` forms them.
        let e = rates(s.v);
        let power: f64 =
            (0..3).map(|g| dot(&hg[g], &e[g])).sum::<f64>() + dot(&hg[3], &e[3]) * THIRD;
        let s_eff = if power > 0.0 { mat.tangent_ratio } else { 1.0 };
        let mu = scale * s_eff * mat.mu;
        let rate = physical_stress_rates(&e, mu, mat.nu);
        let trial: [[f64; 3]; 4] =
            std::array::from_fn(|al| std::array::from_fn(|i| hg[al][i] + s.dt * rate[al][i]));
        let slope = mat
            .yield_stress
            .map(|sy| BoundSlope::new(&trial, &centre_stress(&mat.stress, &frame.e), sy, mat.nu));
        let mut k = Box::new([[0.0; 24]; 24]);
        for col in 0..24 {
            // A unit displacement of one dof over the step: its amplitude increments, through
            // the bound's slope, their generalised forces.
            let mut v = [[0.0; 3]; 8];
            v[col / 3][col % 3] = 1.0 / s.dt;
            let r = physical_stress_rates(&rates(&v), mu, mat.nu);
            let mut dsig: [[f64; 3]; 4] =
                std::array::from_fn(|al| std::array::from_fn(|i| s.dt * r[al][i]));
            if let Some(b) = &slope {
                b.apply(&mut dsig);
            }
            let h = physical_forces(&dsig, &frame.ia, s.vol);
            let mut f = [[0.0; 3]; 8];
            add_forces(&frame, &gam, &h, &mut f);
            for row in 0..24 {
                k[row][col] = -f[row / 3][row % 3];
            }
        }
        k
    }
}

/// The derivative of the yield bound's map tau -> lambda(tau) tau (`yield_bound`) of each group
/// at the trial amplitudes, the centre stress held: 0 where the centre is on or outside the
/// surface (lambda is 0 about every amplitude with a deviator), the identity where the bound
/// does not act (lambda = 1). Where it acts with 0 < lambda < 1, lambda tau lies on the fibre
/// surface Phi(s) = A + 2 |B(s)| + C(s) = sy^2 and the map's own derivative,
/// lambda (I - tau n^T / (n . tau)) with n = grad Phi, is oblique (its stiffness not
/// symmetric, indefinite once symmetrised); it is taken as lambda (I - E n n^T / (n . E n)),
/// E the group's elastic matrix: the same tangent plane, a projection symmetric in the
/// energy's metric (the form of a closest-point return), so the stiffness stays symmetric
/// positive semi-definite.
struct BoundSlope {
    /// Per group: `None` for the identity, else (lambda, n, E n / (n . E n)); lambda = 0: the
    /// zero map.
    groups: [Option<GroupSlope>; 4],
}

/// One group's bound slope: lambda, n and E n / (n . E n) ([`BoundSlope`]).
type GroupSlope = (f64, [f64; 3], [f64; 3]);

impl BoundSlope {
    fn new(trial: &[[f64; 3]; 4], centre: &[[f64; 3]; 3], sy: f64, nu: f64) -> BoundSlope {
        let centre = Centre::new(centre);
        let a = centre.mises_sq;
        let sy2 = sy * sy;
        let groups = std::array::from_fn(|g| {
            let tau = &trial[g];
            let (b, c) = if g < 3 {
                centre.group(g, tau)
            } else {
                centre.mode3(tau)
            };
            if a >= sy2 {
                return Some((0.0, [0.0; 3], [0.0; 3]));
            }
            if c <= 0.0 {
                return None;
            }
            let lambda = (-b.abs() + (b * b + c * (sy2 - a)).sqrt()) / c;
            if lambda >= 1.0 {
                return None;
            }
            // n = grad(2 |B| + C) at s = lambda tau; E (unit shear modulus) times n.
            let sb = if b < 0.0 { -1.0 } else { 1.0 };
            let st = tau.map(|t| lambda * t);
            let (n, en) = if g < 3 {
                let (p, r) = ((g + 1) % 3, (g + 2) % 3);
                let gb = [1.5 * centre.da[p], 1.5 * centre.da[r], 3.0 * centre.a[p][r]];
                let tm = (st[0] + st[1]) * THIRD;
                let (dp, dr) = (st[0] - tm, st[1] - tm);
                let gc = [2.0 * dp - dr + tm, 2.0 * dr - dp + tm, 6.0 * st[2]];
                let n: [f64; 3] = std::array::from_fn(|i| 2.0 * sb * gb[i] + gc[i]);
                let ebar = 2.0 / (1.0 - nu);
                let en = [ebar * (n[0] + nu * n[1]), ebar * (n[1] + nu * n[0]), n[2]];
                (n, en)
            } else {
                let tm = (st[0] + st[1] + st[2]) * THIRD;
                let n: [f64; 3] =
                    std::array::from_fn(|i| 3.0 * sb * centre.da[i] + 3.0 * (st[i] - tm));
                (n, n.map(|x| 2.0 * x))
            };
            let nen = dot(&n, &en);
            if !(nen > 0.0) {
                return Some((lambda, [0.0; 3], [0.0; 3]));
            }
            Some((lambda, n, en.map(|x| x / nen)))
        });
        BoundSlope { groups }
    }

    /// Applies the slope to each group's amplitude increments `dsig`: lambda (d - m (n . d)).
    fn apply(&self, dsig: &mut [[f64; 3]; 4]) {
        for (d, g) in dsig.iter_mut().zip(&self.groups) {
            if let Some((lambda, n, m)) = g {
                let nd = dot(n, d);
                for i in 0..3 {
                    d[i] = lambda * (d[i] - m[i] * nd);
                }
            }
        }
    }
}

/// f_iI -= sum_a H_ia gamma_aI with H in the element frame.
fn add_forces(frame: &Frame, gam: &[[f64; 8]; 4], h: &[[f64; 3]; 4], force: &mut [[f64; 3]; 8]) {
    for al in 0..4 {
        let tg = frame.to_global(&h[al]);
        for k in 0..8 {
            for c in 0..3 {
                force[k][c] -= tg[c] * gam[al][k];
            }
        }
    }
}

/// The physical kind's step: `sig` holds the hourglass stress amplitudes (element frame, Pa).
///
/// Loading (the hourglass stresses do positive work, sum sig . e > 0) follows the material's
/// tangent; unloading is elastic, so that each mode is an elastic-plastic spring whose
/// dissipation (1 - s) sig . de is never negative (scaling unloading too let a mode stiffen
/// while the centre was elastic and unload softly once it yielded: the container crush drew 9 J
/// out of its modes). The amplitudes are then bounded by the material's current yield stress:
/// an element whose centre stays elastic (the middle of a bent wall) cannot carry a fibre
/// stress past yield in its hourglass modes either.
#[allow(clippy::too_many_arguments)]
fn physical_step(
    s: &HourglassStep,
    mat: &HourglassMaterial,
    scale: f64,
    bound: YieldBound,
    frame: &Frame,
    gam: &[[f64; 8]; 4],
    qd: &[[f64; 3]; 4],
    sig: &mut [[f64; 3]; 4],
    force: &mut [[f64; 3]; 8],
) -> f64 {
    let e = physical_strain_rates(qd, &frame.ia);
    // Energy-rate weights: V/3 for the groups, V/9 for mode 3 (only the sign matters here).
    let power: f64 = (0..3).map(|g| dot(&sig[g], &e[g])).sum::<f64>() + dot(&sig[3], &e[3]) * THIRD;
    let s_eff = if power > 0.0 { mat.tangent_ratio } else { 1.0 };
    let rate = physical_stress_rates(&e, scale * s_eff * mat.mu, mat.nu);
    let h_old = physical_forces(sig, &frame.ia, s.vol);
    for al in 0..4 {
        for i in 0..3 {
            sig[al][i] += s.dt * rate[al][i];
        }
    }
    if let Some(sy) = mat.yield_stress {
        yield_bound(sig, &centre_stress(&mat.stress, &frame.e), sy, bound);
    }
    let h = physical_forces(sig, &frame.ia, s.vol);
    let mut work = 0.0;
    for al in 0..4 {
        work += s.dt * 0.5 * (dot(&h_old[al], &qd[al]) + dot(&h[al], &qd[al]));
    }
    add_forces(frame, gam, &h, force);
    work
}
