#!/usr/bin/env bash
# A real one-node SLURM cluster on this machine, from Debian's packages, for testing the
# `--executor slurm` profile (profiles/slurm) without a real cluster.
#
#   scripts/local-slurm.sh up       install if missing, configure, start munged+slurmctld+slurmd,
#                                   wait until the node is idle; prints how long it took
#   scripts/local-slurm.sh status   exit 0 only if the node is up AND a trivial job completes
#   scripts/local-slurm.sh down     stop slurmd, slurmctld and munged
#
# No systemd, no cgroups, no database: proctrack/linuxproc, task/none, accounting_storage/none
# (the Snakemake SLURM plugin then queries job states with `squeue`, see docs/cluster.md), and
# jobcomp/filetxt so every finished job is recorded in /var/log/slurm/jobcomp.log.
# Needs root (or sudo). Idempotent: `up` on a running cluster only checks it.
set -euo pipefail

PARTITION=creatio
CLUSTER=creatio
CONF_DIR=/etc/slurm
CONF=$CONF_DIR/slurm.conf
MARKER="# written by creatio scripts/local-slurm.sh"
LOG_DIR=/var/log/slurm
RUN_DIR=/run/slurm
CTLD_SPOOL=/var/spool/slurmctld
SLURMD_SPOOL=/var/spool/slurmd
JOBCOMP=$LOG_DIR/jobcomp.log
MUNGE_KEY=/etc/munge/munge.key
MUNGE_PID=/run/munge/munged.pid
CTLD_PID=$RUN_DIR/slurmctld.pid
SLURMD_PID=$RUN_DIR/slurmd.pid
PACKAGES=(munge slurm-client slurmctld slurmd)
UP_TIMEOUT=${LOCAL_SLURM_TIMEOUT:-60}

say() { echo "local-slurm: $*" >&2; }

# Fail loudly: the exact command, its output, and the end of the daemon logs
# (not_running: the same without the logs, for `status` on a cluster that is simply down).
not_running() {
    echo "local-slurm: FAILED: $1" >&2
    printf '%s\n' "$2" | sed 's/^/  | /' >&2
    exit 1
}

die() {
    local cmd=$1 out=${2:-}
    {
        echo "local-slurm: FAILED: $cmd"
        [[ -n $out ]] && printf '%s\n' "$out" | sed 's/^/  | /'
        for f in "$LOG_DIR/slurmctld.log" "$LOG_DIR/slurmd.log" /var/log/munge/munged.log; do
            if [[ -s $f ]]; then
                echo "  --- last lines of $f"
                tail -n 15 "$f" | sed 's/^/  | /'
            fi
        done
    } >&2
    exit 1
}

# Run a command; on failure, die with the command and everything it printed.
run() {
    local out
    if ! out=$("$@" 2>&1); then
        die "$*" "$out"
    fi
    [[ -z ${LOCAL_SLURM_VERBOSE:-} || -z $out ]] || printf '%s\n' "$out" >&2
}

# up and down need root (or passwordless sudo); status does not.
SUDO=()
need_root() {
    if [[ $(id -u) -ne 0 ]]; then
        command -v sudo >/dev/null || die "id -u" "not root and no sudo: run as root"
        SUDO=(sudo -n)
    fi
}
as_root() { run "${SUDO[@]}" "$@"; }

now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }'; }

# A daemon is alive if its pid file names a live process (a zombie is not: there may be no
# init to reap daemons in a container or micro-VM).
alive() {
    local pid stat
    pid=$(cat "$1" 2>/dev/null) || return 1
    [[ $pid =~ ^[0-9]+$ ]] || return 1
    stat=$(ps -o stat= -p "$pid" 2>/dev/null) || return 1
    [[ -n $stat && $stat != Z* ]]
}

