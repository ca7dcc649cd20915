//! The coupled timestep (Fig. 3): FE, SPH and contact on their three decompositions in one run.
use tdyn_tests::*;

/// Per frame of fields.h5: (lowest particle centre z, lowest z of the plate's top nodes), m.
fn lowest_particle_and_plate_top(out: &std::path::Path) -> Vec<(f64, f64)> {
    let f = hdf5::File::open(out.join("fields.h5")).unwrap();
    let mut frames = f.group("frames").unwrap().member_names().unwrap();
    frames.sort();
    frames
        .iter()
        .map(|fr| {
            let g = f.group(&format!("frames/{fr}")).unwrap();
            let xp: Vec<f64> = g.dataset("particles/position").unwrap().read_raw().unwrap();
            let xn: Vec<f64> = g.dataset("nodes/position").unwrap().read_raw().unwrap();
            let un: Vec<f64> = g.dataset("nodes/displacement").unwrap().read_raw().unwrap();
            let zp = xp.chunks(3).map(|x| x[2]).fold(f64::INFINITY, f64::min);
            // top nodes: initial z = 0 (meshes/plate.geo puts the top face at z = 0)
            let zt = xn
                .chunks(3)
                .zip(un.chunks(3))
                .filter(|(x, u)| (x[2] - u[2]).abs() < 1e-9)
                .map(|(x, _)| x[2])
                .fold(f64::INFINITY, f64::min);
            (zp, zt)
        })
        .collect()
}

#[test]
fn particle_cloud_falling_on_a_meshed_plate_never_passes_through_it() {
    // scenes/cloud_on_plate.toml: 864 water particles (spacing 5 mm, contact radius 2.5 mm =
    // half the spacing) falling at 10 m/s onto a clamped steel plate of 10 x 10 x 2 hexahedra,
    // particles as contact nodes against the plate's top faces. References: geometry (no
    // particle centre in any frame comes closer to the plate's top than half its contact
    // radius, i.e. no particle passes through; kinematic push-back leaves it at one radius,
    // measured 0.95 r); the energy balance (kinetic + internal + contact = initial + work of
    // gravity) within 2 %; np 1 and 3 agree on the final kinetic energy and contact energy
    // within 1 %.
    let radius = 0.0025;
    let mut finals = Vec::new();
    for np in [1, 3] {
        let dir = workdir(&format!("cloud_on_plate_np{np}"));
        let out = dir.join("out");
        run_ok(np, &root().join("scenes/cloud_on_plate.toml"), &out);
        let frames = lowest_particle_and_plate_top(&out);
        assert!(
            frames.len() >= 8,
            "np {np}: frames written: {}",
            frames.len()
        );
        for (k, (zp, zt)) in frames.iter().enumerate() {
            assert!(
                zp - zt >= 0.5 * radius,
                "np {np}, frame {k}: a particle centre at z = {zp} is {:.3e} m above the plate top at {zt} (at least r/2 = {:.3e} m)",
                zp - zt,
                0.5 * radius
            );
        }
        let (h, rows) = read_csv(&out.join("history.csv"));
        let err = column(&h, &rows, "energy_error");
        let worst = err.iter().cloned().fold(0.0, f64::max);
        assert!(worst < 0.02, "np {np}: energy error {worst} (2 %)");
        let contacts = column(&h, &rows, "contacts");
        assert!(
            contacts.iter().any(|&c| c > 0.0),
            "np {np}: the cloud reaches the plate"
        );
        // The particle probe (outside the mesh: Shepard-interpolated from the particles) at
        // t = 0 gives the cloud's uniform state: density 1000, velocity -10 (Shepard
        // reproduces a constant exactly: 1e-12).
        let (ph, prow) = read_csv(&out.join("probes.csv"));
        let rho0 = column(&ph, &prow, "cloud.density")[0];
        let vz0 = column(&ph, &prow, "cloud.velocity_z")[0];
        assert!(
            (rho0 - 1000.0).abs() < 1e-12 * 1000.0 && (vz0 + 10.0).abs() < 1e-12 * 10.0,
            "np {np}: particle probe at t = 0: density {rho0}, velocity_z {vz0} (1000, -10)"
        );
        let ke = *column(&h, &rows, "kinetic_energy").last().unwrap();
        let ce = *column(&h, &rows, "contact_energy").last().unwrap();
        finals.push((ke, ce));
    }
    let ((k1, c1), (k3, c3)) = (finals[0], finals[1]);
    assert!(
        (k1 - k3).abs() <= 0.01 * k1 && (c1 - c3).abs() <= 0.01 * c1,
        "np 1 vs np 3: kinetic energy {k1} vs {k3}, contact energy {c1} vs {c3} (1 %)"
    );
}
