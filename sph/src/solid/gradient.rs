//! The velocity-gradient pass of the solids, its exact sums, and the corrected gradient.
//!
//! The sums are exact ([`binsum`] two-fold sums on the grids of a [`PassGrids`] of their own:
//! quantity [`gq::GRAD`] for the velocity-gradient terms, [`gq::SHAPE`] for the shape terms), as
//! the fluid passes' (see [`crate::exact`]): every entry's sums are the same bits whatever the
//! order of the pairs, whichever rank computed a pair and however the ghosts' partial sums are
//! merged into their owners.
use super::tensor::{self, inverse, mul, Mat3};
use super::{Solids, CORRECTION_SINGULAR};
use crate::exact::{note, PassGrids, TermMax};
use crate::kernel::SmoothingKernel;
use crate::particles::Particles;
use binsum::{value2, Folds2};
use bytemuck::{Pod, Zeroable};

/// The quantities of the gradient pass's sums, as indices of its [`TermMax`] and
/// [`PassGrids::grid`] (the third grid is unused).
pub mod gq {
    /// Velocity-gradient terms V_b (v_b - v_a)_k (grad_a W)_l, 1/s.
    pub const GRAD: usize = 0;
    /// Shape terms V_b (x_b - x_a)_k (grad_a W)_l (dimensionless).
    pub const SHAPE: usize = 1;
}

/// What the gradient pass added to one entry, as exact sums: `grad` and `shape` row by row
/// (`grad[3 k + l]` is the (k, l) entry). A ghost copy's go to its owner (copies -> owner),
/// who merges them (exact, in any order) and settles them ([`settle_gradients`]). 288 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GradSums {
    /// sum_b V_b (v_b - v_a) (x) grad_a W_ab, 1/s.
    pub grad: [Folds2; 9],
    /// sum_b V_b (x_b - x_a) (x) grad_a W_ab.
    pub shape: [Folds2; 9],
}

impl GradSums {
    /// Merges `o` into these sums (exact).
    #[inline]
    pub fn merge(&mut self, o: &GradSums) {
        for k in 0..9 {
            for f in 0..2 {
                self.grad[k][f] += o.grad[k][f];
                self.shape[k][f] += o.shape[k][f];
            }
        }
    }

    /// The two sums' values as matrices.
    pub fn values(&self) -> (Mat3, Mat3) {
        let m = |s: &[Folds2; 9]| -> Mat3 {
            std::array::from_fn(|k| std::array::from_fn(|l| value2(&s[3 * k + l])))
        };
        (m(&self.grad), m(&self.shape))
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
/// tensor, and a pair listed as (b, a) gives each entry the same bits: both factors of each
/// product change sign). The velocity is `Particles::v`, which between the halves of a step is
/// the half-step velocity v^(n+1/2): the stress increment over the step is then centred (the
/// central difference of PRONTO-3D; Taylor & Flanagan, SAND87-1912). The positions are
/// x^(n+1). Zeroes the sums (`Solids::sums`) of every entry first, adds every term exactly on
/// `g` (quantities [`gq`]) and notes the largest terms in `m`; coincident pairs are skipped.
/// Flops per pair: ~40 for the geometry and the tensors, 2 x 18 x 8 for the exact sums.
pub fn velocity_gradient_pass(
    pairs: &[(u32, u32)],
    p: &Particles,
    s: &mut Solids,
    k: &SmoothingKernel,
    g: &PassGrids,
    m: &mut TermMax,
) {
    s.resize(p.len());
    s.sums.iter_mut().for_each(|e| *e = GradSums::default());
    let (gg, gs) = (g.grid(gq::GRAD), g.grid(gq::SHAPE));
    let (mut mg, mut ms) = (m[gq::GRAD], m[gq::SHAPE]);
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
        // bounds of the entries' terms (a function of the pair: |d_b| <= r)
        let dv_max = dv.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let (bv, bx) = ((gr * r * dv_max).abs(), (gr * r * r).abs());
        let mut add = |e: usize, vol: f64| {
            let sum = &mut s.sums[e];
            for a in 0..3 {
                for b in 0..3 {
                    gg.add(&mut sum.grad[3 * a + b], vol * tv[a][b]);
                    gs.add(&mut sum.shape[3 * a + b], vol * tx[a][b]);
                }
            }
            note(&mut mg, vol * bv);
            note(&mut ms, vol * bx);
        };
        if si {
            add(i, p.m[j] / p.rho[j]);
        }
        if sj {
            add(j, p.m[i] / p.rho[i]);
        }
    }
    m[gq::GRAD] = mg;
    m[gq::SHAPE] = ms;
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
        let (grad, shape) = s.sums[i].values();
        s.grad_sum[i] = grad;
        s.shape_sum[i] = shape;
        match inverse(&shape, CORRECTION_SINGULAR) {
            Some(inv) => {
                s.grad_v[i] = mul(&grad, &inv);
                s.correction[i] = tensor::transpose(&inv);
            }
            None => {
                s.grad_v[i] = grad;
                s.correction[i] = tensor::IDENTITY;
            }
        }
    }
}
