//! Ideal gas: p = (gamma - 1) rho e, c^2 = gamma p / rho (the same formula as
//! `sph::Eos::IdealGas`). `e0` is the initial specific internal energy, J/kg.
use super::{eos_keys, Eos, EosPoint, MIN_SOUND_SPEED_SQ_FRACTION};
use crate::material::{bad, EosSpec, MaterialError, MaterialSpec};

/// Ideal gas.
#[derive(Debug, Clone)]
pub struct IdealGas {
    gamma: f64,
    e0: f64,
}

impl IdealGas {
    /// From `eos = { kind = "ideal_gas", gamma, e0 }`.
    pub fn build(spec: &MaterialSpec, es: &EosSpec) -> Result<Box<dyn Eos>, MaterialError> {
        let v = eos_keys(spec, es, &["gamma", "e0"], &["gamma"])?;
        if !(v[0] > 1.0) {
            return Err(bad(spec, "eos.gamma", v[0], "expected gamma > 1"));
        }
        if !(v[1] >= 0.0) {
            return Err(bad(spec, "eos.e0", v[1], "expected e0 >= 0, J/kg"));
        }
        Ok(Box::new(IdealGas {
            gamma: v[0],
            e0: v[1],
        }))
    }
}

impl Eos for IdealGas {
    fn eval(&self, rho: f64, e: f64) -> EosPoint {
        let g1 = self.gamma - 1.0;
        EosPoint {
            p: g1 * rho * e,
            dp_drho: g1 * e,
            dp_de: g1 * rho,
        }
    }
    fn initial_energy(&self) -> f64 {
        self.e0
    }
    fn min_sound_speed_sq(&self) -> f64 {
        // m^2/s^2, as the SPH crate's floor for an ideal gas
        MIN_SOUND_SPEED_SQ_FRACTION
    }
}
