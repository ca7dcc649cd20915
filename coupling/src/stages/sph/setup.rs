//! The SPH stage's set-up from the scene: the model parameters and equations of state, the
//! particles from their seeds; and what the driver reads from the particles (global sums,
//! probe values).
use crate::input::particles::ParticleSeed;
use crate::input::scene::{Probe, ProbeField, Scene, SphDef};
use crate::stages::sph::stage::SphStage;
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use sph::{
    ArtificialStress, ArtificialViscosity, DensityMode, Eos, Kernel, NewParticle, Params,
    Particles, Periodic, Profile, StressModel, TensileCorrection,
};
use std::sync::Arc;

/// Per scene material: its index in the EOS table and its initial specific internal energy
/// (None: a material no particle has).
pub type MaterialMap = Vec<Option<(u16, f64)>>;

/// The stress model of each EOS index (`None`: a fluid) and the artificial stress of a scene
/// with solid particles.
pub struct SolidModels {
    /// Per EOS index (`sph::Particles::mat`).
    pub models: Vec<Option<Arc<dyn StressModel>>>,
    /// Monaghan's artificial stress (`[sph] artificial_stress`, default Gray et al.'s).
    pub art: Option<ArtificialStress>,
}

/// The SPH model of a scene: the `[sph]` table and the materials' equations of state. Returns
/// the parameters, per scene material its index in the EOS table and its initial specific
/// internal energy, and the stress models where particles are of a solid material (`None`
/// where none is).
///
/// A solid material of particles (elastic, j2_plastic, johnson_cook: no eos) takes the
/// element's law (`fe_petsc::material`, through `strength::MaterialStress`) and, in the EOS
/// table, a linear Tait entry (gamma 1: p = rho0 c0^2 (rho/rho0 - 1), c = c0 with c0 =
/// sqrt(wave modulus / rho0)) that only the integrator's EOS calls read: the stage sets a
/// solid's p and c from its stress after each of them (`sph::solid::solid_pressure`).
///
/// A material whose failed elements become particles (`Scene::releases`) is a solid of the
/// table too; `born_spacing` (m) is then the spacing of its particles' artificial stress where
/// no `[[particles]]` entry is solid.
pub fn params_from_scene(
    scene: &Scene,
    born_spacing: Option<f64>,
) -> Result<(Params, MaterialMap, Option<SolidModels>), String> {
    let file = scene.file.display();
    let mut eos = Vec::new();
    let mut map = Vec::new();
    let mut models: Vec<Option<Arc<dyn StressModel>>> = Vec::new();
    for (i, m) in scene.materials.iter().enumerate() {
        let Some(spec) = &m.eos else {
            let used = scene.particles.iter().any(|p| p.material == m.name) || scene.releases(i);
            if !used {
                map.push(None);
                continue;
            }
            let law = fe_petsc::material::build_material(m)
                .map_err(|e| format!("{file}: material[{i}]: {e}"))?;
            let model: Arc<dyn StressModel> = Arc::new(super::strength::MaterialStress::new(
                Arc::from(law),
                scene.failures.get(i).copied().flatten(),
                m.density,
            ));
            let mut state = vec![0.0; model.n_state()];
            model.init_state(&mut state);
            let c0 = (model.wave_modulus(m.density, &state) / m.density).sqrt();
            map.push(Some((eos.len() as u16, 0.0)));
            eos.push(Eos::Tait {
                rho0: m.density,
                c0,
                gamma: 1.0,
            });
            models.resize(eos.len() - 1, None);
            models.push(Some(model));
            continue;
        };
        // the kind, its keys and its initial specific energy: the eos crate's table
        let kind = ::eos::kind(&spec.kind)
            .ok_or_else(|| format!("{file}: material[{i}].eos.kind: unknown \"{}\"", spec.kind))?;
        let (e, e0) = kind
            .build(|k| spec.params.get(k).copied(), m.density)
            .map_err(|err| match err {
                ::eos::ParamError::Missing { key } => format!(
                    "{file}: material[{i}].eos: kind \"{}\" needs \"{key}\"",
                    spec.kind
                ),
                ::eos::ParamError::Bad { key, value, why } => {
                    format!("{file}: material[{i}].eos.{key} = {value}: {why}")
                }
            })?;
        map.push(Some((eos.len() as u16, e0)));
        eos.push(e);
    }
    let solids = if models.is_empty() {
        None
    } else {
        models.resize(eos.len(), None);
        Some(SolidModels {
            models,
            art: artificial_stress(scene, born_spacing),
        })
    };
    let mut params = Params::new(eos);
    params.gravity = scene.gravity;
    params.energy = scene.sph_energy();
    if let Some(s) = &scene.sph {
        params.profile = if s.profile == "liggghts" {
            Profile::Liggghts
        } else {
            Profile::Standard
        };
        params.kernel = if s.kernel == "wendland" {
            Kernel::Wendland
        } else {
            Kernel::CubicSpline
        };
        params.density = if s.density == "summation" {
            DensityMode::Summation
        } else {
            DensityMode::Continuity
        };
        params.viscosity = s
            .artificial_viscosity
            .map(|a| ArtificialViscosity::new(a.alpha, a.beta));
        params.tensile = fluid_tensile(scene, s, solids.is_some());
        params.adaptive_h = s.adaptive_h;
        params.conductivity = s.conductivity;
        params.periodic = s.periodic.as_ref().map(|p| Periodic {
            axes: p.axes,
            min: p.min,
            max: p.max,
        });
    }
    if solids.is_some()
        && scene
            .sph
            .as_ref()
            .and_then(|s| s.artificial_viscosity)
            .is_none()
    {
        params.viscosity = Some(ArtificialViscosity::new(
            SOLID_VISCOSITY_ALPHA,
            SOLID_VISCOSITY_BETA,
        ));
    }
    Ok((params, map, solids))
}

