//! FE -> SPH: the failed elements of a material whose blocks turn them into particles
//! (`[[block]] failed = "particles"`, the default where the material fails) leave the mesh
//! and join the SPH decomposition.
//!
//! After each step whose global count of failed elements grew, the FE owners release them
//! (`ExplicitFe::release_failed`: each element's record, its mass taken off its nodes by a
//! nodal sum in the canonical order), and each FE owner hands its records to the SPH stage on
//! the same rank as owned particles (`Sph::add_born`); the SPH stage's rebuild then moves
//! them by RCB to the ranks whose boxes hold them, as any particle that crosses a cut. No
//! record travels twice: the SPH RCB is the transfer's only exchange.
//!
//! Conservation: the nodes lose (m/8) v_n each of the element's momentum and its particle
//! carries m times their mean, the same to round-off; the particle's kinetic energy is at most
//! the corners' (the mean's square), and the difference, the motion inside the element one
//! particle cannot carry, is booked in history.csv's `conversion_energy` (the energy balance
//! counts it as taken).
use crate::input::scene::Scene;
use crate::stages::fe::Fe;
use crate::stages::sph::{Births, Sph};
use fe_petsc::explicit::ExplicitFe;
use mpi::topology::SimpleCommunicator;

/// The scene material of each element material index (`ExplicitFe::materials`: the
/// materials the blocks use, in scene order).
fn scene_materials(scene: &Scene) -> Vec<usize> {
    (0..scene.materials.len())
        .filter(|&m| {
            scene
                .blocks
                .iter()
                .any(|b| b.material == scene.materials[m].name)
        })
        .collect()
}

/// What the SPH stage needs before the first birth (collective): the mean size V0^(1/3) of
/// the elements that may become particles and the mesh's mass (the bound of the particles'
/// sums), each an exact sum over ranks.
pub fn births(world: &SimpleCommunicator, scene: &Scene, fe: &ExplicitFe) -> Births {
    let mats = scene_materials(scene);
    let sizes: Vec<f64> = (0..fe.elems.len())
        .filter(|&e| scene.releases(mats[fe.elem_material[e]]))
        .map(|e| fe.vol0[e].cbrt())
        .collect();
    let count = fe_petsc::exact::total(world, &vec![1.0; sizes.len()]);
    let spacing = fe_petsc::exact::total(world, &sizes) / count.max(1.0);
    let owned: Vec<f64> = (0..fe.mass.len())
        .filter(|&n| fe.owned[n])
        .map(|n| fe.mass[n])
        .collect();
    Births {
        spacing,
        mass: fe_petsc::exact::total(world, &owned),
    }
}

/// The transfer's state over a run: the scene material of each element material, the global
/// count of released elements at the last transfer, and the kinetic energy the conversions took.
#[derive(Debug, Clone, Default)]
pub struct Releases {
    mats: Vec<usize>,
    seen: u64,
    /// The kinetic energy the conversions took so far (global), J: history.csv's
    /// `conversion_energy`.
    pub conversion_energy: f64,
}

impl Releases {
    /// The state of a run of `scene` before any element failed.
    pub fn new(scene: &Scene) -> Releases {
        Releases {
            mats: scene_materials(scene),
            ..Releases::default()
        }
    }
}

impl Releases {
    /// Writes the state (global: every rank's file holds the same).
    pub fn save(&self, w: &mut crate::output::state::StateWriter) {
        w.put("fe_sph.state", &[self.seen as f64, self.conversion_energy]);
    }

    /// Sets the state `save` wrote.
    pub fn restore(&mut self, r: &crate::output::state::StateReader) -> Result<(), String> {
        let s: Vec<f64> = r.get("fe_sph.state")?;
        if s.len() != 2 {
            return Err("checkpoint: fe_sph.state".into());
        }
        self.seen = s[0] as u64;
        self.conversion_energy = s[1];
        Ok(())
    }
}

/// After a step (collective): where elements were released in it, their particles to the SPH
/// stage, and the kinetic energy the conversions took added up. Returns whether any was.
pub fn transfer(
    world: &SimpleCommunicator,
    (fe, sph): (&mut Fe, &mut Sph),
    state: &mut Releases,
) -> Result<bool, String> {
    if fe.released_count() == state.seen {
        return Ok(false);
    }
    state.seen = fe.released_count();
    let born: Vec<_> = fe
        .take_released()
        .into_iter()
        .map(|r| {
            let m = state.mats[r.material];
            (r, m)
        })
        .collect();
    let loss: Vec<f64> = born.iter().map(|(r, _)| r.kinetic_loss).collect();
    sph.add_born(world, &born)?;
    state.conversion_energy += fe_petsc::exact::total(world, &loss);
    Ok(true)
}
