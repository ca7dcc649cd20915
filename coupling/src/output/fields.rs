//! `fields.h5` (HDF5 through MPI-IO, every rank writing its own rows) and its XDMF index.
//!
//! Rows are ordered by global id (row r holds id r), so that `elements/connectivity`, which holds
//! node ids, indexes `nodes/position` directly and ParaView draws the mesh from the `.xmf`.
//! Particles are ordered by their dense index and `particles/id` holds the ids the user gave
//! (`ParticleFrame::labels`: the particle file's, docs/scene.md).
//! Before writing, each field is moved to the rank that owns its id range, which then writes
//! its contiguous hyperslab, a bounded number of rows at a time ([`super::by_id`]).
use super::by_id::{Plan, RowFn, CHUNK_ROWS};
use super::OutputError;
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use ndarray::{s, ArrayView1, ArrayView2};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Global sizes of what a frame holds.
#[derive(Debug, Clone, Copy, Default)]
pub struct GlobalCounts {
    /// Nodes (ids 0..nodes).
    pub nodes: u64,
    /// Elements (ids 0..elements).
    pub elements: u64,
    /// Particles (ids 0..particles).
    pub particles: u64,
}

/// A frame's column: values the caller holds, or a function that makes row i's value (the
/// row of `ids[i]`) when the column is written, straight into the buffer that sends it (so that
/// a frame makes no copy of a column).
#[derive(Clone, Copy)]
pub enum Values<'a, T> {
    /// Held by the caller.
    Held(&'a [T]),
    /// Row i's value, made when written.
    Made(&'a dyn Fn(usize) -> T),
}

impl<T: Copy> Values<'_, T> {
    fn at(&self, i: usize) -> T {
        match self {
            Values::Held(s) => s[i],
            Values::Made(f) => f(i),
        }
    }
}

/// This rank's owned nodes for a frame.
pub struct NodeFrame<'a> {
    /// Global ids.
    pub ids: &'a [u64],
    /// Current coordinates.
    pub position: Values<'a, [f64; 3]>,
    /// Displacements.
    pub displacement: Option<Values<'a, [f64; 3]>>,
    /// Velocities.
    pub velocity: Option<Values<'a, [f64; 3]>>,
}

/// This rank's elements for a frame.
pub struct ElementFrame<'a> {
    /// Global ids.
    pub ids: &'a [u64],
    /// Node ids, gmsh/VTK hexahedron order.
    pub connectivity: Connectivity<'a>,
    /// Stress xx,yy,zz,xy,yz,zx.
    pub stress: Option<Values<'a, [f64; 6]>>,
    /// Equivalent plastic strain.
    pub plastic_strain: Option<Values<'a, f64>>,
    /// Pressure.
    pub pressure: Option<Values<'a, f64>>,
    /// Temperature, K (NaN where the material keeps none).
    pub temperature: Option<Values<'a, f64>>,
    /// 1 for a failed (eroded) element, else 0.
    pub failed: Option<Values<'a, f64>>,
    /// Owning rank.
    pub rank: Option<&'a [i32]>,
}

/// The elements' nodes as global node ids: given, or each element's local nodes through a
/// table of global ids (nothing element-sized kept between frames for it).
#[derive(Clone, Copy)]
pub enum Connectivity<'a> {
    /// Global node ids per element.
    Ids(&'a [[u64; 8]]),
    /// Local node indices per element, and the global id of each local node.
    Local {
        /// Local node indices per element.
        nodes: &'a [[u32; 8]],
        /// Global id of each local node.
        ids: &'a [u64],
    },
    /// Each element's local nodes, made when written (a tetrahedron among hexahedra as a
    /// collapsed hexahedron), and the global id of each local node.
    Made {
        /// Local node indices of element i.
        nodes: &'a dyn Fn(usize) -> [u32; 8],
        /// Global id of each local node.
        ids: &'a [u64],
    },
}

