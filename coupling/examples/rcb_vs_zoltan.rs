//! Our parallel RCB ([`coupling::kernels::rcb::Rcb`]) against Zoltan's RCB on exactly the same points,
//! in the same run (`scripts/bench_rcb.sh` runs it at np 1, 2, 4).
//!
//! For every point count and distribution, each repeat starts from scratch:
//! 1. the points are generated from their global ids and dealt out by `id % P` (a bad
//!    initial distribution, as at the start of a run);
//! 2. first partition: ours is one `Rcb::balance` call (which also moves the records); Zoltan is
//!    one `Zoltan_LB_Partition` (timed alone), then the records are moved along the export lists
//!    with [`CommPlan`] (timed separately);
//! 3. every point is displaced by 1 % of the mean spacing `N^(-1/3)` in a random direction
//!    (deterministic by id), and the same structures rebalance: a second `balance` on the same
//!    `Rcb`, a second `Zoltan_LB_Partition` on the same `Zoltan_Struct` (`RCB_REUSE=1`) plus
//!    its move.
//!
//! The two codes alternate which goes first from repeat to repeat. Times are max over ranks
//! (a barrier before each timed region); the ratio ours/Zoltan is taken per repeat and its
//! median reported. The first repeat also checks the results: every id owned exactly once, the
//! owned points inside the owner's region (our cut tree; Zoltan's `Zoltan_LB_Point_Assign`), and
//! Zoltan's export lists (ids match the records, destinations valid, part == proc).
//!
//! The record is 64 bytes: position (3 f64), id (u64), velocity (3 f64) and mass (f64).
//!
//! Zoltan is called through its C interface (Debian's libtrilinos-zoltan-dev; the header's
//! `ZOLTAN_ID_TYPE` is `unsigned int`, Zoltan_config.h selecting no wider type).
//!
//! Usage: `mpirun -np P rcb_vs_zoltan [--sizes 100000:15,1000000:7] [--dists uniform,clustered]
//! [--tol 1.0] [--check-geom 0] [--csv FILE]` (rows are appended to FILE on rank 0).
use bytemuck::{Pod, Zeroable};
use coupling::kernels::comm::CommPlan;
use coupling::kernels::rcb::{Rcb, RcbItem};
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::io::Write;
use std::time::Instant;

// Zoltan's C interface (the subset used here).
#[path = "rcb_vs_zoltan/zoltan.rs"]
mod zoltan;
use zoltan::*;

// ---------------------------------------------------------------------------------------------
// The points.

/// A 64-byte record: position, id, velocity, mass.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Rec {
    x: [f64; 3],
    id: u64,
    v: [f64; 3],
    m: f64,
}

impl RcbItem for Rec {
    fn position(&self) -> [f64; 3] {
        self.x
    }
    fn id(&self) -> u64 {
        self.id
    }
}

fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The k-th uniform number in [0, 1) of stream `s` for point `id`.
fn unit(id: u64, s: u64, k: u64) -> f64 {
    let h = splitmix(splitmix(id ^ (s << 56)) ^ k);
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// Two standard normal numbers (Box-Muller) from uniforms k and k+1.
fn normal2(id: u64, s: u64, k: u64) -> (f64, f64) {
    let u1 = 1.0 - unit(id, s, k); // (0, 1]
    let u2 = unit(id, s, k + 1);
    let r = (-2.0 * u1.ln()).sqrt();
    let t = std::f64::consts::TAU * u2;
    (r * t.cos(), r * t.sin())
}

#[derive(Clone, Copy, PartialEq)]
enum Dist {
    Uniform,
    Clustered,
}

impl Dist {
    fn name(self) -> &'static str {
        match self {
            Dist::Uniform => "uniform",
            Dist::Clustered => "clustered",
        }
    }
}

/// Blobs of the clustered set: centre, standard deviation, share of the points.
const BLOBS: [([f64; 3], f64, f64); 4] = [
    ([0.25, 0.30, 0.35], 0.04, 0.40),
    ([0.70, 0.65, 0.30], 0.06, 0.30),
    ([0.40, 0.75, 0.75], 0.08, 0.20),
    ([0.80, 0.20, 0.80], 0.02, 0.10),
];

