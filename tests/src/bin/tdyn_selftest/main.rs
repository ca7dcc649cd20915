//! Self-tests of the parallel kernels and of the output under mpirun, kept out of the library
//! and of `tdyn` (test code ships in no product binary):
//!
//! - `mpirun -np P tdyn_selftest comm|rcb|contact|sph [--seed S]`: one kernel against its
//!   references (see each module);
//! - `mpirun -np P tdyn_selftest output DIR`: fields, history and report written into DIR and
//!   read back exactly on rank 0.
//!
//! Every rank agrees on the outcome; each failing rank says why; the exit status is non-zero
//! on any failure. `tests/tests/kernels.rs` and `tests/tests/output_mpi.rs` run them.
// Index loops over components read like the formulas they check.
#![allow(clippy::needless_range_loop)]
use mpi::traits::*;
use std::path::Path;
use std::process::ExitCode;

mod comm;
mod contact;
mod output;
mod rcb;
mod sph;

const USAGE: &str =
    "usage: tdyn_selftest comm|rcb|contact|sph [--seed S] | tdyn_selftest output DIR";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(kernel) = args.first().cloned() else {
        eprintln!("{USAGE}");
        return ExitCode::FAILURE;
    };
    let seed = match args.iter().position(|a| a == "--seed") {
        Some(i) => match args.get(i + 1).and_then(|s| s.parse::<u64>().ok()) {
            Some(s) => s,
            None => {
                eprintln!("--seed needs an integer\n{USAGE}");
                return ExitCode::FAILURE;
            }
        },
        None => 1,
    };
    let Some(universe) = mpi::initialize() else {
        eprintln!("tdyn_selftest: MPI could not be initialised");
        return ExitCode::FAILURE;
    };
    let world = universe.world();
    let res = match kernel.as_str() {
        "comm" => comm::selftest(&world, seed),
        "rcb" => rcb::selftest(&world, seed),
        "contact" => contact::selftest(&world, seed),
        "sph" => sph::selftest(&world, seed),
        "output" => match args.get(1) {
            Some(dir) => output::roundtrip_check(&world, Path::new(dir)),
            None => Err(USAGE.to_string()),
        },
        k => Err(format!(
            "unknown self-test {k:?} (expected comm, rcb, contact, sph or output)"
        )),
    };
    // Every rank must agree on the outcome.
    let failed = coupling::kernels::collective::max(&world, res.is_err() as i32 as f64) > 0.0;
    match res {
        Ok(msg) if !failed => {
            if world.rank() == 0 {
                println!("{msg}");
            }
            ExitCode::SUCCESS
        }
        Ok(_) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("tdyn_selftest: rank {}: {e}", world.rank());
            ExitCode::FAILURE
        }
    }
}
