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

/// A small deterministic generator (LCG, Knuth's constants): no rand crate.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
    }
}

/// The nodes of a 3 x 3 x 3 grid on [0, 2]^3, each moved by up to `amp` / 2 of the spacing
/// per component, and the 1-based id of grid point (i, j, k).
fn grid(seed: u64, amp: f64) -> (Vec<[f64; 3]>, impl Fn(usize, usize, usize) -> u64) {
    let mut rng = Lcg(seed);
    let mut x = Vec::new();
    for k in 0..3 {
        for j in 0..3 {
            for i in 0..3 {
                x.push([i, j, k].map(|c| c as f64 + amp * rng.next()));
            }
        }
    }
    (x, |i, j, k| (i + 3 * j + 9 * k + 1) as u64)
}

/// The 8 cubes of the grid by their corners: `corner(i, j, k)[b]` for `HEX_BITS[b]`.
fn cubes<F: Fn(usize, usize, usize) -> u64>(id: &F) -> Vec<[u64; 8]> {
    let mut out = Vec::new();
    for k in 0..2 {
        for j in 0..2 {
            for i in 0..2 {
                out.push(HEX_BITS.map(|b| id(i + b[0], j + b[1], k + b[2])));
            }
        }
    }
    out
}

/// A tetrahedron with its nodes ordered for a positive volume (two swapped if needed).
fn oriented(x: &[[f64; 3]], mut t: [u64; 4]) -> Vec<u64> {
    let p = |n: u64| x[n as usize - 1];
    let v = tet_volume(t.map(p));
    assert!(v.abs() > 1e-3, "the patch's tetrahedra are not flat: {v:e}");
    if v < 0.0 {
        t.swap(2, 3);
    }
    t.to_vec()
}

/// A linear velocity v = A x + c on the split mesh `m`: every sub-hexahedron's stress after
/// one step from zero is C : (D dt) of the constant D = sym(A) within 1e-10 relative
/// (fe_petsc/tests/element.rs's patch test; default hourglass control), with no hourglass
/// work, and the nodes inside the patch are in equilibrium (net force below 1e-10 of the largest nodal force).
fn patch_test(m: &Msh22) {
    use fe_petsc::hex::{self, HexControls, HexState};
    use fe_petsc::material::{build_material, MaterialSpec};
    let mat = build_material(&MaterialSpec {
        name: "steel".into(),
        model: "elastic".into(),
        density: 7850.0,
        params: [("youngs_modulus", 200e9), ("poisson_ratio", 0.3)]
            .iter()
            .map(|(k, v)| (k.to_string(), *v))
            .collect(),
        eos: None,
    })
    .unwrap();
    let (lambda, mu) = (200e9 * 0.3 / (1.3 * 0.4), 200e9 / 2.6);
    let a = [[0.3, -0.7, 0.2], [0.5, 0.1, -0.4], [-0.6, 0.9, 0.25]];
    let c0 = [0.1, -0.2, 0.3];
    let d = [
        a[0][0],
        a[1][1],
        a[2][2],
        0.5 * (a[0][1] + a[1][0]),
        0.5 * (a[1][2] + a[2][1]),
        0.5 * (a[2][0] + a[0][2]),
    ];
    let tr = d[0] + d[1] + d[2];
    let dt = 1e-7;
    let x = coords(m);
    let vel = |p: [f64; 3]| -> [f64; 3] {
        std::array::from_fn(|i| c0[i] + (0..3).map(|j| a[i][j] * p[j]).sum::<f64>())
    };
    // No bulk viscosity: its pressure scales with each element's size (not a constant stress).
    let ctl = HexControls {
        bv_linear: 0.0,
        bv_quadratic: 0.0,
        ..HexControls::default()
    };
    let mut nodal: FxHashMap<u64, [f64; 3]> = FxHashMap::default();
    let mut faces: FxHashMap<Vec<u64>, usize> = FxHashMap::default();
    let mut fscale = 0.0f64;
    for e in m.elements.iter().filter(|e| e.0 == HEX) {
        // x holds the mid-step geometry; the end of the step is x + dt/2 v.
        let ve: [[f64; 3]; 8] = std::array::from_fn(|k| vel(x[&e.3[k]]));
        let xe: [[f64; 3]; 8] =
            std::array::from_fn(|k| std::array::from_fn(|i| x[&e.3[k]][i] + 0.5 * dt * ve[k][i]));
        let mut st = HexState::default();
        let vol = hex::volume(&xe);
        let out = hex::update(&xe, &ve, dt, 7850.0, vol, &*mat, &ctl, &mut st, &mut []).unwrap();
        for k in 0..6 {
            let expect = if k < 3 {
                lambda * tr * dt + 2.0 * mu * d[k] * dt
            } else {
                2.0 * mu * d[k] * dt
            };
            assert!(
                (st.stress[k] - expect).abs() <= 1e-10 * expect.abs(),
                "patch test: stress[{k}] = {} vs analytic C:(D dt) = {expect} (1e-10 relative)",
                st.stress[k]
            );
        }
        assert!(
            out.hg_work.abs() < 1e-12,
            "no hourglass work under a linear field: {}",
            out.hg_work
        );
        for k in 0..8 {
            let f = nodal.entry(e.3[k]).or_default();
            for c in 0..3 {
                f[c] += out.force[k][c];
                fscale = fscale.max(out.force[k][c].abs());
            }
        }
        for f in [
            [0, 3, 2, 1],
            [4, 5, 6, 7],
            [0, 1, 5, 4],
            [1, 2, 6, 5],
            [2, 3, 7, 6],
            [3, 0, 4, 7],
        ] {
            let mut key: Vec<u64> = f.iter().map(|&k| e.3[k]).collect();
            key.sort_unstable();
            *faces.entry(key).or_default() += 1;
        }
    }
    // Nodes on a face of one element only are on the patch's boundary.
    let boundary: rustc_hash::FxHashSet<u64> = faces
        .iter()
        .filter(|(_, &n)| n == 1)
        .flat_map(|(k, _)| k.clone())
        .collect();
    let mut inside = 0;
    for (n, f) in &nodal {
        if !boundary.contains(n) {
            inside += 1;
            for c in 0..3 {
                assert!(
                    f[c].abs() < 1e-10 * fscale,
                    "constant stress is in equilibrium: node {n} net force {} vs {fscale:e} (1e-10)",
                    f[c]
                );
            }
        }
    }
    assert!(inside > 0, "the patch has inner nodes");
}

