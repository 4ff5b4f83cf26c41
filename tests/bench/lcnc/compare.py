#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""evenfeed against LinuxCNC's planner, program by program (docs/benchmarks-linuxcnc.md).

Usage:
  compare.py --evenfeed PATH --work DIR [options] PROGRAM.ngc...

For every program: `evenfeed smooth PROG -o PROG.csv` (its 1 ms setpoints and its summary)
and LinuxCNC on the simulated machine of this directory (lcnc_run.sh: its 1 ms setpoints),
then one table row: cycle times and their ratio, the feed-limited bound and each
planner's efficiency against it, peak per-axis acceleration and jerk of both from second
and third differences of the sampled positions, and the deviation from the programmed
path (evenfeed's own summary figure, and the distance of each planner's setpoints from
the programmed lines and arcs). A program may name a section between the comment lines
"(bench section: WHAT)" and "(bench section end)" (the quantized circles name the circle):
its cycle time (first to last moving period on its lines) and bound are reported on their
own. A summary with the goals of issue 18 follows. It is a
benchmark: it prints figures, and exits non-zero only when a run is broken (2), or 77
when LinuxCNC is not installed.

LinuxCNC's samples are cached under WORK/cache, keyed by the sha256 of the program (in a
directory named by the hash of the machine files and LinuxCNC's version, so a changed
machine or an upgrade reruns): they do not depend on evenfeed's code. --no-cache runs
LinuxCNC every time.

--smoke: instead of the table, check that both runs work, that both cycle times are
positive and that both paths end at the same point (exit 1 if not).

