//! The run's files while it runs (docs/scene.md "Output"): `fields.h5` + `fields.xmf` frames of
//! every stage, `history.csv` rows summed over the stages, `probes.csv`, particle dumps.
use super::setup::Model;
use crate::input::scene::Scene;
use crate::output::{
    exact_forces, write_particle_dump, Connectivity, ElementFrame, FieldWriter, ForceHistory,
    GlobalCounts, History, NodeFrame, Values,
};
use crate::stages::StageEnergies;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The columns history.csv writes as integers (docs/scene.md).
pub const HISTORY_INTEGER_COLUMNS: [&str; 3] = ["step", "contacts", "eroded_elements"];

/// Columns history.csv adds after [`HISTORY_COLUMNS`] (and the contact ones) where a material
/// fails (docs/scene.md `failure`).
pub const EROSION_HISTORY_COLUMNS: [&str; 3] =
    ["eroded_elements", "mass_elements", "mass_particles"];

/// The column history.csv adds after [`EROSION_HISTORY_COLUMNS`] where failed elements
/// become particles: the kinetic energy the conversions took, J (docs/output.md).
pub const CONVERSION_HISTORY_COLUMN: &str = "conversion_energy";

/// Columns of history.csv, in order (docs/scene.md).
pub const HISTORY_COLUMNS: [&str; 13] = [
    "step",
    "time",
    "dt",
    "kinetic_energy",
    "internal_energy",
    "hourglass_energy",
    "external_work",
    "contact_energy",
    "energy_error",
    "momentum_x",
    "momentum_y",
    "momentum_z",
    "contacts",
];

/// Columns history.csv adds after [`HISTORY_COLUMNS`] in a run with contact: the search's
/// balance (max/mean over ranks of owned nodes + faces held) and the bytes the stage sent point
/// to point (all ranks, RCB included), both of the step.
pub const CONTACT_HISTORY_COLUMNS: [&str; 2] = ["contact_imbalance", "contact_bytes"];

/// history.csv's per-block columns, after the docs/scene.md ones: `hourglass_energy.<group>` and
/// `internal_energy.<group>` for each `[[block]]` in scene order.
pub fn block_history_columns(scene: &Scene) -> Vec<String> {
    scene
        .blocks
        .iter()
        .flat_map(|b| {
            [
                format!("hourglass_energy.{}", b.group),
                format!("internal_energy.{}", b.group),
            ]
        })
        .collect()
}

/// The mesh's output layout on this rank: owned nodes and their ids (fixed for the run; the
/// elements' connectivity by node id is made for each frame from the local one).
struct MeshLayout {
    owned_nodes: Vec<usize>,
    node_ids: Vec<u64>,
    rank_field: Vec<i32>,
    /// Global id of each local element (hexahedra, then native tetrahedra).
    elem_ids: Vec<u64>,
}

/// The open output files of a run.
pub struct Outputs {
    writer: FieldWriter,
    history: History,
    probes: History,
    /// reactions.csv (a run with FE) and contact_forces.csv (a run with contact).
    reactions: Option<ForceHistory>,
    /// See `reactions`.
    contact_forces: Option<ForceHistory>,
    mesh: Option<MeshLayout>,
    particle_ranks: Vec<i32>,
    particle_labels: Vec<u64>,
    dump_dir: PathBuf,
    /// The run's folder (for messages naming history.csv and probes.csv).
    dir: PathBuf,
    dump_every: u64,
    rank: i32,
    /// Time spent writing (this rank), s.
    pub wall_s: f64,
}

