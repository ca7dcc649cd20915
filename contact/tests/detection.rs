//! Test 1: the bucket search finds exactly what an all-pairs reference finds.
//!
//! Reference: `common::reference_search`, the crossing rule coded anew (monomial bilinear face, a
//! grid search then Newton for the projection) and applied to every node-face pair, no buckets.
//! Tolerances: the same (node, face) set, except pairs within 1e-9 (relative) of a threshold of the
//! rule, where the two codes' round-off may fall either side (counted and printed; none expected);
//! depths equal to 1e-12 m (depths are O(0.1 m)); parametric points to 1e-9.

mod common;

use common::{random_scene, reference_pair, reference_search, Rng, SceneSpec};
use contact::{search, ContactBox, SearchParams};

const DEPTH_TOL: f64 = 1e-12;
const XI_TOL: f64 = 1e-9;
const BORDERLINE: f64 = 1e-9;

/// Random faces of three bodies, free nodes and crossing nodes, some of them particles.
const MIXED: SceneSpec = SceneSpec {
    faces: 250,
    free_nodes: 300,
    crossing_nodes: 700,
    bodies: 3,
    particles: true,
    size: 8.0,
};

#[test]
fn bucket_search_equals_all_pairs_reference() {
    let mut rng = Rng(20240611);
    let mut total = 0;
    let mut worst_depth: f64 = 0.0;
    let mut borderline = 0;
    for round in 0..4 {
        let scene = random_scene(&mut rng, &MIXED);
        let b = ContactBox::from_records(&scene.nodes, scene.nodes.len(), &scene.faces).unwrap();
        for self_contact in [false, true] {
            let params = SearchParams {
                self_contact,
                ..SearchParams::default()
            };
            let got = search(&b, &params);
            let want = reference_search(&scene, self_contact, params.gap_tol, params.param_tol);
            // A node's first contact is its deepest (the reference's); a node may have further
            // ones on faces of other normals (edges and corners, faces at an angle), compared
            // with the reference's `further` below.
            let mut by_node = std::collections::BTreeMap::new();
            let mut further = std::collections::BTreeSet::new();
            for c in &got {
                if let std::collections::btree_map::Entry::Vacant(e) = by_node.entry(c.node_gid) {
                    e.insert(*c);
                } else {
                    further.insert((c.node_gid, c.face_gid));
                }
            }
            let want_further: std::collections::BTreeSet<(u64, u64)> =
                want.further.iter().cloned().collect();
            for pair in further.symmetric_difference(&want_further) {
                // Only where a node's first contact was a tie of depths, or a pair sits at a
                // threshold of the rule (the angle between normals included).
                let tie = want
                    .contacts
                    .get(&pair.0)
                    .is_some_and(|(_, hit, runner_up)| (hit.depth - runner_up).abs() <= DEPTH_TOL);
                assert!(
                    tie,
                    "round {round}: further contact {pair:?} found by one search only"
                );
                borderline += 1;
            }
            for (node, (face, hit, runner_up)) in &want.contacts {
                match by_node.get(node) {
                    Some(c) if c.face_gid == *face => {
                        let dd = (c.depth - hit.depth).abs();
                        worst_depth = worst_depth.max(dd);
                        assert!(
                            dd <= DEPTH_TOL,
                            "round {round}: node {node} face {face}: depth {} vs reference {} (tol {DEPTH_TOL})",
                            c.depth,
                            hit.depth
                        );
                        assert!(
                            (c.xi[0] - hit.xi[0]).abs() <= XI_TOL
                                && (c.xi[1] - hit.xi[1]).abs() <= XI_TOL,
                            "node {node} face {face}: xi {:?} vs {:?}",
                            c.xi,
                            hit.xi
                        );
                    }
                    Some(c) => {
                        // Another face chosen: only acceptable at a tie of depths.
                        assert!(
                            (hit.depth - runner_up).abs() <= DEPTH_TOL,
                            "round {round}: node {node}: face {} chosen, reference {face} (depth {} vs {})",
                            c.face_gid,
                            c.depth,
                            hit.depth
                        );
                        borderline += 1;
                    }
                    None => {
                        assert!(
                            hit.margin <= BORDERLINE,
                            "round {round}: node {node} crosses face {face} (depth {}) but was not found",
                            hit.depth
                        );
                        borderline += 1;
                    }
                }
            }
            for c in &got {
                if !want.contacts.contains_key(&c.node_gid) {
                    // Found but not in the reference: only at a threshold.
                    let n = &scene.nodes[c.node as usize];
                    let f = &scene.faces[c.face as usize];
                    let x0 = f
                        .nodes
                        .map(|g| scene.nodes.iter().find(|m| m.gid == g).unwrap().x0);
                    let x1 = f
                        .nodes
                        .map(|g| scene.nodes.iter().find(|m| m.gid == g).unwrap().x1);
                    let (_, margin) = reference_pair(
                        x0,
                        x1,
                        n.x0,
                        n.x1,
                        n.radius,
                        params.gap_tol,
                        params.param_tol,
                    );
                    assert!(
                        margin <= BORDERLINE,
                        "round {round}: node {} face {} found (depth {}) but not by the reference",
                        c.node_gid,
                        c.face_gid,
                        c.depth
                    );
                    borderline += 1;
                }
            }
            total += got.len();
        }
    }
    println!(
        "detection: {total} contacts compared, largest depth difference {worst_depth:.3e} m, {borderline} borderline"
    );
    assert!(total > 1000, "too few contacts ({total}) to test anything");
}

