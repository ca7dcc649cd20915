//! The momentum and energy pass with the full stress tensor, and Monaghan's artificial stress.
use super::build::Build;
use super::quadratic::quad_basis;
use super::tensor::{
    from_voigt, mul, mul_lanes, symmetric_eigen, symmetric_eigen_lanes, to_voigt, transpose, Mat3,
    Mat3Lanes,
};
use super::PairGeom;
use super::Solids;
use crate::exact::{note, q, PassGrids, TermMax};
use crate::kernel::SmoothingKernel;
use crate::params::{ArtificialViscosity, Params};
use crate::particles::{PairSums, Particles};
use crate::passes::{add4, lane_shifts, PairWork, Sums as Sums4};

/// Monaghan's artificial stress against the tensile instability of solids (Gray, Monaghan &
/// Swift, CMAME 190 (2001) 6641, §3; Monaghan, J. Comput. Phys. 159 (2000) 290).
///
/// Per particle, in the principal frame of sigma_a (sigma_a = Q diag(s_1, s_2, s_3) Q^T):
///
/// ```text
/// R'_kk = -epsilon s_k / rho_a^2   if s_k > 0 (tension), else 0     (Gray et al. 2001, eq. 25)
/// R_a   = Q diag(R'_11, R'_22, R'_33) Q^T                            Pa m^6/kg^2 = m^5/(kg s^2)
/// ```
///
/// and per pair the term (R_a + R_b) f_ab^n added to the stress terms, with
/// f_ab = W(r_ab, h) / W(delta_ab, h) (dimensionless, 1 at the pair's initial spacing, so the
/// correction acts where particles close up beyond the lattice: a repulsion that stops the
/// clumping of particles in tension). A fluid's stress is -p I: its R is epsilon p/rho^2 I
/// where p < 0 (Monaghan 2000's correction without the compression term).
///
/// delta_ab = (delta_a + delta_b) / 2, each particle's own initial spacing
/// delta_a = (m_a / rho0_a)^(1/3), m (rho0 its material's density: a solid's
/// [`crate::StressModel::reference_density`], a fluid's EOS rho0; the current density where
/// there is none): a lattice particle's `spacing`, a failed element's particle the size of its
/// share of the element. One delta_p for every particle (the first entry's spacing) made
/// particles of another spacing unstable: a 1 mm block against a 2 mm one, delta_p = 2 mm,
/// has f = W(1 mm)/W(2 mm) = 8 between neighbours at rest, f^4 = 4,000 (the run stopped at
/// step 119 with a kinetic energy of 2.5e10 J from 2.3e-3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArtificialStress {
    /// epsilon (Gray et al. 2001 use 0.3).
    pub epsilon: f64,
    /// Exponent n of f_ab^n (Gray et al. 2001: n = 4).
    pub n: i32,
}

/// Gray et al. (2001)'s epsilon of the artificial stress.
pub const ARTIFICIAL_STRESS_EPSILON: f64 = 0.3;
/// Gray et al. (2001)'s exponent n of the artificial stress.
pub const ARTIFICIAL_STRESS_EXPONENT: i32 = 4;

impl Default for ArtificialStress {
    fn default() -> Self {
        Self::new()
    }
}

impl ArtificialStress {
    /// epsilon = 0.3, n = 4 (Gray et al. 2001).
    pub fn new() -> Self {
        Self {
            epsilon: ARTIFICIAL_STRESS_EPSILON,
            n: ARTIFICIAL_STRESS_EXPONENT,
        }
    }

    /// R_a of a particle with stress `sigma` (Voigt, Pa) and density `rho` (kg/m^3). Zero,
    /// without the eigen-decomposition, where Gershgorin's discs show every principal stress
    /// <= 0 (each diagonal entry plus its row's off-diagonal magnitudes <= 0: compression).
    /// The force pass takes the same values, bit for bit, `EIGEN_LANES` particles at a time
    /// ([`ArtificialStress::tensors`]).
    pub fn tensor(&self, sigma: &[f64; 6], rho: f64) -> Mat3 {
        let a = from_voigt(sigma);
        if !may_have_tension(&a) {
            return [[0.0; 3]; 3];
        }
        let (lam, q) = symmetric_eigen(&a);
        let scale = -self.epsilon / (rho * rho);
        let d: Mat3 = std::array::from_fn(|k| {
            std::array::from_fn(|l| if k == l { scale * lam[k].max(0.0) } else { 0.0 })
        });
        mul(&mul(&q, &d), &transpose(&q))
    }

