/* SPDX-License-Identifier: Apache-2.0 */
/*
 * ef_opt.comp: the reference optimizer (host/lib/tables/ef_ref_opt.c, ef_ref_optimize) as an
 * OpenGL 4.3 compute shader in double precision, for normalized planar configurations:
 * p0 = (0, 0), p1 = (1, 0), t_i = (cos, sin), n_i = t_i turned +90 degrees, kappa_i = k_i.
 * The same functional, objective, gradient, Hessian, box, starts, stopping rules, tie rules
 * and caps as the CPU, with no warm start; docs/optimizer.md ("GPU port") has the measured
 * agreement. Every floating-point expression is written in the CPU's order of operations
 * (the 2-D specialisation only drops terms that are exactly zero there), and the doubles
 * the CPU tabulates at run time (Bernstein derivatives at the Gauss-Legendre nodes) are
 * constants printed from the CPU's own formulas with 17 significant digits, so a driver
 * with IEEE double arithmetic and no contraction (llvmpipe) reproduces the CPU bit for bit.
 * Variables are `precise` so that drivers which fuse a * b + c into fma do not drift.
 *
 * Interface (the host is gpu_offline/src/ef_gl.c):
 * - No #version line: the host prepends
 *     #version 430
 *     #extension GL_ARB_gpu_shader_fp64 : require
 *     #define EF_KIND 1            (1 = G1 cubic, 2 = G2 quintic)
 *     #define EF_LOCAL_SIZE 32
 *   and may define EF_CFG_STRIDE (it must be 8).
 * - One invocation per configuration, i = gl_GlobalInvocationID.x, none past ef_count.
 * - binding 0, EfCfg: EF_CFG_STRIDE = 8 doubles per configuration:
 *     alpha, beta, k0, k1, cos alpha, sin alpha, cos beta, sin beta
 *   GLSL 4.30 has no double sin/cos, so the host computes them with libm (the CPU
 *   reference uses the same libm values, through ef_ref_config). alpha and beta are not
 *   read here; k0, k1 are ignored for G1.
 * - binding 1, EfRes: EF_RES_STRIDE = 8 doubles per configuration: [0..3] DOFs per unit
 *   chord (G1: x1_0, x1_1, 0, 0; G2: x1_0, x2_0, x1_1, x2_1), [4] C, [5] converged (0/1),
 *   [6] at-bound bit mask, [7] starts run. C is NaN when no start had a finite objective
 *   (the CPU's EF_ERR_NOCONV). [7] = -1 (and C = NaN) when the driver cut the run short
 *   (below): the result is void and the configuration must be solved again (on the CPU).
 * - Uniforms ef_count, ef_x1_min, ef_x1_max, ef_x2_max, ef_max_iter, ef_tol: the host
 *   validates them as ef_ref_optimize does (0 < x1_min < x1_max, x2_max > 0,
 *   1 <= max_iter <= 100000, tol >= 0, all finite); the shader does not check.
 *
 * Everything is bounded: fixed-size arrays, no recursion, every loop has a constant cap or
 * a cap from a uniform. Private memory per invocation is dominated by the screening grid's
 * values (1225 doubles for G2).
 *
 * llvmpipe (Mesa's CPU driver, the CI's GL) ends every loop of an invocation once all its
 * loops together have run 65535 iterations (gallivm's LP_MAX_TGSI_LOOP_ITERATIONS, a
 * watchdog shared by all loops of the shader), silently. Written with plain loops, a G2
 * solve needs far more (a first draft of this shader lost most of its starts that way). So
 * loops with a fixed count are written out (the Gauss-Legendre nodes one statement each,
 * the Jacobi rotations of a sweep one call per pair on a zero-padded fixed-size block, the
 * grid's neighbour test a row of axis 0 per pass), and each start's Newton iterations and
 * backtracking share one loop with one evaluation per pass. What remains: grid points,
 * starts, evaluations, Jacobi sweeps; a G2 solve takes at most about 12,000 loop iterations per
 * 8 invocations (docs/optimizer.md, "GPU port"). The loop over the starts runs one extra,
 * empty pass at the end; on llvmpipe that pass is reached only if no loop was cut, so an
 * exhausted run is reported ([7] = -1) instead of returned as a wrong optimum. Other
 * drivers have no such limit.
 */

layout(local_size_x = EF_LOCAL_SIZE) in;

layout(std430, binding = 0) readonly buffer EfCfg { double ef_cfg[]; };
layout(std430, binding = 1) writeonly buffer EfRes { double ef_res[]; };

uniform uint ef_count;
uniform double ef_x1_min;
uniform double ef_x1_max;
uniform double ef_x2_max;
uniform int ef_max_iter;
uniform double ef_tol;

/* The host may define the input stride too (ef_gl.c does); it must be 8. */
#ifndef EF_CFG_STRIDE
#define EF_CFG_STRIDE 8
#endif
#if EF_CFG_STRIDE != 8
#error "EF_CFG_STRIDE must be 8: alpha, beta, k0, k1, cos alpha, sin alpha, cos beta, sin beta"
#endif
#define EF_RES_STRIDE 8

/* Caps and thresholds of ef_ref_opt.c (all doubles carry the lf suffix: an unsuffixed
 * literal is a float, and 0.1 as a float is 0.100000001490116). */
#define EF_LS_MAX 40             /* backtracking halvings per iteration */
#define EF_JACOBI_SWEEPS 50      /* Jacobi sweeps per eigen-decomposition */
#define EF_NC_STEP 0.1lf         /* least step along negative curvature */
#define EF_NOISE 1e-10lf         /* relative change of C^2 that is rounding noise */
#define EF_KEEP 8                /* Newton starts taken from the screening grid */

/*
 * Per kind: DOFs, degree, Gauss-Legendre nodes (3 (d - 1): exact for the degree 6d - 8
 * integrand), index of x1 at the far end, fixed starts, screening-grid size.
 * EF_W[j] are the weights on [0, 1]; EF_A[j * EF_D + k - 1] = B'_k(t_j) and
 * EF_C[j * EF_D + k - 1] = B''_k(t_j) for k = 1..d (k = 0 is never needed: control points
 * are relative to b0 = p0 = 0). Printed with %.17e from ef_ref.c's rule and basis code.
 */
