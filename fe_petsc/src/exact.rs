//! The exact sums of the FE stage ([`binsum`]: binned summation on fixed grids) and the
//! collective exact total over ranks.
pub use binsum::{
    add_parts, flatten, merge, pow2, sub_parts, value, values, Folds, Grid, FOLD_BITS, MAX_TERMS,
};

/// A step's nodal sums, each exact on its grid ([`crate::exact`]), as raw sums of the terms:
/// `[sum m v.v (twice the kinetic energy), sum f . dx over both halves of the element work's
/// trapezoids (minus twice the change of internal plus hourglass energy), external work, px,
/// py, pz]`.
pub type StepFolds = [Folds; 6];

/// The grids of the energy (J) and momentum (kg m/s) sums.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SumGrids {
    /// Energies and works.
    pub energy: Grid,
    /// Momenta.
    pub momentum: Grid,
}

impl SumGrids {
    /// The grids of a model of mass `mass`, kg ([`Grid::energy`], [`Grid::momentum`]).
    pub fn for_mass(mass: f64) -> SumGrids {
        SumGrids {
            energy: Grid::energy(mass),
            momentum: Grid::momentum(mass),
        }
    }
}

/// The sum over ranks of every rank's `values` (finite), the same bits at any rank count: on the
/// grid covering the reduced largest magnitude times the reduced number of values (three
/// reductions; for sums taken once, such as the model's mass). Collective.
pub fn total(comm: &mpi::topology::SimpleCommunicator, values: &[f64]) -> f64 {
    totals(comm, &[values.to_vec()])[0]
}

/// [`total`] of several sums at once (each on its own grid; the same three reductions):
/// `terms[k]` are this rank's terms of sum k (every rank passes as many sums). Collective.
pub fn totals(comm: &mpi::topology::SimpleCommunicator, terms: &[Vec<f64>]) -> Vec<f64> {
    use mpi::collective::{CommunicatorCollectives, SystemOperation};
    let n = terms.len();
    let big: Vec<f64> = terms
        .iter()
        .map(|t| t.iter().fold(0.0f64, |m, x| m.max(x.abs())))
        .collect();
    let count: Vec<u64> = terms.iter().map(|t| t.len() as u64).collect();
    let (mut g_big, mut g_n) = (vec![0.0f64; n], vec![0u64; n]);
    comm.all_reduce_into(&big[..], &mut g_big[..], SystemOperation::max());
    comm.all_reduce_into(&count[..], &mut g_n[..], SystemOperation::sum());
    let folds: Vec<Folds> = (0..n)
        .map(|k| {
            let grid = Grid::covering(g_big[k] * g_n[k].max(1) as f64);
            let mut f = [0.0; 3];
            for &x in &terms[k] {
                grid.add(&mut f, x);
            }
            f
        })
        .collect();
    let flat = flatten(&folds);
    let mut red = vec![0.0; flat.len()];
    comm.all_reduce_into(&flat[..], &mut red[..], SystemOperation::sum());
    values(&red)
}
