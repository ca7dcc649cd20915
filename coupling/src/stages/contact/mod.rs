//! The contact stage (Fig. 3, steps 4-5; Fig. 10): the FE surfaces' nodes and faces and the SPH
//! particles as contact nodes on their own RCB decomposition (`stage`), the search and the
//! push-back, and the corrections sent back to the FE and SPH owners. `baseline` searches on
//! the static FE decomposition instead (the paper's comparison, for benchmarks only).
//!
//! The stage is a coupler: it sees the bodies only through [`body::ContactBody`] (the FE and
//! SPH stages implement it), and the energy bookkeeping of its corrections is the `contact`
//! crate's (`contact::energy`).
use crate::input::scene::ContactDef;
use crate::kernels::collective;
use crate::output::{Report, StageStats};
use baseline::BaselineStage;
use body::ContactBody;
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::{Communicator, CommunicatorCollectives};
use stage::{ContactOutcome, ContactStage};
use std::time::Instant;

pub mod baseline;
pub mod body;
mod cells;
pub mod pairs;
pub mod stage;

/// Where contact is searched: the dynamic RCB decomposition (Fig. 10), or, for benchmarks only
/// (`tdyn run --contact-decomposition static`), the static FE decomposition.
enum Search {
    Dynamic(ContactStage),
    Baseline(BaselineStage),
}

/// How the stage searches (`tdyn run --contact-decomposition`, `--contact-rebuild`,
/// `--contact-skins`): choices that change the cost, not the answer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchChoice {
    /// Search on the static FE decomposition (the paper's baseline; mesh nodes only).
    pub static_decomposition: bool,
    /// Keep the decomposition and candidate lists between steps within their skins.
    pub kept: bool,
    /// The skins as multiples of the step's largest motion (ghost faces, candidates); `None`:
    /// the stage's defaults.
    pub skins: Option<(f64, f64)>,
}

/// What the stage found and cost, summed over the steps.
#[derive(Debug, Clone, Default)]
pub struct ContactStats {
    /// Steps taken.
    pub steps: u64,
    /// Contacts found in the last step.
    pub contacts: u64,
    /// Contacts summed over steps, and the most in one step.
    pub contacts_total: u64,
    /// See `contacts_total`.
    pub contacts_max: u64,
    /// Wall time of the stage on this rank, s.
    pub wall_s: f64,
    /// Bytes sent point to point (all ranks, RCB included), summed over steps.
    pub bytes: f64,
    /// Search imbalance (max/mean over ranks of nodes + faces held): summed over steps (for
    /// the mean), the largest, and the last step's.
    pub imbalance_sum: f64,
    /// See `imbalance_sum`.
    pub imbalance_max: f64,
    /// See `imbalance_sum`.
    pub last_imbalance: f64,
    /// The last step's bytes (history.csv).
    pub last_bytes: f64,
    /// Nodes + faces searched summed over steps: on the busiest rank, and over all ranks.
    pub work_max_sum: f64,
    /// See `work_max_sum`.
    pub work_total_sum: f64,
    /// The contact decomposition's RCB: nodes moved between contact owners, bytes sent, wall
    /// time (each call's max over ranks) and imbalance, summed over steps.
    pub rcb_migrated: u64,
    /// See `rcb_migrated`.
    pub rcb_bytes: f64,
    /// See `rcb_migrated`.
    pub rcb_wall_s: f64,
    /// See `rcb_migrated`.
    pub rcb_imbalance_sum: f64,
    /// Steps whose RCB rebalanced (those `rcb_imbalance_sum` sums over).
    pub rcb_rebalances: u64,
    /// Transfers between decompositions (FE/SPH owners <-> contact owners): bytes, time (each
    /// step's max over ranks) and byte imbalance, summed over steps.
    pub transfer_bytes: f64,
    /// See `transfer_bytes`.
    pub transfer_s: f64,
    /// See `transfer_bytes`.
    pub transfer_imbalance_sum: f64,
    /// Push-back solves summed over steps, and the most in one step.
    pub solves_total: u64,
    /// See `solves_total`.
    pub solves_max: u64,
    /// Contacts the rechecks after a push-back added, summed over steps.
    pub rechecked_total: u64,
    /// Contacts sharing a node with a contact of another box, summed over steps.
    pub coupled_total: u64,
    /// Contacts by kind (`PushbackCounts::kinds`), summed over steps.
    pub kinds_total: [u64; 4],
    /// The push-back's Gauss-Seidel sweeps, summed over steps.
    pub sweeps_total: u64,
    /// The push-back's bytes over all ranks, and the largest rank's, summed over steps.
    pub pushback_bytes: f64,
    /// See `pushback_bytes`.
    pub pushback_bytes_max_sum: f64,
    /// Contacts solved by the busiest rank's push-back, summed over steps.
    pub pushback_rows_max_sum: f64,
    /// Contacts between two immovable sides (skipped), summed over steps.
    pub immovable_total: u64,
    /// Contacts whose depth was bounded by the step's own penetration, summed over steps.
    pub bounded_total: u64,
    /// Steps whose push-back was scaled down so as to add no energy.
    pub energy_limited_steps: u64,
}

