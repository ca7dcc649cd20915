//! The native tetrahedra of a mesh in the explicit step ([`crate::tet`]): their arrays and
//! state, and the two passes of each step.
//!
//! A tetrahedron's volumetric strain rate is the mean over its 4 nodes of each node's rate,
//! theta_a = (sum over the node's tetrahedra of V_mid tr D) / (sum of V_mid), and its density
//! follows the mean of the nodes' volume ratios J_a = (sum of V) / (sum of V0) (Bonet & Burton
//! 1998; `crate::tet`). So a step takes two passes over the tetrahedra:
//!
//! 1. each element's volumes and volume rate ([`tet::rates`]) summed at the nodes;
//! 2. each element's update with the means of its nodes' ratios, its forces summed at the
//!    nodes: groups of consecutive tetrahedra of one material through the lane kernel
//!    (`batch/tet.rs`, [`TetBatch`]: one, four or eight at once, `ExplicitFe::width`), which
//!    computes what [`tet::update`] computes to round-off and gives the same bits at every
//!    width; [`tet::update`] is the tests' reference (`tests/tet_lanes.rs`).
//!
//! Both nodal sums are the canonical-order sums of [`crate::assembly`] (the tetrahedra are in
//! their canonical order, `LocalMesh::tet_key`), so they are the same bits at any rank count.
//! The tetrahedra's forces are summed apart from the hexahedra's and added to them after both
//! sums are complete: each node's force is (hexahedra's sum) + (tetrahedra's sum), the same
//! two ordered sums and the same addition on every rank count.
use crate::assembly::Assembly;
use crate::batch::{self, GroupInverted, LaneMaterial, TetBatch, TetInput, Width};
use crate::blocks::BlockWork;
use crate::hex::HexControls;
use crate::material::Material;
use crate::mesh::{LocalMesh, NodeExchange};
use crate::petsc::PetscError;
use crate::tet::{self, TetAverages, TetState};

/// The native tetrahedra one rank holds.
pub struct TetPart {
    /// Connectivity (local node indices, gmsh order, positive volume).
    pub conn: Vec<[u32; 4]>,
    /// Global element ids.
    pub id: Vec<u64>,
    /// Material index of each tetrahedron.
    pub material: Vec<usize>,

    /// Reference volumes, m^3.
    pub vol0: Vec<f64>,
    /// Stress of each tetrahedron.
    pub state: Vec<TetState>,
    /// Material history values, `stride` per tetrahedron.
    pub mat_state: Vec<f64>,
    stride: usize,
    /// The ordered nodal sums over the tetrahedra.
    assembly: Assembly,
    /// Each node's reference volume over its tetrahedra (sum of V0), m^3; 0 off the
    /// tetrahedra.
    node_vol0: Vec<f64>,
    /// Scratch: the nodal sums of pass 1, then the tetrahedra's nodal forces.
    sums: Vec<[f64; 3]>,
}

/// Pass 2's inputs shared by every group.
struct Pass2<'a> {
    /// Positions at t(n+1), m.
    x: &'a [[f64; 3]],
    /// Velocities at t(n+1/2), m/s.
    v: &'a [[f64; 3]],
    /// The step, s.
    dt: f64,
    /// Each node's [theta_a, J_a] ([`TetPart::node_ratios`]).
    ratios: &'a [[f64; 2]],
    /// The models.
    materials: &'a [Box<dyn Material>],
    /// Their lane forms.
    lanes: &'a [LaneMaterial],
    /// The element controls (bulk viscosity).
    ctl: &'a HexControls,
    /// Tetrahedron t's block element: `offset + t`.
    offset: usize,
}

/// What the tetrahedra's passes found: the smallest stable step and the first inverted one.
#[derive(Debug, Clone, Copy)]
pub struct TetSums {
    /// Smallest stable step (no safety factor), s.
    pub dt_min: f64,
    /// The first inverted tetrahedron: its local index and volume.
    pub inverted: Option<(usize, f64)>,
}

