//! report.json at the end of a run (docs/scene.md): the counts, each stage's section (written by the
//! stage), the output's cost, the energy balance, and the run's timing.
use super::energy::HourglassWatch;
use super::setup::Model;
use crate::input::scene::{Mode, Scene};
use crate::kernels::collective;
use crate::output::{Report, StageStats};
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::path::Path;

/// The run-wide figures the report needs besides the stages'.
pub struct RunFigures<'a> {
    /// Steps taken.
    pub steps: u64,
    /// Whole run, time loop without output, set-up (max over ranks), s.
    pub wall_s: f64,
    /// See `wall_s`.
    pub loop_s: f64,
    /// See `wall_s`.
    pub setup_s: f64,
    /// Output time and bytes of fields.h5 on this rank.
    pub output_s: f64,
    /// See `output_s`.
    pub output_bytes: u64,
    /// The largest energy error, and the largest from step 100 on (the checked one).
    pub energy_error_max: f64,
    /// See `energy_error_max`.
    pub energy_error_max_checked: f64,
    /// The explicit stable step at t = 0 and the smallest step taken, s.
    pub dt_stable_initial: f64,
    /// See `dt_stable_initial`.
    pub dt_min: f64,
    /// The blocks' hourglass watch.
    pub hourglass: &'a HourglassWatch,
    /// The energy scale's floor, J (`energy::EnergyScale`), and the model's mass, kg.
    pub energy_floor: f64,
    /// See `energy_floor`.
    pub mass: f64,
    /// How the run ended when it did not finish: the failure's kind and message.
    pub failure: Option<(super::FailureKind, &'a str)>,
}

/// This process's peak resident set (`VmHWM` of /proc/self/status), bytes; NaN where /proc is
/// not there. Read from the kernel rather than through a crate: one line of a Linux file.
pub fn peak_rss() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kb| kb * 1024.0)
}

/// The CPU this process runs on, as the benchmarks name it: the `model name` of
/// /proc/cpuinfo with its `cpu family` and `model` numbers (a virtual machine's name is often
/// only "AMD EPYC": the numbers tell a Zen 3 from a Zen 4), and the widest SIMD set the element
/// kernel can use on it (`AVX-512F`, `AVX2`, or `SSE2`: one lane); "unknown" where /proc is not
/// there.
pub fn cpu_model() -> String {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let field = |key: &str| {
        info.lines()
            .find(|l| l.split(':').next().map(str::trim) == Some(key))
            .and_then(|l| l.split_once(':'))
            .map(|(_, m)| m.trim().to_string())
    };
    let model = match (field("model name"), field("cpu family"), field("model")) {
        (Some(name), Some(f), Some(m)) => format!("{name}, family {f} model {m}"),
        (Some(name), ..) => name,
        _ => "unknown".into(),
    };
    #[cfg(target_arch = "x86_64")]
    let set = if std::arch::is_x86_feature_detected!("avx512f") {
        "AVX-512F"
    } else if std::arch::is_x86_feature_detected!("avx2") {
        "AVX2"
    } else {
        "SSE2"
    };
    #[cfg(not(target_arch = "x86_64"))]
    let set = "no x86 SIMD";
    format!("{model} ({set})")
}

