//! Particle states as LIGGGHTS `dump custom` text files, for the cross-check against LIGGGHTS
//! (`[output] dump_every`, `tdyn crosscheck`): one file per dumped step, `dump.tdyn.<step>`,
//! in LIGGGHTS's own layout (`ITEM: TIMESTEP`, `NUMBER OF ATOMS`, `BOX BOUNDS`, `ATOMS ...`),
//! rows sorted by id, numbers in `%.16e` as the peer decks dump them.
use crate::input::particles::ParticleIds;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use sph::Particles;
use std::io::Write;
use std::path::Path;

/// The columns written, after `ITEM: ATOMS`. `id` is the particle's id as `fields.h5` writes it
/// (docs/scene.md): for particles read from a LIGGGHTS data file, LIGGGHTS's own atom ids; `type` is 1 for a moving particle
/// and 2 for a fixed one (the peer decks' fluid and boundary types); `fx..fz` is the force
/// m a in N as LIGGGHTS dumps it; `mass` is ours (LIGGGHTS's decks do not dump it).
pub const DUMP_COLUMNS: &str = "id type x y z vx vy vz fx fy fz rho p mass";

/// Numbers per particle in the gathered buffer.
const PER: usize = 14;

/// Writes the owned particles of every rank as `dir/dump.tdyn.<step>` (collective; rank 0 writes).
pub fn write_particle_dump(
    comm: &SimpleCommunicator,
    dir: &Path,
    step: u64,
    parts: &Particles,
    ids: &ParticleIds,
) -> std::io::Result<()> {
    let n = parts.n_owned;
    let mut mine = Vec::with_capacity(n * PER);
    for i in 0..n {
        // ids < 2^53 are exact in f64.
        mine.push(ids.id(parts.id[i]) as f64);
        mine.push(if parts.fixed[i] { 2.0 } else { 1.0 });
        mine.extend_from_slice(&parts.x_real[i]);
        mine.extend_from_slice(&parts.v[i]);
        mine.extend_from_slice(&parts.f[i]);
        mine.extend_from_slice(&[parts.rho[i], parts.p[i], parts.m[i]]);
    }
    let all = crate::kernels::collective::all_gather_varcount(comm, &mine);
    if comm.rank() != 0 {
        return Ok(());
    }
    let mut rows: Vec<&[f64]> = all.chunks_exact(PER).collect();
    rows.sort_by(|a, b| a[0].total_cmp(&b[0]));
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for r in &rows {
        for c in 0..3 {
            lo[c] = lo[c].min(r[2 + c]);
            hi[c] = hi[c].max(r[2 + c]);
        }
    }
    std::fs::create_dir_all(dir)?;
    let mut f = std::io::BufWriter::new(std::fs::File::create(
        dir.join(format!("dump.tdyn.{step}")),
    )?);
    writeln!(
        f,
        "ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{}",
        rows.len()
    )?;
    writeln!(f, "ITEM: BOX BOUNDS ff ff ff")?;
    for c in 0..3 {
        writeln!(f, "{:.16e} {:.16e}", lo[c], hi[c])?;
    }
    writeln!(f, "ITEM: ATOMS {DUMP_COLUMNS}")?;
    for r in rows {
        write!(f, "{} {}", r[0] as u64, r[1] as u64)?;
        for v in &r[2..] {
            write!(f, " {v:.16e}")?;
        }
        writeln!(f)?;
    }
    f.flush()
}
