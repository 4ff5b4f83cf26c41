/* SPDX-License-Identifier: Apache-2.0 */
/* Path primitives (lines, arcs, helices): validation, exact frames at an arc length, and the
 * measurement of a move's curve (length, curvature bound, largest tangent components).
 * Freestanding float32, no libm: sin/cos are a fixed-count polynomial below. */
#include "evenfeed/path/ef_path.h"
#include "evenfeed/geom/ef_bezier.h"
#include "evenfeed/core/ef_config.h"
#include "evenfeed/core/ef_err.h"

/* pi/2 split so k * EF_PIO2_1 and k * EF_PIO2_2 are exact for |k| < 2^12 (11 significant
 * bits each): Cody–Waite reduction exact enough for |x| up to EF_ARC_MAX_SWEEP + 2 pi. */
#define EF_PIO2_1      1.5703125f
#define EF_PIO2_2      4.837512969970703e-4f
#define EF_PIO2_3      7.549790126e-8f
#define EF_TWO_OVER_PI 0.63661977236758134f
#define EF_TWO_PI      6.28318530717958648f
#define EF_FLT_EPS     1.1920929e-7f

/* Inlined whatever the optimizer weighs: a frame's call layer costs the M4 its arguments. */
#define EF_PRIM_INLINE static inline __attribute__((always_inline))

/* Finite without libm: NaN fails x == x, inf fails x - x == 0. */
static inline int prim_finite(float x)
{
    return (x == x) & (x - x == 0.0f);
}

/* Bound tests on the bit patterns, one word per value: the magnitude's bits order as the
 * magnitudes do, and inf and NaN lie above every finite bound, so lim - |bits| has its top bit
 * set exactly when |x| > the bound whose bits are lim, NaN and inf included. Or-ing the words
 * tests many values at once, with no float compare (on a Cortex-M4 each costs a compare, a
 * flags transfer and a conditional: the check tests up to 21 values). */
static inline uint32_t prim_abits(float x)
{
    union {
        float f;
        uint32_t u;
    } v = {x};
    return v.u & 0x7fffffffu;
}

/* Top bit set when |x| > the float whose bits are lim, or x is NaN. */
static inline uint32_t prim_over(float x, uint32_t lim)
{
    return lim - prim_abits(x);
}

/* The same for every component of a. */
static inline uint32_t prim_over3(ef_vec3_t a, uint32_t lim)
{
    return prim_over(a.x, lim) | prim_over(a.y, lim) | prim_over(a.z, lim);
}

/* The bits of the largest finite float (finite: |x| <= it) and of EF_MAX_COORD. */
#define EF_PRIM_FINITE_BITS 0x7f7fffffu
static inline uint32_t prim_coord_bits(void)
{
    return prim_abits(EF_MAX_COORD);
}

/* All three components finite (no range bound), to reject NaN/inf control points. */
static inline int prim_v3_finite(ef_vec3_t a)
{
    return prim_finite(a.x) & prim_finite(a.y) & prim_finite(a.z);
}

/* sin and cos of x (|x| < 6400) with a fixed instruction count: Cody–Waite reduction to
 * [-pi/4, pi/4] and the fdlibm float kernels (error about 1 ulp on the reduced argument). */
static void prim_sincosf(float x, float *s, float *c)
{
    float kf = ef_floorf(x * EF_TWO_OVER_PI + 0.5f);
    int k = (int)kf;
    float r = ((x - kf * EF_PIO2_1) - kf * EF_PIO2_2) - kf * EF_PIO2_3;
    float z = r * r;
    float sr = r + r * z *
                       (-1.6666667163e-01f +
                        z * (8.3333337680e-03f + z * (-1.9841270114e-04f + z * 2.7183114939e-06f)));
    float cr = 1.0f - 0.5f * z +
               z * z *
                   (4.1666667908e-02f +
                    z * (-1.3888889225e-03f +
                         z * (2.4801587642e-05f +
                              z * (-2.7557314297e-07f +
                                   z * (2.0875723372e-09f + z * -1.1359647598e-11f)))));
    /* Quadrant q = k mod 4 (two's complement keeps it right for k < 0). */
    int q = k & 3;
    const float ssel[4] = {sr, cr, -sr, -cr};
    const float csel[4] = {cr, -sr, -cr, sr};
    *s = ssel[q];
    *c = csel[q];
}

