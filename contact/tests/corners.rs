//! Test 5: detection never misses a crossing at a node, an edge or a corner of the other surface.
//!
//! A node pressed onto a node of a plate dimples it, and a node just behind the bottom of a dimple
//! (or of any valley between faces) projects off every face around it: the dead zone of the
//! closest-point projection (see the `pair` module's documentation). References: analytic
//! geometry (the tangent planes of the bilinear faces at their corners, the plane of a flat plate)
//! and the non-penetration constraint itself, re-measured after each push-back with the
//! independent projection of `common`.

mod common;

use common::{dot, sub, Mono, V3};
use contact::{
    push_back, recheck, search, Candidates, ContactBox, FaceRecord, NodeRecord, PushBackParams,
    Quad, SearchParams,
};

const DT: f64 = 1e-3;

/// A plate of `n x n` unit faces (body 0, gids 100 + k) over `[-n/2, n/2]^2` at `z = 0` with
/// node masses `mass`, then the node (body 1, gid 1) moving from `p0` to `p1`. `plate0`,
/// `plate1`: the plate nodes' start and end positions (row-major, `(n + 1)^2`).
fn plate_box(n: usize, mass: f64, plate0: &[V3], plate1: &[V3], p0: V3, p1: V3) -> ContactBox {
    let mut nodes = vec![record(1, 1, 1.0, p0, p1)];
    for k in 0..plate0.len() {
        nodes.push(record(10 + k as u64, 0, mass, plate0[k], plate1[k]));
    }
    let id = |i: usize, j: usize| 10 + (j * (n + 1) + i) as u64;
    let mut faces = Vec::new();
    for j in 0..n {
        for i in 0..n {
            faces.push(FaceRecord {
                gid: 100 + (j * n + i) as u64,
                nodes: [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)],
                body: 0,
                reserved: 0,
            });
        }
    }
    ContactBox::from_records(&nodes, 1, &faces).unwrap()
}

/// The flat plate's nodes, with the node at grid point (i, j) lowered by `sink`.
fn plate_nodes(n: usize, sunk: (usize, usize), sink: f64) -> Vec<V3> {
    let mut x = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let z = if (i, j) == sunk { -sink } else { 0.0 };
            x.push([i as f64 - 0.5 * n as f64, j as f64 - 0.5 * n as f64, z]);
        }
    }
    x
}

/// The faces of box `b` in their end configuration.
fn end_faces(b: &ContactBox) -> Vec<[V3; 4]> {
    (0..b.faces.len())
        .map(|f| b.faces.nodes[f].map(|i| b.nodes.x1[i as usize]))
        .collect()
}

/// The signed distance of `p` to the nearest point of the bilinear face `x` within the face
/// (reference projection of `common`, clamped to the face), positive outside.
fn distance_to_face(x: [V3; 4], p: V3) -> f64 {
    let m = Mono::new(x);
    let (s, t) = m.project(p);
    let (s, t) = (s.clamp(-1.0, 1.0), t.clamp(-1.0, 1.0));
    dot(sub(p, m.at(s, t)), m.normal(s, t))
}

#[test]
fn node_behind_the_bottom_of_a_dimple_is_found() {
    // The central node of a 2 x 2 plate is sunk h (a dimple, as push-back leaves it); the node
    // starts on that corner and ends eps below it. Each face's end projection is off the face
    // (the dead zone: asserted, so that the test exercises it), yet the node crossed the corner
    // shared by the four faces: one contact, at a corner of its face. The four faces tie (each
    // depth eps / sqrt(1 + 2 h^2) along its normal (-h, -h, 1) / sqrt(1 + 2 h^2) up to the
    // quadrant's signs), so the contact takes their mean normal, (0, 0, 1), and the depth along
    // it that leaves every face's plane, eps (analytic, to 1e-12): the same whichever face wins
    // the tie.
    let (h, eps) = (0.05, 0.01);
    let plate = plate_nodes(2, (1, 1), h);
    let v = plate[4];
    let b = plate_box(2, 1.0, &plate, &plate, v, [v[0], v[1], v[2] - eps]);
    for x in end_faces(&b) {
        let p = Quad { x }.closest_point(b.nodes.x1[0]).unwrap();
        assert!(
            p.xi[0].abs().max(p.xi[1].abs()) > 1.0 + 1e-4,
            "the end position projects on a face ({:?}): no dead zone to test",
            p.xi
        );
    }
    let contacts = search(&b, &SearchParams::default());
    assert_eq!(contacts.len(), 1, "contacts {contacts:?}");
    let c = contacts[0];
    assert!(
        (c.depth - eps).abs() < 1e-12,
        "depth {} (analytic {eps})",
        c.depth,
    );
    assert!(
        (c.normal[2] - 1.0).abs() < 1e-12 && c.normal[0].abs().max(c.normal[1].abs()) < 1e-12,
        "normal {:?} (analytic (0, 0, 1))",
        c.normal
    );
    assert!(
        c.xi[0].abs() == 1.0 && c.xi[1].abs() == 1.0,
        "xi {:?}",
        c.xi
    );
}

