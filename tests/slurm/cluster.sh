# A one-node Slurm cluster on localhost for tests, from Debian's slurm-wlm and munge packages.
# Source it, then:
#   slurm_cluster_start   # SKIPPED (exit 0) with its reason where it cannot run
#   ...sbatch / squeue / sinfo against it ($SLURM_CONF is exported)...
# and the EXIT trap it installs stops everything it started (by pid), cancels its jobs, and
# removes its files.
#
# Everything lives in one temporary folder: a generated munge key, munged on its own socket,
# slurm.conf for NodeName=localhost with all CPUs, no cgroups (proctrack/linuxproc,
# task/none), no accounting, state and spool folders, logs, pid files; slurmctld and slurmd run
# in the foreground (-D) in the background, on two free TCP ports, so that it neither needs nor
# touches /etc/slurm, /etc/munge, systemd or another cluster on the machine. Needs root:
# slurmd starts jobs as their user, and SlurmUser=root keeps the state files simple.
#
# Environment: SLURM_CLUSTER_UP_S (default 60): how long the node may take to become idle.

slurm_cluster_dir=""
slurm_cluster_pids=()

slurm_skip() {
  echo "SKIPPED: $*"
  exit 0
}

slurm_cluster_stop() {
  if [[ -n $slurm_cluster_dir && -f $slurm_cluster_dir/slurm.conf ]]; then
    # Jobs first (their slurmstepd is no child of ours), while slurmctld still answers.
    SLURM_CONF=$slurm_cluster_dir/slurm.conf timeout 10 scancel --quiet --full \
      --user="$(id -un)" >/dev/null 2>&1 || true
    for _ in $(seq 50); do
      [[ -z $(SLURM_CONF=$slurm_cluster_dir/slurm.conf timeout 5 squeue -h 2>/dev/null) ]] && break
      sleep 0.1
    done
  fi
  local pid
  for pid in "${slurm_cluster_pids[@]}"; do
    kill -TERM "$pid" 2>/dev/null || true
  done
  for pid in "${slurm_cluster_pids[@]}"; do
    for _ in $(seq 50); do
      kill -0 "$pid" 2>/dev/null || break
      sleep 0.1
    done
    kill -KILL "$pid" 2>/dev/null || true
    wait "$pid" 2>/dev/null || true
  done
  slurm_cluster_pids=()
  [[ -n $slurm_cluster_dir ]] && rm -rf "$slurm_cluster_dir"
  slurm_cluster_dir=""
}

# The last lines of the daemons' logs, for a message.
slurm_cluster_logs() {
  local f
  for f in munged.out slurmctld.log slurmctld.out slurmd.log slurmd.out; do
    [[ -s $slurm_cluster_dir/$f ]] || continue
    echo "--- $f (last lines)"
    tail -n 8 "$slurm_cluster_dir/$f"
  done
}