#if EF_KIND == 1
#define EF_N 2
#define EF_D 3
#define EF_NQ 6
#define EF_I1 1
#define EF_NFIX 9
#define EF_GRID_DIMS 2
#define EF_GRID_TOTAL 64
const double EF_W[6] = double[](
    8.56622461895851783e-02lf, 1.80380786524069303e-01lf, 2.33956967286345519e-01lf,
    2.33956967286345519e-01lf, 1.80380786524069303e-01lf, 8.56622461895851783e-02lf);
const double EF_A[18] = double[](
    2.60507790987081833e+00lf, 1.92330632738637763e-01lf, 3.42027488396871469e-03lf,
    1.22550924838935815e+00lf, 7.58118911009435292e-01lf, 8.60843098639236803e-02lf,
    -2.63958209949438360e-01lf, 9.79815768199028825e-01lf, 4.34775557850460181e-01lf,
    -9.79815768199028825e-01lf, 2.63958209949437861e-01lf, 1.15063311610005092e+00lf,
    -7.58118911009435514e-01lf, -1.22550924838935815e+00lf, 2.06971246926271712e+00lf,
    -1.92330632738637708e-01lf, -2.60507790987081833e+00lf, 2.80082881749342505e+00lf);
const double EF_C[18] = double[](
    -1.13922256278283669e+01lf, 5.39222562782836867e+00lf, 2.02591457390543933e-01lf,
    -8.95088447819638056e+00lf, 2.95088447819638056e+00lf, 1.01637184060120633e+00lf,
    -5.14757267474877089e+00lf, -8.52427325251228440e-01lf, 2.28414244175040926e+00lf,
    -8.52427325251227108e-01lf, -5.14757267474877267e+00lf, 3.71585755824959119e+00lf,
    2.95088447819638056e+00lf, -8.95088447819637878e+00lf, 4.98362815939879322e+00lf,
    5.39222562782836867e+00lf, -1.13922256278283669e+01lf, 5.79740854260945593e+00lf);
#elif EF_KIND == 2
#define EF_N 4
#define EF_D 5
#define EF_NQ 12
#define EF_I1 2
#define EF_NFIX 81
#define EF_GRID_DIMS 4
#define EF_GRID_TOTAL 1225
const double EF_W[12] = double[](
    2.35876681932559139e-02lf, 5.34696629976592133e-02lf, 8.00391642716731105e-02lf,
    1.01583713361532962e-01lf, 1.16746268269177403e-01lf, 1.24573522906701387e-01lf,
    1.24573522906701387e-01lf, 1.16746268269177403e-01lf, 1.01583713361532962e-01lf,
    8.00391642716731105e-02lf, 5.34696629976592133e-02lf, 2.35876681932559139e-02lf);
const double EF_A[60] = double[](
    4.63880039955525003e+00lf, 1.76837110139148851e-01lf, 2.48774211596306189e-03lf,
    1.54932956790363111e-05lf, 3.61271695265157205e-08lf, 3.28051597190908861e+00lf,
    7.64932018859460938e-01lf, 6.04003998168379935e-02lf, 2.07168192883769395e-03lf,
    2.64126412250586707e-05lf, 1.47186641902349447e+00lf, 1.28369266228722223e+00lf,
    2.84021166336653141e-01lf, 2.60762090122161755e-02lf, 8.75984268647434492e-04lf,
    -7.92503385537182692e-02lf, 1.25852278597341005e+00lf, 6.65112722299332493e-01lf,
    1.30386847577691256e-01lf, 9.06384187962702183e-03lf, -9.28370058460070591e-01lf,
    6.20328234842608905e-01lf, 9.69991229640186692e-01lf, 3.82048356726778948e-01lf,
    4.99092945894356529e-02lf, -1.05688572205912967e+00lf, -2.58782573993656950e-01lf,
    8.75129184218421119e-01lf, 7.58532849279327626e-01lf, 1.82986384054773688e-01lf,
    -7.58532849279327626e-01lf, -8.75129184218421452e-01lf, 2.58782573993656673e-01lf,
    1.05688572205912967e+00lf, 5.00980121499736364e-01lf, -3.82048356726779059e-01lf,
    -9.69991229640186470e-01lf, -6.20328234842608461e-01lf, 9.28370058460070702e-01lf,
    1.09390705733893889e+00lf, -1.30386847577691312e-01lf, -6.65112722299332715e-01lf,
    -1.25852278597341005e+00lf, 7.92503385537185467e-02lf, 1.98383585917634253e+00lf,
    -2.60762090122161755e-02lf, -2.84021166336653141e-01lf, -1.28369266228722223e+00lf,
    -1.47186641902349447e+00lf, 3.06653244092823352e+00lf, -2.07168192883769049e-03lf,
    -6.04003998168379033e-02lf, -7.64932018859460494e-01lf, -3.28051597190908950e+00lf,
    4.10794648515545013e+00lf, -1.54932956790360502e-05lf, -2.48774211596303370e-03lf,
    -1.76837110139147879e-01lf, -4.63880039955525092e+00lf, 4.81814078123321021e+00lf);
const double EF_C[60] = double[](
    -3.83607793251100944e+01lf, 1.83709012617339624e+01lf, 5.32937099350693444e-01lf,
    5.02178348311559976e-03lf, 1.56739315266688886e-05lf, -3.19111443792234404e+01lf,
    1.21759306693263785e+01lf, 2.34690972867986947e+00lf, 1.26883782214063739e-01lf,
    2.20374513496298698e-03lf, -2.23156467862860950e+01lf, 3.75170951479679626e+00lf,
    4.03079431714945446e+00lf, 6.41891038366717681e-01lf, 3.04561303554533487e-02lf,
    -1.21984738521673783e+01lf, -3.57086230708628038e+00lf, 3.91913368990879718e+00lf,
    1.67606677793360381e+00lf, 1.75706056975826364e-01lf, -3.92508158099970528e+00lf,
    -7.24378215760344890e+00lf, 1.30278250726089673e+00lf, 2.83658105651353187e+00lf,
    6.31594829673957192e-01lf, 1.18332170666602288e+00lf, -6.59414786689812438e+00lf,
    -2.93534993487986018e+00lf, 3.11092499600095662e+00lf, 1.67346476955319634e+00lf,
    3.11092499600095707e+00lf, -2.93534993487985840e+00lf, -6.59414786689812615e+00lf,
    1.18332170666601955e+00lf, 3.56178632955781183e+00lf, 2.83658105651353187e+00lf,
    1.30278250726089451e+00lf, -7.24378215760345245e+00lf, -3.92508158099969862e+00lf,
    6.39790534515476494e+00lf, 1.67606677793360426e+00lf, 3.91913368990879807e+00lf,
    -3.57086230708628438e+00lf, -1.21984738521673748e+01lf, 9.99842963443543020e+00lf,
    6.41891038366717681e-01lf, 4.03079431714945535e+00lf, 3.75170951479679493e+00lf,
    -2.23156467862860950e+01lf, 1.38607957856176718e+01lf, 1.26883782214063601e-01lf,
    2.34690972867986813e+00lf, 1.21759306693263838e+01lf, -3.19111443792234404e+01lf,
    1.72592164538681629e+01lf, 5.02178348311554338e-03lf, 5.32937099350690446e-01lf,
    1.83709012617339660e+01lf, -3.83607793251101015e+01lf, 1.94519035066108010e+01lf);
