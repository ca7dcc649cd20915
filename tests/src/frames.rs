//! Geometry of a run's frames for the contact tests: read the node positions and connectivity
//! of fields.h5, the skin (boundary faces) of a set of elements, and how deep a node lies inside
//! a body (an independent check of the contact stage: its own projection onto bilinear faces).
/// The frames of a run's fields.h5: (time, node positions by node id), and the connectivity
/// (node ids of each element, by element id) of the first frame.
pub struct Frames {
    pub times: Vec<f64>,
    pub positions: Vec<Vec<[f64; 3]>>,
    pub connectivity: Vec<[usize; 8]>,
}

/// The last frame's group of a run's fields.h5 (`/frames/NNNNNN`, the largest number).
pub fn last_frame(out: &std::path::Path) -> hdf5::Group {
    let f = hdf5::File::open(out.join("fields.h5")).unwrap();
    let mut names = f.group("frames").unwrap().member_names().unwrap();
    names.sort();
    f.group(&format!("frames/{}", names.last().unwrap()))
        .unwrap()
}

pub fn read_frames(out: &std::path::Path) -> Frames {
    let f = hdf5::File::open(out.join("fields.h5")).unwrap();
    let mut names = f.group("frames").unwrap().member_names().unwrap();
    names.sort();
    let mut fr = Frames {
        times: Vec::new(),
        positions: Vec::new(),
        connectivity: Vec::new(),
    };
    for (k, name) in names.iter().enumerate() {
        let g = f.group(&format!("frames/{name}")).unwrap();
        let t: f64 = g.attr("time").unwrap().read_scalar().unwrap();
        let pos: Vec<f64> = g.dataset("nodes/position").unwrap().read_raw().unwrap();
        fr.times.push(t);
        fr.positions
            .push(pos.chunks(3).map(|c| [c[0], c[1], c[2]]).collect());
        if k == 0 {
            let conn: Vec<u64> = g
                .dataset("elements/connectivity")
                .unwrap()
                .read_raw()
                .unwrap();
            fr.connectivity = conn
                .chunks(8)
                .map(|c| std::array::from_fn(|i| c[i] as usize))
                .collect();
        }
    }
    fr
}

/// The six faces of a hexahedron in VTK (= gmsh) node order, each counter-clockwise seen from
/// outside, so `(x2 - x0) x (x3 - x1)` points outward.
pub const FACES: [[usize; 4]; 6] = [
    [0, 3, 2, 1],
    [4, 5, 6, 7],
    [0, 1, 5, 4],
    [1, 2, 6, 5],
    [2, 3, 7, 6],
    [3, 0, 4, 7],
];

pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The point of the bilinear face with corners `q` (counter-clockwise seen from outside)
/// closest to `p`, with parametric coordinates kept within `bound`, and the unit outward normal
/// there. The surface is `X = sum N_i(xi) q_i`, `N_i = (1 +- xi)(1 +- eta)/4`; Newton's method on
/// `|p - X|^2` from the centre (the faces here are nearly flat, so it converges in a few
/// iterations); `X_xi x X_eta` points outward for that corner order.
pub fn project(p: [f64; 3], q: &[[f64; 3]; 4], bound: f64) -> ([f64; 3], [f64; 3]) {
    // X = a + b xi + c eta + d xi eta.
    let a: [f64; 3] = std::array::from_fn(|k| 0.25 * (q[0][k] + q[1][k] + q[2][k] + q[3][k]));
    let b: [f64; 3] = std::array::from_fn(|k| 0.25 * (-q[0][k] + q[1][k] + q[2][k] - q[3][k]));
    let c: [f64; 3] = std::array::from_fn(|k| 0.25 * (-q[0][k] - q[1][k] + q[2][k] + q[3][k]));
    let d: [f64; 3] = std::array::from_fn(|k| 0.25 * (q[0][k] - q[1][k] + q[2][k] - q[3][k]));
    let point = |xi: f64, eta: f64| -> [f64; 3] {
        std::array::from_fn(|k| a[k] + b[k] * xi + c[k] * eta + d[k] * xi * eta)
    };
    let (mut xi, mut eta) = (0.0f64, 0.0f64);
    for _ in 0..NEWTON_ITERATIONS {
        let r = sub(p, point(xi, eta));
        let tx: [f64; 3] = std::array::from_fn(|k| b[k] + d[k] * eta);
        let te: [f64; 3] = std::array::from_fn(|k| c[k] + d[k] * xi);
        let g = [dot(r, tx), dot(r, te)];
        let h01 = dot(tx, te) - dot(r, d);
        let (h00, h11) = (dot(tx, tx), dot(te, te));
        let det = h00 * h11 - h01 * h01;
        xi = (xi + (h11 * g[0] - h01 * g[1]) / det).clamp(-bound, bound);
        eta = (eta + (h00 * g[1] - h01 * g[0]) / det).clamp(-bound, bound);
    }
    let tx: [f64; 3] = std::array::from_fn(|k| b[k] + d[k] * eta);
    let te: [f64; 3] = std::array::from_fn(|k| c[k] + d[k] * xi);
    let n = cross(tx, te);
    let len = dot(n, n).sqrt();
    (point(xi, eta), [n[0] / len, n[1] / len, n[2] / len])
}

