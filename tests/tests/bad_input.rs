//! Each documented scene mistake (docs/scene.md) gives one clear line naming the key, a non-zero exit,
//! and no hang, at np 2.
use std::path::{Path, PathBuf};
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
    assert_refused(
        name,
        &scene,
        &dir.join("out"),
        needle,
        name != "missing_file",
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
        "native_tets_implicit",
        |s| {
            s.replace(
                "[run]\n",
                "[run]\ntetrahedra = \"nodal_pressure\"\nmode = \"implicit\"\ndt = 1.0e-6\n",
            )
        },
        "run.tetrahedra",
    );
    expect_error(
        "unknown_tetrahedra",
        |s| s.replace("[run]\n", "[run]\ntetrahedra = \"nodal\"\n"),
        "tetrahedra",
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
        |s| s + "[[probe]]\nname = \"p\"\npoint = [0.5, 0.0, 0.0]\nfields = [\"vorticity\"]\n",
        "vorticity",
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
    // a wall through the middle of the bar (x = 0 to 1 m, held at x = 0): the free nodes
    // past x = 0.5 start behind it
    expect_error(
        "bodies_behind_a_wall",
        |s| {
            s + "[[rigid_wall]]\nname = \"cut\"\npoint = [0.5, 0.0, 0.0]\nnormal = [-1.0, 0.0, 0.0]\n"
        },
        "rigid_wall[0] (\"cut\"): 8 mesh nodes and 0 particles start behind the wall, the deepest 5.000e-1 m",
    );
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
    // Names that head CSV columns: a comma would shift every column after it, a field listed
    // twice would give two columns of one name (probes.csv, contact_forces.csv: docs/output.md).
    let probe = |name: &'static str, fields: &'static str| {
        move |s: String| {
            s + &format!(
                "[[probe]]\nname = \"{name}\"\npoint = [0.5, 0.025, 0.025]\nfields = [{fields}]\n"
            )
        }
    };
    expect_error(
        "probe_name_with_comma",
        probe("a,b", "\"velocity_x\""),
        "probe[0].name: expected a name for probes.csv's columns (not empty, no comma",
    );
    expect_error(
        "probe_field_twice",
        probe("p", "\"velocity_x\", \"stress_xx\", \"velocity_x\""),
        "probe[0].fields[2]: \"velocity_x\" is listed twice",
    );
    expect_error(
        "particles_name_with_comma",
        |s| {
            s + "[[particles]]\nname = \"a,b\"\nmaterial = \"steel\"\nregion = { box = { min = [2.0, 0.0, 0.0], max = [2.01, 0.01, 0.01] } }\nspacing = 0.005\n"
        },
        "particles[0].name: expected a name for contact_forces.csv's columns",
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
    // (a .msh takes no params)
    let text = text
        .replace(&geo, &msh.display().to_string())
        .replace("params = { L = 1.0, A = 0.05, N = 4, M = 1 }\n", "");
    std::fs::write(&scene, text).unwrap();
    let o = run(2, &scene, &dir.join("out"));
    assert!(!o.status.success(), "a broken mesh must fail");
    assert!(
        !String::from_utf8_lossy(&o.stderr).contains("params"),
        "fails on the mesh, not on params"
    );
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
fn pyramids_and_second_order_meshes_are_refused_in_one_line() {
    // Tetrahedra and prisms are split into hexahedra (coupling/src/input/split.rs); pyramids
    // (gmsh makes them where a recombined surface meets tetrahedra) and second-order elements
    // are refused with their count and the gmsh option that avoids them (issue 30).
    let unit_box = "SetFactory(\"OpenCASCADE\");\nBox(1) = {0,0,0,1,1,1};\n";
    let line = refused_mesh(
        "pyramids",
        &format!("{unit_box}Recombine Surface{{1}};\n"),
        "",
        "Mesh.SubdivisionAlgorithm = 2",
    );
    assert!(line.contains("pyramids"), "{line}");
    let line = refused_mesh(
        "order2",
        &format!("{unit_box}Mesh.ElementOrder = 2;\n"),
        "",
        "Mesh.ElementOrder = 1",
    );
    assert!(line.contains("second-order"), "{line}");
}

/// Native tetrahedra (`[run] tetrahedra = "nodal_pressure"`) refuse, in one line at np 1 and
/// 3, what they do not run: a mesh with prisms (they run only as hexahedra, split).
#[test]
fn native_tetrahedra_refuse_prisms_in_one_line() {
    // A triangle-meshed square extruded in layers (gmsh's built-in kernel): prisms.
    let prisms =
        "Point(1) = {0, 0, 0}; Point(2) = {1, 0, 0}; Point(3) = {1, 1, 0}; Point(4) = {0, 1, 0};\n\
                  Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};\n\
                  Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};\n\
                  Extrude {0, 0, 1} { Surface{1}; Layers{2}; Recombine; }\n";
    let line = refused_mesh(
        "native_prisms",
        prisms,
        "tetrahedra = \"nodal_pressure\"",
        "prisms, which run only as hexahedra",
    );
    assert!(line.contains("split"), "the way out: {line}");
}

/// The bar scene (`bar_scene`, the `[run]` lines `run_lines` added) on the mesh of the gmsh geometry
/// `shape` (its physical groups added) is refused at np 1 and 3 with exactly one line holding
/// `needle`; returns that line (np 3's).
fn refused_mesh(name: &str, shape: &str, run_lines: &str, needle: &str) -> String {
    let dir = workdir(name);
    let geo = dir.join(format!("{name}.geo"));
    std::fs::write(
        &geo,
        format!(
            "{shape}Mesh.MeshSizeMax = 0.5;\n\
             Physical Volume(\"bar\") = {{1}};\nPhysical Surface(\"left\") = {{1}};\n\
             Physical Surface(\"sides_y\") = {{3, 4}};\nPhysical Surface(\"sides_z\") = {{5, 6}};\n"
        ),
    )
    .unwrap();
    let scene = bar_scene(&dir, 4, &format!("end_time = 1.0e-5\n{run_lines}"), "");
    let text = std::fs::read_to_string(&scene).unwrap();
    let bar = root().join("meshes").join("bar.geo").display().to_string();
    // (the bar's parameters dropped: this .geo takes none, and a parameter it never uses is
    // refused)
    let text = text.replace("params = { L = 1.0, A = 0.05, N = 4, M = 1 }\n", "");
    std::fs::write(&scene, text.replace(&bar, &geo.display().to_string())).unwrap();
    let mut last = String::new();
    for np in [1, 3] {
        let o = run(np, &scene, &dir.join(format!("out{np}")));
        assert!(!o.status.success(), "{name}: must be refused at np {np}");
        let err = String::from_utf8_lossy(&o.stderr);
        let lines: Vec<&str> = err.lines().filter(|l| l.contains(needle)).collect();
        assert_eq!(
            lines.len(),
            1,
            "{name} at np {np}: one line naming {needle}:\n{err}"
        );
        last = lines[0].to_string();
    }
    last
}

/// One bad-input case: a scene (and its arguments) that once hung a rank or ran on silently,
/// and what its one line must say (docs/scene.md "Exit status": the file, the key or the element
/// and its place, what was expected).
struct Case {
    name: String,
    scene: PathBuf,
    out: PathBuf,
    needles: Vec<String>,
}

/// Longest a bad case may take to exit at any rank count ("within 10 s").
const EXIT_WITHIN_S: f64 = 10.0;
/// mpirun is killed after this long: a case that reaches it hung.
const HANG_KILL_S: u32 = 40;

/// The rows of the `$Elements` section of msh text, with their line index.
fn element_rows(text: &str) -> Vec<(usize, Vec<String>)> {
    let lines: Vec<&str> = text.lines().collect();
    let start = lines.iter().position(|l| *l == "$Elements").unwrap() + 2;
    lines[start..]
        .iter()
        .take_while(|l| !l.starts_with('$'))
        .enumerate()
        .map(|(k, l)| (start + k, l.split(' ').map(String::from).collect()))
        .collect()
}

/// `text` with line `i` replaced.
fn with_line(text: &str, i: usize, line: &str) -> String {
    let mut lines: Vec<&str> = text.lines().collect();
    lines[i] = line;
    lines.join("\n") + "\n"
}

/// A gmsh mesh of the test bar (4 hexahedra along x), msh 2.2, and its variants broken the ways
/// the bad-input cases list; each variant with what its message must name, found from the text here.
fn broken_meshes(dir: &Path) -> Vec<(&'static str, String, Vec<String>)> {
    let msh = dir.join("bar.msh");
    let o = std::process::Command::new("gmsh")
        .arg(root().join("meshes").join("bar.geo"))
        .args([
            "-3",
            "-format",
            "msh22",
            "-setnumber",
            "N",
            "4",
            "-setnumber",
            "M",
            "1",
            "-o",
        ])
        .arg(&msh)
        .output()
        .expect("gmsh is needed (make setup installs it)");
    assert!(o.status.success(), "gmsh: {o:?}");
    let text = std::fs::read_to_string(&msh).unwrap();
    let rows = element_rows(&text);
    let (i, hex) = rows.iter().find(|(_, r)| r[1] == "5").unwrap().clone();
    let (id, nodes) = (&hex[0], &hex[hex.len() - 8..]);
    let head = hex[..hex.len() - 8].join(" ");
    let row = |ns: &[String]| format!("{head} {}", ns.join(" "));
    let mut repeated = nodes.to_vec();
    repeated[7] = nodes[6].clone();
    let mut missing = nodes.to_vec();
    missing[7] = "999999".into();
    let inverted: Vec<String> = nodes[4..].iter().chain(&nodes[..4]).cloned().collect();
    let lines: Vec<&str> = text.lines().collect();
    let n0 = lines.iter().position(|l| *l == "$Nodes").unwrap() + 2;
    let node: Vec<&str> = lines[n0].split(' ').collect();
    let nan_node = format!("{} nan {} {}", node[0], node[2], node[3]);
    let cut = lines[..i].join("\n") + "\n";
    vec![
        ("msh_truncated", cut, vec!["truncated".into()]),
        (
            "msh_repeated_node",
            with_line(&text, i, &row(&repeated)),
            vec![format!(
                "element {id} (hexahedron) lists node {} twice",
                nodes[6]
            )],
        ),
        (
            "msh_missing_node",
            with_line(&text, i, &row(&missing)),
            vec![format!("element {id} (hexahedron) refers to node 999999")],
        ),
        (
            "msh_inverted",
            with_line(&text, i, &row(&inverted)),
            vec![
                format!("element {id} (hexahedron) is inverted"),
                "centroid (".into(),
            ],
        ),
        (
            "msh_nan_coordinate",
            with_line(&text, n0, &nan_node),
            vec![format!("node {} has a non-finite coordinate", node[0])],
        ),
    ]
}

/// Every bad-input case (its hangs and its silent inputs), written into `dir`.
fn issue_16_cases(dir: &Path) -> Vec<Case> {
    let base_dir = dir.join("base");
    std::fs::create_dir_all(&base_dir).unwrap();
    let base = std::fs::read_to_string(bar_scene(
        &base_dir,
        4,
        "end_time = 1.0e-5",
        "[[boundary]]\ngroup = \"left\"\nkind = \"fixed\"\n",
    ))
    .unwrap();
    let geo = root().join("meshes").join("bar.geo").display().to_string();
    let water = "[[material]]\nname = \"water\"\nmodel = \"fluid\"\ndensity = 1000.0\n\
                 eos = { kind = \"tait\", rho0 = 1000.0, sound_speed = 1480.0, gamma = 7.0 }\n\
                 [[particles]]\nname = \"blob\"\nmaterial = \"water\"\nspacing = 0.01\n";
    let box_region = |min: &str| {
        format!("region = {{ box = {{ min = [{min}, 0.0, 0.0], max = [0.1, 0.1, 0.1] }} }}\n")
    };
    let run = |key: &str| base.replace("end_time = 1.0e-5", key);
    let mut scenes: Vec<(String, String, Vec<String>)> = vec![
        (
            "output_every_1e-18".into(),
            run("end_time = 1.0e-5\noutput_every = 1e-18"),
            vec!["run.output_every".into(), "frames".into()],
        ),
        (
            "history_every_1e-18".into(),
            run("end_time = 1.0e-5\nhistory_every = 1e-18"),
            vec!["run.history_every".into(), "rows".into()],
        ),
        (
            "dt_1e-300".into(),
            run("end_time = 1.0e-5\ndt = 1e-300"),
            vec!["run.dt".into(), "run.max_steps".into()],
        ),
        (
            "end_time_1e30".into(),
            run("end_time = 1.0e30"),
            vec!["run.end_time".into(), "run.max_steps".into()],
        ),
        (
            "two_blocks".into(),
            base.clone() + "[[block]]\ngroup = \"bar\"\nmaterial = \"steel\"\n",
            vec!["block[1].group".into(), "already has a block".into()],
        ),
        (
            "velocity_of_4".into(),
            base.replace(
                "material = \"steel\"\n\n",
                "material = \"steel\"\nvelocity = [1.0, 0.0, 0.0, 4.0]\n\n",
            ),
            vec!["block[0].velocity".into(), "got 4 values".into()],
        ),
        (
            "velocity_nan".into(),
            base.replace(
                "material = \"steel\"\n\n",
                "material = \"steel\"\nvelocity = [nan, 0.0, 0.0]\n\n",
            ),
            vec!["block[0].velocity".into(), "finite".into()],
        ),
        (
            "density_string".into(),
            base.replace("density = 7850.0", "density = \"7850\""),
            vec![
                "material[0].density".into(),
                "expected a number, got a string".into(),
            ],
        ),
        (
            "toml_syntax".into(),
            base.replace("[run]", "[run"),
            vec!["line 2, column".into()],
        ),
        (
            "particles_min_-9.2e18".into(),
            base.clone() + water + &box_region("-9.2e18"),
            vec!["particles[0].spacing".into(), "more than the 1e9".into()],
        ),
        (
            "particles_min_1e30".into(),
            base.clone() + water + &box_region("1e30"),
            vec!["particles[0].region.box".into()],
        ),
    ];
    for n in ["0", "-5", "1e12", "nan", "10.5"] {
        scenes.push((
            format!("mesh_param_N_{n}"),
            base.replace("N = 4,", &format!("N = {n},")),
            vec!["mesh[0].params.N".into()],
        ));
    }
    // A parameter the .geo never uses (a typo of M): gmsh would mesh with the file's default.
    scenes.push((
        "mesh_param_typo".into(),
        base.replace("N = 4,", "N = 4, m = 2,"),
        vec![
            "mesh[0].params.m".into(),
            "bar.geo never uses m".into(),
            "it takes A, L, M, N".into(),
        ],
    ));
    for (name, text, needles) in broken_meshes(dir) {
        let msh = dir.join(format!("{name}.msh"));
        std::fs::write(&msh, text).unwrap();
        let mut needles = needles;
        needles.push(format!("{name}.msh"));
        // (a .msh takes no params: refused with them)
        scenes.push((
            name.into(),
            base.replace(&geo, &msh.display().to_string())
                .replace("params = { L = 1.0, A = 0.05, N = 4, M = 1 }\n", ""),
            needles,
        ));
    }
    let mut cases: Vec<Case> = scenes
        .into_iter()
        .map(|(name, text, mut needles)| {
            let scene = dir.join(format!("{name}.toml"));
            std::fs::write(&scene, text).unwrap();
            needles.push(format!("{name}.toml"));
            Case {
                out: dir.join(format!("out_{name}")),
                name,
                scene,
                needles,
            }
        })
        .collect();
    // `--out` naming a file: the directory cannot be created (and the file stays as it was).
    let file = dir.join("a_file");
    std::fs::write(&file, "an earlier result\n").unwrap();
    let scene = dir.join("out_is_a_file.toml");
    std::fs::write(&scene, &base).unwrap();
    cases.push(Case {
        name: "out_is_a_file".into(),
        scene,
        out: file,
        needles: vec!["a_file".into(), "not a folder".into()],
    });
    cases
}

/// Runs one case at `np` ranks: None when it exits non-zero within [`EXIT_WITHIN_S`] with one
/// error line that says what it must; else what went wrong.
fn check_case(case: &Case, np: usize) -> Option<String> {
    let t0 = std::time::Instant::now();
    let o = mpirun(np, HANG_KILL_S)
        .arg(tdyn())
        .arg("run")
        .arg(&case.scene)
        .arg("--out")
        .arg(&case.out)
        .arg("--quiet")
        .output()
        .expect("mpirun");
    let took = t0.elapsed().as_secs_f64();
    let err = String::from_utf8_lossy(&o.stderr);
    let errors = err
        .lines()
        .filter(|l| l.starts_with("tdyn: error:"))
        .count();
    let what = format!("{} at np {np} ({took:.1} s)", case.name);
    if o.status.code() == Some(124) {
        return Some(format!(
            "{what}: hung (killed after {HANG_KILL_S} s):\n{err}"
        ));
    }
    if o.status.success() {
        return Some(format!("{what}: exit 0, a failure expected"));
    }
    if took > EXIT_WITHIN_S {
        return Some(format!("{what}: took more than {EXIT_WITHIN_S} s:\n{err}"));
    }
    if errors != 1 {
        return Some(format!(
            "{what}: {errors} error lines, one expected:\n{err}"
        ));
    }
    let missing: Vec<&String> = case.needles.iter().filter(|n| !err.contains(*n)).collect();
    if !missing.is_empty() {
        return Some(format!("{what}: the message lacks {missing:?}:\n{err}"));
    }
    None
}

/// Issue 16: each case that hung a rank, ran until killed or ran on silently exits non-zero
/// with its one line within 10 s, at np 1, 2 and 3 (two runs at a time: the machine has two
/// cores).
#[test]
fn every_case_of_issue_16_exits_with_its_message_at_np_1_2_3() {
    let dir = workdir("issue16");
    let cases = issue_16_cases(&dir);
    let runs: Vec<(&Case, usize)> = cases
        .iter()
        .flat_map(|c| [1, 2, 3].map(|np| (c, np)))
        .collect();
    let next = std::sync::atomic::AtomicUsize::new(0);
    let failures = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| loop {
                let k = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                let Some(&(case, np)) = runs.get(k) else {
                    break;
                };
                if let Some(f) = check_case(case, np) {
                    failures.lock().unwrap().push(f);
                }
            });
        }
    });
    let failures = failures.into_inner().unwrap();
    assert!(
        failures.is_empty(),
        "{} of {} runs failed:\n{}",
        failures.len(),
        runs.len(),
        failures.join("\n\n")
    );
    assert_eq!(
        std::fs::read_to_string(dir.join("a_file")).unwrap(),
        "an earlier result\n",
        "--out naming a file leaves the file as it was"
    );
}

