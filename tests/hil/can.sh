#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Guest side of the hil_can_* tests (run by uml_run.sh inside User-Mode Linux, vcan0 up):
#   can.sh TEST_BINARY EVENFEED SRC_DIR WORKDIR PART
# Runs test_can_hil, which starts three simulated drives and the streamer on vcan0 and
# checks what they wrote (tests/can/test_can_hil.c). The io_* parts get a gpio-sim chip
# (EF_GSIM_CHIP, EF_GSIM_SYS) for the machine I/O.
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
case $part in
io_*)
    # The machine I/O parts: one simulated GPIO chip, its lines named as in the machine file
    # the test writes (e-stop, enable, alarm, charge pump, feed hold, cycle start, outputs).
    . "$EF_HIL_DIR/gpio_lib.sh"
    gsim_setup || exit 1
    # STO and ALMOUT are a drive's own (sim-drive --sto, --alarm-out).
    dev=$(gsim_chip efio 10 "ESTOP ENABLE ALARM PUMP HOLD START OUT0 OUT1 STO ALMOUT") || exit 1
    EF_GSIM_CHIP=${dev#/dev/}
    EF_GSIM_SYS=$(gsim_sysdir efio)
    export EF_GSIM_CHIP EF_GSIM_SYS
    echo "can.sh: gpio-sim chip $EF_GSIM_CHIP ($EF_GSIM_SYS)"
    ;;
esac
"$test_bin" "$ef" "$src" "$work" "$part"
