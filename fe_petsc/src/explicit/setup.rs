//! Construction: reference volumes, lumped masses summed over ranks, the initial state.
use super::*;

impl ExplicitFe {
    /// Builds the solver: reference volumes, lumped masses (summed over ranks), initial state.
    pub fn new(setup: ExplicitSetup, exchange: &mut NodeExchange) -> Result<ExplicitFe, StepError> {
        let m = setup.mesh;
        let nn = m.coords.len();
        let ne = m.elems.len();
        let mat_stride = setup
            .materials
            .iter()
            .map(|mm| mm.n_state())
            .max()
            .unwrap_or(0);
        let MassSetup {
            assembly,
            mut mass,
            vol0,
            mat_state,
        } = lumped_masses(&setup, mat_stride, exchange)?;
        let tets = tet_part(&setup, mat_stride, &mut mass, exchange)?;
        // The blocks' work over the hexahedra, then the tetrahedra as collapsed hexahedra
        // (a, b, c, c, d, d, d, d), their repeated corners given no force.
        let corners: Vec<[u32; 8]> = m
            .elems
            .iter()
            .copied()
            .chain(m.tets.iter().map(|&[a, b, c, d]| [a, b, c, c, d, d, d, d]))
            .collect();
        let mut elem_block = setup.elem_block.clone();
        elem_block.extend(&setup.tet_block);
        let blocks = BlockWork::new(&corners, elem_block, setup.n_blocks);
        let mut fe = ExplicitFe {
            elems: m.elems.clone(),
            elem_id: m.elem_id.clone(),
            x0: m.coords.clone(),
            x: m.coords.clone(),
            v: setup.velocity,
            a: vec![[0.0; 3]; nn],
            mass,
            force: vec![[0.0; 3]; nn],
            assembly,
            kick_work: [0.0; 3],
            contact_reaction_work: [0.0; 3],
            grids: SumGrids::for_mass(1.0),
            constrained_nodes: Vec::new(),
            constrained_force: Vec::new(),
            reaction: vec![[0.0; 3]; nn],
            reaction_old: vec![[0.0; 3]; nn],
            contact_reaction: vec![[0.0; 3]; setup.constraints.len()],
            x_old: m.coords.clone(),
            pushed: vec![0; nn],
            contact: true,
            kick_dt: 0.0,
            forces_zeroed: false,
            constrained_start: Vec::new(),
            owned: m.owned.clone(),
            state: HexStates::new(ne),
            mat_state,
            mat_stride,
            vol0,
            elem_material: setup.elem_material,
            materials: setup.materials,
            velocity_curves: scaled_velocities(&setup.constraints, setup.velocity_curves),
            constraints: setup.constraints,
            controls: setup.controls,
            gravity: setup.gravity,
            gravity0: setup.gravity,
            gravity_curve: setup.gravity_curve,
            loads: None,
            energies: Energies::default(),
            internal_plus_hg: 0.0,
            block_energies: vec![BlockEnergy::default(); blocks.n_blocks()],
            blocks,
            dt_stable_local: f64::INFINITY,
            time: 0.0,
            step: 0,
            timers: FeTimers::default(),
            lane_materials: Vec::new(),
            width: batch::widest(),
            constrained: vec![false; nn],
            tets,
            erosion: None,
            wall_holds: Default::default(),
        };
        fe.start();
        Ok(fe)
    }

    /// The lane forms of the materials, the constrained nodes, and the initial state: the
    /// boundary conditions acting on the initial velocities (a curve's value at t = 0), the
    /// initial acceleration gravity (zero stress), constrained, and the first stable step.
    fn start(&mut self) {
        let nn = self.x.len();
        self.lane_materials = self
            .materials
            .iter()
            .map(|m| LaneMaterial::new(&**m, &self.controls))
            .collect();
        for (n, _) in &self.constraints {
            self.constrained[*n as usize] = true;
        }
        self.constrained_nodes = (0..nn as u32)
            .filter(|&n| self.constrained[n as usize])
            .collect();
        // Boundary conditions act on the initial velocities (a curve's value at t = 0); the
        // initial acceleration is gravity (zero stress), constrained.
        self.gravity = self.gravity_at(0.0);
        self.scale_velocities(0.0, 0.0);
        self.constrain_velocities();
        for n in 0..nn {
            self.a[n] = self.gravity;
        }
        self.constrain_accelerations();
        self.start_curved_velocities();
        self.dt_stable_local = self.initial_stable_dt();
    }

