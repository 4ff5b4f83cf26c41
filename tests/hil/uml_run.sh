#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Hardware-in-loop runner: boot User-Mode Linux on the host's own file system (hostfs), bring
# up virtual CAN interfaces, run a guest script inside it, and judge its verdict file.
#
#   uml_run.sh GUEST_SCRIPT VERDICT_FILE TIMEOUT_S [ARGS...]
#
# The guest runs `sh GUEST_SCRIPT ARGS...` (cwd: the caller's, environment: EF_HIL_DIR,
# EF_HIL_RUN (this run's directory), plus ASAN_OPTIONS / UBSAN_OPTIONS / EF_HIL_PASS_ENV
# names copied from here). Its output and a last line "PASS" (exit 0) or "FAIL ..." go to
# VERDICT_FILE. The host side prints that file and exits 0 only on PASS; 1 on failure or
# time-out (whole run bounded by TIMEOUT_S); 77 (skip) when linux.uml is missing, unless
# CI or EF_HIL_REQUIRE is set, which makes a missing UML a failure.
#
# The kernel is the project's HIL kernel (tests/hil/build_kernel.sh: vcan, gpio-sim,
# dummy_hcd, configfs, FunctionFS, gs_usb built in), or Debian's linux.uml with its modules
# (vcan only) when EF_UML names it. Built-in drivers need no insmod: the guest loads modules
# only where the kernel has a module tree.
#
# Environment (all optional):
#   EF_UML            UML kernel (default: build/hil-kernel/linux of this checkout; built by
#                     `bash tests/hil/build_kernel.sh build/hil-kernel`, which ./dev test runs)
#   EF_HIL_MEM        guest memory (default 256M). AddressSanitizer cannot run in the guest
#                     at any size (UML 6.1 gives processes 512 GiB of address space; ASan's
#                     shadow needs 16 TiB): build guest binaries without -fsanitize=address.
#   EF_HIL_VCAN       number of vcan interfaces, vcan0.. (default 1)
#   EF_HIL_TXQLEN     txqueuelen set on each vcan (default: the driver's)
#   EF_HIL_VCAN_ECHO  1: load vcan with echo=1 (driver-side loopback, like real hardware)
#   EF_HIL_MODULES    extra kernel modules to load by name (e.g. "sch_plug sch_tbf vxcan")
#   EF_HIL_PASS_ENV   names of further variables to copy into the guest
#   EF_HIL_NICE       niceness of the machine on the host (default -10 where permitted; 0:
#                     the caller's), so host load starves it less (docs/hil.md)
#   EF_HIL_TMP        where the run directory is made (default: VERDICT_FILE's directory)
#   EF_HIL_KEEP       1: keep the run directory after a pass (always kept after a failure)
set -u

