//! Output self-test under mpirun: `mpirun -np 3 tdyn_selftest_output DIR` writes fields, history
//! and report into DIR, reads them back on rank 0 and exits non-zero on any mismatch.
use mpi::traits::*;
use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let Some(dir) = std::env::args_os().nth(1).map(PathBuf::from) else {
        eprintln!("usage: tdyn_selftest_output DIR");
        return ExitCode::FAILURE;
    };
    let universe = mpi::initialize().expect("MPI initialisation failed");
    let world = universe.world();
    match coupling::selftest::output::roundtrip_check(&world, &dir) {
        Ok(summary) => {
            if world.rank() == 0 {
                println!("{summary}");
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("tdyn_selftest_output: rank {}: {e}", world.rank());
            ExitCode::FAILURE
        }
    }
}