/// The point with global id `id` (the same on every rank, for both codes).
fn point(id: u64, dist: Dist) -> Rec {
    let x = match dist {
        Dist::Uniform => [unit(id, 1, 0), unit(id, 1, 1), unit(id, 1, 2)],
        Dist::Clustered => {
            let u = unit(id, 1, 0);
            let mut acc = 0.0;
            let mut b = BLOBS.len() - 1;
            for (k, blob) in BLOBS.iter().enumerate() {
                acc += blob.2;
                if u < acc {
                    b = k;
                    break;
                }
            }
            let (c, s, _) = BLOBS[b];
            let (g0, g1) = normal2(id, 1, 1);
            let (g2, _) = normal2(id, 1, 3);
            [c[0] + s * g0, c[1] + s * g1, c[2] + s * g2]
        }
    };
    Rec {
        x,
        id,
        v: [unit(id, 2, 0), unit(id, 2, 1), unit(id, 2, 2)],
        m: 1.0 + unit(id, 2, 3),
    }
}

/// This rank's initial points: ids `me, me + P, me + 2P, ...` below `n`.
fn initial(n: u64, me: i32, p: i32, dist: Dist) -> Vec<Rec> {
    (me as u64..n)
        .step_by(p as usize)
        .map(|id| point(id, dist))
        .collect()
}

/// Moves every point by `h` in a random direction (deterministic by id).
fn displace(items: &mut [Rec], h: f64) {
    for r in items {
        let z = 2.0 * unit(r.id, 3, 0) - 1.0;
        let phi = std::f64::consts::TAU * unit(r.id, 3, 1);
        let s = (1.0 - z * z).max(0.0).sqrt();
        r.x[0] += h * s * phi.cos();
        r.x[1] += h * s * phi.sin();
        r.x[2] += h * z;
    }
}

// ---------------------------------------------------------------------------------------------
// Measuring and checking.

/// Runs `f` between a barrier and a max-reduction of its wall time over ranks.
fn timed<R>(comm: &SimpleCommunicator, f: impl FnOnce() -> R) -> (R, f64) {
    comm.barrier();
    let t0 = Instant::now();
    let r = f();
    let loc = t0.elapsed().as_secs_f64();
    let mut max = 0.0;
    comm.all_reduce_into(&loc, &mut max, SystemOperation::max());
    (r, max)
}

/// Max over ranks of the local count, over the mean.
fn imbalance(comm: &SimpleCommunicator, n_loc: usize) -> f64 {
    let (mut max, mut sum) = (0u64, 0u64);
    comm.all_reduce_into(&(n_loc as u64), &mut max, SystemOperation::max());
    comm.all_reduce_into(&(n_loc as u64), &mut sum, SystemOperation::sum());
    let mean = sum as f64 / comm.size() as f64;
    if mean > 0.0 {
        max as f64 / mean
    } else {
        1.0
    }
}

fn sum_u64(comm: &SimpleCommunicator, v: u64) -> u64 {
    let mut s = 0;
    comm.all_reduce_into(&v, &mut s, SystemOperation::sum());
    s
}

/// Zoltan's records move: exported records go to their new rank through a [`CommPlan`]; the
/// rank keeps the others (compacted in place, in order) followed by what it receives.
fn zoltan_move(comm: &SimpleCommunicator, items: &mut Vec<Rec>, ex: &Exports) {
    let mut gone = vec![false; items.len()];
    let mut send = Vec::with_capacity(ex.n);
    for &l in ex.lids() {
        gone[l as usize] = true;
        send.push(items[l as usize]);
    }
    let mut plan = CommPlan::new(comm, ex.procs());
    let got = plan.exchange(&send);
    if ex.n > 0 {
        let mut k = 0;
        items.retain(|_| {
            k += 1;
            !gone[k - 1]
        });
    }
    items.extend_from_slice(&got);
}

