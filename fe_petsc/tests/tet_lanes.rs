//! The tetrahedron's lane kernel (`batch::TetBatch`, every width this CPU runs) against the
//! scalar second pass (`tet::update`), which is the reference: randomly distorted tetrahedra
//! driven through steps of a velocity field with random nodal parts and random nodal averages,
//! for the elastic and J2 laws (in lanes), Johnson-Cook with thermal softening and a fluid's
//! equation of state (called lane by lane). Every width must agree with the reference to
//! `TOL` and give the same bits as every other width. No MPI, no PETSc.
use fe_petsc::batch::{self, LaneMaterial, TetBatch, TetInput, Width};
use fe_petsc::hex::{ElementError, HexControls};
use fe_petsc::material::{build_material, EosSpec, Material, MaterialSpec};
use fe_petsc::tet::{self, TetAverages, TetOutput, TetState};

/// Relative agreement required with `tet::update`. The lane kernel runs its operations in its
/// order except for the rotation (the Cayley closed form rather than cofactors), the lane laws'
/// forms and 1/V from one reciprocal of V V(n+1/2): round-off apart. A transcription error
/// shows at 1e-8 or more.
const TOL: f64 = 1e-12;

/// Tetrahedra per test: three groups of eight and a part group (padded).
const ELEMS: usize = 27;

/// A small deterministic generator (an LCG with Knuth's constants), uniform in [-0.5, 0.5).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
    }
}

fn solid(model: &str, extra: &[(&str, f64)]) -> Box<dyn Material> {
    let mut params = vec![("youngs_modulus", 200e9), ("poisson_ratio", 0.3)];
    params.extend_from_slice(extra);
    build_material(&MaterialSpec {
        name: "steel".into(),
        model: model.into(),
        density: 7850.0,
        params: params.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
        eos: None,
    })
    .unwrap()
}

/// Johnson-Cook with thermal softening and adiabatic heating (a 42CrMo4 steel).
fn johnson_cook() -> Box<dyn Material> {
    solid(
        "johnson_cook",
        &[
            ("a", 806e6),
            ("b", 614e6),
            ("n", 0.168),
            ("c", 0.0089),
            ("eps_dot0", 1.0),
            ("m", 1.1),
            ("t_room", 293.15),
            ("t_melt", 1813.15),
            ("specific_heat", 460.0),
        ],
    )
}

/// An ideal gas at 1 bar (gamma 1.4, rho 1.2 kg/m^3), heated by the bulk viscosity: the
/// EOS's wave modulus and heating called lane by lane.
fn gas() -> Box<dyn Material> {
    build_material(&MaterialSpec {
        name: "air".into(),
        model: "fluid".into(),
        density: 1.2,
        params: Default::default(),
        eos: Some(EosSpec {
            kind: "ideal_gas".into(),
            params: [("gamma".to_string(), 1.4), ("e0".to_string(), 1e5 / 0.48)]
                .into_iter()
                .collect(),
        }),
    })
    .unwrap()
}

/// `n` tetrahedra of size about `h` (each with its own nodes), the corners of the unit
/// reference tetrahedron scaled by `h`, each moved by up to 30 % of `h`, in random places.
fn tetrahedra(n: usize, h: f64, rng: &mut Lcg) -> Vec<[[f64; 3]; 4]> {
    let corners = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    (0..n)
        .map(|_| {
            let at = [rng.next(), rng.next(), rng.next()].map(|c| 10.0 * h * c);
            corners.map(|p| std::array::from_fn(|k| at[k] + h * (p[k] + 0.6 * rng.next())))
        })
        .collect()
}

/// Largest |a - b| over the largest |a| of a quantity over all elements and steps.
#[derive(Default)]
struct Diff {
    err: f64,
    scale: f64,
}
impl Diff {
    fn add(&mut self, a: &[f64], b: &[f64]) {
        for (p, q) in a.iter().zip(b) {
            self.err = self.err.max((p - q).abs());
            self.scale = self.scale.max(p.abs());
        }
    }
    fn check(&self, what: &str, case: &str) {
        let rel = self.err / self.scale.max(f64::MIN_POSITIVE);
        println!("{case}: {what} differ by {rel:e} relative (tolerance {TOL:e})");
        assert!(
            rel <= TOL,
            "{case}: the lane kernel's {what} differ from tet::update's by {rel:e} relative \
             to the largest {:e}; tolerance {TOL:e}",
            self.scale
        );
    }
}

const QUANTITIES: [&str; 5] = ["stresses", "forces", "volumes", "stable steps", "pressures"];

/// The quantities compared of one element's update.
fn quantities(stress: &[f64; 6], o: &TetOutput) -> [Vec<f64>; 5] {
    [
        stress.to_vec(),
        o.force.as_flattened().to_vec(),
        vec![o.volume],
        vec![o.dt_stable],
        vec![o.pressure],
    ]
}

/// The inputs of one step: positions, velocities and each element's nodal averages.
struct Step {
    x: Vec<[[f64; 3]; 4]>,
    v: Vec<[[f64; 3]; 4]>,
    avg: Vec<TetAverages>,
}

