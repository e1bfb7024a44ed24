#!/bin/bash
#SBATCH --array=1-8 --cpus-per-task=2 --time=01:00:00
# A sweep as a SLURM job array, one shard per task. Run from the repository root after `make build`:
#   sbatch scripts/slurm-sweep.sh experiments/studies/robustness_map.toml
# then, when every task is done:
#   build/bin/hysid merge --out results/robustness_map results/robustness_map.shard*
# HYSID (the hysid binary, default build/bin/hysid) and HYSID_RESULTS (where the shard directories
# go, default results) can be set in the environment that sbatch passes on.
set -euo pipefail
sweep="${1:?sweep file}"; name="$(basename "$sweep" .toml)"; n="${SLURM_ARRAY_TASK_COUNT:-8}"
hysid="${HYSID:-build/bin/hysid}"; results="${HYSID_RESULTS:-results}"
"$hysid" sweep "$sweep" --threads "${SLURM_CPUS_PER_TASK:-2}" --progress none \
  --shard "${SLURM_ARRAY_TASK_ID}/${n}" --out "${results}/${name}.shard${SLURM_ARRAY_TASK_ID}"
