/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Auxiliary axes (A B C U V W) through the smoother, the planner and the interpolator
 * (ef_smooth.h, "Auxiliary axes"; docs/axes.md). Every run is executed by the interpolator
 * at 1 ms and checked from the float32 setpoints as a drive receives them: each auxiliary
 * axis within its speed, acceleration and jerk limit (differences as tests/motion/
 * ef_sp_check.h forms them, which also checks X Y Z), the chain continuous on every axis,
 * each axis at its programmed value at the end, and the blends' deviation within the
 * axis's tolerance. Then the rules: blends carry rate changes, an axis's limits bound the
 * path speed, auxiliary moves alone, exact stops where no blend can carry a change, and
 * bad input.
 */
#include <string.h>
#include "ef_test.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/motion/ef_interp.h"
#include "evenfeed/motion/ef_smooth.h"
#include "motion/ef_sp_check.h"

extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;

#define MAXM  20000
#define MAXSP 400000
#define DT    1e-3

static ef_smooth_t S;
static ef_interp_t IP;
static ef_move_t M[MAXM];
static int NM;
static ef_setpoint_t SP[MAXSP];
static int NSP;

static ef_smooth_cfg_t cfg_axes(int naux)
{
    ef_smooth_cfg_t c;
    memset(&c, 0, sizeof c);
    c.g2 = &ef_tbl_g2_default;
    c.g1 = &ef_tbl_g1_default;
    for (int i = 0; i < 3; i++) {
        c.lim.v_axis[i] = 200.0f;
        c.lim.a_axis[i] = 2000.0f;
    }
    for (int k = 0; k < naux; k++) {
        c.lim.v_axis[3 + k] = 90.0f + 10.0f * (float)k; /* deg/s (A B C) or mm/s */
        c.lim.a_axis[3 + k] = 500.0f + 100.0f * (float)k;
        c.aux_tol[k] = 0.02f;
    }
    c.lim.j_max = 20000.0f;
    c.lim.a_normal_frac = 0.5f;
    c.micro_len = 1.0f;
    c.micro_turn = 0.35f;
    c.keep_slow_blends = 1;
    c.smooth_degree = 5;
    c.naux = (uint8_t)naux;
    return c;
}

static ef_prim_t line(float x, float y, float z, const float *aux, float feed)
{
    ef_prim_t p;
    memset(&p, 0, sizeof p);
    p.kind = EF_PRIM_LINE;
    p.end = ef_v3(x, y, z);
    p.feed = feed;
    p.tol = 0.05f;
    p.qtol = 0.05f;
    for (int k = 0; k < EF_AUX && aux; k++)
        p.aux[k] = aux[k];
    return p;
}

static int drain(void)
{
    int rc;
    while ((rc = ef_smooth_pull(&S, &M[NM])) == EF_OK)
        if (NM < MAXM - 1)
            NM++;
    return rc;
}

/* Smooth a program into M (pushes retried after pulls; then finished). Returns the first
 * refusal of a push, or EF_OK. */
static int smooth(const ef_smooth_cfg_t *c, const ef_prim_t *pr, int n)
{
    NM = 0;
    EF_CHECK_EQ(ef_smooth_init(&S, c, ef_v3(0, 0, 0)), EF_OK);
    for (int i = 0; i < n; i++) {
        int rc = ef_smooth_push(&S, &pr[i]);
        for (int g = 0; rc == EF_ERR_FULL && g < 100000; g++) {
            drain();
            rc = ef_smooth_push(&S, &pr[i]);
        }
        if (rc != EF_OK)
            return rc;
    }
    int rc = EF_ERR_FULL;
    for (int g = 0; rc == EF_ERR_FULL && g < 1000000; g++) {
        rc = ef_smooth_finish(&S);
        drain();
    }
    EF_CHECK_EQ(rc, EF_OK);
    return EF_OK;
}

/* Execute M in the interpolator (corrected stepping) into SP. */
static void execute(void)
{
    NSP = 0;
    EF_CHECK_EQ(ef_interp_init(&IP, ef_v3(0, 0, 0), 1000, EF_STEP_CORRECTED), EF_OK);
    int next = 0;
    for (int g = 0; g < MAXSP; g++) {
        while (next < NM && ef_interp_space(&IP) > 0) {
            EF_CHECK_EQ(ef_interp_push(&IP, &M[next]), EF_OK);
            next++;
        }
        ef_setpoint_t sp;
        int rc = ef_interp_process(&IP, 1000, NULL, &sp);
        EF_CHECK(rc == EF_OK);
        if (NSP < MAXSP)
            SP[NSP++] = sp;
        if (next == NM && !sp.moving)
            break;
    }
}

