//! The 4-node tetrahedron with a nodal-averaged volumetric strain rate: the non-locking linear
//! tetrahedron of J. Bonet and A. J. Burton, "A simple average nodal pressure tetrahedral
//! element for incompressible and nearly incompressible dynamic explicit applications",
//! Commun. Numer. Meth. Engng 14 (1998) 437-449 (BB below); LS-DYNA's solid ELFORM 13 and
//! OpenRadioss's Itetra4 = 3 are elements of this kind. Node order: gmsh's, which makes
//! det[x1-x0, x2-x0, x3-x0] > 0 (as for the reference (0,0,0), (1,0,0), (0,1,0), (0,0,1)).
//!
//! # Geometry
//!
//! Linear shape functions N_0 = 1 - xi_1 - xi_2 - xi_3, N_i = xi_i (i = 1, 2, 3). With the
//! edge vectors e_i = x_i - x_0 the Jacobian is J = [e1 e2 e3] (columns), V = det J / 6, and
//! grad N_i is the i-th row of J^-1: (e2 x e3, e3 x e1, e1 x e2) / det J, since
//! (e2 x e3) . e1 = det J and (e2 x e3) . e2 = (e2 x e3) . e3 = 0. Partition of unity gives
//! grad N_0 = -(grad N_1 + grad N_2 + grad N_3). V grad N_a = dV/dx_a (the derivative of the
//! triple product), so V grad N_a needs no division; |grad N_a| = 1/h_a with h_a the altitude
//! from node a (V = A_a h_a / 3 with A_a the opposite face's area, and V grad N_a = -A_a n_a / 3,
//! n_a that face's outward normal). The gradients reproduce every linear field exactly:
//! sum_a grad N_a = 0, sum_a x_a (x) grad N_a = I.
//!
//! # Why one volumetric rate per node does not lock
//!
//! A tetrahedral mesh has about 5.5 to 6.5 elements per vertex (the Kuhn split of a cube grid:
//! 6). A nearly incompressible material makes tr D = 0 a constraint: with one volumetric rate
//! per element that is about 5.5 constraints for the 3 velocity components of each vertex, so
//! the constraint ratio (equations per constraint, T. J. R. Hughes, The Finite Element Method,
//! 1987, section 4.3) is 3 / 5.5 < 1 and the mesh locks (it can hardly move without changing
//! some element's volume). BB take the volume at the nodes instead: the nodal volume
//! V_a = (1/4) sum_{e ni a} V_e, its ratio J_a = V_a / V_a0 and a nodal pressure p_a = p(J_a),
//! averaged back to the element, p_e = (1/4) sum_{a in e} p_a; one constraint per vertex for its
//! 3 components, ratio 3: the continuum's (3 equations of motion per incompressibility
//! constraint), Hughes's optimal value. The pressure's power is then nodal:
//! sum_e V_e p_e tr D_e = sum_a p_a (1/4) sum_{e ni a} V_e tr D_e = sum_a p_a dV_a/dt.
//!
//! # The rate form used here
//!
//! The element loop sums, per node, V_e tr D_e (= dV_e/dt at mid-step, [`rates`]), V_e at
//! mid-step and V_e at t(n+1) over the node's elements; theta_a = sum V_e tr D_e / sum V_e
//! = d ln J_a / dt (1/s) and J_a = sum V_e / sum V_e0. The element takes the means
//! theta = (1/4) sum theta_a and J = (1/4) sum J_a ([`TetAverages`]) and replaces the
//! volumetric part of its own rate of deformation:
//!
//! Dbar = D + (theta - tr D) / 3 I, so tr Dbar = theta and dev Dbar = dev D.
//!
//! The material integrates Dbar dt, and reads the density rho0 / J. For a bulk modulus K the
//! pressure rate is -K theta = (1/4) sum_a (-K theta_a): the rate form of BB's
//! p_e = (1/4) sum p(J_a). The deviatoric part stays the element's own constant-strain one.
//!
//! # What remains
//!
//! * The pair (linear velocity, nodal linear pressure) does not satisfy the inf-sup (LBB)
//!   condition: nodal averaging has spurious pressure modes, a checkerboard-like nodal pressure
//!   oscillation that the averaged forces do not resist, visible in nearly incompressible
//!   flows. C. R. Dohrmann, M. W. Heinstein, J. Jung, S. W. Key, W. R. Witkowski, "Node-based
//!   uniform strain elements for three-node triangular and four-node tetrahedral meshes",
//!   IJNME 47 (2000) 1549-1568, and M. W. Gee, C. R. Dohrmann, S. W. Key, W. A. Wall, "A
//!   uniform nodal strain tetrahedron with isochoric stabilization", IJNME 78 (2009) 429-443,
//!   add a stabilising (isochoric) element stress; M. A. Puso, J. Solberg, "A stabilized
//!   nodally integrated tetrahedral", IJNME 67 (2006) 841-867, do the same for nodal
//!   integration. None of that is here.
//! * The deviatoric part is the constant-strain tetrahedron's: linear tetrahedra are far too
//!   stiff in bending (shear locking: a constant strain cannot represent the linear variation
//!   of bending strain across a thickness, so bending produces spurious shear). Averaging the
//!   volumetric part does not change that; bending needs several elements through the
//!   thickness or quadratic (10-node) tetrahedra.
//! * The element pressure follows the nodal average in rate form; with non-linear bulk
//!   response (a fluid's EOS) the material evaluates p at the averaged density per element,
//!   not p(J_a) at the nodes averaged, which BB do.
//!
//! # Stable step
//!
//! [`max_frequency`] bounds the element's highest frequency with its lumped mass (rho0 vol0 / 4
//! per node); with the lumped global mass the element bound bounds the mesh's (the
//! element-eigenvalue theorem: lambda_max(M^-1 K) <= max_e lambda_max(M_e^-1 K_e)). The
//! averaging does not raise it: by Cauchy-Schwarz theta_a^2 <= sum V_e (tr D_e)^2 / sum V_e,
//! so the averaged volumetric energy K sum_a V_a theta_a^2 <= K sum_e V_e (tr D_e)^2, the
//! element-by-element one; the averaged stiffness is below the plain tetrahedra's.
use crate::hex::{rotated_stress, ElementError, HexControls};
use crate::hourglass::THIRD;
use crate::material::Material;

