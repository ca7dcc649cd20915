//! An SPH particle against a face.
//!
//! Choice: the particle is a sphere of its contact radius `r` around its centre, so it touches a
//! face when its centre comes closer than `r` on the outer side (the face offset outward by `r`);
//! a particle resting on a wall then sits on it rather than half inside it. The push-back acts on
//! the centre, like a node's. A particle belongs to no mesh body and is a corner of no face, so the
//! body and self-contact rules do not apply: a particle is tested against every face. Particles are
//! never faces, so particle-particle pairs never arise here (SPH handles those).

use super::{crossing, Hit};
use crate::data::ContactBox;
use crate::SearchParams;

/// See [`super::test`].
pub(super) fn test(b: &ContactBox, j: usize, f: usize, params: &SearchParams) -> Option<Hit> {
    crossing(b, j, f, b.nodes.radius[j], params.param_tol, params)
}
