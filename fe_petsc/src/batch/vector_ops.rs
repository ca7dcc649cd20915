//! What the two intrinsics lane types (`lanes4.rs`: AVX2, `lanes8.rs`: AVX-512) derive the same
//! way from their own few instructions: the arithmetic operators, the comparisons, `min`,
//! `max`, `clamp`, `is_finite`, the reciprocals and the unfused multiply-adds. Each module
//! names its register type's conversions `reg` and `val`, its broadcast, and the instructions
//! below (`cmp`, `sqrt`, `abs`, `select`, `min_instr`, `max_instr`); the macros expand there,
//! so every operation is the module's own instruction, the same IEEE operation in every width.

/// `Add`, `Sub`, `Mul`, `Div` (with `f64` on either side) and their assignments on the lane
/// type `$F`: each one instruction `$add` .. `$div`, a scalar broadcast by `$set1`.
macro_rules! arithmetic_ops {
    ($F:ident, $set1:ident, $add:ident, $sub:ident, $mul:ident, $div:ident) => {
        arithmetic_ops!(@op $F, $set1, Add, add, AddAssign, add_assign, $add);
        arithmetic_ops!(@op $F, $set1, Sub, sub, SubAssign, sub_assign, $sub);
        arithmetic_ops!(@op $F, $set1, Mul, mul, MulAssign, mul_assign, $mul);
        arithmetic_ops!(@op $F, $set1, Div, div, DivAssign, div_assign, $div);
    };
    (@op $F:ident, $set1:ident, $tr:ident, $f:ident, $tra:ident, $fa:ident, $intr:ident) => {
        impl $tr for $F {
            type Output = $F;
            #[inline(always)]
            fn $f(self, o: $F) -> $F {
                // SAFETY: the lane type is operated on only inside its width's kernel, built
                // with and run after the check of its instructions (the module's note).
                val(unsafe { $intr(reg(self), reg(o)) })
            }
        }
        impl $tr<f64> for $F {
            type Output = $F;
            #[inline(always)]
            fn $f(self, o: f64) -> $F {
                // SAFETY: as above.
                val(unsafe { $intr(reg(self), $set1(o)) })
            }
        }
        impl $tr<$F> for f64 {
            type Output = $F;
            #[inline(always)]
            fn $f(self, o: $F) -> $F {
                // SAFETY: as above.
                val(unsafe { $intr($set1(self), reg(o)) })
            }
        }
        impl $tra for $F {
            #[inline(always)]
            fn $fa(&mut self, o: $F) {
                *self = $tr::$f(*self, o);
            }
        }
    };
}

/// The lane operations of `$F` (mask `$M`) built on its `cmp`, `sqrt`, `abs`, `select`,
/// `min_instr` and `max_instr`.
macro_rules! derived_ops {
    ($F:ident, $M:ident) => {
        impl $F {
            /// Lanes that are NaN.
            #[inline(always)]
            fn is_nan(self) -> $M {
                self.cmp::<_CMP_UNORD_Q>(self)
            }

            /// 1 / self, the IEEE quotient (as every width's).
            #[inline(always)]
            pub fn recip(self) -> $F {
                $F::splat(1.0) / self
            }

            /// 1 / sqrt(self) from the IEEE square root and quotient (as every width's).
            #[inline(always)]
            pub fn rsqrt(self) -> $F {
                $F::splat(1.0) / self.sqrt()
            }

            /// Lane-wise `f64::min`: a NaN lane takes the other operand. (The instruction
            /// returns its second operand when either is NaN: `o` first makes a NaN `o` give
            /// `self`, and the blend makes a NaN `self` give `o`.)
            #[inline(always)]
            pub fn min(self, o: $F) -> $F {
                $F::select(self.is_nan(), o, o.min_instr(self))
            }

            /// Lane-wise `f64::max`: a NaN lane takes the other operand (as `min`).
            #[inline(always)]
            pub fn max(self, o: $F) -> $F {
                $F::select(self.is_nan(), o, o.max_instr(self))
            }

            /// Lane-wise `f64::clamp` to [lo, hi] (NaN stays NaN).
            #[inline(always)]
            pub fn clamp(self, lo: f64, hi: f64) -> $F {
                let c = self.max($F::splat(lo)).min($F::splat(hi));
                $F::select(self.is_nan(), self, c)
            }

            /// Lanes where `self < o`.
            #[inline(always)]
            pub fn lt(self, o: $F) -> $M {
                self.cmp::<_CMP_LT_OQ>(o)
            }

            /// Lanes where `self <= o`.
            #[inline(always)]
            pub fn le(self, o: $F) -> $M {
                self.cmp::<_CMP_LE_OQ>(o)
            }

            /// Lanes where `self > o`.
            #[inline(always)]
            pub fn gt(self, o: $F) -> $M {
                self.cmp::<_CMP_GT_OQ>(o)
            }

            /// Lanes where `self >= o`.
            #[inline(always)]
            pub fn ge(self, o: $F) -> $M {
                self.cmp::<_CMP_GE_OQ>(o)
            }

            /// Lanes where `self == o`.
            #[inline(always)]
            pub fn eq(self, o: $F) -> $M {
                self.cmp::<_CMP_EQ_OQ>(o)
            }

            /// Lanes that are finite (|x| < infinity is false for NaN and infinities).
            #[inline(always)]
            pub fn is_finite(self) -> $M {
                self.abs().lt($F::splat(f64::INFINITY))
            }

            twice_rounded_ops!($F);
        }
    };
}
