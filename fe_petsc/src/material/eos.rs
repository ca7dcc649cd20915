//! Equations of state of the meshed `fluid` material: the `eos` crate's (the same formulas and
//! name table as the SPH particles'), built from the scene's `eos = { kind = ..., ... }` through
//! the crate's table (`KINDS`), with its errors as `MaterialError`s. Each kind evaluates
//! p(rho, e) with e the specific internal energy (J/kg) and is affine in e at fixed rho
//! (p = f(rho) + g(rho) e), which the element's energy update uses to solve its trapezoid rule
//! exactly (see `fluid.rs`).
use super::{bad, MaterialError, MaterialSpec};
pub use ::eos::{kind_names, Eos, EosPoint, Kind, KINDS, MIN_SOUND_SPEED_SQ_FRACTION};

/// Builds the EOS of a fluid spec (`density` is the material's reference density), checking
/// that its kind is known, that it has no other key than the kind's and that each value is in
/// range. Returns the EOS and the material's specific internal energy at t = 0, J/kg.
pub fn build_eos(spec: &MaterialSpec) -> Result<(Eos, f64), MaterialError> {
    let Some(es) = &spec.eos else {
        return Err(MaterialError::Missing {
            name: spec.name.clone(),
            key: "eos".into(),
            model: spec.model.clone(),
        });
    };
    let Some(kind) = ::eos::kind(&es.kind) else {
        return Err(MaterialError::UnknownModel {
            name: spec.name.clone(),
            model: format!("eos {}", es.kind),
            expected: kind_names(),
        });
    };
    let model = format!("fluid (eos {})", es.kind);
    if let Some(k) = kind.unknown_key(es.params.keys().map(String::as_str)) {
        return Err(MaterialError::UnknownKey {
            name: spec.name.clone(),
            key: format!("eos.{k}"),
            model,
            expected: kind.keys.join(", "),
        });
    }
    kind.build(|k| es.params.get(k).copied(), spec.density)
        .map_err(|e| match e {
            ::eos::ParamError::Missing { key } => MaterialError::Missing {
                name: spec.name.clone(),
                key: format!("eos.{key}"),
                model,
            },
            ::eos::ParamError::Bad { key, value, why } => {
                bad(spec, &format!("eos.{key}"), value, why)
            }
        })
}
