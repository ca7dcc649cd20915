//! The rigid walls of a scene (`[[rigid_wall]]`, docs/scene.md): infinite planes that no mesh
//! node and no particle passes (a particle's centre stays its contact radius from the plane,
//! as from a mesh face: `SphStage::contact_radius`), applied after the drift (and after the contact stage's
//! push-back, so that nothing the push-back moves ends behind a wall).
//!
//! Its own constraint, not the contact machinery: a wall is one plane known to every rank, and a
//! node's correction ([`contact::Wall::correction`]) is a function of that node's own position
//! and velocity alone. Every copy of a node shared between ranks holds the same bits (the FE
//! stage integrates ghosts with the same summed force as their owner), so every copy takes the
//! same correction with no exchange, no search and no decomposition; a particle has one owner.
//! Through the contact stage the plane would need faces of finite size, a search over them, a
//! move to the contact decomposition and back, and a `[contact]` table the scene may not have.
//!
//! The correction goes through the stages' own push-back interfaces
//! (`stages::fe::apply_contact`, `SphStage::apply_contact`), which apply a node's constraints
//! and return the step's change of kinetic energy beyond what the element, pair and gravity
//! work count, `dK = sum m dv . (v(n+1/2) + dv/2 - a(n) dt/2)`, booked as the contact stage
//! books its corrections (`contact::energy`). The wall's reaction, the force
//! it applies to the bodies, is the impulse it gives, `J = sum m dv` over owned nodes and
//! particles on the momentum grids (exact: the same bits at any rank count); reactions.csv
//! shows its mean over each row's interval (`Walls::forces`).
//!
//! Energy: a wall moving at `W` does the work `W . J` on the bodies in the step (in the wall's
//! frame it does none: there `dK' = dK - W . J`, the kinetic energy of the relative motion the
//! inelastic correction removed, `<= 0`). That work is the prescribed motion's, like a velocity
//! boundary's, and goes to `external_work`; what the correction dissipated, `W . J - dK`, goes
//! to `contact_energy` (`>= 0`: energy the walls took). A wall at rest does no work.
//!
//! A wall with a load curve `s(t)` (`curve`) moves at `s(t) W`: over the step `[t, t + dt]` its
//! plane is the one through `p + W I(t + dt)` at the step's end, `I(t) = integral of s from 0 to
//! t` ([`Curve::integral`], exact for the piecewise-linear curve), and it moves at the step's
//! mean velocity `W (I(t + dt) - I(t)) / dt` ([`Curve::mean`]): the velocity that carries it
//! from the last step's plane to this one, so a node held on it follows `p + W I(t)` to
//! round-off, and `W . J` takes that mean velocity. Without a curve the wall is the constant
//! `p + W t` of [`contact::Wall`].
//!
//! **Implicit mode.** There a wall is a constraint inside the Newmark step, not a correction
//! after a drift: the walls of the step (plane at its end, mean velocity) go to the implicit
//! integrator before it ([`Walls::step`]), which holds the nodes in contact on them by an active
//! set in Newton (`fe_petsc::implicit::WallPlane`, its module doc), and its impulses and the
//! energy the walls took come back after it ([`Walls::after_implicit`]), booked as above.
use super::fe::Fe;
use super::fe::Integrator;
use super::sph::Sph;
use crate::input::curve::Curve;
use crate::input::scene::RigidWallDef;
use crate::kernels::collective;
use crate::output::state::{StateReader, StateWriter};
use contact::Wall;
use fe_petsc::exact::{self as exact_sum, Folds};
use fe_petsc::explicit::WallHold;
use fe_petsc::implicit::WallPlane;
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::time::Instant;

/// The rigid walls of a run.
pub struct Walls {
    walls: Vec<Wall>,
    /// Each wall's load curve scaling its velocity (`None`: constant).
    curves: Vec<Option<Curve>>,
    /// The walls' names, in scene order (reactions.csv's columns).
    pub names: Vec<String>,
    /// Energy the walls took from the bodies so far, J: their work less the change of kinetic
    /// energy their corrections made beyond the element, pair and gravity work.
    pub energy: f64,
    /// The moving walls' work on the bodies so far, `sum W . J`, J.
    pub work: f64,
    /// The impulse each wall gave to the bodies since the last history row, N s (global).
    impulse: Vec<[f64; 3]>,
    /// The time of the last history row, s.
    row_time: f64,
    /// Wall time of the walls' corrections on this rank, s.
    pub wall_s: f64,
    /// Implicit mode: the walls' mean velocities over the present step.
    step_velocities: Vec<[f64; 3]>,
}

