//! The scene's checks: every table in the order docs/scene.md documents it, the first mistake
//! reported with the file, the key and what was expected.
use super::*;

mod stages;
use stages::*;
pub use stages::{validate_groups, validate_groups_hold_elements};

/// Model keys by model (besides `name`, `model`, `density`, `eos`).
const MODEL_KEYS: &[(&str, &[&str])] = &[
    ("elastic", &["youngs_modulus", "poisson_ratio"]),
    (
        "j2_plastic",
        &[
            "youngs_modulus",
            "poisson_ratio",
            "yield_stress",
            "hardening_modulus",
        ],
    ),
    (
        "johnson_cook",
        &[
            "youngs_modulus",
            "poisson_ratio",
            "a",
            "b",
            "n",
            "c",
            "eps_dot0",
        ],
    ),
    ("fluid", &[]),
];

/// Optional model keys: Johnson-Cook's thermal softening (docs/scene.md: `m`, `t_room`,
/// `t_melt`, `specific_heat` together, `taylor_quinney` optional, default 0.9).
const OPTIONAL_KEYS: &[(&str, &[&str])] = &[("johnson_cook", &fe_petsc::material::JC_THERMAL_KEYS)];

/// Of the optional keys, those needed together once one is given.
const TOGETHER_KEYS: &[(&str, &[&str])] =
    &[("johnson_cook", &["m", "t_room", "t_melt", "specific_heat"])];

/// Names the scene file in every error.
struct Ctx {
    file: String,
}

impl Ctx {
    /// An error at `key`.
    fn err(&self, key: &str, message: String) -> SceneError {
        SceneError {
            file: self.file.clone(),
            key: key.to_string(),
            message,
        }
    }
}

#[path = "failure.rs"]
mod failure;

