//! What the output asks of the element state: plastic strain, density, pressure, and the
//! memory the solver holds.
//!
//! The output and the probes see one list of elements: this rank's hexahedra, then its native
//! tetrahedra ([`ExplicitFe::n_elements`]); element `e` at or past `elems.len()` is the
//! tetrahedron `e - elems.len()`.
use super::*;

/// One element of [`ExplicitFe`]'s list: a hexahedron or a native tetrahedron, by its index in
/// its own arrays.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ElementRef {
    /// A hexahedron (`elems`).
    Hex(usize),
    /// A native tetrahedron (`tets`).
    Tet(usize),
}

impl ExplicitFe {
    /// Number of local nodes.
    pub fn n_nodes(&self) -> usize {
        self.x.len()
    }

    /// Number of local elements, hexahedra and native tetrahedra.
    pub fn n_elements(&self) -> usize {
        self.elems.len() + self.tets.as_ref().map_or(0, |t| t.len())
    }

    /// Element `e` of the list (hexahedra first, then tetrahedra).
    pub fn element(&self, e: usize) -> ElementRef {
        let nh = self.elems.len();
        if e < nh {
            ElementRef::Hex(e)
        } else {
            ElementRef::Tet(e - nh)
        }
    }

    /// Global id of element `e`.
    pub fn element_id(&self, e: usize) -> u64 {
        match self.element(e) {
            ElementRef::Hex(h) => self.elem_id[h],
            ElementRef::Tet(t) => self.tet_part().id[t],
        }
    }

    /// The local nodes of element `e` as a hexahedron's 8 (gmsh/VTK order); a tetrahedron
    /// (a, b, c, d) as the collapsed hexahedron (a, b, c, c, d, d, d, d): its base the
    /// triangle abc, its top the point d, which is the tetrahedron itself (how ParaView and
    /// LS-DYNA's d3plot show a tetrahedron among hexahedra).
    pub fn element_nodes(&self, e: usize) -> [u32; 8] {
        match self.element(e) {
            ElementRef::Hex(h) => self.elems[h],
            ElementRef::Tet(t) => {
                let [a, b, c, d] = self.tet_part().conn[t];
                [a, b, c, c, d, d, d, d]
            }
        }
    }

    /// Block of element `e` (its index in the set-up's blocks).
    pub fn element_block(&self, e: usize) -> usize {
        self.blocks.block_of(e)
    }

    /// The tetrahedra, which an element index past the hexahedra names.
    fn tet_part(&self) -> &TetPart {
        self.tets
            .as_ref()
            .expect("an element index past the hexahedra names a tetrahedron")
    }

    /// Material and history values of element `e`.
    fn material_state(&self, e: usize) -> (&dyn Material, &[f64]) {
        let s = self.mat_stride;
        match self.element(e) {
            ElementRef::Hex(h) => (
                &*self.materials[self.elem_material[h]],
                &self.mat_state[h * s..(h + 1) * s],
            ),
            ElementRef::Tet(t) => {
                let tp = self.tet_part();
                (
                    &*self.materials[tp.material[t]],
                    &tp.mat_state[t * s..(t + 1) * s],
                )
            }
        }
    }

    /// Stress of element `e` (Voigt xx,yy,zz,xy,yz,zx), Pa.
    pub fn stress(&self, e: usize) -> [f64; 6] {
        match self.element(e) {
            ElementRef::Hex(h) => self.state.stress(h),
            ElementRef::Tet(t) => self.tet_part().state[t].stress,
        }
    }

    /// Equivalent plastic strain of element `e`.
    pub fn plastic_strain(&self, e: usize) -> f64 {
        let (m, st) = self.material_state(e);
        m.plastic_strain(st)
    }

    /// Temperature of element `e`, K (Johnson-Cook with thermal softening), or NaN where its
    /// material keeps none.
    pub fn temperature(&self, e: usize) -> f64 {
        let (m, st) = self.material_state(e);
        m.temperature(st).unwrap_or(f64::NAN)
    }

    /// Current density of element `e`, kg/m^3: its mass over its volume at the current
    /// positions ([`hex::volume`], [`crate::tet::gradients`]; the element loop's own volume
    /// differs from it at round-off and is not kept: formed on demand here, for output, not
    /// written every step). A tetrahedron's own density (not the nodal average its pressure
    /// follows).
    pub fn density(&self, e: usize) -> f64 {
        let (m, _) = self.material_state(e);
        match self.element(e) {
            ElementRef::Hex(h) => {
                let v = hex::volume(&gather(&self.x, &self.elems[h]));
                m.density() * self.vol0[h] / v
            }
            ElementRef::Tet(t) => {
                let tp = self.tet_part();
                let (_, v) = crate::tet::gradients(&tets::gather4(&self.x, &tp.conn[t]));
                m.density() * tp.vol0[t] / v
            }
        }
    }

    /// Pressure (without bulk viscosity) of element `e`, Pa: -tr(sigma) / 3 of its stress, as
    /// the element update reports it (formed on demand, not written every step).
    pub fn pressure(&self, e: usize) -> f64 {
        let s = self.stress(e);
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
            + self.tets.as_ref().map_or(0, |t| t.bytes())
    }
}
