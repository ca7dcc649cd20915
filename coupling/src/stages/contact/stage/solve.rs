//! The push-back solved with rechecks: contacts the corrected positions reveal join the solve,
//! round by round, on every rank together.
use super::*;

/// [`PushbackCounts::kinds`] of `contacts` found in `b` (this rank's).
pub(crate) fn kinds(b: &ContactBox, contacts: &[Contact]) -> [u64; 4] {
    let mut k = [0u64; 4];
    for c in contacts {
        let (j, f) = (c.node as usize, c.face as usize);
        let i = if b.nodes.particle[j] {
            3
        } else {
            match b.nodes.body[j].cmp(&b.faces.body[f]) {
                std::cmp::Ordering::Greater => 0,
                std::cmp::Ordering::Less => 1,
                std::cmp::Ordering::Equal => 2,
            }
        };
        k[i] += 1;
    }
    k
}

/// The pairs of bodies (node's body, face's body) that `contacts` found in `b` touch, each
/// once, sorted; particles (no body) and a body's contacts with itself left out
/// (contact_forces.csv, `contact::pairs`).
pub(crate) fn body_pairs(b: &ContactBox, contacts: &[Contact]) -> Vec<(u32, u32)> {
    let mut out: Vec<(u32, u32)> = contacts
        .iter()
        .map(|c| (b.nodes.body[c.node as usize], b.faces.body[c.face as usize]))
        .filter(|&(n, f)| n != f && n != u32::MAX && f != u32::MAX)
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// The particles (node gid) that `contacts` found in `b` hold against a face, with the face's
/// body, each pair once, sorted (contact_forces.csv).
pub(crate) fn particle_faces(b: &ContactBox, contacts: &[Contact]) -> Vec<(u64, u32)> {
    let mut out: Vec<(u64, u32)> = contacts
        .iter()
        .filter(|c| b.nodes.particle[c.node as usize])
        .map(|c| (c.node_gid, b.faces.body[c.face as usize]))
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// Step 7b with its rechecks: the push-back of every contact, solved in cells where the
/// contacts are (`cells::solve_in_cells`); then each box tests its nodes again on the corrected
/// positions (`contact::recheck`: the crossings the corrections made, a node pushed out of one
/// face of a crease into the next), and while any box finds new contacts the push-back is solved
/// again with them added (at most [`MAX_SOLVES`] solves; what the last one leaves is found by
/// the next step's search, within its capture tolerance). The new contacts join `parts`' lists.
/// Every rank takes part in each solve; the rounds end on every rank together (a sum over ranks
/// of the new contacts). The contacts and forces do not depend on the cuts: the solve's answer
/// does not (`contact::pushback`, "Sweeps in cells"), and each node's rechecks see the same
/// corrected positions wherever the node is held. `tree`: the contact decomposition's cuts
/// (where cells and nodes' homes are; `None`: all on rank 0).
pub(crate) fn solve_rechecked(
    comm: &Rc<SimpleCommunicator>,
    tree: Option<&CutTree>,
    parts: &mut [Part],
    owned: &[u64],
    dt: f64,
    (friction, params): (f64, &SearchParams),
) -> Result<Settled, String> {
    let mut counts = PushbackCounts::default();
    let boxes: Vec<&ContactBox> = parts.iter().map(|p| &*p.b).collect();
    let mut holders = super::super::cells::Holders::new(comm, tree, &boxes);
    drop(boxes);
    let mut bytes = holders.bytes();
    loop {
        let views: Vec<(&ContactBox, &[Contact])> =
            parts.iter().map(|p| (&*p.b, &p.contacts[..])).collect();
        let super::super::cells::Solved {
            all,
            work,
            sent,
            total,
            coupled,
            sweeps,
            rows,
            immovable,
            bounded,
        } = super::super::cells::solve_in_cells(comm, tree, &views, &mut holders, dt, friction)?;
        counts.immovable = immovable;
        counts.bounded = bounded;
        bytes += sent;
        counts.solves += u64::from(total > 0);
        counts.coupled = coupled;
        counts.sweeps += sweeps;
        counts.rows += rows;
        counts.bytes = bytes;
        // This rank's contacts by kind (the outcome sums them over ranks).
        counts.kinds = [0; 4];
        for p in parts.iter() {
            for (t, k) in counts.kinds.iter_mut().zip(kinds(p.b, &p.contacts)) {
                *t += k;
            }
        }
        let done = Settled {
            force: owned
                .iter()
                .map(|g| all.get(g).copied().unwrap_or([0.0; 3]))
                .collect(),
            work,
            bytes,
            counts,
        };
        if total == 0 || counts.solves >= MAX_SOLVES as u64 {
            return Ok(done);
        }
        let mut added = 0u64;
        for p in parts.iter_mut() {
            let n = &p.b.nodes;
            let dx: Vec<[f64; 3]> = (0..n.len())
                .map(|j| match all.get(&n.gid[j]) {
                    Some(f) if n.mass[j].is_finite() => {
                        let s = dt * dt / n.mass[j];
                        [f[0] * s, f[1] * s, f[2] * s]
                    }
                    _ => [0.0; 3],
                })
                .collect();
            let new = contact::recheck(p.b, params, p.cands, &dx, &p.contacts);
            added += new.len() as u64;
            p.contacts.extend(new);
            // The search's order: by node gid (stable: a node's first contacts stay first).
            p.contacts.sort_by_key(|c| c.node_gid);
        }
        let mut total = 0u64;
        comm.all_reduce_into(&added, &mut total, SystemOperation::sum());
        if total == 0 {
            return Ok(done);
        }
        counts.rechecked += total;
    }
}