#[test]
fn node_pressed_on_a_plate_node_stays_outside_step_after_step() {
    // A contact failure in miniature: a heavy node lands exactly on a node of a light
    // 4 x 4 plate and keeps pressing it for 40 steps, while the plate's spring pulls the hit
    // node back up each step (its neighbours stay put), so the dimple under the node renews
    // every step. Reference: the non-penetration constraint. After each step's push-back the
    // node lands on one of the four faces around the hit node and is behind the others by
    // second-order amounts (its depth times the slope squared, and its offset from the hit node
    // times the slope: measured 6.4e-5 with the dimple 0.057 deep): asserted under a tenth of
    // the capture tolerance (`gap_tol` times the face's diameter, 1.4e-3), so that the next
    // step sees it as having started outside; and every step after the first touch finds a
    // contact.
    let n = 4;
    let (speed, spring) = (0.004, 0.3);
    let mut plate = plate_nodes(n, (0, 0), 0.0);
    let centre = 2 * (n + 1) + 2;
    let mut p = [0.0, 0.0, 0.0105];
    let mut found = 0;
    let capture = SearchParams::default().gap_tol * 2f64.sqrt();
    let mut worst = 0.0f64;
    for step in 0..40 {
        let mut plate1 = plate.clone();
        // The spring: the hit node goes back up by a share of its depth.
        plate1[centre][2] *= 1.0 - spring;
        let p1 = [p[0], p[1], p[2] - speed];
        let b = plate_box(n, 0.2, &plate, &plate1, p, p1);
        let contacts = search(&b, &SearchParams::default());
        let pb = push_back(&b, &contacts, &PushBackParams::new(DT));
        let x: Vec<V3> = (0..b.nodes.len())
            .map(|j| {
                let dx = pb.position_correction(&b, j, DT);
                [
                    b.nodes.x1[j][0] + dx[0],
                    b.nodes.x1[j][1] + dx[1],
                    b.nodes.x1[j][2] + dx[2],
                ]
            })
            .collect();
        if p1[2] < x[1 + centre][2] + 1e-3 {
            assert!(
                !contacts.is_empty(),
                "step {step}: the node (z = {}) crossed the plate node (z = {}) unseen",
                p1[2],
                x[1 + centre][2]
            );
            found += 1;
        }
        for f in 0..b.faces.len() {
            let q = b.faces.nodes[f].map(|i| x[i as usize]);
            if b.faces.nodes[f].contains(&(1 + centre as u32)) {
                let d = distance_to_face(q, x[0]);
                worst = worst.max(-d);
                assert!(
                    d > -0.1 * capture,
                    "step {step}: the node is {:.3e} behind face {} after push-back",
                    -d,
                    b.faces.gid[f]
                );
            }
        }
        p = x[0];
        plate = x[1..].to_vec();
    }
    println!(
        "{found} steps in contact; the node at most {worst:.3e} behind a face after push-back"
    );
    assert!(
        found > 30,
        "the node pressed the plate in only {found} steps"
    );
}

#[test]
fn node_falling_past_the_outer_edge_is_free() {
    // A node falls beside a plate's edge: it crosses the plane of the plate's faces continued
    // past the edge (at x = 1.18 > 1), not a face. No contact.
    let plate = plate_nodes(2, (1, 1), 0.0);
    let b = plate_box(2, 1.0, &plate, &plate, [1.2, 0.3, 0.02], [1.15, 0.3, -0.03]);
    let contacts = search(&b, &SearchParams::default());
    assert!(contacts.is_empty(), "contacts {contacts:?}");
}

