//! Particles that start inside a meshed body are a scene error (before anything is computed):
//! nothing would push them out (particle-face contact only sees crossings during a step, and
//! a particle that starts behind a face never crossed it), so they would stay inside silently,
//! and their mass and pressure would count twice in the same space.
//!
//! Every rank generates every particle position (`input::particles` makes all seeds before it
//! deals them out), so each rank tests them all against its own elements, in the reference
//! configuration, through a grid of the elements' boxes; the ranks then agree on the error of
//! the lowest rank that found one.
use crate::input::particles as particles_setup;
use crate::input::scene::Scene;
use crate::kernels::collective::first_error;
use fe_petsc::explicit::{ElementRef, ExplicitFe};
use fe_petsc::hex;
use mpi::topology::SimpleCommunicator;
use rustc_hash::FxHashMap as HashMap;

/// A particle centre counts as inside an element when its natural coordinates lie within
/// `[-1 + INSIDE_MARGIN, 1 - INSIDE_MARGIN]^3`: a lattice that starts on a body's face (a
/// particle resting on it) is not inside it.
const INSIDE_MARGIN: f64 = 1e-6;

/// The diagonal step, in mean element sizes, of the test for a particle on a face the body's
/// elements share (`first_inside`): far above [`INSIDE_MARGIN`], far below a particle spacing.
const PROBE_STEP: f64 = 1e-4;

/// Whether any particle of `scene` starts inside an element of `fe` (collective): the error
/// names the `[[particles]]` entry, the block, the element and the point.
pub fn check(world: &SimpleCommunicator, scene: &Scene, fe: &ExplicitFe) -> Result<(), String> {
    let mine = if scene.particles.is_empty() {
        None
    } else {
        first_inside(scene, fe)
    };
    first_error(world, mine)
}

/// This rank's first particle (in seed order) inside one of its elements, as the error line.
fn first_inside(scene: &Scene, fe: &ExplicitFe) -> Option<String> {
    let (seeds, _) = particles_setup::particles(scene, 0, 1).ok()?;
    let corners = |e: usize| -> [[f64; 3]; 8] {
        let conn = fe.element_nodes(e);
        std::array::from_fn(|k| fe.x0[conn[k] as usize])
    };
    // A grid of cells of the mean element size over the elements' boxes.
    let n = fe.n_elements();
    if n == 0 {
        return None;
    }
    let boxes: Vec<([f64; 3], [f64; 3])> = (0..n)
        .map(|e| {
            let x = corners(e);
            let lo = std::array::from_fn(|c| x.iter().map(|q| q[c]).fold(f64::INFINITY, f64::min));
            let hi =
                std::array::from_fn(|c| x.iter().map(|q| q[c]).fold(f64::NEG_INFINITY, f64::max));
            (lo, hi)
        })
        .collect();
    let size = boxes
        .iter()
        .map(|(lo, hi)| (0..3).map(|c| hi[c] - lo[c]).fold(0.0, f64::max))
        .sum::<f64>()
        / n as f64;
    if !(size > 0.0) {
        return None;
    }
    let cell = |p: [f64; 3]| -> [i64; 3] { std::array::from_fn(|c| (p[c] / size).floor() as i64) };
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::default();
    for (e, (lo, hi)) in boxes.iter().enumerate() {
        let (a, b) = (cell(*lo), cell(*hi));
        for i in a[0]..=b[0] {
            for j in a[1]..=b[1] {
                for k in a[2]..=b[2] {
                    grid.entry([i, j, k]).or_default().push(e as u32);
                }
            }
        }
    }
    // The element that holds `q` strictly inside (see `inside`), if any.
    let holder = |q: [f64; 3]| -> Option<usize> {
        let list = grid.get(&cell(q))?;
        list.iter().map(|&e| e as usize).find(|&e| {
            let (lo, hi) = boxes[e];
            (0..3).all(|c| q[c] > lo[c] && q[c] < hi[c]) && inside(fe, e, &corners(e), q)
        })
    };
    // A point on a face, an edge or a corner the body's elements share (a lattice that lines
    // up with a structured mesh) is inside none of them strictly, yet inside the body: it is
    // when every point a short step from it along the eight diagonals is inside an element
    // (a point on the body's outer face has a diagonal step leaving the body; the steps, of
    // PROBE_STEP element sizes, leave every face and edge the point lies on).
    let step = PROBE_STEP * size / 3f64.sqrt();
    let on_shared_face = |q: [f64; 3]| -> Option<usize> {
        let near = grid.get(&cell(q))?.iter().any(|&e| {
            let (lo, hi) = boxes[e as usize];
            (0..3).all(|c| q[c] >= lo[c] && q[c] <= hi[c])
        });
        if !near {
            return None;
        }
        let mut first = None;
        for d in 0..8 {
            let sign = |c: usize| if d >> c & 1 == 1 { 1.0 } else { -1.0 };
            let e = holder(std::array::from_fn(|c| q[c] + sign(c) * step))?;
            first.get_or_insert(e);
        }
        first
    };
    for s in &seeds {
        if let Some(e) = holder(s.x).or_else(|| on_shared_face(s.x)) {
            let def = &scene.particles[s.entry];
            let block = &scene.blocks[fe.element_block(e)].group;
            return Some(format!(
                "{}: particles[{}] \"{}\": a particle at ({}, {}, {}) starts inside block \"{block}\" (element {}): particle regions must not overlap meshed bodies (move the region, or shrink it by a particle spacing)",
                scene.file.display(),
                s.entry,
                def.name,
                s.x[0],
                s.x[1],
                s.x[2],
                fe.element_id(e)
            ));
        }
    }
    None
}

/// Whether `p` lies inside element `e` (its corners `x`, a tetrahedron collapsed as in
/// `ExplicitFe::element_nodes`) by more than [`INSIDE_MARGIN`]: a hexahedron's natural
/// coordinates within [-1 + margin, 1 - margin], a tetrahedron's barycentric ones above
/// margin / 2 (the same margin on the natural coordinates' [-1, 1] scale).
fn inside(fe: &ExplicitFe, e: usize, x: &[[f64; 3]; 8], p: [f64; 3]) -> bool {
    match fe.element(e) {
        ElementRef::Hex(_) => hex::natural_coords(x, p, 0.0)
            .is_some_and(|xi| xi.iter().all(|v| v.abs() < 1.0 - INSIDE_MARGIN)),
        ElementRef::Tet(_) => {
            let xt = [x[0], x[1], x[2], x[4]];
            let (g, _) = fe_petsc::tet::gradients(&xt);
            (0..4).all(|a| {
                let l = 0.25
                    + (0..3)
                        .map(|k| {
                            g[a][k] * (p[k] - 0.25 * (xt[0][k] + xt[1][k] + xt[2][k] + xt[3][k]))
                        })
                        .sum::<f64>();
                l > 0.5 * INSIDE_MARGIN
            })
        }
    }
}