/// This rank's particles for a frame.
pub struct ParticleFrame<'a> {
    /// Dense indices 0..N over all ranks (the rows).
    pub ids: &'a [u64],
    /// The ids written to `particles/id` (the particle file's ids), in the order of `ids`;
    /// None: the dense indices.
    pub labels: Option<&'a [u64]>,
    /// Positions.
    pub position: &'a [[f64; 3]],
    /// Velocities.
    pub velocity: Option<&'a [[f64; 3]]>,
    /// Densities.
    pub density: Option<&'a [f64]>,
    /// Pressures.
    pub pressure: Option<&'a [f64]>,
    /// Smoothing lengths.
    pub h: Option<&'a [f64]>,
    /// Cauchy stress xx,yy,zz,xy,yz,zx (runs with solid particles; a fluid's -p I).
    pub stress: Option<&'a [[f64; 6]]>,
    /// Equivalent plastic strain (runs with solid particles; 0 for a fluid).
    pub plastic_strain: Option<&'a [f64]>,
    /// 1 for a failed particle, else 0 (runs with solid particles).
    pub failed: Option<&'a [f64]>,
    /// Temperature, K (runs with solid particles; NaN where the material keeps none).
    pub temperature: Option<&'a [f64]>,
    /// Owning rank.
    pub rank: Option<&'a [i32]>,
}

/// One column of a frame for [`FieldWriter::write_set`]: name, width, the function that writes
/// a local row's values (called when the column is sent, chunk by chunk), integer or not.
type Column<'a> = (&'a str, usize, Box<RowFn<'a>>, bool);

/// A column whose row i is `f(i)`, `N` wide.
fn rows<'a, const N: usize>(f: impl Fn(usize) -> [f64; N] + 'a) -> Box<RowFn<'a>> {
    Box::new(move |i, out: &mut [f64]| out.copy_from_slice(&f(i)))
}

/// A column whose row i is the one value `f(i)`.
fn scalar<'a>(f: impl Fn(usize) -> f64 + 'a) -> Box<RowFn<'a>> {
    Box::new(move |i, out: &mut [f64]| out[0] = f(i))
}

/// One dataset of a frame as the XDMF index needs to know it.
#[derive(serde::Serialize, serde::Deserialize)]
struct Item {
    path: String,
    name: String,
    cols: usize,
    int: bool,
}

/// Frames written so far (for the XDMF index).
#[derive(serde::Serialize, serde::Deserialize)]
struct FrameIndex {
    name: String,
    time: f64,
    node_items: Vec<Item>,
    elem_items: Vec<Item>,
    particle_items: Vec<Item>,
    /// Particles in the frame (0 in an index written before particles could be born: then
    /// the writer's count).
    #[serde(default)]
    particles: u64,
}

/// Writes field frames to `fields.h5` and keeps `fields.xmf` up to date.
pub struct FieldWriter {
    comm: SimpleCommunicator,
    file: hdf5::File,
    dir: PathBuf,
    counts: GlobalCounts,
    fields: Vec<String>,
    frames: Vec<FrameIndex>,
    bytes: u64,
    chunk_rows: u64,
}

impl FieldWriter {
    /// Creates `dir/fields.h5` (collective). `fields` are the `[output] fields` to write besides
    /// ids, positions and connectivity.
    pub fn create(
        comm: &SimpleCommunicator,
        dir: &Path,
        counts: GlobalCounts,
        fields: &[String],
    ) -> Result<FieldWriter, OutputError> {
        let raw = comm.as_raw();
        let file = hdf5::File::with_options()
            .with_fapl(|p| p.mpio(raw, None))
            .create(dir.join("fields.h5"))?;
        file.create_group("frames")?;
        Ok(FieldWriter {
            comm: comm.duplicate(),
            file,
            dir: dir.to_path_buf(),
            counts,
            fields: fields.to_vec(),
            frames: Vec::new(),
            bytes: 0,
            chunk_rows: CHUNK_ROWS,
        })
    }

    /// The frames written so far, as text a restart gives back to [`FieldWriter::reopen`].
    pub fn index(&self) -> String {
        serde_json::to_string(&self.frames).expect("the index serialises")
    }

    /// Reopens `dir/fields.h5` to continue a run (collective): the frames of `index` are
    /// kept, any frame written after it (the run went on past its checkpoint) is removed, and
    /// the XDMF index is rewritten.
    pub fn reopen(
        comm: &SimpleCommunicator,
        dir: &Path,
        counts: GlobalCounts,
        fields: &[String],
        index: &str,
    ) -> Result<FieldWriter, OutputError> {
        let frames: Vec<FrameIndex> = serde_json::from_str(index)
            .map_err(|e| OutputError::Layout(format!("checkpoint's frame index: {e}")))?;
        let raw = comm.as_raw();
        let file = hdf5::File::with_options()
            .with_fapl(|p| p.mpio(raw, None))
            .open_rw(dir.join("fields.h5"))?;
        let group = file.group("frames")?;
        let mut names = group.member_names()?;
        names.sort();
        for n in names {
            if !frames.iter().any(|f| f.name == n) {
                group.unlink(&n)?;
            }
        }
        let w = FieldWriter {
            comm: comm.duplicate(),
            file,
            dir: dir.to_path_buf(),
            counts,
            fields: fields.to_vec(),
            frames,
            bytes: 0,
            chunk_rows: CHUNK_ROWS,
        };
        if comm.rank() == 0 {
            w.write_xdmf()?;
        }
        Ok(w)
    }

