/* SPDX-License-Identifier: Apache-2.0 */
/* What the planar G1 table costs on 3-D data: relative excess of C over the true 3-D optimum,
 * binned by the twist between the tangents' planes. Prints a table; asserts nothing.
 * Usage: bench_twist [COUNT_PER_BIN] */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include "evenfeed/seg/ef_seg.h"
#include "evenfeed/host/tables/ef_ref.h"

extern const ef_table_t ef_tbl_g1_default;

/* splitmix64 uniform in [0,1). */
static double uni(unsigned long long *s)
{
    unsigned long long z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return (double)((z ^ (z >> 31)) >> 11) * (1.0 / 9007199254740992.0);
}

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    int per_bin = argc > 1 ? atoi(argv[1]) : 500;
    if (per_bin < 10)
        per_bin = 10;
    double *ex = malloc(sizeof(double) * (size_t)per_bin);
    if (!ex)
        return 1;
    unsigned long long s = 2024;
    printf("G1 cubic on 3-D data through the planar default table, %d configurations per bin\n"
           "(tangent angles to the chord with cos uniform in [-1,1]; twist = angle between the\n"
           "planes (chord,t0) and (chord,t1), folded into [0,90] degrees)\n\n",
           per_bin);
    printf("twist (deg)   mean excess   median      p99        max\n");
    for (int bin = 0; bin < 6; bin++) {
        double lo = bin * 15.0, hi = lo + 15.0;
        for (int i = 0; i < per_bin; i++) {
            double th0 = acos(2 * uni(&s) - 1), th1 = acos(2 * uni(&s) - 1);
            double tw = (lo + (hi - lo) * uni(&s)) * M_PI / 180;
            double phi = uni(&s) < 0.5 ? tw : M_PI - tw; /* both C- and S-like sides */
            ef_dend_t e0 = {{0, 0, 0}, {cos(th0), sin(th0), 0}, {0, 0, 0}, 0};
            ef_dend_t e1 = {
                {1, 0, 0}, {cos(th1), sin(th1) * cos(phi), sin(th1) * sin(phi)}, {0, 0, 0}, 0};
            ef_endpoint_t f0 = {.p = {0, 0, 0}, .t = {(float)e0.t.x, (float)e0.t.y, 0}};
            ef_endpoint_t f1 = {.p = {1, 0, 0}, .t = {(float)e1.t.x, (float)e1.t.y, (float)e1.t.z}};
            ef_seg_t seg;
            if (ef_seg_g1_cubic(&ef_tbl_g1_default, &f0, &f1, &seg) != EF_OK)
                return 1;
            double dof[2] = {seg.dof[0], seg.dof[1]};
            double c_tab = sqrt(ef_ref_objective(EF_REF_G1_CUBIC, &e0, &e1, dof, NULL));
            ef_ref_opts_t o;
            ef_ref_opts_default(&o);
            o.warm = dof;
            ef_ref_result_t r;
            if (ef_ref_optimize(EF_REF_G1_CUBIC, &e0, &e1, &o, &r, NULL) != EF_OK)
                return 1;
            ex[i] = r.C > 1e-9 ? (c_tab - r.C) / r.C : c_tab - r.C;
        }
        double sum = 0;
        for (int i = 0; i < per_bin; i++)
            sum += ex[i];
        qsort(ex, (size_t)per_bin, sizeof *ex, cmp);
        printf("%4.0f - %-4.0f   %-12.4g  %-10.3g  %-10.3g %.3g\n", lo, hi, sum / per_bin,
               ex[per_bin / 2], ex[(int)ceil(0.99 * per_bin) - 1], ex[per_bin - 1]);
    }
    free(ex);
    return 0;
}