    /// R of every entry whose stress (Voigt, Pa) and density (kg/m^3) `of` gives, for entries
    /// `0..n`: [`ArtificialStress::tensor`] of each (the same bits), the decompositions of
    /// those that may have a tensile principal stress done `EIGEN_LANES` at a time
    /// ([`symmetric_eigen_lanes`], in `build`).
    pub fn tensors(
        &self,
        n: usize,
        of: impl Fn(usize) -> ([f64; 6], f64),
        build: Build,
    ) -> Vec<Mat3> {
        let mut out = Vec::new();
        self.tensors_into(n, of, build, &mut out);
        out
    }

    /// [`ArtificialStress::tensors`] into `out` (its memory reused).
    pub fn tensors_into(
        &self,
        n: usize,
        of: impl Fn(usize) -> ([f64; 6], f64),
        build: Build,
        out: &mut Vec<Mat3>,
    ) {
        out.clear();
        out.resize(n, [[0.0; 3]; 3]);
        let mut batch: Vec<(usize, Mat3, f64)> = Vec::with_capacity(EIGEN_LANES);
        let flush = |batch: &mut Vec<(usize, Mat3, f64)>, out: &mut [Mat3]| {
            // lanes past the batch's entries hold zero matrices (converged at once)
            let mut a = [[[0.0; EIGEN_LANES]; 3]; 3];
            let mut rho = [1.0; EIGEN_LANES];
            for (l, (_, m, r)) in batch.iter().enumerate() {
                for k in 0..3 {
                    for c in 0..3 {
                        a[k][c][l] = m[k][c];
                    }
                }
                rho[l] = *r;
            }
            let rt = tensor_lanes_built(build, &a, &rho, self.epsilon);
            for (l, (i, _, _)) in batch.iter().enumerate() {
                out[*i] = std::array::from_fn(|k| std::array::from_fn(|c| rt[k][c][l]));
            }
            batch.clear();
        };
        for i in 0..n {
            let (sigma, rho) = of(i);
            let a = from_voigt(&sigma);
            if may_have_tension(&a) {
                batch.push((i, a, rho));
                if batch.len() == EIGEN_LANES {
                    flush(&mut batch, out);
                }
            }
        }
        if !batch.is_empty() {
            flush(&mut batch, out);
        }
    }
}

/// Matrices decomposed together by [`ArtificialStress::tensors`]: two AVX-512 registers per
/// quantity, so that two chains of divisions and square roots overlap.
const EIGEN_LANES: usize = 16;

/// Whether Gershgorin's discs of the symmetric `a` reach above zero (some diagonal entry plus
/// its row's off-diagonal magnitudes > 0): else every eigenvalue is <= 0.
#[inline]
fn may_have_tension(a: &Mat3) -> bool {
    (0..3).any(|k| {
        let off: f64 = (0..3).filter(|&l| l != k).map(|l| a[k][l].abs()).sum();
        a[k][k] + off > 0.0
    })
}

/// R = Q diag(scale max(lambda_k, 0)) Q^T, scale = -epsilon/rho^2, of `EIGEN_LANES` stresses
/// at once, as [`ArtificialStress::tensor`] computes each (the same operations lane by lane).
#[inline(always)]
fn tensor_lanes(
    a: &Mat3Lanes<EIGEN_LANES>,
    rho: &[f64; EIGEN_LANES],
    epsilon: f64,
) -> Mat3Lanes<EIGEN_LANES> {
    let (lam, q) = symmetric_eigen_lanes(a);
    let d: Mat3Lanes<EIGEN_LANES> = std::array::from_fn(|k| {
        std::array::from_fn(|c| {
            std::array::from_fn(|l| {
                let scale = -epsilon / (rho[l] * rho[l]);
                if k == c {
                    scale * lam[k][l].max(0.0)
                } else {
                    0.0
                }
            })
        })
    });
    let qt: Mat3Lanes<EIGEN_LANES> = std::array::from_fn(|k| std::array::from_fn(|c| q[c][k]));
    mul_lanes(&mul_lanes(&q, &d), &qt)
}

super::build::builds!(
    /// [`tensor_lanes`] in the build of the pass.
    tensor_lanes_built,
    tensor_lanes,
    (
        a: &Mat3Lanes<EIGEN_LANES>,
        rho: &[f64; EIGEN_LANES],
        epsilon: f64
    ) -> Mat3Lanes<EIGEN_LANES>
);

