//! Self-test of the output under mpirun (`tdyn_selftest output DIR`): a small hex grid and a
//! few particles, scattered over the ranks in an order unrelated to their ids, written as two
//! frames; rank 0 then reads `fields.h5` back and checks every row by id (exact equality), the
//! `time` attributes, that `fields.xmf` is balanced XML whose every data path exists in
//! `fields.h5` with the dimensions it states, the history CSV round trip and `report.json`.
use coupling::output::Values;
use coupling::output::{
    Connectivity, ElementFrame, FieldWriter, GlobalCounts, History, NodeFrame, OutputError,
    ParticleFrame, Report, StageStats,
};
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::path::Path;

/// Elements along x, y, z.
const CELLS: [u64; 3] = [3, 2, 2];
/// SPH particles.
const N_PARTICLES: u64 = 10;
/// Rows a rank receives and writes per chunk (`FieldWriter::set_chunk_rows`): few, so that
/// every set here takes several chunks: at 3 ranks 4 elements each (two chunks, the second of
/// one row), particles 3, 3 and 4 (one rank two chunks, the others one and an empty one).
const CHUNK_ROWS: u64 = 3;
/// Frame times; not exactly representable in binary, so the attribute must round-trip bits.
const FRAME_TIMES: [f64; 2] = [0.0, 1.0 / 3.0e4];
/// Fields asked for: all but `plastic_strain`, which is given and must not be written.
const REQUESTED: [&str; 6] = [
    "displacement",
    "velocity",
    "stress",
    "pressure",
    "density",
    "rank",
];

/// The three parts of a frame.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Part {
    Nodes,
    Elements,
    Particles,
}

impl Part {
    fn group(self) -> &'static str {
        match self {
            Part::Nodes => "nodes",
            Part::Elements => "elements",
            Part::Particles => "particles",
        }
    }
}

/// One dataset the test writes: its part, name, columns, integer type, and in which frames it
/// must exist in `fields.h5`.
struct Column {
    part: Part,
    name: &'static str,
    width: usize,
    int: bool,
    in_frame: [bool; 2],
}

/// Every dataset, with when it must be present (given and requested), or never (not requested).
const COLUMNS: [Column; 16] = [
    col(Part::Nodes, "id", 1, true, [true, true]),
    col(Part::Nodes, "position", 3, false, [true, true]),
    col(Part::Nodes, "displacement", 3, false, [true, true]),
    col(Part::Nodes, "velocity", 3, false, [true, false]),
    col(Part::Elements, "id", 1, true, [true, true]),
    col(Part::Elements, "connectivity", 8, true, [true, true]),
    col(Part::Elements, "stress", 6, false, [true, false]),
    col(Part::Elements, "plastic_strain", 1, false, [false, false]),
    col(Part::Elements, "pressure", 1, false, [true, true]),
    col(Part::Elements, "rank", 1, true, [true, true]),
    col(Part::Particles, "id", 1, true, [true, true]),
    col(Part::Particles, "position", 3, false, [true, true]),
    col(Part::Particles, "velocity", 3, false, [true, true]),
    col(Part::Particles, "density", 1, false, [true, false]),
    col(Part::Particles, "pressure", 1, false, [true, true]),
    col(Part::Particles, "h", 1, false, [true, true]),
];

const fn col(part: Part, name: &'static str, width: usize, int: bool, f: [bool; 2]) -> Column {
    Column {
        part,
        name,
        width,
        int,
        in_frame: f,
    }
}

/// The test's grid: nodes (CELLS+1) per axis, numbered x fastest.
struct Grid;

impl Grid {
    fn nodes() -> u64 {
        CELLS.iter().map(|c| c + 1).product()
    }
    fn elements() -> u64 {
        CELLS.iter().product()
    }
    fn node(i: u64, j: u64, k: u64) -> u64 {
        i + (CELLS[0] + 1) * (j + (CELLS[1] + 1) * k)
    }
    /// Element `e`'s nodes in gmsh/VTK hexahedron order.
    fn connectivity(e: u64) -> [u64; 8] {
        let (i, j, k) = (
            e % CELLS[0],
            (e / CELLS[0]) % CELLS[1],
            e / (CELLS[0] * CELLS[1]),
        );
        let n = Grid::node;
        [
            n(i, j, k),
            n(i + 1, j, k),
            n(i + 1, j + 1, k),
            n(i, j + 1, k),
            n(i, j, k + 1),
            n(i + 1, j, k + 1),
            n(i + 1, j + 1, k + 1),
            n(i, j + 1, k + 1),
        ]
    }
}

