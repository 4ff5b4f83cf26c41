/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed table: info, verify, build, merge, emit-c. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#include "cli.h"
#include "evenfeed/host/tables/ef_build.h"
#ifdef EF_HAVE_GL
#include "evenfeed/gpu/ef_gl.h"
#endif
#include "evenfeed/host/tables/ef_tfile.h"
#include "evenfeed/host/tables/ef_verify.h"

static const char usage[] =
    "usage: evenfeed table info FILE\n"
    "       evenfeed table verify FILE --random N [--seed S] [--3d] [--threads T] [--json]\n"
    "       evenfeed table build [--backend cpu|gl] --kind g1|g2 [--symmetry none|fold|mirror]\n"
    "                            --nodes N0xN1[xN2xN3] [--domain LO:HI,LO:HI,...]\n"
    "                            [--x1-min V] [--x1-max V] [--x2-max V] [--threads T]\n"
    "                            [--shard I/N] [--journal FILE] [--fresh]\n"
    "                            -o FILE [--c-source OUT.c --name IDENT]\n"
    "       evenfeed table merge -o OUT.eft [--c-source OUT.c --name IDENT] SHARD...\n"
    "       evenfeed table emit-c FILE --name IDENT -o OUT.c\n"
    "\n"
    "FILE may be @g1 or @g2 for the tables built into this binary.\n"
    "build defaults: backend cpu (T threads, default 2; gl: OpenGL 4.3 compute, headless);\n"
    "g1 fold over u in [0,pi/2], v in [0,pi] (g1 none: alpha, beta in [-pi,pi], periodic);\n"
    "g2 mirror over alpha in [0,pi/2], beta in [-pi/2,pi/2], k0, k1 in [-2,2]; x1 in\n"
    "[0.1, 10], |x2| <= 100 per unit chord (as the thesis).\n"
    "build works in chunks of rows (a row: the nodes along axis 0) and records each finished\n"
    "chunk in a journal (default FILE.partial); rerunning the same command resumes from it,\n"
    "--fresh discards it. --shard I/N (1 <= I <= N, counted from 1) builds the I-th of N\n"
    "contiguous blocks of rows into a shard file FILE; 'table merge' joins all N shards into\n"
    "the table an unsharded build writes, byte for byte (docs/table-build.md).\n";

/* A loaded table: either a file (owned) or a built-in view. */
typedef struct {
    ef_tfile_t file;
    const ef_table_t *view;
    const char *name;
} ef_cli_table_t;

/* Load FILE or resolve @g1 / @g2. */
static int ef_cli_load(const char *path, ef_cli_table_t *t)
{
    memset(t, 0, sizeof *t);
    t->name = path;
    if (path[0] == '@') {
        if (strcmp(path, "@g1") && strcmp(path, "@g2"))
            return ef_cli_error(EF_ERR_ARG, "unknown built-in table '%s' (there are @g1 and @g2)",
                                path);
        t->view = ef_cli_default_table(path[2] == '1' ? EF_TABLE_G1_CUBIC : EF_TABLE_G2_QUINTIC);
        if (!t->view)
            return ef_cli_error(EF_ERR_ARG, "this build has no built-in table %s", path);
        return EF_OK;
    }
    ef_msg_t m = {{0}};
    int rc = ef_tfile_load(path, &t->file, &m);
    if (rc != EF_OK)
        return ef_cli_error(rc, "%s", m.text);
    t->view = &t->file.view;
    return EF_OK;
}

static const char *ef_kind_name(int kind)
{
    return kind == EF_TABLE_G1_CUBIC     ? "G1 cubic"
           : kind == EF_TABLE_G2_QUINTIC ? "G2 quintic"
                                         : "?";
}
static const char *ef_sym_name(int sym)
{
    return sym == EF_SYM_NONE        ? "none"
           : sym == EF_SYM_G1_FOLD   ? "fold (u,v)"
           : sym == EF_SYM_G2_MIRROR ? "mirror (alpha >= 0)"
                                     : "?";
}

/* Bytes of the file image a view corresponds to. */
static unsigned long ef_table_bytes(const ef_table_t *v)
{
    unsigned long prov = (v->provenance_len + 7u) & ~7u;
    return EF_TABLE_HEADER_SIZE + prov + 4ul * v->nodes * v->ndof + 4ul;
}

