//! `[[rigid_wall]]` in implicit mode (docs/scene.md): the nodes in contact held on the plane by an
//! active set inside Newton (fe_petsc/src/implicit/walls.rs). Each test compares with an answer
//! the implicit wall did not produce: the 1D elastic impact, the same bar on a bilateral
//! symmetry plane, the analytic column under its own weight, the bodies' momentum change. At
//! np 1 and 3, where the answer must also be the same bits.
use std::path::{Path, PathBuf};
use tdyn_tests::*;

/// Every history.csv, reactions.csv and probes.csv column of `b` is the same bits as `a`'s.
fn same_bits(a: &Path, b: &Path, what: &str) {
    for file in ["history.csv", "reactions.csv", "probes.csv"] {
        let d = csv_columns_differ(a, b, file, &[]);
        assert!(d.is_empty(), "{what}: {file} columns differ: {d:?}");
    }
}

#[test]
fn an_elastic_bar_bounces_off_an_implicit_wall_as_the_1d_impact() {
    // The bar at V = 1 m/s onto a rigid wall at x = 0 (its face starts on it), uniaxial strain:
    // the 1D elastic impact (e.g. Graff, Wave Motion in Elastic Solids, 1975, §2.4) holds the
    // face for 2 L / c (c the dilatational speed), with the wall's force rho c V A, and sends the
    // bar back at V: momentum -m V to +m V. The wall must let go (the active set's release).
    // Tolerances: the mean force over the contact within 2 % (Newmark's dispersion rings about
    // it); the release within 3 steps of 2 L / c; the rebound momentum within 4 % of m V: the
    // face nodes' arrival is inelastic (1 / (2N) of the kinetic energy, 1.25 % at N = 40) and
    // the discrete bar leaves ringing (measured -2.8 % at N = 40, dt = 2 us; -1.8 % at N = 80,
    // dt = 1 us; the explicit wall on the same mesh -5.3 %); the wall's impulse equals the bar's momentum change
    // to 1e-6 (the velocity update's part included); the energy balance, the walls' share in
    // contact_energy, to 1e-6.
    let (v, area, n) = (1.0, 0.05 * 0.05, 40);
    let c = c_dilatational();
    let t_c = 2.0 / c;
    let dt = 2.0e-6;
    let mass = RHO * area;
    let dir = workdir("implicit_wall_bounce");
    let mut first: Option<PathBuf> = None;
    for np in [1, 3] {
        let out = dir.join(format!("np{np}"));
        let scene = implicit_bar(
            &mkdir(&dir, &format!("scene_np{np}")),
            n,
            (dt, 5.0e-4),
            "velocity = [-1.0, 0.0, 0.0]",
            WALL_AT_0,
        );
        run_ok(np, &scene, &out);
        let (hr, rr) = read_csv(&out.join("reactions.csv"));
        let (t, fx) = (column(&hr, &rr, "time"), column(&hr, &rr, "target.force_x"));
        let amp = RHO * c * v * area;
        let during: Vec<f64> = t
            .iter()
            .zip(&fx)
            .filter(|(tt, _)| **tt > 0.05 * t_c && **tt < 0.95 * t_c)
            .map(|(_, f)| *f)
            .collect();
        let mean = during.iter().sum::<f64>() / during.len() as f64;
        assert!(
            (mean - amp).abs() < 0.02 * amp,
            "np {np}: the wall's mean force {mean:e} N vs rho c V A = {amp:e} N (2 %)"
        );
        let last_touch = t
            .iter()
            .zip(&fx)
            .filter(|(_, f)| **f != 0.0)
            .map(|(tt, _)| *tt)
            .fold(0.0, f64::max);
        assert!(
            (last_touch - t_c).abs() <= 3.0 * dt,
            "np {np}: the bar leaves the wall at {last_touch:e} s, 2 L / c = {t_c:e} s (3 steps)"
        );
        let (hh, rh) = read_csv(&out.join("history.csv"));
        let px = column(&hh, &rh, "momentum_x");
        let (p0, p1) = (px[0], *px.last().unwrap());
        assert!(
            (p0 + mass * v).abs() < 1e-9 * mass * v,
            "np {np}: initial momentum {p0:e}"
        );
        assert!(
            (p1 - mass * v).abs() < 0.04 * mass * v,
            "np {np}: rebound momentum {p1:e} kg m/s vs m V = {:e} (4 %)",
            mass * v
        );
        let j = impulse(&out, "target.force_x");
        assert!(
            (j - (p1 - p0)).abs() < 1e-6 * mass * v,
            "np {np}: the wall's impulse {j:e} N s vs the momentum change {:e} (1e-6)",
            p1 - p0
        );
        let err = column(&hh, &rh, "energy_error")
            .iter()
            .fold(0.0f64, |m, e| m.max(e.abs()));
        assert!(err < 1e-6, "np {np}: energy error {err:e} (1e-6)");
        let taken = *column(&hh, &rh, "contact_energy").last().unwrap();
        let k0 = 0.5 * mass * v * v;
        assert!(
            taken > 0.0 && taken < 0.03 * k0,
            "np {np}: the wall took {taken:e} J of {k0:e} J (the arrivals: about 1 / (2N))"
        );
        match &first {
            None => first = Some(out),
            Some(a) => same_bits(a, &out, "bouncing bar, np 3 against np 1"),
        }
    }
}

