#![allow(clippy::needless_range_loop)]
//! The hexahedron and the materials against analytic answers (no MPI, no PETSc).
use fe_petsc::hex::{self, HexControls, HexState};
use fe_petsc::hourglass::Hourglass;
use fe_petsc::material::{build_material, Material, MaterialSpec};

/// A small deterministic generator (LCG, Knuth's constants) so tests need no rand crate.
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

fn spec(model: &str, params: &[(&str, f64)]) -> MaterialSpec {
    MaterialSpec {
        name: "m".into(),
        model: model.into(),
        density: 7850.0,
        params: params.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
        eos: None,
    }
}

fn steel() -> Box<dyn Material> {
    build_material(&spec(
        "elastic",
        &[("youngs_modulus", 200e9), ("poisson_ratio", 0.3)],
    ))
    .unwrap()
}

/// A 2x2x2 block of hexahedra on [0,2]^3 with every node except the corners' outer faces
/// perturbed; returns (nodes, elements).
fn distorted_block(seed: u64) -> (Vec<[f64; 3]>, Vec<[usize; 8]>) {
    let mut rng = Lcg(seed);
    let id = |i: usize, j: usize, k: usize| i + 3 * j + 9 * k;
    let mut x = Vec::new();
    for k in 0..3 {
        for j in 0..3 {
            for i in 0..3 {
                let mut p = [i as f64, j as f64, k as f64];
                for c in p.iter_mut() {
                    *c += 0.4 * rng.next(); // up to 20 % of the spacing
                }
                x.push(p);
            }
        }
    }
    let mut e = Vec::new();
    for k in 0..2 {
        for j in 0..2 {
            for i in 0..2 {
                e.push([
                    id(i, j, k),
                    id(i + 1, j, k),
                    id(i + 1, j + 1, k),
                    id(i, j + 1, k),
                    id(i, j, k + 1),
                    id(i + 1, j, k + 1),
                    id(i + 1, j + 1, k + 1),
                    id(i, j + 1, k + 1),
                ]);
            }
        }
    }
    (x, e)
}