Only the standard library; any python3 (LinuxCNC itself needs Debian's /usr/bin/python3,
which lcnc_run.sh uses on its own).
"""

import argparse
import gzip
import hashlib
import json
import math
import os
import re
import shutil
import statistics
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
INCH = 25.4

# The machine: the same limits on both sides (machine.ini; evenfeed smooth's defaults).
VMAX = 100.0      # mm/s per axis; also the path speed of rapids and the path speed cap
AMAX = 1000.0     # mm/s^2 per axis
JMAX = 20000.0    # mm/s^3, evenfeed's path jerk limit (LinuxCNC has none)
DT = 0.001        # s, servo period of both
JERK_BASE = 4     # baseline (periods) of the smoothed jerk figure, see sampling_floor()
DEV_EPS = 1e-6    # mm, as evenfeed's "over tolerance" count

# What LinuxCNC's motion depends on (lcnc_run.sh only starts and stops it)
MACHINE_FILES = ("machine.ini", "machine.hal", "machine.tbl", "run_lcnc.py")


class Broken(Exception):
    """A run that did not work (as opposed to a figure that misses a goal)."""


class NotInstalled(Exception):
    pass


# ---------------------------------------------------------------- programmed path

def plane_axes(plane):
    """(u, v, w) axis indices of a plane: u, v in the plane (right-handed about the normal w)."""
    return {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}[plane]


class Line:
    def __init__(self, a, b, feed, rapid, tol, line):
        self.a, self.b, self.feed, self.rapid, self.tol, self.line = a, b, feed, rapid, tol, line
        self.d = [b[i] - a[i] for i in range(3)]
        self.len2 = sum(c * c for c in self.d)
        self.length = math.sqrt(self.len2)

    def dist(self, p):
        ax, ay, az = self.a
        dx, dy, dz = self.d
        px, py, pz = p[0] - ax, p[1] - ay, p[2] - az
        t = 0.0
        if self.len2 > 0:
            t = (px * dx + py * dy + pz * dz) / self.len2
            t = 1.0 if t > 1.0 else (0.0 if t < 0.0 else t)
        ex, ey, ez = px - t * dx, py - t * dy, pz - t * dz
        return math.sqrt(ex * ex + ey * ey + ez * ez)

    def tangents(self):
        return [[c / self.length for c in self.d]] if self.length > 0 else []


class Arc:
    """Arc or helix as the reader gives it: centre, signed sweep, plane, start and end."""

    def __init__(self, it, tol):
        self.a, self.b = it["start"], it["end"]
        self.feed, self.rapid, self.tol, self.line = it["feed"], False, tol, it["line"]
        self.u, self.v, self.w = plane_axes(it["plane"])
        c = it["centre"]
        self.cu, self.cv = c[self.u], c[self.v]
        self.w0, self.w1 = self.a[self.w], self.b[self.w]
        self.sweep = it["sweep"]
        self.r0 = math.hypot(self.a[self.u] - self.cu, self.a[self.v] - self.cv)
        self.r1 = math.hypot(self.b[self.u] - self.cu, self.b[self.v] - self.cv)
        self.th0 = math.atan2(self.a[self.v] - self.cv, self.a[self.u] - self.cu)
        rm = 0.5 * (self.r0 + self.r1)
        self.length = math.hypot(abs(self.sweep) * rm, self.w1 - self.w0)

    def point(self, s):
        th = self.th0 + self.sweep * s
        r = self.r0 + (self.r1 - self.r0) * s
        p = [0.0, 0.0, 0.0]
        p[self.u] = self.cu + r * math.cos(th)
        p[self.v] = self.cv + r * math.sin(th)
        p[self.w] = self.w0 + (self.w1 - self.w0) * s
        return p

    def dist(self, p):
        """Distance to the nearest point at the same angle (every turn) or to an end: exact
        for a planar arc, an upper bound off by second order in the pitch for a helix."""
        phi = math.atan2(p[self.v] - self.cv, p[self.u] - self.cu)
        cands = [0.0, 1.0]
        if self.sweep != 0:
            k0 = math.floor(min(0.0, self.sweep) / (2 * math.pi)) - 1
            k1 = math.ceil(max(0.0, self.sweep) / (2 * math.pi)) + 1
            for k in range(k0, k1 + 1):
                s = (phi - self.th0 + 2 * math.pi * k) / self.sweep
                if 0.0 < s < 1.0:
                    cands.append(s)
        best = math.inf
        for s in cands:
            q = self.point(s)
            best = min(best, math.dist(p, q))
        return best

    def tangents(self, n=64):
        out = []
        for k in range(n + 1):
            s = k / n
            th = self.th0 + self.sweep * s
            r = self.r0 + (self.r1 - self.r0) * s
            t = [0.0, 0.0, 0.0]
            t[self.u] = -r * math.sin(th) * self.sweep
            t[self.v] = r * math.cos(th) * self.sweep
            t[self.w] = self.w1 - self.w0
            m = math.sqrt(sum(c * c for c in t))
            if m > 0:
                out.append([c / m for c in t])
        return out


SECTION_BEGIN = re.compile(r"^\s*\(bench section: ([^)]*)\)\s*$")
SECTION_END = re.compile(r"^\s*\(bench section end\)\s*$")


def section_lines(path):
    """The source lines (1-based) between a program's "(bench section: WHAT)" and "(bench
    section end)" comment lines, and WHAT; (None, None) without such a section."""
    with open(path, errors="replace") as f:
        text = f.read().splitlines()
    lo = hi = name = None
    for i, ln in enumerate(text, 1):
        m = SECTION_BEGIN.match(ln)
        if m and lo is None:
            lo, name = i, m.group(1).strip()
        elif SECTION_END.match(ln) and lo is not None and hi is None:
            hi = i
    if lo is None or hi is None or hi <= lo + 1:
        return None, None
    return set(range(lo + 1, hi)), name


def section_time(traj, lines):
    """Time from the first to the last period in which the position changed on one of the
    source lines (s)."""
    pos = traj.pos
    moving = [k for k in range(1, len(pos)) if pos[k] != pos[k - 1] and traj.on_lines(k, lines)]
    if not moving:
        raise Broken("no motion on the section's lines")
    return (moving[-1] - moving[0] + 1) * DT