    pub(super) fn initial_stable_dt(&self) -> f64 {
        let mut dt = f64::INFINITY;
        for (e, conn) in self.elems.iter().enumerate() {
            let xe = gather(&self.x, conn);
            let mat = &*self.materials[self.elem_material[e]];
            // The initial volumetric rate (an impact at t = 0 compresses some elements from
            // the first step: a cold gas has almost no sound speed, and only the bulk
            // viscosity's damping, which grows with the rate, limits its step).
            let ve = gather(&self.v, conn);
            let (b, _) = hex::gradient(&xe);
            let div_v: f64 = (0..8)
                .map(|k| ve[k][0] * b[k][0] + ve[k][1] * b[k][1] + ve[k][2] * b[k][2])
                .sum();
            dt = dt.min(hex::stable_dt(
                &xe,
                mat.density(),
                mat,
                &self.controls,
                div_v,
            ));
        }
        if let Some(t) = &self.tets {
            dt = dt.min(t.initial_stable_dt(&self.x, &self.v, &self.materials, &self.controls));
        }
        dt
    }
}

/// The native tetrahedra, where the mesh has any (collective): their masses added to `mass`
/// (each node: the hexahedra's sum, then the tetrahedra's).
fn tet_part(
    setup: &ExplicitSetup,
    mat_stride: usize,
    mass: &mut [f64],
    exchange: &mut NodeExchange,
) -> Result<Option<TetPart>, StepError> {
    let m = setup.mesh;
    if m.global_tets == 0 {
        return Ok(None);
    }
    let mut mass3: Vec<[f64; 3]> = vec![[0.0; 3]; mass.len()];
    let (part, bad) = TetPart::new(
        m,
        setup.tet_material.clone(),
        &setup.materials,
        mat_stride,
        &mut mass3,
        exchange,
    )?;
    for (m, t) in mass.iter_mut().zip(&mass3) {
        *m += t[0];
    }
    if let Some((e, volume)) = bad {
        let xe = tets::gather4(&m.coords, &m.tets[e]);
        return Err(StepError::Inverted {
            elem: m.tet_id[e],
            volume,
            at: tets::centroid4(&xe),
            time: 0.0,
            step: 0,
        });
    }
    Ok(Some(part))
}

/// Each velocity constraint with a curve: (index in `constraints`, velocity, curve), in
/// index order.
fn scaled_velocities(
    constraints: &[(u32, Constraint)],
    curves: Vec<Option<Curve>>,
) -> Vec<(usize, [f64; 3], Curve)> {
    curves
        .into_iter()
        .enumerate()
        .filter_map(|(i, c)| match (&constraints[i].1, c) {
            (Constraint::Velocity(v), Some(c)) => Some((i, *v, c)),
            _ => None,
        })
        .collect()
}

/// What [`lumped_masses`] hands the solver.
struct MassSetup {
    assembly: Assembly,
    mass: Vec<f64>,
    vol0: Vec<f64>,
    mat_state: Vec<f64>,
}

/// The reference volumes, the material states' initial values (`mat_stride` per element) and
/// the lumped masses, summed over ranks as the forces are (collective).
fn lumped_masses(
    setup: &ExplicitSetup,
    mat_stride: usize,
    exchange: &mut NodeExchange,
) -> Result<MassSetup, StepError> {
    let m = setup.mesh;
    let nn = m.coords.len();
    let ne = m.elems.len();
    let mut mass3 = vec![[0.0; 3]; nn];
    // The lumped masses summed as the forces are ([`crate::assembly`]).
    let mut assembly = Assembly::new(&m.elems, &m.elem_key, exchange)?;
    let mut vol0 = Vec::with_capacity(ne);
    let mut mat_state = vec![0.0; ne * mat_stride];
    let mut inverted = None;
    for (e, conn) in m.elems.iter().enumerate() {
        let xe = gather(&m.coords, conn);
        let vol = hex::volume(&xe);
        if vol <= 0.0 || !vol.is_finite() {
            // Keep the first, finish the loop: the mass exchange below is collective, and
            // a rank that left before it would hang the others in it.
            inverted.get_or_insert(StepError::Inverted {
                elem: m.elem_id[e],
                volume: vol,
                at: centroid(&xe),
                time: 0.0,
                step: 0,
            });
            vol0.push(0.0);
            continue;
        }
        vol0.push(vol);
        let mat = &setup.materials[setup.elem_material[e]];
        let me = mat.density() * vol / 8.0;
        for &n in conn {
            for c in 0..3 {
                mass3[n as usize][c] += me;
            }
        }
        assembly.record(e, |_| [me; 3]);
        if mat_stride > 0 {
            mat.init_state(&mut mat_state[e * mat_stride..(e + 1) * mat_stride]);
        }
    }
    assembly.finish(&mut mass3, exchange)?;
    if let Some(e) = inverted {
        return Err(e);
    }
    let mass: Vec<f64> = mass3.iter().map(|m| m[0]).collect();
    Ok(MassSetup {
        assembly,
        mass,
        vol0,
        mat_state,
    })
}