#else
#error "EF_KIND must be 1 (G1 cubic) or 2 (G2 quintic)"
#endif

#define EF_NN (EF_N * EF_N)

/* The configuration and its box, set once per invocation by main(). */
dvec2 ef_t0, ef_n0, ef_t1, ef_n1;
double ef_k0, ef_k1;
double ef_lo[EF_N], ef_hi[EF_N];

/* IEEE +infinity and a quiet NaN, built from bits: GLSL has no literal for either. */
double ef_inf()
{
    return packDouble2x32(uvec2(0u, 0x7FF00000u));
}
double ef_nan()
{
    return packDouble2x32(uvec2(0u, 0x7FF80000u));
}
bool ef_finite(double v)
{
    return !(isnan(v) || isinf(v));
}

/* C's ef_clamp (v < lo ? lo : v > hi ? hi : v), spelled out so NaN behaves the same. */
double ef_clamp(double v, double lo, double hi)
{
    return v < lo ? lo : (v > hi ? hi : v);
}

/* a.b as the CPU's 3-D dot with z = 0: (ax bx + ay by) + 0, the + 0 being exact. */
double ef_dot(dvec2 a, dvec2 b)
{
    precise double r = a.x * b.x + a.y * b.y;
    return r;
}

/* Control points b[1..d] relative to b0 = p0 = (0, 0) (ef_ref_ctrl; b[0] unused). */
void ef_ctrl(double x[EF_N], out dvec2 b[EF_D + 1])
{
    b[0] = dvec2(0.0lf);
#if EF_KIND == 1
    precise double s0 = x[0] / 3.0lf, s1 = -x[1] / 3.0lf;
    b[1] = dvec2(s0 * ef_t0.x, s0 * ef_t0.y);
    b[2] = dvec2(1.0lf + s1 * ef_t1.x, s1 * ef_t1.y);
    b[3] = dvec2(1.0lf, 0.0lf);
#else
    /* f''(0) = x2 t + kappa x1^2 n: the normal part is fixed by the curvature. */
    precise double q0 = ef_k0 * x[0] * x[0], q1 = ef_k1 * x[2] * x[2];
    precise dvec2 dd0 = dvec2(x[1] * ef_t0.x + q0 * ef_n0.x, x[1] * ef_t0.y + q0 * ef_n0.y);
    precise dvec2 dd1 = dvec2(x[3] * ef_t1.x + q1 * ef_n1.x, x[3] * ef_t1.y + q1 * ef_n1.y);
    precise double s0 = x[0] / 5.0lf, s1 = -x[2] / 5.0lf;
    precise dvec2 b1 = dvec2(s0 * ef_t0.x, s0 * ef_t0.y);
    precise dvec2 b4 = dvec2(1.0lf + s1 * ef_t1.x, s1 * ef_t1.y);
    precise dvec2 b2 = b1 + b1;
    precise dvec2 b3 = dvec2(b4.x + b4.x - 1.0lf, b4.y + b4.y);
    b[1] = b1;
    b[2] = dvec2(b2.x + 0.05lf * dd0.x, b2.y + 0.05lf * dd0.y);
    b[3] = dvec2(b3.x + 0.05lf * dd1.x, b3.y + 0.05lf * dd1.y);
    b[4] = b4;
    b[5] = dvec2(1.0lf, 0.0lf);
#endif
}

/*
 * The sparse Jacobian db_k/dx_i of the control points at x (ef_model of ef_ref.c), in the
 * CPU's order of accumulation. jv[0..1] (G1) or jv[0..5] (G2) are the first derivatives, in
 * the order the CPU adds them up (which matters where two reach one DOF); jv[6], jv[7] are the
 * second derivatives d2b2/dx1_0^2 and d2b3/dx1_1^2 (from kappa x1^2 n / 20); no kind has
 * mixed ones.
 *   G1: jv[0] = db1/dx1_0, jv[1] = db2/dx1_1
 *   G2: jv[0] = db1/dx1_0, jv[1] = db2/dx1_0, jv[2] = db2/dx2_0,
 *       jv[3] = db4/dx1_1, jv[4] = db3/dx1_1, jv[5] = db3/dx2_1
 */
void ef_jac(double x[EF_N], out dvec2 jv[8])
{
    for (int e = 0; e < 8; e++)
        jv[e] = dvec2(0.0lf);
#if EF_KIND == 1
    const double third = 0.33333333333333331lf; /* the double nearest 1/3, as 1.0 / 3.0 */
    jv[0] = dvec2(third * ef_t0.x, third * ef_t0.y);
    jv[1] = dvec2(-third * ef_t1.x, -third * ef_t1.y);
#else
    precise double r0 = 0.1lf * ef_k0 * x[0], r1 = 0.1lf * ef_k1 * x[2];
    precise double u0 = 0.1lf * ef_k0, u1 = 0.1lf * ef_k1;
    precise dvec2 j1 = dvec2(0.4lf * ef_t0.x + r0 * ef_n0.x, 0.4lf * ef_t0.y + r0 * ef_n0.y);
    precise dvec2 j4 = dvec2(-0.4lf * ef_t1.x + r1 * ef_n1.x, -0.4lf * ef_t1.y + r1 * ef_n1.y);
    jv[0] = dvec2(0.2lf * ef_t0.x, 0.2lf * ef_t0.y);
    jv[1] = j1;
    jv[2] = dvec2(0.05lf * ef_t0.x, 0.05lf * ef_t0.y);
    jv[3] = dvec2(-0.2lf * ef_t1.x, -0.2lf * ef_t1.y);
    jv[4] = j4;
    jv[5] = dvec2(0.05lf * ef_t1.x, 0.05lf * ef_t1.y);
    jv[6] = dvec2(u0 * ef_n0.x, u0 * ef_n0.y);
    jv[7] = dvec2(u1 * ef_n1.x, u1 * ef_n1.y);
#endif
}