class Program:
    """The programmed path from evenfeed's own G-code reader (`evenfeed gcode --json`):
    positions in mm whatever the program's units."""

    def __init__(self, evenfeed, path):
        r = subprocess.run([evenfeed, "gcode", path, "--json"], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, universal_newlines=True)
        if r.returncode != 0:
            raise Broken("evenfeed gcode %s: %s" % (path, r.stderr.strip()))
        self.prims = []
        # evenfeed starts in G64 at --tol (0.02 mm), its P for a G64 without P as well;
        # every corpus program sets its own
        default_tol = 0.02
        tol = default_tol
        for ln in r.stdout.splitlines():
            it = json.loads(ln)
            kind = it["kind"]
            if kind == "tolerance":
                tol = 0.0 if it["mode"] != "blend" else (it["p"] if it["p"] > 0 else default_tol)
            elif kind == "rapid":
                self.prims.append(Line(it["start"], it["end"], None, True, tol, it["line"]))
            elif kind == "line":
                self.prims.append(Line(it["start"], it["end"], it["feed"], False, tol, it["line"]))
            elif kind == "arc":
                self.prims.append(Arc(it, tol))
        if not self.prims:
            raise Broken("%s: no motion" % path)
        self.section, self.section_name = section_lines(path)
        self.by_line = {}
        for i, pr in enumerate(self.prims):
            self.by_line.setdefault(pr.line, i)
        self.start = self.prims[0].a

    def bound(self, lines=None):
        """Feed-limited cycle time: every move at min(F, path cap, axis-limited speed along
        it), infinite acceleration; rapids at the path cap (VMAX), as both planners do. Only
        the moves of the given source lines when lines is a set."""
        total = 0.0
        for pr in self.prims:
            if pr.length == 0 or (lines is not None and pr.line not in lines):
                continue
            ts = pr.tangents()
            axis = min((VMAX / max(abs(c) for c in t) for t in ts), default=VMAX)
            v = min(VMAX, axis)
            if not pr.rapid:
                v = min(v, pr.feed / 60.0)
            total += pr.length / v
        return total

    def deviation(self, traj):
        """Largest distance of the moving setpoints from the programmed path, absolute (mm)
        and relative to the P in force at the nearest primitive (P > 0 only). The nearest
        primitive is searched near the one found for the previous setpoint and near the
        one of the setpoint's source line, then more widely when the distance is large.
        Also the number of setpoints farther than P (+ their rounding) from the path."""
        prims = self.prims
        n = len(prims)
        idx = 0
        worst, worst_rel, over = 0.0, 0.0, 0
        prev = None
        for k, p in enumerate(traj.pos):
            if p == prev:
                continue
            prev = p
            hint = self.by_line.get(traj.lines[k], idx)
            lo, hi = min(idx, hint) - 3, max(idx, hint) + 8
            if hi - lo > 64:
                rng = list(range(idx - 3, idx + 32)) + list(range(hint - 3, hint + 32))
            else:
                rng = range(lo, hi)
            best, bi = math.inf, idx
            for i in rng:
                if 0 <= i < n:
                    d = prims[i].dist(p)
                    if d < best:
                        best, bi = d, i
            tol = prims[bi].tol
            if best > 0.5 * tol + DEV_EPS:
                # look further: first around the last position, then everywhere
                for rng in (range(max(0, bi - 300), min(n, bi + 300)), range(n)):
                    for i in rng:
                        d = prims[i].dist(p)
                        if d < best:
                            best, bi = d, i
                    tol = prims[bi].tol
                    if best <= tol + DEV_EPS:
                        break
            idx = bi
            worst = max(worst, best)
            if tol > 0:
                worst_rel = max(worst_rel, best / tol)
                if best > tol + traj.e + DEV_EPS:
                    over += 1
        return worst, worst_rel, over


# ---------------------------------------------------------------- sampled trajectories

def ulp32(x):
    """Spacing of float32 numbers at |x|."""
    x = abs(x)
    if x < 2.0 ** -126:
        return 2.0 ** -149
    return 2.0 ** (math.floor(math.log2(x)) - 23)


class Traj:
    """Setpoints every DT in mm, with the source line of each, and the half-resolution e of
    the recorded positions (mm) for the sampling floors."""

    def __init__(self, pos, lines, e):
        self.pos, self.lines, self.e = pos, lines, e

    def on_lines(self, k, lines):
        """Setpoint k belongs to one of the source lines (LinuxCNC reports line 0 for the
        first period of a move started from rest: that period counts with the next)."""
        ln = self.lines[k]
        if ln == 0 and k + 1 < len(self.lines):
            ln = self.lines[k + 1]
        return ln in lines


