//! SPH particles from the scene's `[[particles]]` tables: lattice-filled regions (box, cylinder,
//! sphere) and particle files (CSV, or LIGGGHTS data files with `liggghts_type`), with global ids independent of the rank count.
//!
//! Two numberings. Inside the run a particle has a dense index 0..N (`ParticleSeed::id`, the
//! SPH stage's `id`: rows of `fields.h5`, tie-breaks, contact node ids): particles read from
//! files first, in ascending order of the file's ids, then generated particles, entry by entry
//! in scene order, lattice points in x-fastest order. What the user sees (docs/scene.md: `fields.h5`'s
//! `particles/id`, the LIGGGHTS dumps) are the particle file's own ids (CSV `id` column, or the
//! LIGGGHTS data file's atom ids), and for lattice particles the ids after the largest file id
//! (0, 1, ... without files), in the same order: [`ParticleIds`] maps one to the other, and
//! since the map is increasing, sorting by either gives the same order. Each rank builds a
//! contiguous share of the global sequence; the first RCB balance then places them.
use crate::input::scene::{ParticlesDef, Region, Scene};
use std::path::Path;

/// The ids users see, from the dense indices: file particles first (ascending file id), then
/// generated ones numbered on from one past the largest file id. Held by every rank: as large
/// as the particle files, which every rank reads anyway.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ParticleIds {
    /// The file particles' ids, ascending (dense index k < len holds `file_ids[k]`).
    file_ids: Vec<u64>,
    /// The id of the first generated particle: one past the largest file id, 0 without files.
    first_generated: u64,
    /// The scene's `[[particles]]` entry of the dense indices, as runs: (first dense index,
    /// entry), ascending; past the last seeded particle (particles of failed elements) none.
    entry_runs: Vec<(u64, u32)>,
    /// Seeded particles (dense indices below it have an entry).
    seeded: u64,
}

impl ParticleIds {
    /// The user-facing id of dense index `dense`.
    #[inline]
    pub fn id(&self, dense: u64) -> u64 {
        match self.file_ids.get(dense as usize) {
            Some(&id) => id,
            None => self.first_generated + (dense - self.file_ids.len() as u64),
        }
    }

    /// The `[[particles]]` entry (scene order) that seeded dense index `dense`; `None` for a
    /// particle made later (a failed element's).
    pub fn entry(&self, dense: u64) -> Option<u32> {
        if dense >= self.seeded {
            return None;
        }
        let k = self.entry_runs.partition_point(|r| r.0 <= dense);
        k.checked_sub(1).map(|k| self.entry_runs[k].1)
    }
}

/// One particle as set up (the SPH stage builds its own state from these).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleSeed {
    /// Dense index 0..N (the user-facing id is `ParticleIds::id` of it).
    pub id: u64,
    /// Position, m.
    pub x: [f64; 3],
    /// Velocity, m/s.
    pub v: [f64; 3],
    /// Density, kg/m^3.
    pub rho: f64,
    /// Smoothing length, m.
    pub h: f64,
    /// Mass, kg.
    pub mass: f64,
    /// Index of the material in `scene.materials`.
    pub material: usize,
    /// Boundary particle (density updates, never moves).
    pub fixed: bool,
    /// Index of the `[[particles]]` entry.
    pub entry: usize,
}

/// The box a region's lattice fills (a sphere's or a cylinder's bounding box); none for a file.
fn lattice_box(region: &Region) -> Option<([f64; 3], [f64; 3])> {
    match region {
        Region::Box { min, max } => Some((*min, *max)),
        Region::Sphere {
            center: c,
            radius: r,
        } => Some((
            std::array::from_fn(|d| c[d] - r),
            std::array::from_fn(|d| c[d] + r),
        )),
        Region::Cylinder {
            base: b,
            axis: a,
            radius: r,
        } => {
            let top: [f64; 3] = std::array::from_fn(|d| b[d] + a[d]);
            Some((
                std::array::from_fn(|d| b[d].min(top[d]) - r),
                std::array::from_fn(|d| b[d].max(top[d]) + r),
            ))
        }
        Region::File(_) => None,
    }
}

/// Lattice points along each axis of the box `min`..`max` at spacing `s`: as many as fit, with
/// a tolerance for the round-off in extent / spacing (as reals: a count past any integer type
/// stays a count, for [`lattice_points_bound`]).
fn lattice_dims(min: [f64; 3], max: [f64; 3], s: f64) -> [f64; 3] {
    std::array::from_fn(|d| (((max[d] - min[d]) / s) + 1e-9).floor().max(0.0))
}

