#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# evenfeed against LinuxCNC's planner (docs/benchmarks-linuxcnc.md): writes the generated
# corpus to BUILD_DIR/lcnc/corpus, then compares evenfeed and LinuxCNC on it and on
# samples/*.ngc, printing one row per program and the issue-18 goals. LinuxCNC's samples
# are cached in BUILD_DIR/lcnc/cache (by program sha256); the figures go to
# BUILD_DIR/lcnc/results.json. Without LinuxCNC it prints a note and succeeds.
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
exit "$rc"
