//! From a scene to the stages it needs (DESIGN.md "Model no more than a scene needs"): the
//! mesh (gmsh on rank 0, METIS distribution) and the FE stage when the scene has meshes, the SPH
//! stage when it has particles, the contact stage when it has `[contact]`, and the probes.
use super::{Algorithms, RunFailure};
use crate::driver::probes::Probes;
use crate::input::scene::{self, Mode, Scene, Tetrahedra};
use crate::input::split::{self, SplitSummary};
use crate::input::{gmsh, msh_check};
use crate::kernels::collective::first_error;
use crate::stages::contact::{Contact, SearchChoice};
use crate::stages::fe::{setup::Groups, Fe};
use crate::stages::sph::Sph;
use crate::stages::walls::Walls;
use crate::stages::Stage;
use fe_petsc::mesh::DistributedMesh;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::path::{Path, PathBuf};

/// The stages of a run, and its probes.
pub struct Model {
    /// The FE stage (a scene with meshes).
    pub fe: Option<Fe>,
    /// The SPH stage (a scene with `[[particles]]`).
    pub sph: Option<Sph>,
    /// The contact stage (a scene with `[contact]`).
    pub contact: Option<Contact>,
    /// The rigid walls (a scene with `[[rigid_wall]]`).
    pub walls: Option<Walls>,
    /// The probes, located.
    pub probes: Probes,
    /// The mesh's tetrahedra and prisms and the hexahedra they run as (`split`), when it had
    /// any (every rank).
    pub mesh_split: Option<SplitSummary>,
    /// With element failure, the masses history.csv reports: the mesh's (on its nodes, where a
    /// deleted element leaves its mass) and the particles', kg (global).
    pub erosion_masses: Option<[f64; 2]>,
    /// Where failed elements become particles, the FE -> SPH transfer's state.
    pub releases: Option<crate::transfer::fe_sph::Releases>,
    /// The plastic impact the start line's step estimate follows (explicit runs;
    /// [`super::impact`]).
    pub impact: Option<super::impact::Impact>,
}

impl Model {
    /// history.csv's erosion columns (`eroded_elements`, `mass_elements`, `mass_particles`),
    /// where a material fails.
    /// and where failed elements become particles `conversion_energy`.
    pub fn erosion_columns(&self) -> Option<Vec<f64>> {
        let [me, mp] = self.erosion_masses?;
        let eroded = self.fe.as_ref().map_or(0, |f| f.state().eroded());
        let mut v = vec![eroded as f64, me, mp];
        v.extend(self.releases.as_ref().map(|r| r.conversion_energy));
        Some(v)
    }

    /// The kinetic energy the conversions of failed elements into particles took, J.
    pub fn conversion_energy(&self) -> f64 {
        self.releases.as_ref().map_or(0.0, |r| r.conversion_energy)
    }

    /// The masses of `erosion_masses` summed again (collective): the mesh's nodes' and the
    /// particles', each an exact sum over ranks.
    pub fn sum_erosion_masses(&mut self, world: &SimpleCommunicator) {
        let total = |m: &[f64]| fe_petsc::exact::total(world, m);
        let fe_mass = self.fe.as_ref().map_or(0.0, |f| {
            let s = f.state();
            let owned: Vec<f64> = (0..s.mass.len())
                .filter(|&n| s.owned[n])
                .map(|n| s.mass[n])
                .collect();
            total(&owned)
        });
        let sph_mass = self.sph.as_ref().map_or(0.0, |s| {
            let p = &s.stage.parts;
            total(&p.m[..p.n_owned])
        });
        self.erosion_masses = Some([fe_mass, sph_mass]);
    }
}

impl Model {
    /// history.csv's `contact_energy`, J: what the push-back has taken (the contact stage's
    /// sum, the immovable faces' hold on particles included: `SphStage::hold_on_faces`) and
    /// what the rigid walls took.
    pub fn contact_energy(&self) -> f64 {
        let walls = self.walls.as_ref().map_or(0.0, |w| w.energy);
        let holds = self.sph.as_ref().map_or(0.0, |s| s.hold_taken);
        self.contact.as_ref().map_or(0.0, |c| c.energy) + walls + holds
    }

