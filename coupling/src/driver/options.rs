//! How the user asked to run: the run's options, the algorithm choices that do not change the
//! answer, and the replacements for scene keys.
use crate::input::scene::{Mode, Scene};
use std::path::PathBuf;

/// How the user asked to run.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// The scene file.
    pub scene: PathBuf,
    /// Output directory (default `out/<scene file stem>`).
    pub out: Option<PathBuf>,
    /// No progress bar, no summary on stdout.
    pub quiet: bool,
    /// Values that replace the scene's keys (`tdyn compare`, `tdyn sweep`, `tdyn run --param`).
    pub overrides: RunOverrides,
    /// Stop after set-up (mesh, FE stage, stable step): no time step, no output.
    pub setup_only: bool,
    /// Algorithm choices for benchmarks and reference runs (`tdyn run` flags).
    pub algorithms: Algorithms,
    /// Replace an earlier run's results in `out` (`tdyn run --overwrite`); without it an
    /// earlier run is kept (driver::outdir).
    pub overwrite: bool,
    /// Continue the run whose checkpoint is in this folder (`tdyn run --restart DIR`).
    pub restart: Option<PathBuf>,
    /// Set (by a signal handler: Ctrl-C, SIGTERM) to stop at the next step with the output
    /// closed and a checkpoint written.
    pub stop: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
}

/// Algorithm choices that do not change the answer, only how it is computed: the defaults are
/// what every run should use; the others are the references the tests and benchmarks compare
/// against (`tdyn run --contact-decomposition static --contact-rebuild every-step
/// --contact-skins G,C --sph-pairs fresh`). Every rank parses the same command line, so every
/// rank makes the same choice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Algorithms {
    /// Contact searched on the static FE decomposition (the paper's baseline, for benchmarks)
    /// instead of its own RCB decomposition. Mesh nodes only: particles are not contact nodes.
    pub contact_static: bool,
    /// Keep the contact decomposition and candidate lists between steps within their skins
    /// (default); false rebuilds them every step (Fig. 10 steps 1-6 each step).
    pub contact_kept: bool,
    /// The contact skins as multiples of the step's largest motion (ghost faces, candidate
    /// lists); `None`: the stage's defaults.
    pub contact_skins: Option<(f64, f64)>,
    /// Keep the SPH pair candidates between steps on one rank (default); false searches
    /// afresh every step.
    pub sph_kept_pairs: bool,
    /// The element kernel (`tdyn run --kernel`): every choice gives the same answer.
    pub kernel: KernelChoice,
}

/// Which element kernel the explicit element loop runs (`tdyn run --kernel`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum KernelChoice {
    /// The widest every rank's CPU offers (eight lanes where all have AVX-512F, else four).
    #[default]
    Auto,
    /// One element at a time.
    Scalar,
    /// Four elements per group (any CPU).
    Lanes4,
    /// Eight elements per group in AVX-512 registers (refused on a CPU without AVX-512F).
    Lanes8,
}

impl Default for Algorithms {
    fn default() -> Self {
        Algorithms {
            contact_static: false,
            contact_kept: true,
            contact_skins: None,
            sph_kept_pairs: true,
            kernel: KernelChoice::Auto,
        }
    }
}

/// Replacements for scene keys: `[run]` keys (`tdyn compare`), mesh parameters and particle
/// spacings (`tdyn run --param`, `tdyn sweep`).
#[derive(Debug, Clone, Default)]
pub struct RunOverrides {
    /// `run.mode`.
    pub mode: Option<Mode>,
    /// `run.dt`.
    pub dt: Option<f64>,
    /// `run.force_dt`.
    pub force_dt: Option<bool>,
    /// `run.end_time` (a shorter run for per-step figures: `scripts/scaling.sh`).
    pub end_time: Option<f64>,
    /// `mesh[k].params.NAME = value`, as (k, NAME, value); NAME must be in the scene's table.
    pub mesh_params: Vec<(usize, String, f64)>,
    /// `particles[i].spacing = value`, as (Some(i), value), or of every `[[particles]]` (None).
    pub particle_spacing: Vec<(Option<usize>, f64)>,
}

impl RunOverrides {
    /// Writes the replacements into `scene`; an index or a mesh parameter the scene does not
    /// have is an error naming the key.
    pub fn apply(&self, scene: &mut Scene) -> Result<(), String> {
        let file = scene.file.display().to_string();
        if let Some(m) = self.mode {
            scene.run.mode = m;
        }
        if let Some(dt) = self.dt {
            scene.run.dt = Some(dt);
        }
        if let Some(f) = self.force_dt {
            scene.run.force_dt = f;
        }
        if let Some(t) = self.end_time {
            if !(t > 0.0 && t.is_finite()) {
                return Err(format!(
                    "{file}: run.end_time: expected a positive time in s, got {t}"
                ));
            }
            scene.run.end_time = t;
        }
        for (k, name, v) in &self.mesh_params {
            let n = scene.meshes.len();
            let m = scene
                .meshes
                .get_mut(*k)
                .ok_or_else(|| format!("{file}: mesh[{k}]: the scene has {n} [[mesh]] entries"))?;
            let known: Vec<String> = m.params.keys().cloned().collect();
            match m.params.get_mut(name) {
                Some(p) => *p = *v,
                None => {
                    return Err(format!(
                        "{file}: mesh[{k}].params.{name}: not a parameter of this mesh (it has {}); add it to the scene's params table to vary it",
                        known.join(", ")
                    ))
                }
            }
        }
        for (i, v) in &self.particle_spacing {
            if !(*v > 0.0 && v.is_finite()) {
                return Err(format!(
                    "{file}: particles.spacing: expected a positive spacing in m, got {v}"
                ));
            }
            let n = scene.particles.len();
            match i {
                Some(i) => {
                    scene
                        .particles
                        .get_mut(*i)
                        .ok_or_else(|| {
                            format!(
                                "{file}: particles[{i}]: the scene has {n} [[particles]] entries"
                            )
                        })?
                        .spacing = *v
                }
                None if n == 0 => {
                    return Err(format!(
                        "{file}: particles.spacing: the scene has no [[particles]]"
                    ))
                }
                None => scene.particles.iter_mut().for_each(|p| p.spacing = *v),
            }
        }
        Ok(())
    }
}
