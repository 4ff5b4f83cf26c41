#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Run one Cortex-M4F test image under QEMU's MPS2 AN386 board with the semihosting console
# on stdout and the image's exit status as ours (ef_m4.h).
#
# Usage: qemu_run.sh [--limit SECONDS] [--shift N] IMAGE.elf [OUT]
#   OUT        also write the console to this file
#   --limit S  wall-clock bound (default 300): a hung image is killed and the run fails (124)
#   --shift N  icount shift (default 10); the image's EF_M4_ICOUNT_SHIFT must match
#
# -icount shift=N,sleep=off: the virtual clock advances 2^N ns per executed instruction,
# whatever the host's load, so the images' instruction counts are exact and repeatable.
# The timers run at 25 MHz of that clock: at shift 10 a millisecond is only ~977
# instructions, so an image with a 1 kHz interrupt (firmware/examples) runs at shift 3,
# 8 ns per instruction, 125 000 instructions a millisecond.
# Exit: the image's status; 124 timed out; 77 qemu-system-arm not installed (ctest SKIP,
# unless EF_M4_REQUIRED=1, as ./dev test sets, makes it a failure: 2).
set -eu
limit=300
icount_shift=10
while [ $# -ge 2 ]; do
    case $1 in
    --limit) limit=$2 ;;
    --shift) icount_shift=$2 ;;
    *) break ;;
    esac
    shift 2
done
[ $# -ge 1 ] || { echo "usage: qemu_run.sh [--limit S] [--shift N] IMAGE.elf [OUT]" >&2; exit 2; }
img=$1
out=${2:-}
qemu=${EF_QEMU_ARM:-qemu-system-arm}
if ! command -v "$qemu" >/dev/null 2>&1; then
    echo "qemu_run.sh: $qemu not found (Debian: qemu-system-arm)" >&2
    [ "${EF_M4_REQUIRED:-0}" = 1 ] && exit 2
    exit 77
fi
[ -f "$img" ] || { echo "qemu_run.sh: no image $img" >&2; exit 2; }
set -- "$qemu" -M mps2-an386 -nographic -monitor none -serial none \
    -semihosting-config enable=on,target=native -icount shift="$icount_shift",sleep=off -kernel "$img"
rc=0
if [ -n "$out" ]; then
    # QEMU writes the semihosting console to its stderr.
    timeout -k 5 "$limit" "$@" >"$out" 2>&1 || rc=$?
    cat "$out"
else
    timeout -k 5 "$limit" "$@" || rc=$?
fi
if [ "$rc" -eq 124 ] || [ "$rc" -eq 137 ]; then
    echo "qemu_run.sh: $img ran past ${limit} s" >&2
    exit 124
fi
exit "$rc"
