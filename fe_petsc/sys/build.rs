//! Generates the PETSc bindings from Debian's headers.
//!
//! PETSc's pkg-config file lacks the MPI include path, so `ompi-c` is added. MPI's own types and
//! functions are left out (blocklisted) and taken from `mpi-sys`, so that an rsmpi communicator can
//! be handed to PETSc without conversion.
use std::path::PathBuf;

fn main() {
    let petsc = pkg_config::Config::new()
        .probe("PETSc")
        .expect("PETSc not found by pkg-config: install libpetsc-real-dev (see README)");
    let ompi = pkg_config::Config::new()
        .probe("ompi-c")
        .expect("ompi-c not found by pkg-config: install libopenmpi-dev");
    let mut builder = bindgen::Builder::default()
        .header("wrapper.h")
        .allowlist_function(
            "(Petsc|DM|Vec|Mat|KSP|PC|IS|PetscSF|PetscSection|PetscPartitioner)\\w*",
        )
        .allowlist_type("(Petsc|_p_|DM|Vec|Mat|KSP|PC|IS|Insert|Scatter|NormType)\\w*")
        .allowlist_var("(PETSC|DM_|INSERT|ADD|SCATTER|NORM|KSP|PC|MAT)\\w*")
        .blocklist_type("(MPI|ompi|MPIX)_\\w*")
        .blocklist_function("MPI\\w*")
        .blocklist_var("(MPI|ompi)\\w*")
        .raw_line("use mpi_sys::*;")
        .derive_default(true)
        .layout_tests(false)
        .generate_comments(false)
        .prepend_enum_name(false)
        .parse_callbacks(Box::new(bindgen::CargoCallbacks::new()));
    for p in petsc.include_paths.iter().chain(ompi.include_paths.iter()) {
        builder = builder.clang_arg(format!("-I{}", p.display()));
    }
    let bindings = builder.generate().expect("bindgen failed on PETSc headers");
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    bindings
        .write_to_file(out.join("bindings.rs"))
        .expect("could not write bindings");
    for p in &petsc.link_paths {
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", p.display());
    }
}
