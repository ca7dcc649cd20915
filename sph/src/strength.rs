//! The stress model of a solid particle: the one trait through which an SPH particle carries
//! the Cauchy stress. The coupling crate implements it for `fe_petsc`'s materials (elastic,
//! j2_plastic, johnson_cook), so that an element and a particle of one material share one
//! stress update; the `sph` crate itself holds no material law (its tests define a linear
//! elastic one).
//!
//! Conventions (the same as `fe_petsc::material::Material::update_stress`): stress in Voigt
//! order xx, yy, zz, xy, yz, zx, Pa, tension positive; strain increments with TENSOR shear
//! components (deps_xy = D_xy dt, not the engineering 2 D_xy dt).

/// A solid's constitutive update, called once per particle and step after the stress has been
/// rotated to the new configuration (see `crate::solid::update_stress`).
pub trait StressModel: Send + Sync + std::fmt::Debug {
    /// History values per particle (plastic strain, back stress, temperature...). Default 0.
    fn n_state(&self) -> usize {
        0
    }

    /// Writes the initial history values into `state` (length `n_state`). Default: nothing
    /// (the caller zeroes them).
    fn init_state(&self, _state: &mut [f64]) {}

    /// Writes into `stress` (already rotated) the stress after the strain increment
    /// `deps` = D dt (tensor shear components), and updates `state`. `dt` > 0 is the step, s
    /// (rate-dependent laws); `density` is the particle's density at the end of the step,
    /// kg/m^3 (a law with an equation of state for its pressure reads it).
    fn update_stress(
        &self,
        stress: &mut [f64; 6],
        state: &mut [f64],
        deps: &[f64; 6],
        dt: f64,
        density: f64,
    );

    /// Shear modulus G, Pa.
    fn shear_modulus(&self) -> f64;

    /// rho c^2 at `density` and `state`, Pa: the longitudinal wave modulus (K + 4G/3 for an
    /// elastic solid) that gives the particle's sound speed c = sqrt(modulus / rho), which the
    /// stable step and the artificial viscosity read.
    fn wave_modulus(&self, density: f64, state: &[f64]) -> f64;

    /// Equivalent plastic strain held in `state` (failure criteria, output). Default 0.
    fn plastic_strain(&self, _state: &[f64]) -> f64 {
        0.0
    }

    /// Whether `state` holds a failed particle's (a law with a failure criterion: no
    /// deviatoric stress and no tension from then on; output). Default false.
    fn failed(&self, _state: &[f64]) -> bool {
        false
    }

    /// The least density a particle whose history is `state` may take, kg/m^3 (default 0: no
    /// floor). A failed particle's material carries no tension: where its pairs pull apart it
    /// is opening cracks between fragments, not stretching, so its density stays at the
    /// material's (continuity or summation alone would take it towards m W(0), about a fifth
    /// of it for a particle left alone, and with it the sound speed sqrt(modulus / rho) and
    /// the pair forces' sigma / rho^2 up, the stable step down without bound).
    fn density_floor(&self, _state: &[f64]) -> f64 {
        0.0
    }

    /// Temperature held in `state`, K, where the law keeps one (thermal softening; output).
    /// Default `None`.
    fn temperature(&self, _state: &[f64]) -> Option<f64> {
        None
    }

    /// The material's initial density, kg/m^3, where the law knows it: a particle of mass m
    /// then has the initial spacing (m / rho0)^(1/3), the artificial stress's delta_p
    /// ([`crate::ArtificialStress`]). Default `None` (the particle's current density stands in).
    fn reference_density(&self) -> Option<f64> {
        None
    }
}
