/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Bounded, deterministic, multi-start projected-Newton minimization of C^2 over all DOFs of
 * a segment jointly: the CPU reference optimum. docs/optimizer.md describes the algorithm
 * for the compute-shader port and why each piece is there; keep the two in step.
 *
 *   1. Normalize: translate by p0, scale by 1/s (s the chord), curvature times s. DOFs are
 *      then per unit chord and every tolerance means the same at every scale. No rotation:
 *      C is rotation invariant, so the segment keeps its orientation.
 *   2. Box: x1 in [x1_min, x1_max], |x2| <= x2_max, quartic inner point within x2_max of
 *      the chord midpoint per coordinate.
 *   3. Starts, in this order: the warm start (if any); the fixed starts
 *        cubic    x1_0, x1_1 in {0.3, 1, 2}                                    9
 *        quintic  x1_0, x1_1 in {0.3, 1, 2}, x2_0, x2_1 in {-2, 0, 2}         81
 *        quartic  x1_0, x1_1 in {0.3, 1, 2} x inner point at the midpoint,
 *                 +/- 0.5 across the chord, 0.25 out of the tangents' plane   36
 *      plus 7 with an x1 on its lower bound: (b, 0.3), (b, 1), (b, 2), mirrored, (b, b),
 *      other DOFs neutral (x2 = 0, inner point at the midpoint)
 *      then up to EF_OPT_KEEP = 8 points of a screening grid (cubic 8 x 8, quintic
 *      (5 x 7)^2, quartic 5 x 5 x 3 x 5 x 3 nodes): the lowest grid points that no axis
 *      neighbour undercuts. All are clamped into the box.
 *   4. From each start at most max_iter iterations of projected saddle-free Newton:
 *        stop when pg = |x - P(x - g)| <= tol * max(1, C^2);
 *        eps-active set: x_i within eps = min(pg, 1e-3) of a bound that g pushes against;
 *            those move by -g_i (and stay on the bound after projection);
 *        free set: exact Hessian, Jacobi eigen-decomposition, step -sum (v.g / max(|lambda|,
 *            1e-8 (1 + max|lambda|))) v, and at least 0.1 along any eigenvector with
 *            lambda < -1e-6 (1 + max|lambda|) (to leave saddles, e.g. planes of symmetry);
 *        projected backtracking: x+ = P(x + a d), a = 1, 1/2, ... (at most 40), accepted
 *            when C^2(x+) <= C^2(x) + 1e-4 m with m = g.dx + dx'H dx / 2 < 0 the quadratic
 *            model's change. If already at a = 1 |m| <= 1e-10 C^2 (the rounding floor of
 *            C^2), the full step is taken while C^2(x+) <= C^2(x) (1 + 1e-10) and it
 *            halves pg; when it does not, the start ends converged. Otherwise no accepted
 *            step ends the start unconverged.
 *   5. The lowest C^2 wins; within 1e-9 relative (rounding of C^2 near C = 0) a start that
 *      met the stopping test is preferred, then the lower value, then the earlier start.
 * Everything is bounded by fixed caps; no recursion, no heap, no static mutable state.
 */
#include <float.h>
#include <math.h>
#include <stddef.h>

#include "evenfeed/host/tables/ef_ref.h"

#define EF_OPT_LS_MAX        40    /* backtracking halvings per iteration */
#define EF_OPT_JACOBI_SWEEPS 50    /* Jacobi sweeps per eigen-decomposition */
#define EF_OPT_NC_STEP       0.1   /* least step (per unit chord) along negative curvature */
#define EF_OPT_NOISE         1e-10 /* relative change of C^2 below which values are rounding noise */
#define EF_OPT_ITER_CAP      100000 /* largest accepted max_iter */
#define EF_OPT_AXIS_MAX      8      /* nodes per screening-grid axis */
#define EF_OPT_GRID_MAX      1225   /* screening-grid points (quintic: 35 x 35) */
#define EF_OPT_KEEP          8      /* Newton starts taken from the grid */
#define EF_OPT_MAX_STARTS    (1 + 81 + 7 + EF_OPT_KEEP) /* warm + fixed + bound + grid */

