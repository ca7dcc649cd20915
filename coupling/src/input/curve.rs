//! The scene's load curves (docs/scene.md `curve`, `gravity_curve`): `[[t, s], ...]`, a
//! piecewise-linear scale factor of time ([`fe_petsc::curve::Curve`]), checked here with errors
//! naming the file and the key.
use super::scene::SceneError;
pub use fe_petsc::curve::Curve;

/// The curve of the points `raw` at `key` of scene `file`: at least one point, each two
/// finite numbers `[t, s]` (s, scale), times >= 0 (the run starts at t = 0) and strictly
/// increasing.
pub fn check(file: &str, key: &str, raw: &[Vec<f64>]) -> Result<Curve, SceneError> {
    let err = |key: String, message: String| SceneError {
        file: file.to_string(),
        key,
        message,
    };
    if raw.is_empty() {
        return Err(err(
            key.to_string(),
            "expected at least one point: curve = [[t, s], ...] (t in s, s a scale factor)".into(),
        ));
    }
    let mut points = Vec::with_capacity(raw.len());
    for (k, p) in raw.iter().enumerate() {
        let at = format!("{key}[{k}]");
        let &[t, s] = p.as_slice() else {
            return Err(err(
                at,
                format!(
                    "expected a point [t, s] (time in s, scale factor), got {} values",
                    p.len()
                ),
            ));
        };
        if !t.is_finite() || !s.is_finite() {
            return Err(err(at, format!("expected finite numbers, got [{t}, {s}]")));
        }
        if t < 0.0 {
            return Err(err(
                at,
                format!("expected a time >= 0 s (the run starts at t = 0), got {t}"),
            ));
        }
        if let Some(&(t_prev, _)) = points.last() {
            if t <= t_prev {
                return Err(err(
                    at,
                    format!("times must increase strictly: t = {t} s follows t = {t_prev} s"),
                ));
            }
        }
        points.push((t, s));
    }
    Ok(Curve::new(points))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts(v: &[[f64; 2]]) -> Vec<Vec<f64>> {
        v.iter().map(|p| p.to_vec()).collect()
    }

    #[test]
    fn a_good_curve_reads_its_points() {
        let c = check("s.toml", "load[0].curve", &pts(&[[0.0, 0.0], [1e-3, 2.0]])).unwrap();
        assert_eq!(c.points(), &[(0.0, 0.0), (1e-3, 2.0)]);
        // Halfway up the ramp: 1.0 by hand.
        assert_eq!(c.value(0.5e-3), 1.0);
    }

    #[test]
    fn mistakes_name_the_file_the_key_and_the_point() {
        let e = check("s.toml", "gravity_curve", &[]).unwrap_err();
        assert_eq!(e.key, "gravity_curve");
        assert!(e.message.contains("at least one point"), "{e}");
        let e = check("s.toml", "c", &pts(&[[0.0, 1.0], [2.0, 1.0], [1.0, 0.0]])).unwrap_err();
        assert_eq!((e.file.as_str(), e.key.as_str()), ("s.toml", "c[2]"));
        assert!(e.message.contains("increase strictly"), "{e}");
        let e = check("s.toml", "c", &pts(&[[0.0, 1.0], [0.0, 2.0]])).unwrap_err();
        assert!(e.message.contains("increase strictly"), "{e}");
        let e = check("s.toml", "c", &pts(&[[-1.0, 1.0]])).unwrap_err();
        assert!(e.message.contains(">= 0"), "{e}");
        let e = check("s.toml", "c", &[vec![1.0]]).unwrap_err();
        assert!(e.message.contains("got 1 values"), "{e}");
        let e = check("s.toml", "c", &[vec![1.0, f64::NAN]]).unwrap_err();
        assert!(e.message.contains("finite"), "{e}");
    }
}
