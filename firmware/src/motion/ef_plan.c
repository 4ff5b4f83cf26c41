/* SPDX-License-Identifier: Apache-2.0 */
/* Feed planner: per-move limits, backward/forward passes over the look-ahead window, and
 * the time law of each released move (see ef_plan.h and ef_path.h).
 *
 * The backward-pass bounds are kept up to date incrementally by each push (from the newest
 * move back, stopping at the first unchanged bound), so a pull only runs the forward step and
 * the time law of the oldest move. Every ramp inversion is closed-form (plus a fixed few-ulp
 * correction): without a jerk limit a square root; with one a quadratic (trapezoidal
 * acceleration) or a monotone cubic solved by fixed Newton steps (triangular), bisection
 * (EF_PLAN_BISECT) only as the fallback. Worst case: a push O(EF_LOOKAHEAD) inversions, a
 * pull O(1) plus the push of a staged move it hands over. */
#include "evenfeed/motion/ef_plan.h"
#include "evenfeed/core/ef_err.h"

/** The ramp helpers inside the cruise-speed bisection of a pull's time law (64 calls): at
 *  -Os gcc kept them out of line, and the calls alone put the worst M4 pull at 5.5 k. */
#ifdef __GNUC__
#define EF_PL_INLINE static inline __attribute__((always_inline))
#else
#define EF_PL_INLINE static inline
#endif

/** Bisection steps for every speed search (float32 has 24 mantissa bits). */
#define EF_PLAN_BISECT 32
/** Safeguarded Newton steps where a released group's law reaches a member's end
 *  (pl_law_cross()), before bisection takes over, and the relative step below which a
 *  Newton iterate counts as converged (two ulps of u). */
#define EF_PLAN_CROSS_ITER 8
#define EF_PLAN_CROSS_TOL  2.4e-7f
/** ... and the distance from the target, relative to it, that counts as found (an ulp). */
#define EF_PLAN_CROSS_FTOL 1.2e-7f
/** Newton steps of the triangular ramp's cubic (pl_cubic_rise()). */
#define EF_PLAN_CUBIC_NEWTON 6

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

/* All three components finite (curvature and jerk bounds grow without bound as a curve
 * shrinks: no coordinate range applies). */
static int pl_v3ok(ef_vec3_t v)
{
    return ef_finitef(v.x) & ef_finitef(v.y) & ef_finitef(v.z);
}

/* Validate machine limits (contract in ef_plan.h). */
int ef_limits_check(const ef_limits_t *lim)
{
    if (!lim)
        return EF_ERR_ARG;
    int fin = ef_finitef(lim->j_max) & ef_finitef(lim->a_normal_frac);
    for (int i = 0; i < EF_AXES; i++)
        fin &= ef_finitef(lim->v_axis[i]) & ef_finitef(lim->a_axis[i]);
    for (int k = 0; k < EF_AUX; k++)
        fin &= ef_finitef(lim->j_aux[k]);
    if (!fin)
        return EF_ERR_NONFINITE;
    if (!(lim->a_normal_frac > 0.0f && lim->a_normal_frac < 1.0f))
        return EF_ERR_ARG;
    for (int i = 0; i < 3; i++)
        if (!(lim->v_axis[i] > 0.0f) || !(lim->a_axis[i] > 0.0f))
            return EF_ERR_FEED;
    for (int i = 3; i < EF_AXES; i++)
        if (!(lim->v_axis[i] >= 0.0f) || !(lim->a_axis[i] >= 0.0f) ||
            ((lim->v_axis[i] > 0.0f) != (lim->a_axis[i] > 0.0f)))
            return EF_ERR_FEED;
    for (int k = 0; k < EF_AUX; k++)
        if (!(lim->j_aux[k] >= 0.0f))
            return EF_ERR_FEED;
    if (!(lim->j_max >= 0.0f))
        return EF_ERR_FEED;
    return EF_OK;
}

/* ---------------------------------------------------------------- ramp geometry */

/** Duration of a ramp changing the speed by dv >= 0 at acceleration limit a and jerk limit j
 *  (0: none). With a jerk limit it is the time-optimal S-curve from and to zero
 *  acceleration: dv / a + a / j when the speed change reaches a (dv >= a^2 / j), else
 *  2 sqrt(dv / j) (a triangular acceleration peaking at sqrt(dv j) < a). */
EF_PL_INLINE float pl_ramp_time(float dv, float a, float j)
{
    if (!(j > 0.0f))
        return dv / a;
    if (dv >= a * a / j)
        return dv / a + a / j;
    return 2.0f * ef_sqrtf(dv / j);
}

/** Distance of a ramp from va to vb (either direction): the S-curve's speed is point
 *  symmetric about its midpoint, so the mean speed is (va + vb) / 2. */
EF_PL_INLINE float pl_ramp_dist(float va, float vb, float a, float j)
{
    return 0.5f * (va + vb) * pl_ramp_time(ef_fabsf(vb - va), a, j);
}

/** Largest distance a ramp from v0 down to any speed in [e, v0] needs. With a jerk limit the
 *  ramp distance d(v) = (v0 + v) T(v0 - v) / 2 is not monotone in the target: it is concave
 *  (C1 across dv = a^2 / j, concave on both sides) with its peak at v0 / 3 when
 *  v0 <= 1.5 a^2 / j, else at a^2 / (2 j); so slowing to there can take longer than
 *  stopping. The backward pass bounds entries with this, so that a later rise of the exit
 *  bound (more moves pushed) never makes a committed entry speed unable to reach it. */
