//! Tetrahedra and prisms run as hexahedra: the split of a gmsh mesh into the code's one element
//! (issue 30).
//!
//! # The choice
//!
//! The element of this code is the 8-node hexahedron with a mean (one-point) strain, a constant
//! pressure (Q1/P0) and hourglass control (docs/element.md). A mesh of tetrahedra is run as that
//! element: each tetrahedron (a, b, c, d) becomes 4 hexahedra, one per corner, whose 8 nodes are
//! the corner, its 3 edge midpoints, its 3 face centroids and the cell centroid (the composite
//! tetrahedron of LS-DYNA's hexahedral subdivision; Nagtegaal, Parks & Rice 1974 give the count
//! below).
//!
//! Why it does not lock. In plastic flow the deformation is (nearly) isochoric: every pressure
//! degree of freedom is one constraint on the nodal velocities. A mesh of V vertices holds about
//! 5.5 V linear tetrahedra (the mean of gmsh's Delaunay meshes; each vertex is shared by about 22
//! tetrahedra, each tetrahedron has 4 vertices). The one-point tetrahedron (LS-DYNA ELFORM 10)
//! has about 3 V velocity dofs against 5.5 V constraints: more constraints than dofs, it locks
//! (issue 30: OpenRadioss's default tet4 on the copper bar, foot radius 6.57 mm against 7.2).
//! Split into hexahedra, the same mesh has V + E + F + C nodes (E ~ 6.5 V edges,
//! F ~ 11 V faces, C ~ 5.5 V cells: about 24 V nodes, 3 x 24 V = 72 V dofs) against 4 x 5.5 V =
//! 22 V constraints (one pressure per hexahedron): 3.3 dofs per constraint, the ratio of a
//! hexahedral mesh (3 dofs per node, one node per element), which does not lock.
//!
//! The alternative is `[run] tetrahedra = "nodal_pressure"` (the native tetrahedron with a
//! nodal-averaged pressure, LS-DYNA ELFORM 13 / OpenRadioss `Itetra4 = 3`: `fe_petsc::tet`), with
//! no split at all ([`check_native`] only refuses what it cannot run). It removes the locking in
//! plastic flow another way at the tetrahedron's own cost and step, but stays stiff in bending
//! (docs/element.md compares them): the split is the default because it is right in both. The
//! 10-node composite tetrahedron (Thoutireddy et al. 2002) is not built. The split reuses the
//! hexahedron unchanged: PETSc, the lane kernel, contact, output, probes, particle fill,
//! implicit mode, restart and the reproducibility guarantee see hexahedra as for any
//! hexahedral mesh. The cost: 4 hexahedra per tetrahedron, and a stable step about half the
//! tetrahedron's (the sub-hexahedra are about half as thick).
//!
//! # The split (exact)
//!
//! Write a point of the tetrahedron in barycentric coordinates (l_a, l_b, l_c, l_d). Corner a's
//! hexahedron is the region where l_a is the largest: l_b, l_c, l_d >= 0 and l_a >= l_b, l_c,
//! l_d. Its six faces lie on the planes l_b = 0, l_c = 0, l_d = 0 (faces of the tetrahedron) and
//! l_a = l_b, l_a = l_c, l_a = l_d (planes through the centroid): the midpoint (1/2, 1/2, 0, 0),
//! the centroids (1/3, 1/3, 1/3, 0) and (1/3, 1/3, 0, 1/3) and the centroid (1/4, 1/4, 1/4,
//! 1/4) all have l_a = l_b, so that face is planar, and so for the others. Planar faces make the
//! trilinear hexahedron on these 8 points the region itself; the 4 regions have the same volume
//! by symmetry (an affine map permutes them), V/4 each, and an outer triangle becomes 3 coplanar
//! quadrangles (contact surfaces keep the exact geometry).
//!
//! A prism (6-node wedge, gmsh's x = sum_i l_i [(1 - t) x_i + t x_{i+3}]) becomes 6 hexahedra:
//! each triangle into 3 quadrangles as above, in 2 layers (t = 0, 1/2, 1). The prism's map is
//! linear in l for fixed t and linear in t, and the quadrangle's bilinear map of (u, v) to l, so
//! each sub-hexahedron's map is trilinear in (u, v, t): the trilinear hexahedron on its 8 nodes,
//! exactly. When a mesh has prisms every hexahedron is split into 8 the same way (its trilinear
//! map on the half cells), so the quadrangles shared with prisms (split into 4 by their edge
//! midpoints and centre) conform. Hexahedra in a mesh with only tetrahedra besides stay as they
//! are (a hexahedron and a tetrahedron cannot share a face).
//!
//! Every new node is the mean of a set of corners of one element: an edge's 2 ends, a face's 3
//! or 4 corners, a cell's 4, 6 or 8 nodes; it is keyed by that set sorted, so neighbouring
//! elements get the same node (a conforming mesh) and the numbering follows the file's order
//! (numbers after the file's largest, in order of first use). Surface elements follow: a
//! triangle into 3 quadrangles, a quadrangle into 4 when hexahedra are split, a line into 2 at
//! its midpoint when its elements made that midpoint; points stay. Each keeps its physical and
//! elementary tags. Pyramids and second-order elements are refused with one line naming their
//! count and the gmsh option that avoids them.
use crate::input::gmsh::{self, MeshError, Msh22};
use rustc_hash::FxHashMap;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// What the split did: the file's volume elements and the hexahedra they became.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SplitSummary {
    /// Tetrahedra in the file.
    pub tetrahedra: usize,
    /// Prisms in the file.
    pub prisms: usize,
    /// Hexahedra in the file.
    pub hexahedra: usize,
    /// Hexahedra run.
    pub hexahedra_run: usize,
}