install_packages() {
    local missing=() p
    for p in "${PACKAGES[@]}"; do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" \
            || missing+=("$p")
    done
    [[ ${#missing[@]} -eq 0 ]] && return 0
    command -v apt-get >/dev/null || die "apt-get" "missing ${missing[*]} and no apt-get"
    say "installing ${missing[*]} (apt-get)"
    local t0 out
    t0=$(now)
    export DEBIAN_FRONTEND=noninteractive
    if ! out=$("${SUDO[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}" 2>&1)
    then
        say "apt-get install failed; apt-get update and retry"
        as_root apt-get update -q
        as_root apt-get install -y -q --no-install-recommends "${missing[@]}"
    fi
    say "installed in $(since "$t0") s"
}

start_munge() {
    if [[ ! -s $MUNGE_KEY ]]; then
        as_root install -d -o munge -g munge -m 0700 /etc/munge
        if command -v mungekey >/dev/null; then
            as_root mungekey --create --keyfile "$MUNGE_KEY"
        else
            as_root dd if=/dev/urandom of="$MUNGE_KEY" bs=1 count=1024 status=none
        fi
        as_root chown munge:munge "$MUNGE_KEY"
        as_root chmod 0400 "$MUNGE_KEY"
    fi
    as_root install -d -o munge -g munge -m 0755 /run/munge
    as_root install -d -o munge -g munge -m 0700 /var/log/munge /var/lib/munge
    if ! alive "$MUNGE_PID"; then
        as_root runuser -u munge -- /usr/sbin/munged
    fi
    local out
    out=$(munge -n 2>&1 | unmunge 2>&1) || die "munge -n | unmunge" "$out"
}

write_conf() {
    local node cpu_line out
    node=$(hostname -s)
    # slurmd -C prints this machine's real CPUs/sockets/cores/threads/RealMemory.
    out=$(slurmd -C 2>&1) || die "slurmd -C" "$out"
    cpu_line=$(printf '%s\n' "$out" | grep '^NodeName=' | head -n 1 | sed 's/^NodeName=[^ ]* //')
    [[ -n $cpu_line ]] || die "slurmd -C" "no NodeName= line in: $out"
    cpu_line=$(printf '%s' "$cpu_line" | sed 's/ UpTime=.*//')

    if [[ -e $CONF ]] && ! grep -qF "$MARKER" "$CONF"; then
        die "grep -F '$MARKER' $CONF" \
            "$CONF exists and was not written by this script: refusing to overwrite a real cluster's config"
    fi
    local tmp
    tmp=$(mktemp)
    cat >"$tmp" <<EOF
$MARKER: a one-node test cluster
# (no systemd, no cgroups, no accounting database).
ClusterName=$CLUSTER
SlurmctldHost=$node(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$CTLD_SPOOL
SlurmdSpoolDir=$SLURMD_SPOOL
SlurmctldPidFile=$CTLD_PID
SlurmdPidFile=$SLURMD_PID
SlurmctldLogFile=$LOG_DIR/slurmctld.log
SlurmdLogFile=$LOG_DIR/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
# Container/VM friendly: track processes by parent pid, no task binding, no cgroup plugins.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
MpiDefault=none
SwitchType=switch/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
DefMemPerCPU=1000
ReturnToService=2
MailProg=/bin/true
# No slurmdbd: sacct has no data; finished jobs stay visible to squeue for MinJobAge s,
# and each finished job is appended to the jobcomp file.
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$JOBCOMP
MinJobAge=300
InactiveLimit=0
KillWait=10
Waittime=0
SlurmctldTimeout=60
SlurmdTimeout=120
NodeName=$node NodeAddr=127.0.0.1 $cpu_line State=UNKNOWN
PartitionName=$PARTITION Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
    as_root install -d -m 0755 "$CONF_DIR" "$RUN_DIR" "$LOG_DIR" "$CTLD_SPOOL" "$SLURMD_SPOOL"
    if [[ -e $CONF ]] && cmp -s "$tmp" "$CONF"; then
        rm -f "$tmp"
        return 1  # unchanged
    fi
    as_root install -m 0644 "$tmp" "$CONF"
    rm -f "$tmp"
    return 0  # changed
}

node_state() {
    sinfo -h -N -p "$PARTITION" -o '%T' 2>/dev/null | head -n 1
}

wait_idle() {
    local t0=$SECONDS state="" resumed=""
    while ((SECONDS - t0 < UP_TIMEOUT)); do
        if ((SECONDS - t0 >= 2)); then
            alive "$CTLD_PID" || die "slurmctld" "slurmctld exited right after starting"
            alive "$SLURMD_PID" || die "slurmd -N $(hostname -s)" "slurmd exited right after starting"
        fi
        state=$(node_state || true)
        case $state in
            idle | mixed | allocated | completing) return 0 ;;
            down* | drain* | fail*)
                # A node left down by an earlier run (killed daemons): resume it once; if it
                # stays down, SLURM's reason says why.
                if [[ -z $resumed ]]; then
                    resumed=$SECONDS
                    "${SUDO[@]}" scontrol update nodename="$(hostname -s)" state=resume \
                        >/dev/null 2>&1 || true
                elif ((SECONDS - resumed > 10)); then
                    break
                fi
                ;;
        esac
        sleep 0.5
    done
    die "sinfo -N -p $PARTITION (node not idle after $((SECONDS - t0)) s)" \
        "state: '${state:-none}'
$(sinfo -R 2>&1)
$(scontrol show node 2>&1 | head -n 20)"
}

cmd_up() {
    local t0 changed=0
    t0=$(now)
    need_root
    install_packages
    start_munge
    write_conf && changed=1
    if ((changed)) && { alive "$CTLD_PID" || alive "$SLURMD_PID"; }; then
        say "slurm.conf changed: restarting the daemons"
        stop_slurm
    fi
    if ! alive "$CTLD_PID"; then
        as_root slurmctld
    fi
    if ! alive "$SLURMD_PID"; then
        as_root slurmd -N "$(hostname -s)"
    fi
    wait_idle
    say "up in $(since "$t0") s: partition '$PARTITION', node $(hostname -s)" \
        "($(sinfo -h -N -o '%c CPUs, %m MB' | head -n 1))"
}

stop_slurm() {
    if alive "$CTLD_PID"; then
        # Stops slurmctld and every slurmd it knows.
        "${SUDO[@]}" scontrol shutdown >/dev/null 2>&1 || true
    fi
    local pidfile pid i
    for pidfile in "$SLURMD_PID" "$CTLD_PID"; do
        for i in $(seq 1 40); do
            alive "$pidfile" || break
            if ((i == 10)); then
                "${SUDO[@]}" kill "$(cat "$pidfile" 2>/dev/null)" 2>/dev/null || true
            fi
            sleep 0.25
        done
        if alive "$pidfile"; then
            pid=$(cat "$pidfile" 2>/dev/null)
            say "$pidfile: pid $pid ignores SIGTERM, sending SIGKILL"
            "${SUDO[@]}" kill -9 "$pid" 2>/dev/null || true
        fi
    done
}

cmd_down() {
    local t0
    t0=$(now)
    need_root
    if command -v scontrol >/dev/null; then
        stop_slurm
    fi
    if alive "$MUNGE_PID"; then
        "${SUDO[@]}" kill "$(cat "$MUNGE_PID" 2>/dev/null)" 2>/dev/null || true
        for _ in $(seq 1 40); do alive "$MUNGE_PID" || break; sleep 0.25; done
    fi
    say "down in $(since "$t0") s"
}

cmd_status() {
    local state out t0
    command -v sinfo >/dev/null \
        || not_running "command -v sinfo" "SLURM is not installed (run: $0 up)"
    alive "$MUNGE_PID" || not_running "ps -p \$(cat $MUNGE_PID)" "munged is not running (run: $0 up)"
    alive "$CTLD_PID" || not_running "ps -p \$(cat $CTLD_PID)" "slurmctld is not running (run: $0 up)"
    alive "$SLURMD_PID" || not_running "ps -p \$(cat $SLURMD_PID)" "slurmd is not running (run: $0 up)"
    out=$(scontrol ping 2>&1) || die "scontrol ping" "$out"
    state=$(node_state || true)
    case $state in
        idle | mixed | allocated | completing) ;;
        *) die "sinfo -h -N -p $PARTITION -o %T" "node state '${state:-none}'
$(sinfo -R 2>&1)" ;;
    esac
    t0=$(now)
    out=$(timeout 60 srun -p "$PARTITION" -N1 -n1 -t 1 --mem=50 true 2>&1) \
        || die "srun -p $PARTITION -N1 -n1 -t 1 --mem=50 true" "$out"
    echo "local-slurm: up: partition '$PARTITION', node $(hostname -s) $state;" \
        "srun -N1 true took $(since "$t0") s"
}

case ${1:-} in
    up) cmd_up ;;
    down) cmd_down ;;
    status) cmd_status ;;
    *)
        echo "usage: $0 up|down|status" >&2
        exit 2
        ;;
esac
