//! The grids of the pair sums: each particle's force, energy rate and density (rate) are summed
//! exactly ([`binsum`], binned summation), so they do not depend on the order of the pairs, on
//! which rank computed a pair (the centre-of-interaction rule) or on how the ghosts' partial sums
//! are added to their owners: the same bits at any rank count (docs/scene.md, "One answer").
//!
//! Why exact sums and not a fixed order: a fixed order (each particle's terms sorted by the
//! partner's id) would need every pair term sent to the owner one by one, where today a ghost
//! sends one partial sum; exact sums keep the fold-back one record per ghost (two doubles per
//! value in place of one) and cost about eight flops per term.
//!
//! Two folds 40 bits apart ([`binsum::Grid2`]), one grid per quantity q (force component terms,
//! density or density-rate terms, energy-rate terms), the same on every rank: chosen from the
//! largest term `M` of the previous pass, reduced over ranks (a maximum is exact in any order),
//! as the grid covering `M K 2^(HEADROOM_BITS + 1)` with `K = MAX_PARTNERS`. A pass is accepted
//! when its own largest term `M'` (reduced) lies within `M 2^-SHRINK_BITS <= M' <= M
//! 2^HEADROOM_BITS`; otherwise the pass is redone on the grid fitted to `M'` (the first pass of
//! a run always, else only where a term grows 256-fold in one step). Accepted, each term is
//! below half the top fold's cover and every particle's sum of at most `K` terms below its
//! cover, and the lower fold holds up to `2^14` terms: the sums are exact (see [`binsum`]),
//! resolved to `2^-92` of the cover: at worst `2^-53` of the largest term anywhere (about
//! `2^-69` right after a fit), as fine as a plain sum's rounding for every particle whose own
//! terms are within `2^-20` of the largest. A particle with more than `K` partners is an error
//! (the stage counts them).
use binsum::{ceil_log2, pow2, Folds2, Grid2};

/// The most pair terms one particle's sum may have (partners on every rank together).
pub const MAX_PARTNERS: f64 = (1u64 << 13) as f64;
/// How far a pass's largest term may grow over the grid's before the pass is redone (bits).
pub const HEADROOM_BITS: i32 = 8;
/// How far a pass's largest term may shrink below the grid's before it is redone (bits).
pub const SHRINK_BITS: i32 = 16;

/// The quantities of the pair sums, as indices of [`TermMax`] and [`PassGrids::grid`].
pub mod q {
    /// Force component terms, N.
    pub const FORCE: usize = 0;
    /// Density terms (summation, kg/m^3) or density-rate terms (continuity, kg/(m^3 s)).
    pub const DENSITY: usize = 1;
    /// Specific internal-energy-rate terms, W/kg.
    pub const ENERGY: usize = 2;
}

/// The largest magnitude of the terms a pass added, per quantity ([`q`]); 0 where none.
pub type TermMax = [f64; 3];

/// The grids of the three quantities and the largest terms they were fitted to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassGrids {
    grid: [Grid2; 3],
    /// The largest term each grid was fitted to (0: not fitted yet).
    fitted: TermMax,
}

impl Default for PassGrids {
    /// Not fitted: every grid covers terms up to 1 (the first pass fits them).
    fn default() -> PassGrids {
        PassGrids {
            grid: [Grid2::covering(1.0); 3],
            fitted: [0.0; 3],
        }
    }
}

impl PassGrids {
    /// The grid of quantity `q` ([`q`]).
    #[inline(always)]
    pub fn grid(&self, q: usize) -> &Grid2 {
        &self.grid[q]
    }

    /// The largest terms the grids were fitted to (saved with a restart).
    pub fn fitted(&self) -> TermMax {
        self.fitted
    }

    /// Grids fitted to `m` (from [`PassGrids::fitted`] of a saved run).
    pub fn fitted_to(m: TermMax) -> PassGrids {
        let mut g = PassGrids::default();
        g.refit(&m);
        g
    }

