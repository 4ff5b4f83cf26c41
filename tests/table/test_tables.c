/* SPDX-License-Identifier: Apache-2.0 */
/* The shipped default tables: the linked C data equals the .eft files bit for bit, sampled
 * nodes are recomputed by the reference optimizer and agree, the chain end data -> table ->
 * segment reproduces the published reference, and the accuracy harness stays above a floor.
 * Usage: test_tables SOURCE_DIR */
#include <string.h>
#include "ef_test.h"
#include "evenfeed/geom/ef_bezier.h"
#include "evenfeed/seg/ef_seg.h"
#include "evenfeed/host/tables/ef_ref.h"
#include "evenfeed/host/tables/ef_tfile.h"
#include "evenfeed/host/tables/ef_verify.h"

extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;

/* Linked descriptor and file agree in every field the lookup reads, and in every value. */
static void test_same_as_file(const ef_table_t *lt, const char *path)
{
    ef_tfile_t f;
    ef_msg_t m = {{0}};
    int rc = ef_tfile_load(path, &f, &m);
    EF_CHECK_EQ(rc, EF_OK);
    if (rc != EF_OK) {
        fprintf(stderr, "%s\n", m.text);
        return;
    }
    EF_CHECK_EQ(ef_table_check(lt), EF_OK);
    const ef_table_t *v = &f.view;
    EF_CHECK_EQ(lt->kind, v->kind);
    EF_CHECK_EQ(lt->symmetry, v->symmetry);
    EF_CHECK_EQ(lt->nodes, v->nodes);
    EF_CHECK_EQ(lt->ndof, v->ndof);
    for (int a = 0; a < v->naxes; a++) {
        EF_CHECK(lt->axis[a].lo == v->axis[a].lo && lt->axis[a].hi == v->axis[a].hi);
        EF_CHECK(lt->axis[a].inv_step == v->axis[a].inv_step);
        EF_CHECK_EQ(lt->axis[a].stride, v->axis[a].stride);
    }
    EF_CHECK(memcmp(lt->data, v->data, sizeof(float) * v->nodes * v->ndof) == 0);
    EF_CHECK(lt->provenance_len == v->provenance_len &&
             memcmp(lt->provenance, v->provenance, v->provenance_len) == 0);
    ef_tfile_free(&f);
}

/* Re-optimize sampled nodes; the stored DOFs must be as good as a fresh optimum. */
static void test_recompute(const ef_table_t *lt, const char *path, int samples)
{
    ef_tfile_t f;
    if (ef_tfile_load(path, &f, NULL) != EF_OK)
        return;
    int g2 = lt->kind == EF_TABLE_G2_QUINTIC;
    ef_ref_kind_t kind = g2 ? EF_REF_G2_QUINTIC : EF_REF_G1_CUBIC;
    unsigned long long s = 99;
    double worst = 0, worst_dof = 0;
    for (int i = 0; i < samples; i++) {
        uint32_t node = (uint32_t)(ef_t_rng(&s) % lt->nodes);
        double cfg[4] = {0};
        ef_tfile_node_config(&f, node, cfg);
        ef_dend_t e0, e1;
        ef_ref_config(cfg[0], cfg[1], g2 ? cfg[2] : 0, g2 ? cfg[3] : 0, &e0, &e1);
        ef_ref_opts_t o;
        ef_ref_opts_default(&o);
        o.x1_min = lt->x1_min;
        o.x1_max = lt->x1_max;
        if (g2)
            o.x2_max = lt->x2_max;
        ef_ref_result_t r;
        EF_CHECK_EQ(ef_ref_optimize(kind, &e0, &e1, &o, &r, NULL), EF_OK);
        double stored[4];
        for (int k = 0; k < lt->ndof; k++)
            stored[k] = lt->data[(size_t)node * lt->ndof + k];
        double c_stored = sqrt(ef_ref_objective(kind, &e0, &e1, stored, NULL));
        double rel = (c_stored - r.C) / fmax(r.C, 1e-6);
        worst = fmax(worst, fabs(rel));
        for (int k = 0; k < lt->ndof; k++)
            worst_dof = fmax(worst_dof, fabs(stored[k] - r.dof[k]) / fmax(fabs(r.dof[k]), 0.1));
        if (!(fabs(rel) < 1e-5)) {
            EF_CHECK(0);
            fprintf(stderr, "node %u cfg (%g %g %g %g): stored C %.9g, recomputed %.9g\n", node,
                    cfg[0], cfg[1], cfg[2], cfg[3], c_stored, r.C);
        }
    }
    printf("%s: %d nodes recomputed, max |relative C difference| %.3g, max DOF difference %.3g\n",
           path, samples, worst, worst_dof);
    ef_tfile_free(&f);
}