/// Whether every id in `0..n` is owned by exactly one rank (each id is checked on rank id % P).
fn ids_once(comm: &SimpleCommunicator, items: &[Rec], n: u64) -> bool {
    let p = comm.size() as u64;
    let me = comm.rank() as u64;
    let dest: Vec<i32> = items.iter().map(|r| (r.id % p) as i32).collect();
    let ids: Vec<u64> = items.iter().map(|r| r.id).collect();
    let mut plan = CommPlan::new(comm, &dest);
    let got = plan.exchange(&ids);
    let mine = if me < n { (n - me).div_ceil(p) } else { 0 };
    let mut seen = vec![0u8; mine as usize];
    let mut ok = true;
    for id in got {
        if id >= n || id % p != me {
            ok = false;
            continue;
        }
        let k = (id / p) as usize;
        seen[k] = seen[k].saturating_add(1);
    }
    ok &= seen.iter().all(|&s| s == 1);
    sum_u64(comm, (!ok) as u64) == 0
}

/// Zoltan's export lists are consistent with the records handed in; returns bad entries.
fn check_exports(comm: &SimpleCommunicator, items: &[Rec], ex: &Exports) -> u64 {
    let p = comm.size();
    let me = comm.rank();
    let mut bad = 0u64;
    let mut seen = vec![false; items.len()];
    for k in 0..ex.n {
        let l = ex.lids()[k] as usize;
        let pr = ex.procs()[k];
        let ok = l < items.len()
            && !seen[l]
            && items[l].id as ZoltanId == ex.gids()[k]
            && (0..p).contains(&pr)
            && pr != me
            && ex.parts()[k] == pr;
        if l < items.len() {
            seen[l] = true;
        }
        bad += (!ok) as u64;
    }
    sum_u64(comm, bad)
}

