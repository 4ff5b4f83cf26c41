#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Naming check (docs/style.md): every static function in the library and CLI sources starts
# with its file's prefix from the table in docs/style.md, never with ef_, and no prefix is
# listed for two files. Prints each violation; exit 1 if there is one.
set -euo pipefail
cd "$(dirname "$0")/.."
table=docs/style.md
status=0
dups=$(grep -oE '^\| `[^`]+\.c` \| `[a-z0-9_]+` \|' "$table" | awk -F'`' '{print $4}' | sort | uniq -d)
if [ -n "$dups" ]; then
    echo "check_names: prefix listed twice in $table: $dups" >&2
    status=1
fi
for f in $(find firmware/src host/lib host/cli gpu_offline/src -name '*.c' | sort); do
    # Names of static functions: a line starting "static" whose declarator is "name(".
    names=$(awk '/^static / && !/=/ { line=$0; sub(/\(.*/, "", line); n=split(line, w, /[ *]+/); if (n && line ~ /[A-Za-z0-9_]$/ && index($0, "(")) print w[n] }' "$f" | sort -u)
    [ -z "$names" ] && continue
    prefix=$(grep -F "| \`$f\` |" "$table" | awk -F'`' '{print $4}' || true)
    if [ -z "$prefix" ]; then
        echo "check_names: $f has static functions but no row in $table" >&2
        status=1
        continue
    fi
    for n in $names; do
        case $n in
        "$prefix"*) ;;
        *)
            echo "check_names: $f: static $n() does not start with $prefix" >&2
            status=1
            ;;
        esac
    done
done
[ $status -eq 0 ] && echo "check_names: OK"
exit $status
