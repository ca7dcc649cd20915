#![allow(clippy::needless_range_loop)]
//! The nodal-averaged tetrahedron (fe_petsc/src/tet.rs) against analytic answers: gradients,
//! the patch test, rigid rotation, the averaged volumetric rate, the bulk viscosity, the stable
//! step against the element's exact highest frequency, and a Kuhn-split mesh in a homogeneous
//! field with the two passes and the nodal sums done here.
use fe_petsc::hex::{ElementError, HexControls};
use fe_petsc::material::{build_material, Material, MaterialSpec};
use fe_petsc::tet::{self, TetAverages, TetState};

const E: f64 = 200e9;
const NU: f64 = 0.3;
const RHO: f64 = 7850.0;

/// A small deterministic generator (LCG, Knuth's constants): uniform in [-0.5, 0.5).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
    }
}

fn elastic(e: f64, nu: f64) -> Box<dyn Material> {
    build_material(&MaterialSpec {
        name: "m".into(),
        model: "elastic".into(),
        density: RHO,
        params: [("youngs_modulus", e), ("poisson_ratio", nu)]
            .iter()
            .map(|(k, v)| (k.to_string(), *v))
            .collect(),
        eos: None,
    })
    .unwrap()
}

/// Lame constants from E and nu (independent of the crate's).
fn lame(e: f64, nu: f64) -> (f64, f64) {
    (
        e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
        e / (2.0 * (1.0 + nu)),
    )
}

fn no_viscosity() -> HexControls {
    HexControls {
        bv_linear: 0.0,
        bv_quadratic: 0.0,
        ..HexControls::default()
    }
}

/// The triple product det[x1-x0, x2-x0, x3-x0] / 6.
fn triple(x: &[[f64; 3]; 4]) -> f64 {
    let e: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|k| x[i + 1][k] - x[0][k]));
    (e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1])
        - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0])
        + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]))
        / 6.0
}

/// grad N_a computed independently of the crate: J = dx/dxi = [e1 e2 e3] (columns) inverted
/// by Gauss-Jordan elimination with partial pivoting; grad N_i = row i of J^-1 (i = 1..3),
/// grad N_0 = -sum.
fn ref_gradients(x: &[[f64; 3]; 4]) -> [[f64; 3]; 4] {
    let mut m = [[0.0; 6]; 3];
    for r in 0..3 {
        for c in 0..3 {
            m[r][c] = x[c + 1][r] - x[0][r];
        }
        m[r][3 + r] = 1.0;
    }
    for c in 0..3 {
        let p = (c..3)
            .max_by(|&a, &b| m[a][c].abs().total_cmp(&m[b][c].abs()))
            .unwrap();
        m.swap(c, p);
        let piv = m[c][c];
        for k in 0..6 {
            m[c][k] /= piv;
        }
        for r in 0..3 {
            if r != c {
                let f = m[r][c];
                for k in 0..6 {
                    m[r][k] -= f * m[c][k];
                }
            }
        }
    }
    let mut g = [[0.0; 3]; 4];
    for i in 0..3 {
        for k in 0..3 {
            g[i + 1][k] = m[i][3 + k];
            g[0][k] -= g[i + 1][k];
        }
    }
    g
}

/// Test tetrahedra: the reference one, a regular one, randomly distorted ones, a flat one, a
/// needle and a cap (one node near the opposite face's centre), all positively oriented.
fn shapes() -> Vec<(&'static str, [[f64; 3]; 4])> {
    let s3 = 3f64.sqrt();
    let mut v = vec![
        (
            "reference",
            [
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
        ),
        (
            "regular",
            [
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.5, s3 / 2.0, 0.0],
                [0.5, s3 / 6.0, (2.0f64 / 3.0).sqrt()],
            ],
        ),
        (
            "flat 10:1",
            [
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.3, 0.3, 0.1],
            ],
        ),
        (
            "needle",
            [
                [0.0, 0.0, 0.0],
                [0.2, 0.0, 0.0],
                [0.0, 0.2, 0.0],
                [0.05, 0.05, 3.0],
            ],
        ),
        (
            "cap",
            [
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.5, 0.8, 0.0],
                [0.5, 0.3, 0.05],
            ],
        ),
    ];
    let mut rng = Lcg(11);
    let mut n = 0;
    while n < 5 {
        let base = v[1].1;
        let x: [[f64; 3]; 4] = std::array::from_fn(|a| {
            std::array::from_fn(|k| 2.0 * base[a][k] + 0.8 * rng.next() + 0.3)
        });
        if triple(&x) > 0.05 {
            v.push(("distorted", x));
            n += 1;
        }
    }
    v
}

