//! Test helpers: a seeded generator, random contact configurations, and a reference node-face
//! crossing test written independently of the crate (monomial form of the bilinear face, a grid
//! search then Newton for the projection, all pairs without any bucket search).
#![allow(dead_code)]

use contact::{FaceRecord, NodeRecord, FLAG_PARTICLE};

pub type V3 = [f64; 3];

/// SplitMix64: small, seeded, reproducible.
pub struct Rng(pub u64);

impl Rng {
    pub fn u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn f(&mut self) -> f64 {
        (self.u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.f()
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.u64() % n as u64) as usize
    }
    pub fn unit(&mut self) -> V3 {
        loop {
            let v = [
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            ];
            let n = dot(v, v).sqrt();
            if n > 0.1 && n < 1.0 {
                return scale(v, 1.0 / n);
            }
        }
    }
    pub fn shuffle<T>(&mut self, v: &mut [T]) {
        for i in (1..v.len()).rev() {
            let j = self.below(i + 1);
            v.swap(i, j);
        }
    }
}

/// A mesh node's record (no flags, radius 0) moving from `x0` to `x1` over a step `dt` at the
/// constant velocity `(x1 - x0) / dt`.
pub fn node_record(gid: u64, body: u32, mass: f64, x0: V3, x1: V3, dt: f64) -> NodeRecord {
    NodeRecord {
        gid,
        body,
        flags: 0,
        mass,
        radius: 0.0,
        x0,
        x1,
        v: scale(sub(x1, x0), 1.0 / dt),
    }
}

pub fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}

/// The bilinear face in monomial form `X = a + b s + c t + d s t` (corners at
/// (-1,-1), (1,-1), (1,1), (-1,1)).
#[derive(Clone, Copy)]
pub struct Mono {
    a: V3,
    b: V3,
    c: V3,
    d: V3,
}

impl Mono {
    pub fn new(x: [V3; 4]) -> Mono {
        let q = |s0: f64, s1: f64, s2: f64, s3: f64| {
            let mut v = [0.0; 3];
            for k in 0..3 {
                v[k] = 0.25 * (s0 * x[0][k] + s1 * x[1][k] + s2 * x[2][k] + s3 * x[3][k]);
            }
            v
        };
        Mono {
            a: q(1.0, 1.0, 1.0, 1.0),
            b: q(-1.0, 1.0, 1.0, -1.0),
            c: q(-1.0, -1.0, 1.0, 1.0),
            d: q(1.0, -1.0, 1.0, -1.0),
        }
    }
    pub fn at(&self, s: f64, t: f64) -> V3 {
        std::array::from_fn(|k| self.a[k] + self.b[k] * s + self.c[k] * t + self.d[k] * s * t)
    }
    pub fn normal(&self, s: f64, t: f64) -> V3 {
        let xs = add(self.b, scale(self.d, t));
        let xt = add(self.c, scale(self.d, s));
        let n = cross(xs, xt);
        scale(n, 1.0 / norm(n))
    }
    /// Closest point of the bilinear surface to `p`: the best of a 31 x 31 grid over
    /// [-1.5, 1.5]^2, then Newton on the 2x2 stationarity system.
    pub fn project(&self, p: V3) -> (f64, f64) {
        const SAMPLES: usize = 31;
        let mut best = (f64::INFINITY, 0.0, 0.0);
        for i in 0..SAMPLES {
            for j in 0..SAMPLES {
                let s = -1.5 + 3.0 * i as f64 / (SAMPLES - 1) as f64;
                let t = -1.5 + 3.0 * j as f64 / (SAMPLES - 1) as f64;
                let r = sub(p, self.at(s, t));
                let e = dot(r, r);
                if e < best.0 {
                    best = (e, s, t);
                }
            }
        }
        let (mut s, mut t) = (best.1, best.2);
        for _ in 0..100 {
            let r = sub(p, self.at(s, t));
            let xs = add(self.b, scale(self.d, t));
            let xt = add(self.c, scale(self.d, s));
            let g = [dot(r, xs), dot(r, xt)];
            let h = [
                [dot(xs, xs), dot(xs, xt) - dot(r, self.d)],
                [dot(xs, xt) - dot(r, self.d), dot(xt, xt)],
            ];
            let det = h[0][0] * h[1][1] - h[0][1] * h[1][0];
            let ds = (h[1][1] * g[0] - h[0][1] * g[1]) / det;
            let dt = (h[0][0] * g[1] - h[1][0] * g[0]) / det;
            s += ds;
            t += dt;
            if ds.abs().max(dt.abs()) < 1e-15 {
                break;
            }
        }
        (s, t)
    }
    pub fn diameter(x: &[V3; 4]) -> f64 {
        norm(sub(x[2], x[0])).max(norm(sub(x[3], x[1])))
    }
}

