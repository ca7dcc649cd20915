//! Four f64 lanes in one AVX2 register for the batched element kernel (`batch::w4` on x86-64):
//! the interface of [`super::lanes8`]'s eight lanes, each operation one or two AVX
//! instructions written with `std::arch` intrinsics.
//!
//! Why intrinsics and not four-lane arrays the compiler vectorises (what `fixed.rs` gives the
//! other architectures): on arrays, the masks are four bytes that each selection and each
//! `any`/`all` converts to and from a vector, the minimum and maximum are written lane by lane,
//! and the gathers are scalar inserts; with them the update took 139 ns per element in cache on
//! a Zen 4 (`examples/hex_bench`), more than twice the eight lanes' 61 ns on the same core,
//! whose 256-bit units give four lanes the same operations per cycle; with these, 78 ns. Here
//! a mask is a vector of all-ones or all-zeros lanes (what the comparisons give and the blend
//! takes), and a corner's values come by four 16-byte and four 8-byte loads and a transpose.
//!
//! Every operation is the IEEE operation of `f64` lane by lane, and the comparisons, `min`,
//! `max`, `clamp`, `abs` and negation treat NaN, infinities and signed zeros as `f64`'s do (the
//! operand orders are the eight lanes'). `mul_add`, `mul_sub` and `neg_mul_add` round twice (no
//! FMA), `recip` and `rsqrt` are the IEEE quotient and square root: the same operations, in the
//! same order, as every other width, so the same bits (docs/scene.md, "One answer").
//!
//! Soundness: the operations execute AVX2 instructions. `F4` is operated on only inside
//! `batch::w4`'s kernel, whose entries run after `is_x86_feature_detected!("avx2")` (see
//! `batch::avx2_only`); the operations are inlined into those entries, which are compiled with
//! the feature.
use std::arch::x86_64::{
    __m256d, _mm256_add_pd, _mm256_and_pd, _mm256_andnot_pd, _mm256_blendv_pd,
    _mm256_castpd128_pd256, _mm256_cmp_pd, _mm256_div_pd, _mm256_insertf128_pd, _mm256_max_pd,
    _mm256_min_pd, _mm256_movemask_pd, _mm256_mul_pd, _mm256_or_pd, _mm256_set1_pd, _mm256_sqrt_pd,
    _mm256_sub_pd, _mm256_unpackhi_pd, _mm256_unpacklo_pd, _mm256_xor_pd, _mm_load_sd,
    _mm_loadh_pd, _mm_loadu_pd, _CMP_EQ_OQ, _CMP_GE_OQ, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ,
    _CMP_TRUE_UQ, _CMP_UNORD_Q,
};
use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Not, Sub, SubAssign};

/// Elements per group.
pub const LANES: usize = 4;

/// The points of one corner of a group's elements ([`F4::corner`]), as offsets into a
/// flattened array of `len` points.
#[derive(Clone, Copy)]
pub struct Corner4 {
    offsets: [usize; LANES],
    len: usize,
}

/// Four f64 lanes (the layout of one AVX register).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(32))]
pub struct F4(pub [f64; LANES]);

/// A per-lane condition: all ones in a lane that holds, zeros in one that does not (what the
/// comparisons give and the blend reads).
#[derive(Clone, Copy, Debug)]
pub struct M4(__m256d);

/// One AVX or AVX2 instruction on registers (see the module's soundness note).
macro_rules! avx2 {
    ($e:expr) => {
        // SAFETY: executed only inside `batch::w4`'s kernel, after the CPU was found to have
        // AVX2 (module comment).
        unsafe { $e }
    };
}

impl M4 {
    /// The lanes' bits, bit l for lane l.
    #[inline(always)]
    fn bits(self) -> i32 {
        avx2!(_mm256_movemask_pd(self.0))
    }

    /// Whether any lane holds.
    #[inline(always)]
    pub fn any(self) -> bool {
        self.bits() != 0
    }

    /// Whether every lane holds.
    #[inline(always)]
    pub fn all(self) -> bool {
        self.bits() == 0b1111
    }

    /// Lane-wise or.
    #[inline(always)]
    pub fn or(self, o: M4) -> M4 {
        M4(avx2!(_mm256_or_pd(self.0, o.0)))
    }

    /// Lane-wise and.
    #[inline(always)]
    pub fn and(self, o: M4) -> M4 {
        M4(avx2!(_mm256_and_pd(self.0, o.0)))
    }
}

impl Not for M4 {
    type Output = M4;
    /// Lane-wise not.
    #[inline(always)]
    fn not(self) -> M4 {
        let ones = avx2!(_mm256_cmp_pd::<_CMP_TRUE_UQ>(self.0, self.0));
        M4(avx2!(_mm256_xor_pd(self.0, ones)))
    }
}

#[inline(always)]
fn reg(a: F4) -> __m256d {
    // SAFETY: F4 is 32 aligned bytes of four f64, the layout of __m256d.
    unsafe { std::mem::transmute::<F4, __m256d>(a) }
}