fn sym(a: &[[f64; 3]; 3]) -> [f64; 6] {
    [
        a[0][0],
        a[1][1],
        a[2][2],
        0.5 * (a[0][1] + a[1][0]),
        0.5 * (a[1][2] + a[2][1]),
        0.5 * (a[2][0] + a[0][2]),
    ]
}

fn norm6(s: &[f64; 6]) -> f64 {
    (s[0] * s[0] + s[1] * s[1] + s[2] * s[2] + 2.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]))
        .sqrt()
}

/// The end-of-step positions and velocities of the field v = v0 + A x given at the mid-step
/// positions `xh` (so that the element's L, taken there, is A exactly): x = xh + dt/2 v.
fn linear_field(
    xh: &[[f64; 3]; 4],
    v0: [f64; 3],
    a: &[[f64; 3]; 3],
    dt: f64,
) -> ([[f64; 3]; 4], [[f64; 3]; 4]) {
    let v: [[f64; 3]; 4] = std::array::from_fn(|n| {
        std::array::from_fn(|i| v0[i] + (0..3).map(|j| a[i][j] * xh[n][j]).sum::<f64>())
    });
    let x = std::array::from_fn(|n| std::array::from_fn(|i| xh[n][i] + 0.5 * dt * v[n][i]));
    (x, v)
}

/// -V sigma g_a for a Voigt stress.
fn expected_forces(vol: f64, s: &[f64; 6], g: &[[f64; 3]; 4]) -> [[f64; 3]; 4] {
    let m = [[s[0], s[3], s[5]], [s[3], s[1], s[4]], [s[5], s[4], s[2]]];
    std::array::from_fn(|a| {
        std::array::from_fn(|i| -vol * (0..3).map(|j| m[i][j] * g[a][j]).sum::<f64>())
    })
}

#[test]
fn gradients_reproduce_linear_fields() {
    for (name, x) in shapes() {
        let (g, vol) = tet::gradients(&x);
        let v3 = triple(&x);
        // The volume is the triple product / 6 (1e-14 relative: the same few roundings).
        assert!(
            (vol - v3).abs() <= 1e-14 * v3.abs(),
            "{name}: volume {vol} vs triple product {v3}"
        );
        let scale = x.iter().flatten().fold(0.0f64, |m, c| m.max(c.abs()));
        let gs = g.iter().flatten().fold(0.0f64, |m, c| m.max(c.abs()));
        for k in 0..3 {
            // sum_a grad N_a = 0 (partition of unity), 1e-13 relative to max |grad N|.
            let s: f64 = (0..4).map(|a| g[a][k]).sum();
            assert!(s.abs() <= 1e-13 * gs, "{name}: sum_a dN_a/dx_{k} = {s}");
            for i in 0..3 {
                // sum_a x_a (x) grad N_a = I: linear fields exact (1e-13; x and g are O(1) and
                // O(1/h), their products O(scale/h)).
                let s: f64 = (0..4).map(|a| x[a][i] * g[a][k]).sum();
                let e = if i == k { 1.0 } else { 0.0 };
                let tol = 1e-13 * (scale * gs).max(1.0);
                assert!(
                    (s - e).abs() <= tol,
                    "{name}: sum_a x_a{i} g_a{k} = {s} (tol {tol:e})"
                );
            }
        }
        // Against the independent inversion of the Jacobian (1e-13 relative to max |grad N|).
        let gr = ref_gradients(&x);
        for a in 0..4 {
            for k in 0..3 {
                assert!(
                    (g[a][k] - gr[a][k]).abs() <= 1e-13 * gs,
                    "{name}: grad N_{a}"
                );
            }
        }
        // Swapping two nodes turns the signed volume negative.
        let mut y = x;
        y.swap(1, 2);
        assert!(
            (tet::gradients(&y).1 + vol).abs() <= 1e-14 * vol,
            "{name}: swapped volume"
        );
    }
    assert_eq!(tet::lumped_mass_share(RHO, 2.0), RHO * 0.5);
}