/* table info FILE */
static int ef_table_info(int argc, char **argv)
{
    if (argc != 2)
        return ef_cli_error(EF_ERR_ARG, "usage: evenfeed table info FILE");
    ef_cli_table_t t;
    int rc = ef_cli_load(argv[1], &t);
    if (rc != EF_OK)
        return rc;
    const ef_table_t *v = t.view;
    static const char *g1_axes[] = {"alpha", "beta"},
                      *fold_axes[] = {"u=(alpha+beta)/2", "v=(alpha-beta)/2"},
                      *g2_axes[] = {"alpha", "beta", "k0", "k1"};
    const char **axes = v->kind == EF_TABLE_G2_QUINTIC  ? g2_axes
                        : v->symmetry == EF_SYM_G1_FOLD ? fold_axes
                                                        : g1_axes;
    printf("table:      %s\n", t.name);
    printf("kind:       %s (%u axes, %u DOFs per node)\n", ef_kind_name(v->kind), v->naxes,
           v->ndof);
    printf("symmetry:   %s\n", ef_sym_name(v->symmetry));
    printf("nodes:      %u (", v->nodes);
    for (int a = 0; a < v->naxes; a++)
        printf("%s%u", a ? " x " : "", v->axis[a].nodes);
    printf(")\nbytes:      %lu (values: %lu)\n", ef_table_bytes(v), 4ul * v->nodes * v->ndof);
    for (int a = 0; a < v->naxes; a++)
        printf("axis %d:     %-18s [%.9g, %.9g]%s step %.6g\n", a, axes[a], v->axis[a].lo,
               v->axis[a].hi, (v->axis[a].flags & EF_AXIS_PERIODIC) ? " periodic" : "",
               1.0 / v->axis[a].inv_step);
    printf("bounds:     x1 in [%g, %g]", v->x1_min, v->x1_max);
    if (v->kind == EF_TABLE_G2_QUINTIC)
        printf(", |x2| <= %g", v->x2_max);
    printf(" per unit chord\nfunctional: constant-speed C, Gauss-Legendre %u nodes\n",
           v->quad_nodes);
    printf("provenance: %.*s\n", (int)v->provenance_len, v->provenance ? v->provenance : "");
    ef_tfile_free(&t.file);
    return 0;
}

/* Print a statistic row. */
static void ef_print_stat(const char *name, const ef_stat_t *s)
{
    printf("  %-24s mean %.4g  median %.4g  p99 %.4g  max %.4g  (min %.3g)\n", name, s->mean,
           s->median, s->p99, s->max, s->min);
}

/* Print a statistic as a JSON object member. */
static void ef_json_stat(const char *name, const ef_stat_t *s, int last)
{
    printf("  \"%s\": {\"min\": %.6g, \"mean\": %.6g, \"median\": %.6g, \"p99\": %.6g, \"max\": "
           "%.6g}%s\n",
           name, s->min, s->mean, s->median, s->p99, s->max, last ? "" : ",");
}