/* Fill an arc's frame (ef_prim_geo_t) from its start point, shared by check and frame. */
static void prim_arc_geo(ef_vec3_t start, const ef_prim_t *pr, ef_prim_geo_t *g)
{
    float aa = ef_v3_dot(pr->axis, pr->axis);
    ef_vec3_t a = ef_v3_scale(pr->axis, 1.0f / ef_sqrtf(ef_maxf(aa, 1e-30f)));
    ef_vec3_t d0 = ef_v3_sub(start, pr->centre);
    float h0 = ef_v3_dot(d0, a);
    ef_vec3_t w0 = ef_v3_axpy(d0, -h0, a); /* radial part of start - centre */
    float r0 = ef_v3_norm(w0);
    ef_vec3_t eu = ef_v3_scale(w0, 1.0f / ef_maxf(r0, 1e-30f));
    ef_vec3_t d1 = ef_v3_sub(pr->end, pr->centre);
    float h = ef_v3_dot(d1, a) - h0;
    float ang = r0 * ef_fabsf(pr->sweep);
    g->a = a;
    g->base = ef_v3_axpy(start, -r0, eu);
    g->eu = eu;
    g->ev = ef_v3_cross(a, eu);
    g->r0 = r0;
    g->h = h;
    g->len = ef_sqrtf(ang * ang + h * h);
    /* The end's angle, for the check, the end gap and the end frame: one evaluation instead
     * of one each. The clamp is an identity on a checked sweep; on any other (ef_prim_geo()
     * does not validate) it keeps the reduction's integer conversion defined. */
    prim_sincosf(ef_minf(ef_maxf(pr->sweep, -EF_ARC_MAX_SWEEP), EF_ARC_MAX_SWEEP), &g->sn1,
                 &g->cs1);
}

/* An arc's model point at the angle with sine sn and cosine cs and axial fraction frac of the
 * rise; rad: the outward radial unit there. Shared by ef_prim_frame() and ef_prim_end_gap(),
 * which must agree on where the model ends. */
static inline ef_vec3_t prim_arc_point(const ef_prim_geo_t *g, float sn, float cs, float frac,
                                       ef_vec3_t *rad)
{
    *rad = ef_v3_add(ef_v3_scale(g->eu, cs), ef_v3_scale(g->ev, sn));
    return ef_v3_axpy(ef_v3_axpy(g->base, g->r0, *rad), g->h * frac, g->a);
}

/* A line's geometry, and what a refused primitive leaves: all zero. */
static void prim_geo_zero(ef_prim_geo_t *g)
{
    ef_prim_geo_t zero = {{0.0f, 0.0f, 0.0f},
                          {0.0f, 0.0f, 0.0f},
                          {0.0f, 0.0f, 0.0f},
                          {0.0f, 0.0f, 0.0f},
                          0.0f,
                          0.0f,
                          0.0f,
                          0.0f,
                          0.0f};
    *g = zero;
}

