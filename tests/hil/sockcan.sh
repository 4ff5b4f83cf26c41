#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Guest side of hil_sockcan (run by uml_run.sh inside User-Mode Linux, vcan0 up):
#   sockcan.sh TEST_BINARY WORKDIR
# Checks the tools the test calls, loads the plug qdisc it uses for ENOBUFS, runs the test.
set -u
test_bin=$1
work=$2
for t in canplayer log2asc tc ip; do
    command -v "$t" >/dev/null 2>&1 || { echo "sockcan.sh: $t missing in the guest"; exit 1; }
done
# The project's kernel has it built in (no module tree); a stock kernel loads the module.
if [ -d "/usr/lib/uml/modules/$(uname -r)" ] && [ ! -d /sys/module/sch_plug ]; then
    ko=$(find "/usr/lib/uml/modules/$(uname -r)" -name sch_plug.ko | head -n 1)
    insmod "$ko" || { echo "sockcan.sh: cannot load sch_plug ($ko)"; exit 1; }
fi
mkdir -p "$work" && rm -f "$work"/*.log "$work"/*.asc
"$test_bin" hil "$work"
