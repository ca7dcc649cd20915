//! Meshing `.geo` files with the `gmsh` command (cached by content and parameters) and reading
//! the physical group names of a `.msh` file.
use crate::input::scene::MeshDef;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Meshing or mesh-file errors.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The file does not exist or cannot be read.
    #[error("{path}: {why}")]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        why: String,
    },
    /// A parameter the .geo cannot take.
    #[error("params.{name}: {why}")]
    Param {
        /// The parameter.
        name: String,
        /// What was expected.
        why: String,
    },
    /// gmsh is missing or failed.
    #[error("gmsh failed on {path}: {why}")]
    Gmsh {
        /// The .geo file.
        path: PathBuf,
        /// gmsh's message (tail of its output).
        why: String,
    },
}

/// A gmsh physical group.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PhysicalName {
    /// Dimension (2 surface, 3 volume).
    pub dim: i32,
    /// Numeric tag.
    pub tag: i32,
    /// Name.
    pub name: String,
}

/// Where meshes of `.geo` files in `dir` are cached.
pub fn default_cache_dir(dir: &Path) -> PathBuf {
    dir.join(".cache")
}

fn gmsh_version() -> Result<String, String> {
    let out = Command::new("gmsh")
        .arg("--version")
        .output()
        .map_err(|e| {
            format!("cannot run gmsh ({e}): install it (apt-get install gmsh; `make setup` does)")
        })?;
    let mut v = String::from_utf8_lossy(&out.stdout).trim().to_string();
    v.push_str(String::from_utf8_lossy(&out.stderr).trim());
    Ok(v)
}

/// Returns a `.msh` for the mesh: a `.msh` as given, a `.geo` meshed by gmsh into `cache_dir`
/// (msh 2.2, 3D) unless a mesh with the same .geo content, parameters and gmsh version exists.
pub fn mesh_file(def: &MeshDef, cache_dir: &Path) -> Result<PathBuf, MeshError> {
    let path = &def.file;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    if !path.exists() {
        return Err(MeshError::File {
            path: path.clone(),
            why: "no such file".into(),
        });
    }
    match ext {
        "msh" => return Ok(path.clone()),
        "geo" => {}
        _ => {
            return Err(MeshError::File {
                path: path.clone(),
                why: "expected a .geo or .msh file".into(),
            })
        }
    }
    let text = std::fs::read(path).map_err(|e| MeshError::File {
        path: path.clone(),
        why: e.to_string(),
    })?;
    check_params(def).map_err(|(name, why)| MeshError::Param { name, why })?;
    let version = gmsh_version().map_err(|why| MeshError::Gmsh {
        path: path.clone(),
        why,
    })?;
    let mut h = Sha256::new();
    h.update(&text);
    for (k, v) in &def.params {
        h.update(format!("\n{k}={v:e}").as_bytes());
    }
    h.update(version.as_bytes());
    let hash = short_hash(h);
    let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("mesh");
    let out = cache_dir.join(format!("{stem}-{hash}.msh"));
    if out.exists() {
        return Ok(out);
    }
    std::fs::create_dir_all(cache_dir).map_err(|e| MeshError::File {
        path: cache_dir.to_path_buf(),
        why: e.to_string(),
    })?;
    check_global_size(def, cache_dir)?;
    let tmp = cache_dir.join(format!("{stem}-{hash}.{}.tmp.msh", std::process::id()));
    let mut cmd = Command::new("gmsh");
    cmd.arg(path).arg("-3").arg("-format").arg("msh22");
    for (k, v) in &def.params {
        cmd.arg("-setnumber").arg(k).arg(format!("{v}"));
    }
    cmd.arg("-o").arg(&tmp);
    let res = cmd.output().map_err(|e| MeshError::Gmsh {
        path: path.clone(),
        why: format!("cannot run gmsh: {e}"),
    })?;
    let log = format!(
        "{}{}",
        String::from_utf8_lossy(&res.stdout),
        String::from_utf8_lossy(&res.stderr)
    );
    let has_error = log.lines().any(|l| l.contains("Error"));
    if !res.status.success() || has_error || !tmp.exists() {
        let _ = std::fs::remove_file(&tmp);
        return Err(MeshError::Gmsh {
            path: path.clone(),
            why: failure_summary(&log, &res.status),
        });
    }
    std::fs::rename(&tmp, &out).map_err(|e| MeshError::File {
        path: out.clone(),
        why: e.to_string(),
    })?;
    Ok(out)
}

/// Most elements a global mesh size may ask for along the model's largest extent (as
/// [`MAX_COUNT`] along a curve for `Transfinite` counts).
pub const MAX_ALONG_EXTENT: f64 = MAX_COUNT;

