//! A run of a scene with SPH particles and no mesh: particles from the scene, the parallel SPH
//! stage, history, probes, fields and report per SCENE.md.
use crate::output::{FieldWriter, GlobalCounts, History, Report, StageStats};
use crate::particles_setup::{self, ParticleSeed};
use crate::scene::{Probe, ProbeField, Scene};
use crate::sph_stage::SphStage;
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use sph::{
    ArtificialViscosity, DensityMode, Kernel, NewParticle, Params, Particles, Periodic, Profile,
    TensileCorrection,
};
use std::path::Path;
use std::time::Instant;

/// Per scene material: its index in the EOS table and its initial specific internal energy
/// (None: a solid, no EOS).
pub type MaterialMap = Vec<Option<(u16, f64)>>;

/// The SPH model of a scene: the `[sph]` table and the materials' equations of state. Returns
/// the parameters and, per scene material, its index in the EOS table and its initial specific
/// internal energy.
pub fn params_from_scene(scene: &Scene) -> Result<(Params, MaterialMap), String> {
    let file = scene.file.display();
    let mut eos = Vec::new();
    let mut map = Vec::new();
    for (i, m) in scene.materials.iter().enumerate() {
        let Some(spec) = &m.eos else {
            map.push(None);
            continue;
        };
        // the kind, its keys and its initial specific energy: the eos crate's table
        let kind = ::eos::kind(&spec.kind)
            .ok_or_else(|| format!("{file}: material[{i}].eos.kind: unknown \"{}\"", spec.kind))?;
        let (e, e0) = kind
            .build(|k| spec.params.get(k).copied(), m.density)
            .map_err(|err| match err {
                ::eos::ParamError::Missing { key } => format!(
                    "{file}: material[{i}].eos: kind \"{}\" needs \"{key}\"",
                    spec.kind
                ),
                ::eos::ParamError::Bad { key, value, why } => {
                    format!("{file}: material[{i}].eos.{key} = {value}: {why}")
                }
            })?;
        map.push(Some((eos.len() as u16, e0)));
        eos.push(e);
    }
    let mut params = Params::new(eos);
    params.gravity = scene.gravity;
    if let Some(s) = &scene.sph {
        params.profile = if s.profile == "liggghts" {
            Profile::Liggghts
        } else {
            Profile::Standard
        };
        params.kernel = if s.kernel == "wendland" {
            Kernel::Wendland
        } else {
            Kernel::CubicSpline
        };
        params.density = if s.density == "summation" {
            DensityMode::Summation
        } else {
            DensityMode::Continuity
        };
        params.energy = s.energy;
        params.viscosity = s
            .artificial_viscosity
            .map(|a| ArtificialViscosity::new(a.alpha, a.beta));
        let spacing = scene.particles.first().map(|p| p.spacing).unwrap_or(0.0);
        params.tensile = s.tensile_correction.map(|t| TensileCorrection {
            epsilon: t.epsilon,
            delta_p: spacing,
        });
        params.adaptive_h = s.adaptive_h;
        params.conductivity = s.conductivity;
        params.periodic = s.periodic.as_ref().map(|p| Periodic {
            axes: p.axes,
            min: p.min,
            max: p.max,
        });
    }
    Ok((params, map))
}

/// This rank's initial particles (owned) from the seeds.
pub fn particles_from_seeds(
    seeds: &[ParticleSeed],
    map: &[Option<(u16, f64)>],
) -> Result<Particles, String> {
    let mut p = Particles::new();
    for s in seeds {
        let (mat, e0) = map[s.material].ok_or("particles need a material with an eos")?;
        p.push(NewParticle {
            id: s.id,
            x: s.x,
            v: s.v,
            m: s.mass,
            rho: s.rho,
            e: e0,
            h: s.h,
            mat,
            fixed: s.fixed,
        });
    }
    Ok(p)
}

