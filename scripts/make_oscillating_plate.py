#!/usr/bin/env python3
"""Writes scenes/oscillating_plate.toml with its particle files scenes/oscillating_plate.csv and
scenes/oscillating_plate_clamp.csv: Gray, Monaghan & Swift (CMAME 190 (2001) 6641, section
6.1)'s oscillating elastic plate at NY particles through its thickness. Run from the
repository root; the scene and its files are committed, so this is only needed to change them."""
import math

NY = 10
L, H, RHO, K, G = 0.2, 0.02, 1000.0, 3.25e6, 7.15e5
KL = 1.875104  # the first root of cos kL cosh kL = -1
CLAMP, WIDTH = 3, 1  # layers of fixed particles (>= the support 2h = 2.4 dp); layers across z
VF = 0.002  # tip velocity over c0

dp = H / NY
nx = round(L / dp)
c0 = math.sqrt(K / RHO)
k = KL / L
E = 9 * K * G / (3 * K + G)
NU = (3 * K - 2 * G) / (2 * (3 * K + G))
omega = math.sqrt(E * H * H * k**4 / (12 * RHO * (1 - NU * NU)))
T = 2 * math.pi / omega


def shape(x):
    s, c = math.sinh(KL) + math.sin(KL), math.cosh(KL) + math.cos(KL)
    return s * (math.cosh(k * x) - math.cos(k * x)) - c * (math.sinh(k * x) - math.sin(k * x))


clamp, plate = ["id,x,y,z,vx,vy,vz"], ["id,x,y,z,vx,vy,vz"]
pid = 0
for i in range(nx + CLAMP):
    x = (i - CLAMP + 0.5) * dp
    for j in range(NY):
        for m in range(WIDTH):
            y, z = (j + 0.5) * dp - 0.5 * H, (m + 0.5) * dp
            vy = VF * c0 * shape(x) / shape(L) if x > 0 else 0.0
            row = f"{pid},{x!r},{y!r},{z!r},0,{vy!r},0"
            (plate if x > 0 else clamp).append(row)
            pid += 1
with open("scenes/oscillating_plate.csv", "w") as f:
    f.write("\n".join(plate) + "\n")
with open("scenes/oscillating_plate_clamp.csv", "w") as f:
    f.write("\n".join(clamp) + "\n")

scene = f'''# The oscillating elastic plate of Gray, Monaghan & Swift (CMAME 190 (2001) 6641, section 6.1):
# a plate L = {L} m long and H = {H} m thick, clamped at x = 0 by {CLAMP} layers of fixed solid
# particles (which compute stress like the others but never move), set moving with the velocity
# of its first clamped-free bending mode, v_y(x) = {VF} c0 F(x) / F(L),
#   F(x) = (sinh kL + sin kL)(cosh kx - cos kx) - (cosh kL + cos kL)(sinh kx - sin kx),
# k L = {KL} (zero value and slope at the clamp, no moment and no shear at the free end).
# rho = {RHO:g} kg/m^3, K = {K:g} Pa, G = {G:g} Pa (E = {E:.6g} Pa, nu = {NU:.4f}), c0 =
# sqrt(K/rho) = {c0:.2f} m/s. {NY} particles through the thickness (spacing {dp:g} m, h = 1.2
# spacings), {WIDTH} layers in a periodic z: plane strain, so the thin-plate period is
#   omega^2 = E H^2 k^4 / (12 rho (1 - nu^2)):  T = {T:.5f} s
# (Gray et al. eq. 33; Timoshenko). The particle files (id, position, velocity) are written by
# scripts/make_oscillating_plate.py. Every SPH setting is the default. validation/oscillating_plate
# measures the period at the tip over two periods.
title = "Oscillating elastic plate (Gray, Monaghan & Swift 2001)"

[run]
end_time = {2.1 * T:.4f}
output_every = {2.1 * T / 6:.4f}
history_every = {T / 400:.6f}

[[material]]
name = "rubber"
model = "elastic"
density = {RHO!r}
youngs_modulus = {E!r}
poisson_ratio = {NU!r}

[[particles]]
name = "clamp"
material = "rubber"
region = {{ file = "oscillating_plate_clamp.csv" }}
spacing = {dp!r}
fixed = true

[[particles]]
name = "plate"
material = "rubber"
region = {{ file = "oscillating_plate.csv" }}
spacing = {dp!r}

[sph]
periodic = {{ axes = [false, false, true], min = [-1.0, -1.0, 0.0], max = [1.0, 1.0, {WIDTH * dp!r}] }}

[[probe]]
name = "tip"
point = [{L - 0.5 * dp!r}, 0.0, {1.5 * dp!r}]
fields = ["velocity_y", "displacement_y"]

[output]
fields = ["displacement", "velocity", "stress"]
'''
with open("scenes/oscillating_plate.toml", "w") as f:
    f.write(scene)
print(f"T = {T} s, {pid} particles")
