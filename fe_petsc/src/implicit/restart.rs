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
        v.extend(self.wall_restart_state());
        v
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
        self.set_wall_restart_state(get)?;
        self.tangent_stale = true;
        Ok(())
    }
}