/// The rank that owns item `id` of `part` among `p`: scattered, not in id blocks; all the
/// particles sit on the last rank, so the other ranks have none.
fn owner(part: Part, id: u64, p: u64) -> u64 {
    match part {
        Part::Nodes => (id * 7 + 3) % p,
        Part::Elements => (id * 5 + 1) % p,
        Part::Particles => p - 1,
    }
}

/// The ids of `part` that rank `me` of `p` owns, in a scrambled order (a multiplicative
/// permutation of 0..n).
fn owned_ids(part: Part, n: u64, me: u64, p: u64) -> Vec<u64> {
    let mult = [7u64, 11, 13, 17]
        .into_iter()
        .find(|m| !n.is_multiple_of(*m))
        .unwrap_or(1);
    (0..n)
        .map(|k| (k * mult + 5) % n)
        .filter(|&id| owner(part, id, p) == me)
        .collect()
}

/// The value written in column `comp` of dataset `name` of `part`, row `id`, in `frame`.
fn expected(part: Part, name: &str, frame: usize, id: u64, comp: usize, p: u64) -> f64 {
    match name {
        "id" => id as f64,
        "connectivity" => Grid::connectivity(id)[comp] as f64,
        "rank" => owner(part, id, p) as f64,
        _ => {
            // Distinct for every (part, field, row, column, frame), and not short in binary.
            let field = COLUMNS
                .iter()
                .position(|c| c.part == part && c.name == name)
                .unwrap_or(COLUMNS.len()) as f64;
            (id as f64 + 0.1 * comp as f64 + 100.0 * field) * (1.0 + frame as f64 / 3.0)
        }
    }
}

/// Rows of `W` columns of `expected` for `ids`.
fn rows<const W: usize>(
    part: Part,
    name: &str,
    frame: usize,
    ids: &[u64],
    p: u64,
) -> Vec<[f64; W]> {
    ids.iter()
        .map(|&id| std::array::from_fn(|c| expected(part, name, frame, id, c, p)))
        .collect()
}

/// One-column values of `expected` for `ids`.
fn scalars(part: Part, name: &str, frame: usize, ids: &[u64], p: u64) -> Vec<f64> {
    ids.iter()
        .map(|&id| expected(part, name, frame, id, 0, p))
        .collect()
}

fn global_count(part: Part) -> u64 {
    match part {
        Part::Nodes => Grid::nodes(),
        Part::Elements => Grid::elements(),
        Part::Particles => N_PARTICLES,
    }
}

