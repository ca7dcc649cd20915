//! Raw FFI to PETSc 3.18 (Debian's `libpetsc-real-dev`): `PetscInt` is `i32`, `PetscScalar` is `f64`.
//!
//! This is the project's only unsafe FFI surface to PETSc; `fe_petsc` wraps it in safe types.
#![allow(
    non_upper_case_globals,
    non_camel_case_types,
    non_snake_case,
    dead_code
)]
#![allow(clippy::all)]
#![allow(missing_docs)]
include!(concat!(env!("OUT_DIR"), "/bindings.rs"));