#[test]
fn a_column_on_an_implicit_wall_under_its_weight_is_the_symmetry_planes_and_the_analytic() {
    // The bar standing on a rigid wall at x = 0 with gravity -g x ramped over 20 ms (about 30
    // of its periods 4 L / c: quasi-static). Pressed everywhere on the wall, the bar meets the
    // bilateral symmetry plane's constraint: the two runs agree to the Newton tolerance (1e-6 of
    // the top's displacement). Against the analytic column in uniaxial strain, sigma = -rho g
    // (L - x), u(L) = -rho g L^2 / (2 M), M = lambda + 2 mu, within 1 % after the ramp (the
    // mesh's linear displacement per element: 0.02 % at N = 20; the ramp's left-over
    // oscillation); the wall's force equals the weight rho g A L within 1e-3.
    let (g, area, n) = (9.81, 0.05 * 0.05, 20);
    let m_mod = E * (1.0 - NU) / ((1.0 + NU) * (1.0 - 2.0 * NU));
    let u_top = -RHO * g / (2.0 * m_mod);
    let weight = RHO * area * g;
    let run_keys = |dir: &Path, support: &str| {
        let extra = format!(
            "{support}\n[[probe]]\nname = \"top\"\npoint = [1.0, 0.0, 0.0]\nfields = [\"displacement_x\"]\n"
        );
        let p = implicit_bar(dir, n, (2.5e-4, 0.03), "", &extra);
        let text = std::fs::read_to_string(&p).unwrap().replace(
            "[run]\n",
            "gravity = [-9.81, 0.0, 0.0]\ngravity_curve = [[0.0, 0.0], [0.02, 1.0]]\n[run]\n",
        );
        std::fs::write(&p, text).unwrap();
        p
    };
    let dir = workdir("implicit_wall_column");
    let plane = dir.join("plane");
    let support = "[[boundary]]\ngroup = \"left\"\nkind = \"symmetry\"\n";
    run_ok(1, &run_keys(&mkdir(&dir, "scene_plane"), support), &plane);
    let top = |out: &Path| {
        let (h, rows) = read_csv(&out.join("probes.csv"));
        (
            column(&h, &rows, "time"),
            column(&h, &rows, "top.displacement_x"),
        )
    };
    let (_, u_plane) = top(&plane);
    let mut first: Option<PathBuf> = None;
    for np in [1, 3] {
        let out = dir.join(format!("np{np}"));
        run_ok(
            np,
            &run_keys(&mkdir(&dir, &format!("scene_np{np}")), WALL_AT_0),
            &out,
        );
        let (t, u) = top(&out);
        let worst = u
            .iter()
            .zip(&u_plane)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            worst < 1e-6 * u_top.abs(),
            "np {np}: the top on the wall differs from the plane's by {worst:e} m (1e-6 of {u_top:e})"
        );
        let late: Vec<f64> = t
            .iter()
            .zip(&u)
            .filter(|(tt, _)| **tt > 0.022)
            .map(|(_, u)| *u)
            .collect();
        let mean = late.iter().sum::<f64>() / late.len() as f64;
        assert!(
            (mean - u_top).abs() < 0.01 * u_top.abs(),
            "np {np}: the top's displacement {mean:e} m vs -rho g L^2 / 2M = {u_top:e} m (1 %)"
        );
        let (hr, rr) = read_csv(&out.join("reactions.csv"));
        let (tr, fx) = (column(&hr, &rr, "time"), column(&hr, &rr, "target.force_x"));
        let f_late: Vec<f64> = tr
            .iter()
            .zip(&fx)
            .filter(|(tt, _)| **tt > 0.022)
            .map(|(_, f)| *f)
            .collect();
        let f = f_late.iter().sum::<f64>() / f_late.len() as f64;
        assert!(
            (f - weight).abs() < 1e-3 * weight,
            "np {np}: the wall carries {f:e} N, the weight is {weight:e} N (1e-3)"
        );
        match &first {
            None => first = Some(out),
            Some(a) => same_bits(a, &out, "column on a wall, np 3 against np 1"),
        }
    }
}