/// Nodes of the element.
pub const NODES: usize = 4;

/// The share of the element's mass that each node gets in the lumped mass matrix: the
/// row-sum of the consistent mass (integral of N_a rho over the element = rho V / 4, as every
/// linear shape function integrates to V / 4 over a tetrahedron).
pub const MASS_SHARE: f64 = 0.25;

/// The lumped mass each node gets from one element, rho0 vol0 / 4, kg (`rho0` kg/m^3, `vol0`
/// m^3).
#[inline]
pub fn lumped_mass_share(rho0: f64, vol0: f64) -> f64 {
    MASS_SHARE * rho0 * vol0
}

/// What the first pass reads from one element ([`rates`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TetRates {
    /// Volume at t(n+1), m^3.
    pub vol: f64,
    /// Volume at the mid-step geometry x(n+1) - dt/2 v(n+1/2), m^3.
    pub vol_mid: f64,
    /// vol_mid tr(D) at mid-step = dV/dt there, m^3/s.
    pub vol_rate: f64,
}

/// The nodal averages the second pass needs: means over the element's 4 nodes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TetAverages {
    /// Mean of the nodes' dilatation rates theta_a = sum vol_rate / sum vol_mid, 1/s.
    pub theta: f64,
    /// Mean of the nodes' volume ratios J_a = sum vol / sum vol0 (dimensionless, > 0).
    pub j: f64,
}

/// State of one element between steps.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TetState {
    /// Cauchy stress, Voigt xx,yy,zz,xy,yz,zx, Pa, tension positive (no bulk viscosity).
    pub stress: [f64; 6],
}

/// What one element update produced.
#[derive(Clone, Copy, Debug)]
pub struct TetOutput {
    /// Force on each node from this element (add to the nodal force): -internal, N.
    pub force: [[f64; 3]; 4],
    /// Volume at t(n+1), m^3.
    pub volume: f64,
    /// Stable step of this element (with bulk viscosity, no safety factor), s.
    pub dt_stable: f64,
    /// -tr(stress)/3 without bulk viscosity, Pa.
    pub pressure: f64,
}

