#!/usr/bin/env bash
# A real single-node Slurm cluster runs scripts/slurm/: a 4-task basin array job and a
# 3-task two-parameter map array job, each plus its dependent merge job; the merged files
# must equal a single-process run bit for bit. Installs Debian's slurm-wlm and munge when absent, starts munged, slurmctld and
# slurmd by hand (no systemd; see docs/cluster.md), stops them by PID at the end.
#
# Usage: bash scripts/slurm-test.sh [path to the jeffcott binary]
# JEFFCOTT_REQUIRE_SLURM=1 makes a Slurm that cannot be installed or started a failure
# (CI sets it); otherwise that case prints "skipped" and exits 0.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=$(realpath "${1:-target/release/jeffcott}")
name=slurm_arrays_of_a_basin_and_a_map_sharded_and_merged_equal_the_single_process_runs
t0=$(date +%s)

skip_or_fail() {
  if [ "${JEFFCOTT_REQUIRE_SLURM:-0}" = 1 ]; then
    echo "test $name ... FAILED ($1)"
    echo "0 passed, 1 failed"
    exit 1
  fi
  echo "test $name ... skipped ($1)"
  exit 0
}

[ "$(id -u)" -eq 0 ] || skip_or_fail "a private Slurm cluster needs root"
if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  echo "slurm-test.sh: installing slurm-wlm and munge"
  env DEBIAN_FRONTEND=noninteractive apt-get update -qq || true
  env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
    slurmctld slurmd slurm-client munge >/dev/null || skip_or_fail "apt-get install failed"
fi

host=$(hostname -s)
getent hosts "$host" >/dev/null || echo "127.0.0.1 $host" >>/etc/hosts
work=$(mktemp -d /tmp/jeffcott-slurm.XXXXXX)
chmod 755 "$work"
pids=()
cleanup() {
  for p in /run/slurmd-jeffcott.pid /run/slurmctld-jeffcott.pid; do
    [ -f "$p" ] && kill "$(cat "$p")" 2>/dev/null || true
  done
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  if [ -f /run/munge/munged.pid ] && [ -n "${started_munge:-}" ]; then
    kill "$(cat /run/munge/munged.pid)" 2>/dev/null || true
  fi
  sleep 1
  rm -rf "$work" /var/spool/slurmctld-jeffcott /var/spool/slurmd-jeffcott
}
trap cleanup EXIT

# munge: key, run dirs, daemon as the munge user.
mkdir -p /etc/munge /run/munge /var/log/munge /var/lib/munge
if [ ! -s /etc/munge/munge.key ]; then
  dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
fi
chown munge:munge /etc/munge /etc/munge/munge.key /run/munge /var/log/munge /var/lib/munge
chmod 400 /etc/munge/munge.key
if ! munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
  su -s /bin/sh munge -c /usr/sbin/munged || skip_or_fail "munged did not start"
  started_munge=1
  sleep 1
  munge -n | unmunge >/dev/null || skip_or_fail "munge does not work"
fi

# A stale daemon of an earlier run of this script would hold the ports.
for p in /run/slurmd-jeffcott.pid /run/slurmctld-jeffcott.pid; do
  [ -f "$p" ] && kill "$(cat "$p")" 2>/dev/null || true
done
sleep 0.5
rm -rf /var/spool/slurmctld-jeffcott /var/spool/slurmd-jeffcott
mkdir -p /etc/slurm /var/spool/slurmctld-jeffcott /var/spool/slurmd-jeffcott /var/log/slurm
cat >/etc/slurm/slurm.conf <<CONF
ClusterName=jeffcott-test
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=/var/spool/slurmctld-jeffcott
SlurmdSpoolDir=/var/spool/slurmd-jeffcott
SlurmctldPidFile=/run/slurmctld-jeffcott.pid
SlurmdPidFile=/run/slurmd-jeffcott.pid
SlurmctldLogFile=/var/log/slurm/slurmctld-jeffcott.log
SlurmdLogFile=/var/log/slurm/slurmd-jeffcott.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
MaxArraySize=1001
NodeName=$host CPUs=$(nproc) RealMemory=1000 State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
slurmctld || skip_or_fail "slurmctld did not start (see /var/log/slurm/slurmctld-jeffcott.log)"
slurmd || skip_or_fail "slurmd did not start (see /var/log/slurm/slurmd-jeffcott.log)"
for _ in $(seq 60); do
  state=$(sinfo -h -o %T 2>/dev/null | head -n1 || true)
  [ "$state" = idle ] && break
  sleep 0.5
