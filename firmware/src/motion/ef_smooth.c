/* SPDX-License-Identifier: Apache-2.0 */
/* The streaming smoother: primitives in, feed-planned moves out (ef_smooth.h,
 * docs/smoothing.md). Geometry decisions lag the input by one primitive, because a line's
 * direction is final only once the next primitive has shown it cannot be merged into it. */
#include "evenfeed/motion/ef_smooth.h"
#include "evenfeed/geom/ef_bezier.h"
#include "evenfeed/core/ef_err.h"

/* How a held primitive's end vertex was resolved. */
enum {
    EF_V_OPEN = 0,     /* not decided yet */
    EF_V_STOP = 1,     /* exact stop */
    EF_V_STRAIGHT = 2, /* passes straight through, nothing to do */
    EF_V_BLEND = 3,    /* a blend move follows the primitive */
    EF_V_SMOOTH = 4,   /* smooth vertex: frames fe / fs interpolated */
};

/* Shortest move handed to the planner (it refuses anything shorter). */
#define EF_SM_MIN_MOVE EF_MIN_CHORD
/* Shortest piece an arc body is split into for its tolerance (sm_next_move()): well above
 * EF_SM_MIN_MOVE, so a piece's measured length never falls below it by rounding. */
#define EF_SM_MIN_PIECE (4.0f * EF_MIN_CHORD)

/* Phases of the decision of the oldest open vertex (ef_smooth_t::job; the transition table
 * is in ef_smooth.h, "Work units"). */
enum {
    EF_J_VERTEX = 0,       /* stop wanted? else the smooth gate */
    EF_J_SMOOTH_ARC = 1,   /* section curve from the arc frame at a rest start */
    EF_J_SMOOTH_ARC_M = 2, /* ... measured */
    EF_J_SMOOTH = 3,       /* section curve to the gate's frame */
    EF_J_SMOOTH_M = 4,     /* ... measured */
    EF_J_BLEND = 5,        /* the corner blend */
    EF_J_PROBE = 6,        /* ... measured */
    EF_J_CLOSE_ARC = 7,    /* closing section to the arc frame of its smooth start */
    EF_J_CLOSE_ARC_M = 8,  /* ... measured */
    EF_J_CLOSE = 9,        /* closing section to its end as decided */
    EF_J_CLOSE_M = 10,     /* ... measured */
};

/* Emission phases of the oldest held primitive. */
enum { EF_E_BODY = 0, EF_E_BLEND = 1, EF_E_DONE = 2 };

/* Finite and within EF_MAX_COORD, without libm (NaN fails every comparison). */
static int sm_coord_ok(float x)
{
    return ef_fabsf(x) <= EF_MAX_COORD;
}

/* A point usable by the smoother: every coordinate finite and within EF_MAX_COORD. */
static int sm_v3_ok(ef_vec3_t a)
{
    return sm_coord_ok(a.x) && sm_coord_ok(a.y) && sm_coord_ok(a.z);
}

/* Ring index of the i-th held primitive (0 = oldest). */
static ef_smooth_prim_t *sm_held(ef_smooth_t *s, uint32_t i)
{
    return &s->pq[(s->ph + i) % EF_SMOOTH_PRIMS];
}

/* Unit direction of a line primitive. */
static ef_vec3_t sm_dir(const ef_smooth_prim_t *h)
{
    ef_vec3_t d = ef_v3_sub(h->pr.end, h->start);
    return ef_v3_scale(d, 1.0f / ef_maxf(ef_v3_norm(d), 1e-30f));
}

/* Distance from p to the segment a-b. */
static float sm_dist_seg(ef_vec3_t p, ef_vec3_t a, ef_vec3_t b)
{
    ef_vec3_t ab = ef_v3_sub(b, a), ap = ef_v3_sub(p, a);
    float l2 = ef_v3_dot(ab, ab);
    float t = l2 > 0.0f ? ef_v3_dot(ap, ab) / l2 : 0.0f;
    t = ef_minf(ef_maxf(t, 0.0f), 1.0f);
    return ef_v3_norm(ef_v3_sub(ap, ef_v3_scale(ab, t)));
}

/* Validate the configuration; tables must be of the right kinds. */
static int sm_cfg_check(const ef_smooth_cfg_t *c)
{
    if (!c->g2 || (c->smooth_degree != 5 && c->smooth_degree != 3))
        return EF_ERR_ARG;
    if (c->smooth_degree == 3 && !c->g1)
        return EF_ERR_ARG;
    if (c->g2->kind != EF_TABLE_G2_QUINTIC)
        return EF_ERR_KIND;
    if (c->g1 && c->g1->kind != EF_TABLE_G1_CUBIC)
        return EF_ERR_KIND;
    if (!(c->micro_len - c->micro_len == 0.0f) || !(c->micro_turn - c->micro_turn == 0.0f))
        return EF_ERR_NONFINITE;
    if (c->micro_len < 0.0f || c->micro_turn < 0.0f || c->micro_turn > 0.5f * EF_PI_F)
        return EF_ERR_ARG;
    if (c->naux > EF_AUX)
        return EF_ERR_ARG;
    for (int k = 0; k < c->naux; k++) {
        if (!(c->aux_tol[k] - c->aux_tol[k] == 0.0f))
            return EF_ERR_NONFINITE;
        if (c->aux_tol[k] < 0.0f)
            return EF_ERR_ARG;
    }
    int rc = ef_limits_check(&c->lim);
    if (rc != EF_OK)
        return rc;
    for (int k = 0; k < c->naux; k++)
        if (!(c->lim.v_axis[3 + k] > 0.0f))
            return EF_ERR_FEED;
    return EF_OK;
}

/* Set up an empty smoother at rest at start. */
int ef_smooth_init(ef_smooth_t *s, const ef_smooth_cfg_t *cfg, ef_vec3_t start)
{
    if (!s || !cfg)
        return EF_ERR_ARG;
    int rc = sm_cfg_check(cfg);
    if (rc != EF_OK)
        return rc;
    if (!sm_v3_ok(start))
        return EF_ERR_NONFINITE;
    /* Field by field: the struct is large and a compound-literal zero would put a copy
     * of it on the stack. */
    s->ph = s->pn = 0;
    s->sh = s->sn = 0;
    s->arc_next = s->arc_n = 0;
    s->arc_sized = 0;
    s->arc_k = s->arc_try = 0;
    s->arc_dev = 0.0f;
    s->job = EF_J_VERTEX;
    s->next_id = 0;
    s->emitting = EF_E_BODY;
    ef_smooth_stats_t zero = {0};
    s->st = zero;
    s->cfg = *cfg;
    s->pos = start;
    s->out_end = start;
    for (int k = 0; k < EF_AUX_N; k++)
        s->apos[k] = s->aout_end[k] = 0.0f;
    return ef_plan_init(&s->plan, &cfg->lim);
}

/* The auxiliary axes' position with nothing in the smoother (ef_smooth.h). */
int ef_smooth_set_aux(ef_smooth_t *s, const float *aux)
{
    if (!s || !aux || s->pn || s->sn || s->plan.mcount || s->plan.rel_n)
        return EF_ERR_ARG;
    for (int k = 0; k < s->cfg.naux; k++)
        if (!sm_coord_ok(aux[k]))
            return EF_ERR_NONFINITE;
    for (int k = 0; k < s->cfg.naux; k++)
        s->apos[k] = s->aout_end[k] = aux[k];
    return EF_OK;
}

/* ---------------------------------------------------------------- auxiliary axes */

/* Auxiliary axis k on held primitive h at X Y Z arc length d from its start (linear; its
 * programmed values exactly at both ends). */
static float sm_aux_at(const ef_smooth_prim_t *h, int k, float d)
{
    if (!(d > 0.0f))
        return h->astart[k];
    if (d >= h->len)
        return h->pr.aux[k];
    return h->astart[k] + (h->pr.aux[k] - h->astart[k]) * (d / h->len);
}

/* Rate of auxiliary axis k along h: units per unit of X Y Z length. */
static float sm_aux_rate(const ef_smooth_prim_t *h, int k)
{
    return h->aux_only ? 0.0f : (h->pr.aux[k] - h->astart[k]) / h->len;
}

/* m's auxiliary polynomials: linear from a0 to a1 (exactly at both ends), then the
 * auxiliary bounds; nothing to measure while no axis moves. */
static int sm_aux_set_linear(const ef_smooth_t *s, ef_move_t *m, const float *a0, const float *a1)
{
    if (s->cfg.naux == 0)
        return EF_OK; /* every builder starts from a zeroed move: ab and its bounds are 0 */
    int n = m->degree;
    for (int k = 0; k < EF_AUX_N; k++)
        for (int i = 0; i < 6; i++)
            m->ab[k][i] = 0.0f;
    for (int k = 0; k < s->cfg.naux; k++)
        for (int i = 0; i <= n; i++)
            m->ab[k][i] = i == n ? a1[k] : a0[k] + (a1[k] - a0[k]) * ((float)i / (float)n);
    return ef_move_measure_aux(m);
}

/* m built on h between X Y Z arc lengths d0 and d1: its auxiliary axes linear there. */
static int sm_aux_span(const ef_smooth_t *s, const ef_smooth_prim_t *h, float d0, float d1,
                       ef_move_t *m)
{
    if (s->cfg.naux == 0)
        return EF_OK;
    float a0[EF_AUX_N], a1[EF_AUX_N];
    for (int k = 0; k < EF_AUX_N; k++)
        a0[k] = a1[k] = 0.0f;
    for (int k = 0; k < s->cfg.naux; k++) {
        a0[k] = sm_aux_at(h, k, d0);
        a1[k] = sm_aux_at(h, k, d1);
    }
    return sm_aux_set_linear(s, m, a0, a1);
}

/* A quintic move's parametric speed sp and its rate s1 = <f', f''> / |f'| at both ends. */
typedef struct {
    float sp0, sp1, s10, s11;
} sm_aux_ends_t;

static sm_aux_ends_t sm_aux_ends(const ef_vec3_t *b)
{
    ef_vec3_t d10 = ef_v3_scale(ef_v3_sub(b[1], b[0]), 5.0f);
    ef_vec3_t d11 = ef_v3_scale(ef_v3_sub(b[5], b[4]), 5.0f);
    ef_vec3_t d20 = ef_v3_scale(ef_v3_add(ef_v3_sub(b[2], ef_v3_scale(b[1], 2.0f)), b[0]), 20.0f);
    ef_vec3_t d21 = ef_v3_scale(ef_v3_add(ef_v3_sub(b[5], ef_v3_scale(b[4], 2.0f)), b[3]), 20.0f);
    sm_aux_ends_t e;
    e.sp0 = ef_v3_norm(d10);
    e.sp1 = ef_v3_norm(d11);
    e.s10 = ef_v3_dot(d10, d20) / ef_maxf(e.sp0, 1e-30f);
    e.s11 = ef_v3_dot(d11, d21) / ef_maxf(e.sp1, 1e-30f);
    return e;
}

/* An auxiliary axis's quintic control values c[0..5] on a move with end data e: value p0,
 * rate k0 (units per unit of X Y Z length) and zero second derivative by arc length at its
 * start, p1, k1 and zero at its end (tau-derivatives a' = k sp, a'' = k s1). */