/* One normalized problem: the segment with p0 at the origin and unit chord, and its box. */
typedef struct {
    ef_ref_kind_t kind;
    ef_dend_t e0, e1;
    int n;
    double lo[EF_REF_MAX_DOF], hi[EF_REF_MAX_DOF];
} ef_prob_t;

/* Defaults documented in ef_ref.h. */
void ef_ref_opts_default(ef_ref_opts_t *o)
{
    if (!o)
        return;
    o->x1_min = 0.1;
    o->x1_max = 10.0;
    o->x2_max = 100.0;
    o->max_iter = 200;
    o->tol = 1e-12;
    o->warm = NULL;
}

/* Clamp into [lo, hi]. */
static double opt_clamp(double v, double lo, double hi)
{
    return v < lo ? lo : (v > hi ? hi : v);
}

/* Objective with gradient on the normalized problem. */
static double opt_f(const ef_prob_t *p, const double *x, double *g)
{
    return ef_ref_objective(p->kind, &p->e0, &p->e1, x, g);
}

/* Norm of the projected-gradient step x - P(x - g): zero exactly at a KKT point. */
static double opt_pg(const ef_prob_t *p, const double *x, const double *g)
{
    double s = 0.0;
    for (int i = 0; i < p->n; i++) {
        const double r = x[i] - opt_clamp(x[i] - g[i], p->lo[i], p->hi[i]);
        s += r * r;
    }
    return sqrt(s);
}

/* Exact Hessian (and gradient) at x, unpacked into a square array. */
static void opt_hess(const ef_prob_t *p, const double *x, double *g,
                     double h[EF_REF_MAX_DOF][EF_REF_MAX_DOF])
{
    double flat[EF_REF_MAX_DOF * EF_REF_MAX_DOF];
    ef_ref_objective_hess(p->kind, &p->e0, &p->e1, x, g, flat);
    for (int i = 0; i < p->n; i++)
        for (int j = 0; j < p->n; j++)
            h[i][j] = flat[i * p->n + j];
}

/*
 * Eigen-decomposition of the symmetric m x m block of a by cyclic Jacobi rotations (at most
 * EF_OPT_JACOBI_SWEEPS sweeps): eigenvalues end on a's diagonal, eigenvectors in v's
 * columns. Jacobi is simple, branch-light and exact enough for m <= 5.
 */
