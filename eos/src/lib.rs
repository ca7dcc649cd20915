//! Equations of state p(rho, e), rho the density (kg/m^3) and e the specific internal energy
//! (J/kg), shared by the SPH particles (`sph`) and the meshed fluid (`fe_petsc`'s `fluid`
//! material), and the one table of the scene's `eos = { kind = ..., ... }` kinds (`KINDS`).
//!
//! The adiabatic sound speed is c^2 = dp/drho|_s = dp/drho|_e + (p/rho^2) dp/de|_rho (from
//! de = (p/rho^2) drho along an isentrope). Every kind is affine in e at fixed rho
//! (p = f(rho) + g(rho) e, g = dp/de), which the meshed fluid's energy update uses to solve its
//! trapezoid rule exactly (`fe_petsc/src/material/fluid.rs`).
//!
//! Adding a kind: a variant of `Eos` with its formulas in `Eos::eval_with_floor` and
//! `Eos::min_sound_speed_sq`, and one entry of `KINDS` (name, keys, constructor); the scene
//! check, the SPH parameters and the meshed fluid all read the table. Then document the kind
//! (docs/running.md).
// `!(x > 0.0)` on purpose: NaN fails the range checks too
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![warn(missing_docs)]

/// Smallest c^2 returned, as a fraction of a kind's reference c^2 (or in m^2/s^2 for an ideal
/// gas): keeps the stable step finite where an EOS loses convexity (JWL at large expansion,
/// tension of Mie-Grüneisen) instead of producing NaN from sqrt of a negative number.
pub const MIN_SOUND_SPEED_SQ_FRACTION: f64 = 1e-12;

/// Pressure and its partial derivatives at one (rho, e).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EosPoint {
    /// Pressure, Pa (compression positive).
    pub p: f64,
    /// dp/drho at constant e, Pa m^3/kg.
    pub dp_drho: f64,
    /// dp/de at constant rho (= g(rho) of p = f + g e), kg/m^3.
    pub dp_de: f64,
}

impl EosPoint {
    /// The adiabatic sound speed squared at density `rho`,
    /// c^2 = dp/drho|_e + (p/rho^2) dp/de|_rho, m^2/s^2; not floored.
    #[inline]
    pub fn sound_speed_sq(&self, rho: f64) -> f64 {
        self.dp_drho + self.p / (rho * rho) * self.dp_de
    }
}

/// An equation of state: one entry of the SPH material table (`sph::Params::eos`), or the EOS
/// of a meshed fluid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Eos {
    /// Tait's equation for water (R. H. Cole, Underwater Explosions, Princeton 1948;
    /// J. J. Monaghan 1994 for SPH): p = B [(rho/rho0)^gamma - 1], B = rho0 c0^2 / gamma,
    /// independent of e; c^2 = dp/drho = c0^2 (rho/rho0)^(gamma - 1), so
    /// c = c0 (rho/rho0)^((gamma-1)/2). Scene keys `rho0`, `sound_speed`, `gamma`.
    Tait {
        /// Reference density, kg/m^3.
        rho0: f64,
        /// Sound speed at rho0, m/s.
        c0: f64,
        /// Exponent (7 for water).
        gamma: f64,
    },
    /// Ideal gas: p = (gamma - 1) rho e, c^2 = gamma p / rho. Scene keys `gamma` and `e0`, the
    /// initial specific internal energy, J/kg.
    IdealGas {
        /// Ratio of specific heats.
        gamma: f64,
    },
    /// Jones-Wilkins-Lee detonation products (E. L. Lee, H. C. Hornig, J. W. Kury, "Adiabatic
    /// expansion of high explosive detonation products", UCRL-50422, 1968), with V = rho0/rho
    /// the relative volume and E = rho0 e the energy per unit initial volume:
    /// p = A (1 - omega/(R1 V)) exp(-R1 V) + B (1 - omega/(R2 V)) exp(-R2 V) + omega rho e.
    /// rho0 is the material's `density`, and the scene's `e0` is E at t = 0 (J/m^3), so the
    /// specific energy starts at e0 / rho0. Scene keys `a`, `b`, `r1`, `r2`, `omega`, `e0`.
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
    /// Mie-Grüneisen with the linear us = c0 + s up Hugoniot as reference (LS-DYNA's
    /// `*EOS_GRUNEISEN` with S2 = S3 = 0 and no volume term a; Steinberg's form),
    /// mu = rho/rho0 - 1, rho Gamma = rho0 Gamma0:
    /// compression p = rho0 c0^2 mu (1 + (1 - Gamma0/2) mu) / (1 - (s - 1) mu)^2 + Gamma0 rho0 e,
    /// tension p = rho0 c0^2 mu + Gamma0 rho0 e.
    /// rho0 is the material's `density`; e = 0 at t = 0 (the meshed fluid integrates e from the
    /// element's volume change, SPH from its energy equation). Scene keys `c0`, `s`, `gamma0`.
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

