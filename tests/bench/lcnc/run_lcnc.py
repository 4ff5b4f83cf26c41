#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Headless LinuxCNC "display" for the benchmark (machine.ini [DISPLAY] DISPLAY).

LinuxCNC starts it as ``./run_lcnc.py -ini machine.ini`` once task, motion and HAL are up;
when it exits, LinuxCNC shuts down. It runs one program and writes the sampled setpoints:

  EF_LCNC_PROGRAM   absolute path of the .ngc program (required)
  EF_LCNC_OUT       absolute path of the TSV to write (required)
  EF_LCNC_TIMEOUT   seconds the program may run before the script gives up (default 300)
  EF_LCNC_DEBUG     1: log every change of the polled task/interpreter/motion state
  EF_LCNC_ACTIONS   what to do while the program runs (the planner module's tests,
                    tests/lcnc/): "TRIGGER ACTION" items separated by ";", in order, each
                    after the one before. TRIGGER: t=S (S seconds after motion is released)
                    or line=N (motion has reached source line N); ACTION: feed=X (feed
                    override), pause, resume or abort. After an abort the run ends once
                    motion has come to rest with its queue empty.

Sequence: estop reset, machine on, home all joints (homed in place), auto mode, feed and
rapid override 1, open the program, start halsampler on sampler.0, enable the sampler, run
with motion held (motion.feed-inhibit) until the program is queued (run_program), release,
wait (polling stat and the error channel) until the interpreter is idle, the motion queue
is empty and the machine is in position, disable the sampler, wait until halsampler has
drained its FIFO, stop halsampler and write the TSV: a header line, then one row per servo
period (1 ms): n (sample index from 0), x, y, z (mm, axis.L.pos-cmd), line
(motion.program-line). Exit 0 on success, 1 on any failure (message on stderr).

