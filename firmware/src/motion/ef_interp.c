/* SPDX-License-Identifier: Apache-2.0 */
/* Interpolator: planned moves -> setpoints at the servo period (see ef_interp.h). */
#include "evenfeed/motion/ef_interp.h"
#include "evenfeed/geom/ef_bezier.h"
#include "evenfeed/core/ef_err.h"

/** Smallest parametric speed |f'(tau)| the corrected step divides by (below it the law's
 *  tau is used for that sample). */
#define EF_INTERP_MIN_DERIV 1e-12f

/** Largest parameter step of the corrected mode (1/64 of a curve: the chord of a quintic
 *  over that span is within a few 1e-5 of its arc length); a deficit larger than that share
 *  of the length resynchronises with the time law. */
#define EF_INTERP_RESYNC (1.0f / 64.0f)
/** Newton steps of a resynchronisation. */
#define EF_INTERP_RESYNC_ITER 3
/** Largest parameter step of the corrected mode in law steps (the law's distance per period
 *  over L): where the parametric speed |f'| is a small share of L (a blend whose end x1
 *  sits at the table's lower bound, 0.1 of the chord: |f'(0)| ~ L / 12) one period needs
 *  up to about L / |f'| law steps; a smaller cap makes the setpoint lag there and then
 *  catch up, a speed jump (issue 18). */
#define EF_INTERP_STEP_CAP 16.0f
/** Bounds of the corrected step's secant factor gap / arc (see ip_eval()). */
#define EF_INTERP_SECANT_MIN 0.5f
#define EF_INTERP_SECANT_MAX 2.0f
/** Largest relative arc-over-chord correction of one step (kappa c ~ 1.1 rad). */
#define EF_INTERP_ARC_CORR_MAX 0.05f

/* A point finite and within EF_MAX_COORD on every axis. */
static int ip_vok(ef_vec3_t v)
{
    return ef_finitef(v.x) & ef_finitef(v.y) & ef_finitef(v.z) & (ef_fabsf(v.x) <= EF_MAX_COORD) &
           (ef_fabsf(v.y) <= EF_MAX_COORD) & (ef_fabsf(v.z) <= EF_MAX_COORD);
}

/* Start an empty interpolator at rest at home (contract in ef_interp.h). */
int ef_interp_init(ef_interp_t *ip, ef_vec3_t home, uint32_t period_us, int mode)
{
    if (!ip || period_us == 0u || (mode != EF_STEP_UNIFORM && mode != EF_STEP_CORRECTED))
        return EF_ERR_ARG;
    if (!ip_vok(home))
        return EF_ERR_NONFINITE;
    ip->head = ip->count = 0;
    ip->mode = mode;
    ip->period_us = period_us;
    ip->t = ip->tau = ip->s_done = 0.0f;
    ip->t_c = ip->s_c = 0.0f;
    ip->pos = ip->end = home;
    ip->v_end = 0.0f;
    ip->last_seq = ip->last_tag = 0;
    for (int k = 0; k < EF_AUX_N; k++)
        ip->apos[k] = ip->aend[k] = 0.0f;
    return EF_OK;
}

/* The auxiliary axes' position at rest (contract in ef_interp.h). */
int ef_interp_set_aux(ef_interp_t *ip, const float *aux)
{
    if (!ip || !aux || ip->count > 0)
        return EF_ERR_ARG;
    for (int k = 0; k < EF_AUX; k++)
        if (!ef_finitef(aux[k]) || !(ef_fabsf(aux[k]) <= EF_MAX_COORD))
            return EF_ERR_NONFINITE;
    for (int k = 0; k < EF_AUX; k++)
        ip->apos[k] = ip->aend[k] = aux[k];
    return EF_OK;
}

/* Free queue slots, so callers push only when there is room (see ef_interp.h). */
uint32_t ef_interp_space(const ef_interp_t *ip)
{
    return ip ? (uint32_t)EF_INTERP_QUEUE - ip->count : 0u;
}