/* ef_prim_check() keeping the arc's geometry in *g (prim_arc_geo(), as ef_prim_geo()). */
static int prim_check(ef_vec3_t start, const ef_prim_t *pr, float *len, ef_prim_geo_t *g)
{
    if (!len)
        return EF_ERR_ARG;
    *len = 0.0f;
    if (!pr)
        return EF_ERR_ARG;
    int line = pr->kind == EF_PRIM_LINE, arc = pr->kind == EF_PRIM_ARC;
    if (!(line | arc) || (pr->flags & ~(uint32_t)EF_PRIM_STOP_BEFORE) != 0u)
        return EF_ERR_ARG;
    /* start, end (and centre) within EF_MAX_COORD; feed, tol, qtol (and axis, sweep) finite */
    const uint32_t lc = prim_coord_bits(), lf = EF_PRIM_FINITE_BITS;
    uint32_t over = prim_over3(start, lc) | prim_over3(pr->end, lc) | prim_over(pr->feed, lf) |
                    prim_over(pr->tol, lf) | prim_over(pr->qtol, lf);
    if (arc)
        over |= prim_over3(pr->centre, lc) | prim_over3(pr->axis, lf) | prim_over(pr->sweep, lf);
    if (over >> 31)
        return EF_ERR_NONFINITE;
    if (!(pr->tol >= 0.0f) || !(pr->qtol >= 0.0f))
        return EF_ERR_ARG;
    if (!(pr->feed > 0.0f))
        return EF_ERR_FEED;

    if (line) {
        float l = ef_v3_norm(ef_v3_sub(pr->end, start));
        if (!(l >= EF_MIN_CHORD))
            return EF_ERR_DEGENERATE;
        *len = l;
        return EF_OK;
    }

    /* Arc / helix. */
    float aa = ef_v3_dot(pr->axis, pr->axis);
    if (!(ef_fabsf(aa - 1.0f) <= 2.0f * EF_UNIT_TOL))
        return EF_ERR_ARC;
    float asw = ef_fabsf(pr->sweep);
    if (!(asw > 0.0f) || !(asw <= EF_ARC_MAX_SWEEP))
        return EF_ERR_ARC;
    prim_arc_geo(start, pr, g);
    if (!(g->r0 >= EF_MIN_CHORD))
        return EF_ERR_DEGENERATE;
    float rtol = ef_maxf(EF_ARC_ABS_TOL, EF_ARC_REL_TOL * g->r0);
    ef_vec3_t d1 = ef_v3_sub(pr->end, pr->centre);
    float x1 = ef_v3_dot(d1, g->eu), y1 = ef_v3_dot(d1, g->ev);
    float r1 = ef_sqrtf(x1 * x1 + y1 * y1);
    if (!(ef_fabsf(r1 - g->r0) <= rtol))
        return EF_ERR_ARC;
    /* The end against the point the sweep reaches on its circle (of the end's radius): their
     * distance in the arc's plane, r1 2 sin(|d angle| / 2), at most r1 allow, where allow is
     * the radius tolerance as an angle plus the float32 rounding of the sweep itself (a few
     * ulp of |sweep| and of the sine and cosine), so a many-turn arc is not refused for its
     * representation. The distance form needs no arc tangent (the sweep's sine and cosine
     * are the geometry's, kept for the frames) and no reduction modulo 2 pi. */
    float allow = rtol / g->r0 + 8.0f * EF_FLT_EPS * (asw + EF_TWO_PI);
    float ex = x1 - r1 * g->cs1, ey = y1 - r1 * g->sn1, ar = allow * r1;
    if (!(ex * ex + ey * ey <= ar * ar))
        return EF_ERR_ARC;
    if (!(g->len >= EF_MIN_CHORD) || !prim_finite(g->len))
        return EF_ERR_DEGENERATE;
    /* Every point of the arc, not only its ends and centre, within EF_MAX_COORD: the
     * circle's reach from the centre (radius plus the helix's rise) bounds it. Without this
     * a large arc near the limit makes pieces and blends no move may hold. */
    float cm =
        ef_maxf(ef_maxf(ef_fabsf(pr->centre.x), ef_fabsf(pr->centre.y)), ef_fabsf(pr->centre.z));
    if (!(cm + g->r0 + rtol + ef_fabsf(g->h) <= EF_MAX_COORD))
        return EF_ERR_NONFINITE;
    *len = g->len;
    return EF_OK;
}

/* Validate a primitive and give its length (contract in ef_path.h). */
int ef_prim_check(ef_vec3_t start, const ef_prim_t *pr, float *len)
{
    ef_prim_geo_t g;
    return prim_check(start, pr, len, &g);
}

/* ef_prim_check() and ef_prim_geo() in one (contract in ef_path.h). */
int ef_prim_check_geo(ef_vec3_t start, const ef_prim_t *pr, float *len, ef_prim_geo_t *geo)
{
    if (!geo)
        return EF_ERR_ARG;
    /* An arc the check passes has had every field filled (prim_arc_geo()); anything else is
     * zeroed here, once. */
    int rc = prim_check(start, pr, len, geo);
    if (rc != EF_OK || pr->kind != EF_PRIM_ARC)
        prim_geo_zero(geo);
    return rc;
}

/* An arc's geometry for repeated frames (contract in ef_path.h). */
void ef_prim_geo(ef_vec3_t start, const ef_prim_t *pr, ef_prim_geo_t *g)
{
    if (!g)
        return;
    if (pr && pr->kind == EF_PRIM_ARC)
        prim_arc_geo(start, pr, g); /* every field */
    else
        prim_geo_zero(g);
}

