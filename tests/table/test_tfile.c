/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Table file format tests: CRC, the firmware parser and view check, the host file API
 * (create, serialize, atomic write, load, messages) and the C emitter.
 *
 * Modes:
 *   test_tfile                                   run the unit tests
 *   test_tfile --emit g1|g2 NAME OUT.c OUT.eft   write a test table and its C source (the
 *                                                build runs this; see tests/table/tfile.cmake)
 * Compiled with EF_TFILE_EMITTED (target test_tfile_emitted), main() instead checks the
 * compiled-in emitted tables against their .eft files.
 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include <dirent.h>
#include <errno.h>
#include <float.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "ef_le.h"
#include "ef_test.h"
#include "evenfeed/host/tables/ef_tfile.h"

/* ---------------------------------------------------------------------------------------
 * Shared helpers
 * ------------------------------------------------------------------------------------- */

/* Bitwise float equality: +0/-0 and NaN payloads must survive, not just compare equal. */
static int same_bits(float a, float b)
{
    return memcmp(&a, &b, sizeof a) == 0;
}

/* Two views agree on every header-derived field (data/provenance compared separately). */
static int same_view_header(const ef_table_t *a, const ef_table_t *b)
{
    int i, s = a->kind == b->kind && a->symmetry == b->symmetry && a->naxes == b->naxes &&
               a->ndof == b->ndof && a->quad_nodes == b->quad_nodes && a->nodes == b->nodes &&
               same_bits(a->x1_min, b->x1_min) && same_bits(a->x1_max, b->x1_max) &&
               same_bits(a->x2_max, b->x2_max) && a->provenance_len == b->provenance_len;
    for (i = 0; i < EF_TABLE_MAX_AXES; i++) {
        const ef_table_axis_t *x = &a->axis[i], *y = &b->axis[i];
        s = s && same_bits(x->lo, y->lo) && same_bits(x->hi, y->hi) &&
            same_bits(x->inv_step, y->inv_step) && x->nodes == y->nodes && x->stride == y->stride &&
            x->flags == y->flags;
    }
    return s;
}

#ifndef EF_TFILE_EMITTED

/* Test tables, one per kind/symmetry combination the format allows. */
enum { V_G1_PLAIN, V_G1_PERIODIC, V_G1_FOLD, V_G2_NONE, V_G2_MIRROR, V_COUNT };
static const char *const v_name[V_COUNT] = {"G1 plain", "G1 periodic", "G1 fold", "G2 none",
                                            "G2 mirror"};

/* Spec of test table v; provenance lengths differ so padding is exercised (0, 8k, other). */
static void spec_for(int v, ef_tfile_spec_t *s)
{
    memset(s, 0, sizeof *s);
    s->x1_min = 0.1;
    s->x1_max = 4.0;
    s->quad_nodes = 32;
    switch (v) {
    case V_G1_PLAIN:
        s->kind = EF_TABLE_G1_CUBIC;
        s->lo[0] = s->lo[1] = -M_PI / 2;
        s->hi[0] = s->hi[1] = M_PI / 2;
        s->nodes[0] = 5;
        s->nodes[1] = 4;
        s->provenance = "";
        break;
    case V_G1_PERIODIC:
        s->kind = EF_TABLE_G1_CUBIC;
        s->lo[0] = 0.0;
        s->hi[0] = 2 * M_PI;
        s->lo[1] = -M_PI;
        s->hi[1] = M_PI;
        s->nodes[0] = 9;
        s->nodes[1] = 7;
        s->axis_flags[0] = s->axis_flags[1] = EF_AXIS_PERIODIC;
        s->provenance = "test_tfile: G1 periodic, seed 1, 38 B.";
        break;
    case V_G1_FOLD:
        s->kind = EF_TABLE_G1_CUBIC;
        s->symmetry = EF_SYM_G1_FOLD;
        s->hi[0] = M_PI / 2;
        s->hi[1] = M_PI;
        s->nodes[0] = 6;
        s->nodes[1] = 11;
        s->provenance = "fold 16 chars..";
        break;
    case V_G2_NONE:
    case V_G2_MIRROR:
        s->kind = EF_TABLE_G2_QUINTIC;
        s->symmetry = v == V_G2_MIRROR ? EF_SYM_G2_MIRROR : EF_SYM_NONE;
        s->lo[0] = v == V_G2_MIRROR ? 0.0 : -M_PI / 2;
        s->hi[0] = M_PI / 2;
        s->lo[1] = -M_PI / 2;
        s->hi[1] = M_PI / 2;
        s->lo[2] = s->lo[3] = -2.0;
        s->hi[2] = s->hi[3] = 2.0;
        s->nodes[0] = 3;
        s->nodes[1] = 4;
        s->nodes[2] = 3;
        s->nodes[3] = 2;
        s->x2_max = 8.0;
        s->quad_nodes = 48;
        s->provenance = "evenfeed test_tfile G2 \"quoted\" \\ ?\?= */ {}";
        break;
    default:
        break;
    }
}

/* Random values inside the optimizer box: x1 in [x1_min, x1_max], x2 in +-x2_max. */
static void fill_values(ef_tfile_t *t, unsigned long long seed)
{
    uint32_t k, n = t->view.nodes * t->view.ndof;
    for (k = 0; k < n; k++) {
        const int x2 = t->view.kind == EF_TABLE_G2_QUINTIC && (k & 1u);
        t->values[k] = x2 ? (float)ef_t_uniform(&seed, -t->x2_max, t->x2_max)
                          : (float)ef_t_uniform(&seed, t->x1_min, t->x1_max);
    }
}

/* Create and fill test table v; aborts the test run if the spec itself is rejected. */
static void make_table(int v, ef_tfile_t *t)
{
    ef_tfile_spec_t s;
    ef_msg_t m = {{0}};
    spec_for(v, &s);
    if (ef_tfile_create(t, &s, &m) != EF_OK) {
        fprintf(stderr, "cannot create test table %s: %s\n", v_name[v], m.text);
        exit(EXIT_FAILURE);
    }
    fill_values(t, 1000u + (unsigned)v);
}

/* File image of test table v (malloc'd). */
static uint8_t *make_blob(int v, size_t *len)
{
    ef_tfile_t t;
    ef_msg_t m = {{0}};
    uint8_t *b = NULL;
    make_table(v, &t);
    if (ef_tfile_serialize(&t, &b, len, &m) != EF_OK) {
        fprintf(stderr, "cannot serialize test table %s: %s\n", v_name[v], m.text);
        exit(EXIT_FAILURE);
    }
    ef_tfile_free(&t);
    return b;
}

/* Recompute the trailing CRC so a corruption reaches the field check, not the CRC check. */
static void fix_crc(uint8_t *b, size_t len)
{
    put32(b + len - 4, ef_crc32(0, b, (uint32_t)(len - 4)));
}

/* Offset of the node values in an image. */
static uint32_t data_offset(const uint8_t *b)
{
    return EF_TABLE_HEADER_SIZE + ((get32(b + 56) + 7u) & ~7u);
}

/* A failed parse must leave nothing usable behind. */
static int view_is_zero(const ef_table_t *v)
{
    int i, z = v->kind == 0 && v->symmetry == 0 && v->naxes == 0 && v->ndof == 0 &&
               v->quad_nodes == 0 && v->nodes == 0 && v->x1_min == 0.0f && v->x1_max == 0.0f &&
               v->x2_max == 0.0f && v->data == NULL && v->provenance == NULL &&
               v->provenance_len == 0;
    for (i = 0; i < EF_TABLE_MAX_AXES; i++) {
        const ef_table_axis_t *a = &v->axis[i];
        z = z && a->lo == 0.0f && a->hi == 0.0f && a->inv_step == 0.0f && a->nodes == 0 &&
            a->stride == 0 && a->flags == 0;
    }
    return z;
}

/* Scratch directory for file tests, under TMPDIR. */
static char tmp_dir[512];

/* Create the scratch directory; every file test works inside it. */
static void tmp_setup(void)
{
    const char *base = getenv("TMPDIR");
    snprintf(tmp_dir, sizeof tmp_dir, "%s/ef_tfile_XXXXXX", base && *base ? base : "/tmp");
    if (mkdtemp(tmp_dir) == NULL) {
        perror("mkdtemp");
        exit(EXIT_FAILURE);
    }
}

/* Path of a file in the scratch directory (static buffer per slot). */
static const char *tmp_path(int slot, const char *name)
{
    static char buf[4][600];
    snprintf(buf[slot], sizeof buf[slot], "%s/%s", tmp_dir, name);
    return buf[slot];
}

/* Entries in the scratch directory other than . and ..; fills the first name. */
static int tmp_entries(char *first, size_t n)
{
    DIR *d = opendir(tmp_dir);
    struct dirent *e;
    int count = 0;
    if (first && n) {
        first[0] = '\0';
    }
    if (d == NULL) {
        return -1;
    }
    while ((e = readdir(d)) != NULL) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) {
            continue;
        }
        if (count == 0 && first && n) {
            snprintf(first, n, "%s", e->d_name);
        }
        count++;
    }
    closedir(d);
    return count;
}

/* Empty and remove the scratch directory. */
static void tmp_cleanup(void)
{
    DIR *d = opendir(tmp_dir);
    struct dirent *e;
    if (d == NULL) {
        return;
    }
    while ((e = readdir(d)) != NULL) {
        char p[1200];
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) {
            continue;
        }
        snprintf(p, sizeof p, "%s/%s", tmp_dir, e->d_name);
        if (unlink(p) != 0) {
            (void)rmdir(p);
        }
    }
    closedir(d);
    (void)rmdir(tmp_dir);
}

/* Write raw bytes to a file (for corrupted images the API refuses to write). */
static void write_raw(const char *path, const void *b, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (f == NULL || fwrite(b, 1, n, f) != n || fclose(f) != 0) {
        perror(path);
        exit(EXIT_FAILURE);
    }
}

/* ---------------------------------------------------------------------------------------
 * CRC
 * ------------------------------------------------------------------------------------- */