    /// reactions.csv's entries for the row at `time`: each rigid wall's name and its force on
    /// the bodies, N (`Walls::forces`).
    pub fn reactions(&self, time: f64) -> Vec<(String, [f64; 3])> {
        self.walls.as_ref().map_or(Vec::new(), |w| {
            w.names.iter().cloned().zip(w.forces(time)).collect()
        })
    }

    /// The stages that move material, in the order of Fig. 3 (FE, then SPH).
    pub fn stages(&self) -> Vec<&dyn Stage> {
        let mut v: Vec<&dyn Stage> = Vec::new();
        if let Some(fe) = &self.fe {
            v.push(fe);
        }
        if let Some(s) = &self.sph {
            v.push(s);
        }
        v
    }

    /// See [`Model::stages`].
    pub fn stages_mut(&mut self) -> Vec<&mut dyn Stage> {
        let mut v: Vec<&mut dyn Stage> = Vec::new();
        if let Some(fe) = &mut self.fe {
            v.push(fe);
        }
        if let Some(s) = &mut self.sph {
            v.push(s);
        }
        v
    }

    /// The explicit stable step of the present state over all stages (collective).
    pub fn stable_dt(&self, world: &SimpleCommunicator) -> f64 {
        self.stages()
            .iter()
            .map(|s| s.stable_dt(world))
            .fold(f64::INFINITY, f64::min)
    }
}

/// Refuses the combinations of stages and modes that do not exist, naming the key.
pub fn check_scene(scene: &Scene) -> Result<(), String> {
    let file = scene.file.display();
    let implicit = scene.run.mode == Mode::Implicit;
    if implicit && !scene.particles.is_empty() {
        return Err(format!(
            "{file}: run.mode: the SPH stage is explicit only; use mode = \"explicit\" or remove the [[particles]] tables"
        ));
    }
    if implicit {
        if let Some(b) = scene.blocks.iter().find(|b| {
            scene
                .materials
                .iter()
                .any(|m| m.name == b.material && m.model == "fluid")
        }) {
            return Err(format!(
                "{file}: run.mode: block \"{}\" is meshed with the fluid material \"{}\", which is explicit only (its stress is a function of the density, with no strain tangent); use mode = \"explicit\"",
                b.group, b.material
            ));
        }
    }
    if !implicit
        && scene.run.dt.is_none()
        && scene.sph.as_ref().is_some_and(|s| s.profile == "liggghts")
    {
        // LIGGGHTS always runs at the deck's timestep; its integrator (nve/sph) is not stable
        // at the standard step 0.9 x 0.3 h/(c + |v|): a resting water column of 320 particles
        // blows up there in LIGGGHTS 3.8.0 itself (it loses particles) and in this profile
        // alike, and is quiet at the step such decks use (5e-5 s at h = 0.012 m, c = 20 m/s).
        return Err(format!(
            "{file}: run.dt: sph.profile = \"liggghts\" needs a fixed step, as a LIGGGHTS deck gives one (its integrator is unstable at the standard automatic step 0.3 h/(c + |v|)); set run.dt (about 0.1 h/c), or use profile = \"standard\""
        ));
    }
    if scene.contact.is_some() && implicit {
        return Err(format!(
            "{file}: contact: the contact stage runs in explicit mode only; use mode = \"explicit\" or remove the [contact] table"
        ));
    }
    if !scene.loads.is_empty() && scene.meshes.is_empty() {
        return Err(format!(
            "{file}: load[0]: a pressure load acts on mesh faces: a scene of particles only cannot have a [[load]] table"
        ));
    }
    if scene.contact.is_some() && scene.meshes.is_empty() {
        return Err(format!(
            "{file}: mesh: the contact stage needs mesh faces: a scene of particles only cannot have a [contact] table"
        ));
    }
    if implicit && scene.rigid_walls.len() > 32 {
        return Err(format!(
            "{file}: rigid_wall: at most 32 rigid walls in implicit mode ({} given)",
            scene.rigid_walls.len()
        ));
    }
    if let Some(i) = scene.failures.iter().position(Option::is_some) {
        let why = if implicit {
            Some("implicit mode (its tangent has no erosion)")
        } else if scene.run.tetrahedra == crate::input::scene::Tetrahedra::NodalPressure {
            Some("tetrahedra = \"nodal_pressure\" (the native tetrahedra do not fail yet)")
        } else {
            None
        };
        if let Some(why) = why {
            return Err(format!(
                "{file}: material[{i}].failure: element failure is not built yet with {why} (docs/status.md)"
            ));
        }
    }
    if implicit && scene.run.dt.is_none() {
        return Err(format!(
            "{file}: run.dt: mode = \"implicit\" needs a fixed step run.dt (seconds)"
        ));
    }
    Ok(())
}