/// A free steel block (0.1 x 0.05 x 0.05 m, meshes/bar.geo, 4 x 2 x 2 elements) on a floor
/// `z = 0` with friction `mu`, under `gravity`, its block given `velocity`, in implicit mode
/// (dt = 10 us) to `end`, written into `dir`.
fn block_on_a_rough_floor(
    dir: &Path,
    mu: f64,
    gravity: [f64; 3],
    velocity: f64,
    end: f64,
) -> PathBuf {
    let meshes = root().join("meshes").display().to_string();
    let scene = dir.join("block.toml");
    std::fs::write(
        &scene,
        format!(
            "title = \"a block on a rough floor, implicit\"\ngravity = [{:e}, {:e}, {:e}]\n\
             [run]\nend_time = {end:e}\nmode = \"implicit\"\ndt = 1.0e-5\n\
             [[mesh]]\nfile = \"{meshes}/bar.geo\"\nparams = {{ L = 0.1, A = 0.05, N = 4, M = 2 }}\n\
             [[material]]\nname = \"steel\"\nmodel = \"elastic\"\ndensity = {RHO:e}\n\
             youngs_modulus = {E:e}\npoisson_ratio = {NU}\n\
             [[block]]\ngroup = \"bar\"\nmaterial = \"steel\"\nvelocity = [{velocity:e}, 0.0, 0.0]\n\
             [[rigid_wall]]\nname = \"floor\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n\
             friction = {mu}\n",
            gravity[0], gravity[1], gravity[2]
        ),
    )
    .unwrap();
    scene
}