#[test]
fn patch_test_distorted_mesh_linear_velocity() {
    let (x, elems) = distorted_block(7);
    // v = A x + c with a general non-symmetric A.
    let a = [[0.3, -0.7, 0.2], [0.5, 0.1, -0.4], [-0.6, 0.9, 0.25]];
    let c0 = [0.1, -0.2, 0.3];
    let v: Vec<[f64; 3]> = x
        .iter()
        .map(|p| std::array::from_fn(|i| c0[i] + (0..3).map(|j| a[i][j] * p[j]).sum::<f64>()))
        .collect();
    let mat = steel();
    let lambda = 200e9 * 0.3 / (1.3 * 0.4);
    let mu = 200e9 / 2.6;
    let dt = 1e-7;
    // Every hourglass kind: none may act on a linear field.
    let controls = [
        Hourglass::default(),
        Hourglass::Stiffness { coefficient: 0.05 },
        Hourglass::Viscous { coefficient: 0.1 },
    ]
    .map(|hourglass| HexControls {
        hourglass,
        bv_linear: 0.0,
        bv_quadratic: 0.0,
    });
    let d = [
        a[0][0],
        a[1][1],
        a[2][2],
        0.5 * (a[0][1] + a[1][0]),
        0.5 * (a[1][2] + a[2][1]),
        0.5 * (a[2][0] + a[0][2]),
    ];
    let tr = d[0] + d[1] + d[2];
    let mut nodal = vec![[0.0; 3]; x.len()];
    let mut fscale = 0.0f64;
    for e in &elems {
        // x holds the mid-step geometry (where the element evaluates L); the end of the step
        // is x + dt/2 v.
        let xh: [[f64; 3]; 8] = std::array::from_fn(|k| x[e[k]]);
        let ve: [[f64; 3]; 8] = std::array::from_fn(|k| v[e[k]]);
        let xe: [[f64; 3]; 8] =
            std::array::from_fn(|k| std::array::from_fn(|i| xh[k][i] + 0.5 * dt * ve[k][i]));
        // The mean gradient reproduces linear fields exactly: sum_I b_I x_I^T = I.
        let (b, vol) = hex::gradient(&xh);
        for i in 0..3 {
            for j in 0..3 {
                let s: f64 = (0..8).map(|k| b[k][j] * xh[k][i]).sum();
                let expect = if i == j { 1.0 } else { 0.0 };
                assert!(
                    (s - expect).abs() < 1e-12,
                    "sum_I b_Ij x_Ii = delta_ij within 1e-12, got {s}"
                );
            }
        }
        let _ = vol;
        let vol = hex::volume(&xe);
        for ctl in &controls[1..] {
            let mut st = HexState::default();
            let out = hex::update(&xe, &ve, dt, 7850.0, vol, &*mat, ctl, &mut st, &mut []).unwrap();
            assert!(
                out.hg_work.abs() < 1e-12,
                "hourglass work of a linear field = {} with {:?} (must be 0)",
                out.hg_work,
                ctl.hourglass
            );
        }
        let mut st = HexState::default();
        let out = hex::update(
            &xe,
            &ve,
            dt,
            7850.0,
            vol,
            &*mat,
            &controls[0],
            &mut st,
            &mut [],
        )
        .unwrap();
        // Stress after one step from zero: C : (D dt) exactly (no rotation of a zero stress).
        for k in 0..6 {
            let expect = if k < 3 {
                lambda * tr * dt + 2.0 * mu * d[k] * dt
            } else {
                2.0 * mu * d[k] * dt
            };
            assert!(
                (st.stress[k] - expect).abs() <= 1e-10 * expect.abs().max(1.0),
                "patch test: stress[{k}] = {} vs analytic {expect} (1e-10 relative)",
                st.stress[k]
            );
        }
        // Linear fields excite no hourglass mode.
        assert!(
            out.hg_work.abs() < 1e-12,
            "hourglass work of a linear field = {} (must be 0)",
            out.hg_work
        );
        for hgm in &st.hg {
            for q in hgm {
                assert!(
                    q.abs() < 1e-12 * 1e9,
                    "hourglass force {q} under a linear field"
                );
            }
        }
        for k in 0..8 {
            for c in 0..3 {
                nodal[e[k]][c] += out.force[k][c];
                fscale = fscale.max(out.force[k][c].abs());
            }
        }
    }
    // Constant stress is in equilibrium: the interior node (1,1,1) has zero net force.
    let centre = 1 + 3 + 9;
    for c in 0..3 {
        assert!(
            nodal[centre][c].abs() < 1e-10 * fscale,
            "interior node force {} vs scale {fscale} (1e-10)",
            nodal[centre][c]
        );
    }
}