static float pl_ramp_dist_down(float v0, float e, float a, float j)
{
    if (!(j > 0.0f) || !(v0 > e))
        return pl_ramp_dist(v0, e, a, j);
    float a2j = a * a / j;
    float peak = v0 >= 1.5f * a2j ? 0.5f * a2j : v0 * (1.0f / 3.0f);
    float v = ef_minf(v0, ef_maxf(e, peak));
    return ef_maxf(pl_ramp_dist(v0, e, a, j), pl_ramp_dist(v0, v, a, j));
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

/** The x >= 0 with x (x + c)^2 = q (c, q >= 0): the rise of a triangular-acceleration ramp
 *  from speed c / 2 over distance sqrt(q / j). x (x + c)^2 rises and is convex for x >= 0,
 *  so Newton's method from above converges monotonically; the start, the smaller of
 *  q / c^2 and cbrt(q) (each >= x), is within 1.6 x of x, and EF_PLAN_CUBIC_NEWTON steps
 *  reach float32 resolution. */
static float pl_cubic_rise(float c, float q)
{
    float x = ef_minf(q / ef_maxf(c * c, 1e-30f), ef_cbrtf(q));
    for (int i = 0; i < EF_PLAN_CUBIC_NEWTON; i++) {
        float xc = x + c;
        float f = x * xc * xc - q, df = xc * (3.0f * x + c);
        float xn = x - f / ef_maxf(df, 1e-30f);
        x = ef_maxf(xn, 0.0f);
    }
    return x;
}

/** The largest v >= e with pl_ramp_dist(v, e) <= len under a jerk limit, in closed form:
 *  with x = v - e and k = a^2 / j, a trapezoidal ramp (x >= k) has
 *  (2e + x)(x + k) = 2 a len, a quadratic; a triangular one (x < k) has
 *  x (2e + x)^2 = j len^2 (pl_cubic_rise()). */
static float pl_ramp_up_jerk(float e, float len, float a, float j)
{
    float k = a * a / j;
    float b = 2.0f * e + k, r = 2.0f * e - k;
    float disc = ef_sqrtf(r * r + 8.0f * a * len);
    /* x = (disc - b) / 2, written without the cancellation: (disc^2 - b^2) / (2 (disc + b)),
     * disc^2 - b^2 = 8 a len - 8 e k */
    float x = (4.0f * (a * len - e * k)) / ef_maxf(disc + b, 1e-30f);
    if (x >= k)
        return e + x;
    return e + pl_cubic_rise(2.0f * e, j * len * len);
}

/** pl_ramp_top()'s answer under a jerk limit, in closed form (the caller lowers it by a few
 *  ulps where rounding puts it just beyond len). Up: pl_ramp_up_jerk(). Down: the
 *  distance pl_ramp_dist_down(v, e) is the ramp from v to max(e, p(v)), p(v) the concave
 *  distance's peak (v / 3 while v <= 1.5 k, k / 2 above), and rises with v. While p(v) <= e
 *  (e >= k / 2, or v <= 3 e) it is the ramp to e; past that, the ramp to p(v):
 *  (4 v / 3) sqrt(2 v / (3 j)) = len, v = cbrt(27 j len^2 / 32), while v <= 1.5 k, else
 *  the trapezoid from v to k / 2: (v + k / 2)^2 = 2 a len. Replaces EF_PLAN_BISECT
 *  bisections: the backward pass inverts once per move it updates, up to the whole window
 *  on one push (also the push of a staged move a pull hands over), and 64 bisected
 *  inversions were ~100 k M4 instructions. */
static float pl_ramp_top_jerk(float e, float len, float a, float j, int down)
{
    float k = a * a / j;
    float up = pl_ramp_up_jerk(e, len, a, j);
    if (!down || e >= 0.5f * k || pl_ramp_dist(3.0f * e, e, a, j) >= len)
        return up;
    float v = ef_cbrtf((27.0f / 32.0f) * j * len * len);
    if (v > 1.5f * k)
        v = ef_sqrtf(2.0f * a * len) - 0.5f * k;
    return v;
}

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
    } else {
        /* the closed form, lowered by about an ulp per step while it does not fit, never
         * below vf (which fits: d = 0); where len is a few ulps of vf's ramp that is vf */
        float v = ef_maxf(pl_ramp_top_jerk(vf, len, a, j, down), vf);
        int fits = 0;
        for (int k = 0; k <= EF_PLAN_ULP_STEPS && !fits; k++) {
            v = k == 0 ? v : ef_maxf(vf, v - v * 1.2e-7f);
            d = down ? pl_ramp_dist_down(v, vf, a, j) : pl_ramp_dist(v, vf, a, j);
            fits = d <= len;
        }
        if (fits)
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

/** Zero phase k (unused: skipped by the evaluation and not sent to drives). */
static void pl_law_zero(ef_timelaw_t *law, int k)
{
    law->dt[k] = 0.0f;
    for (int i = 0; i < EF_TIMELAW_COEFFS; i++)
        law->c[k][i] = 0.0f;
}

/** One phase starting at distance s0 with speed v0, acceleration a0 and jerk jk, lasting
 *  T: s(u) = s0 + v0 u + a0 u^2 / 2 + jk u^3 / 6, stored as tau = s / len. */
static void pl_law_phase(ef_timelaw_t *law, int k, float T, float s0, float v0, float a0, float jk,
                         float len)
{
    float il = 1.0f / len;
    law->dt[k] = T;
    law->c[k][0] = s0 * il;
    law->c[k][1] = v0 * il;
    law->c[k][2] = 0.5f * a0 * il;
    law->c[k][3] = jk * (1.0f / 6.0f) * il;
}

/** Fill phases k..k+2 with a ramp from va to vb starting at distance s0, at acceleration
 *  limit a and jerk limit j (0: one constant-acceleration phase). With a jerk limit: jerk
 *  phase, constant-acceleration phase (absent below dv = a^2 / j), jerk phase; the jerk is
 *  recomputed from the durations, dv / (Tj (Tj + Ta)), so the ramp ends exactly at vb.
 *  Returns the ramp's distance. */
static float pl_law_ramp(ef_timelaw_t *law, int k, float va, float vb, float s0, float len, float a,
                         float j)
{
    pl_law_zero(law, k);
    pl_law_zero(law, k + 1);
    pl_law_zero(law, k + 2);
    float dv = ef_fabsf(vb - va), sg = vb >= va ? 1.0f : -1.0f;
    float T = pl_ramp_time(dv, a, j);
    if (!(T > 0.0f))
        return 0.0f;
    if (!(j > 0.0f)) {
        pl_law_phase(law, k, T, s0, va, sg * dv / T, 0.0f, len);
        return 0.5f * (va + vb) * T;
    }
    float tj, ta;
    if (dv >= a * a / j) {
        tj = a / j;
        ta = ef_maxf(0.0f, T - 2.0f * tj);
    } else {
        tj = 0.5f * T;
        ta = 0.0f;
    }
    float jj = sg * dv / (tj * (tj + ta)), ap = jj * tj;
    float s1 = s0 + tj * (va + jj * tj * tj * (1.0f / 6.0f));
    float v1 = va + 0.5f * jj * tj * tj;
    float s2 = s1 + ta * (v1 + 0.5f * ap * ta);
    float v2 = v1 + ap * ta;
    pl_law_phase(law, k, tj, s0, va, 0.0f, jj, len);
    if (ta > 0.0f)
        pl_law_phase(law, k + 1, ta, s1, v1, ap, 0.0f, len);
    pl_law_phase(law, k + 2, tj, s2, v2, ap, -jj, len);
    return 0.5f * (va + vb) * (2.0f * tj + ta);
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
    int up0 = ef_fabsf(vc - v0) > eps, dn2 = vc - v1 > eps;
    float T2 = dn2 ? pl_ramp_time(vc - v1, a, j) : 0.0f;
    float d2 = dn2 ? 0.5f * (vc + v1) * T2 : 0.0f;

    ef_timelaw_t law;
    float d0 = 0.0f;
    if (up0)
        d0 = pl_law_ramp(&law, 0, v0, vc, 0.0f, len, a, j);
    else
        for (int k = 0; k < 3; k++)
            pl_law_zero(&law, k);
    float dc = len - d0 - d2;
    if (dc < 0.0f)
        dc = 0.0f;
    float Tc = 0.0f;
    if (dc > 0.0f && vc > 0.0f)
        Tc = dc / vc;
    pl_law_zero(&law, 3);
    if (Tc > 0.0f)
        pl_law_phase(&law, 3, Tc, d0, vc, 0.0f, 0.0f, len);
    if (dn2)
        (void)pl_law_ramp(&law, 4, vc, v1, d0 + dc, len, a, j);
    else
        for (int k = 4; k < 7; k++)
            pl_law_zero(&law, k);

    float dur = 0.0f;
    for (int k = 0; k < EF_TIMELAW_PHASES; k++)
        dur += law.dt[k];
    int ok = ef_finitef(dur) & (dur > 0.0f);
    for (int k = 0; k < EF_TIMELAW_PHASES; k++)
        for (int i = 0; i < EF_TIMELAW_COEFFS; i++)
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
    /* Unused phases (dt 0) are skipped: the time falls in the first used phase it does not
     * exceed, else in the last used one (clamped to its end). */
    int last = 0;
    for (int k = 0; k < EF_TIMELAW_PHASES; k++)
        if (law->dt[k] > 0.0f)
            last = k;
    int k = last;
    for (int i = 0; i < last; i++) {
        if (!(law->dt[i] > 0.0f))
            continue;
        if (u <= law->dt[i]) {
            k = i;
            break;
        }
        u -= law->dt[i];
    }
    if (u > law->dt[k] || done)
        u = law->dt[k];
    if (!(u >= 0.0f))
        u = 0.0f;
    const float *c = law->c[k];
    float x = c[0] + u * (c[1] + u * (c[2] + u * c[3]));
    x = ef_maxf(0.0f, ef_minf(1.0f, x));
    if (done)
        x = 1.0f;
    if (!(x == x))
        x = 0.0f;
    *tau = x;
    if (v) {
        float d = c[1] + u * (2.0f * c[2] + u * 3.0f * c[3]);
        float s = d * m->length;
        *v = s > 0.0f ? s : 0.0f; /* also maps NaN to 0 */
    }
    return EF_OK;
}

/* ---------------------------------------------------------------- planner */

/** Backward-pass bound of the group at window position n (0 = oldest) given the bound on
 *  the entry of the group after it (0 for the newest, which is assumed to end at rest): the
 *  largest entry speed from which every later group can still be followed and the newest
 *  stopped at its end. */
static float pl_bound(const ef_plan_t *p, uint32_t n, float v_next)
{
    const ef_plan_group_t *q = &p->q[(p->head + n) % EF_LOOKAHEAD];
    if (n > 0 && (p->q[(p->head + n - 1u) % EF_LOOKAHEAD].flags & EF_MOVE_STOP_END))
        return 0.0f;
    float exit_b = (q->flags & EF_MOVE_STOP_END) ? 0.0f : v_next;
    float v = ef_minf(q->v_max, pl_ramp_top(exit_b, q->length, q->a_max, q->j_max, 1));
    if (n > 0)
        v = ef_minf(v, p->q[(p->head + n - 1u) % EF_LOOKAHEAD].v_max);
    return ef_minf(v, q->v_in);
}

/** Incremental backward pass after a push: the newest group's bound, then the earlier ones
 *  while they change. A bound depends only on its group, the group before it and the next
 *  bound, so an unchanged bound leaves every earlier one unchanged: v_lim always equals a
 *  from-scratch pass over the window (the oldest group's bound is never read, so releasing
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
    p->mhead = p->mcount = 0;
    p->v_last = 0.0f;
    p->finished = 0;
    p->open = 0;
    p->rel_n = 0;
    p->k_end = ef_v3(0.0f, 0.0f, 0.0f);
    p->have_k = 0;
    p->have_ar = 0;
    for (int k = 0; k < EF_AUX_N; k++)
        p->ar_end[k] = 0.0f;
    for (uint32_t i = 0; i < EF_LOOKAHEAD; i++)
        p->v_lim[i] = 0.0f;
    return EF_OK;
}

/* Free look-ahead slots, so callers push only when there is room (see ef_plan.h). */
uint32_t ef_plan_space(const ef_plan_t *p)
{
    return p ? (uint32_t)EF_LOOKAHEAD - p->mcount : 0u;
}

/** Tangential jerk every axis leaves at speed v and tangential acceleration a:
 *  min_i (J - g_i v^3 - 3 k_i v a) / t_i over the axes the move drives. */
static float pl_jt(const float t[EF_AXES], const float k[EF_AXES], const float g[EF_AXES],
                   const float J[EF_AXES], int na, float v, float a)
{
    float j = 0.0f;
    int have = 0;
    for (int i = 0; i < na; i++) {
        if (!(t[i] > 0.0f))
            continue;
        float ji = (J[i] - g[i] * v * v * v - 3.0f * k[i] * v * a) / t[i];
        j = have ? ef_minf(j, ji) : ji;
        have = 1;
    }
    return j;
}

/** A move's speed limit, tangential acceleration and tangential jerk (ef_plan.h, "Limits of
 *  a move"). Per axis i, with tangent bound t_i = tabs_i, curvature-vector bound k_i = kabs_i
 *  and third-derivative bound g_i = kjerk_i, the axis acceleration is at most
 *  t_i a + k_i v^2 and its jerk at most t_i j + 3 k_i v a + g_i v^3; the limits keep both
 *  within a_axis_i and j_max at every speed up to v_max. */
static void pl_limits(const ef_limits_t *l, const ef_move_t *m, float *v_out, float *a_out,
                      float *j_out)
{
    /* X Y Z, then the auxiliary axes (all zero where none moves: skipped below, so a move
     * without them is planned as before, to the bit) */
    float t[EF_AXES] = {m->tabs.x, m->tabs.y, m->tabs.z};
    float k[EF_AXES] = {m->kabs.x, m->kabs.y, m->kabs.z};
    float g[EF_AXES] = {m->kjerk.x, m->kjerk.y, m->kjerk.z};
    if (m->kappa_max > 0.0f && !(k[0] > 0.0f || k[1] > 0.0f || k[2] > 0.0f))
        k[0] = k[1] = k[2] = m->kappa_max; /* a move measured without its axis parts */
    /* na: X Y Z and the auxiliary axes up to the last that moves (loops stop there) */
    int na = 3;
    for (int i = 0; i < EF_AUX; i++) {
        t[3 + i] = m->atabs[i];
        k[3 + i] = m->akabs[i];
        g[3 + i] = m->akjerk[i];
        if (t[3 + i] > 0.0f || k[3 + i] > 0.0f || g[3 + i] > 0.0f)
            na = 4 + i;
    }
    float J = EF_PLAN_LIMIT_SHARE * l->j_max, v = m->feed;
    float A[EF_AXES], Ji[EF_AXES];
    for (int i = 0; i < na; i++) {
        A[i] = EF_PLAN_LIMIT_SHARE * l->a_axis[i];
        Ji[i] = J;
    }
    for (int i = 3; i < na; i++)
        if (J > 0.0f && l->j_aux[i - 3] > 0.0f)
            Ji[i] = EF_PLAN_LIMIT_SHARE * l->j_aux[i - 3];
    for (int i = 0; i < na; i++) {
        if (t[i] > 0.0f)
            v = ef_minf(v, l->v_axis[i] / t[i]);
        if (k[i] > 0.0f)
            v = ef_minf(v, ef_sqrtf(l->a_normal_frac * A[i] / k[i]));
        if (J > 0.0f && g[i] > 0.0f)
            v = ef_minf(v, ef_cbrtf(EF_PLAN_JG_SHARE * Ji[i] / g[i]));
    }
    float a = 0.0f, j = 0.0f;
    int have = 0;
    for (int i = 0; i < na; i++) {
        if (!(t[i] > 0.0f))
            continue;
        float ai = (A[i] - k[i] * v * v) / t[i];
        a = have ? ef_minf(a, ai) : ai;
        have = 1;
    }
    if (J > 0.0f) {
        for (int i = 0; i < na; i++) {
            float gv = Ji[i] - g[i] * v * v * v;
            if (t[i] > 0.0f) {
                /* Lower a where the centripetal growth term leaves less than the minimum. */
                /* > 0: gv >= (1 - EF_PLAN_JG_SHARE) J, and the ramps' share stays below it
                 * whatever the two macros are set to */
                float jt = ef_minf(EF_PLAN_JT_MIN, 0.9f * (1.0f - EF_PLAN_JG_SHARE));
                float room = gv - jt * Ji[i] * ef_minf(t[i], 1.0f);
                if (k[i] > 0.0f && v > 0.0f && 3.0f * k[i] * v * a > room)
                    a = ef_maxf(0.0f, room / (3.0f * k[i] * v));
            }
        }
        /* The jerk every axis leaves at the final a. */
        j = pl_jt(t, k, g, Ji, na, v, a);
        /* On a curved move a and j share the jerk budget (3 k_i v a): take the a that makes
         * the ramp from rest to v_max shortest, not the largest a. */
        int curved = 0;
        for (int i = 0; i < na; i++)
            curved |= k[i] > 0.0f;
        if (v > 0.0f && curved) {
            float lo = EF_PLAN_A_SEARCH_LO * a, hi = a;
            for (int it = 0; it < EF_PLAN_A_SEARCH_ITER; it++) {
                float m1 = lo + 0.381966f * (hi - lo), m2 = hi - 0.381966f * (hi - lo);
                float T1 = pl_ramp_time(v, m1, pl_jt(t, k, g, Ji, na, v, m1));
                float T2 = pl_ramp_time(v, m2, pl_jt(t, k, g, Ji, na, v, m2));
                if (T1 <= T2)
                    hi = m2;
                else
                    lo = m1;
            }
            float as = 0.5f * (lo + hi), js = pl_jt(t, k, g, Ji, na, v, as);
            if (pl_ramp_time(v, as, js) < pl_ramp_time(v, a, j)) {
                a = as;
                j = js;
            }
        }
    }
    *v_out = v;
    *a_out = a;
    *j_out = j;
}

/** Curvature vector of a move's curve at tau = 0 (end 0) or 1 (end 1), from its control
 *  points: (f'' - <f'', t> t) / |f'|^2; zero for a line. */
static ef_vec3_t pl_kvec(const ef_move_t *m, int end)
{
    int n = m->degree;
    if (n < 2)
        return ef_v3(0.0f, 0.0f, 0.0f);
    const ef_vec3_t *b = m->b;
    ef_vec3_t d1 = end ? ef_v3_sub(b[n], b[n - 1]) : ef_v3_sub(b[1], b[0]);
    ef_vec3_t d2 = end ? ef_v3_add(ef_v3_sub(b[n], ef_v3_scale(b[n - 1], 2.0f)), b[n - 2])
                       : ef_v3_add(ef_v3_sub(b[2], ef_v3_scale(b[1], 2.0f)), b[0]);
    d1 = ef_v3_scale(d1, (float)n);
    d2 = ef_v3_scale(d2, (float)(n * (n - 1)));
    float s2 = ef_v3_dot(d1, d1);
    if (!(s2 > 0.0f))
        return ef_v3(0.0f, 0.0f, 0.0f);
    ef_vec3_t k = ef_v3_axpy(d2, -ef_v3_dot(d2, d1) / s2, d1);
    return ef_v3_scale(k, 1.0f / s2);
}

/** Entry speed cap of move m after the last pushed move (EF_PLAN_JUMP_T): the acceleration
 *  step of the curvature jump at their junction. */
static float pl_jump_cap(const ef_plan_t *p, const ef_move_t *m)
{
    float J = EF_PLAN_LIMIT_SHARE * p->lim.j_max, cap = 3.4e38f;
    if (!p->have_k || !(J > 0.0f))
        return cap;
    ef_vec3_t dk = ef_v3_sub(pl_kvec(m, 0), p->k_end);
    float d[3] = {ef_fabsf(dk.x), ef_fabsf(dk.y), ef_fabsf(dk.z)};
    for (int i = 0; i < 3; i++)
        if (d[i] > 0.0f)
            cap = ef_minf(cap, ef_sqrtf(EF_PLAN_JUMP_T * J / d[i]));
    return cap;
}

/** The auxiliary axes' rates (units per unit of X Y Z length) of move m at tau = 0 (end 0)
 *  or 1 (end 1), from its end control points; 0 when X Y Z do not move there. */
static int pl_aux_rates(const ef_move_t *m, int end, float r[EF_AUX_N])
{
    int n = m->degree;
    ef_vec3_t d = end ? ef_v3_sub(m->b[n], m->b[n - 1]) : ef_v3_sub(m->b[1], m->b[0]);
    float l = ef_v3_norm(d);
    int ok = l > 0.0f && !(m->flags & EF_MOVE_AUX_ONLY);
    float il = ok ? 1.0f / l : 0.0f;
    for (int k = 0; k < EF_AUX; k++)
        r[k] = (end ? m->ab[k][n] - m->ab[k][n - 1] : m->ab[k][1] - m->ab[k][0]) * il;
    return ok;
}

/** Entry speed cap of move m after the last pushed move from the auxiliary axes' rate jumps
 *  there (EF_PLAN_AUX_STEP_T). */
static float pl_aux_cap(const ef_plan_t *p, const ef_move_t *m)
{
    float cap = 3.4e38f, r[EF_AUX_N];
    if (!p->have_ar || !pl_aux_rates(m, 0, r))
        return cap;
    for (int k = 0; k < EF_AUX; k++) {
        /* a G2 junction's rates agree to the float32 resolution of the control values
         * (test_axes: 1e-4 of the rate): those are not capped, nor split into groups */
        float dr = ef_fabsf(r[k] - p->ar_end[k]);
        if (dr > 2e-3f * ef_maxf(ef_fabsf(r[k]), ef_fabsf(p->ar_end[k])) &&
            p->lim.a_axis[3 + k] > 0.0f)
            cap = ef_minf(cap, EF_PLAN_AUX_STEP_T * p->lim.a_axis[3 + k] / dr);
    }
    return cap;
}

/* A move's limits without queueing it (see ef_plan.h). */
int ef_plan_move_limits(const ef_limits_t *lim, const ef_move_t *m, float *v_max, float *a_max,
                        float *j_max)
{
    if (!lim || !m || !v_max || !a_max || !j_max || !(m->feed > 0.0f))
        return EF_ERR_ARG;
    pl_limits(lim, m, v_max, a_max, j_max);
    return EF_OK;
}

/* Queue a move with its speed/acceleration limits, update bounds (see ef_plan.h). */
int ef_plan_push(ef_plan_t *p, const ef_move_t *m)
{
    if (!p || !m)
        return EF_ERR_ARG;
    if (m->degree != 1 && m->degree != 3 && m->degree != 5)
        return EF_ERR_ARG;
    int fin = ef_finitef(m->length) & ef_finitef(m->kappa_max) & ef_finitef(m->feed) &
              pl_vfinite(m->tabs) & pl_v3ok(m->kabs) & pl_v3ok(m->kjerk);
    for (int i = 0; i <= m->degree; i++)
        fin &= pl_vfinite(m->b[i]);
    float tmax = ef_maxf(m->tabs.x, ef_maxf(m->tabs.y, m->tabs.z));
    /* the auxiliary values and bounds, branch-free (every move comes through here): z turns
     * NaN at a NaN or an infinity, big is the largest |value|, low the smallest bound */
    float z = 0.0f, big = 0.0f, low = 0.0f;
    for (int k = 0; k < EF_AUX; k++) {
        for (int i = 0; i <= m->degree; i++) {
            z += m->ab[k][i] * 0.0f;
            big = ef_maxf(big, ef_fabsf(m->ab[k][i]));
        }
        z += (m->atabs[k] + m->akabs[k] + m->akjerk[k]) * 0.0f;
        low = ef_minf(low, ef_minf(m->atabs[k], ef_minf(m->akabs[k], m->akjerk[k])));
        tmax = ef_maxf(tmax, m->atabs[k]);
    }
    fin &= (z == 0.0f) & (big <= EF_MAX_COORD);
    int aux_ok = low >= 0.0f;
    if (!fin)
        return EF_ERR_NONFINITE;
    /* an auxiliary move carries its axes' tangent bounds only */
    if (!(m->length >= EF_MIN_CHORD) || !(m->kappa_max >= 0.0f) || !(m->tabs.x >= 0.0f) ||
        !(m->tabs.y >= 0.0f) || !(m->tabs.z >= 0.0f) || !(m->kabs.x >= 0.0f) ||
        !(m->kabs.y >= 0.0f) || !(m->kabs.z >= 0.0f) || !(m->kjerk.x >= 0.0f) ||
        !(m->kjerk.y >= 0.0f) || !(m->kjerk.z >= 0.0f) || !aux_ok ||
        !(((m->flags & EF_MOVE_AUX_ONLY)
               ? tmax
               : ef_maxf(m->tabs.x, ef_maxf(m->tabs.y, m->tabs.z))) >= EF_PLAN_TABS_MIN))
        return EF_ERR_ARG;
    if (!(m->feed > 0.0f))
        return EF_ERR_FEED;
    if (p->mcount >= EF_LOOKAHEAD)
        return EF_ERR_FULL; /* (groups never outnumber moves) */

    float vmax, amax, jmax;
    pl_limits(&p->lim, m, &vmax, &amax, &jmax);
    if (!(vmax > 0.0f) || !(amax > 0.0f) || !ef_finitef(vmax) || !ef_finitef(amax) ||
        !ef_finitef(jmax))
        return EF_ERR_FEED;

    float v_in = ef_minf(pl_jump_cap(p, m), pl_aux_cap(p, m));
    p->k_end = pl_kvec(m, 1);
    p->have_k = 1;
    p->have_ar = pl_aux_rates(m, 1, p->ar_end);
    ef_move_t *q = &p->mv[(p->mhead + p->mcount) % EF_LOOKAHEAD];
    *q = *m;
    q->flags = (uint16_t)(m->flags & (EF_MOVE_STOP_END | EF_MOVE_CLAMPED | EF_MOVE_BLEND_CLAMPED |
                                      EF_MOVE_AUX_ONLY));
    q->seq = p->seq++;
    q->v_max = vmax;
    q->a_max = amax;
    q->j_max = jmax;
    q->v_entry = q->v_exit = 0.0f;
    q->duration = 0.0f;
    for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
        q->law.dt[k] = 0.0f;
        for (int i = 0; i < EF_TIMELAW_COEFFS; i++)
            q->law.c[k][i] = 0.0f;
    }
    p->mcount++;

    /* Join the newest group while it is shorter than a full ramp and the limits agree
     * (ef_plan.h, "Ramp groups"); else start a group. */
    ef_plan_group_t *g = p->count ? &p->q[(p->head + p->count - 1u) % EF_LOOKAHEAD] : 0;
    int join = p->open && g && !(g->flags & EF_MOVE_STOP_END) && g->n < EF_PLAN_GROUP_MAX;
    if (join) {
        const float vr = EF_PLAN_GROUP_VRATIO, ar = EF_PLAN_GROUP_ARATIO;
        join = vmax >= vr * g->v_max && g->v_max >= vr * vmax && amax >= ar * g->a_max &&
               g->a_max >= ar * amax && jmax >= ar * g->j_max && g->j_max >= ar * jmax &&
               g->length < pl_ramp_dist(0.0f, g->v_max, g->a_max, g->j_max) &&
               v_in >= ef_minf(g->v_max, vmax); /* a capped junction starts a group */
    }
    if (join) {
        g->length += q->length;
        g->v_max = ef_minf(g->v_max, vmax);
        g->a_max = ef_minf(g->a_max, amax);
        g->j_max = ef_minf(g->j_max, jmax);
        g->n++;
    } else {
        uint32_t idx = (p->head + p->count) % EF_LOOKAHEAD;
        g = &p->q[idx];
        g->length = q->length;
        g->v_max = vmax;
        g->a_max = amax;
        g->j_max = jmax;
        g->v_in = v_in;
        g->flags = 0;
        g->n = 1;
        p->v_lim[idx] = 0.0f;
        p->count++;
    }
    if (q->flags & EF_MOVE_STOP_END) {
        g->flags |= EF_MOVE_STOP_END;
        p->nstops++;
    }
    p->open = 1;
    p->finished = 0;
    pl_backward(p);
    return EF_OK;
}

