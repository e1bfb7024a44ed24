#!/usr/bin/env bash
# The main job on its built-in default (called by `make run` after the build): the reduced default
# study experiments/studies/default.toml into results/default/ (replacing an earlier one), then its figures
# (PNG and PDF, each with a caption .txt) into results/default/figures/ and its table into
# results/default/table.md.
set -euo pipefail
build_dir="${1:-build}"
cd "$(dirname "$0")/.."
hysid="$build_dir/bin/hysid"
out=results/default
rm -rf "$out"
"$hysid" sweep experiments/studies/default.toml --out "$out"
/usr/bin/python3 analysis/hysid_plots all "$out" --format png,pdf
/usr/bin/python3 analysis/hysid_plots table "$out" --format md --out "$out/table.md"
echo "default study done: $out/summary.csv, $out/table.md, $out/figures/*.{png,pdf}"
