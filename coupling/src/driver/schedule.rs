//! The run's clock: when the run ends, the size of the next step, and when a history row or a
//! field frame is due (docs/scene.md: at t >= k * every - 1e-6 dt, and at the end).
use crate::input::scene::Scene;

/// Tolerance on frame and row times, in steps (docs/scene.md: t >= k * every - 1e-6 dt).
pub const TIME_EPS_STEPS: f64 = 1e-6;

/// The last steps of an explicit run share what remains of the end time evenly from this
/// many on ([`Clock::next_step`]).
pub const EVEN_STEPS: f64 = 4.0;

/// The clock of a run.
#[derive(Clone)]
pub struct Clock {
    /// Steps taken.
    pub step: u64,
    /// Time, s. With a fixed step t = step * dt exactly (the end time after a last step
    /// shortened onto it).
    pub time: f64,
    /// The next step's size, s.
    pub dt: f64,
    /// The smallest step taken, s.
    pub dt_min: f64,
    end: f64,
    fixed_dt: Option<f64>,
    dt_safety: f64,
    output_every: f64,
    history_every: f64,
    next_frame: u64,
    next_row: u64,
}

impl Clock {
    /// At t = 0, with the first step from the scene's fixed `run.dt` or the safety factor times
    /// the stable step `stable0`.
    pub fn new(scene: &Scene, stable0: f64) -> Clock {
        let end = scene.run.end_time;
        Clock {
            step: 0,
            time: 0.0,
            dt: scene.run.dt.unwrap_or(scene.run.dt_safety * stable0),
            dt_min: f64::INFINITY,
            end,
            fixed_dt: scene.run.dt,
            dt_safety: scene.run.dt_safety,
            output_every: scene.run.output_every.unwrap_or(end),
            history_every: scene.run.history_every,
            next_frame: 1,
            next_row: 1,
        }
    }

    /// The state a checkpoint keeps.
    pub fn state(&self) -> super::checkpoint::ClockState {
        super::checkpoint::ClockState {
            step: self.step,
            time: self.time,
            dt: self.dt,
            dt_min: self.dt_min,
            next_frame: self.next_frame,
            next_row: self.next_row,
        }
    }

    /// Continues from a checkpoint's state.
    pub fn restore(&mut self, s: &super::checkpoint::ClockState) {
        self.step = s.step;
        self.time = s.time;
        self.dt = s.dt;
        self.dt_min = s.dt_min;
        self.next_frame = s.next_frame;
        self.next_row = s.next_row;
    }

    /// The size of the next step, clipped onto the end time, or `None` when the run is over.
    pub fn next_step(&mut self) -> Option<f64> {
        match self.fixed_dt {
            Some(d) => {
                // The tolerance is on the step that can be taken, at most the end time: a
                // step over a million times the end time (a cold gas at rest, c = 0) must
                // still take its one step to end_time.
                if (self.step as f64) * d >= self.end - TIME_EPS_STEPS * d.min(self.end) {
                    return None;
                }
                // A fixed step that does not divide the end time: the last step is shortened
                // onto it (the run ends at end_time, as with the automatic step).
                self.dt = if ((self.step + 1) as f64) * d > self.end + TIME_EPS_STEPS * d {
                    self.end - (self.step as f64) * d
                } else {
                    d
                };
            }
            None => {
                let remaining = self.end - self.time;
                // As above: the step taken is clipped onto end_time, so the tolerance is a
                // millionth of min(dt, end), not of a proposal far past the end time.
                if remaining <= TIME_EPS_STEPS * self.dt.min(self.end) {
                    return None;
                }
                // The last steps share what remains evenly: once it is at most EVEN_STEPS
                // steps, each takes remaining / n (n = the steps it needs at this step), so
                // the run ends on end_time without a sliver of a last step (each step at least
                // 3/4 of the one before, and the last ones equal). A sliver distorts the force
                // rows: a contact push-back's impulse carries the previous step's closing
                // half-kick too, m a (dt_old + dt) / 2, so over a sliver dt its force, the
                // impulse over dt, came out 3 times the rows' before on the container crush (a
                // last step 0.2 of the one before) and 10 to 18 times on blocks pushed into a
                // plate; now it is at most (1 + 4/3) / 2 = 1.17 times, once, and the last row
                // is the steps' before.
                let n = (remaining / self.dt - TIME_EPS_STEPS).ceil().max(1.0);
                if n <= EVEN_STEPS {
                    self.dt = self.dt.min(remaining / n);
                }
            }
        }
        self.dt_min = self.dt_min.min(self.dt);
        Some(self.dt)
    }

    /// After a step of `self.dt`: the step count and the time.
    pub fn advance(&mut self) {
        self.step += 1;
        self.time = match self.fixed_dt {
            Some(d) if self.dt < d => self.end,
            Some(d) => self.step as f64 * d,
            None => self.time + self.dt,
        };
    }

    /// Whether the fixed step keeps the time (t = step * dt).
    pub fn fixed(&self) -> bool {
        self.fixed_dt.is_some()
    }

    /// The next step from the stable step `stable` the stages proposed (unless fixed).
    pub fn propose(&mut self, stable: f64) {
        if self.fixed_dt.is_none() {
            self.dt = self.dt_safety * stable;
        }
    }

    /// The end time is reached.
    pub fn at_end(&self) -> bool {
        self.time >= self.end - TIME_EPS_STEPS * self.dt.min(self.end)
    }

    /// The fraction of the end time reached.
    pub fn fraction(&self) -> f64 {
        (self.time / self.end).clamp(0.0, 1.0)
    }

    /// The end time, s.
    pub fn end(&self) -> f64 {
        self.end
    }

