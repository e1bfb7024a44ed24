#!/usr/bin/env bash
# scripts/slurm-sweep.sh on a real single-node SLURM started here (munged, slurmctld and slurmd on
# loopback, private ports, everything under WORK_DIR), as a 3-task job array; the merged tables must
# equal a one-process run byte for byte. Exits 77 (ctest: skipped) with the reason when SLURM is not
# installed or its daemons cannot start (not root, no munge); fails on any other difference.
# Usage: slurm_test.sh HYSID SWEEP.toml WORK_DIR REPO_ROOT
set -uo pipefail
hysid="$1"; sweep="$2"; work="$3"; repo="$4"
skip() { echo "SKIPPED: $*"; exit 77; }
for tool in munged mungekey slurmctld slurmd sbatch squeue; do
  command -v "$tool" > /dev/null || [ -x "/usr/sbin/$tool" ] || skip "$tool not installed (Debian: slurm-wlm, munge)"
done
[ "$(id -u)" -eq 0 ] || skip "needs root to start slurmd"
export PATH="$PATH:/usr/sbin"
rm -rf "$work"; mkdir -p "$work"/{spool,state,log,munge,results}
chmod 700 "$work/munge"

cleanup() {
  [ -f "$work/slurmd.pid" ] && kill "$(cat "$work/slurmd.pid")" 2> /dev/null
  [ -f "$work/slurmctld.pid" ] && kill "$(cat "$work/slurmctld.pid")" 2> /dev/null
  munged --socket="$work/munge/socket" --stop > /dev/null 2>&1
}
trap cleanup EXIT

mungekey --create --keyfile="$work/munge/key" > /dev/null 2>&1 || skip "mungekey failed"
munged --socket="$work/munge/socket" --key-file="$work/munge/key" --pid-file="$work/munge/pid" \
  --log-file="$work/log/munged.log" --seed-file="$work/munge/seed" --force 2> "$work/log/munged.err" \
  || skip "munged did not start: $(cat "$work/log/munged.err")"

port=$((20000 + RANDOM % 20000))
cpus=$(nproc)
cat > "$work/slurm.conf" <<CONF
ClusterName=hysidtest
SlurmctldHost=localhost
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$work/munge/socket
CredType=cred/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
SchedulerType=sched/builtin
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=hysid Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$work/slurm.conf"
slurmctld -f "$SLURM_CONF" 2> "$work/log/slurmctld.err" || skip "slurmctld did not start: $(cat "$work/log/slurmctld.err")"
slurmd -f "$SLURM_CONF" 2> "$work/log/slurmd.err" || skip "slurmd did not start: $(cat "$work/log/slurmd.err")"
for _ in $(seq 60); do
  sinfo -h -o %t 2> /dev/null | grep -qE '^(idle|mix|alloc)' && break
  sleep 0.5
done
sinfo -h -o %t 2> /dev/null | grep -qE '^(idle|mix|alloc)' \
  || skip "the SLURM node did not come up: $(sinfo 2>&1 | tail -1); $(tail -3 "$work/log/slurmd.log" 2> /dev/null)"

name="$(basename "$sweep" .toml)"
cd "$repo" || exit 1
# One CPU per task so all three fit a 2-core node at once or in turn; --wait returns when all are done.
HYSID="$hysid" HYSID_RESULTS="$work/results" sbatch --wait --array=1-3 --cpus-per-task=1 \
  --output="$work/log/task-%a.out" --chdir="$repo" scripts/slurm-sweep.sh "$sweep" \
  || { tail -n 20 "$work"/log/*; echo "FAILED: the job array did not succeed"; exit 1; }
"$hysid" merge --out "$work/results/merged" "$work/results/$name".shard* > /dev/null || exit 1
"$hysid" sweep "$sweep" --threads 2 --progress none --out "$work/results/one" > /dev/null || exit 1
for table in trials.csv summary.csv; do
  cmp "$work/results/one/$table" "$work/results/merged/$table" || { echo "FAILED: $table differs"; exit 1; }
done
echo "3-task SLURM job array: merged trials.csv and summary.csv identical to a one-process run"