/* Mark the end of the program: the last move stops, all can drain (see ef_plan.h). */
int ef_plan_finish(ef_plan_t *p)
{
    if (!p)
        return EF_ERR_ARG;
    if (p->count > 0 && p->open) {
        ef_plan_group_t *g = &p->q[(p->head + p->count - 1u) % EF_LOOKAHEAD];
        ef_move_t *last = &p->mv[(p->mhead + p->mcount - 1u) % EF_LOOKAHEAD];
        if (!(g->flags & EF_MOVE_STOP_END)) {
            g->flags |= EF_MOVE_STOP_END;
            last->flags |= EF_MOVE_STOP_END;
            p->nstops++;
        }
    }
    p->open = 0;
    p->finished = 1;
    return EF_OK;
}

/** Group distance reached at time u into phase k of a group law, as the phase's start
 *  distance and the distance covered since (kept apart: a member's own distance is their
 *  sum less its start, with less rounding than one sum), and speed, acceleration, jerk. */
static void pl_law_at(const ef_move_t *g, uint32_t k, float u, float *s0, float *ds, float *d)
{
    const float *c = g->law.c[k];
    float L = g->length;
    *s0 = L * c[0];
    *ds = L * (u * (c[1] + u * (c[2] + u * c[3])));
    d[0] = L * (c[1] + u * (2.0f * c[2] + u * 3.0f * c[3]));
    d[1] = L * (2.0f * c[2] + u * 6.0f * c[3]);
    d[2] = L * 6.0f * c[3];
}

