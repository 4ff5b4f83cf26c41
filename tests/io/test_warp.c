/* SPDX-License-Identifier: Apache-2.0 */
/* The feed-hold time warp (host/lib/io/ef_warp.c) on a path sampled here: at rate 1 the
 * samples pass through unchanged; a hold decelerates along the polyline of the samples
 * within a / 2 of added deceleration and stands; a resume continues; every target lies on
 * the polyline, progress never goes back, no sample is skipped, the end is exact; holds
 * at the start and during a ramp; the end between samples. */
#include <math.h>
#include <stdint.h>
#include <string.h>
#include "ef_test.h"
#include "evenfeed/host/io/ef_warp.h"

#define DT   1e-3
#define V    40.0   /* path speed (units/s) */
#define AMIN 2000.0 /* smallest axis acceleration (units/s^2) */
#define NS   3000   /* samples: 3 s of path */

/* Sample i of the test path: a quarter circle of radius 30 at V, in x/y, z rising. */
static void sample(int i, float p[3])
{
    double s = V * DT * i, th = s / 30.0;
    p[0] = (float)(30.0 * sin(th));
    p[1] = (float)(30.0 * (1.0 - cos(th)));
    p[2] = (float)(0.001 * s);
}

/* Distance of q from the polyline piece i .. i + 1 of the samples; *u: where on it. */
static double piece_dist(const float *q, int i, double *u)
{
    float a[3], b[3];
    sample(i, a);
    sample(i + 1, b);
    double ab[3], aq[3], l2 = 0, dot = 0;
    for (int k = 0; k < 3; k++) {
        ab[k] = (double)b[k] - a[k];
        aq[k] = (double)q[k] - a[k];
        l2 += ab[k] * ab[k];
        dot += ab[k] * aq[k];
    }
    double t = l2 > 0 ? dot / l2 : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    double e = 0;
    for (int k = 0; k < 3; k++)
        e += (aq[k] - t * ab[k]) * (aq[k] - t * ab[k]);
    *u = t;
    return sqrt(e);
}

typedef struct {
    double off, back, acc, v_prev;
    double pos; /* progress along the samples (in samples) of the last target */
    int n_out, held_run, held_max;
    float last[3];
} watch_t;

/* Check one target: on the polyline near the progress so far, never behind it. The
 * acceleration is not taken at the end (end set): the test path ends at full speed, so its
 * last sample, a fraction of a period after the one before, is a stop no real path has. */
static void watch(watch_t *W, const float *q, int end)
{
    int i0 = (int)W->pos;
    double best = 1e30, bpos = W->pos;
    for (int i = i0 > 0 ? i0 - 1 : 0; i < i0 + 4 && i + 1 < NS + 1; i++) {
        double u, e = piece_dist(q, i, &u);
        if (e < best) {
            best = e;
            bpos = i + u;
        }
    }
    W->off = fmax(W->off, best);
    if (bpos < W->pos - 1e-6)
        W->back++;
    double v = W->n_out ? sqrt(pow(q[0] - W->last[0], 2) + pow(q[1] - W->last[1], 2) +
                               pow(q[2] - W->last[2], 2)) /
                              DT
                        : 0;
    if (W->n_out > 1 && !end)
        W->acc = fmax(W->acc, fabs(v - W->v_prev) / DT);
    W->held_run = v == 0.0 && W->n_out ? W->held_run + 1 : 0;
    W->held_max = W->held_run > W->held_max ? W->held_run : W->held_max;
    W->v_prev = v;
    W->pos = bpos > W->pos ? bpos : W->pos;
    memcpy(W->last, q, sizeof W->last);
    W->n_out++;
}

/* Feed the whole path; hold(k) says the request at target k. Returns the targets given. */
static int run(ef_warp_t *w, watch_t *W, int (*hold)(int k))
{
    memset(W, 0, sizeof *W);
    float p[3], q[3];
    uint32_t tag;
    int k = 0;
    for (int i = 0; i <= NS; i++) {
        sample(i, p);
        ef_warp_push(w, p, (uint32_t)(i / 100 + 1));
        while (k < 100000 && ef_warp_next(w, hold(k), 0, q, &tag)) {
            EF_CHECK(tag >= 1 && tag <= NS / 100 + 1);
            watch(W, q, 0);
            k++;
        }
    }
    while (k < 100000 && ef_warp_next(w, hold(k), 1, q, &tag)) {
        watch(W, q, 1);
        k++;
    }
    return k;
}

static int never(int k)
{
    (void)k;
    return 0;
}

/* Hold from target 1000 (at V), release at 2500. */
static int mid(int k)
{
    return k >= 1000 && k < 2500;
}

