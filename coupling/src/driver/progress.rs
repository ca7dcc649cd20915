//! What rank 0 says while a run runs (stderr): a start line (what runs, the step, the steps
//! expected), then progress: on a terminal one line redrawn in place, otherwise (under `mpirun`
//! with output to a file or a pipe, a batch job) a line every [`LOG_EVERY_S`] seconds.
//!
//! Written here rather than with `indicatif`: the solver library prints two kinds of plain
//! lines and should not pull a terminal crate into every program that links it.
use std::io::{IsTerminal, Write};
use std::time::Instant;

/// Seconds between progress lines when stderr is not a terminal.
pub const LOG_EVERY_S: f64 = 10.0;

/// Seconds between redraws on a terminal.
const REDRAW_EVERY_S: f64 = 0.2;

/// More steps than this expected at the start is almost always a unit slip (a density in
/// t/mm^3 read as kg/m^3 gives a step a million times too small): the start line warns.
pub const STEPS_WARNING: f64 = 1e7;

/// What the start line says.
pub struct StartInfo<'a> {
    /// The scene file.
    pub scene: &'a str,
    /// Elements, nodes and particles over all ranks.
    pub elements: u64,
    /// See `elements`.
    pub nodes: u64,
    /// See `elements`.
    pub particles: u64,
    /// The stages that run, in order.
    pub stages: Vec<&'a str>,
    /// Ranks.
    pub ranks: i32,
    /// The explicit stable step at t = 0 and the first step taken, s.
    pub dt_stable: f64,
    /// See `dt_stable`.
    pub dt: f64,
    /// The end time, s.
    pub end_time: f64,
    /// A plastic impact that will shrink the step (a fresh explicit run's): the count follows
    /// it ([`super::impact`]).
    pub impact: Option<super::impact::Impact>,
    /// Whether the step is fixed (`run.dt`, implicit mode): the count is then the run's.
    pub fixed_dt: bool,
    /// The mesh's tetrahedra and prisms run as hexahedra, in words (`SplitSummary::describe`).
    pub mesh_split: Option<String>,
}

/// The progress reporter of rank 0 (inactive elsewhere and with `--quiet`).
pub struct Progress {
    active: bool,
    /// The impact the start line's count followed: the progress lines' count follows its
    /// shape from the current step on.
    impact: Option<super::impact::Impact>,
    terminal: bool,
    t0: Instant,
    last: f64,
    drawn: bool,
}

impl Progress {
    /// Prints the start line when `active`, and the units warning when `warn` (rank 0, even
    /// when quiet: a warning is not progress).
    pub fn start(active: bool, warn: bool, info: &StartInfo) -> Progress {
        let p = Progress {
            active,
            impact: info.impact.clone().filter(|_| !info.fixed_dt),
            terminal: std::io::stderr().is_terminal(),
            t0: Instant::now(),
            last: 0.0,
            drawn: false,
        };
        // (the schedule ends a run whose time is within round-off of end_time: 1e-4 / 2e-6
        // is 50 steps, not the 51 a plain ceiling of 50.000000000000001 gives)
        let steps = info.end_time / info.dt * (1.0 - 1e-12);
        if let (true, Some(split)) = (active, &info.mesh_split) {
            eprintln!("tdyn: {}: mesh: {split}", info.scene);
        }
        if active {
            eprintln!(
                "tdyn: {}: {} elements, {} nodes, {} particles on {} rank{}; stages {}; stable step {:.3e} s, dt {:.3e} s: {}",
                info.scene,
                info.elements,
                info.nodes,
                info.particles,
                info.ranks,
                if info.ranks == 1 { "" } else { "s" },
                info.stages.join(", "),
                info.dt_stable,
                info.dt,
                count_text(info, steps),
            );
        }
        if warn && steps > STEPS_WARNING {
            eprintln!(
                "tdyn: warning: {}: run.end_time = {:e} s takes about {} steps at dt = {:.3e} s: check the scene's units (SI: m, kg, s, Pa, kg/m^3; a density of 7.85e-9 is steel in t/mm^3) or the end time",
                info.scene,
                info.end_time,
                steps_text(steps),
                info.dt
            );
        }
        p
    }

    /// After a step: redraws or logs when due. `end_time` (s): the steps still to come are
    /// estimated at the current `dt`.
    #[allow(clippy::too_many_arguments)]
    pub fn update(
        &mut self,
        step: u64,
        time: f64,
        fraction: f64,
        dt: f64,
        end_time: f64,
        energy_error: f64,
    ) {
        if !self.active {
            return;
        }
        let el = self.t0.elapsed().as_secs_f64();
        let every = if self.terminal {
            REDRAW_EVERY_S
        } else {
            LOG_EVERY_S
        };
        if el - self.last < every {
            return;
        }
        self.last = el;
        // The steps to come at the current step size (where an impact shrinks the step, at
        // the current step scaled by the impact's shape from now on: the integral of
        // rate(t') / rate(t) over the time to come), and the time they take at the mean wall
        // time per step so far (the step shrinks as elements deform: a time fraction would
        // promise too early an end).
        let to_come = match &self.impact {
            Some(i) => (i.steps(1.0, end_time) - i.steps(1.0, time)) / (i.rate(time) * dt),
            None => (end_time - time) / dt,
        };
        // (a hair under the quotient: a fixed step's remaining count, 13.000000000000002, is 13)
        let total = step as f64 + (to_come * (1.0 - 1e-9)).max(0.0).ceil();
        let eta = if step > 0 {
            format!("{:.0} s", el * (total - step as f64) / step as f64)
        } else {
            "?".into()
        };
        let line = format!(
            "tdyn: step {step} of about {}, t = {time:.4e} s ({:.1} %), dt = {dt:.3e} s, energy error {energy_error:.2e}, elapsed {el:.0} s, ETA {eta}",
            steps_text(total),
            100.0 * fraction
        );
        let mut e = std::io::stderr().lock();
        if self.terminal {
            let _ = write!(e, "\r{line}\x1b[K");
            self.drawn = true;
        } else {
            let _ = writeln!(e, "{line}");
        }
        let _ = e.flush();
    }

    /// Ends the redrawn line (a terminal) so that what follows starts on its own line.
    pub fn finish(&mut self) {
        if self.active && self.drawn {
            eprint!("\r\x1b[K");
            self.drawn = false;
        }
    }
}

/// The start line's count: the steps at the first step, or where a plastic impact will shrink
/// the step the estimate that follows it.
fn count_text(info: &StartInfo, steps: f64) -> String {
    let end = info.end_time;
    match (&info.impact, info.fixed_dt) {
        (_, true) => format!("{} steps to {end:.3e} s", steps_text(steps)),
        (None, false) => format!(
            "{} steps to {end:.3e} s at this step (the step shrinks as bodies deform; the progress lines update the count)",
            steps_text(steps)
        ),
        (Some(i), false) => format!(
            "about {} steps to {end:.3e} s ({} at this step: the step falls about {:.1}-fold as \"{}\" crushes against the {} at {} m/s; the progress lines update the count)",
            steps_text(i.steps(info.dt, end)),
            steps_text(steps),
            i.shrink,
            i.body,
            i.against,
            if i.speed >= 10.0 {
                format!("{:.0}", i.speed)
            } else {
                format!("{:.3}", i.speed)
            }
        ),
    }
}

/// A step count for people: "1200", "3.4e7".
fn steps_text(steps: f64) -> String {
    if !steps.is_finite() {
        "infinitely many".into()
    } else if steps < 1e6 {
        format!("{:.0}", steps.ceil())
    } else {
        format!("{steps:.2e}")
    }
}