/// Refuses a `.geo` whose global mesh size (`Mesh.MeshSizeMax` times `Mesh.MeshSizeFactor`,
/// as the file and `params` set them) is more than [`MAX_ALONG_EXTENT`] times smaller than the
/// model's largest extent: gmsh would mesh the curves alone for hours (a size of 1e-9 m on a
/// 0.2 m bar, a unit slip, is 2e8 points on each long edge), a hang rather than an error.
/// gmsh reads the file without meshing it (`-parse_and_exit`) and prints the bounding box and
/// the options; a file it cannot read so is left to the meshing run, which reports it. Sizes
/// set per point (`MeshSize{...} = h`, `Characteristic Length{...} = h`) are checked the same
/// way: gmsh evaluates each statement's expression after reading the file (a value it cannot
/// evaluate there, such as a loop's variable, is not checked).
fn check_global_size(def: &MeshDef, cache_dir: &Path) -> Result<(), MeshError> {
    let Ok(geo) = std::fs::canonicalize(&def.file) else {
        return Ok(());
    };
    let probe = cache_dir.join(format!("size-probe.{}.geo", std::process::id()));
    let exprs = std::fs::read_to_string(&def.file)
        .map(|t| point_size_expressions(&t))
        .unwrap_or_default();
    let mut text = format!(
        "Include \"{}\";\nSyncModel;\nPrintf(\"TDYN_SIZE %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\", General.MinX, General.MinY, General.MinZ, General.MaxX, General.MaxY, General.MaxZ, Mesh.MeshSizeMax, Mesh.MeshSizeFactor, Mesh.MeshSizeMin);\n",
        geo.display()
    );
    for (k, e) in exprs.iter().enumerate() {
        text.push_str(&format!("Printf(\"TDYN_PSIZE {k} %.17g\", {e});\n"));
    }
    if std::fs::write(&probe, text).is_err() {
        return Ok(());
    }
    let mut cmd = Command::new("gmsh");
    cmd.arg(&probe).arg("-parse_and_exit");
    for (k, v) in &def.params {
        cmd.arg("-setnumber").arg(k).arg(format!("{v}"));
    }
    let out = cmd.output();
    let _ = std::fs::remove_file(&probe);
    let Ok(out) = out else {
        return Ok(());
    };
    let log =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    let Some(v) = log.lines().find_map(|l| {
        let rest = l.split("TDYN_SIZE ").nth(1)?;
        let v: Vec<f64> = rest
            .split_whitespace()
            .filter_map(|x| x.parse().ok())
            .collect();
        (v.len() == 9).then_some(v)
    }) else {
        return Ok(());
    };
    let extent = (0..3).map(|c| v[c + 3] - v[c]).fold(0.0f64, f64::max);
    let (factor, floor) = (v[7], v[8].max(0.0));
    // The global size, then each point size (floored by Mesh.MeshSizeMin), with what set it.
    let mut sizes = vec![(v[6] * factor, "the mesh size Mesh.MeshSizeMax".to_string())];
    for l in log.lines() {
        let Some(rest) = l.split("TDYN_PSIZE ").nth(1) else {
            continue;
        };
        let mut it = rest.split_whitespace();
        let (Some(Ok(k)), Some(Ok(h))) = (
            it.next().map(str::parse::<usize>),
            it.next().map(str::parse::<f64>),
        ) else {
            continue;
        };
        if let Some(e) = exprs.get(k) {
            sizes.push((
                h.max(floor) * factor,
                format!("the point size MeshSize{{...}} = {e}"),
            ));
        }
    }
    let worst = sizes
        .into_iter()
        .filter(|(h, _)| *h > 0.0 && h.is_finite())
        .min_by(|a, b| a.0.total_cmp(&b.0));
    let Some((size, what)) = worst else {
        return Ok(());
    };
    if extent.is_finite() && extent / size > MAX_ALONG_EXTENT {
        let params: Vec<String> = def
            .params
            .iter()
            .map(|(k, x)| format!("{k} = {}", crate::input::scene::num_text(*x)))
            .collect();
        return Err(MeshError::File {
            path: def.file.clone(),
            why: format!(
                "{what} = {} m is {:.1e} times smaller than the model's extent {extent:.3e} m, more than {MAX_ALONG_EXTENT:e} elements along it: gmsh would not finish; check the units of the size (m){}",
                crate::input::scene::num_text(size),
                extent / size,
                if params.is_empty() {
                    String::new()
                } else {
                    format!(" and the params ({})", params.join(", "))
                }
            ),
        });
    }
    Ok(())
}

/// The expressions of a .geo's point size statements, `MeshSize{...} = EXPR;` and
/// `Characteristic Length{...} = EXPR;` (comments left out).
fn point_size_expressions(geo: &str) -> Vec<String> {
    let code = strip_comments(geo);
    let mut out = Vec::new();
    for key in ["MeshSize", "Characteristic Length"] {
        let mut rest = code.as_str();
        while let Some(at) = rest.find(key) {
            rest = &rest[at + key.len()..];
            let after = rest.trim_start();
            let Some(inner) = braced(after) else {
                continue;
            };
            let tail = after[inner.len() + 2..].trim_start();
            let Some(expr) = tail.strip_prefix('=') else {
                continue;
            };
            if let Some(end) = expr.find(';') {
                let e = expr[..end].trim();
                if !e.is_empty() && !e.contains('"') {
                    out.push(e.to_string());
                }
            }
        }
    }
    out
}

