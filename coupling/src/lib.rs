//! Everything parallel that is not PETSc: scene loading, meshing, the timestep driver, output.
#![warn(missing_docs)]
// Index loops over nodes and components read like the formulas they implement; `!(x > 0.0)`
// deliberately also rejects NaN.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

pub mod chart;
pub mod collective;
pub mod comm;
pub mod compare;
pub mod contact_baseline;
pub mod contact_selftest;
pub mod contact_stage;
pub mod crosscheck;
pub mod driver;
pub mod fe_contact;
pub mod fe_setup;
pub mod gmsh;
pub mod launch;
pub mod liggghts;
pub mod output;
pub mod particles_setup;
pub mod probes;
pub mod rcb;
pub mod scaling;
pub mod scene;
pub mod sph_coupled;
pub mod sph_run;
pub mod sph_selftest;
pub mod sph_stage;
pub mod sweep;
pub mod validate;
