# SPDX-License-Identifier: Apache-2.0
# Helpers for guest scripts run by uml_run.sh (source with: . "$EF_HIL_DIR/hil_lib.sh").
# Background processes are tracked and stopped by PID; readiness is a file the process
# writes (or any condition), waited for with a bound, never a fixed sleep.

HIL_PIDS=""

# hil_bg LOG CMD [ARGS...]: start CMD in the background (output to LOG); sets HIL_PID.
hil_bg() {
    _log=$1
    shift
    "$@" >"$_log" 2>&1 &
    HIL_PID=$!
    HIL_PIDS="$HIL_PIDS $HIL_PID"
}

# hil_wait SECONDS CMD [ARGS...]: poll until CMD succeeds; 1 if SECONDS pass first.
hil_wait() {
    _end=$(($(date +%s) + $1))
    shift
    until "$@" >/dev/null 2>&1; do
        [ "$(date +%s)" -ge "$_end" ] && { echo "hil_wait: '$*' not true within the bound"; return 1; }
        sleep 0.01
    done
}

# hil_wait_file SECONDS FILE: wait until FILE exists and is not empty (a readiness file).
hil_wait_file() {
    hil_wait "$1" test -s "$2"
}

# hil_stop PID [SECONDS]: SIGTERM, then SIGKILL after SECONDS (default 5); returns its status.
hil_stop() {
    _p=$1
    _n=$((${2:-5} * 20))
    kill -TERM "$_p" 2>/dev/null
    while kill -0 "$_p" 2>/dev/null && [ $_n -gt 0 ]; do
        sleep 0.05
        _n=$((_n - 1))
    done
    kill -0 "$_p" 2>/dev/null && kill -KILL "$_p" 2>/dev/null
    wait "$_p"
}

# hil_stop_all: stop every process hil_bg started (for an EXIT trap).
hil_stop_all() {
    for _q in $HIL_PIDS; do
        kill -0 "$_q" 2>/dev/null && hil_stop "$_q" 2
    done
    HIL_PIDS=""
}