impl Eos {
    /// p, dp/drho|_e and dp/de|_rho at density `rho` (kg/m^3) and specific internal energy `e`
    /// (J/kg).
    #[inline]
    pub fn eval(&self, rho: f64, e: f64) -> EosPoint {
        self.eval_with_floor(rho, e).0
    }

    /// Pressure only, Pa.
    #[inline]
    pub fn pressure(&self, rho: f64, e: f64) -> f64 {
        self.eval_with_floor(rho, e).0.p
    }

    /// The adiabatic c^2 at (rho, e), floored by `min_sound_speed_sq`, m^2/s^2.
    #[inline]
    pub fn sound_speed_sq(&self, rho: f64, e: f64) -> f64 {
        let (pt, floor) = self.eval_with_floor(rho, e);
        pt.sound_speed_sq(rho).max(floor)
    }

    /// (p, c) at density rho and specific internal energy e; c from the floored c^2.
    #[inline]
    pub fn pressure_and_sound_speed(&self, rho: f64, e: f64) -> (f64, f64) {
        let (pt, floor) = self.eval_with_floor(rho, e);
        (pt.p, pt.sound_speed_sq(rho).max(floor).sqrt())
    }

    /// Smallest c^2 the sound speed takes, m^2/s^2: where an EOS loses convexity (JWL at large
    /// expansion, tension) c^2 is floored instead of giving NaN.
    #[inline]
    pub fn min_sound_speed_sq(&self) -> f64 {
        match *self {
            Eos::Tait { c0, .. } | Eos::MieGruneisen { c0, .. } => {
                MIN_SOUND_SPEED_SQ_FRACTION * c0 * c0
            }
            // m^2/s^2: an ideal gas has no reference sound speed
            Eos::IdealGas { .. } => MIN_SOUND_SPEED_SQ_FRACTION,
            // reference c^2 scale (A + B)/rho0 (Pa per kg/m^3)
            Eos::Jwl { a, b, rho0, .. } => MIN_SOUND_SPEED_SQ_FRACTION * (a.abs() + b.abs()) / rho0,
        }
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

    /// (p, dp/drho at constant e, dp/de at constant rho) and the floor for c^2.
    #[inline]
    fn eval_with_floor(&self, rho: f64, e: f64) -> (EosPoint, f64) {
        match *self {
            Eos::Tait { rho0, c0, gamma } => {
                let b = rho0 * c0 * c0 / gamma;
                // rho * (1/rho0), not rho/rho0: LIGGGHTS's `fix sph/pressure` multiplies by a
                // precomputed 1/rho0, and this order reproduces its p bit for bit
                let ratio = rho * (1.0 / rho0);
                let pw = libm::pow(ratio, gamma);
                let p = b * (pw - 1.0);
                // dp/drho = B gamma/rho0 (rho/rho0)^(gamma-1) = c0^2 (rho/rho0)^(gamma-1)
                let dp = c0 * c0 * pw / ratio;
                (
                    EosPoint {
                        p,
                        dp_drho: dp,
                        dp_de: 0.0,
                    },
                    MIN_SOUND_SPEED_SQ_FRACTION * c0 * c0,
                )
            }
            Eos::IdealGas { gamma } => (
                EosPoint {
                    p: (gamma - 1.0) * rho * e,
                    dp_drho: (gamma - 1.0) * e,
                    dp_de: (gamma - 1.0) * rho,
                },
                MIN_SOUND_SPEED_SQ_FRACTION,
            ),
            Eos::Jwl {
                a,
                b,
                r1,
                r2,
                omega,
                rho0,
            } => {
                let v = rho0 / rho;
                let e1 = libm::exp(-r1 * v);
                let e2 = libm::exp(-r2 * v);
                let p = a * (1.0 - omega / (r1 * v)) * e1
                    + b * (1.0 - omega / (r2 * v)) * e2
                    + omega * rho * e;
                // d/dV [A (1 - w/(R V)) e^(-R V)] = A e^(-R V) (w/(R V^2) + w/V - R);
                // dV/drho = -V/rho
                let dterm =
                    |amp: f64, r: f64, ex: f64| amp * ex * (omega / (r * v * v) + omega / v - r);
                let dp_dv = dterm(a, r1, e1) + dterm(b, r2, e2);
                (
                    EosPoint {
                        p,
                        dp_drho: -dp_dv * v / rho + omega * e,
                        dp_de: omega * rho,
                    },
                    MIN_SOUND_SPEED_SQ_FRACTION * (a.abs() + b.abs()) / rho0,
                )
            }
            Eos::MieGruneisen {
                rho0,
                c0,
                s,
                gamma0,
            } => {
                let mu = rho / rho0 - 1.0;
                let k = rho0 * c0 * c0;
                let (p_ref, dp_dmu) = if mu > 0.0 {
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
                (
                    EosPoint {
                        p: p_ref + gamma0 * rho0 * e,
                        dp_drho: dp_dmu / rho0,
                        dp_de: gamma0 * rho0,
                    },
                    MIN_SOUND_SPEED_SQ_FRACTION * c0 * c0,
                )
            }
        }
    }
}

/// A parameter of a scene's `eos` table that is missing or out of range.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamError {
    /// A key of the kind is not given.
    Missing {
        /// The key.
        key: &'static str,
    },
    /// A value out of the kind's range.
    Bad {
        /// The key.
        key: &'static str,
        /// Its value.
        value: f64,
        /// What was expected.
        why: &'static str,
    },
}

impl std::fmt::Display for ParamError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParamError::Missing { key } => write!(f, "missing key \"{key}\""),
            ParamError::Bad { key, value, why } => write!(f, "{key} = {value}: {why}"),
        }
    }
}

