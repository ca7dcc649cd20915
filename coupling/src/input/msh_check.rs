//! The input mesh checked on rank 0 before anything reads it collectively (docs/scene.md "Exit
//! status").
//!
//! PETSc's gmsh reader runs on rank 0 inside a collective call: when it fails (a truncated file,
//! a face element that is no longer a face of any element because a hexahedron repeats or
//! misses a node) rank 0 returns while the other ranks wait in PETSc forever. So rank 0 reads
//! the ASCII msh 2.2 file here first and the ranks agree on the outcome before PETSc is called.
//! The checks, each naming the line, the element's gmsh id and its place:
//!
//! - the file is whole: every section has the rows its count announces, then its `$End` line;
//! - every node row is `id x y z` with finite coordinates, each id defined once;
//! - every element row has the node count of its gmsh type, each node defined in `$Nodes` and
//!   listed once;
//! - every hexahedron, tetrahedron and prism has a positive volume (not inverted, not flat: more than
//!   [`FLAT_VOLUME`] times the cube of its longest edge), named with its centroid;
//! - in a 3D mesh every surface element is a face, every line element an edge and every point
//!   element a node of some volume element.
//!
//! Nodes no element uses are allowed (PETSc leaves them out).
use rustc_hash::{FxHashMap, FxHashSet};
use std::path::Path;

/// A hexahedron or tetrahedron whose volume is at most this fraction of the cube of its longest
/// edge is flat (zero volume): its stable step and its stiffness are meaningless.
pub const FLAT_VOLUME: f64 = 1e-12;

/// gmsh element types this reader knows: (type, name, nodes, dimension). PETSc reads these.
const TYPES: &[(i64, &str, usize, u8)] = &[
    (1, "line", 2, 1),
    (2, "triangle", 3, 2),
    (3, "quadrangle", 4, 2),
    (4, "tetrahedron", 4, 3),
    (5, "hexahedron", 8, 3),
    (6, "prism", 6, 3),
    (7, "pyramid", 5, 3),
    (8, "3-node line", 3, 1),
    (9, "6-node triangle", 6, 2),
    (10, "9-node quadrangle", 9, 2),
    (11, "10-node tetrahedron", 10, 3),
    (12, "27-node hexahedron", 27, 3),
    (13, "18-node prism", 18, 3),
    (14, "14-node pyramid", 14, 3),
    (15, "point", 1, 0),
    (16, "8-node quadrangle", 8, 2),
    (17, "20-node hexahedron", 20, 3),
    (18, "15-node prism", 15, 3),
    (19, "13-node pyramid", 13, 3),
];

/// Faces of the volume elements by their corner nodes (gmsh's local numbering).
const HEX_FACES: [&[usize]; 6] = [
    &[0, 3, 2, 1],
    &[4, 5, 6, 7],
    &[0, 1, 5, 4],
    &[1, 2, 6, 5],
    &[2, 3, 7, 6],
    &[3, 0, 4, 7],
];
const TET_FACES: [&[usize]; 4] = [&[0, 2, 1], &[0, 1, 3], &[0, 3, 2], &[1, 2, 3]];
const PRISM_FACES: [&[usize]; 5] = [
    &[0, 2, 1],
    &[3, 4, 5],
    &[0, 1, 4, 3],
    &[1, 2, 5, 4],
    &[2, 0, 3, 5],
];
const PYRAMID_FACES: [&[usize]; 5] = [
    &[0, 3, 2, 1],
    &[0, 1, 4],
    &[1, 2, 4],
    &[2, 3, 4],
    &[3, 0, 4],
];

