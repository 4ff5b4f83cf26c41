#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Guest side of the hil_can_* tests (run by uml_run.sh inside User-Mode Linux, vcan0 up):
#   can.sh TEST_BINARY EVENFEED SRC_DIR WORKDIR PART
# Runs test_can_hil, which starts three simulated drives and the streamer on vcan0 and
# checks what they wrote (tests/can/test_can_hil.c).
set -u
test_bin=$1
ef=$2
src=$3
work=$4
part=$5
for t in log2asc ip; do
    command -v "$t" >/dev/null 2>&1 || { echo "can.sh: $t missing in the guest"; exit 1; }
done
mkdir -p "$work" && rm -f "$work"/*
"$test_bin" "$ef" "$src" "$work" "$part"
