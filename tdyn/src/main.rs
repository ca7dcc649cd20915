//! `tdyn`: run a scene (and chart its energies), compare explicit and implicit integration on
//! it, sweep its resolution, run the validation suite, chart a scaling study, mesh a .geo. PETSc
//! options (`-log_view`, `-ksp_type cg`, `-pc_type gamg`, `-ksp_monitor`,
//! `-petscpartitioner_type simple`, ...) may follow the other arguments and go to PETSc unchanged.
// Index loops over points and components read like the formulas; `!(x > 0.0)` deliberately also
// rejects NaN.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]
// The option structs' doc comments are the command line's `--help` text (clap), written for a
// terminal: `<scene name>` and `[sweep]` there are words for the user, not HTML or links.
#![allow(rustdoc::invalid_html_tags, rustdoc::broken_intra_doc_links)]

mod chart;
mod compare;
mod crosscheck;
mod csv;
mod energies;
mod force_chart;
mod launch;
mod scaling;
mod sweep;
mod validate;

use clap::{Parser, Subcommand};
use coupling::driver::{self, RunOptions};
use coupling::kernels::collective::{first_error, ExitGate, EXIT_GRACE};
use fe_petsc::petsc::Petsc;
use mpi::traits::*;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "tdyn",
    version,
    about = "Parallel transient dynamics: FE, SPH and contact (PRONTO-3D's algorithms)"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

/// `--contact-decomposition`.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum ContactDecomposition {
    /// Contact's own RCB decomposition (Fig. 10).
    Rcb,
    /// The static FE decomposition (benchmark baseline).
    Static,
}

/// `--kernel`.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Kernel {
    /// The widest every rank's CPU offers (eight lanes with AVX-512F, four with AVX2, else
    /// one).
    Auto,
    /// One element at a time.
    Scalar,
    /// Four elements per group (AVX2 on x86-64).
    Lanes4,
    /// Eight elements per group (AVX-512F only).
    Lanes8,
}

/// `--contact-rebuild`, `--sph-pairs`.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Rebuild {
    /// Keep between steps within a skin.
    Kept,
    /// Rebuild every step.
    EveryStep,
}

/// `GHOST,CANDIDATE`: two positive numbers.
fn parse_skins(s: &str) -> Result<(f64, f64), String> {
    let bad = || format!("expected GHOST,CANDIDATE (two positive numbers, e.g. 200,30), got {s:?}");
    let (a, b) = s.split_once(',').ok_or_else(bad)?;
    let (a, b): (f64, f64) = (
        a.trim().parse().map_err(|_| bad())?,
        b.trim().parse().map_err(|_| bad())?,
    );
    if !(a > 0.0 && b > 0.0 && a.is_finite() && b.is_finite()) {
        return Err(bad());
    }
    Ok((a, b))
}