/// a x b.
#[inline(always)]
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// dV/dx_a = V grad N_a (m^2) and the signed volume V (m^3), no division.
///
/// With e_i = x_i - x_0: 6 V = e1 . (e2 x e3), so dV/dx_1 = (e2 x e3) / 6,
/// dV/dx_2 = (e3 x e1) / 6, dV/dx_3 = (e1 x e2) / 6 (the triple product is cyclic), and
/// dV/dx_0 = -(their sum) since V does not change under a translation.
#[inline(always)]
fn volume_gradient(x: &[[f64; 3]; 4]) -> ([[f64; 3]; 4], f64) {
    let e: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|k| x[i + 1][k] - x[0][k]));
    const SIXTH: f64 = 1.0 / 6.0;
    let c = [cross(e[1], e[2]), cross(e[2], e[0]), cross(e[0], e[1])];
    let mut bv = [[0.0; 3]; 4];
    for i in 0..3 {
        for k in 0..3 {
            bv[i + 1][k] = c[i][k] * SIXTH;
            bv[0][k] -= bv[i + 1][k];
        }
    }
    let vol = e[0][0] * bv[1][0] + e[0][1] * bv[1][1] + e[0][2] * bv[1][2];
    (bv, vol)
}

/// The shape functions' gradients grad N_a (1/m) and the signed volume
/// det[x1-x0, x2-x0, x3-x0] / 6 (m^3, positive for a correctly oriented tetrahedron); the
/// gradients are infinite or NaN for a degenerate one (volume 0).
pub fn gradients(x: &[[f64; 3]; 4]) -> ([[f64; 3]; 4], f64) {
    let (mut g, vol) = volume_gradient(x);
    let iv = 1.0 / vol;
    for r in g.iter_mut() {
        for c in r.iter_mut() {
            *c *= iv;
        }
    }
    (g, vol)
}

/// The mid-step geometry x(n+1/2) = x(n+1) - dt/2 v(n+1/2), as the hexahedron's.
#[inline(always)]
fn mid_step(x: &[[f64; 3]; 4], v: &[[f64; 3]; 4], dt: f64) -> [[f64; 3]; 4] {
    std::array::from_fn(|a| std::array::from_fn(|k| x[a][k] - 0.5 * dt * v[a][k]))
}

/// `Err(Inverted)` unless the volume is positive and finite.
#[inline(always)]
fn check_volume(vol: f64) -> Result<(), ElementError> {
    if !(vol > 0.0) || !vol.is_finite() {
        return Err(ElementError::Inverted { volume: vol });
    }
    Ok(())
}

/// First pass: the element's volumes and volume rate.
///
/// `x`: nodal positions at t(n+1), m; `v`: velocities at t(n+1/2), m/s; `dt`: the step, s.
/// vol_rate = V(n+1/2) tr D = sum_a v_a . (V grad N_a)(n+1/2) = dV/dt at mid-step (the chain
/// rule on V(x_0..x_3)), m^3/s. `Err(Inverted)` when the volume at t(n+1) or at mid-step is not
/// positive and finite.
pub fn rates(x: &[[f64; 3]; 4], v: &[[f64; 3]; 4], dt: f64) -> Result<TetRates, ElementError> {
    let (_, vol) = volume_gradient(x);
    check_volume(vol)?;
    let (bvh, vol_mid) = volume_gradient(&mid_step(x, v, dt));
    check_volume(vol_mid)?;
    let vol_rate = (0..4)
        .map(|a| v[a][0] * bvh[a][0] + v[a][1] * bvh[a][1] + v[a][2] * bvh[a][2])
        .sum();
    Ok(TetRates {
        vol,
        vol_mid,
        vol_rate,
    })
}

