//! SCENE.md's element failure: `[[material]] failure` (`{ plastic_strain = EPS }` or
//! `{ johnson_cook = { d1, d2, d3, d4 } }`) and `[[block]] failed` (`"delete"`, or `"particles"`,
//! the default, which is not built yet), each checked with a one-line error naming the key.
use super::{num_text, Ctx, MaterialSpec, SceneError};
use crate::input::scene::Block;
use fe_petsc::explicit::failure::Failure;

/// Each material's failure criterion, in `materials`' order, from the raw tables.
pub(super) fn check_failures(
    cx: &Ctx,
    raw: &[toml::Table],
    materials: &[MaterialSpec],
) -> Result<Vec<Option<Failure>>, SceneError> {
    let mut out = Vec::with_capacity(raw.len());
    for (i, (t, spec)) in raw.iter().zip(materials).enumerate() {
        let Some(v) = t.get("failure") else {
            out.push(None);
            continue;
        };
        let key = format!("material[{i}].failure");
        if !matches!(spec.model.as_str(), "j2_plastic" | "johnson_cook") {
            return Err(cx.err(
                &key,
                format!(
                    "model {} has no plastic strain to fail at: failure needs j2_plastic or johnson_cook",
                    spec.model
                ),
            ));
        }
        let table = v.as_table().ok_or_else(|| {
            cx.err(
                &key,
                "expected { plastic_strain = ... } or { johnson_cook = { d1 = ..., d2 = ..., d3 = ..., d4 = ... } }".into(),
            )
        })?;
        if let Some(k) = table
            .keys()
            .find(|k| !["plastic_strain", "johnson_cook"].contains(&k.as_str()))
        {
            return Err(cx.err(
                &format!("{key}.{k}"),
                "unknown key (expected plastic_strain or johnson_cook)".into(),
            ));
        }
        let kinds: Vec<&String> = table.keys().collect();
        let f = match kinds.as_slice() {
            [k] if k.as_str() == "plastic_strain" => {
                let v = &table["plastic_strain"];
                let e = number(v).filter(|e| *e > 0.0 && e.is_finite());
                let e = e.ok_or_else(|| {
                    cx.err(
                        &format!("{key}.plastic_strain"),
                        quoted(v).unwrap_or_else(|| {
                            "expected a positive equivalent plastic strain (dimensionless)".into()
                        }),
                    )
                })?;
                Failure::PlasticStrain(e)
            }
            [k] if k.as_str() == "johnson_cook" => {
                let d = johnson_cook(cx, &format!("{key}.johnson_cook"), &table["johnson_cook"])?;
                let eps_dot0 = spec.params.get("eps_dot0").copied().unwrap_or(1.0);
                Failure::JohnsonCook { d, eps_dot0 }
            }
            _ => {
                return Err(cx.err(
                    &key,
                    "expected exactly one of plastic_strain or johnson_cook".into(),
                ))
            }
        };
        out.push(Some(f));
    }
    Ok(out)
}

/// The message for a number written in quotes (`"0.3"`), where `v` is one.
fn quoted(v: &toml::Value) -> Option<String> {
    let s = v.as_str()?;
    s.trim().parse::<f64>().ok()?;
    Some(format!(
        "expected a number, got a string (\"{s}\": write it without quotes)"
    ))
}

fn number(v: &toml::Value) -> Option<f64> {
    match v {
        toml::Value::Float(x) => Some(*x),
        toml::Value::Integer(n) => Some(*n as f64),
        _ => None,
    }
}

/// The largest plastic strain rate, over the reference rate, at which Johnson-Cook's rate
/// factor of the strain to failure must stay positive (a negative `d4` is checked against it).
const MAX_RATE_RATIO: f64 = 1e8;

