//! The checks of the SPH, contact, probe, output and tool tables, and of the mesh's physical
//! groups against the names the scene gives.
use super::*;

/// `[[particles]]`: a known material (a fluid with an eos, or a solid: elastic, j2_plastic,
/// johnson_cook), a positive spacing and h factor, `liggghts_type` only with a data file;
/// solid particles only with the standard profile and continuity density.
pub(super) fn check_particles(
    cx: &Ctx,
    particles: &[ParticlesDef],
    materials: &[MaterialSpec],
    sph: Option<&SphDef>,
    born: bool,
) -> Result<(), SceneError> {
    for (i, p) in particles.iter().enumerate() {
        // (the name heads its columns in contact_forces.csv and its probes)
        if !csv_name(&p.name) {
            return Err(cx.err(
                &format!("particles[{i}].name"),
                format!(
                    "expected a name for contact_forces.csv's columns (not empty, no comma, quote or line break), got {:?}",
                    p.name
                ),
            ));
        }
        if particles[..i].iter().any(|q| q.name == p.name) {
            return Err(cx.err(
                &format!("particles[{i}].name"),
                format!(
                    "\"{}\" names an earlier [[particles]] entry too: give each its own name",
                    p.name
                ),
            ));
        }
        if !materials.iter().any(|m| m.name == p.material) {
            return Err(cx.err(
                &format!("particles[{i}].material"),
                format!(
                    "no material named \"{}\" (materials: {})",
                    p.material,
                    material_names(materials)
                ),
            ));
        }
        if !pos(p.spacing) {
            return Err(cx.err(
                &format!("particles[{i}].spacing"),
                format!("expected a positive spacing in m, got {}", p.spacing),
            ));
        }
        if !pos(p.h_factor) {
            return Err(cx.err(
                &format!("particles[{i}].h_factor"),
                format!("expected a positive factor, got {}", p.h_factor),
            ));
        }
        // (fixed particles never move: a velocity would still count in the kinetic energy and
        // the momentum and enter their neighbours' velocity gradient and viscosity)
        if p.fixed && p.velocity.iter().any(|&v| v != 0.0) {
            return Err(cx.err(
                &format!("particles[{i}].velocity"),
                format!(
                    "{:?} on fixed particles, which never move: remove the key, or set fixed = false",
                    p.velocity
                ),
            ));
        }
        check_region(cx, i, p)?;
        if p.liggghts_type.is_some() && !matches!(p.region, Region::File(_)) {
            return Err(cx.err(
                &format!("particles[{i}].liggghts_type"),
                "only with region = { file = \"<LIGGGHTS data file>\" }".into(),
            ));
        }
    }
    check_solid_particles(cx, particles, materials, sph, born)?;
    // an eos of the specific internal energy with that energy frozen is an isothermal gas:
    // refused where the scene asks for it (omitted, `energy` is on for such particles)
    if let (Some(false), Some((i, name, kind))) = (
        sph.and_then(|s| s.energy),
        particles_needing_energy(particles, materials),
    ) {
        return Err(cx.err(
            "sph.energy",
            format!(
                "false, but particles[{i}] are of material \"{name}\" whose eos \"{kind}\" depends on the specific internal energy: remove the key or set it true (it is on by default for such particles)"
            ),
        ));
    }
    Ok(())
}

/// The models whose particles carry stress (docs/scene.md `[[particles]] material`).
const SOLID_MODELS: [&str; 3] = ["elastic", "j2_plastic", "johnson_cook"];

