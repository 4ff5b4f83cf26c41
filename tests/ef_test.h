/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Minimal test harness shared by evenfeed's C tests: each executable runs its checks and
 * ends with the line "N passed, N failed"; its exit status is nonzero if any check failed
 * or if no check ran at all (a test that checked nothing has not passed).
 *
 * Every test binary's main() hands its parts to the part runner, ef_test_run() (below):
 * a table of named test functions, run all or by name from the command line. An unknown
 * part name fails (listing the known ones), and so does a part that ran no check.
 */
#ifndef EF_TEST_H
#define EF_TEST_H

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

/* Print the closing line and give the exit status: failure when a check failed or when no
 * check ran. */
static inline int ef_test_summary(void)
{
    printf("%d passed, %d failed\n", ef_t_pass, ef_t_fail);
    if (ef_t_pass + ef_t_fail == 0)
        fprintf(stderr, "no checks ran\n");
    return ef_t_fail || ef_t_pass + ef_t_fail == 0 ? EXIT_FAILURE : EXIT_SUCCESS;
}

/* ---------------------------------------------------------------------------------------
 * Part runner.
 *
 *   static const ef_test_part_t parts[] = {
 *       {"codec", test_crc}, {"codec", test_codec}, // one part, two functions, in order
 *       {"exec", test_exec},
 *       {"random [COUNT]", test_random},             // a part that takes arguments
 *   };
 *   return EF_TEST_RUN(argc, argv, 1, parts);
 *
 * A part is every entry of its name, run in table order. A name followed by a space and a
 * usage ("random [COUNT]") makes a part that takes all the arguments after its name on the
 * command line: its functions find them in ef_t_argc / ef_t_argv (0 / NULL when it runs
 * without any, as in a run of all parts); ef_t_part is the running part's name.
 *
 * argv[first] onwards name the parts to run, in the order given; none (or the single word
 * "all") runs every part in table order. Arguments before argv[first] are the binary's own
 * (paths and the like; main() reads them). The run fails, before running anything, on an
 * unknown part name (or arguments after a part that takes none), listing the known parts;
 * it fails after running when a check failed or when a part ran no check. A part that
 * cannot run here calls ef_test_skip(); the run then exits EF_TEST_SKIP (77, ctest's
 * SKIP_RETURN_CODE) unless a check failed. The closing line is always "N passed, N failed".
 * ------------------------------------------------------------------------------------- */

typedef struct {
    const char *name; /* "name", or "name USAGE" for a part that takes arguments */
    void (*fn)(void);
} ef_test_part_t;

#define EF_TEST_SKIP 77

/* The running part's name and its arguments (those after the name on the command line). */
static const char *ef_t_part;
static int ef_t_argc;
static char **ef_t_argv;
static int ef_t_skipped;

/* The running part cannot run on this machine (no GL, say): say why; exit status 77. */
static inline void ef_test_skip(const char *why)
{
    printf("SKIP: %s: %s\n", ef_t_part ? ef_t_part : "?", why);
    ef_t_skipped = 1;
}

/* Length of an entry's part name (without its usage). */
static inline size_t ef_t_part_len(const ef_test_part_t *p)
{
    return strcspn(p->name, " ");
}

/* Whether an entry belongs to the part called name. */
static inline int ef_t_part_is(const ef_test_part_t *p, const char *name)
{
    size_t len = ef_t_part_len(p);
    return strncmp(p->name, name, len) == 0 && name[len] == '\0';
}

/* First entry of a part, or -1. */
static inline int ef_t_part_find(const ef_test_part_t *parts, size_t n, const char *name)
{
    for (size_t i = 0; i < n; i++)
        if (ef_t_part_is(&parts[i], name))
            return (int)i;
    return -1;
}

/* Whether entry i is its part's first (a part is listed and run once, from there). */
static inline int ef_t_part_first(const ef_test_part_t *parts, size_t i)
{
    for (size_t j = 0; j < i; j++)
        if (ef_t_part_len(&parts[j]) == ef_t_part_len(&parts[i]) &&
            strncmp(parts[j].name, parts[i].name, ef_t_part_len(&parts[i])) == 0)
            return 0;
    return 1;
}

/* Runs every entry of the part whose first entry is k; 0 when it ran no check (and did not
 * skip). */