#[test]
fn volume_of_a_parallelepiped_and_gradient_identities() {
    // Parallelepiped spanned by a, b, c: V = a . (b x c) exactly.
    let (a, b, c) = ([2.0, 0.1, 0.0], [0.3, 1.5, 0.2], [0.1, -0.2, 0.8]);
    let o = [0.5, -1.0, 2.0];
    let x: [[f64; 3]; 8] = std::array::from_fn(|k| {
        let xi = hex::NODE_XI[k];
        std::array::from_fn(|i| {
            o[i] + 0.5 * (xi[0] + 1.0) * a[i]
                + 0.5 * (xi[1] + 1.0) * b[i]
                + 0.5 * (xi[2] + 1.0) * c[i]
        })
    });
    let exact = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
        + a[2] * (b[0] * c[1] - b[1] * c[0]);
    let v = hex::volume(&x);
    assert!(
        (v - exact).abs() < 1e-13 * exact,
        "volume {v} vs a.(b x c) = {exact}"
    );
    let (g, _) = hex::gradient(&x);
    for j in 0..3 {
        let s: f64 = (0..8).map(|k| g[k][j]).sum();
        assert!(
            s.abs() < 1e-12,
            "sum_I b_I = 0 (partition of unity), got {s}"
        );
    }
    // A distorted hex: volume equals the 2x2x2 Gauss integral of det J (exact for trilinear).
    let (xs, es) = distorted_block(3);
    let xe: [[f64; 3]; 8] = std::array::from_fn(|k| xs[es[0][k]]);
    let gp = 1.0 / 3f64.sqrt();
    let mut vg = 0.0;
    for p in [
        [-gp, -gp, -gp],
        [gp, -gp, -gp],
        [gp, gp, -gp],
        [-gp, gp, -gp],
        [-gp, -gp, gp],
        [gp, -gp, gp],
        [gp, gp, gp],
        [-gp, gp, gp],
    ] {
        let h = 1e-6;
        let mut j = [[0.0; 3]; 3];
        for d in 0..3 {
            let mut pp = p;
            let mut pm = p;
            pp[d] += h;
            pm[d] -= h;
            let (np, nm) = (hex::shape(pp), hex::shape(pm));
            for i in 0..3 {
                j[i][d] = (0..8).map(|k| (np[k] - nm[k]) * xe[k][i]).sum::<f64>() / (2.0 * h);
            }
        }
        vg += j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1])
            - j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0])
            + j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0]);
    }
    let v = hex::volume(&xe);
    assert!(
        (v - vg).abs() < 1e-8 * v,
        "volume {v} vs Gauss integral of det J {vg} (1e-8)"
    );
}

fn cube(h: f64) -> [[f64; 3]; 8] {
    std::array::from_fn(|k| std::array::from_fn(|i| 0.5 * (hex::NODE_XI[k][i] + 1.0) * h))
}

#[test]
fn stable_step_of_a_cube() {
    let mat = steel();
    let h = 0.01;
    let c = (mat.dilatational_modulus() / 7850.0).sqrt();
    let ctl0 = HexControls {
        bv_linear: 0.0,
        bv_quadratic: 0.0,
        ..HexControls::default()
    };
    let dt = hex::stable_dt(&cube(h), 7850.0, &*mat, &ctl0, 0.0);
    let exact = h / (c * 3f64.sqrt());
    assert!(
        (dt - exact).abs() < 1e-12 * exact,
        "FB step {dt} vs h/(c sqrt 3) = {exact}"
    );
    let ctl = HexControls {
        bv_linear: 0.06,
        ..ctl0
    };
    let dtb = hex::stable_dt(&cube(h), 7850.0, &*mat, &ctl, 0.0);
    // The linear bulk viscosity q = rho b1 c h eps_v damps the cube's highest mode
    // (omega = 2 sqrt(3) c / h, stiffness rho c^2 per unit eps_v) with the ratio
    // xi = b1 c h omega / (2 c^2) = sqrt(3) b1.
    let xi = 0.06 * 3f64.sqrt();
    let f = (1.0f64 + xi * xi).sqrt() - xi;
    assert!(
        (dtb - exact * f).abs() < 1e-12 * exact,
        "with bulk viscosity {dtb} vs {}",
        exact * f
    );
}

