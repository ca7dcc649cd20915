//! Test 6: boundary faces and bodies of hexahedral meshes.
//!
//! References (counted by hand): an `n x n x n` block of unit hexes has `6 n^2` boundary faces
//! (24 for n = 2) and is one body; two blocks that share no node are two bodies; two blocks sharing
//! one corner node are one body. Every boundary face's normal points outward: away from the
//! centroid of the block and of its own element. Exact integer checks; normals checked by sign.

mod common;

use common::{cross, dot, sub, V3};
use contact::{bodies, face_key, surfaces, HEX_FACES};

/// An `n x n x n` block of unit hexes from `origin`; node ids from `first_id`, VTK order.
fn block(n: usize, origin: V3, first_id: u64) -> (Vec<[u64; 8]>, Vec<(u64, V3)>) {
    let id = |i: usize, j: usize, k: usize| first_id + ((k * (n + 1) + j) * (n + 1) + i) as u64;
    let mut coords = Vec::new();
    for k in 0..=n {
        for j in 0..=n {
            for i in 0..=n {
                coords.push((
                    id(i, j, k),
                    [
                        origin[0] + i as f64,
                        origin[1] + j as f64,
                        origin[2] + k as f64,
                    ],
                ));
            }
        }
    }
    let mut hexes = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                hexes.push([
                    id(i, j, k),
                    id(i + 1, j, k),
                    id(i + 1, j + 1, k),
                    id(i, j + 1, k),
                    id(i, j, k + 1),
                    id(i + 1, j, k + 1),
                    id(i + 1, j + 1, k + 1),
                    id(i, j + 1, k + 1),
                ]);
            }
        }
    }
    (hexes, coords)
}

fn centroid(pts: &[V3]) -> V3 {
    let mut c = [0.0; 3];
    for p in pts {
        for k in 0..3 {
            c[k] += p[k] / pts.len() as f64;
        }
    }
    c
}

#[test]
fn block_of_eight_hexes() {
    let (hexes, coords) = block(2, [0.0; 3], 1);
    let at: std::collections::HashMap<u64, V3> = coords.into_iter().collect();
    let s = surfaces(&hexes, |_| true);
    assert_eq!(s.faces.len(), 24);
    assert_eq!(s.n_bodies, 1);
    assert!(s.element_body.iter().all(|&b| b == 0));
    let block_centre = [1.0, 1.0, 1.0];
    let mut keys = std::collections::HashSet::new();
    for f in &s.faces {
        let x: Vec<V3> = f.nodes.iter().map(|n| at[n]).collect();
        // Normal of the bilinear face at its centre: (X_xi x X_eta) with X_xi ~ x1 + x2 - x0 - x3.
        let xi = sub(sub(x[1], x[0]), sub(x[3], x[2]));
        let eta = sub(sub(x[3], x[0]), sub(x[1], x[2]));
        let n = cross(xi, eta);
        let c = centroid(&x);
        assert!(
            dot(n, sub(c, block_centre)) > 0.0,
            "face {:?} points inward",
            f.nodes
        );
        let elem: Vec<V3> = hexes[f.element].iter().map(|n| at[n]).collect();
        assert!(dot(n, sub(c, centroid(&elem))) > 0.0);
        assert!(
            (dot(n, n).sqrt() - 4.0).abs() < 1e-12,
            "the centre normal from corner differences is 16 X_xi x X_eta: 4 times the face area"
        );
        assert!(keys.insert(face_key(f.nodes)), "face listed twice");
        assert_eq!(
            f.nodes,
            HEX_FACES[f.side as usize].map(|i| hexes[f.element][i])
        );
    }
    // Each of the 26 boundary nodes of the 3x3x3 node lattice, and only those.
    assert_eq!(s.nodes().len(), 26);
}

