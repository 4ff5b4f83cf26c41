/**
 * @file ef_build.h
 * @brief Build a table's node values with the CPU reference optimizer.
 *
 * Every node is optimized independently with the multi-start reference (ef_ref.h), plus a
 * warm start from its predecessor along axis 0. Work is split across threads by rows
 * (lines along axis 0), and each row is processed in order, so the result is identical for
 * any thread count.
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

/**
 * @brief Fill every node of t (created by ef_tfile_create()) with the reference optimum.
 * @param t        the table; its bounds (x1_min...) are the optimizer's bounds
 * @param threads  worker threads, 1..64
 * @param progress may be NULL
 * @retval EF_OK
 * @retval EF_ERR_ARG    NULL table, bad thread count
 * @retval EF_ERR_NOCONV the optimizer failed at a node (message names the node and config)
 * @retval EF_ERR_NOMEM  thread creation failed
 */
int ef_build_cpu(ef_tfile_t *t, int threads, ef_build_progress_fn progress, void *ctx,
                 ef_msg_t *m);

#ifdef __cplusplus
}
#endif

#endif /* EF_BUILD_H */