impl TetPart {
    /// The tetrahedra of `mesh` with their materials (`material[i]` indexes `materials`):
    /// reference volumes, initial states, and the lumped masses rho0 V0 / 4 added to `mass3`
    /// in canonical order (collective: the sum over ranks). `Err((i, volume))` names the first
    /// tetrahedron whose reference volume is not positive (after the collective sum).
    pub fn new(
        mesh: &LocalMesh,
        material: Vec<usize>,
        materials: &[Box<dyn Material>],
        stride: usize,
        mass3: &mut [[f64; 3]],
        exchange: &mut NodeExchange,
    ) -> Result<(TetPart, Option<(usize, f64)>), PetscError> {
        let nn = mesh.coords.len();
        let mut assembly = Assembly::new(&mesh.tets, &mesh.tet_key, exchange)?;
        let mut vol0 = Vec::with_capacity(mesh.tets.len());
        let mut mat_state = vec![0.0; mesh.tets.len() * stride];
        let mut sums = vec![[0.0; 3]; nn];
        let mut bad = None;
        for (e, conn) in mesh.tets.iter().enumerate() {
            let xe = gather4(&mesh.coords, conn);
            let (_, v) = tet::gradients(&xe);
            let ok = v > 0.0 && v.is_finite();
            if !ok {
                bad.get_or_insert((e, v));
            }
            let v = if ok { v } else { 0.0 };
            vol0.push(v);
            let me = materials[material[e]].density() * v / 4.0;
            for &n in conn {
                let s = &mut sums[n as usize];
                s[0] += me;
                s[1] += v;
            }
            assembly.record(e, |_| [me, v, 0.0]);
            if stride > 0 {
                materials[material[e]].init_state(&mut mat_state[e * stride..(e + 1) * stride]);
            }
        }
        assembly.finish(&mut sums, exchange)?;
        for (m, s) in mass3.iter_mut().zip(&sums) {
            // Each node's mass: the hexahedra's sum, then the tetrahedra's.
            for c in m.iter_mut() {
                *c += s[0];
            }
        }
        let node_vol0 = sums.iter().map(|s| s[1]).collect();
        let part = TetPart {
            conn: mesh.tets.clone(),
            id: mesh.tet_id.clone(),
            material,
            state: vec![TetState::default(); mesh.tets.len()],
            vol0,
            mat_state,
            stride,
            assembly,
            node_vol0,
            sums,
        };
        Ok((part, bad))
    }

    /// Number of tetrahedra on this rank.
    pub fn len(&self) -> usize {
        self.conn.len()
    }

    /// Whether this rank has none.
    pub fn is_empty(&self) -> bool {
        self.conn.is_empty()
    }

    /// The step's two passes at the positions `x` (t(n+1)) with the velocities `v` (t(n+1/2))
    /// over `dt`; the tetrahedra's nodal forces added to `force` (collective: two ordered sums).
    /// An inverted tetrahedron leaves the states of the others updated but is reported (the
    /// step fails; both sums are still made, so that no rank waits alone).
    ///
    /// `(x, v, dt)`: the positions, velocities and step; `(materials, lanes, width)`: the
    /// models, their lane forms ([`LaneMaterial::new`]) and the element kernel's width;
    /// `(force, blocks, offset)`: the nodal forces, the per-block work (where tetrahedron t is
    /// element `offset + t`, a collapsed hexahedron: `ExplicitFe::element_nodes`).
    pub fn forces(
        &mut self,
        (x, v, dt): (&[[f64; 3]], &[[f64; 3]], f64),
        (materials, lanes, width): (&[Box<dyn Material>], &[LaneMaterial], Width),
        ctl: &HexControls,
        (force, blocks, offset): (&mut [[f64; 3]], &mut BlockWork, usize),
        exchange: &mut NodeExchange,
    ) -> Result<TetSums, PetscError> {
        let mut out = TetSums {
            dt_min: f64::INFINITY,
            inverted: None,
        };
        match width {
            Width::W1 => self.nodal_rates::<batch::w1::TetGroup>(x, v, dt, &mut out),
            Width::W4 => self.nodal_rates::<batch::w4::TetGroup>(x, v, dt, &mut out),
            #[cfg(target_arch = "x86_64")]
            Width::W8 => self.nodal_rates::<batch::w8::TetGroup>(x, v, dt, &mut out),
        }
        self.assembly.finish(&mut self.sums, exchange)?;
        let ratios = self.node_ratios();
        self.sums.iter_mut().for_each(|s| *s = [0.0; 3]);
        let pass = Pass2 {
            x,
            v,
            dt,
            ratios: &ratios,
            materials,
            lanes,
            ctl,
            offset,
        };
        match width {
            Width::W1 => self.update_all::<batch::w1::TetGroup>(&pass, blocks, &mut out),
            Width::W4 => self.update_all::<batch::w4::TetGroup>(&pass, blocks, &mut out),
            #[cfg(target_arch = "x86_64")]
            Width::W8 => self.update_all::<batch::w8::TetGroup>(&pass, blocks, &mut out),
        }
        self.assembly.finish(&mut self.sums, exchange)?;
        for (f, s) in force.iter_mut().zip(&self.sums) {
            for c in 0..3 {
                f[c] += s[c];
            }
        }
        Ok(out)
    }

