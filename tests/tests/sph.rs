//! The SPH stage in a run (issue 4): Sod's shock tube against the exact Riemann solution.
use tdyn_tests::*;

/// Exact star state of Sod's problem (left rho 1, p 1; right rho 0.125, p 0.1; gamma 1.4):
/// p* = 0.30313, u* = 0.92745 (Toro, Riemann Solvers and Numerical Methods, 1999, table 4.3).
const P_STAR: f64 = 0.30313;
const U_STAR: f64 = 0.92745;

#[test]
fn sod_shock_tube_plateau_within_3_percent_at_1_to_4_ranks() {
    // scenes/sod_tube.toml: 1,920 + 240 particles (spacing 0.005 left, 0.01 right, equal
    // masses), periodic across the tube, Wendland kernel, summation density, h = 1.8 (m/rho)^(1/3),
    // energy equation, Monaghan alpha 1, beta 2. Probes at t = 0.2 left of the contact (x = 0.1)
    // and between the contact and the shock (x = 0.27): pressure and velocity within 3 % of the
    // exact p*, u*; the probes at np 2, 3, 4 equal np 1's within 1e-8 (round-off of the sums).
    let mut first: Option<Vec<f64>> = None;
    for np in 1..=4 {
        let dir = workdir(&format!("sod_np{np}"));
        let out = dir.join("out");
        run_ok(np, &root().join("scenes/sod_tube.toml"), &out);
        let (h, rows) = read_csv(&out.join("probes.csv"));
        let last = rows.last().unwrap().clone();
        let t = column(&h, &rows, "time");
        assert!((t.last().unwrap() - 0.2).abs() < 1e-12, "ends at t = 0.2");
        for probe in ["star", "shocked"] {
            let p = column(&h, &rows, &format!("{probe}.pressure"));
            let u = column(&h, &rows, &format!("{probe}.velocity_x"));
            let (p, u) = (p.last().unwrap(), u.last().unwrap());
            assert!(
                (p - P_STAR).abs() < 0.03 * P_STAR && (u - U_STAR).abs() < 0.03 * U_STAR,
                "np {np}, probe {probe}: p = {p}, u = {u}; exact p* = {P_STAR}, u* = {U_STAR} (3 %)"
            );
        }
        let (hh, hist) = read_csv(&out.join("history.csv"));
        let px = column(&hh, &hist, "momentum_x");
        let ke = column(&hh, &hist, "kinetic_energy");
        let ie = column(&hh, &hist, "internal_energy");
        let _ = (ke, ie);
        // Momentum: zero at t = 0 and only pair forces act (equal and opposite), so it stays
        // zero to round-off: 1e-10 of M u* (M = 0.6 x 0.02^2 x (1 + 0.125) kg).
        let scale = 0.6 * 0.02 * 0.02 * 1.125 * U_STAR;
        for (k, p) in px.iter().enumerate() {
            assert!(
                p.abs() < 1e-10 * scale,
                "np {np}: momentum {p} at row {k} (1e-10 of {scale:e})"
            );
        }
        match &first {
            None => first = Some(last),
            Some(f) => {
                for (a, b) in f.iter().zip(&last) {
                    assert!(
                        (a - b).abs() <= 1e-8 * a.abs().max(1e-3),
                        "np {np} probes differ from np 1: {a} vs {b}"
                    );
                }
            }
        }
    }
}