/// What a whole, sound mesh holds.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct MshSummary {
    /// Nodes defined.
    pub nodes: usize,
    /// Elements of each dimension 0..=3.
    pub elements: [usize; 4],
    /// The faces of each physical surface (msh 2.2's first tag of a surface element), by
    /// tag: each face's corners as indices of the nodes in the file's order (PETSc numbers
    /// its vertices in that order), so the FE stage marks its surfaces from them.
    pub surfaces: Vec<(i32, Vec<Vec<usize>>)>,
    /// The volume elements of each physical volume (msh 2.2's first tag of a volume element),
    /// by tag: a physical volume the file names but no element carries is not listed.
    pub volumes: Vec<(i32, usize)>,
    /// Elements other than linear hexahedra, quadrangles, lines and points (tetrahedra, prisms,
    /// pyramids, triangles, second-order elements): the mesh goes through `split`.
    pub not_hexahedral: usize,
}

/// One element row.
struct Element {
    id: i64,
    kind: usize,
    line: usize,
    tags: Vec<i64>,
    nodes: Vec<i64>,
}

impl Element {
    fn name(&self) -> &'static str {
        TYPES[self.kind].1
    }
    fn dim(&self) -> u8 {
        TYPES[self.kind].3
    }
    /// The corner nodes of a volume element's faces.
    fn faces(&self) -> &'static [&'static [usize]] {
        match TYPES[self.kind].0 {
            5 | 12 | 17 => &HEX_FACES,
            4 | 11 => &TET_FACES,
            6 | 13 | 18 => &PRISM_FACES,
            7 | 14 | 19 => &PYRAMID_FACES,
            _ => &[],
        }
    }
    /// The corners of a lower-dimensional element (a face, an edge, a point).
    fn corners(&self) -> &[i64] {
        let n = match (self.dim(), self.nodes.len()) {
            (2, 3) | (2, 6) => 3,
            (2, _) => 4,
            (1, _) => 2,
            _ => 1,
        };
        &self.nodes[..n.min(self.nodes.len())]
    }
}

/// The text's lines with their 1-based numbers, blank lines skipped.
struct Lines<'a> {
    it: std::iter::Enumerate<std::str::Lines<'a>>,
    last: usize,
}

impl<'a> Lines<'a> {
    fn next(&mut self) -> Option<(usize, &'a str)> {
        for (i, l) in self.it.by_ref() {
            self.last = i + 1;
            if !l.trim().is_empty() {
                return Some((i + 1, l.trim()));
            }
        }
        None
    }
}

/// Reads and checks an ASCII msh 2.2 file.
pub fn check_file(path: &Path) -> Result<MshSummary, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read as text ({e}); save the mesh as ASCII msh 2.2 or 4.1"))?;
    check(&text)
}

/// Checks the text of an ASCII msh 2.2 file (see the module's list); the error names the line
/// and, for an element, its gmsh id and centroid.
pub fn check(text: &str) -> Result<MshSummary, String> {
    let mut lines = Lines {
        it: text.lines().enumerate(),
        last: 0,
    };
    match lines.next() {
        Some((_, "$MeshFormat")) => {}
        _ => return Err("not a gmsh mesh file (no $MeshFormat header)".into()),
    }
    let (n, fmt) = lines.next().ok_or("the file ends inside $MeshFormat")?;
    let f: Vec<&str> = fmt.split_whitespace().collect();
    if f.len() < 2 || !f[0].starts_with("2.") || f[1] != "0" {
        return Err(format!(
            "line {n}: format \"{fmt}\": expected ASCII msh 2.2 (\"2.2 0 8\")"
        ));
    }
    end_of(&mut lines, "$EndMeshFormat", 1, "format line")?;
    let mut nodes: Option<FxHashMap<i64, ([f64; 3], usize)>> = None;
    let mut elements: Option<Vec<Element>> = None;
    while let Some((n, l)) = lines.next() {
        match l {
            "$Nodes" => nodes = Some(read_nodes(&mut lines)?),
            "$Elements" => elements = Some(read_elements(&mut lines)?),
            "$PhysicalNames" => read_physical_names(&mut lines)?,
            s if s.starts_with("$End") => {
                return Err(format!("line {n}: {s} without its section"));
            }
            s if s.starts_with('$') => skip_section(&mut lines, n, s)?,
            s => return Err(format!("line {n}: \"{s}\" outside any section")),
        }
    }
    let nodes = nodes.ok_or("no $Nodes section")?;
    let elements = elements.ok_or("no $Elements section")?;
    let mut summary = check_elements(&nodes, &elements)?;
    summary.surfaces = physical_surfaces(&nodes, &elements);
    let mut volumes: std::collections::BTreeMap<i32, usize> = Default::default();
    for e in elements.iter().filter(|e| e.dim() == 3) {
        if let Some(&tag) = e.tags.first().filter(|&&t| t > 0) {
            *volumes.entry(tag as i32).or_default() += 1;
        }
    }
    summary.volumes = volumes.into_iter().collect();
    Ok(summary)
}

