//! Materials: one file per model, one trait, one name table (`MODELS`).
use std::collections::BTreeMap;

/// A material as the scene file declares it (`[[material]]`), before a model is built from it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MaterialSpec {
    /// The scene's `name` of the material.
    pub name: String,
    /// The scene's `model` ("elastic", "j2_plastic", "johnson_cook", "fluid").
    pub model: String,
    /// Reference density, kg/m^3.
    pub density: f64,
    /// Every other numeric key of the table (youngs_modulus, poisson_ratio, yield_stress, ...).
    pub params: BTreeMap<String, f64>,
    /// The `eos` table of a fluid: its `kind` and numeric parameters.
    pub eos: Option<EosSpec>,
}

/// An equation of state as the scene declares it (`eos = { kind = "tait", ... }`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EosSpec {
    /// One of the `eos` crate's kinds (`eos::KINDS`: "tait", "ideal_gas", "jwl", "mie_gruneisen").
    pub kind: String,
    /// Its numeric parameters by name.
    pub params: BTreeMap<String, f64>,
}

mod elastic;
pub mod eos;
mod fluid;
mod j2_plastic;
mod johnson_cook;
pub use elastic::Elastic;
pub use fluid::Fluid;
pub use j2_plastic::J2Plastic;
pub use johnson_cook::{JohnsonCook, TAYLOR_QUINNEY, THERMAL_KEYS as JC_THERMAL_KEYS};

/// A solid material: the stress update and the moduli the element needs.
pub trait Material: Send + Sync + std::fmt::Debug {
    /// Reference density rho0, kg/m^3.
    fn density(&self) -> f64;
    /// lambda + 2 mu, Pa (stable step, hourglass stiffness).
    fn dilatational_modulus(&self) -> f64;
    /// Shear modulus mu, Pa.
    fn shear_modulus(&self) -> f64;
    /// History variables per element.
    fn n_state(&self) -> usize {
        0
    }
    /// Writes the initial history variables.
    fn init_state(&self, _state: &mut [f64]) {}
    /// Writes into `stress` (Voigt xx,yy,zz,xy,yz,zx, tension positive, already rotated to the
    /// new configuration) the stress after the strain increment `deps` = D dt (tensor shear
    /// components), and updates `state`. `dt` > 0 is the step, for rate-dependent laws;
    /// `density` = rho0 V0 / V is the element's density at the end of the step, kg/m^3 (a
    /// fluid's EOS reads it; the solids ignore it).
    fn update_stress(
        &self,
        stress: &mut [f64; 6],
        state: &mut [f64],
        deps: &[f64; 6],
        dt: f64,
        density: f64,
    );
    /// rho c^2 at the element's current `density` and `state` after `update_stress`, Pa: the
    /// modulus the stable step, the bulk viscosity's sound speed and the hourglass stiffness
    /// use. Default: the constant `dilatational_modulus` (lambda + 2 mu of a solid).
    fn wave_modulus(&self, _density: f64, _state: &[f64]) -> f64 {
        self.dilatational_modulus()
    }
    /// The current (static) yield stress in von Mises terms, Pa, for models with a yield
    /// surface; `None` for the others. The physical hourglass control bounds the hourglass
    /// stresses with it.
    fn yield_stress(&self, _state: &[f64]) -> Option<f64> {
        None
    }
    /// Adds `de` J/kg of heat to the element's state: the work of the bulk viscosity, which the
    /// element computes outside the material. Only the models with an energy state (a fluid's
    /// EOS) keep it; the default ignores it (solids: the work is counted in the energy balance,
    /// it changes no stress).
    fn add_heat(&self, _state: &mut [f64], _de: f64, _density: f64) {}
    /// Equivalent plastic strain, for output (0 for elastic models).
    fn plastic_strain(&self, _state: &[f64]) -> f64 {
        0.0
    }
    /// Temperature, K, for models that keep one (Johnson-Cook with thermal softening); `None`
    /// for the others.
    fn temperature(&self, _state: &[f64]) -> Option<f64> {
        None
    }
    /// The model's own lane form of its stress update for the element kernel
    /// ([`crate::batch`]), or `None` (the default): the kernel then calls this model's
    /// `update_stress`, `wave_modulus`, `add_heat` and `yield_stress` lane by lane
    /// ([`LaneLaw::Pointwise`]). A model with a lane form keeps the default `wave_modulus` and
    /// `add_heat`, has at most one history variable, and its lane update computes in each lane
    /// what `update_stress` computes.
    fn lane_law(&self) -> Option<LaneLaw> {
        None
    }
}

/// The most history variables a model keeps per element (the fluid keeps three: its specific
/// internal energy, volume and pressure), the size of the element kernel's per-lane buffer.
pub const MAX_STATE: usize = 4;

/// How the element kernel ([`crate::batch`]) runs a model's stress update on a group of
/// elements, one element per lane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LaneLaw {
    /// Linear elastic ([`Elastic`]) in lanes.
    Elastic(Elastic),
    /// J2 plasticity with linear hardening ([`J2Plastic`]) in lanes; history: the plastic
    /// strain.
    J2Plastic(J2Plastic),
    /// Any other model (Johnson-Cook with its powers and logarithms, a fluid's equation of
    /// state): the kernel calls the model's own scalar functions lane by lane, the rest of the
    /// element (geometry, bulk viscosity, hourglass control, forces) in lanes.
    Pointwise {
        /// The model's history variables per element (at most [`MAX_STATE`]).
        n_state: usize,
    },
}

