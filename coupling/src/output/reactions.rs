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
/// component c of force k), exact, so the same bits at any rank count, and the maximum over
/// ranks of each of `flags`; two reductions in all (collective; every rank passes as many
/// sums and flags). Each sum is binned on the grid covering its largest term (reduced) times
/// `MAX_TERMS` (`fe_petsc::exact`: three folds, the lowest quantum 2^-104 of the grid's top,
/// so 2^-76 of the largest term): a bound on the terms of a sum that every rank count shares,
/// where `fe_petsc::exact::totals` reduces the count itself in a third reduction.
pub fn exact_forces(
    comm: &SimpleCommunicator,
    terms: &[Vec<f64>],
    flags: &[f64],
) -> (Vec<[f64; 3]>, Vec<f64>) {
    use fe_petsc::exact::{flatten, values, Folds, Grid, MAX_TERMS};
    use mpi::collective::{CommunicatorCollectives, SystemOperation};
    if terms.is_empty() && flags.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let n = terms.len();
    let mine: Vec<f64> = terms
        .iter()
        .map(|t| t.iter().fold(0.0f64, |m, x| m.max(x.abs())))
        .chain(flags.iter().copied())
        .collect();
    let mut big = vec![0.0f64; mine.len()];
    comm.all_reduce_into(&mine[..], &mut big[..], SystemOperation::max());
    let folds: Vec<Folds> = terms
        .iter()
        .zip(&big)
        .map(|(t, &b)| {
            assert!(
                t.len() as u64 <= MAX_TERMS,
                "at most MAX_TERMS terms per sum"
            );
            let grid = Grid::covering(b * MAX_TERMS as f64);
            let mut f = [0.0; 3];
            for &x in t {
                grid.add(&mut f, x);
            }
            f
        })
        .collect();
    let flat = flatten(&folds);
    let mut red = vec![0.0; flat.len()];
    if !flat.is_empty() {
        comm.all_reduce_into(&flat[..], &mut red[..], SystemOperation::sum());
    }
    let sums = values(&red);
    let forces = sums.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    (forces, big[n..].to_vec())
}
