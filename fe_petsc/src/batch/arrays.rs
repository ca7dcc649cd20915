//! A group's elements loaded from the element arrays and stored back, lane by lane: the path of
//! a part group, a pointwise law and materials with several history values per element (a
//! whole group of a lane law moves its state as whole vectors instead, [`Batch::update_lanes`]).
use super::Batch;
use crate::hex::{HexState, NODES};
use crate::material::MAX_STATE;
use crate::states::HexStates;

/// The element arrays a group is loaded from: nodal coordinates and velocities, connectivity,
/// reference volumes, element states and the materials' history values (`stride` per element,
/// the element's model's `n_state` first).
pub struct ElementArrays<'a> {
    /// Nodal coordinates, m.
    pub xs: &'a [[f64; 3]],
    /// Nodal velocities, m/s.
    pub vs: &'a [[f64; 3]],
    /// Every element's nodes.
    pub elems: &'a [[u32; NODES]],
    /// Every element's reference volume, m^3.
    pub vol0: &'a [f64],
    /// Every element's state.
    pub state: &'a HexStates,
    /// Every element's history values, `stride` each.
    pub history: &'a [f64],
    /// History values per element in `history`.
    pub stride: usize,
}

/// Loads elements `e0..e0 + n` (`n` at most `B::LANES`, each with `n_state` history values)
/// into the lanes of `g`, the lanes from `n` on with copies of element `e0` (lanes are
/// independent: their results are dropped).
pub fn load<B: Batch>(g: &mut B, a: &ElementArrays<'_>, e0: usize, n: usize, n_state: usize) {
    let mut list = [0usize; super::MAX_LANES];
    for (l, e) in list.iter_mut().zip(e0..e0 + n) {
        *l = e;
    }
    load_list(g, a, &list[..n], n_state);
}

/// Loads the elements `list` (at most `B::LANES`, at least one) into the first lanes of `g`,
/// the other lanes with copies of `list[0]` (as [`load`]).
pub fn load_list<B: Batch>(g: &mut B, a: &ElementArrays<'_>, list: &[usize], n_state: usize) {
    let elem = |l: usize| list[if l < list.len() { l } else { 0 }];
    let hist = |l: usize| {
        let mut h = [0.0; MAX_STATE];
        let at = elem(l) * a.stride;
        h[..n_state].copy_from_slice(&a.history[at..at + n_state]);
        h
    };
    let conn: Vec<[u32; NODES]> = (0..B::LANES).map(|l| a.elems[elem(l)]).collect();
    let vol0: Vec<f64> = (0..B::LANES).map(|l| a.vol0[elem(l)]).collect();
    let state: Vec<HexState> = (0..B::LANES).map(|l| a.state.get(elem(l))).collect();
    g.load(a.xs, a.vs, &conn, &vol0, &state, hist);
}

/// Stores the states and `n_state` history values of the first `n` lanes of `g` as elements
/// `e0..e0 + n` of `state` and `history` (`stride` values per element).
pub fn store<B: Batch>(
    g: &B,
    e0: usize,
    n: usize,
    n_state: usize,
    state: &mut HexStates,
    history: &mut [f64],
    stride: usize,
) {
    let mut list = [0usize; super::MAX_LANES];
    for (l, e) in list.iter_mut().zip(e0..e0 + n) {
        *l = e;
    }
    store_list(g, &list[..n], n_state, state, history, stride);
}

/// Stores lane `l`'s state and history as element `list[l]`'s (as [`store`]).
pub fn store_list<B: Batch>(
    g: &B,
    list: &[usize],
    n_state: usize,
    state: &mut HexStates,
    history: &mut [f64],
    stride: usize,
) {
    for (l, &e) in list.iter().enumerate() {
        let (s, h) = g.lane_state(l);
        state.set(e, &s);
        history[e * stride..e * stride + n_state].copy_from_slice(&h[..n_state]);
    }
}