done
[ "$state" = idle ] || skip_or_fail "the node is '$state', not idle"

fail() {
  echo "--- job output"; cat "$work"/*/*.out 2>/dev/null || true
  echo "test $name ... FAILED ($1)"; echo "0 passed, 1 failed"; exit 1
}

# Submits N array tasks of SCRIPT plus the dependent merge into $work/<tag>/run, waits
# (bounded) and checks the merged FILES against the single-process run in $work/<tag>/single.
array_and_merge() {
  local tag=$1 n=$2 script=$3; shift 3
  export RUN_DIR="$work/$tag/run"
  mkdir -p "$RUN_DIR"
  local ids array merge left state i f
  ids=$(cd "$work/$tag" && bash "$root/scripts/slurm/submit.sh" "$n" "$script")
  echo "slurm-test.sh: $tag: $ids"
  array=$(echo "$ids" | sed -E 's/array job ([0-9]+).*/\1/')
  merge=$(echo "$ids" | sed -E 's/.*merge job ([0-9]+).*/\1/')
  for _ in $(seq 360); do
    left=$(squeue -h -j "$array,$merge" 2>/dev/null | wc -l)
    [ "$left" -eq 0 ] && break
    sleep 0.5
  done
  [ "$left" -eq 0 ] || { squeue; fail "$tag: jobs still queued after 180 s"; }
  state=$(scontrol show job "$merge" 2>/dev/null | grep -o 'JobState=[A-Z]*' | head -n1)
  [ "$state" = JobState=COMPLETED ] || fail "$tag merge job: $state"
  for ((i = 0; i < n; i++)); do
    grep -q '"state": "complete"' "$RUN_DIR/shard-$i/run.json" || fail "$tag shard $i not complete"
  done
  for f in "$@"; do
    cmp -s "$work/$tag/single/$f" "$RUN_DIR/merged/$f" || fail "$tag: $f differs from the single-process run"
  done
  grep -q '"state": "complete"' "$RUN_DIR/merged/run.json" || fail "$tag: merged run not complete"
}

root=$(pwd)
export JEFFCOTT="$bin"
mkdir -p "$work/basin" "$work/map"

# A basin in 4 shards.
basin="--omega 133 --x x_r:-0.006:0.006:24 --y vx_r:-1:1:20 --transient 60 --periods 16 --backend cpu"
# shellcheck disable=SC2086
"$bin" basin $basin --quiet --out "$work/basin/single" 2>/dev/null
export BASIN_ARGS="$basin"
array_and_merge basin 4 basin-array.sbatch labels.npy x.npy y.npy attractors.json basin.png attractors.png

# A two-parameter map (speed against unbalance) in 3 shards.
map="--x omega:131:134:6 --y e:0.0009:0.0011:2 --ics 2 --transient 60 --periods 16 --chunk 1 --backend cpu"
# shellcheck disable=SC2086
"$bin" map $map --quiet --out "$work/map/single" 2>/dev/null
export MAP_ARGS="$map"
array_and_merge map 3 map-array.sbatch period.npy class.npy lambda1.npy attractors.npy contact.npy \
  peak_force.npy map.json map_period.png map_lambda1.png map_multistability.png

echo "test $name ... ok ($(( $(date +%s) - t0 )) s: a 4-task basin array and a 3-task map array, each with its dependent merge)"
echo "1 passed, 0 failed"
