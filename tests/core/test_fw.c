/* SPDX-License-Identifier: Apache-2.0 */
/* Unit tests of the firmware geometry: atan2, Bézier, functional, normalization, lookup,
 * segment construction and bad input. Tables here are synthetic (known functions) so the
 * folding, wrapping and clamping logic is checked independently of the optimizer. */
#include <string.h>
#include "bench/ct_cases.h"
#include "ef_test.h"
#include "ef_testbez.h"
#include "evenfeed/geom/ef_bezier.h"
#include "evenfeed/geom/ef_endpoint.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/seg/ef_seg.h"

static unsigned long long rng = 12345;

/* Double-precision reference: power-basis free evaluation by Bernstein sums. */
static double binom(int n, int k)
{
    double r = 1;
    for (int i = 1; i <= k; i++)
        r = r * (n - k + i) / i;
    return r;
}

/* k-th derivative (k <= 2) of a Bézier curve in double, by the Bernstein formula. */
static void ref_eval(const ef_vec3_t *b, int d, double t, int k, double out[3])
{
    double pts[8][3];
    double f = ef_t_bezier_diffs(b, d, k, pts);
    int m = d - k;
    for (int c = 0; c < 3; c++) {
        double s = 0;
        for (int i = 0; i <= m; i++)
            s += binom(m, i) * pow(t, i) * pow(1 - t, m - i) * pts[i][c];
        out[c] = f * s;
    }
}

/* C by composite Simpson in double with many panels: an independent value. */
static double ref_functional(const ef_vec3_t *b, int d)
{
    const int n = 4000;
    double sum = 0;
    for (int i = 0; i <= n; i++) {
        double t = (double)i / n, d1[3], d2[3];
        ref_eval(b, d, t, 1, d1);
        ref_eval(b, d, t, 2, d2);
        double g = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2];
        double h = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2];
        double w = (i == 0 || i == n) ? 1 : (i % 2 ? 4 : 2);
        sum += w * g * g * h;
    }
    return sqrt(sum / (3.0 * n));
}

static void random_curve(ef_vec3_t *b, int d)
{
    for (int i = 0; i <= d; i++)
        b[i] = ef_v3((float)ef_t_uniform(&rng, -2, 2), (float)ef_t_uniform(&rng, -2, 2),
                     (float)ef_t_uniform(&rng, -1, 1));
}

static void test_atan2(void)
{
    double maxerr = 0;
    for (int i = 0; i < 200000; i++) {
        float y = (float)ef_t_uniform(&rng, -10, 10), x = (float)ef_t_uniform(&rng, -10, 10);
        if (i % 4 == 0)
            y *= 1e-6f;
        if (i % 4 == 1)
            x *= 1e-6f;
        double e = fabs((double)ef_atan2f(y, x) - atan2((double)y, (double)x));
        if (e > M_PI)
            e = fabs(e - 2 * M_PI); /* +-pi on the negative x axis */
        if (e > maxerr)
            maxerr = e;
    }
    printf("atan2f max error %.3g rad\n", maxerr);
    EF_CHECK(maxerr < 4e-7);
    EF_CHECK_NEAR(ef_atan2f(0, 0), 0, 0);
    EF_CHECK_NEAR(ef_atan2f(1, 0), M_PI / 2, 3e-7);
    EF_CHECK_NEAR(ef_atan2f(0, -1), M_PI, 3e-7);
    EF_CHECK_NEAR(ef_atan2f(-1, 0), -M_PI / 2, 3e-7);
}

static void test_bezier(void)
{
    double maxerr = 0;
    for (int d = 1; d <= EF_BEZIER_MAX_DEGREE; d++) {
        for (int rep = 0; rep < 20; rep++) {
            ef_vec3_t b[8], out[8];
            random_curve(b, d);
            float t = (float)ef_t_uniform(&rng, 0, 1);
            int nder = d < 2 ? d : 2;
            EF_CHECK_EQ(ef_bezier_eval(b, d, t, nder, out), EF_OK);
            for (int k = 0; k <= nder; k++) {
                double r[3];
                ref_eval(b, d, t, k, r);
                double scale = 1 + fabs(r[0]) + fabs(r[1]) + fabs(r[2]);
                double e =
                    (fabs(out[k].x - r[0]) + fabs(out[k].y - r[1]) + fabs(out[k].z - r[2])) / scale;
                if (e > maxerr)
                    maxerr = e;
            }
            if (d < EF_BEZIER_MAX_DEGREE) { /* elevation keeps the curve */
                ef_vec3_t el[9], p0[1], p1[1];
                EF_CHECK_EQ(ef_bezier_elevate(b, d, el), EF_OK);
                ef_bezier_eval(b, d, t, 0, p0);
                ef_bezier_eval(el, d + 1, t, 0, p1);
                EF_CHECK_NEAR(p0[0].x, p1[0].x, 1e-5);
                EF_CHECK_NEAR(p0[0].y, p1[0].y, 1e-5);
                EF_CHECK_NEAR(p0[0].z, p1[0].z, 1e-5);
            }
        }
    }
    EF_CHECK(maxerr < 2e-6);
    ef_vec3_t b[8] = {{0}}, out[8];
    EF_CHECK_EQ(ef_bezier_eval(b, 0, 0.5f, 0, out), EF_ERR_ARG);
    EF_CHECK_EQ(ef_bezier_eval(b, 8, 0.5f, 0, out), EF_ERR_ARG);
    EF_CHECK_EQ(ef_bezier_eval(b, 3, 0.5f, 4, out), EF_ERR_ARG);
    EF_CHECK_EQ(ef_bezier_eval(NULL, 3, 0.5f, 1, out), EF_ERR_ARG);
    EF_CHECK_EQ(ef_bezier_elevate(b, 7, out), EF_ERR_ARG);
    EF_CHECK_EQ(ef_bezier_elevate(b, 3, b), EF_ERR_ARG);
}

