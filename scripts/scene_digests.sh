#!/usr/bin/env bash
# One answer, checked on every bundled scene: runs each scene of scenes/ for FRACTION of its
# end_time (default 0.1) on NP ranks (default 1) with `--kernel KERNEL` (default auto) and prints
# one line per scene, "SCENE DIGEST", the digest being `run_digest` (tests/src/lib.rs): FNV-1a
# over history.csv without the run's own measurements, probes.csv, reactions.csv,
# contact_forces.csv and every frame of fields.h5 in id order.
#
#   scripts/scene_digests.sh > /tmp/np1.txt
#   NP=3 KERNEL=scalar scripts/scene_digests.sh > /tmp/np3.txt
#   diff /tmp/np1.txt /tmp/np3.txt        # no output: the same bits (docs/running.md)
#
# The same files on two rank counts, two kernels, two CPUs or before and after a change that
# must not change results say that the results are the same bits. SCENES (space-separated names
# without .toml) chooses the scenes; by default every scene but the long tetrahedral and
# benchmark ones (bench_block_tet, bench_block_tet_nodal, taylor_copper_tets, cantilever_tets).
# Needs the release
# build (`cargo build --release --workspace --bins`). A run that fails prints "SCENE failed".
set -euo pipefail
cd "$(dirname "$0")/.."
NP=${NP:-1}
KERNEL=${KERNEL:-auto}
FRACTION=${FRACTION:-0.1}
WORK=${WORK:-/tmp/scene_digests}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
if [ -z "${SCENES:-}" ]; then
  SCENES=$(ls scenes/*.toml | xargs -n1 basename | sed 's/\.toml$//' |
    grep -vx -e bench_block_tet -e bench_block_tet_nodal -e taylor_copper_tets -e cantilever_tets)
fi
for s in $SCENES; do
  end=$(grep -m1 -E '^end_time *=' "scenes/$s.toml" | sed -E 's/^end_time *= *([^ #]+).*/\1/')
  short=$(awk -v e="$end" -v f="$FRACTION" 'BEGIN { printf "%.17g", e * f }')
  out="$WORK/np${NP}_${KERNEL}/$s"
  mkdir -p "$(dirname "$out")"
  if mpirun -np "$NP" target/release/tdyn run "scenes/$s.toml" --kernel "$KERNEL" \
      --end-time "$short" --quiet --overwrite --out "$out" >"$out.log" 2>&1; then
    echo "$s $(target/release/run_digest "$out")"
  else
    echo "$s failed"
  fi
done