/* Bit-at-a-time reference, written from the definition, to cross-check the nibble table. */
static uint32_t crc_ref(const uint8_t *p, size_t n)
{
    uint32_t c = 0xFFFFFFFFu;
    size_t i;
    int k;
    for (i = 0; i < n; i++) {
        c ^= p[i];
        for (k = 0; k < 8; k++) {
            c = (c & 1u) ? (c >> 1) ^ 0xEDB88320u : c >> 1;
        }
    }
    return ~c;
}

/* Check value, chaining, empty input, and agreement with the reference on random data. */
static void test_crc(void)
{
    static const char check[] = "123456789";
    unsigned long long seed = 7;
    uint8_t buf[300];
    int r;
    size_t i, n;

    EF_CHECK_EQ(ef_crc32(0, check, 9), 0xCBF43926u);
    EF_CHECK_EQ(ef_crc32(ef_crc32(0, check, 4), check + 4, 5), 0xCBF43926u);
    EF_CHECK_EQ(ef_crc32(0, check, 0), 0u);
    EF_CHECK_EQ(ef_crc32(0x12345678u, NULL, 5), 0x12345678u);
    EF_CHECK_EQ(ef_crc32(0, "a", 1), 0xE8B7BE43u);
    for (r = 0; r < 200; r++) {
        n = (size_t)(ef_t_rng(&seed) % sizeof buf);
        for (i = 0; i < n; i++) {
            buf[i] = (uint8_t)ef_t_rng(&seed);
        }
        EF_CHECK_EQ(ef_crc32(0, buf, (uint32_t)n), crc_ref(buf, n));
    }
}

/* ---------------------------------------------------------------------------------------
 * Round trips
 * ------------------------------------------------------------------------------------- */

/* Node configurations agree with the lookup's folding: at an interior node the lookup
 * must return that node's own values (up to interpolation rounding). */
static void check_nodes_vs_lookup(const ef_tfile_t *t)
{
    uint32_t node, d;
    const ef_table_t *v = &t->view;

    for (node = 0; node < v->nodes; node++) {
        double cfg[EF_TABLE_MAX_AXES];
        float dof[4], c[4];
        int interior = 1, i, rc;
        for (i = 0; i < v->naxes; i++) {
            uint32_t k = (node / v->axis[i].stride) % v->axis[i].nodes;
            interior = interior && k > 0 && k + 1 < v->axis[i].nodes;
        }
        if (!interior) {
            continue;
        }
        ef_tfile_node_config(t, node, cfg);
        for (i = 0; i < 4; i++) {
            c[i] = (float)cfg[i];
        }
        rc = v->kind == EF_TABLE_G1_CUBIC ? ef_table_lookup_g1(v, c[0], c[1], dof, NULL)
                                          : ef_table_lookup_g2(v, c, dof, NULL);
        EF_CHECK_EQ(rc, EF_OK);
        for (d = 0; d < v->ndof; d++) {
            EF_CHECK_NEAR(dof[d], t->values[node * v->ndof + d], 1e-4);
        }
    }
}

/* write -> load keeps every value bit for bit and every header field exactly. */
static void test_roundtrip(int v)
{
    ef_tfile_t a, b;
    ef_msg_t m = {{0}};
    uint8_t *ba = NULL, *bb = NULL;
    size_t la = 0, lb = 0;
    const char *path = tmp_path(0, "roundtrip.eft");
    int i, rc;

    make_table(v, &a);
    /* Edge values the format must carry exactly. */
    a.values[0] = (float)a.x1_min;
    a.values[a.view.ndof] = (float)a.x1_max;
    if (a.view.kind == EF_TABLE_G2_QUINTIC) {
        a.values[1] = -0.0f;
        a.values[3] = 0x1p-140f; /* subnormal */
        a.values[5] = (float)-a.x2_max;
    }
    rc = ef_tfile_write(&a, path, &m);
    EF_CHECK_EQ(rc, EF_OK);
    if (rc != EF_OK) {
        fprintf(stderr, "%s: %s\n", v_name[v], m.text);
    }
    rc = ef_tfile_load(path, &b, &m);
    EF_CHECK_EQ(rc, EF_OK);
    if (rc != EF_OK) {
        fprintf(stderr, "%s: %s\n", v_name[v], m.text);
        ef_tfile_free(&a);
        return;
    }
    EF_CHECK(same_view_header(&a.view, &b.view));
    EF_CHECK(memcmp(a.values, b.values, 4u * a.view.nodes * a.view.ndof) == 0);
    EF_CHECK(b.view.data == b.values);
    EF_CHECK(memcmp(a.view.data, b.view.data, 4u * a.view.nodes * a.view.ndof) == 0);
    for (i = 0; i < EF_TABLE_MAX_AXES; i++) {
        EF_CHECK(a.lo[i] == b.lo[i] && a.hi[i] == b.hi[i]);
    }
    EF_CHECK(a.x1_min == b.x1_min && a.x1_max == b.x1_max && a.x2_max == b.x2_max);
    EF_CHECK(strcmp(a.provenance, b.provenance) == 0);
    EF_CHECK(b.view.provenance_len == strlen(a.provenance));
    EF_CHECK(memcmp(b.view.provenance, a.provenance, b.view.provenance_len) == 0);
    EF_CHECK_EQ(ef_table_check(&a.view), EF_OK);
    EF_CHECK_EQ(ef_table_check(&b.view), EF_OK);
    /* Serializing the loaded table reproduces the file byte for byte. */
    EF_CHECK_EQ(ef_tfile_serialize(&a, &ba, &la, &m), EF_OK);
    EF_CHECK_EQ(ef_tfile_serialize(&b, &bb, &lb, &m), EF_OK);
    EF_CHECK(la == lb && ba && bb && memcmp(ba, bb, la) == 0);
    check_nodes_vs_lookup(&b);
    free(ba);
    free(bb);
    /* Values of a loaded table live in its image: editing and rewriting works. */
    b.values[2] = (float)b.x1_max;
    EF_CHECK_EQ(ef_tfile_write(&b, path, &m), EF_OK);
    ef_tfile_free(&a);
    EF_CHECK_EQ(ef_tfile_load(path, &a, &m), EF_OK);
    EF_CHECK(a.values != NULL && same_bits(a.values[2], (float)b.x1_max));
    ef_tfile_free(&a);
    ef_tfile_free(&b);
    ef_tfile_free(&b); /* idempotent */
    unlink(path);
}

/* Largest provenance round-trips; one byte more is refused at create. */
static void test_provenance_limits(void)
{
    static char big[EF_TABLE_MAX_PROVENANCE + 2];
    ef_tfile_spec_t s;
    ef_tfile_t t, u;
    ef_msg_t m = {{0}};
    const char *path = tmp_path(0, "prov.eft");

    memset(big, 'p', EF_TABLE_MAX_PROVENANCE);
    big[EF_TABLE_MAX_PROVENANCE] = '\0';
    spec_for(V_G1_PLAIN, &s);
    s.provenance = big;
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_OK);
    fill_values(&t, 5);
    EF_CHECK_EQ(ef_tfile_write(&t, path, &m), EF_OK);
    EF_CHECK_EQ(ef_tfile_load(path, &u, &m), EF_OK);
    EF_CHECK_EQ(u.view.provenance_len, EF_TABLE_MAX_PROVENANCE);
    EF_CHECK(strcmp(u.provenance, big) == 0);
    ef_tfile_free(&t);
    ef_tfile_free(&u);
    unlink(path);

    big[EF_TABLE_MAX_PROVENANCE] = 'p';
    big[EF_TABLE_MAX_PROVENANCE + 1] = '\0';
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_PROVENANCE);
    EF_CHECK(strstr(m.text, "provenance_len") != NULL);
    s.provenance = NULL; /* NULL means empty */
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_OK);
    EF_CHECK_EQ(t.view.provenance_len, 0u);
    ef_tfile_free(&t);
}

/* ---------------------------------------------------------------------------------------
 * Header fields, one at a time
 * ------------------------------------------------------------------------------------- */

#define AX(i, f) (64u + 24u * (i) + (f)) /* f: 0 lo, 8 hi, 16 nodes, 20 flags */
#define BAD_SAME 0xFFFFFFFFu             /* expected offset: the corrupted field's */
#define BAD_LEN  0xFFFFFFFEu             /* expected offset: the blob length */

typedef struct {
    int v;        /* test table */
    uint32_t off; /* field offset */
    char type;    /* '1', '2', '4' unsigned of that width, 'd' f64 */
    double val;   /* new value */
    int code;     /* expected result */
    uint32_t bad; /* expected *bad_offset: BAD_SAME, BAD_LEN or a value */
    const char *why;
} hcase_t;