impl ContactStats {
    fn add(&mut self, out: &ContactOutcome) {
        self.contacts = out.contacts;
        self.bytes += out.bytes_sent as f64;
        self.imbalance_sum += out.imbalance;
        self.imbalance_max = self.imbalance_max.max(out.imbalance);
        self.work_max_sum += out.work_items_max;
        self.work_total_sum += out.work_items_total;
        self.last_imbalance = out.imbalance;
        self.last_bytes = out.bytes_sent as f64;
        self.contacts_total += out.contacts;
        self.contacts_max = self.contacts_max.max(out.contacts);
        self.rcb_migrated += out.rcb.migrated;
        self.rcb_bytes += out.rcb.bytes_sent as f64;
        self.rcb_wall_s += out.rcb.wall_s;
        if out.rcb.imbalance > 0.0 {
            self.rcb_imbalance_sum += out.rcb.imbalance;
            self.rcb_rebalances += 1;
        }
        self.transfer_bytes += out.transfer.bytes_sent as f64;
        self.transfer_s += out.transfer.wall_s;
        self.transfer_imbalance_sum += out.transfer.imbalance;
        self.solves_total += out.pushback.solves;
        self.solves_max = self.solves_max.max(out.pushback.solves);
        self.rechecked_total += out.pushback.rechecked;
        self.coupled_total += out.pushback.coupled;
        self.sweeps_total += out.pushback.sweeps;
        self.pushback_bytes += out.pushback.bytes as f64;
        self.pushback_bytes_max_sum += out.pushback.bytes_max as f64;
        self.pushback_rows_max_sum += out.pushback.rows as f64;
        self.immovable_total += out.pushback.immovable;
        self.bounded_total += out.pushback.bounded;
        for (t, k) in self.kinds_total.iter_mut().zip(out.pushback.kinds) {
            *t += k;
        }
        self.steps += 1;
    }
}

/// Relative size below which a positive work of the push-back is round-off: `W <= tol (|A| +
/// B)` (`energy_guard`).
pub const ENERGY_TOL: f64 = 1e-9;

/// The push-back's energy injection a step may keep, as a fraction of the run's energy scale
/// (`energy_guard`).
pub const ENERGY_INJECTION_BUDGET: f64 = 1e-6;

