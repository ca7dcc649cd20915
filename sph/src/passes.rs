//! The pair passes and the per-particle updates between them.
//!
//! A pass walks a pair list (from `neighbour::pairs`) and adds each pair's contribution to BOTH
//! entries, owned or ghost, as exact sums (`Particles::sums`, on the grids of
//! [`crate::exact::PassGrids`]; each pass first zeroes the sums it adds to, and records its
//! largest terms), then settles the owned entries' values (`f`, `de`, `drho` or `rho`); the
//! parallel layer then merges the ghosts' sums into their owners (`Particles::pair_sums` /
//! `add_pair_sums`) and settles again. Order within one step (the parallel layer does the
//! communication between the lines; [`crate::exact::exact_pass`] redoes a pass whose terms did
//! not fit its grids):
//!
//! ```text
//! density_pass;        ghosts -> owners (drho, or rho with summation); settle_density
//! update_eos (owned);  owners -> ghosts (rho, p, c)
//! force_pass;          ghosts -> owners (f, de); settle_forces
//! add_gravity (owned)
//! ```
//!
//! Notation: r_ab = x_a - x_b, r = |r_ab|, h = (h_a + h_b)/2, v^_ab = v^_a - v^_b,
//! grad_a W_ab = dW/dr r_ab/r. Passes skip coincident pairs (r = 0: no direction).
use crate::eos::Eos;
use crate::exact::{note, q, PassGrids, TermMax};
use crate::kernel::{Kernel, ScaledKernel};
use crate::params::{DensityMode, Params, Profile};
use crate::particles::{PairSums, Particles};
use binsum::Folds2;

/// The rate at which the pair forces of one pass turn kinetic into internal energy, W (J/s):
/// sum over pairs of m_a m_b X (dW/dr/r)(v^_ab . r_ab) with X the pressure (with tensile
/// correction) or the viscous term. The kinetic-energy rate of the pair forces is minus the
/// total; `Particles::de` holds the same split per particle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PairWork {
    /// From p_a/rho_a^2 + p_b/rho_b^2 and the tensile correction.
    pub pressure: f64,
    /// From the artificial viscosity (>= 0: viscosity only dissipates).
    pub viscosity: f64,
}

impl PairWork {
    /// pressure + viscosity.
    pub fn total(&self) -> f64 {
        self.pressure + self.viscosity
    }

    /// Adds another pass's (or rank's) work.
    pub fn add(&mut self, o: &PairWork) {
        self.pressure += o.pressure;
        self.viscosity += o.viscosity;
    }
}

/// The tensile-correction factor on positive pressures (Monaghan 2000, §4; LIGGGHTS hard-codes
/// the same 0.01 for pairs with both pressures positive).
pub const POSITIVE_PRESSURE_TENSILE_FACTOR: f64 = 0.01;
/// Exponent n of f_ab^n in the tensile correction (Monaghan 2000).
pub const TENSILE_EXPONENT: i32 = 4;

#[inline]
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Zeroes the density sums of every entry (and sizes `Particles::sums`): continuity: 0;
/// summation: the self term m W(0, h) on owned entries, 0 on ghosts.
fn reset_density_sums(p: &mut Particles, params: &Params, g: &PassGrids, m: &mut TermMax) {
    p.sums.resize(p.len(), PairSums::default());
    let k = params.smoothing_kernel();
    let grid = g.grid(q::DENSITY);
    for i in 0..p.len() {
        let s = &mut p.sums[i].dens;
        *s = [0.0; 2];
        if params.density == DensityMode::Summation && i < p.n_owned {
            let w0 = p.m[i] * k.w(0.0, p.h[i]);
            grid.add(s, w0);
            note(&mut m[q::DENSITY], w0);
        }
    }
}

