//! Sums whose value does not depend on the order of their terms: the energies and momenta of
//! history.csv, the FE nodal forces' energy terms and the SPH pair sums are the same bits at any
//! rank count and with any element kernel (docs/scene.md, "One answer").
//!
//! A floating-point sum depends on the order of its terms (each addition rounds), and the order
//! follows the partition: each rank sums its own nodes, and the ranks' partial sums are added in
//! the reduction's order. Here each term is instead split into three parts on fixed grids of
//! power-of-two quanta `Q1 > Q2 = Q1 2^-26 > Q3 = Q2 2^-26` (binned summation: J. Demmel and
//! H. D. Nguyen, "Parallel reproducible summation", IEEE Trans. Comput. 64 (2015) 2060). The
//! part on grid `Qk` is `t = (r + C) - C` with `C = 1.5 2^52 Qk`: for `|r| < 2^51 Qk` the
//! addition rounds `r` to a multiple of `Qk` (IEEE round to nearest) and the subtraction is
//! exact, so `t` and the residual `r - t` (exact, `|r - t| <= Qk / 2`) carry the term on. Each
//! part is a multiple of its quantum, so a fold's sum is exact while it stays below `2^53 Qk`:
//! for the lower folds (parts below `Q(k-1) / 2 = 2^25 Qk`) up to `2^28` terms, for the top one
//! while the total stays below `2^53 Q1`. Exact sums do not depend on the order, and folds
//! reduced over ranks by MPI's sum stay exact. The value is `(f1 + f2) + f3`, rounded once more
//! in a fixed order; the term is resolved to `Q3 = 2^-52 Q1` (what falls below is rounded away,
//! term by term, the same at any rank count).
//!
//! Why by hand: a fixed-point integer sum would need 128-bit integers and a conversion per term
//! that does not vectorise; the grid form is three additions and subtractions per fold, the
//! same in the scalar code and in the eight-lane kernels (`nodal`), and the reduction stays an
//! MPI sum of doubles. Cost: about 11 flops per term in place of one.

/// The parts of one sum (top fold first).
pub type Folds = [f64; 3];

/// The bits between folds: a lower fold's parts are below `2^(FOLD_BITS - 1)` of its quantum.
pub const FOLD_BITS: i32 = 26;

/// The most terms one lower fold may sum exactly (`2^(54 - FOLD_BITS)`: each part is below
/// `2^(FOLD_BITS - 1) Qk`, the fold exact below `2^53 Qk`).
pub const MAX_TERMS: u64 = 1 << (54 - FOLD_BITS);

/// A sum's three grids, as the shifts `C_k = 1.5 2^52 Q_k`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// The shift of each fold, top first.
    pub shift: [f64; 3],
}

/// `2^e` for `e` in the normal range.
pub fn pow2(e: i32) -> f64 {
    assert!(
        (-1022..=1023).contains(&e),
        "2^{e} outside the normal range"
    );
    f64::from_bits(((e + 1023) as u64) << 52)
}

/// The smallest `e` with `2^e >= x` (`x` positive and normal).
pub fn ceil_log2(x: f64) -> i32 {
    let bits = x.to_bits();
    let e = ((bits >> 52) & 0x7ff) as i32 - 1023;
    if bits & ((1u64 << 52) - 1) == 0 {
        e
    } else {
        e + 1
    }
}

impl Grid {
    /// The grid whose top fold sums exactly up to at least `2 top`: `Q1 = 2^(ceil(log2 top) -
    /// 52)`, resolution `Q3 = Q1 2^-52`. `top` is taken from values every rank agrees on (a
    /// reduced maximum, a mass summed exactly), so every rank has the same grid.
    pub fn covering(top: f64) -> Grid {
        let top = if top.is_finite() && top > 1e-280 {
            top
        } else {
            1e-280
        };
        let e1 = ceil_log2(top) - 52;
        let q = [e1, e1 - FOLD_BITS, e1 - 2 * FOLD_BITS];
        Grid {
            shift: q.map(|e| 1.5 * pow2(e + 52)),
        }
    }

