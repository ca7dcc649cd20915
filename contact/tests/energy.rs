//! Kinematic push-back never gives energy back (`contact::pushback`, "Only the step's own
//! penetration"): the kinetic energy of the corrected velocities never exceeds that of the
//! predicted ones.
//!
//! References: the conservation law itself (an inelastic constraint can only remove kinetic
//! energy: `dK <= 0`, to 1e-12 of the kinetic energy of the nodes involved), and the exact
//! impulse of a lone contact against an immovable face, `lambda = m min(d, 2 c)` for depth `d`
//! and the step's approach `c` (a node that started outside, `d <= c`, stops on the face; one
//! that started inside keeps what it had and reverses at most its approach).

mod common;

use common::{crowded_box, dot, Rng, V3};
use contact::{push_back, search, ContactBox, FaceRecord, NodeRecord, PushBackParams};

const DT: f64 = 1e-6;
/// `dK <= ENERGY_TOL * K` (round-off of the sums).
const ENERGY_TOL: f64 = 1e-12;

/// A node (gid 1, body 0, 1 kg) moving from `z0` to `z1` over a unit face in z = 0 (normal +z,
/// body 1) whose corners have mass `corner_mass` (infinite: a held wall) and move by `dz` in z.
fn node_over_face(z0: f64, z1: f64, corner_mass: f64, dz: f64) -> ContactBox {
    let mut nodes = vec![record(1, 0, 1.0, [0.1, 0.2, z0], [0.1, 0.2, z1])];
    let c = [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]];
    for (k, xy) in c.iter().enumerate() {
        let x0 = [xy[0], xy[1], 0.0];
        let x1 = [xy[0], xy[1], dz];
        nodes.push(record(10 + k as u64, 1, corner_mass, x0, x1));
    }
    let faces = [FaceRecord {
        gid: 100,
        nodes: [10, 11, 12, 13],
        body: 1,
        reserved: 0,
    }];
    ContactBox::from_records(&nodes, 1, &faces).unwrap()
}

/// The kinetic energy of the predicted velocities of `b`'s movable nodes, J.
fn kinetic(b: &ContactBox) -> f64 {
    (0..b.nodes.len())
        .filter(|&j| b.nodes.mass[j].is_finite())
        .map(|j| 0.5 * b.nodes.mass[j] * dot(b.nodes.v[j], b.nodes.v[j]))
        .sum()
}

#[test]
fn a_node_that_started_inside_and_moves_away_takes_no_impulse() {
    // The step of `container_crush` (np 2, four lanes) that put 1.5 times the initial energy
    // into the motion, in miniature: the node starts 0.5 mm behind the face (inside the
    // capture tolerance, 1e-3 of the face's 1.41 m diameter), moving away from it by 0.1 mm
    // over the step. Closing its depth would push it out at 0.4 mm / 1 us = 400 m/s.
    let b = node_over_face(-5e-4, -4e-4, f64::INFINITY, 0.0);
    let contacts = search(&b, &Default::default());
    assert_eq!(contacts.len(), 1, "the search still sees it: {contacts:?}");
    let pb = push_back(&b, &contacts, &PushBackParams::new(DT));
    assert_eq!(pb.force[0], [0.0; 3], "no impulse on a separating node");
    assert_eq!(pb.bounded, 1, "the contact's depth was bounded");
    assert!(pb.kinetic_energy_change <= 0.0);
}

#[test]
fn a_node_that_started_inside_closes_at_most_twice_its_approach() {
    // Starts 0.5 mm behind the held face, approaches by c = 0.1 mm: depth 0.6 mm, closed
    // 2c = 0.2 mm (an elastic reversal of its approach), kinetic energy unchanged to
    // round-off, never more.
    let (p0, c) = (5e-4, 1e-4);
    let b = node_over_face(-p0, -p0 - c, f64::INFINITY, 0.0);
    let contacts = search(&b, &Default::default());
    let pb = push_back(&b, &contacts, &PushBackParams::new(DT));
    let lambda = pb.force[0][2] * DT * DT;
    assert!(
        (lambda - 2.0 * c).abs() <= 1e-12 * c,
        "impulse {lambda} kg m, expected m 2c = {}",
        2.0 * c
    );
    let k = kinetic(&b);
    assert!(
        pb.kinetic_energy_change <= ENERGY_TOL * k,
        "dK = {} of K = {k}",
        pb.kinetic_energy_change
    );
    // A node that started outside (1 um above) and ends 0.1 mm behind stops on the face.
    let b = node_over_face(1e-6, -1e-4, f64::INFINITY, 0.0);
    let contacts = search(&b, &Default::default());
    let pb = push_back(&b, &contacts, &PushBackParams::new(DT));
    let lambda = pb.force[0][2] * DT * DT;
    assert!(
        (lambda - 1e-4).abs() <= 1e-12,
        "impulse {lambda}: the depth"
    );
    assert_eq!(pb.bounded, 0);
}

#[test]
fn a_face_moving_onto_a_node_that_started_inside_it_pushes_it_by_the_approach() {
    // The face (free corners, 1 kg each) moves up 0.1 mm onto a node at rest that started
    // 0.5 mm behind it: the approach is the face's motion; momentum is conserved and the
    // kinetic energy does not grow.
    let b = node_over_face(-5e-4, -5e-4, 1.0, 1e-4);
    let contacts = search(&b, &Default::default());
    assert_eq!(contacts.len(), 1);
    let pb = push_back(&b, &contacts, &PushBackParams::new(DT));
    let total: f64 = pb.force.iter().map(|f| f[2]).sum();
    let scale: f64 = pb.force.iter().map(|f| f[2].abs()).sum();
    assert!(total.abs() <= 1e-14 * scale, "momentum: {total} of {scale}");
    assert!(pb.force[0][2] > 0.0, "the face pushes the node up");
    let k = kinetic(&b);
    assert!(
        pb.kinetic_energy_change <= ENERGY_TOL * k,
        "dK = {} of K = {k}",
        pb.kinetic_energy_change
    );
}

#[test]
fn push_back_never_adds_kinetic_energy_on_random_crowded_boxes() {
    // Random bodies, faces and crossing nodes (particles included, self-contact on), many
    // nodes starting inside faces within the capture tolerance and faces sharing nodes:
    // `dK <= 1e-9 K` on every box, K the predicted kinetic energy of the box's nodes
    // (the geometric passes re-linearise, so the linear bound holds to their remainder).
    let mut rng = Rng(2027);
    let mut bounded = 0;
    for _ in 0..6 {
        let (b, contacts) = crowded_box(&mut rng, 60, 40, 500);
        // The random scene's velocities are its motions over a unit step.
        let pb = push_back(&b, &contacts, &PushBackParams::new(1.0));
        let k = kinetic(&b);
        assert!(
            pb.kinetic_energy_change <= 1e-9 * k,
            "dK = {:.3e} J against K = {k:.3e} J ({} contacts)",
            pb.kinetic_energy_change,
            contacts.len()
        );
        bounded += pb.bounded;
    }
    println!("{bounded} contacts bounded by the step's own penetration");
}

fn record(gid: u64, body: u32, mass: f64, x0: V3, x1: V3) -> NodeRecord {
    common::node_record(gid, body, mass, x0, x1, DT)
}
