//! The hexahedron in mode space, in lanes: a nodal field y_I (I = 0..7) written as the
//! trilinear expansion y(xi, eta, zeta) = sum_k phi_k(xi, eta, zeta) Y_k / 8 over the eight
//! products phi = 1, xi, eta, zeta, eta zeta, zeta xi, xi eta, xi eta zeta, whose nodal values
//! phi_k(I) are +-1 and orthogonal (sum_I phi_j(I) phi_k(I) = 8 delta_jk). The mode sums
//! Y_k = sum_I phi_k(I) y_I are a Walsh-Hadamard transform: three stages of butterflies, 23
//! additions per component instead of the 56 of the plain sums.
//!
//! Why: the element's volume, its gradient, the velocity gradient, the hourglass rates and the
//! nodal forces are all short in mode space (Flanagan and Belytschko 1981, section 3, wrote the
//! mean gradient in the same base vectors), so the batched kernel computes them there and
//! returns to the nodes once, for the forces:
//!
//! - with a_k = X_k / 8 the coordinates' modes, the Jacobian at the centre is (a_xi, a_eta,
//!   a_zeta), and the exact volume (the integral of det J over the cube: det J is of degree at
//!   most 2 in each coordinate, so only the even monomials survive, mean of xi^2 = 1/3) is
//!   V = 8 [det(a_xi, a_eta, a_zeta) + (det(a_xi, a_xieta, a_zetaxi) +
//!   det(a_zetaxi, a_etazeta, a_zeta) + det(a_xieta, a_eta, a_etazeta)) / 3];
//!   no term holds a_1 or a_xietazeta;
//! - its gradient G_k = dV/dX_k is one or two cross products ([`volume_gradient`]), the mean
//!   gradient B_I = dV/dx_I = sum_k phi_k(I) G_k, and V = sum_k X_k . G_k / 3 (V is
//!   homogeneous of degree 3: Euler);
//! - sum_I y_I (x) B_I = sum_k Y_k (x) G_k (6 terms, not 8), sum_I |B_I|^2 = 8 sum_k |G_k|^2;
//! - a nodal force f_I = sum_k phi_k(I) F_k is the same transform run backwards ([`nodal`]).
//!
//! Checked against the node-by-node forms of `crate::hex` (the scalar kernel, whose volume
//! `tests/element.rs` holds to the 2x2x2 Gauss integral of det J and whose forces pass the patch
//! test there) in `tests/lanes.rs`: volumes, forces and hourglass work agree to 1e-15 relative.
use super::F;

type V3 = [F; 3];

/// The mode sums Y_k = sum_I phi_k(I) y_I of the nodal vectors `y` for k = xi, eta, zeta,
/// eta zeta, zeta xi, xi eta (the first array) and xi eta zeta (the second); the constant mode
/// is not formed. 69 additions per element.
///
/// The nodes are `crate::hex::NODE_XI`'s: pairs along xi (0, 1), (3, 2), (4, 5), (7, 6), pairs
/// of those along eta, then along zeta.
#[inline(always)]
pub fn modes(y: &[V3; 8]) -> ([V3; 6], V3) {
    let mut m = [[F::ZERO; 3]; 6];
    let mut m7 = [F::ZERO; 3];
    for c in 0..3 {
        // Along xi: sums and differences at the four (eta, zeta) corners --, +-, -+, ++.
        let (s0, d0) = (y[1][c] + y[0][c], y[1][c] - y[0][c]);
        let (s1, d1) = (y[2][c] + y[3][c], y[2][c] - y[3][c]);
        let (s2, d2) = (y[5][c] + y[4][c], y[5][c] - y[4][c]);
        let (s3, d3) = (y[6][c] + y[7][c], y[6][c] - y[7][c]);
        // Along eta, at zeta - and +.
        let (ss_m, sd_m, ss_p, sd_p) = (s1 + s0, s1 - s0, s3 + s2, s3 - s2);
        let (ds_m, dd_m, ds_p, dd_p) = (d1 + d0, d1 - d0, d3 + d2, d3 - d2);
        // Along zeta.
        m[0][c] = ds_p + ds_m; // xi
        m[1][c] = sd_p + sd_m; // eta
        m[2][c] = ss_p - ss_m; // zeta
        m[3][c] = sd_p - sd_m; // eta zeta
        m[4][c] = ds_p - ds_m; // zeta xi
        m[5][c] = dd_p + dd_m; // xi eta
        m7[c] = dd_p - dd_m; // xi eta zeta
    }
    (m, m7)
}

