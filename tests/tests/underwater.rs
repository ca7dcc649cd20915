//! The underwater explosion: a TNT charge (JWL SPH particles) in a cavity of meshed
//! water (Tait fluid) beneath a clamped steel plate with a plug, quarter model
//! (`scenes/underwater_explosion.toml`), at np 1 and 3.
use tdyn_tests::*;

/// Cole's similitude law for the peak pressure of TNT, P = K (W^(1/3)/R)^alpha (W in kg, R in
/// m): R. H. Cole, Underwater Explosions (Princeton 1948); the constants as in T. L. Geers and
/// K. S. Hunter, "An integrated wave-effects model for an underwater explosion bubble",
/// J. Acoust. Soc. Am. 111 (2002) 1584.
const COLE_K: f64 = 52.4e6;
const COLE_ALPHA: f64 = 1.13;
/// The scene's charge: a cube of side 2A (A = 0.02 m) of TNT at 1630 kg/m^3; W is the full
/// charge's mass (the quarter model holds a quarter of it).
const A: f64 = 0.02;
const RHO_TNT: f64 = 1630.0;

fn cole(r: f64) -> f64 {
    let w = RHO_TNT * (2.0 * A).powi(3);
    COLE_K * (w.cbrt() / r).powf(COLE_ALPHA)
}

/// (peak pressure per probe r3..r12, final plug and plate displacement, final kinetic and
/// internal energy, largest energy error).
struct Measures {
    peaks: Vec<(usize, f64)>,
    plug_uz: f64,
    plate_uz: f64,
    kinetic: f64,
    internal: f64,
    energy_error: f64,
}

fn measure(out: &std::path::Path) -> Measures {
    let (h, rows) = read_csv(&out.join("probes.csv"));
    let peaks = [3, 6, 9, 12]
        .iter()
        .map(|&k| {
            let p = column(&h, &rows, &format!("r{k}.pressure"));
            (k, p.iter().cloned().fold(f64::NEG_INFINITY, f64::max))
        })
        .collect();
    let last = |name: &str| *column(&h, &rows, name).last().unwrap();
    let plug_uz = last("plug.displacement_z");
    let plate_uz = last("plate.displacement_z");
    let (h, rows) = read_csv(&out.join("history.csv"));
    let last = |name: &str| *column(&h, &rows, name).last().unwrap();
    Measures {
        peaks,
        plug_uz,
        plate_uz,
        kinetic: last("kinetic_energy"),
        internal: last("internal_energy"),
        energy_error: column(&h, &rows, "energy_error")
            .iter()
            .cloned()
            .fold(0.0, f64::max),
    }
}

#[test]
fn underwater_explosion_peak_pressure_against_cole_energy_and_rank_counts() {
    let mut all = Vec::new();
    for np in [1, 3] {
        let dir = workdir(&format!("underwater_np{np}"));
        let out = dir.join("out");
        // docs/scene.md's bound on contact_energy, 1e-3 of the energy scale between rows
        // (E0 = 1.12e5 J), holds here too: the products pressed on the cavity's faces from
        // rest, whose onset contact booked as given back (143 J, 1.28e-3, before
        // `contact::energy::booked_kick`). Measured: largest fall 1.2e-5 (np 1).
        run_ok_with_contact_fall(
            np,
            &root().join("scenes/underwater_explosion.toml"),
            &out,
            1e-3,
        );
        let m = measure(&out);
        // docs/scene.md's energy error, the products' JWL internal energy (7 GJ/m^3 at t = 0)
        // included: measured 1.65 % (almost all of it in the first steps of the detonated
        // charge against its walls).
        assert!(
            m.energy_error < 0.02,
            "np {np}: energy error {} (2 %)",
            m.energy_error
        );
        for &(k, p) in &m.peaks {
            eprintln!(
                "np {np}: R = {k}A = {:.2} m, R/W^(1/3) = {:.3}: peak {p:.4e} Pa, Cole {:.4e} Pa, ratio {:.3}",
                k as f64 * A,
                k as f64 * A / (RHO_TNT * (2.0 * A).powi(3)).cbrt(),
                cole(k as f64 * A),
                p / cole(k as f64 * A)
            );
        }
        // The plate is loaded: the plug and the plate move up.
        assert!(
            m.plug_uz > 0.0 && m.plate_uz > 0.0,
            "np {np}: plug {} m, plate {} m",
            m.plug_uz,
            m.plate_uz
        );
        all.push(m);
    }
    // Cole at the two farthest probes, R = 9A and 12A (7.3 and 9.7 equivalent-sphere charge
    // radii; R/W^(1/3) = 0.38 and 0.51 m/kg^(1/3)). Tolerance 20 %, from the resolution
    // study (docs/accuracy.md): N = 2 (the CI default) -12.4 % at 12A and -4.3 % at 9A; N = 3 -1.8 %
    // and +5.7 %. The coarse mesh smears the shock over 2-3 elements and lowers its peak; the
    // kinematic particle-water coupling and the cube charge (not Cole's sphere) add the rest.
    let m = &all[0];
    for &(k, p) in &m.peaks[2..] {
        let c = cole(k as f64 * A);
        assert!(
            (p / c - 1.0).abs() <= 0.20,
            "R = {k}A: peak {p:e} Pa vs Cole {c:e} Pa (20 %)"
        );
    }
    // np 1 and np 3 agree on the global measures within 1 % (the tolerance; the
    // push-back of all contacts is solved together, so they agree to round-off of the sums).
    let (a, b) = (&all[0], &all[1]);
    let mut pairs: Vec<(String, f64, f64)> = vec![
        ("kinetic energy".into(), a.kinetic, b.kinetic),
        ("internal energy".into(), a.internal, b.internal),
        ("plug displacement".into(), a.plug_uz, b.plug_uz),
        ("plate displacement".into(), a.plate_uz, b.plate_uz),
    ];
    for (x, y) in a.peaks.iter().zip(&b.peaks) {
        pairs.push((format!("peak pressure at {}A", x.0), x.1, y.1));
    }
    for (what, x, y) in pairs {
        assert!(
            (x - y).abs() <= 0.01 * x.abs(),
            "np 1 vs np 3: {what} {x:e} vs {y:e} (1 %)"
        );
    }
}