/// Density pass. Continuity: adds m_b (dW/dr)(r_ab . v^_ab)/r to drho_a and m_a (...) to drho_b
/// (Monaghan 1992, eq. 2.16; LIGGGHTS `fix sph/density/continuity`). Summation: rho_a = m_a
/// W(0, h_a) + sum m_b W_ab, the same for b. Sets the density sums of every entry (exact, on
/// `g`; largest terms into `m`) and the owned entries' `drho` (or `rho`) from them. Flops per
/// pair ~30 + 2 x 8 for the sums, bytes ~200 (positions, velocities, h, m).
pub fn density_pass(
    pairs: &[(u32, u32)],
    p: &mut Particles,
    params: &Params,
    g: &PassGrids,
    m: &mut TermMax,
) {
    reset_density_sums(p, params, g, m);
    let k = params.smoothing_kernel();
    let grid = g.grid(q::DENSITY);
    let mut big = m[q::DENSITY];
    let mut add = |p: &mut Particles, i: usize, x: f64| {
        grid.add(&mut p.sums[i].dens, x);
        note(&mut big, x);
    };
    match params.density {
        DensityMode::Continuity => {
            for &(i, j) in pairs {
                let (i, j) = (i as usize, j as usize);
                let d = sub(p.x[i], p.x[j]);
                let r = dot(d, d).sqrt();
                if r == 0.0 {
                    continue;
                }
                let h = 0.5 * (p.h[i] + p.h[j]);
                let t = k.dw_dr(r, h) * dot(d, sub(p.vhat[i], p.vhat[j])) / r;
                let (ti, tj) = (p.m[j] * t, p.m[i] * t);
                add(p, i, ti);
                add(p, j, tj);
            }
        }
        DensityMode::Summation => {
            for &(i, j) in pairs {
                let (i, j) = (i as usize, j as usize);
                let d = sub(p.x[i], p.x[j]);
                let r = dot(d, d).sqrt();
                let w = k.w(r, 0.5 * (p.h[i] + p.h[j]));
                let (wi, wj) = (p.m[j] * w, p.m[i] * w);
                add(p, i, wi);
                add(p, j, wj);
            }
        }
    }
    m[q::DENSITY] = big;
    p.settle_density(params.density == DensityMode::Summation);
}

/// Sets p and c of every owned entry from its rho and e with its material's EOS. In the
/// LIGGGHTS profile a Tait fluid's c is its constant c0 (LIGGGHTS's per-type `speedOfSound`).
pub fn update_eos(p: &mut Particles, params: &Params) {
    for i in 0..p.n_owned {
        let eos = &params.eos[p.mat[i] as usize];
        let (pr, c) = match (params.profile, liggghts_sound_speed(eos)) {
            // the EOS's own c is not used: not computed (a square root per particle)
            (Profile::Liggghts, Some(c0)) => (eos.pressure(p.rho[i], p.e[i]), c0),
            _ => eos.pressure_and_sound_speed(p.rho[i], p.e[i]),
        };
        p.p[i] = pr;
        p.c[i] = c;
    }
}

/// The sound speed LIGGGHTS's artificial viscosity uses: the per-type constant `speedOfSound`,
/// which for a Tait fluid is c0; `None` for the other materials (their EOS sound speed is used).
#[inline]
fn liggghts_sound_speed(eos: &Eos) -> Option<f64> {
    match *eos {
        Eos::Tait { c0, .. } => Some(c0),
        _ => None,
    }
}