#[derive(Subcommand)]
enum Cmd {
    /// Run a scene: `mpirun -np 2 tdyn run scenes/slug_on_plate.toml [--out DIR] [PETSc
    /// options]`. Unless --quiet, ends by drawing the energies over time (energies.png and
    /// energies.svg in DIR) and naming the output files.
    Run(RunArgs),
    /// Chart accuracy against cost over a ladder of resolutions:
    /// `mpirun -np 2 tdyn sweep scenes/bar_wave.toml --param N=10,20,40,80
    /// [--measure mid.stress_xx:final=-4.599e7] [--out DIR] [PETSc options]`. Each run is made
    /// in this process, on the same ranks; writes accuracy_cost.csv, accuracy_cost.png and
    /// accuracy_cost.svg in DIR (error against loop wall time, model memory and peak RSS). Runs
    /// that stop or fail are reported: the command still exits 0.
    Sweep(SweepArgs),
    /// Draw a run's energies over time from its output folder: `tdyn plot out/slug_on_plate`
    /// writes energies.png and energies.svg there from history.csv (what `tdyn run` draws at
    /// the end of a run). No MPI.
    ///
    /// With `--force NAME --displacement PROBE` it draws force_displacement.png and .svg
    /// instead: the force column NAME of reactions.csv or contact_forces.csv (a stem such as
    /// `wall`, its largest component, or a whole column `wall.force_z`) against the probe
    /// PROBE's displacement in probes.csv (`gauge`, or `gauge.displacement_z`), row by row.
    Plot {
        /// The run's output folder (holding history.csv).
        dir: PathBuf,
        /// A force: a reactions.csv or contact_forces.csv column, or its stem.
        #[arg(long, requires = "displacement")]
        force: Option<String>,
        /// A probe's displacement: a probes.csv column, or the probe's name.
        #[arg(long, requires = "force")]
        displacement: Option<String>,
    },
    /// Chart a scaling study (scripts/scaling.sh): reads DIR/<series>_np<P>/report.json
    /// (series `strong`, `weak`), writes DIR/scaling.csv, scaling.png and scaling.svg: time per
    /// step by stage, imbalance per stage, bytes per rank per step. No MPI.
    ChartScaling {
        /// The study's directory.
        dir: PathBuf,
        /// Chart title.
        #[arg(long, default_value = "scaling")]
        title: String,
    },
    /// Chart accuracy against cost of explicit and implicit integration on a scene:
    /// `mpirun -np 2 tdyn compare scenes/bar_vibration.toml [--modes explicit,implicit]
    /// [--dt-factors 0.5,1,2,10,100] [--out DIR] [PETSc options]`. Each run is made in this
    /// process, on the same ranks, with dt = factor x the explicit stable limit; writes
    /// compare.csv, compare.png and compare.svg in DIR. Refused or unstable runs are results:
    /// the command still exits 0.
    Compare(CompareArgs),
    /// Cross-check our SPH against LIGGGHTS on the same particles: runs the deck (`liggghts -in`,
    /// or under `mpirun -np M` with `--liggghts-np M`) and the scene (`mpirun -np N tdyn run`),
    /// then compares the two codes' dumps step by step (x, v, f, rho, p; kinetic energy and
    /// front of the moving particles) and their cost. Writes crosscheck.csv in the work
    /// directory. Run it without mpirun:
    /// `tdyn crosscheck scenes/liggghts_random.toml --deck scenes/liggghts/in.random1step --np 2 --tol 1e-12`
    Crosscheck(CrosscheckArgs),
    /// Run the validation suite: each case of `validation/<case>/reference.toml` against its
    /// analytic or published reference. Writes DIR/report.md (ours, reference, error, allowed,
    /// pass/fail) and a chart per case (DIR/<case>.png, .svg); exits non-zero when a judged
    /// measure fails or a run fails. Run it without mpirun (it launches `mpirun -np N tdyn
    /// run` itself): `tdyn validate [--cases a,b] [--np N] [--fast] [--out DIR]`
    Validate(ValidateArgs),
    /// Mesh a gmsh .geo file (cached): `tdyn mesh meshes/bar.geo -p N=80`
    Mesh {
        /// The .geo file.
        geo: PathBuf,
        /// Parameters passed to gmsh as -setnumber NAME VALUE.
        #[arg(long = "param", short = 'p', value_parser = parse_param)]
        params: Vec<(String, f64)>,
    },
}

/// The arguments of `tdyn run`.
#[derive(clap::Args)]
struct RunArgs {
    /// The scene file (TOML, see docs/scene.md).
    scene: PathBuf,
    /// Output directory (default: out/<scene name>).
    #[arg(long)]
    out: Option<PathBuf>,
    /// No start line, progress lines, summary or chart (warnings are still printed).
    #[arg(long, short)]
    quiet: bool,
    /// Replace a scene value: `[K:]NAME=VALUE` sets `[[mesh]]` K's gmsh parameter NAME (K
    /// defaults to 0; the scene's params table must have it), `particles.spacing=VALUE`
    /// (or `particles[i].spacing`) a particle spacing; repeatable.
    #[arg(long = "param", short = 'p')]
    params: Vec<String>,
    /// Replace `run.end_time`, s (a shorter run, e.g. for per-step figures).
    #[arg(long = "end-time", allow_negative_numbers = true)]
    end_time: Option<f64>,
    /// Where contact is searched: `rcb` (its own dynamic decomposition, the default) or
    /// `static` (the FE decomposition: the paper's baseline, for benchmarks; mesh nodes only).
    #[arg(long = "contact-decomposition", value_enum, default_value = "rcb")]
    contact_decomposition: ContactDecomposition,
    /// `kept` (default): keep the contact decomposition and candidate lists between steps
    /// within their skins; `every-step`: rebuild them every step (the reference).
    #[arg(long = "contact-rebuild", value_enum, default_value = "kept")]
    contact_rebuild: Rebuild,
    /// The contact skins GHOST,CANDIDATE as multiples of the step's largest motion
    /// (default 200,30).
    #[arg(long = "contact-skins", value_parser = parse_skins)]
    contact_skins: Option<(f64, f64)>,
    /// `kept` (default): keep SPH pair candidates between steps where possible;
    /// `every-step`: search afresh every step (the reference).
    #[arg(long = "sph-pairs", value_enum, default_value = "kept")]
    sph_pairs: Rebuild,
    /// The element kernel: `auto` (default: the widest every rank's CPU offers), `scalar`,
    /// `lanes4` (refused on an x86-64 CPU without AVX2), or `lanes8` (refused on a CPU without
    /// AVX-512F).
    #[arg(long, value_enum, default_value = "auto")]
    kernel: Kernel,
    /// Replace an earlier run's results in the output folder (without it they are kept:
    /// `--out` naming a folder that holds a run is refused, and the default out/<scene
    /// name> goes on to out/<scene name>-2, -3, ...).
    #[arg(long)]
    overwrite: bool,
    /// Continue the run whose checkpoint is in DIR (its output folder, or that folder's
    /// `checkpoint/`; written with
    /// `[output] checkpoint_every`, at its end, or when it was stopped with Ctrl-C or
    /// SIGTERM) to the scene's end time, appending to its history, probes and frames. The
    /// scene and its --param and --end-time values must be those of the run (the line a
    /// stopped run prints gives them); any rank count continues it.
    #[arg(long, value_name = "DIR")]
    restart: Option<PathBuf>,
}

