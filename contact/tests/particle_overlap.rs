//! A particle whose sphere starts a step across a face's offset surface, its centre outside
//! the face (one born from an element that failed against a striker): the search measures the
//! pair with the distance the centre started at (the `pair` module's documentation, "A particle
//! that starts across the offset surface"), so the face cannot pass through it. References:
//! the geometry of a flat face (distances along its normal).

mod common;

use common::{node_record, V3};
use contact::{
    push_back, search, ContactBox, FaceRecord, PushBackParams, SearchParams, FLAG_PARTICLE,
};

const DT: f64 = 1e-3;
const R: f64 = 0.5;

/// A unit face at z = `z0` -> `z1` (normal +z, corners of mass `face_mass`, gids 10-13, body 0)
/// and a particle of radius `R` and mass 1 (gid 1) whose centre moves from z = `p0` to `p1`
/// over the face's centre.
fn particle_over_face(p: (f64, f64), face: (f64, f64), face_mass: f64) -> ContactBox {
    let mut particle = node_record(1, u32::MAX, 1.0, [0.0, 0.0, p.0], [0.0, 0.0, p.1], DT);
    particle.flags = FLAG_PARTICLE;
    particle.radius = R;
    let corners: [[f64; 2]; 4] = [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]];
    let mut nodes = vec![particle];
    for (k, c) in corners.iter().enumerate() {
        let (x0, x1): (V3, V3) = ([c[0], c[1], face.0], [c[0], c[1], face.1]);
        nodes.push(node_record(10 + k as u64, 0, face_mass, x0, x1, DT));
    }
    let faces = [FaceRecord {
        gid: 100,
        nodes: [10, 11, 12, 13],
        body: 0,
        reserved: 0,
    }];
    ContactBox::from_records(&nodes, 1, &faces).unwrap()
}

#[test]
fn a_particle_starting_across_the_offset_surface_is_held_at_its_start_distance() {
    // The centre starts 0.2 above the face, its sphere (radius 0.5) 0.3 across the offset
    // surface, far past the capture tolerance (1e-3 of the face's diameter); it moves 0.05
    // towards the fixed face: one contact, measured with the radius 0.2, depth 0.05, and the
    // push-back leaves the centre at 0.2 (to 1e-12).
    let b = particle_over_face((0.2, 0.15), (0.0, 0.0), f64::INFINITY);
    let contacts = search(&b, &SearchParams::default());
    assert_eq!(contacts.len(), 1, "{contacts:?}");
    let c = contacts[0];
    assert!((c.radius - 0.2).abs() < 1e-12, "radius {}", c.radius);
    assert!((c.depth - 0.05).abs() < 1e-12, "depth {}", c.depth);
    assert!((c.normal[2] - 1.0).abs() < 1e-12, "normal {:?}", c.normal);
    let pb = push_back(&b, &contacts, &PushBackParams::new(DT));
    let z = b.nodes.x1[0][2] + pb.position_correction(&b, 0, DT)[2];
    assert!((z - 0.2).abs() < 1e-12, "centre left at z = {z}");
    assert_eq!(pb.bounded, 0, "the depth is the step's own motion");

    // The face moving 0.05 into the particle at rest (equal masses of 1 at the corners and the
    // particle): the gap after the push-back is the 0.2 the particle started at.
    let b = particle_over_face((0.2, 0.2), (0.0, 0.05), 1.0);
    let contacts = search(&b, &SearchParams::default());
    assert_eq!(contacts.len(), 1, "{contacts:?}");
    assert!((contacts[0].depth - 0.05).abs() < 1e-12);
    let pb = push_back(&b, &contacts, &PushBackParams::new(DT));
    let zp = b.nodes.x1[0][2] + pb.position_correction(&b, 0, DT)[2];
    let zf = b.nodes.x1[1][2] + pb.position_correction(&b, 1, DT)[2];
    assert!((zp - zf - 0.2).abs() < 1e-12, "gap left {}", zp - zf);
}

#[test]
fn a_particle_across_the_offset_surface_moving_away_or_with_its_centre_behind_is_free() {
    // Moving away from the face: no contact (no crossing of the sphere it started with).
    let b = particle_over_face((0.2, 0.25), (0.0, 0.0), f64::INFINITY);
    assert!(search(&b, &SearchParams::default()).is_empty());
    // At rest: no contact either (the overlap it started with is kept).
    let b = particle_over_face((0.2, 0.2), (0.0, 0.0), f64::INFINITY);
    assert!(search(&b, &SearchParams::default()).is_empty());
    // Its centre started behind the face (the far side of a thin plate): not a contact.
    let b = particle_over_face((-0.01, -0.05), (0.0, 0.0), f64::INFINITY);
    assert!(search(&b, &SearchParams::default()).is_empty());
    // Outside the offset surface at the start: measured with its own radius, as always.
    let b = particle_over_face((0.55, 0.45), (0.0, 0.0), f64::INFINITY);
    let contacts = search(&b, &SearchParams::default());
    assert_eq!(contacts.len(), 1, "{contacts:?}");
    assert_eq!(contacts[0].radius, R);
    assert!((contacts[0].depth - 0.05).abs() < 1e-12);
}
