#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# End-to-end tests of the evenfeed command line: results, JSON, and every bad-input path
# (exit status = negated ef_err code, one clear message, nothing on stdout that looks like a
# segment). Usage: test_cli.sh EVENFEED_BINARY SOURCE_DIR
set -u
ef=$1
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# shellcheck source=tests/cli_lib.sh
. "$(dirname "$0")/../cli_lib.sh"

# number NAME JSON: the first value of "NAME": in a JSON text.
number() { grep -oE "\"$1\": [-0-9.e+]+" <<<"$2" | head -1 | awk '{print $2}'; }

# near A B TOL MSG
near() {
    if awk -v a="$1" -v b="$2" -v t="$3" 'BEGIN { d = a - b; if (d < 0) d = -d; exit !(d <= t) }'; then
        ok
    else
        bad "$4: $1 vs $2 (tol $3)"
    fi
}

PI2=1.5707963267948966

# The published reference: cubic alpha = pi/2, beta = -pi/2.
j=$("$ef" segment --g1 --alpha $PI2 --beta -$PI2 --optimize --json)
near "$(number C "$j")" 1.788278 1e-5 "reference optimum C"
grep -q '"control_points": \[\[0, 0\]' <<<"$j" && ok || bad "control_points in JSON: $j"
j=$("$ef" segment --g1 --alpha $PI2 --beta -$PI2 --json)
near "$(number C "$j")" 1.788278 2e-4 "table C at the reference configuration"
grep -q '"source": "built-in table"' <<<"$j" && ok || bad "source: $j"
j=$("$ef" segment --quartic --alpha $PI2 --beta -$PI2 --optimize --json)
awk -v c="$(number C "$j")" 'BEGIN { exit !(c <= 0.17) }' && ok || bad "quartic joint C <= 0.17: $j"
j=$("$ef" segment --g1 --alpha 0 --beta 0 --optimize --json)
near "$(number C "$j")" 0 1e-9 "straight configuration C"
# Explicit 2-D and 3-D end data; G2 in the table domain and outside it (clamped, still valid).
expect 0 'g2_quintic segment' -- segment --g2 --p0 0,0 --t0 1,0 --p1 10,5 --t1 0,1 --k1 0.1
expect 0 'twist' -- segment --g1 --p0 0,0,0 --t0 1,0,0 --p1 5,5,2 --t1 0,0.6,0.8
expect 0 '"clamped": \["alpha"\]' -- segment --g2 --alpha 2.5 --beta 0 --json
expect 0 'outside the table domain' -- segment --g2 --alpha 0.1 --beta 0 --k0 7
expect 0 'x2_1' -- segment --g2 --alpha 0.5 --beta -0.3 --k0 1 --k1 -0.5 --optimize