/* table verify FILE --random N ... */
static int ef_table_verify(int argc, char **argv)
{
    static const struct option opts[] = {
        {"random", required_argument, 0, 'n'}, {"seed", required_argument, 0, 's'},
        {"3d", no_argument, 0, '3'},           {"threads", required_argument, 0, 't'},
        {"json", no_argument, 0, 'j'},         {0, 0, 0, 0}};
    ef_verify_opts_t o = {.count = 0, .seed = 1, .three_d = 0, .threads = 2};
    int json = 0, c;
    double v;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        switch (c) {
        case 'n':
            if (ef_cli_double("--random", optarg, &v) || v < 1 || v > 1e7 || v != floor(v))
                return ef_cli_error(EF_ERR_ARG, "--random: need a whole number 1..10000000");
            o.count = (uint32_t)v;
            break;
        case 's':
            if (ef_cli_double("--seed", optarg, &v) || v < 0 || v != floor(v))
                return ef_cli_error(EF_ERR_ARG, "--seed: need a whole number >= 0");
            o.seed = (uint64_t)v;
            break;
        case '3':
            o.three_d = 1;
            break;
        case 't':
            if (ef_cli_double("--threads", optarg, &v) || v < 1 || v > 64 || v != floor(v))
                return ef_cli_error(EF_ERR_ARG, "--threads: need 1..64");
            o.threads = (int)v;
            break;
        case 'j':
            json = 1;
            break;
        default:
            return ef_cli_error(EF_ERR_ARG, "table verify: unknown option '%s'", argv[optind - 1]);
        }
    }
    if (optind != argc - 1 || o.count == 0)
        return ef_cli_error(EF_ERR_ARG, "usage: evenfeed table verify FILE --random N [--seed S] "
                                        "[--3d] [--threads T] [--json]");
    ef_cli_table_t t;
    int rc = ef_cli_load(argv[optind], &t);
    if (rc != EF_OK)
        return rc;
    ef_verify_result_t r;
    ef_msg_t m = {{0}};
    rc = ef_verify_table(t.view, &o, &r, &m);
    if (rc != EF_OK) {
        ef_tfile_free(&t.file);
        return ef_cli_error(rc, "%s", m.text);
    }
    const ef_table_t *tv = t.view;
    if (json) {
        printf("{\n  \"table\": \"%s\", \"kind\": \"%s\", \"nodes\": %u, \"bytes\": %lu,\n", t.name,
               tv->kind == EF_TABLE_G1_CUBIC ? "g1_cubic" : "g2_quintic", tv->nodes,
               ef_table_bytes(tv));
        printf("  \"configurations\": %u, \"seed\": %llu, \"three_d\": %s, \"clamped\": %u, "
               "\"optimizer_misses\": %u,\n",
               r.count, (unsigned long long)o.seed, o.three_d ? "true" : "false", r.clamped,
               r.opt_misses);
        ef_json_stat("excess", &r.excess, 0);
        ef_json_stat("x1_error", &r.x1_err, 0);
        ef_json_stat("x2_error", &r.x2_err, 0);
        printf("  \"worst\": [%.6g, %.6g, %.6g, %.6g], \"seconds\": %.3f\n}\n", r.worst_cfg[0],
               r.worst_cfg[1], r.worst_cfg[2], r.worst_cfg[3], r.seconds);
    } else {
        printf("table %s: %s, %u nodes, %lu bytes\n", t.name, ef_kind_name(tv->kind), tv->nodes,
               ef_table_bytes(tv));
        printf("%u random %s configurations (seed %llu), %u outside the domain, %u optimizer "
               "misses, %.1f s\n",
               r.count, o.three_d ? "3-D (twisted)" : "planar", (unsigned long long)o.seed,
               r.clamped, r.opt_misses, r.seconds);
        ef_print_stat("relative excess of C", &r.excess);
        ef_print_stat("relative error of x1", &r.x1_err);
        if (tv->kind == EF_TABLE_G2_QUINTIC)
            ef_print_stat("relative error of x2", &r.x2_err);
        printf("  worst configuration: alpha %.4f beta %.4f", r.worst_cfg[0], r.worst_cfg[1]);
        if (tv->kind == EF_TABLE_G2_QUINTIC)
            printf(" k0 %.4f k1 %.4f", r.worst_cfg[2], r.worst_cfg[3]);
        printf("\n  thesis, for comparison: %s\n",
               tv->kind == EF_TABLE_G1_CUBIC
                   ? "G1 20x20 bilinear: excess mean 0.0146, median 0.0031; x1 error mean 0.0658"
                   : "G2 4-D linear: excess mean 0.1167, median 0.0524; x1 error mean 0.1148, x2 "
                     "0.6481");
    }
    ef_tfile_free(&t.file);
    return 0;
}

/* Progress on stderr: at most about once a second, with nodes/s and ETA. The first call
 * gives the nodes resumed from a journal: they count as done, not in the rate. */
typedef struct {
    struct timespec start, last;
    uint32_t base; /* nodes done before this run computed anything */
    int started;
    const char *journal;
} ef_progress_t;

/* Seconds from a to b. */
static double ef_since(const struct timespec *a, const struct timespec *b)
{
    return (double)(b->tv_sec - a->tv_sec) + 1e-9 * (double)(b->tv_nsec - a->tv_nsec);
}

