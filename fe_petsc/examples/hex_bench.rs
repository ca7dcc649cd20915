#![allow(clippy::needless_range_loop)]
//! Times the element update in a tight loop (no mesh, no MPI), the scalar kernel and the batched
//! one: `cargo run --release --example hex_bench -- [reps] [scalar|batched|both]`.
use fe_petsc::hex::{self, HexControls, HexState};
use fe_petsc::hex_lanes::{self, LaneGroup, LaneMaterial, LaneState};
use fe_petsc::lanes::{F4, LANES};
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
        // The same elements four at a time in lanes (gathered once: this times the kernel).
        let lm = LaneMaterial::new(&*mat, &ctl).unwrap();
        let lane_nodes = |a: &[[[f64; 3]; 8]], g: usize| -> hex_lanes::LaneNodes {
            std::array::from_fn(|k| {
                std::array::from_fn(|c| F4(std::array::from_fn(|l| a[g + l][k][c])))
            })
        };
        let groups: Vec<_> = (0..n / LANES)
            .map(|g| (lane_nodes(&x, g * LANES), lane_nodes(&v, g * LANES)))
            .collect();
        let mut st = vec![LaneState::default(); groups.len()];
        let mut group = LaneGroup {
            vol0: F4::splat(vol0),
            ..Default::default()
        };
        let t = Instant::now();
        for _ in 0..reps {
            for (g, (xg, vg)) in groups.iter().enumerate() {
                (group.x, group.v, group.state) = (*xg, *vg, st[g]);
                group.update(1e-7, &lm, &ctl).unwrap();
                st[g] = group.state;
                acc += group.out.force[0][0].0[0];
            }
        }
        let ns = t.elapsed().as_secs_f64() * 1e9 / (reps * groups.len() * LANES) as f64;
        println!("hex_lanes::LaneGroup::update {ns:.1} ns/element (checksum {acc:e})");
    }
}
