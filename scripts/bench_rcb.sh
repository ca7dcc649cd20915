#!/usr/bin/env bash
# Our parallel RCB (coupling::rcb) against Zoltan's RCB on the same points in the same run:
# 1e5 and 1e6 points, uniform and clustered, at np 1, 2, 4; first partition from an id % P
# distribution, then a rebalance after a 1 %-of-spacing displacement. Builds the example
# `rcb_vs_zoltan` (feature `zoltan`, needs libtrilinos-zoltan-dev), prints one markdown table
# and writes bench_rcb.csv in the current directory. Per-repeat times go to stderr.
#
# Environment: NPS ("1 2 4"), SIZES ("100000:15,1000000:7": points:repeats),
# DISTS ("uniform,clustered"), ZOLTAN_ARGS (extra example arguments, e.g. "--tol 1.1"),
# CARGO_TARGET_DIR (default /work/target-zoltan).
set -euo pipefail
CSV="$PWD/bench_rcb.csv"
cd "$(dirname "$0")/.."
NPS=${NPS:-"1 2 4"}
SIZES=${SIZES:-"100000:15,1000000:7"}
DISTS=${DISTS:-"uniform,clustered"}
ZOLTAN_ARGS=${ZOLTAN_ARGS:-}
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-/work/target-zoltan}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1

cargo build --release -q -p coupling --features zoltan --example rcb_vs_zoltan
BIN="$CARGO_TARGET_DIR/release/examples/rcb_vs_zoltan"

echo "np,n,dist,call,repeats,ours_ms,zoltan_part_ms,zoltan_move_ms,zoltan_total_ms,ratio_ours_zoltan_total,ratio_ours_zoltan_part,imbalance_ours,imbalance_zoltan,migrated_ours,migrated_zoltan,ours_iterations,checks" >"$CSV"
start=$(date +%s)
for np in $NPS; do
  echo "== np $np" >&2
  # shellcheck disable=SC2086
  mpirun -np "$np" "$BIN" --sizes "$SIZES" --dists "$DISTS" --csv "$CSV" $ZOLTAN_ARGS >/dev/null
done
echo "total $(($(date +%s) - start)) s" >&2

awk -F, 'NR == 1 {
  print "| np | N | points | call | ours ms | Zoltan partition ms | Zoltan move ms | Zoltan part+move ms | ours / Zoltan(part+move) | ours / Zoltan(part) | imbalance ours | imbalance Zoltan | migrated ours | migrated Zoltan | ours median-search iterations | checks |"
  print "|---:|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"
  next
}
{
  printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n",
    $1, $2, $3, $4, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17
}' "$CSV"
echo
echo "Times: max over ranks, median of the repeats (column repeats in bench_rcb.csv); ratios: median of the per-repeat ratios (both codes run alternately in each repeat)."