/// The nodal vectors f_I = sum_k phi_k(I) F_k of mode vectors `f` (k as in [`modes`]: xi ..
/// xi eta, then xi eta zeta in `f7`) with no constant mode: [`modes`] run backwards.
/// 69 additions per element.
#[inline(always)]
pub fn nodal(f: &[V3; 6], f7: &V3) -> [V3; 8] {
    let mut y = [[F::ZERO; 3]; 8];
    for c in 0..3 {
        let z = f[2][c];
        // Along zeta (the constant mode is zero: ss_p = zeta, ss_m = -zeta).
        let (sd_p, sd_m) = (f[1][c] + f[3][c], f[1][c] - f[3][c]);
        let (ds_p, ds_m) = (f[0][c] + f[4][c], f[0][c] - f[4][c]);
        let (dd_p, dd_m) = (f[5][c] + f7[c], f[5][c] - f7[c]);
        // Along eta: s0 = -zeta - sd_m, s1 = sd_m - zeta, s2 = zeta - sd_p, s3 = zeta + sd_p.
        let s0 = -(z + sd_m);
        let s1 = sd_m - z;
        let (s2, s3) = (z - sd_p, z + sd_p);
        let (d0, d1) = (ds_m - dd_m, ds_m + dd_m);
        let (d2, d3) = (ds_p - dd_p, ds_p + dd_p);
        // Along xi.
        (y[0][c], y[1][c]) = (s0 - d0, s0 + d0);
        (y[3][c], y[2][c]) = (s1 - d1, s1 + d1);
        (y[4][c], y[5][c]) = (s2 - d2, s2 + d2);
        (y[7][c], y[6][c]) = (s3 - d3, s3 + d3);
    }
    y
}

/// p x q + r x s, each component as two multiply-adds on a product.
#[inline(always)]
fn cross2(p: &V3, q: &V3, r: &V3, s: &V3) -> V3 {
    let comp = |i: usize, j: usize| {
        let t = r[i].mul_sub(s[j], r[j] * s[i]);
        p[j].neg_mul_add(q[i], p[i].mul_add(q[j], t))
    };
    [comp(1, 2), comp(2, 0), comp(0, 1)]
}

/// 64 times the volume gradient G_k = dV/dX_k (k = xi .. xi eta), and the volume V, of the
/// element whose coordinates have the modes `x` = X = 8 a (see the module comment; the xi eta
/// zeta mode does not enter): the module's forms on a, each product of two modes 64 times as
/// large, exactly (powers of two). 9 + 6 x 12 + 19 = 100 operations per element.
#[inline(always)]
pub fn volume_gradient(a: &[V3; 6]) -> ([V3; 6], F) {
    // (`a` here is X = 8 a: the forms below are those on a, scaled.)
    let third = F::splat(crate::hourglass::THIRD);
    let t = |m: usize| [a[m][0] * third, a[m][1] * third, a[m][2] * third];
    let (t3, t4, t5) = (t(3), t(4), t(5));
    let g = [
        cross2(&a[1], &a[2], &t5, &a[4]),
        cross2(&a[2], &a[0], &t3, &a[5]),
        cross2(&a[0], &a[1], &t4, &a[3]),
        cross2(&a[2], &t4, &t5, &a[1]),
        cross2(&a[0], &t5, &t3, &a[2]),
        cross2(&t4, &a[0], &a[1], &t3),
    ];
    // V = sum_k X_k . G_k / 3 = (8 / 3) sum_k a_k . G_k = (8 / 3) / 512 sum_k X_k . 64 G_k.
    let mut s = a[0][0] * g[0][0];
    for m in 0..6 {
        for c in 0..3 {
            if m + c > 0 {
                s = a[m][c].mul_add(g[m][c], s);
            }
        }
    }
    (g, s * (8.0 * crate::hourglass::THIRD / 512.0))
}