/// Monaghan's artificial viscosity where a scene has solid particles and omits
/// `[sph] artificial_viscosity`: the one whose bulk part is the elements' default linear bulk
/// viscosity (`[fe] bulk_viscosity` linear = 0.06: q = C1 rho c l |tr D| with l the element's
/// length, here the particle spacing). Monaghan's viscosity acts as a bulk viscosity
/// zeta = 5 nu / 3 with nu = alpha h c / 10 in 3D (Monaghan, Rep. Prog. Phys. 68 (2005) 1703,
/// §4.2), so q = zeta rho |div v| = alpha h c rho |div v| / 6, Pa; equal to C1 rho c l |div v|
/// for
///
/// ```text
/// alpha = 6 C1 l / h = 6 x 0.06 / 1.2 = 0.3     (h = 1.2 l, the default h_factor)
/// ```
///
/// and beta = 0 (its quadratic term acts on every closing pair, the isochoric plastic flow's
/// too: beta = 2, the value for gas shocks, makes a copper Taylor bar of particles 10 % too
/// long). A solid impact needs a viscosity: without it the shock's energy has nowhere to go
/// but particle noise (the Taylor bar's energy error passes 5 %). A scene of fluid particles
/// only keeps it off when omitted (its dam breaks and the LIGGGHTS cross-check set their own).
pub const SOLID_VISCOSITY_ALPHA: f64 = 0.3;
/// See [`SOLID_VISCOSITY_ALPHA`].
pub const SOLID_VISCOSITY_BETA: f64 = 0.0;

/// The fluid pass's tensile correction (none in a run with solid particles, whose stress pass
/// serves every particle and has the artificial stress: `tensile_correction` is then not used,
/// with a warning, `scene::sph_warnings`): `[sph] tensile_correction` (Monaghan 2000), else
/// `[sph] artificial_stress` (Gray et al. 2001's form on the fluids' tension; None at epsilon
/// 0), at the spacing of the first `[[particles]]` entry.
fn fluid_tensile(scene: &Scene, s: &SphDef, solids: bool) -> Option<TensileCorrection> {
    let spacing = scene.particles.first().map(|p| p.spacing).unwrap_or(0.0);
    if solids {
        return None;
    }
    if let Some(t) = s.tensile_correction {
        return Some(TensileCorrection::monaghan(t.epsilon, spacing));
    }
    let a = s.artificial_stress?;
    (a.epsilon > 0.0).then(|| TensileCorrection::gray(a.epsilon, a.n as i32, spacing))
}