/// Distinct gmsh error lines a failure message quotes at most.
const FAILURE_LINES: usize = 3;

/// What gmsh's log says about a failure, for one line: its distinct `Error` lines (the first
/// `FAILURE_LINES`, with the count of the others: a mesh size of 0 repeats one error for
/// every curve, thousands of times), without gmsh's closing summary box; or, with no error
/// line (gmsh killed, out of memory, crashed), how it ended and its last lines.
pub fn failure_summary(log: &str, status: &std::process::ExitStatus) -> String {
    let mut distinct: Vec<&str> = Vec::new();
    let mut total = 0usize;
    for l in log.lines().filter(|l| l.contains("Error")) {
        let text = l
            .trim_start_matches("Error")
            .trim_start_matches([' ', ':'])
            .trim();
        let summary_box = text.is_empty()
            || text.starts_with("---")
            || text == "Mesh generation error summary"
            || text == "Check the full log for details"
            || text.ends_with(" warnings")
            || text.ends_with(" errors");
        if summary_box {
            continue;
        }
        total += 1;
        if !distinct.contains(&l.trim()) {
            distinct.push(l.trim());
        }
    }
    if total > 0 {
        let shown: Vec<&str> = distinct.iter().take(FAILURE_LINES).copied().collect();
        let more = total - shown.len();
        let mut why = shown.join(" | ");
        if more > 0 {
            why.push_str(&format!(" (and {more} more error lines)"));
        }
        return why;
    }
    let how = match status.code() {
        Some(0) => "gmsh wrote no mesh".to_string(),
        Some(c) => format!("gmsh exited with status {c}"),
        None => "gmsh was killed by a signal (out of memory? a mesh size far too small for the geometry)".to_string(),
    };
    let tail: Vec<&str> = log
        .lines()
        .rev()
        .take(2)
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
        .map(str::trim)
        .collect();
    if tail.is_empty() {
        how
    } else {
        format!("{how}; its log ends: {}", tail.join(" | "))
    }
}

/// Most elements one `Transfinite` or `Layers` count may ask for along a curve.
pub const MAX_COUNT: f64 = 1e6;

/// The gmsh parameters of `def` are finite, and those its .geo uses as element counts
/// ([`count_parameters`]) are whole numbers from 1 to [`MAX_COUNT`] (gmsh would round 10.5 down
/// and turn 0, -5 or 1e12 into a mesh of one element without a word). A .msh takes no
/// parameters: one given to it is refused (it would change nothing, without a word). Returns
/// the parameter and what was expected.
pub fn check_params(def: &MeshDef) -> Result<(), (String, String)> {
    for (name, v) in &def.params {
        if !v.is_finite() {
            return Err((name.clone(), format!("expected a finite number, got {v}")));
        }
    }
    if def.params.is_empty() {
        return Ok(());
    }
    if def.file.extension().is_none_or(|e| e != "geo") {
        let name = def.params.keys().next().cloned().unwrap_or_default();
        return Err((
            name,
            format!(
                "{} is read as it is: params are passed to gmsh to mesh a .geo file, and a .msh file is already meshed (remove params, or name the .geo file)",
                def.file.file_name().unwrap_or_default().to_string_lossy()
            ),
        ));
    }
    let Ok(text) = std::fs::read_to_string(&def.file) else {
        return Ok(()); // reported where the file is read
    };
    let code = strip_comments(&text);
    // A parameter the .geo never names is a typo (`Nz` for `NZ`): gmsh would ignore it and
    // mesh with the file's default, without a word. (A .geo that includes others may name it
    // there: not checked.)
    if !code.contains("Include") {
        let used = identifiers(&code);
        for name in def.params.keys() {
            if !used.contains(name) {
                let known: Vec<String> = overridable(&code).into_iter().collect();
                return Err((
                    name.clone(),
                    format!(
                        "{} never uses {name}{}",
                        def.file.file_name().unwrap_or_default().to_string_lossy(),
                        if known.is_empty() {
                            String::new()
                        } else {
                            format!(" (it takes {})", known.join(", "))
                        }
                    ),
                ));
            }
        }
    }
    let counts = count_parameters(&text);
    for (name, v) in &def.params {
        if counts.contains(name) && !(*v >= 1.0 && v.fract() == 0.0 && *v <= MAX_COUNT) {
            return Err((
                name.clone(),
                format!(
                    "expected a whole number of elements from 1 to {MAX_COUNT:e} ({} uses {name} in an element count: Transfinite or Layers), got {}",
                    def.file.file_name().unwrap_or_default().to_string_lossy(),
                    crate::input::scene::num_text(*v)
                ),
            ));
        }
    }
    Ok(())
}