/// Force pass: for each pair, with P = p_a/rho_a^2 + p_b/rho_b^2 + R_ab f_ab^4 and Pi_ab the
/// viscous term,
///
/// ```text
/// f_a += -m_a m_b (P + Pi) grad_a W_ab,      f_b -= the same          (Monaghan 1992, eq. 3.3)
/// de_a += 1/2 m_b (P + Pi) v^_ab . grad_a W_ab, de_b += 1/2 m_a (...)   (Monaghan 1992, eq. 3.4)
/// ```
///
/// Pi_ab = (-alpha c_mean mu + beta mu^2)/rho_mean with mu = h (v^_ab . r_ab)/(r^2 + eta^2) when
/// v^_ab . r_ab < 0, else 0. Tensile correction f_ab = W(r)/W(delta_p) and R_ab: LIGGGHTS profile:
/// 0.01 (p_a/rho_a^2 + p_b/rho_b^2) if both pressures are positive, otherwise the sum of
/// epsilon |p|/rho^2 over those of a, b in tension; standard profile: R_a + R_b with R = epsilon
/// |p|/rho^2 in tension and 0.01 p/rho^2 in compression (Monaghan 2000; Gray et al. 2001).
/// With `Params::conductivity` (and the energy equation) it also adds Price's (2008)
/// artificial conductivity to de (see there). Sets the force and energy-rate sums of every
/// entry (exact, on `g`; largest terms into `m`) and the owned entries' `f` and `de` from them.
/// Returns the pair work rate. Flops per pair ~80 + ~60 for the sums, bytes ~250.
pub fn force_pass(
    pairs: &[(u32, u32)],
    p: &mut Particles,
    params: &Params,
    g: &PassGrids,
    m: &mut TermMax,
) -> PairWork {
    let mut buf = PassBuffers::default();
    buf.pack(p, params, None);
    let (work, _) = pair_loop::<false, false>(pairs, &mut buf, params, g, m);
    buf.unpack(p, None, false);
    work
}

/// The continuity density pass and the force pass in one walk over the pairs: what
/// `density_pass` (continuity) then `force_pass` add, with the pair geometry and dW/dr computed
/// once. Valid when the forces do not need this pass's density rates, i.e. with continuity
/// density, whose rates only enter the next update of rho: call `update_eos` on the owners
/// first and give the ghosts those (rho, p, c). Saves one walk over the pairs (~30 of ~110
/// flops per pair) and, in parallel, one reverse communication and one ghost refresh. Sets
/// every sum the two passes set.
pub fn continuity_and_force_pass(
    pairs: &[(u32, u32)],
    p: &mut Particles,
    params: &Params,
    g: &PassGrids,
    m: &mut TermMax,
) -> PairWork {
    continuity_and_force_pass_with(pairs, p, params, &mut PassBuffers::default(), g, m)
}

/// [`continuity_and_force_pass`] with buffers kept from pass to pass (no allocation once they
/// have grown to the entries' count).
pub fn continuity_and_force_pass_with(
    pairs: &[(u32, u32)],
    p: &mut Particles,
    params: &Params,
    buf: &mut PassBuffers,
    g: &PassGrids,
    m: &mut TermMax,
) -> PairWork {
    assert_continuity(params);
    buf.pack(p, params, None);
    let (work, _) = pair_loop::<false, true>(pairs, buf, params, g, m);
    buf.unpack(p, None, true);
    work
}

#[inline]
fn assert_continuity(params: &Params) {
    assert_eq!(
        params.density,
        DensityMode::Continuity,
        "the fused pass needs continuity density"
    );
}

/// The inputs of the force pass of one entry, packed together (96 bytes) so that a pair reads
/// two of these rather than ten scattered arrays: position and h (all the overlap test of kept
/// candidates reads), predicted velocity and mass, p/rho^2 (computed once per entry rather than
/// twice per pair), rho, c and p. Aligned to 32 bytes, so that each group of four lies within
/// one cache line.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct Slot {
    x: [f64; 3],
    h: f64,
    vhat: [f64; 3],
    m: f64,
    p_rho2: f64,
    rho: f64,
    c: f64,
    p: f64,
}

/// What a pass adds to one entry, as exact sums: force and energy rate, fold by fold (`fold[k]`
/// = the parts on grid k of f_x, f_y, f_z, de: four lanes, split and added together; 64 bytes,
/// aligned); the density rate is beside them (`PassBuffers::drho`).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub(crate) struct Sums {
    pub(crate) fold: [[f64; 4]; 2],
}

