//! Solid particles: SPH particles that carry the Cauchy stress (Libersky & Petschek 1991;
//! Randles & Libersky, CMAME 139 (1996) 375; Gray, Monaghan & Swift, CMAME 190 (2001) 6641).
//!
//! A particle whose material has a [`StressModel`] (`Solids::models[mat]`) is a solid; the
//! others stay fluids (pressure from their EOS, no deviatoric stress) and none of their passes
//! changes. One evaluation of a step with solids (`SolidSim` is the serial sequence):
//!
//! ```text
//! density_pass (continuity, as for fluids)
//! velocity_gradient_pass;  ghosts -> owners (grad_sum, shape_sum); settle_gradients
//! update_stress (owned solids: rotate, then the model with deps = D dt; p = -tr(sigma)/3,
//!                c = sqrt(wave modulus / rho));  update_eos for the fluids
//! owners -> ghosts (rho, p, c, stress)
//! stress_force_pass;  ghosts -> owners (f, de)
//! ```
//!
//! Sums: the gradient and force sums of the solid passes are plain f64 sums in the order of the
//! pairs (NOT yet the exact sums of [`crate::exact`]): in serial they are reproducible, but a
//! different pair order or rank count changes their last bits. Making them exact (one grid per
//! quantity, as the fluid passes) is left to the parallel slice.
mod force;
pub mod sim;
pub mod tensor;

pub use force::{
    stress_force_pass, ArtificialStress, ARTIFICIAL_STRESS_EPSILON, ARTIFICIAL_STRESS_EXPONENT,
};
pub use sim::SolidSim;

use crate::kernel::SmoothingKernel;
use crate::particles::Particles;
use crate::strength::StressModel;
use std::sync::Arc;
use tensor::{from_voigt, inverse, mul, to_voigt, Mat3};

/// Relative size below which the kernel-gradient correction matrix counts as singular
/// (|det| <= this (max entry)^3): then the uncorrected gradient is used (a particle with
/// neighbours in fewer than three independent directions).
pub const CORRECTION_SINGULAR: f64 = 1e-6;

/// The solid state of every entry (owned first, ghosts after, as `Particles`), beside the
/// particles. Communication roles (for the parallel layer): `stress` and `state` are carried
/// when a particle migrates, written to checkpoints and sent to ghosts after `update_stress`;
/// `grad_sum` and `shape_sum` are summed back from ghosts to owners; `grad_v` is the owner's
/// (not carried).
#[derive(Clone, Debug, Default)]
pub struct Solids {
    /// The stress model of each material index (`Particles::mat`); `None`: a fluid.
    pub models: Vec<Option<Arc<dyn StressModel>>>,
    /// Cauchy stress, Voigt xx, yy, zz, xy, yz, zx, Pa, tension positive (zero for fluids).
    pub stress: Vec<[f64; 6]>,
    /// The model's history values, `stride` per entry.
    pub state: Vec<f64>,
    /// History values per entry: the largest `n_state` of the models.
    pub stride: usize,
    /// sum_b V_b (v_b - v_a) (x) grad_a W_ab, 1/s, this pass's sum.
    pub grad_sum: Vec<Mat3>,
    /// sum_b V_b (x_b - x_a) (x) grad_a W_ab (dimensionless; the identity in the continuum).
    pub shape_sum: Vec<Mat3>,
    /// The corrected velocity gradient L = dv/dx (`L[k][l]` = dv_k/dx_l), 1/s (owned).
    pub grad_v: Vec<Mat3>,
    /// The kernel-gradient correction B = shape_sum^-T (the identity for fluids and where
    /// `shape_sum` is singular), set on owners by `settle_gradients`, sent to ghosts: the force
    /// pass uses B grad W (Bonet & Lok 1999).
    pub correction: Vec<Mat3>,
}

impl Solids {
    /// The solid state of the owned entries of `p`: zero stress, each model's initial history.
    pub fn new(models: Vec<Option<Arc<dyn StressModel>>>, p: &Particles) -> Self {
        let stride = models
            .iter()
            .flatten()
            .map(|m| m.n_state())
            .max()
            .unwrap_or(0);
        let mut s = Self {
            models,
            stride,
            ..Self::default()
        };
        s.resize(p.n_owned);
        for i in 0..p.n_owned {
            if let Some(m) = s.model(p.mat[i]) {
                m.init_state(&mut s.state[i * stride..i * stride + m.n_state()]);
            }
        }
        s
    }