    /// Bytes of field data this rank wrote.
    pub fn bytes_written(&self) -> u64 {
        self.bytes
    }

    fn wants(&self, f: &str) -> bool {
        self.fields.iter().any(|x| x == f)
    }

    /// Sets the rows a rank receives and writes per chunk (default `CHUNK_ROWS`); the
    /// output self-test sets a few, so that its small sets take several chunks.
    pub fn set_chunk_rows(&mut self, rows: u64) {
        self.chunk_rows = rows.max(1);
    }

    /// Moves each column to the ranks that write it and writes it as a dataset, one column
    /// and within it one chunk of rows at a time ([`super::by_id`]: a frame's transient is a
    /// chunk of its widest column). `cols`: (name, width, row function, is_integer). Row r of
    /// every dataset holds id r; a column named `id` replaces the row ids as the `id` dataset.
    fn write_set(
        &mut self,
        group: &hdf5::Group,
        n: u64,
        ids: &[u64],
        cols: Vec<Column>,
    ) -> Result<Vec<Item>, OutputError> {
        // Agreed on by all ranks before any dataset is created, so that a bad id set fails
        // everywhere instead of leaving some ranks inside a collective call.
        let Some(plan) = Plan::new(&self.comm, n, ids, self.chunk_rows) else {
            return Err(OutputError::Layout(format!(
                "{}: the ids over all ranks are not 0..{n} each exactly once",
                group.name()
            )));
        };
        if !cols.iter().any(|c| c.0 == "id") {
            // Row r holds id r, so this rank's ids are its rows' numbers: nothing to move.
            let put = put::<i64>(group, "id", n, 1, &plan, |k| {
                let (a, b) = plan.range(k);
                (a..b).map(|i| i as i64).collect()
            });
            self.bytes += self.agree(put, group, "id")?;
        }
        let mut items = Vec::new();
        for (name, w, row, int) in cols {
            let comm = &self.comm;
            let put = if int {
                put::<i64>(group, name, n, w, &plan, |k| {
                    plan.values(comm, ids, k, w, &*row, |v| v as i64)
                })
            } else {
                put::<f64>(group, name, n, w, &plan, |k| {
                    plan.values(comm, ids, k, w, &*row, |v| v)
                })
            };
            self.bytes += self.agree(put, group, name)?;
            if name != "id" {
                items.push(Item {
                    path: format!("{}/{}", group.name(), name),
                    name: name.to_string(),
                    cols: w,
                    int,
                });
            }
        }
        Ok(items)
    }

    /// The particles' count over all ranks from the next frame on (failed elements became
    /// particles).
    pub fn set_particle_count(&mut self, n: u64) {
        self.counts.particles = n;
    }

    /// Every rank's verdict on a dataset written (collective), so that a failure on one rank
    /// stops all of them before the next dataset's exchanges.
    fn agree(
        &self,
        put: Result<u64, OutputError>,
        group: &hdf5::Group,
        name: &str,
    ) -> Result<u64, OutputError> {
        let mut all_ok = false;
        self.comm
            .all_reduce_into(&put.is_ok(), &mut all_ok, SystemOperation::logical_and());
        match put {
            Ok(_) if !all_ok => Err(OutputError::Layout(format!(
                "{}/{name}: another rank could not write it",
                group.name()
            ))),
            put => put,
        }
    }