Uses Debian's /usr/bin/python3, which has LinuxCNC's modules.
"""

import os
import signal
import subprocess
import sys
import time

import linuxcnc

POLL_S = 0.005  # stat polling interval
STEP_TIMEOUT_S = 30.0  # each start-up step (estop reset, on, home, mode, open)
DEBUG = os.environ.get("EF_LCNC_DEBUG") == "1"  # log every change of the polled state


class RunError(Exception):
    pass


def log(msg):
    sys.stderr.write("run_lcnc: %s\n" % msg)
    sys.stderr.flush()


class Machine:
    def __init__(self):
        self.s = linuxcnc.stat()
        self.c = linuxcnc.command()
        self.e = linuxcnc.error_channel()

    def check_errors(self):
        err = self.e.poll()
        if err:
            kind, text = err
            if kind in (linuxcnc.NML_ERROR, linuxcnc.OPERATOR_ERROR):
                raise RunError("LinuxCNC error: %s" % text)
            log("LinuxCNC message: %s" % text)

    def wait_for(self, what, pred, timeout):
        """Poll stat until pred(stat) is true; raise on timeout or a LinuxCNC error."""
        deadline = time.monotonic() + timeout
        last = None
        while True:
            self.s.poll()
            self.check_errors()
            if DEBUG:
                st = self.s
                now = (st.task_state, st.task_mode, st.interp_state, st.exec_state, st.state,
                       st.queue, st.inpos, st.current_line, st.motion_line)
                if now != last:
                    log("%s: task %d mode %d interp %d exec %d state %d queue %d inpos %d "
                        "line %d/%d" % ((what,) + now))
                    last = now
            if pred(self.s):
                return
            if time.monotonic() > deadline:
                raise RunError("timeout (%.0f s) waiting for %s" % (timeout, what))
            time.sleep(POLL_S)

    def command(self, what, fn, pred):
        fn()
        if self.c.wait_complete(STEP_TIMEOUT_S) == -1:
            raise RunError("timeout waiting for LinuxCNC to accept: %s" % what)
        self.wait_for(what, pred, STEP_TIMEOUT_S)


def halcmd(*args):
    r = subprocess.run(["halcmd"] + list(args), stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, universal_newlines=True)
    if r.returncode != 0:
        raise RunError("halcmd %s: %s" % (" ".join(args), r.stderr.strip()))
    return r.stdout.strip()


def getp(name):
    return halcmd("getp", name)


def start_machine(m, program):
    L = linuxcnc
    m.wait_for("task", lambda s: s.task_state in (L.STATE_ESTOP, L.STATE_ESTOP_RESET,
                                                   L.STATE_OFF, L.STATE_ON), STEP_TIMEOUT_S)
    m.command("estop reset", lambda: m.c.state(L.STATE_ESTOP_RESET),
              lambda s: s.task_state != L.STATE_ESTOP)
    m.command("machine on", lambda: m.c.state(L.STATE_ON),
              lambda s: s.task_state == L.STATE_ON)
    m.command("manual mode", lambda: m.c.mode(L.MODE_MANUAL),
              lambda s: s.task_mode == L.MODE_MANUAL)
    m.command("home all", lambda: m.c.home(-1),
              lambda s: all(s.homed[j] for j in range(s.joints)))
    m.command("auto mode", lambda: m.c.mode(L.MODE_AUTO),
              lambda s: s.task_mode == L.MODE_AUTO)
    m.command("feed override 1", lambda: m.c.feedrate(1.0),
              lambda s: abs(s.feedrate - 1.0) < 1e-12)
    m.command("rapid override 1", lambda: m.c.rapidrate(1.0),
              lambda s: abs(s.rapidrate - 1.0) < 1e-12)
    m.command("open " + program, lambda: m.c.program_open(program),
              lambda s: s.file == program)
    s = m.s
    if abs(s.feedrate - 1.0) > 1e-12 or abs(s.rapidrate - 1.0) > 1e-12:
        raise RunError("feed override %g, rapid override %g (must be 1)"
                       % (s.feedrate, s.rapidrate))
    if s.adaptive_feed_enabled:
        raise RunError("adaptive feed is enabled")
    log("ready: max_velocity %g mm/s, max_acceleration %g mm/s^2, feed %g, rapid %g"
        % (s.max_velocity, s.max_acceleration, s.feedrate, s.rapidrate))


def run_program(m, timeout):
    """Run the program: hold motion until it is queued, then wait until it has ended and
    every queued move is done.

    Task hands the planner one move per task cycle; with dense programs the planner can
    consume them faster, and how often it then runs dry depends on how the host schedules
    task, i.e. on the host's load. To make LinuxCNC's figures repeatable (and give its
    planner its best case, full look-ahead), motion.feed-inhibit holds the machine until
    task has queued everything up to the next point where it waits for motion (the program
    end, an event that needs the machine at rest) or the planner's queue is full."""
    L = linuxcnc
    waiting = (L.EXEC_WAITING_FOR_MOTION, L.EXEC_WAITING_FOR_MOTION_QUEUE,
               L.EXEC_WAITING_FOR_MOTION_AND_IO)
    halcmd("setp", "motion.feed-inhibit", "1")
    m.c.auto(L.AUTO_RUN, 0)
    serial = m.c.serial
    # Task echoes the command's serial number once it has taken it; its status stays
    # RCS_EXEC while the program runs and becomes RCS_DONE when the program has ended.
    m.wait_for("the program to be queued",
               lambda s: (s.echo_serial_number >= serial and s.queue > 0
                          and (s.queue_full or s.exec_state in waiting)),
               STEP_TIMEOUT_S)
    queued = m.s.queue
    halcmd("setp", "motion.feed-inhibit", "0")
    if run_actions(m, timeout):
        m.wait_for("rest after the abort",
                   lambda s: s.queue == 0 and s.inpos and s.interp_state == L.INTERP_IDLE,
                   timeout)
        return queued
    m.wait_for("program end",
               lambda s: (s.echo_serial_number >= serial and s.state == L.RCS_DONE
                          and s.interp_state == L.INTERP_IDLE and s.queue == 0
                          and s.exec_state == L.EXEC_DONE and s.inpos),
               timeout)
    return queued


def parse_actions(text):
    """EF_LCNC_ACTIONS -> [(kind, value, action, arg)]."""
    out = []
    for item in filter(None, (x.strip() for x in text.split(";"))):
        w = item.split()
        if len(w) != 2 or "=" not in w[0]:
            raise RunError("bad EF_LCNC_ACTIONS item %r" % item)
        kind, val = w[0].split("=", 1)
        act, _, arg = w[1].partition("=")
        if kind not in ("t", "line") or act not in ("feed", "pause", "resume", "abort"):
            raise RunError("bad EF_LCNC_ACTIONS item %r" % item)
        out.append((kind, float(val), act, float(arg) if arg else None))
    return out


