//! What the output asks of the element state: plastic strain, density, pressure, and the
//! memory the solver holds.
use super::*;

impl ExplicitFe {
    /// Number of local nodes.
    pub fn n_nodes(&self) -> usize {
        self.x.len()
    }

    /// Equivalent plastic strain of element `e`.
    pub fn plastic_strain(&self, e: usize) -> f64 {
        let s = self.mat_stride;
        self.materials[self.elem_material[e]].plastic_strain(&self.mat_state[e * s..(e + 1) * s])
    }

    /// Temperature of element `e`, K (Johnson-Cook with thermal softening), or NaN where its
    /// material keeps none.
    pub fn temperature(&self, e: usize) -> f64 {
        let s = self.mat_stride;
        self.materials[self.elem_material[e]]
            .temperature(&self.mat_state[e * s..(e + 1) * s])
            .unwrap_or(f64::NAN)
    }

    /// Current density of element `e`, kg/m^3: its mass over its volume at the current
    /// positions ([`hex::volume`]; the element loop's own volume differs from it at round-off
    /// and is not kept: formed on demand here, for output, not written every step).
    pub fn density(&self, e: usize) -> f64 {
        let v = hex::volume(&gather(&self.x, &self.elems[e]));
        self.materials[self.elem_material[e]].density() * self.vol0[e] / v
    }

    /// Pressure (without bulk viscosity) of element `e`, Pa: -tr(sigma) / 3 of its stress, as
    /// the element update reports it (formed on demand, not written every step).
    pub fn pressure(&self, e: usize) -> f64 {
        let s = self.state.stress(e);
        -(s[0] + s[1] + s[2]) * crate::hourglass::THIRD
    }

    /// Bytes of the per-node and per-element arrays on this rank.
    pub fn bytes(&self) -> usize {
        let nn = self.x.len();
        let ne = self.elems.len();
        nn * (7 * 24 + 8 + 1)
            + 24 * self.x_old.len()
            + ne * (std::mem::size_of::<[u32; 8]>()
                + 8
                + std::mem::size_of::<HexState>()
                + 8 * (1 + self.mat_stride)
                + 8)
            + self.blocks.bytes()
    }
}