    /// Pass 2 over every tetrahedron in element order: runs of consecutive tetrahedra of one
    /// material in groups of `B::LANES` through the lane kernel ([`TetBatch`]), a run's last
    /// group padded with copies of its first element (results dropped). Every width runs the
    /// same operations in every lane, so an element's result does not depend on its group
    /// (docs/scene.md, "One answer"). A group with an inverted element is redone one element
    /// at a time (one lane: the same bits), so that the others are updated as by any width.
    fn update_all<B: TetBatch>(
        &mut self,
        p: &Pass2<'_>,
        blocks: &mut BlockWork,
        out: &mut TetSums,
    ) {
        let mut g = Box::<B>::default();
        let mut e = 0;
        while e < self.conn.len() {
            let mi = self.material[e];
            let end = (e + B::LANES).min(self.conn.len());
            let n = (e..end).take_while(|&k| self.material[k] == mi).count();
            if self.update_group(p, e, n, &mut *g).is_ok() {
                self.accept_group(p, e, n, &*g, blocks, out);
            } else {
                let mut one = batch::w1::TetGroup::default();
                for k in e..e + n {
                    match self.update_group(p, k, 1, &mut one) {
                        Ok(()) => self.accept_group(p, k, 1, &one, blocks, out),
                        Err(bad) => {
                            self.assembly.record(k, |_| [0.0; 3]);
                            out.inverted.get_or_insert((k, bad.volume));
                        }
                    }
                }
            }
            e += n;
        }
    }

    /// Loads the tetrahedra `e0..e0 + n` (one material, `n` at most `B::LANES`; the other lanes
    /// copies of `e0`) into `g` and updates them; `Err`, with nothing stored, when one is
    /// inverted.
    fn update_group<B: TetBatch>(
        &self,
        p: &Pass2<'_>,
        e0: usize,
        n: usize,
        g: &mut B,
    ) -> Result<(), GroupInverted> {
        let mi = self.material[e0];
        let ns = p.lanes[mi].n_state();
        let s = self.stride;
        for l in 0..B::LANES {
            let e = if l < n { e0 + l } else { e0 };
            let conn = &self.conn[e];
            g.load(
                l,
                &TetInput {
                    x: &gather4(p.x, conn),
                    v: &gather4(p.v, conn),
                    vol0: self.vol0[e],
                    avg: mean_ratios(p.ratios, conn),
                    stress: &self.state[e].stress,
                    history: &self.mat_state[e * s..e * s + ns],
                },
            );
        }
        g.update(p.dt, &p.lanes[mi], &*p.materials[mi], p.ctl)
    }

    /// Stores the first `n` lanes' states of `g` (tetrahedra `e0..`), adds their forces to the
    /// nodes and records them for the ordered sum in element order, and feeds the blocks and
    /// the smallest stable step.
    fn accept_group<B: TetBatch>(
        &mut self,
        p: &Pass2<'_>,
        e0: usize,
        n: usize,
        g: &B,
        blocks: &mut BlockWork,
        out: &mut TetSums,
    ) {
        let ns = p.lanes[self.material[e0]].n_state();
        let s = self.stride;
        for l in 0..n {
            let e = e0 + l;
            let (stress, history) = g.lane_state(l);
            self.state[e].stress = stress;
            self.mat_state[e * s..e * s + ns].copy_from_slice(&history[..ns]);
            let o = g.lane_output(l);
            for (k, &node) in self.conn[e].iter().enumerate() {
                let f = &mut self.sums[node as usize];
                for c in 0..3 {
                    f[c] += o.force[k][c];
                }
            }
            self.assembly.record(e, |k| o.force[k]);
            out.dt_min = out.dt_min.min(o.dt_stable);
            if blocks.active() {
                let f = o.force;
                let z = [0.0; 3];
                blocks.add(p.offset + e, &[f[0], f[1], f[2], z, f[3], z, z, z], 0.0);
            }
        }
    }