/// [`MshSummary::surfaces`] of a checked file: every surface element with a physical tag.
fn physical_surfaces(
    nodes: &FxHashMap<i64, ([f64; 3], usize)>,
    elements: &[Element],
) -> Vec<(i32, Vec<Vec<usize>>)> {
    // The nodes' order in the file is the order of their lines.
    let mut by_line: Vec<(usize, i64)> = nodes.iter().map(|(&id, &(_, l))| (l, id)).collect();
    by_line.sort_unstable();
    let index: FxHashMap<i64, usize> = by_line
        .iter()
        .enumerate()
        .map(|(k, &(_, id))| (id, k))
        .collect();
    let mut out: std::collections::BTreeMap<i32, Vec<Vec<usize>>> = Default::default();
    for e in elements.iter().filter(|e| e.dim() == 2) {
        let Some(&tag) = e.tags.first() else {
            continue;
        };
        if tag <= 0 {
            continue;
        }
        let face = e.corners().iter().map(|v| index[v]).collect();
        out.entry(tag as i32).or_default().push(face);
    }
    out.into_iter().collect()
}

/// A section this check does not read (`$PhysicalNames`, `$Periodic`, ...): up to its end.
fn skip_section(lines: &mut Lines, at: usize, name: &str) -> Result<(), String> {
    let end = format!("$End{}", &name[1..]);
    while let Some((_, l)) = lines.next() {
        if l == end {
            return Ok(());
        }
    }
    Err(format!(
        "line {at}: {name} has no {end}: the file ends inside it (a truncated file?)"
    ))
}

/// The count line of a section.
fn count(lines: &mut Lines, what: &str) -> Result<usize, String> {
    let (n, l) = lines
        .next()
        .ok_or_else(|| format!("the file ends before the number of {what}"))?;
    l.parse()
        .map_err(|_| format!("line {n}: expected the number of {what}, got \"{l}\""))
}

/// The `$End...` line after a section's rows.
fn end_of(lines: &mut Lines, end: &str, count: usize, what: &str) -> Result<(), String> {
    match lines.next() {
        Some((_, l)) if l == end => Ok(()),
        Some((n, l)) => Err(format!(
            "line {n}: expected {end} after the {count} {what} the section announces, got \"{l}\""
        )),
        None => Err(format!("the file ends before {end} (a truncated file?)")),
    }
}

fn truncated(lines: &Lines, k: usize, total: usize, what: &str, section: &str) -> String {
    format!(
        "line {}: the file ends after {k} of the {total} {what} {section} announces (a truncated file?)",
        lines.last
    )
}

fn early_end(n: usize, row: &str, k: usize, total: usize, what: &str, section: &str) -> String {
    format!("line {n}: {row} after {k} of the {total} {what} {section} announces")
}

