//! The stages of one time step (Fig. 3), each on its own decomposition: the finite elements on
//! PETSc's static distribution, the SPH particles and the contact search each on a dynamic RCB.
pub mod contact;
pub mod fe;
pub mod sph;
