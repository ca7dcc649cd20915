//! Bilinear quadrilateral geometry: shape functions, normals, closest-point projection.
//!
//! A contact face is the bilinear surface through its four corners,
//! `X(xi, eta) = sum_i N_i(xi, eta) X_i`, with `N_i = (1 + xi xi_i)(1 + eta eta_i) / 4` and the
//! corners at `(xi_i, eta_i) = (-1,-1), (1,-1), (1,1), (-1,1)` (the order of [`CORNERS`]). It is the
//! face of the trilinear hexahedron, so a warped face is treated exactly as the element sees it, with
//! no choice of diagonal. The outward normal is `X_xi x X_eta / |X_xi x X_eta|`: corners listed
//! counter-clockwise seen from outside give an outward normal.

use crate::vec3::{add, cross, dot, norm, scale, sub, V3};

/// Parametric coordinates of the four corners, in corner order.
pub const CORNERS: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

/// Newton iterations allowed in [`Quad::closest_point`].
const MAX_NEWTON_ITERATIONS: usize = 50;
/// Parametric step below which the projection has converged (the coordinates are O(1)); Newton
/// converges quadratically, so the step that passes this test leaves an error at round-off.
const NEWTON_STEP_TOL: f64 = 1e-13;
/// Round-off floor of the parametric step, in units of `EPSILON * (coordinate size / face size)`:
/// a small face far from the origin cannot resolve its coordinates better than that.
const NEWTON_NOISE_FACTOR: f64 = 64.0;
/// A step still above the tolerances after the last iteration but below this is accepted (the
/// iteration is stalled by round-off, not diverging).
const NEWTON_ACCEPT_STEP: f64 = 1e-8;
/// Largest parametric step of one Newton iteration (keeps a warped quad's iteration near the face).
const NEWTON_MAX_STEP: f64 = 1.0;
/// A Hessian with `det < HESSIAN_DEFINITE_TOL * trace^2` is not trusted: fall back to Gauss-Newton.
const HESSIAN_DEFINITE_TOL: f64 = 1e-12;

/// Bilinear shape functions at `xi = [xi, eta]`; they sum to one.
#[inline]
pub fn shape(xi: [f64; 2]) -> [f64; 4] {
    let mut n = [0.0; 4];
    for (i, c) in CORNERS.iter().enumerate() {
        n[i] = 0.25 * (1.0 + xi[0] * c[0]) * (1.0 + xi[1] * c[1]);
    }
    n
}

/// Derivatives of the shape functions: `(dN/dxi, dN/deta)`.
#[inline]
pub fn shape_derivatives(xi: [f64; 2]) -> ([f64; 4], [f64; 4]) {
    let mut dxi = [0.0; 4];
    let mut deta = [0.0; 4];
    for (i, c) in CORNERS.iter().enumerate() {
        dxi[i] = 0.25 * c[0] * (1.0 + xi[1] * c[1]);
        deta[i] = 0.25 * (1.0 + xi[0] * c[0]) * c[1];
    }
    (dxi, deta)
}

/// The result of projecting a point on a [`Quad`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Parametric coordinates of the closest point (not clamped to the face).
    pub xi: [f64; 2],
    /// The closest point, `X(xi)`.
    pub point: V3,
    /// Unit outward normal at `xi`.
    pub normal: V3,
    /// `(p - X(xi)) . normal`: positive outside, negative behind.
    pub signed_distance: f64,
}

/// A bilinear quadrilateral given by its corners (counter-clockwise seen from outside).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quad {
    /// Corner coordinates in [`CORNERS`] order.
    pub x: [V3; 4],
}

impl Quad {
    /// `X(xi)`.
    pub fn point(&self, xi: [f64; 2]) -> V3 {
        let n = shape(xi);
        let mut p = [0.0; 3];
        for (i, ni) in n.iter().enumerate() {
            p = add(p, scale(self.x[i], *ni));
        }
        p
    }

    /// Tangents `(X_xi, X_eta)` at `xi`.
    pub fn tangents(&self, xi: [f64; 2]) -> (V3, V3) {
        let (dxi, deta) = shape_derivatives(xi);
        let mut a = [0.0; 3];
        let mut b = [0.0; 3];
        for i in 0..4 {
            a = add(a, scale(self.x[i], dxi[i]));
            b = add(b, scale(self.x[i], deta[i]));
        }
        (a, b)
    }

    /// The mixed derivative `X_xi_eta` (constant on a bilinear face; zero on a parallelogram).
    pub fn twist(&self) -> V3 {
        scale(
            add(sub(self.x[0], self.x[1]), sub(self.x[2], self.x[3])),
            0.25,
        )
    }

    /// Unit outward normal at `xi`, or `None` where the face is degenerate (zero area element).
    pub fn normal(&self, xi: [f64; 2]) -> Option<V3> {
        let (a, b) = self.tangents(xi);
        let c = cross(a, b);
        let len = norm(c);
        let size = norm(a) * norm(b);
        if len.is_nan() || len <= f64::EPSILON * size {
            return None;
        }
        Some(scale(c, 1.0 / len))
    }

    /// Largest diagonal length, the face's size.
    pub fn diameter(&self) -> f64 {
        norm(sub(self.x[2], self.x[0])).max(norm(sub(self.x[3], self.x[1])))
    }