#[test]
fn node_sliding_off_an_edge_is_pushed_up_not_back() {
    // A node resting on the plate at x = 0.95 slides past its edge (x = 1) to x = 1.1 while
    // sinking 0.01: its straight path cuts the plate's corner, so it crossed the face. The
    // contact is the face's normal (0, 0, 1) at the edge with depth 0.01 (analytic), so an
    // immovable plate puts the node back on its plane at x = 1.1 (not dragged back along the
    // face); the next step, starting past the edge, it falls free.
    let plate = plate_nodes(2, (1, 1), 0.0);
    let b = plate_box(
        2,
        f64::INFINITY,
        &plate,
        &plate,
        [0.95, 0.3, 0.0],
        [1.1, 0.3, -0.01],
    );
    let contacts = search(&b, &SearchParams::default());
    assert_eq!(contacts.len(), 1, "contacts {contacts:?}");
    let c = contacts[0];
    assert!((c.depth - 0.01).abs() < 1e-15 && c.normal == [0.0, 0.0, 1.0]);
    let pb = push_back(&b, &contacts, &PushBackParams::new(DT));
    let dx = pb.position_correction(&b, 0, DT);
    let p = [1.1 + dx[0], 0.3 + dx[1], -0.01 + dx[2]];
    assert!(
        (p[0] - 1.1).abs() < 1e-15 && p[2].abs() < 1e-15,
        "after push-back {p:?}"
    );
    let b = plate_box(2, f64::INFINITY, &plate, &plate, p, [1.25, 0.3, -0.01]);
    assert!(search(&b, &SearchParams::default()).is_empty());
}

#[test]
fn node_pressed_into_a_valley_stays_out_of_both_faces() {
    // Faces at an angle: a V-groove of two rows of faces sloping at 45 degrees down to a crease
    // along y (an immovable body), and a node driven straight down onto the crease for 10 steps.
    // Behind the crease the node projects off both faces (the dead zone) and, pushed out of one
    // face only, it would stay behind the other by its depth times sqrt(2). Reference: the
    // non-penetration constraint; after each push-back the node is behind neither face by more
    // than 1e-9, and lies on the crease.
    let nodes_at = |z: f64| -> Vec<V3> {
        let mut x = Vec::new();
        for j in 0..=2 {
            for i in 0..=2 {
                let xx = i as f64 - 1.0;
                x.push([xx, j as f64 - 1.0, xx.abs() + z]);
            }
        }
        x
    };
    let plate = nodes_at(0.0);
    let mut p = [0.0, 0.0, 0.02];
    for step in 0..10 {
        let p1 = [p[0], p[1], p[2] - 0.01];
        let b = plate_box(2, f64::INFINITY, &plate, &plate, p, p1);
        let contacts = search(&b, &SearchParams::default());
        let pb = push_back(&b, &contacts, &PushBackParams::new(DT));
        let dx = pb.position_correction(&b, 0, DT);
        let x = [p1[0] + dx[0], p1[1] + dx[1], p1[2] + dx[2]];
        for q in end_faces(&b) {
            let d = distance_to_face(q, x);
            assert!(
                d > -1e-9,
                "step {step}: the node is {:.3e} behind a face of the groove",
                -d
            );
        }
        if step >= 2 {
            assert!(
                x[0].abs() < 1e-9 && x[2].abs() < 1e-9,
                "step {step}: node at {x:?}, not on the crease"
            );
        }
        p = x;
    }
}

/// A box of one moving node (gid 1, body 1, unit mass, from `p.0` to `p.1`) and immovable
/// corners (gids 10, 11, ... at `corners`, of `bodies`), with `faces` (gid, the positions of
/// its corners in `corners`, body).
fn node_and_faces(
    p: (V3, V3),
    corners: &[V3],
    bodies: &[u32],
    faces: &[(u64, [usize; 4], u32)],
) -> ContactBox {
    let mut nodes = vec![record(1, 1, 1.0, p.0, p.1)];
    for (k, (x, &body)) in corners.iter().zip(bodies).enumerate() {
        nodes.push(record(10 + k as u64, body, f64::INFINITY, *x, *x));
    }
    let faces: Vec<FaceRecord> = faces
        .iter()
        .map(|&(gid, c, body)| FaceRecord {
            gid,
            nodes: c.map(|k| 10 + k as u64),
            body,
            reserved: 0,
        })
        .collect();
    ContactBox::from_records(&nodes, 1, &faces).unwrap()
}

/// The convex edge of the test below, its side face on body `side_body`: the contacts found
/// and the node's position correction.
fn convex_edge(side_body: u32) -> (Vec<contact::Contact>, V3) {
    let top = [
        [-1.0, 0.0, 0.0],
        [0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0],
    ];
    let side = [
        [0.0, 0.0, 0.0],
        [0.0, 0.0, -1.0],
        [0.0, 1.0, -1.0],
        [0.0, 1.0, 0.0],
    ];
    let corners = [top[0], top[1], top[2], top[3], side[1], side[2]];
    let bodies = [0, 0, 0, 0, side_body, side_body];
    let b = node_and_faces(
        ([0.005, 0.5, 0.005], [-0.001, 0.5, -0.002]),
        &corners,
        &bodies,
        &[(100, [0, 1, 2, 3], 0), (101, [1, 4, 5, 2], side_body)],
    );
    let contacts = search(&b, &SearchParams::default());
    let pb = push_back(&b, &contacts, &PushBackParams::new(DT));
    (contacts.clone(), pb.position_correction(&b, 0, DT))
}

