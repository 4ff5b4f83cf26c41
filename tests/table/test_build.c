/* SPDX-License-Identifier: Apache-2.0 */
/* The chunked, resumable, sharded table builder (host/lib/tables/ef_build.c, ef_shard.c):
 * shard arithmetic, shard builds merged back byte for byte, resume after an injected
 * failure (only missing chunks recomputed), journals of other builds and corrupt journals
 * refused, --fresh, backend output checks, and every merge error. A fake backend makes
 * failures reproducible; the CPU backend proves the real thing on tiny G1 and G2 tables. */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif
#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>
#include "ef_test.h"
#include "evenfeed/host/tables/ef_build.h"

static char tmpdir[512];

/* A path in this run's temporary directory. Rotating buffers: a test keeps at most a few
 * dozen paths alive, far fewer than the pool. */
static const char *tpath(const char *name)
{
    static char buf[256][700];
    static int k;
    k = (k + 1) & 255;
    snprintf(buf[k], sizeof buf[k], "%s/%s", tmpdir, name);
    return buf[k];
}

/* Whole file into a malloc'd buffer (NULL if it cannot be read). */
static uint8_t *slurp(const char *path, size_t *len)
{
    return (uint8_t *)ef_t_slurp(path, len);
}

/* Replace a file's contents. */
static void spit(const char *path, const uint8_t *p, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (f) {
        if (n)
            fwrite(p, 1, n, f);
        fclose(f);
    }
}

/* Byte-for-byte file equality. */
static int same_file(const char *a, const char *b)
{
    size_t na = 0, nb = 0;
    uint8_t *pa = slurp(a, &na), *pb = slurp(b, &nb);
    int same = pa && pb && na == nb && memcmp(pa, pb, na) == 0;
    free(pa);
    free(pb);
    return same;
}

/* XOR one byte of a file. */
static void flip(const char *path, long off)
{
    size_t n;
    uint8_t *p = slurp(path, &n);
    if (p && off >= 0 && (size_t)off < n) {
        p[off] ^= 0x5A;
        spit(path, p, n);
    }
    free(p);
}

/* Copy a file. */
static void copy_file(const char *from, const char *to)
{
    size_t n;
    uint8_t *p = slurp(from, &n);
    if (p)
        spit(to, p, n);
    free(p);
}

/* The path exists (any type). */
static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* Message contains a piece; prints the message when it does not. */
static int has(const ef_msg_t *m, const char *piece)
{
    if (strstr(m->text, piece))
        return 1;
    fprintf(stderr, "message lacks '%s': %s\n", piece, m->text);
    return 0;
}

/* ---- a fake backend: deterministic values per node, failures on demand --------------- */
typedef struct {
    int calls;
    uint32_t begin[512], end[512];
    int fail_at;  /* 1-based call that fails (0: none) */
    int nan_at;   /* call that stores a NaN */
    int skip_at;  /* call that leaves its last row unwritten */
    int rmdir_at; /* call that removes directory rmdir_path (output write then fails) */
    const char *rmdir_path;
} fake_t;

/* solve_rows of the fake: value depends on the node only, as the contract requires. */
static int fake_solve(void *ctx, ef_tfile_t *t, uint32_t rb, uint32_t re, ef_msg_t *m)
{
    fake_t *f = ctx;
    if (f->calls < 512) {
        f->begin[f->calls] = rb;
        f->end[f->calls] = re;
    }
    f->calls++;
    if (f->calls == f->fail_at)
        return ef_fail(m, EF_ERR_IO, "injected failure: GL context lost");
    const uint32_t n0 = t->view.axis[0].nodes, last = f->calls == f->skip_at ? re - 1 : re;
    for (uint32_t row = rb; row < last; row++)
        for (uint32_t i = 0; i < n0; i++) {
            uint32_t node = row * n0 + i;
            double d[4] = {0.2 + 0.001 * (node % 997), 3.0 * sin(node * 0.7),
                           0.3 + 0.0007 * (node % 991), -2.0 * cos(node * 0.3)};
            if (t->view.kind == EF_TABLE_G1_CUBIC)
                d[1] = d[2];
            ef_build_store(t, node, d);
        }
    if (f->calls == f->nan_at)
        t->values[(size_t)rb * n0 * t->view.ndof + 1] = NAN;
    if (f->calls == f->rmdir_at && rmdir(f->rmdir_path) != 0)
        perror(f->rmdir_path);
    return EF_OK;
}

/* A fake backend with chunks of `rows_per_chunk` rows of n0 nodes. */
static ef_build_backend_t fake_backend(fake_t *f, const char *name, uint32_t chunk_nodes)
{
    memset(f, 0, sizeof *f);
    return (ef_build_backend_t){
        .name = name, .solve_rows = fake_solve, .ctx = f, .chunk_nodes = chunk_nodes};
}

/* A G1 table spec without symmetry, n0 x n1 nodes. */
static ef_tfile_spec_t g1_spec(uint32_t n0, uint32_t n1, double x1_max, const char *prov)
{
    ef_tfile_spec_t s;
    memset(&s, 0, sizeof s);
    s.kind = EF_TABLE_G1_CUBIC;
    s.symmetry = EF_SYM_NONE;
    s.lo[0] = -1, s.hi[0] = 1, s.lo[1] = -0.5, s.hi[1] = 1.5;
    s.nodes[0] = n0, s.nodes[1] = n1;
    s.x1_min = 0.1, s.x1_max = x1_max;
    s.quad_nodes = 6;
    s.provenance = prov;
    return s;
}

