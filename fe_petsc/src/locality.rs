//! The local elements and nodes put in an order that keeps the element loop's nodal reads and
//! writes close in memory: the elements by block, then along a Morton (Z-order) curve of their
//! centroids; the nodes in the order the elements first touch them.
//!
//! Why: the element loop gathers each element's 8 nodes and adds its forces back to them; in
//! a good order consecutive elements share nodes and neighbouring nodes share cache lines, so
//! most of those accesses hit lines already in cache. A mesh file can list its elements and
//! number its nodes in any order (an unstructured mesher's, or one renumbered by another tool),
//! and the distribution keeps each rank's part in file order. On the 47^3 block
//! (`examples/hex_bench`, eight lanes, a 2-core AMD EPYC with AVX-512; its third argument picks
//! the element order) an element update takes 197-209 ns with the elements in random order and
//! 125-128 ns in file (lexicographic) order or in random order put back by [`order_elements`];
//! 190 against 128 ns with the nodes numbered at random. From a shuffled mesh file the whole
//! benchmark runs within 7 % of gmsh's order with both orders applied, 2.4 times slower without.
//!
//! Blocks stay contiguous (the batched kernel takes runs of one material). The element order
//! is canonical: the curve runs on the whole mesh's centroid box (the same on every rank),
//! ties by global id, so any rank's elements are in the whole mesh's order restricted to them,
//! and the element loop adds each node's forces in the same order at every rank count
//! ([`crate::assembly`]). It is always applied: a structured mesh's lexicographic file order
//! ran 3-10 % faster than the curve's, but keeping it on some ranks and not on others would
//! give other sums. The node numbering only places values in memory (no sum depends on it): a
//! file's numbering that is already about as local is kept ([`KEEP_FACTOR`]). The mesh module
//! renumbers the ghost exchange's leaves with the nodes (`mesh::DistributedMesh::load`).
//!
//! Tetrahedra are ordered the same way, by the same key on the same box (the centroids of
//! all cells, both kinds), as an array of their own beside the hexahedra's: each kind's element
//! loop runs over its own array. The nodes are numbered as the hexahedra first touch them,
//! then as the tetrahedra do: a mesh of hexahedra alone is numbered as before tetrahedra were
//! read, and the hexahedra's nodes stay together in memory whatever tetrahedra sit beside them
//! (in a mixed mesh the two kinds meet only along a band of shared nodes).
use crate::mesh::LocalMesh;

/// Bits per axis of the curve's grid (3 x 21 = 63 bits of key).
const BITS: u32 = 21;

/// The Morton key of the cell `(i, j, k)` of a 2^21 grid: the bits of the three indices
/// interleaved, i's lowest first.
fn morton(i: u64, j: u64, k: u64) -> u64 {
    // Spreads the 21 low bits of v to every third bit (the usual mask sequence for 64 bits).
    fn spread(v: u64) -> u64 {
        let mut x = v & 0x1f_ffff;
        x = (x | x << 32) & 0x001f_0000_0000_ffff;
        x = (x | x << 16) & 0x001f_0000_ff00_00ff;
        x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
        x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
        x = (x | x << 2) & 0x1249_2492_4924_9249;
        x
    }
    spread(i) | spread(j) << 1 | spread(k) << 2
}

/// A node numbering is kept unless its mean span of node numbers within an element is more
/// than this many times the first-touch numbering's ([`node_order`]).
pub const KEEP_FACTOR: f64 = 2.0;

/// The centroid of the element of nodes `c` (their mean: 8 for a hexahedron, 4 for a
/// tetrahedron), m. For a hexahedron the sum and the division by 8 are those before
/// tetrahedra were read, so its key is too.
fn centroid(mesh: &LocalMesh, c: &[u32]) -> [f64; 3] {
    let mut s = [0.0; 3];
    for &v in c {
        for d in 0..3 {
            s[d] += mesh.coords[v as usize][d];
        }
    }
    s.map(|x| x / c.len() as f64)
}

/// The smallest and largest centroid coordinates of `mesh`'s elements (hexahedra and
/// tetrahedra), m (infinite when it has none): over all ranks, the bounding box of
/// [`order_elements`]' curve.
pub fn centroid_bounds(mesh: &LocalMesh) -> ([f64; 3], [f64; 3]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let hexes = mesh.elems.iter().map(|c| &c[..]);
    for c in hexes.chain(mesh.tets.iter().map(|c| &c[..])) {
        let c = centroid(mesh, c);
        for d in 0..3 {
            lo[d] = lo[d].min(c[d]);
            hi[d] = hi[d].max(c[d]);
        }
    }
    (lo, hi)
}

