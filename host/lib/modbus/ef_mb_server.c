/* SPDX-License-Identifier: Apache-2.0 */
/* Simulated Modbus drive: libmodbus server (TCP, several clients, or RTU) around the
 * firmware's register device (ef_modbus.h) and drive model (ef_drive.h). */
#include <errno.h>
#include <math.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <stdlib.h>
#include <string.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>
#include "evenfeed/host/modbus/ef_mb.h"
#include "evenfeed/host/io/ef_drvio.h"

#define SRV_MAX_CLIENTS 8

typedef struct {
    const ef_mb_server_cfg_t *c;
    modbus_t *ctx;
    modbus_mapping_t *map;
    ef_mbdev_t *dev;
    FILE *trace;
    int listen_fd;
    int clients[SRV_MAX_CLIENTS];
    int nclients;
    double drive_t; /* drive time (s) since the server started */
    int fault_done, exception_done, drop_done, disconnect_done;
    double bits_per_char;
    int prev_state; /* the trace also records the period a drive becomes DISABLED */
    ef_drvio_t io;  /* STO input, alarm output (ef_drvio.h) */
} srv_t;

/* The drive's own I/O, every loop round: no torque without the enable input (a power stage
 * on then is an STO fault), the alarm output follows the fault. */
static void srv_io(srv_t *s)
{
    if (!s->io.open)
        return;
    ef_drive_t *d = &s->dev->drv;
    ef_msg_t mm = {{0}};
    int fault = d->state == EF_DRV_FAULT || d->fault != EF_DRV_FAULT_NONE;
    int ok = ef_drvio_process(&s->io, fault, &mm);
    int powered =
        d->state == EF_DRV_ENABLED || d->state == EF_DRV_RUNNING || d->state == EF_DRV_STOPPING;
    if (!ok && powered && !fault) {
        s->io.sto_drops++;
        if (s->trace)
            fprintf(s->trace, "# STO: enable input off at %.6f%s%s\n", s->drive_t,
                    mm.text[0] ? ": " : "", mm.text);
        ef_drive_fault(d, EF_DRV_FAULT_STO);
        (void)ef_drvio_process(&s->io, 1, NULL); /* the alarm at once */
    }
}

/* Fill the server defaults (documented in ef_mb.h). */
void ef_mb_server_cfg_default(ef_mb_server_cfg_t *c)
{
    memset(c, 0, sizeof *c);
    ef_mb_cfg_default(&c->mb);
    snprintf(c->mb.host, sizeof c->mb.host, "127.0.0.1");
    c->mb.port = 1502;
    ef_servo_cfg_default(&c->servo);
    c->period_us = 1000;
    c->time_scale = 1.0;
    c->exception_seq = -1;
    c->exception_code = EF_MB_EX_DEVICE_FAILURE;
    c->drop_reply_seq = -1;
    c->disconnect_seq = -1;
    c->fault_at_s = -1.0;
    c->axes = EF_MB_AXES;
}

/* One trace row per drive period: what a scope on the drive would record. */
static void srv_trace_row(srv_t *s)
{
    const ef_drive_t *d = &s->dev->drv;
    int was = s->prev_state;
    s->prev_state = d->state;
    if (!s->trace || (d->state == EF_DRV_DISABLED && was == EF_DRV_DISABLED))
        return;
    fprintf(s->trace, "%.6f,%u,%u,%u,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6g\n", s->drive_t,
            (unsigned)d->state, (unsigned)d->exec_seq, (unsigned)d->moving, (double)d->cmd.x,
            (double)d->cmd.y, (double)d->cmd.z, (double)d->act.x, (double)d->act.y,
            (double)d->act.z, (double)d->ferr);
}

/* Advance the drive by the wall time elapsed (scaled), one period at a time so the trace
 * has every period; the injected fault fires at its drive time. */
static void srv_tick(srv_t *s, double *last_wall, double *acc)
{
    double now = ef_mb_now();
    double dt = (now - *last_wall) * s->c->time_scale;
    *last_wall = now;
    if (dt < 0.0)
        dt = 0.0;
    if (dt > 1.0) /* a stalled host: the drive would have faulted long ago; cap it */
        dt = 1.0;
    *acc += dt;
    double per = s->c->period_us * 1e-6;
    while (*acc >= per) {
        *acc -= per;
        ef_mbdev_process(s->dev, s->c->period_us, NULL);
        s->drive_t += per;
        srv_trace_row(s);
        if (!s->fault_done && s->c->fault_at_s >= 0.0 && s->drive_t >= s->c->fault_at_s) {
            s->fault_done = 1;
            ef_drive_fault(&s->dev->drv, EF_DRV_FAULT_INJECTED);
            if (s->trace)
                fprintf(s->trace, "#fault injected at %.6f\n", s->drive_t);
        }
    }
}