impl Outputs {
    /// Creates the output folder and files (collective); with `restart`, reopens the run's
    /// files instead, keeping what was written up to the checkpoint.
    pub fn create(
        world: &SimpleCommunicator,
        out_dir: &Path,
        scene: &Scene,
        model: &Model,
        restart: Option<&super::checkpoint::Meta>,
    ) -> Result<Outputs, String> {
        let rank = world.rank();
        let mut err = None;
        if rank == 0 {
            if let Err(e) = std::fs::create_dir_all(out_dir) {
                err = Some(format!(
                    "cannot create output directory {}: {e}",
                    out_dir.display()
                ));
            }
        }
        crate::kernels::collective::first_error(world, err)?;
        let mesh = model.fe.as_ref().map(|fe| {
            let (l, st) = (&fe.mesh.local, fe.state());
            let owned_nodes: Vec<usize> = (0..st.n_nodes()).filter(|&n| st.owned[n]).collect();
            MeshLayout {
                node_ids: owned_nodes.iter().map(|&n| l.node_id[n]).collect(),
                owned_nodes,
                rank_field: vec![rank; st.n_elements()],
                elem_ids: (0..st.n_elements()).map(|e| st.element_id(e)).collect(),
            }
        });
        let counts = GlobalCounts {
            nodes: model.fe.as_ref().map_or(0, |f| f.mesh.local.global_nodes),
            elements: model.fe.as_ref().map_or(0, |f| f.mesh.local.global_elems),
            particles: model.sph.as_ref().map_or(0, |s| s.n_total),
        };
        let fields = &scene.output.fields;
        let writer = match restart {
            None => FieldWriter::create(world, out_dir, counts, fields),
            Some(m) => FieldWriter::reopen(world, out_dir, counts, fields, &m.frames),
        }
        .map_err(|e| format!("{}: {e}", out_dir.display()))?;
        let mut cols: Vec<String> = HISTORY_COLUMNS.iter().map(|c| c.to_string()).collect();
        if model.contact.is_some() {
            cols.extend(CONTACT_HISTORY_COLUMNS.iter().map(|c| c.to_string()));
        }
        if model.erosion_masses.is_some() {
            cols.extend(EROSION_HISTORY_COLUMNS.iter().map(|c| c.to_string()));
            if model.releases.is_some() {
                cols.push(CONVERSION_HISTORY_COLUMN.to_string());
            }
        }
        if model.fe.is_some() {
            cols.extend(block_history_columns(scene));
        }
        let cols: Vec<&str> = cols.iter().map(|c| c.as_str()).collect();
        let mut probe_cols = vec!["time".to_string()];
        probe_cols.extend(model.probes.columns.iter().cloned());
        let probe_cols: Vec<&str> = probe_cols.iter().map(|s| s.as_str()).collect();
        let (hpath, ppath) = (out_dir.join("history.csv"), out_dir.join("probes.csv"));
        let opened = match restart {
            None => History::create(world, &hpath, &cols)
                .and_then(|h| History::create(world, &ppath, &probe_cols).map(|p| (h, p))),
            Some(m) => History::reopen(world, &hpath, &cols, m.history_rows).and_then(|h| {
                History::reopen(world, &ppath, &probe_cols, m.probe_rows).map(|p| (h, p))
            }),
        }
        .map_err(|e| e.to_string());
        crate::kernels::collective::first_error(world, opened.as_ref().err().cloned())?;
        let (history, probes) = opened?;
        let (reactions, contact_forces) =
            open_force_files(world, out_dir, model, restart.map(|m| m.history_rows))?;
        Ok(Outputs {
            writer,
            history: history.integer_columns(&HISTORY_INTEGER_COLUMNS),
            probes,
            reactions,
            contact_forces,
            mesh,
            particle_ranks: Vec::new(),
            particle_labels: Vec::new(),
            dump_dir: out_dir.join("dumps"),
            dir: out_dir.to_path_buf(),
            dump_every: if model.sph.is_some() {
                scene.output.dump_every
            } else {
                0
            },
            rank,
            wall_s: 0.0,
        })
    }

    /// What a checkpoint keeps of the files: history and probe rows written, the frames.
    pub fn progress(&self) -> (usize, usize, String) {
        (self.history.rows(), self.probes.rows(), self.writer.index())
    }

