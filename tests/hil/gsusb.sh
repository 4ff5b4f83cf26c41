#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Guest side of hil_gsusb_kernel (run by uml_run.sh inside User-Mode Linux, vcan0 up):
#   gsusb.sh EVENFEED WORKDIR
# The simulated gs_usb adapter (`evenfeed sim-adapter gsusb`, a FunctionFS gadget on
# dummy_hcd) checked against the kernel's own gs_usb driver: the kernel binds to it and
# makes a CAN interface, whose bit timing, TX (with the echo), RX and the adapter's
# bridge to vcan0 are exercised with iproute2 and can-utils. Every background process is
# stopped by its PID; readiness is waited for with a bound, never a fixed sleep.
set -u
ef=$1
work=$2
. "$EF_HIL_DIR/hil_lib.sh"
trap hil_stop_all EXIT
mkdir -p "$work" && rm -f "$work"/*
for t in candump cansend ip; do
    command -v "$t" >/dev/null 2>&1 || { echo "gsusb.sh: $t missing in the guest"; exit 1; }
done
G=/sys/kernel/config/usb_gadget/efhil

fail() {
    echo "FAIL: $*"
    for f in "$work"/*.log; do
        [ -r "$f" ] && { echo "---- $f"; tail -n 40 "$f"; }
    done
    exit 1
}

# The first CAN interface that is not vcan: the one gs_usb made.
gs_if() {
    for d in /sys/class/net/*; do
        n=${d##*/}
        case $n in vcan*) continue ;; esac
        [ "$(cat "$d/type" 2>/dev/null)" = 280 ] && { echo "$n"; return 0; }
    done
    return 1
}

# Frames seen in a candump -L log ("(ts) IFACE ID#DATA"): count of lines with ID#DATA.
seen() {
    grep -c " $2\$" "$1" 2>/dev/null
}
has() {
    [ "$(seen "$1" "$2")" -ge "${3:-1}" ]
}

# 1. The adapter comes up: configfs, FunctionFS, bound to dummy_hcd, configured by the host.
hil_bg "$work/adapter.log" "$ef" sim-adapter gsusb --iface vcan0 --serial HIL0001 --name efhil \
    --verbose
adapter=$HIL_PID
hil_wait 30 grep -q '^ready gs_usb serial=HIL0001 udc=' "$work/adapter.log" ||
    fail "no ready line from sim-adapter within 30 s"
echo "checked: $(grep '^ready' "$work/adapter.log")"
for a in idVendor idProduct; do
    echo "checked: configfs $a $(cat $G/$a)"
done
hil_wait 20 gs_if || fail "the kernel's gs_usb driver made no CAN interface within 20 s"
can=$(gs_if)
echo "checked: gs_usb bound the adapter: $can ($(readlink -f /sys/class/net/$can/device | sed 's|.*/devices/||'))"

# 2. Bit timing. With CAN_CALC_BITTIMING the kernel computes it from BT_CONST: 1000 bit/s
# needs a prescaler above brp_max (48 MHz / 1000 / 25 quanta = 1920 > 1024), which the
# kernel refuses itself. Without it (the kernel says "bit-timing calculation not
# available") the timing is given explicitly: 1 Mbit/s as 8 quanta of 125 ns (brp 6), and
# tseg1 = 40 quanta (above tseg1_max 16) as the timing the device cannot make.
BT1M="bitrate 1000000"
BTBAD="bitrate 1000"
if ! ip link set "$can" type can bitrate 1000000 >"$work/bt.log" 2>&1; then
    dmesg | grep -q "bit-timing calculation not available" ||
        fail "ip link set $can type can bitrate 1000000 failed: $(cat "$work/bt.log")"
    echo "NOTE: this kernel lacks CONFIG_CAN_CALC_BITTIMING (\"bitrate\" is refused by" \
        "the kernel whatever the device): explicit bit timings used"
    BT1M="tq 125 prop-seg 2 phase-seg1 3 phase-seg2 2 sjw 1"
    BTBAD="tq 125 prop-seg 20 phase-seg1 20 phase-seg2 2 sjw 1"
fi
# shellcheck disable=SC2086 # BTBAD, BT1M: several words on purpose
if ip link set "$can" type can $BTBAD >"$work/btbad.log" 2>&1; then
    fail "'$BTBAD' accepted on a 48 MHz clock with brp_max 1024, tseg1_max 16"
fi
echo "checked: '$BTBAD' refused by the kernel ($(head -n 1 "$work/btbad.log"))"
# shellcheck disable=SC2086
ip link set "$can" up type can $BT1M >"$work/up.log" 2>&1 ||
    fail "ip link set $can up type can $BT1M failed: $(cat "$work/up.log")"
grep -q "bit timing .*1000000 bit/s" "$work/adapter.log" ||
    fail "the adapter did not log a 1 Mbit/s bit timing"
grep -q "channel 0: started" "$work/adapter.log" || fail "the adapter did not start channel 0"
echo "checked: $can up with '$BT1M': $(grep 'bit timing' "$work/adapter.log" | tail -n 1 | sed 's/^sim-adapter: //')"
ip -d link show "$can" | grep -E "bitrate|tq" | sed 's/^ */    /'

