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
    /// "tait" | "ideal_gas" | "jwl" | "mie_gruneisen".
    pub kind: String,
    /// Its numeric parameters by name.
    pub params: BTreeMap<String, f64>,
}
