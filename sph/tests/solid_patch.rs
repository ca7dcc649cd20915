//! Patch tests of the solid particles' velocity gradient and stress update, and the
//! conservation laws of the stress force pass.
//!
//! A linear velocity field v = G x must give the exact gradient L = G at every particle, the
//! free surface included, thanks to the kernel-gradient correction (Randles & Libersky 1996:
//! sum_b V_b (v_b - v_a) (x) grad W = G sum_b V_b (x_b - x_a) (x) grad W, exactly); the stress
//! increment of one step is then the analytic dt (C : D + W sigma - sigma W).
mod common;

use common::elastic::LinearElastic;
use common::{jittered_lattice, Rng};
use sph::exact::{exact_pass, PassGrids};
use sph::solid::build::Build;
use sph::solid::tensor::{from_voigt, mul, to_voigt, Mat3};
use sph::solid::{
    quadratic_pass, settle_gradients, settle_quadratic, stress_force_pass, update_stress,
    velocity_gradient_pass,
};
use sph::{
    pairs, ArtificialStress, ArtificialViscosity, Eos, NewParticle, Params, Particles, Solids,
    StressModel,
};
use std::sync::Arc;

const DX: f64 = 0.01;
const RHO: f64 = 1000.0;

/// A jittered block of n^3 particles (spacing DX, h = 1.2 DX) moving with v = G x.
fn block(n: usize, jitter: f64, g: &Mat3, seed: u64) -> Particles {
    let mut rng = Rng(seed);
    let mut p = Particles::new();
    for (k, x) in jittered_lattice(&mut rng, n, DX, [0.0; 3], jitter)
        .into_iter()
        .enumerate()
    {
        let v = std::array::from_fn(|a| g[a][0] * x[0] + g[a][1] * x[1] + g[a][2] * x[2]);
        p.push(NewParticle {
            id: k as u64 + 1,
            x,
            v,
            m: RHO * DX * DX * DX,
            rho: RHO,
            e: 0.0,
            h: 1.2 * DX,
            mat: 0,
            fixed: false,
        });
    }
    p
}

fn params() -> Params {
    Params::new(vec![Eos::Tait {
        rho0: RHO,
        c0: 50.0,
        gamma: 7.0,
    }])
}

fn elastic() -> LinearElastic {
    LinearElastic::from_bulk_shear(3.25e6, 7.15e5)
}

fn solids_for(p: &Particles) -> Solids {
    let m: Arc<dyn StressModel> = Arc::new(elastic());
    Solids::new(vec![Some(m)], p)
}

/// The gradient pass on grids fitted to its terms (serial: every entry owned), then the
/// surface particles' quadratic fit (`sph::solid::quadratic`), as a step runs them.
fn gradients(pr: &[(u32, u32)], p: &mut Particles, s: &mut Solids, params: &Params) {
    let k = params.smoothing_kernel();
    let mut g = PassGrids::default();
    exact_pass(
        &mut g,
        |m| *m,
        |g, m| velocity_gradient_pass(pr, &*p, s, &k, g, m),
    );
    settle_gradients(p, s);
    let mut g = PassGrids::default();
    exact_pass(&mut g, |m| *m, |g, m| quadratic_pass(&*p, s, g, m));
    settle_quadratic(p, s);
}

/// The stress force pass on grids fitted to its terms.
fn forces(
    pr: &[(u32, u32)],
    p: &mut Particles,
    s: &mut Solids,
    params: &Params,
    art: &ArtificialStress,
) -> sph::PairWork {
    let mut g = PassGrids::default();
    exact_pass(
        &mut g,
        |m| *m,
        |g, m| stress_force_pass(pr, p, s, params, Some(art), g, m),
    )
    .0
}

fn max_abs(m: &Mat3) -> f64 {
    m.iter().flatten().fold(0.0, |s, x| s.max(x.abs()))
}

/// A general (non-symmetric) gradient: stretch, shear and spin together, 1/s.
const G: Mat3 = [[0.3, -0.7, 0.2], [0.5, -0.1, 0.4], [-0.6, 0.25, 0.15]];

