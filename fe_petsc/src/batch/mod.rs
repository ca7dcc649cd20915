//! The element kernel: the hexahedron of [`crate::hex`] on a group of consecutive elements of
//! one material at once, one element per f64 lane, the same operations in every lane and the
//! branches as masked lane operations. Each lane computes what [`crate::hex::update`] computes
//! for its element, the geometry in mode space (`modes.rs`: the volume, its gradient and the
//! nodal forces through the Walsh-Hadamard transform of the nodal values) and the rest in the
//! node-by-node kernel's order. Every material runs here: elastic and J2 in lanes (`law.rs`),
//! the other models' own scalar functions called lane by lane (`pointwise.rs`). Every width
//! runs the same IEEE operations in the same order (no fused multiply-adds: `F::mul_add`
//! rounds twice; IEEE division and square root), so one, four and eight lanes (`--kernel
//! scalar|lanes4|lanes8`) give the same bits. The node-by-node [`crate::hex::update`] forms
//! the geometry otherwise and agrees to round-off; it is the reference the tests hold every
//! width to (`tests/lanes.rs`, 1e-12 relative), and no run calls it.
//!
//! The kernel is written once (`hex.rs`, `hourglass.rs`, `law.rs`, `modes.rs`, `pointwise.rs`
//! in this folder, on a lane type `F`, its mask `M` and the group size `LANES` taken from the
//! parent module) and compiled once per width:
//! - [`w1`]: one lane (`fixed.rs`), one element at a time;
//! - [`w4`]: four lanes, on x86-64 in one AVX2 register (`lanes4.rs`, intrinsics), used when the
//!   CPU has AVX2 (an x86-64 CPU without it runs one lane); elsewhere on fixed-size arrays the
//!   compiler vectorises (`fixed.rs`, the same text as one lane);
//! - [`w8`] (x86-64): eight lanes in one AVX-512 register (`lanes8.rs`, intrinsics), used when
//!   the CPU has AVX-512F. Eight lanes halve the instructions per element, the 32 vector
//!   registers of AVX-512 spill less than AVX2's 16.
//!
//! In the kernel, no `std::array::from_fn` or other library generic taking a closure: those
//! are not inlined into the target-feature builds, and each lane operation inside them becomes
//! a call.
//!
//! The native tetrahedron's second pass ([`crate::tet::update`]) has its kernel here too
//! (`tet.rs`, in the same frame: every width the same bits, the lane laws and `pointwise.rs`
//! for the material); [`TetBatch`] is what its loop and tests see of it.
//!
//! [`widest`] picks the width for this CPU; [`Batch`] is what the element loops and the tests
//! see of any.
// The kernel's files are compiled once per width on purpose (each width its own lane type):
// clippy's duplicate-module lint is for files loaded twice by mistake.
#![allow(clippy::duplicate_mod)]
use crate::hex::{HexControls, HexOutput, HexState, NODES};
use crate::hourglass::{self, Hourglass};
use crate::material::{LaneLaw, Material, MAX_STATE};
use crate::tet::{TetAverages, TetOutput, TetRates};

/// A group of elements in lanes, as the explicit element loop uses it: load the group's
/// elements, update them, read each lane's state and output back.
pub trait Batch: Default {
    /// Elements per group.
    const LANES: usize;

    /// Loads the first `LANES` elements of `conn` (their nodal coordinates from `xs`, velocities
    /// from `vs`, reference volumes, states and history values `history(l)`, the model's
    /// `n_state` first, the rest unused) into the lanes.
    fn load(
        &mut self,
        xs: &[[f64; 3]],
        vs: &[[f64; 3]],
        conn: &[[u32; NODES]],
        vol0: &[f64],
        state: &[HexState],
        history: impl Fn(usize) -> [f64; MAX_STATE],
    );

    /// One explicit update over the step `dt` of the loaded elements of the material `model`
    /// (`m` its lane form, [`LaneMaterial::new`]): in each lane what [`crate::hex::update`]
    /// computes for its element. `Err`, with the state untouched, when a lane's volume (end of
    /// step or mid-step) is not positive and finite.
    fn update(
        &mut self,
        dt: f64,
        m: &LaneMaterial,
        model: &dyn Material,
        ctl: &HexControls,
    ) -> Result<(), GroupInverted>;

