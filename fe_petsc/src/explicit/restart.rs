//! The explicit solver's restart state: the named arrays, how each lies over the ranks, and
//! setting them back.
use super::*;

/// How a named restart array ([`ExplicitFe::restart_state`], `ImplicitFe::restart_state`)
/// lies over the ranks: what a restart on another rank count needs to move it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RestartLayout {
    /// A fixed number of values per local node, in local order; every copy of a node holds the
    /// same values (each rank integrates its ghosts with the same summed force), so any copy
    /// serves.
    Node,
    /// A fixed number of values per local hexahedron, in local order.
    Element,
    /// A fixed number of values per local native tetrahedron, in local order.
    Tet,
    /// The same on every rank (global energies, the clock), except the entry
    /// [`RESTART_DT_STABLE`] of `fe.scalars`: this rank's smallest stable step.
    Global,
}

/// The index in `fe.scalars` of the rank's own smallest stable step (the others are global).
pub const RESTART_DT_STABLE: usize = 8;

/// The layout of the restart array `name`; `None` for a name neither integrator writes.
pub fn restart_layout(name: &str) -> Option<RestartLayout> {
    use RestartLayout::*;
    Some(match name {
        "fe.x"
        | "fe.x_old"
        | "fe.v"
        | "fe.a"
        | "fe.force"
        | "fe.reaction"
        | "fe.reaction_old"
        | "fe.pushed"
        | "implicit.force_n"
        | "implicit.reaction_n"
        | "implicit.wall_active"
        | "implicit.wall_slip"
        | "implicit.wall_force_n" => Node,
        "fe.hex_state"
        | "fe.mat_state"
        | "fe.block_forces"
        | "fe.erosion"
        | "fe.erosion_volume"
        | "implicit.tangent_ke" => Element,
        "fe.tet_state" | "fe.tet_mat_state" | "fe.tet_block_forces" => Tet,
        "fe.scalars"
        | "fe.block_energies"
        | "implicit.force_scale_max"
        | "implicit.stats"
        | "implicit.tangent_kept" => Global,
        _ => return None,
    })
}

impl ExplicitFe {
    /// The state a restart needs to continue bit-identically on the same ranks, as named
    /// arrays of this rank's local nodes and elements in their local order: positions (now and
    /// at the step's start), velocities, accelerations, forces and reactions (now and at the
    /// last step: the energy sums use both), element stress and hourglass state, material
    /// history, volumes, pressures, the per-block bookkeeping, the global energies and the
    /// clock.
    pub fn restart_state(&self) -> Vec<(&'static str, Vec<f64>)> {
        let flat = |v: &Vec<[f64; 3]>| v.as_flattened().to_vec();
        let hex = self.state.to_flat();
        let e = &self.energies;
        let scalars = vec![
            e.kinetic,
            e.internal,
            e.hourglass,
            e.external_work,
            e.momentum[0],
            e.momentum[1],
            e.momentum[2],
            self.internal_plus_hg,
            self.dt_stable_local, // RESTART_DT_STABLE
            self.time,
            self.step as f64,
        ];
        let blocks: Vec<f64> = self
            .block_energies
            .iter()
            .flat_map(|b| [b.internal, b.hourglass, b.kinetic0, b.internal_plus_hg])
            .collect();
        // The per-block work: the hexahedra's, then the tetrahedra's apart (each by its ids).
        let mut block_forces = self.blocks.restart_state();
        let tet_block_forces =
            block_forces.split_off(block_forces.len().min(if self.blocks.active() {
                24 * self.elems.len()
            } else {
                0
            }));
        let mut out = vec![
            ("fe.x", flat(&self.x)),
            // Without kept start positions, the positions (read back only where kept).
            (
                "fe.x_old",
                flat(if self.contact { &self.x_old } else { &self.x }),
            ),
            ("fe.v", flat(&self.v)),
            ("fe.a", flat(&self.a)),
            ("fe.force", flat(&self.force)),
            ("fe.reaction", flat(&self.reaction)),
            ("fe.reaction_old", flat(&self.reaction_old)),
            ("fe.pushed", self.pushed.iter().map(|&p| p as f64).collect()),
            ("fe.hex_state", hex),
            ("fe.mat_state", self.mat_state.clone()),
            ("fe.scalars", scalars),
            ("fe.block_energies", blocks),
            ("fe.block_forces", block_forces),
        ];
        if let Some(t) = &self.tets {
            out.push((
                "fe.tet_state",
                t.state.iter().flat_map(|s| s.stress).collect(),
            ));
            out.push(("fe.tet_mat_state", t.mat_state.clone()));
            out.push(("fe.tet_block_forces", tet_block_forces));
        }
        if let Some(r) = &self.erosion {
            // Per element: failed (0, 1; 2: released to a particle), damage, plastic strain
            // after the last step.
            let v = (0..self.elems.len())
                .flat_map(|e| {
                    let f = r.failed[e] as u8 + r.released[e] as u8;
                    [f as f64, r.damage[e], r.ep_last[e]]
                })
                .collect();
            out.push(("fe.erosion", v));
            out.push(("fe.erosion_volume", r.vol_fail.clone()));
        }
        out
    }

