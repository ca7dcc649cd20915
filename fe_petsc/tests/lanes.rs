//! The element kernel (`batch::Batch::update`, four or eight elements in lanes: every width
//! this CPU runs) against the node-by-node kernel (`hex::update`), which is the reference: a
//! randomly distorted block driven through steps of a velocity field with random nodal parts
//! (hourglass modes), for every material model (elastic and J2 in lanes; Johnson-Cook with
//! thermal softening and a fluid's equation of state called lane by lane) and every hourglass
//! control. No MPI, no PETSc.
use fe_petsc::batch::{self, Batch, LaneMaterial, Width};
use fe_petsc::hex::{self, HexControls, HexOutput, HexState};
use fe_petsc::hourglass::{Hourglass, YieldBound};
use fe_petsc::material::{build_material, EosSpec, Material, MaterialSpec, MAX_STATE};
use fe_petsc::states::HexStates;

/// Relative agreement required. Every width runs the same IEEE operations in the same order
/// (no fused multiply-adds), so four and eight lanes give the same bits as each other; both
/// form the geometry in mode space and `hex::update` node by node, so they differ from it at
/// round-off (at most 2e-13 relative over the 12 yielding steps, in the hourglass amplitudes
/// that the yield bound rescales). A transcription error shows at 1e-8 or more.
const TOL: f64 = 1e-12;

/// A small deterministic generator (LCG, Knuth's constants) so tests need no rand crate.
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