/// A flag that Ctrl-C (SIGINT) and SIGTERM set: the run stops at its next step with its output
/// closed and a checkpoint written (mpirun passes both signals on to every rank; a rank may get
/// one twice, from the terminal and from mpirun, so a repeated signal does not end it at once:
/// mpirun's own second Ctrl-C does).
fn stop_flag() -> std::sync::Arc<std::sync::atomic::AtomicBool> {
    let flag = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        let _ = signal_hook::flag::register(sig, flag.clone());
    }
    flag
}

/// The arguments of `tdyn sweep`.
#[derive(clap::Args)]
struct SweepArgs {
    /// The scene file (TOML; an optional [sweep] table gives the default ladder and measures).
    scene: PathBuf,
    /// The swept parameter: `[K:]NAME=v1,v2,...` (a gmsh parameter of [[mesh]] K) or
    /// `particles.spacing=v1,v2,...`; repeat it to sweep several together (value k of each
    /// in run k).
    #[arg(long = "param", short = 'p')]
    params: Vec<String>,
    /// The [[mesh]] a parameter without `K:` belongs to.
    #[arg(long, default_value_t = 0, allow_negative_numbers = true)]
    mesh: usize,
    /// An accuracy measure: `COLUMN[:peak|final][=REFERENCE]`, COLUMN a probes.csv column
    /// (`probe.field`) or a history.csv column; against REFERENCE when given, else against
    /// the finest run. Repeatable (default: [sweep] measure, else the first probe column's
    /// peak).
    #[arg(long = "measure")]
    measures: Vec<String>,
    /// Output directory (default: out/<scene name>/sweep).
    #[arg(long)]
    out: Option<PathBuf>,
    /// No progress lines.
    #[arg(long, short)]
    quiet: bool,
}

/// The arguments of `tdyn compare`.
#[derive(clap::Args)]
struct CompareArgs {
    /// The scene file (TOML, see docs/scene.md; an optional [compare] table says what to measure).
    scene: PathBuf,
    /// Modes to run, comma-separated (default: explicit,implicit; explicit alone for a
    /// scene only the explicit integrator runs: particles, contact, meshed fluid).
    #[arg(long, value_delimiter = ',')]
    modes: Vec<String>,
    /// Steps as multiples of the explicit stable limit, comma-separated (default: both
    /// sides of the limit, 0.25 to 100).
    #[arg(
        long = "dt-factors",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    dt_factors: Option<Vec<f64>>,
    /// Output directory (default: out/<scene name>/compare).
    #[arg(long)]
    out: Option<PathBuf>,
    /// No progress lines.
    #[arg(long, short)]
    quiet: bool,
}

/// The arguments of `tdyn crosscheck`.
#[derive(clap::Args)]
struct CrosscheckArgs {
    /// Our scene (its particles from the deck's data file, `[output] dump_every` set).
    scene: PathBuf,
    /// The LIGGGHTS deck (its directory's files are copied beside it).
    #[arg(long)]
    deck: PathBuf,
    /// Ranks for our run.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    np: usize,
    /// Ranks for LIGGGHTS.
    #[arg(
        long = "liggghts-np",
        default_value_t = 1,
        allow_negative_numbers = true
    )]
    liggghts_np: usize,
    /// A LIGGGHTS variable, NAME=VALUE (passed as -var NAME VALUE); repeatable.
    #[arg(long = "var", value_parser = parse_var)]
    vars: Vec<(String, String)>,
    /// Work directory (default out/<scene name>/crosscheck).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Exit non-zero when a per-field difference exceeds this fraction of the field's
    /// largest LIGGGHTS value.
    #[arg(long, allow_negative_numbers = true)]
    tol: Option<f64>,
    /// Compare against the LIGGGHTS dumps already in the work directory.
    #[arg(long)]
    reuse_liggghts: bool,
}

