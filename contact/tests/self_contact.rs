//! Test 2: the body rules. A node is never paired with a face it is a corner of; pairs within one
//! body appear only with `self_contact`; different bodies always. Reference: the all-pairs search
//! of `common` (its own coding of the rules), which must give the same set exactly (the geometry
//! here is kept away from the thresholds: 0 borderline pairs).

mod common;

use common::{reference_search, Scene};
use contact::{search, ContactBox, FaceRecord, NodeRecord, SearchParams};

/// A sheet of `n x 2n` quads folded into a hairpin (a lower layer facing up, an upper layer facing
/// down, `gap` apart, shifted in-plane so the layers' nodes do not fall on each other's face edges),
/// with the upper layer pushed `gap + sink` down during the step, so each layer crosses the other:
/// self-contact of body 0. Plus a flat plate (body 1) that the lower layer sinks into.
fn folded_sheet(n: usize, gap: f64, sink: f64) -> Scene {
    let h = 1.0 / n as f64;
    let shift = [h / 3.0, h / 4.0];
    let cols = 2 * n + 1;
    let id = |i: usize, j: usize| (i * (n + 1) + j) as u64 * 5 + 11;
    let mut nodes = Vec::new();
    for i in 0..cols {
        for j in 0..=n {
            let u = i as f64 * h;
            let v = j as f64 * h;
            let (x0, x1) = if i <= n {
                ([u, v, 0.0], [u, v, -0.5 * sink])
            } else {
                let p = [2.0 - u + shift[0], v + shift[1], gap];
                (p, [p[0], p[1], -sink])
            };
            nodes.push(NodeRecord {
                gid: id(i, j),
                body: 0,
                flags: 0,
                mass: 1.0,
                radius: 0.0,
                x0,
                x1,
                v: [0.0; 3],
            });
        }
    }
    let mut faces = Vec::new();
    for i in 0..cols - 1 {
        for j in 0..n {
            faces.push(FaceRecord {
                gid: (i * n + j) as u64 * 3 + 2,
                nodes: [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)],
                body: 0,
                reserved: 0,
            });
        }
    }
    // Body 1: a plate at z = -0.25 sink facing up, under the lower layer, meshed 3 x 3 with an
    // offset so nodes miss its face edges.
    let m = 3;
    let base = 1_000_000u64;
    for i in 0..=m {
        for j in 0..=m {
            let p = [
                -0.1 + 1.2 * i as f64 / m as f64 + 0.013,
                -0.1 + 1.2 * j as f64 / m as f64 + 0.007,
                -0.25 * sink,
            ];
            nodes.push(NodeRecord {
                gid: base + (i * (m + 1) + j) as u64,
                body: 1,
                flags: 0,
                mass: 1.0,
                radius: 0.0,
                x0: p,
                x1: p,
                v: [0.0; 3],
            });
        }
    }
    let pid = |i: usize, j: usize| base + (i * (m + 1) + j) as u64;
    for i in 0..m {
        for j in 0..m {
            faces.push(FaceRecord {
                gid: base + (i * m + j) as u64,
                nodes: [pid(i, j), pid(i + 1, j), pid(i + 1, j + 1), pid(i, j + 1)],
                body: 1,
                reserved: 0,
            });
        }
    }
    Scene { nodes, faces }
}

#[test]
fn body_rules_and_self_contact() {
    let scene = folded_sheet(8, 0.05, 0.02);
    let b = ContactBox::from_records(&scene.nodes, scene.nodes.len(), &scene.faces).unwrap();
    let body_of_face = |f: u32| b.faces.body[f as usize];
    for self_contact in [false, true] {
        let params = SearchParams {
            self_contact,
            ..SearchParams::default()
        };
        let got = search(&b, &params);
        let mut same_body = 0;
        for c in &got {
            assert!(
                !b.faces.node_gid[c.face as usize].contains(&c.node_gid),
                "node {} paired with its own face {}",
                c.node_gid,
                c.face_gid
            );
            if b.nodes.body[c.node as usize] == body_of_face(c.face) {
                same_body += 1;
            }
        }
        if self_contact {
            assert!(
                same_body > 50,
                "self-contact found only {same_body} same-body pairs"
            );
        } else {
            assert_eq!(same_body, 0, "same-body pairs without self_contact");
            assert!(
                !got.is_empty(),
                "the sheet must hit the plate (different bodies)"
            );
        }
        let want = reference_search(&scene, self_contact, params.gap_tol, params.param_tol);
        let mut got_pairs: Vec<(u64, u64)> = got.iter().map(|c| (c.node_gid, c.face_gid)).collect();
        let mut want_pairs: Vec<(u64, u64)> =
            want.contacts.iter().map(|(n, v)| (*n, v.0)).collect();
        want_pairs.extend(&want.further);
        got_pairs.sort_unstable();
        want_pairs.sort_unstable();
        assert_eq!(got_pairs, want_pairs, "self_contact = {self_contact}");
        println!(
            "self_contact = {self_contact}: {} contacts, {same_body} within one body",
            got.len()
        );
    }
}