#[test]
fn patch_test_on_distorted_tetrahedra_split_into_hexahedra() {
    // Each cube into the 6 tetrahedra around its diagonal (0,0,0)-(1,1,1) (Kuhn's split: the
    // same diagonal in every cube conforms), every node moved by up to 5 % of the spacing.
    let (x, id) = grid(11, 0.1);
    let mut elements = Vec::new();
    for c in cubes(&id) {
        // Paths from bit (0,0,0) to (1,1,1) through one axis, then two.
        for (p, q) in [(1, 2), (1, 5), (3, 2), (3, 7), (4, 5), (4, 7)] {
            elements.push((TET, 1, 1, oriented(&x, [c[0], c[p], c[q], c[6]])));
        }
    }
    let (s, summary) = split(&mesh(&x, elements)).unwrap().unwrap();
    assert_eq!(summary.hexahedra_run, 8 * 6 * 4);
    check_split(&s, hexes(&s).iter().map(fe_petsc::hex::volume).sum(), true);
    patch_test(&s);
}

#[test]
fn patch_test_on_hexahedra_and_prisms_sharing_faces() {
    // Cubes with i = 0 are hexahedra, those with i = 1 two prisms each (their bottom quadrangle
    // cut along the diagonal (0,0)-(1,1), extruded along z): the quadrangles at x = 1 are
    // shared between a hexahedron and a prism's side, split into 4 on both.
    let (x, id) = grid(5, 0.1);
    let mut elements = Vec::new();
    let mut volume = 0.0;
    for (n, c) in cubes(&id).into_iter().enumerate() {
        let p = |k: usize| x[c[k] as usize - 1];
        if n % 2 == 0 {
            elements.push((HEX, 1, 1, c.to_vec()));
            volume += fe_petsc::hex::volume(&std::array::from_fn(p));
        } else {
            for w in [[0, 1, 2, 4, 5, 6], [0, 2, 3, 4, 6, 7]] {
                elements.push((PRISM, 1, 1, w.map(|k| c[k]).to_vec()));
                volume += prism_volume(w.map(p));
            }
        }
    }
    let (s, summary) = split(&mesh(&x, elements)).unwrap().unwrap();
    assert_eq!(summary.hexahedra_run, 4 * 8 + 8 * 6);
    check_split(&s, volume, false);
    patch_test(&s);
}
