/* SPDX-License-Identifier: Apache-2.0 */
/* Feed planner: per-move limits, backward/forward passes over the look-ahead window, and
 * the time law of each released move (see ef_plan.h and ef_path.h).
 *
 * The backward-pass bounds are kept up to date incrementally by each push (from the newest
 * move back, stopping at the first unchanged bound), so a pull only runs the forward step and
 * the time law of the oldest move. Without a jerk limit every ramp inversion is closed-form
 * (plus a fixed few-ulp correction); with one it is a bisection with a fixed iteration count
 * (EF_PLAN_BISECT). Worst case: a push O(EF_LOOKAHEAD) inversions, a pull O(1). */
#include "evenfeed/motion/ef_plan.h"
#include "evenfeed/core/ef_err.h"

/** Bisection steps for every speed search (float32 has 24 mantissa bits). */
#define EF_PLAN_BISECT 32

/** Smallest largest-|tangent component| a move may report (every unit vector has one
 *  component >= 1/sqrt(3)); below it the tabs data is inconsistent. */
#define EF_PLAN_TABS_MIN 0.5f

/** A ramp whose speed change is below this fraction of the cruise speed is dropped (its
 *  coefficients would only carry rounding noise). */
#define EF_PLAN_DV_REL 1e-6f

/* A point finite and within EF_MAX_COORD on every axis. */
static int pl_vfinite(ef_vec3_t v)
{
    return ef_finitef(v.x) & ef_finitef(v.y) & ef_finitef(v.z) & (ef_fabsf(v.x) <= EF_MAX_COORD) &
           (ef_fabsf(v.y) <= EF_MAX_COORD) & (ef_fabsf(v.z) <= EF_MAX_COORD);
}

/* Validate machine limits (contract in ef_plan.h). */
int ef_limits_check(const ef_limits_t *lim)
{
    if (!lim)
        return EF_ERR_ARG;
    int fin = ef_finitef(lim->j_max) & ef_finitef(lim->a_normal_frac);
    for (int i = 0; i < 3; i++)
        fin &= ef_finitef(lim->v_axis[i]) & ef_finitef(lim->a_axis[i]);
    if (!fin)
        return EF_ERR_NONFINITE;
    if (!(lim->a_normal_frac > 0.0f && lim->a_normal_frac < 1.0f))
        return EF_ERR_ARG;
    for (int i = 0; i < 3; i++)
        if (!(lim->v_axis[i] > 0.0f) || !(lim->a_axis[i] > 0.0f))
            return EF_ERR_FEED;
    if (!(lim->j_max >= 0.0f))
        return EF_ERR_FEED;
    return EF_OK;
}

/* ---------------------------------------------------------------- ramp geometry */

/** Duration of a ramp changing the speed by dv >= 0. */
static float pl_ramp_time(float dv, float a, float j)
{
    float t = dv / a;
    if (j > 0.0f)
        t = ef_maxf(1.5f * t, ef_sqrtf(6.0f * dv / j));
    return t;
}

/** Distance of a ramp from va to vb (either direction). */
static float pl_ramp_dist(float va, float vb, float a, float j)
{
    return 0.5f * (va + vb) * pl_ramp_time(ef_fabsf(vb - va), a, j);
}

/** Largest distance a ramp from v0 down to any speed in [e, v0] needs. With a jerk limit the
 * ramp distance is not monotone in the target: (v0 + v) sqrt(6 (v0 - v) / J) peaks at
 * v = v0 / 3, so slowing to v0 / 3 can take longer than stopping. The backward pass bounds
 * entries with this, so that a later rise of the exit bound (more moves pushed) never makes
 * a committed entry speed unable to reach it. */
static float pl_ramp_dist_down(float v0, float e, float a, float j)
{
    float d = pl_ramp_dist(v0, e, a, j);
    if (j > 0.0f && v0 > e) {
        float v = ef_maxf(e, v0 * (1.0f / 3.0f));
        d = ef_maxf(d, 0.5f * (v0 + v) * ef_sqrtf(6.0f * (v0 - v) / j));
    }
    return d;
}

/** Steps of the closed-form answers' downward correction (a few ulps at most). */
#define EF_PLAN_ULP_STEPS 4

/** Lower a closed-form speed by about one ulp per step (fixed count) until `fits`; returns
 *  the first fitting value, or a negative value when none of the steps fits. */
