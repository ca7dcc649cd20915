//! The implicit step's tangent: 4 M / dt^2 + K assembled at the trial state, elements and
//! hourglass control.
use super::*;
use crate::hourglass::Hourglass;

/// Forward-difference step of the material tangent, relative to the strain increment...
const FD_REL: f64 = 1e-6;
/// ... and the smallest strain increment it is taken relative to.
const FD_STRAIN_FLOOR: f64 = 1e-6;

impl ImplicitFe {
    /// Assembles 4 M / dt^2 + K at the current trial state (see the module comment).
    pub(super) fn assemble_tangent(
        &mut self,
        exchange: &mut NodeExchange,
    ) -> Result<(), PetscError> {
        let t0 = Instant::now();
        let dt = self.dt;
        if let Linear::Petsc { matrix, .. } = &mut self.linear {
            matrix.zero()?;
        }
        let stride = self.mat_stride;
        let mut ke = [0.0; 576];
        for (e, conn) in self.fe.elems.iter().enumerate() {
            let xe = gather(&self.x_trial, conn);
            let due = gather(&self.du, conn);
            let mat = &*self.fe.materials[self.fe.elem_material[e]];
            let (b, vol) = hex::gradient(&xe);
            // The strain increment of the step, for the material tangent.
            let mut deps = [0.0; 6];
            for k in 0..8 {
                let (d, bk) = (due[k], b[k]);
                deps[0] += d[0] * bk[0];
                deps[1] += d[1] * bk[1];
                deps[2] += d[2] * bk[2];
                deps[3] += 0.5 * (d[0] * bk[1] + d[1] * bk[0]);
                deps[4] += 0.5 * (d[1] * bk[2] + d[2] * bk[1]);
                deps[5] += 0.5 * (d[2] * bk[0] + d[0] * bk[2]);
            }
            let c = material_tangent(
                mat,
                &self.fe.state.stress(e),
                &self.fe.mat_state[e * stride..(e + 1) * stride],
                &deps,
                dt,
            );
            // S_I (6 x 3): engineering strain from node I's displacement.
            let s: [[[f64; 3]; 6]; 8] = std::array::from_fn(|k| {
                let [x, y, z] = b[k];
                [
                    [x, 0.0, 0.0],
                    [0.0, y, 0.0],
                    [0.0, 0.0, z],
                    [y, x, 0.0],
                    [0.0, z, y],
                    [z, 0.0, x],
                ]
            });
            // C S_J, then V S_I^T (C S_J).
            let cs: [[[f64; 3]; 6]; 8] = std::array::from_fn(|j| {
                std::array::from_fn(|p| {
                    std::array::from_fn(|bb| (0..6).map(|q| c[p][q] * s[j][q][bb]).sum())
                })
            });
            let hg = self.hourglass_tangent(e, mat, (&xe, &due), &b, vol, &deps);
            let proj: [Option<[[f64; 3]; 3]>; 8] =
                std::array::from_fn(|k| self.dofs[conn[k] as usize].matrix());
            for i in 0..8 {
                for j in 0..8 {
                    let mut kij = [[0.0; 3]; 3];
                    for a in 0..3 {
                        for bb in 0..3 {
                            let mut v = 0.0;
                            for p in 0..6 {
                                v += s[i][p][a] * cs[j][p][bb];
                            }
                            kij[a][bb] = vol * v + hg[3 * i + a][3 * j + bb];
                        }
                    }
                    if let Some(p) = proj[i] {
                        kij = mat3_mul(&p, &kij);
                    }
                    if let Some(p) = proj[j] {
                        kij = mat3_mul(&kij, &p);
                    }
                    for a in 0..3 {
                        for bb in 0..3 {
                            ke[(3 * i + a) * 24 + 3 * j + bb] = kij[a][bb];
                        }
                    }
                }
            }
            match &mut self.linear {
                Linear::Exact { cg, .. } => cg.store(e, &ke),
                Linear::Petsc { matrix, .. } => {
                    let rows: [i32; 8] = std::array::from_fn(|k| conn[k] as i32);
                    matrix.add_local(&rows, &ke)?;
                }
            }
        }
        match &mut self.linear {
            Linear::Exact { .. } => self.restore_diagonal(exchange)?,
            Linear::Petsc { matrix, .. } => {
                let c_mass = 4.0 / (dt * dt);
                for &n in &self.owned_nodes {
                    let d = c_mass * self.fe.mass[n];
                    let blk = [d, 0.0, 0.0, 0.0, d, 0.0, 0.0, 0.0, d];
                    matrix.add_local(&[n as i32], &blk)?;
                }
                matrix.assemble()?;
            }
        }
        self.stats.assemblies += 1;
        self.stats.assembly_s += t0.elapsed().as_secs_f64();
        Ok(())
    }

