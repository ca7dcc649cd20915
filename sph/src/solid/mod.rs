//! Solid particles: SPH particles that carry the Cauchy stress (Libersky & Petschek 1991;
//! Randles & Libersky, CMAME 139 (1996) 375; Gray, Monaghan & Swift, CMAME 190 (2001) 6641).
//!
//! A particle whose material has a [`StressModel`] (`Solids::models[mat]`) is a solid; the
//! others stay fluids (pressure from their EOS, no deviatoric stress) and none of their passes
//! changes. One evaluation of a step with solids (`SolidSim` is the serial sequence):
//!
//! ```text
//! update_eos (owned; the fluids' p and c)
//! velocity_gradient_pass (and every entry's continuity density rate);
//!                          ghosts -> owners (GradSums); settle_gradients (drho, L, B, the
//!                          surface flags)
//! owners -> ghosts (the flags); quadratic_pass (pairs with a flagged end);
//!                          ghosts -> owners (QuadSums); settle_quadratic (the surface
//!                          particles' L, B and C_quad: [`quadratic`])
//! update_stress (owned solids: rotate, then the model with deps = D dt; p = -tr(sigma)/3,
//!                c = sqrt(wave modulus / rho))
//! owners -> ghosts (SolidGhost: rho, p, c, stress, B, C_quad)
//! stress_force_pass (over the same pairs: r and dW/dr / r kept from the gradient pass,
//!                      `Solids::pair_geom`);  ghosts -> owners (PairSums: f, de); settle_forces
//! ```
//!
//! and after `second_half` (which runs the EOS on every owned particle) `solid_pressure`.
//!
//! Sums: the gradient and force sums of the solid passes are exact ([`crate::exact`], binned
//! sums as the fluid passes'; the gradient pass on a [`crate::exact::PassGrids`] of its own,
//! quantities [`gq`]), so every particle's gradient, force and energy rate are the same bits
//! whatever the order of the pairs and however they are shared between ranks; each pass is run
//! under [`crate::exact::exact_pass`]. The pair loops and the artificial stress's
//! eigen-decompositions run in the widest build the CPUs share ([`build`]: the same operations,
//! the same bits, in fewer vector instructions).
pub mod build;
mod force;
mod gradient;
pub mod quadratic;
pub mod sim;
pub mod tensor;

pub use force::{
    stress_force_pass, ArtificialStress, ARTIFICIAL_STRESS_EPSILON, ARTIFICIAL_STRESS_EXPONENT,
};
pub use gradient::{gq, settle_gradients, velocity_gradient_pass, GradSums, PairGeom};
pub use quadratic::{
    fold_quad_ghost, quad_sums_of, quadratic_pass, settle_quadratic, QuadSums, SURFACE_SHAPE_TOL,
};
pub use sim::SolidSim;

use crate::particles::Particles;
use crate::strength::StressModel;
use bytemuck::{Pod, Zeroable};
use std::sync::Arc;
use tensor::{from_voigt, mul, to_voigt, Mat3};

/// The most history values a solid particle carries when it migrates ([`SolidRecord`]): the
/// elements' laws hold at most two (Johnson-Cook with thermal softening: plastic strain and
/// temperature).
pub const MAX_STATE: usize = 4;

/// A solid entry's state packed for migration and checkpoints (owner -> new owner): its stress
/// and its history values (the first `Solids::stride` of `state`). Plain old data, 80 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SolidRecord {
    /// Cauchy stress, Voigt, Pa.
    pub stress: [f64; 6],
    /// History values (zero past the stride).
    pub state: [f64; MAX_STATE],
}

/// What a ghost needs of its owner for the stress force pass, sent owner -> copies after the
/// stress update: density, pressure and sound speed (as `EosState`), stress, the
/// kernel-gradient correction B (row by row) and C_quad (zero but at a surface,
/// [`quadratic`]). Plain old data, 288 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SolidGhost {
    /// Density, kg/m^3.
    pub rho: f64,
    /// Pressure, Pa.
    pub p: f64,
    /// Sound speed, m/s.
    pub c: f64,
    /// Cauchy stress, Voigt, Pa.
    pub stress: [f64; 6],
    /// B, `b[3 k + l]` = B_kl.
    pub b: [f64; 9],
    /// C_quad, `q[6 k + m]`, 1/m (`Solids::quad`).
    pub q: [f64; 18],
}