/// The shifts of the four lanes of [`Sums`] on each grid: force, force, force, energy rate.
#[inline]
pub(crate) fn lane_shifts(g: &PassGrids) -> [[f64; 4]; 2] {
    let (f, e) = (g.grid(q::FORCE).shift, g.grid(q::ENERGY).shift);
    [0, 1].map(|k| [f[k], f[k], f[k], e[k]])
}

/// Adds the four terms `x` to `acc`, each split on its lane's grids (`binsum::Grid2::split`,
/// lane by lane: the compiler keeps the lanes in vector registers).
#[inline(always)]
pub(crate) fn add4(acc: &mut [[f64; 4]; 2], x: [f64; 4], c: &[[f64; 4]; 2]) {
    let mut r = x;
    for k in 0..2 {
        for l in 0..4 {
            let t = (r[l] + c[k][l]) - c[k][l];
            r[l] -= t;
            acc[k][l] += t;
        }
    }
}

/// The buffers of a pair pass, reused from pass to pass: each entry's inputs packed
/// (`Slot`), in the order of the entries or in an order of the caller's (a kept pair list's,
/// see `KeptPairs`), and the sums the pass adds, in the same order, added to the entries at the
/// end. The sums of an entry are added up in the order of the pairs, whatever the packing
/// order, so the results do not depend on it (bit for bit).
#[derive(Clone, Debug, Default)]
pub struct PassBuffers {
    slots: Vec<Slot>,
    /// Specific internal energy of each slot (with artificial conductivity only).
    e: Vec<f64>,
    sums: Vec<Sums>,
    /// Density rate of each slot (continuity).
    drho: Vec<Folds2>,
    /// Pairs of each slot that passed the overlap test (kept candidates only).
    count: Vec<u32>,
}

impl PassBuffers {
    /// Packs entry `order[k]` (entry k without `order`) into slot k and zeroes the sums.
    pub(crate) fn pack(&mut self, p: &Particles, params: &Params, order: Option<&[u32]>) {
        let n = order.map_or(p.len(), |o| o.len());
        let entry = |k: usize| order.map_or(k, |o| o[k] as usize);
        self.slots.clear();
        self.slots.extend((0..n).map(entry).map(|i| Slot {
            x: p.x[i],
            h: p.h[i],
            vhat: p.vhat[i],
            m: p.m[i],
            p_rho2: p.p[i] / (p.rho[i] * p.rho[i]),
            rho: p.rho[i],
            c: p.c[i],
            p: p.p[i],
        }));
        self.e.clear();
        if conductivity(params).is_some() {
            self.e.extend((0..n).map(entry).map(|i| p.e[i]));
        }
        self.sums.clear();
        self.sums.resize(n, Sums::default());
        self.drho.clear();
        self.drho.resize(n, [0.0; 2]);
        self.count.clear();
        self.count.resize(n, 0);
    }

    /// Sets the sums of entry `order[k]` (entry k without `order`) to those of slot k: f, de
    /// and, with `continuity`, drho; then settles the owned entries' values from them.
    pub(crate) fn unpack(&self, p: &mut Particles, order: Option<&[u32]>, continuity: bool) {
        p.sums.resize(p.len(), PairSums::default());
        if order.is_some() {
            // entries without a candidate have no slot: their sums are zero
            for e in p.sums.iter_mut() {
                e.f = [[0.0; 2]; 3];
                e.de = [0.0; 2];
                e.partners = 0.0;
                if continuity {
                    e.dens = [0.0; 2];
                }
            }
        }
        for (k, s) in self.sums.iter().enumerate() {
            let i = order.map_or(k, |o| o[k] as usize);
            let e = &mut p.sums[i];
            let part = |l: usize| [s.fold[0][l], s.fold[1][l]];
            e.f = [part(0), part(1), part(2)];
            e.de = part(3);
            e.partners = self.count[k] as f64;
            if continuity {
                e.dens = self.drho[k];
            }
        }
        p.settle_forces();
        if continuity {
            p.settle_density(false);
        }
    }