    /// Whether a history row is due now (then the next one is scheduled).
    pub fn row_due(&mut self) -> bool {
        let every = self.history_every;
        let eps = TIME_EPS_STEPS * self.dt;
        let due = every <= 0.0 || self.time >= every * self.next_row as f64 - eps || self.at_end();
        if due && every > 0.0 {
            self.next_row = next_after(self.next_row, every, self.time + eps);
        }
        due
    }

    /// Whether a field frame is due now (then the next one is scheduled).
    pub fn frame_due(&mut self) -> bool {
        let every = self.output_every;
        let eps = TIME_EPS_STEPS * self.dt;
        let due = self.time >= every * self.next_frame as f64 - eps || self.at_end();
        if due {
            self.next_frame = next_after(self.next_frame, every, self.time + eps);
        }
        due
    }
}

/// The smallest k >= `from` with k * `every` > `t`: the next frame or row after time `t`. Jumps
/// to it (a few steps around t / every for the round-off) rather than counting up to it, so
/// an interval far shorter than the step costs nothing.
fn next_after(from: u64, every: f64, t: f64) -> u64 {
    let guess = (t / every).floor();
    let mut k = if guess.is_finite() && guess > 1.0 {
        from.max((guess as u64).saturating_sub(1))
    } else {
        from
    };
    while k < u64::MAX && every * (k as f64) <= t {
        k += 1;
    }
    k
}

#[cfg(test)]
mod tests {
    use super::{next_after, Clock, EVEN_STEPS, TIME_EPS_STEPS};

    /// A clock at the automatic step `dt` (stable step dt / 0.9) to `end`, s.
    fn clock(dt: f64, end: f64) -> Clock {
        Clock {
            step: 0,
            time: 0.0,
            dt,
            dt_min: f64::INFINITY,
            end,
            fixed_dt: None,
            dt_safety: 0.9,
            output_every: end,
            history_every: 0.0,
            next_frame: 1,
            next_row: 1,
        }
    }

    #[test]
    fn a_step_far_longer_than_the_end_time_is_taken_once_onto_it() {
        // Reference: docs/scene.md ("the state at end_time is always written"): a stable step
        // over 1e6 times the end time (particles at rest with c = 0 give 0.3 h / 1e-9) must
        // take one step of exactly end_time, automatic or fixed, not end the run at t = 0.
        for fixed in [None, Some(10.0)] {
            let mut c = clock(3240.0, 1e-3);
            c.fixed_dt = fixed;
            let d = c.next_step();
            assert_eq!(d, Some(1e-3), "fixed {fixed:?}: the one step is end_time");
            c.advance();
            assert_eq!(c.time, 1e-3, "fixed {fixed:?}: t = end_time after it");
            c.propose(3600.0);
            assert!(
                c.at_end() && c.next_step().is_none(),
                "fixed {fixed:?}: then the end"
            );
        }
    }

    #[test]
    fn the_last_steps_share_what_remains_evenly() {
        // Reference: the definition of the schedule (docs/scene.md, `dt_safety`): at a constant
        // stable step, every step the stable step until what remains is at most EVEN_STEPS
        // of them, then equal steps that end on end_time; none below 3/4 of the one before;
        // the count the plain clipped schedule takes (ceil(end / dt)), whatever the sliver.
        let dt = 1.0e-6;
        for frac in [0.0, 1e-9, 0.01, 0.25, 0.5, 0.999, 0.999_999_9] {
            let end = (37.0 + frac) * dt;
            let mut c = clock(dt, end);
            let mut steps = Vec::new();
            while let Some(d) = c.next_step() {
                steps.push(d);
                c.advance();
                c.propose(dt / 0.9);
            }
            let n = steps.len();
            let plain = (end / dt - TIME_EPS_STEPS).ceil() as usize;
            assert_eq!(n, plain, "end {frac}: steps");
            assert!(
                (c.time - end).abs() <= TIME_EPS_STEPS * dt,
                "end {frac}: t {}",
                c.time
            );
            for k in 1..n {
                assert!(
                    steps[k] >= 0.75 * steps[k - 1] && steps[k] <= dt,
                    "end {frac}: step {k} {:e} after {:e}",
                    steps[k],
                    steps[k - 1]
                );
            }
            let tail = EVEN_STEPS as usize;
            assert!(steps[..n - tail].iter().all(|&d| d == dt), "end {frac}");
            for k in n - tail + 1..n - 1 {
                assert!(
                    (steps[k] - steps[n - tail]).abs() <= 1e-12 * dt,
                    "end {frac}: the last steps equal: {:?}",
                    &steps[n - tail..]
                );
            }
        }
    }

    #[test]
    fn the_next_frame_is_the_one_counting_up_finds() {
        // Counting up one by one (the definition) against the jump, over intervals and times
        // where round-off matters: multiples of the interval, and just around them.
        for &every in &[1e-6, 2.5e-6, 1.0 / 3.0, 0.1, 7.0] {
            for k in 0..2000u64 {
                for t in [
                    k as f64 * every,
                    (k as f64 * every) * (1.0 + 1e-15),
                    k as f64 * every - 1e-18,
                ] {
                    for from in [1u64, k / 2 + 1] {
                        let mut want = from;
                        while every * want as f64 <= t {
                            want += 1;
                        }
                        assert_eq!(
                            next_after(from, every, t),
                            want,
                            "every {every}, t {t}, from {from}"
                        );
                    }
                }
            }
        }
        // An interval of 1e-18 s at t = 1e-5 s is frame 1e13 + 1, found at once.
        assert_eq!(next_after(1, 1e-18, 1e-5), 10_000_000_000_001);
    }
}