#[test]
fn rigid_rotation_leaves_stress_invariant_in_the_body_frame() {
    // A cube under uniaxial stress sigma_xx = s0 spins about z at omega for a quarter turn in
    // many steps: the Hughes-Winget update must carry the stress with the body, so at the end
    // sigma_yy = s0 and sigma_xx = 0 (no spurious stress from rotation).
    let mat = steel();
    let ctl = HexControls {
        bv_linear: 0.0,
        bv_quadratic: 0.0,
        ..HexControls::default()
    };
    let s0 = 1e8;
    let mut st = HexState {
        stress: [s0, 0.0, 0.0, 0.0, 0.0, 0.0],
        hg: [[0.0; 3]; 4],
    };
    let x0 = cube(1.0);
    let centre = [0.5, 0.5, 0.5];
    let omega = 1.0;
    let steps = 20000;
    let dt = std::f64::consts::FRAC_PI_2 / omega / steps as f64;
    let vol0 = 1.0;
    for n in 0..steps {
        // Positions at t(n+1) and the exact rigid velocities at t(n+1/2) (midpoint rotation).
        let th1 = omega * dt * (n + 1) as f64;
        let thh = omega * dt * (n as f64 + 0.5);
        let rotp = |p: [f64; 3], th: f64| {
            let (dx, dy) = (p[0] - centre[0], p[1] - centre[1]);
            [
                centre[0] + th.cos() * dx - th.sin() * dy,
                centre[1] + th.sin() * dx + th.cos() * dy,
                p[2],
            ]
        };
        let x: [[f64; 3]; 8] = std::array::from_fn(|k| rotp(x0[k], th1));
        let xh: [[f64; 3]; 8] = std::array::from_fn(|k| rotp(x0[k], thh));
        let v: [[f64; 3]; 8] = std::array::from_fn(|k| {
            [
                -omega * (xh[k][1] - centre[1]),
                omega * (xh[k][0] - centre[0]),
                0.0,
            ]
        });
        hex::update(&x, &v, dt, 7850.0, vol0, &*mat, &ctl, &mut st, &mut []).unwrap();
    }
    let s = st.stress;
    assert!(
        (s[1] - s0).abs() < 1e-6 * s0,
        "sigma_yy {} vs {s0} after a quarter turn (1e-6)",
        s[1]
    );
    assert!(
        s[0].abs() < 1e-6 * s0 && s[3].abs() < 1e-6 * s0,
        "sigma_xx {} sigma_xy {} must vanish",
        s[0],
        s[3]
    );
    let p = -(s[0] + s[1] + s[2]) / 3.0;
    assert!(
        (p + s0 / 3.0).abs() < 1e-6 * s0,
        "pressure {p} unchanged by rotation"
    );
}

#[test]
fn j2_uniaxial_stress_matches_linear_hardening() {
    // Uniaxial stress driven by axial strain increments with the lateral strain found by
    // iteration (sigma_yy = sigma_zz = 0). Analytic: yield at sigma_y; beyond it
    // d sigma / d eps = E H / (E + H) and ep = (sigma - sigma_y) / H.
    let (e, nu, sy, h) = (200e9, 0.3, 350e6, 2e9);
    let m = build_material(&spec(
        "j2_plastic",
        &[
            ("youngs_modulus", e),
            ("poisson_ratio", nu),
            ("yield_stress", sy),
            ("hardening_modulus", h),
        ],
    ))
    .unwrap();
    let mut stress = [0.0; 6];
    let mut state = vec![0.0];
    let de = 1e-5;
    let mut eps = 0.0;
    for _ in 0..600 {
        // Newton on the lateral strain so the lateral stress stays zero.
        let mut lat = -nu * de;
        for _ in 0..50 {
            let mut s = stress;
            let mut st = state.clone();
            m.update_stress(
                &mut s,
                &mut st,
                &[de, lat, lat, 0.0, 0.0, 0.0],
                1e-6,
                7850.0,
            );
            let mut s2 = stress;
            let mut st2 = state.clone();
            let dl = 1e-12;
            m.update_stress(
                &mut s2,
                &mut st2,
                &[de, lat + dl, lat + dl, 0.0, 0.0, 0.0],
                1e-6,
                7850.0,
            );
            let slope = (s2[1] - s[1]) / dl;
            let step = s[1] / slope;
            lat -= step;
            if step.abs() < 1e-18 {
                break;
            }
        }
        m.update_stress(
            &mut stress,
            &mut state,
            &[de, lat, lat, 0.0, 0.0, 0.0],
            1e-6,
            7850.0,
        );
        eps += de;
    }
    let et = e * h / (e + h);
    let eps_y = sy / e;
    let expect = sy + et * (eps - eps_y);
    assert!(
        (stress[0] - expect).abs() < 1e-6 * expect,
        "axial stress {} vs analytic {expect} (1e-6)",
        stress[0]
    );
    assert!(
        stress[1].abs() < 1e-3,
        "lateral stress {} must be ~0",
        stress[1]
    );
    let ep = (stress[0] - sy) / h;
    assert!(
        (state[0] - ep).abs() < 1e-6 * ep,
        "plastic strain {} vs (sigma - sigma_y)/H = {ep}",
        state[0]
    );
}