#[test]
fn rates_and_inversion() {
    let a = [[0.3, -0.7, 0.2], [0.5, 0.1, -0.4], [-0.6, 0.9, 0.25]];
    let dt = 1e-3;
    for (name, xh) in shapes() {
        let (x, v) = linear_field(&xh, [0.1, -0.2, 0.3], &a, dt);
        let r = tet::rates(&x, &v, dt).unwrap();
        // vol and vol_mid are the triple products at x and at x - dt/2 v = xh; vol_rate
        // = vol_mid tr(A) for the linear field (1e-12 relative).
        assert!((r.vol - triple(&x)).abs() <= 1e-12 * r.vol, "{name}: vol");
        assert!(
            (r.vol_mid - triple(&xh)).abs() <= 1e-12 * r.vol_mid,
            "{name}: vol_mid"
        );
        let tr = a[0][0] + a[1][1] + a[2][2];
        assert!(
            (r.vol_rate - r.vol_mid * tr).abs() <= 1e-12 * r.vol_mid * tr.abs(),
            "{name}: vol_rate {} vs vol_mid tr A {}",
            r.vol_rate,
            r.vol_mid * tr
        );
        let mut y = x;
        y.swap(2, 3);
        let vy = {
            let mut w = v;
            w.swap(2, 3);
            w
        };
        match tet::rates(&y, &vy, dt) {
            Err(ElementError::Inverted { volume }) => assert!(volume < 0.0, "{name}"),
            other => panic!("{name}: an inverted element gave {other:?}"),
        }
        let mat = elastic(E, NU);
        let avg = TetAverages { theta: 0.0, j: 1.0 };
        let res = tet::update(
            &y,
            &vy,
            dt,
            RHO,
            1.0,
            avg,
            &*mat,
            &no_viscosity(),
            &mut TetState::default(),
            &mut [],
        );
        assert!(
            matches!(res, Err(ElementError::Inverted { .. })),
            "{name}: update of an inverted element"
        );
    }
}

#[test]
fn patch_test_linear_velocity() {
    let a = [[0.3, -0.7, 0.2], [0.5, 0.1, -0.4], [-0.6, 0.9, 0.25]];
    let dt = 1e-4;
    let mat = elastic(E, NU);
    let (lambda, mu) = lame(E, NU);
    // Hooke's law of eps = sym(A) dt, derived here: lambda tr(eps) I + 2 mu eps.
    let eps = sym(&a).map(|d| d * dt);
    let tr = eps[0] + eps[1] + eps[2];
    let expect: [f64; 6] =
        std::array::from_fn(|k| if k < 3 { lambda * tr } else { 0.0 } + 2.0 * mu * eps[k]);
    for (name, xh) in shapes() {
        let (x, v) = linear_field(&xh, [0.1, -0.2, 0.3], &a, dt);
        let vol = triple(&x);
        let vol0 = triple(&xh) * 0.98;
        let avg = TetAverages {
            theta: a[0][0] + a[1][1] + a[2][2],
            j: vol / vol0,
        };
        let mut st = TetState::default();
        let out = tet::update(
            &x,
            &v,
            dt,
            RHO,
            vol0,
            avg,
            &*mat,
            &no_viscosity(),
            &mut st,
            &mut [],
        )
        .unwrap();
        // Stress = Hooke's increment, 1e-12 relative to its norm.
        let err = norm6(&std::array::from_fn(|k| st.stress[k] - expect[k]));
        assert!(
            err <= 1e-12 * norm6(&expect),
            "{name}: stress {:?} vs {expect:?}",
            st.stress
        );
        assert!((out.volume - vol).abs() <= 1e-14 * vol, "{name}: volume");
        let p = -(expect[0] + expect[1] + expect[2]) / 3.0;
        assert!(
            (out.pressure - p).abs() <= 1e-12 * norm6(&expect),
            "{name}: pressure"
        );
        // Forces = -V sigma grad N_a at t(n+1) (independent gradients) and sum to zero, both
        // 1e-12 relative to the largest nodal force.
        let fe = expected_forces(vol, &expect, &ref_gradients(&x));
        let fmax = fe.iter().flatten().fold(0.0f64, |m, c| m.max(c.abs()));
        for k in 0..3 {
            let s: f64 = (0..4).map(|n| out.force[n][k]).sum();
            assert!(s.abs() <= 1e-12 * fmax, "{name}: force sum {s} vs {fmax}");
            for n in 0..4 {
                assert!(
                    (out.force[n][k] - fe[n][k]).abs() <= 1e-12 * fmax,
                    "{name}: force {n},{k}"
                );
            }
        }
    }
}

