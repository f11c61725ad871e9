#!/usr/bin/env bash
# The installed tree is complete (issue 53, item 5): cmake --install into a temporary prefix, then
# - what the docs and the help texts use is installed under share/rosguard/: README.md and docs/
#   (the guard's example configuration, whose "$schema" resolves there, and its systemd unit,
#   whose ExecStart names the installed rosguard), the READMEs the docs link to, and the ROS 2
#   interface package rosguard_msgs;
# - every example of `rosguard --help` and of each subcommand's --help (nested ones too) runs
#   from a folder outside the source tree that holds nothing (as from `cd /`, without writing
#   results/ into /), in the order the help texts give them, and exits 0. The examples are the
#   help lines that start with `rosguard ` (the text up to the first run of two spaces, where
#   the description starts), read from the help texts: a new example is covered without a
#   change here. One that runs until SIGINT / SIGTERM (the guard on /etc/rosguard/guard.json,
#   this machine's own configuration) is listed as not run.
# Usage: help_examples_test.sh CMAKE BUILD_DIR
set -euo pipefail
cmake=$1 build=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
unset ROSGUARD_HOME
prefix=$tmp/prefix
fail() { echo "FAIL: $*"; exit 1; }

"$cmake" --install "$build" --prefix "$prefix" >"$tmp/install.log" ||
  { cat "$tmp/install.log"; fail "cmake --install"; }
data=$prefix/share/rosguard
for f in README.md docs/guard.md docs/running.md docs/scenario-reference.md \
         docs/guard/example.json docs/guard/rosguard-guard.service \
         docs/guard/security/make_certs.sh sim/README.md hw/README.md \
         rosguard_msgs/package.xml rosguard_msgs/CMakeLists.txt \
         rosguard_msgs/msg/PmcSample.msg rosguard_msgs/msg/Command.msg analysis/goals.json; do
  [[ -s "$data/$f" ]] || fail "share/rosguard/$f is not installed"
done
[[ -x "$data/docs/guard/security/make_certs.sh" ]] || fail "docs' scripts lost their x bit"
schema=$(/usr/bin/python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["$schema"])' \
  "$data/docs/guard/example.json")
[[ -s "$data/docs/guard/$schema" ]] || fail "the guard example's \$schema $schema does not resolve"
grep -qx "ExecStart=$prefix/bin/rosguard guard /etc/rosguard/guard.json" \
  "$data/docs/guard/rosguard-guard.service" ||
  fail "the installed unit does not run the installed rosguard: $(grep ExecStart= \
    "$data/docs/guard/rosguard-guard.service")"
echo "installed: README.md, docs/ (guard example and unit), sim/ hw/ READMEs, rosguard_msgs"

export PATH=$prefix/bin:$PATH MPLBACKEND=Agg
work=$tmp/work  # nothing here: no scenarios/, no docs/, not the source tree
mkdir "$work"
cd "$work"

# The help texts: the top level's, then each subcommand's and each nested one's.
helps=("")
subcommands() {  # the names under "Subcommands:" in the help of `rosguard $1`
  # shellcheck disable=SC2086
  rosguard $1 --help | awk '/^Subcommands:/ {s = 1; next} s && /^  [a-z]/ {print $1} s && /^$/ {s = 0}'
}
for sub in $(subcommands ""); do
  helps+=("$sub")
  for nested in $(subcommands "$sub"); do helps+=("$sub $nested"); done
done
((${#helps[@]} > 10)) || fail "only ${#helps[@]} help texts found: ${helps[*]}"

examples=() seen=""
for h in "${helps[@]}"; do
  # shellcheck disable=SC2086
  while IFS= read -r line; do
    example=$(sed -E 's/^ +//; s/  .*$//' <<<"$line")
    grep -qxF "$example" <<<"$seen" && continue
    seen+="$example"$'\n'
    if [[ $line == *"until SIGINT"* ]]; then  # its description says so
      echo "not run (runs until SIGINT / SIGTERM): $example   [rosguard $h --help]"
      continue
    fi
    examples+=("$example")
  done < <(rosguard $h --help | grep -E '^ +rosguard ' || true)
done
((${#examples[@]} >= 5)) || fail "only ${#examples[@]} examples found"

for example in "${examples[@]}"; do
  start=$(date +%s%N)
  if ! timeout 600 bash -c "$example" >"$tmp/out" 2>&1; then
    cat "$tmp/out"
    fail "from a folder with nothing in it, '$example' failed"
  fi
  echo "ran ($((($(date +%s%N) - start) / 1000000)) ms): $example"
  # A relative scenario or configuration is read from the installed data, saying so.
  if grep -q '^note: .* is not in this folder' "$tmp/out"; then
    grep -q "reading rosguard's own: $data/" "$tmp/out" ||
      { cat "$tmp/out"; fail "'$example' read its file from elsewhere than $data"; }
  fi
done
echo "${#examples[@]} help examples ran from $work with the installed rosguard only"
