//! Element failure and erosion (`[[material]] failure`, `[[block]] failed = "delete"`,
//! docs/scene.md). Each test compares with what the erosion did not produce: the analytic free
//! fall of what is left, the mass the nodes keep, the yield stress the load must pass first;
//! at np 1 and 3, where the answer must also be the same bits.
use std::path::PathBuf;
use tdyn_tests::*;

#[test]
fn a_hanging_bar_fails_at_its_top_and_falls_freely() {
    // The top element carries the whole bar's weight rho g A (L - h/2): it yields first (in
    // uniaxial stress at sigma_y = 350 MPa, reached at t = 0.457 ms on the ramp: no failure
    // before), flows and fails at the plastic strain 0.05 (the next one, as strained, a step
    // later). Then the rest falls freely, the pieces and loose nodes alike: with its top nodes
    // fixed and tied to nothing, the momentum changes at exactly g M_free, M_free =
    // rho A (L - h/2) (the fixed nodes keep the failed element's half of its mass and do not
    // move; were the top element standing, it would pull), within 1e-9 per row after the ramp (round-off of the free
    // elements' internal forces). The mass on the nodes is the bar's rho A L to 1e-12 at every
    // row (a deleted element leaves its mass on its nodes), the particles' zero.
    let (area, len, h, g) = (0.05 * 0.05, 1.0, 0.05, 2.0e5);
    let m_free = RHO * area * (len - 0.5 * h);
    let dir = workdir("erosion_hanging_bar");
    let mut first: Option<PathBuf> = None;
    for np in [1, 3] {
        let scene = hanging_bar_scene(
            &{
                let d = dir.join(format!("scene_np{np}"));
                std::fs::create_dir_all(&d).unwrap();
                d
            },
            "{ plastic_strain = 0.05 }",
        );
        let out = dir.join(format!("np{np}"));
        run_ok(np, &scene, &out);
        let (hh, rows) = read_csv(&out.join("history.csv"));
        let t = column(&hh, &rows, "time");
        let eroded = column(&hh, &rows, "eroded_elements");
        let p = column(&hh, &rows, "momentum_x");
        let (me, mp) = (
            column(&hh, &rows, "mass_elements"),
            column(&hh, &rows, "mass_particles"),
        );
        for k in 0..t.len() {
            assert!(
                (me[k] - RHO * area * len).abs() < 1e-12 * RHO * area * len && mp[k] == 0.0,
                "np {np}: row {k}: masses {} and {} kg, the bar's {} kg",
                me[k],
                mp[k],
                RHO * area * len
            );
        }
        let first_fail = t
            .iter()
            .zip(&eroded)
            .find(|(_, e)| **e > 0.0)
            .map(|(t, _)| *t)
            .unwrap_or_else(|| panic!("np {np}: no element failed"));
        assert!(
            first_fail > 0.457e-3,
            "np {np}: an element failed at {first_fail:e} s, before the top can yield (0.457 ms)"
        );
        // The energy balance holds through the failure (the failed elements' work stays in
        // internal_energy): within 1e-3 after the first 0.2 ms, whose error is large against
        // an energy scale starting from zero (1.1e-3 at 0.1 ms; 4.1e-4 at the second failure).
        let worst = worst_energy_error_after(&hh, &rows, 2e-4);
        assert!(worst < 1e-3, "np {np}: energy error {worst:e} (1e-3)");
        falls_at(np, (&t, &p), -g * m_free, |_| false);
        // fields.h5 marks the failed elements (`failed`, 1) in its last frame: as many as
        // history.csv's last row counts.
        let f = hdf5::File::open(out.join("fields.h5")).unwrap();
        let mut frames = f.group("frames").unwrap().member_names().unwrap();
        frames.sort();
        let marked: Vec<f64> = f
            .dataset(&format!(
                "frames/{}/elements/failed",
                frames.last().unwrap()
            ))
            .unwrap()
            .read_raw()
            .unwrap();
        assert_eq!(
            marked.iter().sum::<f64>(),
            *eroded.last().unwrap(),
            "np {np}: fields.h5's failed elements against history.csv's eroded_elements"
        );
        same_columns_as_first(&mut first, out);
    }
}

