//! Self-test of the parallel SPH stage (`tdyn_selftest sph`): a blob of jittered particles with
//! random velocities and densities (pressures of both signs), run for several steps on the RCB
//! decomposition at any rank count, against the serial reference of the `sph` crate (one box
//! holding everything) on the same particles: the number of pairs computed over all ranks must
//! equal the serial count (the COI rule computes each pair exactly once), positions, velocities,
//! densities and pressures must agree to round-off, and total momentum must stay constant to
//! round-off. Run for the LIGGGHTS and standard profiles, open and periodic.
use coupling::stages::sph::stage::SphStage;
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use sph::{
    ArtificialViscosity, Eos, NewParticle, Params, Particles, Periodic, Profile, SerialSim,
    TensileCorrection,
};

struct Rng(u64);
impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

const DX: f64 = 0.01;

/// The particles (global, id order) and the model.
fn blob(seed: u64, n: usize, profile: Profile, periodic: bool) -> (Vec<NewParticle>, Params) {
    let mut rng = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
    let mut out = Vec::new();
    for k in 0..n * n * n {
        let (i, j, l) = (k % n, (k / n) % n, k / (n * n));
        let x = [i, j, l].map(|c| (c as f64 + 0.5 + 0.2 * (rng.unit() - 0.5)) * DX);
        // Fast enough that particles cross rank boundaries every few steps.
        let v = [0; 3].map(|_| 2.0 * (rng.unit() - 0.5));
        out.push(NewParticle {
            id: k as u64,
            x,
            v,
            m: 1000.0 * DX * DX * DX,
            rho: 995.0 + 10.0 * rng.unit(),
            e: 0.0,
            h: 1.2 * DX * (0.9 + 0.2 * rng.unit()),
            mat: 0,
            fixed: k % 17 == 0,
        });
    }
    let mut params = Params::new(vec![Eos::Tait {
        rho0: 1000.0,
        c0: 20.0,
        gamma: 7.0,
    }]);
    params.profile = profile;
    params.viscosity = Some(ArtificialViscosity::new(0.1, 0.2));
    params.tensile = Some(TensileCorrection::monaghan(0.2, DX));
    params.gravity = [0.0, 0.0, -9.81];
    if periodic {
        params.periodic = Some(Periodic {
            axes: [true, true, false],
            min: [0.0; 3],
            max: [n as f64 * DX, n as f64 * DX, 1.0],
        });
    }
    (out, params)
}

/// Gathers (id, 8 values) of every rank's owned particles on every rank, sorted by id.
fn gather(comm: &SimpleCommunicator, p: &Particles) -> Vec<[f64; 9]> {
    let mine: Vec<f64> = (0..p.n_owned)
        .flat_map(|i| {
            [
                p.id[i] as f64,
                p.x_real[i][0],
                p.x_real[i][1],
                p.x_real[i][2],
                p.v[i][0],
                p.v[i][1],
                p.v[i][2],
                p.rho[i],
                p.p[i],
            ]
        })
        .collect();
    let all = coupling::kernels::collective::all_gather_varcount(comm, &mine);
    let mut rows: Vec<[f64; 9]> = all
        .chunks(9)
        .map(|c| std::array::from_fn(|k| c[k]))
        .collect();
    rows.sort_by(|a, b| a[0].total_cmp(&b[0]));
    rows
}

/// Runs the self-test; returns a summary or the first failure (the same on every rank).
pub fn selftest(comm: &SimpleCommunicator, seed: u64) -> Result<String, String> {
    let p = comm.size() as usize;
    let me = comm.rank() as usize;
    let mut lines = Vec::new();
    for (profile, periodic) in [
        (Profile::Liggghts, false),
        (Profile::Standard, false),
        (Profile::Standard, true),
    ] {
        let n = 8;
        let (all, params) = blob(seed, n, profile, periodic);
        let dt = 2e-4;
        let steps = 10;
        // Parallel: each rank starts with a contiguous share (a poor decomposition on purpose).
        let (a, b) = (all.len() * me / p, all.len() * (me + 1) / p);
        let mut parts = Particles::new();
        for q in &all[a..b] {
            parts.push(*q);
        }
        let mut st = SphStage::new(comm, parts, params.clone());
        st.setup()?;
        // Serial reference.
        let mut sp = Particles::new();
        for q in &all {
            sp.push(*q);
        }
        let mut serial = SerialSim::new(sp, params.clone());
        serial.setup();
        let mut migrated = 0;
        let mut err: Option<String> = None;
        let mut worst = 0.0f64;
        let mut p0 = [0.0; 3];
        for step in 1..=steps {
            st.step(dt)?;
            serial.step(dt);
            migrated += st.stats.rcb.migrated;
            if st.stats.pairs as usize != serial.n_pairs && err.is_none() {
                err = Some(format!(
                    "{profile:?} periodic {periodic}, step {step}: {} pairs over all ranks, {} in the serial box",
                    st.stats.pairs, serial.n_pairs
                ));
            }
            let rows = gather(comm, &st.parts);
            let s = &serial.parts;
            let scale = [DX * n as f64, 2.0, 1000.0, 2e5];
            for r in &rows {
                let i =
                    s.id.iter()
                        .position(|&id| id as f64 == r[0])
                        .expect("same ids");
                let refv = [
                    s.x_real[i][0],
                    s.x_real[i][1],
                    s.x_real[i][2],
                    s.v[i][0],
                    s.v[i][1],
                    s.v[i][2],
                    s.rho[i],
                    s.p[i],
                ];
                for k in 0..8 {
                    let sc = scale[[0, 0, 0, 1, 1, 1, 2, 3][k]];
                    worst = worst.max((r[1 + k] - refv[k]).abs() / sc);
                }
            }
            // Momentum: the pair forces cancel exactly; gravity and fixed particles act, so
            // compare with the serial run's momentum instead of a constant.
            let e = sph::energies(&st.parts);
            let mut g = [0.0; 3];
            comm.all_reduce_into(&e.momentum[..], &mut g[..], SystemOperation::sum());
            let es = sph::energies(&serial.parts);
            for c in 0..3 {
                p0[c] = (g[c] - es.momentum[c]).abs().max(p0[c]);
            }
        }
        // Agreement with the serial run: round-off only (the sums over a particle's neighbours
        // are added in another order on another rank count); 1e-9 of each field's scale.
        if worst > 1e-9 && err.is_none() {
            err = Some(format!(
                "{profile:?} periodic {periodic}: parallel and serial differ by {worst:e} of the field scale (expected round-off, < 1e-9)"
            ));
        }
        let es = sph::energies(&serial.parts);
        if p0.iter().any(|d| *d > 1e-12 * es.abs_momentum.max(1e-30)) && err.is_none() {
            err = Some(format!(
                "{profile:?} periodic {periodic}: momentum differs from the serial run by {p0:?} (expected < 1e-12 of sum m|v| = {:e})",
                es.abs_momentum
            ));
        }
        coupling::kernels::collective::first_error(comm, err)?;
        lines.push(format!(
            "{profile:?}{}: {} particles, {steps} steps, pairs = serial every step, worst difference {worst:.1e} of scale, {migrated} migrations",
            if periodic { " periodic x,y" } else { "" },
            all.len()
        ));
    }
    Ok(format!(
        "sph selftest passed at np {p}:\n  {}",
        lines.join("\n  ")
    ))
}