/// One repeat's measurements of one call (first partition or rebalance).
#[derive(Clone, Copy, Default)]
struct Sample {
    ours_s: f64,
    z_part_s: f64,
    z_move_s: f64,
    imb_ours: f64,
    imb_z: f64,
    mig_ours: u64,
    mig_z: u64,
    iters: u64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

struct Case {
    n: u64,
    dist: Dist,
    repeats: usize,
}

fn zoltan_params(
    p: i32,
    tol: &str,
    check_geom: &str,
    lock: &str,
    avg: &str,
) -> Vec<(&'static str, String)> {
    vec![
        ("DEBUG_LEVEL", "0".into()),
        ("LB_METHOD", "RCB".into()),
        ("NUM_GID_ENTRIES", "1".into()),
        ("NUM_LID_ENTRIES", "1".into()),
        ("NUM_GLOBAL_PARTS", p.to_string()),
        ("OBJ_WEIGHT_DIM", "0".into()),
        ("RETURN_LISTS", "EXPORT".into()),
        ("IMBALANCE_TOL", tol.into()),
        ("RCB_REUSE", "1".into()),
        ("KEEP_CUTS", "1".into()),
        ("CHECK_GEOM", check_geom.into()),
        ("RCB_OUTPUT_LEVEL", "0".into()),
        ("RCB_LOCK_DIRECTIONS", lock.into()),
        ("AVERAGE_CUTS", avg.into()),
    ]
}

fn main() {
    let universe = mpi::initialize().expect("MPI init");
    let world = universe.world();
    let me = world.rank();
    let p = world.size();
    let mut ver = 0.0f32;
    // SAFETY: MPI is initialised; Zoltan does not take argv.
    let rc = unsafe { Zoltan_Initialize(0, std::ptr::null_mut(), &mut ver) };
    assert_eq!(rc, ZOLTAN_OK, "Zoltan_Initialize failed");

    // Arguments.
    let mut sizes = vec![(100_000u64, 15usize), (1_000_000, 7)];
    let mut dists = vec![Dist::Uniform, Dist::Clustered];
    let mut tol = "1.0".to_string();
    let mut check_geom = "0".to_string();
    let mut lock = "1".to_string();
    let mut avg = "1".to_string();
    let mut csv: Option<String> = None;
    let mut only = "both".to_string();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < args.len() {
        let val = args.get(i + 1).cloned().unwrap_or_default();
        match args[i].as_str() {
            "--sizes" => {
                sizes = val
                    .split(',')
                    .map(|s| {
                        let (n, r) = s.split_once(':').unwrap_or((s, "3"));
                        (n.parse().expect("size"), r.parse().expect("repeats"))
                    })
                    .collect()
            }
            "--dists" => {
                dists = val
                    .split(',')
                    .map(|s| match s {
                        "uniform" => Dist::Uniform,
                        "clustered" => Dist::Clustered,
                        _ => panic!("unknown distribution {s}"),
                    })
                    .collect()
            }
            "--tol" => tol = val,
            "--check-geom" => check_geom = val,
            "--lock-directions" => lock = val,
            "--average-cuts" => avg = val,
            "--csv" => csv = Some(val),
            "--only" => only = val,
            a => panic!("unknown argument {a}"),
        }
        i += 2;
    }
    let params = zoltan_params(p, &tol, &check_geom, &lock, &avg);
    if me == 0 {
        eprintln!(
            "rcb_vs_zoltan: np {p}, Zoltan {ver}, record {} bytes, params {:?}",
            std::mem::size_of::<Rec>(),
            params
        );
    }
    let cases: Vec<Case> = sizes
        .iter()
        .flat_map(|&(n, repeats)| dists.iter().map(move |&dist| Case { n, dist, repeats }))
        .collect();

    for case in &cases {
        let n = case.n;
        let h = 0.01 * (1.0 / n as f64).cbrt();
        let mut samples: Vec<[Sample; 2]> = Vec::new();
        let mut checks: Vec<String> = Vec::new();
        for rep in 0..case.repeats {
            let check = rep == 0;
            let mut s = [Sample::default(); 2];
            let run_ours = |s: &mut [Sample; 2], checks: &mut Vec<String>| {
                let items = initial(n, me, p, case.dist);
                let mut rcb = Rcb::new(&world);
                let (r, t) = timed(&world, || rcb.balance(items));
                let (mut items, st) = r.expect("balance");
                s[0].ours_s = t;
                s[0].imb_ours = st.imbalance;
                s[0].mig_ours = st.migrated;
                s[0].iters = st.iterations;
                if check {
                    checks.extend(check_ours(&world, &rcb, &items, n, "ours first"));
                }
                displace(&mut items, h);
                let (r, t) = timed(&world, || rcb.balance(items));
                let (items, st) = r.expect("balance");
                s[1].ours_s = t;
                s[1].imb_ours = st.imbalance;
                s[1].mig_ours = st.migrated;
                s[1].iters = st.iterations;
                if check {
                    checks.extend(check_ours(&world, &rcb, &items, n, "ours rebalance"));
                }
            };
            let run_zoltan = |s: &mut [Sample; 2], checks: &mut Vec<String>| {
                let mut items = initial(n, me, p, case.dist);
                let mut z = Zoltan::new(&world, &params);
                for (call, sc) in s.iter_mut().enumerate() {
                    if call == 1 {
                        displace(&mut items, h);
                    }
                    let what = if call == 0 {
                        "zoltan first"
                    } else {
                        "zoltan rebalance"
                    };
                    let (ex, tp) = timed(&world, || z.partition(&items));
                    if check {
                        let bad = check_exports(&world, &items, &ex);
                        if bad > 0 {
                            checks.push(format!("{what}: {bad} bad export entries"));
                        }
                    }
                    sc.mig_z = sum_u64(&world, ex.n as u64);
                    let ((), tm) = timed(&world, || {
                        zoltan_move(&world, &mut items, &ex);
                        drop(ex);
                    });
                    sc.z_part_s = tp;
                    sc.z_move_s = tm;
                    sc.imb_z = imbalance(&world, items.len());
                    if check {
                        checks.extend(check_zoltan(&world, &z, &items, n, what));
                    }
                }
            };
            let (ours, zoltan) = (only != "zoltan", only != "ours");
            if rep % 2 == 0 {
                if ours {
                    run_ours(&mut s, &mut checks);
                }
                if zoltan {
                    run_zoltan(&mut s, &mut checks);
                }
            } else {
                if zoltan {
                    run_zoltan(&mut s, &mut checks);
                }
                if ours {
                    run_ours(&mut s, &mut checks);
                }
            }
            samples.push(s);
        }
        // Report.
        let check_str = if checks.is_empty() {
            "ok".to_string()
        } else {
            checks.join("; ")
        };
        for (call, name) in ["first", "rebalance"].iter().enumerate() {
            let col = |f: &dyn Fn(&Sample) -> f64| -> f64 {
                median(samples.iter().map(|s| f(&s[call])).collect())
            };
            let ours = col(&|s| s.ours_s);
            let zp = col(&|s| s.z_part_s);
            let zm = col(&|s| s.z_move_s);
            let zt = col(&|s| s.z_part_s + s.z_move_s);
            let r_tot = col(&|s| s.ours_s / (s.z_part_s + s.z_move_s));
            let r_part = col(&|s| s.ours_s / s.z_part_s);
            let s0 = samples[0][call];
            let row = format!(
                "{p},{n},{},{name},{},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.4},{:.4},{},{},{},{}",
                case.dist.name(),
                case.repeats,
                1e3 * ours,
                1e3 * zp,
                1e3 * zm,
                1e3 * zt,
                r_tot,
                r_part,
                s0.imb_ours,
                s0.imb_z,
                s0.mig_ours,
                s0.mig_z,
                s0.iters,
                check_str.replace(',', ";")
            );
            if me == 0 {
                println!("{row}");
                eprintln!(
                    "  per repeat ms (ours | z part + move): {}",
                    samples
                        .iter()
                        .map(|s| format!(
                            "{:.1}|{:.1}+{:.1}",
                            1e3 * s[call].ours_s,
                            1e3 * s[call].z_part_s,
                            1e3 * s[call].z_move_s
                        ))
                        .collect::<Vec<_>>()
                        .join(" ")
                );
                if let Some(path) = &csv {
                    let mut f = std::fs::OpenOptions::new()
                        .create(true)
                        .append(true)
                        .open(path)
                        .expect("open csv");
                    writeln!(f, "{row}").expect("write csv");
                }
            }
        }
    }
}

/// Checks on our result: ids once, every owned point in this rank's region of the cut tree.
fn check_ours(
    comm: &SimpleCommunicator,
    rcb: &Rcb,
    items: &[Rec],
    n: u64,
    what: &str,
) -> Vec<String> {
    let mut out = Vec::new();
    if !ids_once(comm, items, n) {
        out.push(format!("{what}: ids not owned exactly once"));
    }
    let me = comm.rank();
    let wrong = items
        .iter()
        .filter(|r| rcb.tree().owner_of_item(&r.x, r.id) != me)
        .count() as u64;
    let wrong = sum_u64(comm, wrong);
    if wrong > 0 {
        out.push(format!(
            "{what}: {wrong} points outside their rank's region"
        ));
    }
    out
}

/// Checks on Zoltan's result after the move: ids once, and Zoltan's own point location puts
/// every owned point on this rank (points exactly on a cut may legitimately differ).
fn check_zoltan(
    comm: &SimpleCommunicator,
    z: &Zoltan,
    items: &[Rec],
    n: u64,
    what: &str,
) -> Vec<String> {
    let mut out = Vec::new();
    if !ids_once(comm, items, n) {
        out.push(format!("{what}: ids not owned exactly once"));
    }
    let me = comm.rank();
    let (lo, hi) = z.rcb_box(me);
    let (mut on_cut, mut inside_other) = (0u64, 0u64);
    for r in items {
        if z.point_owner(&r.x) != me {
            if (0..3).any(|d| r.x[d] == lo[d] || r.x[d] == hi[d]) {
                on_cut += 1;
            } else {
                inside_other += 1;
            }
        }
    }
    let on_cut = sum_u64(comm, on_cut);
    let inside_other = sum_u64(comm, inside_other);
    if inside_other > 0 {
        out.push(format!(
            "{what}: {inside_other} points inside another rank's region (Zoltan_LB_Point_Assign)"
        ));
    }
    if on_cut > 0 {
        out.push(format!(
            "{what}: {on_cut} points exactly on a cut assigned to the other side by Zoltan_LB_Point_Assign"
        ));
    }
    out
}
