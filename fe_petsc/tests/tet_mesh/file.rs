//! The mesh files of the `tet_mesh` test: a reader of what it needs from gmsh 2.2 files, a
//! writer of the hexahedron mesh, and the checks of the ranks' parts against the file.
use super::*;

/// gmsh 2.2 element types.
pub const TET: i32 = 4;
pub const HEX: i32 = 5;

/// What the test needs of a gmsh 2.2 file.
#[derive(Default)]
pub struct MshFile {
    /// Node coordinates in the order of the file's lines (PETSc's vertex order, so a node's
    /// global id is its line's index).
    pub coords: Vec<[f64; 3]>,
    /// The 3D elements in file order (PETSc's cell order, so a cell's global id is its index
    /// here): gmsh type, physical tag, nodes as line indices in the file's node order.
    pub cells: Vec<(i32, i32, Vec<usize>)>,
    /// The faces (2D elements) of each physical surface, nodes as line indices.
    pub surfaces: BTreeMap<i32, Vec<Vec<usize>>>,
}

impl MshFile {
    pub fn read(path: &Path) -> MshFile {
        let text = std::fs::read_to_string(path).unwrap();
        let mut m = MshFile::default();
        let mut index = BTreeMap::new();
        let mut section = "";
        for line in text.lines() {
            if line.starts_with('$') {
                section = line;
                continue;
            }
            let w: Vec<&str> = line.split_whitespace().collect();
            if w.len() < 2 {
                continue; // a section's count line
            }
            match section {
                "$Nodes" => {
                    index.insert(w[0].parse::<u64>().unwrap(), m.coords.len());
                    m.coords.push([1, 2, 3].map(|k| w[k].parse().unwrap()));
                }
                "$Elements" => {
                    let ty: i32 = w[1].parse().unwrap();
                    let ntags: usize = w[2].parse().unwrap();
                    let phys: i32 = if ntags > 0 { w[3].parse().unwrap() } else { -1 };
                    let nodes: Vec<usize> = w[3 + ntags..]
                        .iter()
                        .map(|x| index[&x.parse::<u64>().unwrap()])
                        .collect();
                    match ty {
                        // Triangles and quadrilaterals: faces of a physical surface.
                        2 | 3 if phys > 0 => m.surfaces.entry(phys).or_default().push(nodes),
                        // Every 3D type: tetrahedra, hexahedra, prisms, pyramids.
                        4..=7 => m.cells.push((ty, phys, nodes)),
                        _ => {}
                    }
                }
                _ => {}
            }
        }
        m
    }

    pub fn count(&self, ty: i32) -> u64 {
        self.cells.iter().filter(|c| c.0 == ty).count() as u64
    }
}

/// A small deterministic generator (xorshift64) for the shuffles.
fn xorshift(s: &mut u64) -> u64 {
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    *s
}

/// Writes a 5 x 4 x 3 grid of hexahedra on [0,1] x [0,0.8] x [0,0.6] with its node lines and
/// elements shuffled (so the loader's reordering and renumbering both act), two physical
/// volumes (1: the bottom layer, 2: the rest) and two physical surfaces (11: x = 0, 12: the
/// top).
pub fn write_hex_mesh(path: &Path) {
    let n = [5usize, 4, 3];
    let grid = |i: usize, j: usize, k: usize| i + (n[0] + 1) * (j + (n[1] + 1) * k);
    let nn = (n[0] + 1) * (n[1] + 1) * (n[2] + 1);
    // line[g]: the file line of grid node g (a shuffle of 0..nn).
    let mut line: Vec<usize> = (0..nn).collect();
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    for i in (1..nn).rev() {
        line.swap(i, (xorshift(&mut s) % (i as u64 + 1)) as usize);
    }
    let mut coords = vec![[0.0; 3]; nn];
    for k in 0..=n[2] {
        for j in 0..=n[1] {
            for i in 0..=n[0] {
                coords[line[grid(i, j, k)]] = [0.2 * i as f64, 0.2 * j as f64, 0.2 * k as f64];
            }
        }
    }
    let id = |i, j, k| line[grid(i, j, k)] + 1;
    let mut faces = Vec::new();
    for k in 0..n[2] {
        for j in 0..n[1] {
            faces.push((
                11,
                vec![
                    id(0, j, k),
                    id(0, j, k + 1),
                    id(0, j + 1, k + 1),
                    id(0, j + 1, k),
                ],
            ));
        }
    }
    for j in 0..n[1] {
        for i in 0..n[0] {
            let t = n[2];
            faces.push((
                12,
                vec![
                    id(i, j, t),
                    id(i + 1, j, t),
                    id(i + 1, j + 1, t),
                    id(i, j + 1, t),
                ],
            ));
        }
    }
    let mut hexes = Vec::new();
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let c = [
                    id(i, j, k),
                    id(i + 1, j, k),
                    id(i + 1, j + 1, k),
                    id(i, j + 1, k),
                    id(i, j, k + 1),
                    id(i + 1, j, k + 1),
                    id(i + 1, j + 1, k + 1),
                    id(i, j + 1, k + 1),
                ];
                hexes.push((if k == 0 { 1 } else { 2 }, c.to_vec()));
            }
        }
    }
    for i in (1..hexes.len()).rev() {
        hexes.swap(i, (xorshift(&mut s) % (i as u64 + 1)) as usize);
    }
    std::fs::write(path, msh_text(&coords, &faces, &hexes)).unwrap();
}