    /// The closest point of the (unbounded) bilinear surface to `p`, by Newton's method on
    /// `min_xi |p - X(xi)|^2 / 2` from the face centre: gradient `-(r . X_xi, r . X_eta)` with
    /// `r = p - X`, Hessian `[[X_xi.X_xi, X_xi.X_eta - r.X_xi_eta], [.., X_eta.X_eta]]`
    /// (`X_xi_xi = X_eta_eta = 0` on a bilinear surface). Where that Hessian is not safely positive
    /// definite (a strongly warped face far from `p`) the Gauss-Newton matrix (without the `r` term)
    /// is used. Returns `None` if the face is degenerate at the result or the iteration does not
    /// converge. Deterministic: it depends only on the corners and `p`.
    pub fn closest_point(&self, p: V3) -> Option<Projection> {
        let twist = self.twist();
        let coordinate_size = self
            .x
            .iter()
            .chain(std::iter::once(&p))
            .flat_map(|v| v.iter())
            .fold(0.0, |a: f64, c| a.max(c.abs()));
        let size = self.diameter();
        let step_tol =
            NEWTON_STEP_TOL.max(NEWTON_NOISE_FACTOR * f64::EPSILON * coordinate_size / size);
        let mut xi = [0.0_f64, 0.0_f64];
        let mut converged = false;
        let mut last_step = f64::INFINITY;
        for _ in 0..MAX_NEWTON_ITERATIONS {
            let r = sub(p, self.point(xi));
            let (a, b) = self.tangents(xi);
            let g = [-dot(r, a), -dot(r, b)];
            let haa = dot(a, a);
            let hbb = dot(b, b);
            let hab_gn = dot(a, b);
            let hab = hab_gn - dot(r, twist);
            let trace = haa + hbb;
            let det = haa * hbb - hab * hab;
            let det_gn = haa * hbb - hab_gn * hab_gn;
            let (h12, det) = if det > HESSIAN_DEFINITE_TOL * trace * trace {
                (hab, det)
            } else if det_gn > HESSIAN_DEFINITE_TOL * trace * trace {
                (hab_gn, det_gn)
            } else {
                return None;
            };
            // Solve H d = -g.
            let mut d = [
                -(hbb * g[0] - h12 * g[1]) / det,
                -(-h12 * g[0] + haa * g[1]) / det,
            ];
            let step = d[0].abs().max(d[1].abs());
            if step > NEWTON_MAX_STEP {
                d = [d[0] * NEWTON_MAX_STEP / step, d[1] * NEWTON_MAX_STEP / step];
            }
            xi = [xi[0] + d[0], xi[1] + d[1]];
            last_step = step;
            if step <= step_tol * (1.0 + xi[0].abs().max(xi[1].abs())) {
                converged = true;
                break;
            }
        }
        if !converged && (last_step.is_nan() || last_step > NEWTON_ACCEPT_STEP) {
            return None;
        }
        let point = self.point(xi);
        let normal = self.normal(xi)?;
        Some(Projection {
            xi,
            point,
            normal,
            signed_distance: dot(sub(p, point), normal),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Partition of unity and corner interpolation (exact: the values are dyadic).
    #[test]
    fn shape_functions() {
        for c in CORNERS {
            let n = shape(c);
            assert_eq!(n.iter().sum::<f64>(), 1.0);
            assert_eq!(n.iter().filter(|&&v| v == 1.0).count(), 1);
        }
        let n = shape([0.3, -0.7]);
        assert!((n.iter().sum::<f64>() - 1.0).abs() <= 2.0 * f64::EPSILON);
    }

    /// On a flat unit square in z = 0 (corners counter-clockwise from above, normal +z) the closest
    /// point is the orthogonal projection: xi = 2x - 1, eta = 2y - 1, distance z (analytic).
    #[test]
    fn projection_on_a_flat_square() {
        let q = Quad {
            x: [
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
        };
        let p = q.closest_point([0.2, 0.9, -0.3]).unwrap();
        assert!((p.xi[0] + 0.6).abs() < 1e-14 && (p.xi[1] - 0.8).abs() < 1e-14);
        assert!((p.signed_distance + 0.3).abs() < 1e-15);
        assert_eq!(p.normal, [0.0, 0.0, 1.0]);
        assert!((q.diameter() - 2f64.sqrt()).abs() < 1e-15);
    }

    /// On a warped face the result is a stationary point: the residual is normal to both tangents.
    #[test]
    fn projection_on_a_warped_face_is_stationary() {
        let q = Quad {
            x: [
                [0.0, 0.0, 0.1],
                [1.2, 0.1, -0.1],
                [1.0, 1.1, 0.15],
                [-0.1, 0.9, -0.12],
            ],
        };
        let p = [0.7, 0.3, -0.4];
        let pr = q.closest_point(p).unwrap();
        let (a, b) = q.tangents(pr.xi);
        let r = sub(p, pr.point);
        assert!(dot(r, a).abs() < 1e-14 && dot(r, b).abs() < 1e-14);
        assert!((pr.signed_distance.abs() - norm(r)).abs() < 1e-14);
    }
}
