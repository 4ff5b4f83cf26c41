#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Flash and RAM of the firmware library per layer on the Cortex-M4F (issue 17), from the M4
# build folders' libef_fw.a (arm-none-eabi-size of every object, summed per firmware/src/
# layer folder), and of the linked images (--gc-sections: only what they call).
# Usage: sizes.sh M4_DIR_O2 M4_DIR_Os
set -eu
top=$(cd "$(dirname "$0")/../.." && pwd)
o2=$1
os=$2
layer_of() { # object name (ef_x.c.obj) -> its layer folder
    src=$(find "$top/firmware/src" -name "${1%.obj}" | head -n 1)
    basename "$(dirname "$src")"
}
sizes() { # dir -> "layer text data bss" lines
    arm-none-eabi-size "$1/fw/libef_fw.a" | awk 'NR > 1 { print $6, $1, $2, $3 }' |
        while read -r obj t d b; do echo "$(layer_of "$obj") $t $d $b"; done |
        awk '{ t[$1] += $2; d[$1] += $3; b[$1] += $4 }
             END { for (l in t) print l, t[l], d[l], b[l] }' | sort
}
sizes "$o2" >"${TMPDIR:-/tmp}/ef_sz_o2.$$"
sizes "$os" >"${TMPDIR:-/tmp}/ef_sz_os.$$"
echo "library per layer (bytes: flash = text + data, RAM = data + bss)"
printf '%-10s %10s %10s %10s %10s\n' layer "flash -O2" "flash -Os" "RAM -O2" "RAM -Os"
join "${TMPDIR:-/tmp}/ef_sz_o2.$$" "${TMPDIR:-/tmp}/ef_sz_os.$$" |
    awk '{ printf "%-10s %10d %10d %10d %10d\n", $1, $2 + $3, $5 + $6, $3 + $4, $6 + $7
           f2 += $2 + $3; fs += $5 + $6 }
         END { printf "%-10s %10d %10d\n", "all", f2, fs }'
rm -f "${TMPDIR:-/tmp}/ef_sz_o2.$$" "${TMPDIR:-/tmp}/ef_sz_os.$$"
echo
echo "linked images (--gc-sections): text data bss"
for d in "$o2" "$os"; do
    for e in "$d"/*.elf; do
        arm-none-eabi-size "$e" | awk -v n="$(basename "$d")/$(basename "$e")" 'NR == 2 { printf "%-28s %8d %6d %8d\n", n, $1, $2, $3 }'
    done
done
