/* SPDX-License-Identifier: Apache-2.0 */
/* Modbus master on libmodbus: streams segment slots to an evenfeed drive with flow
 * control, idempotent retries and reconnection (docs/modbus.md). */
#include <errno.h>
#include <math.h>
#include <modbus/modbus.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "evenfeed/host/modbus/ef_mb.h"

struct ef_mb_master {
    ef_mb_cfg_t c;
    modbus_t *ctx;
    int connected;
    uint16_t session, slots;
    ef_mb_status_t st;
    ef_mb_stats_t io;
    uint16_t axes, words; /* axes per slot (3 or 1) and registers per slot, from the drive */
    uint32_t next_seq;    /* sequence number of the next slot to send */
    uint32_t credits;     /* slots known to be free */
    int begun, started, mode;
    int hold;         /* feed hold requested: every enabling control word carries it */
    int manual_start; /* START only through ef_mb_start() (several drives start together) */
    int lost;         /* the drive restarted: nothing more is sent to it (its state is unknown) */
    double last_poll, last_full; /* any status read; the last whole-block read */
    float pos[3];                /* the drive's command at begin */
};

/* Axis letters by ef_mb_cfg_t::axis (1..9); 0 is the X Y Z drive. */
static const char mbm_axis_letters[] = "xyzabcuvw";

/* Name of what a drive carries ("xyz", or its one axis). */
const char *ef_mb_axis_name(int axis)
{
    static const char *const names[] = {"xyz", "x", "y", "z", "a", "b", "c", "u", "v", "w"};
    return axis >= 0 && axis <= EF_MB_AXIS_MAX ? names[axis] : "?";
}

/* Parse an axis list item: xyz, or one of x y z a b c u v w (either case). */
int ef_mb_axis_parse(const char *s, int *axis)
{
    if (!s || !axis)
        return EF_ERR_ARG;
    if (!strcmp(s, "xyz") || !strcmp(s, "XYZ")) {
        *axis = EF_MB_AXIS_XYZ;
        return EF_OK;
    }
    const char *p = s[0] && !s[1] ? strchr(mbm_axis_letters, s[0] | 0x20) : NULL;
    if (!p || !*p)
        return EF_ERR_ARG;
    *axis = (int)(p - mbm_axis_letters) + 1;
    return EF_OK;
}

/* Monotonic seconds. */
double ef_mb_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

/* Sleep for sec seconds (short waits between polls). */
static void mbm_sleep(double sec)
{
    struct timespec ts = {(time_t)sec, (long)((sec - floor(sec)) * 1e9)};
    while (nanosleep(&ts, &ts) == -1 && errno == EINTR)
        ;
}

/* Defaults documented in ef_mb.h. */
void ef_mb_cfg_default(ef_mb_cfg_t *c)
{
    memset(c, 0, sizeof *c);
    snprintf(c->host, sizeof c->host, "127.0.0.1");
    c->port = 502;
    c->baud = 115200;
    c->parity = 'N';
    c->data_bits = 8;
    c->stop_bits = 1;
    c->slave = 1;
    c->timeout_s = 0.2;
    c->retries = 3;
    c->reconnect_s = 2.0;
    c->watchdog_ms = 1000;
    c->axis = EF_MB_AXIS_XYZ;
}

/* Parse tcp://HOST:PORT or rtu:DEVICE[,BAUD[,8N1]]. */
int ef_mb_url_parse(const char *url, ef_mb_cfg_t *c, ef_msg_t *m)
{
    if (!url || !c)
        return ef_fail(m, EF_ERR_ARG, "no Modbus address");
    if (strncmp(url, "tcp://", 6) == 0) {
        const char *h = url + 6, *colon = strrchr(h, ':');
        if (!colon || colon == h || (size_t)(colon - h) >= sizeof c->host)
            return ef_fail(m, EF_ERR_ARG, "'%s': expected tcp://HOST:PORT", url);
        char *end;
        long port = strtol(colon + 1, &end, 10);
        if (*end || end == colon + 1 || port < 0 || port > 65535)
            return ef_fail(m, EF_ERR_ARG, "'%s': port must be 0..65535", url);
        memcpy(c->host, h, (size_t)(colon - h));
        c->host[colon - h] = '\0';
        c->port = (int)port;
        c->rtu = 0;
        return EF_OK;
    }
    if (strncmp(url, "rtu:", 4) == 0) {
        const char *d = url + 4, *comma = strchr(d, ',');
        size_t dl = comma ? (size_t)(comma - d) : strlen(d);
        if (dl == 0 || dl >= sizeof c->device)
            return ef_fail(m, EF_ERR_ARG, "'%s': expected rtu:DEVICE[,BAUD[,8N1]]", url);
        memcpy(c->device, d, dl);
        c->device[dl] = '\0';
        c->rtu = 1;
        if (!comma)
            return EF_OK;
        char *end;
        long baud = strtol(comma + 1, &end, 10);
        if (end == comma + 1 || baud < 300 || baud > 4000000 || (*end && *end != ','))
            return ef_fail(m, EF_ERR_ARG, "'%s': baud rate must be 300..4000000", url);
        c->baud = (int)baud;
        if (!*end)
            return EF_OK;
        const char *f = end + 1;
        if (strlen(f) != 3 || (f[0] != '7' && f[0] != '8') || !strchr("NEO", f[1]) ||
            (f[2] != '1' && f[2] != '2'))
            return ef_fail(m, EF_ERR_ARG, "'%s': frame format must be like 8N1, 8E1, 8O1, 8N2",
                           url);
        c->data_bits = f[0] - '0';
        c->parity = f[1];
        c->stop_bits = f[2] - '0';
        return EF_OK;
    }
    return ef_fail(m, EF_ERR_ARG, "'%s': expected tcp://HOST:PORT or rtu:DEVICE[,BAUD[,8N1]]", url);
}

