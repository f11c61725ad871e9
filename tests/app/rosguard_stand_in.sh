#!/bin/bash
# Writes FILE: a stand-in rosguard for the validate script's tests. `platform model` says the
# installed model is of this machine (exit 0); `platform contention` answers as
# contention_stand_in.sh does; `calibrate` refuses to run (CALIBRATED empty: no test of this kind
# may calibrate) or only touches the file CALIBRATED; `run --backend hw` runs sim (no hw, no
# second CPU here); everything else is the real rosguard REAL.
# Usage: rosguard_stand_in.sh REAL SOURCE_DIR FILE [CALIBRATED]
set -euo pipefail
real=$1 src=$2 file=$3 calibrated=${4:-}
if [[ -n $calibrated ]]; then
  calibrate="echo \"stand-in: rosguard \$*\"; touch '$calibrated'; exit 0"
else
  calibrate='echo "stand-in: calibrate must not run in this test" >&2; exit 1'
fi
cat >"$file" <<EOF
#!/bin/bash
if [[ \$1 == platform && \${2:-} == model ]]; then echo "stand-in: a model of this machine"; exit 0; fi
if [[ \$1 == platform && \${2:-} == contention ]]; then exec "$src/tests/app/contention_stand_in.sh" "\$@"; fi
if [[ \$1 == calibrate ]]; then $calibrate; fi
args=()
prev=
for a in "\$@"; do
  [[ \$prev == --backend && \$a == hw ]] && a=sim
  args+=("\$a")
  prev=\$a
done
exec "$real" "\${args[@]}"
EOF
chmod +x "$file"
