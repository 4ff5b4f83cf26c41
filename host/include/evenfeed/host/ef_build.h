/**
 * @file ef_build.h
 * @brief Build a table's node values with an optimizer backend (CPU reference, or the
 * OpenGL compute builder in gpu_offline/).
 *
 * Work is cut into rows (the nodes along axis 0). A backend fills whole rows; a driver
 * (ef_build_run()) cuts the table, or one shard of it, into chunks of rows, so no single
 * call (one GPU dispatch) runs long enough to trip a watchdog, and records finished chunks
 * so an interrupted build resumes.
 */
#ifndef EF_BUILD_H
#define EF_BUILD_H

#include <stdint.h>
#include "evenfeed/host/ef_tfile.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Progress callback: nodes done so far of total; called from worker threads, serialized. */
typedef void (*ef_build_progress_fn)(void *ctx, uint32_t done, uint32_t total);

/** An optimizer backend, chosen at run time (ops struct, as libmodbus's backends). */
typedef struct {
    const char *name; /**< "cpu" or "gl" */
    /** Mandatory. Fill the values of rows [row_begin, row_end) of t with the optimum at each
     *  node's configuration (ef_build_node_config()), stored with ef_build_store(). Called
     *  from the driver's thread only; not interrupt context. Returns an ef_err code. */
    int (*solve_rows)(void *ctx, ef_tfile_t *t, uint32_t row_begin, uint32_t row_end,
                      ef_msg_t *m);
    /** Optional (may be NULL). Release ctx. */
    void (*close)(void *ctx);
    void *ctx;
    uint32_t chunk_nodes; /**< preferred nodes per chunk (the driver rounds to whole rows) */
} ef_build_backend_t;

/**
 * @brief The configuration (alpha, beta, k0, k1) a node is optimized at: the node's own,
 * except that nodes on the edges of a G1 fold region are moved 1e-6 rad inside it, because
 * those edges are symmetry lines where two mirror-image optima tie and the lookup needs
 * the branch continuous with the inside.
 */
void ef_build_node_config(const ef_tfile_t *t, uint32_t node, double cfg[EF_TABLE_MAX_AXES]);

/** @brief Store DOFs (per unit chord, double) at a node as float32, kept inside the
 *  table's bounds (float rounding could otherwise cross them). */
void ef_build_store(ef_tfile_t *t, uint32_t node, const double *dof);

/**
 * @brief The CPU reference backend: rows spread over threads, each row in order with a warm
 * start from its predecessor along axis 0, so results do not depend on the thread count.
 * @retval EF_OK
 * @retval EF_ERR_ARG  b NULL or threads outside 1..64
 */
int ef_build_backend_cpu(ef_build_backend_t *b, int threads);

/**
 * @brief Fill every node of t (created by ef_tfile_create()) with a backend, in one pass
 * (no shards, no journal). Kept for callers that need no resumability.
 * @retval EF_OK
 * @retval EF_ERR_ARG    NULL table or backend
 * @retval EF_ERR_NOCONV the optimizer failed at a node (message names the node and config)
 * @retval others        the backend's error (message says which)
 */
int ef_build_all(ef_tfile_t *t, ef_build_backend_t *b, ef_build_progress_fn progress, void *ctx,
                 ef_msg_t *m);

/** @brief ef_build_all() with the CPU backend (compatibility). */
int ef_build_cpu(ef_tfile_t *t, int threads, ef_build_progress_fn progress, void *ctx,
                 ef_msg_t *m);

#ifdef __cplusplus
}
#endif

#endif /* EF_BUILD_H */