/// The arguments of `tdyn validate`.
#[derive(clap::Args)]
struct ValidateArgs {
    /// Cases to run, comma-separated (default: every folder of --dir).
    #[arg(long, value_delimiter = ',')]
    cases: Vec<String>,
    /// Ranks per run.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    np: usize,
    /// Coarse meshes only (the ladders' fast rungs) and only the cases marked fast.
    #[arg(long)]
    fast: bool,
    /// Output directory.
    #[arg(long, default_value = "out/validation")]
    out: PathBuf,
    /// The cases' folder.
    #[arg(long, default_value = "validation")]
    dir: PathBuf,
    /// No progress lines.
    #[arg(long, short)]
    quiet: bool,
}

/// Runs `work` on MPI's world with PETSc initialised (and finalised before MPI is): on success
/// rank 0 calls `ok` with the result; on failure rank 0 prints `<what>: error: <message>`. The
/// exit status is the same on every rank (`work` returns the same outcome on all).
fn on_mpi_with_petsc<T>(
    petsc_args: &[String],
    what: &str,
    work: impl FnOnce(&mpi::topology::SimpleCommunicator) -> Result<T, String>,
    ok: impl FnOnce(T),
) -> ExitCode {
    let Some(universe) = mpi::initialize() else {
        print_once("tdyn: error: MPI could not be initialised");
        return ExitCode::FAILURE;
    };
    let world = universe.world();
    let rank = world.rank();
    let gate = ExitGate::new(&world);
    let petsc = match Petsc::init(world.as_raw(), petsc_args) {
        Ok(p) => p,
        Err(e) => {
            if rank == 0 {
                eprintln!("tdyn: error: {e}");
            }
            return ExitCode::FAILURE;
        }
    };
    let res = work(&world);
    let line = res.as_ref().err().map(|e| format!("{what}: error: {e}"));
    gate.pass(line.as_deref(), EXIT_GRACE);
    // Every rank is here: the outcome is the lowest failing rank's, on every rank.
    let agreed = first_error(&world, res.as_ref().err().cloned());
    let unused = unused_petsc_options(&world);
    if rank == 0 {
        for o in unused {
            eprintln!(
                "tdyn: warning: {o}: option not used (misspelt, or not for this run; docs/cli.md lists tdyn's and PETSc's)"
            );
        }
    }
    drop(petsc);
    match (res, agreed) {
        (Ok(v), Ok(())) => {
            if rank == 0 {
                ok(v);
            }
            ExitCode::SUCCESS
        }
        (_, Err(e)) | (Err(e), _) => {
            if rank == 0 {
                eprintln!("{what}: error: {e}");
            }
            ExitCode::FAILURE
        }
    }
}

/// The PETSc options nothing read on any rank (collective): rank 0's unused options, each kept
/// when no rank read it, as `-name value`.
fn unused_petsc_options(world: &mpi::topology::SimpleCommunicator) -> Vec<String> {
    let root = world.process_at_rank(0);
    let mine = if world.rank() == 0 {
        Petsc::unused_options()
    } else {
        Vec::new()
    };
    let mut text = mine
        .iter()
        .map(|(n, v)| match v {
            Some(v) => format!("{n} {v}"),
            None => n.clone(),
        })
        .collect::<Vec<_>>()
        .join("\n")
        .into_bytes();
    let mut len = text.len() as u64;
    root.broadcast_into(&mut len);
    text.resize(len as usize, 0);
    if len > 0 {
        root.broadcast_into(&mut text[..]);
    }
    let text = String::from_utf8_lossy(&text).into_owned();
    let listed: Vec<&str> = text.lines().filter(|l| !l.is_empty()).collect();
    let used_here: Vec<u8> = listed
        .iter()
        .map(|l| u8::from(Petsc::option_used(l.split(' ').next().unwrap_or(l))))
        .collect();
    let mut used = vec![0u8; listed.len()];
    if !listed.is_empty() {
        world.all_reduce_into(
            &used_here[..],
            &mut used[..],
            mpi::collective::SystemOperation::max(),
        );
    }
    listed
        .iter()
        .zip(&used)
        .filter(|(_, u)| **u == 0)
        .map(|(l, _)| l.to_string())
        .collect()
}

fn parse_var(s: &str) -> Result<(String, String), String> {
    let (k, v) = s.split_once('=').ok_or("expected NAME=VALUE")?;
    Ok((k.to_string(), v.to_string()))
}

fn parse_param(s: &str) -> Result<(String, f64), String> {
    let (k, v) = s.split_once('=').ok_or("expected NAME=VALUE")?;
    let v: f64 = v.parse().map_err(|_| format!("{v}: not a number"))?;
    Ok((k.to_string(), v))
}