/// Contact never gives energy back (docs/scene.md; `contact::pushback`, "Only the step's own
/// penetration"). The push-back is an impulse on the half-step velocities `v(n+1/2)` that the
/// drift moved the nodes with; for its forces scaled by `alpha` it changes their kinetic
/// energy by `dK(alpha) = alpha A + alpha^2 B` (`A = sum m dv . v(n+1/2)`, `B = sum m |dv|^2 /
/// 2`, `dv = F dt / m`, summed over ranks: FE nodes and particles; `A` also holds the contact
/// force's work on the nodes a `velocity` boundary drives, `contact::energy::constrained_work`,
/// so that a driven face pushing a free node is not read as contact adding energy). An inelastic projection has
/// `dK <= 0`, and so do the bounded rows of a linear solve (restitution at most 1); what the
/// geometric passes, the rechecks' rows and friction leave can be positive. Where `dK(1)` is
/// positive past round-off ([`ENERGY_TOL`]) and past [`ENERGY_INJECTION_BUDGET`] of the run's
/// energy scale `S`, the forces are scaled by the largest `alpha` in `[0, 1]` that keeps it
/// within that budget (a root of `alpha A + alpha^2 B = budget`). An injection like one new
/// contact pushing a node out at its depth over dt, which no motion explains, is thereby cut
/// wherever the bound missed it.
///
/// The measure is the half-step one, not the booked work (`contact_energy`, which velocity
/// Verlet books against the start velocity `v(n)`, `m dv . (v(n) + dv/2)`): the two differ by
/// `(dt/2) m a(n) . dv`, second order in dt, and where contact holds bodies that a large
/// acceleration presses together from rest the booked work is positive while the impulse only
/// takes energy away. Measured on `underwater_explosion` (the detonation products pressing on
/// the cavity from t = 0): guarding the booked work scaled the first steps' forces down, the
/// particles ended behind the cavity's faces, beyond the search's reach, and the peak pressures
/// fell to 13-16 % of Cole's law (90 % with the half-step measure). Returns `alpha` (1:
/// untouched; the same on every rank). Collective.
fn energy_guard(
    world: &SimpleCommunicator,
    (mesh, particles): (&dyn ContactBody, Option<&dyn ContactBody>),
    (fe_force, sph_force): (&mut [[f64; 3]], &mut [[f64; 3]]),
    (dt, budget): (f64, f64),
) -> f64 {
    // The mesh's and the particles' terms on their own grids, each exact (the same bits at
    // any rank count), added once reduced.
    let mut t = mesh.energy_terms(fe_force, dt).to_vec();
    t.extend(particles.map_or([[0.0; 3]; 2], |s| s.energy_terms(sph_force, dt)));
    let flat = fe_petsc::exact::flatten(&t);
    let mut g = vec![0.0f64; flat.len()];
    world.all_reduce_into(&flat[..], &mut g[..], SystemOperation::sum());
    let g = fe_petsc::exact::values(&g);
    let (a, b) = (g[0] + g[2], g[1] + g[3]);
    let w = a + b;
    if w <= ENERGY_TOL * (a.abs() + b) || w <= budget || b <= 0.0 {
        return 1.0;
    }
    // The larger root of alpha A + alpha^2 B = budget (>= -A / B, where W is back to 0).
    let budget = budget.max(0.0);
    let alpha = ((-a + (a * a + 4.0 * b * budget).sqrt()) / (2.0 * b)).clamp(0.0, 1.0) + 0.0;
    for f in fe_force.iter_mut().chain(sph_force.iter_mut()) {
        *f = f.map(|c| c * alpha);
    }
    alpha
}

/// What the contact stage is told of the surfaces a body lends it when it starts (the FE
/// stage's: `transfer::fe_contact`), for contact_forces.csv's columns and the report.
#[derive(Debug, Clone, Default)]
pub struct LentSurfaces {
    /// The report's figures.
    pub figures: SurfaceFigures,
    /// Each body's block (index in the scene's `[[block]]` order).
    pub body_block: Vec<u32>,
    /// Whether each block has a contact face.
    pub block_in_contact: Vec<bool>,
}

/// The report's figures of the contact surfaces lent to the stage.
#[derive(Debug, Clone, Copy, Default)]
pub struct SurfaceFigures {
    /// This rank's owned contact nodes.
    pub nodes: usize,
    /// Faces over all ranks.
    pub global_faces: u64,
    /// Bodies in the mesh, and the masters of a one-pass search among them.
    pub n_bodies: u32,
    /// See `n_bodies`.
    pub masters: usize,
}

