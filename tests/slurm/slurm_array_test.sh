#!/usr/bin/env bash
# Slurm end to end, on a real single-node cluster from Debian's packages (munged, slurmctld,
# slurmd, the client commands) brought up in a temporary folder with its own key, socket and
# ports: scripts/slurm/submit.sh runs the capture array as 4 shards, the merge, a lookup array
# of 3 shards and the gather. The joined capture set and the gathered lookups must equal one
# process's, byte for byte. Then faults: a shard deleted and one altered are made again on
# re-submission and only they; a failing capture array leaves no shard file and cancels what
# depends on it. Only the daemons this test started are stopped, by their PID files.
# Usage: slurm_array_test.sh BIN_DIR
set -euo pipefail
bin=$(realpath "$1")
root=$(cd "$(dirname "$0")/../.." && pwd)

fail() {
  echo "slurm_array_test: $*" >&2
  exit 1
}
[ "$(id -u)" = 0 ] || fail "needs root (munged runs as the munge user, the Slurm daemons as root)"
for exe in /usr/sbin/munged /usr/sbin/slurmctld /usr/sbin/slurmd sbatch squeue scontrol sinfo; do
  command -v "$exe" >/dev/null || fail "$exe is missing (scripts/setup.sh installs Slurm and munge)"
done
id munge >/dev/null 2>&1 || fail "no munge user (Debian's munge package creates it)"

# Under /tmp, not $TMPDIR: the daemons' socket paths must stay short (108 bytes at most).
work=$(mktemp -d /tmp/basis-slurm.XXXXXX)
chmod 755 "$work"
stop() {  # stop NAME PIDFILE: the daemon this test started, and only it
  local pid
  [ -f "$2" ] || return 0
  pid=$(cat "$2")
  kill "$pid" 2>/dev/null || return 0
  for _ in $(seq 100); do
    kill -0 "$pid" 2>/dev/null || return 0
    sleep 0.1
  done
  echo "slurm_array_test: $1 ($pid) did not stop; killing it" >&2
  kill -9 "$pid" 2>/dev/null || true
}
cleanup() {
  local status=$?
  if [ $status -ne 0 ] && [ -d "$work/log" ]; then
    echo "--- daemon logs (last lines)" >&2
    tail -n 15 "$work"/log/*.log >&2 || true
    tail -n 15 "$work"/run*/logs/*.log >&2 2>/dev/null || true
  fi
  stop slurmd "$work/slurmd.pid"
  stop slurmctld "$work/slurmctld.pid"
  stop munged "$work/munge/munged.pid"
  rm -rf "$work"
  exit $status
}
trap cleanup EXIT

# munged: a key, socket and logs of this test's own.
mkdir -p "$work/munge" "$work/state" "$work/spool" "$work/log"
head -c 1024 /dev/urandom >"$work/munge/key"
chown -R munge:munge "$work/munge"
chmod 755 "$work/munge"
chmod 600 "$work/munge/key"
runuser -u munge -- /usr/sbin/munged --socket="$work/munge/socket" \
  --pid-file="$work/munge/munged.pid" --log-file="$work/munge/munged.log" \
  --seed-file="$work/munge/seed" --key-file="$work/munge/key"

# Two free ports for slurmctld and slurmd.
read -r ctld_port slurmd_port < <(/usr/bin/python3 -c '
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1", 0))
print(*[x.getsockname()[1] for x in s])')
host=$(hostname -s)
memory=$(($(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 / 2))
cat >"$work/slurm.conf" <<CONF
ClusterName=basis-test
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$work/munge/socket
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
MailProg=/bin/true
ReturnToService=2
SchedulerParameters=batch_sched_delay=0
MinJobAge=3600
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) RealMemory=$memory State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$work/slurm.conf"
/usr/sbin/slurmctld -f "$SLURM_CONF"
/usr/sbin/slurmd -f "$SLURM_CONF" -N "$host"
for _ in $(seq 300); do
  [ "$(sinfo -h -o %t 2>/dev/null)" = idle ] && break
  sleep 0.1
done
[ "$(sinfo -h -o %t)" = idle ] || fail "the node did not come up: $(sinfo -h -o %t)"
echo "slurm_array_test: cluster up (slurmctld on port $ctld_port)"

# Waits for jobs to leave the queue; prints each job's (and array task's) final state.
wait_for() {
  for _ in $(seq 3000); do
    [ -z "$(squeue -h -j "$(
      IFS=,
      echo "$*"
    )" 2>/dev/null)" ] && break
    sleep 0.1
  done
  for job in "$@"; do
    scontrol -o show job "$job" | sed -n 's/.*JobId=\([0-9]*\).*JobState=\([A-Z_]*\).*/\2/p'
  done
}
all_completed() {
  local states
  states=$(wait_for "$@")
  echo "$states" | sort | uniq -c | sed 's/^/slurm_array_test:   /'
  [ -n "$states" ] && ! echo "$states" | grep -qv '^COMPLETED$'
}

