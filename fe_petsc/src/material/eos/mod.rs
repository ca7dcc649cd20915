//! Equations of state of the meshed `fluid` material: one file per kind, one trait, one name
//! table (`KINDS`). Each kind evaluates p(rho, e) with e the specific internal energy (J/kg).
//!
//! The formulas are the same as the SPH crate's (`sph/src/eos.rs`), which the FE side may not
//! depend on; each file cites its source. Every kind is affine in e at fixed rho
//! (p = f(rho) + g(rho) e), which the element's energy update uses to solve its trapezoid rule
//! exactly (see `fluid.rs`).
use super::{bad, MaterialError, MaterialSpec};

mod ideal_gas;
mod jwl;
mod mie_gruneisen;
mod tait;
pub use ideal_gas::IdealGas;
pub use jwl::Jwl;
pub use mie_gruneisen::MieGruneisen;
pub use tait::Tait;

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
    /// The adiabatic sound speed squared, c^2 = dp/drho|_e + (p/rho^2) dp/de|_rho (from
    /// de = (p/rho^2) drho along an isentrope), m^2/s^2; not floored.
    pub fn sound_speed_sq(&self, rho: f64) -> f64 {
        self.dp_drho + self.p / (rho * rho) * self.dp_de
    }
}

/// An equation of state p(rho, e), affine in e at fixed rho.
pub trait Eos: Send + Sync + std::fmt::Debug {
    /// Returns p, dp/drho|_e and dp/de|_rho at density `rho` (kg/m^3) and specific internal
    /// energy `e` (J/kg).
    fn eval(&self, rho: f64, e: f64) -> EosPoint;
    /// Specific internal energy of the material as the scene gives it at t = 0, J/kg (0 for
    /// the kinds without an `e0` key).
    fn initial_energy(&self) -> f64 {
        0.0
    }
    /// Smallest c^2 the stable step uses, m^2/s^2: where an EOS loses convexity (JWL at large
    /// expansion, tension) c^2 is floored instead of giving NaN.
    fn min_sound_speed_sq(&self) -> f64;
}

/// Smallest c^2 as a fraction of a kind's reference c^2 (the SPH crate's
/// `MIN_SOUND_SPEED_SQ_FRACTION`, the same value).
pub const MIN_SOUND_SPEED_SQ_FRACTION: f64 = 1e-12;

/// Builds an EOS from the material's spec (`density` is the material's reference density).
pub type EosConstructor = fn(&MaterialSpec, &super::EosSpec) -> Result<Box<dyn Eos>, MaterialError>;

/// The name table: scene `eos.kind` -> constructor.
pub const KINDS: &[(&str, EosConstructor)] = &[
    ("tait", Tait::build),
    ("ideal_gas", IdealGas::build),
    ("jwl", Jwl::build),
    ("mie_gruneisen", MieGruneisen::build),
];

/// Builds the EOS of a fluid spec, checking its keys.
pub fn build_eos(spec: &MaterialSpec) -> Result<Box<dyn Eos>, MaterialError> {
    let Some(es) = &spec.eos else {
        return Err(MaterialError::Missing {
            name: spec.name.clone(),
            key: "eos".into(),
            model: spec.model.clone(),
        });
    };
    match KINDS.iter().find(|(n, _)| *n == es.kind) {
        Some((_, c)) => c(spec, es),
        None => Err(MaterialError::UnknownModel {
            name: spec.name.clone(),
            model: format!("eos {}", es.kind),
            expected: KINDS.iter().map(|k| k.0).collect::<Vec<_>>().join(", "),
        }),
    }
}

/// The EOS's keys in `keys` order, checking that no other key is present and that each value
/// is finite (`positive` lists those that must be > 0).
pub(crate) fn eos_keys(
    spec: &MaterialSpec,
    es: &super::EosSpec,
    keys: &[&str],
    positive: &[&str],
) -> Result<Vec<f64>, MaterialError> {
    let model = format!("fluid (eos {})", es.kind);
    for k in es.params.keys() {
        if !keys.contains(&k.as_str()) {
            return Err(MaterialError::UnknownKey {
                name: spec.name.clone(),
                key: format!("eos.{k}"),
                model,
                expected: keys.join(", "),
            });
        }
    }
    keys.iter()
        .map(|k| {
            let v = es
                .params
                .get(*k)
                .copied()
                .ok_or_else(|| MaterialError::Missing {
                    name: spec.name.clone(),
                    key: format!("eos.{k}"),
                    model: model.clone(),
                })?;
            if !v.is_finite() || (positive.contains(k) && !(v > 0.0)) {
                return Err(bad(
                    spec,
                    &format!("eos.{k}"),
                    v,
                    if positive.contains(k) {
                        "expected a positive finite number"
                    } else {
                        "expected a finite number"
                    },
                ));
            }
            Ok(v)
        })
        .collect()
}
