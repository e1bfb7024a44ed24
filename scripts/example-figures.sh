#!/bin/sh
# The fit figure of every example (examples/*/fit.png, its caption fit.txt): each example's README
# commands (simulate, or the shipped data), `hysid identify --json --trace` on them, then
# `hysid_plots fit` (one column wide, the first run). `make example-figures` runs it.
#
#   scripts/example-figures.sh [EXAMPLE...]     default: every example below
#
# Scratch files go to $OUT (default build/example-figures). HYSID overrides the binary (default
# build/bin/hysid). FIGURES_ONLY=1 draws again from the reports and traces already in $OUT. An example whose identify writes no report is named and skipped; the exit code
# is then 1.
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
hysid=${HYSID:-$root/build/bin/hysid}
python=/usr/bin/python3
out=${OUT:-$root/build/example-figures}
ex=$root/examples
failed=0

# identify NAME ARGS...: hysid identify ARGS with the report and trace in $out/NAME; exit 1 (a fit its
# residual tests refuse) still leaves a report to draw.
identify() {
  name=$1
  shift
  "$hysid" identify "$@" --json "$out/$name/identify.json" --trace "$out/$name/identify.csv" --progress none \
    > "$out/$name/identify.txt" 2>&1 || true
  if [ ! -s "$out/$name/identify.json" ]; then
    echo "example-figures: $name: identify wrote no report (see $out/$name/identify.txt)" >&2
    failed=1
    return 1
  fi
}

# figure NAME [RUN]: the fit figure of run RUN (default 1) into examples/NAME/fit.png and fit.txt.
figure() {
  name=$1
  run=${2:-1}
  PYTHONPATH="$root/analysis" "$python" -m hysid_plots fit "$out/$name/identify" --runs "$run" --format png \
    --dpi 150 --out "$out/$name/fig" > /dev/null
  png=$(ls "$out/$name/fig/"*.png | head -n 1)
  cp "$png" "$ex/$name/fit.png"
  sed "s|$root/||g" "${png%.png}.txt" > "$ex/$name/fit.txt"  # paths from the repository's root
  echo "wrote examples/$name/fit.png"
}

simulated() {  # simulated NAME MODEL SIMULATE-ARGS...: simulate's data, then identify
  name=$1 model=$2
  shift 2
  "$hysid" simulate --model-file "$model" "$@" --out "$out/$name/data.csv" > /dev/null
  identify "$name" --model-file "$model" --data "$out/$name/data.csv"
}

run_example() {
  name=$1
  rm -rf "${out:?}/$name"
  mkdir -p "$out/$name"
  case $name in
    cube)
      identify cube --model-file "$ex/cube/free-flight.toml" --data "$ex/cube/data/free_flight.csv" \
        --columns t=t,z,vz,run=run --sigma 3.75e-5 0.00614 ;;
    drag-ball)
      "$hysid" simulate --model-file "$ex/drag-ball/drag-ball.toml" --sigma 0.001 --seed 1 \
        --out "$out/drag-ball/ball.csv" > /dev/null
      "$python" -c "import csv,sys; r=list(csv.DictReader(open(sys.argv[1]))); w=csv.writer(open(sys.argv[2],'w',newline='')); w.writerow(['t','h']); [w.writerow([x['t'],x['h']]) for x in r]" \
        "$out/drag-ball/ball.csv" "$out/drag-ball/data.csv"
      identify drag-ball --model-file "$ex/drag-ball/drag-ball.toml" --data "$out/drag-ball/data.csv" ;;
    driven-oscillator)
      simulated "$name" "$ex/$name/driven-oscillator.toml" --sigma 1e-3 ;;
    wall) simulated wall "$ex/wall/wall.toml" --param w=1.0 --sigma 1e-3 --seed 1 ;;
    heater) simulated heater "$ex/heater/model.toml" --sigma 1e-2 --seed 1 ;;
    pump-tank) simulated pump-tank "$ex/pump-tank/model.toml" --sigma 1e-3 --seed 1 ;;
    floor-ceiling) simulated floor-ceiling "$ex/floor-ceiling/model.toml" --sigma 1e-3 --seed 1 ;;
    oscillating-table) simulated oscillating-table "$ex/oscillating-table/model.toml" --sigma 0.01,0.08,0.001 ;;
    cascaded-tanks)
      "$python" "$ex/cascaded-tanks/convert.py" "$out/cascaded-tanks" > /dev/null
      identify cascaded-tanks --model-file "$ex/cascaded-tanks/tanks.toml" \
        --data "$out/cascaded-tanks/estimation.csv" ;;
    *) echo "example-figures: no example '$name'" >&2; exit 2 ;;
  esac
}

names=${*:-cube drag-ball driven-oscillator wall heater pump-tank floor-ceiling oscillating-table cascaded-tanks}
for name in $names; do
  if [ "${FIGURES_ONLY:-0}" = 1 ] || run_example "$name"; then figure "$name"; fi
done
exit $failed
