//! The explicit step's passes over the nodes ([`crate::explicit::ExplicitFe`]'s `kick_drift` and
//! the first part of its `finish_step`), node by node or, as the element kernel's width
//! ([`Nodes`]), eight nodes (24 doubles, three AVX-512 registers per vector field) or four
//! (12 doubles, three AVX2 registers) at a time.
//!
//! Why by hand: node by node the two passes took about 34 and 95 instructions per node
//! (callgrind), the same time per node whether the nodes sat in L2 or in L3, so the passes
//! were bound by instructions, not by memory: about 11 ns per element-cycle of the benchmark
//! block, a sixth of its step. The compiler's vectoriser did not turn the node loops, with
//! their per-node mass and cases (free or constrained, owned or not), into vector code (tried:
//! 163 instructions per node), so the eight- and four-node forms are written with `std::arch`
//! intrinsics, the per-node values spread to the nodes' three slots by one permutation per
//! register. On an AVX2 CPU node by node took about a fifth of the four-lane kernel's step.
//!
//! Both forms compute the same accelerations, velocities and positions bit for bit (each
//! product and sum rounded as node by node, no fused multiply-adds), and the same terms of the
//! energy and momentum sums, which both add on the fixed grids of [`crate::exact`]: the sums
//! are the same bits in either form, in any order of the nodes and on any partition (`tests`
//! below).

use crate::exact::{Folds, Grid, StepFolds, SumGrids};

/// How many nodes the passes take at a time: the element kernel's width
/// ([`crate::batch::Width`]), whose instructions the CPU has.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Nodes {
    /// Node by node.
    One,
    /// Four nodes in AVX2 registers (the CPU must have AVX2).
    #[cfg(target_arch = "x86_64")]
    Four,
    /// Eight nodes in AVX-512 registers (the CPU must have AVX-512F).
    #[cfg(target_arch = "x86_64")]
    Eight,
}

impl Nodes {
    /// The passes' width for an element kernel of width `w` (run only where the CPU has its
    /// instructions).
    pub(crate) fn of(w: crate::batch::Width) -> Nodes {
        use crate::batch::Width;
        match w {
            #[cfg(target_arch = "x86_64")]
            Width::W8 => Nodes::Eight,
            #[cfg(target_arch = "x86_64")]
            Width::W4 => Nodes::Four,
            _ => Nodes::One,
        }
    }
}

/// What a node's energy and momentum sums read ([`close_free`], [`NodalSums::add`]), as slices
/// of the local node count.
pub(crate) struct NodalSums<'a> {
    /// The step, s.
    pub dt: f64,
    pub force: &'a [[f64; 3]],
    pub mass: &'a [f64],
    pub owned: &'a [bool],
    pub gravity: [f64; 3],
    /// The gravity whose work the sums count: the mean over the step (`gravity` when it does
    /// not change).
    pub gravity_work: [f64; 3],
    pub grids: SumGrids,
}

impl NodalSums<'_> {
    /// Adds node `n`'s kinetic energy (velocity `v` at the end of the step), element and
    /// external work over the step (trapezoids with the reactions `r` now and `r_old` a step
    /// ago, over the displacement dt `half`, `half` the velocity of the step's drift; of the
    /// element work's trapezoid, f(n+1)/2 . dx: the kick counted f(n)/2 . dx, [`kick_drift`])
    /// and momentum to `sums` ([`StepFolds`]), if this rank owns the node. About 30 flops and
    /// 15 terms binned.
    ///
    /// The displacement: the drift and the contact push-back move a node by dt times the
    /// velocity they leave at the half step (x(n+1) = x(n) + dt v(n+1/2), the push-back adding
    /// dv to v and dt dv to x), so dt v(n+1/2) is x(n+1) - x(n) without the rounding of x
    /// (relative 1e-16 of |x| against |dx|) and without reading two position arrays.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn add(
        &self,
        n: usize,
        v: [f64; 3],
        half: [f64; 3],
        r: [f64; 3],
        r_old: [f64; 3],
        sums: &mut StepFolds,
    ) {
        if !self.owned[n] {
            return;
        }
        let (g, m) = (self.gravity_work, self.mass[n]);
        let f = self.force[n];
        let (e, p) = (&self.grids.energy, &self.grids.momentum);
        for c in 0..3 {
            let dx = self.dt * half[c];
            e.add(&mut sums[0], m * (v[c] * v[c]));
            e.add(&mut sums[1], f[c] * dx);
            e.add(&mut sums[2], (0.5 * (r[c] + r_old[c]) + m * g[c]) * dx);
            p.add(&mut sums[3 + c], m * v[c]);
        }
    }
}

