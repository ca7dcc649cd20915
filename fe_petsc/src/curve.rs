//! A load curve: a piecewise-linear scale factor of time (docs/scene.md, `curve`), the value
//! of its first point before it and of its last point after it.
//!
//! The scene reads and checks it (`coupling::input::curve`); the integrators evaluate it:
//! its value at a time (gravity, pressure), its mean over a step (a prescribed velocity at the
//! half step of central differences) and its slope (the acceleration of a prescribed velocity).

/// A piecewise-linear function of time through points `(t, s)`, times strictly increasing,
/// at least one point; held constant before the first and after the last.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    points: Vec<(f64, f64)>,
}

impl Curve {
    /// The curve through `points`. The caller checks them (`coupling::input::curve`); here
    /// only asserted: at least one point, finite, times strictly increasing.
    pub fn new(points: Vec<(f64, f64)>) -> Curve {
        assert!(!points.is_empty(), "a curve has at least one point");
        assert!(
            points.iter().all(|(t, s)| t.is_finite() && s.is_finite()),
            "finite points"
        );
        assert!(
            points.windows(2).all(|w| w[0].0 < w[1].0),
            "times strictly increasing"
        );
        Curve { points }
    }

    /// The points `(t, s)`.
    pub fn points(&self) -> &[(f64, f64)] {
        &self.points
    }

    /// The index `i` of the segment `[t_i, t_{i+1}]` holding `t` (`t_i <= t < t_{i+1}`),
    /// for `t` inside the curve's time range.
    fn segment(&self, t: f64) -> usize {
        // The first point whose time exceeds t, minus one.
        self.points.partition_point(|p| p.0 <= t) - 1
    }

    /// s(t): linear interpolation between the points, s = s_i + (t - t_i) (s_{i+1} - s_i) /
    /// (t_{i+1} - t_i) on segment i; the first value before the first point and the last value
    /// after the last.
    pub fn value(&self, t: f64) -> f64 {
        let (first, last) = (self.points[0], self.points[self.points.len() - 1]);
        if t <= first.0 {
            return first.1;
        }
        if t >= last.0 {
            return last.1;
        }
        let i = self.segment(t);
        let ((t0, s0), (t1, s1)) = (self.points[i], self.points[i + 1]);
        s0 + (t - t0) * ((s1 - s0) / (t1 - t0))
    }

    /// The integral of s over `[a, b]` (`a <= b`), s units times seconds: the sum over the
    /// linear pieces between `a`, the points inside and `b` of the trapezoid (b_k - a_k)
    /// (s(a_k) + s(b_k)) / 2, exact for a piecewise-linear function (held parts included).
    pub fn integral(&self, a: f64, b: f64) -> f64 {
        debug_assert!(a <= b);
        let mut sum = 0.0;
        let (mut lo, mut s_lo) = (a, self.value(a));
        for &(t, s) in &self.points {
            if t > a && t < b {
                sum += (t - lo) * (0.5 * (s_lo + s));
                (lo, s_lo) = (t, s);
            }
        }
        sum + (b - lo) * (0.5 * (s_lo + self.value(b)))
    }

    /// The mean of s over the step `[t, t + dt]`, (1/dt) times [`Curve::integral`]: a
    /// velocity held over the step moves a node by exactly the curve's integral. On one linear
    /// piece it is s(t + dt/2), the half step's value; across a point it keeps the
    /// displacement exact. `s(t)` for `dt = 0`.
    pub fn mean(&self, t: f64, dt: f64) -> f64 {
        let end = t + dt;
        if !(dt > 0.0) {
            return self.value(t);
        }
        if self.points.iter().any(|p| p.0 > t && p.0 < end) {
            self.integral(t, end) / dt
        } else {
            // One linear piece: the mean of its ends (a held value exactly).
            0.5 * (self.value(t) + self.value(end))
        }
    }

    /// ds/dt just after `t`, 1/s: the slope of the piece that starts at or holds `t`; 0
    /// from the last point on (held). The slope at the run's start, where nothing comes
    /// before.
    pub fn slope_after(&self, t: f64) -> f64 {
        let n = self.points.len();
        if n < 2 || t >= self.points[n - 1].0 {
            return 0.0;
        }
        if t < self.points[0].0 {
            return 0.0;
        }
        let i = self.segment(t);
        let ((t0, s0), (t1, s1)) = (self.points[i], self.points[i + 1]);
        (s1 - s0) / (t1 - t0)
    }

