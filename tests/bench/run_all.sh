#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Every benchmark, printing figures (nothing here is a pass/fail timing test; the
# constant-time property itself is asserted by the ctest fw_constant_time).
# Usage: run_all.sh BUILD_DIR   (a release build without sanitizers)
set -euo pipefail
b=$(cd "$1" && pwd)
cd "$(dirname "$0")/../.."
ef=$b/host/evenfeed
# The per-call x86 figures, kept for the M4 side-by-side table at the end of that part.
x86log=$(mktemp "${TMPDIR:-/tmp}/ef_x86ct.XXXXXX")
trap 'rm -f "$x86log"' EXIT

echo "== Instructions per segment call (callgrind, x86-64, firmware at -O2), 10000 random"
echo "   valid configurations each (planar, 3-D, near-reversal, out-of-domain), and ef_blend_corner on"
echo "   10000 random corners; targets (issue 17) G1 XY entry <= 400, G2 <= 1500, each entry's"
echo "   max/min <= 1.02; G1 reported per entry (XY: ef_seg_g1_cubic_xy on data in z = const;"
echo "   3-D: ef_seg_g1_cubic on twisted and general data)"
sh tests/bench/ct_bench.sh "$b/tests/bench_ct" 10000 g1 g2 blend | tee -a "$x86log"

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

echo
echo "== Corner treatments at the same tolerance P (docs/benchmarks-smoothing.md): E evenfeed G2"
echo "   blends, A LinuxCNC-rule arcs, F fixed-ratio quintics, S the streaming smoother"
"$b/tests/bench_blends"

echo
echo "== Runtime chain on a generated 100 000-line CAM-like program (tests/bench/gen_cam.c)"
"$b/tests/gen_cam" -n 100000 -o "$b/tests/cam100k.ngc"
"$ef" gcode "$b/tests/cam100k.ngc" >/dev/null
if [ -x "$b/tests/bench_smooth" ]; then
    "$b/tests/bench_smooth" "$b/tests/cam100k.ngc" all 3
    if command -v valgrind >/dev/null 2>&1; then
        echo
        echo "== Instructions per pulled move (callgrind: ef_smooth_push + pull + finish, release"
        echo "   build), 20 000-line program of the same generator"
        "$b/tests/gen_cam" -n 20000 -o "$b/tests/cam20k.ngc"
        cg=$(mktemp -d "${TMPDIR:-/tmp}/ef_cg.XXXXXX")
        valgrind --tool=callgrind --collect-atstart=no --toggle-collect=ef_smooth_push \
            --toggle-collect=ef_smooth_pull --toggle-collect=ef_smooth_finish \
            --callgrind-out-file="$cg/cg.out" "$b/tests/bench_smooth" "$b/tests/cam20k.ngc" \
            smooth 1 >"$cg/log" 2>&1
        awk '/^smooth-count:/ { m = $3; p = $5 }
             /^totals:/ { t = $2 }
             END { printf "%d instructions for %d moves (%d primitives): %.0f per move, %.0f per primitive\n",
                   t, m, p, t / m, t / p }' "$cg/log" "$cg/cg.out"
        rm -rf "$cg"
        echo
        echo "== Per-call instructions of the per-move functions (callgrind, firmware at -O2, default"
        echo "   tables), 1000 random inputs each: min / median / max, max/min; ef_interp_process per"
        echo "   1 ms period over the moves of 1000 CAM-like primitives (target <= 1000 per period)"
        sh tests/bench/ct_bench.sh "$b/tests/bench_ct_path" 1000 bprim_la bprim_aa bprim_la_v bprim_aa_v arcpiece \
            measure smooth interp interp_c | tee -a "$x86log"
    fi
else
    echo "(bench_smooth not built: EF_BENCH_SMOOTH off)"
fi

echo
echo "== Cortex-M4F (QEMU mps2-an386, -icount shift=10: exact instruction counts) against x86"
echo "   (callgrind, above), worst case per call on the same generators (tests/bench/ct_cases.h),"
echo "   1000 inputs each on the M4; the issue-17 targets; stack high-water against the static bound"
echo "   (tests/m4/m4_costs.c, costs_check.sh); flash and RAM per layer (tests/m4/sizes.sh)"
if [ -f "$b/m4-O2/m4_costs.elf" ] && command -v qemu-system-arm >/dev/null 2>&1; then
    for opt in O2 Os; do
        echo "-- -$opt: stack (bytes)"
        sh tests/m4/costs_check.sh "$b/m4-$opt" | grep -E '^stack .* bound=|costs_check' || true
    done
    sh tests/m4/costs_table.sh "$x86log" "$b/m4-O2/m4_costs.out" "$b/m4-Os/m4_costs.out"
    echo
    sh tests/m4/sizes.sh "$b/m4-O2" "$b/m4-Os"
