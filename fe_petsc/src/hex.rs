//! The PRONTO-3D hexahedron: 8 nodes, one-point (mean-gradient) integration, hourglass control
//! (`crate::hourglass`: physical assumed-strain stabilisation by default), linear and quadratic
//! bulk viscosity, Hughes-Winget objective stress update.
//!
//! Reference: D. P. Flanagan and T. Belytschko, "A uniform strain hexahedron and quadrilateral
//! with orthogonal hourglass control", IJNME 17 (1981) 679-706 (FB below).
//! Node order: gmsh/VTK (0-3 the face zeta = -1 counter-clockwise seen from +zeta, 4-7 above).
use crate::hourglass::{self, Hourglass, HourglassMaterial, HourglassStep};
use crate::material::Material;

/// Nodes of the element.
pub const NODES: usize = 8;

/// Natural coordinates of the nodes (gmsh/VTK order).
pub const NODE_XI: [[f64; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];

/// Hourglass and bulk-viscosity coefficients (docs/scene.md `run.hourglass`, `run.bulk_viscosity`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HexControls {
    /// Hourglass control (default: physical stabilisation, see [`crate::hourglass`]).
    pub hourglass: Hourglass,
    /// Linear bulk-viscosity coefficient b1 (default 0.06).
    pub bv_linear: f64,
    /// Quadratic bulk-viscosity coefficient b2 (default 1.2; enters squared).
    pub bv_quadratic: f64,
}

impl Default for HexControls {
    fn default() -> Self {
        HexControls {
            hourglass: Hourglass::default(),
            bv_linear: 0.06,
            bv_quadratic: 1.2,
        }
    }
}

/// State of one element between steps.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HexState {
    /// Cauchy stress, Voigt xx,yy,zz,xy,yz,zx, Pa, tension positive (no bulk viscosity).
    pub stress: [f64; 6],
    /// Hourglass state in the element frame (`crate::hourglass`): the physical kind's stress
    /// amplitudes, Pa, or the FB forms' generalised forces, N.
    pub hg: [[f64; 3]; 4],
}

/// What one element update produced.
#[derive(Clone, Copy, Debug)]
pub struct HexOutput {
    /// Force on each node from this element (add to the nodal force): -internal, N.
    pub force: [[f64; 3]; 8],
    /// Hourglass work done on the element this step, J.
    pub hg_work: f64,
    /// Current volume, m^3.
    pub volume: f64,
    /// Stable step of this element (FB estimate with bulk viscosity, no safety factor), s.
    pub dt_stable: f64,
    /// -tr(stress)/3 without bulk viscosity, Pa.
    pub pressure: f64,
}

/// The element cannot be updated.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum ElementError {
    /// Zero, negative or non-finite volume.
    #[error("element inverted (volume {volume:e} m^3)")]
    Inverted {
        /// The offending volume.
        volume: f64,
    },
}

/// Non-zero terms of dV/dx_I: for each node I, pairs (J, K, c) with
/// dV/dx_I = sum c (y_J z_K - y_K z_J), and cyclically for y and z.
///
/// Derivation: V = integral of det(dx/dxi) over [-1,1]^3 = sum_IJK x_I y_J z_K C_IJK with
/// C_IJK = integral of eps_abc dN_I/dxi_a dN_J/dxi_b dN_K/dxi_c (degree <= 2 per variable, so
/// 2-point Gauss is exact). V is linear in the x-components, so B_xI = dV/dx_I gives
/// sum_I B_xI x_I = V and sum_I B_xI y_I = 0: the FB uniform-strain gradient, exact for linear
/// fields.
pub(crate) struct VolumeTerms {
    pub(crate) pairs: [[(u8, u8, f64); MAX_PAIRS]; 8],
}

/// Non-zero (J, K) pairs per node in dV/dx_I (9 for the trilinear hexahedron).
pub(crate) const MAX_PAIRS: usize = 9;

const fn dshape(xi: [f64; 3]) -> [[f64; 3]; 8] {
    let mut d = [[0.0; 3]; 8];
    let mut i = 0;
    while i < 8 {
        let n = NODE_XI[i];
        let a = 1.0 + n[0] * xi[0];
        let b = 1.0 + n[1] * xi[1];
        let c = 1.0 + n[2] * xi[2];
        d[i] = [n[0] * b * c / 8.0, a * n[1] * c / 8.0, a * b * n[2] / 8.0];
        i += 1;
    }
    d
}

