/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed table: info, verify, build, merge, emit-c. */
#include <errno.h>
#include <limits.h>
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

/* Keys of the long options of the table subcommands. */
enum {
    O_RANDOM = CLI_LONG,
    O_SEED,
    O_3D,
    O_THREADS,
    O_JSON,
    O_BACKEND,
    O_KIND,
    O_SYMMETRY,
    O_NODES,
    O_DOMAIN,
    O_X1MIN,
    O_X1MAX,
    O_X2MAX,
    O_CSOURCE,
    O_NAME,
    O_SHARD,
    O_JOURNAL,
    O_FRESH
};

/* A loaded table: either a file (owned) or a built-in view. */
typedef struct {
    ef_tfile_t file;
    const ef_table_t *view;
    const char *name;
} ctab_table_t;

/* Load FILE or resolve @g1 / @g2. */
static int ctab_load(const char *path, ctab_table_t *t)
{
    memset(t, 0, sizeof *t);
    t->name = path;
    if (path[0] == '@') {
        if (strcmp(path, "@g1") && strcmp(path, "@g2"))
            return cli_error(EF_ERR_ARG, "unknown built-in table '%s' (there are @g1 and @g2)",
                             path);
        t->view = cli_default_table(path[2] == '1' ? EF_TABLE_G1_CUBIC : EF_TABLE_G2_QUINTIC);
        if (!t->view)
            return cli_error(EF_ERR_ARG, "this build has no built-in table %s", path);
        return EF_OK;
    }
    ef_msg_t m = {{0}};
    int rc = ef_tfile_load(path, &t->file, &m);
    if (rc != EF_OK)
        return cli_error(rc, "%s", m.text);
    t->view = &t->file.view;
    return EF_OK;
}

static const char *ctab_kind_name(int kind)
{
    return kind == EF_TABLE_G1_CUBIC     ? "G1 cubic"
           : kind == EF_TABLE_G2_QUINTIC ? "G2 quintic"
                                         : "?";
}
static const char *ctab_sym_name(int sym)
{
    return sym == EF_SYM_NONE        ? "none"
           : sym == EF_SYM_G1_FOLD   ? "fold (u,v)"
           : sym == EF_SYM_G2_MIRROR ? "mirror (alpha >= 0)"
                                     : "?";
}

/* Bytes of the file image a view corresponds to. */
static unsigned long ctab_bytes(const ef_table_t *v)
{
    unsigned long prov = (v->provenance_len + 7u) & ~7u;
    return EF_TABLE_HEADER_SIZE + prov + 4ul * v->nodes * v->ndof + 4ul;
}

/* table info FILE */
static int ctab_info(int argc, char **argv)
{
    static const struct option opts[] = {CLI_OPT_HELP, CLI_OPT_END};
    const char *path = NULL;
    cli_getopt_t g;
    cli_getopt_init(&g, "table info", usage, argc, argv, "", opts);
    int c;
    while ((c = cli_getopt(&g)) > CLI_END) {
        if (c == CLI_HELP)
            return EF_OK;
        if (path)
            return cli_error(EF_ERR_ARG, "usage: evenfeed table info FILE");
        path = g.val;
    }
    if (c < 0)
        return c;
    if (!path)
        return cli_error(EF_ERR_ARG, "usage: evenfeed table info FILE");
    ctab_table_t t;
    int rc = ctab_load(path, &t);
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
    printf("kind:       %s (%u axes, %u DOFs per node)\n", ctab_kind_name(v->kind), v->naxes,
           v->ndof);
    printf("symmetry:   %s\n", ctab_sym_name(v->symmetry));
    printf("nodes:      %u (", v->nodes);
    for (int a = 0; a < v->naxes; a++)
        printf("%s%u", a ? " x " : "", v->axis[a].nodes);
    printf(")\nbytes:      %lu (values: %lu)\n", ctab_bytes(v), 4ul * v->nodes * v->ndof);
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
    return EF_OK;
}

/* Print a statistic row. */
static void ctab_print_stat(const char *name, const ef_stat_t *s)
{
    printf("  %-24s mean %.4g  median %.4g  p99 %.4g  max %.4g  (min %.3g)\n", name, s->mean,
           s->median, s->p99, s->max, s->min);
}

