//! Energies, momentum and point probes over the particles of one box.
use crate::kernel::SmoothingKernel;
use crate::particles::Particles;

/// Sums over the owned particles (add them over ranks for the totals).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energies {
    /// sum 1/2 m |v|^2, J.
    pub kinetic: f64,
    /// sum m (e + work), J: internal energy with the energy equation on, initial internal
    /// energy plus accumulated pressure and viscous pair work with it off.
    pub internal: f64,
    /// sum m v, kg m/s.
    pub momentum: [f64; 3],
    /// sum m |v|, kg m/s (the scale for momentum round-off).
    pub abs_momentum: f64,
    /// sum x_real x m v about the origin, kg m^2/s.
    pub angular_momentum: [f64; 3],
}

/// Energies and momenta of the owned particles.
pub fn energies(p: &Particles) -> Energies {
    let mut out = Energies::default();
    for i in 0..p.n_owned {
        let (m, v, x) = (p.m[i], p.v[i], p.x_real[i]);
        out.internal += m * (p.e[i] + p.work[i]);
        if v == [0.0; 3] {
            // A particle at rest (a fixed wall's) adds exact zeros to every other sum: skipped,
            // and with it a square root (the dam break's walls are 78 % of its particles).
            continue;
        }
        let v2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        out.kinetic += 0.5 * m * v2;
        for (mom, vc) in out.momentum.iter_mut().zip(v) {
            *mom += m * vc;
        }
        out.abs_momentum += m * v2.sqrt();
        out.angular_momentum[0] += m * (x[1] * v[2] - x[2] * v[1]);
        out.angular_momentum[1] += m * (x[2] * v[0] - x[0] * v[2]);
        out.angular_momentum[2] += m * (x[0] * v[1] - x[1] * v[0]);
    }
    out
}

/// The power of gravity on the owned moving particles, sum m g . v, W (for the external work).
pub fn gravity_power(p: &Particles, g: [f64; 3]) -> f64 {
    (0..p.n_owned)
        .filter(|&i| !p.fixed[i])
        .map(|i| p.m[i] * (g[0] * p.v[i][0] + g[1] * p.v[i][1] + g[2] * p.v[i][2]))
        .sum()
}

/// Shepard-normalised kernel interpolation of a particle field at `point`:
/// sum_b V_b f_b W(|point - x_b|, h_b) / sum_b V_b W(...), V_b = m_b/rho_b, over every entry
/// (owned and ghost, so periodic images count). `None` when no particle reaches the point.
/// O(N): meant for a few probes per output step.
pub fn interpolate(
    point: [f64; 3],
    p: &Particles,
    kernel: &SmoothingKernel,
    field: impl Fn(usize) -> f64,
) -> Option<f64> {
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..p.len() {
        let d = [
            point[0] - p.x[i][0],
            point[1] - p.x[i][1],
            point[2] - p.x[i][2],
        ];
        let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let h = p.h[i];
        if r2 >= 4.0 * h * h {
            continue;
        }
        let wv = p.m[i] / p.rho[i] * kernel.w(r2.sqrt(), h);
        num += wv * field(i);
        den += wv;
    }
    (den > 0.0).then(|| num / den)
}
