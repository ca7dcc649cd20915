#!/usr/bin/env python3
# Vendored copy of /work/shared/peers/liggghts/gen_data.py (the project's LIGGGHTS peer notes),
# kept here so that tests/liggghts.rs does not depend on the shared directory. Unchanged below.
"""Write LIGGGHTS 'atom_style sph' data files (id type rho 0 x y z 0 0) with explicit, decomposition-
independent atom IDs, so that LIGGGHTS (any -np) and an independent code read the same particles.

  python3 gen_data.py dambreak    -> data.dambreak3d   (4000 fluid + 14568 wall particles)
  python3 gen_data.py hydrostatic -> data.hydrostatic  (2000 fluid + 300 wall, periodic x,y)
  python3 gen_data.py random      -> data.random       (1000 jittered particles, random v and rho)
  python3 gen_data.py randomper   -> data.randomper    (same particles, periodic box [0,0.1]^3)
"""
import random, sys

DX = 0.01
RHO0, C0, GAM, G = 1000.0, 20.0, 7.0, 9.81
B = C0 * C0 * RHO0 / GAM
MASS = RHO0 * DX ** 3


def write(fn, box, atoms, vel=None, ntypes=2):
    with open(fn, "w") as f:
        f.write("LIGGGHTS data file (atom_style sph: id type rho 0 x y z 0 0)\n\n")
        f.write(f"{len(atoms)} atoms\n{ntypes} atom types\n\n")
        for (lo, hi), ax in zip(box, "xyz"):
            f.write(f"{lo:.10g} {hi:.10g} {ax}lo {ax}hi\n")
        f.write("\nMasses\n\n")
        for t in range(1, ntypes + 1):
            f.write(f"{t} {MASS:.17g}\n")
        f.write("\nAtoms\n\n")
        for i, (t, rho, x, y, z) in enumerate(atoms, 1):
            # LIGGGHTS 3.8.0 bug: AtomVecSPH has size_data_atom=6 but xcol_data=5, i.e. it reads
            # x,y,z from words 5,6,7 -> a plain 6-word line fails ("Did not assign all atoms").
            # Workaround: 9 words "id type rho 0 x y z 0 0"; the last 3 words are parsed as image
            # flags (ix = atoi(z) = 0 as long as |z| < 1), word 4 is ignored.
            assert abs(z) < 1.0
            f.write(f"{i} {t} {rho:.17g} 0 {x:.17g} {y:.17g} {z:.17g} 0 0\n")
        if vel:
            # atom_style sph needs 7 words per Velocities line; only vx vy vz are read
            f.write("\nVelocities\n\n")
            for i, (vx, vy, vz) in enumerate(vel, 1):
                f.write(f"{i} {vx:.17g} {vy:.17g} {vz:.17g} 0 0 0\n")


def grid(nx0, nx1, ny0, ny1, nz0, nz1):
    for k in range(nz0, nz1):
        for j in range(ny0, ny1):
            for i in range(nx0, nx1):
                yield ((i + 0.5) * DX, (j + 0.5) * DX, (k + 0.5) * DX)


def dambreak():
    # fluid: 20 x 10 x 20 cells = [0,0.2]x[0,0.1]x[0,0.2]; tank interior [0,0.6]x[0,0.1]x[0,0.25]
    atoms = [(1, RHO0, *p) for p in grid(0, 20, 0, 10, 0, 20)]
    for p in grid(-3, 63, -3, 13, -3, 25):
        i, j, k = (round(c / DX - 0.5) for c in p)
        if 0 <= i < 60 and 0 <= j < 10 and k >= 0:
            continue  # inside the open-top tank
        atoms.append((2, RHO0, *p))
    write("data.dambreak3d", [(-0.035, 0.635), (-0.035, 0.135), (-0.035, 0.40)], atoms)
    print("dambreak:", sum(a[0] == 1 for a in atoms), "fluid,", sum(a[0] == 2 for a in atoms), "wall")


def hydrostatic():
    # periodic 0.1 x 0.1 in x,y; 20 fluid layers (H = 0.2) + 3 wall layers below z=0
    H = 0.2
    rho_h = lambda z: RHO0 * (1.0 + RHO0 * G * (H - z) / B) ** (1.0 / GAM)  # Tait inverse
    atoms = [(1, rho_h(p[2]), *p) for p in grid(0, 10, 0, 10, 0, 20)]
    atoms += [(2, rho_h(p[2]), *p) for p in grid(0, 10, 0, 10, -3, 0)]
    write("data.hydrostatic", [(0.0, 0.1), (0.0, 0.1), (-0.035, 0.30)], atoms)
    print("hydrostatic:", len(atoms), "atoms")


def rand(fn="data.random", box=((-0.05, 0.15),) * 3):
    random.seed(12345)
    atoms, vel = [], []
    for p in grid(0, 10, 0, 10, 0, 10):
        x = [c + random.uniform(-0.1, 0.1) * DX for c in p]
        atoms.append((1, RHO0 + random.uniform(-5.0, 5.0), *x))
        vel.append(tuple(random.uniform(-0.1, 0.1) for _ in range(3)))
    write(fn, list(box), atoms, vel, ntypes=1)
    print(fn, len(atoms), "atoms")


if __name__ == "__main__":
    {"dambreak": dambreak, "hydrostatic": hydrostatic, "random": rand,
     # same particles, box [0,0.1]^3: fully periodic variant (use -var bnd p)
     "randomper": lambda: rand("data.randomper", ((0.0, 0.1),) * 3)}[sys.argv[1]]()
