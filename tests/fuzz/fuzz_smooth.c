/* SPDX-License-Identifier: Apache-2.0 */
/*
 * libFuzzer target for the runtime chain: the input bytes are decoded into a configuration
 * and a stream of primitives (lines, arcs, helices; ordinary and hostile values: NaN, inf,
 * huge coordinates, zero lengths, reversals, zero and negative feeds, inconsistent arcs,
 * exact stops), pushed through ef_smooth (EF_ERR_FULL handled by draining), the moves into
 * the interpolator, stepped at 1 ms. Whatever the input, every emitted move must be finite,
 * start where the previous one ended, keep its speeds within its limit and continuous, and
 * at every junction passed at speed have the same parametric end speed ratio |f'| / L as
 * the previous one (EF_FZ_RHO_JUMP, EF_FZ_STEP_SHARE: in the drives' uniform stepping a
 * difference is a step in the feed); every setpoint must be finite and move no axis faster
 * than its limit; over every run of consecutive 1 ms setpoints each axis's acceleration
 * (second differences) must stay within its limit and, with a jerk limit, its jerk (third
 * differences) within J, up to the float32 and sampling margins of
 * tests/motion/ef_sp_check.h. A refused primitive must leave the stream usable. Broken
 * invariants abort. With configuration bit 32 the machine has auxiliary axes A and B
 * (ef_smooth.h, "Auxiliary axes") and primitives may move them (hostile values too, and
 * moves of A B alone): their control values must chain, their setpoints stay finite and
 * within each axis's speed, acceleration and jerk limit, and end at the last accepted value.
 *
 * Built with -DEF_FUZZ_REPLAY_MAIN it is a plain-C replay driver (smooth_fuzz_replay
 * DIR|FILE...): every seed ("ok-*") must run without breaking an invariant. With
 * EF_FZ_TRACE set, either driver prints every primitive pushed and every move pulled, and
 * with EF_FZ_TRACE=T (seconds) the setpoints within 20 ms of T as well.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "evenfeed/core/ef_err.h"
#include "evenfeed/motion/ef_interp.h"
#include "evenfeed/motion/ef_smooth.h"
#include "motion/ef_sp_check.h"

extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Report and crash, so the input is saved as a reproducer. */
static void ef_fz_fail(const char *what, double a)
{
    fprintf(stderr, "smooth fuzz invariant broken: %s (%g)\n", what, a);
    abort();
}

/* Byte reader: zeros after the end. */
typedef struct {
    const uint8_t *d;
    size_t n, i;
} ef_fz_in_t;

static uint8_t ef_fz_u8(ef_fz_in_t *in)
{
    return in->i < in->n ? in->d[in->i++] : 0;
}

static int16_t ef_fz_i16(ef_fz_in_t *in)
{
    uint16_t a = ef_fz_u8(in), b = ef_fz_u8(in);
    return (int16_t)(uint16_t)(a | (b << 8));
}

/* A value: mostly scale * i16 / 32768, sometimes a hostile one. */
static float ef_fz_val(ef_fz_in_t *in, float scale)
{
    uint8_t sel = ef_fz_u8(in);
    int16_t v = ef_fz_i16(in);
    switch (sel & 15u) {
    case 0:
        return NAN;
    case 1:
        return (v & 1) ? INFINITY : -INFINITY;
    case 2:
        return 3e7f * (float)v / 32768.0f; /* beyond EF_MAX_COORD */
    case 3:
        return 0.0f;
    case 4:
        return 1e-7f * (float)v; /* tiny */
    default:
        return scale * (float)v / 32768.0f;
    }
}

static int ef_fz_finite3(ef_vec3_t a)
{
    return isfinite(a.x) && isfinite(a.y) && isfinite(a.z);
}

