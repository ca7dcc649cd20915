//! The energy balance the run keeps: E(0), the largest errors, the hourglass watch, and the stop
//! when the error passes `run.max_energy_error`.
use super::*;

/// The energy balance over the run: E(0), the largest errors, the per-block hourglass watch, and
/// the stop when the error passes `run.max_energy_error` (docs/scene.md).
pub(super) struct EnergyCheck {
    pub(super) file: String,
    pub(super) e0: f64,
    pub(super) max_energy_error: f64,
    pub(super) forced: bool,
    pub(super) stable0: f64,
    pub(super) err_max: f64,
    pub(super) err_max_checked: f64,
    /// The error after the last step.
    pub(super) err_last: f64,
    pub(super) hourglass: energy::HourglassWatch,
    pub(super) scale: energy::EnergyScale,
    /// The external work after the last step, J.
    pub(super) external_last: f64,
    /// Checked steps in a row, up to the last, whose error was past the limit
    /// (`energy::ENERGY_STOP_STEPS`).
    pub(super) over_limit_steps: u64,
}

impl EnergyCheck {
    pub(super) fn new(
        world: &SimpleCommunicator,
        scene: &Scene,
        model: &Model,
        forced: bool,
        stable0: f64,
    ) -> EnergyCheck {
        EnergyCheck {
            scale: energy::EnergyScale::new(model_mass(world, model)),
            external_last: 0.0,
            file: scene.file.display().to_string(),
            e0: sum_energies(model).total(),
            max_energy_error: scene.run.max_energy_error,
            forced,
            stable0,
            err_max: 0.0,
            err_max_checked: 0.0,
            err_last: 0.0,
            hourglass: energy::HourglassWatch::new(scene),
            over_limit_steps: 0,
        }
    }

    /// The energy scale after the last step, J (`energy::EnergyScale::value`).
    pub(super) fn scale_now(&self) -> f64 {
        self.scale.value(self.e0, self.external_last)
    }

    /// The state a checkpoint keeps.
    pub(super) fn state(&self) -> checkpoint::CheckState {
        checkpoint::CheckState {
            e0: self.e0,
            err_max: self.err_max,
            err_max_checked: self.err_max_checked,
            hourglass: self.hourglass.clone(),
            scale: self.scale,
            external_last: self.external_last,
            over_limit_steps: self.over_limit_steps,
        }
    }

    /// Continues from a checkpoint's state.
    pub(super) fn restore(&mut self, s: &checkpoint::CheckState) {
        self.e0 = s.e0;
        self.err_max = s.err_max;
        self.err_max_checked = s.err_max_checked;
        self.hourglass = s.hourglass.clone();
        self.over_limit_steps = s.over_limit_steps;
        if s.scale.floor > 0.0 {
            self.scale = s.scale;
            self.external_last = s.external_last;
        }
    }

    /// A history row now.
    pub(super) fn row(
        &self,
        clock: &schedule::Clock,
        model: &Model,
        err: f64,
    ) -> outputs::HistoryRow {
        outputs::HistoryRow {
            step: clock.step,
            time: clock.time,
            dt: clock.dt,
            energies: sum_energies(model),
            energy_error: err,
        }
    }

    /// A failed step's error as the run's: a forced run's failures are its instability.
    pub(super) fn failure(&self, e: StageError) -> RunFailure {
        let kind = if e.unstable || self.forced {
            FailureKind::Unstable
        } else {
            FailureKind::Failed
        };
        RunFailure::new(kind, e.message)
    }