/// The lattice points a region's filling visits (its box's; a sphere or a cylinder keeps
/// fewer), before anything is allocated: what the scene check bounds. Zero for a file.
pub fn lattice_points_bound(region: &Region, spacing: f64) -> f64 {
    match lattice_box(region) {
        Some((min, max)) => lattice_dims(min, max, spacing).iter().product(),
        None => 0.0,
    }
}

/// Whether the point `x` of the region's box lies in the region.
fn inside(region: &Region, x: &[f64; 3]) -> bool {
    match region {
        Region::Sphere {
            center: c,
            radius: r,
        } => {
            let d2: f64 = (0..3).map(|d| (x[d] - c[d]).powi(2)).sum();
            d2 < r * r
        }
        Region::Cylinder {
            base: b,
            axis: a,
            radius: r,
        } => {
            let aa: f64 = a.iter().map(|c| c * c).sum();
            let rel: [f64; 3] = std::array::from_fn(|d| x[d] - b[d]);
            let t = (0..3).map(|d| rel[d] * a[d]).sum::<f64>() / aa;
            let radial2: f64 = (0..3).map(|d| (rel[d] - t * a[d]).powi(2)).sum();
            (0.0..1.0).contains(&t) && radial2 < r * r
        }
        _ => true,
    }
}

/// Lattice points of a region, cell-centred on a simple cubic lattice of `spacing`.
fn lattice(region: &Region, s: f64) -> Vec<[f64; 3]> {
    let Some((min, max)) = lattice_box(region) else {
        return Vec::new();
    };
    // Points min + (i + 1/2) s along each axis.
    let n = lattice_dims(min, max, s).map(|k| k as usize);
    let mut out = Vec::new();
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let x = [
                    min[0] + (i as f64 + 0.5) * s,
                    min[1] + (j as f64 + 0.5) * s,
                    min[2] + (k as f64 + 0.5) * s,
                ];
                if inside(region, &x) {
                    out.push(x);
                }
            }
        }
    }
    out
}

/// Reads a particle CSV: header row; columns id,x,y,z and optionally vx,vy,vz,rho,h,mass.
fn read_file(
    path: &Path,
    def: &ParticlesDef,
    density: f64,
    entry: usize,
    material: usize,
) -> Result<Vec<ParticleSeed>, String> {
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_path(path)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let header: Vec<String> = rdr
        .headers()
        .map_err(|e| format!("{}: {e}", path.display()))?
        .iter()
        .map(|s| s.to_string())
        .collect();
    let col = |name: &str| header.iter().position(|h| h == name);
    let known = ["id", "x", "y", "z", "vx", "vy", "vz", "rho", "h", "mass"];
    if let Some(bad) = header.iter().find(|h| !known.contains(&h.as_str())) {
        return Err(format!(
            "{}: unknown column \"{bad}\" (expected id,x,y,z and optionally vx,vy,vz,rho,h,mass)",
            path.display()
        ));
    }
    let need = |n: &str| {
        col(n).ok_or_else(|| {
            format!(
                "{}: no \"{n}\" column (the header needs id,x,y,z)",
                path.display()
            )
        })
    };
    let (ci, cx, cy, cz) = (need("id")?, need("x")?, need("y")?, need("z")?);
    let (cvx, cvy, cvz, crho, ch, cm) = (
        col("vx"),
        col("vy"),
        col("vz"),
        col("rho"),
        col("h"),
        col("mass"),
    );
    let mut out = Vec::new();
    for (line, rec) in rdr.records().enumerate() {
        let rec = rec.map_err(|e| format!("{}: {e}", path.display()))?;
        let num = |c: usize| -> Result<f64, String> {
            rec.get(c)
                .and_then(|s| s.parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    format!(
                        "{}: line {}: column {}: expected a finite number, got {:?}",
                        path.display(),
                        line + 2,
                        header[c],
                        rec.get(c).unwrap_or("")
                    )
                })
        };
        let opt = |c: Option<usize>, default: f64| c.map(num).unwrap_or(Ok(default));
        let id = rec
            .get(ci)
            .and_then(|s| s.parse::<u64>().ok())
            .ok_or_else(|| {
                format!(
                    "{}: line {}: id: expected a non-negative integer",
                    path.display(),
                    line + 2
                )
            })?;
        let x = [num(cx)?, num(cy)?, num(cz)?];
        let v = [
            opt(cvx, def.velocity[0])?,
            opt(cvy, def.velocity[1])?,
            opt(cvz, def.velocity[2])?,
        ];
        let rho = opt(crho, density)?;
        let h = opt(ch, def.h_factor * def.spacing)?;
        let mass = opt(cm, density * def.spacing.powi(3))?;
        if !(rho > 0.0 && h > 0.0 && mass > 0.0) {
            return Err(format!(
                "{}: line {}: rho, h and mass must be positive",
                path.display(),
                line + 2
            ));
        }
        out.push(ParticleSeed {
            id,
            x,
            v,
            rho,
            h,
            mass,
            material,
            fixed: def.fixed,
            entry,
        });
    }
    Ok(out)
}

