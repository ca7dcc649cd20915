//! f64 lanes on fixed-size arrays for the element kernel: one lane (`batch::w1`, the
//! one-element kernel) and four (`batch::w4`), one lane per element, the same operation in
//! every lane, written so that the compiler turns four lanes into vector instructions (two SSE2
//! instructions per lane operation on the baseline x86-64 target, one with AVX) and one lane
//! into scalar ones. Both are one text (`fixed_lanes!`), instantiated per width.
//!
//! Every operation is the IEEE operation of `f64` lane by lane, in the order written: no fused
//! multiply-add and no reassociation, so that every width and build gives the same bits
//! (`mul_add` here rounds twice, as `a * b + c`; `f64::mul_add` without the `fma` target
//! feature, which the baseline target lacks, is a library call).
use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Not, Sub, SubAssign};

macro_rules! lane_op {
    ($F:ident, $tr:ident, $f:ident, $op:tt, $tra:ident, $fa:ident) => {
        impl $tr for $F {
            type Output = $F;
            #[inline(always)]
            fn $f(self, o: $F) -> $F {
                self.zip(o, |a, b| a $op b)
            }
        }
        impl $tr<f64> for $F {
            type Output = $F;
            #[inline(always)]
            fn $f(self, o: f64) -> $F {
                self.map(|a| a $op o)
            }
        }
        impl $tr<$F> for f64 {
            type Output = $F;
            #[inline(always)]
            fn $f(self, o: $F) -> $F {
                o.map(|b| self $op b)
            }
        }
        impl $tra for $F {
            #[inline(always)]
            fn $fa(&mut self, o: $F) {
                *self = *self $op o;
            }
        }
    };
}

