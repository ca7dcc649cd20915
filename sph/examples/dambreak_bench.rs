//! Benchmark: the peer deck's 3D dam break (4,000 fluid particles, dx = 0.01, in a tank of
//! 14,568 fixed wall particles; the geometry of `tests/liggghts/gen_data.py dambreak`), LIGGGHTS
//! profile, dt = 5e-5. Prints microseconds per particle-step (all particles, walls included, as
//! report.json counts them) and the share of each stage. LIGGGHTS 3.8.0 takes about 1.1-1.3
//! us per particle-step on this deck on one rank (peer README).
//!
//! `cargo run --release -p sph --example dambreak_bench [steps]`
use sph::exact::{exact_pass, PassGrids};
use sph::{
    add_gravity, density_pass, first_half, force_pass, pairs, second_half, setup_state, update_eos,
    ArtificialViscosity, Eos, NewParticle, Params, Particles, Profile, TensileCorrection,
};
use std::time::Instant;

const DX: f64 = 0.01;

fn dam_break() -> Particles {
    let mut p = Particles::new();
    let mut id = 1;
    let mut add = |i: i64, j: i64, k: i64, fixed: bool, p: &mut Particles| {
        p.push(NewParticle {
            id,
            x: [i, j, k].map(|q| (q as f64 + 0.5) * DX),
            v: [0.0; 3],
            m: 1000.0 * DX * DX * DX,
            rho: 1000.0,
            e: 0.0,
            h: 1.2 * DX,
            mat: 0,
            fixed,
        });
        id += 1;
    };
    for k in 0..20 {
        for j in 0..10 {
            for i in 0..20 {
                add(i, j, k, false, &mut p);
            }
        }
    }
    for k in -3..25 {
        for j in -3..13 {
            for i in -3..63 {
                let inside = (0..60).contains(&i) && (0..10).contains(&j) && k >= 0;
                if !inside {
                    add(i, j, k, true, &mut p);
                }
            }
        }
    }
    p
}

fn main() {
    let steps: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse().expect("steps"))
        .unwrap_or(200);
    let mut params = Params::new(vec![Eos::Tait {
        rho0: 1000.0,
        c0: 20.0,
        gamma: 7.0,
    }]);
    params.profile = Profile::Liggghts;
    params.viscosity = Some(ArtificialViscosity::new(0.1, 0.0));
    params.tensile = Some(TensileCorrection::monaghan(0.2, DX));
    params.gravity = [0.0, 0.0, -9.81];
    let mut p = dam_break();
    let n = p.n_owned;
    setup_state(&mut p, &params);
    let opts = params.search_options();
    let list = pairs(&p, &opts, |_| true);
    let mut g = PassGrids::default();
    let one_box = |m: &[f64; 3]| *m;
    exact_pass(&mut g, one_box, |g, m| {
        force_pass(&list, &mut p, &params, g, m)
    });
    add_gravity(&mut p, &params);

    let dt = 5e-5;
    let mut t = [0.0f64; 4]; // integrate, search, density + EOS, forces
    let mut npairs = 0;
    let start = Instant::now();
    for _ in 0..steps {
        let c = Instant::now();
        first_half(&mut p, dt, &params);
        t[0] += c.elapsed().as_secs_f64();
        let c = Instant::now();
        let list = pairs(&p, &opts, |_| true);
        npairs = list.len();
        t[1] += c.elapsed().as_secs_f64();
        let c = Instant::now();
        exact_pass(&mut g, one_box, |g, m| {
            density_pass(&list, &mut p, &params, g, m)
        });
        update_eos(&mut p, &params);
        t[2] += c.elapsed().as_secs_f64();
        let c = Instant::now();
        exact_pass(&mut g, one_box, |g, m| {
            force_pass(&list, &mut p, &params, g, m)
        });
        add_gravity(&mut p, &params);
        t[3] += c.elapsed().as_secs_f64();
        let c = Instant::now();
        second_half(&mut p, dt, &params);
        t[0] += c.elapsed().as_secs_f64();
    }
    let wall = start.elapsed().as_secs_f64();
    let per = |x: f64| 100.0 * x / wall;
    println!(
        "{n} particles ({} fixed), {npairs} pairs, {steps} steps: {:.3} us per particle-step",
        p.fixed.iter().filter(|&&f| f).count(),
        1e6 * wall / (n * steps) as f64
    );
    println!(
        "integrate {:.1} %, pair search {:.1} %, density + EOS {:.1} %, forces {:.1} %",
        per(t[0]),
        per(t[1]),
        per(t[2]),
        per(t[3])
    );
    let xmax = (0..n)
        .filter(|&i| !p.fixed[i])
        .map(|i| p.x[i][0])
        .fold(0.0, f64::max);
    println!(
        "fluid front x_max = {xmax:.4} m at t = {:.4} s",
        steps as f64 * dt
    );
}
