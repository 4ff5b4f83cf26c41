/* CPU table builder: the reference optimum at every node, rows spread over threads. */
#include <pthread.h>
#include <stdio.h>
#include <string.h>
#include "evenfeed/host/ef_build.h"
#include "evenfeed/host/ef_ref.h"

/* How far inside the fold region its edge nodes are optimized (rad): far above the
 * optimizer's tie tolerance (1e-9 relative in C^2), far below the grid spacing. */
#define EF_BUILD_EDGE_NUDGE 1e-6

typedef struct {
    ef_tfile_t *t;
    int threads;
    int index;
    ef_build_progress_fn progress;
    void *ctx;
    pthread_mutex_t *lock;
    uint32_t *done;
    int rc;
    ef_msg_t msg;
} ef_build_job_t;

/* Reference kind for a table kind. */
static ef_ref_kind_t ef_build_ref_kind(int kind)
{
    return kind == EF_TABLE_G2_QUINTIC ? EF_REF_G2_QUINTIC : EF_REF_G1_CUBIC;
}

/* Float value kept inside the table's bounds, which float rounding could otherwise cross. */
static float ef_build_store(double v, double lo, double hi)
{
    float f = (float)v;
    if (f < (float)lo)
        f = (float)lo;
    if (f > (float)hi)
        f = (float)hi;
    return f;
}

/* Optimize one node at chord 1 and store its DOFs; warm is the previous node's, or NULL. */
static int ef_build_node(ef_tfile_t *t, uint32_t node, const double *warm, double *dof_out,
                         ef_msg_t *m)
{
    double cfg[EF_TABLE_MAX_AXES] = {0};
    ef_tfile_node_config(t, node, cfg);
    if (t->view.symmetry == EF_SYM_G1_FOLD) {
        /* The fold's edges are symmetry lines (u = 0: reversal, v = 0: alpha = beta) on
         * which two mirror-image optima can tie exactly; the lookup interpolates from inside
         * the region only, so store the branch continuous with the inside: optimize a hair
         * (EF_BUILD_EDGE_NUDGE rad) inside it. Elsewhere this moves the DOFs by O(1e-6). */
        const uint32_t n0 = t->view.axis[0].nodes, n1 = t->view.axis[1].nodes;
        const uint32_t i = node % n0, j = node / n0;
        double u = t->lo[0] + (t->hi[0] - t->lo[0]) * i / (n0 - 1);
        double v = t->lo[1] + (t->hi[1] - t->lo[1]) * j / (n1 - 1);
        u += (i == 0 ? EF_BUILD_EDGE_NUDGE : 0) - (i == n0 - 1 ? EF_BUILD_EDGE_NUDGE : 0);
        v += (j == 0 ? EF_BUILD_EDGE_NUDGE : 0) - (j == n1 - 1 ? EF_BUILD_EDGE_NUDGE : 0);
        cfg[0] = u + v;
        cfg[1] = u - v;
    }
    int kind = t->view.kind;
    ef_dend_t e0, e1;
    ef_ref_config(cfg[0], cfg[1], kind == EF_TABLE_G2_QUINTIC ? cfg[2] : 0,
                  kind == EF_TABLE_G2_QUINTIC ? cfg[3] : 0, &e0, &e1);
    ef_ref_opts_t o;
    ef_ref_opts_default(&o);
    o.x1_min = t->x1_min;
    o.x1_max = t->x1_max;
    if (kind == EF_TABLE_G2_QUINTIC)
        o.x2_max = t->x2_max;
    o.warm = warm;
    ef_ref_result_t r;
    ef_msg_t sub = {{0}};
    int rc = ef_ref_optimize(ef_build_ref_kind(kind), &e0, &e1, &o, &r, &sub);
    if (rc != EF_OK)
        return ef_fail(m, rc, "node %u (alpha %.6g beta %.6g k0 %.6g k1 %.6g): %s", node, cfg[0],
                       cfg[1], cfg[2], cfg[3], sub.text);
    float *v = t->values + (size_t)node * t->view.ndof;
    for (int k = 0; k < t->view.ndof; k++) {
        int is_x2 = kind == EF_TABLE_G2_QUINTIC && (k == 1 || k == 3);
        v[k] = is_x2 ? ef_build_store(r.dof[k], -t->x2_max, t->x2_max)
                     : ef_build_store(r.dof[k], t->x1_min, t->x1_max);
        dof_out[k] = r.dof[k];
    }
    return EF_OK;
}

/* Worker: rows index, index + threads, ...; each row in order so warm starts are fixed. */
static void *ef_build_worker(void *arg)
{
    ef_build_job_t *j = arg;
    const uint32_t n0 = j->t->view.axis[0].nodes;
    const uint32_t rows = j->t->view.nodes / n0;
    for (uint32_t row = (uint32_t)j->index; row < rows; row += (uint32_t)j->threads) {
        double prev[EF_TABLE_MAX_DOF];
        for (uint32_t i = 0; i < n0; i++) {
            j->rc = ef_build_node(j->t, row * n0 + i, i ? prev : NULL, prev, &j->msg);
            if (j->rc != EF_OK)
                return NULL;
        }
        pthread_mutex_lock(j->lock);
        *j->done += n0;
        if (j->progress)
            j->progress(j->ctx, *j->done, j->t->view.nodes);
        pthread_mutex_unlock(j->lock);
    }
    return NULL;
}

/* Run the workers and report the first failure by row order. */
int ef_build_cpu(ef_tfile_t *t, int threads, ef_build_progress_fn progress, void *ctx,
                 ef_msg_t *m)
{
    if (!t || !t->values || threads < 1 || threads > 64)
        return ef_fail(m, EF_ERR_ARG, "build: bad table or thread count %d", threads);
    pthread_t tid[64];
    ef_build_job_t job[64];
    pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
    uint32_t done = 0;
    int started = 0, rc = EF_OK;
    for (int i = 0; i < threads; i++) {
        job[i] = (ef_build_job_t){.t = t, .threads = threads, .index = i, .progress = progress,
                                  .ctx = ctx, .lock = &lock, .done = &done, .rc = EF_OK};
        if (pthread_create(&tid[i], NULL, ef_build_worker, &job[i]) != 0) {
            rc = ef_fail(m, EF_ERR_NOMEM, "build: cannot start thread %d", i);
            break;
        }
        started++;
    }
    for (int i = 0; i < started; i++)
        pthread_join(tid[i], NULL);
    if (rc != EF_OK)
        return rc;
    for (int i = 0; i < started; i++)
        if (job[i].rc != EF_OK) {
            if (m)
                *m = job[i].msg;
            return job[i].rc;
        }
    return EF_OK;
}
