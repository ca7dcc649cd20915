//! Mie-Grüneisen with the linear us = c0 + s up Hugoniot as reference (LS-DYNA's
//! `*EOS_GRUNEISEN` with S2 = S3 = 0 and no volume term a; Steinberg's form), mu = rho/rho0 - 1,
//! rho Gamma = rho0 Gamma0:
//! compression p = rho0 c0^2 mu (1 + (1 - Gamma0/2) mu) / (1 - (s - 1) mu)^2 + Gamma0 rho0 e,
//! tension p = rho0 c0^2 mu + Gamma0 rho0 e. The same formula as `sph::Eos::MieGruneisen`;
//! rho0 is the material's `density`. The energy term uses the element's specific internal
//! energy (`fluid.rs` integrates it from the element's volume change; e = 0 at t = 0).
use super::{eos_keys, Eos, EosPoint, MIN_SOUND_SPEED_SQ_FRACTION};
use crate::material::{EosSpec, MaterialError, MaterialSpec};

/// Mie-Grüneisen with a linear Hugoniot.
#[derive(Debug, Clone)]
pub struct MieGruneisen {
    rho0: f64,
    c0: f64,
    s: f64,
    gamma0: f64,
}

impl MieGruneisen {
    /// From `eos = { kind = "mie_gruneisen", c0, s, gamma0 }` and the material's `density`.
    pub fn build(spec: &MaterialSpec, es: &EosSpec) -> Result<Box<dyn Eos>, MaterialError> {
        let v = eos_keys(spec, es, &["c0", "s", "gamma0"], &["c0"])?;
        Ok(Box::new(MieGruneisen {
            rho0: spec.density,
            c0: v[0],
            s: v[1],
            gamma0: v[2],
        }))
    }
}

impl Eos for MieGruneisen {
    fn eval(&self, rho: f64, e: f64) -> EosPoint {
        let (rho0, s, g0) = (self.rho0, self.s, self.gamma0);
        let mu = rho / rho0 - 1.0;
        let k = rho0 * self.c0 * self.c0;
        let (p_ref, dp_dmu) = if mu > 0.0 {
            // N = mu + (1 - G/2) mu^2, D = 1 - (s-1) mu, p = k N / D^2,
            // dp/dmu = k (N' D + 2 (s-1) N) / D^3
            let n = mu + (1.0 - 0.5 * g0) * mu * mu;
            let dn = 1.0 + (2.0 - g0) * mu;
            let d = 1.0 - (s - 1.0) * mu;
            (
                k * n / (d * d),
                k * (dn * d + 2.0 * (s - 1.0) * n) / (d * d * d),
            )
        } else {
            (k * mu, k)
        };
        EosPoint {
            p: p_ref + g0 * rho0 * e,
            dp_drho: dp_dmu / rho0,
            dp_de: g0 * rho0,
        }
    }
    fn min_sound_speed_sq(&self) -> f64 {
        MIN_SOUND_SPEED_SQ_FRACTION * self.c0 * self.c0
    }
}
