//! Finite elements on PETSc DMPlex: mesh load, METIS distribution, ghost exchange, the PRONTO-3D
//! hexahedron, the nodal-averaged tetrahedron (`tet`), materials, the explicit
//! central-difference integrator and the implicit Newmark integrator (tangent in a PETSc
//! matrix, solved by KSP).
#![warn(missing_docs)]
// Index loops over nodes and components read like the formulas they implement; `!(x > 0.0)`
// deliberately also rejects NaN.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]
// `petsc_call!` wraps one FFI call whose arguments are raw PETSc handles: the call is the unsafe part.
#![allow(clippy::macro_metavars_in_unsafe)]

pub mod agree;
pub mod assembly;
pub mod batch;
pub mod blocks;
pub mod curve;
pub mod exact;
pub mod explicit;
pub mod hex;
pub mod hourglass;
pub mod implicit;
pub mod locality;
pub mod material;
pub mod mesh;
mod nodal;
pub mod objects;
pub mod petsc;
pub mod solver;
pub mod states;
pub mod tet;

pub use petsc_sys as sys;