/* ef_build_progress_fn for the build command. */
static void ef_progress(void *ctx, uint32_t done, uint32_t total)
{
    ef_progress_t *p = ctx;
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    if (!p->started) {
        p->started = 1;
        p->base = done;
        p->start = p->last = now;
        if (done > 0)
            fprintf(stderr, "build: resuming from %s: %u/%u nodes already done\n",
                    p->journal ? p->journal : "the journal", done, total);
        return;
    }
    if (done < total && ef_since(&p->last, &now) < 1.0)
        return;
    p->last = now;
    double el = ef_since(&p->start, &now), rate = el > 0 ? (done - p->base) / el : 0;
    fprintf(stderr, "build: %u/%u nodes (%3.0f%%), %.0f nodes/s, ETA %.0f s%s", done, total,
            100.0 * done / total, rate, rate > 0 ? (total - done) / rate : 0.0,
            isatty(2) ? "\r" : "\n");
    if (done == total && isatty(2))
        fputc('\n', stderr);
}

/* Parse "A:B,C:D,..." into n ranges. */
static int ef_parse_domain(const char *s, double *lo, double *hi, int n)
{
    const char *p = s;
    for (int a = 0; a < n; a++) {
        char *end;
        lo[a] = strtod(p, &end);
        if (end == p || *end != ':')
            return EF_ERR_ARG;
        p = end + 1;
        hi[a] = strtod(p, &end);
        if (end == p || (a < n - 1 && *end != ',') || (a == n - 1 && *end != '\0'))
            return EF_ERR_ARG;
        if (!isfinite(lo[a]) || !isfinite(hi[a]))
            return EF_ERR_ARG;
        p = end + 1;
    }
    return EF_OK;
}

/* Shortest "%.Ng" text that reads back as the same double (10 -> "10", not "1e+01"), so
 * equal values always print the same and the provenance does not depend on how a number
 * was typed (0.10 vs .1). */
static void ef_fmt_double(char *buf, size_t size, double v)
{
    char cand[40];
    buf[0] = '\0';
    for (int prec = 1; prec <= 17; prec++) {
        snprintf(cand, sizeof cand, "%.*g", prec, v);
        if (strtod(cand, NULL) == v && (!buf[0] || strlen(cand) < strlen(buf)))
            snprintf(buf, size, "%s", cand);
    }
}

/* Canonical provenance: the version and every option that affects the values, in a fixed
 * order and format, defaults included; nothing about where the output goes (-o,
 * --c-source, --name), how it is run (--threads, --shard, --journal, --fresh). Sharded and
 * unsharded builds of the same table thus carry the same bytes. */
static void ef_build_provenance(char *prov, size_t size, const char *backend,
                                const ef_tfile_spec_t *s)
{
    const int g2 = s->kind == EF_TABLE_G2_QUINTIC, naxes = g2 ? 4 : 2;
    const char *sym = s->symmetry == EF_SYM_NONE ? "none" : g2 ? "mirror" : "fold";
    char num[32];
    int len = snprintf(prov, size,
                       "evenfeed %s table build --backend %s --kind %s --symmetry %s "
                       "--nodes ",
                       EF_VERSION, backend, g2 ? "g2" : "g1", sym);
    for (int a = 0; a < naxes && len < (int)size; a++)
        len += snprintf(prov + len, size - (size_t)len, "%s%u", a ? "x" : "", s->nodes[a]);
    if (s->symmetry != EF_SYM_G1_FOLD && len < (int)size) {
        len += snprintf(prov + len, size - (size_t)len, " --domain ");
        for (int a = 0; a < naxes && len < (int)size; a++) {
            ef_fmt_double(num, sizeof num, s->lo[a]);
            len += snprintf(prov + len, size - (size_t)len, "%s%s:", a ? "," : "", num);
            ef_fmt_double(num, sizeof num, s->hi[a]);
            if (len < (int)size)
                len += snprintf(prov + len, size - (size_t)len, "%s", num);
        }
    }
    static const char *const names[] = {"--x1-min", "--x1-max", "--x2-max"};
    const double vals[] = {s->x1_min, s->x1_max, s->x2_max};
    for (int k = 0; k < (g2 ? 3 : 2) && len < (int)size; k++) {
        ef_fmt_double(num, sizeof num, vals[k]);
        len += snprintf(prov + len, size - (size_t)len, " %s %s", names[k], num);
    }
}

/* Write C source atomically (temporary file, rename), so an interrupted emit never leaves a
 * half-written source that a firmware build would pick up. */
