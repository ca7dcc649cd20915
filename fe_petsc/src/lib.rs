//! Finite elements on PETSc DMPlex: mesh load, METIS distribution, ghost exchange, the PRONTO-3D
//! hexahedron, materials and the explicit central-difference integrator.
#![warn(missing_docs)]

pub mod explicit;
pub mod hex;
pub mod material;
pub mod mesh;
pub mod objects;
pub mod petsc;

pub use petsc_sys as sys;
