#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# The golden check (tests/m4/golden.h): run the M4 image under QEMU and the host build of the
# same cases, and compare their `case NAME n=COUNT digest=HEX` lines.
#
# Usage: golden_compare.sh [--limit S] IMAGE.elf HOST_EXE OUTDIR
#   --limit S  wall-clock bound of each side (default 120 s)
#
# Fails (1) when the image or the host exits non-zero, when either printed no case line,
# when the case sets differ, or when a case's line differs (both sides printed). Exit 77 when
# qemu-system-arm is missing (ctest SKIP), as tests/m4/qemu_run.sh. Prints
# "m4_golden: N cases agree" on success.
set -eu
limit=120
if [ "${1:-}" = --limit ]; then
    limit=$2
    shift 2
fi
[ $# -eq 3 ] || { echo "usage: golden_compare.sh [--limit S] IMAGE.elf HOST_EXE OUTDIR" >&2; exit 2; }
img=$1
host=$2
dir=$3
here=$(dirname "$0")
mkdir -p "$dir"
rc=0
# QEMU writes the semihosting console to its stderr: take both streams.
sh "$here/qemu_run.sh" --limit "$limit" "$img" >"$dir/m4.out" 2>&1 || rc=$?
[ "$rc" -eq 77 ] && exit 77
hrc=0
timeout -k 5 "$limit" "$host" >"$dir/host.out" || hrc=$?
grep '^case ' "$dir/m4.out" >"$dir/m4.cases" || true
grep '^case ' "$dir/host.out" >"$dir/host.cases" || true
fail=0
if [ "$rc" -ne 0 ]; then
    echo "golden_compare: the image exited $rc" >&2
    grep -v '^case ' "$dir/m4.out" | tail -20 >&2 || true
    fail=1
fi
if [ "$hrc" -ne 0 ]; then
    echo "golden_compare: the host exited $hrc" >&2
    grep -v '^case ' "$dir/host.out" | tail -20 >&2 || true
    fail=1
fi
nm4=$(wc -l <"$dir/m4.cases")
nhost=$(wc -l <"$dir/host.cases")
if [ "$nm4" -eq 0 ] || [ "$nhost" -eq 0 ]; then
    echo "golden_compare: no case lines (m4 $nm4, host $nhost)" >&2
    exit 1
fi
# Case names on each side, then every case of either side compared.
awk '{print $2}' "$dir/m4.cases" >"$dir/m4.names"
awk '{print $2}' "$dir/host.cases" >"$dir/host.names"
if ! cmp -s "$dir/m4.names" "$dir/host.names"; then
    echo "golden_compare: the case sets differ (m4 | host):" >&2
    diff "$dir/m4.names" "$dir/host.names" >&2 || true
    fail=1
fi
bad=0
for name in $(sort -u "$dir/m4.names" "$dir/host.names"); do
    a=$(awk -v n="$name" '$2 == n' "$dir/m4.cases")
    b=$(awk -v n="$name" '$2 == n' "$dir/host.cases")
    if [ "$a" != "$b" ]; then
        echo "MISMATCH $name" >&2
        echo "  m4:   ${a:-(missing)}" >&2
        echo "  host: ${b:-(missing)}" >&2
        bad=$((bad + 1))
    fi
done
cat "$dir/m4.cases"
if [ "$bad" -ne 0 ] || [ "$fail" -ne 0 ]; then
    echo "golden_compare: FAILED ($bad mismatching cases)" >&2
    exit 1
fi
echo "m4_golden: $nm4 cases agree"
