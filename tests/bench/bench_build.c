/* SPDX-License-Identifier: Apache-2.0 */
/* Table builder throughput, GL backend against the CPU reference on the same grids in one
 * run, and whether the two tables agree value for value. Prints figures; asserts nothing.
 * Usage: bench_build [cpu-threads] */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "evenfeed/gpu/ef_gl.h"
#include "evenfeed/host/tables/ef_build.h"

/* Wall-clock seconds. */
static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* A table of the default kind/symmetry with the given node counts. */
static int make(ef_tfile_t *t, int kind, const uint32_t *nodes)
{
    ef_tfile_spec_t s;
    memset(&s, 0, sizeof s);
    s.kind = kind;
    s.symmetry = kind == EF_TABLE_G1_CUBIC ? EF_SYM_G1_FOLD : EF_SYM_G2_MIRROR;
    if (kind == EF_TABLE_G1_CUBIC) {
        s.lo[0] = 0, s.hi[0] = M_PI / 2, s.lo[1] = 0, s.hi[1] = M_PI;
    } else {
        s.lo[0] = 0, s.hi[0] = M_PI / 2, s.lo[1] = -M_PI / 2, s.hi[1] = M_PI / 2;
        s.lo[2] = s.lo[3] = -2, s.hi[2] = s.hi[3] = 2;
    }
    for (int a = 0; a < 4; a++)
        s.nodes[a] = nodes[a];
    s.x1_min = 0.1, s.x1_max = 10, s.x2_max = kind == EF_TABLE_G2_QUINTIC ? 100 : 0;
    s.quad_nodes = kind == EF_TABLE_G1_CUBIC ? 6 : 12;
    s.provenance = "bench_build";
    return ef_tfile_create(t, &s, NULL);
}

/* Build with a backend; returns nodes/s, or -1 on failure (message printed). */
static double run(ef_tfile_t *t, ef_build_backend_t *b)
{
    ef_msg_t m = {{0}};
    double t0 = now();
    if (ef_build_all(t, b, NULL, NULL, &m) != EF_OK) {
        printf("  %s backend failed: %s\n", b->name, m.text);
        return -1;
    }
    return t->view.nodes / (now() - t0);
}

int main(int argc, char **argv)
{
    int threads = argc > 1 ? atoi(argv[1]) : 2;
    if (threads < 1 || threads > 64)
        threads = 2;
    ef_build_backend_t gl;
    ef_msg_t m = {{0}};
    if (ef_gl_backend_open(&gl, &m) != EF_OK) {
        printf("no GL backend here: %s\n", m.text);
        return 0;
    }
    printf("GL: %s, EGL %s platform; CPU reference: %d threads\n", ef_gl_renderer(gl.ctx),
           ef_gl_platform(gl.ctx), threads);
    static const uint32_t g1[4] = {49, 97, 0, 0}, g2[4] = {5, 9, 7, 7};
    static const struct {
        int kind;
        const uint32_t *nodes;
        const char *name;
    } grids[] = {{EF_TABLE_G1_CUBIC, g1, "G1 cubic fold 49x97"},
                 {EF_TABLE_G2_QUINTIC, g2, "G2 quintic mirror 5x9x7x7"}};
    for (int g = 0; g < 2; g++) {
        ef_tfile_t a, c;
        if (make(&a, grids[g].kind, grids[g].nodes) || make(&c, grids[g].kind, grids[g].nodes))
            return 1;
        /* One warm-up row so the shader's compilation is not billed to the build. */
        gl.solve_rows(gl.ctx, &a, 0, 1, NULL);
        ef_build_backend_t cpu;
        ef_build_backend_cpu(&cpu, threads);
        double r_gl = run(&a, &gl), r_cpu = run(&c, &cpu);
        cpu.close(cpu.ctx);
        size_t nv = (size_t)a.view.nodes * a.view.ndof, diff = 0;
        for (size_t i = 0; i < nv; i++)
            diff += a.values[i] != c.values[i];
        printf("%-28s %6u nodes: GL %9.0f nodes/s, CPU %9.0f nodes/s, GL/CPU %.2f; values that "
               "differ: %zu of %zu\n",
               grids[g].name, a.view.nodes, r_gl, r_cpu, r_gl / r_cpu, diff, nv);
        ef_tfile_free(&a);
        ef_tfile_free(&c);
    }
    printf("GL configurations solved on the CPU after the driver cut a loop short: %llu\n",
           (unsigned long long)ef_gl_fallbacks(gl.ctx));
    printf("(thesis: 20x20 G1 grid, 266 s on one CPU thread, 2.55 s with OpenGL compute)\n");
    gl.close(gl.ctx);
    return 0;
}
