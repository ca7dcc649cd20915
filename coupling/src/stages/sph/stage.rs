//! The SPH stage on its own dynamic RCB decomposition (the paper's §4, Fig. 8).
//!
//! Each step: the owned particles take the first half of the step (the `sph` crate), then
//! 1. RCB rebalance of the particles, started from the previous cuts (every rank then holds the
//!    cut tree: the shared cuts);
//! 2. ghosts: each particle is copied to every other rank whose box its sphere (radius h)
//!    overlaps, and with a periodic box each periodic image of it likewise (the rank's own
//!    included). The centre of interaction of a pair lies within h_a of a and within h_b of b,
//!    so the rank whose half-open box holds the COI holds both;
//! 3. density pass over the pairs whose COI lies in my box, ghost sums sent back to the owners
//!    (the plan's reverse) and added, EOS on the owners, new (rho, p, c) out to the ghosts;
//! 4. force pass likewise, sums back to the owners, gravity;
//!
//! then the owners take the second half of the step. Every pair is computed exactly once over
//! all ranks (the COI rule), so momentum is conserved to round-off whatever the rank count.
use crate::kernels::comm::CommPlan;
use crate::kernels::rcb::{Rcb, RcbItem, RcbStats};
use crate::output::state::{StateReader, StateWriter};
use fe_petsc::exact::{Folds, SumGrids};
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use sph::exact::{exact_pass, PassGrids, TermMax};
use sph::{
    add_gravity, book_work_at_step_velocity, continuity_and_force_pass_with, density_pass,
    first_half, force_pass, pairs_in_box, periodic_images, second_half, setup_state, update_eos,
    DensityMode, EosState, PairSums, PairWork, Params, ParticleRecord, Particles, Profile,
};
use std::time::Instant;

mod contact_side;
mod restart;
mod solid;
pub use solid::SolidPart;

/// Margin on a sphere's radius when finding the ranks it reaches (round-off in the COI).
const REACH_MARGIN: f64 = 1e-9;

/// A particle as RCB sees it: its record (real position, id) and its weight, the work it
/// brought to its rank in the last step: one for its own update plus the pairs it took part
/// in. Balancing work rather than particles matters where the particles differ: a tank of
/// fixed wall particles has few pairs per particle, the fluid many (dam break at np 3: pair
/// imbalance 1.89 with unit weights).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Item {
    rec: ParticleRecord,
    weight: f64,
}

impl RcbItem for Item {
    fn position(&self) -> [f64; 3] {
        self.rec.x
    }
    fn id(&self) -> u64 {
        self.rec.id
    }
    fn weight(&self) -> f64 {
        self.weight
    }
}

/// What the SPH stage did in the last step (global figures, the same on every rank).
#[derive(Clone, Debug, Default)]
pub struct SphStats {
    /// The RCB call.
    pub rcb: RcbStats,
    /// Ghost copies made, over all ranks.
    pub ghosts: u64,
    /// Pairs computed, over all ranks.
    pub pairs: u64,
    /// Pairs computed on this rank (its share of the work).
    pub pairs_local: u64,
    /// Max over ranks of the pairs computed, over the mean.
    pub pair_imbalance: f64,
    /// Bytes sent point to point in the step (RCB, ghosts, sums, EOS states).
    pub bytes_sent: u64,
    /// Wall time of the stage's step, max over ranks, s.
    pub wall_s: f64,
    /// The most pair partners of any particle in the step.
    pub max_partners: f64,
}

