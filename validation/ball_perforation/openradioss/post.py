"""Post-process one OpenRadioss run of the ball perforation deck (ballT01.csv, ball_0001.out)."""
import csv
import os
import re
import sys

d = sys.argv[1]
rows = list(csv.reader(open(os.path.join(d, "ballT01.csv"))))
hdr = [h.strip() for h in rows[0]]
data = [[float(v) for v in r if v.strip() != ""] for r in rows[1:] if r]


def col(name):
    for i, h in enumerate(hdr):
        if re.sub(r"\s+", " ", h) == name:
            return i
    raise KeyError(name)


t = [r[0] for r in data]
zb = [r[col("ball ZMOM")] for r in data]
mb = [r[col("ball MASS")] for r in data]
vzb = [r[col("ball VZ")] for r in data]
v = [z / m for z, m in zip(zb, mb)]
# mean over the last 5 us (the ball rings elastically once through)
last = [vv for tt, vv in zip(t, v) if tt >= t[-1] - 5.0e-6]
out = os.path.join(d, "ball_0001.out")
txt = open(out).read()
deleted = sorted(set(int(m) for m in re.findall(r"DELETE SOLID ELEMENT NUMBER\s+(\d+)", txt)))
cyc = re.findall(r"^\s+(\d+)\s+([0-9.E+-]+)\s+([0-9.E+-]+)\s+SOLID\s+\d+\s+(-?[0-9.]+)%\s+"
                 r"([0-9.E+-]+)\s+([0-9.E+-]+)\s+([0-9.E+-]+)\s+([0-9.E+-]+)", txt, re.M)
ncyc = re.search(r"TOTAL NUMBER OF CYCLES\s*:\s*(\d+)", txt)
el = re.search(r"ELAPSED TIME\s*=\s*([0-9.]+)", txt)
g = data[-1]
print(f"run {os.path.abspath(d)}")
print(f"last TH time {t[-1]:.4e} s; ball mass {mb[-1]:.6e} kg")
print(f"ball mass-weighted vz (ZMOM/MASS) at t_last: {v[-1]:.2f} m/s; part VZ {vzb[-1]:.2f} m/s")
print(f"ball vz mean over last 5 us: {sum(last) / len(last):.2f} m/s (min {min(last):.2f}, max {max(last):.2f})")
for tt in (1e-5, 1.5e-5, 2e-5, 2.5e-5):
    k = min(range(len(t)), key=lambda i: abs(t[i] - tt))
    print(f"  vz at {t[k] * 1e6:5.2f} us: {v[k]:.2f}")
print(f"deleted solid elements: {len(deleted)} (plate ids <= 2048: {sum(1 for e in deleted if e <= 2048)})")
print(f"plate ERODED (TH) at end: {g[col('plate ERODED')]:.6e}")
print("global energies at end (J): IE {:.3f} KE {:.3f} EXTWORK {:.3f} CONTACT {:.3f} HOURGLASS {:.3f} "
      "PLASTIC {:.3f}".format(g[col('INTERNAL ENERGY')], g[col('KINETIC ENERGY')], g[col('EXTERNAL WORK')],
                              g[col('CONTACT ENERGY')], g[col('HOURGLASS ENERGY')], g[col('PLASTIC WORK')]))
print(f"initial KE {data[0][col('KINETIC ENERGY')]:.3f} J")
if cyc:
    c = cyc[-1]
    print(f"last listing cycle {c[0]} t={c[1]} dt={c[2]} ENERGY ERROR {c[3]}% IE {c[4]} KE {c[5]}")
print(f"cycles {ncyc.group(1) if ncyc else '?'}; engine elapsed {el.group(1) if el else '?'} s")