typedef struct {
    double v[EF_AUX_N], a[EF_AUX_N], j[EF_AUX_N]; /* largest |difference| / limit */
    double vmax_path;                             /* largest X Y Z step / dt */
} peaks_t;

/* The setpoint checks of the file comment over SP, for naux axes; X Y Z by ef_sp_check.h. */
static peaks_t check_setpoints(const ef_smooth_cfg_t *c, int naux, const ef_prim_t *last)
{
    peaks_t pk;
    memset(&pk, 0, sizeof pk);
    spc_t xyz;
    spc_init(&xyz, DT, &c->lim);
    double lmax = 0, amag = 0;
    for (int i = 0; i < NM; i++) {
        spc_scale(&xyz, M[i].length);
        lmax = fmax(lmax, M[i].length);
    }
    for (int i = 0; i < NSP; i++) {
        spc_push(&xyz, i * DT, &SP[i]);
        for (int k = 0; k < naux; k++)
            amag = fmax(amag, fabs(SP[i].aux[k]));
    }
    EF_CHECK(spc_ok(&xyz));
    if (!spc_ok(&xyz))
        spc_report(&xyz, "xyz", stderr);
    /* float32 margin, as ef_sp_check.h: E = 2^-23 (|a| + 4 L) */
    double E = (amag + 4.0 * lmax * 10.0) / 8388608.0;
    const int h = 5;
    for (int k = 0; k < naux; k++) {
        double V = c->lim.v_axis[3 + k], A = c->lim.a_axis[3 + k];
        double J = c->lim.j_aux[k] > 0 ? c->lim.j_aux[k] : c->lim.j_max;
        for (int i = 1; i < NSP; i++) {
            double v = fabs((double)SP[i].aux[k] - SP[i - 1].aux[k]) / DT;
            pk.v[k] = fmax(pk.v[k], v / (V * 1.02 + 2 * E / DT));
            if (i >= 2) {
                double a = fabs((double)SP[i].aux[k] - 2.0 * SP[i - 1].aux[k] + SP[i - 2].aux[k]) /
                           (DT * DT);
                pk.a[k] = fmax(pk.a[k], a / (A * 1.02 + 4 * E / (DT * DT)));
            }
            if (i >= 3 * h) {
                double d = (double)SP[i].aux[k] - 3.0 * SP[i - h].aux[k] +
                           3.0 * SP[i - 2 * h].aux[k] - SP[i - 3 * h].aux[k];
                double hd = h * DT;
                pk.j[k] =
                    fmax(pk.j[k], fabs(d) / (hd * hd * hd) / (J * 1.02 + 8 * E / (hd * hd * hd)));
            }
        }
        EF_CHECK(pk.v[k] <= 1.0);
        EF_CHECK(pk.a[k] <= 1.0);
        EF_CHECK(pk.j[k] <= 1.0);
        if (pk.v[k] > 1.0 || pk.a[k] > 1.0 || pk.j[k] > 1.0)
            fprintf(stderr, "axis %d: speed %.4f, acceleration %.4f, jerk %.4f of allowed\n", k,
                    pk.v[k], pk.a[k], pk.j[k]);
    }
    for (int i = 1; i < NSP; i++) {
        ef_vec3_t d = ef_v3_sub(SP[i].p, SP[i - 1].p);
        pk.vmax_path = fmax(pk.vmax_path, ef_v3_norm(d) / DT);
    }
    /* the chain: every move starts where the one before ended, on every axis */
    for (int i = 1; i < NM; i++) {
        EF_CHECK(ef_v3_norm(ef_v3_sub(M[i].b[0], M[i - 1].b[M[i - 1].degree])) <= 1e-6f);
        for (int k = 0; k < naux; k++)
            EF_CHECK(M[i].ab[k][0] == M[i - 1].ab[k][M[i - 1].degree]);
    }
    /* the end: every axis at its programmed value, at rest */
    const ef_setpoint_t *e = &SP[NSP - 1];
    EF_CHECK(!e->moving);
    EF_CHECK(ef_v3_norm(ef_v3_sub(e->p, last->end)) <= 1e-5f);
    for (int k = 0; k < naux; k++)
        EF_CHECK_EQ(e->aux[k] == last->aux[k], 1);
    return pk;
}

