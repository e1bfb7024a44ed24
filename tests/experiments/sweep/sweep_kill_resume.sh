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
  rows=$(($(wc -l < "$work/killed/trials.journal" 2>/dev/null || echo 2) - 2))
  echo "killed after ${delay}s with $rows rows journaled"
done
"$hysid" sweep "$sweep" --out "$work/killed" --threads 1 --progress none
cmp "$work/full/trials.csv" "$work/killed/trials.csv"
cmp "$work/full/summary.csv" "$work/killed/summary.csv"
echo "resumed run equals the uninterrupted run"

# Two writers on one directory: the second is refused at once (exit 2) while the first holds the lock,
# and the first ends with exactly the uninterrupted rows.
"$hysid" sweep "$sweep" --out "$work/two" --threads 1 --progress none > /dev/null &
first=$!
sleep 0.2
set +e
"$hysid" sweep "$sweep" --out "$work/two" --threads 1 --progress none > /dev/null 2> "$work/second.err"
rc=$?
set -e
wait "$first"
cat "$work/second.err"
[ "$rc" -eq 2 ] || { echo "second writer: expected exit 2, got $rc"; exit 1; }
grep -q "another hysid process is running in this directory" "$work/second.err"
cmp "$work/full/trials.csv" "$work/two/trials.csv"
echo "a second writer is refused; the first run equals the uninterrupted run"