/// A node that is a corner of a face sits on that face whatever the face does; round-off in the
/// projection must not make it a contact. Every corner of a strongly warped, moving face is tested
/// against its own face with self-contact on and a large capture tolerance.
#[test]
fn corner_never_contacts_its_face() {
    let mut rng = common::Rng(5);
    let scene = common::random_scene(
        &mut rng,
        &common::SceneSpec {
            faces: 200,
            free_nodes: 0,
            crossing_nodes: 0,
            bodies: 1,
            particles: false,
            size: 1.0,
        },
    );
    let b = ContactBox::from_records(&scene.nodes, scene.nodes.len(), &scene.faces).unwrap();
    let params = SearchParams {
        self_contact: true,
        one_pass: false,
        gap_tol: 0.5,
        param_tol: 0.5,
        self_param_tol: 0.5,
    };
    for f in 0..b.faces.len() {
        for &j in &b.faces.nodes[f] {
            assert!(contact::pair::test(&b, j as usize, f, &params).is_none());
        }
    }
    for c in search(&b, &params) {
        assert!(!b.faces.node_gid[c.face as usize].contains(&c.node_gid));
    }
}

/// One pass (`[contact] passes = 1`): the nodes of a master body are not searched against the
/// faces of the other bodies; everything else is as with two passes. Reference: the two-pass
/// search of the same scene (itself checked against the all-pairs reference above). With the
/// sheet as master, its nodes lose their contacts with the plate (a master node is never paired
/// with a non-master face) and the plate's nodes keep theirs; with the plate as master, the
/// sheet's nodes keep every contact.
#[test]
fn one_pass_searches_only_the_other_bodies_nodes_against_a_masters_faces() {
    let scene = folded_sheet(8, 0.05, 0.02);
    let two = SearchParams {
        self_contact: true,
        ..SearchParams::default()
    };
    let one = SearchParams {
        one_pass: true,
        ..two
    };
    let key = |c: &contact::Contact| (c.node_gid, c.face_gid);
    let b = ContactBox::from_records(&scene.nodes, scene.nodes.len(), &scene.faces).unwrap();
    let both_ways = search(&b, &two);
    let sheet_plate = |c: &&contact::Contact| {
        b.nodes.body[c.node as usize] == 0 && b.faces.body[c.face as usize] == 1
    };
    assert!(
        both_ways.iter().filter(sheet_plate).count() > 10,
        "the sheet must hit the plate"
    );
    for master in [0u32, 1] {
        let mut nodes = scene.nodes.clone();
        for n in nodes.iter_mut().filter(|n| n.body == master) {
            n.flags |= contact::FLAG_MASTER;
        }
        let b = ContactBox::from_records(&nodes, nodes.len(), &scene.faces).unwrap();
        let got = search(&b, &one);
        for c in &got {
            assert!(
                b.nodes.body[c.node as usize] != master || b.faces.body[c.face as usize] == master,
                "master {master}: node {} of the master against face {} of the other body",
                c.node_gid,
                c.face_gid
            );
        }
        let of_slaves = |v: &[contact::Contact]| -> Vec<(u64, u64)> {
            v.iter()
                .filter(|c| b.nodes.body[c.node as usize] != master)
                .map(key)
                .collect()
        };
        assert_eq!(
            of_slaves(&got),
            of_slaves(&both_ways),
            "master {master}: the other body's contacts"
        );
        let lost = both_ways.len() - got.len();
        println!(
            "master {master}: {} contacts, {lost} fewer than two passes",
            got.len()
        );
        if master == 0 {
            assert!(
                lost > 10,
                "the sheet's nodes kept their contacts with the plate"
            );
        }
    }
}