else
    echo "(not built: configure with -DEF_M4=ON, needs gcc-arm-none-eabi and qemu-system-arm)"
fi

echo
echo "== Modbus: sustained segments/s and direct target writes/s over TCP and RTU at 115200"
echo "   baud, and the feed each sustains on the sample profile (docs/benchmarks-modbus.md)"
"$b/tests/bench_modbus" "$ef" .

echo
echo "== Setpoint continuity with uniform parameter stepping (what a segment-mode drive runs):"
echo "   worst per-axis acceleration and jerk against the limits (tests/motion/test_continuity.c;"
echo "   corrected stepping is a ctest, this one is an open item of issue 18)"
"$b/tests/test_continuity" uniform 2>&1 | grep -v '^ok' | tail -6 || true

echo
echo "== evenfeed against LinuxCNC 2.9's planner on the same simulated machine (100 mm/s,"
echo "   1000 mm/s^2 per axis, 1 ms servo period): generated corpus and samples/"
echo "   (docs/benchmarks-linuxcnc.md); evenfeed at J 20000 mm/s^3, LinuxCNC without a jerk limit"
bash tests/bench/lcnc/run.sh "$b"

echo
echo "== LinuxCNC planner module (evenfeedtp): one servo period's call, ef_tp_cycle(), on the"
echo "   recorded motion traces of tests/lcnc/traces/ (wall time on this machine: the maximum"
echo "   depends on its load; the work per period is bounded by 32 smoother units, docs/linuxcnc.md)"
"$b/tests/test_tp" replay tests/lcnc/traces/*.trace | grep -v '^[0-9]* passed' || true

echo
echo "== CAN bus load: CSP at 1 kHz against segment mode, 3 drives, the sample profile, real"
echo "   master and drive code on a simulated 1 Mbit/s bus (docs/benchmarks-can.md)"
"$b/tests/bench_canbus" samples/profile.ngc

echo
echo "== E-stop latency: a gpio-sim e-stop input, evenfeed stream --can on vcan, three drives,"
echo "   inside the project's User-Mode Linux kernel (not a real-time kernel: these are UML"
echo "   figures); EF_BENCH_PRESSES presses (default 100), docs/io.md"
if [ -x "$b/tests/test_can_hil" ]; then
    EF_HIL_PASS_ENV=EF_BENCH_PRESSES EF_BENCH_PRESSES=${EF_BENCH_PRESSES:-100} \
        bash tests/hil/uml_run.sh tests/hil/can.sh "$b/tests/bench_io_latency/verdict" 1200 \
        "$b/tests/test_can_hil" "$ef" "$PWD" "$b/tests/bench_io_latency/out" io_latency |
        grep -E 'latency|presses|press ->|kernel edge|check failed|^(PASS|FAIL|SKIP)' || true
else
    echo "(not built: test_can_hil needs the default tables)"
fi

echo
echo "== USB-CAN adapter (gs_usb over libusb) against SocketCAN, in the same User-Mode Linux"
echo "   guest: TX -> echo latency, burst rate, and the sample profile (half feed) to three drives with"
echo "   canbusload's bus load beside evenfeed's (the adapter is simulated on dummy_hcd, paced"
echo "   at 1 Mbit/s, and bridged to vcan0; docs/benchmarks-can.md)"
if [ -x "$b/tests/test_can_hil" ]; then
    bash tests/hil/uml_run.sh tests/hil/can.sh "$b/tests/bench_gsusb/verdict" 600 \
        "$b/tests/test_can_hil" "$ef" "$PWD" "$b/tests/bench_gsusb/out" gsusb_bench |
        grep -E '^  |TX latency|sample profile|adapter:|check failed|^(PASS|FAIL|SKIP)' || true
else
    echo "(not built: test_can_hil needs the default tables)"
fi