if [ $# -lt 3 ]; then
    echo "usage: $0 GUEST_SCRIPT VERDICT_FILE TIMEOUT_S [ARGS...]" >&2
    exit 2
fi
script=$1
verdict=$2
limit=$3
shift 3

abspath() { # absolute form of a path (the guest sees the host's / as its own)
    case $1 in
    /*) printf '%s\n' "$1" ;;
    *) printf '%s/%s\n' "$PWD" "$1" ;;
    esac
}
script=$(abspath "$script")
verdict=$(abspath "$verdict")
here=$(cd "$(dirname "$0")" && pwd)

uml=${EF_UML:-$(cd "$here/../.." && pwd)/build/hil-kernel/linux}
if [ ! -x "$uml" ]; then
    if [ -n "${CI:-}" ] || [ -n "${EF_HIL_REQUIRE:-}" ]; then
        echo "FAIL: User-Mode Linux kernel '$uml' not found, and CI/EF_HIL_REQUIRE demands the" \
            "HIL tests run (build it: bash tests/hil/build_kernel.sh build/hil-kernel)" >&2
        exit 1
    fi
    echo "SKIP: User-Mode Linux kernel '$uml' not found: build it with" \
        "'bash tests/hil/build_kernel.sh build/hil-kernel' (./dev test does) to run the" \
        "hardware-in-loop tests"
    exit 77
fi
if [ ! -r "$script" ]; then
    echo "FAIL: guest script $script not readable" >&2
    exit 1
fi
case $limit in
'' | *[!0-9]*)
    echo "FAIL: TIMEOUT_S '$limit' is not a whole number of seconds" >&2
    exit 2
    ;;
esac

base=${EF_HIL_TMP:-$(dirname "$verdict")}
mkdir -p "$base" "$(dirname "$verdict")" || exit 1
run=$(mktemp -d "$base/uml-run.XXXXXX") || exit 1
rm -f "$verdict"

# The guest's own bound leaves time for booting and powering off, so a hung guest script
# still yields a verdict (with its output) instead of a killed machine.
glimit=$((limit - 15))
[ "$glimit" -lt 5 ] && glimit=5

quote() { # one shell word, single-quoted
    printf "'%s'" "$(printf '%s' "$1" | sed "s/'/'\\\\''/g")"
}
args=""
for a in "$@"; do args="$args $(quote "$a")"; done
passenv=""
for v in ASAN_OPTIONS UBSAN_OPTIONS LSAN_OPTIONS ${EF_HIL_PASS_ENV:-}; do
    if [ -n "${!v+x}" ]; then
        passenv="${passenv}export $v=$(quote "${!v}")
"
    fi
done

cat >"$run/init.sh" <<INIT
#!/bin/sh
# Guest init (PID 1), written by uml_run.sh.
export PATH=/usr/sbin:/sbin:/usr/bin:/bin HOME=/root
export EF_HIL_DIR=$(quote "$here") EF_HIL_RUN=$(quote "$run")
$passenv
out=$(quote "$run/guest.log")
fin() { # verdict: the guest's output and a last line PASS / FAIL, then power off
    { cat "\$out"; echo "\$1"; } >$(quote "$verdict.tmp") && mv $(quote "$verdict.tmp") $(quote "$verdict")
    sync
    poweroff -f
}
mount -t proc proc /proc && mount -t sysfs sys /sys || fin "FAIL: mounting /proc, /sys"
mount -t tmpfs tmp /run 2>/dev/null
# configfs (gpio-sim, USB gadgets) where the kernel has it; devtmpfs is on /dev already
# (DEVTMPFS_MOUNT) in the project's kernel.
grep -qw configfs /proc/filesystems && mount -t configfs none /sys/kernel/config 2>/dev/null
M=/usr/lib/uml/modules/\$(uname -r)
echo "guest: kernel \$(uname -r), \$(nproc) cpu, \$(awk '/MemTotal/ {print \$2 " kB"}' /proc/meminfo)" >"\$out"
ko() { # load a module by name from the UML module tree (none: the kernel has it built in)
    [ -d "\$M" ] || return 0
    f=\$(find "\$M" -name "\$1.ko" | head -n 1)
    [ -n "\$f" ] || { echo "guest: module \$1 not found under \$M" >>"\$out"; return 1; }
    shift
    insmod "\$f" "\$@" >>"\$out" 2>&1 || { echo "guest: insmod \$f failed" >>"\$out"; return 1; }
}
echo_opt=""
[ "${EF_HIL_VCAN_ECHO:-0}" = 1 ] && echo_opt="echo=1"
echo "guest: drivers \$([ -d "\$M" ] && echo "modules from \$M" || echo "built in")" >>"\$out"
ok=1
ko can-dev && ko can && ko can-raw && ko vcan \$echo_opt || ok=0
for m in ${EF_HIL_MODULES:-}; do ko "\$m" || ok=0; done
[ \$ok = 1 ] || fin "FAIL: loading kernel modules"
ip link set lo up
i=0
while [ \$i -lt ${EF_HIL_VCAN:-1} ]; do
    ip link add dev vcan\$i type vcan >>"\$out" 2>&1 || fin "FAIL: ip link add vcan\$i"
    if [ -n "${EF_HIL_TXQLEN:-}" ]; then
        ip link set vcan\$i txqueuelen ${EF_HIL_TXQLEN:-} >>"\$out" 2>&1 || fin "FAIL: txqueuelen"
    fi
    ip link set vcan\$i up >>"\$out" 2>&1 || fin "FAIL: ip link set vcan\$i up"
    i=\$((i + 1))
done
cd $(quote "$PWD") || fin "FAIL: cd"
t0=\$(date +%s.%N)
timeout -k 5 $glimit sh $(quote "$script")$args </dev/null >>"\$out" 2>&1
rc=\$?
t1=\$(date +%s.%N)
echo "guest: script exit \$rc after \$(awk "BEGIN { printf \\"%.2f\\", \$t1 - \$t0 }") s" >>"\$out"
case \$rc in
0) fin PASS ;;
124 | 137) fin "FAIL: guest script timed out after $glimit s" ;;
*) fin "FAIL: guest script exit status \$rc" ;;
esac
INIT
chmod +x "$run/init.sh"

# Parameters of built-in drivers come on the command line (a module gets them from insmod).
cmdline=""
[ "${EF_HIL_VCAN_ECHO:-0}" = 1 ] && cmdline="vcan.echo=1"
# The guest stands for a machine with a CPU of its own: its drives, adapter and master keep
# real-time periods (1 to 40 ms) that a host loaded by other work (ctest -j, builds) would
# starve, by seconds, as one process among many. Where the host lets us (root, or
# CAP_SYS_NICE), the machine runs at a higher priority (nice -10: a larger CFS share, never
# real-time, so a runaway guest cannot lock the host up); elsewhere as it is.
# EF_HIL_NICE sets the niceness (default -10; 0: as the caller).
nv=${EF_HIL_NICE:--10}
prio=""
[ "$nv" != 0 ] && nice -n "$nv" true 2>/dev/null && [ "$(nice -n "$nv" nice)" -lt "$(nice)" ] &&
    prio="nice -n $nv"
start=$(date +%s.%N)
# timeout signals its whole process group, so the machine's helper processes end with it.
$prio timeout -k 5 "$limit" "$uml" mem="${EF_HIL_MEM:-256M}" root=/dev/root rootfstype=hostfs \
    rootflags=/ rw init="$run/init.sh" con=null ssl=null con0=fd:0,fd:1 uml_dir="$run" \
    umid=efhil quiet loglevel=3 $cmdline </dev/null >"$run/console.log" 2>&1
urc=$?
end=$(date +%s.%N)
secs=$(awk "BEGIN { printf \"%.1f\", $end - $start }")

status=1
if [ -r "$verdict" ]; then
    echo "---- guest log ($verdict) ----"
    cat "$verdict"
    echo "----"
    if [ "$(tail -n 1 "$verdict")" = PASS ]; then
        status=0
    fi
elif [ "$urc" = 124 ] || [ "$urc" = 137 ]; then
    echo "FAIL: the machine ran past $limit s and was stopped; no verdict"
else
    echo "FAIL: no verdict written (linux.uml exit status $urc)"
fi
if [ $status != 0 ]; then
    echo "---- console (last 60 lines of $run/console.log) ----"
    tail -n 60 "$run/console.log" | tr -d '\r'
    [ -r "$run/guest.log" ] && [ ! -r "$verdict" ] && { echo "---- guest.log ----"; cat "$run/guest.log"; }
    echo "FAIL: $(basename "$script") in UML (${secs} s; run directory $run kept)"
    exit 1
fi
echo "PASS: $(basename "$script") in UML (${secs} s)"
[ "${EF_HIL_KEEP:-0}" = 1 ] || rm -rf "$run"
exit 0
