#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Reference harness for the G-code reader: LinuxCNC's standalone interpreter
(/usr/bin/rs274) is the oracle for the path a program means.

  gcode_ref.py ref FILE                     path from rs274, machine coordinates
  gcode_ref.py got EVENFEED FILE            path from `EVENFEED gcode FILE --json`
  gcode_ref.py check EVENFEED FILE EXPECT   compare `got` with EXPECT (exit 0 / 1)
  gcode_ref.py check-ref FILE EXPECT        compare `ref` with EXPECT (exit 77 without rs274)
  gcode_ref.py gen FILE                     write FILE's .path next to it from `ref`

Normalized path, one item per line, numbers %.4f, positions in mm (machine
coordinates: G92, XY rotation, G5x and tool length offsets applied), feeds in mm/min,
zero-length rapids and lines dropped:
    rapid X Y Z
    line X Y Z F<feed>
    arc X Y Z C<c1> <c2> P<17|18|19> T<turn> F<feed>
    dwell S
    end
    error
An arc's X Y Z is its end; C is the centre in the plane (X,Y / X,Z / Y,Z); T is
LinuxCNC's signed rotation (+n ccw, -n cw, n = 1 for an ordinary arc). Lines starting
with # in .path files are comments.

Program coordinates map to machine coordinates as LinuxCNC's canon does
(emccanon.cc rotate_and_offset_pos):  m = rot_xy(p + g92) + g5x + tool,
each offset converted to mm with the length units in force when it was set.
"""
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile

RS274 = "/usr/bin/rs274"
ZERO_LEN = 1e-9
TOL_MM = 2e-4
TOL_INCH = 3e-3
TOL_FEED_REL = 1e-4
TIMEOUT_S = 60


# ---------------------------------------------------------------------------------
# Items: tuples (kind, values...) formatted by fmt_item.

def fmt_num(v):
    s = "%.4f" % v
    if s == "-0.0000":
        s = "0.0000"
    return s


def fmt_item(it):
    k = it[0]
    if k == "rapid":
        return "rapid %s %s %s" % tuple(fmt_num(v) for v in it[1])
    if k == "line":
        return "line %s %s %s F%s" % (tuple(fmt_num(v) for v in it[1]) + (fmt_num(it[2]),))
    if k == "arc":
        _, end, cen, plane, turn, feed = it
        return "arc %s %s %s C%s %s P%d T%d F%s" % (
            fmt_num(end[0]), fmt_num(end[1]), fmt_num(end[2]), fmt_num(cen[0]),
            fmt_num(cen[1]), plane, turn, fmt_num(feed))
    if k == "dwell":
        return "dwell %s" % fmt_num(it[1])
    return k


def dist(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)))


class PathBuilder:
    """Collects items, dropping zero-length rapids and lines."""

    def __init__(self):
        self.pos = [0.0, 0.0, 0.0]
        self.items = []

    def move(self, kind, end, feed=None):
        if dist(self.pos, end) > ZERO_LEN:
            self.items.append((kind, list(end)) if kind == "rapid" else (kind, list(end), feed))
        self.pos = list(end)

    def arc(self, end, cen, plane, turn, feed):
        self.items.append(("arc", list(end), list(cen), plane, turn, feed))
        self.pos = list(end)

    def add(self, *it):
        self.items.append(tuple(it))


def in_plane(v, plane):
    return {17: (v[0], v[1]), 18: (v[0], v[2]), 19: (v[1], v[2])}[plane]


# ---------------------------------------------------------------------------------
# ref: run rs274 and follow its canonical calls.

CANON_RE = re.compile(r"^\s*\d+\s+N\S*\s+([A-Z][A-Z0-9_]*)\((.*)\)\s*$")
NUM_RE = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
UNITS = {"CANON_UNITS_MM": 1.0, "CANON_UNITS_INCHES": 25.4, "CANON_UNITS_CM": 10.0}
PLANES = {"CANON_PLANE_XY": 17, "CANON_PLANE_XZ": 18, "CANON_PLANE_YZ": 19}


def nums(args):
    return [float(x) for x in NUM_RE.findall(args)]


def run_rs274(path):
    """Run rs274 on a copy of path in a temporary directory: (rc, stdout, stderr)."""
    d = tempfile.mkdtemp(prefix="gcode_ref.")
    try:
        prog = os.path.join(d, "prog.ngc")
        shutil.copyfile(path, prog)
        # Tools 1..99 with zero offsets, so that T/M6/G43 Hn/G10 L1 find their entries;
        # the var file starts absent (all parameters 0) and is written by rs274 at the end.
        with open(os.path.join(d, "tool.tbl"), "w") as f:
            for t in range(1, 100):
                f.write("T%d P%d Z0 D0 ;\n" % (t, t))
        cmd = [RS274, "-t", "tool.tbl", "-v", "rs274ngc.var", "-g", "prog.ngc"]
        # rs274 keeps its tool table in $HOME/.tool.mmap, truncated and mapped by every run:
        # two runs at once (ctest -j) truncate each other's mapping and one dies of SIGBUS
        # (exit 135, "link (updating variable file)"). HOME is the run's own directory.
        env = dict(os.environ, HOME=d)
        try:
            p = subprocess.run(cmd, cwd=d, env=env, stdin=subprocess.DEVNULL,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=TIMEOUT_S)
        except subprocess.TimeoutExpired as e:
            return 124, (e.stdout or b"").decode(errors="replace"), "timeout"
        return p.returncode, p.stdout.decode(errors="replace"), p.stderr.decode(errors="replace")
    finally:
        shutil.rmtree(d, ignore_errors=True)


class Canon:
    """Machine state as LinuxCNC's canon keeps it; all lengths in mm."""

    def __init__(self):
        self.unit = 1.0
        self.g5x = [0.0, 0.0, 0.0]
        self.g92 = [0.0, 0.0, 0.0]
        self.rot = 0.0
        self.tool = [0.0, 0.0, 0.0]
        self.feed = 0.0
        self.plane = 17
        self.out = PathBuilder()
        self.ended = False

    def to_machine(self, p):
        x, y, z = (v * self.unit + o for v, o in zip(p, self.g92))
        t = math.radians(self.rot)
        x, y = x * math.cos(t) - y * math.sin(t), x * math.sin(t) + y * math.cos(t)
        return [x + self.g5x[0] + self.tool[0], y + self.g5x[1] + self.tool[1],
                z + self.g5x[2] + self.tool[2]]

    def call(self, name, args):
        a = nums(args)
        u = self.unit
        if name == "USE_LENGTH_UNITS":
            self.unit = UNITS.get(args.strip(), 1.0)
        elif name == "SET_G5X_OFFSET":
            self.g5x = [v * u for v in a[1:4]]
        elif name == "SET_G92_OFFSET":
            self.g92 = [v * u for v in a[0:3]]
        elif name == "SET_XY_ROTATION":
            self.rot = a[0]
        elif name == "USE_TOOL_LENGTH_OFFSET":
            self.tool = [v * u for v in a[0:3]]
        elif name == "SET_FEED_RATE":
            self.feed = a[0] * u  # rs274 already turns G93 inverse time into a rate
        elif name == "SELECT_PLANE":
            self.plane = PLANES.get(args.strip(), 17)
        elif name == "STRAIGHT_TRAVERSE":
            self.out.move("rapid", self.to_machine(a[0:3]))
        elif name == "STRAIGHT_FEED":
            self.out.move("line", self.to_machine(a[0:3]), self.feed)
        elif name == "ARC_FEED":
            e1, e2, c1, c2, turn, ax = a[0:6]
            if self.plane == 17:
                end, cen = [e1, e2, ax], [c1, c2, ax]
            elif self.plane == 18:  # first = Z, second = X, axis = Y
                end, cen = [e2, ax, e1], [c2, ax, c1]
            else:  # 19: first = Y, second = Z, axis = X
                end, cen = [ax, e1, e2], [ax, c1, c2]
            self.out.arc(self.to_machine(end), in_plane(self.to_machine(cen), self.plane),
                         self.plane, int(turn), self.feed)
        elif name == "DWELL":
            self.out.add("dwell", a[0])
        elif name == "PROGRAM_END":
            if not self.ended:
                self.out.add("end")
            self.ended = True