/// Writes the two frames from this rank's scrambled share.
fn write_fields(comm: &SimpleCommunicator, dir: &Path) -> Result<(), OutputError> {
    let p = comm.size() as u64;
    let me = comm.rank() as u64;
    let counts = GlobalCounts {
        nodes: Grid::nodes(),
        elements: Grid::elements(),
        particles: N_PARTICLES,
    };
    let fields: Vec<String> = REQUESTED.iter().map(|s| s.to_string()).collect();
    let mut writer = FieldWriter::create(comm, dir, counts, &fields)?;
    writer.set_chunk_rows(CHUNK_ROWS);
    let node_ids = owned_ids(Part::Nodes, counts.nodes, me, p);
    let elem_ids = owned_ids(Part::Elements, counts.elements, me, p);
    let part_ids = owned_ids(Part::Particles, counts.particles, me, p);
    let conn: Vec<[u64; 8]> = elem_ids.iter().map(|&e| Grid::connectivity(e)).collect();
    let elem_rank: Vec<i32> = elem_ids
        .iter()
        .map(|&e| owner(Part::Elements, e, p) as i32)
        .collect();
    let part_rank = vec![me as i32; part_ids.len()];
    for (frame, &time) in FRAME_TIMES.iter().enumerate() {
        let first = frame == 0;
        let (n, e, q) = (Part::Nodes, Part::Elements, Part::Particles);
        let pos = rows::<3>(n, "position", frame, &node_ids, p);
        let disp = rows::<3>(n, "displacement", frame, &node_ids, p);
        let vel = rows::<3>(n, "velocity", frame, &node_ids, p);
        let stress = rows::<6>(e, "stress", frame, &elem_ids, p);
        let eps = scalars(e, "plastic_strain", frame, &elem_ids, p);
        let pe = scalars(e, "pressure", frame, &elem_ids, p);
        let ppos = rows::<3>(q, "position", frame, &part_ids, p);
        let pvel = rows::<3>(q, "velocity", frame, &part_ids, p);
        let rho = scalars(q, "density", frame, &part_ids, p);
        let pp = scalars(q, "pressure", frame, &part_ids, p);
        let h = scalars(q, "h", frame, &part_ids, p);
        let nodes = NodeFrame {
            ids: &node_ids,
            position: Values::Held(&pos),
            // Made row by row when written (as the run's nodal columns are).
            displacement: Some(Values::Made(&|i| disp[i])),
            velocity: first.then_some(Values::Held(&vel[..])),
        };
        let elements = ElementFrame {
            ids: &elem_ids,
            connectivity: Connectivity::Ids(&conn),
            stress: first.then_some(Values::Held(&stress[..])),
            plastic_strain: Some(Values::Held(&eps)),
            pressure: Some(Values::Held(&pe)),
            temperature: None,
            failed: None,
            rank: Some(&elem_rank),
        };
        let particles = ParticleFrame {
            ids: &part_ids,
            labels: None,
            position: &ppos,
            velocity: Some(&pvel),
            density: first.then_some(&rho[..]),
            pressure: Some(&pp),
            h: Some(&h),
            stress: None,
            plastic_strain: None,
            failed: None,
            temperature: None,
            rank: Some(&part_rank),
        };
        writer.write_frame(time, Some(&nodes), Some(&elements), Some(&particles))?;
    }
    writer.finish()
}

/// Whether `path` (absolute, `/a/b/c`) names an object in `file`, testing each level.
fn exists(file: &hdf5::File, path: &str) -> bool {
    let mut at = String::new();
    for part in path.split('/').filter(|s| !s.is_empty()) {
        let parent = if at.is_empty() { "/" } else { &at };
        match file.group(parent) {
            Ok(g) if g.link_exists(part) => {}
            _ => return false,
        }
        at.push('/');
        at.push_str(part);
    }
    true
}

