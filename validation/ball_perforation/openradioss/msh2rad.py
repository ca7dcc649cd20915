#!/usr/bin/env python3
"""Convert the gmsh (msh2) mesh of scenes/ball_perforation.toml into an OpenRadioss deck.

usage: msh2rad.py mesh.msh OUTDIR NAME [--isolid N] [--inpts N] [--vp N] [--failip N]

Writes OUTDIR/NAME_0000.rad (starter) and OUTDIR/NAME_0001.rad (engine). SI units (kg, m, s).
Parts: 1 plate (Johnson-Cook LAW2 + /FAIL/JOHNSON, element deletion), 2 ball (LAW1 elastic).
"""
import argparse
import os
import sys

import numpy as np

p = argparse.ArgumentParser()
p.add_argument("msh")
p.add_argument("outdir")
p.add_argument("name")
p.add_argument("--isolid", type=int, default=24)   # 24: one-point + physical stabilisation
p.add_argument("--inpts", type=int, default=0)     # 0: default integration points
p.add_argument("--vp", type=int, default=2)        # LAW2 strain-rate: 1 plastic, 2 total
p.add_argument("--failip", type=int, default=1)
p.add_argument("--icpre", type=int, default=0)
p.add_argument("--qa", type=float, default=1.2)    # quadratic bulk viscosity (ours 1.2)
p.add_argument("--qb", type=float, default=0.06)   # linear bulk viscosity (ours 0.06)
p.add_argument("--istf", type=int, default=0)
p.add_argument("--tend", type=float, default=3.0e-5)
p.add_argument("--plate_surf", default="ALL")      # ALL: eroded-solid faces join contact
p.add_argument("--one_way", action="store_true")   # type7: only ball nodes on plate faces
p.add_argument("--contact", default="type25")      # type25 | type7 (two one-way TYPE7)
args = p.parse_args()

# ---------------------------------------------------------------- read msh2
lines = open(args.msh).read().split("\n")
i = 0
names = {}
nodes = {}
elems = []  # (type, phys, nodes)
while i < len(lines):
    l = lines[i].strip()
    if l == "$PhysicalNames":
        n = int(lines[i + 1])
        for k in range(n):
            d, tag, nm = lines[i + 2 + k].split(None, 2)
            names[nm.strip('"')] = int(tag)
        i += n + 2
    elif l == "$Nodes":
        n = int(lines[i + 1])
        for k in range(n):
            t = lines[i + 2 + k].split()
            nodes[int(t[0])] = tuple(float(v) for v in t[1:4])
        i += n + 2
    elif l == "$Elements":
        n = int(lines[i + 1])
        for k in range(n):
            t = [int(v) for v in lines[i + 2 + k].split()]
            ntag = t[2]
            elems.append((t[1], t[3], t[3 + ntag:]))
        i += n + 2
    else:
        i += 1

phys = {v: k for k, v in names.items()}
hexes = {"plate": [], "ball": []}
quads = {}
for typ, ph, conn in elems:
    nm = phys.get(ph)
    if typ == 5:
        hexes[nm].append(conn)
    elif typ == 3:
        quads.setdefault(nm, []).append(conn)

# only nodes used by hexahedra
used = sorted({n for part in hexes.values() for h in part for n in h})
X = {n: np.array(nodes[n]) for n in used}


def vol(h):
    # hexahedron volume from 5 tets... use the standard decomposition into 6 tets
    x = [X[n] for n in h]
    tets = [(0, 1, 3, 4), (1, 2, 3, 6), (1, 3, 4, 6), (3, 4, 6, 7), (1, 4, 5, 6), (1, 3, 6, 4)]
    tets = [(0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6), (0, 5, 1, 6)]
    v = 0.0
    for a, b, c, d in tets:
        v += np.dot(np.cross(x[b] - x[a], x[c] - x[a]), x[d] - x[a]) / 6.0
    return v


nflip = 0
for part in hexes.values():
    for k, h in enumerate(part):
        if vol(h) < 0:
            part[k] = [h[0], h[3], h[2], h[1], h[4], h[7], h[6], h[5]]
            nflip += 1
vols = {nm: sum(vol(h) for h in part) for nm, part in hexes.items()}
side_nodes = sorted({n for q in quads["plate_sides"] for n in q})
ball_nodes = sorted({n for h in hexes["ball"] for n in h})
plate_nodes = set(n for h in hexes["plate"] for n in h)
assert not (plate_nodes & set(ball_nodes))
print(f"nodes {len(used)} plate hexes {len(hexes['plate'])} ball hexes {len(hexes['ball'])} "
      f"flipped {nflip} plate_sides nodes {len(side_nodes)} ball nodes {len(ball_nodes)}")
print(f"volumes: plate {vols['plate']:.6e} m3, ball {vols['ball']:.6e} m3 "
      f"(ball mass {7850 * vols['ball']:.6e} kg)")

# ---------------------------------------------------------------- write starter
os.makedirs(args.outdir, exist_ok=True)
SEP = "#---1----|----2----|----3----|----4----|----5----|----6----|----7----|----8----|----9----|---10----|"
o = []
w = o.append


