#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# evenfeed against LinuxCNC's planner (docs/benchmarks-linuxcnc.md): writes the generated
# corpus to BUILD_DIR/lcnc/corpus, then compares evenfeed and LinuxCNC on it and on
# samples/*.ngc, printing one row per program and the issue-18 goals; then the same
# programs through LinuxCNC with evenfeed's planner module against LinuxCNC's own planner.
# LinuxCNC's own samples are cached in BUILD_DIR/lcnc/cache (by program sha256); the
# figures go to BUILD_DIR/lcnc/results.json and results-tpmod.json. Without LinuxCNC it
# prints a note and succeeds.
# Usage: run.sh BUILD_DIR [extra evenfeed smooth argument, e.g. --jerk=0]...
set -euo pipefail
if [ $# -lt 1 ]; then
    echo "usage: $0 BUILD_DIR [--evenfeed-arg ARG]..." >&2
    exit 1
fi
b=$(cd "$1" && pwd)
shift
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
out=$b/lcnc
mkdir -p "$out/corpus"

list=$(python3 "$here/corpus_gen.py" "$out/corpus")
mapfile -t progs <<<"$list"
progs+=("$root"/samples/*.ngc)
extra=()
for a in "$@"; do extra+=(--evenfeed-arg="$a"); done

set +e
python3 "$here/compare.py" --evenfeed "$b/host/evenfeed" --work "$out" \
    --json "$out/results.json" "${extra[@]}" "${progs[@]}"
rc=$?
set -e
if [ "$rc" -eq 77 ]; then
    echo "(LinuxCNC comparison skipped: LinuxCNC is not installed; Debian 12: apt-get install linuxcnc-uspace)"
    exit 0
fi
[ "$rc" -eq 0 ] || exit "$rc"

# The same programs through LinuxCNC itself, its own planner and evenfeed's planner module
# (evenfeedtp, docs/linuxcnc.md) side by side: installed into LinuxCNC's module directory
# first (root); skipped where the module was not built (no linuxcnc-uspace-dev) or cannot be
# installed. Only the first comparison's extra evenfeed arguments apply to evenfeed smooth.
mod=$b/host/linuxcnc/evenfeedtp.so
moddir=/usr/lib/linuxcnc/modules
echo
echo "== evenfeed as LinuxCNC's planner module ([TRAJ]TPMOD = evenfeedtp) against LinuxCNC's own"
if [ ! -f "$mod" ]; then
    echo "(skipped: $mod not built; Debian 12: apt-get install linuxcnc-uspace-dev)"
    exit 0
fi
# (a new file renamed over the old one: a running LinuxCNC keeps the module it mapped)
if ! cmp -s "$mod" "$moddir/evenfeedtp.so" &&
    ! { cp "$mod" "$moddir/.evenfeedtp.so.tmp" && mv -f "$moddir/.evenfeedtp.so.tmp" "$moddir/evenfeedtp.so"; }; then
    echo "(skipped: cannot install the module into $moddir: run as root, or ./dev linuxcnc)"
    exit 0
fi
python3 "$here/compare.py" --evenfeed "$b/host/evenfeed" --work "$out" --tpmod evenfeedtp \
    --json "$out/results-tpmod.json" "${progs[@]}"
