//! Self-test of the parallel contact stage (`tdyn_selftest contact`): random moving faces and
//! nodes (a third of the free ones SPH particles with a radius, plus a crowd of free
//! particles), some crossing a face during the step, spread over the ranks at random; the
//! particles change homes every step and the crowd gathers in one corner from step 6. The
//! contacts the stage finds over all ranks must equal those of one serial box holding
//! everything (whose search the `contact` crate checks against brute force), with the same
//! depths and forces, and the forces must sum to zero (momentum); the kept decomposition must
//! be rebuilt exactly when the skin (step 3) or the balance (step 7) asks for it.
use contact::{
    push_back, search, ContactBox, FaceRecord, NodeRecord, PushBackParams, FLAG_PARTICLE,
};
use coupling::kernels::collective::first_error;
use coupling::stages::contact::stage::{ContactStage, FullFace};

/// Contact radius of the test's particles, m (a tenth of a face's half-width, about the
/// crossing depths of the test).
const PARTICLE_RADIUS: f64 = 0.002;
/// Free particles besides the faces' crossing nodes (see `configuration`).
const N_CROWD: usize = 800;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

struct Rng(u64);
impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn unit(a: [f64; 3]) -> [f64; 3] {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    [a[0] / n, a[1] / n, a[2] / n]
}

/// The global configuration (the same on every rank): nodes (face corners first) and faces.
fn configuration(seed: u64, step: usize, n_faces: usize) -> (Vec<NodeRecord>, Vec<FaceRecord>) {
    let mut rng = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
    let mut nodes = Vec::new();
    let mut free = Vec::new();
    let mut faces = Vec::new();
    // Small drifts from step to step (the stage keeps its decomposition), a jump at step 3 (it
    // must rebuild); the crowd of particles gathers in a corner at step 6 (see below).
    let drift = 0.002 * step as f64 + if step >= 3 { 0.1 } else { 0.0 };
    for k in 0..n_faces {
        let c = [rng.unit(), rng.unit(), rng.unit()];
        let n = unit([rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5]);
        let t1 = unit(cross(n, [0.3, 0.5, 0.81]));
        let t2 = cross(n, t1);
        let s = 0.02;
        let mv = [
            0.002 * (rng.unit() - 0.5),
            0.002 * (rng.unit() - 0.5),
            0.002 * (rng.unit() - 0.5),
        ];
        let mut ids = [0u64; 4];
        for (q, (a, b)) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .iter()
            .enumerate()
        {
            let x0: [f64; 3] =
                std::array::from_fn(|d| c[d] + s * (a * t1[d] + b * t2[d]) + drift * n[d]);
            let gid = (4 * k + q) as u64;
            ids[q] = gid;
            nodes.push(NodeRecord {
                gid,
                body: k as u32,
                flags: 0,
                mass: 1.0 + rng.unit(),
                radius: 0.0,
                x0,
                x1: std::array::from_fn(|d| x0[d] + mv[d]),
                v: mv,
            });
        }
        faces.push(FaceRecord {
            gid: 1_000_000 + k as u64,
            nodes: ids,
            body: k as u32,
            reserved: 0,
        });
        // Every other face gets a node crossing it during the step (a unit time step, so the
        // velocity is the displacement); the rest of the nodes fly at random.
        let gid = (4 * n_faces + k) as u64;
        let (x0, x1) = if k % 2 == 0 {
            let (a, b) = (rng.unit() * 1.6 - 0.8, rng.unit() * 1.6 - 0.8);
            let p: [f64; 3] = std::array::from_fn(|d| c[d] + s * (a * t1[d] + b * t2[d]));
            let (up, down) = (0.004 + drift * 0.1, 0.003 * rng.unit() + 0.0005);
            (
                std::array::from_fn(|d| p[d] + (drift + up) * n[d]),
                std::array::from_fn(|d| p[d] + (drift - down) * n[d] + mv[d]),
            )
        } else {
            let x0 = [rng.unit(), rng.unit(), rng.unit()];
            (
                x0,
                std::array::from_fn(|d| x0[d] + 0.01 * (rng.unit() - 0.5)),
            )
        };
        // every third free node is an SPH particle (a sphere of radius PARTICLE_RADIUS)
        let particle = k % 3 == 1;
        free.push(NodeRecord {
            gid,
            body: (n_faces + k) as u32,
            flags: if particle { FLAG_PARTICLE } else { 0 },
            mass: 0.5 + rng.unit(),
            radius: if particle { PARTICLE_RADIUS } else { 0.0 },
            x0,
            x1,
            v: std::array::from_fn(|d| x1[d] - x0[d]),
        });
    }
    // A crowd of free particles (a quarter of all nodes), which from step 6 gathers in one
    // corner of the domain (a tenth of its size), each moving little within the step: the
    // contact work's balance drifts while the skin still holds, and the stage must rebuild
    // (and rebalance) for the drift.
    for q in 0..N_CROWD {
        let p0 = [rng.unit(), rng.unit(), rng.unit()];
        let p0 = if step >= 6 { p0.map(|c| 0.1 * c) } else { p0 };
        let mv: [f64; 3] = std::array::from_fn(|_| 0.001 * (rng.unit() - 0.5));
        free.push(NodeRecord {
            gid: (5 * n_faces + q) as u64,
            body: u32::MAX,
            flags: FLAG_PARTICLE,
            mass: 0.5 + rng.unit(),
            radius: PARTICLE_RADIUS,
            x0: p0,
            x1: std::array::from_fn(|d| p0[d] + mv[d]),
            v: mv,
        });
    }
    // Corners have gids 0..4F, free nodes 4F..5F, the crowd after: index = gid.
    nodes.append(&mut free);
    (nodes, faces)
}