/// The contact stage of a run with `[contact]`.
pub struct Contact {
    /// What the report tells of the FE stage's contact surfaces.
    surfaces: SurfaceFigures,
    search: Search,
    /// SPH particles are contact nodes too (`contact.particles`), with ids from this offset
    /// (the mesh's node count, so no particle id meets a node id).
    particles: bool,
    particle_gid_offset: u64,
    /// Search passes between bodies (`[contact] passes`: 2, or 1 with master bodies).
    passes: i64,
    /// Energy taken by the push-back (minus the work of the contact forces), J.
    pub energy: f64,
    /// The run's energy scale after the last step (the energy error's denominator), J: the
    /// driver sets it (`energy_guard`).
    pub energy_scale: f64,
    /// What it found and cost.
    pub stats: ContactStats,
    /// contact_forces.csv's columns and the last step's forces ([`pairs`]).
    pub pair_forces: pairs::PairForces,
}

impl Contact {
    /// The stage for the scene's `[contact]` table over the contact surfaces the bodies lend
    /// (`surfaces`; collective). `mesh_ids`: the mesh's node count (the particles' ids start
    /// there). `with_particles`: the run has an SPH stage; `releases`: failed elements become
    /// particles (contact_forces.csv's `<block>-failed_particles` columns).
    pub fn new(
        world: &SimpleCommunicator,
        file: &str,
        (def, blocks, particle_sets): (&ContactDef, &[String], &[String]),
        (surfaces, mesh_ids): (&LentSurfaces, u64),
        (with_particles, releases): (bool, bool),
        choice: SearchChoice,
    ) -> Result<Contact, String> {
        // contact_forces.csv: every pair of blocks with contact faces, in scene order, then
        // each block with the particle sets, where particles take part.
        let particles =
            def.particles == Some(true) && with_particles && !choice.static_decomposition;
        let sets = if particles { particle_sets } else { &[] };
        let pair_forces = pairs::PairForces::new(
            blocks,
            &surfaces.block_in_contact,
            &surfaces.body_block,
            (sets, particles && releases),
        );
        if surfaces.figures.global_faces == 0 {
            return Err(format!(
                "{file}: contact.surfaces: no boundary face lies on {:?}",
                def.surfaces
            ));
        }
        let mut dynamic = ContactStage::new(world, def.self_contact, def.passes == 1);
        dynamic.configure(choice.kept, choice.skins);
        dynamic.friction = def.friction;
        let search = if choice.static_decomposition {
            let mut b = BaselineStage::new(world, dynamic.params);
            b.friction = def.friction;
            Search::Baseline(b)
        } else {
            Search::Dynamic(dynamic)
        };
        Ok(Contact {
            surfaces: surfaces.figures,
            search,
            particles,
            particle_gid_offset: mesh_ids,
            passes: def.passes,
            energy: 0.0,
            energy_scale: 0.0,
            stats: ContactStats {
                last_imbalance: 1.0,
                ..ContactStats::default()
            },
            pair_forces,
        })
    }

