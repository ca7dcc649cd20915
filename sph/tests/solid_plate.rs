//! The oscillating elastic plate of Gray, Monaghan & Swift (CMAME 190 (2001) 6641, §6.1): a
//! plate of length L = 0.2 m and thickness H = 0.02 m, clamped at x = 0 by fixed particles
//! (which compute stress like the others but never move), set moving with the first
//! cantilever mode's velocity. Periodic across its width (z), so the plate is in plane strain:
//! the thin-plate (Kirchhoff) frequency of the first mode is
//!
//! ```text
//! omega^2 = E H^2 k^4 / (12 rho (1 - nu^2)),   k L = 1.875104   (Gray et al. 2001, eq. 33;
//!                                                               Timoshenko, Vibration Problems)
//! ```
//!
//! and the initial velocity v_y(x) = V_f c_0 F(x)/F(L) with the mode shape
//! F(x) = (sinh kL + sin kL)(cosh kx - cos kx) - (cosh kL + cos kL)(sinh kx - sin kx)
//! (zero value and slope at the clamp, zero moment and shear at the free end).
//! Material (Gray et al.): rho = 1000 kg/m^3, K = 3.25e6 Pa, G = 7.15e5 Pa (E = 1.998e6 Pa,
//! nu = 0.3975), c_0 = sqrt(K/rho) = 57 m/s.
mod common;

use common::elastic::LinearElastic;
use sph::{
    energies, stable_dt, ArtificialStress, ArtificialViscosity, Eos, NewParticle, Params,
    Particles, Periodic, SolidSim, StressModel,
};
use std::sync::Arc;

const L: f64 = 0.2;
const H: f64 = 0.02;
const RHO: f64 = 1000.0;
const K_BULK: f64 = 3.25e6;
const G_SHEAR: f64 = 7.15e5;
/// k L of the first clamped-free mode (the root of cos kL cosh kL = -1).
const KL: f64 = 1.875104;
/// Layers of fixed particles in the clamp: >= the support 2h = 2.4 dp.
const CLAMP_LAYERS: usize = 3;
/// Layers across the periodic width (z): each particle also pairs with its own periodic
/// images (`periodic_images` makes those within the support), so 3 layers give plane strain.
const WIDTH_LAYERS: usize = 3;
/// Smoothing length over spacing.
const H_FACTOR: f64 = 1.2;
/// Tip velocity over c_0 (Gray et al. use 0.01; smaller keeps the motion in the linear range
/// of the thin-plate formula: tip amplitude V_f c_0 / omega = 0.23 H here).
const V_F: f64 = 0.002;

fn mode_shape(x: f64) -> f64 {
    let k = KL / L;
    let (s, c) = (KL.sinh() + KL.sin(), KL.cosh() + KL.cos());
    s * ((k * x).cosh() - (k * x).cos()) - c * ((k * x).sinh() - (k * x).sin())
}

/// The plate with `ny` particles through its thickness.
fn plate(ny: usize) -> (Particles, f64) {
    let dp = H / ny as f64;
    let nx = (L / dp).round() as usize;
    let c0 = (K_BULK / RHO).sqrt();
    let mut p = Particles::new();
    let mut id = 0;
    for i in 0..nx + CLAMP_LAYERS {
        // clamp: x < 0; plate: 0 < x < L
        let x = (i as f64 - CLAMP_LAYERS as f64 + 0.5) * dp;
        for j in 0..ny {
            for k in 0..WIDTH_LAYERS {
                id += 1;
                let vy = if x > 0.0 {
                    V_F * c0 * mode_shape(x) / mode_shape(L)
                } else {
                    0.0
                };
                p.push(NewParticle {
                    id,
                    x: [x, (j as f64 + 0.5) * dp - 0.5 * H, (k as f64 + 0.5) * dp],
                    v: [0.0, vy, 0.0],
                    m: RHO * dp * dp * dp,
                    rho: RHO,
                    e: 0.0,
                    h: H_FACTOR * dp,
                    mat: 0,
                    fixed: x < 0.0,
                });
            }
        }
    }
    (p, dp)
}

