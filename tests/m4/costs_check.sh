#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# ctest m4_costs_O2 / _Os: run the costs image (tests/m4/m4_costs.c) under QEMU and check that
# it ran to its end, printed a cost line for every function, and that every entry point's
# measured stack high-water is within its static bound (tests/m4/stack_bound.sh over the
# build's -fcallgraph-info files). The instruction counts are figures, not judged here.
#
# Usage: costs_check.sh M4_BUILD_DIR      (writes M4_BUILD_DIR/m4_costs.out)
# Exit: 0 pass, 1 a check failed, 77 QEMU not installed (ctest SKIP; see qemu_run.sh).
#
# Recursion declared to stack_bound.sh: ef_smooth.c's sm_skip_body() calls sm_next_move()
# again after setting the emitting state to EF_E_BLEND, which does not skip again: one more
# entry at most.
set -u
here=$(cd "$(dirname "$0")" && pwd)
dir=$1
out=$dir/m4_costs.out
rc=0
sh "$here/qemu_run.sh" --limit 300 "$dir/m4_costs.elf" "$out" || rc=$?
[ "$rc" -eq 77 ] && exit 77
if [ "$rc" -ne 0 ]; then
    echo "costs_check: the image failed (exit $rc)" >&2
    exit 1
fi
status=0
for f in ef_seg_g1_cubic_xy ef_seg_g1_cubic/3d ef_seg_g2_quintic ef_blend_corner \
    ef_blend_prims/line-arc ef_blend_prims/arc-line ef_blend_prims/arc-arc \
    ef_blend_prims/helix-helix ef_blend_prims_valid/line-arc ef_blend_prims_valid/arc-line \
    ef_blend_prims_valid/arc-arc ef_blend_prims_valid/helix-helix ef_blend_arc_piece ef_move_measure ef_smooth_push/cam \
    ef_smooth_pull/cam ef_smooth_finish/cam ef_interp_process/uniform ef_interp_process/corrected \
    ef_interp_process/corrected-late; do
    if ! grep -q "^cost $f n=[1-9][0-9]* min=[0-9]* median=[0-9]* max=[0-9]* ratio=" "$out"; then
        echo "costs_check: no cost line for $f" >&2
        status=1
    fi
done
checked=0
while read -r _ entry used; do
    used=${used#used=}
    bound=0
    why=
    for fn in $(echo "$entry" | tr '+' ' '); do
        line=$(EF_STACK_CYCLES="sm_next_move=1" sh "$here/stack_bound.sh" "$dir" "$fn") || {
            why=$line
            break
        }
        b=$(echo "$line" | awk '{ print $3 }')
        [ "$b" -gt "$bound" ] && bound=$b
    done
    if [ -n "$why" ]; then
        echo "stack $entry measured=$used bound=unknown: $why"
        status=1
    elif [ "$used" -gt "$bound" ]; then
        echo "stack $entry measured=$used bound=$bound: FAIL, above the static bound"
        status=1
    else
        echo "stack $entry measured=$used bound=$bound"
    fi
    checked=$((checked + 1))
done <<EOT
$(grep '^stack ' "$out")
EOT
if [ "$checked" -eq 0 ]; then
    echo "costs_check: no stack lines" >&2
    status=1
fi
[ "$status" -eq 0 ] && echo "costs_check: ok, $checked entry points within their static stack bound"
exit $status
