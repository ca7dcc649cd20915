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

impl RunOverrides {
    /// The `--param` replacements as `tdyn run -p` writes them, `(NAME, value)`: `N` (mesh 0),
    /// `K:N`, `particles.spacing`, `particles[i].spacing`; sorted by name, the last value given
    /// for a name kept (as `apply` does).
    pub fn params(&self) -> Vec<(String, f64)> {
        let mut m = std::collections::BTreeMap::new();
        for (k, name, v) in &self.mesh_params {
            let key = if *k == 0 {
                name.clone()
            } else {
                format!("{k}:{name}")
            };
            m.insert(key, *v);
        }
        for (i, v) in &self.particle_spacing {
            let key = match i {
                Some(i) => format!("particles[{i}].spacing"),
                None => "particles.spacing".to_string(),
            };
            m.insert(key, *v);
        }
        m.into_iter().collect()
    }

    /// The arguments of `tdyn run` that give these replacements (`run_args`).
    pub fn run_args(&self) -> Vec<String> {
        run_args(&self.params(), self.end_time)
    }
}

/// The arguments of `tdyn run` that give the replacements `params` (`RunOverrides::params`)
/// and `end_time`: `-p NAME=VALUE` for each, then `--end-time T` (values in Rust's shortest
/// round-trip form).
pub fn run_args(params: &[(String, f64)], end_time: Option<f64>) -> Vec<String> {
    let mut args = Vec::new();
    for (name, v) in params {
        args.push("-p".to_string());
        args.push(format!("{name}={v}"));
    }
    if let Some(t) = end_time {
        args.push("--end-time".to_string());
        args.push(format!("{t}"));
    }
    args
}

/// `word` as one word of a POSIX shell command line: as it is when it holds only characters
/// no shell reads specially, else in single quotes.
pub fn shell_word(word: &str) -> String {
    let plain = !word.is_empty()
        && word
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./:=,+@%".contains(c));
    if plain {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', r"'\''"))
    }
}

/// The command that continues the run of `scene` with the replacements `args` (`run_args`)
/// from its checkpoint in `dir`: `tdyn run SCENE [-p NAME=VALUE ...] [--end-time T] --restart
/// DIR`.
pub fn restart_command(scene: &std::path::Path, args: &[String], dir: &std::path::Path) -> String {
    let mut words = vec![
        "tdyn".to_string(),
        "run".to_string(),
        shell_word(&scene.display().to_string()),
    ];
    words.extend(args.iter().map(|a| shell_word(a)));
    words.push("--restart".to_string());
    words.push(shell_word(&dir.display().to_string()));
    words.join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_restart_command_gives_the_runs_values_in_one_order_quoted_for_a_shell() {
        let ov = RunOverrides {
            end_time: Some(8e-4),
            mesh_params: vec![
                (0, "NP".into(), 40.0),
                (0, "NB".into(), 8.0),
                (1, "N".into(), 3.0),
                (0, "NB".into(), 9.0),
            ],
            particle_spacing: vec![(Some(0), 0.0025)],
            ..Default::default()
        };
        assert_eq!(
            restart_command(
                std::path::Path::new("scenes/a b.toml"),
                &ov.run_args(),
                std::path::Path::new("out/a")
            ),
            "tdyn run 'scenes/a b.toml' -p 1:N=3 -p NB=9 -p NP=40 -p 'particles[0].spacing=0.0025' --end-time 0.0008 --restart out/a"
        );
        // Another order of the same values: the same command.
        let swapped = RunOverrides {
            mesh_params: vec![
                (0, "NB".into(), 9.0),
                (1, "N".into(), 3.0),
                (0, "NP".into(), 40.0),
            ],
            ..ov.clone()
        };
        assert_eq!(swapped.run_args(), ov.run_args());
        assert_eq!(shell_word("it's"), r"'it'\''s'");
    }
}
