#!/bin/bash
# A stand-in for `rosguard platform contention [--out F]` in the validate script's tests: the
# probe's JSON as the real one writes it, with the state taken from the next line of the file
# $ROSGUARD_TEST_STATES ("RATIO MODEL_RATIO [REVERSE]": MODEL_RATIO "none" for a model that
# records no state, REVERSE the other way round's ratio, RATIO without it; the first way again
# is RATIO; a counter file beside it says which line is next; past the last line, the last line
# again), or "1.40 1.40" without it. Exit status as the real one's: 0 in the model's state
# (within 10 %), 3 otherwise.
set -euo pipefail
out=
while (($#)); do
  [[ $1 == --out ]] && { out=$2; shift; }
  shift
done
line="1.40 1.40"
if [[ -n ${ROSGUARD_TEST_STATES:-} ]]; then
  count=$ROSGUARD_TEST_STATES.count
  n=$(($(cat "$count" 2>/dev/null || echo 0) + 1))
  echo "$n" >"$count"
  total=$(wc -l <"$ROSGUARD_TEST_STATES")
  line=$(sed -n "$((n < total ? n : total))p" "$ROSGUARD_TEST_STATES")
fi
read -r ratio model reverse <<<"$line"
/usr/bin/python3 - "$ratio" "$model" "$out" "${reverse:-$ratio}" <<'PY'
import json, math, sys
ratio, model, out, reverse = float(sys.argv[1]), sys.argv[2], sys.argv[3], float(sys.argv[4])
probe = {"cores": [0, 1], "working_set_kb": 131072.0, "ratio": ratio, "ci95_pct": 2.0,
         "rounds": 7, "date": "2026-11-28T08:00:00Z"}
doc = dict(probe, model=None, matches=None, again=probe,
           reverse=dict(probe, cores=[1, 0], ratio=reverse),
           alike=abs(math.log(ratio / reverse)) <= math.log1p(0.10))
if model != "none":
    doc["model"] = dict(probe, ratio=float(model), date="2026-11-28T07:00:00Z")
    doc["matches"] = abs(math.log(ratio / float(model))) <= math.log1p(0.10)
text = json.dumps(doc, indent=2) + "\n"
if out:
    open(out, "w").write(text)
print(text, end="")
sys.exit(0 if doc["matches"] else 3)
PY
