//! Eight f64 lanes in one AVX-512 register for the batched element kernel (`batch::w8`): the
//! same interface as the four lanes of [`super::lanes4`], each operation one AVX-512
//! instruction written with `std::arch` intrinsics.
//!
//! Why intrinsics and not arrays the compiler vectorises (what `fixed.rs` gives one lane, and
//! four off x86-64): on eight-lane arrays the compiler's loop vectoriser turned some node loops
//! into gathers and scatters across the lanes' arrays (measured 410 ns per element in
//! `examples/hex_bench`, against 245 ns with these intrinsics at the time). The storage stays a
//! plain array, so lanes are read and written by index outside the kernel. The operators,
//! comparisons, `min`, `max`, `clamp` and multiply-adds are derived as the four lanes' are
//! (`vector_ops.rs`).
//!
//! Every operation is the IEEE operation of `f64` lane by lane, and the comparisons, `min`,
//! `max`, `clamp`, `abs` and negation treat NaN, infinities and signed zeros as `f64`'s do.
//! `mul_add`, `mul_sub` and `neg_mul_add` round twice (a multiply, then an add), `recip` and
//! `rsqrt` are the IEEE quotient and square root: the same operations, in the same order, as
//! the four lanes (the kernel's source is one, `batch/hex.rs`), so the eight-lane results are
//! the four-lane results bit for bit (docs/scene.md, "One answer": the same bits with any
//! `--kernel`). Fused multiply-adds and the 14-bit reciprocal estimates with Newton steps were
//! faster (the divider is one per core) but gave other bits than every CPU without AVX-512.
//!
//! Soundness: the operations execute AVX-512F instructions. `F8` is private to the batch module
//! and operated on only inside `batch::w8`'s kernel, whose one entry runs after
//! `is_x86_feature_detected!("avx512f")` (see `batch::w8::LaneGroup::update`); the operations
//! are inlined into that entry, which is compiled with the feature.
use std::arch::x86_64::{
    __m256i, __m512d, __m512i, _mm256_add_epi32, _mm256_and_si256, _mm256_cmpgt_epi32,
    _mm256_i32gather_epi32, _mm256_movemask_epi8, _mm256_set1_epi32, _mm256_setr_epi32,
    _mm512_abs_pd, _mm512_add_pd, _mm512_castpd_si512, _mm512_castsi512_pd, _mm512_cmp_pd_mask,
    _mm512_div_pd, _mm512_i32gather_pd, _mm512_mask_blend_pd, _mm512_max_pd, _mm512_min_pd,
    _mm512_mul_pd, _mm512_set1_epi64, _mm512_set1_pd, _mm512_sqrt_pd, _mm512_sub_pd,
    _mm512_xor_si512, _CMP_EQ_OQ, _CMP_GE_OQ, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _CMP_UNORD_Q,
};
use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Not, Sub, SubAssign};

/// Elements per group.
pub const LANES: usize = 8;

/// The points of one corner of a group's elements ([`F8::corner`]), as 32-bit offsets into a
/// flattened array of `len` points.
#[derive(Clone, Copy)]
pub struct Corner8 {
    offsets: __m256i,
    len: usize,
}

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

    /// The offsets 3 n of the points n = `conn[l][c]` of corner `c` of the elements `conn[..8]`
    /// in a flattened array of `len` points: the eight node numbers by one 32-bit gather (the
    /// connectivity rows are 32 bytes apart; building the vector from eight scalar writes
    /// stalled each time on the store forwarding of the vector read: about 40 % of a group's
    /// load). Panics when `conn` has fewer than eight elements, `c` is not a corner, a node is
    /// not below `len`, or `len` is 2^31 / 3 or more (32-bit offsets).
    #[inline(always)]
    pub fn corner(conn: &[[u32; 8]], c: usize, len: usize) -> Corner8 {
        assert!(conn.len() >= LANES && c < 8, "eight elements, corner 0..8");
        assert!(
            len <= i32::MAX as usize / 3,
            "fewer than 2^31 / 3 points (32-bit offsets)"
        );
        // SAFETY: AVX-512F (and the AVX2 it implies) as in `avx512!`. The index gather reads
        // conn[l][c], l < 8, inside `conn` (checked above: rows of eight u32, 32 bytes apart).
        unsafe {
            let rows = _mm256_setr_epi32(0, 8, 16, 24, 32, 40, 48, 56);
            let nodes = _mm256_i32gather_epi32::<4>(conn.as_ptr().cast::<i32>().add(c), rows);
            let below = _mm256_cmpgt_epi32(_mm256_set1_epi32(len as i32), nodes);
            let nonneg = _mm256_cmpgt_epi32(nodes, _mm256_set1_epi32(-1));
            let ok = _mm256_movemask_epi8(_mm256_and_si256(below, nonneg));
            assert!(ok == -1, "a node index beyond the points");
            Corner8 {
                offsets: _mm256_add_epi32(nodes, _mm256_add_epi32(nodes, nodes)),
                len,
            }
        }
    }

    /// The vectors of `ys` at the points of `at`, component by component: three AVX-512
    /// gathers. Panics when `ys` is not as long as the `len` `at` was checked against.
    #[inline(always)]
    pub fn gather(ys: &[[f64; 3]], at: Corner8) -> [F8; 3] {
        assert_eq!(
            ys.len(),
            at.len,
            "the points the corner was checked against"
        );
        let y = ys.as_flattened().as_ptr();
        // SAFETY: AVX-512F as in `avx512!`; every offset is 3 n with n < len = ys.len()
        // (checked in `corner` and above), so the doubles 3 n + k (k < 3) lie inside `ys`.
        unsafe {
            [
                val(_mm512_i32gather_pd::<8>(at.offsets, y)),
                val(_mm512_i32gather_pd::<8>(at.offsets, y.add(1))),
                val(_mm512_i32gather_pd::<8>(at.offsets, y.add(2))),
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

    /// The minimum instruction, `self` first (its second operand where either is NaN).
    #[inline(always)]
    fn min_instr(self, o: F8) -> F8 {
        val(avx512!(_mm512_min_pd(reg(self), reg(o))))
    }

    /// The maximum instruction, `self` first (its second operand where either is NaN).
    #[inline(always)]
    fn max_instr(self, o: F8) -> F8 {
        val(avx512!(_mm512_max_pd(reg(self), reg(o))))
    }

    /// `a` in the lanes where `m` holds, `b` in the others.
    #[inline(always)]
    pub fn select(m: M8, a: F8, b: F8) -> F8 {
        val(avx512!(_mm512_mask_blend_pd(m.0, reg(b), reg(a))))
    }
}

arithmetic_ops!(
    F8,
    _mm512_set1_pd,
    _mm512_add_pd,
    _mm512_sub_pd,
    _mm512_mul_pd,
    _mm512_div_pd
);
derived_ops!(F8, M8);

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
