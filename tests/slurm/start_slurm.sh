#!/usr/bin/env bash
# A one-machine SLURM cluster for the tests (tests/test_slurm.py): munged, slurmctld and slurmd
# of Debian's slurm-wlm on this machine, one node (this machine's CPUs and memory, as
# `slurmd -C` reports them) in one partition, `debug`; no cgroups, no accounting.
#
#   bash tests/slurm/start_slurm.sh install     # install slurm-wlm and munge if missing (root, apt)
#   bash tests/slurm/start_slurm.sh start [DIR] # install, write DIR/slurm.conf, start the daemons,
#                                               # wait until the node is idle (idempotent)
#   bash tests/slurm/start_slurm.sh status [DIR]# exit 0 when this cluster's node answers idle
#   bash tests/slurm/start_slurm.sh stop [DIR]  # cancel its jobs, stop the daemons it started
#
# DIR (default $ASTROCPG_SLURM_DIR or /tmp/astrocpg-slurm) holds the configuration, the state,
# the munge socket and key, the daemons' logs and pid files: nothing outside it is configured,
# so the machine's own SLURM or munge (if any) is left alone. SLURM's commands find this
# cluster with SLURM_CONF=DIR/slurm.conf (printed as the last line of `start`).
#
# Exit status: 0 done; 77 slurm cannot be installed or started here (not root, no apt-get, or
# apt failed: the reason is printed; the tests skip, naming it); 1 installed but the cluster did
# not come up (the daemons' logs are printed).
set -uo pipefail

CMD=${1:-start}
DIR=${2:-${ASTROCPG_SLURM_DIR:-/tmp/astrocpg-slurm}}
PARTITION=debug
CTLD_PORT=${ASTROCPG_SLURMCTLD_PORT:-6817}
SLURMD_PORT=${ASTROCPG_SLURMD_PORT:-6818}
export SLURM_CONF="$DIR/slurm.conf"

say() { echo "start_slurm: $*" >&2; }

installed() {
    command -v slurmctld >/dev/null && command -v slurmd >/dev/null \
        && command -v munged >/dev/null && command -v sbatch >/dev/null
}

install() {
    installed && return 0
    if [ "$(id -u)" != 0 ]; then
        say "cannot install slurm-wlm and munge: not root (uid $(id -u)) and slurmctld," \
            "slurmd, munged or sbatch is missing"
        exit 77
    fi
    if ! command -v apt-get >/dev/null; then
        say "cannot install slurm-wlm and munge: no apt-get on this machine"
        exit 77
    fi
    say "installing slurm-wlm and munge (apt-get)"
    if ! { apt-get update -qq && DEBIAN_FRONTEND=noninteractive \
            apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null; }; then
        say "cannot install slurm-wlm and munge: apt-get failed (see its messages above)"
        exit 77
    fi
    installed || { say "cannot install slurm-wlm and munge: installed, but a daemon is missing"; exit 77; }
}

node_state() {  # the node's state as sinfo reports it (empty when slurmctld does not answer)
    timeout 10 sinfo -h -N -p "$PARTITION" -o %T 2>/dev/null | head -1
}

alive() {  # the daemon whose pid file is $1 runs (a pid file left by a daemon that died, its
            # pid since reused by another program, does not count)
    local pid
    [ -s "$1" ] || return 1
    pid=$(cat "$1")
    [ "$(cat "/proc/$pid/comm" 2>/dev/null)" = "$(basename "$1" .pid)" ]
}

up() {
    alive "$DIR/munged.pid" && alive "$DIR/slurmctld.pid" && alive "$DIR/slurmd.pid" \
        && [ "$(node_state)" = idle ]
}