/// `{ d1, d2, d3, d4 }`: four finite numbers, and a strain to failure positive at every
/// triaxiality from -1/3 to 3 at the reference rate (d1 + d2 exp(d3 s) > 0 there) and up to
/// [`MAX_RATE_RATIO`] times that rate.
fn johnson_cook(cx: &Ctx, key: &str, v: &toml::Value) -> Result<[f64; 4], SceneError> {
    let t = v.as_table().ok_or_else(|| {
        cx.err(
            key,
            "expected { d1 = ..., d2 = ..., d3 = ..., d4 = ... }".into(),
        )
    })?;
    if let Some(k) = t
        .keys()
        .find(|k| !["d1", "d2", "d3", "d4"].contains(&k.as_str()))
    {
        return Err(cx.err(
            &format!("{key}.{k}"),
            "unknown key (expected d1, d2, d3, d4)".into(),
        ));
    }
    let mut d = [0.0; 4];
    for (j, name) in ["d1", "d2", "d3", "d4"].iter().enumerate() {
        let v = t.get(*name);
        d[j] = v
            .and_then(number)
            .filter(|x| x.is_finite())
            .ok_or_else(|| {
                cx.err(
                    &format!("{key}.{name}"),
                    v.and_then(quoted)
                        .unwrap_or_else(|| "missing or not a finite number".into()),
                )
            })?;
    }
    // The rate factor 1 + d4 ln(rate*) stays positive up to rate* = 1e8 (a negative d4 makes
    // the material more brittle with the rate, and past its zero the strain to failure would
    // be negative: damage would fall as the element deforms).
    let rate_factor = 1.0 + d[3] * MAX_RATE_RATIO.ln();
    if rate_factor <= 0.0 {
        return Err(cx.err(
            &format!("{key}.d4"),
            format!(
                "{}: the rate factor 1 + d4 ln(rate / eps_dot0) would reach zero at a plastic strain rate of {:.3e} times eps_dot0 (it must stay positive up to {MAX_RATE_RATIO:e} times: d4 > {:.4})",
                num_text(d[3]),
                (-1.0 / d[3]).exp(),
                -1.0 / MAX_RATE_RATIO.ln()
            ),
        ));
    }
    for s in [-1.0 / 3.0, 0.0, 1.0 / 3.0, 1.0, 3.0f64] {
        let e = d[0] + d[1] * (d[2] * s).exp();
        if e <= 0.0 || !e.is_finite() {
            return Err(cx.err(
                key,
                format!(
                    "the strain to failure d1 + d2 exp(d3 triaxiality) is {} at triaxiality {}: it must be positive",
                    num_text(e),
                    num_text(s)
                ),
            ));
        }
    }
    Ok(d)
}

/// `[[block]] failed`: `"delete"`, or `"particles"` (the default where the material fails).
/// The blocks of one material must agree (a material's failed elements become one thing).
pub(super) fn check_failed(
    cx: &Ctx,
    blocks: &[Block],
    materials: &[MaterialSpec],
    failures: &[Option<Failure>],
) -> Result<(), SceneError> {
    for (i, b) in blocks.iter().enumerate() {
        let key = format!("block[{i}].failed");
        let fails = materials
            .iter()
            .zip(failures)
            .any(|(m, f)| m.name == b.material && f.is_some());
        let mode = match &b.failed {
            None => None,
            Some(toml::Value::String(s)) if s == "delete" || s == "particles" => Some(s.as_str()),
            Some(_) => {
                return Err(cx.err(&key, "expected \"delete\" or \"particles\"".into()));
            }
        };
        if let (false, Some(_)) = (fails, mode) {
            return Err(cx.err(
                &key,
                format!(
                    "material \"{}\" has no failure: give it failure = {{ plastic_strain = ... }} or remove failed",
                    b.material
                ),
            ));
        }
        let deletes = mode == Some("delete");
        if let Some(j) = blocks[..i]
            .iter()
            .position(|o| o.material == b.material && o.deletes() != deletes)
        {
            return Err(cx.err(
                &key,
                format!(
                    "block[{j}] of the same material \"{}\" says failed = \"{}\": the blocks of one material must agree",
                    b.material,
                    if blocks[j].deletes() { "delete" } else { "particles" }
                ),
            ));
        }
    }
    Ok(())
}
