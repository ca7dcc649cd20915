//! Self-test of parallel RCB under mpirun (`tdyn_selftest rcb`): every check compares with an
//! independent reference (the list of ids handed in, a brute-force test against every rank's
//! box, the arithmetic bound on the balance).
use bytemuck::{Pod, Zeroable};
use coupling::kernels::collective::first_error;
use coupling::kernels::rcb::{Rcb, RcbItem, RcbStats};
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

/// A test point.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct TestPoint {
    x: [f64; 3],
    w: f64,
    id: u64,
}

impl RcbItem for TestPoint {
    fn position(&self) -> [f64; 3] {
        self.x
    }
    fn weight(&self) -> f64 {
        self.w
    }
    fn id(&self) -> u64 {
        self.id
    }
}

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Global ids for `n` local items: the exclusive prefix sum of the counts over ranks.
fn id_offset(comm: &SimpleCommunicator, n: usize) -> (u64, u64) {
    let mut counts = vec![0u64; comm.size() as usize];
    comm.all_gather_into(&(n as u64), &mut counts[..]);
    let off = counts[..comm.rank() as usize].iter().sum();
    (off, counts.iter().sum())
}

/// The checks every balance must pass. `unit`: unit weights, so loads must differ by at most one.
fn check(
    comm: &SimpleCommunicator,
    rcb: &Rcb,
    items: &[TestPoint],
    n_total: u64,
    stats: &RcbStats,
    unit: bool,
    what: &str,
) -> Result<(), String> {
    let p = comm.size();
    let me = comm.rank();
    let tree = rcb.tree();
    let mut err: Option<String> = None;
    let mut fail = |e: String| {
        if err.is_none() {
            err = Some(format!("{what}: {e}"));
        }
    };
    // Every id 0..N owned exactly once (reference: the ids handed in).
    let ids: Vec<u64> = items.iter().map(|t| t.id).collect();
    let mut counts = vec![0i32; p as usize];
    comm.all_gather_into(&(ids.len() as i32), &mut counts[..]);
    let mut all = coupling::kernels::collective::all_gather_varcount(comm, &ids);
    all.sort_unstable();
    if all.len() as u64 != n_total || all.iter().enumerate().any(|(k, &id)| id != k as u64) {
        fail(format!(
            "{} items owned after balancing, {n_total} handed in, or an id owned twice",
            all.len()
        ));
    }
    if stats.items != n_total {
        fail(format!("stats.items {} != {n_total}", stats.items));
    }
    // Balance: unit weights differ by at most one item.
    let (cmin, cmax) = (*counts.iter().min().unwrap(), *counts.iter().max().unwrap());
    if unit && cmax - cmin > 1 {
        fail(format!(
            "unit-weight loads range {cmin}..{cmax}, expected to differ by at most 1"
        ));
    }
    // Each item lies in this rank's box, and the tree says this rank owns it.
    let (lo, hi) = tree.rank_box(me);
    for t in items {
        let inside = (0..3).all(|d| lo[d] <= t.x[d] && t.x[d] <= hi[d]);
        let owner = tree.owner_of_item(&t.x, t.id);
        if !inside || owner != me {
            fail(format!(
                "item {} at {:?} on rank {me}: box {lo:?}..{hi:?}, tree owner {owner}",
                t.id, t.x
            ));
            break;
        }
    }
    // Every rank holds the same tree.
    let h = tree.cuts().fold(0u64, |h, c| {
        h.rotate_left(7) ^ c.value.to_bits() ^ ((c.dim as u64) << 60) ^ c.tie_id
    });
    let (mut hmin, mut hmax) = (0u64, 0u64);
    comm.all_reduce_into(&h, &mut hmin, SystemOperation::min());
    comm.all_reduce_into(&h, &mut hmax, SystemOperation::max());
    if hmin != hmax {
        fail("ranks hold different cut trees".into());
    }
    // Queries against a brute-force test of every rank's box, on points and boxes spread over
    // the items' region (and on the items themselves, which sit on cuts when ties occur).
    let mut rng = Rng(0x5EED ^ ((me as u64 + 1) * 7919));
    let span = items.iter().fold(1.0f64, |s, t| {
        s.max(t.x.iter().fold(0.0f64, |a, c| a.max(c.abs())))
    });
    let boxes: Vec<([f64; 3], [f64; 3])> = (0..p).map(|r| tree.rank_box(r)).collect();
    let mut probes: Vec<[f64; 3]> = (0..300)
        .map(|_| std::array::from_fn(|_| (rng.unit() * 2.4 - 1.2) * span))
        .collect();
    probes.extend(items.iter().take(100).map(|t| t.x));
    for x in &probes {
        let holders: Vec<i32> = (0..p)
            .filter(|&r| {
                (0..3).all(|d| boxes[r as usize].0[d] <= x[d] && x[d] < boxes[r as usize].1[d])
            })
            .collect();
        if holders != vec![tree.owner(x)] {
            fail(format!(
                "point {x:?}: half-open boxes {holders:?}, owner query {}",
                tree.owner(x)
            ));
            break;
        }
        let r: [f64; 3] = std::array::from_fn(|_| rng.unit() * 0.3 * span);
        let (bmin, bmax): ([f64; 3], [f64; 3]) = (
            std::array::from_fn(|d| x[d] - r[d]),
            std::array::from_fn(|d| x[d] + r[d]),
        );
        let brute: Vec<i32> = (0..p)
            .filter(|&q| {
                let (l, h) = &boxes[q as usize];
                (0..3).all(|d| bmin[d] <= h[d] && bmax[d] >= l[d])
            })
            .collect();
        let mut got = Vec::new();
        tree.ranks_overlapping(&bmin, &bmax, &mut got);
        if got != brute {
            fail(format!(
                "box {bmin:?}..{bmax:?}: query {got:?}, brute force {brute:?}"
            ));
            break;
        }
    }
    first_error(comm, err)
}