/// L = sum_a v_a (x) grad N_a = (sum_a v_a (x) V grad N_a) / V at the geometry of `bv`
/// (`iv` = 1/V), 1/s: exact for a linear velocity field.
#[inline(always)]
fn velocity_gradient(v: &[[f64; 3]; 4], bv: &[[f64; 3]; 4], iv: f64) -> [[f64; 3]; 3] {
    let mut l = [[0.0; 3]; 3];
    for a in 0..4 {
        for i in 0..3 {
            for j in 0..3 {
                l[i][j] += v[a][i] * bv[a][j];
            }
        }
    }
    l.map(|row| row.map(|lij| lij * iv))
}

/// The averaged strain increment Dbar dt (Voigt, tensor shears) with
/// Dbar = sym L + (theta - tr sym L) / 3 I: the element's deviatoric rate, the nodal-averaged
/// volumetric rate `theta` (1/s).
#[inline(always)]
fn averaged_increment(l: &[[f64; 3]; 3], theta: f64, dt: f64) -> [f64; 6] {
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

/// 1 + 1e-12: [`max_frequency`]'s margin for rounding (the bound can be exact).
pub(crate) const ROUNDING_MARGIN: f64 = 1.0 + 1e-12;

/// sqrt(2/3) rounded.
pub(crate) const SQRT_2_3: f64 = 0.816_496_580_927_726;

/// Upper bound of the largest eigenvalue of G G^T = sum_a g_a g_a^T (1/m^2), `gg` its trace.
///
/// For a symmetric 3x3 S with eigenvalues s_i, d_i = s_i - tr S / 3 sums to 0, so
/// d_1 = -(d_2 + d_3), d_1^2 <= 2 (d_2^2 + d_3^2) and 3 d_1^2 <= 2 |dev S|^2:
/// lambda_max <= tr S / 3 + sqrt(2/3 |dev S|^2), exact when the two smaller eigenvalues are
/// equal, and never above tr S for S positive semi-definite.
#[inline(always)]
fn gram_max_eigen_bound(g: &[[f64; 3]; 4], gg: f64) -> f64 {
    let mut s = [[0.0; 3]; 3];
    for a in 0..4 {
        for i in 0..3 {
            for j in 0..3 {
                s[i][j] += g[a][i] * g[a][j];
            }
        }
    }
    let m = gg * THIRD;
    let (d0, d1, d2) = (s[0][0] - m, s[1][1] - m, s[2][2] - m);
    let dev2 = d0 * d0
        + d1 * d1
        + d2 * d2
        + 2.0 * (s[0][1] * s[0][1] + s[1][2] * s[1][2] + s[2][0] * s[2][0]);
    (m + SQRT_2_3 * dev2.sqrt()).min(gg)
}

/// Upper bound of the element's highest frequency omega_max (rad/s) with the lumped mass
/// rho vol / 4 per node: `g` the gradients (1/m), `rho` = (element mass) / (current volume)
/// (kg/m^3), `wave_modulus` M = rho c^2 (lambda + 2 mu for a solid, Pa), `shear_modulus` mu
/// (Pa).
///
/// Derivation. The stiffness is K = V B^T C B; for nodal displacements u_a (U the 3x4 matrix of
/// them, G the 3x4 matrix of the g_a), eps = sym(U G^T) and u.K u = V eps:C:eps. Take the
/// tangent bounded by the isotropic one with lambda = M - 2 mu and mu (exact for the elastic
/// model, a softer plastic tangent lies below it, a fluid has mu = 0 and lambda = M):
/// eps:C:eps <= max(lambda, 0) (tr eps)^2 + 2 mu |eps|^2. Cauchy-Schwarz:
/// (tr eps)^2 = (sum_a u_a . g_a)^2 <= |U|^2 sum_a |g_a|^2, and
/// |eps|^2 <= |U G^T|^2 = sum_i r_i^T G^T G r_i <= lambda_max(G^T G) |U|^2 (r_i the rows of U).
/// With u.M u = (rho V / 4) |U|^2 the Rayleigh quotient gives
///
/// omega_max^2 <= (4 / rho) (max(lambda, 0) sum_a |g_a|^2 + 2 mu lambda_max(G^T G)),
///
/// which for lambda >= 0 is below the plain (4 / rho) M sum_a |g_a|^2, as
/// lambda_max(G^T G) <= tr(G^T G) = sum_a |g_a|^2 (for lambda < 0, nu < 0, the plain form is
/// not proven: its Cauchy-Schwarz step on lambda (tr eps)^2 runs the wrong way).
/// lambda_max(G^T G) = lambda_max(G G^T) is bounded by
/// `gram_max_eigen_bound`. For a regular tetrahedron (G G^T isotropic) the bound is the exact
/// highest frequency, so the factor 1 + 1e-12 keeps it above the exact one through the rounding
/// of the sums. For a regular tetrahedron of altitude h, |g_a| = 1/h.
pub fn max_frequency(g: &[[f64; 3]; 4], rho: f64, wave_modulus: f64, shear_modulus: f64) -> f64 {
    let gg: f64 = g.iter().flatten().map(|c| c * c).sum();
    let lmax = gram_max_eigen_bound(g, gg);
    let lambda = (wave_modulus - 2.0 * shear_modulus).max(0.0);
    (4.0 / rho * (lambda * gg + 2.0 * shear_modulus * lmax) * ROUNDING_MARGIN).sqrt()
}

/// The bulk viscosity's pressure q (Pa) and its coefficient eta = q / theta (Pa s), the
/// hexahedron's convention (PRONTO/LS-DYNA, quadratic coefficient squared) with the nodal
/// averaged rate `theta` (1/s) as the volumetric rate:
///
/// q = rho l theta (b1 c + b2^2 l max(0, -theta)).
///
/// `rho` (kg/m^3) and c = sqrt(M / rho) (m/s) the material's density and sound speed. The
/// length is l = 2 / sqrt(sum_a |g_a|^2) (m): the altitude h of a regular tetrahedron
/// (|g_a| = 1/h) and in general between the smallest altitude h_min and 2 h_min
/// (sum 1/h_a^2 lies between 1/h_min^2 and 4/h_min^2), so a sliver is damped on its thin
/// dimension as the hexahedron's sqrt(3)/sqrt(2 b.b) damps a flat brick on its thinnest side,
/// where V^(1/3) would overdamp it; with l, 2/omega for the plain bound is l / (2 c).
#[inline(always)]
fn bulk_viscosity(ctl: &HexControls, gg: f64, rho: f64, c: f64, theta: f64) -> (f64, f64) {
    let len = 2.0 / gg.sqrt();
    let eta = rho
        * len
        * (ctl.bv_linear * c + ctl.bv_quadratic * ctl.bv_quadratic * len * (-theta).max(0.0));
    (eta * theta, eta)
}

/// Stable step (s) of a mode of frequency at most `omega` (rad/s) whose damping gives
/// omega xi at most `gamma` (1/s): (2/omega)(sqrt(1 + xi^2) - xi) with xi = gamma / omega,
/// the central difference's limit with damping ratio xi (T. Belytschko, W. K. Liu, B. Moran,
/// Nonlinear Finite Elements for Continua and Structures, 2000, section 6.3), written
/// 2 / (sqrt(omega^2 + gamma^2) + gamma): decreasing in both, so the two bounds give a safe
/// step.
#[inline(always)]
fn critical_dt(omega: f64, gamma: f64) -> f64 {
    2.0 / ((omega * omega + gamma * gamma).sqrt() + gamma)
}

/// The stable step (s, no safety factor) of a tetrahedron at positions `x` (m), density `rho`
/// (kg/m^3) and volumetric rate `theta` (1/s) with the material's constant moduli: what
/// [`update`] reports, for the start of a run (the hexahedron's `hex::stable_dt`).
pub fn stable_dt(
    x: &[[f64; 3]; 4],
    rho: f64,
    mat: &dyn Material,
    ctl: &HexControls,
    theta: f64,
) -> f64 {
    let (g, _) = gradients(x);
    let gg: f64 = g.iter().flatten().map(|c| c * c).sum();
    let modulus = mat.dilatational_modulus();
    let c = (modulus / rho).sqrt();
    let (_, eta) = bulk_viscosity(ctl, gg, rho, c, theta);
    let omega = max_frequency(&g, rho, modulus, mat.shear_modulus());
    critical_dt(omega, 2.0 * eta * gg / rho)
}

/// The nodal forces -V (sigma + q I) grad N_a (`bv` = V grad N_a at t(n+1)), N.
#[inline(always)]
fn stress_forces(bv: &[[f64; 3]; 4], s: &[f64; 6], q: f64) -> [[f64; 3]; 4] {
    let t = [s[0] + q, s[1] + q, s[2] + q, s[3], s[4], s[5]];
    bv.map(|b| {
        [
            -(t[0] * b[0] + t[3] * b[1] + t[5] * b[2]),
            -(t[3] * b[0] + t[1] * b[1] + t[4] * b[2]),
            -(t[5] * b[0] + t[4] * b[1] + t[2] * b[2]),
        ]
    })
}

/// Second pass: one explicit update of one element with the nodal averages `avg`.
///
/// The explicit loop runs this update in lanes (`batch/tet.rs`, every width the same bits),
/// which agrees with this function to round-off: this is its reference in the tests
/// (`tests/tet_lanes.rs`, 1e-12 relative), as [`crate::hex::update`] is the hexahedron's.
///
/// `x`: nodal positions at t(n+1), m; `v`: velocities at t(n+1/2), m/s; `dt`: the step, s;
/// `rho0` (kg/m^3), `vol0` (m^3): reference density and volume. L from the mid-step gradients,
/// the stress rotated by the Hughes-Winget increment of skew L (the hexahedron's), the material
/// given Dbar dt (module doc) and the density rho0 / avg.j; bulk viscosity on theta added to
/// the normal stresses for the force only, its work q theta dt / rho (J/kg, >= 0) given to the
/// material as heat; forces with the gradients at t(n+1); the stable step from
/// [`max_frequency`] with rho_e = rho0 vol0 / V (the lumped mass over the current volume) and
/// the bulk viscosity's damping: its damping matrix eta V g g^T (volumetric only) has the
/// Rayleigh quotient <= 4 eta sum|g_a|^2 / rho_e over the lumped mass, so a mode of frequency
/// omega has omega xi <= gamma = 2 eta sum|g_a|^2 / rho_e (the hexahedron's xi in the same
/// terms). `Err(Inverted)` when the volume at t(n+1) or mid-step is not positive and finite.
#[allow(clippy::too_many_arguments)]
pub fn update(
    x: &[[f64; 3]; 4],
    v: &[[f64; 3]; 4],
    dt: f64,
    rho0: f64,
    vol0: f64,
    avg: TetAverages,
    mat: &dyn Material,
    ctl: &HexControls,
    st: &mut TetState,
    mat_state: &mut [f64],
) -> Result<TetOutput, ElementError> {
    let (bv, vol) = volume_gradient(x);
    check_volume(vol)?;
    let (bvh, volh) = volume_gradient(&mid_step(x, v, dt));
    check_volume(volh)?;
    let l = velocity_gradient(v, &bvh, 1.0 / volh);
    let mut stress = rotated_stress(&l, dt, &st.stress);
    let deps = averaged_increment(&l, avg.theta, dt);
    let rho = rho0 / avg.j;
    mat.update_stress(&mut stress, mat_state, &deps, dt, rho);
    st.stress = stress;

    let iv = 1.0 / vol;
    let g = bv.map(|b| b.map(|c| c * iv));
    let gg: f64 = g.iter().flatten().map(|c| c * c).sum();
    let modulus = mat.wave_modulus(rho, mat_state);
    let c = (modulus / rho).sqrt();
    let (q, eta) = bulk_viscosity(ctl, gg, rho, c, avg.theta);
    if q != 0.0 {
        mat.add_heat(mat_state, q * avg.theta * dt / rho, rho);
    }
    let rho_e = rho0 * vol0 * iv;
    let omega = max_frequency(&g, rho_e, modulus, mat.shear_modulus());
    let dt_stable = critical_dt(omega, 2.0 * eta * gg / rho_e);
    Ok(TetOutput {
        force: stress_forces(&bv, &stress, q),
        volume: vol,
        dt_stable,
        pressure: -(stress[0] + stress[1] + stress[2]) * THIRD,
    })
}