/// The Hughes-Winget rotation (I - dt/2 W)^-1 (I + dt/2 W) applied to `s`, derived here: for
/// the skew W with axial vector w, (I - h W)^-1 = (I + h W + h^2 w w^T) / (1 + h^2 |w|^2).
fn hughes_winget(w: [f64; 3], dt: f64, s: &[f64; 6]) -> [f64; 6] {
    let h = 0.5 * dt;
    let wm = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]];
    let ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    let id = |i: usize, j: usize| if i == j { 1.0 } else { 0.0 };
    let inv: [[f64; 3]; 3] = std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            (id(i, j) + h * wm[i][j] + h * h * w[i] * w[j]) / (1.0 + h * h * ww)
        })
    });
    let r: [[f64; 3]; 3] = std::array::from_fn(|i| {
        std::array::from_fn(|j| (0..3).map(|k| inv[i][k] * (id(k, j) + h * wm[k][j])).sum())
    });
    let m = [[s[0], s[3], s[5]], [s[3], s[1], s[4]], [s[5], s[4], s[2]]];
    let rot = |i: usize, j: usize| -> f64 {
        (0..3)
            .map(|k| (0..3).map(|l| r[i][k] * m[k][l] * r[j][l]).sum::<f64>())
            .sum()
    };
    [
        rot(0, 0),
        rot(1, 1),
        rot(2, 2),
        rot(0, 1),
        rot(1, 2),
        rot(2, 0),
    ]
}

#[test]
fn rigid_rotation_no_strain() {
    let w: [f64; 3] = [0.3, -0.5, 0.8];
    let wn = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    // v = w x x: A = [w]_x.
    let a = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]];
    let dt = 1e-3;
    let mat = elastic(E, NU);
    let s0 = [1e8, -2e8, 5e7, 3e7, -4e7, 6e7];
    for (name, xh) in shapes() {
        let (x, v) = linear_field(&xh, [0.0; 3], &a, dt);
        let vol = triple(&x);
        let avg = TetAverages { theta: 0.0, j: 1.0 };
        // From zero stress: no strain, the stress stays zero within 1e-12 E dt |w|.
        let mut st = TetState::default();
        tet::update(
            &x,
            &v,
            dt,
            RHO,
            vol,
            avg,
            &*mat,
            &HexControls::default(),
            &mut st,
            &mut [],
        )
        .unwrap();
        assert!(
            norm6(&st.stress) <= 1e-12 * E * dt * wn,
            "{name}: stress {:?}",
            st.stress
        );
        // From a prestress: the stress turns with the Hughes-Winget rotation of W and keeps its
        // norm (1e-12 relative).
        let mut st = TetState { stress: s0 };
        tet::update(
            &x,
            &v,
            dt,
            RHO,
            vol,
            avg,
            &*mat,
            &HexControls::default(),
            &mut st,
            &mut [],
        )
        .unwrap();
        let e = hughes_winget(w, dt, &s0);
        let err = norm6(&std::array::from_fn(|k| st.stress[k] - e[k]));
        assert!(
            err <= 1e-12 * norm6(&s0),
            "{name}: rotated {:?} vs {e:?}",
            st.stress
        );
        assert!(
            (norm6(&st.stress) - norm6(&s0)).abs() <= 1e-12 * norm6(&s0),
            "{name}: norm"
        );
    }
}

