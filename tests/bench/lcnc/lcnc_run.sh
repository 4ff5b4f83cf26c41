#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Runs one part program through LinuxCNC's planner on the simulated benchmark machine
# (machine.ini, machine.hal, machine.tbl, run_lcnc.py) and writes the setpoints sampled every servo
# period (1 ms) to OUT.tsv: header "n x y z line" ("n x y z a line" on the XYZA machine),
# then one row per period (n = sample index from 0, x y z in mm, a in degrees, line =
# motion.program-line).
#
# Usage: lcnc_run.sh PROGRAM.ngc OUT.tsv
# Environment:
#   EF_LCNC_TIMEOUT  wall-clock limit of the whole run in seconds (default 600); the
#                    program itself may run for this minus 60 s
#   EF_LCNC_LOCK     lock file serializing LinuxCNC runs (default /tmp/evenfeed-linuxcnc.lock;
#                    only one LinuxCNC can run on a machine)
#   EF_LCNC_KEEP     set to 1 to keep the scratch directory (its path is printed)
#   EF_LCNC_TPMOD    planner module to load instead of LinuxCNC's ([TRAJ]TPMOD; it must be
#                    installed in LinuxCNC's module directory: docs/linuxcnc.md)
#   EF_LCNC_TRACE    with EF_LCNC_TPMOD=evenfeedtp: write the module's record of motmod's
#                    calls to this file (tests/lcnc/ replays such traces)
#   EF_LCNC_INI_SET  extra INI settings (keys that occur once in machine.ini), one "SECTION KEY VALUE" per line
#   EF_LCNC_ACTIONS  what run_lcnc.py does while the program runs (see there)
#   EF_LCNC_MACHINE  directory with another machine.ini and machine.hal (tests/lcnc/xyza:
#                    a rotary A axis; its samples have a column a after z)
# Exit status: 0 done; 77 LinuxCNC (linuxcnc, halsampler, Debian's python3 with the
# linuxcnc module) is not installed; 1 usage; 2 the run failed; 124 timeout (the LinuxCNC
# process group this script started was killed).
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)