/// The identifiers a .geo uses as element counts: those at the top level of the expression of
/// `Transfinite Curve|Line {...} = EXPR` (before any `Using`) and of `Layers{EXPR}`, that is,
/// outside any function call (`Round(L / H)` makes no count of `H`) and not after a `/`; then,
/// through assignments `X = EXPR;` to a count `X`, the identifiers of `EXPR` the same way.
pub fn count_parameters(geo: &str) -> std::collections::BTreeSet<String> {
    let code = strip_comments(geo);
    let mut counts = std::collections::BTreeSet::new();
    let mut assignments: Vec<(String, String)> = Vec::new();
    for stmt in code.split(';') {
        if let Some(expr) = transfinite_count(stmt) {
            counts.extend(top_level_identifiers(expr));
        }
        let mut rest = stmt;
        while let Some(at) = rest.find("Layers") {
            rest = &rest[at + "Layers".len()..];
            if let Some(inner) = braced(rest) {
                // Layers{ {n1, n2}, {h1, h2} }: the first group holds the counts.
                let counts_part = braced(inner.trim_start()).unwrap_or(inner);
                counts.extend(top_level_identifiers(counts_part));
            }
        }
        let last = stmt.lines().last().unwrap_or("").trim();
        if let Some((lhs, rhs)) = last.split_once('=') {
            let lhs = lhs.trim();
            let is_ident = lhs
                .chars()
                .next()
                .is_some_and(|c| c.is_alphabetic() || c == '_')
                && lhs.chars().all(|c| c.is_alphanumeric() || c == '_');
            if is_ident && !rhs.starts_with('=') {
                assignments.push((lhs.to_string(), rhs.to_string()));
            }
        }
    }
    loop {
        let before = counts.len();
        for (lhs, rhs) in &assignments {
            if counts.contains(lhs) {
                counts.extend(top_level_identifiers(rhs));
            }
        }
        if counts.len() == before {
            return counts;
        }
    }
}

/// The identifiers of .geo code (without comments), outside string literals.
fn identifiers(code: &str) -> std::collections::BTreeSet<String> {
    let mut out = std::collections::BTreeSet::new();
    let mut in_string = false;
    let mut word = String::new();
    for c in code.chars().chain(std::iter::once(' ')) {
        if in_string {
            in_string = c != '"';
        } else if c.is_alphanumeric() || c == '_' {
            word.push(c);
        } else {
            if word
                .chars()
                .next()
                .is_some_and(|f| f.is_alphabetic() || f == '_')
            {
                out.insert(std::mem::take(&mut word));
            }
            word.clear();
            in_string = c == '"';
        }
    }
    out
}

/// The parameters a .geo offers for overriding: the names it tests with `Exists(NAME)` or
/// declares with `DefineConstant[NAME = ...]`.
fn overridable(code: &str) -> std::collections::BTreeSet<String> {
    let mut out = std::collections::BTreeSet::new();
    let mut rest = code;
    while let Some(at) = rest.find("Exists(") {
        rest = &rest[at + "Exists(".len()..];
        let name: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if !name.is_empty() {
            out.insert(name);
        }
    }
    let mut rest = code;
    while let Some(at) = rest.find("DefineConstant") {
        rest = &rest[at + "DefineConstant".len()..];
        let Some(open) = rest.find('[') else { break };
        let close = rest[open..].find(']').map_or(rest.len(), |c| open + c);
        for entry in rest[open + 1..close].split(',') {
            let name = entry.split('=').next().unwrap_or("").trim();
            if !name.is_empty() && name.chars().all(|c| c.is_alphanumeric() || c == '_') {
                out.insert(name.to_string());
            }
        }
        rest = &rest[close..];
    }
    out
}

/// The .geo without `//` and `/* */` comments.
fn strip_comments(geo: &str) -> String {
    let mut out = String::with_capacity(geo.len());
    let mut rest = geo;
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix("//") {
            rest = r.find('\n').map_or("", |i| &r[i..]);
        } else if let Some(r) = rest.strip_prefix("/*") {
            rest = r.find("*/").map_or("", |i| &r[i + 2..]);
        } else {
            let c = rest.chars().next().unwrap();
            out.push(c);
            rest = &rest[c.len_utf8()..];
        }
    }
    out
}

/// The count expression of a `Transfinite Curve|Line {...} = EXPR [Using ...]` statement.
fn transfinite_count(stmt: &str) -> Option<&str> {
    let at = stmt.find("Transfinite")?;
    let rest = stmt[at + "Transfinite".len()..].trim_start();
    let rest = rest
        .strip_prefix("Curve")
        .or_else(|| rest.strip_prefix("Line"))?;
    let inner = braced(rest.trim_start())?;
    let after = &rest.trim_start()[inner.len() + 2..];
    let expr = after.trim_start().strip_prefix('=')?;
    Some(expr.split("Using").next().unwrap_or(expr))
}

/// The text inside the braces that `s` starts with (matching nested braces).
fn braced(s: &str) -> Option<&str> {
    let s = s.strip_prefix('{')?;
    let mut depth = 1;
    for (i, c) in s.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    return Some(&s[..i]);
                }
            }
            _ => {}
        }
    }
    None
}

