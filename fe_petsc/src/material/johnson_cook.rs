//! Johnson-Cook plasticity, isothermal: yield = (a + b ep^n)(1 + c ln(max(1, rate / eps_dot0))),
//! rate = the equivalent plastic strain rate = dgamma / dt (Johnson & Cook, 1983).
//!
//! Radial return as for J2, with the scalar equation for the plastic increment
//! g(dgamma) = q_tr - 3 mu dgamma - yield(ep + dgamma, dgamma / dt) = 0, which decreases
//! monotonically in dgamma: solved by bisection on [0, q_tr / (3 mu)] to round-off (robust where
//! ep^n has an infinite slope at ep = 0). State: [ep].
use super::{add_elastic, bad, deviator, lame, take, Material, MaterialError, MaterialSpec};

/// Bisection steps: halves the bracket to below 1e-16 of its width.
const BISECTION_STEPS: usize = 60;

/// Johnson-Cook rate-dependent plasticity (no thermal softening).
#[derive(Debug, Clone)]
pub struct JohnsonCook {
    rho: f64,
    lambda: f64,
    mu: f64,
    a: f64,
    b: f64,
    n: f64,
    c: f64,
    eps_dot0: f64,
}

impl JohnsonCook {
    /// From `density`, `youngs_modulus`, `poisson_ratio`, `a`, `b`, `n`, `c`, `eps_dot0`.
    pub fn build(spec: &MaterialSpec) -> Result<Box<dyn Material>, MaterialError> {
        let v = take(
            spec,
            &[
                "youngs_modulus",
                "poisson_ratio",
                "a",
                "b",
                "n",
                "c",
                "eps_dot0",
            ],
        )?;
        let (lambda, mu) = lame(spec, v[0], v[1])?;
        if !(v[2] > 0.0) {
            return Err(bad(
                spec,
                "a",
                v[2],
                "expected a positive initial yield stress, Pa",
            ));
        }
        if !(v[3] >= 0.0) {
            return Err(bad(spec, "b", v[3], "expected b >= 0, Pa"));
        }
        if !(v[4] > 0.0) {
            return Err(bad(spec, "n", v[4], "expected n > 0"));
        }
        if !(v[5] >= 0.0) {
            return Err(bad(spec, "c", v[5], "expected c >= 0"));
        }
        if !(v[6] > 0.0) {
            return Err(bad(
                spec,
                "eps_dot0",
                v[6],
                "expected a positive reference rate, 1/s",
            ));
        }
        Ok(Box::new(JohnsonCook {
            rho: spec.density,
            lambda,
            mu,
            a: v[2],
            b: v[3],
            n: v[4],
            c: v[5],
            eps_dot0: v[6],
        }))
    }

    /// Flow stress at plastic strain `ep` and plastic strain rate `rate`.
    pub fn flow_stress(&self, ep: f64, rate: f64) -> f64 {
        (self.a + self.b * libm::pow(ep.max(0.0), self.n))
            * (1.0 + self.c * libm::log((rate / self.eps_dot0).max(1.0)))
    }
}

impl Material for JohnsonCook {
    fn density(&self) -> f64 {
        self.rho
    }
    fn dilatational_modulus(&self) -> f64 {
        self.lambda + 2.0 * self.mu
    }
    fn shear_modulus(&self) -> f64 {
        self.mu
    }
    fn n_state(&self) -> usize {
        1
    }
    fn update_stress(
        &self,
        stress: &mut [f64; 6],
        state: &mut [f64],
        deps: &[f64; 6],
        dt: f64,
        _density: f64,
    ) {
        add_elastic(stress, deps, self.lambda, self.mu);
        let (s, p, q) = deviator(stress);
        let ep = state[0];
        if q <= self.flow_stress(ep, 0.0) {
            return;
        }
        let g = |dg: f64| q - 3.0 * self.mu * dg - self.flow_stress(ep + dg, dg / dt.max(1e-300));
        let (mut lo, mut hi) = (0.0, q / (3.0 * self.mu));
        for _ in 0..BISECTION_STEPS {
            let mid = 0.5 * (lo + hi);
            if g(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let dgamma = 0.5 * (lo + hi);
        let scale = 1.0 - 3.0 * self.mu * dgamma / q;
        for k in 0..3 {
            stress[k] = s[k] * scale + p;
            stress[k + 3] = s[k + 3] * scale;
        }
        state[0] += dgamma;
    }
    fn plastic_strain(&self, state: &[f64]) -> f64 {
        state[0]
    }
    fn yield_stress(&self, state: &[f64]) -> Option<f64> {
        // Static (rate factor 1): the hourglass bound is then on the safe, softer side.
        Some(self.flow_stress(state[0], 0.0))
    }
}
