/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Setpoint continuity checker (issue 18, deliverable 5), shared by test_continuity.c and
 * the runtime-chain fuzzer (tests/fuzz/fuzz_smooth.c). Header only: every function is
 * static inline, file-local names start with spc_.
 *
 * Feed it the interpolator's setpoints (ef_interp_process()) one servo period dt apart.
 * Per axis it forms, in double, from the float32 positions as the drive receives them:
 *
 *   acceleration  a_k = (p[k+1] - 2 p[k] + p[k-1]) / dt^2            (stride 1)
 *   jerk          j_k = (p[k+3h] - 3 p[k+2h] + 3 p[k+h] - p[k]) / (h dt)^3   (stride h)
 *
 * and checks |a| <= a_axis (1 + SPC_A_REL) + 4 E / dt^2 and, when j_max > 0,
 * |j| <= j_max (1 + SPC_J_REL) + 8 E / (h dt)^3. The worst sample of each (largest
 * |value| / allowed) is kept: time, axis, move seq at both ends of the window (different
 * when it spans a junction), source line and planned speed at its centre, value, limit,
 * allowed.
 *
 * ## Why a difference of a limited law stays within the limit (the relative margins)
 * A second difference of p over [t - dt, t + dt] is the average of p'' weighted by the
 * hat function (unit mass, >= 0); a third difference at stride h is the average of p'''
 * over [t, t + 3 h dt] weighted by the quadratic B-spline. So a law whose acceleration
 * (jerk) never exceeds the limit gives differences within the limit exactly, at any
 * stride: sampling needs no margin. A jump of the law does not average away: a speed step
 * dv gives a second difference dv / dt (1 mm/s: 1000 mm/s^2 at 1 ms), an acceleration step
 * da a stride-h third difference of about da / (h dt). The relative margins
 * SPC_A_REL = SPC_J_REL = 2 % only cover what the planner bounds from samples: tabs and
 * kappa_max are taken at 17 points of each curve (ef_move_measure()), which the curve may
 * exceed in between by ~0.2 % (ef_path.h), and the corrected step follows the law to
 * ~1e-5 of the arc length.
 *
 * ## The float32 margin E (positions)
 * A setpoint axis value p is float32. Its error against the exact trajectory is bounded by
 *   - the final rounding p = b0 + d:              0.5 ulp(p) <= 2^-24 |p|
 *   - the curve evaluation relative to b0 (degree <= 5 de Casteljau or Horner, |d| <= L):
 *                                                 about 2^-24 x 2 L
 *   - tau = s / L rounded (law polynomial, or the corrected step's s_done): 2^-24 x L
 *   - the time in the move rounded (float t): 2^-24 t x v <= 2^-24 x L (t v is the
 *     distance since the phase began, within the move)
 * with L the move's length (its control-point extent for a blend). Together, with a factor
 * 2 for the accumulation inside the evaluation:
 *
 *   E = SPC_EPS_POS x (|p| + SPC_LEN_FACTOR x L),   SPC_EPS_POS = 2^-23, SPC_LEN_FACTOR = 4
 *
 * where |p| is the largest |p| of the samples in the difference and L the largest move
 * length the caller declared (spc_scale()). The worst case of the differences is then
 * 4 E / dt^2 for the second (coefficients 1, -2, 1) and 8 E / (h dt)^3 for the third
 * (1, -3, 3, -1). At 1 ms, 100 mm and 10 mm moves: E = 1.67e-5 mm, 67 mm/s^2 (6.7 % of
 * 1000); at 50 mm and 5 mm moves 33 mm/s^2. The jerk's float margin at stride 1 would be
 * 8 E / dt^3 = 1.3e5 mm/s^3, six times J = 20 000: the jerk of float32 setpoints at 1 ms
 * is not resolvable there. The checker therefore takes the smallest stride h (1 to
 * SPC_J_STRIDE_MAX periods) whose float margin is at most SPC_J_NOISE x j_max (10 %):
 * h = 5 (5 ms) in the example above. Evaluating the differences in double (and relative to
 * the first sample) keeps the checker's own rounding out of it.
 *
 * Measured against it (test_continuity part "far": coordinates at 250 mm, 197 mm arc
 * pieces, E = 1.2e-4 mm, margin 740 mm/s^2): the second differences scatter by +-170
 * mm/s^2 about the law's 970 mm/s^2, 2.8 ulp of 250 mm per sample; on the generated
 * corpus (|p| < 60 mm, moves < 25 mm) the margin is 10-40 mm/s^2 and the planner's
 * peaks sit at 0.96 of the allowed value.
 */
#ifndef EF_SP_CHECK_H
#define EF_SP_CHECK_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "evenfeed/motion/ef_interp.h"
#include "evenfeed/motion/ef_plan.h"

/** Relative float32 position error per unit of magnitude (2^-23: one ulp at the value). */
#define SPC_EPS_POS (1.0 / 8388608.0)
/** Weight of the move length in E (evaluation, parameter and time rounding; see above). */
#define SPC_LEN_FACTOR 4.0
/** Relative margins for sampled planner bounds (see above). */
#define SPC_A_REL 0.02
#define SPC_J_REL 0.02
/** Largest share of j_max the jerk's float margin may take when choosing the stride. */
#define SPC_J_NOISE 0.1
/** Longest jerk stride (periods); the history ring holds 3 x that + 1 samples. */
#define SPC_J_STRIDE_MAX 10
#define SPC_RING         (3 * SPC_J_STRIDE_MAX + 1)

/** The worst sample of one quantity. */
typedef struct {
    double ratio;   /* |value| / allowed (> 1: a violation) */
    double value;   /* the difference (mm/s^2 or mm/s^3), signed */
    double limit;   /* the axis limit */
    double allowed; /* limit with both margins */
    double t;       /* time of the sample the difference is centred on (s) */
    int axis;       /* 0 x, 1 y, 2 z */
    int stride;     /* periods between the samples */
    uint32_t seq0;  /* move seq at the window's first sample */
    uint32_t seq1;  /* and at its last (different: the window spans a junction) */
    uint32_t tag;   /* tag (source line) of the centre sample */
    double v_plan;  /* planned path speed there */
} spc_worst_t;

typedef struct {
    /* configuration (spc_init) */
    double dt;
    double a_lim[3];
    double j_lim; /* 0: no jerk check */
    double scale; /* largest move length the caller declared (spc_scale) */
    /* history: positions relative to org, newest at ring[(n - 1) % SPC_RING] */
    double org[3];
    double p[SPC_RING][3];
    double mag[SPC_RING]; /* largest |p_i| of the sample, absolute */
    double t[SPC_RING], v[SPC_RING];
    uint32_t seq[SPC_RING], tag[SPC_RING];
    uint64_t n;        /* samples in the current run (since the last break) */
    uint64_t samples;  /* all samples */
    uint64_t a_checks; /* differences checked */
    uint64_t j_checks;
    uint64_t a_over; /* differences above allowed */
    uint64_t j_over;
    spc_worst_t wa, wj;
} spc_t;

/** Start a checker for period dt (s) and the limits lim (a_axis, j_max are used). */
static inline void spc_init(spc_t *c, double dt, const ef_limits_t *lim)
{
    memset(c, 0, sizeof *c);
    c->dt = dt;
    for (int i = 0; i < 3; i++)
        c->a_lim[i] = lim->a_axis[i];
    c->j_lim = lim->j_max > 0.0f ? lim->j_max : 0.0;
    c->wa.axis = c->wj.axis = -1;
}

/** Declare that moves up to length len (program units) are being executed (keeps the
 *  largest; call it for every move before its setpoints, or once with the largest). */
static inline void spc_scale(spc_t *c, double len)
{
    if (len > c->scale)
        c->scale = len;
}

/** The samples are no longer consecutive (a late call, a skipped interval): start a new
 *  run; differences never span the gap. */
static inline void spc_break(spc_t *c)
{
    c->n = 0;
}

/** Position error bound E for a difference whose samples reach magnitude mag. */
static inline double spc_pos_err(const spc_t *c, double mag)
{
    return SPC_EPS_POS * (mag + SPC_LEN_FACTOR * c->scale);
}

/** Float margin of the stride-h third difference for magnitude mag. */
static inline double spc_j_noise(const spc_t *c, double mag, int h)
{
    double hd = h * c->dt;
    return 8.0 * spc_pos_err(c, mag) / (hd * hd * hd);
}

/* Ring index of the sample `back` places before the newest. */
static inline int spc_at(const spc_t *c, int back)
{
    return (int)((c->n - 1u - (uint64_t)back) % SPC_RING);
}

/* Keep the difference centred on ring sample `centre` when it is the worst so far. */
static inline void spc_note(const spc_t *c, spc_worst_t *w, double value, double limit,
                            double allowed, int centre, int axis, int stride, uint32_t seq0,
                            uint32_t seq1)
{
    double r = fabs(value) / allowed;
    if (w->axis < 0 || r > w->ratio) {
        w->ratio = r;
        w->value = value;
        w->limit = limit;
        w->allowed = allowed;
        w->t = c->t[centre];
        w->axis = axis;
        w->stride = stride;
        w->seq0 = seq0;
        w->seq1 = seq1;
        w->tag = c->tag[centre];
        w->v_plan = c->v[centre];
    }
}

/** Add the setpoint taken at time t (s); checks every difference it completes. Returns
 *  the number of differences (acceleration and jerk) above their allowed value. */
static inline int spc_push(spc_t *c, double t, const ef_setpoint_t *sp)
{
    double q[3] = {sp->p.x, sp->p.y, sp->p.z};
    if (c->samples == 0)
        memcpy(c->org, q, sizeof q);
    int k = (int)(c->n % SPC_RING);
    double mag = 0;
    for (int i = 0; i < 3; i++) {
        c->p[k][i] = q[i] - c->org[i]; /* exact: both are float32 values in double */
        mag = fmax(mag, fabs(q[i]));
    }
    c->mag[k] = mag;
    c->t[k] = t;
    c->v[k] = sp->v_plan;
    c->seq[k] = sp->seq;
    c->tag[k] = sp->tag;
    c->n++;
    c->samples++;
    int over = 0;
    if (c->n >= 3) {
        int i0 = spc_at(c, 2), i1 = spc_at(c, 1), i2 = spc_at(c, 0);
        double m = fmax(c->mag[i0], fmax(c->mag[i1], c->mag[i2]));
        double noise = 4.0 * spc_pos_err(c, m) / (c->dt * c->dt);
        for (int ax = 0; ax < 3; ax++) {
            double a = (c->p[i2][ax] - 2.0 * c->p[i1][ax] + c->p[i0][ax]) / (c->dt * c->dt);
            double allowed = c->a_lim[ax] * (1.0 + SPC_A_REL) + noise;
            c->a_checks++;
            if (fabs(a) > allowed) {
                c->a_over++;
                over++;
            }
            spc_note(c, &c->wa, a, c->a_lim[ax], allowed, i1, ax, 1, c->seq[i0], c->seq[i2]);
        }
    }
    if (c->j_lim > 0) {
        /* the stride: the smallest whose float margin is within SPC_J_NOISE of j_max */
        int h = 1;
        while (h < SPC_J_STRIDE_MAX && spc_j_noise(c, c->mag[k], h) > SPC_J_NOISE * c->j_lim)
            h++;
        if (c->n >= (uint64_t)(3 * h + 1)) {
            int s[4] = {spc_at(c, 3 * h), spc_at(c, 2 * h), spc_at(c, h), spc_at(c, 0)};
            double m = 0;
            for (int b = 0; b <= 3 * h; b++)
                m = fmax(m, c->mag[spc_at(c, b)]);
            double hd = h * c->dt;
            double noise = spc_j_noise(c, m, h);
            for (int ax = 0; ax < 3; ax++) {
                double j = (c->p[s[3]][ax] - 3.0 * c->p[s[2]][ax] + 3.0 * c->p[s[1]][ax] -
                            c->p[s[0]][ax]) /
                           (hd * hd * hd);
                double allowed = c->j_lim * (1.0 + SPC_J_REL) + noise;
                c->j_checks++;
                if (fabs(j) > allowed) {
                    c->j_over++;
                    over++;
                }
                /* at the window's centre sample */
                spc_note(c, &c->wj, j, c->j_lim, allowed, spc_at(c, (3 * h + 1) / 2), ax, h,
                         c->seq[s[0]], c->seq[s[3]]);
            }
        }
    }
    return over;
}

/** Whether no difference exceeded its allowed value. */
static inline int spc_ok(const spc_t *c)
{
    return c->a_over == 0 && c->j_over == 0;
}

/** One line per quantity: the worst sample against its limit, on f. */
static inline void spc_report(const spc_t *c, const char *name, FILE *f)
{
    static const char ax[] = "xyz";
    const spc_worst_t *w = &c->wa;
    if (w->axis >= 0)
        fprintf(f,
                "%s: accel worst %.1f (limit %.0f, allowed %.1f, %.2fx allowed) axis %c t %.3f s "
                "seq %u..%u line %u v %.2f; %llu of %llu over\n",
                name, w->value, w->limit, w->allowed, w->ratio, ax[w->axis], w->t,
                (unsigned)w->seq0, (unsigned)w->seq1, (unsigned)w->tag, w->v_plan,
                (unsigned long long)c->a_over, (unsigned long long)c->a_checks);
    w = &c->wj;
    if (c->j_lim > 0 && w->axis >= 0)
        fprintf(f,
                "%s: jerk worst %.0f (limit %.0f, allowed %.0f, %.2fx allowed, stride %d) axis %c "
                "t %.3f s seq %u..%u line %u v %.2f; %llu of %llu over\n",
                name, w->value, w->limit, w->allowed, w->ratio, w->stride, ax[w->axis], w->t,
                (unsigned)w->seq0, (unsigned)w->seq1, (unsigned)w->tag, w->v_plan,
                (unsigned long long)c->j_over, (unsigned long long)c->j_checks);
}

#endif /* EF_SP_CHECK_H */