/* Name of a Modbus exception code. */
static const char *mbm_exc_name(int code)
{
    switch (code) {
    case 1:
        return "illegal function";
    case 2:
        return "illegal data address";
    case 3:
        return "illegal data value";
    case 4:
        return "server device failure";
    case 5:
        return "acknowledge";
    case 6:
        return "server device busy";
    case 8:
        return "memory parity error";
    case 10:
        return "gateway path unavailable";
    case 11:
        return "gateway target failed to respond";
    default:
        return "unknown exception";
    }
}

/* Name of a drive fault code. */
static const char *mbm_fault_name(int code)
{
    switch (code) {
    case EF_DRV_FAULT_NONE:
        return "none";
    case EF_DRV_FAULT_UNDERRUN:
        return "underrun: ring ran dry while moving";
    case EF_DRV_FAULT_FOLLOWING:
        return "following error";
    case EF_DRV_FAULT_WATCHDOG:
        return "watchdog: master silent";
    case EF_DRV_FAULT_INJECTED:
        return "external fault";
    case EF_DRV_FAULT_SEGMENT:
        return "segment refused";
    case EF_DRV_FAULT_STO:
        return "safe torque off: the drive's enable input dropped";
    default:
        return "unknown fault";
    }
}

/* Drop the connection (a fresh one carries no stale replies). */
static void mbm_disconnect(ef_mb_master_t *ms)
{
    if (ms->connected)
        modbus_close(ms->ctx);
    ms->connected = 0;
}

/* Connect once; after a reconnect the session number must be the one seen at open. */
static int mbm_connect(ef_mb_master_t *ms, ef_msg_t *m)
{
    double until = ef_mb_now() + ms->c.reconnect_s;
    int again = ms->session != 0;
    for (;;) {
        if (modbus_connect(ms->ctx) == 0)
            break;
        if (ef_mb_now() >= until) {
            const char *where = ms->c.rtu ? ms->c.device : ms->c.host;
            return ef_fail(m, EF_ERR_DISCONNECT, "drive %s%s%d: cannot %sconnect: %s", where,
                           ms->c.rtu ? " slave " : ":", ms->c.rtu ? ms->c.slave : ms->c.port,
                           again ? "re" : "", modbus_strerror(errno));
        }
        mbm_sleep(0.02);
    }
    ms->connected = 1;
    if (again) {
        ms->io.reconnects++;
        uint16_t id[6];
        if (modbus_read_registers(ms->ctx, 0, 6, id) == 6 && id[EF_MB_REG_SESSION] != ms->session) {
            ms->lost = 1;
            return ef_fail(m, EF_ERR_DRIVE,
                           "drive restarted (session %u, now %u): its ring and position are "
                           "lost; stream stopped after %u segments sent",
                           ms->session, id[EF_MB_REG_SESSION], ms->next_seq);
        }
    }
    return EF_OK;
}

/* One transaction with retries: a timeout, a corrupt reply or a broken connection is
 * retried on a fresh connection (TCP) or after a flush (RTU); an exception reply is not
 * retried and its code goes to *exc. Slot writes may be retried safely: sequence numbers
 * make a repeated slot a duplicate the drive acknowledges without executing. */