def load_evenfeed(csv_path, start, inch):
    u = INCH if inch else 1.0
    pos, lines = [tuple(start)], [0]
    with open(csv_path) as f:
        head = f.readline().strip().split(",")
        if head[:4] != ["t", "x", "y", "z"] or "line" not in head:
            raise Broken("%s: unexpected CSV header %r" % (csv_path, head))
        li = head.index("line")
        for ln in f:
            w = ln.split(",")
            pos.append((float(w[1]) * u, float(w[2]) * u, float(w[3]) * u))
            lines.append(int(w[li]))
    big = max(max(abs(c) for c in p) for p in pos) / u
    # float32 setpoints in program units, written with 6 decimals
    e = (0.5 * ulp32(big) + 0.5e-6) * u
    return Traj(pos, lines, e)


def load_lcnc(tsv_lines):
    pos, lines = [], []
    it = iter(tsv_lines)
    head = next(it).split()
    if head != ["n", "x", "y", "z", "line"]:
        raise Broken("LinuxCNC samples: unexpected header %r" % head)
    for ln in it:
        w = ln.split()
        if w:
            pos.append((float(w[1]), float(w[2]), float(w[3])))
            lines.append(int(w[4]))
    if not pos:
        raise Broken("LinuxCNC samples: empty")
    pos.insert(0, pos[0])
    lines.insert(0, lines[0])
    return Traj(pos, lines, 0.5e-6)  # doubles written by halsampler with 6 decimals


def motion_stats(traj):
    """Cycle time (first to last period in which the position changed), end point, peak per-axis
    acceleration (1 ms second differences) and jerk (1 ms and JERK_BASE ms third
    differences) over that span."""
    pos = traj.pos
    moving = [k for k in range(1, len(pos)) if pos[k] != pos[k - 1]]
    if not moving:
        raise Broken("no motion in the samples")
    i0, i1 = moving[0], moving[-1]
    lo, hi = max(0, i0 - 3 * JERK_BASE), min(len(pos), i1 + 3 * JERK_BASE + 1)
    a1 = j1 = jb = 0.0
    h = JERK_BASE
    for ax in range(3):
        x = [p[ax] for p in pos[lo:hi]]
        n = len(x)
        for k in range(n - 2):
            a1 = max(a1, abs(x[k + 2] - 2 * x[k + 1] + x[k]))
        for k in range(n - 3):
            j1 = max(j1, abs(x[k + 3] - 3 * x[k + 2] + 3 * x[k + 1] - x[k]))
        for k in range(n - 3 * h):
            jb = max(jb, abs(x[k + 3 * h] - 3 * x[k + 2 * h] + 3 * x[k + h] - x[k]))
    return {"cycle": (i1 - i0 + 1) * DT, "end": pos[-1],
            "a": a1 / DT ** 2, "j": j1 / DT ** 3, "jb": jb / (h * DT) ** 3}


def sampling_floor(e):
    """Largest change rounding of e (mm) on each position can make in the differences: the
    margins of the acceleration and jerk checks. Differences of a smooth path never exceed
    the path's own peak (they are averages of it), so peak + floor bounds each figure."""
    return {"a": 4 * e / DT ** 2, "j": 8 * e / DT ** 3, "jb": 8 * e / (JERK_BASE * DT) ** 3}


# ---------------------------------------------------------------- the two planners

SUMMARY_RE = {
    "program": re.compile(r"^program\s+.*\((G2[01]), (mm|inch)\)\s*$", re.M),
    "deviation": re.compile(r"^deviation\s+max (\S+) (mm|in) at line (\d+) \(tolerance (\S+) "
                            r"(?:mm|in) there\), (\d+) moves over tolerance", re.M),
    "cycle": re.compile(r"^cycle time\s+(\S+) s", re.M),
    "end": re.compile(r"^end position\s+(\S+) (\S+) (\S+)", re.M),
}


def run_evenfeed(evenfeed, prog, csv_path, extra):
    cmd = [evenfeed, "smooth", prog, "-o", csv_path] + extra
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       universal_newlines=True)
    if r.returncode != 0:
        raise Broken("%s: exit %d: %s" % (" ".join(cmd), r.returncode, r.stderr.strip()))
    m = {k: rx.search(r.stdout) for k, rx in SUMMARY_RE.items()}
    missing = [k for k, v in m.items() if v is None]
    if missing:
        raise Broken("evenfeed smooth %s: summary without %s:\n%s"
                     % (prog, ", ".join(missing), r.stdout))
    inch = m["program"].group(2) == "inch"
    u = INCH if inch else 1.0
    d = m["deviation"]
    return {"inch": inch, "dev": float(d.group(1)) * u, "dev_line": int(d.group(3)),
            "dev_tol": float(d.group(4)) * u, "dev_over": int(d.group(5)),
            "cycle_reported": float(m["cycle"].group(1))}


