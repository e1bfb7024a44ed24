#!/usr/bin/env bash
# Kill-and-resume: a sweep killed with SIGKILL (twice, at different moments) and started again with
# the same command must end with exactly the trials.csv and summary.csv of an uninterrupted run.
# Usage: sweep_kill_resume.sh HYSID SWEEP.toml WORK_DIR
set -euo pipefail
hysid="$1"; sweep="$2"; work="$3"
rm -rf "$work"; mkdir -p "$work"
"$hysid" sweep "$sweep" --out "$work/full" --threads 2 --progress none > /dev/null
for delay in 0.15 0.4; do
  "$hysid" sweep "$sweep" --out "$work/killed" --threads 2 --progress none > /dev/null 2>&1 &
  pid=$!
  sleep "$delay"
  kill -KILL "$pid" 2>/dev/null || true
  wait "$pid" 2>/dev/null || true
  rows=$(($(wc -l < "$work/killed/trials.journal" 2>/dev/null || echo 1) - 1))
  echo "killed after ${delay}s with $rows rows journaled"
done
"$hysid" sweep "$sweep" --out "$work/killed" --threads 1 --progress none
cmp "$work/full/trials.csv" "$work/killed/trials.csv"
cmp "$work/full/summary.csv" "$work/killed/summary.csv"
echo "resumed run equals the uninterrupted run"