/// Identifiers of `expr` outside any function call or array index and not right after a `/`.
fn top_level_identifiers(expr: &str) -> Vec<String> {
    let chars: Vec<char> = expr.chars().collect();
    let mut out = Vec::new();
    // Open brackets: true for a call or an index (whose insides are not counts).
    let mut open: Vec<bool> = Vec::new();
    let mut after_slash = false;
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c.is_ascii_digit() || (c == '.' && chars.get(i + 1).is_some_and(|d| d.is_ascii_digit()))
        {
            // A number, with its exponent.
            while i < chars.len()
                && (chars[i].is_ascii_alphanumeric()
                    || chars[i] == '.'
                    || ((chars[i] == '+' || chars[i] == '-') && matches!(chars[i - 1], 'e' | 'E')))
            {
                i += 1;
            }
            after_slash = false;
            continue;
        }
        if c.is_alphabetic() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            let word: String = chars[start..i].iter().collect();
            let next = chars[i..].iter().find(|c| !c.is_whitespace());
            let applied = matches!(next, Some('(') | Some('['));
            if applied {
                // Skip to the bracket and mark it a call.
                while chars[i] != '(' && chars[i] != '[' {
                    i += 1;
                }
                open.push(true);
                i += 1;
            } else if !open.iter().any(|&call| call) && !after_slash {
                out.push(word);
            }
            after_slash = false;
            continue;
        }
        match c {
            // A group after `/` is a divisor: its insides are not counts either.
            '(' | '[' | '{' => open.push(after_slash),
            ')' | ']' | '}' => {
                open.pop();
            }
            _ => {}
        }
        if !c.is_whitespace() {
            after_slash = c == '/';
        }
        i += 1;
    }
    out
}

/// Reads the `$PhysicalNames` section of an ASCII msh 2.2 or 4.1 file.
pub fn physical_names(msh: &Path) -> Result<Vec<PhysicalName>, MeshError> {
    let text = std::fs::read_to_string(msh).map_err(|e| MeshError::File {
        path: msh.to_path_buf(),
        why: format!("cannot read ({e}); binary .msh files need $PhysicalNames in ASCII: save as ASCII msh 2.2 or 4.1"),
    })?;
    if !text.starts_with("$MeshFormat") {
        return Err(MeshError::File {
            path: msh.to_path_buf(),
            why:
                "not a gmsh mesh file (no $MeshFormat header); expected an ASCII .msh (2.2 or 4.1)"
                    .into(),
        });
    }
    let mut out = Vec::new();
    let mut lines = text.lines();
    while let Some(l) = lines.next() {
        if l.trim() == "$PhysicalNames" {
            let n: usize = lines
                .next()
                .and_then(|s| s.trim().parse().ok())
                .unwrap_or(0);
            for _ in 0..n {
                let Some(row) = lines.next() else { break };
                let mut it = row.splitn(3, char::is_whitespace);
                let dim = it.next().and_then(|s| s.parse().ok());
                let tag = it.next().and_then(|s| s.parse().ok());
                let name = it.next().map(|s| s.trim().trim_matches('"').to_string());
                if let (Some(dim), Some(tag), Some(name)) = (dim, tag, name) {
                    out.push(PhysicalName { dim, tag, name });
                } else {
                    return Err(MeshError::File {
                        path: msh.to_path_buf(),
                        why: format!("bad $PhysicalNames row: {row}"),
                    });
                }
            }
            break;
        }
    }
    Ok(out)
}

/// A msh 2.2 ASCII file in memory: what merging and splitting need (`split.rs`).
pub(crate) struct Msh22 {
    pub(crate) names: Vec<PhysicalName>,
    /// (gmsh node id, coordinates)
    pub(crate) nodes: Vec<(u64, [f64; 3])>,
    /// (type, physical tag, elementary tag, node ids)
    pub(crate) elements: Vec<(i32, i32, i32, Vec<u64>)>,
}

/// The msh 2.2 ASCII text of `m`: elements numbered from 1 in order, each with its physical
/// and elementary tag; coordinates written in Rust's shortest round-trip form (read back to
/// the same bits).
pub(crate) fn msh22_text(m: &Msh22) -> String {
    let mut text = String::from("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n");
    text.push_str(&format!("$PhysicalNames\n{}\n", m.names.len()));
    for g in &m.names {
        text.push_str(&format!("{} {} \"{}\"\n", g.dim, g.tag, g.name));
    }
    text.push_str("$EndPhysicalNames\n");
    text.push_str(&format!("$Nodes\n{}\n", m.nodes.len()));
    for (id, x) in &m.nodes {
        text.push_str(&format!("{id} {:?} {:?} {:?}\n", x[0], x[1], x[2]));
    }
    text.push_str("$EndNodes\n");
    text.push_str(&format!("$Elements\n{}\n", m.elements.len()));
    for (k, (ty, phys, geom, conn)) in m.elements.iter().enumerate() {
        text.push_str(&format!("{} {ty} 2 {phys} {geom}", k + 1));
        for c in conn {
            text.push_str(&format!(" {c}"));
        }
        text.push('\n');
    }
    text.push_str("$EndElements\n");
    text
}

