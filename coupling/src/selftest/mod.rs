//! Self-tests of the parallel kernels and the output under mpirun (`tdyn selftest KERNEL`,
//! `tdyn_selftest_output`): an install check, built with the `selftest` feature.
pub mod comm;
pub mod contact;
pub mod output;
pub mod rcb;
pub mod sph;
