/* Table building: node configurations, storage, the CPU backend and a one-pass driver. */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "evenfeed/host/ef_build.h"
#include "evenfeed/host/ef_ref.h"

/* How far inside the fold region its edge nodes are optimized (rad): far above the
 * optimizer's tie tolerance (1e-9 relative in C^2), far below the grid spacing. */
#define EF_BUILD_EDGE_NUDGE 1e-6

/* Node configuration, with the fold-edge nudge (see ef_build.h). */
void ef_build_node_config(const ef_tfile_t *t, uint32_t node, double cfg[EF_TABLE_MAX_AXES])
{
    memset(cfg, 0, sizeof(double) * EF_TABLE_MAX_AXES);
    ef_tfile_node_config(t, node, cfg);
    if (t->view.symmetry != EF_SYM_G1_FOLD)
        return;
    const uint32_t n0 = t->view.axis[0].nodes, n1 = t->view.axis[1].nodes;
    const uint32_t i = node % n0, j = node / n0;
    double u = t->lo[0] + (t->hi[0] - t->lo[0]) * i / (n0 - 1);
    double v = t->lo[1] + (t->hi[1] - t->lo[1]) * j / (n1 - 1);
    u += (i == 0 ? EF_BUILD_EDGE_NUDGE : 0) - (i == n0 - 1 ? EF_BUILD_EDGE_NUDGE : 0);
    v += (j == 0 ? EF_BUILD_EDGE_NUDGE : 0) - (j == n1 - 1 ? EF_BUILD_EDGE_NUDGE : 0);
    cfg[0] = u + v;
    cfg[1] = u - v;
}

/* Float value kept inside [lo, hi], which float rounding could otherwise cross. */
static float ef_build_clampf(double v, double lo, double hi)
{
    float f = (float)v;
    if (f < (float)lo)
        f = (float)lo;
    if (f > (float)hi)
        f = (float)hi;
    return f;
}

/* x1 DOFs between the x1 bounds, x2 DOFs within +-x2_max. */
void ef_build_store(ef_tfile_t *t, uint32_t node, const double *dof)
{
    float *v = t->values + (size_t)node * t->view.ndof;
    const int g2 = t->view.kind == EF_TABLE_G2_QUINTIC;
    for (int k = 0; k < t->view.ndof; k++) {
        int is_x2 = g2 && (k == 1 || k == 3);
        v[k] = is_x2 ? ef_build_clampf(dof[k], -t->x2_max, t->x2_max)
                     : ef_build_clampf(dof[k], t->x1_min, t->x1_max);
    }
}

/* Optimize one node at chord 1 and store its DOFs; warm is the previous node's, or NULL. */
static int ef_build_node(ef_tfile_t *t, uint32_t node, const double *warm, double *dof_out,
                         ef_msg_t *m)
{
    double cfg[EF_TABLE_MAX_AXES];
    ef_build_node_config(t, node, cfg);
    const int g2 = t->view.kind == EF_TABLE_G2_QUINTIC;
    ef_dend_t e0, e1;
    ef_ref_config(cfg[0], cfg[1], g2 ? cfg[2] : 0, g2 ? cfg[3] : 0, &e0, &e1);
    ef_ref_opts_t o;
    ef_ref_opts_default(&o);
    o.x1_min = t->x1_min;
    o.x1_max = t->x1_max;
    if (g2)
        o.x2_max = t->x2_max;
    o.warm = warm;
    ef_ref_result_t r;
    ef_msg_t sub = {{0}};
    int rc = ef_ref_optimize(g2 ? EF_REF_G2_QUINTIC : EF_REF_G1_CUBIC, &e0, &e1, &o, &r, &sub);
    if (rc != EF_OK)
        return ef_fail(m, rc, "node %u (alpha %.6g beta %.6g k0 %.6g k1 %.6g): %s", node, cfg[0],
                       cfg[1], cfg[2], cfg[3], sub.text);
    ef_build_store(t, node, r.dof);
    memcpy(dof_out, r.dof, sizeof(double) * (size_t)t->view.ndof);
    return EF_OK;
}

typedef struct {
    int threads;
} ef_cpu_ctx_t;