# Bad input: NaN/inf, coincident endpoints, bad tangents/normals, malformed vectors.
expect 1 'not a finite number' -- segment --g1 --alpha nan --beta 0
expect 1 'not a finite number' -- segment --g1 --alpha 0 --beta inf
expect 1 'not a finite number' -- segment --g1 --alpha 1x --beta 0
expect 3 'coincident endpoints' -- segment --g1 --p0 1,1 --t0 1,0 --p1 1,1 --t1 1,0
expect 3 'coincident endpoints' -- segment --g1 --p0 1,1 --t0 1,0 --p1 1,1 --t1 1,0 --optimize
expect 4 'tangent' -- segment --g1 --p0 0,0 --t0 0,0 --p1 1,0 --t1 1,0
expect 4 'tangent' -- segment --g1 --p0 0,0 --t0 2,0 --p1 1,0 --t1 1,0
expect 5 'normal' -- segment --g2 --p0 0,0,0 --t0 1,0,0 --p1 1,0,0 --t1 1,0,0 --k0 1
expect 5 'normal' -- segment --g2 --p0 0,0,0 --t0 1,0,0 --n0 1,0,0 --p1 1,0,0 --t1 1,0,0 --k0 1
expect 2 'NaN or infinite' -- segment --g1 --p0 0,0 --t0 1,0 --p1 1e30,0 --t1 1,0
expect 6 'outside the table domain' -- segment --g2 --alpha 0 --beta 0 --k0 5000
expect 1 'not a 2-D' -- segment --g1 --p0 1,2,3,4 --t0 1,0 --p1 1,0 --t1 1,0
expect 1 'not a 2-D' -- segment --g1 --p0 1 --t0 1,0 --p1 1,0 --t1 1,0
expect 1 'not a finite number' -- segment --g1 --p0 1,,2 --t0 1,0 --p1 1,0 --t1 1,0
expect 1 'mix of 2-D and 3-D' -- segment --g1 --p0 0,0 --t0 1,0,0 --p1 1,0 --t1 1,0
expect 1 'need --g2' -- segment --g1 --alpha 0 --beta 0 --k0 1
expect 1 'add --optimize' -- segment --quartic --alpha 0 --beta 0
expect 1 'exactly one of' -- segment --g1 --g2 --alpha 0 --beta 0
expect 1 'both --alpha and --beta' -- segment --g1 --alpha 0
expect 1 'not both' -- segment --g1 --alpha 0 --beta 0 --p0 0,0
expect 1 'given twice' -- segment --g1 --alpha 0 --alpha 1 --beta 0
expect 1 'unknown option' -- segment --g1 --alpha 0 --beta 0 --bogus
expect 1 'unknown command' -- frobnicate
expect 7 'does not match' -- segment --g2 --alpha 0 --beta 0 --table "$src/tables/g1_cubic_default.eft"

# Table files: info, corrupt, truncated, missing, wrong kind.
expect 0 'fold' -- table info "$src/tables/g1_cubic_default.eft"
expect 0 'mirror' -- table info "$src/tables/g2_quintic_default.eft"
expect 0 'G1 cubic' -- table info @g1
cp "$src/tables/g1_cubic_default.eft" "$tmp/flip.eft"
printf '\x55' | dd of="$tmp/flip.eft" bs=1 seek=1000 conv=notrunc status=none
expect 32 'CRC' -- table info "$tmp/flip.eft"
head -c 500 "$src/tables/g1_cubic_default.eft" >"$tmp/short.eft"
expect 20 'truncated' -- table info "$tmp/short.eft"
printf 'hello, not a table, padded to be long enough to hold a header of 160 bytes ...........................................................................' >"$tmp/text.eft"
expect 21 'magic' -- table info "$tmp/text.eft"
expect 9 'missing.eft' -- table info "$tmp/missing.eft"
expect 1 'unknown built-in table' -- table info @g3

