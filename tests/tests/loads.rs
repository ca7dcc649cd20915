//! Load curves and pressure loads (docs/scene.md `curve`, `gravity_curve`, `[[load]]`), at np 1
//! and 3: a clamped plate's static deflection under a ramped pressure against Kirchhoff, a
//! velocity ramp's displacement against the curve's integral, ramped gravity's momentum
//! against m g times the curve's integral, the energy balance of each, the same bits at np 1
//! and 3 with a pressure load on faces the partition cuts, and the scene mistakes.
use std::path::{Path, PathBuf};
use tdyn_tests::*;

/// The last value of `name` in `dir`'s history.csv or probes.csv.
fn last(dir: &Path, file: &str, name: &str) -> f64 {
    let (h, rows) = read_csv(&dir.join(file));
    *column(&h, &rows, name).last().unwrap()
}

/// The largest energy error of a run (history.csv).
fn max_energy_error(dir: &Path) -> f64 {
    let (h, rows) = read_csv(&dir.join("history.csv"));
    column(&h, &rows, "energy_error")
        .into_iter()
        .fold(0.0, f64::max)
}

/// The plate's mean centre deflection (downwards positive) over the hold, from 2 ms after the
/// ramp's end (0.036 s) to the end (the reference's window), m: probes.csv of `out`.
fn held_deflection(out: &Path) -> f64 {
    let (h, rows) = read_csv(&out.join("probes.csv"));
    let (time, w) = (
        column(&h, &rows, "time"),
        column(&h, &rows, "centre.displacement_z"),
    );
    let hold: Vec<f64> = time
        .iter()
        .zip(&w)
        .filter(|(t, _)| (0.038..=0.048).contains(*t))
        .map(|(_, w)| -w)
        .collect();
    hold.iter().sum::<f64>() / hold.len() as f64
}

/// The clamped plate (scenes/kirchhoff_plate.toml, N = 10, M = 3) under a pressure ramped over
/// about eight periods and held: the mean of the centre's deflection over the hold against
/// Kirchhoff's w = alpha q a^4 / D (validation/kirchhoff_plate/reference.toml: alpha = 0.00126,
/// Timoshenko & Woinowsky-Krieger table 35) within 3 %; the load's work booked in
/// external_work keeps the energy balance; and np 3 gives np 1's bits (history.csv, probes.csv
/// and fields.h5: the faces' nodal forces summed in key order over the ranks sharing a node).
#[test]
fn clamped_plate_under_ramped_pressure_deflects_as_kirchhoff_says() {
    let scene = root().join("scenes/kirchhoff_plate.toml");
    let want = reference_value("kirchhoff_plate", "centre deflection");
    // The reference from its formula, so the file's number is checked too.
    let (e, nu, t, a, q): (f64, f64, f64, f64, f64) = (E, NU, 0.025, 1.0, 1.0e4);
    let d = e * t * t * t / (12.0 * (1.0 - nu * nu));
    let kirchhoff = 0.00126 * q * a.powi(4) / d;
    assert!(
        (want / kirchhoff - 1.0).abs() < 1e-4,
        "reference.toml's {want:e} m against alpha q a^4 / D = {kirchhoff:e} m"
    );
    let mut outs = Vec::new();
    for np in [1, 3] {
        let out = workdir(&format!("loads_plate_np{np}")).join("out");
        run_ok(np, &scene, &out);
        let mean = held_deflection(&out);
        let err = mean / want - 1.0;
        assert!(
            err.abs() < 0.03,
            "np {np}: centre deflection {mean:e} m against Kirchhoff {want:e} m: {:.2} % (allowed 3 %)",
            100.0 * err
        );
        let ee = max_energy_error(&out);
        assert!(
            ee < 1e-4,
            "np {np}: energy error {ee:e} (the pressure's work is external work; allowed 1e-4)"
        );
        outs.push(out);
    }
    if let Err(e) = fields_differ(&outs[0], &outs[1]) {
        panic!("np 3 against np 1: fields.h5 {e} (same bits expected)");
    }
    for file in ["history.csv", "probes.csv"] {
        let bad = csv_columns_differ(&outs[0], &outs[1], file, &[]);
        assert!(
            bad.is_empty(),
            "np 3 against np 1: {file} columns differ (column, first row): {bad:?}"
        );
    }
}