/// The stress of entry `i` as a matrix: a solid's sigma, a fluid's -p I, Pa.
fn stress_of(p: &Particles, s: &Solids, i: usize) -> Mat3 {
    if s.is_solid(p.mat[i]) {
        from_voigt(&s.stress[i])
    } else {
        let q = -p.p[i];
        [[q, 0.0, 0.0], [0.0, q, 0.0], [0.0, 0.0, q]]
    }
}

/// What the Monaghan (1992) artificial viscosity of a chunk's pairs needs, lane by lane (one
/// lane per pair): h = (h_a + h_b)/2, v^_ab . x_ab, r^2, the mean sound speed and density.
struct ViscLanes {
    h: [f64; PAIR_CHUNK],
    vr: [f64; PAIR_CHUNK],
    r2: [f64; PAIR_CHUNK],
    c_mean: [f64; PAIR_CHUNK],
    rho_mean: [f64; PAIR_CHUNK],
}

impl Default for ViscLanes {
    fn default() -> Self {
        let z = [0.0; PAIR_CHUNK];
        ViscLanes {
            h: z,
            vr: z,
            r2: z,
            c_mean: z,
            rho_mean: z,
        }
    }
}

impl ViscLanes {
    /// The Monaghan (1992) artificial viscosity Pi_ab, m^5/(kg s^2), of the first `n` lanes into
    /// `pi`, as the fluid pass has it (`passes::pair_viscosity`, `params::ArtificialViscosity`):
    /// mu = h min(vr, 0)/(r^2 + eta^2), Pi = (-alpha c_mean mu + beta mu^2)/rho_mean (0 without
    /// viscosity). Each lane's operations are one pair's, in that order; the loop over the
    /// lanes is what the wider builds do several at a time (its two divisions in vector
    /// registers).
    #[inline(always)]
    fn viscosity(&self, av: Option<ArtificialViscosity>, n: usize, pi: &mut [f64; PAIR_CHUNK]) {
        let Some(av) = av else {
            pi.iter_mut().for_each(|x| *x = 0.0);
            return;
        };
        for (p, pi) in pi.iter_mut().enumerate().take(n) {
            let h = self.h[p];
            let mu = h * self.vr[p].min(0.0) / (self.r2[p] + av.eta_factor * h * h);
            *pi = (-av.alpha * self.c_mean[p] * mu + av.beta * mu * mu) / self.rho_mean[p];
        }
    }
}