#[test]
fn linear_velocity_gives_exact_gradient_and_stress_rate() {
    for jitter in [0.0, 0.2] {
        let mut p = block(7, jitter, &G, 7);
        let params = params();
        let mut s = solids_for(&p);
        let pr = pairs(&p, &params.search_options(), |_| true);
        gradients(&pr, &mut p, &mut s, &params);
        for i in 0..p.n_owned {
            let err: Mat3 =
                std::array::from_fn(|a| std::array::from_fn(|b| s.grad_v[i][a][b] - G[a][b]));
            // the correction is exact for a linear field: only round-off of ~60 terms of size
            // |G| remains (1e-10 relative, the brief's patch-test tolerance)
            assert!(
                max_abs(&err) < 1e-10 * max_abs(&G),
                "particle {i}: L - G = {err:?}"
            );
        }
        // one stress update from a prestress sigma0: dt (C : D + W sigma0 - sigma0 W)
        let sigma0 = [1.0e4, -2.0e4, 5.0e3, 3.0e3, -1.0e3, 2.0e3];
        for st in s.stress.iter_mut() {
            *st = sigma0;
        }
        let dt = 1e-5;
        update_stress(&mut p, &mut s, dt);
        let d = to_voigt(&G);
        let w: Mat3 = std::array::from_fn(|a| std::array::from_fn(|b| 0.5 * (G[a][b] - G[b][a])));
        let sg = from_voigt(&sigma0);
        let (ws, sw) = (mul(&w, &sg), mul(&sg, &w));
        let jau = to_voigt(&std::array::from_fn(|a| {
            std::array::from_fn(|b| ws[a][b] - sw[a][b])
        }));
        let inc = elastic().increment(&d.map(|x| x * dt));
        let expect: [f64; 6] = std::array::from_fn(|c| sigma0[c] + dt * jau[c] + inc[c]);
        let scale = 2.0 * elastic().mu * 1.0 * dt; // the size of the increment, Pa
        for i in 0..p.n_owned {
            for (c, (got, want)) in s.stress[i].iter().zip(&expect).enumerate() {
                let e = (got - want).abs();
                // the increment exact to 1e-10 of its size (plus the prestress's round-off)
                assert!(
                    e < 1e-10 * scale + 1e-15 * 2.0e4,
                    "particle {i} comp {c}: {e}"
                );
            }
            let tr = expect[0] + expect[1] + expect[2];
            assert!((p.p[i] + tr / 3.0).abs() < 1e-9, "p = -tr(sigma)/3");
        }
    }
}

/// Equal and opposite pair forces conserve momentum, and the energy rate given to the particles
/// is what the forces take from the kinetic energy: sum m de = -sum v^ . f (to round-off), with
/// random stresses (tension and compression), the kernel-gradient correction, artificial
/// stress and viscosity.
#[test]
fn stress_force_pass_conserves_momentum_and_energy() {
    let zero = [[0.0; 3]; 3];
    let mut p = block(6, 0.2, &zero, 11);
    let mut rng = Rng(5);
    for i in 0..p.n_owned {
        p.vhat[i] = [0, 1, 2].map(|_| rng.range(-1.0, 1.0));
        p.rho[i] = rng.range(990.0, 1010.0);
        p.c[i] = 60.0;
    }
    let mut params = params();
    params.viscosity = Some(ArtificialViscosity::new(1.0, 2.0));
    let mut s = solids_for(&p);
    for st in s.stress.iter_mut() {
        *st = [0; 6].map(|_| rng.range(-1.0e5, 1.0e5));
    }
    let pr = pairs(&p, &params.search_options(), |_| true);
    // the kernel-gradient correction B of each particle (not the identity on a jittered block)
    gradients(&pr, &mut p, &mut s, &params);
    let art = ArtificialStress::new();
    let work = forces(&pr, &mut p, &mut s, &params, &art);
    let (mut fsum, mut fabs, mut ke_rate, mut ie_rate, mut scale) = ([0.0; 3], 0.0, 0.0, 0.0, 0.0);
    for i in 0..p.n_owned {
        for (c, sum) in fsum.iter_mut().enumerate() {
            *sum += p.f[i][c];
            fabs += p.f[i][c].abs();
            ke_rate += p.vhat[i][c] * p.f[i][c];
            scale += (p.vhat[i][c] * p.f[i][c]).abs();
        }
        ie_rate += p.m[i] * p.de[i];
    }
    for c in 0..3 {
        // round-off of ~10^4 terms: 1e-13 of the sum of magnitudes
        assert!(fsum[c].abs() < 1e-13 * fabs, "momentum: {fsum:?} vs {fabs}");
    }
    assert!(
        (ke_rate + ie_rate).abs() < 1e-12 * scale,
        "energy: {ke_rate} + {ie_rate}"
    );
    assert!(
        (work.total() - ie_rate).abs() < 1e-12 * scale,
        "work = sum m de"
    );
    assert!(work.viscosity >= 0.0, "viscosity only dissipates");
}

