#!/usr/bin/env bash
# Scaling study of a scene (issue 7): a strong series (the same problem at every rank count)
# and a weak one (the problem grown with the rank count, at about 1,875 elements per rank as in
# the paper), then `tdyn chart-scaling`: time per step split by stage, and the figures that do
# not depend on the machine, imbalance per stage and bytes sent per rank per step.
#
#   scripts/scaling.sh SCENE [PARAM...]
#
# PARAM: NAME=VALUE as `tdyn run --param` (a gmsh parameter of the scene's mesh, K:NAME for
# [[mesh]] K, particles.spacing=...), applied to every strong run. Environment:
#   NPS          rank counts (default "1 2 4 8"; beyond the cores they are oversubscribed: their
#                times say nothing about speed, their imbalance and bytes still do)
#   WEAK_SCENE   scene of the weak series (default scenes/bench_block.toml); WEAK=0 skips it
#   WEAK_PARAMS  its parameters as awk expressions of np (default "A=1 M=25 N=3*np L=0.12*np":
#                a 3np x 25 x 25 block of 4 cm cubes, 1,875 x np elements at a constant step)
#   END_TIME     run.end_time of every run, s (default: the scenes'); the figures are per step,
#                so a shorter run gives them at less cost
#   OUT          output directory (default out/scaling/<scene name>)
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -lt 1 ]; then
  echo "usage: scripts/scaling.sh SCENE [NAME=VALUE...]" >&2
  exit 2
fi
SCENE=$1
shift
NPS=${NPS:-1 2 4 8}
WEAK=${WEAK:-1}
WEAK_SCENE=${WEAK_SCENE:-scenes/bench_block.toml}
WEAK_PARAMS=${WEAK_PARAMS:-A=1 M=25 N=3*np L=0.12*np}
name=$(basename "$SCENE" .toml)
OUT=${OUT:-out/scaling/$name}
TDYN=${TDYN:-target/release/tdyn}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
mkdir -p "$OUT"
rm -rf "$OUT"/strong_np* "$OUT"/weak_np*

common=()
if [ -n "${END_TIME:-}" ]; then common+=(--end-time "$END_TIME"); fi
strong=("${common[@]}")
for p in "$@"; do strong+=(--param "$p"); done
for np in $NPS; do
  echo "strong np $np: $SCENE $*"
  mpirun -np "$np" "$TDYN" run "$SCENE" "${strong[@]}" --quiet --out "$OUT/strong_np$np"
done

if [ "$WEAK" != 0 ]; then
  for np in $NPS; do
    weak=("${common[@]}")
    shown=""
    for p in $WEAK_PARAMS; do
      v=$(awk -v np="$np" "BEGIN { printf \"%.10g\", ${p#*=} }")
      weak+=(--param "${p%%=*}=$v")
      shown="$shown ${p%%=*}=$v"
    done
    echo "weak np $np: $WEAK_SCENE$shown"
    mpirun -np "$np" "$TDYN" run "$WEAK_SCENE" "${weak[@]}" --quiet --out "$OUT/weak_np$np"
  done
fi

weak_name=$(basename "$WEAK_SCENE" .toml)
"$TDYN" chart-scaling "$OUT" --title "scaling: $name${*:+ ($*)}, strong; $weak_name, weak ($(nproc) cores here)"