#[test]
fn failure_keys_are_checked_and_implicit_failure_is_refused_in_one_line() {
    // docs/scene.md: each mistake one line naming the file and the key, a non-zero exit.
    let dir = workdir("erosion_bad");
    let good = "{ plastic_strain = 0.05 }";
    let cases: [(&str, String, &str); 5] = [
        (
            "negative",
            "{ plastic_strain = -0.1 }".into(),
            "material[0].failure.plastic_strain",
        ),
        (
            "two_kinds",
            "{ plastic_strain = 0.1, johnson_cook = { d1 = 0.1, d2 = 0.1, d3 = -1.0, d4 = 0.0 } }"
                .into(),
            "material[0].failure",
        ),
        (
            "jc_missing",
            "{ johnson_cook = { d1 = 0.1, d2 = 0.1, d3 = -1.0 } }".into(),
            "material[0].failure.johnson_cook.d4",
        ),
        (
            "jc_negative",
            "{ johnson_cook = { d1 = -1.0, d2 = 0.1, d3 = -1.0, d4 = 0.0 } }".into(),
            "must be positive",
        ),
        ("implicit", good.into(), "with implicit mode"),
    ];
    for (name, failure, needle) in cases {
        let d = dir.join(name);
        std::fs::create_dir_all(&d).unwrap();
        let scene = hanging_bar_scene(&d, &failure);
        let mut text = std::fs::read_to_string(&scene).unwrap();
        if name == "implicit" {
            text = text.replace("[run]\n", "[run]\nmode = \"implicit\"\ndt = 1.0e-5\n");
        }
        std::fs::write(&scene, text).unwrap();
        assert_scene_refused(name, &scene, &d.join("out"), needle);
    }
}

#[test]
fn johnson_cook_damage_with_a_constant_strain_to_failure_is_the_plastic_strain_criterion() {
    // Johnson & Cook's damage D = sum d(ep) / eps_f with d2 = d4 = 0 has eps_f = d1 at every
    // triaxiality and rate, so D = ep / d1: the hanging bar must fail as with
    // failure = { plastic_strain = d1 }, at the same step or the next (the damage is summed
    // increment by increment, the plastic strain is one value: they may part in the last bit).
    let dir = workdir("erosion_jc_constant");
    let first_failure = |name: &str, failure: &str| {
        let d = dir.join(name);
        std::fs::create_dir_all(&d).unwrap();
        let scene = hanging_bar_scene(&d, failure);
        let out = d.join("out");
        run_ok(1, &scene, &out);
        let (h, rows) = read_csv(&out.join("history.csv"));
        let (step, eroded) = (
            column(&h, &rows, "step"),
            column(&h, &rows, "eroded_elements"),
        );
        step.iter()
            .zip(&eroded)
            .find(|(_, e)| **e > 0.0)
            .map(|(s, _)| *s)
            .unwrap_or_else(|| panic!("{name}: no element failed"))
    };
    let a = first_failure("plastic_strain", "{ plastic_strain = 0.05 }");
    let b = first_failure(
        "johnson_cook",
        "{ johnson_cook = { d1 = 0.05, d2 = 0.0, d3 = 0.0, d4 = 0.0 } }",
    );
    assert!(
        (a - b).abs() <= 1.0,
        "first failure at step {a} with the plastic strain, {b} with the damage"
    );
}

