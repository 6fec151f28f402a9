#!/bin/bash
# Runs a command under a CPU quota, the way a container on a shared CI host runs: the kernel's
# CFS bandwidth control lets it use CORES cores' worth of time per 100 ms period and then
# stops every process of it until the next period. Timing races that a busy CI machine
# exposes, and that stress-ng beside a run does not, show up here.
#
#   tools/cpu_quota.sh CORES COMMAND [ARG...]     e.g.  tools/cpu_quota.sh 1.3 make test
#
# Needs root (it writes the cgroup file system), cgroup v2 with the cpu controller or cgroup
# v1's cpu hierarchy. The group is removed afterwards; the command's exit status is returned.
set -euo pipefail

usage() { echo "usage: $0 CORES COMMAND [ARG...]  (CORES > 0, e.g. 1.3)" >&2; exit 2; }
[ $# -ge 2 ] || usage
cores=$1; shift
period=100000
quota=$(awk -v c="$cores" -v p="$period" 'BEGIN { if (c + 0 <= 0) exit 1; printf "%d", c * p }') \
    || usage
if [ "$(id -u)" != 0 ]; then
    echo "$0: needs root to create a cgroup (try sudo)" >&2
    exit 2
fi

name="harvest_quota_$$"
if [ -f /sys/fs/cgroup/cgroup.controllers ]; then             # cgroup v2
    root=/sys/fs/cgroup
    grep -qw cpu "$root/cgroup.subtree_control" || echo +cpu > "$root/cgroup.subtree_control"
    group="$root/$name"
    mkdir "$group"
    echo "$quota $period" > "$group/cpu.max"
elif [ -d /sys/fs/cgroup/cpu ]; then                          # cgroup v1
    group="/sys/fs/cgroup/cpu/$name"
    mkdir "$group"
    echo "$period" > "$group/cpu.cfs_period_us"
    echo "$quota" > "$group/cpu.cfs_quota_us"
else
    echo "$0: no cgroup cpu controller on this machine" >&2
    exit 2
fi

cleanup() {
    # the command's processes have ended (or were left to the parent group): move any
    # stragglers out, then remove the group
    if [ -f "$group/cgroup.procs" ]; then
        while read -r pid; do
            echo "$pid" > "$(dirname "$group")/cgroup.procs" 2>/dev/null || true
        done < "$group/cgroup.procs"
    fi
    rmdir "$group" 2>/dev/null || echo "$0: could not remove $group" >&2
}
trap cleanup EXIT

echo "cpu_quota: ${cores} cores (${quota} us per ${period} us) for: $*" >&2
status=0
# a subshell joins the group first, then becomes the command
( echo "$BASHPID" > "$group/cgroup.procs" && exec "$@" ) || status=$?
exit "$status"