/// The atoms of type `kind` of a LIGGGHTS `atom_style sph` data file: position, velocity and
/// density as in the file, the mass of the type from its Masses section, h = h_factor x spacing.
fn read_liggghts_data(
    path: &Path,
    def: &ParticlesDef,
    kind: u32,
    entry: usize,
    material: usize,
) -> Result<Vec<ParticleSeed>, String> {
    let data = crate::input::liggghts::read_data(path)?;
    let mass = *data
        .masses
        .get(&kind)
        .ok_or_else(|| format!("{}: no mass for atom type {kind}", path.display()))?;
    let out: Vec<ParticleSeed> = data
        .atoms
        .iter()
        .filter(|a| a.kind == kind)
        .map(|a| ParticleSeed {
            id: a.id,
            x: a.x,
            v: a.v,
            rho: a.rho,
            h: def.h_factor * def.spacing,
            mass,
            material,
            fixed: def.fixed,
            entry,
        })
        .collect();
    if out.is_empty() {
        return Err(format!("{}: no atom of type {kind}", path.display()));
    }
    Ok(out)
}

/// All particles of the scene, every rank building the same global list, then keeping its
/// contiguous share `[N me / P, N (me + 1) / P)` (seeds with dense indices), and the map to
/// the user-facing ids. Errors name the entry and key.
pub fn particles(
    scene: &Scene,
    rank: usize,
    nranks: usize,
) -> Result<(Vec<ParticleSeed>, ParticleIds), String> {
    let file = scene.file.display();
    let mut from_files = Vec::new();
    let mut generated: Vec<(usize, Vec<[f64; 3]>)> = Vec::new();
    for (i, def) in scene.particles.iter().enumerate() {
        let material = scene
            .materials
            .iter()
            .position(|m| m.name == def.material)
            .ok_or_else(|| format!("{file}: particles[{i}].material: unknown"))?;
        let density = scene.materials[material].density;
        match &def.region {
            Region::File(p) => {
                let path = scene.dir.join(p);
                let mut seeds = match def.liggghts_type {
                    Some(kind) => read_liggghts_data(&path, def, kind, i, material),
                    None => read_file(&path, def, density, i, material),
                }
                .map_err(|e| format!("{file}: particles[{i}].region.file: {e}"))?;
                if seeds.is_empty() {
                    return Err(format!(
                        "{file}: particles[{i}].region.file: no particle in {} (a header and no rows)",
                        path.display()
                    ));
                }
                from_files.append(&mut seeds);
            }
            r => {
                let pts = lattice(r, def.spacing);
                if pts.is_empty() {
                    return Err(format!(
                        "{file}: particles[{i}].region: no lattice point of spacing {} fits in the region",
                        def.spacing
                    ));
                }
                generated.push((i, pts));
            }
        }
    }
    let mut ids: Vec<u64> = from_files.iter().map(|s| s.id).collect();
    ids.sort_unstable();
    if let Some(w) = ids.windows(2).find(|w| w[0] == w[1]) {
        return Err(format!(
            "{file}: particles: id {} appears twice in the particle files",
            w[0]
        ));
    }
    // Dense indices 0..N: file particles in ascending file id, then the generated ones; the
    // file ids are kept in `ParticleIds` (what fields.h5 and the dumps write).
    from_files.sort_by_key(|s| s.id);
    let mut ids = ParticleIds {
        first_generated: ids.last().map_or(0, |&m| m + 1),
        file_ids: ids,
        entry_runs: Vec::new(),
        seeded: 0,
    };
    for (k, s) in from_files.iter_mut().enumerate() {
        s.id = k as u64;
    }
    let mut next = from_files.len() as u64;
    let mut all = from_files;
    for (i, pts) in generated {
        let def = &scene.particles[i];
        let material = scene
            .materials
            .iter()
            .position(|m| m.name == def.material)
            .expect("checked above");
        let rho = scene.materials[material].density;
        for x in pts {
            all.push(ParticleSeed {
                id: next,
                x,
                v: def.velocity,
                rho,
                h: def.h_factor * def.spacing,
                mass: rho * def.spacing.powi(3),
                material,
                fixed: def.fixed,
                entry: i,
            });
            next += 1;
        }
    }
    check_periodic(scene, &all)?;
    let n = all.len();
    for s in &all {
        if ids.entry_runs.last().is_none_or(|r| r.1 != s.entry as u32) {
            ids.entry_runs.push((s.id, s.entry as u32));
        }
    }
    ids.seeded = n as u64;
    let (a, b) = (n * rank / nranks, n * (rank + 1) / nranks);
    Ok((all[a..b].to_vec(), ids))
}