    /// ds/dt at `t`, 1/s: the slope of the piece holding `t`; at a point between two pieces
    /// the mean of their slopes; 0 outside the curve's range (held values).
    pub fn slope(&self, t: f64) -> f64 {
        let n = self.points.len();
        let piece = |i: usize| {
            let ((t0, s0), (t1, s1)) = (self.points[i], self.points[i + 1]);
            (s1 - s0) / (t1 - t0)
        };
        if n < 2 || t < self.points[0].0 || t > self.points[n - 1].0 {
            return 0.0;
        }
        // At a point: the mean of the slopes on either side (a held side's slope is 0).
        if let Some(k) = self.points.iter().position(|p| p.0 == t) {
            let left = if k > 0 { piece(k - 1) } else { 0.0 };
            let right = if k + 1 < n { piece(k) } else { 0.0 };
            return 0.5 * (left + right);
        }
        piece(self.segment(t))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp_hold() -> Curve {
        // 0 at t = 0, 1 at t = 2, 1 after; then down to 0.5 at t = 4.
        Curve::new(vec![(0.0, 0.0), (2.0, 1.0), (3.0, 1.0), (4.0, 0.5)])
    }

    #[test]
    fn values_by_hand() {
        let c = ramp_hold();
        // Held before the first point and after the last.
        assert_eq!(c.value(-1.0), 0.0);
        assert_eq!(c.value(10.0), 0.5);
        // On the pieces: 0.5 t on [0, 2], 1 on [2, 3], 1 - 0.5 (t - 3) on [3, 4].
        assert_eq!(c.value(0.5), 0.25);
        assert_eq!(c.value(2.0), 1.0);
        assert_eq!(c.value(2.5), 1.0);
        assert_eq!(c.value(3.5), 0.75);
        // One point: constant.
        let one = Curve::new(vec![(1.0, 3.0)]);
        assert_eq!(one.value(0.0), 3.0);
        assert_eq!(one.value(5.0), 3.0);
        assert_eq!(one.slope(1.0), 0.0);
    }

    #[test]
    fn integrals_by_hand() {
        let c = ramp_hold();
        // 0..2: triangle 1; 2..3: 1; 3..4: trapezoid 0.75; after 4: 0.5 per second.
        assert_eq!(c.integral(0.0, 2.0), 1.0);
        assert_eq!(c.integral(0.0, 4.0), 2.75);
        assert_eq!(c.integral(0.0, 6.0), 3.75);
        // Before the first point: the first value held (0 here).
        assert_eq!(c.integral(-3.0, 0.0), 0.0);
        // Across a point: 1..2.5 = (0.5 + 1)/2 * 1 + 0.5 = 1.25.
        assert_eq!(c.integral(1.0, 2.5), 1.25);
        // The mean on one piece is the half step's value.
        assert_eq!(c.mean(0.5, 1.0), c.value(1.0));
        assert_eq!(c.mean(1.0, 1.5), 1.25 / 1.5);
    }

    #[test]
    fn slopes_by_hand() {
        let c = ramp_hold();
        assert_eq!(c.slope(1.0), 0.5);
        assert_eq!(c.slope(2.5), 0.0);
        assert_eq!(c.slope(3.5), -0.5);
        // At points: the mean of the two sides.
        assert_eq!(c.slope(2.0), 0.25);
        assert_eq!(c.slope(0.0), 0.25);
        assert_eq!(c.slope(4.0), -0.25);
        assert_eq!(c.slope(-1.0), 0.0);
        assert_eq!(c.slope(5.0), 0.0);
        // Just after: the piece starting there.
        assert_eq!(c.slope_after(0.0), 0.5);
        assert_eq!(c.slope_after(2.0), 0.0);
        assert_eq!(c.slope_after(3.0), -0.5);
        assert_eq!(c.slope_after(4.0), 0.0);
        assert_eq!(c.slope_after(-1.0), 0.0);
    }

    #[test]
    fn the_steps_means_add_up_to_the_integral() {
        // Steps that straddle the points: the sum of dt * mean telescopes to the integral.
        let c = ramp_hold();
        let dt = 0.3;
        let (mut t, mut sum) = (0.0, 0.0);
        for _ in 0..20 {
            sum += dt * c.mean(t, dt);
            t += dt;
        }
        let exact = c.integral(0.0, t);
        assert!((sum - exact).abs() <= 1e-14 * exact, "{sum} vs {exact}");
    }
}