/// Runs one balance from scratch on `items` and checks it.
fn case(
    comm: &SimpleCommunicator,
    items: Vec<TestPoint>,
    unit: bool,
    what: &str,
) -> Result<(Rcb, Vec<TestPoint>, RcbStats), String> {
    let (_, n_total) = id_offset(comm, items.len());
    let mut rcb = Rcb::new(comm);
    let (mine, stats) = rcb.balance(items).map_err(|e| e.to_string())?;
    check(comm, &rcb, &mine, n_total, &stats, unit, what)?;
    Ok((rcb, mine, stats))
}

/// Self-test: unit and weighted balance, ties, degenerate inputs, an incremental rebalance,
/// queries against brute force, and a clear error for a non-finite point. Returns a summary
/// or the first failure (the same on every rank).
pub fn selftest(comm: &SimpleCommunicator, seed: u64) -> Result<String, String> {
    let p = comm.size();
    let me = comm.rank();
    let mut rng = Rng(seed ^ (me as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    for _ in 0..4 {
        rng.next();
    }
    let mut lines = Vec::new();

    // 1. Uniform random points, unit weights, uneven counts, rank 1 empty.
    let n = if me == 1 {
        0
    } else {
        (rng.next() % 3000) as usize
    };
    let (off, _) = id_offset(comm, n);
    let pts: Vec<TestPoint> = (0..n)
        .map(|k| TestPoint {
            x: [rng.unit(), 2.0 * rng.unit(), 0.5 * rng.unit()],
            w: 1.0,
            id: off + k as u64,
        })
        .collect();
    let (_, _, s) = case(comm, pts, true, "uniform")?;
    lines.push(format!(
        "uniform: {} items, imbalance {:.4}",
        s.items, s.imbalance
    ));

    // 2. A lattice: many points share each cut coordinate (tie cuts by id), scattered at random.
    let m = 14usize;
    let lattice: Vec<TestPoint> = (0..m * m * m)
        .filter(|k| (k.wrapping_mul(2654435761) >> 3) % p as usize == me as usize)
        .map(|k| TestPoint {
            x: [(k % m) as f64, ((k / m) % m) as f64, (k / (m * m)) as f64],
            w: 1.0,
            id: k as u64,
        })
        .collect();
    let (_, _, s) = case(comm, lattice, true, "lattice")?;
    lines.push(format!(
        "lattice: {} items, imbalance {:.4}",
        s.items, s.imbalance
    ));

    // 3. Weighted: weights in [0.1, 10]. Each bisection places its split within half the
    // largest weight of its target, and a rank sits under at most ceil(log2 P) bisections, so
    // its load is within ceil(log2 P) * w_max of the mean (the reference bound asserted).
    let n = 1500 + (rng.next() % 1000) as usize;
    let (off, _) = id_offset(comm, n);
    let pts: Vec<TestPoint> = (0..n)
        .map(|k| TestPoint {
            x: [rng.unit(), rng.unit(), rng.unit()],
            w: 0.1 + 9.9 * rng.unit(),
            id: off + k as u64,
        })
        .collect();
    let (_, mine, s) = case(comm, pts, false, "weighted")?;
    let w_loc: f64 = mine.iter().map(|t| t.w).sum();
    let w_max_loc = mine.iter().fold(0.0f64, |a, t| a.max(t.w));
    let (mut w_sum, mut l_max, mut l_min, mut w_max) = (0.0, 0.0, 0.0, 0.0);
    comm.all_reduce_into(&w_loc, &mut w_sum, SystemOperation::sum());
    comm.all_reduce_into(&w_loc, &mut l_max, SystemOperation::max());
    comm.all_reduce_into(&w_loc, &mut l_min, SystemOperation::min());
    comm.all_reduce_into(&w_max_loc, &mut w_max, SystemOperation::max());
    let mean = w_sum / p as f64;
    let bound = (p as f64).log2().ceil() * w_max;
    if l_max - mean > bound + 1e-9 * w_sum || mean - l_min > bound + 1e-9 * w_sum {
        return Err(format!(
            "weighted: loads {l_min:.3}..{l_max:.3} around mean {mean:.3}, expected within {bound:.3} (ceil(log2 P) x largest weight)"
        ));
    }
    lines.push(format!(
        "weighted: {} items, imbalance {:.4}, loads within {:.3} of the mean (bound {bound:.3})",
        s.items,
        s.imbalance,
        (l_max - mean).max(mean - l_min)
    ));

    // 4. Degenerate inputs.
    for (what, gen) in [
        ("identical points", 0),
        ("points on a plane", 1),
        ("points on a line", 2),
    ] {
        let n = 200 + (rng.next() % 200) as usize;
        let (off, _) = id_offset(comm, n);
        let pts: Vec<TestPoint> = (0..n)
            .map(|k| {
                let x = match gen {
                    0 => [0.5, 0.5, 0.5],
                    1 => [rng.unit(), rng.unit(), 0.0],
                    _ => [rng.unit(), 0.0, 0.0],
                };
                TestPoint {
                    x,
                    w: 1.0,
                    id: off + k as u64,
                }
            })
            .collect();
        let (_, _, s) = case(comm, pts, true, what)?;
        lines.push(format!(
            "{what}: {} items, imbalance {:.4}",
            s.items, s.imbalance
        ));
    }
    for n_total in [0usize, (p as usize).saturating_sub(1), 1] {
        // All on rank 0: more ranks than points.
        let n = if me == 0 { n_total } else { 0 };
        let pts: Vec<TestPoint> = (0..n)
            .map(|k| TestPoint {
                x: [rng.unit(), rng.unit(), rng.unit()],
                w: 1.0,
                id: k as u64,
            })
            .collect();
        case(comm, pts, true, &format!("{n_total} points on {p} ranks"))?;
    }
    lines.push("0, P-1 and 1 points: every point owned once, no rank above one".into());

    // 5. Incremental: a jittered lattice, then every point moves by 1 % of the spacing.
    let m = 24usize;
    let spacing = 1.0 / m as f64;
    let mut pts: Vec<TestPoint> = (0..m * m * m)
        .filter(|k| k % p as usize == me as usize)
        .map(|k| {
            let mut rj = Rng(k as u64 * 31 + 17 + seed);
            rj.next();
            TestPoint {
                x: [
                    ((k % m) as f64 + 0.3 * rj.unit()) * spacing,
                    (((k / m) % m) as f64 + 0.3 * rj.unit()) * spacing,
                    ((k / (m * m)) as f64 + 0.3 * rj.unit()) * spacing,
                ],
                w: 1.0,
                id: k as u64,
            }
        })
        .collect();
    let n_total = (m * m * m) as u64;
    let mut rcb = Rcb::new(comm);
    let (mine, s0) = rcb.balance(pts).map_err(|e| e.to_string())?;
    check(
        comm,
        &rcb,
        &mine,
        n_total,
        &s0,
        true,
        "incremental, first call",
    )?;
    pts = mine;
    for t in pts.iter_mut() {
        let mut rj = Rng(t.id * 7 + 3 + seed);
        rj.next();
        let u: [f64; 3] = std::array::from_fn(|_| rj.unit() - 0.5);
        let norm = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt().max(1e-12);
        for d in 0..3 {
            t.x[d] += 0.01 * spacing * u[d] / norm;
        }
    }
    let (mine, s1) = rcb.balance(pts).map_err(|e| e.to_string())?;
    check(
        comm,
        &rcb,
        &mine,
        n_total,
        &s1,
        true,
        "incremental, rebalance",
    )?;
    let frac = s1.migrated as f64 / n_total as f64;
    if frac >= 0.05 {
        return Err(format!(
            "incremental: rebalance after a 1 % move migrated {} of {n_total} ({:.2} %), expected under 5 %",
            s1.migrated,
            100.0 * frac
        ));
    }
    lines.push(format!(
        "incremental: first call migrated {} items, rebalance after a 1 % move {} ({:.3} %), {} bytes, {} iterations",
        s0.migrated, s1.migrated, 100.0 * frac, s1.bytes_sent, s1.iterations
    ));

    // 6. A non-finite point is refused on every rank with its id.
    let pts: Vec<TestPoint> = if me == p - 1 {
        vec![TestPoint {
            x: [f64::NAN, 0.0, 0.0],
            w: 1.0,
            id: 42,
        }]
    } else {
        Vec::new()
    };
    match Rcb::new(comm).balance(pts) {
        Err(e) if e.to_string().contains("item 42") => {}
        Err(e) => return Err(format!("NaN point: unexpected message {e}")),
        Ok(_) => return Err("a NaN point was accepted".into()),
    }
    lines.push("a NaN point is refused with its id".into());
    Ok(format!(
        "rcb selftest passed at np {p}:\n  {}",
        lines.join("\n  ")
    ))
}