#[test]
fn node_at_a_convex_edge_leaves_one_face_only() {
    // The convex edge of an immovable body (x < 0 and z < 0 over 0 < y < 1: a top face with
    // normal +z, a side face with normal +x): a node ends 0.002 below the top plane and 0.001
    // inside the side plane, behind both. Leaving either face takes it out of the body, so it
    // keeps one contact (the deepest: the top face, depth 0.002), not two (pushed out of both
    // planes, a sideways kick as well). Reference: the geometry of the wedge; after push-back the
    // node is on the top plane, where it ended in x and y.
    let (contacts, dx) = convex_edge(0);
    assert_eq!(contacts.len(), 1, "contacts {contacts:?}");
    assert_eq!(contacts[0].face_gid, 100);
    assert!((contacts[0].depth - 0.002).abs() < 1e-15);
    assert!(
        dx[0] == 0.0 && dx[1] == 0.0 && (dx[2] - 0.002).abs() < 1e-15,
        "correction {dx:?}"
    );
}

#[test]
fn node_behind_faces_of_two_bodies_leaves_both() {
    // The same edge with its side face on another body: behind either face the node is inside
    // a body, so it keeps both contacts (`search::apart`) and leaves both planes. Reference:
    // the geometry; the node ends on the edge, (0, 0.5, 0): moved +0.001 in x, +0.002 in z.
    let (contacts, dx) = convex_edge(2);
    let faces: Vec<u64> = contacts.iter().map(|c| c.face_gid).collect();
    assert_eq!(faces, [100, 101], "contacts {contacts:?}");
    assert!(
        (dx[0] - 0.001).abs() < 1e-15 && dx[1] == 0.0 && (dx[2] - 0.002).abs() < 1e-15,
        "correction {dx:?}"
    );
}

#[test]
fn a_node_on_a_node_found_both_ways_is_one_constraint() {
    // Two 2 x 2 plates, the upper one facing down and tilted 0.05 about y, its centre node
    // driven 0.003 down onto the lower one's centre node (equal masses, the plates' other nodes
    // immovable). The two-pass search finds the gap both ways (each centre node against a face
    // around the other, at that node), two rows a few degrees apart that Gauss-Seidel converges
    // slowly and that, both active, would hold the pair together sideways. The push-back makes
    // them one row along the mean of the two normals. Reference: the geometry of the pair; after
    // push-back the two nodes are level along that mean normal (to 1e-15), their offset across
    // it unchanged, each moved by half the depth (equal masses), in one sweep per pass.
    let lower = plate_nodes(2, (1, 1), 0.0);
    let tilt = 0.05;
    let upper0: Vec<V3> = lower
        .iter()
        .map(|x| [x[0], x[1], 0.001 + tilt * x[0]])
        .collect();
    let mut upper1 = upper0.clone();
    upper1[4][2] -= 0.003;
    let mut nodes = Vec::new();
    for k in 0..9 {
        let m = if k == 4 { 1.0 } else { f64::INFINITY };
        nodes.push(record(10 + k as u64, 0, m, lower[k], lower[k]));
        nodes.push(record(30 + k as u64, 1, m, upper0[k], upper1[k]));
    }
    let id = |base: u64, i: usize, j: usize| base + (j * 3 + i) as u64;
    let mut faces = Vec::new();
    for j in 0..2 {
        for i in 0..2 {
            let c = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
            faces.push(FaceRecord {
                gid: 100 + (j * 2 + i) as u64,
                nodes: c.map(|(a, b)| id(10, a, b)),
                body: 0,
                reserved: 0,
            });
            // Facing down: the same corners the other way round.
            let mut d = c.map(|(a, b)| id(30, a, b));
            d.reverse();
            faces.push(FaceRecord {
                gid: 200 + (j * 2 + i) as u64,
                nodes: d,
                body: 1,
                reserved: 0,
            });
        }
    }
    let b = ContactBox::from_records(&nodes, nodes.len(), &faces).unwrap();
    let contacts = search(&b, &SearchParams::default());
    let gids: Vec<u64> = contacts.iter().map(|c| c.node_gid).collect();
    assert_eq!(gids, vec![14, 34], "contacts {contacts:?}");
    let n = {
        let d = sub(contacts[0].normal, contacts[1].normal);
        let l = dot(d, d).sqrt();
        [d[0] / l, d[1] / l, d[2] / l]
    };
    assert!(n[0].abs() > 0.01, "the two normals must differ ({n:?})");
    let pb = push_back(&b, &contacts, &PushBackParams::new(DT));
    let moved = |j: usize| {
        let dx = pb.position_correction(&b, j, DT);
        [
            b.nodes.x1[j][0] + dx[0],
            b.nodes.x1[j][1] + dx[1],
            b.nodes.x1[j][2] + dx[2],
        ]
    };
    let (s, p) = (contacts[1].node as usize, contacts[0].node as usize);
    let before = sub(b.nodes.x1[s], b.nodes.x1[p]);
    let after = sub(moved(s), moved(p));
    assert!(
        dot(after, n).abs() < 1e-15,
        "gap along n after {:.3e}",
        dot(after, n)
    );
    let across = |v: V3| sub(v, [n[0] * dot(v, n), n[1] * dot(v, n), n[2] * dot(v, n)]);
    let (a, c) = (across(before), across(after));
    assert!(
        dot(sub(a, c), sub(a, c)).sqrt() < 1e-15,
        "offset across n changed"
    );
    let half = 0.5 * dot(before, n).abs();
    let ds = pb.position_correction(&b, s, DT);
    assert!((dot(ds, ds).sqrt() - half).abs() < 1e-15);
    assert!(pb.sweeps <= 2, "{} sweeps", pb.sweeps);
    assert_eq!(pb.normal_force[1], 0.0);
}