    /// Pairs of each slot that passed the overlap test in the last pass over kept candidates.
    pub(crate) fn counts(&self) -> &[u32] {
        &self.count
    }
}

/// Price's (2008) artificial conductivity coefficient, when it applies (with the energy
/// equation).
#[inline]
fn conductivity(params: &Params) -> Option<f64> {
    if params.energy {
        params.conductivity
    } else {
        None
    }
}

/// The kernel at h and 1/W(delta_p, h) of the tensile correction (0 without tensile
/// correction or when delta_p is beyond the support).
fn kernel_at(k: &crate::kernel::SmoothingKernel, h: f64, params: &Params) -> (ScaledKernel, f64) {
    let sk = k.at(h);
    let inv_w_dp = match params.tensile {
        Some(tc) => {
            let w_dp = sk.w(tc.delta_p);
            if w_dp > 0.0 {
                1.0 / w_dp
            } else {
                0.0
            }
        }
        None => 0.0,
    };
    (sk, inv_w_dp)
}

/// Kept candidates tested per chunk before the chunk's overlapping pairs are computed: the
/// test writes every candidate to a small buffer (in L1) and advances by one where it passes,
/// so the ~30 % of candidates that fail cost no mispredicted jump each.
const CANDIDATE_CHUNK: usize = 256;

/// The pair loop of the force passes over packed slots (`buf`, from [`PassBuffers::pack`]).
/// `KEPT`: `pairs` are kept candidates, of which only those whose spheres overlap now
/// (r^2 < (h_a + h_b)^2, the search's test) are computed and counted in `buf.count`; else every
/// pair is computed. `CONTINUITY`: also the continuity density rates. Coincident pairs (r = 0)
/// are skipped. Returns the pair work rate and the number of overlapping pairs (`KEPT` only).
/// The choices within a pair (viscosity only when approaching, the tensile correction's sign
/// cases, the kernel's pieces) are clamps and masks (one maxsd, minsd or compare each), not
/// jumps: each goes either way at random from pair to pair. They give the textbook cases'
/// values bit for bit (up to the sign of a zero term, which no sum here can see).
///
/// Per computed pair (cubic spline, viscosity and tensile correction on, as the dam break):
/// ~100 flops (geometry 8, one sqrt and three divisions, kernel value and derivative 20,
/// viscosity 12, tensile correction 10, pressure, force and energy 30, density rate 6, work 10)
/// and 2 x 96 bytes of packed inputs read and 2 x 40 bytes of sums read and written, in L1/L2
/// when the slots follow the pairs' order (`KeptPairs`); a candidate's test costs 9 flops and
/// 2 x 32 bytes. Measured (dam break at np 1, 2,000 steps, callgrind): ~280 instructions per
/// computed pair with its share of the rejected candidates (1.4 candidates per pair), ~17 ns
/// per pair at 2.6 GHz: far from the memory's limit (the data are in cache) and from the
/// divider's (4 square roots or divisions, ~5 cycles each): bound by instructions and by the
/// latency of each pair's chain (square root, division, kernel, force, sums).
/// A 4-lane form of the formula over fixed-size arrays (gather, compute, scatter in order)
/// and a blocked form (gather into per-quantity arrays, formula, scatter) were both measured
/// slower on the baseline x86-64 target (SSE2, 2 lanes): the gathers and scatters cost more than
/// the halved arithmetic.
#[inline(always)]
fn pair_loop<const KEPT: bool, const CONTINUITY: bool>(
    pairs: &[(u32, u32)],
    buf: &mut PassBuffers,
    params: &Params,
    g: &PassGrids,
    m: &mut TermMax,
) -> (PairWork, usize) {
    // the kernel's shape and the profile as constants of the loop (no test of them per pair)
    let liggghts = params.profile == Profile::Liggghts;
    match (params.kernel, liggghts) {
        (Kernel::CubicSpline, true) => {
            pair_loop_for::<KEPT, CONTINUITY, true, true>(pairs, buf, params, g, m)
        }
        (Kernel::CubicSpline, false) => {
            pair_loop_for::<KEPT, CONTINUITY, true, false>(pairs, buf, params, g, m)
        }
        (Kernel::Wendland, true) => {
            pair_loop_for::<KEPT, CONTINUITY, false, true>(pairs, buf, params, g, m)
        }
        (Kernel::Wendland, false) => {
            pair_loop_for::<KEPT, CONTINUITY, false, false>(pairs, buf, params, g, m)
        }
    }
}

