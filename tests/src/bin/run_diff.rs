//! Whether two runs' outputs are the same bits: the check for a change that must not change
//! any result (a refactoring, another rank count, another `--kernel`).
//!
//! `cargo run --release -p tdyn-tests --bin run_diff -- DIR_A DIR_B`
//!
//! Compares history.csv (all but the run's own measurements `contact_imbalance` and
//! `contact_bytes`), probes.csv, reactions.csv and contact_forces.csv where the runs wrote
//! them, cell by cell as text, and every frame's values in fields.h5 matched by id. Prints
//! `same` and exits 0, or names what differs and exits 1.
use std::path::Path;
use tdyn_tests::{csv_columns_differ, fields_differ};

/// history.csv's columns that measure the run, not the physics (docs/output.md).
const MEASURED: [&str; 2] = ["contact_imbalance", "contact_bytes"];

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() != 2 {
        eprintln!("usage: run_diff DIR_A DIR_B");
        std::process::exit(2);
    }
    let (a, b) = (Path::new(&args[0]), Path::new(&args[1]));
    let mut differ: Vec<String> = Vec::new();
    for file in [
        "history.csv",
        "probes.csv",
        "reactions.csv",
        "contact_forces.csv",
    ] {
        match (a.join(file).exists(), b.join(file).exists()) {
            (false, false) => continue,
            (true, true) => {}
            _ => {
                differ.push(format!("{file}: in one run only"));
                continue;
            }
        }
        let skip: &[&str] = if file == "history.csv" {
            &MEASURED
        } else {
            &[]
        };
        for (col, row) in csv_columns_differ(a, b, file, skip) {
            differ.push(format!("{file}: {col} (first at row {row})"));
        }
    }
    if a.join("fields.h5").exists() || b.join("fields.h5").exists() {
        if let Err(e) = fields_differ(a, b) {
            differ.push(format!("fields.h5: {e}"));
        }
    }
    if differ.is_empty() {
        println!("same");
    } else {
        for d in &differ {
            println!("{d}");
        }
        std::process::exit(1);
    }
}