/// What the kick reads of each node besides its motion and forces: masses, gravity, and which
/// nodes this rank owns and which are constrained.
pub(crate) struct KickInput<'a> {
    /// The grid of the work's sum.
    pub energy: Grid,
    pub mass: &'a [f64],
    pub gravity: [f64; 3],
    pub owned: &'a [bool],
    pub constrained: &'a [bool],
}

/// 1 / m of a nodal mass, and 0 where the node has none (all its elements became particles:
/// it carries no force and keeps its velocity).
#[inline(always)]
pub(crate) fn inverse_mass(m: f64) -> f64 {
    if m > 0.0 {
        1.0 / m
    } else {
        0.0
    }
}

/// The kick to the half step and the drift of every node: v += dt/2 a with the acceleration
/// a = f / m + g of the forces `force` at the step's start (the last step's element forces;
/// set to zero as read where `zero`: for the next element loop, when nothing reads them after
/// the kick), x_old = x (where `x_old` is given: the start positions kept for the contact
/// stage), x += dt v; before the constraints, which the caller applies to the velocities (a
/// constrained component's velocity is set there, whatever this kick gave it). Returns the
/// sum over the owned free nodes of f . dt v(n+1/2), twice the old forces' half of the element
/// work's trapezoid (the caller adds the constrained nodes' and the contact push-back's, and
/// `finish_step` the new forces' half): so that the closing pass reads no old forces. `wide`:
/// how many nodes at a time. Per node: v, f, m, x read (80 B), v, x
/// written (48 B), and x_old (24 B); 19 flops and a division.
#[allow(clippy::too_many_arguments)]
pub(crate) fn kick_drift(
    v: &mut [[f64; 3]],
    force: &mut [[f64; 3]],
    zero: bool,
    input: &KickInput,
    x: &mut [[f64; 3]],
    mut x_old: Option<&mut [[f64; 3]]>,
    dt: f64,
    wide: Nodes,
) -> Folds {
    let nn = v.len();
    assert!(
        force.len() == nn
            && input.mass.len() == nn
            && input.owned.len() == nn
            && input.constrained.len() == nn
            && x.len() == nn
            && x_old.as_ref().is_none_or(|o| o.len() == nn),
        "one value per node"
    );
    let (g, h) = (input.gravity, 0.5 * dt);
    #[allow(unused_mut)]
    let (mut done, mut work) = (0, [0.0; 3]);
    match wide {
        #[cfg(target_arch = "x86_64")]
        Nodes::Eight => {
            assert!(std::arch::is_x86_feature_detected!("avx512f"), "AVX-512F");
            // SAFETY: the CPU has AVX-512F (checked just above); the slices have one length.
            (done, work) =
                unsafe { w8::kick_drift(v, force, zero, input, x, x_old.as_deref_mut(), dt) };
        }
        #[cfg(target_arch = "x86_64")]
        Nodes::Four => {
            assert!(std::arch::is_x86_feature_detected!("avx2"), "AVX2");
            // SAFETY: the CPU has AVX2 (checked just above); the slices have one length.
            (done, work) =
                unsafe { w4::kick_drift(v, force, zero, input, x, x_old.as_deref_mut(), dt) };
        }
        Nodes::One => {}
    }
    for n in done..nn {
        if let Some(o) = x_old.as_deref_mut() {
            o[n] = x[n];
        }
        let im = inverse_mass(input.mass[n]);
        let f = force[n];
        if zero {
            force[n] = [0.0; 3];
        }
        let counted = input.owned[n] && !input.constrained[n];
        for c in 0..3 {
            v[n][c] += h * (f[c] * im + g[c]);
            x[n][c] += dt * v[n][c];
            if counted {
                input.energy.add(&mut work, f[c] * (dt * v[n][c]));
            }
        }
    }
    work
}

/// The first part of `finish_step`: for every free node (not `constrained`) the closing kick
/// of `v` (the half-step velocity to the end of the step) with a = f / m + g, and its sums
/// ([`NodalSums::add`] with zero reactions: only constrained nodes' reactions are ever
/// written) added to `sums`. The constrained nodes' kicks and sums are the caller's. `wide`:
/// how many nodes at a time.
///
/// Per node: force, mass and v read (56 B), v written (24 B); about 35 flops.
pub(crate) fn close_free(
    read: &NodalSums,
    constrained: &[bool],
    v: &mut [[f64; 3]],
    sums: &mut StepFolds,
    wide: Nodes,
) {
    let nn = v.len();
    assert!(
        constrained.len() == nn
            && read.force.len() == nn
            && read.mass.len() == nn
            && read.owned.len() == nn,
        "one value per node"
    );
    #[allow(unused_mut)]
    let mut done = 0;
    match wide {
        #[cfg(target_arch = "x86_64")]
        Nodes::Eight => {
            assert!(std::arch::is_x86_feature_detected!("avx512f"), "AVX-512F");
            // SAFETY: the CPU has AVX-512F (checked just above); every slice has `nn` nodes.
            done = unsafe { w8::close_free(read, constrained, v, sums) };
        }
        #[cfg(target_arch = "x86_64")]
        Nodes::Four => {
            assert!(std::arch::is_x86_feature_detected!("avx2"), "AVX2");
            // SAFETY: the CPU has AVX2 (checked just above); every slice has `nn` nodes.
            done = unsafe { w4::close_free(read, constrained, v, sums) };
        }
        Nodes::One => {}
    }
    let (g, h) = (read.gravity, 0.5 * read.dt);
    for n in done..nn {
        if !constrained[n] {
            let im = inverse_mass(read.mass[n]);
            let f = read.force[n];
            let an = [f[0] * im + g[0], f[1] * im + g[1], f[2] * im + g[2]];
            let vn = &mut v[n];
            let half = *vn;
            for c in 0..3 {
                vn[c] += h * an[c];
            }
            read.add(n, *vn, half, [0.0; 3], [0.0; 3], sums);
        }
    }
}

