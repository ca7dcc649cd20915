//! Smoothing kernels in 3D with support radius 2h, written W(r, h) = sigma / h^3 f(s), s = r/h.
//! A pair uses h_ab = (h_a + h_b)/2 (the LIGGGHTS convention), so its support 2 h_ab = h_a + h_b
//! is exactly the distance at which the two particles' spheres (radius h) touch.
use crate::params::Profile;
use crate::passes::pos_part;
use std::f64::consts::PI;

/// Cubic spline: sigma = 1/(4 pi) with f = (2-s)^3 - 4(1-s)^3 on [0,1), (2-s)^3 on [1,2)
/// (Monaghan & Lattanzio 1985; equal to the usual 1/(pi h^3) (1 - 3/2 s^2 + 3/4 s^3)).
pub const CUBIC_SIGMA: f64 = 1.0 / (4.0 * PI);
/// LIGGGHTS 3.8.0's cubic-spline constant: 1/(4 pi) truncated to 0.079577.
pub const CUBIC_SIGMA_LIGGGHTS: f64 = 0.079577;
/// Wendland C2 in 3D with support 2h: sigma = 21/(16 pi), f = (1 - s/2)^4 (2s + 1)
/// (Wendland 1995; Dehnen & Aly 2012 for the 2h scaling).
pub const WENDLAND_SIGMA: f64 = 21.0 / (16.0 * PI);
/// LIGGGHTS 3.8.0's Wendland constant in W: 21/(16 pi) rounded to 0.417781726.
pub const WENDLAND_SIGMA_LIGGGHTS: f64 = 0.417781726;
/// LIGGGHTS 3.8.0's Wendland constant in dW/dr: 0.4177817255, a different rounding (found by
/// fitting its forces: the ratio of its pair forces to ours with 0.417781726 is
/// 0.99999999880320, i.e. this constant to 1e-15; with it forces agree to 1e-14).
pub const WENDLAND_GRAD_SIGMA_LIGGGHTS: f64 = 0.4177817255;

/// Kernel shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Kernel {
    /// M4 cubic B-spline.
    #[default]
    CubicSpline,
    /// Wendland C2.
    Wendland,
}

impl Kernel {
    /// The normalisation sigma used by `profile` (exact in `Standard`, LIGGGHTS's truncated
    /// constants in `Liggghts`).
    pub fn sigma(self, profile: Profile) -> f64 {
        match (self, profile) {
            (Kernel::CubicSpline, Profile::Standard) => CUBIC_SIGMA,
            (Kernel::CubicSpline, Profile::Liggghts) => CUBIC_SIGMA_LIGGGHTS,
            (Kernel::Wendland, Profile::Standard) => WENDLAND_SIGMA,
            (Kernel::Wendland, Profile::Liggghts) => WENDLAND_SIGMA_LIGGGHTS,
        }
    }

    /// This shape with the normalisation of `profile`.
    pub fn with_profile(self, profile: Profile) -> SmoothingKernel {
        SmoothingKernel {
            kind: self,
            sigma: self.sigma(profile),
            grad_sigma: self.grad_sigma(profile),
        }
    }

    /// The normalisation used in dW/dr by `profile`: `sigma`, except LIGGGHTS's Wendland
    /// gradient, which uses a differently rounded constant.
    pub fn grad_sigma(self, profile: Profile) -> f64 {
        match (self, profile) {
            (Kernel::Wendland, Profile::Liggghts) => WENDLAND_GRAD_SIGMA_LIGGGHTS,
            _ => self.sigma(profile),
        }
    }

    /// W(r, h) with the exact (standard) normalisation, 1/m^3.
    pub fn w(self, r: f64, h: f64) -> f64 {
        self.with_profile(Profile::Standard).w(r, h)
    }

    /// dW/dr (r, h) with the exact (standard) normalisation, 1/m^4.
    pub fn dw_dr(self, r: f64, h: f64) -> f64 {
        self.with_profile(Profile::Standard).dw_dr(r, h)
    }