/* Exact position, tangent, normal, curvature at arc length s (contract in ef_path.h). */
int ef_prim_frame(ef_vec3_t start, const ef_prim_t *pr, float s, ef_frame_t *out)
{
    ef_prim_geo_t g;
    ef_prim_geo(start, pr, &g);
    return ef_prim_frame_geo(start, pr, &g, s, out);
}

/* A line's frame at s (clamped to [0, len]; NaN counts as 0). */
static void prim_line_frame(ef_vec3_t start, const ef_prim_t *pr, float s, ef_frame_t *out)
{
    ef_vec3_t d = ef_v3_sub(pr->end, start);
    float len = ef_v3_norm(d);
    float inv = 1.0f / ef_maxf(len, 1e-30f);
    float sc = ef_minf(ef_maxf(s, 0.0f), len); /* NaN s clamps to 0 */
    int at_end = sc >= len;
    ef_vec3_t u = ef_v3_scale(d, inv);
    ef_vec3_t p = ef_v3_axpy(start, sc, u);
    out->p.x = ef_selectf(at_end, pr->end.x, p.x);
    out->p.y = ef_selectf(at_end, pr->end.y, p.y);
    out->p.z = ef_selectf(at_end, pr->end.z, p.z);
    out->t = u;
}

/* An arc's frame at the clamped arc length sc, fraction frac = sc / len of it, the angle's
 * sine sn and cosine cs: shared by ef_prim_frame_geo() and ef_prim_frame_end_geo(), which
 * differ only in where the sine and cosine come from. */
EF_PRIM_INLINE void prim_arc_frame(ef_vec3_t start, const ef_prim_t *pr, const ef_prim_geo_t *g,
                                   float sc, float frac, float sn, float cs, ef_frame_t *out)
{
    float len = g->len;
    ef_vec3_t rad;
    ef_vec3_t p = prim_arc_point(g, sn, cs, frac, &rad);
    /* dp/ds: (r0 sweep / len) (-sin e_u + cos e_v) + (h / len) a, unit by construction. */
    float il = 1.0f / ef_maxf(len, 1e-30f);
    ef_vec3_t tan = ef_v3_add(ef_v3_scale(g->eu, -sn), ef_v3_scale(g->ev, cs));
    ef_vec3_t t = ef_v3_axpy(ef_v3_scale(tan, g->r0 * pr->sweep * il), g->h * il, g->a);
    t = ef_v3_scale(t, 1.0f / ef_maxf(ef_v3_norm(t), 1e-30f));
    int at_end = sc >= len, at_start = sc <= 0.0f;
    out->p.x = ef_selectf(at_end, pr->end.x, ef_selectf(at_start, start.x, p.x));
    out->p.y = ef_selectf(at_end, pr->end.y, ef_selectf(at_start, start.y, p.y));
    out->p.z = ef_selectf(at_end, pr->end.z, ef_selectf(at_start, start.z, p.z));
    out->t = t;
    out->n = ef_v3_scale(rad, -1.0f); /* towards the axis */
    /* r / (r^2 + c^2), c = h / sweep, written as r sweep^2 / len^2 (len^2 = r^2 sw^2 + h^2). */
    float q = pr->sweep * il;
    out->kappa = g->r0 * q * q;
}

/* What both frame entry points start with: out zeroed (so a refused call leaves nothing to
 * drive), the arguments checked. */
EF_PRIM_INLINE int prim_frame_begin(const ef_prim_t *pr, const ef_prim_geo_t *geo, ef_frame_t *out)
{
    if (!out)
        return EF_ERR_ARG;
    ef_frame_t zero = {{0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f}, 0.0f};
    *out = zero;
    if (!pr || (pr->kind != EF_PRIM_LINE && pr->kind != EF_PRIM_ARC) || !geo)
        return EF_ERR_ARG;
    return EF_OK;
}

/* The same with the arc's geometry from ef_prim_geo() (contract in ef_path.h). */
int ef_prim_frame_geo(ef_vec3_t start, const ef_prim_t *pr, const ef_prim_geo_t *geo, float s,
                      ef_frame_t *out)
{
    int rc = prim_frame_begin(pr, geo, out);
    if (rc != EF_OK)
        return rc;
    if (pr->kind == EF_PRIM_LINE) {
        prim_line_frame(start, pr, s, out);
        return EF_OK;
    }
    float len = geo->len;
    float sc = ef_minf(ef_maxf(s, 0.0f), len);
    float frac = sc / ef_maxf(len, 1e-30f);
    float sn, cs;
    prim_sincosf(pr->sweep * frac, &sn, &cs);
    prim_arc_frame(start, pr, geo, sc, frac, sn, cs, out);
    return EF_OK;
}