/// The hanging bar of `a_hanging_bar_fails_at_its_top_and_falls_freely` with its failed
/// elements becoming particles (`failed` omitted: the default). The top element's mass leaves
/// its nodes with it: the fixed end's nodes, which it alone held, keep none, so once gravity is
/// constant (t > 2 ms) everything falls, the nodes and the particles together: the momentum
/// (mesh and particles) changes at exactly -g times the whole bar's mass (Newton: 1e-9 of it)
/// between rows with no new failure. The mesh's mass plus the particles' stays the bar's to
/// 1e-12 and moves from one to the other; the energy balance, with `conversion_energy`, holds
/// to 1e-3 after the start (as the deleting bar's); np 1 and 3 give the same columns.
#[test]
fn a_hanging_bar_whose_failed_top_becomes_a_particle_falls_whole() {
    let (area, len, g) = (0.05 * 0.05, 1.0, 2.0e5);
    let m_bar = RHO * area * len;
    let dir = workdir("erosion_hanging_bar_particles");
    let mut first: Option<PathBuf> = None;
    for np in [1, 3] {
        let d = dir.join(format!("scene_np{np}"));
        std::fs::create_dir_all(&d).unwrap();
        let scene = hanging_bar_scene(&d, "{ plastic_strain = 0.05 }");
        let text = std::fs::read_to_string(&scene).unwrap();
        std::fs::write(&scene, text.replace("failed = \"delete\"\n", "")).unwrap();
        let out = dir.join(format!("np{np}"));
        run_ok(np, &scene, &out);
        let (hh, rows) = read_csv(&out.join("history.csv"));
        let t = column(&hh, &rows, "time");
        let eroded = column(&hh, &rows, "eroded_elements");
        let p = column(&hh, &rows, "momentum_x");
        let me = column(&hh, &rows, "mass_elements");
        let mp = column(&hh, &rows, "mass_particles");
        for k in 0..t.len() {
            assert!(
                (me[k] + mp[k] - m_bar).abs() < 1e-12 * m_bar,
                "np {np}: row {k}: masses {} + {} kg, the bar's {m_bar} kg",
                me[k],
                mp[k]
            );
        }
        assert!(
            *mp.last().unwrap() > 0.0,
            "np {np}: the failed top became a particle"
        );
        let worst = worst_energy_error_after(&hh, &rows, 2e-4);
        assert!(worst < 1e-3, "np {np}: energy error {worst:e} (1e-3)");
        // rows with no failure in or just before them (a release comes a step after the
        // failure), once the top is a particle
        let checked = falls_at(np, (&t, &p), -g * m_bar, |k| {
            eroded[k] != eroded[k - 2] || mp[k] == 0.0
        });
        assert!(checked > 10, "np {np}: {checked} rows of free fall");
        same_columns_as_first(&mut first, out);
    }
}

/// The largest |energy_error| of a history.csv (`hh`, `rows`) after time `t0`, s.
/// Asserts that after the gravity ramp (t > 2 ms) the momentum `p` (kg m/s at times `t`, s)
/// changes at `want` N to 1e-9 over every row k >= 2 that `skip` does not leave out (Newton:
/// gravity the only external force on the falling mass); returns the rows checked.
fn falls_at(np: usize, (t, p): (&[f64], &[f64]), want: f64, skip: impl Fn(usize) -> bool) -> usize {
    let mut checked = 0;
    for k in 2..t.len() {
        if t[k - 1] < 2.0e-3 + 1e-12 || skip(k) {
            continue;
        }
        let rate = (p[k] - p[k - 1]) / (t[k] - t[k - 1]);
        assert!(
            (rate - want).abs() < 1e-9 * want.abs(),
            "np {np}: at t = {:e} s the momentum changes at {rate:e} N, g M = {want:e} N (1e-9)",
            t[k]
        );
        checked += 1;
    }
    checked
}

fn worst_energy_error_after(hh: &[String], rows: &[Vec<f64>], t0: f64) -> f64 {
    let t = column(hh, rows, "time");
    let err = column(hh, rows, "energy_error");
    t.iter()
        .zip(&err)
        .filter(|(t, _)| **t > t0)
        .fold(0.0f64, |m, (_, e)| m.max(e.abs()))
}

/// Keeps the first run's folder, or checks that history.csv and probes.csv of `out` have the
/// same columns as its.
fn same_columns_as_first(first: &mut Option<PathBuf>, out: PathBuf) {
    match first {
        None => *first = Some(out),
        Some(a) => {
            for f in ["history.csv", "probes.csv"] {
                let d = csv_columns_differ(a, &out, f, &[]);
                assert!(d.is_empty(), "np 3 against np 1: {f} columns differ: {d:?}");
            }
        }
    }
}