#[test]
fn johnson_cook_flow_stress_at_constant_rate() {
    // Pure shear at a constant total shear-strain rate far in the plastic range: the
    // equivalent plastic strain rate approaches the total rate, and the von Mises stress must
    // equal (a + b ep^n)(1 + c ln(rate / eps_dot0)) at the current ep.
    let (a, b, n, c, e0) = (300e6, 500e6, 0.3, 0.02, 1.0);
    let m = build_material(&spec(
        "johnson_cook",
        &[
            ("youngs_modulus", 200e9),
            ("poisson_ratio", 0.3),
            ("a", a),
            ("b", b),
            ("n", n),
            ("c", c),
            ("eps_dot0", e0),
        ],
    ))
    .unwrap();
    let mut s = [0.0; 6];
    let mut st = vec![0.0];
    let dt = 1e-6;
    let gdot = 1000.0; // tensor shear rate D_xy
    let mut prev = 0.0;
    let mut rate = 0.0;
    for _ in 0..2000 {
        m.update_stress(
            &mut s,
            &mut st,
            &[0.0, 0.0, 0.0, gdot * dt, 0.0, 0.0],
            dt,
            7850.0,
        );
        rate = (st[0] - prev) / dt;
        prev = st[0];
    }
    let q = (3.0f64).sqrt() * s[3].abs();
    let expect = (a + b * st[0].powf(n)) * (1.0 + c * (rate / e0).ln());
    assert!(
        (q - expect).abs() < 1e-6 * expect,
        "JC flow stress {q} vs formula {expect} (1e-6)"
    );
}

#[test]
fn natural_coordinates_invert_the_map() {
    let (xs, es) = distorted_block(11);
    let xe: [[f64; 3]; 8] = std::array::from_fn(|k| xs[es[3][k]]);
    let mut rng = Lcg(5);
    for _ in 0..50 {
        let xi = [1.8 * rng.next(), 1.8 * rng.next(), 1.8 * rng.next()];
        let n = hex::shape(xi);
        let p: [f64; 3] = std::array::from_fn(|i| (0..8).map(|k| n[k] * xe[k][i]).sum());
        let got = hex::natural_coords(&xe, p, 1e-9).expect("interior point found");
        for i in 0..3 {
            assert!((got[i] - xi[i]).abs() < 1e-10, "xi {:?} vs {:?}", got, xi);
        }
    }
    assert!(
        hex::natural_coords(&xe, [10.0, 10.0, 10.0], 1e-9).is_none(),
        "far point is outside"
    );
}