/* Print a statistic as a JSON object member. */
static void ctab_json_stat(const char *name, const ef_stat_t *s, int last)
{
    printf("  \"%s\": {\"min\": %.6g, \"mean\": %.6g, \"median\": %.6g, \"p99\": %.6g, \"max\": "
           "%.6g}%s\n",
           name, s->min, s->mean, s->median, s->p99, s->max, last ? "" : ",");
}

/* table verify FILE --random N ... */
static int ctab_verify(int argc, char **argv)
{
    static const struct option opts[] = {{"random", required_argument, NULL, O_RANDOM},
                                         {"seed", required_argument, NULL, O_SEED},
                                         {"3d", no_argument, NULL, O_3D},
                                         {"threads", required_argument, NULL, O_THREADS},
                                         {"json", no_argument, NULL, O_JSON},
                                         CLI_OPT_HELP,
                                         CLI_OPT_END};
    ef_verify_opts_t o = {.count = 0, .seed = 1, .three_d = 0, .threads = 2};
    const char *path = NULL;
    int json = 0, c, npos = 0;
    cli_getopt_t g;
    cli_getopt_init(&g, "table verify", usage, argc, argv, "", opts);
    while ((c = cli_getopt(&g)) > CLI_END) {
        long long n = 0;
        int rc = EF_OK;
        switch (c) {
        case CLI_HELP:
            return EF_OK;
        case O_RANDOM:
            if ((rc = cli_opt_int(&g, 1, 10000000, &n)) == EF_OK)
                o.count = (uint32_t)n;
            break;
        case O_SEED:
            if ((rc = cli_opt_int(&g, 0, LLONG_MAX, &n)) == EF_OK)
                o.seed = (uint64_t)n;
            break;
        case O_3D:
            o.three_d = 1;
            break;
        case O_THREADS:
            if ((rc = cli_opt_int(&g, 1, 64, &n)) == EF_OK)
                o.threads = (int)n;
            break;
        case O_JSON:
            json = 1;
            break;
        case CLI_ARG:
            path = g.val;
            npos++;
            break;
        }
        if (rc != EF_OK)
            return rc;
    }
    if (c < 0)
        return c;
    if (npos != 1 || o.count == 0)
        return cli_error(EF_ERR_ARG, "usage: evenfeed table verify FILE --random N [--seed S] "
                                     "[--3d] [--threads T] [--json]");
    ctab_table_t t;
    int rc = ctab_load(path, &t);
    if (rc != EF_OK)
        return rc;
    ef_verify_result_t r;
    ef_msg_t m = {{0}};
    rc = ef_verify_table(t.view, &o, &r, &m);
    if (rc != EF_OK) {
        ef_tfile_free(&t.file);
        return cli_error(rc, "%s", m.text);
    }
    const ef_table_t *tv = t.view;
    if (json) {
        printf("{\n  \"table\": \"%s\", \"kind\": \"%s\", \"nodes\": %u, \"bytes\": %lu,\n", t.name,
               tv->kind == EF_TABLE_G1_CUBIC ? "g1_cubic" : "g2_quintic", tv->nodes,
               ctab_bytes(tv));
        printf("  \"configurations\": %u, \"seed\": %llu, \"three_d\": %s, \"clamped\": %u, "
               "\"optimizer_misses\": %u,\n",
               r.count, (unsigned long long)o.seed, o.three_d ? "true" : "false", r.clamped,
               r.opt_misses);
        ctab_json_stat("excess", &r.excess, 0);
        ctab_json_stat("x1_error", &r.x1_err, 0);
        ctab_json_stat("x2_error", &r.x2_err, 0);
        printf("  \"worst\": [%.6g, %.6g, %.6g, %.6g], \"seconds\": %.3f\n}\n", r.worst_cfg[0],
               r.worst_cfg[1], r.worst_cfg[2], r.worst_cfg[3], r.seconds);
    } else {
        printf("table %s: %s, %u nodes, %lu bytes\n", t.name, ctab_kind_name(tv->kind), tv->nodes,
               ctab_bytes(tv));
        printf("%u random %s configurations (seed %llu), %u outside the domain, %u optimizer "
               "misses, %.1f s\n",
               r.count, o.three_d ? "3-D (twisted)" : "planar", (unsigned long long)o.seed,
               r.clamped, r.opt_misses, r.seconds);
        ctab_print_stat("relative excess of C", &r.excess);
        ctab_print_stat("relative error of x1", &r.x1_err);
        if (tv->kind == EF_TABLE_G2_QUINTIC)
            ctab_print_stat("relative error of x2", &r.x2_err);
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
    return EF_OK;
}

/* Progress on stderr: at most about once a second, with nodes/s and ETA. The first call
 * gives the nodes resumed from a journal: they count as done, not in the rate. */
typedef struct {
    struct timespec start, last;
    uint32_t base; /* nodes done before this run computed anything */
    int started;
    const char *journal;
} ctab_progress_t;

/* Seconds from a to b. */
static double ctab_since(const struct timespec *a, const struct timespec *b)
{
    return (double)(b->tv_sec - a->tv_sec) + 1e-9 * (double)(b->tv_nsec - a->tv_nsec);
}

/* ef_build_progress_fn for the build command. */
static void ctab_progress(void *ctx, uint32_t done, uint32_t total)
{
    ctab_progress_t *p = ctx;
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
    if (done < total && ctab_since(&p->last, &now) < 1.0)
        return;
    p->last = now;
    double el = ctab_since(&p->start, &now), rate = el > 0 ? (done - p->base) / el : 0;
    fprintf(stderr, "build: %u/%u nodes (%3.0f%%), %.0f nodes/s, ETA %.0f s%s", done, total,
            100.0 * done / total, rate, rate > 0 ? (total - done) / rate : 0.0,
            isatty(2) ? "\r" : "\n");
    if (done == total && isatty(2))
        fputc('\n', stderr);
}

/* Parse "A:B,C:D,..." into n ranges. */
static int ctab_domain(const char *s, double *lo, double *hi, int n)
{
    char buf[512], pbuf[128], *range[EF_TABLE_MAX_AXES], *end[2];
    if (cli_split(s, ',', buf, sizeof buf, range, EF_TABLE_MAX_AXES) != n)
        return EF_ERR_ARG;
    for (int a = 0; a < n; a++)
        if (cli_split(range[a], ':', pbuf, sizeof pbuf, end, 2) != 2 ||
            cli_parse_double(end[0], &lo[a]) != EF_OK || cli_parse_double(end[1], &hi[a]) != EF_OK)
            return EF_ERR_ARG;
    return EF_OK;
}

/* Parse the node counts "AxB[xCxD]": n counts of 2..EF_TABLE_MAX_AXIS_NODES. */
static int ctab_nodes(const char *s, uint32_t *nodes, int n)
{
    char buf[128], *count[EF_TABLE_MAX_AXES];
    if (cli_split(s, 'x', buf, sizeof buf, count, EF_TABLE_MAX_AXES) != n)
        return EF_ERR_ARG;
    for (int a = 0; a < n; a++) {
        long long v;
        if (cli_parse_int(count[a], 2, EF_TABLE_MAX_AXIS_NODES, &v) != EF_OK)
            return EF_ERR_ARG;
        nodes[a] = (uint32_t)v;
    }
    return EF_OK;
}

/* Shortest "%.Ng" text that reads back as the same double (10 -> "10", not "1e+01"), so
 * equal values always print the same and the provenance does not depend on how a number
 * was typed (0.10 vs .1). */
static void ctab_fmt_double(char *buf, size_t size, double v)
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
static void ctab_provenance(char *prov, size_t size, const char *backend, const ef_tfile_spec_t *s)
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
            ctab_fmt_double(num, sizeof num, s->lo[a]);
            len += snprintf(prov + len, size - (size_t)len, "%s%s:", a ? "," : "", num);
            ctab_fmt_double(num, sizeof num, s->hi[a]);
            if (len < (int)size)
                len += snprintf(prov + len, size - (size_t)len, "%s", num);
        }
    }
    static const char *const names[] = {"--x1-min", "--x1-max", "--x2-max"};
    const double vals[] = {s->x1_min, s->x1_max, s->x2_max};
    for (int k = 0; k < (g2 ? 3 : 2) && len < (int)size; k++) {
        ctab_fmt_double(num, sizeof num, vals[k]);
        len += snprintf(prov + len, size - (size_t)len, " %s %s", names[k], num);
    }
}