/// Force pass with the stress tensor, over every pair (solids and fluids: a fluid's stress is
/// -p I and its B = I). With g = grad_a W_ab = (dW/dr / r)(x_a - x_b), 1/m^4, B_a the
/// kernel-gradient correction (`Solids::correction`, Randles & Libersky 1996) and
///
/// ```text
/// T_ab g = (S_ab B_a + S_ba B_b) g + (R_a + R_b) f_ab^n g - Pi_ab g
/// S_ab   = sigma_a / (rho_a rho_b)   a solid        (V_a V_b sigma_a / (m_a m_b))
///        = sigma_a / rho_a^2         a fluid        (Monaghan 1992)
/// f_a  += m_a m_b T_ab g,   f_b -= the same                   N    (Gray et al. 2001, eq. 10,
///                                                                   with Bonet & Lok, CMAME 180
///                                                                   (1999) 97, eq. 50's B g)
/// de_a += -1/2 m_b v^_ab . (T_ab g),  de_b += -1/2 m_a (same)  W/kg
/// ```
///
/// (T in m^5/(kg s^2)). Why a solid's term has V_a V_b: its velocity gradient is
/// L_a = sum_b V_b (v_b - v_a) (x) B_a g with the partners' volumes V_b = m_b/rho_b
/// ([`super::velocity_gradient_pass`]), so its stress power is
/// V_a sigma_a : L_a = sum_b V_a V_b sigma_a : ((v_b - v_a) (x) B_a g), and the forces that take
/// exactly that power from the kinetic energy are +-V_a V_b sigma_a B_a g (sigma symmetric).
/// Gray et al.'s sigma_a/rho_a^2 is the same where rho_b = rho_a; across a density jump (two
/// materials in contact) it is not the transpose of the gradient, by the factor rho_b/rho_a,
/// and the pair's energy is not conserved: an aluminium block (2,700 kg/m^3) pushed at 1 m/s
/// against a copper one (8,960) went unstable, its kinetic energy 13,600 times its start in
/// 20 us. A fluid's pressure term stays Monaghan's, the transpose of its continuity equation
/// (the density rate with m_b). Where either end has the surface's quadratic fit
/// ([`super::quadratic`]) T g gains (Q_ab - Q_ba) |gr| q(d), Q_ab = sigma_a C_quad,a /
/// (rho_a rho_b) and q(d) the quadratic basis (even in d): the rest of each end's pair
/// weight, so the forces stay the transpose of the fitted gradient. The pair term is the same tensor applied to g for a and to -g for b,
/// so the forces are equal and opposite (momentum conserved) whatever B. B makes a linear
/// stress field's divergence exact at the free surface too; without it (B = I, Gray et al.'s
/// form) a surface particle's truncated kernel carries only part of its stress, and a bent
/// plate is as stiff as one (n_y - 1) particle spacings thick rather than n_y. For a fluid pair
/// T g = -(p_a/rho_a^2 + p_b/rho_b^2 + Pi) g: the fluid pass's Monaghan (1992) eqs. 3.3-3.4.
/// The two halves of -m_a m_b v^_ab . (T g) given to a and b are what the forces take from the
/// kinetic energy (d/dt sum 1/2 m v^2 = sum_pairs m_a m_b v^_ab . T g at v = v^), so kinetic +
/// sum m e is conserved as in the fluid pass. Sets the force and energy-rate sums and the
/// partner counts of every entry (`Particles::sums`: exact, on `g`'s force and energy grids,
/// largest terms into `m`; a pair listed as (b, a) gives each entry the same bits, as T g
/// changes sign with g) and the owned entries' `f` and `de` from them (the caller merges the
/// ghosts' sums into their owners and settles again). Returns the work rate: `pressure` from
/// the stress and artificial stress, `viscosity` from Pi.
///
/// `pairs` must be those of the last [`super::velocity_gradient_pass`] on `s`, at the same
/// positions: r and dW/dr / r are read from `Solids::pair_geom` (its pairs checked against
/// `pairs`), not computed again. Flops per pair ~110 (geometry 8, viscosity 12 with two
/// divisions, (S_a + S_b) g 24, artificial stress 40 where either end is in tension, force and
/// energy 20), and 2 x 4 lanes x 6 for the exact sums (the fluid pass's `add4`); bytes: 2 x 240
/// of packed inputs read, 2 x 64 of sums read and written, 24 of geometry read. The pairs go
/// in chunks of `PAIR_CHUNK`, in three short loops: the viscosity and f_ab^n (the divisions),
/// then the terms (no sum between pairs: they overlap), then the exact sums in the pairs'
/// order; each pair's operations are the same. The artificial stress R of every entry first
/// ([`ArtificialStress::tensors`], 16 eigen-decompositions at a time).
pub fn stress_force_pass(
    pairs: &[(u32, u32)],
    p: &mut Particles,
    s: &mut Solids,
    params: &Params,
    art: Option<&ArtificialStress>,
    grids: &PassGrids,
    m: &mut TermMax,
) -> PairWork {
    let n = p.len();
    let k = params.smoothing_kernel();
    assert_eq!(
        s.pair_geom.len(),
        pairs.len(),
        "the force pass runs over the pairs of the last gradient pass"
    );
    // the buffers of the last evaluation, refilled (put back at the end)
    let mut b = std::mem::take(&mut s.buffers);
    let geom = &s.pair_geom[..];
    let rts = &mut b.art;
    match art {
        Some(a) => a.tensors_into(
            n,
            |i| (to_voigt(&stress_of(p, s, i)), p.rho[i]),
            s.build,
            rts,
        ),
        None => {
            rts.clear();
            rts.resize(n, [[0.0; 3]; 3]);
        }
    }
    let slots = &mut b.force_slots;
    slots.clear();
    // (m / rho0)^(1/3) is mostly the same from entry to entry (one mass, one material): the
    // cube root is taken again only where its argument's bits change
    let mut dp = (f64::NAN, f64::NAN);
    slots.extend((0..n).map(|i| Slot::of(p, s, params, &rts[i], i, &mut dp)));
    // force x, y, z and energy rate of each entry, fold by fold, and its partners
    let sums = &mut b.force_sums;
    sums.clear();
    sums.resize(n, Sums4::default());
    let partners = &mut b.partners;
    partners.clear();
    partners.resize(n, 0);
    let shifts = lane_shifts(grids);
    let consts = PassConsts {
        kernel: k,
        viscosity: params.viscosity,
        art: art.copied(),
        shifts,
    };
    let work = force_pairs_built(s.build, pairs, geom, slots, sums, partners, &consts, m);
    p.sums.resize(n, PairSums::default());
    for ((e, su), &np) in p.sums.iter_mut().zip(&*sums).zip(&*partners) {
        let part = |l: usize| [su.fold[0][l], su.fold[1][l]];
        e.f = [part(0), part(1), part(2)];
        e.de = part(3);
        e.partners = np as f64;
    }
    p.settle_forces();
    s.buffers = b;
    work
}

