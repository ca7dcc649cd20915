//! Equations of state p(rho, e) with e the specific internal energy (J/kg), and the adiabatic
//! sound speed c^2 = dp/drho|_s = dp/drho|_e + (p/rho^2) dp/de|_rho (from de = p/rho^2 drho
//! along an isentrope).

/// An equation of state, one entry of the material table (`Params::eos`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Eos {
    /// Tait (Cole 1948; Monaghan 1994 for SPH): p = B[(rho/rho0)^gamma - 1], B = rho0 c0^2/gamma;
    /// c = c0 (rho/rho0)^((gamma-1)/2). Ignores e.
    Tait {
        /// Reference density, kg/m^3.
        rho0: f64,
        /// Sound speed at rho0, m/s.
        c0: f64,
        /// Exponent (7 for water).
        gamma: f64,
    },
    /// Ideal gas: p = (gamma - 1) rho e, c = sqrt(gamma p / rho).
    IdealGas {
        /// Ratio of specific heats.
        gamma: f64,
    },
    /// Jones-Wilkins-Lee detonation products (Lee, Hornig & Kury 1968), V = rho0/rho:
    /// p = a(1 - omega/(r1 V)) exp(-r1 V) + b(1 - omega/(r2 V)) exp(-r2 V) + omega rho e.
    Jwl {
        /// A, Pa.
        a: f64,
        /// B, Pa.
        b: f64,
        /// R1.
        r1: f64,
        /// R2.
        r2: f64,
        /// omega (Grüneisen coefficient of the products).
        omega: f64,
        /// Density of the unreacted explosive, kg/m^3.
        rho0: f64,
    },
    /// Mie-Grüneisen with a linear us-up Hugoniot as reference (the LS-DYNA / Steinberg form),
    /// mu = rho/rho0 - 1 and rho Gamma = rho0 Gamma0:
    /// compression p = rho0 c0^2 mu (1 + (1 - Gamma0/2) mu) / (1 - (s-1) mu)^2 + Gamma0 rho0 e,
    /// tension p = rho0 c0^2 mu + Gamma0 rho0 e.
    MieGruneisen {
        /// Reference density, kg/m^3.
        rho0: f64,
        /// Bulk sound speed (intercept of us = c0 + s up), m/s.
        c0: f64,
        /// Slope s of us = c0 + s up.
        s: f64,
        /// Grüneisen coefficient at rho0.
        gamma0: f64,
    },
}

/// Smallest c^2 returned, as a fraction of a material's reference c^2 (or in m^2/s^2 for an
/// ideal gas): keeps the CFL step finite where an EOS loses convexity (JWL at large expansion,
/// tension of Mie-Grüneisen) instead of producing NaN from sqrt of a negative number.
pub const MIN_SOUND_SPEED_SQ_FRACTION: f64 = 1e-12;

impl Eos {
    /// (p, c) at density rho and specific internal energy e.
    pub fn pressure_and_sound_speed(&self, rho: f64, e: f64) -> (f64, f64) {
        let (p, dp_drho, dp_de, c2_floor) = self.pressure_and_derivatives(rho, e);
        let c2 = dp_drho + p / (rho * rho) * dp_de;
        (p, c2.max(c2_floor).sqrt())
    }

    /// Pressure only.
    pub fn pressure(&self, rho: f64, e: f64) -> f64 {
        self.pressure_and_derivatives(rho, e).0
    }

    /// The reference density rho0 of the kinds that have one (Tait, JWL, Mie-Grüneisen), kg/m^3.
    pub fn reference_density(&self) -> Option<f64> {
        match *self {
            Eos::Tait { rho0, .. } | Eos::Jwl { rho0, .. } | Eos::MieGruneisen { rho0, .. } => {
                Some(rho0)
            }
            Eos::IdealGas { .. } => None,
        }
    }

