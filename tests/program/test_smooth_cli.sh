#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# End-to-end tests of `evenfeed smooth` (docs/smoothing-cli.md): summary, JSON, CSV, SVG,
# units, and bad input (exit status = negated ef_err code, one message).
# Usage: test_smooth_cli.sh EVENFEED_BINARY SOURCE_DIR
set -u
ef=$1
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# shellcheck source=tests/cli_lib.sh
. "$(dirname "$0")/../cli_lib.sh"

bracket=$src/samples/bracket.ngc
have_py=0
command -v python3 >/dev/null 2>&1 && have_py=1

# Summary lines on the sample program.
expect 0 'moves +[0-9]+: [0-9]+ line, [0-9]+ arc, [0-9]+ blend, [0-9]+ smooth' -- smooth "$bracket"
expect 0 'deviation +max [0-9.e-]+ mm at line [0-9]+ \(tolerance 0.01 mm there\), 0 moves over' -- smooth "$bracket"
expect 0 'uniform +max [0-9.e+-]+ +rms' -- smooth "$bracket"
expect 0 'corrected +max [0-9.e+-]+ +rms' -- smooth "$bracket"
expect 0 'end position +75.0000 40.0000 25.0000 mm' -- smooth "$bracket"
expect 0 'note: .*bracket.ngc:6:21: G40 ignored' -- smooth "$bracket"

# JSON: well formed, fields, units, continuity, deviation within the tolerance.
"$ef" smooth "$bracket" -o "$tmp/b.json" >/dev/null 2>&1 && ok || bad "smooth -o b.json"
if [ $have_py -eq 1 ]; then
    python3 - "$tmp/b.json" <<'PY' && ok || bad "JSON content of b.json"
import json, sys
d = json.load(open(sys.argv[1]))
assert d["units"] == "mm" and abs(d["tolerance"] - 0.01) < 1e-9, (d["units"], d["tolerance"])
segs = d["segments"]
assert len(segs) == d["summary"]["moves"] > 0
prev = [0.0, 0.0, 0.0]
for k, s in enumerate(segs):
    assert s["seq"] == k
    assert s["kind"] in ("line", "arc", "blend", "smooth")
    assert len(s["control_points"]) == s["degree"] + 1
    assert max(abs(a - b) for a, b in zip(s["control_points"][0], prev)) < 1e-3, k
    prev = s["control_points"][-1]
    assert s["duration"] > 0 and s["length"] > 0
    assert abs(sum(s["time_law"]["dt"]) - s["duration"]) <= 1e-4 * s["duration"] + 1e-6
    assert len(s["time_law"]["c"]) == 7 and all(len(c) == 4 for c in s["time_law"]["c"])
    assert s["dev"] <= d["tolerance"] + 1e-6
    assert isinstance(s["line"], int)
assert max(abs(a - b) for a, b in zip(prev, [75, 40, 25])) < 1e-4
assert d["summary"]["status"] == "ok" and d["summary"]["dev_over"] == 0
PY
else
    grep -q '"segments": \[' "$tmp/b.json" && grep -q '"summary": {' "$tmp/b.json" && ok ||
        bad "JSON structure"
fi

# G20: control points and lengths come back in inches.
printf 'G20 G64 P0.001\nG1 X1 F20\nY1\nX0\nM2\n' >"$tmp/inch.ngc"
"$ef" smooth "$tmp/inch.ngc" -o "$tmp/inch.json" >/dev/null 2>&1 && ok || bad "smooth inch"
grep -q '"units": "inch"' "$tmp/inch.json" && ok || bad "inch units: $(head -c 300 "$tmp/inch.json")"
if [ $have_py -eq 1 ]; then
    python3 - "$tmp/inch.json" <<'PY' && ok || bad "inch JSON content"
import json, sys
d = json.load(open(sys.argv[1]))
assert abs(d["tolerance"] - 0.001) < 1e-9
end = d["segments"][-1]["control_points"][-1]
assert abs(end[0]) < 1e-5 and abs(end[1] - 1) < 1e-5, end
assert abs(d["summary"]["length"] - 3) < 0.01, d["summary"]["length"]
PY
fi
expect 0 'end position +0.0000 1.0000 0.0000 in' -- smooth "$tmp/inch.ngc"

