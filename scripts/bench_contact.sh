#!/usr/bin/env bash
# Contact benchmark (issue 5): the dynamic RCB contact decomposition (Fig. 10 of the paper)
# against the baseline the paper argues against (contact searched on the static FE
# decomposition, each rank's box exchanged; `tdyn run --contact-decomposition static`, for
# benchmarks only). Scenes: scenes/bricks.toml (64 bricks flying apart),
# scenes/bricks_table.toml (the bricks lifting off a finely meshed table),
# scenes/bricks_pedestal.toml (the bricks on a tall column: the baseline leaves ranks idle) and
# scenes/container_crush.toml (contact active everywhere: the paper's crushed container, its
# first CONTAINER_END = 1.2 ms unless set), at np 2 and 4,
# medians of REPEATS runs. Per run (report.json): the imbalance of the contact work (max/mean
# over ranks of nodes + faces searched, mean over steps), the nodes + faces searched by the
# busiest rank and by all ranks, bytes the stage sent per step, time per step and the contact
# stage's share of it. Counts and bytes do not depend on the machine; times do (2 cores here:
# np 4 is oversubscribed).
set -euo pipefail
cd "$(dirname "$0")/.."
REPEATS=${REPEATS:-3}
SCENES=${SCENES:-"bricks bricks_table bricks_pedestal container_crush"}
CONTAINER_END=${CONTAINER_END:-1.2e-3}
NPS=${NPS:-"2 4"}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
for scene in $SCENES; do
  for np in $NPS; do
    for mode in 0 1; do
      decomposition=rcb; [ "$mode" = 1 ] && decomposition=static
      extra=()
      if [ "$scene" = container_crush ]; then extra=(--end-time "$CONTAINER_END"); fi
      for r in $(seq "$REPEATS"); do
        mpirun -np "$np" target/release/tdyn run "scenes/$scene.toml" \
          --contact-decomposition "$decomposition" --quiet --overwrite "${extra[@]}" --out "out/bench_contact/${scene}_np${np}_b${mode}_r${r}"
      done
    done
  done
done
python3 - "$REPEATS" "$SCENES" "$NPS" <<'PY'
import json, statistics, sys
rep, scenes, nps = int(sys.argv[1]), sys.argv[2].split(), sys.argv[3].split()
print("| scene | np | decomposition | imbalance (mean, max) | busiest rank: nodes+faces | all ranks | "
      "bytes/step | ms/step | contact share | contacts | rebuilds |")
print("|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|")
for scene in scenes:
    for np_ in nps:
        for mode, name in ((0, "dynamic RCB"), (1, "static FE baseline")):
            rs = [json.load(open(f"out/bench_contact/{scene}_np{np_}_b{mode}_r{r}/report.json"))
                  for r in range(1, rep + 1)]
            med = lambda f: statistics.median(f(x) for x in rs)
            imb = med(lambda x: x["contact"]["imbalance"])
            imb_max = med(lambda x: x["contact_imbalance_max"])
            print(f"| {scene} | {np_} | {name} | {imb:.3f}, {imb_max:.3f} | "
                  f"{med(lambda x: x['contact_work_max_per_step']):.0f} | "
                  f"{med(lambda x: x['contact_work_total_per_step']):.0f} | "
                  f"{med(lambda x: x['contact_bytes_per_step']) / 1e3:.0f} kB | "
                  f"{med(lambda x: 1e3 * x['loop_s'] / x['steps']):.2f} | "
                  f"{100 * med(lambda x: x['contact_share_of_step']):.0f} % | "
                  f"{med(lambda x: x['contacts_found_total']):.0f} | "
                  + (f"{rs[0]['contact_rebuilds']} of {rs[0]['steps']} |" if mode == 0 else "static |"))
print(f"(medians of {rep} runs; {rs[0]['steps']} steps, {rs[0]['elements']} elements, "
      f"{rs[0]['contact_nodes']} contact nodes, {rs[0]['contact_faces']} faces in the last scene)")
PY
