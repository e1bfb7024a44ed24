#!/usr/bin/env bash
# The main job on its built-in default (called by `make run` after the build).
# Simulates the paper's §5 impact mass-spring-damper with its default values and writes the
# trajectory and the jumps under results/default/.
set -euo pipefail
build_dir="${1:-build}"
cd "$(dirname "$0")/.."
hysid="$build_dir/experiments/hysid"
out=results/default
mkdir -p "$out"
"$hysid" simulate --model impact-msd --out "$out/paper_traj.csv" --jumps-out "$out/paper_jumps.csv"
