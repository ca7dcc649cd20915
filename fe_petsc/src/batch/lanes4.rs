//! Four f64 lanes for the batched element kernel (`batch::w4`): one lane per element,
//! the same operation in every lane, written on fixed-size arrays that the compiler turns into
//! vector instructions (two SSE2 instructions per lane operation on the baseline x86-64 target,
//! one with AVX).
//!
//! Every operation is the IEEE operation of `f64` lane by lane, in the order written: no fused
//! multiply-add and no reassociation, so that the AVX2 and the baseline builds give the same bits
//! (`mul_add` here rounds twice, as `a * b + c`; `f64::mul_add` without the `fma` target feature,
//! which the baseline target lacks, is a library call).
use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Not, Sub, SubAssign};

/// Elements per group.
pub const LANES: usize = 4;

/// Four f64 lanes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(32))]
pub struct F4(pub [f64; LANES]);

/// A per-lane condition.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct M4(pub [bool; LANES]);

impl M4 {
    /// Whether any lane holds.
    #[inline(always)]
    pub fn any(self) -> bool {
        self.0[0] | self.0[1] | self.0[2] | self.0[3]
    }

    /// Whether every lane holds.
    #[inline(always)]
    pub fn all(self) -> bool {
        self.0[0] & self.0[1] & self.0[2] & self.0[3]
    }

    /// Lane-wise or.
    #[inline(always)]
    pub fn or(self, o: M4) -> M4 {
        let (a, b) = (self.0, o.0);
        M4([a[0] | b[0], a[1] | b[1], a[2] | b[2], a[3] | b[3]])
    }

    /// Lane-wise and.
    #[inline(always)]
    pub fn and(self, o: M4) -> M4 {
        let (a, b) = (self.0, o.0);
        M4([a[0] & b[0], a[1] & b[1], a[2] & b[2], a[3] & b[3]])
    }
}

impl Not for M4 {
    type Output = M4;
    /// Lane-wise not.
    #[inline(always)]
    fn not(self) -> M4 {
        let a = self.0;
        M4([!a[0], !a[1], !a[2], !a[3]])
    }
}

impl F4 {
    /// Zero in every lane.
    pub const ZERO: F4 = F4([0.0; LANES]);

    /// `v` in every lane.
    #[inline(always)]
    pub const fn splat(v: f64) -> F4 {
        F4([v; LANES])
    }

    /// The first `LANES` doubles of `s`, lane `l` from `s[l]` (one unaligned vector load in
    /// the kernel's build). Panics when `s` is shorter.
    #[inline(always)]
    pub fn load(s: &[f64]) -> F4 {
        let mut a = [0.0; LANES];
        a.copy_from_slice(&s[..LANES]);
        F4(a)
    }

    /// The node numbers of corner `c` of the elements `conn[..4]`, each checked below `len`.
    /// Panics when one is not.
    #[inline(always)]
    pub fn corner(conn: &[[u32; 8]], c: usize, len: usize) -> [usize; LANES] {
        let n = [
            conn[0][c] as usize,
            conn[1][c] as usize,
            conn[2][c] as usize,
            conn[3][c] as usize,
        ];
        assert!(n.iter().all(|&i| i < len), "a node index beyond the points");
        n
    }

    /// The vectors of `ys` at the nodes `n`, component by component. Panics when a node is not
    /// in `ys`.
    #[inline(always)]
    pub fn gather(ys: &[[f64; 3]], n: [usize; LANES]) -> [F4; 3] {
        let lanes = |k: usize| F4([ys[n[0]][k], ys[n[1]][k], ys[n[2]][k], ys[n[3]][k]]);
        [lanes(0), lanes(1), lanes(2)]
    }

    /// Writes lane `l` to `s[l]` for the first `LANES` doubles of `s`. Panics when `s` is
    /// shorter.
    #[inline(always)]
    pub fn store(self, s: &mut [f64]) {
        s[..LANES].copy_from_slice(&self.0);
    }

    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> F4 {
        F4([f(self.0[0]), f(self.0[1]), f(self.0[2]), f(self.0[3])])
    }

    #[inline(always)]
    fn zip(self, o: F4, f: impl Fn(f64, f64) -> f64) -> F4 {
        let (a, b) = (self.0, o.0);
        F4([f(a[0], b[0]), f(a[1], b[1]), f(a[2], b[2]), f(a[3], b[3])])
    }

    #[inline(always)]
    fn test(self, o: F4, f: impl Fn(f64, f64) -> bool) -> M4 {
        let (a, b) = (self.0, o.0);
        M4([f(a[0], b[0]), f(a[1], b[1]), f(a[2], b[2]), f(a[3], b[3])])
    }