# 3. Bus -> host: a simulated CANopen drive on vcan0 boots (0x701#00); an SDO write from
# can0 (through the adapter) sets its heartbeat to 100 ms; candump on can0 sees the SDO
# answer and heartbeats.
hil_bg "$work/candump-can.log" candump -L "$can"
dump_can=$HIL_PID
hil_bg "$work/candump-vcan.log" candump -L vcan0
dump_vcan=$HIL_PID
# candump gives no readiness signal: a probe frame on each bus, repeated until seen,
# tells that both are listening (and that the bridge works both ways).
i=0
until has "$work/candump-vcan.log" "7FF#01" && has "$work/candump-can.log" "7FE#02"; do
    i=$((i + 1))
    [ $i -gt 200 ] && fail "candump did not see the probe frames 7FF#01 (vcan0) / 7FE#02 ($can)"
    has "$work/candump-vcan.log" "7FF#01" || cansend "$can" 7FF#01
    has "$work/candump-can.log" "7FE#02" || cansend vcan0 7FE#02
    sleep 0.05
done
echo "checked: both candumps listen (probes crossed the adapter after $i tries)"
hil_bg "$work/drive.log" "$ef" sim-drive can --iface vcan0 --node 1
drive=$HIL_PID
hil_wait 20 has "$work/candump-can.log" "701#00" ||
    fail "candump $can did not see the drive's boot-up 701#00 within 20 s"
echo "checked: candump $can saw the drive's boot-up 701#00"
cansend "$can" 601#2B17100064000000
hil_wait 20 has "$work/candump-can.log" "581#6017100000000000" ||
    fail "no SDO answer 581#60171000... on $can within 20 s"
hil_wait 20 has "$work/candump-can.log" "701#7F" 3 ||
    fail "fewer than 3 heartbeats 701#7F on $can within 20 s"
echo "checked: SDO 0x1017 = 100 ms through the adapter answered; $(seen "$work/candump-can.log" "701#7F") heartbeats 701#7F on $can"

# 4. Host -> bus: cansend on can0 reaches vcan0; the kernel's TX echo counts it.
tx0=$(ip -s link show "$can" | awk '/TX:/ { getline; print $2; exit }')
cansend "$can" 123#DEADBEEF
hil_wait 20 has "$work/candump-vcan.log" "123#DEADBEEF" ||
    fail "cansend $can 123#DEADBEEF did not appear on vcan0 within 20 s"
echo "checked: cansend $can 123#DEADBEEF appeared on vcan0"
txok() {
    [ "$(ip -s link show "$can" | awk '/TX:/ { getline; print $2; exit }')" -gt "$tx0" ]
}
hil_wait 10 txok || fail "TX packets of $can did not grow after the echo (still $tx0)"
echo "checked: TX echo: $can TX packets $tx0 -> $(ip -s link show "$can" | awk '/TX:/ { getline; print $2; exit }')"
# Echoes of everything sent: the kernel frees a TX slot only on its echo, so 30 frames
# (3 times its 10 slots) through the adapter prove the echo path keeps up.
k=0
while [ $k -lt 30 ]; do
    cansend "$can" "124#$(printf '%02X' $k)" || fail "cansend $k failed (TX window stuck?)"
    k=$((k + 1))
done
hil_wait 20 has "$work/candump-vcan.log" "124#1D" || fail "frame 30 of 30 not on vcan0"
echo "checked: 30 frames more through the adapter; $(grep -c ' 124#' "$work/candump-vcan.log") on vcan0"
ip -s link show "$can" | sed 's/^/    /'

# 5. Stop everything by PID; the adapter removes its gadget, and starts again cleanly.
hil_stop $drive
ip link set "$can" down
hil_stop $adapter 10 || fail "sim-adapter exit status $? after SIGTERM"
hil_stop $dump_can 2
hil_stop $dump_vcan 2
HIL_PIDS=""
[ -e "$G" ] && fail "the gadget $G is still in configfs after the adapter stopped"
grep ' functionfs ' /proc/mounts && fail "FunctionFS still mounted after the adapter stopped"
echo "checked: adapter stopped; gadget removed from configfs, FunctionFS unmounted"
grep '^sim-adapter: requests' "$work/adapter.log" | sed 's/^/    /'
# The second start refuses bit timings above 500 kbit/s (--fault bitrate-max): the
# kernel's BITTIMING is taken (FunctionFS cannot stall an OUT request after its data) and
# the following MODE start is stalled, so bringing the interface up fails.
hil_bg "$work/adapter2.log" "$ef" sim-adapter gsusb --iface vcan0 --serial HIL0002 --name efhil \
    --fault bitrate-max=500000
adapter=$HIL_PID
hil_wait 30 grep -q '^ready gs_usb serial=HIL0002' "$work/adapter2.log" ||
    fail "a second start in the same guest did not get ready"
hil_wait 20 gs_if || fail "no CAN interface for the second start within 20 s"
can=$(gs_if)
# shellcheck disable=SC2086
if ip link set "$can" up type can $BT1M >"$work/up2.log" 2>&1; then
    fail "$can came up at 1 Mbit/s on an adapter refusing more than 500 kbit/s"
fi
grep -q "BITTIMING refused" "$work/adapter2.log" || fail "the adapter did not refuse BITTIMING"
echo "checked: a second start in the same guest was ready; with --fault bitrate-max=500000" \
    "'ip link set $can up' at 1 Mbit/s failed ($(head -n 1 "$work/up2.log"))"
echo "    $(grep 'BITTIMING refused' "$work/adapter2.log" | head -n 1)"
hil_stop $adapter 10 || fail "second sim-adapter exit status $?"
HIL_PIDS=""
[ -e "$G" ] && fail "the gadget $G is still in configfs after the second stop"
echo "gsusb.sh: all checks passed"
