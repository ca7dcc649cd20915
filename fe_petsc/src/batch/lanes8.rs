//! Eight f64 lanes in one AVX-512 register for the batched element kernel (`batch::w8`): the
//! same interface as the four lanes of [`super::lanes4`], each operation one AVX-512
//! instruction written with `std::arch` intrinsics.
//!
//! Why intrinsics and not arrays the compiler vectorises (as the four lanes are): on eight-lane
//! arrays the compiler's loop vectoriser turned some node loops into gathers and scatters
//! across the lanes' arrays (measured 410 ns per element in `examples/hex_bench`, against
//! 245 ns with these intrinsics and 320 ns with four AVX2 lanes). The storage stays a plain
//! array, so lanes are read and written by index outside the kernel.
//!
//! Every operation is the IEEE operation of `f64` lane by lane, and the comparisons, `min`,
//! `max`, `clamp`, `abs` and negation treat NaN, infinities and signed zeros as `f64`'s do. The
//! one difference from the four lanes and the scalar kernel: `mul_add`, `mul_sub` and
//! `neg_mul_add` are fused (one rounding instead of two, and one instruction instead of two),
//! so eight-lane results differ from the scalar kernel's at round-off (1e-13 relative measured
//! in `tests/lanes.rs`).
//!
//! Soundness: the operations execute AVX-512F instructions. `F8` is private to the batch module
//! and operated on only inside `batch::w8`'s kernel, whose one entry runs after
//! `is_x86_feature_detected!("avx512f")` (see `batch::w8::LaneGroup::update`); the operations
//! are inlined into that entry, which is compiled with the feature.
use std::arch::x86_64::{
    __m256i, __m512d, __m512i, _mm256_loadu_si256, _mm512_abs_pd, _mm512_add_pd,
    _mm512_castpd_si512, _mm512_castsi512_pd, _mm512_cmp_pd_mask, _mm512_div_pd, _mm512_fmadd_pd,
    _mm512_fmsub_pd, _mm512_fnmadd_pd, _mm512_i32gather_pd, _mm512_mask_blend_pd, _mm512_max_pd,
    _mm512_min_pd, _mm512_mul_pd, _mm512_set1_epi64, _mm512_set1_pd, _mm512_sqrt_pd, _mm512_sub_pd,
    _mm512_xor_si512, _CMP_EQ_OQ, _CMP_GE_OQ, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _CMP_UNORD_Q,
};
use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Not, Sub, SubAssign};

/// Elements per group.
pub const LANES: usize = 8;

/// Eight f64 lanes (the layout of one AVX-512 register).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
pub struct F8(pub [f64; LANES]);

/// A per-lane condition: bit l for lane l (an AVX-512 mask register).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct M8(u8);

impl M8 {
    /// Whether any lane holds.
    #[inline(always)]
    pub fn any(self) -> bool {
        self.0 != 0
    }

    /// Whether every lane holds.
    #[inline(always)]
    pub fn all(self) -> bool {
        self.0 == u8::MAX
    }

    /// Lane-wise or.
    #[inline(always)]
    pub fn or(self, o: M8) -> M8 {
        M8(self.0 | o.0)
    }

    /// Lane-wise and.
    #[inline(always)]
    pub fn and(self, o: M8) -> M8 {
        M8(self.0 & o.0)
    }
}

impl Not for M8 {
    type Output = M8;
    /// Lane-wise not.
    #[inline(always)]
    fn not(self) -> M8 {
        M8(!self.0)
    }
}

#[inline(always)]
fn reg(a: F8) -> __m512d {
    // SAFETY: F8 is 64 aligned bytes of eight f64, the layout of __m512d.
    unsafe { std::mem::transmute::<F8, __m512d>(a) }
}

#[inline(always)]
fn val(a: __m512d) -> F8 {
    // SAFETY: as in `reg`.
    unsafe { std::mem::transmute::<__m512d, F8>(a) }
}

/// One AVX-512F instruction on registers (see the module's soundness note).
macro_rules! avx512 {
    ($e:expr) => {
        // SAFETY: executed only inside `batch::w8`'s kernel, after the CPU was found to have
        // AVX-512F (module comment).
        unsafe { $e }
    };
}

