//! The FE stage as a body of the contact stage ([`ContactBody`]): its contact surfaces' owned
//! nodes and its faces lent as records ([`FeContact`]), the push-back forces summed over the
//! ranks that hold copies of a node, applied with the nodes' constraints, and booked as the
//! contact stage books every correction (`contact::energy`).
use super::setup::Groups;
use super::{Fe, Integrator};
use crate::input::scene::ContactDef;
use crate::stages::contact::body::ContactBody;
use crate::transfer::fe_contact::{FeContact, FullFace};
use contact::energy::{booked_kick, booked_work, constrained_work, half_step_terms};
use contact::NodeRecord;
use fe_petsc::exact::Folds;
use fe_petsc::explicit::ExplicitFe;
use mpi::topology::SimpleCommunicator;

impl Fe {
    /// Finds the contact surfaces of the scene's `[contact]` table (`def`: its `surfaces`, the
    /// named physical surfaces or `"exterior"` for every boundary face, and the `master`
    /// volumes of a one-pass search) over the scene's `blocks` (collective), keeps them for the
    /// contact stage's steps and returns them.
    pub fn set_contact_surfaces(
        &mut self,
        world: &SimpleCommunicator,
        def: &ContactDef,
        blocks: &[String],
        groups: &Groups,
    ) -> &FeContact {
        let local = &self.mesh.local;
        // The named physical surfaces as node bits ("exterior": every boundary face).
        let bits = if def.surfaces.iter().any(|s| s == "exterior") {
            None
        } else {
            let mut b = 0u32;
            for name in &def.surfaces {
                let tag = groups.surfaces.get(name).copied();
                if let Some(k) = local.surface_tags.iter().position(|&t| Some(t) == tag) {
                    b |= 1 << k;
                }
            }
            Some(b)
        };
        // The master bodies of a one-pass search: those with an element in a `master` volume.
        let master: Vec<i32> = def
            .master
            .iter()
            .filter_map(|m| groups.volumes.get(m).copied())
            .collect();
        let block_tags: Vec<i32> = blocks
            .iter()
            .map(|b| groups.volumes.get(b).copied().unwrap_or(i32::MIN))
            .collect();
        // The faces that failing elements open, and their nodes, join (`FeContact::openings`).
        let state = self.state();
        let can_fail: Vec<bool> = (0..local.elems.len()).map(|e| state.can_fail(e)).collect();
        let built = FeContact::build(world, local, bits, (&master, &block_tags), &can_fail);
        self.contact_surfaces.insert(built)
    }

    /// The contact surfaces ([`Fe::set_contact_surfaces`]). Panics before they are set.
    fn surfaces(&self) -> &FeContact {
        self.contact_surfaces
            .as_ref()
            .expect("the FE stage's contact surfaces are set before the contact stage runs")
    }
}

/// Applies push-back forces `force` (one per local node, every copy holding the sum over
/// ranks) to the FE state after the drift ([`ExplicitFe::apply_contact`]) and returns the work
/// the corrections book over owned nodes, as the contact stage books every correction: `m dv .
/// (v + dv/2 - kick a(n) dt)`, `kick` = [`booked_kick`] of the node's push-back bits
/// ([`booked_work`]), plus on a constrained node the contact force's work at its prescribed
/// velocity, `m removed . v` ([`constrained_work`]). The contact stage's and the rigid walls'
/// push-back.
pub fn apply_contact(state: &mut ExplicitFe, force: &[[f64; 3]], dt: f64) -> Folds {
    state.apply_contact(force, dt, |c| {
        let kick = booked_kick(c.pushed);
        std::array::from_fn(|k| {
            booked_work(c.mass, c.dv[k], c.v[k], kick * dt * c.a[k])
                + constrained_work(c.mass, c.removed[k], c.v[k])
        })
    })
}

impl ContactBody for Fe {
    /// The owned contact nodes' records, after `kick_drift`; the mesh's node ids are the
    /// contact ids (the stage gives the mesh the offset 0), the start velocity the kick's.
    fn contact_nodes(&self, gid_offset: u64, _dt: f64) -> Vec<NodeRecord> {
        debug_assert_eq!(gid_offset, 0, "mesh nodes keep their ids");
        self.surfaces()
            .node_records(self.state(), &self.mesh.local.node_id)
    }

    /// The faces that elements failed since the last call opened or closed
    /// ([`crate::transfer::fe_contact::openings`]).
    fn update_faces(&mut self, world: &SimpleCommunicator) -> bool {
        let Fe {
            integrator,
            contact_surfaces,
            ..
        } = self;
        let state = match integrator {
            Integrator::Explicit(e) => &*e,
            Integrator::Implicit(i) => &i.fe,
        };
        contact_surfaces
            .as_mut()
            .is_some_and(|c| c.openings.update(world, state))
    }

    fn contact_faces(&self) -> Vec<FullFace> {
        self.surfaces()
            .face_records(self.state(), &self.mesh.local.node_id)
    }

    fn take_forces(&mut self, on_records: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, String> {
        let mut f = self
            .surfaces()
            .forces_on_nodes(self.state().n_nodes(), on_records);
        let Fe {
            integrator, mesh, ..
        } = self;
        let state = match integrator {
            Integrator::Explicit(e) => e,
            Integrator::Implicit(i) => &mut i.fe,
        };
        state
            .sum_contact_forces(&mut f, &mut mesh.exchange)
            .map_err(|e| e.to_string())?;
        Ok(f)
    }

    fn energy_terms(&self, force: &[[f64; 3]], dt: f64) -> [Folds; 2] {
        let fe = self.state();
        let mut t = [[0.0; 3]; 2];
        let e = &fe.grids.energy;
        for n in 0..fe.x.len() {
            let f = force[n];
            if f == [0.0; 3] || !fe.owned[n] {
                continue;
            }
            let (dv, removed) = fe.contact_dv_removed(n, f, dt);
            let v = fe.v[n];
            for c in 0..3 {
                let [a, b] = half_step_terms(fe.mass[n], dv[c], v[c]);
                e.add(&mut t[0], a);
                e.add(&mut t[1], b);
                // A driven node's share: the contact force's work on it (`constrained_work`).
                if removed[c] != 0.0 {
                    e.add(&mut t[0], constrained_work(fe.mass[n], removed[c], v[c]));
                }
            }
        }
        t
    }

    fn forces_on_records(&self, force: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.surfaces()
            .nodes
            .iter()
            .map(|&(n, _)| force[n as usize])
            .collect()
    }

    /// Mesh nodes are never held (`held` is ignored).
    fn apply_impulses(&mut self, force: &[[f64; 3]], _held: &[bool], dt: f64) -> Folds {
        apply_contact(self.state_mut(), force, dt)
    }
}