    /// The dimensionless shape f(s) (zero for s >= 2). Each piece is written with clamped
    /// factors, max(2 - s, 0) and max(1 - s, 0), so that the sum of the pieces is the piecewise
    /// form without a branch (a zero factor adds exactly nothing), the pair loops' kernel
    /// costing no mispredicted jump where s falls on either side of 1 at random.
    #[inline(always)]
    pub(crate) fn shape(self, s: f64) -> f64 {
        match self {
            Kernel::CubicSpline => {
                let a = pos_part(2.0 - s);
                let b = pos_part(1.0 - s);
                a * a * a - 4.0 * b * b * b
            }
            Kernel::Wendland => {
                let a = pos_part(1.0 - 0.5 * s);
                let a2 = a * a;
                a2 * a2 * (2.0 * s + 1.0)
            }
        }
    }

    /// df/ds (zero for s >= 2), branch-free as `shape`.
    #[inline(always)]
    pub(crate) fn shape_derivative(self, s: f64) -> f64 {
        match self {
            // d/ds [(2-s)^3 - 4(1-s)^3] = -3(2-s)^2 + 12(1-s)^2
            Kernel::CubicSpline => {
                let a = pos_part(2.0 - s);
                let b = pos_part(1.0 - s);
                -3.0 * a * a + 12.0 * b * b
            }
            // d/ds [(1-s/2)^4 (2s+1)] = -5 s (1-s/2)^3
            Kernel::Wendland => {
                let a = pos_part(1.0 - 0.5 * s);
                -5.0 * s * a * a * a
            }
        }
    }
}

/// A kernel shape with its normalisation constant: what the passes evaluate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmoothingKernel {
    /// Shape.
    pub kind: Kernel,
    /// sigma in W = sigma / h^3 f(r/h).
    pub sigma: f64,
    /// sigma in dW/dr = sigma / h^4 f'(r/h) (equal to `sigma` but in LIGGGHTS's Wendland).
    pub grad_sigma: f64,
}

impl SmoothingKernel {
    /// W(r, h) = sigma/h^3 f(r/h), 1/m^3; zero for r >= 2h.
    #[inline]
    pub fn w(&self, r: f64, h: f64) -> f64 {
        let s = r / h;
        self.sigma / (h * h * h) * self.kind.shape(s)
    }

    /// dW/dr = sigma/h^4 f'(r/h), 1/m^4; zero for r >= 2h.
    #[inline]
    pub fn dw_dr(&self, r: f64, h: f64) -> f64 {
        let s = r / h;
        self.grad_sigma / (h * h * h * h) * self.kind.shape_derivative(s)
    }

    /// The support radius 2h.
    #[inline]
    pub fn support(h: f64) -> f64 {
        2.0 * h
    }

    /// The kernel at one smoothing length, its h-dependent factors computed once (1/h,
    /// sigma/h^3, grad_sigma/h^4), so that a pass over many pairs of equal h divides once per
    /// h rather than twice per evaluation. Agrees with `w`/`dw_dr` to round-off (r/h is taken
    /// as r x (1/h)).
    #[inline]
    pub fn at(&self, h: f64) -> ScaledKernel {
        let inv_h = 1.0 / h;
        let inv_h3 = inv_h * inv_h * inv_h;
        ScaledKernel {
            kind: self.kind,
            h,
            inv_h,
            w_norm: self.sigma * inv_h3,
            dw_norm: self.grad_sigma * inv_h3 * inv_h,
        }
    }
}

/// A `SmoothingKernel` at a fixed h (see `SmoothingKernel::at`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScaledKernel {
    kind: Kernel,
    /// The smoothing length it was made for, m.
    pub h: f64,
    inv_h: f64,
    w_norm: f64,
    dw_norm: f64,
}

impl ScaledKernel {
    /// 1/h, sigma/h^3 and grad_sigma/h^4: W = sigma/h^3 f(r/h), dW/dr = grad_sigma/h^4 f'(r/h)
    /// with r/h taken as r x (1/h), for a caller that knows the shape at compile time.
    #[inline(always)]
    pub(crate) fn factors(&self) -> (f64, f64, f64) {
        (self.inv_h, self.w_norm, self.dw_norm)
    }

    /// W(r, h), 1/m^3.
    #[inline(always)]
    pub fn w(&self, r: f64) -> f64 {
        self.w_norm * self.kind.shape(r * self.inv_h)
    }