/// A number as a message shows it: plain when short, in exponent form when very large or
/// very small.
pub fn num_text(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// A positive finite number.
fn pos(v: f64) -> bool {
    v > 0.0 && v.is_finite()
}

/// Parses scene text; `file` names it in errors and anchors relative paths. The tables are
/// checked in the order they are documented (docs/scene.md); the first mistake is reported.
pub fn parse(text: &str, file: &Path) -> Result<Scene, SceneError> {
    let cx = Ctx {
        file: file.display().to_string(),
    };
    let raw = deserialize(&cx, text)?;
    let dir = file.parent().unwrap_or(Path::new(".")).to_path_buf();
    check_run(&cx, &raw.run)?;
    let meshes = check_meshes(&cx, &dir, &raw.mesh, raw.particles.is_empty())?;
    let materials = check_materials(&cx, &raw.material)?;
    check_blocks(&cx, &raw.block, &materials)?;
    let failures = failure::check_failures(&cx, &raw.material, &materials)?;
    failure::check_failed(&cx, &raw.block, &materials, &failures)?;
    let gravity_curve = raw
        .gravity_curve
        .as_ref()
        .map(|c| crate::input::curve::check(&cx.file, "gravity_curve", c))
        .transpose()?;
    // A curve scales gravity: with none (or zero) it would scale nothing, without a word (as a
    // wall's curve needs the wall's velocity).
    if gravity_curve.is_some() && raw.gravity == [0.0; 3] {
        return Err(cx.err(
            "gravity_curve",
            "a curve scales gravity, which is zero here: give gravity = [x, y, z] (m/s^2) too, a top-level key before the first [table], or remove gravity_curve".into(),
        ));
    }
    let boundaries = check_boundaries(&cx, &raw.boundary)?;
    let loads = check_loads(&cx, &raw.load)?;
    // failed elements that become particles make the run one with solid particles
    let born = raw.block.iter().any(|b| {
        !b.deletes()
            && (materials.iter().zip(&failures)).any(|(m, f)| m.name == b.material && f.is_some())
    });
    check_particles(&cx, &raw.particles, &materials, raw.sph.as_ref(), born)?;
    if let Some(s) = &raw.sph {
        check_sph(&cx, s)?;
    }
    if let Some(c) = &raw.contact {
        check_contact(&cx, c)?;
    }
    let rigid_walls = check_rigid_walls(&cx, &raw.rigid_wall, &boundaries)?;
    check_probes(&cx, &raw.probe)?;
    check_output(&cx, &raw.output)?;
    let mut output = raw.output;
    // The default fields take `temperature` where a material has one.
    let thermal = materials
        .iter()
        .any(|m| m.model == "johnson_cook" && m.params.contains_key("m"));
    let default_fields = output.fields == super::d_fields();
    if thermal && default_fields {
        output.fields.push("temperature".into());
    }
    // The default fields take `failed` where a material fails (an eroded element is still
    // drawn: 1 marks it, for ParaView's Threshold).
    if default_fields && failures.iter().any(Option::is_some) {
        output.fields.push("failed".into());
    }
    if !thermal {
        for (i, p) in raw.probe.iter().enumerate() {
            if p.fields.contains(&super::ProbeField::Temperature) {
                return Err(cx.err(
                    &format!("probe[{i}].fields"),
                    "temperature needs a johnson_cook material with thermal softening (m, t_room, t_melt, specific_heat)".into(),
                ));
            }
        }
    }
    if let Some(c) = &raw.compare {
        check_compare(&cx, c, &raw.probe)?;
    }
    Ok(Scene {
        file: file.to_path_buf(),
        dir,
        title: raw.title,
        gravity: raw.gravity,
        gravity_curve,
        run: raw.run,
        meshes,
        materials,
        failures,
        blocks: raw.block,
        boundaries,
        loads,
        particles: raw.particles,
        sph: raw.sph,
        contact: raw.contact,
        rigid_walls,
        probes: raw.probe,
        output,
        compare: raw.compare,
        sweep: raw.sweep,
    })
}

/// The TOML text into the raw tables (serde: unknown keys and wrong types refused, with their
/// path).
fn deserialize(cx: &Ctx, text: &str) -> Result<RawScene, SceneError> {
    let de = toml::Deserializer::new(text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        // One line (toml's parse messages run over several).
        let mut msg = inner
            .message()
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .collect::<Vec<_>>()
            .join("; ");
        if msg.is_empty() {
            // toml says nothing at some ends of input (`model = ` as the last line).
            msg = "invalid TOML (a value missing?)".into();
        }
        if let Some(q) = quoted_number(&msg) {
            msg = format!("expected a number, got a string (\"{q}\": write it without quotes)");
        }
        // A top-level key written after a [table] header lands in that table (TOML's rule).
        if let Some(k) = ["title", "gravity", "gravity_curve"]
            .into_iter()
            .find(|k| msg.starts_with(&format!("unknown field `{k}`")))
        {
            msg = format!(
                "{msg}; {k} is a top-level key: write it before the first [table] (after a [table] header a key belongs to that table)"
            );
        }
        if let Some(r) = inner.span() {
            let (line, column) = line_column(text, r.start);
            msg = format!("{msg} (line {line}, column {column})");
        }
        let key = if path.is_empty() || path == "." {
            "(scene)".to_string()
        } else {
            path
        };
        cx.err(&key, msg)
    })
}

/// The quoted text of serde's `invalid type: string "X", expected f64` (or another number
/// type) where `X` reads as a number: a number written in quotes.
fn quoted_number(msg: &str) -> Option<&str> {
    let rest = msg.strip_prefix("invalid type: string \"")?;
    let (q, tail) = rest.split_once('"')?;
    let wanted = tail.strip_prefix(", expected ")?;
    let numeric = [
        "f64", "f32", "u64", "u32", "u16", "u8", "usize", "i64", "i32", "a number",
    ];
    (numeric.iter().any(|t| wanted.starts_with(t)) && q.trim().parse::<f64>().is_ok()).then_some(q)
}

/// The 1-based line and column (in characters) of byte `at` of `text`.
fn line_column(text: &str, at: usize) -> (usize, usize) {
    let mut at = at.min(text.len());
    while !text.is_char_boundary(at) {
        at -= 1;
    }
    let before = &text[..at];
    let line = before.matches('\n').count() + 1;
    let start = before.rfind('\n').map_or(0, |i| i + 1);
    (line, before[start..].chars().count() + 1)
}