/* The frame at either end, the angle's sine and cosine known (contract in ef_path.h). At
 * s = 0 the angle is sweep * 0, a zero of either sign, whose sine prim_sincosf() gives as +0
 * and cosine as 1; at s = len the fraction is len / len = 1, the angle the sweep itself,
 * whose sine and cosine the geometry holds. */
int ef_prim_frame_end_geo(ef_vec3_t start, const ef_prim_t *pr, const ef_prim_geo_t *geo,
                          int at_end, ef_frame_t *out)
{
    int rc = prim_frame_begin(pr, geo, out);
    if (rc != EF_OK)
        return rc;
    if (pr->kind == EF_PRIM_LINE) {
        prim_line_frame(start, pr, at_end ? 3.4e38f : 0.0f, out);
        return EF_OK;
    }
    float len = geo->len;
    float sc = at_end ? len : 0.0f;
    float frac = sc / ef_maxf(len, 1e-30f);
    float sn = at_end ? geo->sn1 : 0.0f, cs = at_end ? geo->cs1 : 1.0f;
    prim_arc_frame(start, pr, geo, sc, frac, sn, cs, out);
    return EF_OK;
}

/* Distance of an arc's end from its model's end (contract in ef_path.h). */
float ef_prim_end_gap(ef_vec3_t start, const ef_prim_t *pr)
{
    ef_prim_geo_t g;
    ef_prim_geo(start, pr, &g);
    return ef_prim_end_gap_geo(pr, &g);
}

/* The same with the arc's geometry from ef_prim_geo() (contract in ef_path.h). */
float ef_prim_end_gap_geo(const ef_prim_t *pr, const ef_prim_geo_t *geo)
{
    if (!pr || pr->kind != EF_PRIM_ARC || !geo)
        return 0.0f;
    const ef_prim_geo_t g = *geo;
    ef_vec3_t rad;
    ef_vec3_t p = prim_arc_point(&g, g.sn1, g.cs1, 1.0f, &rad);
    return ef_v3_norm(ef_v3_sub(pr->end, p));
}

/* Cubic Bernstein evaluation, for the second hodograph in ef_move_measure(). */
static ef_vec3_t prim_mm_b3(const ef_vec3_t *p, float t)
{
    float u = 1.0f - t;
    ef_vec3_t r = ef_v3_scale(p[0], u * u * u);
    r = ef_v3_axpy(r, 3.0f * u * u * t, p[1]);
    r = ef_v3_axpy(r, 3.0f * u * t * t, p[2]);
    return ef_v3_axpy(r, t * t * t, p[3]);
}

/* Quadratic Bernstein combination of p[0..2] at t. */
static ef_vec3_t prim_mm_b2(const ef_vec3_t *p, float t)
{
    float u = 1.0f - t;
    ef_vec3_t r = ef_v3_scale(p[0], u * u);
    r = ef_v3_axpy(r, 2.0f * u * t, p[1]);
    return ef_v3_axpy(r, t * t, p[2]);
}

/* Degree elevation of p (degree n, n + 1 points) in place to degree n + 1. */
static void prim_mm_elevate(ef_vec3_t *p, int n)
{
    p[n + 1] = p[n];
    for (int i = n; i >= 1; i--) {
        float a = (float)i / (float)(n + 1);
        p[i] = ef_v3_add(ef_v3_scale(p[i - 1], a), ef_v3_scale(p[i], 1.0f - a));
    }
}

/* Clear a move's measured fields and pass rc on, so failures leave no stale data. */
static void prim_aux_zero(ef_move_t *m)
{
    for (int k = 0; k < EF_AUX_N; k++)
        m->atabs[k] = m->akabs[k] = m->akjerk[k] = 0.0f;
}

static int prim_move_measure_fail(ef_move_t *m, int rc)
{
    m->length = 0.0f;
    m->kappa_max = 0.0f;
    m->tabs = m->kabs = m->kjerk = ef_v3(0.0f, 0.0f, 0.0f);
    prim_aux_zero(m);
    return rc;
}

