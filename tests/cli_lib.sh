# SPDX-License-Identifier: Apache-2.0
# Shared by the CLI test scripts (sourced): pass/fail counters and expect(); the caller sets
# $ef to the evenfeed binary.
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