/// `[run]`: times, step, intervals, energy limit, bulk viscosity and hourglass control.
fn check_run(cx: &Ctx, r: &Run) -> Result<(), SceneError> {
    if !pos(r.end_time) {
        return Err(cx.err(
            "run.end_time",
            format!("expected a positive number of seconds, got {}", r.end_time),
        ));
    }
    if !(r.dt_safety > 0.0 && r.dt_safety <= 1.0) {
        return Err(cx.err(
            "run.dt_safety",
            format!("expected a fraction in (0, 1], got {}", r.dt_safety),
        ));
    }
    if let Some(dt) = r.dt {
        if !pos(dt) {
            return Err(cx.err(
                "run.dt",
                format!("expected a positive step in seconds, got {dt}"),
            ));
        }
    } else if r.mode == Mode::Implicit {
        return Err(cx.err(
            "run.dt",
            "mode = \"implicit\" needs a fixed step run.dt (seconds)".into(),
        ));
    }
    if r.mode == Mode::Implicit && r.tetrahedra == Tetrahedra::NodalPressure {
        return Err(cx.err(
            "run.tetrahedra",
            "\"nodal_pressure\" tetrahedra run in explicit mode only (its nodal average has no implicit tangent here): use \"split\" (the default) with mode = \"implicit\"".into(),
        ));
    }
    if let Some(o) = r.output_every {
        if !pos(o) {
            return Err(cx.err(
                "run.output_every",
                format!("expected a positive interval in seconds, got {o}"),
            ));
        }
    }
    if !(r.history_every >= 0.0 && r.history_every.is_finite()) {
        return Err(cx.err(
            "run.history_every",
            format!("expected seconds >= 0, got {}", r.history_every),
        ));
    }
    if !pos(r.max_energy_error) {
        return Err(cx.err(
            "run.max_energy_error",
            format!("expected a positive fraction, got {}", r.max_energy_error),
        ));
    }
    for (k, v) in [
        ("run.bulk_viscosity.linear", r.bulk_viscosity.linear),
        ("run.bulk_viscosity.quadratic", r.bulk_viscosity.quadratic),
        (
            "run.hourglass.coefficient",
            r.hourglass.coefficient.unwrap_or(0.0),
        ),
    ] {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(cx.err(k, format!("expected a coefficient >= 0, got {v}")));
        }
    }
    if !HOURGLASS_KINDS.contains(&r.hourglass.kind.as_str()) {
        return Err(cx.err(
            "run.hourglass.kind",
            format!(
                "expected one of {}, got \"{}\"",
                HOURGLASS_KINDS.join(", "),
                r.hourglass.kind
            ),
        ));
    }
    if !(r.max_steps >= 1.0 && r.max_steps.is_finite()) {
        return Err(cx.err(
            "run.max_steps",
            format!("expected a number of steps >= 1, got {}", r.max_steps),
        ));
    }
    work_bounds(cx, r, r.dt)
}

/// The work a run asks for, refused with its numbers before it starts (docs/scene.md "Exit
/// status"): more than `run.max_steps` steps, more than [`MAX_FRAMES`] frames or [`MAX_ROWS`]
/// rows, or intervals [`MAX_OUTPUTS_PER_STEP`] times shorter than the step. `dt` is the step
/// when known (a fixed `run.dt`, or the first step the run takes); the scene check passes the
/// fixed one, the run the one it starts with ([`check_work`]).
fn work_bounds(cx: &Ctx, r: &Run, dt: Option<f64>) -> Result<(), SceneError> {
    let end = r.end_time;
    if let Some(dt) = dt {
        let steps = end / dt;
        if !(steps <= r.max_steps) {
            let (key, step) = match r.dt {
                Some(_) => ("run.dt", "run.dt"),
                None => ("run.end_time", "the stable step times run.dt_safety"),
            };
            return Err(cx.err(
                key,
                format!(
                    "run.end_time = {end:e} s in steps of {dt:.3e} s ({step}) is {steps:.3e} steps, more than run.max_steps = {:e}: check the units (SI: m, kg, s) and the values; raise run.max_steps to run it anyway",
                    r.max_steps
                ),
            ));
        }
    }
    let intervals = [
        ("run.output_every", "frames", r.output_every, MAX_FRAMES),
        (
            "run.history_every",
            "rows",
            Some(r.history_every).filter(|h| *h > 0.0),
            MAX_ROWS,
        ),
    ];
    for (key, what, every, max) in intervals {
        let Some(every) = every else { continue };
        let every_step = if what == "rows" {
            " (history_every = 0 writes a row every step)"
        } else {
            ""
        };
        let count = end / every;
        if count > max {
            return Err(cx.err(
                key,
                format!(
                    "{every:e} s over run.end_time = {end:e} s is {count:.3e} {what}, more than the {max:e} a run may write: use a longer interval{every_step}"
                ),
            ));
        }
        if let Some(dt) = dt.filter(|dt| every * MAX_OUTPUTS_PER_STEP < *dt) {
            return Err(cx.err(
                key,
                format!(
                    "{every:e} s is {:.3e} times shorter than the step {dt:e} s: {what} come at most once a step; use an interval of at least the step{every_step}",
                    dt / every
                ),
            ));
        }
    }
    Ok(())
}