    /// dW/dr (r, h), 1/m^4.
    #[inline(always)]
    pub fn dw_dr(&self, r: f64) -> f64 {
        self.dw_norm * self.kind.shape_derivative(r * self.inv_h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 4 pi int_0^{2h} r^2 W dr by composite Simpson on each polynomial piece (the integrand is a
    /// polynomial of degree <= 7 on each piece, so 2,000 intervals leave an error far below 1e-10).
    fn integral(k: &SmoothingKernel, h: f64) -> f64 {
        let n = 2000;
        let mut total = 0.0;
        for (lo, hi) in [(0.0, h), (h, 2.0 * h)] {
            let dr = (hi - lo) / n as f64;
            let f = |r: f64| 4.0 * PI * r * r * k.w(r, h);
            let mut s = f(lo) + f(hi);
            for i in 1..n {
                let r = lo + i as f64 * dr;
                s += if i % 2 == 1 { 4.0 } else { 2.0 } * f(r);
            }
            total += s * dr / 3.0;
        }
        total
    }

    #[test]
    fn normalisation_is_one() {
        // Reference: a normalised kernel integrates to 1 over its support (exact constant).
        for kind in [Kernel::CubicSpline, Kernel::Wendland] {
            for h in [0.013, 1.0, 7.5] {
                let k = kind.with_profile(Profile::Standard);
                let i = integral(&k, h);
                assert!(
                    (i - 1.0).abs() < 1e-6,
                    "{kind:?} h {h}: integral {i}, tol 1e-6"
                );
            }
        }
        // The truncated LIGGGHTS constants integrate to 0.079577 * 4 pi = 0.99999407 and
        // 0.417781726 * 16 pi / 21 = 1.0000000010: within 1e-5 of 1, not 1e-6.
        let i = integral(&Kernel::CubicSpline.with_profile(Profile::Liggghts), 1.0);
        assert!((i - CUBIC_SIGMA_LIGGGHTS * 4.0 * PI).abs() < 1e-9);
        assert!((i - 1.0).abs() < 1e-5);
    }

    #[test]
    fn derivative_matches_finite_difference() {
        // Reference: central difference (W(r+d) - W(r-d))/(2d), error O(d^2 W''') ~ 1e-10 at d
        // = 1e-6 h; compared away from the spline knots s = 1, 2 where W''' jumps.
        for kind in [Kernel::CubicSpline, Kernel::Wendland] {
            let h = 0.37;
            let k = kind.with_profile(Profile::Standard);
            let scale = k.dw_dr(0.8 * h, h).abs();
            for i in 0..200 {
                let s = 0.005 + i as f64 * 0.01;
                if (s - 1.0).abs() < 1e-3 {
                    continue;
                }
                let r = s * h;
                let d = 1e-6 * h;
                let fd = (k.w(r + d, h) - k.w(r - d, h)) / (2.0 * d);
                let an = k.dw_dr(r, h);
                assert!(
                    (fd - an).abs() <= 1e-7 * scale,
                    "{kind:?} s {s}: dW/dr {an} vs finite difference {fd} (tol 1e-7 x {scale})"
                );
            }
            assert_eq!(k.w(2.0 * h, h), 0.0);
            assert_eq!(k.dw_dr(2.0 * h, h), 0.0);
            assert_eq!(k.dw_dr(0.0, h), 0.0);
        }
    }

    #[test]
    fn cubic_equals_textbook_form() {
        // Reference: 1/(pi h^3)(1 - 3/2 s^2 + 3/4 s^3) on [0,1), 1/(4 pi h^3)(2-s)^3 on [1,2).
        let h = 0.5;
        for i in 0..40 {
            let s = i as f64 * 0.05;
            let textbook = if s < 1.0 {
                (1.0 - 1.5 * s * s + 0.75 * s * s * s) / (PI * h * h * h)
            } else {
                (2.0 - s).powi(3) / (4.0 * PI * h * h * h)
            };
            let w = Kernel::CubicSpline.w(s * h, h);
            assert!((w - textbook).abs() <= 1e-14 * textbook.abs().max(1.0));
        }
    }
}
