//! The contact stage's two kinds of step: on the kept decomposition, and the rebuild (the
//! paper's Fig. 10 in full).
use super::*;

impl ContactStage {
    /// A step on the kept decomposition (see [`ContactStage::step`]).
    pub(super) fn sticky_step(
        &mut self,
        nodes: &[NodeRecord],
        (motion, any_particles): (f64, bool),
        dt: f64,
        t0: Instant,
    ) -> Result<ContactOutcome, String> {
        let comm = &self.comm;
        let me = comm.rank();
        let st = self.sticky.as_mut().expect("a kept decomposition");
        let tree = self
            .tree
            .as_ref()
            .expect("the cut tree of the last rebuild");
        let mut bytes = 0u64;
        let (mut t_bytes, mut t_s) = (0u64, 0.0f64);
        // 1 (and 3, 5-6). The mesh nodes' records straight to the boxes holding them, written
        // in place.
        let tt = Instant::now();
        let (fe_inputs, sent) = send_mesh_records(
            (&mut st.plan, &st.send_idx, &st.recv_slot),
            &mut st.send_buf,
            nodes,
            &mut st.b.nodes,
        );
        bytes += sent;
        t_bytes += sent;
        // Particles (never face corners) to the box their predicted position falls in: the
        // ghost skin's bound holds for a node inside its box's region.
        let (pitems, pplan, pgot) = if any_particles {
            let (items, plan, got) = particles_to_boxes(comm, tree, nodes, me);
            bytes += plan.bytes_sent;
            t_bytes += plan.bytes_sent;
            (items, Some(plan), got)
        } else {
            (Vec::new(), None, Vec::new())
        };
        t_s += tt.elapsed().as_secs_f64();
        // 7. The search over the candidate lists, rebuilt here when the skin no longer covers.
        let (kept, particles, owned_gids, rebuilt) =
            search_kept(st, &pgot, &self.params, (motion, self.skins));
        self.rebuilds.candidates += rebuilt;
        let (settled, contacts, pcontacts) = solve_kept(
            comm,
            tree,
            st,
            (kept, particles, &owned_gids),
            dt,
            (self.friction, &self.params),
        )?;
        let pairs = body_pairs(&st.b, &contacts);
        let held_by = match &st.pbox {
            Some((_, pb, _)) => particle_faces(pb, &pcontacts),
            None => Vec::new(),
        };
        let (owned_force, pb_work, pushback) = (settled.force, settled.work, settled.counts);
        bytes += settled.bytes;
        // 8. Forces back to the homes: the mesh nodes' nonzero ones along the plan's own pairs
        // of ranks, the particles' back along their plan.
        let tt = Instant::now();
        let (force, held, back_bytes) = kept_forces_home(
            st,
            (&owned_force, &fe_inputs, nodes.len()),
            pplan.map(|plan| (plan, &pitems[..], &pcontacts[..], pgot.len())),
        );
        bytes += back_bytes;
        t_bytes += back_bytes;
        t_s += tt.elapsed().as_secs_f64();
        let work_items = st.work_items + pgot.len() as f64;
        let mut all_contacts = contacts;
        all_contacts.extend(pcontacts);
        self.outcome(OutcomeParts {
            pushback,
            force,
            held,
            contacts: &all_contacts,
            body_pairs: pairs,
            particle_faces: held_by,
            pb_work,
            bytes,
            work_items,
            t_bytes,
            t_s,
            rcb: RcbStats::default(),
            t0,
        })
    }

