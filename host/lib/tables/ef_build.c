/* SPDX-License-Identifier: Apache-2.0 */
/* Table building: node configurations, storage, the CPU backend, and the chunked driver
 * with its journal of finished chunks (layout: docs/table-build.md). */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>
#include "evenfeed/host/tables/ef_build.h"
#include "evenfeed/host/tables/ef_ref.h"
#include "core/ef_parallel_int.h"
#include "tables/ef_shard_int.h"

/* How far inside the fold region its edge nodes are optimized (rad): far above the
 * optimizer's tie tolerance (1e-9 relative in C^2), far below the grid spacing. */
#define EF_BUILD_EDGE_NUDGE 1e-6

/* Node configuration, with the fold-edge nudge (see ef_build.h). */
void ef_build_node_config(const ef_tfile_t *t, uint32_t node, double cfg[EF_TABLE_MAX_AXES])
{
    memset(cfg, 0, sizeof(double) * EF_TABLE_MAX_AXES);
    ef_tfile_node_config(t, node, cfg);
    if (t->view.symmetry != EF_SYM_G1_FOLD)
        return;
    const uint32_t n0 = t->view.axis[0].nodes, n1 = t->view.axis[1].nodes;
    const uint32_t i = node % n0, j = node / n0;
    double u = t->lo[0] + (t->hi[0] - t->lo[0]) * i / (n0 - 1);
    double v = t->lo[1] + (t->hi[1] - t->lo[1]) * j / (n1 - 1);
    u += (i == 0 ? EF_BUILD_EDGE_NUDGE : 0) - (i == n0 - 1 ? EF_BUILD_EDGE_NUDGE : 0);
    v += (j == 0 ? EF_BUILD_EDGE_NUDGE : 0) - (j == n1 - 1 ? EF_BUILD_EDGE_NUDGE : 0);
    cfg[0] = u + v;
    cfg[1] = u - v;
}

/* Float value kept inside [lo, hi], which float rounding could otherwise cross. */
static float bld_clampf(double v, double lo, double hi)
{
    float f = (float)v;
    if (f < (float)lo)
        f = (float)lo;
    if (f > (float)hi)
        f = (float)hi;
    return f;
}

/* The table's bounds on top of the reference defaults. */
void ef_build_ref_opts(const ef_tfile_t *t, ef_ref_opts_t *o)
{
    ef_ref_opts_default(o);
    o->x1_min = t->x1_min;
    o->x1_max = t->x1_max;
    if (t->view.kind == EF_TABLE_G2_QUINTIC)
        o->x2_max = t->x2_max;
}

/* x1 DOFs between the x1 bounds, x2 DOFs within +-x2_max. */
void ef_build_store(ef_tfile_t *t, uint32_t node, const double *dof)
{
    float *v = t->values + (size_t)node * t->view.ndof;
    const int g2 = t->view.kind == EF_TABLE_G2_QUINTIC;
    for (int k = 0; k < t->view.ndof; k++) {
        int is_x2 = g2 && (k == 1 || k == 3);
        v[k] = is_x2 ? bld_clampf(dof[k], -t->x2_max, t->x2_max)
                     : bld_clampf(dof[k], t->x1_min, t->x1_max);
    }
}

/* Optimize one node at chord 1 and store its DOFs; warm is the previous node's, or NULL. */
static int bld_node(ef_tfile_t *t, uint32_t node, const double *warm, double *dof_out, ef_msg_t *m)
{
    double cfg[EF_TABLE_MAX_AXES];
    ef_build_node_config(t, node, cfg);
    const int g2 = t->view.kind == EF_TABLE_G2_QUINTIC;
    ef_dend_t e0, e1;
    ef_ref_config(cfg[0], cfg[1], g2 ? cfg[2] : 0, g2 ? cfg[3] : 0, &e0, &e1);
    ef_ref_opts_t o;
    ef_build_ref_opts(t, &o);
    o.warm = warm;
    ef_ref_result_t r;
    ef_msg_t sub = {{0}};
    int rc = ef_ref_optimize(g2 ? EF_REF_G2_QUINTIC : EF_REF_G1_CUBIC, &e0, &e1, &o, &r, &sub);
    if (rc != EF_OK)
        return ef_fail(m, rc, "node %u (alpha %.6g beta %.6g k0 %.6g k1 %.6g): %s", node, cfg[0],
                       cfg[1], cfg[2], cfg[3], sub.text);
    ef_build_store(t, node, r.dof);
    memcpy(dof_out, r.dof, sizeof(double) * (size_t)t->view.ndof);
    return EF_OK;
}

