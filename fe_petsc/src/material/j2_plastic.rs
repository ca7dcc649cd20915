//! J2 (von Mises) plasticity with linear isotropic hardening, radial return.
//!
//! Trial stress sigma_tr = sigma + C : deps; q_tr = sqrt(3/2 s_tr : s_tr). If
//! f = q_tr - (sigma_y + H ep) > 0, the plastic increment is dgamma = f / (3 mu + H) and the
//! deviator is scaled back to the yield surface: s = s_tr (1 - 3 mu dgamma / q_tr)
//! (Simo & Hughes, Computational Inelasticity, 1998, Box 3.1). State: [ep].
use super::{
    add_elastic, add_elastic_lanes, bad, deviator, deviator_lanes, lame, take, LaneLaw, Material,
    MaterialError, MaterialSpec,
};
use crate::lanes::F4;

/// Elastic-plastic J2 material with linear hardening.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct J2Plastic {
    rho: f64,
    lambda: f64,
    mu: f64,
    yield_stress: f64,
    hardening: f64,
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
        }))
    }

    /// [`Material::update_stress`] in lanes (the batched element kernel): the same trial
    /// stress and radial return, the return taken in the lanes that flow (f > 0) and the trial
    /// stress kept in the others. `ep`: the plastic strain of each lane.
    #[inline(always)]
    pub(crate) fn update_lanes(&self, stress: &mut [F4; 6], ep: &mut F4, deps: &[F4; 6]) {
        add_elastic_lanes(stress, deps, self.lambda, self.mu);
        let (s, p, q) = deviator_lanes(stress);
        let f = q - (self.yield_stress + self.hardening * *ep);
        let flow = f.gt(F4::ZERO);
        let dgamma = f / (3.0 * self.mu + self.hardening);
        let scale = 1.0 - 3.0 * self.mu * dgamma / q;
        for k in 0..3 {
            stress[k] = F4::select(flow, s[k] * scale + p, stress[k]);
            stress[k + 3] = F4::select(flow, s[k + 3] * scale, stress[k + 3]);
        }
        *ep = F4::select(flow, *ep + dgamma, *ep);
    }

    /// [`Material::yield_stress`] in lanes.
    #[inline(always)]
    pub(crate) fn yield_stress_lanes(&self, ep: F4) -> F4 {
        self.yield_stress + self.hardening * ep
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
            let dgamma = f / (3.0 * self.mu + self.hardening);
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