static const hcase_t hcases[] = {
    {V_G1_PERIODIC, 8, '2', 2, EF_ERR_TBL_VERSION, BAD_SAME, "version 2"},
    {V_G1_PERIODIC, 8, '2', 0, EF_ERR_TBL_VERSION, BAD_SAME, "version 0"},
    {V_G2_NONE, 10, '2', 159, EF_ERR_TBL_HEADER, BAD_SAME, "header size 159"},
    {V_G2_NONE, 10, '2', 168, EF_ERR_TBL_HEADER, BAD_SAME, "header size 168"},
    {V_G1_PLAIN, 12, '2', 0, EF_ERR_TBL_KIND, BAD_SAME, "kind 0"},
    {V_G1_PLAIN, 12, '2', 3, EF_ERR_TBL_KIND, BAD_SAME, "kind 3"},
    {V_G1_PLAIN, 12, '2', 0x101, EF_ERR_TBL_KIND, BAD_SAME, "kind 0x101"},
    {V_G1_PLAIN, 12, '2', 2, EF_ERR_TBL_SHAPE, 16, "G1 table relabelled G2"},
    {V_G2_NONE, 12, '2', 1, EF_ERR_TBL_SHAPE, 16, "G2 table relabelled G1"},
    {V_G1_PLAIN, 14, '2', 0, EF_ERR_TBL_VALUE_TYPE, BAD_SAME, "value type 0"},
    {V_G2_NONE, 14, '2', 2, EF_ERR_TBL_VALUE_TYPE, BAD_SAME, "value type 2"},
    {V_G1_PLAIN, 16, '1', 4, EF_ERR_TBL_SHAPE, BAD_SAME, "G1 with 4 axes"},
    {V_G2_NONE, 16, '1', 3, EF_ERR_TBL_SHAPE, BAD_SAME, "G2 with 3 axes"},
    {V_G1_PLAIN, 17, '1', 1, EF_ERR_TBL_SHAPE, BAD_SAME, "G1 with 1 DOF"},
    {V_G2_NONE, 17, '1', 2, EF_ERR_TBL_SHAPE, BAD_SAME, "G2 with 2 DOFs"},
    {V_G1_PLAIN, 18, '2', 3, EF_ERR_TBL_SYMMETRY, BAD_SAME, "symmetry 3"},
    {V_G1_PLAIN, 18, '2', 0xFFFF, EF_ERR_TBL_SYMMETRY, BAD_SAME, "symmetry 0xffff"},
    {V_G1_PLAIN, 18, '2', 2, EF_ERR_TBL_SYMMETRY, BAD_SAME, "G2 mirror on G1"},
    {V_G2_NONE, 18, '2', 1, EF_ERR_TBL_SYMMETRY, BAD_SAME, "G1 fold on G2"},
    {V_G1_PLAIN, 18, '2', 1, EF_ERR_TBL_SYMMETRY, AX(0, 0), "fold over a non-fold region"},
    {V_G1_PERIODIC, 18, '2', 1, EF_ERR_TBL_AXIS, AX(0, 20), "fold with periodic axes"},
    {V_G2_NONE, 18, '2', 2, EF_ERR_TBL_SYMMETRY, AX(0, 0), "mirror with alpha < 0"},
    {V_G1_FOLD, 18, '2', 0, EF_OK, 0, "fold region stored unfolded is valid"},
    {V_G2_MIRROR, 18, '2', 0, EF_OK, 0, "mirror half stored unfolded is valid"},
    {V_G1_PLAIN, 20, '2', 0, EF_ERR_TBL_FUNCTIONAL, BAD_SAME, "functional 0"},
    {V_G2_NONE, 20, '2', 2, EF_ERR_TBL_FUNCTIONAL, BAD_SAME, "functional 2"},
    {V_G1_PLAIN, 22, '2', 0, EF_ERR_TBL_FUNCTIONAL, BAD_SAME, "quadrature 0"},
    {V_G2_NONE, 22, '2', 2, EF_ERR_TBL_FUNCTIONAL, BAD_SAME, "quadrature 2"},
    {V_G1_PLAIN, 24, '2', 0, EF_ERR_TBL_FUNCTIONAL, BAD_SAME, "quad nodes 0"},
    {V_G1_PLAIN, 24, '2', 65, EF_ERR_TBL_FUNCTIONAL, BAD_SAME, "quad nodes 65"},
    {V_G1_PLAIN, 24, '2', 1, EF_OK, 0, "quad nodes 1"},
    {V_G2_NONE, 24, '2', 64, EF_OK, 0, "quad nodes 64"},
    {V_G1_PLAIN, 26, '2', 1, EF_ERR_TBL_HEADER, BAD_SAME, "reserved0"},
    {V_G2_NONE, 26, '2', 0x8000, EF_ERR_TBL_HEADER, BAD_SAME, "reserved0 high bit"},
    {V_G1_PLAIN, 28, '4', 21, EF_ERR_TBL_SHAPE, BAD_SAME, "node count + 1"},
    {V_G2_NONE, 28, '4', 71, EF_ERR_TBL_SHAPE, BAD_SAME, "node count - 1"},
    {V_G2_NONE, 28, '4', 0, EF_ERR_TBL_SHAPE, BAD_SAME, "node count 0"},
    {V_G1_PLAIN, 32, 'd', 0.0, EF_ERR_TBL_VALUE, BAD_SAME, "x1_min 0"},
    {V_G1_PLAIN, 32, 'd', -0.1, EF_ERR_TBL_VALUE, BAD_SAME, "x1_min < 0"},
    {V_G1_PLAIN, 32, 'd', NAN, EF_ERR_TBL_VALUE, BAD_SAME, "x1_min NaN"},
    {V_G1_PLAIN, 32, 'd', INFINITY, EF_ERR_TBL_VALUE, BAD_SAME, "x1_min inf"},
    {V_G1_PLAIN, 32, 'd', 1e-50, EF_ERR_TBL_VALUE, BAD_SAME, "x1_min 0 as float"},
    {V_G1_PLAIN, 32, 'd', 4.0, EF_ERR_TBL_VALUE, 40, "x1_min = x1_max"},
    {V_G1_PLAIN, 40, 'd', 0.05, EF_ERR_TBL_VALUE, BAD_SAME, "x1_max < x1_min"},
    {V_G1_PLAIN, 40, 'd', NAN, EF_ERR_TBL_VALUE, BAD_SAME, "x1_max NaN"},
    {V_G1_PLAIN, 40, 'd', INFINITY, EF_ERR_TBL_VALUE, BAD_SAME, "x1_max inf"},
    {V_G1_PLAIN, 40, 'd', 1e39, EF_ERR_TBL_VALUE, BAD_SAME, "x1_max beyond float"},
    {V_G1_PLAIN, 40, 'd', 1e6 * (1 + 1e-12), EF_ERR_TBL_VALUE, BAD_SAME, "x1_max above cap"},
    {V_G1_PLAIN, 40, 'd', 1e6, EF_OK, 0, "x1_max at cap"},
    {V_G1_PLAIN, 32, 'd', 1e6, EF_ERR_TBL_VALUE, BAD_SAME, "x1_min at cap"},
    {V_G1_PLAIN, 40, 'd', 0.1 * (1 + 1e-12), EF_ERR_TBL_VALUE, BAD_SAME, "bounds equal in float"},
    {V_G1_PLAIN, 48, 'd', 1.0, EF_ERR_TBL_VALUE, BAD_SAME, "G1 with an x2 bound"},
    {V_G1_PLAIN, 48, 'd', NAN, EF_ERR_TBL_VALUE, BAD_SAME, "G1 x2 bound NaN"},
    {V_G2_NONE, 48, 'd', -1.0, EF_ERR_TBL_VALUE, BAD_SAME, "x2_max < 0"},
    {V_G2_NONE, 48, 'd', NAN, EF_ERR_TBL_VALUE, BAD_SAME, "x2_max NaN"},
    {V_G2_NONE, 48, 'd', INFINITY, EF_ERR_TBL_VALUE, BAD_SAME, "x2_max inf"},
    {V_G2_NONE, 48, 'd', 1e39, EF_ERR_TBL_VALUE, BAD_SAME, "x2_max beyond float"},
    {V_G2_NONE, 48, 'd', 1e6 * (1 + 1e-12), EF_ERR_TBL_VALUE, BAD_SAME, "x2_max above cap"},
    {V_G2_NONE, 48, 'd', 1e6, EF_OK, 0, "x2_max at cap"},
    {V_G1_PLAIN, 56, '4', EF_TABLE_MAX_PROVENANCE + 1, EF_ERR_TBL_PROVENANCE, BAD_SAME,
     "provenance too long"},
    {V_G1_PLAIN, 56, '4', 0xFFFFFFFFu, EF_ERR_TBL_PROVENANCE, BAD_SAME, "provenance 4 GiB"},
    {V_G1_PLAIN, 56, '4', 8, EF_ERR_TBL_TRUNCATED, BAD_LEN, "provenance longer than stored"},
    {V_G1_PLAIN, 60, '4', 1, EF_ERR_TBL_HEADER, BAD_SAME, "reserved1"},
    {V_G2_NONE, 60, '4', 0x80000000u, EF_ERR_TBL_HEADER, BAD_SAME, "reserved1 high bit"},
    /* Axis domains by kind. */
    {V_G1_PLAIN, AX(0, 0), 'd', -7.0, EF_ERR_TBL_AXIS, BAD_SAME, "G1 alpha below -2 pi"},
    {V_G1_PLAIN, AX(1, 8), 'd', 7.0, EF_ERR_TBL_AXIS, BAD_SAME, "G1 beta above 2 pi"},
    {V_G1_PLAIN, AX(0, 0), 'd', -2 * M_PI, EF_OK, 0, "G1 alpha from -2 pi"},
    {V_G2_NONE, AX(0, 8), 'd', 3.2, EF_ERR_TBL_AXIS, BAD_SAME, "G2 alpha above pi"},
    {V_G2_NONE, AX(1, 0), 'd', -3.2, EF_ERR_TBL_AXIS, BAD_SAME, "G2 beta below -pi"},
    {V_G2_NONE, AX(1, 0), 'd', -M_PI, EF_OK, 0, "G2 beta from -pi"},
    {V_G2_NONE, AX(2, 0), 'd', -1000.5, EF_ERR_TBL_AXIS, BAD_SAME, "k0 below -1e3"},
    {V_G2_NONE, AX(3, 8), 'd', 1000.5, EF_ERR_TBL_AXIS, BAD_SAME, "k1 above 1e3"},
    {V_G2_NONE, AX(3, 8), 'd', 1000.0, EF_OK, 0, "k1 up to 1e3"},
    {V_G2_NONE, AX(2, 8), 'd', -2.0, EF_ERR_TBL_AXIS, BAD_SAME, "empty axis"},
    {V_G2_NONE, AX(2, 8), 'd', -3.0, EF_ERR_TBL_AXIS, BAD_SAME, "decreasing axis"},
    {V_G2_NONE, AX(2, 8), 'd', -2.0 + 1e-12, EF_ERR_TBL_AXIS, BAD_SAME, "empty in float"},
    {V_G2_NONE, AX(2, 0), 'd', 0.0, EF_OK, 0, "k0 from 0"},
    /* Periodic axes. */
    {V_G1_PERIODIC, AX(0, 8), 'd', 2 * M_PI - 1e-6, EF_ERR_TBL_AXIS, AX(0, 20),
     "periodic span short"},
    {V_G1_PERIODIC, AX(1, 0), 'd', -M_PI - 1e-8, EF_ERR_TBL_AXIS, AX(1, 20), "periodic span long"},
    {V_G1_PERIODIC, AX(0, 8), 'd', 2 * M_PI + 5e-10, EF_OK, 0, "periodic span within 1e-9"},
    {V_G1_PERIODIC, AX(0, 20), '4', 0, EF_OK, 0, "2 pi axis need not be periodic"},
    {V_G1_PLAIN, AX(0, 20), '4', 1, EF_ERR_TBL_AXIS, BAD_SAME, "periodic flag on a pi axis"},
    {V_G1_PERIODIC, AX(0, 20), '4', 3, EF_ERR_TBL_AXIS, BAD_SAME, "unknown axis flag"},
    {V_G2_NONE, AX(2, 20), '4', 1, EF_ERR_TBL_AXIS, BAD_SAME, "periodic curvature"},
    {V_G1_FOLD, AX(1, 20), '4', 1, EF_ERR_TBL_AXIS, BAD_SAME, "periodic fold axis"},
    /* Symmetry regions. */
    {V_G1_FOLD, AX(0, 0), 'd', 2e-6, EF_ERR_TBL_SYMMETRY, BAD_SAME, "fold u from 2e-6"},
    {V_G1_FOLD, AX(0, 0), 'd', -5e-7, EF_OK, 0, "fold u from -5e-7"},
    {V_G1_FOLD, AX(0, 8), 'd', M_PI / 2 + 2e-6, EF_ERR_TBL_SYMMETRY, BAD_SAME, "fold u to pi/2+"},
    {V_G1_FOLD, AX(0, 8), 'd', M_PI / 2 - 5e-7, EF_OK, 0, "fold u to pi/2 - 5e-7"},
    {V_G1_FOLD, AX(1, 0), 'd', 1e-5, EF_ERR_TBL_SYMMETRY, BAD_SAME, "fold v from 1e-5"},
    {V_G1_FOLD, AX(1, 8), 'd', 3.0, EF_ERR_TBL_SYMMETRY, BAD_SAME, "fold v to 3"},
    {V_G1_FOLD, AX(1, 8), 'd', 2 * M_PI, EF_ERR_TBL_SYMMETRY, BAD_SAME, "fold v to 2 pi"},
    {V_G2_MIRROR, AX(0, 0), 'd', -0.1, EF_ERR_TBL_SYMMETRY, BAD_SAME, "mirror alpha from -0.1"},
    {V_G2_MIRROR, AX(0, 0), 'd', 1e-12, EF_ERR_TBL_SYMMETRY, BAD_SAME, "mirror alpha from 1e-12"},
    {V_G2_MIRROR, AX(0, 0), 'd', -0.0, EF_OK, 0, "mirror alpha from -0"},
};