def lcnc_version():
    """LinuxCNC's version, or "" where it is not installed."""
    if not shutil.which("linuxcnc_var"):
        return ""
    r = subprocess.run(["linuxcnc_var", "LINUXCNCVERSION"], stdout=subprocess.PIPE,
                       stderr=subprocess.DEVNULL, universal_newlines=True)
    return r.stdout.strip()


def machine_hash():
    """Names the cache: the machine's files and LinuxCNC's version."""
    h = hashlib.sha256(lcnc_version().encode() + b"\0")
    for name in MACHINE_FILES:
        with open(os.path.join(HERE, name), "rb") as f:
            h.update(name.encode() + b"\0" + f.read() + b"\0")
    return h.hexdigest()[:16]


def run_lcnc(prog, sha, cache_dir, scratch, use_cache, tpmod=None):
    """LinuxCNC's samples of prog, with its own planner or (tpmod) another planner module
    (never cached: it is the code under test)."""
    cached = os.path.join(cache_dir, sha + ".tsv.gz")
    if tpmod:
        use_cache = False
    if use_cache and os.path.exists(cached):
        with gzip.open(cached, "rt") as f:
            return f.read().splitlines(), True
    out = os.path.join(scratch, "lcnc.tsv")
    env = dict(os.environ)
    env.pop("EF_LCNC_TPMOD", None)
    if tpmod:
        env["EF_LCNC_TPMOD"] = tpmod
    r = subprocess.run(["bash", os.path.join(HERE, "lcnc_run.sh"), prog, out], env=env,
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                       universal_newlines=True)
    if r.returncode == 77:
        raise NotInstalled(r.stdout.strip())
    if r.returncode != 0:
        raise Broken("lcnc_run.sh %s: exit %d:\n%s" % (prog, r.returncode, r.stdout.strip()))
    with open(out) as f:
        text = f.read()
    os.unlink(out)
    if use_cache:
        os.makedirs(cache_dir, exist_ok=True)
        with gzip.open(cached + ".tmp", "wt") as f:
            f.write(text)
        os.replace(cached + ".tmp", cached)
    return text.splitlines(), False


def compare(args, prog, cache_dir):
    name = os.path.splitext(os.path.basename(prog))[0]
    with open(prog, "rb") as f:
        sha = hashlib.sha256(f.read()).hexdigest()
    scratch = os.path.join(args.work, "runs")
    os.makedirs(scratch, exist_ok=True)
    program = Program(args.evenfeed, prog)

    if args.tpmod:
        # evenfeed as LinuxCNC's planner module: both sides are LinuxCNC runs
        tp_lines, _ = run_lcnc(prog, sha, cache_dir, scratch, False, args.tpmod)
        ef_traj = load_lcnc(tp_lines)
        big = max(max(abs(c) for c in p) for p in ef_traj.pos)
        ef_traj.e = 0.5 * ulp32(big) + 0.5e-6  # float32 setpoints
        ef = {"inch": False}
    else:
        csv_path = os.path.join(scratch, name + ".csv")
        ef = run_evenfeed(args.evenfeed, prog, csv_path, args.evenfeed_arg)
        ef_traj = load_evenfeed(csv_path, program.start, ef["inch"])
        os.unlink(csv_path)
    lc_lines, cached = run_lcnc(prog, sha, cache_dir, scratch, not args.no_cache)
    lc_traj = load_lcnc(lc_lines)

    row = {"program": name, "path": prog, "sha256": sha, "lcnc_cached": cached,
           "units": "inch" if ef["inch"] else "mm", "primitives": len(program.prims)}
    row["bound"] = program.bound()
    for key, traj in (("ef", ef_traj), ("lc", lc_traj)):
        st = motion_stats(traj)
        dev, dev_rel, over = program.deviation(traj)
        row[key] = dict(st, geo_dev=dev, geo_dev_rel=dev_rel, geo_over=over,
                        floor=sampling_floor(traj.e))
    if args.tpmod:
        # no summary of its own: the setpoints' distance from the path stands in for it
        e = row["ef"]
        row["ef"].update({"dev": e["geo_dev"], "dev_tol": e["geo_dev"] / e["geo_dev_rel"]
                          if e["geo_dev_rel"] > 0 else 0.0, "dev_line": 0,
                          "dev_over": e["geo_over"], "cycle_reported": e["cycle"]})
    else:
        row["ef"].update({"dev": ef["dev"], "dev_tol": ef["dev_tol"], "dev_line": ef["dev_line"],
                          "dev_over": ef["dev_over"], "cycle_reported": ef["cycle_reported"]})
    row["ratio"] = row["ef"]["cycle"] / row["lc"]["cycle"]
    row["ef"]["eff"] = row["bound"] / row["ef"]["cycle"]
    row["lc"]["eff"] = row["bound"] / row["lc"]["cycle"]
    row["end_gap"] = math.dist(row["ef"]["end"], row["lc"]["end"])
    if program.section:
        sb = program.bound(program.section)
        row["section"] = {"name": program.section_name, "bound": sb,
                          "ef": section_time(ef_traj, program.section),
                          "lc": section_time(lc_traj, program.section)}
    return row