typedef struct {
    ef_tfile_t *t;
    uint32_t row_begin, row_end, stride;
    int rc;
    ef_msg_t msg;
} ef_cpu_job_t;

/* Worker: rows row_begin + index, + threads, ...; each row in order so warm starts are fixed. */
static void *ef_cpu_worker(void *arg)
{
    ef_cpu_job_t *j = arg;
    const uint32_t n0 = j->t->view.axis[0].nodes;
    for (uint32_t row = j->row_begin; row < j->row_end; row += j->stride) {
        double prev[EF_TABLE_MAX_DOF];
        for (uint32_t i = 0; i < n0; i++) {
            j->rc = ef_build_node(j->t, row * n0 + i, i ? prev : NULL, prev, &j->msg);
            if (j->rc != EF_OK)
                return NULL;
        }
    }
    return NULL;
}

/* CPU backend: threads over the rows of [row_begin, row_end); first failure by thread order. */
static int ef_cpu_solve_rows(void *ctx, ef_tfile_t *t, uint32_t row_begin, uint32_t row_end,
                             ef_msg_t *m)
{
    const ef_cpu_ctx_t *c = ctx;
    pthread_t tid[64];
    ef_cpu_job_t job[64];
    int started = 0, rc = EF_OK;
    for (int i = 0; i < c->threads; i++) {
        job[i] = (ef_cpu_job_t){.t = t, .row_begin = row_begin + (uint32_t)i, .row_end = row_end,
                                .stride = (uint32_t)c->threads, .rc = EF_OK};
        if (pthread_create(&tid[i], NULL, ef_cpu_worker, &job[i]) != 0) {
            rc = ef_fail(m, EF_ERR_NOMEM, "build: cannot start thread %d", i);
            break;
        }
        started++;
    }
    for (int i = 0; i < started; i++)
        pthread_join(tid[i], NULL);
    for (int i = 0; i < started && rc == EF_OK; i++)
        if (job[i].rc != EF_OK) {
            rc = job[i].rc;
            if (m)
                *m = job[i].msg;
        }
    return rc;
}

static void ef_cpu_close(void *ctx)
{
    free(ctx);
}

/* CPU backend with a thread count. */
int ef_build_backend_cpu(ef_build_backend_t *b, int threads)
{
    if (!b || threads < 1 || threads > 64)
        return EF_ERR_ARG;
    ef_cpu_ctx_t *c = malloc(sizeof *c);
    if (!c)
        return EF_ERR_NOMEM;
    c->threads = threads;
    *b = (ef_build_backend_t){.name = "cpu", .solve_rows = ef_cpu_solve_rows,
                              .close = ef_cpu_close, .ctx = c, .chunk_nodes = 4096};
    return EF_OK;
}

/* One pass over all rows in chunks of whole rows, reporting progress after each chunk. */
int ef_build_all(ef_tfile_t *t, ef_build_backend_t *b, ef_build_progress_fn progress, void *ctx,
                 ef_msg_t *m)
{
    if (!t || !t->values || !b || !b->solve_rows)
        return ef_fail(m, EF_ERR_ARG, "build: bad table or backend");
    const uint32_t n0 = t->view.axis[0].nodes, rows = t->view.nodes / n0;
    uint32_t chunk = b->chunk_nodes / n0;
    if (chunk < 1)
        chunk = 1;
    for (uint32_t r = 0; r < rows; r += chunk) {
        uint32_t end = r + chunk < rows ? r + chunk : rows;
        int rc = b->solve_rows(b->ctx, t, r, end, m);
        if (rc != EF_OK)
            return rc;
        if (progress)
            progress(ctx, end * n0, t->view.nodes);
    }
    return EF_OK;
}

/* Compatibility wrapper: the CPU backend over the whole table. */
int ef_build_cpu(ef_tfile_t *t, int threads, ef_build_progress_fn progress, void *ctx,
                 ef_msg_t *m)
{
    ef_build_backend_t b;
    if (ef_build_backend_cpu(&b, threads) != EF_OK)
        return ef_fail(m, EF_ERR_ARG, "build: bad thread count %d", threads);
    int rc = ef_build_all(t, &b, progress, ctx, m);
    b.close(b.ctx);
    return rc;
}
