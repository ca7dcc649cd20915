//! The material laws with a lane form ([`crate::material::LaneLaw`]) in lanes: in each lane what
//! the model's [`crate::material::Material::update_stress`] computes for its element, the same
//! operations in the same order, the radial return's branch as a masked lane operation.
use super::F;
use crate::hourglass::THIRD;
use crate::material::LaneLaw;

/// Writes into `stress` (lanes of Voigt stresses, already rotated) the stress after the strain
/// increments `deps`, and updates the history variable `history` (the plastic strain of J2;
/// unused by the elastic law). Elastic: 12 flops; J2: about 60 more with the return taken in
/// the lanes that flow (f > 0) and the trial stress kept in the others.
#[inline(always)]
pub(super) fn update_stress(law: &LaneLaw, stress: &mut [F; 6], history: &mut F, deps: &[F; 6]) {
    match law {
        LaneLaw::Elastic(m) => add_elastic(stress, deps, m.lambda, m.mu),
        LaneLaw::J2Plastic(m) => {
            add_elastic(stress, deps, m.lambda, m.mu);
            let (s, p, q, iq) = deviator(stress);
            let f = q - (m.yield_stress + m.hardening * *history);
            let flow = f.gt(F::ZERO);
            let dgamma = f * m.inv_return;
            let scale = 1.0 - 3.0 * m.mu * dgamma * iq;
            for k in 0..3 {
                stress[k] = F::select(flow, s[k] * scale + p, stress[k]);
                stress[k + 3] = F::select(flow, s[k + 3] * scale, stress[k + 3]);
            }
            *history = F::select(flow, *history + dgamma, *history);
        }
        LaneLaw::Pointwise { .. } => unreachable!("a pointwise law runs lane by lane"),
    }
}

/// The current yield stress of each lane ([`crate::material::Material::yield_stress`]); `None`
/// for a law without a yield surface.
#[inline(always)]
pub(super) fn yield_stress(law: &LaneLaw, history: F) -> Option<F> {
    match law {
        LaneLaw::Elastic(_) => None,
        LaneLaw::J2Plastic(m) => Some(m.yield_stress + m.hardening * history),
        LaneLaw::Pointwise { .. } => unreachable!("a pointwise law runs lane by lane"),
    }
}

/// Hooke's increment (`material::add_elastic`) in lanes.
#[inline(always)]
fn add_elastic(stress: &mut [F; 6], deps: &[F; 6], lambda: f64, mu: f64) {
    let tr = deps[0] + deps[1] + deps[2];
    for k in 0..3 {
        stress[k] += lambda * tr + 2.0 * mu * deps[k];
        stress[k + 3] += 2.0 * mu * deps[k + 3];
    }
}

/// The deviator, the mean stress, the von Mises stress q (`material::deviator`) and 1/q in
/// lanes, q and 1/q from one reciprocal square root (`F::rsqrt`; a lane with no deviator gets
/// NaN for both and does not flow: NaN > 0 is false).
#[inline(always)]
fn deviator(s: &[F; 6]) -> ([F; 6], F, F, F) {
    let p = (s[0] + s[1] + s[2]) * THIRD;
    let d = [s[0] - p, s[1] - p, s[2] - p, s[3], s[4], s[5]];
    let j2 =
        0.5 * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) + d[3] * d[3] + d[4] * d[4] + d[5] * d[5];
    let x = 3.0 * j2;
    let iq = x.rsqrt();
    (d, p, x * iq, iq)
}
