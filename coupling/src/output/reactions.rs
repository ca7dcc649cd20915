//! Force histories (docs/output.md): `reactions.csv` (the force each constraint applies to the
//! bodies) and `contact_forces.csv` (the contact force between each pair of bodies), the same
//! rows as history.csv. The writer is generic: a list of named forces, fixed at the start, and
//! each row their values. The driver collects the entries (FE boundary groups first; more
//! constraints, such as rigid walls, add entries after them).
use super::History;
use mpi::topology::SimpleCommunicator;
use std::path::Path;

/// A CSV file of named force vectors: `time`, then `<name>.force_{x,y,z}` per entry (N).
pub struct ForceHistory {
    file: History,
    entries: usize,
}

/// The columns of a force history with entries `names`.
pub fn force_columns(names: &[String]) -> Vec<String> {
    let mut cols = vec!["time".to_string()];
    for n in names {
        cols.extend(["x", "y", "z"].map(|c| format!("{n}.force_{c}")));
    }
    cols
}

impl ForceHistory {
    /// Creates the file (rank 0 writes it) with the entries `names`, or with `rows` reopens
    /// it to continue a run from its checkpoint (the header and the first `rows` rows kept).
    pub fn open(
        comm: &SimpleCommunicator,
        path: &Path,
        names: &[String],
        rows: Option<usize>,
    ) -> std::io::Result<ForceHistory> {
        let cols = force_columns(names);
        let cols: Vec<&str> = cols.iter().map(|c| c.as_str()).collect();
        let file = match rows {
            None => History::create(comm, path, &cols)?,
            Some(r) => History::reopen(comm, path, &cols, r)?,
        };
        Ok(ForceHistory {
            file,
            entries: names.len(),
        })
    }

    /// Writes the row of `time` with one force per entry, in the entries' order (rank 0).
    pub fn row(&mut self, time: f64, forces: &[[f64; 3]]) -> std::io::Result<()> {
        assert_eq!(forces.len(), self.entries, "one force per entry");
        let mut r = Vec::with_capacity(1 + 3 * forces.len());
        r.push(time);
        r.extend(forces.iter().flatten());
        self.file.row(&r)
    }

    /// Rows written so far.
    pub fn rows(&self) -> usize {
        self.file.rows()
    }

    /// Flushes to disk.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

/// Each force's sum over ranks from every rank's terms (`terms[3 k + c]`: this rank's terms of
/// component c of force k), exact (binned on a grid from the reduced largest term and count:
/// `fe_petsc::exact::totals`), so the same bits at any rank count. Collective.
pub fn exact_forces(comm: &SimpleCommunicator, terms: &[Vec<f64>]) -> Vec<[f64; 3]> {
    if terms.is_empty() {
        return Vec::new();
    }
    let t = fe_petsc::exact::totals(comm, terms);
    t.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}
