#![allow(clippy::needless_range_loop)]
//! Times the element update in a tight loop (no mesh, no MPI), the scalar kernel and the batched
//! one at every width this CPU runs: `cargo run --release --example hex_bench -- [reps]
//! [scalar|batched|both] [file|shuffled|reordered]` (the last: the elements' order).
use fe_petsc::batch::{self, Batch, LaneMaterial, Width};
use fe_petsc::hex::{self, HexControls, HexState};
use fe_petsc::locality;
use fe_petsc::material::{build_material, Material, MaterialSpec, MAX_STATE};
use fe_petsc::mesh::LocalMesh;
use fe_petsc::states::HexStates;
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
    // A structured block of 47^3 = 103,823 elements with shared nodes, numbered along x then y
    // then z (as the benchmark scene's mesh), its nodes moved off the grid and given varied
    // velocities so that every branch of the kernel sees varied data.
    let m = 47;
    let node = |i: usize, j: usize, k: usize| (i + (m + 1) * (j + (m + 1) * k)) as u32;
    let h = 0.01;
    let nn = (m + 1) * (m + 1) * (m + 1);
    let xs: Vec<[f64; 3]> = (0..nn)
        .map(|p| {
            let ijk = [
                p % (m + 1),
                (p / (m + 1)) % (m + 1),
                p / ((m + 1) * (m + 1)),
            ];
            std::array::from_fn(|d| h * ijk[d] as f64 + 1e-4 * ((p * 7 + d * 3) % 5) as f64)
        })
        .collect();
    let vs: Vec<[f64; 3]> = (0..nn)
        .map(|p| std::array::from_fn(|d| -10.0 * ((p * 3 + d) % 7) as f64 + 30.0))
        .collect();
    let conn: Vec<[u32; 8]> = (0..m * m * m)
        .map(|e| {
            let (i, j, k) = (e % m, (e / m) % m, e / (m * m));
            std::array::from_fn(|c| {
                let o = |d: usize| (hex::NODE_XI[c][d] > 0.0) as usize;
                node(i + o(0), j + o(1), k + o(2))
            })
        })
        .collect();
    // The element order (third argument): `file` as built (lexicographic), `shuffled` in a
    // random order, `reordered` shuffled then put in order by `locality::order_elements`.
    let order = std::env::args().nth(3).unwrap_or_else(|| "file".into());
    let conn = if order == "file" {
        conn
    } else {
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut conn = conn;
        for i in (1..conn.len()).rev() {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            conn.swap(i, (s % (i as u64 + 1)) as usize);
        }
        if order == "reordered" {
            let mut mesh = LocalMesh {
                coords: xs.clone(),
                elem_id: (0..conn.len() as u64).collect(),
                elem_block: vec![1; conn.len()],
                elems: conn,
                ..Default::default()
            };
            let (lo, hi) = locality::centroid_bounds(&mesh);
            locality::order_elements(&mut mesh, lo, hi);
            mesh.elems
        } else {
            assert_eq!(order, "shuffled", "order: file, shuffled or reordered");
            conn
        }
    };
    let n = conn.len();
    let x: Vec<[[f64; 3]; 8]> = conn
        .iter()
        .map(|c| std::array::from_fn(|k| xs[c[k] as usize]))
        .collect();
    let v: Vec<[[f64; 3]; 8]> = conn
        .iter()
        .map(|c| std::array::from_fn(|k| vs[c[k] as usize]))
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
        let lm = LaneMaterial::new(&*mat, &ctl);
        for w in batch::available() {
            let ns = match w {
                Width::W1 => batched::<batch::w1::LaneGroup>(
                    &xs, &vs, &conn, vol0, &lm, &*mat, &ctl, reps, &mut acc,
                ),
                Width::W4 => batched::<batch::w4::LaneGroup>(
                    &xs, &vs, &conn, vol0, &lm, &*mat, &ctl, reps, &mut acc,
                ),
                #[cfg(target_arch = "x86_64")]
                Width::W8 => batched::<batch::w8::LaneGroup>(
                    &xs, &vs, &conn, vol0, &lm, &*mat, &ctl, reps, &mut acc,
                ),
            };
            println!("batch::{w:?} update {ns:.1} ns/element (checksum {acc:e})");
        }
    }
}

/// ns per element of `reps` updates of every element in groups of `B::LANES`, as the explicit
/// loop runs them (state in lanes, forces added to the nodes from the lanes); prints also the
/// update alone (the same loaded group again and again, in registers and L1).
#[allow(clippy::too_many_arguments)]
fn batched<B: Batch>(
    xs: &[[f64; 3]],
    vs: &[[f64; 3]],
    conn: &[[u32; 8]],
    vol0: f64,
    lm: &LaneMaterial,
    model: &dyn Material,
    ctl: &HexControls,
    reps: usize,
    acc: &mut f64,
) -> f64 {
    let n = conn.len() / B::LANES * B::LANES;
    let vol = vec![vol0; n];
    let mut st = HexStates::new(n);
    let mut hist = vec![0.0; n];
    let mut force = vec![[0.0; 3]; xs.len()];
    let mut group = B::default();
    // One untimed pass first: the arrays' pages mapped and the elements' state past its first
    // step, as in the time loop after its first step (a first pass ran about 1.5x slower than
    // the following ones).
    let mut pass = |group: &mut B| {
        for g in (0..n).step_by(B::LANES) {
            let e = g..g + B::LANES;
            let mut io = batch::GroupLanes {
                xs,
                vs,
                conn: &conn[e.clone()],
                vol0: &vol[e.clone()],
                state: st.lanes_mut(g),
                history: Some(&mut hist[e.clone()]),
                force: Some(&mut force),
            };
            group.update_lanes(&mut io, 1e-7, lm, ctl).unwrap();
        }
    };
    pass(&mut group);
    let t = Instant::now();
    for _ in 0..reps {
        pass(&mut group);
    }
    let full = t.elapsed().as_secs_f64() * 1e9 / (reps * n) as f64;
    *acc += force[0][0];
    // The first group loaded lane by lane (the whole-group path leaves the group's own nodal
    // arrays alone).
    let states = vec![fe_petsc::hex::HexState::default(); B::LANES];
    group.load(xs, vs, &conn[..B::LANES], &vol[..B::LANES], &states, |_| {
        [0.0; MAX_STATE]
    });
    let t = Instant::now();
    for _ in 0..reps {
        for _ in (0..n).step_by(B::LANES) {
            group.update(1e-7, lm, model, ctl).unwrap();
            *acc += group.force(0, 0)[0];
        }
    }
    let update = t.elapsed().as_secs_f64() * 1e9 / (reps * n) as f64;
    println!("  of which the update alone (in cache) {update:.1} ns/element");
    full
}