/// `pair_loop` for one kernel shape (`CUBIC`: cubic spline, else Wendland) and profile
/// (`LIGGGHTS`).
#[inline(never)]
fn pair_loop_for<
    const KEPT: bool,
    const CONTINUITY: bool,
    const CUBIC: bool,
    const LIGGGHTS: bool,
>(
    pairs: &[(u32, u32)],
    buf: &mut PassBuffers,
    params: &Params,
    g: &PassGrids,
    m: &mut TermMax,
) -> (PairWork, usize) {
    let k = params.smoothing_kernel();
    let gd = g.grid(q::DENSITY);
    let shifts = lane_shifts(g);
    let (mut mf, mut md, mut me) = (m[q::FORCE], m[q::DENSITY], m[q::ENERGY]);
    let kind = if CUBIC {
        Kernel::CubicSpline
    } else {
        Kernel::Wendland
    };
    let cond = conductivity(params);
    let PassBuffers {
        slots,
        e,
        sums,
        drho,
        count,
    } = buf;
    let slots = &slots[..];
    let sums = &mut sums[..slots.len()];
    let drho = &mut drho[..slots.len()];
    let count = &mut count[..slots.len()];
    // h is mostly the same for every pair: the kernel's factors are remade when it changes
    let mut kern = kernel_at(&k, f64::NAN, params);
    let mut work = PairWork::default();
    let pair = |i: usize, j: usize| {
        let (a, b) = (&slots[i], &slots[j]);
        let d = sub(a.x, b.x);
        let r2 = dot(d, d);
        let r = r2.sqrt();
        if r == 0.0 {
            return; // coincident: no direction
        }
        let h = 0.5 * (a.h + b.h);
        if kern.0.h != h {
            kern = kernel_at(&k, h, params);
        }
        let inv_r = 1.0 / r;
        // kern.0.dw_dr(r) and kern.0.w(r) with the shape known here
        let (inv_h, w_norm, dw_norm) = kern.0.factors();
        let s = r * inv_h;
        let dw = dw_norm * kind.shape_derivative(s);
        let vr = dot(sub(a.vhat, b.vhat), d);
        if CONTINUITY {
            // Monaghan 1992, eq. 2.16, as in density_pass
            let t = dw * vr * inv_r;
            let (ti, tj) = (b.m * t, a.m * t);
            gd.add(&mut drho[i], ti);
            gd.add(&mut drho[j], tj);
            note(&mut md, ti);
            note(&mut md, tj);
        }
        let visc = pair_viscosity(params, a, b, h, vr, r2);
        let (pa, pb) = (a.p_rho2, b.p_rho2);
        let tensile = pair_tensile::<LIGGGHTS>(params, kind, s, w_norm, kern.1, a, b);
        let press = pa + pb + tensile;
        let gr = dw * inv_r; // grad_a W_ab = gr r_ab
        let mm = a.m * b.m;
        let fs = mm * (press + visc) * gr;
        let fd = [fs * d[0], fs * d[1], fs * d[2]];
        // the largest force term's bound, |fs| r >= |fs d_c|, is a function of the pair
        note(&mut mf, fs * r);
        let de = (press + visc) * gr * vr;
        let mut de_i = 0.5 * b.m * de;
        let mut de_j = 0.5 * a.m * de;
        work.pressure += mm * press * gr * vr;
        work.viscosity += mm * visc * gr * vr;
        if let Some(alpha_u) = cond {
            // de_a += m_b alpha_u v_sig (e_a - e_b)/rho_mean dW/dr, v_sig = sqrt(|p_a - p_b|/rho_mean)
            let rho_mean = 0.5 * (a.rho + b.rho);
            let v_sig = ((a.p - b.p).abs() / rho_mean).sqrt();
            let q = alpha_u * v_sig * (e[i] - e[j]) / rho_mean * dw;
            de_i += b.m * q;
            de_j -= a.m * q;
        }
        note(&mut me, de_i);
        note(&mut me, de_j);
        // equal and opposite forces: a swapped pair gives the negated terms, whose parts are
        // the negated parts (binsum::Grid::split)
        add4(&mut sums[i].fold, [-fd[0], -fd[1], -fd[2], de_i], &shifts);
        add4(&mut sums[j].fold, [fd[0], fd[1], fd[2], de_j], &shifts);
    };
    let n_pairs = each_pair::<KEPT>(pairs, slots, count, pair);
    *m = [mf, md, me];
    (work, n_pairs)
}

