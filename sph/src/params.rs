//! The model settings shared by every pass: which formulas (profile), kernel, density method,
//! energy equation, artificial viscosity, tensile correction, gravity, periodic box and the
//! equation-of-state table.
use crate::eos::Eos;
use crate::kernel::{Kernel, SmoothingKernel};
use crate::neighbour::SearchOptions;
use crate::periodic::Periodic;

/// Which set of formulas and which integrator to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Profile {
    /// Textbook forms: 1/(pi h^3) cubic-spline normalisation, Monaghan (1992) viscosity with the
    /// particles' EOS sound speeds, per-particle tensile correction (Monaghan 2000, Gray et al.
    /// 2001), kick-drift-kick leapfrog with predicted density and energy (see `integrate`).
    #[default]
    Standard,
    /// LIGGGHTS-PUBLIC 3.8.0's `pair sph/artVisc/tensCorr` + `fix nve/sph`, reproduced to
    /// round-off: truncated kernel constants, material (not EOS) sound speed in the viscosity, its
    /// tensile-correction rule, Euler density update and its velocity predictor.
    Liggghts,
}

impl Profile {
    /// Whether the set-up evaluation (before step 1) runs the density pass and the EOS.
    /// LIGGGHTS computes the set-up forces before any `pre_force` fix ran, i.e. with p = 0,
    /// drho/dt = 0 and v^ = 0; the standard profile evaluates the full state at t = 0.
    pub fn setup_evaluates_density_and_eos(self) -> bool {
        self == Profile::Standard
    }
}

/// How density is obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum DensityMode {
    /// Integrate drho_a/dt = sum_b m_b (dW/dr)(r_ab . v^_ab)/r.
    #[default]
    Continuity,
    /// rho_a = m_a W(0, h_a) + sum_b m_b W_ab at every evaluation.
    Summation,
}

/// Monaghan artificial viscosity, active for approaching pairs (v^_ab . r_ab < 0):
/// mu = h (v^_ab . r_ab)/(r^2 + eta^2), Pi_ab = (-alpha c_mean mu + beta mu^2)/rho_mean, with
/// eta^2 = `eta_factor` h^2 (h of the pair). Monaghan, Annu. Rev. Astron. Astrophys. 30 (1992) 543.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArtificialViscosity {
    /// Linear (bulk) coefficient alpha.
    pub alpha: f64,
    /// Quadratic (von Neumann-Richtmyer) coefficient beta.
    pub beta: f64,
    /// eta^2 / h^2, 0.01 by convention (LIGGGHTS's `artViscEta` is this times h^2).
    pub eta_factor: f64,
}

/// The conventional eta^2 / h^2 of the artificial viscosity.
pub const ETA_FACTOR: f64 = 0.01;

impl ArtificialViscosity {
    /// alpha, beta with eta^2 = 0.01 h^2.
    pub fn new(alpha: f64, beta: f64) -> Self {
        Self {
            alpha,
            beta,
            eta_factor: ETA_FACTOR,
        }
    }
}

/// Tensile-instability correction R_ab f_ab^n with f_ab = W(r)/W(delta_p): R = epsilon
/// |p|/rho^2 for a particle in tension (p < 0) and `positive` p/rho^2 in compression.
/// Monaghan's (J. Comput. Phys. 159 (2000) 290): positive 0.01, n = 4
/// ([`TensileCorrection::monaghan`], `[sph] tensile_correction`); Gray, Monaghan & Swift's
/// artificial stress of a fluid, whose stress -p I is tensile where p < 0 (CMAME 190 (2001)
/// 6641, eq. 25): positive 0, their n ([`TensileCorrection::gray`], `[sph] artificial_stress`
/// in a scene of fluids only).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TensileCorrection {
    /// epsilon, the factor on |p|/rho^2 of particles in tension (0.2 typical).
    pub epsilon: f64,
    /// The reference distance delta_p (the initial particle spacing), m.
    pub delta_p: f64,
    /// The factor on p/rho^2 of particles in compression (Monaghan 2000: 0.01; Gray et al.: 0).
    pub positive: f64,
    /// The exponent n of f_ab^n (1 to 16).
    pub exponent: i32,
}