typedef struct {
    int threads;
} ef_cpu_ctx_t;

typedef struct {
    ef_job_t job; /* first: ef_parallel_run() reads it */
    ef_tfile_t *t;
    uint32_t row_begin, row_end, stride;
} ef_cpu_job_t;

/* Worker: rows row_begin + index, + threads, ...; each row in order so warm starts are fixed. */
static void *bld_cpu_worker(void *arg)
{
    ef_cpu_job_t *j = arg;
    const uint32_t n0 = j->t->view.axis[0].nodes;
    for (uint32_t row = j->row_begin; row < j->row_end; row += j->stride) {
        double prev[EF_TABLE_MAX_DOF];
        for (uint32_t i = 0; i < n0; i++) {
            j->job.rc = bld_node(j->t, row * n0 + i, i ? prev : NULL, prev, &j->job.msg);
            if (j->job.rc != EF_OK)
                return NULL;
        }
    }
    return NULL;
}

/* CPU backend: threads over the rows of [row_begin, row_end); first failure by thread order. */
static int bld_cpu_solve_rows(void *ctx, ef_tfile_t *t, uint32_t row_begin, uint32_t row_end,
                              ef_msg_t *m)
{
    const ef_cpu_ctx_t *c = ctx;
    ef_cpu_job_t job[64];
    for (int i = 0; i < c->threads; i++)
        job[i] = (ef_cpu_job_t){.t = t,
                                .row_begin = row_begin + (uint32_t)i,
                                .row_end = row_end,
                                .stride = (uint32_t)c->threads};
    return ef_parallel_run(job, sizeof job[0], c->threads, bld_cpu_worker, "build", NULL, m);
}

/* Release the CPU backend's context. */
static void bld_cpu_close(void *ctx)
{
    free(ctx);
}

/* CPU backend with a thread count. */
int ef_build_backend_cpu(ef_build_backend_t *b, int threads)
{
    if (!b || threads < 1 || threads > 64)
        return EF_ERR_ARG;
    ef_cpu_ctx_t *c = malloc(sizeof *c);
    if (!c)
        return EF_ERR_NOMEM;
    c->threads = threads;
    *b = (ef_build_backend_t){.name = "cpu",
                              .solve_rows = bld_cpu_solve_rows,
                              .close = bld_cpu_close,
                              .ctx = c,
                              .chunk_nodes = 4096};
    return EF_OK;
}

/* ---- Journal of finished chunks --------------------------------------------------------
 * Header (ef_efile_put_header(), magic "EFJN") then one record per finished chunk:
 * "EFJR", row_begin, row_end, CRC-32 of those 12 bytes, the rows' values (float32 LE),
 * CRC-32 of the values. Records are appended and fsync'ed one at a time. */
#define EF_JREC_HEAD 16u
static const uint8_t ef_jrec_tag[4] = {0x45, 0x46, 0x4A, 0x52}; /* "EFJR" */

/* What a journal holds for the shard being built. */
typedef struct {
    uint8_t *done;      /* per row of the shard: 1 once its values are final */
    uint32_t rows_done; /* rows marked in done */
    uint32_t chunks;    /* records */
    size_t valid_len;   /* journal bytes up to the end of the last whole, good record */
} ef_jstate_t;

/* Common checks of ef_build_check() and ef_build_run(): the shard, the spec record, the
 * paths. Fills the header a journal of this build has. */
