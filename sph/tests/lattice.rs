//! Periodic sums and interpolation on regular lattices, against direct sums.
mod common;

use sph::{
    interpolate, DensityMode, Eos, Kernel, NewParticle, Params, Particles, Periodic, Profile,
    SerialSim,
};

/// A simple cubic lattice of n^3 particles of spacing dx filling the periodic cube [0, n dx)^3.
fn periodic_lattice(n: usize, dx: f64, h: f64, kernel: Kernel) -> SerialSim {
    let mut p = Particles::new();
    let mut id = 0;
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                p.push(NewParticle {
                    id,
                    x: [i, j, k].map(|q| (q as f64 + 0.5) * dx),
                    v: [0.0; 3],
                    m: 1.0,
                    rho: 1.0,
                    e: 1.0,
                    h,
                    mat: 0,
                    fixed: false,
                });
                id += 1;
            }
        }
    }
    let mut params = Params::new(vec![Eos::IdealGas { gamma: 1.4 }]);
    params.kernel = kernel;
    params.density = DensityMode::Summation;
    params.periodic = Some(Periodic {
        axes: [true; 3],
        min: [0.0; 3],
        max: [n as f64 * dx; 3],
    });
    SerialSim::new(p, params)
}

/// sum over all lattice vectors n dx of m W(|n dx|, h): the density of an infinite lattice.
fn lattice_sum(dx: f64, h: f64, kernel: Kernel) -> f64 {
    let r = (2.0 * h / dx).ceil() as i64 + 1;
    let k = kernel.with_profile(Profile::Standard);
    let mut s = 0.0;
    for a in -r..=r {
        for b in -r..=r {
            for c in -r..=r {
                let d = dx * ((a * a + b * b + c * c) as f64).sqrt();
                s += k.w(d, h);
            }
        }
    }
    s
}

#[test]
fn summation_density_in_periodic_boxes_equals_lattice_sum() {
    // Reference: the direct lattice sum. A box of one particle (period dx: the particle meets
    // only its own images), of 2^3 and of 6^3 particles must all give it, to round-off
    // (tol 1e-12 relative); forces vanish by symmetry (tol 1e-12 of m p/rho^2 W'(dx) scale).
    let dx = 0.1;
    for kernel in [Kernel::CubicSpline, Kernel::Wendland] {
        for hf in [1.2, 2.1] {
            let h = hf * dx;
            let want = lattice_sum(dx, h, kernel);
            for n in [1, 2, 6] {
                let mut sim = periodic_lattice(n, dx, h, kernel);
                sim.setup();
                let p = &sim.parts;
                let scale = p.p[0] / (p.rho[0] * p.rho[0]) * kernel.dw_dr(dx, h).abs();
                for i in 0..p.n_owned {
                    let err = (p.rho[i] - want).abs() / want;
                    assert!(
                        err < 1e-12,
                        "{kernel:?} h {hf} dx, {n}^3 box: rho {} vs lattice sum {want}",
                        p.rho[i]
                    );
                    let f = p.f[i].iter().fold(0.0f64, |a, &b| a.max(b.abs()));
                    assert!(
                        f < 1e-12 * scale,
                        "{kernel:?} {n}^3: force {f:e} on a perfect lattice"
                    );
                }
            }
        }
    }
}

#[test]
fn shepard_interpolation_reproduces_constant_and_linear_fields() {
    // Reference: Shepard interpolation is exact for a constant field (to round-off) and, on a
    // lattice, for a linear field at a point of symmetry (the lattice centre).
    let mut sim = periodic_lattice(6, 0.1, 0.12, Kernel::CubicSpline);
    sim.setup();
    let p = &sim.parts;
    let k = sim.params.smoothing_kernel();
    let c = interpolate([0.33, 0.21, 0.47], p, &k, |_| 2.5).unwrap();
    assert!((c - 2.5).abs() < 1e-14, "constant: {c}");
    let lin = interpolate([0.3, 0.3, 0.3], p, &k, |i| {
        1.0 + 2.0 * p.x[i][0] - p.x[i][2]
    })
    .unwrap();
    assert!(
        (lin - (1.0 + 0.6 - 0.3)).abs() < 1e-13,
        "linear at centre: {lin}"
    );
    assert!(interpolate([5.0, 5.0, 5.0], p, &k, |_| 1.0).is_none());
}