static void sm_aux_hermite(const sm_aux_ends_t *e, float p0, float k0, float p1, float k1, float *c)
{
    float v0 = k0 * e->sp0, v1 = k1 * e->sp1, w0 = k0 * e->s10, w1 = k1 * e->s11;
    c[0] = p0;
    c[1] = p0 + v0 * 0.2f;
    c[2] = p0 + v0 * 0.4f + w0 * 0.05f;
    c[3] = p1 - v1 * 0.4f + w1 * 0.05f;
    c[4] = p1 - v1 * 0.2f;
    c[5] = p1;
}

/* The blend m at the vertex between h and nx: per axis the quintic with the value, the rate
 * (units per unit of X Y Z length) and zero second derivative by X Y Z arc length of the
 * line or arc it leaves and joins, at the blend's own ends (its parametric speed sp and
 * its rate s1 = <f', f''> / |f'| there, so the joins are G2 by arc length); then its
 * deviation from the programmed value at the same share of the corner's length. */
static int sm_aux_blend(ef_smooth_t *s, const ef_smooth_prim_t *h, const ef_smooth_prim_t *nx,
                        ef_move_t *m)
{
    if (s->cfg.naux == 0)
        return EF_OK; /* the blend move starts zeroed */
    for (int k = 0; k < EF_AUX_N; k++)
        for (int i = 0; i < 6; i++)
            m->ab[k][i] = 0.0f;
    sm_aux_ends_t e = sm_aux_ends(m->b);
    float te = h->trim_end, ts = nx->trim_start, D = te + ts;
    for (int k = 0; k < s->cfg.naux; k++) {
        float p0 = sm_aux_at(h, k, h->len - te), p1 = sm_aux_at(nx, k, ts);
        float k0 = sm_aux_rate(h, k), k1 = sm_aux_rate(nx, k);
        float *c = m->ab[k];
        sm_aux_hermite(&e, p0, k0, p1, k1, c);
        /* deviation at EF_MOVE_SAMPLES shares of the corner: the programmed value there is
         * on h up to the vertex (te of D), then on nx */
        float dev = 0.0f;
        for (int i = 1; i < EF_MOVE_SAMPLES; i++) {
            float t = (float)i / (float)EF_MOVE_SAMPLES, u = 1.0f - t;
            float bz = u * u * u * u * u * c[0] + 5.0f * t * u * u * u * u * c[1] +
                       10.0f * t * t * u * u * u * c[2] + 10.0f * t * t * t * u * u * c[3] +
                       5.0f * t * t * t * t * u * c[4] + t * t * t * t * t * c[5];
            float sg = t * D;
            float pr = sg <= te ? sm_aux_at(h, k, h->len - te + sg) : sm_aux_at(nx, k, sg - te);
            dev = ef_maxf(dev, ef_fabsf(bz - pr));
        }
        s->st.aux_dev_max = ef_maxf(s->st.aux_dev_max, dev);
    }
    return ef_move_measure_aux(m);
}

/* The auxiliary axes of smooth section m on held line h, from h's arc length trim_start
 * to d1: per axis the quintic from the value and rate (units per unit of X Y Z length)
 * where it starts (at a smooth vertex the rate both sides share there, h->ar_s; else h's
 * own) to those where it ends (ar_e, NULL: h's own), with zero second derivative by arc
 * length at both ends, built as a blend's (sm_aux_blend()), so consecutive sections join G2
 * on every axis. 1 when every axis stays within its tolerance of h's programmed value
 * (linear along the chord, at the point's place along it) at the move's samples and its
 * bounds are measured, else 0 (the vertex is then a corner). Only quintic sections carry
 * a moving axis (the gate). */
static int sm_aux_section(ef_smooth_t *s, const ef_smooth_prim_t *h, const float *ar_e, float d1,
                          ef_move_t *m)
{
    if (s->cfg.naux == 0)
        return 1;
    for (int k = 0; k < EF_AUX_N; k++)
        for (int i = 0; i < 6; i++)
            m->ab[k][i] = 0.0f;
    if (!h->amove) { /* constant, as sm_aux_span() makes it */
        for (int k = 0; k < s->cfg.naux; k++)
            for (int i = 0; i <= m->degree; i++)
                m->ab[k][i] = h->astart[k];
        return ef_move_measure_aux(m) == EF_OK;
    }
    if (m->degree != 5)
        return 0;
    sm_aux_ends_t e = sm_aux_ends(m->b);
    int smooth_start = h->start_smooth && !h->start_stop;
    ef_vec3_t dir = sm_dir(h);
    for (int k = 0; k < s->cfg.naux; k++) {
        float own = sm_aux_rate(h, k);
        float p0 = sm_aux_at(h, k, h->trim_start), p1 = sm_aux_at(h, k, d1);
        float k0 = smooth_start ? h->ar_s[k] : own, k1 = ar_e ? ar_e[k] : own;
        float *c = m->ab[k];
        sm_aux_hermite(&e, p0, k0, p1, k1, c);
        /* float32 rounding of the values themselves is not a deviation */
        float slack = 1e-6f * (ef_fabsf(p0) + ef_fabsf(p1)) + 1e-9f;
        float dev = 0.0f;
        for (int i = 1; i < EF_MOVE_SAMPLES; i++) {
            float t = (float)i / (float)EF_MOVE_SAMPLES;
            ef_vec3_t q;
            (void)ef_bezier_eval(m->b, 5, t, 0, &q);
            float u = ef_minf(ef_maxf(ef_v3_dot(ef_v3_sub(q, h->start), dir), 0.0f), h->len);
            dev = ef_maxf(dev, ef_fabsf(ef_bezier_eval_scalar(c, 5, t) - sm_aux_at(h, k, u)));
        }
        if (!(dev <= s->cfg.aux_tol[k] + slack))
            return 0;
        s->st.aux_dev_max = ef_maxf(s->st.aux_dev_max, dev);
    }
    return ef_move_measure_aux(m) == EF_OK;
}

/* h's feed, capped by what its auxiliary axes' speed limits leave the path (the speed the
 * lines around a corner run at, which a blend is weighed against). */
static float sm_aux_vmax(const ef_smooth_t *s, const ef_smooth_prim_t *h)
{
    float v = h->pr.feed;
    for (int k = 0; k < s->cfg.naux; k++) {
        float r = ef_fabsf(sm_aux_rate(h, k));
        if (r > 0.0f)
            v = ef_minf(v, s->cfg.lim.v_axis[3 + k] / r);
    }
    return v;
}

/* The largest trim a blend between a and b may take on either side for the auxiliary axes'
 * tolerances (ef_smooth.h, "Auxiliary axes"); 3.4e38 where none changes its rate, 0 where
 * one does and its tolerance is 0 (an exact stop). *kink: some axis changes its rate. */
static float sm_aux_trim_cap(const ef_smooth_t *s, const ef_smooth_prim_t *a,
                             const ef_smooth_prim_t *b, int *kink)
{
    float cap = 3.4e38f;
    *kink = 0;
    for (int k = 0; k < s->cfg.naux; k++) {
        float ka = sm_aux_rate(a, k), kb = sm_aux_rate(b, k);
        float dk = ef_fabsf(kb - ka);
        /* equal rates to rounding (a line split in two): no kink */
        if (!(dk > 1e-5f * ef_maxf(ef_fabsf(ka), ef_fabsf(kb)) + 1e-12f))
            continue;
        *kink = 1;
        cap = ef_minf(cap, s->cfg.aux_tol[k] / (0.45f * dk));
    }
    return cap;
}

/* Newest staged move, or NULL. */
static ef_move_t *sm_stage_last(ef_smooth_t *s)
{
    return s->sn ? &s->stage[(s->sh + s->sn - 1) % EF_SMOOTH_STAGE] : (ef_move_t *)0;
}

static int sm_line_move(ef_move_t *m, ef_vec3_t a, ef_vec3_t b, float feed, uint32_t tag);

/* Append a move to the stage (caller checked room); snap its start onto the previous
 * move's end so the chain is exactly continuous (they agree to rounding already). */
static void sm_stage(ef_smooth_t *s, const ef_move_t *m)
{
    ef_move_t *prev = sm_stage_last(s);
    ef_move_t gap;
    if (m->length < EF_SM_MIN_MOVE) {
        /* A remnant below float32 resolution (e.g. what two blends leave of a line, to
         * rounding): not a move a planner or drive can time. The move before it is
         * stretched to its end (by less than EF_MIN_CHORD, while that move is still
         * staged) and takes over its stop, if any. With none staged, the move before has
         * gone to the planner, which happens only when it ends at a stop (sm_feed_plan()) or
         * before the first move: the machine is at rest at out_end, within EF_MIN_CHORD of
         * the remnant's end, so a stop of the remnant is that one, and the next move's start
         * snaps over the gap. Counted either way (stats.remnants). */
        s->st.remnants++;
        if (prev) {
            prev->b[prev->degree] = m->b[m->degree];
            for (int k = 0; k < s->cfg.naux; k++)
                prev->ab[k][prev->degree] = s->aout_end[k] = m->ab[k][m->degree];
            prev->flags |= (uint16_t)(m->flags & EF_MOVE_STOP_END);
            (void)ef_move_measure(prev); /* valid before, moved by < EF_MIN_CHORD */
            s->out_end = m->b[m->degree];
            return;
        }
        /* Remnants in a row at rest add up: two tiny arcs after a stop left the chain
         * 1.9e-6 short of the program's end (tests/fuzz corpus ok-remnants-at-rest), where
         * no next move's start covers them. Once the machine would be EF_SM_MIN_MOVE or
         * more from their end, it is driven there: a line, ending at rest as it began. */
        ef_vec3_t re = m->b[m->degree];
        float ae[EF_AUX_N], da2 = 0.0f;
        for (int k = 0; k < EF_AUX_N; k++) {
            ae[k] = m->ab[k][m->degree];
            float d = k < s->cfg.naux ? ae[k] - s->aout_end[k] : 0.0f;
            da2 += d * d;
        }
        if (ef_v3_norm(ef_v3_sub(re, s->out_end)) >= EF_SM_MIN_MOVE) {
            if (sm_line_move(&gap, s->out_end, re, m->feed, m->tag) != EF_OK ||
                sm_aux_set_linear(s, &gap, s->aout_end, ae) != EF_OK)
                return;
        } else if (ef_sqrtf(da2) >= EF_SM_MIN_MOVE) {
            /* X Y Z (nearly) there, the auxiliary axes not (a remnant of a tiny arc or line
             * that turns them, fuzz_smooth): they are driven there alone, from rest */
            ef_move_t zero = {0};
            gap = zero;
            gap.b[0] = gap.b[1] = s->out_end;
            gap.degree = 1;
            gap.kind = EF_MOVE_LINE;
            gap.flags = EF_MOVE_AUX_ONLY;
            gap.feed = m->feed;
            gap.tag = m->tag;
            if (sm_aux_set_linear(s, &gap, s->aout_end, ae) != EF_OK)
                return;
            s->st.aux_moves++;
        } else {
            return;
        }
        gap.flags |= EF_MOVE_STOP_END;
        s->st.stops++;
        m = &gap;
    }
    ef_move_t *d = &s->stage[(s->sh + s->sn) % EF_SMOOTH_STAGE];
    *d = *m;
    ef_vec3_t e = s->out_end;
    float sc = ef_maxf(ef_maxf(ef_fabsf(e.x), ef_fabsf(e.y)), ef_fabsf(e.z));
    if (ef_v3_norm(ef_v3_sub(d->b[0], e)) <= 2.0f * EF_SM_MIN_MOVE + 8.0f * 1.1920929e-7f * sc)
        d->b[0] = e;
    s->out_end = d->b[d->degree];
    for (int k = 0; k < s->cfg.naux; k++) {
        float ea = s->aout_end[k];
        if (ef_fabsf(d->ab[k][0] - ea) <=
            2.0f * EF_SM_MIN_MOVE + 8.0f * 1.1920929e-7f * ef_fabsf(ea))
            d->ab[k][0] = ea;
        s->aout_end[k] = d->ab[k][d->degree];
    }
    s->sn++;
    s->st.dev_max = ef_maxf(s->st.dev_max, m->dev);
}

