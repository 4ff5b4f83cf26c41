/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed segment: one G1 cubic / G2 quintic (or optimized G1 quartic) segment. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"
#include "evenfeed/geom/ef_bezier.h"
#include "evenfeed/seg/ef_seg.h"
#include "evenfeed/host/tables/ef_ref.h"
#include "evenfeed/host/tables/ef_tfile.h"

static const char usage[] =
    "usage: evenfeed segment (--g1 | --g2 | --quartic) END-DATA [--optimize] [--table FILE] "
    "[--json]\n"
    "\n"
    "END-DATA is either the normalized configuration from (0,0) to (1,0):\n"
    "  --alpha A --beta B            tangent angles to the chord (radians)\n"
    "  --k0 K0 --k1 K1               signed curvatures x chord (G2; default 0)\n"
    "or explicit end data, 2-D (x,y) or 3-D (x,y,z), in program units:\n"
    "  --p0 P --t0 T --p1 P --t1 T   positions and unit tangents\n"
    "  --n0 N --n1 N --k0 K --k1 K   unit normals and curvatures (G2; in 2-D the normal\n"
    "                                defaults to the tangent turned +90 degrees, K signed)\n"
    "\n"
    "  --optimize    the CPU reference optimum instead of the table lookup\n"
    "  --quartic     G1 quartic with a free inner control point (needs --optimize)\n"
    "  --table FILE  a table file instead of the built-in table\n"
    "  --json        one JSON object: kind, source, dim, config, dofs, control_points, C\n";

typedef struct {
    int kind;       /* EF_REF_* */
    int normalized; /* --alpha/--beta form */
    int dim;        /* 2 or 3 */
    ef_dend_t e0, e1;
    double cfg[4]; /* alpha, beta, k0, k1 as given (normalized form) */
} cseg_args_t;

/* Parse "x,y" or "x,y,z" into v and its component count into *dim. */
static int cseg_vec(const char *opt, const char *s, ef_dvec3_t *v, int *dim)
{
    char buf[256], *item[3];
    double c[3] = {0, 0, 0};
    int n = cli_split(s, ',', buf, sizeof buf, item, 3);
    if (n < 2 || n > 3)
        return cli_error(EF_ERR_ARG, "segment: %s: '%s' is not a 2-D (x,y) or 3-D (x,y,z) vector",
                         opt, s);
    for (int k = 0; k < n; k++)
        if (cli_parse_double(item[k], &c[k]) != EF_OK)
            return cli_error(EF_ERR_ARG, "segment: %s: '%s' is not a finite number", opt, item[k]);
    *v = (ef_dvec3_t){c[0], c[1], c[2]};
    *dim = n;
    return EF_OK;
}

