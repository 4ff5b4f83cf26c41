/* SPDX-License-Identifier: Apache-2.0 */
/* Feed planner (ef_plan) and interpolator (ef_interp) tests. Moves are built here with
 * length, kappa_max and tabs computed by the test itself (exact for lines, dense sampling in
 * double for curves), so these tests do not depend on ef_move_measure(). */
#include <string.h>
#include "ef_test.h"
#include "ef_testbez.h"
#include "evenfeed/geom/ef_bezier.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/motion/ef_interp.h"
#include "evenfeed/motion/ef_plan.h"

/* ------------------------------------------------------------------ helpers */

/* Limits whose planned share (EF_PLAN_LIMIT_SHARE) is a and j: the cases below state the
 * accelerations and jerks the planner works with. */
static ef_limits_t mk_limits(float v, float a, float j, float frac)
{
    ef_limits_t l;
    memset(&l, 0, sizeof l);
    for (int i = 0; i < 3; i++) {
        l.v_axis[i] = v;
        l.a_axis[i] = a / EF_PLAN_LIMIT_SHARE;
    }
    l.j_max = j / EF_PLAN_LIMIT_SHARE;
    l.a_normal_frac = frac;
    return l;
}

static ef_move_t mk_line(ef_vec3_t p0, ef_vec3_t p1, float feed, unsigned flags)
{
    ef_move_t m;
    memset(&m, 0, sizeof m);
    m.degree = 1;
    m.kind = EF_MOVE_LINE;
    m.flags = (uint16_t)flags;
    m.b[0] = p0;
    m.b[1] = p1;
    double dx = (double)p1.x - p0.x, dy = (double)p1.y - p0.y, dz = (double)p1.z - p0.z;
    double len = sqrt(dx * dx + dy * dy + dz * dz);
    m.length = (float)len;
    m.tabs = ef_v3((float)(fabs(dx) / len), (float)(fabs(dy) / len), (float)(fabs(dz) / len));
    m.feed = feed;
    return m;
}

/* Bézier position/derivative in double (de Casteljau on differences). */
static void bz(const ef_vec3_t *b, int d, double t, int k, double out[3])
{
    double pts[8][3];
    double f = ef_t_bezier_diffs(b, d, k, pts);
    int m = d - k;
    for (int r = 0; r < m; r++)
        for (int i = 0; i < m - r; i++)
            for (int c = 0; c < 3; c++)
                pts[i][c] = (1 - t) * pts[i][c] + t * pts[i + 1][c];
    for (int c = 0; c < 3; c++)
        out[c] = f * pts[0][c];
}

/* Length, kappa_max, tabs of a curve by dense sampling in double; also the ratio of the
 * largest to the smallest parametric speed. */
static double measure_curve(ef_move_t *m)
{
    const int n = 20000;
    double len = 0, kmax = 0, tab[3] = {0, 0, 0}, smin = 1e300, smax = 0;
    for (int i = 0; i <= n; i++) {
        double t = (double)i / n, d1[3], d2[3];
        bz(m->b, m->degree, t, 1, d1);
        bz(m->b, m->degree, t, 2, d2);
        double s = sqrt(d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]);
        double cx = d1[1] * d2[2] - d1[2] * d2[1], cy = d1[2] * d2[0] - d1[0] * d2[2],
               cz = d1[0] * d2[1] - d1[1] * d2[0];
        double k = sqrt(cx * cx + cy * cy + cz * cz) / (s * s * s);
        kmax = k > kmax ? k : kmax;
        for (int c = 0; c < 3; c++)
            tab[c] = fabs(d1[c]) / s > tab[c] ? fabs(d1[c]) / s : tab[c];
        smin = s < smin ? s : smin;
        smax = s > smax ? s : smax;
        len += s * ((i == 0 || i == n) ? 1 : (i % 2 ? 4 : 2)) / (3.0 * n);
    }
    m->length = (float)len;
    m->kappa_max = (float)kmax;
    m->tabs = ef_v3((float)tab[0], (float)tab[1], (float)tab[2]);
    return smax / smin;
}

/* Speed of a move's law at time t, evaluated in double from the stored coefficients (the
 * float evaluation's rounding would swamp second differences at small steps). */
static double law_v(const ef_move_t *m, double t)
{
    double u = t < 0 ? 0 : t;
    int last = 0, k;
    for (k = 0; k < EF_TIMELAW_PHASES; k++)
        if (m->law.dt[k] > 0)
            last = k;
    for (k = 0; k < last; k++) {
        if (!(m->law.dt[k] > 0))
            continue; /* unused phase */
        if (u <= m->law.dt[k])
            break;
        u -= m->law.dt[k];
    }
    if (u > m->law.dt[k])
        u = m->law.dt[k];
    const float *c = m->law.c[k];
    return m->length * (c[1] + u * (2.0 * c[2] + u * 3.0 * c[3]));
}

/* Peak |accel| and |jerk| of a sequence of moves, by finite differences on the sampled
 * speed (step h), across move boundaries; also the largest v / v_max seen. */
typedef struct {
    double acc_ratio, jerk_ratio, v_ratio, total;
} peaks_t;

static peaks_t measure_peaks(const ef_move_t *ms, int n, double jmax, double h)
{
    peaks_t r = {0, 0, 0, 0};
    for (int i = 0; i < n; i++)
        r.total += ms[i].duration;
    long steps = (long)(r.total / h);
    double vp = 0, ap = 0;
    int mi = 0, mprev = 0, mprev2 = 0; /* moves of the samples at t, t - h, t - 2 h */
    double t0 = 0;                     /* start time of move mi */
    for (long s = 0; s <= steps; s++) {
        double t = s * h;
        while (mi < n - 1 && t > t0 + ms[mi].duration) {
            t0 += ms[mi].duration;
            mi++;
        }
        double v = law_v(&ms[mi], t - t0);
        double vr = v / ms[mi].v_max;
        r.v_ratio = vr > r.v_ratio ? vr : r.v_ratio;
        if (s >= 1) {
            double a = (v - vp) / h;
            /* the difference averages the acceleration over [t - h, t]: compare with the
             * largest limit of the moves that interval covers */
            double amax = 0, jm = 0;
            for (int k = mprev; k <= mi; k++)
                amax = ms[k].a_max > amax ? ms[k].a_max : amax;
            /* the jerk's difference spans t - 2h .. t; each move has its tangential jerk */
            for (int k = mprev2; k <= mi; k++)
                jm = ms[k].j_max > jm ? ms[k].j_max : jm;
            double ar = fabs(a) / amax;
            r.acc_ratio = ar > r.acc_ratio ? ar : r.acc_ratio;
            if (s >= 2 && jmax > 0) {
                double jr = fabs(a - ap) / h / jm;
                r.jerk_ratio = jr > r.jerk_ratio ? jr : r.jerk_ratio;
            }
            ap = a;
        }
        vp = v;
        mprev2 = mprev;
        mprev = mi;
    }
    return r;
}

/* Plan a whole list (stream through the window, finish), writing the released moves. */
static int plan_list(const ef_limits_t *lim, const ef_move_t *in, int n, ef_move_t *out)
{
    static ef_plan_t p;
    if (ef_plan_init(&p, lim) != EF_OK)
        return -1;
    int got = 0;
    for (int i = 0; i < n; i++) {
        int rc = ef_plan_push(&p, &in[i]);
        if (rc == EF_ERR_FULL) {
            if (ef_plan_pull(&p, &out[got]) != EF_OK)
                return -1;
            got++;
            rc = ef_plan_push(&p, &in[i]);
        }
        if (rc != EF_OK)
            return -1;
    }
    ef_plan_finish(&p);
    while (ef_plan_pull(&p, &out[got]) == EF_OK)
        got++;
    return got;
}

/* ------------------------------------------------------------------ (1) single line */

static double trap_time(double L, double v, double a)
{
    double d = v * v / a; /* both ramps */
    if (d <= L)
        return 2 * v / a + (L - d) / v;
    return 2 * sqrt(a * L) / a;
}

/* Duration of the time-optimal S-curve ramp by dv at acceleration a and jerk j. */
static double scurve_T(double dv, double a, double j)
{
    return dv >= a * a / j ? dv / a + a / j : 2 * sqrt(dv / j);
}

static double smooth_time(double L, double v, double a, double j)
{
    double T = scurve_T(v, a, j);
    double D = v * T; /* both ramps */
    return 2 * T + (L - D) / v;
}