static int bld_prepare(const ef_tfile_t *t, const char *backend, const ef_build_opts_t *o,
                       ef_efile_hdr_t *h, ef_msg_t *m)
{
    memset(h, 0, sizeof *h);
    if (!t || !t->values || !o || t->view.axis[0].nodes == 0)
        return ef_fail(m, EF_ERR_ARG, "build: bad table or options");
    int rc = ef_build_shard_rows(t, &o->shard, &h->row_begin, &h->row_end, m);
    if (rc != EF_OK)
        return rc;
    h->index = o->shard.count ? o->shard.index : 0;
    h->count = o->shard.count;
    rc = ef_spec_from_table(t, backend, &h->spec, m);
    if (rc == EF_OK && o->output)
        rc = ef_file_check_writable(o->output, "output", m);
    if (rc == EF_OK && o->journal) {
        if (o->output && !strcmp(o->output, o->journal))
            return ef_fail(m, EF_ERR_ARG, "journal %s: the same path as the output", o->journal);
        rc = ef_file_check_writable(o->journal, "journal", m);
    }
    return rc;
}

/* The bytes [p, p + n) are all zero: what a crash between a record's write and its fsync
 * can leave (the file grew, the data never landed), unlike a flipped bit. */
static int bld_all_zero(const uint8_t *p, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (p[i])
            return 0;
    return 1;
}

/* Refuse a damaged journal, saying how to get past it. */
static int bld_journal_corrupt(ef_msg_t *m, int code, const char *path, const char *detail)
{
    return ef_fail(m, code,
                   "%s: corrupt build journal (%s); it cannot be resumed: delete it or "
                   "pass --fresh to start this build over",
                   path, detail);
}

/* Check a journal image against this build and collect its records (values into t when t
 * is not NULL). A record cut short at the end of the file (a crash mid-append) is dropped,
 * anything else that fails a check refuses the journal. */
