//! The implicit mode (Newmark average acceleration, Newton, PETSc KSP) under mpirun against
//! analytic answers, against the explicit mode, and across rank counts.
//!
//! The scene: a steel bar (L = 1 m, 0.05 m square, 20 hexahedra along x) in uniaxial strain
//! (symmetry planes on the lateral faces), fixed at x = 0 and released moving at 1 m/s. Its
//! nodes move as a 1D chain with lumped masses, so two analytic references apply:
//!
//! - the continuum: period T = 4 L / c with c = sqrt((lambda + 2 mu) / rho) (the rod's
//!   fixed-free fundamental);
//! - the semi-discrete model (lumped-mass linear elements, h = L / N): its fundamental
//!   omega_h = (2 c / h) sin(pi h / (4 L)), mode shape sin(pi x / (2 L)) at the nodes
//!   (e.g. Hughes, *The Finite Element Method*, 2000, §9.2 for the chain's dispersion).
//!
//! Probes at the 21 node sections give the modal coordinate q1(t) = sum_j m_j sin(pi x_j / 2L)
//! u_j (masses m_j: 1, the free end 1/2), which holds the fundamental alone (the chain's modes
//! are mass-orthogonal). A linear integrator advances each mode independently as a sampled
//! sinusoid, q1(n+1) + q1(n-1) = 2 cos(omega dt) q1(n), so omega is measured from the record
//! by least squares on that recurrence, without interpolation. Newmark's average acceleration
//! lengthens the period: T = T_h x / atan(x), x = omega_h dt / 2 (Hughes §9.3), error
//! (omega dt)^2 / 12 to leading order.
use tdyn_tests::*;

/// Elements along the bar.
const N: usize = 20;
/// Bar length, m.
const L: f64 = 1.0;
/// Initial velocity, m/s.
const V0: f64 = 1.0;
/// Linear bulk-viscosity coefficient (docs/scene.md default): it lowers the explicit estimate.
const BV_LINEAR: f64 = 0.06;

/// The explicit stable limit the driver reports for this mesh (FB estimate for a cube of side
/// h: h / (c sqrt 3), times sqrt(1 + xi^2) - xi with xi the linear bulk-viscosity coefficient).
fn dt_limit() -> f64 {
    let h = L / N as f64;
    // The linear bulk viscosity damps a cube's highest mode (omega = 2 sqrt(3) c / h) with the
    // ratio xi = sqrt(3) b1 (hex.rs, `bulk_viscosity`).
    let xi = 3f64.sqrt() * BV_LINEAR;
    h / (c_dilatational() * 3f64.sqrt()) * ((1.0 + xi * xi).sqrt() - xi)
}

/// The continuum period 4 L / c.
fn period_analytic() -> f64 {
    4.0 * L / c_dilatational()
}

/// The semi-discrete (lumped-mass FE) fundamental period.
fn period_fe() -> f64 {
    let h = L / N as f64;
    let w = 2.0 * c_dilatational() / h * (std::f64::consts::PI * h / (4.0 * L)).sin();
    2.0 * std::f64::consts::PI / w
}

/// Newmark average acceleration's period for the semi-discrete fundamental at step dt.
fn period_newmark(dt: f64) -> f64 {
    let x = std::f64::consts::PI * dt / period_fe();
    period_fe() * x / x.atan()
}

/// What one run produced.
struct Vibration {
    time: Vec<f64>,
    /// Modal coordinate of the fundamental.
    q1: Vec<f64>,
    /// Tip displacement.
    tip: Vec<f64>,
    /// Largest energy error of the run.
    energy_error_max: f64,
    report: serde_json::Value,
    history: (Vec<String>, Vec<Vec<f64>>),
}

/// The vibration scene in `mode` with fixed step `dt` over `periods` periods, at np ranks.
fn vibration_scene(
    dir: &std::path::Path,
    mode: &str,
    dt: f64,
    periods: f64,
    extra_run: &str,
) -> std::path::PathBuf {
    let steps = (periods * period_analytic() / dt).round();
    let mut probes = String::new();
    for j in 0..=N {
        probes += &format!(
            "[[probe]]\nname = \"n{j}\"\npoint = [{}, 0.0, 0.0]\nfields = [\"displacement_x\"]\n",
            j as f64 * L / N as f64
        );
    }
    let scene = bar_scene(
        dir,
        N,
        &format!(
            "end_time = {:e}\nmode = \"{mode}\"\ndt = {dt:e}\n{extra_run}",
            steps * dt
        ),
        &format!("[[boundary]]\ngroup = \"left\"\nkind = \"fixed\"\n{probes}"),
    );
    let text = std::fs::read_to_string(&scene).unwrap().replace(
        "[[block]]\ngroup = \"bar\"\nmaterial = \"steel\"\n",
        &format!("[[block]]\ngroup = \"bar\"\nmaterial = \"steel\"\nvelocity = [{V0}, 0.0, 0.0]\n"),
    );
    std::fs::write(&scene, text).unwrap();
    scene
}

