#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Build the firmware library alone for a Cortex-M4F, link firmware/arm/link_check.c against
# it with --gc-sections, print sizes, and check that nothing a firmware must not need is
# referenced.
#
# Usage: firmware/arm/build.sh [-Os|-O2] [BUILD_DIR]     (defaults: -Os, build-arm)
#
# Fails (exit 1) if
#  - libef_fw.a has an undefined symbol other than memcpy/memset/memmove and its own
#    functions (a libm call, a soft-float double helper, anything from a hosted libc);
#  - the linked image contains malloc/free/calloc/realloc, printf/sprintf/puts, or any
#    double-precision soft-float helper (__aeabi_d*, __aeabi_f2d, __adddf3, ...).
# Exit 2: toolchain missing or the build itself failed.
set -eu

opt=-Os
case "${1:-}" in
-Os | -O2) opt=$1; shift ;;
esac
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
build=${1:-$root/build-arm}
prefix=${EF_ARM_PREFIX:-arm-none-eabi-}

for tool in gcc nm size objdump; do
    if ! command -v "$prefix$tool" >/dev/null 2>&1; then
        echo "build.sh: $prefix$tool not found (Debian: gcc-arm-none-eabi," \
            "libnewlib-arm-none-eabi)" >&2
        exit 2
    fi
done

# MinSizeRel is -Os; -O2 is Release with its default -O3 replaced.
btype=MinSizeRel
[ "$opt" = -O2 ] && btype=Release
mkdir -p "$build"
gen=
command -v ninja >/dev/null 2>&1 && gen="-G Ninja"
# shellcheck disable=SC2086 # $gen is empty or two words on purpose
if ! cmake -S "$root/firmware" -B "$build" $gen \
    -DCMAKE_TOOLCHAIN_FILE="$root/cmake/arm-none-eabi.cmake" -DCMAKE_BUILD_TYPE="$btype" \
    "-DCMAKE_C_FLAGS_RELEASE=-O2 -DNDEBUG" -DEF_WERROR=ON >"$build/configure.log" 2>&1; then
    cat "$build/configure.log" >&2
    exit 2
fi
cmake --build "$build" || exit 2
lib=$build/libef_fw.a

# The link check, compiled as the library is (same CPU, FPU, ABI, sections, warnings).
cpu="-mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard"
warn="-Wall -Wextra -Wpedantic -Wshadow -Wstrict-prototypes -Wmissing-prototypes -Wundef
      -Wvla -Wdouble-promotion -Werror"
elf=$build/link_check.elf
# shellcheck disable=SC2086
"${prefix}gcc" $cpu $opt -std=c11 -ffreestanding -fno-math-errno -ffunction-sections \
    -fdata-sections $warn -I"$root/firmware/include" -c "$here/link_check.c" \
    -o "$build/link_check.o" || exit 2
# No start files: link_check.c brings its own vectors and reset code. nano.specs only
# supplies memcpy/memset if the library calls them; -lgcc anything the compiler needs.
# shellcheck disable=SC2086
"${prefix}gcc" $cpu $opt -nostartfiles --specs=nano.specs -T "$here/link_check.ld" \
    -Wl,--gc-sections -Wl,-Map="$build/link_check.map" "$build/link_check.o" "$lib" \
    -o "$elf" || exit 2

echo "== libef_fw.a ($opt), per object (text includes read-only data)"
"${prefix}size" -t "$lib"
echo "== link_check.elf ($opt, --gc-sections): whole image"
"${prefix}size" "$elf"
echo "== link_check.elf: library functions kept by the link (bytes)"
"${prefix}nm" -S --size-sort -t d "$elf" |
    awk '$3 ~ /^[TtRr]$/ && $4 ~ /^ef_/ { s += $2; printf "  %6d %s\n", $2, $4 }
         END { printf "  %6d total\n", s }'

status=0
# Names a firmware image must not contain. Double helpers: the AEABI ones (__aeabi_dadd,
# __aeabi_dcmplt, __aeabi_f2d, __aeabi_i2d, ...) and libgcc's generic *df* routines.
forbidden='^_*(malloc|free|calloc|realloc|printf|sprintf|puts)(_r)?$'
double='^(__aeabi_d[a-z0-9]*|__aeabi_[a-z0-9]*2d|__[a-z]*df[0-9]|__[a-z]*sfdf[0-9]|__[a-z]*dfsf[0-9]|__float[a-z]*idf|__fix[a-z]*df[a-z]*)$'

bad=$("${prefix}nm" "$elf" | awk '{ print $NF }' | grep -E "$forbidden|$double" | sort -u || true)
if [ -n "$bad" ]; then
    echo "FAIL: link_check.elf contains: $(echo "$bad" | tr '\n' ' ')" >&2
    status=1
fi

# Undefined references of the library, per object, less its own definitions and the three
# memory routines a compiler may emit for struct copies and initializers.
defined=$("${prefix}nm" -g --defined-only "$lib" | awk 'NF == 3 { print $3 }' | sort -u)
undef=$("${prefix}nm" -A -u "$lib" | awk '{ print $NF, $1 }' | sort -u |
    while read -r sym where; do
        case "$sym" in memcpy | memset | memmove) continue ;; esac
        # Table validation (ef_table_parse / ef_table_check, run once at load or boot)
        # checks the file's f64 fields exactly, so it may use the compiler's soft-double
        # helpers (libgcc). The per-segment path may not: link_check.elf, which uses it,
        # is held to no double helpers at all above.
        case "$where" in *ef_table_parse.c.obj*)
            printf '%s\n' "$sym" | grep -qE "$double" && continue ;;
        esac
        if ! printf '%s\n' "$defined" | grep -qx "$sym"; then
            echo "  $sym  (${where%:})"
        fi
    done)
if [ -n "$undef" ]; then
    echo "FAIL: libef_fw.a needs symbols a freestanding firmware does not have:" >&2
    echo "$undef" >&2
    status=1
fi

# The M4F FPU is single precision only: any double arithmetic would be a helper call, which
# the checks above catch. Report what the disassembly calls, for the record.
calls=$("${prefix}objdump" -d "$elf" | grep -oE 'bl?[[:space:]]+[0-9a-f]+ <[^>]+>' |
    sed 's/.*<\(.*\)>/\1/' | sort -u | tr '\n' ' ')
echo "== functions called in link_check.elf: $calls"
if [ "$status" -eq 0 ]; then
    echo "OK: no heap, no stdio, no double-precision helpers in the segment path; library needs only"
    echo "    memcpy/memset/memmove (and libgcc soft-double in table validation, ef_table_parse.c)"
fi
exit $status
