/* SPDX-License-Identifier: Apache-2.0 */
/* Feed hold of a sampled path: the time warp (see ef_warp.h). */
#include <math.h>
#include <string.h>
#include "evenfeed/host/io/ef_warp.h"

/* Defaults and limits documented in ef_warp.h. */
void ef_warp_init(ef_warp_t *w, int axes, double dt_s, double a_min)
{
    memset(w, 0, sizeof *w);
    w->axes = axes < 1 ? 1 : axes > EF_WARP_AXES ? EF_WARP_AXES : axes;
    w->dt = dt_s > 0.0 ? dt_s : 1e-3;
    w->a = a_min > 0.0 ? a_min : 1000.0;
    w->r = w->r0 = w->r1 = 1.0;
    w->u = 1.0;
    w->T = EF_WARP_RAMP_MIN_S;
    w->last = -1;
}

/* Keep the sample in the ring. */
void ef_warp_push(ef_warp_t *w, const float *p, uint32_t tag)
{
    uint64_t k = w->n % EF_WARP_RING;
    for (int a = 0; a < w->axes; a++)
        w->s[k][a] = p[a];
    w->tag[k] = tag;
    w->n++;
}

static double warp_smoothstep(double u)
{
    u = u < 0.0 ? 0.0 : u > 1.0 ? 1.0 : u;
    return u * u * (3.0 - 2.0 * u);
}

/* The path speed at w at full rate (units/s): between the samples around it, or the two
 * newest when w is at the newest (at rate 1 it always is: a speed of 0 there made every
 * ramp the shortest, 50 ms, and the deceleration 30 v instead of a / 2). */
static double warp_speed(const ef_warp_t *w)
{
    uint64_t i = (uint64_t)w->w;
    if (i + 1 >= w->n && i >= 1)
        i--;
    if (i + 1 >= w->n)
        return 0.0;
    const float *a = w->s[i % EF_WARP_RING], *b = w->s[(i + 1) % EF_WARP_RING];
    double d = 0;
    for (int k = 0; k < w->axes; k++)
        d += ((double)b[k] - a[k]) * ((double)b[k] - a[k]);
    return sqrt(d) / w->dt;
}

/* One target at w, then w advances by the rate (ef_warp.h). */
int ef_warp_next(ef_warp_t *w, int hold, int end, float *out, uint32_t *tag)
{
    hold = hold != 0;
    if (w->n > 0 && w->w <= (double)(w->n - 1)) {
        if (hold != w->hold) {
            /* A new request: ramp from the rate now to 0 (hold) or 1 (resume), long enough
             * that the added tangential deceleration (v * 1.5 / T) stays below a / 2. */
            w->hold = hold;
            w->r0 = w->r;
            w->r1 = hold ? 0.0 : 1.0;
            w->u = 0.0;
            w->T = fmax(EF_WARP_RAMP_MIN_S, 3.0 * warp_speed(w) / w->a);
            if (hold)
                w->holds++;
        }
        uint64_t i = (uint64_t)w->w;
        double f = w->w - (double)i;
        const float *a = w->s[i % EF_WARP_RING];
        const float *b = i + 1 < w->n ? w->s[(i + 1) % EF_WARP_RING] : a; /* f = 0 then */
        for (int k = 0; k < w->axes; k++)
            out[k] = f == 0.0 ? a[k] : (float)((double)a[k] + f * ((double)b[k] - a[k]));
        *tag = w->tag[i % EF_WARP_RING];
        w->last = f == 0.0 ? (int64_t)i : -1;
        if (w->u < 1.0) {
            w->u += w->dt / w->T;
            w->r = w->u >= 1.0 ? w->r1 : w->r0 + (w->r1 - w->r0) * warp_smoothstep(w->u);
        }
        if (w->r == 0.0)
            w->held_s += w->dt;
        w->w += w->r;
        return 1;
    }
    if (end && w->n > 0 && w->last != (int64_t)(w->n - 1)) {
        /* The warp ended between samples: the last one is where the path ends. */
        uint64_t i = w->n - 1;
        for (int k = 0; k < w->axes; k++)
            out[k] = w->s[i % EF_WARP_RING][k];
        *tag = w->tag[i % EF_WARP_RING];
        w->last = (int64_t)i;
        w->w = (double)i + 1.0;
        return 1;
    }
    return 0;
}
