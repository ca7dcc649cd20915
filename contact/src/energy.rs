//! The push-back's energy bookkeeping, one definition for every body (mesh nodes and
//! particles): the terms of the change of the half-step kinetic energy that the contact stage's
//! energy guard weighs, and the work a correction books in the step's energy balance. Each
//! body forms its own velocity correction, velocity and start acceleration (with its
//! constraints, in its own arithmetic) and hands the values here, one component at a time;
//! the bodies sum what these return on their own exact grids.

/// The share of the start kick `(dt/2) a(n)` that a contact correction `dv` is booked against,
/// as a multiple of `dt a(n)`: a node (or particle) the push-back or a wall also corrected in
/// the last step books `m dv . (v(n) + dv/2)`, one met first in this step `m dv . (v(n) +
/// (dt/4) a(n) + dv/2)` (`pushed`: bit 0 set when corrected in the last step).
///
/// Why. Velocity Verlet with an impulse `dv` between the kicks changes the full-step kinetic
/// energy by `dK = W_trapezoid + m dv . (v(n) + dv/2) + m (|q|^2 - |p|^2) / 2`, with `p = (dt/2)
/// a(n)` and `q = (dt/2) a(n+1)` the two half kicks; the last term is the integrator's own
/// O(dt^2) difference between the full-step kinetic energy and a conserved one, which
/// telescopes over the steps and is the energy error of any explicit run. For a pair pressed
/// together (the contact force balancing `m a`), `v(n)` is not the pair's motion: the closing
/// kick left it `p` into the face, and every step the push-back takes `2p` out again at no
/// work (`dv = -2p`, `m dv . (v(n) + dv/2) = 0`). That full-step `p` is a kinetic energy
/// `m |p|^2 / 2` no motion makes; it appears the step the pressing starts (from rest: `v(n) =
/// 0`, `dv = -p`, booked work `m |p|^2 / 2`, i.e. contact would give it) and leaves through
/// the telescoping term when the pressing stops. Booking a pair's first correction against
/// `v(n) + p/2` (the trapezoid's share of the start kick) takes nothing at that onset (`m (-p)
/// . (p/2 - p/2) = 0`) and leaves the inelastic impact's loss unchanged to first order (`v(n)
/// = V` into the face, `p = 0`: `m V^2 / 2`); the onset's `m |p|^2 / 2` then stays with the
/// integrator's telescoping term in the energy error (history.csv `energy_error`), where the
/// pressed pair's full-step kinetic energy sits, instead of in `contact_energy`, which only
/// takes energy (docs/scene.md). A particle the immovable faces held at the end of the last
/// step (`SphStage::hold_on_faces` in `coupling`) starts as one met first: the hold took that
/// kick. Measured on `underwater_explosion` (detonation products pressed on their cavity from
/// rest): with every correction booked against `v(n)` (and the hold booked on its own) the
/// first row's `contact_energy` fell 143 J, 1.28e-3 of the energy scale; booked so, its
/// largest fall between rows is 1.2e-5 and the energy error's largest value 1.65 % (1.44 %
/// before: the onset's kinetic energy moved there), the motion the same bits.
pub fn booked_kick(pushed: u8) -> f64 {
    if pushed & 1 == 0 {
        0.25
    } else {
        0.5
    }
}

/// One component's terms `[m dv v, m dv^2 / 2]` of the change of the half-step kinetic energy
/// that a velocity correction `dv` of a node of mass `m` moving at the half-step velocity `v`
/// makes: for the correction scaled by `alpha`, `dK(alpha) = alpha A + alpha^2 B` with `A` the
/// sum of the first terms and `B` of the second over nodes and components (J). The contact
/// stage's energy guard weighs them (`coupling`'s `energy_guard`).
pub fn half_step_terms(m: f64, dv: f64, v: f64) -> [f64; 2] {
    [m * dv * v, 0.5 * m * dv * dv]
}

/// One component of the work a contact correction `dv` of a node of mass `m` books in the
/// step's energy balance, with `v` its half-step velocity before the correction and
/// `start_kick` the booked share of the start kick, `booked_kick(pushed) dt a(n)` as the body
/// forms its start acceleration `a(n)` (J).
///
/// The change of the half-step kinetic energy, less the part of the start kick that the
/// element, pair, external and gravity work (trapezoids over the corrected displacement)
/// already count: velocity Verlet with an impulse `dv` between the kicks gives `dKE =
/// W_trapezoid + m dv . (v + dv/2) - (dt/2) m a(n) . dv`; a node the push-back meets first
/// books half of that kick ([`booked_kick`]).
pub fn booked_work(m: f64, dv: f64, v: f64, start_kick: f64) -> f64 {
    m * dv * (v + 0.5 * dv - start_kick)
}

/// One component of the work a contact correction does on a constrained node of mass `m`
/// moving at its half-step velocity `v` (a `velocity` node's prescribed one), where its
/// constraints removed `removed` of the correction `F dt / m` (J): `m removed v`, `F . v dt`.
/// The node's motion does not change (its reaction takes the impulse, and its work, the
/// opposite, is external work), but the contact force works on it: a face driven into a free
/// node gives the node kinetic energy, `m dv . (v + dv/2)` in [`booked_work`], that the
/// driven corners' share takes back. The pair's total is then what contact takes (a free node
/// of mass `m` at rest met by an immovable face at speed `V`: `m V^2 / 2 - m V^2 = -m V^2 /
/// 2`, an inelastic impact's loss), not the boundary's work through the face, which booked on
/// the free node alone reads as contact giving energy back. Counted in the energy guard's
/// first term too (`half_step_terms`' `A`).
pub fn constrained_work(m: f64, removed: f64, v: f64) -> f64 {
    m * removed * v
}