#[test]
fn a_node_pushed_out_of_one_body_into_another_is_found_by_the_recheck() {
    // Two immovable bodies meeting in a wedge: a face A of body 0 in the plane through the
    // y axis with normal (sin 30, 0, cos 30), and a face B of body 2 in the plane x = 0 with
    // normal -x. A node ends the step 0.00396 behind A and 0.001 in front of B: the search
    // finds A only, and pushing the node out of A along A's normal carries it 0.00098 past
    // B (a crossing the push-back made, which the next step could not see: it would start
    // behind B). `contact::recheck` on the corrected position finds B (another body: a
    // constraint of its own), and the push-back of both leaves the node on the wedge's edge.
    // Reference: the geometry of the two planes; the node ends at their intersection straight
    // across from where it ended, (0, 0.5, 0), to 1e-12 m, and a second recheck finds nothing.
    let (s, c) = (0.5f64, 0.75f64.sqrt());
    // Points of A's plane at x = -1 and x = 0.2: z = -x tan 30.
    let a_at = |x: f64, y: f64| [x, y, -x * s / c];
    let corners = [
        a_at(-1.0, 0.0),
        a_at(0.2, 0.0),
        a_at(0.2, 1.0),
        a_at(-1.0, 1.0),
        [0.0, 0.0, -1.0],
        [0.0, 0.0, 1.0],
        [0.0, 1.0, 1.0],
        [0.0, 1.0, -1.0],
    ];
    let (p0, p1) = ([-0.01, 0.5, 0.01], [-0.001, 0.5, -0.004]);
    let mut b = node_and_faces(
        (p0, p1),
        &corners,
        &[0, 0, 0, 0, 2, 2, 2, 2],
        &[(100, [0, 1, 2, 3], 0), (200, [4, 5, 6, 7], 2)],
    );
    let params = SearchParams::default();
    let cands = Candidates::build(&b, &params, 0.0);
    let mut contacts = search(&b, &params);
    assert_eq!(contacts.len(), 1, "contacts {contacts:?}");
    assert_eq!(contacts[0].face_gid, 100);
    let corrections = |pb: &contact::PushBack, b: &ContactBox| -> Vec<V3> {
        (0..b.nodes.len())
            .map(|j| pb.position_correction(b, j, DT))
            .collect()
    };
    let pb = push_back(&b, &contacts, &PushBackParams::new(DT));
    let dx = corrections(&pb, &b);
    let x = [p1[0] + dx[0][0], p1[1] + dx[0][1], p1[2] + dx[0][2]];
    // The depth behind A, then the node's x after moving that far along A's normal.
    let depth_a = -(s * p1[0] + c * p1[2]);
    let past_b = p1[0] + s * depth_a;
    assert!(
        (x[0] - past_b).abs() < 1e-12,
        "pushed out of A only, the node is {} past B (geometry: {past_b})",
        x[0]
    );
    let new = recheck(&mut b, &params, &cands, &dx, &contacts);
    assert_eq!(new.len(), 1, "recheck found {new:?}");
    assert_eq!(new[0].face_gid, 200);
    // Measured on the uncorrected geometry: the node ended 0.001 in front of B.
    assert!(
        (new[0].depth + 0.001).abs() < 1e-12,
        "depth {}",
        new[0].depth
    );
    contacts.extend(new);
    let pb = push_back(&b, &contacts, &PushBackParams::new(DT));
    let dx = corrections(&pb, &b);
    let x = [p1[0] + dx[0][0], p1[1] + dx[0][1], p1[2] + dx[0][2]];
    let off = sub(x, [0.0, 0.5, 0.0]);
    assert!(
        dot(off, off).sqrt() < 1e-12,
        "the node ends at {x:?}, not on the wedge's edge (0, 0.5, 0)"
    );
    assert!(recheck(&mut b, &params, &cands, &dx, &contacts).is_empty());
}

