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
use fe_petsc::explicit::{ElementRef, ExplicitFe};
use fe_petsc::hex;
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

/// Distance within which a point counts as inside an element, m (docs/scene.md).
const LOCATE_TOL_M: f64 = 1e-9;

/// Where in its element a probe lies: a hexahedron's natural coordinates, or a tetrahedron's
/// barycentric ones (the weights of its 4 nodes).
#[derive(Debug, Clone, Copy)]
enum At {
    Hex([f64; 3]),
    Tet([f64; 4]),
}

/// A probe located on this rank (or not).
#[derive(Debug, Clone)]
struct Located {
    /// Local element index (`ExplicitFe::element`) and the place in it, when this rank
    /// evaluates it.
    here: Option<(usize, At)>,
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
            let mut best: Option<(u64, usize, At)> = None;
            for e in 0..fe.map_or(0, |fe| fe.n_elements()) {
                let fe = fe.expect("elements come from the FE stage");
                if let Some(at) = locate_in(fe, e, p.point) {
                    let id = fe.element_id(e);
                    if best.is_none_or(|b| id < b.0) {
                        best = Some((id, e, at));
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
            // (a particle probe is a point fixed in space: it has no displacement)
            let moved: Vec<&str> = p
                .fields
                .iter()
                .map(|f| f.name())
                .filter(|f| f.starts_with("displacement"))
                .collect();
            if outside && particles && !moved.is_empty() && comm.rank() == 0 {
                eprintln!(
                    "tdyn: warning: probe[{i}] \"{}\" lies outside the mesh: a particle probe, a point fixed in space, whose {} will be NaN (a point that does not move has no displacement; its velocity is the particles' there)",
                    p.name,
                    moved.join(", ")
                );
            }
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
                    (Some((e, at)), Some(fe)) => value(fe, e, at, f),
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

/// Where `point` lies in element `e` of `fe` (in the reference configuration, to within
/// [`LOCATE_TOL_M`]), or `None` outside it.
fn locate_in(fe: &ExplicitFe, e: usize, point: [f64; 3]) -> Option<At> {
    let conn = fe.element_nodes(e);
    let x: [[f64; 3]; 8] = std::array::from_fn(|k| fe.x0[conn[k] as usize]);
    // Bounding-box reject first, grown by the tolerance.
    let inside_box = (0..3).all(|c| {
        let lo = x.iter().map(|q| q[c]).fold(f64::INFINITY, f64::min);
        let hi = x.iter().map(|q| q[c]).fold(f64::NEG_INFINITY, f64::max);
        point[c] >= lo - LOCATE_TOL_M && point[c] <= hi + LOCATE_TOL_M
    });
    if !inside_box {
        return None;
    }
    match fe.element(e) {
        ElementRef::Hex(_) => {
            let size = (hex::volume(&x)).cbrt();
            hex::natural_coords(&x, point, LOCATE_TOL_M / size).map(At::Hex)
        }
        ElementRef::Tet(_) => {
            // Barycentric coordinates: N_a(p) = 1/4 + grad N_a . (p - centroid), exact for
            // the linear tetrahedron; inside when none is below -tol / (its altitude).
            let xt = [x[0], x[1], x[2], x[4]];
            let (g, _) = fe_petsc::tet::gradients(&xt);
            let c: [f64; 3] =
                std::array::from_fn(|k| 0.25 * (xt[0][k] + xt[1][k] + xt[2][k] + xt[3][k]));
            let l: [f64; 4] = std::array::from_fn(|a| {
                0.25 + (0..3).map(|k| g[a][k] * (point[k] - c[k])).sum::<f64>()
            });
            let inside = (0..4).all(|a| {
                let gn = (g[a][0] * g[a][0] + g[a][1] * g[a][1] + g[a][2] * g[a][2]).sqrt();
                l[a] >= -LOCATE_TOL_M * gn
            });
            inside.then_some(At::Tet(l))
        }
    }
}

/// Interpolates a nodal field with the shape functions, or reads an element field.
fn value(fe: &ExplicitFe, e: usize, at: At, f: &ProbeField) -> f64 {
    let conn = fe.element_nodes(e);
    let nodal = |get: &dyn Fn(usize) -> f64| -> f64 {
        match at {
            At::Hex(xi) => {
                let n = hex::shape(xi);
                (0..8).map(|k| n[k] * get(conn[k] as usize)).sum()
            }
            // The collapsed hexahedron (a, b, c, c, d, ...): corners 0, 1, 2 and 4.
            At::Tet(l) => [0, 1, 2, 4]
                .iter()
                .zip(l)
                .map(|(&k, w)| w * get(conn[k] as usize))
                .sum(),
        }
    };
    let s = &fe.stress(e);
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
