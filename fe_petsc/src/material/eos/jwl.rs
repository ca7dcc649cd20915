//! Jones-Wilkins-Lee detonation products (E. L. Lee, H. C. Hornig, J. W. Kury, "Adiabatic
//! expansion of high explosive detonation products", UCRL-50422, 1968), with V = rho0/rho the
//! relative volume and E = rho0 e the energy per unit initial volume:
//! p = A (1 - omega/(R1 V)) exp(-R1 V) + B (1 - omega/(R2 V)) exp(-R2 V) + omega rho e.
//! The same formula as `sph::Eos::Jwl`; rho0 is the material's `density`, and the scene's `e0`
//! is E at t = 0 (J/m^3), so the specific energy starts at e0 / rho0.
use super::{eos_keys, Eos, EosPoint, MIN_SOUND_SPEED_SQ_FRACTION};
use crate::material::{EosSpec, MaterialError, MaterialSpec};

/// JWL products.
#[derive(Debug, Clone)]
pub struct Jwl {
    a: f64,
    b: f64,
    r1: f64,
    r2: f64,
    omega: f64,
    rho0: f64,
    e0: f64,
}

impl Jwl {
    /// From `eos = { kind = "jwl", a, b, r1, r2, omega, e0 }` and the material's `density`.
    pub fn build(spec: &MaterialSpec, es: &EosSpec) -> Result<Box<dyn Eos>, MaterialError> {
        let v = eos_keys(
            spec,
            es,
            &["a", "b", "r1", "r2", "omega", "e0"],
            &["r1", "r2", "omega"],
        )?;
        Ok(Box::new(Jwl {
            a: v[0],
            b: v[1],
            r1: v[2],
            r2: v[3],
            omega: v[4],
            rho0: spec.density,
            e0: v[5] / spec.density,
        }))
    }
}

impl Eos for Jwl {
    fn eval(&self, rho: f64, e: f64) -> EosPoint {
        let (a, b, r1, r2, w) = (self.a, self.b, self.r1, self.r2, self.omega);
        let v = self.rho0 / rho;
        let e1 = (-r1 * v).exp();
        let e2 = (-r2 * v).exp();
        let p = a * (1.0 - w / (r1 * v)) * e1 + b * (1.0 - w / (r2 * v)) * e2 + w * rho * e;
        // d/dV [A (1 - w/(R V)) e^(-R V)] = A e^(-R V) (w/(R V^2) + w/V - R); dV/drho = -V/rho
        let dterm = |amp: f64, r: f64, ex: f64| amp * ex * (w / (r * v * v) + w / v - r);
        let dp_dv = dterm(a, r1, e1) + dterm(b, r2, e2);
        EosPoint {
            p,
            dp_drho: -dp_dv * v / rho + w * e,
            dp_de: w * rho,
        }
    }
    fn initial_energy(&self) -> f64 {
        self.e0
    }
    fn min_sound_speed_sq(&self) -> f64 {
        // reference c^2 scale A/rho0 (Pa per kg/m^3), as the SPH crate
        MIN_SOUND_SPEED_SQ_FRACTION * (self.a.abs() + self.b.abs()) / self.rho0
    }
}