/// A wall's correction of every FE node (or particle) it pushes back, as the push-back forces
/// `m dv / dt` (zero elsewhere) that `apply_contact` takes, or `None` when it touches none.
fn forces_of(
    wall: &Wall,
    (t, dt): (f64, f64),
    nodes: impl Iterator<Item = (usize, [f64; 3], [f64; 3], f64)>,
    len: usize,
) -> Option<Vec<[f64; 3]>> {
    let mut f: Option<Vec<[f64; 3]>> = None;
    for (i, x, v, m) in nodes {
        if let Some(dv) = wall.correction(x, v, t, dt) {
            let f = f.get_or_insert_with(|| vec![[0.0; 3]; len]);
            f[i] = dv.map(|c| m * c / dt);
        }
    }
    f
}

impl Walls {
    /// The scene's walls (normals already of unit length), or `None` without any.
    pub fn new(defs: &[RigidWallDef]) -> Option<Walls> {
        if defs.is_empty() {
            return None;
        }
        Some(Walls {
            walls: defs
                .iter()
                .map(|d| Wall {
                    point: d.point,
                    normal: d.normal,
                    velocity: d.velocity.unwrap_or([0.0; 3]),
                    friction: d.friction,
                })
                .collect(),
            curves: defs
                .iter()
                .map(|d| {
                    d.curve
                        .as_ref()
                        .map(|raw| Curve::new(raw.iter().map(|p| (p[0], p[1])).collect()))
                })
                .collect(),
            names: defs.iter().map(|d| d.name.clone()).collect(),
            energy: 0.0,
            work: 0.0,
            impulse: vec![[0.0; 3]; defs.len()],
            row_time: 0.0,
            wall_s: 0.0,
            step_velocities: Vec::new(),
        })
    }

    /// Refuses a scene whose bodies start behind a wall (collective: every rank returns the
    /// same): each owned mesh node that is not `fixed` or velocity-prescribed and each moving
    /// particle (its contact radius from its centre) at t = 0 more than 1e-9 of the model's
    /// size behind its plane. The wall would
    /// put them all back on the plane in the first step, its impulse the bodies' whole
    /// overlap over one step, and the run would stop on the energy check with nothing said of
    /// the wall.
    pub fn check_start(
        &self,
        world: &SimpleCommunicator,
        fe: Option<&Fe>,
        sph: Option<&Sph>,
        file: &str,
    ) -> Result<(), String> {
        // (point, its contact radius, 0 for a mesh node or 1 for a particle)
        let mut points: Vec<([f64; 3], f64, usize)> = Vec::new();
        if let Some(fe) = fe {
            let st = fe.state();
            let held = st.fully_constrained();
            let free = (0..st.x.len()).filter(|&n| st.owned[n] && !held[n]);
            points.extend(free.map(|n| (st.x[n], 0.0, 0)));
        }
        if let Some(sph) = sph {
            let (stage, p) = (&sph.stage, &sph.stage.parts);
            let moving = (0..p.n_owned).filter(|&i| !p.fixed[i]);
            points.extend(moving.map(|i| (p.x_real[i], stage.contact_radius(i), 1)));
        }
        let size = points
            .iter()
            .flat_map(|(x, _, _)| x.iter().map(|c| c.abs()))
            .fold(0.0f64, f64::max);
        let tol = 1e-9 * collective::max(world, size);
        for (k, wall) in self.walls.iter().enumerate() {
            let (mut behind, mut deepest) = ([0.0f64; 2], 0.0f64);
            for &(x, r, kind) in &points {
                let d = wall.distance(x, 0.0) - r;
                if d < -tol {
                    behind[kind] += 1.0;
                    deepest = deepest.min(d);
                }
            }
            let behind = behind.map(|b| collective::sum(world, b));
            let deepest = collective::min(world, deepest);
            if behind[0] + behind[1] > 0.0 {
                let n = wall.normal;
                // a particle whose centre is on the plane or in front of it is behind it too
                let spheres = if behind[1] > 0.0 {
                    " (a particle counts from its contact radius, half the spacing it was seeded at, around its centre: its sphere must not cross the plane)"
                } else {
                    ""
                };
                return Err(format!(
                    "{file}: rigid_wall[{k}] (\"{}\"): {} mesh nodes and {} particles start behind the wall, the deepest {:.3e} m behind its plane{spheres}; the bodies must start on the side its normal [{:.4}, {:.4}, {:.4}] points to: move its point or turn its normal",
                    self.names[k], behind[0], behind[1], -deepest, n[0], n[1], n[2]
                ));
            }
        }
        Ok(())
    }