static void test_single_line(void)
{
    static const struct {
        float L, feed, a_axis, j;
    } cases[] = {
        {100, 50, 200, 0},    /* trapezoid */
        {10, 50, 200, 0},     /* triangle */
        {100, 50, 200, 1000}, /* jerk-limited, acceleration-bound ramps */
        {100, 50, 200, 200},  /* jerk-bound ramps */
        {5, 50, 200, 500},    /* jerk, cruise speed below the feed (bisection) */
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        ef_limits_t lim = mk_limits(1000, cases[c].a_axis, cases[c].j, 0.5f);
        ef_plan_t p;
        EF_CHECK_EQ(ef_plan_init(&p, &lim), EF_OK);
        ef_move_t m = mk_line(ef_v3(0, 0, 0), ef_v3(cases[c].L, 0, 0), cases[c].feed, 0);
        EF_CHECK_EQ(ef_plan_push(&p, &m), EF_OK);
        EF_CHECK_EQ(ef_plan_finish(&p), EF_OK);
        ef_move_t o;
        EF_CHECK_EQ(ef_plan_pull(&p, &o), EF_OK);
        double a = cases[c].a_axis; /* a line has the whole budget */
        EF_CHECK_NEAR(o.a_max, a, 1e-4);
        EF_CHECK_NEAR(o.v_max, cases[c].feed, 1e-4);
        EF_CHECK_EQ(o.v_entry, 0);
        EF_CHECK_EQ(o.v_exit, 0);
        EF_CHECK(o.flags & EF_MOVE_STOP_END);
        double want;
        if (cases[c].j == 0) {
            want = trap_time(cases[c].L, cases[c].feed, a);
        } else if (c == 4) {
            /* cruise speed vc solves vc * T(vc) = L, found here in double */
            double lo = 0, hi = cases[c].feed;
            for (int i = 0; i < 100; i++) {
                double mid = 0.5 * (lo + hi);
                double T = scurve_T(mid, a, cases[c].j);
                if (mid * T <= cases[c].L)
                    lo = mid;
                else
                    hi = mid;
            }
            want = 2 * scurve_T(lo, a, cases[c].j);
        } else {
            want = smooth_time(cases[c].L, cases[c].feed, a, cases[c].j);
        }
        EF_CHECK_NEAR(o.duration, want, 1e-5 * want);
        double sum = 0;
        for (int k = 0; k < EF_TIMELAW_PHASES; k++)
            sum += o.law.dt[k];
        EF_CHECK_NEAR(o.duration, sum, 1e-6 * want);
        float tau, v;
        EF_CHECK_EQ(ef_timelaw_eval(&o, o.duration, &tau, &v), EF_OK);
        EF_CHECK_EQ(tau, 1.0f);
        EF_CHECK_NEAR(v, 0, 1e-3);
        EF_CHECK_EQ(ef_timelaw_eval(&o, 0, &tau, &v), EF_OK);
        EF_CHECK_EQ(tau, 0.0f);
        /* the distance travelled (integral of v) matches tau * L everywhere */
        double h = 1e-4, dist = 0, vp = 0, tau_err = 0, tau_prev = 0;
        int mono = 1;
        for (double t = h; t <= o.duration; t += h) {
            ef_timelaw_eval(&o, (float)t, &tau, &v);
            dist += 0.5 * (v + vp) * h;
            vp = v;
            tau_err = fmax(tau_err, fabs(dist - tau * (double)o.length));
            mono &= tau >= tau_prev - 3e-7f; /* float rounding only */
            tau_prev = tau;
        }
        EF_CHECK(mono);
        EF_CHECK(tau_err < 1e-3 * cases[c].L);
        peaks_t pk = measure_peaks(&o, 1, cases[c].j, 1e-3);
        printf("line L=%g j=%g: duration %.6f (analytic %.6f), peak acc/a_max %.4f, "
               "peak jerk/J %.4f, v/v_max %.5f\n",
               (double)cases[c].L, (double)cases[c].j, (double)o.duration, want, pk.acc_ratio,
               pk.jerk_ratio, pk.v_ratio);
        EF_CHECK(pk.acc_ratio <= 1.002);
        EF_CHECK(pk.v_ratio <= 1.0001);
        if (cases[c].j > 0) {
            EF_CHECK(pk.jerk_ratio <= 1.01);
            EF_CHECK(pk.jerk_ratio > 0.5); /* the measurement sees the jerk at all */
        }
        EF_CHECK_EQ(ef_plan_pull(&p, &o), EF_ERR_AGAIN);
    }
}

/* ------------------------------------------------------------------ (2) chain with corner */

#define CHAIN_N 40

static void chain_case(float j)
{
    ef_limits_t lim = mk_limits(1000, 200, j, 0.5f);
    static ef_move_t in[CHAIN_N], out[CHAIN_N];
    for (int i = 0; i < CHAIN_N; i++) {
        in[i] = mk_line(ef_v3(5.0f * i, 0, 0), ef_v3(5.0f * (i + 1), 0, 0), 50, 0);
        in[i].tag = (uint32_t)(1000 + i);
        if (i >= 18 && i <= 22)
            in[i].kappa_max = 2.0f; /* tight corner: v_max = sqrt(100 / 2) */
    }
    int n = plan_list(&lim, in, CHAIN_N, out);
    EF_CHECK_EQ(n, CHAIN_N);
    if (n != CHAIN_N)
        return;
    int cont = 1, seq = 1, vok = 1;
    for (int i = 0; i < n; i++) {
        seq &= out[i].seq == (uint32_t)i && out[i].tag == (uint32_t)(1000 + i);
        vok &= out[i].v_entry <= out[i].v_max * 1.0001f && out[i].v_exit <= out[i].v_max * 1.0001f;
        if (i + 1 < n) {
            cont &= out[i].v_exit == out[i + 1].v_entry;
            vok &= out[i].v_exit <= out[i + 1].v_max * 1.0001f;
        }
    }
    EF_CHECK(seq);
    EF_CHECK(cont);
    EF_CHECK(vok);
    EF_CHECK_EQ(out[0].v_entry, 0);
    EF_CHECK_EQ(out[n - 1].v_exit, 0);
    EF_CHECK_NEAR(out[20].v_max, sqrt(50.0), 1e-4);
    /* entry of the corner region is at its limit (the planner does not stop needlessly) */
    EF_CHECK_NEAR(out[18].v_entry, sqrt(50.0), 1e-3);
    EF_CHECK(out[10].v_entry > 49.9f);
    peaks_t pk = measure_peaks(out, n, j, 1e-3);
    /* time bounds: never faster than each move at its v_max; never slower than stopping at
     * every change of limit (three rest-to-rest regions) */
    double lower = 0;
    for (int i = 0; i < n; i++)
        lower += out[i].length / out[i].v_max;
    double a = 100, vc = sqrt(50.0), upper;
    if (j > 0)
        upper = smooth_time(90, 50, a, j) + smooth_time(25, vc, a, j) + smooth_time(85, 50, a, j);
    else
        upper = trap_time(90, 50, a) + trap_time(25, vc, a) + trap_time(85, 50, a);
    printf("chain j=%g: total %.4f s (bounds %.4f .. %.4f), peak acc/a_max %.4f, "
           "peak jerk/J %.4f, v/v_max %.5f\n",
           (double)j, pk.total, lower, upper, pk.acc_ratio, pk.jerk_ratio, pk.v_ratio);
    EF_CHECK(pk.total > lower && pk.total < upper);
    EF_CHECK(pk.v_ratio <= 1.0001);
    EF_CHECK(pk.acc_ratio <= 1.002);
    if (j > 0)
        EF_CHECK(pk.jerk_ratio <= 1.01);
}

/* Random streams: lengths from 1e-4 to 20, feeds, curvature limits, stops, with and without
 * jerk; invariants on every released move. */
static void test_random_streams(void)
{
    enum { N = 1500 };
    static ef_move_t in[N], out[N];
    unsigned long long rng = 777;
    for (int pass = 0; pass < 2; pass++) {
        float j = pass ? 3000.0f : 0.0f;
        ef_limits_t lim = {{300, 200, 100}, {2000, 1500, 800}, j, 0.4f, {0}};
        ef_vec3_t p = ef_v3(0, 0, 0);
        for (int i = 0; i < N; i++) {
            double len = pow(10, ef_t_uniform(&rng, -4, 1.3));
            double th = ef_t_uniform(&rng, 0, 2 * M_PI), z = ef_t_uniform(&rng, -0.3, 0.3);
            ef_vec3_t d = ef_v3((float)cos(th), (float)sin(th), (float)z);
            double dn = sqrt((double)ef_v3_dot(d, d));
            ef_vec3_t q = ef_v3_axpy(p, (float)(len / dn), d);
            float feed = (float)ef_t_uniform(&rng, 1, 400);
            in[i] = mk_line(p, q, feed, ef_t_uniform(&rng, 0, 1) < 0.02 ? EF_MOVE_STOP_END : 0);
            if (ef_t_uniform(&rng, 0, 1) < 0.2)
                in[i].kappa_max = (float)pow(10, ef_t_uniform(&rng, -2, 2));
            p = q;
        }
        int n = plan_list(&lim, in, N, out);
        EF_CHECK_EQ(n, N);
        int ok = 1, cont = 1, stops = 1;
        for (int i = 0; i < n; i++) {
            ok &= out[i].duration > 0 && out[i].duration < 1e3f && out[i].v_max > 0;
            ok &= out[i].seq == (uint32_t)i;
            if (in[i].flags & EF_MOVE_STOP_END)
                stops &= out[i].v_exit == 0;
            if (i + 1 < n)
                cont &= out[i].v_exit == out[i + 1].v_entry;
        }
        EF_CHECK(ok);
        EF_CHECK(cont);
        EF_CHECK(stops);
        EF_CHECK_EQ(out[n - 1].v_exit, 0);
        /* 2 ms steps with a jerk limit: the law's float32 coefficients round the speed by
         * ~1 ulp (2.3e-6 mm/s at 39 mm/s on a 16 mm move), a second difference of which is
         * 2.3 mm/s^3 at 1 ms, 0.3 % of the 735 mm/s^3 such a curved move keeps for its
         * ramps; at 2 ms a quarter of that */
        peaks_t pk = measure_peaks(out, n, j, j > 0 ? 2e-3 : 2e-5);
        printf("random stream j=%g: %d moves, %.3f s, peak acc/a_max %.4f, peak jerk/J %.4f, "
               "v/v_max %.5f\n",
               (double)j, n, pk.total, pk.acc_ratio, pk.jerk_ratio, pk.v_ratio);
        EF_CHECK(pk.v_ratio <= 1.0001);
        EF_CHECK(pk.acc_ratio <= 1.01);
        if (j > 0)
            EF_CHECK(pk.jerk_ratio <= 1.01);
    }
}