/// Pairs whose viscosity and artificial-stress factors the force pass computes before their
/// terms (4 kB, in L1).
const PAIR_CHUNK: usize = 256;

/// What the pair loop of the force pass needs besides the pairs and the entries.
struct PassConsts {
    kernel: SmoothingKernel,
    viscosity: Option<ArtificialViscosity>,
    art: Option<ArtificialStress>,
    shifts: [[f64; 4]; 2],
}

super::build::builds!(
    /// [`force_pairs`] in the build of the pass.
    force_pairs_built,
    force_pairs,
    (
        pairs: &[(u32, u32)],
        geom: &[PairGeom],
        slots: &[Slot],
        sums: &mut [Sums4],
        partners: &mut [u32],
        c: &PassConsts,
        m: &mut TermMax
    ) -> PairWork
);

/// The pair loop of [`stress_force_pass`] (inlined into each build, [`super::build`]): adds
/// every pair's force and energy-rate terms to `sums`, counts `partners`, notes the largest
/// terms in `m`; returns the work rate.
#[inline(always)]
fn force_pairs(
    pairs: &[(u32, u32)],
    geom: &[PairGeom],
    slots: &[Slot],
    sums: &mut [Sums4],
    partners: &mut [u32],
    c: &PassConsts,
    m: &mut TermMax,
) -> PairWork {
    let (k, art, shifts) = (&c.kernel, c.art.as_ref(), &c.shifts);
    // the kernel at the pair's h and 1/W(delta_ab, h) (0 without artificial stress or with
    // delta_ab beyond the support), remade where h or delta_ab changes (mostly the same from
    // pair to pair)
    let at = |h: f64, dp: f64| {
        let sk = k.at(h);
        let inv_w_dp = match art {
            Some(_) if sk.w(dp) > 0.0 => 1.0 / sk.w(dp),
            _ => 0.0,
        };
        (sk, inv_w_dp, dp)
    };
    let mut kern = at(f64::NAN, f64::NAN);
    // the largest size of the pairs' terms, lane by lane (force x, y, z, the lane past them,
    // energy rates of a and b), noted in `m` at the end (the same maxima as noting term by
    // term: a maximum does not depend on the order)
    let mut noted = [0.0f64; 6];
    let mut work = PairWork::default();
    // per pair of a chunk: what Pi needs, Pi, and f_ab^n where the artificial stress acts on
    // the pair
    let mut vl = ViscLanes::default();
    let mut visc = [0.0; PAIR_CHUNK];
    let mut fns = [0.0; PAIR_CHUNK];
    let mut acts = [false; PAIR_CHUNK];
    // per pair of a chunk: the terms of its two entries (force x, y, z and energy rate)
    let mut terms = [[[0.0; 4]; 2]; PAIR_CHUNK];
    for (chunk, geom) in pairs.chunks(PAIR_CHUNK).zip(geom.chunks(PAIR_CHUNK)) {
        // the chunk's viscosity and artificial-stress factors first: what the viscosity needs
        // gathered pair by pair, then Pi lane by lane (its divisions, a chain in each pair, in
        // vector registers)
        let factors = fns.iter_mut().zip(acts.iter_mut());
        for (p, ((&(i, j), pg), (out, acts))) in chunk.iter().zip(geom).zip(factors).enumerate() {
            assert!(
                (pg.i, pg.j) == (i, j),
                "the force pass runs over the pairs of the last gradient pass"
            );
            let (a, b) = (&slots[i as usize], &slots[j as usize]);
            let d: [f64; 3] = std::array::from_fn(|l| a.x[l] - b.x[l]);
            let h = 0.5 * (a.h + b.h);
            let dv: [f64; 3] = std::array::from_fn(|l| a.vhat[l] - b.vhat[l]);
            vl.r2[p] = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            vl.h[p] = h;
            vl.vr[p] = dv[0] * d[0] + dv[1] * d[1] + dv[2] * d[2];
            vl.c_mean[p] = 0.5 * (a.c + b.c);
            vl.rho_mean[p] = 0.5 * (a.rho + b.rho);
            *acts = false;
            if let (Some(an), true) = (art, a.tension || b.tension) {
                let dp = 0.5 * (a.dp + b.dp);
                if kern.0.h != h || kern.2 != dp {
                    kern = at(h, dp);
                }
                if kern.1 > 0.0 {
                    *out = powi(kern.0.w(pg.r) * kern.1, an.n);
                    *acts = true;
                }
            }
        }
        vl.viscosity(c.viscosity, chunk.len(), &mut visc);
        // then the chunk's terms, each pair apart (no sum in between: pairs overlap) ...
        let pair_factors = geom.iter().zip(visc.iter().zip(&fns)).zip(&acts);
        for (((pg, (&pi, &fn_ab)), &acts), out) in pair_factors.zip(terms.iter_mut()) {
            if pg.r == 0.0 {
                continue;
            }
            let (a, b) = (&slots[pg.i as usize], &slots[pg.j as usize]);
            let (t, de) = pair_terms(a, b, pg.gr, pi, acts.then_some(fn_ab), &mut work);
            // the largest terms, lane by lane: force x, y, z (|-t| = |t|) and the lane past
            // them, which is +-0 or NaN (`pair_terms`) and so never raises a maximum (a NaN
            // is passed over, as `note` does); the energy rates
            for (mx, x) in noted.iter_mut().zip(t.iter().chain(&de)) {
                let x = x.abs();
                *mx = if x > *mx { x } else { *mx };
            }
            // equal and opposite forces: b's terms are the negated ones, each split on its own
            *out = [[t[0], t[1], t[2], de[0]], [-t[0], -t[1], -t[2], de[1]]];
        }
        // ... and last their exact sums, in the order of the pairs
        for (pg, out) in geom.iter().zip(&terms) {
            let (i, j) = (pg.i as usize, pg.j as usize);
            partners[i] += 1;
            partners[j] += 1;
            if pg.r == 0.0 {
                continue;
            }
            add4(&mut sums[i].fold, out[0], shifts);
            add4(&mut sums[j].fold, out[1], shifts);
        }
    }
    for (l, &x) in noted.iter().enumerate() {
        note(&mut m[if l < 4 { q::FORCE } else { q::ENERGY }], x);
    }
    work
}