/// Puts `mesh`'s elements (connectivity, ids and blocks together) in the canonical order: by
/// block, then by the Morton key of the centroid on the box `lo..hi` (the whole mesh's
/// centroid bounds, the same on every rank), then by global id; sets `mesh.elem_key` to each
/// element's key. The order is the same for any partition (a rank's elements in it are the
/// whole mesh's order restricted to them), so the element loop meets each node's elements in
/// the same order on every rank count: the nodal sums' order ([`crate::assembly`]). The
/// tetrahedra likewise, in their own arrays (`tets`, `tet_id`, `tet_block`, `tet_key`).
pub fn order_elements(mesh: &mut LocalMesh, lo: [f64; 3], hi: [f64; 3]) {
    let top = ((1u64 << BITS) - 1) as f64;
    let cell = |x: f64, d: usize| {
        let span = hi[d] - lo[d];
        if span > 0.0 {
            (((x - lo[d]) / span) * top).clamp(0.0, top) as u64
        } else {
            0
        }
    };
    let key = |c: &[u32], block: i32, id: u64| {
        let c = centroid(mesh, c);
        let m = morton(cell(c[0], 0), cell(c[1], 1), cell(c[2], 2));
        // The block tag as an order-preserving u64 (tags may be -1).
        let b = (block as i64 as u64) ^ (1 << 63);
        [b, m, id]
    };
    let hex_keys: Vec<[u64; 3]> = (0..mesh.elems.len())
        .map(|e| key(&mesh.elems[e], mesh.elem_block[e], mesh.elem_id[e]))
        .collect();
    let tet_keys: Vec<[u64; 3]> = (0..mesh.tets.len())
        .map(|e| key(&mesh.tets[e], mesh.tet_block[e], mesh.tet_id[e]))
        .collect();
    let order = sorted_by_key(&hex_keys);
    mesh.elems = order.iter().map(|&e| mesh.elems[e]).collect();
    mesh.elem_id = order.iter().map(|&e| mesh.elem_id[e]).collect();
    mesh.elem_block = order.iter().map(|&e| mesh.elem_block[e]).collect();
    mesh.elem_key = order.iter().map(|&e| hex_keys[e]).collect();
    let order = sorted_by_key(&tet_keys);
    mesh.tets = order.iter().map(|&e| mesh.tets[e]).collect();
    mesh.tet_id = order.iter().map(|&e| mesh.tet_id[e]).collect();
    mesh.tet_block = order.iter().map(|&e| mesh.tet_block[e]).collect();
    mesh.tet_key = order.iter().map(|&e| tet_keys[e]).collect();
}

/// The indices of `keys` in the order of their keys (distinct: the last is the global id).
fn sorted_by_key(keys: &[[u64; 3]]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..keys.len()).collect();
    order.sort_unstable_by_key(|&e| keys[e]);
    order
}

/// A node numbering that follows the element order: nodes numbered as the hexahedra first
/// touch them, then as the tetrahedra do (nodes in no element after, in file order), as
/// `new_of_old`; `None` when the file's numbering is already about as local: its mean span of
/// node numbers within an element (over both kinds) at most [`KEEP_FACTOR`] times the
/// first-touch numbering's. Measured with `examples/hex_bench` on the 47^3 block: nodes
/// numbered at random 190 ns per element update against 128 in the file's (lexicographic)
/// numbering.
pub fn node_order(mesh: &LocalMesh) -> Option<Vec<u32>> {
    let nn = mesh.coords.len();
    let cells = || {
        let hexes = mesh.elems.iter().map(|c| &c[..]);
        hexes.chain(mesh.tets.iter().map(|c| &c[..]))
    };
    let mut new_of_old = vec![u32::MAX; nn];
    let mut next = 0u32;
    for c in cells() {
        for &v in c {
            if new_of_old[v as usize] == u32::MAX {
                new_of_old[v as usize] = next;
                next += 1;
            }
        }
    }
    for n in new_of_old.iter_mut().filter(|n| **n == u32::MAX) {
        *n = next;
        next += 1;
    }
    let ncells = mesh.elems.len() + mesh.tets.len();
    if ncells == 0 {
        return None;
    }
    // Summed over the hexahedra then the tetrahedra: for hexahedra alone, the sum before
    // tetrahedra were read.
    let span = |f: &dyn Fn(u32) -> u32| {
        let total: f64 = cells()
            .map(|c| {
                let (lo, hi) = c.iter().fold((u32::MAX, 0), |(lo, hi), &v| {
                    let n = f(v);
                    (lo.min(n), hi.max(n))
                });
                (hi - lo) as f64
            })
            .sum();
        total / ncells as f64
    };
    let (file, touch) = (span(&|v| v), span(&|v| new_of_old[v as usize]));
    (file > KEEP_FACTOR * touch).then_some(new_of_old)
}

