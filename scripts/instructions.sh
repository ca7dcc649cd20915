#!/usr/bin/env bash
# Machine-independent counts for the speed aims (docs/benchmarks.md, "Instruction counts"):
# instructions per element-cycle of the FE loop and per particle-step of solid and fluid SPH
# particles, counted by valgrind's cachegrind. Each figure is the difference of two runs of
# the same scene to two end times divided by the steps between them, so the set-up (meshing,
# reading, partitioning) drops out. valgrind hides AVX-512 from the program, so the counts are
# those of the AVX2 builds (the four-lane element kernel and nodal passes, the AVX2 pair
# loops): the paths of every CPU without AVX-512. np 1. Needs valgrind (apt-get install
# valgrind); takes about 3 minutes.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v valgrind >/dev/null || { echo "instructions.sh: valgrind is not installed (apt-get install valgrind)" >&2; exit 1; }
T=target/release/tdyn
W=out/instructions
mkdir -p "$W"
# count SCENE END NAME [ARGS...]: the run's instructions into $W/NAME.ir, its report beside
count() {
  local scene=$1 end=$2 name=$3
  shift 3
  valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file="$W/$name.cg" \
    "$T" run "$scene" --quiet --overwrite --end-time "$end" --out "$W/$name" "$@" 2>"$W/$name.log"
  grep -o 'I *refs: *[0-9,]*' "$W/$name.log" | tr -d ', ' | sed 's/Irefs://' > "$W/$name.ir"
}
fluid=$W/fluid_blocks.toml
sed -e 's/^model = "elastic"/model = "fluid"\neos = { kind = "tait", rho0 = 1200.0, sound_speed = 133.6, gamma = 7.0 }/' \
    -e '/^youngs_modulus\|^poisson_ratio\|^artificial_stress/d' \
    -e 's/"stress_xy", //; s/, "plastic_strain"\]/]/' scenes/rubber_blocks.toml > "$fluid"
count scenes/bench_block.toml 2e-5 fe_a
count scenes/bench_block.toml 6e-5 fe_b
for s in solid fluid; do
  src=scenes/rubber_blocks.toml
  [ "$s" = fluid ] && src=$fluid
  count "$src" 1e-3 "${s}_a"
  count "$src" 2e-3 "${s}_b"
done
python3 - "$W" <<'PY'
import json, sys
w = sys.argv[1]
def per(name, what):
    a, b = (json.load(open(f"{w}/{name}_{k}/report.json")) for k in "ab")
    ia, ib = (int(open(f"{w}/{name}_{k}.ir").read()) for k in "ab")
    steps = b["steps"] - a["steps"]
    return (ib - ia) / (steps * a[what]), steps, a
fe, s, r = per("fe", "elements")
print(f"FE loop ({r.get('fe_kernel')} under valgrind), bench_block, {r['elements']} elements: "
      f"{fe:,.0f} instructions per element-cycle ({s} steps counted)")
so, s1, _ = per("solid", "particles")
fl, s2, _ = per("fluid", "particles")
print(f"SPH rubber blocks: solid {so:,.0f} instructions per particle-step ({s1} steps), "
      f"fluid {fl:,.0f} ({s2} steps), ratio solid/fluid {so / fl:.2f}")
PY