impl F8 {
    /// Zero in every lane.
    pub const ZERO: F8 = F8([0.0; LANES]);

    /// `v` in every lane.
    #[inline(always)]
    pub const fn splat(v: f64) -> F8 {
        F8([v; LANES])
    }

    /// The first `LANES` doubles of `s`, lane `l` from `s[l]` (one unaligned vector load in
    /// the kernel's build). Panics when `s` is shorter.
    #[inline(always)]
    pub fn load(s: &[f64]) -> F8 {
        let mut a = [0.0; LANES];
        a.copy_from_slice(&s[..LANES]);
        F8(a)
    }

    /// The three components of the points `xs[nodes[l]]`, lane `l` from `nodes[l]`: three
    /// AVX-512 gathers with the same indices (one per component). Panics when a node is not in
    /// `xs` or `xs` has 2^31 / 3 points or more (the gather's indices are 32-bit).
    #[inline(always)]
    pub fn gather3(xs: &[[f64; 3]], nodes: &[u32; LANES]) -> [F8; 3] {
        assert!(
            xs.len() <= i32::MAX as usize / 3,
            "too many points for 32-bit indices"
        );
        let mut idx = [0i32; LANES];
        let mut inside = true;
        for l in 0..LANES {
            inside &= (nodes[l] as usize) < xs.len();
            idx[l] = 3 * nodes[l] as i32;
        }
        assert!(inside, "a node index beyond the points");
        let base = xs.as_flattened().as_ptr();
        // SAFETY: AVX-512F as in `avx512!`; every index is 3 n with n < xs.len(), so the
        // gathered doubles 3 n + c (c < 3) lie inside `xs`; the index array is 32 bytes read
        // as one 256-bit vector (unaligned load).
        unsafe {
            let vi = _mm256_loadu_si256(idx.as_ptr().cast::<__m256i>());
            [
                val(_mm512_i32gather_pd::<8>(vi, base)),
                val(_mm512_i32gather_pd::<8>(vi, base.add(1))),
                val(_mm512_i32gather_pd::<8>(vi, base.add(2))),
            ]
        }
    }

    /// Writes lane `l` to `s[l]` for the first `LANES` doubles of `s`. Panics when `s` is
    /// shorter.
    #[inline(always)]
    pub fn store(self, s: &mut [f64]) {
        s[..LANES].copy_from_slice(&self.0);
    }

    #[inline(always)]
    fn cmp<const P: i32>(self, o: F8) -> M8 {
        M8(avx512!(_mm512_cmp_pd_mask::<P>(reg(self), reg(o))))
    }

    /// Lanes that are NaN.
    #[inline(always)]
    fn is_nan(self) -> M8 {
        self.cmp::<_CMP_UNORD_Q>(self)
    }

    /// Lane-wise square root.
    #[inline(always)]
    pub fn sqrt(self) -> F8 {
        val(avx512!(_mm512_sqrt_pd(reg(self))))
    }

    /// Lane-wise absolute value.
    #[inline(always)]
    pub fn abs(self) -> F8 {
        val(avx512!(_mm512_abs_pd(reg(self))))
    }

    /// Lane-wise `f64::min`: a NaN lane takes the other operand. (The instruction returns its
    /// second operand when either is NaN: `o` first makes a NaN `o` give `self`, and the blend
    /// makes a NaN `self` give `o`.)
    #[inline(always)]
    pub fn min(self, o: F8) -> F8 {
        let m = val(avx512!(_mm512_min_pd(reg(o), reg(self))));
        F8::select(self.is_nan(), o, m)
    }

    /// Lane-wise `f64::max`: a NaN lane takes the other operand (as `min`).
    #[inline(always)]
    pub fn max(self, o: F8) -> F8 {
        let m = val(avx512!(_mm512_max_pd(reg(o), reg(self))));
        F8::select(self.is_nan(), o, m)
    }

    /// Lane-wise `f64::clamp` to [lo, hi] (NaN stays NaN).
    #[inline(always)]
    pub fn clamp(self, lo: f64, hi: f64) -> F8 {
        let c = self.max(F8::splat(lo)).min(F8::splat(hi));
        F8::select(self.is_nan(), self, c)
    }

