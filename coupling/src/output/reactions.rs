//! reactions.csv (docs/output.md): the same rows as history.csv, `time` and then
//! `<name>.force_x`, `<name>.force_y`, `<name>.force_z` for every entry the driver collects
//! (a generic list of named forces, N: the force each constraint applies to the bodies; today
//! the rigid walls). Rank 0 writes it, through the same CSV writer as history.csv (shortest
//! round-trip numbers, whole rows, the rows of a checkpoint kept at a restart).
use super::History;
use mpi::topology::SimpleCommunicator;
use std::path::Path;

/// The writer of reactions.csv.
pub struct Reactions {
    csv: History,
    entries: usize,
}

/// The header of reactions.csv for the entries `names`, in their order.
pub fn columns(names: &[String]) -> Vec<String> {
    let mut cols = vec!["time".to_string()];
    for n in names {
        cols.extend(["x", "y", "z"].map(|c| format!("{n}.force_{c}")));
    }
    cols
}

impl Reactions {
    /// Creates the file (rank 0) with the header of `names`.
    pub fn create(
        comm: &SimpleCommunicator,
        path: &Path,
        names: &[String],
    ) -> std::io::Result<Reactions> {
        let cols = columns(names);
        let cols: Vec<&str> = cols.iter().map(|c| c.as_str()).collect();
        Ok(Reactions {
            csv: History::create(comm, path, &cols)?,
            entries: names.len(),
        })
    }

    /// Reopens the file of a run continued from a checkpoint, keeping its first `rows` rows.
    pub fn reopen(
        comm: &SimpleCommunicator,
        path: &Path,
        names: &[String],
        rows: usize,
    ) -> std::io::Result<Reactions> {
        let cols = columns(names);
        let cols: Vec<&str> = cols.iter().map(|c| c.as_str()).collect();
        Ok(Reactions {
            csv: History::reopen(comm, path, &cols, rows)?,
            entries: names.len(),
        })
    }

    /// Writes the row at `time`: one force per entry, in the header's order (rank 0).
    pub fn row(&mut self, time: f64, forces: &[[f64; 3]]) -> std::io::Result<()> {
        assert_eq!(
            forces.len(),
            self.entries,
            "one force per reactions.csv entry"
        );
        let mut r = vec![time];
        r.extend(forces.iter().flatten());
        self.csv.row(&r)
    }

    /// Flushes to disk.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.csv.flush()
    }
}