/* Rate (units per unit of X Y Z length) and its derivative of auxiliary axis k of move m at
 * tau = 0 or 1, in double from the control points. */
static void aux_rates(const ef_move_t *m, int k, int end, double *r1, double *r2, double *spo)
{
    int n = m->degree;
    const ef_vec3_t *b = m->b;
    const float *c = m->ab[k];
    int i0 = end ? n - 1 : 0;
    double d1[3] = {n * ((double)b[i0 + 1].x - b[i0].x), n * ((double)b[i0 + 1].y - b[i0].y),
                    n * ((double)b[i0 + 1].z - b[i0].z)};
    double a1 = n * ((double)c[i0 + 1] - c[i0]);
    double d2[3] = {0, 0, 0}, a2 = 0;
    if (n >= 2) {
        int j = end ? n - 2 : 0;
        d2[0] = n * (n - 1) * ((double)b[j + 2].x - 2.0 * b[j + 1].x + b[j].x);
        d2[1] = n * (n - 1) * ((double)b[j + 2].y - 2.0 * b[j + 1].y + b[j].y);
        d2[2] = n * (n - 1) * ((double)b[j + 2].z - 2.0 * b[j + 1].z + b[j].z);
        a2 = n * (n - 1) * ((double)c[j + 2] - 2.0 * c[j + 1] + c[j]);
    }
    double sp = sqrt(d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]);
    double s1 = (d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2]) / sp;
    *r1 = a1 / sp;
    *r2 = (a2 - s1 * a1 / sp) / (sp * sp);
    *spo = sp;
}

/* G2 by X Y Z arc length at every junction crossed at speed: the rate and its derivative
 * agree on both sides, to the float32 resolution of the control points (absolute values:
 * an ulp e of the largest |c| makes the first difference of a degree-n curve uncertain by
 * 2 n e, the second by 4 n (n - 1) e, divided by the parametric speed sp, sp^2). Returns
 * the junctions checked. */
static int check_junctions(int naux)
{
    int n = 0;
    for (int i = 1; i < NM; i++) {
        const ef_move_t *p = &M[i - 1], *q = &M[i];
        if (!(p->v_exit > 0.0f) || (p->flags & EF_MOVE_AUX_ONLY) || (q->flags & EF_MOVE_AUX_ONLY))
            continue;
        for (int k = 0; k < naux; k++) {
            double p1, p2, q1, q2, sp, sq, cm = 0;
            aux_rates(p, k, 1, &p1, &p2, &sp);
            aux_rates(q, k, 0, &q1, &q2, &sq);
            for (int j = 0; j <= 5; j++)
                cm = fmax(cm, fmax(fabs(p->ab[k][j]), fabs(q->ab[k][j])));
            double e = cm / 8388608.0, s = fmin(sp, sq);
            double t1 = 1e-4 * fmax(fabs(p1), fabs(q1)) + 2.0 * 5 * e / s * 2.0;
            double t2 = 1e-3 * fmax(fabs(p2), fabs(q2)) + 4.0 * 20 * e / (s * s) * 2.0;
            EF_CHECK(fabs(p1 - q1) <= t1);
            EF_CHECK(fabs(p2 - q2) <= t2);
            if (!(fabs(p1 - q1) <= t1) || !(fabs(p2 - q2) <= t2))
                fprintf(stderr,
                        "junction %d axis %d: rate %.6g / %.6g (allowed %.3g), its derivative "
                        "%.6g / %.6g (allowed %.3g)\n",
                        i, k, p1, q1, t1, p2, q2, t2);
        }
        n++;
    }
    return n;
}