    /// Pass 1: each tetrahedron's volume rate, mid-step and end volumes ([`tet::rates`], in
    /// groups of `B::LANES` consecutive tetrahedra through the lane kernel: the same bits)
    /// added at its nodes into `self.sums` and recorded for the ordered sum, in element order;
    /// an inverted one adds zeros and is reported in `out`.
    fn nodal_rates<B: TetBatch>(
        &mut self,
        x: &[[f64; 3]],
        v: &[[f64; 3]],
        dt: f64,
        out: &mut TetSums,
    ) {
        self.sums.iter_mut().for_each(|s| *s = [0.0; 3]);
        let mut g = Box::<B>::default();
        let len = self.conn.len();
        for e0 in (0..len).step_by(B::LANES) {
            let n = B::LANES.min(len - e0);
            for l in 0..B::LANES {
                let conn = &self.conn[e0 + if l < n { l } else { 0 }];
                g.load_nodes(l, &gather4(x, conn), &gather4(v, conn));
            }
            g.rates(dt);
            for l in 0..n {
                let e = e0 + l;
                let r = g.lane_rates(l);
                // tet::rates's checks, in its order.
                let bad = [r.vol, r.vol_mid]
                    .into_iter()
                    .find(|&v| !(v > 0.0) || !v.is_finite());
                let r = match bad {
                    None => [r.vol_rate, r.vol_mid, r.vol],
                    Some(volume) => {
                        out.inverted.get_or_insert((e, volume));
                        [0.0; 3]
                    }
                };
                for &node in &self.conn[e] {
                    let s = &mut self.sums[node as usize];
                    for c in 0..3 {
                        s[c] += r[c];
                    }
                }
                self.assembly.record(e, |_| r);
            }
        }
    }

    /// Each node's dilatation rate theta_a = (sum of V_mid tr D) / (sum of V_mid), 1/s, and
    /// volume ratio J_a = (sum of V) / (sum of V0), from pass 1's sums (0 and 1 off the
    /// tetrahedra, and where an inverted neighbour left a sum not positive).
    fn node_ratios(&self) -> Vec<[f64; 2]> {
        self.sums
            .iter()
            .zip(&self.node_vol0)
            .map(|(s, &v0)| {
                if s[1] > 0.0 && v0 > 0.0 {
                    [s[0] / s[1], s[2] / v0]
                } else {
                    [0.0, 1.0]
                }
            })
            .collect()
    }

    /// The smallest stable step at the start (the state as set up): each tetrahedron's
    /// estimate at its own initial volumetric rate (an impact at t = 0 compresses some
    /// elements from the first step, as for the hexahedra), s.
    pub fn initial_stable_dt(
        &self,
        x: &[[f64; 3]],
        v: &[[f64; 3]],
        materials: &[Box<dyn Material>],
        ctl: &HexControls,
    ) -> f64 {
        let mut dt = f64::INFINITY;
        for (e, conn) in self.conn.iter().enumerate() {
            let (xe, ve) = (gather4(x, conn), gather4(v, conn));
            let (g, _) = tet::gradients(&xe);
            let div_v: f64 = (0..4)
                .map(|k| ve[k][0] * g[k][0] + ve[k][1] * g[k][1] + ve[k][2] * g[k][2])
                .sum();
            let mat = &*materials[self.material[e]];
            dt = dt.min(tet::stable_dt(&xe, mat.density(), mat, ctl, div_v));
        }
        dt
    }

    /// Bytes of the tetrahedra's arrays on this rank.
    pub fn bytes(&self) -> usize {
        self.conn.len() * (16 + 8 + 8 + 8 + std::mem::size_of::<TetState>() + 8 * self.stride)
            + self.sums.len() * 32
    }
}

/// The element's means of its 4 nodes' ratios (in corner order).
fn mean_ratios(ratios: &[[f64; 2]], conn: &[u32; 4]) -> TetAverages {
    let r = conn.map(|n| ratios[n as usize]);
    TetAverages {
        theta: 0.25 * (((r[0][0] + r[1][0]) + r[2][0]) + r[3][0]),
        j: 0.25 * (((r[0][1] + r[1][1]) + r[2][1]) + r[3][1]),
    }
}

/// A tetrahedron's nodal values.
#[inline]
pub(crate) fn gather4(xs: &[[f64; 3]], conn: &[u32; 4]) -> [[f64; 3]; 4] {
    conn.map(|n| xs[n as usize])
}

/// Centroid of a tetrahedron's nodes.
pub(crate) fn centroid4(x: &[[f64; 3]; 4]) -> [f64; 3] {
    std::array::from_fn(|c| 0.25 * (((x[0][c] + x[1][c]) + x[2][c]) + x[3][c]))
}
