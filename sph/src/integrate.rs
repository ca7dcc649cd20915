//! Time integration of the owned particles in two halves around the passes:
//!
//! ```text
//! first_half(dt)   move: rates of the previous evaluation
//! ... ghosts, pairs, density pass, EOS, force pass, gravity (see `passes`) ...
//! second_half(dt)  finish the step with the new rates
//! ```
//!
//! `Profile::Liggghts` is LIGGGHTS 3.8.0's `fix nve/sph` (and `nve/sph/stationary` for fixed
//! particles), with f and drho/dt from step n-1:
//!
//! ```text
//! first:  rho += dt drho;  v^ = v + dt f/m;  v += dt/2 f/m;  x += dt v      (fixed: rho only)
//! second: v += dt/2 f/m
//! ```
//!
//! With the energy equation on, e is advanced like rho (Euler, e += dt de), an extension.
//!
//! `Profile::Standard` is a kick-drift-kick leapfrog (velocity Verlet) in which density and
//! energy are kicked like the velocity, and the passes see predicted end-of-step values:
//!
//! ```text
//! first:  v += dt/2 a;  x += dt v;  v^ = v + dt/2 a               (v^ predicts v at n+1)
//!         rho_half = rho + dt/2 drho;  rho = rho_half + dt/2 drho  (predicted rho at n+1)
//!         e_half   = e   + dt/2 de;    e   = e_half   + dt/2 de    (energy equation on)
//! second: v += dt/2 a;  rho = rho_half + dt/2 drho;  e = e_half + dt/2 de;  EOS (p, c)
//! ```
//!
//! Second order in dt (the predictor errors are O(dt^2) in the rates). Fixed particles update
//! rho and e, never x or v (their v^ = v). With `Params::adaptive_h`, h = eta (m/rho)^(1/3) is
//! reset after the EOS of the second half, for the next step's search and passes.
//!
//! In both profiles, when the energy equation is off the pair work per unit mass is accumulated
//! in `work` by the trapezoidal rule (dt/2 de in each half), so that kinetic + sum m (e + work)
//! is the conserved total.
use crate::params::{DensityMode, Params, Profile};
use crate::particles::Particles;
use crate::passes::update_eos;

/// Courant factor of the SPH stable step (docs/scene.md): dt = 0.3 min h/(c + |v|).
pub const CFL_FACTOR: f64 = 0.3;

/// The SPH stable step over the owned particles, 0.3 min h/(c + |v|) (infinite when there are
/// none or all are at rest with c = 0).
pub fn stable_dt(p: &Particles) -> f64 {
    let mut dt = f64::INFINITY;
    for i in 0..p.n_owned {
        let v = p.v[i];
        let vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        // sqrt(0) = 0: a particle at rest (a fixed wall's) skips the square root.
        let speed = p.c[i] + if vv == 0.0 { 0.0 } else { vv.sqrt() };
        if speed > 0.0 {
            dt = dt.min(CFL_FACTOR * p.h[i] / speed);
        }
    }
    dt
}

/// Books the work of this step's pair forces at the velocity the step ends with (standard
/// profile; after `second_half` and any hold of a face or wall on the closing kick): for each
/// owned moving particle, with f the pair force (the force pass's, the particle's weight taken
/// off), v its velocity after the closing half-kick and v^ the rates' velocity the passes took,
///
/// ```text
/// rate = -f . (v - v^) / m                                            W/kg
/// de += rate;   e += (dt/2) rate (energy equation on: the EOS is run again), else
///               work += (dt/2) rate                                    J/kg
/// ```
///
/// Why: the passes' energy rate is the forces' power at v^ = v(n+1/2) + (dt/2) a(n), the
/// velocity predicted with the last step's acceleration (`Particles::vhat`), booked for the
/// closing half of the step and the opening half of the next. With velocity Verlet,
/// v(n+1/2) - v(n-1/2) = dt f(n) / m and v(n) = (v(n-1/2) + v(n+1/2)) / 2, so
/// dt f(n) . v(n) = m (|v(n+1/2)|^2 - |v(n-1/2)|^2) / 2 exactly: work booked at v(n) is the
/// kinetic energy the forces took, step by step, with nothing left over. At v^ instead each
/// step books dt f(n) . (v^ - v)(n) = dt^2 f(n) . (a(n-1) - a(n)) / 2 more, whose sum over a
/// run grows with |f(n) - f(n-1)|^2 and does not telescope. Measured at the default step:
/// a block of elastic particles stopped by a rigid wall booked 17 % more internal energy than
/// its motion lost, and water dropped at 10 m/s on a rigid floor (sound speed 100 m/s) 15 %
/// once its splash broke up, until the energy check stopped the runs; booked at v(n), 0.6 %
/// and 0.3 %. The forces and the motion are unchanged (with the energy equation on, e and so
/// the pressure move by this term, O(dt^2) a step). The LIGGGHTS profile keeps LIGGGHTS's
/// booking (its e and the energies `tdyn crosscheck` compares).
pub fn book_work_at_step_velocity(p: &mut Particles, params: &Params, dt: f64) {
    if params.profile != Profile::Standard {
        return;
    }
    for i in 0..p.n_owned {
        if p.fixed[i] {
            continue;
        }
        let m = p.m[i];
        let mut power = 0.0;
        for (c, g) in params.gravity.iter().enumerate() {
            let f = p.f[i][c] - m * g;
            power -= f * (p.v[i][c] - p.vhat[i][c]);
        }
        let rate = power / m;
        p.de[i] += rate;
        if params.energy {
            p.e[i] += 0.5 * dt * rate;
        } else {
            p.work[i] += 0.5 * dt * rate;
        }
    }
    if params.energy {
        update_eos(p, params);
    }
}