#[test]
fn separate_and_touching_blocks() {
    let (mut hexes, _) = block(2, [0.0; 3], 0);
    let (far, _) = block(1, [5.0, 0.0, 0.0], 1000);
    hexes.extend_from_slice(&far);
    let s = surfaces(&hexes, |_| true);
    assert_eq!(s.n_bodies, 2);
    assert_eq!(s.faces.len(), 24 + 6);
    assert!(s.faces[..24].iter().all(|f| f.body == 0));
    assert!(s.faces[24..].iter().all(|f| f.body == 1));
    // Selecting only the second block keeps its 6 faces, still labelled body 1.
    let only = surfaces(&hexes, |e| e >= 8);
    assert_eq!(only.faces.len(), 6);
    assert!(only.faces.iter().all(|f| f.body == 1));
    // A third block sharing one corner node with the first joins its body.
    let (mut touching, _) = block(1, [2.0, 2.0, 2.0], 2000);
    touching[0][0] = 26; // node (2, 2, 2) of the first block
    hexes.extend_from_slice(&touching);
    let (body, n) = bodies(&hexes);
    assert_eq!(n, 2);
    assert_eq!(body[9], 0);
}

/// Selecting elements does not change which faces are interior: a face between a selected and an
/// unselected element is interior.
#[test]
fn interior_faces_stay_interior_under_selection() {
    let (hexes, _) = block(2, [0.0; 3], 0);
    let s = surfaces(&hexes, |e| e == 0);
    assert_eq!(
        s.faces.len(),
        3,
        "the corner hex shows 3 faces on the block boundary"
    );
}

/// Tetrahedra as collapsed hexahedra (a, b, c, c, d, d, d, d): the unit cube split into the 6
/// tetrahedra around its diagonal (Kuhn) has 12 boundary triangles (2 per cube face, counted by
/// hand) and no interior face counted as boundary, although two neighbours repeat different
/// corners of the triangle they share; no point or edge "face"; each triangle's normal points
/// out of the cube.
#[test]
fn collapsed_tetrahedra_give_the_boundary_triangles() {
    // Cube corners by bits (x, y, z) -> id.
    let x = |id: u64| -> V3 {
        [
            (id & 1) as f64,
            ((id >> 1) & 1) as f64,
            ((id >> 2) & 1) as f64,
        ]
    };
    // Paths 0 -> 7 through one axis then two: (0, p, q, 7), oriented positive.
    let mut tets = Vec::new();
    for (p, q) in [(1, 3), (1, 5), (2, 3), (2, 6), (4, 5), (4, 6)] {
        let mut t = [0u64, p, q, 7];
        let v = dot(
            sub(x(t[1]), x(t[0])),
            cross(sub(x(t[2]), x(t[0])), sub(x(t[3]), x(t[0]))),
        );
        if v < 0.0 {
            t.swap(2, 3);
        }
        let [a, b, c, d] = t;
        tets.push([a, b, c, c, d, d, d, d]);
    }
    let s = surfaces(&tets, |_| true);
    assert_eq!(s.n_bodies, 1);
    assert_eq!(s.faces.len(), 12, "2 triangles per cube face");
    for f in &s.faces {
        let mut d = f.nodes.to_vec();
        d.sort_unstable();
        d.dedup();
        assert_eq!(d.len(), 3, "a triangle: {:?}", f.nodes);
        let key = face_key(f.nodes);
        assert_eq!(key[3], u64::MAX, "the key of its 3 distinct nodes: {key:?}");
        let p: Vec<V3> = d.iter().map(|&n| x(n)).collect();
        let n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
        // Outward: the face's corners in its own order give a normal away from the centre.
        let q: Vec<V3> = f.nodes.iter().map(|&n| x(n)).collect();
        let (a, b) = (sub(q[2], q[0]), sub(q[3], q[1]));
        let outward = cross(a, b);
        let centre = [0.5, 0.5, 0.5];
        let mid = [
            (p[0][0] + p[1][0] + p[2][0]) / 3.0,
            (p[0][1] + p[1][1] + p[2][1]) / 3.0,
            (p[0][2] + p[1][2] + p[2][2]) / 3.0,
        ];
        assert!(dot(n, n) > 0.0);
        assert!(
            dot(outward, sub(mid, centre)) > 0.0,
            "face {:?} points into the cube",
            f.nodes
        );
    }
}