/// `steps` steps of `ELEMS` tetrahedra: a compression along x with shear (3e3 1/s, yielding
/// within a few steps) plus random nodal velocities of the same size, moved by dt v each step;
/// nodal averages theta within 50 % of the element's own volumetric rate (either sign) and
/// J within 2 % of 1.
fn steps(n_steps: usize, dt: f64) -> Vec<Step> {
    let mut rng = Lcg(0x7e7_1a9e5);
    let h = 0.01;
    let rate = 3e3;
    let mut x = tetrahedra(ELEMS, h, &mut rng);
    let v: Vec<[[f64; 3]; 4]> = x
        .iter()
        .map(|xe| {
            xe.map(|p| {
                let r = [rng.next(), rng.next(), rng.next()];
                [
                    -rate * p[0] + rate * h * r[0],
                    0.3 * rate * p[0] + 0.5 * rate * p[2] + rate * h * r[1],
                    0.2 * rate * p[1] + rate * h * r[2],
                ]
            })
        })
        .collect();
    let mut out = Vec::new();
    for _ in 0..n_steps {
        for (xe, ve) in x.iter_mut().zip(&v) {
            for (p, w) in xe.iter_mut().zip(ve) {
                for c in 0..3 {
                    p[c] += dt * w[c];
                }
            }
        }
        let avg = x
            .iter()
            .zip(&v)
            .map(|(xe, ve)| {
                let r = tet::rates(xe, ve, dt).expect("no inverted element");
                TetAverages {
                    theta: r.vol_rate / r.vol_mid * (1.0 + rng.next()),
                    j: 1.0 + 0.04 * rng.next(),
                }
            })
            .collect();
        out.push(Step {
            x: x.clone(),
            v: v.clone(),
            avg,
        });
    }
    out
}

/// Runs the steps through `tet::update` and through the lane kernel `B` (groups of
/// consecutive elements, the last padded with copies of its first), compares them, and
/// returns the lane kernel's results as bits (for the comparison between widths) and how many
/// element-steps increased the first history value (plastic flow).
fn compare<B: TetBatch>(mat: &dyn Material, case: &str, steps: &[Step]) -> (Vec<u64>, usize) {
    let ctl = HexControls::default();
    let lm = LaneMaterial::new(mat, &ctl);
    let case = &format!("{case}, {} lanes", B::LANES);
    let ns = mat.n_state();
    let dt = 1e-7;
    let vol0: Vec<f64> = steps[0].x.iter().map(|xe| tet::gradients(xe).1).collect();
    let mut st_s = vec![TetState::default(); ELEMS];
    let mut ms_s = vec![0.0; ELEMS * ns];
    for e in 0..ELEMS {
        mat.init_state(&mut ms_s[e * ns..(e + 1) * ns]);
    }
    let (mut st_b, mut ms_b) = (st_s.clone(), ms_s.clone());
    let mut g = B::default();
    let mut bits = Vec::new();
    let mut flowed = 0;
    let mut diffs: [Diff; 5] = Default::default();
    let mut d_hist: Vec<Diff> = (0..ns).map(|_| Diff::default()).collect();
    for s in steps {
        for g0 in (0..ELEMS).step_by(B::LANES) {
            let n = B::LANES.min(ELEMS - g0);
            for l in 0..B::LANES {
                let e = g0 + if l < n { l } else { 0 };
                let input = TetInput {
                    x: &s.x[e],
                    v: &s.v[e],
                    vol0: vol0[e],
                    avg: s.avg[e],
                    stress: &st_b[e].stress,
                    history: &ms_b[e * ns..(e + 1) * ns],
                };
                g.load(l, &input);
            }
            g.update(dt, &lm, mat, &ctl).expect("no inverted element");
            for l in 0..n {
                let e = g0 + l;
                let ms = &mut ms_s[e * ns..(e + 1) * ns];
                let (x, v) = (&s.x[e], &s.v[e]);
                let r = tet::update(
                    x,
                    v,
                    dt,
                    mat.density(),
                    vol0[e],
                    s.avg[e],
                    mat,
                    &ctl,
                    &mut st_s[e],
                    ms,
                )
                .expect("no inverted element");
                let (stress, hist) = g.lane_state(l);
                let o = g.lane_output(l);
                if ns > 0 && hist[0] > ms_b[e * ns] {
                    flowed += 1;
                }
                st_b[e].stress = stress;
                ms_b[e * ns..(e + 1) * ns].copy_from_slice(&hist[..ns]);
                let (a, b) = (quantities(&st_s[e].stress, &r), quantities(&stress, &o));
                for (d, (p, q)) in diffs.iter_mut().zip(a.iter().zip(&b)) {
                    d.add(p, q);
                    bits.extend(q.iter().map(|v| v.to_bits()));
                }
                for (k, d) in d_hist.iter_mut().enumerate() {
                    d.add(&ms_s[e * ns + k..e * ns + k + 1], &hist[k..k + 1]);
                    bits.push(hist[k].to_bits());
                }
            }
        }
    }
    for (d, what) in diffs.iter().zip(QUANTITIES) {
        d.check(what, case);
    }
    for (k, d) in d_hist.iter().enumerate() {
        d.check(&format!("history values {k}"), case);
    }
    (bits, flowed)
}

