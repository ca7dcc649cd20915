//! Prints what each rank holds after distribution: `mpirun -np 2 meshinfo file.msh`.
use fe_petsc::mesh::DistributedMesh;
use fe_petsc::petsc::Petsc;
use mpi::traits::*;

fn tet(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> f64 {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let w = [d[0] - a[0], d[1] - a[1], d[2] - a[2]];
    (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
        + u[2] * (v[0] * w[1] - v[1] * w[0]))
        / 6.0
}

fn main() {
    let universe = mpi::initialize().unwrap();
    let world = universe.world();
    let path = std::env::args().nth(1).expect("usage: meshinfo FILE.msh");
    let petsc = Petsc::init(world.as_raw(), &[]).unwrap();
    let mut m =
        DistributedMesh::load(&world, std::path::Path::new(&path), &Default::default()).unwrap();
    let l = &m.local;
    let mut vol = 0.0;
    for e in &l.elems {
        let x = |k: usize| l.coords[e[k] as usize];
        // 5-tet split of a hex in VTK order (positive for a right-handed hex).
        vol += tet(x(0), x(1), x(3), x(4))
            + tet(x(1), x(2), x(3), x(6))
            + tet(x(1), x(4), x(5), x(6))
            + tet(x(3), x(4), x(6), x(7))
            + tet(x(1), x(3), x(4), x(6));
    }
    let mut ones = vec![1.0; 3 * l.coords.len()];
    m.exchange.sum_shared(&mut ones).unwrap();
    let shared = ones.iter().step_by(3).filter(|v| **v > 1.0).count();
    println!(
        "rank {} elems {} nodes {} owned {} shared {} vol {} ids {:?} blocks {:?} surf {:?} masks {:?} global {} {}",
        world.rank(), l.elems.len(), l.coords.len(), l.owned.iter().filter(|o| **o).count(), shared, vol,
        &l.elem_id[..l.elem_id.len().min(4)], &l.elem_block[..l.elem_block.len().min(3)], l.surface_tags,
        &l.node_surfaces[..l.node_surfaces.len().min(6)], l.global_nodes, l.global_elems
    );
    drop(m);
    drop(petsc);
}
