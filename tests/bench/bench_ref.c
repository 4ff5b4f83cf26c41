/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Timing of ef_ref_optimize per kind on random normalized configurations (the table
 * builder's workload), in thread CPU time. Build without sanitizers for meaningful figures.
 */
#include <stdio.h>
#include <time.h>

#include "../ef_test.h"
#include "evenfeed/host/tables/ef_ref.h"

/* This thread's CPU time in seconds: steadier than wall time on a shared machine. */
static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Time N optimizations per kind and print mean / worst per call. */
int main(int argc, char **argv)
{
    const int n = argc > 1 ? atoi(argv[1]) : 200;
    static const char *names[4] = {"", "G1 cubic", "G2 quintic", "G1 quartic"};
    for (int kind = 1; kind <= 3; kind++) {
        unsigned long long s = 42;
        double total = 0.0, worst = 0.0;
        long iters = 0, starts = 0;
        int nconv = 0;
        for (int k = 0; k < n; k++) {
            ef_dend_t e0, e1;
            ef_ref_config(ef_t_uniform(&s, -3.14159, 3.14159), ef_t_uniform(&s, -3.14159, 3.14159),
                          ef_t_uniform(&s, -2, 2), ef_t_uniform(&s, -2, 2), &e0, &e1);
            ef_ref_result_t r;
            const double t0 = now();
            ef_ref_optimize((ef_ref_kind_t)kind, &e0, &e1, NULL, &r, NULL);
            const double dt = now() - t0;
            total += dt;
            worst = dt > worst ? dt : worst;
            iters += r.iters;
            starts += r.starts;
            nconv += r.converged;
        }
        printf("%-11s %4d configs: mean %8.3f ms, worst %8.3f ms per optimize; %.1f starts, "
               "%.1f iterations per call; converged %d/%d\n",
               names[kind], n, 1e3 * total / n, 1e3 * worst, (double)starts / n, (double)iters / n,
               nconv, n);
    }
    return 0;
}