/* The float functional against an independent double Simpson value, every degree. */
static void test_functional(void)
{
    double maxrel = 0;
    for (int d = 2; d <= EF_BEZIER_MAX_DEGREE; d++) {
        for (int rep = 0; rep < 10; rep++) {
            ef_vec3_t b[8];
            random_curve(b, d);
            float c;
            EF_CHECK_EQ(ef_bezier_functional(b, d, &c), EF_OK);
            double r = ref_functional(b, d);
            double rel = fabs(c - r) / r;
            if (rel > maxrel)
                maxrel = rel;
        }
    }
    printf("float functional vs double Simpson: max relative difference %.3g\n", maxrel);
    EF_CHECK(maxrel < 2e-5);
    /* Straight line at constant speed: C = 0. Domain.md's reference cubic: C = 1.788278. */
    ef_vec3_t line[4] = {{0, 0, 0}, {1.f / 3, 0, 0}, {2.f / 3, 0, 0}, {1, 0, 0}};
    float c;
    ef_bezier_functional(line, 3, &c);
    EF_CHECK_NEAR(c, 0, 1e-6); /* float rounding only */
    float x = 1.288176f / 3;
    ef_vec3_t arc[4] = {{0, 0, 0}, {0, x, 0}, {1, x, 0}, {1, 0, 0}};
    ef_bezier_functional(arc, 3, &c);
    EF_CHECK_NEAR(c, 1.788278, 2e-5);
    float c1;
    ef_bezier_functional(line, 1, &c1);
    EF_CHECK_NEAR(c1, 0, 0);
}

static ef_endpoint_t ep2(float px, float py, float ang, float kappa)
{
    ef_endpoint_t e;
    memset(&e, 0, sizeof e);
    e.p = ef_v3(px, py, 0);
    e.t = ef_v3(cosf(ang), sinf(ang), 0);
    e.n = ef_v3(-sinf(ang), cosf(ang), 0);
    e.kappa = kappa;
    return e;
}

/* Rotate a vector about an axis (Rodrigues), to make 3-D data from planar data. */
static ef_vec3_t rot(ef_vec3_t v, ef_vec3_t k, float th)
{
    float c = cosf(th), s = sinf(th);
    ef_vec3_t kxv = ef_v3_cross(k, v);
    float kd = ef_v3_dot(k, v) * (1 - c);
    return ef_v3(v.x * c + kxv.x * s + k.x * kd, v.y * c + kxv.y * s + k.y * kd,
                 v.z * c + kxv.z * s + k.z * kd);
}