#[test]
fn a_block_on_a_rough_implicit_floor_slides_sticks_and_slips_as_coulomb_says() {
    // Coulomb's law for a rigid block on a plane (gravity g at angle theta from the normal):
    // 1. sliding at 2 m/s on a level floor, mu = 0.3: the deceleration mu g, momentum change
    //    -mu M g t over 2 ms, within 1 % (measured 0.02 %, 0.05 % when friction acted on the
    //    velocity only; the explicit wall's test: 0.07 %), the floor's impulse the momentum
    //    change to 1e-6, friction's work mu M g v t in contact_energy within 1 % (measured
    //    0.13 %; the speed falls 0.3 %);
    // 2. at rest, gravity tilted to tan(theta) = 0.2 < mu = 0.3: static friction holds it: the
    //    momentum along the slope stays below 1e-3 of what sliding without friction would
    //    give, M g sin(theta) t (measured 1.8e-4: the block's elastic settling);
    // 3. tilted to tan(theta) = 0.5 > mu: it slides at g (sin(theta) - mu cos(theta)): the
    //    momentum change within 1 % (measured 0.25 %, before 0.56 %: the first steps stick).
    // Energy error below 1e-9 in all three (measured 5e-11).
    // At np 1 and 3, the same bits.
    let (mu, g) = (0.3, 9.81);
    let mass = RHO * 0.1 * 0.05 * 0.05;
    let dir = workdir("implicit_wall_friction");
    let tilted = |tan: f64| {
        let theta = f64::atan(tan);
        [-g * theta.sin(), 0.0, -g * theta.cos()]
    };
    let cases: [(&str, [f64; 3], f64, f64); 3] = [
        ("level", [0.0, 0.0, -g], 2.0, 2.0e-3),
        ("holds", tilted(0.2), 0.0, 2.0e-3),
        ("slips", tilted(0.5), 0.0, 2.0e-3),
    ];
    for (name, gravity, v0, t_end) in cases {
        let mut first: Option<PathBuf> = None;
        for np in [1, 3] {
            let scene = block_on_a_rough_floor(
                &mkdir(&dir, &format!("{name}_scene_np{np}")),
                mu,
                gravity,
                v0,
                t_end,
            );
            let out = dir.join(format!("{name}_np{np}"));
            run_ok(np, &scene, &out);
            let (h, rows) = read_csv(&out.join("history.csv"));
            let (t, px) = (column(&h, &rows, "time"), column(&h, &rows, "momentum_x"));
            let (dp, t) = (px.last().unwrap() - px[0], *t.last().unwrap());
            let (gx, gz) = (gravity[0], -gravity[2]);
            match name {
                "level" => {
                    let expect = -mu * mass * g * t;
                    assert!(
                        (dp - expect).abs() < 0.01 * expect.abs(),
                        "{name} np {np}: momentum change {dp:e} kg m/s vs -mu M g t = {expect:e} (1 %)"
                    );
                    let j = impulse(&out, "floor.force_x");
                    assert!(
                        (j - dp).abs() < 1e-6 * dp.abs(),
                        "{name} np {np}: the floor's impulse {j:e} N s vs the momentum change {dp:e} (1e-6)"
                    );
                    let heat = column(&h, &rows, "contact_energy").last().copied().unwrap();
                    let work = mu * mass * g * v0 * t;
                    assert!(
                        (heat - work).abs() < 0.01 * work,
                        "{name} np {np}: contact_energy {heat:e} J vs mu M g v t = {work:e} J (1 %)"
                    );
                }
                "holds" => {
                    let free = mass * gx.abs() * t;
                    assert!(
                        dp.abs() < 1e-3 * free,
                        "{name} np {np}: momentum along the slope {dp:e} kg m/s; sliding freely {free:e} (1e-3)"
                    );
                }
                _ => {
                    let expect = mass * (gx + mu * gz) * t;
                    assert!(
                        (dp - expect).abs() < 0.01 * expect.abs(),
                        "{name} np {np}: momentum change {dp:e} kg m/s vs M g (sin - mu cos) t = {expect:e} (1 %)"
                    );
                }
            }
            match &first {
                None => first = Some(out),
                Some(a) => same_bits(a, &out, &format!("{name}, np 3 against np 1")),
            }
        }
    }
}