/// Writes `text` to `out` through a temporary file in the same folder (another rank or run
/// never sees half a file).
pub(crate) fn write_atomically(out: &Path, text: &str) -> Result<(), MeshError> {
    let dir = out.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(|e| bad(dir, &e.to_string()))?;
    let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("mesh");
    let tmp = dir.join(format!("{stem}.{}.tmp", std::process::id()));
    std::fs::write(&tmp, text).map_err(|e| bad(&tmp, &e.to_string()))?;
    std::fs::rename(&tmp, out).map_err(|e| bad(out, &e.to_string()))
}

pub(crate) fn bad(path: &Path, why: &str) -> MeshError {
    MeshError::File {
        path: path.to_path_buf(),
        why: why.to_string(),
    }
}

pub(crate) fn read_msh22(path: &Path) -> Result<Msh22, MeshError> {
    let text = std::fs::read_to_string(path).map_err(|e| bad(path, &e.to_string()))?;
    let names = physical_names(path)?;
    let mut nodes = Vec::new();
    let mut elements = Vec::new();
    let mut lines = text.lines();
    while let Some(l) = lines.next() {
        match l.trim() {
            "$Nodes" => {
                let n: usize = lines
                    .next()
                    .and_then(|s| s.trim().parse().ok())
                    .ok_or_else(|| bad(path, "bad $Nodes count"))?;
                for _ in 0..n {
                    let row = lines.next().ok_or_else(|| bad(path, "truncated $Nodes"))?;
                    let v: Vec<f64> = row
                        .split_whitespace()
                        .filter_map(|s| s.parse().ok())
                        .collect();
                    if v.len() < 4 {
                        return Err(bad(path, &format!("bad node row: {row}")));
                    }
                    nodes.push((v[0] as u64, [v[1], v[2], v[3]]));
                }
            }
            "$Elements" => {
                let n: usize = lines
                    .next()
                    .and_then(|s| s.trim().parse().ok())
                    .ok_or_else(|| bad(path, "bad $Elements count"))?;
                for _ in 0..n {
                    let row = lines
                        .next()
                        .ok_or_else(|| bad(path, "truncated $Elements"))?;
                    let v: Vec<i64> = row
                        .split_whitespace()
                        .filter_map(|s| s.parse().ok())
                        .collect();
                    if v.len() < 3 || v.len() < 3 + v[2] as usize {
                        return Err(bad(path, &format!("bad element row: {row}")));
                    }
                    let ntags = v[2] as usize;
                    let phys = if ntags > 0 { v[3] as i32 } else { 0 };
                    let geom = if ntags > 1 { v[4] as i32 } else { 0 };
                    let conn = v[3 + ntags..].iter().map(|&x| x as u64).collect();
                    elements.push((v[1] as i32, phys, geom, conn));
                }
            }
            _ => {}
        }
    }
    Ok(Msh22 {
        names,
        nodes,
        elements,
    })
}

/// A `.msh` in the 2.2 ASCII format: the file itself, or a conversion by gmsh into `cache_dir`
/// (other versions, and binary files of any version, which gmsh reads). A conversion is written
/// under a temporary name and kept only when gmsh succeeded without an error line, so a file
/// gmsh cannot load is reported each time, never cached half-written.
pub fn as_msh22(path: &Path, cache_dir: &Path) -> Result<PathBuf, MeshError> {
    let bytes = std::fs::read(path).map_err(|e| bad(path, &format!("cannot read ({e})")))?;
    // "2.2 0 8": version 2.2, ASCII (a binary file has "2.2 1 8")
    let ascii22 = bytes
        .split(|&b| b == b'\n')
        .nth(1)
        .is_some_and(|l| l.starts_with(b"2.2 0"));
    if ascii22 {
        return Ok(path.to_path_buf());
    }
    std::fs::create_dir_all(cache_dir).map_err(|e| bad(cache_dir, &e.to_string()))?;
    let mut h = Sha256::new();
    h.update(&bytes);
    let hash = short_hash(h);
    let out = cache_dir.join(format!("converted-{hash}.msh"));
    if out.exists() {
        return Ok(out);
    }
    let tmp = cache_dir.join(format!("converted-{hash}.msh.{}.part", std::process::id()));
    let res = Command::new("gmsh")
        .arg(path)
        .args(["-save", "-format", "msh22", "-o"])
        .arg(&tmp)
        .output()
        .map_err(|e| MeshError::Gmsh {
            path: path.to_path_buf(),
            why: format!("cannot run gmsh: {e}"),
        })?;
    let text =
        String::from_utf8_lossy(&res.stderr).to_string() + &String::from_utf8_lossy(&res.stdout);
    let error = text.lines().any(|l| l.contains("Error"));
    if !res.status.success() || error || !tmp.exists() {
        let _ = std::fs::remove_file(&tmp);
        return Err(MeshError::Gmsh {
            path: path.to_path_buf(),
            why: failure_summary(&text, &res.status),
        });
    }
    std::fs::rename(&tmp, &out).map_err(|e| bad(&out, &e.to_string()))?;
    Ok(out)
}

