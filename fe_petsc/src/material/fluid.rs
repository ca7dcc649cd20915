//! The meshed fluid: an equation of state and no strength. stress = -p I with p = EOS(rho, e),
//! rho = m / V from the element's exact volume (the element passes rho0 V0 / V), and e the
//! specific internal energy integrated from the volume change, de = -p dv (v = 1/rho), by the
//! trapezoid rule:
//!
//! ```text
//! e1 = e0 - (p0 + p1)/2 (v1 - v0),   p1 = p(rho1, e1)
//! ```
//!
//! Every kind is affine in e at fixed rho (p(rho1, e) = p(rho1, e0) + g (e - e0), g = dp/de),
//! so the implicit rule has the closed form de = -(p0 + p(rho1, e0)) dv / (2 + g dv): second
//! order in the step, exact for Tait (which ignores e). The bulk viscosity's work, q eps_v dt / rho
//! per unit mass (computed by the element outside the material), is added to e after the update
//! (`add_heat`): it is the shock's entropy rise, without which a shock in a cold ideal gas is
//! never heated (planar Noh inverted its first element). The wave modulus rho c^2 (the stable step, the bulk viscosity's c, the hourglass
//! stiffness) uses the adiabatic c^2 = dp/drho|_e + (p/rho^2) dp/de|_rho.
//!
//! State per element: [e (J/kg), v (m^3/kg) and p (Pa) at the last update].
use super::eos::{build_eos, Eos};
use super::{take, Material, MaterialError, MaterialSpec};

/// Index of the specific internal energy in the state.
const E: usize = 0;
/// Index of the specific volume at the last update.
const V: usize = 1;
/// Index of the pressure at the last update.
const P: usize = 2;

/// A fluid: EOS only.
#[derive(Debug)]
pub struct Fluid {
    rho: f64,
    eos: Eos,
    /// Specific internal energy at t = 0 (the scene's, per the EOS table), J/kg.
    e0: f64,
    /// rho c^2 at the initial state (density, e0), Pa.
    modulus0: f64,
}

impl Fluid {
    /// From `density` and `eos = { kind = ..., ... }`.
    pub fn build(spec: &MaterialSpec) -> Result<Box<dyn Material>, MaterialError> {
        take(spec, &[])?;
        let (eos, e0) = build_eos(spec)?;
        let rho = spec.density;
        // the adiabatic c^2, floored by the EOS's minimum
        let modulus0 = rho * eos.sound_speed_sq(rho, e0);
        Ok(Box::new(Fluid {
            rho,
            eos,
            e0,
            modulus0,
        }))
    }

    /// The equation of state.
    pub fn eos(&self) -> &Eos {
        &self.eos
    }
}

impl Material for Fluid {
    fn density(&self) -> f64 {
        self.rho
    }
    fn dilatational_modulus(&self) -> f64 {
        self.modulus0
    }
    fn shear_modulus(&self) -> f64 {
        0.0
    }
    fn n_state(&self) -> usize {
        3
    }
    fn init_state(&self, state: &mut [f64]) {
        let e0 = self.e0;
        state[E] = e0;
        state[V] = 1.0 / self.rho;
        state[P] = self.eos.eval(self.rho, e0).p;
    }
    fn update_stress(
        &self,
        stress: &mut [f64; 6],
        state: &mut [f64],
        _deps: &[f64; 6],
        _dt: f64,
        density: f64,
    ) {
        let v1 = 1.0 / density;
        let dv = v1 - state[V];
        let trial = self.eos.eval(density, state[E]);
        let de = -(state[P] + trial.p) * dv / (2.0 + trial.dp_de * dv);
        let p = trial.p + trial.dp_de * de;
        state[E] += de;
        state[V] = v1;
        state[P] = p;
        *stress = [-p, -p, -p, 0.0, 0.0, 0.0];
    }
    fn add_heat(&self, state: &mut [f64], de: f64, density: f64) {
        state[E] += de;
        state[P] = self.eos.eval(density, state[E]).p;
    }
    fn wave_modulus(&self, density: f64, state: &[f64]) -> f64 {
        density * self.eos.sound_speed_sq(density, state[E])
    }
}
