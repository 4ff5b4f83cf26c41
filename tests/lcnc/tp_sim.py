#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""evenfeed's planner module (evenfeedtp.so, [TRAJ]TPMOD) inside LinuxCNC's simulator.

Usage:
  tp_sim.py --evenfeed PATH --module PATH --work DIR [--record DIR] [CASE...]

Installs the module in LinuxCNC's module directory (rtapi_app loads modules only from
there; this needs write access, as root in CI), then runs each case on the simulated XYZ
benchmark machine (tests/bench/lcnc/, 1 ms servo period, 100 mm/s and 1000 mm/s^2 per axis)
through tests/bench/lcnc/lcnc_run.sh, and samples every servo period's commanded position:

  mix        tp_mix.ngc with LinuxCNC's own planner and with evenfeedtp
  override   tp_long.ngc with evenfeedtp, feed override 100 % -> 30 % -> 150 % (the INI's
             MAX_FEED_OVERRIDE 1.5), then a feed hold (pause) and resume
  abort      tp_long.ngc with evenfeedtp, aborted once motion reaches the blended corner
             into line 12
  xyza       tp_xyza.ngc on the XYZA machine (tests/lcnc/xyza/): A turns alone between XYZ
             moves; A within its own speed, acceleration and jerk limits, never moving
             together with X Y Z, and at its programmed end
  mixed      tp_xyza_mixed.ngc on the XYZA machine with aux_tolerance=0.5: X Y and A
             together through blended corners and an arc; A within its limits and moving
             together with X Y, the path within P, every axis at its end