/* A square with A changing its rate at every corner, and a full circle turning A once. */
static void test_blend(void)
{
    ef_smooth_cfg_t c = cfg_axes(1);
    float a[4][EF_AUX_N] = {{30}, {30}, {-10}, {35}};
    ef_prim_t pr[6];
    pr[0] = line(40, 0, 0, a[0], 50);
    pr[1] = line(40, 40, 0, a[1], 50);
    pr[2] = line(0, 40, 0, a[2], 50);
    pr[3] = line(0, 0, 0, a[3], 50);
    memset(&pr[4], 0, sizeof pr[4]);
    pr[4].kind = EF_PRIM_ARC;
    pr[4].end = ef_v3(0, 0, 0);
    pr[4].centre = ef_v3(10, 0, 0);
    pr[4].axis = ef_v3(0, 0, 1);
    pr[4].sweep = 2.0f * (float)M_PI;
    pr[4].feed = 50;
    pr[4].tol = 0.05f;
    pr[4].aux[0] = 395;
    pr[5] = line(-20, 0, 0, pr[4].aux, 50);
    EF_CHECK_EQ(smooth(&c, pr, 6), EF_OK);
    ef_smooth_stats_t st = ef_smooth_stats(&S);
    EF_CHECK(st.blends >= 4);
    EF_CHECK_EQ(st.aux_stops, 0);
    EF_CHECK(st.aux_dev_max > 0.0f && st.aux_dev_max <= c.aux_tol[0] * 1.001f);
    EF_CHECK(check_junctions(1) >= 4);
    execute();
    peaks_t pk = check_setpoints(&c, 1, &pr[5]);
    printf("blend: %u blends, A deviation %.4g deg (tol %.3g), A peaks %.3f v %.3f a %.3f j of "
           "allowed\n",
           st.blends, st.aux_dev_max, c.aux_tol[0], pk.v[0], pk.a[0], pk.j[0]);
}

/* Planned time of the moves in M. */
static double moves_time(void)
{
    double t = 0;
    for (int i = 0; i < NM; i++)
        t += M[i].duration;
    return t;
}

/* A 5-axis CAM run: a circle of radius 10 from 200 micro-segments with A = 30 sin(2 theta)
 * deg, its rate changing at every vertex. The vertices are smooth (rule 3) with A through
 * them: every section carries A as a quintic with the three-point rate at each vertex and
 * zero second derivative by arc length, so A is G2 at every junction, within its tolerance
 * of the programmed value, within its limits at the setpoints, and the run is faster than
 * blending every corner (micro_len 0, what a line moving A got before). */
static void test_cam5(void)
{
    enum { N = 200 };
    static ef_prim_t pr[N + 1];
    float a[EF_AUX_N] = {0};
    pr[0] = line(10, 0, 0, a, 50); /* lead-in, A still */
    for (int i = 1; i <= N; i++) {
        double th = 2 * M_PI * i / N;
        a[0] = (float)(30.0 * sin(2 * th));
        pr[i] = line((float)(10 * cos(th)), (float)(10 * sin(th)), 0, a, 50);
    }
    ef_smooth_cfg_t c = cfg_axes(1);
    c.keep_slow_blends = 0;
    c.micro_len = 0.0f; /* no smooth sections: every vertex a corner */
    EF_CHECK_EQ(smooth(&c, pr, N + 1), EF_OK);
    double t_corners = moves_time();
    uint32_t blends0 = ef_smooth_stats(&S).blends;
    c.micro_len = 1.0f;
    EF_CHECK_EQ(smooth(&c, pr, N + 1), EF_OK);
    ef_smooth_stats_t st = ef_smooth_stats(&S);
    double t_smooth = moves_time();
    EF_CHECK(st.smooth >= N - 2);
    EF_CHECK_EQ(st.aux_stops, 0);
    EF_CHECK(st.aux_dev_max > 0.0f && st.aux_dev_max <= c.aux_tol[0] * 1.001f);
    EF_CHECK(check_junctions(1) >= N - 2);
    EF_CHECK(t_smooth < t_corners);
    execute();
    peaks_t pk = check_setpoints(&c, 1, &pr[N]);
    printf("cam5: %u of %d vertices smooth with A (%u blends without smooth sections), A "
           "deviation %.4g deg (tol %.3g), A peaks %.3f v %.3f a %.3f j of allowed; %.3f s "
           "(%.3f s blending every corner)\n",
           st.smooth, N, blends0, st.aux_dev_max, c.aux_tol[0], pk.v[0], pk.a[0], pk.j[0], t_smooth,
           t_corners);
}

/* Nine axes: the six auxiliary axes each at its own rate, changing at every vertex of a
 * zigzag (random rates from a fixed seed). */