/// Reads `fields.h5` and checks every dataset row by id.
fn check_fields(dir: &Path, p: u64) -> Result<usize, String> {
    let h5 = |e: hdf5::Error| e.to_string();
    let file = hdf5::File::open(dir.join("fields.h5")).map_err(h5)?;
    let mut names = file
        .group("frames")
        .and_then(|g| g.member_names())
        .map_err(h5)?;
    names.sort();
    if names != ["000000", "000001"] {
        return Err(format!("frames are {names:?}, expected 000000 and 000001"));
    }
    let mut checked = 0;
    for (frame, &time) in FRAME_TIMES.iter().enumerate() {
        let g = format!("/frames/{frame:06}");
        let t: f64 = file
            .group(&g)
            .and_then(|g| g.attr("time"))
            .and_then(|a| a.read_scalar())
            .map_err(h5)?;
        if t.to_bits() != time.to_bits() {
            return Err(format!("{g}: time {t:e}, expected {time:e}"));
        }
        for c in &COLUMNS {
            let path = format!("{g}/{}/{}", c.part.group(), c.name);
            let present = exists(&file, &path);
            if present != c.in_frame[frame] {
                return Err(format!(
                    "{path}: present {present}, expected {}",
                    c.in_frame[frame]
                ));
            }
            if !present {
                continue;
            }
            let n = global_count(c.part);
            let ds = file.dataset(&path).map_err(h5)?;
            let shape: Vec<usize> = if c.width == 1 {
                vec![n as usize]
            } else {
                vec![n as usize, c.width]
            };
            if ds.shape() != shape {
                return Err(format!(
                    "{path}: shape {:?}, expected {shape:?}",
                    ds.shape()
                ));
            }
            let got: Vec<f64> = if c.int {
                let a = ds.read_dyn::<i64>().map_err(h5)?;
                a.iter().map(|&v| v as f64).collect()
            } else {
                ds.read_dyn::<f64>().map_err(h5)?.iter().copied().collect()
            };
            for (k, v) in got.iter().enumerate() {
                let (row, comp) = ((k / c.width) as u64, k % c.width);
                let want = expected(c.part, c.name, frame, row, comp, p);
                if v.to_bits() != want.to_bits() {
                    return Err(format!("{path}[{row}][{comp}] = {v:e}, expected {want:e}"));
                }
                checked += 1;
            }
        }
    }
    // The XDMF index must point at datasets that exist, with their shapes.
    let xmf = std::fs::read_to_string(dir.join("fields.xmf")).map_err(|e| e.to_string())?;
    check_balanced_xml(&xmf)?;
    let refs = data_item_refs(&xmf)?;
    for (dims, path) in &refs {
        if !exists(&file, path) {
            return Err(format!("fields.xmf names {path}, absent from fields.h5"));
        }
        let shape = file.dataset(path).map_err(h5)?.shape();
        if *dims != shape {
            return Err(format!(
                "fields.xmf gives {path} dimensions {dims:?}, fields.h5 has {shape:?}"
            ));
        }
    }
    let (nn, ne, np) = (Grid::nodes(), Grid::elements(), N_PARTICLES);
    let must = [
        format!("TopologyType=\"Hexahedron\" NumberOfElements=\"{ne}\""),
        format!("TopologyType=\"Polyvertex\" NumberOfElements=\"{np}\""),
        format!("Dimensions=\"{ne} 8\""),
        format!("Dimensions=\"{nn} 3\""),
        "GeometryType=\"XYZ\"".to_string(),
        "CollectionType=\"Temporal\"".to_string(),
        "fields.h5:/frames/000001/elements/connectivity<".to_string(),
        "fields.h5:/frames/000001/nodes/position<".to_string(),
        "fields.h5:/frames/000000/nodes/velocity<".to_string(),
        "fields.h5:/frames/000000/elements/stress<".to_string(),
        "fields.h5:/frames/000001/particles/position<".to_string(),
        format!("<Time Value=\"{:e}\"/>", FRAME_TIMES[1]),
    ];
    for m in &must {
        if !xmf.contains(m.as_str()) {
            return Err(format!("fields.xmf lacks {m}"));
        }
    }
    let mesh_grids = xmf.matches("<Grid Name=\"mesh ").count();
    if mesh_grids != FRAME_TIMES.len() {
        return Err(format!(
            "fields.xmf has {mesh_grids} mesh grids, expected 2"
        ));
    }
    if xmf.contains("plastic_strain") {
        return Err("fields.xmf names plastic_strain, which was not requested".into());
    }
    Ok(checked + refs.len())
}

/// Checks that every tag of `xml` is closed in order (`<?..?>`, `<!..>` and `<../>` stand
/// alone).
fn check_balanced_xml(xml: &str) -> Result<(), String> {
    let mut open: Vec<&str> = Vec::new();
    let mut rest = xml;
    while let Some(start) = rest.find('<') {
        let end = rest[start..]
            .find('>')
            .ok_or("fields.xmf: unterminated tag")?
            + start;
        let tag = &rest[start + 1..end];
        rest = &rest[end + 1..];
        if tag.starts_with('?') || tag.starts_with('!') || tag.ends_with('/') {
            continue;
        }
        if let Some(closing) = tag.strip_prefix('/') {
            match open.pop() {
                Some(o) if o == closing.trim() => {}
                o => return Err(format!("fields.xmf: </{closing}> closes {o:?}")),
            }
        } else {
            open.push(tag.split_whitespace().next().unwrap_or(""));
        }
    }
    if !open.is_empty() {
        return Err(format!("fields.xmf: unclosed {open:?}"));
    }
    if !xml.trim_start().starts_with("<?xml") {
        return Err("fields.xmf: no XML declaration".into());
    }
    Ok(())
}