def f20(v):
    return f"{v:20.10g}"


w("#RADIOSS STARTER")
w("/BEGIN")
w(args.name)
w("      2025         0")
w("                  kg                   m                   s")
w("                  kg                   m                   s")
w("/TITLE")
w("Steel ball perforating a 2024-T351 plate (mesh of scenes/ball_perforation.toml)")
w(SEP)
# plate material: Johnson-Cook, isothermal (rhoCp = 0: no heating; Tmelt = 0 -> 1e20: no softening)
w("/MAT/PLAS_JOHNS/1")
w("aluminium 2024-T351")
w("#              RHO_I")
w(f20(2770.0))
w("#                  E                  Nu     Iflag    flagVP                Pmin")
w(f20(73.0e9) + f20(0.33) + f"{0:10d}{args.vp:10d}" + f20(0.0))
w("#                  a                   b                   n           EPS_p_max            SIG_max0")
w(f20(265.0e6) + f20(426.0e6) + f20(0.34) + f20(0.0) + f20(0.0))
w("#                  c           EPS_DOT_0       ICC   Fsmooth               F_cut               Chard")
w(f20(0.015) + f20(1.0) + f"{1:10d}{0:10d}" + f20(0.0) + f20(0.0))
w("#                  m              T_melt              rhoC_p                 T_r               T_max")
w(f20(0.0) + f20(0.0) + f20(0.0) + f20(0.0) + f20(0.0))
w("/FAIL/JOHNSON/1")
w("#                 D1                  D2                  D3                  D4                  D5")
w(f20(0.13) + f20(0.13) + f20(-1.5) + f20(0.011) + f20(0.0))
w("#      EPSILON_DOT_0  IFAIL_SH  IFAIL_SO            EPSF_MIN                DADV               IXFEM")
w(f20(1.0) + f"{0:10d}{1:10d}" + f20(0.0) + f20(0.0) + f"{'':10s}{0:10d}")
w("#FAILIP")
w(f"{args.failip:10d}")
w("/MAT/ELAST/2")
w("steel")
w("#              RHO_I")
w(f20(7850.0))
w("#                  E                  Nu")
w(f20(200.0e9) + f20(0.3))
w(SEP)
w("/PROP/SOLID/1")
w("hexa")
w("#   Isolid    Ismstr      Iale     Icpre  Itetra10     Inpts   Itetra4    Iframe                  Dn")
w(f"{args.isolid:10d}{0:10d}{0:10d}{args.icpre:10d}{0:10d}{args.inpts:10d}{0:10d}{0:10d}" + f20(0.0))
w("#                 qa                  qb                   h              Lambda                  Mu")
w(f20(args.qa) + f20(args.qb) + f20(0.0) + f20(0.0) + f20(0.0))
w("#         deltaT_min            vdef_min            vdef_max             ASP_max             COL_min")
w(f20(0.0) * 5)
w("#     Ndir sphpartID  Icontrol")
w(f"{0:10d}{0:10d}{0:10d}")
w(SEP)
w("/PART/1")
w("plate")
w(f"{1:10d}{1:10d}{0:10d}")
w("/PART/2")
w("ball")
w(f"{1:10d}{2:10d}{0:10d}")
w(SEP)
w("/NODE")
for n in used:
    x = X[n]
    w(f"{n:10d}" + "".join(f20(v) for v in x))
eid = 0
for pid, nm in ((1, "plate"), (2, "ball")):
    w(f"/BRICK/{pid}")
    for h in hexes[nm]:
        eid += 1
        w(f"{eid:10d}" + "".join(f"{n:10d}" for n in h))
w(SEP)


def grnod(gid, title, ids):
    w(f"/GRNOD/NODE/{gid}")
    w(title)
    for k in range(0, len(ids), 10):
        w("".join(f"{n:10d}" for n in ids[k:k + 10]))


w("/BCS/1")
w("plate_sides clamped")
w("#  Tra rot   skew_ID  grnod_ID")
w("   111 111         0         1")
grnod(1, "plate_sides", side_nodes)
w("/INIVEL/TRA/1")
w("ball -500 m/s")
w("#                 Vx                  Vy                  Vz   Gnod_id   Skew_id")
w(f20(0.0) + f20(0.0) + f20(-500.0) + f"{2:10d}{0:10d}")
w("#             tstart   sens_ID")
w(f20(0.0) + f"{0:10d}")
grnod(2, "ball nodes", ball_nodes)
w(SEP)
# contact: ball skin (external faces) against every face of the plate's solids (/SURF/PART/ALL):
# with Idel = 1 the faces a deleted plate element uncovers join the contact (solid erosion)
def type7(iid, title, grnod_id, surf_id):
    w(f"/INTER/TYPE7/{iid}")
    w(title)
    w("# grnod_id   surf_id      Istf      Ithe      Igap                Ibag      Idel     Icurv      Iadm")
    w(f"{grnod_id:10d}{surf_id:10d}{args.istf:10d}{0:10d}{0:10d}{'':10s}{0:10d}{1:10d}{0:10d}{0:10d}")
    w("#          Fscalegap             Gap_max             Fpenmax                         Itied      Ists")
    w(f20(0.0) * 3 + f"{'':20s}{0:10d}{0:10d}")
    w("#              Stmin               Stmax   Percent_mesh_size               dtmin  Irem_gap   Irem_i2")
    w(f20(0.0) * 4 + f"{0:10d}{0:10d}")
    w("#              Stfac                Fric              GAPmin              Tstart               Tstop")
    w(f20(0.0) * 5)
    w("#      IBC                        Inacti               VIS_S               VIS_F              Bumult")
    w(f"{'':7s}000{'':20s}{0:10d}" + f20(0.0) * 3)
    w("#    Ifric    Ifiltr               Xfreq     Iform   sens_ID   fct_IDF             AscaleF   fric_ID")
    w(f"{0:10d}{0:10d}" + f20(0.0) + f"{0:10d}{0:10d}{0:10d}" + f20(0.0) + f"{0:10d}")