impl std::error::Error for ParamError {}

/// One kind of the scene's `eos = { kind = ..., ... }`: its name, its keys and how it is built.
#[derive(Debug)]
pub struct Kind {
    /// The scene's `kind`.
    pub name: &'static str,
    /// Its parameter keys, all required, in the order `make` takes their values.
    pub keys: &'static [&'static str],
    /// The keys whose values must be > 0.
    pub positive: &'static [&'static str],
    /// The EOS and its initial specific internal energy (J/kg) from the values of `keys`
    /// (finite, and > 0 for `positive`) and the material's density (> 0, kg/m^3).
    make: Make,
}

/// A kind's constructor: the values of its keys (in order) and the material's density to the
/// EOS and the initial specific internal energy.
type Make = fn(&[f64], f64) -> Result<(Eos, f64), ParamError>;

impl Kind {
    /// Builds the kind from its parameters, `get(key)` for each of `keys`, and the material's
    /// `density` (> 0, kg/m^3, checked by the caller): the EOS and the material's initial
    /// specific internal energy, J/kg. Checks, in `keys` order, that each value is given and
    /// finite (and > 0 for `positive`), then the kind's own ranges. Keys that are not the
    /// kind's are the caller's to reject (`unknown_key`).
    pub fn build(
        &self,
        get: impl Fn(&str) -> Option<f64>,
        density: f64,
    ) -> Result<(Eos, f64), ParamError> {
        let mut v = Vec::with_capacity(self.keys.len());
        for &key in self.keys {
            let value = get(key).ok_or(ParamError::Missing { key })?;
            let positive = self.positive.contains(&key);
            if !value.is_finite() || (positive && !(value > 0.0)) {
                return Err(ParamError::Bad {
                    key,
                    value,
                    why: if positive {
                        "expected a positive finite number"
                    } else {
                        "expected a finite number"
                    },
                });
            }
            v.push(value);
        }
        (self.make)(&v, density)
    }

    /// The first of `given` that is not one of this kind's keys.
    pub fn unknown_key<'a>(&self, given: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
        given.into_iter().find(|k| !self.keys.contains(k))
    }
}

