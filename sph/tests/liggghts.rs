//! Operator-level cross-check against the peer code LIGGGHTS-PUBLIC 3.8.0 (Debian's `liggghts`).
//!
//! Reference: LIGGGHTS itself, run on the deck `scenes/liggghts/in.random1step` (1,000 jittered
//! particles, random velocities, densities 995..1005 so that pressures of both signs occur, no
//! walls, no gravity, non-periodic, one rank, so no ghosts): Tait EOS, cubic spline, continuity,
//! artificial viscosity alpha 0.1, beta 0.2, eta = 0.01 h^2, tensile correction epsilon 0.2 with
//! delta_p = dx, `nve/sph`, dt = 1e-4, dumped at steps 0..5 with 17 significant digits.
//! Our `Profile::Liggghts` runs the same particles (read from the same data file), and x, v, f,
//! rho, p must agree at every step to 1e-12 of each field's largest magnitude (round-off
//! differences of the summation order give ~1e-15).
//!
//! The same deck edited to LIGGGHTS's `wendland` kernel checks our Wendland constant.
//! A third test runs the dam-break deck `scenes/liggghts/in.dambreak3d` for 40 steps (fixed
//! wall particles, gravity) with the same tolerance.
//!
//! Needs `liggghts` and `python3` on PATH (scripts/setup.sh installs liggghts).
use sph::{
    ArtificialViscosity, DensityMode, Eos, Kernel, NewParticle, Params, Particles, Profile,
    SerialSim, TensileCorrection,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The deck's settings (in.random1step): dx, h = 1.2 dx (printed by LIGGGHTS as 0.012), Tait
/// rho0 1000, c0 20, gamma 7, alpha 0.1, beta 0.2, epsilon 0.2, dt 1e-4, 5 steps.
const DX: f64 = 0.01;
const H: f64 = 0.012;
const DT: f64 = 1e-4;
/// in.dambreak3d's step.
const DAMBREAK_DT: f64 = 5e-5;
const NSTEPS: usize = 5;
/// Largest accepted |ours - LIGGGHTS| / max |LIGGGHTS| per field.
const TOL: f64 = 1e-12;

fn on_path(exe: &str) -> bool {
    std::env::var_os("PATH")
        .map(|p| std::env::split_paths(&p).any(|d| d.join(exe).is_file()))
        .unwrap_or(false)
}

struct Atom {
    rho: f64,
    x: [f64; 3],
    v: [f64; 3],
    kind: u32,
}

/// Reads a `gen_data.py` data file: Masses, Atoms (`id type rho 0 x y z 0 0`), Velocities.
fn read_data(path: &Path) -> (BTreeMap<u64, Atom>, BTreeMap<u32, f64>) {
    let text = std::fs::read_to_string(path).unwrap();
    let (mut atoms, mut masses) = (BTreeMap::new(), BTreeMap::new());
    let mut section = "";
    for line in text.lines().skip(1) {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        if matches!(line, "Masses" | "Atoms" | "Velocities") {
            section = match line {
                "Masses" => "m",
                "Atoms" => "a",
                _ => "v",
            };
            continue;
        }
        let w: Vec<&str> = line.split_whitespace().collect();
        let f = |i: usize| w[i].parse::<f64>().unwrap();
        match section {
            "m" => {
                masses.insert(w[0].parse().unwrap(), f(1));
            }
            "a" => {
                assert_eq!(w.len(), 9, "Atoms line: {line}");
                atoms.insert(
                    w[0].parse().unwrap(),
                    Atom {
                        kind: w[1].parse().unwrap(),
                        rho: f(2),
                        x: [f(4), f(5), f(6)],
                        v: [0.0; 3],
                    },
                );
            }
            "v" => {
                let id: u64 = w[0].parse().unwrap();
                atoms.get_mut(&id).unwrap().v = [f(1), f(2), f(3)];
            }
            _ => {}
        }
    }
    (atoms, masses)
}

/// Reads one `dump custom` snapshot into columns by name, rows by id.
fn read_dump(path: &Path) -> BTreeMap<u64, BTreeMap<String, f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines
        .by_ref()
        .find(|l| l.starts_with("ITEM: ATOMS"))
        .unwrap();
    let cols: Vec<String> = header
        .split_whitespace()
        .skip(2)
        .map(String::from)
        .collect();
    let mut out = BTreeMap::new();
    for l in lines {
        let w: Vec<f64> = l.split_whitespace().map(|s| s.parse().unwrap()).collect();
        if w.is_empty() {
            continue;
        }
        let row: BTreeMap<String, f64> = cols.iter().cloned().zip(w.iter().copied()).collect();
        out.insert(row["id"] as u64, row);
    }
    out
}

