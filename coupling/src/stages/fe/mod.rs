//! The FE stage (Fig. 3, step 1): the mesh on PETSc's static distribution, explicit or implicit.
pub mod setup;