    /// Flushes the CSV files (before a checkpoint names their row counts).
    pub fn flush_rows(&mut self) -> Result<(), String> {
        let history = self
            .history
            .flush()
            .map_err(|e| self.named("history.csv", e));
        let probes = self.probes.flush().map_err(|e| self.named("probes.csv", e));
        let forces = self.flush_forces();
        history.and(probes).and(forces)
    }

    /// Flushes reactions.csv and contact_forces.csv.
    fn flush_forces(&mut self) -> Result<(), String> {
        let r = self.reactions.as_mut().map_or(Ok(()), |f| f.flush());
        let r = r.map_err(|e| self.named(REACTIONS_FILE, e));
        let c = self.contact_forces.as_mut().map_or(Ok(()), |f| f.flush());
        let c = c.map_err(|e| self.named(CONTACT_FORCES_FILE, e));
        r.and(c)
    }

    /// The rows of reactions.csv and contact_forces.csv at `time` (collective: the forces are
    /// summed over ranks; rank 0 writes). The error is this rank's own.
    pub fn force_rows(
        &mut self,
        world: &SimpleCommunicator,
        model: &Model,
        time: f64,
    ) -> Result<(), String> {
        let t0 = Instant::now();
        // Both files' sums in one exact reduction (two collectives): the reactions' entries,
        // then each contact body's total force and the pairs touched.
        let (mut terms, n_reactions) = reaction_terms(model);
        let (contact_terms, touched) = match &model.contact {
            Some(c) => c.pair_forces.terms(),
            None => (Vec::new(), Vec::new()),
        };
        terms.extend(contact_terms);
        let (forces, touched) = exact_forces(world, &terms, &touched);
        let (reactions, totals) = forces.split_at(n_reactions);
        // The rigid walls' forces after the FE groups' (already summed over ranks).
        let mut reactions = reactions.to_vec();
        reactions.extend(model.reactions(time).into_iter().map(|e| e.1));
        let mut res = Ok(());
        if let Some(file) = self.reactions.as_mut() {
            res = file.row(time, &reactions).map_err(|e| (REACTIONS_FILE, e));
        }
        if let (Some(file), Some(c)) = (self.contact_forces.as_mut(), model.contact.as_ref()) {
            let r = file.row(time, &c.pair_forces.row(totals, &touched));
            res = res.and(r.map_err(|e| (CONTACT_FORCES_FILE, e)));
        }
        self.wall_s += t0.elapsed().as_secs_f64();
        res.map_err(|(name, e)| self.named(name, e))
    }