/// The eight-node forms. A chunk is nodes n0..n0 + 8, their vector fields 24 doubles from
/// 3 n0: register j holds slots 8 j .. 8 j + 8, slot s being component s % 3 of node s / 3.
#[cfg(target_arch = "x86_64")]
mod w8 {
    use super::{Folds, KickInput, NodalSums, StepFolds};
    use std::arch::x86_64::*;

    /// [`super::inverse_mass`] of eight masses `m`, given `im` = 1 / m: zero where m is not
    /// positive (a node all of whose elements became particles).
    #[inline(always)]
    fn inverse_masses(m: __m512d, im: __m512d) -> __m512d {
        // SAFETY: AVX-512F, as every caller's target feature.
        unsafe {
            let k = _mm512_cmp_pd_mask::<_CMP_GT_OQ>(m, _mm512_setzero_pd());
            _mm512_maskz_mov_pd(k, im)
        }
    }

    /// The node of each slot of register j, as an index for `vpermpd`.
    const SLOT_NODE: [[i64; 8]; 3] = [
        [0, 0, 0, 1, 1, 1, 2, 2],
        [2, 3, 3, 3, 4, 4, 4, 5],
        [5, 5, 6, 6, 6, 7, 7, 7],
    ];

    /// The slot mask (24 bits) of a node mask (8 bits): node bit k to slot bits 3k .. 3k + 3.
    const fn spread(m: u8) -> u32 {
        let mut r = 0;
        let mut k = 0;
        while k < 8 {
            if (m >> k) & 1 == 1 {
                r |= 7 << (3 * k);
            }
            k += 1;
        }
        r
    }

    static SPREAD: [u32; 256] = {
        let mut t = [0; 256];
        let mut i = 0;
        while i < 256 {
            t[i] = spread(i as u8);
            i += 1;
        }
        t
    };

    /// Bit k set where `b[k]` (eight values).
    #[inline(always)]
    fn node_mask(b: &[bool]) -> u8 {
        b[..8]
            .iter()
            .enumerate()
            .fold(0, |m, (k, &x)| m | ((x as u8) << k))
    }

    /// The gravity of each slot of register j (slot 8 j + t is component (8 j + t) % 3).
    #[inline(always)]
    fn gravity_slots(g: [f64; 3]) -> [__m512d; 3] {
        std::array::from_fn(|j| {
            let s: [f64; 8] = std::array::from_fn(|t| g[(8 * j + t) % 3]);
            // SAFETY: eight doubles (AVX-512F: every caller is built with it).
            unsafe { _mm512_loadu_pd(s.as_ptr()) }
        })
    }

    /// `SLOT_NODE` as index vectors.
    #[inline(always)]
    fn slot_nodes() -> [__m512i; 3] {
        // SAFETY: eight i64 each (AVX-512F: every caller is built with it).
        std::array::from_fn(|j| unsafe { _mm512_loadu_epi64(SLOT_NODE[j].as_ptr()) })
    }

    /// The slot masks (24 bits) of the free nodes and of the counted ones (owned and free) of
    /// the chunk at `n0`.
    #[inline(always)]
    fn chunk_masks(owned: &[bool], constrained: &[bool], n0: usize) -> (u32, u32) {
        let con = node_mask(&constrained[n0..]);
        let own = node_mask(&owned[n0..]);
        (SPREAD[!con as usize], SPREAD[(own & !con) as usize])
    }

    /// A grid's shifts in every lane.
    #[inline(always)]
    fn shifts(g: &crate::exact::Grid) -> [__m512d; 3] {
        // SAFETY: AVX-512F (every caller is built with it).
        g.shift.map(|c| unsafe { _mm512_set1_pd(c) })
    }