# Build: bad requests fail before any work; a small build round-trips through verify.
expect 1 'counts of 2' -- table build --kind g1 --nodes 1x5 -o "$tmp/x.eft"
expect 1 'counts of 2' -- table build --kind g1 --nodes 100000x5 -o "$tmp/x.eft"
expect 1 'counts of 2' -- table build --kind g2 --nodes 5x5 -o "$tmp/x.eft"
expect 1 'unknown backend' -- table build --backend vulkan --kind g1 --nodes 5x5 -o "$tmp/x.eft"
# Bad input fails before the backend opens, GL or not.
expect 1 'counts of 2' -- table build --backend gl --kind g1 --nodes 0x5 -o "$tmp/x.eft"
expect 1 'only 4 rows' -- table build --backend gl --kind g1 --nodes 5x4 --shard 1/5 -o "$tmp/x.efs"
expect 30 'more than the 4194304' -- table build --backend gl --kind g1 --nodes 4096x4096 -o "$tmp/x.eft"
expect 27 "axis\\[0\\].hi" -- table build --backend gl --kind g1 --symmetry none --domain 1:0,0:1 --nodes 5x5 -o "$tmp/x.eft"
expect 33 'x1_min' -- table build --backend gl --kind g2 --x1-min 0 --nodes 3x3x3x3 -o "$tmp/x.eft"
expect 1 'does not apply' -- table build --kind g1 --symmetry mirror --nodes 5x5 -o "$tmp/x.eft"
expect 1 'ranges' -- table build --kind g2 --symmetry none --nodes 3x3x3x3 --domain 0:1 -o "$tmp/x.eft"
expect 1 'required' -- table build --nodes 5x5 -o "$tmp/x.eft"
[ ! -e "$tmp/x.eft" ] && ok || bad "a failed build left a file"
expect 0 'wrote' -- table build --kind g1 --nodes 9x17 -o "$tmp/small.eft" --c-source "$tmp/small.c" --name small_g1
grep -q 'const ef_table_t small_g1' "$tmp/small.c" && ok || bad "emitted C lacks the descriptor"
expect 0 '9 x 17' -- table info "$tmp/small.eft"
mv "$tmp/small.eft" "$tmp/first.eft"
"$ef" table build --kind g1 --nodes 9x17 -o "$tmp/small.eft" --c-source "$tmp/small.c" --name small_g1 --threads 1 2>/dev/null
cmp -s "$tmp/small.eft" "$tmp/first.eft" && ok || bad "builds with 2 and 1 threads differ"
expect 0 '"optimizer_misses": 0' -- table verify "$tmp/small.eft" --random 200 --json
# The provenance is canonical: it names every value-affecting option (defaults included) and
# nothing about outputs or threads, so another -o gives the same bytes.
expect 0 'provenance: evenfeed [0-9.]+ table build --backend cpu --kind g1 --symmetry fold --nodes 9x17 --x1-min 0.1 --x1-max 10$' -- table info "$tmp/small.eft"
"$ef" table build --kind g1 --nodes 9x17 --x1-max 10.0 --x1-min .1 -o "$tmp/other-name.eft" --threads 3 2>/dev/null
cmp -s "$tmp/other-name.eft" "$tmp/first.eft" && ok || bad "the output name or spelling of a value changed the bytes"

# Shards: built one by one (as a job array would), merged, byte-identical to the unsharded
# build, C source included; uneven splits (17 rows into 4 and 3).
for i in 1 2 3 4; do
    expect 0 "shard $i/4: rows" -- table build --kind g1 --nodes 9x17 --shard $i/4 -o "$tmp/s$i.efs"
done
expect 0 'merge: 4 shards' -- table merge -o "$tmp/merged.eft" --c-source "$tmp/merged.c" --name small_g1 "$tmp/s3.efs" "$tmp/s1.efs" "$tmp/s4.efs" "$tmp/s2.efs"
cmp -s "$tmp/merged.eft" "$tmp/first.eft" && ok || bad "merged 4 shards differ from the unsharded build"
cmp -s "$tmp/merged.c" "$tmp/small.c" && ok || bad "C source of the merge differs from the build's"
for i in 1 2 3; do
    "$ef" table build --kind g1 --nodes 9x17 --shard $i/3 --threads 1 -o "$tmp/t$i.efs" 2>/dev/null
