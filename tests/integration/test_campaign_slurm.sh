#!/usr/bin/env bash
# The Slurm path for real, run by CI (.ci/run installs slurm-wlm and munge) and by
# hand; not part of ctest, since it starts daemons and needs root. It brings up a
# one-node Slurm cluster on localhost (Debian's slurm-wlm + munge: slurmctld and slurmd with a private slurm.conf in a temporary folder),
# submits a small campaign as a job array (`rtsim campaign emit --slurm`, sbatch
# --wait), merges the per-job result files (`rtsim campaign collect`), runs the same
# campaign locally and checks both databases hold the same runs, byte for byte in
# every deterministic column (all but host time and timestamps).
#
#   sudo apt-get install slurm-wlm munge sqlite3
#   tests/integration/test_campaign_slurm.sh build/rtsim
set -euo pipefail

rtsim=$(realpath "${1:?usage: $0 path/to/rtsim}")
for tool in slurmctld slurmd sbatch sinfo munged sqlite3; do
  command -v "$tool" >/dev/null || { echo "SKIP: $tool not installed (apt-get install slurm-wlm munge sqlite3)"; exit 77; }
done
[ "$(id -u)" -eq 0 ] || { echo "SKIP: needs root to start slurmctld/slurmd"; exit 77; }

work=$(mktemp -d /tmp/rtsim-slurm-test.XXXXXX)
mkdir -p "$work"/{state,spool,log}
started_munged=""
cleanup() {
  for pidfile in "$work/slurmd.pid" "$work/slurmctld.pid"; do
    [ -s "$pidfile" ] && kill "$(cat "$pidfile")" 2>/dev/null || true
  done
  [ -n "$started_munged" ] && kill "$started_munged" 2>/dev/null || true
  # Until the daemons are gone (they write into $work until they exit).
  for pidfile in "$work/slurmd.pid" "$work/slurmctld.pid"; do
    [ -s "$pidfile" ] || continue
    for _ in $(seq 100); do kill -0 "$(cat "$pidfile")" 2>/dev/null || break; sleep 0.1; done
  done
  rm -rf "$work"
}
trap cleanup EXIT

# munge: reuse a running daemon, else start one as the munge user.
if ! munge -n >/dev/null 2>&1; then
  [ -f /etc/munge/munge.key ] || { echo "SKIP: no /etc/munge/munge.key"; exit 77; }
  mkdir -p /run/munge && chown munge:munge /run/munge
  runuser -u munge -- /usr/sbin/munged
  # Until munged answers (a fixed second was a guess at its start-up time).
  for _ in $(seq 300); do munge -n >/dev/null 2>&1 && break; sleep 0.1; done
  started_munged=$(pgrep -u munge -n munged || true)
fi

host=$(hostname)
cpus=$(nproc)
# Ports away from the defaults so a real cluster on this machine is not disturbed.
cat > "$work/slurm.conf" <<CONF
ClusterName=rtsimtest
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldPort=16917
SlurmdPort=16918
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SwitchType=switch/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=1000 State=UNKNOWN
PartitionName=rtsimtest Nodes=ALL Default=YES MaxTime=30 State=UP
CONF
export SLURM_CONF="$work/slurm.conf"
slurmctld -i
slurmd
for _ in $(seq 30); do
  sinfo -h -o %t 2>/dev/null | grep -q idle && break
  sleep 1
done
sinfo -h -o %t | grep -q idle || { echo "FAIL: the node never became idle"; cat "$work"/log/*.log; exit 1; }

cat > "$work/campaign.toml" <<'TOML'
[campaign]
name = "slurm-check"
[sweep]
scene = "interior"
builder = ["sah", "aobvh"]
preset = ["mobile", "desktop"]
resolution = "32x32"
[[group]]
name = "grid"
[[group]]
name = "l2"
builder = "sah"
preset = "mobile"
set.l2.size_bytes = [131072, 262144]
TOML

"$rtsim" campaign emit --slurm --throttle 2 "$work/campaign.toml" --out-dir "$work/slurm-run"
sbatch --wait "$work/slurm-run/slurm/campaign.sbatch"
"$rtsim" campaign collect "$work/campaign.toml" --out-dir "$work/slurm-run"
# Idempotent: a second collect changes nothing.
"$rtsim" campaign collect "$work/campaign.toml" --out-dir "$work/slurm-run" | grep -q " 0 new, 0 replaced"
"$rtsim" campaign run "$work/campaign.toml" -j 2 --no-results-cache --out-dir "$work/local-run"

columns="campaign, job_key, label, group_name, config_hash, git_revision, status, error, scene,
  builder, camera, preset, fidelity, seed, overrides, rays, cycles, ops_per_ray, trv_ops_per_ray,
  ist_ops_per_ray, node_fetches_per_ray, triangle_fetches_per_ray, dram_bytes_per_ray,
  l1_node_hit_rate, l1_triangle_hit_rate, l2_hit_rate, job_json, stats_json"
dump() { sqlite3 "$1" "SELECT $columns FROM runs ORDER BY job_key"; }
for db in "$work/slurm-run/results.sqlite" "$work/local-run/results.sqlite"; do
  [ "$(sqlite3 "$db" 'PRAGMA integrity_check')" = ok ] || { echo "FAIL: integrity_check of $db"; exit 1; }
done
rows=$(sqlite3 "$work/slurm-run/results.sqlite" "SELECT count(*) FROM runs WHERE status = 'ok'")
expected=$("$rtsim" campaign list "$work/campaign.toml" | wc -l)
[ "$rows" -eq "$expected" ] || { echo "FAIL: $rows ok runs from Slurm, expected $expected"; exit 1; }
if ! diff <(dump "$work/slurm-run/results.sqlite") <(dump "$work/local-run/results.sqlite") >"$work/diff.txt"; then
  echo "FAIL: the Slurm database differs from the local run:"
  head -40 "$work/diff.txt"
  exit 1
fi
echo "PASS: $rows jobs ran as a Slurm array on a one-node cluster; the collected database equals a local run"