/// The solid passes' sums are exact (binned sums, `sph::exact`): the pairs in another order,
/// each listed the other way round, give every particle the same gradient, correction, density
/// rate, force and energy rate bit for bit (tolerance 0: what makes a run the same bits at any rank count,
/// docs/scene.md "One answer").
#[test]
fn solid_sums_do_not_depend_on_the_order_of_the_pairs() {
    let mut p = block(6, 0.2, &G, 3);
    let mut rng = Rng(9);
    for i in 0..p.n_owned {
        p.vhat[i] = [0, 1, 2].map(|_| rng.range(-1.0, 1.0));
        p.c[i] = 60.0;
    }
    let mut params = params();
    params.viscosity = Some(ArtificialViscosity::new(1.0, 2.0));
    let art = ArtificialStress::new();
    let pr = pairs(&p, &params.search_options(), |_| true);
    // reversed, each pair swapped, then rotated by a third
    let mut other: Vec<(u32, u32)> = pr.iter().rev().map(|&(i, j)| (j, i)).collect();
    other.rotate_left(pr.len() / 3);
    let run = |list: &[(u32, u32)], p: &mut Particles| {
        let mut s = solids_for(p);
        let mut rng = Rng(4);
        for st in s.stress.iter_mut() {
            *st = [0; 6].map(|_| rng.range(-1.0e5, 1.0e5));
        }
        gradients(list, p, &mut s, &params);
        forces(list, p, &mut s, &params, &art);
        let out = (
            s.grad_v.clone(),
            s.correction.clone(),
            p.f.clone(),
            p.de.clone(),
        );
        (out, p.drho.clone())
    };
    let a = run(&pr, &mut p.clone());
    let b = run(&other, &mut p.clone());
    let ((a, da), (b, db)) = (a, b);
    assert!(a.0 == b.0, "velocity gradients differ");
    assert!(a.1 == b.1, "corrections differ");
    assert!(a.2 == b.2, "forces differ");
    assert!(a.3 == b.3, "energy rates differ");
    assert!(da == db, "density rates differ");
}

/// Every build of the solid pair loops (`sph::solid::build`: baseline, AVX2, AVX-512F, as the
/// CPU has them) gives every particle the same gradient, correction, density rate, force and
/// energy rate, bit for bit (`--kernel scalar` and `auto` give the same run).
#[test]
fn every_build_of_the_solid_passes_gives_the_same_bits() {
    let mut p = block(6, 0.2, &G, 13);
    let mut rng = Rng(21);
    for i in 0..p.n_owned {
        p.vhat[i] = [0, 1, 2].map(|_| rng.range(-1.0, 1.0));
        p.c[i] = 60.0;
    }
    let mut params = params();
    params.viscosity = Some(ArtificialViscosity::new(1.0, 2.0));
    let art = ArtificialStress::new();
    let pr = pairs(&p, &params.search_options(), |_| true);
    let run = |build: Build, p: &mut Particles| {
        let mut s = solids_for(p);
        s.build = build;
        let mut rng = Rng(4);
        for st in s.stress.iter_mut() {
            *st = [0; 6].map(|_| rng.range(-1.0e5, 1.0e5));
        }
        gradients(&pr, p, &mut s, &params);
        let work = forces(&pr, p, &mut s, &params, &art);
        (
            s.grad_v.clone(),
            s.correction.clone(),
            p.f.clone(),
            p.de.clone(),
            p.drho.clone(),
            work,
        )
    };
    let want = run(Build::Baseline, &mut p.clone());
    for build in Build::available() {
        let got = run(build, &mut p.clone());
        assert!(got == want, "{build:?} differs from the baseline build");
    }
}