fn vibration(name: &str, np: usize, mode: &str, dt: f64, periods: f64) -> Vibration {
    vibration_with(name, np, mode, dt, periods, "")
}

/// As [`vibration`], with more `[run]` keys.
fn vibration_with(
    name: &str,
    np: usize,
    mode: &str,
    dt: f64,
    periods: f64,
    extra_run: &str,
) -> Vibration {
    let dir = workdir(name);
    let scene = vibration_scene(&dir, mode, dt, periods, extra_run);
    run_ok(np, &scene, &dir.join("out"));
    let (h, rows) = read_csv(&dir.join("out/probes.csv"));
    let time = column(&h, &rows, "time");
    let u: Vec<Vec<f64>> = (0..=N)
        .map(|j| column(&h, &rows, &format!("n{j}.displacement_x")))
        .collect();
    let q1 = (0..time.len())
        .map(|k| {
            (0..=N)
                .map(|j| {
                    let m = if j == N { 0.5 } else { 1.0 };
                    let x = j as f64 * L / N as f64;
                    m * (std::f64::consts::PI * x / (2.0 * L)).sin() * u[j][k]
                })
                .sum()
        })
        .collect();
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out/report.json")).unwrap())
            .unwrap();
    let history = read_csv(&dir.join("out/history.csv"));
    let energy_error_max = column(&history.0, &history.1, "energy_error")
        .into_iter()
        .fold(0.0, f64::max);
    Vibration {
        time,
        q1,
        tip: u[N].clone(),
        energy_error_max,
        report,
        history,
    }
}

/// The period of a sampled sinusoid from the recurrence q(n+1) + q(n-1) = 2 cos(w dt) q(n)
/// (least squares over the record; dt fixed).
fn measured_period(v: &Vibration) -> f64 {
    let q = &v.q1;
    let dt = v.time[1] - v.time[0];
    let (mut num, mut den) = (0.0, 0.0);
    for n in 1..q.len() - 1 {
        num += q[n] * (q[n + 1] + q[n - 1]);
        den += 2.0 * q[n] * q[n];
    }
    2.0 * std::f64::consts::PI * dt / (num / den).acos()
}