    /// Lanes where `self < o`.
    #[inline(always)]
    pub fn lt(self, o: F8) -> M8 {
        self.cmp::<_CMP_LT_OQ>(o)
    }

    /// Lanes where `self <= o`.
    #[inline(always)]
    pub fn le(self, o: F8) -> M8 {
        self.cmp::<_CMP_LE_OQ>(o)
    }

    /// Lanes where `self > o`.
    #[inline(always)]
    pub fn gt(self, o: F8) -> M8 {
        self.cmp::<_CMP_GT_OQ>(o)
    }

    /// Lanes where `self >= o`.
    #[inline(always)]
    pub fn ge(self, o: F8) -> M8 {
        self.cmp::<_CMP_GE_OQ>(o)
    }

    /// Lanes where `self == o`.
    #[inline(always)]
    pub fn eq(self, o: F8) -> M8 {
        self.cmp::<_CMP_EQ_OQ>(o)
    }

    /// Lanes that are finite (|x| < infinity is false for NaN and infinities).
    #[inline(always)]
    pub fn is_finite(self) -> M8 {
        self.abs().lt(F8::splat(f64::INFINITY))
    }

    /// `self * b + c` fused: one rounding (the four-lane and scalar kernels round twice, so
    /// the eight-lane results differ from theirs at round-off).
    #[inline(always)]
    pub fn mul_add(self, b: F8, c: F8) -> F8 {
        val(avx512!(_mm512_fmadd_pd(reg(self), reg(b), reg(c))))
    }

    /// `self * b - c` fused.
    #[inline(always)]
    pub fn mul_sub(self, b: F8, c: F8) -> F8 {
        val(avx512!(_mm512_fmsub_pd(reg(self), reg(b), reg(c))))
    }

    /// `c - self * b` fused.
    #[inline(always)]
    pub fn neg_mul_add(self, b: F8, c: F8) -> F8 {
        val(avx512!(_mm512_fnmadd_pd(reg(self), reg(b), reg(c))))
    }

    /// `a` in the lanes where `m` holds, `b` in the others.
    #[inline(always)]
    pub fn select(m: M8, a: F8, b: F8) -> F8 {
        val(avx512!(_mm512_mask_blend_pd(m.0, reg(b), reg(a))))
    }
}

macro_rules! lane_op {
    ($tr:ident, $f:ident, $tra:ident, $fa:ident, $intr:ident) => {
        impl $tr for F8 {
            type Output = F8;
            #[inline(always)]
            fn $f(self, o: F8) -> F8 {
                val(avx512!($intr(reg(self), reg(o))))
            }
        }
        impl $tr<f64> for F8 {
            type Output = F8;
            #[inline(always)]
            fn $f(self, o: f64) -> F8 {
                val(avx512!($intr(reg(self), _mm512_set1_pd(o))))
            }
        }
        impl $tr<F8> for f64 {
            type Output = F8;
            #[inline(always)]
            fn $f(self, o: F8) -> F8 {
                val(avx512!($intr(_mm512_set1_pd(self), reg(o))))
            }
        }
        impl $tra for F8 {
            #[inline(always)]
            fn $fa(&mut self, o: F8) {
                *self = $tr::$f(*self, o);
            }
        }
    };
}

lane_op!(Add, add, AddAssign, add_assign, _mm512_add_pd);
lane_op!(Sub, sub, SubAssign, sub_assign, _mm512_sub_pd);
lane_op!(Mul, mul, MulAssign, mul_assign, _mm512_mul_pd);
lane_op!(Div, div, DivAssign, div_assign, _mm512_div_pd);

impl Neg for F8 {
    type Output = F8;
    /// Lane-wise negation: the sign bit flipped, as `-x` on an f64 (so -0.0 from 0.0).
    #[inline(always)]
    fn neg(self) -> F8 {
        let sign: __m512i = avx512!(_mm512_set1_epi64(i64::MIN));
        val(avx512!(_mm512_castsi512_pd(_mm512_xor_si512(
            _mm512_castpd_si512(reg(self)),
            sign
        ))))
    }
}