# ---------------------------------------------------------------- report

def fmt_row(r):
    ef, lc = r["ef"], r["lc"]
    dev_rel = ef["dev"] / ef["dev_tol"] if ef["dev_tol"] > 0 else float("nan")
    return ("%-16s %8.3f %8.3f %6.2f %8.3f %5.2f %5.2f %6.0f %6.0f %7.0f %7.0f %7.1f %6.2f%s %6.2f %6.2f"
            % (r["program"][:16], lc["cycle"], ef["cycle"], r["ratio"], r["bound"], lc["eff"],
               ef["eff"], lc["a"], ef["a"], lc["j"] / 1e3, ef["j"] / 1e3, ef["jb"] / 1e3,
               dev_rel, "!" if ef["dev_over"] else " ", ef["geo_dev_rel"], lc["geo_dev_rel"]))


HEADER = (
    "%-16s %8s %8s %6s %8s %5s %5s %6s %6s %7s %7s %7s %7s %6s %6s\n" %
    ("", "LinuxCNC", "evenfeed", "ratio", "bound", "eff", "eff", "a max", "a max", "j 1ms",
     "j 1ms", "j %dms" % JERK_BASE, "dev/P", "geo/P", "geo/P") +
    "%-16s %8s %8s %6s %8s %5s %5s %6s %6s %7s %7s %7s %7s %6s %6s" %
    ("program", "s", "s", "ef/LC", "s", "LC", "ef", "LC", "ef", "LC k", "ef k", "ef k",
     "ef", "ef", "LC"))


def verdict(ok):
    return "met" if ok else "NOT met"