# One process: the captures and their lookups.
map=/usr/share/blender/datafiles/studiolights/world/sunrise.exr
light=(--env "$map")
[ -f "$map" ] || light=(--env-constant 1,2,3)
capture_args=("${light[@]}" --scene "$root/data/scene.obj" --sample 50 --res 16 --spp 1 --seed 3)
"$bin/brdf2qt" "$root/data/phong.json" --wo-res 9 --wi-res 16 --no-tilt -o "$work/phong.qt" -q
"$bin/capture2qt" "${capture_args[@]}" -o "$work/single.qt" -q
"$bin/qtconvolve" "$work/phong.qt" "$work/single.qt" --wo 0.3,0.1,0.95 --csv >"$work/single.csv"

submit() {  # submit OUT_DIR capture2qt-args...: the whole pipeline; prints its job IDs
  local out=$1
  shift
  BASIS_BIN=$bin "$root/scripts/slurm/submit.sh" --table "$work/phong.qt" --lookup-shards 3 \
    --wo 0.3,0.1,0.95 --join --throttle 2 "$out" 4 -- "$@"
}

# The pipeline on the cluster.
mapfile -t jobs < <(submit "$work/run" "${capture_args[@]}")
[ ${#jobs[@]} = 4 ] || fail "submit.sh printed ${#jobs[@]} job IDs, not 4"
all_completed "${jobs[@]}" || fail "not every job completed"
cmp "$work/run/captures.qt" "$work/single.qt" ||
  fail "the joined capture set differs from one process's"
cmp "$work/run/lookups.csv" "$work/single.csv" ||
  fail "the gathered lookups differ from one process's"
"$bin/qtinfo" "$work/run/captures.qtm" >/dev/null
echo "slurm_array_test: 4 capture shards joined and 3 lookup shards gathered equal one process"

# Faults: a shard deleted, another altered; re-submitted, only they are made again.
rm "$work/run/shards/captures.2.qt"
printf 'x' | dd of="$work/run/shards/captures.1.qt" bs=1 seek=2000 conv=notrunc status=none
rm "$work/run/captures.qt" "$work/run/lookups.csv"
touch -d '2001-01-01' "$work/run/shards/captures.0.qt"
mapfile -t jobs < <(submit "$work/run" "${capture_args[@]}")
all_completed "${jobs[@]}" || fail "the re-submitted jobs did not all complete"
[ "$(date -r "$work/run/shards/captures.0.qt" +%Y)" = 2001 ] || fail "shard 0 was made again"
cmp "$work/run/captures.qt" "$work/single.qt" || fail "the re-made set differs"
cmp "$work/run/lookups.csv" "$work/single.csv" || fail "the re-made lookups differ"
echo "slurm_array_test: re-submitted, only the deleted and the altered shard were made again"

# A capture array that fails (a scene that does not exist): no shard file, nothing downstream.
mapfile -t jobs < <(submit "$work/run-bad" "${light[@]}" --scene "$work/missing.obj" --sample 50)
states=$(wait_for "${jobs[@]}")
echo "$states" | grep -q FAILED || fail "the failing capture array did not fail: $states"
! echo "$states" | grep -q COMPLETED || fail "a job after the failing array ran: $states"
[ -z "$(ls -A "$work/run-bad/shards" 2>/dev/null)" ] || fail "a failed shard left files"
[ ! -e "$work/run-bad/captures.qtm" ] || fail "a manifest was written after a failure"
echo "slurm_array_test: a failing array left no shard and cancelled the jobs after it"
