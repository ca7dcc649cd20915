//! The validation suite (`tdyn validate`, validation/<case>/reference.toml) on its coarse meshes
//! (`--fast`) at np 1 and 3, and the analytic references of its new cases recomputed from their
//! formulas (a reference is a formula or a published number, never our own output).
use tdyn_tests::*;

/// Runs the fast suite on `cases` at np 1 and 3 and asserts that every judged measure passes;
/// the report's table is in the message when one does not.
fn passes_at_np1_and_np3(cases: &str) {
    for np in [1, 3] {
        let tag = format!("validate_{}_np{np}", cases.replace(',', "_"));
        let (ok, report) = validate_fast(cases, np, &tag);
        assert!(
            ok,
            "tdyn validate --fast --cases {cases} --np {np} failed:\n{report}"
        );
        assert!(
            report.contains("| pass |") && !report.contains("| FAIL"),
            "np {np}:\n{report}"
        );
    }
}

#[test]
fn elastic_wave_and_elastic_plastic_impact_pass_at_np1_and_np3() {
    passes_at_np1_and_np3("bar_wave,plastic_impact_1d");
}

/// The ball through the plate against OpenRadioss on the same mesh (the scene's, NP = 32):
/// the velocity drop and the failed elements within the case's 10 %.
#[test]
fn ball_perforation_against_openradioss_passes_at_np1_and_np3() {
    passes_at_np1_and_np3("ball_perforation");
}

#[test]
fn sod_and_the_liggghts_crosscheck_pass_at_np1_and_np3() {
    passes_at_np1_and_np3("sod,liggghts_random");
}

/// Issue 13's "done when": length within 2 % and foot radius within 5 % of the literature at
/// N = 6 (fails with the stiffness hourglass default: foot radius 17.7 % narrow).
#[test]
fn taylor_copper_bar_at_n6_within_the_literature() {
    passes_at_np1_and_np3("taylor_copper");
}

/// Johnson-Cook with thermal softening and adiabatic heating against two published codes: the
/// steel Taylor bar of the DynELA manual (validation/taylor_jc_steel: DynELA and
/// Abaqus/Explicit) at N = 6, at np 1 and 3: final length within 1 %, impact-face diameter
/// within 3 %, the centre element's temperature rise within 5 % and its plastic strain within
/// 8 % (measured 0.08 %, 0.7 %, 1.2 %, 1.4 %). The isothermal law misses the foot by 7.6 %
/// and the plastic strain by 23 %, so the thermal term is what passes.
#[test]
fn johnson_cook_thermal_taylor_bar_matches_dynela_and_abaqus() {
    passes_at_np1_and_np3("taylor_jc_steel");
}

/// Issue 30's "done when" on tetrahedra, as the hexahedral case above: the copper Taylor bar
/// on gmsh's default tetrahedra of size R/6 (validation/taylor_copper_tets, each tetrahedron
/// run as 4 hexahedra): length within 2 % and foot radius within 4 % of the literature at np 1
/// and 3; and the pressure in the foot free of checkerboarding: its scatter between face
/// neighbours (`foot_pressure_scatter`) at most `CHECKERBOARD_FACTOR` times the O-grid's
/// (scenes/taylor_copper.toml, N = 6). Ignored in `make test`: 68,285 steps of 35,336
/// hexahedra (133 s at np 2 on an idle 2-core AVX-512 Xeon; about twice that per rank count on
/// an AVX2 CPU or a loaded machine); the same bar on native tetrahedra runs in the suite (below);
/// `cargo test --release -p tdyn-tests --test validation tetrahedra -- --ignored`.
#[test]
#[ignore = "minutes per rank count: the split tetrahedral Taylor bar at np 1 and 3"]
fn taylor_copper_bar_on_tetrahedra_within_the_literature_without_checkerboard() {
    passes_full_at_np1_and_np3("taylor_copper_tets");
    no_checkerboard_in_the_foot("taylor_copper_tets", "taylor_copper_hex_pressure");
}

