#![allow(clippy::needless_range_loop)]
//! The implicit mode's material tangent (forward differences of the stress update) against the
//! closed forms: isotropic elasticity, and the consistent elastic-plastic tangent of the J2
//! radial return with linear hardening (Simo & Hughes, *Computational Inelasticity*, 1998,
//! Box 3.2: C = kappa 1(x)1 + 2 mu theta (I - 1/3 1(x)1) - 2 mu theta_bar n(x)n with
//! theta = 1 - 2 mu dgamma / ||s_tr||, theta_bar = 1 / (1 + H / (3 mu)) - (1 - theta)).
//! No MPI, no PETSc.
use fe_petsc::implicit::material_tangent;
use fe_petsc::material::{build_material, MaterialSpec};

const E: f64 = 200.0e9;
const NU: f64 = 0.3;
const YIELD: f64 = 350.0e6;
const H: f64 = 1.0e9;

fn spec(model: &str, params: &[(&str, f64)]) -> MaterialSpec {
    MaterialSpec {
        name: "m".into(),
        model: model.into(),
        density: 7850.0,
        params: params.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
        eos: None,
    }
}

fn lame() -> (f64, f64) {
    let mu = E / (2.0 * (1.0 + NU));
    (E * NU / ((1.0 + NU) * (1.0 - 2.0 * NU)), mu)
}

/// C_eng . (engineering form of a tensor strain direction d).
fn apply(c: &[[f64; 6]; 6], d: &[f64; 6]) -> [f64; 6] {
    let eng: [f64; 6] = std::array::from_fn(|l| if l >= 3 { 2.0 * d[l] } else { d[l] });
    std::array::from_fn(|k| (0..6).map(|l| c[k][l] * eng[l]).sum())
}

/// Strain directions: each axis, each shear, and a mixed one.
const DIRECTIONS: [[f64; 6]; 7] = [
    [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
    [0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
    [0.3, -0.7, 0.2, 0.5, -0.4, 0.6],
];

#[test]
fn elastic_tangent_is_exact() {
    let m = build_material(&spec(
        "elastic",
        &[("youngs_modulus", E), ("poisson_ratio", NU)],
    ))
    .unwrap();
    let (lambda, mu) = lame();
    let stress = [1.0e8, -2.0e7, 3.0e7, 1.0e7, -5.0e6, 2.0e6];
    let deps = [1e-5, -2e-5, 3e-6, 4e-6, 0.0, -1e-6];
    let c = material_tangent(&*m, &stress, &[], &deps, 1e-7);
    for d in DIRECTIONS {
        let tr = d[0] + d[1] + d[2];
        let expect: [f64; 6] = std::array::from_fn(|k| {
            if k < 3 {
                lambda * tr + 2.0 * mu * d[k]
            } else {
                2.0 * mu * d[k]
            }
        });
        let got = apply(&c, &d);
        for k in 0..6 {
            assert!(
                (got[k] - expect[k]).abs() <= 1e-6 * (lambda + 2.0 * mu),
                "elastic tangent, direction {d:?}, component {k}: {} vs {} (1e-6 of lambda + 2 mu)",
                got[k],
                expect[k]
            );
        }
    }
}

#[test]
fn j2_tangent_is_the_consistent_tangent() {
    let m = build_material(&spec(
        "j2_plastic",
        &[
            ("youngs_modulus", E),
            ("poisson_ratio", NU),
            ("yield_stress", YIELD),
            ("hardening_modulus", H),
        ],
    ))
    .unwrap();
    let (lambda, mu) = lame();
    let kappa = lambda + 2.0 * mu / 3.0;
    // A stress on the yield surface (ep = 0.01) and an increment that loads it plastically.
    let ep = 0.01;
    let s_dir = [0.6, -0.2, -0.4, 0.3, 0.1, -0.2];
    let norm = |s: &[f64; 6]| {
        (s[0] * s[0] + s[1] * s[1] + s[2] * s[2] + 2.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]))
            .sqrt()
    };
    let q_unit = (1.5f64).sqrt() * norm(&s_dir);
    let p = -5.0e7;
    let scale = (YIELD + H * ep) / q_unit;
    let stress: [f64; 6] = std::array::from_fn(|k| {
        if k < 3 {
            p + scale * s_dir[k]
        } else {
            scale * s_dir[k]
        }
    });
    let deps = [4e-4, -1e-4, -2e-4, 3e-4, 1e-4, -1e-4];
    let c = material_tangent(&*m, &stress, &[ep], &deps, 1e-7);
    // The closed form at the trial state.
    let tr = deps[0] + deps[1] + deps[2];
    let trial: [f64; 6] = std::array::from_fn(|k| {
        if k < 3 {
            stress[k] + lambda * tr + 2.0 * mu * deps[k]
        } else {
            stress[k] + 2.0 * mu * deps[k]
        }
    });
    let pt = (trial[0] + trial[1] + trial[2]) / 3.0;
    let s_tr: [f64; 6] = std::array::from_fn(|k| if k < 3 { trial[k] - pt } else { trial[k] });
    let s_norm = norm(&s_tr);
    let q_tr = (1.5f64).sqrt() * s_norm;
    let f = q_tr - (YIELD + H * ep);
    assert!(f > 0.0, "the test increment must load plastically");
    // Simo-Hughes' dgamma (on ||s||) = sqrt(3/2) x the material's (on q).
    let dgamma_q = f / (3.0 * mu + H);
    let theta = 1.0 - 3.0 * mu * dgamma_q / q_tr;
    let theta_bar = 1.0 / (1.0 + H / (3.0 * mu)) - (1.0 - theta);
    let n: [f64; 6] = std::array::from_fn(|k| s_tr[k] / s_norm);
    for d in DIRECTIONS {
        let trd = d[0] + d[1] + d[2];
        let n_d = n[0] * d[0]
            + n[1] * d[1]
            + n[2] * d[2]
            + 2.0 * (n[3] * d[3] + n[4] * d[4] + n[5] * d[5]);
        let expect: [f64; 6] = std::array::from_fn(|k| {
            let dev = if k < 3 { d[k] - trd / 3.0 } else { d[k] };
            let vol = if k < 3 { kappa * trd } else { 0.0 };
            vol + 2.0 * mu * theta * dev - 2.0 * mu * theta_bar * n[k] * n_d
        });
        let got = apply(&c, &d);
        for k in 0..6 {
            assert!(
                (got[k] - expect[k]).abs() <= 1e-4 * (lambda + 2.0 * mu),
                "J2 tangent, direction {d:?}, component {k}: {} vs Simo-Hughes {} (1e-4 of lambda + 2 mu)",
                got[k],
                expect[k]
            );
        }
    }
}
