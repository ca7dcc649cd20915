//! Element failure with contact (docs/scene.md "Failure and contact"): the faces a failed
//! element opens join the contact surfaces. A steel striker hits a target whose front layer
//! (one element thick, 2 x 2 across, of a soft steel that fails) lies on an elastic back block
//! sharing its face node for node (meshes/striker_layers.geo): once the front layer fails, the
//! face between it and the back block is open and the striker must stop on it.
use tdyn_tests::frames::*;
use tdyn_tests::*;

/// The striker's speed, m/s.
const V: f64 = 200.0;
/// The front layer's thickness, m (one element; 2 x 2 across).
const LF: f64 = 0.005;
/// The element size along x, m (every part: 5 mm).
const H: f64 = 0.005;
/// The run's end, s: a free striker would travel V T = 16 mm, past the back face at 5 mm.
const T: f64 = 8.0e-5;

/// Before this time the striker has not reached the back block's opened face (measured: at
/// 35.4 us, the contact energy's second jump), s.
const T_REACH: f64 = 3.0e-5;

/// The scene: striker (elastic steel, V along x), front layer (J2 steel yielding at 100 MPa,
/// failing at the plastic strain 0.05, deleted), back block (elastic steel); contact on
/// `surfaces`.
fn scene(dir: &std::path::Path, surfaces: &str) -> std::path::PathBuf {
    let geo = root().join("meshes").join("striker_layers.geo");
    let steel = |name: &str| {
        format!(
            "[[material]]\nname = \"{name}\"\nmodel = \"elastic\"\ndensity = {RHO:e}\n\
             youngs_modulus = {E:e}\npoisson_ratio = {NU}\n\n"
        )
    };
    let text = format!(
        "title = \"a striker through a failing layer onto the block behind\"\n\
         [run]\nend_time = {T:e}\noutput_every = 4.0e-6\n\n\
         [[mesh]]\nfile = \"{}\"\nparams = {{ M = 2 }}\n\n{}{}\
         [[material]]\nname = \"soft\"\nmodel = \"j2_plastic\"\ndensity = {RHO:e}\n\
         youngs_modulus = {E:e}\npoisson_ratio = {NU}\nyield_stress = 100.0e6\n\
         hardening_modulus = 1.0e8\nfailure = {{ plastic_strain = 0.05 }}\n\n\
         [[block]]\ngroup = \"striker\"\nmaterial = \"striker_steel\"\nvelocity = [{V:e}, 0.0, 0.0]\n\n\
         [[block]]\ngroup = \"front\"\nmaterial = \"soft\"\nfailed = \"delete\"\n\n\
         [[block]]\ngroup = \"back\"\nmaterial = \"back_steel\"\n\n\
         [contact]\nsurfaces = {surfaces}\n\n\
         [[probe]]\nname = \"back\"\npoint = [{:e}, 0.005, 0.005]\nfields = [\"velocity_x\"]\n",
        geo.display(),
        steel("striker_steel"),
        steel("back_steel"),
        LF + 0.01,
    );
    let p = dir.join("scene.toml");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn a_striker_through_a_failed_layer_stops_on_the_face_it_opened() {
    // The front layer fails within the first microseconds (the striker compresses it at
    // V / LF = 4e4 /s, past the 0.05 plastic strain in about 1.3 us; measured: all 4 elements
    // at 3.2 us). From then on its faces are gone and the back block's face at x = LF is open:
    // the striker's nodes must never be inside the back block, nor a tip node past the back
    // node it faced (1e-3 of the 5 mm element, as the other contact tests; measured 8.4e-8 m
    // at worst), though it
    // reaches that face (its tip passes x = LF - H / 10) and pushes the block: the block,
    // under V / 4 until then (what the layer passed on before it failed; measured 32 m/s),
    // moves faster than V / 2 at the end (measured 138 m/s); nothing but the opened face can
    // push it, the failed element carries no force (the striker's nodes half an element on
    // would be found inside, which the check must see). The same bits at np 1 and 3, and at
    // np 3 with the contact decomposition rebuilt at every step (the kept one is dropped when
    // a face opens), contact never gives energy back (run_ok); the energy error, largest after
    // the impacts of a 200 m/s kinematic contact on 5 mm elements, stays under 2e-2 (measured
    // 9.5e-3 at 39 us) and ends under 5e-3 (measured 1.9e-3). Surfaces named ("striker_tip",
    // "target_face"): the opened face joins them as it does "exterior" (here the same result,
    // the lateral faces touch nothing).
    let dir = workdir("erosion_contact_striker");
    let mut digests = Vec::new();
    let exterior = "[\"exterior\"]";
    let every_step: &[&str] = &["--contact-rebuild", "every-step"];
    for (name, np, surfaces, args) in [
        ("np1", 1, exterior, &[][..]),
        ("np3", 3, exterior, &[][..]),
        ("np3_every_step", 3, exterior, every_step),
        (
            "np2_named",
            2,
            "[\"striker_tip\", \"target_face\"]",
            &[][..],
        ),
    ] {
        let d = mkdir(&dir, name);
        let out = d.join("out");
        run_ok_args(np, &scene(&d, surfaces), &out, args);
        let (h, rows) = read_csv(&out.join("history.csv"));
        let (t, eroded) = (
            column(&h, &rows, "time"),
            column(&h, &rows, "eroded_elements"),
        );
        let first = t
            .iter()
            .zip(&eroded)
            .find(|(_, e)| **e > 0.0)
            .map(|(t, _)| *t);
        let first = first.unwrap_or_else(|| panic!("np {np}: the front layer never failed"));
        assert!(
            first < 1.0e-5,
            "np {np}: the front layer failed at {first:e} s"
        );
        assert_eq!(
            *eroded.last().unwrap(),
            4.0,
            "np {np}: the front layer's 4 elements fail, no other"
        );
        let err = column(&h, &rows, "energy_error");
        let worst = err.iter().fold(0.0f64, |m, e| m.max(e.abs()));
        let last = err.last().unwrap().abs();
        assert!(
            worst < 2e-2 && last < 5e-3,
            "np {np}: energy error {worst:e} at worst (2e-2), {last:e} at the end (5e-3)"
        );
        let (ph, prow) = read_csv(&out.join("probes.csv"));
        let (tp, vb) = (
            column(&ph, &prow, "time"),
            column(&ph, &prow, "back.velocity_x"),
        );
        let before = tp
            .iter()
            .zip(&vb)
            .filter(|(t, _)| **t < T_REACH)
            .fold(f64::NEG_INFINITY, |m, (_, v)| m.max(*v));
        let after = *vb.last().unwrap();
        assert!(
            before < 0.25 * V && after > 0.5 * V,
            "np {np}: the back block moves at {before} m/s at most before the striker reaches it (V / 4), {after} m/s at the end (V / 2)"
        );
        let fr = read_frames(&out);
        let (x0, conn) = (&fr.positions[0], &fr.connectivity);
        let back = Body::new(
            conn,
            (0..conn.len())
                .filter(|&e| conn[e].iter().all(|&n| x0[n][0] >= LF - 1e-9))
                .collect(),
        );
        let striker: Vec<usize> = (0..x0.len()).filter(|&n| x0[n][0] < -1e-9).collect();
        let tip = fr.positions.iter().fold(f64::NEG_INFINITY, |m, p| {
            striker.iter().fold(m, |m, &n| m.max(p[n][0]))
        });
        assert!(
            tip > LF - 0.1 * H,
            "np {np}: the striker's tip reached only x = {tip}"
        );
        // Each striker tip node against the back block's node that faced it at the start
        // (the same y and z): never past it along x.
        let tip_nodes: Vec<usize> = striker
            .iter()
            .copied()
            .filter(|&n| x0[n][0] > -0.5 * H)
            .collect();
        let facing = |n: usize| {
            let m = (0..x0.len()).find(|&m| {
                (x0[m][0] - LF).abs() < 1e-9
                    && (x0[m][1] - x0[n][1]).abs() < 1e-9
                    && (x0[m][2] - x0[n][2]).abs() < 1e-9
            });
            m.unwrap()
        };
        let pairs: Vec<(usize, usize)> = tip_nodes.iter().map(|&n| (n, facing(n))).collect();
        assert_eq!(pairs.len(), 9, "np {np}: the striker's tip nodes");
        let mut deepest = 0.0f64;
        for (k, pos) in fr.positions.iter().enumerate() {
            let (depth, n) = deepest_penetration(pos, conn, &striker, &back);
            let past = pairs
                .iter()
                .fold(0.0f64, |m, &(a, b)| m.max(pos[a][0] - pos[b][0]));
            deepest = deepest.max(depth).max(past);
            assert!(
                depth < 1e-3 * H && past < 1e-3 * H,
                "np {np}: striker node {n} is {depth} m inside the back block, a tip node {past} m past the node it faced, at t = {} s",
                fr.times[k]
            );
        }
        // The check sees a penetration when there is one: the striker moved on along x until
        // its tip is half an element into the block.
        let mut moved = fr.positions.last().unwrap().clone();
        let gap = pairs
            .iter()
            .fold(f64::INFINITY, |m, &(a, b)| m.min(moved[b][0] - moved[a][0]));
        for &n in &striker {
            moved[n][0] += gap + 0.5 * H;
        }
        let (depth, _) = deepest_penetration(&moved, conn, &striker, &back);
        assert!(
            depth > 0.25 * H,
            "np {np}: the check missed a striker moved H / 2 on ({depth} m)"
        );
        eprintln!(
            "{name}: failed at {first:e} s, tip {tip} m, back block {before} then {after} m/s, deepest {deepest:e} m, energy error {worst:e} (end {last:e})"
        );
        digests.push(run_digest(&out));
    }
    assert_eq!(
        digests[0], digests[1],
        "np 3 against np 1: the digests differ"
    );
    assert_eq!(
        digests[0], digests[2],
        "np 3 rebuilding contact at every step against np 1: the digests differ"
    );
}

/// The bundled perforation (scenes/ball_perforation.toml: a 5 mm steel ball at 500 m/s through
/// a 2 mm aluminium 2024-T351 plate, Johnson-Cook damage, failed elements deleted) with the
/// plate free (its clamp removed) and run to 40 us, at np 1 and 3. Checks:
/// - the same bytes at both rank counts (run_digest), so the residual velocity is equal;
/// - conservation with nothing external: erosion keeps a deleted element's mass on its nodes,
///   contact's push-back is equal and opposite, so `mass_elements` stays its start value to
///   1e-12 and the momentum to 1e-9 of the ball's m V (measured ~1e-16); the energy balance
///   (a deleted element's work stays booked in internal_energy) within 2 % (measured 1e-4);
/// - elements fail (eroded_elements > 0) and the ball comes out of the far side: its centre
///   more than a radius below the plate's bottom face (z = -H = -2 mm).
#[test]
fn a_ball_perforates_a_free_plate_with_the_same_bytes_at_np_1_and_3() {
    let dir = mkdir(&workdir("ball_perforation"), "scene");
    let text = bundled_scene("ball_perforation")
        .replace("end_time = 3.0e-5", "end_time = 4.0e-5")
        .replace(
            "[[boundary]]\ngroup = \"plate_sides\"\nkind = \"fixed\"\n",
            "",
        );
    assert!(!text.contains("plate_sides"), "the clamp removed");
    let scene = dir.join("free_plate.toml");
    std::fs::write(&scene, text).unwrap();
    let a = run_np1_np3_same_bytes(&scene, &dir);
    let (h, rows) = read_csv(&a.join("history.csv"));
    let mass = column(&h, &rows, "mass_elements");
    let pz = column(&h, &rows, "momentum_z");
    let mv = 7850.0 * 4.0 / 3.0 * std::f64::consts::PI * 0.005f64.powi(3) * 500.0;
    let dm = mass.iter().fold(0.0f64, |m, x| m.max((x - mass[0]).abs()));
    let dp = pz.iter().fold(0.0f64, |m, x| m.max((x - pz[0]).abs()));
    let err = column(&h, &rows, "energy_error")
        .iter()
        .fold(0.0f64, |m, e| m.max(*e));
    let eroded = *column(&h, &rows, "eroded_elements").last().unwrap();
    let (ph, prow) = read_csv(&a.join("probes.csv"));
    let z = 0.0052
        + column(&ph, &prow, "ball_centre.displacement_z")
            .last()
            .unwrap();
    eprintln!(
        "perforation: {eroded} eroded, mass drift {:e}, momentum drift {:e} of m V, energy error {err:e}, ball centre at z = {z} m",
        dm / mass[0],
        dp / mv
    );
    assert!(dm <= 1e-12 * mass[0], "mass drift {dm:e} of {}", mass[0]);
    assert!(dp <= 1e-9 * mv, "momentum drift {dp:e} (m V = {mv})");
    assert!(err < 0.02, "energy error {err:e}");
    assert!(eroded > 0.0, "elements fail");
    assert!(
        z < -0.002 - 0.005,
        "the ball is through: its centre at z = {z} m"
    );
}

/// The same perforation with the plate's failed elements becoming particles (`failed`
/// omitted: "particles", its default; docs/scene.md "Failure and erosion"): each failed
/// element leaves the mesh as one SPH particle with its mass, momentum and stress, and meets the
/// ball and the plate through particle-face contact (on by default where elements become
/// particles). At np 1 and 3:
/// - the same bytes, so the ball's residual velocity is equal;
/// - conservation with nothing external (conservation laws, not measured values): the mass
///   of the nodes plus the particles' stays its start value to 1e-12 (measured 1e-16) while
///   mass moves from one to the other; momentum to 1e-9 of the ball's m V (measured 1e-16:
///   the nodes lose (m/8) v_n, the particle carries m times their mean); the energy balance,
///   with the kinetic energy the conversions took in `conversion_energy`, within 2 %
///   (measured 0.013 %);
/// - elements fail and their particles carry their mass (born failed: no deviatoric stress
///   and no tension) (`mass_particles` > 0, one particle
///   per eroded element in the last field frame), and the ball comes out of the far side;
/// - contact_forces.csv's columns of the failed particles (`<block>-failed_particles`) are
///   zero until the first particle is born, and the debris ahead of the ball pushes it back
///   (a positive impulse along z on the ball, which moves along -z).
#[test]
fn a_ball_perforates_a_free_plate_its_failed_elements_becoming_particles() {
    let dir = mkdir(&workdir("ball_perforation_particles"), "scene");
    let text = bundled_scene("ball_perforation")
        .replace("end_time = 3.0e-5", "end_time = 4.0e-5")
        .replace("failed = \"delete\"\n", "")
        .replace(
            "[[boundary]]\ngroup = \"plate_sides\"\nkind = \"fixed\"\n",
            "",
        );
    assert!(!text.contains("plate_sides") && !text.contains("\nfailed ="));
    let scene = dir.join("free_plate_particles.toml");
    std::fs::write(&scene, text).unwrap();
    let a = run_np1_np3_same_bytes(&scene, &dir);
    let (h, rows) = read_csv(&a.join("history.csv"));
    let me = column(&h, &rows, "mass_elements");
    let mp = column(&h, &rows, "mass_particles");
    let total: Vec<f64> = me.iter().zip(&mp).map(|(a, b)| a + b).collect();
    let pz = column(&h, &rows, "momentum_z");
    let mv = 7850.0 * 4.0 / 3.0 * std::f64::consts::PI * 0.005f64.powi(3) * 500.0;
    let dm = total
        .iter()
        .fold(0.0f64, |m, x| m.max((x - total[0]).abs()));
    let dp = pz.iter().fold(0.0f64, |m, x| m.max((x - pz[0]).abs()));
    let err = column(&h, &rows, "energy_error")
        .iter()
        .fold(0.0f64, |m, e| m.max(*e));
    let eroded = *column(&h, &rows, "eroded_elements").last().unwrap();
    let conversion = *column(&h, &rows, "conversion_energy").last().unwrap();
    let (ph, prow) = read_csv(&a.join("probes.csv"));
    let z = 0.0052
        + column(&ph, &prow, "ball_centre.displacement_z")
            .last()
            .unwrap();
    let vz = *column(&ph, &prow, "ball_centre.velocity_z").last().unwrap();
    let particles = last_frame_particles(&a.join("fields.h5"));
    eprintln!(
        "perforation to particles: {eroded} eroded, {particles} particles, mass drift {:e}, momentum drift {:e} of m V, energy error {err:e}, conversion {conversion} J, ball centre at z = {z} m, v_z {vz} m/s",
        dm / total[0],
        dp / mv
    );
    assert!(dm <= 1e-12 * total[0], "mass drift {dm:e} of {}", total[0]);
    assert!(dp <= 1e-9 * mv, "momentum drift {dp:e} (m V = {mv})");
    assert!(err < 0.02, "energy error {err:e}");
    assert!(
        eroded > 0.0 && *mp.last().unwrap() > 0.0,
        "elements fail and become particles"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(a.join("report.json")).unwrap()).unwrap();
    assert_eq!(
        report["erosion"]["particles_from_elements"].as_u64(),
        Some(particles as u64),
        "report.json's particles from elements against the last frame's particles"
    );
    assert!(
        (particles as f64 - eroded).abs() <= 2.0,
        "one particle per released element: {particles} for {eroded} failed (the last step's failures wait a step)"
    );
    assert!(
        z < -0.002 - 0.005,
        "the ball is through: its centre at z = {z} m"
    );
    // contact_forces.csv: the failed particles' columns, zero until the first particle is
    // born; the debris ahead of the ball pushes it back (+z on the ball, which moves -z)
    let (ch, crow) = read_csv(&a.join("contact_forces.csv"));
    let t = column(&ch, &crow, "time");
    let on_ball = column(&ch, &crow, "ball-failed_particles.force_z");
    let on_plate = column(&ch, &crow, "plate-failed_particles.force_z");
    assert_eq!(
        t.len(),
        mp.len(),
        "contact_forces.csv has history.csv's rows"
    );
    let born = mp.iter().position(|&m| m > 0.0).unwrap();
    assert!(
        on_ball[..born]
            .iter()
            .chain(&on_plate[..born])
            .all(|&f| f == 0.0),
        "no failed particle, no force before row {born}"
    );
    let impulse: f64 = (1..t.len()).map(|k| on_ball[k] * (t[k] - t[k - 1])).sum();
    eprintln!("impulse of the failed particles on the ball: {impulse:e} N s (z)");
    assert!(
        impulse > 0.0,
        "the debris ahead of the ball pushes it back: impulse {impulse:e} N s along z"
    );
}

/// The particles in the last frame of a fields.h5.
fn last_frame_particles(path: &std::path::Path) -> usize {
    let f = hdf5::File::open(path).unwrap();
    let frames = f.group("frames").unwrap();
    let mut names = frames.member_names().unwrap();
    names.sort();
    let g = frames.group(names.last().unwrap()).unwrap();
    g.dataset("particles/id").map_or(0, |d| d.size())
}

/// An element of a material that fails fails in the step it would invert, instead of stopping
/// the run (docs/scene.md, `failure`): scenes/ball_perforation.toml's steel ball at 3 km/s
/// into a free, thin (1 mm, one element) plate of a soft material (rho 200 kg/m^3, E 2 MPa,
/// J2 yielding at 1 GPa: it stays elastic), whose elements the contact push-back folds. Without
/// `failure` the run stops at the first inverted element with its one line (measured: element
/// 466 at step 658); with `failure = { plastic_strain = 1e30 }` (a strain never reached:
/// inversion is the only way to fail) and `failed = "delete"`, that element fails at that very
/// step and the run goes on to its end (measured: 12 elements by the end). Checked against
/// the conservation laws, as the perforation above: nothing external acts (no supports, no
/// gravity), so the momentum stays at its start (1e-9 of it), the mass stays on the nodes
/// (`mass_elements` the same bits every row), and the energy error stays under 1 % (measured
/// 4.7e-6); the same bytes at np 1 (`auto` kernel) and np 3 (`scalar`).
#[test]
fn an_element_that_would_invert_fails_instead_of_stopping_the_run() {
    let dir = workdir("erosion_inversion");
    let text = bundled_scene("ball_perforation");
    let swaps = [
        ("H = 0.002, NP = 32, NH = 2", "H = 0.001, NP = 32, NH = 1"),
        (
            "velocity = [0.0, 0.0, -500.0]",
            "velocity = [0.0, 0.0, -3000.0]",
        ),
        (
            "[[boundary]]\ngroup = \"plate_sides\"\nkind = \"fixed\"\n",
            "",
        ),
    ];
    let mut text = text;
    for (from, to) in swaps {
        assert!(text.contains(from), "ball_perforation.toml's {from:?}");
        text = text.replace(from, to);
    }
    let start = text.find("[[material]]\nname = \"aluminium\"").unwrap();
    let end = start + text[start..].find("[[block]]").unwrap();
    let soft = |failure: &str| {
        format!(
            "[[material]]\nname = \"aluminium\"\nmodel = \"j2_plastic\"\ndensity = 200.0\n\
             youngs_modulus = 2.0e6\npoisson_ratio = 0.0\nyield_stress = 1.0e9\n\
             hardening_modulus = 0.0\n{failure}\n"
        )
    };
    let failing = format!(
        "{}{}{}",
        &text[..start],
        soft("failure = { plastic_strain = 1.0e30 }\n"),
        &text[end..]
    );
    let plain = format!("{}{}{}", &text[..start], soft(""), &text[end..])
        .replace("failed = \"delete\"\n", "");
    let (scene, scene_plain) = (dir.join("failing.toml"), dir.join("plain.toml"));
    std::fs::write(&scene, failing).unwrap();
    std::fs::write(&scene_plain, plain).unwrap();
    // without failure: the run stops at the first inverted element, naming it and its step
    let o = run(1, &scene_plain, &dir.join("plain"));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "without failure the run stops:\n{err}");
    let step: f64 = err
        .split(", step ")
        .nth(1)
        .and_then(|s| s.split(',').next())
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or_else(|| panic!("an inverted element and its step:\n{err}"));
    assert!(err.contains("inverted"), "{err}");
    // with failure: that element fails at that step, and the run goes on
    let (a, b) = (dir.join("np1"), dir.join("np3"));
    run_ok(1, &scene, &a);
    run_ok_args(3, &scene, &b, &["--kernel", "scalar"]);
    assert_eq!(
        run_digest(&a),
        run_digest(&b),
        "np 3 scalar against np 1 auto"
    );
    let (h, rows) = read_csv(&a.join("history.csv"));
    let (steps, eroded) = (
        column(&h, &rows, "step"),
        column(&h, &rows, "eroded_elements"),
    );
    let first = steps
        .iter()
        .zip(&eroded)
        .find(|(_, &e)| e > 0.0)
        .map(|(&s, _)| s);
    assert_eq!(
        first,
        Some(step),
        "the first failure is at the step the run without failure stopped"
    );
    let time = column(&h, &rows, "time");
    assert!(
        *time.last().unwrap() >= 3.0e-5 * (1.0 - 1e-12) && *eroded.last().unwrap() >= 2.0,
        "the run reaches its end, more elements failing: t = {}, eroded {}",
        time.last().unwrap(),
        eroded.last().unwrap()
    );
    let mass = column(&h, &rows, "mass_elements");
    assert!(
        mass.iter().all(|&m| m == mass[0]),
        "deleted elements leave their mass on their nodes"
    );
    let p: Vec<Vec<f64>> = ["momentum_x", "momentum_y", "momentum_z"]
        .iter()
        .map(|c| column(&h, &rows, c))
        .collect();
    let p0 = (p[0][0].powi(2) + p[1][0].powi(2) + p[2][0].powi(2)).sqrt();
    for (c, pc) in p.iter().enumerate() {
        let drift = (pc.last().unwrap() - pc[0]).abs();
        assert!(
            drift < 1e-9 * p0,
            "momentum {c}: drift {drift:e} of {p0:e} (1e-9)"
        );
    }
    let worst = column(&h, &rows, "energy_error")
        .into_iter()
        .fold(0.0, f64::max);
    assert!(worst < 0.01, "energy error {worst:e} (1 %)");
}