/* Read options into a: EF_OK, CLI_HELP (usage printed) or an error (printed). */
static int cseg_parse(int argc, char **argv, cseg_args_t *a, int *optimize, int *json,
                      const char **table_path)
{
    enum {
        O_G1 = CLI_LONG,
        O_G2,
        O_QUARTIC,
        O_ALPHA,
        O_BETA,
        O_K0,
        O_K1,
        O_P0,
        O_T0,
        O_N0,
        O_P1,
        O_T1,
        O_N1,
        O_OPT,
        O_TABLE,
        O_JSON
    };
    static const struct option opts[] = {{"g1", no_argument, 0, O_G1},
                                         {"g2", no_argument, 0, O_G2},
                                         {"quartic", no_argument, 0, O_QUARTIC},
                                         {"alpha", required_argument, 0, O_ALPHA},
                                         {"beta", required_argument, 0, O_BETA},
                                         {"k0", required_argument, 0, O_K0},
                                         {"k1", required_argument, 0, O_K1},
                                         {"p0", required_argument, 0, O_P0},
                                         {"t0", required_argument, 0, O_T0},
                                         {"n0", required_argument, 0, O_N0},
                                         {"p1", required_argument, 0, O_P1},
                                         {"t1", required_argument, 0, O_T1},
                                         {"n1", required_argument, 0, O_N1},
                                         {"optimize", no_argument, 0, O_OPT},
                                         {"table", required_argument, 0, O_TABLE},
                                         {"json", no_argument, 0, O_JSON},
                                         CLI_OPT_HELP,
                                         CLI_OPT_END};
    unsigned seen = 0; /* bit per option id - O_G1 */
    int dims[6] = {0}, c;
    memset(a, 0, sizeof *a);
    cli_getopt_t g;
    cli_getopt_init(&g, "segment", usage, argc, argv, "", opts);
    while ((c = cli_getopt(&g)) > CLI_END) {
        if (c == CLI_HELP)
            return CLI_HELP;
        if (c == CLI_ARG)
            return cli_error(EF_ERR_ARG, "segment: unexpected argument '%s'", g.val);
        if (seen & (1u << (c - O_G1)))
            return cli_error(EF_ERR_ARG, "segment: option given twice: '%s'", g.opt);
        seen |= 1u << (c - O_G1);
        int rc = EF_OK;
        switch (c) {
        case O_G1:
            a->kind = a->kind ? -1 : EF_REF_G1_CUBIC;
            break;
        case O_G2:
            a->kind = a->kind ? -1 : EF_REF_G2_QUINTIC;
            break;
        case O_QUARTIC:
            a->kind = a->kind ? -1 : EF_REF_G1_QUARTIC;
            break;
        case O_ALPHA:
            rc = cli_opt_double(&g, &a->cfg[0]);
            break;
        case O_BETA:
            rc = cli_opt_double(&g, &a->cfg[1]);
            break;
        case O_K0:
            rc = cli_opt_double(&g, &a->cfg[2]);
            break;
        case O_K1:
            rc = cli_opt_double(&g, &a->cfg[3]);
            break;
        case O_P0:
            rc = cseg_vec(g.opt, g.val, &a->e0.p, &dims[0]);
            break;
        case O_T0:
            rc = cseg_vec(g.opt, g.val, &a->e0.t, &dims[1]);
            break;
        case O_N0:
            rc = cseg_vec(g.opt, g.val, &a->e0.n, &dims[2]);
            break;
        case O_P1:
            rc = cseg_vec(g.opt, g.val, &a->e1.p, &dims[3]);
            break;
        case O_T1:
            rc = cseg_vec(g.opt, g.val, &a->e1.t, &dims[4]);
            break;
        case O_N1:
            rc = cseg_vec(g.opt, g.val, &a->e1.n, &dims[5]);
            break;
        case O_OPT:
            *optimize = 1;
            break;
        case O_TABLE:
            *table_path = g.val;
            break;
        case O_JSON:
            *json = 1;
            break;
        }
        if (rc != EF_OK)
            return rc;
    }
    if (c < 0)
        return c;
#define HAS(o) (seen & (1u << ((o)-O_G1)))
    if (a->kind <= 0)
        return cli_error(EF_ERR_ARG, "segment: give exactly one of --g1, --g2, --quartic");
    int g2 = a->kind == EF_REF_G2_QUINTIC;
    if (!g2 && (HAS(O_K0) || HAS(O_K1) || HAS(O_N0) || HAS(O_N1)))
        return cli_error(EF_ERR_ARG,
                         "segment: curvature and normals (--k0 --k1 --n0 --n1) need --g2");
    if (a->kind == EF_REF_G1_QUARTIC && !*optimize)
        return cli_error(EF_ERR_ARG, "segment: --quartic has no table; add --optimize");
    if (*optimize && *table_path)
        return cli_error(EF_ERR_ARG, "segment: --table and --optimize exclude each other");
    int norm_form = HAS(O_ALPHA) || HAS(O_BETA);
    int expl_form = HAS(O_P0) || HAS(O_T0) || HAS(O_P1) || HAS(O_T1) || HAS(O_N0) || HAS(O_N1);
    if (norm_form && expl_form)
        return cli_error(EF_ERR_ARG,
                         "segment: give either --alpha/--beta or --p0/--t0/--p1/--t1, not both");
    if (norm_form) {
        if (!HAS(O_ALPHA) || !HAS(O_BETA))
            return cli_error(EF_ERR_ARG,
                             "segment: the normalized form needs both --alpha and --beta");
        a->normalized = 1;
        a->dim = 2;
        ef_ref_config(a->cfg[0], a->cfg[1], a->cfg[2], a->cfg[3], &a->e0, &a->e1);
        return EF_OK;
    }
    if (!HAS(O_P0) || !HAS(O_T0) || !HAS(O_P1) || !HAS(O_T1))
        return cli_error(EF_ERR_ARG, "segment: give --alpha/--beta, or all of --p0 --t0 --p1 --t1");
    a->dim = dims[0];
    for (int i = 0; i < 6; i++)
        if (dims[i] && dims[i] != a->dim)
            return cli_error(EF_ERR_ARG, "segment: mix of 2-D and 3-D vectors");
    a->e0.kappa = a->cfg[2];
    a->e1.kappa = a->cfg[3];
    if (a->dim == 2) { /* planar: normal = tangent turned +90 degrees unless given */
        double l0 = hypot(a->e0.t.x, a->e0.t.y), l1 = hypot(a->e1.t.x, a->e1.t.y);
        if (!HAS(O_N0) && l0 > 0)
            a->e0.n = (ef_dvec3_t){-a->e0.t.y / l0, a->e0.t.x / l0, 0};
        if (!HAS(O_N1) && l1 > 0)
            a->e1.n = (ef_dvec3_t){-a->e1.t.y / l1, a->e1.t.x / l1, 0};
    }
    return EF_OK;
#undef HAS
}