/// The work bounds of `work_bounds` at the step the run starts with (`dt`: the fixed step,
/// or the safety factor times the stable step), once it is known.
pub fn check_work(scene: &Scene, dt: f64) -> Result<(), SceneError> {
    let cx = Ctx {
        file: scene.file.display().to_string(),
    };
    work_bounds(&cx, &scene.run, Some(dt))
}

/// `[[mesh]]`: each file a .geo or .msh that exists (relative to the scene's directory); a
/// scene needs a mesh unless it has particles.
fn check_meshes(
    cx: &Ctx,
    dir: &Path,
    raw: &[RawMesh],
    no_particles: bool,
) -> Result<Vec<MeshDef>, SceneError> {
    let mut meshes = Vec::new();
    for (i, m) in raw.iter().enumerate() {
        let f = dir.join(&m.file);
        let ext = f.extension().and_then(|e| e.to_str()).unwrap_or("");
        if ext != "geo" && ext != "msh" {
            return Err(cx.err(
                &format!("mesh[{i}].file"),
                format!("expected a .geo or .msh file, got {}", m.file.display()),
            ));
        }
        if !f.exists() {
            return Err(cx.err(
                &format!("mesh[{i}].file"),
                format!("no such file: {}", f.display()),
            ));
        }
        let def = MeshDef {
            file: f,
            params: m.params.clone(),
            translate: m.translate,
        };
        crate::input::gmsh::check_params(&def)
            .map_err(|(name, why)| cx.err(&format!("mesh[{i}].params.{name}"), why))?;
        meshes.push(def);
    }
    if meshes.is_empty() && no_particles {
        return Err(cx.err(
            "mesh",
            "a scene needs at least one [[mesh]] or [[particles]]".into(),
        ));
    }
    Ok(meshes)
}

/// `[[material]]`: each table checked against its model's keys and built once (a fluid is
/// built when a block meshes it: [`check_blocks`]).
fn check_materials(cx: &Ctx, raw: &[toml::Table]) -> Result<Vec<MaterialSpec>, SceneError> {
    let mut materials: Vec<MaterialSpec> = Vec::new();
    for (i, t) in raw.iter().enumerate() {
        let spec = check_material(cx, i, t, &materials)?;
        if spec.model != "fluid" {
            if let Err(e) = fe_petsc::material::build_material(&spec) {
                return Err(material_error(cx, i, e));
            }
        }
        materials.push(spec);
    }
    Ok(materials)
}

/// A material the library refused, as `FILE: material[i].KEY: ...` where the error names a key
/// (a value out of range, a key missing or unknown), else `FILE: material[i]: ...`.
fn material_error(cx: &Ctx, i: usize, e: fe_petsc::material::MaterialError) -> SceneError {
    use fe_petsc::material::MaterialError as E;
    match e {
        E::BadValue {
            name,
            key,
            value,
            why,
        } => cx.err(
            &format!("material[{i}].{key}"),
            format!("{why}, got {} (material \"{name}\")", num_text(value)),
        ),
        E::Missing { name, key, model } => cx.err(
            &format!("material[{i}].{key}"),
            format!("missing (needed by model {model}; material \"{name}\")"),
        ),
        E::UnknownKey {
            name,
            key,
            model,
            expected,
        } => cx.err(
            &format!("material[{i}].{key}"),
            format!("unknown key for model {model} (expected {expected}; material \"{name}\")"),
        ),
        e => cx.err(&format!("material[{i}]"), e.to_string()),
    }
}

