//! Failure criteria (`fe_petsc::explicit::failure`) against their formulas evaluated by hand:
//! the stress triaxiality of simple stress states and Johnson & Cook's (1985) strain to
//! failure.
use fe_petsc::explicit::failure::{triaxiality, Failure};

#[test]
fn triaxiality_of_simple_stress_states() {
    // sigma* = mean stress / von Mises stress: uniaxial tension 1/3, compression -1/3, pure
    // shear 0, equibiaxial tension 2/3, hydrostatic (q = 0) taken as 0; to 1e-15.
    let s = 250.0e6;
    let cases = [
        ([s, 0.0, 0.0, 0.0, 0.0, 0.0], 1.0 / 3.0),
        ([0.0, -s, 0.0, 0.0, 0.0, 0.0], -1.0 / 3.0),
        ([0.0, 0.0, 0.0, s, 0.0, 0.0], 0.0),
        ([s, s, 0.0, 0.0, 0.0, 0.0], 2.0 / 3.0),
        ([s, s, s, 0.0, 0.0, 0.0], 0.0),
    ];
    for (stress, want) in cases {
        let got = triaxiality(&stress);
        assert!((got - want).abs() < 1e-15, "{stress:?}: {got} vs {want}");
    }
}

#[test]
fn johnson_cook_strain_to_failure_follows_its_three_factors() {
    // eps_f = (d1 + d2 exp(d3 sigma*)) (1 + d4 ln(rate / eps_dot0)), the rate term from
    // rate* = 1 on (Johnson & Cook 1985, eq. 3). With d = (0.5, 1, -1.5, 0.1), eps_dot0 = 2:
    // at sigma* = 0 and rate* <= 1: 1.5; at sigma* = 2/3: 0.5 + exp(-1) = 0.8679; at rate*
    // = e^2 (rate = 2 e^2): times 1.2. To 1e-15 relative.
    let f = Failure::JohnsonCook {
        d: [0.5, 1.0, -1.5, 0.1],
        eps_dot0: 2.0,
    };
    let e2 = std::f64::consts::E * std::f64::consts::E;
    let cases = [
        (0.0, 1.0, 1.5),
        (0.0, 0.5, 1.5),
        (2.0 / 3.0, 2.0, 0.5 + (-1.0f64).exp()),
        (0.0, 2.0 * e2, 1.5 * 1.2),
    ];
    for (triax, rate, want) in cases {
        let got = f.strain_to_failure(triax, rate);
        assert!(
            (got - want).abs() < 1e-15 * want,
            "sigma* {triax}, rate {rate}: {got} vs {want}"
        );
    }
    assert_eq!(Failure::PlasticStrain(0.3).strain_to_failure(0.7, 1e3), 0.3);
}

#[test]
fn a_failed_elements_particle_volume_is_its_volume_within_half_and_twice_its_reference() {
    // docs/scene.md, `failed = "particles"`: the volume at failure, bounded to [V0/2, 2 V0];
    // none recorded (0) or not a number: V0.
    use fe_petsc::explicit::failure::particle_volume;
    let v0 = 1e-9;
    assert_eq!(particle_volume(1.01e-9, v0), 1.01e-9);
    assert_eq!(particle_volume(1e-18, v0), 0.5e-9);
    assert_eq!(particle_volume(5e-9, v0), 2e-9);
    assert_eq!(particle_volume(0.0, v0), v0);
    assert_eq!(particle_volume(f64::NAN, v0), v0);
}