def run_actions(m, timeout):
    """Do EF_LCNC_ACTIONS while the program runs; True when one of them was an abort."""
    L = linuxcnc
    t0 = time.monotonic()
    aborted = False
    for kind, val, act, arg in parse_actions(os.environ.get("EF_LCNC_ACTIONS", "")):
        if kind == "t":
            m.wait_for("t=%g" % val, lambda s: time.monotonic() - t0 >= val, timeout)
        else:
            m.wait_for("line %d" % val, lambda s: s.motion_line >= val, timeout)
        log("action at %s=%g (%.3f s): %s%s" % (kind, val, time.monotonic() - t0, act,
                                                 "" if arg is None else "=%g" % arg))
        # (task completes these commands only when the program ends: wait for their
        # effect in the status instead of wait_complete())
        if act == "feed":
            m.c.feedrate(arg)
            m.wait_for("feed override", lambda s: abs(s.feedrate - arg) < 1e-9, STEP_TIMEOUT_S)
        elif act == "pause":
            m.c.auto(L.AUTO_PAUSE)
            m.wait_for("pause", lambda s: s.paused, STEP_TIMEOUT_S)
        elif act == "resume":
            m.c.auto(L.AUTO_RESUME)
            m.wait_for("resume", lambda s: not s.paused, STEP_TIMEOUT_S)
        else:
            m.c.abort()
            aborted = True
    return aborted


def convert(raw_path, out_path):
    """halsampler -t rows 'tag x y z [a] line' -> TSV with a header, checking the tags."""
    rows = 0
    tmp = out_path + ".tmp"
    with open(raw_path) as f, open(tmp, "w") as o:
        first = None
        width = None
        for ln in f:
            w = ln.split()
            if not w:
                continue
            if width is None and len(w) in (5, 6):
                width = len(w)
                o.write("n\tx\ty\tz\t%sline\n" % ("a\t" if width == 6 else ""))
            if len(w) != width:
                raise RunError("malformed halsampler row %d: %r" % (rows + 1, ln))
            tag = int(w[0])
            if first is None:
                first = tag
            if tag != first + rows:
                raise RunError("sample %d missing (got tag %d): samples were lost"
                               % (first + rows, tag))
            o.write("%d\t%s\n" % (rows, "\t".join(w[1:])))
            rows += 1
    if rows == 0:
        raise RunError("no samples recorded")
    os.replace(tmp, out_path)
    return rows


def main():
    program = os.environ.get("EF_LCNC_PROGRAM")
    out = os.environ.get("EF_LCNC_OUT")
    timeout = float(os.environ.get("EF_LCNC_TIMEOUT", "300"))
    if not program or not out or not os.path.isabs(program) or not os.path.isabs(out):
        log("EF_LCNC_PROGRAM and EF_LCNC_OUT must be absolute paths")
        return 1
    raw = out + ".raw"
    sampler = None
    m = Machine()
    try:
        start_machine(m, program)
        with open(raw, "w") as f:
            sampler = subprocess.Popen(["halsampler", "-t", "-c", "0"], stdout=f)
        halcmd("setp", "sampler.0.enable", "1")
        t0 = time.monotonic()
        queued = run_program(m, timeout)
        wall = time.monotonic() - t0
        halcmd("setp", "sampler.0.enable", "0")
        # Let halsampler drain the FIFO, then stop it.
        deadline = time.monotonic() + STEP_TIMEOUT_S
        while int(getp("sampler.0.curr-depth")) > 0:
            if sampler.poll() is not None:
                raise RunError("halsampler exited early (status %d)" % sampler.returncode)
            if time.monotonic() > deadline:
                raise RunError("halsampler did not drain the sampler FIFO")
            time.sleep(POLL_S)
        overruns = int(getp("sampler.0.overruns"))
        sampler.send_signal(signal.SIGINT)
        sampler.wait(STEP_TIMEOUT_S)
        sampler = None
        if overruns:
            raise RunError("sampler FIFO overran %d times: samples lost" % overruns)
        rows = convert(raw, out)
        log("done: %d samples, %d moves queued before the start, %.1f s wall for the program"
            % (rows, queued, wall))
        return 0
    except (RunError, linuxcnc.error, subprocess.SubprocessError, OSError, ValueError) as ex:
        log("error: %s" % ex)
        try:
            m.c.abort()
        except linuxcnc.error:
            pass
        return 1
    finally:
        if sampler is not None:
            sampler.kill()
            sampler.wait()
        if os.path.exists(raw):
            os.unlink(raw)


if __name__ == "__main__":
    sys.exit(main())
