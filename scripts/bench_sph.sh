#!/usr/bin/env bash
# SPH benchmark against LIGGGHTS (issue 4): the peer's dam break (4,000 fluid + 14,568 fixed
# wall particles, 2,000 steps) run by LIGGGHTS 3.8.0 and by us on the same data file, one after
# the other inside one `tdyn crosscheck` call, at np 1 and 2, REPEATS times; prints the medians
# of us per particle-step (loop time x ranks / (particles x steps); LIGGGHTS's from its "Loop
# time" line) and of the per-repeat ratio ours / LIGGGHTS. Then our run alone at np 2 and 4:
# pair-work imbalance (max/mean over ranks), bytes moved per step by the SPH stage (RCB
# migration, ghosts, sums back), ghosts and RCB migrations in the last step.
set -euo pipefail
cd "$(dirname "$0")/.."
REPEATS=${REPEATS:-3}
NSTEPS=${NSTEPS:-2000}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
T=target/release/tdyn
scene=out/bench_sph/dambreak.toml
mkdir -p out/bench_sph
# the scene with NSTEPS steps (end_time = NSTEPS x 5e-5 s), dumps only at the first and last
sed -e "s/^end_time = .*/end_time = $(python3 -c "print($NSTEPS * 5e-5)")/" \
    -e "s/^dump_every = .*/dump_every = $NSTEPS/" \
    -e "s#liggghts/data#$(pwd)/scenes/liggghts/data#" scenes/liggghts_dambreak.toml > "$scene"
for np in 1 2; do
  for r in $(seq "$REPEATS"); do
    $T crosscheck "$scene" --deck scenes/liggghts/in.dambreak3d --np "$np" --liggghts-np "$np" \
      --var nsteps="$NSTEPS" --var dumpevery="$NSTEPS" --out "out/bench_sph/np${np}_r${r}" \
      | grep '^cost' | sed "s/^/np $np repeat $r: /"
  done
done
for np in 2 4; do
  mpirun -np "$np" $T run "$scene" --quiet --overwrite --out "out/bench_sph/alone_np${np}"
done
python3 - "$REPEATS" <<'PY'
import json, re, statistics, sys
rep = int(sys.argv[1])
print("CPU " + json.load(open("out/bench_sph/alone_np2/report.json")).get("cpu", "unknown"))
for np_ in (1, 2):
    ours, lig = [], []
    for r in range(1, rep + 1):
        d = f"out/bench_sph/np{np_}_r{r}"
        ours.append(json.load(open(f"{d}/tdyn/report.json"))["us_per_particle_step"])
        m = re.search(r"Loop time of (\S+) on (\d+) procs for (\d+) steps with (\d+) atoms",
                      open(f"{d}/liggghts/liggghts.out").read())
        t, p, n, a = float(m[1]), int(m[2]), int(m[3]), int(m[4])
        lig.append(t * p / (n * a) * 1e6)
    ratios = [o / l for o, l in zip(ours, lig)]
    ratio = statistics.median(ratios)
    print(f"np {np_}: ours {statistics.median(ours):.3f} us/particle-step, LIGGGHTS "
          f"{statistics.median(lig):.3f}, ratio ours/LIGGGHTS {ratio:.3f} (median of {rep}; "
          f"ratios {', '.join(f'{x:.3f}' for x in ratios)}; "
          f"ours {', '.join(f'{x:.3f}' for x in ours)}; LIGGGHTS {', '.join(f'{x:.3f}' for x in lig)})")
for np_ in (2, 4):
    r = json.load(open(f"out/bench_sph/alone_np{np_}/report.json"))
    s, ex = r["sph"], r
    print(f"np {np_} alone: {r['us_per_particle_step']:.3f} us/particle-step, pair-work imbalance "
          f"{s['imbalance']:.3f}, {s['bytes_sent'] / r['steps'] / 1e3:.1f} kB moved per step "
          f"({s['bytes_sent'] / r['steps'] / r['particles']:.1f} B per particle), ghosts "
          f"{ex['sph_ghosts_last_step']}, RCB migrations {ex['rcb_migrated_last_step']} in the last step")
PY
# Solid particles against fluid ones (issue 33: a solid particle costs at most twice a fluid one
# per particle-step): scenes/rubber_blocks.toml (2,000 elastic particles, artificial stress and
# viscosity) and the same blocks as a Tait fluid of the same sound speed (no strength, the same
# viscosity), to 3 ms at np 1, REPEATS times each; medians of us per particle-step and their ratio.
fluid=out/bench_sph/fluid_blocks.toml
sed -e 's/^model = "elastic"/model = "fluid"\neos = { kind = "tait", rho0 = 1200.0, sound_speed = 133.6, gamma = 7.0 }/' \
    -e '/^youngs_modulus\|^poisson_ratio\|^artificial_stress/d' \
    -e 's/"stress_xy", //; s/, "plastic_strain"\]/]/' scenes/rubber_blocks.toml > "$fluid"
for r in $(seq "$REPEATS"); do
  for s in solid fluid; do
    src=scenes/rubber_blocks.toml
    [ "$s" = fluid ] && src=$fluid
    $T run "$src" --quiet --overwrite --end-time 3e-3 --out "out/bench_sph/blocks_${s}_r${r}"
  done
done
python3 - "$REPEATS" <<'PY'
import json, statistics, sys
rep = int(sys.argv[1])
us = {s: [json.load(open(f"out/bench_sph/blocks_{s}_r{r}/report.json"))["us_per_particle_step"]
          for r in range(1, rep + 1)] for s in ("solid", "fluid")}
m = {s: statistics.median(v) for s, v in us.items()}
print(f"blocks np 1: solid {m['solid']:.3f} us/particle-step, fluid {m['fluid']:.3f}, "
      f"ratio solid/fluid {m['solid'] / m['fluid']:.2f} (median of {rep})")
PY
