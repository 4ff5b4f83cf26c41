#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Guest side of the hil_gpio_* tests (run by uml_run.sh inside User-Mode Linux with gpio-sim):
#   gpio.sh TEST_BINARY PART
# Makes the simulated chip tests/io/test_gpio.c expects (8 lines, names below, a kernel hog
# "ef-hog" on line 7), checks the helpers of gpio_lib.sh on it, and runs the binary's part
# PART with the chip's device and sysfs directory.
set -u
test_bin=$1
part=$2
. "$EF_HIL_DIR/gpio_lib.sh"

command -v gpioinfo >/dev/null 2>&1 || { echo "gpio.sh: gpioinfo missing in the guest (package gpiod)"; exit 1; }
gsim_setup || exit 1
# Line layout: keep in step with SIM_* in tests/io/test_gpio.c.
dev=$(gsim_chip efsim 8 "ESTOP LIMIT ENABLE BRAKE PROBE - - HOGGED" 7 ef-hog) || exit 1
sys=$(gsim_sysdir efsim)
echo "gpio.sh: chip efsim is $dev, $sys"
gpioinfo "$(basename "$dev")"

# The helpers themselves: a pull moves an unrequested line, the hog drives its line high.
fail=0
if ! gsim_pull efsim 4 pull-up || [ "$(gsim_value efsim 4)" != 1 ]; then
    echo "gpio.sh: gsim_pull up not seen"
    fail=1
fi
if ! gsim_pull efsim 4 pull-down || [ "$(gsim_value efsim 4)" != 0 ]; then
    echo "gpio.sh: gsim_pull down not seen"
    fail=1
fi
[ "$(gsim_value efsim 7)" = 1 ] || { echo "gpio.sh: the hog does not drive line 7 high"; fail=1; }
gpioinfo "$(basename "$dev")" | grep -q '"ef-hog"' || { echo "gpio.sh: gpioinfo does not show the hog"; fail=1; }
[ $fail = 0 ] || exit 1

"$test_bin" "$part" "$dev" "$sys"
rc=$?

# Whatever the part did, nothing of evenfeed holds a line once it has exited.
if gpioinfo "$(basename "$dev")" | grep -q '"evenfeed"'; then
    echo "gpio.sh: lines still held by evenfeed after the test exited"
    gpioinfo "$(basename "$dev")"
    rc=1
fi
gsim_remove efsim || { echo "gpio.sh: removing the chip failed"; rc=1; }
exit $rc