impl SplitSummary {
    /// Whether the split changed the mesh (tetrahedra or prisms).
    pub fn changed(&self) -> bool {
        self.tetrahedra + self.prisms > 0
    }

    /// The start line's words: "10,845 tetrahedra run as 43,380 hexahedra (4 per
    /// tetrahedron)".
    pub fn describe(&self) -> String {
        let mut had = Vec::new();
        let mut per = Vec::new();
        if self.tetrahedra > 0 {
            had.push(format!("{} tetrahedra", grouped(self.tetrahedra)));
            per.push("4 per tetrahedron");
        }
        if self.prisms > 0 {
            had.push(format!("{} prisms", grouped(self.prisms)));
            per.push("6 per prism");
        }
        if self.hexahedra > 0 {
            had.push(format!("{} hexahedra", grouped(self.hexahedra)));
            per.push(if self.prisms > 0 {
                "8 per hexahedron"
            } else {
                "hexahedra as they are"
            });
        }
        format!(
            "{} run as {} hexahedra ({})",
            had.join(" and "),
            grouped(self.hexahedra_run),
            per.join(", ")
        )
    }
}

/// `n` with a comma every 3 digits.
pub fn grouped(n: usize) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// gmsh element types.
const POINT: i32 = 15;
const LINE: i32 = 1;
const TRIANGLE: i32 = 2;
const QUAD: i32 = 3;
const TET: i32 = 4;
const HEX: i32 = 5;
const PRISM: i32 = 6;
const PYRAMID: i32 = 7;

/// The even permutations of a tetrahedron (a, b, c, d) = (0, 1, 2, 3) that put each corner
/// first: corner a's hexahedron spans towards b, c, d as x, y, z with the tetrahedron's
/// orientation.
const TET_CORNERS: [[usize; 4]; 4] = [[0, 1, 2, 3], [1, 2, 0, 3], [2, 0, 1, 3], [3, 0, 2, 1]];

/// gmsh's hexahedron node order as (x, y, z) bits of the unit cube.
const HEX_BITS: [[usize; 3]; 8] = [
    [0, 0, 0],
    [1, 0, 0],
    [1, 1, 0],
    [0, 1, 0],
    [0, 0, 1],
    [1, 0, 1],
    [1, 1, 1],
    [0, 1, 1],
];

/// The refusal of a mesh with pyramids or second-order elements, one line.
fn refuse(elements: &[(i32, i32, i32, Vec<u64>)]) -> Result<(), String> {
    let pyramids = elements.iter().filter(|e| e.0 == PYRAMID).count();
    // gmsh's second-order (and higher) types: 8-14, 16-19, and types above 19.
    let higher = elements
        .iter()
        .filter(|e| matches!(e.0, 8..=14 | 16..))
        .count();
    if pyramids > 0 {
        return Err(format!(
            "the mesh has {} pyramids, which tdyn does not run (gmsh makes them where a recombined volume meets tetrahedra): mesh all hexahedra with Mesh.SubdivisionAlgorithm = 2, or do not recombine the volume (tetrahedra, prisms and hexahedra are run)",
            grouped(pyramids)
        ));
    }
    if higher > 0 {
        return Err(format!(
            "the mesh has {} second-order elements (10-node tetrahedra, 20- or 27-node hexahedra, 6-node triangles ...), which tdyn does not run: mesh with Mesh.ElementOrder = 1 (gmsh's default)",
            grouped(higher)
        ));
    }
    Ok(())
}

/// The new nodes: each the mean of a sorted set of corners, numbered in order of first use.
struct Nodes {
    x: FxHashMap<u64, [f64; 3]>,
    made: FxHashMap<Vec<u64>, u64>,
    next: u64,
    added: Vec<(u64, [f64; 3])>,
}

