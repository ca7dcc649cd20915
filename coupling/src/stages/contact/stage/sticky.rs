//! The kept contact decomposition made after a rebuild: the mesh box without its particles and
//! the plan that sends each mesh node's record straight to the boxes holding it.
use super::*;

/// After a rebuild: the kept box (the rebuild's box without its particles) and the plan that
/// sends each mesh node's record straight to every box holding it (its contact owner and the
/// boxes holding a face it is a corner of), so that the next steps skip steps 1-6 (collective).
/// Requests for owned nodes go to their homes; requests for a face's corner copy go to the
/// corner's contact owner (the cut tree's owner of its position), which forwards them to the
/// home. Nodes are named by their position among the home's mesh nodes (`CNode::fe_idx`), which
/// particles coming and going do not change. `None` (on every rank) if a request finds no owner,
/// which keeps rebuilding.
pub(super) fn build_sticky(
    comm: &Rc<SimpleCommunicator>,
    tree: &CutTree,
    nodes: &[NodeRecord],
    mine: &[CNode],
    index: &HashMap<u64, usize>,
    sb: SetupBox,
) -> Result<(Option<Sticky>, u64), String> {
    let me = comm.rank() as u64;
    let mut bytes = 0u64;
    let full = sb.b;
    let n_owned = full.nodes.n_owned;
    // The kept box: the owned mesh nodes, then the corner copies (never particles), the faces.
    let owned_fe: Vec<&CNode> = mine.iter().filter(|n| !is_particle(&n.rec)).collect();
    let mut recs: Vec<NodeRecord> = owned_fe.iter().map(|n| n.rec).collect();
    let n_fe_owned = recs.len();
    recs.extend((n_owned..full.nodes.len()).map(|i| full.nodes.record(i)));
    let face_recs: Vec<FaceRecord> = (0..full.faces.len())
        .map(|f| full.faces.record(f))
        .collect();
    let b = box_on_every_rank(comm, &recs, n_fe_owned, &face_recs)?;
    let slot_of: HashMap<u64, usize> = recs.iter().enumerate().map(|(i, r)| (r.gid, i)).collect();
    // Corner copies: ask their contact owners.
    let mut dest = Vec::new();
    let mut asks = Vec::new();
    for i in n_owned..full.nodes.len() {
        let gid = full.nodes.gid[i];
        dest.push(tree.owner_of_item(&full.nodes.x1[i], gid));
        asks.push(Ask { key: gid, to: me });
    }
    let mut plan = CommPlan::new_shared(comm, &dest);
    let got = plan.exchange(&asks);
    bytes += plan.bytes_sent;
    let mut ok = true;
    // Requests to the homes: this rank's owned mesh nodes, and the forwarded corner requests.
    let mut dest = Vec::new();
    let mut reqs = Vec::new();
    for n in &owned_fe {
        dest.push(n.home as i32);
        reqs.push(Ask {
            key: n.fe_idx,
            to: me,
        });
    }
    for a in &got {
        match index.get(&a.key) {
            Some(&i) if i < n_owned && !is_particle(&mine[i].rec) => {
                dest.push(mine[i].home as i32);
                reqs.push(Ask {
                    key: mine[i].fe_idx,
                    to: a.to,
                });
            }
            _ => ok = false,
        }
    }
    let mut plan = CommPlan::new_shared(comm, &dest);
    let mut got = plan.exchange(&reqs);
    bytes += plan.bytes_sent;
    // The home's plan: by destination, mesh-node order inside each.
    got.sort_unstable_by_key(|a| (a.to, a.key));
    let fe_inputs: Vec<usize> = (0..nodes.len())
        .filter(|&i| !is_particle(&nodes[i]))
        .collect();
    ok &= got.iter().all(|a| (a.key as usize) < fe_inputs.len());
    let send_idx: Vec<u32> = got.iter().map(|a| a.key as u32).collect();
    let dest: Vec<i32> = got.iter().map(|a| a.to as i32).collect();
    let mut plan = CommPlan::new_shared(comm, &dest);
    let send: Vec<NodeRecord> = send_idx
        .iter()
        .map(|&k| nodes[fe_inputs.get(k as usize).copied().unwrap_or(0)])
        .collect();
    let arrived = plan.exchange(&send);
    bytes += plan.bytes_sent;
    // Where each arriving record goes in the box: every slot exactly once.
    let mut filled = vec![false; b.nodes.len()];
    let mut recv_slot = Vec::with_capacity(arrived.len());
    for r in &arrived {
        match slot_of.get(&r.gid) {
            Some(&i) if !filled[i] => {
                filled[i] = true;
                recv_slot.push(i as u32);
            }
            _ => ok = false,
        }
    }
    ok &= filled.iter().all(|f| *f);
    let mut all_ok = 0i32;
    comm.all_reduce_into(&(ok as i32), &mut all_ok, SystemOperation::min());
    if all_ok == 0 {
        return Ok((None, bytes));
    }
    let mut source_of_home = vec![u32::MAX; comm.size() as usize];
    for (k, (r, _)) in plan.sources().enumerate() {
        source_of_home[r as usize] = k as u32;
    }
    let cands = Candidates::build(&b, sb.params, sb.cand_skin);
    let work_items = (n_fe_owned + b.faces.len()) as f64;
    let st = Sticky {
        source_of_home,
        gids: fe_inputs.iter().map(|&i| nodes[i].gid).collect(),
        x_ref: fe_inputs.iter().map(|&i| nodes[i].x1).collect(),
        skin: sb.skin,
        face_size: sb.face_size,
        max_radius: sb.max_radius,
        send_idx,
        send_buf: Vec::new(),
        plan,
        recv_slot,
        b,
        owned_home: owned_fe.iter().map(|n| (n.home as i32, n.fe_idx)).collect(),
        cands,
        pbox: None,
        work_items,
        imbalance: f64::INFINITY,
    };
    Ok((Some(st), bytes))
}