/* A move the interpolator can execute after `start` (contract in ef_interp.h); shared with
 * the drive, which refuses a bad segment when it arrives rather than when it runs. */
int ef_interp_check(const ef_move_t *m, ef_vec3_t start)
{
    if (!m)
        return EF_ERR_ARG;
    if (m->degree != 1 && m->degree != 3 && m->degree != 5)
        return EF_ERR_ARG;
    int ok = ef_finitef(m->duration) & ef_finitef(m->length) & ef_finitef(m->v_exit);
    for (int i = 0; i <= m->degree; i++)
        ok &= ip_vok(m->b[i]);
    for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
        ok &= ef_finitef(m->law.dt[k]) & (m->law.dt[k] >= 0.0f);
        for (int i = 0; i < EF_TIMELAW_COEFFS; i++)
            ok &= ef_finitef(m->law.c[k][i]);
    }
    if (!ok || !(m->duration > 0.0f) || !(m->length > 0.0f) || !(m->v_exit >= 0.0f))
        return EF_ERR_ARG;
    ef_vec3_t gap = ef_v3_sub(m->b[0], start);
    if (!(ef_v3_dot(gap, gap) <= EF_INTERP_JOIN_TOL * EF_INTERP_JOIN_TOL))
        return EF_ERR_ARG;
    return EF_OK;
}

/* Power-basis coefficients of m's curve relative to b0, centred on t = 1/2:
 * f(t) - b0 = sum_k pc[k] (t - 1/2)^k, pc[k] = f^(k)(1/2) / k! (de Casteljau's derivatives,
 * once per move here in the background context, so a servo period is one Horner pass, see
 * ip_horner()). Centred because the coefficients at t = 0 (binomials times forward
 * differences) grow with the control polygon's roughness: evaluated at t near 1 their
 * rounding reached 2e-6 of the curve's size on rough quintics, where these stay below de
 * Casteljau's own (2.7e-7 against 4.2e-7, random quintics against a double reference). */
static void ip_power(const ef_move_t *m, ef_vec3_t pc[6])
{
    ef_vec3_t lb[6], d[6];
    int n = m->degree;
    for (int i = 0; i < 6; i++) {
        lb[i] = i <= n ? ef_v3_sub(m->b[i], m->b[0]) : ef_v3(0.0f, 0.0f, 0.0f);
        d[i] = pc[i] = ef_v3(0.0f, 0.0f, 0.0f);
    }
    (void)ef_bezier_eval(lb, n, 0.5f, n, d); /* n is 1, 3 or 5 (ef_interp_check) */
    float fact = 1.0f;
    for (int k = 0; k <= n && k < 6; k++) {
        fact *= (float)(k > 0 ? k : 1);
        pc[k] = ef_v3_scale(d[k], 1.0f / fact);
    }
}

/* ip_power() for the auxiliary axes that move (mask; the others are not evaluated:
 * ef_interp_t::amask), as scalars: de Casteljau's derivatives at 1/2. */
static void ip_power_aux(const ef_move_t *m, uint32_t mask, float apc[EF_AUX_N][6])
{
    int n = m->degree;
    for (int k = 0; k < EF_AUX; k++) {
        if (!((mask >> k) & 1u))
            continue;
        float w[6][6];
        for (int i = 0; i < 6; i++) {
            w[0][i] = i <= n ? m->ab[k][i] - m->ab[k][0] : 0.0f;
            apc[k][i] = 0.0f;
        }
        /* forward differences: the k-th derivative at 1/2 is n!/(n-j)! times the de
         * Casteljau value of the j-th differences */
        for (int j = 1; j <= n; j++)
            for (int i = 0; i + j <= n; i++)
                w[j][i] = w[j - 1][i + 1] - w[j - 1][i];
        float ff = 1.0f; /* n! / (n - j)! / j! */
        for (int j = 0; j <= n; j++) {
            float c[6];
            for (int i = 0; i + j <= n; i++)
                c[i] = w[j][i];
            for (int r = 1; r <= n - j; r++)
                for (int i = 0; i + r <= n - j; i++)
                    c[i] = 0.5f * (c[i] + c[i + 1]);
            apc[k][j] = ff * c[0];
            ff = ff * (float)(n - j) / (float)(j + 1);
        }
    }
}