/* Read a big-endian 16-bit field of the request. */
static uint16_t srv_be16(const uint8_t *p)
{
    return (uint16_t)((p[0] << 8) | p[1]);
}

/* Hold the reply for the wire time of request and reply at the configured baud rate, so a
 * pseudo-terminal (which has no baud rate) behaves like the line it stands for. */
static void srv_wire_delay(srv_t *s, int req_len, int rsp_len)
{
    if (s->c->wire_baud <= 0 || !s->c->mb.rtu)
        return;
    /* Each frame is followed by 3.5 character times of silence. */
    double chars = req_len + rsp_len + 7.0;
    double sec = chars * s->bits_per_char / s->c->wire_baud;
    struct timespec ts = {(time_t)sec, (long)((sec - floor(sec)) * 1e9)};
    while (nanosleep(&ts, &ts) == -1 && errno == EINTR)
        ;
}

/* Length of a normal reply, for the wire-time model. */
static int srv_reply_len(srv_t *s, int fc, uint16_t n)
{
    int hl = modbus_get_header_length(s->ctx), tail = s->c->mb.rtu ? 2 : 0;
    if (fc == 3)
        return hl + 2 + 2 * n + tail;
    return hl + 5 + tail;
}

/* Answer one request: reads refresh the mapping from the device first; writes go through
 * the device's validation, and only an accepted write gets libmodbus's normal reply.
 * Returns 0, or -1 when the client is to be dropped. */
static int srv_request(srv_t *s, const uint8_t *q, int len)
{
    int hl = modbus_get_header_length(s->ctx);
    int tail = s->c->mb.rtu ? 2 : 0; /* RTU frames end with their CRC */
    if (len < hl + 1 + tail)
        return 0;
    int fc = q[hl];
    uint8_t exc = EF_MB_EX_NONE;
    uint16_t regs[MODBUS_MAX_WRITE_REGISTERS];
    long seq = -1;
    if (fc == 3) {
        if (len < hl + 5 + tail) {
            modbus_reply_exception(s->ctx, q, EF_MB_EX_ILLEGAL_VALUE);
            return 0;
        }
        uint16_t addr = srv_be16(q + hl + 1), n = srv_be16(q + hl + 3);
        if (n < 1 || n > MODBUS_MAX_READ_REGISTERS) {
            exc = EF_MB_EX_ILLEGAL_VALUE;
        } else if (ef_mbdev_read(s->dev, addr, n, s->map->tab_registers + addr, &exc) == EF_OK) {
            srv_wire_delay(s, len, srv_reply_len(s, fc, n));
            modbus_reply(s->ctx, q, len, s->map);
            return 0;
        }
        if (exc == EF_MB_EX_NONE)
            exc = EF_MB_EX_ILLEGAL_ADDRESS;
        srv_wire_delay(s, len, hl + 2 + tail);
        modbus_reply_exception(s->ctx, q, exc);
        return 0;
    }
    uint16_t addr = 0, n = 0;
    if (fc == 6 && len >= hl + 5 + tail) {
        addr = srv_be16(q + hl + 1);
        n = 1;
        regs[0] = srv_be16(q + hl + 3);
    } else if (fc == 16 && len >= hl + 6 + tail) {
        addr = srv_be16(q + hl + 1);
        n = srv_be16(q + hl + 3);
        int bytes = q[hl + 5];
        if (n < 1 || n > MODBUS_MAX_WRITE_REGISTERS || bytes != 2 * n ||
            len < hl + 6 + bytes + tail) {
            srv_wire_delay(s, len, hl + 2 + tail);
            modbus_reply_exception(s->ctx, q, EF_MB_EX_ILLEGAL_VALUE);
            return 0;
        }
        for (uint16_t i = 0; i < n; i++)
            regs[i] = srv_be16(q + hl + 6 + 2 * i);
    } else {
        /* Coils, inputs, FC23 and the rest are not part of the map. */
        srv_wire_delay(s, len, hl + 2 + tail);
        modbus_reply_exception(s->ctx, q, EF_MB_EX_ILLEGAL_FUNCTION);
        return 0;
    }
    int is_slot = addr >= EF_MB_REG_SLOT0 && n == s->dev->slot_words;
    if (is_slot)
        seq = (long)ef_mb_get_u32(regs + EF_MB_SLOT_SEQ);
    if (is_slot && !s->exception_done && seq == s->c->exception_seq) {
        s->exception_done = 1;
        if (s->trace)
            fprintf(s->trace, "#exception %d to seq %ld\n", s->c->exception_code, seq);
        srv_wire_delay(s, len, hl + 2 + tail);
        modbus_reply_exception(s->ctx, q, (unsigned)s->c->exception_code);
        return 0;
    }
    uint32_t before = s->dev->drv.next_seq;
    int rc = ef_mbdev_write(s->dev, addr, n, regs, &exc);
    if (rc == EF_OK && is_slot && s->trace && s->dev->drv.next_seq != before)
        fprintf(s->trace, "#accepted %ld\n", seq);
    if (rc != EF_OK) {
        if (exc == EF_MB_EX_NONE)
            exc = EF_MB_EX_DEVICE_FAILURE;
        srv_wire_delay(s, len, hl + 2 + tail);
        modbus_reply_exception(s->ctx, q, exc);
        return 0;
    }
    if (is_slot && !s->drop_done && seq == s->c->drop_reply_seq) {
        s->drop_done = 1;
        if (s->trace)
            fprintf(s->trace, "#reply dropped for seq %ld\n", seq);
        return 0;
    }
    if (is_slot && !s->disconnect_done && seq == s->c->disconnect_seq) {
        s->disconnect_done = 1;
        if (s->trace)
            fprintf(s->trace, "#disconnect after seq %ld\n", seq);
        return -1;
    }
    /* The mapping is only an echo buffer for libmodbus's reply; the device holds the state. */
    srv_wire_delay(s, len, srv_reply_len(s, fc, n));
    modbus_reply(s->ctx, q, len, s->map);
    return 0;
}

