//! Test 5: two elastic bars meeting head on, with kinematic contact between them.
//!
//! Each bar is a chain of `N` lumped masses joined by springs (`k = E A / h`, node mass `rho A h`,
//! half at the ends): a bar of length `L` whose long waves travel at `c = sqrt(E / rho)`. The bars
//! approach at `+v0` and `-v0`. Reference (1D elastic impact of equal bars, e.g. Graff, "Wave
//! Motion in Elastic Solids", §2.3): a compression wave runs from the contact to each free end and
//! returns as tension; the bars separate after `2 L / c`, each with the other's velocity (they
//! exchange velocities). Tolerances: contact duration and each bar's mean velocity after
//! separation within 5 %; total momentum conserved at every step to 1e-14 of `M v0` (the contact
//! forces sum to zero to round-off).
//!
//! The contact pair in the box: the end node of bar A (a contact node) against a square face
//! whose four corners all move with the end node of bar B (each carrying a quarter of its mass;
//! the face's outward normal points at bar A). The driver sums the forces on the four corners onto
//! that end node. Central differences; the step is a fraction of the chain's stable step `h / c`.

use contact::{
    push_back, search, ContactBox, FaceRecord, NodeRecord, PushBackParams, SearchParams,
};

const YOUNG: f64 = 1.0;
const DENSITY: f64 = 1.0;
const AREA: f64 = 1.0;
const LENGTH: f64 = 1.0;
const NODES: usize = 101;
const V0: f64 = 0.01;
const COURANT: f64 = 0.5;
const DURATION_TOL: f64 = 0.05;
const VELOCITY_TOL: f64 = 0.05;
const MOMENTUM_TOL: f64 = 1e-14;
/// Half-width of the contact face (any size: the bar is 1D).
const FACE_HALF_WIDTH: f64 = 0.5;

struct Chain {
    x: Vec<f64>,
    v: Vec<f64>,
    m: Vec<f64>,
    h: f64,
    k: f64,
}

impl Chain {
    fn new(x_left: f64, velocity: f64) -> Chain {
        let h = LENGTH / (NODES - 1) as f64;
        let mut m = vec![DENSITY * AREA * h; NODES];
        m[0] *= 0.5;
        m[NODES - 1] *= 0.5;
        Chain {
            x: (0..NODES).map(|i| x_left + i as f64 * h).collect(),
            v: vec![velocity; NODES],
            m,
            h,
            k: YOUNG * AREA / h,
        }
    }

    /// `v += dt f / m` with the spring forces.
    fn kick(&mut self, dt: f64) {
        let mut f = vec![0.0; NODES];
        for i in 0..NODES - 1 {
            let t = self.k * (self.x[i + 1] - self.x[i] - self.h);
            f[i] += t;
            f[i + 1] -= t;
        }
        for ((v, f), m) in self.v.iter_mut().zip(&f).zip(&self.m) {
            *v += dt * f / m;
        }
    }

    fn momentum(&self) -> f64 {
        self.m.iter().zip(&self.v).map(|(m, v)| m * v).sum()
    }

    fn mass(&self) -> f64 {
        self.m.iter().sum()
    }
}

/// The contact box of one step: bar A's right end node (gid 0) and bar B's left end face (gids
/// 1-4, corners counter-clockwise seen from -x).
fn contact_box(a: &Chain, b: &Chain, dt: f64) -> ContactBox {
    let ia = NODES - 1;
    let xa0 = a.x[ia];
    let xb0 = b.x[0];
    let mut nodes = vec![NodeRecord {
        gid: 0,
        body: 0,
        flags: 0,
        mass: a.m[ia],
        radius: 0.0,
        x0: [xa0, 0.0, 0.0],
        x1: [xa0 + dt * a.v[ia], 0.0, 0.0],
        v: [a.v[ia], 0.0, 0.0],
    }];
    let w = FACE_HALF_WIDTH;
    // (y, z) of the corners: xi along z, eta along y, so X_xi x X_eta = z x y = -x.
    let corners = [[-w, -w], [-w, w], [w, w], [w, -w]];
    for (i, c) in corners.iter().enumerate() {
        nodes.push(NodeRecord {
            gid: 1 + i as u64,
            body: 1,
            flags: 0,
            mass: 0.25 * b.m[0],
            radius: 0.0,
            x0: [xb0, c[0], c[1]],
            x1: [xb0 + dt * b.v[0], c[0], c[1]],
            v: [b.v[0], 0.0, 0.0],
        });
    }
    let faces = [FaceRecord {
        gid: 0,
        nodes: [1, 2, 3, 4],
        body: 1,
        reserved: 0,
    }];
    ContactBox::from_records(&nodes, nodes.len(), &faces).unwrap()
}