    /// Lane `l`'s element state and history values after the update.
    fn lane_state(&self, l: usize) -> (HexState, [f64; MAX_STATE]);

    /// Lane `l`'s output of the update.
    fn lane_output(&self, l: usize) -> HexOutput;

    /// Loads, updates and stores a whole group whose state lies in lanes (the elements
    /// `e0..e0 + LANES` of a [`crate::states::HexStates`], `e0` a multiple of `LANES`): what
    /// [`Batch::load`], [`Batch::update`] and storing each [`Batch::lane_state`] do, with the
    /// state moved as whole vectors. `Err`, with `io.state` and `io.history` untouched, as
    /// [`Batch::update`]. The outputs are read as after [`Batch::update`]. For a material with
    /// its own lane law (not [`LaneLaw::Pointwise`]: a pointwise model's history values are
    /// not consecutive lanes; [`Batch::load`] and [`Batch::update`] take those).
    fn update_lanes(
        &mut self,
        io: &mut GroupLanes<'_>,
        dt: f64,
        m: &LaneMaterial,
        ctl: &HexControls,
    ) -> Result<(), GroupInverted>;

    /// The force of lane `l`'s element on its node `k` from the last update, N.
    fn force(&self, l: usize, k: usize) -> [f64; 3];

    /// The last update's hourglass work, volume, stable step and pressure of each lane, in
    /// lane order (`LANES` values each).
    fn scalars(&self) -> [&[f64]; 4];
}

/// A group of native tetrahedra in lanes ([`crate::tet`]'s second pass), as the tetrahedra's
/// loop uses it: load each lane's element, update the group, read each lane's state and output
/// back. A group of fewer than `LANES` elements fills its other lanes with copies of its first
/// (their results dropped: lanes are independent).
pub trait TetBatch: Default {
    /// Elements per group.
    const LANES: usize;

    /// Loads one tetrahedron's inputs and state into lane `l`.
    fn load(&mut self, l: usize, input: &TetInput<'_>);

    /// Loads one tetrahedron's nodal coordinates `x` (t(n+1)) and velocities `v` (t(n+1/2))
    /// into lane `l`, for [`TetBatch::rates`].
    fn load_nodes(&mut self, l: usize, x: &[[f64; 3]; 4], v: &[[f64; 3]; 4]);

    /// The first pass over the step `dt` of the loaded tetrahedra: in each lane what
    /// [`crate::tet::rates`] computes, the same bits, without its check of the volumes
    /// ([`TetBatch::lane_rates`] are what it checks).
    fn rates(&mut self, dt: f64);

    /// Lane `l`'s result of [`TetBatch::rates`].
    fn lane_rates(&self, l: usize) -> TetRates;

    /// One explicit update over the step `dt` of the loaded tetrahedra of the material `model`
    /// (`m` its lane form): in each lane what [`crate::tet::update`] computes for its element
    /// (to round-off; the same bits in every width). `Err`, with the state untouched, when a
    /// lane's volume (end of step or mid-step) is not positive and finite.
    fn update(
        &mut self,
        dt: f64,
        m: &LaneMaterial,
        model: &dyn Material,
        ctl: &HexControls,
    ) -> Result<(), GroupInverted>;

    /// Lane `l`'s stress and history values after the update (the model's `n_state` first).
    fn lane_state(&self, l: usize) -> ([f64; 6], [f64; MAX_STATE]);

    /// Lane `l`'s output of the update.
    fn lane_output(&self, l: usize) -> TetOutput;
}

/// One tetrahedron's inputs to [`TetBatch::load`].
#[derive(Clone, Copy, Debug)]
pub struct TetInput<'a> {
    /// Nodal coordinates at t(n+1), m.
    pub x: &'a [[f64; 3]; 4],
    /// Nodal velocities at t(n+1/2), m/s.
    pub v: &'a [[f64; 3]; 4],
    /// Reference volume, m^3.
    pub vol0: f64,
    /// The means of its nodes' ratios.
    pub avg: TetAverages,
    /// Its stress (Voigt), Pa.
    pub stress: &'a [f64; 6],
    /// Its history values (the model's `n_state`, at most [`MAX_STATE`]).
    pub history: &'a [f64],
}