/// End position of box node `j` with the push-back's position correction.
fn corrected(b: &ContactBox, pb: &contact::PushBack, j: usize) -> V3 {
    let dx = pb.position_correction(b, j, DT);
    [
        b.nodes.x1[j][0] + dx[0],
        b.nodes.x1[j][1] + dx[1],
        b.nodes.x1[j][2] + dx[2],
    ]
}

#[test]
fn a_node_squeezed_between_two_bodies_stays_on_both() {
    // A node of body 1 (unit mass, at rest) between two unit faces of two other bodies that
    // close on it from both sides: face A of body 0 (normal +z, corner masses 0.5) rises from
    // z = -0.01 to a = 0.003, face B of body 2 (normal -z, corner masses 0.25) falls from
    // z = 0.01 to -b = -0.002, the node at both faces' centres. Behind either face the node is
    // inside a body, so both are contacts (`search::apart`, whatever the angle: here the
    // normals are opposite, |cos| = 1, which the search's one-surface rule alone reads as one
    // contact, keeping A only and pushing the node 0.004 into B). Reference: the push-back
    // closes both gaps, so the node and both faces' centres (flat faces pushed at their centres
    // translate) end at one height; it conserves momentum, so that height is the mass-weighted
    // mean z* = (M_A a - M_B b) / (m + M_A + M_B) = 0.001, with each face's mass seen at its
    // centre M = 4 m_corner (M_A = 2, M_B = 1); the impulses are M_A (a - z*) = 0.004 and
    // M_B (z* + b) = 0.003 (kg m). All to 1e-12.
    let (a, b_end) = (0.003, 0.002);
    let (m_a, m_b) = (0.5, 0.25);
    let square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let mut nodes = vec![record(1, 1, 1.0, [0.5, 0.5, 0.0], [0.5, 0.5, 0.0])];
    for (k, c) in square.iter().enumerate() {
        let at = |z: f64| [c[0], c[1], z];
        nodes.push(record(10 + k as u64, 0, m_a, at(-0.01), at(a)));
        nodes.push(record(20 + k as u64, 2, m_b, at(0.01), at(-b_end)));
    }
    let face = |gid: u64, nodes: [u64; 4], body: u32| FaceRecord {
        gid,
        nodes,
        body,
        reserved: 0,
    };
    // B faces down: the same corners the other way round.
    let faces = [
        face(100, [10, 11, 12, 13], 0),
        face(200, [23, 22, 21, 20], 2),
    ];
    let b = ContactBox::from_records(&nodes, 1, &faces).unwrap();
    let contacts = search(&b, &SearchParams::default());
    let found: Vec<(u64, f64)> = contacts.iter().map(|c| (c.face_gid, c.depth)).collect();
    assert_eq!(
        found.len(),
        2,
        "contacts {found:?}: the node is behind both bodies' faces (depths {a}, {b_end})"
    );
    assert!(
        found[0].0 == 100
            && (found[0].1 - a).abs() < 1e-12
            && found[1].0 == 200
            && (found[1].1 - b_end).abs() < 1e-12,
        "contacts (face, depth) {found:?} (geometry: A {a}, B {b_end})"
    );
    let pb = push_back(&b, &contacts, &PushBackParams::new(DT));
    let (big_a, big_b) = (4.0 * m_a, 4.0 * m_b);
    let z_star = (big_a * a - big_b * b_end) / (1.0 + big_a + big_b);
    let z_of = |gid: u64| {
        let j = b.nodes.gid.iter().position(|&g| g == gid).unwrap();
        corrected(&b, &pb, j)
    };
    let centre = |first: u64| (first..first + 4).map(|g| z_of(g)[2]).sum::<f64>() / 4.0;
    let node = z_of(1);
    for (what, z) in [
        ("the node", node[2]),
        ("face A's centre", centre(10)),
        ("face B's centre", centre(20)),
    ] {
        assert!(
            (z - z_star).abs() < 1e-12,
            "{what} ends at z = {z:.15e}, not at the mass-weighted mean z* = {z_star} (1e-12)"
        );
    }
    assert!(
        node[0] == 0.5 && node[1] == 0.5,
        "the node moved sideways: {node:?}"
    );
    let impulse = [big_a * (a - z_star), big_b * (z_star + b_end)];
    for (k, want) in impulse.iter().enumerate() {
        let got = pb.normal_force[k] * DT * DT;
        assert!(
            (got - want).abs() < 1e-12,
            "face {}: impulse times dt {got:.15e}, analytic {want} (1e-12)",
            contacts[k].face_gid
        );
    }
}