    /// [`crate::exact::Grid::add`] lane by lane, in the lanes of mask `k`.
    #[inline(always)]
    fn bin(acc: &mut [__m512d; 3], x: __m512d, c: &[__m512d; 3], k: u8) {
        // SAFETY: AVX-512F (every caller is built with it).
        unsafe {
            let t1 = _mm512_sub_pd(_mm512_add_pd(x, c[0]), c[0]);
            let r1 = _mm512_sub_pd(x, t1);
            let t2 = _mm512_sub_pd(_mm512_add_pd(r1, c[1]), c[1]);
            let r2 = _mm512_sub_pd(r1, t2);
            let t3 = _mm512_sub_pd(_mm512_add_pd(r2, c[2]), c[2]);
            acc[0] = _mm512_mask_add_pd(acc[0], k, acc[0], t1);
            acc[1] = _mm512_mask_add_pd(acc[1], k, acc[1], t2);
            acc[2] = _mm512_mask_add_pd(acc[2], k, acc[2], t3);
        }
    }

    /// [`super::kick_drift`] on the whole chunks; returns the nodes done and their work sum.
    ///
    /// # Safety
    /// The CPU must have AVX-512F; the slices must have one value per node.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn kick_drift(
        v: &mut [[f64; 3]],
        force: &mut [[f64; 3]],
        zero: bool,
        input: &KickInput,
        x: &mut [[f64; 3]],
        x_old: Option<&mut [[f64; 3]]>,
        dt: f64,
    ) -> (usize, Folds) {
        let whole = v.len() / 8 * 8;
        let (gp, idx) = (gravity_slots(input.gravity), slot_nodes());
        let (h, dtv, one) = (
            _mm512_set1_pd(0.5 * dt),
            _mm512_set1_pd(dt),
            _mm512_set1_pd(1.0),
        );
        let grid = shifts(&input.energy);
        let mut work = [_mm512_setzero_pd(); 3];
        let (pv, pf) = (v.as_mut_ptr() as *mut f64, force.as_mut_ptr() as *mut f64);
        let px = x.as_mut_ptr() as *mut f64;
        let po = x_old.map(|o| o.as_mut_ptr() as *mut f64);
        let pm = input.mass.as_ptr();
        for n0 in (0..whole).step_by(8) {
            // SAFETY: n0 + 8 <= len masses.
            let m = unsafe { _mm512_loadu_pd(pm.add(n0)) };
            let im = inverse_masses(m, _mm512_div_pd(one, m));
            let (_, counted) = chunk_masks(input.owned, input.constrained, n0);
            for j in 0..3 {
                let s = 3 * n0 + 8 * j;
                let kc = (counted >> (8 * j)) as u8;
                let imj = _mm512_permutexvar_pd(idx[j], im);
                // SAFETY: s + 8 <= 3 (n0 + 8) <= 3 len doubles in each array.
                unsafe {
                    let f = _mm512_loadu_pd(pf.add(s));
                    if zero {
                        _mm512_storeu_pd(pf.add(s), _mm512_setzero_pd());
                    }
                    let an = _mm512_add_pd(_mm512_mul_pd(f, imj), gp[j]);
                    let vn = _mm512_add_pd(_mm512_loadu_pd(pv.add(s)), _mm512_mul_pd(h, an));
                    _mm512_storeu_pd(pv.add(s), vn);
                    let xs = _mm512_loadu_pd(px.add(s));
                    if let Some(po) = po {
                        _mm512_storeu_pd(po.add(s), xs);
                    }
                    let dx = _mm512_mul_pd(dtv, vn);
                    _mm512_storeu_pd(px.add(s), _mm512_add_pd(xs, dx));
                    bin(&mut work, _mm512_mul_pd(f, dx), &grid, kc);
                }
            }
        }
        (whole, work.map(|w| _mm512_reduce_add_pd(w)))
    }

    /// [`super::close_free`] on the whole chunks; returns the nodes done.
    ///
    /// # Safety
    /// The CPU must have AVX-512F; every slice must have one value per node.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn close_free(
        r: &NodalSums,
        constrained: &[bool],
        v: &mut [[f64; 3]],
        sums: &mut StepFolds,
    ) -> usize {
        let nn = v.len();
        let whole = nn / 8 * 8;
        let (gp, idx) = (gravity_slots(r.gravity), slot_nodes());
        let gw = gravity_slots(r.gravity_work);
        let (h, dt, one) = (
            _mm512_set1_pd(0.5 * r.dt),
            _mm512_set1_pd(r.dt),
            _mm512_set1_pd(1.0),
        );
        let zero = _mm512_setzero_pd();
        let (ge, gm) = (shifts(&r.grids.energy), shifts(&r.grids.momentum));
        // The folds of m v^2, f dx and m g dx over every slot, and of m v per register (its
        // slots' components), over the counted nodes.
        let (mut ke, mut we, mut wx) = ([zero; 3], [zero; 3], [zero; 3]);
        let mut mo = [[zero; 3]; 3];
        let pf = r.force.as_ptr() as *const f64;
        let pv = v.as_mut_ptr() as *mut f64;
        for n0 in (0..whole).step_by(8) {
            // SAFETY: n0 + 8 <= nn masses.
            let m = unsafe { _mm512_loadu_pd(r.mass.as_ptr().add(n0)) };
            let im = inverse_masses(m, _mm512_div_pd(one, m));
            let (free, counted) = chunk_masks(r.owned, constrained, n0);
            for j in 0..3 {
                let (kf, kc) = ((free >> (8 * j)) as u8, (counted >> (8 * j)) as u8);
                let s = 3 * n0 + 8 * j;
                let mj = _mm512_permutexvar_pd(idx[j], m);
                let imj = _mm512_permutexvar_pd(idx[j], im);
                // SAFETY: s + 8 <= 3 (n0 + 8) <= 3 nn doubles in each array.
                unsafe {
                    let f = _mm512_loadu_pd(pf.add(s));
                    let an = _mm512_add_pd(_mm512_mul_pd(f, imj), gp[j]);
                    let half = _mm512_loadu_pd(pv.add(s));
                    let vn = _mm512_mask_add_pd(half, kf, half, _mm512_mul_pd(h, an));
                    _mm512_storeu_pd(pv.add(s), vn);
                    let dx = _mm512_mul_pd(dt, half);
                    bin(&mut ke, _mm512_mul_pd(mj, _mm512_mul_pd(vn, vn)), &ge, kc);
                    bin(&mut we, _mm512_mul_pd(f, dx), &ge, kc);
                    let mg = _mm512_add_pd(zero, _mm512_mul_pd(mj, gw[j]));
                    bin(&mut wx, _mm512_mul_pd(mg, dx), &ge, kc);
                    bin(&mut mo[j], _mm512_mul_pd(mj, vn), &gm, kc);
                }
            }
        }
        // Each fold's lanes are exact multiples of its quantum: added in any order.
        for (k, acc) in [ke, we, wx].iter().enumerate() {
            for f in 0..3 {
                sums[k][f] += _mm512_reduce_add_pd(acc[f]);
            }
        }
        for (j, reg) in mo.iter().enumerate() {
            for (f, fold) in reg.iter().enumerate() {
                let mut lanes = [0.0; 8];
                // SAFETY: eight doubles.
                unsafe { _mm512_storeu_pd(lanes.as_mut_ptr(), *fold) };
                for (t, x) in lanes.iter().enumerate() {
                    sums[3 + (8 * j + t) % 3][f] += x;
                }
            }
        }
        whole
    }
}