def summary(rows, jerk):
    n = len(rows)
    ratios = [r["ratio"] for r in rows]
    wins = sum(1 for x in ratios if x <= 1.0)
    worst = max(rows, key=lambda r: r["ratio"])
    med = statistics.median(ratios)
    effs = [r["ef"]["eff"] for r in rows]
    print()
    print("programs %d; evenfeed <= LinuxCNC on %d (%.0f %%); ratio evenfeed/LinuxCNC median "
          "%.2f, worst %.2f (%s), best %.2f" % (n, wins, 100.0 * wins / n, med, worst["ratio"],
                                                  worst["program"], min(ratios)))
    print("efficiency against the feed-limited bound: evenfeed median %.2f (min %.2f), "
          "LinuxCNC median %.2f" % (statistics.median(effs), min(effs),
                                    statistics.median(r["lc"]["eff"] for r in rows)))
    print("peak axis acceleration: evenfeed %.0f, LinuxCNC %.0f mm/s^2 (limit %.0f); peak axis "
          "jerk (1 ms): evenfeed %.3g, LinuxCNC %.3g mm/s^3"
          % (max(r["ef"]["a"] for r in rows), max(r["lc"]["a"] for r in rows), AMAX,
             max(r["ef"]["j"] for r in rows), max(r["lc"]["j"] for r in rows)))
    print()
    print("goals (issue 18; evenfeed with %s, LinuxCNC without a jerk limit):"
          % ("J = %.0f mm/s^3" % jerk if math.isfinite(jerk) else "no jerk limit"))
    print("  cycle time <= LinuxCNC's on >= 90 %% of the corpus: %.0f %%: %s"
          % (100.0 * wins / n, verdict(wins >= 0.9 * n)))
    print("  median ratio <= 0.90: %.2f: %s" % (med, verdict(med <= 0.90)))
    circles = [r for r in rows if r["program"].startswith("circle_q")]
    if circles:
        # the circle itself (its G1 lines, from rest to rest) decides; the whole program adds
        # a rapid, a plunge and a retract, each from rest to rest (under J a 1 mm move takes
        # (32 mm / J)^(1/3) = 0.12 s against 0.01-0.02 s at the feed)
        secs = [r for r in circles if "section" in r]
        if secs:
            worst_s = max(r["section"]["ef"] / r["section"]["bound"] for r in secs)
            print("  quantized circle within 1.2x its feed-limited bound: the circle (its G1 "
                  "lines, rest to rest): %s: %s"
                  % (", ".join("%s %.2fx (LinuxCNC %.2fx)" % (
                      r["program"], r["section"]["ef"] / r["section"]["bound"],
                      r["section"]["lc"] / r["section"]["bound"]) for r in secs),
                     verdict(worst_s <= 1.2)))
        print("    the whole program (with its rapid, plunge and retract): %s"
              % ", ".join("%s %.2fx (LinuxCNC %.2fx)" % (r["program"], 1 / r["ef"]["eff"],
                                                         1 / r["lc"]["eff"]) for r in circles))
    # jerk: 1 ms differences within J + floor everywhere proves it; a JERK_BASE-period
    # difference above J + its floor anywhere disproves it (it is an average of the jerk)
    proven = all(r["ef"]["j"] <= jerk + r["ef"]["floor"]["j"] for r in rows)
    over = [r for r in rows if r["ef"]["jb"] > jerk + r["ef"]["floor"]["jb"]]
    jworst = max(rows, key=lambda r: r["ef"]["jb"])
    if proven:
        jv = "met"
    elif over:
        jv = "NOT met (%d programs over J even at %d ms)" % (len(over), JERK_BASE)
    else:
        jv = "undecided: 1 ms differences are within the float32/CSV rounding floor"
    print("  peak axis jerk <= J: %d ms differences up to %.3g mm/s^3 (%s), margin for rounding "
          "up to %.3g: %s" % (JERK_BASE, jworst["ef"]["jb"], jworst["program"],
                              max(r["ef"]["floor"]["jb"] for r in rows), jv))
    aover = [r for r in rows if r["ef"]["a"] > AMAX + r["ef"]["floor"]["a"]]
    print("  peak axis acceleration <= %.0f mm/s^2 + rounding margin (up to %.0f): peak %.0f: %s"
          % (AMAX, max(r["ef"]["floor"]["a"] for r in rows), max(r["ef"]["a"] for r in rows),
             verdict(not aover) + ("" if not aover else " (%s)" % ", ".join(
                 r["program"] for r in aover))))
    dover = [r for r in rows if r["ef"]["dev_over"] > 0]
    gover = [r for r in rows if r["ef"]["geo_over"] > 0]
    print("  deviation <= P: evenfeed's summary: %s; setpoints' distance from the programmed "
          "path, max %.2f P: %s" % (
              verdict(not dover) + ("" if not dover else " (%s)" % ", ".join(
                  r["program"] for r in dover)),
              max(r["ef"]["geo_dev_rel"] for r in rows),
              verdict(not gover) + ("" if not gover else " (%s)" % ", ".join(
                  r["program"] for r in gover))))