/// max |ours - theirs| / max |theirs| over the particles and the given columns (absolute when
/// the reference is all zero).
fn field_error(
    parts: &Particles,
    dump: &BTreeMap<u64, BTreeMap<String, f64>>,
    cols: &[&str],
    ours: impl Fn(usize, usize) -> f64,
) -> f64 {
    field_error_over(parts, dump, cols, ours, |_| true)
}

/// `field_error` over the particles that move.
fn field_error_moving(
    parts: &Particles,
    dump: &BTreeMap<u64, BTreeMap<String, f64>>,
    cols: &[&str],
    ours: impl Fn(usize, usize) -> f64,
) -> f64 {
    field_error_over(parts, dump, cols, ours, |i| !parts.fixed[i])
}

fn field_error_over(
    parts: &Particles,
    dump: &BTreeMap<u64, BTreeMap<String, f64>>,
    cols: &[&str],
    ours: impl Fn(usize, usize) -> f64,
    keep: impl Fn(usize) -> bool,
) -> f64 {
    let (mut diff, mut scale) = (0.0f64, 0.0f64);
    for i in (0..parts.n_owned).filter(|&i| keep(i)) {
        let row = &dump[&parts.id[i]];
        for (c, name) in cols.iter().enumerate() {
            let theirs = row[*name];
            diff = diff.max((ours(i, c) - theirs).abs());
            scale = scale.max(theirs.abs());
        }
    }
    if scale > 0.0 {
        diff / scale
    } else {
        diff
    }
}

/// Runs `gen_data.py <kind>` and `liggghts -in <deck> <vars>` in `dir`, the deck's text passed
/// through `edit` first.
fn run_liggghts(dir: &Path, kind: &str, deck: &str, vars: &[&str], edit: impl Fn(&str) -> String) {
    // the decks and generator shared with the scenes and `tdyn crosscheck`
    let src = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenes/liggghts");
    std::fs::copy(src.join("gen_data.py"), dir.join("gen_data.py")).unwrap();
    let text = std::fs::read_to_string(src.join(deck)).unwrap();
    std::fs::write(dir.join(deck), edit(&text)).unwrap();
    let st = Command::new("python3")
        .args(["gen_data.py", kind])
        .current_dir(dir)
        .output()
        .expect("python3 gen_data.py");
    assert!(st.status.success(), "gen_data.py failed: {st:?}");
    let mut args = vec!["-in", deck];
    args.extend_from_slice(vars);
    let st = Command::new("liggghts")
        .args(&args)
        .current_dir(dir)
        .output()
        .expect("liggghts");
    assert!(
        st.status.success(),
        "liggghts failed: {}",
        String::from_utf8_lossy(&st.stdout)
    );
}