/// The np 3 validation run of the tetrahedral Taylor case `case` has a foot whose pressure
/// scatters between face neighbours at most `CHECKERBOARD_FACTOR` times the O-grid's
/// (scenes/taylor_copper.toml, N = 6, run at np 3 in workdir `tag`). The foot: the first 3 mm
/// above the impact face (the bulge is about 2 R0 = 6.4 mm high).
fn no_checkerboard_in_the_foot(case: &str, tag: &str) {
    let tets = root()
        .join(format!("target/test-runs/validate_{case}_np3"))
        .join(format!("{case}/N_6"));
    let dir = workdir(tag);
    run_ok(
        3,
        &root().join("scenes/taylor_copper.toml"),
        &dir.join("out"),
    );
    let (s_tets, s_hex) = (
        foot_pressure_scatter(&tets, 0.003),
        foot_pressure_scatter(&dir.join("out"), 0.003),
    );
    eprintln!("{case}: foot pressure scatter {s_tets:.3}, the O-grid's {s_hex:.3}");
    assert!(
        s_tets <= CHECKERBOARD_FACTOR * s_hex,
        "{case}: pressure scatter between neighbours in the foot: tetrahedra {s_tets:.3} vs hexahedra {s_hex:.3} (at most {CHECKERBOARD_FACTOR} times)"
    );
}

/// Issue 30's "done when" on native tetrahedra (`[run] tetrahedra = "nodal_pressure"`,
/// validation/taylor_copper_tets_nodal: the same gmsh tetrahedra of size R/6, each one element
/// with a nodal-averaged volumetric strain, fe_petsc/src/tet.rs): length within 2 % and foot
/// radius within 4 % of the literature at np 1 and 3 (measured: 21.507 mm, +0.3 %; 7.160 mm,
/// -0.1 %), and the foot's pressure free of checkerboarding against the O-grid's, as above
/// (measured: 1.32 times the O-grid's scatter). About 40 s per rank count on 2 cores.
#[test]
fn taylor_copper_bar_on_native_tetrahedra_within_the_literature_without_checkerboard() {
    passes_at_np1_and_np3("taylor_copper_tets_nodal");
    no_checkerboard_in_the_foot(
        "taylor_copper_tets_nodal",
        "taylor_copper_hex_pressure_native",
    );
}

/// How much rougher the tetrahedra's pressure may be than the O-grid's, measured as
/// `foot_pressure_scatter`. A checkerboard (pressures alternating between neighbours, the mode a
/// locking or under-stabilised tetrahedron shows) gives a scatter of order 1, a smooth field
/// the pressure's gradient times the element size over the pressure: the tetrahedra's
/// sub-hexahedra are about half the O-grid's cells, so a smooth field scatters less, and a
/// factor of 2 leaves room for the unstructured mesh's irregular sizes but none for a
/// checkerboard.
const CHECKERBOARD_FACTOR: f64 = 2.0;

/// The scatter of the final frame's element pressure between face neighbours in the foot
/// (element centroids below `z_max`, m): the RMS of the differences over the pairs of elements
/// sharing a face, over the RMS of the pressure there.
fn foot_pressure_scatter(out: &std::path::Path, z_max: f64) -> f64 {
    let fr = tdyn_tests::frames::read_frames(out);
    let p: Vec<f64> = tdyn_tests::frames::last_frame(out)
        .dataset("elements/pressure")
        .unwrap()
        .read_raw()
        .unwrap();
    let pos = fr.positions.last().unwrap();
    // An element's distinct nodes: a native tetrahedron is written as the collapsed
    // hexahedron (a, b, c, c, d, d, d, d).
    let distinct = |c: &[usize; 8]| {
        let mut v = c.to_vec();
        v.sort_unstable();
        v.dedup();
        v
    };
    let foot: Vec<bool> = fr
        .connectivity
        .iter()
        .map(|c| {
            let d = distinct(c);
            d.iter().map(|&n| pos[n][2]).sum::<f64>() / (d.len() as f64) < z_max
        })
        .collect();
    // Faces by their distinct nodes (a collapsed hexahedron's triangles have 3; its edge and
    // point faces are no faces).
    let mut by_face: std::collections::HashMap<Vec<usize>, usize> = Default::default();
    let (mut diff2, mut pairs) = (0.0, 0usize);
    for (e, c) in fr.connectivity.iter().enumerate().filter(|(e, _)| foot[*e]) {
        for face in tdyn_tests::frames::FACES {
            let mut key: Vec<usize> = face.iter().map(|&k| c[k]).collect();
            key.sort_unstable();
            key.dedup();
            if key.len() < 3 {
                continue;
            }
            if let Some(other) = by_face.insert(key, e) {
                diff2 += (p[e] - p[other]).powi(2);
                pairs += 1;
            }
        }
    }
    let (sum2, n) = p
        .iter()
        .zip(&foot)
        .filter(|(_, &f)| f)
        .fold((0.0, 0usize), |(s, n), (q, _)| (s + q * q, n + 1));
    assert!(pairs > 0 && n > 0, "the foot has neighbouring elements");
    (diff2 / pairs as f64).sqrt() / (sum2 / n as f64).sqrt()
}

