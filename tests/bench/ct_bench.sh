#!/bin/sh
# Constant-time check of ef_seg_g1_cubic / ef_seg_g2_quintic / ef_blend_corner by
# instruction count.
#
# Usage: ct_bench.sh [--targets] [--verify] [--keep DIR] BENCH N KIND...
#   BENCH     the bench_ct binary (this script builds nothing)
#   N         calls per kind (random valid configurations, fixed seed)
#   KIND      g1, g2 or blend (ef_blend_corner) (several may be given; each is run and checked)
#   --targets also fail if the max count is above the targets (G1 400, G2 1500)
#   --verify  also run once without per-call dumps and check that the single dump's total,
#             and callgrind_annotate's inclusive count for the function, equal the sum of
#             the per-call dumps (that is, each dump is exactly one call, callees included)
#   --keep D  copy the per-call dumps to D instead of deleting them (for callgrind_annotate)
#
# Each call runs between CALLGRIND_ZERO_STATS and CALLGRIND_DUMP_STATS under
# --collect-atstart=no --toggle-collect=FUNCTION, so every dump's "totals:" line is the
# instruction count of exactly one call. Callgrind counts are deterministic, so the ratio
# is not a timing measurement and does not flake.
#
# Prints "G1 cubic: N calls, instructions min X median Y max Z, max/min R" per kind.
# Exit status: 0 pass, 1 ratio above 1.02 (or a target missed with --targets, or a
# failed verification), 2 usage or run error, 77 valgrind not installed (ctest SKIP).
set -eu

MAX_RATIO=1.02
TARGET_G1=400
TARGET_G2=1500
# No target was set for corner blends; this one is the G2 segment's.
TARGET_BLEND=1500

targets=0
verify=0
keep=
while [ $# -gt 0 ]; do
    case "$1" in
    --targets) targets=1; shift ;;
    --verify) verify=1; shift ;;
    --keep) keep=$2; shift 2 ;;
    --) shift; break ;;
    -*) echo "ct_bench.sh: unknown option $1" >&2; exit 2 ;;
    *) break ;;
    esac
done
if [ $# -lt 3 ]; then
    echo "usage: ct_bench.sh [--targets] [--verify] [--keep DIR] BENCH N g1|g2|blend..." >&2
    exit 2
fi
bench=$1
n=$2
shift 2

if ! command -v valgrind >/dev/null 2>&1; then
    echo "ct_bench.sh: valgrind not found, constant-time check skipped"
    exit 77
fi
if [ ! -x "$bench" ]; then
    echo "ct_bench.sh: $bench is not an executable" >&2
    exit 2
fi

tmp=$(mktemp -d "${TMPDIR:-/tmp}/ef_ct.XXXXXX")
trap 'rm -rf "$tmp"' EXIT INT TERM

# Run the bench under callgrind collecting only inside $2; dumps go to $tmp/$3.
run_cg() {
    mode=$1 fn=$2 dir=$3 kind=$4
    mkdir -p "$tmp/$dir"
    if ! valgrind --tool=callgrind --collect-atstart=no --toggle-collect="$fn" \
        --callgrind-out-file="$tmp/$dir/cg.%p" "$bench" "$kind" "$n" "$mode" \
        >"$tmp/$dir/log" 2>&1; then
        cat "$tmp/$dir/log" >&2
        echo "ct_bench.sh: $bench $kind $n $mode failed under valgrind" >&2
        exit 2
    fi
}

status=0
for kind in "$@"; do
    case "$kind" in
    g1) fn=ef_seg_g1_cubic; label="G1 cubic"; target=$TARGET_G1 ;;
    g2) fn=ef_seg_g2_quintic; label="G2 quintic"; target=$TARGET_G2 ;;
    blend) fn=ef_blend_corner; label="corner blend"; target=$TARGET_BLEND ;;
    *) echo "ct_bench.sh: kind must be g1, g2 or blend, not $kind" >&2; exit 2 ;;
    esac
    run_cg dump "$fn" "$kind" "$kind"
    # Per-call dumps are cg.PID.1 .. cg.PID.N; cg.PID (the exit dump) holds nothing
    # counted, since collection is off outside the function.
    find "$tmp/$kind" -name 'cg.*.*' -exec awk '/^totals:/ { print $2 }' {} + \
        | sort -n >"$tmp/$kind.counts"
    got=$(wc -l <"$tmp/$kind.counts")
    if [ "$got" -ne "$n" ]; then
        echo "ct_bench.sh: $got dumps for $n calls (bench built without valgrind/callgrind.h?)" >&2
        exit 2
    fi
    if [ -n "$keep" ]; then
        mkdir -p "$keep/$kind"
        cp "$tmp/$kind"/cg.* "$keep/$kind/"
    fi
    line=$(awk -v label="$label" -v lim="$MAX_RATIO" -v tgt="$target" -v chk="$targets" '
        { v[NR] = $1; s += $1 }
        END {
            med = (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2
            r = v[1] > 0 ? v[NR] / v[1] : 0
            bad = (v[1] <= 0 || r > lim) ? 1 : 0
            if (chk && v[NR] > tgt) bad += 2
            printf "%s: %d calls, instructions min %d median %g max %d, max/min %.4f %d %d\n",
                   label, NR, v[1], med, v[NR], r, bad, s
        }' "$tmp/$kind.counts")
    bad=$(echo "$line" | awk '{ print $(NF - 1) }')
    sum=$(echo "$line" | awk '{ print $NF }')
    echo "$line" | awk '{ NF -= 2; print }'
    case "$bad" in
    1 | 3) echo "FAIL: $label instruction count varies more than max/min $MAX_RATIO" >&2 ;;
    esac
    case "$bad" in
    2 | 3) echo "FAIL: $label max count above the target of $target instructions" >&2 ;;
    esac
    [ "$bad" -eq 0 ] || status=1

    if [ "$verify" -eq 1 ]; then
        run_cg nodump "$fn" "$kind-all" "$kind"
        whole=$(find "$tmp/$kind-all" -name 'cg.*' ! -name '*.*.*' ! -name log)
        total=$(awk '/^totals:/ { print $2 }' "$whole")
        incl=$(callgrind_annotate --inclusive=yes "$whole" 2>/dev/null \
            | awk -v f="$fn" '$0 ~ ("[ :]" f " ") || $0 ~ (":" f "$") {
                  gsub(",", "", $1); print $1; exit }')
        echo "verify $label: sum of per-call dumps $sum, one-dump total $total," \
            "callgrind_annotate inclusive $incl"
        if [ "$sum" != "$total" ] || [ "$sum" != "$incl" ]; then
            echo "FAIL: per-call dumps do not add up to the whole-run count" >&2
            status=1
        fi
    fi
done
exit $status
