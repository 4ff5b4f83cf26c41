#!/usr/bin/env bash
# End-to-end tests of the evenfeed command line: results, JSON, and every bad-input path
# (exit status = negated ef_err code, one clear message, nothing on stdout that looks like a
# segment). Usage: test_cli.sh EVENFEED_BINARY SOURCE_DIR
set -u
ef=$1
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
pass=0
fail=0

ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*" >&2; }

# expect STATUS PATTERN -- ARGS...: exit status and a pattern in stdout+stderr.
expect() {
    local want=$1 pat=$2
    shift 3
    local out rc
    out=$("$ef" "$@" 2>&1)
    rc=$?
    if [ "$rc" -ne "$want" ]; then
        bad "evenfeed $* -> exit $rc, want $want; output: $out"
    elif ! grep -qE -- "$pat" <<<"$out"; then
        bad "evenfeed $* -> output lacks /$pat/: $out"
    else
        ok
    fi
}

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
expect 1 'not available' -- table build --backend gl --kind g1 --nodes 5x5 -o "$tmp/x.eft"
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