static int mbm_xfer(ef_mb_master_t *ms, int write, uint16_t addr, int n, uint16_t *regs,
                    const char *what, int *exc, ef_msg_t *m)
{
    *exc = 0;
    if (ms->lost && write)
        return ef_fail(m, EF_ERR_DRIVE,
                       "%s: not sent: the drive restarted and its state is "
                       "not known",
                       what);
    int last_errno = 0;
    for (int attempt = 0; attempt <= ms->c.retries; attempt++) {
        if (!ms->connected) {
            int rc = mbm_connect(ms, m);
            if (rc != EF_OK)
                return rc;
        }
        ms->io.transactions++;
        if (attempt > 0)
            ms->io.retries++;
        int r = write ? modbus_write_registers(ms->ctx, addr, n, regs)
                      : modbus_read_registers(ms->ctx, addr, n, regs);
        if (r == n)
            return EF_OK;
        int e = r == -1 ? errno : EMBBADDATA;
        last_errno = e;
        if (e > MODBUS_ENOBASE && e <= MODBUS_ENOBASE + MODBUS_EXCEPTION_GATEWAY_TARGET) {
            *exc = e - MODBUS_ENOBASE;
            return ef_fail(m, EF_ERR_PROTO, "%s: drive answered exception %d (%s)", what, *exc,
                           mbm_exc_name(*exc));
        }
        if (e == ETIMEDOUT)
            ms->io.timeouts++;
        if (ms->c.rtu && (e == ETIMEDOUT || e == EMBBADCRC || e == EMBBADDATA || e == EMBBADSLAVE ||
                          e == EMBMDATA || e == EMBBADEXC)) {
            /* A late or torn frame may still be on the line: let it pass, then flush. */
            mbm_sleep(0.005);
            modbus_flush(ms->ctx);
        } else {
            mbm_disconnect(ms);
        }
    }
    if (last_errno == ETIMEDOUT)
        return ef_fail(m, EF_ERR_TIMEOUT, "%s: no answer after %d attempts (%.0f ms each)", what,
                       ms->c.retries + 1, ms->c.timeout_s * 1e3);
    return ef_fail(m, EF_ERR_DISCONNECT, "%s: failed after %d attempts: %s", what,
                   ms->c.retries + 1, modbus_strerror(last_errno));
}

/* The flow-control fields, from registers read starting at address base. */
static void mbm_parse_flow(ef_mb_status_t *s, const uint16_t *r, int base)
{
    s->status = r[EF_MB_REG_STATUS - base];
    s->state = r[EF_MB_REG_STATE - base];
    s->fault = r[EF_MB_REG_FAULT - base];
    s->free = r[EF_MB_REG_FREE - base];
    s->next_seq = ef_mb_get_u32(r + EF_MB_REG_NEXT_SEQ - base);
    s->done_seq = ef_mb_get_u32(r + EF_MB_REG_DONE_SEQ - base);
    s->exec_seq = ef_mb_get_u32(r + EF_MB_REG_EXEC_SEQ - base);
    s->time_ms = ef_mb_get_u32(r + EF_MB_REG_TIME_MS - base);
}

/* Read the identification, control and status blocks in one transaction. */
static int mbm_poll(ef_mb_master_t *ms, ef_msg_t *m)
{
    uint16_t r[0x40];
    int exc;
    int rc = mbm_xfer(ms, 0, 0, 0x40, r, "read status", &exc, m);
    ms->io.polls++;
    ms->last_poll = ms->last_full = ef_mb_now();
    if (rc != EF_OK)
        return rc;
    ef_mb_status_t *s = &ms->st;
    s->session = r[EF_MB_REG_SESSION];
    s->slots = r[EF_MB_REG_SLOTS];
    mbm_parse_flow(s, r, 0);
    s->done_count = ef_mb_get_u32(r + EF_MB_REG_DONE_COUNT);
    s->rejected = r[EF_MB_REG_REJECTED];
    s->duplicates = r[EF_MB_REG_DUPLICATES];
    for (int i = 0; i < 3; i++) {
        s->act[i] = ef_mb_get_f32(r + EF_MB_REG_ACT + 2 * i);
        s->cmd[i] = ef_mb_get_f32(r + EF_MB_REG_CMD + 2 * i);
    }
    s->ferr_max = ef_mb_get_f32(r + EF_MB_REG_FERR_MAX);
    if (ms->session && s->session != ms->session) {
        ms->lost = 1;
        return ef_fail(m, EF_ERR_DRIVE,
                       "drive restarted (session %u, now %u): its ring and position are lost; "
                       "stream stopped after %u segments sent",
                       ms->session, s->session, ms->next_seq);
    }
    return EF_OK;
}

