//! A rigid wall: an infinite plane that no contact node passes (`[[rigid_wall]]`,
//! docs/scene.md), the same kinematic push-back as a node-face contact against an immovable
//! face, in closed form.
//!
//! The wall is infinitely massive: it takes the impulse it gives without moving (its motion is
//! prescribed, a translation at a constant velocity `W`). Its plane at time `t` is the set of
//! `x` with `(x - p - W t) . n = 0`; the bodies are on the side `n` points to.
//!
//! After the drift of central differences, `x(n+1) = x(n) + dt v(n+1/2)`, a node behind the
//! plane, `s1 = (x(n+1) - p - W t(n+1)) . n < 0`, takes the velocity change (m/s)
//!
//! ```text
//! du   = -s1 / dt                                   normal, along n (> 0)
//! w    = v(n+1/2) + du n - W,  w_t = w - (w . n) n  the sliding velocity left
//! dv_t = -w_t min(1, mu du / |w_t|)                 Coulomb: |m dv_t| <= mu |m du|
//! dv   = du n + dv_t
//! ```
//!
//! and the position `dv dt`: the corrected half-step velocity is the one that carries the node
//! from its start position onto the plane over the step (Taylor & Flanagan's kinematic contact,
//! PRONTO's push-back, for a face of infinite mass), so the node ends the step on the plane and
//! its displacement and velocity stay consistent (the step's impulse is `m dv`, exactly). A node
//! that started the step on the plane (`s0 = 0`) thereby ends with its normal velocity relative
//! to the wall zero (perfectly inelastic); one that started ahead of it (`s0 > 0`) with the
//! approach `-s0/dt` that lands it there, less than its approach before (`|du| <= -(v - W) . n`),
//! so a wall at rest never adds kinetic energy; friction only slows the sliding. A node that
//! started behind the plane (a scene that places a body across a wall) is put back on it in one
//! step, at the speed depth/dt: what that gives is booked like every correction (the caller
//! counts `m dv . (v + dv/2)` in `contact_energy`).

/// An infinite plane that no node passes, moving at a constant velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wall {
    /// A point of the plane at t = 0, m.
    pub point: [f64; 3],
    /// The unit normal, towards the bodies.
    pub normal: [f64; 3],
    /// The wall's velocity (a translation), m/s.
    pub velocity: [f64; 3],
    /// Coulomb's coefficient (static and kinetic), >= 0.
    pub friction: f64,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl Wall {
    /// The signed distance of `x` from the plane at time `t` (positive on the bodies' side), m.
    pub fn distance(&self, x: [f64; 3], t: f64) -> f64 {
        let p: [f64; 3] = std::array::from_fn(|c| x[c] - (self.point[c] + self.velocity[c] * t));
        dot(p, self.normal)
    }

    /// The velocity change (m/s) that puts a node at `x` (after the drift to time `t`) with
    /// half-step velocity `v` back onto the plane over the step `dt` (module doc); `None` when
    /// the node is not behind the plane.
    pub fn correction(&self, x: [f64; 3], v: [f64; 3], t: f64, dt: f64) -> Option<[f64; 3]> {
        let s1 = self.distance(x, t);
        if s1 >= 0.0 {
            return None;
        }
        let n = self.normal;
        let du = -s1 / dt;
        let w: [f64; 3] = std::array::from_fn(|c| v[c] + du * n[c] - self.velocity[c]);
        let wn = dot(w, n);
        let wt: [f64; 3] = std::array::from_fn(|c| w[c] - wn * n[c]);
        let slide = dot(wt, wt).sqrt();
        // The share of the sliding velocity friction removes: all of it when the normal
        // impulse's Coulomb bound covers it (sticking), else mu du of it (slipping).
        let stop = if slide > 0.0 {
            (self.friction * du / slide).min(1.0)
        } else {
            0.0
        };
        Some(std::array::from_fn(|c| du * n[c] - stop * wt[c]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn floor(friction: f64, velocity: [f64; 3]) -> Wall {
        Wall {
            point: [0.0, 0.0, 1.0],
            normal: [0.0, 0.0, 1.0],
            velocity,
            friction,
        }
    }

    /// A node that started the step on a wall at rest and moved into it ends on the plane
    /// with no normal velocity; without friction its sliding is untouched.
    #[test]
    fn a_node_from_the_plane_lands_on_it_at_rest_normally() {
        let (dt, v) = (1e-3, [2.0, 0.0, -3.0]);
        let x = [v[0] * dt, 0.0, 1.0 + v[2] * dt];
        let dv = floor(0.0, [0.0; 3]).correction(x, v, 0.0, dt).unwrap();
        let v1: [f64; 3] = std::array::from_fn(|c| v[c] + dv[c]);
        let x1: [f64; 3] = std::array::from_fn(|c| x[c] + dv[c] * dt);
        assert!(v1[2].abs() < 1e-12, "normal velocity {} (0)", v1[2]);
        assert_eq!(v1[0], 2.0, "frictionless: the sliding is kept");
        assert!((x1[2] - 1.0).abs() < 1e-15, "on the plane: z = {}", x1[2]);
        assert!(floor(0.0, [0.0; 3])
            .correction([0.0, 0.0, 1.0], v, 0.0, dt)
            .is_none());
    }

    /// Coulomb: the tangential impulse is at most mu times the normal one, and a node whose
    /// sliding the bound covers sticks to the wall (moving with it).
    #[test]
    fn friction_is_bounded_by_coulomb_and_sticks_below_it() {
        let dt = 1e-3;
        let w = floor(0.3, [0.5, 0.0, 0.0]);
        let v = [4.0, 0.0, -3.0];
        let x = [0.0, 0.0, 1.0 + v[2] * dt];
        let dv = w.correction(x, v, 0.0, dt).unwrap();
        let ratio = (dv[0] * dv[0] + dv[1] * dv[1]).sqrt() / dv[2];
        assert!(
            (ratio - 0.3).abs() < 1e-12,
            "slipping: |dv_t| / dv_n = {ratio} (mu = 0.3)"
        );
        let v = [0.9, 0.0, -3.0];
        let dv = w.correction(x, v, 0.0, dt).unwrap();
        assert!(
            (v[0] + dv[0] - 0.5).abs() < 1e-12,
            "sticking: moves with the wall at 0.5 m/s, got {}",
            v[0] + dv[0]
        );
    }

    /// A moving wall: a node at rest that the plane overtook in the step leaves it with the
    /// wall's normal velocity, on the plane at the step's end.
    #[test]
    fn a_moving_wall_carries_a_resting_node_with_it() {
        let dt = 1e-4;
        let w = floor(0.0, [0.0, 0.0, 10.0]);
        // At t = 0 the node is on the plane; at t = dt the plane is 1 mm above it.
        let dv = w.correction([0.0, 0.0, 1.0], [0.0; 3], dt, dt).unwrap();
        assert!((dv[2] - 10.0).abs() < 1e-9, "dv = {dv:?} (10 m/s)");
        assert!(w.distance([0.0, 0.0, 1.0 + dv[2] * dt], dt).abs() < 1e-15);
    }
}