#[test]
fn hourglass_mode_stays_bounded_and_conserves_energy() {
    // A unit cube given a pure hourglass velocity (v_x = v0 * Gamma_xy at the nodes) with a
    // lumped mass: the default (physical) hourglass stiffness makes it oscillate; kinetic +
    // stored hourglass energy is conserved (1 %) and the velocity never grows (1e-6).
    let mat = steel();
    let ctl = HexControls {
        bv_linear: 0.0,
        bv_quadratic: 0.0,
        ..HexControls::default()
    };
    let mut x = cube(1.0);
    let m = 7850.0 / 8.0;
    let v0 = 1.0;
    let mut v: [[f64; 3]; 8] =
        std::array::from_fn(|k| [v0 * hex::NODE_XI[k][0] * hex::NODE_XI[k][1], 0.0, 0.0]);
    let ke0: f64 = v
        .iter()
        .map(|q| 0.5 * m * (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]))
        .sum();
    // A tenth of the stable step: velocity Verlet's energy measure fluctuates by about
    // (omega dt)^2 / 8 of the energy, 0.3 % for the physical mode's omega here (1.5 % at half).
    let dt = 0.1 * hex::stable_dt(&x, 7850.0, &*mat, &ctl, 0.0);
    let mut st = HexState::default();
    let mut f = [[0.0; 3]; 8];
    let mut e_hg = 0.0;
    let mut stored = 0.0; // work of the element on the nodes, negated: strain + hourglass energy
    let mut vmax = 0.0f64;
    for _ in 0..5000 {
        let f_old = f;
        let mut dx = [[0.0; 3]; 8];
        for k in 0..8 {
            for c in 0..3 {
                v[k][c] += 0.5 * dt * f[k][c] / m;
                dx[k][c] = dt * v[k][c];
                x[k][c] += dx[k][c];
            }
        }
        let out = hex::update(&x, &v, dt, 7850.0, 1.0, &*mat, &ctl, &mut st, &mut []).unwrap();
        e_hg += out.hg_work;
        f = out.force;
        for k in 0..8 {
            for c in 0..3 {
                stored -= 0.5 * (f_old[k][c] + f[k][c]) * dx[k][c];
                v[k][c] += 0.5 * dt * f[k][c] / m;
            }
            vmax = vmax.max(v[k][0].abs());
        }
    }
    let ke: f64 = v
        .iter()
        .map(|q| 0.5 * m * (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]))
        .sum();
    assert!(
        vmax <= v0 * 1.01,
        "hourglass velocity grew to {vmax} from {v0} (bounded within 1 %)"
    );
    let e = ke + stored;
    assert!(
        (e - ke0).abs() < 0.01 * ke0,
        "KE + stored energy {e} vs initial {ke0} (1 %)"
    );
    assert!(
        e_hg > 0.1 * ke0 || ke < 0.9 * ke0,
        "the hourglass stiffness must act (stored {e_hg})"
    );
}

