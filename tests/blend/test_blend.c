/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Corner blends (ef_blend_corner) with the default G2 table: deviation from the programmed
 * corner measured by dense sampling on random corners in 2-D and 3-D, G2 contact with the
 * lines, trims within the neighbours' limits, the symmetry the construction relies on, and
 * every bad-input case. Prints the measured figures (docs/math.md, "Corner blends").
 */
#include <float.h>
#include <string.h>
#include "ef_test.h"
#include "evenfeed/geom/ef_bezier.h"
#include "evenfeed/blend/ef_blend.h"
#include "evenfeed/core/ef_err.h"

extern const ef_table_t ef_tbl_g2_default;
#define G2 (&ef_tbl_g2_default)

typedef struct {
    double x[3];
} dv3;

static dv3 dv(ef_vec3_t a)
{
    dv3 r = {{a.x, a.y, a.z}};
    return r;
}
static double ddot(dv3 a, dv3 b)
{
    return a.x[0] * b.x[0] + a.x[1] * b.x[1] + a.x[2] * b.x[2];
}
static dv3 dsub(dv3 a, dv3 b)
{
    dv3 r = {{a.x[0] - b.x[0], a.x[1] - b.x[1], a.x[2] - b.x[2]}};
    return r;
}
static dv3 daxpy(dv3 a, double s, dv3 b)
{
    dv3 r = {{a.x[0] + s * b.x[0], a.x[1] + s * b.x[1], a.x[2] + s * b.x[2]}};
    return r;
}
static double dnorm(dv3 a)
{
    return sqrt(ddot(a, a));
}

/* The quintic in double from the float control points (de Casteljau-free Bernstein sum). */
static dv3 quintic_at(const dv3 *b, double t)
{
    double s = 1.0 - t,
           w[6] = {s * s * s * s * s,      5 * t * s * s * s * s, 10 * t * t * s * s * s,
                   10 * t * t * t * s * s, 5 * t * t * t * t * s, t * t * t * t * t};
    dv3 r = {{0, 0, 0}};
    for (int i = 0; i < 6; i++)
        r = daxpy(r, w[i], b[i]);
    return r;
}

/* Distance from p to the segment [a, a + len u] (u unit). */
static double dist_seg(dv3 p, dv3 a, dv3 u, double len)
{
    double t = ddot(dsub(p, a), u);
    t = t < 0 ? 0 : t > len ? len : t;
    return dnorm(dsub(p, daxpy(a, t, u)));
}

/* Measured deviation of a blend from the corner polyline (v - len_in u_in .. v .. v +
 * len_out u_out): the largest distance of a curve point to the polyline, and the distance of
 * v to the curve (with the parameter where it is reached). Dense sampling plus golden-section
 * refinement around the best samples. */
#define NS 2000
typedef struct {
    double to_poly; /* max over the curve of the distance to the polyline */
    double v_dist;  /* min over the curve of |f(t) - v| */
    double v_t;     /* where */
} meas_t;

static double poly_dist(dv3 p, dv3 v, dv3 ui, dv3 uo, double len_in, double len_out)
{
    double d0 = dist_seg(p, daxpy(v, -len_in, ui), ui, len_in);
    double d1 = dist_seg(p, v, uo, len_out);
    return d0 < d1 ? d0 : d1;
}

static double refine(const dv3 *b, double lo, double hi, int maximize, dv3 v, dv3 ui, dv3 uo,
                     double li, double lo_, int to_v, double *t_best)
{
    const double gr = 0.5 * (sqrt(5.0) - 1.0);
    double a = lo < 0 ? 0 : lo, c = hi > 1 ? 1 : hi;
    for (int it = 0; it < 60; it++) {
        double x1 = c - gr * (c - a), x2 = a + gr * (c - a);
        dv3 p1 = quintic_at(b, x1), p2 = quintic_at(b, x2);
        double f1 = to_v ? dnorm(dsub(p1, v)) : poly_dist(p1, v, ui, uo, li, lo_);
        double f2 = to_v ? dnorm(dsub(p2, v)) : poly_dist(p2, v, ui, uo, li, lo_);
        if (maximize ? f1 > f2 : f1 < f2)
            c = x2;
        else
            a = x1;
    }
    double t = 0.5 * (a + c);
    dv3 p = quintic_at(b, t);
    *t_best = t;
    return to_v ? dnorm(dsub(p, v)) : poly_dist(p, v, ui, uo, li, lo_);
}

