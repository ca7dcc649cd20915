//! The SPH stage's restart state: saved, restored on the same ranks, or remapped onto
//! another rank count.
use super::*;

/// A particle's solid record in a checkpoint (`None` in a run of fluids).
type SolidRecordOf = Option<sph::solid::SolidRecord>;

impl SphStage {
    /// The restart state (`driver::checkpoint`): the owned particles in their order, the RCB
    /// weights and cuts the next balance starts from, this rank's box, and the kept pair list
    /// (so the pairs are summed in the same order as without the stop).
    pub fn save(&self, w: &mut StateWriter) {
        let recs: Vec<sph::ParticleRecord> = (0..self.parts.n_owned)
            .map(|i| self.parts.record(i))
            .collect();
        w.put("sph.particles", &recs);
        self.save_solid(w);
        w.put("sph.pair_count", &self.pair_count);
        w.put(
            "sph.flags",
            &[self.balanced_once as u64, self.pair_searches],
        );
        let b = [self.box_lo, self.box_hi];
        w.put("sph.box", b.as_flattened());
        // the pair sums' grids (the same on every rank), so the sums after the stop are the
        // same bits as without it
        w.put("sph.pass_grids", &self.pass_grids.fitted());
        if let Some(cuts) = self.rcb.cuts() {
            let dims: Vec<u64> = cuts.iter().map(|c| c.dim as u64).collect();
            let values: Vec<f64> = cuts.iter().map(|c| c.value).collect();
            let ties: Vec<u64> = cuts.iter().map(|c| c.tie_id).collect();
            w.put("sph.cut_dims", &dims);
            w.put("sph.cut_values", &values);
            w.put("sph.cut_ties", &ties);
        }
        if let Some(k) = &self.kept_box {
            // The kept decomposition of several ranks: its candidates, references and ghost
            // plan (rebuilt from its destinations on restore, so the ghosts arrive in the same
            // order).
            let (pairs, skin) = k.pairs.to_parts();
            w.put("sph.kbox_pairs", &pairs);
            w.put("sph.kbox_x", &k.x_ref);
            w.put("sph.kbox_h", &k.h_ref);
            let flags = [
                k.provisional as u64 as f64,
                self.build_weighted as u64 as f64,
            ];
            // The last step's pair imbalance decides the next step's rebuild.
            let meta = [
                k.imbalance,
                skin,
                self.skin,
                flags[0],
                flags[1],
                self.stats.pair_imbalance,
            ];
            w.put("sph.kbox_meta", &meta);
            let src: Vec<u64> = self.ghost_src.iter().map(|&i| i as u64).collect();
            w.put("sph.ghost_src", &src);
            w.put("sph.ghost_dest", &self.ghost_dest);
        }
        if let Some(v) = &self.verlet {
            let (pairs, x_ref, h_ref, id_ref, skin) = v.to_parts();
            w.put("sph.kept_pairs", &pairs);
            w.put("sph.kept_x", &x_ref);
            w.put("sph.kept_h", &h_ref);
            w.put("sph.kept_id", &id_ref);
            w.put("sph.kept_skin", &[skin]);
        }
    }

    /// Sets the state [`SphStage::save`] wrote (the same rank count).
    pub fn restore(&mut self, r: &StateReader) -> Result<(), String> {
        let recs: Vec<sph::ParticleRecord> = r.get("sph.particles")?;
        let solid = self.solid_records_of(r, recs.len())?;
        let mut parts = Particles::new();
        for rec in &recs {
            parts.push_owned(rec);
        }
        self.parts = parts;
        self.set_solid_records(&solid);
        self.restore_grad_grids(r)?;
        self.pair_count = r.get("sph.pair_count")?;
        let flags: Vec<u64> = r.get("sph.flags")?;
        if flags.len() != 2 {
            return Err("checkpoint: sph.flags".into());
        }
        self.balanced_once = flags[0] != 0;
        self.pair_searches = flags[1];
        let b: Vec<f64> = r.get("sph.box")?;
        if b.len() != 6 {
            return Err("checkpoint: sph.box".into());
        }
        self.box_lo = [b[0], b[1], b[2]];
        self.box_hi = [b[3], b[4], b[5]];
        self.restore_pass_grids(r)?;
        if r.has("sph.cut_dims") {
            let dims: Vec<u64> = r.get("sph.cut_dims")?;
            let values: Vec<f64> = r.get("sph.cut_values")?;
            let ties: Vec<u64> = r.get("sph.cut_ties")?;
            let cuts: Vec<crate::kernels::rcb::Cut> = dims
                .iter()
                .zip(&values)
                .zip(&ties)
                .map(|((&dim, &value), &tie_id)| crate::kernels::rcb::Cut {
                    dim: dim as usize,
                    value,
                    tie_id,
                })
                .collect();
            if !self.rcb.set_cuts(&cuts) {
                return Err("checkpoint: the SPH cuts are for another rank count".into());
            }
        }
        self.kept_box = None;
        if r.has("sph.kbox_pairs") {
            let meta: Vec<f64> = r.get("sph.kbox_meta")?;
            if meta.len() != 6 {
                return Err("checkpoint: sph.kbox_meta".into());
            }
            self.stats.pair_imbalance = meta[5];
            self.kept_box = Some(KeptBox {
                pairs: sph::KeptBoxPairs::from_parts(r.get("sph.kbox_pairs")?, meta[1]),
                x_ref: r.get("sph.kbox_x")?,
                h_ref: r.get("sph.kbox_h")?,
                imbalance: meta[0],
                provisional: meta[3] != 0.0,
            });
            self.skin = meta[2];
            self.build_weighted = meta[4] != 0.0;
            let src: Vec<u64> = r.get("sph.ghost_src")?;
            self.ghost_src = src.iter().map(|&i| i as usize).collect();
            self.ghost_dest = r.get("sph.ghost_dest")?;
            // Collective: every rank of a kept decomposition has one (builds are collective).
            self.plan = Some(CommPlan::new_shared(&self.comm, &self.ghost_dest));
        }
        self.verlet = if r.has("sph.kept_pairs") {
            let skin: Vec<f64> = r.get("sph.kept_skin")?;
            Some(sph::KeptPairs::from_parts(
                r.get("sph.kept_pairs")?,
                r.get("sph.kept_x")?,
                r.get("sph.kept_h")?,
                r.get("sph.kept_id")?,
                skin.first().copied().unwrap_or(0.0),
            ))
        } else {
            None
        };
        Ok(())
    }

