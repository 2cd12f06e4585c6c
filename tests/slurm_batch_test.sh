#!/bin/bash
# A real single-node Slurm on this machine: munged, slurmctld and slurmd with a config written into a
# temporary folder, the shipped scripts/raycloth_batch.sbatch submitted as an 8-task job array over
# tests/data/batch/slurm.json, and its results compared with a local `raycloth batch` of the same sweep
# (the deterministic columns of results.jsonl, and every case's run.json byte for byte).
# Exit 77 (ctest: skipped) with the reason when the daemons cannot start here; 1 when a check fails.
#   tests/slurm_batch_test.sh RAYCLOTH_EXECUTABLE SOURCE_DIR
set -uo pipefail
raycloth=$(realpath "$1")
src=$(realpath "$2")
sweep=$src/tests/data/batch/slurm.json
skip() { echo "SKIPPED: $*"; exit 77; }
fail() { echo "FAILED: $*"; exit 1; }

[ "$(id -u)" -eq 0 ] || skip "starting munged, slurmctld and slurmd needs root"
for c in munged mungekey slurmctld slurmd sbatch sinfo scontrol; do
  command -v "$c" >/dev/null || skip "$c is not installed (Debian packages slurm-wlm and munge)"
done

tmp=$(mktemp -d /tmp/raycloth_slurm.XXXXXX)
chmod 700 "$tmp"
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done
  for p in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$p" 2>/dev/null
  done
  rm -rf "$tmp"
}
trap cleanup EXIT
show_logs() { for f in "$tmp"/*.log; do echo "--- $f"; tail -n 15 "$f"; done; }

# munge, with its own key, socket and state.
mkdir -p "$tmp/munge"
chmod 755 "$tmp/munge"
mungekey --create --keyfile="$tmp/munge/munge.key" >/dev/null 2>&1 || skip "mungekey cannot create a key"
munged --foreground --force --key-file="$tmp/munge/munge.key" --socket="$tmp/munge/munge.socket" \
  --pid-file="$tmp/munge/munged.pid" --seed-file="$tmp/munge/munged.seed" --log-file="$tmp/munged.log" \
  >>"$tmp/munged.log" 2>&1 &
pids+=($!)
for _ in $(seq 50); do [ -S "$tmp/munge/munge.socket" ] && break; sleep 0.1; done
[ -S "$tmp/munge/munge.socket" ] || { show_logs; skip "munged did not start"; }

host=$(hostname -s)
node=$(slurmd -C | head -n 1)
case $node in NodeName=*) ;; *) skip "slurmd -C cannot describe this machine";; esac
node=${node/NodeName=* CPUs/NodeName=$host CPUs}
# Ports from the test's pid, away from the defaults of a Slurm that may run here already.
ctld_port=$((20000 + $$ % 20000))
slurmd_port=$((ctld_port + 1))
mkdir -p "$tmp/state" "$tmp/spool"
cat >"$tmp/slurm.conf" <<EOF
ClusterName=raycloth-test
SlurmctldHost=$host
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$tmp/munge/munge.socket
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
ReturnToService=2
$node State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$tmp/slurm.conf
slurmctld -D -c -f "$SLURM_CONF" >>"$tmp/slurmctld.log" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" >>"$tmp/slurmd.log" 2>&1 &
pids+=($!)
state=""
for _ in $(seq 120); do
  state=$(sinfo -h -n "$host" -o %t 2>/dev/null | head -n 1)
  [ "$state" = idle ] && break
  sleep 0.5
done
[ "$state" = idle ] || { show_logs; skip "the Slurm node did not come up (state '${state:-none}')"; }
echo "$(date +%T) Slurm up: node $host idle"

n=$("$raycloth" batch "$sweep" --count) || fail "raycloth batch --count"
[ "$n" -ge 8 ] || fail "the sweep has $n cases, fewer than 8"
cd "$tmp" || exit 1
RAYCLOTH=$raycloth timeout 300 sbatch --wait --array=0-$((n - 1)) --output="$tmp/job-%A_%a.out" \
  "$src/scripts/raycloth_batch.sbatch" "$sweep" "$tmp/slurm" >"$tmp/sbatch.txt" 2>&1
code=$?
cat "$tmp/sbatch.txt"
echo "$(date +%T) array done"
if [ $code -ne 0 ]; then
  for f in "$tmp"/job-*.out; do echo "--- $f"; cat "$f"; done
  show_logs
  fail "sbatch --wait exited $code"
fi

jobs=$(ls "$tmp"/job-*.out | wc -l)
[ "$jobs" -eq "$n" ] || fail "$jobs array tasks ran, not $n"
"$raycloth" batch "$sweep" --out "$tmp/local" --quiet || fail "the local raycloth batch exited $?"
lines=$(wc -l <"$tmp/slurm/results.jsonl")
[ "$lines" -eq "$n" ] || fail "results.jsonl of the Slurm run has $lines lines, not $n"
# The deterministic columns, in case order (the run's lines come in the order the cases ended).
table() {
  python3 -c '
import json, sys
keys = ["case", "id", "values", "status", "clean", "frames", "bad_frames", "max_crossings", "max_vertices_inside",
        "pinched_frames", "max_vertices_pinched", "steps", "simulated_time", "error"]
rows = [json.loads(l) for l in open(sys.argv[1])]
for r in sorted(rows, key=lambda r: r["case"]):
    print(json.dumps({k: r[k] for k in keys}))
' "$1"
}
table "$tmp/slurm/results.jsonl" >"$tmp/slurm.table" || fail "cannot read the Slurm run's results.jsonl"
table "$tmp/local/results.jsonl" >"$tmp/local.table" || fail "cannot read the local run's results.jsonl"
diff "$tmp/local.table" "$tmp/slurm.table" || fail "the Slurm and local results differ (above: < local, > Slurm)"
for ((i = 0; i < n; i++)); do
  id=$(printf %05d "$i")
  cmp "$tmp/local/cases/$id/run.json" "$tmp/slurm/cases/$id/run.json" || fail "case $id: run.json differs"
done
clean=$(grep -c '"clean":true' "$tmp/slurm/results.jsonl")
echo "$n cases under Slurm ($clean clean), the same as the local batch:"
cat "$tmp/slurm.table"
echo "PASSED"
