//! One Gauss-Seidel sweep over the rows of a geometric pass, colour by colour, with Coulomb
//! friction on the tangential impulses.
use super::*;

/// The index ranges of the colours' runs in the sweep order.
pub(super) fn colour_ranges(
    ends: &[usize; COLOURS],
) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
    (0..COLOURS).map(|c| if c == 0 { 0 } else { ends[c - 1] }..ends[c])
}

/// The rows of one geometric pass with the impulses at its start.
pub(super) struct Pass<'a> {
    pub(super) rows: &'a [Row],
    pub(super) start: &'a [V3],
    pub(super) inv_m: &'a [f64],
}

impl Pass<'_> {
    /// Penetration left by row `r` with impulses `impulse`:
    /// `d - n . sum_j w_j (I_j - I0_j) / m_j`.
    pub(super) fn left(&self, r: &Row, impulse: &[V3]) -> f64 {
        let mut opened = 0.0;
        for q in 0..r.len {
            let j = r.nodes[q];
            opened += r.w[q] * self.inv_m[j] * dot(r.normal, sub(impulse[j], self.start[j]));
        }
        r.depth - opened
    }

    /// The largest residual: penetration left, or separation where the impulse is positive.
    pub(super) fn residual(&self, lambda: &[f64], impulse: &[V3]) -> f64 {
        self.rows.iter().zip(lambda).fold(0.0, |a: f64, (r, &l)| {
            let res = self.left(r, impulse);
            a.max(if l > 0.0 { res.abs() } else { res.max(0.0) })
        })
    }

    /// Row `k`'s Gauss-Seidel update: its impulse from its residual, kept non-negative.
    pub(super) fn update(&self, k: usize, lambda: &mut [f64], impulse: &mut [V3]) {
        let r = &self.rows[k];
        if r.inv_mass.is_nan() || r.inv_mass <= 0.0 {
            return;
        }
        let new = (lambda[k] + self.left(r, impulse) / r.inv_mass).max(0.0);
        let step = new - lambda[k];
        lambda[k] = new;
        for q in 0..r.len {
            axpy(&mut impulse[r.nodes[q]], r.rw[q] * step, r.normal);
        }
    }
}

/// The sweep order and its colours' runs.
#[derive(Clone, Copy)]
pub(super) struct Sweep<'a> {
    pub(super) order: &'a [usize],
    pub(super) ends: &'a [usize; COLOURS],
}

/// The friction impulses (module documentation, "Friction") on top of the normal ones: sweeps
/// over the contacts, colour by colour, until the tangential slips of the sticking contacts are
/// gone to `tol` of the largest slip, or `max_sweeps`. Updates the accumulated impulses;
/// returns the sweeps done.
#[allow(clippy::too_many_arguments)]
pub(super) fn friction(
    b: &ContactBox,
    rows: &[Row],
    sweep: Sweep,
    lambda_n: &[f64],
    params: &PushBackParams,
    inv_m: &[f64],
    impulse: &mut [V3],
    ex: &mut dyn Exchange,
) -> usize {
    let slip_of = |r: &Row, impulse: &[V3]| -> V3 {
        let mut s = [0.0; 3];
        for q in 0..r.len {
            let j = r.nodes[q];
            let moved = add(
                sub(b.nodes.x1[j], b.nodes.x0[j]),
                scale(impulse[j], inv_m[j]),
            );
            axpy(&mut s, r.w[q], moved);
        }
        sub(s, scale(r.normal, dot(s, r.normal)))
    };
    let norm = |v: V3| dot(v, v).sqrt();
    let mut lambda_t = vec![[0.0; 3]; rows.len()];
    let largest = ex.max(
        rows.iter()
            .map(|r| norm(slip_of(r, impulse)))
            .fold(0.0, f64::max),
    );
    let limit = params.tol * largest;
    let mut sweeps = 0;
    while sweeps < params.max_sweeps {
        let mut change = 0.0f64;
        for (colour, range) in colour_ranges(sweep.ends).enumerate() {
            for &k in &sweep.order[range] {
                let r = &rows[k];
                let cap = params.friction * lambda_n[k];
                if r.inv_mass.is_nan() || r.inv_mass <= 0.0 || cap.is_nan() || cap <= 0.0 {
                    continue;
                }
                // The impulse that stops this contact's slip, added to what it has, kept
                // inside the friction disc |lambda_t| <= mu lambda_n.
                let slip = slip_of(r, impulse);
                let want = sub(lambda_t[k], scale(slip, 1.0 / r.inv_mass));
                let size = norm(want);
                let new = if size > cap {
                    scale(want, cap / size)
                } else {
                    want
                };
                let step = sub(new, lambda_t[k]);
                lambda_t[k] = new;
                for q in 0..r.len {
                    axpy(&mut impulse[r.nodes[q]], r.rw[q], step);
                }
                change = change.max(norm(step) * r.inv_mass);
            }
            ex.sync(colour, impulse);
        }
        sweeps += 1;
        if ex.max(change) <= limit {
            break;
        }
    }
    sweeps
}
