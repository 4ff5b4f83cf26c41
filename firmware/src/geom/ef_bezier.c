/* SPDX-License-Identifier: Apache-2.0 */
/* Bézier evaluation, degree elevation and the constant-speed functional (float32). */
#include "evenfeed/geom/ef_bezier.h"
#include "evenfeed/core/ef_err.h"

/* Gauss–Legendre nodes and weights mapped to [0,1] ({t, w}), from tools/gen_fw_constants.c. */
static const float ef_gl1[1][2] = {
    {5.000000000e-01f, 1.000000000e+00f},
};
static const float ef_gl3[3][2] = {
    {1.127016654e-01f, 2.777777778e-01f},
    {5.000000000e-01f, 4.444444444e-01f},
    {8.872983346e-01f, 2.777777778e-01f},
};
static const float ef_gl6[6][2] = {
    {3.376524290e-02f, 8.566224619e-02f}, {1.693953068e-01f, 1.803807865e-01f},
    {3.806904070e-01f, 2.339569673e-01f}, {6.193095930e-01f, 2.339569673e-01f},
    {8.306046932e-01f, 1.803807865e-01f}, {9.662347571e-01f, 8.566224619e-02f},
};
static const float ef_gl9[9][2] = {
    {1.591988025e-02f, 4.063719418e-02f}, {8.198444634e-02f, 9.032408035e-02f},
    {1.933142836e-01f, 1.303053482e-01f}, {3.378732883e-01f, 1.561735385e-01f},
    {5.000000000e-01f, 1.651196775e-01f}, {6.621267117e-01f, 1.561735385e-01f},
    {8.066857164e-01f, 1.303053482e-01f}, {9.180155537e-01f, 9.032408035e-02f},
    {9.840801198e-01f, 4.063719418e-02f},
};
static const float ef_gl12[12][2] = {
    {9.219682877e-03f, 2.358766819e-02f}, {4.794137181e-02f, 5.346966300e-02f},
    {1.150486629e-01f, 8.003916427e-02f}, {2.063410229e-01f, 1.015837134e-01f},
    {3.160842505e-01f, 1.167462683e-01f}, {4.373832957e-01f, 1.245735229e-01f},
    {5.626167043e-01f, 1.245735229e-01f}, {6.839157495e-01f, 1.167462683e-01f},
    {7.936589771e-01f, 1.015837134e-01f}, {8.849513371e-01f, 8.003916427e-02f},
    {9.520586282e-01f, 5.346966300e-02f}, {9.907803171e-01f, 2.358766819e-02f},
};
static const float ef_gl15[15][2] = {
    {6.003740990e-03f, 1.537662100e-02f}, {3.136330380e-02f, 3.518302374e-02f},
    {7.589670829e-02f, 5.357961023e-02f}, {1.377911343e-01f, 6.978533896e-02f},
    {2.145139137e-01f, 8.313460291e-02f}, {3.029243265e-01f, 9.308050001e-02f},
    {3.994029530e-01f, 9.921574266e-02f}, {5.000000000e-01f, 1.012891210e-01f},
    {6.005970470e-01f, 9.921574266e-02f}, {6.970756735e-01f, 9.308050001e-02f},
    {7.854860863e-01f, 8.313460291e-02f}, {8.622088657e-01f, 6.978533896e-02f},
    {9.241032917e-01f, 5.357961023e-02f}, {9.686366962e-01f, 3.518302374e-02f},
    {9.939962590e-01f, 1.537662100e-02f},
};
static const float ef_gl18[18][2] = {
    {4.217415790e-03f, 1.080800676e-02f}, {2.208802521e-02f, 2.485727445e-02f},
    {5.369876675e-02f, 3.821286513e-02f}, {9.814752051e-02f, 5.047102205e-02f},
    {1.541564785e-01f, 6.127760336e-02f}, {2.201145845e-01f, 7.032145734e-02f},
    {2.941244193e-01f, 7.734233756e-02f}, {3.740568872e-01f, 8.213824187e-02f},
    {4.576124935e-01f, 8.457119148e-02f}, {5.423875065e-01f, 8.457119148e-02f},
    {6.259431128e-01f, 8.213824187e-02f}, {7.058755807e-01f, 7.734233756e-02f},
    {7.798854155e-01f, 7.032145734e-02f}, {8.458435215e-01f, 6.127760336e-02f},
    {9.018524795e-01f, 5.047102205e-02f}, {9.463012332e-01f, 3.821286513e-02f},
    {9.779119748e-01f, 2.485727445e-02f}, {9.957825842e-01f, 1.080800676e-02f},
};

/* Quadrature rule exact for the functional's integrand (degree 6d-8) of a degree-d curve. */
static const float (*ef_gl_rule(int degree, int *n))[2]
{
    static const struct {
        int n;
        const float (*r)[2];
    } rules[EF_BEZIER_MAX_DEGREE + 1] = {
        {1, ef_gl1}, {1, ef_gl1},   {3, ef_gl3},   {6, ef_gl6},
        {9, ef_gl9}, {12, ef_gl12}, {15, ef_gl15}, {18, ef_gl18},
    };
    *n = rules[degree].n;
    return rules[degree].r;
}