/// Relative size below which the kernel-gradient correction matrix counts as singular
/// (|det| <= this (max entry)^3): then the uncorrected gradient is used (a particle with
/// neighbours in fewer than three independent directions).
pub const CORRECTION_SINGULAR: f64 = 1e-6;

/// The largest entry of the kernel-gradient correction B = shape_sum^-T that a moving particle
/// uses; past it the uncorrected gradient is. In a lattice B stays near the identity (about 2 at a corner,
/// where shape_sum's eigenvalues are about 1/2); a particle with a few partners, nearly in a
/// plane or a line (a failed element's particle among a handful of others), has a
/// near-singular shape_sum whose inverse amplifies its velocity gradient and its forces
/// a hundredfold (measured: entries 100-400 with 4-7 partners, the stress changing sign from
/// step to step and the particles' internal energy growing without bound). Fixed particles
/// keep theirs: the outer layers of a clamp of fixed particles have entries past 1,000 (the
/// oscillating plate's), part of the clamp's stiffness, and they never move.
pub const CORRECTION_MAX: f64 = 10.0;

/// The solid state of every entry (owned first, ghosts after, as `Particles`), beside the
/// particles. Communication roles (for the parallel layer): `stress` and `state` are carried
/// when a particle migrates and written to checkpoints ([`SolidRecord`]); `stress` and
/// `correction` (with rho, p, c) are sent to ghosts after `update_stress` ([`SolidGhost`]);
/// `sums` are summed back from ghosts to owners ([`GradSums`]); `grad_sum`, `shape_sum` and
/// `grad_v` are the owner's (not carried).
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
    /// The gradient pass's exact sums (every entry; ghosts' go to their owners).
    pub sums: Vec<GradSums>,
    /// sum_b V_b (v_b - v_a) (x) grad_a W_ab, 1/s, this pass's sum (owned, settled).
    pub grad_sum: Vec<Mat3>,
    /// sum_b V_b (x_b - x_a) (x) grad_a W_ab (dimensionless; the identity in the continuum).
    pub shape_sum: Vec<Mat3>,
    /// The corrected velocity gradient L = dv/dx (`L[k][l]` = dv_k/dx_l), 1/s (owned).
    pub grad_v: Vec<Mat3>,
    /// The kernel-gradient correction B = shape_sum^-T (the identity for fluids and where
    /// `shape_sum` is singular), set on owners by `settle_gradients`, sent to ghosts: the force
    /// pass uses B grad W (Bonet & Lok 1999).
    pub correction: Vec<Mat3>,
    /// The geometry of each pair of the last gradient pass, in its order (not carried): the
    /// force pass over the same pairs reads it ([`PairGeom`]).
    pub pair_geom: Vec<PairGeom>,
    /// The build of the pair loops ([`build::Build`]; every build gives the same bits).
    pub build: build::Build,
    /// Whether an entry's gradient is the quadratic fit's ([`quadratic`]): set on owners by
    /// `settle_gradients`, sent to ghosts before the quadratic pass (not carried).
    pub quad_flag: Vec<bool>,
    /// Each entry's index into `quad_sums` (`u32::MAX`: not flagged).
    pub quad_slot: Vec<u32>,
    /// The quadratic pass's exact sums, one per flagged entry (ghosts' go to their owners).
    pub quad_sums: Vec<quadratic::QuadSums>,
    /// C_quad of each entry (rows of A^-1 past the linear block, 1/m, `q[6 k + m]`; zero but
    /// where the quadratic fit settled), set on owners, sent to ghosts with the stress.
    pub quad: Vec<[f64; 18]>,
    /// The share of the quadratic fit each owned entry's gradient took (0: the linear
    /// correction alone; 1: the fit whole; [`quadratic::surface_blend`] times
    /// [`quadratic::amplification_blend`]), as of the last evaluation (not carried).
    pub quad_share: Vec<f64>,
    /// The pair passes' per-entry work space, kept from evaluation to evaluation (not state).
    buffers: PassBuffers,
}