/// The artificial stress of a scene with solid particles (a solid `[[particles]]` entry, or
/// failed elements' particles: `born_spacing`): `[sph] artificial_stress`, or Gray et al.'s
/// epsilon 0.3, n 4 where omitted (None where epsilon = 0). Each pair's delta_p (where
/// f_ab = 1) is its particles' own initial spacing ([`ArtificialStress`]).
fn artificial_stress(scene: &Scene, born_spacing: Option<f64>) -> Option<ArtificialStress> {
    let solid = scene.particles.iter().any(|p| {
        scene
            .materials
            .iter()
            .any(|m| m.name == p.material && m.eos.is_none())
    });
    if !solid && born_spacing.is_none() {
        return None;
    }
    let mut a = ArtificialStress::new();
    if let Some(d) = scene.sph.as_ref().and_then(|s| s.artificial_stress) {
        a.epsilon = d.epsilon;
        a.n = d.n as i32;
    }
    (a.epsilon > 0.0).then_some(a)
}

/// This rank's initial particles (owned) from the seeds.
pub fn particles_from_seeds(
    seeds: &[ParticleSeed],
    map: &[Option<(u16, f64)>],
) -> Result<Particles, String> {
    let mut p = Particles::new();
    for s in seeds {
        let (mat, e0) = map[s.material].ok_or("particles of a material without an SPH model")?;
        p.push(NewParticle {
            id: s.id,
            x: s.x,
            v: s.v,
            m: s.mass,
            rho: s.rho,
            e: e0,
            h: s.h,
            mat,
            fixed: s.fixed,
        });
    }
    Ok(p)
}

/// Shepard-interpolated values of `probes` from the particles (collective): partial sums over
/// owned particles, summed over ranks (exact, whatever the decomposition), their columns in
/// order. NaN where no particle reaches the point or the field has no particle meaning
/// (displacement; plastic strain in a run without solid particles). Stress is a solid's Cauchy
/// stress, a fluid's -p I; plastic strain a solid's equivalent plastic strain, a fluid's 0;
/// temperature a thermally softening solid's (NaN where a particle within reach keeps none).
pub fn shepard(comm: &SimpleCommunicator, st: &SphStage, probes: &[&Probe]) -> Vec<f64> {
    let p = &st.parts;
    let k = st.params.smoothing_kernel();
    let solids = st.solids();
    // Voigt component c of the stress: a solid's, a fluid's -p I
    let stress = |i: usize, c: usize| match solids {
        Some(s) if s.is_solid(p.mat[i]) => s.stress[i][c],
        _ if c < 3 => -p.p[i],
        _ => 0.0,
    };
    // each sum's terms (the denominator, then each field's numerator), summed exactly
    let mut terms: Vec<Vec<f64>> = Vec::new();
    for pr in probes {
        let (mut den, mut num) = (Vec::new(), vec![Vec::new(); pr.fields.len()]);
        for i in 0..p.n_owned {
            let x = p.x_real[i];
            let r2: f64 = (0..3).map(|c| (x[c] - pr.point[c]).powi(2)).sum();
            if r2 >= 4.0 * p.h[i] * p.h[i] {
                continue;
            }
            let w = p.m[i] / p.rho[i] * k.w(r2.sqrt(), p.h[i]);
            den.push(w);
            for (f, field) in pr.fields.iter().enumerate() {
                let v = match field {
                    ProbeField::VelocityX => p.v[i][0],
                    ProbeField::VelocityY => p.v[i][1],
                    ProbeField::VelocityZ => p.v[i][2],
                    ProbeField::Pressure => p.p[i],
                    ProbeField::Density => p.rho[i],
                    ProbeField::StressXx => stress(i, 0),
                    ProbeField::StressYy => stress(i, 1),
                    ProbeField::StressZz => stress(i, 2),
                    ProbeField::StressXy => stress(i, 3),
                    ProbeField::StressYz => stress(i, 4),
                    ProbeField::StressZx => stress(i, 5),
                    ProbeField::PlasticStrain => match solids {
                        Some(s) => s.plastic_strain(p.mat[i], i),
                        None => f64::NAN,
                    },
                    ProbeField::Temperature => solids
                        .and_then(|s| s.temperature(p.mat[i], i))
                        .unwrap_or(f64::NAN),
                    _ => f64::NAN,
                };
                num[f].push(w * v);
            }
        }
        terms.push(den);
        terms.extend(num);
    }
    let g = fe_petsc::exact::totals(comm, &terms);
    let mut out = Vec::new();
    let mut k = 0;
    for pr in probes {
        let den = g[k];
        for f in 0..pr.fields.len() {
            out.push(if den > 0.0 {
                g[k + 1 + f] / den
            } else {
                f64::NAN
            });
        }
        k += 1 + pr.fields.len();
    }
    out
}