/// Newton iterations of [`project`] (quadratic convergence from the centre of a nearly flat
/// face: 8 are far more than round-off needs).
pub const NEWTON_ITERATIONS: usize = 8;
/// Parametric bound of the projections that decide "inside an element": beyond the face, so a
/// point near an edge is judged against the face's own surface continued a little.
pub const INSIDE_BOUND: f64 = 2.0;

/// How deep point `p` lies inside the (deformed) hexahedron with corners `x`: the smallest
/// distance behind its six bilinear faces. Negative: `p` is outside at least one face.
///
/// A point farther from the corners' mean than every corner is outside: the trilinear element
/// is a convex combination of its corners (weights >= 0 summing to 1), so it lies in their
/// convex hull, inside that ball. The screen is exact and keeps the faces' continuation (to
/// `INSIDE_BOUND`) from judging points beyond it: the bilinear map of a planar face far from
/// a parallelogram (the kites of a split tetrahedron: a corner, two edge midpoints, a face
/// centroid) folds over outside its square, where the projection's normal can point either way.
pub fn depth_inside(p: [f64; 3], x: &[[f64; 3]; 8]) -> f64 {
    if is_collapsed_tet(x) {
        return depth_inside_tet(p, [x[0], x[1], x[2], x[4]]);
    }
    let mean = x.iter().fold([0.0; 3], |m, c| {
        [m[0] + c[0] / 8.0, m[1] + c[1] / 8.0, m[2] + c[2] / 8.0]
    });
    let reach = x
        .iter()
        .map(|c| dot(sub(*c, mean), sub(*c, mean)))
        .fold(0.0, f64::max);
    let d2 = dot(sub(p, mean), sub(p, mean));
    if d2 > reach {
        return -(d2.sqrt() - reach.sqrt());
    }
    let mut depth = f64::INFINITY;
    for f in &FACES {
        let q = [x[f[0]], x[f[1]], x[f[2]], x[f[3]]];
        let (c, n) = project(p, &q, INSIDE_BOUND);
        depth = depth.min(dot(sub(c, p), n));
        if depth < 0.0 {
            return depth;
        }
    }
    depth
}

/// The boundary faces of a set of hexahedra (faces used by exactly one of them), as node ids
/// counter-clockwise seen from outside.
pub fn boundary_faces(conn: &[[usize; 8]], elems: &[usize]) -> Vec<[usize; 4]> {
    let mut uses: std::collections::HashMap<[usize; 4], ([usize; 4], u32)> =
        std::collections::HashMap::new();
    for &e in elems {
        for f in &FACES {
            let nodes = f.map(|i| conn[e][i]);
            // Matched by their distinct nodes: a native tetrahedron comes as the collapsed
            // hexahedron (a, b, c, c, d, d, d, d), its triangles with a repeated corner (not
            // the same in two neighbours), its point and edge "faces" no faces.
            let mut key = nodes;
            key.sort_unstable();
            let mut distinct = key.to_vec();
            distinct.dedup();
            if distinct.len() < 3 {
                continue;
            }
            distinct.resize(4, usize::MAX);
            key.copy_from_slice(&distinct);
            uses.entry(key).or_insert((nodes, 0)).1 += 1;
        }
    }
    let mut out: Vec<[usize; 4]> = uses
        .into_values()
        .filter(|(_, c)| *c == 1)
        .map(|(f, _)| f)
        .collect();
    out.sort_unstable();
    out
}

/// A body the check looks into: its elements and its boundary faces.
pub struct Body {
    pub elems: Vec<usize>,
    pub skin: Vec<[usize; 4]>,
}

impl Body {
    pub fn new(conn: &[[usize; 8]], elems: Vec<usize>) -> Body {
        let skin = boundary_faces(conn, &elems);
        Body { elems, skin }
    }
}

