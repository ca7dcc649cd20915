//! Helpers for the integration tests: find or build `tdyn`, write scenes, run under mpirun,
//! read the CSV output.
pub mod frames;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// The release `tdyn` binary, built once if missing.
pub fn tdyn() -> PathBuf {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| release_bin("tdyn", "tdyn")).clone()
}

/// The release binary `tdyn_selftest` of this package (the kernels' and the output's MPI
/// self-tests, kept out of `tdyn`), built on first use.
pub fn selftest_bin() -> PathBuf {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| release_bin("tdyn-tests", "tdyn_selftest"))
        .clone()
}

/// Builds package `package`'s release binaries and returns binary `name`'s path.
fn release_bin(package: &str, name: &str) -> PathBuf {
    let target = std::env::var("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|_| root().join("target"));
    let st = Command::new(env!("CARGO"))
        .args(["build", "--release", "-p", package, "--bins"])
        .current_dir(root())
        .status()
        .expect("cargo build");
    assert!(st.success(), "building {package} failed");
    target.join("release").join(name)
}

/// A fresh directory for one test.
pub fn workdir(name: &str) -> PathBuf {
    let d = root().join("target").join("test-runs").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `timeout LIMIT_S mpirun -np NP`, with the environment mpirun needs here (as root, more
/// ranks than cores); add the program and its arguments (and mpirun's own `-x` first).
pub fn mpirun(np: usize, limit_s: u32) -> Command {
    let mut c = Command::new("timeout");
    c.args([&limit_s.to_string(), "mpirun", "-np", &np.to_string()]);
    mpi_env(&mut c);
    c
}

/// Sets the environment mpirun needs here on `c` (as root, more ranks than cores), and a
/// session directory base of its own ([`session_base`]).
pub fn mpi_env(c: &mut Command) -> &mut Command {
    c.env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("OMPI_MCA_rmaps_base_oversubscribe", "1")
        .env("OMPI_MCA_orte_tmpdir_base", session_base())
}

/// A new, empty directory for one mpirun's session files (Open MPI's `orte_tmpdir_base`).
/// Why: the suite starts several mpiruns at once, and by default they share
/// `/tmp/ompi.<host>.<uid>`; one job's clean-up removing it while another job creates its own
/// session directory under it made that job fail to start ("A call to mkdir was unable to
/// create the desired directory ... File exists", seen once in a run of the suite).
pub fn session_base() -> PathBuf {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("tdyn-tests-mpi/{}-{n}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a session directory for mpirun");
    dir
}

/// `mpirun -np N tdyn run scene EXTRA --out out --quiet` (10 min limit).
fn launch(np: usize, scene: &Path, out: &Path, extra: &[&str]) -> Output {
    mpirun(np, 600)
        .arg(tdyn())
        .arg("run")
        .arg(scene)
        .args(extra)
        .arg("--out")
        .arg(out)
        .arg("--quiet")
        .output()
        .expect("mpirun")
}

/// Insists that a run succeeded, printing its output otherwise.
fn assert_ran(o: &Output, what: &str) {
    assert!(
        o.status.success(),
        "tdyn {what} failed:\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Runs `mpirun -np N tdyn run scene --out out --quiet` (10 min limit) and returns its output.
pub fn run(np: usize, scene: &Path, out: &Path) -> Output {
    launch(np, scene, out, &[])
}

/// Runs with `extra` arguments after the scene (e.g. `--param H=0.025`) and insists on success;
/// a run with contact must keep docs/scene.md's promise that contact never gives energy back
/// ([`assert_contact_energy_never_falls`], the model's mass from report.json).
pub fn run_ok_args(np: usize, scene: &Path, out: &Path, extra: &[&str]) {
    let o = launch(np, scene, out, extra);
    assert_ran(&o, &format!("at np {np} with {extra:?}"));
    check_contact_energy(out);
}

/// Runs and insists on success (and on contact's energy, as [`run_ok_args`]).
pub fn run_ok(np: usize, scene: &Path, out: &Path) {
    assert_ran(&run(np, scene, out), &format!("at np {np}"));
    check_contact_energy(out);
}

/// [`run_ok`] for a run whose `contact_energy` may fall by up to `limit` of the energy scale
/// between rows (docs/scene.md's 1e-3 elsewhere): only for a case the caller measured and explains.
pub fn run_ok_with_contact_fall(np: usize, scene: &Path, out: &Path, limit: f64) {
    assert_ran(&run(np, scene, out), &format!("at np {np}"));
    assert_contact_energy_falls_at_most(out, limit);
}

/// [`assert_contact_energy_never_falls`] for a run whose history has contact.
fn check_contact_energy(out: &Path) {
    assert_contact_energy_falls_at_most(out, 1e-3);
}

/// [`assert_contact_energy_never_falls`] with the bound `limit` (a fraction of the energy
/// scale), for a run whose history has contact; the model's mass from report.json.
fn assert_contact_energy_falls_at_most(out: &Path, limit: f64) {
    let (h, _) = read_csv(&out.join("history.csv"));
    if !h.iter().any(|c| c == "contact_energy") {
        return;
    }
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let mass = r["mass"].as_f64().unwrap_or(0.0);
    contact_energy_fall(out, mass, limit);
}

/// A CSV file as (header, rows).
pub fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    // lines starting with '#' are comments (the reference data files say where they come from)
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|s| s.to_string())
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse::<f64>().unwrap()).collect())
        .collect();
    (header, rows)
}

/// A column of a CSV by name.
pub fn column(h: &[String], rows: &[Vec<f64>], name: &str) -> Vec<f64> {
    let k = h
        .iter()
        .position(|c| c == name)
        .unwrap_or_else(|| panic!("no column {name}"));
    rows.iter().map(|r| r[k]).collect()
}

/// The bar scene used by the wave, vibration and rank tests: steel, uniaxial strain (symmetry
/// planes on the lateral faces). `extra` is appended (boundaries, probes, run keys).
pub fn bar_scene(dir: &Path, n: usize, run: &str, extra: &str) -> PathBuf {
    let geo = root().join("meshes").join("bar.geo");
    let text = format!(
        "title = \"test bar\"\n[run]\n{run}\n\n[[mesh]]\nfile = \"{}\"\nparams = {{ L = 1.0, A = 0.05, N = {n}, M = 1 }}\n\n\
         [[material]]\nname = \"steel\"\nmodel = \"elastic\"\ndensity = 7850.0\nyoungs_modulus = 200.0e9\npoisson_ratio = 0.3\n\n\
         [[block]]\ngroup = \"bar\"\nmaterial = \"steel\"\n\n\
         [[boundary]]\ngroup = \"sides_y\"\nkind = \"symmetry\"\n\n[[boundary]]\ngroup = \"sides_z\"\nkind = \"symmetry\"\n\n{extra}\n",
        geo.display()
    );
    let p = dir.join("scene.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// The test bar (steel, 1 m, uniaxial strain, `n` elements) in implicit mode with step `dt`
/// to `end`, its block given `block` (extra keys) and `extra` appended.
pub fn implicit_bar(
    dir: &Path,
    n: usize,
    (dt, end): (f64, f64),
    block: &str,
    extra: &str,
) -> PathBuf {
    let run =
        format!("end_time = {end:e}\nmode = \"implicit\"\ndt = {dt:e}\noutput_every = {dt:e}");
    let p = bar_scene(dir, n, &run, extra);
    let text = std::fs::read_to_string(&p).unwrap();
    let from = "material = \"steel\"\n\n[[boundary]]";
    assert!(text.contains(from), "bar_scene's block");
    let text = text.replace(
        from,
        &format!("material = \"steel\"\n{block}\n\n[[boundary]]"),
    );
    std::fs::write(&p, text).unwrap();
    p
}

/// A rigid wall at x = 0 facing +x, named "target" (the implicit bar's wall).
pub const WALL_AT_0: &str =
    "[[rigid_wall]]\nname = \"target\"\npoint = [0.0, 0.0, 0.0]\nnormal = [1.0, 0.0, 0.0]\n";

/// A steel bar (meshes/bar.geo: 1 m, 0.05 x 0.05 m, 20 elements, free sides) of J2 steel
/// failing at `failure`, hanging from its face x = 1 ("right", fixed) under gravity -x ramped
/// from 0 to 2e5 m/s^2 over 2 ms, to 3 ms; written into `dir`.
pub fn hanging_bar_scene(dir: &Path, failure: &str) -> PathBuf {
    let geo = root().join("meshes").join("bar.geo");
    let text = format!(
        "title = \"a bar hanging until its top fails\"\n\
         gravity = [-2.0e5, 0.0, 0.0]\ngravity_curve = [[0.0, 0.0], [2.0e-3, 1.0]]\n\
         [run]\nend_time = 3.0e-3\noutput_every = 5.0e-5\n\n\
         [[mesh]]\nfile = \"{}\"\nparams = {{ L = 1.0, A = 0.05, N = 20, M = 1 }}\n\n\
         [[material]]\nname = \"steel\"\nmodel = \"j2_plastic\"\ndensity = {RHO:e}\n\
         youngs_modulus = {E:e}\npoisson_ratio = {NU}\nyield_stress = 350.0e6\n\
         hardening_modulus = 1.0e9\nfailure = {failure}\n\n\
         [[block]]\ngroup = \"bar\"\nmaterial = \"steel\"\nfailed = \"delete\"\n\n\
         [[boundary]]\ngroup = \"right\"\nkind = \"fixed\"\n",
        geo.display()
    );
    let p = dir.join("scene.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// `dir/name`, created.
pub fn mkdir(dir: &Path, name: &str) -> PathBuf {
    let d = dir.join(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The time integral of a reactions.csv force column (each row holds the mean force over the
/// interval since the row before: docs/output.md), N s.
pub fn impulse(out: &Path, column_name: &str) -> f64 {
    let (h, rows) = read_csv(&out.join("reactions.csv"));
    let (t, f) = (column(&h, &rows, "time"), column(&h, &rows, column_name));
    (1..t.len()).map(|k| f[k] * (t[k] - t[k - 1])).sum()
}

/// scenes/kirchhoff_plate.toml in implicit mode (`mode = "implicit"`, dt = 1 ms: 48 steps, about
/// a fifth of the plate's first period), its mesh path made absolute, written into `dir`.
pub fn implicit_plate_scene(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(root().join("scenes/kirchhoff_plate.toml"))
        .unwrap()
        .replace(
            "end_time = 0.048\n",
            "end_time = 0.048\nmode = \"implicit\"\ndt = 1.0e-3\n",
        )
        .replace(
            "\"../meshes/",
            &format!("\"{}/", root().join("meshes").display()),
        );
    assert!(
        text.contains("mode = \"implicit\""),
        "the plate scene's [run]"
    );
    let scene = dir.join("plate_implicit.toml");
    std::fs::write(&scene, text).unwrap();
    scene
}

/// Steel: rho, E, nu and the dilatational wave speed sqrt((lambda + 2 mu)/rho).
pub const RHO: f64 = 7850.0;
/// Young's modulus, Pa.
pub const E: f64 = 200.0e9;
/// Poisson's ratio.
pub const NU: f64 = 0.3;

/// Dilatational (uniaxial-strain) wave speed of the test steel, m/s.
pub fn c_dilatational() -> f64 {
    (E * (1.0 - NU) / ((1.0 + NU) * (1.0 - 2.0 * NU)) / RHO).sqrt()
}

/// Runs `mpirun -np NP tdyn_selftest KERNEL --seed SEED` and asserts it passed (the self-test
/// itself compares with its references and says "passed").
pub fn selftest(np: usize, kernel: &str, seed: u64, timeout_s: u32) {
    let o = mpirun(np, timeout_s)
        .arg(selftest_bin())
        .args([kernel, "--seed", &seed.to_string()])
        .output()
        .expect("mpirun could not be started");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success() && out.contains("passed"),
        "selftest {kernel} at np {np}, seed {seed}:\n{out}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A case's reference.toml (`validation/<case>/`), parsed.
pub fn reference_case(case: &str) -> toml::Table {
    let path = root().join("validation").join(case).join("reference.toml");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.parse()
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The reference value of the measure named `measure` in `validation/<case>/reference.toml` (its
/// `reference`, or the midpoint of its `range`): the one copy of a published or analytic
/// number that the validation suite and the tests share.
pub fn reference_value(case: &str, measure: &str) -> f64 {
    let t = reference_case(case);
    let m = t["measure"]
        .as_array()
        .and_then(|ms| ms.iter().find(|m| m["name"].as_str() == Some(measure)))
        .unwrap_or_else(|| panic!("validation/{case}: no measure \"{measure}\""));
    let num = |v: &toml::Value| v.as_float().or(v.as_integer().map(|i| i as f64)).unwrap();
    match (m.get("reference"), m.get("range")) {
        (Some(r), _) => num(r),
        (None, Some(toml::Value::Array(r))) => 0.5 * (num(&r[0]) + num(&r[1])),
        _ => panic!("validation/{case}: measure \"{measure}\" has no reference value"),
    }
}

/// `tdyn validate --fast --cases CASES --np NP --out target/test-runs/TAG` (not under mpirun:
/// it launches its runs itself); returns (success, report.md).
pub fn validate_fast(cases: &str, np: usize, tag: &str) -> (bool, String) {
    validate(cases, np, tag, true, 600)
}

/// `tdyn validate [--fast] --cases CASES --np NP --out target/test-runs/TAG`, killed after
/// `limit_s`; returns (success, report.md).
pub fn validate(cases: &str, np: usize, tag: &str, fast: bool, limit_s: u32) -> (bool, String) {
    let dir = workdir(tag);
    let o = mpi_env(&mut Command::new("timeout"))
        .arg(limit_s.to_string())
        .arg(tdyn())
        .arg("validate")
        .args(fast.then_some("--fast"))
        .args(["--quiet", "--cases", cases])
        .args(["--np", &np.to_string(), "--dir"])
        .arg(root().join("validation"))
        .arg("--out")
        .arg(&dir)
        .output()
        .expect("tdyn validate");
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap_or_else(|_| {
        format!(
            "no report.md:\n{}\n{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        )
    });
    (o.status.success(), report)
}

/// docs/scene.md "Contact never gives energy back": between consecutive rows of `out`'s
/// history.csv, `contact_energy` falls by at most `1e-3` of the run's energy scale there, the
/// largest of |E(0)| + |W_external|, the kinetic and internal (plus hourglass) energies reached
/// so far, and the floor `0.5 mass (1 mm/s)^2` (`mass`: the model's, kg, from its geometry).
/// Returns the largest fall over that scale.
pub fn assert_contact_energy_never_falls(out: &Path, mass: f64) -> f64 {
    contact_energy_fall(out, mass, 1e-3)
}

/// The largest fall of `contact_energy` between rows as a fraction of the energy scale,
/// asserted at most `limit`.
fn contact_energy_fall(out: &Path, mass: f64, limit: f64) -> f64 {
    let (h, rows) = read_csv(&out.join("history.csv"));
    let col = |n: &str| column(&h, &rows, n);
    let (ke, ie, hg, w, ce) = (
        col("kinetic_energy"),
        col("internal_energy"),
        col("hourglass_energy"),
        col("external_work"),
        col("contact_energy"),
    );
    let e0 = ke[0] + ie[0] + hg[0] + ce[0];
    let (mut ke_max, mut ie_max, mut worst) = (0.0f64, 0.0f64, 0.0f64);
    for i in 0..rows.len() {
        ke_max = ke_max.max(ke[i].abs());
        ie_max = ie_max.max((ie[i] + hg[i]).abs());
        let scale = (e0.abs() + w[i].abs())
            .max(ke_max)
            .max(ie_max)
            .max(0.5 * mass * 1e-6);
        if i > 0 {
            let fall = (ce[i - 1] - ce[i]) / scale;
            worst = worst.max(fall);
            assert!(
                fall <= limit,
                "{}: contact_energy fell from {} to {} J at row {i} (t = {}), {fall:.3e} of the energy scale {scale:.3e} J (limit {limit:e})",
                out.display(),
                ce[i - 1],
                ce[i],
                rows[i][1]
            );
        }
    }
    worst
}

/// Every frame's values in `fields.h5` of run `b` against run `a`, matched by id in each
/// group that has ids (nodes, elements, particles): `Err` names the first frame, group and
/// dataset whose bits differ (the rank column and the ids themselves are not compared).
pub fn fields_differ(a: &Path, b: &Path) -> Result<(), String> {
    let (fa, fb) = (
        hdf5::File::open(a.join("fields.h5")).map_err(|e| e.to_string())?,
        hdf5::File::open(b.join("fields.h5")).map_err(|e| e.to_string())?,
    );
    let mut frames = fa.group("frames").unwrap().member_names().unwrap();
    frames.sort();
    let mut fb_frames = fb.group("frames").unwrap().member_names().unwrap();
    fb_frames.sort();
    if frames != fb_frames {
        return Err(format!("frames {} and {}", frames.len(), fb_frames.len()));
    }
    for fr in &frames {
        let (ga, gb) = (
            fa.group(&format!("frames/{fr}")).unwrap(),
            fb.group(&format!("frames/{fr}")).unwrap(),
        );
        for grp in ga.member_names().unwrap() {
            let (Ok(ha), Ok(hb)) = (ga.group(&grp), gb.group(&grp)) else {
                continue;
            };
            let (Ok(ia), Ok(ib)) = (ha.dataset("id"), hb.dataset("id")) else {
                continue;
            };
            let (ia, ib): (Vec<u64>, Vec<u64>) = (ia.read_raw().unwrap(), ib.read_raw().unwrap());
            let order = |ids: &[u64]| {
                let mut o: Vec<usize> = (0..ids.len()).collect();
                o.sort_by_key(|&i| ids[i]);
                o
            };
            let (oa, ob) = (order(&ia), order(&ib));
            if oa.iter().map(|&i| ia[i]).ne(ob.iter().map(|&i| ib[i])) {
                return Err(format!("frame {fr}, {grp}: other ids"));
            }
            for ds in ha.member_names().unwrap() {
                if ds == "id" || ds == "rank" {
                    continue;
                }
                let va: Vec<f64> = ha.dataset(&ds).unwrap().read_raw().unwrap();
                let vb: Vec<f64> = hb.dataset(&ds).unwrap().read_raw().unwrap();
                let w = va.len() / ia.len().max(1);
                let same = va.len() == vb.len()
                    && oa.iter().zip(&ob).all(|(&i, &j)| {
                        (0..w).all(|c| va[i * w + c].to_bits() == vb[j * w + c].to_bits())
                    });
                if !same {
                    return Err(format!("frame {fr}, {grp}/{ds}: other bits"));
                }
            }
        }
    }
    Ok(())
}

/// The columns of CSV file `name` in runs `a` and `b` whose text differs in some row (`skip`
/// left out), with the first such row; and whether the row counts differ.
pub fn csv_columns_differ(a: &Path, b: &Path, name: &str, skip: &[&str]) -> Vec<(String, usize)> {
    let read = |d: &Path| std::fs::read_to_string(d.join(name)).unwrap();
    let (ta, tb) = (read(a), read(b));
    let (la, lb): (Vec<&str>, Vec<&str>) = (ta.lines().collect(), tb.lines().collect());
    let head: Vec<&str> = la[0].split(',').collect();
    let mut out: Vec<(String, usize)> = Vec::new();
    if la.len() != lb.len() {
        out.push((format!("rows {} and {}", la.len(), lb.len()), 0));
    }
    for (r, (x, y)) in la.iter().zip(&lb).enumerate().skip(1) {
        for (k, (u, v)) in x.split(',').zip(y.split(',')).enumerate() {
            let h = head.get(k).copied().unwrap_or("?");
            if u != v && !skip.contains(&h) && !out.iter().any(|(c, _)| c == h) {
                out.push((h.to_string(), r));
            }
        }
    }
    out
}

/// Runs `scene` at np 2, which must fail with a message that contains `needle` and names the
/// scene file `scene.toml` (docs/scene.md: the file, the key, what was expected); `name` labels
/// the case in the assertion.
pub fn assert_scene_refused(name: &str, scene: &Path, out: &Path, needle: &str) {
    assert_refused(name, scene, out, needle, true);
}

/// [`assert_scene_refused`], the file named only when `names_scene` (a mistake in another
/// file, a missing mesh, names that file instead).
pub fn assert_refused(name: &str, scene: &Path, out: &Path, needle: &str, names_scene: bool) {
    let o = run(2, scene, out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{name}: must fail");
    assert!(
        err.contains(needle),
        "{name}: stderr should mention {needle:?}:\n{err}"
    );
    assert!(
        !names_scene || err.contains("scene.toml"),
        "{name}: the message names the file:\n{err}"
    );
}

/// The text of the bundled scene `scenes/NAME.toml` with its meshes' paths made absolute, so a
/// test can change it and write it anywhere.
pub fn bundled_scene(name: &str) -> String {
    std::fs::read_to_string(root().join(format!("scenes/{name}.toml")))
        .unwrap()
        .replace("\"../meshes/", &format!("\"{}/meshes/", root().display()))
}

/// Runs `scene` at np 1 and np 3 in `dir` (`np1`, `np3`) and asserts the same bytes
/// ([`run_digest`]); returns the np 1 output folder.
pub fn run_np1_np3_same_bytes(scene: &Path, dir: &Path) -> PathBuf {
    let (a, b) = (dir.join("np1"), dir.join("np3"));
    run_ok(1, scene, &a);
    run_ok(3, scene, &b);
    assert_eq!(run_digest(&a), run_digest(&b), "np 3 against np 1");
    a
}

/// A run's bits in one number: FNV-1a (64 bits) over history.csv without the run's own
/// measurements (`contact_imbalance`, `contact_bytes`), then probes.csv, reactions.csv and
/// contact_forces.csv (those the run wrote), then every frame's
/// datasets in fields.h5 (each group's values in id order, the rank column left out). Two runs
/// with the same digest wrote the same results; the one-answer guarantee (docs/scene.md) says
/// every CPU writes the same digest for a scene. `run_digest DIR` prints it.
pub fn run_digest(out: &Path) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    let text = std::fs::read_to_string(out.join("history.csv")).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let keep: Vec<bool> = head
        .iter()
        .map(|c| !["contact_imbalance", "contact_bytes"].contains(c))
        .collect();
    for line in std::iter::once(head.join(",").as_str()).chain(lines) {
        for (cell, _) in line.split(',').zip(&keep).filter(|(_, &k)| k) {
            eat(cell.as_bytes());
            eat(b",");
        }
        eat(b"\n");
    }
    for file in ["probes.csv", "reactions.csv", "contact_forces.csv"] {
        eat(&std::fs::read(out.join(file)).unwrap_or_default());
    }
    let file = hdf5::File::open(out.join("fields.h5")).unwrap();
    let mut frames = file.group("frames").unwrap().member_names().unwrap();
    frames.sort();
    for fr in &frames {
        let g = file.group(&format!("frames/{fr}")).unwrap();
        let mut groups = g.member_names().unwrap();
        groups.sort();
        for grp in groups {
            let Ok(gg) = g.group(&grp) else { continue };
            let Ok(ids) = gg.dataset("id") else { continue };
            let ids: Vec<u64> = ids.read_raw().unwrap();
            let mut order: Vec<usize> = (0..ids.len()).collect();
            order.sort_by_key(|&i| ids[i]);
            let mut names = gg.member_names().unwrap();
            names.sort();
            for ds in names.iter().filter(|d| *d != "id" && *d != "rank") {
                let v: Vec<f64> = gg.dataset(ds).unwrap().read_raw().unwrap();
                let w = v.len() / ids.len().max(1);
                eat(format!("{fr}/{grp}/{ds}").as_bytes());
                for &i in &order {
                    for c in 0..w {
                        eat(&v[i * w + c].to_bits().to_le_bytes());
                    }
                }
            }
        }
    }
    format!("{h:016x}")
}

/// A 40 x 40 x 20 mm block of elastic rubber particles (spacing 4 mm) resting in the corner of
/// two rigid walls, the floor z = 0 and the wall x = 0, gravity tilted 30 degrees towards the
/// wall, 20 ms (tests/tests/rigid_wall.rs), written into `dir`.
pub fn corner_block_scene(dir: &Path) -> PathBuf {
    let scene = dir.join("corner.toml");
    std::fs::write(
        &scene,
        r#"title = "Rubber block resting in a corner of two rigid walls"
gravity = [-4.905, 0.0, -8.496]
[run]
end_time = 0.02
history_every = 1.0e-4
[[material]]
name = "rubber"
model = "elastic"
density = 1200.0
youngs_modulus = 1.0e7
poisson_ratio = 0.4
[[particles]]
name = "block"
material = "rubber"
region = { box = { min = [0.0, 0.0, 0.0], max = [0.04, 0.04, 0.02] } }
spacing = 0.004
[[rigid_wall]]
name = "floor"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[[rigid_wall]]
name = "wall"
point = [0.0, 0.0, 0.0]
normal = [1.0, 0.0, 0.0]
"#,
    )
    .unwrap();
    scene
}