    /// The stress model of material `mat`, if it is a solid.
    #[inline]
    pub fn model(&self, mat: u16) -> Option<Arc<dyn StressModel>> {
        self.models.get(mat as usize).cloned().flatten()
    }

    /// Whether material `mat` is a solid.
    #[inline]
    pub fn is_solid(&self, mat: u16) -> bool {
        matches!(self.models.get(mat as usize), Some(Some(_)))
    }

    /// Sizes every per-entry field to `n` entries (new ones zero).
    pub fn resize(&mut self, n: usize) {
        self.stress.resize(n, [0.0; 6]);
        self.state.resize(n * self.stride, 0.0);
        self.grad_sum.resize(n, [[0.0; 3]; 3]);
        self.shape_sum.resize(n, [[0.0; 3]; 3]);
        self.grad_v.resize(n, [[0.0; 3]; 3]);
        self.correction.resize(n, tensor::IDENTITY);
    }

    /// Copies owner `o`'s stress and history to entry `g` (a ghost copy of it).
    pub fn copy_to_ghost(&mut self, g: usize, o: usize) {
        self.stress[g] = self.stress[o];
        self.correction[g] = self.correction[o];
        let k = self.stride;
        self.state.copy_within(o * k..(o + 1) * k, g * k);
    }

    /// Adds ghost `g`'s gradient sums to its owner `o`.
    pub fn fold_ghost(&mut self, g: usize, o: usize) {
        for k in 0..3 {
            for l in 0..3 {
                self.grad_sum[o][k][l] += self.grad_sum[g][k][l];
                self.shape_sum[o][k][l] += self.shape_sum[g][k][l];
            }
        }
    }
}

/// Velocity-gradient pass over the pairs, for every entry (owned or ghost) that is a solid:
///
/// ```text
/// grad_sum_a  += V_b (v_b - v_a) (x) grad_a W_ab      (Libersky & Petschek 1991), 1/s
/// shape_sum_a += V_b (x_b - x_a) (x) grad_a W_ab      (Randles & Libersky 1996, eq. 29)
/// ```
///
/// with V_b = m_b / rho_b, grad_a W_ab = (dW/dr / r) (x_a - x_b), h = (h_a + h_b)/2, and the
/// same for b with a and b swapped (grad_b W_ba = -grad_a W_ab: b gets V_a times the same
/// tensor). The velocity is `Particles::v`, which between the halves of a step is the half-step
/// velocity v^(n+1/2): the stress increment over the step is then centred (the central
/// difference of PRONTO-3D; Taylor & Flanagan, SAND87-1912). The positions are x^(n+1).
/// Zeroes the sums of every entry first; coincident pairs are skipped.
pub fn velocity_gradient_pass(
    pairs: &[(u32, u32)],
    p: &Particles,
    s: &mut Solids,
    k: &SmoothingKernel,
) {
    s.resize(p.len());
    for e in 0..p.len() {
        s.grad_sum[e] = [[0.0; 3]; 3];
        s.shape_sum[e] = [[0.0; 3]; 3];
    }
    for &(i, j) in pairs {
        let (i, j) = (i as usize, j as usize);
        let (si, sj) = (s.is_solid(p.mat[i]), s.is_solid(p.mat[j]));
        if !si && !sj {
            continue;
        }
        let d: [f64; 3] = std::array::from_fn(|c| p.x[i][c] - p.x[j][c]);
        let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if r == 0.0 {
            continue;
        }
        let gr = k.dw_dr(r, 0.5 * (p.h[i] + p.h[j])) / r;
        let dv: [f64; 3] = std::array::from_fn(|c| p.v[i][c] - p.v[j][c]);
        // (v_b - v_a) (x) grad_a W = -(v_a - v_b) (x) gr d; (x_b - x_a) (x) grad_a W = -gr d (x) d
        let tv: Mat3 = std::array::from_fn(|a| std::array::from_fn(|b| -dv[a] * gr * d[b]));
        let tx: Mat3 = std::array::from_fn(|a| std::array::from_fn(|b| -d[a] * gr * d[b]));
        let mut add = |e: usize, vol: f64| {
            for a in 0..3 {
                for b in 0..3 {
                    s.grad_sum[e][a][b] += vol * tv[a][b];
                    s.shape_sum[e][a][b] += vol * tx[a][b];
                }
            }
        };
        if si {
            add(i, p.m[j] / p.rho[j]);
        }
        if sj {
            add(j, p.m[i] / p.rho[i]);
        }
    }
}