typedef struct {
    ef_vec3_t end;   /* where the last move ended */
    float v_exit;    /* its exit speed */
    float v_axis[3]; /* the axis speed limits */
    float a_min;     /* the smallest axis acceleration limit */
    float scale;     /* largest coordinate magnitude of any move so far */
    ef_vec3_t last;  /* last setpoint */
    int have_sp;
    uint32_t skips;  /* skip-ahead steps so far (ef_fz_drain()) */
    int gave_up;     /* the input's moves outlast EF_FZ_SKIPS_MAX skip-ahead steps */
    float rho_exit;  /* the last move's exit speed ratio (ef_fz_rho()), 0 before the first */
    float rho_slack; /* and its float32 slack */
    int kind;        /* the last move's kind and length, for the report */
    float length;
    spc_t chk; /* setpoint continuity over consecutive 1 ms periods */
    double t;  /* time of the last setpoint (s) */
    int naux;  /* auxiliary axes in use (0 or EF_FZ_AUX) */
    float aend[EF_AUX_N], alast[EF_AUX_N], v_aux[EF_AUX_N], ascale;
    spc_t achk; /* A and B through the checker's X and Y */
} ef_fz_state_t;

/* Auxiliary axes the fuzzer uses (configuration bit 32). */
#define EF_FZ_AUX (EF_AUX < 2 ? EF_AUX : 2)

static ef_smooth_t S;
static ef_interp_t IP;
/* EF_FZ_TRACE set (replaying a reproducer): every primitive pushed and move pulled is printed. */
static int ef_fz_trace = -1;
static double ef_fz_trace_t = -1.0; /* and EF_FZ_TRACE=T: the setpoints within 20 ms of T s */

/* A move's parametric end speed |f'| at tau = 0 (end 0) or 1 (end 1) over its length: what
 * uniform stepping of tau (the drives' segment mode) moves at, relative to the planned
 * speed. */
static float ef_fz_rho(const ef_move_t *m, int end)
{
    int n = m->degree;
    ef_vec3_t d = end ? ef_v3_sub(m->b[n], m->b[n - 1]) : ef_v3_sub(m->b[1], m->b[0]);
    return (float)n * ef_v3_norm(d) / m->length;
}

/* Float32 slack of ef_fz_rho(): the control points' rounding (2 ulps of the largest
 * coordinate per difference) over the length, times the degree. */
static float ef_fz_rho_slack(const ef_move_t *m)
{
    float big = 0.0f;
    for (int k = 0; k <= m->degree; k++)
        big = fmaxf(big, fmaxf(fmaxf(fabsf(m->b[k].x), fabsf(m->b[k].y)), fabsf(m->b[k].z)));
    return (float)m->degree * 2.0f * 1.2e-7f * big / m->length;
}

/* Largest difference of the end speed ratios at a junction passed at speed: uniform stepping
 * changes the feed there by v times it within one period (ef_seg_g2_even()). A larger one
 * fails only where that step is felt: above EF_FZ_STEP_SHARE of the smallest axis
 * acceleration limit over one 1 ms period (a 0.1 mm corner at 0.002 mm/s is not). */
#define EF_FZ_RHO_JUMP   5e-3f
#define EF_FZ_STEP_SHARE 0.05f