/// The name table: every kind a scene may name, its keys and its constructor.
pub static KINDS: &[Kind] = &[
    Kind {
        name: "tait",
        keys: &["rho0", "sound_speed", "gamma"],
        positive: &["rho0", "sound_speed", "gamma"],
        make: |v, _density| {
            let eos = Eos::Tait {
                rho0: v[0],
                c0: v[1],
                gamma: v[2],
            };
            Ok((eos, 0.0))
        },
    },
    Kind {
        name: "ideal_gas",
        keys: &["gamma", "e0"],
        positive: &["gamma"],
        make: |v, _density| {
            if !(v[0] > 1.0) {
                return Err(ParamError::Bad {
                    key: "gamma",
                    value: v[0],
                    why: "expected gamma > 1",
                });
            }
            if !(v[1] >= 0.0) {
                return Err(ParamError::Bad {
                    key: "e0",
                    value: v[1],
                    why: "expected e0 >= 0, J/kg",
                });
            }
            // e0 is already specific, J/kg
            Ok((Eos::IdealGas { gamma: v[0] }, v[1]))
        },
    },
    Kind {
        name: "jwl",
        keys: &["a", "b", "r1", "r2", "omega", "e0"],
        positive: &["r1", "r2", "omega"],
        make: |v, density| {
            let eos = Eos::Jwl {
                a: v[0],
                b: v[1],
                r1: v[2],
                r2: v[3],
                omega: v[4],
                rho0: density,
            };
            // e0 is energy per unit initial volume, J/m^3: specific e = e0 / rho0
            Ok((eos, v[5] / density))
        },
    },
    Kind {
        name: "mie_gruneisen",
        keys: &["c0", "s", "gamma0"],
        positive: &["c0"],
        make: |v, density| {
            let eos = Eos::MieGruneisen {
                rho0: density,
                c0: v[0],
                s: v[1],
                gamma0: v[2],
            };
            Ok((eos, 0.0))
        },
    },
];

/// The kind of that name.
pub fn kind(name: &str) -> Option<&'static Kind> {
    KINDS.iter().find(|k| k.name == name)
}

