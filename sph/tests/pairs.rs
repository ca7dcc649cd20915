//! The neighbour search and the centre-of-interaction rule against brute force.
//!
//! Reference: an O(N^2) loop over every pair of particles (and every periodic image offset),
//! with the interaction criterion r < h_a + h_b. These are exact set comparisons (no tolerance):
//! the same pairs, each exactly once.
mod common;

use common::Rng;
use sph::{coi, pairs, periodic_images, NewParticle, Particles, Periodic, SearchOptions};
use std::collections::BTreeMap;

fn random_particles(
    rng: &mut Rng,
    n: usize,
    lo: [f64; 3],
    hi: [f64; 3],
    h: (f64, f64),
) -> Particles {
    let mut p = Particles::new();
    for k in 0..n {
        p.push(NewParticle {
            // ids deliberately not in index order
            id: (k as u64 * 7919) % 100_003 + 1,
            x: [0, 1, 2].map(|a| rng.range(lo[a], hi[a])),
            v: [0.0; 3],
            m: 1.0,
            rho: 1.0,
            e: 0.0,
            h: rng.range(h.0, h.1),
            mat: 0,
            fixed: rng.unit() < 0.3,
        });
    }
    p
}

/// Physical pair key: (smaller id, larger id, image of the larger-id copy relative to the other).
type Key = (u64, u64, [i64; 3]);

fn brute_force(p: &Particles, per: Option<&Periodic>, skip_fixed: bool) -> BTreeMap<Key, usize> {
    let mut out = BTreeMap::new();
    let range = |k: usize| match per {
        Some(per) if per.axes[k] => -3i64..=3,
        _ => 0..=0,
    };
    for i in 0..p.n_owned {
        for j in 0..p.n_owned {
            if p.id[i] > p.id[j] || (skip_fixed && p.fixed[i] && p.fixed[j]) {
                continue;
            }
            for mx in range(0) {
                for my in range(1) {
                    for mz in range(2) {
                        let m = [mx, my, mz];
                        // a particle and its own image: the pair (a, a, m) is (a, a, -m), kept
                        // once, with m lexicographically positive
                        if i == j && m <= [0; 3] {
                            continue;
                        }
                        let mut d2 = 0.0;
                        for (k, &mk) in m.iter().enumerate() {
                            let mut d = p.x[j][k] - p.x[i][k];
                            if mk != 0 {
                                d += mk as f64 * per.unwrap().period(k);
                            }
                            d2 += d * d;
                        }
                        if d2 < (p.h[i] + p.h[j]).powi(2) {
                            out.insert((p.id[i], p.id[j], m), 1);
                        }
                    }
                }
            }
        }
    }
    out
}

fn key_of(p: &Particles, i: usize, j: usize, per: Option<&Periodic>) -> Key {
    let (ei, ej) = (p.pair_end(i, per), p.pair_end(j, per));
    let (a, b) = sph::canonical(&ei, &ej);
    (a.id, b.id, [0, 1, 2].map(|k| b.image[k] - a.image[k]))
}

#[test]
fn search_equals_brute_force() {
    let mut rng = Rng(2024);
    // h from 0.02 to 0.09 (a factor 4.5: fine cells, two deep, with pruning by cell h_max) and
    // from 0.05 to 0.06 (coarse cells, one deep)
    for (skip_fixed, hr) in [
        (false, (0.02, 0.09)),
        (true, (0.02, 0.09)),
        (true, (0.05, 0.06)),
    ] {
        let p = random_particles(&mut rng, 700, [0.0; 3], [1.0, 0.7, 0.5], hr);
        let opts = SearchOptions {
            periodic: None,
            skip_fixed_pairs: skip_fixed,
        };
        let list = pairs(&p, &opts, |_| true);
        let mut got = BTreeMap::new();
        for &(i, j) in &list {
            assert!(i < j);
            *got.entry(key_of(&p, i as usize, j as usize, None))
                .or_insert(0) += 1;
        }
        let want = brute_force(&p, None, skip_fixed);
        assert!(
            want.len() > 2000,
            "enough pairs to mean something: {}",
            want.len()
        );
        assert_eq!(got, want, "cell-list pairs (each once) = brute-force pairs");
    }
}