/* Check one move against the chain so far. */
static void ef_fz_move(ef_fz_state_t *st, const ef_move_t *m)
{
    if (ef_fz_trace)
        fprintf(stderr,
                "move %u kind %d deg %d tag %u t %.6f L %.6g v %.6g..%.6g max %.6g a %.6g j %.6g "
                "dur %.6g flags %u end %.6g %.6g %.6g\n",
                (unsigned)m->seq, m->kind, m->degree, (unsigned)m->tag, st->t, (double)m->length,
                (double)m->v_entry, (double)m->v_exit, (double)m->v_max, (double)m->a_max,
                (double)m->j_max, (double)m->duration, (unsigned)m->flags,
                (double)m->b[m->degree].x, (double)m->b[m->degree].y, (double)m->b[m->degree].z);
    for (int a = 0; ef_fz_trace && a < st->naux; a++)
        fprintf(stderr, "  aux %d: %.9g .. %.9g, atabs %.6g akabs %.6g akjerk %.6g\n", a,
                (double)m->ab[a][0], (double)m->ab[a][m->degree], (double)m->atabs[a],
                (double)m->akabs[a], (double)m->akjerk[a]);
    if (m->degree != 1 && m->degree != 3 && m->degree != 5)
        ef_fz_fail("degree", m->degree);
    for (int k = 0; k <= m->degree; k++)
        if (!ef_fz_finite3(m->b[k]))
            ef_fz_fail("control point not finite", k);
    if (!(m->duration > 0.0f) || !isfinite(m->duration) || !(m->length > 0.0f))
        ef_fz_fail("duration/length", m->duration);
    float gap = ef_v3_norm(ef_v3_sub(m->b[0], st->end));
    if (!(gap <= 1e-6f))
        ef_fz_fail("move does not start where the previous ended", gap);
    if (!(fabsf(m->v_entry - st->v_exit) <= 1e-3f * (1.0f + st->v_exit)))
        ef_fz_fail("entry speed != previous exit speed", m->v_entry - st->v_exit);
    if (!(m->v_entry <= m->v_max * 1.0001f + 1e-4f) || !(m->v_exit <= m->v_max * 1.0001f + 1e-4f))
        ef_fz_fail("speed above limit", m->v_max);
    if ((m->flags & EF_MOVE_STOP_END) && m->v_exit != 0.0f)
        ef_fz_fail("stop with speed", m->v_exit);
    float rho0 = ef_fz_rho(m, 0);
    float jump = fabsf(rho0 - st->rho_exit) - ef_fz_rho_slack(m) - st->rho_slack;
    if (m->v_entry > 0.0f && st->rho_exit > 0.0f && !(jump <= EF_FZ_RHO_JUMP) &&
        !(m->v_entry * jump <= EF_FZ_STEP_SHARE * st->a_min * 1e-3f)) {
        fprintf(stderr,
                "junction at %.6g %.6g %.6g, v %.6g: move kind %d degree %d length %.6g "
                "ratio %.6g after kind %d length %.6g ratio %.6g\n",
                (double)m->b[0].x, (double)m->b[0].y, (double)m->b[0].z, (double)m->v_entry,
                m->kind, m->degree, (double)m->length, (double)rho0, st->kind, (double)st->length,
                (double)st->rho_exit);
        for (int k = 0; k <= m->degree; k++)
            fprintf(stderr, "  b%d %.9g %.9g %.9g\n", k, (double)m->b[k].x, (double)m->b[k].y,
                    (double)m->b[k].z);
        ef_fz_fail("end speed ratios differ at a junction passed at speed", rho0 - st->rho_exit);
    }
    st->rho_exit = ef_fz_rho(m, 1);
    st->rho_slack = ef_fz_rho_slack(m);
    st->kind = m->kind;
    st->length = m->length;
    /* the move's extent bounds the float32 error of its setpoints (ef_sp_check.h) */
    double ext = m->length;
    for (int k = 1; k <= m->degree; k++)
        ext = fmax(ext, (double)ef_v3_norm(ef_v3_sub(m->b[k], m->b[0])));
    spc_scale(&st->chk, ext);
    double aext = 0.0;
    for (int a = 0; a < st->naux; a++) {
        for (int k = 0; k <= m->degree; k++) {
            if (!isfinite(m->ab[a][k]))
                ef_fz_fail("auxiliary control value not finite", a);
            aext = fmax(aext, fabs((double)m->ab[a][k] - m->ab[a][0]));
            st->ascale = fmaxf(st->ascale, fabsf(m->ab[a][k]));
        }
        float agap = fabsf(m->ab[a][0] - st->aend[a]);
        if (!(agap <= 1e-6f * (1.0f + fabsf(st->aend[a]))))
            ef_fz_fail("auxiliary axis does not start where the previous move ended", agap);
        st->aend[a] = m->ab[a][m->degree];
    }
    if (st->naux)
        spc_scale(&st->achk, fmax(aext, ext));
    st->end = m->b[m->degree];
    st->v_exit = m->v_exit;
    for (int k = 0; k <= m->degree; k++)
        st->scale =
            fmaxf(st->scale, fmaxf(fmaxf(fabsf(m->b[k].x), fabsf(m->b[k].y)), fabsf(m->b[k].z)));
}