/// A lane type `$F` of `$n` f64 lanes (aligned to `$align` bytes) and its mask `$M`, the
/// lanes' indices listed in `$i` (each lane operation written out lane by lane, no loop: what
/// the four-lane build vectorises best).
macro_rules! fixed_lanes {
    ($F:ident, $M:ident, $n:literal, $align:literal, [$($i:literal),*]) => {

        /// Elements per group.
        pub const LANES: usize = $n;

        #[doc = concat!(stringify!($n), " f64 lanes.")]
        #[derive(Clone, Copy, Debug, Default, PartialEq)]
        #[repr(C, align($align))]
        pub struct $F(pub [f64; LANES]);

        /// A per-lane condition.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub struct $M(pub [bool; LANES]);

        impl $M {
            /// Whether any lane holds.
            #[inline(always)]
            pub fn any(self) -> bool {
                false $(| self.0[$i])*
            }

            /// Whether every lane holds.
            #[inline(always)]
            pub fn all(self) -> bool {
                true $(& self.0[$i])*
            }

            /// Lane-wise or.
            #[inline(always)]
            pub fn or(self, o: $M) -> $M {
                let (a, b) = (self.0, o.0);
                $M([$(a[$i] | b[$i]),*])
            }

            /// Lane-wise and.
            #[inline(always)]
            pub fn and(self, o: $M) -> $M {
                let (a, b) = (self.0, o.0);
                $M([$(a[$i] & b[$i]),*])
            }
        }

        impl Not for $M {
            type Output = $M;
            /// Lane-wise not.
            #[inline(always)]
            fn not(self) -> $M {
                let a = self.0;
                $M([$(!a[$i]),*])
            }
        }

        impl $F {
            /// Zero in every lane.
            pub const ZERO: $F = $F([0.0; LANES]);

            /// `v` in every lane.
            #[inline(always)]
            pub const fn splat(v: f64) -> $F {
                $F([v; LANES])
            }

            /// The first `LANES` doubles of `s`, lane `l` from `s[l]` (one unaligned vector load in
            /// the kernel's build). Panics when `s` is shorter.
            #[inline(always)]
            pub fn load(s: &[f64]) -> $F {
                let mut a = [0.0; LANES];
                a.copy_from_slice(&s[..LANES]);
                $F(a)
            }

            /// The node numbers of corner `c` of the elements `conn[..LANES]`, each checked below `len`.
            /// Panics when one is not.
            #[inline(always)]
            pub fn corner(conn: &[[u32; 8]], c: usize, len: usize) -> [usize; LANES] {
                let n = [$(conn[$i][c] as usize),*];
                assert!(n.iter().all(|&i| i < len), "a node index beyond the points");
                n
            }

            /// The vectors of `ys` at the nodes `n`, component by component. Panics when a node is not
            /// in `ys`.
            #[inline(always)]
            pub fn gather(ys: &[[f64; 3]], n: [usize; LANES]) -> [$F; 3] {
                let lanes = |k: usize| $F([$(ys[n[$i]][k]),*]);
                [lanes(0), lanes(1), lanes(2)]
            }

            /// Writes lane `l` to `s[l]` for the first `LANES` doubles of `s`. Panics when `s` is
            /// shorter.
            #[inline(always)]
            pub fn store(self, s: &mut [f64]) {
                s[..LANES].copy_from_slice(&self.0);
            }

            #[inline(always)]
            fn map(self, f: impl Fn(f64) -> f64) -> $F {
                $F([$(f(self.0[$i])),*])
            }

            #[inline(always)]
            fn zip(self, o: $F, f: impl Fn(f64, f64) -> f64) -> $F {
                let (a, b) = (self.0, o.0);
                $F([$(f(a[$i], b[$i])),*])
            }

            #[inline(always)]
            fn test(self, o: $F, f: impl Fn(f64, f64) -> bool) -> $M {
                let (a, b) = (self.0, o.0);
                $M([$(f(a[$i], b[$i])),*])
            }

            /// Lane-wise square root.
            #[inline(always)]
            pub fn sqrt(self) -> $F {
                self.map(f64::sqrt)
            }

            /// 1 / self, the IEEE quotient (the eight lanes' `recip` is an estimate refined to about
            /// 1 ulp, which the divider-bound eight-lane kernel needs and this one does not).
            #[inline(always)]
            pub fn recip(self) -> $F {
                self.map(|x| 1.0 / x)
            }

            /// 1 / sqrt(self) from the IEEE square root and quotient.
            #[inline(always)]
            pub fn rsqrt(self) -> $F {
                self.map(|x| 1.0 / x.sqrt())
            }

            /// Lane-wise absolute value.
            #[inline(always)]
            pub fn abs(self) -> $F {
                self.map(f64::abs)
            }

            /// Lane-wise `f64::min` (a NaN lane takes the other operand).
            #[inline(always)]
            pub fn min(self, o: $F) -> $F {
                self.zip(o, f64::min)
            }

            /// Lane-wise `f64::max` (a NaN lane takes the other operand).
            #[inline(always)]
            pub fn max(self, o: $F) -> $F {
                self.zip(o, f64::max)
            }

            /// Lane-wise `f64::clamp` to [lo, hi] (NaN stays NaN).
            #[inline(always)]
            pub fn clamp(self, lo: f64, hi: f64) -> $F {
                self.map(|x| x.clamp(lo, hi))
            }

            /// Lanes where `self < o`.
            #[inline(always)]
            pub fn lt(self, o: $F) -> $M {
                self.test(o, |a, b| a < b)
            }

            /// Lanes where `self <= o`.
            #[inline(always)]
            pub fn le(self, o: $F) -> $M {
                self.test(o, |a, b| a <= b)
            }

            /// Lanes where `self > o`.
            #[inline(always)]
            pub fn gt(self, o: $F) -> $M {
                self.test(o, |a, b| a > b)
            }

            /// Lanes where `self >= o`.
            #[inline(always)]
            pub fn ge(self, o: $F) -> $M {
                self.test(o, |a, b| a >= b)
            }

            /// Lanes where `self == o`.
            #[inline(always)]
            pub fn eq(self, o: $F) -> $M {
                self.test(o, |a, b| a == b)
            }

            /// Lanes that are finite.
            #[inline(always)]
            pub fn is_finite(self) -> $M {
                $M(self.0.map(f64::is_finite))
            }

            twice_rounded_ops!($F);

            /// `a` in the lanes where `m` holds, `b` in the others.
            #[inline(always)]
            pub fn select(m: $M, a: $F, b: $F) -> $F {
                let pick = |l: usize| if m.0[l] { a.0[l] } else { b.0[l] };
                $F([$(pick($i)),*])
            }
        }

        lane_op!($F, Add, add, +, AddAssign, add_assign);
        lane_op!($F, Sub, sub, -, SubAssign, sub_assign);
        lane_op!($F, Mul, mul, *, MulAssign, mul_assign);
        lane_op!($F, Div, div, /, DivAssign, div_assign);

        impl Neg for $F {
            type Output = $F;
            #[inline(always)]
            fn neg(self) -> $F {
                self.map(|a| -a)
            }
        }
    };
}

/// One lane: the element kernel one element at a time (`--kernel scalar`).
pub mod lanes1 {
    use super::*;
    fixed_lanes!(F1, M1, 1, 8, [0]);
}

/// Four lanes (`--kernel lanes4`) where the four lanes are not AVX2 registers (`lanes4.rs`, on
/// x86-64); built on x86-64 for the tests only, which hold it to the AVX2 lanes' bits.
#[cfg(any(test, not(target_arch = "x86_64")))]
pub mod lanes4 {
    use super::*;
    fixed_lanes!(F4, M4, 4, 32, [0, 1, 2, 3]);
}