/* f' and f'' at Gauss-Legendre node j: a = sum_k B'_k b_k, c = sum_k B''_k b_k. */
void ef_node_ac(int j, dvec2 b[EF_D + 1], out dvec2 a, out dvec2 c)
{
    precise dvec2 pa = dvec2(EF_A[j * EF_D] * b[1].x, EF_A[j * EF_D] * b[1].y);
    precise dvec2 pc = dvec2(EF_C[j * EF_D] * b[1].x, EF_C[j * EF_D] * b[1].y);
    for (int k = 2; k <= EF_D; k++) {
        const double ak = EF_A[j * EF_D + k - 1], ck = EF_C[j * EF_D + k - 1];
        pa = dvec2(pa.x + ak * b[k].x, pa.y + ak * b[k].y);
        pc = dvec2(pc.x + ck * b[k].x, pc.y + ck * b[k].y);
    }
    a = pa;
    c = pc;
}

/* Node j's share of C^2: w g^2 h with g = a.c, h = a.a. */
void ef_node_val(int j, dvec2 b[EF_D + 1], inout double c2)
{
    dvec2 a, c;
    ef_node_ac(j, b, a, c);
    precise double g = ef_dot(a, c), h = ef_dot(a, a);
    precise double c2n = c2 + EF_W[j] * g * g * h;
    c2 = c2n;
}

/*
 * Node j's share of C^2 and of the gradient (the loop body of ef_eval in ef_ref.c, in its
 * order of operations), and what the Hessian needs besides: a, c, g, h, the derivatives
 * U = 2gh c + 2g^2 a and V = 2gh a of the integrand in a and c, and a_i, c_i, the
 * derivatives of a, c in DOF i through the sparse Jacobian (docs/optimizer.md).
 */
void ef_node_grad_parts(int j, dvec2 b[EF_D + 1], dvec2 jv[8], inout double c2,
                        inout double grad[EF_N], out dvec2 a, out dvec2 c, out double g,
                        out double h, out dvec2 U, out dvec2 V, out dvec2 ai[EF_N],
                        out dvec2 ci[EF_N])
{
    const double w = EF_W[j];
    ef_node_ac(j, b, a, c);
    precise double gv = ef_dot(a, c), hv = ef_dot(a, a);
    g = gv;
    h = hv;
    precise double c2n = c2 + w * gv * gv * hv;
    c2 = c2n;
    precise double gh2 = 2.0lf * gv * hv, gg2 = 2.0lf * gv * gv;
    precise dvec2 pU = dvec2(gh2 * c.x + gg2 * a.x, gh2 * c.y + gg2 * a.y);
    U = pU;
    V = dvec2(gh2 * a.x, gh2 * a.y);
    /* a_i = sum_k B'_k db_k/dx_i, c_i likewise with B''_k (k = 1..d, stored at k - 1). */
    const double A1 = EF_A[j * EF_D], A2 = EF_A[j * EF_D + 1];
    const double C1 = EF_C[j * EF_D], C2 = EF_C[j * EF_D + 1];
#if EF_KIND == 1
    ai[0] = dvec2(A1 * jv[0].x, A1 * jv[0].y);
    ci[0] = dvec2(C1 * jv[0].x, C1 * jv[0].y);
    ai[1] = dvec2(A2 * jv[1].x, A2 * jv[1].y);
    ci[1] = dvec2(C2 * jv[1].x, C2 * jv[1].y);
#else
    const double A3 = EF_A[j * EF_D + 2], A4 = EF_A[j * EF_D + 3];
    const double C3 = EF_C[j * EF_D + 2], C4 = EF_C[j * EF_D + 3];
    precise dvec2 t;
    t = dvec2(A1 * jv[0].x, A1 * jv[0].y);
    ai[0] = dvec2(t.x + A2 * jv[1].x, t.y + A2 * jv[1].y);
    t = dvec2(C1 * jv[0].x, C1 * jv[0].y);
    ci[0] = dvec2(t.x + C2 * jv[1].x, t.y + C2 * jv[1].y);
    ai[1] = dvec2(A2 * jv[2].x, A2 * jv[2].y);
    ci[1] = dvec2(C2 * jv[2].x, C2 * jv[2].y);
    t = dvec2(A4 * jv[3].x, A4 * jv[3].y);
    ai[2] = dvec2(t.x + A3 * jv[4].x, t.y + A3 * jv[4].y);
    t = dvec2(C4 * jv[3].x, C4 * jv[3].y);
    ci[2] = dvec2(t.x + C3 * jv[4].x, t.y + C3 * jv[4].y);
    ai[3] = dvec2(A3 * jv[5].x, A3 * jv[5].y);
    ci[3] = dvec2(C3 * jv[5].x, C3 * jv[5].y);
#endif
    for (int i = 0; i < EF_N; i++) {
        precise double gi = grad[i] + w * (ef_dot(U, ai[i]) + ef_dot(V, ci[i]));
        grad[i] = gi;
    }
}

