#!/usr/bin/env bash
# FE benchmark: ns per element-cycle (time-step loop only) and bytes per element for an
# elastic-plastic block of 103,823 hexahedra at np 1 and np 2, median of REPEATS runs each,
# with the split between element kernel, ghost exchange and nodal updates (report.json). Then
# (TETS=1, the default) the same block meshed by gmsh's default tetrahedra of about the same node
# count (scenes/bench_block_tet.toml): ns per tetrahedron-cycle and per hexahedron-cycle of its
# split (4 hexahedra per tetrahedron), the runs interleaved with the hexahedral block's (hex,
# tet, hex, tet, ...) so that the ratio of each pair holds when the machine's speed drifts;
# and the same tetrahedra run natively (scenes/bench_block_tet_nodal.toml, `[run] tetrahedra =
# "nodal_pressure"`): ns per tetrahedron-cycle of the native element, its stable step against
# the split's, and the cost per simulated microsecond of both.
# On a CPU with AVX-512F the hexahedral block runs also with `--kernel lanes4` (the AVX2 path
# every CPU without AVX-512 takes), its runs interleaved with the eight lanes' (LANES4=0 leaves
# it out), so both paths' figures come from one run.
# NPS (default "1 2") lists the rank counts. One run on tetrahedra takes minutes: its set-up
# (the split, PETSc's partition and distribution of 2.5 million cells) about 3 on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
REPEATS=${REPEATS:-3}
TETS=${TETS:-1}
NPS=${NPS:-1 2}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
target/release/tdyn mesh meshes/bar.geo -p L=1 -p A=1 -p N=47 -p M=47 >/dev/null
kinds="hex"
if [ "${LANES4:-1}" = 1 ] && grep -qw avx512f /proc/cpuinfo 2>/dev/null; then
  kinds="hex hex4"
fi
if [ "$TETS" = 1 ]; then
  target/release/tdyn mesh meshes/block_tet.geo -p L=1 -p A=1 -p H=0.0195 >/dev/null
  kinds="$kinds tet tetn"
fi
for np in $NPS; do
  for r in $(seq "$REPEATS"); do
    for kind in $kinds; do
      scene=scenes/bench_block.toml
      kernel=auto
      [ "$kind" = hex4 ] && kernel=lanes4
      [ "$kind" = tet ] && scene=scenes/bench_block_tet.toml
      [ "$kind" = tetn ] && scene=scenes/bench_block_tet_nodal.toml
      mpirun -np "$np" target/release/tdyn run "$scene" --kernel "$kernel" --quiet --overwrite \
        --out "out/bench_${kind}_np${np}_r${r}"
    done
  done
  python3 - "$np" "$REPEATS" $kinds <<'PY'
import json, statistics, sys
np_, rep, kinds = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
runs = {k: [json.load(open(f"out/bench_{k}_np{np_}_r{r}/report.json")) for r in range(1, rep + 1)]
        for k in kinds}
for kind, rs in runs.items():
    med = lambda k: statistics.median(x[k] for x in rs)
    ns = med("ns_per_element_cycle")
    print(f"{kind} np {np_}: {rs[0]['elements']} elements, {rs[0]['nodes']} nodes, {rs[0]['steps']} steps: "
          f"{ns:.1f} ns/element-cycle (median of {rep}; runs: "
          + ", ".join(f"{x['ns_per_element_cycle']:.1f}" for x in rs) + ")")
    print(f"   CPU {rs[0].get('cpu', 'unknown')}, element kernel {rs[0].get('fe_kernel', 'unknown')}")
    tets = (rs[0].get("mesh_split") or {}).get("tetrahedra", 0)
    if tets:
        per = rs[0]["elements"] / tets
        print(f"   {tets} tetrahedra run as {rs[0]['elements']} hexahedra: "
              f"{ns * per:.1f} ns per tetrahedron-cycle ({ns:.1f} per hexahedron-cycle of the split)")
    loop = med("loop_s")
    for k in ("fe_element_kernel_s", "fe_ghost_exchange_s", "fe_nodal_s"):
        print(f"   {k[3:-2]:<16} {med(k):7.3f} s  ({100 * med(k) / loop:4.1f} % of the loop)")
    print(f"   memory: {med('bytes_per_element'):.0f} bytes per element (nodal + element arrays)")
if "hex4" in runs:
    ratio = [f["ns_per_element_cycle"] / h["ns_per_element_cycle"] for h, f in zip(runs["hex"], runs["hex4"])]
    print(f"np {np_}: four lanes (AVX2) / eight lanes (AVX-512F), pair by pair: median "
          f"{statistics.median(ratio):.3f} (" + ", ".join(f"{x:.3f}" for x in ratio) + ")")
if "tet" in runs:
    ratio = [t["ns_per_element_cycle"] / h["ns_per_element_cycle"] for h, t in zip(runs["hex"], runs["tet"])]
    print(f"np {np_}: split hexahedron-cycle / hexahedron-cycle, pair by pair: median "
          f"{statistics.median(ratio):.3f} (" + ", ".join(f"{x:.3f}" for x in ratio) + ")")
if "tetn" in runs:
    # CPU seconds per simulated microsecond: elements x steps x ns per element-cycle over the
    # 10 us both tetrahedral bench scenes run.
    def per_us(x):
        return x["elements"] * x["steps"] * x["ns_per_element_cycle"] * 1e-9 / 10.0
    tets = (runs["tet"][0].get("mesh_split") or {}).get("tetrahedra", 0)
    n = runs["tetn"][0]["elements"]
    print(f"np {np_}: {n} native tetrahedra, {tets} split: CPU seconds per simulated microsecond "
          f"native {statistics.median(per_us(x) for x in runs['tetn']):.3f}, split "
          f"{statistics.median(per_us(x) for x in runs['tet']):.3f}")
PY
done