/* Progress recorder. */
typedef struct {
    int calls;
    uint32_t first, last, total;
} prog_t;

/* ef_build_progress_fn recording the first and last report. */
static void prog_cb(void *ctx, uint32_t done, uint32_t total)
{
    prog_t *p = ctx;
    if (p->calls++ == 0)
        p->first = done;
    p->last = done;
    p->total = total;
}

/* Create a table from a spec or fail the test. */
static int make(ef_tfile_t *t, const ef_tfile_spec_t *s)
{
    ef_msg_t m = {{0}};
    int rc = ef_tfile_create(t, s, &m);
    EF_CHECK_EQ(rc, EF_OK);
    if (rc != EF_OK)
        fprintf(stderr, "create: %s\n", m.text);
    return rc;
}

/* Build (table or shard) with a fresh fake backend; returns the code, keeps the message. */
static int fake_build(const ef_tfile_spec_t *s, const char *backend, uint32_t chunk_nodes,
                      uint32_t index, uint32_t count, const char *out, const char *journal,
                      int fresh, fake_t *f, ef_msg_t *m)
{
    ef_tfile_t t;
    if (make(&t, s) != EF_OK)
        return EF_ERR_ARG;
    ef_build_backend_t b = fake_backend(f, backend, chunk_nodes);
    ef_build_opts_t o = {
        .shard = {index, count}, .journal = journal, .fresh = fresh, .output = out};
    int rc = ef_build_run(&t, &b, &o, m);
    ef_tfile_free(&t);
    return rc;
}

/* ---- tests ---------------------------------------------------------------------------- */

