//! The physical hourglass stabilisation against beam and plate theory and the elastic-plastic
//! tangent (fe_petsc/src/hourglass.rs).
use fe_petsc::hex::{self, HexControls, HexState};
use fe_petsc::hourglass;
use fe_petsc::material::{self, Material, MaterialSpec};

const E: f64 = 200e9;
const NU: f64 = 0.3;
const RHO: f64 = 7850.0;

fn material(model: &str, params: &[(&str, f64)]) -> Box<dyn Material> {
    material::build_material(&MaterialSpec {
        name: "m".into(),
        model: model.into(),
        density: RHO,
        params: params.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
        eos: None,
    })
    .unwrap()
}

fn steel() -> Box<dyn Material> {
    material("elastic", &[("youngs_modulus", E), ("poisson_ratio", NU)])
}

/// A brick with half-lengths `a`, centred at the origin, turned by `rot` (rows: its axes).
fn brick(a: [f64; 3], rot: &[[f64; 3]; 3]) -> [[f64; 3]; 8] {
    std::array::from_fn(|k| {
        let l: [f64; 3] = std::array::from_fn(|i| hex::NODE_XI[k][i] * a[i]);
        std::array::from_fn(|c| (0..3).map(|i| rot[i][c] * l[i]).sum())
    })
}

/// Strain energy the element stores when its nodes take the displacement `u(local point)` in
/// one step (hourglass work + the centre's stress work), J, for a brick turned by `rot`.
fn energy_of(a: [f64; 3], rot: &[[f64; 3]; 3], u: impl Fn([f64; 3]) -> [f64; 3]) -> f64 {
    let mat = steel();
    let ctl = HexControls {
        bv_linear: 0.0,
        bv_quadratic: 0.0,
        ..HexControls::default()
    };
    let x0 = brick(a, rot);
    let dt = 1e-6;
    let ul: [[f64; 3]; 8] = std::array::from_fn(|k| {
        let p: [f64; 3] = std::array::from_fn(|i| hex::NODE_XI[k][i] * a[i]);
        let d = u(p);
        std::array::from_fn(|c| (0..3).map(|i| rot[i][c] * d[i]).sum())
    });
    let x: [[f64; 3]; 8] = std::array::from_fn(|k| std::array::from_fn(|c| x0[k][c] + ul[k][c]));
    let v: [[f64; 3]; 8] = std::array::from_fn(|k| std::array::from_fn(|c| ul[k][c] / dt));
    let vol = hex::volume(&x0);
    let mut st = HexState::default();
    let out = hex::update(&x, &v, dt, RHO, vol, &*mat, &ctl, &mut st, &mut []).unwrap();
    // The centre's stress work over the step (trapezoid from zero stress): V sigma : D dt / 2.
    let (b, _) = hex::gradient(&x0);
    let mut w = 0.0;
    for k in 0..8 {
        let s = &st.stress;
        let f = [
            s[0] * b[k][0] + s[3] * b[k][1] + s[5] * b[k][2],
            s[3] * b[k][0] + s[1] * b[k][1] + s[4] * b[k][2],
            s[5] * b[k][0] + s[4] * b[k][1] + s[2] * b[k][2],
        ];
        w += 0.5 * vol * (f[0] * ul[k][0] + f[1] * ul[k][1] + f[2] * ul[k][2]);
    }
    out.hg_work + w
}

fn turned() -> [[f64; 3]; 3] {
    // Rotation by 0.4 rad about (1, 2, 2)/3: the element's axes are not the global ones.
    let n = [1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0];
    let (s, c) = 0.4f64.sin_cos();
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let d = if i == j { c } else { 0.0 };
            let cross = match (i, j) {
                (0, 1) => -n[2],
                (0, 2) => n[1],
                (1, 0) => n[2],
                (1, 2) => -n[0],
                (2, 0) => -n[1],
                (2, 1) => n[0],
                _ => 0.0,
            };
            d + s * cross + (1.0 - c) * n[i] * n[j]
        })
    })
}

#[test]
fn one_element_is_exact_in_pure_bending_of_a_beam_and_of_a_plate() {
    // Reference: pure bending of an elastic beam (Timoshenko & Goodier, Theory of Elasticity,
    // sec. 102): u_x = -k x y, u_y = k/2 (x^2 + nu (y^2 - z^2)), u_z = nu k y z; sigma_xx = -E k y
    // only; energy per element (1/2) E k^2 integral(y^2 dV) = (1/2) E k^2 V b^2 / 3 for a brick
    // of half-lengths (a, b, c). Held at z (a plate, cylindrical bending, u_z = 0): E / (1 - nu^2)
    // in place of E. One element through the depth, its nodes on the exact field: the element's
    // energy must be the exact one to 1e-6 (the step's geometric change is of order k a = 1e-7).
    let k = 1e-5;
    for a in [[0.01, 0.005, 0.004], [0.002, 0.01, 0.02]] {
        for rot in [
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            turned(),
        ] {
            let vol = 8.0 * a[0] * a[1] * a[2];
            let exact_beam = 0.5 * E * k * k * vol * a[1] * a[1] / 3.0;
            let beam = energy_of(a, &rot, |p| {
                let [x, y, z] = p;
                [
                    -k * x * y,
                    0.5 * k * (x * x + NU * (y * y - z * z)),
                    NU * k * y * z,
                ]
            });
            assert!(
                (beam / exact_beam - 1.0).abs() < 1e-6,
                "beam bending energy {beam:e} vs beam theory {exact_beam:e} (1e-6), brick {a:?}"
            );
            let exact_plate = exact_beam / (1.0 - NU * NU);
            let plate = energy_of(a, &rot, |p| {
                let [x, y, _] = p;
                [-k * x * y, 0.5 * k * (x * x + NU / (1.0 - NU) * y * y), 0.0]
            });
            assert!(
                (plate / exact_plate - 1.0).abs() < 1e-6,
                "plate bending energy {plate:e} vs plate theory {exact_plate:e} (1e-6), brick {a:?}"
            );
        }
    }
}