static void test_nine(void)
{
    ef_smooth_cfg_t c = cfg_axes(EF_AUX);
    static ef_prim_t pr[40];
    float a[EF_AUX_N] = {0};
    unsigned long long rng = 12345;
    for (int i = 0; i < 40; i++) {
        for (int k = 0; k < EF_AUX; k++) {
            rng = rng * 6364136223846793005ULL + 1442695040888963407ULL;
            a[k] += (float)((double)(rng >> 40) / (double)(1ULL << 24) * 20.0 - 8.0);
        }
        pr[i] = line(5.0f * (float)(i + 1), (i & 1) ? 4.0f : 0.0f, 0.3f * (float)i, a, 60);
    }
    EF_CHECK_EQ(smooth(&c, pr, 40), EF_OK);
    ef_smooth_stats_t st = ef_smooth_stats(&S);
    EF_CHECK(st.blends >= 30);
    EF_CHECK(st.aux_dev_max <= 0.02f * 1.001f);
    EF_CHECK(check_junctions(EF_AUX) >= 30);
    execute();
    peaks_t pk = check_setpoints(&c, EF_AUX, &pr[39]);
    double w = 0;
    for (int k = 0; k < EF_AUX; k++)
        w = fmax(w, fmax(pk.v[k], fmax(pk.a[k], pk.j[k])));
    printf("nine: %d axes, %u blends, %u stops, deviation %.4g (tol 0.02), worst axis peak %.3f "
           "of allowed, %d setpoints\n",
           EF_AXES, st.blends, st.stops, st.aux_dev_max, w, NSP);
}

/* An axis's own limits bound the path speed: A turns 180 deg along 10 mm at F 100 mm/s. */
static void test_limits(void)
{
    ef_smooth_cfg_t c = cfg_axes(1);
    float a1[EF_AUX_N] = {180};
    ef_prim_t pr[2] = {line(10, 0, 0, a1, 100), line(20, 0, 0, a1, 100)};
    EF_CHECK_EQ(smooth(&c, pr, 2), EF_OK);
    EF_CHECK(M[0].atabs[0] > 17.9f && M[0].atabs[0] < 18.1f);
    EF_CHECK(M[0].v_max <= 90.0f / 18.0f * 1.001f);
    execute();
    peaks_t pk = check_setpoints(&c, 1, &pr[1]);
    EF_CHECK(pk.v[0] > 0.9); /* the axis's limit is what bounds it */
    printf("limits: path speed on the A move %.3f mm/s (A at %.3f of its limit)\n",
           (double)M[0].v_max, pk.v[0]);
}

/* A alone between X Y Z moves: X Y Z still while it turns, at its own feed (deg/s). */
static void test_only(void)
{
    ef_smooth_cfg_t c = cfg_axes(1);
    float a0[EF_AUX_N] = {0}, a1[EF_AUX_N] = {90};
    ef_prim_t pr[3] = {line(10, 0, 0, a0, 50), line(10, 0, 0, a1, 45), line(20, 5, 0, a1, 50)};
    EF_CHECK_EQ(smooth(&c, pr, 3), EF_OK);
    ef_smooth_stats_t st = ef_smooth_stats(&S);
    EF_CHECK_EQ(st.aux_moves, 1);
    int found = 0;
    for (int i = 0; i < NM; i++)
        if (M[i].flags & EF_MOVE_AUX_ONLY) {
            found++;
            EF_CHECK(M[i].length > 89.99f && M[i].length < 90.01f);
            EF_CHECK(M[i].v_exit == 0.0f && i > 0 && M[i - 1].v_exit == 0.0f);
        }
    EF_CHECK_EQ(found, 1);
    execute();
    check_setpoints(&c, 1, &pr[2]);
    int turning = 0, together = 0;
    double vmax = 0;
    for (int i = 1; i < NSP; i++) {
        int ta = SP[i].aux[0] != SP[i - 1].aux[0];
        int tx = ef_v3_norm(ef_v3_sub(SP[i].p, SP[i - 1].p)) > 0.0f;
        turning += ta;
        together += ta && tx;
        vmax = fmax(vmax, fabs((double)SP[i].aux[0] - SP[i - 1].aux[0]) / DT);
    }
    EF_CHECK(turning > 1000);
    EF_CHECK_EQ(together, 0);
    EF_CHECK(vmax <= 45.0 * 1.01 && vmax > 44.0);
    printf("only: A turned in %d periods at up to %.2f deg/s (F 45), never with X Y Z\n", turning,
           vmax);
}