slurm_cluster_start() {
  local up_s=${SLURM_CLUSTER_UP_S:-60}
  [[ $(id -u) -eq 0 ]] || slurm_skip "a local Slurm cluster needs root (slurmd starts jobs as their user)"
  local missing=() c
  for c in munged slurmctld slurmd sbatch squeue sinfo scancel /usr/bin/python3; do
    command -v "$c" >/dev/null 2>&1 || missing+=("$c")
  done
  ((${#missing[@]} == 0)) ||
    slurm_skip "not installed: ${missing[*]} (Debian packages slurm-wlm, munge; tools/install-deps.sh)"

  slurm_cluster_dir=$(mktemp -d /tmp/rosguard-slurm.XXXXXX)
  trap slurm_cluster_stop EXIT
  trap 'exit 130' INT
  trap 'exit 143' TERM
  local d=$slurm_cluster_dir
  chmod 755 "$d" # munged wants its socket's folder searchable
  mkdir -p "$d/state" "$d/spool"

  # munge: a fresh key (mungekey, or 1024 random bytes where the tool is older), its own socket.
  if command -v mungekey >/dev/null 2>&1; then
    mungekey --create --keyfile="$d/munge.key" >/dev/null 2>&1
  fi
  [[ -s $d/munge.key ]] || dd if=/dev/urandom of="$d/munge.key" bs=1024 count=1 status=none
  chmod 600 "$d/munge.key"
  munged --foreground --force --socket="$d/munge.socket" --key-file="$d/munge.key" \
    --pid-file="$d/munged.pid" --seed-file="$d/munged.seed" --log-file="$d/munged.log" \
    >"$d/munged.out" 2>&1 &
  slurm_cluster_pids+=($!)
  for _ in $(seq 100); do
    [[ -S $d/munge.socket ]] && break
    kill -0 "${slurm_cluster_pids[0]}" 2>/dev/null || break
    sleep 0.1
  done
  [[ -S $d/munge.socket ]] || slurm_skip "munged did not start: $(tail -n 3 "$d/munged.out" | tr '\n' ' ')"

  local ports
  ports=$(/usr/bin/python3 -c '
import socket
socks = [socket.socket() for _ in range(2)]
for s in socks:
    s.bind(("127.0.0.1", 0))
print(" ".join(str(s.getsockname()[1]) for s in socks))')
  local ctld_port=${ports% *} slurmd_port=${ports#* }
  cat >"$d/slurm.conf" <<EOF
# A one-node test cluster (tests/slurm/cluster.sh); removed when the test ends.
ClusterName=rosguardtest
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$d/munge.socket
CredType=cred/munge
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
ReturnToService=2
MinJobAge=600
StateSaveLocation=$d/state
SlurmdSpoolDir=$d/spool
SlurmctldPidFile=$d/slurmctld.pid
SlurmdPidFile=$d/slurmd.pid
SlurmctldLogFile=$d/slurmctld.log
SlurmdLogFile=$d/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=test Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
  export SLURM_CONF=$d/slurm.conf
  slurmctld -D -f "$SLURM_CONF" >"$d/slurmctld.out" 2>&1 &
  slurm_cluster_pids+=($!)
  slurmd -D -N localhost -f "$SLURM_CONF" >"$d/slurmd.out" 2>&1 &
  slurm_cluster_pids+=($!)

  local state="" t0=$SECONDS
  while ((SECONDS - t0 < up_s)); do
    state=$(timeout 10 sinfo -h -n localhost -o %T 2>/dev/null || true)
    [[ $state == idle ]] && break
    sleep 0.5
  done
  if [[ $state != idle ]]; then
    echo "the local cluster did not come up in ${up_s} s (node state: '${state:-no answer}')"
    slurm_cluster_logs
    slurm_skip "slurmctld / slurmd did not bring the node up within ${up_s} s"
  fi
  # A node that is up may still be unable to start a job here (a container that forbids what
  # slurmstepd does): a trivial job tells the environment's failures from the test's.
  local probe
  probe=$(sbatch --parsable --output="$d/probe.out" --wrap 'echo probe-ok' 2>&1) ||
    slurm_skip "the local cluster refuses a job: $probe"
  probe=${probe%%;*}
  t0=$SECONDS
  while ((SECONDS - t0 < up_s)) && [[ -n $(squeue -h -j "$probe" -o %i 2>/dev/null) ]]; do
    sleep 0.2
  done
  if ! grep -qx probe-ok "$d/probe.out" 2>/dev/null; then
    echo "probe job $probe: $(squeue -h -t all -j "$probe" -o '%T %r' 2>/dev/null)"
    slurm_cluster_logs
    slurm_skip "the local cluster did not run a trivial job within ${up_s} s"
  fi
  echo "slurm: one-node cluster up and running jobs ($(sinfo --version), $(nproc) CPU(s), $d)"
}

# Waits until Slurm job $1 (every array task) has left the queue; $2: time limit in seconds.
# Returns 1 (after printing the queue and the logs) when it has not.
slurm_wait_job() {
  local job=$1 limit=${2:-300} t0=$SECONDS
  while ((SECONDS - t0 < limit)); do
    [[ -z $(squeue -h -j "$job" -o %i 2>/dev/null) ]] && return 0
    sleep 0.5
  done
  echo "job $job still in the queue after ${limit} s:"
  squeue -j "$job" -r
  slurm_cluster_logs
  return 1
}