/** Where a group law reaches group distance `target`, searching on from phase k at time u:
 *  the first used phase whose end reaches it (else the last used phase), then a fixed-count
 *  bisection in it; (k, u) are updated. */
static void pl_law_cross(const ef_move_t *g, uint32_t last, float target, uint32_t *k, float *u)
{
    float s0, ds, d[3];
    uint32_t kk = *k;
    float lo = *u, s_end = 0.0f;
    int have_end = 0; /* s_end is s at phase kk's end */
    for (; kk < last; kk++, lo = 0.0f) {
        if (!(g->law.dt[kk] > 0.0f))
            continue;
        pl_law_at(g, kk, g->law.dt[kk], &s0, &ds, d);
        s_end = s0 + ds;
        if (s_end >= target) {
            have_end = 1;
            break;
        }
    }
    /* Newton's method on s(u) = target inside the bracket [lo, hi], from the secant point
     * of the bracket's ends, with a bisection step where it would leave the bracket (or
     * the speed is 0): s is a cubic with s' the speed >= 0, so the root is simple wherever
     * the law moves and the steps converge quadratically. Where they have not converged
     * (EF_PLAN_CROSS_TOL) after EF_PLAN_CROSS_ITER steps (a fuzzed deceleration
     * phase whose root sat at 0.2 % of it: the midpoint start and the concave cubic sent
     * every step out of the bracket), bisection finishes the job as before (at most
     * EF_PLAN_BISECT steps in all). Most crossings take 3 to 5 steps instead of 32. */
    float end = g->law.dt[kk], hi = end;
    if (!have_end) { /* the last used phase: not evaluated by the search */
        pl_law_at(g, kk, hi, &s0, &ds, d);
        s_end = s0 + ds;
    }
    float f_hi = s_end - target;
    int past = !(f_hi > 0.0f); /* at or past the phase's end: its end */
    pl_law_at(g, kk, lo, &s0, &ds, d);
    float f_lo = (s0 + ds) - target;
    float uu = lo - f_lo * ((hi - lo) / (f_hi - f_lo));
    uu = ((uu > lo) & (uu < hi)) ? uu : 0.5f * (lo + hi);
    int done = past;
    for (int i = 0; i < EF_PLAN_BISECT && !done; i++) {
        pl_law_at(g, kk, uu, &s0, &ds, d);
        float f = (s0 + ds) - target;
        hi = f >= 0.0f ? uu : hi;
        lo = f >= 0.0f ? lo : uu;
        /* found: s within an ulp of the target (where the law starts from rest, s ~ u^3,
         * the steps shrink only by a third each and would not converge in u) */
        int hit = ef_fabsf(f) <= EF_PLAN_CROSS_FTOL * ef_fabsf(target);
        float un = uu - f / d[0];
        /* false for NaN (d[0] = 0); inclusive, so a root found on the bracket stays */
        int inside = (i < EF_PLAN_CROSS_ITER) & (un >= lo) & (un <= hi);
        /* converged: the step is below float32 resolution of u */
        done = hit | (inside & (ef_fabsf(un - uu) <= EF_PLAN_CROSS_TOL * uu));
        uu = hit ? uu : (inside ? un : 0.5f * (lo + hi));
    }
    *k = kk;
    *u = past ? end : (done ? uu : hi); /* not converged: bisection's answer, as before */
}

