//! The contact stage in a run (issue 5): two elastic bars meeting head on.
use tdyn_tests::*;

const L: f64 = 0.1;
const V: f64 = 10.0;

/// c = sqrt(E / rho): Poisson's ratio 0 makes the bar problem exactly 1D.
fn c_bar() -> f64 {
    (200.0e9f64 / 7850.0).sqrt()
}

/// Mass-weighted mean x-velocity of each bar in the last frame of fields.h5 (lumped masses of a
/// uniform 1D mesh: end nodes carry half).
fn bar_velocities(out: &std::path::Path) -> (f64, f64, f64) {
    let f = hdf5::File::open(out.join("fields.h5")).unwrap();
    let mut frames = f.group("frames").unwrap().member_names().unwrap();
    frames.sort();
    let mut gap_min = f64::INFINITY;
    let mut last = (0.0, 0.0);
    for fr in &frames {
        let g = f.group(&format!("frames/{fr}")).unwrap();
        let pos: Vec<f64> = g.dataset("nodes/position").unwrap().read_raw().unwrap();
        let disp: Vec<f64> = g.dataset("nodes/displacement").unwrap().read_raw().unwrap();
        let vel: Vec<f64> = g.dataset("nodes/velocity").unwrap().read_raw().unwrap();
        let n = pos.len() / 3;
        let (mut a_max, mut b_min) = (f64::NEG_INFINITY, f64::INFINITY);
        let (mut pa, mut ma, mut pb, mut mb) = (0.0, 0.0, 0.0, 0.0);
        for i in 0..n {
            let x0 = pos[3 * i] - disp[3 * i];
            let end = x0.abs() < 1e-9 || (x0 - L).abs() < 1e-9 || (x0 - 2.0 * L).abs() < 2e-4;
            let w = if end || (x0 - L).abs() < 2e-4 {
                0.5
            } else {
                1.0
            };
            if x0 < L + 5e-5 {
                a_max = a_max.max(pos[3 * i]);
                pa += w * vel[3 * i];
                ma += w;
            } else {
                b_min = b_min.min(pos[3 * i]);
                pb += w * vel[3 * i];
                mb += w;
            }
        }
        gap_min = gap_min.min(b_min - a_max);
        last = (pa / ma, pb / mb);
    }
    (last.0, last.1, gap_min)
}

#[test]
fn bars_meeting_head_on_exchange_velocities_after_2l_over_c() {
    // scenes/bars_impact.toml: two steel bars (nu = 0), L = 0.1 m, 40 elements each, no bulk viscosity, +-10 m/s,
    // kinematic contact between the facing ends. References: momentum zero (it starts at zero
    // and only internal and contact forces act) to 1e-12 of M v; the 1D elastic impact of
    // equal bars lasts 2L/c and ends with the velocities exchanged (St Venant), within 5 %; the
    // facing ends never overlap by more than 1e-3 of an element (40 elements per 0.1 m) in the
    // frames. At np 1, 2, 3, 4, whose histories agree within 1e-9 of the largest value.
    let dt_el = L / 40.0;
    let mut histories = Vec::new();
    for np in 1..=4 {
        let dir = workdir(&format!("bars_impact_np{np}"));
        let out = dir.join("out");
        run_ok(np, &root().join("scenes/bars_impact.toml"), &out);
        let (h, rows) = read_csv(&out.join("history.csv"));
        let t = column(&h, &rows, "time");
        let dt = column(&h, &rows, "dt");
        let px = column(&h, &rows, "momentum_x");
        let contacts = column(&h, &rows, "contacts");
        let err = column(&h, &rows, "energy_error");
        let mass = 2.0 * 7850.0 * L * 0.01 * 0.01;
        for (k, p) in px.iter().enumerate() {
            assert!(
                p.abs() < 1e-12 * mass * V,
                "np {np}: momentum {p} at t = {} (expected 0 within 1e-12 M v)",
                t[k]
            );
        }
        let steps: Vec<usize> = (0..t.len()).filter(|&k| contacts[k] > 0.0).collect();
        assert!(!steps.is_empty(), "np {np}: the bars never touched");
        let start = t[steps[0]] - dt[steps[0]];
        let end = t[*steps.last().unwrap()];
        let duration = end - start;
        let expect = 2.0 * L / c_bar();
        assert!(
            (duration - expect).abs() < 0.05 * expect,
            "np {np}: contact lasted {duration:e} s, 2L/c = {expect:e} s (5 %)"
        );
        let err_max = err.iter().cloned().fold(0.0, f64::max);
        assert!(
            err_max < 0.05,
            "np {np}: energy error {err_max} (the run's own 5 % limit)"
        );
        let (va, vb, gap) = bar_velocities(&out);
        assert!(
            (va + V).abs() < 0.05 * V && (vb - V).abs() < 0.05 * V,
            "np {np}: mean bar velocities after the impact {va}, {vb}; expected -10, +10 (5 %)"
        );
        assert!(
            gap > -1e-3 * dt_el,
            "np {np}: the bars overlap by {} m in a frame (limit 1e-3 of an element)",
            -gap
        );
        histories.push(rows);
    }
    let scale = histories[0]
        .iter()
        .flatten()
        .fold(0.0f64, |a, v| a.max(v.abs()));
    for (k, h) in histories.iter().enumerate().skip(1) {
        for (r0, r) in histories[0].iter().zip(h) {
            for (a, b) in r0.iter().zip(r) {
                assert!(
                    (a - b).abs() <= 1e-9 * scale,
                    "np {} history differs from np 1: {a} vs {b}",
                    k + 1
                );
            }
        }
    }
}
