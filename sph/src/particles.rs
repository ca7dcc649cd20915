//! Particles as struct-of-arrays: owned particles first (`0..n_owned`), ghost copies after.
//!
//! Communication roles of the fields (what the parallel layer does with each):
//! - sent to ghosts when they are made: every field of `ParticleRecord` (`record`/`push_ghost`);
//! - refreshed on ghosts after the EOS (owner -> copies): `EosState` (rho, p, c);
//! - summed back from ghosts after a pass (copies -> owner): `PairSums`, the exact sums (folds,
//!   [`crate::exact`]) of f, de and the density (rate), which the owner merges and then settles
//!   into `f`, `de` and `drho` (or `rho` in summation mode);
//! - carried when a particle migrates: every field of `ParticleRecord`.
use crate::exact::values3;
use binsum::{value2, Folds2};
use bytemuck::{Pod, Zeroable};

/// [`Particles::pushed`]: corrected by the push-back or a wall in the last step.
pub const PUSHED_LAST: u8 = 1;
/// [`Particles::pushed`]: corrected in this step.
pub const PUSHED_NOW: u8 = 2;
/// [`Particles::pushed`]: held by a face or wall through the last step's closing kick.
pub const HELD_LAST: u8 = 4;
/// [`Particles::pushed`]: held through this step's closing kick.
pub const HELD_NOW: u8 = 8;

/// The SPH particles held by one box.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Particles {
    /// Number of owned particles; entries `n_owned..len()` are ghost copies.
    pub n_owned: usize,
    /// Global id (the same for every copy of a particle).
    pub id: Vec<u64>,
    /// Position of this copy, m (for a periodic image: the real position plus `shift`). All
    /// geometry of the passes uses it.
    pub x: Vec<[f64; 3]>,
    /// The real position, m, bit for bit as its owner holds it (the centre-of-interaction rule
    /// uses it so that every rank computes the same bits). Equal to `x` unless `shift` != 0.
    pub x_real: Vec<[f64; 3]>,
    /// Periodic shift of this copy (a multiple of the period on periodic axes; zero for real
    /// particles and for ghosts that are not images).
    pub shift: Vec<[f64; 3]>,
    /// Velocity, m/s (between the halves of a step: the half-step velocity).
    pub v: Vec<[f64; 3]>,
    /// Predicted velocity v^ used by the passes (LIGGGHTS's `vest`), m/s.
    pub vhat: Vec<[f64; 3]>,
    /// Force, N (pair forces + gravity), accumulated by the force pass.
    pub f: Vec<[f64; 3]>,
    /// Mass, kg.
    pub m: Vec<f64>,
    /// Density, kg/m^3.
    pub rho: Vec<f64>,
    /// Density rate drho/dt, kg/(m^3 s), accumulated by the continuity pass.
    pub drho: Vec<f64>,
    /// Pressure, Pa.
    pub p: Vec<f64>,
    /// Sound speed, m/s.
    pub c: Vec<f64>,
    /// Specific internal energy, J/kg.
    pub e: Vec<f64>,
    /// Rate of specific internal energy from pressure and viscous pair work, W/kg, accumulated
    /// by the force pass (whether or not the energy equation is on).
    pub de: Vec<f64>,
    /// Accumulated specific pair work, J/kg, integrated from `de` when the energy equation is
    /// off (so that kinetic + sum m (e + work) stays checkable); 0 with the energy equation on.
    pub work: Vec<f64>,
    /// Smoothing length h, m: the particle's sphere has radius h, the kernel support of a pair
    /// is h_a + h_b.
    pub h: Vec<f64>,
    /// Density at the half step (standard profile, continuity), kg/m^3.
    pub rho_half: Vec<f64>,
    /// Specific internal energy at the half step (standard profile, energy equation), J/kg.
    pub e_half: Vec<f64>,
    /// Material index into `Params::eos`.
    pub mat: Vec<u16>,
    /// Boundary particle: its density (and energy) evolve, it never moves.
    pub fixed: Vec<bool>,
    /// The outward normal of the immovable faces or the rigid wall holding this particle in
    /// the current step, times its holder's tag (1 the faces, 2 + k rigid wall k: the length
    /// says who holds it), set by the push-back, used and cleared after the step's closing kick
    /// by the parallel layer; zero when none. Carried when the particle migrates within a step.
    /// The first holder of the step; the rigid walls that hold it besides (a corner) are in
    /// [`Particles::hold_more`].
    pub hold: Vec<[f64; 3]>,
    /// The tags (2 + k, rigid wall k) of up to two more rigid walls holding this particle in the
    /// current step, besides [`Particles::hold`]'s (0: none): a particle in a corner of walls is
    /// held by each (their normals are the walls'). Set and cleared with `hold`. Carried.
    pub hold_more: Vec<[u8; 2]>,
    /// The tags of the holders (1 the faces, 2 + k rigid wall k; 0: none) that took part of the
    /// last step's closing kick from this particle (set with [`HELD_NOW`]), each used once by
    /// the push-back's booking of the start kick it took back (coupling's `apply_contact`).
    /// Carried.
    pub held_by: Vec<[u8; 3]>,
    /// Contact corrections: [`PUSHED_LAST`] set when the push-back or a wall moved the particle
    /// in the last step, [`PUSHED_NOW`] in this one; [`HELD_LAST`] when a face or wall held it
    /// through the last step's closing kick, [`HELD_NOW`] this step's (the step's drift shifts
    /// each "now" bit into its "last" bit: [`Particles::start_step_flags`]; what the push-back
    /// books depends on them: `contact::energy::booked_kick` and coupling's `apply_contact`).
    /// Carried.
    pub pushed: Vec<u8>,
    /// The exact sums a pass adds to, one per entry (sized by the passes' resets; not carried).
    pub sums: Vec<PairSums>,
}