static int ef_emit_c_file(const ef_tfile_t *t, const char *name, const char *path, ef_msg_t *m)
{
    char tmp[4200];
    if (snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid()) >= (int)sizeof tmp)
        return ef_fail(m, EF_ERR_ARG, "%s: path too long", path);
    FILE *f = fopen(tmp, "w");
    if (!f)
        return ef_fail(m, EF_ERR_IO, "%s: cannot open for writing: %s", tmp, strerror(errno));
    int rc = ef_tfile_emit_c(t, name, f, m);
    if (rc == EF_OK && (fflush(f) != 0 || fsync(fileno(f)) != 0))
        rc = ef_fail(m, EF_ERR_IO, "%s: write failed: %s", tmp, strerror(errno));
    if (fclose(f) != 0 && rc == EF_OK)
        rc = ef_fail(m, EF_ERR_IO, "%s: write failed: %s", tmp, strerror(errno));
    if (rc == EF_OK && rename(tmp, path) != 0)
        rc = ef_fail(m, EF_ERR_IO, "%s: rename from %s: %s", path, tmp, strerror(errno));
    if (rc != EF_OK)
        (void)unlink(tmp);
    return rc;
}

/* An output location's directory must be writable and the path not a directory; checked
 * before any work. */
static int ef_check_out(const char *path, const char *what)
{
    struct stat st;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        return ef_cli_error(EF_ERR_IO, "%s %s: is a directory", what, path);
    char dir[4096];
    const char *slash = strrchr(path, '/');
    if (!slash)
        snprintf(dir, sizeof dir, ".");
    else
        snprintf(dir, sizeof dir, "%.*s", slash == path ? 1 : (int)(slash - path), path);
    if (access(dir, W_OK | X_OK) != 0)
        return ef_cli_error(EF_ERR_IO, "%s %s: cannot write in directory %s: %s", what, path, dir,
                            strerror(errno));
    return 0;
}

/* Open the backend named on the command line (after every check has passed). */
static int ef_open_backend(const char *name, int threads, ef_build_backend_t *b, ef_msg_t *m)
{
    if (!strcmp(name, "cpu"))
        return ef_build_backend_cpu(b, threads) == EF_OK
                   ? EF_OK
                   : ef_fail(m, EF_ERR_ARG, "--threads: need 1..64");
#ifdef EF_HAVE_GL
    return ef_gl_backend_open(b, m);
#else
    return ef_fail(m, EF_ERR_ARG,
                   "--backend gl: this evenfeed was built without OpenGL "
                   "(libepoxy); install libepoxy-dev and rebuild, or use --backend cpu");
#endif
}