/* Shard specs parse strictly; rows split into contiguous, near-equal, covering blocks. */
static void test_shard_arith(void)
{
    ef_build_shard_t s;
    ef_msg_t m = {{0}};
    EF_CHECK_EQ(ef_build_shard_parse("1/1", &s, &m), EF_OK);
    EF_CHECK(s.index == 1 && s.count == 1);
    EF_CHECK_EQ(ef_build_shard_parse("4/4", &s, &m), EF_OK);
    EF_CHECK(s.index == 4 && s.count == 4);
    static const char *bad[] = {"0/0",  "5/4", "1/0",   "abc",           "",
                                "1/",   "/3",  " 1/2",  "1/2 ",          "+1/2",
                                "1/-2", "0/4", "1/2/3", "99999999999/1", "2/4x"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        int rc = ef_build_shard_parse(bad[i], &s, &m);
        EF_CHECK_EQ(rc, EF_ERR_ARG);
        if (rc == EF_OK)
            fprintf(stderr, "accepted bad shard spec '%s'\n", bad[i]);
    }
    EF_CHECK(has(&m, "--shard"));

    ef_tfile_spec_t sp = g1_spec(9, 17, 10, "p");
    ef_tfile_t t;
    if (make(&t, &sp) != EF_OK)
        return;
    for (uint32_t n = 1; n <= 17; n++) {
        uint32_t next = 0, minsz = 99, maxsz = 0;
        for (uint32_t i = 1; i <= n; i++) {
            uint32_t b, e;
            ef_build_shard_t sh = {i, n};
            EF_CHECK_EQ(ef_build_shard_rows(&t, &sh, &b, &e, &m), EF_OK);
            EF_CHECK_EQ(b, next); /* contiguous, in order, no gap or overlap */
            next = e;
            minsz = e - b < minsz ? e - b : minsz;
            maxsz = e - b > maxsz ? e - b : maxsz;
        }
        EF_CHECK_EQ(next, 17);
        EF_CHECK(minsz >= 1 && maxsz - minsz <= 1);
    }
    uint32_t b, e;
    ef_build_shard_t too_many = {3, 100000}, zero = {0, 4}, over = {5, 4};
    EF_CHECK_EQ(ef_build_shard_rows(&t, &too_many, &b, &e, &m), EF_ERR_ARG);
    EF_CHECK(has(&m, "only 17 rows"));
    EF_CHECK_EQ(ef_build_shard_rows(&t, &zero, &b, &e, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_build_shard_rows(&t, &over, &b, &e, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_build_shard_rows(&t, NULL, &b, &e, &m), EF_OK);
    EF_CHECK(b == 0 && e == 17);
    ef_tfile_free(&t);
}

/* The real CPU backend: N shards merged == the unsharded build, byte for byte. */
static void cpu_shards_case(const ef_tfile_spec_t *sp, const char *tag)
{
    char whole[64], merged[64], name[64];
    snprintf(whole, sizeof whole, "%s-whole.eft", tag);
    snprintf(merged, sizeof merged, "%s-merged.eft", tag);
    ef_msg_t m = {{0}};
    ef_tfile_t t;
    if (make(&t, sp) != EF_OK)
        return;
    const uint32_t n0 = t.view.axis[0].nodes;
    ef_build_backend_t b;
    EF_CHECK_EQ(ef_build_backend_cpu(&b, 2), EF_OK);
    b.chunk_nodes = 2 * n0; /* several chunks even on a tiny table */
    ef_build_opts_t o = {.journal = tpath("cpu.partial"), .output = tpath(whole)};
    int rc = ef_build_run(&t, &b, &o, &m);
    EF_CHECK_EQ(rc, EF_OK);
    if (rc != EF_OK)
        fprintf(stderr, "%s\n", m.text);
    EF_CHECK(!exists(tpath("cpu.partial"))); /* removed on success */
    ef_tfile_free(&t);
    for (uint32_t n = 3; n <= 4; n++) {
        const char *paths[4];
        char store[4][64];
        for (uint32_t i = 1; i <= n; i++) {
            if (make(&t, sp) != EF_OK)
                return;
            b.chunk_nodes = (i + 1) * n0; /* chunking must not matter either */
            snprintf(name, sizeof name, "%s-%u-of-%u.efs", tag, i, n);
            snprintf(store[i - 1], sizeof store[i - 1], "%s", tpath(name));
            ef_build_opts_t so = {
                .shard = {i, n}, .journal = tpath("cpu-s.partial"), .output = store[i - 1]};
            rc = ef_build_run(&t, &b, &so, &m);
            EF_CHECK_EQ(rc, EF_OK);
            if (rc != EF_OK)
                fprintf(stderr, "%s\n", m.text);
            ef_tfile_free(&t);
        }
        /* given in reverse order: order must not matter */
        for (uint32_t i = 0; i < n; i++)
            paths[i] = store[n - 1 - i];
        ef_tfile_t mt;
        rc = ef_shard_merge(paths, n, &mt, &m);
        EF_CHECK_EQ(rc, EF_OK);
        if (rc != EF_OK) {
            fprintf(stderr, "%s\n", m.text);
            continue;
        }
        EF_CHECK_EQ(ef_tfile_write(&mt, tpath(merged), &m), EF_OK);
        ef_tfile_free(&mt);
        EF_CHECK(same_file(tpath(merged), tpath(whole)));
    }
    b.close(b.ctx);
}

/* G1 fold and a tiny G2 mirror table through the CPU backend, 3 and 4 (uneven) shards. */
static void test_cpu_shards(void)
{
    ef_tfile_spec_t g1;
    memset(&g1, 0, sizeof g1);
    g1.kind = EF_TABLE_G1_CUBIC;
    g1.symmetry = EF_SYM_G1_FOLD;
    g1.lo[0] = 0, g1.hi[0] = M_PI / 2, g1.lo[1] = 0, g1.hi[1] = M_PI;
    g1.nodes[0] = 7, g1.nodes[1] = 13; /* 13 rows: 4+4+5 and 3+3+3+4 */
    g1.x1_min = 0.1, g1.x1_max = 10, g1.quad_nodes = 6;
    g1.provenance = "test g1 fold 7x13";
    cpu_shards_case(&g1, "g1");

    ef_tfile_spec_t g2;
    memset(&g2, 0, sizeof g2);
    g2.kind = EF_TABLE_G2_QUINTIC;
    g2.symmetry = EF_SYM_G2_MIRROR;
    g2.lo[0] = 0, g2.hi[0] = M_PI / 2, g2.lo[1] = -M_PI / 2, g2.hi[1] = M_PI / 2;
    g2.lo[2] = g2.lo[3] = -2, g2.hi[2] = g2.hi[3] = 2;
    g2.nodes[0] = 2, g2.nodes[1] = 3, g2.nodes[2] = 2, g2.nodes[3] = 3; /* 18 rows */
    g2.x1_min = 0.1, g2.x1_max = 10, g2.x2_max = 100, g2.quad_nodes = 12;
    g2.provenance = "test g2 mirror 2x3x2x3";
    cpu_shards_case(&g2, "g2");
}

/* A failure at chunk k leaves k-1 chunks in the journal and no output; the rerun loads
 * them, computes only the rest, and writes what a clean build writes. */
static void test_resume(void)
{
    const ef_tfile_spec_t sp = g1_spec(6, 20, 10, "resume");
    const char *out = tpath("res.eft"), *jn = tpath("res.eft.partial");
    fake_t f;
    ef_msg_t m = {{0}};
    unlink(jn);
    /* reference: a clean build without journal */
    EF_CHECK_EQ(fake_build(&sp, "fake", 12, 0, 0, tpath("res-ref.eft"), NULL, 0, &f, &m), EF_OK);
    EF_CHECK_EQ(f.calls, 10);

    ef_tfile_t t;
    if (make(&t, &sp) != EF_OK)
        return;
    ef_build_backend_t b = fake_backend(&f, "fake", 12); /* 2 rows per chunk, 10 chunks */
    f.fail_at = 4;
    ef_build_opts_t o = {.journal = jn, .output = out};
    int rc = ef_build_run(&t, &b, &o, &m);
    ef_tfile_free(&t);
    EF_CHECK_EQ(rc, EF_ERR_IO);
    EF_CHECK(has(&m, "injected failure"));
    EF_CHECK(has(&m, "3 chunks (6 of 20 rows) are safe in"));
    EF_CHECK(has(&m, "res.eft.partial"));
    EF_CHECK(has(&m, "resume"));
    EF_CHECK(!exists(out)); /* never a partial table */
    EF_CHECK(exists(jn));

    ef_build_plan_t plan;
    if (make(&t, &sp) != EF_OK)
        return;
    EF_CHECK_EQ(ef_build_check(&t, "fake", &o, &plan, &m), EF_OK);
    EF_CHECK(plan.journal_exists && plan.rows_done == 6 && plan.chunks_done == 3);
    EF_CHECK(plan.row_begin == 0 && plan.row_end == 20 && plan.rows == 20 && plan.n0 == 6);

    b = fake_backend(&f, "fake", 12);
    prog_t pr = {0};
    o.progress = prog_cb;
    o.progress_ctx = &pr;
    rc = ef_build_run(&t, &b, &o, &m);
    ef_tfile_free(&t);
    EF_CHECK_EQ(rc, EF_OK);
    EF_CHECK_EQ(f.calls, 7); /* only the 7 missing chunks */
    for (int i = 0; i < f.calls && i < 512; i++)
        EF_CHECK(f.begin[i] >= 6);
    EF_CHECK_EQ(pr.first, 36); /* resumed nodes reported before any work */
    EF_CHECK_EQ(pr.last, 120);
    EF_CHECK_EQ(pr.total, 120);
    EF_CHECK_EQ(pr.calls, 8);
    EF_CHECK(same_file(out, tpath("res-ref.eft")));
    EF_CHECK(!exists(jn));

    /* resume with a different chunk size: the journal records rows, not chunk numbers */
    unlink(out);
    if (make(&t, &sp) != EF_OK)
        return;
    b = fake_backend(&f, "fake", 18); /* 3 rows per chunk */
    f.fail_at = 3;
    o.progress = NULL;
    EF_CHECK_EQ(ef_build_run(&t, &b, &o, &m), EF_ERR_IO);
    ef_tfile_free(&t);
    EF_CHECK_EQ(fake_build(&sp, "fake", 30, 0, 0, out, jn, 0, &f, &m), EF_OK); /* 5 rows */
    EF_CHECK_EQ(f.calls, 3); /* rows 6..10, 11..15, 16..19 */
    EF_CHECK(f.begin[0] == 6 && f.end[0] == 11);
    EF_CHECK(same_file(out, tpath("res-ref.eft")));

    /* a shard resumes the same way and its file is the one a clean shard build writes */
    const char *s2 = tpath("res-2.efs"), *s2j = tpath("res-2.efs.partial");
    EF_CHECK_EQ(fake_build(&sp, "fake", 6, 2, 3, tpath("res-2-ref.efs"), NULL, 0, &f, &m), EF_OK);
    if (make(&t, &sp) != EF_OK)
        return;
    b = fake_backend(&f, "fake", 6);
    f.fail_at = 2;
    ef_build_opts_t so = {.shard = {2, 3}, .journal = s2j, .output = s2};
    EF_CHECK_EQ(ef_build_run(&t, &b, &so, &m), EF_ERR_IO);
    EF_CHECK(has(&m, "1 chunk (1 of 7 rows) is safe in"));
    ef_tfile_free(&t);
    EF_CHECK_EQ(fake_build(&sp, "fake", 6, 2, 3, s2, s2j, 0, &f, &m), EF_OK);
    EF_CHECK_EQ(f.calls, 6); /* shard 2/3 has rows 6..12: 7 rows, 1 in the journal */
    EF_CHECK(same_file(s2, tpath("res-2-ref.efs")));

    /* the output cannot be written after the last chunk (its directory vanished): every
     * row stays in the journal, and the rerun computes nothing, it only writes */
    const char *dir = tpath("gone"), *gone_out = tpath("gone/res.eft"),
               *gone_jn = tpath("gone.partial");
    EF_CHECK_EQ(mkdir(dir, 0777), 0);
    if (make(&t, &sp) != EF_OK)
        return;
    b = fake_backend(&f, "fake", 60);
    f.rmdir_at = 2;
    f.rmdir_path = dir;
    ef_build_opts_t go = {.journal = gone_jn, .output = gone_out};
    EF_CHECK_EQ(ef_build_run(&t, &b, &go, &m), EF_ERR_IO);
    EF_CHECK(has(&m, "every row is safe in"));
    ef_tfile_free(&t);
    EF_CHECK_EQ(mkdir(dir, 0777), 0);
    EF_CHECK_EQ(fake_build(&sp, "fake", 60, 0, 0, gone_out, gone_jn, 0, &f, &m), EF_OK);
    EF_CHECK_EQ(f.calls, 0);
    EF_CHECK(same_file(gone_out, tpath("res-ref.eft")));
    EF_CHECK(!exists(gone_jn));
}

/* Leave a journal from a build that failed after `chunks` chunks. */
static void leave_journal(const ef_tfile_spec_t *sp, const char *backend, uint32_t index,
                          uint32_t count, const char *jn, int chunks)
{
    fake_t f;
    ef_msg_t m = {{0}};
    unlink(jn);
    ef_tfile_t t;
    if (make(&t, sp) != EF_OK)
        return;
    ef_build_backend_t b = fake_backend(&f, backend, 12);
    f.fail_at = chunks + 1;
    ef_build_opts_t o = {.shard = {index, count}, .journal = jn, .output = tpath("never.eft")};
    EF_CHECK_EQ(ef_build_run(&t, &b, &o, &m), EF_ERR_IO);
    ef_tfile_free(&t);
}

/* A journal is resumed only by the very build that wrote it. */
static void test_journal_mismatch(void)
{
    const ef_tfile_spec_t sp = g1_spec(6, 20, 10, "mismatch");
    const char *jn = tpath("mm.partial");
    fake_t f;
    ef_msg_t m = {{0}};

    leave_journal(&sp, "fake", 0, 0, jn, 3);
    ef_tfile_spec_t other = g1_spec(6, 20, 5, "mismatch");
    EF_CHECK_EQ(fake_build(&other, "fake", 12, 0, 0, NULL, jn, 0, &f, &m), EF_ERR_ARG);
    EF_CHECK_EQ(f.calls, 0); /* refused before any work */
    EF_CHECK(has(&m, "mm.partial"));
    EF_CHECK(has(&m, "different build"));
    EF_CHECK(has(&m, "x1_max 5 vs 10"));
    EF_CHECK(has(&m, "--fresh"));

    ef_tfile_spec_t rows = g1_spec(6, 21, 10, "mismatch");
    EF_CHECK_EQ(fake_build(&rows, "fake", 12, 0, 0, NULL, jn, 0, &f, &m), EF_ERR_ARG);
    EF_CHECK(has(&m, "axis[1].nodes 21 vs 20"));
    ef_tfile_spec_t prov = g1_spec(6, 20, 10, "mismatch, other command");
    EF_CHECK_EQ(fake_build(&prov, "fake", 12, 0, 0, NULL, jn, 0, &f, &m), EF_ERR_ARG);
    EF_CHECK(has(&m, "provenance"));
    EF_CHECK_EQ(fake_build(&sp, "gl", 12, 0, 0, NULL, jn, 0, &f, &m), EF_ERR_ARG);
    EF_CHECK(has(&m, "backend 'gl' vs 'fake'"));
    EF_CHECK_EQ(fake_build(&sp, "fake", 12, 1, 2, NULL, jn, 0, &f, &m), EF_ERR_ARG);
    EF_CHECK(has(&m, "the whole table; this build is shard 1/2"));

    /* the check without a backend says the same */
    ef_tfile_t t;
    if (make(&t, &other) != EF_OK)
        return;
    ef_build_opts_t o = {.journal = jn};
    EF_CHECK_EQ(ef_build_check(&t, "fake", &o, NULL, &m), EF_ERR_ARG);
    EF_CHECK(has(&m, "different build"));
    ef_tfile_free(&t);

    leave_journal(&sp, "fake", 1, 2, jn, 2);
    EF_CHECK_EQ(fake_build(&sp, "fake", 12, 2, 2, NULL, jn, 0, &f, &m), EF_ERR_ARG);
    EF_CHECK(has(&m, "shard 1/2; this build is shard 2/2"));
    EF_CHECK(exists(jn)); /* refusing never deletes */
    unlink(jn);
}

/* Damage anywhere is refused with the file's name; a torn last record is not damage. */
static void test_journal_corrupt(void)
{
    const ef_tfile_spec_t sp = g1_spec(6, 20, 10, "corrupt");
    const char *jn = tpath("cj.partial"), *out = tpath("cj.eft"), *keep = tpath("cj.keep");
    fake_t f;
    ef_msg_t m = {{0}};
    EF_CHECK_EQ(fake_build(&sp, "fake", 12, 0, 0, tpath("cj-ref.eft"), NULL, 0, &f, &m), EF_OK);
    leave_journal(&sp, "fake", 0, 0, jn, 3);
    copy_file(jn, keep);
    size_t len = 0;
    uint8_t *img = slurp(jn, &len);
    free(img);
    const size_t rec = 16 + 24 * 4 + 4; /* one record: 2 rows x 6 nodes x 2 DOFs */
    const long hdr = (long)(len - 3 * rec);
    EF_CHECK(hdr > 0);

    /* a byte flipped: in the magic, the spec, a record header, a record's values, a CRC */
    const long spots[] = {2, 60, hdr + 5, hdr + (long)rec + 30, (long)len - 1};
    for (size_t i = 0; i < sizeof spots / sizeof spots[0]; i++) {
        copy_file(keep, jn);
        flip(jn, spots[i]);
        int rc = fake_build(&sp, "fake", 12, 0, 0, out, jn, 0, &f, &m);
        EF_CHECK(rc != EF_OK);
        EF_CHECK_EQ(f.calls, 0);
        EF_CHECK(has(&m, "cj.partial"));
        if (i > 0) {
            EF_CHECK(has(&m, "--fresh"));
            EF_CHECK(rc == EF_ERR_TBL_CRC);
        }
        EF_CHECK(!exists(out));
    }
    /* the check without a backend refuses it too */
    ef_tfile_t t;
    if (make(&t, &sp) == EF_OK) {
        ef_build_opts_t o = {.journal = jn};
        EF_CHECK_EQ(ef_build_check(&t, "fake", &o, NULL, &m), EF_ERR_TBL_CRC);
        EF_CHECK(has(&m, "corrupt"));
        ef_tfile_free(&t);
    }
    /* --fresh discards it and builds everything */
    EF_CHECK_EQ(fake_build(&sp, "fake", 12, 0, 0, out, jn, 1, &f, &m), EF_OK);
    EF_CHECK_EQ(f.calls, 10);
    EF_CHECK(same_file(out, tpath("cj-ref.eft")));
    unlink(out);

    /* torn last record (crash mid-append): dropped, that chunk recomputed */
    size_t n;
    uint8_t *p = slurp(keep, &n);
    if (p) {
        spit(jn, p, n - 10);
        free(p);
    }
    EF_CHECK_EQ(fake_build(&sp, "fake", 12, 0, 0, out, jn, 0, &f, &m), EF_OK);
    EF_CHECK_EQ(f.calls, 8);
    EF_CHECK_EQ(f.begin[0], 4);
    EF_CHECK(same_file(out, tpath("cj-ref.eft")));
    unlink(out);
    /* a record header cut short, and a tail of zeros (the file grew, the data never landed) */
    p = slurp(keep, &n);
    if (p) {
        uint8_t *q = calloc(n + rec, 1);
        memcpy(q, p, n);
        spit(jn, q, n + 7);
        EF_CHECK_EQ(fake_build(&sp, "fake", 12, 0, 0, out, jn, 0, &f, &m), EF_OK);
        EF_CHECK_EQ(f.calls, 7);
        spit(jn, q, n + rec);
        EF_CHECK_EQ(fake_build(&sp, "fake", 12, 0, 0, out, jn, 0, &f, &m), EF_OK);
        EF_CHECK_EQ(f.calls, 7);
        EF_CHECK(same_file(out, tpath("cj-ref.eft")));
        free(q);
        free(p);
    }
    /* a file that is no journal is never overwritten or deleted, not even with --fresh */
    spit(jn, (const uint8_t *)"important notes, not a journal\n", 31);
    EF_CHECK_EQ(fake_build(&sp, "fake", 12, 0, 0, out, jn, 0, &f, &m), EF_ERR_TBL_MAGIC);
    EF_CHECK(has(&m, "refusing to overwrite"));
    EF_CHECK_EQ(fake_build(&sp, "fake", 12, 0, 0, out, jn, 1, &f, &m), EF_ERR_TBL_MAGIC);
    EF_CHECK(has(&m, "refusing to delete"));
    ef_tfile_t ct;
    if (make(&ct, &sp) == EF_OK) {
        ef_build_opts_t fo = {.journal = jn, .fresh = 1};
        EF_CHECK_EQ(ef_build_check(&ct, "fake", &fo, NULL, &m), EF_ERR_TBL_MAGIC);
        ef_tfile_free(&ct);
    }
    EF_CHECK_EQ(f.calls, 0);
    size_t tn;
    uint8_t *txt = slurp(jn, &tn);
    EF_CHECK(txt && tn == 31);
    free(txt);
    spit(jn, NULL, 0); /* empty */
    EF_CHECK(fake_build(&sp, "fake", 12, 0, 0, out, jn, 0, &f, &m) != EF_OK);
    EF_CHECK(has(&m, "cj.partial"));
    unlink(jn);
    unlink(keep);
    unlink(out);
}

/* A second build on the same journal is refused while the first holds it. */
static void test_journal_locked(void)
{
    const ef_tfile_spec_t sp = g1_spec(6, 20, 10, "lock");
    const char *jn = tpath("lock.partial");
    fake_t f;
    ef_msg_t m = {{0}};
    leave_journal(&sp, "fake", 0, 0, jn, 2);
    int fd = open(jn, O_RDWR);
    EF_CHECK(fd >= 0 && flock(fd, LOCK_EX | LOCK_NB) == 0);
    EF_CHECK_EQ(fake_build(&sp, "fake", 12, 0, 0, NULL, jn, 0, &f, &m), EF_ERR_IO);
    EF_CHECK(has(&m, "in use"));
    EF_CHECK_EQ(f.calls, 0);
    close(fd);
    EF_CHECK_EQ(fake_build(&sp, "fake", 12, 0, 0, NULL, jn, 0, &f, &m), EF_OK);
    EF_CHECK_EQ(f.calls, 8);
}

/* Values a backend must not hand back: NaN, rows left unwritten. */
static void test_backend_values(void)
{
    const ef_tfile_spec_t sp = g1_spec(6, 20, 10, "values");
    const char *jn = tpath("val.partial");
    ef_msg_t m = {{0}};
    ef_tfile_t t;
    fake_t f;
    unlink(jn);
    if (make(&t, &sp) != EF_OK)
        return;
    ef_build_backend_t b = fake_backend(&f, "fake", 12);
    f.nan_at = 2;
    ef_build_opts_t o = {.journal = jn, .output = tpath("val.eft")};
    EF_CHECK_EQ(ef_build_run(&t, &b, &o, &m), EF_ERR_TBL_VALUE);
    EF_CHECK(has(&m, "node 12 DOF 1"));
    EF_CHECK(has(&m, "1 chunk (2 of 20 rows) is safe in"));
    b = fake_backend(&f, "fake", 12);
    f.skip_at = 1; /* the first chunk's second row is never written: NaN, caught */
    EF_CHECK_EQ(ef_build_run(&t, &b, &o, &m), EF_ERR_TBL_VALUE);
    EF_CHECK(has(&m, "rows 2..3"));
    EF_CHECK(!exists(tpath("val.eft")));
    /* without a journal the message says nothing is kept */
    b = fake_backend(&f, "fake", 12);
    f.fail_at = 1;
    EF_CHECK_EQ(ef_build_all(&t, &b, NULL, NULL, &m), EF_ERR_IO);
    EF_CHECK(has(&m, "nothing is saved"));
    /* the compatibility entry points still work */
    b = fake_backend(&f, "fake", 12);
    EF_CHECK_EQ(ef_build_all(&t, &b, NULL, NULL, &m), EF_OK);
    EF_CHECK_EQ(f.calls, 10);
    EF_CHECK_EQ(ef_build_cpu(&t, 0, NULL, NULL, &m), EF_ERR_ARG);
    ef_tfile_free(&t);
    unlink(jn);
}

/* Unwritable outputs and clashing paths fail in the check, before a backend exists. */
static void test_paths(void)
{
    const ef_tfile_spec_t sp = g1_spec(6, 20, 10, "paths");
    ef_tfile_t t;
    ef_msg_t m = {{0}};
    if (make(&t, &sp) != EF_OK)
        return;
    ef_build_opts_t o = {.output = tpath("no/such/dir/x.eft")};
    EF_CHECK_EQ(ef_build_check(&t, "cpu", &o, NULL, &m), EF_ERR_IO);
    EF_CHECK(has(&m, "no/such/dir"));
    o.output = tmpdir;
    EF_CHECK_EQ(ef_build_check(&t, "cpu", &o, NULL, &m), EF_ERR_IO);
    EF_CHECK(has(&m, "is a directory"));
    o.output = tpath("same");
    o.journal = tpath("same");
    EF_CHECK_EQ(ef_build_check(&t, "cpu", &o, NULL, &m), EF_ERR_ARG);
    o.journal = tpath("no/such/dir/j");
    EF_CHECK_EQ(ef_build_check(&t, "cpu", &o, NULL, &m), EF_ERR_IO);
    o.journal = NULL;
    o.shard = (ef_build_shard_t){1, 21};
    EF_CHECK_EQ(ef_build_check(&t, "cpu", &o, NULL, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_build_check(&t, "", &o, NULL, &m), EF_ERR_ARG);
    ef_build_plan_t plan;
    ef_build_opts_t ok = {.shard = {4, 4}, .output = tpath("x.efs")};
    EF_CHECK_EQ(ef_build_check(&t, "cpu", &ok, &plan, &m), EF_OK);
    EF_CHECK(plan.row_begin == 15 && plan.row_end == 20 && !plan.journal_exists);
    ef_tfile_free(&t);
}

/* Every way a set of shard files can fail to make a table. */
static void test_merge_errors(void)
{
    const ef_tfile_spec_t sp = g1_spec(6, 20, 10, "merge");
    fake_t f;
    ef_msg_t m = {{0}};
    char s[5][64];
    for (int i = 1; i <= 4; i++) {
        char name[32];
        snprintf(name, sizeof name, "m%d.efs", i);
        snprintf(s[i], sizeof s[i], "%s", tpath(name));
        EF_CHECK_EQ(fake_build(&sp, "fake", 12, (uint32_t)i, 4, s[i], NULL, 0, &f, &m), EF_OK);
    }
    EF_CHECK_EQ(fake_build(&sp, "fake", 12, 0, 0, tpath("m-ref.eft"), NULL, 0, &f, &m), EF_OK);
    ef_tfile_t t;
    const char *all[] = {s[3], s[1], s[4], s[2]};
    EF_CHECK_EQ(ef_shard_merge(all, 4, &t, &m), EF_OK);
    EF_CHECK_EQ(ef_tfile_write(&t, tpath("m-merged.eft"), &m), EF_OK);
    ef_tfile_free(&t);
    EF_CHECK(same_file(tpath("m-merged.eft"), tpath("m-ref.eft")));

    const char *missing[] = {s[1], s[2], s[4]};
    EF_CHECK_EQ(ef_shard_merge(missing, 3, &t, &m), EF_ERR_ARG);
    EF_CHECK(has(&m, "1 of 4 shards missing: 3/4 (rows 10..14)"));
    EF_CHECK(t.values == NULL);
    const char *lone[] = {s[2]};
    EF_CHECK_EQ(ef_shard_merge(lone, 1, &t, &m), EF_ERR_ARG);
    EF_CHECK(has(&m, "3 of 4 shards missing"));
    const char *twice[] = {s[1], s[2], s[2], s[3], s[4]};
    EF_CHECK_EQ(ef_shard_merge(twice, 5, &t, &m), EF_ERR_ARG);
    EF_CHECK(has(&m, "both shard 2/4"));
    EF_CHECK_EQ(ef_shard_merge(NULL, 0, &t, &m), EF_ERR_ARG);

    /* a shard of another spec: bounds, provenance, backend */
    ef_tfile_spec_t other = g1_spec(6, 20, 8, "merge");
    const char *o3 = tpath("o3.efs");
    EF_CHECK_EQ(fake_build(&other, "fake", 12, 3, 4, o3, NULL, 0, &f, &m), EF_OK);
    const char *mixed[] = {s[1], s[2], o3, s[4]};
    EF_CHECK_EQ(ef_shard_merge(mixed, 4, &t, &m), EF_ERR_ARG);
    EF_CHECK(has(&m, "o3.efs: not from the same build as"));
    EF_CHECK(has(&m, "x1_max 10 vs 8"));
    EF_CHECK_EQ(fake_build(&sp, "gl", 12, 3, 4, o3, NULL, 0, &f, &m), EF_OK);
    EF_CHECK_EQ(ef_shard_merge(mixed, 4, &t, &m), EF_ERR_ARG);
    EF_CHECK(has(&m, "backend 'fake' vs 'gl'"));
    /* shards of a different split */
    const char *n3 = tpath("n3.efs");
    EF_CHECK_EQ(fake_build(&sp, "fake", 12, 3, 3, n3, NULL, 0, &f, &m), EF_OK);
    const char *split[] = {s[1], s[2], n3, s[4]};
    EF_CHECK_EQ(ef_shard_merge(split, 4, &t, &m), EF_ERR_ARG);
    EF_CHECK(has(&m, "n3.efs is shard 3/3"));
    EF_CHECK(has(&m, "same --shard"));

    /* damaged shard files */
    const char *bad = tpath("bad.efs");
    const char *with_bad[] = {s[1], s[2], bad, s[4]};
    size_t n;
    uint8_t *img = slurp(s[3], &n);
    if (!img)
        return;
    spit(bad, img, n);
    flip(bad, (long)n - 9); /* a value */
    EF_CHECK_EQ(ef_shard_merge(with_bad, 4, &t, &m), EF_ERR_TBL_CRC);
    EF_CHECK(has(&m, "bad.efs"));
    spit(bad, img, n);
    flip(bad, 50); /* the spec */
    EF_CHECK_EQ(ef_shard_merge(with_bad, 4, &t, &m), EF_ERR_TBL_CRC);
    EF_CHECK(has(&m, "header CRC"));
    spit(bad, img, n - 4);
    EF_CHECK_EQ(ef_shard_merge(with_bad, 4, &t, &m), EF_ERR_TBL_TRUNCATED);
    uint8_t *longer = calloc(n + 4, 1);
    memcpy(longer, img, n);
    spit(bad, longer, n + 4);
    EF_CHECK_EQ(ef_shard_merge(with_bad, 4, &t, &m), EF_ERR_TBL_SIZE);
    free(longer);
    spit(bad, img, 20);
    EF_CHECK_EQ(ef_shard_merge(with_bad, 4, &t, &m), EF_ERR_TBL_TRUNCATED);
    img[8] = 9; /* version, CRC then wrong too: the version is reported first */
    spit(bad, img, n);
    EF_CHECK_EQ(ef_shard_merge(with_bad, 4, &t, &m), EF_ERR_TBL_VERSION);
    free(img);

    /* files that are no shard at all */
    const char *tbl[] = {tpath("m-ref.eft")};
    EF_CHECK_EQ(ef_shard_merge(tbl, 1, &t, &m), EF_ERR_TBL_MAGIC);
    EF_CHECK(has(&m, "it is a table file"));
    leave_journal(&sp, "fake", 0, 0, tpath("j.partial"), 1);
    const char *jrn[] = {tpath("j.partial")};
    EF_CHECK_EQ(ef_shard_merge(jrn, 1, &t, &m), EF_ERR_TBL_MAGIC);
    EF_CHECK(has(&m, "build journal"));
    spit(bad, (const uint8_t *)"hello, world, this is text", 26);
    EF_CHECK_EQ(ef_shard_merge(with_bad, 4, &t, &m), EF_ERR_TBL_MAGIC);
    EF_CHECK(has(&m, "not a shard file"));
    spit(bad, NULL, 0);
    EF_CHECK_EQ(ef_shard_merge(with_bad, 4, &t, &m), EF_ERR_TBL_TRUNCATED);
    const char *nofile[] = {tpath("nonexistent.efs")};
    EF_CHECK_EQ(ef_shard_merge(nofile, 1, &t, &m), EF_ERR_IO);
    EF_CHECK(has(&m, "nonexistent.efs"));
    const char *dir[] = {tmpdir};
    EF_CHECK_EQ(ef_shard_merge(dir, 1, &t, &m), EF_ERR_IO);

    /* ef_shard_write refuses what it cannot write */
    ef_tfile_t empty;
    if (make(&empty, &sp) == EF_OK) {
        ef_build_shard_t sh = {1, 4}, whole = {0, 0};
        EF_CHECK_EQ(ef_shard_write(&empty, "fake", &sh, tpath("e.efs"), &m), EF_ERR_TBL_VALUE);
        EF_CHECK_EQ(ef_shard_write(&empty, "fake", &whole, tpath("e.efs"), &m), EF_ERR_ARG);
        EF_CHECK(!exists(tpath("e.efs")));
        ef_tfile_free(&empty);
    }
}

/* Every test in a fresh temporary directory, removed when all pass. */
int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"shard_arith", test_shard_arith},
        {"resume", test_resume},
        {"journal_mismatch", test_journal_mismatch},
        {"journal_corrupt", test_journal_corrupt},
        {"journal_locked", test_journal_locked},
        {"backend_values", test_backend_values},
        {"paths", test_paths},
        {"merge_errors", test_merge_errors},
        {"cpu_shards", test_cpu_shards},
    };
    const char *base = getenv("TMPDIR");
    snprintf(tmpdir, sizeof tmpdir, "%s/test_build.XXXXXX", base && *base ? base : "/tmp");
    if (!mkdtemp(tmpdir)) {
        perror("mkdtemp");
        return 2;
    }
    int rc = EF_TEST_RUN(argc, argv, 1, parts);
    if (ef_t_fail == 0) { /* keep the files of a failed run for inspection */
        char cmd[700];
        snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
        if (system(cmd) != 0)
            fprintf(stderr, "could not remove %s\n", tmpdir);
    } else {
        fprintf(stderr, "files kept in %s\n", tmpdir);
    }
    return rc;
}