/** The law of one member of the group being released: the group law between the crossing
 *  (rel_k, rel_u) and (k1, u1), in the member's own parameter. Returns the duration. */
static float pl_law_slice(const ef_plan_t *p, uint32_t k1, float u1, float s_start, float len,
                          ef_timelaw_t *law)
{
    const ef_move_t *g = &p->rel;
    for (int k = 0; k < EF_TIMELAW_PHASES; k++)
        pl_law_zero(law, k);
    float il = 1.0f / len, dur = 0.0f;
    int slot = 0;
    for (uint32_t k = p->rel_k; k <= k1 && k < EF_TIMELAW_PHASES; k++) {
        if (!(g->law.dt[k] > 0.0f))
            continue;
        float u0 = k == p->rel_k ? p->rel_u : 0.0f;
        float ue = k == k1 ? u1 : g->law.dt[k];
        if (!(ue > u0))
            continue;
        float s0, ds, d[3];
        pl_law_at(g, k, u0, &s0, &ds, d);
        law->dt[slot] = ue - u0;
        law->c[slot][0] = slot == 0 ? 0.0f : ((s0 - s_start) + ds) * il;
        law->c[slot][1] = d[0] * il;
        law->c[slot][2] = 0.5f * d[1] * il;
        law->c[slot][3] = d[2] * (1.0f / 6.0f) * il;
        dur += ue - u0;
        slot++;
    }
    return dur;
}