/* Drop a TCP client by its index. */
static void srv_drop(srv_t *s, int i)
{
    close(s->clients[i]);
    s->clients[i] = s->clients[--s->nclients];
}

/* Open the listening socket or the serial line and announce readiness. */
static int srv_open(srv_t *s, ef_msg_t *m)
{
    const ef_mb_cfg_t *mb = &s->c->mb;
    FILE *ready = s->c->ready ? s->c->ready : stdout;
    if (mb->rtu) {
        s->ctx = modbus_new_rtu(mb->device, mb->baud, mb->parity, mb->data_bits, mb->stop_bits);
        if (!s->ctx)
            return ef_fail(m, EF_ERR_ARG, "rtu %s: %s", mb->device, modbus_strerror(errno));
        modbus_set_slave(s->ctx, mb->slave);
        if (modbus_connect(s->ctx) == -1)
            return ef_fail(m, EF_ERR_IO, "open %s: %s", mb->device, modbus_strerror(errno));
        s->bits_per_char = 1.0 + mb->data_bits + (mb->parity != 'N') + mb->stop_bits;
        fprintf(ready, "ready rtu %s slave %d\n", mb->device, mb->slave);
    } else {
        s->ctx = modbus_new_tcp(mb->host, mb->port);
        if (!s->ctx)
            return ef_fail(m, EF_ERR_ARG, "tcp %s:%d: %s", mb->host, mb->port,
                           modbus_strerror(errno));
        s->listen_fd = modbus_tcp_listen(s->ctx, SRV_MAX_CLIENTS);
        if (s->listen_fd == -1)
            return ef_fail(m, EF_ERR_IO, "listen on %s:%d: %s", mb->host, mb->port,
                           modbus_strerror(errno));
        struct sockaddr_in a;
        socklen_t al = sizeof a;
        int port = mb->port;
        if (getsockname(s->listen_fd, (struct sockaddr *)&a, &al) == 0)
            port = ntohs(a.sin_port);
        fprintf(ready, "ready tcp %s:%d\n", mb->host, port);
    }
    fflush(ready);
    return EF_OK;
}