/// A pressure load on a failed element's face carries no load (docs/scene.md `[[load]]`):
/// the material it pushed is gone. A steel bar (meshes/bar.geo: 1 m, 20 elements, uniaxial
/// strain) of J2 steel failing at a plastic strain of 0.005 (the first plastic wave leaves 0.0072) (`failed = "delete"`), fixed at
/// x = 1, takes a sudden 2 GPa pressure on its face x = 0 (`[[load]] group = "left"`): the
/// plastic wave starts there, so the loaded element is the first to fail (its `failed` field
/// in the last frame). From the step after it fails the load does no work: history.csv's
/// `external_work` (the loads' trapezoid, the fixed end doing none) stays at its value to
/// 1e-12 of it to the end, where a load left on the face would push the deleted element's
/// free nodes on for ever; np 1 and 3 give the same bytes. (No energy bound here: the sudden
/// load on 5 cm elements starts the balance 10 % off in its first step, 2 % by the failure;
/// the hanging bars above check the balance through a failure.)
#[test]
fn a_pressure_load_on_a_failed_elements_face_stops() {
    let dir = workdir("load_on_failed");
    let geo = root().join("meshes").join("bar.geo");
    let scene = dir.join("scene.toml");
    std::fs::write(
        &scene,
        format!(
            "title = \"a pressure on a face whose element fails\"\n\
             [run]\nend_time = 4.0e-4\noutput_every = 5.0e-5\n\n\
             [[mesh]]\nfile = \"{}\"\nparams = {{ L = 1.0, A = 0.05, N = 20, M = 1 }}\n\n\
             [[material]]\nname = \"steel\"\nmodel = \"j2_plastic\"\ndensity = {RHO:e}\n\
             youngs_modulus = {E:e}\npoisson_ratio = {NU}\nyield_stress = 350.0e6\n\
             hardening_modulus = 1.0e9\nfailure = {{ plastic_strain = 0.005 }}\n\n\
             [[block]]\ngroup = \"bar\"\nmaterial = \"steel\"\nfailed = \"delete\"\n\n\
             [[boundary]]\ngroup = \"right\"\nkind = \"fixed\"\n\n\
             [[boundary]]\ngroup = \"sides_y\"\nkind = \"symmetry\"\n\n\
             [[boundary]]\ngroup = \"sides_z\"\nkind = \"symmetry\"\n\n\
             [[load]]\ngroup = \"left\"\npressure = 2.0e9\n",
            geo.display()
        ),
    )
    .unwrap();
    let a = run_np1_np3_same_bytes(&scene, &dir);
    let (h, rows) = read_csv(&a.join("history.csv"));
    let (t, eroded, work) = (
        column(&h, &rows, "time"),
        column(&h, &rows, "eroded_elements"),
        column(&h, &rows, "external_work"),
    );
    let k = eroded
        .iter()
        .position(|&e| e > 0.0)
        .expect("an element fails");
    assert!(k + 2 < rows.len(), "the failure comes before the end");
    let w = work[k + 1];
    assert!(w > 0.0, "the load did work before: {w} J");
    for j in k + 1..rows.len() {
        assert!(
            (work[j] - w).abs() <= 1e-12 * w,
            "t = {:e} s: external work {} J, {w} J when the loaded element failed at {:e} s",
            t[j],
            work[j],
            t[k]
        );
    }
    // the failed element is the loaded one (centroid within the first 0.05 m)
    let g = tdyn_tests::frames::last_frame(&a);
    let x: Vec<f64> = g.dataset("nodes/position").unwrap().read_raw().unwrap();
    let nid: Vec<u64> = g.dataset("nodes/id").unwrap().read_raw().unwrap();
    let conn: Vec<u64> = g
        .dataset("elements/connectivity")
        .unwrap()
        .read_raw()
        .unwrap();
    let failed: Vec<f64> = g.dataset("elements/failed").unwrap().read_raw().unwrap();
    let at: std::collections::HashMap<u64, usize> =
        nid.iter().enumerate().map(|(i, &g)| (g, i)).collect();
    let x0 = |e: usize| -> f64 { (0..8).map(|c| x[3 * at[&conn[8 * e + c]]]).sum::<f64>() / 8.0 };
    let first = (0..failed.len())
        .min_by(|&a, &b| x0(a).total_cmp(&x0(b)))
        .unwrap();
    assert_eq!(failed[first], 1.0, "the loaded element failed");
    eprintln!(
        "load on a failed face: failed at {:e} s ({} elements at the end), work {w} J",
        t[k],
        eroded.last().unwrap()
    );
}