    /// After a step: the energy error, the hourglass watch, and the stop (with the row written
    /// first) when the energy is not finite or the error passes the limit.
    pub(super) fn after_step(
        &mut self,
        world: &SimpleCommunicator,
        clock: &schedule::Clock,
        model: &Model,
        outputs: &mut outputs::Outputs,
    ) -> Result<f64, RunFailure> {
        let en = sum_energies(model);
        // what contact took, and what the conversions of failed elements to particles took
        let contact = model.contact_energy() + model.conversion_energy();
        let total = en.total() + contact;
        let external = en.external_work;
        self.scale.observe(en.kinetic, en.internal + en.hourglass);
        let scale = self.scale.value(self.e0, external);
        self.external_last = external;
        let err = energy::energy_error(total, self.e0, external, scale);
        let (t, step, dt, file) = (clock.time, clock.step, clock.dt, &self.file);
        let blow_up = if self.forced {
            format!(
                "the explicit run is unstable: run.dt = {dt:e} s is {:.3} times the stable limit {:e} s (forced with run.force_dt = true)",
                dt / self.stable0,
                self.stable0
            )
        } else {
            "the run is unstable or under-resolved; reduce run.dt or run.dt_safety".to_string()
        };
        if !total.is_finite() || !external.is_finite() {
            return Err(RunFailure::new(
                FailureKind::Unstable,
                format!("{file}: non-finite energy at t = {t:e} s, step {step}: {blow_up}"),
            ));
        }
        self.err_max = self.err_max.max(err);
        self.err_last = err;
        if let Some(fe) = &model.fe {
            for line in self
                .hourglass
                .check(t, step, &fe.state().block_energies, scale)
            {
                if world.rank() == 0 {
                    eprintln!("{line}");
                }
            }
        }
        if step >= ENERGY_CHECK_FROM_STEP {
            self.err_max_checked = self.err_max_checked.max(err);
        }
        // Before step 100 a blow-up is measured against the start scale (energy.rs,
        // EARLY_BLOW_UP_ERROR); err <= early always (S(t) >= the start scale). It stops the run
        // where the error against S(t) is also past EARLY_SCALED_ERROR: energy the state
        // stores at the start (pressure) is not in E(0), and its work is no blow-up.
        let early = energy::energy_error(
            total,
            self.e0,
            external,
            self.scale.start_value(self.e0, external),
        );
        let (measured, scaled_past) = if step >= ENERGY_CHECK_FROM_STEP {
            (err, true)
        } else {
            (early, err > energy::EARLY_SCALED_ERROR)
        };
        let limit = energy_error_limit(step, self.max_energy_error);
        let past = scaled_past && measured > limit;
        // From step 100 an error past the limit stops the run when it stays there
        // (energy::ENERGY_STOP_STEPS) or passes ten times the limit.
        self.over_limit_steps = if past { self.over_limit_steps + 1 } else { 0 };
        let stop = past
            && (step < ENERGY_CHECK_FROM_STEP
                || self.over_limit_steps >= energy::ENERGY_STOP_STEPS
                || measured > energy::ENERGY_STOP_AT_ONCE * limit);
        // (energy::solid_energy_negative: an instability the balance does not see)
        if energy::solid_energy_negative(en.solid_internal, self.max_energy_error, scale, step) {
            return Err(self.stop(world, clock, model, outputs, err,
                format!(
                    "{file}: the solid particles' internal energy fell to {:e} J at t = {t:e} s, step {step}, below -run.max_energy_error = -{} of the energy scale {scale:e} J (their forces are giving back work no strain stored; the kinetic energy is {:e} J): {blow_up}",
                    en.solid_internal, self.max_energy_error, en.kinetic
                ),
            ));
        }
        if stop {
            let err = measured;
            return Err(self.stop(world, clock, model, outputs, err,
                format!(
                    "{file}: energy error {err:.3e} passed run.max_energy_error = {}{} at t = {t:e} s, step {step} (E = {total:e} J, E0 = {:e} J, external work {external:e} J): {blow_up}",
                    self.max_energy_error,
                    self.stop_note(step),
                    self.e0
                ),
            ));
        }
        Ok(err)
    }

    /// A stop: the step's history and force rows written (with the error `err`) and flushed,
    /// then the run's failure with `message`.
    fn stop(
        &self,
        world: &SimpleCommunicator,
        clock: &schedule::Clock,
        model: &Model,
        outputs: &mut outputs::Outputs,
        err: f64,
        message: String,
    ) -> RunFailure {
        let _ = outputs.history_row(model, &self.row(clock, model, err));
        let _ = outputs.force_rows(world, model, clock.time);
        outputs.flush();
        RunFailure::new(FailureKind::Unstable, message)
    }

    /// How the error passed the limit, for the stop's message: the early check's rule, ten
    /// times the limit at once, or the limit for `energy::ENERGY_STOP_STEPS` steps.
    fn stop_note(&self, step: u64) -> String {
        if step < ENERGY_CHECK_FROM_STEP {
            early_note(step)
        } else if self.over_limit_steps >= energy::ENERGY_STOP_STEPS {
            format!(" for {} steps in a row", self.over_limit_steps)
        } else {
            format!(" (over {} times it at once)", energy::ENERGY_STOP_AT_ONCE)
        }
    }
}
