#!/usr/bin/env bash
# Installs the build into a temporary prefix and checks what a user gets there:
# - the layout: bin/rosguard, share/rosguard/{scenarios,analysis}, include/rosguard/..., the
#   CMake package;
# - the installed rosguard reads its data from <prefix>/share/rosguard (not from the source
#   tree), prints its baked-in version, and (when the sim backend is built) runs and plots the
#   quickstart from there;
# - a consumer project (tests/install/consumer) finds the package, links rosguard::model only,
#   and prints the expected commands; every installed header compiles where it is included
#   from (<rosguard/...>).
# Usage: install_test.sh CMAKE BUILD_DIR CONSUMER_DIR CXX [LAUNCHER]
set -euo pipefail
cmake=$1 build=$2 consumer=$3 cxx=$4 launcher=${5:-}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
unset ROSGUARD_HOME
prefix=$tmp/prefix
fail() { echo "FAIL: $*"; exit 1; }

"$cmake" --install "$build" --prefix "$prefix" >"$tmp/install.log" ||
  { cat "$tmp/install.log"; fail "cmake --install"; }
for f in bin/rosguard share/rosguard/scenarios/quickstart.json \
         share/rosguard/scenarios/schema/scenario.schema.json \
         share/rosguard/scenarios/platforms/orin-agx.json \
         share/rosguard/scenarios/workloads/mser.json share/rosguard/analysis/__main__.py \
         include/rosguard/regulator/regulator.h include/rosguard/core/types.h; do
  [[ -e "$prefix/$f" ]] || fail "$f is not installed"
done
config=$(find "$prefix" -name rosguard-config.cmake)
[[ -n "$config" && -e "$(dirname "$config")/rosguard-config-version.cmake" ]] ||
  fail "no CMake package config (rosguard-config.cmake + version file) installed"
if find "$prefix/share/rosguard" -name __pycache__ | grep -q .; then fail "__pycache__ installed"; fi

cd "$tmp"  # nowhere near the source tree
rosguard=$prefix/bin/rosguard
version=$("$rosguard" --version)
echo "$version"
grep -qE '^rosguard [0-9]+\.[0-9]+\.[0-9]+$' <<<"$version" || fail "--version: no version line"
grep -qE '^git revision: ([0-9a-f]{12}(-dirty)?|unknown)$' <<<"$version" ||
  fail "--version: no git revision line"
grep -qE '^build type: ' <<<"$version" || fail "--version: no build type line"

# The man page (from --help) and bash completion.
page=$prefix/share/man/man1/rosguard.1
[[ -s $page ]] || fail "share/man/man1/rosguard.1 is not installed"
grep -q '^\.SH NAME' "$page" && grep -q 'rosguard run' "$page" || fail "rosguard.1 lacks its sections"
if command -v man >/dev/null; then
  MANPATH=$prefix/share/man man rosguard 2>&1 | grep -q 'rosguard calibrate' ||
    fail "man rosguard does not show the page"
fi
completion=$prefix/share/bash-completion/completions/rosguard
[[ -s $completion ]] || fail "bash completion is not installed"
bash -c "source '$completion' && complete -p rosguard" | grep -q _rosguard ||
  fail "the completion does not register for rosguard"

# A platform that exists only in the installed data: the binary must list it.
cp "$prefix/share/rosguard/scenarios/platforms/orin-agx.json" \
   "$prefix/share/rosguard/scenarios/platforms/only-in-the-install.json"
"$rosguard" list platforms | grep -q only-in-the-install ||
  fail "the installed rosguard does not read <prefix>/share/rosguard"

if grep -qE '^backends: .*\bsim\b' <<<"$version"; then
  "$rosguard" run "$prefix/share/rosguard/scenarios/quickstart.json" --out "$tmp/q" --quiet ||
    fail "run of the installed quickstart"
  rows=$(($(wc -l <"$tmp/q/points.csv") - 1))
  echo "quickstart from the install: $rows rows"
  ((rows == 36)) || fail "expected 36 quickstart rows, got $rows"
  MPLBACKEND=Agg "$rosguard" plot "$tmp/q" >"$tmp/plot.log" 2>&1 ||
    { cat "$tmp/plot.log"; fail "plot with the installed analysis/"; }
  ls "$tmp/q/figures/"*.png >/dev/null || fail "plot drew no PNG"
fi

"$cmake" -S "$consumer" -B "$tmp/consumer" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_CXX_COMPILER="$cxx" ${launcher:+-DCMAKE_CXX_COMPILER_LAUNCHER="$launcher"} \
  >"$tmp/configure.log" 2>&1 || { cat "$tmp/configure.log"; fail "consumer configure"; }
grep -E "rosguard( |::)" "$tmp/configure.log"
"$cmake" --build "$tmp/consumer" >"$tmp/build.log" 2>&1 ||
  { cat "$tmp/build.log"; fail "consumer build"; }
"$tmp/consumer/consumer" >"$tmp/consumer.out" || fail "consumer exited $?"
diff -u "$consumer/expected.txt" "$tmp/consumer.out" || fail "consumer output differs"
echo "consumer linked rosguard::model from $prefix and printed the expected commands"
