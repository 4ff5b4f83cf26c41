/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_warp.h
 * @brief Feed hold of a sampled path: a time warp between the pipeline's setpoints and the
 * targets a streamer sends (CAN CSP, Modbus direct mode).
 *
 * Samples arrive at a fixed period dt (sample i belongs to time i dt); targets leave at the
 * same period, each at a virtual time w (in samples), linear between the two samples around
 * it, and w advances by a rate r in [0, 1] per target. r = 1 passes the samples through
 * unchanged. A hold ramps r to 0 along a smoothstep over T = max(::EF_WARP_RAMP_MIN_S,
 * 3 v / a), v the path speed at w and a the smallest axis acceleration limit, so the
 * tangential deceleration it adds (1.5 v / T at the steepest) stays within a / 2; a resume
 * ramps it back. Held (r = 0), the same target leaves every period. Every target lies on
 * the polyline of the samples, w never goes back, no sample is skipped, and the last
 * target of a finished path is its last sample exactly.
 *
 * Use: ef_warp_push() each sample, then take targets with ef_warp_next() until it says it
 * needs the next sample (0); at the path's end (or before an event that needs the axes at
 * the last sample) call it with end set until 0. While held, ef_warp_next() keeps giving the
 * same target: the caller paces it (one per period) and so holds the pipeline back. Only
 * the newest ::EF_WARP_RING samples are kept, enough because the caller takes every target
 * before it pushes the next sample.
 */
#ifndef EF_WARP_H
#define EF_WARP_H

#include <stdint.h>
#include "evenfeed/core/ef_config.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Samples kept (a power of two, > 2: the two around w and the newest). */
#define EF_WARP_RING 8u
/** Axes a sample has at most. */
#define EF_WARP_AXES EF_AXES
/** Shortest hold or resume ramp (s): a slow path still gets a gentle one. */
#define EF_WARP_RAMP_MIN_S 0.05

/** Warp state (public for static allocation; read the documented fields only). */
typedef struct {
    int axes;  /**< axes per sample, 1..EF_WARP_AXES */
    double dt; /**< sample and target period (s) */
    double a;  /**< smallest axis acceleration limit (units/s^2) */
    float s[EF_WARP_RING][EF_WARP_AXES];
    uint32_t tag[EF_WARP_RING];
    uint64_t n;          /**< samples pushed */
    double w;            /**< virtual time of the next target (samples) */
    double r;            /**< rate now */
    double r0, r1, u, T; /* ramp from r0 to r1, phase u in [0, 1], length T (s) */
    int hold;            /**< the hold request the ramp follows */
    int64_t last;        /* sample the last target was exactly (-1: between two) */
    uint32_t holds;      /**< holds begun */
    double held_s;       /**< time of the targets given at rate 0 (s) */
} ef_warp_t;

/**
 * @brief Start at rate 1 with no samples.
 * @param axes 1..EF_WARP_AXES (clamped)
 * @param dt_s period (s), > 0
 * @param a_min smallest axis acceleration limit (units/s^2); not positive: 1000
 */
void ef_warp_init(ef_warp_t *w, int axes, double dt_s, double a_min);

/** @brief The next sample (axes values) and its tag (the program line). */
void ef_warp_push(ef_warp_t *w, const float *p, uint32_t tag);

/**
 * @brief The next target, if the samples pushed cover it.
 * @param hold the hold request now (nonzero: hold); a change starts a ramp from the rate
 *             reached
 * @param end  the path ends after the samples pushed: when the warp is between the last two,
 *             give the last sample itself
 * @param out  the target (axes values)
 * @param tag  its tag (the line of the sample before it)
 * @return 1 with a target in out, 0 when the next sample is needed (or, end set, all given)
 */
int ef_warp_next(ef_warp_t *w, int hold, int end, float *out, uint32_t *tag);

#ifdef __cplusplus
}
#endif

#endif /* EF_WARP_H */
