#!/usr/bin/env bash
# Regenerates the measured figures of docs/accuracy.md: runs `tdyn sweep` on each scene with a
# `[sweep]` table at NP ranks (default 2), copies its chart to docs/sweep_SCENE.svg and writes
# its table (one row per run: the swept parameters, elements, particles, steps, loop time, model
# memory, the largest energy error, and each measure's value and error) between the lines
# `<!-- table: SCENE -->` and `<!-- end table -->` of docs/accuracy.md, the text around them
# untouched; then runs `tdyn validate` on the CASES (default taylor_copper) and writes each
# case's rows of its report between `<!-- table: validate CASE -->` and `<!-- end table -->`.
# Prints each table as it goes.
#
#   scripts/accuracy_tables.sh                        # every scene with a [sweep] table
#   SCENES="bar_wave taylor_impact" CASES=none scripts/accuracy_tables.sh
#
# Needs the release build (`cargo build --release --workspace --bins`). About 5 minutes on 2
# cores; the loop times are this machine's (say which in the text).
set -euo pipefail
cd "$(dirname "$0")/.."
NP=${NP:-2}
WORK=${WORK:-/tmp/accuracy_tables}
DOC=docs/accuracy.md
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
if [ -z "${SCENES:-}" ]; then
  SCENES=$(grep -l '^\[sweep\]' scenes/*.toml | xargs -n1 basename | sed 's/\.toml$//')
fi
CASES=${CASES:-taylor_copper}
[ "$SCENES" = none ] && SCENES=""
[ "$CASES" = none ] && CASES=""
mkdir -p "$WORK"

# Replaces the lines between `<!-- table: $1 -->` and `<!-- end table -->` of the manual with
# the file $2 (or says that the manual has no such block).
put() {
  if grep -q "^<!-- table: $1 -->\$" "$DOC"; then
    awk -v s="$1" -v f="$2" '
      $0 == "<!-- table: " s " -->" { print; while ((getline l < f) > 0) print l; skip = 1; next }
      skip && $0 == "<!-- end table -->" { skip = 0 }
      !skip { print }' "$DOC" >"$WORK/doc.md"
    cp "$WORK/doc.md" "$DOC"
  else
    echo "($DOC has no '<!-- table: $1 -->' line: table printed only)"
  fi
}

# The markdown table of a sweep's accuracy_cost.csv (docs/accuracy.md's "tdyn sweep" section
# names the columns). The CSV's quoted fields hold no commas except the message, which is last.
table() {
  awk -F, '
    function pct(x) { x = 100 * x; return (x >= 10 ? sprintf("%.0f %%", x) : x >= 1 ? sprintf("%.1f %%", x) : sprintf("%.2g %%", x)) }
    function num(x) { return (x + 0 == 0 ? "0" : sprintf("%.4g", x)) }
    function strip(s) { gsub(/"/, "", s); return s }
    NR == 1 {
      for (i = 1; i <= NF; i++) {
        col[$i] = i
        if ($i ~ /_value$/) { m = substr($i, 1, length($i) - 6); measures[++nm] = m }
      }
      head = "| run | elements | particles | steps | loop (s) | model (MB) | energy error |"
      rule = "|---|---:|---:|---:|---:|---:|---:|"
      for (k = 1; k <= nm; k++) { head = head " " measures[k] " | its error |"; rule = rule "---:|---:|" }
      print head; print rule
      next
    }
    {
      status = $(col["status"])
      row = "| " strip($(col["label"]))
      if (status != "ok") row = row " (" status ")"
      row = row " | " $(col["elements"]) " | " $(col["particles"]) " | " $(col["steps"])
      row = row " | " sprintf("%.3g", $(col["loop_s"])) " | " sprintf("%.3g", $(col["model_bytes"]) / 1e6)
      row = row " | " sprintf("%.1e", $(col["energy_error_max"])) " |"
      for (k = 1; k <= nm; k++) {
        v = $(col[measures[k] "_value"]); e = $(col[measures[k] "_error"])
        row = row " " num(v) " | " (e == "" ? "-" : e + 0 == 0 ? "reference" : pct(e)) " |"
      }
      print row
    }' "$1"
}

for s in $SCENES; do
  out="$WORK/$s"
  rm -rf "$out"
  mpirun -np "$NP" target/release/tdyn sweep "scenes/$s.toml" --out "$out" >"$WORK.$s.log" 2>&1 ||
    { echo "$s: tdyn sweep failed (see $WORK.$s.log)" >&2; exit 1; }
  cp "$out/accuracy_cost.svg" "docs/sweep_$s.svg"
  table "$out/accuracy_cost.csv" >"$WORK/$s.md"
  echo "== $s"
  cat "$WORK/$s.md"
  put "$s" "$WORK/$s.md"
done

for c in $CASES; do
  target/release/tdyn validate --cases "$c" --np "$NP" --out "$WORK/validate_$c" --quiet \
    >"$WORK.validate_$c.log" 2>&1 || true
  { grep -m1 '^| case ' "$WORK/validate_$c/report.md"
    grep -m1 '^| --- ' "$WORK/validate_$c/report.md"
    grep "^| $c |" "$WORK/validate_$c/report.md"; } >"$WORK/validate_$c.md"
  echo "== validate $c"
  cat "$WORK/validate_$c.md"
  put "validate $c" "$WORK/validate_$c.md"
done