    /// The sound speed LIGGGHTS's artificial viscosity uses: the per-type constant
    /// `speedOfSound`, which for a Tait fluid is c0; `None` for the other materials (their EOS
    /// sound speed is used).
    pub fn liggghts_sound_speed(&self) -> Option<f64> {
        match self {
            Eos::Tait { c0, .. } => Some(*c0),
            _ => None,
        }
    }

    /// (p, dp/drho at constant e, dp/de at constant rho, floor for c^2).
    fn pressure_and_derivatives(&self, rho: f64, e: f64) -> (f64, f64, f64, f64) {
        match *self {
            Eos::Tait { rho0, c0, gamma } => {
                let b = rho0 * c0 * c0 / gamma;
                // rho * (1/rho0), not rho/rho0: LIGGGHTS's `fix sph/pressure` multiplies by a
                // precomputed 1/rho0, and this order reproduces its p bit for bit
                let ratio = rho * (1.0 / rho0);
                let pw = ratio.powf(gamma);
                let p = b * (pw - 1.0);
                // dp/drho = B gamma/rho0 (rho/rho0)^(gamma-1) = c0^2 (rho/rho0)^(gamma-1)
                let dp = c0 * c0 * pw / ratio;
                (p, dp, 0.0, MIN_SOUND_SPEED_SQ_FRACTION * c0 * c0)
            }
            Eos::IdealGas { gamma } => {
                let p = (gamma - 1.0) * rho * e;
                (
                    p,
                    (gamma - 1.0) * e,
                    (gamma - 1.0) * rho,
                    MIN_SOUND_SPEED_SQ_FRACTION,
                )
            }
            Eos::Jwl {
                a,
                b,
                r1,
                r2,
                omega,
                rho0,
            } => {
                let v = rho0 / rho;
                let e1 = (-r1 * v).exp();
                let e2 = (-r2 * v).exp();
                let p = a * (1.0 - omega / (r1 * v)) * e1
                    + b * (1.0 - omega / (r2 * v)) * e2
                    + omega * rho * e;
                // d/dV [A(1 - w/(R V)) e^{-R V}] = A e^{-R V} (w/(R V^2) + w/V - R); dV/drho = -V/rho
                let dterm =
                    |amp: f64, r: f64, ex: f64| amp * ex * (omega / (r * v * v) + omega / v - r);
                let dp_dv = dterm(a, r1, e1) + dterm(b, r2, e2);
                let dp_drho = -dp_dv * v / rho + omega * e;
                // reference c^2 scale: A/rho0 (Pa per kg/m^3)
                let floor = MIN_SOUND_SPEED_SQ_FRACTION * (a.abs() + b.abs()) / rho0;
                (p, dp_drho, omega * rho, floor)
            }
            Eos::MieGruneisen {
                rho0,
                c0,
                s,
                gamma0,
            } => {
                let mu = rho / rho0 - 1.0;
                let k = rho0 * c0 * c0;
                let (p_cold, dp_dmu) = if mu > 0.0 {
                    // N = mu + (1 - G/2) mu^2, D = 1 - (s-1) mu, p = k N / D^2,
                    // dp/dmu = k (N' D + 2 (s-1) N) / D^3
                    let n = mu + (1.0 - 0.5 * gamma0) * mu * mu;
                    let dn = 1.0 + (2.0 - gamma0) * mu;
                    let d = 1.0 - (s - 1.0) * mu;
                    (
                        k * n / (d * d),
                        k * (dn * d + 2.0 * (s - 1.0) * n) / (d * d * d),
                    )
                } else {
                    (k * mu, k)
                };
                let p = p_cold + gamma0 * rho0 * e;
                (
                    p,
                    dp_dmu / rho0,
                    gamma0 * rho0,
                    MIN_SOUND_SPEED_SQ_FRACTION * c0 * c0,
                )
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// c^2 against finite differences of p: dp/drho|_e and dp/de|_rho by central differences
    /// (relative error ~1e-8 at step 1e-5 relative), combined as c^2 = p_rho + p/rho^2 p_e.
    fn check_sound_speed(eos: Eos, rho: f64, e: f64) {
        let (p, c) = eos.pressure_and_sound_speed(rho, e);
        let dr = 1e-5 * rho;
        let de = 1e-5 * e.abs().max(1.0);
        let p_rho = (eos.pressure(rho + dr, e) - eos.pressure(rho - dr, e)) / (2.0 * dr);
        let p_e = (eos.pressure(rho, e + de) - eos.pressure(rho, e - de)) / (2.0 * de);
        let c2 = p_rho + p / (rho * rho) * p_e;
        assert!(c2 > 0.0);
        assert!(
            (c * c - c2).abs() <= 1e-6 * c2,
            "{eos:?} rho {rho} e {e}: c^2 {} vs finite difference {c2} (tol 1e-6 relative)",
            c * c
        );
    }

    #[test]
    fn sound_speeds_match_finite_differences() {
        check_sound_speed(
            Eos::Tait {
                rho0: 1000.0,
                c0: 20.0,
                gamma: 7.0,
            },
            1003.0,
            0.0,
        );
        check_sound_speed(Eos::IdealGas { gamma: 1.4 }, 0.3, 2.2);
        // TNT (Dobratz & Crawford, LLNL Explosives Handbook): A 371.2 GPa, B 3.231 GPa,
        // R1 4.15, R2 0.95, omega 0.30, rho0 1630 kg/m^3, E0 7 GJ/m^3 -> e0 = 4.29e6 J/kg.
        let tnt = Eos::Jwl {
            a: 3.712e11,
            b: 3.231e9,
            r1: 4.15,
            r2: 0.95,
            omega: 0.30,
            rho0: 1630.0,
        };
        for rho in [1630.0, 1200.0, 400.0] {
            check_sound_speed(tnt, rho, 4.29e6);
        }
        // Copper (Steinberg): rho0 8930, c0 3940, s 1.49, Gamma0 2.02.
        let cu = Eos::MieGruneisen {
            rho0: 8930.0,
            c0: 3940.0,
            s: 1.49,
            gamma0: 2.02,
        };
        for rho in [9500.0, 8930.0 * 1.001, 8800.0] {
            check_sound_speed(cu, rho, 1.0e4);
        }
    }

    #[test]
    fn reference_values() {
        // Tait at rho0: p = 0, c = c0 (by definition).
        let t = Eos::Tait {
            rho0: 1000.0,
            c0: 20.0,
            gamma: 7.0,
        };
        assert_eq!(t.pressure_and_sound_speed(1000.0, 0.0), (0.0, 20.0));
        // Ideal gas, Sod left state: rho 1, p 1 -> e = 2.5, c = sqrt(1.4).
        let (p, c) = Eos::IdealGas { gamma: 1.4 }.pressure_and_sound_speed(1.0, 2.5);
        assert!((p - 1.0).abs() < 1e-15 && (c - 1.4f64.sqrt()).abs() < 1e-15);
        // Mie-Grüneisen at rho0, e = 0: p = 0, c = c0 (Hugoniot slope at mu = 0 is rho0 c0^2).
        let (p, c) = Eos::MieGruneisen {
            rho0: 8930.0,
            c0: 3940.0,
            s: 1.49,
            gamma0: 2.02,
        }
        .pressure_and_sound_speed(8930.0, 0.0);
        assert!(p.abs() < 1e-6 && (c - 3940.0).abs() < 1e-9);
        // JWL at V = 1 with e = 0: A(1 - w/R1)e^-R1 + B(1 - w/R2)e^-R2 by hand.
        let (a, b, r1, r2, w): (f64, f64, f64, f64, f64) = (3.712e11, 3.231e9, 4.15, 0.95, 0.30);
        let want = a * (1.0 - w / r1) * (-r1).exp() + b * (1.0 - w / r2) * (-r2).exp();
        let got = Eos::Jwl {
            a,
            b,
            r1,
            r2,
            omega: w,
            rho0: 1630.0,
        }
        .pressure(1630.0, 0.0);
        assert!((got - want).abs() <= 1e-12 * want);
    }
}