    /// The columns of a frame's nodes.
    fn node_columns<'a>(&self, nf: &'a NodeFrame) -> Vec<Column<'a>> {
        let mut cols: Vec<Column> = vec![("position", 3, rows(|i| nf.position.at(i)), false)];
        if let (true, Some(d)) = (self.wants("displacement"), nf.displacement) {
            cols.push(("displacement", 3, rows(move |i| d.at(i)), false));
        }
        if let (true, Some(v)) = (self.wants("velocity"), nf.velocity) {
            cols.push(("velocity", 3, rows(move |i| v.at(i)), false));
        }
        cols
    }

    /// The columns of a frame's elements.
    fn element_columns<'a>(&self, ef: &'a ElementFrame) -> Vec<Column<'a>> {
        // ids < 2^53 are exact in f64.
        let conn = match ef.connectivity {
            Connectivity::Ids(c) => rows(move |e| c[e].map(|n| n as f64)),
            Connectivity::Local { nodes, ids } => {
                rows(move |e| nodes[e].map(|n| ids[n as usize] as f64))
            }
            Connectivity::Made { nodes, ids } => {
                rows(move |e| nodes(e).map(|n| ids[n as usize] as f64))
            }
        };
        let mut cols: Vec<Column> = vec![("connectivity", 8, conn, true)];
        if let (true, Some(s)) = (self.wants("stress"), ef.stress) {
            cols.push(("stress", 6, rows(move |e| s.at(e)), false));
        }
        if let (true, Some(s)) = (self.wants("plastic_strain"), ef.plastic_strain) {
            cols.push(("plastic_strain", 1, scalar(move |e| s.at(e)), false));
        }
        if let (true, Some(s)) = (self.wants("pressure"), ef.pressure) {
            cols.push(("pressure", 1, scalar(move |e| s.at(e)), false));
        }
        if let (true, Some(s)) = (self.wants("failed"), ef.failed) {
            cols.push(("failed", 1, scalar(move |e| s.at(e)), false));
        }
        if let (true, Some(s)) = (self.wants("temperature"), ef.temperature) {
            cols.push(("temperature", 1, scalar(move |e| s.at(e)), false));
        }
        if let (true, Some(s)) = (self.wants("rank"), ef.rank) {
            cols.push(("rank", 1, scalar(move |e| f64::from(s[e])), true));
        }
        cols
    }

    /// The columns of a frame's particles.
    fn particle_columns<'a>(&self, pf: &'a ParticleFrame) -> Vec<Column<'a>> {
        let mut cols: Vec<Column> = vec![("position", 3, rows(|i| pf.position[i]), false)];
        if let Some(l) = pf.labels {
            // ids < 2^53 are exact in f64.
            cols.push(("id", 1, scalar(move |i| l[i] as f64), true));
        }
        if let (true, Some(v)) = (self.wants("velocity"), pf.velocity) {
            cols.push(("velocity", 3, rows(move |i| v[i]), false));
        }
        if let (true, Some(v)) = (self.wants("density"), pf.density) {
            cols.push(("density", 1, scalar(move |i| v[i]), false));
        }
        if let (true, Some(v)) = (self.wants("pressure"), pf.pressure) {
            cols.push(("pressure", 1, scalar(move |i| v[i]), false));
        }
        if let Some(v) = pf.h {
            cols.push(("h", 1, scalar(move |i| v[i]), false));
        }
        if let (true, Some(v)) = (self.wants("stress"), pf.stress) {
            cols.push(("stress", 6, rows(move |i| v[i]), false));
        }
        if let (true, Some(v)) = (self.wants("plastic_strain"), pf.plastic_strain) {
            cols.push(("plastic_strain", 1, scalar(move |i| v[i]), false));
        }
        if let (true, Some(v)) = (self.wants("failed"), pf.failed) {
            cols.push(("failed", 1, scalar(move |i| v[i]), false));
        }
        if let (true, Some(v)) = (self.wants("temperature"), pf.temperature) {
            cols.push(("temperature", 1, scalar(move |i| v[i]), false));
        }
        if let (true, Some(v)) = (self.wants("rank"), pf.rank) {
            cols.push(("rank", 1, scalar(move |i| f64::from(v[i])), true));
        }
        cols
    }

    /// Writes a frame at `time` (collective).
    pub fn write_frame(
        &mut self,
        time: f64,
        nodes: Option<&NodeFrame>,
        elements: Option<&ElementFrame>,
        particles: Option<&ParticleFrame>,
    ) -> Result<(), OutputError> {
        // What the frame holds must agree over the ranks: every HDF5 create below is collective.
        let mask = [nodes.is_some(), elements.is_some(), particles.is_some()]
            .iter()
            .enumerate()
            .fold(0i32, |m, (k, &has)| m | (i32::from(has) << k));
        let (mut lo_mask, mut hi_mask) = (0i32, 0i32);
        self.comm
            .all_reduce_into(&mask, &mut lo_mask, SystemOperation::bitwise_and());
        self.comm
            .all_reduce_into(&mask, &mut hi_mask, SystemOperation::bitwise_or());
        if lo_mask != hi_mask {
            return Err(OutputError::Layout(
                "write_frame: nodes, elements and particles must be given on every rank or on none"
                    .into(),
            ));
        }
        let name = format!("{:06}", self.frames.len());
        let g = self.file.group("frames")?.create_group(&name)?;
        g.new_attr::<f64>().create("time")?.write_scalar(&time)?;
        let mut node_items = Vec::new();
        if let Some(nf) = nodes {
            let gg = g.create_group("nodes")?;
            let cols = self.node_columns(nf);
            node_items = self.write_set(&gg, self.counts.nodes, nf.ids, cols)?;
        }
        let mut elem_items = Vec::new();
        if let Some(ef) = elements {
            let gg = g.create_group("elements")?;
            let cols = self.element_columns(ef);
            elem_items = self.write_set(&gg, self.counts.elements, ef.ids, cols)?;
        }
        let mut particle_items = Vec::new();
        if let Some(pf) = particles {
            let gg = g.create_group("particles")?;
            let cols = self.particle_columns(pf);
            particle_items = self.write_set(&gg, self.counts.particles, pf.ids, cols)?;
        }
        self.file.flush()?;
        self.frames.push(FrameIndex {
            name,
            time,
            node_items,
            elem_items,
            particle_items,
            particles: self.counts.particles,
        });
        // Rank 0 writes the index; every rank returns its verdict, so none goes on alone.
        let xdmf = if self.comm.rank() == 0 {
            self.write_xdmf()
        } else {
            Ok(())
        };
        let mut xdmf_ok = i32::from(xdmf.is_ok());
        self.comm.process_at_rank(0).broadcast_into(&mut xdmf_ok);
        xdmf?;
        if xdmf_ok == 0 {
            return Err(OutputError::Layout(
                "rank 0 could not write fields.xmf".into(),
            ));
        }
        Ok(())
    }

    /// Finishes the file (the XDMF index is already current).
    pub fn finish(self) -> Result<(), OutputError> {
        self.file.flush()?;
        Ok(())
    }

    /// Rewrites `fields.xmf` (rank 0) for the frames so far: one temporal collection for the
    /// mesh, one for the particles, each frame a grid whose data items name `fields.h5` paths.
    /// Written to a temporary file and renamed, so a reader never sees half an index.
    fn write_xdmf(&self) -> Result<(), OutputError> {
        let c = self.counts;
        let mut x = String::from(
            "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n<Xdmf Version=\"3.0\">\n <Domain>\n",
        );
        let any_particles = c.particles > 0 || self.frames.iter().any(|f| f.particles > 0);
        for (kind, has) in [("mesh", c.elements > 0), ("particles", any_particles)] {
            if !has {
                continue;
            }
            let _ = writeln!(
                x,
                "  <Grid Name=\"{kind}\" GridType=\"Collection\" CollectionType=\"Temporal\">"
            );
            for f in &self.frames {
                // A frame without this part (e.g. particles only) has no grid in its collection.
                let body = if kind == "mesh" {
                    mesh_grid(f, c)
                } else {
                    particle_grid(f, c)
                };
                let Some(body) = body else { continue };
                let _ = writeln!(
                    x,
                    "   <Grid Name=\"{kind} {}\" GridType=\"Uniform\">\n      <Time Value=\"{:e}\"/>",
                    f.name, f.time
                );
                x.push_str(&body);
                x.push_str("   </Grid>\n");
            }
            x.push_str("  </Grid>\n");
        }
        x.push_str(" </Domain>\n</Xdmf>\n");
        let tmp = self.dir.join("fields.xmf.tmp");
        std::fs::write(&tmp, x)?;
        std::fs::rename(tmp, self.dir.join("fields.xmf"))?;
        Ok(())
    }
}