/* table build ... */
static int ef_table_build(int argc, char **argv)
{
    static const struct option opts[] = {
        {"backend", required_argument, 0, 'b'},  {"kind", required_argument, 0, 'k'},
        {"symmetry", required_argument, 0, 'y'}, {"nodes", required_argument, 0, 'n'},
        {"domain", required_argument, 0, 'd'},   {"x1-min", required_argument, 0, '1'},
        {"x1-max", required_argument, 0, '2'},   {"x2-max", required_argument, 0, '3'},
        {"threads", required_argument, 0, 't'},  {"output", required_argument, 0, 'o'},
        {"c-source", required_argument, 0, 'c'}, {"name", required_argument, 0, 'N'},
        {"shard", required_argument, 0, 's'},    {"journal", required_argument, 0, 'J'},
        {"fresh", no_argument, 0, 'F'},          {0, 0, 0, 0}};
    const char *backend = "cpu", *kind = NULL, *sym = NULL, *nodes = NULL, *domain = NULL,
               *out = NULL, *csrc = NULL, *name = NULL, *shard = NULL, *journal = NULL;
    double x1min = 0.1, x1max = 10, x2max = 100, thr = 2;
    int c, rc, fresh = 0;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, "o:", opts, NULL)) != -1) {
        rc = EF_OK;
        switch (c) {
        case 'b':
            backend = optarg;
            break;
        case 'k':
            kind = optarg;
            break;
        case 'y':
            sym = optarg;
            break;
        case 'n':
            nodes = optarg;
            break;
        case 'd':
            domain = optarg;
            break;
        case '1':
            rc = ef_cli_double("--x1-min", optarg, &x1min);
            break;
        case '2':
            rc = ef_cli_double("--x1-max", optarg, &x1max);
            break;
        case '3':
            rc = ef_cli_double("--x2-max", optarg, &x2max);
            break;
        case 't':
            rc = ef_cli_double("--threads", optarg, &thr);
            break;
        case 'o':
            out = optarg;
            break;
        case 'c':
            csrc = optarg;
            break;
        case 'N':
            name = optarg;
            break;
        case 's':
            shard = optarg;
            break;
        case 'J':
            journal = optarg;
            break;
        case 'F':
            fresh = 1;
            break;
        default:
            return ef_cli_error(EF_ERR_ARG, "table build: unknown option or missing value '%s'",
                                argv[optind - 1]);
        }
        if (rc != EF_OK)
            return ef_cli_exit(rc);
    }
    if (optind != argc)
        return ef_cli_error(EF_ERR_ARG, "table build: unexpected argument '%s'", argv[optind]);
    if (strcmp(backend, "cpu") && strcmp(backend, "gl"))
        return ef_cli_error(EF_ERR_ARG, "table build: unknown backend '%s' (cpu or gl)", backend);
    if (!kind || (strcmp(kind, "g1") && strcmp(kind, "g2")))
        return ef_cli_error(EF_ERR_ARG, "table build: --kind g1 or g2 is required");
    if (!nodes || !out)
        return ef_cli_error(EF_ERR_ARG, "table build: --nodes and -o are required");
    if ((csrc == NULL) != (name == NULL))
        return ef_cli_error(EF_ERR_ARG, "table build: --c-source and --name go together");
    if (csrc && shard)
        return ef_cli_error(EF_ERR_ARG, "table build: --c-source needs the whole table; give it "
                                        "to 'table merge' when building shards");
    if (thr < 1 || thr > 64 || thr != floor(thr))
        return ef_cli_error(EF_ERR_ARG, "--threads: need 1..64");
    ef_msg_t m = {{0}};
    ef_build_opts_t bo;
    memset(&bo, 0, sizeof bo);
    if (shard && ef_build_shard_parse(shard, &bo.shard, &m) != EF_OK)
        return ef_cli_error(EF_ERR_ARG, "%s", m.text);
    ef_tfile_spec_t spec;
    memset(&spec, 0, sizeof spec);
    int g2 = kind[1] == '2', naxes = g2 ? 4 : 2;
    spec.kind = g2 ? EF_TABLE_G2_QUINTIC : EF_TABLE_G1_CUBIC;
    if (!sym)
        spec.symmetry = g2 ? EF_SYM_G2_MIRROR : EF_SYM_G1_FOLD;
    else if (!strcmp(sym, "none"))
        spec.symmetry = EF_SYM_NONE;
    else if (!strcmp(sym, "fold") && !g2)
        spec.symmetry = EF_SYM_G1_FOLD;
    else if (!strcmp(sym, "mirror") && g2)
        spec.symmetry = EF_SYM_G2_MIRROR;
    else
        return ef_cli_error(
            EF_ERR_ARG,
            "table build: --symmetry %s does not apply to %s (g1: none|fold, g2: none|mirror)", sym,
            kind);
    /* Node counts "AxB[xCxD]". */
    const char *p = nodes;
    for (int a = 0; a < naxes; a++) {
        char *end;
        unsigned long v = strtoul(p, &end, 10);
        if (end == p || *p < '0' || *p > '9' || v < 2 || v > EF_TABLE_MAX_AXIS_NODES ||
            (a < naxes - 1 ? *end != 'x' : *end != '\0'))
            return ef_cli_error(EF_ERR_ARG, "--nodes: '%s' is not %d counts of 2..%u joined by 'x'",
                                nodes, naxes, EF_TABLE_MAX_AXIS_NODES);
        spec.nodes[a] = (uint32_t)v;
        p = end + 1;
    }
    uint64_t total = 1;
    for (int a = 0; a < naxes; a++)
        total *= spec.nodes[a];
    if (total > EF_TABLE_MAX_NODES)
        return ef_cli_error(EF_ERR_TBL_SIZE,
                            "--nodes %s: %llu nodes, more than the %u a table may hold", nodes,
                            (unsigned long long)total, EF_TABLE_MAX_NODES);
    if (!g2 && spec.symmetry == EF_SYM_G1_FOLD) {
        spec.lo[0] = 0, spec.hi[0] = M_PI / 2, spec.lo[1] = 0, spec.hi[1] = M_PI;
    } else if (!g2) {
        for (int a = 0; a < 2; a++)
            spec.lo[a] = -M_PI, spec.hi[a] = M_PI, spec.axis_flags[a] = EF_AXIS_PERIODIC;
    } else {
        spec.lo[0] = spec.symmetry == EF_SYM_G2_MIRROR ? 0 : -M_PI / 2, spec.hi[0] = M_PI / 2;
        spec.lo[1] = -M_PI / 2, spec.hi[1] = M_PI / 2;
        spec.lo[2] = spec.lo[3] = -2, spec.hi[2] = spec.hi[3] = 2;
    }
    if (domain) {
        if (!g2 && spec.symmetry == EF_SYM_G1_FOLD)
            return ef_cli_error(
                EF_ERR_ARG, "--domain: a fold table always covers its fixed fundamental region");
        if (ef_parse_domain(domain, spec.lo, spec.hi, naxes) != EF_OK)
            return ef_cli_error(EF_ERR_ARG, "--domain: '%s' is not %d ranges LO:HI joined by ','",
                                domain, naxes);
        for (int a = 0; a < naxes; a++)
            if (!g2 && fabs(spec.hi[a] - spec.lo[a] - 2 * M_PI) > 1e-9)
                spec.axis_flags[a] = 0; /* periodic only when the axis spans the circle */
    }
    spec.x1_min = x1min;
    spec.x1_max = x1max;
    spec.x2_max = g2 ? x2max : 0;
    spec.quad_nodes = g2 ? 12 : 6;
    /* Large enough for any canonical command; the table format caps it, and
     * ef_tfile_create() refuses a longer one with a clear message. */
    char prov[2 * EF_TABLE_MAX_PROVENANCE];
    ef_build_provenance(prov, sizeof prov, backend, &spec);
    spec.provenance = prov;

    /* Every check before the backend opens: spec (domain, counts, bounds), shard, paths,
     * an existing journal. A GPU is touched only for a build that can finish. */
    ef_tfile_t t;
    rc = ef_tfile_create(&t, &spec, &m);
    if (rc != EF_OK)
        return ef_cli_error(rc, "table build: %s", m.text);
    char jpath[4200];
    if (!journal) {
        if (snprintf(jpath, sizeof jpath, "%s.partial", out) >= (int)sizeof jpath) {
            ef_tfile_free(&t);
            return ef_cli_error(EF_ERR_ARG, "-o: path too long");
        }
        journal = jpath;
    }
    bo.journal = journal;
    bo.fresh = fresh;
    bo.output = out;
    ef_build_plan_t plan;
    rc = ef_build_check(&t, backend, &bo, &plan, &m);
    if (rc == EF_OK && csrc && (rc = ef_check_out(csrc, "--c-source")) != 0) {
        ef_tfile_free(&t);
        return rc;
    }
    if (rc != EF_OK) {
        ef_tfile_free(&t);
        return ef_cli_error(rc, "table build: %s", m.text);
    }
    if (bo.shard.count)
        fprintf(stderr, "build: shard %u/%u: rows %u..%u of %u (%u nodes)\n", bo.shard.index,
                bo.shard.count, plan.row_begin, plan.row_end - 1, plan.rows,
                (plan.row_end - plan.row_begin) * plan.n0);
    ef_build_backend_t b;
    rc = ef_open_backend(backend, (int)thr, &b, &m);
    if (rc != EF_OK) {
        ef_tfile_free(&t);
        return ef_cli_error(rc, "table build: %s", m.text);
    }
    ef_progress_t pr = {.journal = journal};
    bo.progress = ef_progress;
    bo.progress_ctx = &pr;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    rc = ef_build_run(&t, &b, &bo, &m);
    if (b.close)
        b.close(b.ctx);
    if (rc == EF_OK && csrc) {
        rc = ef_emit_c_file(&t, name, csrc, &m);
        if (rc != EF_OK) {
            char text[sizeof m.text];
            snprintf(text, sizeof text, "%s", m.text);
            ef_fail(&m, rc,
                    "%.300s (%s is written; 'evenfeed table emit-c %s --name %s -o %s' "
                    "retries the C source)",
                    text, out, out, name, csrc);
        }
    }
    ef_tfile_free(&t);
    if (rc != EF_OK)
        return ef_cli_error(rc, "table build: %s", m.text);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    fprintf(stderr, "build: wrote %s%s%s (%.1f s)\n", out, csrc ? " and " : "", csrc ? csrc : "",
            ef_since(&t0, &t1));
    return 0;
}