/// The SPH stage of one run.
pub struct SphStage {
    /// The stage's communicator, shared by its plans.
    comm: std::rc::Rc<SimpleCommunicator>,
    rcb: Rcb,
    /// The particles this rank holds (owned first, then this step's ghosts).
    pub parts: Particles,
    /// The model.
    pub params: Params,
    /// Owned index of each ghost record sent (in the plan's order).
    ghost_src: Vec<usize>,
    plan: Option<CommPlan>,
    bytes: u64,
    /// This rank's box (half-open) from the last rebalance.
    box_lo: [f64; 3],
    box_hi: [f64; 3],
    /// Statistics of the last step.
    pub stats: SphStats,
    /// Pair work rate of the last evaluation (local), W.
    pub work: PairWork,
    /// Start positions of the owned particles in the current step (for contact).
    x_start: Vec<[f64; 3]>,
    /// Per EOS index (`Particles::mat`), the material's initial density, kg/m^3, that fixes
    /// the contact radius (`contact_records`); empty: the EOS's reference density.
    contact_rho: Vec<f64>,
    /// The grids of the energy and momentum sums ([`fe_petsc::exact`]), from the particles'
    /// mass at the start (`Sph::new`).
    pub grids: SumGrids,
    /// Wall time of the last drift, s.
    drift_s: f64,
    /// Pairs each owned particle took part in on this rank in the last evaluation (its RCB
    /// weight is one more).
    pair_count: Vec<u32>,
    /// Whether the decomposition was balanced at least once.
    balanced_once: bool,
    /// The kept pair candidates of a run on one rank without a periodic box (see
    /// `SphStage::pair_list`); `None` elsewhere, or until the first search.
    verlet: Option<sph::KeptPairs>,
    /// Whether pair lists may be kept (`tdyn run --sph-pairs every-step` searches afresh every
    /// step).
    verlet_enabled: bool,
    /// The kept decomposition of a run on several ranks without a periodic box (see
    /// [`SphStage::finish`]); `None` until a rebuild makes it.
    kept_box: Option<KeptBox>,
    /// The skin of the kept decomposition, m (0 where none is kept).
    skin: f64,
    /// Destination rank of each ghost record sent (in the plan's order).
    ghost_dest: Vec<i32>,
    /// Whether the last rebuild balanced on counted pairs (see `KeptBox::provisional`).
    build_weighted: bool,
    /// Pair searches run so far (fresh lists and candidate builds).
    pub pair_searches: u64,
    /// The fused pass's packed inputs and sums, reused from step to step.
    pass_buf: sph::PassBuffers,
    /// The grids of the pair sums, the same on every rank ([`sph::exact`]).
    pass_grids: PassGrids,
    /// Passes redone because their terms did not fit the grids, so far.
    pub passes_redone: u64,
    /// The solid particles' state and passes (`stage::solid`); `None` in a run of fluids.
    solid: Option<SolidPart>,
    /// What this step's holds on faces and walls changed of the solids' kinetic energy beyond
    /// their pair work (`hold_on_faces`), on the energy grid, J; reset at each drift.
    pub hold_work: Folds,
    /// This step's impulses of the rigid walls' holds (`hold_on_faces`), per wall and
    /// component, on the momentum grid, N s; reset at each drift.
    pub hold_impulse: Vec<[Folds; 3]>,
    /// The rigid walls' unit normals, in scene order (`Walls::size_holds`): a particle held by
    /// more than one wall is held on each (`hold_on_faces`).
    pub wall_normals: Vec<[f64; 3]>,
    /// Whether each rigid wall has friction (`Walls::size_holds`; `hold_on_faces`).
    pub rough_walls: Vec<bool>,
    /// Per owned particle, in the contact phase of a step: what the last step's holds left it
    /// to book that its corrections have not booked yet, J (`apply_contact`; not carried).
    hold_left: Vec<f64>,
}

/// What a rank of several keeps between rebuilds of the SPH decomposition: its box's pair
/// candidates, and its owned particles' positions and smoothing lengths at the build.
struct KeptBox {
    pairs: sph::KeptBoxPairs,
    x_ref: Vec<[f64; 3]>,
    h_ref: Vec<f64>,
    /// The pair imbalance (max/mean over ranks) of the build's step (infinite until known).
    imbalance: f64,
    /// Built on unit weights (the set-up's, before any pair was counted): rebuilt at the next
    /// step, on the pairs then counted (the dam break's fixed walls have few pairs: 1.96 of
    /// pair imbalance on unit weights at np 2, 1.03 on pair counts).
    provisional: bool,
}

/// A kept decomposition is rebuilt (and so rebalanced) when the pair imbalance has grown this
/// much over its value at the build (the contact stage's rule).
pub const IMBALANCE_DRIFT: f64 = 0.05;

impl SphStage {
    /// Whether entry `i` is a solid particle (its material carries stress).
    pub fn is_solid(&self, i: usize) -> bool {
        self.solid
            .as_ref()
            .is_some_and(|s| s.solids.is_solid(self.parts.mat[i]))
    }