/// The four-node forms (AVX2, beside the four-lane element kernel). A chunk is nodes
/// n0..n0 + 4, their vector fields 12 doubles from 3 n0: register j holds slots 4 j .. 4 j + 4,
/// slot s being component s % 3 of node s / 3. A mask is a vector of all-ones or all-zeros
/// lanes, and the eight-node form's masked additions are blends (an untouched lane keeps its
/// bits, -0.0 included).
#[cfg(target_arch = "x86_64")]
mod w4 {
    use super::{Folds, KickInput, NodalSums, StepFolds};
    use std::arch::x86_64::*;

    /// [`super::inverse_mass`] of four masses `m`, given `im` = 1 / m: zero where m is not
    /// positive (a node all of whose elements became particles).
    #[inline(always)]
    fn inverse_masses(m: __m256d, im: __m256d) -> __m256d {
        // SAFETY: AVX, as every caller's target feature.
        unsafe { _mm256_and_pd(im, _mm256_cmp_pd::<_CMP_GT_OQ>(m, _mm256_setzero_pd())) }
    }

    /// Four per-node values spread to the slots of the three registers (slot 4 j + t holds
    /// node (4 j + t) / 3's): `vpermpd` with the nodes 0001, 1122 and 2333.
    #[inline(always)]
    fn spread(a: __m256d) -> [__m256d; 3] {
        // SAFETY: AVX2, as every caller's target feature.
        unsafe {
            [
                _mm256_permute4x64_pd::<0b01_00_00_00>(a),
                _mm256_permute4x64_pd::<0b10_10_01_01>(a),
                _mm256_permute4x64_pd::<0b11_11_11_10>(a),
            ]
        }
    }

    /// All ones in lane k where `b[k]` (four values).
    #[inline(always)]
    fn node_mask(b: &[bool]) -> __m256d {
        let lane = |x: bool| -(x as i64);
        // SAFETY: AVX, as every caller's target feature.
        unsafe {
            _mm256_castsi256_pd(_mm256_setr_epi64x(
                lane(b[0]),
                lane(b[1]),
                lane(b[2]),
                lane(b[3]),
            ))
        }
    }