/* Node j's share of C^2, the gradient and the upper triangle of the Hessian. */
void ef_node_hess(int j, dvec2 b[EF_D + 1], dvec2 jv[8], inout double c2,
                  inout double grad[EF_N], inout double hess[EF_NN])
{
    const double w = EF_W[j];
    dvec2 a, c, U, V, ai[EF_N], ci[EF_N];
    double g, h;
    ef_node_grad_parts(j, b, jv, c2, grad, a, c, g, h, U, V, ai, ci);
    precise double gh2 = 2.0lf * g * h, gg2 = 2.0lf * g * g;
    /* P = phi_aa a_i + phi_ac c_i,  Q = phi_ca a_i + phi_cc c_i. */
    dvec2 P[EF_N], Q[EF_N];
    for (int i = 0; i < EF_N; i++) {
        precise double a_ai = ef_dot(a, ai[i]), c_ai = ef_dot(c, ai[i]);
        precise double a_ci = ef_dot(a, ci[i]);
        precise double sc = 2.0lf * h * (c_ai + a_ci) + 4.0lf * g * a_ai;
        precise double sa = 4.0lf * g * (c_ai + a_ci);
        precise dvec2 p = dvec2(sc * c.x + sa * a.x, sc * c.y + sa * a.y);
        p = dvec2(p.x + gg2 * ai[i].x, p.y + gg2 * ai[i].y);
        P[i] = dvec2(p.x + gh2 * ci[i].x, p.y + gh2 * ci[i].y);
        Q[i] = dvec2(sc * a.x + gh2 * ai[i].x, sc * a.y + gh2 * ai[i].y);
    }
    for (int i = 0; i < EF_N; i++)
        for (int k = 0; k < EF_N; k++)
            if (k >= i) {
                precise double hik =
                    hess[i * EF_N + k] + w * (ef_dot(ai[i], P[k]) + ef_dot(ci[i], Q[k]));
                hess[i * EF_N + k] = hik;
            }
#if EF_KIND == 2
    /* (U.a_ii + V.c_ii) on the diagonal: only b2 depends on x1_0 twice, b3 on x1_1. */
    const double A2 = EF_A[j * EF_D + 1], A3 = EF_A[j * EF_D + 2];
    const double C2 = EF_C[j * EF_D + 1], C3 = EF_C[j * EF_D + 2];
    precise double h00 = hess[0] + w * (A2 * ef_dot(U, jv[6]) + C2 * ef_dot(V, jv[6]));
    hess[0] = h00;
    precise double h22 =
        hess[2 * EF_N + 2] + w * (A3 * ef_dot(U, jv[7]) + C3 * ef_dot(V, jv[7]));
    hess[2 * EF_N + 2] = h22;
#endif
}

/*
 * The Gauss-Legendre nodes one statement each, in the CPU's order, instead of a loop:
 * llvmpipe stops every loop of an invocation after 65535 loop iterations in all (see the
 * top), so only loops whose count depends on the data stay loops. The value (screening
 * grid) and the full evaluation (Newton) have separate node functions, each called from one
 * place: the GLSL front end inlines a whole body at every call before it prunes, and a
 * shared body with flags, called from several places, made the G2 shader three times slower
 * to compile (which matters most under ASan in CI).
 */
#if EF_NQ == 6
#define EF_EACH_NODE(S) S(0) S(1) S(2) S(3) S(4) S(5)
#else
#define EF_EACH_NODE(S) S(0) S(1) S(2) S(3) S(4) S(5) S(6) S(7) S(8) S(9) S(10) S(11)
#endif
#define EF_NODE_VAL(j) ef_node_val(j, b, c2);
#define EF_NODE_HESS(j) ef_node_hess(j, b, jv, c2, grad, hess);

/* C^2 at x (the screening grid). */
double ef_value(double x[EF_N])
{
    dvec2 b[EF_D + 1];
    ef_ctrl(x, b);
    double c2 = 0.0lf;
    EF_EACH_NODE(EF_NODE_VAL)
    return c2;
}

/* C^2, its gradient and its Hessian (row-major EF_N x EF_N) at x. */
double ef_hess(double x[EF_N], out double grad[EF_N], out double hess[EF_NN])
{
    dvec2 b[EF_D + 1], jv[8];
    ef_ctrl(x, b);
    ef_jac(x, jv);
    for (int i = 0; i < EF_N; i++)
        grad[i] = 0.0lf;
    for (int i = 0; i < EF_NN; i++)
        hess[i] = 0.0lf;
    double c2 = 0.0lf;
    EF_EACH_NODE(EF_NODE_HESS)
    for (int i = 0; i < EF_N; i++)
        for (int k = 0; k < EF_N; k++)
            if (k < i)
                hess[i * EF_N + k] = hess[k * EF_N + i];
    return c2;
}

/* Norm of the projected-gradient step x - P(x - g): zero exactly at a KKT point. */
double ef_pg(double x[EF_N], double g[EF_N])
{
    precise double s = 0.0lf;
    for (int i = 0; i < EF_N; i++) {
        precise double r = x[i] - ef_clamp(x[i] - g[i], ef_lo[i], ef_hi[i]);
        s = s + r * r;
    }
    return sqrt(s);
}

/*
 * Eigen-decomposition of the symmetric m x m leading block of ef_ea (row stride EF_N) by
 * cyclic Jacobi rotations, at most EF_JACOBI_SWEEPS sweeps: eigenvalues end on ef_ea's
 * diagonal, eigenvectors in ef_ev's columns (ef_opt_eigen). ef_ea must be zero outside the
 * block: a sweep then visits the fixed pairs of the full EF_N x EF_N (straight-line code)
 * and does exactly the CPU's arithmetic on the block. The zero rows and columns add only
 * exact zeros to the sums, pairs (p, q) reaching outside the block have a[p][q] = 0 and are
 * skipped as the CPU skips zeros, and rotations inside the block keep the outside zero.
 * Globals rather than parameters: nothing is copied per rotation.
 */
double ef_ea[EF_NN], ef_ev[EF_NN];

/* The rotation in the (p, q) plane that zeroes a[p][q] (the smaller angle, for
 * stability), applied to the columns and rows of ef_ea and the columns of ef_ev. */
void ef_rot(int p, int q)
{
    if (ef_ea[p * EF_N + q] == 0.0lf)
        return;
    precise double th =
        (ef_ea[q * EF_N + q] - ef_ea[p * EF_N + p]) / (2.0lf * ef_ea[p * EF_N + q]);
    precise double t = (th >= 0.0lf ? 1.0lf : -1.0lf) / (abs(th) + sqrt(th * th + 1.0lf));
    precise double c = 1.0lf / sqrt(t * t + 1.0lf);
    precise double s = t * c;
    for (int k = 0; k < EF_N; k++) {
        precise double akp = ef_ea[k * EF_N + p], akq = ef_ea[k * EF_N + q];
        precise double np = c * akp - s * akq, nq = s * akp + c * akq;
        ef_ea[k * EF_N + p] = np;
        ef_ea[k * EF_N + q] = nq;
    }
    for (int k = 0; k < EF_N; k++) {
        precise double apk = ef_ea[p * EF_N + k], aqk = ef_ea[q * EF_N + k];
        precise double np = c * apk - s * aqk, nq = s * apk + c * aqk;
        ef_ea[p * EF_N + k] = np;
        ef_ea[q * EF_N + k] = nq;
    }
    for (int k = 0; k < EF_N; k++) {
        precise double vkp = ef_ev[k * EF_N + p], vkq = ef_ev[k * EF_N + q];
        precise double np = c * vkp - s * vkq, nq = s * vkp + c * vkq;
        ef_ev[k * EF_N + p] = np;
        ef_ev[k * EF_N + q] = nq;
    }
}