    /// The sums of energies (J) of a model of mass `mass` (kg): exact up to `2^60` times the
    /// energy of the whole model moving at 1 mm/s (about `6e11 M` J, the model at 10^6 m/s),
    /// resolved to about `2.7e-20 M` J.
    pub fn energy(mass: f64) -> Grid {
        Grid::covering(pow2(60) * 0.5 * mass * 1e-6)
    }

    /// The sums of momenta (kg m/s) of a model of mass `mass` (kg): exact up to `2^60` times
    /// the model's momentum at 1 mm/s.
    pub fn momentum(mass: f64) -> Grid {
        Grid::covering(pow2(60) * mass * 1e-3)
    }

    /// Adds `x` to `acc`.
    #[inline(always)]
    pub fn add(&self, acc: &mut Folds, x: f64) {
        add_parts(acc, &self.split(x));
    }

    /// The parts of `x` on the three grids (what [`Grid::add`] adds). Round to nearest is
    /// symmetric, so the parts of `-x` are the negated parts of `x`: a pair's equal and opposite
    /// terms are split once.
    #[inline(always)]
    pub fn split(&self, x: f64) -> Folds {
        let [c1, c2, c3] = self.shift;
        let t1 = (x + c1) - c1;
        let r1 = x - t1;
        let t2 = (r1 + c2) - c2;
        let r2 = r1 - t2;
        let t3 = (r2 + c3) - c3;
        [t1, t2, t3]
    }

    /// The exponent of the top quantum `Q1 = 2^e`.
    pub fn top_exponent(&self) -> i32 {
        ceil_log2(self.shift[0] / 1.5) - 52
    }
}

/// Adds the parts `t` (from [`Grid::split`]) to `acc`.
#[inline(always)]
pub fn add_parts(acc: &mut Folds, t: &Folds) {
    acc[0] += t[0];
    acc[1] += t[1];
    acc[2] += t[2];
}

/// Subtracts the parts `t` (from [`Grid::split`]) from `acc`.
#[inline(always)]
pub fn sub_parts(acc: &mut Folds, t: &Folds) {
    acc[0] -= t[0];
    acc[1] -= t[1];
    acc[2] -= t[2];
}

/// The value of a sum's folds (each exact; added top first).
#[inline]
pub fn value(f: &Folds) -> f64 {
    (f[0] + f[1]) + f[2]
}

/// Adds fold sums `b` to `a` (exact, in any order).
#[inline]
pub fn merge(a: &mut Folds, b: &Folds) {
    for k in 0..3 {
        a[k] += b[k];
    }
}

/// `n` sums' folds laid out flat (3 n doubles, sum by sum), for one reduction over ranks.
pub fn flatten(sums: &[Folds]) -> Vec<f64> {
    sums.as_flattened().to_vec()
}

/// The values of the sums laid out by [`flatten`] (after the reduction).
pub fn values(flat: &[f64]) -> Vec<f64> {
    flat.chunks_exact(3)
        .map(|c| value(&[c[0], c[1], c[2]]))
        .collect()
}

/// The parts of a two-fold sum (top fold first): [`Grid2`].
pub type Folds2 = [f64; 2];

/// The bits between the two folds of a [`Grid2`].
pub const FOLD2_BITS: i32 = 40;

/// The most terms the lower fold of a [`Grid2`] sums exactly (`2^(54 - FOLD2_BITS)`).
pub const MAX_TERMS2: u64 = 1 << (54 - FOLD2_BITS);

/// Two folds, `Q2 = Q1 2^-40`: 92 bits from the top quantum's cover to the resolution (three
/// folds 26 bits apart give 104), for sums of at most [`MAX_TERMS2`] terms (each particle's
/// pair sums), at two thirds of [`Grid`]'s flops and storage. The same construction: the part
/// on grid `Qk` is `(r + C_k) - C_k`, `C_k = 1.5 2^52 Q_k`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid2 {
    /// The shift of each fold, top first.
    pub shift: [f64; 2],
}