/// Builds the stages the scene needs (collective; every rank returns the same error).
pub fn build(
    world: &SimpleCommunicator,
    scene: &Scene,
    algorithms: &Algorithms,
) -> Result<Model, RunFailure> {
    let file = scene.file.display().to_string();
    let mut mesh_split = None;
    let (mut fe, groups) = if scene.meshes.is_empty() {
        (None, Groups::default())
    } else {
        let (mesh, groups, summary) = load_mesh(world, scene)?;
        mesh_split = summary;
        let implicit_dt = (scene.run.mode == Mode::Implicit)
            .then_some(scene.run.dt)
            .flatten();
        (
            Some(Fe::new(
                world,
                scene,
                &groups,
                mesh,
                implicit_dt,
                mesh_split.is_some(),
            )?),
            groups,
        )
    };
    if let Some(fe) = &mut fe {
        fe.choose_kernel(world, algorithms.kernel)
            .map_err(RunFailure::from)?;
        super::overlap::check(world, scene, fe.state()).map_err(RunFailure::from)?;
    }
    // A scene whose failed elements become particles has an SPH stage from the start, empty
    // until the first one fails.
    let births = match (&fe, scene.releases_any()) {
        (Some(fe), true) => Some(crate::transfer::fe_sph::births(world, scene, fe.state())),
        _ => None,
    };
    let sph = if scene.particles.is_empty() && births.is_none() {
        None
    } else {
        Some(Sph::new(
            world,
            scene,
            algorithms.sph_kept_pairs,
            algorithms.kernel,
            births,
        )?)
    };
    let probes = Probes::locate(
        world,
        &file,
        &scene.probes,
        fe.as_ref().map(|f| f.state()),
        sph.is_some(),
    )?;
    let block_names: Vec<String> = scene.blocks.iter().map(|b| b.group.clone()).collect();
    let particle_names: Vec<String> = scene.particles.iter().map(|p| p.name.clone()).collect();
    let contact = match (&scene.contact, &mut fe) {
        (Some(def), Some(fe)) => {
            let def = &crate::input::scene::ContactDef {
                particles: Some(def.particles_on(scene)),
                ..def.clone()
            };
            // The FE stage lends the contact stage the nodes and faces of the named surfaces.
            let mesh_ids = fe.mesh.local.global_nodes;
            let surfaces = fe.set_contact_surfaces(world, def, &block_names, &groups);
            // Faces of one body alone, without self-contact or particles to meet them: no pair
            // can form (the same count on every rank; rank 0 says it).
            let particles_meet =
                def.particles == Some(true) && (sph.is_some() || scene.releases_any());
            if surfaces.bodies_in_contact < 2
                && !def.self_contact
                && !particles_meet
                && world.rank() == 0
            {
                eprintln!(
                    "tdyn: warning: {file}: contact.surfaces: {}: no pair can form (pairs are searched between bodies; name the surfaces of the bodies that meet, or set self_contact = true)",
                    match surfaces.bodies_in_contact {
                        0 => "no face of the surfaces named lies on a body's boundary",
                        _ => "every contact face is on one body, and self_contact is false",
                    }
                );
            }
            Some(Contact::new(
                world,
                &file,
                (def, &block_names, &particle_names),
                (&surfaces.lent(), mesh_ids),
                (sph.is_some(), scene.releases_any()),
                SearchChoice {
                    static_decomposition: algorithms.contact_static,
                    kept: algorithms.contact_kept,
                    skins: algorithms.contact_skins,
                },
            )?)
        }
        _ => None,
    };
    let impact = match (&fe, scene.run.mode, scene.run.dt) {
        (Some(fe), Mode::Explicit, None) => super::impact::find(world, scene, fe, &groups),
        _ => None,
    };
    let walls = Walls::new(&scene.rigid_walls);
    if let (None, None, Some(fe)) = (&contact, &walls, &mut fe) {
        // Only the contact stage and the walls' push-back read the start-of-step forces after
        // the kick (`ExplicitFe::apply_contact`'s work).
        fe.state_mut().set_contact_stage(false);
    }
    let mut model = Model {
        fe,
        sph,
        contact,
        walls,
        probes,
        mesh_split,
        erosion_masses: None,
        releases: scene
            .releases_any()
            .then(|| crate::transfer::fe_sph::Releases::new(scene)),
        impact,
    };
    if let Some(w) = &model.walls {
        w.check_start(world, model.fe.as_ref(), model.sph.as_ref(), &file)?;
        if let Some(sph) = model.sph.as_mut() {
            w.size_holds(sph);
        }
    }
    if scene.failures.iter().any(Option::is_some) {
        model.sum_erosion_masses(world);
    }
    Ok(model)
}

