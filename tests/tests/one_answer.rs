//! One answer at any rank count (docs/scene.md "One answer"): the same bits, not the same to a
//! tolerance. The reference is the run on one rank; the property is exact equality, which no
//! tolerance can hide.
use tdyn_tests::*;

/// `scenes/block_drop.toml` (a tilted steel block dropped at 40 m/s onto a plate: FE on METIS
/// partitions, contact on its own RCB decomposition) at np 1 to 4: every frame's node and
/// element values in fields.h5 (matched by id) and every probe value are the same bits as at
/// np 1, and so is every history.csv column but the run's own measurements `contact_imbalance`
/// and `contact_bytes` (energies, per-block energies, momenta, energy error). Each node's force
/// is summed in canonical element order over all ranks holding it (`fe_petsc::assembly`);
/// contact, given the same nodes, finds and solves the same contacts; every energy and
/// momentum sum is exact on fixed grids (`fe_petsc::exact`).
#[test]
fn fe_and_contact_fields_are_the_same_bits_at_1_to_4_ranks() {
    let scene = root().join("scenes/block_drop.toml");
    let base = workdir("one_answer_np1").join("out");
    run_ok(1, &scene, &base);
    let measured = ["contact_imbalance", "contact_bytes"];
    for np in [2, 3, 4] {
        let out = workdir(&format!("one_answer_np{np}")).join("out");
        run_ok(np, &scene, &out);
        if let Err(e) = fields_differ(&base, &out) {
            panic!("np {np} against np 1: fields.h5 {e} (same bits expected)");
        }
        let probes = csv_columns_differ(&base, &out, "probes.csv", &[]);
        assert!(
            probes.is_empty(),
            "np {np} against np 1: probes.csv columns differ (column, first row): {probes:?}"
        );
        let bad = csv_columns_differ(&base, &out, "history.csv", &measured);
        assert!(
            bad.is_empty(),
            "np {np} against np 1: history.csv columns differ (column, first row): {bad:?}"
        );
    }
}

/// The default scene made oblique with friction (see the test below), to `end_time` (s), written
/// in `dir`.
fn oblique_slug(dir: &std::path::Path, end_time: f64) -> std::path::PathBuf {
    let text = std::fs::read_to_string(root().join("scenes/slug_on_plate.toml")).unwrap();
    let mesh = root().join("meshes/plate.geo");
    let mut scene = text.clone();
    for (from, to) in [
        (
            "file = \"../meshes/plate.geo\"".to_string(),
            format!("file = {:?}", mesh.to_str().unwrap()),
        ),
        (
            "velocity = [0.0, 0.0, -100.0]".into(),
            "velocity = [30.0, 0.0, -100.0]".into(),
        ),
        (
            "\nparticles = true\n".into(),
            "\nparticles = true\nfriction = 0.3\n".into(),
        ),
        (
            "end_time = 8.0e-4".into(),
            format!("end_time = {end_time:e}"),
        ),
        (
            "output_every = 5.0e-5".into(),
            "output_every = 1.0e-4".into(),
        ),
    ] {
        assert!(scene.contains(&from), "slug_on_plate.toml has no {from}");
        scene = scene.replacen(&from, &to, 1);
    }
    let path = dir.join("oblique_slug.toml");
    std::fs::write(&path, scene).unwrap();
    path
}