/// A reference crossing: parametric point, depth, and the margins to the thresholds (to tell a
/// borderline pair).
#[derive(Debug, Clone, Copy)]
pub struct RefHit {
    pub xi: [f64; 2],
    /// Outward normal of the face at `xi` (end configuration).
    pub normal: V3,
    pub depth: f64,
    /// Smallest distance of a threshold test to its limit (parametric or length/face size).
    pub margin: f64,
}

/// The crossing rule (the same definition as the crate's, coded anew) with the margins of every
/// test, whether it passes or not. `None` only where the projection failed. Two branches: the end
/// projection on the face (contact there), or off it (the path's crossing of the offset surface,
/// interpolated between the start and end projections, must lie on the face; contact at that
/// point clamped to the face, against the tangent plane there).
pub fn reference_pair(
    x0: [V3; 4],
    x1: [V3; 4],
    p0: V3,
    p1: V3,
    r: f64,
    gap_tol: f64,
    param_tol: f64,
) -> (Option<RefHit>, f64) {
    let m1 = Mono::new(x1);
    let (s, t) = m1.project(p1);
    let lim = 1.0 + param_tol;
    let size = Mono::diameter(&x1);
    let tol = gap_tol * size;
    let mut margin = (lim - s.abs()).abs().min((lim - t.abs()).abs());
    let s1 = dot(sub(p1, m1.at(s, t)), m1.normal(s, t));
    margin = margin.min((r - s1).abs() / size);
    let m0 = Mono::new(x0);
    let corner_motion = (0..4).map(|k| norm(sub(x1[k], x0[k]))).fold(0.0, f64::max);
    let cap = norm(sub(p1, p0)) + corner_motion + r + tol;
    // A particle whose centre started outside the face, its sphere across the offset surface:
    // measured with the distance it started at.
    let started = |s0: f64| {
        if s0 >= r - tol {
            (true, r)
        } else if r > 0.0 && s0 >= 0.0 {
            (true, s0)
        } else {
            (false, r)
        }
    };
    let (hit, xi, depth) = if s.abs() <= lim && t.abs() <= lim {
        let s0 = dot(sub(p0, m0.at(s, t)), m0.normal(s, t));
        margin = margin.min((s0 - (r - tol)).abs() / size);
        let (outside, r) = started(s0);
        let depth = r - s1;
        margin = margin.min((cap - depth).abs() / size);
        (depth > 0.0 && outside && depth <= cap, [s, t], depth)
    } else {
        let (a, b) = m0.project(p0);
        let s0 = dot(sub(p0, m0.at(a, b)), m0.normal(a, b));
        margin = margin.min((s0 - (r - tol)).abs() / size);
        let (outside, r) = started(s0);
        let frac = if s0 > r { (s0 - r) / (s0 - s1) } else { 0.0 };
        let c = [a + frac * (s - a), b + frac * (t - b)];
        margin = margin.min((lim - c[0].abs()).abs().min((lim - c[1].abs()).abs()));
        let xi = [c[0].clamp(-1.0, 1.0), c[1].clamp(-1.0, 1.0)];
        let gap = sub(p1, m1.at(xi[0], xi[1]));
        let depth = r - dot(gap, m1.normal(xi[0], xi[1]));
        margin = margin.min(depth.abs() / size);
        margin = margin.min((cap - norm(gap)).abs() / size);
        let hit = s1 < r
            && outside
            && c[0].abs() <= lim
            && c[1].abs() <= lim
            && depth > 0.0
            && norm(gap) <= cap;
        (hit, xi, depth)
    };
    (
        if hit {
            Some(RefHit {
                xi,
                normal: m1.normal(xi[0], xi[1]),
                depth,
                margin,
            })
        } else {
            None
        },
        margin,
    )
}

/// A random configuration of moving warped quads and moving nodes, many of them crossing faces.
pub struct Scene {
    pub nodes: Vec<NodeRecord>,
    pub faces: Vec<FaceRecord>,
}

pub struct SceneSpec {
    pub faces: usize,
    pub free_nodes: usize,
    pub crossing_nodes: usize,
    pub bodies: u32,
    pub particles: bool,
    pub size: f64,
}

