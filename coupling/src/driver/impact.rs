//! The start line's step estimate for a plastic impact: how far the step will fall as a body's
//! impact face crushes, so that the count the start line gives is the one the run takes.
//!
//! Why: the explicit step is the smallest element's length over its wave speed. Where a
//! plastic body meets a plane (a symmetry plane it moves into, a rigid wall), the elements at
//! its impact face shorten along the impact and widen across it, and the step falls with them:
//! the bundled copper Taylor bar (`scenes/taylor_impact.toml`) ends at 0.216 of its first step
//! and takes 3,316 steps where the first step's count is 959.
//!
//! Model (Taylor, Proc. R. Soc. A 194 (1948) 289; Wilkins & Guinan, J. Appl. Phys. 44 (1973)
//! 1200): a body of density rho (kg/m^3) and flow stress sigma_1 (Pa, at plastic strain 1:
//! `yield_stress + hardening_modulus` of `j2_plastic`, `a + b` of `johnson_cook` at its
//! reference rate and temperature) meeting the plane at the closing speed v (m/s) is crushed
//! as far as the severity
//!
//! ```text
//! s = rho v^2 / sigma_1                     (dimensionless)
//! ```
//!
//! says (Wilkins & Guinan's final length L_f / L = exp(-s / 2)). The step falls to 1/k of the
//! first, k = exp(C_K s), over the crush's duration t_c, a fraction C_T of the time the flow
//! stress takes to stop the body's momentum (Taylor's rigid-plastic deceleration over the
//! body's length L along the plane's normal):
//!
//! ```text
//! k   = exp(C_K s)                          (capped at K_MAX)
//! t_c = C_T rho L v / sigma_1               s
//! ```
//!
//! and 1/dt grows from 1/dt_0 to k/dt_0 over [t_i, t_i + t_c] (t_i = gap / v, the time the
//! body reaches the plane) along the smoothstep 3 x^2 - 2 x^3 of x = (t - t_i) / t_c, the
//! measured step's S shape (slow while the foot starts to spread, fastest mid-crush, flat once
//! the body stops). The count is the integral of 1/dt to the end time,
//!
//! ```text
//! N = [ min(T, t_i) + t_c (x + (k - 1)(x^3 - x^4 / 2)) + k max(T - t_i - t_c, 0) ] / dt_0
//! ```
//!
//! with x = clamp((T - t_i) / t_c, 0, 1). A run that ends mid-crush is estimated within 40 % at
//! a quarter of these bars' end times, within 36 % at half (a line instead of the smoothstep:
//! 56 % and 40 %). C_K and C_T are fitted to the Taylor bars below (the
//! bundled scenes, and variants at other speeds and on a rigid wall); the step's measured fall
//! k gives ln k / s = 2.05-2.81 among them, so a fit cannot do better than about 20 %:
//!
//! | bar (run to 80 us unless said) | s | first step's count | taken | estimate |
//! | --- | ---: | ---: | ---: | ---: |
//! | `taylor_impact` (copper, square, 190 m/s) | 0.645 | 959 | 3,316 | +7 % |
//! | the same at 120 m/s | 0.257 | 922 | 1,397 | +13 % |
//! | the same at 250 m/s | 1.116 | 993 | 7,589 | +6 % |
//! | `taylor_copper` (copper, round, 227 m/s) | 0.920 | 1,843 | 12,948 | -18 % |
//! | `taylor_jc_steel` (4340 steel, 287 m/s) | 0.454 | 2,389 | 6,254 | +2 % |
//! | the same on a rigid wall 2 mm away, to 90 us | 0.454 | 2,418 | 7,254 | -15 % |
//! | `example_bar` (aluminium, 150 m/s, to 40 us) | 0.122 | 304 | 343 | +14 % |
//! | the same at 250 m/s | 0.338 | 317 | 529 | +19 % |
//!
//! (C_K = 2.4, C_T = 0.5, K_MAX = 12.) Elastic bodies (no flow stress), slow impacts (k below
//! [`K_MIN`]) and bodies that meet other bodies through contact keep the first step's count:
//! the bundled scenes of those kinds take within 5 % of it, but for the container crush (its
//! thin walls fold: 20,005 at the first step, 24,247 taken).
use crate::input::scene::{BoundaryKind, Scene};
use crate::stages::fe::{setup::Groups, Fe};
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