/// The result depends on geometry and gids only: shuffling the storage order of nodes and faces
/// gives bit-identical contacts (by gid).
#[test]
fn search_is_independent_of_storage_order() {
    let mut rng = Rng(7);
    let scene = random_scene(
        &mut rng,
        &SceneSpec {
            faces: 300,
            free_nodes: 200,
            crossing_nodes: 800,
            bodies: 2,
            particles: true,
            size: 6.0,
        },
    );
    let params = SearchParams {
        self_contact: true,
        ..SearchParams::default()
    };
    let b = ContactBox::from_records(&scene.nodes, scene.nodes.len(), &scene.faces).unwrap();
    let key = |b: &ContactBox| {
        search(b, &params)
            .iter()
            .map(|c| {
                (
                    c.node_gid,
                    c.face_gid,
                    c.xi.map(f64::to_bits),
                    c.normal.map(f64::to_bits),
                    c.depth.to_bits(),
                )
            })
            .collect::<Vec<_>>()
    };
    let reference = key(&b);
    assert!(reference.len() > 300);
    for _ in 0..3 {
        let mut nodes = scene.nodes.clone();
        let mut faces = scene.faces.clone();
        rng.shuffle(&mut nodes);
        rng.shuffle(&mut faces);
        let shuffled = ContactBox::from_records(&nodes, nodes.len(), &faces).unwrap();
        assert_eq!(key(&shuffled), reference);
    }
}

/// Only owned nodes (`0..n_owned`) are searched; copies serve only as face corners.
#[test]
fn only_owned_nodes_are_searched() {
    let mut rng = Rng(99);
    let scene = random_scene(
        &mut rng,
        &SceneSpec {
            faces: 100,
            free_nodes: 0,
            crossing_nodes: 300,
            bodies: 2,
            particles: false,
            size: 5.0,
        },
    );
    // Face corners first (copies), crossing nodes after: put the crossing nodes first and own them.
    let n_corners = 4 * scene.faces.len();
    let mut nodes = scene.nodes[n_corners..].to_vec();
    nodes.extend_from_slice(&scene.nodes[..n_corners]);
    let all = ContactBox::from_records(&nodes, nodes.len(), &scene.faces).unwrap();
    let owned = ContactBox::from_records(&nodes, nodes.len() - n_corners, &scene.faces).unwrap();
    let params = SearchParams::default();
    let want: Vec<_> = search(&all, &params)
        .into_iter()
        .filter(|c| (c.node as usize) < nodes.len() - n_corners)
        .collect();
    assert_eq!(search(&owned, &params), want);
}