#[test]
fn material_mistakes_are_named() {
    let e = build_material(&spec("foo", &[])).unwrap_err().to_string();
    assert!(
        e.contains("unknown model \"foo\"") && e.contains("j2_plastic"),
        "{e}"
    );
    let e = build_material(&spec(
        "j2_plastic",
        &[
            ("youngs_modulus", 1e9),
            ("poisson_ratio", 0.3),
            ("yield_stress", 1e6),
        ],
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("missing key \"hardening_modulus\""), "{e}");
    let e = build_material(&spec(
        "elastic",
        &[("youngs_modulus", 1e9), ("poisson_ratio", 0.5)],
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("poisson_ratio"), "{e}");
    let e = build_material(&spec(
        "elastic",
        &[
            ("youngs_modulus", 1e9),
            ("poisson_ratio", 0.3),
            ("yield_stress", 1.0),
        ],
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("unknown key \"yield_stress\""), "{e}");
}

/// Johnson & Cook's 1983 OFHC copper (their table 1: A = 90 MPa, B = 292 MPa, n = 0.31,
/// C = 0.025, m = 1.09, T_melt = 1356 K; specific heat 383 J/(kg K)), E 124 GPa, nu 0.34,
/// room 294 K, with `extra` keys.
fn jc_copper(extra: &[(&'static str, f64)]) -> Box<dyn Material> {
    build_material(&spec("johnson_cook", &jc_copper_keys(extra))).unwrap()
}

/// [`jc_copper`]'s keys with `extra`.
fn jc_copper_keys(extra: &[(&'static str, f64)]) -> Vec<(&'static str, f64)> {
    let mut p = vec![
        ("youngs_modulus", 124e9),
        ("poisson_ratio", 0.34),
        ("a", 90e6),
        ("b", 292e6),
        ("n", 0.31),
        ("c", 0.025),
        ("eps_dot0", 1.0),
        ("m", 1.09),
        ("t_room", 294.0),
        ("t_melt", 1356.0),
        ("specific_heat", 383.0),
    ];
    p.extend_from_slice(extra);
    p
}

#[test]
fn johnson_cook_heats_by_its_share_of_the_plastic_work_and_softens() {
    // Pure shear at a constant rate D_xy = 5e3 /s to a tensor shear strain of 2 (4,000 steps):
    // the plastic work per unit volume is the stress work sum sigma : d(eps) (trapezoid over
    // the steps) less the elastic energy left, q^2 / (6 mu) in pure shear (energy
    // conservation, measured outside the law), and the temperature must have risen by beta
    // times it over rho c (beta 0.9, the default), within 1e-3: the law books q(n+1) dgamma
    // per step (the return's dissipation), the trapezoid (q(n) + q(n+1)) dgamma / 2, apart by
    // half the hardening over a step (measured 1.2e-3 with 400 steps, 1.2e-4 with 4,000). The flow stress at the end is the law's with that temperature:
    // (A + B ep^n)(1 + C ln(rate))(1 - T*^m).
    let m = jc_copper(&[]);
    let rho = 7850.0; // the tests' spec density
    let mu = 124e9 / (2.0 * 1.34);
    let (dt, d) = (1e-7, 5e3);
    let mut s = [0.0; 6];
    let mut st = vec![0.0; m.n_state()];
    m.init_state(&mut st);
    assert_eq!(st, [0.0, 294.0], "starts at room temperature");
    let (mut work, mut prev, mut rate) = (0.0, 0.0, 0.0);
    for _ in 0..4000 {
        let before = s[3];
        m.update_stress(&mut s, &mut st, &[0.0, 0.0, 0.0, d * dt, 0.0, 0.0], dt, rho);
        // sigma : d(eps) with the tensor shear d(eps)_xy counted twice.
        work += 2.0 * 0.5 * (before + s[3]) * d * dt;
        rate = (st[0] - prev) / dt;
        prev = st[0];
    }
    let q = 3f64.sqrt() * s[3].abs();
    let plastic_work = work - q * q / (6.0 * mu);
    let heat = rho * 383.0 * (st[1] - 294.0) / 0.9;
    assert!(
        (heat / plastic_work - 1.0).abs() < 1e-3,
        "rho c dT / beta = {heat:e} J/m^3 against the plastic work {plastic_work:e} J/m^3 (1e-3)"
    );
    let ts = (st[1] - 294.0) / (1356.0 - 294.0);
    let expect =
        (90e6 + 292e6 * st[0].powf(0.31)) * (1.0 + 0.025 * rate.ln()) * (1.0 - ts.powf(1.09));
    assert!(
        (q - expect).abs() < 1e-4 * expect,
        "flow stress {q:e} Pa at T = {} K against the law's {expect:e} Pa (1e-4)",
        st[1]
    );
    assert_eq!(m.temperature(&st), Some(st[1]));
}

#[test]
fn johnson_cook_thermal_keys_are_checked() {
    let without = |k: &str| -> Vec<(&'static str, f64)> {
        jc_copper_keys(&[])
            .into_iter()
            .filter(|(n, _)| *n != k)
            .collect()
    };
    let missing = build_material(&spec("johnson_cook", &without("t_melt")))
        .unwrap_err()
        .to_string();
    assert!(missing.contains("t_melt"), "{missing}");
    let e = build_material(&spec(
        "johnson_cook",
        &jc_copper_keys(&[("taylor_quinney", 1.5)]),
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("taylor_quinney"), "{e}");
    // Without the thermal keys: one state variable, no temperature (the isothermal law).
    let iso: Vec<(&'static str, f64)> = jc_copper_keys(&[])
        .into_iter()
        .filter(|(n, _)| !["m", "t_room", "t_melt", "specific_heat"].contains(n))
        .collect();
    let iso = build_material(&spec("johnson_cook", &iso)).unwrap();
    assert_eq!((iso.n_state(), iso.temperature(&[0.0])), (1, None));
}
