/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Agreement of the compute-shader optimizer (gpu_offline/shaders/ef_opt.comp, run through
 * ef_gl.h) with the CPU reference ef_ref_optimize on a deterministic sample of normalized
 * configurations. On CI this runs on llvmpipe; with no headless GL at all it is skipped
 * (exit 77), saying why.
 *
 * Criteria (docs/optimizer.md, "GPU port"): C within 1e-4 relative everywhere. Unless the
 * two picked different optima whose C^2 tie within 1e-9 (the CPU's own tie window: either
 * is "the" optimum): the same at-bound bits, and DOFs within 1e-3 relative where no DOF is
 * on a bound. Converged flags differ in at most 5 % of configurations. No configuration is
 * handed back to the CPU (that would hide a shader fault behind the fallback). The shader
 * does the CPU's arithmetic in the CPU's order, so on llvmpipe the results are in fact
 * bit-identical; the test prints how many, but does not require it of other drivers.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "ef_test.h"
#include "evenfeed/gpu/ef_gl.h"

#define N_G1  200 /* full circle, plus the fixed cases below */
#define N_G2  40  /* alpha, beta in [-pi/2, pi/2], kappa in [-2, 2] (the default G2 table) */
#define MAX_N (N_G1 + 8)

/* Outcome counts of one comparison run. */
typedef struct {
    int n, bit_identical, dof_checked, ties, conv_diff, starts_diff;
    double max_rel_c, max_rel_dof;
} stats_t;

/* C^2 of the CPU objective at normalized DOFs (to recognize ties between distinct optima). */
static double objective(ef_ref_kind_t kind, const double *cfg, const double *dof)
{
    ef_dend_t e0, e1;
    ef_ref_config(cfg[0], cfg[1], cfg[2], cfg[3], &e0, &e1);
    return ef_ref_objective(kind, &e0, &e1, dof, NULL);
}

/*
 * Solve cfg[n][4] on the GPU in one dispatch and on the CPU one by one, and check the
 * agreement criteria of the file comment. o may be NULL (defaults).
 */