def ref_items(path):
    rc, out, err = run_rs274(path)
    c = Canon()
    for line in out.splitlines():
        m = CANON_RE.match(line)
        if m and not c.ended:
            c.call(m.group(1), m.group(2))
    if rc != 0:
        c.out.add("error")
    elif not c.ended:  # a program framed by % ends without PROGRAM_END
        c.out.add("end")
    return c.out.items, rc, err


# ---------------------------------------------------------------------------------
# got: read evenfeed's JSON item stream.

DWELL_RE = re.compile(r"^\s*G0*4(?![0-9.])\D*?P\s*([-+]?(?:\d+\.?\d*|\.\d+))", re.I)


def got_items(evenfeed, path):
    try:
        p = subprocess.run([evenfeed, "gcode", path, "--json"], stdin=subprocess.DEVNULL,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=TIMEOUT_S)
        rc, out, err = p.returncode, p.stdout.decode(errors="replace"), \
            p.stderr.decode(errors="replace")
    except subprocess.TimeoutExpired:
        rc, out, err = 124, "", "timeout"
    b = PathBuilder()
    ended = False
    for line in out.splitlines():
        line = line.strip()
        if not line.startswith("{"):
            continue
        try:
            o = json.loads(line)
        except ValueError:
            continue
        k = o.get("kind")
        if k in ("rapid", "line"):
            b.pos = list(o["start"])
            b.move(k, o["end"], o.get("feed", 0.0))
        elif k == "arc":
            plane = int(o.get("plane", 17))
            turns = int(o.get("turns", 1)) or 1
            turn = (1 if o.get("dir", 1) > 0 else -1) * turns
            b.arc(o["end"], in_plane(o["centre"], plane), plane, turn, o.get("feed", 0.0))
        elif k == "zero":
            b.pos = list(o["end"])
        elif k == "event":
            m = DWELL_RE.match(o.get("text", ""))
            if m:
                b.add("dwell", float(m.group(1)))
        elif k == "end":
            if not ended:
                b.add("end")
            ended = True
    if rc != 0:
        b.add("error")
    return b.items, rc, err


