//! Reading the files of LIGGGHTS, the peer our SPH is cross-checked against: its `atom_style sph`
//! data files (to give our run the very same particles) and its `dump custom` text files (to
//! compare field by field, matched by id).
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

/// One atom of a LIGGGHTS `atom_style sph` data file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DataAtom {
    /// Atom id.
    pub id: u64,
    /// Atom type.
    pub kind: u32,
    /// Density.
    pub rho: f64,
    /// Position.
    pub x: [f64; 3],
    /// Velocity (0 when the file has no Velocities section).
    pub v: [f64; 3],
}

/// A parsed data file: atoms and per-type masses.
#[derive(Clone, Debug, Default)]
pub struct DataFile {
    /// Atoms in file order.
    pub atoms: Vec<DataAtom>,
    /// Mass per type.
    pub masses: BTreeMap<u32, f64>,
}

fn num<T: std::str::FromStr>(w: Option<&str>, what: &str, line: usize) -> Result<T, String> {
    w.and_then(|s| s.parse::<T>().ok())
        .ok_or_else(|| format!("line {line}: expected {what}"))
}

/// Reads a data file written for `atom_style sph` as the peer README describes (Atoms lines
/// `id type rho 0 x y z 0 0`, Velocities lines `id vx vy vz 0 0 0`).
pub fn read_data(path: &Path) -> Result<DataFile, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut out = DataFile::default();
    let mut section = "";
    let mut vel: BTreeMap<u64, [f64; 3]> = BTreeMap::new();
    for (k, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        let lno = k + 1;
        if line.is_empty() {
            continue;
        }
        match line {
            "Atoms" | "Velocities" | "Masses" => {
                section = match line {
                    "Atoms" => "atoms",
                    "Velocities" => "vel",
                    _ => "masses",
                };
                continue;
            }
            _ => {}
        }
        if k == 0 {
            continue; // title line
        }
        let mut w = line.split_whitespace();
        let err = |e: String| format!("{}: {e}", path.display());
        match section {
            "masses" => {
                let t: u32 = num(w.next(), "a type", lno).map_err(err)?;
                let m: f64 = num(w.next(), "a mass", lno).map_err(err)?;
                out.masses.insert(t, m);
            }
            "atoms" => {
                let words: Vec<&str> = line.split_whitespace().collect();
                if words.len() != 9 {
                    return Err(err(format!(
                        "line {lno}: expected 9 words (id type rho 0 x y z 0 0), got {}",
                        words.len()
                    )));
                }
                let f = |i: usize| num::<f64>(Some(words[i]), "a number", lno);
                out.atoms.push(DataAtom {
                    id: num(Some(words[0]), "an id", lno).map_err(err)?,
                    kind: num(Some(words[1]), "a type", lno).map_err(err)?,
                    rho: f(2).map_err(err)?,
                    x: [f(4).map_err(err)?, f(5).map_err(err)?, f(6).map_err(err)?],
                    v: [0.0; 3],
                });
            }
            "vel" => {
                let id: u64 = num(w.next(), "an id", lno).map_err(err)?;
                let v = [
                    num(w.next(), "vx", lno).map_err(err)?,
                    num(w.next(), "vy", lno).map_err(err)?,
                    num(w.next(), "vz", lno).map_err(err)?,
                ];
                vel.insert(id, v);
            }
            _ => {} // header lines (counts, box)
        }
    }
    for a in &mut out.atoms {
        if let Some(v) = vel.get(&a.id) {
            a.v = *v;
        }
    }
    if out.atoms.is_empty() {
        return Err(format!("{}: no Atoms section", path.display()));
    }
    Ok(out)
}

/// Writes the atoms of one type as our particle CSV (`id,x,y,z,vx,vy,vz,rho,mass`), ids as in
/// the data file, numbers in shortest round-trip form (so nothing is lost).
pub fn write_csv(data: &DataFile, kind: u32, path: &Path) -> Result<usize, String> {
    let mass = data
        .masses
        .get(&kind)
        .copied()
        .ok_or_else(|| format!("no mass for type {kind}"))?;
    let mut f = std::io::BufWriter::new(
        std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?,
    );
    let mut n = 0;
    writeln!(f, "id,x,y,z,vx,vy,vz,rho,mass").map_err(|e| e.to_string())?;
    for a in data.atoms.iter().filter(|a| a.kind == kind) {
        writeln!(
            f,
            "{},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?}",
            a.id, a.x[0], a.x[1], a.x[2], a.v[0], a.v[1], a.v[2], a.rho, mass
        )
        .map_err(|e| e.to_string())?;
        n += 1;
    }
    Ok(n)
}