/// Solid particles (a `[[particles]]` entry whose material has no eos): a model of
/// [`SOLID_MODELS`], `[sph]` with continuity density and the standard profile and without the
/// fluid pass's `conductivity` (its `tensile_correction` is not used there: a warning,
/// `sph_warnings`); `[sph] artificial_stress`: epsilon >= 0, n an integer from 1 to 16, and in
/// a scene of fluids only (no solid particles, `born` false: no failed elements become
/// particles) the standard profile.
fn check_solid_particles(
    cx: &Ctx,
    particles: &[ParticlesDef],
    materials: &[MaterialSpec],
    sph: Option<&SphDef>,
    born: bool,
) -> Result<(), SceneError> {
    let mut solid = None;
    for (i, p) in particles.iter().enumerate() {
        let Some(m) = materials.iter().find(|m| m.name == p.material) else {
            continue; // check_particles names it
        };
        if m.eos.is_some() {
            continue;
        }
        if !SOLID_MODELS.contains(&m.model.as_str()) {
            return Err(cx.err(
                &format!("particles[{i}].material"),
                format!(
                    "material \"{}\" is a {} without an eos: particles need a fluid with an eos or a solid ({})",
                    p.material,
                    m.model,
                    SOLID_MODELS.join(", ")
                ),
            ));
        }
        solid.get_or_insert((i, m.name.clone()));
    }
    let Some(s) = sph else {
        return Ok(());
    };
    if let Some(a) = &s.artificial_stress {
        if solid.is_none() && !born && s.profile == "liggghts" && s.tensile_correction.is_none() {
            return Err(cx.err(
                "sph.artificial_stress",
                "not in the liggghts profile (LIGGGHTS 3.8.0 has no artificial stress): use tensile_correction, or profile = \"standard\"".into(),
            ));
        }
        if !(a.epsilon >= 0.0 && a.epsilon.is_finite()) {
            return Err(cx.err(
                "sph.artificial_stress.epsilon",
                format!(
                    "expected a coefficient >= 0 (Gray et al.: 0.3), got {}",
                    a.epsilon
                ),
            ));
        }
        if !(1..=16).contains(&a.n) {
            return Err(cx.err(
                "sph.artificial_stress.n",
                format!(
                    "expected an integer exponent from 1 to 16 (Gray et al.: 4), got {}",
                    a.n
                ),
            ));
        }
    }
    if let Some((i, name)) = solid {
        // the stress pass serves every particle of a run with solids (a fluid's stress -p I):
        // the fluid pass's own corrections have no place in it
        for (k, set, instead) in [(
            "sph.conductivity",
            s.conductivity.is_some(),
            "artificial conductivity is not in the stress pass",
        )] {
            if set {
                return Err(cx.err(
                    k,
                    format!(
                        "particles[{i}] are of the solid material \"{name}\": remove the key ({instead})"
                    ),
                ));
            }
        }
        for (k, v, want) in [
            ("sph.density", &s.density, "continuity"),
            ("sph.profile", &s.profile, "standard"),
        ] {
            if v != want {
                return Err(cx.err(
                    k,
                    format!(
                        "particles[{i}] are of the solid material \"{name}\", which needs {k} = \"{want}\", got \"{v}\""
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// A lattice region: a box with min < max, a positive radius, a non-zero axis, and no more than
/// [`MAX_PARTICLES`] lattice points to visit at the entry's spacing (counted before anything
/// is allocated).
pub(super) fn check_region(cx: &Ctx, i: usize, p: &ParticlesDef) -> Result<(), SceneError> {
    let key = |k: &str| format!("particles[{i}].region.{k}");
    match &p.region {
        Region::Box { min, max } => {
            if let Some(d) = (0..3).find(|&d| !(min[d] < max[d])) {
                return Err(cx.err(
                    &key("box"),
                    format!(
                        "expected min < max on every axis, got min[{d}] = {} and max[{d}] = {}",
                        num_text(min[d]),
                        num_text(max[d])
                    ),
                ));
            }
        }
        Region::Sphere { radius, .. } if !pos(*radius) => {
            return Err(cx.err(
                &key("sphere.radius"),
                format!("expected a positive radius in m, got {radius}"),
            ));
        }
        Region::Cylinder { radius, .. } if !pos(*radius) => {
            return Err(cx.err(
                &key("cylinder.radius"),
                format!("expected a positive radius in m, got {radius}"),
            ));
        }
        Region::Cylinder { axis, .. } if axis.iter().all(|a| *a == 0.0) => {
            return Err(cx.err(
                &key("cylinder.axis"),
                "expected a non-zero axis (from the base to the top, m)".into(),
            ));
        }
        _ => {}
    }
    let n = crate::input::particles::lattice_points_bound(&p.region, p.spacing);
    if !(n <= MAX_PARTICLES) {
        return Err(cx.err(
            &format!("particles[{i}].spacing"),
            format!(
                "the region at a spacing of {:e} m is a lattice of {n:.3e} points, more than the {MAX_PARTICLES:e} particles a run may hold: use a larger spacing or a smaller region",
                p.spacing
            ),
        ));
    }
    Ok(())
}

/// `[sph]`: positive optional coefficients, coefficients >= 0, and known names.
pub(super) fn check_sph(cx: &Ctx, s: &SphDef) -> Result<(), SceneError> {
    let av = s.artificial_viscosity.as_ref();
    for (k, v) in [
        ("sph.artificial_viscosity.alpha", av.map(|a| a.alpha)),
        ("sph.artificial_viscosity.beta", av.map(|a| a.beta)),
        (
            "sph.tensile_correction.epsilon",
            s.tensile_correction.as_ref().map(|t| t.epsilon),
        ),
    ] {
        if let Some(v) = v.filter(|v| !(*v >= 0.0 && v.is_finite())) {
            return Err(cx.err(k, format!("expected a coefficient >= 0, got {v}")));
        }
    }
    for (k, v) in [
        ("sph.adaptive_h", s.adaptive_h),
        ("sph.conductivity", s.conductivity),
    ] {
        if let Some(v) = v {
            if !(v > 0.0 && v.is_finite()) {
                return Err(cx.err(k, format!("expected a positive number, got {v}")));
            }
        }
    }
    for (k, v, ok) in [
        ("sph.kernel", &s.kernel, &["cubic_spline", "wendland"][..]),
        ("sph.density", &s.density, &["continuity", "summation"][..]),
        ("sph.profile", &s.profile, &["standard", "liggghts"][..]),
    ] {
        if !ok.contains(&v.as_str()) {
            return Err(cx.err(
                k,
                format!("unknown value \"{v}\" (expected one of {})", ok.join(", ")),
            ));
        }
    }
    Ok(())
}

/// `[contact]`: one pass with master bodies or two without, a Coulomb coefficient >= 0.
pub(super) fn check_contact(cx: &Ctx, c: &ContactDef) -> Result<(), SceneError> {
    match c.passes {
        1 if c.master.is_empty() => {
            return Err(cx.err(
                "contact.master",
                "passes = 1 needs the master bodies: master = [\"<physical volume>\", ...] \
                 (the other bodies' nodes are searched against their faces)"
                    .into(),
            ))
        }
        2 if !c.master.is_empty() => {
            return Err(cx.err(
                "contact.master",
                "a master is only read with passes = 1 (two passes search every pair of \
                 bodies both ways)"
                    .into(),
            ))
        }
        1 | 2 => {}
        n => {
            return Err(cx.err(
                "contact.passes",
                format!(
                    "expected 1 (one pass, master/slave) or 2 (both ways, the default), got {n}"
                ),
            ))
        }
    }
    if !(c.friction >= 0.0 && c.friction.is_finite()) {
        return Err(cx.err(
            "contact.friction",
            format!("expected Coulomb's coefficient >= 0, got {}", c.friction),
        ));
    }
    Ok(())
}

/// The most `[[rigid_wall]]` entries a scene may have.
pub const MAX_RIGID_WALLS: usize = 200;

/// `[[rigid_wall]]`: at most [`MAX_RIGID_WALLS`]; a name that no other wall and no boundary group has (they share
/// reactions.csv's columns), a normal that is not zero (returned normalised), Coulomb's
/// coefficient >= 0.
pub(super) fn check_rigid_walls(
    cx: &Ctx,
    walls: &[RigidWallDef],
    boundaries: &[Boundary],
) -> Result<Vec<RigidWallDef>, SceneError> {
    let mut out: Vec<RigidWallDef> = Vec::new();
    // (a particle holds its holder's index in a byte: `SphStage::apply_contact`)
    if walls.len() > MAX_RIGID_WALLS {
        return Err(cx.err(
            "rigid_wall",
            format!(
                "{} rigid walls, at most {MAX_RIGID_WALLS}: an infinite plane each",
                walls.len()
            ),
        ));
    }
    for (i, w) in walls.iter().enumerate() {
        let key = |k: &str| format!("rigid_wall[{i}].{k}");
        if w.name.trim().is_empty() || w.name.contains(',') {
            return Err(cx.err(
                &key("name"),
                format!(
                    "expected a name for reactions.csv's columns (not empty, no comma), got \"{}\"",
                    w.name
                ),
            ));
        }
        if out.iter().any(|o| o.name == w.name) {
            return Err(cx.err(
                &key("name"),
                format!("\"{}\" names another rigid wall already", w.name),
            ));
        }
        if boundaries.iter().any(|b| b.group == w.name) {
            return Err(cx.err(
                &key("name"),
                format!(
                    "\"{}\" is a [[boundary]] group's name, which reactions.csv uses too: name the wall otherwise",
                    w.name
                ),
            ));
        }
        let n = w.normal;
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if !(len > 0.0 && len.is_finite()) {
            return Err(cx.err(
                &key("normal"),
                format!(
                    "expected a direction (the side the bodies are on), got {n:?} of length zero (or beyond a double's range)"
                ),
            ));
        }
        if !(w.friction >= 0.0 && w.friction.is_finite()) {
            return Err(cx.err(
                &key("friction"),
                format!("expected Coulomb's coefficient >= 0, got {}", w.friction),
            ));
        }
        if let Some(raw) = &w.curve {
            if w.velocity.is_none() {
                return Err(cx.err(
                    &key("curve"),
                    "a curve scales the wall's velocity: give `velocity` (m/s) too".into(),
                ));
            }
            crate::input::curve::check(&cx.file, &key("curve"), raw)?;
        }
        out.push(RigidWallDef {
            normal: n.map(|c| c / len),
            ..w.clone()
        });
    }
    Ok(out)
}

/// `[[probe]]`: unique names, at least one field each.
pub(super) fn check_probes(cx: &Ctx, probes: &[Probe]) -> Result<(), SceneError> {
    let mut names: Vec<&str> = Vec::new();
    for (i, p) in probes.iter().enumerate() {
        if names.contains(&p.name.as_str()) {
            return Err(cx.err(
                &format!("probe[{i}].name"),
                format!("probe \"{}\" is defined twice", p.name),
            ));
        }
        names.push(&p.name);
        if !csv_name(&p.name) {
            return Err(cx.err(
                &format!("probe[{i}].name"),
                format!(
                    "expected a name for probes.csv's columns (not empty, no comma, quote or line break), got {:?}",
                    p.name
                ),
            ));
        }
        if p.fields.is_empty() {
            return Err(cx.err(
                &format!("probe[{i}].fields"),
                "expected at least one field".into(),
            ));
        }
        for (k, f) in p.fields.iter().enumerate() {
            if p.fields[..k].contains(f) {
                return Err(cx.err(
                    &format!("probe[{i}].fields[{k}]"),
                    format!(
                        "\"{}\" is listed twice (probes.csv would have two columns \"{}.{}\")",
                        f.name(),
                        p.name,
                        f.name()
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// A name that can head CSV columns as it is: not empty, no comma, quote or line break.
pub(super) fn csv_name(name: &str) -> bool {
    !name.trim().is_empty() && !name.contains([',', '"', '\n', '\r'])
}

/// `[output]`: a positive checkpoint interval, known field names.
pub(super) fn check_output(cx: &Ctx, output: &OutputDef) -> Result<(), SceneError> {
    if let Some(c) = output.checkpoint_every {
        if !(c > 0.0 && c.is_finite()) {
            return Err(cx.err(
                "output.checkpoint_every",
                format!("expected a positive interval in seconds, got {c}"),
            ));
        }
    }
    for (i, f) in output.fields.iter().enumerate() {
        if !OUTPUT_FIELDS.contains(&f.as_str()) {
            return Err(cx.err(
                &format!("output.fields[{i}]"),
                format!(
                    "unknown field \"{f}\" (expected one of {})",
                    OUTPUT_FIELDS.join(", ")
                ),
            ));
        }
    }
    Ok(())
}

/// `[compare]`: a known measure, a quantity that is a probe column, a positive period.
pub(super) fn check_compare(cx: &Ctx, c: &CompareDef, probes: &[Probe]) -> Result<(), SceneError> {
    if !COMPARE_MEASURES.contains(&c.measure.as_str()) {
        return Err(cx.err(
            "compare.measure",
            format!(
                "unknown value \"{}\" (expected one of {})",
                c.measure,
                COMPARE_MEASURES.join(", ")
            ),
        ));
    }
    if let Some(q) = &c.quantity {
        let known = probes.iter().flat_map(Probe::columns).any(|col| &col == q);
        if !known {
            return Err(cx.err(
                "compare.quantity",
                format!("\"{q}\" is not a probe column (expected probe.field of a [[probe]])"),
            ));
        }
    }
    if let Some(t) = c.reference_period {
        if !pos(t) {
            return Err(cx.err(
                "compare.reference_period",
                format!("expected a positive period in seconds, got {t}"),
            ));
        }
    }
    Ok(())
}

/// A material's number: an integer or a finite float; anything else named by its type.
pub(super) fn number(v: &toml::Value) -> Result<f64, String> {
    match v {
        toml::Value::Float(f) if f.is_finite() => Ok(*f),
        toml::Value::Float(f) => Err(format!("expected a finite number, got {f}")),
        toml::Value::Integer(i) => Ok(*i as f64),
        toml::Value::String(s) => Err(format!(
            "expected a number, got a string (\"{s}\": write it without quotes)"
        )),
        other => Err(format!("expected a number, got {}", other.type_str())),
    }
}

/// Checks that every group the scene names holds elements of its dimension (after
/// [`validate_groups`]: the names exist): `has_volume(name)` says whether the physical volume
/// holds volume elements, `has_surface(name)` whether the physical surface holds faces.
pub fn validate_groups_hold_elements(
    scene: &Scene,
    has_volume: impl Fn(&str) -> bool,
    has_surface: impl Fn(&str) -> bool,
) -> Result<(), SceneError> {
    let file = scene.file.display().to_string();
    let empty = |key: String, what: &str, name: &str| {
        SceneError {
        file: file.clone(),
        key,
        message: format!(
            "the physical {what} \"{name}\" holds no elements in the mesh (a physical group of no meshed entity, or of the wrong entity numbers in the .geo): it would act on nothing"
        ),
    }
    };
    for (i, b) in scene.blocks.iter().enumerate() {
        if !has_volume(&b.group) {
            return Err(empty(format!("block[{i}].group"), "volume", &b.group));
        }
    }
    for (i, b) in scene.boundaries.iter().enumerate() {
        if !has_surface(&b.group) {
            return Err(empty(format!("boundary[{i}].group"), "surface", &b.group));
        }
    }
    for (i, l) in scene.loads.iter().enumerate() {
        if !has_surface(&l.group) {
            return Err(empty(format!("load[{i}].group"), "surface", &l.group));
        }
    }
    if let Some(c) = &scene.contact {
        for (i, s) in c.surfaces.iter().enumerate() {
            if s != "exterior" && !has_surface(s) {
                return Err(empty(format!("contact.surfaces[{i}]"), "surface", s));
            }
        }
        for (i, m) in c.master.iter().enumerate() {
            if !has_volume(m) {
                return Err(empty(format!("contact.master[{i}]"), "volume", m));
            }
        }
    }
    Ok(())
}

/// Checks that every group the scene names exists in the mesh.
pub fn validate_groups(
    scene: &Scene,
    volumes: &[String],
    surfaces: &[String],
) -> Result<(), SceneError> {
    let file = scene.file.display().to_string();
    let list = |v: &[String]| {
        if v.is_empty() {
            "none".to_string()
        } else {
            v.join(", ")
        }
    };
    for (i, b) in scene.blocks.iter().enumerate() {
        if !volumes.contains(&b.group) {
            return Err(SceneError {
                file,
                key: format!("block[{i}].group"),
                message: format!(
                    "no physical volume \"{}\" in the mesh (physical volumes: {})",
                    b.group,
                    list(volumes)
                ),
            });
        }
    }
    for (i, b) in scene.boundaries.iter().enumerate() {
        if !surfaces.contains(&b.group) {
            return Err(SceneError {
                file,
                key: format!("boundary[{i}].group"),
                message: format!(
                    "no physical surface \"{}\" in the mesh (physical surfaces: {})",
                    b.group,
                    list(surfaces)
                ),
            });
        }
    }
    for (i, l) in scene.loads.iter().enumerate() {
        if !surfaces.contains(&l.group) {
            let what = if volumes.contains(&l.group) {
                format!(
                    "\"{}\" is a physical volume; a [[load]] acts on a physical surface",
                    l.group
                )
            } else {
                format!("no physical surface \"{}\" in the mesh", l.group)
            };
            return Err(SceneError {
                file,
                key: format!("load[{i}].group"),
                message: format!("{what} (physical surfaces: {})", list(surfaces)),
            });
        }
    }
    if let Some(c) = &scene.contact {
        for (i, s) in c.surfaces.iter().enumerate() {
            if s != "exterior" && !surfaces.contains(s) {
                return Err(SceneError {
                    file,
                    key: format!("contact.surfaces[{i}]"),
                    message: format!("no physical surface \"{s}\" in the mesh (physical surfaces: {}; or \"exterior\")", list(surfaces)),
                });
            }
        }
        for (i, m) in c.master.iter().enumerate() {
            if !volumes.contains(m) {
                return Err(SceneError {
                    file,
                    key: format!("contact.master[{i}]"),
                    message: format!(
                        "no physical volume \"{m}\" in the mesh (physical volumes: {})",
                        list(volumes)
                    ),
                });
            }
        }
    }
    Ok(())
}