/// Merges several meshes, each moved by its translation, into one msh 2.2 file in `cache_dir`
/// (cached by content). Physical groups with the same dimension and name become one group;
/// node, element and elementary-entity numbers are offset so they stay unique. The bodies stay
/// separate (no nodes are shared between meshes).
pub fn merge(parts: &[(PathBuf, [f64; 3])], cache_dir: &Path) -> Result<PathBuf, MeshError> {
    let mut meshes = Vec::new();
    let mut h = Sha256::new();
    for (p, t) in parts {
        let p22 = as_msh22(p, cache_dir)?;
        h.update(std::fs::read(&p22).map_err(|e| bad(&p22, &e.to_string()))?);
        h.update(format!("{t:?}").as_bytes());
        meshes.push((read_msh22(&p22)?, *t));
    }
    let hash = short_hash(h);
    let out = cache_dir.join(format!("merged-{hash}.msh"));
    if out.exists() {
        return Ok(out);
    }
    // New physical tags per (dim, name), in order of first appearance.
    let mut groups: Vec<PhysicalName> = Vec::new();
    let mut maps = Vec::new();
    for (m, _) in &meshes {
        let mut map = std::collections::BTreeMap::new();
        for n in &m.names {
            let tag = match groups.iter().find(|g| g.dim == n.dim && g.name == n.name) {
                Some(g) => g.tag,
                None => {
                    let tag = groups.len() as i32 + 1;
                    groups.push(PhysicalName {
                        dim: n.dim,
                        tag,
                        name: n.name.clone(),
                    });
                    tag
                }
            };
            map.insert((n.dim, n.tag), tag);
        }
        maps.push(map);
    }
    let mut merged = Msh22 {
        names: groups,
        nodes: Vec::new(),
        elements: Vec::new(),
    };
    let mut offsets = Vec::new();
    let mut base = 0u64;
    for (m, t) in &meshes {
        offsets.push(base);
        let mut top = 0;
        for (id, x) in &m.nodes {
            merged
                .nodes
                .push((id + base, [x[0] + t[0], x[1] + t[1], x[2] + t[2]]));
            top = top.max(*id);
        }
        base += top;
    }
    let mut geom_base = 0;
    for (k, (m, _)) in meshes.iter().enumerate() {
        let mut geom_top = 0;
        for (ty, phys, geom, conn) in &m.elements {
            let dim = match ty {
                15 => 0,
                1 | 8 => 1,
                2 | 3 | 9 | 10 => 2,
                _ => 3,
            };
            let p = maps[k].get(&(dim, *phys)).copied().unwrap_or(0);
            let conn = conn.iter().map(|c| c + offsets[k]).collect();
            merged.elements.push((*ty, p, geom + geom_base, conn));
            geom_top = geom_top.max(*geom);
        }
        geom_base += geom_top;
    }
    write_atomically(&out, &msh22_text(&merged))?;
    Ok(out)
}

/// The first 12 bytes of a SHA-256 as hex: the cache files' content key.
fn short_hash(h: Sha256) -> String {
    h.finalize()
        .iter()
        .take(12)
        .map(|b| format!("{b:02x}"))
        .collect()
}

#[cfg(test)]
mod tests {
    #[test]
    fn point_size_statements_are_found() {
        let geo = "MeshSize{ PointsOf{ Volume{1}; } } = HP; // the plate\nMeshSize{ Point In BoundingBox{-e, -e, -e, A + e, A + e, T + e} } = HH / 2;\nMesh.MeshSizeMax = H;\nCharacteristic Length{1, 2} = lc;\n";
        assert_eq!(point_size_expressions(geo), ["HP", "HH / 2", "lc"]);
    }

    #[test]
    fn a_gmsh_failure_is_summarised_in_a_few_distinct_lines() {
        use std::os::unix::process::ExitStatusExt;
        // gmsh with a mesh size of 0: one error per curve, then its summary box.
        let mut log = String::from("Info    : Meshing 1D...\n");
        for _ in 0..1500 {
            log.push_str("Error   : Wrong mesh element size lc = 0 (lcmin = 0, lcmax = 0)\n");
        }
        log.push_str("Error   : No elements in volume 1\nError   : ------------------------------\nError   : Mesh generation error summary\nError   :     0 warnings\nError   :  1583 errors\nError   : Check the full log for details\nError   : ------------------------------\n");
        let why = failure_summary(&log, &std::process::ExitStatus::from_raw(256));
        assert_eq!(
            why,
            "Error   : Wrong mesh element size lc = 0 (lcmin = 0, lcmax = 0) | Error   : No elements in volume 1 (and 1499 more error lines)"
        );
        // Killed (signal 9), no error line: how it ended and the log's last lines.
        let why = failure_summary(
            "Info    : Meshing 1D...\nInfo    : [ 10%] Meshing curve 2 (Line)\n",
            &std::process::ExitStatus::from_raw(9),
        );
        assert!(why.starts_with("gmsh was killed by a signal"), "{why}");
        assert!(
            why.ends_with("Info    : Meshing 1D... | Info    : [ 10%] Meshing curve 2 (Line)"),
            "{why}"
        );
    }