#[test]
fn averaged_volumetric_rate() {
    let a = [[0.3, -0.7, 0.2], [0.5, 0.1, -0.4], [-0.6, 0.9, 0.25]];
    let dt = 1e-4;
    let mat = elastic(E, NU);
    let (lambda, mu) = lame(E, NU);
    let k_bulk = lambda + 2.0 * mu / 3.0;
    let d = sym(&a);
    let trd = d[0] + d[1] + d[2];
    let dev: [f64; 6] = std::array::from_fn(|k| d[k] - if k < 3 { trd / 3.0 } else { 0.0 });
    for theta in [0.0, 2.0 * trd, -0.7] {
        for (name, xh) in shapes() {
            let (x, v) = linear_field(&xh, [0.0; 3], &a, dt);
            let vol = triple(&x);
            let avg = TetAverages { theta, j: 1.0 };
            let mut st = TetState::default();
            let out = tet::update(
                &x,
                &v,
                dt,
                RHO,
                vol,
                avg,
                &*mat,
                &no_viscosity(),
                &mut st,
                &mut [],
            )
            .unwrap();
            let scale = E * dt * norm6(&d);
            // The pressure follows theta, not tr D: p = -K theta dt (1e-12 relative to E dt |D|).
            assert!(
                (out.pressure + k_bulk * theta * dt).abs() <= 1e-12 * scale,
                "{name}, theta {theta}: p {} vs {}",
                out.pressure,
                -k_bulk * theta * dt
            );
            // The deviator follows dev D: 2 mu dev(D) dt (1e-12 relative).
            let p = -(st.stress[0] + st.stress[1] + st.stress[2]) / 3.0;
            for k in 0..6 {
                let s = st.stress[k] + if k < 3 { p } else { 0.0 };
                assert!(
                    (s - 2.0 * mu * dev[k] * dt).abs() <= 1e-12 * scale,
                    "{name}, theta {theta}: dev {k}"
                );
            }
        }
    }
}

#[test]
fn bulk_viscosity_pressure_and_damping() {
    let a = [[0.3, -0.7, 0.2], [0.5, 0.1, -0.4], [-0.6, 0.9, 0.25]];
    let dt = 1e-4;
    let mat = elastic(E, NU);
    let ctl = HexControls::default();
    let (lambda, mu) = lame(E, NU);
    for theta in [-150.0, 80.0] {
        for (name, xh) in shapes() {
            let (x, v) = linear_field(&xh, [0.0; 3], &a, dt);
            let vol = triple(&x);
            let j = 0.97;
            let avg = TetAverages { theta, j };
            let mut s1 = TetState::default();
            let with =
                tet::update(&x, &v, dt, RHO, vol / j, avg, &*mat, &ctl, &mut s1, &mut []).unwrap();
            let mut s2 = TetState::default();
            let without = tet::update(
                &x,
                &v,
                dt,
                RHO,
                vol / j,
                avg,
                &*mat,
                &no_viscosity(),
                &mut s2,
                &mut [],
            )
            .unwrap();
            // q = rho l theta (b1 c + b2^2 l max(0, -theta)), rho = rho0 / j,
            // l = 2 / sqrt(sum |g|^2),
            // c = sqrt((lambda + 2 mu) / rho); the force difference is -V q g_a (1e-12 relative to
            // the largest force).
            let g = ref_gradients(&x);
            let gg: f64 = g.iter().flatten().map(|c| c * c).sum();
            let rho = RHO / j;
            let len = 2.0 / gg.sqrt();
            let c = ((lambda + 2.0 * mu) / rho).sqrt();
            let q = rho
                * len
                * theta
                * (ctl.bv_linear * c + ctl.bv_quadratic.powi(2) * len * (-theta).max(0.0));
            let fq = expected_forces(vol, &[q, q, q, 0.0, 0.0, 0.0], &g);
            // The difference of two forces: its rounding is relative to the larger of them.
            let fmax = [with.force, without.force, fq]
                .iter()
                .flatten()
                .flatten()
                .fold(0.0f64, |m, c| m.max(c.abs()));
            for n in 0..4 {
                for k in 0..3 {
                    let df = with.force[n][k] - without.force[n][k];
                    assert!(
                        (df - fq[n][k]).abs() <= 1e-12 * fmax,
                        "{name}, theta {theta}: q force {n},{k}"
                    );
                }
            }
            // The stress and pressure carry no q; the damping shortens the step.
            assert_eq!(s1.stress, s2.stress, "{name}: stress without q");
            assert!(
                with.dt_stable < without.dt_stable,
                "{name}: damping shortens the step"
            );
        }
    }
}

