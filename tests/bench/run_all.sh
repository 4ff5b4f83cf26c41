#!/usr/bin/env bash
# Every benchmark, printing figures (nothing here is a pass/fail timing test; the
# constant-time property itself is asserted by the ctest fw_constant_time).
# Usage: run_all.sh BUILD_DIR   (a release build without sanitizers)
set -euo pipefail
b=$(cd "$1" && pwd)
cd "$(dirname "$0")/../.."
ef=$b/host/evenfeed

echo "== Instructions per segment call (callgrind, x86-64, firmware at -O2), 10000 random"
echo "   valid configurations each (planar, 3-D, near-reversal, out-of-domain), and ef_blend_corner on"
echo "   10000 random corners; targets G1 <= 400, G2 <= 1500"
sh tests/bench/ct_bench.sh "$b/tests/bench_ct" 10000 g1 g2 blend

echo
echo "== Default tables against the CPU reference optimum (accuracy harness)"
"$ef" table verify tables/g1_cubic_default.eft --random 4000
"$ef" table verify tables/g2_quintic_default.eft --random 2000
echo
echo "== G1 on 3-D data through the planar table"
"$ef" table verify tables/g1_cubic_default.eft --random 4000 --3d
"$b/tests/bench_twist" 500

echo
echo "== CPU reference optimizer, time per optimization"
"$b/tests/bench_ref" 200

echo
echo "== Table builder: OpenGL compute backend against the CPU reference, same grids, one run"
if [ -x "$b/tests/bench_build" ]; then
    "$b/tests/bench_build" 2
else
    echo "(not built: no libepoxy)"
fi