/// The terms of one pair (a, b) with r > 0, `gr` = dW/dr / r, Pi `pi` and f_ab^n where the
/// artificial stress acts: a's force (b's is its negation), and a's and b's energy rates; the
/// pair's work rate added to `work`. The 3-vectors are 4 lanes (rows x, y, z and one past
/// them), so that each of their operations is one in vector registers: every lane's the
/// scalar form's, in its order. The lane past them starts from the slots' zeros (positions,
/// matrix columns): every operation on it is a product with such a zero, or a sum or
/// difference of those, so it is +-0 or NaN (a factor infinite or NaN) in the force too. The
/// caller notes it with the force (that it is used keeps the vectors four lanes wide).
#[inline(always)]
fn pair_terms(
    a: &Slot,
    b: &Slot,
    gr: f64,
    pi: f64,
    fn_ab: Option<f64>,
    work: &mut PairWork,
) -> (V4, [f64; 2]) {
    let d: V4 = v4(|l| a.x[l] - b.x[l]);
    let g: V4 = v4(|l| gr * d[l]);
    let dv: V4 = v4(|l| a.vhat[l] - b.vhat[l]);
    let vr = dv[0] * d[0] + dv[1] * d[1] + dv[2] * d[2];
    // T g without the viscous part: (S_a + S_b) g, plus (R_a + R_b) f_ab^n g where
    // either particle has a tensile principal stress (f_ab^n = (W(r)/W(delta_p))^n;
    // none where delta_p is beyond the support, 1/W(delta_p) = 0)
    // (a solid end's sigma B / rho times the other end's 1 / rho: V_a V_b / (m_a m_b))
    let (ka, kb) = (a.partner_scale(b), b.partner_scale(a));
    let mut tg = mat_vec_sum(&a.sr, ka, &b.sr, kb, &g);
    // the quadratic fit's part of the pair weights (surface particles,
    // `super::quadratic`): (Q_ab - Q_ba) |gr| q(d), q even in d
    if a.quad || b.quad {
        let qd = quad_basis(&[d[0], d[1], d[2]]);
        let mut x = [0.0; 4];
        for (m, &qm) in qd.iter().enumerate() {
            x = v4(|l| x[l] + (a.q[m][l] * ka - b.q[m][l] * kb) * qm);
        }
        tg = v4(|l| tg[l] + -gr * x[l]);
    }
    if let Some(fn_ab) = fn_ab {
        let rg = mat_vec_sum(&a.rt, 1.0, &b.rt, 1.0, &g);
        tg = v4(|l| tg[l] + fn_ab * rg[l]);
    }
    let mm = a.m * b.m;
    // the viscous part -Pi I g, kept apart for the work split
    let full: V4 = v4(|l| tg[l] - pi * g[l]);
    let e = dv[0] * full[0] + dv[1] * full[1] + dv[2] * full[2];
    let (de_i, de_j) = (-0.5 * b.m * e, -0.5 * a.m * e);
    work.pressure -= mm * (dv[0] * tg[0] + dv[1] * tg[1] + dv[2] * tg[2]);
    work.viscosity += mm * pi * gr * vr;
    (v4(|l| mm * full[l]), [de_i, de_j])
}

