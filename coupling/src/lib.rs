//! Everything parallel that is not PETSc: scene loading, meshing, the timestep driver, output.
#![warn(missing_docs)]

pub mod collective;
pub mod driver;
pub mod fe_setup;
pub mod gmsh;
pub mod output;
pub mod probes;
pub mod scene;