/// The clamped plate of the test above in implicit mode (`mode = "implicit"`, dt = 1 ms,
/// about a fifth of the first period: Newmark's average acceleration, the load on the faces at
/// each Newton iterate's positions): the centre's mean deflection over the same hold against
/// Kirchhoff within 3 % (measured -0.27 %), the energy balance to 1e-6 (Newmark conserves it;
/// measured 4e-10), and np 3 gives np 1's bits.
#[test]
fn implicit_clamped_plate_under_ramped_pressure_deflects_as_kirchhoff_says() {
    let want = reference_value("kirchhoff_plate", "centre deflection");
    let dir = workdir("loads_plate_implicit");
    let scene = implicit_plate_scene(&dir);
    let mut outs = Vec::new();
    for np in [1, 3] {
        let out = dir.join(format!("np{np}"));
        run_ok(np, &scene, &out);
        let mean = held_deflection(&out);
        let err = mean / want - 1.0;
        assert!(
            err.abs() < 0.03,
            "implicit np {np}: centre deflection {mean:e} m against Kirchhoff {want:e} m: {:.2} % (allowed 3 %)",
            100.0 * err
        );
        let ee = max_energy_error(&out);
        assert!(
            ee < 1e-6,
            "implicit np {np}: energy error {ee:e} (the pressure's work is external work; allowed 1e-6)"
        );
        outs.push(out);
    }
    for file in ["history.csv", "probes.csv"] {
        let bad = csv_columns_differ(&outs[0], &outs[1], file, &[]);
        assert!(
            bad.is_empty(),
            "implicit np 3 against np 1: {file} columns differ (column, first row): {bad:?}"
        );
    }
}

/// The bar (tests' bar scene, 20 elements) driven at its left end by v(t) = 2 m/s times the
/// curve 0 -> 1 over 0.1 ms, then 1 to 0.15 ms, then down to 0.5 at 0.2 ms and held, to
/// 0.3 ms with the stable step (the curve's points fall inside steps): the left face's
/// displacement is 2 m/s times the curve's integral (by hand: 0.05 + 0.05 + 0.0375 + 0.05 =
/// 0.1875 ms), exact to round-off (1e-12 relative), since the prescribed velocity of each
/// step is the curve's mean over it; the energy balance holds with the reaction's work.
///
/// The same in implicit mode (Newmark, a fixed step of 2 us: the prescribed increment is dt v
/// times the curve's mean over the step).
#[test]
fn velocity_ramp_moves_the_driven_nodes_by_the_curves_integral() {
    let integral = 0.1875e-3;
    let v = 2.0;
    let modes = [
        ("explicit", "end_time = 3.0e-4\nhistory_every = 1.0e-5"),
        (
            "implicit",
            "end_time = 3.0e-4\nhistory_every = 1.0e-5\nmode = \"implicit\"\ndt = 2.0e-6",
        ),
    ];
    for ((mode, run_keys), np) in modes.iter().flat_map(|m| [(m, 1), (m, 3)]) {
        let np: usize = np;
        let dir = workdir(&format!("loads_velocity_{mode}_np{np}"));
        let scene = bar_scene(
            &dir,
            20,
            run_keys,
            "[[boundary]]\ngroup = \"left\"\nkind = \"velocity\"\nvelocity = [2.0, 0.0, 0.0]\n\
             curve = [[0.0, 0.0], [1.0e-4, 1.0], [1.5e-4, 1.0], [2.0e-4, 0.5]]\n\n\
             [[probe]]\nname = \"end\"\npoint = [0.0, 0.025, 0.025]\nfields = [\"displacement_x\", \"velocity_x\"]\n",
        );
        let out = dir.join("out");
        run_ok(np, &scene, &out);
        let u = last(&out, "probes.csv", "end.displacement_x");
        let want = v * integral;
        assert!(
            (u / want - 1.0).abs() < 1e-12,
            "{mode} np {np}: driven end moved {u:e} m, v times the curve's integral {want:e} m (round-off expected)"
        );
        // After the last point the velocity is held at 0.5 v.
        let vel = last(&out, "probes.csv", "end.velocity_x");
        assert!(
            (vel - 0.5 * v).abs() < 1e-12,
            "{mode} np {np}: driven end's final velocity {vel} m/s, the curve's last value times v = {} m/s",
            0.5 * v
        );
        // From rest the energies grow from zero and the balance's start-up error falls as
        // dt/t (1.6 % of the energy at step 3, 0.3 % at step 10): judged from 50 us (12 steps).
        let (h, rows) = read_csv(&out.join("history.csv"));
        let (time, err) = (column(&h, &rows, "time"), column(&h, &rows, "energy_error"));
        let ee = time
            .iter()
            .zip(&err)
            .filter(|(t, _)| **t >= 5.0e-5)
            .fold(0.0f64, |m, (_, e)| m.max(*e));
        assert!(
            ee < 3e-3,
            "{mode} np {np}: energy error {ee:e} after 50 us with the reaction's work (allowed 3e-3)"
        );
    }
}

