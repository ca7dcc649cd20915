//! The element kernel's calls into a material without a lane law of its own
//! ([`crate::material::LaneLaw::Pointwise`]: Johnson-Cook, a fluid's equation of state): the
//! model's scalar functions called lane by lane on each lane's values, in the order
//! [`crate::hex::update`] calls them. Every width calls the same functions on the same values,
//! so every width gives the same bits; the rest of the element stays in lanes.
use super::{F, LANES};
use crate::material::{Material, MAX_STATE};

/// The history values of a group's elements, lane by lane (the model's `n_state` first).
pub type LaneHistory = [[f64; MAX_STATE]; LANES];

/// A pointwise material and its lanes' history values for one update.
pub(super) struct Pointwise<'a> {
    /// The model.
    pub model: &'a dyn Material,
    /// Its history values per element.
    pub n_state: usize,
    /// Each lane's history values.
    pub history: &'a mut LaneHistory,
}

impl Pointwise<'_> {
    /// [`Material::update_stress`] in each lane: the rotated stress `stress` becomes the new
    /// one after the strain increment `deps` over `dt` at the end-of-step density `rho`.
    #[inline]
    pub fn update_stress(&mut self, stress: &mut [F; 6], deps: &[F; 6], dt: f64, rho: F) {
        for l in 0..LANES {
            let mut s = [0.0; 6];
            let mut d = [0.0; 6];
            for k in 0..6 {
                s[k] = stress[k].0[l];
                d[k] = deps[k].0[l];
            }
            let h = &mut self.history[l][..self.n_state];
            self.model.update_stress(&mut s, h, &d, dt, rho.0[l]);
            for k in 0..6 {
                stress[k].0[l] = s[k];
            }
        }
    }

    /// Each lane's current wave modulus rho c^2 ([`Material::wave_modulus`]), Pa, at the
    /// density `rho`, kg/m^3.
    #[inline]
    pub fn wave_modulus(&self, rho: F) -> F {
        let mut m = F::ZERO;
        for l in 0..LANES {
            m.0[l] = self.model.wave_modulus(rho.0[l], &self.history[l][..self.n_state]);
        }
        m
    }

    /// The sound speed c = sqrt(rho c^2 / rho), m/s, of each lane from the model's current
    /// wave modulus ([`Material::wave_modulus`]) at the density `rho`, kg/m^3.
    #[inline]
    pub fn sound_speed(&self, rho: F) -> F {
        let mut c = F::ZERO;
        for l in 0..LANES {
            let r = rho.0[l];
            let modulus = self.model.wave_modulus(r, &self.history[l][..self.n_state]);
            c.0[l] = (modulus / r).sqrt();
        }
        c
    }

    /// The bulk viscosity's work q eps_v dt / rho, J/kg, added to each lane's state where q is
    /// not zero ([`Material::add_heat`]).
    #[inline]
    pub fn add_heat(&mut self, q: F, ev: F, dt: f64, rho: F) {
        for l in 0..LANES {
            let (ql, r) = (q.0[l], rho.0[l]);
            if ql != 0.0 {
                let h = &mut self.history[l][..self.n_state];
                self.model.add_heat(h, ql * ev.0[l] * dt / r, r);
            }
        }
    }

    /// Each lane's current yield stress ([`Material::yield_stress`]), Pa; `None` for a model
    /// without a yield surface.
    #[inline]
    pub fn yield_stress(&self) -> Option<F> {
        let mut y = F::ZERO;
        for l in 0..LANES {
            y.0[l] = self.model.yield_stress(&self.history[l][..self.n_state])?;
        }
        Some(y)
    }
}

/// The FB viscous hourglass coefficient of each lane, kappa rho c V^(2/3) / 4, kg/s (the
/// scalar kernel's form, [`crate::hourglass::Hourglass::apply`]; a cube root per element,
/// which has no lane instruction).
#[inline]
pub(super) fn viscous_coefficient(kappa: f64, rho: F, c: F, vol: F) -> F {
    let mut visc = F::ZERO;
    for l in 0..LANES {
        visc.0[l] = 0.25 * kappa * rho.0[l] * c.0[l] * libm::cbrt(vol.0[l]).powi(2);
    }
    visc
}