/// The (dimensions, HDF5 path) of every `<DataItem Dimensions=".." ..>fields.h5:PATH</DataItem>`.
fn data_item_refs(xml: &str) -> Result<Vec<(Vec<usize>, String)>, String> {
    let mut out = Vec::new();
    for item in xml.split("<DataItem").skip(1) {
        let dims = item
            .split("Dimensions=\"")
            .nth(1)
            .and_then(|s| s.split('"').next())
            .ok_or("fields.xmf: DataItem without Dimensions")?;
        let dims = dims
            .split_whitespace()
            .map(|d| d.parse::<usize>().map_err(|e| format!("{d}: {e}")))
            .collect::<Result<Vec<_>, _>>()?;
        let body = item
            .split_once('>')
            .and_then(|(_, b)| b.split_once("</DataItem>"))
            .map(|(b, _)| b.trim())
            .ok_or("fields.xmf: DataItem without a body")?;
        let path = body
            .strip_prefix("fields.h5:")
            .ok_or_else(|| format!("fields.xmf: DataItem body {body} is not in fields.h5"))?;
        out.push((dims, path.to_string()));
    }
    if out.is_empty() {
        return Err("fields.xmf has no DataItem".into());
    }
    Ok(out)
}

/// Values whose shortest decimal form is long or extreme.
const AWKWARD: [f64; 8] = [
    0.1,
    1.0 / 3.0,
    -2.5e17,
    1e-300,
    f64::MIN_POSITIVE,
    f64::MAX,
    123_456_789.123_456_79,
    -0.0,
];

/// Rows written to the history: more than one flush interval.
const HISTORY_ROWS: usize = 150;

fn history_row(step: usize) -> [f64; 3] {
    [
        step as f64,
        AWKWARD[step % AWKWARD.len()] * (1.0 + step as f64 / 7.0),
        (step as f64).sqrt(),
    ]
}

/// History CSV: header, then rows that read back bit-identical.
fn write_history(comm: &SimpleCommunicator, dir: &Path) -> Result<(), String> {
    let mut h = History::create(comm, &dir.join("history.csv"), &["step", "time", "dt"])
        .map_err(|e| e.to_string())?;
    for step in 0..HISTORY_ROWS {
        h.row(&history_row(step)).map_err(|e| e.to_string())?;
    }
    h.flush().map_err(|e| e.to_string())
}

fn check_history(dir: &Path) -> Result<usize, String> {
    let text = std::fs::read_to_string(dir.join("history.csv")).map_err(|e| e.to_string())?;
    let mut lines = text.lines();
    if lines.next() != Some("step,time,dt") {
        return Err("history.csv: wrong header".into());
    }
    let mut n = 0;
    for (step, line) in lines.enumerate() {
        let got = line
            .split(',')
            .map(|v| v.parse::<f64>().map_err(|e| format!("{v}: {e}")))
            .collect::<Result<Vec<_>, _>>()?;
        let want = history_row(step);
        if got.len() != want.len()
            || got
                .iter()
                .zip(&want)
                .any(|(a, b)| a.to_bits() != b.to_bits())
        {
            return Err(format!(
                "history.csv row {step}: {got:?}, expected {want:?}"
            ));
        }
        n += 1;
    }
    if n != HISTORY_ROWS {
        return Err(format!("history.csv has {n} rows, expected {HISTORY_ROWS}"));
    }
    Ok(n)
}

/// `StageStats::reduce` and the shape of `report.json` (stages at the top level, extras
/// flattened, missing figures null).
fn check_report(comm: &SimpleCommunicator, dir: &Path) -> Result<(), String> {
    let p = comm.size();
    let me = comm.rank();
    const BYTES_PER_RANK: f64 = 100.0;
    let s = StageStats::reduce(comm, (me + 1) as f64, me as f64, BYTES_PER_RANK);
    // Work 0, 1, .., p-1: max/mean = 2 (or 1 on one rank, where all work is 0).
    let imbalance = if p == 1 { 1.0 } else { 2.0 };
    let want = StageStats {
        wall_s: p as f64,
        imbalance,
        bytes_sent: BYTES_PER_RANK * p as f64,
    };
    if s != want {
        return Err(format!("StageStats::reduce gave {s:?}, expected {want:?}"));
    }
    if me != 0 {
        return Ok(());
    }
    let mut r = Report::new(p as usize, Grid::elements(), Grid::nodes(), 0, 7, 1.5);
    r.fe = Some(s);
    r.stages_run = vec!["fe".into()];
    r.extra.insert("title".into(), "selftest".into());
    r.write(&dir.join("report.json"))
        .map_err(|e| e.to_string())?;
    let text = std::fs::read_to_string(dir.join("report.json")).map_err(|e| e.to_string())?;
    let j: serde_json::Value = serde_json::from_str(&text).map_err(|e| e.to_string())?;
    let ok = j["ranks"] == p
        && j["elements"] == Grid::elements()
        && j["fe"]["wall_s"] == p as f64
        && j["fe"]["imbalance"] == imbalance
        && j["sph"].is_null()
        && j["us_per_particle_step"].is_null()
        && j["title"] == "selftest"
        && j.get("extra").is_none()
        && j["stages_run"][0] == "fe";
    if !ok {
        return Err(format!("report.json: unexpected content\n{text}"));
    }
    Ok(())
}