/* Write C source atomically (temporary file, rename), so an interrupted emit never leaves a
 * half-written source that a firmware build would pick up. */
static int ctab_emit_c_file(const ef_tfile_t *t, const char *name, const char *path, ef_msg_t *m)
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
static int ctab_check_out(const char *path, const char *what)
{
    struct stat st;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        return cli_error(EF_ERR_IO, "%s %s: is a directory", what, path);
    char dir[4096];
    const char *slash = strrchr(path, '/');
    if (!slash)
        snprintf(dir, sizeof dir, ".");
    else
        snprintf(dir, sizeof dir, "%.*s", slash == path ? 1 : (int)(slash - path), path);
    if (access(dir, W_OK | X_OK) != 0)
        return cli_error(EF_ERR_IO, "%s %s: cannot write in directory %s: %s", what, path, dir,
                         strerror(errno));
    return EF_OK;
}

/* Open the backend named on the command line (after every check has passed). */
static int ctab_open_backend(const char *name, int threads, ef_build_backend_t *b, ef_msg_t *m)
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
static int ctab_build(int argc, char **argv)
{
    static const struct option opts[] = {{"backend", required_argument, NULL, O_BACKEND},
                                         {"kind", required_argument, NULL, O_KIND},
                                         {"symmetry", required_argument, NULL, O_SYMMETRY},
                                         {"nodes", required_argument, NULL, O_NODES},
                                         {"domain", required_argument, NULL, O_DOMAIN},
                                         {"x1-min", required_argument, NULL, O_X1MIN},
                                         {"x1-max", required_argument, NULL, O_X1MAX},
                                         {"x2-max", required_argument, NULL, O_X2MAX},
                                         {"threads", required_argument, NULL, O_THREADS},
                                         {"output", required_argument, NULL, 'o'},
                                         {"c-source", required_argument, NULL, O_CSOURCE},
                                         {"name", required_argument, NULL, O_NAME},
                                         {"shard", required_argument, NULL, O_SHARD},
                                         {"journal", required_argument, NULL, O_JOURNAL},
                                         {"fresh", no_argument, NULL, O_FRESH},
                                         CLI_OPT_HELP,
                                         CLI_OPT_END};
    const char *backend = "cpu", *kind = NULL, *sym = NULL, *nodes = NULL, *domain = NULL,
               *out = NULL, *csrc = NULL, *name = NULL, *shard = NULL, *journal = NULL;
    double x1min = 0.1, x1max = 10, x2max = 100;
    long long thr = 2;
    int c, rc, fresh = 0;
    cli_getopt_t g;
    cli_getopt_init(&g, "table build", usage, argc, argv, "o:", opts);
    while ((c = cli_getopt(&g)) > CLI_END) {
        rc = EF_OK;
        switch (c) {
        case CLI_HELP:
            return EF_OK;
        case O_BACKEND:
            backend = g.val;
            break;
        case O_KIND:
            kind = g.val;
            break;
        case O_SYMMETRY:
            sym = g.val;
            break;
        case O_NODES:
            nodes = g.val;
            break;
        case O_DOMAIN:
            domain = g.val;
            break;
        case O_X1MIN:
            rc = cli_opt_double(&g, &x1min);
            break;
        case O_X1MAX:
            rc = cli_opt_double(&g, &x1max);
            break;
        case O_X2MAX:
            rc = cli_opt_double(&g, &x2max);
            break;
        case O_THREADS:
            rc = cli_opt_int(&g, 1, 64, &thr);
            break;
        case 'o':
            out = g.val;
            break;
        case O_CSOURCE:
            csrc = g.val;
            break;
        case O_NAME:
            name = g.val;
            break;
        case O_SHARD:
            shard = g.val;
            break;
        case O_JOURNAL:
            journal = g.val;
            break;
        case O_FRESH:
            fresh = 1;
            break;
        case CLI_ARG:
            return cli_error(EF_ERR_ARG, "table build: unexpected argument '%s'", g.val);
        }
        if (rc != EF_OK)
            return rc;
    }
    if (c < 0)
        return c;
    if (strcmp(backend, "cpu") && strcmp(backend, "gl"))
        return cli_error(EF_ERR_ARG, "table build: unknown backend '%s' (cpu or gl)", backend);
    if (!kind || (strcmp(kind, "g1") && strcmp(kind, "g2")))
        return cli_error(EF_ERR_ARG, "table build: --kind g1 or g2 is required");
    if (!nodes || !out)
        return cli_error(EF_ERR_ARG, "table build: --nodes and -o are required");
    if ((csrc == NULL) != (name == NULL))
        return cli_error(EF_ERR_ARG, "table build: --c-source and --name go together");
    if (csrc && shard)
        return cli_error(EF_ERR_ARG, "table build: --c-source needs the whole table; give it "
                                     "to 'table merge' when building shards");
    ef_msg_t m = {{0}};
    ef_build_opts_t bo;
    memset(&bo, 0, sizeof bo);
    if (shard && ef_build_shard_parse(shard, &bo.shard, &m) != EF_OK)
        return cli_error(EF_ERR_ARG, "%s", m.text);
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
        return cli_error(
            EF_ERR_ARG,
            "table build: --symmetry %s does not apply to %s (g1: none|fold, g2: none|mirror)", sym,
            kind);
    if (ctab_nodes(nodes, spec.nodes, naxes) != EF_OK)
        return cli_error(EF_ERR_ARG, "--nodes: '%s' is not %d counts of 2..%u joined by 'x'", nodes,
                         naxes, EF_TABLE_MAX_AXIS_NODES);
    uint64_t total = 1;
    for (int a = 0; a < naxes; a++)
        total *= spec.nodes[a];
    if (total > EF_TABLE_MAX_NODES)
        return cli_error(EF_ERR_TBL_SIZE,
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
            return cli_error(EF_ERR_ARG,
                             "--domain: a fold table always covers its fixed fundamental region");
        if (ctab_domain(domain, spec.lo, spec.hi, naxes) != EF_OK)
            return cli_error(EF_ERR_ARG, "--domain: '%s' is not %d ranges LO:HI joined by ','",
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
    ctab_provenance(prov, sizeof prov, backend, &spec);
    spec.provenance = prov;

    /* Every check before the backend opens: spec (domain, counts, bounds), shard, paths,
     * an existing journal. A GPU is touched only for a build that can finish. */
    ef_tfile_t t;
    rc = ef_tfile_create(&t, &spec, &m);
    if (rc != EF_OK)
        return cli_error(rc, "table build: %s", m.text);
    char jpath[4200];
    if (!journal) {
        if (snprintf(jpath, sizeof jpath, "%s.partial", out) >= (int)sizeof jpath) {
            ef_tfile_free(&t);
            return cli_error(EF_ERR_ARG, "-o: path too long");
        }
        journal = jpath;
    }
    bo.journal = journal;
    bo.fresh = fresh;
    bo.output = out;
    ef_build_plan_t plan;
    rc = ef_build_check(&t, backend, &bo, &plan, &m);
    if (rc == EF_OK && csrc && (rc = ctab_check_out(csrc, "--c-source")) != 0) {
        ef_tfile_free(&t);
        return rc;
    }
    if (rc != EF_OK) {
        ef_tfile_free(&t);
        return cli_error(rc, "table build: %s", m.text);
    }
    if (bo.shard.count)
        fprintf(stderr, "build: shard %u/%u: rows %u..%u of %u (%u nodes)\n", bo.shard.index,
                bo.shard.count, plan.row_begin, plan.row_end - 1, plan.rows,
                (plan.row_end - plan.row_begin) * plan.n0);
    ef_build_backend_t b;
    rc = ctab_open_backend(backend, (int)thr, &b, &m);
    if (rc != EF_OK) {
        ef_tfile_free(&t);
        return cli_error(rc, "table build: %s", m.text);
    }
    ctab_progress_t pr = {.journal = journal};
    bo.progress = ctab_progress;
    bo.progress_ctx = &pr;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    rc = ef_build_run(&t, &b, &bo, &m);
    if (b.close)
        b.close(b.ctx);
    if (rc == EF_OK && csrc) {
        rc = ctab_emit_c_file(&t, name, csrc, &m);
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
        return cli_error(rc, "table build: %s", m.text);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    fprintf(stderr, "build: wrote %s%s%s (%.1f s)\n", out, csrc ? " and " : "", csrc ? csrc : "",
            ctab_since(&t0, &t1));
    return EF_OK;
}

/* Check the outputs, merge n shards into out (and the C source csrc with name). */
static int ctab_merge_write(const char *out, const char *csrc, const char *name,
                            const char *const *shards, uint32_t n)
{
    if (!out || n == 0)
        return cli_error(
            EF_ERR_ARG,
            "usage: evenfeed table merge -o OUT.eft [--c-source OUT.c --name IDENT] SHARD...");
    if ((csrc == NULL) != (name == NULL))
        return cli_error(EF_ERR_ARG, "table merge: --c-source and --name go together");
    int rc = ctab_check_out(out, "-o");
    if (rc == EF_OK && csrc)
        rc = ctab_check_out(csrc, "--c-source");
    if (rc != EF_OK)
        return rc;
    ef_tfile_t t;
    ef_msg_t m = {{0}};
    rc = ef_shard_merge(shards, n, &t, &m);
    if (rc == EF_OK)
        rc = ef_tfile_write(&t, out, &m);
    if (rc == EF_OK && csrc)
        rc = ctab_emit_c_file(&t, name, csrc, &m);
    ef_tfile_free(&t);
    if (rc != EF_OK)
        return cli_error(rc, "table merge: %s", m.text);
    fprintf(stderr, "merge: %u shards -> %s%s%s\n", (unsigned)n, out, csrc ? " and " : "",
            csrc ? csrc : "");
    return EF_OK;
}

/* table merge -o OUT.eft [--c-source OUT.c --name IDENT] SHARD... */
static int ctab_merge(int argc, char **argv)
{
    static const struct option opts[] = {{"output", required_argument, NULL, 'o'},
                                         {"c-source", required_argument, NULL, O_CSOURCE},
                                         {"name", required_argument, NULL, O_NAME},
                                         CLI_OPT_HELP,
                                         CLI_OPT_END};
    const char *out = NULL, *csrc = NULL, *name = NULL;
    /* The shards: the positional arguments, wherever they are among the options. */
    const char **shards = calloc((size_t)argc, sizeof *shards);
    if (!shards)
        return cli_error(EF_ERR_NOMEM, "table merge: out of memory");
    uint32_t n = 0;
    cli_getopt_t g;
    cli_getopt_init(&g, "table merge", usage, argc, argv, "o:", opts);
    int c;
    while ((c = cli_getopt(&g)) > CLI_END && c != CLI_HELP) {
        if (c == 'o')
            out = g.val;
        else if (c == O_CSOURCE)
            csrc = g.val;
        else if (c == O_NAME)
            name = g.val;
        else
            shards[n++] = g.val; /* CLI_ARG */
    }
    int rc = c < 0 ? c : c == CLI_HELP ? EF_OK : ctab_merge_write(out, csrc, name, shards, n);
    free(shards);
    return rc;
}

/* table emit-c FILE --name IDENT -o OUT.c */
static int ctab_emit(int argc, char **argv)
{
    static const struct option opts[] = {{"name", required_argument, NULL, O_NAME},
                                         {"output", required_argument, NULL, 'o'},
                                         CLI_OPT_HELP,
                                         CLI_OPT_END};
    const char *name = NULL, *out = NULL, *path = NULL;
    int c, npos = 0;
    cli_getopt_t g;
    cli_getopt_init(&g, "table emit-c", usage, argc, argv, "o:", opts);
    while ((c = cli_getopt(&g)) > CLI_END) {
        if (c == CLI_HELP)
            return EF_OK;
        if (c == O_NAME)
            name = g.val;
        else if (c == 'o')
            out = g.val;
        else if (npos++ == 0)
            path = g.val; /* CLI_ARG */
    }
    if (c < 0)
        return c;
    if (npos != 1 || !name || !out)
        return cli_error(EF_ERR_ARG, "usage: evenfeed table emit-c FILE --name IDENT -o OUT.c");
    ef_tfile_t t;
    ef_msg_t m = {{0}};
    int rc = ef_tfile_load(path, &t, &m);
    if (rc != EF_OK)
        return cli_error(rc, "%s", m.text);
    rc = ctab_emit_c_file(&t, name, out, &m);
    ef_tfile_free(&t);
    return rc == EF_OK ? EF_OK : cli_error(rc, "%s", m.text);
}

static const cli_cmd_t ctab_cmds[] = {
    {"info", ctab_info, "a table file's header: kind, axes, nodes, bounds, provenance"},
    {"verify", ctab_verify, "accuracy against the reference optimizer on random configurations"},
    {"build", ctab_build, "compute a table (or one shard of it), resumable"},
    {"merge", ctab_merge, "join the shards of a build into its table"},
    {"emit-c", ctab_emit, "a table file as C source for a firmware build"},
    {NULL, NULL, NULL}};

/* evenfeed table SUBCOMMAND ... */
int cli_cmd_table(int argc, char **argv)
{
    if (argc < 2) {
        fputs(usage, stderr);
        return EF_ERR_ARG;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
        fputs(usage, stdout);
        return EF_OK;
    }
    const cli_cmd_t *c = cli_cmd_find(ctab_cmds, argv[1]);
    if (!c) {
        fputs(usage, stderr);
        return cli_error(EF_ERR_ARG, "table: unknown subcommand '%s'", argv[1]);
    }
    return c->fn(argc - 1, argv + 1);
}