/// Writes one dataset of `n` rows, `w` values each, chunk by chunk: `chunk(k)` gives this
/// rank's rows of chunk k (collective: the create, and whatever exchange `chunk` makes; each
/// rank writes its rows independently). Returns the bytes this rank wrote. Every chunk is
/// asked for on every rank even after a failure here, so that no other rank waits in one.
fn put<T: hdf5::H5Type>(
    group: &hdf5::Group,
    name: &str,
    n: u64,
    w: usize,
    plan: &Plan,
    mut chunk: impl FnMut(usize) -> Vec<T>,
) -> Result<u64, OutputError> {
    let n = n as usize;
    let ds = if w == 1 {
        group.new_dataset::<T>().shape([n]).create(name)
    } else {
        group.new_dataset::<T>().shape([n, w]).create(name)
    };
    let mut failed = None;
    let mut bytes = 0;
    for k in 0..plan.chunks {
        let vals = chunk(k);
        bytes += 8 * vals.len() as u64;
        if let (Ok(ds), None) = (&ds, &failed) {
            failed = write_rows(ds, plan.range(k), w, &vals).err();
        }
    }
    match (ds, failed) {
        (Err(e), _) | (_, Some(e)) => Err(e.into()),
        _ => Ok(bytes),
    }
}

/// Writes `vals` (rows [a, b), `w` values each) into `ds`.
fn write_rows<T: hdf5::H5Type>(
    ds: &hdf5::Dataset,
    (a, b): (u64, u64),
    w: usize,
    vals: &[T],
) -> hdf5::Result<()> {
    let (a, b) = (a as usize, b as usize);
    if b == a {
        return Ok(());
    }
    if w == 1 {
        ds.write_slice(ArrayView1::from(vals), s![a..b])
    } else {
        let v = ArrayView2::from_shape((b - a, w), vals).expect("a chunk holds rows x w values");
        ds.write_slice(v, s![a..b, ..])
    }
}

