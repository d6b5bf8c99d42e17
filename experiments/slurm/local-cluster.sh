#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, all of it in one folder, for the tests, for measuring and
# for trying --slurm before a real cluster (docs/distributed.md; no systemd, nothing in /etc): its own munge key and munged socket, slurm.conf, state, logs, and
# slurmctld + slurmd running as root on the first free pair of ports from 16817.
#
#   bash experiments/slurm/local-cluster.sh start [DIR]  # installs what is missing (root), starts, waits until idle
#   bash experiments/slurm/local-cluster.sh stop [DIR]   # cancels its jobs, stops its daemons (by their pid files)
#   export SLURM_CONF=DIR/slurm.conf                     # then sbatch, squeue, ... talk to it
# DIR defaults to /tmp/smseg-slurm-<uid>.
#
# start prints "slurm: unavailable: REASON" and exits 1 when the cluster cannot come up (not root and
# packages missing, a daemon that dies); what it had started is stopped again.
set -euo pipefail

usage() { echo "usage: $0 start|stop [DIR]" >&2; exit 2; }
(($# == 1 || $# == 2)) || usage
action=$1
dir_arg=${2:-/tmp/smseg-slurm-$(id -u)}
dir=$(mkdir -p "$dir_arg" && cd "$dir_arg" && pwd)
export SLURM_CONF="$dir/slurm.conf"
packages=(slurmctld slurmd slurm-client munge)

unavailable() {
  echo "slurm: unavailable: $*" >&2
  stop_cluster
  exit 1
}

install_missing() {
  local missing=()
  for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  ((${#missing[@]})) || return 0
  [[ $(id -u) -eq 0 ]] || unavailable "Debian packages ${missing[*]} missing (run as root, or apt-get install them)"
  echo "slurm: installing ${missing[*]}" >&2
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}" >&2 ||
    { apt-get update -q >&2 && DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}" >&2; } ||
    unavailable "apt-get could not install ${missing[*]}"
}

port_free() { ! (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }

write_config() {
  local port=16817
  while ! port_free "$port" || ! port_free $((port + 1)); do
    port=$((port + 2))
    ((port < 16900)) || unavailable "no free port pair in 16817..16900"
  done
  local host
  host=$(hostname -s)
  # proctrack/linuxproc and task/none: no cgroups to set up in a container; sched/builtin starts
  # array tasks as soon as CPUs free up (backfill would wait for its next pass); no accounting
  # daemon, so sacct has nothing and callers fall back to scontrol.
  cat >"$SLURM_CONF" <<EOF
ClusterName=smseg-local
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
SlurmctldPort=$port
SlurmdPort=$((port + 1))
AuthType=auth/munge
AuthInfo=socket=$dir/run/munge.socket
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=local Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
}

start_munge() {
  mkdir -p "$dir/run" "$dir/key"
  chmod 755 "$dir" "$dir/run"  # munged wants its socket's folders searchable by all
  chmod 700 "$dir/key"
  [[ -f $dir/key/munge.key ]] || mungekey -c -k "$dir/key/munge.key" || unavailable "mungekey failed"
  munged --socket="$dir/run/munge.socket" --key-file="$dir/key/munge.key" --log-file="$dir/log/munged.log" \
    --pid-file="$dir/run/munged.pid" --seed-file="$dir/key/munged.seed" ||
    unavailable "munged did not start (see $dir/log/munged.log)"
}

wait_idle() {
  for _ in $(seq 1 100); do
    state=$(sinfo -h -o %T 2>/dev/null || true)
    [[ $state == idle* ]] && return 0
    sleep 0.2
  done
  unavailable "the node is not idle after 20 s (sinfo: ${state:-no answer}; see $dir/log/)"
}

running() { [[ -f $1 ]] && kill -0 "$(cat "$1")" 2>/dev/null; }

start_cluster() {
  [[ $(uname -s) == Linux ]] || unavailable "needs Linux"
  if running "$dir/run/slurmctld.pid" && running "$dir/run/slurmd.pid"; then
    wait_idle
    return 0  # already up
  fi
  stop_cluster
  install_missing
  mkdir -p "$dir/state" "$dir/spool" "$dir/log"
  write_config
  start_munge
  slurmctld -i || unavailable "slurmctld did not start (see $dir/log/slurmctld.log)"
  slurmd || unavailable "slurmd did not start (see $dir/log/slurmd.log)"
  wait_idle
  echo "slurm: one-node cluster up; export SLURM_CONF=$SLURM_CONF" >&2
}

# Stops only what this folder's pid files name: other Slurm or munge daemons on the machine are
# left alone.
stop_daemon() {
  local pidfile=$1
  running "$pidfile" || { rm -f "$pidfile"; return 0; }
  local pid
  pid=$(cat "$pidfile")
  kill "$pid" 2>/dev/null || true
  for _ in $(seq 1 50); do
    kill -0 "$pid" 2>/dev/null || { rm -f "$pidfile"; return 0; }
    sleep 0.1
  done
  kill -9 "$pid" 2>/dev/null || true
  rm -f "$pidfile"
}

stop_cluster() {
  if [[ -f $SLURM_CONF ]] && running "$dir/run/slurmctld.pid"; then
    scancel --user=root >/dev/null 2>&1 || true  # this cluster's jobs only (SLURM_CONF)
    for _ in $(seq 1 50); do
      [[ -z $(squeue -h 2>/dev/null) ]] && break
      sleep 0.1
    done
  fi
  stop_daemon "$dir/run/slurmd.pid"
  stop_daemon "$dir/run/slurmctld.pid"
  stop_daemon "$dir/run/munged.pid"
}

case $action in
  start) start_cluster ;;
  stop) stop_cluster ;;
  *) usage ;;
esac