/// A 3-vector in four lanes (the last unused), or a column of a 3 x 3 matrix.
type V4 = [f64; 4];

/// The lanes `f(0..4)`.
#[inline(always)]
fn v4(f: impl Fn(usize) -> f64) -> V4 {
    std::array::from_fn(f)
}

/// x^n by binary powering, the operations of `f64::powi`'s runtime routine (compiler-builtins'
/// `__powidf2`: r = 1, r *= x for each set bit of |n| from the lowest, x squared between;
/// 1/r for n < 0), inlined: the same bits. n = 4 (the default) is written out, x^4 =
/// 1 (x^2)^2 = (x^2)^2, with no loop over the bits of n per pair.
#[inline(always)]
fn powi(x: f64, n: i32) -> f64 {
    if n == 4 {
        let x2 = x * x;
        return x2 * x2;
    }
    let (mut a, mut e) = (x, n.unsigned_abs());
    let mut r = 1.0;
    loop {
        if e & 1 != 0 {
            r *= a;
        }
        e >>= 1;
        if e == 0 {
            break;
        }
        a *= a;
    }
    if n < 0 {
        1.0 / r
    } else {
        r
    }
}

/// (ka A + kb B) g for two matrices stored column by column (`a[c][r]`, lane 3 unused), summed
/// entry by entry first (a factor 1 leaves its matrix's bits): row r is
/// (t_0r g_0 + t_1r g_1) + t_2r g_2, t_cr = a_cr ka + b_cr kb, the rows lane by lane.
#[inline(always)]
fn mat_vec_sum(a: &[V4; 3], ka: f64, b: &[V4; 3], kb: f64, g: &V4) -> V4 {
    let t = |c: usize| v4(|r| a[c][r] * ka + b[c][r] * kb);
    let (t0, t1, t2) = (t(0), t(1), t(2));
    v4(|r| t0[r] * g[0] + t1[r] * g[1] + t2[r] * g[2])
}

/// What the force pass reads of one entry, packed: position, h, predicted velocity, mass,
/// density and its reciprocal, sound speed, its stress term (a solid's sigma B / rho, a
/// fluid's sigma / rho^2) and the artificial stress R, both column by column in four lanes
/// (`sr[c][r]`: row r of column c, lane 3 zero), and whether R is not zero.
pub(super) struct Slot {
    x: V4,
    vhat: V4,
    h: f64,
    m: f64,
    rho: f64,
    /// 1 / rho.
    inv_rho: f64,
    c: f64,
    /// The initial spacing (m / rho0)^(1/3), m (the artificial stress's delta).
    dp: f64,
    sr: [V4; 3],
    rt: [V4; 3],
    tension: bool,
    /// Whether the entry is a solid (its terms are divided by the partner's density).
    solid: bool,
    /// sigma C_quad / rho (3 x 6, `q[m][k]` row k, column m, lane 3 zero; zero off the
    /// surface and for fluids).
    q: [V4; 6],
    /// Whether `q` is not zero.
    quad: bool,
}