    /// Whether a pass whose largest terms (over every rank) were `m` is exact on these grids
    /// and resolved finely enough (module docs). A quantity without terms, or with a term that
    /// is not finite (the run's checks stop it), is accepted.
    pub fn accepts(&self, m: &TermMax) -> bool {
        (0..3).all(|k| {
            let (now, fit) = (m[k], self.fitted[k]);
            if !(now.is_finite() && now > 0.0) {
                return true;
            }
            fit > 0.0 && now <= fit * pow2(HEADROOM_BITS) && now >= fit * pow2(-SHRINK_BITS)
        })
    }

    /// Refits the grid of each quantity with terms in `m` to them (the others stay).
    pub fn refit(&mut self, m: &TermMax) {
        for (k, &now) in m.iter().enumerate() {
            if now.is_finite() && now > 0.0 {
                // cover M K 2^H, then one more doubling: every term below half the cover
                let e = ceil_log2(now * MAX_PARTNERS) + HEADROOM_BITS + 1;
                self.grid[k] = Grid2::covering(pow2(e));
                self.fitted[k] = now;
            }
        }
    }
}

/// Runs `pass` until its sums are exact: `pass` resets the sums it adds to and adds them,
/// recording its largest terms in the `TermMax` it is given; `reduce` gives the maximum over
/// every rank (collective: every rank calls it equally often, and all take the same decision).
/// Returns what the accepted pass returned and how many passes were redone.
pub fn exact_pass<T>(
    grids: &mut PassGrids,
    mut reduce: impl FnMut(&TermMax) -> TermMax,
    mut pass: impl FnMut(&PassGrids, &mut TermMax) -> T,
) -> (T, u32) {
    let mut redone = 0;
    loop {
        let mut m = [0.0; 3];
        let out = pass(grids, &mut m);
        let m = reduce(&m);
        let ok = grids.accepts(&m);
        grids.refit(&m);
        if ok {
            return (out, redone);
        }
        redone += 1;
    }
}

/// Sets `m` to the larger of `m` and `|x|` (a max is exact: order free).
#[inline(always)]
pub fn note(m: &mut f64, x: f64) {
    *m = m.max(x.abs());
}

/// The value of each of three sums (force components).
#[inline]
pub fn values3(f: &[Folds2; 3]) -> [f64; 3] {
    [
        binsum::value2(&f[0]),
        binsum::value2(&f[1]),
        binsum::value2(&f[2]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pass_is_redone_until_its_terms_fit_and_then_kept() {
        let mut g = PassGrids::default();
        // terms of 1e6: the first pass fits, the second is accepted
        let mut calls = 0;
        let (_, redone) = exact_pass(
            &mut g,
            |m| *m,
            |_, m| {
                calls += 1;
                m[q::FORCE] = 1e6;
            },
        );
        assert_eq!((calls, redone), (2, 1));
        // within 2^8 above and 2^16 below: accepted; beyond: refused
        assert!(g.accepts(&[1e6 * 255.0, 0.0, 0.0]));
        assert!(g.accepts(&[1e6 / 65535.0, 0.0, 0.0]));
        assert!(!g.accepts(&[1e6 * 257.0, 0.0, 0.0]));
        assert!(!g.accepts(&[1e6 / 65537.0, 0.0, 0.0]));
        // a quantity without terms, or not finite, is accepted
        assert!(g.accepts(&[0.0, 0.0, f64::NAN]));
    }

    /// On an accepted grid, K terms of the largest size still sum exactly: the cover of the
    /// top fold is above K M 2^H (2^53 Q1 >= 2 cover).
    #[test]
    fn an_accepted_grid_covers_max_partners_terms_of_the_largest_size() {
        for m in [1e-9, 3.0, 7.7e12] {
            let g = PassGrids::fitted_to([m, m, m]);
            let q1 = pow2(g.grid(q::FORCE).top_exponent());
            let biggest = m * pow2(HEADROOM_BITS);
            assert!(biggest < pow2(51) * q1, "a term below half the cover");
            assert!(
                biggest * MAX_PARTNERS < pow2(53) * q1,
                "K terms below the cover"
            );
            // the resolution, 2^-104 of the cover, against the smallest accepted largest term
            let q3 = q1 * pow2(-52);
            assert!(
                q3 <= m * pow2(-SHRINK_BITS) * pow2(-58),
                "resolution {q3:e}"
            );
        }
    }
}
