/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Child processes for the transport tests and benchmarks: start a program with its stdout
 * (or stderr) on a pipe, wait for its readiness line, stop it by its PID. Simulated drives
 * and socat pseudo-terminal pairs are started this way; nothing sleeps to wait for them.
 */
#ifndef EF_PROC_H
#define EF_PROC_H

#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

/* The evenfeed binary and the drive time scale tm_drive() uses (set by the program). */
static const char *tm_evenfeed, *tm_time_scale = "4";

typedef struct {
    pid_t pid;
    int out; /* read end of its stdout (or stderr for socat) */
} tm_proc_t;

/* Start argv[] with stdout (or stderr) on a pipe. */
static inline int tm_spawn(char *const argv[], int use_stderr, tm_proc_t *p)
{
    int fds[2];
    p->pid = 0; /* on failure: nothing to stop (tm_stop returns -1) */
    p->out = -1;
    if (pipe(fds) != 0)
        return -1;
    pid_t pid = fork();
    if (pid < 0) {
        close(fds[0]);
        close(fds[1]);
        return -1;
    }
    if (pid == 0) {
        dup2(fds[1], use_stderr ? 2 : 1);
        close(fds[0]);
        close(fds[1]);
        execvp(argv[0], argv);
        _exit(127);
    }
    close(fds[1]);
    p->pid = pid;
    p->out = fds[0];
    return 0;
}

/* Read one line from fd within timeout_ms; 0 on success. */
static inline int tm_line(int fd, char *buf, size_t n, int timeout_ms)
{
    size_t k = 0;
    while (k + 1 < n) {
        struct pollfd pf = {fd, POLLIN, 0};
        if (poll(&pf, 1, timeout_ms) <= 0)
            return -1;
        char ch;
        if (read(fd, &ch, 1) != 1)
            return -1;
        if (ch == '\n')
            break;
        buf[k++] = ch;
    }
    buf[k] = 0;
    return 0;
}

/* Stop a process we started, by its PID: SIGTERM, then SIGKILL if it lingers. */
static inline int tm_stop(tm_proc_t *p, int sig)
{
    if (p->pid <= 0)
        return -1;
    kill(p->pid, sig);
    int st = 0;
    for (int i = 0; i < 300; i++) {
        if (waitpid(p->pid, &st, WNOHANG) == p->pid)
            break;
        if (i == 299) {
            kill(p->pid, SIGKILL);
            waitpid(p->pid, &st, 0);
        }
        usleep(10000);
    }
    close(p->out);
    p->pid = 0;
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

/* Start a simulated drive and wait for its "ready" line; *port gets the TCP port. */
static inline int tm_drive(tm_proc_t *p, const char *addr_opt, const char *addr, const char *trace,
                           const char *extra, int *port)
{
    char *argv[32];
    int n = 0;
    static char buf[8][64];
    argv[n++] = (char *)tm_evenfeed;
    argv[n++] = "sim-drive";
    argv[n++] = "modbus";
    argv[n++] = (char *)addr_opt;
    argv[n++] = (char *)addr;
    argv[n++] = "--time-scale";
    argv[n++] = (char *)tm_time_scale;
    if (trace) {
        argv[n++] = "--trace";
        argv[n++] = (char *)trace;
    }
    /* extra: up to 8 space-separated words */
    if (extra) {
        char tmp[256];
        snprintf(tmp, sizeof tmp, "%s", extra);
        int w = 0;
        for (char *t = strtok(tmp, " "); t && w < 8; t = strtok(NULL, " "))
            snprintf(buf[w], sizeof buf[w], "%s", t), argv[n++] = buf[w++];
    }
    argv[n] = NULL;
    if (tm_spawn(argv, 0, p) != 0)
        return -1;
    char line[256];
    if (tm_line(p->out, line, sizeof line, 10000) != 0) {
        fprintf(stderr, "sim-drive did not become ready\n");
        tm_stop(p, SIGKILL);
        return -1;
    }
    if (port) {
        const char *c = strrchr(line, ':');
        *port = c ? atoi(c + 1) : 0;
    }
    return strncmp(line, "ready ", 6) == 0 ? 0 : -1;
}

/* A socat pseudo-terminal pair: the two device names, ready once socat says so. */
static inline int tm_socat(tm_proc_t *p, char a[64], char b[64])
{
    char *argv[] = {"socat", "-d", "-d", "pty,raw,echo=0", "pty,raw,echo=0", NULL};
    if (tm_spawn(argv, 1, p) != 0)
        return -1;
    int got = 0;
    char line[256];
    while (tm_line(p->out, line, sizeof line, 5000) == 0) {
        const char *s = strstr(line, "PTY is ");
        if (s && got < 2)
            snprintf(got++ == 0 ? a : b, 64, "%s", s + 7);
        if (strstr(line, "starting data transfer loop"))
            return got == 2 ? 0 : -1;
    }
    return -1;
}

#endif
