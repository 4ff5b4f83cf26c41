#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Static stack bound of entry points of the Cortex-M4F images, from GCC's call-graph files
# (-fcallgraph-info=su writes a .ci beside every object: each function's frame from
# -fstack-usage and its direct calls).
#
# Usage: stack_bound.sh DIR ENTRY...
#   DIR    a build folder of firmware/arm/m4 (every *.ci under it is read)
#   ENTRY  a function name
# Prints per entry either
#   bound ENTRY BYTES PATH          the deepest call path's frames summed (PATH: f>g>h)
#   bound ENTRY unknown REASON      recursion, an indirect call, a frame of dynamic size, or a
#                                   callee with no stack figure (not compiled here)
# memcpy, memset and memmove (newlib's, in assembly or compiled without .ci) are counted as
# EF_STACK_LIBC_LEAF bytes each (default 32: they are leaf functions that push at most
# eight registers). EF_STACK_CYCLES="f=k ..." declares a recursion through f that enters f at
# most k more times (stated in f's source): every path from f then holds at most k + 1
# acyclic stretches from f, and f's bound is k + 1 times its deepest acyclic path (the back
# edge counted 0). Exit 0 when every bound was computed, 1 otherwise, 2 on usage errors.
# POSIX sh and awk only.
set -eu
[ $# -ge 2 ] || { echo "usage: stack_bound.sh DIR ENTRY..." >&2; exit 2; }
dir=$1
shift
[ -d "$dir" ] || { echo "stack_bound.sh: no folder $dir" >&2; exit 2; }
cis=$(find "$dir" -name '*.ci' | sort)
[ -n "$cis" ] || { echo "stack_bound.sh: no .ci files under $dir (built without -fcallgraph-info=su?)" >&2; exit 2; }
# shellcheck disable=SC2086
awk -v entries="$*" -v leaf="${EF_STACK_LIBC_LEAF:-32}" -v cycles="${EF_STACK_CYCLES:-}" '
    function field(s, key,    i, r) {
        i = index(s, key ": \"")
        if (i == 0) return ""
        r = substr(s, i + length(key) + 3)
        return substr(r, 1, index(r, "\"") - 1)
    }
    /^node:/ {
        t = field($0, "title")
        l = field($0, "label")
        if (match(l, /\\n[0-9]+ bytes \([a-z,]+\)/)) {
            s = substr(l, RSTART + 2, RLENGTH - 2)
            split(s, ws, " ")
            size[t] = ws[1] + 0
            if (s ~ /dynamic\)/ && s !~ /bounded/) dyn[t] = 1
        }
        next
    }
    /^edge:/ {
        s = field($0, "sourcename")
        t = field($0, "targetname")
        if (!((s, t) in seen)) {
            seen[s, t] = 1
            ne[s]++
            e[s, ne[s]] = t
        }
    }
    function worst(f,    i, w, best, bp, g, c) {
        if (f in memo) return memo[f]
        if (f == "__indirect_call") { err = "indirect call"; return -1 }
        g = f
        sub(/^.*:/, "", g)
        if (f in onstk) {
            if (g in cyc) { open_cyc++; return 0 }
            err = "recursion through " f
            return -1
        }
        if (!(f in size)) {
            if (f == "memcpy" || f == "memset" || f == "memmove") { memo[f] = leaf; pth[f] = f; return leaf }
            err = "no stack figure for " f
            return -1
        }
        if (f in dyn) { err = "dynamic frame in " f; return -1 }
        onstk[f] = 1
        best = 0
        bp = ""
        for (i = 1; i <= ne[f]; i++) {
            w = worst(e[f, i])
            if (w < 0) { delete onstk[f]; return -1 }
            if (w > best) { best = w; bp = pth[e[f, i]] }
        }
        delete onstk[f]
        w = size[f] + best
        c = ""
        if ((g in cyc) && open_cyc > 0) {
            open_cyc = 0
            w = (cyc[g] + 1) * w
            c = "(x" (cyc[g] + 1) ")"
        }
        pth[f] = bp == "" ? g c : g c ">" bp
        if (open_cyc == 0) memo[f] = w
        return w
    }
    END {
        nc = split(cycles, cl, " ")
        for (k = 1; k <= nc; k++) { split(cl[k], kv, "="); cyc[kv[1]] = kv[2] + 0 }
        n = split(entries, en, " ")
        bad = 0
        for (k = 1; k <= n; k++) {
            err = ""
            w = worst(en[k])
            if (w < 0) { printf "bound %s unknown %s\n", en[k], err; bad = 1 }
            else printf "bound %s %d %s\n", en[k], w, pth[en[k]]
        }
        exit bad
    }' $cis