/* Write value val of the given type at off. */
static void poke(uint8_t *b, uint32_t off, char type, double val)
{
    switch (type) {
    case '1':
        b[off] = (uint8_t)val;
        break;
    case '2':
        put16(b + off, (uint32_t)val);
        break;
    case '4':
        put32(b + off, (uint32_t)val);
        break;
    default:
        putf64(b + off, val);
        break;
    }
}

/* Parse a corrupted copy (CRC fixed up) and compare code and offset. */
static void expect_parse(const uint8_t *b, size_t len, int code, uint32_t bad, const char *why)
{
    ef_table_t view;
    uint32_t off = 12345;
    int rc = ef_table_parse(b, (uint32_t)len, &view, &off);
    EF_CHECK_EQ(rc, code);
    if (rc == EF_OK) {
        EF_CHECK_EQ(off, 0);
        EF_CHECK_EQ(ef_table_check(&view), EF_OK);
    } else {
        EF_CHECK_EQ(off, bad);
        EF_CHECK(view_is_zero(&view));
    }
    if (rc != code || (rc != EF_OK && off != bad)) {
        fprintf(stderr, "  case: %s (got %s at %u)\n", why, ef_err_str(rc), (unsigned)off);
    }
}

/* Every header field individually, each corrupted value with its code and offset. */
static void test_header_fields(void)
{
    uint8_t *blob[V_COUNT];
    size_t len[V_COUNT], i;
    int v;
    unsigned a, j;

    for (v = 0; v < V_COUNT; v++) {
        blob[v] = make_blob(v, &len[v]);
    }
    for (i = 0; i < sizeof hcases / sizeof hcases[0]; i++) {
        const hcase_t *c = &hcases[i];
        uint8_t *b = malloc(len[c->v]);
        uint32_t bad;
        memcpy(b, blob[c->v], len[c->v]);
        poke(b, c->off, c->type, c->val);
        fix_crc(b, len[c->v]);
        bad = c->bad == BAD_SAME ? c->off : c->bad == BAD_LEN ? (uint32_t)len[c->v] : c->bad;
        expect_parse(b, len[c->v], c->code, bad, c->why);
        free(b);
    }

    /* Provenance length against the stored bytes (length 38: 38 % 8 leaves room either
     * way within the same padded size). */
    {
        const size_t n = len[V_G1_PERIODIC];
        const uint32_t pl = get32(blob[V_G1_PERIODIC] + 56);
        uint8_t *b = malloc(n);
        EF_CHECK(pl % 8u != 0u && pl % 8u != 1u);
        memcpy(b, blob[V_G1_PERIODIC], n);
        put32(b + 56, pl - 1u); /* last character now sits in the padding */
        fix_crc(b, n);
        expect_parse(b, n, EF_ERR_TBL_PROVENANCE, 160u + pl - 1u, "char in padding");
        put32(b + 56, pl + 1u); /* first padding byte now counts as a (NUL) character */
        fix_crc(b, n);
        expect_parse(b, n, EF_ERR_TBL_PROVENANCE, 160u + pl, "NUL as provenance");
        put32(b + 56, pl - 8u);
        fix_crc(b, n);
        expect_parse(b, n, EF_ERR_TBL_SIZE, (uint32_t)n - 8u, "provenance shorter than stored");
        put32(b + 56, pl + 8u);
        fix_crc(b, n);
        expect_parse(b, n, EF_ERR_TBL_TRUNCATED, (uint32_t)n, "provenance longer than stored");
        free(b);
    }

    /* Magic: every byte. */
    for (j = 0; j < 8; j++) {
        uint8_t *b = malloc(len[V_G1_PLAIN]);
        memcpy(b, blob[V_G1_PLAIN], len[V_G1_PLAIN]);
        b[j] ^= 0x20;
        fix_crc(b, len[V_G1_PLAIN]);
        expect_parse(b, len[V_G1_PLAIN], EF_ERR_TBL_MAGIC, 0, "magic byte");
        free(b);
    }

    /* Used axes of every table: non-finite bounds and node counts out of range. */
    for (v = 0; v < V_COUNT; v++) {
        const unsigned naxes = v >= V_G2_NONE ? 4u : 2u;
        for (a = 0; a < naxes; a++) {
            static const struct {
                uint32_t f;
                char type;
                double val;
            } ax[] = {{0, 'd', NAN}, {0, 'd', -INFINITY},   {8, 'd', NAN},   {8, 'd', INFINITY},
                      {16, '4', 0},  {16, '4', 1},          {16, '4', 4097}, {16, '4', 0xFFFFFFFFu},
                      {20, '4', 2},  {20, '4', 0x80000000u}};
            for (j = 0; j < sizeof ax / sizeof ax[0]; j++) {
                uint8_t *b = malloc(len[v]);
                memcpy(b, blob[v], len[v]);
                poke(b, AX(a, ax[j].f), ax[j].type, ax[j].val);
                fix_crc(b, len[v]);
                expect_parse(b, len[v], EF_ERR_TBL_AXIS, AX(a, ax[j].f), "axis field");
                free(b);
            }
        }
        /* Unused axes: any nonzero byte, reported at the field holding it. */
        for (a = naxes; a < EF_TABLE_MAX_AXES; a++) {
            for (j = 0; j < 24; j++) {
                uint8_t *b = malloc(len[v]);
                const uint32_t field = j < 8 ? 0 : j < 16 ? 8 : j < 20 ? 16 : 20;
                memcpy(b, blob[v], len[v]);
                b[AX(a, j)] = 0x01;
                fix_crc(b, len[v]);
                expect_parse(b, len[v], EF_ERR_TBL_AXIS, AX(a, field), "unused axis byte");
                free(b);
            }
        }
    }

    /* Node counts each in range whose product exceeds EF_TABLE_MAX_NODES: SIZE at 28, found
     * before the (then huge) size is ever compared with the blob. */
    {
        uint8_t *b = malloc(len[V_G2_NONE]);
        memcpy(b, blob[V_G2_NONE], len[V_G2_NONE]);
        for (a = 0; a < 4; a++) {
            put32(b + AX(a, 16), 64);
        }
        put32(b + 28, 64u * 64u * 64u * 64u);
        fix_crc(b, len[V_G2_NONE]);
        expect_parse(b, len[V_G2_NONE], EF_ERR_TBL_SIZE, 28, "16 Mi nodes");
        /* 4096^4 does not fit the 32-bit count at all. */
        for (a = 0; a < 4; a++) {
            put32(b + AX(a, 16), 4096);
        }
        fix_crc(b, len[V_G2_NONE]);
        expect_parse(b, len[V_G2_NONE], EF_ERR_TBL_SHAPE, 28, "2^48 nodes");
        free(b);
    }
    {
        /* Exactly the limit is accepted as a shape (then the blob is simply too short). */
        uint8_t *b = malloc(len[V_G1_PLAIN]);
        memcpy(b, blob[V_G1_PLAIN], len[V_G1_PLAIN]);
        put32(b + AX(0, 16), 2048);
        put32(b + AX(1, 16), 2048);
        put32(b + 28, 2048u * 2048u);
        fix_crc(b, len[V_G1_PLAIN]);
        expect_parse(b, len[V_G1_PLAIN], EF_ERR_TBL_TRUNCATED, (uint32_t)len[V_G1_PLAIN],
                     "4 Mi nodes");
        put32(b + AX(0, 16), 2049);
        put32(b + 28, 2049u * 2048u);
        fix_crc(b, len[V_G1_PLAIN]);
        expect_parse(b, len[V_G1_PLAIN], EF_ERR_TBL_SIZE, 28, "4 Mi + 2048 nodes");
        free(b);
    }
    {
        /* An axis so narrow that its float step overflows. */
        uint8_t *b = malloc(len[V_G2_NONE]);
        memcpy(b, blob[V_G2_NONE], len[V_G2_NONE]);
        putf64(b + AX(2, 0), 0.0);
        putf64(b + AX(2, 8), 1e-40);
        fix_crc(b, len[V_G2_NONE]);
        expect_parse(b, len[V_G2_NONE], EF_ERR_TBL_AXIS, AX(2, 8), "inv_step beyond float");
        free(b);
    }
    {
        /* A non-printable provenance with a correct CRC. */
        uint8_t *b = malloc(len[V_G2_NONE]);
        memcpy(b, blob[V_G2_NONE], len[V_G2_NONE]);
        b[160 + 3] = '\t';
        fix_crc(b, len[V_G2_NONE]);
        expect_parse(b, len[V_G2_NONE], EF_ERR_TBL_PROVENANCE, 163, "tab in provenance");
        b[160 + 3] = 0x7F;
        fix_crc(b, len[V_G2_NONE]);
        expect_parse(b, len[V_G2_NONE], EF_ERR_TBL_PROVENANCE, 163, "DEL in provenance");
        b[160 + 3] = 0x00;
        fix_crc(b, len[V_G2_NONE]);
        expect_parse(b, len[V_G2_NONE], EF_ERR_TBL_PROVENANCE, 163, "NUL in provenance");
        free(b);
    }
    for (v = 0; v < V_COUNT; v++) {
        free(blob[v]);
    }
}