/// A whole group's inputs and state in the element arrays, for [`Batch::update_lanes`].
pub struct GroupLanes<'a> {
    /// Nodal coordinates at t(n+1), m.
    pub xs: &'a [[f64; 3]],
    /// Nodal velocities at t(n+1/2), m/s.
    pub vs: &'a [[f64; 3]],
    /// The group's elements' nodes (`LANES` elements).
    pub conn: &'a [[u32; NODES]],
    /// Their reference volumes, m^3 (`LANES` values).
    pub vol0: &'a [f64],
    /// Their state: [`crate::states::HexStates::lanes_mut`] at the group's first element.
    pub state: &'a mut [f64],
    /// Their history values (`LANES`, consecutive), `None` for a material without one.
    pub history: Option<&'a mut [f64]>,
    /// The nodal forces (one per point of `xs`) to which the update adds its elements' forces,
    /// element by element in lane order, corner by corner (as adding each
    /// [`Batch::lane_output`]'s forces would); `None` to leave them to the caller.
    pub force: Option<&'a mut [[f64; 3]]>,
}

/// The group sizes of the element kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Width {
    /// One element at a time ([`w1`]).
    W1,
    /// Four lanes ([`w4`]).
    W4,
    /// Eight lanes in AVX-512 registers ([`w8`]).
    #[cfg(target_arch = "x86_64")]
    W8,
}

/// The widest group this CPU runs: on x86-64 eight lanes with AVX-512F, four with AVX2, one
/// otherwise; four elsewhere.
pub fn widest() -> Width {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            return Width::W8;
        }
        if !std::arch::is_x86_feature_detected!("avx2") {
            return Width::W1;
        }
    }
    Width::W4
}

/// The widths this CPU can run, narrowest first (the tests compare each with the node-by-node
/// kernel).
pub fn available() -> Vec<Width> {
    match widest() {
        Width::W1 => vec![Width::W1],
        Width::W4 => vec![Width::W1, Width::W4],
        #[cfg(target_arch = "x86_64")]
        Width::W8 => vec![Width::W1, Width::W4, Width::W8],
    }
}

/// A material the batched kernel can update, with the constants the scalar kernel asks the
/// material for at each element (the same values: the same calls).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaneMaterial {
    pub(crate) law: LaneLaw,
    pub(crate) rho0: f64,
    pub(crate) dilatational: f64,
    pub(crate) mu: f64,
    pub(crate) nu: f64,
    pub(crate) hourglass: LaneHourglassKind,
}

/// The hourglass control of a material in the batched kernel ([`Hourglass::for_material`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum LaneHourglassKind {
    /// The physical kind, its stiffness multiplied by `scale`.
    Physical {
        /// Multiplier of the physical stiffness.
        scale: f64,
        /// How the yield stress bounds the amplitudes.
        bound: hourglass::YieldBound,
    },
    /// The FB/PRONTO stiffness form with coefficient kappa.
    Stiffness {
        /// kappa.
        coefficient: f64,
    },
    /// The FB viscous form with coefficient kappa (and fluids under the physical kind).
    Viscous {
        /// kappa.
        coefficient: f64,
    },
}

impl LaneMaterial {
    /// The lane form of `mat` under the controls `ctl`: the model's own lane law, or
    /// [`LaneLaw::Pointwise`] for a model without one.
    pub fn new(mat: &dyn Material, ctl: &HexControls) -> LaneMaterial {
        let n_state = mat.n_state();
        assert!(
            n_state <= MAX_STATE,
            "a material keeps at most {MAX_STATE} history values per element, not {n_state}"
        );
        let law = mat.lane_law().unwrap_or(LaneLaw::Pointwise { n_state });
        let mu = mat.shear_modulus();
        let hourglass = match ctl.hourglass.for_material(mu) {
            Hourglass::Physical { scale, bound } => LaneHourglassKind::Physical { scale, bound },
            Hourglass::Stiffness { coefficient } => LaneHourglassKind::Stiffness { coefficient },
            Hourglass::Viscous { coefficient } => LaneHourglassKind::Viscous { coefficient },
        };
        LaneMaterial {
            law,
            rho0: mat.density(),
            dilatational: mat.dilatational_modulus(),
            mu,
            nu: hourglass::poisson_ratio(mat.dilatational_modulus(), mu),
            hourglass,
        }
    }