    /// Steps 4-5 of Fig. 3 after the drift: detection on the contact decomposition, push-back
    /// forces back on the bodies, the mesh's (`mesh`: its nodes, all copies, and faces) and
    /// the particles' (where they take part), positions and half-step velocities corrected
    /// (collective). `t`: the time at the step's start.
    pub fn step(
        &mut self,
        world: &SimpleCommunicator,
        (mesh, particles): (&mut dyn ContactBody, Option<&mut dyn ContactBody>),
        (t, dt): (f64, f64),
    ) -> Result<(), String> {
        let t0 = Instant::now();
        // Faces opened by failed elements: the kept decomposition holds the old ones.
        if mesh.update_faces(world) {
            if let Search::Dynamic(stage) = &mut self.search {
                stage.forget_decomposition();
            }
        }
        let mut nodes = mesh.contact_nodes(0, dt);
        let n_fe = nodes.len();
        let mut particles = particles.filter(|_| self.particles);
        if let Some(s) = &particles {
            nodes.extend(s.contact_nodes(self.particle_gid_offset, dt));
        }
        let out = match &mut self.search {
            Search::Dynamic(stage) => {
                let lender = &*mesh;
                stage.step(&nodes, || lender.contact_faces(), dt)?
            }
            Search::Baseline(stage) => {
                // the benchmark baseline searches mesh nodes only (`particles` is off)
                let faces = mesh.contact_faces();
                stage.step(&nodes[..n_fe], &faces, dt)?
            }
        };
        let mut f = mesh.take_forces(&out.force[..n_fe])?;
        let mut sph_force = match particles.as_deref_mut() {
            Some(s) => s.take_forces(&out.force[n_fe..])?,
            None => out.force[n_fe..].to_vec(),
        };
        let budget = ENERGY_INJECTION_BUDGET * self.energy_scale;
        let alpha = energy_guard(
            world,
            (&*mesh, particles.as_deref().map(|s| s as &dyn ContactBody)),
            (&mut f, &mut sph_force),
            (dt, budget),
        );
        self.record_pair_forces(
            (&*mesh, particles.as_deref().map(|s| s as &dyn ContactBody)),
            (&nodes, n_fe),
            (&f, &sph_force),
            &out,
        );
        let mut w = vec![mesh.apply_impulses(&f, &out.held[..n_fe], dt)];
        let held = &out.held[n_fe..];
        w.push(particles.map_or([0.0; 3], |s| s.apply_impulses(&sph_force, held, dt)));
        let flat = fe_petsc::exact::flatten(&w);
        let mut g = vec![0.0f64; flat.len()];
        world.all_reduce_into(&flat[..], &mut g[..], SystemOperation::sum());
        let g = fe_petsc::exact::values(&g);
        self.energy -= g[0] + g[1];
        if alpha < 1.0 {
            if self.stats.energy_limited_steps == 0 && world.rank() == 0 {
                eprintln!(
                    "tdyn: warning: the contact push-back at t = {:.4e} s would have added kinetic energy to the half-step motion; its forces were scaled by {alpha:.3} (report.json contact_energy_limited_steps counts such steps; logged once)",
                    t + dt
                );
            }
            self.stats.energy_limited_steps += 1;
        }
        self.stats.add(&out);
        self.stats.wall_s += t0.elapsed().as_secs_f64();
        Ok(())
    }

    /// contact_forces.csv's: the forces as applied (`f` on the mesh's array, `sph_force` on
    /// the particles') on the owned contact nodes and particles (`nodes`: the step's records,
    /// the mesh's `n_fe` first), and the pairs of bodies this rank's contacts touched.
    fn record_pair_forces(
        &mut self,
        (mesh, particles): (&dyn ContactBody, Option<&dyn ContactBody>),
        (nodes, n_fe): (&[contact::NodeRecord], usize),
        (f, sph_force): (&[[f64; 3]], &[[f64; 3]]),
        out: &ContactOutcome,
    ) {
        let (pf, offset) = (&mut self.pair_forces, self.particle_gid_offset);
        let vertex = |gid: u64| {
            let entry = particles.and_then(|s| s.particle_entry(gid - offset));
            pf.particle_vertex(entry)
        };
        let on_mesh = mesh.forces_on_records(f);
        let fe_nodes = nodes[..n_fe]
            .iter()
            .zip(on_mesh)
            .map(|(r, fc)| (r.body, fc));
        let held_by: Vec<(usize, u32)> = out
            .particle_faces
            .iter()
            .map(|&(g, b)| (vertex(g), b))
            .collect();
        let on_records =
            particles.map_or_else(|| sph_force.to_vec(), |s| s.forces_on_records(sph_force));
        let on_particles: Vec<(usize, [f64; 3])> = nodes[n_fe..]
            .iter()
            .zip(on_records)
            .map(|(r, fc)| (vertex(r.gid), fc))
            .collect();
        pf.record(
            fe_nodes,
            on_particles.into_iter(),
            &out.body_pairs,
            held_by.into_iter(),
        );
    }