/* table merge -o OUT.eft [--c-source OUT.c --name IDENT] SHARD... */
static int ef_table_merge(int argc, char **argv)
{
    static const struct option opts[] = {{"output", required_argument, 0, 'o'},
                                         {"c-source", required_argument, 0, 'c'},
                                         {"name", required_argument, 0, 'N'},
                                         {0, 0, 0, 0}};
    const char *out = NULL, *csrc = NULL, *name = NULL;
    int c;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, "o:", opts, NULL)) != -1) {
        if (c == 'o')
            out = optarg;
        else if (c == 'c')
            csrc = optarg;
        else if (c == 'N')
            name = optarg;
        else
            return ef_cli_error(EF_ERR_ARG, "table merge: unknown option or missing value '%s'",
                                argv[optind - 1]);
    }
    if (!out || optind >= argc)
        return ef_cli_error(
            EF_ERR_ARG,
            "usage: evenfeed table merge -o OUT.eft [--c-source OUT.c --name IDENT] SHARD...");
    if ((csrc == NULL) != (name == NULL))
        return ef_cli_error(EF_ERR_ARG, "table merge: --c-source and --name go together");
    int rc = ef_check_out(out, "-o");
    if (rc == 0 && csrc)
        rc = ef_check_out(csrc, "--c-source");
    if (rc != 0)
        return rc;
    ef_tfile_t t;
    ef_msg_t m = {{0}};
    rc = ef_shard_merge((const char *const *)(argv + optind), (uint32_t)(argc - optind), &t, &m);
    if (rc == EF_OK)
        rc = ef_tfile_write(&t, out, &m);
    if (rc == EF_OK && csrc)
        rc = ef_emit_c_file(&t, name, csrc, &m);
    ef_tfile_free(&t);
    if (rc != EF_OK)
        return ef_cli_error(rc, "table merge: %s", m.text);
    fprintf(stderr, "merge: %d shards -> %s%s%s\n", argc - optind, out, csrc ? " and " : "",
            csrc ? csrc : "");
    return 0;
}

