/* SPDX-License-Identifier: Apache-2.0 */
/* Accuracy harness: table segments against the reference optimum on random configurations. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "evenfeed/seg/ef_seg.h"
#include "evenfeed/host/tables/ef_ref.h"
#include "evenfeed/host/tables/ef_verify.h"
#include "core/ef_parallel_int.h"

typedef struct {
    ef_job_t job; /* first: ef_parallel_run() reads it */
    const ef_table_t *tbl;
    const ef_verify_opts_t *o;
    int index, threads;
    double *excess, *x1e, *x2e, (*cfg)[4];
    uint32_t clamped, misses;
} ef_verify_job_t;

/* splitmix64: configuration i depends only on (seed, i), whatever the thread split. */
static uint64_t ver_mix(uint64_t *s)
{
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* Uniform double in [lo, hi]. */
static double ver_uni(uint64_t *s, double lo, double hi)
{
    return lo + (hi - lo) * (double)(ver_mix(s) >> 11) * (1.0 / 9007199254740992.0);
}

/* The user-coordinate range of axis a: folded and periodic tables cover whole circles. */
static void ver_range(const ef_table_t *t, int a, double *lo, double *hi)
{
    *lo = t->axis[a].lo;
    *hi = t->axis[a].hi;
    if (t->kind == EF_TABLE_G1_CUBIC &&
        (t->symmetry == EF_SYM_G1_FOLD || (t->axis[a].flags & EF_AXIS_PERIODIC))) {
        *lo = -M_PI;
        *hi = M_PI;
    }
    if (t->symmetry == EF_SYM_G2_MIRROR && a == 0)
        *lo = -*hi;
}

/* Unit vector uniform on the sphere. */
static ef_dvec3_t ver_sphere(uint64_t *s)
{
    double z = ver_uni(s, -1, 1), ph = ver_uni(s, -M_PI, M_PI), r = sqrt(1 - z * z);
    return (ef_dvec3_t){r * cos(ph), r * sin(ph), z};
}

/* One configuration: the firmware's segment, its C in double, and the reference optimum. */
static int ver_one(ef_verify_job_t *j, uint32_t i)
{
    const ef_table_t *t = j->tbl;
    int g2 = t->kind == EF_TABLE_G2_QUINTIC;
    uint64_t s = j->o->seed * 0x100000001B3ull + i;
    double cfg[4] = {0, 0, 0, 0};
    ef_dend_t e0, e1;
    if (j->o->three_d) {
        memset(&e0, 0, sizeof e0);
        memset(&e1, 0, sizeof e1);
        e1.p.x = 1;
        e0.t = ver_sphere(&s);
        e1.t = ver_sphere(&s);
        cfg[0] = acos(e0.t.x);
        cfg[1] = acos(e1.t.x);
    } else {
        for (int a = 0; a < t->naxes; a++) {
            double lo, hi;
            ver_range(t, a, &lo, &hi);
            cfg[a] = ver_uni(&s, lo, hi);
        }
        ef_ref_config(cfg[0], cfg[1], g2 ? cfg[2] : 0, g2 ? cfg[3] : 0, &e0, &e1);
    }
    ef_endpoint_t f0 = ef_ref_end_to_fw(&e0), f1 = ef_ref_end_to_fw(&e1);
    ef_seg_t seg;
    int rc = g2 ? ef_seg_g2_quintic(t, &f0, &f1, &seg) : ef_seg_g1_cubic(t, &f0, &f1, &seg);
    if (rc != EF_OK)
        return ef_fail(&j->job.msg, rc, "verify: configuration %u (%.6g, %.6g, %.6g, %.6g): %s", i,
                       cfg[0], cfg[1], cfg[2], cfg[3], ef_err_str(rc));
    ef_dvec3_t b[6];
    for (int k = 0; k <= seg.degree; k++)
        b[k] = (ef_dvec3_t){seg.b[k].x, seg.b[k].y, seg.b[k].z};
    double c_tab = ef_ref_functional(b, seg.degree);

    double warm[4];
    for (int k = 0; k < seg.ndof; k++)
        warm[k] = seg.dof[k] / seg.norm.chord;
    ef_ref_opts_t o;
    ef_ref_opts_default(&o);
    o.x1_min = t->x1_min;
    o.x1_max = t->x1_max;
    if (g2)
        o.x2_max = t->x2_max;
    o.warm = warm;
    ef_ref_result_t r;
    ef_msg_t sub = {{0}};
    rc = ef_ref_optimize(g2 ? EF_REF_G2_QUINTIC : EF_REF_G1_CUBIC, &e0, &e1, &o, &r, &sub);
    if (rc != EF_OK)
        return ef_fail(&j->job.msg, rc, "verify: reference failed at configuration %u: %s", i,
                       sub.text);
    double ex = r.C < 1e-9 ? c_tab - r.C : (c_tab - r.C) / r.C;
    /* Float32 control points sit up to an ulp off the feasible set, so a table may beat the
     * reference by ~1e-7 relative; beyond 1e-6 the reference missed the optimum. */
    if (c_tab < r.C * (1 - 1e-6) - 1e-9)
        j->misses++;
    j->clamped += (seg.flags & EF_SEG_CLAMPED) != 0;
    j->excess[i] = ex;
    double floor_x = t->x1_min, e1s = 0, e2s = 0;
    for (int k = 0; k < seg.ndof; k++) {
        double e = fabs(seg.dof[k] - r.dof[k]) / fmax(fabs(r.dof[k]), floor_x);
        if (g2 && (k == 1 || k == 3))
            e2s += e / 2;
        else
            e1s += e / 2;
    }
    j->x1e[i] = e1s;
    j->x2e[i] = e2s;
    memcpy(j->cfg[i], cfg, sizeof cfg);
    return EF_OK;
}

/* Worker over configurations index, index + threads, ... */
static void *ver_worker(void *arg)
{
    ef_verify_job_t *j = arg;
    for (uint32_t i = (uint32_t)j->index; i < j->o->count; i += (uint32_t)j->threads) {
        j->job.rc = ver_one(j, i);
        if (j->job.rc != EF_OK)
            break;
    }
    return NULL;
}

/* qsort comparator for doubles. */
static int ver_cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* mean, median, p99, max of v[0..n) (sorts v). */
static ef_stat_t ver_stats(double *v, uint32_t n)
{
    ef_stat_t st;
    double sum = 0;
    for (uint32_t i = 0; i < n; i++)
        sum += v[i];
    qsort(v, n, sizeof *v, ver_cmp_double);
    st.min = v[0];
    st.mean = sum / n;
    st.median = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
    uint32_t k = (uint32_t)ceil(0.99 * n);
    st.p99 = v[k ? k - 1 : 0];
    st.max = v[n - 1];
    return st;
}

/* Run the configurations over threads, then reduce to statistics. */
int ef_verify_table(const ef_table_t *tbl, const ef_verify_opts_t *o, ef_verify_result_t *r,
                    ef_msg_t *m)
{
    if (!tbl || !o || !r || o->count == 0 || o->threads < 1 || o->threads > 64)
        return ef_fail(m, EF_ERR_ARG, "verify: bad arguments");
    if (tbl->kind != EF_TABLE_G1_CUBIC && tbl->kind != EF_TABLE_G2_QUINTIC)
        return ef_fail(m, EF_ERR_KIND, "verify: unknown table kind %u", tbl->kind);
    if (o->three_d && tbl->kind != EF_TABLE_G1_CUBIC)
        return ef_fail(m, EF_ERR_ARG, "verify: --3d applies to G1 tables only");
    memset(r, 0, sizeof *r);
    uint32_t n = o->count;
    double *buf = calloc((size_t)n * 7, sizeof(double));
    if (!buf)
        return ef_fail(m, EF_ERR_NOMEM, "verify: out of memory for %u configurations", n);
    double *excess = buf, *x1e = buf + n, *x2e = buf + 2 * (size_t)n;
    double(*cfg)[4] = (double(*)[4])(buf + 3 * (size_t)n);
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    ef_verify_job_t job[64];
    for (int i = 0; i < o->threads; i++)
        job[i] = (ef_verify_job_t){.tbl = tbl,
                                   .o = o,
                                   .index = i,
                                   .threads = o->threads,
                                   .excess = excess,
                                   .x1e = x1e,
                                   .x2e = x2e,
                                   .cfg = cfg};
    int started = 0;
    int rc = ef_parallel_run(job, sizeof job[0], o->threads, ver_worker, "verify", &started, m);
    if (rc == EF_OK) {
        uint32_t worst = 0;
        for (uint32_t i = 1; i < n; i++)
            if (excess[i] > excess[worst])
                worst = i;
        memcpy(r->worst_cfg, cfg[worst], sizeof r->worst_cfg);
        for (int i = 0; i < started; i++) {
            r->clamped += job[i].clamped;
            r->opt_misses += job[i].misses;
        }
        r->count = n;
        r->excess = ver_stats(excess, n);
        r->x1_err = ver_stats(x1e, n);
        r->x2_err = ver_stats(x2e, n);
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    r->seconds = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    free(buf);
    return rc;
}
