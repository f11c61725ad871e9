#!/usr/bin/env bash
# make reproduce: every scenario of scenarios/paper/ on the sim backend into
# results/paper/<experiment>/, plotted; then the "paper vs sim" table and the gallery of
# docs/paper-vs-sim.md (figures in docs/figures/) regenerated from them (tools/paper_table.py).
# Usage: tools/reproduce.sh [ROSGUARD]   (from anywhere; default build/rosguard)
set -euo pipefail
cd "$(dirname "$0")/.."
rosguard=${1:-build/rosguard}
start=$(date +%s)
for scenario in scenarios/paper/*.json; do
  name=$(basename "$scenario" .json)
  out=results/paper/$name
  printf '%-24s' "$name"
  "$rosguard" run "$scenario" --out "$out" --overwrite --quiet
  "$rosguard" plot "$out" > "$out/plot.log"
  echo "$(grep -c '\.png' "$out/plot.log") figure(s) in $out/figures/"
done
/usr/bin/python3 tools/paper_table.py results/paper --gallery docs/figures --doc docs/paper-vs-sim.md
echo "reproduced in $(($(date +%s) - start)) s"