/* Where no blend can carry a change of rate: tolerance 0, and a straight vertex. */
static void test_stops(void)
{
    ef_smooth_cfg_t c = cfg_axes(1);
    c.aux_tol[0] = 0.0f;
    float a[3][EF_AUX_N] = {{10}, {10}, {40}};
    ef_prim_t pr[3] = {line(10, 0, 0, a[0], 50), line(10, 10, 0, a[1], 50),
                       line(20, 10, 0, a[2], 50)};
    EF_CHECK_EQ(smooth(&c, pr, 3), EF_OK);
    EF_CHECK_EQ(ef_smooth_stats(&S).aux_stops, 2);
    execute();
    check_setpoints(&c, 1, &pr[2]);
    /* a straight vertex with A changing its rate */
    c = cfg_axes(1);
    ef_prim_t q[2] = {line(10, 0, 0, a[0], 50), line(20, 0, 0, a[2], 50)};
    EF_CHECK_EQ(smooth(&c, q, 2), EF_OK);
    EF_CHECK_EQ(ef_smooth_stats(&S).aux_stops, 1);
    execute();
    check_setpoints(&c, 1, &q[1]);
    /* the same rate on both sides (a line split in two): straight through */
    float h[EF_AUX_N] = {20};
    ef_prim_t r[2] = {line(10, 0, 0, h, 50), line(20, 0, 0, a[2], 50)};
    EF_CHECK_EQ(smooth(&c, r, 2), EF_OK);
    EF_CHECK_EQ(ef_smooth_stats(&S).aux_stops, 0);
    EF_CHECK_EQ(ef_smooth_stats(&S).stops, 1); /* the end only */
}

/* naux 0: the auxiliary fields are not read (garbage there changes nothing). */
static void test_xyz(void)
{
    ef_smooth_cfg_t c = cfg_axes(0);
    ef_prim_t pr[3] = {line(10, 0, 0, NULL, 50), line(10, 10, 0, NULL, 50),
                       line(0, 10, 0, NULL, 50)};
    EF_CHECK_EQ(smooth(&c, pr, 3), EF_OK);
    static ef_move_t ref[64];
    int nref = NM;
    memcpy(ref, M, sizeof(ef_move_t) * (size_t)NM);
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < EF_AUX; k++)
            pr[i].aux[k] = k == 0 ? NAN : 1e30f;
    EF_CHECK_EQ(smooth(&c, pr, 3), EF_OK);
    EF_CHECK_EQ(NM, nref);
    EF_CHECK(memcmp(ref, M, sizeof(ef_move_t) * (size_t)NM) == 0);
}