/// A free steel bar (the tests' bar, its lateral symmetry planes parallel to x) and a free
/// water cloud (SPH) under gravity g = 100 m/s^2 along x scaled by 0 -> 1 over 0.1 ms, then
/// down to 0.5 at 0.2 ms and held, to 0.3 ms with a fixed step of 1 us (the curve's points on
/// steps): the total momentum along x is (m_bar + m_cloud) g times the curve's integral (by
/// hand: 0.05 + 0.075 + 0.05 = 0.175 ms) to 1e-9 (the trapezoid rule of the velocity update is
/// exact on each linear piece); gravity's work keeps the energy balance.
#[test]
fn ramped_gravity_gives_the_momentum_of_its_integral() {
    let integral = 0.175e-3;
    let g = 100.0;
    for np in [1, 3] {
        let dir = workdir(&format!("loads_gravity_np{np}"));
        let scene = gravity_scene(&dir);
        let out = dir.join("out");
        run_ok(np, &scene, &out);
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                .unwrap();
        let m_bar = RHO * 1.0 * 0.05 * 0.05;
        // The cloud: 4 x 4 x 4 particles of 1000 kg/m^3 x (0.005 m)^3.
        let m_cloud = 64.0 * 1000.0 * 0.005f64.powi(3);
        if let Some(m) = r["mass"].as_f64() {
            assert!(
                (m / (m_bar + m_cloud) - 1.0).abs() < 1e-9,
                "np {np}: report.json mass {m} kg, by hand {} kg",
                m_bar + m_cloud
            );
        }
        let p = last(&out, "history.csv", "momentum_x");
        let want = (m_bar + m_cloud) * g * integral;
        assert!(
            (p / want - 1.0).abs() < 1e-9,
            "np {np}: momentum {p:e} kg m/s, m g times the curve's integral {want:e} (allowed 1e-9)"
        );
        let ee = max_energy_error(&out);
        assert!(
            ee < 1e-3,
            "np {np}: energy error {ee:e} with gravity's work (allowed 1e-3)"
        );
    }
}

