//! The fused pass over kept candidates (`KeptPairs::continuity_and_force_pass`, which tests
//! each candidate's overlap inside the pass) against two references it does not produce:
//!
//! - the same pass over the pairs the kept list's filter gives (`KeptPairs::filter`, then
//!   `continuity_and_force_pass`): the same pairs in the same order, so the same sums bit for
//!   bit (tolerance 0);
//! - the same pass over a fresh search (`pairs_in_box`), as a run that searches every step
//!   would do: the same pairs in another order, so the same sums bit for bit too (they are
//!   exact sums, `sph::exact`: a plain floating-point sum would differ in its last bits), the
//!   pair counts exactly, and the pass's work rate (a plain sum) to round-off (1e-12).
mod common;

use common::{jittered_lattice, Rng};
use sph::exact::{exact_pass, PassGrids};
use sph::{
    continuity_and_force_pass, pairs_in_box, setup_state, update_eos, ArtificialViscosity,
    DensityMode, Eos, KeptPairs, NewParticle, Params, Particles, Profile, SearchOptions,
    TensileCorrection,
};

/// Spacing, m.
const DX: f64 = 0.01;

/// A free blob of 10^3 water particles (dx 0.01, h 1.2 dx, one in five 1.3 dx), densities
/// 990..1010 kg/m^3 (pressures of both signs), velocities up to 1 m/s per component, with
/// `shuffle` the entries in a scrambled order (the packing must not depend on it).
fn water_blob(seed: u64, shuffle: bool) -> Particles {
    let mut rng = Rng(seed);
    let mut pts: Vec<[f64; 3]> = jittered_lattice(&mut rng, 10, DX, [0.0; 3], 0.2);
    if shuffle {
        for k in (1..pts.len()).rev() {
            let j = (rng.next_u64() % (k as u64 + 1)) as usize;
            pts.swap(k, j);
        }
    }
    let mut p = Particles::new();
    for (k, x) in pts.into_iter().enumerate() {
        p.push(NewParticle {
            id: k as u64 + 1,
            x,
            v: [0, 1, 2].map(|_| rng.range(-1.0, 1.0)),
            m: 1000.0 * DX * DX * DX,
            rho: rng.range(990.0, 1010.0),
            e: rng.range(0.0, 10.0),
            h: if k % 5 == 0 { 1.3 * DX } else { 1.2 * DX },
            mat: 0,
            fixed: false,
        });
    }
    p
}

fn params(profile: Profile, conductivity: bool) -> Params {
    let mut params = Params::new(vec![Eos::Tait {
        rho0: 1000.0,
        c0: 20.0,
        gamma: 7.0,
    }]);
    params.profile = profile;
    params.viscosity = Some(ArtificialViscosity::new(0.1, 0.2));
    params.tensile = Some(TensileCorrection::monaghan(0.2, DX));
    if conductivity {
        params.energy = true;
        params.conductivity = Some(0.5);
    }
    params
}

/// Moves every particle by its velocity times `t` (s).
fn drift(p: &mut Particles, t: f64) {
    for i in 0..p.len() {
        for c in 0..3 {
            p.x[i][c] += p.v[i][c] * t;
        }
        p.x_real[i] = p.x[i];
    }
}

/// The fields a fused pass writes: drho, de and f, per entry.
fn sums(p: &Particles) -> Vec<[f64; 5]> {
    (0..p.len())
        .map(|i| [p.drho[i], p.de[i], p.f[i][0], p.f[i][1], p.f[i][2]])
        .collect()
}

#[test]
fn kept_pass_equals_the_filtered_list_and_a_fresh_search() {
    let (lo, hi) = ([f64::NEG_INFINITY; 3], [f64::INFINITY; 3]);
    for (profile, conductivity, shuffle) in [
        (Profile::Liggghts, false, false),
        (Profile::Standard, true, true),
    ] {
        let params = params(profile, conductivity);
        let mut p = water_blob(7, shuffle);
        setup_state(&mut p, &params);
        // the LIGGGHTS set-up zeroes v^ (its state at the set-up forces): the step's v^ = v
        p.vhat = p.v.clone();
        update_eos(&mut p, &params);
        let mut kept = KeptPairs::build(&p, &params.search_options(), lo, hi);
        // moves of up to sqrt(3) m/s x 0.6 ms = 1.04e-3 m, within half the skin (0.2 h_min / 2
        // = 1.2e-3 m), change which candidates overlap
        let mut counts = Vec::new();
        for step in 0..4 {
            drift(&mut p, 1.5e-4);
            assert!(
                kept.still_valid(&p),
                "{profile:?} step {step}: the kept list must still hold (the test moves too far)"
            );
            // the pass under test, on grids fitted to its terms
            let mut count = Vec::new();
            let mut g = PassGrids::default();
            let ((work, n), _) = exact_pass(
                &mut g,
                |m| *m,
                |g, m| kept.continuity_and_force_pass(&mut p, &params, &mut count, g, m),
            );
            let got = sums(&p);
            let mut m = [0.0; 3];
            // reference 1: the filtered list, same order
            let mut count_f = Vec::new();
            let list = kept.filter(&p, &mut count_f);
            let work_f = continuity_and_force_pass(&list, &mut p, &params, &g, &mut m);
            assert_eq!(n, list.len(), "{profile:?} step {step}: pairs");
            counts.push(n);
            assert_eq!(count, count_f, "{profile:?} step {step}: pairs per entry");
            assert_eq!(work, work_f, "{profile:?} step {step}: work (bit for bit)");
            assert_eq!(got, sums(&p), "{profile:?} step {step}: sums (bit for bit)");
            // reference 2: a fresh search
            let fresh = pairs_in_box(&p, &params.search_options(), lo, hi);
            assert_eq!(
                n,
                fresh.len(),
                "{profile:?} step {step}: pairs against fresh"
            );
            let mut count_s = vec![0u32; p.len()];
            for &(i, j) in &fresh {
                count_s[i as usize] += 1;
                count_s[j as usize] += 1;
            }
            assert_eq!(
                count, count_s,
                "{profile:?} step {step}: counts against fresh"
            );
            let work_s = continuity_and_force_pass(&fresh, &mut p, &params, &g, &mut m);
            let want = sums(&p);
            for c in 0..5 {
                let scale = want.iter().map(|s| s[c].abs()).fold(0.0, f64::max);
                assert!(scale > 0.0, "field {c} is all zero: nothing tested");
            }
            assert!(
                got == want,
                "{profile:?} step {step}: the kept pass's sums differ from a fresh search's \
                 (exact sums: tolerance 0)"
            );
            let dw = (work.total() - work_s.total()).abs();
            let scale = work_s.pressure.abs() + work_s.viscosity.abs();
            assert!(
                dw <= 1e-12 * scale,
                "{profile:?} step {step}: work {work:?} against {work_s:?} (tolerance 1e-12)"
            );
        }
        assert!(
            counts.windows(2).all(|w| w[0] != w[1]),
            "{profile:?}: the pair count must change from step to step: {counts:?}"
        );
    }
}

