#![allow(clippy::needless_range_loop)]
//! Times one element update in a tight loop (no mesh, no MPI): `cargo run --release --example hex_bench`.
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
    let mut st = vec![HexState::default(); n];
    let mut ms = vec![0.0; n];
    let vol0 = 1e-6;
    let reps = 20;
    let mut acc = 0.0;
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
    let t = Instant::now();
    for _ in 0..reps {
        for xe in &x {
            acc += hex::volume(xe);
        }
    }
    let nsv = t.elapsed().as_secs_f64() * 1e9 / (reps * n) as f64;
    println!("hex::update {ns:.1} ns/element, hex::volume {nsv:.1} ns (checksum {acc:e})");
}