/* A built, measured move the planner and a drive can take: control points within
 * EF_MAX_COORD and not shorter than the planner accepts (every builder measures already). */
static int sm_move_ok(const ef_move_t *m)
{
    for (int i = 0; i <= m->degree && i < 6; i++)
        if (!sm_v3_ok(m->b[i]))
            return 0;
    return m->length >= EF_SM_MIN_MOVE;
}

/* Fill the measured fields of a move built from control points; 0 on success. */
static int sm_finish_move(ef_move_t *m, uint8_t kind, float feed, uint32_t tag)
{
    m->kind = kind;
    m->feed = feed;
    m->tag = tag;
    return ef_move_measure(m);
}

/* A straight move a -> b. */
static int sm_line_move(ef_move_t *m, ef_vec3_t a, ef_vec3_t b, float feed, uint32_t tag)
{
    ef_move_t zero = {0};
    *m = zero;
    m->b[0] = a;
    m->b[1] = b;
    m->degree = 1;
    return sm_finish_move(m, EF_MOVE_LINE, feed, tag);
}

/* The vertices merged into held line h (valid until its end vertex is decided). */
static ef_vec3_t *sm_run(ef_smooth_t *s, const ef_smooth_prim_t *h)
{
    return s->runs[h->id % EF_SMOOTH_RUNS];
}

/* Vertex k of the input polyline held line h stands for: its start, the vertices merged
 * into it (pts, in order), its end (k = nmerged + 1). */
static ef_vec3_t sm_vertex(const ef_smooth_prim_t *h, const ef_vec3_t *pts, uint32_t k)
{
    if (k == 0)
        return h->start;
    return k <= h->nmerged ? pts[k - 1] : h->pr.end;
}

/* Where vertex k of h lies along its chord (distance from its start). */
static float sm_vertex_u(const ef_smooth_prim_t *h, const ef_vec3_t *pts, uint32_t k, ef_vec3_t dir)
{
    return ef_v3_dot(ef_v3_sub(sm_vertex(h, pts, k), h->start), dir);
}

/* Offset from the chord line of the piecewise-linear curve through (u[i], o[i]) at u, for
 * piece i; outside the piece's span the end point is used and the distance along the chord
 * is returned in *gap (0 inside). */
static ef_vec3_t sm_lerp_off(float u0, ef_vec3_t o0, float u1, ef_vec3_t o1, float u, float *gap)
{
    float du = u1 - u0, t = du > 0.0f ? (u - u0) / du : 0.0f;
    *gap = 0.0f;
    if (t < 0.0f) {
        *gap = u0 - u;
        t = 0.0f;
    } else if (t > 1.0f) {
        *gap = u - u1;
        t = 1.0f;
    }
    return ef_v3_add(o0, ef_v3_scale(ef_v3_sub(o1, o0), t));
}

/* Deviation of the sampled curve (us[j], os[j]: distance along h's chord and offset from it,
 * j = 0..EF_BLEND_DEV_SAMPLES, increasing in u) from the input polyline of h, at equal
 * distance along the chord: the largest |offset of the curve - offset of the polyline| over
 * the curve's span. The input points run forward along the chord (the decimation checks
 * it), so the polyline has exactly one point at each u; between consecutive breakpoints
 * (samples and input vertices) both offsets are affine in u, so the largest difference is
 * at a breakpoint. It bounds both the distance of every curve sample's chord point from the
 * polyline and of every input vertex in the span from the sampled curve. */
static float sm_poly_dev(const ef_smooth_prim_t *h, const ef_vec3_t *pts, ef_vec3_t dir,
                         const float *us, const ef_vec3_t *os)
{
    const int ns = EF_BLEND_DEV_SAMPLES;
    uint32_t nv = h->nmerged + 2, v = 1, k = 0;
    int j = 0, js = 0;
    float worst = 0.0f;
    /* Every sample and every inner vertex once, in order of u: bounded by ns + nv. */
    for (uint32_t guard = 0; guard < (uint32_t)ns + nv + 2u && (j <= ns || v + 1 < nv); guard++) {
        float u;
        if (v + 1 < nv && (j > ns || sm_vertex_u(h, pts, v, dir) < us[j])) {
            u = sm_vertex_u(h, pts, v++, dir);
            if (u < us[0] || u > us[ns])
                continue; /* under a blend at the chord's end, not this curve's */
        } else {
            u = us[j++];
        }
        while (js + 1 < ns && us[js + 1] < u)
            js++;
        while (k + 2 < nv && sm_vertex_u(h, pts, k + 1, dir) < u)
            k++;
        float g0, g1;
        ef_vec3_t oc = sm_lerp_off(us[js], os[js], us[js + 1], os[js + 1], u, &g0);
        ef_vec3_t p0 = ef_v3_sub(sm_vertex(h, pts, k), h->start);
        ef_vec3_t p1 = ef_v3_sub(sm_vertex(h, pts, k + 1), h->start);
        float u0 = ef_v3_dot(p0, dir), u1 = ef_v3_dot(p1, dir);
        ef_vec3_t op =
            sm_lerp_off(u0, ef_v3_axpy(p0, -u0, dir), u1, ef_v3_axpy(p1, -u1, dir), u, &g1);
        ef_vec3_t dd = ef_v3_sub(oc, op);
        float e = ef_sqrtf(ef_v3_dot(dd, dd) + g1 * g1);
        worst = ef_maxf(worst, e);
    }
    return worst;
}

/* Point of a quintic (deg 5) or cubic (deg 3) at t, in Bernstein form with the weights
 * from the powers of t and 1 - t: a tenth of ef_bezier_eval()'s general de Casteljau, and as
 * stable (non-negative weights summing to 1). */
static ef_vec3_t sm_bez_point(const ef_vec3_t *b, int deg, float t)
{
    float u = 1.0f - t, t2 = t * t, u2 = u * u;
    ef_vec3_t r;
    if (deg == 5) {
        float t3 = t2 * t, u3 = u2 * u;
        r = ef_v3_scale(b[0], u3 * u2);
        r = ef_v3_axpy(r, 5.0f * u2 * u2 * t, b[1]);
        r = ef_v3_axpy(r, 10.0f * u3 * t2, b[2]);
        r = ef_v3_axpy(r, 10.0f * u2 * t3, b[3]);
        r = ef_v3_axpy(r, 5.0f * u * t2 * t2, b[4]);
        return ef_v3_axpy(r, t3 * t2, b[5]);
    }
    r = ef_v3_scale(b[0], u2 * u);
    r = ef_v3_axpy(r, 3.0f * u2 * t, b[1]);
    r = ef_v3_axpy(r, 3.0f * u * t2, b[2]);
    return ef_v3_axpy(r, t2 * t, b[3]);
}

/* First half of a smooth section between two frames on held line h (a work unit of its
 * own, ef_smooth_work()): the table's curve, its ends evened; the control points, degree
 * and clamp flag into *m. Returns an ef_err code (the caller falls back). */
static int sm_smooth_curve(ef_smooth_t *s, ef_move_t *m, const ef_frame_t *f0, const ef_frame_t *f1)
{
    ef_endpoint_t e0 = ef_frame_endpoint(f0), e1 = ef_frame_endpoint(f1);
    ef_seg_t seg;
    int rc = s->cfg.smooth_degree == 5 ? ef_seg_g2_quintic(s->cfg.g2, &e0, &e1, &seg)
                                       : ef_seg_g1_cubic(s->cfg.g1, &e0, &e1, &seg);
    if (rc != EF_OK)
        return rc;
    if (seg.degree == 5) { /* even ends; short near-circular pieces: x2 = 0 is more even */
        float ends = 0.0f;
        ef_seg_g2_even(&e0, &e1, &seg, 0, &ends);
        /* Some end data admit no quintic whose end speeds equal its length (a curvature so
         * large against the chord that L(x1) > x1 for every x1: the fuzzer's frames of
         * 1.7e-5 mm radius on a 1.8e-3 mm chord). Such a section would step the feed at
         * both junctions in segment mode: it does not fit, the vertex is a corner. */
        if (!(ends <= ef_seg_end_allow(e0.p, e1.p)))
            return EF_ERR_DOMAIN;
    }
    ef_move_t zero = {0};
    *m = zero;
    for (int i = 0; i <= seg.degree; i++)
        m->b[i] = seg.b[i];
    m->degree = seg.degree;
    m->flags = (uint16_t)((seg.flags & EF_SEG_CLAMPED) ? EF_MOVE_CLAMPED : 0u);
    return EF_OK;
}

/* Second half: the deviation of the curve in *m from held line h, measured from the chord
 * (samples plus a bound between them) and, where vertices were merged into the chord and
 * pts holds them, from the input points themselves (sm_poly_dev()); m->dev is the smaller
 * of the two bounds (chord bound + merge_dev, or the polyline measure) plus the
 * between-samples bound. Then the move is measured. Returns an ef_err code. */
static int sm_smooth_measure(ef_move_t *m, const ef_smooth_prim_t *h, const ef_vec3_t *pts)
{
    /* Samples: distance from the chord, and position along it / offset from it. */
    enum { NS = EF_BLEND_DEV_SAMPLES };
    float us[NS + 1];
    ef_vec3_t os[NS + 1];
    ef_vec3_t dir = sm_dir(h);
    float dmax = 0.0f;
    int mono = 1;
    for (int i = 0; i <= NS; i++) {
        ef_vec3_t p = sm_bez_point(m->b, m->degree, (float)i / (float)NS);
        dmax = ef_maxf(dmax, sm_dist_seg(p, h->start, h->pr.end));
        ef_vec3_t q = ef_v3_sub(p, h->start);
        us[i] = ef_v3_dot(q, dir);
        os[i] = ef_v3_axpy(q, -us[i], dir);
        if (i > 0 && !(us[i] > us[i - 1]))
            mono = 0;
    }
    /* Bound of the distance a chord between two samples can keep from the curve
     * (|f''| h^2 / 8, with |f''| bounded by the second-difference hull of the control
     * points). */
    float d2 = 0.0f;
    int n = m->degree;
    for (int i = 0; i + 2 <= n; i++) {
        ef_vec3_t dd = ef_v3_add(ef_v3_sub(m->b[i + 2], ef_v3_scale(m->b[i + 1], 2.0f)), m->b[i]);
        d2 = ef_maxf(d2, ef_v3_norm(dd));
    }
    float hs = 1.0f / (float)NS;
    float between = (float)(n * (n - 1)) * d2 * hs * hs * 0.125f;
    float dev = dmax + h->merge_dev;
    if (h->nmerged > 0 && mono && pts)
        dev = ef_minf(dev, sm_poly_dev(h, pts, dir, us, os));
    m->dev = dev + between;
    return sm_finish_move(m, EF_MOVE_SMOOTH, h->pr.feed, h->pr.tag);
}

