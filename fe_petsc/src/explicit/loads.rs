//! Pressure loads on faces (docs/scene.md `[[load]]`): the consistent nodal forces of a
//! pressure on the deformed faces, summed per node in an order fixed by the mesh.
//!
//! A pressure p (Pa, positive pushing into the body) on a face with outward unit normal n
//! applies the traction t = -p n. Its consistent nodal force on corner a of a bilinear
//! quadrilateral with shape functions N_a(xi, eta) on [-1, 1]^2 is
//!
//! ```text
//! f_a = -p ∫ N_a n dA = -p ∫∫ N_a (x_xi × x_eta) dxi deta
//! ```
//!
//! With x_xi = a + b eta and x_eta = c + b xi (b the face's twist), the cross product is
//! a×c + xi a×b + eta b×c: its integral over the square is 4 a×c, the area vector
//! A = ∫ n dA = (1/2) (x_3 - x_1) × (x_4 - x_2) (corners 1..4 in order, the diagonals' cross
//! product; exact for a warped face too). Taken at the face's centre (one-point rule,
//! N_a(0, 0) = 1/4), each of the four corners gets f_a = -p A / 4: exact for a parallelogram,
//! and the forces always add up to the exact resultant -p A. A face with a repeated corner
//! (a triangle) gives its three distinct corners -p A / 3 each.
//!
//! The forces follow the faces: they are evaluated at the current positions each step, with
//! the curve's value at that time. Their work is booked in the external work (trapezoid
//! f(n)+f(n+1) over each step's displacement, as the element forces' work).
//!
//! One answer at any rank count: each face is evaluated by the rank of its element, and each
//! node's load is `0 + f_1 + f_2 + ...` over its faces in the order of their keys (load, face
//! gid), the faces of a node that several ranks hold summed by its owner through an
//! [`Assembly`] of the faces (the element forces' scheme), then added to the node's summed
//! element force.
use super::{ExplicitFe, StepError};
use crate::assembly::Assembly;
use crate::curve::Curve;
use crate::exact::{Grid, StepFolds};
use crate::mesh::NodeExchange;
use crate::petsc::PetscError;

/// A pressure on a set of faces: what the scene's `[[load]]` gives the integrator.
#[derive(Debug, Clone, PartialEq)]
pub struct PressureLoad {
    /// Pressure, Pa (positive pushes into the body).
    pub pressure: f64,
    /// The scale of the pressure in time (none: 1).
    pub curve: Option<Curve>,
    /// This rank's faces: global face id (the same at any rank count) and the local nodes of
    /// its corners, ordered so that the right-hand rule gives the outward normal.
    pub faces: Vec<(u64, [u32; 4])>,
    /// The local index of each face's element (aligned with `faces`; `u32::MAX`: an element
    /// that cannot fail, such as a native tetrahedron). A failed element's face carries no
    /// load: the material it bounded is gone.
    pub elements: Vec<u32>,
}

/// The loads of one rank: the faces in key order, their ordered nodal sum and the loaded
/// nodes' forces now and a step ago.
pub struct Loads {
    /// Pressure and curve of each load.
    sets: Vec<(f64, Option<Curve>)>,
    /// The faces in key order (load, face gid): their load and corners.
    faces: Vec<(u32, [u32; 4])>,
    /// Each face's element (local index; `u32::MAX`: none that fails), in key order.
    elements: Vec<u32>,
    /// The ordered nodal sum of the faces' forces.
    assembly: Assembly,
    /// Local nodes with a load on some rank's face (every copy of them), ascending.
    pub nodes: Vec<u32>,
    /// The load on every local node now (zero off `nodes`), N.
    pub now: Vec<[f64; 3]>,
    /// The load at the last step's end, on `nodes` (in their order), N.
    pub old: Vec<[f64; 3]>,
}

/// v × w.
fn cross(v: [f64; 3], w: [f64; 3]) -> [f64; 3] {
    [
        v[1] * w[2] - v[2] * w[1],
        v[2] * w[0] - v[0] * w[2],
        v[0] * w[1] - v[1] * w[0],
    ]
}

/// The nodal forces of pressure `p` on the face with corners `x` (outward by the right-hand
/// rule): -p A / 4 on each corner, -p A / 3 on each distinct corner of a triangle (a repeated
/// corner's share split between its two places), A = (x_3 - x_1) × (x_4 - x_2) / 2 (see the
/// module documentation). N.
pub fn face_forces(x: &[[f64; 3]; 4], nodes: &[u32; 4], p: f64) -> [[f64; 3]; 4] {
    let d1 = std::array::from_fn(|c| x[2][c] - x[0][c]);
    let d2 = std::array::from_fn(|c| x[3][c] - x[1][c]);
    let a = cross(d1, d2).map(|v| 0.5 * v);
    let distinct = (0..4).filter(|&k| !nodes[..k].contains(&nodes[k])).count();
    let mut out = [[0.0; 3]; 4];
    for k in 0..4 {
        let copies = nodes.iter().filter(|&&n| n == nodes[k]).count();
        let share = 1.0 / (distinct as f64 * copies as f64);
        out[k] = a.map(|v| -p * v * share);
    }
    out
}