impl LaneLaw {
    /// History variables per element.
    pub fn n_state(&self) -> usize {
        match self {
            LaneLaw::Elastic(_) => 0,
            LaneLaw::J2Plastic(_) => 1,
            LaneLaw::Pointwise { n_state } => *n_state,
        }
    }

    /// Whether the kernel calls the model's scalar functions lane by lane.
    pub fn is_pointwise(&self) -> bool {
        matches!(self, LaneLaw::Pointwise { .. })
    }
}

/// A bad `[[material]]` table.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MaterialError {
    /// The model name is not in the table.
    #[error("material \"{name}\": unknown model \"{model}\" (expected one of {expected})")]
    UnknownModel {
        /// Material name.
        name: String,
        /// The model asked for.
        model: String,
        /// The models known.
        expected: String,
    },
    /// A required key is missing.
    #[error("material \"{name}\": missing key \"{key}\" (needed by model {model})")]
    Missing {
        /// Material name.
        name: String,
        /// The key.
        key: String,
        /// The model.
        model: String,
    },
    /// A key the model does not use.
    #[error("material \"{name}\": unknown key \"{key}\" for model {model} (expected {expected})")]
    UnknownKey {
        /// Material name.
        name: String,
        /// The key.
        key: String,
        /// The model.
        model: String,
        /// The keys it takes.
        expected: String,
    },
    /// A value out of range.
    #[error("material \"{name}\": {key} = {value}: {why}")]
    BadValue {
        /// Material name.
        name: String,
        /// The key.
        key: String,
        /// Its value.
        value: f64,
        /// What was expected.
        why: String,
    },
}

/// Builds a model from a spec.
pub type Constructor = fn(&MaterialSpec) -> Result<Box<dyn Material>, MaterialError>;

/// The name table: scene `model` -> constructor.
pub const MODELS: &[(&str, Constructor)] = &[
    ("elastic", Elastic::build),
    ("j2_plastic", J2Plastic::build),
    ("johnson_cook", JohnsonCook::build),
    ("fluid", Fluid::build),
];

/// Builds the material a spec describes, checking its keys and values.
pub fn build_material(spec: &MaterialSpec) -> Result<Box<dyn Material>, MaterialError> {
    match MODELS.iter().find(|(n, _)| *n == spec.model) {
        Some((_, c)) => c(spec),
        None => Err(MaterialError::UnknownModel {
            name: spec.name.clone(),
            model: spec.model.clone(),
            expected: MODELS.iter().map(|m| m.0).collect::<Vec<_>>().join(", "),
        }),
    }
}

/// Checks a spec's keys against the model's and returns the values in `keys` order.
pub(crate) fn take(spec: &MaterialSpec, keys: &[&str]) -> Result<Vec<f64>, MaterialError> {
    for k in spec.params.keys() {
        if !keys.contains(&k.as_str()) {
            return Err(MaterialError::UnknownKey {
                name: spec.name.clone(),
                key: k.clone(),
                model: spec.model.clone(),
                expected: keys.join(", "),
            });
        }
    }
    if !(spec.density > 0.0 && spec.density.is_finite()) {
        return Err(bad(
            spec,
            "density",
            spec.density,
            "expected a positive density, kg/m^3",
        ));
    }
    keys.iter()
        .map(|k| {
            spec.params
                .get(*k)
                .copied()
                .ok_or_else(|| MaterialError::Missing {
                    name: spec.name.clone(),
                    key: k.to_string(),
                    model: spec.model.clone(),
                })
        })
        .collect()
}

pub(crate) fn bad(spec: &MaterialSpec, key: &str, value: f64, why: &str) -> MaterialError {
    MaterialError::BadValue {
        name: spec.name.clone(),
        key: key.to_string(),
        value,
        why: why.to_string(),
    }
}

/// Lame constants (lambda, mu) from E and nu, with range checks.
pub(crate) fn lame(spec: &MaterialSpec, e: f64, nu: f64) -> Result<(f64, f64), MaterialError> {
    if !(e > 0.0 && e.is_finite()) {
        return Err(bad(
            spec,
            "youngs_modulus",
            e,
            "expected a positive modulus, Pa",
        ));
    }
    if !(nu > -1.0 && nu < 0.5) {
        return Err(bad(
            spec,
            "poisson_ratio",
            nu,
            "expected -1 < poisson_ratio < 0.5",
        ));
    }
    let mu = e / (2.0 * (1.0 + nu));
    let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    Ok((lambda, mu))
}

/// Adds the isotropic elastic increment: stress += lambda tr(deps) I + 2 mu deps.
#[inline]
pub(crate) fn add_elastic(stress: &mut [f64; 6], deps: &[f64; 6], lambda: f64, mu: f64) {
    let tr = deps[0] + deps[1] + deps[2];
    for k in 0..3 {
        stress[k] += lambda * tr + 2.0 * mu * deps[k];
        stress[k + 3] += 2.0 * mu * deps[k + 3];
    }
}

/// [`add_elastic`] in lanes.
/// Deviator of a Voigt stress and the von Mises stress sqrt(3/2 s:s).
#[inline]
pub(crate) fn deviator(s: &[f64; 6]) -> ([f64; 6], f64, f64) {
    let p = (s[0] + s[1] + s[2]) * crate::hourglass::THIRD;
    let d = [s[0] - p, s[1] - p, s[2] - p, s[3], s[4], s[5]];
    let j2 =
        0.5 * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) + d[3] * d[3] + d[4] * d[4] + d[5] * d[5];
    (d, p, (3.0 * j2).sqrt())
}
