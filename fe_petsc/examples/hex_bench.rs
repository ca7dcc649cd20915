#![allow(clippy::needless_range_loop)]
//! Times the element update in a tight loop (no mesh, no MPI), the scalar kernel and the batched
//! one at every width this CPU runs: `cargo run --release --example hex_bench -- [reps]
//! [scalar|batched|both]`.
use fe_petsc::batch::{self, Batch, LaneMaterial, Width};
use fe_petsc::hex::{self, HexControls, HexState};
use fe_petsc::material::{build_material, MaterialSpec};
use std::time::Instant;

fn main() {
    let spec = MaterialSpec {
        name: "steel".into(),
        model: "j2_plastic".into(),
        density: 7850.0,
        params: [
            ("youngs_modulus", 200e9),
            ("poisson_ratio", 0.3),
            ("yield_stress", 350e6),
            ("hardening_modulus", 1e9),
        ]
        .iter()
        .map(|(k, v)| (k.to_string(), *v))
        .collect(),
        eos: None,
    };
    let mat = build_material(&spec).unwrap();
    let ctl = HexControls::default();
    let n = 100_000;
    let x: Vec<[[f64; 3]; 8]> = (0..n)
        .map(|e| {
            std::array::from_fn(|k| {
                std::array::from_fn(|i| {
                    0.01 * (0.5 * (hex::NODE_XI[k][i] + 1.0))
                        + 1e-4 * ((e * 7 + k * 3 + i) % 5) as f64
                })
            })
        })
        .collect();
    let v: Vec<[[f64; 3]; 8]> = (0..n)
        .map(|e| {
            std::array::from_fn(|k| {
                std::array::from_fn(|i| -10.0 * hex::NODE_XI[k][i] + ((e + k + i) % 3) as f64)
            })
        })
        .collect();
    let args: Vec<String> = std::env::args().collect();
    let reps: usize = args.get(1).map_or(20, |a| a.parse().expect("reps"));
    let kernels = args.get(2).map_or("both", |a| a.as_str());
    let vol0 = 1e-6;
    let mut acc = 0.0;
    if kernels != "batched" {
        let mut st = vec![HexState::default(); n];
        let mut ms = vec![0.0; n];
        let t = Instant::now();
        for _ in 0..reps {
            for e in 0..n {
                let o = hex::update(
                    &x[e],
                    &v[e],
                    1e-7,
                    7850.0,
                    vol0,
                    &*mat,
                    &ctl,
                    &mut st[e],
                    &mut ms[e..e + 1],
                )
                .unwrap();
                acc += o.force[0][0];
            }
        }
        let ns = t.elapsed().as_secs_f64() * 1e9 / (reps * n) as f64;
        println!("hex::update {ns:.1} ns/element (checksum {acc:e})");
    }
    if kernels != "scalar" {
        // The same elements in groups (loaded from the element arrays each time, as the
        // explicit loop does): every width this CPU runs.
        let lm = LaneMaterial::new(&*mat, &ctl).unwrap();
        for w in batch::available() {
            let ns = match w {
                Width::W4 => {
                    batched::<batch::w4::LaneGroup>(&x, &v, vol0, &lm, &ctl, reps, &mut acc)
                }
                #[cfg(target_arch = "x86_64")]
                Width::W8 => {
                    batched::<batch::w8::LaneGroup>(&x, &v, vol0, &lm, &ctl, reps, &mut acc)
                }
            };
            println!("batch::{w:?} update {ns:.1} ns/element (checksum {acc:e})");
        }
    }
}

/// ns per element of `reps` updates of every element in groups of `B::LANES`.
fn batched<B: Batch>(
    x: &[[[f64; 3]; 8]],
    v: &[[[f64; 3]; 8]],
    vol0: f64,
    lm: &LaneMaterial,
    ctl: &HexControls,
    reps: usize,
    acc: &mut f64,
) -> f64 {
    // Each element's nodes numbered apart (element e: nodes 8e..8e+8).
    let xs: Vec<[f64; 3]> = x.iter().flatten().copied().collect();
    let vs: Vec<[f64; 3]> = v.iter().flatten().copied().collect();
    let conn: Vec<[u32; 8]> = (0..x.len())
        .map(|e| std::array::from_fn(|k| (8 * e + k) as u32))
        .collect();
    let n = x.len() / B::LANES * B::LANES;
    let vol = vec![vol0; n];
    let mut st = vec![HexState::default(); n];
    let mut hist = vec![0.0; n];
    let mut group = B::default();
    let t = Instant::now();
    for _ in 0..reps {
        for g in (0..n).step_by(B::LANES) {
            let e = g..g + B::LANES;
            group.load(&xs, &vs, &conn[e.clone()], &vol[e.clone()], &st[e], |l| {
                hist[g + l]
            });
            group.update(1e-7, lm, ctl).unwrap();
            for l in 0..B::LANES {
                (st[g + l], hist[g + l]) = group.lane_state(l);
            }
            *acc += group.lane_output(0).force[0][0];
        }
    }
    t.elapsed().as_secs_f64() * 1e9 / (reps * n) as f64
}