/* Flow-control read: the drive's state and ring counters only (14 registers; on an RTU
 * line about a quarter of the time of the whole block), with the whole block, session
 * included, at least every 100 ms. A restarted drive also shows up here: it is DISABLED
 * with an empty ring, which mbm_check_fault() refuses. */
static int mbm_poll_flow(ef_mb_master_t *ms, ef_msg_t *m)
{
    if (ef_mb_now() - ms->last_full > 0.1)
        return mbm_poll(ms, m);
    uint16_t r[EF_MB_REG_TIME_MS + 2 - EF_MB_REG_STATUS];
    int exc;
    int rc =
        mbm_xfer(ms, 0, EF_MB_REG_STATUS, (int)(sizeof r / sizeof r[0]), r, "read status", &exc, m);
    ms->io.polls++;
    ms->last_poll = ef_mb_now();
    if (rc != EF_OK)
        return rc;
    ef_mb_status_t *s = &ms->st;
    mbm_parse_flow(s, r, EF_MB_REG_STATUS);
    /* Executed count: every segment before the one executing (or all, at rest). */
    if (s->done_seq != EF_MB_DONE_NONE)
        s->done_count = s->done_seq + 1u;
    return EF_OK;
}

/* A fault reported in the last status ends the stream; say where it happened. */
static int mbm_check_fault(ef_mb_master_t *ms, ef_msg_t *m)
{
    const ef_mb_status_t *s = &ms->st;
    if (s->status & EF_MB_ST_FAULT || s->state == EF_DRV_FAULT)
        return ef_fail(m, EF_ERR_DRIVE,
                       "drive fault %u (%s) at segment %u: %u of %u segments executed; the "
                       "drive stopped under control",
                       s->fault, mbm_fault_name(s->fault), s->exec_seq, s->done_count,
                       ms->next_seq);
    if (ms->begun && !ms->started && s->state != EF_DRV_ENABLED)
        return ef_fail(m, EF_ERR_DRIVE, "drive left ENABLED (state %u) before the start", s->state);
    if (ms->started && ms->mode == EF_MB_MODE_SEGMENT && s->state != EF_DRV_RUNNING)
        return ef_fail(m, EF_ERR_DRIVE,
                       "drive left RUNNING (state %u) at segment %u: %u of %u segments executed",
                       s->state, s->exec_seq, s->done_count, ms->next_seq);
    return EF_OK;
}

/* A flow-control read that also fails on a fault or an unexpected state. */
static int mbm_poll_checked(ef_mb_master_t *ms, ef_msg_t *m)
{
    if (ms->c.on_poll) {
        int hrc = ms->c.on_poll(ms->c.on_poll_user, m);
        if (hrc != 0)
            return hrc;
    }
    int rc = mbm_poll_flow(ms, m);
    return rc == EF_OK ? mbm_check_fault(ms, m) : rc;
}

/* Write the control word. */
static int mbm_control(ef_mb_master_t *ms, uint16_t word, const char *what, ef_msg_t *m)
{
    int exc;
    if (ms->hold && (word & EF_MB_CTL_ENABLE))
        word |= EF_MB_CTL_HOLD; /* a level: a start or a quick stop must not drop it */
    return mbm_xfer(ms, 1, EF_MB_REG_CONTROL, 1, &word, what, &exc, m);
}