/* Hold from the first target, release at 300. */
static int first(int k)
{
    return k < 300;
}

/* Hold at 1000, released at 1030 (mid-ramp), held again at 1060. */
static int bounce(int k)
{
    return (k >= 1000 && k < 1030) || (k >= 1060 && k < 1600);
}

static void t_warp(void)
{
    ef_warp_t w;
    watch_t W;
    float end[3];
    sample(NS, end);

    /* Rate 1: every sample once, unchanged. */
    ef_warp_init(&w, 3, DT, AMIN);
    int n = run(&w, &W, never);
    EF_CHECK_EQ(n, NS + 1);
    EF_CHECK(W.off < 1e-9 && W.back == 0);
    EF_CHECK(memcmp(W.last, end, sizeof end) == 0);
    EF_CHECK_EQ(w.holds, 0);

    /* A hold at V: T = 3 V / a = 60 ms, the deceleration added peaks at a / 2. */
    ef_warp_init(&w, 3, DT, AMIN);
    n = run(&w, &W, mid);
    printf("warp: hold at %.0f units/s: peak acceleration %.0f units/s^2 (a / 2 = %.0f), off "
           "the polyline %.2g, stood %d periods, %d targets for %d samples\n",
           V, W.acc, AMIN / 2, W.off, W.held_max, n, NS + 1);
    EF_CHECK(W.off < 1e-4);
    EF_CHECK_EQ(W.back, 0);
    /* The path's own centripetal change per period is tiny next to a / 2 (V^2 / 30 = 53). */
    EF_CHECK(W.acc <= AMIN / 2 * 1.02 + 60.0);
    EF_CHECK(W.acc >= AMIN / 2 * 0.9);
    EF_CHECK(W.held_max > 1300); /* 1500 held targets less the ramp */
    EF_CHECK(memcmp(W.last, end, sizeof end) == 0);
    EF_CHECK_EQ(w.holds, 1);
    EF_CHECK(w.held_s > 1.3 && w.held_s < 1.5);
    /* Each ramp covers half its time's path: 1500 targets of hold lose 1500 samples' time. */
    EF_CHECK(abs(n - (NS + 1) - 1500) <= 3);

    /* A hold at the start (rest): stands, then runs the path. */
    ef_warp_init(&w, 3, DT, AMIN);
    n = run(&w, &W, first);
    EF_CHECK(W.off < 1e-4 && W.back == 0);
    EF_CHECK(memcmp(W.last, end, sizeof end) == 0);
    EF_CHECK(W.held_max >= 240); /* moving at the start: a 50 ms ramp first */

    /* Released mid-ramp and held again: each change ramps from the rate reached. */
    ef_warp_init(&w, 3, DT, AMIN);
    n = run(&w, &W, bounce);
    printf("warp: hold, release mid-ramp, hold: peak acceleration %.0f units/s^2\n", W.acc);
    EF_CHECK(W.off < 1e-4 && W.back == 0);
    EF_CHECK(W.acc <= AMIN / 2 * 1.02 + 60.0);
    EF_CHECK(memcmp(W.last, end, sizeof end) == 0);
    EF_CHECK_EQ(w.holds, 2);

    /* The end between two samples: after a hold and its resume the warp runs at rate 1 but
     * a fraction between samples, so the path's last sample is given by the end call, once,
     * and nothing after it. */
    ef_warp_init(&w, 1, DT, AMIN);
    float q, x, prev = -1;
    uint32_t tag;
    int k = 0, at_end = 0, frac = 0;
    for (int i = 0; i < 100; i++) {
        x = (float)(0.04 * i);
        ef_warp_push(&w, &x, (uint32_t)i);
        while (ef_warp_next(&w, k < 100, 0, &q, &tag)) {
            EF_CHECK(q >= prev);
            prev = q;
            k++;
        }
    }
    frac = w.w != floor(w.w);
    EF_CHECK(frac);
    while (ef_warp_next(&w, 0, 1, &q, &tag)) {
        EF_CHECK(q >= prev);
        prev = q;
        at_end += q == x;
    }
    EF_CHECK(q == x && tag == 99);
    EF_CHECK_EQ(at_end, 1);
    EF_CHECK_EQ(ef_warp_next(&w, 0, 1, &q, &tag), 0); /* all given */
    /* Nothing pushed: nothing to give. */
    ef_warp_init(&w, 0, 0, 0);
    EF_CHECK(w.axes == 1 && w.dt > 0 && w.a > 0);
    EF_CHECK_EQ(ef_warp_next(&w, 0, 1, &q, &tag), 0);
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"warp", t_warp},
    };
    return EF_TEST_RUN(argc, argv, 1, parts);
}