/// The default scene made harder: the water slug of `scenes/slug_on_plate.toml` strikes the plate
/// obliquely (30 m/s along x besides the 100 m/s down) with Coulomb friction 0.3, to 0.2 ms (the
/// slug spreading over the plate, the plate yielding): FE, SPH (RCB every step, ghosts whose
/// pair sums go back to their owners) and particle-on-face contact with sliding, on three
/// decompositions. At np 2, 3 and 4, and at np 2 with every element kernel the CPU has, every
/// history.csv column but the run's own measurements, every probe and every frame's node,
/// element and particle values (matched by id) are the same bits as the np 1 run with the
/// default kernel, and the np 1 run's digest is that of the same run on the CPU named in
/// tests/reference/one_answer.toml. The SPH pair sums are exact ([`sph::exact`]), so a
/// particle's force does not depend on which rank computed which of its pairs.
#[test]
fn coupled_fe_sph_contact_with_friction_same_bits_at_any_rank_count_and_kernel() {
    let dir = workdir("one_answer_coupled");
    let path = oblique_slug(&dir, 2.0e-4);
    let base = dir.join("np1");
    run_ok(1, &path, &base);
    // friction acts: the x momentum (the slug's 30 m/s x 0.116 kg) falls by 2.3 % to 0.2 ms
    // (without friction it rises by 0.3 %: the plate's supports take none of it)
    let (h, rows) = read_csv(&base.join("history.csv"));
    let px = column(&h, &rows, "momentum_x");
    assert!(
        px[px.len() - 1] < 0.99 * px[0],
        "friction must slow the slug along x by over 1 %: momentum_x {} -> {}",
        px[0],
        px[px.len() - 1]
    );
    // The same bits as on the CPU that made the reference (tests/reference/one_answer.toml):
    // the guarantee holds across CPUs, not only across this CPU's kernels.
    let refs: toml::Table = std::fs::read_to_string(root().join("tests/reference/one_answer.toml"))
        .unwrap()
        .parse()
        .unwrap();
    let (want, made_on) = (
        refs["oblique_slug"]["digest"].as_str().unwrap(),
        refs["oblique_slug"]["made_on"].as_str().unwrap(),
    );
    let got = run_digest(&base);
    assert_eq!(
        got, want,
        "the oblique slug at np 1 on this CPU gives digest {got}, the CPU of the reference ({made_on}) \
         gave {want}: other bits on another CPU (or a change of results: see tests/reference/one_answer.toml)"
    );
    let mut runs: Vec<(usize, &str)> = vec![(2, "auto"), (3, "auto"), (4, "auto")];
    runs.push((2, "scalar"));
    if std::arch::is_x86_feature_detected!("avx2") {
        runs.push((2, "lanes4"));
    }
    if std::arch::is_x86_feature_detected!("avx512f") {
        runs.push((2, "lanes8"));
    }
    let measured = ["contact_imbalance", "contact_bytes"];
    for (np, kernel) in runs {
        let out = dir.join(format!("np{np}_{kernel}"));
        run_ok_args(np, &path, &out, &["--kernel", kernel]);
        let what = format!("np {np} --kernel {kernel} against np 1");
        if let Err(e) = fields_differ(&base, &out) {
            panic!("{what}: fields.h5 {e} (same bits expected)");
        }
        for file in ["history.csv", "probes.csv"] {
            let bad = csv_columns_differ(&base, &out, file, &measured);
            assert!(
                bad.is_empty(),
                "{what}: {file} columns differ (column, first row): {bad:?}"
            );
        }
    }
}

/// The elastic cantilever (`scenes/cantilever.toml`, one block released at 0.1 m/s) to 0.2 ms at
/// np 3 against np 1: every frame's values the same bits, the first frame's velocities
/// included, and every node of the moving block starts at exactly the block's 0.1 m/s (before,
/// each node's initial velocity was the mean of its elements' velocities summed in the
/// partition's order: some nodes started an ulp off at np 3).
#[test]
fn initial_block_velocities_are_the_same_bits_at_any_rank_count() {
    let scene = root().join("scenes/cantilever.toml");
    let dir = workdir("one_answer_cantilever");
    let (a, b) = (dir.join("np1"), dir.join("np3"));
    run_ok_args(1, &scene, &a, &["--end-time", "2e-4"]);
    run_ok_args(3, &scene, &b, &["--end-time", "2e-4"]);
    if let Err(e) = fields_differ(&a, &b) {
        panic!("np 3 against np 1: fields.h5 {e} (same bits expected)");
    }
    let bad = csv_columns_differ(
        &a,
        &b,
        "history.csv",
        &["contact_imbalance", "contact_bytes"],
    );
    assert!(
        bad.is_empty(),
        "np 3 against np 1: history columns differ: {bad:?}"
    );
    let f = hdf5::File::open(a.join("fields.h5")).unwrap();
    let v: Vec<f64> = f
        .dataset("frames/000000/nodes/velocity")
        .unwrap()
        .read_raw::<f64>()
        .unwrap();
    let moving: Vec<f64> = v.chunks(3).map(|c| c[2]).filter(|&z| z != 0.0).collect();
    assert!(!moving.is_empty(), "no moving node at t = 0");
    assert!(
        moving.iter().all(|&z| z == 0.1),
        "every free node starts at exactly 0.1 m/s (the block's velocity): {:?}",
        moving.iter().find(|&&z| z != 0.1)
    );
}