static void test_normalize(void)
{
    for (int rep = 0; rep < 2000; rep++) {
        float a = (float)ef_t_uniform(&rng, -M_PI, M_PI),
              bt = (float)ef_t_uniform(&rng, -M_PI, M_PI);
        float k0 = (float)ef_t_uniform(&rng, -3, 3), k1 = (float)ef_t_uniform(&rng, -3, 3);
        float s = (float)exp(ef_t_uniform(&rng, -5, 5)),
              phi = (float)ef_t_uniform(&rng, -M_PI, M_PI);
        /* Offsets within 100 chords: float32 resolves the shape to about 1e-5 there. */
        float ox = s * (float)ef_t_uniform(&rng, -100, 100),
              oy = s * (float)ef_t_uniform(&rng, -100, 100);
        /* The normalized configuration rotated by phi, scaled by s, moved to (ox, oy). */
        ef_endpoint_t e0 = ep2(ox, oy, a + phi, k0 / s);
        ef_endpoint_t e1 = ep2(ox + s * cosf(phi), oy + s * sinf(phi), bt + phi, k1 / s);
        ef_norm_t nm;
        EF_CHECK_EQ(ef_normalize(&e0, &e1, 1, &nm), EF_OK);
        double da = remainder(nm.alpha - a, 2 * M_PI), db = remainder(nm.beta - bt, 2 * M_PI);
        if (!(fabs(da) < 2e-4 && fabs(db) < 2e-4 && fabs(nm.k0 - k0) < 2e-3 * (1 + fabs(k0)) &&
              fabs(nm.k1 - k1) < 2e-3 * (1 + fabs(k1)) && fabs(nm.chord / s - 1) < 1e-4)) {
            EF_CHECK(0);
            fprintf(stderr, "a %g->%g b %g->%g k0 %g->%g k1 %g->%g s %g->%g\n", a, nm.alpha, bt,
                    nm.beta, k0, nm.k0, k1, nm.k1, s, nm.chord);
        }
        EF_CHECK(ef_norm_twist(&nm, &e0, &e1) < 1e-3f);
        /* The same segment placed in 3-D: same configuration up to the mirror symmetry. */
        ef_vec3_t ax = ef_v3_scale(ef_v3(0.3f, -0.5f, 0.8f), 1.0f / sqrtf(0.98f));
        float th = (float)ef_t_uniform(&rng, 0.1, 3.0);
        ef_endpoint_t r0 = e0, r1 = e1;
        r0.p = rot(e0.p, ax, th), r0.t = rot(e0.t, ax, th), r0.n = rot(e0.n, ax, th);
        r1.p = rot(e1.p, ax, th), r1.t = rot(e1.t, ax, th), r1.n = rot(e1.n, ax, th);
        ef_norm_t n3;
        EF_CHECK_EQ(ef_normalize(&r0, &r1, 1, &n3), EF_OK);
        float m = (n3.alpha * nm.alpha + n3.beta * nm.beta) < 0 ? -1.0f : 1.0f;
        double e3 = fabs(remainder(m * n3.alpha - nm.alpha, 2 * M_PI)) +
                    fabs(remainder(m * n3.beta - nm.beta, 2 * M_PI)) + fabs(m * n3.k0 - nm.k0) +
                    fabs(m * n3.k1 - nm.k1);
        if (!(e3 < 2e-2 * (1 + fabs(k0) + fabs(k1)))) {
            EF_CHECK(0);
            fprintf(stderr, "3d: %g %g %g %g vs %g %g %g %g\n", n3.alpha, n3.beta, n3.k0, n3.k1,
                    nm.alpha, nm.beta, nm.k0, nm.k1);
        }
    }
    /* Twisted 3-D tangents: angles to the chord are the true angles, twist reported. */
    ef_endpoint_t a0 = ep2(0, 0, 0, 0), a1 = ep2(1, 0, 0, 0);
    a0.t = ef_v3(0, 1, 0);
    a1.t = ef_v3(0, 0, 1);
    ef_norm_t nm;
    EF_CHECK_EQ(ef_normalize(&a0, &a1, 0, &nm), EF_OK);
    EF_CHECK_NEAR(fabs(nm.alpha), M_PI / 2, 1e-5);
    EF_CHECK_NEAR(fabs(nm.beta), M_PI / 2, 1e-5);
    EF_CHECK_NEAR(ef_norm_twist(&nm, &a0, &a1), M_PI / 2, 1e-5);
    /* Straight data: both angles 0, for G1 and for G2 (which falls back to z for its plane). */
    ef_endpoint_t s0 = {.t = {1, 0, 0}}, s1 = {.p = {2, 0, 0}, .t = {1, 0, 0}};
    EF_CHECK_EQ(ef_normalize(&s0, &s1, 0, &nm), EF_OK);
    EF_CHECK(nm.alpha == 0 && nm.beta == 0);
    EF_CHECK_EQ(ef_normalize(&s0, &s1, 1, &nm), EF_OK);
    EF_CHECK(nm.alpha == 0 && nm.beta == 0 && nm.k0 == 0);
    /* Straight tangents with curvature (G2): the curvature vectors give the plane, and the
     * signed curvatures agree with the planar convention. */
    ef_endpoint_t c0 = {.t = {1, 0, 0}, .n = {0, 1, 0}, .kappa = 0.5f};
    ef_endpoint_t c1 = {.p = {2, 0, 0}, .t = {1, 0, 0}, .n = {0, -1, 0}, .kappa = 0.25f};
    EF_CHECK_EQ(ef_normalize(&c0, &c1, 1, &nm), EF_OK);
    EF_CHECK_NEAR(nm.k0, 1.0, 1e-6);
    EF_CHECK_NEAR(nm.k1, -0.5, 1e-6);
    /* G1 and G2 give the same angles on the same planar data. */
    for (int rep = 0; rep < 1000; rep++) {
        float a = (float)ef_t_uniform(&rng, -M_PI, M_PI),
              b = (float)ef_t_uniform(&rng, -M_PI, M_PI);
        ef_endpoint_t p0 = ep2(0, 0, a, 0), p1 = ep2(1, 0, b, 0);
        ef_norm_t n1, n2;
        ef_normalize(&p0, &p1, 0, &n1);
        ef_normalize(&p0, &p1, 1, &n2);
        EF_CHECK(n1.alpha == n2.alpha && n1.beta == n2.beta);
    }
}

static void test_bad_input(void)
{
    ef_endpoint_t g0 = ep2(0, 0, 0.3f, 0.5f), g1 = ep2(1, 0, -0.3f, 0.5f), e;
    ef_norm_t nm;
    const float bad[] = {NAN, INFINITY, -INFINITY};
    for (int i = 0; i < 3; i++) {
        float *fields[] = {&e.p.x, &e.p.y, &e.p.z, &e.t.x, &e.t.y,
                           &e.t.z, &e.n.x, &e.n.y, &e.n.z, &e.kappa};
        for (unsigned f = 0; f < sizeof fields / sizeof fields[0]; f++) {
            e = g0;
            *fields[f] = bad[i];
            EF_CHECK_EQ(ef_normalize(&e, &g1, 1, &nm), EF_ERR_NONFINITE);
            EF_CHECK_EQ(ef_normalize(&g1, &e, 1, &nm), EF_ERR_NONFINITE);
        }
    }
    e = g0;
    e.p.x = 2e6f;
    EF_CHECK_EQ(ef_normalize(&e, &g1, 0, &nm), EF_ERR_NONFINITE);
    e = g0;
    e.t = ef_v3(0, 0, 0);
    EF_CHECK_EQ(ef_normalize(&e, &g1, 0, &nm), EF_ERR_TANGENT);
    e.t = ef_v3(1.01f, 0, 0);
    EF_CHECK_EQ(ef_normalize(&e, &g1, 0, &nm), EF_ERR_TANGENT);
    e = g0;
    e.n = ef_v3(0, 0, 0);
    EF_CHECK_EQ(ef_normalize(&e, &g1, 1, &nm), EF_ERR_NORMAL);
    EF_CHECK_EQ(ef_normalize(&e, &g1, 0, &nm), EF_OK); /* G1 ignores curvature data */
    e.kappa = 0;
    EF_CHECK_EQ(ef_normalize(&e, &g1, 1, &nm), EF_OK); /* no curvature, no normal needed */
    e = g0;
    e.n = e.t;
    EF_CHECK_EQ(ef_normalize(&e, &g1, 1, &nm), EF_ERR_NORMAL);
    e = g0;
    e.kappa = 5000;
    EF_CHECK_EQ(ef_normalize(&e, &g1, 1, &nm), EF_ERR_DOMAIN);
    e = g1;
    e.p = ef_v3(0, 0, 0);
    EF_CHECK_EQ(ef_normalize(&g0, &e, 0, &nm), EF_ERR_DEGENERATE);
    e.p = ef_v3(1e-7f, 0, 0);
    EF_CHECK_EQ(ef_normalize(&g0, &e, 0, &nm), EF_ERR_DEGENERATE);
    ef_endpoint_t far0 = ep2(1e5f, 0, 0, 0), far1 = ep2(1e5f + 0.5f, 0, 0, 0);
    EF_CHECK_EQ(ef_normalize(&far0, &far1, 0, &nm), EF_ERR_DEGENERATE); /* below float resolution */
    EF_CHECK_EQ(ef_normalize(NULL, &g1, 0, &nm), EF_ERR_ARG);
}

