/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Minimal test harness shared by evenfeed's C tests: each executable runs its checks and
 * ends with the line "N passed, N failed"; its exit status is nonzero if any check failed.
 */
#ifndef EF_TEST_H
#define EF_TEST_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#ifndef M_PI /* strict C11 headers do not define it */
#define M_PI 3.14159265358979323846
#endif

static int ef_t_pass, ef_t_fail;

#define EF_CHECK(cond)                                                                             \
    do {                                                                                           \
        if (cond) {                                                                                \
            ef_t_pass++;                                                                           \
        } else {                                                                                   \
            ef_t_fail++;                                                                           \
            fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond);               \
        }                                                                                          \
    } while (0)

/* |a - b| <= tol, reporting both values on failure. */
#define EF_CHECK_NEAR(a, b, tol)                                                                   \
    do {                                                                                           \
        double ef_a_ = (double)(a), ef_b_ = (double)(b), ef_tol_ = (double)(tol);                  \
        if (fabs(ef_a_ - ef_b_) <= ef_tol_) {                                                      \
            ef_t_pass++;                                                                           \
        } else {                                                                                   \
            ef_t_fail++;                                                                           \
            fprintf(stderr, "%s:%d: %s = %.10g, %s = %.10g, |diff| %.3g > %.3g\n", __FILE__,       \
                    __LINE__, #a, ef_a_, #b, ef_b_, fabs(ef_a_ - ef_b_), ef_tol_);                 \
        }                                                                                          \
    } while (0)

/* Integer equality, reporting both values on failure. */
#define EF_CHECK_EQ(a, b)                                                                          \
    do {                                                                                           \
        long long ef_a_ = (long long)(a), ef_b_ = (long long)(b);                                  \
        if (ef_a_ == ef_b_) {                                                                      \
            ef_t_pass++;                                                                           \
        } else {                                                                                   \
            ef_t_fail++;                                                                           \
            fprintf(stderr, "%s:%d: %s = %lld, expected %s = %lld\n", __FILE__, __LINE__, #a,      \
                    ef_a_, #b, ef_b_);                                                             \
        }                                                                                          \
    } while (0)

/* Whole file into a malloc'd, NUL-terminated buffer (NULL if it cannot be read). */
static inline char *ef_t_slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *b = n >= 0 ? (char *)malloc((size_t)n + 1) : NULL;
    if (b && fread(b, 1, (size_t)n, f) != (size_t)n) {
        free(b);
        b = NULL;
    }
    fclose(f);
    if (b)
        b[n] = 0;
    *len = n > 0 ? (size_t)n : 0;
    return b;
}

/* Print the closing line and give the exit status. */
static inline int ef_test_summary(void)
{
    printf("%d passed, %d failed\n", ef_t_pass, ef_t_fail);
    return ef_t_fail ? EXIT_FAILURE : EXIT_SUCCESS;
}

/* Deterministic 64-bit PRNG (splitmix64) so tests are reproducible. */
static inline unsigned long long ef_t_rng(unsigned long long *s)
{
    unsigned long long z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}
/* Uniform double in [lo, hi). */
static inline double ef_t_uniform(unsigned long long *s, double lo, double hi)
{
    return lo + (hi - lo) * (double)(ef_t_rng(s) >> 11) * (1.0 / 9007199254740992.0);
}

/* A 3x3 rotation (row-major), for tests that place configurations in random frames. */
typedef struct {
    double m[3][3];
} ef_t_rot3_t;

/* Uniformly random rotation, from a random unit quaternion (rejection sampling). */
static inline ef_t_rot3_t ef_t_rot_random(unsigned long long *rs)
{
    double q[4], n;
    do {
        n = 0;
        for (int i = 0; i < 4; i++) {
            q[i] = ef_t_uniform(rs, -1, 1);
            n += q[i] * q[i];
        }
    } while (n > 1 || n < 1e-6);
    n = sqrt(n);
    double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
    ef_t_rot3_t r = {{{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                      {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                      {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}}};
    return r;
}

#endif /* EF_TEST_H */