/// The deepest penetration of any of `nodes` into `body` in configuration `pos`: a node is in
/// the body when it lies inside one of its elements that it is not a corner of, and it is then
/// as deep as its distance to the nearest face of the body's skin that it is not a corner of.
/// Returns (depth, node), depth 0 when no node is inside. Elements are screened by bounding
/// boxes.
pub fn deepest_penetration(
    pos: &[[f64; 3]],
    conn: &[[usize; 8]],
    nodes: &[usize],
    body: &Body,
) -> (f64, usize) {
    let points: Vec<(usize, [f64; 3])> = nodes.iter().map(|&n| (n, pos[n])).collect();
    deepest_point_inside(pos, conn, &points, body)
}

/// [`deepest_penetration`] for any points `(label, point)`: a point is in the body when it lies
/// inside one of its elements that it is not a corner of (a label equal to a corner's node id
/// is that node), and is then as deep as its distance to the nearest face of the body's skin
/// it is not a corner of. Returns (depth, label), depth 0 when none is inside.
pub fn deepest_point_inside(
    pos: &[[f64; 3]],
    conn: &[[usize; 8]],
    points: &[(usize, [f64; 3])],
    body: &Body,
) -> (f64, usize) {
    let boxes: Vec<([f64; 3], [f64; 3])> = body
        .elems
        .iter()
        .map(|&e| {
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            for &n in &conn[e] {
                for k in 0..3 {
                    lo[k] = lo[k].min(pos[n][k]);
                    hi[k] = hi[k].max(pos[n][k]);
                }
            }
            (lo, hi)
        })
        .collect();
    let mut worst = (0.0, usize::MAX);
    for &(n, p) in points {
        let inside = boxes.iter().zip(&body.elems).any(|(b, &e)| {
            (0..3).all(|k| p[k] >= b.0[k] && p[k] <= b.1[k])
                && !conn[e].contains(&n)
                && depth_inside(p, &std::array::from_fn(|i| pos[conn[e][i]])) > 0.0
        });
        if !inside {
            continue;
        }
        let depth = body
            .skin
            .iter()
            .filter(|f| !f.contains(&n))
            .map(|f| {
                let c = closest_on_face(p, &f.map(|i| pos[i]));
                dot(sub(p, c), sub(p, c)).sqrt()
            })
            .fold(f64::INFINITY, f64::min);
        if depth > worst.0 {
            worst = (depth, n);
        }
    }
    worst
}

/// Largest distance any node moved between two consecutive frames: a node cannot have crossed
/// a layer thicker than this without a frame showing it inside.
pub fn max_frame_motion(fr: &Frames) -> f64 {
    let mut m = 0.0f64;
    for w in fr.positions.windows(2) {
        for (a, b) in w[0].iter().zip(&w[1]) {
            m = m.max(dot(sub(*b, *a), sub(*b, *a)).sqrt());
        }
    }
    m
}

/// Largest |a - b| over two histories, over the largest |value| of the first, per column.
pub fn column_differences(a: &[Vec<f64>], b: &[Vec<f64>]) -> Vec<f64> {
    let ncol = a[0].len();
    (0..ncol)
        .map(|c| {
            let scale = a.iter().fold(0.0f64, |m, r| m.max(r[c].abs()));
            let d = a
                .iter()
                .zip(b)
                .fold(0.0f64, |m, (x, y)| m.max((x[c] - y[c]).abs()));
            if scale > 0.0 {
                d / scale
            } else {
                d
            }
        })
        .collect()
}

/// The bodies of a mesh: its elements grouped into connected sets (elements sharing a node),
/// numbered by their lowest element id, each with its skin.
pub fn bodies(conn: &[[usize; 8]]) -> Vec<Body> {
    let n_nodes = conn.iter().flatten().max().map_or(0, |m| m + 1);
    // Union-find over nodes, joined through each element.
    let mut parent: Vec<usize> = (0..n_nodes).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    for e in conn {
        for w in e.windows(2) {
            let (a, b) = (find(&mut parent, w[0]), find(&mut parent, w[1]));
            parent[a.max(b)] = a.min(b);
        }
    }
    let mut index: std::collections::HashMap<usize, usize> = std::collections::HashMap::new();
    let mut elems: Vec<Vec<usize>> = Vec::new();
    for (e, c) in conn.iter().enumerate() {
        let root = find(&mut parent, c[0]);
        let k = *index.entry(root).or_insert_with(|| {
            elems.push(Vec::new());
            elems.len() - 1
        });
        elems[k].push(e);
    }
    elems.into_iter().map(|es| Body::new(conn, es)).collect()
}