static meas_t measure(const ef_blend_t *bl, dv3 v, dv3 ui, dv3 uo, double len_in, double len_out)
{
    dv3 b[6];
    for (int i = 0; i < 6; i++)
        b[i] = dv(bl->seg.b[i]);
    meas_t m = {0, 1e300, 0};
    int imax = 0, imin = 0;
    for (int i = 0; i <= NS; i++) {
        double t = (double)i / NS;
        dv3 p = quintic_at(b, t);
        double dp = poly_dist(p, v, ui, uo, len_in, len_out);
        double dvv = dnorm(dsub(p, v));
        if (dp > m.to_poly)
            m.to_poly = dp, imax = i;
        if (dvv < m.v_dist)
            m.v_dist = dvv, m.v_t = t, imin = i;
    }
    double tb;
    double r =
        refine(b, (imax - 1.0) / NS, (imax + 1.0) / NS, 1, v, ui, uo, len_in, len_out, 0, &tb);
    if (r > m.to_poly)
        m.to_poly = r;
    r = refine(b, (imin - 1.0) / NS, (imin + 1.0) / NS, 0, v, ui, uo, len_in, len_out, 1, &tb);
    if (r < m.v_dist)
        m.v_dist = r, m.v_t = tb;
    return m;
}

/* ---- table symmetry ---------------------------------------------------------------- */

/* The construction relies on the table giving x1_0 = x1_1, x2_0 = -x2_1 at (phi, -phi, 0, 0).
 * Measure how far the interpolated DOFs are from that (ef_blend_corner averages anyway). */
static void test_table_symmetry(void)
{
    double worst_x1 = 0, worst_x2 = 0;
    for (int i = 0; i <= 20000; i++) {
        float phi = (float)(0.5 * EF_BLEND_MAX_TURN * i / 20000.0);
        float c[4] = {phi, -phi, 0, 0}, d[4];
        uint32_t cl = 99;
        EF_CHECK_EQ(ef_table_lookup_g2(G2, c, d, &cl), EF_OK);
        if (i % 1000 == 0)
            EF_CHECK_EQ(cl, 0);
        double e1 = fabs(d[0] - d[2]) / fmax(fabs(d[0]), 0.1);
        double e2 = fabs(d[1] + d[3]) / fmax(fabs(d[1]), 1.0);
        worst_x1 = fmax(worst_x1, e1);
        worst_x2 = fmax(worst_x2, e2);
    }
    printf("table symmetry at (phi,-phi,0,0): max |x1_0-x1_1|/x1 %.3g, max |x2_0+x2_1|/max(|x2|,1) "
           "%.3g\n",
           worst_x1, worst_x2);
    EF_CHECK(worst_x1 < 1e-2);
    EF_CHECK(worst_x2 < 1e-1);
}

/* ---- random corners ---------------------------------------------------------------- */

static ef_vec3_t rot_apply(const ef_t_rot3_t *r, double x, double y)
{
    return ef_v3((float)(r->m[0][0] * x + r->m[0][1] * y), (float)(r->m[1][0] * x + r->m[1][1] * y),
                 (float)(r->m[2][0] * x + r->m[2][1] * y));
}

static double log_uniform(unsigned long long *rs, double lo, double hi)
{
    return exp(ef_t_uniform(rs, log(lo), log(hi)));
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

#define NCORNER 30000
static double ratios[NCORNER], lg_ratio[NCORNER];

/* |f'(0)| / L - 1 and |f'(1)| / L - 1 of a quintic in double, the larger in magnitude (L by
 * 4000 midpoint samples of the hodograph). */
static double end_speed_dev(const ef_vec3_t *b)
{
    double h[5][3];
    for (int i = 0; i < 5; i++) {
        h[i][0] = 5.0 * ((double)b[i + 1].x - b[i].x);
        h[i][1] = 5.0 * ((double)b[i + 1].y - b[i].y);
        h[i][2] = 5.0 * ((double)b[i + 1].z - b[i].z);
    }
    double L = 0;
    for (int k = 0; k < 4000; k++) {
        double t = (k + 0.5) / 4000, u = 1 - t;
        double w[5] = {u * u * u * u, 4 * u * u * u * t, 6 * u * u * t * t, 4 * u * t * t * t,
                       t * t * t * t};
        double r[3] = {0, 0, 0};
        for (int i = 0; i < 5; i++)
            for (int c = 0; c < 3; c++)
                r[c] += w[i] * h[i][c];
        L += sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) / 4000;
    }
    double s0 = sqrt(h[0][0] * h[0][0] + h[0][1] * h[0][1] + h[0][2] * h[0][2]);
    double s1 = sqrt(h[4][0] * h[4][0] + h[4][1] * h[4][1] + h[4][2] * h[4][2]);
    return fmax(fabs(s0 / L - 1), fabs(s1 / L - 1));
}