impl TensileCorrection {
    /// Monaghan's (2000) correction: epsilon on tension, 0.01 on compression, n = 4.
    pub fn monaghan(epsilon: f64, delta_p: f64) -> Self {
        Self {
            epsilon,
            delta_p,
            positive: crate::passes::POSITIVE_PRESSURE_TENSILE_FACTOR,
            exponent: crate::passes::TENSILE_EXPONENT,
        }
    }

    /// Gray, Monaghan & Swift's (2001) artificial stress on a fluid: epsilon on tension only,
    /// exponent `n`.
    pub fn gray(epsilon: f64, n: i32, delta_p: f64) -> Self {
        Self {
            epsilon,
            delta_p,
            positive: 0.0,
            exponent: n,
        }
    }
}

/// Everything the passes and the integrator need besides the particles.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// Formulas and integrator.
    pub profile: Profile,
    /// Kernel shape (its normalisation follows `profile`).
    pub kernel: Kernel,
    /// Continuity or summation density.
    pub density: DensityMode,
    /// Evolve the specific internal energy e with de/dt (EOS then sees e change).
    pub energy: bool,
    /// Artificial viscosity, if any.
    pub viscosity: Option<ArtificialViscosity>,
    /// Tensile correction, if any.
    pub tensile: Option<TensileCorrection>,
    /// Artificial thermal conductivity coefficient alpha_u (Price, J. Comput. Phys. 227 (2008)
    /// 10040, eq. 28 with the pressure signal speed of eq. 30), used with the energy equation:
    /// it diffuses e across contact discontinuities so that pressure stays continuous there
    /// (without it a contact between fluids of different entropy holds a spurious pressure
    /// jump). It moves energy between particles and changes no total. `None`: off.
    pub conductivity: Option<f64>,
    /// Gravity, m/s^2 (added as m g to every moving owned particle).
    pub gravity: [f64; 3],
    /// Periodic box, if any.
    pub periodic: Option<Periodic>,
    /// Adaptive smoothing length: at the end of every step (standard profile) each owned
    /// particle takes h = `adaptive_h` (m/rho)^(1/3), so that its neighbour count stays near
    /// its initial one as the flow compresses or expands (no grad-h terms: momentum stays
    /// exactly conserved, energy to the order of dh/dt). `None`: h is constant.
    pub adaptive_h: Option<f64>,
    /// Equation of state per material index (`Particles::mat`).
    pub eos: Vec<Eos>,
}

impl Params {
    /// Standard profile, cubic spline, continuity, no energy equation, no viscosity, no tensile
    /// correction, no gravity, not periodic, with the given EOS table.
    pub fn new(eos: Vec<Eos>) -> Self {
        Self {
            profile: Profile::Standard,
            kernel: Kernel::CubicSpline,
            density: DensityMode::Continuity,
            energy: false,
            viscosity: None,
            tensile: None,
            conductivity: None,
            gravity: [0.0; 3],
            periodic: None,
            adaptive_h: None,
            eos,
        }
    }

    /// The kernel with this profile's normalisation.
    pub fn smoothing_kernel(&self) -> SmoothingKernel {
        self.kernel.with_profile(self.profile)
    }

    /// The neighbour-search options this model needs: pairs of two fixed particles are skipped
    /// with continuity density (they change nothing: fixed particles do not move, so
    /// v^_ab = 0 and their mutual forces act on nobody) but kept with summation density (their
    /// kernel sums are each other's density).
    pub fn search_options(&self) -> SearchOptions {
        SearchOptions {
            periodic: self.periodic,
            skip_fixed_pairs: self.density == DensityMode::Continuity,
        }
    }
}