/* Plain de Casteljau on a working copy; degree is at most EF_BEZIER_MAX_DEGREE. */
static ef_vec3_t bz_casteljau(ef_vec3_t *w, int degree, float t)
{
    for (int r = 1; r <= degree; r++)
        for (int i = 0; i <= degree - r; i++)
            w[i] = ef_v3_axpy(w[i], t, ef_v3_sub(w[i + 1], w[i]));
    return w[0];
}

/* Derivative k is d!/(d-k)! times the degree-(d-k) curve of k-th forward differences. */
int ef_bezier_eval(const ef_vec3_t *b, int degree, float t, int nder, ef_vec3_t *out)
{
    if (!b || !out || degree < 1 || degree > EF_BEZIER_MAX_DEGREE || nder < 0 || nder > degree)
        return EF_ERR_ARG;
    ef_vec3_t diff[EF_BEZIER_MAX_DEGREE + 1], work[EF_BEZIER_MAX_DEGREE + 1];
    for (int i = 0; i <= degree; i++)
        diff[i] = b[i];
    float factor = 1.0f;
    for (int k = 0; k <= nder; k++) {
        int d = degree - k;
        for (int i = 0; i <= d; i++)
            work[i] = diff[i];
        out[k] = ef_v3_scale(bz_casteljau(work, d, t), factor);
        for (int i = 0; i < d; i++)
            diff[i] = ef_v3_sub(diff[i + 1], diff[i]);
        factor *= (float)d;
    }
    return EF_OK;
}

/* Standard elevation formula: b'_i = i/(d+1) b_{i-1} + (1 - i/(d+1)) b_i. */
int ef_bezier_elevate(const ef_vec3_t *b, int degree, ef_vec3_t *out)
{
    if (!b || !out || b == out || degree < 1 || degree >= EF_BEZIER_MAX_DEGREE)
        return EF_ERR_ARG;
    if (out < b + degree + 1 && b < out + degree + 2)
        return EF_ERR_ARG;
    const float inv = 1.0f / (float)(degree + 1);
    out[0] = b[0];
    for (int i = 1; i <= degree; i++) {
        float a = (float)i * inv;
        out[i] = ef_v3_add(ef_v3_scale(b[i - 1], a), ef_v3_scale(b[i], 1.0f - a));
    }
    out[degree + 1] = b[degree];
    return EF_OK;
}

/* Sum of w <f',f''>^2 |f'|^2 over the exact Gauss–Legendre rule for this degree. */
int ef_bezier_functional(const ef_vec3_t *b, int degree, float *out)
{
    if (!b || !out || degree < 1 || degree > EF_BEZIER_MAX_DEGREE)
        return EF_ERR_ARG;
    if (degree == 1) { /* f'' = 0 */
        *out = 0.0f;
        return EF_OK;
    }
    int n;
    const float(*rule)[2] = ef_gl_rule(degree, &n);
    float sum = 0.0f;
    for (int i = 0; i < n; i++) {
        ef_vec3_t d[3];
        ef_bezier_eval(b, degree, rule[i][0], 2, d);
        float g = ef_v3_dot(d[1], d[2]);
        sum += rule[i][1] * g * g * ef_v3_dot(d[1], d[1]);
    }
    *out = ef_sqrtf(sum);
    return EF_OK;
}

/* Gauss–Legendre, 16 nodes on [0, 1]: offsets from 1/2 and weights of each symmetric pair's
 * members. Exact for polynomials up to degree 31; |f'| of a quintic with near-constant speed
 * is smooth, so the rule's error is far below float32 rounding for evenfeed's curves. */
static const float bz_gl16[8][2] = {
    {4.750625492e-02f, 9.472530523e-02f}, {1.408017754e-01f, 9.130170752e-02f},
    {2.290083888e-01f, 8.457825970e-02f}, {3.089381222e-01f, 7.479799441e-02f},
    {3.777022042e-01f, 6.231448563e-02f}, {4.328156012e-01f, 4.757925584e-02f},
    {4.722875115e-01f, 3.112676197e-02f}, {4.947004675e-01f, 1.357622971e-02f},
};

/* Sum over the symmetric node pairs (contract in ef_bezier.h). */
float ef_bezier_h4_length(const ef_vec3_t *h, int sym)
{
    float len = 0.0f;
    for (int i = 0; i < 8; i++) {
        float a = ef_v3_norm(ef_bezier_b4(h, 0.5f - bz_gl16[i][0]));
        float b = sym ? a : ef_v3_norm(ef_bezier_b4(h, 0.5f + bz_gl16[i][0]));
        len += bz_gl16[i][1] * (a + b);
    }
    return len;
}

/* Both halves, each by the 16-node rule scaled to [0, 1/2] (contract in ef_bezier.h). */
float ef_bezier_h4_length_halves(const ef_vec3_t *h)
{
    float len = 0.0f;
    for (int i = 0; i < 8; i++) {
        float o = 0.5f * bz_gl16[i][0];
        float a = ef_v3_norm(ef_bezier_b4(h, 0.25f - o)) + ef_v3_norm(ef_bezier_b4(h, 0.25f + o));
        float b = ef_v3_norm(ef_bezier_b4(h, 0.75f - o)) + ef_v3_norm(ef_bezier_b4(h, 0.75f + o));
        len += bz_gl16[i][1] * (a + b);
    }
    return 0.5f * len;
}