/* Connect and check that this is an evenfeed drive with a map we speak. */
int ef_mb_open(const ef_mb_cfg_t *c, ef_mb_master_t **out, ef_msg_t *m)
{
    if (!c || !out)
        return ef_fail(m, EF_ERR_ARG, "no configuration");
    *out = NULL;
    if (c->slave < 1 || c->slave > 247 || !(c->timeout_s > 0.0) || c->timeout_s > 60.0 ||
        c->retries < 0 || c->retries > 100)
        return ef_fail(m, EF_ERR_ARG, "slave 1..247, timeout 0..60 s, retries 0..100");
    if (c->axis < 0 || c->axis > EF_MB_AXIS_MAX || (c->axis > 3 && c->axis - 3 > EF_AUX))
        return ef_fail(m, EF_ERR_ARG, "axis %d: this build carries X Y Z and %d more (EF_AXES)",
                       c->axis, EF_AUX);
    ef_mb_master_t *ms = calloc(1, sizeof *ms);
    if (!ms)
        return ef_fail(m, EF_ERR_NOMEM, "out of memory");
    ms->c = *c;
    ms->ctx = c->rtu ? modbus_new_rtu(c->device, c->baud, c->parity, c->data_bits, c->stop_bits)
                     : modbus_new_tcp(c->host, c->port);
    if (!ms->ctx) {
        free(ms);
        return ef_fail(m, EF_ERR_ARG, "Modbus context: %s", modbus_strerror(errno));
    }
    modbus_set_slave(ms->ctx, c->slave);
    uint32_t sec = (uint32_t)c->timeout_s;
    modbus_set_response_timeout(ms->ctx, sec, (uint32_t)((c->timeout_s - sec) * 1e6));
    int rc = mbm_connect(ms, m);
    uint16_t id[7];
    int exc;
    if (rc == EF_OK)
        rc = mbm_xfer(ms, 0, 0, 7, id, "read identification", &exc, m);
    if (rc == EF_OK &&
        (id[EF_MB_REG_MAGIC] != EF_MB_MAGIC || id[EF_MB_REG_VERSION] != EF_MB_MAP_VERSION))
        rc = ef_fail(m, EF_ERR_PROTO,
                     "not an evenfeed drive: magic 0x%04x version %u (want 0x%04x version %u)",
                     id[EF_MB_REG_MAGIC], id[EF_MB_REG_VERSION], EF_MB_MAGIC, EF_MB_MAP_VERSION);
    if (rc == EF_OK && (ef_mb_slot_words(id[EF_MB_REG_AXES]) == 0u ||
                        id[EF_MB_REG_SLOT_WORDS] != ef_mb_slot_words(id[EF_MB_REG_AXES]) ||
                        id[EF_MB_REG_SLOTS] < 2 || id[EF_MB_REG_SESSION] == 0))
        rc = ef_fail(m, EF_ERR_PROTO,
                     "drive's map does not match: %u axes, %u slots of %u words, session %u",
                     id[EF_MB_REG_AXES], id[EF_MB_REG_SLOTS], id[EF_MB_REG_SLOT_WORDS],
                     id[EF_MB_REG_SESSION]);
    /* What the drive carries must be what it was listed for: a slot of the wrong size
     * would be refused, but a 1-axis drive listed as X Y Z would be a wrong machine. */
    int want = c->axis == EF_MB_AXIS_XYZ ? EF_MB_AXES : (int)EF_MB_AXES1;
    if (rc == EF_OK && id[EF_MB_REG_AXES] != want)
        rc = ef_fail(m, EF_ERR_PROTO,
                     "the drive carries %u ax%s per slot but is listed for %s: a %s drive is "
                     "needed (sim-drive modbus --axes %d)",
                     id[EF_MB_REG_AXES], id[EF_MB_REG_AXES] == 1 ? "is" : "es",
                     ef_mb_axis_name(c->axis), want == EF_MB_AXES ? "3-axis" : "single-axis", want);
    if (rc != EF_OK) {
        ef_mb_close(ms);
        return rc;
    }
    ms->session = id[EF_MB_REG_SESSION];
    ms->slots = id[EF_MB_REG_SLOTS];
    ms->axes = id[EF_MB_REG_AXES];
    ms->words = id[EF_MB_REG_SLOT_WORDS];
    *out = ms;
    return EF_OK;
}

/* Close and free. */
void ef_mb_close(ef_mb_master_t *ms)
{
    if (!ms)
        return;
    mbm_disconnect(ms);
    modbus_free(ms->ctx);
    free(ms);
}

/* Public status read. */
int ef_mb_read_status(ef_mb_master_t *ms, ef_mb_status_t *st, ef_msg_t *m)
{
    if (!ms)
        return ef_fail(m, EF_ERR_ARG, "no master");
    int rc = mbm_poll(ms, m);
    if (st)
        *st = ms->st;
    return rc;
}