/// The artificial stress tensor of a uniaxial tension sigma_xx = s > 0 rotated by an angle:
/// R = -epsilon s / rho^2 n n^T (n the tension's direction), zero for compression (Gray et al.
/// 2001, eq. 25).
#[test]
fn artificial_stress_acts_on_tension_only() {
    let art = ArtificialStress::new();
    let (s, th) = (2.0e5, 0.3f64);
    let n = [th.cos(), th.sin(), 0.0];
    let sig: Mat3 = std::array::from_fn(|a| std::array::from_fn(|b| s * n[a] * n[b]));
    let r = art.tensor(&to_voigt(&sig), RHO);
    let k = -art.epsilon * s / (RHO * RHO);
    for a in 0..3 {
        for b in 0..3 {
            // eigen-decomposition round-off, 1e-14 of |R|
            assert!(
                (r[a][b] - k * n[a] * n[b]).abs() < 1e-14 * k.abs(),
                "R[{a}][{b}]"
            );
        }
    }
    let comp: Mat3 = std::array::from_fn(|a| std::array::from_fn(|b| -sig[a][b]));
    let r = art.tensor(&to_voigt(&comp), RHO);
    assert!(
        max_abs(&r) < 1e-14 * k.abs(),
        "compression: no artificial stress"
    );
}

/// A quadratic velocity field v_k = G_kl x_l + (1/2) x . H_k x, its gradient at x.
fn quadratic_field(x: &[f64; 3], h: &[Mat3; 3]) -> ([f64; 3], Mat3) {
    let v = std::array::from_fn(|k| {
        let hx: f64 = (0..3)
            .map(|a| (0..3).map(|b| x[a] * h[k][a][b] * x[b]).sum::<f64>())
            .sum();
        (0..3).map(|l| G[k][l] * x[l]).sum::<f64>() + 0.5 * hx
    });
    let grad = std::array::from_fn(|k| {
        std::array::from_fn(|l| G[k][l] + (0..3).map(|b| h[k][l][b] * x[b]).sum::<f64>())
    });
    (v, grad)
}

