//! The data of one box: contact nodes (struct-of-arrays), contact faces, and the `Pod` records the
//! parallel layer moves between boxes as bytes.
//!
//! Communication roles (for the parallel layer): every field of [`NodeRecord`] travels with a node
//! when it moves to another box or is copied there as a face node; every field of [`FaceRecord`]
//! travels with a face (ghost copies included). Push-back results go back to the owners as
//! `(node gid, force)` pairs ([`crate::PushBack::contributions`]), summed there.

use rustc_hash::FxHashMap as HashMap;

use bytemuck::{Pod, Zeroable};

use crate::geometry::Quad;
use crate::vec3::V3;
use crate::ContactError;

/// [`NodeRecord::flags`] bit: the node is an SPH particle centre.
pub const FLAG_PARTICLE: u32 = 1;
/// [`NodeRecord::flags`] bit: the node belongs to a master body of a one-pass search
/// ([`crate::SearchParams::one_pass`]; `[contact] passes = 1`, `master`).
pub const FLAG_MASTER: u32 = 2;

/// One contact node as bytes (104 bytes, no padding).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct NodeRecord {
    /// Global id (the mesh node id; particles get ids distinct from every mesh node).
    pub gid: u64,
    /// Body id (see [`crate::surfaces()`]); ignored for particles.
    pub body: u32,
    /// Bit set of `FLAG_*`.
    pub flags: u32,
    /// Lumped mass, kg; `f64::INFINITY` for a node whose motion is prescribed (it takes reactions
    /// but does not move).
    pub mass: f64,
    /// Contact radius, m: a particle's radius, 0 for a mesh node.
    pub radius: f64,
    /// Position at the start of the step, m.
    pub x0: V3,
    /// Predicted position at the end of the step, before contact, m.
    pub x1: V3,
    /// Velocity at the start of the step, m/s (central difference: `v^n = v^{n+1/2} - a^n dt /
    /// 2`, the velocity against which the step's energy balance measures the push-back; where
    /// nothing accelerates the node, `(x1 - x0) / dt`).
    pub v: V3,
}

/// One contact face as bytes (48 bytes, no padding).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct FaceRecord {
    /// Global face id.
    pub gid: u64,
    /// Global ids of the four corner nodes, counter-clockwise seen from outside.
    pub nodes: [u64; 4],
    /// Body id of the element the face bounds.
    pub body: u32,
    /// Always 0 (keeps the record free of padding).
    pub reserved: u32,
}

/// Axis-aligned bounding box.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Aabb {
    /// Lower corner.
    pub min: V3,
    /// Upper corner.
    pub max: V3,
}

impl Aabb {
    /// The empty box (its union with anything is that thing).
    pub const EMPTY: Aabb = Aabb {
        min: [f64::INFINITY; 3],
        max: [f64::NEG_INFINITY; 3],
    };

    /// Grows the box to hold `p`.
    pub fn include(&mut self, p: V3) {
        for (k, c) in p.iter().enumerate() {
            self.min[k] = self.min[k].min(*c);
            self.max[k] = self.max[k].max(*c);
        }
    }

    /// The box grown by `d` on every side.
    pub fn grown(&self, d: f64) -> Aabb {
        Aabb {
            min: [self.min[0] - d, self.min[1] - d, self.min[2] - d],
            max: [self.max[0] + d, self.max[1] + d, self.max[2] + d],
        }
    }

    /// Whether the closed boxes intersect.
    pub fn overlaps(&self, o: &Aabb) -> bool {
        (0..3).all(|k| self.min[k] <= o.max[k] && o.min[k] <= self.max[k])
    }
}

/// The contact nodes of one box, struct-of-arrays. Entries `0..n_owned` are the nodes this box
/// searches for (each node is searched by exactly one box); entries after are copies held only
/// because a face in the box uses them. Reordering or removing goes through [`ContactNodes::push`]
/// and [`ContactNodes::clear`], which touch every field.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactNodes {
    /// Global ids.
    pub gid: Vec<u64>,
    /// Body ids.
    pub body: Vec<u32>,
    /// Masses, kg (`INFINITY`: prescribed motion).
    pub mass: Vec<f64>,
    /// Contact radius, m (0 for mesh nodes).
    pub radius: Vec<f64>,
    /// Whether the node is an SPH particle centre.
    pub particle: Vec<bool>,
    /// Whether the node belongs to a master body ([`FLAG_MASTER`]).
    pub master: Vec<bool>,
    /// Start-of-step positions.
    pub x0: Vec<V3>,
    /// Predicted end-of-step positions.
    pub x1: Vec<V3>,
    /// Start-of-step velocities ([`NodeRecord::v`]).
    pub v: Vec<V3>,
    /// Number of leading entries this box searches for.
    pub n_owned: usize,
}

impl ContactNodes {
    /// Number of nodes (owned and copies).
    pub fn len(&self) -> usize {
        self.gid.len()
    }

    /// Whether there is no node.
    pub fn is_empty(&self) -> bool {
        self.gid.is_empty()
    }