#[test]
fn the_tangent_ratio_of_a_flowing_j2_material_is_the_elastic_plastic_modulus() {
    // Reference: J2 plasticity with linear hardening H, on the yield surface and strained along
    // its flow direction n (a deviatoric unit tensor): the radial return gives
    // dsigma' = 2 mu H / (3 mu + H) deps' (Simo & Hughes, Computational Inelasticity, sec. 3.3),
    // so the ratio is H / (3 mu + H); unloading is elastic: 1.
    let (sy, h) = (400e6, 1e9);
    let mat = material(
        "j2_plastic",
        &[
            ("youngs_modulus", E),
            ("poisson_ratio", NU),
            ("yield_stress", sy),
            ("hardening_modulus", h),
        ],
    );
    let mu = E / (2.0 * (1.0 + NU));
    let mut state = vec![0.0; mat.n_state()];
    mat.init_state(&mut state);
    // Pure shear in xy past yield (tau_y = sy / sqrt 3), then one more increment.
    let mut stress = [0.0; 6];
    let g = 2.0 * sy / 3f64.sqrt() / (2.0 * mu);
    mat.update_stress(
        &mut stress,
        &mut state,
        &[0.0, 0.0, 0.0, g, 0.0, 0.0],
        1e-6,
        RHO,
    );
    let deps = [0.0, 0.0, 0.0, 1e-5, 0.0, 0.0];
    let before = stress;
    mat.update_stress(&mut stress, &mut state, &deps, 1e-6, RHO);
    let dsig: [f64; 6] = std::array::from_fn(|k| stress[k] - before[k]);
    let s = hourglass::tangent_ratio(&dsig, &deps, mu);
    let want = h / (3.0 * mu + h);
    assert!(
        (s / want - 1.0).abs() < 1e-9,
        "flowing: ratio {s} vs H/(3 mu + H) = {want} (1e-9)"
    );
    // Unloading: elastic.
    let deps = [0.0, 0.0, 0.0, -1e-5, 0.0, 0.0];
    let before = stress;
    mat.update_stress(&mut stress, &mut state, &deps, 1e-6, RHO);
    let dsig: [f64; 6] = std::array::from_fn(|k| stress[k] - before[k]);
    let s = hourglass::tangent_ratio(&dsig, &deps, mu);
    assert!((s - 1.0).abs() < 1e-9, "unloading: ratio {s} vs 1 (1e-9)");
}

#[test]
fn a_cube_hourglass_mode_oscillates_at_its_assumed_strain_frequency() {
    // A unit cube (half-length a = 1/2), lumped mass rho/8 per node, given the hourglass velocity
    // v_x = v0 xi eta, v_z = v0 eta zeta: both fields strain the cube linearly in eta
    // (eps_xx = q eta / a, eps_zz = q eta / a), the plane-stress group of the derivation in
    // hourglass.rs with energy (V/3) Ebar/2 (2 + 2 nu) (q/a)^2, Ebar = E/(1 - nu^2), against the
    // kinetic energy 2 x 8 (rho/8)/2 qdot^2: omega^2 = 4 E / (3 rho (1 - nu)), and the nodal
    // velocity is v0 cos(omega t). Checked to 0.5 % on the first zero crossing.
    let mat = steel();
    let ctl = HexControls {
        bv_linear: 0.0,
        bv_quadratic: 0.0,
        ..HexControls::default()
    };
    let mut x = brick(
        [0.5; 3],
        &[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    );
    let m = RHO / 8.0;
    let mut v: [[f64; 3]; 8] = std::array::from_fn(|k| {
        let [x, y, z] = hex::NODE_XI[k];
        [x * y, 0.0, y * z]
    });
    let omega = (4.0 * E / (3.0 * RHO * (1.0 - NU))).sqrt();
    let dt = 1e-3 * 2.0 * std::f64::consts::PI / omega;
    let mut st = HexState::default();
    let mut f = [[0.0; 3]; 8];
    let mut t = 0.0;
    let mut prev = v[2][0];
    let t_zero = loop {
        for k in 0..8 {
            for c in 0..3 {
                v[k][c] += 0.5 * dt * f[k][c] / m;
                x[k][c] += dt * v[k][c];
            }
        }
        let out = hex::update(&x, &v, dt, RHO, 1.0, &*mat, &ctl, &mut st, &mut []).unwrap();
        f = out.force;
        for k in 0..8 {
            for c in 0..3 {
                v[k][c] += 0.5 * dt * f[k][c] / m;
            }
        }
        t += dt;
        if prev > 0.0 && v[2][0] <= 0.0 {
            break t - dt * v[2][0] / (v[2][0] - prev);
        }
        prev = v[2][0];
        assert!(t < 10.0 / omega, "no zero crossing");
    };
    let want = 0.5 * std::f64::consts::PI / omega;
    assert!(
        (t_zero / want - 1.0).abs() < 5e-3,
        "first zero of the mode velocity at {t_zero:e} s vs pi/(2 omega) = {want:e} s (0.5 %)"
    );
}