static void test_random_corners(void)
{
    double max_end_speed = 0, max_end_speed_hp = 0;
    unsigned long long rs = 2026;
    int n_blend = 0, n_clamped = 0, n_straight = 0, n_stop = 0, n_rev = 0, n_near_rev_ok = 0;
    double max_ratio = 0, max_ratio_unclamped = 0, max_pred_err = 0, max_vt_err = 0;
    double max_tan_err = 0, max_curv = 0, max_pos_err = 0, max_rel_extra = 0;
    double max_excess = 0, max_ratio_clean = 0, clean_tan = 0, clean_curv = 0, clean_curv170 = 0;
    int n_clean = 0;
    int nr = 0, nlg = 0;
    double worst_ratio_turn = 0;
    for (int k = 0; k < NCORNER; k++) {
        int planar = k % 2 == 0;
        int cls = (k / 2) % 6;
        double theta;
        if (cls <= 2) /* uniform over (0, 179] degrees */
            theta = ef_t_uniform(&rs, 1e-9, 1.0) * (179.0 * M_PI / 180.0);
        else if (cls == 3) /* near 0 */
            theta = log_uniform(&rs, 1e-7, 1e-1);
        else if (cls == 4) /* just below the reversal threshold */
            theta = EF_BLEND_MAX_TURN - log_uniform(&rs, 1e-6, 3e-2);
        else /* around and above the threshold, up to exact reversal */
            theta = EF_BLEND_MAX_TURN + ef_t_uniform(&rs, -2e-3, M_PI - EF_BLEND_MAX_TURN);
        double tol = log_uniform(&rs, 1e-4, 10.0);
        double pmag = ef_t_rng(&rs) % 4u == 0 ? 0.0 : log_uniform(&rs, 1e-2, 1000.0);
        ef_vec3_t v =
            ef_v3((float)ef_t_uniform(&rs, -pmag, pmag), (float)ef_t_uniform(&rs, -pmag, pmag),
                  planar ? 0.0f : (float)ef_t_uniform(&rs, -pmag, pmag));
        double mi =
            ef_t_rng(&rs) % 3u == 0 ? log_uniform(&rs, 1e-7, 1e-2) : log_uniform(&rs, 1e-3, 1e3);
        double mo =
            ef_t_rng(&rs) % 3u == 0 ? log_uniform(&rs, 1e-7, 1e-2) : log_uniform(&rs, 1e-3, 1e3);
        ef_vec3_t ui, uo;
        if (planar) {
            double a0 = ef_t_uniform(&rs, -M_PI, M_PI), sg = ef_t_rng(&rs) & 1u ? 1 : -1;
            ui = ef_v3((float)cos(a0), (float)sin(a0), 0);
            uo = ef_v3((float)cos(a0 + sg * theta), (float)sin(a0 + sg * theta), 0);
        } else {
            ef_t_rot3_t r = ef_t_rot_random(&rs);
            ui = rot_apply(&r, 1, 0);
            uo = rot_apply(&r, cos(theta), sin(theta));
        }
        ef_blend_t bl;
        int rc = ef_blend_corner(G2, v, ui, uo, (float)tol, (float)mi, (float)mo, &bl);
        /* The turn the float directions really make. */
        dv3 dui = dv(ui), duo = dv(uo);
        dui = daxpy((dv3){{0, 0, 0}}, 1.0 / dnorm(dui), dui);
        duo = daxpy((dv3){{0, 0, 0}}, 1.0 / dnorm(duo), duo);
        dv3 cr = {{dui.x[1] * duo.x[2] - dui.x[2] * duo.x[1],
                   dui.x[2] * duo.x[0] - dui.x[0] * duo.x[2],
                   dui.x[0] * duo.x[1] - dui.x[1] * duo.x[0]}};
        double th = atan2(dnorm(cr), ddot(dui, duo));
        if (th > EF_BLEND_MAX_TURN + 1e-6) {
            EF_CHECK_EQ(rc, EF_ERR_REVERSAL);
            n_rev++;
            continue;
        }
        if (th > EF_BLEND_MAX_TURN - 1e-6) { /* on the threshold: either answer */
            EF_CHECK(rc == EF_OK || rc == EF_ERR_REVERSAL);
            if (rc != EF_OK) {
                n_rev++;
                continue;
            }
        }
        EF_CHECK_EQ(rc, EF_OK);
        if (rc != EF_OK)
            continue;
        n_near_rev_ok += th > EF_BLEND_MAX_TURN - 1e-3;
        EF_CHECK(bl.trim_in <= (float)mi && bl.trim_out <= (float)mo);
        EF_CHECK(bl.trim_in >= 0 && bl.trim_out >= 0);
        EF_CHECK(bl.dev <= (float)tol * (1 + 1e-6f));
        if (bl.flags & (EF_BLEND_STRAIGHT | EF_BLEND_STOP)) {
            EF_CHECK(bl.seg.degree == 0 && bl.trim_in == 0 && bl.trim_out == 0 && bl.dev == 0);
            EF_CHECK(bl.p_in.x == v.x && bl.p_in.y == v.y && bl.p_in.z == v.z);
            if (bl.flags & EF_BLEND_STRAIGHT) {
                n_straight++;
                EF_CHECK(th < EF_BLEND_MIN_TURN * 1.01);
            } else {
                n_stop++;
            }
            continue;
        }
        EF_CHECK(th >= EF_BLEND_MIN_TURN * 0.99);
        EF_CHECK_EQ(bl.seg.degree, 5);
        EF_CHECK_EQ(bl.flags & EF_BLEND_TBL_CLAMPED, 0);
        n_blend++;
        n_clamped += (bl.flags & EF_BLEND_CLAMPED) != 0;
        double L = bl.trim_in;
        dv3 dvv = dv(v);
        meas_t m = measure(&bl, dvv, dui, duo, 2.0 * mi, 2.0 * mo);
        double dev = fmax(m.to_poly, m.v_dist);
        /* float32 slack: a few ulps of the coordinates (control points are rounded there). */
        double scale = fmax(fmax(fabs(v.x), fabs(v.y)), fabs(v.z));
        double slack = 8.0 * FLT_EPSILON * fmax(scale, L);
        double ratio = dev / tol;
        /* No slack for the coordinates' rounding: ef_blend_corner keeps a margin for it. */
        EF_CHECK(dev <= tol * (1 + 1e-3));
        if (!(dev <= tol * (1 + 1e-3)))
            fprintf(stderr, "  turn %.9g tol %g L %g dev %g pred %g v %g\n", th, tol, L, dev,
                    bl.dev, scale);
        if (ratio > max_ratio)
            max_ratio = ratio, worst_ratio_turn = th;
        max_excess = fmax(max_excess, (dev - slack) / tol);
        if (slack < 1e-4 * tol)
            max_ratio_clean = fmax(max_ratio_clean, ratio), n_clean++;
        ratios[nr++] = ratio;
        if (!(bl.flags & EF_BLEND_CLAMPED)) {
            max_ratio_unclamped = fmax(max_ratio_unclamped, ratio);
            lg_ratio[nlg++] =
                L * bl.gain / (tol - 4.0 * FLT_EPSILON * scale); /* tol less the margin */
        }
        /* End speeds equal the arc length (uniform stepping's feed is continuous at the
         * junctions with the lines), up to the control points' rounding (2 ulp of the
         * coordinates in |b1 - b0| = L / 5) and, at hairpins beyond 175 degrees, the
         * quadrature of L (|f'| dips deep at the middle there: up to 1 %, at blends that are
         * jerk-bound to a crawl). */
        {
            double es = end_speed_dev(bl.seg.b);
            double es_slack = 5.0 * 2.0 * FLT_EPSILON * fmax(scale, L) / fmax(L, 1e-30);
            int hairpin = th > 3.05;
            if (es_slack < 1e-4) {
                if (hairpin)
                    max_end_speed_hp = fmax(max_end_speed_hp, es);
                else
                    max_end_speed = fmax(max_end_speed, es);
            }
            EF_CHECK(es <= (hairpin ? 1.5e-2 : 1e-4) + es_slack);
        }
        /* The programmed corner's farthest point is v, and the curve's nearest point to v is
         * its midpoint: measured |v - curve| = |f(1/2) - v| = predicted dev. */
        max_pred_err = fmax(max_pred_err, (fabs(m.v_dist - bl.dev) - slack) / fmax(bl.dev, 1e-30));
        EF_CHECK(fabs(m.v_dist - bl.dev) <= 1e-3 * bl.dev + slack);
        /* No curve point farther from the polyline than v is from the curve. */
        max_rel_extra = fmax(max_rel_extra, (m.to_poly - m.v_dist - slack) / fmax(m.v_dist, 1e-30));
        if (bl.dev > 1e3 * slack) {
            max_vt_err = fmax(max_vt_err, fabs(m.v_t - 0.5));
            EF_CHECK(fabs(m.v_t - 0.5) < 2e-2);
        }
        /* G2 contact: position, unit tangent and zero curvature at both ends, evaluated with
         * ef_bezier_eval on the control points taken relative to v (as the blend is built). */
        ef_vec3_t lb[6];
        for (int i = 0; i < 6; i++)
            lb[i] =
                ef_v3((float)((double)bl.seg.b[i].x - v.x), (float)((double)bl.seg.b[i].y - v.y),
                      (float)((double)bl.seg.b[i].z - v.z));
        double rel_slack = 8.0 * FLT_EPSILON * fmax(scale, L) / L; /* rounding relative to L */
        for (int end = 0; end < 2; end++) {
            ef_vec3_t der[3];
            EF_CHECK_EQ(ef_bezier_eval(lb, 5, (float)end, 2, der), EF_OK);
            dv3 d1 = dv(der[1]), d2 = dv(der[2]), u = end ? duo : dui;
            dv3 want = end ? daxpy(dvv, L, duo) : daxpy(dvv, -L, dui);
            dv3 got = dv(end ? bl.seg.b[5] : bl.seg.b[0]);
            double pe = dnorm(dsub(got, want)) / L;
            dv3 pin = dv(end ? bl.p_out : bl.p_in);
            EF_CHECK(pin.x[0] == got.x[0] && pin.x[1] == got.x[1] && pin.x[2] == got.x[2]);
            double n1 = dnorm(d1);
            double te = dnorm(dsub(daxpy((dv3){{0, 0, 0}}, 1.0 / n1, d1), u));
            dv3 c2 = {{d1.x[1] * d2.x[2] - d1.x[2] * d2.x[1], d1.x[2] * d2.x[0] - d1.x[0] * d2.x[2],
                       d1.x[0] * d2.x[1] - d1.x[1] * d2.x[0]}};
            double kap_l = dnorm(c2) / (n1 * n1 * n1) * L; /* curvature x trim */
            max_pos_err = fmax(max_pos_err, pe - rel_slack);
            max_tan_err = fmax(max_tan_err, te / fmax(1.0, 1e3 * rel_slack));
            max_curv = fmax(max_curv, kap_l / fmax(1.0, 1e3 * rel_slack));
            if (rel_slack < 1e-5)
                clean_tan = fmax(clean_tan, te), clean_curv = fmax(clean_curv, kap_l),
                clean_curv170 = th < 170 * M_PI / 180 ? fmax(clean_curv170, kap_l) : clean_curv170;
            EF_CHECK(pe <= 1e-6 + rel_slack);
            EF_CHECK(te <= 1e-5 + 1e3 * rel_slack);
            EF_CHECK(kap_l <= 1e-3 + 1e5 * rel_slack);
        }
    }
    qsort(ratios, (size_t)nr, sizeof ratios[0], cmp_d);
    qsort(lg_ratio, (size_t)nlg, sizeof lg_ratio[0], cmp_d);
    printf("random corners: %d (blend %d, of which clamped %d; straight %d; stop %d; reversal %d; "
           "blends within 1e-3 rad of the threshold %d)\n",
           NCORNER, n_blend, n_clamped, n_straight, n_stop, n_rev, n_near_rev_ok);
    printf(
        "measured dev/tol: max %.9f (turn %.6f rad), unclamped max %.9f, median %.6f, p99 %.9f\n",
        max_ratio, worst_ratio_turn, max_ratio_unclamped, nr ? ratios[nr / 2] : 0,
        nr ? ratios[(int)(0.99 * nr)] : 0);
    if (nlg)
        printf("unclamped L*g/(tol - 4 eps max|v_i|): min %.9f median %.9f max %.9f (n %d)\n",
               lg_ratio[0], lg_ratio[nlg / 2], lg_ratio[nlg - 1], nlg);
    printf("(dev - float slack)/tol max %.9f; dev/tol where the slack is below 1e-4 tol: max %.9f "
           "(n %d)\n",
           max_excess, max_ratio_clean, n_clean);
    printf("ends where rounding is below 1e-5 L: unit tangent err max %.3g, curvature*L max %.3g "
           "(%.3g for turns below 170 deg)\n",
           clean_tan, clean_curv, clean_curv170);
    printf("|dist(v,curve) - predicted dev| / dev (less slack): max %.3g; |t_nearest - 1/2| max "
           "%.3g\n",
           max_pred_err, max_vt_err);
    printf("curve-to-polyline beyond dist(v,curve), relative: max %.3g\n", max_rel_extra);
    printf(
        "ends, all blends: position err/L beyond rounding %.3g; unit tangent err and curvature*L "
        "over max(1, 1e3 x rounding/L): %.3g, %.3g\n",
        max_pos_err, max_tan_err, max_curv);
    printf("end speed / L - 1 where rounding is below 1e-4: max %.3g (turns above 3.05 rad: "
           "%.3g)\n",
           max_end_speed, max_end_speed_hp);
    EF_CHECK(n_blend > 12000);
    EF_CHECK(n_near_rev_ok > 100);
}