static int bld_journal_scan(const char *path, const uint8_t *buf, size_t len,
                            const ef_efile_hdr_t *want, ef_tfile_t *t, ef_jstate_t *js, ef_msg_t *m)
{
    ef_efile_hdr_t h;
    ef_msg_t sub = {{0}};
    char detail[440];
    int rc = ef_efile_get_header(path, buf, len, ef_magic_journal, "build journal", &h, &sub);
    if (rc == EF_ERR_TBL_MAGIC)
        return ef_fail(m, rc,
                       "%s; refusing to overwrite it: remove it or choose another "
                       "--journal",
                       sub.text);
    if (rc != EF_OK)
        return ef_fail(m, rc,
                       "%.400s; it cannot be resumed: delete it or pass --fresh to start "
                       "this build over",
                       sub.text);
    if (ef_spec_diff(&want->spec, &h.spec, detail, sizeof detail))
        return ef_fail(m, EF_ERR_ARG,
                       "%s: journal of a different build (this build vs the "
                       "journal: %.330s); pass --fresh to discard it, or --journal to use another "
                       "file",
                       path, detail);
    if (h.index != want->index || h.count != want->count) {
        char a[40], b[40];
        snprintf(a, sizeof a, want->count ? "shard %u/%u" : "the whole table", want->index,
                 want->count);
        snprintf(b, sizeof b, h.count ? "shard %u/%u" : "the whole table", h.index, h.count);
        return ef_fail(m, EF_ERR_ARG,
                       "%s: journal of a different build (%s; this build is %s); "
                       "pass --fresh to discard it, or --journal to use another file",
                       path, b, a);
    }
    const uint32_t rb = want->row_begin, re = want->row_end;
    const size_t per_row = (size_t)want->spec.axis_nodes[0] * want->spec.ndof;
    size_t off = h.header_len;
    for (uint32_t rec = 1; off < len; rec++) {
        const uint8_t *r = buf + off;
        const size_t left = len - off;
        if (left < EF_JREC_HEAD)
            break; /* torn record header */
        const uint32_t r0 = ef_le_get32(r + 4), r1 = ef_le_get32(r + 8);
        if (memcmp(r, ef_jrec_tag, 4) || ef_le_get32(r + 12) != ef_crc32(0, r, 12)) {
            if (bld_all_zero(r, left))
                break;
            snprintf(detail, sizeof detail, "record %u at offset %zu: bad record header", rec, off);
            return bld_journal_corrupt(m, EF_ERR_TBL_CRC, path, detail);
        }
        if (r0 >= r1 || r0 < rb || r1 > re) {
            snprintf(detail, sizeof detail,
                     "record %u at offset %zu: rows %u..%u outside the build's rows %u..%u", rec,
                     off, r0, r1 - 1, rb, re - 1);
            return bld_journal_corrupt(m, EF_ERR_TBL_HEADER, path, detail);
        }
        const size_t nval = (size_t)(r1 - r0) * per_row, need = EF_JREC_HEAD + 4 * nval + 4;
        if (left < need)
            break; /* torn record body */
        const uint8_t *v = r + EF_JREC_HEAD;
        if (ef_le_get32(v + 4 * nval) != ef_crc32(0, v, (uint32_t)(4 * nval))) {
            if (off + need == len && bld_all_zero(v, 4 * nval + 4))
                break;
            snprintf(detail, sizeof detail,
                     "record %u at offset %zu (rows %u..%u): values CRC "
                     "mismatch",
                     rec, off, r0, r1 - 1);
            return bld_journal_corrupt(m, EF_ERR_TBL_CRC, path, detail);
        }
        for (uint32_t row = r0; row < r1; row++)
            if (js->done[row - rb]) {
                snprintf(detail, sizeof detail, "record %u at offset %zu: row %u recorded twice",
                         rec, off, row);
                return bld_journal_corrupt(m, EF_ERR_TBL_HEADER, path, detail);
            }
        const size_t bad = ef_values_check(&want->spec, v, NULL, nval);
        if (bad < nval) {
            snprintf(detail, sizeof detail, "record %u: value at offset %zu out of bounds", rec,
                     off + EF_JREC_HEAD + 4 * bad);
            return bld_journal_corrupt(m, EF_ERR_TBL_VALUE, path, detail);
        }
        if (t) {
            float *dst = t->values + (size_t)r0 * per_row;
            for (size_t i = 0; i < nval; i++) {
                uint32_t u = ef_le_get32(v + 4 * i);
                memcpy(&dst[i], &u, sizeof u);
            }
        }
        memset(js->done + (r0 - rb), 1, r1 - r0);
        js->rows_done += r1 - r0;
        js->chunks++;
        off += need;
    }
    js->valid_len = off;
    return EF_OK;
}

/* --fresh deletes only what is recognizably a journal: a mistyped --journal must not cost
 * the user an unrelated file. EF_OK when path is absent or starts with the journal magic. */