/* The fall-back for a piece no curve can represent: its chord a-b, with exact stops at
 * both ends (the tangents differ there), the previous move marked too while it is still
 * staged (the stage holds the newest move back for this). */
static int sm_chord_stop(ef_smooth_t *s, ef_move_t *m, ef_vec3_t a, ef_vec3_t b,
                         const ef_prim_t *pr)
{
    ef_move_t *prev = sm_stage_last(s);
    if (prev)
        prev->flags |= EF_MOVE_STOP_END;
    int rc = sm_line_move(m, a, b, pr->feed, pr->tag);
    m->flags |= EF_MOVE_STOP_END;
    s->st.stops += 2;
    return rc;
}

/* Frame on a line primitive at a point (tangent = direction, no curvature). */
static ef_frame_t sm_line_frame(ef_vec3_t p, ef_vec3_t dir)
{
    ef_frame_t f;
    f.p = p;
    f.t = dir;
    f.n = ef_v3(0.0f, 0.0f, 0.0f);
    f.kappa = 0.0f;
    return f;
}

/* The curve of held line h's smooth section as its vertices stand (the first of two work
 * units, ef_smooth_work()): its start as decided (a smooth frame, or where the blend before
 * it ended), its end at the smooth frame fe, or on the line trim_end before its end when fe
 * is NULL. Built once, when h's end vertex is decided: a section that fits is kept in h
 * (sm_section_keep()) and emitted from there. Returns an ef_err code. */
static int sm_section_curve(ef_smooth_t *s, const ef_smooth_prim_t *h, const ef_frame_t *fe,
                            float trim_end, ef_move_t *m)
{
    ef_vec3_t dir = sm_dir(h);
    ef_frame_t f0 =
        h->start_smooth ? h->fs : sm_line_frame(ef_v3_axpy(h->start, h->trim_start, dir), dir);
    ef_frame_t f1 = fe ? *fe : sm_line_frame(ef_v3_axpy(h->pr.end, -trim_end, dir), dir);
    if (h->trim_start > 0.0f)
        f0.p = h->blend_in_end; /* exactly where the blend ended */
    return sm_smooth_curve(s, m, &f0, &f1);
}

/* The second unit: that curve measured against h's input points pts (NULL: from the chord
 * only), its auxiliary axes built and measured (sm_aux_section(): rates ar_e where it ends
 * at h's arc length d1, NULL for h's own). 1 when the section is a move within h's
 * tolerances, else 0. */
static int sm_section_fits(ef_smooth_t *s, const ef_smooth_prim_t *h, const ef_vec3_t *pts,
                           const float *ar_e, float d1, ef_move_t *m)
{
    return sm_smooth_measure(m, h, pts) == EF_OK && sm_move_ok(m) && m->dev <= h->pr.tol &&
           sm_aux_section(s, h, ar_e, d1, m);
}

/* Legendre polynomials P0..P4 and their first two derivatives at x. */
static void sm_legendre(float x, float *p, float *d1, float *d2)
{
    float x2 = x * x;
    p[0] = 1.0f;
    p[1] = x;
    p[2] = 1.5f * x2 - 0.5f;
    p[3] = (2.5f * x2 - 1.5f) * x;
    p[4] = (4.375f * x2 - 3.75f) * x2 + 0.375f;
    d1[0] = 0.0f;
    d1[1] = 1.0f;
    d1[2] = 3.0f * x;
    d1[3] = 7.5f * x2 - 1.5f;
    d1[4] = (17.5f * x2 - 7.5f) * x;
    d2[0] = d2[1] = 0.0f;
    d2[2] = 3.0f;
    d2[3] = 15.0f * x;
    d2[4] = 52.5f * x2 - 7.5f;
}

/* Smooth-vertex frame from the input points, not only three of them (ef_smooth.h, rule 3):
 * the circle through a, b, c takes their rounding straight into the tangent and curvature
 * at b (q / L each), and the G2 section between two such frames then carries that noise
 * as curvature changing along it (at 0.001 mm rounding on 0.9 mm chords of a 10 mm circle,
 * a third derivative 8 x the circle's, which starves the ramps of jerk). So every input
 * point of both chords (the runs are still held) is fitted in the circle's plane by a
 * least-squares quartic y(x) across the circle's tangent at b, in Legendre polynomials on
 * the points' x range (well conditioned in float32), and the tangent and curvature at b
 * are taken from the fit: t along (1, y'(0)), kappa = y''(0) / (1 + y'(0)^2)^(3/2), and
 * the vertex moves onto the fitted curve, b + y(0) n, when that is within
 * EF_SMOOTH_FIT_SHIFT tol (the sections on both sides start and end at the frame; a chord
 * driven instead of a section too). Chords with no dropped points (three points, a, b, c)
 * whose neighbouring chords (ending at a, starting at c) continue the run are fitted through
 * five: the one's start zs, a, b, c, the other's end ce (the quartic interpolates them,
 * so b stays; returns 2). The circle's tangent errs by about kappa' L^2 / 6 where the
 * curvature changes along the run (0.015 rad on a sine's 1 mm chords, which the section
 * then corrects by a curvature swinging 40 % about the curve's), the five points' by
 * O(L^4) (0.0007 rad there). Fewer points, or a fit that turns the frame by more than the
 * circle's own turn, keep the circle's frame (returns 0; 1 when the frame is a fit to the
 * dropped points). zs and ce: the two outer points, NULL where the run does not go on. */
static int sm_frame_fit(const ef_smooth_t *s, const ef_smooth_prim_t *pa,
                        const ef_smooth_prim_t *pb, const ef_vec3_t *zs, const ef_vec3_t *ce,
                        float tol, ef_frame_t *f)
{
    uint32_t na = pa->nmerged + 1u, nb = pb->nmerged + 1u; /* vertices before b, after b */
    uint32_t ends = 0;                                     /* zs and ce too */
    if (na + nb + 1u < EF_SMOOTH_FIT_MIN) {
        if (na + nb + 1u != 3u || !zs || !ce)
            return 0;
        ends = 1;
    }
    const ef_vec3_t *ra = s->runs[pa->id % EF_SMOOTH_RUNS];
    const ef_vec3_t *rb = s->runs[pb->id % EF_SMOOTH_RUNS];
    /* x range of the points along t (for the Legendre variable) */
    float xlo = ef_v3_dot(ef_v3_sub(ends ? *zs : pa->start, f->p), f->t);
    float xhi = ef_v3_dot(ef_v3_sub(ends ? *ce : pb->pr.end, f->p), f->t);
    float mid = 0.5f * (xlo + xhi), half = 0.5f * (xhi - xlo);
    if (!(half > EF_MIN_CHORD))
        return 0;
    float G[5][6];
    for (int i = 0; i < 5; i++)
        for (int j = 0; j < 6; j++)
            G[i][j] = 0.0f;
    for (uint32_t jp = 0; jp < na + nb + 1u + 2u * ends; jp++) {
        uint32_t k = jp - ends; /* wraps below 0 for zs; ce is k = na + nb + 1 */
        ef_vec3_t q = ends && jp == 0             ? *zs
                      : ends && k == na + nb + 1u ? *ce
                      : k < na                    ? sm_vertex(pa, ra, k)
                                                  : sm_vertex(pb, rb, k - na); /* b once */
        ef_vec3_t d = ef_v3_sub(q, f->p);
        float xi = (ef_v3_dot(d, f->t) - mid) / half, y = ef_v3_dot(d, f->n);
        float P[5], D1[5], D2[5];
        sm_legendre(xi, P, D1, D2);
        for (int i = 0; i < 5; i++) {
            for (int j = 0; j < 5; j++)
                G[i][j] += P[i] * P[j];
            G[i][5] += P[i] * y;
        }
    }
    /* Gaussian elimination with partial pivoting, 5 x 5 */
    for (int c = 0; c < 5; c++) {
        int piv = c;
        for (int r = c + 1; r < 5; r++)
            if (ef_fabsf(G[r][c]) > ef_fabsf(G[piv][c]))
                piv = r;
        if (!(ef_fabsf(G[piv][c]) > 1e-20f))
            return 0;
        for (int j = 0; j < 6; j++) {
            float t = G[c][j];
            G[c][j] = G[piv][j];
            G[piv][j] = t;
        }
        for (int r = c + 1; r < 5; r++) {
            float m = G[r][c] / G[c][c];
            for (int j = c; j < 6; j++)
                G[r][j] -= m * G[c][j];
        }
    }
    float a[5];
    for (int c = 4; c >= 0; c--) {
        float v = G[c][5];
        for (int j = c + 1; j < 5; j++)
            v -= G[c][j] * a[j];
        a[c] = v / G[c][c];
    }
    float P[5], D1[5], D2[5];
    sm_legendre(-mid / half, P, D1, D2);
    float y0 = 0.0f, y1 = 0.0f, y2 = 0.0f;
    for (int i = 0; i < 5; i++) {
        y0 += a[i] * P[i];
        y1 += a[i] * D1[i];
        y2 += a[i] * D2[i];
    }
    y1 /= half;
    y2 /= half * half;
    float w = 1.0f + y1 * y1;
    float kappa = y2 / (w * ef_sqrtf(w));
    /* The circle's frame is a sound estimate: a fit far from it is a bad fit (too few
     * points across the range, or a run that is not one curve). */
    if (!ef_finitef(kappa) || !ef_finitef(y0) ||
        !(ef_fabsf(y1) <= 0.5f * ef_fabsf(f->kappa) * half + 1e-3f) || !(kappa > 0.0f) ||
        !(kappa < 2.0f * f->kappa + 1e-6f) || !(ef_fabsf(y0) <= EF_SMOOTH_FIT_SHIFT * tol))
        return 0;
    f->p = ef_v3_axpy(f->p, y0, f->n);
    ef_vec3_t t = ef_v3_add(f->t, ef_v3_scale(f->n, y1));
    t = ef_v3_scale(t, 1.0f / ef_v3_norm(t));
    ef_vec3_t n = ef_v3_axpy(f->n, -ef_v3_dot(f->n, t), t);
    n = ef_v3_scale(n, 1.0f / ef_maxf(ef_v3_norm(n), 1e-30f));
    f->t = t;
    f->n = n;
    f->kappa = kappa;
    return ends ? 2 : 1;
}

/* Smooth-vertex test between held lines pa (a->b) and pb (b->c), decimated chords (the
 * tolerance-gated rule, ef_smooth.h); on success *f is the frame at b: the circle through
 * a, b, c, or a fit (sm_frame_fit()) to more input points, zs and ce the start of the line
 * before pa and the end of the line after pb where they continue the run (NULL otherwise). */