/* ---- fixed cases -------------------------------------------------------------------- */

static int all_zero(const ef_blend_t *b)
{
    int z = b->flags == 0 && b->seg.degree == 0 && b->seg.ndof == 0 && b->trim_in == 0 &&
            b->trim_out == 0 && b->dev == 0 && b->gain == 0 && b->turn == 0 && b->p_in.x == 0 &&
            b->p_out.x == 0 && b->seg.norm.chord == 0;
    for (int i = 0; i < 6; i++)
        z = z && b->seg.b[i].x == 0 && b->seg.b[i].y == 0 && b->seg.b[i].z == 0;
    return z;
}

static void poison(ef_blend_t *b)
{
    memset(b, 0x55, sizeof *b);
}

static void test_bad_input(void)
{
    ef_vec3_t v = ef_v3(10, 20, 0), ex = ef_v3(1, 0, 0), ey = ef_v3(0, 1, 0);
    ef_blend_t b;
    const float nan = NAN, inf = INFINITY;
    EF_CHECK_EQ(ef_blend_corner(G2, v, ex, ey, 0.01f, 1, 1, NULL), EF_ERR_ARG);
    poison(&b);
    EF_CHECK_EQ(ef_blend_corner(NULL, v, ex, ey, 0.01f, 1, 1, &b), EF_ERR_ARG);
    EF_CHECK(all_zero(&b));
    ef_table_t g1 = ef_tbl_g2_default;
    g1.kind = EF_TABLE_G1_CUBIC;
    poison(&b);
    EF_CHECK_EQ(ef_blend_corner(&g1, v, ex, ey, 0.01f, 1, 1, &b), EF_ERR_KIND);
    EF_CHECK(all_zero(&b));
    /* NaN / inf anywhere */
    float bad[2] = {nan, inf};
    for (int i = 0; i < 2; i++) {
        float x = bad[i];
        const struct {
            ef_vec3_t v, ui, uo;
            float tol, mi, mo;
        } c[] = {
            {ef_v3(x, 0, 0), ex, ey, 0.01f, 1, 1},
            {ef_v3(0, 0, x), ex, ey, 0.01f, 1, 1},
            {v, ef_v3(x, 0, 0), ey, 0.01f, 1, 1},
            {v, ex, ef_v3(0, x, 0), 0.01f, 1, 1},
            {v, ex, ey, x, 1, 1},
            {v, ex, ey, 0.01f, x, 1},
            {v, ex, ey, 0.01f, 1, x},
            {v, ex, ey, -x, 1, 1},
            {ef_v3(2e6f, 0, 0), ex, ey, 0.01f, 1, 1},
        };
        for (size_t j = 0; j < sizeof c / sizeof c[0]; j++) {
            poison(&b);
            EF_CHECK_EQ(
                ef_blend_corner(G2, c[j].v, c[j].ui, c[j].uo, c[j].tol, c[j].mi, c[j].mo, &b),
                EF_ERR_NONFINITE);
            EF_CHECK(all_zero(&b));
        }
    }
    /* tol, max <= 0 */
    const float np[3][3] = {{0, 1, 1}, {-1e-3f, 1, 1}, {0.01f, 0, 1}};
    for (int j = 0; j < 3; j++) {
        poison(&b);
        EF_CHECK_EQ(ef_blend_corner(G2, v, ex, ey, np[j][0], np[j][1], np[j][2], &b), EF_ERR_ARG);
        EF_CHECK(all_zero(&b));
        poison(&b);
        EF_CHECK_EQ(ef_blend_corner(G2, v, ex, ey, 0.01f, np[j][2], -np[j][1], &b), EF_ERR_ARG);
        EF_CHECK(all_zero(&b));
    }
    /* zero-length move (zero direction) and non-unit directions */
    const ef_vec3_t nu[] = {ef_v3(0, 0, 0), ef_v3(1.01f, 0, 0), ef_v3(0.5f, 0, 0),
                            ef_v3(1e-20f, 0, 0)};
    for (size_t j = 0; j < sizeof nu / sizeof nu[0]; j++) {
        poison(&b);
        EF_CHECK_EQ(ef_blend_corner(G2, v, nu[j], ey, 0.01f, 1, 1, &b), EF_ERR_TANGENT);
        EF_CHECK(all_zero(&b));
        poison(&b);
        EF_CHECK_EQ(ef_blend_corner(G2, v, ey, nu[j], 0.01f, 1, 1, &b), EF_ERR_TANGENT);
        EF_CHECK(all_zero(&b));
    }
    /* exact and near reversals: stop at the vertex */
    const double rev[] = {M_PI, M_PI - 1e-7, 179.5 * M_PI / 180, 179.01 * M_PI / 180};
    for (size_t j = 0; j < sizeof rev / sizeof rev[0]; j++) {
        poison(&b);
        ef_vec3_t uo = ef_v3((float)cos(rev[j]), (float)sin(rev[j]), 0);
        EF_CHECK_EQ(ef_blend_corner(G2, v, ex, uo, 0.01f, 1, 1, &b), EF_ERR_REVERSAL);
        EF_CHECK(all_zero(&b));
    }
    poison(&b);
    EF_CHECK_EQ(ef_blend_corner(G2, v, ex, ef_v3(-1, 0, 0), 0.01f, 1, 1, &b), EF_ERR_REVERSAL);
    EF_CHECK(all_zero(&b));
    /* 178.99 degrees still blends */
    ef_vec3_t uo = ef_v3((float)cos(178.99 * M_PI / 180), (float)sin(178.99 * M_PI / 180), 0);
    EF_CHECK_EQ(ef_blend_corner(G2, ef_v3(0, 0, 0), ex, uo, 0.01f, 1, 1, &b), EF_OK);
    EF_CHECK_EQ(b.flags, 0);
    EF_CHECK_EQ(b.seg.degree, 5);
}