#[test]
fn a_node_on_a_node_at_a_junction_is_two_constraints() {
    // A junction of bodies in miniature (rod_wall's rod face on the corner where four bricks
    // meet): a "rod" of 2 x 2 unit faces in the plane x = 0 (body 0, normal +x) whose centre
    // node p (unit mass) slides from y = -1e-4 to 1e-4 in that plane, into a "brick" (body 1)
    // whose corner s (unit mass) comes from x = 1e-3 to -2e-4, through the rod's face at p.
    // Of the brick only the side face at s is in the box, in the plane y = 0 (normal -y; the
    // brick at y > 0), s and three immovable corners. The two-pass search finds s 2e-4 behind
    // the rod's face at p (normal +x) and p 1e-4 behind the brick's side face at s (normal
    // -y): a node on a node found both ways, each contact point within `same_point_tol` of the
    // other node, but two gaps at right angles, not one gap seen from both sides. Reference:
    // the non-penetration constraints, re-measured after the push-back with the independent
    // projection of `common`: s outside every face of the rod and p outside the brick's face
    // to 1e-12 m (one row along the normals' mean closes only the sum of the two depths,
    // (2e-4 + 1e-4) / sqrt 2 along it, and leaves each 5e-5 deep); momentum: the forces sum to
    // zero (immovable corners take their reactions), to 1e-12 of the largest.
    let mut nodes = vec![
        record(1, 0, 1.0, [0.0, -1e-4, 0.0], [0.0, 1e-4, 0.0]),
        record(2, 1, 1.0, [1e-3, 0.0, 0.0], [-2e-4, 0.0, 0.0]),
    ];
    // The rod's other nodes: grid points (y, z) in {-1, 0, 1}^2 but the centre, gids 10 + k.
    let rod_gid = |i: usize, j: usize| {
        if (i, j) == (1, 1) {
            1
        } else {
            10 + (3 * j + i) as u64
        }
    };
    for j in 0..3 {
        for i in 0..3 {
            if (i, j) != (1, 1) {
                let x = [0.0, i as f64 - 1.0, j as f64 - 1.0];
                nodes.push(record(rod_gid(i, j), 0, f64::INFINITY, x, x));
            }
        }
    }
    let brick = [[1.0, 0.0, 0.0], [1.0, 0.0, 1.0], [0.0, 0.0, 1.0]];
    for (k, x) in brick.iter().enumerate() {
        nodes.push(record(30 + k as u64, 1, f64::INFINITY, *x, *x));
    }
    let mut faces = Vec::new();
    for j in 0..2 {
        for i in 0..2 {
            // Counter-clockwise seen from +x: y then z.
            let c = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
            faces.push(FaceRecord {
                gid: 100 + (2 * j + i) as u64,
                nodes: c.map(|(a, b)| rod_gid(a, b)),
                body: 0,
                reserved: 0,
            });
        }
    }
    // Seen from -y (outside the brick), counter-clockwise: s, (1, 0, 0), (1, 0, 1), (0, 0, 1).
    faces.push(FaceRecord {
        gid: 200,
        nodes: [2, 30, 31, 32],
        body: 1,
        reserved: 0,
    });
    let b = ContactBox::from_records(&nodes, 2, &faces).unwrap();
    let contacts = search(&b, &SearchParams::default());
    let pairs: Vec<(u64, u64)> = contacts.iter().map(|c| (c.node_gid, c.face_gid)).collect();
    assert_eq!(pairs.len(), 2, "contacts {contacts:?}");
    assert!(
        pairs[0].0 == 1 && pairs[0].1 == 200 && pairs[1].0 == 2 && pairs[1].1 < 200,
        "contacts {pairs:?}: p on the brick's face, s on a rod face"
    );
    assert!(
        dot(contacts[0].normal, contacts[1].normal).abs() < 1e-12,
        "normals {:?}, {:?}: at right angles by construction",
        contacts[0].normal,
        contacts[1].normal
    );
    let pb = push_back(&b, &contacts, &PushBackParams::new(DT));
    let at = |gid: u64| {
        let j = b.nodes.gid.iter().position(|&g| g == gid).unwrap();
        corrected(&b, &pb, j)
    };
    let face_at = |f: &FaceRecord| f.nodes.map(at);
    for f in &faces {
        let (who, node) = if f.body == 0 { ("s", 2) } else { ("p", 1) };
        let d = distance_to_face(face_at(f), at(node));
        assert!(
            d > -1e-12,
            "{who} is {:.3e} m behind face {} after the push-back (1e-12)",
            -d,
            f.gid
        );
    }
    let mut sum = [0.0; 3];
    let mut largest = 0.0f64;
    for f in &pb.force {
        for k in 0..3 {
            sum[k] += f[k];
        }
        largest = largest.max(dot(*f, *f).sqrt());
    }
    assert!(
        dot(sum, sum).sqrt() <= 1e-12 * largest,
        "forces sum to {sum:?} (largest {largest:.3e}): momentum not conserved"
    );
}