if args.contact == "type7":
    # ball skin nodes onto every plate face (Idel = 1: a face leaves when all its solids are
    # deleted; the internal faces of /SURF/PART/ALL are there from the start), and the plate's
    # nodes onto the ball skin
    type7(1, "ball nodes on plate faces", 3, 2)
    if not args.one_way:
        type7(2, "plate nodes on ball skin", 4, 1)
    skin = sorted({n for q in quads["ball_skin"] for n in q})
    grnod(3, "ball skin nodes", skin)
    w("/GRNOD/PART/4")
    w("plate nodes")
    w(f"{1:10d}")
else:
    w("/INTER/TYPE25/1")
    w("ball_plate")
    w("# surf_ID1  surf_ID2      Istf      Ithe      Igap   Irem_i2                Idel     Iedge    IPSTIF")
    w(f"{1:10d}{2:10d}{args.istf:10d}{0:10d}{0:10d}{0:10d}{'':10s}{1:10d}{0:10d}{0:10d}")
    w("# grnd_IDs                     Gap_scale          %mesh_size           Gap_max_s           Gap_max_m")
    w(f"{0:10d}{'':10s}" + f20(0.0) * 4)
    w("#              Stmin               Stmax     Igap0    Ishape          Edge_angle          STFAC_MDT")
    w(f20(0.0) + f20(0.0) + f"{0:10d}{0:10d}" + f20(0.0) + f20(0.0))
    w("#              Stfac                Fric           Tpressfit              Tstart               Tstop")
    w(f20(0.0) + f20(0.0) + f20(0.0) + f20(0.0) + f20(0.0))
    w("#      IBC               IVIS2    Inacti                VISs    Ithick                          Pmax")
    w(f"{'':7s}000{'':10s}{0:10d}{0:10d}" + f20(0.0) + f"{0:10d}{'':10s}" + f20(0.0))
    w("#    Ifric    Ifiltr               Xfreq             sens_ID              DTSTIF             fric_ID")
    w(f"{0:10d}{0:10d}" + f20(0.0) + f"{'':10s}{0:10d}" + f20(0.0) + f"{'':10s}{0:10d}")

w("/SURF/PART/EXT/1")
w("ball skin")
w(f"{2:10d}")
w(f"/SURF/PART/{args.plate_surf}/2")
w("plate all faces")
w(f"{1:10d}")
w(SEP)
w("/TH/PART/1")
w("parts")
w("#     var1      var2      var3      var4      var5      var6      var7      var8      var9     var10")
w("".join(f"{v:10s}" for v in ["IE", "KE", "XMOM", "YMOM", "ZMOM", "MASS", "HE", "VZ", "ERODED"]))
w("#     Obj1      Obj2      Obj3      Obj4      Obj5      Obj6      Obj7      Obj8      Obj9     Obj10")
w(f"{1:10d}{2:10d}")
w("/TH/INTER/2")
w("contact")
w("#     var1      var2      var3      var4      var5      var6      var7      var8      var9     var10")
w("DEF")
w("#     Obj1      Obj2      Obj3      Obj4      Obj5      Obj6      Obj7      Obj8      Obj9     Obj10")
w(f"{1:10d}")
w("/END")
open(os.path.join(args.outdir, f"{args.name}_0000.rad"), "w").write("\n".join(o) + "\n")

e = []
e.append("#RADIOSS ENGINE")
e.append(f"/RUN/{args.name}/1")
e.append(f20(args.tend))
e.append("/TFILE/4")
e.append(f20(2.0e-7))
e.append("/PRINT/-20")
e.append("/ANIM/DT")
e.append(f20(0.0) + f20(5.0e-6))
e.append("/ANIM/ELEM/EPSP")
e.append("/ANIM/ELEM/VONM")
e.append("/ANIM/VECT/VEL")
e.append("/ANIM/VECT/CONT")
e.append("/ANIM/MASS")
open(os.path.join(args.outdir, f"{args.name}_0001.rad"), "w").write("\n".join(e) + "\n")
# node ids of the ball for the post-processing
np.savetxt(os.path.join(args.outdir, "ball_nodes.txt"), ball_nodes, fmt="%d")
