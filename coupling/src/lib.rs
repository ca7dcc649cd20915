//! Everything parallel that is not PETSc: scene loading, meshing, the timestep driver, output.
#![warn(missing_docs)]

pub mod gmsh;
pub mod output;
pub mod scene;