/* Print the result in the chosen format. */
static void cseg_print(const cseg_args_t *a, const char *source, const double *dof, int ndof,
                       const ef_dvec3_t *b, int degree, double C, uint32_t clamp,
                       const ef_norm_t *nm, int json)
{
    ef_endpoint_t f0 = ef_ref_end_to_fw(&a->e0), f1 = ef_ref_end_to_fw(&a->e1);
    float twist = ef_norm_twist(nm, &f0, &f1);
    static const char *names_g1[] = {"x1_0", "x1_1"};
    static const char *names_g2[] = {"x1_0", "x2_0", "x1_1", "x2_1"};
    static const char *names_q[] = {"x1_0", "x1_1", "b2_x", "b2_y", "b2_z"};
    const char **names = a->kind == EF_REF_G2_QUINTIC   ? names_g2
                         : a->kind == EF_REF_G1_QUARTIC ? names_q
                                                        : names_g1;
    const char *kname = a->kind == EF_REF_G2_QUINTIC   ? "g2_quintic"
                        : a->kind == EF_REF_G1_QUARTIC ? "g1_quartic"
                                                       : "g1_cubic";
    static const char *cl_names[] = {"alpha", "beta", "k0", "k1"};
    if (json) {
        printf("{\"kind\": \"%s\", \"source\": \"%s\", \"dim\": %d, \"degree\": %d,\n", kname,
               source, a->dim, degree);
        printf(" \"config\": {\"alpha\": ");
        cli_json_num(stdout, nm->alpha);
        printf(", \"beta\": ");
        cli_json_num(stdout, nm->beta);
        printf(", \"k0\": ");
        cli_json_num(stdout, nm->k0);
        printf(", \"k1\": ");
        cli_json_num(stdout, nm->k1);
        printf(", \"chord\": ");
        cli_json_num(stdout, nm->chord);
        printf(", \"twist\": ");
        cli_json_num(stdout, twist);
        printf("},\n \"dof_names\": [");
        for (int k = 0; k < ndof; k++)
            printf("%s\"%s\"", k ? ", " : "", names[k]);
        printf("],\n \"dofs\": [");
        for (int k = 0; k < ndof; k++) {
            printf(k ? ", " : "");
            cli_json_num(stdout, dof[k]);
        }
        printf("],\n \"control_points\": [");
        for (int i = 0; i <= degree; i++) {
            printf("%s[", i ? ", " : "");
            cli_json_num(stdout, b[i].x);
            printf(", ");
            cli_json_num(stdout, b[i].y);
            if (a->dim == 3) {
                printf(", ");
                cli_json_num(stdout, b[i].z);
            }
            printf("]");
        }
        printf("],\n \"C\": ");
        cli_json_num(stdout, C);
        printf(",\n \"clamped\": [");
        for (int i = 0, first = 1; i < 4; i++)
            if (clamp & (1u << i)) {
                printf("%s\"%s\"", first ? "" : ", ", cl_names[i]);
                first = 0;
            }
        printf("]}\n");
        return;
    }
    printf("%s segment (%s)\n", kname, source);
    printf("  configuration: alpha %.6f  beta %.6f", nm->alpha, nm->beta);
    if (a->kind == EF_REF_G2_QUINTIC)
        printf("  k0 %.6f  k1 %.6f", nm->k0, nm->k1);
    printf("  chord %.6g", nm->chord);
    if (a->dim == 3)
        printf("  twist %.4f rad", twist);
    printf("\n  dofs:");
    for (int k = 0; k < ndof; k++)
        printf("  %s = %.6f", names[k], dof[k]);
    printf("\n  C = %.6f\n  control points:\n", C);
    for (int i = 0; i <= degree; i++) {
        if (a->dim == 3)
            printf("    (%.9g, %.9g, %.9g)\n", b[i].x, b[i].y, b[i].z);
        else
            printf("    (%.9g, %.9g)\n", b[i].x, b[i].y);
    }
    if (clamp) {
        printf("  warning: configuration outside the table domain (clamped:");
        for (int i = 0; i < 4; i++)
            if (clamp & (1u << i))
                printf(" %s", cl_names[i]);
        printf("); the segment meets the end data exactly but is not the optimum\n");
    }
}