/// Runs the plate until the tip's mean deflection has crossed zero `n_cross` times (at T/2, T,
/// ...; at most 3 `n_cross` thin-plate half periods); returns (the crossing times, the
/// thin-plate period, the smallest particle distance over dp at the end, the largest relative
/// drift of kinetic + internal energy).
fn run(ny: usize, n_cross: usize) -> (Vec<f64>, f64, f64, f64) {
    let (p, dp) = plate(ny);
    let el = LinearElastic::from_bulk_shear(K_BULK, G_SHEAR);
    let (e, nu) = (el.youngs(), el.poisson());
    let k = KL / L;
    let omega = (e * H * H * k.powi(4) / (12.0 * RHO * (1.0 - nu * nu))).sqrt();
    let period = 2.0 * std::f64::consts::PI / omega;
    let mut params = Params::new(vec![Eos::Tait {
        rho0: RHO,
        c0: (K_BULK / RHO).sqrt(),
        gamma: 7.0,
    }]);
    params.viscosity = Some(ArtificialViscosity::new(0.5, 0.0));
    let width = WIDTH_LAYERS as f64 * dp;
    params.periodic = Some(Periodic {
        axes: [false, false, true],
        min: [-1.0, -1.0, 0.0],
        max: [1.0, 1.0, width],
    });
    let model: Arc<dyn StressModel> = Arc::new(el);
    let mut sim = SolidSim::new(p, params, vec![Some(model)], Some(ArtificialStress::new()));
    sim.setup();
    let tip: Vec<usize> = (0..sim.sim.parts.n_owned)
        .filter(|&i| sim.sim.parts.x[i][0] > L - dp)
        .collect();
    let deflection = |p: &Particles| tip.iter().map(|&i| p.x[i][1]).sum::<f64>() / tip.len() as f64;
    let y0 = deflection(&sim.sim.parts);
    let e0 = energies(&sim.sim.parts);
    let total0 = e0.kinetic + e0.internal;
    let (mut crossings, mut drift) = (Vec::new(), 0.0f64);
    let mut prev = (0.0, 0.0);
    while crossings.len() < n_cross && sim.sim.time < 1.5 * n_cross as f64 * period {
        let dt = stable_dt(&sim.sim.parts);
        sim.step(dt);
        let y = deflection(&sim.sim.parts) - y0;
        let t = sim.sim.time;
        if prev.1 != 0.0 && (y > 0.0) != (prev.1 > 0.0) {
            crossings.push(prev.0 + (t - prev.0) * prev.1 / (prev.1 - y));
        }
        prev = (t, y);
        let en = energies(&sim.sim.parts);
        drift = drift.max(((en.kinetic + en.internal) - total0).abs() / total0);
    }
    let p = &sim.sim.parts;
    let mut closest = f64::INFINITY;
    for i in 0..p.n_owned {
        for j in 0..i {
            let d: f64 = (0..3).map(|c| (p.x[i][c] - p.x[j][c]).powi(2)).sum();
            closest = closest.min(d.sqrt() / dp);
        }
    }
    eprintln!(
        "plate ny {ny}: {} steps, crossings {crossings:?}, T analytic {period}, closest {closest} dp, energy drift {drift}",
        sim.sim.steps
    );
    (crossings, period, closest, drift)
}

/// Crossing times of the tip through zero, at T/2, T, 3T/2, ...: the period from the last
/// one, T = 2 t_k / k.
fn period_of(crossings: &[f64]) -> f64 {
    let k = crossings.len();
    assert!(k >= 1, "the tip never crossed zero");
    2.0 * crossings[k - 1] / k as f64
}