#[test]
fn vibration_period_order_and_energy() {
    let limit = dt_limit();
    let t_exact = period_analytic();
    // Fine steps: both modes within 1 % of 4 L / c (the semi-discrete model itself is
    // (pi h / 4L)^2 / 24 = 0.026 % long).
    let fine = 0.5 * limit;
    let ex = vibration("implicit_fine_explicit", 2, "explicit", fine, 2.0);
    let im = vibration("implicit_fine_implicit", 2, "implicit", fine, 2.0);
    let reported = ex.report["dt_stable_initial"].as_f64().unwrap();
    assert!(
        (reported - limit).abs() < 1e-9 * limit,
        "explicit stable limit: the driver reports {reported:e} s, the FB formula gives {limit:e} s"
    );
    for (name, v) in [("explicit", &ex), ("implicit", &im)] {
        let t = measured_period(v);
        assert!(
            (t / t_exact - 1.0).abs() < 0.01,
            "{name} at dt = 0.5 x limit: period {t:e} s vs 4L/c = {t_exact:e} s (1 %)"
        );
        println!(
            "{name} dt = {fine:.3e} s: period {t:.6e} s, error against 4L/c {:+.4} %, against the FE model {:+.4} %",
            100.0 * (t / t_exact - 1.0),
            100.0 * (t / period_fe() - 1.0)
        );
    }
    // Implicit above the explicit limit: the period error against the semi-discrete model
    // grows as dt^2 (fit over 2, 4, 8, 16 x the limit) and matches Newmark's x / atan(x).
    let factors = [2.0, 4.0, 8.0, 16.0];
    let mut pts = Vec::new();
    for f in factors {
        let dt = f * limit;
        let v = vibration(&format!("implicit_order_x{f}"), 1, "implicit", dt, 2.0);
        let t = measured_period(&v);
        let err = t / period_fe() - 1.0;
        let theory = period_newmark(dt) / period_fe() - 1.0;
        println!(
            "implicit dt = {f} x limit = {dt:.3e} s: period error {err:.4e} (Newmark theory {theory:.4e}), energy error max {:.2e}, Newton {} / step, KSP {} / solve",
            v.energy_error_max,
            v.report["newton_iterations_per_step"],
            v.report["ksp_iterations_per_solve"]
        );
        assert!(
            (err - theory).abs() < 0.02 * theory,
            "dt = {f} x limit: period error {err:e} vs Newmark's x/atan(x) - 1 = {theory:e} (2 % of it)"
        );
        // Energy: the scheme conserves a linear system's energy; what remains is the Newton
        // tolerance (1e-8 of the force scale) and KSP's (1e-10): allow 1e-6 of E0.
        assert!(
            v.energy_error_max < 1e-6,
            "dt = {f} x limit: energy error {:e} (limit 1e-6, solver tolerance)",
            v.energy_error_max
        );
        pts.push((dt.ln(), err.ln()));
    }
    let n = pts.len() as f64;
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (mx, my) = (sx / n, sy / n);
    let slope = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>()
        / pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum::<f64>();
    println!("implicit period error: measured order {slope:.3} (fit over dt = 2..16 x limit)");
    assert!(
        (1.7..=2.3).contains(&slope),
        "implicit period error order {slope:.3}: expected 2 (in [1.7, 2.3])"
    );
    // The energy of the fine implicit run, column by column: E(t) = E0 to the solver tolerance.
    let (h, rows) = &im.history;
    let ke = column(h, rows, "kinetic_energy");
    let ie = column(h, rows, "internal_energy");
    let hg = column(h, rows, "hourglass_energy");
    let w = column(h, rows, "external_work");
    let drift = (0..ke.len())
        .map(|i| (ke[i] + ie[i] + hg[i] - ke[0]).abs() / ke[0])
        .fold(0.0, f64::max);
    assert!(
        drift < 1e-6,
        "implicit energy drift {drift:e} of E0 over two periods (limit 1e-6)"
    );
    assert!(
        w.iter().all(|x| x.abs() < 1e-12 * ke[0]),
        "a fixed end does no work"
    );
    let kmin = ke.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(
        kmin < 0.2 * ke[0],
        "the kinetic energy swings into strain energy (min {kmin:e} of {:e})",
        ke[0]
    );
}

#[test]
fn explicit_and_implicit_agree_at_small_steps() {
    // Bulk viscosity off (it acts in explicit mode only and damps each mode by a ratio of
    // 0.06 omega / omega_max: 0.24 % for the fundamental here), so that the two runs differ in
    // time integration alone. At a tenth of the limit over one period the fundamental's
    // histories agree to 1e-4 of its amplitude and the tip's displacement (all modes, the
    // highest dephasing fastest) to 0.2 % of v L / c; the agreement improves as dt^2.
    let amp = V0 * L / c_dilatational();
    let no_bv = "bulk_viscosity = { linear = 0.0, quadratic = 0.0 }";
    let mut tip_diff = Vec::new();
    for f in [0.5, 0.1] {
        let dt = f * dt_limit();
        let ex = vibration_with(
            &format!("agree_explicit_x{f}"),
            2,
            "explicit",
            dt,
            1.0,
            no_bv,
        );
        let im = vibration_with(
            &format!("agree_implicit_x{f}"),
            2,
            "implicit",
            dt,
            1.0,
            no_bv,
        );
        assert_eq!(ex.time.len(), im.time.len());
        let qmax = ex.q1.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let dq = ex
            .q1
            .iter()
            .zip(&im.q1)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        let du = ex
            .tip
            .iter()
            .zip(&im.tip)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        println!(
            "dt = {f} x limit: fundamental differs by {:.2e} of its amplitude, tip by {:.2e} of v L / c",
            dq / qmax,
            du / amp
        );
        if f == 0.1 {
            assert!(
                dq < 1e-4 * qmax,
                "fundamental: explicit and implicit differ by {:e} of its amplitude (1e-4)",
                dq / qmax
            );
            assert!(
                du < 2e-3 * amp,
                "tip displacement: explicit and implicit differ by {:e} of v L / c (0.2 %)",
                du / amp
            );
        }
        tip_diff.push(du);
    }
    // Both schemes are second order: 5 times smaller steps, 25 times closer (at least 10).
    assert!(
        tip_diff[1] < 0.1 * tip_diff[0],
        "the tip histories converge to each other as dt^2: {tip_diff:?} at 0.5 and 0.1 x limit"
    );
}

