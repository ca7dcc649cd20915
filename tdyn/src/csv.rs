//! The CSV files the tools read (history.csv, probes.csv, reactions.csv, contact_forces.csv,
//! the validation cases' reference curves), in one reader: a header row, then rows of numbers;
//! lines starting with `#` are comments (reference files say where they come from) and blank
//! lines are skipped.
use std::path::{Path, PathBuf};

/// A CSV file's columns and rows of numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// The file read (for messages).
    pub path: PathBuf,
    /// Column names, trimmed.
    pub header: Vec<String>,
    /// Rows of numbers; a short row is read as is (`column` gives NaN for its missing cells).
    pub rows: Vec<Vec<f64>>,
}

impl Table {
    /// Reads `path`. An empty file, or a cell that is not a number, is an error naming the file,
    /// the data row (from 1) and the cell.
    pub fn read(path: &Path) -> Result<Table, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        Table::parse(path, &text)
    }

    /// [`Table::read`] of `text` (named `path`).
    pub fn parse(path: &Path, text: &str) -> Result<Table, String> {
        let mut lines = text
            .lines()
            .filter(|l| !l.starts_with('#') && !l.trim().is_empty());
        let header: Vec<String> = lines
            .next()
            .ok_or_else(|| format!("{}: empty", path.display()))?
            .split(',')
            .map(|s| s.trim().to_string())
            .collect();
        let rows = lines
            .enumerate()
            .map(|(i, l)| {
                l.split(',')
                    .map(|v| {
                        v.trim().parse::<f64>().map_err(|_| {
                            format!("{}: data row {}: bad number {v:?}", path.display(), i + 1)
                        })
                    })
                    .collect()
            })
            .collect::<Result<_, _>>()?;
        Ok(Table {
            path: path.to_path_buf(),
            header,
            rows,
        })
    }

    /// The index of column `name`.
    pub fn position(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// Column `j` (NaN where a row is short).
    pub fn at(&self, j: usize) -> Vec<f64> {
        self.rows
            .iter()
            .map(|r| r.get(j).copied().unwrap_or(f64::NAN))
            .collect()
    }

    /// Column `name`, if the file has it.
    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        self.position(name).map(|j| self.at(j))
    }

    /// Column `name`, or an error naming the file.
    pub fn need(&self, name: &str) -> Result<Vec<f64>, String> {
        self.column(name)
            .ok_or_else(|| format!("{}: no column {name}", self.path.display()))
    }
}

/// One column of a CSV file, by name ([`Table::need`]).
pub fn read_column(path: &Path, column: &str) -> Result<Vec<f64>, String> {
    Table::read(path)?.need(column)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comments_blank_lines_and_columns() {
        let t = Table::parse(
            Path::new("f.csv"),
            "# from a paper\ntime,a, b\n\n0,1,2\n1e-3,3,4\n",
        )
        .unwrap();
        assert_eq!(t.header, ["time", "a", "b"]);
        assert_eq!(t.need("b").unwrap(), [2.0, 4.0]);
        assert_eq!(t.need("time").unwrap(), [0.0, 1e-3]);
        assert!(t.need("c").unwrap_err().contains("f.csv: no column c"));
    }

    #[test]
    fn a_bad_cell_names_the_file_and_row() {
        let e = Table::parse(Path::new("f.csv"), "t,a\n0,1\n1,x\n").unwrap_err();
        assert!(
            e.contains("f.csv: data row 2") && e.contains("\"x\""),
            "{e}"
        );
        assert!(Table::parse(Path::new("e.csv"), "# only\n")
            .unwrap_err()
            .contains("empty"));
    }
}