/* Diagonalize ef_ea in place, eigenvectors into ef_ev (see above). */
void ef_eigen()
{
    for (int i = 0; i < EF_N; i++)
        for (int j = 0; j < EF_N; j++)
            ef_ev[i * EF_N + j] = i == j ? 1.0lf : 0.0lf;
    for (int sweep = 0; sweep < EF_JACOBI_SWEEPS; sweep++) {
        precise double off = 0.0lf, diag = 0.0lf;
        for (int i = 0; i < EF_N; i++) {
            diag = diag + ef_ea[i * EF_N + i] * ef_ea[i * EF_N + i];
            for (int j = 0; j < EF_N; j++)
                if (j > i)
                    off = off + ef_ea[i * EF_N + j] * ef_ea[i * EF_N + j];
        }
        if (!(off > 1e-32lf * diag))
            break;
        /* pairs in the CPU's order: p ascending, then q ascending */
        ef_rot(0, 1);
#if EF_N == 4
        ef_rot(0, 2);
        ef_rot(0, 3);
        ef_rot(1, 2);
        ef_rot(1, 3);
        ef_rot(2, 3);
#endif
    }
}

/*
 * The saddle-free Newton direction at x (steps 2-3 of a CPU iteration): components in the
 * eps-active set (near a bound with the gradient pushing out) move by -g; the free ones
 * along the eigenvectors of their Hessian block, each scaled by 1/|lambda| so that negative
 * curvature is descended, not climbed, and at least EF_NC_STEP along clearly negative
 * curvature, to leave exact saddles.
 */
void ef_direction(double x[EF_N], double g[EF_N], double h[EF_NN], double pg,
                  out double d[EF_N])
{
    const double eps = min(pg, 1e-3lf);
    bool act[EF_N];
    int fi[EF_N];
    int m = 0;
    for (int i = 0; i < EF_N; i++) {
        act[i] = (x[i] <= ef_lo[i] + eps && g[i] > 0.0lf) ||
                 (x[i] >= ef_hi[i] - eps && g[i] < 0.0lf);
        fi[i] = 0;
    }
    for (int i = 0; i < EF_N; i++)
        if (!act[i]) {
            fi[m] = i;
            m++;
        }
    /* fi[0..m-1] lists the free DOFs; their Hessian block, zero-padded, is decomposed. */
    for (int p = 0; p < EF_N; p++)
        for (int q = 0; q < EF_N; q++)
            ef_ea[p * EF_N + q] = p < m && q < m ? h[fi[p] * EF_N + fi[q]] : 0.0lf;
    ef_eigen();
    double lmax = 0.0lf;
    for (int p = 0; p < EF_N; p++)
        if (p < m)
            lmax = max(lmax, abs(ef_ea[p * EF_N + p]));
    for (int i = 0; i < EF_N; i++)
        d[i] = act[i] ? -g[i] : 0.0lf;
    for (int e = 0; e < EF_N; e++)
        if (e < m) {
            const double lam = ef_ea[e * EF_N + e];
            precise double gv = 0.0lf;
            for (int p = 0; p < EF_N; p++)
                if (p < m)
                    gv = gv + ef_ev[p * EF_N + e] * g[fi[p]];
            precise double cc = -gv / max(abs(lam), 1e-8lf * (1.0lf + lmax));
            if (lam < -1e-6lf * (1.0lf + lmax) && abs(cc) < EF_NC_STEP)
                cc = cc < 0.0lf ? -EF_NC_STEP : EF_NC_STEP;
            for (int p = 0; p < EF_N; p++)
                if (p < m) {
                    precise double dn = d[fi[p]] + cc * ef_ev[p * EF_N + e];
                    d[fi[p]] = dn;
                }
        }
}

/* The trial point y = P(x + step d) and the quadratic model's change there,
 * pred = g.dx + dx' H dx / 2 with dx = y - x (negative for descent). */
double ef_trial(double x[EF_N], double g[EF_N], double h[EF_NN], double d[EF_N], double step,
                out double y[EF_N])
{
    precise double dx[EF_N];
    precise double lin = 0.0lf, quad = 0.0lf;
    for (int i = 0; i < EF_N; i++) {
        y[i] = ef_clamp(x[i] + step * d[i], ef_lo[i], ef_hi[i]);
        dx[i] = y[i] - x[i];
        lin = lin + g[i] * dx[i];
    }
    for (int i = 0; i < EF_N; i++)
        for (int j = 0; j < EF_N; j++)
            quad = quad + dx[i] * h[i * EF_N + j] * dx[j];
    precise double pred = lin + 0.5lf * quad;
    return pred;
}

/*
 * Projected saddle-free Newton from x (clamped into the box first); x becomes the end point
 * (ef_opt_local, docs/optimizer.md step 3). Returns C^2 there; conv is true when the start
 * ended stationary: the projected gradient met tol, or the Newton model promised less than
 * the rounding of C^2 and the gradient could not be halved any more.
 *
 * The CPU's two nested loops (iterations, backtracking) are one loop here with one
 * evaluation per pass, of the start point or of a trial point, and that evaluation always
 * includes the Hessian: an accepted trial's Hessian is the next iteration's. One evaluation
 * site keeps the compiled shader small (the front end inlines every call), and the loop
 * count low for llvmpipe. The values are the CPU's: the Hessian call there recomputes the
 * gradient at the same point, with the same bits.
 */