/// A tungsten ball (4 mm, 800 m/s) through a free 3 mm j2 steel plate whose failed elements
/// become particles (`failure = { plastic_strain = 0.3 }`), a rigid floor 8 mm under the plate
/// (the tester's scene, meshes/ball_plate.geo).
fn ball_over_floor(dir: &std::path::Path) -> std::path::PathBuf {
    let text = format!(
        "title = \"ball through a plate over a floor\"\n[run]\nend_time = 2.5e-5\n\
         output_every = 5.0e-6\n\
         [[mesh]]\nfile = \"{}\"\n\
         params = {{ R = 0.004, N = 4, M = 2, W = 0.03, H = 0.003, NP = 24, NH = 3, G = 0.0002, BALL_FIRST = 0 }}\n\
         [[material]]\nname = \"tungsten\"\nmodel = \"elastic\"\ndensity = 17600.0\n\
         youngs_modulus = 400.0e9\npoisson_ratio = 0.28\n\
         [[material]]\nname = \"mild\"\nmodel = \"j2_plastic\"\ndensity = 7850.0\n\
         youngs_modulus = 210.0e9\npoisson_ratio = 0.3\nyield_stress = 300.0e6\n\
         hardening_modulus = 800.0e6\nfailure = {{ plastic_strain = 0.3 }}\n\
         [[block]]\ngroup = \"plate\"\nmaterial = \"mild\"\nfailed = \"particles\"\n\
         [[block]]\ngroup = \"ball\"\nmaterial = \"tungsten\"\nvelocity = [0.0, 0.0, -800.0]\n\
         [contact]\nsurfaces = [\"ball_skin\", \"plate_top\"]\n\
         [[rigid_wall]]\nname = \"floor\"\npoint = [0.0, 0.0, -0.008]\nnormal = [0.0, 0.0, 1.0]\n",
        tdyn_tests::root().join("meshes/ball_plate.geo").display()
    );
    let p = dir.join("ball_over_floor.toml");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn nodes_whose_elements_all_became_particles_stay_where_they_were_released() {
    // docs/scene.md `[[rigid_wall]]`: no mesh node and no particle passes a wall. A node all
    // of whose elements were released keeps no mass and takes no force: it stops where it is
    // (fe_petsc explicit/failure.rs `release_failed`). Moving on at its speed (up to 970 m/s)
    // it carried the released elements' drawing through the floor (78 nodes 14 mm behind it
    // at 25 us). References: the floor plane (no node or particle behind it in any frame, by
    // 1e-9 m), and momentum: the floor's impulse (reactions.csv, the rule of walls: each
    // row's force over the step that ended at it) is the bodies' momentum change, to 1e-9 of
    // the ball's start momentum (a conservation law; no gravity). np 1 = np 3 bytes.
    let dir = tdyn_tests::workdir("orphan_nodes_stop");
    let out = tdyn_tests::run_np1_np3_same_bytes(&ball_over_floor(&dir), &dir);
    let f = hdf5::File::open(out.join("fields.h5")).unwrap();
    let mut released = 0;
    for name in f.group("frames").unwrap().member_names().unwrap() {
        let g = f.group(&format!("frames/{name}")).unwrap();
        for set in ["nodes", "particles"] {
            let Ok(d) = g.dataset(&format!("{set}/position")) else {
                continue;
            };
            let pos: Vec<f64> = d.read_raw().unwrap();
            if set == "particles" {
                released = released.max(pos.len() / 3);
            }
            let low = pos.chunks(3).map(|c| c[2]).fold(f64::INFINITY, f64::min);
            assert!(
                low >= -0.008 - 1e-9,
                "frame {name}: a {set} position at z = {low} m, behind the floor at -0.008 m"
            );
        }
    }
    assert!(released > 50, "elements became particles ({released})");
    let (h, rows) = tdyn_tests::read_csv(&out.join("history.csv"));
    let pz = tdyn_tests::column(&h, &rows, "momentum_z");
    let (rh, rrows) = tdyn_tests::read_csv(&out.join("reactions.csv"));
    let t = tdyn_tests::column(&rh, &rrows, "time");
    let fz = tdyn_tests::column(&rh, &rrows, "floor.force_z");
    let j: f64 = (1..t.len()).map(|i| (t[i] - t[i - 1]) * fz[i]).sum();
    let dp = pz[pz.len() - 1] - pz[0];
    assert!(
        (j - dp).abs() <= 1e-9 * pz[0].abs(),
        "floor impulse {j:e} N s vs momentum change {dp:e} kg m/s"
    );
}