/** Start releasing the oldest group: its law over its whole length, from the committed
 *  entry speed to what the rest of the window allows. */
static int pl_release_start(ef_plan_t *p)
{
    const ef_plan_group_t *g = &p->q[p->head];
    if (p->count == 1u)
        p->open = 0; /* nothing joins a group under release */
    float exit_b = 0.0f;
    if (!(g->flags & EF_MOVE_STOP_END) && p->count > 1)
        exit_b = p->v_lim[(p->head + 1u) % EF_LOOKAHEAD];
    ef_move_t *r = &p->rel;
    r->length = g->length;
    r->v_max = g->v_max;
    r->a_max = g->a_max;
    r->j_max = g->j_max;
    r->flags = g->flags;
    float v0 = p->v_last;
    float up = pl_ramp_top(v0, r->length, r->a_max, r->j_max, 0);
    r->v_entry = v0;
    r->v_exit = ef_minf(ef_minf(exit_b, up), r->v_max);
    int rc = pl_timelaw_up(r, r->j_max, up);
    if (rc != EF_OK)
        return rc; /* not reachable for data push accepted; state unchanged */
    if ((g->flags & EF_MOVE_STOP_END) || p->count == 1u)
        r->v_exit = 0.0f; /* exact: the ramp ends at rest (dropped ramps only for vc ~ 0);
                             the window's newest group is planned to (ef_plan_pull_now()) */
    p->rel_n = g->n;
    p->rel_s = 0.0f;
    p->rel_k = 0;
    p->rel_u = 0.0f;
    p->rel_v = v0;
    return EF_OK;
}