/// Eigenvalues of a symmetric matrix by cyclic Jacobi rotations (Golub & Van Loan 8.5):
/// rotate each off-diagonal (p, q) to zero with t = sgn(z) / (|z| + sqrt(1 + z^2)),
/// z = (a_qq - a_pp) / (2 a_pq), until the off-diagonal norm is 1e-15 of the whole.
fn jacobi_eigenvalues(mut a: Vec<Vec<f64>>) -> Vec<f64> {
    let n = a.len();
    let total: f64 = a.iter().flatten().map(|v| v * v).sum::<f64>().sqrt();
    for _ in 0..100 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i][j] * a[i][j])
            .sum::<f64>()
            .sqrt();
        if off <= 1e-15 * total {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                if a[p][q] == 0.0 {
                    continue;
                }
                let z = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = z.signum() / (z.abs() + (1.0 + z * z).sqrt());
                let c = 1.0 / (1.0 + t * t).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (akp, akq) = (a[k][p], a[k][q]);
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p][k], a[q][k]);
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
            }
        }
    }
    (0..n).map(|i| a[i][i]).collect()
}

/// The element stiffness K = V B^T C B (12x12, dof 3a+i) of isotropic elasticity, derived from
/// u.K u = V (lambda (sum_a u_a.g_a)^2 + 2 mu |sym(sum_a u_a (x) g_a)|^2) with
/// 2 |sym A|^2 = A:A + A:A^T: K_ai,bj = V (lambda g_ai g_bj + mu (delta_ij g_a.g_b + g_aj g_bi)).
fn stiffness(g: &[[f64; 3]; 4], vol: f64, lambda: f64, mu: f64) -> Vec<Vec<f64>> {
    let mut k = vec![vec![0.0; 12]; 12];
    for a in 0..4 {
        for b in 0..4 {
            let gab: f64 = (0..3).map(|i| g[a][i] * g[b][i]).sum();
            for i in 0..3 {
                for j in 0..3 {
                    let dij = if i == j { 1.0 } else { 0.0 };
                    k[3 * a + i][3 * b + j] =
                        vol * (lambda * g[a][i] * g[b][j] + mu * (dij * gab + g[a][j] * g[b][i]));
                }
            }
        }
    }
    k
}