/// One particle packed for communication (migration, ghost creation, checkpoints): plain old
/// data, no padding. `x` is the REAL position; `shift` the periodic shift of the copy to make.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
#[allow(missing_docs)]
pub struct ParticleRecord {
    pub id: u64,
    /// Real position.
    pub x: [f64; 3],
    pub shift: [f64; 3],
    pub v: [f64; 3],
    pub vhat: [f64; 3],
    pub f: [f64; 3],
    pub m: f64,
    pub rho: f64,
    pub drho: f64,
    pub p: f64,
    pub c: f64,
    pub e: f64,
    pub de: f64,
    pub work: f64,
    pub h: f64,
    pub rho_half: f64,
    pub e_half: f64,
    /// Material index (u16 widened).
    pub mat: u32,
    /// 1 for a fixed (boundary) particle.
    pub fixed: u32,
    /// See [`Particles::hold`].
    pub hold: [f64; 3],
    /// See [`Particles::pushed`] (bits 0-7), with [`Particles::hold_more`]'s tags in bits 8-15
    /// and 16-23.
    pub pushed: u32,
    /// [`Particles::held_by`]'s tags in bits 0-7, 8-15 and 16-23.
    pub held_by: u32,
}

/// What a pass added to an entry, as exact sums ([`crate::exact`]); a ghost copy's go to its
/// owner (copies -> owner), who merges them (in any order: the sums are exact).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PairSums {
    /// Force components, N.
    pub f: [Folds2; 3],
    /// Density rate (continuity), kg/(m^3 s), or density (summation), kg/m^3.
    pub dens: Folds2,
    /// Specific internal-energy rate, W/kg.
    pub de: Folds2,
    /// Pair partners (an integer), for the bound of [`crate::exact::MAX_PARTNERS`].
    pub partners: f64,
}

impl PairSums {
    /// Merges `o` into these sums (exact).
    #[inline]
    pub fn merge(&mut self, o: &PairSums) {
        fn merge2(a: &mut Folds2, b: &Folds2) {
            a[0] += b[0];
            a[1] += b[1];
        }
        for c in 0..3 {
            merge2(&mut self.f[c], &o.f[c]);
        }
        merge2(&mut self.dens, &o.dens);
        merge2(&mut self.de, &o.de);
        self.partners += o.partners;
    }
}

/// The state the EOS update produces, to be copied from an owner to its ghosts (owner ->
/// copies) before the force pass.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct EosState {
    /// Density.
    pub rho: f64,
    /// Pressure.
    pub p: f64,
    /// Sound speed.
    pub c: f64,
}

/// A new owned particle: the fields a user sets; the rest start at zero (`vhat` = v).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NewParticle {
    /// Global id.
    pub id: u64,
    /// Position.
    pub x: [f64; 3],
    /// Velocity.
    pub v: [f64; 3],
    /// Mass.
    pub m: f64,
    /// Density.
    pub rho: f64,
    /// Specific internal energy.
    pub e: f64,
    /// Smoothing length.
    pub h: f64,
    /// Material index.
    pub mat: u16,
    /// Boundary particle.
    pub fixed: bool,
}