/// The deepest penetration of any skin node of one body into another body of the mesh, in
/// configuration `pos` (see [`deepest_penetration`]): (depth, node), over every ordered pair of
/// distinct bodies.
/// The deepest node of any body inside another over all frames: (depth m, the frame's time s,
/// the node), from [`deepest_between_bodies`] frame by frame (the first frame of the largest
/// depth; depth 0 and node `usize::MAX` when none is inside).
pub fn deepest_over_frames(fr: &Frames, bodies: &[Body]) -> (f64, f64, usize) {
    let mut deepest = (0.0f64, 0.0f64, usize::MAX);
    for (k, pos) in fr.positions.iter().enumerate() {
        let (d, n) = deepest_between_bodies(pos, &fr.connectivity, bodies);
        if d > deepest.0 {
            deepest = (d, fr.times[k], n);
        }
    }
    deepest
}

pub fn deepest_between_bodies(
    pos: &[[f64; 3]],
    conn: &[[usize; 8]],
    bodies: &[Body],
) -> (f64, usize) {
    let mut worst = (0.0, usize::MAX);
    for (a, ba) in bodies.iter().enumerate() {
        let mut nodes: Vec<usize> = ba.skin.iter().flatten().cloned().collect();
        nodes.sort_unstable();
        nodes.dedup();
        for (b, bb) in bodies.iter().enumerate() {
            if a != b {
                let d = deepest_penetration(pos, conn, &nodes, bb);
                if d.0 > worst.0 {
                    worst = d;
                }
            }
        }
    }
    worst
}

/// Whether the corners `x` are a tetrahedron written as the collapsed hexahedron (a, b, c, c,
/// d, d, d, d) (fields.h5's form of a native tetrahedron).
pub fn is_collapsed_tet(x: &[[f64; 3]; 8]) -> bool {
    x[3] == x[2] && x[5] == x[4] && x[6] == x[4] && x[7] == x[4] && x[4] != x[2]
}

/// How deep `p` lies inside the tetrahedron `t` (gmsh order, positive volume): the smallest
/// distance behind its 4 planar faces (negative outside one).
pub fn depth_inside_tet(p: [f64; 3], t: [[f64; 3]; 4]) -> f64 {
    // Each face (i, j, k) with the fourth corner l behind it: the inward normal points to l.
    [(1, 2, 3, 0), (0, 2, 3, 1), (0, 1, 3, 2), (0, 1, 2, 3)]
        .iter()
        .map(|&(i, j, k, l)| {
            let n = cross(sub(t[j], t[i]), sub(t[k], t[i]));
            let len = dot(n, n).sqrt();
            let s = if dot(sub(t[l], t[i]), n) > 0.0 {
                1.0
            } else {
                -1.0
            };
            s * dot(sub(p, t[i]), n) / len
        })
        .fold(f64::INFINITY, f64::min)
}

/// The point of the triangle `t` closest to `p` (by the region of the triangle's plane `p`
/// projects into: a vertex, an edge or the inside; C. Ericson, Real-Time Collision Detection,
/// 2005, section 5.1.5).
pub fn closest_on_triangle(p: [f64; 3], t: [[f64; 3]; 3]) -> [f64; 3] {
    let (a, b, c) = (t[0], t[1], t[2]);
    let (ab, ac, ap) = (sub(b, a), sub(c, a), sub(p, a));
    let at = |u: f64, v: f64| -> [f64; 3] { std::array::from_fn(|k| a[k] + u * ab[k] + v * ac[k]) };
    let (d1, d2) = (dot(ab, ap), dot(ac, ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = sub(p, b);
    let (d3, d4) = (dot(ab, bp), dot(ac, bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return at(d1 / (d1 - d3), 0.0);
    }
    let cp = sub(p, c);
    let (d5, d6) = (dot(ab, cp), dot(ac, cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return at(0.0, d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return std::array::from_fn(|k| b[k] + w * (c[k] - b[k]));
    }
    let denom = 1.0 / (va + vb + vc);
    at(vb * denom, vc * denom)
}

/// The point of a skin face `q` (a quadrangle, or a triangle with a repeated corner) closest
/// to `p`.
pub fn closest_on_face(p: [f64; 3], q: &[[f64; 3]; 4]) -> [f64; 3] {
    let mut tri = Vec::with_capacity(4);
    for c in q {
        if !tri.contains(c) {
            tri.push(*c);
        }
    }
    if tri.len() == 3 {
        closest_on_triangle(p, [tri[0], tri[1], tri[2]])
    } else {
        project(p, q, 1.0).0
    }
}