/// 1/sqrt(3): the 2-point Gauss abscissa (sqrt is not available at compile time).
const GAUSS_2PT: f64 = 0.577_350_269_189_625_8;

/// The table, computed at compile time so that the loops in `volume_gradient` unroll into
/// straight-line code with constant coefficients and indices.
pub(crate) const VOLUME_TERMS: VolumeTerms = {
    let mut c = [[[0.0f64; 8]; 8]; 8];
    let mut p = 0;
    while p < 8 {
        let xi = [
            if p & 1 == 0 { -GAUSS_2PT } else { GAUSS_2PT },
            if p & 2 == 0 { -GAUSS_2PT } else { GAUSS_2PT },
            if p & 4 == 0 { -GAUSS_2PT } else { GAUSS_2PT },
        ];
        let d = dshape(xi);
        let mut i = 0;
        while i < 8 {
            let mut j = 0;
            while j < 8 {
                let mut k = 0;
                while k < 8 {
                    let (a, b, e) = (d[i], d[j], d[k]);
                    c[i][j][k] += a[0] * (b[1] * e[2] - b[2] * e[1])
                        - a[1] * (b[0] * e[2] - b[2] * e[0])
                        + a[2] * (b[0] * e[1] - b[1] * e[0]);
                    k += 1;
                }
                j += 1;
            }
            i += 1;
        }
        p += 1;
    }
    let mut pairs = [[(0u8, 0u8, 0.0f64); MAX_PAIRS]; 8];
    let mut i = 0;
    while i < 8 {
        let mut n = 0;
        let mut j = 0;
        while j < 8 {
            let mut k = j + 1;
            while k < 8 {
                let v = c[i][j][k];
                if v > 1e-12 || v < -1e-12 {
                    assert!(n < MAX_PAIRS, "hex volume terms: more pairs than expected");
                    // Round to the exact multiple of 1/12 (the integrals are rational).
                    let r = v * 12.0;
                    let ri = if r > 0.0 {
                        (r + 0.5) as i64
                    } else {
                        (r - 0.5) as i64
                    };
                    pairs[i][n] = (j as u8, k as u8, ri as f64 / 12.0);
                    n += 1;
                }
                k += 1;
            }
            j += 1;
        }
        assert!(
            n == MAX_PAIRS,
            "hex volume terms: fewer pairs than expected"
        );
        i += 1;
    }
    VolumeTerms { pairs }
};

/// FB volume gradient B[I] = dV/dx_I (N.B. not divided by V) and the exact volume.
///
/// Written as one call per node with the node as a const parameter, so that each node's nine
/// (J, K, c) terms are compile-time constants: the loops unroll into straight-line code with
/// constant indices and coefficients (a loop over the table's entries read them at run time:
/// 75 -> 40 ns per call in `examples/hex_bench.rs`).
#[inline]
fn volume_gradient(x: &[[f64; 3]; 8]) -> ([[f64; 3]; 8], f64) {
    let b = [
        node_volume_gradient::<0>(x),
        node_volume_gradient::<1>(x),
        node_volume_gradient::<2>(x),
        node_volume_gradient::<3>(x),
        node_volume_gradient::<4>(x),
        node_volume_gradient::<5>(x),
        node_volume_gradient::<6>(x),
        node_volume_gradient::<7>(x),
    ];
    let v = (0..8).map(|i| x[i][0] * b[i][0]).sum();
    (b, v)
}

/// dV/dx_I for node `I`: `VOLUME_GROUPS`'s three cross products summed, times 1/12.
/// 18 additions for the W_J, 3 x 9 for the cross products, 6 + 3 to sum and scale: 54 flops
/// (the nine pair terms one by one took 135).
#[inline(always)]
fn node_volume_gradient<const I: usize>(x: &[[f64; 3]; 8]) -> [f64; 3] {
    let s0 = group_term(x, &VOLUME_GROUPS.groups[I][0]);
    let s1 = group_term(x, &VOLUME_GROUPS.groups[I][1]);
    let s2 = group_term(x, &VOLUME_GROUPS.groups[I][2]);
    [
        (s0[0] + s1[0] + s2[0]) * TWELFTH,
        (s0[1] + s1[1] + s2[1]) * TWELFTH,
        (s0[2] + s1[2] + s2[2]) * TWELFTH,
    ]
}

