//! Johnson-Cook plasticity: yield = (a + b ep^n)(1 + c ln(max(1, rate / eps_dot0)))(1 - T*^m),
//! rate = the equivalent plastic strain rate = dgamma / dt, T* = (T - t_room) / (t_melt -
//! t_room) clamped to [0, 1] (G. R. Johnson & W. H. Cook, "A constitutive model and data for
//! metals subjected to large strains, high strain rates and high temperatures", 7th Int. Symp.
//! on Ballistics, The Hague, 1983, eq. 1). Without `m` the law is isothermal (the last factor
//! 1).
//!
//! Radial return as for J2, with the scalar equation for the plastic increment
//! g(dgamma) = q_tr - 3 mu dgamma - yield(ep + dgamma, dgamma / dt, T) = 0, which decreases
//! monotonically in dgamma: solved by bisection on [0, q_tr / (3 mu)] to round-off (robust where
//! ep^n has an infinite slope at ep = 0). The temperature is that at the start of the step
//! (staggered), and then rises adiabatically by the plastic work's share the Taylor-Quinney
//! coefficient beta converts to heat (Taylor & Quinney 1934: beta about 0.9 for metals):
//!
//! ```text
//!   dT = beta * q * dgamma / (rho * specific_heat)      (K; q the von Mises stress after the
//!                                                        return, Pa; rho the current density)
//! ```
//!
//! State: [ep], or [ep, T] with thermal softening.
use super::{add_elastic, bad, deviator, lame, take, Material, MaterialError, MaterialSpec};

/// Bisection steps: halves the bracket to below 1e-16 of its width.
const BISECTION_STEPS: usize = 60;

/// The optional thermal keys (all of `m`, `t_room`, `t_melt`, `specific_heat` together;
/// `taylor_quinney` defaults to [`TAYLOR_QUINNEY`]).
pub const THERMAL_KEYS: [&str; 5] = ["m", "t_room", "t_melt", "specific_heat", "taylor_quinney"];

/// Default Taylor-Quinney coefficient: the share of plastic work that becomes heat.
pub const TAYLOR_QUINNEY: f64 = 0.9;

/// Thermal softening and adiabatic heating.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Thermal {
    /// Exponent m of T*.
    m: f64,
    /// Room and melting temperatures, K.
    t_room: f64,
    t_melt: f64,
    /// J/(kg K).
    specific_heat: f64,
    /// Taylor-Quinney coefficient beta.
    beta: f64,
}

impl Thermal {
    /// The softening factor 1 - T*^m at temperature `t`.
    fn factor(&self, t: f64) -> f64 {
        let ts = ((t - self.t_room) / (self.t_melt - self.t_room)).clamp(0.0, 1.0);
        1.0 - libm::pow(ts, self.m)
    }
}

/// Johnson-Cook rate-dependent plasticity, with optional thermal softening.
#[derive(Debug, Clone)]
pub struct JohnsonCook {
    rho: f64,
    lambda: f64,
    mu: f64,
    a: f64,
    b: f64,
    n: f64,
    c: f64,
    eps_dot0: f64,
    thermal: Option<Thermal>,
}

impl JohnsonCook {
    /// From `density`, `youngs_modulus`, `poisson_ratio`, `a`, `b`, `n`, `c`, `eps_dot0`.
    pub fn build(spec: &MaterialSpec) -> Result<Box<dyn Material>, MaterialError> {
        let (spec, thermal) = thermal_of(spec)?;
        let spec = &spec;
        let v = take(
            spec,
            &[
                "youngs_modulus",
                "poisson_ratio",
                "a",
                "b",
                "n",
                "c",
                "eps_dot0",
            ],
        )?;
        let (lambda, mu) = lame(spec, v[0], v[1])?;
        if !(v[2] > 0.0) {
            return Err(bad(
                spec,
                "a",
                v[2],
                "expected a positive initial yield stress, Pa",
            ));
        }
        if !(v[3] >= 0.0) {
            return Err(bad(spec, "b", v[3], "expected b >= 0, Pa"));
        }
        if !(v[4] > 0.0) {
            return Err(bad(spec, "n", v[4], "expected n > 0"));
        }
        if !(v[5] >= 0.0) {
            return Err(bad(spec, "c", v[5], "expected c >= 0"));
        }
        if !(v[6] > 0.0) {
            return Err(bad(
                spec,
                "eps_dot0",
                v[6],
                "expected a positive reference rate, 1/s",
            ));
        }
        Ok(Box::new(JohnsonCook {
            rho: spec.density,
            lambda,
            mu,
            a: v[2],
            b: v[3],
            n: v[4],
            c: v[5],
            eps_dot0: v[6],
            thermal,
        }))
    }

    /// Flow stress at plastic strain `ep`, plastic strain rate `rate` and temperature `t` (K;
    /// ignored without thermal softening), Pa.
    pub fn flow_stress(&self, ep: f64, rate: f64, t: f64) -> f64 {
        let soft = self.thermal.map_or(1.0, |th| th.factor(t));
        (self.a + self.b * libm::pow(ep.max(0.0), self.n))
            * (1.0 + self.c * libm::log((rate / self.eps_dot0).max(1.0)))
            * soft
    }

