#!/usr/bin/env python3
"""Writes scenes/bricks.toml, scenes/bricks_table.toml and scenes/bricks_pedestal.toml (the
contact benchmark's scenes): one
[[block]] per brick of meshes/bricks.geo, each with its own velocity. Run from the repository
root; the scenes are committed, so this is only needed to change them."""

N, A, G, NE, V = 4, 0.01, 0.0002, 3, 400.0
PITCH = A + G
C0 = -0.5 * (N * A + (N - 1) * G)
CMAX = C0 + (N - 1) * PITCH + A / 2  # the outermost brick centre

HEAD = {
    "bricks": f'''# The paper's bricks: {N**3} separate steel bricks ({A * 1e3:g} mm, {NE**3} elements each,
# {G * 1e3:g} mm apart) flying apart, each with the velocity V x / x_max of its centre x
# (V = {V:g} m/s along each axis at the outer bricks). The bricks move rigidly (no stress) and
# never touch; the search still runs over every skin every step while the bodies spread from a
# 41 mm cube to about 2.5 times its size. The contact benchmark (scripts/bench_contact.sh);
# written by scripts/make_bricks_scenes.py.
title = "Bricks flying apart (contact benchmark)"
''',
    "bricks_table": f'''# The bricks of bricks.toml lifting off a table: {N**3} separate steel bricks flying up and
# apart (velocity V (x / x_max, y / y_max, (z - z_min) / (z_max - z_min)) of the centre x,
# V = {V:g} m/s: the bottom layer slides off the table top without pressing it) above a
# 61 x 61 x 10 mm steel table of 2,304 elements whose top face only is a contact surface. Most
# elements are the table's, most contact nodes the bricks': the FE partition (balanced by
# elements) is not balanced in contact work, the case the paper argues from. The contact
# benchmark (scripts/bench_contact.sh); written by scripts/make_bricks_scenes.py.
title = "Bricks lifting off a table (contact benchmark)"
''',
    "bricks_pedestal": f'''# The bricks of bricks_table.toml lifting off a pedestal instead of a table: a 61 x 61 x
# 200 mm steel column of 12 x 12 x 40 = 5,760 elements whose top face only is a contact
# surface. METIS cuts the column across its height (the smallest cut), so the ranks holding its
# lower part hold no contact surface at all: the static FE decomposition leaves them idle in
# the contact search while one rank searches every brick (the case the paper argues from, at
# its strongest). The contact benchmark (scripts/bench_contact.sh); written by
# scripts/make_bricks_scenes.py.
title = "Bricks lifting off a pedestal (contact benchmark)"
''',
}

# Extra mesh parameters of the table: thickness TH, NW x NW x NH elements.
TABLE_PARAMS = {"bricks_table": "", "bricks_pedestal": ", TH = 0.2, NW = 12, NH = 40"}


def scene(name):
    table = name in TABLE_PARAMS
    params = f"N = {N}, A = {A}, G = {G}, NE = {NE}" + (
        ", TABLE = 1" + TABLE_PARAMS[name] if table else ""
    )
    surfaces = '["brick_skin", "table_top"]' if table else '["exterior"]'
    out = [HEAD[name], f'''[run]
end_time = 1.0e-4

[[mesh]]
file = "../meshes/bricks.geo"
params = {{ {params} }}

[[material]]
name = "steel"
model = "elastic"
density = 7850.0
youngs_modulus = 200.0e9
poisson_ratio = 0.3

[contact]
surfaces = {surfaces}
''']
    if table:
        out.append('[[block]]\ngroup = "table"\nmaterial = "steel"\n')
    for k in range(N):
        for j in range(N):
            for i in range(N):
                c = [C0 + n * PITCH + A / 2 for n in (i, j, k)]
                v = [round(V * x / CMAX, 6) for x in c]
                if table:
                    v[2] = round(V * k / (N - 1), 6)
                out.append(
                    f'[[block]]\ngroup = "b{i + N * j + N * N * k}"\nmaterial = "steel"\n'
                    f"velocity = [{v[0]!r}, {v[1]!r}, {v[2]!r}]\n"
                )
    with open(f"scenes/{name}.toml", "w") as f:
        f.write("\n".join(out))


for name in HEAD:
    scene(name)
