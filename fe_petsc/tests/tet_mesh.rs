//! `DistributedMesh::load` on meshes of 4-node tetrahedra, alone and beside hexahedra, at 1, 2
//! and 3 ranks, checked against the mesh file itself; and a mesh of hexahedra alone, whose
//! `LocalMesh` must stay what it was before tetrahedra were read.
//!
//! No libtest harness (`harness = false`): the parent process writes or meshes the files, runs
//! itself under `mpirun` as the child (environment `TET_MESH_CHILD`), and compares what each
//! child rank wrote. A child rank writes its part of the mesh in global terms (cell ids, node
//! ids), so the parent can check it against the file and across rank counts.
use fe_petsc::mesh::{DistributedMesh, FileSurfaces, LocalMesh};
use fe_petsc::petsc::Petsc;
use mpi::traits::*;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

#[path = "tet_mesh/file.rs"]
mod file;
use file::*;

fn main() {
    if let Ok(mesh) = std::env::var("TET_MESH_CHILD") {
        let out = std::env::var("TET_MESH_OUT").expect("TET_MESH_OUT");
        child(Path::new(&mesh), Path::new(&out));
        return;
    }
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("tet_mesh");
    std::fs::create_dir_all(&dir).unwrap();
    hexahedra_alone_as_before(&dir);
    tetrahedra_alone(&dir);
    tetrahedra_beside_hexahedra(&dir);
    prisms_refused(&dir);
    println!("tet_mesh: all checks passed");
}

/// One rank: loads the mesh and writes what it holds to `out.<rank>`.
fn child(mesh: &Path, out: &Path) {
    let universe = mpi::initialize().unwrap();
    let world = universe.world();
    let petsc = Petsc::init(world.as_raw(), &[]).unwrap();
    // Rank 0 hands the loader the file's physical surfaces, as the driver does.
    let file = if world.rank() == 0 {
        let m = MshFile::read(mesh);
        FileSurfaces {
            nodes: m.coords.len(),
            surfaces: m.surfaces.clone().into_iter().collect(),
        }
    } else {
        FileSurfaces::default()
    };
    let out = format!("{}.{}", out.display(), world.rank());
    let mut m = match DistributedMesh::load(&world, mesh, &file) {
        Ok(m) => m,
        Err(e) => {
            // Every rank returns the same error (the loader's agreement step).
            std::fs::write(out, format!("error {e}\n")).unwrap();
            return;
        }
    };
    // How many ranks hold each node: ones summed over the ranks sharing it.
    let mut holders = vec![1.0; 3 * m.local.coords.len()];
    m.exchange.sum_shared(&mut holders).unwrap();
    let text = rank_report(&m.local, &holders);
    std::fs::write(out, text).unwrap();
    drop(m);
    drop(petsc);
}