/// One `[[material]]` table (the `i`-th): name (unique among `earlier`), model, density, the
/// model's keys, and a fluid's `eos`.
fn check_material(
    cx: &Ctx,
    i: usize,
    t: &toml::Table,
    earlier: &[MaterialSpec],
) -> Result<MaterialSpec, SceneError> {
    let key = |k: &str| format!("material[{i}].{k}");
    let name = match t.get("name") {
        Some(toml::Value::String(s)) => s.clone(),
        Some(_) => return Err(cx.err(&key("name"), "expected a string".into())),
        None => return Err(cx.err(&key("name"), "missing (every material needs a name)".into())),
    };
    if earlier.iter().any(|m| m.name == name) {
        return Err(cx.err(
            &key("name"),
            format!("material \"{name}\" is defined twice"),
        ));
    }
    let model = match t.get("model") {
        Some(toml::Value::String(s)) => s.clone(),
        Some(_) => return Err(cx.err(&key("model"), "expected a string".into())),
        None => {
            return Err(cx.err(
                &key("model"),
                "missing (elastic, j2_plastic, johnson_cook or fluid)".into(),
            ))
        }
    };
    let Some((_, keys)) = MODEL_KEYS.iter().find(|(m, _)| *m == model) else {
        return Err(cx.err(&key("model"), format!("unknown model \"{model}\" (expected one of elastic, j2_plastic, johnson_cook, fluid)")));
    };
    let density = match t.get("density").map(number) {
        Some(Ok(d)) if pos(d) => d,
        Some(Ok(d)) => {
            return Err(cx.err(
                &key("density"),
                format!("expected a positive density in kg/m^3, got {d}"),
            ))
        }
        Some(Err(e)) => return Err(cx.err(&key("density"), e)),
        None => return Err(cx.err(&key("density"), "missing (kg/m^3)".into())),
    };
    let mut params = BTreeMap::new();
    let mut eos = None;
    for (k, v) in t {
        match k.as_str() {
            "name" | "model" | "density" => {}
            "eos" if model == "fluid" => eos = Some(check_eos(cx, i, v)?),
            "failure" => {} // `failure::check_failures`
            _ => {
                let optional = OPTIONAL_KEYS
                    .iter()
                    .find(|(m, _)| *m == model)
                    .map_or(&[][..], |o| o.1);
                if !keys.contains(&k.as_str()) && !optional.contains(&k.as_str()) {
                    let mut all: Vec<&str> = vec!["name", "model", "density"];
                    all.extend(keys.iter());
                    all.extend(optional.iter());
                    if model == "fluid" {
                        all.push("eos");
                    }
                    return Err(cx.err(
                        &key(k),
                        format!(
                            "unknown key for model {model} (expected one of {})",
                            all.join(", ")
                        ),
                    ));
                }
                let x = number(v).map_err(|e| cx.err(&key(k), e))?;
                params.insert(k.clone(), x);
            }
        }
    }
    for need in keys.iter() {
        if !params.contains_key(*need) {
            return Err(cx.err(
                &key(need),
                format!("missing (model {model} needs {})", keys.join(", ")),
            ));
        }
    }
    if let Some((_, together)) = TOGETHER_KEYS.iter().find(|(m, _)| *m == model) {
        let any = OPTIONAL_KEYS
            .iter()
            .filter(|(m, _)| *m == model)
            .any(|(_, o)| o.iter().any(|k| params.contains_key(*k)));
        if any {
            if let Some(need) = together.iter().find(|k| !params.contains_key(**k)) {
                return Err(cx.err(
                    &key(need),
                    format!(
                        "missing: thermal softening needs {} together",
                        together.join(", ")
                    ),
                ));
            }
        }
    }
    if model == "fluid" && eos.is_none() {
        return Err(cx.err(
            &key("eos"),
            "missing: a fluid needs eos = { kind = ..., ... }".into(),
        ));
    }
    Ok(MaterialSpec {
        name,
        model,
        density,
        params,
        eos,
    })
}

