/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Double-precision reference geometry: control points of the three segment kinds from end
 * data and DOFs, and the constant-speed functional C(f) = sqrt(int <f',f''>^2 |f'|^2 dt)
 * with its exact gradient and Hessian in the DOFs. The optimizer (ef_ref_opt.c) only calls
 * the public functions here, so tables are built and verified against this one objective.
 */
#include <math.h>
#include <pthread.h>
#include <stddef.h>
#include <string.h>

#include "evenfeed/host/tables/ef_ref.h"

/*
 * Gauss-Legendre rules on [0, 1] as {node, weight} (weights sum to 1), for n = 3, 6, 9, 12,
 * 15, 18 nodes. A degree-d curve's integrand has degree 6d - 8, which n = 3(d - 1) nodes
 * (exact to degree 2n - 1 = 6d - 7) integrate exactly. The values are the correctly rounded
 * doubles of roots found by Newton's method on P_n in 60-digit decimal arithmetic; the tests
 * check the functional against an independent long-double rule. Constants keep the
 * functional thread-safe and portable to a compute shader.
 */
static const double ef_gl_rule[63][2] = {
    {0.11270166537925831, 0.2777777777777778},    {0.5, 0.4444444444444444},
    {0.8872983346207417, 0.2777777777777778},     {0.03376524289842399, 0.08566224618958518},
    {0.16939530676686773, 0.1803807865240693},    {0.38069040695840156, 0.23395696728634552},
    {0.6193095930415985, 0.23395696728634552},    {0.8306046932331322, 0.1803807865240693},
    {0.966234757101576, 0.08566224618958518},     {0.015919880246186954, 0.040637194180787206},
    {0.0819844463366821, 0.0903240803474287},     {0.1933142836497048, 0.13030534820146772},
    {0.33787328829809554, 0.15617353852000143},   {0.5, 0.1651196775006299},
    {0.6621267117019045, 0.15617353852000143},    {0.8066857163502952, 0.13030534820146772},
    {0.9180155536633179, 0.0903240803474287},     {0.984080119753813, 0.040637194180787206},
    {0.009219682876640375, 0.023587668193255914}, {0.04794137181476257, 0.05346966299765921},
    {0.11504866290284765, 0.08003916427167311},   {0.2063410228566913, 0.10158371336153296},
    {0.3160842505009099, 0.1167462682691774},     {0.43738329574426554, 0.12457352290670139},
    {0.5626167042557345, 0.12457352290670139},    {0.6839157494990901, 0.1167462682691774},
    {0.7936589771433087, 0.10158371336153296},    {0.8849513370971523, 0.08003916427167311},
    {0.9520586281852375, 0.05346966299765921},    {0.9907803171233597, 0.023587668193255914},
    {0.006003740989757286, 0.015376620998058635}, {0.031363303799647045, 0.03518302374405406},
    {0.0758967082947864, 0.05357961023358597},    {0.13779113431991497, 0.06978533896307716},
    {0.21451391369573058, 0.08313460290849696},   {0.3029243264612183, 0.0930805000077811},
    {0.39940295300128276, 0.09921574266355579},   {0.5, 0.10128912096278064},
    {0.6005970469987173, 0.09921574266355579},    {0.6970756735387816, 0.0930805000077811},
    {0.7854860863042694, 0.08313460290849696},    {0.862208865680085, 0.06978533896307716},
    {0.9241032917052137, 0.05357961023358597},    {0.968636696200353, 0.03518302374405406},
    {0.9939962590102427, 0.015376620998058635},   {0.004217415789534527, 0.010808006763241656},
    {0.022088025214301123, 0.0248572744474849},   {0.05369876675122213, 0.038212865127444526},
    {0.09814752051373844, 0.050471022053143584},  {0.1541564784698234, 0.06127760335573923},
    {0.22011458446302623, 0.07032145733532533},   {0.2941244192685787, 0.07734233756313262},
    {0.37405688715424723, 0.08213824187291636},   {0.45761249347913235, 0.0845711914815718},
    {0.5423875065208676, 0.0845711914815718},     {0.6259431128457528, 0.08213824187291636},
    {0.7058755807314213, 0.07734233756313262},    {0.7798854155369738, 0.07032145733532533},
    {0.8458435215301766, 0.06127760335573923},    {0.9018524794862616, 0.050471022053143584},
    {0.9463012332487779, 0.038212865127444526},   {0.9779119747856989, 0.0248572744474849},
    {0.9957825842104655, 0.010808006763241656},
};
/* Offset of the n = 3(i + 1) node rule in ef_gl_rule, i = 0..5, plus the end. */
static const int ef_gl_off[7] = {0, 3, 9, 18, 30, 45, 63};