/* Advance dt_us; setpoints finite and no faster than the fastest limit allows. */
static void ef_fz_tick(ef_fz_state_t *st, uint32_t dt_us)
{
    ef_setpoint_t sp;
    uint32_t next;
    int rc = ef_interp_process(&IP, dt_us, &next, &sp);
    if (rc != EF_OK && rc != EF_ERR_UNDERRUN)
        ef_fz_fail("interp", rc);
    if (!ef_fz_finite3(sp.p))
        ef_fz_fail("setpoint not finite", 0);
    if (st->have_sp) {
        /* no axis faster than its limit, plus float32 resolution: a few ulps of the
         * coordinates and of the moves' extent (a setpoint of a 800 m line is rounded at
         * that scale, wherever on it) */
        float d[3] = {sp.p.x - st->last.x, sp.p.y - st->last.y, sp.p.z - st->last.z};
        float c[3] = {sp.p.x, sp.p.y, sp.p.z};
        for (int i = 0; i < 3; i++)
            if (!(fabsf(d[i]) <= st->v_axis[i] * (float)dt_us * 1e-6f * 1.02f + 1e-6f +
                                     4e-7f * (fabsf(c[i]) + st->scale)))
                ef_fz_fail("axis faster than its limit", d[i]);
    }
    if (ef_fz_trace && st->t > ef_fz_trace_t - 0.02 && st->t < ef_fz_trace_t + 0.02)
        fprintf(stderr, "sp t %.4f %.9g %.9g %.9g v %.6g seq %u moving %d rc %d\n", st->t,
                (double)sp.p.x, (double)sp.p.y, (double)sp.p.z, (double)sp.v_plan, (unsigned)sp.seq,
                sp.moving, rc);
    for (int a = 0; a < st->naux; a++) {
        if (!isfinite(sp.aux[a]))
            ef_fz_fail("auxiliary setpoint not finite", a);
        float d = sp.aux[a] - st->alast[a];
        if (st->have_sp && !(fabsf(d) <= st->v_aux[a] * (float)dt_us * 1e-6f * 1.02f + 1e-6f +
                                             4e-7f * (fabsf(sp.aux[a]) + st->ascale)))
            ef_fz_fail("auxiliary axis faster than its limit", d);
        st->alast[a] = sp.aux[a];
    }
    st->last = sp.p;
    st->have_sp = 1;
    /* continuity: differences only over consecutive periods (a late call starts anew) */
    if (dt_us != 1000u)
        spc_break(&st->chk);
    st->t += (double)dt_us * 1e-6;
    if (spc_push(&st->chk, st->t, &sp) > 0) {
        spc_report(&st->chk, "smooth fuzz", stderr);
        ef_fz_fail(st->chk.a_over ? "axis acceleration above its limit"
                                  : "axis jerk above the limit",
                   st->chk.a_over ? st->chk.wa.value : st->chk.wj.value);
    }
    if (st->naux) {
        if (dt_us != 1000u)
            spc_break(&st->achk);
        ef_setpoint_t as = sp;
        as.p = ef_v3(sp.aux[0], st->naux > 1 ? sp.aux[1] : 0.0f, 0.0f);
        if (spc_push(&st->achk, st->t, &as) > 0) {
            spc_report(&st->achk, "smooth fuzz, auxiliary axes", stderr);
            ef_fz_fail(st->achk.a_over ? "auxiliary acceleration above its limit"
                                       : "auxiliary jerk above the limit",
                       st->achk.a_over ? st->achk.wa.value : st->achk.wj.value);
        }
    }
}