/// The oblique slug with friction (above) to 0.1 ms at 5, 6 and 8 ranks (more than the cores:
/// oversubscribed) against np 1: the same bits (docs/scene.md, "One answer": any rank count). At
/// 8 ranks the plate's METIS parts, the SPH and the contact RCB boxes are a few elements and
/// particles wide, so most pairs and contacts straddle a cut.
#[test]
fn coupled_scene_same_bits_at_5_6_and_8_ranks() {
    let dir = workdir("one_answer_many");
    let path = oblique_slug(&dir, 1.0e-4);
    let base = dir.join("np1");
    run_ok(1, &path, &base);
    let measured = ["contact_imbalance", "contact_bytes"];
    for np in [5, 6, 8] {
        let out = dir.join(format!("np{np}"));
        run_ok(np, &path, &out);
        if let Err(e) = fields_differ(&base, &out) {
            panic!("np {np} against np 1: fields.h5 {e} (same bits expected)");
        }
        for file in ["history.csv", "probes.csv"] {
            let bad = csv_columns_differ(&base, &out, file, &measured);
            assert!(
                bad.is_empty(),
                "np {np} against np 1: {file} columns differ (column, first row): {bad:?}"
            );
        }
    }
}

/// `[[rigid_wall]]` with Coulomb friction, on mesh nodes and on particles: the Taylor bar of
/// `scenes/taylor_impact.toml` on a rough wall (friction 0.3) in place of its impact symmetry
/// plane, and the water of `scenes/water_on_floor.toml` on a rough floor that slides at 1 m/s
/// along x. At np 2 and 3 every history.csv, reactions.csv and probes.csv column and every
/// frame is the same bits as at np 1: a node shared between ranks takes the same correction on
/// every copy (a function of its own position and velocity), and the walls' energy and
/// impulses are exact sums.
#[test]
fn rigid_walls_with_friction_are_the_same_bits_at_1_to_3_ranks() {
    let dir = workdir("one_answer_walls");
    let taylor = std::fs::read_to_string(root().join("scenes/taylor_impact.toml"))
        .unwrap()
        .replace(
            "[[boundary]]\ngroup = \"impact\"\nkind = \"symmetry\"\n",
            "[[rigid_wall]]\nname = \"target\"\npoint = [0.0, 0.0, 0.0]\nnormal = [1.0, 0.0, 0.0]\nfriction = 0.3\n",
        )
        .replace("\"../meshes/", &format!("\"{}/meshes/", root().display()));
    assert!(
        taylor.contains("friction = 0.3"),
        "taylor_impact.toml's impact plane"
    );
    let water = std::fs::read_to_string(root().join("scenes/water_on_floor.toml"))
        .unwrap()
        .replace(
            "normal = [0.0, 0.0, 1.0]\n",
            "normal = [0.0, 0.0, 1.0]\nfriction = 0.3\nvelocity = [1.0, 0.0, 0.0]\n",
        );
    assert!(
        water.contains("friction = 0.3"),
        "water_on_floor.toml's floor"
    );
    for (name, text) in [("taylor_rough", taylor), ("water_rough", water)] {
        let scene = dir.join(format!("{name}.toml"));
        std::fs::write(&scene, text).unwrap();
        let base = dir.join(format!("{name}_np1"));
        run_ok(1, &scene, &base);
        for np in [2, 3] {
            let out = dir.join(format!("{name}_np{np}"));
            run_ok(np, &scene, &out);
            if let Err(e) = fields_differ(&base, &out) {
                panic!("{name}: np {np} against np 1: fields.h5 {e} (same bits expected)");
            }
            for file in ["history.csv", "reactions.csv", "probes.csv"] {
                let bad = csv_columns_differ(&base, &out, file, &[]);
                assert!(
                    bad.is_empty(),
                    "{name}: np {np} against np 1: {file} columns differ (column, first row): {bad:?}"
                );
            }
        }
    }
}