static void compare(ef_gl_t *gl, int kind, const double *cfg, int n, const ef_ref_opts_t *o,
                    const char *label, stats_t *st)
{
    static double res[MAX_N * EF_GL_RES_STRIDE];
    const ef_ref_kind_t rk = kind == EF_TABLE_G1_CUBIC ? EF_REF_G1_CUBIC : EF_REF_G2_QUINTIC;
    const int nd = ef_ref_ndof(rk);
    ef_msg_t m = {{0}};
    memset(st, 0, sizeof *st);
    st->n = n;
    const uint64_t fb0 = ef_gl_fallbacks(gl);
    const int rc = ef_gl_solve(gl, kind, cfg, (uint32_t)n, o, res, &m);
    EF_CHECK_EQ(rc, EF_OK);
    if (rc != EF_OK) {
        fprintf(stderr, "%s: ef_gl_solve: %s\n", label, m.text);
        return;
    }
    /* A fallback would mean llvmpipe's loop limit was reached: the shader's margin is gone. */
    EF_CHECK_EQ(ef_gl_fallbacks(gl) - fb0, 0);

    for (int i = 0; i < n; i++) {
        const double *c = cfg + 4 * i, *g = res + EF_GL_RES_STRIDE * i;
        ef_dend_t e0, e1;
        ef_ref_config(c[0], c[1], c[2], c[3], &e0, &e1);
        ef_ref_result_t r;
        if (ef_ref_optimize(rk, &e0, &e1, o, &r, &m) != EF_OK) {
            EF_CHECK(0);
            fprintf(stderr, "%s %d: CPU reference failed: %s\n", label, i, m.text);
            continue;
        }
        /* The CPU's result is in program units; at unit chord they are per unit chord. */
        int same = g[4] == r.C && (int)g[5] == r.converged && (unsigned)g[6] == r.at_bound &&
                   (int)g[7] == r.starts;
        for (int k = 0; k < nd; k++)
            same = same && g[k] == r.dof[k];
        st->bit_identical += same;
        st->conv_diff += (int)g[5] != r.converged;
        st->starts_diff += (int)g[7] != r.starts;

        const double dc = fabs(g[4] - r.C);
        const double rel_c = dc / fmax(r.C, 1e-300);
        if (r.C > 1e-12)
            st->max_rel_c = fmax(st->max_rel_c, rel_c);
        if (!(dc <= 1e-4 * r.C + 1e-12)) { /* the straight line has C = 0 */
            EF_CHECK(0);
            fprintf(stderr, "%s %d (%.17g, %.17g, %.17g, %.17g): C gpu %.17g cpu %.17g\n", label, i,
                    c[0], c[1], c[2], c[3], g[4], r.C);
        }

        double rel_dof = 0.0;
        for (int k = 0; k < nd; k++)
            rel_dof = fmax(rel_dof, fabs(g[k] - r.dof[k]) / fmax(fabs(r.dof[k]), 1e-12));
        if (rel_dof > 1e-3) {
            const double fg = objective(rk, c, g), fc = r.C * r.C;
            if (fabs(fg - fc) <= 1e-9 * fc + 1e-300) {
                st->ties++; /* two optima, equally good: either is right */
                continue;
            }
        }
        EF_CHECK_EQ((unsigned)g[6], r.at_bound);
        if (r.at_bound != 0)
            continue; /* an optimum on a bound is flat along it: only C is compared */
        st->dof_checked++;
        st->max_rel_dof = fmax(st->max_rel_dof, rel_dof);
        if (!(rel_dof <= 1e-3)) {
            EF_CHECK(0);
            fprintf(stderr,
                    "%s %d (%.17g, %.17g, %.17g, %.17g): DOFs gpu %.10g %.10g %.10g "
                    "%.10g, cpu %.10g %.10g %.10g %.10g (C %.10g / %.10g)\n",
                    label, i, c[0], c[1], c[2], c[3], g[0], g[1], g[2], g[3], r.dof[0], r.dof[1],
                    nd > 2 ? r.dof[2] : 0.0, nd > 3 ? r.dof[3] : 0.0, g[4], r.C);
        }
    }
    printf("%-22s %3d configs: bit-identical %3d; max rel. diff C %.2g, DOFs %.2g (%d compared, "
           "%d ties); converged flag differs %d, starts differ %d\n",
           label, st->n, st->bit_identical, st->max_rel_c, st->max_rel_dof, st->dof_checked,
           st->ties, st->conv_diff, st->starts_diff);
    /* Rounding may flip a borderline stopping decision on a driver that is not bit-identical,
     * but not often: a wrong Hessian shows up here first (it changes convergence, not the
     * optimum). */
    EF_CHECK(st->conv_diff * 20 <= n);
}