impl Nodes {
    fn new(nodes: &[(u64, [f64; 3])]) -> Nodes {
        let x: FxHashMap<u64, [f64; 3]> = nodes.iter().copied().collect();
        let next = nodes.iter().map(|n| n.0).max().unwrap_or(0) + 1;
        Nodes {
            x,
            made: FxHashMap::default(),
            next,
            added: Vec::new(),
        }
    }

    /// The node at the mean of `corners` (a corner itself when there is one), made on first use.
    fn at(&mut self, corners: &[u64]) -> u64 {
        if corners.len() == 1 {
            return corners[0];
        }
        let mut key = corners.to_vec();
        key.sort_unstable();
        if let Some(&id) = self.made.get(&key) {
            return id;
        }
        // The mean, summed in the key's order (the same bits whichever element asks first).
        let mut s = [0.0; 3];
        for k in &key {
            let p = self.x[k];
            for c in 0..3 {
                s[c] += p[c];
            }
        }
        let n = key.len() as f64;
        let p = [s[0] / n, s[1] / n, s[2] / n];
        let id = self.next;
        self.next += 1;
        self.x.insert(id, p);
        self.added.push((id, p));
        self.made.insert(key, id);
        id
    }

    /// The node made at the mean of `corners`, if any element made it.
    fn made(&self, corners: &[u64]) -> Option<u64> {
        let mut key = corners.to_vec();
        key.sort_unstable();
        self.made.get(&key).copied()
    }
}

/// A tetrahedron's 4 hexahedra: corner a's node of bits (x, y, z) is the mean of a and those of
/// b, c, d whose bit is set.
fn split_tet(t: &[u64], nodes: &mut Nodes) -> Vec<Vec<u64>> {
    TET_CORNERS
        .iter()
        .map(|p| {
            HEX_BITS
                .iter()
                .map(|b| {
                    let mut set = vec![t[p[0]]];
                    for (axis, &bit) in b.iter().enumerate() {
                        if bit == 1 {
                            set.push(t[p[axis + 1]]);
                        }
                    }
                    nodes.at(&set)
                })
                .collect()
        })
        .collect()
}

/// A hexahedron's 8 half cells. On the grid of half steps (0, 1, 2 per axis) octant o spans
/// o..o+1 per axis, in the parent's orientation; a grid point is the mean of the corners whose
/// bit matches it on the axes where it is 0 or 2 (1: both bits).
fn split_hex(h: &[u64], nodes: &mut Nodes) -> Vec<Vec<u64>> {
    HEX_BITS
        .iter()
        .map(|o| {
            HEX_BITS
                .iter()
                .map(|b| {
                    let g: [usize; 3] = std::array::from_fn(|a| o[a] + b[a]);
                    let set: Vec<u64> = (0..8)
                        .filter(|&k| (0..3).all(|a| g[a] == 1 || g[a] == 2 * HEX_BITS[k][a]))
                        .map(|k| h[k])
                        .collect();
                    nodes.at(&set)
                })
                .collect()
        })
        .collect()
}

/// A prism's 6 hexahedra: triangle corner i's quadrangle (i, mid(i, i+1), centroid,
/// mid(i, i-1)) in the layers t = 0..1/2 and 1/2..1. A point (triangle corners S, level L of
/// 0, 1, 2) is the mean of S on the bottom (L = 0), of S + 3 on the top (2), of both (1).
fn split_prism(w: &[u64], nodes: &mut Nodes) -> Vec<Vec<u64>> {
    let mut out = Vec::with_capacity(6);
    for layer in 0..2 {
        for i in 0..3 {
            let quad: [Vec<usize>; 4] = [
                vec![i],
                vec![i, (i + 1) % 3],
                vec![0, 1, 2],
                vec![i, (i + 2) % 3],
            ];
            let mut hex = Vec::with_capacity(8);
            for level in [layer, layer + 1] {
                for s in &quad {
                    let mut set = Vec::new();
                    for &k in s {
                        if level != 2 {
                            set.push(w[k]);
                        }
                        if level != 0 {
                            set.push(w[k + 3]);
                        }
                    }
                    hex.push(nodes.at(&set));
                }
            }
            out.push(hex);
        }
    }
    out
}

/// A polygon's (triangle's, quadrangle's) quadrangles, one per corner i: (i, mid(i, i+1),
/// centre, mid(i, i-1)), in its orientation.
fn split_polygon(f: &[u64], nodes: &mut Nodes) -> Vec<Vec<u64>> {
    let n = f.len();
    let centre = nodes.at(f);
    (0..n)
        .map(|i| {
            vec![
                f[i],
                nodes.at(&[f[i], f[(i + 1) % n]]),
                centre,
                nodes.at(&[f[i], f[(i + n - 1) % n]]),
            ]
        })
        .collect()
}