/// The free bar of the test above alone in implicit mode (dt = 10 us, the curve's points on
/// steps): Newmark's velocity update is the trapezoid of the accelerations, exact on each linear
/// piece of the curve, so the momentum along x is m_bar g times the curve's integral to 1e-9,
/// and gravity's work (the trapezoid of g(t(n)) and g(t(n+1))) keeps the energy balance.
#[test]
fn implicit_ramped_gravity_gives_the_momentum_of_its_integral() {
    let (integral, g) = (0.175e-3, 100.0);
    for np in [1, 3] {
        let dir = workdir(&format!("loads_gravity_implicit_np{np}"));
        let scene = bar_scene(
            &dir,
            10,
            "end_time = 3.0e-4\nmode = \"implicit\"\ndt = 1.0e-5\nhistory_every = 1.0e-5",
            "",
        );
        let text = std::fs::read_to_string(&scene).unwrap().replace(
            "title = \"test bar\"\n",
            "title = \"test bar\"\ngravity = [100.0, 0.0, 0.0]\n\
             gravity_curve = [[0.0, 0.0], [1.0e-4, 1.0], [2.0e-4, 0.5]]\n",
        );
        std::fs::write(&scene, text).unwrap();
        let out = dir.join("out");
        run_ok(np, &scene, &out);
        let m_bar = RHO * 1.0 * 0.05 * 0.05;
        let p = last(&out, "history.csv", "momentum_x");
        let want = m_bar * g * integral;
        assert!(
            (p / want - 1.0).abs() < 1e-9,
            "implicit np {np}: momentum {p:e} kg m/s, m g times the curve's integral {want:e} (allowed 1e-9)"
        );
        let ee = max_energy_error(&out);
        assert!(
            ee < 1e-6,
            "implicit np {np}: energy error {ee:e} with gravity's work (allowed 1e-6)"
        );
    }
}

/// The gravity test's scene: the bar and a water cloud beside it (not touching, no contact).
fn gravity_scene(dir: &Path) -> PathBuf {
    let scene = bar_scene(
        dir,
        10,
        "end_time = 3.0e-4\ndt = 1.0e-6\nhistory_every = 1.0e-5",
        "[[material]]\nname = \"water\"\nmodel = \"fluid\"\ndensity = 1000.0\n\
         eos = { kind = \"tait\", rho0 = 1000.0, sound_speed = 50.0, gamma = 7.0 }\n\n\
         [[particles]]\nname = \"cloud\"\nmaterial = \"water\"\n\
         region = { box = { min = [0.0, 0.2, 0.0], max = [0.02, 0.22, 0.02] } }\n\
         spacing = 0.005\nh_factor = 1.2\n",
    );
    let text = std::fs::read_to_string(&scene).unwrap().replace(
        "title = \"test bar\"\n",
        "title = \"test bar\"\ngravity = [100.0, 0.0, 0.0]\n\
         gravity_curve = [[0.0, 0.0], [1.0e-4, 1.0], [2.0e-4, 0.5]]\n",
    );
    std::fs::write(&scene, text).unwrap();
    scene
}

/// A bar scene with a load, changed by `mutate`, must fail at np 2 with a line naming the file
/// and containing `needle`.
fn expect_error(name: &str, mutate: impl Fn(String) -> String, needle: &str) {
    let dir = workdir(&format!("loads_bad_{name}"));
    let scene = bar_scene(
        &dir,
        4,
        "end_time = 1.0e-5",
        "[[boundary]]\ngroup = \"left\"\nkind = \"fixed\"\n\n\
         [[load]]\ngroup = \"right\"\npressure = 1.0e6\ncurve = [[0.0, 0.0], [1.0e-5, 1.0]]\n",
    );
    let text = mutate(std::fs::read_to_string(&scene).unwrap());
    std::fs::write(&scene, text).unwrap();
    assert_scene_refused(name, &scene, &dir.join("out"), needle);
}