/* Queue a planned move that joins the previous end (contract in ef_interp.h). */
int ef_interp_push(ef_interp_t *ip, const ef_move_t *m)
{
    if (!ip || !m)
        return EF_ERR_ARG;
    int rc = ef_interp_check(m, ip->end);
    if (rc != EF_OK)
        return rc;
    /* the auxiliary axes in one branch-free pass (this runs in the servo interrupt's
     * handoff): z turns NaN at a NaN or an infinity, big is the largest |value|, gap the
     * largest join, mask the axes that move */
    float z = 0.0f, big = 0.0f, gap = 0.0f;
    uint32_t mask = 0;
    int n = m->degree;
    for (int k = 0; k < EF_AUX; k++) {
        const float *c = m->ab[k];
        uint32_t mv = 0;
        for (int i = 0; i <= n; i++) {
            z += c[i] * 0.0f;
            big = ef_maxf(big, ef_fabsf(c[i]));
            mv |= (uint32_t)(c[i] != c[0]);
        }
        gap = ef_maxf(gap, ef_fabsf(c[0] - ip->aend[k]));
        mask |= mv << k;
    }
    if (!(z == 0.0f) || !(big <= EF_MAX_COORD) || !(gap <= EF_INTERP_JOIN_TOL))
        return EF_ERR_ARG;
    if (ip->count >= EF_INTERP_QUEUE)
        return EF_ERR_FULL;
    if (ip->count == 0) {
        ip->t = ip->tau = ip->s_done = 0.0f;
        ip->t_c = ip->s_c = 0.0f;
    }
    uint32_t slot = (ip->head + ip->count) % EF_INTERP_QUEUE;
    ip->q[slot] = *m;
    ip_power(m, ip->pc[slot]);
    ip->amask[slot] = (uint8_t)mask;
    if (mask)
        ip_power_aux(m, mask, ip->apc[slot]);
    ip->count++;
    ip->end = m->b[m->degree];
    for (int k = 0; k < EF_AUX; k++)
        ip->aend[k] = m->ab[k][m->degree];
    ip->v_end = m->v_exit;
    return EF_OK;
}

/* Compensated (Kahan) sum *sum += x: the running error *c is fed back, so adding many
 * small steps to a large total keeps full precision (the firmware is never built with
 * -ffast-math, which would undo it). */
static void ip_kahan(float *sum, float *c, float x)
{
    float y = x - *c;
    float t = *sum + y;
    *c = (t - *sum) - y;
    *sum = t;
}

/* The curve relative to b0 at t from its centred power-basis coefficients (ip_power()), and for
 * nder 1 or 2 its first / second derivative too (out[0..nder]): Horner's rule over all
 * six coefficients (those above the degree are zero, so every degree costs the same),
 * derivatives in the same pass. */
static void ip_horner(const ef_vec3_t pc[6], float t, int nder, ef_vec3_t *out)
{
    ef_vec3_t p = pc[5], d1 = ef_v3(0.0f, 0.0f, 0.0f), d2 = d1;
    t -= 0.5f;
    if (nder == 0) {
        for (int k = 4; k >= 0; k--)
            p = ef_v3_axpy(pc[k], t, p);
        out[0] = p;
        return;
    }
    for (int k = 4; k >= 0; k--) {
        d2 = ef_v3_axpy(d1, t, d2);
        d1 = ef_v3_axpy(p, t, d1);
        p = ef_v3_axpy(pc[k], t, p);
    }
    out[0] = p;
    out[1] = d1;
    if (nder > 1)
        out[2] = ef_v3_scale(d2, 2.0f);
}