/// Splits PETSc options (single dash, e.g. `-log_view`, `-ksp_type cg`) from tdyn's own. A
/// word with `=` is never a PETSc option (they have none): `-pN=30` is `-p N=30`.
fn split_petsc(args: Vec<String>) -> (Vec<String>, Vec<String>) {
    let is_petsc = |a: &str| {
        a.len() > 2
            && a.starts_with('-')
            && !a.starts_with("--")
            && a[1..2].chars().all(|c| c.is_ascii_lowercase())
            && !a.contains('=')
    };
    let mut ours = Vec::new();
    let mut petsc = Vec::new();
    let mut i = 0;
    while i < args.len() {
        if i > 0 && is_petsc(&args[i]) {
            petsc.push(args[i].clone());
            if let Some(next) = args.get(i + 1) {
                let looks_like_file = [".toml", ".geo", ".msh"].iter().any(|e| next.ends_with(e));
                if !next.starts_with('-') && !looks_like_file {
                    petsc.push(next.clone());
                    i += 1;
                }
            }
        } else {
            ours.push(args[i].clone());
        }
        i += 1;
    }
    (ours, petsc)
}

/// Whether this process is a rank other than 0 of an MPI job, told before MPI starts (and
/// without it) from the launcher's environment: Open MPI, PMIx, MPICH's and Intel MPI's PMI,
/// Slurm. A mistake found before MPI starts (the command line) is printed by rank 0 alone;
/// every rank exits with the same status.
fn not_rank_0() -> bool {
    [
        "OMPI_COMM_WORLD_RANK",
        "PMIX_RANK",
        "PMI_RANK",
        "SLURM_PROCID",
    ]
    .iter()
    .any(|v| std::env::var(v).is_ok_and(|r| r.trim() != "0"))
}

/// How long a rank other than 0 waits before it exits on a mistake found before MPI starts:
/// mpirun ends the job when the first rank exits with a failure, and rank 0 must have printed
/// the line by then.
const QUIET_RANK_EXIT_DELAY: std::time::Duration = std::time::Duration::from_secs(2);

/// Prints `line` to standard error on rank 0, or on a rank other than 0 of an MPI job
/// ([`not_rank_0`]) waits for rank 0 to print it: for mistakes found before MPI starts.
fn print_once(line: &str) {
    if not_rank_0() {
        std::thread::sleep(QUIET_RANK_EXIT_DELAY);
    } else {
        eprintln!("{line}");
    }
}

fn main() -> ExitCode {
    let (ours, petsc_args) = split_petsc(std::env::args().collect());
    let cli = match Cli::try_parse_from(ours) {
        Ok(c) => c,
        // clap's own report (and --help, --version) from rank 0 only, the same status on all.
        Err(e) if not_rank_0() => {
            if e.exit_code() != 0 {
                std::thread::sleep(QUIET_RANK_EXIT_DELAY);
            }
            std::process::exit(e.exit_code())
        }
        // A mistake on the command line reads as every other error, `tdyn: error: ...`
        // (clap's text, its usage and tip lines after it); --help and --version as clap
        // prints them.
        Err(e) if e.use_stderr() => {
            eprint!("tdyn: {e}");
            std::process::exit(e.exit_code())
        }
        Err(e) => e.exit(),
    };
    match cli.cmd {
        Cmd::Run(a) => run(a, &petsc_args),
        Cmd::Sweep(a) => sweep(a, &petsc_args),
        Cmd::Plot {
            dir,
            force: Some(f),
            displacement: Some(d),
        } => force_plot(&dir, &f, &d),
        Cmd::Plot { dir, .. } => plot(&dir),
        Cmd::ChartScaling { dir, title } => chart_scaling(&dir, &title),
        Cmd::Compare(a) => compare(a, &petsc_args),
        Cmd::Crosscheck(a) => crosscheck(a),
        Cmd::Validate(a) => validate(a),
        Cmd::Mesh { geo, params } => mesh(&geo, params),
    }
}

/// The run folder `--restart DIR` names: DIR itself, or, when DIR is that folder's
/// `checkpoint/` (it holds `meta.json` and has no `checkpoint/` of its own), the folder above.
fn run_folder_of(dir: PathBuf) -> PathBuf {
    let is_checkpoint = dir.join("meta.json").is_file()
        && !dir.join("checkpoint").join("meta.json").is_file()
        && dir.file_name().is_some_and(|n| n == "checkpoint");
    match dir.parent() {
        Some(p) if is_checkpoint => {
            if p.as_os_str().is_empty() {
                PathBuf::from(".")
            } else {
                p.to_path_buf()
            }
        }
        _ => dir,
    }
}