/// An axis-aligned half-open region [lo, hi) (infinite at the outside).
#[derive(Clone, Copy, Debug)]
struct Region {
    lo: [f64; 3],
    hi: [f64; 3],
}

impl Region {
    fn contains(&self, x: [f64; 3]) -> bool {
        (0..3).all(|k| x[k] >= self.lo[k] && x[k] < self.hi[k])
    }
    fn near(&self, x: [f64; 3], reach: f64) -> bool {
        (0..3).all(|k| x[k] >= self.lo[k] - reach && x[k] < self.hi[k] + reach)
    }
}

/// Splits space into `k` regions by random cut planes, recursively (RCB-like).
fn cut(rng: &mut Rng, r: Region, k: usize, dom: ([f64; 3], [f64; 3]), out: &mut Vec<Region>) {
    if k == 1 {
        out.push(r);
        return;
    }
    let axis = (rng.next_u64() % 3) as usize;
    let lo = r.lo[axis].max(dom.0[axis]);
    let hi = r.hi[axis].min(dom.1[axis]);
    let at = rng.range(lo + 0.2 * (hi - lo), hi - 0.2 * (hi - lo));
    let (mut a, mut b) = (r, r);
    a.hi[axis] = at;
    b.lo[axis] = at;
    let ka = k / 2;
    cut(rng, a, ka, dom, out);
    cut(rng, b, k - ka, dom, out);
}

#[test]
fn coi_rule_lists_each_physical_pair_once_over_regions() {
    // h from 0.02 to 0.08: interaction distances up to 0.16. A wide box (periods 1: minimum
    // images unique) and a narrow one (z period 0.1: a particle meets several images of another
    // and its own images).
    // A third case with nearly uniform h (coarse cells).
    for (seed, zmax, n, hr) in [
        (77, 0.5, 900, (0.02, 0.08)),
        (78, -0.4, 300, (0.02, 0.08)),
        (79, 0.5, 700, (0.05, 0.06)),
    ] {
        let per = Periodic {
            axes: [true, false, true],
            min: [0.0, 0.0, -0.5],
            max: [1.0, 1.0, zmax],
        };
        regions_check(seed, &per, n, hr);
    }
}