/// One snapshot of a `dump custom` file: its timestep, column names and rows by id.
#[derive(Clone, Debug, Default)]
pub struct Dump {
    /// Timestep.
    pub step: u64,
    /// Column names (after `ITEM: ATOMS`).
    pub columns: Vec<String>,
    /// Rows by atom id.
    pub rows: BTreeMap<u64, Vec<f64>>,
}

impl Dump {
    /// Column `name` of atom `id`.
    pub fn get(&self, id: u64, name: &str) -> Option<f64> {
        let c = self.columns.iter().position(|c| c == name)?;
        self.rows.get(&id).map(|r| r[c])
    }
}

/// Reads a single-snapshot `dump custom` text file (a column `id` required).
pub fn read_dump(path: &Path) -> Result<Dump, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut lines = text.lines();
    let mut d = Dump::default();
    while let Some(l) = lines.next() {
        if l.starts_with("ITEM: TIMESTEP") {
            d.step = lines
                .next()
                .and_then(|s| s.trim().parse().ok())
                .ok_or_else(|| format!("{}: bad TIMESTEP", path.display()))?;
        } else if let Some(cols) = l.strip_prefix("ITEM: ATOMS") {
            d.columns = cols.split_whitespace().map(String::from).collect();
            let ci = d
                .columns
                .iter()
                .position(|c| c == "id")
                .ok_or_else(|| format!("{}: no id column", path.display()))?;
            for row in lines.by_ref() {
                if row.trim().is_empty() {
                    continue;
                }
                let v: Vec<f64> = row
                    .split_whitespace()
                    .map(|s| s.parse::<f64>())
                    .collect::<Result<_, _>>()
                    .map_err(|e| format!("{}: {e} in {row:?}", path.display()))?;
                if v.len() != d.columns.len() {
                    return Err(format!("{}: short row {row:?}", path.display()));
                }
                d.rows.insert(v[ci] as u64, v);
            }
            break;
        }
    }
    if d.columns.is_empty() {
        return Err(format!("{}: no ITEM: ATOMS section", path.display()));
    }
    Ok(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-written data file and dump (the formats the peer README documents) read back
    /// to the values written.
    #[test]
    fn reads_data_and_dump() {
        let dir = std::env::temp_dir().join(format!("lig_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let data = dir.join("data.x");
        std::fs::write(
            &data,
            "LIGGGHTS data file\n\n2 atoms\n1 atom types\n\n0 1 xlo xhi\n0 1 ylo yhi\n0 1 zlo zhi\n\nMasses\n\n1 0.001\n\nAtoms\n\n1 1 1000.5 0 0.1 0.2 0.3 0 0\n2 1 999 0 0.4 0.5 0.6 0 0\n\nVelocities\n\n2 1 -2 3 0 0 0\n",
        )
        .unwrap();
        let d = read_data(&data).unwrap();
        assert_eq!(d.atoms.len(), 2);
        assert_eq!(d.atoms[0].x, [0.1, 0.2, 0.3]);
        assert_eq!(d.atoms[0].rho, 1000.5);
        assert_eq!(d.atoms[1].v, [1.0, -2.0, 3.0]);
        assert_eq!(d.masses[&1], 0.001);
        let csv = dir.join("p.csv");
        assert_eq!(write_csv(&d, 1, &csv).unwrap(), 2);
        let text = std::fs::read_to_string(&csv).unwrap();
        assert!(
            text.contains("2,0.4,0.5,0.6,1.0,-2.0,3.0,999.0,0.001"),
            "{text}"
        );
        let dump = dir.join("dump.1");
        std::fs::write(
            &dump,
            "ITEM: TIMESTEP\n3\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS ff ff ff\n0 1\n0 1\n0 1\nITEM: ATOMS id type x rho\n2 1 4.0000000000000002e-01 9.99e+02\n1 1 1.0e-01 1.0005e+03\n",
        )
        .unwrap();
        let dm = read_dump(&dump).unwrap();
        assert_eq!(dm.step, 3);
        assert_eq!(dm.get(2, "x"), Some(0.4));
        assert_eq!(dm.get(1, "rho"), Some(1000.5));
        std::fs::remove_dir_all(&dir).ok();
    }
}