double ef_local(inout double x[EF_N], out bool conv)
{
    double f = 0.0lf, pg = 0.0lf, pred = 0.0lf, step = 1.0lf;
    double g[EF_N], h[EF_NN], d[EF_N], y[EF_N];
    bool first = true, done = false;
    int it = 0, ls = 0;
    conv = false;
    for (int i = 0; i < EF_N; i++) {
        x[i] = ef_clamp(x[i], ef_lo[i], ef_hi[i]);
        y[i] = x[i];
        g[i] = 0.0lf;
        d[i] = 0.0lf;
    }
    for (int i = 0; i < EF_NN; i++)
        h[i] = 0.0lf;
    /* Each pass evaluates y and then either takes it as the current point (the start, or an
     * accepted trial) or halves the step; at most 1 + max_iter * EF_LS_MAX passes. */
    const int max_pass = 1 + ef_max_iter * EF_LS_MAX;
    for (int pass = 0; pass < max_pass && !done; pass++) {
        double gy[EF_N], hy[EF_NN];
        const double fy = ef_hess(y, gy, hy);
        bool take = first;
        if (!first) {
            /* Trial ls of the backtracking (step 4). */
            bool accepted = false, floor_reached = false;
            if (!ef_finite(fy)) {
                /* a shorter step is tried */
            } else if (ls == 0 && abs(pred) <= EF_NOISE * abs(f)) {
                /* Below the rounding of C^2 values cannot judge the step; the gradient
                 * can: take it while it halves the projected gradient, else stop here. */
                precise double lim = f + EF_NOISE * abs(f);
                accepted = fy <= lim && ef_pg(y, gy) < 0.5lf * pg;
                floor_reached = !accepted;
            } else {
                precise double lim = f + 1e-4lf * pred;
                accepted = pred < 0.0lf && fy <= lim;
            }
            if (accepted) {
                take = true;
                it++;
            } else if (floor_reached) {
                conv = true; /* stationary to working precision */
                done = true;
            } else if (ls + 1 >= EF_LS_MAX) {
                done = true; /* no acceptable step: the start ends unconverged */
            } else {
                ls++;
                step *= 0.5lf;
                pred = ef_trial(x, g, h, d, step, y);
            }
        }
        if (take) {
            /* y is the current point: the top of a CPU iteration (steps 1-3). */
            for (int i = 0; i < EF_N; i++) {
                x[i] = y[i];
                g[i] = gy[i];
            }
            for (int i = 0; i < EF_NN; i++)
                h[i] = hy[i];
            f = fy;
            pg = ef_finite(f) ? ef_pg(x, g) : ef_inf();
            first = false;
            if (!(it < ef_max_iter && ef_finite(f))) {
                done = true;
            } else if (pg <= ef_tol * max(1.0lf, f)) {
                conv = true;
                done = true;
            } else {
                ef_direction(x, g, h, pg, d);
                ls = 0;
                step = 1.0lf;
                pred = ef_trial(x, g, h, d, step, y);
            }
        }
    }
    if (it == ef_max_iter && pg <= ef_tol * max(1.0lf, f))
        conv = true;
    return f;
}

/* Nodes per screening-grid axis: G1 8 x 8, G2 (5 x 7)^2 on x1_0, x2_0, x1_1, x2_1. */
int ef_grid_len(int k)
{
#if EF_KIND == 1
    return 8;
#else
    return (k & 1) == 0 ? 5 : 7;
#endif
}

/* Screening-grid node v of axis k, clamped into the box (ef_opt_axis). The first x1 node
 * is 0, i.e. x1_min after clamping. */
double ef_grid_node(int k, int v)
{
#if EF_KIND == 1
    const double x1c[8] = double[](0.0lf, 0.2lf, 0.4lf, 0.7lf, 1.0lf, 1.4lf, 2.0lf, 3.0lf);
    return ef_clamp(x1c[v], ef_lo[k], ef_hi[k]);
#else
    const double x1q[5] = double[](0.0lf, 0.3lf, 0.7lf, 1.2lf, 2.0lf);
    const double x2q[7] = double[](-16.0lf, -6.0lf, -2.0lf, 0.0lf, 2.0lf, 6.0lf, 16.0lf);
    return ef_clamp((k & 1) == 0 ? x1q[v] : x2q[v], ef_lo[k], ef_hi[k]);
#endif
}

/* DOFs of grid point idx (mixed radix, axis 0 fastest), clamped (ef_opt_grid_point). */
void ef_grid_point(int idx, out double x[EF_N])
{
    for (int k = 0; k < EF_N; k++) {
        const int len = ef_grid_len(k);
        x[k] = ef_clamp(ef_grid_node(k, idx % len), ef_lo[k], ef_hi[k]);
        idx /= len;
    }
}

/* Screening-grid values and the grid starts picked from them (globals, so that the large
 * array is never copied into a function's parameters). */
double ef_val[EF_GRID_TOTAL];
int ef_keep[EF_KEEP];
double ef_keepv[EF_KEEP];
int ef_nk;

/* Value of grid point i (+inf where not finite, as the CPU). */
void ef_grid_eval(int i)
{
    double x[EF_N];
    ef_grid_point(i, x);
    const double v = ef_value(x);
    ef_val[i] = ef_finite(v) ? v : ef_inf();
}

/*
 * Grid point i becomes a start candidate when no axis neighbour undercuts it (ties broken by
 * index, so points merged by clamping count once); candidates go into the sorted list of the
 * EF_KEEP lowest (ascending value, earlier index first among equals: ef_opt_grid_starts).
 * The CPU's early exits are replaced by fixed-bound loops with the same outcome: is_min is
 * the AND over all neighbours, and since the list is sorted the CPU's backward scan stops
 * at pos = the number of kept values not above v.
 */
void ef_grid_pick(int i)
{
    const double v = ef_val[i];
    if (isinf(v))
        return;
    bool is_min = true;
    int stride = 1, rest = i;
    for (int k = 0; k < EF_GRID_DIMS; k++) {
        const int len = ef_grid_len(k);
        const int ik = rest % len;
        rest /= len;
        if (ik > 0) {
            const int j = i - stride;
            is_min = is_min && (v < ef_val[j] || (v == ef_val[j] && i < j));
        }
        if (ik + 1 < len) {
            const int j = i + stride;
            is_min = is_min && (v < ef_val[j] || (v == ef_val[j] && i < j));
        }
        stride *= len;
    }
    if (!is_min)
        return;
    const int lim = min(ef_nk, EF_KEEP);
    int pos = 0;
    for (int q = 0; q < EF_KEEP; q++)
        if (q < lim && !(ef_keepv[q] > v))
            pos++;
    if (pos >= EF_KEEP)
        return;
    const int top = min(ef_nk, EF_KEEP - 1);
    for (int q = EF_KEEP - 1; q > 0; q--)
        if (q <= top && q > pos) {
            ef_keep[q] = ef_keep[q - 1];
            ef_keepv[q] = ef_keepv[q - 1];
        }
    ef_keep[pos] = i;
    ef_keepv[pos] = v;
    if (ef_nk < EF_KEEP)
        ef_nk++;
}

/* A row of axis 0, for the candidates' loop: fewer loop passes for llvmpipe's count. (The
 * values' loop stays one point per pass: a value is more code, and compile time counts.) */