    /// A stage over `comm` (collective) with this rank's initial particles (owned).
    pub fn new(comm: &SimpleCommunicator, parts: Particles, params: Params) -> SphStage {
        SphStage {
            comm: std::rc::Rc::new(comm.duplicate()),
            rcb: Rcb::new(comm),
            parts,
            params,
            ghost_src: Vec::new(),
            plan: None,
            bytes: 0,
            box_lo: [f64::NEG_INFINITY; 3],
            box_hi: [f64::INFINITY; 3],
            stats: SphStats::default(),
            work: PairWork::default(),
            x_start: Vec::new(),
            contact_rho: Vec::new(),
            grids: SumGrids::for_mass(1.0),
            drift_s: 0.0,
            pair_count: Vec::new(),
            balanced_once: false,
            verlet: None,
            verlet_enabled: true,
            kept_box: None,
            skin: 0.0,
            ghost_dest: Vec::new(),
            build_weighted: false,
            pair_searches: 0,
            pass_buf: sph::PassBuffers::default(),
            pass_grids: PassGrids::default(),
            passes_redone: 0,
            solid: None,
            hold_work: [0.0; 3],
            hold_impulse: Vec::new(),
            wall_normals: Vec::new(),
            rough_walls: Vec::new(),
            hold_left: Vec::new(),
        }
    }

    /// Whether this run keeps its decomposition, ghosts and pair candidates between rebuilds
    /// on several ranks (no periodic box, lists not refused).
    fn keeps_box(&self) -> bool {
        self.verlet_enabled && self.comm.size() > 1 && self.params.periodic.is_none()
    }