Checks on every evenfeedtp run, from the sampled positions: each setpoint within P of the
programmed path (evenfeed's G-code reader gives the path); per-axis speed, acceleration
(1 ms second differences) and jerk (4 ms third differences) within the machine's limits
(the jerk limit is the module's default, 20/s x the acceleration) plus the float32
setpoints' rounding floor; no step larger than the speed limit allows; the program end
reached (mix, override), or rest on the path (abort). LinuxCNC's own run (mix) must end at
the same point. Prints one line per run. Exit 0 when every check holds, 1 when one fails,
2 when a run is broken, 77 when LinuxCNC is not installed or the module cannot be
installed. --record DIR keeps the module's call traces (DIR/CASE.trace) for test_tp.
"""

import argparse
import filecmp
import math
import os
import re
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
BENCH = os.path.join(HERE, "..", "bench", "lcnc")
sys.path.insert(0, BENCH)
import compare as C  # noqa: E402  (the benchmark's path and trajectory tools)

MODDIR = "/usr/lib/linuxcnc/modules"
JMAX = 20000.0  # the module's default jerk limit on this machine (20/s x 1000 mm/s^2)
XYZA = os.path.join(HERE, "xyza")  # the benchmark machine with a rotary A axis
A_V, A_A = 90.0, 360.0  # its A limits (deg/s, deg/s^2); the module's A jerk 20/s x A_A
CASES = {
    "mix": ("tp_mix.ngc", "", ""),
    "override": ("tp_long.ngc", "t=0.8 feed=0.3; t=2.0 feed=1.5; t=3.0 pause; t=3.6 resume",
                 "DISPLAY MAX_FEED_OVERRIDE 1.5"),
    "abort": ("tp_long.ngc", "line=12 abort", ""),
    "xyza": ("tp_xyza.ngc", "", ""),
    "mixed": ("tp_xyza_mixed.ngc", "", ""),  # with aux_tolerance=0.5 (main())
}


class Broken(Exception):
    pass


def install(module):
    dst = os.path.join(MODDIR, "evenfeedtp.so")
    if not os.path.isdir(MODDIR):
        return "LinuxCNC's module directory %s does not exist" % MODDIR
    if os.path.exists(dst) and filecmp.cmp(module, dst, shallow=False):
        return None
    try:
        shutil.copyfile(module, dst + ".tmp")
        os.replace(dst + ".tmp", dst)
    except OSError as ex:
        return "cannot install %s: %s (run as root, or ./dev linuxcnc)" % (dst, ex)
    return None


def run(prog, out, tpmod, actions, ini_set, trace, machine=None, expect_error=None):
    env = dict(os.environ)
    for k in ("EF_LCNC_TPMOD", "EF_LCNC_ACTIONS", "EF_LCNC_INI_SET", "EF_LCNC_TRACE",
              "EF_LCNC_MACHINE"):
        env.pop(k, None)
    if machine:
        env["EF_LCNC_MACHINE"] = machine
    if tpmod:
        env["EF_LCNC_TPMOD"] = tpmod
    if actions:
        env["EF_LCNC_ACTIONS"] = actions
    if ini_set:
        env["EF_LCNC_INI_SET"] = ini_set
    if trace:
        env["EF_LCNC_TRACE"] = trace
    env.setdefault("EF_LCNC_TIMEOUT", "240")
    r = subprocess.run(["bash", os.path.join(BENCH, "lcnc_run.sh"), prog, out], env=env,
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                       universal_newlines=True)
    if r.returncode == 77:
        raise C.NotInstalled(r.stdout.strip())
    if expect_error is not None:
        return r.returncode, r.stdout
    if r.returncode != 0:
        raise Broken("lcnc_run.sh %s (%s): exit %d:\n%s"
                     % (prog, tpmod or "tpmod", r.returncode, r.stdout.strip()))
    with open(out) as f:
        lines = f.read().splitlines()
    extra = None
    if lines and lines[0].split() == ["n", "x", "y", "z", "a", "line"]:
        # XYZA samples: A apart, the rest as the benchmark's
        extra = [float(ln.split()[4]) for ln in lines[1:] if ln.split()]
        extra.insert(0, extra[0])
        lines = ["n\tx\ty\tz\tline"] + ["\t".join(w[:4] + w[5:]) for w in
                                           (ln.split() for ln in lines[1:]) if w]
    traj = C.load_lcnc(lines)
    traj.a = extra
    # evenfeed's setpoints are float32: their rounding, not halsampler's 6 decimals, is
    # the floor of the differences
    big = max(max(abs(c) for c in p) for p in traj.pos)
    traj.e = 0.5 * C.ulp32(big) + 0.5e-6
    return traj


class Checker:
    def __init__(self):
        self.failed = 0

    def check(self, ok, what):
        if not ok:
            self.failed += 1
            print("  FAIL: %s" % what)


def largest_step(traj):
    return max(math.dist(traj.pos[k], traj.pos[k - 1]) for k in range(1, len(traj.pos)))


def check_run(ck, name, program, traj, aborted):
    st = C.motion_stats(traj)
    fl = C.sampling_floor(traj.e)
    dev, dev_rel, over = program.deviation(traj)
    step = largest_step(traj)
    end = program.prims[-1].b if hasattr(program.prims[-1], "b") else None
    print("%-9s evenfeedtp: %.3f s, a %.0f mm/s^2 (limit %.0f + %.1f), jerk over 4 ms %.0f "
          "mm/s^3 (limit %.0f + %.0f), 1 ms %.0f, largest step %.4f mm, path within %.2f P "
          "(%d over), end %s"
          % (name, st["cycle"], st["a"], C.AMAX, fl["a"], st["jb"], JMAX, fl["jb"], st["j"],
             step, dev_rel, over, tuple(round(c, 4) for c in st["end"])))
    ck.check(st["a"] <= C.AMAX + fl["a"], "%s: acceleration %.1f above the limit" % (name, st["a"]))
    ck.check(st["jb"] <= JMAX + fl["jb"], "%s: jerk %.0f above the limit" % (name, st["jb"]))
    ck.check(step <= C.VMAX * math.sqrt(3) * C.DT * 1.001, "%s: a step of %.4f mm" % (name, step))
    ck.check(over == 0, "%s: %d setpoints farther than P from the path" % (name, over))
    if not aborted:
        ck.check(end is not None and math.dist(st["end"], end) < 1e-3,
                 "%s: ends at %s, not at the program end %s" % (name, st["end"], end))
    else:
        ck.check(traj.pos[-1] == traj.pos[-2], "%s: not at rest after the abort" % name)
    return st


def check_a(ck, traj, a_end, together=False, name="xyza"):
    """A's own limits (1 ms differences for speed and acceleration, 4 ms for jerk, plus the
    rounding of the float32 setpoints and of the samples' 6 decimals), A never moving while
    X Y Z do (together: A moving while X Y Z do for most of its motion), A at its end."""
    a = traj.a
    e = 0.5 * C.ulp32(max(abs(x) for x in a)) + 0.5e-6  # float32 setpoints, 6 decimals
    v = max(abs(a[k] - a[k - 1]) for k in range(1, len(a))) / C.DT
    acc = max(abs(a[k] - 2 * a[k - 1] + a[k - 2]) for k in range(2, len(a))) / C.DT ** 2
    h = C.JERK_BASE
    j = max(abs(a[k] - 3 * a[k - h] + 3 * a[k - 2 * h] - a[k - 3 * h])
            for k in range(3 * h, len(a))) / (h * C.DT) ** 3
    both = sum(1 for k in range(1, len(a))
               if a[k] != a[k - 1] and traj.pos[k] != traj.pos[k - 1])
    print("%-9s A: speed %.2f deg/s (limit %.0f), acceleration %.1f deg/s^2 (limit %.0f), "
          "jerk over 4 ms %.0f deg/s^3 (limit %.0f), periods with A and X Y Z both moving %d, "
          "A at the end %.4f" % (name, v, A_V, acc, A_A, j, 20 * A_A, both, a[-1]))
    ck.check(v <= A_V + 2 * e / C.DT + 1e-6, "%s: A speed %.3f above its limit" % (name, v))
    ck.check(acc <= A_A + 4 * e / C.DT ** 2,
             "%s: A acceleration %.1f above its limit" % (name, acc))
    ck.check(j <= 20 * A_A + 8 * e / (h * C.DT) ** 3, "%s: A jerk %.0f above its limit" % (name, j))
    ck.check(abs(a[-1] - a_end) < 1e-5, "%s: A ends at %.6f, not %g" % (name, a[-1], a_end))
    if together:
        moving = sum(1 for k in range(1, len(a)) if a[k] != a[k - 1])
        ck.check(both > 0.8 * moving, "%s: A moved with X Y Z in only %d of its %d periods"
                 % (name, both, moving))
        return
    ck.check(both == 0, "xyza: A moved together with X Y Z in %d periods" % both)
    ck.check(max(a) >= 180.0 - 1e-6, "xyza: A never reached 180")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("cases", nargs="*", metavar="CASE")
    ap.add_argument("--evenfeed", required=True, help="the evenfeed binary (G-code reader)")
    ap.add_argument("--module", required=True, help="evenfeedtp.so as built")
    ap.add_argument("--work", required=True, help="scratch directory")
    ap.add_argument("--record", metavar="DIR", help="keep the module's call traces here")
    args = ap.parse_args()
    cases = args.cases or list(CASES)
    unknown = [c for c in cases if c not in CASES]
    if unknown:
        print("tp_sim: unknown case %s (known: %s)" % (", ".join(unknown), ", ".join(CASES)))
        return 2
    os.makedirs(args.work, exist_ok=True)
    why = install(args.module)
    if why:
        print("tp_sim: %s (skipped)" % why)
        return 77
    ck = Checker()
    try:
        for name in cases:
            prog_name, actions, ini_set = CASES[name]
            prog = os.path.join(HERE, "programs", prog_name)
            if name == "xyza":
                # the X Y Z path the setpoints are measured against, without the lines that
                # turn A alone (each kept as a comment, so line numbers stay); the mixed case
                # reads its program as it is (the reader takes A B C U V W, docs/gcode.md)
                xyz = os.path.join(args.work, "tp_xyza_path.ngc")
                with open(prog) as f, open(xyz, "w") as o:
                    for ln in f:
                        o.write("(A move)\n" if re.search(r"\bA-?[0-9.]", ln) else ln)
                program = C.Program(args.evenfeed, xyz)
            else:
                program = C.Program(args.evenfeed, prog)
            trace = os.path.join(args.record, name + ".trace") if args.record else None
            out = os.path.join(args.work, name + ".tsv")
            tpmod = "evenfeedtp aux_tolerance=0.5" if name == "mixed" else "evenfeedtp"
            traj = run(prog, out, tpmod, actions, ini_set, trace,
                       XYZA if name in ("xyza", "mixed") else None)
            st = check_run(ck, name, program, traj, name == "abort")
            if name == "xyza":
                check_a(ck, traj, 0.0)
            if name == "mixed":
                check_a(ck, traj, 0.0, together=True, name=name)
                # LinuxCNC's own planner on the same program and machine, for the record
                lc = run(prog, out, "", "", "", None, XYZA)
                ls = C.motion_stats(lc)
                both = sum(1 for k in range(1, len(lc.a))
                           if lc.a[k] != lc.a[k - 1] and lc.pos[k] != lc.pos[k - 1])
                la, h = lc.a, C.JERK_BASE
                lacc = max(abs(la[k] - 2 * la[k - 1] + la[k - 2])
                           for k in range(2, len(la))) / C.DT ** 2
                ljrk = max(abs(la[k] - 3 * la[k - h] + 3 * la[k - 2 * h] - la[k - 3 * h])
                           for k in range(3 * h, len(la))) / (h * C.DT) ** 3
                print("%-9s LinuxCNC's planner: %.3f s (evenfeedtp / LinuxCNC %.2f), periods "
                      "with A and X Y Z both moving %d, A acceleration %.0f deg/s^2, A jerk "
                      "over 4 ms %.0f deg/s^3, end %s"
                      % (name, ls["cycle"], st["cycle"] / ls["cycle"], both, lacc, ljrk,
                         tuple(round(c, 4) for c in ls["end"])))
                ck.check(math.dist(ls["end"], st["end"]) < 1e-3,
                         "mixed: the two planners end at different points")
            if name == "mix":
                lc = run(prog, out, "", "", "", None)
                ls = C.motion_stats(lc)
                print("%-9s LinuxCNC's planner: %.3f s (evenfeedtp / LinuxCNC %.2f), a %.0f, "
                      "jerk over 4 ms %.0f, end %s"
                      % (name, ls["cycle"], st["cycle"] / ls["cycle"], ls["a"], ls["jb"],
                         tuple(round(c, 4) for c in ls["end"])))
                ck.check(math.dist(ls["end"], st["end"]) < 1e-3,
                         "mix: the two planners end at different points")
    except C.NotInstalled as ex:
        print("tp_sim: LinuxCNC is not installed (skipped): %s" % ex)
        return 77
    except (Broken, C.Broken) as ex:
        print("tp_sim: broken run: %s" % ex)
        return 2
    print("tp_sim: %d check(s) failed" % ck.failed if ck.failed else "tp_sim: all checks hold")
    return 1 if ck.failed else 0


if __name__ == "__main__":
    sys.exit(main())
