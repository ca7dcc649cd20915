//! The FE stage's restart on another rank count (`driver::checkpoint`): every rank holds all
//! writing ranks' sections (`pieces`) and builds its own arrays, in its local order, by global
//! node and element id (the mesh's ids, those fields.h5 writes).
//!
//! Each array's layout (`fe_petsc::explicit::restart_layout`) says how:
//! - per node: from the copy the writing rank owned (every copy of a node holds the same
//!   values: each rank integrates its ghosts with the same summed force);
//! - per element: from the one rank that held the element;
//! - global (energies, the clock): from rank 0's file, except the rank's own smallest stable
//!   step, set to the minimum over the files (only its minimum over ranks is ever read, and
//!   the next force evaluation replaces it).
//!
//! The per-block work bookkeeping (`fe_petsc::blocks`) is per element (each element's corner
//! forces at the last accepted state).
use super::Fe;
use crate::output::state::{StateReader, StateWriter};
use fe_petsc::explicit::{restart_layout, ExplicitFe, RestartLayout, RESTART_DT_STABLE};
use fe_petsc::mesh::LocalMesh;
use std::collections::HashMap;

/// Sections naming the ids of the local arrays, written beside them (`save_ids`).
const NODE_ID: &str = "fe.node_id";
const NODE_OWNED: &str = "fe.node_owned";
const ELEM_ID: &str = "fe.elem_id";
const TET_ID: &str = "fe.tet_id";

/// Writes the global ids of this rank's nodes and elements and which nodes it owns: what a
/// restart on another rank count maps the arrays by.
pub fn save_ids(w: &mut StateWriter, mesh: &LocalMesh, fe: &ExplicitFe) {
    w.put(NODE_ID, &mesh.node_id);
    let owned: Vec<u8> = fe.owned.iter().map(|&o| o as u8).collect();
    w.put(NODE_OWNED, &owned);
    w.put(ELEM_ID, &fe.elem_id);
    if let Some(t) = &fe.tets {
        w.put(TET_ID, &t.id);
    }
}

/// Where the items (nodes or elements) of the writing ranks lie.
struct Located {
    /// (piece, local index) of each global id.
    at: HashMap<u64, (usize, usize)>,
    /// Local items per piece.
    counts: Vec<usize>,
}

/// Where each id lies among the pieces. With `owned`, only the copies their rank owned count
/// (one per node).
fn locate(pieces: &[StateReader], ids: &str, owned: Option<&str>) -> Result<Located, String> {
    let mut at = HashMap::new();
    let mut counts = Vec::with_capacity(pieces.len());
    for (p, r) in pieces.iter().enumerate() {
        let id: Vec<u64> = r.get(ids).map_err(|e| {
            format!("{e}: the checkpoint predates restarts on another rank count; restart it on the rank count that wrote it")
        })?;
        let own: Option<Vec<u8>> = owned.map(|o| r.get(o)).transpose()?;
        for (i, &g) in id.iter().enumerate() {
            if own.as_ref().is_none_or(|o| o.get(i) == Some(&1)) {
                at.insert(g, (p, i));
            }
        }
        counts.push(id.len());
    }
    Ok(Located { at, counts })
}

/// The array `name` (`width` values per item) for the items with ids `mine`, gathered from
/// the pieces where `from` finds them.
fn gather(
    pieces: &[StateReader],
    name: &str,
    width: usize,
    mine: &[u64],
    from: &Located,
) -> Result<Vec<f64>, String> {
    let counts = &from.counts;
    let arrays: Vec<Vec<f64>> = pieces
        .iter()
        .map(|r| r.get::<f64>(name))
        .collect::<Result<_, _>>()?;
    for (p, a) in arrays.iter().enumerate() {
        if a.len() != width * counts[p] {
            return Err(format!(
                "checkpoint: {name}: rank {p} wrote {} values for {} items of {width}",
                a.len(),
                counts[p]
            ));
        }
    }
    let mut out = Vec::with_capacity(width * mine.len());
    for g in mine {
        let &(p, i) = from
            .at
            .get(g)
            .ok_or_else(|| format!("checkpoint: {name}: id {g} is in no rank's file"))?;
        out.extend_from_slice(&arrays[p][i * width..(i + 1) * width]);
    }
    Ok(out)
}

/// This rank's restart arrays, by name, built from every writing rank's.
pub fn arrays(fe: &Fe, pieces: &[StateReader]) -> Result<HashMap<&'static str, Vec<f64>>, String> {
    let (mesh, st) = (&fe.mesh.local, fe.state());
    let first = pieces.first().ok_or("checkpoint: no rank files")?;
    let nodes = locate(pieces, NODE_ID, Some(NODE_OWNED))?;
    let elems = locate(pieces, ELEM_ID, None)?;
    let tet_ids: &[u64] = match &fe.integrator {
        super::Integrator::Explicit(e) => e.tets.as_ref().map_or(&[], |t| &t.id),
        super::Integrator::Implicit(_) => &[],
    };
    let tets = match tet_ids.is_empty() {
        true => None,
        false => Some(locate(pieces, TET_ID, None)?),
    };
    let now = match &fe.integrator {
        super::Integrator::Explicit(e) => e.restart_state(),
        super::Integrator::Implicit(i) => i.restart_state(),
    };
    let mut out = HashMap::new();
    for (name, current) in now {
        let layout = restart_layout(name)
            .ok_or_else(|| format!("checkpoint: {name}: no layout for another rank count"))?;
        // Values per item from this rank's own array (no items: nothing to fill).
        let per = |n: usize| current.len().checked_div(n).unwrap_or(0);
        let a = (|| -> Result<Vec<f64>, String> {
            Ok(match layout {
                RestartLayout::Node => {
                    let w = per(mesh.node_id.len());
                    gather(pieces, name, w, &mesh.node_id, &nodes)?
                }
                RestartLayout::Element => {
                    let w = per(st.elem_id.len());
                    gather(pieces, name, w, &st.elem_id, &elems)?
                }
                RestartLayout::Tet => {
                    let w = per(tet_ids.len());
                    let from = tets
                        .as_ref()
                        .ok_or("checkpoint: tetrahedra's state without them")?;
                    gather(pieces, name, w, tet_ids, from)?
                }
                RestartLayout::Global => {
                    let mut a: Vec<f64> = first.get(name)?;
                    if name == "fe.scalars" && a.len() > RESTART_DT_STABLE {
                        for r in pieces {
                            let s: Vec<f64> = r.get(name)?;
                            let d = s.get(RESTART_DT_STABLE).copied().unwrap_or(f64::INFINITY);
                            a[RESTART_DT_STABLE] = a[RESTART_DT_STABLE].min(d);
                        }
                    }
                    a
                }
            })
        })();
        // The implicit tangent is optional: absent from a checkpoint of an earlier tdyn or of
        // a run with a PETSc solver, the continued run assembles a fresh one.
        if name.starts_with("implicit.tangent_") {
            if let Ok(a) = a {
                out.insert(name, a);
            }
            continue;
        }
        out.insert(name, a?);
    }
    Ok(out)
}