static void test_fixed(void)
{
    /* At the origin the rounding margin q is 0, so dev = tol exactly when unclamped. */
    ef_vec3_t v = ef_v3(0, 0, 0), ex = ef_v3(1, 0, 0), ey = ef_v3(0, 1, 0);
    ef_blend_t b;
    /* 90 degrees: symmetric, dev = tol, trims equal, G2 data in seg */
    EF_CHECK_EQ(ef_blend_corner(G2, v, ex, ey, 0.05f, 10, 10, &b), EF_OK);
    EF_CHECK_EQ(b.flags, 0);
    EF_CHECK_EQ(b.seg.degree, 5);
    EF_CHECK_NEAR(b.dev, 0.05, 1e-6);
    EF_CHECK_NEAR(b.turn, M_PI / 2, 1e-6);
    EF_CHECK_NEAR(b.trim_in * b.gain, 0.05, 1e-6);
    EF_CHECK_NEAR(b.p_in.x, -b.trim_in, 1e-7);
    EF_CHECK_NEAR(b.p_out.y, b.trim_out, 1e-7);
    /* away from the origin the margin 4 eps max|v_i| comes off the tolerance */
    ef_blend_t o;
    EF_CHECK_EQ(ef_blend_corner(G2, ef_v3(10, 20, 0), ex, ey, 0.05f, 10, 10, &o), EF_OK);
    EF_CHECK_NEAR(o.dev, 0.05 - 4 * FLT_EPSILON * 20, 1e-7);
    EF_CHECK_NEAR(b.seg.norm.alpha, M_PI / 4, 1e-6);
    printf("90-degree corner: g = %.6f (trim per unit deviation %.4f)\n", b.gain, 1.0 / b.gain);
    /* linear in L: half the tolerance, half the trim */
    ef_blend_t h;
    EF_CHECK_EQ(ef_blend_corner(G2, v, ex, ey, 0.025f, 10, 10, &h), EF_OK);
    EF_CHECK_NEAR(h.trim_in, 0.5 * b.trim_in, 1e-6);
    EF_CHECK_EQ(h.gain == b.gain, 1);
    /* clamped by a short neighbour on either side */
    EF_CHECK_EQ(ef_blend_corner(G2, v, ex, ey, 0.05f, 0.01f, 10, &b), EF_OK);
    EF_CHECK_EQ(b.flags, EF_BLEND_CLAMPED);
    EF_CHECK(b.trim_in == 0.01f && b.trim_out == 0.01f && b.dev < 0.05f);
    EF_CHECK_EQ(ef_blend_corner(G2, v, ex, ey, 0.05f, 10, 0.02f, &b), EF_OK);
    EF_CHECK_EQ(b.flags, EF_BLEND_CLAMPED);
    EF_CHECK(b.trim_in == 0.02f);
    /* straight: identical directions, and a turn just below the threshold */
    EF_CHECK_EQ(ef_blend_corner(G2, v, ex, ex, 0.05f, 10, 10, &b), EF_OK);
    EF_CHECK_EQ(b.flags, EF_BLEND_STRAIGHT);
    EF_CHECK(b.seg.degree == 0 && b.trim_in == 0 && b.p_in.x == v.x && b.p_out.y == v.y);
    ef_vec3_t u = ef_v3(cosf(5e-5f), sinf(5e-5f), 0);
    EF_CHECK_EQ(ef_blend_corner(G2, v, ex, u, 0.05f, 10, 10, &b), EF_OK);
    EF_CHECK_EQ(b.flags & EF_BLEND_STRAIGHT, EF_BLEND_STRAIGHT);
    u = ef_v3(cosf(3e-4f), sinf(3e-4f), 0);
    EF_CHECK_EQ(ef_blend_corner(G2, v, ex, u, 0.05f, 10, 10, &b), EF_OK);
    EF_CHECK_EQ(b.flags, EF_BLEND_CLAMPED); /* tiny turn: the neighbours limit the trim */
    EF_CHECK_EQ(b.seg.degree, 5);
    /* too small to represent at this position: stop at the vertex */
    ef_vec3_t far = ef_v3(900, -900, 500);
    EF_CHECK_EQ(ef_blend_corner(G2, far, ex, ey, 1e-4f, 10, 10, &b), EF_OK);
    EF_CHECK_EQ(b.flags, EF_BLEND_STOP);
    EF_CHECK(b.seg.degree == 0 && b.trim_in == 0 && b.dev == 0 && b.p_in.x == far.x);
    /* a tolerance below the coordinates' float32 resolution: stop */
    EF_CHECK_EQ(ef_blend_corner(G2, ef_v3(1e5f, 0, 0), ex, ey, 1e-2f, 10, 10, &b), EF_OK);
    EF_CHECK_EQ(b.flags, EF_BLEND_STOP);
    EF_CHECK_EQ(ef_blend_corner(G2, v, ex, ey, 0.05f, 1e-7f, 10, &b), EF_OK);
    EF_CHECK_EQ(b.flags, EF_BLEND_STOP);
    /* "no limit" and a huge tolerance: trims bounded by EF_MAX_COORD, output finite */
    EF_CHECK_EQ(ef_blend_corner(G2, v, ex, u, FLT_MAX, FLT_MAX, FLT_MAX, &b), EF_OK);
    EF_CHECK(b.trim_in <= 1e6f && b.trim_in > 0 && b.seg.degree == 5);
    for (int i = 0; i < 6; i++)
        EF_CHECK(fabsf(b.seg.b[i].x) <= 1e7f && fabsf(b.seg.b[i].y) <= 1e7f && b.dev <= FLT_MAX);
    EF_CHECK_EQ(ef_blend_corner(G2, v, ex, ey, FLT_MAX, FLT_MAX, FLT_MAX, &b), EF_OK);
    EF_CHECK(b.trim_in == 1e6f && b.flags == EF_BLEND_CLAMPED && fabsf(b.seg.b[2].x) < 1e7f);
    /* slightly non-unit directions are normalized */
    EF_CHECK_EQ(
        ef_blend_corner(G2, v, ef_v3(1.0009f, 0, 0), ef_v3(0, 0.9991f, 0), 0.05f, 10, 10, &b),
        EF_OK);
    EF_CHECK_NEAR(b.dev, 0.05, 1e-6);
    /* g(turn) table for the docs */
    printf("g(turn):");
    const double degs[] = {1, 10, 30, 45, 60, 90, 120, 150, 170, 175, 178, 178.99};
    for (size_t j = 0; j < sizeof degs / sizeof degs[0]; j++) {
        double th = degs[j] * M_PI / 180;
        EF_CHECK_EQ(ef_blend_corner(G2, ef_v3(0, 0, 0), ex,
                                    ef_v3((float)cos(th), (float)sin(th), 0), 1.0f, 1e3f, 1e3f, &b),
                    EF_OK);
        printf(" %g deg %.4f;", degs[j], b.gain);
    }
    printf("\n");
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"table_symmetry", test_table_symmetry},
        {"bad_input", test_bad_input},
        {"fixed", test_fixed},
        {"random_corners", test_random_corners},
    };
    return EF_TEST_RUN(argc, argv, 1, parts);
}