    /// Writes this rank's restart state: the contact energy and the last step's figures. The
    /// decomposition and candidate lists are rebuilt at the first step after a restart (the
    /// kept ones give the contacts of a rebuild: `stage`).
    pub fn save(&self, w: &mut crate::output::state::StateWriter) {
        let c = &self.stats;
        w.put(
            "contact.state",
            &[self.energy, c.last_imbalance, c.last_bytes],
        );
        w.put("contact.contacts", &[c.contacts]);
    }

    /// Sets the state `save` wrote.
    pub fn restore(&mut self, r: &crate::output::state::StateReader) -> Result<(), String> {
        let s: Vec<f64> = r.get("contact.state")?;
        if s.len() != 3 {
            return Err("checkpoint: contact.state".into());
        }
        self.energy = s[0];
        self.stats.last_imbalance = s[1];
        self.stats.last_bytes = s[2];
        self.stats.contacts = r
            .get::<u64>("contact.contacts")?
            .first()
            .copied()
            .unwrap_or(0);
        Ok(())
    }

    /// history.csv's contact columns: the last step's search imbalance and bytes.
    pub fn history_columns(&self) -> [f64; 2] {
        [self.stats.last_imbalance, self.stats.last_bytes]
    }

    /// The stage's section and figures in the report (collective).
    pub fn report(&self, world: &SimpleCommunicator, report: &mut Report, loop_s: f64) {
        let c = &self.stats;
        let wall = collective::max(world, c.wall_s);
        let n_steps = c.steps.max(1) as f64;
        report.contact = Some(StageStats {
            wall_s: wall,
            imbalance: c.imbalance_sum / n_steps,
            bytes_sent: c.bytes,
        });
        // `rcb`: both dynamic decompositions' rebalances (SPH and contact) together.
        if matches!(self.search, Search::Dynamic(_)) {
            let mine = StageStats {
                wall_s: c.rcb_wall_s,
                imbalance: crate::stages::sph::mean_imbalance(
                    c.rcb_imbalance_sum,
                    c.rcb_rebalances,
                ),
                bytes_sent: c.rcb_bytes,
            };
            report.rcb = Some(match report.rcb.take() {
                Some(r) => StageStats {
                    wall_s: r.wall_s + mine.wall_s,
                    imbalance: r.imbalance.max(mine.imbalance),
                    bytes_sent: r.bytes_sent + mine.bytes_sent,
                },
                None => mine,
            });
            report.transfer = Some(StageStats {
                wall_s: c.transfer_s,
                imbalance: c.transfer_imbalance_sum / n_steps,
                bytes_sent: c.transfer_bytes,
            });
            report.stages_run.push("transfer".into());
        }
        let contact_nodes = collective::sum(world, self.surfaces.nodes as f64) as u64;
        let ex = &mut report.extra;
        ex.insert(
            "contact_share_of_step".into(),
            (wall / loop_s.max(1e-30)).into(),
        );
        ex.insert("contact_nodes".into(), contact_nodes.into());
        ex.insert("contacts_found_total".into(), c.contacts_total.into());
        ex.insert("contacts_found_max_step".into(), c.contacts_max.into());
        ex.insert("contact_imbalance_max".into(), c.imbalance_max.into());
        ex.insert("contact_bytes_per_step".into(), (c.bytes / n_steps).into());
        ex.insert("contact_s_per_step".into(), (wall / n_steps).into());
        ex.insert("contact_rcb_migrated".into(), c.rcb_migrated.into());
        pushback_figures(c, n_steps, ex);
        if let Search::Dynamic(stage) = &self.search {
            // Steps that rebuilt the decomposition, and candidate-list rebuilds summed over
            // ranks (the other steps kept them: the skins in `stage`).
            ex.insert(
                "contact_rebuilds".into(),
                stage.rebuilds.decomposition.into(),
            );
            let candidates = collective::sum(world, stage.rebuilds.candidates as f64) as u64;
            ex.insert("contact_candidate_rebuilds".into(), candidates.into());
        }
        ex.insert(
            "contact_work_max_per_step".into(),
            (c.work_max_sum / n_steps).into(),
        );
        ex.insert(
            "contact_work_total_per_step".into(),
            (c.work_total_sum / n_steps).into(),
        );
        ex.insert(
            "contact_decomposition".into(),
            match self.search {
                Search::Dynamic(_) => "dynamic_rcb",
                Search::Baseline(_) => "static_fe_baseline",
            }
            .into(),
        );
        ex.insert("contact_faces".into(), self.surfaces.global_faces.into());
        ex.insert("contact_bodies".into(), self.surfaces.n_bodies.into());
        ex.insert("contact_passes".into(), self.passes.into());
        ex.insert("contact_master_bodies".into(), self.surfaces.masters.into());
    }
}

