//! Each documented scene mistake (SCENE.md) gives one clear line naming the key, a non-zero exit,
//! and no hang, at np 2.
use tdyn_tests::*;

fn expect_error(name: &str, mutate: impl Fn(String) -> String, needle: &str) {
    let dir = workdir(&format!("bad_{name}"));
    let scene = bar_scene(
        &dir,
        4,
        "end_time = 1.0e-5",
        "[[boundary]]\ngroup = \"left\"\nkind = \"fixed\"\n",
    );
    let text = mutate(std::fs::read_to_string(&scene).unwrap());
    std::fs::write(&scene, text).unwrap();
    let o = run(2, &scene, &dir.join("out"));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{name}: must fail");
    assert!(
        err.contains(needle),
        "{name}: stderr should mention {needle:?}:\n{err}"
    );
    assert!(
        err.contains("scene.toml") || name == "missing_file",
        "{name}: the message names the file:\n{err}"
    );
}

#[test]
fn documented_mistakes_give_clear_messages() {
    expect_error(
        "unknown_key",
        |s| s.replace("[run]\n", "[run]\nbogus = 1\n"),
        "bogus",
    );
    expect_error(
        "negative_end",
        |s| s.replace("end_time = 1.0e-5", "end_time = -1.0"),
        "run.end_time",
    );
    expect_error(
        "unknown_material",
        |s| s.replace("material = \"steel\"", "material = \"stel\""),
        "no material named \"stel\"",
    );
    expect_error(
        "unknown_model",
        |s| s.replace("model = \"elastic\"", "model = \"rubber\""),
        "unknown model \"rubber\"",
    );
    expect_error(
        "missing_modulus",
        |s| s.replace("youngs_modulus = 200.0e9\n", ""),
        "youngs_modulus",
    );
    expect_error(
        "bad_poisson",
        |s| s.replace("poisson_ratio = 0.3", "poisson_ratio = 0.7"),
        "poisson_ratio",
    );
    expect_error(
        "missing_group",
        |s| s.replace("group = \"left\"", "group = \"lft\""),
        "no physical surface \"lft\"",
    );
    expect_error(
        "missing_volume",
        |s| s.replace("group = \"bar\"", "group = \"rod\""),
        "no physical volume \"rod\"",
    );
    expect_error(
        "bad_kind",
        |s| s.replace("kind = \"fixed\"", "kind = \"glued\""),
        "unknown kind \"glued\"",
    );
    expect_error(
        "velocity_without_value",
        |s| s.replace("kind = \"fixed\"", "kind = \"velocity\""),
        "velocity",
    );
    expect_error(
        "fixed_and_velocity",
        |s| s + "[[boundary]]\ngroup = \"left\"\nkind = \"velocity\"\nvelocity = [1.0, 0.0, 0.0]\n",
        "fixed group",
    );
    expect_error(
        "velocity_into_symmetry",
        |s| {
            s.replace(
                "kind = \"fixed\"",
                "kind = \"velocity\"\nvelocity = [0.0, 1.0, 0.0]",
            )
        },
        "symmetry plane",
    );
    expect_error(
        "dt_above_limit",
        |s| s.replace("end_time = 1.0e-5", "end_time = 1.0e-5\ndt = 1.0e-3"),
        "stable limit",
    );
    expect_error(
        "probe_outside",
        |s| s + "[[probe]]\nname = \"p\"\npoint = [5.0, 0.0, 0.0]\nfields = [\"pressure\"]\n",
        "outside the mesh",
    );
    expect_error(
        "bad_probe_field",
        |s| s + "[[probe]]\nname = \"p\"\npoint = [0.5, 0.0, 0.0]\nfields = [\"temperature\"]\n",
        "temperature",
    );
    expect_error(
        "implicit_without_dt",
        |s| {
            s.replace(
                "end_time = 1.0e-5",
                "end_time = 1.0e-5\nmode = \"implicit\"",
            )
        },
        "run.dt",
    );
    expect_error(
        "missing_file",
        |s| s.replace("bar.geo", "nope.geo"),
        "nope.geo",
    );
    // [contact] passes and master (docs/running.md, contact).
    let contact = |keys: &'static str| {
        move |s: String| s + "[contact]\nsurfaces = [\"left\", \"right\"]\n" + keys
    };
    expect_error("contact_passes", contact("passes = 3\n"), "contact.passes");
    expect_error(
        "contact_one_pass_without_master",
        contact("passes = 1\n"),
        "passes = 1 needs the master bodies",
    );
    expect_error(
        "contact_master_with_two_passes",
        contact("master = [\"bar\"]\n"),
        "a master is only read with passes = 1",
    );
    expect_error(
        "contact_unknown_master",
        contact("passes = 1\nmaster = [\"rod\"]\n"),
        "contact.master[0]: no physical volume \"rod\"",
    );
}

#[test]
fn an_unreadable_mesh_and_a_blow_up_are_reported() {
    // A .msh that is not a mesh.
    let dir = workdir("bad_mesh");
    let msh = dir.join("broken.msh");
    std::fs::write(&msh, "this is not a gmsh file\n").unwrap();
    let scene = bar_scene(&dir, 4, "end_time = 1.0e-5", "");
    let text = std::fs::read_to_string(&scene).unwrap();
    let geo = root().join("meshes").join("bar.geo").display().to_string();
    std::fs::write(&scene, text.replace(&geo, &msh.display().to_string())).unwrap();
    let o = run(2, &scene, &dir.join("out"));
    assert!(!o.status.success(), "a broken mesh must fail");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("broken.msh"), "names the mesh:\n{err}");

    // A violent compression that must invert elements: the left end of a 1 m bar driven at
    // 3 km/s for 0.5 ms (1.5 m) against a fixed right end. It must stop with the element, the
    // place and the time (or the energy check), and never hang.
    let dir = workdir("inversion");
    let scene = bar_scene(&dir, 8, "end_time = 5.0e-4\nmax_energy_error = 0.5", "[[boundary]]\ngroup = \"left\"\nkind = \"velocity\"\nvelocity = [3000.0, 0.0, 0.0]\n[[boundary]]\ngroup = \"right\"\nkind = \"fixed\"\n");
    let o = run(2, &scene, &dir.join("out"));
    assert!(
        !o.status.success(),
        "crushing the bar flat must stop the run"
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("inverted") || err.contains("energy error") || err.contains("non-finite"),
        "clear reason:\n{err}"
    );
}

#[test]
fn tetrahedral_meshes_are_refused_with_a_reason() {
    // The element is an 8-node hexahedron: a tetrahedral mesh is refused by name.
    let dir = workdir("tets");
    let geo = dir.join("tets.geo");
    std::fs::write(
        &geo,
        "SetFactory(\"OpenCASCADE\");\nBox(1) = {0,0,0,1,1,1};\nMesh.MeshSizeMax = 0.5;\n\
         Physical Volume(\"bar\") = {1};\nPhysical Surface(\"left\") = {1};\n\
         Physical Surface(\"sides_y\") = {3, 4};\nPhysical Surface(\"sides_z\") = {5, 6};\n",
    )
    .unwrap();
    let scene = bar_scene(&dir, 4, "end_time = 1.0e-5", "");
    let text = std::fs::read_to_string(&scene).unwrap();
    let bar = root().join("meshes").join("bar.geo").display().to_string();
    std::fs::write(&scene, text.replace(&bar, &geo.display().to_string())).unwrap();
    let o = run(2, &scene, &dir.join("out"));
    assert!(!o.status.success(), "a tetrahedral mesh must be refused");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("tetrahedron") && err.contains("hexahedral"),
        "names the problem:\n{err}"
    );
}