#define EF_PLAN_ULP_DOWN(v, fits)                                                                  \
    do {                                                                                           \
        int ef_k_ = 0;                                                                             \
        for (; ef_k_ < EF_PLAN_ULP_STEPS && !(fits); ef_k_++)                                      \
            (v) -= (v)*1.2e-7f;                                                                    \
        if (ef_k_ == EF_PLAN_ULP_STEPS && !(fits))                                                 \
            (v) = -1.0f;                                                                           \
    } while (0)

/** Largest v >= vf such that a ramp between v and vf fits in len (either direction: the
 *  distance is symmetric); with `down`, every ramp from v to a speed in [vf, v] must fit
 *  (pl_ramp_dist_down()). The returned value always satisfies the condition. Without a jerk
 *  limit the answer is closed-form, sqrt(vf^2 + 2 a len), lowered by a few ulps if rounding
 *  puts it just beyond len; the bisection is only the fallback for that case and the
 *  search with a jerk limit. */
static float pl_ramp_top(float vf, float len, float a, float j, int down)
{
    float lo = vf;
    float hi = ef_sqrtf(vf * vf + 2.0f * a * len); /* no-jerk bound, >= the jerk answer */
    float d = down ? pl_ramp_dist_down(hi, vf, a, j) : pl_ramp_dist(hi, vf, a, j);
    if (d <= len)
        return hi;
    if (!(j > 0.0f)) {
        float v = hi;
        EF_PLAN_ULP_DOWN(v, v >= vf && pl_ramp_dist(v, vf, a, 0.0f) <= len);
        if (v >= vf)
            return v;
    }
    for (int i = 0; i < EF_PLAN_BISECT; i++) {
        float mid = 0.5f * (lo + hi);
        d = down ? pl_ramp_dist_down(mid, vf, a, j) : pl_ramp_dist(mid, vf, a, j);
        if (d <= len)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/** A v in [0, v0] such that a ramp from v0 down to v fits in len: 0 when stopping fits,
 *  else the upper end of a bisection bracket (always a fitting speed; the smallest one when
 *  the distance is monotone, see pl_ramp_dist_down()). Only reached for entry/exit pairs
 *  the passes did not produce. */
static float pl_ramp_bottom(float v0, float len, float a, float j)
{
    float lo = 0.0f, hi = v0;
    if (pl_ramp_dist(v0, 0.0f, a, j) <= len)
        return 0.0f;
    for (int i = 0; i < EF_PLAN_BISECT; i++) {
        float mid = 0.5f * (lo + hi);
        if (pl_ramp_dist(v0, mid, a, j) <= len)
            hi = mid;
        else
            lo = mid;
    }
    return hi;
}

/* ---------------------------------------------------------------- time law */

/** Fill phase k as a ramp from va to vb lasting T, starting at distance s0. */
static void pl_law_ramp(ef_timelaw_t *law, int k, float va, float vb, float T, float s0, float len,
                        float j)
{
    float *c = law->c[k];
    c[0] = s0 / len;
    c[1] = va / len;
    c[2] = c[3] = c[4] = 0.0f;
    law->dt[k] = T;
    if (!(T > 0.0f))
        return;
    float dv = vb - va;
    if (j > 0.0f) {
        /* v = va + dv (3 r^2 - 2 r^3): s = va u + dv (u^3 / T^2 - u^4 / (2 T^3)) */
        float iT2 = 1.0f / (T * T);
        c[3] = dv * iT2 / len;
        c[4] = -0.5f * dv * iT2 / (T * len);
    } else {
        c[2] = 0.5f * (dv / T) / len;
    }
}

/** ef_plan_timelaw() with, when up >= 0, pl_ramp_top(v_entry, length, a_max, j_max, 0)
 *  already known (the pull computes it for the exit). */
static int pl_timelaw_up(ef_move_t *m, float j_max, float up)
{
    float len = m->length, v0 = m->v_entry, v1 = m->v_exit, vmax = m->v_max, a = m->a_max;
    int fin = ef_finitef(len) & ef_finitef(v0) & ef_finitef(v1) & ef_finitef(vmax) & ef_finitef(a) &
              ef_finitef(j_max);
    if (!fin || !(len >= EF_MIN_CHORD) || !(v0 >= 0.0f) || !(v1 >= 0.0f) || !(vmax > 0.0f) ||
        !(a > 0.0f) || !(j_max >= 0.0f))
        return EF_ERR_ARG;
    float j = j_max;

    /* Exit reachable from the entry within the length (rounding-level fixes only when the
     * passes planned it). */
    if (v1 > v0) {
        if (!(up >= 0.0f))
            up = pl_ramp_top(v0, len, a, j, 0);
        v1 = ef_minf(v1, up);
    } else if (v1 < v0 && pl_ramp_dist(v0, v1, a, j) > len) {
        v1 = pl_ramp_bottom(v0, len, a, j);
    }
    float vtop = ef_maxf(vmax, ef_maxf(v0, v1));

    /* Cruise speed: vtop if the two ramps fit, else the largest that does (bisection). */
    float vc = vtop;
    if (pl_ramp_dist(v0, vtop, a, j) + pl_ramp_dist(vtop, v1, a, j) > len) {
        float lo = ef_maxf(v0, v1), hi = vtop;
        if (!(j > 0.0f)) {
            /* (2 vc^2 - v0^2 - v1^2) / (2 a) = len, within [lo, vtop] */
            float v = ef_minf(vtop, ef_sqrtf(0.5f * (v0 * v0 + v1 * v1) + a * len));
            EF_PLAN_ULP_DOWN(
                v, v >= lo && pl_ramp_dist(v0, v, a, 0.0f) + pl_ramp_dist(v, v1, a, 0.0f) <= len);
            if (v >= lo)
                lo = hi = v;
        }
        for (int i = 0; i < EF_PLAN_BISECT && lo < hi; i++) {
            float mid = 0.5f * (lo + hi);
            if (pl_ramp_dist(v0, mid, a, j) + pl_ramp_dist(mid, v1, a, j) <= len)
                lo = mid;
            else
                hi = mid;
        }
        vc = lo;
    }

    /* Ramps: drop those whose speed change is rounding noise. The exit stays exact (the
     * next move's entry and an exact stop rely on it): a cruise within noise of the exit
     * becomes the exit speed; a dropped entry ramp leaves the law starting at vc, within
     * EF_PLAN_DV_REL of v_entry. */
    float eps = EF_PLAN_DV_REL * vc;
    if (vc - v1 <= eps)
        vc = v1;
    float T0 = 0.0f, T2 = 0.0f, d0 = 0.0f, d2 = 0.0f;
    if (ef_fabsf(vc - v0) > eps) {
        T0 = pl_ramp_time(ef_fabsf(vc - v0), a, j);
        d0 = 0.5f * (v0 + vc) * T0;
    }
    if (vc - v1 > eps) {
        T2 = pl_ramp_time(vc - v1, a, j);
        d2 = 0.5f * (vc + v1) * T2;
    }
    float dc = len - d0 - d2;
    if (dc < 0.0f)
        dc = 0.0f;
    float Tc = 0.0f;
    if (dc > 0.0f && vc > 0.0f)
        Tc = dc / vc;

    ef_timelaw_t law;
    pl_law_ramp(&law, 0, T0 > 0.0f ? v0 : vc, vc, T0, 0.0f, len, j);
    law.dt[1] = Tc;
    law.c[1][0] = d0 / len;
    law.c[1][1] = vc / len;
    law.c[1][2] = law.c[1][3] = law.c[1][4] = 0.0f;
    pl_law_ramp(&law, 2, vc, v1, T2, d0 + dc, len, j);

    float dur = T0 + Tc + T2;
    int ok = ef_finitef(dur) & (dur > 0.0f);
    for (int k = 0; k < EF_TIMELAW_PHASES; k++)
        for (int i = 0; i < 5; i++)
            ok &= ef_finitef(law.c[k][i]);
    if (!ok)
        return EF_ERR_ARG;
    m->law = law;
    m->duration = dur;
    m->v_exit = v1;
    return EF_OK;
}

/* Time law of a move from its entry/exit speeds (contract in ef_plan.h). */
int ef_plan_timelaw(ef_move_t *m, float j_max)
{
    if (!m)
        return EF_ERR_ARG;
    return pl_timelaw_up(m, j_max, -1.0f);
}

/* Curve parameter and path speed at time t of a move (contract in ef_path.h). */
int ef_timelaw_eval(const ef_move_t *m, float t, float *tau, float *v)
{
    if (!m || !tau)
        return EF_ERR_ARG;
    const ef_timelaw_t *law = &m->law;
    int done = !(t < m->duration); /* NaN t counts as the end */
    float u = t > 0.0f ? t : 0.0f;
    int k = 0;
    for (; k < EF_TIMELAW_PHASES - 1; k++) {
        if (u <= law->dt[k])
            break;
        u -= law->dt[k];
    }
    if (u > law->dt[k] || done)
        u = law->dt[k];
    if (!(u >= 0.0f))
        u = 0.0f;
    const float *c = law->c[k];
    float x = c[0] + u * (c[1] + u * (c[2] + u * (c[3] + u * c[4])));
    x = ef_maxf(0.0f, ef_minf(1.0f, x));
    if (done)
        x = 1.0f;
    if (!(x == x))
        x = 0.0f;
    *tau = x;
    if (v) {
        float d = c[1] + u * (2.0f * c[2] + u * (3.0f * c[3] + u * 4.0f * c[4]));
        float s = d * m->length;
        *v = s > 0.0f ? s : 0.0f; /* also maps NaN to 0 */
    }
    return EF_OK;
}

/* ---------------------------------------------------------------- planner */

/** Backward-pass bound of the move at window position n (0 = oldest) given the bound on the
 *  entry of the move after it (0 for the newest, which is assumed to end at rest): the
 *  largest entry speed from which every later move can still be followed and the newest
 *  stopped at its end. */
static float pl_bound(const ef_plan_t *p, uint32_t n, float v_next)
{
    const ef_move_t *q = &p->q[(p->head + n) % EF_LOOKAHEAD];
    if (n > 0 && (p->q[(p->head + n - 1u) % EF_LOOKAHEAD].flags & EF_MOVE_STOP_END))
        return 0.0f;
    float exit_b = (q->flags & EF_MOVE_STOP_END) ? 0.0f : v_next;
    float v = ef_minf(q->v_max, pl_ramp_top(exit_b, q->length, q->a_max, p->lim.j_max, 1));
    if (n > 0)
        v = ef_minf(v, p->q[(p->head + n - 1u) % EF_LOOKAHEAD].v_max);
    return v;
}

/** Incremental backward pass after a push: the newest move's bound, then the earlier ones
 *  while they change. A bound depends only on its move, the move before it and the next
 *  bound, so an unchanged bound leaves every earlier one unchanged: v_lim always equals a
 *  from-scratch pass over the window (the oldest move's bound is never read, so releasing
 *  it changes nothing). At most count bound computations. */
static void pl_backward(ef_plan_t *p)
{
    uint32_t n = p->count - 1u;
    float v = pl_bound(p, n, 0.0f);
    p->v_lim[(p->head + n) % EF_LOOKAHEAD] = v;
    while (n-- > 0) {
        uint32_t idx = (p->head + n) % EF_LOOKAHEAD;
        if (p->q[idx].flags & EF_MOVE_STOP_END)
            break; /* exit bound 0 whatever follows */
        float w = pl_bound(p, n, v);
        if (w == p->v_lim[idx])
            break;
        p->v_lim[idx] = w;
        v = w;
    }
}

/* Start an empty planner with checked limits (contract in ef_plan.h). */
int ef_plan_init(ef_plan_t *p, const ef_limits_t *lim)
{
    if (!p)
        return EF_ERR_ARG;
    int rc = ef_limits_check(lim);
    if (rc != EF_OK)
        return rc;
    p->lim = *lim;
    p->head = p->count = p->nstops = p->seq = 0;
    p->v_last = 0.0f;
    p->finished = 0;
    for (uint32_t i = 0; i < EF_LOOKAHEAD; i++)
        p->v_lim[i] = 0.0f;
    return EF_OK;
}

/* Free look-ahead slots, so callers push only when there is room (see ef_plan.h). */
uint32_t ef_plan_space(const ef_plan_t *p)
{
    return p ? (uint32_t)EF_LOOKAHEAD - p->count : 0u;
}

/* Queue a move with its speed/acceleration limits, update bounds (see ef_plan.h). */
int ef_plan_push(ef_plan_t *p, const ef_move_t *m)
{
    if (!p || !m)
        return EF_ERR_ARG;
    if (m->degree != 1 && m->degree != 3 && m->degree != 5)
        return EF_ERR_ARG;
    int fin = ef_finitef(m->length) & ef_finitef(m->kappa_max) & ef_finitef(m->feed) &
              pl_vfinite(m->tabs);
    for (int i = 0; i <= m->degree; i++)
        fin &= pl_vfinite(m->b[i]);
    if (!fin)
        return EF_ERR_NONFINITE;
    if (!(m->length >= EF_MIN_CHORD) || !(m->kappa_max >= 0.0f) || !(m->tabs.x >= 0.0f) ||
        !(m->tabs.y >= 0.0f) || !(m->tabs.z >= 0.0f) ||
        !(ef_maxf(m->tabs.x, ef_maxf(m->tabs.y, m->tabs.z)) >= EF_PLAN_TABS_MIN))
        return EF_ERR_ARG;
    if (!(m->feed > 0.0f))
        return EF_ERR_FEED;
    if (p->count >= EF_LOOKAHEAD)
        return EF_ERR_FULL;

    /* Limits (ef_plan.h): axis speeds and accelerations through tabs, centripetal share. */
    const ef_limits_t *l = &p->lim;
    float tabs[3] = {m->tabs.x, m->tabs.y, m->tabs.z};
    float vmax = m->feed, apath = 0.0f;
    int have_a = 0;
    for (int i = 0; i < 3; i++) {
        if (tabs[i] > 0.0f) {
            vmax = ef_minf(vmax, l->v_axis[i] / tabs[i]);
            float ai = l->a_axis[i] / tabs[i];
            apath = have_a ? ef_minf(apath, ai) : ai;
            have_a = 1;
        }
    }
    float an = l->a_normal_frac * apath;
    if (m->kappa_max > 0.0f)
        vmax = ef_minf(vmax, ef_sqrtf(an / m->kappa_max));
    float amax = (1.0f - l->a_normal_frac) * apath;
    if (!(vmax > 0.0f) || !(amax > 0.0f) || !ef_finitef(vmax) || !ef_finitef(amax))
        return EF_ERR_FEED;

    uint32_t idx = (p->head + p->count) % EF_LOOKAHEAD;
    ef_move_t *q = &p->q[idx];
    *q = *m;
    q->flags = (uint16_t)(m->flags & (EF_MOVE_STOP_END | EF_MOVE_CLAMPED | EF_MOVE_BLEND_CLAMPED));
    q->seq = p->seq++;
    q->v_max = vmax;
    q->a_max = amax;
    q->v_entry = q->v_exit = 0.0f;
    q->duration = 0.0f;
    for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
        q->law.dt[k] = 0.0f;
        for (int i = 0; i < 5; i++)
            q->law.c[k][i] = 0.0f;
    }
    p->v_lim[idx] = 0.0f;
    p->count++;
    if (q->flags & EF_MOVE_STOP_END)
        p->nstops++;
    p->finished = 0;
    pl_backward(p);
    return EF_OK;
}

/* Mark the end of the program: the last move stops, all can drain (see ef_plan.h). */
int ef_plan_finish(ef_plan_t *p)
{
    if (!p)
        return EF_ERR_ARG;
    if (p->count > 0) {
        ef_move_t *last = &p->q[(p->head + p->count - 1u) % EF_LOOKAHEAD];
        if (!(last->flags & EF_MOVE_STOP_END)) {
            last->flags |= EF_MOVE_STOP_END;
            p->nstops++;
        }
    }
    p->finished = 1;
    return EF_OK;
}

/* Release the oldest move with its final speeds and time law (see ef_plan.h). */
int ef_plan_pull(ef_plan_t *p, ef_move_t *out)
{
    if (!p || !out)
        return EF_ERR_ARG;
    if (p->count == 0 || !(p->count >= EF_LOOKAHEAD || p->nstops > 0 || p->finished))
        return EF_ERR_AGAIN;

    ef_move_t m = p->q[p->head];
    /* Forward pass for the head: entry committed, exit what the entry can reach within the
     * move and what the rest of the window allows. */
    float exit_b = 0.0f;
    if (!(m.flags & EF_MOVE_STOP_END) && p->count > 1)
        exit_b = p->v_lim[(p->head + 1u) % EF_LOOKAHEAD];
    float v0 = p->v_last;
    float up = pl_ramp_top(v0, m.length, m.a_max, p->lim.j_max, 0);
    float v1 = ef_minf(exit_b, up);
    m.v_entry = v0;
    m.v_exit = ef_minf(v1, m.v_max);
    int rc = pl_timelaw_up(&m, p->lim.j_max, up);
    if (rc != EF_OK)
        return rc; /* not reachable for data push accepted; state unchanged */
    if (m.flags & EF_MOVE_STOP_END) {
        m.v_exit = 0.0f; /* exact: the ramp ends at rest (dropped ramps only for vc ~ 0) */
        p->nstops--;
    }
    p->v_last = m.v_exit;
    p->head = (p->head + 1u) % EF_LOOKAHEAD;
    p->count--;
    *out = m;
    return EF_OK;
}