/// Runs `pair` on each pair of `pairs` and counts each slot's pairs; with `KEPT` (candidates
/// kept between steps) only on those whose particles overlap, a chunk at a time: the overlap
/// test first, then the pairs that passed. Returns how many passed (0 without `KEPT`).
#[inline(always)]
fn each_pair<const KEPT: bool>(
    pairs: &[(u32, u32)],
    slots: &[Slot],
    count: &mut [u32],
    mut pair: impl FnMut(usize, usize),
) -> usize {
    let mut n_pairs = 0usize;
    if KEPT {
        let mut close = [(0u32, 0u32); CANDIDATE_CHUNK];
        for chunk in pairs.chunks(CANDIDATE_CHUNK) {
            let mut n = 0;
            for &(i, j) in chunk {
                let (a, b) = (&slots[i as usize], &slots[j as usize]);
                let d = sub(a.x, b.x);
                let reach = a.h + b.h;
                close[n] = (i, j);
                n += (dot(d, d) < reach * reach) as usize;
            }
            n_pairs += n;
            for &(i, j) in &close[..n] {
                let (i, j) = (i as usize, j as usize);
                count[i] += 1;
                count[j] += 1;
                pair(i, j);
            }
        }
    } else {
        for &(i, j) in pairs {
            let (i, j) = (i as usize, j as usize);
            count[i] += 1;
            count[j] += 1;
            pair(i, j);
        }
    }
    n_pairs
}

/// The artificial viscosity Pi_ab of a pair (zero without one), with h the pair's mean
/// smoothing length, vr = (v_a - v_b) . (x_a - x_b) and r2 = |x_a - x_b|^2.
#[inline(always)]
fn pair_viscosity(params: &Params, a: &Slot, b: &Slot, h: f64, vr: f64, r2: f64) -> f64 {
    match params.viscosity {
        Some(av) => {
            // mu = 0 (so Pi = 0) when receding: min(vr, 0) rather than a jump
            let mu = h * neg_part(vr) / (r2 + av.eta_factor * h * h);
            let c_mean = 0.5 * (a.c + b.c);
            let rho_mean = 0.5 * (a.rho + b.rho);
            (-av.alpha * c_mean * mu + av.beta * mu * mu) / rho_mean
        }
        None => 0.0,
    }
}