/* Clear, configure and enable a drive whose state is known to be clean. */
int ef_mb_begin(ef_mb_master_t *ms, int mode, ef_msg_t *m)
{
    if (!ms || (mode != EF_MB_MODE_SEGMENT && mode != EF_MB_MODE_DIRECT))
        return ef_fail(m, EF_ERR_ARG, "mode must be segment or direct");
    int rc = mbm_poll(ms, m);
    if (rc != EF_OK)
        return rc;
    if (ms->st.state == EF_DRV_FAULT)
        return ef_fail(m, EF_ERR_DRIVE,
                       "drive is in fault %u (%s): not enabling it; reset the fault first "
                       "(--fault-reset)",
                       ms->st.fault, mbm_fault_name(ms->st.fault));
    if (ms->st.state != EF_DRV_DISABLED && ms->st.state != EF_DRV_ENABLED)
        return ef_fail(m, EF_ERR_DRIVE, "drive is busy (state %u): another master is streaming?",
                       ms->st.state);
    int exc;
    uint16_t cfg[2] = {(uint16_t)mode, ms->c.watchdog_ms};
    rc = mbm_xfer(ms, 1, EF_MB_REG_MODE, 2, cfg, "write mode and watchdog", &exc, m);
    if (rc == EF_OK)
        rc = mbm_control(ms, EF_MB_CTL_CLEAR | EF_MB_CTL_ENABLE, "clear and enable", m);
    if (rc == EF_OK)
        rc = mbm_poll(ms, m);
    if (rc != EF_OK)
        return rc;
    if (ms->st.state != EF_DRV_ENABLED || ms->st.free != ms->slots || ms->st.next_seq != 0)
        return ef_fail(m, EF_ERR_DRIVE,
                       "drive did not enable cleanly: state %u, %u of %u slots free, next "
                       "sequence %u",
                       ms->st.state, ms->st.free, ms->slots, ms->st.next_seq);
    for (int i = 0; i < 3; i++)
        ms->pos[i] = ms->st.cmd[i];
    ms->mode = mode;
    ms->next_seq = 0;
    ms->credits = ms->slots;
    ms->begun = 1;
    ms->started = 0;
    ms->hold = 0;
    return EF_OK;
}

/* Start executing (segment mode). */
static int mbm_start(ef_mb_master_t *ms, ef_msg_t *m)
{
    int rc = mbm_control(ms, EF_MB_CTL_ENABLE | EF_MB_CTL_START, "start", m);
    if (rc == EF_OK)
        ms->started = 1;
    return rc;
}

/* The move as a single-axis drive carries it: its axis's control values in b[i].x, y and z
 * 0; the time law, length and the rest as the move has them (one law for all axes). */
static void mbm_axis_move(const ef_move_t *mv, int axis, ef_move_t *out)
{
    *out = *mv;
    for (int i = 0; i < 6; i++) {
        float v = axis == 1   ? mv->b[i].x
                  : axis == 2 ? mv->b[i].y
                  : axis == 3 ? mv->b[i].z
                              : mv->ab[axis - 4][i]; /* axis - 3 <= EF_AUX (ef_mb_open) */
        out->b[i] = ef_v3(v, 0.0f, 0.0f);
    }
}

/* Several drives start together (ef_mb.h). */
int ef_mb_set_manual_start(ef_mb_master_t *ms, int on)
{
    if (!ms)
        return EF_ERR_ARG;
    ms->manual_start = on != 0;
    return EF_OK;
}

/* START unless started (ef_mb.h). */
int ef_mb_start(ef_mb_master_t *ms, ef_msg_t *m)
{
    if (!ms || !ms->begun || ms->mode != EF_MB_MODE_SEGMENT)
        return ef_fail(m, EF_ERR_STATE, "drive not prepared for segments");
    return ms->started ? EF_OK : mbm_start(ms, m);
}

/* A checked status read (ef_mb.h). */
int ef_mb_poll(ef_mb_master_t *ms, ef_msg_t *m)
{
    if (!ms)
        return ef_fail(m, EF_ERR_ARG, "no master");
    return mbm_poll_checked(ms, m);
}

/* Whether the drive was started (ef_mb.h). */
int ef_mb_started(const ef_mb_master_t *ms)
{
    return ms && ms->started;
}

/* Segments sent (ef_mb.h). */
uint32_t ef_mb_sent(const ef_mb_master_t *ms)
{
    return ms ? ms->next_seq : 0u;
}

/* Ring size (ef_mb.h). */
uint32_t ef_mb_slots(const ef_mb_master_t *ms)
{
    return ms ? ms->slots : 0u;
}

/* Wait for free slots: poll, and while none is free, give the drive a moment. */
static int mbm_wait_credit(ef_mb_master_t *ms, ef_msg_t *m)
{
    for (;;) {
        int rc = mbm_poll_checked(ms, m);
        if (rc != EF_OK)
            return rc;
        ms->credits = ms->st.free;
        if (ms->credits > 0)
            return EF_OK;
        ms->io.busy++;
        if (!ms->started && ms->manual_start)
            return ef_fail(m, EF_ERR_STATE, "the ring is full before the start");
        if (!ms->started) {
            rc = mbm_start(ms, m);
            if (rc != EF_OK)
                return rc;
            continue;
        }
        mbm_sleep(0.001);
    }
}