/// The split mesh (see the module): only hexahedra, and quadrangles, lines and points.
/// Returns it with its summary; `None` for a mesh without tetrahedra and prisms (run as it is).
pub(crate) fn split(m: &Msh22) -> Result<Option<(Msh22, SplitSummary)>, String> {
    refuse(&m.elements)?;
    let count = |ty: i32| m.elements.iter().filter(|e| e.0 == ty).count();
    let mut summary = SplitSummary {
        tetrahedra: count(TET),
        prisms: count(PRISM),
        hexahedra: count(HEX),
        hexahedra_run: 0,
    };
    if !summary.changed() {
        return Ok(None);
    }
    let split_hexes = summary.prisms > 0;
    let mut nodes = Nodes::new(&m.nodes);
    // Volume elements first: they make the nodes the faces and lines then find.
    let mut volumes: Vec<Option<Vec<Vec<u64>>>> = Vec::with_capacity(m.elements.len());
    for (ty, _, _, conn) in &m.elements {
        volumes.push(match *ty {
            TET => Some(split_tet(conn, &mut nodes)),
            PRISM => Some(split_prism(conn, &mut nodes)),
            HEX if split_hexes => Some(split_hex(conn, &mut nodes)),
            HEX => Some(vec![conn.clone()]),
            _ => None,
        });
    }
    let mut elements = Vec::with_capacity(m.elements.len() * 4);
    for ((ty, phys, geom, conn), vol) in m.elements.iter().zip(volumes) {
        let (out_ty, parts) = match (*ty, vol) {
            (_, Some(hexes)) => {
                summary.hexahedra_run += hexes.len();
                (HEX, hexes)
            }
            (TRIANGLE, None) => (QUAD, split_polygon(conn, &mut nodes)),
            (QUAD, None) if nodes.made(conn).is_some() => (QUAD, split_polygon(conn, &mut nodes)),
            (LINE, None) => match nodes.made(conn) {
                Some(mid) => (LINE, vec![vec![conn[0], mid], vec![mid, conn[1]]]),
                None => (LINE, vec![conn.clone()]),
            },
            (POINT | QUAD, None) => (*ty, vec![conn.clone()]),
            (other, None) => return Err(format!("gmsh element type {other} is not run")),
        };
        for p in parts {
            elements.push((out_ty, *phys, *geom, p));
        }
    }
    let mut all = m.nodes.clone();
    all.extend(nodes.added);
    Ok(Some((
        Msh22 {
            names: m.names.clone(),
            nodes: all,
            elements,
        },
        summary,
    )))
}

/// The check of a mesh whose tetrahedra run natively (`[run] tetrahedra = "nodal_pressure"`):
/// hexahedra and tetrahedra only; pyramids, second-order elements and prisms are refused with
/// one line (prisms run only as hexahedra, with the split). Returns the counts of tetrahedra and
/// hexahedra.
pub fn check_native(msh: &Path) -> Result<(usize, usize), MeshError> {
    let m = gmsh::read_msh22(msh)?;
    refuse(&m.elements).map_err(|why| gmsh::bad(msh, &why))?;
    let count = |ty: i32| m.elements.iter().filter(|e| e.0 == ty).count();
    let prisms = count(PRISM);
    if prisms > 0 {
        return Err(gmsh::bad(
            msh,
            &format!(
                "the mesh has {} prisms, which run only as hexahedra: set [run] tetrahedra = \"split\" (the default), or mesh without extrusions of triangles (tetrahedra and hexahedra run natively)",
                grouped(prisms)
            ),
        ));
    }
    Ok((count(TET), count(HEX)))
}

/// The split of the checked msh 2.2 file `msh`, cached in `cache_dir` by the file's content:
/// the file itself (and `None`) for a mesh without tetrahedra and prisms, which runs as it is.
pub fn split_file(
    msh: &Path,
    cache_dir: &Path,
) -> Result<(PathBuf, Option<SplitSummary>), MeshError> {
    let m = gmsh::read_msh22(msh)?;
    let Some((split, summary)) = split(&m).map_err(|why| gmsh::bad(msh, &why))? else {
        return Ok((msh.to_path_buf(), None));
    };
    let mut h = Sha256::new();
    h.update(b"tdyn split 1\n");
    h.update(std::fs::read(msh).map_err(|e| gmsh::bad(msh, &e.to_string()))?);
    let hash: String = h
        .finalize()
        .iter()
        .take(12)
        .map(|b| format!("{b:02x}"))
        .collect();
    let stem = msh.file_stem().and_then(|s| s.to_str()).unwrap_or("mesh");
    let out = cache_dir.join(format!("{stem}-split-{hash}.msh"));
    if !out.exists() {
        gmsh::write_atomically(&out, &gmsh::msh22_text(&split))?;
    }
    Ok((out, Some(summary)))
}

#[cfg(test)]
mod tests;