/* table emit-c FILE --name IDENT -o OUT.c */
static int ef_table_emit(int argc, char **argv)
{
    static const struct option opts[] = {
        {"name", required_argument, 0, 'N'}, {"output", required_argument, 0, 'o'}, {0, 0, 0, 0}};
    const char *name = NULL, *out = NULL;
    int c;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, "o:", opts, NULL)) != -1) {
        if (c == 'N')
            name = optarg;
        else if (c == 'o')
            out = optarg;
        else
            return ef_cli_error(EF_ERR_ARG, "table emit-c: unknown option '%s'", argv[optind - 1]);
    }
    if (optind != argc - 1 || !name || !out)
        return ef_cli_error(EF_ERR_ARG, "usage: evenfeed table emit-c FILE --name IDENT -o OUT.c");
    ef_tfile_t t;
    ef_msg_t m = {{0}};
    int rc = ef_tfile_load(argv[optind], &t, &m);
    if (rc != EF_OK)
        return ef_cli_error(rc, "%s", m.text);
    rc = ef_emit_c_file(&t, name, out, &m);
    ef_tfile_free(&t);
    return rc == EF_OK ? 0 : ef_cli_error(rc, "%s", m.text);
}

/* evenfeed table SUBCOMMAND ... */
int ef_cmd_table(int argc, char **argv)
{
    if (argc < 2 || !strcmp(argv[1], "--help")) {
        fputs(usage, argc < 2 ? stderr : stdout);
        return argc < 2 ? 1 : 0;
    }
    if (!strcmp(argv[1], "info"))
        return ef_table_info(argc - 1, argv + 1);
    if (!strcmp(argv[1], "verify"))
        return ef_table_verify(argc - 1, argv + 1);
    if (!strcmp(argv[1], "build"))
        return ef_table_build(argc - 1, argv + 1);
    if (!strcmp(argv[1], "merge"))
        return ef_table_merge(argc - 1, argv + 1);
    if (!strcmp(argv[1], "emit-c"))
        return ef_table_emit(argc - 1, argv + 1);
    fputs(usage, stderr);
    return ef_cli_error(EF_ERR_ARG, "table: unknown subcommand '%s'", argv[1]);
}