/* Segments from DOFs interpolate the end data: positions, tangents x speed, curvature. */
static void test_seg_from_dofs(void)
{
    for (int rep = 0; rep < 500; rep++) {
        ef_endpoint_t e0 = ep2((float)ef_t_uniform(&rng, -5, 5), (float)ef_t_uniform(&rng, -5, 5),
                               (float)ef_t_uniform(&rng, -3, 3), (float)ef_t_uniform(&rng, -1, 1));
        ef_endpoint_t e1 = ep2((float)ef_t_uniform(&rng, -5, 5), (float)ef_t_uniform(&rng, -5, 5),
                               (float)ef_t_uniform(&rng, -3, 3), (float)ef_t_uniform(&rng, -1, 1));
        float dof[4] = {(float)ef_t_uniform(&rng, 0.5, 3), (float)ef_t_uniform(&rng, -2, 2),
                        (float)ef_t_uniform(&rng, 0.5, 3), (float)ef_t_uniform(&rng, -2, 2)};
        ef_seg_t s;
        if (ef_seg_from_dofs(&e0, &e1, 5, dof, &s) != EF_OK)
            continue; /* coincident random points */
        ef_vec3_t d0[3], d1[3];
        ef_bezier_eval(s.b, 5, 0, 2, d0);
        ef_bezier_eval(s.b, 5, 1, 2, d1);
        EF_CHECK_NEAR(d0[0].x, e0.p.x, 1e-5);
        EF_CHECK_NEAR(d1[0].y, e1.p.y, 1e-5);
        EF_CHECK_NEAR(ef_v3_dot(d0[1], e0.t), dof[0], 1e-4);
        EF_CHECK_NEAR(ef_v3_dot(d1[1], e1.t), dof[2], 1e-4);
        EF_CHECK_NEAR(ef_v3_dot(d0[2], e0.t), dof[1], 1e-3);
        EF_CHECK_NEAR(ef_v3_dot(d1[2], e1.t), dof[3], 1e-3);
        /* signed curvature (f' x f'')_z / |f'|^3 equals kappa */
        float k0 = ef_v3_cross(d0[1], d0[2]).z / powf(ef_v3_norm(d0[1]), 3);
        float k1 = ef_v3_cross(d1[1], d1[2]).z / powf(ef_v3_norm(d1[1]), 3);
        EF_CHECK_NEAR(k0, e0.kappa, 1e-3 * (1 + fabs(e0.kappa)));
        EF_CHECK_NEAR(k1, e1.kappa, 1e-3 * (1 + fabs(e1.kappa)));
        float d3[2] = {dof[0], dof[2]};
        EF_CHECK_EQ(ef_seg_from_dofs(&e0, &e1, 3, d3, &s), EF_OK);
        ef_bezier_eval(s.b, 3, 0, 1, d0);
        EF_CHECK_NEAR(ef_v3_dot(d0[1], e0.t), dof[0], 1e-4);
    }
    ef_endpoint_t e0 = ep2(0, 0, 0, 0), e1 = ep2(1, 0, 0, 0);
    ef_seg_t s;
    float neg[2] = {-1, 1}, nan2[2] = {NAN, 1};
    EF_CHECK_EQ(ef_seg_from_dofs(&e0, &e1, 3, neg, &s), EF_ERR_ARG);
    EF_CHECK_EQ(s.degree, 0);
    EF_CHECK_EQ(ef_seg_from_dofs(&e0, &e1, 3, nan2, &s), EF_ERR_NONFINITE);
    EF_CHECK_EQ(ef_seg_from_dofs(&e0, &e1, 4, neg, &s), EF_ERR_ARG);
}

/* Synthetic DOF functions with the symmetries of the true optimum (see ef_table.h). */
static double g1f(int k, double a, double b)
{
    return k == 0 ? 2 + cos(a) + 0.5 * cos(b) + 0.2 * sin(a) * sin(b)
                  : 2 + cos(b) + 0.5 * cos(a) + 0.2 * sin(a) * sin(b);
}
static double g2f(int k, const double *c)
{
    double a = c[0], b = c[1], k0 = c[2], k1 = c[3];
    switch (k) {
    case 0:
        return 2 + cos(a) + 0.1 * k0 * sin(b) + 0.05 * k1 * k0;
    case 1:
        return a * b + 0.3 * k0 * a - 0.2 * sin(k1) * sin(a);
    case 2:
        return 2 + cos(b) + 0.1 * k1 * sin(a);
    default:
        return 0.5 * a * b - 0.2 * b * k1;
    }
}