if [ $# -ne 2 ]; then
    echo "usage: $0 PROGRAM.ngc OUT.tsv" >&2
    exit 1
fi
prog=$(realpath -- "$1")
out=$(realpath -m -- "$2")
if [ ! -r "$prog" ]; then
    echo "lcnc_run: cannot read $1" >&2
    exit 1
fi

# LinuxCNC's Python modules live in Debian's python3, not in any other python on PATH.
py=/usr/bin/python3
for tool in linuxcnc halsampler halcmd; do
    if ! command -v "$tool" >/dev/null 2>&1; then
        echo "lcnc_run: $tool not found: LinuxCNC is not installed (Debian 12: apt-get install linuxcnc-uspace)" >&2
        exit 77
    fi
done
if ! "$py" -c 'import linuxcnc' >/dev/null 2>&1; then
    echo "lcnc_run: $py cannot import linuxcnc: LinuxCNC is not installed (linuxcnc-uspace)" >&2
    exit 77
fi

limit=${EF_LCNC_TIMEOUT:-600}
if [ "$limit" -lt 90 ]; then
    echo "lcnc_run: EF_LCNC_TIMEOUT must be at least 90 s" >&2
    exit 1
fi

# One LinuxCNC at a time on this machine; wait for the lock at most the run's limit.
lock=${EF_LCNC_LOCK:-/tmp/evenfeed-linuxcnc.lock}
# (read-only: flock needs no write access, so users other than the creator share the file)
[ -e "$lock" ] || : >"$lock" || true
exec 9<"$lock"
if ! flock -w "$limit" 9; then
    echo "lcnc_run: another LinuxCNC run holds $lock for more than $limit s" >&2
    exit 2
fi
# A LinuxCNC not started through this script: linuxcnc would "clean up" (stop) it. Refuse
# instead; a lock file left by a crashed run (none of its processes alive) is LinuxCNC's
# own to clean up.
if [ -e /tmp/linuxcnc.lock ] && pidof -q milltask linuxcncsvr rtapi_app; then
    echo "lcnc_run: another LinuxCNC is running (/tmp/linuxcnc.lock); not starting a second" >&2
    exit 2
fi

run=$(mktemp -d "${TMPDIR:-/tmp}/ef_lcnc.XXXXXX")
lpid=
wpid=
# Every process this run starts inherits EF_LCNC_OUT (unique to the scratch directory),
# including rtapi_app and linuxcncsvr, which LinuxCNC starts in sessions of their own:
# ours() lists their PIDs, so what is left of a run can be stopped by PID, never by name.
marker="EF_LCNC_OUT=$run/samples.tsv"
ours() {
    grep -lzxF -- "$marker" /proc/[0-9]*/environ 2>/dev/null | sed 's|^/proc/\([0-9]*\)/environ$|\1|'
}
# Wait up to $1 seconds for every process of this run to exit, then KILL what is left.
reap() {
    local end=$((SECONDS + $1)) left
    while left=$(ours) && [ -n "$left" ]; do
        if [ $SECONDS -ge "$end" ]; then
            echo "lcnc_run: killing what is left of the run: PIDs ${left//$'\n'/ }" >&2
            # shellcheck disable=SC2086
            kill -KILL $left 2>/dev/null || true
            return
        fi
        sleep 0.1
    done
}
cleanup() {
    if [ -n "$wpid" ]; then kill "$wpid" 2>/dev/null || true; wait "$wpid" 2>/dev/null || true; fi
    if [ -n "$lpid" ]; then
        kill -TERM -- "-$lpid" 2>/dev/null || true
        reap 20
    fi
    if [ "${EF_LCNC_KEEP:-0}" = 1 ]; then
        echo "lcnc_run: scratch directory kept: $run" >&2
    else
        rm -rf "$run"
    fi
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# LinuxCNC writes its tool table, parameter and position files next to the INI file: it
# runs on copies in the scratch directory, never in the source tree.
mdir=${EF_LCNC_MACHINE:-$here}
cp "$mdir/machine.ini" "$mdir/machine.hal" "$here/machine.tbl" "$here/run_lcnc.py" "$run/"
# Another planner module ([TRAJ]TPMOD, e.g. evenfeedtp: docs/linuxcnc.md) and other INI
# settings: "SECTION KEY VALUE" lines in EF_LCNC_INI_SET, each added to its section.
tpmod=${EF_LCNC_TPMOD:-}
if [ -n "$tpmod" ] && [ -n "${EF_LCNC_TRACE:-}" ]; then
    tpmod="$tpmod trace=$run/tp.trace"
fi
if [ -n "$tpmod" ]; then
    sed -i "s|^\[TRAJ\]\$|[TRAJ]\nTPMOD = $tpmod|" "$run/machine.ini"
fi
if [ -n "${EF_LCNC_INI_SET:-}" ]; then
    while read -r sec key val; do
        [ -n "$sec" ] || continue
        sed -i "/^$key = /d; s|^\[$sec\]\$|[$sec]\n$key = $val|" "$run/machine.ini"
    done <<<"$EF_LCNC_INI_SET"
fi
chmod +x "$run/run_lcnc.py"
: >"$run/machine.var"

# The run's settings go to LinuxCNC's environment only (not this shell's: ours() must not
# find this script or its helpers).
lenv=(EF_LCNC_PROGRAM="$prog" "$marker" EF_LCNC_TIMEOUT=$((limit - 60))
      RTAPI_FIFO_PATH="$run/.rtapi_fifo")
if [ -n "${EF_LCNC_DEBUG:-}" ]; then lenv+=(EF_LCNC_DEBUG="$EF_LCNC_DEBUG"); fi
if [ -n "${EF_LCNC_ACTIONS:-}" ]; then lenv+=(EF_LCNC_ACTIONS="$EF_LCNC_ACTIONS"); fi
if [ "$(id -u)" = 0 ]; then
    # rtapi_app refuses to run as root without a user to fall back to
    uid=${RTAPI_UID:-65534}
    lenv+=(RTAPI_UID="$uid")
    chmod 755 "$run"
    chown "$uid" "$run"
fi
# No X display (LinuxCNC would try dialogs) and no terminal (it would ask questions).
unset DISPLAY

# LinuxCNC in a session (and process group) of its own: setsid execs linuxcnc in the
# background child, so $! is the group's id and a timeout can stop everything it started.
env "${lenv[@]}" setsid linuxcnc -r "$run/machine.ini" </dev/null >"$run/linuxcnc.log" 2>&1 &
lpid=$!
sleep "$limit" &
wpid=$!
set +e
wait -n "$lpid" "$wpid"
set -e
if kill -0 "$lpid" 2>/dev/null; then
    echo "lcnc_run: timeout after $limit s on $prog: stopping LinuxCNC (process group $lpid)" >&2
    # LinuxCNC's own clean-up runs on TERM; reap gives it 20 s, then kills what is left.
    kill -TERM -- "-$lpid" 2>/dev/null || true
    reap 20
    wait "$lpid" 2>/dev/null || true
    lpid=
    tail -n 20 "$run/linuxcnc.log" >&2 || true
    exit 124
fi
kill "$wpid" 2>/dev/null || true
wait "$wpid" 2>/dev/null || true
wpid=
set +e
wait "$lpid"
rc=$?
set -e
lpid=
# LinuxCNC's clean-up stops everything it started; wait until it has (the next run needs
# the machine free).
reap 20
if [ "$rc" -ne 0 ] || [ ! -s "$run/samples.tsv" ]; then
    echo "lcnc_run: LinuxCNC run of $prog failed (status $rc); its log:" >&2
    tail -n 40 "$run/linuxcnc.log" >&2 || true
    exit 2
fi
mv -f "$run/samples.tsv" "$out"
if [ -n "${EF_LCNC_TRACE:-}" ] && [ -n "${EF_LCNC_TPMOD:-}" ]; then
    cp "$run/tp.trace" "$EF_LCNC_TRACE"
fi
grep '^run_lcnc: \(ready\|done\)' "$run/linuxcnc.log" >&2 || true