# CSV: header and rows; the last row is at rest at the program end.
"$ef" smooth "$bracket" -o "$tmp/b.csv" --step uniform >/dev/null 2>&1 && ok || bad "smooth -o b.csv"
[ "$(head -1 "$tmp/b.csv")" = "t,x,y,z,v_plan,feed,seq,line,a,b,c,u,v,w" ] && ok || bad "CSV header"
rows=$(($(wc -l <"$tmp/b.csv") - 1))
[ "$rows" -gt 1000 ] && ok || bad "CSV rows $rows"
tail -1 "$tmp/b.csv" | grep -qE '^[0-9.]+,75\.0000[0-9]*,40\.0000[0-9]*,25\.0000[0-9]*,0\.000000,' && ok ||
    bad "CSV last row: $(tail -1 "$tmp/b.csv")"

# SVG: written, one document, with the legend and the layers.
"$ef" smooth "$bracket" --svg "$tmp/b.svg" --step corrected >/dev/null 2>&1 && ok || bad "smooth --svg"
[ -s "$tmp/b.svg" ] && ok || bad "SVG not written"
for id in programmed blends smoothed stops legend; do
    grep -q "<g id=\"$id\"" "$tmp/b.svg" && ok || bad "SVG lacks $id"
done
tail -1 "$tmp/b.svg" | grep -q '</svg>' && ok || bad "SVG not closed"
if [ $have_py -eq 1 ]; then
    python3 -c 'import sys, xml.dom.minidom as m; m.parse(sys.argv[1])' "$tmp/b.svg" && ok ||
        bad "SVG is not well-formed XML"
fi

# Options change the run.
expect 0 'feed fluctuation .* servo period 250 us' -- smooth "$bracket" --period-us 250
expect 0 'moves' -- smooth "$bracket" --g1 --micro-len 0 --tol 0.05 --vmax 50 --amax 500 --jerk 0
# A square at 10 mm/s, G64 P0.05: its corners are slow corners (exact stops, faster than the
# blends under the jerk limit) unless --keep-blends keeps every blend.
printf 'G64 P0.05\nG1 X10 F600\nY10\nX0\nY0\nM2\n' >"$tmp/square.ngc"
expect 0 'vertices  *0 blended, .*3 slow corners' -- smooth "$tmp/square.ngc"
expect 0 'vertices  *3 blended, .*0 slow corners' -- smooth "$tmp/square.ngc" --keep-blends

