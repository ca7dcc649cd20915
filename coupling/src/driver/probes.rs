//! Probes: field values at fixed material points, written to probes.csv.
//!
//! A probe is located once, in the reference configuration, in the element with the lowest
//! global id that contains it (to within 1e-9 m). The owning rank evaluates it; one sum over the
//! ranks gathers every probe's values (non-owners contribute zero). In a run with SPH particles,
//! a probe outside the mesh is a particle probe: Shepard-interpolated from the particles
//! (docs/scene.md "Probes").
use crate::input::scene::{Probe, ProbeField};
use crate::kernels::collective::first_error;
use crate::stages::sph::stage::SphStage;
use fe_petsc::explicit::ExplicitFe;
use fe_petsc::hex;
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

/// Distance within which a point counts as inside an element, m (docs/scene.md).
const LOCATE_TOL_M: f64 = 1e-9;

/// A probe located on this rank (or not).
#[derive(Debug, Clone)]
struct Located {
    /// Local element index and natural coordinates, when this rank evaluates it.
    here: Option<(usize, [f64; 3])>,
    fields: Vec<ProbeField>,
    /// Outside the mesh, sampled from the particles.
    particle: Option<Probe>,
}

/// All probes of a scene.
pub struct Probes {
    located: Vec<Located>,
    /// Column names, `probe.field`.
    pub columns: Vec<String>,
}

impl Probes {
    /// Locates every probe; a probe outside the mesh is a scene error, or, with `particles`,
    /// a particle probe (collective).
    pub fn locate(
        comm: &SimpleCommunicator,
        file: &str,
        probes: &[Probe],
        fe: Option<&ExplicitFe>,
        particles: bool,
    ) -> Result<Probes, String> {
        let mut located = Vec::new();
        let mut columns = Vec::new();
        let mut err = None;
        for (i, p) in probes.iter().enumerate() {
            let mut best: Option<(u64, usize, [f64; 3])> = None;
            for (e, conn) in fe.iter().flat_map(|fe| fe.elems.iter().enumerate()) {
                let fe = fe.expect("elements come from the FE stage");
                let x: [[f64; 3]; 8] = std::array::from_fn(|k| fe.x0[conn[k] as usize]);
                // Bounding-box reject first, grown by the tolerance.
                let inside_box = (0..3).all(|c| {
                    let lo = x.iter().map(|q| q[c]).fold(f64::INFINITY, f64::min);
                    let hi = x.iter().map(|q| q[c]).fold(f64::NEG_INFINITY, f64::max);
                    p.point[c] >= lo - LOCATE_TOL_M && p.point[c] <= hi + LOCATE_TOL_M
                });
                if !inside_box {
                    continue;
                }
                let size = (hex::volume(&x)).cbrt();
                if let Some(xi) = hex::natural_coords(&x, p.point, LOCATE_TOL_M / size) {
                    let id = fe.elem_id[e];
                    if best.is_none_or(|b| id < b.0) {
                        best = Some((id, e, xi));
                    }
                }
            }
            let mine = best.map(|b| b.0).unwrap_or(u64::MAX);
            let mut lowest = 0u64;
            comm.all_reduce_into(&mine, &mut lowest, SystemOperation::min());
            let outside = lowest == u64::MAX;
            if outside && !particles && err.is_none() {
                err = Some(format!(
                    "{file}: probe[{i}] \"{}\": point ({}, {}, {}) lies outside the mesh",
                    p.name, p.point[0], p.point[1], p.point[2]
                ));
            }
            let here = best.filter(|b| b.0 == lowest).map(|b| (b.1, b.2));
            columns.extend(p.columns());
            located.push(Located {
                here,
                fields: p.fields.clone(),
                particle: (outside && particles).then(|| p.clone()),
            });
        }
        first_error(comm, err)?;
        Ok(Probes { located, columns })
    }

    /// The values of every probe column, on every rank (collective).
    pub fn sample(
        &self,
        comm: &SimpleCommunicator,
        fe: Option<&ExplicitFe>,
        sph: Option<&SphStage>,
    ) -> Vec<f64> {
        let mut vals = Vec::with_capacity(self.columns.len());
        for l in &self.located {
            for f in &l.fields {
                vals.push(match (l.here, fe) {
                    (Some((e, xi)), Some(fe)) => value(fe, e, xi, f),
                    _ => 0.0,
                });
            }
        }
        let mut out = vec![0.0; vals.len()];
        if !vals.is_empty() {
            comm.all_reduce_into(&vals[..], &mut out[..], SystemOperation::sum());
        }
        // One rank's value plus zeros is that value exactly, but for its sign at zero: -0.0
        // (a pressure at rest) comes back +0.0 from several ranks; one sign at any rank count.
        for v in out.iter_mut() {
            *v += 0.0;
        }
        // Particle probes: their columns from the particles (collective: every rank has the
        // same list).
        let parts: Vec<&Probe> = self
            .located
            .iter()
            .filter_map(|l| l.particle.as_ref())
            .collect();
        if let (Some(st), false) = (sph, parts.is_empty()) {
            let mut v = crate::stages::sph::setup::shepard(comm, st, &parts).into_iter();
            let mut col = 0;
            for l in &self.located {
                for _ in &l.fields {
                    if l.particle.is_some() {
                        out[col] = v.next().unwrap_or(f64::NAN);
                    }
                    col += 1;
                }
            }
        }
        out
    }
}

/// Interpolates a nodal field with the shape functions, or reads an element field.
fn value(fe: &ExplicitFe, e: usize, xi: [f64; 3], f: &ProbeField) -> f64 {
    let conn = &fe.elems[e];
    let nodal = |get: &dyn Fn(usize) -> f64| -> f64 {
        let n = hex::shape(xi);
        (0..8).map(|k| n[k] * get(conn[k] as usize)).sum()
    };
    let s = &fe.state.stress(e);
    use ProbeField::*;
    match f {
        DisplacementX => nodal(&|n| fe.x[n][0] - fe.x0[n][0]),
        DisplacementY => nodal(&|n| fe.x[n][1] - fe.x0[n][1]),
        DisplacementZ => nodal(&|n| fe.x[n][2] - fe.x0[n][2]),
        VelocityX => nodal(&|n| fe.v[n][0]),
        VelocityY => nodal(&|n| fe.v[n][1]),
        VelocityZ => nodal(&|n| fe.v[n][2]),
        StressXx => s[0],
        StressYy => s[1],
        StressZz => s[2],
        StressXy => s[3],
        StressYz => s[4],
        StressZx => s[5],
        Pressure => -(s[0] + s[1] + s[2]) / 3.0,
        PlasticStrain => fe.plastic_strain(e),
        Density => fe.density(e),
        Temperature => fe.temperature(e),
    }
}
