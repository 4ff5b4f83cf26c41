/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_verify.h
 * @brief Accuracy harness: a table's segments against the reference optimum on random
 * configurations, with the statistics the thesis reports.
 *
 * For each configuration the segment is produced exactly as a firmware would (float32 end
 * data through ef_seg_g1_cubic() / ef_seg_g2_quintic()), its C is evaluated in double on
 * the control points it produced, and compared with the reference optimum (ef_ref.h) under
 * the same bounds, warm-started also from the table's DOFs so the reference never reports
 * worse than the table's own answer.
 *
 * - relative excess of C: (C_table - C_opt) / C_opt (absolute when C_opt < 1e-9);
 * - relative DOF error: |x_table - x_opt| / max(|x_opt|, x1_min), per DOF, for x1 (both ends)
 *   and x2 (both ends, G2) separately.
 */
#ifndef EF_VERIFY_H
#define EF_VERIFY_H

#include <stdint.h>
#include "evenfeed/table/ef_table.h"
#include "evenfeed/host/core/ef_host.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Summary of one statistic over all configurations. */
typedef struct {
    double min, mean, median, p99, max;
} ef_stat_t;

typedef struct {
    uint32_t count; /**< random configurations (>= 1) */
    uint64_t seed;  /**< PRNG seed; same seed, same configurations */
    int three_d;    /**< G1 only: random twisted 3-D tangents instead of planar */
    int threads;    /**< 1..64 */
} ef_verify_opts_t;

typedef struct {
    uint32_t count;
    uint32_t clamped;    /**< configurations outside the table domain (flag set) */
    uint32_t opt_misses; /**< table beat the reference by > 1e-6 relative, beyond float32
                              rounding of its control points (should be 0) */
    ef_stat_t excess;    /**< relative excess of C */
    ef_stat_t x1_err;    /**< relative error of x1 */
    ef_stat_t x2_err;    /**< relative error of x2 (G2; zero for G1) */
    double worst_cfg[4]; /**< configuration (alpha, beta, k0, k1) of the largest excess */
    double seconds;      /**< wall time */
} ef_verify_result_t;

/**
 * @brief Draw configurations uniformly over the table's full (unfolded) domain and compare.
 * @retval EF_OK
 * @retval EF_ERR_ARG     NULL pointer, count 0, bad threads, 3-D asked for a G2 table
 * @retval EF_ERR_KIND    unknown table kind
 * @retval EF_ERR_NOMEM   allocation or thread creation failed
 * @retval EF_ERR_NOCONV  the reference failed on a configuration
 */
int ef_verify_table(const ef_table_t *tbl, const ef_verify_opts_t *o, ef_verify_result_t *r,
                    ef_msg_t *m);

#ifdef __cplusplus
}
#endif

#endif /* EF_VERIFY_H */