static inline int ef_t_part_run(const ef_test_part_t *parts, size_t n, size_t k, int argc,
                                char **argv, int announce)
{
    static char name[128];
    int before = ef_t_pass + ef_t_fail, skipped = ef_t_skipped;
    snprintf(name, sizeof name, "%.*s", (int)ef_t_part_len(&parts[k]), parts[k].name);
    if (announce)
        fprintf(stderr, "-- part %s\n", name);
    ef_t_part = name;
    ef_t_argc = argc;
    ef_t_argv = argv;
    ef_t_skipped = 0;
    for (size_t i = k; i < n; i++)
        if (ef_t_part_is(&parts[i], name))
            parts[i].fn();
    int ok = ef_t_pass + ef_t_fail > before || ef_t_skipped;
    if (!ok)
        fprintf(stderr, "part %s ran no checks\n", name);
    ef_t_skipped |= skipped;
    ef_t_part = NULL;
    ef_t_argc = 0;
    ef_t_argv = NULL;
    return ok;
}

/* The known parts (and their arguments), on stderr. */
static inline void ef_t_part_list(const char *prog, const ef_test_part_t *parts, size_t n)
{
    const char *sep = " ";
    fprintf(stderr, "%s: known parts (none: all):", prog);
    for (size_t i = 0; i < n; i++) {
        if (ef_t_part_first(parts, i)) {
            fprintf(stderr, "%s%s", sep, parts[i].name);
            sep = ", ";
        }
    }
    fprintf(stderr, "\n");
}

/* Runs the parts named by argv[first..] (all when none); prints the closing line and returns
 * the exit status (see above). */
static inline int ef_test_run(int argc, char **argv, int first, const ef_test_part_t *parts,
                              size_t n)
{
    const char *prog = argc > 0 ? argv[0] : "test";
    int empty = 0;
    if (first < 1)
        first = 1;
    if (n == 0) {
        fprintf(stderr, "%s: no parts\n", prog);
        return EXIT_FAILURE;
    }
    for (size_t i = 0; i < n; i++) {
        if (parts[i].name == NULL || ef_t_part_len(&parts[i]) == 0 ||
            ef_t_part_len(&parts[i]) >= 128 || parts[i].fn == NULL) {
            fprintf(stderr, "%s: part table entry %zu has no name or no function\n", prog, i);
            return EXIT_FAILURE;
        }
    }
    int all = argc <= first || (argc == first + 1 && strcmp(argv[first], "all") == 0 &&
                                ef_t_part_find(parts, n, "all") < 0);
    if (all) {
        int distinct = 0;
        for (size_t i = 0; i < n; i++)
            distinct += ef_t_part_first(parts, i);
        for (size_t i = 0; i < n; i++)
            if (ef_t_part_first(parts, i) && !ef_t_part_run(parts, n, i, 0, NULL, distinct > 1))
                empty++;
    } else {
        /* Check every name before running anything. */
        int count = 0;
        for (int a = first; a < argc; a++, count++) {
            int k = ef_t_part_find(parts, n, argv[a]);
            if (k < 0) {
                if (a > first)
                    fprintf(stderr, "%s: unknown part '%s' (part '%s' takes no arguments)\n", prog,
                            argv[a], argv[a - 1]);
                else
                    fprintf(stderr, "%s: unknown part '%s'\n", prog, argv[a]);
                ef_t_part_list(prog, parts, n);
                printf("%d passed, %d failed\n", ef_t_pass, ef_t_fail);
                return EXIT_FAILURE;
            }
            if (parts[k].name[ef_t_part_len(&parts[k])] == ' ') {
                count++;
                break; /* the rest are its arguments */
            }
        }
        for (int a = first; a < argc; a++) {
            int k = ef_t_part_find(parts, n, argv[a]);
            int takes = parts[k].name[ef_t_part_len(&parts[k])] == ' ';
            int rest = takes ? argc - a - 1 : 0;
            if (!ef_t_part_run(parts, n, (size_t)k, rest, rest ? argv + a + 1 : NULL, count > 1))
                empty++;
            if (takes)
                break;
        }
    }
    printf("%d passed, %d failed\n", ef_t_pass, ef_t_fail);
    if (ef_t_fail || empty)
        return EXIT_FAILURE;
    if (ef_t_skipped)
        return EF_TEST_SKIP;
    if (ef_t_pass == 0) {
        fprintf(stderr, "no checks ran\n");
        return EXIT_FAILURE;
    }
    return EXIT_SUCCESS;
}

#define EF_TEST_RUN(argc, argv, first, parts)                                                      \
    ef_test_run((argc), (argv), (first), (parts), sizeof(parts) / sizeof((parts)[0]))

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