/// An XDMF `DataItem` reading `it` (n rows) from `fields.h5`.
fn data_item(it: &Item, n: u64) -> String {
    let dims = if it.cols == 1 {
        format!("{n}")
    } else {
        format!("{n} {}", it.cols)
    };
    let ty = if it.int { "Int" } else { "Float" };
    format!(
        "<DataItem Dimensions=\"{dims}\" NumberType=\"{ty}\" Precision=\"8\" Format=\"HDF\">fields.h5:{}</DataItem>",
        it.path
    )
}

/// An XDMF `Attribute` for `it` (n rows) centred on `center` (`Node` or `Cell`). Stress (6
/// columns) is a `Matrix`, not XDMF's `Tensor6`, whose component order differs from ours.
fn attribute(it: &Item, n: u64, center: &str) -> String {
    let kind = match it.cols {
        1 => "Scalar",
        3 => "Vector",
        _ => "Matrix",
    };
    format!(
        "      <Attribute Name=\"{}\" AttributeType=\"{kind}\" Center=\"{center}\">\n        {}\n      </Attribute>\n",
        it.name,
        data_item(it, n)
    )
}

/// The body of frame `f`'s mesh grid (hexahedra, node and cell attributes), if it has a mesh.
fn mesh_grid(f: &FrameIndex, c: GlobalCounts) -> Option<String> {
    let conn = f.elem_items.iter().find(|i| i.name == "connectivity")?;
    let pos = f.node_items.iter().find(|i| i.name == "position")?;
    let mut x = format!(
        "      <Topology TopologyType=\"Hexahedron\" NumberOfElements=\"{}\">\n        {}\n      </Topology>\n",
        c.elements,
        data_item(conn, c.elements)
    );
    let _ = writeln!(
        x,
        "      <Geometry GeometryType=\"XYZ\">\n        {}\n      </Geometry>",
        data_item(pos, c.nodes)
    );
    for it in f.node_items.iter().filter(|i| i.name != "position") {
        x.push_str(&attribute(it, c.nodes, "Node"));
    }
    for it in f.elem_items.iter().filter(|i| i.name != "connectivity") {
        x.push_str(&attribute(it, c.elements, "Cell"));
    }
    Some(x)
}

/// The body of frame `f`'s particle grid (one vertex per particle), if it has particles.
fn particle_grid(f: &FrameIndex, mut c: GlobalCounts) -> Option<String> {
    if f.particles > 0 {
        c.particles = f.particles;
    }
    if c.particles == 0 {
        return None;
    }
    let pos = f.particle_items.iter().find(|i| i.name == "position")?;
    let mut x = format!(
        "      <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{}\" NodesPerElement=\"1\"/>\n",
        c.particles
    );
    let _ = writeln!(
        x,
        "      <Geometry GeometryType=\"XYZ\">\n        {}\n      </Geometry>",
        data_item(pos, c.particles)
    );
    for it in f.particle_items.iter().filter(|i| i.name != "position") {
        x.push_str(&attribute(it, c.particles, "Node"));
    }
    Some(x)
}