static float g1_full[97 * 97 * 2], g1_fold[49 * 97 * 2], g2_full[9 * 9 * 9 * 9 * 4],
    g2_half[5 * 9 * 9 * 9 * 4];

/* A view over values computed by fill(); axes as given. */
static ef_table_t make_table(int kind, int sym, int naxes, const float *lo, const float *hi,
                             const uint32_t *n, uint32_t periodic, float *data)
{
    ef_table_t t;
    memset(&t, 0, sizeof t);
    t.kind = (uint16_t)kind;
    t.symmetry = (uint16_t)sym;
    t.naxes = t.ndof = (uint8_t)naxes;
    t.x1_min = 0.1f;
    t.x1_max = 10;
    t.x2_max = 100;
    uint32_t stride = 1;
    for (int a = 0; a < naxes; a++) {
        t.axis[a].lo = lo[a];
        t.axis[a].hi = hi[a];
        t.axis[a].nodes = n[a];
        t.axis[a].inv_step = (float)(n[a] - 1) / (hi[a] - lo[a]);
        t.axis[a].stride = stride;
        t.axis[a].flags = periodic;
        stride *= n[a];
    }
    t.nodes = stride;
    for (uint32_t node = 0; node < stride; node++) {
        double c[4];
        uint32_t r = node;
        for (int a = 0; a < naxes; a++) {
            c[a] = lo[a] + (double)(r % n[a]) * ((double)hi[a] - lo[a]) / (n[a] - 1);
            r /= n[a];
        }
        if (kind == EF_TABLE_G1_CUBIC) {
            double al = c[0], be = c[1];
            if (sym == EF_SYM_G1_FOLD)
                al = c[0] + c[1], be = c[0] - c[1];
            data[2 * node] = (float)g1f(0, al, be);
            data[2 * node + 1] = (float)g1f(1, al, be);
        } else {
            for (int k = 0; k < 4; k++)
                data[4 * node + k] = (float)g2f(k, c);
        }
    }
    t.data = data;
    return t;
}