fn check_tools() {
    assert!(
        on_path("liggghts"),
        "`liggghts` is not on PATH: run scripts/setup.sh (it installs Debian's liggghts package, \
         `apt-get install -y --no-install-recommends liggghts`)"
    );
    assert!(
        on_path("python3"),
        "`python3` is not on PATH (needed for gen_data.py)"
    );
}

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sph-liggghts-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The random-blob deck with `kernel` (LIGGGHTS's name) against our `Kernel`, and continuity
/// or summation density (`fix sph/density/summation` in place of `sph/density/continuity`),
/// 5 steps.
fn random_blob(kernel_name: &str, kernel: Kernel, density: DensityMode) {
    check_tools();
    let fix = match density {
        DensityMode::Continuity => "sph/density/continuity",
        DensityMode::Summation => "sph/density/summation",
    };
    let dir = temp_dir(&format!("{kernel_name}-{density:?}"));
    run_liggghts(&dir, "random", "in.random1step", &[], |deck| {
        deck.replace("cubicspline", kernel_name)
            .replace("sph/density/continuity", fix)
    });
    let mut params = deck_params(0.1, 0.2, [0.0; 3]);
    params.kernel = kernel;
    params.density = density;
    let mut sim = SerialSim::new(particles_from(&dir, "data.random"), params);
    sim.setup();
    let mut worst = 0.0f64;
    for step in 0..=NSTEPS {
        if step > 0 {
            sim.step(DT);
        }
        worst = worst.max(compare(&sim, &dir.join(format!("dump.r1.{step}")), step));
    }
    println!("{kernel_name} {density:?}: largest relative difference over {NSTEPS} steps and all fields: {worst:.3e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Our particles from a data file: type 1 moves, type 2 is fixed (the decks' `nve/sph/stationary`
/// group), h = 0.012 for all.
fn particles_from(dir: &Path, data: &str) -> Particles {
    let (atoms, masses) = read_data(&dir.join(data));
    let mut parts = Particles::new();
    for (&id, a) in &atoms {
        parts.push(NewParticle {
            id,
            x: a.x,
            v: a.v,
            m: masses[&a.kind],
            rho: a.rho,
            e: 0.0,
            h: H,
            mat: 0,
            fixed: a.kind == 2,
        });
    }
    parts
}

/// The decks' model: Tait rho0 1000, c0 20, gamma 7; cubic spline; continuity; viscosity
/// (alpha, beta), eta = 0.01 h^2; tensile correction epsilon 0.2, delta_p = dx.
fn deck_params(alpha: f64, beta: f64, gravity: [f64; 3]) -> Params {
    let mut params = Params::new(vec![Eos::Tait {
        rho0: 1000.0,
        c0: 20.0,
        gamma: 7.0,
    }]);
    params.profile = Profile::Liggghts;
    params.kernel = Kernel::CubicSpline;
    params.density = DensityMode::Continuity;
    params.viscosity = Some(ArtificialViscosity::new(alpha, beta));
    params.tensile = Some(TensileCorrection::monaghan(0.2, DX));
    params.gravity = gravity;
    params
}

/// Compares x, v, f, rho, p with a dump; returns the largest relative difference.
fn compare(sim: &SerialSim, dump_path: &Path, step: usize) -> f64 {
    let dump = read_dump(dump_path);
    assert_eq!(dump.len(), sim.parts.n_owned);
    let p = &sim.parts;
    let errs = [
        (
            "x",
            field_error(p, &dump, &["x", "y", "z"], |i, c| p.x[i][c]),
        ),
        (
            "v",
            field_error(p, &dump, &["vx", "vy", "vz"], |i, c| p.v[i][c]),
        ),
        // forces on moving particles only: LIGGGHTS also sums wall-wall pair forces onto fixed
        // particles, which never act (they do not move); we skip those pairs
        (
            "f",
            field_error_moving(p, &dump, &["fx", "fy", "fz"], |i, c| p.f[i][c]),
        ),
        ("rho", field_error(p, &dump, &["rho"], |i, _| p.rho[i])),
        ("p", field_error(p, &dump, &["p"], |i, _| p.p[i])),
    ];
    println!("step {step}: pairs {} {errs:?}", sim.n_pairs);
    let mut worst = 0.0f64;
    for (name, e) in errs {
        assert!(
            e <= TOL,
            "step {step}: {name} differs from LIGGGHTS by {e:.3e} of its max (tol {TOL:e})"
        );
        worst = worst.max(e);
    }
    worst
}

#[test]
fn matches_liggghts_random_blob_five_steps() {
    random_blob("cubicspline", Kernel::CubicSpline, DensityMode::Continuity);
}

/// The same deck with summation density, both kernels: checks the kernel values W (the
/// continuity runs only see dW/dr and ratios of W).
#[test]
fn matches_liggghts_random_blob_summation() {
    random_blob("cubicspline", Kernel::CubicSpline, DensityMode::Summation);
    random_blob("wendland", Kernel::Wendland, DensityMode::Summation);
}

/// The same deck with LIGGGHTS's `wendland` kernel (the deck edited: pair style and `set ...
/// sphkernel`).
#[test]
fn matches_liggghts_random_blob_wendland() {
    random_blob("wendland", Kernel::Wendland, DensityMode::Continuity);
}

/// The dam break deck (4,000 fluid particles, 14,568 fixed wall particles, gravity on the fluid
/// only, alpha 0.1, beta 0, dt 5e-5), 40 steps, compared at steps 0, 20 and 40: checks the
/// fixed particles (`nve/sph/stationary`: density only) and gravity.
#[test]
fn matches_liggghts_dam_break_forty_steps() {
    check_tools();
    let dir = temp_dir("dambreak");
    let (nsteps, every) = (40, 20);
    let vars = [
        "-var",
        "nsteps",
        "40",
        "-var",
        "dumpevery",
        "20",
        "-var",
        "tag",
        "db",
    ];
    run_liggghts(&dir, "dambreak", "in.dambreak3d", &vars, |deck| {
        deck.to_string()
    });
    let params = deck_params(0.1, 0.0, [0.0, 0.0, -9.81]);
    let mut sim = SerialSim::new(particles_from(&dir, "data.dambreak3d"), params);
    sim.setup();
    let mut worst = compare(&sim, &dir.join("dump.db.0"), 0);
    for step in 1..=nsteps {
        sim.step(DAMBREAK_DT);
        if step % every == 0 {
            worst = worst.max(compare(&sim, &dir.join(format!("dump.db.{step}")), step));
        }
    }
    println!("largest relative difference: {worst:.3e}");
    let _ = std::fs::remove_dir_all(&dir);
}