    /// After the drift to `t1 = t + dt` (and the contact push-back): every FE node (all local
    /// copies) and every owned moving particle behind a wall put back on it, wall by wall in
    /// scene order; the energy and the impulses summed over ranks in one reduction
    /// (collective).
    pub fn step(
        &mut self,
        world: &SimpleCommunicator,
        mut fe: Option<&mut Fe>,
        sph: Option<&mut Sph>,
        (t1, dt): (f64, f64),
    ) {
        let t0 = Instant::now();
        let walls = self.walls_of_step(t1, dt);
        if let Some(Integrator::Implicit(imp)) = fe.as_mut().map(|f| &mut f.integrator) {
            // Implicit: the planes at the step's end go into Newton (module doc).
            let planes = walls
                .iter()
                .map(|(w, t)| WallPlane {
                    point: std::array::from_fn(|c| w.point[c] + w.velocity[c] * t),
                    normal: w.normal,
                    velocity: w.velocity,
                    friction: w.friction,
                })
                .collect();
            imp.set_wall_planes(planes);
            self.step_velocities = walls.iter().map(|(w, _)| w.velocity).collect();
            self.wall_s += t0.elapsed().as_secs_f64();
            return;
        }
        let nw = walls.len();
        // [FE work, particles' work, then per wall FE impulse x, y, z and particles' x, y, z]:
        // each on its own stage's grid, added once reduced.
        let mut folds: Vec<Folds> = vec![[0.0; 3]; 2 + 6 * nw];
        if let Some(fe) = fe {
            fe_step(&walls, fe, dt, &mut folds);
        }
        if let Some(sph) = sph {
            sph_step(&walls, sph, dt, &mut folds);
        }
        let flat = exact_sum::flatten(&folds);
        let mut g = vec![0.0f64; flat.len()];
        world.all_reduce_into(&flat[..], &mut g[..], SystemOperation::sum());
        let g = exact_sum::values(&g);
        let impulses: Vec<[f64; 3]> = (0..nw)
            .map(|k| std::array::from_fn(|c| g[2 + 6 * k + c] + g[5 + 6 * k + c]))
            .collect();
        let velocities: Vec<[f64; 3]> = walls.iter().map(|(w, _)| w.velocity).collect();
        let work = self.book(&impulses, &velocities);
        self.energy += work - (g[0] + g[1]);
        self.step_velocities = velocities;
        self.wall_s += t0.elapsed().as_secs_f64();
    }

    /// Sizes the SPH stage's per-wall hold impulses (`SphStage::hold_impulse`) to the walls and
    /// gives it their normals (`SphStage::wall_normals`).
    pub fn size_holds(&self, sph: &mut Sph) {
        sph.stage.hold_impulse = vec![[[0.0; 3]; 3]; self.impulse.len()];
        sph.stage.wall_normals = self.walls.iter().map(|w| w.normal).collect();
        sph.stage.rough_walls = self.walls.iter().map(|w| w.friction > 0.0).collect();
    }