/// Resets the peak resident set to the current one (Linux: "5" to /proc/self/clear_refs), so
/// that a later [`peak_rss`] measures what came after; nothing where that is refused.
pub fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// Writes `<out_dir>/report.json` (collective; rank 0 writes).
pub fn write(
    world: &SimpleCommunicator,
    out_dir: &Path,
    scene: &Scene,
    model: &Model,
    f: &RunFigures,
) -> Result<(), String> {
    let size = world.size();
    let fe_mesh = model.fe.as_ref().map(|fe| &fe.mesh.local);
    let mut report = Report::new(
        size as usize,
        fe_mesh.map_or(0, |l| l.global_elems),
        fe_mesh.map_or(0, |l| l.global_nodes),
        model.sph.as_ref().map_or(0, |s| s.n_total),
        f.steps,
        f.wall_s,
    );
    let skipped = stage_figures(world, &mut report, model, f.loop_s);
    report.output = Some(StageStats::reduce(
        world,
        f.output_s,
        f.output_bytes as f64,
        f.output_bytes as f64,
    ));
    report.energy_error_max = f.energy_error_max;
    let ex = &mut report.extra;
    ex.insert("stages_skipped".into(), serde_json::Value::Object(skipped));
    insert_status(ex, f.failure);
    ex.insert(
        "energy_error_max_checked".into(),
        f.energy_error_max_checked.into(),
    );
    ex.insert("mass".into(), f.mass.into());
    ex.insert("energy_scale_floor".into(), f.energy_floor.into());
    if let Some(s) = &model.mesh_split {
        ex.insert(
            "mesh_split".into(),
            serde_json::json!({
                "tetrahedra": s.tetrahedra,
                "prisms": s.prisms,
                "hexahedra": s.hexahedra,
                "hexahedra_run": s.hexahedra_run,
                "text": s.describe(),
            }),
        );
    }
    if let Some(l) = fe_mesh.filter(|l| l.global_tets > 0) {
        ex.insert(
            "native_tetrahedra".into(),
            serde_json::json!({ "tetrahedra": l.global_tets, "hexahedra": l.global_hexes }),
        );
    }
    // Where a material fails: the failed elements, the particles they became and the kinetic
    // energy their conversions took (history.csv's last values).
    if let Some(c) = model.erosion_columns() {
        let mut e = serde_json::json!({
            "eroded_elements": c[0] as u64,
            "mass_elements": c[1],
            "mass_particles": c[2],
        });
        if let (Some(r), Some(fe)) = (&model.releases, &model.fe) {
            e["particles_from_elements"] = fe.released_count().into();
            e["conversion_energy"] = r.conversion_energy.into();
        }
        ex.insert("erosion".into(), e);
    }
    if let Some(fe) = &model.fe {
        ex.insert("blocks".into(), f.hourglass.report(fe.state()));
        // How many ranks put their elements and nodes in a new order (a poor file order).
        let r = fe.mesh.local.reordered;
        let ranks = |b: bool| collective::sum(world, f64::from(u8::from(b))) as u64;
        ex.insert(
            "fe_reordered_ranks".into(),
            serde_json::json!({ "elements": ranks(r[0]), "nodes": ranks(r[1]) }),
        );
    }
    ex.insert("title".into(), scene.title.clone().into());
    ex.insert(
        "mode".into(),
        match scene.run.mode {
            Mode::Explicit => "explicit",
            Mode::Implicit => "implicit",
        }
        .into(),
    );
    ex.insert("dt_stable_initial".into(), f.dt_stable_initial.into());
    ex.insert("dt_min".into(), f.dt_min.into());
    ex.insert("setup_s".into(), collective::max(world, f.setup_s).into());
    insert_memory(world, &mut report);
    report.extra.insert("loop_s".into(), f.loop_s.into());
    if world.rank() == 0 {
        report
            .write(&out_dir.join("report.json"))
            .map_err(|e| format!("report.json: {e}"))?;
    }
    Ok(())
}

/// Each stage's figures into `report` (the stages that ran, in order, the rigid walls' time),
/// and why each stage that did not run was skipped (collective).
fn stage_figures(
    world: &SimpleCommunicator,
    report: &mut Report,
    model: &Model,
    loop_s: f64,
) -> serde_json::Map<String, serde_json::Value> {
    let mut skipped = serde_json::Map::new();
    for stage in model.stages() {
        report.stages_run.push(stage.name().into());
        stage.report(world, report, loop_s);
    }
    if model.fe.is_none() {
        skipped.insert("fe".into(), "no [[mesh]]".into());
    }
    if model.sph.is_none() {
        skipped.insert("sph".into(), "no [[particles]]".into());
    }
    match &model.contact {
        Some(c) => {
            report.stages_run.push("contact".into());
            c.report(world, report, loop_s);
        }
        None => {
            skipped.insert("contact".into(), "no [contact]".into());
        }
    }
    if let Some(w) = &model.walls {
        // The walls' corrections: not a decomposition, a pass over the nodes and particles.
        report.stages_run.push("rigid_walls".into());
        let s = crate::kernels::collective::max(world, w.wall_s);
        report.extra.insert("rigid_walls_s".into(), s.into());
    }
    skipped
}

/// How the run ended: "finished", "stopped" or "failed", with the failure's kind and message.
fn insert_status(
    ex: &mut serde_json::Map<String, serde_json::Value>,
    failure: Option<(super::FailureKind, &str)>,
) {
    match failure {
        None => {
            ex.insert("status".into(), "finished".into());
        }
        Some((kind, message)) => {
            let status = match kind {
                super::FailureKind::Stopped => "stopped",
                _ => "failed",
            };
            ex.insert("status".into(), status.into());
            ex.insert(
                "failure".into(),
                serde_json::json!({ "kind": format!("{kind:?}").to_lowercase(), "message": message }),
            );
        }
    }
}

/// The processes' peak memory, summed over ranks and on the largest rank, and per element and
/// per particle (collective).
fn insert_memory(world: &SimpleCommunicator, report: &mut Report) {
    // The processes' peak memory (the largest resident set each reached, summed over ranks;
    // the set-up's mesh structures included), over the elements and over the particles: the
    // whole process's figure, so with both a mesh and particles each ratio counts both.
    let rss = collective::sum(world, peak_rss());
    let (elements, particles) = (report.elements, report.particles);
    let ex = &mut report.extra;
    // Rank 0's CPU: the machine a figure of this report was measured on.
    ex.insert("cpu".into(), cpu_model().into());
    ex.insert("peak_rss_bytes".into(), rss.into());
    ex.insert(
        "peak_rss_bytes_max_rank".into(),
        collective::max(world, peak_rss()).into(),
    );
    if elements > 0 {
        ex.insert(
            "peak_rss_bytes_per_element".into(),
            (rss / elements as f64).into(),
        );
    }
    if particles > 0 {
        ex.insert(
            "peak_rss_bytes_per_particle".into(),
            (rss / particles as f64).into(),
        );
    }
}