/* Bit k set: auxiliary axis k moves on the move (its control points differ); -1 when one is
 * not finite. */
static int prim_aux_moving(const ef_move_t *m)
{
    /* branch-free: every move of every caller comes through here (a few instructions per
     * value); z turns NaN at a NaN or an infinity (inf x 0) */
    int mask = 0;
    float z = 0.0f;
    for (int k = 0; k < EF_AUX; k++) {
        const float *c = m->ab[k];
        int mv = 0;
        for (int i = 0; i <= m->degree && i < 6; i++) {
            z += c[i] * 0.0f;
            mv |= c[i] != c[0];
        }
        mask |= mv << k;
    }
    return z == 0.0f ? mask : -1;
}

/* Measure a move's length, curvature bound and tangent bounds (contract in ef_path.h). */
int ef_move_measure(ef_move_t *m)
{
    if (!m)
        return EF_ERR_ARG;
    int deg = m->degree;
    if (deg != 1 && deg != 3 && deg != 5)
        return prim_move_measure_fail(m, EF_ERR_ARG);
    int finite = 1;
    for (int i = 0; i <= deg; i++)
        finite &= prim_v3_finite(m->b[i]);
    int amask = prim_aux_moving(m);
    if (!finite || amask < 0)
        return prim_move_measure_fail(m, EF_ERR_NONFINITE);
    prim_aux_zero(m);

    if (deg == 1 && (m->flags & EF_MOVE_AUX_ONLY)) {
        /* X Y Z stay: the path parameter is the auxiliary axes' own distance */
        float l2 = 0.0f;
        for (int k = 0; k < EF_AUX; k++) {
            float d = m->ab[k][1] - m->ab[k][0];
            l2 += d * d;
        }
        float l = ef_sqrtf(l2);
        float inv = 1.0f / ef_maxf(l, 1e-30f);
        m->length = l;
        m->kappa_max = 0.0f;
        m->tabs = m->kabs = m->kjerk = ef_v3(0.0f, 0.0f, 0.0f);
        for (int k = 0; k < EF_AUX; k++)
            m->atabs[k] = ef_fabsf(m->ab[k][1] - m->ab[k][0]) * inv;
        if (!prim_finite(l))
            return prim_move_measure_fail(m, EF_ERR_NONFINITE);
        return EF_OK;
    }
    if (deg == 1) {
        ef_vec3_t d = ef_v3_sub(m->b[1], m->b[0]);
        float l = ef_v3_norm(d);
        float inv = 1.0f / ef_maxf(l, 1e-30f);
        m->length = l;
        m->kappa_max = 0.0f;
        m->tabs = ef_v3(ef_fabsf(d.x) * inv, ef_fabsf(d.y) * inv, ef_fabsf(d.z) * inv);
        m->kabs = m->kjerk = ef_v3(0.0f, 0.0f, 0.0f);
        for (int k = 0; k < EF_AUX; k++)
            if (amask & (1 << k))
                m->atabs[k] = ef_fabsf(m->ab[k][1] - m->ab[k][0]) * inv;
        if (!prim_finite(l))
            return prim_move_measure_fail(m, EF_ERR_NONFINITE);
        return EF_OK;
    }

    /* The moving auxiliary axes' hodographs (scalars, not elevated: ef_bezier_eval_scalar() takes
     * any degree). */
    float a1[EF_AUX_N][5], a2[EF_AUX_N][4], a3[EF_AUX_N][3];
    float aab[EF_AUX_N], aak[EF_AUX_N], aaj[EF_AUX_N];
    for (int k = 0; k < EF_AUX && amask; k++) {
        aab[k] = aak[k] = aaj[k] = 0.0f;
        if (!(amask & (1 << k)))
            continue;
        for (int i = 0; i < deg; i++)
            a1[k][i] = (float)deg * (m->ab[k][i + 1] - m->ab[k][i]);
        for (int i = 0; i + 1 < deg; i++)
            a2[k][i] = (float)(deg - 1) * (a1[k][i + 1] - a1[k][i]);
        for (int i = 0; i + 2 < deg; i++)
            a3[k][i] = (float)(deg - 2) * (a2[k][i + 1] - a2[k][i]);
    }

    /* Hodograph (degree deg - 1) and second hodograph (deg - 2) control points, once (for a
     * cubic elevated to degrees 4 and 3, exact up to rounding); then every node is a
     * Bernstein combination of them: the same nodes and samples as evaluating the curve's
     * derivatives by de Casteljau's algorithm, in about a sixth of the instructions. */
    ef_vec3_t h1[5], h2[4], h3[3];
    for (int i = 0; i < deg; i++)
        h1[i] = ef_v3_scale(ef_v3_sub(m->b[i + 1], m->b[i]), (float)deg);
    for (int i = 0; i + 1 < deg; i++)
        h2[i] = ef_v3_scale(ef_v3_sub(h1[i + 1], h1[i]), (float)(deg - 1));
    for (int i = 0; i + 2 < deg; i++)
        h3[i] = ef_v3_scale(ef_v3_sub(h2[i + 1], h2[i]), (float)(deg - 2));
    if (deg == 3) {
        prim_mm_elevate(h1, 2);
        prim_mm_elevate(h1, 3);
        prim_mm_elevate(h2, 1);
        prim_mm_elevate(h2, 2);
        h3[1] = h3[2] = h3[0]; /* a constant, as a quadratic */
    }
    float len = ef_bezier_h4_length_halves(h1); /* followed to the end: ef_bezier.h */
    float kmax = 0.0f;
    float ilen = 1.0f / ef_maxf(len, 1e-30f);
    float ilen2 = ilen * ilen, ilen3 = ilen2 * ilen;
    ef_vec3_t tabs = ef_v3(0.0f, 0.0f, 0.0f), kabs = tabs, kjerk = tabs;
    for (int i = 0; i <= EF_MOVE_SAMPLES; i++) {
        float t = (float)i * (1.0f / (float)EF_MOVE_SAMPLES);
        ef_vec3_t d1 = ef_bezier_b4(h1, t), d2 = prim_mm_b3(h2, t), d3 = prim_mm_b2(h3, t);
        float sp = ef_v3_norm(d1);
        float isp = 1.0f / ef_maxf(sp, 1e-30f);
        float k = ef_v3_norm(ef_v3_cross(d1, d2)) * isp * isp * isp;
        kmax = ef_maxf(kmax, k);
        /* Curvature vector (d2 less its tangential part, / sp^2): what arc-length stepping
         * accelerates each axis by per unit v^2; f'' / L^2 is what uniform stepping does.
         * The planner takes the larger per axis (its centripetal and jerk limits). */
        ef_vec3_t tn = ef_v3_scale(d1, isp);
        ef_vec3_t kv = ef_v3_scale(ef_v3_axpy(d2, -ef_v3_dot(d2, tn), tn), isp * isp);
        kabs.x = ef_maxf(kabs.x, ef_maxf(ef_fabsf(kv.x), ef_fabsf(d2.x) * ilen2));
        kabs.y = ef_maxf(kabs.y, ef_maxf(ef_fabsf(kv.y), ef_fabsf(d2.y) * ilen2));
        kabs.z = ef_maxf(kabs.z, ef_maxf(ef_fabsf(kv.z), ef_fabsf(d2.z) * ilen2));
        /* Third derivative by arc length (what arc-length stepping jerks each axis by per
         * unit v^3), d3p/ds3 = f'''/s^3 - 3 s' f''/s^4 + (3 s'^2/s^5 - s''/s^4) f' with
         * s = |f'|, and f''' / L^3 (uniform stepping): the larger per axis. */
        float s1 = ef_v3_dot(d1, d2) * isp;
        float s2 = (ef_v3_dot(d2, d2) + ef_v3_dot(d1, d3)) * isp - s1 * s1 * isp;
        float i3 = isp * isp * isp, i4 = i3 * isp;
        ef_vec3_t js = ef_v3_axpy(ef_v3_scale(d3, i3), -3.0f * s1 * i4, d2);
        js = ef_v3_axpy(js, 3.0f * s1 * s1 * i4 * isp - s2 * i4, d1);
        kjerk.x = ef_maxf(kjerk.x, ef_maxf(ef_fabsf(js.x), ef_fabsf(d3.x) * ilen3));
        kjerk.y = ef_maxf(kjerk.y, ef_maxf(ef_fabsf(js.y), ef_fabsf(d3.y) * ilen3));
        kjerk.z = ef_maxf(kjerk.z, ef_maxf(ef_fabsf(js.z), ef_fabsf(d3.z) * ilen3));
        /* Per axis, the larger of |t_i| (what arc-length stepping moves the axis by per unit
         * path speed) and |f'_i| / L (what stepping tau uniformly by the time law does, where
         * the curve's parametric speed exceeds its mean): the planner's axis limits then
         * hold for both interpolator modes. */
        float w = ef_maxf(isp, ilen);
        tabs.x = ef_maxf(tabs.x, ef_fabsf(d1.x) * w);
        tabs.y = ef_maxf(tabs.y, ef_fabsf(d1.y) * w);
        tabs.z = ef_maxf(tabs.z, ef_fabsf(d1.z) * w);
        /* An auxiliary axis a(tau) follows the same parameter: by X Y Z arc length its
         * derivatives are a' / s, (a'' - s1 a' / s) / s^2 and the third as js's (the path's
         * own s1, s2); by uniform tau a^(k) / L^k. The larger of each, as above. */
        for (int q = 0; q < EF_AUX && amask; q++) {
            if (!(amask & (1 << q)))
                continue;
            float e1 = ef_bezier_eval_scalar(a1[q], deg - 1, t),
                  e2 = ef_bezier_eval_scalar(a2[q], deg - 2, t);
            float e3 = ef_bezier_eval_scalar(a3[q], deg - 3, t);
            float ka = (e2 - s1 * e1 * isp) * isp * isp;
            float ja = e3 * i3 - 3.0f * s1 * i4 * e2 + (3.0f * s1 * s1 * i4 * isp - s2 * i4) * e1;
            aab[q] = ef_maxf(aab[q], ef_fabsf(e1) * w);
            aak[q] = ef_maxf(aak[q], ef_maxf(ef_fabsf(ka), ef_fabsf(e2) * ilen2));
            aaj[q] = ef_maxf(aaj[q], ef_maxf(ef_fabsf(ja), ef_fabsf(e3) * ilen3));
        }
    }
    for (int k = 0; k < EF_AUX && amask; k++) {
        aak[k] = ef_minf(aak[k], 1e30f);
        aaj[k] = ef_minf(aaj[k], 1e30f);
        if (!(prim_finite(aab[k]) & prim_finite(aak[k]) & prim_finite(aaj[k])))
            return prim_move_measure_fail(m, EF_ERR_NONFINITE);
    }
    /* A tiny curve's bounds are huge (curvature ~ 1 / L, its rate ~ 1 / L^2) but finite:
     * saturate rather than overflow, so the planner gets a small positive speed limit. */
    const float big = 1e30f;
    kabs = ef_v3(ef_minf(kabs.x, big), ef_minf(kabs.y, big), ef_minf(kabs.z, big));
    kjerk = ef_v3(ef_minf(kjerk.x, big), ef_minf(kjerk.y, big), ef_minf(kjerk.z, big));
    int fin = prim_finite(len) & prim_finite(kmax) & prim_v3_finite(kabs) & prim_v3_finite(kjerk);
    if (!fin)
        return prim_move_measure_fail(m, EF_ERR_NONFINITE);
    m->length = len;
    m->kappa_max = kmax;
    m->tabs = tabs;
    m->kabs = kabs;
    m->kjerk = kjerk;
    for (int k = 0; k < EF_AUX && amask; k++) { /* (zeros already, without amask) */
        m->atabs[k] = aab[k];
        m->akabs[k] = aak[k];
        m->akjerk[k] = aaj[k];
    }
    return EF_OK;
}

/* Auxiliary bounds after ab changed (contract in ef_path.h). */
int ef_move_measure_aux(ef_move_t *m)
{
    if (!m)
        return EF_ERR_ARG;
    if (m->degree != 1 && m->degree != 3 && m->degree != 5)
        return prim_move_measure_fail(m, EF_ERR_ARG);
    int amask = prim_aux_moving(m);
    if (amask < 0)
        return prim_move_measure_fail(m, EF_ERR_NONFINITE);
    if (amask == 0 && !(m->flags & EF_MOVE_AUX_ONLY)) {
        prim_aux_zero(m);
        return EF_OK;
    }
    return ef_move_measure(m);
}