/// `$PhysicalNames`: rows `dim tag "name"` (PETSc's reader wants the quotes).
fn read_physical_names(lines: &mut Lines) -> Result<(), String> {
    let total = count(lines, "physical names")?;
    for k in 0..total {
        let (n, row) = lines
            .next()
            .ok_or_else(|| truncated(lines, k, total, "names", "$PhysicalNames"))?;
        let mut t = row.splitn(3, char::is_whitespace);
        let dim = t.next().and_then(|s| s.parse::<u8>().ok());
        let tag = t.next().and_then(|s| s.parse::<i64>().ok());
        let name = t.next().map(str::trim).unwrap_or("");
        let quoted = name.len() >= 2 && name.starts_with('"') && name.ends_with('"');
        if !matches!(dim, Some(0..=3)) || tag.is_none() || !quoted {
            return Err(format!(
                "line {n}: bad physical name row \"{row}\" (expected: dimension tag \"name\")"
            ));
        }
    }
    end_of(lines, "$EndPhysicalNames", total, "names")
}

/// `$Nodes`: id -> (coordinates, line).
fn read_nodes(lines: &mut Lines) -> Result<FxHashMap<i64, ([f64; 3], usize)>, String> {
    let total = count(lines, "nodes")?;
    let mut nodes = FxHashMap::default();
    for k in 0..total {
        let (n, row) = lines
            .next()
            .ok_or_else(|| truncated(lines, k, total, "nodes", "$Nodes"))?;
        if row.starts_with('$') {
            return Err(early_end(n, row, k, total, "nodes", "$Nodes"));
        }
        let t: Vec<&str> = row.split_whitespace().collect();
        let id = t.first().and_then(|s| s.parse::<i64>().ok());
        let x: Vec<f64> = t.iter().skip(1).filter_map(|s| s.parse().ok()).collect();
        let (Some(id), true, 3) = (id, t.len() == 4, x.len()) else {
            return Err(format!(
                "line {n}: bad node row \"{row}\" (expected: id x y z)"
            ));
        };
        if x.iter().any(|c| !c.is_finite()) {
            return Err(format!(
                "line {n}: node {id} has a non-finite coordinate ({}, {}, {})",
                x[0], x[1], x[2]
            ));
        }
        if let Some((_, first)) = nodes.insert(id, ([x[0], x[1], x[2]], n)) {
            return Err(format!(
                "line {n}: node {id} is defined twice (first on line {first})"
            ));
        }
    }
    end_of(lines, "$EndNodes", total, "nodes")?;
    Ok(nodes)
}

/// `$Elements`: each row's id, type, tags and nodes, its node count checked against its type.
fn read_elements(lines: &mut Lines) -> Result<Vec<Element>, String> {
    let total = count(lines, "elements")?;
    let mut out = Vec::with_capacity(total.min(1 << 20));
    let mut seen = FxHashMap::default();
    for k in 0..total {
        let (n, row) = lines
            .next()
            .ok_or_else(|| truncated(lines, k, total, "elements", "$Elements"))?;
        if row.starts_with('$') {
            return Err(early_end(n, row, k, total, "elements", "$Elements"));
        }
        let t: Option<Vec<i64>> = row.split_whitespace().map(|s| s.parse().ok()).collect();
        let bad = || {
            format!(
                "line {n}: bad element row \"{row}\" (expected: id type ntags tags... nodes...)"
            )
        };
        let t = t.filter(|t| t.len() >= 3).ok_or_else(bad)?;
        let (id, ty, ntags) = (t[0], t[1], t[2]);
        let Some(kind) = TYPES.iter().position(|e| e.0 == ty) else {
            return Err(format!(
                "line {n}: element {id} has gmsh type {ty}, which tdyn does not read (hexahedra are type 5)"
            ));
        };
        let want = TYPES[kind].2;
        let have = usize::try_from(ntags)
            .ok()
            .and_then(|m| (t.len() - 3).checked_sub(m))
            .ok_or_else(bad)?;
        if have != want {
            return Err(format!(
                "line {n}: element {id}: a {} has {want} nodes, the row lists {have}",
                TYPES[kind].1
            ));
        }
        if let Some(first) = seen.insert(id, n) {
            return Err(format!(
                "line {n}: element {id} is defined twice (first on line {first})"
            ));
        }
        let tags_end = 3 + ntags as usize;
        out.push(Element {
            id,
            kind,
            line: n,
            tags: t[3..tags_end].to_vec(),
            nodes: t[tags_end..].to_vec(),
        });
    }
    end_of(lines, "$EndElements", total, "elements")?;
    Ok(out)
}

