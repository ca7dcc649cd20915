//! CSV time histories written by rank 0 (other ranks hold a writer that does nothing).
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Rows flushed to disk at least this often, so a crashed run keeps its history.
const FLUSH_EVERY_ROWS: usize = 64;

/// A CSV file with a header row; numbers are written in Rust's shortest round-trip form, so a
/// value read back is bit-identical. Columns marked integer (`integer_columns`: history.csv's
/// `step` and `contacts`, docs/scene.md) are written as integers (`12`, not `12.0`).
pub struct History {
    out: Option<BufWriter<std::fs::File>>,
    rows: usize,
    columns: Vec<String>,
    integer: Vec<bool>,
}

impl History {
    /// Creates the file on rank 0 and writes the header.
    pub fn create(
        comm: &SimpleCommunicator,
        path: &Path,
        columns: &[&str],
    ) -> std::io::Result<History> {
        let out = if comm.rank() == 0 {
            let mut w = BufWriter::new(std::fs::File::create(path)?);
            writeln!(w, "{}", columns.join(","))?;
            Some(w)
        } else {
            None
        };
        Ok(History {
            out,
            rows: 0,
            columns: columns.iter().map(|c| c.to_string()).collect(),
            integer: vec![false; columns.len()],
        })
    }

    /// Reopens the file to continue a run (rank 0): the header and the first `rows` rows are
    /// kept (rows written after a checkpoint are dropped), then rows are appended.
    pub fn reopen(
        comm: &SimpleCommunicator,
        path: &Path,
        columns: &[&str],
        rows: usize,
    ) -> std::io::Result<History> {
        let out = if comm.rank() == 0 {
            let text = std::fs::read_to_string(path)?;
            let mut keep: String = text
                .lines()
                .take(rows + 1)
                .flat_map(|l| [l, "\n"])
                .collect();
            if !keep.starts_with(&columns.join(",")) {
                return Err(std::io::Error::other(format!(
                    "{}: its columns are not this run's",
                    path.display()
                )));
            }
            let tmp = path.with_extension("csv.tmp");
            std::fs::write(&tmp, std::mem::take(&mut keep))?;
            std::fs::rename(&tmp, path)?;
            let f = std::fs::OpenOptions::new().append(true).open(path)?;
            Some(BufWriter::new(f))
        } else {
            None
        };
        Ok(History {
            out,
            rows,
            columns: columns.iter().map(|c| c.to_string()).collect(),
            integer: vec![false; columns.len()],
        })
    }

    /// Rows written so far (the header not counted).
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Writes the columns named in `names` as integers (those present; others are ignored).
    pub fn integer_columns(mut self, names: &[&str]) -> History {
        for (c, int) in self.columns.iter().zip(self.integer.iter_mut()) {
            *int = names.contains(&c.as_str());
        }
        self
    }

    /// Writes one row (rank 0; a no-op elsewhere). The row is formatted whole and the buffer
    /// is flushed before a row that would not fit in it, so every write to the file ends at a
    /// row's end: a run killed at any moment leaves only whole rows.
    pub fn row(&mut self, values: &[f64]) -> std::io::Result<()> {
        if let Some(w) = &mut self.out {
            let mut line = Vec::with_capacity(24 * values.len());
            for (k, v) in values.iter().enumerate() {
                if k > 0 {
                    line.push(b',');
                }
                // Integer columns hold counts (exact in f64 below 2^53).
                if self.integer.get(k).copied().unwrap_or(false) && v.is_finite() {
                    write!(line, "{}", *v as i64)?;
                } else {
                    write!(line, "{v:?}")?;
                }
            }
            line.push(b'\n');
            if w.buffer().len() + line.len() > w.capacity() {
                w.flush()?;
            }
            w.write_all(&line)?;
            self.rows += 1;
            if self.rows.is_multiple_of(FLUSH_EVERY_ROWS) {
                w.flush()?;
            }
        }
        Ok(())
    }

    /// Flushes to disk.
    pub fn flush(&mut self) -> std::io::Result<()> {
        if let Some(w) = &mut self.out {
            w.flush()?;
        }
        Ok(())
    }
}