/// Gathers (node gid, face gid, depth) of every rank on every rank, sorted.
fn gather_found(comm: &SimpleCommunicator, found: &[(u64, u64, f64)]) -> Vec<(u64, u64, f64)> {
    let flat: Vec<u64> = found
        .iter()
        .flat_map(|c| [c.0, c.1, c.2.to_bits()])
        .collect();
    let all = coupling::kernels::collective::all_gather_varcount(comm, &flat);
    let mut out: Vec<(u64, u64, f64)> = all
        .chunks(3)
        .map(|c| (c[0], c[1], f64::from_bits(c[2])))
        .collect();
    out.sort_by_key(|a| (a.0, a.1));
    out
}

/// Runs the self-test; returns a summary or the first failure (the same on every rank).
pub fn selftest(comm: &SimpleCommunicator, seed: u64) -> Result<String, String> {
    let p = comm.size() as u64;
    let me = comm.rank() as u64;
    let n_faces = 400;
    let mut stage = ContactStage::new(comm, false, false);
    let mut total_contacts = 0;
    let mut lines = Vec::new();
    let steps = 9;
    for step in 0..steps {
        let before = stage.rebuilds.decomposition;
        let (nodes, faces) = configuration(seed, step, n_faces);
        // FE/SPH owners at random; faces on another random rank, with their nodes' records.
        // Particles change homes every step (SPH migration), mesh nodes never: the kept
        // decomposition must serve anyway.
        let home = |n: &NodeRecord| {
            let salt = if n.flags & FLAG_PARTICLE != 0 {
                step as u64 * 7919
            } else {
                0
            };
            ((n.gid + salt).wrapping_mul(2654435761) >> 5) % p
        };
        let mine: Vec<NodeRecord> = nodes.iter().filter(|n| home(n) == me).copied().collect();
        let my_faces: Vec<FullFace> = faces
            .iter()
            .filter(|f| (f.gid * 7 + 3) % p == me)
            .map(|f| FullFace {
                face: *f,
                nodes: std::array::from_fn(|q| nodes[f.nodes[q] as usize]),
            })
            .collect();
        let out = stage.step(&mine, || my_faces, 1.0)?;
        let found = gather_found(comm, &out.found);
        // The reference: one box holding everything, searched serially.
        let b = ContactBox::from_records(&nodes, nodes.len(), &faces).map_err(|e| e.to_string())?;
        let reference = search(&b, &stage.params);
        let pb = push_back(&b, &reference, &PushBackParams::new(1.0));
        let mut refs: Vec<(u64, u64, f64)> = reference
            .iter()
            .map(|c| (c.node_gid, c.face_gid, c.depth))
            .collect();
        refs.sort_by_key(|a| (a.0, a.1));
        let mut err = None;
        if found.len() != refs.len()
            || found
                .iter()
                .zip(&refs)
                .any(|(a, b)| a.0 != b.0 || a.1 != b.1 || (a.2 - b.2).abs() > 1e-12)
        {
            err = Some(format!(
                "step {step}: {} contacts found in parallel, {} by the serial search (or a pair or depth differs by more than 1e-12 m)",
                found.len(),
                refs.len()
            ));
        }
        if refs.len() < n_faces / 4 {
            err = Some(format!(
                "step {step}: only {} contacts in the test configuration",
                refs.len()
            ));
        }
        // Forces: the same as the serial push-back at each node (one contact per face, so the
        // boxes' solutions cannot differ), and summing to zero over all ranks.
        let mut fmax = 0.0f64;
        let mut sum = [0.0f64; 3];
        for (i, n) in mine.iter().enumerate() {
            let f = out.force[i];
            let r = pb.force[n.gid as usize];
            for d in 0..3 {
                sum[d] += f[d];
                fmax = fmax.max(r[d].abs());
                if (f[d] - r[d]).abs() > 1e-9 * (1.0 + r[d].abs()) && err.is_none() {
                    err = Some(format!(
                        "step {step}: node {} force {f:?}, serial push-back {r:?}",
                        n.gid
                    ));
                }
            }
        }
        let mut gsum = [0.0f64; 3];
        comm.all_reduce_into(
            &sum[..],
            &mut gsum[..],
            mpi::collective::SystemOperation::sum(),
        );
        let total_ref: f64 = pb.force.iter().flatten().map(|c| c.abs()).sum();
        if gsum.iter().any(|c| c.abs() > 1e-12 * total_ref) && err.is_none() {
            err = Some(format!(
                "step {step}: forces sum to {gsum:?}, expected 0 within 1e-12 x {total_ref:e}"
            ));
        }
        first_error(comm, err)?;
        total_contacts += found.len();
        lines.push(format!(
            "step {step}: {} contacts (= serial), decomposition {}, imbalance {:.3}, {} bytes, rcb migrated {}",
            found.len(),
            if stage.rebuilds.decomposition > before { "rebuilt" } else { "kept" },
            out.imbalance,
            out.bytes_sent,
            out.rcb.migrated
        ));
    }
    // The kept decomposition must have served: rebuilt at steps 0 and 3 (the skin) and 7 (the
    // balance, after the crowd gathered at step 6; not on one rank, always balanced) only.
    let want = if p == 1 { 2 } else { 3 };
    if stage.rebuilds.decomposition != want {
        return Err(format!(
            "the decomposition was rebuilt {} times over {steps} steps, expected {want}",
            stage.rebuilds.decomposition
        ));
    }
    Ok(format!(
        "contact selftest passed at np {p}: {total_contacts} contacts over {steps} steps\n  {}",
        lines.join("\n  ")
    ))
}
