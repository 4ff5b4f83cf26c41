#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# `evenfeed stream` and `evenfeed sim-drive` from the command line: argument errors, an
# unreachable drive, and a whole program streamed to a simulated drive over Modbus TCP.
# The drive signals readiness on stdout (read through a FIFO); it is stopped by its PID.
# usage: test_stream_cli.sh EVENFEED SOURCE_DIR WORK_DIR
set -u
ef=$1
src=$2
work=$3
. "$src/tests/cli_lib.sh"
prog=$src/samples/profile.ngc

expect 1 "expected tcp://HOST:PORT or rtu:" -- stream --modbus udp://x:1 "$prog"
expect 1 "port must be 0..65535" -- stream --modbus tcp://h:99999 "$prog"
expect 1 "frame format" -- stream --modbus rtu:/dev/null,115200,9X1 "$prog"
expect 1 "no --modbus address" -- stream "$prog"
expect 1 "no program" -- stream --modbus tcp://127.0.0.1:1
expect 1 "unknown option '--bogus'" -- stream --bogus --modbus tcp://127.0.0.1:1 "$prog"
# CAN (docs/can.md): argument errors; the streaming itself needs a CAN kernel (hil_can_*).
expect 9 "no such network interface" -- stream --can nosuch0 "$prog"
expect 1 "node 1 given twice" -- stream --can vcan0 --nodes 1,1 "$prog"
expect 1 "node id 0 not 1..127" -- stream --can vcan0 --nodes 0 "$prog"
expect 1 "at most 9 nodes" -- stream --can vcan0 --nodes 1,2,3,4,5,6,7,8,9,10 "$prog"
expect 1 "not a CAN mode" -- stream --can vcan0 --mode direct "$prog"
expect 1 "is a Modbus option" -- stream --can vcan0 --slave 2 "$prog"
expect 1 "is a CAN option" -- stream --modbus tcp://127.0.0.1:1 --nodes 1 "$prog"
expect 1 "--hb-timeout '5'" -- stream --can vcan0 --hb-timeout 5 "$prog"
expect 1 "--bringup-ms '10'" -- stream --can vcan0 --bringup-ms 10 "$prog"
expect 1 "--enable-timeout '5'" -- stream --can vcan0 --enable-timeout 5 "$prog"
expect 1 "--bringup-ms is a CAN option" -- stream --modbus tcp://127.0.0.1:1 --bringup-ms 5000 "$prog"
expect 1 "needs --iface IFACE and --node N" -- sim-drive can
expect 1 "--node '200'" -- sim-drive can --iface vcan0 --node 200
expect 1 "--fault-at 'x'" -- sim-drive can --iface vcan0 --node 1 --fault-at x
expect 1 "--slave '300'" -- stream --slave 300 --modbus tcp://127.0.0.1:1 "$prog"
expect 1 "give --tcp HOST:PORT or --rtu DEVICE" -- sim-drive modbus
expect 1 "--time-scale" -- sim-drive modbus --tcp 127.0.0.1:0 --time-scale 0
# Nothing listens on port 1: connection refused after the reconnect window.
expect 45 "cannot connect" -- stream --modbus tcp://127.0.0.1:1 "$prog"
# A missing program is reported before anything is sent.
expect 9 "nothing.ngc" -- stream --modbus tcp://127.0.0.1:1 "$work/nothing.ngc"

# The real thing: a drive on a free port, the program streamed, the drive stopped.
fifo=$work/sim-drive.fifo
rm -f "$fifo"
mkfifo "$fifo"
"$ef" sim-drive modbus --tcp 127.0.0.1:0 --time-scale 8 --trace "$work/stream-cli.csv" >"$fifo" &
pid=$!
exec 3<"$fifo"
if read -r -t 10 line <&3 && [[ $line == "ready tcp "* ]]; then
    ok
    port=${line##*:}
    out=$("$ef" stream --modbus "tcp://127.0.0.1:$port" "$prog" 2>&1)
    rc=$?
    # every segment the smoother made (however many that is for the profile) executed
    n=$(sed -n "s|^stream: \([0-9]*\) segments to tcp://127.0.0.1:$port.*|\1|p" <<<"$out")
    if [ $rc -eq 0 ] && [ "${n:-0}" -gt 100 ] &&
        grep -q "^drive: state 0, fault 0, $n segments executed" <<<"$out"; then
        ok
    else
        bad "stream to the simulated drive: exit $rc: $out"
    fi
    # A second stream on the same drive starts where the first ended: refused, nothing sent.
    expect 1 "the path starts at .* but the drive is at" -- stream --modbus "tcp://127.0.0.1:$port" "$prog"
else
    bad "sim-drive did not become ready: '${line:-}'"
fi
kill "$pid"
wait "$pid"
[ $? -eq 0 ] && ok || bad "sim-drive did not exit cleanly on SIGTERM"
exec 3<&-
rm -f "$fifo"
grep -q "^#accepted $((${n:-0} - 1))\$" "$work/stream-cli.csv" && ok || bad "trace lacks the last segment"

echo "stream cli: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
