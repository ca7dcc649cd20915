//! A linear (Hookean) elastic stress model for the solid-particle tests: the `sph` crate holds
//! no material law (the coupling crate implements `StressModel` for fe_petsc's materials).
use sph::StressModel;

/// Hooke's law in rate form: dsigma = lambda tr(deps) I + 2 mu deps (deps with tensor shear
/// components, so the shear stress increment is 2 mu deps_xy), Pa.
#[derive(Clone, Copy, Debug)]
pub struct LinearElastic {
    /// Lame's lambda, Pa.
    pub lambda: f64,
    /// Shear modulus mu = G, Pa.
    pub mu: f64,
}

impl LinearElastic {
    /// From the bulk modulus K and shear modulus G, Pa: lambda = K - 2G/3.
    pub fn from_bulk_shear(k: f64, g: f64) -> Self {
        Self {
            lambda: k - 2.0 * g / 3.0,
            mu: g,
        }
    }

    /// Young's modulus E = mu (3 lambda + 2 mu)/(lambda + mu), Pa.
    pub fn youngs(&self) -> f64 {
        self.mu * (3.0 * self.lambda + 2.0 * self.mu) / (self.lambda + self.mu)
    }

    /// Poisson's ratio nu = lambda / (2 (lambda + mu)).
    pub fn poisson(&self) -> f64 {
        self.lambda / (2.0 * (self.lambda + self.mu))
    }

    /// The stress increment of `deps` (Voigt, tensor shear), Pa.
    pub fn increment(&self, deps: &[f64; 6]) -> [f64; 6] {
        let tr = deps[0] + deps[1] + deps[2];
        std::array::from_fn(|c| {
            let iso = if c < 3 { self.lambda * tr } else { 0.0 };
            iso + 2.0 * self.mu * deps[c]
        })
    }
}

impl StressModel for LinearElastic {
    fn update_stress(
        &self,
        stress: &mut [f64; 6],
        _state: &mut [f64],
        deps: &[f64; 6],
        _dt: f64,
        _density: f64,
    ) {
        let d = self.increment(deps);
        for c in 0..6 {
            stress[c] += d[c];
        }
    }

    fn shear_modulus(&self) -> f64 {
        self.mu
    }

    fn wave_modulus(&self, _density: f64, _state: &[f64]) -> f64 {
        self.lambda + 2.0 * self.mu
    }
}