static int sm_smooth_gate(const ef_smooth_t *s, const ef_smooth_prim_t *pa,
                          const ef_smooth_prim_t *pb, const ef_vec3_t *zs, const ef_vec3_t *ce,
                          float tol, ef_frame_t *f)
{
    float ml = s->cfg.micro_len;
    if (!(ml > 0.0f))
        return 0;
    if (pa->piece_max > ml || pb->piece_max > ml)
        return 0; /* input lines longer than micro-segments: corners, not samples */
    ef_vec3_t a = pa->start, b = pa->pr.end, c = pb->pr.end;
    ef_vec3_t d1 = ef_v3_sub(b, a), d2 = ef_v3_sub(c, b);
    float l1 = ef_v3_norm(d1), l2 = ef_v3_norm(d2);
    if (l1 > EF_SMOOTH_LEN_RATIO * l2 || l2 > EF_SMOOTH_LEN_RATIO * l1)
        return 0;
    ef_vec3_t u1 = ef_v3_scale(d1, 1.0f / l1), u2 = ef_v3_scale(d2, 1.0f / l2);
    float sn = ef_v3_norm(ef_v3_cross(u1, u2)), cs = ef_v3_dot(u1, u2);
    float turn = ef_atan2f(sn, cs);
    if (turn > s->cfg.micro_turn || turn < EF_BLEND_MIN_TURN)
        return 0; /* straight vertices need no smoothing: the lines go on as lines */
    /* Circumcircle: kappa = 2 sin(turn) / |c - a|. */
    float lac = ef_v3_norm(ef_v3_sub(c, a));
    float kappa = 2.0f * sn / lac;
    /* Gate: the curve through the points bulges from each chord by about kappa L^2 / 8;
     * the rest of the tolerance is kept for the curvature varying along the section (which
     * is measured against the input points before the vertex is taken as smooth). */
    float lm = ef_maxf(l1, l2);
    float bulge = kappa * lm * lm * 0.125f;
    float shift = s->cfg.chord_shift ? ef_minf(0.5f * bulge, EF_SMOOTH_CHORD_SHIFT * tol) : 0.0f;
    if (bulge - shift > EF_SMOOTH_GATE_SHARE * tol)
        return 0;
    /* Tangent of the circle at b: u1 turned towards u2 by the half-angle of chord ab,
     * sin(d1) = l1 kappa / 2. In the plane of u1, u2 with e = u1 and f perpendicular. */
    ef_vec3_t fv = ef_v3_axpy(u2, -cs, u1);
    fv = ef_v3_scale(fv, 1.0f / ef_maxf(ef_v3_norm(fv), 1e-30f));
    float sd = ef_minf(0.5f * l1 * kappa, 1.0f);
    float cd = ef_sqrtf(1.0f - sd * sd);
    ef_vec3_t t = ef_v3_add(ef_v3_scale(u1, cd), ef_v3_scale(fv, sd));
    /* Normal: towards the centre, perpendicular to t in the same plane. */
    ef_vec3_t n = ef_v3_add(ef_v3_scale(u1, -sd), ef_v3_scale(fv, cd));
    f->p = b;
    f->t = t;
    f->n = n;
    f->kappa = kappa;
    if (sm_frame_fit(s, pa, pb, zs, ce, tol, f) != 1 && shift > 0.0f)
        f->p = ef_v3_axpy(b, shift, f->n); /* merged chords: halfway between them and the curve */
    return 1;
}

/* Frame at q of the circular arc from the other end p of a chord, tangent to t there: the
 * tangents at the two ends of an arc make equal angles with its chord. Used where a smooth
 * section ends at an exact stop: the speed is zero there, so the tangent is free, and the
 * arc continues the curve the smooth vertex at the other end estimated (instead of turning
 * into the chord's direction, which costs deviation on a curved run). */
static ef_frame_t sm_arc_frame(ef_vec3_t p, ef_vec3_t t, ef_vec3_t q)
{
    ef_vec3_t d = ef_v3_sub(q, p);
    float l = ef_v3_norm(d);
    ef_vec3_t u = ef_v3_scale(d, 1.0f / ef_maxf(l, 1e-30f));
    ef_frame_t f;
    f.p = q;
    f.t = ef_v3_axpy(ef_v3_scale(t, -1.0f), 2.0f * ef_v3_dot(t, u), u);
    f.t = ef_v3_scale(f.t, 1.0f / ef_maxf(ef_v3_norm(f.t), 1e-30f));
    /* Towards the centre: the part of (p - q) across the tangent at q. */
    ef_vec3_t w = ef_v3_scale(d, -1.0f);
    ef_vec3_t nn = ef_v3_axpy(w, -ef_v3_dot(w, f.t), f.t);
    float ln = ef_v3_norm(nn);
    float sn = ef_v3_norm(ef_v3_cross(t, u));
    if (ln > 1e-6f * l && sn > EF_BLEND_MIN_TURN) {
        f.n = ef_v3_scale(nn, 1.0f / ln);
        f.kappa = 2.0f * sn / l;
    } else {
        f.n = ef_v3(0.0f, 0.0f, 0.0f);
        f.kappa = 0.0f;
    }
    return f;
}

/* Keep the fitted section of held line h (built and measured once: emission hands it on
 * as it is, sm_section_emit()). */
static void sm_section_keep(ef_smooth_prim_t *h, const ef_move_t *m)
{
    h->sec = 1;
    h->sec_dev = m->dev;
    for (int i = 0; i < 6; i++)
        h->sec_b[i] = m->b[i];
    h->sec_degree = m->degree;
    h->sec_flags = m->flags;
    h->sec_len = m->length;
    h->sec_kmax = m->kappa_max;
    h->sec_tabs = m->tabs;
    h->sec_kabs = m->kabs;
    h->sec_kjerk = m->kjerk;
    for (int k = 0; k < EF_AUX_N; k++) {
        for (int i = 0; i < 6; i++)
            h->sec_ab[k][i] = m->ab[k][i];
        h->sec_atabs[k] = m->atabs[k];
        h->sec_akabs[k] = m->akabs[k];
        h->sec_akjerk[k] = m->akjerk[k];
    }
}

/* The move of held line h's kept section (sec == 1), as sm_section_build() made it. */
static void sm_section_emit(const ef_smooth_prim_t *h, ef_move_t *m)
{
    ef_move_t zero = {0};
    *m = zero;
    for (int i = 0; i < 6; i++)
        m->b[i] = h->sec_b[i];
    m->degree = h->sec_degree;
    m->flags = h->sec_flags;
    m->kind = EF_MOVE_SMOOTH;
    m->feed = h->pr.feed;
    m->tag = h->pr.tag;
    m->length = h->sec_len;
    m->kappa_max = h->sec_kmax;
    m->tabs = h->sec_tabs;
    m->kabs = h->sec_kabs;
    m->kjerk = h->sec_kjerk;
    m->dev = h->sec_dev; /* measured against the input points when it was fitted */
    for (int k = 0; k < EF_AUX_N; k++) {
        for (int i = 0; i < 6; i++)
            m->ab[k][i] = h->sec_ab[k][i];
        m->atabs[k] = h->sec_atabs[k];
        m->akabs[k] = h->sec_akabs[k];
        m->akjerk[k] = h->sec_akjerk[k];
    }
}

/* Time a ramp between speed v and v_hi (> v) loses against covering its distance at v_hi:
 * T (v_hi - v) / (2 v_hi), T the S-curve's duration (ef_plan.h, "Speed profile"). */
static float sm_ramp_loss(float v, float v_hi, float a, float j)
{
    float dv = v_hi - v, T;
    if (!(j > 0.0f))
        T = dv / a;
    else if (dv >= a * a / j)
        T = dv / a + a / j;
    else
        T = 2.0f * ef_sqrtf(dv / j);
    return T * dv / (2.0f * v_hi);
}

/* A corner blend whose speed limit (ef_plan_move_limits()) is so low that the time spent in
 * it, blend_len / v_b against blend_len / v_hi, exceeds what the two ramps lose by going on
 * to rest instead of to v_b is slower than an exact stop at the vertex (ef_smooth.h, rule
 * 1): under a jerk limit a sharp corner at a tight tolerance can only be blended at a few
 * mm/s. Between two lines only (an arc's own speed limit may be as low as the blend's):
 * v_hi is their feed within the axis speeds, the acceleration the smallest axis's. */
static int sm_stop_is_faster(const ef_limits_t *lim, ef_move_t *blend, float feed)
{
    float v_b, a_b, j_b;
    blend->feed = feed;
    /* (lim was checked once, by ef_plan_init() in ef_smooth_init()) */
    if (ef_plan_move_limits(lim, blend, &v_b, &a_b, &j_b) != EF_OK || !(v_b < feed))
        return 0;
    float a = ef_minf(lim->a_axis[0], ef_minf(lim->a_axis[1], lim->a_axis[2]));
    float j = lim->j_max, vh = feed;
    for (int i = 0; i < 3; i++)
        vh = ef_minf(vh, lim->v_axis[i]);
    if (!(v_b < vh))
        return 0;
    if (!(v_b > 0.0f))
        return 1;
    float extra = 2.0f * (sm_ramp_loss(0.0f, vh, a, j) - sm_ramp_loss(v_b, vh, a, j));
    return blend->length * (1.0f / v_b - 1.0f / vh) > extra;
}

/* Held primitive a's end vertex is decided (a->end_kind set): the next one, b (NULL when a
 * is the newest), starts at rest after a stop. Then a's smooth section, if it has smooth
 * frames and none yet, is built (the CLOSE phases: a section from a smooth vertex to an
 * exact stop ends on the arc of its smooth start, sm_arc_frame(), when that fits, else on
 * the chord's direction); otherwise a is closed. */
static void sm_job_decided(ef_smooth_t *s, ef_smooth_prim_t *a, ef_smooth_prim_t *b)
{
    if (a->end_kind == EF_V_STOP && b)
        b->start_stop = 1;
    if (a->pr.kind != EF_PRIM_LINE || a->sec != 0 || !(a->start_smooth || a->end_smooth)) {
        a->closed = 1;
        s->job = EF_J_VERTEX;
        return;
    }
    s->job =
        a->end_kind == EF_V_STOP && a->start_smooth && !a->end_smooth ? EF_J_CLOSE_ARC : EF_J_CLOSE;
}

/* a's end vertex is a smooth vertex with the gate's frame s->jf; its section (s->jtrial)
 * fits. */
static void sm_job_smooth(ef_smooth_t *s, ef_smooth_prim_t *a, ef_smooth_prim_t *b)
{
    sm_section_keep(a, &s->jtrial);
    a->end_kind = EF_V_SMOOTH;
    a->end_smooth = 1;
    a->fe = s->jf;
    b->start_smooth = 1;
    b->fs = s->jf;
    for (int k = 0; k < EF_AUX_N; k++)
        a->ar_e[k] = b->ar_s[k] = s->jar[k];
    s->st.smooth++;
    sm_job_decided(s, a, b);
}

/* a's end vertex is an exact stop (counted). */
static void sm_job_stop(ef_smooth_t *s, ef_smooth_prim_t *a, ef_smooth_prim_t *b)
{
    a->end_kind = EF_V_STOP;
    s->st.stops++;
    sm_job_decided(s, a, b);
}

/* The arc frame tried at a's free start (a starts at rest, sm_arc_frame()) is taken back. */
static void sm_job_unarc(ef_smooth_t *s, ef_smooth_prim_t *a)
{
    a->start_smooth = 0;
    a->fs = s->jkeep;
}

/* Whether a line of length l2 along u2 continues the run of micro-segments of a line of
 * length l1 along u1 that it follows or precedes (rule 3's length ratio and turn), for the
 * frame fit of the vertex next to it (sm_frame_fit()). */
static int sm_continues(const ef_smooth_t *s, ef_vec3_t u1, float l1, ef_vec3_t u2, float l2)
{
    if (!(l2 > EF_MIN_CHORD) || l1 > EF_SMOOTH_LEN_RATIO * l2 || l2 > EF_SMOOTH_LEN_RATIO * l1)
        return 0;
    return ef_atan2f(ef_v3_norm(ef_v3_cross(u1, u2)), ef_v3_dot(u1, u2)) <= s->cfg.micro_turn;
}