/// Meshes the scene's `.geo` files on rank 0 (gmsh, cached; several meshes merged, each moved
/// by its translation), checks the physical groups the scene names, and distributes the mesh
/// (collective). Returns it with the groups and what the split of tetrahedra and prisms did.
fn load_mesh(
    world: &SimpleCommunicator,
    scene: &Scene,
) -> Result<(DistributedMesh, Groups, Option<SplitSummary>), RunFailure> {
    let file = scene.file.display().to_string();
    let mut mesh_path = PathBuf::new();
    let mut surfaces = fe_petsc::mesh::FileSurfaces::default();
    let mut volume_counts: Vec<(i32, usize)> = Vec::new();
    let mut err = None;
    let mut split_counts = [0u64; 4];
    if world.rank() == 0 {
        match mesh_on_root(scene).and_then(|p| check_on_root(scene, &p)) {
            Ok((p, summary, split)) => {
                if let Some(s) = split {
                    split_counts =
                        [s.tetrahedra, s.prisms, s.hexahedra, s.hexahedra_run].map(|n| n as u64);
                }
                mesh_path = p;
                volume_counts = summary.volumes;
                surfaces = fe_petsc::mesh::FileSurfaces {
                    nodes: summary.nodes,
                    surfaces: summary.surfaces,
                };
            }
            Err(e) => err = Some(format!("{file}: {e}")),
        }
    }
    // The agreement step before PETSc reads the mesh collectively.
    first_error(world, err)?;
    world
        .process_at_rank(0)
        .broadcast_into(&mut split_counts[..]);
    let [tetrahedra, prisms, hexahedra, hexahedra_run] = split_counts.map(|n| n as usize);
    let split = SplitSummary {
        tetrahedra,
        prisms,
        hexahedra,
        hexahedra_run,
    };
    let split = split.changed().then_some(split);
    let mut buf = mesh_path.to_string_lossy().into_owned().into_bytes();
    let mut len = buf.len() as u64;
    world.process_at_rank(0).broadcast_into(&mut len);
    buf.resize(len as usize, 0);
    world.process_at_rank(0).broadcast_into(&mut buf[..]);
    let mesh_path = PathBuf::from(String::from_utf8_lossy(&buf).into_owned());
    // Every rank reads the names itself: a rank that cannot (another file system) must not
    // leave the others in the collective read below.
    let names = gmsh::physical_names(&mesh_path).map_err(|e| format!("{file}: mesh: {e}"));
    first_error(world, names.as_ref().err().cloned())?;
    let names = names?;
    let mut groups = Groups::default();
    for n in &names {
        match n.dim {
            3 => {
                groups.volumes.insert(n.name.clone(), n.tag);
            }
            2 => {
                groups.surfaces.insert(n.name.clone(), n.tag);
            }
            _ => {}
        }
    }
    let vols: Vec<String> = groups.volumes.keys().cloned().collect();
    let surfs: Vec<String> = groups.surfaces.keys().cloned().collect();
    scene::validate_groups(scene, &vols, &surfs).map_err(|e| e.to_string())?;
    // A group the scene names must hold elements: gmsh writes the name of a physical group
    // whose entities have none (`Physical Surface("top") = {};`, or a wrong entity number),
    // and a condition or a block on it would act on nothing without a word. Rank 0 read the
    // file's elements; the others learn its verdict.
    let mut err = None;
    if world.rank() == 0 {
        let has_volume = |tag: i32| volume_counts.iter().any(|&(t, n)| t == tag && n > 0);
        let has_surface = |tag: i32| {
            surfaces
                .surfaces
                .iter()
                .any(|(t, f)| *t == tag && !f.is_empty())
        };
        err = scene::validate_groups_hold_elements(
            scene,
            |name| groups.volumes.get(name).is_some_and(|&t| has_volume(t)),
            |name| groups.surfaces.get(name).is_some_and(|&t| has_surface(t)),
        )
        .err()
        .map(|e| e.to_string());
    }
    first_error(world, err)?;
    let mut dm = DistributedMesh::load(world, &mesh_path, &surfaces)
        .map_err(|e| format!("{file}: mesh: {e}"))?;
    // One mesh is moved here; several were moved when merged.
    let tr = scene.meshes[0].translate;
    if scene.meshes.len() == 1 && tr != [0.0; 3] {
        for x in dm.local.coords.iter_mut() {
            for c in 0..3 {
                x[c] += tr[c];
            }
        }
    }
    Ok((dm, groups, split))
}