/* The whole comparison, in one GL context. */
static void test_agree(void)
{
    ef_gl_t *gl = NULL;
    ef_msg_t m = {{0}};
    if (ef_gl_open(&gl, NULL, &m) != EF_OK) {
        char why[sizeof m.text + 64];
        snprintf(why, sizeof why, "no headless OpenGL 4.3 context with fp64 here: %s", m.text);
        ef_test_skip(why); /* exit 77, ctest's skip code (SKIP_RETURN_CODE in gl.cmake) */
        return;
    }
    printf("platform %s, renderer %s\n", ef_gl_platform(gl), ef_gl_renderer(gl));

    static double cfg[MAX_N * 4];
    unsigned long long seed = 20240611;
    stats_t st;

    /* G1 cubic over the full circle, after fixed cases: the published optimum, the straight
     * line (C = 0), a node where the best basin sits on the x1 bound next to a close
     * interior one, a symmetric arc, and tangents pointing backwards (both x1 on the
     * bound). */
    static const double fixed_g1[][2] = {{M_PI / 2, -M_PI / 2}, {0.0, 0.0},   {2.1271, -1.1454},
                                         {0.6, -0.6},           {M_PI, M_PI}, {-3.0, 2.5}};
    const int nf = (int)(sizeof fixed_g1 / sizeof fixed_g1[0]);
    for (int i = 0; i < N_G1 + nf; i++) {
        double *c = cfg + 4 * i;
        c[0] = i < nf ? fixed_g1[i][0] : ef_t_uniform(&seed, -M_PI, M_PI);
        c[1] = i < nf ? fixed_g1[i][1] : ef_t_uniform(&seed, -M_PI, M_PI);
        c[2] = c[3] = 0.0;
    }
    compare(gl, EF_TABLE_G1_CUBIC, cfg, N_G1 + nf, NULL, "G1 cubic", &st);
    EF_CHECK(st.dof_checked >= N_G1 / 10);

    /* The published optimum, from the GPU (docs/optimizer.md, Verification). */
    {
        static double res[EF_GL_RES_STRIDE];
        const double c[4] = {M_PI / 2, -M_PI / 2, 0.0, 0.0};
        EF_CHECK_EQ(ef_gl_solve(gl, EF_TABLE_G1_CUBIC, c, 1, NULL, res, &m), EF_OK);
        EF_CHECK_NEAR(res[4], 1.788277849, 1e-9);
        EF_CHECK_NEAR(res[0], 1.288175515, 1e-8);
        EF_CHECK_NEAR(res[1], 1.288175515, 1e-8);
        EF_CHECK_EQ((int)res[5], 1);
        EF_CHECK(res[7] >= 9 + 7 && res[7] <= 9 + 7 + 8); /* fixed, on the bound, grid */
    }

    /* Settings other than the defaults reach the shader (uniforms): a narrower x1 box and
     * few iterations, so some starts end unconverged. */
    {
        ef_ref_opts_t o;
        ef_ref_opts_default(&o);
        o.x1_min = 0.25;
        o.x1_max = 3.0;
        o.max_iter = 4;
        o.tol = 1e-10;
        compare(gl, EF_TABLE_G1_CUBIC, cfg, 60, &o, "G1 cubic, other box", &st);
    }

    /* G2 quintic over the default table's domain, after the straight line. */
    for (int i = 0; i < N_G2; i++) {
        double *c = cfg + 4 * i;
        c[0] = i == 0 ? 0.0 : ef_t_uniform(&seed, -M_PI / 2, M_PI / 2);
        c[1] = i == 0 ? 0.0 : ef_t_uniform(&seed, -M_PI / 2, M_PI / 2);
        c[2] = i == 0 ? 0.0 : ef_t_uniform(&seed, -2.0, 2.0);
        c[3] = i == 0 ? 0.0 : ef_t_uniform(&seed, -2.0, 2.0);
    }
    compare(gl, EF_TABLE_G2_QUINTIC, cfg, N_G2, NULL, "G2 quintic", &st);
    EF_CHECK(st.dof_checked >= N_G2 / 10);
    {
        ef_ref_opts_t o;
        ef_ref_opts_default(&o);
        o.x2_max = 8.0; /* the x2 bound becomes active for some */
        o.max_iter = 30;
        compare(gl, EF_TABLE_G2_QUINTIC, cfg, 12, &o, "G2 quintic, other box", &st);
    }

    /* A repeated dispatch in the same context gives the same bits. */
    {
        static double r1[16 * EF_GL_RES_STRIDE], r2[16 * EF_GL_RES_STRIDE];
        EF_CHECK_EQ(ef_gl_solve(gl, EF_TABLE_G2_QUINTIC, cfg, 16, NULL, r1, &m), EF_OK);
        EF_CHECK_EQ(ef_gl_solve(gl, EF_TABLE_G2_QUINTIC, cfg, 16, NULL, r2, &m), EF_OK);
        EF_CHECK(memcmp(r1, r2, sizeof r1) == 0);
    }

    ef_gl_close(gl);
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {{"agree", test_agree}};
    return EF_TEST_RUN(argc, argv, 1, parts);
}