#[test]
fn explicit_above_the_limit_is_refused_or_stopped_and_implicit_stays_bounded() {
    let limit = dt_limit();
    // Refused as given ...
    let dir = workdir("implicit_forced");
    let dt = 3.0 * limit;
    let scene = vibration_scene(&dir, "explicit", dt, 1.0, "");
    let o = run(2, &scene, &dir.join("refused"));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success(),
        "an explicit dt above the limit is refused"
    );
    assert!(
        err.contains("above the explicit stable limit") && err.contains("force_dt"),
        "the refusal names the limit and the way to force it: {err}"
    );
    // ... and, forced, stopped by the energy check with its message.
    let scene = vibration_scene(&dir, "explicit", dt, 1.0, "force_dt = true");
    let o = run(2, &scene, &dir.join("forced"));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "the forced run must stop");
    assert!(
        err.contains("passed run.max_energy_error")
            && err.contains("the explicit run is unstable")
            && err.contains("times the stable limit"),
        "stopped by the energy check with a clear message: {err}"
    );
    // The implicit run at 10 and 100 times that step (30 and 300 x the limit) stays bounded:
    // energy conserved to the solver tolerance, the tip within the continuum's amplitude
    // v L / c (+5 %).
    let amp = V0 * L / c_dilatational();
    for f in [10.0, 100.0] {
        let v = vibration(
            &format!("implicit_bounded_x{f}"),
            2,
            "implicit",
            f * dt,
            3.0,
        );
        let umax = v.tip.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        println!(
            "implicit at {f} x the refused step ({} steps): energy error max {:.2e}, tip max {:.4} of v L / c",
            v.time.len() - 1,
            v.energy_error_max,
            umax / amp
        );
        assert!(
            v.energy_error_max < 1e-6,
            "implicit at {f} x: energy error {:e} (1e-6)",
            v.energy_error_max
        );
        assert!(
            umax < 1.05 * amp,
            "implicit at {f} x: tip displacement {umax:e} m vs v L / c = {amp:e} m (+5 %)"
        );
    }
}

#[test]
fn rank_independence_of_the_implicit_solution() {
    // docs/scene.md's one answer: np 1, 2, 3, 4 at 4 x the explicit limit give history.csv and
    // probes.csv byte for byte (the default linear solve, `exact_cg`: canonical nodal sums and
    // exact dot products). A PETSc solver chosen with -pc_type (GAMG here) solves the same
    // equations to KSP's tolerance: its np 3 run agrees with np 1's to 1e-8 of each column's
    // scale (the Newton tolerance; E0 for the energies).
    let dt = 4.0 * dt_limit();
    let runs: Vec<Vibration> = (1..=4)
        .map(|np| vibration(&format!("implicit_ranks_np{np}"), np, "implicit", dt, 1.0))
        .collect();
    let bytes = |np: usize, file: &str| {
        std::fs::read(
            root()
                .join("target/test-runs")
                .join(format!("implicit_ranks_np{np}"))
                .join("out")
                .join(file),
        )
        .unwrap()
    };
    for np in 2..=4 {
        for file in ["history.csv", "probes.csv"] {
            assert!(
                bytes(np, file) == bytes(1, file),
                "np {np}: {file} is not byte-identical to np 1's"
            );
        }
        let r = &runs[np - 1].report;
        println!(
            "np {np}: Newton {} / step, CG {} / solve",
            r["newton_iterations_per_step"], r["ksp_iterations_per_solve"]
        );
    }
    let dir = workdir("implicit_ranks_gamg");
    let scene = vibration_scene(&dir, "implicit", dt, 1.0, "");
    run_ok_args(3, &scene, &dir.join("out"), &["-pc_type", "gamg"]);
    let (h, r) = read_csv(&dir.join("out/history.csv"));
    let (h1, r1) = &runs[0].history;
    assert_eq!(&h, h1);
    assert_eq!(r.len(), r1.len(), "GAMG took a different number of steps");
    let e0 = column(h1, r1, "kinetic_energy")[0];
    for (c, name) in h.iter().enumerate() {
        let scale = if name.contains("energy") && name != "energy_error" || name == "external_work"
        {
            e0
        } else if name == "energy_error" {
            1.0
        } else {
            r1.iter()
                .fold(0.0f64, |m, row| m.max(row[c].abs()))
                .max(1e-300)
        };
        for (a, b) in r.iter().zip(r1.iter()) {
            assert!(
                (a[c] - b[c]).abs() <= 1e-8 * scale,
                "GAMG np 3 vs exact CG np 1: {name} differs: {} vs {} (scale {scale:e}, tolerance 1e-8)",
                a[c],
                b[c]
            );
        }
    }
}