# Bad input: exit status is the negated error code, the message names file and line.
printf 'G1 X10 F600\nY10\n#1=[0/0]\nX0\n' >"$tmp/nan.ngc"
expect 11 'nan.ngc:3:6: division by zero' -- smooth "$tmp/nan.ngc"
printf 'G1 X10 F0\n' >"$tmp/f0.ngc"
expect 11 'f0.ngc:1:1: feed move with no feed rate' -- smooth "$tmp/f0.ngc"
printf 'G1 X10 F600\nG2 X10 Y0 I-1 P2000\nG1 X20\n' >"$tmp/arc.ngc"
expect 15 'arc.ngc:2: inconsistent arc' -- smooth "$tmp/arc.ngc"
printf 'G1 X1 F100\nG2 X1 Y0 I0.0000001\n' >"$tmp/tiny.ngc"
expect 11 'tiny.ngc:2:1: G2 arc radius is zero' -- smooth "$tmp/tiny.ngc"
printf 'G1 X1 F100\nG1 X1\nG40\nM2\n' >"$tmp/zero.ngc"
expect 0 'note: .*zero.ngc:2:1: zero-length G1 move' -- smooth "$tmp/zero.ngc"
# A refused program still writes the JSON of what was accepted, with its status.
"$ef" smooth "$tmp/arc.ngc" -o "$tmp/arc.json" >/dev/null 2>&1
[ $? -eq 15 ] && grep -q '"status": "inconsistent arc' "$tmp/arc.json" && ok || bad "JSON on error"
expect 9 'no-such.ngc' -- smooth "$tmp/no-such.ngc"
expect 1 'no input file' -- smooth
expect 1 "unknown option '--bogus'" -- smooth "$bracket" --bogus
expect 1 'must end in .json or .csv' -- smooth "$bracket" -o "$tmp/x.txt"
expect 1 '--step uniform\|corrected' -- smooth "$bracket" --step fast
expect 1 '--vmax' -- smooth "$bracket" --vmax 0
expect 1 '--tol' -- smooth "$bracket" --tol -1
expect 1 '--period-us' -- smooth "$bracket" --period-us 0
expect 1 "'nan' is not a finite number" -- smooth "$bracket" --amax nan
# Nine axes (docs/axes.md): A with X Y through blends, A alone, B C U V W; the JSON carries
# the auxiliary control points, the CSV ends at every programmed value.
cat >"$tmp/axes.ngc" <<'EOF2'
G21 G90 G64 P0.05
G1 X40 A30 F1200
G1 Y40
G1 X0 A-10
G1 A80 F2700
G1 X-20 B10 C90 U5 V3 W1 F1200
M2
EOF2
expect 0 'axes A B C U V W 1 moves of them alone, 0 exact stops for their rate changes, blend deviation max [0-9.e-]+ \(deg or mm; tolerance 0.02\)' -- smooth "$tmp/axes.ngc" --keep-blends
"$ef" smooth "$tmp/axes.ngc" --keep-blends -o "$tmp/axes.csv" >/dev/null 2>&1 && ok || bad "smooth axes.ngc -o csv"
tail -1 "$tmp/axes.csv" | grep -qE ',-20\.000000,40\.000000,0\.000000,0\.000000,0\.000000,[0-9]+,6,80\.000000,10\.000000,90\.000000,5\.000000,3\.000000,1\.000000$' && ok ||
    bad "axes CSV last row: $(tail -1 "$tmp/axes.csv")"
"$ef" smooth "$tmp/axes.ngc" --keep-blends -o "$tmp/axes.json" >/dev/null 2>&1 && ok || bad "smooth axes.ngc -o json"
if [ $have_py -eq 1 ]; then
    python3 - "$tmp/axes.json" <<'PY' && ok || bad "JSON auxiliary control points"
import json, sys
segs = json.load(open(sys.argv[1]))["segments"]
aux = [s for s in segs if "aux_control_points" in s]
assert len(aux) >= 4, len(aux)
assert sum(1 for s in aux if s["aux_only"]) == 1
prev = None
for s in segs:
    a = s.get("aux_control_points", {"a": [0.0] * (s["degree"] + 1)})["a"]
    assert len(a) == s["degree"] + 1
    if prev is not None:
        assert abs(a[0] - prev) < 1e-4, (s["seq"], a[0], prev)
    prev = a[-1]
assert abs(prev - 80) < 1e-6
PY
fi
expect 0 'end position +-20.0000 40.0000 0.0000 mm' -- smooth "$tmp/axes.ngc" --axes 9
expect 1 'axes.ngc:2: axis A moves, the machine has X Y Z only' -- smooth "$tmp/axes.ngc" --axes 3
expect 1 'axes.ngc:6: axis B moves, the machine has X Y Z A only' -- smooth "$tmp/axes.ngc" --axes 4
expect 1 "--axes '10': a whole number 3..9" -- smooth "$tmp/axes.ngc" --axes 10
expect 1 'Modbus streaming carries X Y Z only' -- stream "$tmp/axes.ngc" --modbus tcp://127.0.0.1:1502 --axes 4
expect 1 'axes 4 with 3 nodes: over CAN each axis is a node' -- stream "$tmp/axes.ngc" --can vcan0 --axes 4
expect 1 "nodes '1,2,3,4,5,6,7,8,9,10': at most 9 nodes" -- stream "$tmp/axes.ngc" --can vcan0 --nodes 1,2,3,4,5,6,7,8,9,10

expect 9 'cannot write' -- smooth "$bracket" --svg "$tmp/no/such/dir.svg"
expect 0 'usage: evenfeed smooth' -- smooth --help

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