/// Shepard-interpolated probe values: partial sums over owned particles, summed over ranks
/// (exact, whatever the decomposition). NaN where no particle reaches the point or the field
/// has no particle meaning (displacement, plastic strain).
pub(crate) fn sample(comm: &SimpleCommunicator, st: &SphStage, scene: &Scene) -> Vec<f64> {
    let all: Vec<&Probe> = scene.probes.iter().collect();
    shepard(comm, st, &all)
}

/// `sample` for the given probes (collective): their columns in order.
pub(crate) fn shepard(comm: &SimpleCommunicator, st: &SphStage, probes: &[&Probe]) -> Vec<f64> {
    let p = &st.parts;
    let k = st.params.smoothing_kernel();
    let mut sums = Vec::new();
    for pr in probes {
        let (mut den, mut num) = (0.0, vec![0.0; pr.fields.len()]);
        for i in 0..p.n_owned {
            let x = p.x_real[i];
            let r2: f64 = (0..3).map(|c| (x[c] - pr.point[c]).powi(2)).sum();
            if r2 >= 4.0 * p.h[i] * p.h[i] {
                continue;
            }
            let w = p.m[i] / p.rho[i] * k.w(r2.sqrt(), p.h[i]);
            den += w;
            for (f, field) in pr.fields.iter().enumerate() {
                let v = match field {
                    ProbeField::VelocityX => p.v[i][0],
                    ProbeField::VelocityY => p.v[i][1],
                    ProbeField::VelocityZ => p.v[i][2],
                    ProbeField::Pressure => p.p[i],
                    ProbeField::Density => p.rho[i],
                    ProbeField::StressXx | ProbeField::StressYy | ProbeField::StressZz => -p.p[i],
                    ProbeField::StressXy | ProbeField::StressYz | ProbeField::StressZx => 0.0,
                    _ => f64::NAN,
                };
                num[f] += w * v;
            }
        }
        sums.push(den);
        sums.extend(num);
    }
    let mut g = vec![0.0; sums.len()];
    comm.all_reduce_into(&sums[..], &mut g[..], SystemOperation::sum());
    let mut out = Vec::new();
    let mut k = 0;
    for pr in probes {
        let den = g[k];
        for f in 0..pr.fields.len() {
            out.push(if den > 0.0 {
                g[k + 1 + f] / den
            } else {
                f64::NAN
            });
        }
        k += 1 + pr.fields.len();
    }
    out
}

/// Global energies and momentum: [kinetic, internal, px, py, pz, gravity power].
pub(crate) fn globals(comm: &SimpleCommunicator, st: &SphStage) -> [f64; 6] {
    let e = sph::energies(&st.parts);
    let gp = sph::gravity_power(&st.parts, st.params.gravity);
    let loc = [
        e.kinetic,
        e.internal,
        e.momentum[0],
        e.momentum[1],
        e.momentum[2],
        gp,
    ];
    let mut g = [0.0; 6];
    comm.all_reduce_into(&loc[..], &mut g[..], SystemOperation::sum());
    g
}

