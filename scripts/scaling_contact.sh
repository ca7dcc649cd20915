#!/usr/bin/env bash
# Weak scaling of the contact stage (issue 15): scenes/cloud_on_plate.toml grown along x with the
# rank count, the same contacts per rank at every P: a 0.1 P x 0.1 m plate of 10 P x 10 x 2
# hexahedra (`meshes/plate.geo` LX, NX) under a water cloud 0.1 P - 0.01 m long (about 1,700
# particles per rank), falling at 10 m/s; the runs stop at END_TIME, after about 200 steps of
# contact. Then `tdyn chart-scaling`: bytes per rank per step by stage (the push-back among
# them), imbalance, and time per step (oversubscribed beyond the cores: the times say nothing
# about speed there, the counts still do). The push-back's own counts per run are in
# scaling.csv (pushback_*) and in each run's report.json (`contact_pushback_*`).
#
#   scripts/scaling_contact.sh
#
# Environment: NPS (default "1 2 4 8 16 32"), END_TIME (default 2.5e-4 s), OUT (default
# out/scaling/contact_weak).
set -euo pipefail
cd "$(dirname "$0")/.."
NPS=${NPS:-1 2 4 8 16 32}
END_TIME=${END_TIME:-2.5e-4}
OUT=${OUT:-out/scaling/contact_weak}
TDYN=${TDYN:-target/release/tdyn}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
mkdir -p "$OUT"
rm -rf "$OUT"/weak_np*
for np in $NPS; do
  lx=$(awk -v p="$np" 'BEGIN { printf "%.6g", 0.1 * p }')
  x1=$(awk -v p="$np" 'BEGIN { printf "%.6g", 0.05 * p - 0.005 }')
  scene="$OUT/weak_np$np.toml"
  sed -e "s|file = \"../meshes/plate.geo\"|file = \"$PWD/meshes/plate.geo\"|" \
      -e "s|params = { L = 0.1, T = 0.01, N = 10, M = 2 }|params = { L = 0.1, LX = $lx, NX = $((10 * np)), T = 0.01, N = 10, M = 2 }|" \
      -e "s|min = \[-0.03, -0.03, 0.0005\], max = \[0.03, 0.03, 0.0305\]|min = [-$x1, -0.03, 0.0005], max = [$x1, 0.03, 0.0305]|" \
      scenes/cloud_on_plate.toml > "$scene"
  grep -q "LX = $lx" "$scene" && grep -q "max = \[$x1," "$scene" || {
    echo "scripts/scaling_contact.sh: scenes/cloud_on_plate.toml changed: the plate or cloud line was not found" >&2
    exit 1
  }
  echo "weak np $np: plate $lx m long, cloud to x = +-$x1 m"
  mpirun -np "$np" "$TDYN" run "$scene" --end-time "$END_TIME" --quiet --out "$OUT/weak_np$np"
done
"$TDYN" chart-scaling "$OUT"
