#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# `evenfeed can list` and `evenfeed stream --can gsusb...` from the command line, with no
# adapter attached: the list says so (exit 0), malformed specs and options are refused with
# a message naming what is wrong, and an absent adapter is an I/O error (exit 9) naming it.
# usage: test_gsusb_cli.sh EVENFEED SOURCE_DIR
set -u
ef=$1
src=$2
. "$src/tests/cli_lib.sh"
prog=$src/samples/profile.ngc

# With an adapter on the build host the list names it instead; libusb unusable: exit 9.
if out=$("$ef" can list 2>&1); then
    if grep -qE "^no gs_usb adapter found$|^[0-9a-f]{4}:[0-9a-f]{4} " <<<"$out"; then ok; else
        bad "can list: unexpected output: $out"; fi
else
    grep -q "libusb_init" <<<"$out" && ok || bad "can list failed: $out"
fi
if out=$("$ef" can list --json 2>&1); then
    grep -q '^{"adapters": \[' <<<"$out" && ok || bad "can list --json: $out"
else
    grep -q "libusb_init" <<<"$out" && ok || bad "can list --json failed: $out"
fi
expect 0 "usage: evenfeed can list" -- can --help
expect 1 "list is the one subcommand" -- can
expect 1 "list is the one subcommand" -- can probe
expect 1 "unexpected argument 'x'" -- can list x
expect 1 "unknown option '--bogus'" -- can list --bogus

expect 0 "gsusb\[:SERIAL\]\[@BITRATE\]" -- stream --help
expect 0 "--can-opts LIST" -- stream --help
expect 1 "empty serial after ':'" -- stream --can gsusb: "$prog"
expect 1 "bitrate after '@' must be a number" -- stream --can gsusb@ "$prog"
expect 1 "bitrate after '@' must be a number" -- stream --can gsusb:EF01@fast "$prog"
expect 1 "bitrate 2000000 not 1..1000000" -- stream --can gsusb@2000000 "$prog"
expect 1 "bitrate 0 not 1..1000000" -- stream --can gsusb:EF01@0 "$prog"
expect 1 "--can-opts is for gs_usb adapters" -- stream --can vcan0 --can-opts loopback "$prog"
expect 1 "unknown 'turbo'" -- stream --can gsusb --can-opts turbo "$prog"
expect 1 "channel 0..7" -- stream --can gsusb --can-opts channel=9 "$prog"
expect 1 "exclude each other" -- stream --can gsusb --can-opts loopback,listen-only "$prog"
expect 1 "is a CAN option" -- stream --modbus tcp://127.0.0.1:1 --can-opts loopback "$prog"
# No adapter (or none by that serial): an I/O error naming it, before any program is read.
if "$ef" can list 2>/dev/null | grep -q "^no gs_usb adapter found$"; then
    expect 9 "gs_usb EFNONE01: no gs_usb adapter found" -- stream --can gsusb:EFNONE01@500000 "$prog"
    expect 9 "gs_usb: no gs_usb adapter found" -- stream --can gsusb "$prog"
else
    ok
fi

echo "gsusb cli: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
