#!/usr/bin/env bash
# Starts a private Slurm (munged, slurmctld, slurmd) on this host for the cohort test:
#   slurm_local.sh start DIR   -> prints "export SLURM_CONF=DIR/slurm.conf"; exit 77 if it cannot start
#   slurm_local.sh stop DIR
# Everything lives in DIR (key, sockets, state, logs) on ports chosen free; the host's own Slurm and
# munge configuration, if any, is not touched. Needs root (slurmd runs jobs as their users), the
# Debian packages slurm-wlm and munge.
set -euo pipefail
cmd=${1:?start or stop}
dir=$(realpath -m "${2:?folder}")
skip() { echo "slurm_local.sh: cannot start a local Slurm: $*" >&2; exit 77; }

stop() {
  [ -f "$dir/slurm.conf" ] && SLURM_CONF="$dir/slurm.conf" scancel --user="$(id -un)" 2>/dev/null || true
  local pids=()
  for d in slurmd slurmctld munged; do
    [ -f "$dir/$d.pid" ] && pids+=("$(cat "$dir/$d.pid")")
  done
  ((${#pids[@]})) || return 0
  kill "${pids[@]}" 2>/dev/null || true
  for _ in $(seq 50); do
    kill -0 "${pids[@]}" 2>/dev/null || break
    sleep 0.1
  done
  kill -9 "${pids[@]}" 2>/dev/null || true
  rm -f "$dir"/*.pid
}

if [ "$cmd" = stop ]; then stop; exit 0; fi
[ "$cmd" = start ] || { echo "usage: slurm_local.sh start|stop DIR" >&2; exit 2; }
[ "$(id -u)" = 0 ] || skip "it needs root (slurmd starts jobs as their owners)"
for p in munged mungekey slurmctld slurmd sbatch sinfo scancel; do
  command -v "$p" >/dev/null || [ -x "/usr/sbin/$p" ] || skip "$p is missing (apt-get install slurm-wlm munge)"
done
export PATH=$PATH:/usr/sbin
mkdir -p "$dir"/{state,spool,munge}
chmod 700 "$dir/munge"

# Two free TCP ports for slurmctld and slurmd (nothing answers on them now).
free_port() {
  local p
  for _ in $(seq 200); do
    p=$((20000 + RANDOM % 40000))
    [ "$p" != "${1:-0}" ] && ! (exec 3<>"/dev/tcp/127.0.0.1/$p") 2>/dev/null && { echo "$p"; return; }
  done
  skip "no free TCP port found"
}
ctld_port=$(free_port); slurmd_port=$(free_port "$ctld_port")

mungekey -c -f -k "$dir/munge/munge.key" 2>/dev/null || dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$dir/munge/munge.key"
socket="$dir/munge/munge.socket"
if [ ${#socket} -gt 100 ]; then  # a Unix socket's path has at most 107 bytes
  socket=$(mktemp -u /tmp/sinew-munge-XXXXXX.socket)
fi
munged --force --key-file="$dir/munge/munge.key" --socket="$socket" --pid-file="$dir/munged.pid" \
  --log-file="$dir/munged.log" --seed-file="$dir/munge/munge.seed" || skip "munged did not start (see $dir/munged.log)"

host=$(hostname -s)
cpus=$(nproc)
mem=$(awk '/MemTotal/ {print int($2/1024*0.8)}' /proc/meminfo)
cat > "$dir/slurm.conf" <<CONF
ClusterName=sinewtest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
MpiDefault=none
SwitchType=switch/none
ReturnToService=2
SchedulerType=sched/backfill
SchedulerParameters=sched_interval=2
MinJobAge=300
NodeName=$host NodeAddr=127.0.0.1 NodeHostname=$host CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=cohort Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$dir/slurm.conf"
slurmctld -f "$SLURM_CONF" -i || { stop; skip "slurmctld did not start (see $dir/slurmctld.log)"; }
slurmd -f "$SLURM_CONF" -N "$host" || { stop; skip "slurmd did not start (see $dir/slurmd.log)"; }
for _ in $(seq 60); do
  state=$(sinfo -h -N -o %t 2>/dev/null | head -1 || true)
  case "$state" in idle|mix|alloc) echo "export SLURM_CONF=$SLURM_CONF"; exit 0 ;; esac
  sleep 0.5
done
tail -5 "$dir/slurmctld.log" "$dir/slurmd.log" >&2 || true
stop
skip "the node did not become idle within 30 s (state: ${state:-none})"
