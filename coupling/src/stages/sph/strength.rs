//! fe_petsc's materials as the SPH stage's stress models (`sph::StressModel`): an element and a
//! particle of the same `[[material]]` share one stress update (the elastic, J2 and
//! Johnson-Cook laws of `fe_petsc::material`, their radial returns included). The SPH stage
//! does not use it in runs yet: solid particles wait for the parallel step (docs/status.md).
//! The `sph` crate holds no material law and does not depend on fe_petsc; this adapter, in the
//! crate that depends on both, joins them. Both traits take the same conventions: Voigt xx, yy,
//! zz, xy, yz, zx, Pa, tension positive; strain increments with tensor shear components.
use fe_petsc::material::Material;
use std::sync::Arc;

/// A `[[material]]` of the elements as a particle's stress model.
#[derive(Debug, Clone)]
pub struct MaterialStress(pub Arc<dyn Material>);

impl sph::StressModel for MaterialStress {
    fn n_state(&self) -> usize {
        self.0.n_state()
    }

    fn init_state(&self, state: &mut [f64]) {
        self.0.init_state(state)
    }

    fn update_stress(
        &self,
        stress: &mut [f64; 6],
        state: &mut [f64],
        deps: &[f64; 6],
        dt: f64,
        density: f64,
    ) {
        self.0.update_stress(stress, state, deps, dt, density)
    }

    fn shear_modulus(&self) -> f64 {
        self.0.shear_modulus()
    }

    fn wave_modulus(&self, density: f64, state: &[f64]) -> f64 {
        self.0.wave_modulus(density, state)
    }

    fn plastic_strain(&self, state: &[f64]) -> f64 {
        self.0.plastic_strain(state)
    }

    fn temperature(&self, state: &[f64]) -> Option<f64> {
        self.0.temperature(state)
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

    /// One particle of `mat` at rest and unstressed, given the velocity gradient `l`, after one
    /// stress update over `dt` through `sph::solid::update_stress`: its stress, its pressure
    /// and the model's plastic strain.
    fn one_update(mat: Arc<dyn Material>, l: Mat3, dt: f64) -> ([f64; 6], f64, f64) {
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
        let model: Arc<dyn StressModel> = Arc::new(MaterialStress(mat));
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
}