/// Small faces far from the origin (1 mm faces at 1 km): the projection's Newton iteration stops at
/// the round-off floor of the coordinates instead of missing the contact. Reference: every node is
/// placed above the interior of one face and sinks 0.05 mm through it, so each must be found, on
/// that face, with depth 0.05 mm to 1e-9 m (coordinates of 1e3 m carry about 1e-13 m of round-off).
#[test]
fn small_faces_far_from_the_origin() {
    let n = 40;
    let h = 1e-3;
    let origin = [1000.0, -500.0, 250.0];
    let id = |i: usize, j: usize| (i * (n + 1) + j) as u64;
    let mut nodes = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            let p = [
                origin[0] + i as f64 * h,
                origin[1] + j as f64 * h,
                origin[2],
            ];
            nodes.push(contact::NodeRecord {
                gid: id(i, j),
                body: 0,
                flags: 0,
                mass: 1.0,
                radius: 0.0,
                x0: p,
                x1: p,
                v: [0.0; 3],
            });
        }
    }
    let mut faces = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let p = [
                origin[0] + (i as f64 + 0.4) * h,
                origin[1] + (j as f64 + 0.3) * h,
                origin[2] + 0.1 * h,
            ];
            nodes.push(contact::NodeRecord {
                gid: 1_000_000 + id(i, j),
                body: 1,
                flags: 0,
                mass: 1.0,
                radius: 0.0,
                x0: p,
                x1: [p[0], p[1], origin[2] - 0.05 * h],
                v: [0.0; 3],
            });
            faces.push(contact::FaceRecord {
                gid: (i * n + j) as u64,
                nodes: [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)],
                body: 0,
                reserved: 0,
            });
        }
    }
    let b = ContactBox::from_records(&nodes, nodes.len(), &faces).unwrap();
    let got = search(&b, &SearchParams::default());
    assert_eq!(got.len(), n * n);
    for c in &got {
        let g = (c.node_gid - 1_000_000) as usize;
        let (i, j) = (g / (n + 1), g % (n + 1));
        assert_eq!(c.face_gid, (i * n + j) as u64);
        assert!((c.depth - 0.05 * h).abs() <= 1e-9, "depth {}", c.depth);
    }
}

/// A candidate list kept from an earlier configuration (a Verlet list with a skin) gives exactly
/// what a fresh search gives, as long as the skin covers the motion since (the bound of
/// `contact::Candidates`). Reference: `search` on the current configuration (itself checked
/// against the all-pairs reference above); bit-identical contacts required. The earlier
/// configuration moves every node by its own random displacement of up to 1.5 (faces are 1 to 3 across), far
/// more than a real step, so a list missing any face would show.
#[test]
fn candidate_list_with_skin_equals_fresh_search() {
    let mut rng = Rng(31337);
    let mut compared = 0;
    for round in 0..3 {
        let scene = random_scene(&mut rng, &MIXED);
        for self_contact in [false, true] {
            let params = contact::SearchParams {
                self_contact,
                one_pass: round == 1,
                ..contact::SearchParams::default()
            };
            let d_max = 1.5;
            let mut earlier = scene.nodes.clone();
            let mut motion: f64 = 0.0;
            for n in earlier.iter_mut() {
                let dv = rng.unit();
                let r = rng.range(0.0, d_max);
                for (k, d) in dv.iter().enumerate() {
                    n.x0[k] -= r * d;
                    n.x1[k] -= r * d;
                }
                let m: f64 = (0..3).map(|k| (n.x1[k] - n.x0[k]).powi(2)).sum::<f64>();
                motion = motion.max(m.sqrt());
            }
            let mut nodes = scene.nodes.clone();
            if params.one_pass {
                // Body 0 is the master: its nodes are not searched against the others' faces.
                for (n, e) in nodes.iter_mut().zip(earlier.iter_mut()) {
                    if n.body == 0 {
                        n.flags |= contact::FLAG_MASTER;
                        e.flags |= contact::FLAG_MASTER;
                    }
                }
            }
            let n_owned = nodes.len();
            let now = ContactBox::from_records(&nodes, n_owned, &scene.faces).unwrap();
            let then = ContactBox::from_records(&earlier, n_owned, &scene.faces).unwrap();
            let mut skin = 0.0;
            while !contact::within_skin(d_max, motion, &params, skin) {
                skin += 0.01;
            }
            let cands = contact::Candidates::build(&then, &params, skin);
            assert!(
                cands.still_valid(&now, &params),
                "round {round}: the bound refused a list within it"
            );
            let want = search(&now, &params);
            let got = contact::search_candidates(&now, &params, &cands);
            assert_eq!(got, want, "round {round}, self_contact {self_contact}");
            compared += want.len();
            // A list whose skin does not cover the motion is refused.
            let thin = contact::Candidates::build(&then, &params, 0.5 * motion);
            assert!(
                !thin.still_valid(&now, &params),
                "a skin of half a step was accepted"
            );
        }
    }
    println!("candidate lists: {compared} contacts compared bit for bit");
    assert!(
        compared > 1000,
        "too few contacts ({compared}) to test anything"
    );
}