#[test]
fn a_cube_slides_down_a_rough_implicit_floor_at_coulombs_rate_in_contact_at_large_steps() {
    // A 20 mm aluminium cube (meshes/bar.geo with L = A, 4 x 4 x 4 elements) on a floor z = 0
    // with mu = 0.3, gravity tilted 30 degrees from the normal and applied at once, for 20 ms
    // at dt = 0.2 ms and 1 ms (100 and 20 steps, beyond the cube's elastic periods, about 8 us,
    // by 25 and 125 times). A rigid block slides at g (sin - mu cos) = 2.356 m/s^2 pressed by
    // M g cos; friction's moment leaves the rear edge 10 % of the mean pressure (3 mu h / a =
    // 0.9 of it taken by the moment), so the cube must not lift it or tip: the normal momentum
    // stays at the elastic ringing's level. Before friction entered Newton, the cube slid at
    // 3.50 m/s^2 at dt = 20 us with the floor holding it in 23-30 % of the steps (normal speed
    // +-5e-3 m/s) and inverted an element at step 64 (dt = 0.2 ms) and at step 2 (dt = 1 ms).
    // Tolerances: the momentum along the slope within 1 % of M g (sin - mu cos) t (the start's
    // settling; measured 0.01 % at 0.2 ms, 0.002 % at 1 ms); the floor's normal force positive
    // in every row and the mean normal speed below 1e-4 m/s (measured 1.9e-5 and 3.6e-6 m/s,
    // the frictionless cube's ringing 1.7e-5); the floor's impulse the momentum change to 1e-6
    // and its tangential part mu times its normal part to 1e-6 (every node slips throughout,
    // and each step's friction impulse is mu times its normal impulse: measured 5e-8). At np 1
    // and 3, the same bits.
    let (rho, e, nu) = (2700.0, 70.0e9, 0.3);
    let (mu, g, a) = (0.3, 9.81, 0.02);
    let theta = 30f64.to_radians();
    let gravity = [g * theta.sin(), 0.0, -g * theta.cos()];
    let mass = rho * a * a * a;
    let meshes = root().join("meshes").display().to_string();
    let dir = workdir("implicit_wall_slide");
    for dt in [2.0e-4, 1.0e-3] {
        let mut first: Option<PathBuf> = None;
        for np in [1, 3] {
            let sdir = mkdir(&dir, &format!("scene_{dt:e}_np{np}"));
            let scene = sdir.join("cube.toml");
            std::fs::write(
                &scene,
                format!(
                    "title = \"a cube sliding down a rough floor, implicit\"\n\
                     gravity = [{:e}, 0.0, {:e}]\n\
                     [run]\nend_time = 2.0e-2\nmode = \"implicit\"\ndt = {dt:e}\n\
                     [[mesh]]\nfile = \"{meshes}/bar.geo\"\n\
                     params = {{ L = {a:e}, A = {a:e}, N = 4, M = 4 }}\n\
                     [[material]]\nname = \"al\"\nmodel = \"elastic\"\ndensity = {rho:e}\n\
                     youngs_modulus = {e:e}\npoisson_ratio = {nu}\n\
                     [[block]]\ngroup = \"bar\"\nmaterial = \"al\"\n\
                     [[rigid_wall]]\nname = \"floor\"\npoint = [0.0, 0.0, 0.0]\n\
                     normal = [0.0, 0.0, 1.0]\nfriction = {mu}\n",
                    gravity[0], gravity[2]
                ),
            )
            .unwrap();
            let out = dir.join(format!("{dt:e}_np{np}"));
            run_ok(np, &scene, &out);
            let (h, rows) = read_csv(&out.join("history.csv"));
            let t = *column(&h, &rows, "time").last().unwrap();
            let px = column(&h, &rows, "momentum_x");
            let pz = column(&h, &rows, "momentum_z");
            let dp = px.last().unwrap() - px[0];
            let expect = mass * g * (theta.sin() - mu * theta.cos()) * t;
            assert!(
                (dp - expect).abs() < 0.01 * expect,
                "dt {dt:e} np {np}: momentum along the slope {dp:e} kg m/s vs M g (sin - mu cos) t = {expect:e} (1 %)"
            );
            let vz = pz.iter().fold(0.0f64, |m, p| m.max(p.abs())) / mass;
            assert!(
                vz < 1e-4,
                "dt {dt:e} np {np}: the cube's normal speed reached {vz:e} m/s (1e-4: it lifts)"
            );
            let (hr, rr) = read_csv(&out.join("reactions.csv"));
            let fz = column(&hr, &rr, "floor.force_z");
            let lifted = fz[1..].iter().filter(|f| **f <= 0.0).count();
            assert!(
                lifted == 0,
                "dt {dt:e} np {np}: no normal force in {lifted} of {} rows",
                fz.len() - 1
            );
            let (jx, jz) = (
                impulse(&out, "floor.force_x"),
                impulse(&out, "floor.force_z"),
            );
            let dpz = pz.last().unwrap() - pz[0];
            let weight_j = -mass * gravity[2] * t;
            assert!(
                (jz + mass * gravity[2] * t - dpz).abs() < 1e-6 * weight_j,
                "dt {dt:e} np {np}: the floor's normal impulse {jz:e} N s vs M g cos t + dp_z = {:e} (1e-6)",
                weight_j + dpz
            );
            assert!(
                (jx + mass * gravity[0] * t - dp).abs() < 1e-6 * expect,
                "dt {dt:e} np {np}: the floor's impulse along the slope {jx:e} N s vs dp - M g sin t = {:e} (1e-6)",
                dp - mass * gravity[0] * t
            );
            assert!(
                (-jx - mu * jz).abs() < 1e-6 * mu * jz,
                "dt {dt:e} np {np}: friction's impulse {:e} N s vs mu times the normal impulse {:e} (1e-6)",
                -jx,
                mu * jz
            );
            match &first {
                None => first = Some(out),
                Some(b) => same_bits(
                    b,
                    &out,
                    &format!("sliding cube dt {dt:e}, np 3 against np 1"),
                ),
            }
        }
    }
}