fn record(gid: u64, body: u32, mass: f64, x0: V3, x1: V3) -> NodeRecord {
    common::node_record(gid, body, mass, x0, x1, DT)
}

/// The contact of a node that crossed the ridge between two faces of one body (each sloping
/// down by `s` away from the ridge at x = 0) and ends at x = `dx` from it, `eps` below; faces
/// (gid_a, on x < 0) and (gid_b, on x > 0).
fn ridge_contact(s: f64, dx: f64, eps: f64, gid_a: u64, gid_b: u64) -> contact::Contact {
    let corners = [
        [-1.0, 0.0, -s],
        [0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [-1.0, 1.0, -s],
        [1.0, 0.0, -s],
        [1.0, 1.0, -s],
    ];
    let faces = [(gid_a, [0, 1, 2, 3], 0), (gid_b, [1, 4, 5, 2], 0)];
    let b = node_and_faces(([dx, 0.5, eps], [dx, 0.5, -eps]), &corners, &[0; 6], &faces);
    let contacts = search(&b, &SearchParams::default());
    assert_eq!(contacts.len(), 1, "one contact: {contacts:?}");
    contacts[0]
}

#[test]
fn a_tie_between_two_faces_gives_their_mean_normal_whichever_face_wins() {
    // A node crosses the ridge between two faces of one body exactly at the ridge: both faces
    // are hit at the same depth, eps / sqrt(1 + s^2) along normals (-+s, 0, 1) / sqrt(1 + s^2)
    // (analytic). Reference: the symmetry of the set-up. The contact's normal is their mean,
    // (0, 0, 1), and its depth the motion along it out of both planes, eps (to 1e-12), the same
    // bits whichever face has the lower gid (which breaks ties of the order); moved 1e-12 m off
    // the ridge the normal moves by less than 1e-6 (continuous: a tie decided by round-off does
    // not tilt the normal by the faces' angle, 0.2 rad); 1e-3 m off it towards x > 0, the own
    // normal of the face whose plane it is further behind (x < 0: 2 s dx deeper, beyond the tie
    // band).
    let (s, eps) = (0.1, 0.01);
    let c = ridge_contact(s, 0.0, eps, 100, 101);
    let swapped = ridge_contact(s, 0.0, eps, 101, 100);
    assert!(
        (c.normal[2] - 1.0).abs() < 1e-12 && c.normal[0].abs() < 1e-12,
        "normal {:?} at the tie (analytic (0, 0, 1))",
        c.normal
    );
    assert!(
        (c.depth - eps).abs() < 1e-12,
        "depth {} (analytic {eps})",
        c.depth
    );
    assert_eq!(
        (c.normal.map(f64::to_bits), c.depth.to_bits()),
        (swapped.normal.map(f64::to_bits), swapped.depth.to_bits()),
        "the same contact whichever face wins the tie"
    );
    let near = ridge_contact(s, 1e-12, eps, 100, 101);
    let moved = (0..3)
        .map(|k| (near.normal[k] - c.normal[k]).abs())
        .fold(0.0, f64::max);
    assert!(
        moved < 1e-6,
        "1e-12 m off the ridge the normal moved {moved:e}"
    );
    let off = ridge_contact(s, 1e-3, eps, 100, 101);
    let k = 1.0 / (1.0 + s * s).sqrt();
    assert!(
        (off.normal[0] + s * k).abs() < 1e-12 && (off.normal[2] - k).abs() < 1e-12,
        "1e-3 m off the ridge: normal {:?}, the deeper x < 0 face's (-s, 0, 1) k expected",
        off.normal
    );
}