/* Dot product. */
static double ref_dot(ef_dvec3_t a, ef_dvec3_t b)
{
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

/* a + s b. */
static ef_dvec3_t ref_axpy(ef_dvec3_t a, double s, ef_dvec3_t b)
{
    ef_dvec3_t r = {a.x + s * b.x, a.y + s * b.y, a.z + s * b.z};
    return r;
}

/* Number of DOFs of a kind, 0 if the kind is unknown. */
int ef_ref_ndof(ef_ref_kind_t kind)
{
    switch (kind) {
    case EF_REF_G1_CUBIC:
        return 2;
    case EF_REF_G2_QUINTIC:
        return 4;
    case EF_REF_G1_QUARTIC:
        return 5;
    default:
        return 0;
    }
}

/* Bezier degree of a kind, 0 if the kind is unknown. */
int ef_ref_degree(ef_ref_kind_t kind)
{
    switch (kind) {
    case EF_REF_G1_CUBIC:
        return 3;
    case EF_REF_G2_QUINTIC:
        return 5;
    case EF_REF_G1_QUARTIC:
        return 4;
    default:
        return 0;
    }
}

/* The normalized planar configuration tables are indexed by. */
void ef_ref_config(double alpha, double beta, double k0, double k1, ef_dend_t *e0, ef_dend_t *e1)
{
    if (e0) {
        ef_dend_t e = {
            {0.0, 0.0, 0.0}, {cos(alpha), sin(alpha), 0.0}, {-sin(alpha), cos(alpha), 0.0}, k0};
        *e0 = e;
    }
    if (e1) {
        ef_dend_t e = {
            {1.0, 0.0, 0.0}, {cos(beta), sin(beta), 0.0}, {-sin(beta), cos(beta), 0.0}, k1};
        *e1 = e;
    }
}

/* Control points from end data and DOFs (formulas in ef_ref.h / domain.md). */
int ef_ref_ctrl(ef_ref_kind_t kind, const ef_dend_t *e0, const ef_dend_t *e1, const double *dof,
                ef_dvec3_t *b)
{
    if (!e0 || !e1 || !dof || !b)
        return EF_ERR_ARG;
    switch (kind) {
    case EF_REF_G1_CUBIC:
        b[0] = e0->p;
        b[1] = ref_axpy(e0->p, dof[0] / 3.0, e0->t);
        b[2] = ref_axpy(e1->p, -dof[1] / 3.0, e1->t);
        b[3] = e1->p;
        return EF_OK;
    case EF_REF_G2_QUINTIC: {
        /* f''(0) = x2 t + kappa x1^2 n: the normal part is fixed by the curvature. */
        ef_dvec3_t dd0 = ref_axpy(ref_axpy((ef_dvec3_t){0.0, 0.0, 0.0}, dof[1], e0->t),
                                  e0->kappa * dof[0] * dof[0], e0->n);
        ef_dvec3_t dd1 = ref_axpy(ref_axpy((ef_dvec3_t){0.0, 0.0, 0.0}, dof[3], e1->t),
                                  e1->kappa * dof[2] * dof[2], e1->n);
        b[0] = e0->p;
        b[1] = ref_axpy(e0->p, dof[0] / 5.0, e0->t);
        b[2] = ref_axpy(ref_axpy(b[1], 1.0, b[1]), -1.0, b[0]);
        b[2] = ref_axpy(b[2], 1.0 / 20.0, dd0);
        b[5] = e1->p;
        b[4] = ref_axpy(e1->p, -dof[2] / 5.0, e1->t);
        b[3] = ref_axpy(ref_axpy(b[4], 1.0, b[4]), -1.0, b[5]);
        b[3] = ref_axpy(b[3], 1.0 / 20.0, dd1);
        return EF_OK;
    }
    case EF_REF_G1_QUARTIC:
        b[0] = e0->p;
        b[1] = ref_axpy(e0->p, dof[0] / 4.0, e0->t);
        b[2].x = dof[2];
        b[2].y = dof[3];
        b[2].z = dof[4];
        b[3] = ref_axpy(e1->p, -dof[1] / 4.0, e1->t);
        b[4] = e1->p;
        return EF_OK;
    default:
        return EF_ERR_ARG;
    }
}

/*
 * Derivatives of the degree-d Bernstein basis at t: A[k] = B'_{k,d}(t), C[k] = B''_{k,d}(t)
 * for k = 0..d, from the degree d-1 and d-2 bases built by the triangle scheme.
 */
static void ref_basis_derivs(double t, int d, double *A, double *C)
{
    double bern[EF_REF_MAX_DEGREE + 1], bern2[EF_REF_MAX_DEGREE + 1];
    const double s = 1.0 - t;
    bern[0] = bern2[0] = 1.0;
    for (int k = 1; k < d; k++) {
        if (k == d - 1) /* keep the degree d-2 row */
            for (int i = 0; i < k; i++)
                bern2[i] = bern[i];
        bern[k] = t * bern[k - 1];
        for (int i = k - 1; i > 0; i--)
            bern[i] = s * bern[i] + t * bern[i - 1];
        bern[0] = s * bern[0];
    }
    for (int k = 0; k <= d; k++) {
        const double lo = k > 0 ? bern[k - 1] : 0.0, hi = k < d ? bern[k] : 0.0;
        A[k] = d * (lo - hi);
        double c = 0.0;
        if (d >= 2) {
            if (k >= 2)
                c += bern2[k - 2];
            if (k >= 1 && k - 1 <= d - 2)
                c -= 2.0 * bern2[k - 1];
            if (k <= d - 2)
                c += bern2[k];
        }
        C[k] = (double)(d * (d - 1)) * c;
    }
}

/* B'_k and B''_k of each rule's degree at each of its nodes: ef_basis_tab[j][0][k] and
 * [j][1][k] for node j of ef_gl_rule (node j belongs to one rule, hence one degree).
 * Filled once under pthread_once, read-only afterwards, so concurrent callers are safe. */
static double ef_basis_tab[63][2][EF_REF_MAX_DEGREE + 1];
static pthread_once_t ef_basis_once = PTHREAD_ONCE_INIT;

/* Fill ef_basis_tab (run once). */
static void ref_basis_init(void)
{
    for (int d = 2; d <= EF_REF_MAX_DEGREE; d++)
        for (int j = ef_gl_off[d - 2]; j < ef_gl_off[d - 1]; j++)
            ref_basis_derivs(ef_gl_rule[j][0], d, ef_basis_tab[j][0], ef_basis_tab[j][1]);
}

/* C^2 of a Bezier curve; control points are taken relative to b[0] so that a segment far
 * from the origin loses no digits in f' and f''. */
static double ref_c2_ctrl(const ef_dvec3_t *b, int d)
{
    double c2 = 0.0;
    if (d < 2)
        return 0.0; /* a line segment has f'' = 0 */
    pthread_once(&ef_basis_once, ref_basis_init);
    for (int j = ef_gl_off[d - 2]; j < ef_gl_off[d - 1]; j++) {
        const double *A = ef_basis_tab[j][0], *C = ef_basis_tab[j][1];
        ef_dvec3_t fp = {0.0, 0.0, 0.0}, fpp = {0.0, 0.0, 0.0};
        for (int k = 1; k <= d; k++) {
            const ef_dvec3_t r = ref_axpy(b[k], -1.0, b[0]);
            fp = ref_axpy(fp, A[k], r);
            fpp = ref_axpy(fpp, C[k], r);
        }
        const double g = ref_dot(fp, fpp), h = ref_dot(fp, fp);
        c2 += ef_gl_rule[j][1] * g * g * h;
    }
    return c2;
}

/* C(f) of a Bezier curve by exact Gauss-Legendre quadrature. */
double ef_ref_functional(const ef_dvec3_t *b, int degree)
{
    if (!b || degree < 1 || degree > EF_REF_MAX_DEGREE)
        return NAN;
    return sqrt(ref_c2_ctrl(b, degree));
}

/* Most nonzero entries of db_k/dx_i over the kinds (quintic: 6) and of d2b_k/dx_i^2 (2). */
#define EF_JAC_MAX  8
#define EF_JAC2_MAX 2

/*
 * A segment as a function of its DOFs: control points (relative to b[0]) and the sparse
 * Jacobian db_k/dx_i. The only second derivatives are the quintic's d2b/dx1^2 = kappa n / 10
 * (from kappa x1^2 n / 20); no kind has mixed ones.
 */
typedef struct {
    int d, n, nj, nj2;
    ef_dvec3_t b[EF_REF_MAX_DEGREE + 1];
    int jk[EF_JAC_MAX], ji[EF_JAC_MAX];
    ef_dvec3_t jv[EF_JAC_MAX];
    int sk[EF_JAC2_MAX], si[EF_JAC2_MAX];
    ef_dvec3_t sv[EF_JAC2_MAX];
} ef_model_t;

/* Append one Jacobian entry db_k/dx_i = v. */
static void ref_jac(ef_model_t *md, int k, int i, ef_dvec3_t v)
{
    md->jk[md->nj] = k;
    md->ji[md->nj] = i;
    md->jv[md->nj] = v;
    md->nj++;
}

/* Build the model of a segment at the DOFs (the derivatives of ef_ref_ctrl's formulas). */
static int ref_model(ef_ref_kind_t kind, const ef_dend_t *e0, const ef_dend_t *e1,
                     const double *dof, ef_model_t *md)
{
    const ef_dvec3_t zero = {0.0, 0.0, 0.0};
    memset(md, 0, sizeof *md); /* unused entries defined, for the compiler and for debuggers */
    const int rc = ef_ref_ctrl(kind, e0, e1, dof, md->b);
    if (rc != EF_OK)
        return rc;
    md->d = ef_ref_degree(kind);
    md->n = ef_ref_ndof(kind);
    md->nj = md->nj2 = 0;
    for (int k = md->d; k >= 0; k--)
        md->b[k] = ref_axpy(md->b[k], -1.0, md->b[0]);
    switch (kind) {
    case EF_REF_G1_CUBIC:
        ref_jac(md, 1, 0, ref_axpy(zero, 1.0 / 3.0, e0->t));
        ref_jac(md, 2, 1, ref_axpy(zero, -1.0 / 3.0, e1->t));
        break;
    case EF_REF_G2_QUINTIC:
        ref_jac(md, 1, 0, ref_axpy(zero, 0.2, e0->t));
        ref_jac(md, 2, 0, ref_axpy(ref_axpy(zero, 0.4, e0->t), 0.1 * e0->kappa * dof[0], e0->n));
        ref_jac(md, 2, 1, ref_axpy(zero, 0.05, e0->t));
        ref_jac(md, 4, 2, ref_axpy(zero, -0.2, e1->t));
        ref_jac(md, 3, 2, ref_axpy(ref_axpy(zero, -0.4, e1->t), 0.1 * e1->kappa * dof[2], e1->n));
        ref_jac(md, 3, 3, ref_axpy(zero, 0.05, e1->t));
        md->sk[0] = 2;
        md->si[0] = 0;
        md->sv[0] = ref_axpy(zero, 0.1 * e0->kappa, e0->n);
        md->sk[1] = 3;
        md->si[1] = 2;
        md->sv[1] = ref_axpy(zero, 0.1 * e1->kappa, e1->n);
        md->nj2 = 2;
        break;
    default: /* EF_REF_G1_QUARTIC: ef_ref_ctrl already rejected unknown kinds */
        ref_jac(md, 1, 0, ref_axpy(zero, 0.25, e0->t));
        ref_jac(md, 3, 1, ref_axpy(zero, -0.25, e1->t));
        ref_jac(md, 2, 2, (ef_dvec3_t){1.0, 0.0, 0.0});
        ref_jac(md, 2, 3, (ef_dvec3_t){0.0, 1.0, 0.0});
        ref_jac(md, 2, 4, (ef_dvec3_t){0.0, 0.0, 1.0});
        break;
    }
    return EF_OK;
}

/*
 * C^2 = sum_j w_j phi(a_j, c_j) with a = f'(t_j), c = f''(t_j), phi = (a.c)^2 |a|^2, and
 * optionally its gradient and Hessian in the DOFs, in one pass over the nodes. With
 * g = a.c, h = a.a the derivatives of phi are
 *   U = dphi/da = 2gh c + 2g^2 a,   V = dphi/dc = 2gh a,
 *   phi_aa = 2h cc' + 4g (ca' + ac') + 2g^2 I,   phi_ac = 2h ca' + 2gh I + 4g aa',
 *   phi_cc = 2h aa',
 * and a, c are linear in the control points, so a_i = da/dx_i = sum_k B'_k db_k/dx_i (c_i
 * likewise with B''_k), giving grad_i = sum w (U.a_i + V.c_i) and
 * H_ij = sum w [(a_i, c_i)' Phi (a_j, c_j) + (U.a_ii + V.c_ii) delta_ij].
 */
static double ref_eval(const ef_model_t *md, double *grad, double *hess)
{
    const int d = md->d, n = md->n;
    const ef_dvec3_t zero = {0.0, 0.0, 0.0};
    double c2 = 0.0;

    if (grad)
        for (int i = 0; i < n; i++)
            grad[i] = 0.0;
    if (hess)
        for (int i = 0; i < n * n; i++)
            hess[i] = 0.0;
    if (d < 2)
        return 0.0;
    pthread_once(&ef_basis_once, ref_basis_init);
    for (int j = ef_gl_off[d - 2]; j < ef_gl_off[d - 1]; j++) {
        const double w = ef_gl_rule[j][1];
        const double *A = ef_basis_tab[j][0], *C = ef_basis_tab[j][1];
        ef_dvec3_t a = zero, c = zero;
        for (int k = 1; k <= d; k++) {
            a = ref_axpy(a, A[k], md->b[k]);
            c = ref_axpy(c, C[k], md->b[k]);
        }
        const double g = ref_dot(a, c), h = ref_dot(a, a);
        c2 += w * g * g * h;
        if (!grad && !hess)
            continue;

        const ef_dvec3_t U = ref_axpy(ref_axpy(zero, 2.0 * g * h, c), 2.0 * g * g, a);
        const ef_dvec3_t V = ref_axpy(zero, 2.0 * g * h, a);
        ef_dvec3_t ai[EF_REF_MAX_DOF], ci[EF_REF_MAX_DOF];
        for (int i = 0; i < n; i++)
            ai[i] = ci[i] = zero;
        for (int e = 0; e < md->nj; e++) {
            ai[md->ji[e]] = ref_axpy(ai[md->ji[e]], A[md->jk[e]], md->jv[e]);
            ci[md->ji[e]] = ref_axpy(ci[md->ji[e]], C[md->jk[e]], md->jv[e]);
        }
        if (grad)
            for (int i = 0; i < n; i++)
                grad[i] += w * (ref_dot(U, ai[i]) + ref_dot(V, ci[i]));
        if (!hess)
            continue;

        ef_dvec3_t P[EF_REF_MAX_DOF], Q[EF_REF_MAX_DOF];
        for (int i = 0; i < n; i++) {
            /* P = phi_aa a_i + phi_ac c_i,  Q = phi_ca a_i + phi_cc c_i. */
            const double a_ai = ref_dot(a, ai[i]), c_ai = ref_dot(c, ai[i]);
            const double a_ci = ref_dot(a, ci[i]);
            ef_dvec3_t p = ref_axpy(zero, 2.0 * h * (c_ai + a_ci) + 4.0 * g * a_ai, c);
            p = ref_axpy(p, 4.0 * g * (c_ai + a_ci), a);
            p = ref_axpy(p, 2.0 * g * g, ai[i]);
            P[i] = ref_axpy(p, 2.0 * g * h, ci[i]);
            ef_dvec3_t q = ref_axpy(zero, 2.0 * h * (c_ai + a_ci) + 4.0 * g * a_ai, a);
            Q[i] = ref_axpy(q, 2.0 * g * h, ai[i]);
        }
        for (int i = 0; i < n; i++)
            for (int k = i; k < n; k++)
                hess[i * n + k] += w * (ref_dot(ai[i], P[k]) + ref_dot(ci[i], Q[k]));
        for (int e = 0; e < md->nj2; e++) {
            const ef_dvec3_t s2 = md->sv[e];
            hess[md->si[e] * (n + 1)] +=
                w * (A[md->sk[e]] * ref_dot(U, s2) + C[md->sk[e]] * ref_dot(V, s2));
        }
    }
    if (hess)
        for (int i = 0; i < n; i++)
            for (int k = 0; k < i; k++)
                hess[i * n + k] = hess[k * n + i];
    return c2;
}

/* C^2 as a function of the DOFs, with the gradient and Hessian by the chain rule. */
double ef_ref_objective_hess(ef_ref_kind_t kind, const ef_dend_t *e0, const ef_dend_t *e1,
                             const double *dof, double *grad, double *hess)
{
    ef_model_t md;
    if (ref_model(kind, e0, e1, dof, &md) != EF_OK)
        return NAN;
    return ref_eval(&md, grad, hess);
}

/* C^2 as a function of the DOFs, with the gradient. */
double ef_ref_objective(ef_ref_kind_t kind, const ef_dend_t *e0, const ef_dend_t *e1,
                        const double *dof, double *grad)
{
    return ef_ref_objective_hess(kind, e0, e1, dof, grad, NULL);
}

/* Rounded to float32 component by component, as a firmware would receive it. */
ef_endpoint_t ef_ref_end_to_fw(const ef_dend_t *e)
{
    ef_endpoint_t f;
    f.p = ef_v3((float)e->p.x, (float)e->p.y, (float)e->p.z);
    f.t = ef_v3((float)e->t.x, (float)e->t.y, (float)e->t.z);
    f.n = ef_v3((float)e->n.x, (float)e->n.y, (float)e->n.z);
    f.kappa = (float)e->kappa;
    return f;
}