#[test]
fn compare_charts_both_modes_and_exits_0_on_unstable_runs() {
    // `tdyn compare` on the vibration scene at np 2, three steps: the CSV has a row per
    // (mode, step); explicit above the limit is refused then stopped as unstable (exit 0
    // all the same); implicit runs finish, with the period error growing with dt and within
    // 1 % of the analytic period at 0.9 x the limit (scene's [compare] reference_period).
    let dir = workdir("implicit_compare");
    let out = dir.join("cmp");
    // The scene as shipped, over two periods instead of five (test time).
    let geo = root().join("meshes/bar.geo").display().to_string();
    let text = std::fs::read_to_string(root().join("scenes/bar_vibration.toml"))
        .unwrap()
        .replace("end_time = 3.415e-3", "end_time = 1.366e-3")
        .replace("../meshes/bar.geo", &geo);
    let scene = dir.join("bar_vibration.toml");
    std::fs::write(&scene, text).unwrap();
    let o = mpirun(2, 600)
        .arg(tdyn())
        .arg("compare")
        .arg(&scene)
        .args(["--dt-factors", "0.9,10,30", "--out"])
        .arg(&out)
        .arg("--quiet")
        .output()
        .expect("mpirun");
    assert!(
        o.status.success(),
        "tdyn compare failed:\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    for f in ["compare.png", "compare.svg"] {
        let len = std::fs::metadata(out.join(f)).map(|m| m.len()).unwrap_or(0);
        assert!(len > 1000, "{f} drawn ({len} bytes)");
    }
    let text = std::fs::read_to_string(out.join("compare.csv")).unwrap();
    let rows: Vec<Vec<&str>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 6, "2 modes x 3 steps:\n{text}");
    let get = |mode: &str, k: usize| -> Vec<&str> {
        rows.iter().filter(|r| r[0] == mode).map(|r| r[k]).collect()
    };
    // Columns: mode,dt,dt_factor,steps,wall_s,loop_s,error,refused,unstable,status,...
    assert_eq!(get("explicit", 9), ["ok", "unstable", "unstable"], "{text}");
    assert_eq!(get("explicit", 7), ["false", "true", "true"], "{text}");
    assert_eq!(get("implicit", 9), ["ok", "ok", "ok"], "{text}");
    let err: Vec<f64> = get("implicit", 6)
        .iter()
        .map(|e| e.parse().unwrap())
        .collect();
    assert!(
        err[0] < 0.01,
        "implicit at 0.9 x limit: period error {} (1 %)",
        err[0]
    );
    assert!(
        err[0] < err[1] && err[1] < err[2],
        "the implicit period error grows with dt: {err:?}"
    );
}

#[test]
fn a_fixed_step_that_does_not_divide_the_end_time_ends_the_run_on_it() {
    // docs/scene.md: end_time is when the run stops and the state at end_time is written. A
    // fixed run.dt of 3e-5 s to 1e-3 s is 33 steps and a last one of 1e-5 s; 5e-3 s to 1e-3 s
    // is one step of 1e-3 s. The bar (free, no supports, moving at 1 m/s along x) translates
    // rigidly, so its displacement at the end is v t_end = 1e-3 m (analytic; within 1e-13 m,
    // the round-off of 1 m coordinates over a few dozen steps: with the whole last step it was
    // 1.02e-3 and 5e-3 m). Implicit and explicit alike (the
    // explicit fixed step 1e-7 s, below the stable limit, to 3.05e-6 s: 30 steps and a half).
    for (mode, dt, end, steps) in [
        ("implicit", 3e-5, 1e-3, 34.0),
        ("implicit", 5e-3, 1e-3, 1.0),
        ("explicit", 1e-7, 3.05e-6, 31.0),
    ] {
        let dir = workdir(&format!("fixed_dt_end_{mode}_{dt:e}"));
        let run = format!("end_time = {end:e}\nmode = \"{mode}\"\ndt = {dt:e}\n");
        let scene = bar_scene(
            &dir,
            4,
            &run,
            "[[probe]]\nname = \"tip\"\npoint = [1.0, 0.0, 0.0]\nfields = [\"displacement_x\"]\n",
        );
        let text = std::fs::read_to_string(&scene).unwrap().replace(
            "material = \"steel\"\n\n[[boundary]]",
            "material = \"steel\"\nvelocity = [1.0, 0.0, 0.0]\n\n[[boundary]]",
        );
        std::fs::write(&scene, text).unwrap();
        // np 1 and np 3 the same bytes (one answer), the np 1 run checked
        let out = run_np1_np3_same_bytes(&scene, &dir);
        let (h, rows) = read_csv(&out.join("history.csv"));
        let (t, step) = (column(&h, &rows, "time"), column(&h, &rows, "step"));
        assert_eq!(
            *step.last().unwrap(),
            steps,
            "{mode} dt {dt:e} to {end:e}: steps (the last shortened onto end_time)"
        );
        assert!(
            (t.last().unwrap() - end).abs() <= 1e-15 * end,
            "{mode} dt {dt:e}: the run ends at end_time {end:e}, not {}",
            t.last().unwrap()
        );
        let (ph, prow) = read_csv(&out.join("probes.csv"));
        let u = *column(&ph, &prow, "tip.displacement_x").last().unwrap();
        assert!(
            (u - end).abs() <= 1e-13,
            "{mode} dt {dt:e}: rigid translation v t_end = {end:e} m, got {u:e} (1e-13 m)"
        );
    }
}