    /// A step that rebuilds the decomposition: the paper's Fig. 10 in full.
    pub(super) fn full_step(
        &mut self,
        nodes: &[NodeRecord],
        faces: Vec<FullFace>,
        (motion, radius): (f64, f64),
        dt: f64,
        t0: Instant,
    ) -> Result<ContactOutcome, String> {
        // Set up a kept decomposition for the next steps?
        let keep_next = self.sticky_enabled && self.step_count >= self.retry_at;
        // 1-3. The nodes to their contact owners, the RCB, the faces to theirs.
        let Arrived {
            mine,
            rcb: rcb_stats,
            tree,
            faces: my_faces,
            mut bytes,
            mut t_bytes,
            mut t_s,
        } = self.gather_at_owners(nodes, &faces)?;
        let comm = &self.comm;
        // 5-6. Ghost each face to every box its search box overlaps, grown by the zone of
        // influence: the largest node motion of the step and the largest particle radius (the
        // face's search box), and the skin the kept decomposition needs (at least the motion).
        let (skin, cand_skin, face_size) = if keep_next {
            let face = mean_face_diameter(comm, &my_faces);
            let (a, b) = skins(motion, face, self.skins);
            (a, b, face)
        } else {
            (motion, 0.0, 0.0)
        };
        let (held, ghost_bytes) = ghost_faces(comm, &tree, &my_faces, &self.params, radius, skin);
        bytes += ghost_bytes;

        // 7. The local search: owned nodes first, then copies of face nodes not owned here.
        let (recs, index, face_recs) = box_records(&mine, &held);
        let n_owned = mine.len();
        let work_items = (n_owned + face_recs.len()) as f64;
        let mut b = box_on_every_rank(comm, &recs, n_owned, &face_recs)?;
        let cands = Candidates::build(&b, &self.params, cand_skin);
        let contacts = search_candidates(&b, &self.params, &cands);

        // 7b. The push-back, solved in cells where the contacts are (`cells`): contacts that
        // share nodes but were found in different boxes (a touching pair found from both sides
        // by the two passes) are rows of one Gauss-Seidel whose order the cells fix, so the
        // forces are those of one box holding everything, at any rank count.
        let owned_gids: Vec<u64> = recs[..n_owned].iter().map(|r| r.gid).collect();
        let mut parts = [Part {
            b: &mut b,
            cands: &cands,
            contacts,
        }];
        let settled = solve_rechecked(
            comm,
            Some(&tree),
            &mut parts,
            &owned_gids,
            dt,
            (self.friction, &self.params),
        )?;
        let [Part { contacts, .. }] = parts;
        let pairs = body_pairs(&b, &contacts);
        let held_by = particle_faces(&b, &contacts);
        let (owned_force, pb_work, pushback) = (settled.force, settled.work, settled.counts);
        bytes += settled.bytes;
        let tt = Instant::now();
        let owned_home: Vec<(i32, u64)> =
            mine.iter().map(|n| (n.home as i32, n.home_idx)).collect();
        let flags = held_particles(&b, &contacts, n_owned);
        let (force, held, back_bytes) =
            send_home(comm, &owned_force, &owned_home, (&flags, nodes.len()));
        bytes += back_bytes;
        t_bytes += back_bytes;
        t_s += tt.elapsed().as_secs_f64();

        // The plan for the steps that keep this decomposition.
        self.sticky = None;
        if keep_next {
            let sb = SetupBox {
                b: &b,
                params: &self.params,
                skin,
                cand_skin,
                face_size,
                max_radius: radius,
            };
            let (st, setup_bytes) = build_sticky(comm, &tree, nodes, &mine, &index, sb)?;
            bytes += setup_bytes;
            self.sticky = st.map(Box::new);
        }
        self.tree = Some(tree);
        self.outcome(OutcomeParts {
            pushback,
            force,
            held,
            contacts: &contacts,
            body_pairs: pairs,
            particle_faces: held_by,
            pb_work,
            bytes,
            work_items,
            t_bytes,
            t_s,
            rcb: rcb_stats,
            t0,
        })
    }
}

/// Steps 1-3 of a rebuild ([`ContactStage::gather_at_owners`]): what arrived on this rank.
struct Arrived {
    /// The contact nodes this rank owns after the RCB.
    mine: Vec<CNode>,
    /// The RCB's statistics.
    rcb: RcbStats,
    /// The new cuts.
    tree: CutTree,
    /// The faces whose first node this rank owns, with their nodes' records.
    faces: Vec<FullFace>,
    /// Bytes sent (the RCB's included), and those of the transfers between decompositions.
    bytes: u64,
    /// See `bytes`.
    t_bytes: u64,
    /// The transfers' time, s.
    t_s: f64,
}

impl ContactStage {
    /// Steps 1-3 of a rebuild (collective): every node lent here (`nodes`) to its contact
    /// owner of the last step, the RCB rebalance from the previous cuts, and each face
    /// (`faces`) with its nodes to the contact owner of its first node.
    fn gather_at_owners(
        &mut self,
        nodes: &[NodeRecord],
        faces: &[FullFace],
    ) -> Result<Arrived, String> {
        let me = self.comm.rank();
        let mut bytes = 0u64;
        let items = home_items(nodes, me);
        // The transfers between decompositions (steps 1, 3 and the last half of 8: FE and SPH
        // owners to contact owners and back): their bytes and time.
        let (mut t_bytes, mut t_s) = (0u64, 0.0f64);
        // 1. To last step's contact owners.
        let tt = Instant::now();
        let (items, sent) = to_owners(&self.comm, self.tree.as_ref(), items);
        bytes += sent;
        t_bytes += sent;
        t_s += tt.elapsed().as_secs_f64();
        // 2. RCB over nodes and particles, from the previous cuts.
        let (mine, rcb) = self.rcb.balance(items).map_err(|e| e.to_string())?;
        bytes += rcb.bytes_sent;
        let tree = self.rcb.tree().clone();
        // 3. Faces with their nodes to the contact owner of their first node.
        let tt = Instant::now();
        let (my_faces, sent) = faces_to_owners(&self.comm, &tree, faces);
        bytes += sent;
        t_bytes += sent;
        t_s += tt.elapsed().as_secs_f64();
        Ok(Arrived {
            mine,
            rcb,
            tree,
            faces: my_faces,
            bytes,
            t_bytes,
            t_s,
        })
    }
}