#[test]
fn bars_rebound_after_two_transit_times() {
    let c = (YOUNG / DENSITY).sqrt();
    let h = LENGTH / (NODES - 1) as f64;
    let dt = COURANT * h / c;
    let gap = 2.5 * (2.0 * V0 * dt);
    let mut a = Chain::new(-0.5 * gap - LENGTH, V0);
    let mut b = Chain::new(0.5 * gap, -V0);
    let p_scale = (a.mass() + b.mass()) * V0;
    let p0 = a.momentum() + b.momentum();
    let t_expected = 2.0 * LENGTH / c;
    let steps = ((t_expected * 1.3) / dt) as usize;
    let mut first = None;
    let mut last = None;
    let mut intervals = 0;
    let mut was_in_contact = false;
    let mut worst_p: f64 = 0.0;
    let mut contact_work = 0.0;
    let mut half_step_ke_change = 0.0;
    let ke0: f64 = [&a, &b]
        .iter()
        .map(|ch| {
            ch.m.iter()
                .zip(&ch.v)
                .map(|(m, v)| 0.5 * m * v * v)
                .sum::<f64>()
        })
        .sum();
    let params = SearchParams::default();
    for step in 0..steps {
        a.kick(dt);
        b.kick(dt);
        let cb = contact_box(&a, &b, dt);
        let contacts = search(&cb, &params);
        if !contacts.is_empty() {
            let pb = push_back(&cb, &contacts, &PushBackParams::new(dt));
            a.v[NODES - 1] += pb.force[0][0] * dt / a.m[NODES - 1];
            let f_b: f64 = pb.force[1..].iter().map(|f| f[0]).sum();
            b.v[0] += f_b * dt / b.m[0];
            contact_work += pb.work;
            half_step_ke_change += pb.kinetic_energy_change;
            first.get_or_insert(step);
            last = Some(step);
            if !was_in_contact {
                intervals += 1;
            }
        }
        was_in_contact = !contacts.is_empty();
        for ch in [&mut a, &mut b] {
            for i in 0..NODES {
                ch.x[i] += dt * ch.v[i];
            }
        }
        let dp = (a.momentum() + b.momentum() - p0).abs() / p_scale;
        worst_p = worst_p.max(dp);
        assert!(
            dp <= MOMENTUM_TOL,
            "step {step}: momentum drift {dp:.3e} of M v0"
        );
    }
    let (first, last) = (first.expect("the bars never met"), last.unwrap());
    assert!(last + 10 < steps, "still in contact at the end");
    let duration = (last + 1 - first) as f64 * dt;
    let va = a.momentum() / a.mass();
    let vb = b.momentum() / b.mass();
    let ke1: f64 = [&a, &b]
        .iter()
        .map(|ch| {
            ch.m.iter()
                .zip(&ch.v)
                .map(|(m, v)| 0.5 * m * v * v)
                .sum::<f64>()
        })
        .sum();
    println!(
        "rebound: contact {duration:.4} (2L/c = {t_expected}), {intervals} contact interval(s); \
         mean velocities after: A {va:.6e}, B {vb:.6e} (v0 = {V0}); momentum drift {worst_p:.2e} M v0; \
         contact work {contact_work:.3e} J, half-step kinetic energy change {half_step_ke_change:.3e} J, \
         kinetic energy before {ke0:.4e} J, after {ke1:.4e} J"
    );
    assert!(
        (duration - t_expected).abs() <= DURATION_TOL * t_expected,
        "contact lasted {duration}, expected 2L/c = {t_expected} within {DURATION_TOL}"
    );
    assert!(
        (va + V0).abs() <= VELOCITY_TOL * V0,
        "bar A mean velocity {va}, expected {}",
        -V0
    );
    assert!(
        (vb - V0).abs() <= VELOCITY_TOL * V0,
        "bar B mean velocity {vb}, expected {V0}"
    );
}
