//! The split's geometry against what it must keep: volumes, orientation, planar faces, and a
//! conforming mesh (module comment of `split.rs`).
use super::*;
use crate::input::gmsh::PhysicalName;

type Elem = (i32, i32, i32, Vec<u64>);

fn mesh(nodes: &[[f64; 3]], elements: Vec<Elem>) -> Msh22 {
    Msh22 {
        names: vec![PhysicalName {
            dim: 3,
            tag: 1,
            name: "body".into(),
        }],
        nodes: nodes
            .iter()
            .enumerate()
            .map(|(i, x)| (i as u64 + 1, *x))
            .collect(),
        elements,
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn tet_volume(p: [[f64; 3]; 4]) -> f64 {
    dot(sub(p[1], p[0]), cross(sub(p[2], p[0]), sub(p[3], p[0]))) / 6.0
}

/// The prism's volume: the integral of det(dx/d(l1, l2, t)) over the reference prism, whose
/// integrand is linear in (l1, l2) (dx/dl_j does not depend on l) and quadratic in t: the
/// triangle's centroid rule (area 1/2) times 2-point Gauss in t is exact.
fn prism_volume(x: [[f64; 3]; 6]) -> f64 {
    let g = 0.5 / 3f64.sqrt();
    let mut v = 0.0;
    for t in [0.5 - g, 0.5 + g] {
        let l = [1.0 / 3.0; 3];
        let dl = |j: usize| -> [f64; 3] {
            std::array::from_fn(|c| (1.0 - t) * (x[j][c] - x[0][c]) + t * (x[j + 3][c] - x[3][c]))
        };
        let dt: [f64; 3] =
            std::array::from_fn(|c| (0..3).map(|i| l[i] * (x[i + 3][c] - x[i][c])).sum());
        v += 0.5 * 0.5 * dot(dl(1), cross(dl(2), dt));
    }
    v
}

fn coords(m: &Msh22) -> FxHashMap<u64, [f64; 3]> {
    m.nodes.iter().copied().collect()
}

fn hexes(m: &Msh22) -> Vec<[[f64; 3]; 8]> {
    let x = coords(m);
    m.elements
        .iter()
        .filter(|e| e.0 == HEX)
        .map(|e| std::array::from_fn(|k| x[&e.3[k]]))
        .collect()
}

/// Largest distance of a quadrangle's 4th point from the plane of its first 3, over its size.
fn non_planarity(q: [[f64; 3]; 4]) -> f64 {
    let n = cross(sub(q[1], q[0]), sub(q[3], q[0]));
    let size = dot(sub(q[2], q[0]), sub(q[2], q[0])).sqrt();
    dot(sub(q[2], q[0]), n).abs() / dot(n, n).sqrt() / size
}

/// Every hexahedron positive, its faces planar (to round-off) when `planar` (a split of
/// tetrahedra: a distorted hexahedron's or prism's own faces are not), no two nodes at the same
/// place (a conforming mesh), and the volumes add up to `volume`.
fn check_split(m: &Msh22, volume: f64, planar: bool) {
    let faces: [[usize; 4]; 6] = [
        [0, 3, 2, 1],
        [4, 5, 6, 7],
        [0, 1, 5, 4],
        [1, 2, 6, 5],
        [2, 3, 7, 6],
        [3, 0, 4, 7],
    ];
    let mut total = 0.0;
    for h in hexes(m) {
        let v = fe_petsc::hex::volume(&h);
        assert!(v > 0.0, "every sub-hexahedron positive, got {v:e}");
        total += v;
        for f in faces.iter().filter(|_| planar) {
            let q = f.map(|k| h[k]);
            assert!(
                non_planarity(q) < 1e-12,
                "faces are planar (module comment): {:e}",
                non_planarity(q)
            );
        }
    }
    assert!(
        (total - volume).abs() <= 1e-12 * volume,
        "volumes add up to the element's exactly (1e-12): {total:e} vs {volume:e}"
    );
    let mut seen: Vec<[u64; 3]> = m.nodes.iter().map(|(_, x)| x.map(f64::to_bits)).collect();
    let n = seen.len();
    seen.sort_unstable();
    seen.dedup();
    assert_eq!(seen.len(), n, "no two nodes at the same place (conforming)");
}

const TETS: [[f64; 3]; 5] = [
    [0.0, 0.0, 0.0],
    [1.1, 0.1, -0.05],
    [0.2, 0.9, 0.1],
    [0.15, 0.2, 1.3],
    [0.9, 0.8, 0.9],
];

#[test]
fn two_distorted_tetrahedra_split_exactly_and_conform() {
    // Two tetrahedra sharing the face (2, 3, 4) (1-based), with a triangle on an outer face
    // and a line on an outer edge.
    let m = mesh(
        &TETS,
        vec![
            (TRIANGLE, 2, 1, vec![1, 3, 2]),
            (LINE, 0, 1, vec![1, 2]),
            (POINT, 0, 1, vec![1]),
            (TET, 1, 1, vec![1, 2, 3, 4]),
            (TET, 1, 1, vec![2, 5, 3, 4]),
        ],
    );
    let p = |k: usize| TETS[k];
    let volume = tet_volume([p(0), p(1), p(2), p(3)]) + tet_volume([p(1), p(4), p(2), p(3)]);
    let (s, summary) = split(&m).unwrap().unwrap();
    assert_eq!(
        summary,
        SplitSummary {
            tetrahedra: 2,
            prisms: 0,
            hexahedra: 0,
            hexahedra_run: 8
        }
    );
    assert_eq!(
        summary.describe(),
        "2 tetrahedra run as 8 hexahedra (4 per tetrahedron)"
    );
    check_split(&s, volume, true);
    // 5 corners + 9 edges + 7 faces + 2 cells.
    assert_eq!(
        s.nodes.len(),
        5 + 9 + 7 + 2,
        "shared edges and faces made once"
    );
    // The triangle: 3 quadrangles in its plane, with its normal, covering its area.
    let x = coords(&s);
    let tri = [p(0), p(2), p(1)];
    let normal = cross(sub(tri[1], tri[0]), sub(tri[2], tri[0]));
    let quads: Vec<&Elem> = s.elements.iter().filter(|e| e.0 == QUAD).collect();
    assert_eq!(quads.len(), 3);
    let mut area = 0.0;
    for q in quads {
        assert_eq!((q.1, q.2), (2, 1), "physical and elementary tags kept");
        let c: [[f64; 3]; 4] = std::array::from_fn(|k| x[&q.3[k]]);
        for pt in c {
            let off = dot(sub(pt, tri[0]), normal) / dot(normal, normal).sqrt();
            assert!(
                off.abs() < 1e-15,
                "quadrangle in the triangle's plane: {off:e}"
            );
        }
        let qn = cross(sub(c[2], c[0]), sub(c[3], c[1]));
        assert!(dot(qn, normal) > 0.0, "same orientation as the triangle");
        area += 0.5 * dot(qn, qn).sqrt();
    }
    let tri_area = 0.5 * dot(normal, normal).sqrt();
    assert!(
        (area - tri_area).abs() < 1e-12 * tri_area,
        "quadrangles cover the triangle"
    );
    let lines: Vec<&Elem> = s.elements.iter().filter(|e| e.0 == LINE).collect();
    assert_eq!(lines.len(), 2, "the line split at its midpoint");
    assert_eq!(s.elements.iter().filter(|e| e.0 == POINT).count(), 1);
}

#[test]
fn a_prism_and_a_hexahedron_split_exactly_and_conform() {
    // A distorted hexahedron (1..8) and a prism on its face x = 1 (2, 3, 7, 6), sharing it.
    let x = [
        [0.0, 0.0, 0.0],
        [1.0, 0.05, 0.0],
        [1.1, 1.0, 0.1],
        [0.0, 0.9, 0.0],
        [0.1, 0.0, 1.0],
        [1.0, 0.1, 1.2],
        [1.05, 1.1, 1.0],
        [-0.1, 1.0, 1.1],
        [1.9, 0.5, 0.05],
        [1.8, 0.6, 1.1],
    ];
    // Prism: bottom triangle (2, 9, 3), top (6, 10, 7): sides (2, 9, 10, 6), (9, 3, 7, 10) and
    // the shared quadrangle (3, 2, 6, 7).
    let m = mesh(
        &x,
        vec![
            (QUAD, 2, 3, vec![1, 4, 3, 2]),
            (TRIANGLE, 2, 3, vec![2, 3, 9]),
            (HEX, 1, 1, vec![1, 2, 3, 4, 5, 6, 7, 8]),
            (PRISM, 1, 2, vec![2, 9, 3, 6, 10, 7]),
        ],
    );
    let hex: [[f64; 3]; 8] = std::array::from_fn(|k| x[k]);
    let prism = [x[1], x[8], x[2], x[5], x[9], x[6]];
    let volume = fe_petsc::hex::volume(&hex) + prism_volume(prism);
    assert!(prism_volume(prism) > 0.0);
    let (s, summary) = split(&m).unwrap().unwrap();
    assert_eq!(summary.hexahedra_run, 8 + 6);
    assert_eq!(
        summary.describe(),
        "1 prisms and 1 hexahedra run as 14 hexahedra (6 per prism, 8 per hexahedron)"
    );
    check_split(&s, volume, false);
    assert_eq!(s.elements.iter().filter(|e| e.0 == QUAD).count(), 4 + 3);
}

#[test]
fn hexahedra_beside_tetrahedra_stay_and_hexahedral_meshes_are_not_split() {
    let x = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
        [2.0, 0.0, 0.0],
        [1.0, -1.0, 0.0],
    ];
    let hex = (HEX, 1, 1, vec![1, 2, 3, 4, 5, 6, 7, 8]);
    assert!(split(&mesh(&x, vec![hex.clone()])).unwrap().is_none());
    // A tetrahedron touching the hexahedron along its edge (2, 6).
    let (s, summary) = split(&mesh(&x, vec![hex.clone(), (TET, 1, 1, vec![2, 9, 10, 6])]))
        .unwrap()
        .unwrap();
    assert_eq!(summary.hexahedra_run, 1 + 4);
    assert_eq!(s.elements[0], hex, "the hexahedron as it was");
}

#[test]
fn pyramids_and_second_order_elements_are_refused_in_one_line() {
    let x = [[0.0; 3]; 10];
    let e = split(&mesh(&x, vec![(PYRAMID, 1, 1, vec![1, 2, 3, 4, 5])]))
        .err()
        .unwrap();
    assert!(
        e.contains("1 pyramids") && e.contains("Mesh.SubdivisionAlgorithm = 2"),
        "{e}"
    );
    let e = split(&mesh(&x, vec![(11, 1, 1, (1..=10).collect())]))
        .err()
        .unwrap();
    assert!(
        e.contains("1 second-order") && e.contains("Mesh.ElementOrder = 1"),
        "{e}"
    );
    assert!(!e.contains('\n'));
}

#[test]
fn counts_are_grouped_by_thousands() {
    assert_eq!(grouped(10845), "10,845");
    assert_eq!(grouped(43380), "43,380");
    assert_eq!(grouped(999), "999");
    assert_eq!(grouped(1_000_000), "1,000,000");
}