static void test_bad(void)
{
    ef_smooth_cfg_t c = cfg_axes(2);
    float ok[EF_AUX_N] = {5, 5};
    ef_prim_t p = line(10, 0, 0, ok, 50);
    /* configuration */
    ef_smooth_cfg_t b = c;
    b.naux = EF_AUX + 1;
    EF_CHECK_EQ(ef_smooth_init(&S, &b, ef_v3(0, 0, 0)), EF_ERR_ARG);
    b = c;
    b.aux_tol[1] = -1.0f;
    EF_CHECK_EQ(ef_smooth_init(&S, &b, ef_v3(0, 0, 0)), EF_ERR_ARG);
    b = c;
    b.aux_tol[0] = NAN;
    EF_CHECK_EQ(ef_smooth_init(&S, &b, ef_v3(0, 0, 0)), EF_ERR_NONFINITE);
    b = c;
    b.lim.v_axis[4] = 0.0f;
    b.lim.a_axis[4] = 0.0f; /* the machine has no B, yet B is in use */
    EF_CHECK_EQ(ef_smooth_init(&S, &b, ef_v3(0, 0, 0)), EF_ERR_FEED);
    b = c;
    b.lim.a_axis[3] = 0.0f; /* a speed without an acceleration */
    EF_CHECK_EQ(ef_smooth_init(&S, &b, ef_v3(0, 0, 0)), EF_ERR_FEED);
    b = c;
    b.lim.j_aux[0] = -1.0f;
    EF_CHECK_EQ(ef_smooth_init(&S, &b, ef_v3(0, 0, 0)), EF_ERR_FEED);
    /* primitives: refused whole, the path so far unchanged */
    EF_CHECK_EQ(ef_smooth_init(&S, &c, ef_v3(0, 0, 0)), EF_OK);
    ef_prim_t q = p;
    q.aux[1] = NAN;
    EF_CHECK_EQ(ef_smooth_push(&S, &q), EF_ERR_NONFINITE);
    q.aux[1] = INFINITY;
    EF_CHECK_EQ(ef_smooth_push(&S, &q), EF_ERR_NONFINITE);
    q.aux[1] = 2e6f;
    EF_CHECK_EQ(ef_smooth_push(&S, &q), EF_ERR_NONFINITE);
    q = line(0, 0, 0, ok, 0.0f); /* an auxiliary move without a feed */
    EF_CHECK_EQ(ef_smooth_push(&S, &q), EF_ERR_FEED);
    q.feed = NAN;
    EF_CHECK_EQ(ef_smooth_push(&S, &q), EF_ERR_NONFINITE);
    q.feed = 10.0f;
    q.flags = 0x80;
    EF_CHECK_EQ(ef_smooth_push(&S, &q), EF_ERR_ARG);
    q = line(0, 0, 0, NULL, 10.0f); /* nothing moves at all */
    EF_CHECK_EQ(ef_smooth_push(&S, &q), EF_ERR_DEGENERATE);
    EF_CHECK_EQ(ef_smooth_stats(&S).prims, 0);
    /* setting the axes while something is held */
    EF_CHECK_EQ(ef_smooth_set_aux(&S, ok), EF_OK);
    EF_CHECK_EQ(ef_smooth_push(&S, &p), EF_OK);
    EF_CHECK_EQ(ef_smooth_set_aux(&S, ok), EF_ERR_ARG);
    float nan2[EF_AUX_N] = {NAN, 0};
    EF_CHECK_EQ(ef_smooth_init(&S, &c, ef_v3(0, 0, 0)), EF_OK);
    EF_CHECK_EQ(ef_smooth_set_aux(&S, nan2), EF_ERR_NONFINITE);
    /* the planner: a move that moves an axis the machine lacks gets no speed */
    ef_limits_t lim = c.lim;
    lim.v_axis[3] = lim.a_axis[3] = 0.0f;
    ef_plan_t pl;
    EF_CHECK_EQ(ef_plan_init(&pl, &lim), EF_OK);
    ef_move_t m;
    memset(&m, 0, sizeof m);
    m.degree = 1;
    m.b[1] = ef_v3(10, 0, 0);
    m.ab[0][1] = 30.0f;
    m.feed = 50.0f;
    EF_CHECK_EQ(ef_move_measure(&m), EF_OK);
    EF_CHECK(m.atabs[0] > 2.99f && m.atabs[0] < 3.01f);
    EF_CHECK_EQ(ef_plan_push(&pl, &m), EF_ERR_FEED);
    m.ab[0][0] = NAN;
    EF_CHECK_EQ(ef_move_measure(&m), EF_ERR_NONFINITE);
    /* the interpolator: a move that starts elsewhere on an auxiliary axis */
    m.ab[0][0] = 0.0f;
    EF_CHECK_EQ(ef_move_measure(&m), EF_OK);
    EF_CHECK_EQ(ef_plan_init(&pl, &c.lim), EF_OK);
    EF_CHECK_EQ(ef_plan_push(&pl, &m), EF_OK);
    EF_CHECK_EQ(ef_plan_finish(&pl), EF_OK);
    ef_move_t out;
    EF_CHECK_EQ(ef_plan_pull(&pl, &out), EF_OK);
    EF_CHECK_EQ(ef_interp_init(&IP, ef_v3(0, 0, 0), 1000, EF_STEP_UNIFORM), EF_OK);
    float at[EF_AUX_N] = {1.0f};
    EF_CHECK_EQ(ef_interp_set_aux(&IP, at), EF_OK);
    EF_CHECK_EQ(ef_interp_push(&IP, &out), EF_ERR_ARG);
    at[0] = 0.0f;
    EF_CHECK_EQ(ef_interp_set_aux(&IP, at), EF_OK);
    EF_CHECK_EQ(ef_interp_push(&IP, &out), EF_OK);
    EF_CHECK_EQ(ef_interp_set_aux(&IP, at), EF_ERR_ARG); /* moves queued */
}

/* Bernstein polynomial of degree n and its first three derivatives at t, in double. */
static void bern_d(const double *c, int n, double t, double d[4])
{
    double w[6][6];
    for (int i = 0; i <= n; i++)
        w[0][i] = c[i];
    for (int j = 1; j <= n; j++)
        for (int i = 0; i + j <= n; i++)
            w[j][i] = w[j - 1][i + 1] - w[j - 1][i];
    double f = 1.0; /* n! / (n - j)! */
    for (int j = 0; j < 4; j++) {
        double v = 0.0;
        if (j <= n) {
            /* the j-th differences as a Bernstein polynomial of degree n - j */
            double b[6];
            for (int i = 0; i + j <= n; i++)
                b[i] = w[j][i];
            for (int r = 1; r <= n - j; r++)
                for (int i = 0; i + r <= n - j; i++)
                    b[i] = (1 - t) * b[i] + t * b[i + 1];
            v = f * b[0];
        }
        d[j] = v;
        f *= (double)(n - j);
    }
}

