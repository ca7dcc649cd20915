//! The implicit state a checkpoint keeps beyond the explicit arrays.
use super::*;

impl ImplicitFe {
    /// The restart state beyond the explicit arrays (`ExplicitFe::restart_state`): the
    /// accepted state's forces and reactions (the energy sums use them), the force scale of
    /// the convergence test, and the tangent in use: with the default solver (`Linear::Exact`)
    /// its element matrices by element (`implicit.tangent_ke`, 576 values each) and whether
    /// they are current (`implicit.tangent_kept`), so the continued run's modified Newton
    /// iterates with the same matrix as the run without a stop, on the same ranks or others
    /// (the solver is rank-independent): bit for bit. With a PETSc solver the tangent is
    /// assembled afresh after a restart (its answers agree to its tolerance only anyway).
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
        let (ke, kept) = match &self.linear {
            Linear::Exact { cg, .. } => (cg.matrices().to_vec(), !self.tangent_stale),
            Linear::Petsc { .. } => (Vec::new(), false),
        };
        v.push(("implicit.tangent_ke", ke));
        v.push(("implicit.tangent_kept", vec![f64::from(u8::from(kept))]));
        v
    }

    /// Sums the diagonal and the coarse grid of the stored element matrices (the exact
    /// solver's): the tangent's assembly after storing them, and a restart after a checkpoint
    /// gave them back (collective).
    pub(super) fn restore_diagonal(
        &mut self,
        exchange: &mut NodeExchange,
    ) -> Result<(), PetscError> {
        if let Linear::Exact { cg, .. } = &mut self.linear {
            let sys = CgSystem {
                elems: &self.fe.elems,
                owned: &self.fe.owned,
                mass_term: &self.mass_term,
                dofs: &self.dofs,
            };
            cg.set_diagonal(&sys, &mut self.fe.assembly, exchange)?;
        }
        Ok(())
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
        self.tangent_restored = false;
        // The tangent in use at the checkpoint (absent from a checkpoint of an earlier tdyn,
        // or written with a PETSc solver: assembled afresh).
        let kept = get("implicit.tangent_kept").is_some_and(|k| k.first() == Some(&1.0));
        if let (true, Some(ke), Linear::Exact { cg, .. }) =
            (kept, get("implicit.tangent_ke"), &mut self.linear)
        {
            if ke.len() == cg.matrices().len() {
                cg.set_matrices(&ke);
                self.tangent_stale = false;
                self.tangent_restored = true;
            }
        }
        Ok(())
    }
}