/// C_K: ln k per unit of severity.
const C_K: f64 = 2.4;
/// C_T: the crush's duration over rho L v / sigma_1.
const C_T: f64 = 0.5;
/// The largest fall of the step the estimate assumes (the 250 m/s copper bar's, 11.8).
const K_MAX: f64 = 12.0;
/// A fall of the step below this leaves the count as it is.
pub const K_MIN: f64 = 1.1;

/// The impact the start line's estimate follows: the most severe one the scene sets up.
#[derive(Debug, Clone, PartialEq)]
pub struct Impact {
    /// The block (its `group`).
    pub body: String,
    /// What it meets, in words (`symmetry plane "impact"`, `rigid wall "floor"`).
    pub against: String,
    /// The closing speed, m/s.
    pub speed: f64,
    /// k: the first step over the last.
    pub shrink: f64,
    /// t_i: when the body reaches the plane, s.
    pub start: f64,
    /// t_c: the crush's duration, s.
    pub duration: f64,
}

impl Impact {
    /// The first step over the step at time `t` (s) the model expects: 1 before `start`,
    /// 1 + (k - 1)(3 x^2 - 2 x^3) during the crush, k after.
    pub fn rate(&self, t: f64) -> f64 {
        let x = ((t - self.start) / self.duration).clamp(0.0, 1.0);
        1.0 + (self.shrink - 1.0) * x * x * (3.0 - 2.0 * x)
    }

    /// The steps from t = 0 to `end` (s) at a first step `dt0` (s): the integral of 1/dt with
    /// 1/dt = 1/dt0 before `start`, growing to k/dt0 along a smoothstep over `duration`, k/dt0
    /// after (the module's N).
    pub fn steps(&self, dt0: f64, end: f64) -> f64 {
        let k = self.shrink;
        let before = end.min(self.start);
        let x = ((end - self.start) / self.duration).clamp(0.0, 1.0);
        let during = self.duration * (x + (k - 1.0) * (x * x * x - 0.5 * x * x * x * x));
        let after = (end - self.start - self.duration).max(0.0) * k;
        (before + during + after) / dt0
    }
}

/// The flow stress at plastic strain 1 of a material (Pa), or `None` for one that does not
/// yield.
fn flow_stress_1(scene: &Scene, material: &str) -> Option<(f64, f64)> {
    let m = scene.materials.iter().find(|m| m.name == material)?;
    let p = |k: &str| m.params.get(k).copied();
    let sigma = match m.model.as_str() {
        "j2_plastic" => p("yield_stress")? + p("hardening_modulus").unwrap_or(0.0),
        "johnson_cook" => p("a")? + p("b").unwrap_or(0.0),
        _ => return None,
    };
    (sigma > 0.0).then_some((m.density, sigma))
}