/// Random quads in a cube of side `size`, each with its own 4 corner nodes (the face's body),
/// moving a little during the step; `crossing_nodes` nodes aimed through random faces (some
/// starting slightly behind, some stopping short), `free_nodes` anywhere. Gids are shuffled.
pub fn random_scene(rng: &mut Rng, spec: &SceneSpec) -> Scene {
    let mut gids: Vec<u64> = (0..(4 * spec.faces + spec.free_nodes + spec.crossing_nodes) as u64)
        .map(|g| g * 7 + 3)
        .collect();
    rng.shuffle(&mut gids);
    let mut next = gids.into_iter();
    let mut nodes = Vec::new();
    let mut faces = Vec::new();
    let mut quads: Vec<([V3; 4], [V3; 4])> = Vec::new();
    let mut face_gids: Vec<u64> = (0..spec.faces as u64).map(|g| 1000 + 3 * g).collect();
    rng.shuffle(&mut face_gids);
    for &face_gid in &face_gids {
        let c = [
            rng.range(0.0, spec.size),
            rng.range(0.0, spec.size),
            rng.range(0.0, spec.size),
        ];
        let n = rng.unit();
        let mut t1 = cross(n, rng.unit());
        t1 = scale(t1, 1.0 / norm(t1));
        let t2 = cross(n, t1);
        let a = rng.range(0.5, 1.5);
        let warp = rng.range(-0.15, 0.15) * a;
        let signs = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
        let mut x0 = [[0.0; 3]; 4];
        let mut x1 = [[0.0; 3]; 4];
        let vel = scale(rng.unit(), rng.range(0.0, 0.3) * a);
        for k in 0..4 {
            let jit = scale(rng.unit(), 0.08 * a);
            let w = if k % 2 == 0 { warp } else { -warp };
            x0[k] = add(
                add(
                    c,
                    add(scale(t1, signs[k][0] * a), scale(t2, signs[k][1] * a)),
                ),
                add(scale(n, w), jit),
            );
            x1[k] = add(add(x0[k], vel), scale(rng.unit(), 0.03 * a));
        }
        let body = rng.below(spec.bodies as usize) as u32;
        let mut corner_gids = [0u64; 4];
        for k in 0..4 {
            let gid = next.next().unwrap();
            corner_gids[k] = gid;
            nodes.push(NodeRecord {
                gid,
                body,
                flags: 0,
                mass: rng.range(0.5, 2.0),
                radius: 0.0,
                x0: x0[k],
                x1: x1[k],
                v: sub(x1[k], x0[k]),
            });
        }
        faces.push(FaceRecord {
            gid: face_gid,
            nodes: corner_gids,
            body,
            reserved: 0,
        });
        quads.push((x0, x1));
    }
    for _ in 0..spec.crossing_nodes {
        let (x0, x1) = quads[rng.below(quads.len())];
        let m0 = Mono::new(x0);
        let m1 = Mono::new(x1);
        let a = Mono::diameter(&x1);
        let (s, t) = (rng.range(-1.2, 1.2), rng.range(-1.2, 1.2));
        let before = rng.range(-0.002, 0.3) * a;
        let after = rng.range(-0.05, 0.4) * a;
        let p0 = add(m0.at(s, t), scale(m0.normal(s, t), before));
        let (s1, t1) = (s + rng.range(-0.1, 0.1), t + rng.range(-0.1, 0.1));
        let p1 = sub(m1.at(s1, t1), scale(m1.normal(s1, t1), after));
        let particle = spec.particles && rng.f() < 0.3;
        nodes.push(NodeRecord {
            gid: next.next().unwrap(),
            body: rng.below(spec.bodies as usize) as u32,
            flags: if particle { FLAG_PARTICLE } else { 0 },
            mass: rng.range(0.5, 2.0),
            radius: if particle {
                rng.range(0.0, 0.1) * a
            } else {
                0.0
            },
            x0: p0,
            x1: p1,
            v: sub(p1, p0),
        });
    }
    for _ in 0..spec.free_nodes {
        let p0 = [
            rng.range(0.0, spec.size),
            rng.range(0.0, spec.size),
            rng.range(0.0, spec.size),
        ];
        let p1 = add(p0, scale(rng.unit(), rng.range(0.0, 1.0)));
        nodes.push(NodeRecord {
            gid: next.next().unwrap(),
            body: rng.below(spec.bodies as usize) as u32,
            flags: 0,
            mass: rng.range(0.5, 2.0),
            radius: 0.0,
            x0: p0,
            x1: p1,
            v: sub(p1, p0),
        });
    }
    Scene { nodes, faces }
}

/// Reference search over all pairs: per node, the deepest crossing (then lowest face gid) under
/// the body rules. Returns, per node gid with a contact, `(face gid, hit, runner-up depth)`, the
/// further contacts a node keeps (deepest first, each hit that against every kept one is on a
/// face of another body, at any angle, or has a normal more than 25 degrees, |cos| < 0.9, from
/// the kept one's and, for a mesh node, a face forming a valley with it) as (node gid, face
/// gid), and the smallest margin met over all pairs (how close the configuration came to a
/// threshold).
pub struct RefResult {
    pub contacts: std::collections::BTreeMap<u64, (u64, RefHit, f64)>,
    pub further: Vec<(u64, u64)>,
    pub min_margin: f64,
}