static int bld_journal_deletable(const char *path, ef_msg_t *m)
{
    uint8_t head[8];
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return errno == ENOENT
                   ? EF_OK
                   : ef_fail(m, EF_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    ssize_t n = read(fd, head, sizeof head);
    (void)close(fd);
    if (n != (ssize_t)sizeof head || memcmp(head, ef_magic_journal, sizeof head))
        return ef_fail(m, EF_ERR_TBL_MAGIC,
                       "%s: not a build journal; refusing to delete it for "
                       "--fresh: remove it yourself or choose another --journal",
                       path);
    return EF_OK;
}

/* Largest journal a build can have: header, and at most one record per row. */
static size_t bld_journal_max(const ef_efile_hdr_t *h)
{
    const size_t rows = h->row_end - h->row_begin;
    return EF_EFILE_MAX_HEADER +
           rows * (EF_JREC_HEAD + 4 + 4 * (size_t)h->spec.axis_nodes[0] * h->spec.ndof);
}

/* Validate without a backend: nothing here starts a GPU or writes a file. */
int ef_build_check(const ef_tfile_t *t, const char *backend, const ef_build_opts_t *o,
                   ef_build_plan_t *plan, ef_msg_t *m)
{
    ef_efile_hdr_t h;
    int rc = bld_prepare(t, backend, o, &h, m);
    if (rc != EF_OK)
        return rc;
    ef_build_plan_t p = {.rows = h.spec.rows,
                         .row_begin = h.row_begin,
                         .row_end = h.row_end,
                         .n0 = h.spec.axis_nodes[0]};
    struct stat st;
    if (o->journal && o->fresh)
        rc = bld_journal_deletable(o->journal, m);
    if (rc == EF_OK && o->journal && !o->fresh && stat(o->journal, &st) == 0) {
        uint8_t *buf;
        size_t len;
        ef_jstate_t js = {.done = calloc(h.row_end - h.row_begin, 1)};
        if (!js.done)
            return ef_fail(m, EF_ERR_NOMEM, "build: out of memory");
        rc = ef_file_read(o->journal, bld_journal_max(&h), &buf, &len, m);
        if (rc == EF_ERR_TBL_SIZE)
            rc = bld_journal_corrupt(m, rc, o->journal, "larger than any journal of this build");
        if (rc == EF_OK) {
            rc = bld_journal_scan(o->journal, buf, len, &h, NULL, &js, m);
            free(buf);
        }
        free(js.done);
        p.journal_exists = 1;
        p.rows_done = js.rows_done;
        p.chunks_done = js.chunks;
    }
    if (plan)
        *plan = p;
    return rc;
}

/* Open (or create) the journal, lock it against a second build, load what it holds into t
 * and cut off a torn last record; *fd is left positioned for appending. */
static int bld_journal_open(const char *path, int fresh, const ef_efile_hdr_t *h, ef_tfile_t *t,
                            ef_jstate_t *js, int *fd_out, ef_msg_t *m)
{
    int err;
    *fd_out = -1;
    if (fresh) {
        int rc = bld_journal_deletable(path, m);
        if (rc != EF_OK)
            return rc;
        if (unlink(path) != 0 && errno != ENOENT) {
            err = errno;
            return ef_fail(m, EF_ERR_IO, "%s: cannot remove the old journal: %s", path,
                           strerror(err));
        }
    }
    int fd = open(path, O_RDWR | O_CLOEXEC);
    if (fd < 0 && errno == ENOENT) {
        /* Created whole by rename, so a journal never exists with a torn header. */
        uint8_t hdr[EF_EFILE_MAX_HEADER];
        size_t n = ef_efile_put_header(hdr, ef_magic_journal, h);
        int rc = ef_file_write_atomic(path, hdr, n, m);
        if (rc != EF_OK)
            return rc;
        fd = open(path, O_RDWR | O_CLOEXEC);
    }
    if (fd < 0) {
        err = errno;
        return ef_fail(m, EF_ERR_IO, "%s: cannot open the journal: %s", path, strerror(err));
    }
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
        err = errno;
        (void)close(fd);
        return ef_fail(m, EF_ERR_IO,
                       "%s: journal in use by another build (%s); wait for it or "
                       "give this build another --journal",
                       path, strerror(err));
    }
    uint8_t *buf;
    size_t len;
    int rc = ef_file_read(path, bld_journal_max(h), &buf, &len, m);
    if (rc == EF_ERR_TBL_SIZE)
        rc = bld_journal_corrupt(m, rc, path, "larger than any journal of this build");
    if (rc == EF_OK) {
        rc = bld_journal_scan(path, buf, len, h, t, js, m);
        free(buf);
    }
    if (rc == EF_OK && js->valid_len < len &&
        (ftruncate(fd, (off_t)js->valid_len) != 0 || fsync(fd) != 0)) {
        err = errno;
        rc = ef_fail(m, EF_ERR_IO, "%s: cannot cut the journal's torn last record: %s", path,
                     strerror(err));
    }
    if (rc == EF_OK && lseek(fd, 0, SEEK_END) < 0) {
        err = errno;
        rc = ef_fail(m, EF_ERR_IO, "%s: seek: %s", path, strerror(err));
    }
    if (rc != EF_OK) {
        (void)close(fd);
        return rc;
    }
    *fd_out = fd;
    return EF_OK;
}

