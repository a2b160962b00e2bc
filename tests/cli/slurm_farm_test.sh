#!/usr/bin/env bash
# `drtv farm slurm` against a real Slurm: a single-node cluster (slurmctld, slurmd and munged with
# their own configuration, key, sockets and logs in a temporary folder) started here and stopped
# by PID at the end, on success or failure. It checks that
#   1. a world baked as a 4-task job array plus the dependent merge equals the 1-process archive,
#      byte for byte;
#   2. with one task made to fail (its journal held by another process, as a straggler of the same
#      shard would hold it) the merge does not run, `drtv farm status` names the shard and the
#      error the shard wrote, and a retry of that task alone completes and releases the merge,
#      which writes the same bytes.
# Slurm missing is a failure, not a skip: CI installs it (scripts/bootstrap). Needs root (the
# daemons run as root without systemd).
#
# usage: slurm_farm_test.sh <drtv> <world>
set -euo pipefail
drtv=$1
world=$2

fail() { echo "FAIL: $*" >&2; exit 1; }
for tool in slurmctld slurmd sbatch scontrol squeue sinfo munged flock; do
  command -v "$tool" >/dev/null ||
    fail "$tool is not installed: this test needs a real Slurm (apt-get install slurmctld slurmd slurm-client munge; scripts/bootstrap does)"
done
[ "$(id -u)" -eq 0 ] || fail "the single-node Slurm of this test runs as root (SlurmUser=root); run it as root"