/// The `eos` table of fluid material `i`: a kind from the eos crate's name table and exactly
/// that kind's keys, each a number.
fn check_eos(cx: &Ctx, i: usize, v: &toml::Value) -> Result<EosSpec, SceneError> {
    let key = |k: &str| format!("material[{i}].{k}");
    let Some(et) = v.as_table() else {
        return Err(cx.err(&key("eos"), "expected a table { kind = ..., ... }".into()));
    };
    let kind = et
        .get("kind")
        .and_then(|k| k.as_str())
        .unwrap_or("")
        .to_string();
    // the equation-of-state keys by kind: the eos crate's table
    let Some(ek) = ::eos::kind(&kind).map(|k| k.keys) else {
        return Err(cx.err(
            &key("eos.kind"),
            format!(
                "unknown or missing eos kind \"{kind}\" (expected one of {})",
                ::eos::kind_names()
            ),
        ));
    };
    let mut ep = BTreeMap::new();
    for (ekk, ev) in et {
        if ekk == "kind" {
            continue;
        }
        if !ek.contains(&ekk.as_str()) {
            return Err(cx.err(
                &key(&format!("eos.{ekk}")),
                format!("unknown key for eos {kind} (expected {})", ek.join(", ")),
            ));
        }
        let x = number(ev).map_err(|e| cx.err(&key(&format!("eos.{ekk}")), e))?;
        ep.insert(ekk.clone(), x);
    }
    for need in ek.iter() {
        if !ep.contains_key(*need) {
            return Err(cx.err(
                &key(&format!("eos.{need}")),
                format!("missing (eos {kind} needs {})", ek.join(", ")),
            ));
        }
    }
    Ok(EosSpec { kind, params: ep })
}

