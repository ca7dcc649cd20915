//! Linear elastic, hypo-elastic rate form: sigma_dot (objective) = lambda tr(D) I + 2 mu D.
use super::{add_elastic, lame, take, LaneLaw, Material, MaterialError, MaterialSpec};

/// Isotropic linear elasticity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Elastic {
    pub(crate) rho: f64,
    pub(crate) lambda: f64,
    pub(crate) mu: f64,
}

impl Elastic {
    /// From `density`, `youngs_modulus`, `poisson_ratio`.
    pub fn build(spec: &MaterialSpec) -> Result<Box<dyn Material>, MaterialError> {
        let v = take(spec, &["youngs_modulus", "poisson_ratio"])?;
        let (lambda, mu) = lame(spec, v[0], v[1])?;
        Ok(Box::new(Elastic {
            rho: spec.density,
            lambda,
            mu,
        }))
    }
}

impl Material for Elastic {
    fn density(&self) -> f64 {
        self.rho
    }
    fn dilatational_modulus(&self) -> f64 {
        self.lambda + 2.0 * self.mu
    }
    fn shear_modulus(&self) -> f64 {
        self.mu
    }
    fn update_stress(
        &self,
        stress: &mut [f64; 6],
        _state: &mut [f64],
        deps: &[f64; 6],
        _dt: f64,
        _density: f64,
    ) {
        add_elastic(stress, deps, self.lambda, self.mu);
    }
    fn lane_law(&self) -> Option<LaneLaw> {
        Some(LaneLaw::Elastic(*self))
    }
}