/* The start of the line before held line a, where it continues a's run, else NULL. */
static const ef_vec3_t *sm_run_before(const ef_smooth_t *s, const ef_smooth_prim_t *a)
{
    if (!a->zline)
        return (const ef_vec3_t *)0;
    ef_vec3_t d = ef_v3_sub(a->start, a->zstart);
    float l = ef_v3_norm(d);
    if (!(l > EF_MIN_CHORD) || !sm_continues(s, sm_dir(a), a->len, ef_v3_scale(d, 1.0f / l), l))
        return (const ef_vec3_t *)0;
    return &a->zstart;
}

/* The end of the held line after held line b, where it continues b's run, else NULL. */
static const ef_vec3_t *sm_run_after(ef_smooth_t *s, const ef_smooth_prim_t *b)
{
    uint32_t i = ((uint32_t)(b - s->pq) + EF_SMOOTH_PRIMS - s->ph) % EF_SMOOTH_PRIMS;
    if (i + 1u >= s->pn)
        return (const ef_vec3_t *)0;
    const ef_smooth_prim_t *c = sm_held(s, i + 1u);
    if (c->pr.kind != EF_PRIM_LINE || c->aux_only || c->piece_max > s->cfg.micro_len ||
        !sm_continues(s, sm_dir(b), b->len, sm_dir(c), c->len))
        return (const ef_vec3_t *)0;
    return &c->pr.end;
}

/* One step of the oldest open vertex's decision (ef_smooth_work(), the phases in
 * ef_smooth.h): held primitive a ends there, b (NULL only when a ends at a finish) starts
 * there. Each phase is one bounded work unit. */
static void sm_job_step(ef_smooth_t *s, ef_smooth_prim_t *a, ef_smooth_prim_t *b)
{
    const ef_vec3_t *pts = sm_run(s, a);
    switch (s->job) {
    case EF_J_VERTEX:
        if (a->fin_stop || !b || (b->pr.flags & EF_PRIM_STOP_BEFORE) || !(b->pr.tol > 0.0f) ||
            a->aux_only || b->aux_only) {
            sm_job_stop(s, a, b);
            return;
        }
        /* The section ending here is final once this vertex is: built and measured now, so
         * a section that does not fit makes this vertex a corner, not an exact stop. */
        if (a->pr.kind == EF_PRIM_LINE && b->pr.kind == EF_PRIM_LINE &&
            (s->cfg.smooth_degree == 5 || (!a->amove && !b->amove)) &&
            sm_smooth_gate(s, a, b, sm_run_before(s, a), sm_run_after(s, b), b->pr.tol, &s->jf)) {
            /* the auxiliary axes' rates at the vertex: the three-point slope through it,
             * (ra lb + rb la) / (la + lb), which both sections meet */
            for (int k = 0; k < EF_AUX_N; k++)
                s->jar[k] = k < s->cfg.naux
                                ? (sm_aux_rate(a, k) * b->len + sm_aux_rate(b, k) * a->len) /
                                      (a->len + b->len)
                                : 0.0f;
            s->job = !a->start_smooth && a->start_stop ? EF_J_SMOOTH_ARC : EF_J_SMOOTH;
        } else
            s->job = EF_J_BLEND;
        return;
    case EF_J_SMOOTH_ARC:
        /* a starts at rest without a smooth frame: the arc of the gate's frame is tried
         * first as its start frame (the reflection of the forward tangent at the end is the
         * forward one here) */
        s->jkeep = a->fs;
        a->fs = sm_arc_frame(s->jf.p, s->jf.t, a->start);
        a->start_smooth = 1;
        if (sm_section_curve(s, a, &s->jf, 0.0f, &s->jtrial) == EF_OK) {
            s->job = EF_J_SMOOTH_ARC_M;
        } else {
            sm_job_unarc(s, a);
            s->job = EF_J_SMOOTH;
        }
        return;
    case EF_J_SMOOTH_ARC_M:
        if (sm_section_fits(s, a, pts, s->jar, a->len, &s->jtrial)) {
            sm_job_smooth(s, a, b);
            return;
        }
        sm_job_unarc(s, a);
        s->job = EF_J_SMOOTH;
        return;
    case EF_J_SMOOTH:
        s->job =
            sm_section_curve(s, a, &s->jf, 0.0f, &s->jtrial) == EF_OK ? EF_J_SMOOTH_M : EF_J_BLEND;
        return;
    case EF_J_SMOOTH_M:
        if (sm_section_fits(s, a, pts, s->jar, a->len, &s->jtrial))
            sm_job_smooth(s, a, b);
        else
            s->job = EF_J_BLEND;
        return;
    case EF_J_BLEND: {
        /* What the decimation used of the tolerance is not available to a blend here;
         * smooth sections are measured against the input points themselves. Each side
         * gives at most half its length, so the blends at its two ends cannot overlap
         * (ef_smooth.h); both primitives were checked when pushed, a->len and b->len are
         * ef_prim_check()'s. */
        float tol = b->pr.tol - ef_maxf(a->merge_dev, b->merge_dev);
        int kink;
        float cap = sm_aux_trim_cap(s, a, b, &kink);
        if (kink && !(cap >= 4.0f * EF_MIN_CHORD)) {
            /* an auxiliary axis changes its rate here and its tolerance leaves no blend */
            s->st.aux_stops++;
            sm_job_stop(s, a, b);
            return;
        }
        int rc = ef_blend_prims_valid(s->cfg.g2, a->start, &a->pr, a->len, &b->pr, b->len, tol,
                                      ef_minf(0.5f * a->len, cap), ef_minf(0.5f * b->len, cap),
                                      &a->blend);
        if (rc == EF_OK && (a->blend.flags & EF_BLEND_STRAIGHT) && kink) {
            /* straight through, but an auxiliary axis changes its rate: no blend to carry
             * that, so the axis would jump in speed */
            s->st.aux_stops++;
            sm_job_stop(s, a, b);
        } else if (rc == EF_ERR_REVERSAL) {
            s->st.reversals++;
            sm_job_stop(s, a, b);
        } else if (rc != EF_OK || (a->blend.flags & EF_BLEND_STOP)) {
            /* No blend that float32 can hold (or a lookup failure on validated data): the
             * safe outcome is the same as for a reversal, an exact stop. */
            sm_job_stop(s, a, b);
        } else if (a->blend.flags & EF_BLEND_STRAIGHT) {
            a->end_kind = EF_V_STRAIGHT;
            s->st.straight++;
            sm_job_decided(s, a, b);
        } else {
            s->job = EF_J_PROBE;
        }
        return;
    }
    case EF_J_PROBE: {
        /* A blend as wide as a huge tolerance allows can reach beyond the coordinate range
         * (its control points are not bounded by the path's): not a move anything can
         * hold ... */
        ef_move_t *probe = &s->jtrial;
        ef_move_t zero = {0};
        *probe = zero;
        for (int i = 0; i < 6; i++)
            probe->b[i] = a->blend.seg.b[i];
        probe->degree = 5;
        /* ... or loop far from the path it replaces (a huge tolerance lets the trial trims
         * grow into configurations the table clamps): a blend longer than twice the trimmed
         * path is not a rounded corner, and its speed peaks between the samples the limits
         * rely on. */
        if (ef_move_measure(probe) != EF_OK || !sm_move_ok(probe) ||
            !(probe->length <= 2.0f * (a->blend.trim_in + a->blend.trim_out) + EF_MIN_CHORD)) {
            sm_job_stop(s, a, b);
            return;
        }
        if (!s->cfg.keep_slow_blends && a->pr.kind == EF_PRIM_LINE && b->pr.kind == EF_PRIM_LINE &&
            sm_stop_is_faster(&s->cfg.lim, probe, ef_minf(sm_aux_vmax(s, a), sm_aux_vmax(s, b)))) {
            s->st.slow_corners++;
            sm_job_stop(s, a, b);
            return;
        }
        a->blend_len = probe->length;
        a->blend_kmax = probe->kappa_max;
        a->blend_tabs = probe->tabs;
        a->blend_kabs = probe->kabs;
        a->blend_kjerk = probe->kjerk;
        a->end_kind = EF_V_BLEND;
        a->trim_end = a->blend.trim_in;
        b->trim_start = a->blend.trim_out;
        b->blend_in_end = a->blend.seg.b[5]; /* as emitted; a section on b starts there */
        s->st.blends++;
        sm_job_decided(s, a, b);
        return;
    }
    case EF_J_CLOSE_ARC:
        s->jf = sm_arc_frame(a->fs.p, a->fs.t, a->pr.end);
        s->job = sm_section_curve(s, a, &s->jf, 0.0f, &s->jtrial) == EF_OK ? EF_J_CLOSE_ARC_M
                                                                           : EF_J_CLOSE;
        return;
    case EF_J_CLOSE_ARC_M:
        if (sm_section_fits(s, a, pts, (const float *)0, a->len, &s->jtrial)) {
            a->fe = s->jf;
            a->end_smooth = 1;
            sm_section_keep(a, &s->jtrial);
            a->closed = 1;
            s->job = EF_J_VERTEX;
        } else {
            s->job = EF_J_CLOSE;
        }
        return;
    case EF_J_CLOSE:
        if (sm_section_curve(s, a, a->end_smooth ? &a->fe : (const ef_frame_t *)0, a->trim_end,
                             &s->jtrial) == EF_OK) {
            s->job = EF_J_CLOSE_M;
            return;
        }
        a->sec = 2u; /* driven as its chord between exact stops */
        a->closed = 1;
        s->job = EF_J_VERTEX;
        return;
    default: /* EF_J_CLOSE_M */
        if (sm_section_fits(
                s, a, pts, a->end_smooth && a->end_kind == EF_V_SMOOTH ? a->ar_e : (const float *)0,
                a->end_smooth ? a->len : a->len - a->trim_end, &s->jtrial))
            sm_section_keep(a, &s->jtrial);
        else
            a->sec = 2u;
        a->closed = 1;
        s->job = EF_J_VERTEX;
        return;
    }
}

/* Arc length bounds of piece i (0-based) of n of an arc body; the last piece ends exactly
 * at the body's end, so the chain meets the next move without a rounding gap. */
static void sm_piece_bounds(const ef_smooth_prim_t *h, uint32_t i, uint32_t n, float *a, float *b)
{
    float s0 = h->trim_start, s1 = h->len - h->trim_end;
    *a = s0 + (s1 - s0) * (float)i / (float)n;
    *b = (i + 1 == n) ? s1 : s0 + (s1 - s0) * (float)(i + 1) / (float)n;
}

/* Move i (0-based) of n pieces of the oldest (arc) primitive's body. */
static int sm_arc_piece(ef_smooth_t *s, ef_smooth_prim_t *h, uint32_t i, uint32_t n, ef_move_t *m)
{
    float a, b;
    sm_piece_bounds(h, i, n, &a, &b);
    return ef_blend_arc_piece(s->cfg.g2, h->start, &h->pr, a, b, m);
}

/* Pieces an arc body is split into. */
static uint32_t sm_arc_pieces(const ef_smooth_prim_t *h)
{
    float frac = (h->len - h->trim_start - h->trim_end) / h->len;
    float sw = ef_fabsf(h->pr.sweep) * frac;
    float n = sw / EF_ARC_PIECE_SWEEP;
    uint32_t k = (uint32_t)n;
    if ((float)k < n)
        k++;
    return k ? k : 1u;
}

static int sm_next_move(ef_smooth_t *s, ef_move_t *m);