    /// Writes a frame of every stage at `time` (collective).
    pub fn frame(&mut self, time: f64, model: &Model) -> Result<(), String> {
        let t0 = Instant::now();
        // The mesh's columns, each row made only when the frame sends it.
        let fe = match (&self.mesh, &model.fe) {
            (Some(m), Some(fe)) => Some((m, fe.state(), &fe.mesh.local.node_id[..])),
            _ => None,
        };
        // Owned node i's local node.
        let node = |i: usize| fe.map_or(0, |(m, _, _)| m.owned_nodes[i]);
        let pos = |i| fe.map_or([0.0; 3], |(_, st, _)| st.x[node(i)]);
        let disp = |i| {
            fe.map_or([0.0; 3], |(_, st, _)| {
                let n = node(i);
                std::array::from_fn(|c| st.x[n][c] - st.x0[n][c])
            })
        };
        let vel = |i| fe.map_or([0.0; 3], |(_, st, _)| st.v[node(i)]);
        let stress = |e: usize| fe.map_or([0.0; 6], |(_, st, _)| st.stress(e));
        let eps = |e| fe.map_or(0.0, |(_, st, _)| st.plastic_strain(e));
        let pressure = |e| fe.map_or(0.0, |(_, st, _)| st.pressure(e));
        let temperature = |e| fe.map_or(f64::NAN, |(_, st, _)| st.temperature(e));
        let failed = |e: usize| {
            fe.map_or(0.0, |(_, st, _)| {
                (e < st.elems.len() && st.is_failed(e)) as u8 as f64
            })
        };
        let nodes = fe.map(|(m, _, _)| NodeFrame {
            ids: &m.node_ids,
            position: Values::Made(&pos),
            displacement: Some(Values::Made(&disp)),
            velocity: Some(Values::Made(&vel)),
        });
        let corners = |e: usize| fe.map_or([0; 8], |(_, st, _)| st.element_nodes(e));
        let elems = fe.map(|(m, st, local_ids)| ElementFrame {
            ids: &m.elem_ids,
            connectivity: match st.tets {
                None => Connectivity::Local {
                    nodes: &st.elems,
                    ids: local_ids,
                },
                Some(_) => Connectivity::Made {
                    nodes: &corners,
                    ids: local_ids,
                },
            },
            stress: Some(Values::Made(&stress)),
            plastic_strain: Some(Values::Made(&eps)),
            pressure: Some(Values::Made(&pressure)),
            temperature: Some(Values::Made(&temperature)),
            failed: Some(Values::Made(&failed)),
            rank: Some(&m.rank_field),
        });
        let rank = self.rank;
        let parts = model
            .sph
            .as_ref()
            .map(|s| s.frame(&mut self.particle_ranks, &mut self.particle_labels, rank));
        if let Some(s) = &model.sph {
            self.writer.set_particle_count(s.n_total);
        }
        self.writer
            .write_frame(time, nodes.as_ref(), elems.as_ref(), parts.as_ref())
            .map_err(|e| format!("writing fields.h5: {e}"))?;
        self.wall_s += t0.elapsed().as_secs_f64();
        Ok(())
    }

    /// Writes a particle dump of step `step` when one is due (`output.dump_every`; always at
    /// the end); collective.
    pub fn dump(
        &mut self,
        world: &SimpleCommunicator,
        step: u64,
        last: bool,
        model: &Model,
    ) -> Result<(), String> {
        let Some(s) = &model.sph else { return Ok(()) };
        if self.dump_every == 0 || !(step.is_multiple_of(self.dump_every) || last) {
            return Ok(());
        }
        let t0 = Instant::now();
        write_particle_dump(world, &self.dump_dir, step, &s.stage.parts, &s.ids).map_err(|e| {
            let file = self.dump_dir.join(format!("dump.tdyn.{step}"));
            format!("{}: {e}", file.display())
        })?;
        self.wall_s += t0.elapsed().as_secs_f64();
        Ok(())
    }

    /// A history.csv row and a probes.csv row (collective: the probes are sampled on every
    /// rank, also when the history row failed, which only rank 0 writes). The error is this
    /// rank's own: the caller agrees on it.
    pub fn rows(
        &mut self,
        world: &SimpleCommunicator,
        model: &Model,
        row: &HistoryRow,
    ) -> Result<(), String> {
        let history = self.history_row(model, row);
        let mut pr = vec![row.time];
        pr.extend(model.probes.sample(
            world,
            model.fe.as_ref().map(|f| f.state()),
            model.sph.as_ref().map(|s| &s.stage),
        ));
        let probes = self
            .probes
            .row(&pr)
            .map_err(|e| self.named("probes.csv", e));
        let forces = self.force_rows(world, model, row.time);
        history.and(probes).and(forces)
    }

    /// A write error of the run's file `name` as the line to print.
    fn named(&self, name: &str, e: std::io::Error) -> String {
        format!("{}: {e}", self.dir.join(name).display())
    }

    /// Only the history.csv row (the row before a run stops), flushed.
    pub fn history_row(&mut self, model: &Model, row: &HistoryRow) -> Result<(), String> {
        let e = &row.energies;
        let mut r = vec![
            row.step as f64,
            row.time,
            row.dt,
            e.kinetic,
            e.internal,
            e.hourglass,
            e.external_work,
            model.contact_energy(),
            row.energy_error,
            e.momentum[0],
            e.momentum[1],
            e.momentum[2],
            model
                .contact
                .as_ref()
                .map_or(0.0, |c| c.stats.contacts as f64),
        ];
        if let Some(c) = &model.contact {
            r.extend(c.history_columns());
        }
        if let Some(e) = model.erosion_columns() {
            r.extend(e);
        }
        if let Some(fe) = &model.fe {
            for b in &fe.state().block_energies {
                r.extend([b.hourglass, b.internal]);
            }
        }
        self.history
            .row(&r)
            .map_err(|e| self.named("history.csv", e))
    }

