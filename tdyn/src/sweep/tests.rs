use super::*;

#[test]
fn parameter_specs() {
    let (t, v) = parse_param("N=10, 20,40", 0).unwrap();
    assert_eq!(
        t,
        Target::Mesh {
            mesh: 0,
            name: "N".into()
        }
    );
    assert_eq!(v, vec![10.0, 20.0, 40.0]);
    let (t, _) = parse_param("1:M=2", 0).unwrap();
    assert_eq!(t.name(), "1:M");
    let (t, _) = parse_param("M=2", 2).unwrap();
    assert_eq!(t.name(), "2:M");
    let (t, v) = parse_param("particles[1].spacing=0.002,0.001", 0).unwrap();
    assert_eq!((t, v), (Target::Spacing(Some(1)), vec![0.002, 0.001]));
    assert_eq!(
        parse_param("particles.spacing=1e-3", 0).unwrap().0,
        Target::Spacing(None)
    );
    for bad in [
        "N",
        "N=",
        "N=1,x",
        "a-b=1",
        "x:N=1",
        "particles[x].spacing=1",
    ] {
        assert!(parse_param(bad, 0).is_err(), "{bad} should be refused");
    }
}

#[test]
fn measure_specs() {
    let cols = vec!["mid.stress_xx".to_string()];
    let m = parse_measure("mid.stress_xx:final=-4.599e7", &cols).unwrap();
    assert_eq!(
        (m.file, m.kind, m.reference),
        ("probes.csv", Kind::Final, Some(-4.599e7))
    );
    let m = parse_measure("kinetic_energy", &cols).unwrap();
    assert_eq!(
        (m.file, m.kind, m.reference),
        ("history.csv", Kind::Peak, None)
    );
    let m = parse_measure("hourglass_energy.wall:final", &cols).unwrap();
    assert_eq!(
        (m.file, m.kind),
        ("history.csv", Kind::Final),
        "a per-block history column"
    );
    for bad in [
        "mid.stress_yy",
        "mid.stress_xx:max",
        "mid.stress_xx=0",
        "kinetic_energy=x",
    ] {
        assert!(
            parse_measure(bad, &cols).is_err(),
            "{bad} should be refused"
        );
    }
}