write_config() {
    local node cpus mem
    node=$(hostname -s)
    cpus=$(nproc)
    # what slurmd finds on this machine (a node configured with more memory is drained)
    mem=$(slurmd -C 2>/dev/null | sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p')
    mem=${mem:-1024}
    mkdir -p "$DIR/state" "$DIR/spool" "$DIR/munge"
    cat > "$SLURM_CONF" <<EOF
# written by tests/slurm/start_slurm.sh: a one-machine cluster for the tests
ClusterName=astrocpg-test
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$CTLD_PORT
SlurmdPort=$SLURMD_PORT
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$DIR/munge/munge.socket
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool/slurmd-%n
SlurmctldPidFile=$DIR/slurmctld.pid
SlurmdPidFile=$DIR/slurmd.pid
SlurmctldLogFile=$DIR/slurmctld.log
SlurmdLogFile=$DIR/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SwitchType=switch/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
# a cancelled job's processes get SIGTERM, then SIGKILL after KillWait seconds
KillWait=5
MinJobAge=60
InactiveLimit=0
SlurmctldTimeout=30
SlurmdTimeout=30
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=$PARTITION Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
}

start_munge() {
    alive "$DIR/munged.pid" && return 0
    if [ ! -s "$DIR/munge/munge.key" ]; then
        (umask 077 && head -c 1024 /dev/urandom > "$DIR/munge/munge.key")
    fi
    chmod 700 "$DIR/munge"
    munged --force --socket="$DIR/munge/munge.socket" --key-file="$DIR/munge/munge.key" \
        --pid-file="$DIR/munged.pid" --log-file="$DIR/munged.log" \
        --seed-file="$DIR/munge/munged.seed" || return 1
}

logs() {
    for f in munged slurmctld slurmd; do
        [ -f "$DIR/$f.log" ] && { say "--- $DIR/$f.log (last lines)"; tail -20 "$DIR/$f.log" >&2; }
    done
}

start() {
    install
    mkdir -p "$DIR"
    if up; then
        say "already running (SLURM_CONF=$SLURM_CONF)"
        echo "SLURM_CONF=$SLURM_CONF"
        return 0
    fi
    if [ "$(id -u)" != 0 ]; then  # slurmd runs the jobs as their users: it must be root
        say "cannot start slurmctld and slurmd: not root (uid $(id -u))"
        exit 77
    fi
    alive "$DIR/slurmctld.pid" || alive "$DIR/slurmd.pid" || write_config
    start_munge || { say "munged did not start"; logs; exit 1; }
    alive "$DIR/slurmctld.pid" || slurmctld -f "$SLURM_CONF" \
        || { say "slurmctld did not start"; logs; exit 1; }
    alive "$DIR/slurmd.pid" || slurmd -f "$SLURM_CONF" -N "$(hostname -s)" \
        || { say "slurmd did not start"; logs; exit 1; }
    local state=""
    for _ in $(seq 60); do
        state=$(node_state)
        [ "$state" = idle ] && break
        # a node left down or drained by an earlier run of this cluster (ReturnToService=2
        # brings back only nodes down for not responding)
        case "$state" in down*|drain*) scontrol update NodeName="$(hostname -s)" State=RESUME \
            >/dev/null 2>&1 ;; esac
        sleep 1
    done
    if [ "$state" != idle ]; then
        say "the node is not idle after 60 s (sinfo says '${state:-nothing}')"
        logs
        exit 1
    fi
    say "running: partition $PARTITION, node $(hostname -s)"
    echo "SLURM_CONF=$SLURM_CONF"
}

stop_pid() {  # stop the daemon whose pid file is $1, waiting up to 10 s, then SIGKILL
    alive "$1" || return 0
    local pid
    pid=$(cat "$1")
    kill "$pid" 2>/dev/null
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || return 0; sleep 0.2; done
    kill -9 "$pid" 2>/dev/null
}

stop() {
    if [ -f "$SLURM_CONF" ] && alive "$DIR/slurmctld.pid"; then
        # the jobs' processes are ended by slurmd (SIGTERM, SIGKILL after KillWait): wait for
        # the queue to empty before stopping it
        timeout 10 scancel --quiet --partition "$PARTITION" >/dev/null 2>&1
        for _ in $(seq 40); do
            [ -z "$(timeout 10 squeue -h -p "$PARTITION" -o %i 2>/dev/null)" ] && break
            sleep 0.5
        done
    fi
    stop_pid "$DIR/slurmd.pid"
    stop_pid "$DIR/slurmctld.pid"
    stop_pid "$DIR/munged.pid"
    say "stopped"
}

case "$CMD" in
    install) install ;;
    start) start ;;
    status) installed && up ;;
    stop) stop ;;
    *) say "usage: $0 install|start|status|stop [DIR]"; exit 2 ;;
esac