/// The quadratic fit of the surface particles (`sph::solid::quadratic`, the moving least
/// squares with a quadratic basis) gives the exact gradient of a quadratic velocity field at
/// the surface (round-off: 1e-9 of |H| DX, the 9 x 9 solve amplifying the sums' round-off at
/// most 100-fold), where the linear correction alone is off by a fraction of H h (the third
/// moments of a one-sided neighbourhood; measured about 0.3 |H| DX). Checked at the particles
/// that take the fit whole (`Solids::quad_share` 1); the interior particles, in
/// a symmetric neighbourhood, keep the linear correction, whose error there is second order.
#[test]
fn the_surface_fit_is_exact_for_a_quadratic_velocity_field() {
    // symmetric Hessians of each component, 1/(m s)
    let h: [Mat3; 3] = [
        [[2.0, 0.5, -1.0], [0.5, -3.0, 0.7], [-1.0, 0.7, 1.5]],
        [[-1.0, 2.0, 0.3], [2.0, 0.4, -0.6], [0.3, -0.6, 2.5]],
        [[0.8, -0.2, 1.1], [-0.2, 1.9, 0.5], [1.1, 0.5, -2.2]],
    ];
    let hmax = h.iter().map(max_abs).fold(0.0, f64::max);
    for jitter in [0.0, 0.2] {
        let mut p = block(7, jitter, &G, 17);
        for i in 0..p.n_owned {
            p.v[i] = quadratic_field(&p.x[i], &h).0;
        }
        let params = params();
        let mut s = solids_for(&p);
        let pr = pairs(&p, &params.search_options(), |_| true);
        gradients(&pr, &mut p, &mut s, &params);
        let first_order = s.grad_sum.iter().zip(&s.shape_sum);
        let (mut fitted, mut worst_linear) = (0, 0.0f64);
        for (i, (gs, sh)) in first_order.enumerate().take(p.n_owned) {
            let (_, want) = quadratic_field(&p.x[i], &h);
            let err = |l: &Mat3| {
                max_abs(&std::array::from_fn(|a| {
                    std::array::from_fn(|b| l[a][b] - want[a][b])
                }))
            };
            // the fit taken whole (`quad_share` 1: a face, S 0.5 from the identity in its
            // normal, the fit's largest weight 34; edges and corners take part of it)
            if s.quad_share[i] == 1.0 {
                fitted += 1;
                assert!(
                    err(&s.grad_v[i]) < 1e-9 * hmax * DX,
                    "jitter {jitter}, particle {i}: fitted L off by {:e}",
                    err(&s.grad_v[i])
                );
                let inv = sph::solid::tensor::inverse(sh, 1e-6).expect("a regular shape sum");
                worst_linear = worst_linear.max(err(&mul(gs, &inv)));
            }
        }
        // a 7^3 block: the 150 particles of its faces' interiors take the fit whole
        assert!(
            fitted >= 100,
            "jitter {jitter}: {fitted} particles fitted whole"
        );
        assert!(
            worst_linear > 0.1 * hmax * DX,
            "the linear correction alone is off at the surface: {worst_linear:e}"
        );
    }
}

/// The forces are the transpose of the gradient, the quadratic fit's part included: with one
/// density everywhere (so m_a m_b / rho^2 = V_a V_b) and neither viscosity nor artificial
/// stress, the power of the pair forces equals minus the stress power, sum_a v_a . f_a =
/// -sum_a V_a sigma_a : L_a, to round-off (1e-12 of the sum of magnitudes): a stress does no
/// work the gradient did not give it (Bonet & Lok 1999's variational consistency).
#[test]
fn the_forces_are_the_transpose_of_the_fitted_gradient() {
    let zero = [[0.0; 3]; 3];
    let mut p = block(6, 0.2, &zero, 23);
    let mut rng = Rng(31);
    for i in 0..p.n_owned {
        p.v[i] = [0, 1, 2].map(|_| rng.range(-1.0, 1.0));
        p.vhat[i] = p.v[i];
        p.c[i] = 60.0;
    }
    let params = params();
    let mut s = solids_for(&p);
    for st in s.stress.iter_mut() {
        *st = [0; 6].map(|_| rng.range(-1.0e5, 1.0e5));
    }
    let pr = pairs(&p, &params.search_options(), |_| true);
    gradients(&pr, &mut p, &mut s, &params);
    let fitted = (0..p.n_owned)
        .filter(|&i| s.quad[i].iter().any(|&x| x != 0.0))
        .count();
    assert!(fitted > 50, "{fitted} particles fitted");
    let mut g = PassGrids::default();
    exact_pass(
        &mut g,
        |m| *m,
        |g, m| stress_force_pass(&pr, &mut p, &mut s, &params, None, g, m),
    );
    let (mut force_power, mut stress_power, mut scale) = (0.0, 0.0, 0.0);
    for i in 0..p.n_owned {
        for c in 0..3 {
            force_power += p.v[i][c] * p.f[i][c];
            scale += (p.v[i][c] * p.f[i][c]).abs();
        }
        let vol = p.m[i] / p.rho[i];
        let sg = from_voigt(&s.stress[i]);
        for (srow, lrow) in sg.iter().zip(&s.grad_v[i]) {
            for (x, l) in srow.iter().zip(lrow) {
                stress_power += vol * x * l;
            }
        }
    }
    assert!(
        (force_power + stress_power).abs() < 1e-12 * scale,
        "force power {force_power} against stress power {stress_power}"
    );
}