impl Loads {
    /// The loads `sets` on `nn` local nodes over the node exchange `ex` (collective: every
    /// rank calls it, with the same number of loads).
    pub fn new(
        sets: Vec<PressureLoad>,
        nn: usize,
        ex: &mut NodeExchange,
    ) -> Result<Loads, PetscError> {
        let mut keyed: Vec<([u64; 3], u32, [u32; 4], u32)> = Vec::new();
        for (i, s) in sets.iter().enumerate() {
            for (k, &(gid, corners)) in s.faces.iter().enumerate() {
                let elem = s.elements.get(k).copied().unwrap_or(u32::MAX);
                keyed.push(([i as u64, gid, 0], i as u32, corners, elem));
            }
        }
        keyed.sort_unstable_by_key(|k| k.0);
        let keys: Vec<[u64; 3]> = keyed.iter().map(|k| k.0).collect();
        let faces: Vec<(u32, [u32; 4])> = keyed.iter().map(|k| (k.1, k.2)).collect();
        let elements: Vec<u32> = keyed.iter().map(|k| k.3).collect();
        let corners: Vec<[u32; 4]> = faces.iter().map(|f| f.1).collect();
        let assembly = Assembly::new(&corners, &keys, ex)?;
        // The loaded nodes on every copy: a mark per face corner, summed over the ranks.
        let mut mark = vec![0.0; 3 * nn];
        for c in &corners {
            for &n in c {
                mark[3 * n as usize] = 1.0;
            }
        }
        ex.sum_shared(&mut mark)?;
        let nodes: Vec<u32> = (0..nn as u32)
            .filter(|&n| mark[3 * n as usize] > 0.0)
            .collect();
        let old = vec![[0.0; 3]; nodes.len()];
        Ok(Loads {
            sets: sets.into_iter().map(|s| (s.pressure, s.curve)).collect(),
            faces,
            elements,
            assembly,
            nodes,
            now: vec![[0.0; 3]; nn],
            old,
        })
    }

    /// Sets `now` to the loads at positions `x` and time `t` (collective): each face's
    /// forces added to its corners in key order, the shared nodes' sums taken by their
    /// owners in the same order ([`Assembly::finish`]). `failed` (where elements fail: each
    /// local element's flag) gives a failed element's faces no load (zero forces, in their
    /// place in the order: the same bits at any rank count, as the flags are).
    pub fn evaluate(
        &mut self,
        x: &[[f64; 3]],
        t: f64,
        failed: Option<&[bool]>,
        ex: &mut NodeExchange,
    ) -> Result<(), PetscError> {
        for &n in &self.nodes {
            self.now[n as usize] = [0.0; 3];
        }
        let scale: Vec<f64> = self
            .sets
            .iter()
            .map(|(p, c)| p * c.as_ref().map_or(1.0, |c| c.value(t)))
            .collect();
        for (k, &(set, corners)) in self.faces.iter().enumerate() {
            let gone = failed.is_some_and(|fl| fl.get(self.elements[k] as usize) == Some(&true));
            let f = if gone {
                [[0.0; 3]; 4]
            } else {
                let xf = corners.map(|n| x[n as usize]);
                face_forces(&xf, &corners, scale[set as usize])
            };
            for (j, &n) in corners.iter().enumerate() {
                for c in 0..3 {
                    self.now[n as usize][c] += f[j][c];
                }
            }
            self.assembly.record(k, |j| f[j]);
        }
        self.assembly.finish(&mut self.now, ex)
    }

    /// Moves `now` on the loaded nodes into `old` (the step's end becomes the next step's
    /// start).
    pub fn keep(&mut self) {
        for (o, &n) in self.old.iter_mut().zip(&self.nodes) {
            *o = self.now[n as usize];
        }
    }

    /// Adds the loads `now` (the last [`Loads::evaluate`]) to the nodal forces `force`.
    pub fn add_to(&self, force: &mut [[f64; 3]]) {
        for &n in &self.nodes {
            let n = n as usize;
            for c in 0..3 {
                force[n][c] += self.now[n][c];
            }
        }
    }

    /// The loads' work over a step on the owned loaded nodes, each node's displacement
    /// `dx(n, c)`: the trapezoid (L(n) + L(n+1))/2 . dx into the external work (`sums[2]`),
    /// and the same forces' (L(n) + L(n+1)) . dx taken out of the element work's raw sum
    /// (`sums[1]`, halved later), which summed the nodal forces with the loads in them.
    pub(crate) fn book_work(
        &self,
        owned: &[bool],
        grid: &Grid,
        dx: impl Fn(usize, usize) -> f64,
        sums: &mut StepFolds,
    ) {
        for (old, &n) in self.old.iter().zip(&self.nodes) {
            let n = n as usize;
            if !owned[n] {
                continue;
            }
            let now = self.now[n];
            for c in 0..3 {
                let d = dx(n, c);
                let both = old[c] + now[c];
                grid.add(&mut sums[2], (0.5 * both) * d);
                grid.add(&mut sums[1], -(both * d));
            }
        }
    }
}

