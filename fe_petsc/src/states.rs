//! The hexahedra's state ([`HexState`]: stress and hourglass amplitudes, 18 doubles per element)
//! stored in the batched kernel's lane layout, so that a group of elements loads and stores its
//! state as whole vectors.
//!
//! Layout: elements in blocks of [`BLOCK`]; in a block, field `k` of element `e` at
//! `k * BLOCK + e % BLOCK` (struct of arrays within the block, arrays of blocks). An element
//! group of the batched kernel that starts at a multiple of its width (4 or 8, both dividing
//! [`BLOCK`]) finds each field of its elements in consecutive doubles: one vector load or store
//! per field instead of a transposition lane by lane (measured in `examples/hex_bench`, eight
//! lanes: the transposition in and out took about 15 ns of the 140 ns per element of load,
//! update and extraction).
use crate::hex::HexState;

/// Elements per block: the widest group the batched kernel runs (eight AVX-512 lanes).
pub const BLOCK: usize = 8;
/// Doubles of state per element: stress (Voigt, 6) then the hourglass amplitudes (4 x 3).
pub const FIELDS: usize = 18;

/// The state of `len` hexahedra in blocks of [`BLOCK`] (see the module's comment).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HexStates {
    len: usize,
    data: Vec<f64>,
}

impl HexStates {
    /// `len` elements at the zero state.
    pub fn new(len: usize) -> HexStates {
        HexStates {
            len,
            data: vec![0.0; len.div_ceil(BLOCK) * BLOCK * FIELDS],
        }
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there are no elements.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Where element `e`'s field 0 lies; field `k` lies `k * BLOCK` further.
    #[inline(always)]
    fn base(e: usize) -> usize {
        (e / BLOCK) * BLOCK * FIELDS + e % BLOCK
    }

    /// Element `e`'s state.
    #[inline]
    pub fn get(&self, e: usize) -> HexState {
        assert!(e < self.len, "element {e} of {}", self.len);
        let b = Self::base(e);
        let f = |k: usize| self.data[b + k * BLOCK];
        HexState {
            stress: [f(0), f(1), f(2), f(3), f(4), f(5)],
            hg: [
                [f(6), f(7), f(8)],
                [f(9), f(10), f(11)],
                [f(12), f(13), f(14)],
                [f(15), f(16), f(17)],
            ],
        }
    }

    /// Element `e`'s stress (Voigt xx, yy, zz, xy, yz, zx), Pa.
    #[inline]
    pub fn stress(&self, e: usize) -> [f64; 6] {
        self.get(e).stress
    }

    /// Sets element `e`'s state.
    #[inline]
    pub fn set(&mut self, e: usize, s: &HexState) {
        assert!(e < self.len, "element {e} of {}", self.len);
        let b = Self::base(e);
        for (k, v) in s.stress.iter().chain(s.hg.as_flattened()).enumerate() {
            self.data[b + k * BLOCK] = *v;
        }
    }

    /// The lanes of the elements `e0..` up to the end of `e0`'s block: field `k` of element
    /// `e0 + l` at `[k * BLOCK + l]`.
    #[inline]
    pub fn lanes(&self, e0: usize) -> &[f64] {
        let b = Self::base(e0);
        &self.data[b..b - e0 % BLOCK + BLOCK * FIELDS]
    }

    /// [`HexStates::lanes`], to write.
    #[inline]
    pub fn lanes_mut(&mut self, e0: usize) -> &mut [f64] {
        let b = Self::base(e0);
        &mut self.data[b..b - e0 % BLOCK + BLOCK * FIELDS]
    }

    /// Every element's state in element order, 18 doubles each (stress then hourglass): the
    /// restart file's layout.
    pub fn to_flat(&self) -> Vec<f64> {
        (0..self.len)
            .flat_map(|e| {
                let s = self.get(e);
                let mut v = [0.0; FIELDS];
                v[..6].copy_from_slice(&s.stress);
                v[6..].copy_from_slice(s.hg.as_flattened());
                v
            })
            .collect()
    }

    /// Sets every element's state from [`HexStates::to_flat`]'s layout (`flat` holds 18 doubles
    /// per element).
    pub fn set_flat(&mut self, flat: &[f64]) {
        assert_eq!(flat.len(), FIELDS * self.len, "18 doubles per element");
        for (e, c) in flat.chunks_exact(FIELDS).enumerate() {
            let mut s = HexState::default();
            s.stress.copy_from_slice(&c[..6]);
            s.hg.as_flattened_mut().copy_from_slice(&c[6..]);
            self.set(e, &s);
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        8 * self.data.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every element's state comes back as set, through the element and the lane views, with
    /// a length that is not a multiple of the block (the reference: the values set).
    #[test]
    fn element_and_lane_views_agree() {
        let n = 2 * BLOCK + 3;
        let mut s = HexStates::new(n);
        let val = |e: usize, k: usize| (100 * e + k) as f64;
        for e in 0..n {
            let mut h = HexState::default();
            for k in 0..6 {
                h.stress[k] = val(e, k);
            }
            for k in 0..12 {
                h.hg[k / 3][k % 3] = val(e, 6 + k);
            }
            s.set(e, &h);
        }
        for e in 0..n {
            let h = s.get(e);
            assert_eq!(h.stress[5], val(e, 5));
            assert_eq!(h.hg[3][2], val(e, 17));
            let lanes = s.lanes(e);
            for k in 0..FIELDS {
                assert_eq!(lanes[k * BLOCK], val(e, k), "element {e} field {k}");
            }
        }
        let flat = s.to_flat();
        assert_eq!(flat[FIELDS * 5 + 7], val(5, 7));
        let mut t = HexStates::new(n);
        t.set_flat(&flat);
        assert_eq!(t, s);
    }
}