/// x_J x W_J (or W_J x x_J) of one group of [`VolumeGroups`].
#[inline(always)]
fn group_term(x: &[[f64; 3]; 8], g: &VolumeGroup) -> [f64; 3] {
    let mut w = x[g.k[0] as usize];
    let mut t = 1;
    while t < g.n as usize {
        let q = &x[g.k[t] as usize];
        if g.minus[t] {
            w = [w[0] - q[0], w[1] - q[1], w[2] - q[2]];
        } else {
            w = [w[0] + q[0], w[1] + q[1], w[2] + q[2]];
        }
        t += 1;
    }
    let p = &x[g.j as usize];
    let (a, b) = if g.swap { (&w, p) } else { (p, &w) };
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// 1/12 rounded: the one coefficient of the volume terms, taken out of their sums.
pub(crate) const TWELFTH: f64 = 1.0 / 12.0;

/// Most terms in one group of [`VolumeGroups`].
pub(crate) const MAX_GROUP: usize = 5;

/// One group of node I's volume terms: x_J x W_J with W_J = x_K0 +- x_K1 +- ... (or
/// W_J x x_J when `swap`, which carries the group's sign so that W_J starts with a plus).
#[derive(Clone, Copy, Debug)]
pub(crate) struct VolumeGroup {
    pub(crate) j: u8,
    pub(crate) swap: bool,
    pub(crate) k: [u8; MAX_GROUP],
    pub(crate) minus: [bool; MAX_GROUP],
    pub(crate) n: u8,
}

/// [`VolumeTerms`] regrouped: every coefficient is +-1/12, and the nine pairs (J, K) of node I
/// each contain one of I's three edge neighbours (a vertex cover of the pairs), so
/// 12 dV/dx_I = sum over the three neighbours J of x_J x W_J, W_J the signed sum of the other
/// nodes K paired with J: three cross products and additions instead of nine cross products
/// and nine scalings.
pub(crate) struct VolumeGroups {
    pub(crate) groups: [[VolumeGroup; 3]; 8],
}

/// The groups, computed at compile time from [`VOLUME_TERMS`] (and checked there: every
/// coefficient +-1/12, every pair covered, at most [`MAX_GROUP`] terms per group).
pub(crate) const VOLUME_GROUPS: VolumeGroups = {
    let empty = VolumeGroup {
        j: 0,
        swap: false,
        k: [0; MAX_GROUP],
        minus: [false; MAX_GROUP],
        n: 0,
    };
    let mut groups = [[empty; 3]; 8];
    let mut i = 0;
    while i < 8 {
        // I's edge neighbours: the nodes whose natural coordinates differ from I's in one.
        let mut g = 0;
        let mut j = 0;
        while j < 8 {
            let (a, b) = (NODE_XI[i], NODE_XI[j]);
            let differ = (a[0] != b[0]) as u8 + (a[1] != b[1]) as u8 + (a[2] != b[2]) as u8;
            if differ == 1 {
                groups[i][g].j = j as u8;
                g += 1;
            }
            j += 1;
        }
        assert!(
            g == 3,
            "hex volume groups: a node without three edge neighbours"
        );
        // Each pair (J, K, c) to the first group whose node is J or K: c x_J x x_K, or
        // -c x_K x x_J when the group's node is K. Signs relative to the group's first term.
        let mut sign = [0.0f64; 3];
        let mut n = 0;
        while n < MAX_PAIRS {
            let (pj, pk, c) = VOLUME_TERMS.pairs[i][n];
            assert!(
                c * 12.0 == 1.0 || c * 12.0 == -1.0,
                "hex volume groups: a coefficient other than +-1/12"
            );
            let mut g = 0;
            while g < 3 && groups[i][g].j != pj && groups[i][g].j != pk {
                g += 1;
            }
            assert!(g < 3, "hex volume groups: a pair without an edge neighbour");
            let (other, c) = if groups[i][g].j == pj {
                (pk, c)
            } else {
                (pj, -c)
            };
            let gr = &mut groups[i][g];
            let t = gr.n as usize;
            assert!(t < MAX_GROUP, "hex volume groups: a group too long");
            if t == 0 {
                sign[g] = c;
                gr.swap = c < 0.0;
            }
            gr.k[t] = other;
            gr.minus[t] = (c < 0.0) != (sign[g] < 0.0);
            gr.n += 1;
            n += 1;
        }
        i += 1;
    }
    VolumeGroups { groups }
};

/// Exact volume and the FB mean gradient `b[I][i]` = (1/V) integral of dN_I/dx_i over the element.
pub fn gradient(x: &[[f64; 3]; 8]) -> ([[f64; 3]; 8], f64) {
    let (mut b, v) = volume_gradient(x);
    let iv = 1.0 / v;
    for r in b.iter_mut() {
        for c in r.iter_mut() {
            *c *= iv;
        }
    }
    (b, v)
}

/// Exact volume of the trilinear hexahedron.
pub fn volume(x: &[[f64; 3]; 8]) -> f64 {
    volume_gradient(x).1
}

/// Trilinear shape functions at natural coordinates `xi`.
pub fn shape(xi: [f64; 3]) -> [f64; 8] {
    std::array::from_fn(|i| {
        let n = NODE_XI[i];
        (1.0 + n[0] * xi[0]) * (1.0 + n[1] * xi[1]) * (1.0 + n[2] * xi[2]) / 8.0
    })
}

/// Natural coordinates of point `p` in the element (Newton on x(xi) = p), or `None` when the
/// point lies outside [-1 - tol, 1 + tol]^3.
pub fn natural_coords(x: &[[f64; 3]; 8], p: [f64; 3], tol: f64) -> Option<[f64; 3]> {
    let mut xi = [0.0; 3];
    for _ in 0..50 {
        let n = shape(xi);
        let d = dshape(xi);
        let mut r = p;
        let mut j = [[0.0; 3]; 3];
        for k in 0..8 {
            for a in 0..3 {
                r[a] -= n[k] * x[k][a];
                for b in 0..3 {
                    j[a][b] += x[k][a] * d[k][b];
                }
            }
        }
        let ji = inverse3(&j)?;
        let dxi: [f64; 3] = std::array::from_fn(|a| (0..3).map(|b| ji[a][b] * r[b]).sum());
        for a in 0..3 {
            // Keep the iterate near the element so that far points do not diverge.
            xi[a] = (xi[a] + dxi[a]).clamp(-3.0, 3.0);
        }
        if dxi.iter().all(|d| d.abs() < 1e-14) {
            break;
        }
    }
    if xi.iter().all(|v| v.abs() <= 1.0 + tol) {
        // Confirm the map (a clamped iterate may not have converged).
        let n = shape(xi);
        let mut err = 0.0f64;
        let mut size = 0.0f64;
        for a in 0..3 {
            let q: f64 = (0..8).map(|k| n[k] * x[k][a]).sum();
            err = err.max((q - p[a]).abs());
            let lo = x.iter().map(|v| v[a]).fold(f64::INFINITY, f64::min);
            let hi = x.iter().map(|v| v[a]).fold(f64::NEG_INFINITY, f64::max);
            size = size.max(hi - lo);
        }
        if err <= 1e-9 * size.max(1e-300) + tol * size {
            return Some(xi);
        }
    }
    None
}

fn inverse3(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let c = [
        [
            m[1][1] * m[2][2] - m[1][2] * m[2][1],
            m[0][2] * m[2][1] - m[0][1] * m[2][2],
            m[0][1] * m[1][2] - m[0][2] * m[1][1],
        ],
        [
            m[1][2] * m[2][0] - m[1][0] * m[2][2],
            m[0][0] * m[2][2] - m[0][2] * m[2][0],
            m[0][2] * m[1][0] - m[0][0] * m[1][2],
        ],
        [
            m[1][0] * m[2][1] - m[1][1] * m[2][0],
            m[0][1] * m[2][0] - m[0][0] * m[2][1],
            m[0][0] * m[1][1] - m[0][1] * m[1][0],
        ],
    ];
    let det = m[0][0] * c[0][0] + m[0][1] * c[1][0] + m[0][2] * c[2][0];
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let id = 1.0 / det;
    Some(std::array::from_fn(|i| {
        std::array::from_fn(|j| c[i][j] * id)
    }))
}

/// The element's wave terms: s = sqrt(2 sum_Ii b_Ii^2) and 1 / (c s), the one division that
/// the bulk viscosity's length, its quadratic term and the stable step share (below).
#[derive(Clone, Copy)]
struct Wave {
    s: f64,
    ics: f64,
}

impl Wave {
    #[inline]
    fn new(bb: f64, c: f64) -> Wave {
        let s = (2.0 * bb).sqrt();
        Wave {
            s,
            ics: 1.0 / (c * s),
        }
    }
}

/// sqrt(3) rounded.
pub(crate) const SQRT_3: f64 = 1.732_050_807_568_877_2;

/// FB maximum-frequency bound: omega_max = 2 c s with s = sqrt(2 sum_Ii b_Ii^2); with damping
/// ratio xi the stable step is (2/omega_max)(sqrt(1 + xi^2) - xi), 2/omega_max = 1/(c s). For a
/// cube of side h, 2/omega_max = h/(c sqrt 3).
#[inline]
fn critical_dt(w: Wave, xi: f64) -> f64 {
    w.ics * ((1.0 + xi * xi).sqrt() - xi)
}

/// The bulk viscosity: the pressure q it adds to the normal stresses and the damping ratio it
/// gives the element's highest mode, one definition for the force and the stable step.
///
/// q = rho l eps_v (b1 c + b2^2 l max(0, -eps_v)) (PRONTO/LS-DYNA convention, quadratic
/// coefficient squared; eps_v = tr D, 1/s). As a viscosity on the mode of frequency
/// omega_max = 2 c sqrt(2 b.b), whose stiffness is rho c^2 times the same geometric factor, it
/// gives the damping ratio xi = (q / (rho c^2 eps_v)) omega_max / 2
/// = (b1 + b2^2 l |eps_v| / c) l sqrt(2 b.b) = sqrt(3) (b1 + b2^2 l |eps_v| / c): sqrt(3) times
/// what the bare coefficients say (the stable step once assumed b1 alone, and bar_wave with
/// 8:1 bricks and b1 = 0.3 blew up at dt_safety 0.86).
///
/// The length is l = sqrt(3) / s (s = sqrt(2 b.b)): h for a cube of side h (as V^(1/3) is),
/// close to the thinnest side of a flat brick (V^(1/3) damped an 8:1 brick 2.4 times more than
/// its step allowed: bar_wave at N = 160, M = 1 blew up). With 1/(c s) known, l = sqrt(3) c
/// (1/(c s)) and 1/c = s (1/(c s)): no division here.
#[inline]
fn bulk_viscosity(ctl: &HexControls, w: Wave, rho: f64, c: f64, ev: f64) -> (f64, f64) {
    let len = SQRT_3 * (c * w.ics);
    let comp = (-ev).max(0.0);
    let lin_quad = ctl.bv_linear + ctl.bv_quadratic * ctl.bv_quadratic * len * comp * (w.s * w.ics);
    let q = rho * len * c * ev * lin_quad;
    let xi = lin_quad * len * w.s;
    (q, xi)
}

/// Stable step of an element at density `rho` with volumetric strain rate `div_v`.
pub fn stable_dt(
    x: &[[f64; 3]; 8],
    rho: f64,
    mat: &dyn Material,
    ctl: &HexControls,
    div_v: f64,
) -> f64 {
    let (b, _) = gradient(x);
    let bb: f64 = b.iter().flatten().map(|q| q * q).sum();
    let c = (mat.dilatational_modulus() / rho).sqrt();
    let w = Wave::new(bb, c);
    let (_, xi) = bulk_viscosity(ctl, w, rho, c, div_v);
    critical_dt(w, xi)
}

/// The mean gradient b = B / V (`bv` is B = V b, `iv` = 1/V) and the sum of its squares.
#[inline(always)]
fn mean_gradient(bv: &[[f64; 3]; 8], iv: f64) -> ([[f64; 3]; 8], f64) {
    let mut b = [[0.0; 3]; 8];
    let mut bb = 0.0;
    for i in 0..8 {
        for j in 0..3 {
            b[i][j] = bv[i][j] * iv;
            bb += b[i][j] * b[i][j];
        }
    }
    (b, bb)
}

/// The velocity gradient L = (sum_I v_I (x) V bh_I) / V(n+1/2) (`bvh` the mid-step V bh,
/// `ivh` = 1/V(n+1/2)): the division by the volume once per entry.
#[inline(always)]
fn velocity_gradient(v: &[[f64; 3]; 8], bvh: &[[f64; 3]; 8], ivh: f64) -> [[f64; 3]; 3] {
    let mut l = [[0.0; 3]; 3];
    for i in 0..8 {
        for a in 0..3 {
            for j in 0..3 {
                l[a][j] += v[i][a] * bvh[i][j];
            }
        }
    }
    for row in l.iter_mut() {
        for lj in row.iter_mut() {
            *lj *= ivh;
        }
    }
    l
}

/// The stress `s` (Voigt xx,yy,zz,xy,yz,zx) rotated by the step's Hughes-Winget increment of
/// the spin W = skew(L): R s R^T.
#[inline(always)]
pub(crate) fn rotated_stress(l: &[[f64; 3]; 3], dt: f64, s: &[f64; 6]) -> [f64; 6] {
    // Spin W = skew(L): w[0] = W_yz... store as the full antisymmetric matrix.
    let w01 = 0.5 * (l[0][1] - l[1][0]);
    let w12 = 0.5 * (l[1][2] - l[2][1]);
    let w20 = 0.5 * (l[2][0] - l[0][2]);
    // Hughes-Winget: R = (I - dt/2 W)^-1 (I + dt/2 W), incrementally objective.
    let h = 0.5 * dt;
    let a = [
        [1.0, -h * w01, h * w20],
        [h * w01, 1.0, -h * w12],
        [-h * w20, h * w12, 1.0],
    ];
    let p = [
        [1.0, h * w01, -h * w20],
        [-h * w01, 1.0, h * w12],
        [h * w20, -h * w12, 1.0],
    ];
    let ai = inverse3(&a).unwrap_or([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    let r: [[f64; 3]; 3] =
        std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| ai[i][k] * p[k][j]).sum()));
    // sigma <- R sigma R^T
    let sm = [[s[0], s[3], s[5]], [s[3], s[1], s[4]], [s[5], s[4], s[2]]];
    let mut rs = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            rs[i][j] = (0..3).map(|k| r[i][k] * sm[k][j]).sum();
        }
    }
    let rot = |i: usize, j: usize| -> f64 { (0..3).map(|k| rs[i][k] * r[j][k]).sum() };
    [
        rot(0, 0),
        rot(1, 1),
        rot(2, 2),
        rot(0, 1),
        rot(1, 2),
        rot(2, 0),
    ]
}