impl ExplicitFe {
    /// The pressure loads, where the scene has some ([`ExplicitFe::set_loads`]).
    pub fn loads(&self) -> Option<&Loads> {
        self.loads.as_ref()
    }

    /// [`ExplicitFe::loads`], to evaluate them elsewhere (implicit mode's trial positions).
    pub fn loads_mut(&mut self) -> Option<&mut Loads> {
        self.loads.as_mut()
    }

    /// The pressure loads of this rank (collective: every rank calls it, with the same
    /// number of loads; none: nothing to do): their forces at the present positions and
    /// time are added to the nodal forces the next kick reads.
    pub fn set_loads(
        &mut self,
        sets: Vec<PressureLoad>,
        exchange: &mut NodeExchange,
    ) -> Result<(), StepError> {
        if sets.is_empty() {
            return Ok(());
        }
        let mut l = Loads::new(sets, self.x.len(), exchange)?;
        let failed = self.erosion.as_ref().map(|r| &r.failed[..]);
        l.evaluate(&self.x, self.time, failed, exchange)?;
        for &n in &l.nodes {
            let n = n as usize;
            for c in 0..3 {
                self.force[n][c] += l.now[n][c];
            }
        }
        self.loads = Some(l);
        Ok(())
    }

    /// After a restart: the loads at the restored positions and time, as the step that
    /// wrote the checkpoint left them (its forces, restored, already hold them); gravity at
    /// the restored time (collective).
    pub fn refresh_after_restart(&mut self, exchange: &mut NodeExchange) -> Result<(), StepError> {
        self.gravity = self.gravity_at(self.time);
        if let Some(l) = &mut self.loads {
            let failed = self.erosion.as_ref().map(|r| &r.failed[..]);
            l.evaluate(&self.x, self.time, failed, exchange)?;
        }
        Ok(())
    }

    /// The loads at the step's end (time `t`, the present positions) added to the summed
    /// element forces; the last step's kept for the work (collective).
    pub(super) fn add_loads(
        &mut self,
        t: f64,
        exchange: &mut NodeExchange,
    ) -> Result<(), PetscError> {
        let Some(l) = &mut self.loads else {
            return Ok(());
        };
        l.keep();
        let failed = self.erosion.as_ref().map(|r| &r.failed[..]);
        l.evaluate(&self.x, t, failed, exchange)?;
        for &n in &l.nodes {
            let n = n as usize;
            for c in 0..3 {
                self.force[n][c] += l.now[n][c];
            }
        }
        Ok(())
    }

    /// The loads' work over the step on the owned loaded nodes, with the displacement dt v
    /// (`v` the half-step velocities): the trapezoid (L(n) + L(n+1))/2 . dx into the external
    /// work, and the same forces' f . dx taken out of the element work's sum (the nodal
    /// forces the kick and the closing pass summed include the loads).
    pub(super) fn load_work(&self, dt: f64, sums: &mut StepFolds) {
        if let Some(l) = &self.loads {
            let v = &self.v;
            l.book_work(&self.owned, &self.grids.energy, |n, c| dt * v[n][c], sums);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_unit_square_takes_a_quarter_of_minus_p_a_per_corner() {
        // The square [0,1]^2 at z = 0, counter-clockwise from +z: outward normal +z, A = 1.
        let x = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let f = face_forces(&x, &[0, 1, 2, 3], 2.0);
        for fk in f {
            assert_eq!(fk, [0.0, 0.0, -0.5]);
        }
    }

    #[test]
    fn a_warped_face_gets_the_exact_resultant() {
        // One corner lifted: the resultant is -p times the exact area vector, which for a
        // bilinear face is half the diagonals' cross product: d1 = (1,1,h), d2 = (-1,1,0),
        // d1 x d2 = (-h, -h, 2), so A = (-h/2, -h/2, 1).
        let h = 0.3;
        let x = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, h],
            [0.0, 1.0, 0.0],
        ];
        let f = face_forces(&x, &[0, 1, 2, 3], 1.0);
        let sum: [f64; 3] = std::array::from_fn(|c| f.iter().map(|fk| fk[c]).sum());
        let want = [h / 2.0, h / 2.0, -1.0];
        for c in 0..3 {
            assert!((sum[c] - want[c]).abs() < 1e-15, "{sum:?} vs {want:?}");
        }
    }

    #[test]
    fn a_triangle_shares_in_thirds() {
        // Right triangle (0,0), (1,0), (0,1) as a face with its last corner repeated: A = 1/2.
        let x = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let f = face_forces(&x, &[0, 1, 2, 2], 3.0);
        let third = -3.0 * 0.5 / 3.0;
        assert!((f[0][2] - third).abs() < 1e-15);
        assert!((f[1][2] - third).abs() < 1e-15);
        assert!((f[2][2] + f[3][2] - third).abs() < 1e-15);
    }
}