/// A splash over a floor: a jittered block of 8 x 8 x 6 moving particles over three layers of
/// 14 x 14 fixed ones (wall pairs are skipped under continuity), some moving particles thrown
/// well clear (sparse cells), the entries in a scrambled order; h 1.2 dx, or with `varied`
/// 0.6 ... 1.8 dx (ratio 3: cells h_max wide, a two-cell stencil).
fn splash(seed: u64, varied: bool) -> Particles {
    let mut rng = Rng(seed);
    let mut pts: Vec<([f64; 3], bool)> = Vec::new();
    for k in 0..3 {
        for j in 0..14 {
            for i in 0..14 {
                let x = [i, j, k].map(|q| (q as f64 - 3.0) * DX);
                pts.push((x, true));
            }
        }
    }
    for (k, x) in jittered_lattice(&mut rng, 8, DX, [0.0, 0.0, 0.03], 0.3)
        .into_iter()
        .enumerate()
    {
        if k % 61 == 0 {
            let far = [x[0] + 0.1, x[1] - 0.05, x[2] + 0.2];
            pts.push((far, false));
        } else if k % 8 < 6 {
            pts.push((x, false));
        }
    }
    for k in (1..pts.len()).rev() {
        let j = (rng.next_u64() % (k as u64 + 1)) as usize;
        pts.swap(k, j);
    }
    let mut p = Particles::new();
    for (k, (x, fixed)) in pts.into_iter().enumerate() {
        let h = if varied {
            rng.range(0.6, 1.8) * DX
        } else {
            1.2 * DX
        };
        p.push(NewParticle {
            id: 1000 + 3 * k as u64,
            x,
            v: [0.0; 3],
            m: 1000.0 * DX * DX * DX,
            rho: 1000.0,
            e: 0.0,
            h,
            mat: 0,
            fixed,
        });
    }
    p
}

#[test]
fn one_box_build_equals_the_general_search() {
    let (lo, hi) = ([f64::NEG_INFINITY; 3], [f64::INFINITY; 3]);
    let mut cases: Vec<(String, Particles)> = vec![
        ("blob".into(), water_blob(3, false)),
        ("shuffled blob".into(), water_blob(5, true)),
        ("splash".into(), splash(11, false)),
        ("splash, varied h".into(), splash(13, true)),
        ("empty".into(), Particles::new()),
    ];
    let mut single = Particles::new();
    single.push(NewParticle {
        id: 7,
        x: [0.1, 0.2, 0.3],
        v: [0.0; 3],
        m: 1.0,
        rho: 1000.0,
        e: 0.0,
        h: 1.2 * DX,
        mat: 0,
        fixed: false,
    });
    cases.push(("one particle".into(), single));
    let mut nonempty = 0;
    for (name, p) in &cases {
        for density in [DensityMode::Continuity, DensityMode::Summation] {
            let mut params = params(Profile::Liggghts, false);
            params.density = density;
            let opts: SearchOptions = params.search_options();
            let (got, want) = (
                KeptPairs::build(p, &opts, lo, hi),
                KeptPairs::build_by_search(p, &opts, lo, hi),
            );
            // everything, the packing order included (shortest round-trip floats)
            assert_eq!(
                format!("{got:?}"),
                format!("{want:?}"),
                "{name}, {density:?}"
            );
            let (got, want) = (got.to_parts(), want.to_parts());
            assert_eq!(
                got.0, want.0,
                "{name}, {density:?}: candidates (and their order)"
            );
            assert_eq!(got.1, want.1, "{name}, {density:?}: reference positions");
            assert_eq!(got.2, want.2, "{name}, {density:?}: reference h");
            assert_eq!(got.3, want.3, "{name}, {density:?}: ids");
            assert_eq!(got.4, want.4, "{name}, {density:?}: skin");
            let walls = got
                .0
                .iter()
                .filter(|[a, b]| p.fixed[*a as usize] && p.fixed[*b as usize])
                .count();
            if density == DensityMode::Continuity {
                assert_eq!(walls, 0, "{name}: wall-wall candidates under continuity");
            } else if p.fixed.iter().any(|f| *f) {
                assert!(walls > 0, "{name}: wall-wall candidates under summation");
            }
            nonempty += usize::from(!got.0.is_empty());
        }
    }
    assert_eq!(
        nonempty, 8,
        "every case but the empty and one-particle ones has candidates"
    );
}