/// A frame with a node id missing or out of range, or with nodes given on rank 0 only, must
/// fail on every rank (no hang) with [`OutputError::Layout`].
fn check_bad_input(comm: &SimpleCommunicator, dir: &Path) -> Result<(), String> {
    let p = comm.size() as u64;
    let me = comm.rank() as u64;
    let n = Grid::nodes();
    let all = owned_ids(Part::Nodes, n, me, p);
    let missing: Vec<u64> = all.iter().copied().filter(|&id| id != 0).collect();
    expect_layout_error(comm, dir, &missing, true, "a missing node id")?;
    // Node 0's row given an id out of range instead (left out of the exchange by the rank
    // holding it, which must still take part in every chunk's).
    let out: Vec<u64> = all.iter().map(|&id| if id == 0 { n } else { id }).collect();
    expect_layout_error(comm, dir, &out, true, "a node id out of range")?;
    if p > 1 {
        expect_layout_error(comm, dir, &all, me == 0, "nodes given on rank 0 only")?;
    }
    Ok(())
}

/// Writes a frame of nodes `ids` (given on this rank or not) and expects
/// [`OutputError::Layout`]; `what` names the fault in the message otherwise.
fn expect_layout_error(
    comm: &SimpleCommunicator,
    dir: &Path,
    ids: &[u64],
    given: bool,
    what: &str,
) -> Result<(), String> {
    let counts = GlobalCounts {
        nodes: Grid::nodes(),
        ..GlobalCounts::default()
    };
    let pos = rows::<3>(Part::Nodes, "position", 0, ids, comm.size() as u64);
    let nodes = NodeFrame {
        ids,
        position: Values::Held(&pos),
        displacement: None,
        velocity: None,
    };
    let mut w = FieldWriter::create(comm, dir, counts, &[]).map_err(|e| e.to_string())?;
    w.set_chunk_rows(CHUNK_ROWS);
    match w.write_frame(0.0, given.then_some(&nodes), None, None) {
        Err(OutputError::Layout(_)) => Ok(()),
        other => Err(format!("{what} gave {other:?}")),
    }
}

/// Runs the output self-test in `dir` (created if missing) on every rank of `comm`
/// (collective). Returns a summary line, or on every rank the first failure rank 0 found.
pub fn roundtrip_check(comm: &SimpleCommunicator, dir: &Path) -> Result<String, String> {
    let p = comm.size() as u64;
    let me = comm.rank();
    let bad_dir = dir.join("bad_input");
    if me == 0 {
        std::fs::create_dir_all(&bad_dir).map_err(|e| format!("{}: {e}", bad_dir.display()))?;
    }
    comm.barrier();
    write_fields(comm, dir).map_err(|e| format!("writing fields: {e}"))?;
    write_history(comm, dir)?;
    // Every rank reaches the same checks; only rank 0 reads files, then shares the verdict.
    let mut local = check_report(comm, dir);
    comm.barrier();
    let mut summary = String::new();
    if me == 0 && local.is_ok() {
        local = check_fields(dir, p).and_then(|values| {
            let rows = check_history(dir)?;
            summary = format!(
                "output selftest passed at np {p}: {values} field values and XDMF references, \
                 {rows} history rows"
            );
            Ok(())
        });
    }
    let bad = check_bad_input(comm, &bad_dir);
    let failed = i32::from(local.is_err() || bad.is_err());
    let mut any_failed = 0i32;
    comm.all_reduce_into(
        &failed,
        &mut any_failed,
        mpi::collective::SystemOperation::max(),
    );
    local?;
    bad?;
    if any_failed != 0 {
        return Err(format!("rank {me}: another rank failed (see its message)"));
    }
    Ok(summary)
}
