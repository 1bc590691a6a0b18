#!/bin/bash
# A real single-node Slurm on loopback for Obscura's farm tests (no systemd, no cgroups, as root):
#   slurm-local.sh start DIR   writes DIR/slurm.conf, starts munged, slurmctld and slurmd, waits until
#                              the node is idle, and records the three PIDs in DIR/pids
#   slurm-local.sh stop DIR    stops exactly those PIDs
# Needs Debian's slurm-wlm and munge (slurm-wlm 22.05: apt-get install slurm-wlm munge).
# After start, `export SLURM_CONF=DIR/slurm.conf` points sbatch, squeue and sinfo at it.
set -euo pipefail
cmd=${1:?start or stop}
dir=$(realpath -m "${2:?a directory for the cluster state}")

stop() {
  [ -f "$dir/pids" ] || return 0
  # The cluster's jobs first (it is this directory's own cluster), so no job step outlives slurmd.
  if SLURM_CONF="$dir/slurm.conf" scancel --quiet --user=root 2>/dev/null; then
    for _ in $(seq 50); do
      [ -z "$(SLURM_CONF="$dir/slurm.conf" squeue -h 2>/dev/null)" ] && break
      sleep 0.1
    done
  fi
  # shellcheck disable=SC2046
  for pid in $(cat "$dir/pids"); do
    kill "$pid" 2>/dev/null || true
  done
  for pid in $(cat "$dir/pids"); do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
  done
  rm -f "$dir/pids"
}

if [ "$cmd" = stop ]; then stop; exit 0; fi
[ "$cmd" = start ] || { echo "usage: $0 start|stop DIR" >&2; exit 2; }

mkdir -p "$dir/state" "$dir/spool" "$dir/log"
cpus=$(nproc)
cat > "$dir/slurm.conf" <<CONF
ClusterName=obscura
SlurmctldHost=localhost(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CryptoType=crypto/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerParameters=bf_interval=1,sched_interval=2,batch_sched_delay=0,sched_min_interval=0
CommunicationParameters=NoInAddrAny
ReturnToService=2
KillWait=5
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=1000 State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF=$dir/slurm.conf
: > "$dir/pids"
trap 'stop' ERR

# munged refuses to run as root; Debian's package made its key.
mkdir -p /run/munge && chown munge:munge /run/munge
if ! pgrep -x munged >/dev/null; then
  runuser -u munge -- /usr/sbin/munged --pid-file=/run/munge/munged.pid
  for _ in $(seq 50); do [ -s /run/munge/munged.pid ] && break; sleep 0.1; done
  cat /run/munge/munged.pid >> "$dir/pids"
fi
/usr/sbin/slurmctld -f "$SLURM_CONF"
for _ in $(seq 100); do [ -s "$dir/slurmctld.pid" ] && break; sleep 0.1; done
cat "$dir/slurmctld.pid" >> "$dir/pids"
/usr/sbin/slurmd -f "$SLURM_CONF" -N localhost
for _ in $(seq 100); do [ -s "$dir/slurmd.pid" ] && break; sleep 0.1; done
cat "$dir/slurmd.pid" >> "$dir/pids"
for _ in $(seq 300); do
  [ "$(sinfo -h -o %T 2>/dev/null)" = idle ] && exit 0
  sleep 0.1
done
echo "slurm-local: the node did not become idle; logs in $dir/log" >&2
stop
exit 1