/// Applies `$body` (a macro taking the field) to every per-particle Vec of `$p`.
macro_rules! for_each_field {
    ($p:expr, $mac:ident) => {{
        $mac!($p.id);
        $mac!($p.x);
        $mac!($p.x_real);
        $mac!($p.shift);
        $mac!($p.v);
        $mac!($p.vhat);
        $mac!($p.f);
        $mac!($p.m);
        $mac!($p.rho);
        $mac!($p.drho);
        $mac!($p.p);
        $mac!($p.c);
        $mac!($p.e);
        $mac!($p.de);
        $mac!($p.work);
        $mac!($p.h);
        $mac!($p.rho_half);
        $mac!($p.e_half);
        $mac!($p.mat);
        $mac!($p.fixed);
        $mac!($p.hold);
        $mac!($p.hold_more);
        $mac!($p.held_by);
        $mac!($p.pushed);
    }};
}

impl Particles {
    /// At a step's start (its drift): each "now" bit of `pushed` becomes its "last" bit and
    /// the "now" bits clear ([`PUSHED_NOW`] -> [`PUSHED_LAST`], [`HELD_NOW`] -> [`HELD_LAST`]).
    pub fn start_step_flags(&mut self) {
        for (p, by) in self.pushed.iter_mut().zip(&mut self.held_by) {
            if *p & HELD_NOW == 0 {
                *by = [0; 3];
            }
            *p = (*p >> 1) & (PUSHED_LAST | HELD_LAST);
        }
    }

    /// No particles.
    pub fn new() -> Self {
        Self::default()
    }

    /// Owned + ghost entries.
    #[inline]
    pub fn len(&self) -> usize {
        self.id.len()
    }

    /// No entries at all.
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// Number of ghost entries.
    pub fn n_ghosts(&self) -> usize {
        self.len() - self.n_owned
    }

    /// Appends an owned particle from user data (`vhat` = v, `x_real` = x, rates zero).
    /// Panics if ghosts are present (owned entries come first).
    pub fn push(&mut self, p: NewParticle) {
        self.push_owned(&ParticleRecord {
            id: p.id,
            x: p.x,
            v: p.v,
            vhat: p.v,
            m: p.m,
            rho: p.rho,
            rho_half: p.rho,
            e: p.e,
            e_half: p.e,
            h: p.h,
            mat: p.mat as u32,
            fixed: p.fixed as u32,
            ..ParticleRecord::default()
        });
    }

    /// Appends an owned particle from a record (e.g. one that migrated here). Its shift must be
    /// zero. Panics if ghosts are present.
    pub fn push_owned(&mut self, r: &ParticleRecord) {
        assert_eq!(
            self.n_ghosts(),
            0,
            "owned particles must be pushed before ghosts (truncate_ghosts first)"
        );
        debug_assert_eq!(r.shift, [0.0; 3], "an owned particle is a real copy");
        self.push_raw(r);
        self.n_owned += 1;
    }

    /// Appends a ghost copy from a record: `x_real` = r.x, `x` = r.x + r.shift.
    pub fn push_ghost(&mut self, r: &ParticleRecord) {
        self.push_raw(r);
    }

    fn push_raw(&mut self, r: &ParticleRecord) {
        let x = if r.shift == [0.0; 3] {
            r.x
        } else {
            [
                r.x[0] + r.shift[0],
                r.x[1] + r.shift[1],
                r.x[2] + r.shift[2],
            ]
        };
        self.id.push(r.id);
        self.x.push(x);
        self.x_real.push(r.x);
        self.shift.push(r.shift);
        self.v.push(r.v);
        self.vhat.push(r.vhat);
        self.f.push(r.f);
        self.m.push(r.m);
        self.rho.push(r.rho);
        self.drho.push(r.drho);
        self.p.push(r.p);
        self.c.push(r.c);
        self.e.push(r.e);
        self.de.push(r.de);
        self.work.push(r.work);
        self.h.push(r.h);
        self.rho_half.push(r.rho_half);
        self.e_half.push(r.e_half);
        self.mat.push(r.mat as u16);
        self.fixed.push(r.fixed != 0);
        self.hold.push(r.hold);
        self.hold_more
            .push([(r.pushed >> 8) as u8, (r.pushed >> 16) as u8]);
        self.held_by.push([
            r.held_by as u8,
            (r.held_by >> 8) as u8,
            (r.held_by >> 16) as u8,
        ]);
        self.pushed.push(r.pushed as u8);
    }

