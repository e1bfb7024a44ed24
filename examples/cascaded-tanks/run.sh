#!/bin/sh
# The Cascaded Tanks benchmark with hysid: fit tanks.toml on the estimation record, then simulate the
# fitted model on the test input from the initial state fitted on the estimation record (the
# benchmark's protocol: the unknown initial state is the same for both records).
#
#   examples/cascaded-tanks/run.sh OUTDIR                 identify, then simulate its estimate
#   examples/cascaded-tanks/run.sh OUTDIR --params FILE   simulate FILE's parameters (NAME=VALUE
#                                                         lines and x0=H1,Y, as written by
#                                                         scipy_reference.py --hysid-params)
# Writes OUTDIR/estimation.csv, validation.csv, validation_input.csv (convert.py), identify.txt and
# identify.json, params.txt, simulate.csv (+ .json, jumps.csv) and test_simulation.csv (t,y, 1024
# rows), and prints the test RMSE. HYSID overrides the binary (default: build/bin/hysid).
# Exit: 0 done; 2 usage; otherwise identify's or simulate's exit code when it wrote no estimate.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
hysid=${HYSID:-$root/build/bin/hysid}
python=/usr/bin/python3

if [ $# -ne 1 ] && { [ $# -ne 3 ] || [ "$2" != --params ]; }; then
  echo "usage: run.sh OUTDIR [--params FILE]" >&2
  exit 2
fi
out=$1
mkdir -p "$out"
"$python" "$here/convert.py" "$out"

if [ $# -eq 3 ]; then
  cp "$3" "$out/params.txt"
else
  echo "hysid identify (estimation record) ..."
  rc=0
  "$hysid" identify --model-file "$here/tanks.toml" --data "$out/estimation.csv" \
    --json "$out/identify.json" > "$out/identify.txt" 2>&1 || rc=$?
  cat "$out/identify.txt"
  if [ ! -s "$out/identify.json" ]; then
    echo "run.sh: hysid identify exited $rc without an estimate: no test simulation" >&2
    exit "$rc"
  fi
  "$python" "$here/hysid_io.py" params "$out/identify.json" "$out/params.txt"
fi

set --
while IFS= read -r line; do
  case $line in
    x0=*) x0=${line#x0=} ;;
    ?*) set -- "$@" --param "$line" ;;
  esac
done < "$out/params.txt"
echo "hysid simulate (test input) ..."
"$hysid" simulate --model-file "$here/tanks.toml" "$@" --x0 "$x0" \
  --inputs "$out/validation_input.csv" --t-end 4092 --dt 4 \
  --out "$out/simulate.csv" --jumps-out "$out/jumps.csv"
"$python" "$here/hysid_io.py" test-simulation "$out/simulate.csv" "$out/test_simulation.csv"
"$python" "$here/hysid_io.py" rmse "$out/test_simulation.csv" "$out/validation.csv"