    use super::*;

    #[test]
    fn meshes_caches_and_reads_names() {
        if gmsh_version().is_err() {
            panic!("gmsh is required (make setup installs it)");
        }
        let dir = std::env::temp_dir().join(format!("tdyn-gmsh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let geo = dir.join("cube.geo");
        std::fs::write(
            &geo,
            "If(!Exists(N)) N = 2; EndIf\nSetFactory(\"OpenCASCADE\");\nBox(1) = {0,0,0,1,1,1};\n\
             Transfinite Curve{:} = N + 1;\nTransfinite Surface{:};\nRecombine Surface{:};\n\
             Transfinite Volume{:};\nPhysical Volume(\"block\") = {1};\nPhysical Surface(\"bottom\") = {5};\n",
        )
        .unwrap();
        let cache = dir.join(".cache");
        let mut def = MeshDef {
            file: geo.clone(),
            params: [("N".to_string(), 3.0)].into_iter().collect(),
            translate: [0.0; 3],
        };
        let a = mesh_file(&def, &cache).unwrap();
        let t1 = std::fs::metadata(&a).unwrap().modified().unwrap();
        let b = mesh_file(&def, &cache).unwrap();
        assert_eq!(a, b, "same inputs must hit the cache");
        assert_eq!(
            t1,
            std::fs::metadata(&b).unwrap().modified().unwrap(),
            "cache hit must not re-mesh"
        );
        // 3^3 = 27 hexahedra (gmsh element type 5) in the msh 2.2 file.
        let text = std::fs::read_to_string(&a).unwrap();
        let hexes = text
            .lines()
            .skip_while(|l| *l != "$Elements")
            .skip(2)
            .take_while(|l| *l != "$EndElements")
            .filter(|l| l.split_whitespace().nth(1) == Some("5"))
            .count();
        assert_eq!(hexes, 27, "N = 3 gives 3^3 hexahedra");
        def.params.insert("N".into(), 2.0);
        let c = mesh_file(&def, &cache).unwrap();
        assert_ne!(a, c, "other parameters, other mesh");
        let names = physical_names(&a).unwrap();
        assert!(names.contains(&PhysicalName {
            dim: 3,
            tag: 1,
            name: "block".into()
        }));
        assert!(names.iter().any(|n| n.dim == 2 && n.name == "bottom"));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn count_parameters_are_those_in_element_counts() {
        let geo = |name: &str| {
            let p = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../meshes")
                .join(name);
            count_parameters(&std::fs::read_to_string(p).unwrap())
        };
        let set = |v: &[&str]| v.iter().map(|s| s.to_string()).collect();
        assert_eq!(geo("bar.geo"), set(&["M", "N"]));
        assert_eq!(geo("block_plate.geo"), set(&["NB", "NH", "NP"]));
        // `Round(len / H)`: H is a length, not a count.
        assert_eq!(geo("container.geo"), set(&["NT"]));
        assert_eq!(geo("rod_wall.geo"), set(&[]));
        let text = "// Transfinite Curve{1} = X + 1;\n/* Layers{Y} */\nNN = 2 * N;\n\
                    Transfinite Curve{1, 2} = NN + 1;\nTransfinite Line{3} = K Using Progression 1.1;\n\
                    Extrude {0, 0, 1} { Surface{1}; Layers{ {L1, L2}, {0.5, 1} }; Recombine; }\n\
                    Transfinite Curve{4} = Round(A / h) + 1e3 + (P + 1) / (Q + 1);";
        assert_eq!(
            count_parameters(text),
            set(&["K", "L1", "L2", "N", "NN", "P"])
        );
    }

    #[test]
    fn missing_file_and_bad_geo_are_clear() {
        let dir = std::env::temp_dir().join(format!("tdyn-gmsh-bad-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let def = MeshDef {
            file: dir.join("nope.geo"),
            params: Default::default(),
            translate: [0.0; 3],
        };
        let e = mesh_file(&def, &dir).unwrap_err().to_string();
        assert!(e.contains("no such file"), "{e}");
        let geo = dir.join("bad.geo");
        std::fs::write(&geo, "Box(1) = {0,0,0;\n").unwrap();
        let def = MeshDef {
            file: geo,
            params: Default::default(),
            translate: [0.0; 3],
        };
        let e = mesh_file(&def, &dir).unwrap_err().to_string();
        assert!(e.contains("gmsh failed"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