/// Every particle inside `[sph] periodic`'s range `[min, max)` on each periodic axis: one
/// outside would be wrapped onto another's place (a lattice region longer than the period
/// overlaps itself), so it is an error naming the entry, the axis and the range.
fn check_periodic(scene: &Scene, seeds: &[ParticleSeed]) -> Result<(), String> {
    let Some(p) = scene.sph.as_ref().and_then(|s| s.periodic.as_ref()) else {
        return Ok(());
    };
    for s in seeds {
        for c in (0..3).filter(|&c| p.axes[c]) {
            if !(s.x[c] >= p.min[c] && s.x[c] < p.max[c]) {
                return Err(format!(
                    "{}: particles[{}]: a particle at {} = {:e} m lies outside sph.periodic's range [{:e}, {:e}) m on that axis: the region must lie within the periodic box (wrapped, its particles would sit on others)",
                    scene.file.display(),
                    s.entry,
                    ["x", "y", "z"][c],
                    s.x[c],
                    p.min[c],
                    p.max[c]
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The user-facing ids: a file numbered 5, 7, 10 keeps them; the lattice continues at 11.
    #[test]
    fn file_ids_and_lattice_ids_after_them() {
        let ids = ParticleIds {
            file_ids: vec![5, 7, 10],
            first_generated: 11,
            ..Default::default()
        };
        let got: Vec<u64> = (0..5).map(|d| ids.id(d)).collect();
        assert_eq!(got, [5, 7, 10, 11, 12], "file ids, then max + 1 onwards");
        let none = ParticleIds::default();
        assert_eq!(none.id(3), 3, "no file: lattice ids from 0");
    }

    /// The entries of dense indices: runs, and none past the seeded particles.
    #[test]
    fn entries_of_dense_indices() {
        let ids = ParticleIds {
            entry_runs: vec![(0, 1), (3, 0), (4, 2)],
            seeded: 6,
            ..Default::default()
        };
        let got: Vec<Option<u32>> = (0..7).map(|d| ids.entry(d)).collect();
        let want = [1, 1, 1, 0, 2, 2].map(Some);
        assert_eq!(&got[..6], &want[..]);
        assert_eq!(got[6], None, "a failed element's particle");
    }

    /// Counts against the lattice arithmetic: a 0.2 x 0.1 x 0.2 box at spacing 0.01 holds
    /// 20 x 10 x 20 points; a sphere of radius 10 s holds close to (4/3) pi 10^3 points.
    #[test]
    fn lattice_counts() {
        let b = lattice(
            &Region::Box {
                min: [0.0; 3],
                max: [0.2, 0.1, 0.2],
            },
            0.01,
        );
        assert_eq!(b.len(), 4000, "20 x 10 x 20 lattice points");
        assert!((b[0][0] - 0.005).abs() < 1e-15, "cell-centred");
        let s = lattice(
            &Region::Sphere {
                center: [0.0; 3],
                radius: 10.0,
            },
            1.0,
        );
        let exact = 4.0 / 3.0 * std::f64::consts::PI * 1000.0;
        assert!(
            (s.len() as f64 - exact).abs() / exact < 0.02,
            "{} points vs volume/s^3 = {exact:.1} (2 %)",
            s.len()
        );
        let c = lattice(
            &Region::Cylinder {
                base: [0.0; 3],
                axis: [0.0, 0.0, 10.0],
                radius: 10.0,
            },
            1.0,
        );
        let exact = std::f64::consts::PI * 100.0 * 10.0;
        assert!(
            (c.len() as f64 - exact).abs() / exact < 0.02,
            "{} points vs volume/s^3 = {exact:.1} (2 %)",
            c.len()
        );
    }
}
