#!/bin/sh
# Fuzz the table parser with libFuzzer for a fixed time.
#
#   tests/fuzz/run.sh [SECONDS [BUILD_DIR]]     default 60 s, build-fuzz
#
# Configures its own clang build directory (BUILD_DIR, or $EF_FUZZ_BUILD), builds
# fuzz_table_parse (-fsanitize=fuzzer,address,undefined), and fuzzes a working copy of the
# seed corpus kept in that build directory, so coverage accumulates across runs while the
# checked-in corpus stays as generated. Crash reproducers go to $EF_FUZZ_BUILD/artifacts/;
# the script exits nonzero when the fuzzer finds one. EF_FUZZ_JOBS=N runs N processes
# (libFuzzer fork mode). Needs clang and libclang-rt-dev (the libFuzzer runtime). Warnings
# are not errors here: a fuzz run should not depend on the newest clang diagnostics.
set -eu

secs=${1:-60}
case $secs in
'' | *[!0-9]*) echo "usage: $0 [SECONDS [BUILD_DIR]]" >&2; exit 2 ;;
esac
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${2:-${EF_FUZZ_BUILD:-$root/build-fuzz}}
mkdir -p "$build"
build=$(cd "$build" && pwd)
jobs=${EF_FUZZ_JOBS:-1}
cc=${CC:-clang}

cmake -S "$root" -B "$build" -G Ninja -DCMAKE_C_COMPILER="$cc" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DEF_FUZZ=ON -DEF_WERROR=ON >/dev/null
ninja -C "$build" fuzz_table_parse

corpus=$build/fuzz-corpus
mkdir -p "$corpus" "$build/artifacts"
cp "$root"/tests/fuzz/corpus/* "$corpus"/

set -- -max_total_time="$secs" -print_final_stats=1 -artifact_prefix="$build/artifacts/"
if [ "$jobs" -gt 1 ]; then
    set -- "$@" -fork="$jobs"
fi
echo "fuzzing for ${secs}s, corpus $corpus"
status=0
# libFuzzer reports every new corpus entry; keep that in a log and show its summary.
log="$build/fuzz.log"
"$build/tests/fuzz_table_parse" "$@" "$corpus" >"$log" 2>&1 || status=$?
grep -E '^(INFO: Seed|#[0-9]+[[:space:]]+DONE|Done [0-9]+ runs|stat::)' "$log" || true
if [ "$status" -ne 0 ]; then
    tail -n 60 "$log" >&2
    echo "fuzzer failed (exit $status); reproducers in $build/artifacts/:" >&2
    ls -l "$build/artifacts/" >&2 || true
    echo "replay one with: $build/tests/fuzz_table_parse FILE" >&2
fi
exit "$status"