    /// History variables per element of the material.
    pub fn n_state(&self) -> usize {
        self.law.n_state()
    }

    /// Whether the kernel calls the model's scalar functions lane by lane
    /// ([`LaneLaw::Pointwise`]).
    pub fn pointwise(&self) -> bool {
        self.law.is_pointwise()
    }
}

/// A group with an element whose volume (end of step or mid-step) is not positive and finite:
/// the first such lane and that volume (the end-of-step one when it is the bad one), m^3.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroupInverted {
    /// The lane of the first inverted element.
    pub lane: usize,
    /// Its volume, m^3.
    pub volume: f64,
}

/// The multiply-adds of a lane type `$F`, each rounded twice (`a * b` rounded, then the add):
/// every width's, so that the kernel's `mul_add`s give the same bits at every width (no fused
/// instruction; "One answer"). Expanded inside each lane type's `impl` (`fixed.rs`,
/// `vector_ops.rs`).
macro_rules! twice_rounded_ops {
    ($F:ident) => {
        /// `self * b + c`, rounded twice.
        #[inline(always)]
        pub fn mul_add(self, b: $F, c: $F) -> $F {
            self * b + c
        }

        /// `self * b - c`, rounded twice.
        #[inline(always)]
        pub fn mul_sub(self, b: $F, c: $F) -> $F {
            self * b - c
        }

        /// `c - self * b`, rounded twice.
        #[inline(always)]
        pub fn neg_mul_add(self, b: $F, c: $F) -> $F {
            c - self * b
        }
    };
}

pub mod arrays;
mod fixed;
#[cfg(target_arch = "x86_64")]
#[macro_use]
mod vector_ops;
#[cfg(target_arch = "x86_64")]
mod lanes4;
#[cfg(target_arch = "x86_64")]
mod lanes8;
use fixed::lanes1;
#[cfg(not(target_arch = "x86_64"))]
use fixed::lanes4;

/// Makes the calling kernel entry keep its stack frame aligned to 64 bytes, so that its spills
/// of 512-bit registers (several hundred per group) never straddle two cache lines.
///
/// Why: LLVM spills vector registers with unaligned moves into a frame aligned only to the
/// ABI's 16 bytes unless something in the frame asks for more; a 64-byte spill then straddles
/// two cache lines three times in four, and such split accesses halve the load and store
/// throughput (measured on this machine: 1.7 against 0.8 aligned and misaligned 512-bit loads
/// per cycle, 0.86 against 0.39 stores). Which case a build got depended on its callers'
/// frames. A 64-byte-aligned local that may be written through an escaping reference
/// (`black_box`; a read-only one becomes a constant) makes LLVM realign
/// the frame (`and rsp, -64` in the prologue), and the spill slots with it.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn aligned_frame() {
    #[repr(align(64))]
    struct Line(#[allow(dead_code)] [u8; 64]);
    let mut line = Line([0; 64]);
    std::hint::black_box(&mut line);
}

/// The most lanes of any width (a group's elements fit a stack array of this length).
pub const MAX_LANES: usize = 8;

/// The kernel's files, declared in each width's module (which names the lane types `F`, `M`
/// and `LANES` they are compiled on).
macro_rules! kernel_files {
    () => {
        #[path = "hex.rs"]
        pub mod hex;
        #[path = "hourglass.rs"]
        mod hourglass;
        #[path = "law.rs"]
        mod law;
        #[path = "modes.rs"]
        mod modes;
        #[path = "pointwise.rs"]
        mod pointwise;
        #[path = "tet.rs"]
        pub mod tet;
        pub use hex::LaneGroup;
        pub use tet::TetGroup;
    };
}