/// |cos| of the angle between two normals under which two hits of one node are one contact.
pub const SAME_NORMAL_COS: f64 = 0.9;

pub fn reference_search(
    scene: &Scene,
    self_contact: bool,
    gap_tol: f64,
    param_tol: f64,
) -> RefResult {
    use std::collections::{BTreeMap, HashMap};
    let by_gid: HashMap<u64, &NodeRecord> = scene.nodes.iter().map(|n| (n.gid, n)).collect();
    let mut contacts = BTreeMap::new();
    let mut further = Vec::new();
    let mut min_margin = f64::INFINITY;
    for n in &scene.nodes {
        let particle = n.flags & FLAG_PARTICLE != 0;
        let mut hits: Vec<(f64, u64, RefHit)> = Vec::new();
        for f in &scene.faces {
            if !particle {
                if f.nodes.contains(&n.gid) {
                    continue;
                }
                if !self_contact && f.body == n.body {
                    continue;
                }
            }
            let x0 = f.nodes.map(|g| by_gid[&g].x0);
            let x1 = f.nodes.map(|g| by_gid[&g].x1);
            // Cheap sound rejection: a contact has p1 = X1(xi) - depth n with depth at most
            // the cap of the rule, so p1 lies within (cap + a margin) of the ball around the
            // face's end corners.
            let mut centre = [0.0; 3];
            for x in x1.iter() {
                centre = add(centre, scale(*x, 0.25));
            }
            let rad = x1.iter().map(|x| norm(sub(*x, centre))).fold(0.0, f64::max);
            let diam = Mono::diameter(&x1);
            let corner_motion = (0..4).map(|k| norm(sub(x1[k], x0[k]))).fold(0.0, f64::max);
            let cap = norm(sub(n.x1, n.x0)) + corner_motion + n.radius + gap_tol * diam;
            if norm(sub(n.x1, centre)) > rad + cap + (2.0 * param_tol + 0.01) * diam {
                continue;
            }
            let (hit, margin) = reference_pair(x0, x1, n.x0, n.x1, n.radius, gap_tol, param_tol);
            min_margin = min_margin.min(margin);
            if let Some(h) = hit {
                hits.push((h.depth, f.gid, h));
            }
        }
        hits.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        if let Some(best) = hits.first() {
            let runner_up = hits.get(1).map(|h| h.0).unwrap_or(f64::NEG_INFINITY);
            contacts.insert(n.gid, (best.1, best.2, runner_up));
            // (normal, contact point, face centre, face body) of each kept hit.
            let geometry = |h: &(f64, u64, RefHit)| {
                let f = scene.faces.iter().find(|f| f.gid == h.1).unwrap();
                let m = Mono::new(f.nodes.map(|g| by_gid[&g].x1));
                (
                    h.2.normal,
                    m.at(h.2.xi[0], h.2.xi[1]),
                    m.at(0.0, 0.0),
                    f.body,
                )
            };
            let mut kept = vec![geometry(best)];
            for h in &hits[1..] {
                let (normal, at, centre, body) = geometry(h);
                // A face of another body than a kept one's, at any angle (the node must be
                // outside both bodies); on the kept one's body, a face of another normal and,
                // for a mesh node, forming a valley with it (each face's centre in front of the
                // other's tangent plane at its contact point).
                let valley = |k: &(V3, V3, V3, u32)| {
                    particle
                        || (dot(k.0, sub(centre, k.1)) > 0.0 && dot(normal, sub(k.2, at)) > 0.0)
                };
                let fits = |k: &(V3, V3, V3, u32)| {
                    k.3 != body || (dot(k.0, normal).abs() < SAME_NORMAL_COS && valley(k))
                };
                if kept.iter().all(fits) {
                    kept.push((normal, at, centre, body));
                    further.push((n.gid, h.1));
                }
            }
        }
    }
    RefResult {
        contacts,
        further,
        min_margin,
    }
}

/// A box of `random_scene` (3 bodies, particles, a cube of side 4) with `faces` faces, `free`
/// free nodes and `crossing` nodes aimed through faces, all owned, and its contacts (the
/// search with self-contact).
pub fn crowded_box(
    rng: &mut Rng,
    faces: usize,
    free: usize,
    crossing: usize,
) -> (contact::ContactBox, Vec<contact::Contact>) {
    let scene = random_scene(
        rng,
        &SceneSpec {
            faces,
            free_nodes: free,
            crossing_nodes: crossing,
            bodies: 3,
            particles: true,
            size: 4.0,
        },
    );
    let b =
        contact::ContactBox::from_records(&scene.nodes, scene.nodes.len(), &scene.faces).unwrap();
    let contacts = contact::search(
        &b,
        &contact::SearchParams {
            self_contact: true,
            ..contact::SearchParams::default()
        },
    );
    (b, contacts)
}