/// `tdyn run`: the scene on MPI's world; unless --quiet, rank 0 then draws the energies and
/// prints the closing block.
fn run(a: RunArgs, petsc_args: &[String]) -> ExitCode {
    let overrides = match run_overrides(&a) {
        Ok(o) => o,
        Err(e) => {
            print_once(&format!("tdyn: error: {e}"));
            return ExitCode::FAILURE;
        }
    };
    let quiet = a.quiet;
    let restart = a.restart.map(run_folder_of);
    // `--out` naming the run's own folder says what --restart says already.
    let same = |o: &PathBuf, r: &PathBuf| match (o.canonicalize(), r.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => o == r,
    };
    let out = match (&a.out, &restart) {
        (Some(o), Some(r)) if same(o, r) => None,
        _ => a.out,
    };
    let opts = RunOptions {
        scene: a.scene,
        out,
        quiet,
        overrides,
        algorithms: driver::Algorithms {
            contact_static: a.contact_decomposition == ContactDecomposition::Static,
            contact_kept: a.contact_rebuild == Rebuild::Kept,
            contact_skins: a.contact_skins,
            sph_kept_pairs: a.sph_pairs == Rebuild::Kept,
            kernel: match a.kernel {
                Kernel::Auto => driver::KernelChoice::Auto,
                Kernel::Scalar => driver::KernelChoice::Scalar,
                Kernel::Lanes4 => driver::KernelChoice::Lanes4,
                Kernel::Lanes8 => driver::KernelChoice::Lanes8,
            },
        },
        overwrite: a.overwrite,
        restart,
        stop: Some(stop_flag()),
        ..Default::default()
    };
    on_mpi_with_petsc(
        petsc_args,
        "tdyn",
        |world| {
            driver::run(world, &opts)
                .map(|s| energies::Finished {
                    out: s.out,
                    steps: s.steps,
                    wall_s: Some(s.wall_s),
                    energy_error_max: s.energy_error_max,
                    energy_error_max_checked: s.energy_error_max_checked,
                    energy_error_last: s.energy_error_last,
                })
                .map_err(|e| e.to_string())
        },
        |mut done| {
            if !quiet {
                done.wall_s = done.wall_s.or_else(|| energies::report_wall_s(&done.out));
                let chart = energies::plot(&done.out);
                print!("{}", energies::closing(&done, &chart));
            }
        },
    )
}

/// `tdyn run`'s `--end-time` and `--param` values as the driver's overrides; the message
/// (after "tdyn: error: ") when a `--param` is not one value.
fn run_overrides(a: &RunArgs) -> Result<driver::RunOverrides, String> {
    let mut overrides = driver::RunOverrides {
        end_time: a.end_time,
        ..Default::default()
    };
    for p in &a.params {
        match crate::sweep::parse_param(p, 0) {
            Ok((t, v)) if v.len() == 1 => t.set(&mut overrides, v[0]),
            Ok(_) => {
                return Err(format!(
                    "--param {p}: expected one value (tdyn sweep runs several)"
                ))
            }
            // (the sweep's wording, "NAME=v1,v2,...", is for lists: a run takes one value)
            Err(e) => {
                return Err(format!(
                    "--param {}",
                    e.replace("NAME=v1,v2,...", "NAME=VALUE")
                ))
            }
        }
    }
    Ok(overrides)
}

/// `tdyn sweep`: the ladder on MPI's world; rank 0 names the outputs unless --quiet.
fn sweep(a: SweepArgs, petsc_args: &[String]) -> ExitCode {
    let opts = crate::sweep::SweepOptions {
        scene: a.scene,
        params: a.params,
        mesh: a.mesh,
        measures: a.measures,
        out: a.out,
        quiet: a.quiet,
    };
    on_mpi_with_petsc(
        petsc_args,
        "tdyn sweep",
        |world| crate::sweep::sweep(world, &opts),
        |dir| {
            if !opts.quiet {
                println!(
                    "tdyn sweep: accuracy_cost.csv, accuracy_cost.png and accuracy_cost.svg in {}/",
                    dir.display()
                );
            }
        },
    )
}

/// `tdyn plot`: the energies chart of the run in `dir`. No MPI.
fn plot(dir: &Path) -> ExitCode {
    chart_written(crate::energies::plot(dir))
}

/// `tdyn plot DIR --force NAME --displacement PROBE`: the force-displacement chart. No MPI.
fn force_plot(dir: &Path, force: &str, displacement: &str) -> ExitCode {
    chart_written(crate::force_chart::plot(dir, force, displacement))
}