/// Runs a particles-only scene (collective). Returns (steps, largest energy error).
pub fn run(
    world: &SimpleCommunicator,
    scene: &Scene,
    out_dir: &Path,
    quiet: bool,
    kept_pairs: bool,
) -> Result<(u64, f64), String> {
    let wall0 = Instant::now();
    let rank = world.rank();
    let size = world.size();
    let file = scene.file.display().to_string();
    let (params, map) = params_from_scene(scene)?;
    let seeds =
        particles_setup::particles(scene, rank as usize, size as usize).map_err(|e| e.to_string());
    crate::collective::first_error(world, seeds.as_ref().err().cloned())?;
    let (seeds, ids) = seeds.expect("checked");
    let mut n_total = 0u64;
    world.all_reduce_into(&(seeds.len() as u64), &mut n_total, SystemOperation::sum());
    let parts = particles_from_seeds(&seeds, &map)?;
    let liggghts = params.profile == Profile::Liggghts;
    let mut st = SphStage::new(world, parts, params);
    st.set_kept_pairs(kept_pairs);
    st.setup()?;
    let stable0 = st.stable_dt();
    if let Some(dt) = scene.run.dt {
        if dt > stable0 && !liggghts {
            return Err(format!(
                "{file}: run.dt: {dt:e} s is above the SPH stable limit {stable0:e} s (0.3 min h/(c + |v|)); use run.dt <= {stable0:e} or remove run.dt"
            ));
        }
        if dt > stable0 && rank == 0 {
            eprintln!("tdyn: warning: run.dt {dt:e} s is above the SPH stable limit {stable0:e} s; taken as given (profile = \"liggghts\")");
        }
    }

    std::fs::create_dir_all(out_dir).map_err(|e| format!("{}: {e}", out_dir.display()))?;
    world.barrier();
    let counts = GlobalCounts {
        nodes: 0,
        elements: 0,
        particles: n_total,
    };
    let mut writer = FieldWriter::create(world, out_dir, counts, &scene.output.fields)
        .map_err(|e| format!("{}: {e}", out_dir.display()))?;
    let mut history = History::create(
        world,
        &out_dir.join("history.csv"),
        &crate::driver::HISTORY_COLUMNS,
    )
    .map_err(|e| e.to_string())?
    .integer_columns(&crate::driver::HISTORY_INTEGER_COLUMNS);
    let mut probe_cols = vec!["time".to_string()];
    for p in &scene.probes {
        for f in &p.fields {
            let name = ProbeField::ALL
                .iter()
                .find(|(g, _)| g == f)
                .map(|(_, n)| *n)
                .unwrap_or("?");
            probe_cols.push(format!("{}.{name}", p.name));
        }
    }
    let probe_cols_ref: Vec<&str> = probe_cols.iter().map(|s| s.as_str()).collect();
    let mut probe_csv = History::create(world, &out_dir.join("probes.csv"), &probe_cols_ref)
        .map_err(|e| e.to_string())?;

    let mut output_s = 0.0;
    let mut ranks = Vec::new();
    let mut labels = Vec::new();
    let mut write_frame = |st: &SphStage, t: f64, w: &mut FieldWriter| -> Result<f64, String> {
        let t0 = Instant::now();
        let frame =
            crate::sph_coupled::particle_frame(&st.parts, &ids, &mut ranks, &mut labels, rank);
        w.write_frame(t, None, None, Some(&frame))
            .map_err(|e| format!("writing fields.h5: {e}"))?;
        Ok(t0.elapsed().as_secs_f64())
    };

    let g0 = globals(world, &st);
    let e0 = g0[0] + g0[1];
    let mut w_ext = 0.0;
    let mut gp_old = g0[5];
    let row = |step: u64, t: f64, dt: f64, g: &[f64; 6], w_ext: f64, err: f64| -> Vec<f64> {
        vec![
            step as f64,
            t,
            dt,
            g[0],
            g[1],
            0.0,
            w_ext,
            0.0,
            err,
            g[2],
            g[3],
            g[4],
            0.0,
        ]
    };
    let end = scene.run.end_time;
    let output_every = scene.run.output_every.unwrap_or(end);
    let history_every = scene.run.history_every;
    let fixed_dt = scene.run.dt;
    let mut dt = fixed_dt.unwrap_or(scene.run.dt_safety * stable0);
    output_s += write_frame(&st, 0.0, &mut writer)?;
    let dump_every = scene.output.dump_every;
    let dump_dir = out_dir.join("dumps");
    let dump = |st: &SphStage, step: u64| -> Result<f64, String> {
        let t0 = Instant::now();
        crate::output::write_particle_dump(world, &dump_dir, step, &st.parts, &ids)
            .map_err(|e| format!("{}: {e}", dump_dir.display()))?;
        Ok(t0.elapsed().as_secs_f64())
    };
    if dump_every > 0 {
        output_s += dump(&st, 0)?;
    }
    history
        .row(&row(0, 0.0, dt, &g0, 0.0, 0.0))
        .map_err(|e| e.to_string())?;
    let mut pr = vec![0.0];
    pr.extend(sample(world, &st, scene));
    probe_csv.row(&pr).map_err(|e| e.to_string())?;

    let progress = (rank == 0 && !quiet).then(|| {
        let pb = indicatif::ProgressBar::new(1000);
        pb.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {bar:40} {percent:>3}% t={msg} ETA {eta}",
            )
            .expect("valid template"),
        );
        pb
    });
    let eps = 1e-6;
    let (mut next_frame, mut next_row) = (1u64, 1u64);
    let (mut t, mut steps) = (0.0f64, 0u64);
    let mut err_max = 0.0f64;
    let mut err_max_checked = 0.0f64;
    let (mut sph_s, mut rcb_s, mut bytes) = (0.0, 0.0, 0.0);
    let mut pairs_work = 0.0;
    let loop0 = Instant::now();
    let mut output_in_loop = 0.0;
    while t < end * (1.0 - 1e-12) {
        if fixed_dt.is_none() {
            dt = scene.run.dt_safety * st.stable_dt();
            dt = dt.min(end - t);
        }
        st.step(dt)?;
        steps += 1;
        t = match fixed_dt {
            Some(f) => steps as f64 * f,
            None => t + dt,
        };
        sph_s += st.stats.wall_s;
        rcb_s += st.stats.rcb.wall_s;
        bytes += st.stats.bytes_sent as f64;
        pairs_work += st.stats.pairs_local as f64;
        let g = globals(world, &st);
        w_ext += 0.5 * (gp_old + g[5]) * dt;
        gp_old = g[5];
        let e = g[0] + g[1];
        let err = (e - e0 - w_ext).abs() / (e0.abs() + w_ext.abs()).max(1e-30);
        err_max = err_max.max(err);
        // Checked from step 100 on, before it only a blow-up (SCENE.md; why:
        // driver::ENERGY_CHECK_FROM_STEP).
        let checked = steps >= crate::driver::ENERGY_CHECK_FROM_STEP;
        if checked {
            err_max_checked = err_max_checked.max(err);
        }
        let non_finite = !g.iter().all(|v| v.is_finite());
        let last = t >= end * (1.0 - 1e-12);
        let row_due = history_every <= 0.0
            || t >= next_row as f64 * history_every - eps * dt
            || last
            || non_finite;
        if row_due {
            while history_every > 0.0 && t >= next_row as f64 * history_every - eps * dt {
                next_row += 1;
            }
            history
                .row(&row(steps, t, dt, &g, w_ext, err))
                .map_err(|e| e.to_string())?;
            let mut pr = vec![t];
            pr.extend(sample(world, &st, scene));
            probe_csv.row(&pr).map_err(|e| e.to_string())?;
        }
        if non_finite {
            let _ = history.flush();
            return Err(format!(
                "{file}: the SPH state became non-finite at t = {t:e} s (step {steps}); reduce run.dt_safety or check the EOS"
            ));
        }
        if err > crate::driver::energy_error_limit(steps, scene.run.max_energy_error) {
            let _ = history.flush();
            return Err(format!(
                "{file}: energy error {err:.3e} at t = {t:e} s (step {steps}) exceeds run.max_energy_error = {}{}; the step is too large or the model unstable",
                scene.run.max_energy_error,
                crate::driver::early_note(steps)
            ));
        }
        if t >= next_frame as f64 * output_every - eps * dt || last {
            while t >= next_frame as f64 * output_every - eps * dt {
                next_frame += 1;
            }
            let s = write_frame(&st, t, &mut writer)?;
            output_s += s;
            output_in_loop += s;
        }
        if dump_every > 0 && (steps % dump_every == 0 || last) {
            let s = dump(&st, steps)?;
            output_s += s;
            output_in_loop += s;
        }
        if let Some(pb) = &progress {
            pb.set_position((1000.0 * t / end).min(1000.0) as u64);
            pb.set_message(format!("{t:.3e}"));
        }
    }
    if let Some(pb) = progress {
        pb.finish_and_clear();
    }
    let loop_s = loop0.elapsed().as_secs_f64() - output_in_loop;
    history.flush().map_err(|e| e.to_string())?;
    let written = writer.bytes_written();
    writer
        .finish()
        .map_err(|e| format!("writing fields.xmf: {e}"))?;

    let wall_s = crate::collective::max(world, wall0.elapsed().as_secs_f64());
    let loop_s = crate::collective::max(world, loop_s);
    let sph_stats = StageStats::reduce(world, sph_s, pairs_work, bytes / size as f64);
    let rcb_stats = StageStats {
        wall_s: rcb_s,
        imbalance: st.stats.rcb.imbalance,
        bytes_sent: 0.0,
    };
    let out_stats = StageStats::reduce(world, output_s, written as f64, written as f64);
    let mut report = Report::new(size as usize, 0, 0, n_total, steps, wall_s);
    report.stages_run = vec!["sph".into()];
    report.sph = Some(StageStats {
        bytes_sent: bytes,
        ..sph_stats
    });
    report.rcb = Some(rcb_stats);
    report.output = Some(out_stats);
    let us = loop_s * size as f64 / (n_total.max(1) as f64 * steps.max(1) as f64) * 1e6;
    report.us_per_particle_step = Some(us);
    report.energy_error_max = err_max;
    let ex = &mut report.extra;
    ex.insert("energy_error_max_checked".into(), err_max_checked.into());
    ex.insert("title".into(), scene.title.clone().into());
    ex.insert("mode".into(), "explicit".into());
    ex.insert("stable_dt_initial".into(), stable0.into());
    ex.insert("loop_s".into(), loop_s.into());
    ex.insert("sph_pairs_last_step".into(), st.stats.pairs.into());
    // Pair searches run (on one rank without a periodic box the candidates are kept between
    // steps: sph::KeptPairs); the sum over ranks.
    ex.insert(
        "sph_pair_searches".into(),
        (crate::collective::sum(world, st.pair_searches as f64) as u64).into(),
    );
    ex.insert("sph_ghosts_last_step".into(), st.stats.ghosts.into());
    ex.insert(
        "sph_pair_imbalance_last_step".into(),
        st.stats.pair_imbalance.into(),
    );
    ex.insert(
        "rcb_migrated_last_step".into(),
        st.stats.rcb.migrated.into(),
    );
    ex.insert(
        "stages_skipped".into(),
        serde_json::json!({"fe": "no [[mesh]]", "contact": "no [contact]"}),
    );
    if rank == 0 {
        report
            .write(&out_dir.join("report.json"))
            .map_err(|e| format!("report.json: {e}"))?;
        if !quiet {
            println!(
                "tdyn: {steps} steps, {n_total} particles on {size} ranks, {us:.2} us/particle-step, energy error max {err_max:.2e}; output in {}",
                out_dir.display()
            );
        }
    }
    Ok((steps, err_max))
}

/// Runs the scene here when it has particles and no mesh and no contact (collective), with the
/// options' overrides (particle spacings); `None` when it is not such a scene (or does not
/// load: the main driver reports that).
pub fn run_if_particles_only(
    world: &SimpleCommunicator,
    opts: &crate::driver::RunOptions,
) -> Option<Result<(u64, f64), String>> {
    let mut scene = crate::scene::load(&opts.scene).ok()?;
    if !(scene.meshes.is_empty() && !scene.particles.is_empty() && scene.contact.is_none()) {
        return None;
    }
    if let Err(e) = opts.overrides.apply(&mut scene) {
        return Some(Err(e));
    }
    if scene.run.mode == crate::scene::Mode::Implicit {
        return Some(Err(format!(
            "{}: run.mode: the SPH stage is explicit only; use mode = \"explicit\"",
            scene.file.display()
        )));
    }
    let out_dir = opts.out.clone().unwrap_or_else(|| {
        std::path::PathBuf::from("out").join(
            scene
                .file
                .file_stem()
                .map(|s| s.to_os_string())
                .unwrap_or_default(),
        )
    });
    Some(run(
        world,
        &scene,
        &out_dir,
        opts.quiet,
        opts.algorithms.sph_kept_pairs,
    ))
}