#[test]
fn stable_step_bounds_exact_frequency() {
    let mut worst: f64 = 1.0;
    let mut best: f64 = 0.0;
    for nu in [0.3, 0.45, 0.499, 0.0, -0.5] {
        let mat = elastic(E, nu);
        let (lambda, mu) = lame(E, nu);
        for (name, x) in shapes() {
            let (g, vol) = tet::gradients(&x);
            // Exact: omega^2 = lambda_max(K) / m, m = rho0 V / 4 on every node.
            let kmat = stiffness(&g, vol, lambda, mu);
            let lmax = jacobi_eigenvalues(kmat)
                .into_iter()
                .fold(f64::NEG_INFINITY, f64::max);
            let omega = (lmax / (RHO * vol / 4.0)).sqrt();
            let dt_exact = 2.0 / omega;
            // At rest, reference geometry (J = 1, rho = rho0).
            let avg = TetAverages { theta: 0.0, j: 1.0 };
            let step = |ctl: &HexControls| {
                let v = [[0.0; 3]; 4];
                let mut st = TetState::default();
                let out = tet::update(&x, &v, 1e-9, RHO, vol, avg, &*mat, ctl, &mut st, &mut []);
                out.unwrap().dt_stable
            };
            // Without bulk viscosity dt_stable = 2 / max_frequency.
            let ratio = step(&no_viscosity()) / dt_exact;
            let bound = tet::max_frequency(&g, RHO, lambda + 2.0 * mu, mu);
            assert!(
                (step(&no_viscosity()) * bound / 2.0 - 1.0).abs() <= 1e-14,
                "{name}: dt_stable = 2 / max_frequency"
            );
            // With the default bulk viscosity its linear term damps even at theta = 0 (as the
            // hexahedron's): a shorter step.
            let damped = step(&HexControls::default()) / dt_exact;
            // The plain bound omega^2 <= (4/rho) (lambda + 2 mu) sum |g|^2, for comparison.
            let gg: f64 = g.iter().flatten().map(|c| c * c).sum();
            let plain = 2.0 / (4.0 / RHO * (lambda + 2.0 * mu) * gg).sqrt() / dt_exact;
            println!(
                "nu {nu:6}  {name:10}  dt_stable / (2/omega_exact) = {ratio:.4}  \
                 (plain bound {plain:.4}, with default bulk viscosity {damped:.4})"
            );
            // Safe (the bound must not exceed the exact limit, no tolerance) and not absurdly
            // small (>= 0.3 of it).
            assert!(ratio <= 1.0, "{name}, nu {nu}: ratio {ratio} > 1");
            assert!(ratio >= 0.3, "{name}, nu {nu}: ratio {ratio} < 0.3");
            assert!(
                damped < ratio,
                "{name}, nu {nu}: damping must shorten the step"
            );
            worst = worst.min(ratio);
            best = best.max(ratio);
        }
    }
    println!("ratios between {worst:.4} and {best:.4}");
}

/// The Kuhn (Freudenthal) split of an n x n x n grid of the unit cube: 6 tetrahedra per cell
/// along its main diagonal, one per permutation of the axes, oriented positively.
fn kuhn_mesh(n: usize) -> (Vec<[f64; 3]>, Vec<[usize; 4]>) {
    let id = |i: usize, j: usize, k: usize| i + (n + 1) * (j + (n + 1) * k);
    let h = 1.0 / n as f64;
    let mut x = Vec::new();
    for k in 0..=n {
        for j in 0..=n {
            for i in 0..=n {
                x.push([i as f64 * h, j as f64 * h, k as f64 * h]);
            }
        }
    }
    let perms = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    let mut e = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                for p in perms {
                    let mut c = [i, j, k];
                    let mut t = [id(c[0], c[1], c[2]); 4];
                    for (s, &axis) in p.iter().enumerate() {
                        c[axis] += 1;
                        t[s + 1] = id(c[0], c[1], c[2]);
                    }
                    let xt: [[f64; 3]; 4] = std::array::from_fn(|a| x[t[a]]);
                    if triple(&xt) < 0.0 {
                        t.swap(1, 2);
                    }
                    e.push(t);
                }
            }
        }
    }
    (x, e)
}

fn gather(f: &[[f64; 3]], t: &[usize; 4]) -> [[f64; 3]; 4] {
    std::array::from_fn(|k| f[t[k]])
}

/// The element loop's first pass: reference volumes at `x0`, [`tet::rates`] summed per node
/// ([vol_rate, vol_mid, vol, vol0]) and each element's means theta = mean of the nodes'
/// sum vol_rate / sum vol_mid, J = mean of the nodes' sum vol / sum vol0. In a homogeneous
/// field every node sees its elements' common rate: theta = vol_rate / vol_mid of each element
/// (checked, 1e-12 relative).
fn first_pass(
    x0: &[[f64; 3]],
    x: &[[f64; 3]],
    v: &[[f64; 3]],
    elems: &[[usize; 4]],
    dt: f64,
) -> (Vec<f64>, Vec<TetAverages>) {
    let vol0: Vec<f64> = elems
        .iter()
        .map(|t| tet::gradients(&gather(x0, t)).1)
        .collect();
    let mut sums = vec![[0.0; 4]; x.len()];
    let mut own = Vec::new();
    for (e, t) in elems.iter().enumerate() {
        let r = tet::rates(&gather(x, t), &gather(v, t), dt).unwrap();
        own.push(r.vol_rate / r.vol_mid);
        for &node in t {
            let s = &mut sums[node];
            s[0] += r.vol_rate;
            s[1] += r.vol_mid;
            s[2] += r.vol;
            s[3] += vol0[e];
        }
    }
    let avgs: Vec<TetAverages> = elems
        .iter()
        .map(|t| TetAverages {
            theta: t.iter().map(|&k| sums[k][0] / sums[k][1]).sum::<f64>() / 4.0,
            j: t.iter().map(|&k| sums[k][2] / sums[k][3]).sum::<f64>() / 4.0,
        })
        .collect();
    for (a, th) in avgs.iter().zip(&own) {
        assert!(
            (a.theta - th).abs() <= 1e-12 * th.abs(),
            "theta {} vs {th}",
            a.theta
        );
    }
    (vol0, avgs)
}