/// Prepares the owned particles for the set-up evaluation (before step 1).
/// LIGGGHTS: v^ = 0, p = 0, drho/dt = 0, f = 0 (its state when the set-up forces are
/// computed), c = the material sound speed. Standard: v^ = v, rho_half = rho, e_half = e, and
/// p, c from the EOS. Then the caller runs the passes (see
/// `Profile::setup_evaluates_density_and_eos`).
pub fn setup_state(p: &mut Particles, params: &Params) {
    let n = p.n_owned;
    for i in 0..n {
        p.drho[i] = 0.0;
        p.de[i] = 0.0;
        p.f[i] = [0.0; 3];
        p.rho_half[i] = p.rho[i];
        p.e_half[i] = p.e[i];
    }
    update_eos(p, params);
    match params.profile {
        Profile::Liggghts => {
            for i in 0..n {
                p.vhat[i] = [0.0; 3];
                p.p[i] = 0.0;
            }
        }
        Profile::Standard => {
            for i in 0..n {
                p.vhat[i] = p.v[i];
            }
        }
    }
}

/// The first half of a step on the owned particles (see the module doc), then, with a periodic
/// box, wraps their positions into it.
pub fn first_half(p: &mut Particles, dt: f64, params: &Params) {
    let continuity = params.density == DensityMode::Continuity;
    let half = 0.5 * dt;
    for i in 0..p.n_owned {
        if params.energy {
            match params.profile {
                Profile::Liggghts => p.e[i] += dt * p.de[i],
                Profile::Standard => {
                    p.e_half[i] = p.e[i] + half * p.de[i];
                    p.e[i] = p.e_half[i] + half * p.de[i];
                }
            }
        } else {
            p.work[i] += half * p.de[i];
        }
        if continuity {
            match params.profile {
                Profile::Liggghts => p.rho[i] += dt * p.drho[i],
                Profile::Standard => {
                    p.rho_half[i] = p.rho[i] + half * p.drho[i];
                    p.rho[i] = p.rho_half[i] + half * p.drho[i];
                }
            }
        }
        if p.fixed[i] {
            if params.profile == Profile::Standard {
                p.vhat[i] = p.v[i];
            }
            continue;
        }
        let inv_m = 1.0 / p.m[i];
        for c in 0..3 {
            let a = p.f[i][c] * inv_m;
            match params.profile {
                Profile::Liggghts => {
                    p.vhat[i][c] = p.v[i][c] + dt * a;
                    p.v[i][c] += half * a;
                }
                Profile::Standard => {
                    p.v[i][c] += half * a;
                    p.vhat[i][c] = p.v[i][c] + half * a;
                }
            }
            p.x[i][c] += dt * p.v[i][c];
        }
        p.x_real[i] = p.x[i];
    }
    if let Some(per) = &params.periodic {
        for i in 0..p.n_owned {
            let w = per.wrap(p.x[i]);
            p.x[i] = w;
            p.x_real[i] = w;
        }
    }
}

/// The second half of a step on the owned particles, with the rates of this step's passes
/// (see the module doc).
pub fn second_half(p: &mut Particles, dt: f64, params: &Params) {
    let half = 0.5 * dt;
    let standard = params.profile == Profile::Standard;
    for i in 0..p.n_owned {
        if !params.energy {
            p.work[i] += half * p.de[i];
        } else if standard {
            p.e[i] = p.e_half[i] + half * p.de[i];
        }
        if standard && params.density == DensityMode::Continuity {
            p.rho[i] = p.rho_half[i] + half * p.drho[i];
        }
        if p.fixed[i] {
            continue;
        }
        let inv_m = 1.0 / p.m[i];
        for c in 0..3 {
            p.v[i][c] += half * p.f[i][c] * inv_m;
        }
    }
    if standard {
        update_eos(p, params);
        if let Some(eta) = params.adaptive_h {
            for i in 0..p.n_owned {
                p.h[i] = eta * libm::cbrt(p.m[i] / p.rho[i]);
            }
        }
    }
}
