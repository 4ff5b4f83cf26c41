/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Double-precision helper shared by tests that check firmware curves independently: the
 * control points of the k-th derivative of a Bézier curve (forward differences), without
 * the degree factor, which is returned.
 */
#ifndef EF_TESTBEZ_H
#define EF_TESTBEZ_H

#include "evenfeed/core/ef_math.h"

/* pts[0..d-k] receive the k-th forward differences of b[0..d]; returns d (d-1) ... (d-k+1). */
static inline double ef_t_bezier_diffs(const ef_vec3_t *b, int d, int k, double pts[8][3])
{
    for (int i = 0; i <= d; i++) {
        pts[i][0] = b[i].x;
        pts[i][1] = b[i].y;
        pts[i][2] = b[i].z;
    }
    double f = 1;
    for (int r = 0; r < k; r++) {
        for (int i = 0; i < d - r; i++)
            for (int c = 0; c < 3; c++)
                pts[i][c] = pts[i + 1][c] - pts[i][c];
        f *= d - r;
    }
    return f;
}

#endif
