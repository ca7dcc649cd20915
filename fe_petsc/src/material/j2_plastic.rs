//! J2 (von Mises) plasticity with linear isotropic hardening, radial return.
//!
//! Trial stress sigma_tr = sigma + C : deps; q_tr = sqrt(3/2 s_tr : s_tr). If
//! f = q_tr - (sigma_y + H ep) > 0, the plastic increment is dgamma = f / (3 mu + H) and the
//! deviator is scaled back to the yield surface: s = s_tr (1 - 3 mu dgamma / q_tr)
//! (Simo & Hughes, Computational Inelasticity, 1998, Box 3.1). State: [ep].
use super::{
    add_elastic, bad, deviator, lame, take, LaneLaw, Material, MaterialError, MaterialSpec,
};

/// Elastic-plastic J2 material with linear hardening.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct J2Plastic {
    pub(crate) rho: f64,
    pub(crate) lambda: f64,
    pub(crate) mu: f64,
    pub(crate) yield_stress: f64,
    pub(crate) hardening: f64,
    /// 1 / (3 mu + H): the radial return multiplies by it (the scalar and batched kernels
    /// alike) instead of dividing at every yielding element.
    pub(crate) inv_return: f64,
}

impl J2Plastic {
    /// From `density`, `youngs_modulus`, `poisson_ratio`, `yield_stress`, `hardening_modulus`.
    pub fn build(spec: &MaterialSpec) -> Result<Box<dyn Material>, MaterialError> {
        let v = take(
            spec,
            &[
                "youngs_modulus",
                "poisson_ratio",
                "yield_stress",
                "hardening_modulus",
            ],
        )?;
        let (lambda, mu) = lame(spec, v[0], v[1])?;
        if !(v[2] > 0.0 && v[2].is_finite()) {
            return Err(bad(
                spec,
                "yield_stress",
                v[2],
                "expected a positive stress, Pa",
            ));
        }
        if !(v[3] >= 0.0 && v[3].is_finite()) {
            return Err(bad(
                spec,
                "hardening_modulus",
                v[3],
                "expected a modulus >= 0, Pa",
            ));
        }
        Ok(Box::new(J2Plastic {
            rho: spec.density,
            lambda,
            mu,
            yield_stress: v[2],
            hardening: v[3],
            inv_return: 1.0 / (3.0 * mu + v[3]),
        }))
    }
}

impl Material for J2Plastic {
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
        _dt: f64,
        _density: f64,
    ) {
        add_elastic(stress, deps, self.lambda, self.mu);
        let (s, p, q) = deviator(stress);
        let f = q - (self.yield_stress + self.hardening * state[0]);
        if f > 0.0 {
            let dgamma = f * self.inv_return;
            let scale = 1.0 - 3.0 * self.mu * dgamma / q;
            for k in 0..3 {
                stress[k] = s[k] * scale + p;
                stress[k + 3] = s[k + 3] * scale;
            }
            state[0] += dgamma;
        }
    }
    fn plastic_strain(&self, state: &[f64]) -> f64 {
        state[0]
    }
    fn yield_stress(&self, state: &[f64]) -> Option<f64> {
        Some(self.yield_stress + self.hardening * state[0])
    }
    fn lane_law(&self) -> Option<LaneLaw> {
        Some(LaneLaw::J2Plastic(*self))
    }
}