static void test_lookup(void)
{
    float plo[2] = {(float)-M_PI, (float)-M_PI}, phi[2] = {(float)M_PI, (float)M_PI};
    uint32_t pn[2] = {97, 97};
    ef_table_t full =
        make_table(EF_TABLE_G1_CUBIC, EF_SYM_NONE, 2, plo, phi, pn, EF_AXIS_PERIODIC, g1_full);
    float flo[2] = {0, 0}, fhi[2] = {(float)(M_PI / 2), (float)M_PI};
    uint32_t fn[2] = {49, 97};
    ef_table_t fold = make_table(EF_TABLE_G1_CUBIC, EF_SYM_G1_FOLD, 2, flo, fhi, fn, 0, g1_fold);
    double e_full = 0, e_fold = 0;
    for (int rep = 0; rep < 20000; rep++) {
        double a = ef_t_uniform(&rng, -4 * M_PI, 4 * M_PI),
               b = ef_t_uniform(&rng, -4 * M_PI, 4 * M_PI);
        float d[2], f[2];
        uint32_t fl = 99, fl2 = 99;
        EF_CHECK_EQ(ef_table_lookup_g1(&full, (float)a, (float)b, d, &fl), EF_OK);
        EF_CHECK_EQ(ef_table_lookup_g1(&fold, (float)a, (float)b, f, &fl2), EF_OK);
        EF_CHECK_EQ(fl, 0);
        EF_CHECK_EQ(fl2, 0);
        for (int k = 0; k < 2; k++) {
            double ref = g1f(k, a, b);
            e_full = fmax(e_full, fabs(d[k] - ref));
            e_fold = fmax(e_fold, fabs(f[k] - ref));
        }
    }
    printf("G1 synthetic lookup max error: full %.3g, fold %.3g\n", e_full, e_fold);
    EF_CHECK(e_full < 2e-3);
    EF_CHECK(e_fold < 2e-3);
    /* At nodes the lookup returns the stored value exactly (up to float). */
    float d[2];
    ef_table_lookup_g1(&full, (float)(-M_PI + 2 * M_PI * 10 / 96),
                       (float)(-M_PI + 2 * M_PI * 30 / 96), d, NULL);
    EF_CHECK_NEAR(d[0], g1_full[2 * (10 + 97 * 30)], 2e-5);

    /* A non-periodic G1 table clamps and flags. */
    float slo[2] = {-1, -1}, shi[2] = {1, 1};
    uint32_t sn[2] = {97, 49};
    ef_table_t part = make_table(EF_TABLE_G1_CUBIC, EF_SYM_NONE, 2, slo, shi, sn, 0, g1_full);
    uint32_t fl;
    EF_CHECK_EQ(ef_table_lookup_g1(&part, 2, 0.5f, d, &fl), EF_OK);
    EF_CHECK_EQ(fl, EF_LOOKUP_CLAMP_ALPHA);
    EF_CHECK_NEAR(d[0], g1f(0, 1, 0.5), 2e-3);
    EF_CHECK_EQ(ef_table_lookup_g1(&part, 0, -3, d, &fl), EF_OK);
    EF_CHECK_EQ(fl, EF_LOOKUP_CLAMP_BETA);

    /* G2: full vs mirror half, 4-linear. */
    float glo[4] = {(float)(-M_PI / 2), (float)(-M_PI / 2), -2, -2};
    float ghi[4] = {(float)(M_PI / 2), (float)(M_PI / 2), 2, 2};
    uint32_t gn[4] = {9, 9, 9, 9};
    ef_table_t g2 = make_table(EF_TABLE_G2_QUINTIC, EF_SYM_NONE, 4, glo, ghi, gn, 0, g2_full);
    float hlo[4] = {0, (float)(-M_PI / 2), -2, -2};
    uint32_t hn[4] = {5, 9, 9, 9};
    ef_table_t g2h = make_table(EF_TABLE_G2_QUINTIC, EF_SYM_G2_MIRROR, 4, hlo, ghi, hn, 0, g2_half);
    double emax = 0;
    for (int rep = 0; rep < 5000; rep++) {
        float c[4] = {(float)ef_t_uniform(&rng, -M_PI / 2, M_PI / 2),
                      (float)ef_t_uniform(&rng, -M_PI / 2, M_PI / 2),
                      (float)ef_t_uniform(&rng, -2, 2), (float)ef_t_uniform(&rng, -2, 2)};
        float a[4], b[4];
        uint32_t f1 = 9, f2 = 9;
        EF_CHECK_EQ(ef_table_lookup_g2(&g2, c, a, &f1), EF_OK);
        EF_CHECK_EQ(ef_table_lookup_g2(&g2h, c, b, &f2), EF_OK);
        EF_CHECK_EQ(f1 | f2, 0);
        for (int k = 0; k < 4; k++)
            emax = fmax(emax, fabs(a[k] - b[k]));
    }
    printf("G2 synthetic lookup: full vs mirror max difference %.3g\n", emax);
    EF_CHECK(emax < 1e-5);
    /* The symmetric corner's lookup equals the general one at (phi, -phi, 0, 0): on tables
     * with curvature 0 on a node (its bilinear path) and without (8 curvature nodes: the
     * general path), mirrored or not, inside and beyond the range (clamp flags too). */
    uint32_t gn8[4] = {9, 9, 8, 8};
    ef_table_t g2e = make_table(EF_TABLE_G2_QUINTIC, EF_SYM_NONE, 4, glo, ghi, gn8, 0, g2_full);
    const ef_table_t *ctab[3] = {&g2, &g2h, &g2e};
    long corner_checks = 0;
    for (int t = 0; t < 3; t++) {
        for (int i = -60; i <= 60; i++) {
            float ph = (float)(i * 0.03 + 0.001 * t), cc[4] = {ph, -ph, 0.0f, 0.0f};
            float a[4], b[4];
            uint32_t f1 = 99, f2 = 98;
            EF_CHECK_EQ(ef_table_lookup_g2_corner(ctab[t], ph, a, &f1), EF_OK);
            EF_CHECK_EQ(ef_table_lookup_g2(ctab[t], cc, b, &f2), EF_OK);
            EF_CHECK_EQ(f1, f2);
            for (int k = 0; k < 4; k++)
                EF_CHECK(a[k] == b[k]);
            corner_checks++;
        }
    }
    EF_CHECK_EQ(corner_checks, 363);
    float dc[4];
    EF_CHECK_EQ(ef_table_lookup_g2_corner(NULL, 0.1f, dc, NULL), EF_ERR_ARG);
    EF_CHECK_EQ(ef_table_lookup_g2_corner(&g2, 0.1f, NULL, NULL), EF_ERR_ARG);
    EF_CHECK_EQ(ef_table_lookup_g2_corner(&full, 0.1f, dc, NULL), EF_ERR_KIND);
    /* A 4-linear interpolant is exact for functions linear in each coordinate. */
    float c[4] = {0.3f, -0.7f, 3.5f, -2.5f}, o[4];
    uint32_t f;
    EF_CHECK_EQ(ef_table_lookup_g2(&g2, c, o, &f), EF_OK);
    EF_CHECK_EQ(f, EF_LOOKUP_CLAMP_K0 | EF_LOOKUP_CLAMP_K1);
    EF_CHECK_EQ(ef_table_lookup_g1(&g2, 0, 0, d, NULL), EF_ERR_KIND);
    EF_CHECK_EQ(ef_table_lookup_g2(&full, c, o, NULL), EF_ERR_KIND);

    /* Segment through a table: failure zeroes the output, kind mismatch refused. */
    ef_endpoint_t e0 = ep2(0, 0, 0.2f, 0), e1 = ep2(2, 1, 0.4f, 0);
    ef_seg_t s;
    EF_CHECK_EQ(ef_seg_g1_cubic(&full, &e0, &e1, &s), EF_OK);
    EF_CHECK_EQ(s.degree, 3);
    EF_CHECK_EQ(ef_seg_g2_quintic(&full, &e0, &e1, &s), EF_ERR_KIND);
    EF_CHECK_EQ(s.degree, 0);
    e1.p = e0.p;
    EF_CHECK_EQ(ef_seg_g1_cubic(&full, &e0, &e1, &s), EF_ERR_DEGENERATE);
    EF_CHECK_EQ(s.degree, 0);
    EF_CHECK(s.b[1].x == 0 && s.b[1].y == 0);
    e1 = ep2(2, 1, 0.4f, 1);
    EF_CHECK_EQ(ef_seg_g2_quintic(&g2, &e0, &e1, &s), EF_OK);
    EF_CHECK_EQ(s.degree, 5);
}

/* A refused planar segment is all zero. */
static int seg_xy_zero(const ef_seg_xy_t *a)
{
    ef_seg_xy_t z;
    memset(&z, 0, sizeof z);
    return memcmp(a, &z, sizeof z) == 0;
}