    /// Entry `i` packed (its real position, its shift, every other field).
    pub fn record(&self, i: usize) -> ParticleRecord {
        ParticleRecord {
            id: self.id[i],
            x: self.x_real[i],
            shift: self.shift[i],
            v: self.v[i],
            vhat: self.vhat[i],
            f: self.f[i],
            m: self.m[i],
            rho: self.rho[i],
            drho: self.drho[i],
            p: self.p[i],
            c: self.c[i],
            e: self.e[i],
            de: self.de[i],
            work: self.work[i],
            h: self.h[i],
            rho_half: self.rho_half[i],
            e_half: self.e_half[i],
            mat: self.mat[i] as u32,
            fixed: self.fixed[i] as u32,
            hold: self.hold[i],
            pushed: u32::from(self.pushed[i])
                | u32::from(self.hold_more[i][0]) << 8
                | u32::from(self.hold_more[i][1]) << 16,
            held_by: u32::from_le_bytes([
                self.held_by[i][0],
                self.held_by[i][1],
                self.held_by[i][2],
                0,
            ]),
        }
    }

    /// Removes every ghost entry.
    pub fn truncate_ghosts(&mut self) {
        let n = self.n_owned;
        macro_rules! trunc {
            ($f:expr) => {
                $f.truncate(n)
            };
        }
        for_each_field!(self, trunc);
    }

    /// Keeps only the owned entries listed in `keep`, in that order (to drop particles that
    /// migrated away, or to sort by cell); ghosts are removed. The one function that removes or
    /// reorders particles: it touches every field.
    pub fn select_owned(&mut self, keep: &[usize]) {
        assert!(keep.iter().all(|&i| i < self.n_owned));
        macro_rules! sel {
            ($f:expr) => {
                $f = keep.iter().map(|&i| $f[i]).collect()
            };
        }
        for_each_field!(self, sel);
        self.n_owned = keep.len();
    }

    /// The ghost contributions of entry `i`, to be sent to its owner.
    pub fn pair_sums(&self, i: usize) -> PairSums {
        self.sums[i]
    }

    /// Merges contributions received from a ghost copy of owned entry `i` (exact).
    pub fn add_pair_sums(&mut self, i: usize, s: &PairSums) {
        self.sums[i].merge(s);
    }

    /// Sets the density of every owned entry from its sum: `rho` with `summation`, else the
    /// continuity rate `drho`.
    pub fn settle_density(&mut self, summation: bool) {
        let out = if summation {
            &mut self.rho
        } else {
            &mut self.drho
        };
        for (o, s) in out.iter_mut().zip(&self.sums).take(self.n_owned) {
            *o = value2(&s.dens);
        }
    }

    /// Sets the force and the energy rate of every owned entry from its sums.
    pub fn settle_forces(&mut self) {
        for i in 0..self.n_owned {
            self.f[i] = values3(&self.sums[i].f);
            self.de[i] = value2(&self.sums[i].de);
        }
    }

    /// The EOS state of entry `i`, to be copied to its ghosts.
    pub fn eos_state(&self, i: usize) -> EosState {
        EosState {
            rho: self.rho[i],
            p: self.p[i],
            c: self.c[i],
        }
    }

    /// Sets the EOS state of (ghost) entry `i`.
    pub fn set_eos_state(&mut self, i: usize, s: &EosState) {
        self.rho[i] = s.rho;
        self.p[i] = s.p;
        self.c[i] = s.c;
    }

    /// Bytes held by the per-particle arrays (owned and ghost entries, allocated capacity).
    pub fn bytes(&self) -> usize {
        fn b<T>(v: &Vec<T>) -> usize {
            v.capacity() * std::mem::size_of::<T>()
        }
        b(&self.id)
            + b(&self.x)
            + b(&self.x_real)
            + b(&self.shift)
            + b(&self.v)
            + b(&self.vhat)
            + b(&self.f)
            + b(&self.m)
            + b(&self.rho)
            + b(&self.drho)
            + b(&self.p)
            + b(&self.c)
            + b(&self.e)
            + b(&self.de)
            + b(&self.work)
            + b(&self.h)
            + b(&self.rho_half)
            + b(&self.e_half)
            + b(&self.mat)
            + b(&self.fixed)
            + b(&self.hold)
            + b(&self.hold_more)
            + b(&self.held_by)
            + b(&self.pushed)
            + b(&self.sums)
    }

    /// The largest smoothing length over all entries (0 if none).
    pub fn max_h(&self) -> f64 {
        self.h.iter().fold(0.0, |a: f64, &b| a.max(b))
    }
}