    /// Flushes history.csv (before a run stops with an error).
    pub fn flush(&mut self) {
        let _ = self.history.flush();
        let _ = self.probes.flush();
        let _ = self.flush_forces();
    }

    /// Closes the files; returns the bytes of fields.h5 this rank wrote.
    pub fn finish(mut self) -> Result<u64, String> {
        let written = self.writer.bytes_written();
        // Both whatever the other's result (closing fields.h5 is collective).
        let rows = self.flush_rows();
        self.writer.finish().map_err(|e| e.to_string())?;
        rows.map(|_| written)
    }
}

/// The force histories' file names (docs/output.md).
pub const REACTIONS_FILE: &str = "reactions.csv";
/// See [`REACTIONS_FILE`].
pub const CONTACT_FORCES_FILE: &str = "contact_forces.csv";

/// reactions.csv's entries, in order: the FE stage's `fixed` and `velocity` groups in scene
/// order (docs/output.md), then the rigid walls (`Model::reactions`, whose forces are
/// summed over ranks already and join the row after the groups' in `force_rows`).
fn reaction_names(model: &Model) -> Vec<String> {
    let mut names = Vec::new();
    if let Some(fe) = &model.fe {
        names.extend(fe.reaction_groups.iter().map(|g| g.name.clone()));
    }
    names.extend(model.reactions(0.0).into_iter().map(|e| e.0));
    names
}

/// This rank's terms of the force of each of [`reaction_names`]' entries now
/// (`terms[3 k + c]`: component c of entry k; [`exact_forces`] sums them), and the entries.
fn reaction_terms(model: &Model) -> (Vec<Vec<f64>>, usize) {
    let mut terms = Vec::new();
    if let Some(fe) = &model.fe {
        terms.extend(fe.reaction_terms());
    }
    let n = terms.len() / 3;
    (terms, n)
}

/// Opens reactions.csv (a run with FE: its `fixed` and `velocity` groups) and
/// contact_forces.csv (a run with contact: its pairs of blocks), created or, with `rows` (a
/// restart), reopened keeping that many rows (collective: one agreed error).
#[allow(clippy::type_complexity)]
fn open_force_files(
    world: &SimpleCommunicator,
    out_dir: &Path,
    model: &Model,
    rows: Option<usize>,
) -> Result<(Option<ForceHistory>, Option<ForceHistory>), String> {
    let open = |name: &str, names: &[String]| {
        let path = out_dir.join(name);
        ForceHistory::open(world, &path, names, rows)
            .map_err(|e| format!("{}: {e}", path.display()))
    };
    let names = reaction_names(model);
    let reactions = (model.fe.is_some() || !names.is_empty())
        .then(|| open(REACTIONS_FILE, &names))
        .transpose();
    let pairs = model
        .contact
        .as_ref()
        .map(|c| open(CONTACT_FORCES_FILE, &c.pair_forces.names))
        .transpose();
    let err = reactions.as_ref().err().or(pairs.as_ref().err()).cloned();
    crate::kernels::collective::first_error(world, err)?;
    Ok((reactions?, pairs?))
}

/// What one history.csv row says besides the stages' own columns.
pub struct HistoryRow {
    /// Step number.
    pub step: u64,
    /// Time, s.
    pub time: f64,
    /// The step just taken (at step 0 the first one), s.
    pub dt: f64,
    /// Energies and momentum summed over the stages.
    pub energies: StageEnergies,
    /// The relative energy error.
    pub energy_error: f64,
}