static void opt_eigen(double a[EF_REF_MAX_DOF][EF_REF_MAX_DOF], int m,
                      double v[EF_REF_MAX_DOF][EF_REF_MAX_DOF])
{
    for (int i = 0; i < m; i++)
        for (int j = 0; j < m; j++)
            v[i][j] = i == j ? 1.0 : 0.0;
    for (int sweep = 0; sweep < EF_OPT_JACOBI_SWEEPS; sweep++) {
        double off = 0.0, diag = 0.0;
        for (int i = 0; i < m; i++) {
            diag += a[i][i] * a[i][i];
            for (int j = i + 1; j < m; j++)
                off += a[i][j] * a[i][j];
        }
        if (!(off > 1e-32 * diag))
            break;
        for (int p = 0; p < m; p++)
            for (int q = p + 1; q < m; q++) {
                if (a[p][q] == 0.0)
                    continue;
                /* Rotation angle that zeroes a[p][q] (the smaller root, for stability). */
                const double th = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                const double t = (th >= 0.0 ? 1.0 : -1.0) / (fabs(th) + sqrt(th * th + 1.0));
                const double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
                for (int k = 0; k < m; k++) {
                    const double akp = a[k][p], akq = a[k][q];
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for (int k = 0; k < m; k++) {
                    const double apk = a[p][k], aqk = a[q][k];
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                for (int k = 0; k < m; k++) {
                    const double vkp = v[k][p], vkq = v[k][q];
                    v[k][p] = c * vkp - s * vkq;
                    v[k][q] = s * vkp + c * vkq;
                }
            }
    }
}

/*
 * Projected saddle-free Newton from x (clamped into the box first); x becomes the end point.
 * Returns C^2 there; *iters counts iterations; *conv is 1 when the start ended stationary:
 * the projected gradient met tol, or the Newton model predicted a change below the rounding
 * of C^2 and the gradient could not be halved any more (the numerical floor).
 */
static double opt_local(const ef_prob_t *p, double *x, int max_iter, double tol, int *iters,
                        int *conv)
{
    const int n = p->n;
    double g[EF_REF_MAX_DOF], f;
    int it;

    *conv = 0;
    for (int i = 0; i < n; i++)
        x[i] = opt_clamp(x[i], p->lo[i], p->hi[i]);
    f = opt_f(p, x, g);
    double pg = isfinite(f) ? opt_pg(p, x, g) : INFINITY;
    for (it = 0; it < max_iter && isfinite(f); it++) {
        if (pg <= tol * fmax(1.0, f)) {
            *conv = 1;
            break;
        }
        const double eps = fmin(pg, 1e-3);
        int act[EF_REF_MAX_DOF], fi[EF_REF_MAX_DOF], m = 0;
        for (int i = 0; i < n; i++) {
            act[i] =
                (x[i] <= p->lo[i] + eps && g[i] > 0.0) || (x[i] >= p->hi[i] - eps && g[i] < 0.0);
            if (!act[i])
                fi[m++] = i;
        }

        double h[EF_REF_MAX_DOF][EF_REF_MAX_DOF], hf[EF_REF_MAX_DOF][EF_REF_MAX_DOF];
        double ev[EF_REF_MAX_DOF][EF_REF_MAX_DOF], d[EF_REF_MAX_DOF], lmax = 0.0;
        opt_hess(p, x, g, h);
        for (int a = 0; a < m; a++)
            for (int b = 0; b < m; b++)
                hf[a][b] = h[fi[a]][fi[b]];
        opt_eigen(hf, m, ev);
        for (int a = 0; a < m; a++)
            lmax = fmax(lmax, fabs(hf[a][a]));
        /* Saddle-free Newton on the free set: each eigen-direction scaled by 1/|lambda|, so
         * negative curvature is descended, not climbed. Where curvature is clearly negative
         * move at least EF_OPT_NC_STEP along it: from an exact saddle (e.g. the plane of
         * symmetry of planar data) the gradient alone never leaves. */
        for (int i = 0; i < n; i++)
            d[i] = act[i] ? -g[i] : 0.0;
        for (int e = 0; e < m; e++) {
            const double lam = hf[e][e];
            double gv = 0.0;
            for (int a = 0; a < m; a++)
                gv += ev[a][e] * g[fi[a]];
            double c = -gv / fmax(fabs(lam), 1e-8 * (1.0 + lmax));
            if (lam < -1e-6 * (1.0 + lmax) && fabs(c) < EF_OPT_NC_STEP)
                c = c < 0.0 ? -EF_OPT_NC_STEP : EF_OPT_NC_STEP;
            for (int a = 0; a < m; a++)
                d[fi[a]] += c * ev[a][e];
        }

        double xn[EF_REF_MAX_DOF], gn[EF_REF_MAX_DOF], fn = f, pgn = pg, step = 1.0;
        int accepted = 0, floor_reached = 0;
        for (int ls = 0; ls < EF_OPT_LS_MAX && !accepted && !floor_reached; ls++, step *= 0.5) {
            double dx[EF_REF_MAX_DOF], lin = 0.0, quad = 0.0;
            for (int i = 0; i < n; i++) {
                xn[i] = opt_clamp(x[i] + step * d[i], p->lo[i], p->hi[i]);
                dx[i] = xn[i] - x[i];
                lin += g[i] * dx[i];
            }
            for (int i = 0; i < n; i++)
                for (int j = 0; j < n; j++)
                    quad += dx[i] * h[i][j] * dx[j];
            /* The quadratic model's change: negative for descent and for negative curvature. */
            const double pred = lin + 0.5 * quad;
            fn = opt_f(p, xn, gn);
            if (!isfinite(fn))
                continue;
            if (ls == 0 && fabs(pred) <= EF_OPT_NOISE * fabs(f)) {
                /* The full step's predicted change is below the rounding of C^2 (which near
                 * C = 0 is far above 1 ulp), so values cannot judge it; the gradient can:
                 * take it while it halves the projected gradient, else stop here. */
                pgn = opt_pg(p, xn, gn);
                accepted = fn <= f + EF_OPT_NOISE * fabs(f) && pgn < 0.5 * pg;
                floor_reached = !accepted;
            } else {
                accepted = pred < 0.0 && fn <= f + 1e-4 * pred;
                if (accepted)
                    pgn = opt_pg(p, xn, gn);
            }
        }
        if (floor_reached)
            *conv = 1;
        if (!accepted)
            break;
        for (int i = 0; i < n; i++) {
            x[i] = xn[i];
            g[i] = gn[i];
        }
        f = fn;
        pg = pgn;
    }
    if (it == max_iter && pg <= tol * fmax(1.0, f))
        *conv = 1;
    *iters = it;
    return f;
}

/* Nonzero when every component is finite. */
static int opt_finite3(ef_dvec3_t v)
{
    return isfinite(v.x) && isfinite(v.y) && isfinite(v.z);
}

/* Screening grid: per-axis node lists (normalized units) and, for the quartic, the frame
 * that maps the inner point's axes (along, across, out of the chord plane) to x, y, z. */
typedef struct {
    int dims;
    int len[EF_REF_MAX_DOF];
    double node[EF_REF_MAX_DOF][EF_OPT_AXIS_MAX];
    ef_dvec3_t mid, u, v, w;
} ef_grid_t;

/* Copy a node list into one grid axis, clamped into [lo, hi] (its first node is lo). */
static void opt_axis(ef_grid_t *gr, int k, const double *v, int len, double lo, double hi)
{
    gr->len[k] = len;
    for (int i = 0; i < len; i++)
        gr->node[k][i] = opt_clamp(v[i], lo, hi);
}

/* Unit vector, or the zero vector when v is shorter than 1e-9. */
static ef_dvec3_t opt_unit(ef_dvec3_t v)
{
    const double l = sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    if (!(l >= 1e-9))
        return (ef_dvec3_t){0.0, 0.0, 0.0};
    return (ef_dvec3_t){v.x / l, v.y / l, v.z / l};
}

/* Component of a normal to the unit vector u. */
static ef_dvec3_t opt_perp(ef_dvec3_t a, ef_dvec3_t u)
{
    const double au = a.x * u.x + a.y * u.y + a.z * u.z;
    return (ef_dvec3_t){a.x - au * u.x, a.y - au * u.y, a.z - au * u.z};
}

/* The screening grid of a kind (node lists in docs/optimizer.md). */
static void opt_grid(const ef_prob_t *p, ef_grid_t *gr)
{
    static const double x1c[8] = {0.0, 0.2, 0.4, 0.7, 1.0, 1.4, 2.0, 3.0};
    static const double x1q[5] = {0.0, 0.3, 0.7, 1.2, 2.0};
    static const double x2q[7] = {-16.0, -6.0, -2.0, 0.0, 2.0, 6.0, 16.0};
    static const double off_u[3] = {-0.25, 0.0, 0.25};
    static const double off_v[5] = {-1.0, -0.5, 0.0, 0.5, 1.0};
    static const double off_w[3] = {-0.25, 0.0, 0.25};
    const ef_dvec3_t zero = {0.0, 0.0, 0.0};

    gr->mid = gr->u = gr->v = gr->w = zero; /* only the quartic uses the frame */
    switch (p->kind) {
    case EF_REF_G1_CUBIC:
        gr->dims = 2;
        for (int k = 0; k < 2; k++)
            opt_axis(gr, k, x1c, 8, p->lo[k], p->hi[k]);
        break;
    case EF_REF_G2_QUINTIC:
        gr->dims = 4;
        for (int k = 0; k < 4; k += 2) {
            opt_axis(gr, k, x1q, 5, p->lo[k], p->hi[k]);
            opt_axis(gr, k + 1, x2q, 7, p->lo[k + 1], p->hi[k + 1]);
        }
        break;
    default: { /* EF_REF_G1_QUARTIC: axes 2..4 are offsets, clamped when mapped */
        gr->dims = 5;
        for (int k = 0; k < 2; k++)
            opt_axis(gr, k, x1q, 5, p->lo[k], p->hi[k]);
        opt_axis(gr, 2, off_u, 3, -INFINITY, INFINITY);
        opt_axis(gr, 3, off_v, 5, -INFINITY, INFINITY);
        opt_axis(gr, 4, off_w, 3, -INFINITY, INFINITY);
        /* Frame: u along the chord, v across it in the plane the tangents lean into (the
         * larger of the sum and the difference of their normal parts), w = u x v. */
        const ef_dvec3_t u = p->e1.p;
        const ef_dvec3_t a = opt_perp(p->e0.t, u), b = opt_perp(p->e1.t, u);
        const ef_dvec3_t sum = {a.x + b.x, a.y + b.y, a.z + b.z};
        const ef_dvec3_t dif = {a.x - b.x, a.y - b.y, a.z - b.z};
        ef_dvec3_t v = opt_unit(sum.x * sum.x + sum.y * sum.y + sum.z * sum.z >=
                                        dif.x * dif.x + dif.y * dif.y + dif.z * dif.z
                                    ? sum
                                    : dif);
        if (v.x == 0.0 && v.y == 0.0 && v.z == 0.0) /* tangents along the chord */
            v = opt_unit(opt_perp(
                fabs(u.x) > 0.6 ? (ef_dvec3_t){0.0, 1.0, 0.0} : (ef_dvec3_t){1.0, 0.0, 0.0}, u));
        gr->u = u;
        gr->v = v;
        gr->w = (ef_dvec3_t){u.y * v.z - u.z * v.y, u.z * v.x - u.x * v.z, u.x * v.y - u.y * v.x};
        gr->mid = (ef_dvec3_t){0.5 * u.x, 0.5 * u.y, 0.5 * u.z};
        break;
    }
    }
}

/* DOFs of grid point number idx (mixed radix, axis 0 fastest), clamped into the box. */
static void opt_grid_point(const ef_prob_t *p, const ef_grid_t *gr, int idx, double *x)
{
    double c[EF_REF_MAX_DOF];
    for (int k = 0; k < gr->dims; k++) {
        c[k] = gr->node[k][idx % gr->len[k]];
        idx /= gr->len[k];
    }
    for (int k = 0; k < p->n; k++)
        x[k] = c[k];
    if (p->kind == EF_REF_G1_QUARTIC) {
        x[2] = gr->mid.x + c[2] * gr->u.x + c[3] * gr->v.x + c[4] * gr->w.x;
        x[3] = gr->mid.y + c[2] * gr->u.y + c[3] * gr->v.y + c[4] * gr->w.y;
        x[4] = gr->mid.z + c[2] * gr->u.z + c[3] * gr->v.z + c[4] * gr->w.z;
    }
    for (int k = 0; k < p->n; k++)
        x[k] = opt_clamp(x[k], p->lo[k], p->hi[k]);
}

/*
 * Starts from the screening grid: the EF_OPT_KEEP lowest grid points that no axis neighbour
 * undercuts (ties broken by index, so clamped duplicates count once). Returns how many.
 */
static int opt_grid_starts(const ef_prob_t *p, const ef_grid_t *gr, double st[][EF_REF_MAX_DOF])
{
    double val[EF_OPT_GRID_MAX], keepv[EF_OPT_KEEP];
    int keep[EF_OPT_KEEP], nk = 0, total = 1;

    for (int k = 0; k < gr->dims; k++)
        total *= gr->len[k];
    for (int i = 0; i < total; i++) {
        double x[EF_REF_MAX_DOF];
        opt_grid_point(p, gr, i, x);
        val[i] = opt_f(p, x, NULL);
        if (!isfinite(val[i]))
            val[i] = INFINITY;
    }
    for (int i = 0; i < total; i++) {
        if (!(val[i] < INFINITY))
            continue;
        int is_min = 1;
        for (int k = 0, stride = 1, rest = i; k < gr->dims && is_min; k++) {
            const int ik = rest % gr->len[k];
            rest /= gr->len[k];
            for (int sg = -1; sg <= 1 && is_min; sg += 2) {
                if (ik + sg < 0 || ik + sg >= gr->len[k])
                    continue;
                const int j = i + sg * stride;
                is_min = val[i] < val[j] || (val[i] == val[j] && i < j);
            }
            stride *= gr->len[k];
        }
        if (!is_min)
            continue;
        /* Insert into the sorted keep list (ascending value, then index). */
        int pos = nk < EF_OPT_KEEP ? nk : EF_OPT_KEEP;
        while (pos > 0 && keepv[pos - 1] > val[i])
            pos--;
        if (pos >= EF_OPT_KEEP)
            continue;
        for (int q = (nk < EF_OPT_KEEP ? nk : EF_OPT_KEEP - 1); q > pos; q--) {
            keep[q] = keep[q - 1];
            keepv[q] = keepv[q - 1];
        }
        keep[pos] = i;
        keepv[pos] = val[i];
        if (nk < EF_OPT_KEEP)
            nk++;
    }
    for (int q = 0; q < nk; q++)
        opt_grid_point(p, gr, keep[q], st[q]);
    return nk;
}

/*
 * The fixed starts: x1 in {0.3, 1, 2} at each end, times x2 in {-2, 0, 2} at each end
 * (quintic) or the inner point at the chord midpoint, +/- 0.5 across the chord and 0.25
 * out of the plane (quartic; the last finds optima that leave the plane of planar data,
 * which a start in the plane cannot reach by symmetry). Returns how many.
 */
static int opt_fixed_starts(const ef_prob_t *p, const ef_grid_t *gr, double st[][EF_REF_MAX_DOF])
{
    static const double x1s[3] = {0.3, 1.0, 2.0};
    static const double x2s[3] = {-2.0, 0.0, 2.0};
    static const double off[4][2] = {{0.0, 0.0}, {0.5, 0.0}, {-0.5, 0.0}, {0.0, 0.25}};
    int k = 0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
            if (p->kind == EF_REF_G1_CUBIC) {
                st[k][0] = x1s[a];
                st[k][1] = x1s[b];
                k++;
            } else if (p->kind == EF_REF_G2_QUINTIC) {
                for (int c = 0; c < 3; c++)
                    for (int e = 0; e < 3; e++) {
                        st[k][0] = x1s[a];
                        st[k][1] = x2s[c];
                        st[k][2] = x1s[b];
                        st[k][3] = x2s[e];
                        k++;
                    }
            } else {
                for (int o = 0; o < 4; o++) {
                    st[k][0] = x1s[a];
                    st[k][1] = x1s[b];
                    st[k][2] = gr->mid.x + off[o][0] * gr->v.x + off[o][1] * gr->w.x;
                    st[k][3] = gr->mid.y + off[o][0] * gr->v.y + off[o][1] * gr->w.y;
                    st[k][4] = gr->mid.z + off[o][0] * gr->v.z + off[o][1] * gr->w.z;
                    k++;
                }
            }
        }
    /* Starts on the x1 lower bound, where most G1 optima sit: there the objective is flat
     * and two basins can lie closer than the screening grid resolves (alpha 2.1271,
     * beta -1.1454: C 1.80333 on the bound, 1.80844 at x1_0 = 0.51, reached from every
     * interior start). Other DOFs at their neutral value (x2 = 0, inner point centred). */
    const int i0 = 0, i1 = p->kind == EF_REF_G2_QUINTIC ? 2 : 1;
    const double b0 = p->lo[i0], b1 = p->lo[i1];
    const double pairs[7][2] = {{b0, 0.3}, {b0, 1.0}, {b0, 2.0}, {0.3, b1},
                                {1.0, b1}, {2.0, b1}, {b0, b1}};
    for (int q = 0; q < 7; q++, k++) {
        for (int d = 0; d < p->n; d++)
            st[k][d] = 0.0;
        st[k][i0] = pairs[q][0];
        st[k][i1] = pairs[q][1];
        if (p->kind == EF_REF_G1_QUARTIC) {
            st[k][2] = gr->mid.x;
            st[k][3] = gr->mid.y;
            st[k][4] = gr->mid.z;
        }
    }
    return k;
}

/* Global minimum of C over the DOF box: multi-start projected Newton (see the top). */
int ef_ref_optimize(ef_ref_kind_t kind, const ef_dend_t *e0, const ef_dend_t *e1,
                    const ef_ref_opts_t *o, ef_ref_result_t *r, ef_msg_t *m)
{
    ef_ref_opts_t def;
    const int n = ef_ref_ndof(kind);

    if (n == 0)
        return ef_fail(m, EF_ERR_ARG, "ef_ref_optimize: unknown kind %d", (int)kind);
    if (!e0 || !e1 || !r)
        return ef_fail(m, EF_ERR_ARG, "ef_ref_optimize: NULL %s", !e0 ? "e0" : !e1 ? "e1" : "r");
    if (!o) {
        ef_ref_opts_default(&def);
        o = &def;
    }
    if (!(isfinite(o->x1_min) && o->x1_min > 0.0 && isfinite(o->x1_max) && o->x1_max > o->x1_min))
        return ef_fail(m, EF_ERR_ARG, "ef_ref_optimize: need 0 < x1_min < x1_max, got %g, %g",
                       o->x1_min, o->x1_max);
    if (!(isfinite(o->x2_max) && o->x2_max > 0.0))
        return ef_fail(m, EF_ERR_ARG, "ef_ref_optimize: need x2_max > 0, got %g", o->x2_max);
    if (o->max_iter < 1 || o->max_iter > EF_OPT_ITER_CAP)
        return ef_fail(m, EF_ERR_ARG, "ef_ref_optimize: max_iter %d outside [1, %d]", o->max_iter,
                       EF_OPT_ITER_CAP);
    if (!(isfinite(o->tol) && o->tol >= 0.0))
        return ef_fail(m, EF_ERR_ARG, "ef_ref_optimize: tol %g not finite and >= 0", o->tol);
    if (o->warm)
        for (int i = 0; i < n; i++)
            if (!isfinite(o->warm[i]))
                return ef_fail(m, EF_ERR_ARG, "ef_ref_optimize: warm[%d] not finite", i);

    const ef_dend_t *ends[2] = {e0, e1};
    for (int k = 0; k < 2; k++) {
        const ef_dend_t *e = ends[k];
        if (!opt_finite3(e->p))
            return ef_fail(m, EF_ERR_NONFINITE, "ef_ref_optimize: e%d.p not finite", k);
        if (!opt_finite3(e->t))
            return ef_fail(m, EF_ERR_NONFINITE, "ef_ref_optimize: e%d.t not finite", k);
        if (kind == EF_REF_G2_QUINTIC && !opt_finite3(e->n))
            return ef_fail(m, EF_ERR_NONFINITE, "ef_ref_optimize: e%d.n not finite", k);
        if (kind == EF_REF_G2_QUINTIC && !isfinite(e->kappa))
            return ef_fail(m, EF_ERR_NONFINITE, "ef_ref_optimize: e%d.kappa not finite", k);
    }

    const ef_dvec3_t q = {e1->p.x - e0->p.x, e1->p.y - e0->p.y, e1->p.z - e0->p.z};
    /* The chord, scaled first so that no square overflows or underflows. */
    const double qm = fmax(fabs(q.x), fmax(fabs(q.y), fabs(q.z)));
    const double s =
        qm > 0.0
            ? qm * sqrt((q.x / qm) * (q.x / qm) + (q.y / qm) * (q.y / qm) + (q.z / qm) * (q.z / qm))
            : 0.0;
    if (!isfinite(s))
        return ef_fail(m, EF_ERR_NONFINITE, "ef_ref_optimize: chord overflows (|p1 - p0| > %g)",
                       DBL_MAX);
    double scale = 1.0;
    for (int k = 0; k < 2; k++) {
        scale = fmax(scale, fabs(ends[k]->p.x));
        scale = fmax(scale, fabs(ends[k]->p.y));
        scale = fmax(scale, fabs(ends[k]->p.z));
    }
    if (s < 1e-12 * scale)
        return ef_fail(m, EF_ERR_DEGENERATE,
                       "ef_ref_optimize: chord %g below 1e-12 x coordinate scale %g", s, scale);

    /* Normalized problem: p0 at the origin, unit chord, curvature times chord. */
    ef_prob_t p;
    p.kind = kind;
    p.n = n;
    p.e0 = *e0;
    p.e1 = *e1;
    p.e0.p = (ef_dvec3_t){0.0, 0.0, 0.0};
    p.e1.p = (ef_dvec3_t){q.x / s, q.y / s, q.z / s};
    p.e0.kappa = kind == EF_REF_G2_QUINTIC ? e0->kappa * s : 0.0;
    p.e1.kappa = kind == EF_REF_G2_QUINTIC ? e1->kappa * s : 0.0;
    for (int i = 0; i < n; i++) {
        p.lo[i] = -o->x2_max;
        p.hi[i] = o->x2_max;
    }
    p.lo[0] = p.lo[kind == EF_REF_G2_QUINTIC ? 2 : 1] = o->x1_min;
    p.hi[0] = p.hi[kind == EF_REF_G2_QUINTIC ? 2 : 1] = o->x1_max;
    if (kind == EF_REF_G1_QUARTIC) {
        const double mid[3] = {0.5 * p.e1.p.x, 0.5 * p.e1.p.y, 0.5 * p.e1.p.z};
        for (int i = 0; i < 3; i++) {
            p.lo[2 + i] = mid[i] - o->x2_max;
            p.hi[2 + i] = mid[i] + o->x2_max;
        }
    }

    double st[EF_OPT_MAX_STARTS][EF_REF_MAX_DOF];
    int ns = 0;
    if (o->warm) {
        for (int i = 0; i < n; i++)
            st[0][i] = o->warm[i];
        ns = 1;
    }
    ef_grid_t gr;
    opt_grid(&p, &gr);
    ns += opt_fixed_starts(&p, &gr, st + ns);
    ns += opt_grid_starts(&p, &gr, st + ns);

    double best[EF_REF_MAX_DOF] = {0.0}, bestf = INFINITY;
    int bestconv = 0;
    int iters = 0;
    for (int k = 0; k < ns; k++) {
        double x[EF_REF_MAX_DOF];
        int it, conv;
        for (int i = 0; i < n; i++)
            x[i] = st[k][i];
        const double f = opt_local(&p, x, o->max_iter, o->tol, &it, &conv);
        iters += it;
        /* Starts that reach the same minimum differ only by rounding there; among such
         * near-ties prefer one that met the stopping test. */
        const double tie = 1e-9 * bestf;
        if (isfinite(f) &&
            (f < bestf - tie ||
             (f <= bestf + tie && (conv > bestconv || (conv == bestconv && f < bestf))))) {
            bestf = f;
            bestconv = conv;
            for (int i = 0; i < n; i++)
                best[i] = x[i];
        }
    }
    r->ndof = n;
    r->starts = ns;
    r->iters = iters;
    if (!isfinite(bestf)) {
        r->C = NAN;
        r->at_bound = 0;
        r->converged = 0;
        return ef_fail(m, EF_ERR_NOCONV, "ef_ref_optimize: no start gave a finite objective");
    }
    r->at_bound = 0;
    for (int i = 0; i < n; i++) {
        const double tolb = 1e-9 * (p.hi[i] - p.lo[i]);
        if (best[i] <= p.lo[i] + tolb || best[i] >= p.hi[i] - tolb)
            r->at_bound |= 1u << i;
    }
    r->converged = bestconv;

    /* Back to program units: lengths scale by s, the inner point also moves by p0. */
    for (int i = 0; i < n; i++)
        r->dof[i] = best[i] * s;
    if (kind == EF_REF_G1_QUARTIC) {
        r->dof[2] += e0->p.x;
        r->dof[3] += e0->p.y;
        r->dof[4] += e0->p.z;
    }
    for (int i = n; i < EF_REF_MAX_DOF; i++)
        r->dof[i] = 0.0;
    ef_dvec3_t b[EF_REF_MAX_DEGREE + 1];
    ef_ref_ctrl(kind, e0, e1, r->dof, b);
    r->C = ef_ref_functional(b, ef_ref_degree(kind));
    return EF_OK;
}