    /// Sets the state [`ExplicitFe::restart_state`] gave (the same mesh on the same ranks);
    /// `get` returns each named array. An array missing or of the wrong length is an error
    /// naming it.
    pub fn set_restart_state(
        &mut self,
        get: &mut dyn FnMut(&str) -> Option<Vec<f64>>,
    ) -> Result<(), String> {
        let mut take = |name: &str, len: usize| -> Result<Vec<f64>, String> {
            let v = get(name).ok_or_else(|| format!("{name}: missing"))?;
            if v.len() != len {
                return Err(format!(
                    "{name}: {} values where this rank's mesh needs {len}",
                    v.len()
                ));
            }
            Ok(v)
        };
        let n3 = 3 * self.x.len();
        let ne = self.state.len();
        let unflat = |v: Vec<f64>| -> Vec<[f64; 3]> {
            v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
        };
        self.x = unflat(take("fe.x", n3)?);
        let x_old = unflat(take("fe.x_old", n3)?);
        if self.contact {
            self.x_old = x_old;
        }
        self.v = unflat(take("fe.v", n3)?);
        self.a = unflat(take("fe.a", n3)?);
        self.force = unflat(take("fe.force", n3)?);
        self.reaction = unflat(take("fe.reaction", n3)?);
        self.reaction_old = unflat(take("fe.reaction_old", n3)?);
        self.pushed = take("fe.pushed", self.x.len())?
            .iter()
            .map(|&p| p as u8)
            .collect();
        self.state.set_flat(&take("fe.hex_state", 18 * ne)?);
        self.mat_state = take("fe.mat_state", self.mat_state.len())?;
        let s = take("fe.scalars", 11)?;
        self.energies = Energies {
            kinetic: s[0],
            internal: s[1],
            hourglass: s[2],
            external_work: s[3],
            momentum: [s[4], s[5], s[6]],
        };
        self.internal_plus_hg = s[7];
        self.dt_stable_local = s[RESTART_DT_STABLE];
        self.time = s[9];
        self.step = s[10] as u64;
        let nb = self.block_energies.len();
        let b = take("fe.block_energies", 4 * nb)?;
        for (be, c) in self.block_energies.iter_mut().zip(b.chunks_exact(4)) {
            be.internal = c[0];
            be.hourglass = c[1];
            be.kinetic0 = c[2];
            be.internal_plus_hg = c[3];
        }
        // The step sums are filled by the next force evaluation before they are read.
        let mut w = take(
            "fe.block_forces",
            if self.blocks.active() {
                24 * self.elems.len()
            } else {
                0
            },
        )?;
        if let Some(t) = &mut self.tets {
            let n = t.len();
            let st = take("fe.tet_state", 6 * n)?;
            for (s, c) in t.state.iter_mut().zip(st.chunks_exact(6)) {
                s.stress.copy_from_slice(c);
            }
            t.mat_state = take("fe.tet_mat_state", t.mat_state.len())?;
            let nb = if self.blocks.active() { 24 * n } else { 0 };
            w.extend(take("fe.tet_block_forces", nb)?);
        }
        if !self.blocks.set_restart_state(&w) {
            return Err("fe.block_forces: does not fit this rank's mesh".into());
        }
        if let Some(r) = &mut self.erosion {
            let v = take("fe.erosion", 3 * r.failed.len())?;
            for (e, c) in v.chunks_exact(3).enumerate() {
                (r.failed[e], r.damage[e], r.ep_last[e]) = (c[0] != 0.0, c[1], c[2]);
                r.released[e] = c[0] == 2.0;
            }
            // the failure volumes (absent from a checkpoint of a version without them)
            match take("fe.erosion_volume", r.failed.len()) {
                Ok(v) => r.vol_fail = v,
                Err(e) if e.ends_with("missing") => {}
                Err(e) => return Err(e),
            }
            r.any = r.failed.iter().any(|&f| f);
        }
        Ok(())
    }
}