    /// Removes every node.
    pub fn clear(&mut self) {
        self.gid.clear();
        self.body.clear();
        self.mass.clear();
        self.radius.clear();
        self.particle.clear();
        self.master.clear();
        self.x0.clear();
        self.x1.clear();
        self.v.clear();
        self.n_owned = 0;
    }

    /// Appends a node (it is owned only if `n_owned` is then raised over it).
    pub fn push(&mut self, r: &NodeRecord) {
        self.gid.push(r.gid);
        self.body.push(r.body);
        self.mass.push(r.mass);
        self.radius.push(r.radius);
        self.particle.push(r.flags & FLAG_PARTICLE != 0);
        self.master.push(r.flags & FLAG_MASTER != 0);
        self.x0.push(r.x0);
        self.x1.push(r.x1);
        self.v.push(r.v);
    }

    /// Sets node `i`'s mass, radius, start and end positions and velocity from `r` (a kept
    /// box's node updated in place for the next step).
    pub fn set_motion(&mut self, i: usize, r: &NodeRecord) {
        self.mass[i] = r.mass;
        self.radius[i] = r.radius;
        self.x0[i] = r.x0;
        self.x1[i] = r.x1;
        self.v[i] = r.v;
    }

    /// Node `i` as a record.
    pub fn record(&self, i: usize) -> NodeRecord {
        NodeRecord {
            gid: self.gid[i],
            body: self.body[i],
            flags: if self.particle[i] { FLAG_PARTICLE } else { 0 }
                | if self.master[i] { FLAG_MASTER } else { 0 },
            mass: self.mass[i],
            radius: self.radius[i],
            x0: self.x0[i],
            x1: self.x1[i],
            v: self.v[i],
        }
    }
}

/// The contact faces of one box. `nodes[f]` are indices into the box's [`ContactNodes`] (the box
/// holds a copy of every node a face uses); `node_gid[f]` the same nodes by global id.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactFaces {
    /// Global face ids.
    pub gid: Vec<u64>,
    /// Corner nodes as box node indices.
    pub nodes: Vec<[u32; 4]>,
    /// Corner nodes as global ids.
    pub node_gid: Vec<[u64; 4]>,
    /// Body ids.
    pub body: Vec<u32>,
}

impl ContactFaces {
    /// Number of faces.
    pub fn len(&self) -> usize {
        self.gid.len()
    }

    /// Whether there is no face.
    pub fn is_empty(&self) -> bool {
        self.gid.is_empty()
    }

    /// Face `f` as a record.
    pub fn record(&self, f: usize) -> FaceRecord {
        FaceRecord {
            gid: self.gid[f],
            nodes: self.node_gid[f],
            body: self.body[f],
            reserved: 0,
        }
    }
}

/// Which configuration of a face.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Config {
    /// Start of step (`x0`).
    Start,
    /// Predicted end of step (`x1`).
    End,
}

/// Everything one box holds: nodes and faces.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactBox {
    /// Contact nodes (owned first).
    pub nodes: ContactNodes,
    /// Contact faces.
    pub faces: ContactFaces,
}

impl ContactBox {
    /// Builds a box from records: `nodes[..n_owned]` are searched for, the rest are copies. Every
    /// face's corner must be among `nodes`; node gids must be distinct.
    pub fn from_records(
        nodes: &[NodeRecord],
        n_owned: usize,
        faces: &[FaceRecord],
    ) -> Result<ContactBox, ContactError> {
        if n_owned > nodes.len() {
            return Err(ContactError::OwnedCount {
                n_owned,
                len: nodes.len(),
            });
        }
        let mut b = ContactBox::default();
        let mut index: HashMap<u64, u32> =
            HashMap::with_capacity_and_hasher(nodes.len(), Default::default());
        for (i, r) in nodes.iter().enumerate() {
            if index.insert(r.gid, i as u32).is_some() {
                return Err(ContactError::DuplicateNode { gid: r.gid });
            }
            b.nodes.push(r);
        }
        b.nodes.n_owned = n_owned;
        for f in faces {
            let mut local = [0u32; 4];
            for (k, g) in f.nodes.iter().enumerate() {
                local[k] = *index.get(g).ok_or(ContactError::MissingFaceNode {
                    face: f.gid,
                    node: *g,
                })?;
            }
            b.faces.gid.push(f.gid);
            b.faces.nodes.push(local);
            b.faces.node_gid.push(f.nodes);
            b.faces.body.push(f.body);
        }
        Ok(b)
    }

    /// Face `f` in configuration `c`.
    pub fn quad(&self, f: usize, c: Config) -> Quad {
        let x = match c {
            Config::Start => &self.nodes.x0,
            Config::End => &self.nodes.x1,
        };
        let n = self.faces.nodes[f];
        Quad {
            x: [
                x[n[0] as usize],
                x[n[1] as usize],
                x[n[2] as usize],
                x[n[3] as usize],
            ],
        }
    }

    /// Largest contact radius of the box's nodes (0 without particles).
    pub fn max_radius(&self) -> f64 {
        self.nodes.radius.iter().fold(0.0, |a: f64, &r| a.max(r))
    }
}