/// The foot's pressure scatter of existing runs, by hand: `TDYN_OUT=DIR1,DIR2 cargo test
/// --release -p tdyn-tests --test validation foot_pressure_scatter_of_runs -- --ignored
/// --nocapture`.
#[test]
#[ignore]
fn foot_pressure_scatter_of_runs() {
    for dir in std::env::var("TDYN_OUT").unwrap().split(',') {
        let s = foot_pressure_scatter(std::path::Path::new(dir), 0.003);
        println!("{dir}: foot pressure scatter {s:.4}");
    }
}

/// Issue 30's "done when": the cantilever meshed with gmsh's default tetrahedra of size
/// depth/4 (validation/cantilever_tets): first bending period within 5 % of Timoshenko at np 1
/// and 3. Ignored in `make test`: about 135,000 steps of 14,400 hexahedra, minutes per rank
/// count on 2 cores. (The native tetrahedra's cantilever, `scenes/cantilever_tets_nodal.toml`,
/// runs in 16 s at np 2 but is 6.0 % fast: docs/element.md "Native tetrahedra".)
#[test]
#[ignore = "minutes per rank count: the split tetrahedral cantilever at np 1 and 3"]
fn cantilever_on_tetrahedra_bending_period_within_timoshenko() {
    passes_full_at_np1_and_np3("cantilever_tets");
}

/// [`passes_at_np1_and_np3`] for a case not run under `--fast` (its full ladder, 1 h limit).
fn passes_full_at_np1_and_np3(cases: &str) {
    for np in [1, 3] {
        let tag = format!("validate_{}_np{np}", cases.replace(',', "_"));
        let (ok, report) = validate(cases, np, &tag, false, 3600);
        assert!(
            ok && report.contains("| pass |") && !report.contains("| FAIL"),
            "tdyn validate --cases {cases} --np {np} failed:\n{report}"
        );
    }
}

/// Issue 13's "done when": first bending period within 3 % of Timoshenko with 2 elements
/// through the depth, 1.5 % with 4, default settings (fails with the stiffness hourglass
/// default at 2 elements: +3.9 %).
#[test]
fn cantilever_bending_period_within_timoshenko() {
    passes_at_np1_and_np3("cantilever");
}

/// Planar Noh: density 4, pressure 4/3, shock speed 1/3 within the reference file's
/// tolerances.
#[test]
fn noh_planar_shock_state_and_speed() {
    passes_at_np1_and_np3("noh_planar");
}

/// The lowest clamped-free frequency of a Timoshenko beam (rad/s) by shooting: integrate
/// EI psi'' = -(kGA (w' - psi) + rho I w^2 psi), kGA w'' = kGA psi' - rho A w^2 w from the clamped
/// end (w = psi = 0) with unit w' or unit psi', and find where the free-end conditions (psi' = 0,
/// w' - psi = 0) admit a solution (the 2 x 2 determinant's root, bisection from below the
/// Euler-Bernoulli value).
fn timoshenko_clamped_free(e: f64, nu: f64, rho: f64, l: f64, b: f64, h: f64) -> f64 {
    let g = e / (2.0 * (1.0 + nu));
    let (a, i) = (b * h, b * h.powi(3) / 12.0);
    // Cowper 1966, rectangle.
    let k = 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu);
    let det = |w: f64| {
        let f = |y: [f64; 4]| {
            let [ww, wp, p, pp] = y;
            [
                wp,
                pp - rho * a * w * w * ww / (k * g * a),
                pp,
                -(k * g * a * (wp - p) + rho * i * w * w * p) / (e * i),
            ]
        };
        let shoot = |y0: [f64; 4]| {
            const STEPS: usize = 4000;
            let dx = l / STEPS as f64;
            let mut y = y0;
            let add = |y: [f64; 4], d: [f64; 4], s: f64| std::array::from_fn(|j| y[j] + s * d[j]);
            for _ in 0..STEPS {
                let k1 = f(y);
                let k2 = f(add(y, k1, dx / 2.0));
                let k3 = f(add(y, k2, dx / 2.0));
                let k4 = f(add(y, k3, dx));
                y = std::array::from_fn(|j| {
                    y[j] + dx / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
                });
            }
            (y[3], y[1] - y[2])
        };
        let (a1, b1) = shoot([0.0, 1.0, 0.0, 0.0]);
        let (a2, b2) = shoot([0.0, 0.0, 0.0, 1.0]);
        a1 * b2 - b1 * a2
    };
    let euler_bernoulli = 1.875_104_068_7f64.powi(2) * (e * i / (rho * a * l.powi(4))).sqrt();
    let (mut lo, mut hi) = (0.9 * euler_bernoulli, 1.0001 * euler_bernoulli);
    let f_lo = det(lo);
    assert!(f_lo * det(hi) < 0.0, "no root bracketed");
    for _ in 0..60 {
        let m = 0.5 * (lo + hi);
        if (det(m) > 0.0) == (f_lo > 0.0) {
            lo = m;
        } else {
            hi = m;
        }
    }
    0.5 * (lo + hi)
}