#[test]
fn kuhn_mesh_homogeneous_field() {
    let n = 3;
    let (x0, elems) = kuhn_mesh(n);
    assert_eq!(elems.len(), 6 * n * n * n);
    let a = [[0.3, -0.7, 0.2], [0.5, -0.4, -0.4], [-0.6, 0.9, -0.25]];
    let v0 = [0.1, -0.2, 0.3];
    let dt = 1e-4;
    // v given at the nodes' t(n) positions; x(n+1) = x0 + dt v: a homogeneous deformation.
    let v: Vec<[f64; 3]> = x0
        .iter()
        .map(|p| std::array::from_fn(|i| v0[i] + (0..3).map(|j| a[i][j] * p[j]).sum::<f64>()))
        .collect();
    let x: Vec<[f64; 3]> = x0
        .iter()
        .zip(&v)
        .map(|(p, w)| std::array::from_fn(|i| p[i] + dt * w[i]))
        .collect();
    let (vol0, avgs) = first_pass(&x0, &x, &v, &elems, dt);
    // Pass 2, from a uniform prestress.
    let mat = elastic(E, NU);
    let ctl = HexControls::default();
    let s0 = [1e8, -2e8, 5e7, 3e7, -4e7, 6e7];
    let mut force = vec![[0.0; 3]; x.len()];
    let mut stresses = Vec::new();
    let mut fmax = 0.0f64;
    for (e, t) in elems.iter().enumerate() {
        let mut st = TetState { stress: s0 };
        let out = tet::update(
            &gather(&x, t),
            &gather(&v, t),
            dt,
            RHO,
            vol0[e],
            avgs[e],
            &*mat,
            &ctl,
            &mut st,
            &mut [],
        )
        .unwrap();
        for (a, &k) in t.iter().enumerate() {
            for i in 0..3 {
                force[k][i] += out.force[a][i];
                fmax = fmax.max(out.force[a][i].abs());
            }
        }
        stresses.push(st.stress);
    }
    // Every element the same stress (1e-12 relative to its norm).
    let s_ref = stresses[0];
    let s_norm = norm6(&s_ref);
    let mut worst = 0.0f64;
    for s in &stresses {
        worst = worst.max(norm6(&std::array::from_fn(|k| s[k] - s_ref[k])) / s_norm);
    }
    println!("largest stress difference between elements: {worst:e} (relative)");
    assert!(
        worst <= 1e-12,
        "elements' stresses differ by {worst:e} relative"
    );
    // Interior nodes: zero total force (1e-10 relative to the largest element force).
    let mut worst_f = 0.0f64;
    for k in 0..=n {
        for j in 0..=n {
            for i in 0..=n {
                if [i, j, k].iter().all(|&c| c > 0 && c < n) {
                    let f = force[i + (n + 1) * (j + (n + 1) * k)];
                    worst_f = worst_f.max(f.iter().fold(0.0f64, |m, c| m.max(c.abs())) / fmax);
                }
            }
        }
    }
    println!("largest interior nodal force / largest element force: {worst_f:e}");
    assert!(
        worst_f <= 1e-10,
        "interior nodal force {worst_f:e} of the element forces"
    );
}