/* Send one slot (see ef_mb.h). */
int ef_mb_send(ef_mb_master_t *ms, const ef_move_t *mv, ef_msg_t *m)
{
    if (!ms || !mv)
        return ef_fail(m, EF_ERR_ARG, "no master or segment");
    if (!ms->begun || ms->mode != EF_MB_MODE_SEGMENT)
        return ef_fail(m, EF_ERR_STATE, "drive not prepared for segments");
    ef_move_t cp = *mv;
    if (ms->c.axis != EF_MB_AXIS_XYZ)
        mbm_axis_move(mv, ms->c.axis, &cp);
    if (ms->next_seq == 0) {
        float d = 0.0f;
        const float b0[3] = {cp.b[0].x, cp.b[0].y, cp.b[0].z};
        for (int i = 0; i < 3; i++)
            d += (b0[i] - ms->pos[i]) * (b0[i] - ms->pos[i]);
        d = sqrtf(d); /* the drive's own continuity check is this distance */
        if (!(d <= EF_INTERP_JOIN_TOL) && ms->c.axis != EF_MB_AXIS_XYZ)
            return ef_fail(m, EF_ERR_ARG,
                           "the path starts at %c = %.4f but the drive is at %.4f: move it "
                           "there first",
                           mbm_axis_letters[ms->c.axis - 1] - 0x20, (double)b0[0],
                           (double)ms->pos[0]);
        if (!(d <= EF_INTERP_JOIN_TOL))
            return ef_fail(m, EF_ERR_ARG,
                           "the path starts at (%.4f %.4f %.4f) but the drive is at "
                           "(%.4f %.4f %.4f): move it there first",
                           (double)b0[0], (double)b0[1], (double)b0[2], (double)ms->pos[0],
                           (double)ms->pos[1], (double)ms->pos[2]);
    }
    cp.seq = ms->next_seq;
    uint16_t w[EF_MB_SLOT_WORDS];
    int rc = ef_mb_slot_encode_axes(&cp, ms->axes, w);
    if (rc != EF_OK)
        return ef_fail(m, EF_ERR_ARG, "segment %u (source line %u) cannot be encoded: %s", cp.seq,
                       mv->tag, ef_err_str(rc));
    char what[96];
    snprintf(what, sizeof what, "write slot %u (segment %u, source line %u)",
             (unsigned)(cp.seq % ms->slots), cp.seq, mv->tag);
    uint16_t addr = (uint16_t)(EF_MB_REG_SLOT0 + (cp.seq % ms->slots) * ms->words);
    for (;;) {
        /* Look at the drive now and then even with credit left, so a fault stops the
         * stream promptly rather than when the ring fills. */
        if (ms->credits == 0 || ef_mb_now() - ms->last_poll > 0.05) {
            rc = mbm_wait_credit(ms, m);
            if (rc != EF_OK)
                return rc;
        }
        int exc;
        rc = mbm_xfer(ms, 1, addr, ms->words, w, what, &exc, m);
        if (rc == EF_OK)
            break;
        if (exc == EF_MB_EX_BUSY) {
            ms->credits = 0;
            continue;
        }
        if (exc) {
            /* Say whether the refusal came from a fault. */
            ef_msg_t why, first;
            snprintf(first.text, sizeof first.text, "%s", m ? m->text : what);
            if (mbm_poll(ms, &why) == EF_OK && mbm_check_fault(ms, &why) != EF_OK)
                return ef_fail(m, EF_ERR_DRIVE, "%s; %s", first.text, why.text);
        }
        return rc;
    }
    double now = ef_mb_now();
    if (ms->io.slot_writes == 0)
        ms->io.t_first = now;
    ms->io.t_last = now;
    ms->io.slot_writes++;
    ms->next_seq++;
    ms->credits--;
    if (!ms->started && !ms->manual_start && (ms->credits == 0 || ms->next_seq >= ms->slots))
        return mbm_start(ms, m);
    return EF_OK;
}

/* Wait until everything sent has executed; a drive that stops progressing is an error. */
int ef_mb_drain(ef_mb_master_t *ms, ef_msg_t *m)
{
    if (!ms || !ms->begun)
        return ef_fail(m, EF_ERR_STATE, "drive not prepared");
    if (ms->mode == EF_MB_MODE_SEGMENT && !ms->started && ms->next_seq > 0) {
        int rc = mbm_start(ms, m);
        if (rc != EF_OK)
            return rc;
    }
    double progress_t = ef_mb_now();
    uint32_t last_time = 0;
    for (;;) {
        int rc = mbm_poll_checked(ms, m);
        if (rc != EF_OK)
            return rc;
        if (!(ms->st.status & EF_MB_ST_MOVING) &&
            (ms->mode == EF_MB_MODE_DIRECT || ms->st.done_count >= ms->next_seq))
            return EF_OK;
        if (ms->st.time_ms != last_time || ms->mode == EF_MB_MODE_DIRECT) {
            last_time = ms->st.time_ms;
            progress_t = ef_mb_now();
        } else if (ef_mb_now() - progress_t > 2.0) {
            return ef_fail(m, EF_ERR_TIMEOUT,
                           "drive makes no progress for 2 s at segment %u (%u of %u executed)",
                           ms->st.exec_seq, ms->st.done_count, ms->next_seq);
        }
        mbm_sleep(0.002);
    }
}