/// Rank 0 checks the mesh file before PETSc reads it (`msh_check`: a whole file, sound nodes
/// and elements, no inverted or flat element); a mesh in another format than ASCII msh 2.2 is
/// checked through its conversion by gmsh. Tetrahedra and prisms are then split into
/// hexahedra (`split`, cached beside the conversions), and the split file is checked again
/// for its summary. What PETSc reads is the last of these files (the physical surfaces'
/// faces, from its check, index its nodes in its order). Returns the file to read, the
/// check's summary and what the split did.
fn check_on_root(
    scene: &Scene,
    msh: &Path,
) -> Result<(PathBuf, msh_check::MshSummary, Option<SplitSummary>), String> {
    let cache = gmsh::default_cache_dir(&scene.dir);
    let m22 = gmsh::as_msh22(msh, &cache).map_err(|e| format!("mesh: {e}"))?;
    let summary =
        msh_check::check_file(&m22).map_err(|e| format!("mesh {}: {e}", msh.display()))?;
    if summary.not_hexahedral == 0 {
        // Hexahedra only: the file runs as it is (not read again).
        return Ok((m22, summary, None));
    }
    if scene.run.tetrahedra == Tetrahedra::NodalPressure {
        // Tetrahedra run natively: the file as it is, once checked for what they cannot be.
        split::check_native(&m22).map_err(|e| format!("mesh: {e}"))?;
        return Ok((m22, summary, None));
    }
    let (run, split) = split::split_file(&m22, &cache).map_err(|e| format!("mesh: {e}"))?;
    if split.is_none() {
        return Ok((m22, summary, None));
    }
    let summary = msh_check::check_file(&run)
        .map_err(|e| format!("mesh {} (split into hexahedra): {e}", msh.display()))?;
    Ok((run, summary, split))
}

/// The `.msh` of the scene's meshes, meshed and merged on rank 0.
fn mesh_on_root(scene: &Scene) -> Result<PathBuf, String> {
    let mut parts = Vec::new();
    for (i, m) in scene.meshes.iter().enumerate() {
        let cache = gmsh::default_cache_dir(m.file.parent().unwrap_or(Path::new(".")));
        let p = gmsh::mesh_file(m, &cache).map_err(|e| format!("mesh[{i}]: {e}"))?;
        parts.push((p, m.translate));
    }
    if parts.len() == 1 {
        return Ok(parts.remove(0).0);
    }
    gmsh::merge(&parts, &gmsh::default_cache_dir(&scene.dir)).map_err(|e| format!("mesh: {e}"))
}