/* Skip-ahead steps (2000 s each) an input may take in all, about 1.3 years of motion: a
 * feed of 1e-7 mm/s over 1e5 mm (the fuzzer makes such) lasts 1e12 s, 5e8 steps, and a unit
 * ran past libFuzzer's 20 min timeout in CI. Such an input is not simulated further. */
#define EF_FZ_SKIPS_MAX 20000u

/* Pull what the smoother has into the interpolator, stepping it at 1 ms when its queue is
 * full; after ticks_max such steps (slow feeds make long moves) it skips ahead half an
 * hour a step, which the interpolator must handle as well, up to EF_FZ_SKIPS_MAX of them
 * for the input (then st->gave_up). */
static void ef_fz_drain(ef_fz_state_t *st, int ticks_max)
{
    ef_move_t m;
    int ticks = 0;
    while (!st->gave_up) {
        if (ef_interp_space(&IP) == 0) {
            int skip = ticks++ >= ticks_max;
            st->skips += (uint32_t)skip;
            st->gave_up = st->skips > EF_FZ_SKIPS_MAX;
            ef_fz_tick(st, skip ? 2000000000u : 1000u);
            continue;
        }
        int rc = ef_smooth_pull(&S, &m);
        if (rc == EF_ERR_AGAIN)
            return;
        if (rc != EF_OK)
            ef_fz_fail("pull", rc);
        ef_fz_move(st, &m);
        if (ef_interp_push(&IP, &m) != EF_OK)
            ef_fz_fail("interp refused a move", m.seq);
    }
}

/* Work units done and moves pulled so far: every EF_ERR_FULL of push and finish must move
 * one of them (ef_smooth.h, "Work units"), else the smoother is stuck. */
static uint64_t ef_fz_progress(void)
{
    ef_smooth_stats_t t = ef_smooth_stats(&S);
    return ((uint64_t)t.units << 32) | t.moves;
}

/* Finish, draining between the calls (one work unit each), until it reports everything
 * built; a call without progress fails. */
static void ef_fz_finish(ef_fz_state_t *st, int ticks_max, const char *what)
{
    for (;;) {
        uint64_t before = ef_fz_progress();
        int rc = ef_smooth_finish(&S);
        ef_fz_drain(st, ticks_max);
        if (rc == EF_OK || st->gave_up)
            return;
        if (rc != EF_ERR_FULL)
            ef_fz_fail(what, rc);
        if (ef_fz_progress() == before)
            ef_fz_fail(what, 1);
    }
}