    /// The pair sums' grids a checkpoint holds (fitted afresh where it holds none).
    pub(super) fn restore_pass_grids(&mut self, r: &StateReader) -> Result<(), String> {
        self.pass_grids = saved_grids(r, "sph.pass_grids")?;
        Ok(())
    }

    /// Sets the state [`SphStage::save`] wrote on another rank count: `pieces` holds every
    /// writing rank's sections. This rank takes the block of the particles (ordered by id)
    /// that its rank number gives, with their RCB weights; the first step's rebalance moves
    /// them into the decomposition that the set-up at t = 0 made on these ranks (RCB takes
    /// its items from anywhere) and the pairs are searched afresh. The pairs are then summed
    /// in another order than without the stop: the run agrees with it to round-off.
    pub fn restore_remapped(&mut self, pieces: &[StateReader]) -> Result<(), String> {
        let mut all: Vec<(sph::ParticleRecord, u32, SolidRecordOf)> = Vec::new();
        let mut searches = 0;
        for r in pieces {
            let recs: Vec<sph::ParticleRecord> = r.get("sph.particles")?;
            let counts: Vec<u32> = r.get("sph.pair_count")?;
            let n = recs.len();
            let solid = self.solid_records_of(r, n)?;
            let solid = solid.into_iter().map(Some).chain(std::iter::repeat(None));
            all.extend(
                recs.into_iter()
                    .zip(counts.into_iter().chain(std::iter::repeat(0)).take(n))
                    .zip(solid)
                    .map(|((rec, c), s)| (rec, c, s)),
            );
            searches += r.get::<u64>("sph.flags")?.get(1).copied().unwrap_or(0);
        }
        all.sort_by_key(|(rec, _, _)| rec.id);
        if let Some(r) = pieces.first() {
            self.restore_pass_grids(r)?;
            self.restore_grad_grids(r)?;
        }
        let (p, me) = (self.comm.size() as usize, self.comm.rank() as usize);
        let (lo, hi) = (all.len() * me / p, all.len() * (me + 1) / p);
        let mut parts = Particles::new();
        for (rec, _, _) in &all[lo..hi] {
            parts.push_owned(rec);
        }
        self.parts = parts;
        let solid: Vec<sph::solid::SolidRecord> =
            all[lo..hi].iter().filter_map(|(_, _, s)| *s).collect();
        self.set_solid_records(&solid);
        self.pair_count = all[lo..hi].iter().map(|(_, c, _)| *c).collect();
        self.verlet = None;
        // Another rank count: the kept decomposition is rebuilt at the first step.
        self.kept_box = None;
        // The report sums the searches over ranks.
        self.pair_searches = if me == 0 { searches } else { 0 };
        Ok(())
    }
}

/// The exact sums' grids a checkpoint holds under `key` (fitted afresh where it holds none: a
/// checkpoint written before the grids were saved).
pub(super) fn saved_grids(r: &StateReader, key: &str) -> Result<PassGrids, String> {
    if !r.has(key) {
        return Ok(PassGrids::default());
    }
    let m: Vec<f64> = r.get(key)?;
    let m: TermMax = m.try_into().map_err(|_| format!("checkpoint: {key}"))?;
    Ok(PassGrids::fitted_to(m))
}