/* Append one chunk's record and make it durable before the chunk counts as done; a failed
 * append is cut off again so the journal stays a sequence of whole records. */
static int bld_journal_append(int fd, const char *path, const ef_tfile_t *t, uint32_t r0,
                              uint32_t r1, size_t *jlen, ef_msg_t *m)
{
    const size_t per_row = (size_t)t->view.axis[0].nodes * t->view.ndof;
    const size_t nval = (size_t)(r1 - r0) * per_row, n = EF_JREC_HEAD + 4 * nval + 4;
    uint8_t *rec = malloc(n);
    if (!rec)
        return ef_fail(m, EF_ERR_NOMEM, "%s: out of memory for a journal record", path);
    memcpy(rec, ef_jrec_tag, 4);
    ef_le_put32(rec + 4, r0);
    ef_le_put32(rec + 8, r1);
    ef_le_put32(rec + 12, ef_crc32(0, rec, 12));
    const float *v = t->values + (size_t)r0 * per_row;
    for (size_t i = 0; i < nval; i++) {
        uint32_t u;
        memcpy(&u, &v[i], sizeof u);
        ef_le_put32(rec + EF_JREC_HEAD + 4 * i, u);
    }
    ef_le_put32(rec + n - 4, ef_crc32(0, rec + EF_JREC_HEAD, (uint32_t)(4 * nval)));
    int rc = EF_OK;
    size_t done = 0;
    while (done < n) {
        ssize_t w = write(fd, rec + done, n - done);
        if (w < 0 && errno == EINTR)
            continue;
        if (w < 0)
            break;
        done += (size_t)w;
    }
    if (done < n || fdatasync(fd) != 0) {
        int err = errno;
        if (ftruncate(fd, (off_t)*jlen) == 0)
            (void)lseek(fd, 0, SEEK_END);
        rc = ef_fail(m, EF_ERR_IO, "%s: cannot append to the journal: %s", path, strerror(err));
    } else {
        *jlen += n;
    }
    free(rec);
    return rc;
}

/* First invalid value among nodes [n_begin, n_end) of t, or SIZE_MAX if all are good. */
static size_t bld_bad_value(const ef_spec_rec_t *s, const ef_tfile_t *t, uint32_t n_begin,
                            uint32_t n_end)
{
    const size_t nval = (size_t)(n_end - n_begin) * t->view.ndof;
    const size_t bad = ef_values_check(s, NULL, t->values + (size_t)n_begin * t->view.ndof, nval);
    return bad < nval ? (size_t)n_begin * t->view.ndof + bad : SIZE_MAX;
}