#[test]
fn curve_and_load_mistakes_give_clear_messages() {
    let curve = "curve = [[0.0, 0.0], [1.0e-5, 1.0]]";
    expect_error(
        "decreasing_times",
        |s| s.replace(curve, "curve = [[0.0, 0.0], [2.0e-5, 1.0], [1.0e-5, 0.5]]"),
        "load[0].curve[2]: times must increase strictly",
    );
    expect_error(
        "empty_curve",
        |s| s.replace(curve, "curve = []"),
        "load[0].curve: expected at least one point",
    );
    expect_error(
        "negative_time",
        |s| s.replace(curve, "curve = [[-1.0e-5, 0.0], [1.0e-5, 1.0]]"),
        "load[0].curve[0]: expected a time >= 0",
    );
    expect_error(
        "unknown_group",
        |s| s.replace("group = \"right\"", "group = \"lid\""),
        "load[0].group: no physical surface \"lid\"",
    );
    expect_error(
        "volume_group",
        |s| s.replace("group = \"right\"", "group = \"bar\""),
        "load[0].group: \"bar\" is a physical volume",
    );
    expect_error(
        "gravity_curve_empty",
        |s| {
            s.replace(
                "title = \"test bar\"\n",
                "title = \"test bar\"\ngravity_curve = []\n",
            )
        },
        "gravity_curve: expected at least one point",
    );
    // A gravity_curve without gravity scaled nothing and ran without a word.
    expect_error(
        "gravity_curve_without_gravity",
        |s| {
            s.replace(
                "title = \"test bar\"\n",
                "title = \"test bar\"\ngravity_curve = [[0.0, 0.0], [1.0e-5, 1.0]]\n",
            )
        },
        "gravity_curve: a curve scales gravity, which is zero here: give gravity = [x, y, z]",
    );
    // gravity written under [run] (after a table header a key belongs to that table): the
    // message says it is a top-level key and where it goes.
    expect_error(
        "gravity_under_run",
        |s| s.replace("[run]\n", "[run]\ngravity = [0.0, 0.0, -9.81]\n"),
        "run.gravity: unknown field `gravity`",
    );
    expect_error(
        "gravity_curve_under_run",
        |s| s.replace("[run]\n", "[run]\ngravity_curve = [[0.0, 1.0]]\n"),
        "gravity_curve is a top-level key: write it before the first [table]",
    );
    expect_error(
        "curve_on_fixed",
        |s| {
            s.replace(
                "kind = \"fixed\"\n",
                "kind = \"fixed\"\ncurve = [[0.0, 1.0]]\n",
            )
        },
        "only kind = \"velocity\" takes a curve",
    );
}

/// The default implicit solver's coarse grid (fe_petsc `implicit::coarse`: CG preconditioned
/// by the diagonal plus a trilinear coarse-grid correction) keeps its iteration count from
/// growing with the mesh, as a two-level method does (Toselli & Widlund 2005, ch. 2: the
/// condition number bounded through the coarse cells' size over the elements', not the
/// elements' count). The implicit clamped plate at N = 10 and at N = 20 elements along the
/// quarter's side (4 times the elements, half their size), np 2: the CG iterations per Newton
/// solve at N = 20 at most 1.5 times N = 10's (measured 193 and 74: the finer elements are
/// also less flat; the diagonal alone took 939 and 971, 4.9 and 13 times as many), and the
/// deflection against Kirchhoff within 3 % at both.
#[test]
fn implicit_iterations_do_not_grow_with_the_mesh() {
    let want = reference_value("kirchhoff_plate", "centre deflection");
    let dir = workdir("loads_plate_implicit_sizes");
    let scene = implicit_plate_scene(&dir);
    let mut per_solve = Vec::new();
    for n in [10, 20] {
        let out = dir.join(format!("n{n}"));
        run_ok_args(2, &scene, &out, &["--param", &format!("N={n}")]);
        let mean = held_deflection(&out);
        let err = mean / want - 1.0;
        assert!(
            err.abs() < 0.03,
            "N = {n}: centre deflection {mean:e} m against Kirchhoff {want:e} m: {:.2} % (3 %)",
            100.0 * err
        );
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                .unwrap();
        per_solve.push(report["ksp_iterations_per_solve"].as_f64().unwrap());
    }
    eprintln!(
        "CG iterations per solve: N = 10: {}, N = 20: {}",
        per_solve[0], per_solve[1]
    );
    assert!(
        per_solve[1] <= 1.5 * per_solve[0],
        "CG iterations per solve grow from {} to {} with the mesh (allowed 1.5 times)",
        per_solve[0],
        per_solve[1]
    );
}
