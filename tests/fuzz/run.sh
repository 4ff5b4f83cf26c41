#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Fuzz the table parser, the G-code reader, the runtime chain (smoother, planner,
# interpolator), the CANopen frame handling (drive and master) and what a USB-CAN adapter
# sends (gs_usb frames and replies) with libFuzzer for a fixed time.
#
#   tests/fuzz/run.sh [SECONDS [BUILD_DIR]]     default 60 s, build-fuzz
#
# Configures its own clang build directory (BUILD_DIR, or $EF_FUZZ_BUILD), builds
# fuzz_table_parse, fuzz_gcode, fuzz_smooth, fuzz_canopen and fuzz_gsusb (-fsanitize=fuzzer,address,undefined), and
# fuzzes each for an equal share of SECONDS (EF_FUZZ_TARGETS="table", "gcode", "smooth", "can" or "gsusb" picks
# some, which then share all of it), on a working copy of its seed corpus kept in that build directory, so coverage
# accumulates across runs while the checked-in corpora stay as they are. Crash reproducers
# go to $EF_FUZZ_BUILD/artifacts/; the script exits nonzero when a fuzzer finds one.
# EF_FUZZ_JOBS=N runs N processes (libFuzzer fork mode). EF_FUZZ_RUNS=N runs N inputs per
# target instead of the time share, and EF_FUZZ_SEED=S fixes libFuzzer's random seed: with
# both, on a fresh build directory (only the checked-in seeds), a run is the same on every
# machine, as `./dev test` (CI) needs; `./dev fuzz` stays random. Needs clang and libclang-rt-dev
# (the libFuzzer runtime). Warnings are not errors here: a fuzz run should not depend on
# the newest clang diagnostics.
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
runs=${EF_FUZZ_RUNS:-}
seed=${EF_FUZZ_SEED:-}
cc=${CC:-clang}
targets=${EF_FUZZ_TARGETS:-table gcode smooth can gsusb}

cmake -S "$root" -B "$build" -G Ninja -DCMAKE_C_COMPILER="$cc" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DEF_FUZZ=ON -DEF_WERROR=ON >/dev/null
ninja -C "$build" fuzz_table_parse fuzz_gcode fuzz_smooth fuzz_canopen fuzz_gsusb
mkdir -p "$build/artifacts"
n=0
for t in $targets; do n=$((n + 1)); done
each=$((secs / n))
[ "$each" -ge 1 ] || each=1

# fuzz BINARY SEEDS CORPUS [MORE_SEEDS]: one target for $each seconds; returns the fuzzer's
# status. MORE_SEEDS: a directory whose *.ngc files are seeds too (the reader's path corpus).
fuzz() {
    bin=$1 seeds=$2 corpus=$3 more=${4:-}
    mkdir -p "$corpus"
    cp "$seeds"/* "$corpus"/
    if [ -n "$more" ]; then
        cp "$more"/*.ngc "$corpus"/
    fi
    if [ -n "$runs" ]; then
        set -- -runs="$runs"
    else
        set -- -max_total_time="$each"
    fi
    set -- "$@" -print_final_stats=1 -artifact_prefix="$build/artifacts/"
    if [ -n "$seed" ]; then
        set -- "$@" -seed="$seed"
    fi
    if [ "$jobs" -gt 1 ]; then
        set -- "$@" -fork="$jobs"
    fi
    if [ -n "$runs" ]; then
        echo "fuzzing $bin for $runs runs${seed:+ (seed $seed)}, corpus $corpus"
    else
        echo "fuzzing $bin for ${each}s${seed:+ (seed $seed)}, corpus $corpus"
    fi
    st=0
    # libFuzzer reports every new corpus entry; keep that in a log and show its summary.
    log="$build/fuzz-$bin.log"
    # A seeded run also runs without address randomisation where the kernel allows it:
    # libFuzzer takes the operands of comparisons into its dictionary, stack addresses among
    # them, so with ASLR the same seed mutates differently from run to run.
    norand=
    if [ -n "$seed" ] && setarch "$(uname -m)" -R true 2>/dev/null; then
        norand="setarch $(uname -m) -R"
    fi
    $norand "$build/tests/$bin" "$@" "$corpus" >"$log" 2>&1 || st=$?
    grep -E '^(INFO: Seed|#[0-9]+[[:space:]]+DONE|Done [0-9]+ runs|stat::|INFO: fuzzed for)' "$log" || true
    # fork mode (EF_FUZZ_JOBS > 1) prints progress lines instead of the final stats
    [ "$jobs" -gt 1 ] && grep -E '^#[0-9]+: cov:' "$log" | tail -n 1 || true
    if [ "$st" -ne 0 ]; then
        tail -n 60 "$log" >&2
        echo "$bin failed (exit $st); reproducers in $build/artifacts/:" >&2
        ls -l "$build/artifacts/" >&2 || true
        # the reproducers themselves, so a CI log alone suffices to replay one (xxd -r -p)
        for f in "$build/artifacts/"*; do
            [ -f "$f" ] && [ "$(wc -c <"$f")" -le 8192 ] || continue
            echo "reproducer $(basename "$f") (hex):" >&2
            od -An -tx1 -v "$f" | tr -d ' \n' | fold -w 128 >&2
            echo >&2
        done
        echo "replay one with: $build/tests/$bin FILE" >&2
    fi
    return "$st"
}

status=0
for t in $targets; do
    case $t in
    table) fuzz fuzz_table_parse "$root/tests/fuzz/corpus" "$build/fuzz-corpus" || status=$? ;;
    gcode) fuzz fuzz_gcode "$root/tests/fuzz/corpus_gcode" "$build/fuzz-corpus-gcode" \
        "$root/tests/data/gcode" || status=$? ;;
    smooth) fuzz fuzz_smooth "$root/tests/fuzz/corpus_smooth" "$build/fuzz-corpus-smooth" || status=$? ;;
    can) fuzz fuzz_canopen "$root/tests/fuzz/corpus_canopen" "$build/fuzz-corpus-canopen" || status=$? ;;
    gsusb) fuzz fuzz_gsusb "$root/tests/fuzz/corpus_gsusb" "$build/fuzz-corpus-gsusb" || status=$? ;;
    *) echo "unknown fuzz target '$t' (table, gcode, smooth, can, gsusb)" >&2; exit 2 ;;
    esac
done
exit "$status"