/* The published configuration through the whole firmware chain, at any placement. */
static void test_reference_chain(void)
{
    ef_endpoint_t e0 = {.p = {10, 20, 0}, .t = {1, 0, 0}}, e1 = {.p = {10, 18, 0}, .t = {-1, 0, 0}};
    /* Chord 2 from (10,20) down to (10,18), tangents across it in a C shape: relative to the
     * chord direction (0,-1) that is alpha = pi/2, beta = -pi/2, the published case. */
    ef_seg_t seg;
    EF_CHECK_EQ(ef_seg_g1_cubic(&ef_tbl_g1_default, &e0, &e1, &seg), EF_OK);
    EF_CHECK_EQ(seg.flags, 0);
    EF_CHECK_NEAR(seg.dof[0], 2 * 1.288176, 2 * 2e-3);
    EF_CHECK_NEAR(seg.dof[1], 2 * 1.288176, 2 * 2e-3);
    float c;
    ef_bezier_functional(seg.b, 3, &c);
    /* C scales with chord^3: f' and f'' scale with s, so the integrand scales with s^6. */
    EF_CHECK_NEAR(c / 8.0f, 1.788278, 2e-4);
}

/* Regression floor for the accuracy harness on a small sample. */
static void test_accuracy_floor(void)
{
    ef_verify_opts_t o = {.count = 400, .seed = 7, .threads = 2};
    ef_verify_result_t r;
    ef_msg_t m = {{0}};
    EF_CHECK_EQ(ef_verify_table(&ef_tbl_g1_default, &o, &r, &m), EF_OK);
    printf("G1 default, %u configs: excess mean %.3g median %.3g p99 %.3g max %.3g, misses %u\n",
           r.count, r.excess.mean, r.excess.median, r.excess.p99, r.excess.max, r.opt_misses);
    EF_CHECK_EQ(r.opt_misses, 0);
    EF_CHECK_EQ(r.clamped, 0);
    EF_CHECK(r.excess.mean < 3e-4);
    EF_CHECK(r.excess.p99 < 0.01);
    o.count = 60;
    EF_CHECK_EQ(ef_verify_table(&ef_tbl_g2_default, &o, &r, &m), EF_OK);
    printf("G2 default, %u configs: excess mean %.3g median %.3g p99 %.3g max %.3g, misses %u\n",
           r.count, r.excess.mean, r.excess.median, r.excess.p99, r.excess.max, r.opt_misses);
    EF_CHECK_EQ(r.opt_misses, 0);
    EF_CHECK(r.excess.mean < 0.1167); /* the thesis's 4-D linear figure */
    EF_CHECK(r.excess.median < 0.0524);
}

static char tables_p1[4096], tables_p2[4096]; /* the shipped .eft files */

static void test_same_as_files(void)
{
    test_same_as_file(&ef_tbl_g1_default, tables_p1);
    test_same_as_file(&ef_tbl_g2_default, tables_p2);
}

static void test_recompute_both(void)
{
    test_recompute(&ef_tbl_g1_default, tables_p1, 80);
    test_recompute(&ef_tbl_g2_default, tables_p2, 12);
}

/* test_tables SOURCE_DIR [PART...] */
int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"same_as_file", test_same_as_files},
        {"recompute", test_recompute_both},
        {"reference_chain", test_reference_chain},
        {"accuracy_floor", test_accuracy_floor},
    };
    if (argc < 2) {
        fprintf(stderr, "usage: test_tables SOURCE_DIR [PART...]\n");
        return 2;
    }
    snprintf(tables_p1, sizeof tables_p1, "%s/tables/g1_cubic_default.eft", argv[1]);
    snprintf(tables_p2, sizeof tables_p2, "%s/tables/g2_quintic_default.eft", argv[1]);
    return EF_TEST_RUN(argc, argv, 2, parts);
}