/* The oldest primitive has no body left between its blends: go on with its end blend, or,
 * when its end is an exact stop, put that stop on the move before (the newest staged one:
 * the stage holds it back for this), so the run still ends at rest. */
static int sm_skip_body(ef_smooth_t *s, ef_smooth_prim_t *h, ef_move_t *m)
{
    ef_move_t *prev = sm_stage_last(s);
    if (prev && h->end_kind != EF_V_BLEND) {
        /* What is left (under EF_MIN_CHORD) is taken by the move before, which then ends
         * exactly at the primitive's end, and its stop with it. */
        prev->b[prev->degree] = h->pr.end;
        for (int k = 0; k < s->cfg.naux; k++)
            prev->ab[k][prev->degree] = s->aout_end[k] = h->pr.aux[k];
        (void)ef_move_measure(prev);
        s->out_end = h->pr.end;
        if (h->end_kind == EF_V_STOP)
            prev->flags |= EF_MOVE_STOP_END;
    }
    s->emitting = EF_E_BLEND;
    return sm_next_move(s, m);
}

/* Build the next move of the oldest held primitive (closed: its two vertices decided, its
 * section built) into *m. Returns 1 when a move was built, 0 when the primitive had nothing
 * more (it is then popped), 2 when a work unit went into sizing its arc body (no move yet),
 * or a negative ef_err code. */
static int sm_next_move(ef_smooth_t *s, ef_move_t *m)
{
    ef_smooth_prim_t *h = sm_held(s, 0);
    if (s->emitting == EF_E_BODY && h->aux_only) {
        /* X Y Z still, between exact stops (both vertices stop: sm_job_step()) */
        ef_move_t zero = {0};
        *m = zero;
        m->b[0] = m->b[1] = h->start;
        m->degree = 1;
        m->kind = EF_MOVE_LINE;
        m->feed = h->pr.feed;
        m->tag = h->pr.tag;
        m->flags = EF_MOVE_AUX_ONLY | EF_MOVE_STOP_END;
        int rc = sm_aux_span(s, h, 0.0f, h->len, m);
        if (rc != EF_OK)
            return rc;
        s->st.aux_moves++;
        s->emitting = EF_E_DONE;
        return 1;
    }
    if (s->emitting == EF_E_BODY) {
        int rc, kept = 0;
        if (h->pr.kind == EF_PRIM_ARC) {
            if (h->len - h->trim_start - h->trim_end < EF_MIN_CHORD) {
                /* Both blends took the whole arc: nothing of it is left between them. */
                return sm_skip_body(s, h, m);
            }
            int reuse = 0;
            if (s->arc_next == 0 && !s->arc_sized) {
                /* Piece count: by sweep, then doubled until a piece is within the budget
                 * (all pieces of an arc are congruent, so the first one decides), one trial
                 * piece per work unit. A doubling that does not halve the deviation stops
                 * there, one count back: what is left is float32 rounding at the
                 * coordinates' magnitude, which no split reduces (the approximation error
                 * falls 64-fold per doubling). Nor is a piece made shorter than
                 * EF_SM_MIN_PIECE: the stage would drop it as a remnant (a fuzzed arc of
                 * 1e-6 at z = 1e5 went into 64 pieces of 1.6e-8, all dropped, and the chain
                 * ended 1.07e-6 short). */
                float budget = ef_maxf(0.5f * h->pr.tol, EF_SMOOTH_ARC_TOL_MIN);
                float body = h->len - h->trim_start - h->trim_end;
                if (s->arc_k == 0) {
                    s->arc_try = sm_arc_pieces(h);
                    s->arc_dev = 3.4e38f;
                }
                uint32_t n = s->arc_try;
                int rc0 = sm_arc_piece(s, h, 0, n, m);
                uint32_t built = rc0 == EF_OK ? n : 0u;
                if (rc0 != EF_OK || m->dev <= budget) {
                    /* this count */
                } else if (!(m->dev < 0.5f * s->arc_dev)) {
                    n /= 2u;
                } else if (!(s->arc_k == EF_SMOOTH_ARC_SPLITS ||
                             body < 2.0f * (float)n * EF_SM_MIN_PIECE)) {
                    s->arc_dev = m->dev;
                    s->arc_try = 2u * n;
                    s->arc_k++;
                    return 2; /* next unit: the next trial */
                }
                s->arc_n = n;
                s->arc_sized = 1;
                /* the first piece at the final count is already in *m: not built twice */
                reuse = built == n;
                if (!reuse)
                    return 2; /* next unit: the first piece at the count found */
            }
            uint32_t n = s->arc_n;
            rc = reuse ? EF_OK : sm_arc_piece(s, h, s->arc_next, n, m);
            if (rc == EF_OK && !sm_move_ok(m))
                rc = EF_ERR_NONFINITE;
            if (rc == EF_OK) {
                float pa, pb;
                sm_piece_bounds(h, s->arc_next, n, &pa, &pb);
                rc = sm_aux_span(s, h, pa, pb, m);
            }
            if (rc == EF_OK) {
                s->st.arc_pieces++;
                if (++s->arc_next < n)
                    return 1; /* more pieces; the last one goes on below */
            } else {
                /* A piece the table cannot hold (validated data should never get here): its
                 * chord, with exact stops at both ends, so no tangent break is driven
                 * through at speed. */
                ef_frame_t f0, f1;
                float a, b;
                sm_piece_bounds(h, s->arc_next, n, &a, &b);
                ef_prim_frame(h->start, &h->pr, a, &f0);
                ef_prim_frame(h->start, &h->pr, b, &f1);
                rc = sm_chord_stop(s, m, f0.p, f1.p, &h->pr);
                if (rc == EF_OK)
                    rc = sm_aux_span(s, h, a, b, m);
                if (rc == EF_OK && ++s->arc_next < n)
                    return 1;
            }
        } else {
            ef_vec3_t dir = sm_dir(h);
            ef_vec3_t a = ef_v3_axpy(h->start, h->trim_start, dir);
            ef_vec3_t b = ef_v3_axpy(h->pr.end, -h->trim_end, dir);
            if (h->start_smooth || h->end_smooth) {
                rc = EF_OK;
                if (h->sec == 1) {
                    sm_section_emit(h, m); /* its auxiliary axes built with it */
                    kept = 1;
                } else {
                    /* Not representable within the tolerance: the chord itself, with exact
                     * stops at both ends (tangents differ there). */
                    if (h->trim_start > 0.0f)
                        a = h->blend_in_end;
                    rc = sm_chord_stop(s, m, h->start_smooth ? h->fs.p : a,
                                       h->end_smooth ? h->fe.p : b, &h->pr);
                    /* the frames may sit off the chord's ends (sm_frame_fit()) */
                    float sh =
                        ef_maxf(h->start_smooth ? ef_v3_norm(ef_v3_sub(h->fs.p, h->start)) : 0.0f,
                                h->end_smooth ? ef_v3_norm(ef_v3_sub(h->fe.p, h->pr.end)) : 0.0f);
                    m->dev = h->merge_dev + sh;
                }
            } else {
                if (h->trim_start > 0.0f)
                    a = h->blend_in_end;
                /* exactly where the blend starts: its frame point on a long line is rounded
                 * at the line's scale, not at its end's (a fuzzed gap of 4e-6) */
                if (h->end_kind == EF_V_BLEND && h->blend.seg.degree == 5)
                    b = h->blend.seg.b[0];
                if (ef_v3_norm(ef_v3_sub(b, a)) < EF_MIN_CHORD) {
                    /* Both blends took the whole line: nothing straight is left. */
                    return sm_skip_body(s, h, m);
                }
                rc = sm_line_move(m, a, b, h->pr.feed, h->pr.tag);
                m->dev = h->merge_dev; /* the chord, off the input points by that much */
            }
            if (rc == EF_OK && !kept)
                rc = sm_aux_span(s, h, h->trim_start, h->len - h->trim_end, m);
        }
        if (rc != EF_OK)
            return rc;
        s->emitting = EF_E_BLEND;
        if (h->end_kind == EF_V_BLEND)
            return 1;
        if (h->end_kind == EF_V_STOP)
            m->flags |= EF_MOVE_STOP_END;
        s->emitting = EF_E_DONE;
        return 1;
    }
    if (s->emitting == EF_E_BLEND && h->end_kind == EF_V_BLEND) {
        ef_move_t zero = {0};
        *m = zero;
        for (int i = 0; i < 6; i++)
            m->b[i] = h->blend.seg.b[i];
        ef_smooth_prim_t *nx = sm_held(s, 1);
        m->degree = 5;
        m->dev = h->blend.dev + ef_maxf(h->merge_dev, nx->merge_dev);
        if (h->blend.flags & EF_BLEND_CLAMPED)
            m->flags |= EF_MOVE_BLEND_CLAMPED;
        if (h->blend.flags & EF_BLEND_TBL_CLAMPED)
            m->flags |= EF_MOVE_CLAMPED;
        m->kind = EF_MOVE_BLEND;
        m->feed = ef_minf(h->pr.feed, nx->pr.feed);
        m->tag = nx->pr.tag;
        m->length = h->blend_len; /* measured when the vertex was decided */
        m->kappa_max = h->blend_kmax;
        m->tabs = h->blend_tabs;
        m->kabs = h->blend_kabs;
        m->kjerk = h->blend_kjerk;
        int rc = sm_aux_blend(s, h, nx, m);
        if (rc != EF_OK)
            return rc;
        nx->blend_in_end = m->b[5];
        s->emitting = EF_E_DONE;
        return 1;
    }
    return 0;
}

/* The oldest staged move into the planner, when it may go and the planner has room: the
 * newest staged move is held back (unless it ends at a stop) so a fall-back can still mark
 * it as ending at a stop. A work unit of its own: the planner's backward pass may run over
 * its whole window (ef_plan.h, "Cost"). 1 when a move went, 0 when none could, or an ef_err
 * code. */
static int sm_feed_plan(ef_smooth_t *s)
{
    ef_move_t *last = sm_stage_last(s);
    if (!(s->sn > 1 || (last && (last->flags & EF_MOVE_STOP_END))) || ef_plan_space(&s->plan) == 0)
        return 0;
    int rc = ef_plan_push(&s->plan, &s->stage[s->sh]);
    if (rc != EF_OK)
        return rc;
    s->sh = (s->sh + 1) % EF_SMOOTH_STAGE;
    s->sn--;
    return 1;
}

/* The oldest held primitive that is not closed and the index of it, or NULL when every held
 * primitive is. */
static ef_smooth_prim_t *sm_open(ef_smooth_t *s, uint32_t *at)
{
    for (uint32_t i = 0; i < s->pn; i++) {
        ef_smooth_prim_t *h = sm_held(s, i);
        if (!h->closed) {
            *at = i;
            return h;
        }
    }
    return (ef_smooth_prim_t *)0;
}

/* One work unit (ef_smooth_work()), the first of: a staged move into the planner; the
 * oldest closed primitive's next move onto the stage when it has room; one phase of the
 * oldest open vertex's decision once that vertex can be decided (the primitive after it can
 * no longer grow by decimation: one more has come, or a finish). 1 when a unit was done, 0
 * when nothing can be done now, or a negative ef_err code. */
