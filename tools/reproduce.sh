#!/usr/bin/env bash
# make reproduce: every scenario of scenarios/paper/ on the sim backend into
# results/paper/<experiment>/, plotted; then the README's gallery (docs/figures/) and its
# "paper vs sim" table regenerated from those results (tools/paper_table.py).
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
/usr/bin/python3 tools/paper_table.py results/paper --gallery docs/figures --readme README.md
echo "reproduced in $(($(date +%s) - start)) s"
