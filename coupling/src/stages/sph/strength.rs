//! fe_petsc's materials as the SPH stage's stress models (`sph::StressModel`): an element and a
//! particle of the same `[[material]]` share one stress update (the elastic, J2 and
//! Johnson-Cook laws of `fe_petsc::material`, their radial returns included).
//! The `sph` crate holds no material law and does not depend on fe_petsc; this adapter, in the
//! crate that depends on both, joins them. Both traits take the same conventions: Voigt xx, yy,
//! zz, xy, yz, zx, Pa, tension positive; strain increments with tensor shear components.
use fe_petsc::explicit::failure::Failure;
use fe_petsc::material::Material;
use std::sync::Arc;

/// A `[[material]]` of the elements as a particle's stress model, with the material's
/// `failure` criterion where it has one.
///
/// **Failed particles** (`[[material]] failure` on a `[[particles]]` material, and every
/// particle a failed element becomes). The criterion is the elements' own
/// ([`Failure::fails`]: the plastic strain reached, or Johnson-Cook's damage D at 1), checked
/// after each stress update; its state is one history value past the law's, D (Johnson-Cook's
/// damage; for the plastic-strain criterion 0, then 1 once failed). A failed particle is
/// material broken into fragments: it carries no deviatoric stress and no tension, as fully
/// damaged material in Benz & Asphaug's SPH fracture model (Icarus 107 (1994) 98) and in
/// Libersky et al.'s (J. Comput. Phys. 109 (1993) 67). Its stress is the mean stress of the law's update alone (the bulk modulus, or the
/// law's equation of state), capped at zero: sigma = min(tr(sigma_law) / 3, 0) I; the law's
/// history (plastic strain, temperature) stays as it was at failure. The work the deviatoric
/// stress took stays in the particle's internal energy.
#[derive(Debug, Clone)]
pub struct MaterialStress {
    /// The law (fe_petsc's elastic, J2 or Johnson-Cook).
    pub law: Arc<dyn Material>,
    /// The material's failure criterion (`None`: it does not fail).
    pub failure: Option<Failure>,
    /// The material's density, kg/m^3: a failed particle's density floor.
    pub density: f64,
}

impl MaterialStress {
    /// The law `law` of a material of density `density` (kg/m^3) with the criterion `failure`.
    pub fn new(law: Arc<dyn Material>, failure: Option<Failure>, density: f64) -> Self {
        Self {
            law,
            failure,
            density,
        }
    }
}

/// The mean stress of `stress`, capped at zero, as a hydrostatic stress (a failed particle's).
fn without_strength(stress: &mut [f64; 6]) {
    let mean = ((stress[0] + stress[1] + stress[2]) / 3.0).min(0.0);
    *stress = [mean, mean, mean, 0.0, 0.0, 0.0];
}

impl sph::StressModel for MaterialStress {
    fn n_state(&self) -> usize {
        self.law.n_state() + usize::from(self.failure.is_some())
    }

    fn init_state(&self, state: &mut [f64]) {
        let n = self.law.n_state();
        self.law.init_state(&mut state[..n]);
        if self.failure.is_some() {
            state[n] = 0.0;
        }
    }

    fn update_stress(
        &self,
        stress: &mut [f64; 6],
        state: &mut [f64],
        deps: &[f64; 6],
        dt: f64,
        density: f64,
    ) {
        let n = self.law.n_state();
        let Some(failure) = self.failure else {
            self.law.update_stress(stress, state, deps, dt, density);
            return;
        };
        let (law_state, damage) = state.split_at_mut(n);
        if damage[0] >= 1.0 {
            // failed: the law's mean stress alone, its history left as it was
            let mut scratch = [0.0; sph::solid::MAX_STATE];
            scratch[..n].copy_from_slice(law_state);
            self.law
                .update_stress(stress, &mut scratch[..n], deps, dt, density);
            without_strength(stress);
            return;
        }
        let ep0 = self.law.plastic_strain(law_state);
        self.law.update_stress(stress, law_state, deps, dt, density);
        let ep = self.law.plastic_strain(law_state);
        if failure.fails(&mut damage[0], ep, ep - ep0, stress, dt) {
            damage[0] = damage[0].max(1.0);
            without_strength(stress);
        }
    }

    fn shear_modulus(&self) -> f64 {
        self.law.shear_modulus()
    }

    fn wave_modulus(&self, density: f64, state: &[f64]) -> f64 {
        self.law.wave_modulus(density, &state[..self.law.n_state()])
    }

    fn plastic_strain(&self, state: &[f64]) -> f64 {
        self.law.plastic_strain(&state[..self.law.n_state()])
    }

    fn failed(&self, state: &[f64]) -> bool {
        self.failure.is_some() && state[self.law.n_state()] >= 1.0
    }

    fn density_floor(&self, state: &[f64]) -> f64 {
        if sph::StressModel::failed(self, state) {
            self.density
        } else {
            0.0
        }
    }

    fn temperature(&self, state: &[f64]) -> Option<f64> {
        self.law.temperature(&state[..self.law.n_state()])
    }