impl Slot {
    /// Entry `i`: sigma_a B_a / rho_a for a solid, -p_a / rho_a^2 I for a fluid, and R_a
    /// (`rt`). `dp`: the last (m / rho0, its cube root), updated where m / rho0 differs.
    fn of(
        p: &Particles,
        s: &Solids,
        params: &Params,
        rt: &Mat3,
        i: usize,
        dp: &mut (f64, f64),
    ) -> Slot {
        let t = stress_of(p, s, i);
        let solid = s.is_solid(p.mat[i]);
        let mat = p.mat[i] as usize;
        let rho0 = match s.models.get(mat) {
            Some(Some(model)) => model.reference_density(),
            _ => params.eos.get(mat).and_then(|e| e.reference_density()),
        }
        .unwrap_or(p.rho[i]);
        let vol0 = p.m[i] / rho0;
        if vol0.to_bits() != dp.0.to_bits() {
            *dp = (vol0, libm::cbrt(vol0));
        }
        let inv_rho = 1.0 / p.rho[i];
        // (a fluid's 1/rho^2 as it always was: the fluid pass's bits)
        let inv_rho2 = if solid {
            inv_rho
        } else {
            1.0 / (p.rho[i] * p.rho[i])
        };
        let sb = mul(&t, &s.correction[i]);
        let cq = &s.quad[i];
        let lanes = |f: &dyn Fn(usize) -> f64| v4(|k| if k < 3 { f(k) } else { 0.0 });
        Slot {
            x: lanes(&|k| p.x[i][k]),
            vhat: lanes(&|k| p.vhat[i][k]),
            h: p.h[i],
            m: p.m[i],
            rho: p.rho[i],
            inv_rho,
            c: p.c[i],
            dp: dp.1,
            sr: std::array::from_fn(|c| lanes(&|r| sb[r][c] * inv_rho2)),
            rt: std::array::from_fn(|c| lanes(&|r| rt[r][c])),
            tension: rt.iter().flatten().any(|&x| x != 0.0),
            solid,
            q: std::array::from_fn(|m| {
                lanes(&|k| {
                    (t[k][0] * cq[m] + t[k][1] * cq[6 + m] + t[k][2] * cq[12 + m]) * inv_rho2
                })
            }),
            quad: s.quad[i].iter().any(|&x| x != 0.0),
        }
    }

    /// The factor of this entry's stress terms in a pair with `other`: 1 / rho_other for a
    /// solid (with its sigma B / rho, V_a V_b / (m_a m_b)), 1 for a fluid.
    #[inline(always)]
    fn partner_scale(&self, other: &Slot) -> f64 {
        if self.solid {
            other.inv_rho
        } else {
            1.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A xorshift stream of numbers in [-1, 1).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        }
    }

    /// Stresses of every kind: random, near-degenerate, diagonal (zero pivots), compressive,
    /// zero, and of very different sizes.
    fn stresses(n: usize) -> Vec<([f64; 6], f64)> {
        let mut g = Rng(0x9e37_79b9_7f4a_7c15);
        (0..n)
            .map(|k| {
                let scale = [1.0, 1e6, 3e-4, 7.5e9][k % 4];
                let mut s: [f64; 6] = std::array::from_fn(|_| scale * g.next());
                match k % 7 {
                    1 => s[3..].iter_mut().for_each(|x| *x = 0.0),
                    2 => s = [s[0], s[0], s[0] + 1e-12 * scale, 1e-13 * scale, 0.0, 0.0],
                    3 => s = [-scale, -2.0 * scale, -0.5 * scale, 0.1 * scale, 0.0, 0.0],
                    4 => s = [0.0; 6],
                    _ => {}
                }
                (s, 1000.0 + 500.0 * g.next())
            })
            .collect()
    }

    #[test]
    fn tensors_in_lanes_are_the_bits_of_tensor_in_every_build() {
        let art = ArtificialStress::new();
        // 2 x 16 lanes and a partial batch
        let sts = stresses(16 * 2 + 5 + 40);
        let want: Vec<Mat3> = sts.iter().map(|(s, r)| art.tensor(s, *r)).collect();
        assert!(want.iter().any(|m| m.iter().flatten().any(|&x| x != 0.0)));
        for build in Build::available() {
            let got = art.tensors(sts.len(), |i| sts[i], build);
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                for k in 0..3 {
                    for c in 0..3 {
                        assert_eq!(
                            g[k][c].to_bits(),
                            w[k][c].to_bits(),
                            "{build:?}: entry {i} R[{k}][{c}]"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn powi_is_the_bits_of_f64_powi() {
        let mut g = Rng(7);
        for _ in 0..1000 {
            let x = 3.0 * g.next();
            for n in [-3, -1, 0, 1, 2, 3, 4, 5, 8, 13] {
                assert_eq!(powi(x, n).to_bits(), x.powi(n).to_bits(), "{x}^{n}");
            }
        }
    }
}