/// Node references, repeated nodes, volumes, and the lower-dimensional elements against the
/// volume elements' faces, edges and nodes.
fn check_elements(
    nodes: &FxHashMap<i64, ([f64; 3], usize)>,
    elements: &[Element],
) -> Result<MshSummary, String> {
    let mut summary = MshSummary {
        nodes: nodes.len(),
        ..Default::default()
    };
    for e in elements {
        summary.elements[e.dim() as usize] += 1;
        if !matches!(TYPES[e.kind].0, 1 | 3 | 5 | 15) {
            summary.not_hexahedral += 1;
        }
        let mut seen = FxHashSet::default();
        for &v in &e.nodes {
            if !nodes.contains_key(&v) {
                return Err(format!(
                    "line {}: element {} ({}) refers to node {v}, which $Nodes does not define",
                    e.line,
                    e.id,
                    e.name()
                ));
            }
            if !seen.insert(v) {
                return Err(format!(
                    "line {}: element {} ({}) lists node {v} twice",
                    e.line,
                    e.id,
                    e.name()
                ));
            }
        }
        if e.dim() == 3 {
            check_volume(nodes, e)?;
        }
    }
    if summary.elements[3] > 0 {
        check_boundary_elements(elements)?;
    }
    Ok(summary)
}

/// The signed volume of the tetrahedron `(p[a], p[b], p[c], p[d])`, m^3 (positive in gmsh's
/// order).
fn tet_volume(p: &[[f64; 3]], [a, b, c, d]: [usize; 4]) -> f64 {
    let e = |k: usize| std::array::from_fn::<f64, 3, _>(|i| p[k][i] - p[a][i]);
    let (u, v, w) = (e(b), e(c), e(d));
    (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
        + u[2] * (v[0] * w[1] - v[1] * w[0]))
        / 6.0
}

/// A hexahedron's, tetrahedron's or prism's volume is positive and not flat. A prism (gmsh's
/// node order: the triangle 0 1 2 below 3 4 5) is measured as the three tetrahedra 0123, 1234
/// and 2345, exact where its quadrangles are planar, and inverted or flat where they are.
fn check_volume(nodes: &FxHashMap<i64, ([f64; 3], usize)>, e: &Element) -> Result<(), String> {
    let x = |k: usize| nodes[&e.nodes[k]].0;
    let corners = match (e.faces().len(), e.nodes.len()) {
        (6, _) => 8,
        (4, _) => 4,
        (5, 6) => 6,
        _ => return Ok(()),
    };
    let pts: Vec<[f64; 3]> = (0..corners).map(x).collect();
    let volume = match corners {
        8 => {
            let hex: [[f64; 3]; 8] = std::array::from_fn(|k| pts[k]);
            fe_petsc::hex::volume(&hex)
        }
        6 => [[0, 1, 2, 3], [1, 2, 3, 4], [2, 3, 4, 5]]
            .into_iter()
            .map(|t| tet_volume(&pts, t))
            .sum(),
        _ => tet_volume(&pts, [0, 1, 2, 3]),
    };
    let mut longest: f64 = 0.0;
    for i in 0..corners {
        for j in i + 1..corners {
            let l2: f64 = (0..3).map(|c| (pts[i][c] - pts[j][c]).powi(2)).sum();
            longest = longest.max(l2.sqrt());
        }
    }
    let centroid: [f64; 3] =
        std::array::from_fn(|c| pts.iter().map(|p| p[c]).sum::<f64>() / corners as f64);
    let at = format!(
        "({:.6e}, {:.6e}, {:.6e}) m",
        centroid[0], centroid[1], centroid[2]
    );
    if volume.abs() <= FLAT_VOLUME * longest.powi(3) {
        return Err(format!(
            "line {}: element {} ({}) has zero volume ({volume:.3e} m^3 with an edge of {longest:.3e} m): it is flat, centroid {at}",
            e.line,
            e.id,
            e.name()
        ));
    }
    if volume < 0.0 {
        return Err(format!(
            "line {}: element {} ({}) is inverted: volume {volume:.3e} m^3, centroid {at} (its nodes are not in gmsh's order)",
            e.line,
            e.id,
            e.name()
        ));
    }
    Ok(())
}