    fn reference_density(&self) -> Option<f64> {
        Some(self.density)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fe_petsc::material::{build_material, MaterialSpec};
    use sph::solid::tensor::Mat3;
    use sph::solid::update_stress;
    use sph::{NewParticle, Particles, Solids, StressModel};

    const E: f64 = 200e9;
    const NU: f64 = 0.3;

    fn material(model: &str, extra: &[(&str, f64)]) -> Arc<dyn Material> {
        let mut params = vec![("youngs_modulus", E), ("poisson_ratio", NU)];
        params.extend_from_slice(extra);
        Arc::from(
            build_material(&MaterialSpec {
                name: "steel".into(),
                model: model.into(),
                density: 7850.0,
                params: params.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
                eos: None,
            })
            .unwrap(),
        )
    }

    /// One steel particle at rest (1 mm^3, material index 0).
    fn one_particle() -> Particles {
        let mut p = Particles::new();
        p.push(NewParticle {
            id: 1,
            x: [0.0; 3],
            v: [0.0; 3],
            m: 7850e-9,
            rho: 7850.0,
            e: 0.0,
            h: 1.2e-3,
            mat: 0,
            fixed: false,
        });
        p
    }

    /// One particle of `mat` at rest and unstressed, given the velocity gradient `l`, after one
    /// stress update over `dt` through `sph::solid::update_stress`: its stress, its pressure
    /// and the model's plastic strain.
    fn one_update(mat: Arc<dyn Material>, l: Mat3, dt: f64) -> ([f64; 6], f64, f64) {
        let mut p = one_particle();
        let model: Arc<dyn StressModel> = Arc::new(MaterialStress::new(mat, None, 7850.0));
        let mut s = Solids::new(vec![Some(model.clone())], &p);
        s.grad_v[0] = l;
        update_stress(&mut p, &mut s, dt);
        let ep = model.plastic_strain(&s.state[..model.n_state()]);
        (s.stress[0], p.p[0], ep)
    }

    #[test]
    fn an_elastic_particle_takes_hookes_increment() {
        // From zero stress the Jaumann term vanishes: sigma = dt (lambda tr(D) I + 2 mu D),
        // D = sym(L), exactly (Hooke; lambda and mu from E and nu), to 1e-12 relative.
        let l = [[1.0, 2.0, 0.0], [0.0, -0.5, 0.3], [0.4, 0.0, 0.2]];
        let dt = 1e-7;
        let (sig, p, _) = one_update(material("elastic", &[]), l, dt);
        let mu = E / (2.0 * (1.0 + NU));
        let lambda = E * NU / ((1.0 + NU) * (1.0 - 2.0 * NU));
        let tr = l[0][0] + l[1][1] + l[2][2];
        let d = [
            l[0][0],
            l[1][1],
            l[2][2],
            0.5 * (l[0][1] + l[1][0]),
            0.5 * (l[1][2] + l[2][1]),
            0.5 * (l[2][0] + l[0][2]),
        ];
        for k in 0..6 {
            let want = dt * (if k < 3 { lambda * tr } else { 0.0 } + 2.0 * mu * d[k]);
            assert!(
                (sig[k] - want).abs() <= 1e-12 * want.abs().max(1.0),
                "stress[{k}] = {} Pa, Hooke's {want} Pa (1e-12)",
                sig[k]
            );
        }
        let want_p = -(lambda + 2.0 * mu / 3.0) * tr * dt;
        assert!(
            (p - want_p).abs() <= 1e-12 * want_p.abs(),
            "pressure {p} Pa, -K tr(D) dt = {want_p} Pa (1e-12)"
        );
    }

    #[test]
    fn a_j2_particle_returns_to_its_yield_surface() {
        // A pure shear rate far past yield in one step: the radial return puts the von Mises
        // stress on the hardened surface, sigma_y + H ep, with 3 mu dep = q_trial - q
        // (linear hardening, exact), to 1e-10 relative.
        let (sy, h) = (250e6, 2e9);
        let mat = material(
            "j2_plastic",
            &[("yield_stress", sy), ("hardening_modulus", h)],
        );
        let g = 0.01;
        let l = [[0.0, g, 0.0], [g, 0.0, 0.0], [0.0, 0.0, 0.0]];
        let dt = 1.0;
        let (sig, _, ep) = one_update(mat, l, dt);
        let q = (3.0 * sig[3] * sig[3]).sqrt();
        let mu = E / (2.0 * (1.0 + NU));
        let q_trial = 3.0_f64.sqrt() * 2.0 * mu * g * dt;
        assert!(ep > 0.0, "the shear of {g} flows plastically");
        assert!(
            (q - (sy + h * ep)).abs() <= 1e-10 * q,
            "von Mises {q} Pa on the surface sigma_y + H ep = {} Pa (1e-10)",
            sy + h * ep
        );
        assert!(
            (3.0 * mu * ep - (q_trial - q)).abs() <= 1e-10 * q_trial,
            "3 mu dep = {} Pa, q_trial - q = {} Pa (1e-10)",
            3.0 * mu * ep,
            q_trial - q
        );
    }

    #[test]
    fn a_failing_j2_particle_follows_uniaxial_strain_then_keeps_only_compression() {
        uniaxial_strain_to_failure(Failure::PlasticStrain(0.02));
    }

    #[test]
    fn johnson_cook_damage_with_a_constant_strain_to_failure_fails_a_particle_alike() {
        // d2 = d3 = d4 = 0: the strain to failure is d1 at every triaxiality and rate, so
        // D = ep / d1 and the particle fails at the same closed-form strain as with
        // `plastic_strain = d1` (the damage summed step by step, the threshold mid-step).
        uniaxial_strain_to_failure(Failure::JohnsonCook {
            d: [0.02, 0.0, 0.0, 0.0],
            eps_dot0: 1.0,
        });
    }

    /// One J2 particle under uniaxial strain failing by `failure`, whose strain to failure is
    /// 0.02 at every state.
    fn uniaxial_strain_to_failure(failure: Failure) {
        // Uniaxial strain (L = diag(r, 0, 0)), J2 with linear hardening H and failure at the
        // plastic strain eps_f, in steps of the strain increment d. The closed form (radial
        // return, exact for linear hardening on this proportional path): the mean stress is
        // K eps (J2 flow keeps the volume); past 2 mu |eps| = sigma_y the plastic strain is
        // ep = (2 mu |eps| - sigma_y) / (3 mu + H) and sigma_xx - sigma_yy = -(sigma_y + H ep).
        // The particle fails at the first step whose ep reaches eps_f, i.e. past
        // |eps_f_strain| = (sigma_y + (3 mu + H) eps_f) / (2 mu); from then on its stress is
        // K eps I in compression (Benz & Asphaug 1994's fully damaged material) and zero once
        // the strain turns to tension, its plastic strain frozen. Tolerance 1e-9 relative.
        let (sy, h, eps_f) = (250e6, 2e9, 0.02);
        let law = material(
            "j2_plastic",
            &[("yield_stress", sy), ("hardening_modulus", h)],
        );
        let model: Arc<dyn StressModel> = Arc::new(MaterialStress::new(law, Some(failure), 7850.0));
        let mut p = one_particle();
        let mut s = Solids::new(vec![Some(model.clone())], &p);
        let n = model.n_state();
        assert_eq!(n, 2, "J2's plastic strain and the damage");
        let mu = E / (2.0 * (1.0 + NU));
        let k = E / (3.0 * (1.0 - 2.0 * NU));
        let (dt, d) = (1e-6, -1.0e-4);
        let strain_f = (sy + (3.0 * mu + h) * eps_f) / (2.0 * mu);
        let close = |a: f64, b: f64, what: &str| {
            assert!(
                (a - b).abs() <= 1e-9 * b.abs().max(1e6),
                "{what}: {a:e}, closed form {b:e} (1e-9)"
            );
        };
        let mut eps = 0.0;
        let mut failed_at = None;
        // 400 steps in compression (to -0.04), then 800 back (to +0.04)
        for step in 0..1200 {
            let inc = if step < 400 { d } else { -d };
            s.grad_v[0] = [[inc / dt, 0.0, 0.0], [0.0; 3], [0.0; 3]];
            // the density continuity gives under this uniaxial strain: rho0 / (1 + eps)
            let rho_strained = 7850.0 / (1.0 + eps + inc);
            p.rho[0] = rho_strained;
            update_stress(&mut p, &mut s, dt);
            eps += inc;
            let sig = s.stress[0];
            let ep = model.plastic_strain(&s.state[..n]);
            let mean = (sig[0] + sig[1] + sig[2]) / 3.0;
            if failed_at.is_none() && s.state[n - 1] >= 1.0 {
                failed_at = Some(eps);
            }
            match failed_at {
                None => {
                    close(p.rho[0], rho_strained, "density before failure");
                    close(mean, k * eps, "mean stress before failure");
                    let want_ep = ((2.0 * mu * eps.abs() - sy) / (3.0 * mu + h)).max(0.0);
                    close(ep * 1e9, want_ep * 1e9, "plastic strain (x 1e9)");
                    if want_ep > 0.0 {
                        close(sig[0] - sig[1], -(sy + h * ep), "sigma_xx - sigma_yy");
                    }
                }
                Some(_) => {
                    // Fragments separate rather than stretch: the density stays at the
                    // material's in tension (the floor), follows the strain in compression.
                    close(p.rho[0], rho_strained.max(7850.0), "failed density");
                    let c = ((k + 4.0 * mu / 3.0) / rho_strained.max(7850.0)).sqrt();
                    close(p.c[0] * 1e6, c * 1e6, "failed sound speed (x 1e6)");
                    let want = (k * eps).min(0.0);
                    for (c, &v) in sig.iter().enumerate() {
                        close(v, if c < 3 { want } else { 0.0 }, "failed stress");
                    }
                    assert!(
                        ep < eps_f + (-d) * 2.0 * mu / (3.0 * mu + h),
                        "plastic strain {ep} frozen at failure"
                    );
                }
            }
        }
        let at = failed_at.expect("the particle fails");
        assert!(
            at.abs() >= strain_f && at.abs() < strain_f + d.abs(),
            "failed at strain {at}, closed form: the first step past {strain_f}"
        );
    }
}