/// A gmsh 2.2 file of `coords` (node ids 1..: their line numbers), then the quadrilaterals
/// `faces` and the hexahedra `hexes` (each with its physical tag, nodes as 1-based ids).
fn msh_text(
    coords: &[[f64; 3]],
    faces: &[(i32, Vec<usize>)],
    hexes: &[(i32, Vec<usize>)],
) -> String {
    let nn = coords.len();
    let mut t = String::from("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n");
    t += &format!("{nn}\n");
    for (l, c) in coords.iter().enumerate() {
        t += &format!("{} {:?} {:?} {:?}\n", l + 1, c[0], c[1], c[2]);
    }
    t += &format!("$EndNodes\n$Elements\n{}\n", faces.len() + hexes.len());
    let all = faces
        .iter()
        .map(|f| (3, f))
        .chain(hexes.iter().map(|h| (HEX, h)));
    for (e, (ty, (tag, nodes))) in all.enumerate() {
        let v: Vec<String> = nodes.iter().map(|x| x.to_string()).collect();
        t += &format!("{} {ty} 2 {tag} {tag} {}\n", e + 1, v.join(" "));
    }
    t += "$EndElements\n";
    t
}

/// What every rank count must give alike: each tetrahedron's id -> its sorted global node ids,
/// and the tetrahedra's total volume summed in id order.
pub struct Whole {
    pub tet_nodes: BTreeMap<u64, Vec<u64>>,
    pub tet_volume: f64,
}

/// The ranks' parts against the file: counts; each cell on exactly one rank, with the file's
/// physical tag and the file's nodes in the file's order (which fixes PETSc's vertex order to
/// gmsh's); every tetrahedron's volume positive; each node owned by exactly one rank, its
/// holders counted right by the exchange, on exactly the file's physical surfaces.
pub fn check_against_file(file: &MshFile, parts: &[RankPart], np: usize) -> Whole {
    let want = [
        file.coords.len() as u64,
        file.cells.len() as u64,
        file.count(HEX),
        file.count(TET),
    ];
    for (r, p) in parts.iter().enumerate() {
        assert_eq!(
            p.counts, want,
            "np {np} rank {r}: global nodes, cells, hexahedra, tetrahedra"
        );
    }
    let mut cells: BTreeMap<u64, (i32, i32, Vec<u64>)> = BTreeMap::new();
    let mut volumes = BTreeMap::new();
    let mut tet_nodes = BTreeMap::new();
    for p in parts {
        for (id, block, nodes, vol) in &p.tets {
            assert!(
                *vol > 0.0,
                "np {np}: tetrahedron {id} has volume {vol:e} <= 0"
            );
            volumes.insert(*id, *vol);
            let mut sorted = nodes.clone();
            sorted.sort_unstable();
            tet_nodes.insert(*id, sorted);
            let dup = cells.insert(*id, (TET, *block, nodes.clone()));
            assert!(dup.is_none(), "np {np}: cell {id} on two ranks");
        }
        for (id, block, nodes) in &p.hexes {
            let dup = cells.insert(*id, (HEX, *block, nodes.clone()));
            assert!(dup.is_none(), "np {np}: cell {id} on two ranks");
        }
    }
    assert_eq!(
        cells.len(),
        file.cells.len(),
        "np {np}: cells over all ranks"
    );
    for (id, (ty, block, nodes)) in &cells {
        let (fty, fblock, fnodes) = &file.cells[*id as usize];
        let fnodes: Vec<u64> = fnodes.iter().map(|&v| v as u64).collect();
        assert_eq!(
            (ty, block, nodes),
            (fty, fblock, &fnodes),
            "np {np}: cell {id} (type, block, nodes in order) is not the file's"
        );
    }
    check_nodes(file, parts, np);
    Whole {
        tet_nodes,
        tet_volume: volumes.values().sum(),
    }
}

/// Each node owned by exactly one rank, its holder count from the exchange the number of ranks
/// that hold it, its surface tags the file's surfaces through it.
fn check_nodes(file: &MshFile, parts: &[RankPart], np: usize) {
    let mut on_surface: Vec<BTreeSet<i32>> = vec![BTreeSet::new(); file.coords.len()];
    for (tag, faces) in &file.surfaces {
        for &v in faces.iter().flatten() {
            on_surface[v].insert(*tag);
        }
    }
    let mut owners = vec![0usize; file.coords.len()];
    let mut held = vec![0usize; file.coords.len()];
    for p in parts {
        for (id, owned, _, tags) in &p.nodes {
            owners[*id as usize] += *owned as usize;
            held[*id as usize] += 1;
            assert_eq!(
                tags, &on_surface[*id as usize],
                "np {np}: node {id}'s surfaces"
            );
        }
    }
    for p in parts {
        for (id, _, holders, _) in &p.nodes {
            assert_eq!(
                *holders, held[*id as usize] as f64,
                "np {np}: node {id}'s holders"
            );
        }
    }
    assert!(
        owners.iter().all(|&o| o == 1),
        "np {np}: a node without exactly one owner"
    );
}

/// Meshes `geo` with gmsh as the driver does (`gmsh FILE -3 -format msh22`), into `dir`.
pub fn gmsh(dir: &Path, name: &str, geo: &str) -> PathBuf {
    let g = dir.join(format!("{name}.geo"));
    let m = dir.join(format!("{name}.msh"));
    std::fs::write(&g, geo).unwrap();
    let o = Command::new("gmsh")
        .arg(&g)
        .args(["-3", "-format", "msh22", "-o"])
        .arg(&m)
        .output()
        .expect("gmsh (needed by this test)");
    assert!(
        o.status.success(),
        "gmsh failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    m
}