/// Step 7 on a kept decomposition: the search of the kept box over its candidate lists (rebuilt
/// when their skin no longer covers the step's `motion`, with the stage's `skins`), and of the
/// particles `pgot` this rank received in their own box. Returns the mesh box's contacts, the
/// particles', the owned nodes' gids (the mesh box's, then the particles') and the candidate
/// lists rebuilt.
fn search_kept(
    st: &mut Sticky,
    pgot: &[CNode],
    params: &SearchParams,
    (motion, skin_steps): (f64, (f64, f64)),
) -> (Vec<Contact>, Vec<Contact>, Vec<u64>, u64) {
    let mut rebuilt = 0;
    if !st.cands.still_valid(&st.b, params) {
        let (_, cand_skin) = skins(motion, st.face_size, skin_steps);
        st.cands = Candidates::build(&st.b, params, cand_skin);
        rebuilt += 1;
    }
    let contacts = search_candidates(&st.b, params, &st.cands);
    let n_owned = st.b.nodes.n_owned;
    let mut owned_gids: Vec<u64> = st.b.nodes.gid[..n_owned].to_vec();
    let (_, cand_skin) = skins(motion, st.face_size, skin_steps);
    rebuilt += refresh_particle_box(st, pgot, params, cand_skin);
    let pcontacts = match &st.pbox {
        Some((_, pb, pc)) => {
            owned_gids.extend(pgot.iter().map(|c| c.rec.gid));
            search_candidates(pb, params, pc)
        }
        None => Vec::new(),
    };
    (contacts, pcontacts, owned_gids, rebuilt)
}

/// Step 7b on a kept decomposition: the push-back over the kept box's contacts and the
/// particle box's (`owned_gids`: the owned nodes of both, [`solve_rechecked`]; collective).
/// Returns what it settled and both boxes' contacts, the rechecks' included.
fn solve_kept(
    comm: &Rc<SimpleCommunicator>,
    tree: &CutTree,
    st: &mut Sticky,
    (contacts, pcontacts, owned_gids): (Vec<Contact>, Vec<Contact>, &[u64]),
    dt: f64,
    (friction, params): (f64, &SearchParams),
) -> Result<(Settled, Vec<Contact>, Vec<Contact>), String> {
    let mut parts = vec![Part {
        b: &mut st.b,
        cands: &st.cands,
        contacts,
    }];
    if let Some((_, pb, pc)) = &mut st.pbox {
        parts.push(Part {
            b: pb,
            cands: pc,
            contacts: pcontacts,
        });
    }
    let settled = solve_rechecked(
        comm,
        Some(tree),
        &mut parts,
        owned_gids,
        dt,
        (friction, params),
    )?;
    let mut parts = parts.into_iter();
    let contacts = parts.next().map(|p| p.contacts).unwrap_or_default();
    let pcontacts = parts.next().map(|p| p.contacts).unwrap_or_default();
    Ok((settled, contacts, pcontacts))
}

/// Step 8 on a kept decomposition (collective): the forces of the kept box's owned mesh nodes
/// (`owned_force`'s first `n_owned`; `fe_inputs` and `n_inputs` as for [`mesh_forces_home`])
/// back to their FE homes, then, where particles came (`particles`: their plan, the records
/// this rank sent, the particle box's contacts and the particles received), the particles'
/// forces and whether immovable faces alone hold them back along their plan. Returns the force
/// on each input node, the held flags and the bytes sent.
fn kept_forces_home(
    st: &mut Sticky,
    (owned_force, fe_inputs, n_inputs): (&[[f64; 3]], &[u32], usize),
    particles: Option<(CommPlan, &[CNode], &[Contact], usize)>,
) -> (Vec<[f64; 3]>, Vec<bool>, u64) {
    let n_owned = st.b.nodes.n_owned;
    let (mut force, mut bytes) = mesh_forces_home(
        (&mut st.plan, &st.owned_home, &st.source_of_home),
        &owned_force[..n_owned],
        fe_inputs,
        n_inputs,
    );
    let mut held = vec![false; n_inputs];
    if let Some((mut plan, pitems, pcontacts, n_got)) = particles {
        let flags = match &st.pbox {
            Some((_, pb, _)) => held_particles(pb, pcontacts, n_got),
            None => vec![false; n_got],
        };
        bytes += particle_forces_home(
            &mut plan,
            pitems,
            (&owned_force[n_owned..], &flags),
            (&mut force, &mut held),
        );
    }
    (force, held, bytes)
}