fn regions_check(seed: u64, per: &Periodic, n: usize, hr: (f64, f64)) {
    let per = *per;
    let mut rng = Rng(seed);
    let dom = (per.min, per.max);
    let real = random_particles(&mut rng, n, per.min, per.max, hr);
    let reach = 2.0 * real.max_h();
    // every copy of every particle: the real one and its periodic images near the box
    let mut copies = Vec::new();
    for i in 0..real.n_owned {
        let r = real.record(i);
        copies.push(r);
        for s in periodic_images(real.x_real[i], reach, &per) {
            let mut g = r;
            g.shift = s;
            copies.push(g);
        }
    }
    for skip_fixed in [false, true] {
        let want = brute_force(&real, Some(&per), skip_fixed);
        assert!(
            want.keys().any(|k| k.2 != [0; 3]),
            "some pairs cross the periodic faces"
        );
        let selfs = want.keys().filter(|k| k.0 == k.1).count();
        println!(
            "period z {}: {} pairs, {selfs} with own images",
            per.period(2),
            want.len()
        );
        for nregions in [1, 2, 5, 7] {
            let all = Region {
                lo: [f64::NEG_INFINITY; 3],
                hi: [f64::INFINITY; 3],
            };
            let mut regions = Vec::new();
            cut(&mut rng, all, nregions, dom, &mut regions);
            let opts = SearchOptions {
                periodic: Some(per),
                skip_fixed_pairs: skip_fixed,
            };
            let mut got: BTreeMap<Key, usize> = BTreeMap::new();
            for reg in &regions {
                // what a rank owning `reg` holds: its particles, then every other copy within
                // reach of its region
                let mut local = Particles::new();
                for c in copies
                    .iter()
                    .filter(|c| c.shift == [0.0; 3] && reg.contains(c.x))
                {
                    local.push_owned(c);
                }
                for c in &copies {
                    let x = [0, 1, 2].map(|k| c.x[k] + c.shift[k]);
                    let owned_here = c.shift == [0.0; 3] && reg.contains(c.x);
                    if !owned_here && reg.near(x, reach) {
                        local.push_ghost(c);
                    }
                }
                for (i, j) in pairs(&local, &opts, |x| reg.contains(x)) {
                    let (i, j) = (i as usize, j as usize);
                    *got.entry(key_of(&local, i, j, Some(&per))).or_insert(0) += 1;
                    // the COI is the same bits from either end
                    let (a, b) = (local.pair_end(i, Some(&per)), local.pair_end(j, Some(&per)));
                    assert_eq!(coi(&a, &b, Some(&per)), coi(&b, &a, Some(&per)));
                }
            }
            let dup: Vec<_> = got.iter().filter(|(_, &n)| n != 1).collect();
            assert!(
                dup.is_empty(),
                "{nregions} regions: pairs listed more than once: {dup:?}"
            );
            let missing: Vec<_> = want.keys().filter(|k| !got.contains_key(*k)).collect();
            let extra: Vec<_> = got.keys().filter(|k| !want.contains_key(*k)).collect();
            assert!(
                missing.is_empty() && extra.is_empty(),
                "{nregions} regions: missing {missing:?}, extra {extra:?}"
            );
        }
    }
}

#[test]
fn coi_is_the_midpoint_of_the_closest_sphere_points() {
    // Reference: hand geometry. Spheres of radius 1 at x = 0 and 0.5 at x = 1.2 (overlap):
    // closest point of A to B's centre: x = 1; of B to A's centre: x = 0.7; COI = 0.85.
    let a = sph::PairEnd {
        id: 1,
        x_real: [0.0; 3],
        image: [0; 3],
        h: 1.0,
    };
    let b = sph::PairEnd {
        id: 2,
        x_real: [1.2, 0.0, 0.0],
        image: [0; 3],
        h: 0.5,
    };
    let c = coi(&a, &b, None);
    assert!(c.overlap && (c.point[0] - 0.85).abs() < 1e-15 && c.point[1] == 0.0);
    // B's centre inside A (r = 0.3 < h_a): A's closest point is B's centre itself, B's closest
    // point to A is at distance min(h_b, r) = 0.3 from B, i.e. A's centre: COI = 0.15.
    let b2 = sph::PairEnd {
        x_real: [0.3, 0.0, 0.0],
        ..b
    };
    assert!((coi(&a, &b2, None).point[0] - 0.15).abs() < 1e-15);
    // across a periodic face: A at 0.95, B at 0.05 + one period image (period 1): d = +0.1
    let per = Periodic {
        axes: [true, false, false],
        min: [0.0; 3],
        max: [1.0; 3],
    };
    let pa = sph::PairEnd {
        id: 1,
        x_real: [0.95, 0.0, 0.0],
        image: [0; 3],
        h: 0.1,
    };
    let pb = sph::PairEnd {
        id: 2,
        x_real: [0.05, 0.0, 0.0],
        image: [1, 0, 0],
        h: 0.1,
    };
    let c = coi(&pa, &pb, Some(&per));
    // unwrapped COI 1.0 -> wrapped 0.0; the listed copy is the one with a's image at -1
    assert!(c.overlap && c.point[0].abs() < 1e-15 && c.a_image == [-1, 0, 0]);
}