/// A free steel cube (20 mm, 4^3 hexahedra) moving at 2 m/s along x, its face x = L loaded by
/// a pressure ramped from 0 to 1 kPa over the run (implicit, dt = 0.1 ms, 20 steps). The motion
/// is a rigid body's and the load tiny: the force scale F is about 1e-3 N, and rtol F is below
/// the residual's round-off (the increments of 0.2 mm cancel in the strain and inertia terms to
/// a few 1e-10 N); Newton must stop at its round-off floor, not fail.
///
/// References: momentum_x = M v0 - p0 A T / 2 (the ramp's impulse, a trapezoid, exact for a
/// linear curve), to 1e-6 of the impulse; momentum_y and _z zero to 1e-12 of M v0; one or two
/// Newton iterations a step (the stiffness is linear and the load small); the same bytes at
/// np 1 and np 3.
#[test]
fn a_free_cube_translating_under_a_small_ramped_pressure_converges_at_its_round_off() {
    let dir = workdir("implicit_translating_cube");
    let (a, rho, v0, p0, t_end) = (0.02, 7850.0, 2.0, 1.0e3, 2.0e-3);
    let scene = dir.join("cube.toml");
    std::fs::write(
        &scene,
        format!(
            r#"[run]
end_time = {t_end:e}
mode = "implicit"
dt = 1.0e-4
[[mesh]]
file = "{root}/meshes/bar.geo"
params = {{ L = {a}, A = {a}, N = 4, M = 4 }}
[[material]]
name = "steel"
model = "elastic"
density = {rho}
youngs_modulus = 200.0e9
poisson_ratio = 0.3
[[block]]
group = "bar"
material = "steel"
velocity = [{v0}, 0.0, 0.0]
[[load]]
group = "right"
pressure = {p0:e}
curve = [[0.0, 0.0], [{t_end:e}, 1.0]]
"#,
            root = root().display()
        ),
    )
    .unwrap();
    let out = run_np1_np3_same_bytes(&scene, &dir);
    let (h, rows) = read_csv(&out.join("history.csv"));
    let last = |name: &str| *column(&h, &rows, name).last().unwrap();
    let mass = rho * a * a * a;
    let impulse = p0 * a * a * t_end / 2.0;
    let px_exact = mass * v0 - impulse;
    assert!(
        (last("momentum_x") - px_exact).abs() < 1e-6 * impulse,
        "momentum_x {} against M v0 - p0 A T / 2 = {px_exact} (1e-6 of the impulse {impulse:e} N s)",
        last("momentum_x")
    );
    for c in ["momentum_y", "momentum_z"] {
        assert!(
            last(c).abs() < 1e-12 * mass * v0,
            "{c} {} against 0 (1e-12 of M v0)",
            last(c)
        );
    }
    assert!((last("time") - t_end).abs() < 1e-12 * t_end, "ended early");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let per_step = report["newton_iterations_per_step"].as_f64().unwrap();
    assert!(
        per_step <= 2.0,
        "{per_step} Newton iterations a step (a linear body under a small load: 1 or 2)"
    );
}
