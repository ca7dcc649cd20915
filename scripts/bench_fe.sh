#!/usr/bin/env bash
# FE benchmark: ns per element-cycle (time-step loop only) and bytes per element for an
# elastic-plastic block of 103,823 hexahedra at np 1 and np 2, median of REPEATS runs each,
# with the split between element kernel, ghost exchange and nodal updates (report.json).
set -euo pipefail
cd "$(dirname "$0")/.."
REPEATS=${REPEATS:-3}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
target/release/tdyn mesh meshes/bar.geo -p L=1 -p A=1 -p N=47 -p M=47 >/dev/null
for np in 1 2; do
  for r in $(seq "$REPEATS"); do
    mpirun -np "$np" target/release/tdyn run scenes/bench_block.toml --quiet --overwrite --out "out/bench_np${np}_r${r}"
  done
  python3 - "$np" "$REPEATS" <<'PY'
import json, statistics, sys
np_, rep = sys.argv[1], int(sys.argv[2])
rs = [json.load(open(f"out/bench_np{np_}_r{r}/report.json")) for r in range(1, rep + 1)]
med = lambda k: statistics.median(x[k] for x in rs)
ns = med("ns_per_element_cycle")
print(f"np {np_}: {rs[0]['elements']} elements, {rs[0]['steps']} steps: "
      f"{ns:.1f} ns/element-cycle (median of {rep}; runs: "
      + ", ".join(f"{x['ns_per_element_cycle']:.1f}" for x in rs) + ")")
loop = med("loop_s")
for k in ("fe_element_kernel_s", "fe_ghost_exchange_s", "fe_nodal_s"):
    print(f"   {k[3:-2]:<16} {med(k):7.3f} s  ({100 * med(k) / loop:4.1f} % of the loop)")
print(f"   memory: {med('bytes_per_element'):.0f} bytes per element (nodal + element arrays)")
PY
done