    /// The hourglass tangent of element `e` at the trial state (the forces the residual's last
    /// evaluation computed, `state_trial` and `mat_trial`, at the trial positions `x` and the
    /// step's increments `du`). For a material with a yield surface under the physical kind,
    /// the element's own hourglass step linearised (`Hourglass::tangent_at`): its loading
    /// ratio and its yield bound, so that an element whose centre flows, whose hourglass
    /// stresses the bound sets to zero, has no hourglass stiffness either (the elastic
    /// hourglass stiffness there, about a third of the element's, left Newton converging at about
    /// 1 - 4 m / (dt^2 k_hg) per iteration: hundreds of iterations a step once the elements
    /// yielded). Otherwise the linear map of `Hourglass::tangent` (elastic moduli, viscous part
    /// as c / dt).
    pub(super) fn hourglass_tangent(
        &self,
        e: usize,
        mat: &dyn Material,
        (x, du): (&[[f64; 3]; 8], &[[f64; 3]; 8]),
        b: &[[f64; 3]; 8],
        vol: f64,
        deps: &[f64; 6],
    ) -> Box<[[f64; 24]; 24]> {
        let bb: f64 = b.iter().flatten().map(|q| q * q).sum();
        let rho = mat.density() * self.fe.vol0[e] / vol;
        let mu = mat.shear_modulus();
        let stride = self.mat_stride;
        let state = &self.mat_trial[e * stride..e * stride + mat.n_state()];
        let yield_stress = mat.yield_stress(state);
        let physical = matches!(
            self.controls.hourglass.for_material(mu),
            Hourglass::Physical { .. }
        );
        let zero = [[0.0; 3]; 8];
        let mut step = HourglassStep {
            x,
            v: &zero,
            b,
            bb,
            vol,
            dt: self.dt,
        };
        let mut hm = HourglassMaterial {
            mu,
            nu: hourglass::poisson_ratio(mat.dilatational_modulus(), mu),
            rho,
            c: (mat.dilatational_modulus() / rho).sqrt(),
            tangent_ratio: 1.0,
            yield_stress: None,
            stress: [0.0; 6],
        };
        if !(physical && yield_stress.is_some()) {
            return self.controls.hourglass.tangent(&step, &hm, self.dt);
        }
        // The element's hourglass step as the residual took it: the mean velocity du / dt
        // from the amplitudes at t(n), the trial stress and yield stress, and the tangent
        // ratio of the trial stress change (unrotated: the rotation of a step is of the order
        // of its strain).
        let stress = self.state_trial.stress(e);
        let stress_n = self.fe.state.stress(e);
        let dsig: [f64; 6] = std::array::from_fn(|k| stress[k] - stress_n[k]);
        hm.tangent_ratio = hourglass::tangent_ratio(&dsig, deps, mu);
        hm.yield_stress = yield_stress;
        hm.stress = stress;
        let inv_dt = 1.0 / self.dt;
        let v: [[f64; 3]; 8] = std::array::from_fn(|k| du[k].map(|d| d * inv_dt));
        step.v = &v;
        self.controls
            .hourglass
            .tangent_at(&step, &hm, &self.fe.state.get(e).hg)
    }
}

#[inline]
fn mat3_mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// The algorithmic tangent d(stress)/d(strain) of `mat`'s stress update at (stress, state,
/// deps), Voigt xx,yy,zz,xy,yz,zx against engineering shear strains, symmetrised: forward
/// differences of `update_stress` (6 extra calls), at the reference density (a fluid, whose
/// stress is a function of the density alone, has no such tangent: fluids are explicit only).
pub fn material_tangent(
    mat: &dyn Material,
    stress: &[f64; 6],
    state: &[f64],
    deps: &[f64; 6],
    dt: f64,
) -> [[f64; 6]; 6] {
    let n = state.len();
    let mut buf = [0.0; MAX_MAT_STATE];
    let mut eval = |d: &[f64; 6]| -> [f64; 6] {
        let mut s = *stress;
        buf[..n].copy_from_slice(state);
        mat.update_stress(&mut s, &mut buf[..n], d, dt, mat.density());
        s
    };
    let s0 = eval(deps);
    let scale = deps.iter().fold(FD_STRAIN_FLOOR, |m, d| m.max(d.abs()));
    let h = FD_REL * scale;
    let mut c = [[0.0; 6]; 6];
    for l in 0..6 {
        let mut d = *deps;
        d[l] += h;
        let s1 = eval(&d);
        // Tensor shear strain h is engineering strain 2h.
        let to_eng = if l >= 3 { 0.5 } else { 1.0 };
        for k in 0..6 {
            c[k][l] = (s1[k] - s0[k]) / h * to_eng;
        }
    }
    for k in 0..6 {
        for l in (k + 1)..6 {
            let m = 0.5 * (c[k][l] + c[l][k]);
            c[k][l] = m;
            c[l][k] = m;
        }
    }
    c
}