    /// The gravity of each slot of register j (slot 4 j + t is component (4 j + t) % 3).
    #[inline(always)]
    fn gravity_slots(g: [f64; 3]) -> [__m256d; 3] {
        std::array::from_fn(|j| {
            let s: [f64; 4] = std::array::from_fn(|t| g[(4 * j + t) % 3]);
            // SAFETY: four doubles (AVX: every caller is built with it).
            unsafe { _mm256_loadu_pd(s.as_ptr()) }
        })
    }

    /// The slot masks of the free nodes and of the counted ones (owned and free) of the chunk
    /// at `n0`, per register.
    #[inline(always)]
    fn chunk_masks(owned: &[bool], constrained: &[bool], n0: usize) -> [[__m256d; 3]; 2] {
        let (con, own) = (node_mask(&constrained[n0..]), node_mask(&owned[n0..]));
        // SAFETY: AVX, as every caller's target feature.
        let (free, counted) = unsafe {
            let ones = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
            (_mm256_xor_pd(con, ones), _mm256_andnot_pd(con, own))
        };
        [spread(free), spread(counted)]
    }

    /// A grid's shifts in every lane.
    #[inline(always)]
    fn shifts(g: &crate::exact::Grid) -> [__m256d; 3] {
        // SAFETY: AVX (every caller is built with it).
        g.shift.map(|c| unsafe { _mm256_set1_pd(c) })
    }

    /// [`crate::exact::Grid::add`] lane by lane, in the lanes of mask `k`: the term is zeroed
    /// outside them (one `and` in place of a blend per fold), and a zero term's parts are +0,
    /// which leaves a fold's bits as they were (a fold is never -0: it starts at +0, and a sum
    /// that returns to zero rounds to +0), so the folds are those of the eight-node form's
    /// masked additions.
    #[inline(always)]
    fn bin(acc: &mut [__m256d; 3], x: __m256d, c: &[__m256d; 3], k: __m256d) {
        // SAFETY: AVX (every caller is built with it).
        unsafe {
            let x = _mm256_and_pd(x, k);
            let t1 = _mm256_sub_pd(_mm256_add_pd(x, c[0]), c[0]);
            let r1 = _mm256_sub_pd(x, t1);
            let t2 = _mm256_sub_pd(_mm256_add_pd(r1, c[1]), c[1]);
            let r2 = _mm256_sub_pd(r1, t2);
            let t3 = _mm256_sub_pd(_mm256_add_pd(r2, c[2]), c[2]);
            for (a, t) in acc.iter_mut().zip([t1, t2, t3]) {
                *a = _mm256_add_pd(*a, t);
            }
        }
    }

    /// The four lanes' sum (each fold's lanes are exact multiples of its quantum: added in
    /// any order).
    #[inline(always)]
    fn lanes(a: __m256d) -> [f64; 4] {
        let mut l = [0.0; 4];
        // SAFETY: four doubles (AVX: every caller is built with it).
        unsafe { _mm256_storeu_pd(l.as_mut_ptr(), a) };
        l
    }