fn material(model: &str, extra: &[(&str, f64)]) -> Box<dyn Material> {
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

/// Johnson-Cook with thermal softening and adiabatic heating (the 42CrMo4 steel of
/// scenes/taylor_jc_steel.toml): two history values, the plastic strain and the temperature.
fn johnson_cook() -> Box<dyn Material> {
    material(
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

/// An ideal gas at 1 bar (gamma 1.4, rho 1.2 kg/m^3): three history values, the specific
/// energy (heated by the bulk viscosity here), volume and pressure.
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

/// History values `ms[e * ns..]` of element `e` as the kernel loads them.
fn history_of(ms: &[f64], ns: usize, e: usize) -> [f64; MAX_STATE] {
    let mut h = [0.0; MAX_STATE];
    h[..ns].copy_from_slice(&ms[e * ns..(e + 1) * ns]);
    h
}

/// An n x n x m block of hexahedra of side `h` with every node moved by up to 20 % of `h`;
/// returns (nodes, elements).
fn distorted_block(n: usize, m: usize, h: f64, rng: &mut Lcg) -> (Vec<[f64; 3]>, Vec<[u32; 8]>) {
    let id = |i: usize, j: usize, k: usize| (i + (n + 1) * (j + (n + 1) * k)) as u32;
    let mut x = Vec::new();
    for k in 0..=m {
        for j in 0..=n {
            for i in 0..=n {
                let p = [i as f64, j as f64, k as f64];
                x.push(p.map(|c| h * (c + 0.4 * rng.next())));
            }
        }
    }
    let mut e = Vec::new();
    for k in 0..m {
        for j in 0..n {
            for i in 0..n {
                e.push([
                    id(i, j, k),
                    id(i + 1, j, k),
                    id(i + 1, j + 1, k),
                    id(i, j + 1, k),
                    id(i, j, k + 1),
                    id(i + 1, j, k + 1),
                    id(i + 1, j + 1, k + 1),
                    id(i, j + 1, k + 1),
                ]);
            }
        }
    }
    (x, e)
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
            "{case}: batched {what} differs from the scalar kernel's (hex::update, the \
             reference) by {rel:e} relative to the largest value {:e}; tolerance {TOL:e}",
            self.scale
        );
    }
}

/// The outputs of an element update, each compared on its own scale.
const OUTPUTS: [&str; 5] = [
    "forces",
    "hourglass work",
    "volume",
    "stable step",
    "pressure",
];

fn outputs(o: &HexOutput) -> [Vec<f64>; 5] {
    [
        o.force.as_flattened().to_vec(),
        vec![o.hg_work],
        vec![o.volume],
        vec![o.dt_stable],
        vec![o.pressure],
    ]
}

/// Runs `steps` steps of the block with both kernels, each on its own copy of the state, and
/// compares every output and state; returns how many (element, step) pairs flowed plastically
/// and in how many group-steps the lanes disagreed on flowing (masked lanes exercised).
fn compare_kernels<B: Batch>(
    mat: &dyn Material,
    ctl: &HexControls,
    case: &str,
    steps: usize,
) -> (usize, usize) {
    let ctl = *ctl;
    let lanes = B::LANES;
    let case = &format!("{case}, {lanes} lanes");
    let mut rng = Lcg(0x5eed_0017);
    let h = 0.01;
    let (mut x, elems) = distorted_block(4, 3, h, &mut rng);
    assert_eq!(elems.len() % lanes, 0, "whole groups");
    // A compression along x with shear (about 3e3 1/s: yield within a few steps) plus random
    // nodal velocities of the same size, which drive the hourglass modes.
    let rate = 3e3;
    let v: Vec<[f64; 3]> = x
        .iter()
        .map(|p| {
            let r = [rng.next(), rng.next(), rng.next()];
            [
                -rate * p[0] + rate * h * r[0],
                0.3 * rate * p[0] + 0.5 * rate * p[2] + rate * h * r[1],
                0.2 * rate * p[1] + rate * h * r[2],
            ]
        })
        .collect();
    let lm = LaneMaterial::new(mat, &ctl);
    let ns = mat.n_state().max(1);
    // A pointwise model's history is loaded lane by lane only (no whole-group path).
    let whole_path = !lm.pointwise();
    let vol0: Vec<f64> = elems
        .iter()
        .map(|c| hex::volume(&c.map(|n| x[n as usize])))
        .collect();
    let mut st_s = vec![HexState::default(); elems.len()];
    let mut ms_s = vec![0.0; elems.len() * ns];
    for e in 0..elems.len() {
        mat.init_state(&mut ms_s[e * ns..(e + 1) * ns]);
    }
    let mut st_b = st_s.clone();
    // One buffer for every group, as the explicit loop uses it.
    let mut group = B::default();
    let mut ms_b = ms_s.clone();
    // The same groups again through the whole-group path (state in lanes), as the explicit
    // loop runs a whole group: it must give the same bits as loading lane by lane.
    let mut group_l = B::default();
    let mut st_l = HexStates::new(elems.len());
    let mut ms_l: Vec<f64> = vec![0.0; elems.len()];
    // The nodal forces summed over every step: by the kernel, and from the lanes' outputs.
    let (mut f_whole, mut f_lanes) = (vec![[0.0; 3]; x.len()], vec![[0.0; 3]; x.len()]);
    let dt = 2e-7;
    let (mut flowed, mut mixed) = (0, 0);
    let mut d_out: [Diff; 5] = Default::default();
    let [mut d_stress, mut d_hg]: [Diff; 2] = Default::default();
    let mut d_hist: Vec<Diff> = (0..mat.n_state()).map(|_| Diff::default()).collect();
    for _ in 0..steps {
        for (p, w) in x.iter_mut().zip(&v) {
            for c in 0..3 {
                p[c] += dt * w[c];
            }
        }
        let mut ref_out = Vec::new();
        for (e, c) in elems.iter().enumerate() {
            let (xe, ve) = (c.map(|n| x[n as usize]), c.map(|n| v[n as usize]));
            let ms = &mut ms_s[e * ns..(e + 1) * ns];
            let o = hex::update(
                &xe,
                &ve,
                dt,
                mat.density(),
                vol0[e],
                mat,
                &ctl,
                &mut st_s[e],
                ms,
            );
            ref_out.push(o.expect("no inverted element"));
        }
        for g in (0..elems.len()).step_by(lanes) {
            let e = g..g + lanes;
            group.load(
                &x,
                &v,
                &elems[e.clone()],
                &vol0[e.clone()],
                &st_b[e.clone()],
                |l| history_of(&ms_b, ns, g + l),
            );
            group
                .update(dt, &lm, mat, &ctl)
                .expect("no inverted element");
            if whole_path {
                let mut io = batch::GroupLanes {
                    xs: &x,
                    vs: &v,
                    conn: &elems[e.clone()],
                    vol0: &vol0[e.clone()],
                    state: st_l.lanes_mut(g),
                    history: (mat.n_state() > 0).then(|| &mut ms_l[e.clone()]),
                    force: Some(&mut f_whole),
                };
                group_l
                    .update_lanes(&mut io, dt, &lm, &ctl)
                    .expect("no inverted element");
            }
            let flows = (0..lanes)
                .filter(|&l| group.lane_state(l).1[0] > ms_b[(g + l) * ns])
                .count();
            flowed += flows;
            mixed += usize::from(flows > 0 && flows < lanes);
            for l in 0..lanes {
                let e = g + l;
                let (s, hist) = group.lane_state(l);
                st_b[e] = s;
                ms_b[e * ns..(e + 1) * ns].copy_from_slice(&hist[..ns]);
                let (r, b) = (outputs(&ref_out[e]), outputs(&group.lane_output(l)));
                for (d, (r, b)) in d_out.iter_mut().zip(r.iter().zip(&b)) {
                    d.add(r, b);
                }
                d_stress.add(&st_s[e].stress, &s.stress);
                d_hg.add(st_s[e].hg.as_flattened(), s.hg.as_flattened());
                for (k, d) in d_hist.iter_mut().enumerate() {
                    d.add(&ms_s[e * ns + k..e * ns + k + 1], &hist[k..k + 1]);
                }
                for k in 0..8 {
                    let node = &mut f_lanes[elems[e][k] as usize];
                    for (p, q) in node.iter_mut().zip(group.lane_output(l).force[k]) {
                        *p += q;
                    }
                }
                if !whole_path {
                    continue;
                }
                let by_lane = format!("{:?} {:?} {:?}", s, hist[0], group.lane_output(l));
                let whole = format!(
                    "{:?} {:?} {:?}",
                    st_l.get(e),
                    ms_l[e],
                    group_l.lane_output(l)
                );
                assert_eq!(
                    whole, by_lane,
                    "{case}: element {e}: the whole-group path differs from lane-by-lane loading"
                );
                for k in 0..8 {
                    assert_eq!(group_l.force(l, k), group.lane_output(l).force[k]);
                }
            }
        }
    }
    // The whole-group path adds its forces to the nodes in the kernel: the same sums, in the
    // same order, as adding each lane's output element by element.
    if whole_path {
        assert_eq!(
            f_whole, f_lanes,
            "{case}: the nodal forces added in the kernel differ from the lanes' outputs summed"
        );
    }
    for (d, what) in d_out.iter().zip(OUTPUTS) {
        d.check(what, case);
    }
    d_stress.check("stresses", case);
    d_hg.check("hourglass stress amplitudes", case);
    for (k, d) in d_hist.iter().enumerate() {
        d.check(&format!("history values {k}"), case);
    }
    (flowed, mixed)
}

/// `compare_kernels` for the group size `w`.
fn compare_width(
    w: Width,
    mat: &dyn Material,
    ctl: &HexControls,
    case: &str,
    steps: usize,
) -> (usize, usize) {
    match w {
        Width::W1 => compare_kernels::<batch::w1::LaneGroup>(mat, ctl, case, steps),
        Width::W4 => compare_kernels::<batch::w4::LaneGroup>(mat, ctl, case, steps),
        #[cfg(target_arch = "x86_64")]
        Width::W8 => compare_kernels::<batch::w8::LaneGroup>(mat, ctl, case, steps),
    }
}

/// The widths this CPU runs, said on the test's output (a CPU without AVX-512 tests four
/// lanes only).
fn widths() -> Vec<Width> {
    let w = batch::available();
    println!("batched kernel widths on this CPU: {w:?}");
    w
}

#[test]
fn batched_kernel_equals_the_scalar_kernel_elastic() {
    let mat = material("elastic", &[]);
    for w in widths() {
        compare_width(w, &*mat, &HexControls::default(), "elastic", 12);
    }
}

#[test]
fn batched_kernel_equals_the_scalar_kernel_j2_yielding() {
    let mat = material(
        "j2_plastic",
        &[("yield_stress", 250e6), ("hardening_modulus", 2e9)],
    );
    for w in widths() {
        let (flowed, mixed) = compare_width(w, &*mat, &HexControls::default(), "j2_plastic", 12);
        // The comparison means something only if the return and its mask were exercised.
        assert!(
            flowed > 100,
            "j2_plastic, {w:?}: only {flowed} element-steps flowed"
        );
        assert!(
            mixed > 0 || w == Width::W1,
            "j2_plastic, {w:?}: no group had flowing and elastic lanes in one step"
        );
    }
}

#[test]
fn batched_kernel_equals_the_scalar_kernel_j2_yielding_tangential_bound() {
    // The split meshes' yield bound (normal part bounded, tangential part returned radially)
    // on the yielding block: its amplitudes in lanes against the scalar kernel.
    let mat = material(
        "j2_plastic",
        &[("yield_stress", 250e6), ("hardening_modulus", 2e9)],
    );
    let ctl = HexControls {
        hourglass: Hourglass::Physical {
            scale: 1.0,
            bound: YieldBound::Tangential,
        },
        ..HexControls::default()
    };
    for w in widths() {
        let (flowed, mixed) = compare_width(w, &*mat, &ctl, "j2_plastic, tangential bound", 12);
        assert!(
            flowed > 100,
            "tangential bound, {w:?}: only {flowed} element-steps flowed"
        );
        assert!(
            mixed > 0 || w == Width::W1,
            "tangential bound, {w:?}: no group had flowing and elastic lanes in one step"
        );
    }
}

#[test]
fn batched_kernel_equals_the_scalar_kernel_fb_stiffness_hourglass() {
    // The FB/PRONTO stiffness form (as tube_crush.toml sets it) on the yielding block: its
    // generalised forces, their work and their nodal forces in lanes against the scalar kernel.
    let mat = material(
        "j2_plastic",
        &[("yield_stress", 250e6), ("hardening_modulus", 2e9)],
    );
    let ctl = HexControls {
        hourglass: Hourglass::Stiffness { coefficient: 0.05 },
        ..HexControls::default()
    };
    for w in widths() {
        let (flowed, _) = compare_width(w, &*mat, &ctl, "j2_plastic, FB stiffness", 12);
        assert!(
            flowed > 100,
            "FB stiffness, {w:?}: only {flowed} element-steps flowed"
        );
    }
}

#[test]
fn element_kernel_equals_the_node_by_node_kernel_johnson_cook_thermal() {
    // Johnson-Cook's stress update, yield stress and temperature called lane by lane, the rest
    // of the element in lanes, under the physical hourglass control (bounded by the current
    // yield stress, which here depends on each lane's history; both bounds) and the FB
    // stiffness form.
    let mat = johnson_cook();
    for ctl in [
        HexControls::default(),
        HexControls {
            hourglass: Hourglass::Physical {
                scale: 1.0,
                bound: YieldBound::Tangential,
            },
            ..HexControls::default()
        },
        HexControls {
            hourglass: Hourglass::Stiffness { coefficient: 0.05 },
            ..HexControls::default()
        },
    ] {
        for w in widths() {
            let case = format!("johnson_cook, {:?}", ctl.hourglass);
            let (flowed, mixed) = compare_width(w, &*mat, &ctl, &case, 12);
            assert!(
                flowed > 100,
                "{case}, {w:?}: only {flowed} element-steps flowed"
            );
            assert!(
                mixed > 0 || w == Width::W1,
                "{case}, {w:?}: no group mixed flowing and elastic lanes"
            );
        }
    }
}

#[test]
fn element_kernel_equals_the_node_by_node_kernel_fluid_and_fb_viscous() {
    // An ideal gas (no shear modulus: the physical control turns into the FB viscous form),
    // its EOS, wave modulus and bulk-viscosity heating called lane by lane; and J2 under the
    // FB viscous form asked for by name.
    let gas = gas();
    for w in widths() {
        compare_width(w, &*gas, &HexControls::default(), "ideal gas", 12);
    }
    let j2 = material(
        "j2_plastic",
        &[("yield_stress", 250e6), ("hardening_modulus", 2e9)],
    );
    let ctl = HexControls {
        hourglass: Hourglass::Viscous { coefficient: 0.1 },
        ..HexControls::default()
    };
    for w in widths() {
        compare_width(w, &*j2, &ctl, "j2_plastic, FB viscous", 12);
    }
}

#[test]
fn a_group_with_an_inverted_element_is_refused_naming_it() {
    for w in widths() {
        match w {
            Width::W1 => inverted_group_is_refused::<batch::w1::LaneGroup>(),
            Width::W4 => inverted_group_is_refused::<batch::w4::LaneGroup>(),
            #[cfg(target_arch = "x86_64")]
            Width::W8 => inverted_group_is_refused::<batch::w8::LaneGroup>(),
        }
    }
}

/// A group whose third element is inside out is refused with nothing changed, naming that
/// lane and its volume (the node-by-node kernel's, to round-off).
fn inverted_group_is_refused<B: Batch + std::fmt::Debug>() {
    let mat = material(
        "j2_plastic",
        &[("yield_stress", 250e6), ("hardening_modulus", 2e9)],
    );
    let ctl = HexControls::default();
    let lm = LaneMaterial::new(&*mat, &ctl);
    let cube: [[f64; 3]; 8] = hex::NODE_XI.map(|p| p.map(|c| 0.005 * (c + 1.0)));
    let mut inverted = cube;
    inverted.swap(0, 4);
    inverted.swap(1, 5);
    inverted.swap(2, 6);
    inverted.swap(3, 7);
    let n = B::LANES;
    // The third lane, or the only one.
    let bad_lane = 2.min(n - 1);
    let xs: Vec<[f64; 3]> = (0..n)
        .flat_map(|l| if l == bad_lane { inverted } else { cube })
        .collect();
    let conn: Vec<[u32; 8]> = (0..n)
        .map(|l| std::array::from_fn(|k| (8 * l + k) as u32))
        .collect();
    let state = HexState {
        stress: [1e6, 0.0, 0.0, 0.0, 0.0, 0.0],
        ..HexState::default()
    };
    let mut group = B::default();
    group.load(
        &xs,
        &vec![[1.0, 0.0, 0.0]; 8 * n],
        &conn,
        &vec![1.25e-7; n],
        &vec![state; n],
        |_| [0.0; MAX_STATE],
    );
    let before = format!("{group:?}");
    let r = group.update(1e-7, &lm, &*mat, &ctl);
    // The node-by-node kernel's volume of the inverted element (the same to round-off).
    let mut s = HexState::default();
    let Err(hex::ElementError::Inverted { volume }) = hex::update(
        &inverted,
        &[[1.0, 0.0, 0.0]; 8],
        1e-7,
        7850.0,
        1.25e-7,
        &*mat,
        &ctl,
        &mut s,
        &mut [0.0],
    ) else {
        panic!("the node-by-node kernel must refuse the inverted element")
    };
    let Err(bad) = r else {
        panic!("{n} lanes: lane {bad_lane} is inverted: the group must be refused")
    };
    assert_eq!(
        bad.lane, bad_lane,
        "{n} lanes: the refusal names lane {bad_lane}"
    );
    assert!(
        (bad.volume - volume).abs() <= 1e-12 * volume.abs(),
        "{n} lanes: the refusal's volume {} is not the inverted element's {volume} (1e-12)",
        bad.volume
    );
    assert_eq!(
        before,
        format!("{group:?}"),
        "{n} lanes: a refused group changes no state and no output"
    );
    // The whole-group path refuses it too and leaves the stored state and history as they were.
    let mut st = HexStates::new(n);
    for e in 0..n {
        st.set(e, &state);
    }
    let mut hist = vec![0.5; n];
    let vs = vec![[1.0, 0.0, 0.0]; 8 * n];
    let vol0 = vec![1.25e-7; n];
    let stored = st.clone();
    let mut io = batch::GroupLanes {
        xs: &xs,
        vs: &vs,
        conn: &conn,
        vol0: &vol0,
        state: st.lanes_mut(0),
        history: Some(&mut hist),
        force: None,
    };
    assert!(
        B::default().update_lanes(&mut io, 1e-7, &lm, &ctl).is_err(),
        "{n} lanes: the whole-group path must refuse the group with lane 2 inverted"
    );
    assert_eq!(
        st, stored,
        "{n} lanes: a refused group's stored state changed"
    );
    assert_eq!(
        hist,
        vec![0.5; n],
        "{n} lanes: a refused group's history changed"
    );
}

#[test]
fn each_lane_computes_its_own_element_whatever_fills_the_others() {
    // The element loop fills a run's last, partial group with copies of its first element;
    // an element's result must then be the same bits as in a whole group, or results would
    // depend on how elements are dealt to ranks.
    for w in widths() {
        match w {
            Width::W1 => lanes_are_independent::<batch::w1::LaneGroup>(),
            Width::W4 => lanes_are_independent::<batch::w4::LaneGroup>(),
            #[cfg(target_arch = "x86_64")]
            Width::W8 => lanes_are_independent::<batch::w8::LaneGroup>(),
        }
    }
}

/// One update of a whole group against updates of the same elements in groups whose lanes
/// from `n` on hold copies of lane 0: lanes below `n` give the same bits.
fn lanes_are_independent<B: Batch>() {
    let mat = material(
        "j2_plastic",
        &[("yield_stress", 250e6), ("hardening_modulus", 2e9)],
    );
    let ctl = HexControls::default();
    let lm = LaneMaterial::new(&*mat, &ctl);
    let lanes = B::LANES;
    let mut rng = Lcg(0x1a4e5);
    let (x, elems) = distorted_block(4, 3, 0.01, &mut rng);
    let v: Vec<[f64; 3]> = x
        .iter()
        .map(|_| [1e2 * rng.next(), 1e2 * rng.next(), 1e2 * rng.next()])
        .collect();
    let vol0: Vec<f64> = elems
        .iter()
        .map(|c| hex::volume(&c.map(|n| x[n as usize])))
        .collect();
    let state: Vec<HexState> = (0..lanes)
        .map(|l| HexState {
            stress: [
                3e8 * rng.next(),
                1e8,
                0.0,
                2e8 * rng.next(),
                0.0,
                1e7 * l as f64,
            ],
            ..HexState::default()
        })
        .collect();
    let update = |n: usize| {
        let pick = |l: usize| if l < n { l } else { 0 };
        let conn: Vec<[u32; 8]> = (0..lanes).map(|l| elems[pick(l)]).collect();
        let vol: Vec<f64> = (0..lanes).map(|l| vol0[pick(l)]).collect();
        let st: Vec<HexState> = (0..lanes).map(|l| state[pick(l)]).collect();
        let mut g = B::default();
        g.load(&x, &v, &conn, &vol, &st, |l| {
            [1e-3 * pick(l) as f64, 0.0, 0.0, 0.0]
        });
        g.update(2e-7, &lm, &*mat, &ctl)
            .expect("no inverted element");
        (0..n)
            .map(|l| format!("{:?} {:?}", g.lane_state(l), g.lane_output(l)))
            .collect::<Vec<_>>()
    };
    let whole = update(lanes);
    for n in 1..lanes {
        assert_eq!(
            update(n)[..],
            whole[..n],
            "{lanes} lanes: a group with {n} elements and copies of the first in the other \
             lanes gives different bits from the whole group"
        );
    }
}

#[test]
fn an_element_gives_the_same_bits_in_every_lane() {
    // How the element loop deals elements to groups depends on the rank count: an element's
    // result must not depend on which lane it lands in, nor on its neighbours in the group,
    // whether they move or rest (zero rates take the kernels' masked branches).
    for w in widths() {
        match w {
            Width::W1 => lane_position_free::<batch::w1::LaneGroup>(),
            Width::W4 => lane_position_free::<batch::w4::LaneGroup>(),
            #[cfg(target_arch = "x86_64")]
            Width::W8 => lane_position_free::<batch::w8::LaneGroup>(),
        }
    }
}

/// Each element of a group updated in every lane position (the group rotated), half the
/// nodes at rest: the same bits in every position.
fn lane_position_free<B: Batch>() {
    let mat = material("elastic", &[]);
    let ctl = HexControls::default();
    let lm = LaneMaterial::new(&*mat, &ctl);
    let lanes = B::LANES;
    let mut rng = Lcg(0x7a9e);
    let (x, elems) = distorted_block(4, 3, 0.01, &mut rng);
    let v: Vec<[f64; 3]> = x
        .iter()
        .enumerate()
        .map(|(i, _)| {
            let s = if i % 2 == 0 { 0.0 } else { 40.0 };
            [s * rng.next(), s * rng.next(), s * rng.next()]
        })
        .collect();
    let vol0: Vec<f64> = elems
        .iter()
        .map(|c| hex::volume(&c.map(|n| x[n as usize])))
        .collect();
    let update = |shift: usize| {
        let pick = |l: usize| (l + shift) % lanes;
        let conn: Vec<[u32; 8]> = (0..lanes).map(|l| elems[pick(l)]).collect();
        let vol: Vec<f64> = (0..lanes).map(|l| vol0[pick(l)]).collect();
        let st = vec![HexState::default(); lanes];
        let mut g = B::default();
        g.load(&x, &v, &conn, &vol, &st, |_| [0.0; MAX_STATE]);
        g.update(2e-7, &lm, &*mat, &ctl)
            .expect("no inverted element");
        // Results by element, not by lane.
        let mut r = vec![String::new(); lanes];
        for l in 0..lanes {
            r[pick(l)] = format!("{:?} {:?}", g.lane_state(l), g.lane_output(l));
        }
        r
    };
    let first = update(0);
    for shift in 1..lanes {
        assert_eq!(
            update(shift),
            first,
            "{lanes} lanes: rotating the group by {shift} lanes changed an element's bits"
        );
    }
}