impl Grid2 {
    /// The grid whose top fold sums exactly up to at least `2 top` (as [`Grid::covering`]),
    /// resolved to `Q2 = Q1 2^-40`.
    pub fn covering(top: f64) -> Grid2 {
        let g = Grid::covering(top);
        let e1 = g.top_exponent();
        Grid2 {
            shift: [e1, e1 - FOLD2_BITS].map(|e| 1.5 * pow2(e + 52)),
        }
    }

    /// The parts of `x` on the two grids (`-x` gives the negated parts, as [`Grid::split`]).
    #[inline(always)]
    pub fn split(&self, x: f64) -> Folds2 {
        let [c1, c2] = self.shift;
        let t1 = (x + c1) - c1;
        let t2 = ((x - t1) + c2) - c2;
        [t1, t2]
    }

    /// Adds `x` to `acc`.
    #[inline(always)]
    pub fn add(&self, acc: &mut Folds2, x: f64) {
        let t = self.split(x);
        acc[0] += t[0];
        acc[1] += t[1];
    }

    /// The exponent of the top quantum `Q1 = 2^e`.
    pub fn top_exponent(&self) -> i32 {
        ceil_log2(self.shift[0] / 1.5) - 52
    }
}

/// The value of a two-fold sum (each fold exact; added top first).
#[inline]
pub fn value2(f: &Folds2) -> f64 {
    f[0] + f[1]
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Terms of mixed signs over 30 decades, as energies of nodes are.
    fn terms(n: usize, seed: u64) -> Vec<f64> {
        let mut r = Rng(seed);
        (0..n)
            .map(|_| {
                let s = if r.next() < 0.5 { -1.0 } else { 1.0 };
                s * 10f64.powf(-20.0 + 30.0 * r.next())
            })
            .collect()
    }

    fn sum(g: &Grid, xs: &[f64]) -> Folds {
        let mut f = [0.0; 3];
        for &x in xs {
            g.add(&mut f, x);
        }
        f
    }

    /// The reference: each term rounded to the bottom quantum Q3 as an integer (exact scaling
    /// by a power of two, then `round`), summed in 128-bit integers: an exact sum computed
    /// another way. The fold sum is that sum rounded (two roundings: within 2 ulps).
    #[test]
    fn the_sum_is_the_exact_sum_of_the_terms_on_the_finest_grid() {
        let xs = terms(20000, 0x9e3779b97f4a7c15);
        let top: f64 = xs.iter().map(|x| x.abs()).sum();
        let g = Grid::covering(top);
        let q3 = g.shift[2] / (1.5 * pow2(52));
        let exact: i128 = xs.iter().map(|&x| (x / q3).round() as i128).sum();
        let want = exact as f64 * q3;
        let got = value(&sum(&g, &xs));
        let ulp = f64::EPSILON * want.abs();
        assert!(
            (got - want).abs() <= 2.0 * ulp,
            "fold sum {got:e} against the integer sum {want:e} (limit 2 ulp)"
        );
    }

    /// The same bits whatever the order and however the terms are split into partial sums
    /// (ranks) whose folds are then merged in another order.
    #[test]
    fn the_same_bits_in_any_order_and_partition() {
        let mut xs = terms(5000, 7);
        let top: f64 = xs.iter().map(|x| x.abs()).sum();
        let g = Grid::covering(top);
        let one = value(&sum(&g, &xs));
        xs.reverse();
        assert_eq!(value(&sum(&g, &xs)).to_bits(), one.to_bits(), "reversed");
        let mut r = Rng(11);
        for parts in [2usize, 3, 7] {
            for i in (1..xs.len()).rev() {
                let j = (r.next() * (i + 1) as f64) as usize;
                xs.swap(i, j);
            }
            let mut total = [0.0; 3];
            for chunk in xs.chunks(xs.len() / parts + 1).rev() {
                merge(&mut total, &sum(&g, chunk));
            }
            assert_eq!(value(&total).to_bits(), one.to_bits(), "{parts} parts");
        }
        // The plain sum differs with the order (what the folds are for).
        let plain: f64 = xs.iter().sum();
        let back: f64 = xs.iter().rev().sum();
        assert!(plain.to_bits() != back.to_bits() || plain == one);
    }

    /// The parts of -x are the negated parts of x (round to nearest, ties to even, is symmetric
    /// about the shift, an even multiple of each quantum), so a pair's opposite terms split once
    /// give the sums of terms split one by one.
    #[test]
    fn opposite_terms_split_to_opposite_parts() {
        // terms up to 1e10: the grid covers 2^35 (each term below half the cover)
        let g = Grid::covering(pow2(35));
        for &x in &terms(20000, 3) {
            let (a, b) = (g.split(x), g.split(-x));
            for k in 0..3 {
                // equal values (a zero part is +0 either way, which no sum can tell apart)
                assert_eq!(a[k], -b[k], "{x:e} fold {k}");
            }
        }
        // ties: a term half a quantum above a multiple
        let q1 = pow2(g.top_exponent());
        for x in [0.5 * q1, 1.5 * q1, 2.5 * q1, 3.5 * q1] {
            assert_eq!(g.split(x)[0], -g.split(-x)[0], "tie {x:e}");
        }
    }

    /// Two folds: the fold sum is the terms rounded to Q2 summed as 128-bit integers (2 ulp),
    /// and the same bits in any order and partition, for sums of up to MAX_TERMS2 terms.
    #[test]
    fn two_folds_sum_exactly_in_any_order() {
        let mut xs = terms(1 << 13, 5);
        let top: f64 = xs.iter().map(|x| x.abs()).sum();
        let g = Grid2::covering(top);
        let q2 = g.shift[1] / (1.5 * pow2(52));
        let sum = |xs: &[f64]| {
            let mut f = [0.0; 2];
            for &x in xs {
                g.add(&mut f, x);
            }
            f
        };
        let exact: i128 = xs.iter().map(|&x| (x / q2).round() as i128).sum();
        let want = exact as f64 * q2;
        let one = value2(&sum(&xs));
        assert!(
            (one - want).abs() <= 2.0 * f64::EPSILON * want.abs(),
            "two-fold sum {one:e} against the integer sum {want:e} (limit 2 ulp)"
        );
        xs.reverse();
        assert_eq!(value2(&sum(&xs)).to_bits(), one.to_bits(), "reversed");
        let mut total = [0.0; 2];
        for chunk in xs.chunks(1000).rev() {
            let f = sum(chunk);
            total[0] += f[0];
            total[1] += f[1];
        }
        assert_eq!(value2(&total).to_bits(), one.to_bits(), "in parts");
        assert_eq!(g.top_exponent(), Grid::covering(top).top_exponent());
        for &x in &xs[..100] {
            let (a, b) = (g.split(x), g.split(-x));
            assert!(a[0] == -b[0] && a[1] == -b[1], "opposite parts of {x:e}");
        }
    }

    #[test]
    fn grids_are_powers_of_two_and_cover_their_top() {
        for top in [1e-12, 1.0, 3.0, 4.0, 6.02e23] {
            let g = Grid::covering(top);
            let q1 = g.shift[0] / (1.5 * pow2(52));
            assert_eq!(q1.to_bits() & ((1u64 << 52) - 1), 0, "Q1 a power of two");
            assert!(pow2(53) * q1 >= 2.0 * top && pow2(52) * q1 < 4.0 * top);
            assert_eq!(pow2(g.top_exponent()), q1, "top exponent");
        }
        // A non-finite term makes the sum non-finite (the run's non-finite check sees it).
        let g = Grid::covering(1.0);
        assert!(!value(&sum(&g, &[1.0, f64::INFINITY])).is_finite());
        assert!(!value(&sum(&g, &[f64::NAN])).is_finite());
    }
}