/* ef_move_measure()'s auxiliary bounds against the same quantities in double at the same
 * samples, for every auxiliary axis of random curves of each degree: the larger of the
 * derivative by X Y Z arc length and by tau over L, for speed, acceleration and jerk. */
static void test_measure(void)
{
    unsigned long long rng = 99;
    double worst = 0;
    for (int run = 0; run < 300; run++) {
        ef_move_t m;
        memset(&m, 0, sizeof m);
        static const int degs[3] = {1, 3, 5};
        m.degree = (uint8_t)degs[run % 3];
        int n = m.degree;
        for (int i = 0; i <= n; i++) {
            float r[3 + EF_AUX_N];
            for (int k = 0; k < 3 + EF_AUX; k++) {
                rng = rng * 6364136223846793005ULL + 1442695040888963407ULL;
                r[k] = (float)((double)(rng >> 40) / (double)(1ULL << 24) - 0.5);
            }
            m.b[i] = ef_v3(3.0f * (float)i + r[0], r[1] + 0.3f * (float)i, r[2]);
            for (int k = 0; k < EF_AUX; k++)
                m.ab[k][i] = 100.0f + 7.0f * (float)k * (float)i + 2.0f * r[3 + k];
        }
        EF_CHECK_EQ(ef_move_measure(&m), EF_OK);
        double L = m.length;
        for (int k = 0; k < EF_AUX; k++) {
            double c[6], bx[3][6], want[3] = {0, 0, 0};
            for (int i = 0; i <= n; i++) {
                c[i] = m.ab[k][i];
                bx[0][i] = m.b[i].x;
                bx[1][i] = m.b[i].y;
                bx[2][i] = m.b[i].z;
            }
            for (int s = 0; s <= EF_MOVE_SAMPLES; s++) {
                double t = (double)s / EF_MOVE_SAMPLES, a[4], x[3][4];
                bern_d(c, n, t, a);
                for (int q = 0; q < 3; q++)
                    bern_d(bx[q], n, t, x[q]);
                double sp = sqrt(x[0][1] * x[0][1] + x[1][1] * x[1][1] + x[2][1] * x[2][1]);
                double s1 = (x[0][1] * x[0][2] + x[1][1] * x[1][2] + x[2][1] * x[2][2]) / sp;
                double s2 = (x[0][2] * x[0][2] + x[1][2] * x[1][2] + x[2][2] * x[2][2] +
                             x[0][1] * x[0][3] + x[1][1] * x[1][3] + x[2][1] * x[2][3]) /
                                sp -
                            s1 * s1 / sp;
                double v1 = a[1] / sp, v2 = (a[2] - s1 * a[1] / sp) / (sp * sp);
                double v3 = a[3] / pow(sp, 3) - 3 * s1 * a[2] / pow(sp, 4) +
                            (3 * s1 * s1 / pow(sp, 5) - s2 / pow(sp, 4)) * a[1];
                want[0] = fmax(want[0], fmax(fabs(v1), fabs(a[1]) / L));
                want[1] = fmax(want[1], fmax(fabs(v2), fabs(a[2]) / (L * L)));
                want[2] = fmax(want[2], fmax(fabs(v3), fabs(a[3]) / (L * L * L)));
            }
            const float got[3] = {m.atabs[k], m.akabs[k], m.akjerk[k]};
            for (int q = 0; q < 3; q++) {
                double sc = fmax(want[q], q == 0 ? 1.0 : q == 1 ? 1.0 / L : 1.0 / (L * L));
                double e = fabs(got[q] - want[q]) / sc;
                worst = fmax(worst, e);
                EF_CHECK(e <= 2e-3);
                if (!(e <= 2e-3))
                    fprintf(stderr, "run %d degree %d axis %d bound %d: %.6g, in double %.6g\n",
                            run, n, k, q, (double)got[q], want[q]);
            }
        }
    }
    printf("measure: 300 curves x %d auxiliary axes, largest relative difference %.2g\n", EF_AUX,
           worst);
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"blend", test_blend}, {"nine", test_nine},       {"limits", test_limits},
        {"only", test_only},   {"stops", test_stops},     {"xyz", test_xyz},
        {"bad", test_bad},     {"measure", test_measure}, {"cam5", test_cam5},
    };
    setvbuf(stdout, NULL, _IOLBF, 0);
    return EF_TEST_RUN(argc, argv, 1, parts);
}