/* Arc length of the curve between parameters a and b by 8-point Gauss-Legendre quadrature
 * of |f'| (exact to float rounding for the smooth speeds of degree <= 5 curves). */
static float ip_arc(const ef_vec3_t *pc, float a, float b)
{
    static const float gx[4] = {0.1834346425f, 0.5255324099f, 0.7966664774f,
                                0.9602898565f}; /* abscissae on [-1, 1] */
    static const float gw[4] = {0.1813418917f, 0.1568533229f, 0.1111905172f,
                                0.0506142681f}; /* weights / 2 */
    float span = b - a, mid = 0.5f * (a + b), sum = 0.0f;
    for (int k = 0; k < 4; k++) {
        ef_vec3_t e[2], f[2];
        ip_horner(pc, mid - 0.5f * span * gx[k], 1, e);
        ip_horner(pc, mid + 0.5f * span * gx[k], 1, f);
        sum += gw[k] * (ef_v3_norm(e[1]) + ef_v3_norm(f[1]));
    }
    return sum * span;
}

/** Position on the head move at time ip->t (uniform or corrected parameter step). */
static void ip_eval(ef_interp_t *ip, const ef_move_t *m, const ef_vec3_t *pc, float *v)
{
    float tau_law = 0.0f;
    ef_timelaw_eval(m, ip->t, &tau_law, v);
    /* The curve is evaluated relative to b0 and b0 added last: at the curve's own scale
     * float32 resolves one servo period's step far better than at machine coordinates,
     * where the evaluation's rounding (several ulps of ~100 mm) is a few per cent of a
     * slow 1 um step. The corrected step's chords need the same resolution. */
    ef_vec3_t d[3];
    if (ip->mode != EF_STEP_CORRECTED || !(m->length <= EF_INTERP_CORRECTED_MAX_LEN) ||
        (m->flags & EF_MOVE_AUX_ONLY)) {
        ip_horner(pc, tau_law, 0, d);
        ip->tau = tau_law;
        ip->pos = ef_v3_add(m->b[0], d[0]);
        return;
    }
    /* One step on arc length: S (the arc reached so far, from the chords of the steps)
     * towards s(t) = L tau_law. */
    ip_horner(pc, ip->tau, 2, d); /* a line's f'' is exactly zero */
    float s = tau_law * m->length;
    float gap = s - ip->s_done;
    float law_ds = *v * (float)ip->period_us * 1e-6f; /* the law's distance per period */
    if (gap > ef_maxf(EF_INTERP_RESYNC * m->length, 4.0f * law_ds) && tau_law > ip->tau) {
        /* Far behind (a late call, or a move entered part-way through): find the parameter
         * whose arc length is s by EF_INTERP_RESYNC_ITER Newton steps from the law's, the
         * arc from here measured by quadrature each time (chords would understate a long
         * span, one linear step misses on an uneven curve), so S stays a true arc length. */
        float t0 = ip->tau, s0 = ip->s_done, tn = tau_law, arc = 0.0f;
        for (int it = 0; it < EF_INTERP_RESYNC_ITER; it++) {
            arc = ip_arc(pc, t0, tn);
            ef_vec3_t e[2];
            ip_horner(pc, tn, 1, e);
            float sp0 = ef_v3_norm(e[1]);
            float next = tn;
            if (sp0 > EF_INTERP_MIN_DERIV)
                next = tn + (s - s0 - arc) / sp0;
            tn = ef_finitef(next) ? ef_maxf(t0, ef_minf(1.0f, next)) : tn;
        }
        arc = ip_arc(pc, t0, tn);
        ip_kahan(&ip->s_done, &ip->s_c, arc);
        ef_vec3_t q0;
        ip_horner(pc, tn, 0, &q0);
        ip->tau = tn;
        ip->pos = ef_v3_add(m->b[0], q0);
        return;
    }
    /* Second-order step: along the curve |f'| changes at k = <f', f''> / |f'| per unit of
     * parameter, so the arc from tau is about sp h + k h^2 / 2; h solves that for the gap
     * (the root continuous in k; a plain Newton step h = gap / sp where the quadratic has
     * no root). At a move's start where |f'| is a small share of L and rising fast (a blend
     * with x1 at the table's bound) the Newton step alone overshot by up to half a period's
     * distance and, never stepping back, left a speed jump at the junction (issue 18).
     * A chord c of a curve with curvature kappa is shorter than its arc by about
     * c (kappa c)^2 / 24: summed over a tight blend's steps that is tens of nanometres
     * (kappa 45 / mm, 3.4 um steps), which the setpoint gave back as a jump at the move's
     * end. So S adds arc(c) = c (1 + kk c^2), kk = kappa^2 / 24 at tau (the correction
     * capped at EF_INTERP_ARC_CORR_MAX, where the series holds: kappa c up to about 1). */
    float sp = ef_v3_norm(d[1]);
    float tn = tau_law, kk = 0.0f;
    if (sp > EF_INTERP_MIN_DERIV) {
        float k = ef_v3_dot(d[1], d[2]) / sp;
        float disc = sp * sp + 2.0f * k * gap;
        float h = gap / sp;
        if (gap > 0.0f && disc > 0.0f)
            h = 2.0f * gap / (sp + ef_sqrtf(disc));
        tn = ip->tau + h;
        ef_vec3_t cr = ef_v3_cross(d[1], d[2]);
        float isp2 = 1.0f / (sp * sp);
        kk = ef_v3_dot(cr, cr) * isp2 * isp2 * isp2 * (1.0f / 24.0f);
        if (!ef_finitef(kk))
            kk = 0.0f;
    }
    if (!ef_finitef(tn))
        tn = tau_law;
    /* Never step back; never more than the larger of EF_INTERP_RESYNC of the curve and
     * EF_INTERP_STEP_CAP times the law's own step per servo period (where |f'| is near 0 a
     * step would run away; a fixed cap alone would hold back a short curve that slows
     * parametrically). */
    float law_step = law_ds / ef_maxf(m->length, 1e-30f);
    float cap = ef_maxf(EF_INTERP_RESYNC, EF_INTERP_STEP_CAP * law_step);
    float hi = ef_minf(1.0f, ip->tau + cap);
    tn = ef_maxf(ip->tau, ef_minf(hi, tn));
    ef_vec3_t p[1];
    ip_horner(pc, tn, 0, p);
    float chord = ef_v3_norm(ef_v3_sub(p[0], d[0]));
    float arc = chord * (1.0f + ef_minf(EF_INTERP_ARC_CORR_MAX, kk * chord * chord));
    /* One secant correction on the arc actually covered: the step scaled by gap / arc takes
     * out what the quadratic model missed (f''' on a quintic), for one more evaluation.
     * That is a correction of a few per cent (half a step where the Newton step overshot at
     * a blend's start), so the factor is held to [1/2, 2]: a chord at the resolution of the
     * coordinates (a fuzzed arc at 0.9 um/s: 0.9 nm per period, 1.7 mm from b0, where
     * float32 resolves 0.12 nm) may round to a fraction of its length, and gap / arc then
     * threw tau 140 periods ahead: a 0.13 um jump, then a 140 ms stand. */
    if (gap > 0.0f && arc > 0.0f && tn > ip->tau) {
        float ratio = ef_maxf(EF_INTERP_SECANT_MIN, ef_minf(EF_INTERP_SECANT_MAX, gap / arc));
        float t2 = ip->tau + (tn - ip->tau) * ratio;
        t2 = ef_maxf(ip->tau, ef_minf(hi, t2));
        if (ef_finitef(t2) && t2 != tn) {
            tn = t2;
            ip_horner(pc, tn, 0, p);
            chord = ef_v3_norm(ef_v3_sub(p[0], d[0]));
            arc = chord * (1.0f + ef_minf(EF_INTERP_ARC_CORR_MAX, kk * chord * chord));
        }
    }
    ip_kahan(&ip->s_done, &ip->s_c, arc);
    ip->tau = tn;
    ip->pos = ef_v3_add(m->b[0], p[0]);
}

