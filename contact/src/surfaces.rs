//! Contact surfaces and bodies from a hexahedral mesh (a tetrahedron as the collapsed
//! hexahedron (a, b, c, c, d, d, d, d): its triangles are faces with a repeated corner).
//!
//! Hexahedra use the VTK (and gmsh) node order: `0-1-2-3` the bottom face counter-clockwise seen
//! from above, `4-5-6-7` the top face above them. A face of the mesh is a *boundary* face when
//! exactly one hexahedron of the whole mesh uses it (one used by two is interior). A *body* is a
//! connected set of elements, two elements being connected when they share a node (docs/scene.md).

use std::collections::HashMap;

use crate::data::FaceRecord;

/// The six faces of a VTK hexahedron as local node lists, each counter-clockwise seen from outside
/// (outward normal by the right-hand rule): bottom, top, front (`y-`), right (`x+`), back (`y+`),
/// left (`x-`) for the reference element.
pub const HEX_FACES: [[usize; 4]; 6] = [
    [0, 3, 2, 1],
    [4, 5, 6, 7],
    [0, 1, 5, 4],
    [1, 2, 6, 5],
    [2, 3, 7, 6],
    [3, 0, 4, 7],
];

/// A boundary face of a selected element.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoundaryFace {
    /// Global node ids, counter-clockwise seen from outside the element.
    pub nodes: [u64; 4],
    /// Index of the element (in the slice handed to [`surfaces`]).
    pub element: usize,
    /// Which face of the element, an index into [`HEX_FACES`].
    pub side: u8,
    /// Body of the element.
    pub body: u32,
}

/// The result of [`surfaces`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Surfaces {
    /// Boundary faces of the selected elements, in element order then side order.
    pub faces: Vec<BoundaryFace>,
    /// Body of every element of the mesh.
    pub element_body: Vec<u32>,
    /// Number of bodies.
    pub n_bodies: u32,
}

impl Surfaces {
    /// The distinct nodes of the faces with their bodies, sorted by gid: the mesh's contact nodes.
    pub fn nodes(&self) -> Vec<(u64, u32)> {
        let mut v: Vec<(u64, u32)> = self
            .faces
            .iter()
            .flat_map(|f| f.nodes.iter().map(move |&n| (n, f.body)))
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    }

    /// The faces as records, with gids `first_gid`, `first_gid + 1`, ... in face order.
    pub fn face_records(&self, first_gid: u64) -> Vec<FaceRecord> {
        self.faces
            .iter()
            .enumerate()
            .map(|(i, f)| FaceRecord {
                gid: first_gid + i as u64,
                nodes: f.nodes,
                body: f.body,
                reserved: 0,
            })
            .collect()
    }
}

/// The face's distinct nodes sorted (padded with `u64::MAX`): the same key for both
/// orientations, to match faces between elements. A tetrahedron is handed in as the collapsed
/// hexahedron (a, b, c, c, d, d, d, d), whose triangles repeat a corner, and not the same one
/// in the two tetrahedra sharing a triangle: the key of its distinct nodes matches them.
pub fn face_key(nodes: [u64; 4]) -> [u64; 4] {
    let mut k = nodes;
    k.sort_unstable();
    for i in (1..4).rev() {
        if k[i] == k[i - 1] {
            k[i..].rotate_left(1);
            k[3] = u64::MAX;
        }
    }
    k
}

/// Whether a face has an area: at least 3 distinct corners (a collapsed hexahedron's point and
/// edge "faces" have not).
fn is_face(key: &[u64; 4]) -> bool {
    key[2] != u64::MAX
}

/// Union-find with path halving; the root of a set is its smallest element.
struct UnionFind(Vec<usize>);

impl UnionFind {
    fn find(&mut self, mut a: usize) -> usize {
        while self.0[a] != a {
            self.0[a] = self.0[self.0[a]];
            a = self.0[a];
        }
        a
    }

    fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        self.0[hi] = lo;
    }
}

/// The body of every element: connected components of elements sharing nodes, numbered 0, 1, ...
/// in the order of each component's first element. Returns `(element_body, n_bodies)`.
pub fn bodies(hexes: &[[u64; 8]]) -> (Vec<u32>, u32) {
    let mut uf = UnionFind((0..hexes.len()).collect());
    let mut first: HashMap<u64, usize> = HashMap::with_capacity(hexes.len());
    for (e, h) in hexes.iter().enumerate() {
        for n in h {
            match first.get(n) {
                Some(&o) => uf.union(o, e),
                None => {
                    first.insert(*n, e);
                }
            }
        }
    }
    let mut number: HashMap<usize, u32> = HashMap::new();
    let mut body = Vec::with_capacity(hexes.len());
    for e in 0..hexes.len() {
        let root = uf.find(e);
        let next = number.len() as u32;
        body.push(*number.entry(root).or_insert(next));
    }
    (body, number.len() as u32)
}

/// The boundary faces of the elements for which `selected(element)` holds (faces used by exactly
/// one element among all of `hexes`), oriented outward, with the bodies of all elements.
pub fn surfaces(hexes: &[[u64; 8]], selected: impl Fn(usize) -> bool) -> Surfaces {
    let (element_body, n_bodies) = bodies(hexes);
    let mut uses: HashMap<[u64; 4], u32> = HashMap::with_capacity(3 * hexes.len());
    let corners = |h: &[u64; 8], side: &[usize; 4]| side.map(|i| h[i]);
    for h in hexes {
        for side in &HEX_FACES {
            *uses.entry(face_key(corners(h, side))).or_insert(0) += 1;
        }
    }
    let mut faces = Vec::new();
    for (e, h) in hexes.iter().enumerate() {
        if !selected(e) {
            continue;
        }
        for (s, side) in HEX_FACES.iter().enumerate() {
            let nodes = corners(h, side);
            let key = face_key(nodes);
            if is_face(&key) && uses[&key] == 1 {
                faces.push(BoundaryFace {
                    nodes,
                    element: e,
                    side: s as u8,
                    body: element_body[e],
                });
            }
        }
    }
    Surfaces {
        faces,
        element_body,
        n_bodies,
    }
}