tmp=$(mktemp -d /tmp/drtv-slurm-test.XXXXXX)
pids=()
cleanup() {
  local rc=$?
  if [ -n "${SLURM_CONF:-}" ] && [ -S "$tmp/munge/munge.socket" ]; then scancel --quiet --full -u root 2>/dev/null || true; fi
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$pid" 2>/dev/null || true
  done
  if [ "$rc" -ne 0 ]; then
    echo "--- slurmctld.log (tail)" >&2; tail -n 30 "$tmp/slurmctld.log" 2>/dev/null >&2 || true
    echo "--- slurmd.log (tail)" >&2; tail -n 30 "$tmp/slurmd.log" 2>/dev/null >&2 || true
    for log in "$tmp"/jobs*/logs/*.log; do [ -f "$log" ] && { echo "--- $log" >&2; cat "$log" >&2; }; done
  fi
  rm -rf "$tmp"
}
trap cleanup EXIT

# Free TCP ports for the two daemons (another Slurm on this machine keeps its own): a port nothing
# answers on (bash's /dev/tcp; no other tool needed).
free_port() {
  local port
  for _ in $(seq 200); do
    port=$((20000 + RANDOM % 40000))
    [ "$port" = "${1:-}" ] && continue
    if ! (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then echo "$port"; return 0; fi
  done
  fail "no free TCP port found for the test's Slurm"
}
ctld_port=$(free_port)
slurmd_port=$(free_port "$ctld_port")

# munge: its own key, socket, pid and seed files.
mkdir -p "$tmp/munge"
chmod 755 "$tmp" "$tmp/munge"
dd if=/dev/urandom of="$tmp/munge.key" bs=1024 count=1 status=none
chmod 400 "$tmp/munge.key"
munged --foreground --force --socket="$tmp/munge/munge.socket" --key-file="$tmp/munge.key" --pid-file="$tmp/munged.pid" \
  --seed-file="$tmp/munged.seed" --log-file="$tmp/munged.log" &
pids+=($!)

# The daemons talk over loopback whatever the host's name resolves to (a fresh CI machine's may
# resolve to nothing): the controller's and the node's addresses are given.
host=$(hostname -s)
node="$(slurmd -C | head -n 1) NodeAddr=127.0.0.1"
mkdir -p "$tmp/state" "$tmp/spool"
cat >"$tmp/slurm.conf" <<EOF
ClusterName=drtvtest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$tmp/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$tmp/jobcomp.txt
SchedulerParameters=batch_sched_delay=0
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
$node
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF="$tmp/slurm.conf"
for _ in $(seq 100); do [ -S "$tmp/munge/munge.socket" ] && break; sleep 0.1; done
[ -S "$tmp/munge/munge.socket" ] || fail "munged did not start: $(cat "$tmp/munged.log" 2>/dev/null)"
slurmctld -D -c -i &
pids+=($!)
slurmd -D &
pids+=($!)
up=0
for _ in $(seq 300); do
  if [ "$(sinfo -h -o %T 2>/dev/null | head -n 1)" = "idle" ]; then up=1; break; fi
  sleep 0.1
done
[ "$up" -eq 1 ] || fail "the single-node Slurm did not come up (sinfo: $(sinfo 2>&1 | tail -n 2))"

# The state of a job (or array task) as scontrol shows it: PENDING, RUNNING, COMPLETED, FAILED...
state() { scontrol show job "$1" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | head -n 1; }
reason() { scontrol show job "$1" 2>/dev/null | sed -n 's/.*Reason=\([A-Za-z_]*\).*/\1/p' | head -n 1; }
# Waits until job $1 is in one of the states $2 (a regex), at most $3 seconds.
await() {
  local s
  for _ in $(seq $(($3 * 10))); do
    s=$(state "$1")
    [[ "$s" =~ ^($2)$ ]] && return 0
    sleep 0.1
  done
  scontrol show job "$1" >&2 || true
  fail "job $1 is $s after $3 s, expected $2"
}

# The 1-process archive.
CI=1 "$drtv" bake "$world" -o "$tmp/one/w.drtv" --quality draft --threads 2 >/dev/null

# 1. Four array tasks and the merge.
out=$(CI=1 "$drtv" farm slurm "$world" -o "$tmp/farm/w.drtv" --shards 4 --scripts "$tmp/jobs" --quality draft --max-cpus 1 --submit)
echo "$out"
array=$(sed -n 's/^shards \([0-9]*\)$/\1/p' <<<"$out")
merge=$(sed -n 's/^merge \([0-9]*\)$/\1/p' <<<"$out")
[ -n "$array" ] && [ -n "$merge" ] || fail "drtv farm slurm --submit printed no job ids"
grep -q -- "--dependency" "$tmp/jobs/submit.sh" || fail "submit.sh has no dependency"
await "$merge" "COMPLETED|FAILED|CANCELLED|TIMEOUT" 120
[ "$(state "$merge")" = COMPLETED ] || fail "the merge job $merge is $(state "$merge")"
for i in 0 1 2 3; do [ "$(state "${array}_$i")" = COMPLETED ] || fail "task ${array}_$i is $(state "${array}_$i")"; done
cmp "$tmp/one/w.drtv" "$tmp/farm/w.drtv" || fail "the farm's archive differs from the 1-process bake's"
echo "ok: 4 array tasks and the merge wrote the 1-process archive's bytes"

# 2. Task 2 fails: another process holds its journal.
mkdir -p "$tmp/farm2/w.drtv.sectors"
exec 9>>"$tmp/farm2/w.drtv.sectors/sectors-2-of-4.log"
flock -n 9 || fail "cannot lock the journal of shard 2"
out=$(CI=1 "$drtv" farm slurm "$world" -o "$tmp/farm2/w.drtv" --shards 4 --scripts "$tmp/jobs2" --quality draft --max-cpus 1 --submit)
echo "$out"
array=$(sed -n 's/^shards \([0-9]*\)$/\1/p' <<<"$out")
merge=$(sed -n 's/^merge \([0-9]*\)$/\1/p' <<<"$out")
[ -n "$array" ] && [ -n "$merge" ] || fail "drtv farm slurm --submit printed no job ids"
for i in 0 1 3; do await "${array}_$i" "COMPLETED" 120; done
await "${array}_2" "FAILED" 120
# The merge stays pending: its dependency can no longer be met (until the task is retried).
for _ in $(seq 100); do [ "$(reason "$merge")" = DependencyNeverSatisfied ] && break; sleep 0.1; done
[ "$(state "$merge")" = PENDING ] || fail "the merge ran after a failed shard: $(state "$merge")"
[ "$(reason "$merge")" = DependencyNeverSatisfied ] || fail "the merge waits for '$(reason "$merge")', not its failed dependency"
[ ! -e "$tmp/farm2/w.drtv" ] || fail "an archive was written with a shard missing"
status=$(CI=1 "$drtv" farm status "$tmp/farm2/w.drtv")
echo "$status"
grep -q "shard 2/4 failed .*another bake is writing this shard's journal" <<<"$status" ||
  fail "drtv farm status does not name shard 2 and its error"
for i in 0 1 3; do grep -q "^shard $i/4 done" <<<"$status" || fail "drtv farm status does not say shard $i is done"; done
grep -q "another bake is writing this shard's journal" "$tmp/jobs2/logs/${array}_2.log" || fail "task 2's log lacks its error"

# The retry of task 2 alone (released now), started at once rather than after cred_expire.
exec 9>&-
"$tmp/jobs2/retry.sh" 2
await "$merge" "COMPLETED|FAILED|CANCELLED|TIMEOUT" 60
[ "$(state "$merge")" = COMPLETED ] || fail "the merge job $merge is $(state "$merge") after the retry"
cmp "$tmp/one/w.drtv" "$tmp/farm2/w.drtv" || fail "the archive merged after a retry differs from the 1-process bake's"
# --open-mode=append: the retry's log keeps the first attempt's error.
grep -q "another bake is writing this shard's journal" "$tmp/jobs2/logs/${array}_2.log" || fail "the retry truncated task 2's log"
grep -q "restart 1" "$tmp/jobs2/logs/${array}_2.log" || fail "task 2's log does not show its retry"
echo "ok: a failed task held the merge back, was named with its error, and its retry released the merge to the same bytes"