/// Measured (this file's set-up: V_f = 0.002, artificial viscosity alpha = 0.5, artificial
/// stress epsilon = 0.3, n = 4), relative excess of the period over the thin-plate value, with
/// the surface particles' quadratic fit (`sph::solid::quadratic`): n_y = 3: +11.4 %, 4: +7.8 %
/// (extrapolated +3.2 %). With the linear correction alone (B, Randles & Libersky 1996) at the
/// surface too: 3: +49.6 %, 4: +25.7 %, 6: +13.2 %, 8: +8.8 %, 10: +6.8 %; there a surface
/// particle's strain is that of a point a third of h inside it, and the plate bends as one
/// about 0.6 spacings thinner. The excess falls as ~n_y^-2 (the finite thickness resolution
/// and the SPH clamp), towards the thin-plate period lengthened by shear and rotary inertia
/// (about 1 % at L/H = 10).
const NY_COARSE: usize = 3;
/// The finer resolution of the test (one period).
const NY: usize = 4;
/// The bound on the period excess at `NY` (measured +7.8 %, see above; +25.7 % without the
/// quadratic fit).
const EXCESS_BOUND: f64 = 0.10;
/// The bound on |T_extrapolated / T_thin - 1| (the issue's 5 %): T_extrapolated is the
/// Richardson extrapolation of the `NY_COARSE` and `NY` periods with order 2,
/// (ny^2 T_ny - ny_c^2 T_ny_c)/(ny^2 - ny_c^2) (measured +3.2 %).
const EXTRAPOLATED_TOLERANCE: f64 = 0.05;

/// n_y = 3 over two periods (the plate intact: no tensile clumping, no two particles closer
/// than half the spacing; energy conserved), n_y = 4 over one; the periods' extrapolation to
/// infinite resolution against the thin-plate period. ~40 s (release, one core).
#[test]
fn plate_period_converges_to_thin_plate_theory() {
    let (c3, period, closest, drift) = run(NY_COARSE, 4);
    assert!(c3.len() >= 4, "two full periods: {c3:?}");
    let t3 = period_of(&c3[..4]);
    assert!(
        closest > 0.5,
        "no tensile clumping: closest pair {closest} dp"
    );
    // the standard integrator conserves kinetic + internal (pair work) to O(dt^2): ~1e-4 measured
    assert!(drift < 1e-3, "energy drift {drift}");
    let (c4, _, closest, _) = run(NY, 2);
    assert!(
        closest > 0.5,
        "no tensile clumping: closest pair {closest} dp"
    );
    let t4 = period_of(&c4[..2]);
    let excess = t4 / period - 1.0;
    assert!(
        excess > 0.0 && excess < EXCESS_BOUND,
        "n_y = {NY}: period {t4} vs thin plate {period}: excess {excess} (measured +7.8 %)"
    );
    assert!(t3 > t4, "the period converges from above: {t3} then {t4}");
    let (a, b) = ((NY * NY) as f64, (NY_COARSE * NY_COARSE) as f64);
    let extrapolated = (a * t4 - b * t3) / (a - b);
    let err = extrapolated / period - 1.0;
    eprintln!("T(3) {t3}, T(4) {t4}, extrapolated {extrapolated}, thin plate {period}: {err}");
    assert!(
        err.abs() < EXTRAPOLATED_TOLERANCE,
        "extrapolated period {extrapolated} vs thin plate {period}: {err}"
    );
}

/// The issue's resolution, 10 particles through the thickness, one period (~8 min release on
/// one core: run with `--ignored`): the period within 5 % of the thin-plate value (the issue's
/// criterion; measured +4.0 % from T/2, closest pair 0.999 dp; +6.8 % with the linear
/// correction alone at the surface). The bundled scene scenes/oscillating_plate.toml is the
/// same plate with the default viscosity, measured over two periods (validation/oscillating_plate).
#[test]
#[ignore]
fn plate_period_at_ten_particles_through_thickness() {
    let (crossings, period, closest, _) = run(10, 2);
    let t = period_of(&crossings[..2]);
    let err = t / period - 1.0;
    assert!(
        err.abs() < 0.05,
        "n_y = 10: period {t} vs thin plate {period}: {err}"
    );
    assert!(
        closest > 0.5,
        "no tensile clumping: closest pair {closest} dp"
    );
}