/// The material names, for messages.
fn material_names(materials: &[MaterialSpec]) -> String {
    materials
        .iter()
        .map(|m| m.name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// `[[block]]`: each names a defined material; a fluid meshed by a block is built here (its
/// EOS keys and values checked); particles take their EOS from the SPH side.
fn check_blocks(cx: &Ctx, blocks: &[Block], materials: &[MaterialSpec]) -> Result<(), SceneError> {
    for (i, b) in blocks.iter().enumerate() {
        if let Some(j) = blocks[..i].iter().position(|o| o.group == b.group) {
            return Err(cx.err(
                &format!("block[{i}].group"),
                format!(
                    "group \"{}\" already has a block (block[{j}]): one [[block]] per physical volume",
                    b.group
                ),
            ));
        }
        if !materials.iter().any(|m| m.name == b.material) {
            return Err(cx.err(
                &format!("block[{i}].material"),
                format!(
                    "no material named \"{}\" (materials: {})",
                    b.material,
                    material_names(materials)
                ),
            ));
        }
    }
    for (i, m) in materials.iter().enumerate() {
        if m.model == "fluid" && blocks.iter().any(|b| b.material == m.name) {
            if let Err(e) = fe_petsc::material::build_material(m) {
                return Err(material_error(cx, i, e));
            }
        }
    }
    Ok(())
}

/// `[[boundary]]`: the kind, and a velocity exactly when the kind is `velocity`.
fn check_boundaries(cx: &Ctx, raw: &[RawBoundary]) -> Result<Vec<Boundary>, SceneError> {
    let mut boundaries = Vec::new();
    for (i, b) in raw.iter().enumerate() {
        let kind = match (b.kind.as_str(), b.velocity) {
            ("fixed", None) => BoundaryKind::Fixed,
            ("symmetry", None) => BoundaryKind::Symmetry,
            ("velocity", Some(v)) => BoundaryKind::Velocity(v),
            ("velocity", None) => {
                return Err(cx.err(
                    &format!("boundary[{i}].velocity"),
                    "missing: kind = \"velocity\" needs velocity = [vx, vy, vz]".into(),
                ))
            }
            ("fixed" | "symmetry", Some(_)) => {
                return Err(cx.err(
                    &format!("boundary[{i}].velocity"),
                    format!(
                        "only kind = \"velocity\" takes a velocity (this boundary is \"{}\")",
                        b.kind
                    ),
                ))
            }
            (k, _) => {
                return Err(cx.err(
                    &format!("boundary[{i}].kind"),
                    format!("unknown kind \"{k}\" (expected fixed, velocity or symmetry)"),
                ))
            }
        };
        let curve = match (&b.curve, &kind) {
            (None, _) => None,
            (Some(c), BoundaryKind::Velocity(_)) => Some(crate::input::curve::check(
                &cx.file,
                &format!("boundary[{i}].curve"),
                c,
            )?),
            (Some(_), _) => {
                return Err(cx.err(
                    &format!("boundary[{i}].curve"),
                    format!(
                        "only kind = \"velocity\" takes a curve (this boundary is \"{}\")",
                        b.kind
                    ),
                ))
            }
        };
        boundaries.push(Boundary {
            group: b.group.clone(),
            kind,
            curve,
        });
    }
    Ok(boundaries)
}

/// A solid's density below this is almost always a unit slip (steel in t/mm^3 is 7.85e-9;
/// the lightest structural foams are about 30 kg/m^3): a warning, not an error.
pub const LOW_SOLID_DENSITY: f64 = 50.0;

/// A Young's modulus below this is almost always a unit slip (steel in MPa is 2e5; the
/// softest rubbers are about 1e6 Pa): a warning, not an error.
pub const LOW_YOUNGS_MODULUS: f64 = 1e6;

/// A Johnson-Cook `t_room` below this, K, is almost always a temperature in degrees Celsius
/// (room temperature 20 C is 293.15 K; liquid nitrogen, 77 K, stays above it): a warning.
pub const LOW_ROOM_TEMPERATURE: f64 = 50.0;

/// A `specific_heat` below this, J/(kg K), is almost always in kJ/(kg K) or J/(g K) (copper
/// 0.385; the lowest of the metals, lead and gold, are about 130 J/(kg K)): a warning.
pub const LOW_SPECIFIC_HEAT: f64 = 50.0;

/// The scene's likely unit slips, one warning line each naming the key (docs/scene.md, "Units"):
/// a solid's density below [`LOW_SOLID_DENSITY`], a Young's modulus below [`LOW_YOUNGS_MODULUS`],
/// a `t_room` below `LOW_ROOM_TEMPERATURE` (50 K), a `specific_heat` below `LOW_SPECIFIC_HEAT` (50 J/(kg K)).
pub fn unit_warnings(scene: &Scene) -> Vec<String> {
    let file = scene.file.display();
    let mut out = Vec::new();
    for (i, m) in scene.materials.iter().enumerate() {
        if m.model != "fluid" && m.density < LOW_SOLID_DENSITY {
            out.push(format!(
                "{file}: material[{i}].density = {:e} kg/m^3 ({:?}) is below {LOW_SOLID_DENSITY} kg/m^3 for a solid: check the units (SI: kg/m^3; 7.85e-9 is steel in t/mm^3)",
                m.density, m.name
            ));
        }
        if let Some(&e) = m.params.get("youngs_modulus") {
            if e < LOW_YOUNGS_MODULUS {
                out.push(format!(
                    "{file}: material[{i}].youngs_modulus = {e:e} Pa ({:?}) is below {LOW_YOUNGS_MODULUS:e} Pa: check the units (SI: Pa; 2e5 is steel in MPa)",
                    m.name
                ));
            }
        }
        if let Some(&t) = m.params.get("t_room") {
            if t < LOW_ROOM_TEMPERATURE {
                out.push(format!(
                    "{file}: material[{i}].t_room = {t:e} K ({:?}) is below {LOW_ROOM_TEMPERATURE} K: check the units (K, not degrees Celsius: 20 C is 293.15 K; t_melt too)",
                    m.name
                ));
            }
        }
        if let Some(&c) = m.params.get("specific_heat") {
            if c < LOW_SPECIFIC_HEAT {
                out.push(format!(
                    "{file}: material[{i}].specific_heat = {c:e} J/(kg K) ({:?}) is below {LOW_SPECIFIC_HEAT} J/(kg K): check the units (SI: J/(kg K); 0.385 is copper in kJ/(kg K))",
                    m.name
                ));
            }
        }
    }
    out
}

/// Particles that will never meet the mesh, one warning line each (docs/scene.md, `[contact]`):
/// a scene with a mesh whose `[[particles]]` are not contact nodes because `[contact]` is missing
/// or leaves `particles` out, or whose failed elements become particles without a `[contact]`
/// table. Either may be meant (bodies that never come near each other); it is far more often a
/// forgotten key, and the particles then pass through the mesh's faces without a word.
pub fn interaction_warnings(scene: &Scene) -> Vec<String> {
    let file = scene.file.display();
    let mut out = Vec::new();
    if scene.meshes.is_empty() {
        return out;
    }
    if !scene.particles.is_empty() {
        let names: Vec<String> = scene
            .particles
            .iter()
            .map(|p| format!("{:?}", p.name))
            .collect();
        let names = names.join(", ");
        match &scene.contact {
            None => out.push(format!(
                "{file}: the particles ({names}) and the mesh do not touch: the scene has no [contact] table; add [contact] with surfaces = [\"exterior\"] and particles = true"
            )),
            Some(c) if c.particles.is_none() && !c.particles_on(scene) => out.push(format!(
                "{file}: contact.particles is not set, so the particles ({names}) are not contact nodes and pass through the mesh's faces; set contact.particles = true (or false to silence this)"
            )),
            _ => {}
        }
    }
    if scene.contact.is_none() {
        for (i, m) in scene.materials.iter().enumerate() {
            if scene.releases(i) {
                out.push(format!(
                    "{file}: material[{i}] ({:?}) fails and its failed elements become particles, but the scene has no [contact] table: those particles will pass through the mesh; add [contact] with surfaces = [\"exterior\"] (or [[block]] failed = \"delete\")",
                    m.name
                ));
            }
        }
    }
    out
}

/// The `[run]` keys of the other integration mode that a scene gives and the run does not use,
/// one warning line each (docs/scene.md, `[run]`): in implicit mode `dt_safety`, `force_dt`
/// and `bulk_viscosity` (explicit only); in explicit mode with a fixed `dt`, `dt_safety`. A key
/// counts as given when it differs from its default.
pub fn mode_warnings(scene: &Scene) -> Vec<String> {
    let file = scene.file.display();
    let r = &scene.run;
    let mut out = Vec::new();
    let safety_given = r.dt_safety != super::d_safety();
    match r.mode {
        Mode::Implicit => {
            if safety_given {
                out.push(format!(
                    "{file}: run.dt_safety is not used in implicit mode (the step is run.dt)"
                ));
            }
            if r.force_dt {
                out.push(format!(
                    "{file}: run.force_dt is not used in implicit mode (any run.dt is stable there)"
                ));
            }
            if r.bulk_viscosity != super::d_bv() {
                out.push(format!(
                    "{file}: run.bulk_viscosity is not used in implicit mode (explicit only)"
                ));
            }
        }
        Mode::Explicit => {
            if safety_given && r.dt.is_some() {
                out.push(format!(
                    "{file}: run.dt_safety is not used: run.dt fixes the step"
                ));
            }
        }
    }
    out
}

/// The `[sph]` corrections a scene gives and the run does not use, one warning line each
/// (docs/scene.md, `[sph]`): `tensile_correction` in a run with solid particles (a solid
/// `[[particles]]` entry, or failed elements that become particles), whose stress pass serves
/// every particle and has `artificial_stress` for the fluids' tension too; `artificial_stress`
/// beside `tensile_correction` in a scene of fluids, where the fluids take the latter.
pub fn sph_warnings(scene: &Scene) -> Vec<String> {
    let file = scene.file.display();
    let Some(s) = &scene.sph else {
        return Vec::new();
    };
    let solids = scene.releases_any()
        || scene
            .particles
            .iter()
            .any(|p| (scene.materials.iter()).any(|m| m.name == p.material && m.eos.is_none()));
    let mut out = Vec::new();
    if solids && s.tensile_correction.is_some() {
        out.push(format!(
            "{file}: sph.tensile_correction is not used: with solid particles every particle takes the stress pass, where artificial_stress acts on the fluids' tension too"
        ));
    } else if s.tensile_correction.is_some() && s.artificial_stress.is_some() {
        out.push(format!(
            "{file}: sph.artificial_stress is not used: a scene of fluid particles takes tensile_correction (give one of the two)"
        ));
    }
    out
}

/// `[[load]]`: a finite pressure and an optional curve (the group is checked against the
/// mesh in `validate_groups`).
fn check_loads(cx: &Ctx, raw: &[RawLoad]) -> Result<Vec<Load>, SceneError> {
    let mut loads = Vec::new();
    for (i, l) in raw.iter().enumerate() {
        if !l.pressure.is_finite() {
            return Err(cx.err(
                &format!("load[{i}].pressure"),
                format!("expected a finite pressure in Pa, got {}", l.pressure),
            ));
        }
        let curve = l
            .curve
            .as_ref()
            .map(|c| crate::input::curve::check(&cx.file, &format!("load[{i}].curve"), c))
            .transpose()?;
        loads.push(Load {
            group: l.group.clone(),
            pressure: l.pressure,
            curve,
        });
    }
    Ok(loads)
}