#[inline(always)]
fn val(a: __m256d) -> F4 {
    // SAFETY: as in `reg`.
    unsafe { std::mem::transmute::<__m256d, F4>(a) }
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

    /// The offsets 3 n of the points n = `conn[l][c]` of corner `c` of the elements `conn[..4]`
    /// in a flattened array of `len` points (four scalar loads: on Zen 3 and 4 an AVX2 gather
    /// of four indices costs more). Panics when `conn` has fewer than four elements, `c` is not
    /// a corner, or a node is not below `len`.
    #[inline(always)]
    pub fn corner(conn: &[[u32; 8]], c: usize, len: usize) -> Corner4 {
        // (written out, no `map`: a library generic taking a closure is not inlined into the
        // target-feature build, module `batch`)
        let n = [
            conn[0][c] as usize,
            conn[1][c] as usize,
            conn[2][c] as usize,
            conn[3][c] as usize,
        ];
        assert!(
            n[0] < len && n[1] < len && n[2] < len && n[3] < len,
            "a node index beyond the points"
        );
        Corner4 {
            offsets: [3 * n[0], 3 * n[1], 3 * n[2], 3 * n[3]],
            len,
        }
    }

    /// The vectors of `ys` at the points of `at`, component by component: each point's x and
    /// y by one 16-byte load and its z by one 8-byte load, then transposed into the three
    /// component vectors (on Zen 3 and 4 this is fewer operations than three AVX2 gathers).
    /// Panics when `ys` is not as long as the `len` `at` was checked against.
    #[inline(always)]
    pub fn gather(ys: &[[f64; 3]], at: Corner4) -> [F4; 3] {
        assert_eq!(
            ys.len(),
            at.len,
            "the points the corner was checked against"
        );
        let y = ys.as_flattened().as_ptr();
        // SAFETY: AVX2 as in `avx2!`; every offset is 3 n with n < len = ys.len() (checked in
        // `corner` and above), so the doubles 3 n + k (k < 3) lie inside `ys`.
        unsafe {
            let o = at.offsets;
            let (p0, p1, p2, p3) = (y.add(o[0]), y.add(o[1]), y.add(o[2]), y.add(o[3]));
            // (x0, y0, x2, y2) and (x1, y1, x3, y3).
            let a02 = _mm256_insertf128_pd::<1>(
                _mm256_castpd128_pd256(_mm_loadu_pd(p0)),
                _mm_loadu_pd(p2),
            );
            let a13 = _mm256_insertf128_pd::<1>(
                _mm256_castpd128_pd256(_mm_loadu_pd(p1)),
                _mm_loadu_pd(p3),
            );
            let z01 = _mm_loadh_pd(_mm_load_sd(p0.add(2)), p1.add(2));
            let z23 = _mm_loadh_pd(_mm_load_sd(p2.add(2)), p3.add(2));
            [
                val(_mm256_unpacklo_pd(a02, a13)),
                val(_mm256_unpackhi_pd(a02, a13)),
                val(_mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(z01), z23)),
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
    fn cmp<const P: i32>(self, o: F4) -> M4 {
        M4(avx2!(_mm256_cmp_pd::<P>(reg(self), reg(o))))
    }

    /// Lane-wise square root.
    #[inline(always)]
    pub fn sqrt(self) -> F4 {
        val(avx2!(_mm256_sqrt_pd(reg(self))))
    }

    /// Lane-wise absolute value (the sign bit cleared).
    #[inline(always)]
    pub fn abs(self) -> F4 {
        val(avx2!(_mm256_andnot_pd(_mm256_set1_pd(-0.0), reg(self))))
    }

    /// The minimum instruction, `self` first (its second operand where either is NaN).
    #[inline(always)]
    fn min_instr(self, o: F4) -> F4 {
        val(avx2!(_mm256_min_pd(reg(self), reg(o))))
    }

    /// The maximum instruction, `self` first (its second operand where either is NaN).
    #[inline(always)]
    fn max_instr(self, o: F4) -> F4 {
        val(avx2!(_mm256_max_pd(reg(self), reg(o))))
    }

    /// `a` in the lanes where `m` holds, `b` in the others.
    #[inline(always)]
    pub fn select(m: M4, a: F4, b: F4) -> F4 {
        val(avx2!(_mm256_blendv_pd(reg(b), reg(a), m.0)))
    }
}

arithmetic_ops!(
    F4,
    _mm256_set1_pd,
    _mm256_add_pd,
    _mm256_sub_pd,
    _mm256_mul_pd,
    _mm256_div_pd
);
derived_ops!(F4, M4);

impl Neg for F4 {
    type Output = F4;
    /// Lane-wise negation: the sign bit flipped, as `-x` on an f64 (so -0.0 from 0.0).
    #[inline(always)]
    fn neg(self) -> F4 {
        val(avx2!(_mm256_xor_pd(reg(self), _mm256_set1_pd(-0.0))))
    }
}
