//! `fields.h5` (HDF5 through MPI-IO, every rank writing its own rows) and its XDMF index.
//!
//! Rows are ordered by global id (row r holds id r), so that `elements/connectivity`, which holds
//! node ids, indexes `nodes/position` directly and ParaView draws the mesh from the `.xmf`.
//! Particles are ordered by their dense index and `particles/id` holds the ids the user gave
//! (`ParticleFrame::labels`: the particle file's, SCENE.md).
//! Before writing, each field is moved to the rank that owns its id range
//! ([`redistribute_by_id`]), which then writes one contiguous hyperslab.
use super::OutputError;
use mpi::collective::SystemOperation;
use mpi::datatype::{Partition, PartitionMut};
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

/// A frame's column: values the caller holds, or a function that makes them when the column is
/// written (so that a frame holds one column's copy at a time, not one of each).
#[derive(Clone, Copy)]
pub enum Values<'a, T> {
    /// Held by the caller.
    Held(&'a [T]),
    /// Made when written.
    Made(&'a dyn Fn() -> Vec<T>),
}

impl<T: Clone> Values<'_, T> {
    fn get(&self) -> std::borrow::Cow<'_, [T]> {
        match self {
            Values::Held(s) => std::borrow::Cow::Borrowed(s),
            Values::Made(f) => std::borrow::Cow::Owned(f()),
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
    pub pressure: Option<&'a [f64]>,
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
    /// Owning rank.
    pub rank: Option<&'a [i32]>,
}

/// The rows [lo, hi) of `n` ids that rank `r` of `p` writes.
fn block(n: u64, p: usize, r: usize) -> (u64, u64) {
    (n * r as u64 / p as u64, n * (r as u64 + 1) / p as u64)
}

/// Moves rows (`ids[i]`, `values[i*w..(i+1)*w]`) to the rank whose id block holds them and
/// returns this rank's block sorted by id: (ids, values). Collective. Every id in 0..n must
/// appear exactly once over all ranks.
///
/// Takes `values` by value and frees each buffer as soon as the next holds its data (the send
/// buffer after the exchange), so that at most two copies of the rows are alive at once: a
/// frame's peak memory (measured on a 110,592-hexahedron block: the first frame raised the
/// peak resident set by 94 MB with five copies alive).
pub fn redistribute_by_id(
    comm: &SimpleCommunicator,
    n: u64,
    ids: &[u64],
    values: Vec<f64>,
    w: usize,
) -> (Vec<u64>, Vec<f64>) {
    let p = comm.size() as usize;
    let dest = |id: u64| -> usize {
        // The block of id: the largest r with lo(r) <= id.
        let mut r = ((id as u128 * p as u128) / n.max(1) as u128) as usize;
        r = r.min(p - 1);
        while r + 1 < p && block(n, p, r + 1).0 <= id {
            r += 1;
        }
        while r > 0 && block(n, p, r).0 > id {
            r -= 1;
        }
        r
    };
    let stride = w + 1;
    let mut counts = vec![0i32; p];
    for &id in ids {
        counts[dest(id)] += stride as i32;
    }
    let mut displs = vec![0i32; p];
    for r in 1..p {
        displs[r] = displs[r - 1] + counts[r - 1];
    }
    let mut send = vec![0.0f64; ids.len() * stride];
    let mut fill = displs.clone();
    for (i, &id) in ids.iter().enumerate() {
        let d = dest(id);
        let o = fill[d] as usize;
        // ids < 2^53 are exact in f64.
        send[o] = id as f64;
        send[o + 1..o + stride].copy_from_slice(&values[i * w..(i + 1) * w]);
        fill[d] += stride as i32;
    }
    drop(values);
    let mut rcounts = vec![0i32; p];
    comm.all_to_all_into(&counts[..], &mut rcounts[..]);
    let mut rdispls = vec![0i32; p];
    for r in 1..p {
        rdispls[r] = rdispls[r - 1] + rcounts[r - 1];
    }
    let total = rcounts.iter().sum::<i32>() as usize;
    let mut recv = vec![0.0f64; total];
    {
        let sp = Partition::new(&send[..], &counts[..], &displs[..]);
        let mut rp = PartitionMut::new(&mut recv[..], &rcounts[..], &rdispls[..]);
        comm.all_to_all_varcount_into(&sp, &mut rp);
    }
    drop(send);
    let m = total / stride;
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by_key(|&i| recv[i * stride] as u64);
    let mut out_ids = Vec::with_capacity(m);
    let mut out_vals = Vec::with_capacity(m * w);
    for i in order {
        out_ids.push(recv[i * stride] as u64);
        out_vals.extend_from_slice(&recv[i * stride + 1..(i + 1) * stride]);
    }
    (out_ids, out_vals)
}

/// One column of a frame for [`FieldWriter::write_set`]: name, width, the values (made only when
/// the column is written, so a frame holds one column's copies at a time), integer or not.
type Column<'a> = (&'a str, usize, Box<dyn FnOnce() -> Vec<f64> + 'a>, bool);

/// A column's values, made when written.
fn lazy<'a>(f: impl FnOnce() -> Vec<f64> + 'a) -> Box<dyn FnOnce() -> Vec<f64> + 'a> {
    Box::new(f)
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

    /// Writes one dataset of `shape` = (n rows, w columns) from this rank's block starting at
    /// row `lo` (collective create); returns the bytes written.
    fn put(
        group: &hdf5::Group,
        name: &str,
        shape: (u64, usize),
        lo: u64,
        vals: &[f64],
        int: bool,
    ) -> Result<u64, OutputError> {
        let (n, w) = shape;
        let rows = (vals.len() / w.max(1)) as u64;
        let hi = lo + rows;
        let n = n as usize;
        if int {
            let ints: Vec<i64> = vals.iter().map(|v| *v as i64).collect();
            if w == 1 {
                let ds = group.new_dataset::<i64>().shape([n]).create(name)?;
                if rows > 0 {
                    ds.write_slice(ArrayView1::from(&ints[..]), s![lo as usize..hi as usize])?;
                }
            } else {
                let ds = group.new_dataset::<i64>().shape([n, w]).create(name)?;
                if rows > 0 {
                    let a = ArrayView2::from_shape((rows as usize, w), &ints[..]).unwrap();
                    ds.write_slice(a, s![lo as usize..hi as usize, ..])?;
                }
            }
        } else if w == 1 {
            let ds = group.new_dataset::<f64>().shape([n]).create(name)?;
            if rows > 0 {
                ds.write_slice(ArrayView1::from(vals), s![lo as usize..hi as usize])?;
            }
        } else {
            let ds = group.new_dataset::<f64>().shape([n, w]).create(name)?;
            if rows > 0 {
                let a = ArrayView2::from_shape((rows as usize, w), vals).unwrap();
                ds.write_slice(a, s![lo as usize..hi as usize, ..])?;
            }
        }
        Ok(8 * vals.len() as u64)
    }

    /// Redistributes each column by id and writes it as a dataset, one column at a time (a
    /// frame's memory: each column is freed once written, so the frame's transient is a few
    /// copies of its widest column, not of the whole frame). `cols`: (name, width, values,
    /// is_integer). A column named `id` replaces the row ids as the `id` dataset.
    fn write_set(
        &mut self,
        group: &hdf5::Group,
        n: u64,
        ids: &[u64],
        cols: Vec<Column>,
    ) -> Result<Vec<Item>, OutputError> {
        let p = self.comm.size() as usize;
        let (lo, hi) = block(n, p, self.comm.rank() as usize);
        let has_id = cols.iter().any(|c| c.0 == "id");
        let mut items = Vec::new();
        for (k, (name, cw, make, int)) in cols.into_iter().enumerate() {
            let (bids, col) = redistribute_by_id(&self.comm, n, ids, make(), cw);
            if k == 0 {
                // Row r must hold id r: this rank's block must be exactly lo..hi, once each.
                // Agreed on by all ranks before any dataset is created, so that a bad id set
                // fails everywhere instead of leaving some ranks inside a collective call.
                let covered =
                    bids.len() as u64 == hi - lo && bids.iter().zip(lo..hi).all(|(a, b)| *a == b);
                let mut all_covered = false;
                self.comm.all_reduce_into(
                    &covered,
                    &mut all_covered,
                    SystemOperation::logical_and(),
                );
                if !all_covered {
                    return Err(OutputError::Layout(format!(
                        "{}: the ids over all ranks are not 0..{n} each exactly once",
                        group.name()
                    )));
                }
                if !has_id {
                    let idf: Vec<f64> = bids.iter().map(|&i| i as f64).collect();
                    self.bytes += Self::put(group, "id", (n, 1), lo, &idf, true)?;
                }
            }
            self.bytes += Self::put(group, name, (n, cw), lo, &col, int)?;
            if name == "id" {
                continue;
            }
            items.push(Item {
                path: format!("{}/{}", group.name(), name),
                name: name.to_string(),
                cols: cw,
                int,
            });
        }
        Ok(items)
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
        let flat3 = |v: &[[f64; 3]]| v.as_flattened().to_vec();
        let mut node_items = Vec::new();
        if let Some(nf) = nodes {
            let mut cols = vec![(
                "position",
                3,
                lazy(move || flat3(&nf.position.get())),
                false,
            )];
            if let (true, Some(d)) = (self.wants("displacement"), nf.displacement) {
                cols.push(("displacement", 3, lazy(move || flat3(&d.get())), false));
            }
            if let (true, Some(v)) = (self.wants("velocity"), nf.velocity) {
                cols.push(("velocity", 3, lazy(move || flat3(&v.get())), false));
            }
            let gg = g.create_group("nodes")?;
            node_items = self.write_set(&gg, self.counts.nodes, nf.ids, cols)?;
        }
        let mut elem_items = Vec::new();
        if let Some(ef) = elements {
            let conn = lazy(|| match ef.connectivity {
                Connectivity::Ids(c) => c.iter().flatten().map(|&c| c as f64).collect(),
                Connectivity::Local { nodes, ids } => nodes
                    .iter()
                    .flatten()
                    .map(|&n| ids[n as usize] as f64)
                    .collect(),
            });
            let mut cols = vec![("connectivity", 8, conn, true)];
            if let (true, Some(s)) = (self.wants("stress"), ef.stress) {
                cols.push((
                    "stress",
                    6,
                    lazy(move || s.get().as_flattened().to_vec()),
                    false,
                ));
            }
            if let (true, Some(s)) = (self.wants("plastic_strain"), ef.plastic_strain) {
                cols.push((
                    "plastic_strain",
                    1,
                    lazy(move || s.get().into_owned()),
                    false,
                ));
            }
            if let (true, Some(s)) = (self.wants("pressure"), ef.pressure) {
                cols.push(("pressure", 1, lazy(move || s.to_vec()), false));
            }
            if let (true, Some(s)) = (self.wants("rank"), ef.rank) {
                cols.push((
                    "rank",
                    1,
                    lazy(move || s.iter().map(|&r| r as f64).collect()),
                    true,
                ));
            }
            let gg = g.create_group("elements")?;
            elem_items = self.write_set(&gg, self.counts.elements, ef.ids, cols)?;
        }
        let mut particle_items = Vec::new();
        if let Some(pf) = particles {
            let mut cols = vec![("position", 3, lazy(move || flat3(pf.position)), false)];
            if let Some(l) = pf.labels {
                // ids < 2^53 are exact in f64.
                cols.push((
                    "id",
                    1,
                    lazy(move || l.iter().map(|&i| i as f64).collect()),
                    true,
                ));
            }
            if let (true, Some(v)) = (self.wants("velocity"), pf.velocity) {
                cols.push(("velocity", 3, lazy(move || flat3(v)), false));
            }
            if let (true, Some(v)) = (self.wants("density"), pf.density) {
                cols.push(("density", 1, lazy(move || v.to_vec()), false));
            }
            if let (true, Some(v)) = (self.wants("pressure"), pf.pressure) {
                cols.push(("pressure", 1, lazy(move || v.to_vec()), false));
            }
            if let Some(v) = pf.h {
                cols.push(("h", 1, lazy(move || v.to_vec()), false));
            }
            if let (true, Some(v)) = (self.wants("rank"), pf.rank) {
                cols.push((
                    "rank",
                    1,
                    lazy(move || v.iter().map(|&r| r as f64).collect()),
                    true,
                ));
            }
            let gg = g.create_group("particles")?;
            particle_items = self.write_set(&gg, self.counts.particles, pf.ids, cols)?;
        }
        self.file.flush()?;
        self.frames.push(FrameIndex {
            name,
            time,
            node_items,
            elem_items,
            particle_items,
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
        for (kind, has) in [("mesh", c.elements > 0), ("particles", c.particles > 0)] {
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
fn particle_grid(f: &FrameIndex, c: GlobalCounts) -> Option<String> {
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
