//! A periodic box: wrapping positions into it and listing the periodic images a particle needs.
//!
//! An image of a particle is a ghost copy at `x_real + shift` with `shift = n * period` (n an
//! integer per periodic axis, 0 on the others). Shifts are always made as `n as f64 * period`,
//! so `image_index` recovers n exactly.

/// Periodic box: on each axis with `axes[k]`, space repeats with period `max[k] - min[k]` and
/// positions are wrapped into the half-open interval `[min[k], max[k])`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Periodic {
    /// Which axes are periodic.
    pub axes: [bool; 3],
    /// Lower corner.
    pub min: [f64; 3],
    /// Upper corner (exclusive).
    pub max: [f64; 3],
}

impl Periodic {
    /// The period on axis k.
    #[inline]
    pub fn period(&self, k: usize) -> f64 {
        self.max[k] - self.min[k]
    }

    /// The shift vector of image index n (0 on non-periodic axes).
    pub fn shift_of(&self, n: [i64; 3]) -> [f64; 3] {
        let mut s = [0.0; 3];
        for k in 0..3 {
            if self.axes[k] {
                s[k] = n[k] as f64 * self.period(k);
            }
        }
        s
    }

    /// The integer image index of a shift made by `shift_of` (0 on non-periodic axes).
    #[inline]
    pub fn image_index(&self, shift: [f64; 3]) -> [i64; 3] {
        let mut n = [0i64; 3];
        for k in 0..3 {
            if self.axes[k] && shift[k] != 0.0 {
                n[k] = (shift[k] / self.period(k)).round() as i64;
            }
        }
        n
    }

    /// `x` wrapped into the box on periodic axes, and the image count `n` removed, so that
    /// `wrapped = x - shift_of(n)` with `min <= wrapped < max` on periodic axes.
    /// Deterministic: the same `x` gives the same bits on every rank.
    #[inline]
    pub fn wrap_with_index(&self, x: [f64; 3]) -> ([f64; 3], [i64; 3]) {
        if self.contains(x) {
            return (x, [0; 3]);
        }
        self.wrap_outside(x)
    }

    /// `wrap_with_index` for a point known to lie outside on some periodic axis.
    fn wrap_outside(&self, x: [f64; 3]) -> ([f64; 3], [i64; 3]) {
        let mut out = x;
        let mut n = [0i64; 3];
        for k in 0..3 {
            if !self.axes[k] {
                continue;
            }
            let (lo, hi, len) = (self.min[k], self.max[k], self.period(k));
            if x[k] >= lo && x[k] < hi {
                continue;
            }
            let mut m = ((x[k] - lo) / len).floor() as i64;
            let mut y = x[k] - m as f64 * len;
            // round-off guards so that the half-open interval holds exactly
            while y >= hi {
                m += 1;
                y = x[k] - m as f64 * len;
            }
            while y < lo {
                m -= 1;
                y = x[k] - m as f64 * len;
            }
            out[k] = y;
            n[k] = m;
        }
        (out, n)
    }

    /// `x` wrapped into `[min, max)` on periodic axes.
    pub fn wrap(&self, x: [f64; 3]) -> [f64; 3] {
        self.wrap_with_index(x).0
    }

    /// Whether `x` lies in the half-open box on the periodic axes (other axes are not looked at).
    #[inline]
    pub fn contains(&self, x: [f64; 3]) -> bool {
        (0..3).all(|k| !self.axes[k] || (x[k] >= self.min[k] && x[k] < self.max[k]))
    }
}

/// The shifts (nonzero, each `n * period` on periodic axes) of every periodic image of the point
/// `x_real` (assumed inside the box) that lies within `reach` of the box on every periodic axis,
/// i.e. in `[min - reach, max + reach)`; corners and edges give the combined shifts. With
/// `reach` = the largest interaction distance (2 h_max), these are the images a rank holding the
/// whole box needs; `reach` may exceed the period (then several images per axis).
pub fn periodic_images(x_real: [f64; 3], reach: f64, per: &Periodic) -> Vec<[f64; 3]> {
    let mut per_axis: [Vec<i64>; 3] = [vec![0], vec![0], vec![0]];
    for k in 0..3 {
        if !per.axes[k] {
            continue;
        }
        let len = per.period(k);
        let nmax = (reach / len).ceil() as i64 + 1;
        for n in -nmax..=nmax {
            if n == 0 {
                continue;
            }
            let y = x_real[k] + n as f64 * len;
            if y >= per.min[k] - reach && y < per.max[k] + reach {
                per_axis[k].push(n);
            }
        }
    }
    let mut out = Vec::new();
    for &i in &per_axis[0] {
        for &j in &per_axis[1] {
            for &k in &per_axis[2] {
                if (i, j, k) != (0, 0, 0) {
                    out.push(per.shift_of([i, j, k]));
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_and_images() {
        let per = Periodic {
            axes: [true, true, false],
            min: [0.0, -1.0, 0.0],
            max: [1.0, 1.0, 1.0],
        };
        let (w, n) = per.wrap_with_index([2.25, -1.5, 7.0]);
        assert_eq!(w, [0.25, 0.5, 7.0]);
        assert_eq!(n, [2, -1, 0]);
        assert_eq!(per.wrap([1.0, 1.0, -3.0]), [0.0, -1.0, -3.0]);
        // a point near the x = 0 face and the y = 1 face: images +x, -y and the corner +x-y
        let imgs = periodic_images([0.05, 0.95, 0.5], 0.1, &per);
        let mut got: Vec<[i64; 3]> = imgs.iter().map(|s| per.image_index(*s)).collect();
        got.sort();
        assert_eq!(got, vec![[0, -1, 0], [1, -1, 0], [1, 0, 0]]);
        // in the middle: none
        assert!(periodic_images([0.5, 0.0, 0.5], 0.1, &per).is_empty());
    }
}