#if EF_KIND == 1
#define EF_GRID_ROW(F, r) F(r); F(r + 1); F(r + 2); F(r + 3); F(r + 4); F(r + 5); F(r + 6); F(r + 7)
#define EF_GRID_AXIS0 8
#else
#define EF_GRID_ROW(F, r) F(r); F(r + 1); F(r + 2); F(r + 3); F(r + 4)
#define EF_GRID_AXIS0 5
#endif

/*
 * Start number k, in the CPU's order: the fixed starts (x1 in {0.3, 1, 2} at each end,
 * times x2 in {-2, 0, 2} at each end for G2), the 7 starts with an x1 on its lower bound,
 * then the grid points ef_keep[] (ef_opt_fixed_starts, ef_opt_grid_starts).
 */
void ef_start(int k, out double x[EF_N])
{
    const double x1s[3] = double[](0.3lf, 1.0lf, 2.0lf);
    for (int i = 0; i < EF_N; i++)
        x[i] = 0.0lf;
    if (k < EF_NFIX) {
#if EF_KIND == 1
        x[0] = x1s[k / 3];
        x[1] = x1s[k % 3];
#else
        const double x2s[3] = double[](-2.0lf, 0.0lf, 2.0lf);
        x[0] = x1s[k / 27];
        x[1] = x2s[(k / 3) % 3];
        x[2] = x1s[(k / 9) % 3];
        x[3] = x2s[k % 3];
#endif
    } else if (k < EF_NFIX + 7) {
        /* (b, 0.3), (b, 1), (b, 2), (0.3, b), (1, b), (2, b), (b, b) for (x1_0, x1_1) */
        const int q = k - EF_NFIX;
        x[0] = q < 3 || q == 6 ? ef_lo[0] : x1s[q - 3];
        x[EF_I1] = q >= 3 ? ef_lo[EF_I1] : x1s[q];
    } else {
        ef_grid_point(ef_keep[k - EF_NFIX - 7], x);
    }
}

void main()
{
    const uint id = gl_GlobalInvocationID.x;
    if (id >= ef_count)
        return;
    const uint ci = id * uint(EF_CFG_STRIDE), ri = id * uint(EF_RES_STRIDE);
    ef_t0 = dvec2(ef_cfg[ci + 4u], ef_cfg[ci + 5u]);
    ef_t1 = dvec2(ef_cfg[ci + 6u], ef_cfg[ci + 7u]);
    ef_n0 = dvec2(-ef_t0.y, ef_t0.x);
    ef_n1 = dvec2(-ef_t1.y, ef_t1.x);
#if EF_KIND == 2
    ef_k0 = ef_cfg[ci + 2u];
    ef_k1 = ef_cfg[ci + 3u];
#else
    ef_k0 = 0.0lf;
    ef_k1 = 0.0lf;
#endif
    for (int i = 0; i < EF_N; i++) {
        ef_lo[i] = -ef_x2_max;
        ef_hi[i] = ef_x2_max;
    }
    ef_lo[0] = ef_x1_min;
    ef_hi[0] = ef_x1_max;
    ef_lo[EF_I1] = ef_x1_min;
    ef_hi[EF_I1] = ef_x1_max;

    /* Screening grid: all values, then the candidates in index order. */
    for (int i = 0; i < EF_GRID_TOTAL; i++)
        ef_grid_eval(i);
    for (int q = 0; q < EF_KEEP; q++) {
        ef_keep[q] = 0;
        ef_keepv[q] = 0.0lf;
    }
    ef_nk = 0;
    for (int r = 0; r < EF_GRID_TOTAL; r += EF_GRID_AXIS0) {
        EF_GRID_ROW(ef_grid_pick, r);
    }

    /* Every start runs to its end; the lowest C^2 wins, and within 1e-9 relative of the
     * best so far a converged start beats an unconverged one, then the lower value, then
     * the earlier start (the CPU's rule; its bestf = inf start is have_best = false).
     * The loop runs once more than there are starts: reaching that last pass proves that
     * no loop was cut short (llvmpipe's limit, see the top). */
    const int ns = EF_NFIX + 7 + ef_nk;
    double best[EF_N];
    for (int i = 0; i < EF_N; i++)
        best[i] = 0.0lf;
    double bestf = 0.0lf;
    bool have_best = false, bestconv = false, complete = false;
    for (int k = 0; k <= ns; k++) {
        if (k == ns) {
            complete = true;
        } else {
            double x[EF_N];
            bool conv;
            ef_start(k, x);
            const double f = ef_local(x, conv);
            precise double tie = 1e-9lf * bestf;
            precise double lo_t = bestf - tie, hi_t = bestf + tie;
            const int ic = conv ? 1 : 0, ib = bestconv ? 1 : 0;
            if (ef_finite(f) &&
                (!have_best || f < lo_t || (f <= hi_t && (ic > ib || (ic == ib && f < bestf))))) {
                have_best = true;
                bestf = f;
                bestconv = conv;
                for (int i = 0; i < EF_N; i++)
                    best[i] = x[i];
            }
        }
    }

    /* at_bound: bit i when DOF i is within 1e-9 of its box width of a bound. */
    uint at_bound = 0u;
    for (int i = 0; i < EF_N; i++) {
        precise double tolb = 1e-9lf * (ef_hi[i] - ef_lo[i]);
        precise double lt = ef_lo[i] + tolb, ht = ef_hi[i] - tolb;
        if (have_best && (best[i] <= lt || best[i] >= ht))
            at_bound |= 1u << uint(i);
    }
    /* The chord is 1, so the DOFs need no scaling back and the CPU's recomputed C is the
     * square root of the same C^2 of the same control points. */
    const bool ok = complete && have_best;
    ef_res[ri + 0u] = ok ? best[0] : 0.0lf;
    ef_res[ri + 1u] = ok ? best[1] : 0.0lf;
#if EF_KIND == 1
    ef_res[ri + 2u] = 0.0lf;
    ef_res[ri + 3u] = 0.0lf;
#else
    ef_res[ri + 2u] = ok ? best[2] : 0.0lf;
    ef_res[ri + 3u] = ok ? best[3] : 0.0lf;
#endif
    ef_res[ri + 4u] = ok ? sqrt(bestf) : ef_nan();
    ef_res[ri + 5u] = ok && bestconv ? 1.0lf : 0.0lf;
    ef_res[ri + 6u] = ok ? double(at_bound) : 0.0lf;
    ef_res[ri + 7u] = complete ? double(ns) : -1.0lf;
}