/// Names the PNG and SVG `tdyn plot` wrote, or its error.
fn chart_written(r: Result<PathBuf, String>) -> ExitCode {
    match r {
        Ok(png) => {
            println!(
                "tdyn plot: {} and {}",
                png.display(),
                png.with_extension("svg").display()
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("tdyn plot: error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// `tdyn chart-scaling`: the study in `dir` as a table, scaling.csv and the charts. No MPI.
fn chart_scaling(dir: &Path, title: &str) -> ExitCode {
    match crate::scaling::chart_scaling(dir, title) {
        Ok(rows) => {
            print!("{}", crate::scaling::table(&rows));
            println!(
                "tdyn chart-scaling: scaling.csv, scaling.png and scaling.svg in {}/",
                dir.display()
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("tdyn chart-scaling: error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// `tdyn compare`: the (mode, step) ladder on MPI's world; rank 0 names the outputs unless
/// --quiet.
fn compare(a: CompareArgs, petsc_args: &[String]) -> ExitCode {
    let opts = crate::compare::CompareOptions {
        scene: a.scene,
        modes: a.modes,
        dt_factors: a.dt_factors,
        out: a.out,
        quiet: a.quiet,
    };
    on_mpi_with_petsc(
        petsc_args,
        "tdyn compare",
        |world| crate::compare::compare(world, &opts),
        |dir| {
            if !opts.quiet {
                println!(
                    "tdyn compare: compare.csv, compare.png and compare.svg in {}/",
                    dir.display()
                );
            }
        },
    )
}

/// `tdyn crosscheck`: both codes as child processes, then the table. No MPI in this process.
fn crosscheck(a: CrosscheckArgs) -> ExitCode {
    let opts = crate::crosscheck::CrosscheckOptions {
        scene: a.scene,
        deck: a.deck,
        np: a.np,
        liggghts_np: a.liggghts_np,
        vars: a.vars,
        out: a.out,
        tol: a.tol,
        reuse_liggghts: a.reuse_liggghts,
    };
    match crate::crosscheck::crosscheck(&opts) {
        Ok(s) => {
            print!("{}", crate::crosscheck::table(&s));
            println!("tdyn crosscheck: {}/crosscheck.csv", s.dir.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("tdyn crosscheck: error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// `tdyn validate`: the suite's runs as child processes; fails when a judged measure or a run
/// fails, naming them. No MPI in this process.
fn validate(a: ValidateArgs) -> ExitCode {
    let opts = crate::validate::ValidateOptions {
        dir: a.dir,
        cases: a.cases,
        np: a.np,
        fast: a.fast,
        out: a.out,
        quiet: a.quiet,
    };
    let o = match crate::validate::validate(&opts) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("tdyn validate: error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let failed: Vec<String> = o
        .rows
        .iter()
        .filter(|r| r.failed())
        .map(|r| format!("{} {} {}", r.case, r.rung, r.measure))
        .collect();
    print!("{}", case_lines(&o.rows));
    println!("tdyn validate: {}", o.report.display());
    if !o.skipped.is_empty() {
        println!("tdyn validate: skipped (--fast): {}", o.skipped.join(", "));
    }
    if o.passed() {
        ExitCode::SUCCESS
    } else {
        eprintln!("tdyn validate: failed: {}", failed.join("; "));
        ExitCode::FAILURE
    }
}

/// One line per validation case, `PASS` when every judged measure of every rung passed and every
/// run ran, `FAIL` with the failed measures otherwise, in the order the cases ran; then the total.
fn case_lines(rows: &[crate::validate::Row]) -> String {
    let mut cases: Vec<(&str, Vec<String>)> = Vec::new();
    for r in rows {
        if cases.last().is_none_or(|c| c.0 != r.case) {
            cases.push((&r.case, Vec::new()));
        }
        if r.failed() {
            let c = cases.last_mut().expect("pushed above");
            c.1.push(format!("{} {}", r.rung, r.measure));
        }
    }
    let mut out = String::new();
    for (case, failed) in &cases {
        if failed.is_empty() {
            out += &format!("PASS  {case}\n");
        } else {
            out += &format!("FAIL  {case}: {}\n", failed.join("; "));
        }
    }
    let passed = cases.iter().filter(|c| c.1.is_empty()).count();
    out += &format!("tdyn validate: {passed} of {} cases passed\n", cases.len());
    out
}

/// `tdyn mesh`: meshes `geo` with gmsh (cached beside it) and prints the .msh path. No MPI.
fn mesh(geo: &Path, params: Vec<(String, f64)>) -> ExitCode {
    let def = coupling::input::scene::MeshDef {
        file: geo.to_path_buf(),
        params: params.into_iter().collect(),
        translate: [0.0; 3],
    };
    let cache = coupling::input::gmsh::default_cache_dir(geo.parent().unwrap_or(Path::new(".")));
    match coupling::input::gmsh::mesh_file(&def, &cache) {
        Ok(p) => {
            println!("{}", p.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("{}", mesh_error_line(geo, &e));
            ExitCode::FAILURE
        }
    }
}

/// `tdyn mesh`'s one line for `e`: the file named once (the file and gmsh errors name it
/// themselves), a parameter as the `-p` it came from.
fn mesh_error_line(geo: &Path, e: &coupling::input::gmsh::MeshError) -> String {
    use coupling::input::gmsh::MeshError;
    match e {
        MeshError::Param { name, why } => {
            format!("tdyn: error: {}: -p {name}: {why}", geo.display())
        }
        _ => format!("tdyn: error: {e}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;
    use std::path::Path;

    /// Folders of the repository whose files the help texts and the manual name as examples.
    const EXAMPLE_ROOTS: [&str; 5] = ["scenes/", "meshes/", "scripts/", "validation/", "docs/"];

    /// The repository paths named in `text`: words under [`EXAMPLE_ROOTS`] (not under `out/`,
    /// which runs write, nor hidden caches), up to a `<placeholder>`, trailing punctuation off.
    fn named_paths(text: &str) -> Vec<String> {
        let in_path = |c: char| c.is_ascii_alphanumeric() || "_./-".contains(c);
        text.split(|c: char| !in_path(c))
            .map(|w| w.trim_end_matches(['.', ',', ':']))
            .filter(|w| EXAMPLE_ROOTS.iter().any(|r| w.starts_with(r)) && !w.contains("/."))
            .map(str::to_string)
            .collect()
    }

    #[test]
    fn tdyn_mesh_names_a_missing_file_once() {
        let geo = Path::new("meshes/nosuch.geo");
        let def = coupling::input::scene::MeshDef {
            file: geo.to_path_buf(),
            params: Default::default(),
            translate: [0.0; 3],
        };
        let e = coupling::input::gmsh::mesh_file(&def, Path::new("meshes/.cache")).unwrap_err();
        assert_eq!(
            mesh_error_line(geo, &e),
            "tdyn: error: meshes/nosuch.geo: no such file"
        );
    }

    /// `tdyn run -p` takes one value: a word without one is asked for as NAME=VALUE (not as
    /// the sweep's list), and a list is refused naming `tdyn sweep`.
    #[test]
    fn a_run_parameter_without_its_value_is_asked_for_as_name_value() {
        let args = |p: &str| match Cli::try_parse_from(["tdyn", "run", "s.toml", "-p", p]) {
            Ok(Cli { cmd: Cmd::Run(a) }) => a,
            _ => panic!("tdyn run parses"),
        };
        let e = run_overrides(&args("N")).unwrap_err();
        assert_eq!(e, "--param \"N\": expected NAME=VALUE");
        let e = run_overrides(&args("N=1,2")).unwrap_err();
        assert!(
            e.contains("expected one value (tdyn sweep runs several)"),
            "{e}"
        );
        assert!(run_overrides(&args("N=3")).is_ok());
    }

    #[test]
    fn a_word_with_an_equals_sign_is_never_a_petsc_option() {
        let words = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let (ours, petsc) = split_petsc(words(&[
            "tdyn",
            "run",
            "a.toml",
            "-pN=30",
            "-ksp_type",
            "cg",
            "-log_view",
            "-p",
            "M=2",
        ]));
        assert_eq!(
            ours,
            words(&["tdyn", "run", "a.toml", "-pN=30", "-p", "M=2"])
        );
        assert_eq!(petsc, words(&["-ksp_type", "cg", "-log_view"]));
        let a = Cli::try_parse_from(ours).unwrap();
        let Cmd::Run(r) = a.cmd else { panic!("run") };
        assert_eq!(r.params, ["N=30", "M=2"]);
    }

    #[test]
    fn every_example_in_the_help_and_the_manual_exists() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let mut texts: Vec<(String, String)> = Vec::new();
        let cmd = Cli::command();
        for sub in cmd.get_subcommands() {
            let mut help: Vec<String> = [sub.get_about(), sub.get_long_about()]
                .into_iter()
                .flatten()
                .map(|s| s.to_string())
                .collect();
            for arg in sub.get_arguments() {
                help.extend(
                    [arg.get_help(), arg.get_long_help()]
                        .into_iter()
                        .flatten()
                        .map(|s| s.to_string()),
                );
            }
            texts.push((format!("tdyn {} --help", sub.get_name()), help.join("\n")));
        }
        let mut pages = vec![root.join("README.md")];
        let mut docs: Vec<_> = std::fs::read_dir(root.join("docs"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "md"))
            .collect();
        docs.sort();
        pages.extend(docs);
        for p in pages {
            texts.push((
                p.display().to_string(),
                std::fs::read_to_string(&p).unwrap(),
            ));
        }
        let mut missing = Vec::new();
        let mut named = 0;
        for (what, text) in &texts {
            for path in named_paths(text) {
                named += 1;
                if !root.join(&path).exists() {
                    missing.push(format!("{what}: {path}"));
                }
            }
        }
        assert!(named > 20, "only {named} paths found: the scan is broken");
        assert!(
            missing.is_empty(),
            "examples that do not exist:\n{}",
            missing.join("\n")
        );
        // The scan itself: a word under out/ or a placeholder is not a repository path.
        assert_eq!(
            named_paths("see out/validation/report.md and validation/<case>/reference.toml, or scenes/a.toml."),
            vec!["validation/".to_string(), "scenes/a.toml".to_string()]
        );
    }
}