/* Direct mode: one target. */
int ef_mb_target(ef_mb_master_t *ms, const float p[3], ef_msg_t *m)
{
    if (!ms || !p || !ms->begun || ms->mode != EF_MB_MODE_DIRECT)
        return ef_fail(m, EF_ERR_STATE, "drive not prepared for direct targets");
    uint16_t w[EF_MB_TARGET_WORDS];
    for (int i = 0; i < 3; i++) {
        if (!isfinite(p[i]))
            return ef_fail(m, EF_ERR_NONFINITE, "target axis %d is not finite", i);
        ef_mb_put_f32(w + 2 * i, p[i]);
    }
    int exc, rc = mbm_xfer(ms, 1, EF_MB_REG_TARGET, EF_MB_TARGET_WORDS, w, "write target", &exc, m);
    if (rc == EF_OK)
        ms->io.target_writes++;
    return rc;
}

/* Explicit fault reset, then check it took. */
int ef_mb_fault_reset(ef_mb_master_t *ms, ef_msg_t *m)
{
    if (!ms)
        return EF_ERR_ARG;
    int rc = mbm_poll(ms, m);
    if (rc != EF_OK || ms->st.state != EF_DRV_FAULT)
        return rc; /* nothing to reset */
    rc = mbm_control(ms, EF_MB_CTL_FAULT_RESET, "fault reset", m);
    if (rc == EF_OK)
        rc = mbm_poll(ms, m);
    if (rc == EF_OK && ms->st.state == EF_DRV_FAULT)
        return ef_fail(m, EF_ERR_DRIVE, "drive still in fault %u (%s) after a reset", ms->st.fault,
                       mbm_fault_name(ms->st.fault));
    return rc;
}

/* Feed hold (see ef_mb.h). */
int ef_mb_hold(ef_mb_master_t *ms, int on, ef_msg_t *m)
{
    if (!ms || !ms->begun || ms->mode != EF_MB_MODE_SEGMENT)
        return ef_fail(m, EF_ERR_STATE, "feed hold needs a drive prepared for segments");
    if ((on != 0) == ms->hold)
        return EF_OK;
    ms->hold = on != 0;
    uint16_t w = (uint16_t)(EF_MB_CTL_ENABLE | (ms->started ? EF_MB_CTL_START : 0u));
    return mbm_control(ms, w, on ? "feed hold" : "resume", m);
}

/* Controlled stop; errors are only reported. */
int ef_mb_quick_stop(ef_mb_master_t *ms, ef_msg_t *m)
{
    if (!ms)
        return EF_ERR_ARG;
    return mbm_control(ms, EF_MB_CTL_ENABLE | EF_MB_CTL_QUICK_STOP, "quick stop", m);
}

/* Disable: a moving drive stops under control first; wait (bounded) until it is at rest. */
int ef_mb_end(ef_mb_master_t *ms, ef_msg_t *m)
{
    if (!ms)
        return EF_ERR_ARG;
    ms->begun = 0;
    ms->started = 0;
    int rc = mbm_control(ms, 0, "disable", m);
    if (ms->lost)
        return rc;
    /* Wait for rest even when the disable was refused: a faulted drive is stopping on its
     * own, and whoever called this must not see it as stopped before it is. */
    double until = ef_mb_now() + 5.0;
    for (;;) {
        ef_msg_t pm;
        int prc = mbm_poll(ms, &pm);
        if (prc != EF_OK)
            return rc != EF_OK ? rc : ef_fail(m, prc, "%s", pm.text);
        if (!(ms->st.status & (EF_MB_ST_MOVING | EF_MB_ST_STOPPING)))
            break;
        if (ef_mb_now() > until)
            return ef_fail(m, EF_ERR_TIMEOUT, "drive still moving 5 s after being disabled");
        mbm_sleep(0.002);
    }
    return rc;
}

/* Counters. */
const ef_mb_stats_t *ef_mb_stats(const ef_mb_master_t *ms)
{
    return &ms->io;
}

/* Last status read. */
const ef_mb_status_t *ef_mb_last_status(const ef_mb_master_t *ms)
{
    return &ms->st;
}
