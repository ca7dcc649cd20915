//! CSV time histories written by rank 0 (other ranks hold a writer that does nothing).
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Rows flushed to disk at least this often, so a crashed run keeps its history.
const FLUSH_EVERY_ROWS: usize = 64;

/// A CSV file with a header row; numbers are written in Rust's shortest round-trip form, so a
/// value read back is bit-identical.
pub struct History {
    out: Option<BufWriter<std::fs::File>>,
    rows: usize,
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
        Ok(History { out, rows: 0 })
    }

    /// Writes one row (rank 0; a no-op elsewhere).
    pub fn row(&mut self, values: &[f64]) -> std::io::Result<()> {
        if let Some(w) = &mut self.out {
            let mut first = true;
            for v in values {
                if !first {
                    w.write_all(b",")?;
                }
                first = false;
                write!(w, "{v:?}")?;
            }
            w.write_all(b"\n")?;
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