    /// Lane-wise square root.
    #[inline(always)]
    pub fn sqrt(self) -> F4 {
        self.map(f64::sqrt)
    }

    /// 1 / self, the IEEE quotient (the eight lanes' `recip` is an estimate refined to about
    /// 1 ulp, which the divider-bound eight-lane kernel needs and this one does not).
    #[inline(always)]
    pub fn recip(self) -> F4 {
        self.map(|x| 1.0 / x)
    }

    /// 1 / sqrt(self) from the IEEE square root and quotient.
    #[inline(always)]
    pub fn rsqrt(self) -> F4 {
        self.map(|x| 1.0 / x.sqrt())
    }

    /// Lane-wise absolute value.
    #[inline(always)]
    pub fn abs(self) -> F4 {
        self.map(f64::abs)
    }

    /// Lane-wise `f64::min` (a NaN lane takes the other operand).
    #[inline(always)]
    pub fn min(self, o: F4) -> F4 {
        self.zip(o, f64::min)
    }

    /// Lane-wise `f64::max` (a NaN lane takes the other operand).
    #[inline(always)]
    pub fn max(self, o: F4) -> F4 {
        self.zip(o, f64::max)
    }

    /// Lane-wise `f64::clamp` to [lo, hi] (NaN stays NaN).
    #[inline(always)]
    pub fn clamp(self, lo: f64, hi: f64) -> F4 {
        self.map(|x| x.clamp(lo, hi))
    }

    /// Lanes where `self < o`.
    #[inline(always)]
    pub fn lt(self, o: F4) -> M4 {
        self.test(o, |a, b| a < b)
    }

    /// Lanes where `self <= o`.
    #[inline(always)]
    pub fn le(self, o: F4) -> M4 {
        self.test(o, |a, b| a <= b)
    }

    /// Lanes where `self > o`.
    #[inline(always)]
    pub fn gt(self, o: F4) -> M4 {
        self.test(o, |a, b| a > b)
    }

    /// Lanes where `self >= o`.
    #[inline(always)]
    pub fn ge(self, o: F4) -> M4 {
        self.test(o, |a, b| a >= b)
    }

    /// Lanes where `self == o`.
    #[inline(always)]
    pub fn eq(self, o: F4) -> M4 {
        self.test(o, |a, b| a == b)
    }

    /// Lanes that are finite.
    #[inline(always)]
    pub fn is_finite(self) -> M4 {
        M4(self.0.map(f64::is_finite))
    }

    /// `self * b + c`, rounded twice as the scalar kernel's `a * b + c` (the eight-lane build
    /// fuses it: see `lanes8`).
    #[inline(always)]
    pub fn mul_add(self, b: F4, c: F4) -> F4 {
        self * b + c
    }

    /// `self * b - c`, rounded twice.
    #[inline(always)]
    pub fn mul_sub(self, b: F4, c: F4) -> F4 {
        self * b - c
    }

    /// `c - self * b`, rounded twice.
    #[inline(always)]
    pub fn neg_mul_add(self, b: F4, c: F4) -> F4 {
        c - self * b
    }

    /// `a` in the lanes where `m` holds, `b` in the others.
    #[inline(always)]
    pub fn select(m: M4, a: F4, b: F4) -> F4 {
        let pick = |l: usize| if m.0[l] { a.0[l] } else { b.0[l] };
        F4([pick(0), pick(1), pick(2), pick(3)])
    }
}

macro_rules! lane_op {
    ($tr:ident, $f:ident, $op:tt, $tra:ident, $fa:ident) => {
        impl $tr for F4 {
            type Output = F4;
            #[inline(always)]
            fn $f(self, o: F4) -> F4 {
                self.zip(o, |a, b| a $op b)
            }
        }
        impl $tr<f64> for F4 {
            type Output = F4;
            #[inline(always)]
            fn $f(self, o: f64) -> F4 {
                self.map(|a| a $op o)
            }
        }
        impl $tr<F4> for f64 {
            type Output = F4;
            #[inline(always)]
            fn $f(self, o: F4) -> F4 {
                o.map(|b| self $op b)
            }
        }
        impl $tra for F4 {
            #[inline(always)]
            fn $fa(&mut self, o: F4) {
                *self = *self $op o;
            }
        }
    };
}

lane_op!(Add, add, +, AddAssign, add_assign);
lane_op!(Sub, sub, -, SubAssign, sub_assign);
lane_op!(Mul, mul, *, MulAssign, mul_assign);
lane_op!(Div, div, /, DivAssign, div_assign);

impl Neg for F4 {
    type Output = F4;
    #[inline(always)]
    fn neg(self) -> F4 {
        self.map(|a| -a)
    }
}