    /// [`super::kick_drift`] on the whole chunks; returns the nodes done and their work sum.
    ///
    /// # Safety
    /// The CPU must have AVX2; the slices must have one value per node.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn kick_drift(
        v: &mut [[f64; 3]],
        force: &mut [[f64; 3]],
        zero: bool,
        input: &KickInput,
        x: &mut [[f64; 3]],
        x_old: Option<&mut [[f64; 3]]>,
        dt: f64,
    ) -> (usize, Folds) {
        let whole = v.len() / 4 * 4;
        let gp = gravity_slots(input.gravity);
        let (h, dtv, one) = (
            _mm256_set1_pd(0.5 * dt),
            _mm256_set1_pd(dt),
            _mm256_set1_pd(1.0),
        );
        let grid = shifts(&input.energy);
        let mut work = [_mm256_setzero_pd(); 3];
        let (pv, pf) = (v.as_mut_ptr() as *mut f64, force.as_mut_ptr() as *mut f64);
        let px = x.as_mut_ptr() as *mut f64;
        let po = x_old.map(|o| o.as_mut_ptr() as *mut f64);
        let pm = input.mass.as_ptr();
        for n0 in (0..whole).step_by(4) {
            // SAFETY: n0 + 4 <= len masses.
            let m = unsafe { _mm256_loadu_pd(pm.add(n0)) };
            let im = spread(inverse_masses(m, _mm256_div_pd(one, m)));
            let [_, counted] = chunk_masks(input.owned, input.constrained, n0);
            for j in 0..3 {
                let s = 3 * n0 + 4 * j;
                // SAFETY: s + 4 <= 3 (n0 + 4) <= 3 len doubles in each array.
                unsafe {
                    let f = _mm256_loadu_pd(pf.add(s));
                    if zero {
                        _mm256_storeu_pd(pf.add(s), _mm256_setzero_pd());
                    }
                    let an = _mm256_add_pd(_mm256_mul_pd(f, im[j]), gp[j]);
                    let vn = _mm256_add_pd(_mm256_loadu_pd(pv.add(s)), _mm256_mul_pd(h, an));
                    _mm256_storeu_pd(pv.add(s), vn);
                    let xs = _mm256_loadu_pd(px.add(s));
                    if let Some(po) = po {
                        _mm256_storeu_pd(po.add(s), xs);
                    }
                    let dx = _mm256_mul_pd(dtv, vn);
                    _mm256_storeu_pd(px.add(s), _mm256_add_pd(xs, dx));
                    bin(&mut work, _mm256_mul_pd(f, dx), &grid, counted[j]);
                }
            }
        }
        (whole, work.map(|w| lanes(w).iter().sum()))
    }

    /// [`super::close_free`] on the whole chunks; returns the nodes done.
    ///
    /// # Safety
    /// The CPU must have AVX2; every slice must have one value per node.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn close_free(
        r: &NodalSums,
        constrained: &[bool],
        v: &mut [[f64; 3]],
        sums: &mut StepFolds,
    ) -> usize {
        let nn = v.len();
        let whole = nn / 4 * 4;
        let (gp, gw) = (gravity_slots(r.gravity), gravity_slots(r.gravity_work));
        let (h, dt, one) = (
            _mm256_set1_pd(0.5 * r.dt),
            _mm256_set1_pd(r.dt),
            _mm256_set1_pd(1.0),
        );
        let zero = _mm256_setzero_pd();
        let (ge, gm) = (shifts(&r.grids.energy), shifts(&r.grids.momentum));
        // The folds of m v^2, f dx and m g dx over every slot, and of m v per register (its
        // slots' components), over the counted nodes.
        let (mut ke, mut we, mut wx) = ([zero; 3], [zero; 3], [zero; 3]);
        let mut mo = [[zero; 3]; 3];
        let pf = r.force.as_ptr() as *const f64;
        let pv = v.as_mut_ptr() as *mut f64;
        for n0 in (0..whole).step_by(4) {
            // SAFETY: n0 + 4 <= nn masses.
            let m = unsafe { _mm256_loadu_pd(r.mass.as_ptr().add(n0)) };
            let im = spread(inverse_masses(m, _mm256_div_pd(one, m)));
            let ms = spread(m);
            let [free, counted] = chunk_masks(r.owned, constrained, n0);
            for j in 0..3 {
                let (kf, kc) = (free[j], counted[j]);
                let s = 3 * n0 + 4 * j;
                // SAFETY: s + 4 <= 3 (n0 + 4) <= 3 nn doubles in each array.
                unsafe {
                    let f = _mm256_loadu_pd(pf.add(s));
                    let an = _mm256_add_pd(_mm256_mul_pd(f, im[j]), gp[j]);
                    let half = _mm256_loadu_pd(pv.add(s));
                    let kicked = _mm256_add_pd(half, _mm256_mul_pd(h, an));
                    let vn = _mm256_blendv_pd(half, kicked, kf);
                    _mm256_storeu_pd(pv.add(s), vn);
                    let dx = _mm256_mul_pd(dt, half);
                    bin(
                        &mut ke,
                        _mm256_mul_pd(ms[j], _mm256_mul_pd(vn, vn)),
                        &ge,
                        kc,
                    );
                    bin(&mut we, _mm256_mul_pd(f, dx), &ge, kc);
                    let mg = _mm256_add_pd(zero, _mm256_mul_pd(ms[j], gw[j]));
                    bin(&mut wx, _mm256_mul_pd(mg, dx), &ge, kc);
                    bin(&mut mo[j], _mm256_mul_pd(ms[j], vn), &gm, kc);
                }
            }
        }
        for (k, acc) in [ke, we, wx].iter().enumerate() {
            for f in 0..3 {
                sums[k][f] += lanes(acc[f]).iter().sum::<f64>();
            }
        }
        for (j, reg) in mo.iter().enumerate() {
            for (f, fold) in reg.iter().enumerate() {
                for (t, x) in lanes(*fold).iter().enumerate() {
                    sums[3 + (4 * j + t) % 3][f] += x;
                }
            }
        }
        whole
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small xorshift generator for test data.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        }
    }

    fn field(rng: &mut Rng, n: usize, scale: f64) -> Vec<[f64; 3]> {
        (0..n)
            .map(|_| [scale * rng.next(), scale * rng.next(), scale * rng.next()])
            .collect()
    }

    /// The eight- and four-node passes (those this CPU runs) against the node-by-node ones
    /// (the reference: the loops of the explicit step as they were written node by node), on
    /// 101 nodes (whole chunks and a tail) with random fields, a quarter of the nodes
    /// constrained and a third not owned: velocities, positions and the sums bit for bit (the
    /// sums' terms are added in another order, on the exact grids); the sums against plain
    /// sums of the same terms to 1e-13 of their scale.
    #[test]
    fn several_nodes_at_a_time_give_the_node_by_node_results() {
        let forms: Vec<Nodes> = crate::batch::available()
            .into_iter()
            .map(Nodes::of)
            .filter(|&f| f != Nodes::One)
            .collect();
        if forms.is_empty() {
            println!("neither AVX2 nor AVX-512F on this CPU: only the node-by-node form runs here");
        }
        let n = 101;
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        let (v0, x0) = (field(&mut rng, n, 30.0), field(&mut rng, n, 1.0));
        let (f0, f) = (field(&mut rng, n, 1e4), field(&mut rng, n, 1e4));
        let mass: Vec<f64> = (0..n).map(|_| 1.0 + rng.next()).collect();
        let owned: Vec<bool> = (0..n).map(|i| i % 3 != 1).collect();
        let constrained: Vec<bool> = (0..n).map(|i| i % 4 == 2).collect();
        let (dt, g) = (1e-7, [0.0, -9.81, 0.0]);
        // The gravity whose work the sums count (a load curve's mean over the step), unlike
        // the kick's `g`, so that the two are not confused.
        let gw = g.map(|x| 0.75 * x);
        let grids = SumGrids::for_mass(mass.iter().sum());
        let input = KickInput {
            energy: grids.energy,
            mass: &mass,
            gravity: g,
            owned: &owned,
            constrained: &constrained,
        };
        let run = |wide: Nodes| {
            let (mut v, mut x, mut x_old) = (v0.clone(), x0.clone(), vec![[0.0; 3]; n]);
            let mut fk = f0.clone();
            let work = kick_drift(
                &mut v,
                &mut fk,
                false,
                &input,
                &mut x,
                Some(&mut x_old),
                dt,
                wide,
            );
            assert_eq!(fk, f0, "the forces kept");
            // Without start positions, the forces zeroed: the same velocities and positions.
            let (mut v2, mut x2) = (v0.clone(), x0.clone());
            kick_drift(&mut v2, &mut fk, true, &input, &mut x2, None, dt, wide);
            assert_eq!(
                (&v2, &x2),
                (&v, &x),
                "the same drift without start positions"
            );
            assert!(fk.iter().flatten().all(|&c| c == 0.0), "the forces zeroed");
            let read = NodalSums {
                dt,
                force: &f,
                mass: &mass,
                owned: &owned,
                gravity: g,
                gravity_work: gw,
                grids,
            };
            let mut sums = [[0.0; 3]; 6];
            let half = v.clone();
            close_free(&read, &constrained, &mut v, &mut sums, wide);
            (v, x, x_old, sums, work, half)
        };
        let narrow = run(Nodes::One);
        for form in forms {
            let wide = run(form);
            assert_eq!(narrow.0, wide.0, "velocities, {form:?}");
            assert_eq!(narrow.1, wide.1, "positions, {form:?}");
            assert_eq!(narrow.2, wide.2, "start positions, {form:?}");
            assert_eq!(narrow.3, wide.3, "the step's sums, fold by fold, {form:?}");
            assert_eq!(narrow.4, wide.4, "the kick's work, fold by fold, {form:?}");
        }
        // The sums against plain sums of the terms (the reference: the formulas written out).
        let (v, v_half) = (&narrow.0, &narrow.5);
        let counted = |i: usize| owned[i] && !constrained[i];
        let mut plain = [0.0f64; 6];
        let mut scale = [0.0f64; 6];
        for i in (0..n).filter(|&i| counted(i)) {
            for c in 0..3 {
                let dx = dt * v_half[i][c];
                let t = [
                    mass[i] * v[i][c] * v[i][c],
                    f[i][c] * dx,
                    mass[i] * gw[c] * dx,
                ];
                for k in 0..3 {
                    plain[k] += t[k];
                    scale[k] += t[k].abs();
                }
                plain[3 + c] += mass[i] * v[i][c];
                scale[3 + c] += (mass[i] * v[i][c]).abs();
            }
        }
        for k in 0..6 {
            let (p, q) = (plain[k], crate::exact::value(&narrow.3[k]));
            assert!(
                (p - q).abs() <= 1e-13 * scale[k],
                "sum {k}: plain {p:e}, on the grids {q:e} (tolerance 1e-13 of {:e})",
                scale[k]
            );
        }
    }
}