/* Every prefix of a valid image is rejected as truncated, read from an exact-size heap
 * buffer so ASan flags any read past the end; trailing bytes are SIZE. */
static void test_truncation(void)
{
    int v;
    size_t n, len;

    for (v = 0; v < V_COUNT; v++) {
        uint8_t *blob = make_blob(v, &len);
        int all_ok = 1;
        for (n = 0; n < len; n++) {
            uint8_t *b = malloc(n ? n : 1);
            ef_table_t view;
            uint32_t off = 0;
            int rc;
            memcpy(b, blob, n);
            rc = ef_table_parse(b, (uint32_t)n, &view, &off);
            all_ok = all_ok && rc == EF_ERR_TBL_TRUNCATED && off == n && view_is_zero(&view);
            free(b);
        }
        EF_CHECK(all_ok);
        for (n = 1; n <= 16; n++) {
            uint8_t *b = calloc(len + n, 1);
            memcpy(b, blob, len);
            expect_parse(b, len + n, EF_ERR_TBL_SIZE, (uint32_t)len, "trailing bytes");
            free(b);
        }
        free(blob);
    }
}

/* Any single bit flip is caught: past the header always by the CRC, in the header by a
 * field check or the CRC, never accepted. */
static void test_bitflips(void)
{
    int v;
    size_t len, i;

    for (v = 0; v < V_COUNT; v++) {
        uint8_t *blob = make_blob(v, &len);
        int body_crc = 1, header_rejected = 1;
        for (i = 0; i < len * 8; i++) {
            ef_table_t view;
            uint32_t off = 0;
            int rc;
            blob[i / 8] ^= (uint8_t)(1u << (i % 8));
            rc = ef_table_parse(blob, (uint32_t)len, &view, &off);
            blob[i / 8] ^= (uint8_t)(1u << (i % 8));
            if (i / 8 >= EF_TABLE_HEADER_SIZE) {
                body_crc = body_crc && rc == EF_ERR_TBL_CRC && off == len - 4;
            } else {
                header_rejected = header_rejected && rc != EF_OK && view_is_zero(&view);
            }
        }
        EF_CHECK(body_crc);
        EF_CHECK(header_rejected);
        expect_parse(blob, len, EF_OK, 0, "unflipped");
        free(blob);
    }
}

/* Values are checked after the CRC: NaN, infinities and out-of-box values with a valid
 * CRC are VALUE at the first bad value's offset; the 1e-6 relative slack is honoured. */
static void test_values(void)
{
    static const struct {
        int v;
        uint32_t k; /* value index */
        float val;
        int code;
        const char *why;
    } cases[] = {
        {V_G1_PLAIN, 0, NAN, EF_ERR_TBL_VALUE, "NaN x1"},
        {V_G1_PLAIN, 39, INFINITY, EF_ERR_TBL_VALUE, "inf, last value"},
        {V_G1_PLAIN, 5, -INFINITY, EF_ERR_TBL_VALUE, "-inf"},
        {V_G1_PLAIN, 3, -1.0f, EF_ERR_TBL_VALUE, "negative x1"},
        {V_G1_PLAIN, 3, 0.0f, EF_ERR_TBL_VALUE, "zero x1"},
        {V_G1_PLAIN, 3, (float)(0.1 * (1 - 2e-6)), EF_ERR_TBL_VALUE, "x1 below min"},
        {V_G1_PLAIN, 3, (float)(0.1 * (1 - 5e-7)), EF_OK, "x1 within slack below"},
        {V_G1_PLAIN, 3, (float)(4.0 * (1 + 2e-6)), EF_ERR_TBL_VALUE, "x1 above max"},
        {V_G1_PLAIN, 3, (float)(4.0 * (1 + 5e-7)), EF_OK, "x1 within slack above"},
        {V_G1_PLAIN, 3, 1e30f, EF_ERR_TBL_VALUE, "huge x1"},
        {V_G2_NONE, 0, NAN, EF_ERR_TBL_VALUE, "NaN x1_0"},
        {V_G2_NONE, 1, NAN, EF_ERR_TBL_VALUE, "NaN x2_0"},
        {V_G2_NONE, 7, INFINITY, EF_ERR_TBL_VALUE, "inf x2_1"},
        {V_G2_NONE, 2, -0.5f, EF_ERR_TBL_VALUE, "negative x1_1"},
        {V_G2_NONE, 3, (float)(8.0 * (1 + 2e-6)), EF_ERR_TBL_VALUE, "x2 above bound"},
        {V_G2_NONE, 3, (float)(-8.0 * (1 + 2e-6)), EF_ERR_TBL_VALUE, "x2 below -bound"},
        {V_G2_NONE, 3, -8.0f, EF_OK, "x2 at -bound"},
        {V_G2_NONE, 3, -0.0f, EF_OK, "x2 -0"},
        {V_G2_NONE, 3, 0x1p-149f, EF_OK, "x2 smallest subnormal"},
        {V_G2_NONE, 0, 5.0f, EF_ERR_TBL_VALUE, "x1_0 = 5 above x1_max"},
        {V_G2_MIRROR, 287, NAN, EF_ERR_TBL_VALUE, "NaN, last value"},
    };
    size_t i, len;

    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        uint8_t *b = make_blob(cases[i].v, &len);
        const uint32_t at = data_offset(b) + 4u * cases[i].k;
        memcpy(b + at, &cases[i].val, 4);
        fix_crc(b, len);
        expect_parse(b, len, cases[i].code, at, cases[i].why);
        free(b);
    }
    {
        /* Exact edges of the slack: the first float inside each bound passes, the next float
         * outward fails (the parser compares in float but must mean the real bound). */
        const double edges[3] = {0.1 * (1 - 1e-6), 4.0 * (1 + 1e-6), 8.0 * (1 + 1e-6)};
        int e;
        for (e = 0; e < 3; e++) {
            float in = (float)edges[e], out;
            const uint32_t k = e == 2 ? 3u : 2u; /* x2_1 or x1_1 of node 0 */
            uint8_t *b = make_blob(V_G2_NONE, &len);
            const uint32_t at = data_offset(b) + 4u * k;
            if (e == 0 ? (double)in < edges[e] : (double)in > edges[e]) {
                in = nextafterf(in, e == 0 ? 1.0f : 0.0f);
            }
            out = nextafterf(in, e == 0 ? 0.0f : 100.0f);
            memcpy(b + at, &in, 4);
            fix_crc(b, len);
            expect_parse(b, len, EF_OK, 0, "first float inside the slack");
            memcpy(b + at, &out, 4);
            fix_crc(b, len);
            expect_parse(b, len, EF_ERR_TBL_VALUE, at, "first float outside the slack");
            if (e == 2) {
                in = -in;
                out = -out;
                memcpy(b + at, &in, 4);
                fix_crc(b, len);
                expect_parse(b, len, EF_OK, 0, "x2 at -bound edge");
                memcpy(b + at, &out, 4);
                fix_crc(b, len);
                expect_parse(b, len, EF_ERR_TBL_VALUE, at, "x2 past -bound edge");
            }
            free(b);
        }
    }
    {
        /* Two bad values: the first is reported. */
        uint8_t *b = make_blob(V_G2_NONE, &len);
        const float nan = NAN, neg = -1.0f;
        const uint32_t d = data_offset(b);
        memcpy(b + d + 4u * 10, &neg, 4);
        memcpy(b + d + 4u * 20, &nan, 4);
        fix_crc(b, len);
        expect_parse(b, len, EF_ERR_TBL_VALUE, d + 40u, "first of two");
        /* Without fixing the CRC the corruption is reported as such. */
        memcpy(b + d + 4u * 10, &nan, 4);
        expect_parse(b, len, EF_ERR_TBL_CRC, (uint32_t)len - 4u, "stale CRC");
        free(b);
    }
}

/* Arguments: NULL pointers and misaligned blobs are ARG, and the view is still zeroed. */
static void test_args(void)
{
    size_t len;
    uint8_t *blob = make_blob(V_G1_PERIODIC, &len);
    uint8_t *shifted = malloc(len + 4);
    ef_table_t view;
    uint32_t off = 99;
    int s;

    for (s = 1; s < 4; s++) {
        memcpy(shifted + s, blob, len);
        memset(&view, 0xAB, sizeof view);
        EF_CHECK_EQ(ef_table_parse(shifted + s, (uint32_t)len, &view, &off), EF_ERR_ARG);
        EF_CHECK(view_is_zero(&view));
    }
    memcpy(shifted, blob, len);
    EF_CHECK_EQ(ef_table_parse(shifted, (uint32_t)len, &view, NULL), EF_OK);
    EF_CHECK_EQ(ef_table_parse(NULL, (uint32_t)len, &view, &off), EF_ERR_ARG);
    EF_CHECK(view_is_zero(&view));
    EF_CHECK_EQ(ef_table_parse(blob, (uint32_t)len, NULL, &off), EF_ERR_ARG);
    free(shifted);
    free(blob);
}