/// The water block of scenes/water_on_floor.toml with its floor raised through the water: every
/// particle below the raised plane is named as starting behind it, in one line, at np 2.
#[test]
fn particles_behind_a_rigid_wall_are_refused() {
    let dir = workdir("bad_particles_behind_wall");
    let scene = dir.join("scene.toml");
    let text = bundled_scene("water_on_floor");
    let raised = text.replacen("point = [0.0, 0.0, 0.0]", "point = [0.0, 0.0, 1.0]", 1);
    assert_ne!(text, raised, "the floor's point is in the scene");
    std::fs::write(&scene, raised).unwrap();
    assert_scene_refused(
        "particles behind a wall",
        &scene,
        &dir.join("out"),
        "rigid_wall[0] (\"floor\"): 0 mesh nodes and",
    );
}

#[test]
fn particles_on_a_face_inside_a_meshed_body_are_refused_and_on_its_outer_face_accepted() {
    // docs/scene.md: a particle may not start inside a meshed body (nothing would push it out:
    // particle-face contact sees crossings only). A plate 4 mm thick of two hexahedra through
    // its thickness (meshes/plate.geo) has an inner face at z = -2 mm; a lattice of spacing
    // 2 mm whose layer lies on it (z = -2 mm exactly, x and y off the element faces) is inside
    // the plate, on no element's interior: refused, naming the entry and the block. The same
    // lattice one layer up, resting on the plate's top face (z = 0), is outside: accepted.
    let dir = workdir("particles_on_inner_face");
    let scene = |zmin: f64, zmax: f64| {
        format!(
            "title = \"jet on plate\"\n[run]\nend_time = 1.0e-7\n[[mesh]]\nfile = \"{}\"\n\
             params = {{ L = 0.1, T = 0.004, N = 10, M = 2 }}\n\
             [[material]]\nname = \"steel\"\nmodel = \"elastic\"\ndensity = 7850.0\n\
             youngs_modulus = 200.0e9\npoisson_ratio = 0.3\n\
             [[material]]\nname = \"water\"\nmodel = \"fluid\"\ndensity = 1000.0\n\
             eos = {{ kind = \"tait\", rho0 = 1000.0, sound_speed = 50.0, gamma = 7.0 }}\n\
             [[block]]\ngroup = \"plate\"\nmaterial = \"steel\"\n\
             [[particles]]\nname = \"jet\"\nmaterial = \"water\"\nspacing = 0.002\n\
             region = {{ box = {{ min = [-0.008, -0.008, {zmin}], max = [0.008, 0.008, {zmax}] }} }}\n\
             velocity = [0.0, 0.0, -50.0]\n\
             [contact]\nsurfaces = [\"top\"]\nparticles = true\n",
            root().join("meshes/plate.geo").display()
        )
    };
    let inner = dir.join("scene.toml");
    std::fs::write(&inner, scene(-0.003, -0.001)).unwrap();
    assert_scene_refused(
        "a lattice on the plate's inner face",
        &inner,
        &dir.join("inner"),
        "particles[0] \"jet\": a particle at (-0.007, -0.007, -0.002) starts inside block \"plate\"",
    );
    let outer = dir.join("outer.toml");
    std::fs::write(&outer, scene(-0.001, 0.001)).unwrap();
    let o = run(2, &outer, &dir.join("outer"));
    assert!(
        o.status.success(),
        "a lattice resting on the plate's top face is outside it:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn an_empty_physical_group_and_params_on_a_msh_are_refused_at_np_3() {
    // gmsh writes the name of a physical group that holds no element (`Physical Surface("x") =
    // {};`, or wrong entity numbers), so the name check alone passes: a condition, load or
    // block on it acted on nothing without a word. And `params` on a .msh file (already
    // meshed) were ignored without a word. Each must be one line naming the key, at np 3 too.
    let dir = workdir("bad_empty_groups");
    let geo = dir.join("bar_empty.geo");
    let text = std::fs::read_to_string(root().join("meshes").join("bar.geo")).unwrap()
        + "Physical Surface(\"nothing\") = {};\nPhysical Volume(\"no_volume\") = {};\n";
    std::fs::write(&geo, text).unwrap();
    let scene = bar_scene(&dir, 4, "end_time = 1.0e-5", "");
    let base = std::fs::read_to_string(&scene).unwrap().replace(
        &root().join("meshes/bar.geo").display().to_string(),
        "bar_empty.geo",
    );
    let msh = dir.join("bar.msh");
    let o = std::process::Command::new("gmsh")
        .arg(root().join("meshes").join("bar.geo"))
        .args(["-3", "-format", "msh22", "-setnumber", "N", "4", "-o"])
        .arg(&msh)
        .output()
        .expect("gmsh is needed (make setup installs it)");
    assert!(o.status.success(), "gmsh: {o:?}");
    let cases: [(&str, String, &str); 5] = [
        (
            "boundary",
            base.clone() + "[[boundary]]\ngroup = \"nothing\"\nkind = \"fixed\"\n",
            "boundary[2].group: the physical surface \"nothing\" holds no elements",
        ),
        (
            "load",
            base.clone() + "[[load]]\ngroup = \"nothing\"\npressure = 1.0e6\n",
            "load[0].group: the physical surface \"nothing\" holds no elements",
        ),
        (
            "block",
            base.clone() + "[[block]]\ngroup = \"no_volume\"\nmaterial = \"steel\"\n",
            "block[1].group: the physical volume \"no_volume\" holds no elements",
        ),
        (
            "contact",
            base.clone() + "[contact]\nsurfaces = [\"left\", \"nothing\"]\n",
            "contact.surfaces[1]: the physical surface \"nothing\" holds no elements",
        ),
        (
            "msh_params",
            base.replace("bar_empty.geo", "bar.msh"),
            "mesh[0].params.A: bar.msh is read as it is: params are passed to gmsh to mesh a .geo",
        ),
    ];
    for (name, text, needle) in cases {
        std::fs::write(&scene, &text).unwrap();
        let out = dir.join(format!("out_{name}"));
        let o = mpirun(3, 120)
            .arg(tdyn())
            .args(["run"])
            .arg(&scene)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{name}: must fail at np 3:\n{err}");
        let lines: Vec<&str> = err.lines().filter(|l| l.contains("tdyn: error")).collect();
        assert!(
            lines.len() == 1 && lines[0].contains(needle) && lines[0].contains("scene.toml"),
            "{name}: one line at np 3 naming the file and {needle:?}:\n{err}"
        );
        assert!(!err.contains("panicked"), "{name}: no panic:\n{err}");
    }
}

#[test]
fn a_gmsh_failure_is_one_short_line_at_np_3() {
    // A mesh size of 0 (`bar_tets.geo`'s H) makes gmsh print one error per curve and surface,
    // about 1,580 lines: the message quoted them all, joined into one line of about 120 kB.
    // Now the distinct error lines (at most 3) and the count of the others.
    let dir = workdir("bad_gmsh_failure");
    let scene = dir.join("scene.toml");
    std::fs::write(
        &scene,
        format!(
            "[run]\nend_time = 1.0e-5\n[[mesh]]\nfile = \"{}\"\nparams = {{ L = 0.2, A = 0.05, H = 0.0 }}\n\
             [[material]]\nname = \"steel\"\nmodel = \"elastic\"\ndensity = 7850.0\nyoungs_modulus = 200.0e9\npoisson_ratio = 0.3\n\
             [[block]]\ngroup = \"bar\"\nmaterial = \"steel\"\n",
            root().join("meshes/bar_tets.geo").display()
        ),
    )
    .unwrap();
    let o = mpirun(3, 120)
        .arg(tdyn())
        .arg("run")
        .arg(&scene)
        .arg("--out")
        .arg(dir.join("out"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "must fail:\n{err}");
    let lines: Vec<&str> = err.lines().filter(|l| l.contains("tdyn: error")).collect();
    assert_eq!(lines.len(), 1, "one error line:\n{err}");
    let l = lines[0];
    assert!(
        l.contains("mesh[0]: gmsh failed on")
            && l.contains("Wrong mesh element size lc = 0")
            && l.contains("more error lines")
            && l.len() < 500,
        "one short line naming the key and gmsh's distinct errors ({} chars):\n{}",
        l.len(),
        &l[..l.len().min(2000)]
    );
}

#[test]
fn a_global_mesh_size_far_below_the_model_is_refused_before_gmsh_hangs() {
    // `bar_tets.geo` sets Mesh.MeshSizeMin/Max = H. H = 1e-9 m on a 0.2 m bar (a unit slip)
    // kept gmsh meshing the curves (2e8 points each) for more than 10 minutes: a hang. Now
    // refused at once, naming the size, the extent and the params; the reference is the
    // ratio extent / size = 0.2 / 1e-9 = 2e8 > 1e6 (the most elements docs/scene.md allows
    // along a curve). H = 0.02 (10 along the bar) still runs.
    let dir = workdir("bad_tiny_mesh_size");
    let scene = dir.join("scene.toml");
    let text = |h: &str| {
        format!(
            "[run]\nend_time = 1.0e-6\n[[mesh]]\nfile = \"{}\"\nparams = {{ L = 0.2, A = 0.05, H = {h} }}\n\
             [[material]]\nname = \"steel\"\nmodel = \"elastic\"\ndensity = 7850.0\nyoungs_modulus = 200.0e9\npoisson_ratio = 0.3\n\
             [[block]]\ngroup = \"bar\"\nmaterial = \"steel\"\n",
            root().join("meshes/bar_tets.geo").display()
        )
    };
    std::fs::write(&scene, text("1.0e-9")).unwrap();
    let t0 = std::time::Instant::now();
    let o = mpirun(3, 120)
        .arg(tdyn())
        .arg("run")
        .arg(&scene)
        .arg("--out")
        .arg(dir.join("out"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "must fail:\n{err}");
    assert!(
        t0.elapsed().as_secs() < 60,
        "refused at once, not after gmsh's meshing ({:?})",
        t0.elapsed()
    );
    let lines: Vec<&str> = err.lines().filter(|l| l.contains("tdyn: error")).collect();
    assert!(
        lines.len() == 1
            && lines[0].contains("mesh[0]")
            && lines[0].contains("the mesh size Mesh.MeshSizeMax = 1e-9 m is 2.0e8 times smaller")
            && lines[0].contains("H = 1e-9"),
        "one line naming the size, the ratio and the params:\n{err}"
    );
    std::fs::write(&scene, text("0.02")).unwrap();
    run_ok(3, &scene, &dir.join("ok"));
    // The same size set per point (`block_tet.geo`: MeshSize{ PointsOf{ Volume{1}; } } = H).
    let block = std::fs::read_to_string(&scene)
        .unwrap()
        .replace("bar_tets.geo", "block_tet.geo")
        .replace("H = 0.02", "H = 1.0e-9");
    std::fs::write(&scene, block).unwrap();
    let o = mpirun(3, 120)
        .arg(tdyn())
        .arg("run")
        .arg(&scene)
        .arg("--out")
        .arg(dir.join("out_points"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    let lines: Vec<&str> = err.lines().filter(|l| l.contains("tdyn: error")).collect();
    assert!(
        !o.status.success()
            && lines.len() == 1
            && lines[0]
                .contains("the point size MeshSize{...} = H = 1e-9 m is 2.0e8 times smaller"),
        "a point size: one line naming the statement and the ratio:\n{err}"
    );
}