/// What the pair passes gather of every entry and the force pass's sums, rebuilt by every
/// pass: kept between evaluations so that each step reuses the memory rather than allocating
/// and faulting in a few hundred bytes per entry again. No content outlives its pass, so a
/// clone starts empty.
#[derive(Default)]
struct PassBuffers {
    grad_slots: Vec<gradient::Slot>,
    quad_slots: Vec<quadratic::QSlot>,
    force_slots: Vec<force::Slot>,
    /// The artificial stress R of every entry.
    art: Vec<Mat3>,
    force_sums: Vec<crate::passes::Sums>,
    partners: Vec<u32>,
}

impl Clone for PassBuffers {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl std::fmt::Debug for PassBuffers {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("PassBuffers")
    }
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
            build: build::Build::widest(),
            ..Self::default()
        };
        assert!(
            stride <= MAX_STATE,
            "a stress model holds {stride} history values, more than a particle carries ({MAX_STATE})"
        );
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

    /// The stress model of material `mat`, if it is a solid, borrowed (no reference count
    /// raised and dropped per particle, as [`Solids::model`]'s clone does).
    #[inline]
    pub fn model_ref(&self, mat: u16) -> Option<&dyn StressModel> {
        self.models.get(mat as usize)?.as_deref()
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
        self.sums.resize(n, GradSums::default());
        self.grad_sum.resize(n, [[0.0; 3]; 3]);
        self.shape_sum.resize(n, [[0.0; 3]; 3]);
        self.grad_v.resize(n, [[0.0; 3]; 3]);
        self.correction.resize(n, tensor::IDENTITY);
        self.quad_flag.resize(n, false);
        self.quad.resize(n, [0.0; 18]);
        self.quad_share.resize(n, 0.0);
    }

    /// Copies owner `o`'s ghost state to entry `g` (a ghost copy of it; serial images).
    pub fn copy_to_ghost(&mut self, p: &mut Particles, g: usize, o: usize) {
        let st = self.ghost_state(p, o);
        self.set_ghost_state(p, g, &st);
    }

    /// Adds ghost `g`'s gradient sums to its owner `o` (exact).
    pub fn fold_ghost(&mut self, g: usize, o: usize) {
        let s = self.sums[g];
        self.sums[o].merge(&s);
    }

    /// What ghosts of owned entry `i` need for the force pass.
    pub fn ghost_state(&self, p: &Particles, i: usize) -> SolidGhost {
        let b = &self.correction[i];
        SolidGhost {
            rho: p.rho[i],
            p: p.p[i],
            c: p.c[i],
            stress: self.stress[i],
            b: std::array::from_fn(|k| b[k / 3][k % 3]),
            q: self.quad[i],
        }
    }

    /// Sets (ghost) entry `i` from its owner's [`SolidGhost`] (sizing the fields to `p`).
    pub fn set_ghost_state(&mut self, p: &mut Particles, i: usize, g: &SolidGhost) {
        self.resize(p.len());
        p.rho[i] = g.rho;
        p.p[i] = g.p;
        p.c[i] = g.c;
        self.stress[i] = g.stress;
        self.correction[i] = std::array::from_fn(|k| std::array::from_fn(|l| g.b[3 * k + l]));
        self.quad[i] = g.q;
    }

    /// Owned entry `i` packed for migration or a checkpoint.
    pub fn record(&self, i: usize) -> SolidRecord {
        let k = self.stride;
        let mut r = SolidRecord {
            stress: self.stress[i],
            ..SolidRecord::default()
        };
        r.state[..k].copy_from_slice(&self.state[i * k..(i + 1) * k]);
        r
    }

    /// Keeps no entry (the models stay): owned entries are then pushed again
    /// ([`Solids::push_owned`]), in the order of the particles'.
    pub fn clear(&mut self) {
        let (models, stride, build) = (std::mem::take(&mut self.models), self.stride, self.build);
        let buffers = std::mem::take(&mut self.buffers);
        *self = Self {
            models,
            stride,
            build,
            buffers,
            ..Self::default()
        };
    }

    /// Appends an entry from a record (after every entry before it; no ghosts).
    pub fn push_owned(&mut self, r: &SolidRecord) {
        let n = self.stress.len();
        self.resize(n + 1);
        self.stress[n] = r.stress;
        let k = self.stride;
        self.state[n * k..(n + 1) * k].copy_from_slice(&r.state[..k]);
    }

    /// Drops the entries from `n` on (the ghosts, with `n` = the owned count).
    pub fn truncate(&mut self, n: usize) {
        self.stress.truncate(n);
        self.state.truncate(n * self.stride);
        self.sums.truncate(n);
        self.grad_sum.truncate(n);
        self.shape_sum.truncate(n);
        self.grad_v.truncate(n);
        self.correction.truncate(n);
        self.quad_flag.truncate(n);
        self.quad.truncate(n);
        self.quad_share.truncate(n);
    }

    /// The temperature of entry `i`, K, where its law keeps one (`None` for a fluid and for
    /// laws without thermal softening).
    pub fn temperature(&self, mat: u16, i: usize) -> Option<f64> {
        let m = self.model_ref(mat)?;
        let k = self.stride;
        m.temperature(&self.state[i * k..i * k + m.n_state()])
    }

    /// Whether entry `i` has failed (its model's [`StressModel::failed`]; false for a fluid).
    pub fn failed(&self, mat: u16, i: usize) -> bool {
        self.model_ref(mat).is_some_and(|m| {
            let k = self.stride;
            m.failed(&self.state[i * k..i * k + m.n_state()])
        })
    }

    /// The equivalent plastic strain of entry `i` (0 for a fluid).
    pub fn plastic_strain(&self, mat: u16, i: usize) -> f64 {
        match self.model_ref(mat) {
            Some(m) => {
                let k = self.stride;
                m.plastic_strain(&self.state[i * k..i * k + m.n_state()])
            }
            None => 0.0,
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
    let Solids {
        models,
        stress: stresses,
        state: states,
        grad_v,
        stride,
        ..
    } = s;
    for i in 0..p.n_owned {
        let Some(model) = models.get(p.mat[i] as usize).and_then(|m| m.as_deref()) else {
            continue;
        };
        let l = grad_v[i];
        let w: Mat3 = std::array::from_fn(|a| std::array::from_fn(|b| 0.5 * (l[a][b] - l[b][a])));
        let sig = from_voigt(&stresses[i]);
        let (ws, sw) = (mul(&w, &sig), mul(&sig, &w));
        let rate: Mat3 = std::array::from_fn(|a| std::array::from_fn(|b| ws[a][b] - sw[a][b]));
        let rot = to_voigt(&rate);
        let mut stress: [f64; 6] = std::array::from_fn(|c| stresses[i][c] + dt * rot[c]);
        let d = to_voigt(&l);
        let deps: [f64; 6] = std::array::from_fn(|c| d[c] * dt);
        let k = *stride;
        let state = &mut states[i * k..i * k + model.n_state()];
        model.update_stress(&mut stress, state, &deps, dt, p.rho[i]);
        stresses[i] = stress;
    }
    solid_pressure(p, s);
}

/// Sets p = -tr(sigma)/3 and c = sqrt(wave_modulus(rho, state) / rho) of every owned solid,
/// its density first raised to the model's floor where it fell below
/// ([`StressModel::density_floor`]: a failed particle's stays at its material's).
pub fn solid_pressure(p: &mut Particles, s: &Solids) {
    for i in 0..p.n_owned {
        let Some(model) = s.model_ref(p.mat[i]) else {
            continue;
        };
        let t = &s.stress[i];
        p.p[i] = -(t[0] + t[1] + t[2]) / 3.0;
        let k = s.stride;
        let state = &s.state[i * k..i * k + model.n_state()];
        p.rho[i] = p.rho[i].max(model.density_floor(state));
        let modulus = model.wave_modulus(p.rho[i], state);
        p.c[i] = (modulus / p.rho[i]).sqrt();
    }
}