/* The derived step of an axis after a test has moved its bounds. */
static float inv_step_of(const ef_table_axis_t *a)
{
    return (float)((double)(a->nodes - 1) / ((double)a->hi - (double)a->lo));
}

/* ef_table_check: accepts every parsed view, and each broken derived field has its code. */
static void test_check(void)
{
    uint8_t *blob[V_COUNT];
    ef_table_t view[V_COUNT], t;
    size_t len;
    int v;

    for (v = 0; v < V_COUNT; v++) {
        blob[v] = make_blob(v, &len);
        EF_CHECK_EQ(ef_table_parse(blob[v], (uint32_t)len, &view[v], NULL), EF_OK);
        EF_CHECK_EQ(ef_table_check(&view[v]), EF_OK);
    }
    EF_CHECK_EQ(ef_table_check(NULL), EF_ERR_ARG);
    t = view[V_G1_PLAIN], t.data = NULL;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_ARG);
    t = view[V_G1_PLAIN], t.provenance = NULL;
    EF_CHECK_EQ(ef_table_check(&t), EF_OK); /* empty provenance */
    t = view[V_G2_NONE], t.provenance = NULL;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_ARG);
    t = view[V_G1_PLAIN], t.kind = 3;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_KIND);
    t = view[V_G1_PLAIN], t.naxes = 4;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_SHAPE);
    t = view[V_G2_NONE], t.ndof = 2;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_SHAPE);
    t = view[V_G2_NONE], t.axis[2].stride++;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_SHAPE);
    t = view[V_G1_PLAIN], t.axis[0].stride = 0;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_SHAPE);
    t = view[V_G1_PLAIN], t.nodes++;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_SHAPE);
    t = view[V_G1_PERIODIC], t.axis[1].inv_step *= 1.001f;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_AXIS);
    t = view[V_G1_PERIODIC], t.axis[1].hi = t.axis[1].lo;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_AXIS);
    t = view[V_G1_PERIODIC], t.axis[0].lo = NAN;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_AXIS);
    t = view[V_G1_PERIODIC];
    t.axis[0].hi -= 0.01f;
    t.axis[0].inv_step = inv_step_of(&t.axis[0]);
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_AXIS); /* periodic, not 2 pi */
    t = view[V_G1_FOLD], t.axis[0].flags = EF_AXIS_PERIODIC;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_AXIS); /* periodic only without symmetry */
    t = view[V_G2_NONE], t.axis[3].flags = EF_AXIS_PERIODIC;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_AXIS); /* and only for G1 */
    t = view[V_G1_PLAIN], t.axis[1].flags = 2;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_AXIS);
    t = view[V_G1_PLAIN], t.axis[1].nodes = 1;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_AXIS);
    t = view[V_G1_PLAIN], t.axis[3].lo = 1.0f;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_AXIS);
    t = view[V_G1_PLAIN], t.axis[2].stride = 20;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_AXIS);
    t = view[V_G2_NONE], t.axis[2].hi = 2000.0f;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_AXIS);
    t = view[V_G1_FOLD], t.symmetry = 7;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_SYMMETRY);
    t = view[V_G1_FOLD], t.symmetry = EF_SYM_G2_MIRROR;
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_SYMMETRY);
    t = view[V_G1_FOLD];
    t.axis[1].hi = 3.0f;
    t.axis[1].inv_step = inv_step_of(&t.axis[1]);
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_SYMMETRY);
    t = view[V_G2_MIRROR];
    t.axis[0].lo = -0.1f;
    t.axis[0].inv_step = inv_step_of(&t.axis[0]);
    EF_CHECK_EQ(ef_table_check(&t), EF_ERR_TBL_SYMMETRY);
    for (v = 0; v < V_COUNT; v++) {
        free(blob[v]);
    }
}

/* ---------------------------------------------------------------------------------------
 * Host API
 * ------------------------------------------------------------------------------------- */

/* Invalid specs come back with the parser's code and a message naming the field; values
 * of a new table are zero and therefore refused when written. */
static void test_create(void)
{
    ef_tfile_spec_t s;
    ef_tfile_t t;
    ef_msg_t m;
    uint8_t dummy = 0, *b = &dummy;
    size_t len = 1;
    uint32_t k;

    spec_for(V_G1_PLAIN, &s);
    EF_CHECK_EQ(ef_tfile_create(NULL, &s, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_tfile_create(&t, NULL, &m), EF_ERR_ARG);

    spec_for(V_G1_PLAIN, &s), s.kind = 7;
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_KIND);
    EF_CHECK(strstr(m.text, "'kind'") && strstr(m.text, "(7)"));
    EF_CHECK(t.values == NULL);
    ef_tfile_free(&t);
    spec_for(V_G1_PLAIN, &s), s.kind = 65537; /* must not wrap to 1 */
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_KIND);
    spec_for(V_G2_NONE, &s), s.symmetry = EF_SYM_G1_FOLD;
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_SYMMETRY);
    spec_for(V_G2_NONE, &s), s.symmetry = 65536 + EF_SYM_G2_MIRROR;
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_SYMMETRY);
    spec_for(V_G1_PLAIN, &s), s.symmetry = -1;
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_SYMMETRY);
    spec_for(V_G1_PLAIN, &s), s.quad_nodes = 0;
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_FUNCTIONAL);
    EF_CHECK(strstr(m.text, "quad_nodes") != NULL);
    spec_for(V_G1_PLAIN, &s), s.quad_nodes = 65536 + 16;
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_FUNCTIONAL);
    spec_for(V_G1_PLAIN, &s), s.provenance = "line\nbreak";
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_PROVENANCE);
    EF_CHECK(strstr(m.text, "provenance[4]") != NULL);
    spec_for(V_G1_PLAIN, &s), s.provenance = "caf\xc3\xa9";
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_PROVENANCE);
    spec_for(V_G1_PLAIN, &s), s.nodes[1] = 1;
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_AXIS);
    EF_CHECK(strstr(m.text, "axis[1].nodes") != NULL);
    spec_for(V_G2_NONE, &s), s.nodes[0] = s.nodes[1] = s.nodes[2] = s.nodes[3] = 64;
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_SIZE);
    spec_for(V_G2_NONE, &s), s.nodes[0] = s.nodes[1] = s.nodes[2] = s.nodes[3] = 4096;
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_SIZE); /* 2^48: saturated count */
    EF_CHECK(strstr(m.text, "node_count") != NULL);
    spec_for(V_G2_NONE, &s), s.nodes[0] = s.nodes[1] = s.nodes[2] = s.nodes[3] = 70000;
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_AXIS);
    spec_for(V_G1_PLAIN, &s), s.lo[2] = 1.0; /* unused axis must be zero */
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_AXIS);
    spec_for(V_G1_PLAIN, &s), s.x1_min = 0.0;
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_VALUE);
    EF_CHECK(strstr(m.text, "x1_min") != NULL);
    spec_for(V_G1_PLAIN, &s), s.x2_max = 1.0;
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_VALUE);
    spec_for(V_G1_FOLD, &s), s.hi[1] = 2 * M_PI;
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_SYMMETRY);
    spec_for(V_G1_PLAIN, &s), s.axis_flags[0] = EF_AXIS_PERIODIC;
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_ERR_TBL_AXIS);
    EF_CHECK(strstr(m.text, "axis[0].flags") != NULL);

    /* A valid spec: values zero, view usable for shape, writing refused. */
    spec_for(V_G2_MIRROR, &s);
    EF_CHECK_EQ(ef_tfile_create(&t, &s, &m), EF_OK);
    EF_CHECK(t.values != NULL && t.view.data == t.values && t.blob == NULL);
    EF_CHECK_EQ(t.view.nodes, 72u);
    EF_CHECK_EQ(t.view.axis[3].stride, 36u);
    EF_CHECK_EQ(ef_table_check(&t.view), EF_OK);
    for (k = 0; k < 4u * t.view.nodes; k++) {
        EF_CHECK(t.values[k] == 0.0f);
    }
    EF_CHECK_EQ(ef_tfile_serialize(&t, &b, &len, &m), EF_ERR_TBL_VALUE);
    EF_CHECK(b == NULL && len == 0);
    EF_CHECK(strstr(m.text, "values[node 0, dof 0]") != NULL);
    EF_CHECK_EQ(ef_tfile_serialize(&t, NULL, &len, &m), EF_ERR_ARG);
    /* Filling x1 only leaves x2 = 0, which is valid; one x1 left 0 is not. */
    for (k = 0; k < 4u * t.view.nodes; k += 2) {
        t.values[k] = 1.0f;
    }
    EF_CHECK_EQ(ef_tfile_serialize(&t, &b, &len, &m), EF_OK);
    free(b);
    t.values[4u * 71 + 2] = 0.0f;
    EF_CHECK_EQ(ef_tfile_serialize(&t, &b, &len, &m), EF_ERR_TBL_VALUE);
    EF_CHECK(strstr(m.text, "values[node 71, dof 2]") != NULL);
    ef_tfile_free(&t);
    EF_CHECK(t.values == NULL);
}