/// The tensile-instability correction R_ab f_ab^n of a pair (zero without one), f_ab =
/// W(r) / W(delta_p) (`w_norm` times the shape at `s` = r / h, times `inv_w_delta` = 1 /
/// W(delta_p)); the LIGGGHTS form with `LIGGGHTS`.
#[inline(always)]
fn pair_tensile<const LIGGGHTS: bool>(
    params: &Params,
    kind: Kernel,
    s: f64,
    w_norm: f64,
    inv_w_delta: f64,
    a: &Slot,
    b: &Slot,
) -> f64 {
    let (pa, pb) = (a.p_rho2, b.p_rho2);
    match params.tensile {
        Some(tc) if inv_w_delta > 0.0 => {
            let fab = w_norm * kind.shape(s) * inv_w_delta;
            // epsilon |x| in tension (x < 0), else 0: epsilon max(-x, 0)
            let tension = |x: f64| tc.epsilon * pos_part(-x);
            if LIGGGHTS {
                // 0.01 (pa + pb) when both pressures are positive (the tension terms
                // are then zero), else the tension terms
                let both = (a.p > 0.0) & (b.p > 0.0);
                let positive = POSITIVE_PRESSURE_TENSILE_FACTOR * (pa + pb);
                (select_or_zero(both, positive) + (tension(pa) + tension(pb)))
                    * fab.powi(TENSILE_EXPONENT)
            } else {
                let one = |x: f64| tension(x) + tc.positive * pos_part(x);
                (one(pa) + one(pb)) * powi_tensile(fab, tc.exponent)
            }
        }
        _ => 0.0,
    }
}

/// f^n of the tensile correction: n = 4 (Monaghan's, the default) written out as `powi(4)`
/// with a constant exponent (the same bits as the runtime routine's for n = 4, and no call
/// per pair); other n through `powi`.
#[inline(always)]
fn powi_tensile(f: f64, n: i32) -> f64 {
    if n == TENSILE_EXPONENT {
        f.powi(TENSILE_EXPONENT)
    } else {
        f.powi(n)
    }
}

/// x where x > 0, else +0 (also for NaN): a clamp of a pair's formula, one `maxsd` rather than
/// a jump (the cases go either way at random from pair to pair).
#[inline(always)]
pub(crate) fn pos_part(x: f64) -> f64 {
    if x > 0.0 {
        x
    } else {
        0.0
    }
}

/// x where x < 0, else +0 (also for NaN), as [`pos_part`] (one `minsd`).
#[inline(always)]
fn neg_part(x: f64) -> f64 {
    if x < 0.0 {
        x
    } else {
        0.0
    }
}

/// x where `c` holds, else +0, for a cheap x (a compare and a mask, not a jump).
#[inline(always)]
fn select_or_zero(c: bool, x: f64) -> f64 {
    if c {
        x
    } else {
        0.0
    }
}

/// [`continuity_and_force_pass`] over kept candidates packed in `order`
/// (`KeptPairs`): candidates whose spheres do not overlap now are skipped inside the pass.
/// Returns the work rate and the number of overlapping pairs; `buf.counts()` gives each slot's.
pub(crate) fn kept_continuity_and_force_pass(
    candidates: &[(u32, u32)],
    order: &[u32],
    p: &mut Particles,
    params: &Params,
    buf: &mut PassBuffers,
    g: &PassGrids,
    m: &mut TermMax,
) -> (PairWork, usize) {
    assert_continuity(params);
    buf.pack(p, params, Some(order));
    let out = pair_loop::<true, true>(candidates, buf, params, g, m);
    buf.unpack(p, Some(order), true);
    out
}

/// Adds m g to the force of every owned entry that moves.
pub fn add_gravity(p: &mut Particles, params: &Params) {
    if params.gravity == [0.0; 3] {
        return;
    }
    for i in 0..p.n_owned {
        if !p.fixed[i] {
            for c in 0..3 {
                p.f[i][c] += p.m[i] * params.gravity[c];
            }
        }
    }
}