    /// After the step's closing kicks (collective): the impulses the walls' holds gave the
    /// particles (`SphStage::hold_on_faces`, summed over ranks) and the mesh nodes
    /// (`ExplicitFe::set_wall_holds`, summed here), added to the walls' and their work `W . J`
    /// to the walls' energy. The particles' holds' change of the kinetic energy is the SPH
    /// stage's (`Sph::hold_taken`), the nodes' is booked here: the two together with the work
    /// are what the walls took.
    pub fn after_holds(&mut self, world: &SimpleCommunicator, fe: Option<&Fe>, sph: Option<&Sph>) {
        if let Some(Integrator::Explicit(state)) = fe.map(|f| &f.integrator) {
            let local = state.wall_hold_sums();
            if local.len() == 1 + 3 * self.impulse.len() {
                let flat = exact_sum::flatten(local);
                let mut g = vec![0.0f64; flat.len()];
                world.all_reduce_into(&flat[..], &mut g[..], SystemOperation::sum());
                let g = exact_sum::values(&g);
                let impulses: Vec<[f64; 3]> = (0..self.impulse.len())
                    .map(|k| std::array::from_fn(|c| g[1 + 3 * k + c]))
                    .collect();
                let velocities = self.step_velocities.clone();
                let work = self.book(&impulses, &velocities);
                self.energy += work - g[0];
            }
        }
        let Some(sph) = sph else {
            return;
        };
        let impulses = &sph.globals.hold_impulses;
        if impulses.len() != self.impulse.len() || self.step_velocities.len() != impulses.len() {
            return;
        }
        let velocities = self.step_velocities.clone();
        let work = self.book(impulses, &velocities);
        self.energy += work;
    }

    /// After an implicit step: its walls' impulses and the energy they took, from the
    /// integrator (module doc). Every rank holds the same global values.
    pub fn after_implicit(&mut self, fe: Option<&Fe>) {
        let Some(Integrator::Implicit(imp)) = fe.map(|f| &f.integrator) else {
            return;
        };
        let Some((impulses, taken)) = imp.wall_step() else {
            return;
        };
        let velocities = std::mem::take(&mut self.step_velocities);
        // What the walls took: their work and what the integrator found unexplained by the
        // other forces in the kinetic energy of the nodes in contact.
        let work = self.book(impulses, &velocities);
        self.energy += work + taken;
    }

    /// Adds a step's impulses of the walls (moving at `velocities`) to the row's, and their
    /// work `W . J` to the run's; returns that work.
    fn book(&mut self, impulses: &[[f64; 3]], velocities: &[[f64; 3]]) -> f64 {
        let mut work = 0.0;
        for ((imp, j), w) in self.impulse.iter_mut().zip(impulses).zip(velocities) {
            for c in 0..3 {
                imp[c] += j[c];
                work += w[c] * j[c];
            }
        }
        self.work += work;
        work
    }

    /// The walls as they stand over the step to `t1` (scene order), each with the time at
    /// which [`Wall::correction`] is to place it: a wall without a curve as given, at `t1`; one
    /// with a curve moved to its plane at `t1` and its mean velocity over the step (module
    /// doc), at time 0.
    fn walls_of_step(&self, t1: f64, dt: f64) -> Vec<(Wall, f64)> {
        self.walls
            .iter()
            .zip(&self.curves)
            .map(|(w, curve)| match curve {
                None => (*w, t1),
                Some(c) => {
                    let (moved, mean) = (c.integral(0.0, t1), c.mean(t1 - dt, dt));
                    let wall = Wall {
                        point: std::array::from_fn(|k| w.point[k] + w.velocity[k] * moved),
                        velocity: w.velocity.map(|v| v * mean),
                        ..*w
                    };
                    (wall, 0.0)
                }
            })
            .collect()
    }

    /// Each wall's force on the bodies for the history row at `time`, N: the impulse it gave
    /// since the last row over the time since then (the mean force over the row's interval,
    /// so that the rows' forces times their intervals sum to the impulse exactly; a step's
    /// impulse over dt when a row is written every step). Zero at the first row.
    pub fn forces(&self, time: f64) -> Vec<[f64; 3]> {
        let span = time - self.row_time;
        self.impulse
            .iter()
            .map(|i| {
                if span > 0.0 {
                    i.map(|c| c / span)
                } else {
                    [0.0; 3]
                }
            })
            .collect()
    }

    /// A history row was written at `time`: the next row's impulses start from zero.
    pub fn row_written(&mut self, time: f64) {
        self.row_time = time;
        for i in &mut self.impulse {
            *i = [0.0; 3];
        }
    }

    /// Writes the walls' state (global values, the same on every rank): the energy, the work,
    /// the last row's time and the impulses since. The planes are a function of time.
    pub fn save(&self, w: &mut StateWriter) {
        let mut s = vec![self.energy, self.work, self.row_time];
        s.extend(self.impulse.iter().flatten());
        w.put("rigid_walls.state", &s);
    }