/// A bar of gmsh's default tetrahedra (meshes/bar_tets.geo), each run as 4 hexahedra
/// (coupling/src/input/split.rs, issue 30), struck at 10 m/s against its fixed end, at np 1 to 3:
/// the split is made once on rank 0 and the run is then a hexahedral one, so fields.h5,
/// probes.csv and history.csv are the same bits as at np 1; report.json says what ran (4
/// hexahedra per tetrahedron, the elements counted).
#[test]
fn tetrahedral_mesh_is_the_same_bits_at_1_to_3_ranks() {
    let dir = workdir("one_answer_tets");
    let scene = dir.join("tets.toml");
    std::fs::write(
        &scene,
        format!(
            "title = \"tetrahedral bar\"\n[run]\nend_time = 2.0e-5\noutput_every = 1.0e-5\n\
             [[mesh]]\nfile = \"{}\"\nparams = {{ L = 0.2, A = 0.05, H = 0.025 }}\n\
             [[material]]\nname = \"steel\"\nmodel = \"j2_plastic\"\ndensity = 7850.0\n\
             youngs_modulus = 200.0e9\npoisson_ratio = 0.3\nyield_stress = 350.0e6\nhardening_modulus = 1.0e9\n\
             [[block]]\ngroup = \"bar\"\nmaterial = \"steel\"\nvelocity = [-10.0, 0.0, 0.0]\n\
             [[boundary]]\ngroup = \"left\"\nkind = \"fixed\"\n\
             [[probe]]\nname = \"mid\"\npoint = [0.1, 0.025, 0.025]\nfields = [\"velocity_x\"]\n",
            root().join("meshes/bar_tets.geo").display()
        ),
    )
    .unwrap();
    let base = dir.join("np1");
    run_ok(1, &scene, &base);
    let r = report(&base);
    let split = &r["mesh_split"];
    let tets = split["tetrahedra"].as_u64().unwrap();
    assert!(tets > 100, "a tetrahedral mesh: {split}");
    assert_eq!(
        split["hexahedra_run"].as_u64(),
        Some(4 * tets),
        "4 per tetrahedron"
    );
    assert_eq!(
        r["elements"].as_u64(),
        Some(4 * tets),
        "the hexahedra run are counted"
    );
    np2_and_np3_give_np1s_bits(
        &dir,
        &scene,
        &base,
        "mesh_split",
        &["probes.csv", "history.csv"],
    );
}

/// The same bar as above with its tetrahedra run natively (`[run] tetrahedra =
/// "nodal_pressure"`, fe_petsc/src/tet.rs), at np 1 to 3: the tetrahedra's two nodal sums per
/// step (dilatation, then forces) are the canonical-order sums of `fe_petsc::assembly`, so
/// fields.h5, probes.csv and history.csv are the same bits at every rank count; report.json
/// counts one element per tetrahedron, and no split is made.
#[test]
fn native_tetrahedra_are_the_same_bits_at_1_to_3_ranks() {
    let dir = workdir("one_answer_native_tets");
    let scene = dir.join("tets.toml");
    std::fs::write(
        &scene,
        format!(
            "title = \"tetrahedral bar, native tetrahedra\"\n[run]\nend_time = 2.0e-5\noutput_every = 1.0e-5\n\
             tetrahedra = \"nodal_pressure\"\n\
             [[mesh]]\nfile = \"{}\"\nparams = {{ L = 0.2, A = 0.05, H = 0.025 }}\n\
             [[material]]\nname = \"steel\"\nmodel = \"j2_plastic\"\ndensity = 7850.0\n\
             youngs_modulus = 200.0e9\npoisson_ratio = 0.3\nyield_stress = 350.0e6\nhardening_modulus = 1.0e9\n\
             [[block]]\ngroup = \"bar\"\nmaterial = \"steel\"\nvelocity = [-10.0, 0.0, 0.0]\n\
             [[boundary]]\ngroup = \"left\"\nkind = \"fixed\"\n\
             [[probe]]\nname = \"mid\"\npoint = [0.1, 0.025, 0.025]\nfields = [\"velocity_x\", \"pressure\"]\n",
            root().join("meshes/bar_tets.geo").display()
        ),
    )
    .unwrap();
    let base = dir.join("np1");
    run_ok(1, &scene, &base);
    let r = report(&base);
    assert!(
        r["mesh_split"].is_null(),
        "native tetrahedra are not split: {}",
        r["mesh_split"]
    );
    // The file's tetrahedra, one element each (meshes/bar_tets.geo at H = 0.025: a few
    // hundred).
    let elements = r["elements"].as_u64().unwrap();
    assert!(elements > 100, "a tetrahedral mesh: {elements} elements");
    let (h, rows) = read_csv(&base.join("probes.csv"));
    let v = column(&h, &rows, "mid.velocity_x");
    assert!(
        v.iter().any(|&x| x != 0.0) && v.iter().all(|x| x.is_finite()),
        "the bar moves: {v:?}"
    );
    np2_and_np3_give_np1s_bits(
        &dir,
        &scene,
        &base,
        "elements",
        &["probes.csv", "history.csv"],
    );
}