# ---------------------------------------------------------------------------------
# check: compare normalized lines.

def read_expect(path):
    with open(path) as f:
        return [l.strip() for l in f if l.strip() and not l.lstrip().startswith("#")]


def is_inch(path):
    with open(path, errors="replace") as f:
        text = f.read()
    return bool(re.search(r"\(\s*units:\s*inch\s*\)", text, re.I) or
                re.search(r"(?<![A-Z0-9.])G0*20(?![0-9.])", text, re.I))


def line_eq(a, b, tol):
    ta, tb = a.split(), b.split()
    if len(ta) != len(tb) or not ta or ta[0] != tb[0]:
        return False
    for x, y in zip(ta[1:], tb[1:]):
        px, py = x[0] if x[0].isalpha() else "", y[0] if y[0].isalpha() else ""
        if px != py:
            return False
        try:
            vx, vy = float(x[len(px):]), float(y[len(py):])
        except ValueError:
            if x != y:
                return False
            continue
        if px in ("P", "T"):
            if vx != vy:
                return False
        elif px == "F" or ta[0] == "dwell":
            if abs(vx - vy) > TOL_FEED_REL * max(abs(vx), abs(vy)) + 1e-4:
                return False
        elif abs(vx - vy) > tol:
            return False
    return True


def compare(got, expect, tol):
    """Return None on match, else (index, got line, expected line).

    A program the expectation refuses (last line `error`) matches when the reader also
    refuses it and the items it produced before refusing are a prefix of the expected
    ones: a reader may find a structural error (say, a call of an undefined sub) before
    LinuxCNC, which reads line by line, does."""
    if expect and expect[-1] == "error" and got and got[-1] == "error":
        g, e = got[:-1], expect[:-1]
        for i, gl in enumerate(g):
            if i >= len(e) or not line_eq(gl, e[i], tol):
                return (i, gl, e[i] if i < len(e) else "(none)")
        return None
    for i in range(max(len(got), len(expect))):
        gl = got[i] if i < len(got) else "(none)"
        el = expect[i] if i < len(expect) else "(none)"
        if not line_eq(gl, el, tol):
            return (i, gl, el)
    return None


def do_check(lines, ngc, expect_path, what):
    expect = read_expect(expect_path)
    tol = TOL_INCH if is_inch(ngc) else TOL_MM
    d = compare(lines, expect, tol)
    if d is None:
        print("ok %s: %d items match %s" % (ngc, len(expect), os.path.basename(expect_path)))
        return 0
    i, gl, el = d
    print("%s: %s differs from %s at item %d" % (ngc, what, expect_path, i))
    print("  got:      %s" % gl)
    print("  expected: %s" % el)
    return 1


def usage():
    sys.stderr.write(__doc__)
    return 2


def main(argv):
    if len(argv) < 2:
        return usage()
    cmd = argv[1]
    if cmd == "ref" and len(argv) == 3:
        items, rc, err = ref_items(argv[2])
        for it in items:
            print(fmt_item(it))
        if rc != 0:
            sys.stderr.write(err)
        return 0
    if cmd == "got" and len(argv) == 4:
        items, rc, err = got_items(argv[2], argv[3])
        for it in items:
            print(fmt_item(it))
        if rc != 0:
            sys.stderr.write(err)
        return 0
    if cmd == "check" and len(argv) == 5:
        items, rc, err = got_items(argv[2], argv[3])
        r = do_check([fmt_item(it) for it in items], argv[3], argv[4], "evenfeed")
        if r and rc != 0:
            sys.stderr.write(err)
        return r
    if cmd == "check-ref" and len(argv) == 4:
        if not os.access(RS274, os.X_OK):
            print("skip: %s not installed" % RS274)
            return 77
        items, rc, err = ref_items(argv[2])
        r = do_check([fmt_item(it) for it in items], argv[2], argv[3], "rs274")
        if r and rc != 0:
            sys.stderr.write(err)
        return r
    if cmd == "gen" and len(argv) == 3:
        ngc = argv[2]
        items, rc, err = ref_items(ngc)
        out = os.path.splitext(ngc)[0] + ".path"
        with open(out, "w") as f:
            f.write("# SPDX-License-Identifier: Apache-2.0\n")
            f.write("# %s: path from LinuxCNC rs274 (tests/program/gcode_ref.py gen), "
                    "reviewed by hand\n" % os.path.basename(ngc))
            if rc != 0:
                msg = [l for l in err.splitlines()
                       if l.strip() and l != "executing" and not l.startswith("link (")]
                for l in msg[:2]:
                    f.write("# rs274: %s\n" % l)
            for it in items:
                f.write(fmt_item(it) + "\n")
        print("wrote %s (%d items%s)" % (out, len(items), ", refused" if rc else ""))
        return 0
    return usage()


if __name__ == "__main__":
    sys.exit(main(sys.argv))