/* Advance by dt_us and give the next setpoint (contract in ef_interp.h). */
int ef_interp_process(ef_interp_t *ip, uint32_t dt_us, uint32_t *next_us, ef_setpoint_t *sp)
{
    return ef_interp_process_rate(ip, dt_us, 1.0f, next_us, sp);
}

/* Advance the moves' time by rate * dt_us (contract in ef_interp.h). */
int ef_interp_process_rate(ef_interp_t *ip, uint32_t dt_us, float rate, uint32_t *next_us,
                           ef_setpoint_t *sp)
{
    if (!ip || !sp)
        return EF_ERR_ARG;
    if (next_us)
        *next_us = ip->period_us;
    rate = rate >= 0.0f ? ef_minf(rate, 1.0f) : 0.0f; /* NaN fails the test: 0 */
    int rc = EF_OK;
    float v = 0.0f;
    if (ip->count > 0) {
        ip_kahan(&ip->t, &ip->t_c, (float)dt_us * 1e-6f * rate);
        /* Finish every move the elapsed time covers; the leftover carries into the next. */
        for (uint32_t i = 0; i < EF_INTERP_QUEUE && ip->count > 0; i++) {
            const ef_move_t *m = &ip->q[ip->head];
            if (ip->t < m->duration)
                break;
            ip_kahan(&ip->t, &ip->t_c, -m->duration);
            ip->pos = m->b[m->degree];
            for (uint32_t am = ip->amask[ip->head], k = 0; am >> k; k++)
                if ((am >> k) & 1u)
                    ip->apos[k] = m->ab[k][m->degree];
            ip->last_seq = m->seq;
            ip->last_tag = m->tag;
            ip->tau = ip->s_done = 0.0f;
            ip->s_c = 0.0f;
            ip->head = (ip->head + 1u) % EF_INTERP_QUEUE;
            ip->count--;
        }
        if (ip->count > 0) {
            const ef_move_t *m = &ip->q[ip->head];
            ip_eval(ip, m, ip->pc[ip->head], &v);
            /* the auxiliary axes that move on it, at the parameter the step reached (either
             * mode); the others stay where they are */
            uint32_t am = ip->amask[ip->head];
            float u = ip->tau - 0.5f;
            for (int k = 0; k < EF_AUX && am; k++) {
                if (!((am >> k) & 1u))
                    continue;
                const float *c = ip->apc[ip->head][k];
                float a = c[5];
                for (int j = 4; j >= 0; j--)
                    a = c[j] + u * a;
                ip->apos[k] = m->ab[k][0] + a;
            }
            __builtin_memcpy(sp->aux, ip->apos, sizeof sp->aux); /* a few word moves */
            sp->p = ip->pos;
            sp->v_plan = v;
            sp->seq = m->seq;
            sp->tag = m->tag;
            sp->moving = 1;
            return EF_OK;
        }
        ip->t = ip->t_c = 0.0f;
        ip->pos = ip->end;
        for (int k = 0; k < EF_AUX; k++)
            ip->apos[k] = ip->aend[k];
    }
    if (ip->v_end > 0.0f)
        rc = EF_ERR_UNDERRUN; /* ran dry while moving: hold the end position */
    sp->p = ip->pos;
    __builtin_memcpy(sp->aux, ip->apos, sizeof sp->aux);
    sp->v_plan = 0.0f;
    sp->seq = ip->last_seq;
    sp->tag = ip->last_tag;
    sp->moving = 0;
    return rc;
}
