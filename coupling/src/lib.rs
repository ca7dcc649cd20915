//! Everything parallel that is not PETSc, in folders named after the paper's parts (Plimpton et
//! al., "Transient dynamics simulations: parallel algorithms for contact detection and smoothed
//! particle hydrodynamics"):
//!
//! - [`kernels`]: the two kernels of §3: the unstructured-communication plan (Fig. 5), the
//!   collectives every failure agrees through, recursive coordinate bisection (Figs. 6, 7);
//! - [`stages`]: the three stages of one time step (Fig. 3), each on its own decomposition: `fe`
//!   (static, PETSc), `sph` (dynamic RCB, Fig. 8), `contact` (dynamic RCB, Fig. 10);
//! - [`transfer`]: moving records between the decompositions;
//! - [`driver`]: the run, its step (Fig. 3, one named and timed stage per line), probes;
//! - [`input`], [`output`]: the scene, gmsh and LIGGGHTS files; history, fields, report.
//!
//! The CLI and the analysis tools (`tdyn compare`, `sweep`, `validate`, ...) live in the `tdyn`
//! crate; the MPI self-tests of the kernels and the output are the `tdyn_selftest` binary of the
//! `tdyn-tests` package.
#![warn(missing_docs)]
// Index loops over nodes and components read like the formulas they implement; `!(x > 0.0)`
// deliberately also rejects NaN.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

pub mod driver;
pub mod input;
pub mod kernels;
pub mod output;
pub mod stages;
pub mod transfer;