/* ef_seg_g1_cubic_xy against ef_seg_g1_cubic on data in planes z = const (chords 1e-3..1e3,
 * up to 1e4 from the origin, tangents at random, along and back along the chord, slightly
 * off unit), with a fold table and with a partial one that clamps: the 3-D path's angles to
 * 1e-6 rad, the DOFs of the table at those angles, the control points those DOFs make, the
 * same flags (tests/bench/ct_cases.h: ct_xy_diff()); invalid data gets the same error.
 * ef_seg_xy_expand() gives the general form. */
static void test_seg_xy(void)
{
    float flo[2] = {0, 0}, fhi[2] = {(float)(M_PI / 2), (float)M_PI};
    uint32_t fn[2] = {49, 97};
    ef_table_t fold = make_table(EF_TABLE_G1_CUBIC, EF_SYM_G1_FOLD, 2, flo, fhi, fn, 0, g1_fold);
    float slo[2] = {-1, -1}, shi[2] = {1, 1};
    uint32_t sn[2] = {97, 49};
    ef_table_t part = make_table(EF_TABLE_G1_CUBIC, EF_SYM_NONE, 2, slo, shi, sn, 0, g1_full);
    unsigned long long rs = 4242;
    int same = 0, valid = 0, clamped = 0, n = 8000;
    double w[3] = {0, 0, 0}, wx = 0;
    for (int i = 0; i < n; i++) {
        const ef_table_t *tb = (i & 1) ? &part : &fold;
        int cls = (i >> 1) % 3; /* 0 random, 1 along/back along the chord, 2 z = 0 */
        double s = exp(ef_t_uniform(&rs, log(1e-3), log(1e3)));
        double mag = fmin(1e4, 2e4 * s) * ef_t_uniform(&rs, 0, 1);
        double al = ef_t_uniform(&rs, -M_PI, M_PI), be = ef_t_uniform(&rs, -M_PI, M_PI);
        if (cls == 1) {
            al = (ef_t_rng(&rs) & 1u) ? 0 : M_PI;
            be = (ef_t_rng(&rs) & 1u) ? ef_t_uniform(&rs, -1e-3, 1e-3) : M_PI;
        }
        double ph = ef_t_uniform(&rs, -M_PI, M_PI), cp = cos(ph), sp = sin(ph);
        double len0 = 1 + ef_t_uniform(&rs, -9e-4, 9e-4), len1 = 1 + ef_t_uniform(&rs, -9e-4, 9e-4);
        double ox = ef_t_uniform(&rs, -mag, mag), oy = ef_t_uniform(&rs, -mag, mag);
        float z = cls == 2 ? 0.0f : (float)ef_t_uniform(&rs, -mag, mag);
        ef_endpoint_t e0, e1;
        memset(&e0, 0, sizeof e0);
        memset(&e1, 0, sizeof e1);
        e0.p = ef_v3((float)ox, (float)oy, z);
        e1.p = ef_v3((float)(ox + s * cp), (float)(oy + s * sp), z);
        e0.t = ef_v3((float)(len0 * cos(al + ph)), (float)(len0 * sin(al + ph)), 0.0f);
        e1.t = ef_v3((float)(len1 * cos(be + ph)), (float)(len1 * sin(be + ph)), 0.0f);
        ef_seg_xy_t a;
        ef_seg_t b, ax;
        int ra = ef_seg_g1_cubic_xy(tb, &e0, &e1, &a), rb = ef_seg_g1_cubic(tb, &e0, &e1, &b);
        EF_CHECK_EQ(ra, rb);
        if (ra != EF_OK)
            continue;
        valid++;
        clamped += (a.flags & EF_SEG_CLAMPED) != 0;
        if (ct_xy_diff(tb, &e0, &e1, &a, &b, w))
            same++;
        else
            printf("seg_xy: case %d: flags, clamp bits or plane differ from the 3-D path\n", i);
        /* the general form: the same points, angles and DOFs; the chord as the 3-D path's;
         * the tangents along the handles, to the precision of the control points */
        EF_CHECK_EQ(ef_seg_xy_expand(&a, &ax), EF_OK);
        EF_CHECK(ax.degree == 3 && ax.ndof == 2 && ax.b[2].x == a.x[2] && ax.b[1].z == z &&
                 ax.norm.alpha == a.alpha && ax.dof[1] == a.dof[1] && ax.flags == a.flags);
        EF_CHECK(ax.norm.chord == b.norm.chord);
        double hmin =
            fmin(ef_v3_norm(ef_v3_sub(ax.b[1], ax.b[0])), ef_v3_norm(ef_v3_sub(ax.b[3], ax.b[2])));
        double tol_t = 4 * 1.1920929e-7 * (mag + s) / hmin + 1e-6;
        wx = fmax(wx, fmax(ef_v3_norm(ef_v3_sub(ax.norm.t0, b.norm.t0)),
                           ef_v3_norm(ef_v3_sub(ax.norm.t1, b.norm.t1))) /
                          tol_t);
    }
    printf("seg_xy: %d of %d valid, %d clamped, %d with the 3-D path's flags; largest: angle "
           "off the 3-D path's %.3g rad, DOF off the table at its angles %.3g, control point "
           "off its DOFs %.3g eps; expanded tangents %.3g of their bound\n",
           valid, n, clamped, same, w[0], w[1], w[2], wx);
    EF_CHECK(valid > n - n / 50);
    EF_CHECK(clamped > 0);
    EF_CHECK_EQ(same, valid);
    EF_CHECK(w[0] <= 1e-6);
    EF_CHECK(w[1] <= 1e-6);
    EF_CHECK(w[2] <= 4.0);
    EF_CHECK(wx <= 1.0);

    /* The angles 0, pi/2 and pi come out exact (the tangent along, across, against the
     * chord), as the 3-D path's do. */
    {
        const float ux[3] = {1, 0, -1}, uy[3] = {0, 1, 0},
                    want[3] = {0.0f, (float)(M_PI / 2), (float)M_PI};
        for (int k = 0; k < 3; k++) {
            ef_endpoint_t p0, p1;
            memset(&p0, 0, sizeof p0);
            memset(&p1, 0, sizeof p1);
            p0.p = ef_v3(1, 2, 3);
            p1.p = ef_v3(4, 2, 3);
            p0.t = ef_v3(ux[k], uy[k], 0);
            p1.t = ef_v3(1, 0, 0);
            ef_seg_xy_t a;
            ef_seg_t b;
            EF_CHECK_EQ(ef_seg_g1_cubic_xy(&fold, &p0, &p1, &a), EF_OK);
            EF_CHECK_EQ(ef_seg_g1_cubic(&fold, &p0, &p1, &b), EF_OK);
            EF_CHECK(fabsf(a.alpha) == want[k] && fabsf(b.norm.alpha) == want[k]);
            EF_CHECK(a.beta == 0.0f);
        }
    }

    /* Invalid data: the 3-D path's error, whichever check fails; z of e1 and t.z not read. */
    ef_endpoint_t e0 = ep2(0, 0, 0.3f, 0), e1 = ep2(1, 0, -0.2f, 0), x;
    ef_seg_xy_t sg;
    ef_seg_t ref;
    const float bad[] = {NAN, INFINITY, -INFINITY, 2e6f};
    for (int k = 0; k < 4; k++)
        for (int f = 0; f < 8; f++) {
            x = f < 4 ? e0 : e1;
            float *v = f % 4 == 0 ? &x.p.x : f % 4 == 1 ? &x.p.y : f % 4 == 2 ? &x.t.x : &x.t.y;
            *v = bad[k];
            const ef_endpoint_t *a = f < 4 ? &x : &e0, *b = f < 4 ? &e1 : &x;
            int rc = ef_seg_g1_cubic_xy(&fold, a, b, &sg);
            EF_CHECK_EQ(rc, ef_seg_g1_cubic(&fold, a, b, &ref));
            EF_CHECK(rc == EF_ERR_NONFINITE || rc == EF_ERR_TANGENT);
            EF_CHECK(seg_xy_zero(&sg));
        }
    for (int k = 0; k < 4; k++) {
        x = e0;
        x.p.z = bad[k];
        EF_CHECK_EQ(ef_seg_g1_cubic_xy(&fold, &x, &e1, &sg), EF_ERR_NONFINITE);
        x = e1;
        x.p.z = bad[k];
        x.t.z = bad[k];
        EF_CHECK_EQ(ef_seg_g1_cubic_xy(&fold, &e0, &x, &sg), EF_OK);
        EF_CHECK(sg.z == 0.0f);
    }
    x = e0;
    x.t = ef_v3(1.01f, 0, 0);
    EF_CHECK_EQ(ef_seg_g1_cubic_xy(&fold, &x, &e1, &sg), EF_ERR_TANGENT);
    x.t = ef_v3(0, 0, 1); /* unit, but not in the plane: (0, 0) read */
    EF_CHECK_EQ(ef_seg_g1_cubic_xy(&fold, &x, &e1, &sg), EF_ERR_TANGENT);
    x = e1;
    x.t = ef_v3(NAN, 0, 0);
    x.p = ef_v3(1e-7f, 0, 0); /* the non-finite tangent comes first, as in ef_normalize() */
    EF_CHECK_EQ(ef_seg_g1_cubic_xy(&fold, &e0, &x, &sg), EF_ERR_NONFINITE);
    x.t = e1.t;
    EF_CHECK_EQ(ef_seg_g1_cubic_xy(&fold, &e0, &x, &sg), EF_ERR_DEGENERATE);
    EF_CHECK(seg_xy_zero(&sg));
    x.t = ef_v3(-1, 0, 0); /* reversal: back along the chord is a valid configuration */
    x.p = ef_v3(1, 0, 0);
    EF_CHECK_EQ(ef_seg_g1_cubic_xy(&fold, &e0, &x, &sg), ef_seg_g1_cubic(&fold, &e0, &x, &ref));
    x.p = ef_v3(5e5f, 0, 0);
    e0.p = ef_v3(5e5f - 1e-3f, 0, 0);
    EF_CHECK_EQ(ef_seg_g1_cubic_xy(&fold, &e0, &x, &sg), ef_seg_g1_cubic(&fold, &e0, &x, &ref));
    EF_CHECK_EQ(ef_seg_g1_cubic_xy(&fold, NULL, &x, &sg), EF_ERR_ARG);
    ef_table_t kind = fold;
    kind.kind = EF_TABLE_G2_QUINTIC;
    EF_CHECK_EQ(ef_seg_g1_cubic_xy(&kind, &e0, &x, &sg), EF_ERR_KIND);
    EF_CHECK(seg_xy_zero(&sg));
    EF_CHECK_EQ(ef_seg_xy_expand(NULL, &ref), EF_ERR_ARG);
    EF_CHECK_EQ(ref.degree, 0);
    EF_CHECK_EQ(ef_seg_xy_expand(&sg, NULL), EF_ERR_ARG);
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"atan2", test_atan2},           {"bezier", test_bezier},
        {"functional", test_functional}, {"normalize", test_normalize},
        {"bad_input", test_bad_input},   {"seg_from_dofs", test_seg_from_dofs},
        {"lookup", test_lookup},         {"seg_xy", test_seg_xy},
    };
    return EF_TEST_RUN(argc, argv, 1, parts);
}