/// A mesh of hexahedra and native tetrahedra together (`[run] tetrahedra = "nodal_pressure"`;
/// two `[[mesh]]` entries merged: the hexahedral bar of meshes/bar.geo and the tetrahedral one
/// of meshes/bar_tets.geo beside it, one block), both struck at 10 m/s against their fixed
/// ends, at np 1 to 3: the two element kinds' ordered sums (each node's force the hexahedra's
/// sum, then the tetrahedra's) give the same bits in fields.h5, probes.csv and history.csv at
/// every rank count; report.json counts both kinds, and a probe in each bar reads its own
/// element kind.
#[test]
fn hexahedra_beside_native_tetrahedra_are_the_same_bits_at_1_to_3_ranks() {
    let dir = workdir("one_answer_mixed_native");
    let scene = dir.join("mixed.toml");
    std::fs::write(
        &scene,
        format!(
            "title = \"hexahedral and tetrahedral bars\"\n[run]\nend_time = 2.0e-5\noutput_every = 1.0e-5\n\
             tetrahedra = \"nodal_pressure\"\n\
             [[mesh]]\nfile = \"{}\"\nparams = {{ L = 0.2, A = 0.05, N = 8, M = 2 }}\n\
             [[mesh]]\nfile = \"{}\"\nparams = {{ L = 0.2, A = 0.05, H = 0.025 }}\ntranslate = [0.0, 0.1, 0.0]\n\
             [[material]]\nname = \"steel\"\nmodel = \"j2_plastic\"\ndensity = 7850.0\n\
             youngs_modulus = 200.0e9\npoisson_ratio = 0.3\nyield_stress = 350.0e6\nhardening_modulus = 1.0e9\n\
             [[block]]\ngroup = \"bar\"\nmaterial = \"steel\"\nvelocity = [-10.0, 0.0, 0.0]\n\
             [[boundary]]\ngroup = \"left\"\nkind = \"fixed\"\n\
             [[probe]]\nname = \"hex\"\npoint = [0.1, 0.025, 0.025]\nfields = [\"velocity_x\", \"pressure\"]\n\
             [[probe]]\nname = \"tet\"\npoint = [0.1, 0.125, 0.025]\nfields = [\"velocity_x\", \"pressure\"]\n",
            root().join("meshes/bar.geo").display(),
            root().join("meshes/bar_tets.geo").display()
        ),
    )
    .unwrap();
    let base = dir.join("np1");
    run_ok(1, &scene, &base);
    let r = report(&base);
    let kinds = &r["native_tetrahedra"];
    let (tets, hexes) = (
        kinds["tetrahedra"].as_u64().unwrap(),
        kinds["hexahedra"].as_u64().unwrap(),
    );
    assert_eq!(hexes, 8 * 2 * 2, "the hexahedral bar's N x M x M: {kinds}");
    assert!(tets > 100, "the tetrahedral bar: {kinds}");
    assert_eq!(
        r["elements"].as_u64(),
        Some(tets + hexes),
        "both kinds counted"
    );
    let (h, rows) = read_csv(&base.join("probes.csv"));
    for bar in ["hex", "tet"] {
        let v = column(&h, &rows, &format!("{bar}.velocity_x"));
        assert!(
            v.iter().any(|&x| x != 0.0) && v.iter().all(|x| x.is_finite()),
            "the {bar} bar moves: {v:?}"
        );
    }
    np2_and_np3_give_np1s_bits(
        &dir,
        &scene,
        &base,
        "native_tetrahedra",
        &["probes.csv", "history.csv"],
    );
}

/// A run's report.json.
fn report(out: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap()
}

/// `scene` at np 2 and 3 (runs in `dir`/npN) gives the np 1 run's (`base`) bits in fields.h5 and
/// in each of `files`, and the same report.json entry `key` (what ran: the split, the element
/// kinds).
fn np2_and_np3_give_np1s_bits(
    dir: &std::path::Path,
    scene: &std::path::Path,
    base: &std::path::Path,
    key: &str,
    files: &[&str],
) {
    let want = report(base)[key].clone();
    for np in [2, 3] {
        let out = dir.join(format!("np{np}"));
        run_ok(np, scene, &out);
        assert_eq!(report(&out)[key], want, "np {np}: report.json's {key}");
        if let Err(e) = fields_differ(base, &out) {
            panic!("np {np} against np 1: fields.h5 {e} (same bits expected)");
        }
        for file in files {
            let bad = csv_columns_differ(base, &out, file, &[]);
            assert!(
                bad.is_empty(),
                "np {np} against np 1: {file} columns differ: {bad:?}"
            );
        }
    }
}