/* Journal (resume), chunks, output, journal removal; see ef_build.h for the contract. */
int ef_build_run(ef_tfile_t *t, ef_build_backend_t *b, const ef_build_opts_t *o, ef_msg_t *m)
{
    static const ef_build_opts_t defaults;
    if (!o)
        o = &defaults;
    if (!t || !t->values || !b || !b->solve_rows)
        return ef_fail(m, EF_ERR_ARG, "build: bad table or backend");
    const char *bname = b->name && *b->name ? b->name : "unnamed";
    ef_efile_hdr_t h;
    int rc = bld_prepare(t, bname, o, &h, m);
    if (rc != EF_OK)
        return rc;
    const uint32_t rb = h.row_begin, re = h.row_end, n0 = t->view.axis[0].nodes;
    const uint32_t ndof = t->view.ndof;
    ef_jstate_t js = {.done = calloc(re - rb, 1)};
    if (!js.done)
        return ef_fail(m, EF_ERR_NOMEM, "build: out of memory");
    int fd = -1;
    size_t jlen = 0;
    if (o->journal) {
        rc = bld_journal_open(o->journal, o->fresh, &h, t, &js, &fd, m);
        if (rc != EF_OK) {
            free(js.done);
            return rc;
        }
        jlen = js.valid_len;
    }
    const uint32_t total = (re - rb) * n0;
    if (o->progress)
        o->progress(o->progress_ctx, js.rows_done * n0, total);
    const uint32_t chunk = b->chunk_nodes / n0 ? b->chunk_nodes / n0 : 1;
    for (uint32_t r = rb; r < re && rc == EF_OK;) {
        if (js.done[r - rb]) {
            r++;
            continue;
        }
        uint32_t e = r + 1; /* up to chunk rows, stopping at a row the journal holds */
        while (e < re && e - r < chunk && !js.done[e - rb])
            e++;
        /* NaN first: a row the backend never wrote fails the value check below. */
        for (size_t i = (size_t)r * n0 * ndof; i < (size_t)e * n0 * ndof; i++)
            t->values[i] = NAN;
        ef_msg_t sub = {{0}};
        rc = b->solve_rows(b->ctx, t, r, e, &sub);
        if (rc == EF_OK) {
            size_t bad = bld_bad_value(&h.spec, t, r * n0, e * n0);
            if (bad != SIZE_MAX)
                rc = ef_fail(&sub, EF_ERR_TBL_VALUE,
                             "node %zu DOF %zu: value non-finite or out of bounds (%.9g)",
                             bad / ndof, bad % ndof, (double)t->values[bad]);
        }
        if (rc == EF_OK && fd >= 0)
            rc = bld_journal_append(fd, o->journal, t, r, e, &jlen, &sub);
        if (rc != EF_OK) {
            char safe[300];
            if (fd >= 0)
                snprintf(safe, sizeof safe,
                         "%u chunk%s (%u of %u rows) %s safe in %s: run the "
                         "same command again to resume",
                         js.chunks, js.chunks == 1 ? "" : "s", js.rows_done, re - rb,
                         js.chunks == 1 ? "is" : "are", o->journal);
            else
                snprintf(safe, sizeof safe, "no journal was kept, nothing is saved");
            ef_fail(m, rc, "build stopped at rows %u..%u (backend %s): %.260s; %s", r, e - 1, bname,
                    sub.text, safe);
            break;
        }
        memset(js.done + (r - rb), 1, e - r);
        js.rows_done += e - r;
        js.chunks++;
        if (o->progress)
            o->progress(o->progress_ctx, js.rows_done * n0, total);
        r = e;
    }
    if (rc == EF_OK && o->output) {
        rc = o->shard.count ? ef_shard_write(t, bname, &o->shard, o->output, m)
                            : ef_tfile_write(t, o->output, m);
        if (rc != EF_OK && fd >= 0) {
            char text[sizeof m->text];
            snprintf(text, sizeof text, "%s", m->text);
            ef_fail(m, rc,
                    "%.380s; every row is safe in %s: rerun the same command to write the "
                    "output without recomputing",
                    text, o->journal);
        }
    }
    if (fd >= 0)
        (void)close(fd); /* releases the lock */
    if (rc == EF_OK && o->journal) {
        (void)unlink(o->journal);
        ef_file_sync_dir(o->journal);
    }
    free(js.done);
    return rc;
}

/* One pass over all rows, no journal or output: ef_build_run() with default options. */
int ef_build_all(ef_tfile_t *t, ef_build_backend_t *b, ef_build_progress_fn progress, void *ctx,
                 ef_msg_t *m)
{
    ef_build_opts_t o = {.progress = progress, .progress_ctx = ctx};
    return ef_build_run(t, b, &o, m);
}

/* Compatibility wrapper: the CPU backend over the whole table. */
int ef_build_cpu(ef_tfile_t *t, int threads, ef_build_progress_fn progress, void *ctx, ef_msg_t *m)
{
    ef_build_backend_t b;
    if (ef_build_backend_cpu(&b, threads) != EF_OK)
        return ef_fail(m, EF_ERR_ARG, "build: bad thread count %d", threads);
    int rc = ef_build_all(t, &b, progress, ctx, m);
    b.close(b.ctx);
    return rc;
}