/// The particles' global sums (collective).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SphGlobals {
    /// Kinetic energy, J.
    pub kinetic: f64,
    /// Internal energy, J.
    pub internal: f64,
    /// Momentum, kg m/s.
    pub momentum: [f64; 3],
    /// Power of gravity on the particles, W.
    pub gravity_power: f64,
    /// What the step's holds changed of the kinetic energy beyond the pair work, J
    /// (`SphStage::hold_work`).
    pub hold_work: f64,
    /// The step's impulses of the rigid walls' holds, per wall, N s (`SphStage::hold_impulse`).
    pub hold_impulses: Vec<[f64; 3]>,
    /// The solid particles' internal energy, J (part of `internal`).
    pub solid_internal: f64,
}

impl SphGlobals {
    /// All finite.
    pub fn is_finite(&self) -> bool {
        self.kinetic.is_finite()
            && self.internal.is_finite()
            && self.momentum.iter().all(|m| m.is_finite())
            && self.gravity_power.is_finite()
    }
}

/// Global energies, momentum and gravity power, in one reduction (collective): each sum on
/// the stage's grids ([`fe_petsc::exact`]), the same bits at any rank count.
pub fn globals(comm: &SimpleCommunicator, st: &SphStage) -> SphGlobals {
    let p = &st.parts;
    let (ge, gm) = (st.grids.energy, st.grids.momentum);
    let g = st.params.gravity;
    // [sum m v.v, sum m (e + work), px, py, pz, sum m g.v (moving particles), the holds'
    // energy, the solids' sum m (e + work), then each wall's hold impulse x, y, z]
    let mut f = vec![[0.0; 3]; 8];
    f[6] = st.hold_work;
    f.extend(st.hold_impulse.iter().flatten().copied());
    for i in 0..p.n_owned {
        let (m, v) = (p.m[i], p.v[i]);
        ge.add(&mut f[1], m * (p.e[i] + p.work[i]));
        if st.is_solid(i) {
            ge.add(&mut f[7], m * (p.e[i] + p.work[i]));
        }
        for c in 0..3 {
            ge.add(&mut f[0], m * (v[c] * v[c]));
            gm.add(&mut f[2 + c], m * v[c]);
        }
        if !p.fixed[i] {
            ge.add(&mut f[5], m * (g[0] * v[0] + g[1] * v[1] + g[2] * v[2]));
        }
    }
    let flat = fe_petsc::exact::flatten(&f);
    let mut red = vec![0.0; flat.len()];
    comm.all_reduce_into(&flat[..], &mut red[..], SystemOperation::sum());
    let t = fe_petsc::exact::values(&red);
    SphGlobals {
        kinetic: 0.5 * t[0],
        internal: t[1],
        momentum: [t[2], t[3], t[4]],
        gravity_power: t[5],
        hold_work: t[6],
        solid_internal: t[7],
        hold_impulses: t[8..].chunks(3).map(|j| [j[0], j[1], j[2]]).collect(),
    }
}