/// `compare` for every width this CPU runs; asserts that all give the same bits. Returns the
/// plastic element-steps.
fn every_width(mat: &dyn Material, case: &str) -> usize {
    let steps = steps(12, 1e-7);
    let widths = batch::available();
    println!("lane kernel widths on this CPU: {widths:?}");
    let mut first: Option<(Width, Vec<u64>)> = None;
    let mut flowed = 0;
    for w in widths {
        let (bits, f) = match w {
            Width::W1 => compare::<batch::w1::TetGroup>(mat, case, &steps),
            Width::W4 => compare::<batch::w4::TetGroup>(mat, case, &steps),
            #[cfg(target_arch = "x86_64")]
            Width::W8 => compare::<batch::w8::TetGroup>(mat, case, &steps),
        };
        flowed = f;
        match &first {
            None => first = Some((w, bits)),
            Some((w0, b0)) => assert!(
                *b0 == bits,
                "{case}: {w:?} does not give the bits of {w0:?}"
            ),
        }
    }
    flowed
}

#[test]
fn tet_lanes_equal_tet_update_elastic() {
    every_width(&*solid("elastic", &[]), "elastic");
}

#[test]
fn tet_lanes_equal_tet_update_j2_yielding() {
    let mat = solid(
        "j2_plastic",
        &[("yield_stress", 250e6), ("hardening_modulus", 2e9)],
    );
    let flowed = every_width(&*mat, "j2_plastic");
    assert!(
        flowed > 100,
        "j2_plastic: only {flowed} element-steps flowed"
    );
}

#[test]
fn tet_lanes_equal_tet_update_johnson_cook_thermal() {
    // Its yield stress (806 MPa and up) is reached later than J2's (250 MPa).
    let flowed = every_width(&*johnson_cook(), "johnson_cook");
    assert!(
        flowed > 50,
        "johnson_cook: only {flowed} element-steps flowed"
    );
}

#[test]
fn tet_lanes_equal_tet_update_gas() {
    every_width(&*gas(), "ideal gas");
}

/// A group with an inverted element reports its lane and the volume `tet::update` reports.
#[test]
fn tet_lanes_report_the_inverted_lane() {
    let mat = solid("elastic", &[]);
    let ctl = HexControls::default();
    let lm = LaneMaterial::new(&*mat, &ctl);
    let mut x = tetrahedra(8, 0.01, &mut Lcg(3));
    x[2].swap(1, 2);
    let v = [[0.0; 3]; 4];
    let avg = TetAverages { theta: 0.0, j: 1.0 };
    let expected = match tet::update(
        &x[2],
        &v,
        1e-7,
        7850.0,
        1e-6,
        avg,
        &*mat,
        &ctl,
        &mut TetState::default(),
        &mut [],
    ) {
        Err(ElementError::Inverted { volume }) => volume,
        Ok(_) => panic!("tet::update took an inverted tetrahedron"),
    };
    let mut g = batch::w4::TetGroup::default();
    for (l, xe) in x.iter().take(4).enumerate() {
        let input = TetInput {
            x: xe,
            v: &v,
            vol0: 1e-6,
            avg,
            stress: &[0.0; 6],
            history: &[],
        };
        g.load(l, &input);
    }
    let bad = g
        .update(1e-7, &lm, &*mat, &ctl)
        .expect_err("an inverted lane");
    assert_eq!((bad.lane, bad.volume), (2, expected));
}

/// Pass 1 in lanes gives `tet::rates`'s bits in every width, a part group padded.
fn rates_match<B: TetBatch>(steps: &[Step]) {
    let mut g = B::default();
    let dt = 1e-7;
    for s in steps {
        for g0 in (0..ELEMS).step_by(B::LANES) {
            let n = B::LANES.min(ELEMS - g0);
            for l in 0..B::LANES {
                let e = g0 + if l < n { l } else { 0 };
                g.load_nodes(l, &s.x[e], &s.v[e]);
            }
            g.rates(dt);
            for l in 0..n {
                let r = tet::rates(&s.x[g0 + l], &s.v[g0 + l], dt).expect("not inverted");
                let b = g.lane_rates(l);
                let bits = |r: &tet::TetRates| [r.vol, r.vol_mid, r.vol_rate].map(f64::to_bits);
                assert_eq!(
                    bits(&r),
                    bits(&b),
                    "{} lanes: element {}: {r:?} != {b:?}",
                    B::LANES,
                    g0 + l
                );
            }
        }
    }
}

#[test]
fn tet_lane_rates_equal_tet_rates_bits() {
    let steps = steps(3, 1e-7);
    for w in batch::available() {
        match w {
            Width::W1 => rates_match::<batch::w1::TetGroup>(&steps),
            Width::W4 => rates_match::<batch::w4::TetGroup>(&steps),
            #[cfg(target_arch = "x86_64")]
            Width::W8 => rates_match::<batch::w8::TetGroup>(&steps),
        }
    }
}