    /// Sets the state `save` wrote.
    pub fn restore(&mut self, r: &StateReader) -> Result<(), String> {
        let s: Vec<f64> = r.get("rigid_walls.state")?;
        if s.len() != 3 + 3 * self.impulse.len() {
            return Err("checkpoint: rigid_walls.state".into());
        }
        self.energy = s[0];
        self.work = s[1];
        self.row_time = s[2];
        for (k, i) in self.impulse.iter_mut().enumerate() {
            *i = [s[3 + 3 * k], s[4 + 3 * k], s[5 + 3 * k]];
        }
        Ok(())
    }
}

/// The FE nodes' corrections by `walls` (each with its time, [`Walls::walls_of_step`]): work
/// into `folds[0]`, wall k's impulse into `folds[2 + 6k..5 + 6k]`: `m (v' - v)` over the owned
/// nodes it touched, the velocity change `apply_contact` made (its constraints applied: a
/// fixed node takes none).
fn fe_step(walls: &[(Wall, f64)], fe: &mut Fe, dt: f64, folds: &mut [Folds]) {
    let state = fe.state_mut();
    let grid = state.grids.momentum;
    // the nodes each wall put back (every local copy), held through the closing kick
    let mut holds = Vec::new();
    for (k, &(wall, t)) in walls.iter().enumerate() {
        let nodes = (0..state.n_nodes()).map(|n| (n, state.x[n], state.v[n], state.mass[n]));
        let Some(f) = forces_of(&wall, (t, dt), nodes, state.n_nodes()) else {
            continue;
        };
        let touched: Vec<(usize, [f64; 3])> = (0..f.len())
            .filter(|&n| f[n] != [0.0; 3] && state.owned[n])
            .map(|n| (n, state.v[n]))
            .collect();
        holds.extend(
            (0..f.len())
                .filter(|&n| f[n] != [0.0; 3])
                .map(|n| WallHold {
                    node: n as u32,
                    normal: wall.normal,
                    wall: k,
                    velocity: wall.velocity,
                    friction: wall.friction,
                }),
        );
        let w = super::fe::apply_contact(state, &f, dt);
        exact_sum::merge(&mut folds[0], &w);
        for (n, v0) in touched {
            for c in 0..3 {
                grid.add(
                    &mut folds[2 + 6 * k + c],
                    state.mass[n] * (state.v[n][c] - v0[c]),
                );
            }
        }
    }
    state.set_wall_holds(holds, walls.len());
}

/// The owned moving particles' corrections by `walls` (each with its time): work into
/// `folds[1]`, wall k's impulse into `folds[5 + 6k..8 + 6k]`, `m (v' - v)`.
fn sph_step(walls: &[(Wall, f64)], sph: &mut Sph, dt: f64, folds: &mut [Folds]) {
    let stage = &mut sph.stage;
    let grid = stage.grids.momentum;
    for (k, &(wall, t)) in walls.iter().enumerate() {
        let p = &stage.parts;
        // a particle's point nearest the plane, its contact radius from its centre
        let n = wall.normal;
        let nodes = (0..p.n_owned).filter(|&i| !p.fixed[i]).map(|i| {
            let r = stage.contact_radius(i);
            let x: [f64; 3] = std::array::from_fn(|c| p.x_real[i][c] - r * n[c]);
            (i, x, p.v[i], p.m[i])
        });
        let Some(f) = forces_of(&wall, (t, dt), nodes, p.n_owned) else {
            continue;
        };
        let touched: Vec<(usize, [f64; 3])> = (0..f.len())
            .filter(|&i| f[i] != [0.0; 3])
            .map(|i| (i, p.v[i]))
            .collect();
        // The wall cannot give way: a particle it touched is held on it through the step's
        // closing half-kick too (`SphStage::hold_on_faces`), as on an immovable face; that
        // hold's impulse comes back to the wall after the kick (`Walls::after_holds`).
        let tag = u8::try_from(2 + k).expect("at most 253 rigid walls");
        let held: Vec<u8> = f
            .iter()
            .map(|v| if *v != [0.0; 3] { tag } else { 0 })
            .collect();
        let w = stage.apply_contact(&f, &held, dt);
        exact_sum::merge(&mut folds[1], &w);
        let p = &stage.parts;
        for (i, v0) in touched {
            for c in 0..3 {
                grid.add(&mut folds[5 + 6 * k + c], p.m[i] * (p.v[i][c] - v0[c]));
            }
        }
    }
}