/// Signed volume of the tetrahedron (a, b, c, d): det[b-a, c-a, d-a] / 6.
pub fn tet_volume(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> f64 {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let w = [d[0] - a[0], d[1] - a[1], d[2] - a[2]];
    (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
        + u[2] * (v[0] * w[1] - v[1] * w[0]))
        / 6.0
}

/// FNV-1a (64 bits) over every field a mesh of hexahedra alone had before tetrahedra were
/// read, and the exchange's result: equal fingerprints, equal `LocalMesh`es.
fn hex_fingerprint(l: &LocalMesh, holders: &[f64]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |x: u64| {
        for b in x.to_le_bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    l.coords.iter().flatten().for_each(|x| eat(x.to_bits()));
    l.node_id.iter().for_each(|&x| eat(x));
    l.owned.iter().for_each(|&x| eat(x as u64));
    l.node_surfaces.iter().for_each(|&x| eat(x as u64));
    l.surface_tags.iter().for_each(|&x| eat(x as u64));
    for n in &l.surface_normals {
        eat(n.is_some() as u64);
        n.iter().flatten().for_each(|x| eat(x.to_bits()));
    }
    l.elems.iter().flatten().for_each(|&x| eat(x as u64));
    l.elem_id.iter().for_each(|&x| eat(x));
    l.elem_block.iter().for_each(|&x| eat(x as u64));
    l.elem_key.iter().flatten().for_each(|&x| eat(x));
    eat(l.global_nodes);
    eat(l.global_elems);
    l.reordered.iter().for_each(|&x| eat(x as u64));
    holders.iter().for_each(|x| eat(x.to_bits()));
    h
}

/// A rank's part in global terms, one item a line (parsed by [`RankPart::parse`]).
fn rank_report(l: &LocalMesh, holders: &[f64]) -> String {
    let g = |v: u32| l.node_id[v as usize];
    let mut s = format!(
        "counts {} {} {} {}\nfp {}\nreordered {} {}\n",
        l.global_nodes,
        l.global_elems,
        l.global_hexes,
        l.global_tets,
        hex_fingerprint(l, holders),
        l.reordered[0],
        l.reordered[1]
    );
    for (e, c) in l.tets.iter().enumerate() {
        let x = |k: usize| l.coords[c[k] as usize];
        let vol = tet_volume(x(0), x(1), x(2), x(3));
        let n = c.map(g);
        s += &format!(
            "tet {} {} {} {} {} {} {:?}\n",
            l.tet_id[e], l.tet_block[e], n[0], n[1], n[2], n[3], vol
        );
    }
    for (e, c) in l.elems.iter().enumerate() {
        let n: Vec<String> = c.iter().map(|&v| g(v).to_string()).collect();
        s += &format!("hex {} {} {}\n", l.elem_id[e], l.elem_block[e], n.join(" "));
    }
    for v in 0..l.coords.len() {
        let tags: Vec<String> = (0..l.surface_tags.len())
            .filter(|&k| l.node_surfaces[v] >> k & 1 == 1)
            .map(|k| l.surface_tags[k].to_string())
            .collect();
        s += &format!(
            "node {} {} {} {}\n",
            l.node_id[v],
            l.owned[v] as u8,
            holders[3 * v],
            tags.join(",")
        );
    }
    s
}

/// What one rank wrote.
#[derive(Default)]
struct RankPart {
    counts: [u64; 4],
    fingerprint: u64,
    /// Whether the elements were reordered and the nodes renumbered (`LocalMesh::reordered`).
    reordered: String,
    /// The loader's error, when it failed.
    error: Option<String>,
    /// id -> (block, global node ids in the element's order, volume).
    tets: Vec<(u64, i32, Vec<u64>, f64)>,
    hexes: Vec<(u64, i32, Vec<u64>)>,
    /// global id -> (owned, holders, surface tags).
    nodes: Vec<(u64, bool, f64, BTreeSet<i32>)>,
}

impl RankPart {
    fn parse(text: &str) -> RankPart {
        let mut p = RankPart::default();
        for line in text.lines() {
            let w: Vec<&str> = line.split(' ').collect();
            let ids = |r: std::ops::Range<usize>| -> Vec<u64> {
                w[r].iter().map(|x| x.parse().unwrap()).collect()
            };
            match w[0] {
                "counts" => p.counts = ids(1..5).try_into().unwrap(),
                "fp" => p.fingerprint = w[1].parse().unwrap(),
                "reordered" => p.reordered = w[1..].join(" "),
                "error" => p.error = Some(w[1..].join(" ")),
                "tet" => p.tets.push((
                    w[1].parse().unwrap(),
                    w[2].parse().unwrap(),
                    ids(3..7),
                    w[7].parse().unwrap(),
                )),
                "hex" => p
                    .hexes
                    .push((w[1].parse().unwrap(), w[2].parse().unwrap(), ids(3..11))),
                "node" => p.nodes.push((
                    w[1].parse().unwrap(),
                    w[2] == "1",
                    w[3].parse().unwrap(),
                    w[4].split(',')
                        .filter(|t| !t.is_empty())
                        .map(|t| t.parse().unwrap())
                        .collect(),
                )),
                other => panic!("unexpected line kind {other}"),
            }
        }
        p
    }
}

/// Runs the child on `mesh` at `np` ranks and reads back every rank's part.
fn run_child(mesh: &Path, np: usize) -> Vec<RankPart> {
    let out = mesh.with_extension(format!("np{np}"));
    for r in 0..np {
        let _ = std::fs::remove_file(format!("{}.{r}", out.display()));
    }
    let session = mesh.with_extension(format!("mpi{np}"));
    std::fs::create_dir_all(&session).expect("a session directory for mpirun");
    let o = Command::new("timeout")
        .args(["300", "mpirun", "-np", &np.to_string()])
        .args(["-x", "TET_MESH_CHILD", "-x", "TET_MESH_OUT"])
        .arg(std::env::current_exe().unwrap())
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("OMPI_MCA_rmaps_base_oversubscribe", "1")
        // a session directory base of this run's own (concurrent mpiruns sharing
        // /tmp/ompi.<host>.<uid> can fail to start: tests/src/lib.rs, `session_base`)
        .env("OMPI_MCA_orte_tmpdir_base", &session)
        .env("TET_MESH_CHILD", mesh)
        .env("TET_MESH_OUT", &out)
        .output()
        .expect("mpirun");
    assert!(
        o.status.success(),
        "child on {} at np {np} failed:\n{}{}",
        mesh.display(),
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (0..np)
        .map(|r| {
            let t = std::fs::read_to_string(format!("{}.{r}", out.display())).unwrap();
            RankPart::parse(&t)
        })
        .collect()
}

/// The hexahedron mesh's fingerprints at np 1, 2 and 3 (each rank's, in rank order), recorded
/// with the code before tetrahedra were read (commit 03858be): the mesh file is written by
/// this test ([`write_hex_mesh`]), so they depend on no mesher.
const HEX_FINGERPRINTS: [&[u64]; 3] = [
    &[7805631387003909543],
    &[6961290353845931315, 7512168593380721133],
    &[
        2685349867534415332,
        10389714385966801774,
        17444627836496482233,
    ],
];

/// A mesh of hexahedra alone gives, rank by rank, the `LocalMesh` (and ghost exchange) it gave
/// before tetrahedra were read, and agrees with its file.
fn hexahedra_alone_as_before(dir: &Path) {
    let mesh = dir.join("hexes.msh");
    write_hex_mesh(&mesh);
    let file = MshFile::read(&mesh);
    for np in 1..=3 {
        let parts = run_child(&mesh, np);
        let got: Vec<u64> = parts.iter().map(|p| p.fingerprint).collect();
        println!("hexes np {np}: fingerprints {got:?}");
        assert_eq!(
            got,
            HEX_FINGERPRINTS[np - 1],
            "np {np}: the hexahedra-only LocalMesh changed"
        );
        check_against_file(&file, &parts, np);
    }
}

/// gmsh's default tetrahedra in a box of 1 x 0.7 x 0.5 (about a thousand).
const TET_BOX: &str = r#"SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1.0, 0.7, 0.5};
Mesh.MeshSizeMax = 0.2;
Physical Volume(1) = {1};
Physical Surface(11) = {1};
Physical Surface(12) = {5, 6};
"#;

/// A transfinite, recombined box of 3^3 hexahedra (1 x 0.8 x 0.6) and, 0.5 away, a box of
/// tetrahedra (0.9 x 0.7 x 0.5): two volumes that share no face (a hexahedron and a
/// tetrahedron cannot share one conformingly). Surfaces 11 and 12 each take a face of both.
const MIXED: &str = r#"SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1.0, 0.8, 0.6};
Box(2) = {1.5, 0, 0, 0.9, 0.7, 0.5};
s1[] = Boundary{Volume{1};};
c1[] = Unique(Abs(Boundary{Surface{s1[]};}));
Transfinite Curve{c1[]} = 4;
Transfinite Surface{s1[]};
Recombine Surface{s1[]};
Transfinite Volume{1};
Mesh.MeshSizeMax = 0.2;
Physical Volume(1) = {1};
Physical Volume(2) = {2};
Physical Surface(11) = {1, 7};
Physical Surface(12) = {6, 12};
"#;

/// At np 1, 2 and 3: the checks against the file ([`check_against_file`]); the tetrahedra's
/// total volume `box_volume` to 1e-12 relative (about a thousand positive terms in id order:
/// their rounding is below 1e-13 relative); and each tetrahedron's sorted global nodes, and
/// that sum bit for bit, the same at every rank count (the same coordinates, the same order).
fn check_tet_mesh(mesh: &Path, box_volume: f64, want: [u64; 2]) {
    let file = MshFile::read(mesh);
    assert_eq!([file.count(HEX), file.count(TET)], want, "gmsh's mesh");
    let mut first: Option<Whole> = None;
    for np in 1..=3 {
        let parts = run_child(mesh, np);
        let whole = check_against_file(&file, &parts, np);
        let rel = (whole.tet_volume - box_volume).abs() / box_volume;
        println!(
            "{} np {np}: {} tetrahedra on ranks {:?} (reordered, renumbered: {:?}), volume {:?} (rel. error {rel:.1e})",
            mesh.display(),
            whole.tet_nodes.len(),
            parts.iter().map(|p| p.tets.len()).collect::<Vec<_>>(),
            parts.iter().map(|p| p.reordered.as_str()).collect::<Vec<_>>(),
            whole.tet_volume
        );
        assert!(rel <= 1e-12, "np {np}: tetrahedra's volume off by {rel:e}");
        if let Some(f) = &first {
            assert_eq!(
                whole.tet_nodes, f.tet_nodes,
                "np {np}: tetrahedra differ from np 1"
            );
            assert_eq!(
                whole.tet_volume.to_bits(),
                f.tet_volume.to_bits(),
                "np {np}: volume"
            );
        } else {
            first = Some(whole);
        }
    }
}

fn tetrahedra_alone(dir: &Path) {
    let mesh = gmsh(dir, "tets", TET_BOX);
    let ntet = MshFile::read(&mesh).count(TET);
    assert!(ntet > 500, "gmsh made {ntet} tetrahedra");
    check_tet_mesh(&mesh, 1.0 * 0.7 * 0.5, [0, ntet]);
}

fn tetrahedra_beside_hexahedra(dir: &Path) {
    let mesh = gmsh(dir, "mixed", MIXED);
    let ntet = MshFile::read(&mesh).count(TET);
    assert!(ntet > 100, "gmsh made {ntet} tetrahedra");
    check_tet_mesh(&mesh, 0.9 * 0.7 * 0.5, [27, ntet]);
}

/// Prisms (extruded triangles, gmsh's `Recombine` of a triangle's layers): 12 of them.
const PRISMS: &str = r#"Point(1) = {0, 0, 0}; Point(2) = {1, 0, 0}; Point(3) = {0, 1, 0};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 1};
Curve Loop(1) = {1, 2, 3}; Plane Surface(1) = {1};
Transfinite Curve{1, 2, 3} = 3;
v[] = Extrude{0, 0, 1}{Surface{1}; Layers{2}; Recombine;};
Physical Volume(1) = {v[1]};
"#;

/// A mesh of prisms is refused on every rank with one line that names the first prism and
/// the counts of each kind (the driver splits prisms into hexahedra before this read).
fn prisms_refused(dir: &Path) {
    let mesh = gmsh(dir, "prisms", PRISMS);
    assert_eq!(MshFile::read(&mesh).count(6), 12, "gmsh's prisms");
    for np in [1, 2] {
        for (r, p) in run_child(&mesh, np).iter().enumerate() {
            let e = p.error.as_deref().unwrap_or("(loaded)");
            println!("prisms np {np} rank {r}: {e}");
            assert!(
                e.contains("element 0 is a prism (0 hexahedra, 0 tetrahedra, 12 other cells)"),
                "np {np} rank {r}: {e}"
            );
        }
    }
}
