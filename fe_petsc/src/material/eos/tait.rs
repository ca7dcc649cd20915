//! Tait's equation for water (R. H. Cole, Underwater Explosions, Princeton 1948; J. J. Monaghan 1994 for SPH):
//! p = B [(rho/rho0)^gamma - 1], B = rho0 c0^2 / gamma, independent of e;
//! c^2 = dp/drho = c0^2 (rho/rho0)^(gamma - 1). The same formula as `sph::Eos::Tait`.
use super::{eos_keys, Eos, EosPoint, MIN_SOUND_SPEED_SQ_FRACTION};
use crate::material::{EosSpec, MaterialError, MaterialSpec};

/// Tait water.
#[derive(Debug, Clone)]
pub struct Tait {
    rho0: f64,
    c0: f64,
    gamma: f64,
}

impl Tait {
    /// From `eos = { kind = "tait", rho0, sound_speed, gamma }`.
    pub fn build(spec: &MaterialSpec, es: &EosSpec) -> Result<Box<dyn Eos>, MaterialError> {
        let keys = ["rho0", "sound_speed", "gamma"];
        let v = eos_keys(spec, es, &keys, &keys)?;
        Ok(Box::new(Tait {
            rho0: v[0],
            c0: v[1],
            gamma: v[2],
        }))
    }
}

impl Eos for Tait {
    fn eval(&self, rho: f64, _e: f64) -> EosPoint {
        let b = self.rho0 * self.c0 * self.c0 / self.gamma;
        let ratio = rho / self.rho0;
        let pw = ratio.powf(self.gamma);
        EosPoint {
            p: b * (pw - 1.0),
            // B gamma / rho0 (rho/rho0)^(gamma-1) = c0^2 (rho/rho0)^(gamma-1)
            dp_drho: self.c0 * self.c0 * pw / ratio,
            dp_de: 0.0,
        }
    }
    fn min_sound_speed_sq(&self) -> f64 {
        MIN_SOUND_SPEED_SQ_FRACTION * self.c0 * self.c0
    }
}