/// The entries of a width's kernel that [`Batch`] and [`TetBatch`] call (`entry`,
/// `entry_lanes`, `tet_rates_entry`, `tet_entry`), each its kernel function built by `$build`:
/// [`plain`] (one lane: the baseline build; four lanes off x86-64), `avx2_only` (four lanes) or
/// [`avx512_only`] (eight lanes).
macro_rules! entries {
    ($build:ident) => {
        $build!(
            /// [`super::Batch::update`].
            entry,
            update_built,
            hex::update_inline,
            (g: &mut LaneGroup, dt: f64, m: &LaneMaterial, model: &dyn Material, ctl: &HexControls)
                -> Result<(), GroupInverted>
        );
        $build!(
            /// [`super::Batch::update_lanes`].
            entry_lanes,
            update_lanes_built,
            hex::update_lanes_inline,
            (g: &mut LaneGroup, io: &mut super::GroupLanes<'_>, dt: f64, m: &LaneMaterial, ctl: &HexControls)
                -> Result<(), GroupInverted>
        );
        $build!(
            /// [`super::TetBatch::rates`].
            tet_rates_entry,
            tet_rates_built,
            tet::rates_inline,
            (g: &mut TetGroup, dt: f64) -> ()
        );
        $build!(
            /// [`super::TetBatch::update`].
            tet_entry,
            tet_built,
            tet::update_inline,
            (g: &mut TetGroup, dt: f64, m: &LaneMaterial, model: &dyn Material, ctl: &HexControls)
                -> Result<(), GroupInverted>
        );
    };
}

/// An entry that calls its kernel function as the module's target builds it.
macro_rules! plain {
    ($(#[$doc:meta])* $name:ident, $built:ident, $inner:path, ($($a:ident: $t:ty),*) -> $r:ty) => {
        $(#[$doc])*
        #[inline]
        fn $name($($a: $t),*) -> $r {
            $inner($($a),*)
        }
    };
}

/// An entry that calls the AVX2 build of its kernel function; panics on a CPU without AVX2
/// (the loops take four lanes on x86-64 only where [`available`] lists them).
#[cfg(target_arch = "x86_64")]
macro_rules! avx2_only {
    ($(#[$doc:meta])* $name:ident, $built:ident, $inner:path, ($($a:ident: $t:ty),*) -> $r:ty) => {
        $(#[$doc])*
        #[inline]
        fn $name($($a: $t),*) -> $r {
            assert!(
                std::arch::is_x86_feature_detected!("avx2"),
                "the four-lane element kernel needs AVX2, which this CPU lacks"
            );
            // SAFETY: the CPU has AVX2, checked just above.
            unsafe { $built($($a),*) }
        }

        /// The kernel function compiled for AVX2: every lane operation one instruction on a
        /// 256-bit register (`lanes4`), inlined here, in a frame aligned for its spills
        /// ([`super::aligned_frame`]). The same IEEE operations in the same order (no FMA), so
        /// the same bits as every width.
        #[target_feature(enable = "avx2")]
        fn $built($($a: $t),*) -> $r {
            super::aligned_frame();
            $inner($($a),*)
        }
    };
}

/// An entry that calls the AVX-512F build of its kernel function; panics on a CPU without
/// AVX-512F (the loops take eight lanes only where [`widest`] found it).
macro_rules! avx512_only {
    ($(#[$doc:meta])* $name:ident, $built:ident, $inner:path, ($($a:ident: $t:ty),*) -> $r:ty) => {
        $(#[$doc])*
        #[inline]
        fn $name($($a: $t),*) -> $r {
            assert!(
                std::arch::is_x86_feature_detected!("avx512f"),
                "the eight-lane element kernel needs AVX-512F, which this CPU lacks"
            );
            // SAFETY: the CPU has AVX-512F, checked just above.
            unsafe { $built($($a),*) }
        }

        /// The kernel function compiled for AVX-512F: every lane operation one instruction on
        /// a 512-bit register (`lanes8`), inlined here, in a frame aligned for its spills
        /// ([`super::aligned_frame`]).
        #[target_feature(enable = "avx512f")]
        fn $built($($a: $t),*) -> $r {
            super::aligned_frame();
            $inner($($a),*)
        }
    };
}

/// The kernel on one lane (`fixed.rs`): one element at a time, for the baseline x86-64 (no
/// vector instructions to gain from).
#[path = "."]
pub mod w1 {
    pub use super::lanes1::{F1 as F, LANES, M1 as M};
    use super::{GroupInverted, LaneMaterial};
    use crate::hex::HexControls;
    use crate::material::Material;

    kernel_files!();

    entries!(plain);
}

/// The kernel on four lanes: in AVX2 registers on x86-64 (`lanes4.rs`; its update needs AVX2,
/// [`available`] says whether this CPU has it), on fixed-size arrays the compiler vectorises
/// elsewhere (`fixed.rs`).
#[path = "."]
pub mod w4 {
    #[cfg(target_arch = "x86_64")]
    pub use super::lanes4::LANES;
    #[cfg(not(target_arch = "x86_64"))]
    pub use super::lanes4::{F4 as F, LANES, M4 as M};
    #[cfg(target_arch = "x86_64")]
    pub(crate) use super::lanes4::{F4 as F, M4 as M};
    use super::{GroupInverted, LaneMaterial};
    use crate::hex::HexControls;
    use crate::material::Material;

    kernel_files!();

    #[cfg(target_arch = "x86_64")]
    entries!(avx2_only);
    #[cfg(not(target_arch = "x86_64"))]
    entries!(plain);
}

/// The kernel on four lanes of fixed-size arrays (`fixed.rs`), what a CPU other than x86-64
/// runs as [`w4`]: built on x86-64 for the tests only (`tests::four_lanes_on_arrays_...`).
#[cfg(all(test, target_arch = "x86_64"))]
#[path = "."]
pub mod w4_arrays {
    pub use super::fixed::lanes4::{F4 as F, LANES, M4 as M};
    use super::{GroupInverted, LaneMaterial};
    use crate::hex::HexControls;
    use crate::material::Material;

    kernel_files!();

    entries!(plain);
}

/// The kernel on eight lanes in AVX-512 registers (`lanes8.rs`); its update needs AVX-512F
/// ([`widest`] says whether this CPU has it).
#[cfg(target_arch = "x86_64")]
#[path = "."]
pub mod w8 {
    pub use super::lanes8::LANES;
    pub(crate) use super::lanes8::{F8 as F, M8 as M};
    use super::{GroupInverted, LaneMaterial};
    use crate::hex::HexControls;
    use crate::material::Material;

    kernel_files!();

    entries!(avx512_only);
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use crate::hex::HexState;
    use crate::material::{build_material, MaterialSpec};

    /// The four-lane kernel on fixed-size arrays (what aarch64 and every CPU other than x86-64
    /// run) against the AVX2 four lanes, and each against one lane: groups of distorted,
    /// compressed and sheared elements of a J2 steel through 20 steps (into plastic flow), the
    /// stresses, history, forces and scalars bit for bit (the rule of docs/running.md, "One
    /// answer": every width the same IEEE operations in the same order).
    #[test]
    fn four_lanes_on_arrays_give_the_avx2_and_one_lane_bits() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            println!("no AVX2 on this CPU: the four lanes in registers do not run here");
            return;
        }
        let spec = MaterialSpec {
            name: "steel".into(),
            model: "j2_plastic".into(),
            density: 7850.0,
            params: [
                ("youngs_modulus", 200e9),
                ("poisson_ratio", 0.3),
                ("yield_stress", 350e6),
                ("hardening_modulus", 1e9),
            ]
            .iter()
            .map(|(k, v)| (k.to_string(), *v))
            .collect(),
            eos: None,
        };
        let mat = build_material(&spec).unwrap();
        let ctl = HexControls::default();
        let lm = LaneMaterial::new(&*mat, &ctl);
        // Four unit-cube elements side by side along x (h = 1 cm), corners moved off the grid
        // and given varied velocities: a compression along x with shear.
        let h = 0.01;
        let mut xs = Vec::new();
        for k in 0..2 {
            for j in 0..2 {
                for i in 0..5 {
                    let p = xs.len() as f64;
                    xs.push([
                        h * i as f64 + 1e-4 * (p * 0.37).sin(),
                        h * j as f64 + 1e-4 * (p * 0.71).cos(),
                        h * k as f64 + 1e-4 * (p * 1.13).sin(),
                    ]);
                }
            }
        }
        let vs: Vec<[f64; 3]> = xs
            .iter()
            .enumerate()
            .map(|(n, p)| {
                let r = (n as f64 * 0.91).sin();
                [-3e4 * p[0] + 5.0 * r, 1e4 * p[2] - 3.0 * r, 2e3 * p[1] + r]
            })
            .collect();
        let node = |i: usize, j: usize, k: usize| (i + 5 * (j + 2 * k)) as u32;
        let conn: Vec<[u32; 8]> = (0..4)
            .map(|e| {
                crate::hex::NODE_XI.map(|xi| {
                    let b = xi.map(|c| usize::from(c > 0.0));
                    node(e + b[0], b[1], b[2])
                })
            })
            .collect();
        let vol0: Vec<f64> = conn
            .iter()
            .map(|c| crate::hex::volume(&c.map(|n| xs[n as usize])))
            .collect();
        // Each width's run: every lane's state, history and output after each step, as text
        // (Debug of an f64 is its shortest round trip: other bits, other text).
        fn run<B: Batch>(
            xs: &[[f64; 3]],
            vs: &[[f64; 3]],
            conn: &[[u32; 8]],
            vol0: &[f64],
            lm: &LaneMaterial,
            mat: &dyn Material,
            ctl: &HexControls,
        ) -> (Vec<String>, Vec<[f64; MAX_STATE]>) {
            let mut xs = xs.to_vec();
            let mut states = vec![HexState::default(); 4];
            let mut hist = vec![[0.0; MAX_STATE]; 4];
            let mut out = Vec::new();
            let dt = 2e-7;
            for _ in 0..20 {
                for (p, v) in xs.iter_mut().zip(vs) {
                    for c in 0..3 {
                        p[c] += dt * v[c];
                    }
                }
                for g in (0..4).step_by(B::LANES) {
                    let e = g..g + B::LANES;
                    let mut group = B::default();
                    let hs = &hist[e.clone()];
                    group.load(
                        &xs,
                        vs,
                        &conn[e.clone()],
                        &vol0[e.clone()],
                        &states[e.clone()],
                        |l| hs[l],
                    );
                    group.update(dt, lm, mat, ctl).unwrap();
                    for l in 0..B::LANES {
                        let (s, hl) = group.lane_state(l);
                        states[g + l] = s;
                        hist[g + l] = hl;
                        out.push(format!("{:?} {:?} {:?}", s, hl, group.lane_output(l)));
                    }
                }
            }
            (out, hist)
        }
        let (avx2, plastic) = run::<w4::LaneGroup>(&xs, &vs, &conn, &vol0, &lm, &*mat, &ctl);
        let (arrays, _) = run::<w4_arrays::LaneGroup>(&xs, &vs, &conn, &vol0, &lm, &*mat, &ctl);
        let (one, _) = run::<w1::LaneGroup>(&xs, &vs, &conn, &vol0, &lm, &*mat, &ctl);
        // The J2 law's first history value is the equivalent plastic strain: the steps reach
        // the plastic branch (about 0.12 strain at 3e4 1/s over 4 us; yield at 1.75e-3).
        assert!(
            plastic.iter().all(|h| h[0] > 1e-3),
            "every element flowed: {:?}",
            plastic.iter().map(|h| h[0]).collect::<Vec<_>>()
        );
        for (k, ((a, b), c)) in avx2.iter().zip(&arrays).zip(&one).enumerate() {
            assert_eq!(
                a,
                b,
                "step {} element {}: AVX2 lanes against arrays",
                k / 4,
                k % 4
            );
            assert_eq!(
                a,
                c,
                "step {} element {}: AVX2 lanes against one lane",
                k / 4,
                k % 4
            );
        }
    }
}
