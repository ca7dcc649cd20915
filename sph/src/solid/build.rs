//! Which build of the solid pair loops runs: the same source compiled for the baseline x86-64
//! (SSE2, two lanes per register), for AVX2 (four) or for AVX-512F (eight), chosen at run time.
//!
//! The pair loops add each pair's terms to exact sums lane by lane (16 lanes per entry in the
//! gradient pass, 4 in the force pass: `(r + C) - C`, `r - t`, `fold + t` on each): the wider
//! builds do the same IEEE operations, each lane's in the same order, in fewer instructions.
//! No build contracts a multiply and an add into an FMA (Rust never does; the source has no
//! `mul_add`), every operation is a correctly rounded add, subtract, multiply, divide or square
//! root, min or max: each build gives the same bits (docs/scene.md "One answer"), checked by
//! the tests below and by the scene digests with `--kernel scalar` (baseline) against
//! `--kernel auto`.

/// A build of the pair loops.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Build {
    /// The baseline x86-64 (and every other target).
    #[default]
    Baseline,
    /// AVX2 (x86-64).
    Avx2,
    /// AVX-512F (x86-64).
    Avx512,
}

impl Build {
    /// The widest build this CPU runs.
    pub fn widest() -> Build {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                return Build::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                return Build::Avx2;
            }
        }
        Build::Baseline
    }

    /// The builds this CPU runs, narrowest first (the tests compare them).
    pub fn available() -> Vec<Build> {
        let mut v = vec![Build::Baseline];
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                v.push(Build::Avx2);
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                v.push(Build::Avx512);
            }
        }
        v
    }
}

/// Defines `$name(build, args)`, which runs the `#[inline(always)]` function `$inner` (args)
/// compiled for `build` (the baseline where the CPU lacks the build's features).
macro_rules! builds {
    ($(#[$doc:meta])* $name:ident, $inner:path, ($($a:ident: $t:ty),*) -> $r:ty) => {
        $(#[$doc])*
        #[inline]
        #[allow(clippy::too_many_arguments)]
        fn $name(build: $crate::solid::build::Build, $($a: $t),*) -> $r {
            #[cfg(target_arch = "x86_64")]
            {
                use $crate::solid::build::Build;
                /// `$inner` compiled for AVX2 (four lanes per register).
                #[target_feature(enable = "avx2")]
                #[allow(clippy::too_many_arguments)]
                fn avx2($($a: $t),*) -> $r {
                    $inner($($a),*)
                }
                /// `$inner` compiled for AVX-512F (eight lanes per register).
                #[target_feature(enable = "avx512f")]
                #[allow(clippy::too_many_arguments)]
                fn avx512($($a: $t),*) -> $r {
                    $inner($($a),*)
                }
                match build {
                    Build::Avx512 if std::arch::is_x86_feature_detected!("avx512f") => {
                        // SAFETY: the CPU has AVX-512F, checked just above.
                        return unsafe { avx512($($a),*) };
                    }
                    Build::Avx2 if std::arch::is_x86_feature_detected!("avx2") => {
                        // SAFETY: the CPU has AVX2, checked just above.
                        return unsafe { avx2($($a),*) };
                    }
                    _ => {}
                }
            }
            let _ = build;
            $inner($($a),*)
        }
    };
}
pub(crate) use builds;