/// A plane a body may meet: unit normal, offset (n . x on the plane), its velocity along the
/// normal (m/s), whether the bodies must lie on its positive side (a wall), and its name.
struct Plane {
    n: [f64; 3],
    offset: f64,
    speed: f64,
    one_sided: bool,
    name: String,
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The symmetry planes (each group whose nodes all lie on one plane) and the rigid walls at
/// rest or moving at a constant velocity. Collective.
fn planes(world: &SimpleCommunicator, scene: &Scene, fe: &Fe, groups: &Groups) -> Vec<Plane> {
    let local = &fe.mesh.local;
    let mut sym = Vec::new();
    for b in &scene.boundaries {
        if !matches!(b.kind, BoundaryKind::Symmetry) {
            continue;
        }
        let Some(k) = (groups.surfaces.get(&b.group))
            .and_then(|t| local.surface_tags.iter().position(|s| s == t))
        else {
            continue;
        };
        let Some(n) = local.surface_normals[k] else {
            continue;
        };
        sym.push((b.group.clone(), n, 1u32 << k));
    }
    // each symmetry group's range of n . x (one plane where the two agree)
    let mut lo = vec![f64::INFINITY; sym.len()];
    let mut hi = vec![f64::NEG_INFINITY; sym.len()];
    for (i, x) in local.coords.iter().enumerate() {
        for (j, (_, n, bit)) in sym.iter().enumerate() {
            if local.node_surfaces[i] & bit != 0 {
                lo[j] = lo[j].min(dot(n, x));
                hi[j] = hi[j].max(dot(n, x));
            }
        }
    }
    let (lo, hi) = (reduce(world, &lo, false), reduce(world, &hi, true));
    let mut out: Vec<Plane> = Vec::new();
    for (j, (name, n, _)) in sym.into_iter().enumerate() {
        let scale = lo[j].abs().max(hi[j].abs()).max(1e-300);
        if lo[j].is_finite() && hi[j] - lo[j] <= 1e-9 * scale.max(1e-3) {
            out.push(Plane {
                n,
                offset: lo[j],
                speed: 0.0,
                one_sided: false,
                name: format!("symmetry plane \"{name}\""),
            });
        }
    }
    for w in &scene.rigid_walls {
        let v = w.velocity.unwrap_or([0.0; 3]);
        if w.curve.is_some() && v != [0.0; 3] {
            continue;
        }
        out.push(Plane {
            n: w.normal,
            offset: dot(&w.normal, &w.point),
            speed: dot(&w.normal, &v),
            one_sided: true,
            name: format!("rigid wall \"{}\"", w.name),
        });
    }
    out
}

/// Element-wise min (`max` false) or max over the ranks.
fn reduce(world: &SimpleCommunicator, mine: &[f64], max: bool) -> Vec<f64> {
    let mut out = vec![0.0; mine.len()];
    let op = if max {
        SystemOperation::max()
    } else {
        SystemOperation::min()
    };
    world.all_reduce_into(mine, &mut out[..], op);
    out
}

/// The most severe plastic impact of a fresh explicit run (the one whose estimate takes the
/// most steps to `scene.run.end_time` at a unit first step): a `j2_plastic` or `johnson_cook`
/// block with an initial velocity moving into a symmetry plane or a rigid wall. `None` where
/// there is none. Collective.
pub fn find(world: &SimpleCommunicator, scene: &Scene, fe: &Fe, groups: &Groups) -> Option<Impact> {
    let planes = planes(world, scene, fe, groups);
    let st = fe.state();
    let bodies: Vec<(usize, f64, f64)> = (scene.blocks.iter().enumerate())
        .filter(|(_, b)| b.velocity != [0.0; 3])
        .filter_map(|(i, b)| flow_stress_1(scene, &b.material).map(|(rho, s)| (i, rho, s)))
        .collect();
    if planes.is_empty() || bodies.is_empty() {
        return None;
    }
    // each body's range of n . x over its nodes, plane by plane: [body][plane]
    let np = planes.len();
    let mut lo = vec![f64::INFINITY; bodies.len() * np];
    let mut hi = vec![f64::NEG_INFINITY; bodies.len() * np];
    for e in 0..st.n_elements() {
        let blk = st.element_block(e);
        let Some(bi) = bodies.iter().position(|b| b.0 == blk) else {
            continue;
        };
        for &node in &st.element_nodes(e) {
            let x = &st.x0[node as usize];
            for (j, p) in planes.iter().enumerate() {
                let d = dot(&p.n, x);
                lo[bi * np + j] = lo[bi * np + j].min(d);
                hi[bi * np + j] = hi[bi * np + j].max(d);
            }
        }
    }
    let (lo, hi) = (reduce(world, &lo, false), reduce(world, &hi, true));
    let end = scene.run.end_time;
    let mut best: Option<(f64, Impact)> = None;
    for (bi, &(blk, rho, sigma)) in bodies.iter().enumerate() {
        let v = scene.blocks[blk].velocity;
        for (j, p) in planes.iter().enumerate() {
            let (a, b) = (lo[bi * np + j], hi[bi * np + j]);
            if !a.is_finite() {
                continue;
            }
            let length = b - a;
            let tol = 1e-6 * length.max(1e-300);
            // the body on the plane's positive side closes at (v_plane - v) . n, on its
            // negative side at (v - v_plane) . n
            let (gap, speed) = if a >= p.offset - tol {
                (a - p.offset, p.speed - dot(&v, &p.n))
            } else if !p.one_sided && b <= p.offset + tol {
                (p.offset - b, dot(&v, &p.n) - p.speed)
            } else {
                continue;
            };
            let severity = rho * speed * speed / sigma;
            let shrink = (C_K * severity).exp().min(K_MAX);
            if speed <= 0.0 || shrink < K_MIN || length <= 0.0 {
                continue;
            }
            let impact = Impact {
                body: scene.blocks[blk].group.clone(),
                against: p.name.clone(),
                speed,
                shrink,
                start: gap.max(0.0) / speed,
                duration: C_T * rho * length * speed / sigma,
            };
            let steps = impact.steps(1.0, end);
            if best.as_ref().is_none_or(|(s, _)| steps > *s) {
                best = Some((steps, impact));
            }
        }
    }
    best.map(|(_, i)| i)
}