/* Node coordinates: grid points from the exact double domain, fold unfolded to angles. */
static void test_node_config(void)
{
    ef_tfile_t t;
    double cfg[4];
    uint32_t iu, iv;

    make_table(V_G1_PERIODIC, &t);
    ef_tfile_node_config(&t, 0, cfg);
    EF_CHECK(cfg[0] == 0.0 && cfg[1] == -M_PI && cfg[2] == 0.0 && cfg[3] == 0.0);
    ef_tfile_node_config(&t, t.view.nodes - 1, cfg);
    EF_CHECK(cfg[0] == 2 * M_PI && cfg[1] == M_PI);
    ef_tfile_node_config(&t, 3 + 9 * 2, cfg);
    EF_CHECK_NEAR(cfg[0], 3 * 2 * M_PI / 8, 1e-15);
    EF_CHECK_NEAR(cfg[1], -M_PI + 2 * 2 * M_PI / 6, 1e-15);
    cfg[0] = 42.0;
    ef_tfile_node_config(&t, t.view.nodes, cfg); /* out of range: zeros */
    EF_CHECK(cfg[0] == 0.0 && cfg[1] == 0.0);
    ef_tfile_node_config(NULL, 0, cfg);
    ef_tfile_node_config(&t, 0, NULL);
    ef_tfile_free(&t);

    make_table(V_G1_FOLD, &t);
    for (iv = 0; iv < 11; iv++) {
        for (iu = 0; iu < 6; iu++) {
            const double u = iu == 5 ? M_PI / 2 : (M_PI / 2) * iu / 5;
            const double v = iv == 10 ? M_PI : M_PI * iv / 10;
            ef_tfile_node_config(&t, iu + 6 * iv, cfg);
            EF_CHECK_NEAR(cfg[0], u + v, 1e-15);
            EF_CHECK_NEAR(cfg[1], u - v, 1e-15);
        }
    }
    ef_tfile_free(&t);

    make_table(V_G2_MIRROR, &t);
    ef_tfile_node_config(&t, 1 + 3 * 2 + 12 * 1 + 36 * 1, cfg);
    EF_CHECK_NEAR(cfg[0], M_PI / 4, 1e-15);
    EF_CHECK_NEAR(cfg[1], -M_PI / 2 + 2 * M_PI / 3, 1e-15);
    EF_CHECK(cfg[2] == 0.0 && cfg[3] == 2.0);
    ef_tfile_free(&t);
}

/* Field names for messages, by any byte of the field. */
static void test_field_names(void)
{
    EF_CHECK(strcmp(ef_tfile_field_name(0), "magic") == 0);
    EF_CHECK(strcmp(ef_tfile_field_name(7), "magic") == 0);
    EF_CHECK(strcmp(ef_tfile_field_name(12), "kind") == 0);
    EF_CHECK(strcmp(ef_tfile_field_name(13), "kind") == 0);
    EF_CHECK(strcmp(ef_tfile_field_name(17), "dof_count") == 0);
    EF_CHECK(strcmp(ef_tfile_field_name(28), "node_count") == 0);
    EF_CHECK(strcmp(ef_tfile_field_name(45), "x1_max") == 0);
    EF_CHECK(strcmp(ef_tfile_field_name(64), "axis[0].lo") == 0);
    EF_CHECK(strcmp(ef_tfile_field_name(104), "axis[1].nodes") == 0);
    EF_CHECK(strcmp(ef_tfile_field_name(159), "axis[3].flags") == 0);
    EF_CHECK(strcmp(ef_tfile_field_name(160), "body") == 0);
    EF_CHECK(strcmp(ef_tfile_field_name(0xFFFFFFFFu), "body") == 0);
}

/* Atomic write leaves exactly the target file; failures leave the old file untouched;
 * load reports I/O and format errors with the path, field and offset. */