#[test]
fn reference_values_follow_their_formulas() {
    use std::f64::consts::PI;
    // Cantilever (scenes/cantilever.toml): steel, L = 1 m, h = b = 0.1 m.
    let omega = timoshenko_clamped_free(E, NU, RHO, 1.0, 0.1, 0.1);
    let t = reference_value("cantilever", "first bending period");
    assert!(
        (2.0 * PI / omega - t).abs() < 1e-4 * t,
        "Timoshenko T1 = {} s, reference.toml {t} s (1e-4)",
        2.0 * PI / omega
    );
    // Uniaxial-strain elastic-plastic impact (scenes/plastic_impact_1d.toml).
    let (sy, hm, v0, x) = (350.0e6, 1.0e9, 50.0, 1.5);
    let mu = E / (2.0 * (1.0 + NU));
    let lambda = E * NU / ((1.0 + NU) * (1.0 - 2.0 * NU));
    let k = lambda + 2.0 * mu / 3.0;
    let c_l = ((lambda + 2.0 * mu) / RHO).sqrt();
    let g_t = mu * hm / (hm + 3.0 * mu);
    let c_p = ((k + 4.0 / 3.0 * g_t) / RHO).sqrt();
    let hel = (1.0 - NU) / (1.0 - 2.0 * NU) * sy;
    let s2 = hel + RHO * c_p * (v0 - hel / (RHO * c_l));
    let case = "plastic_impact_1d";
    for (name, exact) in [
        ("precursor arrival (half HEL)", x / c_l),
        ("precursor plateau (HEL)", -hel),
        ("plastic wave arrival (mid-level)", x / c_p),
        ("plastic plateau", -s2),
    ] {
        let r = reference_value(case, name);
        assert!(
            (r - exact).abs() < 1e-4 * exact.abs(),
            "{case}: {name}: reference.toml {r}, formula {exact} (1e-4)"
        );
    }
    // Planar Noh, gamma 5/3, rho0 = u0 = 1: the shock meets the gas from X = 0.6 at
    // X / (u_s + u0) with u_s = (gamma - 1)/2.
    let gamma: f64 = 5.0 / 3.0;
    for (name, exact) in [
        ("post-shock density", (gamma + 1.0) / (gamma - 1.0)),
        ("post-shock pressure", (gamma + 1.0) / 2.0),
        (
            "shock arrival at X = 0.6 (density 2.5)",
            0.6 / ((gamma - 1.0) / 2.0 + 1.0),
        ),
    ] {
        let r = reference_value("noh_planar", name);
        assert!(
            (r - exact).abs() < 1e-6 * exact,
            "noh_planar: {name}: reference.toml {r}, formula {exact}"
        );
    }
    // The elastic wave: x / c and -rho c v.
    let c = c_dilatational();
    let r = reference_value("bar_wave", "arrival at x = 0.5 m (velocity 0.5 m/s)");
    assert!((r - 0.5 / c).abs() < 1e-4 * r, "bar_wave arrival {r}");
    let r = reference_value("bar_wave", "stress behind the front");
    assert!((r + RHO * c).abs() < 1e-4 * RHO * c, "bar_wave stress {r}");
}