def smoke(rows):
    bad = []
    for r in rows:
        for key in ("ef", "lc"):
            if not r[key]["cycle"] > 0:
                bad.append("%s: %s cycle time %g" % (r["program"], key, r[key]["cycle"]))
        if r["end_gap"] > 1e-3:
            bad.append("%s: end points differ by %.6f mm: evenfeed %s, LinuxCNC %s"
                       % (r["program"], r["end_gap"], r["ef"]["end"], r["lc"]["end"]))
        print("%s: LinuxCNC %.3f s, evenfeed %.3f s, ends %.6f mm apart"
              % (r["program"], r["lc"]["cycle"], r["ef"]["cycle"], r["end_gap"]))
    for b in bad:
        print("lcnc_smoke: " + b)
    print("lcnc_smoke: %s" % ("ok" if not bad else "FAILED"))
    return 0 if not bad else 1


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("programs", nargs="+", metavar="PROGRAM.ngc")
    ap.add_argument("--evenfeed", required=True, help="the evenfeed binary")
    ap.add_argument("--work", required=True, help="scratch and cache directory")
    ap.add_argument("--no-cache", action="store_true", help="run LinuxCNC every time")
    ap.add_argument("--json", metavar="FILE", help="write every figure as JSON")
    ap.add_argument("--smoke", action="store_true", help="check the runs instead of a table")
    ap.add_argument("--evenfeed-arg", action="append", default=[], metavar="ARG",
                    help="extra argument for evenfeed smooth (repeatable), e.g. --jerk=0")
    ap.add_argument("--tpmod", metavar="MODULE",
                    help="evenfeed's side is LinuxCNC with this planner module ([TRAJ]TPMOD, "
                         "e.g. evenfeedtp, installed in LinuxCNC's module directory) instead "
                         "of evenfeed smooth; the module's default jerk limit is J")
    args = ap.parse_args()
    args.evenfeed = os.path.abspath(args.evenfeed)
    args.work = os.path.abspath(args.work)
    jerk = JMAX
    for a in args.evenfeed_arg:
        if a.startswith("--jerk="):
            jerk = float(a.split("=", 1)[1]) or math.inf
    cache_dir = os.path.join(args.work, "cache", machine_hash())

    rows, failed = [], []
    if not args.smoke:
        if args.tpmod:
            print("evenfeed as LinuxCNC's planner ([TRAJ]TPMOD = %s) vs LinuxCNC %s's own, "
                  "side by side on the same machine (tests/bench/lcnc/machine.ini): per axis "
                  "%.0f mm/s, %.0f mm/s^2, servo period %.0f ms; the module's defaults (J %.0f "
                  "mm/s^3, planning to 0.9 of a and J)"
                  % (args.tpmod, lcnc_version(), VMAX, AMAX, DT * 1e3, JMAX))
        else:
            print("evenfeed %s vs LinuxCNC %s (tests/bench/lcnc/machine.ini): per axis %.0f "
                  "mm/s, %.0f mm/s^2, servo period %.0f ms; evenfeed smooth%s"
                  % (args.evenfeed, lcnc_version() or "(cached)", VMAX, AMAX, DT * 1e3,
                     (" " + " ".join(args.evenfeed_arg)) if args.evenfeed_arg else
                     " defaults (J %.0f mm/s^3)" % JMAX))
        print("cycle: first to last period of motion; bound: feed-limited (every move at "
              "min(F, axis limits), infinite acceleration); eff = bound / cycle;")
        print("a, j: peak per-axis |2nd|, |3rd| differences of the 1 ms setpoints (mm/s^2; "
              "10^3 mm/s^3), j %d ms: third differences %d periods apart;" % (JERK_BASE,
                                                                               JERK_BASE))
        print("dev/P: evenfeed's summary deviation / P there (! = moves over P); geo/P: "
              "largest distance of the setpoints from the programmed path / local P")
        print()
        print(HEADER)
        sys.stdout.flush()
    for prog in args.programs:
        try:
            r = compare(args, os.path.abspath(prog), cache_dir)
        except NotInstalled as ex:
            print("LinuxCNC is not installed (skipped): %s" % ex)
            return 77
        except (Broken, OSError, ValueError, KeyError) as ex:
            failed.append(prog)
            print("%-16s BROKEN: %s" % (os.path.basename(prog)[:16], ex))
            sys.stdout.flush()
            continue
        rows.append(r)
        if not args.smoke:
            print(fmt_row(r))
            sys.stdout.flush()
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"rows": rows, "failed": failed}, f, indent=1)
    if args.smoke:
        rc = smoke(rows)
        return 2 if failed else rc
    if rows:
        summary(rows, jerk)
    if failed:
        print("\nbroken runs: %s" % " ".join(failed))
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
