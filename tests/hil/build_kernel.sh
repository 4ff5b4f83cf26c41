#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Build the project's hardware-in-loop kernel: User-Mode Linux from Debian's linux-source-6.1
# with the options in tests/hil/uml-hil.fragment built in (vcan, gpio-sim, dummy_hcd,
# configfs, FunctionFS, gs_usb).
#
#   build_kernel.sh OUT_DIR
#
# The kernel lands in OUT_DIR/<key>/linux, where <key> is a hash of the fragment, this
# script and the source package's version: a kernel is built once per key (about 6 minutes
# on 2 cores) and reused after that. OUT_DIR/linux is a link to the newest one; its path is
# the last line printed. Callers running at the same time wait for each other (flock).
# Needs: linux-source-6.1 flex bison bc make gcc libc6-dev xz-utils (./dev installs them).
#
# Environment: EF_HIL_JOBS (make -j, default: nproc), EF_HIL_KEEP_OBJ=1 keeps the object
# tree (OUT_DIR/<key>/obj) for a later incremental build.
set -euo pipefail

if [ $# -ne 1 ]; then
    echo "usage: $0 OUT_DIR" >&2
    exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
frag=$here/uml-hil.fragment
tarball=/usr/src/linux-source-6.1.tar.xz
mkdir -p "$1"
out=$(cd "$1" && pwd)

[ -r "$tarball" ] || {
    echo "build_kernel: $tarball missing: install linux-source-6.1" >&2
    exit 1
}
for t in flex bison bc make gcc xz; do
    command -v "$t" >/dev/null || {
        echo "build_kernel: '$t' missing (packages: flex bison bc make gcc xz-utils)" >&2
        exit 1
    }
done

srcver=$(dpkg-query -W -f='${Version}' linux-source-6.1 2>/dev/null || stat -c %s "$tarball")
key=$({ cat "$frag" "$0"; echo "$srcver"; } | sha256sum | cut -c1-12)
dir=$out/$key

exec 9>"$out/.lock"
flock 9

link() {
    ln -sfn "$key/linux" "$out/linux"
    echo "$out/linux"
}
if [ -x "$dir/linux" ] && [ -e "$dir/ok" ]; then
    link
    exit 0
fi

echo "build_kernel: building the HIL kernel $key (linux-source-6.1 $srcver) in $dir" >&2
start=$(date +%s)
rm -rf "$dir"
mkdir -p "$dir"
src=$out/src-$srcver
if [ ! -e "$src/.unpacked" ]; then
    rm -rf "$src"
    mkdir -p "$src"
    tar -xJf "$tarball" -C "$src" --strip-components=1
    touch "$src/.unpacked"
fi

# The fragment without comments is the set of symbols allnoconfig must honour
# (KCONFIG_ALLCONFIG: choices such as HZ_1000 are resolved by kconfig itself).
want=$dir/want.config
grep -E '^(CONFIG_[A-Z0-9_]+=.*|# CONFIG_[A-Z0-9_]+ is not set)$' "$frag" >"$want"
obj=$dir/obj
mkdir -p "$obj"
make -C "$src" ARCH=um O="$obj" KCONFIG_ALLCONFIG="$want" allnoconfig >"$dir/config.log" 2>&1 || {
    tail -n 30 "$dir/config.log" >&2
    exit 1
}

# Every option as asked, or stop here: kconfig drops a symbol whose dependencies are unmet
# without a word.
missing=0
while IFS= read -r line; do
    if ! grep -qxF "$line" "$obj/.config"; then
        name=${line%%=*}
        name=${name#\# }
        name=${name%% is not set}
        echo "build_kernel: '$line' asked, .config has: $(grep -E "(^|# )$name[= ]" "$obj/.config" || echo nothing)" >&2
        missing=1
    fi
done <"$want"
[ $missing = 0 ] || {
    echo "build_kernel: the fragment's options are not all met (see above)" >&2
    exit 1
}

jobs=${EF_HIL_JOBS:-$(nproc)}
if ! make -C "$src" ARCH=um O="$obj" -j"$jobs" linux >"$dir/build.log" 2>&1; then
    grep -E "error|Error" "$dir/build.log" | head -n 20 >&2
    tail -n 20 "$dir/build.log" >&2
    echo "build_kernel: build failed (log: $dir/build.log)" >&2
    exit 1
fi
cp "$obj/linux" "$dir/linux"
cp "$obj/.config" "$dir/config"
touch "$dir/ok"
# What a finished build no longer needs: its objects, the unpacked source (1.4 GB), and
# the remains of builds that did not finish.
if [ "${EF_HIL_KEEP_OBJ:-0}" != 1 ]; then
    rm -rf "$obj" "$src"
fi
for d in "$out"/*/; do
    [ -e "$d/ok" ] || [ "${d%/}" = "$src" ] || rm -rf "$d"
done
echo "build_kernel: built in $(($(date +%s) - start)) s" >&2
link