/// The push-back's figures in the report's extra section: solves and rechecks per step, the
/// contacts by pass, its bytes, sweeps and rows per step, and its energy guards' counts.
fn pushback_figures(
    c: &ContactStats,
    n_steps: f64,
    ex: &mut serde_json::Map<String, serde_json::Value>,
) {
    // Push-back solves per step (1 + the rounds after rechecks that found contacts; 0 in
    // steps without contacts) and the contacts those rechecks added.
    ex.insert(
        "contact_pushback_solves_per_step".into(),
        (c.solves_total as f64 / n_steps).into(),
    );
    ex.insert("contact_pushback_solves_max".into(), c.solves_max.into());
    ex.insert("contacts_rechecked_total".into(), c.rechecked_total.into());
    // Contacts by pass: a node of a later body (bodies numbered by their lowest element
    // id) in a face of an earlier one (the only pass of a one-pass search without
    // masters), the other way, self-contact, particles; and the contacts touching a node
    // another rank's cells touch (what the push-back exchanges between ranks).
    let k = c.kinds_total;
    ex.insert("contacts_later_on_earlier_total".into(), k[0].into());
    ex.insert("contacts_earlier_on_later_total".into(), k[1].into());
    ex.insert("contacts_self_total".into(), k[2].into());
    ex.insert("contacts_particle_total".into(), k[3].into());
    ex.insert(
        "contacts_coupled_across_boxes_total".into(),
        c.coupled_total.into(),
    );
    // The push-back's own cost (step 7b, solved in cells where the contacts are): bytes
    // per step over all ranks and on the busiest rank, Gauss-Seidel sweeps per step, and
    // the contacts the busiest rank solved per step.
    ex.insert(
        "contact_pushback_bytes_per_step".into(),
        (c.pushback_bytes / n_steps).into(),
    );
    ex.insert(
        "contact_pushback_bytes_per_rank_step_max".into(),
        (c.pushback_bytes_max_sum / n_steps).into(),
    );
    ex.insert(
        "contact_pushback_sweeps_per_step".into(),
        (c.sweeps_total as f64 / n_steps).into(),
    );
    ex.insert(
        "contact_pushback_rows_per_rank_step_max".into(),
        (c.pushback_rows_max_sum / n_steps).into(),
    );
    // The push-back's energy guards (`contact::pushback`): contacts between two
    // prescribed surfaces (skipped), contacts that started the step inside their face
    // (only the step's own penetration closed), and steps whose impulses were scaled down
    // because they would have added kinetic energy.
    ex.insert("contacts_immovable_total".into(), c.immovable_total.into());
    ex.insert("contacts_bounded_total".into(), c.bounded_total.into());
    ex.insert(
        "contact_energy_limited_steps".into(),
        c.energy_limited_steps.into(),
    );
}