/* evenfeed segment ... */
int cli_cmd_segment(int argc, char **argv)
{
    cseg_args_t a;
    int optimize = 0, json = 0;
    const char *table_path = NULL;
    int rc = cseg_parse(argc, argv, &a, &optimize, &json, &table_path);
    if (rc != EF_OK)
        return rc == CLI_HELP ? EF_OK : rc;
    int g2 = a.kind == EF_REF_G2_QUINTIC;
    /* One validation for both paths: the firmware's, on the data a drive would get. */
    ef_endpoint_t f0 = ef_ref_end_to_fw(&a.e0), f1 = ef_ref_end_to_fw(&a.e1);
    ef_norm_t nm;
    rc = ef_normalize(&f0, &f1, g2, &nm);
    if (rc != EF_OK)
        return cli_error(rc, "segment: %s", ef_err_str(rc));

    ef_dvec3_t b[EF_REF_MAX_DEGREE + 1];
    if (optimize) {
        ef_ref_result_t r;
        ef_msg_t m = {{0}};
        rc = ef_ref_optimize((ef_ref_kind_t)a.kind, &a.e0, &a.e1, NULL, &r, &m);
        if (rc != EF_OK)
            return cli_error(rc, "segment: %s", m.text);
        ef_ref_ctrl((ef_ref_kind_t)a.kind, &a.e0, &a.e1, r.dof, b);
        int degree = ef_ref_degree((ef_ref_kind_t)a.kind);
        cseg_print(&a, "optimize", r.dof, r.ndof, b, degree, ef_ref_functional(b, degree), 0, &nm,
                   json);
        return EF_OK;
    }
    int tkind = g2 ? EF_TABLE_G2_QUINTIC : EF_TABLE_G1_CUBIC;
    ef_tfile_t tf;
    memset(&tf, 0, sizeof tf);
    const ef_table_t *tbl = cli_default_table(tkind);
    if (table_path) {
        ef_msg_t m = {{0}};
        rc = ef_tfile_load(table_path, &tf, &m);
        if (rc != EF_OK)
            return cli_error(rc, "%s", m.text);
        tbl = &tf.view;
    }
    if (!tbl)
        return cli_error(
            EF_ERR_ARG,
            "segment: this build has no built-in table; use --table FILE or --optimize");
    ef_seg_t seg;
    rc = g2 ? ef_seg_g2_quintic(tbl, &f0, &f1, &seg) : ef_seg_g1_cubic(tbl, &f0, &f1, &seg);
    if (rc != EF_OK) {
        ef_tfile_free(&tf);
        return cli_error(rc, "segment: %s%s", ef_err_str(rc),
                         rc == EF_ERR_KIND ? " (table kind does not match --g1/--g2)" : "");
    }
    double dof[4];
    for (int k = 0; k < seg.ndof; k++)
        dof[k] = seg.dof[k];
    for (int i = 0; i <= seg.degree; i++)
        b[i] = (ef_dvec3_t){seg.b[i].x, seg.b[i].y, seg.b[i].z};
    cseg_print(&a, table_path ? "table file" : "built-in table", dof, seg.ndof, b, seg.degree,
               ef_ref_functional(b, seg.degree), seg.clamp, &seg.norm, json);
    ef_tfile_free(&tf);
    return EF_OK;
}