    /// Whether the kept decomposition still holds every pair (collective): no particle has
    /// moved half the skin since the build (its ghosts reach `h + skin / 2`, the candidates
    /// `skin`; see `sph::KeptBoxPairs`), no smoothing length changed, and the pair imbalance
    /// has not grown [`IMBALANCE_DRIFT`] over its value at the build.
    fn kept_box_valid(&self) -> bool {
        let Some(k) = &self.kept_box else {
            return false;
        };
        let p = &self.parts;
        let n = p.n_owned;
        let moved = p.x_real[..n]
            .iter()
            .zip(&k.x_ref)
            .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>())
            .fold(0.0, f64::max)
            .sqrt();
        let ok = !k.provisional
            && k.x_ref.len() == n
            && p.h[..n] == k.h_ref[..]
            && 2.0 * moved < self.skin
            && self.stats.pair_imbalance <= k.imbalance + IMBALANCE_DRIFT;
        crate::kernels::collective::max(&self.comm, if ok { 0.0 } else { 1.0 }) == 0.0
    }

    /// A rebuild of the decomposition (collective): rebalance, and the skin of the kept lists
    /// that `make_ghosts` and `pair_list` will use.
    fn rebuild(&mut self) -> Result<(), String> {
        self.kept_box = None;
        // The RCB weights are the pairs counted in the last evaluation (none at the set-up).
        self.build_weighted = crate::kernels::collective::min(
            &self.comm,
            if self.pair_count.len() == self.parts.n_owned && self.parts.n_owned > 0 {
                1.0
            } else {
                0.0
            },
        ) > 0.0;
        self.rebalance()?;
        self.skin = if self.keeps_box() {
            let h_min = self.parts.h[..self.parts.n_owned]
                .iter()
                .fold(f64::INFINITY, |a, &b| a.min(b));
            let h_min = crate::kernels::collective::min(&self.comm, h_min);
            if h_min.is_finite() {
                sph::KEPT_PAIRS_SKIN_H * h_min
            } else {
                0.0
            }
        } else {
            0.0
        };
        Ok(())
    }

    /// The ghosts of a kept decomposition: the same particles to the same ranks as at the
    /// build, with their current records, through the build's plan (the ghosts arrive in the
    /// same order, so the kept pairs' indices hold).
    fn refresh_ghosts(&mut self) {
        self.parts.truncate_ghosts();
        let recs: Vec<ParticleRecord> = self
            .ghost_src
            .iter()
            .map(|&i| self.parts.record(i))
            .collect();
        let plan = self.plan.as_mut().expect("ghosts made at the build");
        let got = plan.exchange(&recs);
        self.bytes += plan.bytes_sent;
        plan.bytes_sent = 0;
        for g in &got {
            self.parts.push_ghost(g);
        }
    }

    /// Whether pair candidates may be kept between steps (default true; false searches afresh
    /// every step: the reference `tdyn run --sph-pairs fresh` compares against).
    pub fn set_kept_pairs(&mut self, kept: bool) {
        self.verlet_enabled = kept;
    }

    /// The decomposition's cut tree (after the first rebalance).
    pub fn tree(&self) -> &crate::kernels::rcb::CutTree {
        self.rcb.tree()
    }

    /// The set-up evaluation before the first step (collective): state at t = 0 and the first
    /// rates, on a fresh decomposition.
    pub fn setup(&mut self) -> Result<(), String> {
        let t0 = Instant::now();
        self.bytes = 0;
        setup_state(&mut self.parts, &self.params);
        self.rebuild()?;
        self.make_ghosts();
        if self.solid.is_some() {
            self.evaluate_solid(None);
            self.refresh_output();
        } else {
            let full = self.params.profile.setup_evaluates_density_and_eos();
            self.evaluate(full);
        }
        self.finish_stats(t0, 0.0);
        self.check_partners()
    }

    /// The exact pair sums hold at most [`sph::exact::MAX_PARTNERS`] terms per particle: more
    /// is an error (collective: the reduced count of `finish_stats`).
    fn check_partners(&self) -> Result<(), String> {
        let k = sph::exact::MAX_PARTNERS;
        if self.stats.max_partners > k {
            return Err(format!(
                "SPH: a particle has {} pair partners, more than the {k} its exact sums hold: \
                 particles packed far closer than their smoothing lengths (check the spacing, \
                 h_factor and the material's density)",
                self.stats.max_partners
            ));
        }
        Ok(())
    }

    /// One step of `dt` (collective): `drift` then `finish`.
    pub fn step(&mut self, dt: f64) -> Result<(), String> {
        self.drift(dt);
        self.finish(dt)
    }

    /// The first half of a step on the owned particles (Fig. 3 step 3: kick and move; no
    /// communication). Keeps the start positions for the contact stage (`contact_records`).
    pub fn drift(&mut self, dt: f64) {
        let t0 = Instant::now();
        self.bytes = 0;
        self.parts.truncate_ghosts();
        self.hold_work = [0.0; 3];
        for w in &mut self.hold_impulse {
            *w = [[0.0; 3]; 3];
        }
        self.x_start.clear();
        self.x_start
            .extend_from_slice(&self.parts.x_real[..self.parts.n_owned]);
        self.parts.start_step_flags();
        first_half(&mut self.parts, dt, &self.params);
        self.drift_s = t0.elapsed().as_secs_f64();
    }

    /// The rest of the step after `drift` (and any contact correction): rebalance, ghosts,
    /// passes, second half (collective).
    ///
    /// On several ranks (no periodic box) the decomposition, the ghosts and the pair
    /// candidates are kept between rebuilds while `SphStage::kept_box_valid` holds: the
    /// ghosts then go to the same ranks as at the build through its plan, and the candidates
    /// are filtered with the search's own tests, so every step computes the pairs a rebuild
    /// would (each once, by the box holding its COI), summed in another order.
    pub fn finish(&mut self, dt: f64) -> Result<(), String> {
        let t0 = Instant::now();
        let keep = self.kept_box_valid();
        if !keep {
            self.rebuild()?;
        } else {
            // No rebalance in this step.
            self.stats.rcb.migrated = 0;
            self.stats.rcb.bytes_sent = 0;
            self.stats.rcb.wall_s = 0.0;
        }

        let ghosts = |st: &mut Self| {
            if keep {
                st.refresh_ghosts();
            } else {
                st.make_ghosts();
            }
        };
        if self.solid.is_some() {
            ghosts(self);
            self.evaluate_solid(Some(dt));
        } else if self.params.density == DensityMode::Continuity {
            // The forces need (rho, p, c) at the new positions, which continuity density has
            // already (rho was advanced in the first half): the EOS runs on the owners before
            // the ghosts are made (they carry it), and one fused pass computes density rates
            // and forces.
            update_eos(&mut self.parts, &self.params);
            ghosts(self);
            self.evaluate_fused();
        } else {
            ghosts(self);
            self.evaluate(true);
        }
        second_half(&mut self.parts, dt, &self.params);
        self.hold_on_faces(dt);
        // (its EOS, with the energy equation on, before the solids' pressure from their stress)
        book_work_at_step_velocity(&mut self.parts, &self.params, dt);
        self.solid_pressure_after_step();
        self.finish_stats(t0, self.drift_s);
        self.check_partners()
    }

    /// 1. RCB over the owned particles, from the previous cuts.
    fn rebalance(&mut self) -> Result<(), String> {
        self.parts.truncate_ghosts();
        // One rank: its box is all of space and every particle stays; after the first call
        // (which sets up the cut tree) there is nothing to rebalance.
        if self.comm.size() == 1 && self.box_lo[0] == f64::NEG_INFINITY && self.balanced_once {
            self.stats.rcb.migrated = 0;
            self.stats.rcb.bytes_sent = 0;
            self.stats.rcb.wall_s = 0.0;
            return Ok(());
        }
        self.balanced_once = true;
        if self.solid.is_some() {
            return self.rebalance_solid();
        }
        let items: Vec<Item> = (0..self.parts.n_owned)
            .map(|i| Item {
                rec: self.parts.record(i),
                weight: 1.0 + self.pair_count.get(i).copied().unwrap_or(0) as f64,
            })
            .collect();
        if let Some(mine) = self.balance(items)? {
            let mut parts = Particles::new();
            for it in &mine {
                parts.push_owned(&it.rec);
            }
            self.parts = parts;
        }
        Ok(())
    }

    /// RCB over `items` (the owned particles in their order, with what travels with them):
    /// this rank's items after it, or `None` where nothing came or went (the common case once
    /// balanced: RCB keeps its items in order, and the particles stay as they are). Sets the
    /// box and the statistics.
    fn balance<T: RcbItem>(&mut self, items: Vec<T>) -> Result<Option<Vec<T>>, String> {
        let (mine, stats) = self.rcb.balance(items).map_err(|e| e.to_string())?;
        let same = mine.len() == self.parts.n_owned
            && mine
                .iter()
                .zip(&self.parts.id)
                .all(|(it, &id)| it.id() == id);
        self.bytes += stats.bytes_sent;
        self.stats.rcb = stats;
        let (lo, hi) = self.rcb.tree().rank_box(self.comm.rank());
        self.box_lo = lo;
        self.box_hi = hi;
        Ok((!same).then_some(mine))
    }

    /// 2. Ghost copies (and periodic images) to every rank their sphere reaches.
    fn make_ghosts(&mut self) {
        let me = self.comm.rank();
        let tree = self.rcb.tree();
        let per = self.params.periodic;
        let mut dest = Vec::new();
        let mut recs = Vec::new();
        let mut src = Vec::new();
        let mut ranks = Vec::new();
        let mut shifts = Vec::new();
        // One rank without a periodic box has no ghosts: every sphere reaches this rank only.
        let n_sources = if self.comm.size() == 1 && per.is_none() {
            0
        } else {
            self.parts.n_owned
        };
        for i in 0..n_sources {
            let x = self.parts.x_real[i];
            // A kept decomposition's ghosts also reach the pairs the particle may enter
            // before the next rebuild (it moves less than half the skin).
            let r = self.parts.h[i] * (1.0 + REACH_MARGIN) + 0.5 * self.skin;
            shifts.clear();
            shifts.push([0.0; 3]);
            if let Some(p) = &per {
                shifts.extend(periodic_images(x, r, p));
            }
            for &s in &shifts {
                let c: [f64; 3] = std::array::from_fn(|k| x[k] + s[k]);
                let lo = [c[0] - r, c[1] - r, c[2] - r];
                let hi = [c[0] + r, c[1] + r, c[2] + r];
                ranks.clear();
                tree.ranks_overlapping(&lo, &hi, &mut ranks);
                for &q in &ranks {
                    if q == me && s == [0.0; 3] {
                        continue;
                    }
                    let mut rec = self.parts.record(i);
                    rec.shift = s;
                    dest.push(q);
                    recs.push(rec);
                    src.push(i);
                }
            }
        }
        let mut plan = CommPlan::new_shared(&self.comm, &dest);
        let got = plan.exchange(&recs);
        for g in &got {
            self.parts.push_ghost(g);
        }
        self.bytes += plan.bytes_sent;
        plan.bytes_sent = 0;
        self.ghost_src = src;
        self.ghost_dest = dest;
        self.plan = Some(plan);
    }

    /// Sends the ghosts' sums back to their owners and merges them there (exact: in any
    /// order); then sets the owners' values from the sums: the density (rate) with
    /// `density`, the force and energy rate with `forces`.
    fn fold_back(&mut self, density: bool, forces: bool) {
        let n0 = self.parts.n_owned;
        let sums: Vec<PairSums> = (0..self.parts.n_ghosts())
            .map(|g| self.parts.pair_sums(n0 + g))
            .collect();
        let plan = self.plan.as_mut().expect("ghosts made");
        let back = plan.reverse(&sums);
        self.bytes += plan.bytes_sent;
        plan.bytes_sent = 0;
        for (k, s) in back.iter().enumerate() {
            self.parts.add_pair_sums(self.ghost_src[k], s);
        }
        if density {
            let summation = self.params.density == DensityMode::Summation;
            self.parts.settle_density(summation);
        }
        if forces {
            self.parts.settle_forces();
        }
    }

    /// Runs `pass` (which sets the sums it adds to) until its terms fit the pair sums' grids,
    /// the largest terms reduced over the ranks ([`sph::exact::exact_pass`]). Collective.
    fn exact<T>(&mut self, mut pass: impl FnMut(&mut Self, &PassGrids, &mut TermMax) -> T) -> T {
        let mut grids = self.pass_grids;
        let comm = self.comm.clone();
        let reduce = |m: &TermMax| {
            let mut g = [0.0; 3];
            comm.all_reduce_into(&m[..], &mut g[..], SystemOperation::max());
            g
        };
        let (out, redone) = exact_pass(&mut grids, reduce, |g, m| pass(self, g, m));
        self.pass_grids = grids;
        self.passes_redone += redone as u64;
        out
    }

    /// 3-4 with continuity density: one fused pass (density rates and forces), its sums back
    /// to the owners, gravity. The EOS was applied before the ghosts were made. On one rank
    /// with a kept list the pass tests the candidates itself (see [`SphStage::one_rank_list`]).
    fn evaluate_fused(&mut self) {
        let one_rank = self.one_rank_list();
        let list = if one_rank {
            Vec::new()
        } else {
            self.pair_list()
        };
        let (work, n_pairs) = self.exact(|st, g, m| {
            if one_rank {
                let v = st.verlet.as_mut().expect("kept list made");
                v.continuity_and_force_pass(&mut st.parts, &st.params, &mut st.pair_count, g, m)
            } else {
                let w = continuity_and_force_pass_with(
                    &list,
                    &mut st.parts,
                    &st.params,
                    &mut st.pass_buf,
                    g,
                    m,
                );
                (w, list.len())
            }
        });
        self.work = work;
        self.fold_back(true, true);
        add_gravity(&mut self.parts, &self.params);
        self.stats.pairs = n_pairs as u64;
    }

    /// The pairs this box computes (COI in its box), counted per owned particle.
    ///
    /// On one rank without a periodic box (no ghosts, no migration, every pair interior) the
    /// candidates are kept between steps ([`sph::KeptPairs`]) and filtered with the search's overlap
    /// test: the same pairs as a fresh search (in another order, so sums differ at round-off).
    fn pair_list(&mut self) -> Vec<(u32, u32)> {
        let opts = self.params.search_options();
        if self.keeps_box() {
            // Several ranks: the box's candidates, made at the rebuild (the ghosts just made
            // reach them), filtered every step.
            if self.kept_box.is_none() {
                self.pair_searches += 1;
                let p = &self.parts;
                let pairs = sph::KeptBoxPairs::build(p, &opts, self.box_lo, self.box_hi, self.skin);
                self.kept_box = Some(KeptBox {
                    pairs,
                    x_ref: p.x_real[..p.n_owned].to_vec(),
                    h_ref: p.h[..p.n_owned].to_vec(),
                    imbalance: f64::INFINITY,
                    provisional: !self.build_weighted,
                });
            }
            let k = self.kept_box.as_ref().expect("just built");
            return k
                .pairs
                .filter(&self.parts, self.box_lo, self.box_hi, &mut self.pair_count);
        }
        if self.one_rank_list() {
            let v = self.verlet.as_ref().expect("kept list made");
            // every entry is owned here (no ghosts), so the counts are the owned particles'
            return v.filter(&self.parts, &mut self.pair_count);
        }
        self.verlet = None;
        self.pair_searches += 1;
        let list = pairs_in_box(&self.parts, &opts, self.box_lo, self.box_hi);
        self.count_pairs(&list);
        list
    }

    /// Whether this evaluation uses the kept candidates of one rank ([`sph::KeptPairs`]): one
    /// rank without a periodic box (no ghosts, no migration, every pair interior), lists not
    /// refused; if so, the list is valid for the particles now (rebuilt if a particle has moved
    /// half the skin).
    fn one_rank_list(&mut self) -> bool {
        let opts = self.params.search_options();
        let p = &self.parts;
        let keepable = self.verlet_enabled
            && self.comm.size() == 1
            && opts.periodic.is_none()
            && p.len() == p.n_owned
            && self.box_lo.iter().all(|c| *c == f64::NEG_INFINITY)
            && self.box_hi.iter().all(|c| *c == f64::INFINITY);
        if !keepable {
            return false;
        }
        if !self.verlet.as_ref().is_some_and(|v| v.still_valid(p)) {
            self.pair_searches += 1;
            self.verlet = Some(sph::KeptPairs::build(p, &opts, self.box_lo, self.box_hi));
        }
        true
    }

    /// Pairs per owned particle in this evaluation (the next rebalance's weights).
    fn count_pairs(&mut self, list: &[(u32, u32)]) {
        let n = self.parts.n_owned;
        self.pair_count.clear();
        self.pair_count.resize(n, 0);
        for &(i, j) in list {
            for e in [i as usize, j as usize] {
                if e < n {
                    self.pair_count[e] += 1;
                }
            }
        }
    }

    /// 3-4. The passes with their communication.
    fn evaluate(&mut self, density_and_eos: bool) {
        let list = self.pair_list();
        if density_and_eos {
            self.exact(|st, g, m| density_pass(&list, &mut st.parts, &st.params, g, m));
            self.fold_back(true, false);
            update_eos(&mut self.parts, &self.params);
            // New (rho, p, c) of the owners out to their ghosts.
            let states: Vec<EosState> = self
                .ghost_src
                .iter()
                .map(|&i| self.parts.eos_state(i))
                .collect();
            let plan = self.plan.as_mut().expect("ghosts made");
            let got = plan.exchange(&states);
            self.bytes += plan.bytes_sent;
            plan.bytes_sent = 0;
            let n0 = self.parts.n_owned;
            for (g, s) in got.iter().enumerate() {
                self.parts.set_eos_state(n0 + g, s);
            }
        }
        self.work = self.exact(|st, g, m| force_pass(&list, &mut st.parts, &st.params, g, m));
        self.fold_back(false, true);
        add_gravity(&mut self.parts, &self.params);
        self.stats.pairs = list.len() as u64;
    }

    /// Global statistics of the step; `extra_s`: time of this step spent before `t0` (the drift).
    fn finish_stats(&mut self, t0: Instant, extra_s: f64) {
        let comm = &self.comm;
        let mut sums = [0.0f64; 3];
        comm.all_reduce_into(
            &[
                self.stats.pairs as f64,
                self.parts.n_ghosts() as f64,
                self.bytes as f64,
            ][..],
            &mut sums[..],
            SystemOperation::sum(),
        );
        let mut maxes = [0.0f64; 3];
        let partners = (0..self.parts.n_owned)
            .map(|i| self.parts.sums.get(i).map_or(0.0, |s| s.partners))
            .fold(0.0, f64::max);
        comm.all_reduce_into(
            &[
                self.stats.pairs as f64,
                t0.elapsed().as_secs_f64() + extra_s,
                partners,
            ][..],
            &mut maxes[..],
            SystemOperation::max(),
        );
        self.stats.max_partners = maxes[2];
        let mean = sums[0] / comm.size() as f64;
        self.stats.pair_imbalance = if mean > 0.0 { maxes[0] / mean } else { 1.0 };
        self.stats.pairs_local = self.stats.pairs;
        self.stats.pairs = sums[0] as u64;
        if let Some(k) = &mut self.kept_box {
            if k.imbalance.is_infinite() {
                k.imbalance = self.stats.pair_imbalance;
            }
        }
        self.stats.ghosts = sums[1] as u64;
        self.stats.bytes_sent = sums[2] as u64;
        self.stats.wall_s = maxes[1];
    }

    /// The stable step over all ranks (collective), 0.3 min h/(c + |v|).
    pub fn stable_dt(&self) -> f64 {
        crate::kernels::collective::min(&self.comm, sph::stable_dt(&self.parts))
    }
}