/// The nodal forces -V sigma b of the stress plus the bulk viscosity `q` on its normal
/// components (`bv` = V b).
#[inline(always)]
fn stress_forces(bv: &[[f64; 3]; 8], stress: &[f64; 6], q: f64) -> [[f64; 3]; 8] {
    let st_tot = [
        stress[0] + q,
        stress[1] + q,
        stress[2] + q,
        stress[3],
        stress[4],
        stress[5],
    ];
    let mut force = [[0.0; 3]; 8];
    for i in 0..8 {
        let bi = &bv[i]; // V * b
        force[i] = [
            -(st_tot[0] * bi[0] + st_tot[3] * bi[1] + st_tot[5] * bi[2]),
            -(st_tot[3] * bi[0] + st_tot[1] * bi[1] + st_tot[4] * bi[2]),
            -(st_tot[5] * bi[0] + st_tot[4] * bi[1] + st_tot[2] * bi[2]),
        ];
    }
    force
}

/// One explicit update of one element.
///
/// `x`: nodal coordinates at t(n+1); `v`: nodal velocities at t(n+1/2); `dt`: the step just taken;
/// `rho0`, `vol0`: reference density and volume. Rotates the stress with the
/// Hughes-Winget increment, calls the material with D dt, adds bulk viscosity for the force only.
///
/// Cost: about 2 x 450 flops for the gradients (mid-step and end), 150 for L/D/W and the rotation, 200 for the
/// hourglass part, 100 for the forces, plus the material; 48 doubles gathered, 24 scattered.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn update(
    x: &[[f64; 3]; 8],
    v: &[[f64; 3]; 8],
    dt: f64,
    rho0: f64,
    vol0: f64,
    mat: &dyn Material,
    ctl: &HexControls,
    st: &mut HexState,
    mat_state: &mut [f64],
) -> Result<HexOutput, ElementError> {
    let (bv, vol) = volume_gradient(x);
    if !(vol > 0.0) || !vol.is_finite() {
        return Err(ElementError::Inverted { volume: vol });
    }
    // The velocity gradient L_ij = sum_I v_iI bh_Ij at the mid-step geometry
    // x(n+1/2) = x(n+1) - dt/2 v(n+1/2), where v(n+1/2) is the exact rate (PRONTO-3D): a rigid
    // rotation then gives a skew L and no strain.
    let xh: [[f64; 3]; 8] =
        std::array::from_fn(|i| std::array::from_fn(|a| x[i][a] - 0.5 * dt * v[i][a]));
    let (bvh, volh) = volume_gradient(&xh);
    if !(volh > 0.0) || !volh.is_finite() {
        return Err(ElementError::Inverted { volume: volh });
    }
    // 1/V and 1/V(n+1/2) from one division.
    let inv = 1.0 / (vol * volh);
    let (iv, ivh) = (volh * inv, vol * inv);
    // Mean gradient b = B / V at t(n+1) (forces, hourglass, stable step).
    let (b, bb) = mean_gradient(&bv, iv);
    let l = velocity_gradient(v, &bvh, ivh);
    let d = [
        l[0][0],
        l[1][1],
        l[2][2],
        0.5 * (l[0][1] + l[1][0]),
        0.5 * (l[1][2] + l[2][1]),
        0.5 * (l[2][0] + l[0][2]),
    ];
    let mut stress = rotated_stress(&l, dt, &st.stress);
    let deps: [f64; 6] = std::array::from_fn(|k| d[k] * dt);
    // rho = m / V with the exact volume (a fluid's EOS reads it).
    let rho = rho0 * vol0 * iv;
    let rotated = stress;
    mat.update_stress(&mut stress, mat_state, &deps, dt, rho);
    st.stress = stress;

    // Bulk viscosity, added to the normal stresses for the force only; c from the material's
    // current rho c^2 (constant for a solid, the EOS's for a fluid).
    let modulus = mat.wave_modulus(rho, mat_state);
    let c = (modulus / rho).sqrt();
    let ev = d[0] + d[1] + d[2];
    let w = Wave::new(bb, c);
    let (q, xi) = bulk_viscosity(ctl, w, rho, c, ev);
    let dt_stable = critical_dt(w, xi);
    // Its work heats the material (q eps_v >= 0, J/m^3/s): a fluid's EOS keeps it.
    if q != 0.0 {
        mat.add_heat(mat_state, q * ev * dt / rho, rho);
    }

    let mut force = stress_forces(&bv, &stress, q);

    // Hourglass control with the material's current tangent (see `crate::hourglass`).
    let mu = mat.shear_modulus();
    let dsig: [f64; 6] = std::array::from_fn(|k| stress[k] - rotated[k]);
    let hg_mat = HourglassMaterial {
        mu,
        nu: hourglass::poisson_ratio(mat.dilatational_modulus(), mu),
        rho,
        c,
        tangent_ratio: hourglass::tangent_ratio(&dsig, &deps, mu),
        yield_stress: mat.yield_stress(mat_state),
        stress,
    };
    let step = HourglassStep {
        x,
        v,
        b: &b,
        bb,
        vol,
        dt,
    };
    let hg_work = ctl.hourglass.apply(&step, &hg_mat, &mut st.hg, &mut force);
    Ok(HexOutput {
        force,
        hg_work,
        volume: vol,
        dt_stable,
        pressure: -(stress[0] + stress[1] + stress[2]) * crate::hourglass::THIRD,
    })
}