/* The server loop (see ef_mb.h). */
int ef_mb_serve(const ef_mb_server_cfg_t *c, ef_msg_t *m)
{
    static ef_mbdev_t dev; /* 28 KB: static, as on a drive */
    srv_t s;
    memset(&s, 0, sizeof s);
    s.c = c;
    s.dev = &dev;
    s.listen_fd = -1;
    ef_vec3_t home = {c->home[0], c->home[1], c->home[2]};
    /* The session number tells a master that this is a new power-up. */
    uint16_t session = (uint16_t)(((unsigned)getpid() * 2654435761u) ^ (unsigned)time(NULL));
    if (session == 0)
        session = 1;
    int rc = ef_mbdev_init_axes(&dev, &c->servo, home, c->period_us, session, (uint32_t)c->axes);
    if (rc == EF_ERR_ARG && c->axes == 1 && (home.y != 0.0f || home.z != 0.0f))
        return ef_fail(m, rc, "a single-axis drive's home is X only (y and z 0)");
    if (rc != EF_OK)
        return ef_fail(m, rc, "drive model: %s", ef_err_str(rc));
    s.map = modbus_mapping_new(0, 0, EF_MB_REGS, 0);
    if (!s.map)
        return ef_fail(m, EF_ERR_NOMEM, "modbus mapping");
    if (c->trace) {
        s.trace = fopen(c->trace, "w");
        if (!s.trace) {
            modbus_mapping_free(s.map);
            return ef_fail(m, EF_ERR_IO, "%s: %s", c->trace, strerror(errno));
        }
        fprintf(s.trace, "t,state,seq,moving,cmd_x,cmd_y,cmd_z,act_x,act_y,act_z,ferr\n");
    }
    rc = ef_drvio_open(&s.io, c->sto_line, c->alarm_line, m); /* before the ready line */
    if (rc == EF_OK) {
        srv_io(&s);
        rc = srv_open(&s, m);
    }
    double last = ef_mb_now(), acc = 0.0;
    uint8_t q[MODBUS_TCP_MAX_ADU_LENGTH];
    while (rc == EF_OK && !(c->stop && *c->stop)) {
        fd_set rd;
        FD_ZERO(&rd);
        int maxfd = -1;
        if (c->mb.rtu) {
            maxfd = modbus_get_socket(s.ctx);
            FD_SET(maxfd, &rd);
        } else {
            FD_SET(s.listen_fd, &rd);
            maxfd = s.listen_fd;
            for (int i = 0; i < s.nclients; i++) {
                FD_SET(s.clients[i], &rd);
                if (s.clients[i] > maxfd)
                    maxfd = s.clients[i];
            }
        }
        double per = c->period_us * 1e-6 / c->time_scale;
        double wait = per - acc / c->time_scale;
        if (wait < 0.0)
            wait = 0.0;
        struct timeval tv = {(time_t)wait, (long)((wait - floor(wait)) * 1e6)};
        int n = select(maxfd + 1, &rd, NULL, NULL, &tv);
        srv_tick(&s, &last, &acc);
        srv_io(&s);
        if (s.trace)
            fflush(s.trace); /* a reader sees every period up to now, requests or not */
        if (n <= 0)
            continue; /* timeout, or a signal (checked by the loop) */
        if (c->mb.rtu) {
            int len = modbus_receive(s.ctx, q);
            if (len > 0) {
                srv_request(&s, q, len);
            } else if (len == -1 && errno != EMBBADCRC && errno != EMBBADDATA) {
                /* Noise or a torn frame: resynchronise on the next silence. */
                modbus_flush(s.ctx);
            }
            if (s.trace)
                fflush(s.trace);
            continue;
        }
        if (FD_ISSET(s.listen_fd, &rd)) {
            int fd = accept(s.listen_fd, NULL, NULL);
            if (fd >= 0 && s.nclients < SRV_MAX_CLIENTS)
                s.clients[s.nclients++] = fd;
            else if (fd >= 0)
                close(fd);
        }
        for (int i = s.nclients - 1; i >= 0; i--) {
            if (!FD_ISSET(s.clients[i], &rd))
                continue;
            modbus_set_socket(s.ctx, s.clients[i]);
            int len = modbus_receive(s.ctx, q);
            if (len == -1 || (len > 0 && srv_request(&s, q, len) == -1))
                srv_drop(&s, i);
        }
        if (s.trace)
            fflush(s.trace);
    }
    for (int i = s.nclients - 1; i >= 0; i--)
        srv_drop(&s, i);
    if (s.listen_fd >= 0)
        close(s.listen_fd);
    if (s.ctx) {
        if (c->mb.rtu)
            modbus_close(s.ctx);
        modbus_free(s.ctx);
    }
    modbus_mapping_free(s.map);
    if (s.trace)
        fclose(s.trace);
    ef_drvio_close(&s.io);
    return rc;
}