/// `v` with entry `o` moved to `new_of_old[o]`.
pub fn permute<T: Copy>(v: &mut Vec<T>, new_of_old: &[u32]) {
    assert_eq!(v.len(), new_of_old.len(), "one new number per entry");
    let mut out = v.clone();
    for (o, x) in v.iter().enumerate() {
        out[new_of_old[o] as usize] = *x;
    }
    *v = out;
}

/// Renumbers `mesh`'s nodes by `new_of_old` ([`node_order`]): the node arrays (coordinates,
/// ids, surfaces; ownership once known) moved, both kinds' connectivity rewritten.
pub fn renumber_nodes(mesh: &mut LocalMesh, new_of_old: &[u32]) {
    permute(&mut mesh.coords, new_of_old);
    permute(&mut mesh.node_id, new_of_old);
    permute(&mut mesh.node_surfaces, new_of_old);
    if !mesh.owned.is_empty() {
        permute(&mut mesh.owned, new_of_old);
    }
    for c in mesh.elems.iter_mut() {
        for v in c.iter_mut() {
            *v = new_of_old[*v as usize];
        }
    }
    for c in mesh.tets.iter_mut() {
        for v in c.iter_mut() {
            *v = new_of_old[*v as usize];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The key interleaves the bits: (1,0,0) -> 1, (0,1,0) -> 2, (0,0,1) -> 4, and the top bit
    /// of each index lands at bits 60, 61, 62 (the definition of the Z-order curve).
    #[test]
    fn morton_interleaves_the_bits() {
        assert_eq!(morton(1, 0, 0), 1);
        assert_eq!(morton(0, 1, 0), 2);
        assert_eq!(morton(0, 0, 1), 4);
        assert_eq!(morton(3, 0, 0), 0b1001);
        let t = 1 << (BITS - 1);
        assert_eq!(morton(t, t, t), 0b111 << 60);
    }

    /// A grid of 12^3 unit cubes in two blocks: in lexicographic order it is kept; shuffled, it
    /// is reordered, and after ordering each
    /// element keeps its id, nodes and block; the blocks are contiguous; and consecutive
    /// elements lie close: mean centroid distance at most 2 cube widths, about what the
    /// grid's own lexicographic order gives (1.86: steps of 1 along rows, 11.0 between rows,
    /// 15.6 between planes), against 7.94 for a random order (the mean distance of two random
    /// points in a cube of side 12, 0.6617 x 12).
    #[test]
    fn shuffled_grid_is_ordered_along_the_curve() {
        let m = 12;
        let node = |i: usize, j: usize, k: usize| (i + (m + 1) * (j + (m + 1) * k)) as u32;
        let mut mesh = LocalMesh::default();
        for k in 0..=m {
            for j in 0..=m {
                for i in 0..=m {
                    mesh.coords.push([i as f64, j as f64, k as f64]);
                }
            }
        }
        let mut cells = Vec::new();
        for k in 0..m {
            for j in 0..m {
                for i in 0..m {
                    let c = [
                        node(i, j, k),
                        node(i + 1, j, k),
                        node(i + 1, j + 1, k),
                        node(i, j + 1, k),
                        node(i, j, k + 1),
                        node(i + 1, j, k + 1),
                        node(i + 1, j + 1, k + 1),
                        node(i, j + 1, k + 1),
                    ];
                    cells.push((c, cells.len() as u64, if k < m / 2 { 1 } else { 2 }));
                }
            }
        }
        // The canonical order does not depend on the order the elements come in: the
        // lexicographic grid and its shuffle (below) end in the same order.
        let mut lex = LocalMesh {
            coords: mesh.coords.clone(),
            elems: cells.iter().map(|t| t.0).collect(),
            elem_id: cells.iter().map(|t| t.1).collect(),
            elem_block: cells.iter().map(|t| t.2).collect(),
            ..Default::default()
        };
        let (lo, hi) = centroid_bounds(&lex);
        order_elements(&mut lex, lo, hi);
        let mut s = 0x2545_f491_4f6c_dd1du64;
        for i in (1..cells.len()).rev() {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            cells.swap(i, (s % (i as u64 + 1)) as usize);
        }
        for (c, id, b) in &cells {
            mesh.elems.push(*c);
            mesh.elem_id.push(*id);
            mesh.elem_block.push(*b);
        }
        let mean_step = |mesh: &LocalMesh| {
            let cent = |c: &[u32; 8]| {
                let p = mesh.coords[c[0] as usize];
                [p[0] + 0.5, p[1] + 0.5, p[2] + 0.5]
            };
            let d: f64 = mesh
                .elems
                .windows(2)
                .map(|w| {
                    let (a, b) = (cent(&w[0]), cent(&w[1]));
                    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
                })
                .sum();
            d / (mesh.elems.len() - 1) as f64
        };
        let before = mean_step(&mesh);
        order_elements(&mut mesh, lo, hi);
        let after = mean_step(&mesh);
        assert_eq!(
            mesh.elem_id, lex.elem_id,
            "the shuffled grid's order is the lexicographic grid's"
        );
        println!(
            "mean step between consecutive elements: shuffled {before:.2}, ordered {after:.2}"
        );
        assert!(before > 7.0, "the shuffle left the grid ordered ({before})");
        assert!(after <= 2.0, "ordered mean step {after} > 2 cube widths");
        let mut got: Vec<([u32; 8], u64, i32)> = (0..mesh.elems.len())
            .map(|e| (mesh.elems[e], mesh.elem_id[e], mesh.elem_block[e]))
            .collect();
        let switches = got.windows(2).filter(|w| w[0].2 != w[1].2).count();
        assert_eq!(switches, 1, "blocks not contiguous");
        got.sort_by_key(|t| t.1);
        cells.sort_by_key(|t| t.1);
        assert_eq!(got, cells, "an element lost its nodes or block");
    }

    /// A hexahedron (the unit cube) beside a unit cube split into six tetrahedra (Kuhn's split
    /// along the diagonal 0-7): the tetrahedra, given in two orders, end in one order with
    /// their keys, ids and blocks; the hexahedron keeps its key from the box of all centroids;
    /// renumbering the nodes moves the tetrahedra's corners with them (same coordinates).
    #[test]
    fn tetrahedra_are_ordered_and_renumbered_beside_hexahedra() {
        let mut mesh = LocalMesh::default();
        for x0 in [0.0, 2.0] {
            for k in 0..8 {
                let (i, j, l) = (k & 1, k >> 1 & 1, k >> 2 & 1);
                mesh.coords.push([x0 + i as f64, j as f64, l as f64]);
            }
        }
        mesh.node_id = (0..16).collect();
        mesh.node_surfaces = vec![0; 16];
        mesh.elems.push([0, 1, 3, 2, 4, 5, 7, 6]);
        mesh.elem_id.push(6);
        mesh.elem_block.push(1);
        // Kuhn's six paths from corner 0 to corner 7 of the second cube (nodes 8..16).
        let paths = [[1, 3], [1, 5], [2, 3], [2, 6], [4, 5], [4, 6]];
        let tets: Vec<[u32; 4]> = paths.iter().map(|p| [8, 8 + p[0], 8 + p[1], 15]).collect();
        let mut orders = Vec::new();
        for reverse in [false, true] {
            let mut m = mesh.clone();
            let mut ids: Vec<usize> = (0..6).collect();
            if reverse {
                ids.reverse();
            }
            for &t in &ids {
                m.tets.push(tets[t]);
                m.tet_id.push(t as u64);
                m.tet_block.push(2);
            }
            let (lo, hi) = centroid_bounds(&m);
            // x from the hexahedron's centroid (0.5) to that of the tetrahedra with three
            // corners on x = 3 (paths 0-1-3-7 and 0-1-5-7: (2 + 3 + 3 + 3) / 4).
            assert_eq!(
                (lo[0], hi[0]),
                (0.5, 2.75),
                "the box spans both kinds' centroids"
            );
            order_elements(&mut m, lo, hi);
            assert!(
                m.tet_key.windows(2).all(|w| w[0] < w[1]),
                "tetrahedra sorted"
            );
            for e in 0..6 {
                let id = m.tet_id[e] as usize;
                assert_eq!((m.tets[e], m.tet_key[e][2]), (tets[id], id as u64));
            }
            orders.push(m);
        }
        assert_eq!(
            orders[0].tet_id, orders[1].tet_id,
            "one order from either input"
        );
        let mut m = orders.pop().unwrap();
        assert_eq!(m.elem_key[0][2], 6);
        let before: Vec<[[f64; 3]; 4]> = m
            .tets
            .iter()
            .map(|c| c.map(|v| m.coords[v as usize]))
            .collect();
        let new_of_old: Vec<u32> = (0..16u32).map(|v| (v * 5 + 3) % 16).collect();
        renumber_nodes(&mut m, &new_of_old);
        let after: Vec<[[f64; 3]; 4]> = m
            .tets
            .iter()
            .map(|c| c.map(|v| m.coords[v as usize]))
            .collect();
        assert_eq!(
            before, after,
            "a tetrahedron's corners moved with the renumbering"
        );
    }
}