    /// The temperature a state holds (K), or NaN without thermal softening.
    fn temperature_of(&self, state: &[f64]) -> f64 {
        match self.thermal {
            Some(_) => state[1],
            None => f64::NAN,
        }
    }
}

/// Splits the thermal keys off `spec`: the spec without them, and the thermal law when `m` is
/// given (then `t_room`, `t_melt` and `specific_heat` are needed too; `taylor_quinney` in
/// [0, 1], default [`TAYLOR_QUINNEY`]).
fn thermal_of(spec: &MaterialSpec) -> Result<(MaterialSpec, Option<Thermal>), MaterialError> {
    let mut rest = spec.clone();
    let mut got = std::collections::BTreeMap::new();
    for k in THERMAL_KEYS {
        if let Some(v) = rest.params.remove(k) {
            got.insert(k, v);
        }
    }
    if got.is_empty() {
        return Ok((rest, None));
    }
    let need = |k: &str| -> Result<f64, MaterialError> {
        got.get(k).copied().ok_or_else(|| MaterialError::Missing {
            name: spec.name.clone(),
            key: k.to_string(),
            model: "johnson_cook with thermal softening (m, t_room, t_melt, specific_heat)".into(),
        })
    };
    let th = Thermal {
        m: need("m")?,
        t_room: need("t_room")?,
        t_melt: need("t_melt")?,
        specific_heat: need("specific_heat")?,
        beta: got.get("taylor_quinney").copied().unwrap_or(TAYLOR_QUINNEY),
    };
    if !(th.m > 0.0 && th.m.is_finite()) {
        return Err(bad(spec, "m", th.m, "expected a positive exponent"));
    }
    if !(th.t_room > 0.0 && th.t_room.is_finite()) {
        return Err(bad(
            spec,
            "t_room",
            th.t_room,
            "expected a positive temperature, K",
        ));
    }
    if !(th.t_melt > th.t_room && th.t_melt.is_finite()) {
        return Err(bad(
            spec,
            "t_melt",
            th.t_melt,
            "expected a temperature above t_room, K",
        ));
    }
    if !(th.specific_heat > 0.0 && th.specific_heat.is_finite()) {
        return Err(bad(
            spec,
            "specific_heat",
            th.specific_heat,
            "expected a positive specific heat, J/(kg K)",
        ));
    }
    if !(0.0..=1.0).contains(&th.beta) {
        return Err(bad(
            spec,
            "taylor_quinney",
            th.beta,
            "expected a share of plastic work in [0, 1]",
        ));
    }
    Ok((rest, Some(th)))
}

impl Material for JohnsonCook {
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
        if self.thermal.is_some() {
            2
        } else {
            1
        }
    }
    fn init_state(&self, state: &mut [f64]) {
        state[0] = 0.0;
        if let Some(th) = self.thermal {
            state[1] = th.t_room;
        }
    }
    fn update_stress(
        &self,
        stress: &mut [f64; 6],
        state: &mut [f64],
        deps: &[f64; 6],
        dt: f64,
        density: f64,
    ) {
        add_elastic(stress, deps, self.lambda, self.mu);
        let (s, p, q) = deviator(stress);
        let ep = state[0];
        let t = self.temperature_of(state);
        if q <= self.flow_stress(ep, 0.0, t) {
            return;
        }
        let g =
            |dg: f64| q - 3.0 * self.mu * dg - self.flow_stress(ep + dg, dg / dt.max(1e-300), t);
        let (mut lo, mut hi) = (0.0, q / (3.0 * self.mu));
        for _ in 0..BISECTION_STEPS {
            let mid = 0.5 * (lo + hi);
            if g(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let dgamma = 0.5 * (lo + hi);
        let scale = 1.0 - 3.0 * self.mu * dgamma / q;
        for k in 0..3 {
            stress[k] = s[k] * scale + p;
            stress[k + 3] = s[k + 3] * scale;
        }
        state[0] += dgamma;
        if let Some(th) = self.thermal {
            // The plastic work per unit volume q' dgamma, q' = q - 3 mu dgamma the von Mises
            // stress after the return; its share beta heats the element.
            let rho = if density > 0.0 { density } else { self.rho };
            let work = (q - 3.0 * self.mu * dgamma) * dgamma;
            state[1] += th.beta * work / (rho * th.specific_heat);
        }
    }
    fn plastic_strain(&self, state: &[f64]) -> f64 {
        state[0]
    }
    fn temperature(&self, state: &[f64]) -> Option<f64> {
        self.thermal.map(|_| state[1])
    }
    fn yield_stress(&self, state: &[f64]) -> Option<f64> {
        // Static (rate factor 1): the hourglass bound is then on the safe, softer side.
        Some(self.flow_stress(state[0], 0.0, self.temperature_of(state)))
    }
}