/// The kinds' names, ", "-separated (for error messages).
pub fn kind_names() -> String {
    KINDS.iter().map(|k| k.name).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    /// TNT (Dobratz & Crawford, LLNL Explosives Handbook, UCRL-52997, 1985): A 371.2 GPa,
    /// B 3.231 GPa, R1 4.15, R2 0.95, omega 0.30, rho0 1630 kg/m^3, E0 7 GJ/m^3 -> e0 = 4.29e6 J/kg.
    const TNT: Eos = Eos::Jwl {
        a: 3.712e11,
        b: 3.231e9,
        r1: 4.15,
        r2: 0.95,
        omega: 0.30,
        rho0: 1630.0,
    };
    /// Copper (Steinberg): rho0 8930, c0 3940, s 1.49, Gamma0 2.02.
    const CU: Eos = Eos::MieGruneisen {
        rho0: 8930.0,
        c0: 3940.0,
        s: 1.49,
        gamma0: 2.02,
    };
    const WATER: Eos = Eos::Tait {
        rho0: 1000.0,
        c0: 20.0,
        gamma: 7.0,
    };
    const AIR: Eos = Eos::IdealGas { gamma: 1.4 };

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
        assert_eq!(
            eos.sound_speed_sq(rho, e),
            eos.eval(rho, e).sound_speed_sq(rho),
            "{eos:?}: the floored c^2 equals the point's where c^2 > 0"
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
        for rho in [1630.0, 1200.0, 400.0] {
            check_sound_speed(TNT, rho, 4.29e6);
        }
        for rho in [9500.0, 8930.0 * 1.001, 8800.0] {
            check_sound_speed(CU, rho, 1.0e4);
        }
    }

    #[test]
    fn reference_values() {
        // Tait at rho0: p = 0, c = c0 (by definition).
        assert_eq!(
            WATER.pressure_and_sound_speed(1000.0, 0.0),
            (0.0, 20.0),
            "Tait at rho0: p = 0 and c = c0 exactly"
        );
        // Ideal gas, Sod left state: rho 1, p 1 -> e = 2.5, c = sqrt(1.4).
        let (p, c) = AIR.pressure_and_sound_speed(1.0, 2.5);
        assert!(
            (p - 1.0).abs() < 1e-15 && (c - 1.4f64.sqrt()).abs() < 1e-15,
            "Sod's left state: p {p} (1), c {c} (sqrt 1.4), tol 1e-15"
        );
        // Mie-Grüneisen at rho0, e = 0: p = 0, c = c0 (Hugoniot slope at mu = 0 is rho0 c0^2).
        let (p, c) = CU.pressure_and_sound_speed(8930.0, 0.0);
        assert!(
            p.abs() < 1e-6 && (c - 3940.0).abs() < 1e-9,
            "Mie-Grüneisen at rho0, e = 0: p {p} (0, tol 1e-6 Pa), c {c} (c0 3940, tol 1e-9 m/s)"
        );
        // JWL at V = 1 with e = 0: A(1 - w/R1)e^-R1 + B(1 - w/R2)e^-R2 by hand.
        let (a, b, r1, r2, w): (f64, f64, f64, f64, f64) = (3.712e11, 3.231e9, 4.15, 0.95, 0.30);
        let want = a * (1.0 - w / r1) * (-r1).exp() + b * (1.0 - w / r2) * (-r2).exp();
        let got = TNT.pressure(1630.0, 0.0);
        assert!(
            (got - want).abs() <= 1e-12 * want,
            "JWL at V = 1, e = 0: {got} vs {want} by hand (tol 1e-12 relative)"
        );
    }

    #[test]
    fn ideal_gas_is_the_textbook_formula() {
        // p = (gamma - 1) rho e exactly (same operations), c^2 = gamma p / rho to round-off.
        for (rho, e) in [(1.0, 2.5), (0.125, 2.0), (0.3, 2.2), (4.0, 0.5)] {
            let pt = AIR.eval(rho, e);
            assert_eq!(pt.p, (1.4 - 1.0) * rho * e, "ideal gas p, exact");
            let c2 = 1.4 * pt.p / rho;
            assert!(
                (AIR.sound_speed_sq(rho, e) - c2).abs() <= 4.0 * f64::EPSILON * c2,
                "ideal gas c^2 = gamma p / rho at rho {rho} e {e} (tol 4 eps relative)"
            );
        }
    }

    #[test]
    fn tait_c_follows_its_closed_form() {
        // c = c0 (rho/rho0)^((gamma-1)/2) (Monaghan 1994), independent of e.
        for rho in [990.0, 1000.0, 1003.0, 1050.0] {
            let (_, c) = WATER.pressure_and_sound_speed(rho, 123.0);
            let want = 20.0 * (rho / 1000.0f64).powf(3.0);
            assert!(
                (c - want).abs() <= 1e-14 * want,
                "Tait c at rho {rho}: {c} vs c0 (rho/rho0)^3 = {want} (tol 1e-14 relative)"
            );
        }
        assert_eq!(WATER.pressure(1003.0, 0.0), WATER.pressure(1003.0, 5.0e6));
    }

    #[test]
    fn jwl_tends_to_its_ideal_gas_term_at_large_volume() {
        // At V = 50 the exponential terms are below B e^(-47.5) ~ 8e-12 Pa, the omega rho e
        // term is 0.3 x 32.6 x 4.29e6 ~ 4e7 Pa: p = omega rho e to round-off.
        let rho = 1630.0 / 50.0;
        let e = 4.29e6;
        let p = TNT.pressure(rho, e);
        let want = 0.30 * rho * e;
        assert!(
            (p - want).abs() <= 1e-15 * want,
            "JWL at V = 50: {p} vs omega rho e = {want} (tol 1e-15 relative)"
        );
    }

    #[test]
    fn mie_gruneisen_at_rho0_is_its_energy_term() {
        // mu = 0: the reference curve vanishes, p = Gamma0 rho0 e (the same operations, exact).
        let e = 1.0e4;
        assert_eq!(CU.pressure(8930.0, e), 2.02 * 8930.0 * e, "p(rho0, e)");
        // Tension is linear: p = rho0 c0^2 mu + Gamma0 rho0 e (to round-off).
        let rho = 8800.0;
        let mu = rho / 8930.0 - 1.0;
        let want = 8930.0 * 3940.0 * 3940.0 * mu + 2.02 * 8930.0 * e;
        let p = CU.pressure(rho, e);
        assert!(
            (p - want).abs() <= 1e-12 * want.abs(),
            "Mie-Grüneisen tension: {p} vs {want} (tol 1e-12 relative)"
        );
    }

    #[test]
    fn every_kind_is_affine_in_e() {
        // p(rho, e) = p(rho, 0) + dp/de e: the meshed fluid's closed-form energy update relies
        // on it. Tolerance: round-off of the sum, 1e-13 of the largest term.
        for (eos, rho, e) in [
            (WATER, 1003.0, 7.0),
            (AIR, 0.3, 2.2),
            (TNT, 1200.0, 4.29e6),
            (CU, 9500.0, 1.0e4),
            (CU, 8800.0, 1.0e4),
        ] {
            let p0 = eos.eval(rho, 0.0);
            let p = eos.pressure(rho, e);
            let want = p0.p + p0.dp_de * e;
            let scale = p0.p.abs().max((p0.dp_de * e).abs());
            assert!(
                (p - want).abs() <= 1e-13 * scale,
                "{eos:?}: p(rho, e) {p} vs p(rho, 0) + dp/de e = {want} (tol 1e-13)"
            );
        }
    }

    #[test]
    fn sound_speed_is_floored() {
        // JWL expanded (V = 3) with e < 0: c^2 < 0 there, it takes the floor (A + B)/rho0 1e-12.
        let (rho, e) = (1630.0 / 3.0, -1.0e7);
        assert!(TNT.eval(rho, e).sound_speed_sq(rho) < 0.0);
        let floor = MIN_SOUND_SPEED_SQ_FRACTION * (3.712e11 + 3.231e9) / 1630.0;
        assert_eq!(TNT.sound_speed_sq(rho, e), floor);
        assert_eq!(TNT.min_sound_speed_sq(), floor);
        assert_eq!(AIR.sound_speed_sq(1.0, 0.0), MIN_SOUND_SPEED_SQ_FRACTION);
    }

    fn params(kv: &[(&str, f64)]) -> BTreeMap<String, f64> {
        kv.iter().map(|(k, v)| (k.to_string(), *v)).collect()
    }

    #[test]
    fn the_table_builds_each_kind_with_its_initial_energy() {
        let build = |name: &str, kv: &[(&str, f64)], density: f64| {
            let p = params(kv);
            kind(name)
                .unwrap()
                .build(|k| p.get(k).copied(), density)
                .unwrap()
        };
        assert_eq!(
            build(
                "tait",
                &[("rho0", 1000.0), ("sound_speed", 20.0), ("gamma", 7.0)],
                998.0
            ),
            (WATER, 0.0),
            "tait: its own rho0 (not the material's density), e = 0 (exact)"
        );
        // ideal gas: e0 is specific (J/kg), taken as is
        assert_eq!(
            build("ideal_gas", &[("gamma", 1.4), ("e0", 2.5)], 1.0),
            (AIR, 2.5),
            "ideal_gas: e0 taken as J/kg (exact)"
        );
        // JWL: e0 is J/m^3 of initial volume, rho0 the material's density: e = e0 / rho0
        let tnt = [
            ("a", 3.712e11),
            ("b", 3.231e9),
            ("r1", 4.15),
            ("r2", 0.95),
            ("omega", 0.30),
            ("e0", 7.0e9),
        ];
        assert_eq!(
            build("jwl", &tnt, 1630.0),
            (TNT, 7.0e9 / 1630.0),
            "jwl: rho0 = density, e = e0 / rho0 (exact)"
        );
        assert_eq!(
            build(
                "mie_gruneisen",
                &[("c0", 3940.0), ("s", 1.49), ("gamma0", 2.02)],
                8930.0
            ),
            (CU, 0.0),
            "mie_gruneisen: rho0 = density, e = 0 (exact)"
        );
        // every kind of the table is reachable by name, once
        for k in KINDS {
            assert!(
                std::ptr::eq(kind(k.name).unwrap(), k),
                "{}: found by name, and only once",
                k.name
            );
        }
        assert_eq!(kind_names(), "tait, ideal_gas, jwl, mie_gruneisen");
        assert!(kind("water").is_none());
    }

    #[test]
    fn the_table_checks_keys_and_ranges() {
        let ig = kind("ideal_gas").unwrap();
        let try_build = |kv: &[(&str, f64)]| {
            let p = params(kv);
            ig.build(|k| p.get(k).copied(), 1.0)
        };
        assert_eq!(
            try_build(&[("gamma", 1.4)]),
            Err(ParamError::Missing { key: "e0" })
        );
        assert_eq!(
            try_build(&[("gamma", 0.9), ("e0", 1.0)]),
            Err(ParamError::Bad {
                key: "gamma",
                value: 0.9,
                why: "expected gamma > 1"
            })
        );
        assert_eq!(
            try_build(&[("gamma", 1.4), ("e0", -1.0)]),
            Err(ParamError::Bad {
                key: "e0",
                value: -1.0,
                why: "expected e0 >= 0, J/kg"
            })
        );
        assert!(matches!(
            try_build(&[("gamma", -1.0), ("e0", 1.0)]),
            Err(ParamError::Bad {
                key: "gamma",
                why: "expected a positive finite number",
                ..
            })
        ));
        assert!(matches!(
            try_build(&[("gamma", 1.4), ("e0", f64::NAN)]),
            Err(ParamError::Bad {
                key: "e0",
                why: "expected a finite number",
                ..
            })
        ));
        assert_eq!(ig.unknown_key(["gamma", "cv", "e0"]), Some("cv"));
        assert_eq!(ig.unknown_key(["gamma", "e0"]), None);
    }
}