/* Release the oldest move with its final speeds and time law (see ef_plan.h); now: whatever
 * the window holds (ef_plan_pull_now()). */
static int pl_pull(ef_plan_t *p, ef_move_t *out, int now)
{
    if (!p || !out)
        return EF_ERR_ARG;
    if (p->rel_n == 0u) {
        if (p->count == 0 || !(now || p->mcount >= EF_LOOKAHEAD || p->nstops > 0 || p->finished))
            return EF_ERR_AGAIN;
        int rc = pl_release_start(p);
        if (rc != EF_OK)
            return rc;
    }
    const ef_move_t *r = &p->rel;
    /* built in place: one copy of the move, not two (it is 0.5 KB with nine axes) */
    ef_move_t *m = out;
    *m = p->mv[p->mhead];
    m->v_max = r->v_max;
    m->a_max = r->a_max;
    m->j_max = r->j_max;
    m->v_entry = p->rel_v;
    if (p->rel_n == 1u && p->rel_s == 0.0f) {
        /* A group of one: its law as it is. */
        m->law = r->law;
        m->duration = r->duration;
        m->v_exit = r->v_exit;
    } else {
        uint32_t last = 0;
        for (uint32_t k = 0; k < EF_TIMELAW_PHASES; k++)
            if (r->law.dt[k] > 0.0f)
                last = k;
        uint32_t k1 = p->rel_k;
        float u1 = p->rel_u, v1;
        if (p->rel_n == 1u) {
            k1 = last; /* the last member ends where the law does, at its exit speed */
            u1 = r->law.dt[last];
            v1 = r->v_exit;
        } else {
            pl_law_cross(r, last, p->rel_s + m->length, &k1, &u1);
            float s0, ds, d[3];
            pl_law_at(r, k1, u1, &s0, &ds, d);
            v1 = ef_maxf(0.0f, d[0]);
        }
        float dur = pl_law_slice(p, k1, u1, p->rel_s, m->length, &m->law);
        if (!(dur > 0.0f)) {
            /* Shorter than the time resolution at this point of the law: one cruise phase
             * at the speed there (adds at most that resolution to the program). */
            float v = ef_maxf(ef_maxf(m->v_entry, v1), 1e-3f);
            for (int k = 0; k < EF_TIMELAW_PHASES; k++)
                pl_law_zero(&m->law, k);
            dur = m->length / v;
            m->law.dt[0] = dur;
            m->law.c[0][1] = 1.0f / dur;
        }
        m->duration = dur;
        m->v_exit = v1;
        p->rel_k = k1;
        p->rel_u = u1;
        p->rel_v = v1;
        p->rel_s += m->length;
    }
    if (p->rel_n == 1u && (m->flags & EF_MOVE_STOP_END))
        m->v_exit = 0.0f;
    p->mhead = (p->mhead + 1u) % EF_LOOKAHEAD;
    p->mcount--;
    p->rel_n--;
    if (p->rel_n == 0u) {
        if (p->q[p->head].flags & EF_MOVE_STOP_END)
            p->nstops--;
        p->v_last = m->v_exit;
        p->head = (p->head + 1u) % EF_LOOKAHEAD;
        p->count--;
    }
    return EF_OK;
}

int ef_plan_pull(ef_plan_t *p, ef_move_t *out)
{
    return pl_pull(p, out, 0);
}

int ef_plan_pull_now(ef_plan_t *p, ef_move_t *out)
{
    return pl_pull(p, out, 1);
}