static void test_write_load(void)
{
    ef_tfile_t t, u, z;
    ef_msg_t m;
    ef_tfile_spec_t s;
    char first[256], expect[1024];
    const char *path = tmp_path(0, "t.eft");
    const char *raw = tmp_path(1, "raw.eft");
    uint8_t *b;
    size_t len;
    FILE *f;

    EF_CHECK_EQ(tmp_entries(first, sizeof first), 0);
    make_table(V_G2_NONE, &t);
    EF_CHECK_EQ(ef_tfile_write(&t, path, &m), EF_OK);
    EF_CHECK_EQ(tmp_entries(first, sizeof first), 1);
    EF_CHECK(strcmp(first, "t.eft") == 0);

    /* Overwrite with a different table: readers get the new one, still one file. */
    ef_tfile_free(&t);
    make_table(V_G1_FOLD, &t);
    EF_CHECK_EQ(ef_tfile_write(&t, path, &m), EF_OK);
    EF_CHECK_EQ(tmp_entries(first, sizeof first), 1);
    EF_CHECK_EQ(ef_tfile_load(path, &u, &m), EF_OK);
    EF_CHECK_EQ(u.view.symmetry, EF_SYM_G1_FOLD);
    ef_tfile_free(&u);

    /* Refused write (unfilled values): no temporary left, old file intact. */
    spec_for(V_G2_NONE, &s);
    EF_CHECK_EQ(ef_tfile_create(&z, &s, &m), EF_OK);
    EF_CHECK_EQ(ef_tfile_write(&z, path, &m), EF_ERR_TBL_VALUE);
    EF_CHECK_EQ(tmp_entries(first, sizeof first), 1);
    EF_CHECK_EQ(ef_tfile_load(path, &u, &m), EF_OK);
    EF_CHECK_EQ(u.view.symmetry, EF_SYM_G1_FOLD);
    ef_tfile_free(&u);
    ef_tfile_free(&z);

    /* Rename onto a directory fails: I/O error, temporary removed. */
    EF_CHECK_EQ(mkdir(tmp_path(2, "adir"), 0755), 0);
    EF_CHECK_EQ(ef_tfile_write(&t, tmp_path(2, "adir"), &m), EF_ERR_IO);
    EF_CHECK(strstr(m.text, "adir") != NULL);
    EF_CHECK_EQ(tmp_entries(NULL, 0), 2);
    rmdir(tmp_path(2, "adir"));
    /* Missing directory. */
    EF_CHECK_EQ(ef_tfile_write(&t, tmp_path(2, "no/such/dir/t.eft"), &m), EF_ERR_IO);
    EF_CHECK(strstr(m.text, "no/such/dir/t.eft") != NULL);
    EF_CHECK_EQ(ef_tfile_write(&t, "", &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_tfile_write(NULL, path, &m), EF_ERR_ARG);

    /* Load: missing file, directory, empty file. */
    EF_CHECK_EQ(ef_tfile_load(tmp_path(2, "missing.eft"), &u, &m), EF_ERR_IO);
    EF_CHECK(strstr(m.text, "missing.eft") != NULL && strstr(m.text, strerror(ENOENT)) != NULL);
    EF_CHECK(u.values == NULL && u.blob == NULL);
    EF_CHECK_EQ(ef_tfile_load(tmp_dir, &u, &m), EF_ERR_IO);
    write_raw(raw, "", 0);
    EF_CHECK_EQ(ef_tfile_load(raw, &u, &m), EF_ERR_TBL_TRUNCATED);
    EF_CHECK(strstr(m.text, raw) != NULL);
    EF_CHECK_EQ(ef_tfile_load(NULL, &u, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_tfile_load(path, NULL, &m), EF_ERR_ARG);

    /* Format errors: the message names path, field, offset and value. */
    EF_CHECK_EQ(ef_tfile_serialize(&t, &b, &len, &m), EF_OK);
    put16(b + 12, 7);
    fix_crc(b, len);
    write_raw(raw, b, len);
    EF_CHECK_EQ(ef_tfile_load(raw, &u, &m), EF_ERR_TBL_KIND);
    snprintf(expect, sizeof expect, "%s: field 'kind' (offset 12): unknown table kind (7)", raw);
    EF_CHECK(strcmp(m.text, expect) == 0);
    if (strcmp(m.text, expect) != 0) {
        fprintf(stderr, "  got '%s'\n", m.text);
    }
    put16(b + 12, EF_TABLE_G1_CUBIC);
    putf64(b + 72, 2.0); /* fold u hi */
    fix_crc(b, len);
    write_raw(raw, b, len);
    EF_CHECK_EQ(ef_tfile_load(raw, &u, &m), EF_ERR_TBL_SYMMETRY);
    EF_CHECK(strstr(m.text, "field 'axis[0].hi' (offset 72)") && strstr(m.text, "(2)"));
    putf64(b + 72, M_PI / 2);
    b[len - 9] ^= 1u; /* data, CRC stale */
    write_raw(raw, b, len);
    EF_CHECK_EQ(ef_tfile_load(raw, &u, &m), EF_ERR_TBL_CRC);
    EF_CHECK(strstr(m.text, "field 'crc'") && strstr(m.text, "computed"));
    fix_crc(b, len);
    {
        const float nan = NAN;
        memcpy(b + data_offset(b) + 4u * 5, &nan, 4);
    }
    fix_crc(b, len);
    write_raw(raw, b, len);
    EF_CHECK_EQ(ef_tfile_load(raw, &u, &m), EF_ERR_TBL_VALUE);
    EF_CHECK(strstr(m.text, "values[node 2, dof 1]") != NULL);
    write_raw(raw, b, len - 1);
    EF_CHECK_EQ(ef_tfile_load(raw, &u, &m), EF_ERR_TBL_TRUNCATED);
    b[1] = 'X';
    write_raw(raw, b, len);
    EF_CHECK_EQ(ef_tfile_load(raw, &u, &m), EF_ERR_TBL_MAGIC);
    EF_CHECK(strstr(m.text, "field 'magic' (offset 0)") && strstr(m.text, "45 58 54 42"));
    free(b);

    /* Nonzero provenance padding (the fold table's provenance is 15 bytes). */
    EF_CHECK_EQ(ef_tfile_serialize(&t, &b, &len, &m), EF_OK);
    EF_CHECK_EQ(get32(b + 56), 15u);
    b[160 + 15] = ' ';
    fix_crc(b, len);
    write_raw(raw, b, len);
    EF_CHECK_EQ(ef_tfile_load(raw, &u, &m), EF_ERR_TBL_PROVENANCE);
    EF_CHECK(strstr(m.text, "'provenance padding' (offset 175)") != NULL);
    free(b);

    /* A bare file name is written in the current directory (its fsync target is "."). */
    {
        char cwd[1024];
        if (getcwd(cwd, sizeof cwd) != NULL && chdir(tmp_dir) == 0) {
            EF_CHECK_EQ(ef_tfile_write(&t, "rel.eft", &m), EF_OK);
            EF_CHECK_EQ(ef_tfile_load("rel.eft", &u, &m), EF_OK);
            ef_tfile_free(&u);
            unlink("rel.eft");
            EF_CHECK_EQ(chdir(cwd), 0);
        }
    }

    /* Trailing garbage and absurd sizes: SIZE, the latter without reading the file. */
    EF_CHECK_EQ(ef_tfile_serialize(&t, &b, &len, &m), EF_OK);
    f = fopen(raw, "wb");
    EF_CHECK(f != NULL);
    if (f) {
        fwrite(b, 1, len, f);
        fputc(0, f);
        fclose(f);
    }
    EF_CHECK_EQ(ef_tfile_load(raw, &u, &m), EF_ERR_TBL_SIZE);
    EF_CHECK(strstr(m.text, "header implies") != NULL);
    free(b);
    EF_CHECK_EQ(truncate(raw, (off_t)1 << 31), 0);
    EF_CHECK_EQ(ef_tfile_load(raw, &u, &m), EF_ERR_TBL_SIZE);
    EF_CHECK(strstr(m.text, "larger than any valid table") != NULL);
    unlink(raw);
    ef_tfile_free(&t);
    unlink(path);
    EF_CHECK_EQ(tmp_entries(NULL, 0), 0);
}

/* The emitter: identifiers, escaping, refusal of invalid tables, write errors. */
static void test_emit(void)
{
    ef_tfile_t t, z;
    ef_tfile_spec_t s;
    ef_msg_t m;
    FILE *f = tmpfile();
    char *text;
    long n;
    static const char *const bad_names[] = {"", "1abc", "a-b", "int", "a b", "_Bool", "x\n"};
    size_t i;

    make_table(V_G2_NONE, &t);
    EF_CHECK(f != NULL);
    if (f == NULL) {
        return;
    }
    EF_CHECK_EQ(ef_tfile_emit_c(&t, "my_table", f, &m), EF_OK);
    n = ftell(f);
    text = calloc((size_t)n + 1, 1);
    rewind(f);
    EF_CHECK(fread(text, 1, (size_t)n, f) == (size_t)n);
    EF_CHECK(strstr(text, "DO NOT EDIT") != NULL);
    EF_CHECK(strstr(text, "ef_tfile_emit_c") != NULL);
    EF_CHECK(strstr(text, "#include \"evenfeed/table/ef_table.h\"") != NULL);
    EF_CHECK(strstr(text, "static const float my_table_data[288]") != NULL);
    EF_CHECK(strstr(text, "const ef_table_t my_table = {") != NULL);
    EF_CHECK(strstr(text, "\\\"quoted\\\" \\\\ \\?\\?= */") != NULL);
    EF_CHECK(strstr(text, ".stride = 36u") != NULL);
    free(text);
    fclose(f);

    for (i = 0; i < sizeof bad_names / sizeof bad_names[0]; i++) {
        EF_CHECK_EQ(ef_tfile_emit_c(&t, bad_names[i], stdout, &m), EF_ERR_ARG);
    }
    EF_CHECK_EQ(ef_tfile_emit_c(&t, "ok", NULL, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_tfile_emit_c(NULL, "ok", stdout, &m), EF_ERR_ARG);

    spec_for(V_G1_PLAIN, &s);
    EF_CHECK_EQ(ef_tfile_create(&z, &s, &m), EF_OK);
    EF_CHECK_EQ(ef_tfile_emit_c(&z, "zero", stdout, &m), EF_ERR_TBL_VALUE);
    /* Empty provenance is an empty string literal. */
    fill_values(&z, 3);
    f = tmpfile();
    if (f != NULL) {
        EF_CHECK_EQ(ef_tfile_emit_c(&z, "plain", f, &m), EF_OK);
        n = ftell(f);
        text = calloc((size_t)n + 1, 1);
        rewind(f);
        EF_CHECK(fread(text, 1, (size_t)n, f) == (size_t)n);
        EF_CHECK(strstr(text, "static const char plain_provenance[] = \"\";") != NULL);
        EF_CHECK(strstr(text, ".provenance_len = 0u,") != NULL);
        free(text);
        fclose(f);
    }
    ef_tfile_free(&z);

    f = fopen("/dev/full", "w");
    if (f != NULL) {
        EF_CHECK_EQ(ef_tfile_emit_c(&t, "full", f, &m), EF_ERR_IO);
        fclose(f);
    }
    ef_tfile_free(&t);
}

/* Build-time mode: write a table with awkward contents (escapes, subnormal, -0) and its C
 * source, for test_tfile_emitted to compile and compare. */
static int emit_mode(int argc, char **argv)
{
    ef_tfile_t t;
    ef_msg_t m;
    FILE *f;
    int v, rc;

    if (argc != 6 || (strcmp(argv[2], "g1") != 0 && strcmp(argv[2], "g2") != 0)) {
        fprintf(stderr, "usage: %s --emit g1|g2 NAME OUT.c OUT.eft\n", argv[0]);
        return 2;
    }
    v = strcmp(argv[2], "g1") == 0 ? V_G1_FOLD : V_G2_MIRROR;
    make_table(v, &t);
    if (v == V_G1_FOLD) {
        snprintf(t.provenance, sizeof t.provenance, "%s",
                 "emit test: \"q\" \\ ?\?= ?\?/ */ /* %s 'c' trailing backslash \\");
    } else {
        t.values[1] = -0.0f;
        t.values[3] = 0x1p-149f;
        t.values[5] = -0x1.fffffcp-127f; /* largest subnormal */
        t.values[6] = (float)t.x1_max;
    }
    rc = ef_tfile_write(&t, argv[5], &m);
    if (rc == EF_OK) {
        f = fopen(argv[4], "w");
        if (f == NULL) {
            perror(argv[4]);
            ef_tfile_free(&t);
            return 1;
        }
        rc = ef_tfile_emit_c(&t, argv[3], f, &m);
        if (fclose(f) != 0 && rc == EF_OK) {
            rc = EF_ERR_IO;
        }
    }
    if (rc != EF_OK) {
        fprintf(stderr, "%s\n", m.text);
    }
    ef_tfile_free(&t);
    return rc == EF_OK ? 0 : 1;
}

/* Unit tests, or the build-time --emit mode. */
/* test_roundtrip for every variant. */
static void test_roundtrip_all(void)
{
    int v;

    for (v = 0; v < V_COUNT; v++) {
        test_roundtrip(v);
    }
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"crc", test_crc},
        {"roundtrip", test_roundtrip_all},
        {"provenance_limits", test_provenance_limits},
        {"header_fields", test_header_fields},
        {"truncation", test_truncation},
        {"bitflips", test_bitflips},
        {"values", test_values},
        {"args", test_args},
        {"check", test_check},
        {"create", test_create},
        {"node_config", test_node_config},
        {"field_names", test_field_names},
        {"write_load", test_write_load},
        {"emit", test_emit},
    };
    int rc;

    if (argc > 1 && strcmp(argv[1], "--emit") == 0) {
        return emit_mode(argc, argv); /* not a check: its arguments are checked there */
    }
    tmp_setup();
    rc = EF_TEST_RUN(argc, argv, 1, parts);
    tmp_cleanup();
    return rc;
}

#else /* EF_TFILE_EMITTED */

/* Defined by the generated sources (tfile_emitted/g1.c, g2.c). */
extern const ef_table_t ef_emitted_g1, ef_emitted_g2;

/* The compiled-in view equals the one parsed from the file, values bit for bit. */
static void check_emitted(const ef_table_t *c, const char *path)
{
    ef_tfile_t t;
    ef_msg_t m;
    int rc = ef_tfile_load(path, &t, &m);

    EF_CHECK_EQ(rc, EF_OK);
    if (rc != EF_OK) {
        fprintf(stderr, "%s\n", m.text);
        return;
    }
    EF_CHECK_EQ(ef_table_check(c), EF_OK);
    EF_CHECK(same_view_header(c, &t.view));
    EF_CHECK(memcmp(c->data, t.view.data, 4u * t.view.nodes * t.view.ndof) == 0);
    EF_CHECK(c->provenance_len == t.view.provenance_len &&
             memcmp(c->provenance, t.view.provenance, c->provenance_len) == 0);
    EF_CHECK(c->provenance[c->provenance_len] == '\0');
    /* Identical tables give identical lookups, in and out of the domain. */
    if (c->kind == EF_TABLE_G1_CUBIC) {
        float a[2], b[2];
        EF_CHECK_EQ(ef_table_lookup_g1(c, 0.3f, -2.0f, a, NULL), EF_OK);
        EF_CHECK_EQ(ef_table_lookup_g1(&t.view, 0.3f, -2.0f, b, NULL), EF_OK);
        EF_CHECK(memcmp(a, b, sizeof a) == 0);
    } else {
        const float x[4] = {-0.7f, 0.2f, 1.5f, -3.0f};
        float a[4], b[4];
        EF_CHECK_EQ(ef_table_lookup_g2(c, x, a, NULL), EF_OK);
        EF_CHECK_EQ(ef_table_lookup_g2(&t.view, x, b, NULL), EF_OK);
        EF_CHECK(memcmp(a, b, sizeof a) == 0);
    }
    ef_tfile_free(&t);
}

static const char *emitted_g1_path, *emitted_g2_path;

static void test_emitted_g1(void)
{
    check_emitted(&ef_emitted_g1, emitted_g1_path);
}

static void test_emitted_g2(void)
{
    check_emitted(&ef_emitted_g2, emitted_g2_path);
}

/* The awkward values survive the C source. */
static void test_emitted_bits(void)
{
    EF_CHECK(same_bits(ef_emitted_g2.data[1], -0.0f));
    EF_CHECK(same_bits(ef_emitted_g2.data[3], 0x1p-149f));
    EF_CHECK(same_bits(ef_emitted_g2.data[5], -0x1.fffffcp-127f));
}

/* Compare both emitted tables with their files: test_tfile_emitted G1.eft G2.eft [PART...] */
int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"g1", test_emitted_g1},
        {"g2", test_emitted_g2},
        {"bits", test_emitted_bits},
    };
    if (argc < 3) {
        fprintf(stderr, "usage: %s G1.eft G2.eft [PART...]\n", argv[0]);
        return 2;
    }
    emitted_g1_path = argv[1];
    emitted_g2_path = argv[2];
    return EF_TEST_RUN(argc, argv, 3, parts);
}

#endif /* EF_TFILE_EMITTED */