static void ef_fz_run(const uint8_t *data, size_t size)
{
    ef_fz_in_t in = {data, size, 0};
    if (ef_fz_trace < 0) {
        const char *e = getenv("EF_FZ_TRACE");
        ef_fz_trace = e != NULL;
        ef_fz_trace_t = e ? atof(e) : -1.0;
    }
    ef_smooth_cfg_t c;
    memset(&c, 0, sizeof c);
    c.g2 = &ef_tbl_g2_default;
    c.g1 = &ef_tbl_g1_default;
    uint8_t cf = ef_fz_u8(&in);
    for (int i = 0; i < 3; i++) {
        c.lim.v_axis[i] = 50.0f + 10.0f * (float)(ef_fz_u8(&in) & 31u);
        c.lim.a_axis[i] = 500.0f + 100.0f * (float)(ef_fz_u8(&in) & 31u);
    }
    c.lim.j_max = (cf & 1u) ? 0.0f : 20000.0f;
    c.lim.a_normal_frac = 0.5f;
    c.micro_len = (cf & 2u) ? 0.0f : 1.0f;
    c.micro_turn = 0.35f;
    c.smooth_degree = (cf & 4u) ? 3 : 5;
    float scale = (cf & 8u) ? 2.0f : 50.0f; /* micro-segments or ordinary moves */
    if (cf & 32u) {
        c.naux = EF_FZ_AUX;
        uint8_t at = ef_fz_u8(&in);
        for (int a = 0; a < EF_FZ_AUX; a++) {
            c.lim.v_axis[3 + a] = 30.0f + 10.0f * (float)(at & 7u);
            c.lim.a_axis[3 + a] = 300.0f + 100.0f * (float)((at >> 3) & 7u);
            c.aux_tol[a] = (at & 64u) ? 0.0f : (at & 128u) ? 0.5f : 0.02f;
        }
    }
    if (ef_smooth_init(&S, &c, ef_v3(0, 0, 0)) != EF_OK)
        ef_fz_fail("init", 0);
    if (ef_interp_init(&IP, ef_v3(0, 0, 0), 1000u,
                       (cf & 16u) ? EF_STEP_UNIFORM : EF_STEP_CORRECTED) != EF_OK)
        ef_fz_fail("interp init", 0);
    static ef_fz_state_t st; /* the continuity checker's history: not on the stack */
    memset(&st, 0, sizeof st);
    for (int i = 0; i < 3; i++)
        st.v_axis[i] = c.lim.v_axis[i];
    st.naux = c.naux;
    if (st.naux) {
        ef_limits_t al = c.lim; /* A and B in the checker's X and Y slots */
        al.a_axis[0] = c.lim.a_axis[3];
        al.a_axis[1] = c.naux > 1 ? c.lim.a_axis[4] : c.lim.a_axis[3];
        spc_init(&st.achk, 1e-3, &al);
        for (int a = 0; a < st.naux; a++)
            st.v_aux[a] = c.lim.v_axis[3 + a];
    }
    float apos[EF_AUX_N] = {0};
    st.a_min = fminf(c.lim.a_axis[0], fminf(c.lim.a_axis[1], c.lim.a_axis[2]));
    spc_init(&st.chk, 1e-3, &c.lim);
    ef_vec3_t pos = ef_v3(0, 0, 0);
    for (int n = 0; n < 400 && in.i < in.n; n++) {
        uint8_t op = ef_fz_u8(&in);
        ef_prim_t p;
        memset(&p, 0, sizeof p);
        p.kind = (op & 3u) == 3u ? EF_PRIM_ARC : EF_PRIM_LINE;
        p.flags = (op & 4u) ? EF_PRIM_STOP_BEFORE : 0u;
        p.feed = (op & 8u) ? ef_fz_val(&in, 100.0f) : 5.0f + (float)(ef_fz_u8(&in) & 63u);
        p.tol = (op & 16u) ? ef_fz_val(&in, 0.05f) : 0.01f;
        p.qtol = (op & 32u) ? 0.005f : 0.0f;
        p.tag = (uint32_t)n;
        if (op & 64u) { /* finish: an event */
            ef_fz_finish(&st, 2000, "finish");
            if (st.gave_up)
                return;
        }
        for (int a = 0; a < EF_AUX_N; a++)
            p.aux[a] = apos[a];
        if (st.naux && (ef_fz_u8(&in) & 1u)) {
            /* the auxiliary axes move (hostile values too); a line with X Y Z still below is
             * then a move of them alone */
            for (int a = 0; a < st.naux; a++) {
                float da = ef_fz_val(&in, 45.0f);
                p.aux[a] = apos[a] + da;
            }
        }
        if (p.kind == EF_PRIM_LINE) {
            /* one read per statement: the order of a call's arguments is unspecified (gcc
             * and clang differ), and a reproducer must replay the same under both */
            float dx = ef_fz_val(&in, scale);
            float dy = ef_fz_val(&in, scale);
            float dz = (op & 128u) ? ef_fz_val(&in, scale) : 0.0f;
            p.end = ef_v3(pos.x + dx, pos.y + dy, pos.z + dz);
        } else {
            /* centre offset in the plane, axis +Z (or tilted), sweep, end by rotation (with
             * an optional radius error) */
            float cx = ef_fz_val(&in, scale), cy = ef_fz_val(&in, scale);
            float sw = ef_fz_val(&in, 7.0f);
            float err = (ef_fz_u8(&in) & 7u) == 0 ? ef_fz_val(&in, 0.1f) : 0.0f;
            float h = (op & 128u) ? ef_fz_val(&in, scale) : 0.0f;
            p.centre = ef_v3(pos.x + cx, pos.y + cy, pos.z);
            p.axis = ef_v3(0, 0, 1);
            p.sweep = sw;
            float rx = -cx, ry = -cy;
            float co = cosf(sw), si = sinf(sw);
            float r = sqrtf(rx * rx + ry * ry);
            float k = r > 0.0f ? (r + err) / r : 1.0f;
            p.end = ef_v3(p.centre.x + k * (co * rx - si * ry),
                          p.centre.y + k * (si * rx + co * ry), pos.z + h);
        }
        int rc = ef_smooth_push(&S, &p);
        if (ef_fz_trace)
            fprintf(stderr,
                    "prim %d kind %d flags %u feed %.6g tol %.6g end %.6g %.6g %.6g sweep %.6g "
                    "-> %d\n",
                    n, p.kind, (unsigned)p.flags, (double)p.feed, (double)p.tol, (double)p.end.x,
                    (double)p.end.y, (double)p.end.z, (double)p.sweep, rc);
        while (rc == EF_ERR_FULL && !st.gave_up) {
            uint64_t before = ef_fz_progress();
            ef_fz_drain(&st, 2000);
            int again = ef_smooth_push(&S, &p);
            if (again == EF_ERR_FULL && ef_fz_progress() == before)
                ef_fz_fail("still full after draining, no work done", 0);
            rc = again;
        }
        if (st.gave_up)
            return; /* too slow to simulate: what ran so far was checked */
        if (rc == EF_OK) {
            /* an auxiliary move keeps X Y Z exactly where they were */
            if (!(ef_v3_norm(ef_v3_sub(p.end, pos)) < EF_MIN_CHORD && st.naux))
                pos = p.end;
            for (int a = 0; a < st.naux; a++)
                apos[a] = p.aux[a];
        } else if (rc > 0 || !strcmp(ef_err_str(rc), "unknown error"))
            ef_fz_fail("refusal that is not an ef_err code", rc);
        ef_fz_drain(&st, 50);
        if (st.gave_up)
            return;
    }
    ef_fz_finish(&st, 2000, "final finish");
    if (st.gave_up)
        return;
    ef_move_t m;
    if (ef_smooth_pull(&S, &m) != EF_ERR_AGAIN)
        ef_fz_fail("moves left after the final drain", 0);
    /* everything accepted came out, ending at rest at the last accepted end */
    if (!(ef_v3_norm(ef_v3_sub(st.end, pos)) <= 1e-6f))
        ef_fz_fail("chain does not end at the last accepted end", 0);
    if (st.v_exit != 0.0f)
        ef_fz_fail("chain does not end at rest", st.v_exit);
    for (int a = 0; a < st.naux; a++)
        if (!(fabsf(st.aend[a] - apos[a]) <= 1e-6f * (1.0f + fabsf(apos[a]))))
            ef_fz_fail("auxiliary axis does not end at its last accepted value", st.aend[a]);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    ef_fz_run(data, size);
    return 0;
}

#ifdef EF_FUZZ_REPLAY_MAIN
#include "replay.h"

/* Every input is acceptable; breaking an invariant aborts. */
static int replay_smooth(const uint8_t *buf, size_t len, char *why, size_t why_len)
{
    (void)why;
    (void)why_len;
    ef_fz_run(buf, len);
    return 0;
}

int main(int argc, char **argv)
{
    return ef_replay_main(argc, argv, replay_smooth);
}
#endif