/// Sets the corrected velocity gradient of every owned solid from its (merged) sums:
///
/// ```text
/// L_a = grad_sum_a shape_sum_a^-1         (Randles & Libersky 1996, eqs. 29-30), 1/s
/// ```
///
/// For a linear field v = G x, v_b - v_a = G (x_b - x_a), so grad_sum_a = G shape_sum_a and
/// L_a = G exactly, at the free surface too (where the uncorrected sum is short of neighbours).
/// A singular `shape_sum` (see [`CORRECTION_SINGULAR`]) leaves the uncorrected sum. Also sets
/// `correction` = shape_sum^-T: L_kl = sum_b V_b (v_b - v_a)_k (shape_sum^-T grad_a W)_l, so
/// B grad_a W is the corrected kernel gradient.
pub fn settle_gradients(p: &Particles, s: &mut Solids) {
    s.resize(p.len());
    for i in 0..p.n_owned {
        if !s.is_solid(p.mat[i]) {
            continue;
        }
        match inverse(&s.shape_sum[i], CORRECTION_SINGULAR) {
            Some(inv) => {
                s.grad_v[i] = mul(&s.grad_sum[i], &inv);
                s.correction[i] = tensor::transpose(&inv);
            }
            None => {
                s.grad_v[i] = s.grad_sum[i];
                s.correction[i] = tensor::IDENTITY;
            }
        }
    }
}

/// The stress update of every owned solid over a step `dt`, s, from its `grad_v`:
///
/// ```text
/// D = (L + L^T)/2,  W = (L - L^T)/2                         (rate of deformation, spin), 1/s
/// sigma* = sigma + dt (W sigma - sigma W)                   (Jaumann rate: the co-rotational
///                                                            rate is C : D; Gray et al. 2001,
///                                                            eq. 5), Pa
/// sigma^(n+1) = model(sigma*, deps = D dt, dt, rho^(n+1))   (StressModel::update_stress)
/// ```
///
/// then p = -tr(sigma)/3, Pa, and c = sqrt(wave_modulus / rho), m/s, for the stable step and
/// the artificial viscosity (the fluids' p and c are the EOS's: `update_eos`).
pub fn update_stress(p: &mut Particles, s: &mut Solids, dt: f64) {
    for i in 0..p.n_owned {
        let Some(model) = s.model(p.mat[i]) else {
            continue;
        };
        let l = s.grad_v[i];
        let w: Mat3 = std::array::from_fn(|a| std::array::from_fn(|b| 0.5 * (l[a][b] - l[b][a])));
        let sig = from_voigt(&s.stress[i]);
        let (ws, sw) = (mul(&w, &sig), mul(&sig, &w));
        let rate: Mat3 = std::array::from_fn(|a| std::array::from_fn(|b| ws[a][b] - sw[a][b]));
        let rot = to_voigt(&rate);
        let mut stress: [f64; 6] = std::array::from_fn(|c| s.stress[i][c] + dt * rot[c]);
        let d = to_voigt(&l);
        let deps: [f64; 6] = std::array::from_fn(|c| d[c] * dt);
        let k = s.stride;
        let state = &mut s.state[i * k..i * k + model.n_state()];
        model.update_stress(&mut stress, state, &deps, dt, p.rho[i]);
        s.stress[i] = stress;
    }
    solid_pressure(p, s);
}

/// Sets p = -tr(sigma)/3 and c = sqrt(wave_modulus(rho, state) / rho) of every owned solid.
pub fn solid_pressure(p: &mut Particles, s: &Solids) {
    for i in 0..p.n_owned {
        let Some(model) = s.model(p.mat[i]) else {
            continue;
        };
        let t = &s.stress[i];
        p.p[i] = -(t[0] + t[1] + t[2]) / 3.0;
        let k = s.stride;
        let modulus = model.wave_modulus(p.rho[i], &s.state[i * k..i * k + model.n_state()]);
        p.c[i] = (modulus / p.rho[i]).sqrt();
    }
}
