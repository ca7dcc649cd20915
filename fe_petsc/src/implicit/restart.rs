//! The implicit state a checkpoint keeps beyond the explicit arrays.
use super::*;

impl ImplicitFe {
    /// The restart state beyond the explicit arrays (`ExplicitFe::restart_state`): the
    /// accepted state's forces and reactions (the energy sums use them) and the force scale of
    /// the convergence test. The tangent is not kept: a restarted run assembles a fresh one,
    /// so it agrees with the run without a stop to the Newton tolerance, not bit for bit.
    pub fn restart_state(&self) -> Vec<(&'static str, Vec<f64>)> {
        let mut v = self.fe.restart_state();
        v.push(("implicit.force_n", self.force_n.as_flattened().to_vec()));
        v.push((
            "implicit.reaction_n",
            self.reaction_n.as_flattened().to_vec(),
        ));
        v.push(("implicit.force_scale_max", vec![self.force_scale_max]));
        v.push(("implicit.stats", self.stats_state()));
        v.extend(self.wall_restart_state());
        v
    }

    /// The run's counters (the same on every rank: the solves are collective), so that
    /// report.json counts the whole run after a restart; not its timers, which time this
    /// process's part.
    fn stats_state(&self) -> Vec<f64> {
        let s = &self.stats;
        vec![
            s.newton_iterations as f64,
            s.ksp_iterations as f64,
            s.assemblies as f64,
            s.residuals as f64,
            s.max_step_iterations as f64,
        ]
    }

    /// Sets the state [`ImplicitFe::restart_state`] gave.
    pub fn set_restart_state(
        &mut self,
        get: &mut dyn FnMut(&str) -> Option<Vec<f64>>,
    ) -> Result<(), String> {
        self.fe.set_restart_state(get)?;
        let n3 = 3 * self.force_n.len();
        let mut take = |name: &str, len: usize| -> Result<Vec<f64>, String> {
            let v = get(name).ok_or_else(|| format!("{name}: missing"))?;
            if v.len() != len {
                return Err(format!("{name}: {} values, {len} expected", v.len()));
            }
            Ok(v)
        };
        let f = take("implicit.force_n", n3)?;
        self.force_n.as_flattened_mut().copy_from_slice(&f);
        let r = take("implicit.reaction_n", n3)?;
        self.reaction_n.as_flattened_mut().copy_from_slice(&r);
        self.force_scale_max = take("implicit.force_scale_max", 1)?[0];
        // (absent from a checkpoint of an earlier tdyn: the counts start again)
        if let Some(c) = get("implicit.stats") {
            if c.len() != 5 {
                return Err(format!("implicit.stats: {} values, 5 expected", c.len()));
            }
            self.stats.newton_iterations = c[0] as u64;
            self.stats.ksp_iterations = c[1] as u64;
            self.stats.assemblies = c[2] as u64;
            self.stats.residuals = c[3] as u64;
            self.stats.max_step_iterations = c[4] as u32;
        }
        self.set_wall_restart_state(get)?;
        self.tangent_stale = true;
        Ok(())
    }
}