/* ------------------------------------------------------------------ incremental bounds */

/* From-scratch backward pass in double (ef_plan.h): the incremental bounds must match it. */
static double ref_time(double dv, double a, double j)
{
    return j > 0 ? scurve_T(dv, a, j) : dv / a;
}

static double ref_dist(double va, double vb, double a, double j)
{
    return 0.5 * (va + vb) * ref_time(fabs(vb - va), a, j);
}

static double ref_dist_down(double v0, double e, double a, double j)
{
    double d = ref_dist(v0, e, a, j);
    if (j > 0 && v0 > e) {
        /* d(v) = (v0 + v) T(v0 - v) / 2 is concave in v: its stationary point is v0 / 3 in
         * the triangular range, a^2 / (2 j) in the trapezoidal one */
        double a2j = a * a / j;
        double pk = v0 - v0 / 3 <= a2j ? v0 / 3 : a2j / 2;
        double v = fmin(v0, fmax(e, pk));
        d = fmax(d, ref_dist(v0, v, a, j));
    }
    return d;
}

static double ref_top(double vf, double len, double a, double j)
{
    double lo = vf, hi = sqrt(vf * vf + 2 * a * len);
    if (ref_dist_down(hi, vf, a, j) <= len)
        return hi;
    for (int i = 0; i < 80; i++) {
        double mid = 0.5 * (lo + hi);
        if (ref_dist_down(mid, vf, a, j) <= len)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* Largest relative difference between the planner's bounds (every move but the oldest,
 * whose bound is never read) and a from-scratch pass. */
static double bounds_diff(const ef_plan_t *p)
{
    double v_next = 0, worst = 0;
    for (uint32_t n = p->count; n-- > 0;) {
        const ef_plan_group_t *q = &p->q[(p->head + n) % EF_LOOKAHEAD];
        double exit_b = (q->flags & EF_MOVE_STOP_END) ? 0 : v_next;
        double v = fmin(q->v_max, ref_top(exit_b, q->length, q->a_max, q->j_max));
        if (n > 0) {
            const ef_plan_group_t *prev = &p->q[(p->head + n - 1u) % EF_LOOKAHEAD];
            v = (prev->flags & EF_MOVE_STOP_END) ? 0 : fmin(v, prev->v_max);
            double got = p->v_lim[(p->head + n) % EF_LOOKAHEAD];
            worst = fmax(worst, fabs(got - v) / (fabs(v) + 1e-3));
        }
        v_next = v;
    }
    return worst;
}

static void test_incremental_bounds(void)
{
    static ef_plan_t p;
    unsigned long long rng = 4242;
    for (int pass = 0; pass < 2; pass++) {
        float j = pass ? 3000.0f : 0.0f;
        ef_limits_t lim = {{300, 200, 100}, {2000, 1500, 800}, j, 0.4f, {0}};
        EF_CHECK_EQ(ef_plan_init(&p, &lim), EF_OK);
        ef_vec3_t a = ef_v3(0, 0, 0);
        double worst = 0, worst_exit = 0;
        int pulls = 0, okc = 1;
        float v_prev = 0;
        for (int i = 0; i < 4000; i++) {
            double len = pow(10, ef_t_uniform(&rng, -3, 1));
            double th = ef_t_uniform(&rng, 0, 2 * M_PI);
            ef_vec3_t b = ef_v3_axpy(a, (float)len, ef_v3((float)cos(th), (float)sin(th), 0));
            float feed = (float)ef_t_uniform(&rng, 5, 400);
            ef_move_t m =
                mk_line(a, b, feed, ef_t_uniform(&rng, 0, 1) < 0.01 ? EF_MOVE_STOP_END : 0);
            if (ef_t_uniform(&rng, 0, 1) < 0.2)
                m.kappa_max = (float)pow(10, ef_t_uniform(&rng, -2, 2));
            a = b;
            if (ef_plan_push(&p, &m) == EF_ERR_FULL) {
                ef_move_t o;
                EF_CHECK_EQ(ef_plan_pull(&p, &o), EF_OK);
                okc &= o.v_entry == v_prev;
                v_prev = o.v_exit;
                EF_CHECK_EQ(ef_plan_push(&p, &m), EF_OK);
            }
            worst = fmax(worst, bounds_diff(&p));
            if (ef_t_uniform(&rng, 0, 1) < 0.005)
                ef_plan_finish(&p);
            /* Release a random number of moves, checking each exit against the bounds. */
            int k = (int)ef_t_uniform(&rng, 0, 3);
            for (int r = 0; r < k && p.count > 0; r++) {
                const ef_plan_group_t *h = &p.q[p.head];
                double exit_b = 0;
                if (!(h->flags & EF_MOVE_STOP_END) && p.count > 1)
                    exit_b = p.v_lim[(p.head + 1u) % EF_LOOKAHEAD];
                double want = fmin(fmin(exit_b, ref_top(v_prev, h->length, h->a_max, 0)), h->v_max);
                /* the jerk-limited exit is checked by the bounds; a move inside a ramp group
                 * exits where the group's law crosses its end */
                int want_known = j == 0 && p.rel_n == 0 && h->n == 1;
                ef_move_t o;
                if (ef_plan_pull(&p, &o) != EF_OK)
                    break;
                okc &= o.v_entry == v_prev;
                if (want_known && !(o.flags & EF_MOVE_STOP_END))
                    worst_exit = fmax(worst_exit, fabs(o.v_exit - want) / (want + 1e-3));
                v_prev = o.v_exit;
                pulls++;
                worst = fmax(worst, bounds_diff(&p));
            }
        }
        printf("incremental bounds j=%g: %d pulls, worst bound difference %.3g, exit %.3g\n",
               (double)j, pulls, worst, worst_exit);
        EF_CHECK(okc);
        EF_CHECK(pulls > 1000);
        EF_CHECK(worst <= 1e-5);
        EF_CHECK(worst_exit <= 1e-5);
    }
}

/* ------------------------------------------------------------------ ramp groups */

/* A straight run cut into n equal short moves plans as fast as the same run as one move
 * (ramp groups: the moves share one law, the acceleration continuous across their
 * junctions); each move's law is a slice: contiguous in time and speed, ending at tau 1. */
static void groups_case(float j, int n, double seglen, double slack)
{
    static ef_move_t in[4000], out[4000];
    ef_limits_t lim = mk_limits(100, 1000, j, 0.85f);
    double L = n * seglen;
    for (int i = 0; i < n; i++)
        in[i] = mk_line(ef_v3((float)(i * seglen), 0, 0), ef_v3((float)((i + 1) * seglen), 0, 0),
                        100, 0);
    int got = plan_list(&lim, in, n, out);
    EF_CHECK_EQ(got, n);
    ef_move_t one = mk_line(ef_v3(0, 0, 0), ef_v3((float)L, 0, 0), 100, 0), o1;
    EF_CHECK_EQ(plan_list(&lim, &one, 1, &o1), 1);
    double total = 0;
    int cont = 1, ends = 1;
    for (int i = 0; i < got; i++) {
        total += out[i].duration;
        if (i + 1 < got)
            cont &= out[i].v_exit == out[i + 1].v_entry;
        float tau, v;
        ef_timelaw_eval(&out[i], out[i].duration, &tau, &v);
        ends &= tau == 1.0f && fabs(v - out[i].v_exit) <= 1e-3 * 100 + 1e-2;
        ef_timelaw_eval(&out[i], 0, &tau, &v);
        ends &= tau == 0.0f && fabs(v - out[i].v_entry) <= 1e-3 * 100 + 1e-2;
    }
    peaks_t pk = measure_peaks(out, got, j, 1e-3);
    printf("groups j=%g: %d moves of %g mm: %.4f s, one move %.4f s; peak acc/a_max %.4f, "
           "jerk/J %.4f, v/v_max %.5f\n",
           (double)j, n, seglen, total, (double)o1.duration, pk.acc_ratio, pk.jerk_ratio,
           pk.v_ratio);
    EF_CHECK(cont);
    EF_CHECK(ends);
    /* no slower than the single move but for `slack`: group boundaries fall where the
     * groups' own ramps put them, each a junction at zero acceleration */
    EF_CHECK(total <= o1.duration * (1 + slack) + 1e-3);
    EF_CHECK(pk.acc_ratio <= 1.002);
    EF_CHECK(pk.v_ratio <= 1.0001);
    if (j > 0)
        EF_CHECK(pk.jerk_ratio <= 1.01);
}

static void test_groups(void)
{
    /* 0.5 mm moves: a ramp to 100 mm/s (about 7.5 mm with J = 20000) spans 15 of them */
    groups_case(20000, 400, 0.5, 0.001);
    groups_case(0, 400, 0.5, 0.001);
    /* 0.25 mm: a group holds EF_PLAN_GROUP_MAX = 32 moves, 8 mm, just over a ramp */
    groups_case(20000, 800, 0.25, 0.01);
}

/* ------------------------------------------------------------------ (3) window */

/* ef_plan_pull_now(): releases with a short window, interleaved with pushes, as a caller
 * whose input trickles in; speeds chain, the window's last group ends at rest, and every
 * released law is within the limits (ef_plan_timelaw()'s own check is the chain below). */
static void test_pull_now(void)
{
    static ef_plan_t p;
    ef_limits_t lim = mk_limits(1000, 200, 5000, 0.5f);
    EF_CHECK_EQ(ef_plan_init(&p, &lim), EF_OK);
    ef_move_t o;
    EF_CHECK_EQ(ef_plan_pull_now(&p, &o), EF_ERR_AGAIN); /* empty */
    EF_CHECK_EQ(ef_plan_pull_now(NULL, &o), EF_ERR_ARG);
    float v_prev = 0.0f;
    int pulled = 0, rests = 0;
    uint32_t next_seq = 0;
    for (int i = 0; i < 200; i++) {
        ef_move_t m = mk_line(ef_v3((float)i, 0, 0), ef_v3((float)i + 1, 0, 0), 40, 0);
        EF_CHECK_EQ(ef_plan_push(&p, &m), EF_OK);
        /* three in the window at most: release the oldest now */
        while (p.mcount > 3 || (i % 17 == 16 && p.mcount > 0)) {
            EF_CHECK_EQ(ef_plan_pull_now(&p, &o), EF_OK);
            EF_CHECK_EQ(o.seq, next_seq);
            next_seq++;
            EF_CHECK_NEAR(o.v_entry, v_prev, 1e-4);
            EF_CHECK(o.v_exit >= 0.0f && o.v_exit <= o.v_max * 1.0001f);
            EF_CHECK(o.duration > 0.0f);
            v_prev = o.v_exit;
            pulled++;
            if (p.mcount == 0) {
                EF_CHECK_EQ(o.v_exit, 0.0f); /* the window ran empty: at rest */
                rests++;
            }
        }
    }
    while (ef_plan_pull_now(&p, &o) == EF_OK) {
        EF_CHECK_NEAR(o.v_entry, v_prev, 1e-4);
        v_prev = o.v_exit;
        pulled++;
    }
    EF_CHECK_EQ(pulled, 200);
    EF_CHECK_EQ(v_prev, 0.0f);
    EF_CHECK(rests >= 10);
}

static void test_window(void)
{
    static ef_plan_t p;
    ef_limits_t lim = mk_limits(1000, 200, 0, 0.5f);
    EF_CHECK_EQ(ef_plan_init(&p, &lim), EF_OK);
    EF_CHECK_EQ(ef_plan_space(&p), EF_LOOKAHEAD);
    EF_CHECK_EQ(ef_plan_space(NULL), 0);
    ef_move_t o;
    EF_CHECK_EQ(ef_plan_pull(&p, &o), EF_ERR_AGAIN); /* empty */
    for (int i = 0; i < EF_LOOKAHEAD; i++) {
        ef_move_t m = mk_line(ef_v3((float)i, 0, 0), ef_v3((float)i + 1, 0, 0), 20, 0);
        EF_CHECK_EQ(ef_plan_push(&p, &m), EF_OK);
        if (i == 9)
            EF_CHECK_EQ(ef_plan_pull(&p, &o), EF_ERR_AGAIN);
    }
    EF_CHECK_EQ(ef_plan_space(&p), 0);
    ef_move_t extra = mk_line(ef_v3(64, 0, 0), ef_v3(65, 0, 0), 20, 0);
    EF_CHECK_EQ(ef_plan_push(&p, &extra), EF_ERR_FULL);
    EF_CHECK_EQ(p.seq, EF_LOOKAHEAD);
    EF_CHECK_EQ(ef_plan_pull(&p, &o), EF_OK);
    EF_CHECK_EQ(o.seq, 0);
    EF_CHECK_EQ(o.v_entry, 0);
    EF_CHECK(o.v_exit > 0);
    EF_CHECK_EQ(ef_plan_pull(&p, &o), EF_ERR_AGAIN); /* not full any more */
    EF_CHECK_EQ(ef_plan_push(&p, &extra), EF_OK);
    EF_CHECK_EQ(ef_plan_finish(&p), EF_OK);
    uint32_t last = 0;
    int n = 1;
    while (ef_plan_pull(&p, &o) == EF_OK) {
        EF_CHECK_EQ(o.seq, n);
        last = o.seq;
        n++;
    }
    EF_CHECK_EQ(n, EF_LOOKAHEAD + 1);
    EF_CHECK_EQ(last, EF_LOOKAHEAD);
    EF_CHECK_EQ(o.v_exit, 0);
    EF_CHECK_EQ(p.v_last, 0);

    /* a stop inside the window makes everything up to it releasable */
    EF_CHECK_EQ(ef_plan_init(&p, &lim), EF_OK);
    for (int i = 0; i < 5; i++) {
        ef_move_t m = mk_line(ef_v3((float)i, 0, 0), ef_v3((float)i + 1, 0, 0), 20,
                              i == 2 ? EF_MOVE_STOP_END : 0);
        EF_CHECK_EQ(ef_plan_push(&p, &m), EF_OK);
    }
    for (int i = 0; i < 3; i++) {
        EF_CHECK_EQ(ef_plan_pull(&p, &o), EF_OK);
        EF_CHECK_EQ(o.seq, i);
    }
    EF_CHECK_EQ(o.v_exit, 0);
    EF_CHECK_EQ(ef_plan_pull(&p, &o), EF_ERR_AGAIN);
    /* finish, pull one, push more: the moves before the finish point stay releasable and
     * the new ones start from rest */
    EF_CHECK_EQ(ef_plan_finish(&p), EF_OK);
    EF_CHECK_EQ(ef_plan_pull(&p, &o), EF_OK);
    EF_CHECK_EQ(o.v_entry, 0);
    ef_move_t m6 = mk_line(ef_v3(5, 0, 0), ef_v3(6, 0, 0), 20, 0);
    EF_CHECK_EQ(ef_plan_push(&p, &m6), EF_OK);
    EF_CHECK_EQ(ef_plan_pull(&p, &o), EF_OK);
    EF_CHECK_EQ(o.seq, 4);
    EF_CHECK_EQ(o.v_exit, 0);
    EF_CHECK_EQ(ef_plan_pull(&p, &o), EF_ERR_AGAIN);
    EF_CHECK_EQ(ef_plan_finish(&p), EF_OK);
    EF_CHECK_EQ(ef_plan_pull(&p, &o), EF_OK);
    EF_CHECK_EQ(o.seq, 5);
    EF_CHECK_EQ(o.v_entry, 0);
    EF_CHECK_EQ(o.v_exit, 0);

    /* long stream through the window with a stop in the middle */
    enum { N = 700 };
    static ef_move_t in[N], out[N];
    for (int i = 0; i < N; i++) {
        in[i] = mk_line(ef_v3(0.5f * i, 0, 0), ef_v3(0.5f * (i + 1), 0, 0),
                        (i % 37 < 30) ? 40.0f : 15.0f, i == 350 ? EF_MOVE_STOP_END : 0);
    }
    int got = plan_list(&lim, in, N, out);
    EF_CHECK_EQ(got, N);
    int mono = 1, cont = 1, lim_ok = 1;
    for (int i = 0; i < got; i++) {
        mono &= out[i].seq == (uint32_t)i;
        lim_ok &= out[i].v_entry <= out[i].v_max * 1.0001f;
        lim_ok &= out[i].duration > 0 && out[i].duration < 1;
        if (i + 1 < got)
            cont &= out[i].v_exit == out[i + 1].v_entry;
    }
    EF_CHECK(mono);
    EF_CHECK(cont);
    EF_CHECK(lim_ok);
    EF_CHECK_EQ(out[350].v_exit, 0);
    EF_CHECK_EQ(out[351].v_entry, 0);
    EF_CHECK_EQ(out[N - 1].v_exit, 0);
    EF_CHECK(out[200].v_entry > 39.9f); /* cruising at feed well inside the stream */
    peaks_t pk = measure_peaks(out, got, 0, 1e-4);
    printf("stream of %d moves: total %.3f s, peak acc/a_max %.4f, v/v_max %.5f\n", got, pk.total,
           pk.acc_ratio, pk.v_ratio);
    EF_CHECK(pk.acc_ratio <= 1.002);
    EF_CHECK(pk.v_ratio <= 1.0001);
}

/* ------------------------------------------------------------------ (4) axis limits */

static void test_axis_limits(void)
{
    const double S = EF_PLAN_LIMIT_SHARE; /* of every acceleration limit */
    ef_limits_t lim = {{10, 20, 30}, {100, 50, 100}, 0, 0.5f, {0}};
    ef_plan_t p;
    EF_CHECK_EQ(ef_plan_init(&p, &lim), EF_OK);
    ef_move_t m = mk_line(ef_v3(0, 0, 0), ef_v3(10, 10, 0), 100, 0);
    EF_CHECK_EQ(ef_plan_push(&p, &m), EF_OK);
    ef_move_t q = p.mv[p.mhead];
    double c = sqrt(0.5);
    EF_CHECK_NEAR(q.v_max, 10 / c, 1e-3);
    EF_CHECK(q.v_max * m.tabs.x <= 10.0001f && q.v_max * m.tabs.y <= 20.0001f);
    /* a line: the whole budget of its most loaded axis (y: 50 at a tangent share c) */
    double a_path = S * 50 / c;
    EF_CHECK_NEAR(q.a_max, a_path, 1e-3);
    EF_CHECK(q.a_max * c <= 50.001);

    /* centripetal: kappa_max 1 on a z-free curve-like move (no axis parts measured, so
     * every axis counts the whole curvature): the centripetal part takes a_normal_frac of
     * the smallest axis budget at v_max, the tangential ramps what each axis has left */
    ef_move_t k = mk_line(ef_v3(10, 10, 0), ef_v3(20, 20, 0), 100, 0);
    k.kappa_max = 1.0f;
    EF_CHECK_EQ(ef_plan_push(&p, &k), EF_OK);
    ef_move_t kq = p.mv[(p.mhead + 1) % EF_LOOKAHEAD];
    double an = 0.5 * S * 50;
    EF_CHECK_NEAR(kq.v_max, sqrt(an), 1e-3);
    EF_CHECK((double)kq.v_max * kq.v_max * k.kappa_max <= an * 1.0001);
    EF_CHECK_NEAR(kq.a_max, (S * 50 - an) / c, 1e-3);
    /* both parts together keep each axis within its acceleration */
    EF_CHECK(kq.a_max * c + (double)kq.v_max * kq.v_max <= 50.001);
    EF_CHECK(kq.a_max * c + (double)kq.v_max * kq.v_max <= 100.001);
    /* feed is the bound when smaller */
    ef_move_t f = mk_line(ef_v3(20, 20, 0), ef_v3(20, 20, 5), 3, 0);
    EF_CHECK_EQ(ef_plan_push(&p, &f), EF_OK);
    EF_CHECK_NEAR(p.mv[(p.mhead + 2) % EF_LOOKAHEAD].v_max, 3, 1e-6);
    EF_CHECK_NEAR(p.mv[(p.mhead + 2) % EF_LOOKAHEAD].a_max, S * 100, 1e-4); /* z alone */
    /* planned through: speeds stay within every limit */
    ef_plan_finish(&p);
    ef_move_t o[3];
    for (int i = 0; i < 3; i++)
        EF_CHECK_EQ(ef_plan_pull(&p, &o[i]), EF_OK);
    peaks_t pk = measure_peaks(o, 3, 0, 1e-4);
    EF_CHECK(pk.v_ratio <= 1.0001);
    EF_CHECK(pk.acc_ratio <= 1.002);
    EF_CHECK(o[1].v_entry <= kq.v_max * 1.0001f);
}

/* Ramp time 0 -> v at a, j (the S-curve of ef_plan.h), in double. */
static double ramp_time_d(double v, double a, double j)
{
    return v >= a * a / j ? v / a + a / j : 2 * sqrt(v / j);
}

/* A curved move under a jerk limit: a and j share the budget through 3 k_i v a, so the
 * planner's pair must keep every axis's jerk bound and give a ramp from rest to v_max as
 * short as the best pair of a fine scan (the largest a is not it: on a circle of 10 mm at
 * 50 mm/s it leaves the ramps 0.18 J, measured on the LinuxCNC corpus's quantized circle). */
static void test_curved_share(void)
{
    const double S = EF_PLAN_LIMIT_SHARE;
    ef_limits_t lim = {{100, 100, 100}, {1000, 1000, 1000}, 20000, 0.5f, {0}};
    /* circle-like section: R 10 (k 0.1 per axis), kjerk 0.05 / mm^2 (uniform stepping's
     * ripple), and one with a geometric kjerk only (0.01) */
    static const float kj[] = {0.05f, 0.01f, 0.0f};
    int checked = 0;
    for (unsigned c = 0; c < sizeof kj / sizeof kj[0]; c++) {
        ef_move_t m = mk_line(ef_v3(0, 0, 0), ef_v3(1, 0, 0), 50, 0);
        m.tabs = ef_v3(1, 1, 0);
        m.kabs = ef_v3(0.1f, 0.1f, 0);
        m.kjerk = ef_v3(kj[c], kj[c], 0);
        m.kappa_max = 0.1f;
        float v, a, j;
        EF_CHECK_EQ(ef_plan_move_limits(&lim, &m, &v, &a, &j), EF_OK);
        double J = S * 20000, gv = J - kj[c] * (double)v * v * v;
        /* every axis within the jerk and acceleration budget at v_max */
        EF_CHECK(j + 3 * 0.1 * (double)v * a + kj[c] * (double)v * v * v <= J * 1.0001);
        EF_CHECK(a + 0.1 * (double)v * v <= S * 1000 * 1.0001);
        /* the best pair of a fine scan over a, j = what the axes leave */
        double a_full = S * 1000 - 0.1 * (double)v * v, best = 1e30, a_best = 0;
        for (int i = 1; i <= 4000; i++) {
            double aa = a_full * i / 4000, jj = gv - 3 * 0.1 * v * aa;
            if (jj <= 0)
                break;
            double t = ramp_time_d(v, aa, jj);
            if (t < best)
                best = t, a_best = aa;
        }
        double got = ramp_time_d(v, a, j);
        printf("  curved share, kjerk %.2f: v %.1f a %.0f j %.0f ramp %.4f s; best of the scan "
               "a %.0f ramp %.4f s; largest a %.0f ramp %.4f s\n",
               kj[c], v, a, j, got, a_best, best, a_full,
               ramp_time_d(v, a_full, gv - 3 * 0.1 * v * a_full));
        EF_CHECK(got <= best * 1.01);
        checked++;
    }
    EF_CHECK_EQ(checked, 3);
}

/* A move of degree 3 with the given control points, measured. */
static ef_move_t mk_cubic(ef_vec3_t b0, ef_vec3_t b1, ef_vec3_t b2, ef_vec3_t b3, float feed)
{
    ef_move_t m;
    memset(&m, 0, sizeof m);
    m.degree = 3;
    m.kind = EF_MOVE_SMOOTH;
    m.b[0] = b0;
    m.b[1] = b1;
    m.b[2] = b2;
    m.b[3] = b3;
    m.feed = feed;
    EF_CHECK_EQ(ef_move_measure(&m), EF_OK);
    return m;
}

/* Curvature jump at a junction (G1 cubic sections): the entry speed of the move after it is
 * capped so that the acceleration step dk_i v^2 is one the jerk limit makes in
 * EF_PLAN_JUMP_T (the fuzzed case: 1.2 J at 19 mm/s across a jump of 0.2 / mm); a G2
 * junction (a line into a cubic that starts straight) is not capped; without a jerk limit
 * nothing is. */
static void test_curvature_jump(void)
{
    const double S = EF_PLAN_LIMIT_SHARE;
    /* a line along x, then a cubic leaving along x that bends (start curvature 2 b2y / (3
     * (b1x)^2 ... computed below in double), then a long line */
    ef_vec3_t p0 = ef_v3(0, 0, 0), p1 = ef_v3(20, 0, 0);
    ef_move_t l1 = mk_line(p0, p1, 100, 0);
    ef_move_t bend = mk_cubic(p1, ef_v3(21, 0, 0), ef_v3(22, 0.2f, 0), ef_v3(23, 0.6f, 0), 100);
    ef_move_t flat = mk_cubic(p1, ef_v3(21, 0, 0), ef_v3(22, 0, 0), ef_v3(23, 0.6f, 0), 100);
    /* start curvature vector of the bent cubic: f' = 3 (b1 - b0), f'' = 6 (b2 - 2 b1 + b0) */
    double d1x = 3.0, d2y = 6.0 * 0.2, ky = d2y / (d1x * d1x);
    for (int c = 0; c < 3; c++) {
        float J = c == 2 ? 0.0f : 20000.0f;
        ef_limits_t lim = {{100, 100, 100}, {1000, 1000, 1000}, J, 0.5f, {0}};
        ef_plan_t p;
        EF_CHECK_EQ(ef_plan_init(&p, &lim), EF_OK);
        EF_CHECK_EQ(ef_plan_push(&p, &l1), EF_OK);
        EF_CHECK_EQ(ef_plan_push(&p, c == 1 ? &flat : &bend), EF_OK);
        ef_move_t l2 = mk_line((c == 1 ? flat : bend).b[3], ef_v3(43, 0.6f, 0), 100, 0);
        EF_CHECK_EQ(ef_plan_push(&p, &l2), EF_OK);
        ef_plan_finish(&p);
        ef_move_t o[3];
        for (int i = 0; i < 3; i++)
            EF_CHECK_EQ(ef_plan_pull(&p, &o[i]), EF_OK);
        double vj = o[1].v_entry, cap = sqrt(EF_PLAN_JUMP_T * S * 20000 / ky);
        printf("  curvature jump %s, J %.0f: junction speed %.3f mm/s (cap %.3f, move v_max "
               "%.3f)\n",
               c == 1 ? "none (G2)" : "0.13 / mm", J, vj, cap, o[1].v_max);
        EF_CHECK_NEAR(o[1].v_entry, o[0].v_exit, 1e-4);
        if (c == 0) {
            EF_CHECK(vj <= cap * 1.001);
            EF_CHECK(vj >= cap * 0.99); /* the cap binds, nothing else here does */
        } else {
            EF_CHECK(vj > cap * 1.5); /* G2, or no jerk limit: only the move's own limits */
        }
    }
}

/* ------------------------------------------------------------------ (5) interpolator */

typedef struct {
    int n;
    double max_jump_ratio; /* |dp| / (v dt) worst, v the larger planned speed */
    double max_speed_err;  /* | |dp|/dt - mean v_plan | on lines (units/s) */
    ef_vec3_t last;
    int end_idle;
} run_t;

/* Run planned moves through the interpolator at period_us until idle. */
static run_t run_interp(ef_move_t *ms, int n, int mode, uint32_t period_us, ef_vec3_t home,
                        double *fluct_out)
{
    run_t r = {0, 0, 0, home, 0};
    ef_interp_t ip;
    EF_CHECK_EQ(ef_interp_init(&ip, home, period_us, mode), EF_OK);
    int next = 0;
    ef_setpoint_t sp, prev;
    memset(&prev, 0, sizeof prev);
    prev.p = home;
    double dt = period_us * 1e-6, fluct = 0, vmax = 0;
    for (int i = 0; i < n; i++)
        vmax = fmax(vmax, ms[i].v_max);
    int idle_seen = 0;
    for (long step = 0; step < 10000000 && idle_seen < 5; step++) {
        while (next < n && ef_interp_space(&ip) > 0)
            EF_CHECK_EQ(ef_interp_push(&ip, &ms[next++]), EF_OK);
        uint32_t nus = 0;
        int rc = ef_interp_process(&ip, period_us, &nus, &sp);
        EF_CHECK_EQ(rc, EF_OK);
        EF_CHECK_EQ(nus, period_us);
        double dx = (double)sp.p.x - prev.p.x, dy = (double)sp.p.y - prev.p.y,
               dz = (double)sp.p.z - prev.p.z;
        double dp = sqrt(dx * dx + dy * dy + dz * dz);
        double vref = fmax(sp.v_plan, prev.v_plan);
        /* allowance: float32 resolution of the coordinates (ulp near 20 is 2e-6) */
        double jr = (dp - 1e-5) / (fmax(vref, 1e-9) * dt);
        if (jr > r.max_jump_ratio)
            r.max_jump_ratio = jr;
        if (sp.moving && prev.moving && sp.seq == prev.seq && step > 0) {
            double e = fabs(dp / dt - 0.5 * (sp.v_plan + prev.v_plan));
            r.max_speed_err = fmax(r.max_speed_err, e);
            fluct = fmax(fluct, e / vmax);
        }
        if (!sp.moving) {
            idle_seen++;
            EF_CHECK_EQ(sp.v_plan, 0);
        }
        prev = sp;
        r.n++;
    }
    r.last = sp.p;
    r.end_idle = idle_seen >= 5 && next == n;
    if (fluct_out)
        *fluct_out = fluct;
    return r;
}

static void test_interp_lines(void)
{
    ef_limits_t lim = mk_limits(1000, 400, 5000, 0.5f);
    enum { N = 12 };
    static ef_move_t in[N], out[N];
    ef_vec3_t p = ef_v3(1, 2, 3);
    for (int i = 0; i < N; i++) {
        ef_vec3_t q =
            i < 6 ? ef_v3_add(p, ef_v3(3.0f + (float)i, 0, 0)) : ef_v3_add(p, ef_v3(0, 2.5f, 0.5f));
        in[i] = mk_line(p, q, i % 3 == 1 ? 15.0f : 40.0f, i == 5 ? EF_MOVE_STOP_END : 0);
        p = q;
    }
    int n = plan_list(&lim, in, N, out);
    EF_CHECK_EQ(n, N);
    double total = 0;
    for (int i = 0; i < n; i++)
        total += out[i].duration;
    for (int mode = 0; mode < 2; mode++) {
        run_t r = run_interp(out, n, mode, 1000, ef_v3(1, 2, 3), NULL);
        printf("interp lines (%s): %d samples for %.4f s, worst |dp|/(v dt) %.4f, "
               "worst speed error %.4g units/s\n",
               mode ? "corrected" : "uniform", r.n, total, r.max_jump_ratio, r.max_speed_err);
        EF_CHECK(r.end_idle);
        EF_CHECK_EQ(r.last.x, out[n - 1].b[1].x);
        EF_CHECK_EQ(r.last.y, out[n - 1].b[1].y);
        EF_CHECK_EQ(r.last.z, out[n - 1].b[1].z);
        EF_CHECK(r.max_jump_ratio <= 1.01);
        EF_CHECK(r.max_speed_err < 0.05);
        EF_CHECK(fabs(r.n - 5 - total / 1e-3) <= 2); /* time chains exactly */
    }
}

/* A curve longer than EF_INTERP_CORRECTED_MAX_LEN is stepped uniformly even in corrected
 * mode: the fuzzed case, a 199 m quintic along z at 50 mm/s (a cruise phase of 3973 s),
 * whose corrected steps drifted 20 mm behind the law and resynchronised with a 3 m jump.
 * Over 3000 s of it every step stays within the law's 0.05 mm per period (plus float32
 * rounding at 1e5 mm) and the curve is followed to its end. */
static void test_interp_long_curve(void)
{
    ef_move_t m;
    memset(&m, 0, sizeof m);
    m.degree = 5;
    for (int i = 0; i < 6; i++)
        m.b[i] = ef_v3(-0.53f - 0.075f * (float)i, 1.55f + 0.003f * (float)(i * (5 - i)),
                       39733.8867f * (float)i);
    EF_CHECK_EQ(ef_move_measure(&m), EF_OK);
    EF_CHECK(m.length > EF_INTERP_CORRECTED_MAX_LEN);
    m.v_entry = m.v_exit = m.v_max = 50.0f;
    m.feed = 50.0f;
    m.duration = m.length / 50.0f;
    m.law.dt[0] = m.duration;
    m.law.c[0][1] = 1.0f / m.duration;
    static ef_interp_t ip;
    EF_CHECK_EQ(ef_interp_init(&ip, m.b[0], 1000, EF_STEP_CORRECTED), EF_OK);
    EF_CHECK_EQ(ef_interp_push(&ip, &m), EF_OK);
    ef_setpoint_t sp;
    ef_vec3_t prev = m.b[0];
    double worst = 0;
    for (long k = 0; k < 3000000; k++) {
        EF_CHECK_EQ(ef_interp_process(&ip, 1000, NULL, &sp), EF_OK);
        worst = fmax(worst, ef_v3_norm(ef_v3_sub(sp.p, prev)));
        prev = sp.p;
    }
    printf("interp: 199 m quintic, corrected mode: largest step per period %.4f mm\n", worst);
    EF_CHECK(worst < 0.05 + 0.06);
    /* the law ends at speed (nothing follows): an underrun, holding the end */
    EF_CHECK_EQ(ef_interp_process(&ip, 0xFFFFFFFFu, NULL, &sp), EF_ERR_UNDERRUN);
    EF_CHECK_EQ(sp.moving, 0);
    EF_CHECK(sp.p.z == m.b[5].z);
}

static void test_interp_underrun_wrap(void)
{
    ef_interp_t ip;
    ef_setpoint_t sp;
    EF_CHECK_EQ(ef_interp_init(&ip, ef_v3(0, 0, 0), 1000, EF_STEP_UNIFORM), EF_OK);
    /* idle at rest */
    EF_CHECK_EQ(ef_interp_process(&ip, 1000, NULL, &sp), EF_OK);
    EF_CHECK_EQ(sp.moving, 0);
    ef_move_t a = mk_line(ef_v3(0, 0, 0), ef_v3(10, 0, 0), 20, 0);
    a.v_max = 20;
    a.a_max = 100;
    a.v_entry = 0;
    a.v_exit = 10;
    EF_CHECK_EQ(ef_plan_timelaw(&a, 0), EF_OK);
    EF_CHECK_EQ(a.v_exit, 10);
    ef_move_t bad = mk_line(ef_v3(10, 0.01f, 0), ef_v3(20, 0, 0), 20, 0);
    bad.duration = 1;
    EF_CHECK_EQ(ef_interp_push(&ip, &bad), EF_ERR_ARG); /* does not join home */
    EF_CHECK_EQ(ef_interp_push(&ip, &a), EF_OK);
    EF_CHECK_EQ(ef_interp_push(&ip, &bad), EF_ERR_ARG); /* does not join a's end */
    int rc = EF_OK, steps = 0;
    while (rc == EF_OK && steps < 100000) {
        rc = ef_interp_process(&ip, 1000, NULL, &sp);
        steps++;
    }
    EF_CHECK_EQ(rc, EF_ERR_UNDERRUN);
    EF_CHECK_EQ(sp.p.x, 10.0f);
    EF_CHECK_EQ(sp.moving, 0);
    EF_CHECK_NEAR(steps * 1e-3, a.duration, 1.5e-3);
    rc = ef_interp_process(&ip, 1000, NULL, &sp);
    EF_CHECK_EQ(rc, EF_ERR_UNDERRUN); /* holds */
    EF_CHECK_EQ(sp.p.x, 10.0f);
    /* continue with a move joining the held end, ending at rest */
    ef_move_t b = mk_line(ef_v3(10, 0, 0), ef_v3(20, 0, 0), 20, 0);
    b.v_max = 20;
    b.a_max = 100;
    b.v_entry = 10;
    b.v_exit = 0;
    EF_CHECK_EQ(ef_plan_timelaw(&b, 0), EF_OK);
    EF_CHECK_EQ(ef_interp_push(&ip, &b), EF_OK);
    EF_CHECK_EQ(ef_interp_process(&ip, 1000, NULL, &sp), EF_OK);
    EF_CHECK_EQ(sp.moving, 1);
    EF_CHECK(sp.p.x > 10.0f && sp.p.x < 10.02f);
    /* a huge dt (counter wrapped by the caller: now - prev in uint32) runs it out */
    uint32_t prev_us = 0xFFFFFC18u, now_us = 0x00000000u;
    uint32_t d = now_us - prev_us;
    EF_CHECK_EQ(d, 1000);
    EF_CHECK_EQ(ef_interp_process(&ip, d, NULL, &sp), EF_OK);
    EF_CHECK_EQ(ef_interp_process(&ip, 0xFFFFFFFFu, NULL, &sp), EF_OK);
    EF_CHECK_EQ(sp.moving, 0);
    EF_CHECK_EQ(sp.p.x, 20.0f);
    EF_CHECK_EQ(ef_interp_process(&ip, 0xFFFFFFFFu, NULL, &sp), EF_OK);
    EF_CHECK_EQ(sp.p.x, 20.0f);

    /* several moves consumed by one huge step, chained */
    EF_CHECK_EQ(ef_interp_init(&ip, ef_v3(0, 0, 0), 1000, EF_STEP_CORRECTED), EF_OK);
    ef_move_t c0 = a, c1 = b;
    c1.b[0] = ef_v3(10, 0, 0);
    EF_CHECK_EQ(ef_interp_push(&ip, &c0), EF_OK);
    EF_CHECK_EQ(ef_interp_push(&ip, &c1), EF_OK);
    EF_CHECK_EQ(ef_interp_space(&ip), EF_INTERP_QUEUE - 2);
    EF_CHECK_EQ(ef_interp_process(&ip, 0xFFFFFFF0u, NULL, &sp), EF_OK);
    EF_CHECK_EQ(sp.p.x, 20.0f);
    EF_CHECK_EQ(sp.moving, 0);
    EF_CHECK_EQ(sp.seq, c1.seq);
    /* leftover time carried exactly: stepping across the boundary at a time inside c1 */
    EF_CHECK_EQ(ef_interp_init(&ip, ef_v3(0, 0, 0), 1000, EF_STEP_UNIFORM), EF_OK);
    EF_CHECK_EQ(ef_interp_push(&ip, &c0), EF_OK);
    EF_CHECK_EQ(ef_interp_push(&ip, &c1), EF_OK);
    uint32_t t_us = (uint32_t)(c0.duration * 1e6f) + 50000u;
    EF_CHECK_EQ(ef_interp_process(&ip, t_us, NULL, &sp), EF_OK);
    float tau, v;
    ef_timelaw_eval(&c1, (float)t_us * 1e-6f - c0.duration, &tau, &v);
    EF_CHECK_NEAR(sp.p.x, 10 + 10 * tau, 1e-4);
    EF_CHECK_NEAR(sp.v_plan, v, 1e-3);

    /* queue full */
    EF_CHECK_EQ(ef_interp_init(&ip, ef_v3(0, 0, 0), 1000, EF_STEP_UNIFORM), EF_OK);
    ef_move_t z = a;
    for (int i = 0; i < EF_INTERP_QUEUE; i++) {
        z.b[0] = ef_v3(0, 0, 0);
        z.b[1] = ef_v3(0, 0, 0); /* a closed loop (zero chord) is still a valid join */
        z.b[1] = z.b[0];
        z.b[1].x = (i % 2) ? 0.0f : 10.0f;
        z.b[0].x = (i % 2) ? 10.0f : 0.0f;
        EF_CHECK_EQ(ef_interp_push(&ip, &z), EF_OK);
    }
    z.b[0] = ip.end;
    EF_CHECK_EQ(ef_interp_push(&ip, &z), EF_ERR_FULL);
    EF_CHECK_EQ(ef_interp_space(&ip), 0);
}

/* ------------------------------------------------------------------ (6) feed fluctuation */

static void fluct_case(const char *name, const ef_vec3_t *b, int uneven)
{
    ef_move_t m;
    memset(&m, 0, sizeof m);
    m.degree = 5;
    m.kind = EF_MOVE_ARC;
    for (int i = 0; i < 6; i++)
        m.b[i] = b[i];
    m.feed = 20;
    double ratio = measure_curve(&m);
    ef_limits_t lim = mk_limits(1000, 400, 0, 0.5f);
    ef_move_t o;
    EF_CHECK_EQ(plan_list(&lim, &m, 1, &o), 1);
    double fu = 0, fc = 0;
    run_t ru = run_interp(&o, 1, EF_STEP_UNIFORM, 1000, b[0], &fu);
    run_t rc = run_interp(&o, 1, EF_STEP_CORRECTED, 1000, b[0], &fc);
    printf("feed fluctuation on %s quintic (|f'| max/min %.3f, L %.4f, v_max %.3f): "
           "uniform %.4f%%, corrected %.4f%% of v_max\n",
           name, ratio, (double)o.length, (double)o.v_max, 100 * fu, 100 * fc);
    EF_CHECK(ru.end_idle && rc.end_idle);
    EF_CHECK_EQ(rc.last.x, b[5].x);
    EF_CHECK_EQ(rc.last.y, b[5].y);
    EF_CHECK(rc.max_jump_ratio < 1.05);
    if (uneven) {
        EF_CHECK(fu > 0.05);   /* the curve really is uneven */
        EF_CHECK(fc * 5 < fu); /* corrected at least five times smaller */
        EF_CHECK(fc < 0.01);
    } else {
        EF_CHECK(fu < 0.05);
        EF_CHECK(fc <= fu * 1.5 + 1e-3);
    }
}

static void test_fluctuation(void)
{
    /* near-even: quarter circle r = 10 as the degree-5 elevation of the standard cubic
     * (handles 4/3 tan(pi/8) r), which has near-constant parametric speed */
    double k = 4.0 / 3.0 * tan(M_PI / 8) * 10;
    double c3[4][2] = {{10, 0}, {10, k}, {k, 10}, {0, 10}};
    double c4[5][2], c5[6][2];
    for (int i = 0; i <= 4; i++)
        for (int c = 0; c < 2; c++)
            c4[i][c] = (i == 0   ? c3[0][c]
                        : i == 4 ? c3[3][c]
                                 : (i / 4.0) * c3[i - 1][c] + (1 - i / 4.0) * c3[i][c]);
    for (int i = 0; i <= 5; i++)
        for (int c = 0; c < 2; c++)
            c5[i][c] = (i == 0   ? c4[0][c]
                        : i == 5 ? c4[4][c]
                                 : (i / 5.0) * c4[i - 1][c] + (1 - i / 5.0) * c4[i][c]);
    ef_vec3_t even[6];
    for (int i = 0; i < 6; i++)
        even[i] = ef_v3((float)c5[i][0], (float)c5[i][1], 0);
    fluct_case("near-even arc", even, 0);
    /* uneven: control points on the same arc at angles crowding towards the start, so the
     * parametric speed grows along the curve */
    ef_vec3_t unev[6];
    for (int i = 0; i < 6; i++) {
        double th = M_PI / 2 * pow(i / 5.0, 1.8);
        unev[i] = ef_v3((float)(10 * cos(th)), (float)(10 * sin(th)), 0);
    }
    fluct_case("uneven arc", unev, 1);
}

/* ------------------------------------------------------------------ (7) bad input */

static void test_bad_input(void)
{
    ef_limits_t good = mk_limits(100, 100, 0, 0.5f);
    EF_CHECK_EQ(ef_limits_check(&good), EF_OK);
    EF_CHECK_EQ(ef_limits_check(NULL), EF_ERR_ARG);
    ef_limits_t l = good;
    l.v_axis[1] = NAN;
    EF_CHECK_EQ(ef_limits_check(&l), EF_ERR_NONFINITE);
    l = good;
    l.a_axis[2] = INFINITY;
    EF_CHECK_EQ(ef_limits_check(&l), EF_ERR_NONFINITE);
    l = good;
    l.v_axis[0] = 0;
    EF_CHECK_EQ(ef_limits_check(&l), EF_ERR_FEED);
    l = good;
    l.a_axis[0] = -1;
    EF_CHECK_EQ(ef_limits_check(&l), EF_ERR_FEED);
    l = good;
    l.j_max = -1;
    EF_CHECK_EQ(ef_limits_check(&l), EF_ERR_FEED);
    l = good;
    l.a_normal_frac = 0;
    EF_CHECK_EQ(ef_limits_check(&l), EF_ERR_ARG);
    l.a_normal_frac = 1;
    EF_CHECK_EQ(ef_limits_check(&l), EF_ERR_ARG);
    l.a_normal_frac = NAN;
    EF_CHECK_EQ(ef_limits_check(&l), EF_ERR_NONFINITE);

    static ef_plan_t p, saved;
    EF_CHECK_EQ(ef_plan_init(NULL, &good), EF_ERR_ARG);
    l = good;
    l.v_axis[2] = -5;
    EF_CHECK_EQ(ef_plan_init(&p, &l), EF_ERR_FEED);
    EF_CHECK_EQ(ef_plan_init(&p, &good), EF_OK);
    ef_move_t ok = mk_line(ef_v3(0, 0, 0), ef_v3(1, 0, 0), 10, 0);
    EF_CHECK_EQ(ef_plan_push(&p, &ok), EF_OK);
    memcpy(&saved, &p, sizeof p);

    ef_move_t m = ok;
    m.b[1].y = NAN;
    EF_CHECK_EQ(ef_plan_push(&p, &m), EF_ERR_NONFINITE);
    m = ok;
    m.b[0].z = 2e6f; /* beyond EF_MAX_COORD */
    EF_CHECK_EQ(ef_plan_push(&p, &m), EF_ERR_NONFINITE);
    m = ok;
    m.length = NAN;
    EF_CHECK_EQ(ef_plan_push(&p, &m), EF_ERR_NONFINITE);
    m = ok;
    m.kappa_max = INFINITY;
    EF_CHECK_EQ(ef_plan_push(&p, &m), EF_ERR_NONFINITE);
    m = ok;
    m.tabs.x = NAN;
    EF_CHECK_EQ(ef_plan_push(&p, &m), EF_ERR_NONFINITE);
    m = ok;
    m.feed = NAN;
    EF_CHECK_EQ(ef_plan_push(&p, &m), EF_ERR_NONFINITE);
    m = ok;
    m.feed = 0;
    EF_CHECK_EQ(ef_plan_push(&p, &m), EF_ERR_FEED);
    m.feed = -3;
    EF_CHECK_EQ(ef_plan_push(&p, &m), EF_ERR_FEED);
    m = ok;
    m.degree = 2;
    EF_CHECK_EQ(ef_plan_push(&p, &m), EF_ERR_ARG);
    m.degree = 0;
    EF_CHECK_EQ(ef_plan_push(&p, &m), EF_ERR_ARG);
    m = ok;
    m.length = 0;
    EF_CHECK_EQ(ef_plan_push(&p, &m), EF_ERR_ARG);
    m.length = -1;
    EF_CHECK_EQ(ef_plan_push(&p, &m), EF_ERR_ARG);
    m = ok;
    m.kappa_max = -1;
    EF_CHECK_EQ(ef_plan_push(&p, &m), EF_ERR_ARG);
    m = ok;
    m.tabs = ef_v3(0, 0, 0);
    EF_CHECK_EQ(ef_plan_push(&p, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_plan_push(&p, NULL), EF_ERR_ARG);
    EF_CHECK_EQ(ef_plan_push(NULL, &ok), EF_ERR_ARG);
    EF_CHECK(memcmp(&saved, &p, sizeof p) == 0); /* no state change */
    ef_move_t o;
    EF_CHECK_EQ(ef_plan_pull(&p, NULL), EF_ERR_ARG);
    EF_CHECK_EQ(ef_plan_pull(NULL, &o), EF_ERR_ARG);
    EF_CHECK_EQ(ef_plan_finish(NULL), EF_ERR_ARG);
    EF_CHECK(memcmp(&saved, &p, sizeof p) == 0);

    /* time law */
    EF_CHECK_EQ(ef_plan_timelaw(NULL, 0), EF_ERR_ARG);
    m = ok;
    m.v_max = 10;
    m.a_max = 50;
    m.v_entry = 0;
    m.v_exit = -1;
    EF_CHECK_EQ(ef_plan_timelaw(&m, 0), EF_ERR_ARG);
    m.v_exit = NAN;
    EF_CHECK_EQ(ef_plan_timelaw(&m, 0), EF_ERR_ARG);
    m.v_exit = 0;
    m.length = 0;
    EF_CHECK_EQ(ef_plan_timelaw(&m, 0), EF_ERR_ARG);
    m.length = 1;
    EF_CHECK_EQ(ef_plan_timelaw(&m, -1), EF_ERR_ARG);
    /* unreachable exit lowered to what the length allows */
    m.v_exit = 100;
    EF_CHECK_EQ(ef_plan_timelaw(&m, 0), EF_OK);
    EF_CHECK_NEAR(m.v_exit, 10, 1e-4); /* capped at v_max: sqrt(2 a L) = 10 */
    m.v_max = 1000;
    m.v_exit = 100;
    EF_CHECK_EQ(ef_plan_timelaw(&m, 0), EF_OK);
    EF_CHECK_NEAR(m.v_exit, 10, 1e-3);
    EF_CHECK(m.duration > 0 && m.duration < 1);
    m.v_entry = 100;
    m.v_exit = 0; /* cannot stop: exit raised */
    EF_CHECK_EQ(ef_plan_timelaw(&m, 500), EF_OK);
    EF_CHECK(m.v_exit > 0 && m.duration > 0);
    float tau, v;
    EF_CHECK_EQ(ef_timelaw_eval(NULL, 0, &tau, &v), EF_ERR_ARG);
    EF_CHECK_EQ(ef_timelaw_eval(&m, 0, NULL, &v), EF_ERR_ARG);
    EF_CHECK_EQ(ef_timelaw_eval(&m, NAN, &tau, NULL), EF_OK);
    EF_CHECK(tau == tau);
    EF_CHECK_EQ(ef_timelaw_eval(&m, -5, &tau, &v), EF_OK);
    EF_CHECK_EQ(tau, 0);

    /* interpolator */
    ef_interp_t ip;
    EF_CHECK_EQ(ef_interp_init(NULL, ef_v3(0, 0, 0), 1000, 0), EF_ERR_ARG);
    EF_CHECK_EQ(ef_interp_init(&ip, ef_v3(0, 0, 0), 0, 0), EF_ERR_ARG);
    EF_CHECK_EQ(ef_interp_init(&ip, ef_v3(0, 0, 0), 1000, 7), EF_ERR_ARG);
    EF_CHECK_EQ(ef_interp_init(&ip, ef_v3(NAN, 0, 0), 1000, 0), EF_ERR_NONFINITE);
    EF_CHECK_EQ(ef_interp_init(&ip, ef_v3(0, 0, 0), 1000, 0), EF_OK);
    ef_interp_t isaved;
    memcpy(&isaved, &ip, sizeof ip);
    m = ok;
    m.v_max = 10;
    m.a_max = 50;
    m.v_entry = m.v_exit = 0;
    EF_CHECK_EQ(ef_plan_timelaw(&m, 0), EF_OK);
    ef_move_t mm = m;
    mm.degree = 2;
    EF_CHECK_EQ(ef_interp_push(&ip, &mm), EF_ERR_ARG);
    mm = m;
    mm.duration = 0;
    EF_CHECK_EQ(ef_interp_push(&ip, &mm), EF_ERR_ARG);
    mm.duration = NAN;
    EF_CHECK_EQ(ef_interp_push(&ip, &mm), EF_ERR_ARG);
    mm = m;
    mm.law.c[1][1] = INFINITY;
    EF_CHECK_EQ(ef_interp_push(&ip, &mm), EF_ERR_ARG);
    mm = m;
    mm.b[1].x = NAN;
    EF_CHECK_EQ(ef_interp_push(&ip, &mm), EF_ERR_ARG);
    EF_CHECK_EQ(ef_interp_push(&ip, NULL), EF_ERR_ARG);
    EF_CHECK(memcmp(&isaved, &ip, sizeof ip) == 0);
    ef_setpoint_t sp;
    EF_CHECK_EQ(ef_interp_process(&ip, 1000, NULL, NULL), EF_ERR_ARG);
    EF_CHECK_EQ(ef_interp_process(NULL, 1000, NULL, &sp), EF_ERR_ARG);
    EF_CHECK_EQ(ef_interp_space(NULL), 0);
}

/* Usage: test_plan [plan|interp] (no argument: both). */
static void chain_case_0(void)
{
    chain_case(0);
}

static void chain_case_2000(void)
{
    chain_case(2000);
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"plan", test_single_line},
        {"plan", chain_case_0},
        {"plan", chain_case_2000},
        {"plan", test_window},
        {"plan", test_pull_now},
        {"plan", test_axis_limits},
        {"plan", test_curved_share},
        {"plan", test_curvature_jump},
        {"plan", test_random_streams},
        {"plan", test_incremental_bounds},
        {"plan", test_groups},
        {"interp", test_interp_lines},
        {"interp", test_interp_underrun_wrap},
        {"interp", test_interp_long_curve},
        {"interp", test_fluctuation},
        {"bad", test_bad_input},
    };
    return EF_TEST_RUN(argc, argv, 1, parts);
}
