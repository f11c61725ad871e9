#!/usr/bin/env bash
# Writes the man page of rosguard from its own --help (help2man, Debian package help2man): the
# top-level help, then one section per command from `rosguard COMMAND --help`, so the page
# cannot drift from the program. Usage: make_man.sh ROSGUARD OUT.1
set -euo pipefail
rosguard=$1
out=$2
include=$(mktemp)
trap 'rm -f "$include"' EXIT
{
  echo "[COMMANDS]"
  for cmd in run tune check plot compare list calibrate platform profile; do
    echo ".SS \"rosguard $cmd\""
    echo ".nf"
    # roff: a leading dot or quote would be a request; backslashes are escapes.
    "$rosguard" "$cmd" --help | sed -e 's/\\/\\e/g' -e "s/^\([.']\)/\\\\\&\1/"
    echo ".fi"
  done
  echo "[FILES]"
  echo "Results folders hold manifest.json, points.csv, samples.csv, columns.json,"
  echo "baselines.json and, with --trace, trace.json; the column meanings: rosguard list columns."
  echo "The installed data (schemas, platforms, workloads, scenarios, analysis) is in"
  echo "share/rosguard next to bin/; ROSGUARD_HOME points at another copy."
}  > "$include"
help2man --no-info --name="simulate, run and analyse memory-bandwidth regulation (ROSGuard)" \
  --include="$include" --output="$out" "$rosguard"