done
expect 0 'merge: 3 shards' -- table merge -o "$tmp/merged3.eft" "$tmp/t1.efs" "$tmp/t2.efs" "$tmp/t3.efs"
cmp -s "$tmp/merged3.eft" "$tmp/first.eft" && ok || bad "merged 3 shards differ from the unsharded build"
ls "$tmp"/*.partial >/dev/null 2>&1 && bad "a finished build left its journal" || ok
# Bad shard specs, before any work.
expect 1 'N must be at least 1' -- table build --kind g1 --nodes 9x17 --shard 0/0 -o "$tmp/x.efs"
expect 1 'I must be 1..4' -- table build --kind g1 --nodes 9x17 --shard 5/4 -o "$tmp/x.efs"
expect 1 'N must be at least 1' -- table build --kind g1 --nodes 9x17 --shard 1/0 -o "$tmp/x.efs"
expect 1 'not I/N' -- table build --kind g1 --nodes 9x17 --shard abc -o "$tmp/x.efs"
expect 1 'I must be 1..4' -- table build --kind g1 --nodes 9x17 --shard 0/4 -o "$tmp/x.efs"
expect 1 'not I/N' -- table build --kind g1 --nodes 9x17 --shard 1/4x -o "$tmp/x.efs"
expect 1 'only 17 rows' -- table build --kind g1 --nodes 9x17 --shard 3/100000 -o "$tmp/x.efs"
expect 1 'c-source needs the whole table' -- table build --kind g1 --nodes 9x17 --shard 1/2 -o "$tmp/x.efs" --c-source "$tmp/x.c" --name x
[ ! -e "$tmp/x.efs" ] && ok || bad "a refused shard build left a file"
# Merge of an incomplete or inconsistent set: a clear error, no output.
expect 1 '1 of 4 shards missing: 3/4 \(rows 8..11\)' -- table merge -o "$tmp/m.eft" "$tmp/s1.efs" "$tmp/s2.efs" "$tmp/s4.efs"
expect 1 'both shard 2/4' -- table merge -o "$tmp/m.eft" "$tmp/s1.efs" "$tmp/s2.efs" "$tmp/s2.efs" "$tmp/s3.efs" "$tmp/s4.efs"
expect 1 'same --shard' -- table merge -o "$tmp/m.eft" "$tmp/s1.efs" "$tmp/t2.efs" "$tmp/t3.efs"
"$ef" table build --kind g1 --nodes 9x17 --x1-max 9 --shard 3/4 -o "$tmp/o3.efs" 2>/dev/null
expect 1 'o3.efs: not from the same build.*x1_max 10 vs 9' -- table merge -o "$tmp/m.eft" "$tmp/s1.efs" "$tmp/s2.efs" "$tmp/o3.efs" "$tmp/s4.efs"
head -c 300 "$tmp/s3.efs" >"$tmp/part.efs"
expect 20 'part.efs: shard file truncated' -- table merge -o "$tmp/m.eft" "$tmp/s1.efs" "$tmp/s2.efs" "$tmp/part.efs" "$tmp/s4.efs"
cp "$tmp/s3.efs" "$tmp/flip.efs"
printf '\x55' | dd of="$tmp/flip.efs" bs=1 seek=400 conv=notrunc status=none
expect 32 'flip.efs: shard file corrupt' -- table merge -o "$tmp/m.eft" "$tmp/s1.efs" "$tmp/s2.efs" "$tmp/flip.efs" "$tmp/s4.efs"
expect 21 'it is a table file' -- table merge -o "$tmp/m.eft" "$tmp/first.eft"
expect 9 'missing.efs' -- table merge -o "$tmp/m.eft" "$tmp/missing.efs"
expect 1 'usage' -- table merge -o "$tmp/m.eft"
expect 9 'cannot write in directory' -- table merge -o "$tmp/no/dir/m.eft" "$tmp/s1.efs"
[ ! -e "$tmp/m.eft" ] && ok || bad "a refused merge left a file"
# Journals: a file at the journal path that is not this build's journal is refused (and never
# deleted); --fresh discards a journal; --journal picks the path; checks precede any work.
printf 'my notes, not a journal' >"$tmp/j.eft.partial"
expect 21 'not a build journal.*refusing to overwrite' -- table build --kind g1 --nodes 9x17 -o "$tmp/j.eft"
expect 21 'refusing to delete' -- table build --kind g1 --nodes 9x17 -o "$tmp/j.eft" --fresh
grep -q 'my notes' "$tmp/j.eft.partial" && ok || bad "a non-journal file was touched"
cp "$tmp/s2.efs" "$tmp/j2.partial"
expect 21 'it is a shard file' -- table build --kind g1 --nodes 9x17 -o "$tmp/j.eft" --journal "$tmp/j2.partial"
expect 1 'same path as the output' -- table build --kind g1 --nodes 9x17 -o "$tmp/j.eft" --journal "$tmp/j.eft"
expect 9 'cannot write in directory' -- table build --kind g1 --nodes 9x17 -o "$tmp/no/dir/j.eft"
expect 9 'cannot write in directory' -- table build --kind g1 --nodes 9x17 -o "$tmp/j3.eft" --c-source "$tmp/no/dir/j.c" --name j
[ ! -e "$tmp/j.eft" ] && [ ! -e "$tmp/j3.eft" ] && ok || bad "a refused build left its output"
expect 0 'wrote' -- table build --kind g1 --nodes 9x17 -o "$tmp/j.eft" --journal "$tmp/custom.journal"
[ ! -e "$tmp/custom.journal" ] && ok || bad "--journal file left after success"
cmp -s "$tmp/j.eft" "$tmp/first.eft" && ok || bad "--journal changed the bytes"
printf 'EFJN\r\n\032\n garbage after the magic' >"$tmp/k.eft.partial"
expect 22 'k.eft.partial.*--fresh' -- table build --kind g1 --nodes 9x17 -o "$tmp/k.eft"
expect 0 'wrote' -- table build --kind g1 --nodes 9x17 -o "$tmp/k.eft" --fresh
cmp -s "$tmp/k.eft" "$tmp/first.eft" && ok || bad "--fresh build differs"
[ ! -e "$tmp/k.eft.partial" ] && ok || bad "--fresh build left its journal"
# A real interruption: kill -9 once the journal holds a chunk (3 chunks of 819 rows), then
# a different build is refused, a flipped byte is refused, and the rerun resumes and writes
# exactly what an uninterrupted build writes.
big=(table build --kind g1 --nodes 5x2048 --threads 1)
"$ef" "${big[@]}" -o "$tmp/big.eft" 2>/dev/null &
pid=$!
for _ in $(seq 600); do
    [ "$(stat -c %s "$tmp/big.eft.partial" 2>/dev/null || echo 0)" -gt 1000 ] && break
    sleep 0.05
done
kill -9 $pid 2>/dev/null
wait $pid 2>/dev/null
if [ -e "$tmp/big.eft" ] || [ ! -e "$tmp/big.eft.partial" ]; then
    bad "interrupted build: output written or no journal"
else
    ok
    cp "$tmp/big.eft.partial" "$tmp/big.keep"
    expect 1 'big.eft.partial: journal of a different build.*x1_max 9 vs 10' -- "${big[@]}" --x1-max 9 -o "$tmp/big.eft"
    printf '\x55' | dd of="$tmp/big.eft.partial" bs=1 seek=700 conv=notrunc status=none
    expect 32 'corrupt build journal.*--fresh' -- "${big[@]}" -o "$tmp/big.eft"
    cp "$tmp/big.keep" "$tmp/big.eft.partial"
    expect 0 'resuming from .*big.eft.partial: [0-9]+/10240 nodes already done' -- "${big[@]}" -o "$tmp/big.eft"
    [ ! -e "$tmp/big.eft.partial" ] && ok || bad "resumed build left its journal"
    "$ef" "${big[@]}" -o "$tmp/big-clean.eft" 2>/dev/null
    cmp -s "$tmp/big.eft" "$tmp/big-clean.eft" && ok || bad "resumed build differs from an uninterrupted one"
fi
# The GL backend: a table when this binary and machine have it, else a clear error and no file.
out=$("$ef" table build --backend gl --kind g1 --nodes 5x5 -o "$tmp/gl.eft" 2>&1)
rc=$?
if [ "$rc" -eq 0 ]; then
    [ -s "$tmp/gl.eft" ] && ok || bad "gl build reported success without a file"
elif grep -qE 'OpenGL|EGL|GL' <<<"$out" && [ ! -e "$tmp/gl.eft" ]; then
    ok
else
    bad "gl build: exit $rc, unclear message or leftover file: $out"
fi
expect 0 '"optimizer_misses": 0' -- table verify @g1 --random 300 --json
expect 0 '"optimizer_misses": 0' -- table verify @g1 --random 100 --3d --json
expect 0 '"optimizer_misses": 0' -- table verify @g2 --random 30 --json
expect 1 'whole number' -- table verify @g1 --random 0
expect 1 'G1 tables only' -- table verify @g2 --random 5 --3d
expect 0 '' -- table emit-c "$tmp/small.eft" --name small_g1 -o "$tmp/e.c"
cmp -s "$tmp/e.c" "$tmp/small.c" && ok || bad "emit-c output differs from the build's --c-source"
expect 1 'not a C identifier|identifier' -- table emit-c "$tmp/small.eft" --name 9bad -o "$tmp/e2.c"

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