static int sm_unit(ef_smooth_t *s)
{
    int fed = sm_feed_plan(s);
    if (fed != 0)
        return fed;
    if (s->pn > 0 && s->sn < EF_SMOOTH_STAGE && sm_held(s, 0)->closed) {
        ef_move_t m;
        int rc = sm_next_move(s, &m);
        if (rc < 0)
            return rc;
        if (rc == 1)
            sm_stage(s, &m);
        if (s->emitting == EF_E_DONE || rc == 0) {
            s->ph = (s->ph + 1) % EF_SMOOTH_PRIMS;
            s->pn--;
            s->emitting = EF_E_BODY;
            s->arc_next = 0;
            s->arc_sized = 0;
            s->arc_k = 0;
        }
        return 1;
    }
    uint32_t i;
    ef_smooth_prim_t *a = sm_open(s, &i);
    if (!a)
        return 0;
    ef_smooth_prim_t *b = i + 1 < s->pn ? sm_held(s, i + 1) : (ef_smooth_prim_t *)0;
    if (s->job == EF_J_VERTEX && !a->fin_stop && !(i + 2 < s->pn) && !(b && b->fin_stop))
        return 0; /* b may still grow */
    sm_job_step(s, a, b);
    return 1;
}

/* One unit of work (ef_smooth.h, "Work units"). */
int ef_smooth_work(ef_smooth_t *s)
{
    if (!s)
        return EF_ERR_ARG;
    int did = sm_unit(s);
    if (did < 0)
        return did;
    if (!did)
        return EF_ERR_AGAIN;
    s->st.units++;
    return EF_OK;
}

/* Room for one more held primitive: a ring slot, and its run slot (the one of the
 * primitive three before it) no longer needed, i.e. that one closed (ids wrap safely). */
static int sm_room(ef_smooth_t *s)
{
    if (s->pn >= EF_SMOOTH_PRIMS)
        return 0;
    uint32_t i;
    const ef_smooth_prim_t *h = sm_open(s, &i);
    return !h || s->next_id - h->id <= 2u;
}

/* Band decimation (ef_smooth.h, rule 2): merge line pr (from s->pos) into the newest held
 * line when every inner vertex, old and new, lies within the band of the merged chord and
 * every input piece runs forward along it (no reversal, whatever the band), at the same
 * feed. Straight runs and gently curving ones alike. Returns 1 when merged. */
static int sm_try_merge(ef_smooth_t *s, const ef_prim_t *pr)
{
    if (s->pn == 0 || pr->kind != EF_PRIM_LINE || !(pr->qtol > 0.0f) || !(pr->tol > 0.0f) ||
        (pr->flags & EF_PRIM_STOP_BEFORE))
        return 0;
    ef_smooth_prim_t *h = sm_held(s, s->pn - 1);
    /* no decimation across an auxiliary axis's motion (ef_smooth.h, "Auxiliary axes") */
    if (h->amove || h->aux_only)
        return 0;
    for (int k = 0; k < s->cfg.naux; k++)
        if (pr->aux[k] != s->apos[k])
            return 0;
    if (h->pr.kind != EF_PRIM_LINE || h->end_kind != EF_V_OPEN || h->fin_stop ||
        h->pr.feed != pr->feed || h->nmerged >= EF_SMOOTH_MERGE_MAX || !(h->pr.tol > 0.0f))
        return 0;
    ef_vec3_t a = h->start, c = pr->end;
    ef_vec3_t ac = ef_v3_sub(c, a);
    float lac = ef_v3_norm(ac);
    if (!(lac > EF_MIN_CHORD))
        return 0;
    /* The band: Q, and at most a share of the path tolerance so the blends and smooth
     * sections on the chord keep the rest. A run whose every inner vertex turns by 60
     * degrees or more (a curving or S-shaped run never does; its pieces turn by a few
     * degrees) is noise about a straight line, a zigzag of rounding or of a CAM post: it
     * may use Q up to the whole tol, as LinuxCNC's G64 Q does. The blends at its ends then
     * get what is left of tol (rule 2 in ef_smooth.h). */
    float qt = ef_minf(pr->qtol, h->pr.qtol), tl = ef_minf(pr->tol, h->pr.tol);
    float lim = ef_minf(qt, EF_SMOOTH_BAND_SHARE * tl), wide = ef_minf(qt, tl);
    /* Every piece forward along the new chord, every inner vertex within the band. */
    ef_vec3_t prev = a;
    float dev = 0.0f;
    int sharp = 1;
    ef_vec3_t *pts = sm_run(s, h);
    for (uint32_t i = 0; i <= h->nmerged; i++) {
        ef_vec3_t v = i < h->nmerged ? pts[i] : h->pr.end;
        ef_vec3_t next = i + 1 < h->nmerged ? pts[i + 1] : (i < h->nmerged ? h->pr.end : c);
        ef_vec3_t din = ef_v3_sub(v, prev), dout = ef_v3_sub(next, v);
        if (!(ef_v3_dot(din, ac) > 0.0f))
            return 0;
        sharp &= ef_v3_dot(din, dout) <= 0.5f * ef_v3_norm(din) * ef_v3_norm(dout);
        dev = ef_maxf(dev, sm_dist_seg(v, a, c));
        if (!(dev <= wide))
            return 0;
        prev = v;
    }
    if (!(ef_v3_dot(ef_v3_sub(c, prev), ac) > 0.0f) || !(dev <= (sharp ? wide : lim)))
        return 0;
    h->merge_dev = dev;
    pts[h->nmerged++] = h->pr.end;
    h->piece_max = ef_maxf(h->piece_max, ef_v3_norm(ef_v3_sub(c, h->pr.end)));
    h->pr.end = c;
    h->pr.tol = ef_minf(h->pr.tol, pr->tol);
    h->pr.qtol = ef_minf(h->pr.qtol, pr->qtol);
    h->len = lac;
    s->st.merged++;
    return 1;
}

/* Accept one primitive (ef_smooth.h). */
int ef_smooth_push(ef_smooth_t *s, const ef_prim_t *pr)
{
    if (!s || !pr)
        return EF_ERR_ARG;
    /* One unit of the work pending before taking more: a push costs one unit at most. */
    int rc = ef_smooth_work(s);
    if (rc != EF_OK && rc != EF_ERR_AGAIN)
        return rc;
    /* Taken (merged or held) only with a slot free: a primitive pushed again after
     * EF_ERR_FULL is checked and its decimation tested once, not at every call. Deferring
     * a merge changes nothing: the newest held line is not touched by the work units. */
    if (!sm_room(s))
        return EF_ERR_FULL;
    float len;
    int aux_only = 0, amove = 0;
    for (int k = 0; k < s->cfg.naux; k++) {
        if (!sm_coord_ok(pr->aux[k]))
            return EF_ERR_NONFINITE;
        amove |= pr->aux[k] != s->apos[k];
    }
    if (amove && pr->kind == EF_PRIM_LINE && sm_v3_ok(pr->end) &&
        ef_v3_norm(ef_v3_sub(pr->end, s->pos)) < EF_MIN_CHORD) {
        /* X Y Z still: an auxiliary move, its length the axes' own distance */
        float l2 = 0.0f;
        for (int k = 0; k < s->cfg.naux; k++) {
            float d = pr->aux[k] - s->apos[k];
            l2 += d * d;
        }
        len = ef_sqrtf(l2);
        aux_only = len >= EF_MIN_CHORD;
    }
    if (aux_only) {
        if (pr->flags & ~EF_PRIM_STOP_BEFORE)
            return EF_ERR_ARG;
        if (!(pr->feed - pr->feed == 0.0f) || !(pr->tol - pr->tol == 0.0f) ||
            !(pr->qtol - pr->qtol == 0.0f))
            return EF_ERR_NONFINITE;
        if (pr->tol < 0.0f || pr->qtol < 0.0f)
            return EF_ERR_ARG;
        if (!(pr->feed > 0.0f))
            return EF_ERR_FEED;
    } else {
        rc = ef_prim_check(s->pos, pr, &len);
        if (rc != EF_OK)
            return rc;
    }
    if (!aux_only && sm_try_merge(s, pr)) {
        s->pos = pr->end;
        s->st.prims++;
        return EF_OK;
    }
    ef_smooth_prim_t *h = sm_held(s, s->pn);
    h->pr = *pr;
    h->start = s->pos;
    h->len = len;
    h->amove = (uint8_t)amove;
    h->aux_only = (uint8_t)aux_only;
    for (int k = 0; k < EF_AUX_N; k++) {
        h->astart[k] = k < s->cfg.naux ? s->apos[k] : 0.0f;
        h->pr.aux[k] = k < s->cfg.naux ? pr->aux[k] : 0.0f;
    }
    if (aux_only)
        h->pr.end = s->pos; /* X Y Z stay exactly */
    h->trim_start = h->trim_end = 0.0f;
    h->end_kind = EF_V_OPEN;
    h->fin_stop = 0;
    h->closed = 0;
    h->start_smooth = h->end_smooth = 0;
    /* At rest where it starts: the first primitive, or after ef_smooth_finish(); a stop
     * decided later sets it in sm_job_decided(). */
    const ef_smooth_prim_t *prev = s->pn ? sm_held(s, s->pn - 1) : (const ef_smooth_prim_t *)0;
    h->start_stop = !prev || prev->end_kind == EF_V_STOP || prev->fin_stop;
    h->zline = prev && prev->pr.kind == EF_PRIM_LINE && !prev->aux_only &&
               prev->piece_max <= s->cfg.micro_len;
    h->zstart = prev ? prev->start : h->start;
    h->nmerged = 0;
    h->merge_dev = 0.0f;
    h->piece_max = len;
    h->sec = 0;
    h->sec_dev = 0.0f;
    /* Its run slot is the one of the primitive three before it, closed (sm_room()). */
    h->id = s->next_id++;
    h->blend_in_end = h->start;
    s->pn++;
    s->pos = h->pr.end;
    for (int k = 0; k < s->cfg.naux; k++)
        s->apos[k] = pr->aux[k];
    s->st.prims++;
    return EF_OK;
}

/* Mark the end as an exact stop, then one unit of the work left (ef_smooth.h). */
int ef_smooth_finish(ef_smooth_t *s)
{
    if (!s)
        return EF_ERR_ARG;
    if (s->pn >= 1) {
        ef_smooth_prim_t *b = sm_held(s, s->pn - 1);
        if (b->end_kind == EF_V_OPEN)
            b->fin_stop = 1;
    }
    int rc = ef_smooth_work(s);
    if (rc != EF_OK && rc != EF_ERR_AGAIN)
        return rc;
    /* done when every primitive is built and every move is in the planner (the last one
     * ends at a stop, so none is held back) */
    return s->pn == 0 && s->sn == 0 ? EF_OK : EF_ERR_FULL;
}

/* Hand out the next final move: the planner's release only (the work units feed it);
 * now: whatever the planner's window holds (ef_smooth_pull_now()). */
static int sm_pull(ef_smooth_t *s, ef_move_t *m, int now)
{
    if (!s || !m)
        return EF_ERR_ARG;
    int rc = now ? ef_plan_pull_now(&s->plan, m) : ef_plan_pull(&s->plan, m);
    if (rc == EF_OK)
        s->st.moves++;
    return rc;
}

int ef_smooth_pull(ef_smooth_t *s, ef_move_t *m)
{
    return sm_pull(s, m, 0);
}

int ef_smooth_pull_now(ef_smooth_t *s, ef_move_t *m)
{
    return sm_pull(s, m, 1);
}

/* Copy of the counters. */
ef_smooth_stats_t ef_smooth_stats(const ef_smooth_t *s)
{
    ef_smooth_stats_t z = {0};
    return s ? s->st : z;
}