/// Corner nodes as a key independent of their order.
fn key(nodes: &[i64]) -> Vec<i64> {
    let mut k = nodes.to_vec();
    k.sort_unstable();
    k
}

/// In a 3D mesh, every surface element is a face, every line element an edge, every point
/// element a node of a volume element (PETSc's reader fails on rank 0 otherwise).
fn check_boundary_elements(elements: &[Element]) -> Result<(), String> {
    let mut wanted: FxHashMap<Vec<i64>, usize> = FxHashMap::default();
    for (i, e) in elements.iter().enumerate() {
        if e.dim() < 3 {
            wanted.entry(key(e.corners())).or_insert(i);
        }
    }
    if wanted.is_empty() {
        return Ok(());
    }
    let mut found: FxHashSet<Vec<i64>> = FxHashSet::default();
    for e in elements.iter().filter(|e| e.dim() == 3) {
        for f in e.faces() {
            let face: Vec<i64> = f.iter().map(|&k| e.nodes[k]).collect();
            let n = face.len();
            let mut candidates = vec![key(&face)];
            for k in 0..n {
                candidates.push(key(&[face[k], face[(k + 1) % n]]));
                candidates.push(vec![face[k]]);
            }
            for c in candidates {
                if wanted.contains_key(&c) {
                    found.insert(c);
                }
            }
        }
        if found.len() == wanted.len() {
            return Ok(());
        }
    }
    let first = wanted
        .iter()
        .filter(|(k, _)| !found.contains(*k))
        .map(|(_, &i)| i)
        .min()
        .expect("some element is not found");
    let e = &elements[first];
    let part = match e.dim() {
        2 => "a face",
        1 => "an edge",
        _ => "a node",
    };
    let group = match e.tags.first() {
        Some(&t) if t != 0 => format!(" of physical group {t}"),
        _ => String::new(),
    };
    Err(format!(
        "line {}: element {} ({}{group}, nodes {:?}) is not {part} of any volume element",
        e.line,
        e.id,
        e.name(),
        e.nodes
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two unit hexahedra side by side along x, with a quadrangle on the face x = 0 (gmsh's
    /// node order), as gmsh writes msh 2.2.
    const TWO_HEXES: &str = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n\
$PhysicalNames\n2\n2 2 \"left\"\n3 1 \"bar\"\n$EndPhysicalNames\n\
$Nodes\n12\n1 0 0 0\n2 1 0 0\n3 1 1 0\n4 0 1 0\n5 0 0 1\n6 1 0 1\n7 1 1 1\n8 0 1 1\n\
9 2 0 0\n10 2 1 0\n11 2 0 1\n12 2 1 1\n$EndNodes\n\
$Elements\n3\n1 3 2 2 1 1 4 8 5\n2 5 2 1 1 1 2 3 4 5 6 7 8\n3 5 2 1 1 2 9 10 3 6 11 12 7\n$EndElements\n";

    fn with(from: &str, to: &str) -> String {
        assert!(TWO_HEXES.contains(from), "{from}");
        TWO_HEXES.replacen(from, to, 1)
    }

    /// One prism (gmsh's reference: the triangle (0,0,0) (1,0,0) (0,1,0) below the same at z = 2),
    /// volume 1 m^3.
    const PRISM: &str = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n\
$Nodes\n6\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 2\n5 1 0 2\n6 0 1 2\n$EndNodes\n\
$Elements\n1\n1 6 2 1 1 1 2 3 4 5 6\n$EndElements\n";

    #[test]
    fn a_prism_upside_down_or_flat_is_named() {
        assert_eq!(check(PRISM).unwrap().elements, [0, 0, 0, 1]);
        // Its two triangles swapped: volume -1 m^3 (the reference's, negated).
        let e =
            check(&PRISM.replace("1 6 2 1 1 1 2 3 4 5 6", "1 6 2 1 1 4 5 6 1 2 3")).unwrap_err();
        assert!(
            e.contains("element 1 (prism) is inverted: volume -1.000e0 m^3"),
            "{e}"
        );
        // The top triangle on the bottom one's plane: zero volume.
        let e = check(&PRISM.replace("\n4 0 0 2\n5 1 0 2\n6 0 1 2", "\n4 0 0 0\n5 1 0 0\n6 0 1 0"))
            .unwrap_err();
        assert!(e.contains("has zero volume"), "{e}");
    }

    #[test]
    fn a_sound_mesh_passes() {
        let s = check(TWO_HEXES).unwrap();
        assert_eq!(s.nodes, 12);
        assert_eq!(s.elements, [0, 0, 1, 2]);
    }

    #[test]
    fn each_broken_mesh_is_named_by_line_element_and_place() {
        let cases = [
            // (change, what the message must say)
            (with("$EndElements\n", ""), "the file ends before $EndElements"),
            (TWO_HEXES[..200].to_string(), "truncated"),
            (with("7 1 1 1", "7 nan 1 1"), "line 17: node 7 has a non-finite coordinate (NaN, 1, 1)"),
            (with("1 2 3 4 5 6 7 8", "1 2 3 4 5 6 7 7"), "element 2 (hexahedron) lists node 7 twice"),
            (with("1 2 3 4 5 6 7 8", "1 2 3 4 5 6 7 99"), "element 2 (hexahedron) refers to node 99"),
            (
                with("1 2 3 4 5 6 7 8", "5 6 7 8 1 2 3 4"),
                "element 2 (hexahedron) is inverted: volume -1.000e0 m^3, centroid (5.000000e-1, 5.000000e-1, 5.000000e-1) m",
            ),
            (
                with("9 2 0 0\n10 2 1 0\n11 2 0 1\n12 2 1 1", "9 1 0 0\n10 1 1 0\n11 1 0 1\n12 1 1 1"),
                "element 3 (hexahedron) has zero volume",
            ),
            (with("1 3 2 2 1 1 4 8 5", "1 3 2 2 1 1 4 8 6"), "element 1 (quadrangle of physical group 2, nodes [1, 4, 8, 6]) is not a face"),
            (with("$Nodes\n12", "$Nodes\n13"), "line 23: $EndNodes after 12 of the 13 nodes"),
            (with("2 5 2 1 1", "2 5 2 1 1 1"), "a hexahedron has 8 nodes, the row lists 9"),
            (with("2 5 2 1 1", "2 42 2 1 1"), "gmsh type 42"),
            (with("3 5 2 1 1", "2 5 2 1 1"), "element 2 is defined twice"),
            (with("9 2 0 0", "1 2 0 0"), "node 1 is defined twice"),
            (with("2.2 0 8", "2.2 1 8"), "expected ASCII msh 2.2"),
            ("hello".to_string(), "not a gmsh mesh file"),
            (with("2 2 \"left\"", "2 2 left"), "line 6: bad physical name row \"2 2 left\""),
        ];
        for (text, needle) in cases {
            let e = check(&text).expect_err(needle);
            assert!(e.contains(needle), "expected {needle:?} in {e:?}");
        }
    }
}
