/*
 * Generates the table-parser seed corpus (tests/fuzz/corpus): small valid tables of every
 * kind and symmetry ("ok-*"), and near misses that each break one rule, with the CRC fixed
 * up where the rule is not the CRC itself, so the fuzzer starts next to every check
 * ("bad-*"). Output is deterministic: values are exact binary fractions.
 *
 * Usage: tfile_make_corpus DIR           (re)write the seed files into DIR
 *        tfile_make_corpus --check DIR   exit 1 if DIR lacks a seed or holds a stale one
 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../ef_le.h"
#include "evenfeed/host/tables/ef_tfile.h"

#define PI         3.14159265358979323846
#define PROVENANCE "evenfeed tests/fuzz/make_corpus.c: seed corpus v1" /* 49 B: padded */

enum { T_G1_NONE, T_G1_PERIODIC, T_G1_FOLD, T_G2_NONE, T_G2_MIRROR, T_G1_NOPROV, T_COUNT };

static const char *const base_names[T_COUNT] = {
    "ok-g1-none.eft", "ok-g1-periodic.eft", "ok-g1-fold.eft",
    "ok-g2-none.eft", "ok-g2-mirror.eft",   "ok-g1-no-provenance.eft",
};

/* Spec of a base table: a few nodes per axis keeps files small and fuzzing fast. */
static void base_spec(int which, ef_tfile_spec_t *s)
{
    memset(s, 0, sizeof *s);
    s->x1_min = 0.1;
    s->x1_max = 4.0;
    s->quad_nodes = 32;
    s->provenance = PROVENANCE;
    s->kind = which >= T_G2_NONE && which <= T_G2_MIRROR ? EF_TABLE_G2_QUINTIC : EF_TABLE_G1_CUBIC;
    switch (which) {
    case T_G1_NONE:
    case T_G1_NOPROV:
        s->lo[0] = s->lo[1] = -PI / 2;
        s->hi[0] = s->hi[1] = PI / 2;
        s->nodes[0] = 3;
        s->nodes[1] = 4;
        if (which == T_G1_NOPROV) {
            s->provenance = NULL;
        }
        break;
    case T_G1_PERIODIC:
        s->hi[0] = 2 * PI;
        s->lo[1] = -PI;
        s->hi[1] = PI;
        s->nodes[0] = 4;
        s->nodes[1] = 3;
        s->axis_flags[0] = s->axis_flags[1] = EF_AXIS_PERIODIC;
        break;
    case T_G1_FOLD:
        s->symmetry = EF_SYM_G1_FOLD;
        s->hi[0] = PI / 2;
        s->hi[1] = PI;
        s->nodes[0] = 3;
        s->nodes[1] = 5;
        break;
    default: /* G2 */
        s->symmetry = which == T_G2_MIRROR ? EF_SYM_G2_MIRROR : EF_SYM_NONE;
        s->lo[0] = which == T_G2_MIRROR ? 0.0 : -PI / 2;
        s->hi[0] = PI / 2;
        s->lo[1] = -PI / 2;
        s->hi[1] = PI / 2;
        s->lo[2] = s->lo[3] = -2.0;
        s->hi[2] = s->hi[3] = 2.0;
        s->nodes[0] = 2;
        s->nodes[1] = 3;
        s->nodes[2] = 2;
        s->nodes[3] = 2;
        s->x2_max = 8.0;
        s->quad_nodes = 48;
        break;
    }
}

/* Image of a base table with deterministic in-bound values. */
static uint8_t *base_image(int which, size_t *len)
{
    ef_tfile_spec_t s;
    ef_tfile_t t;
    ef_msg_t m;
    uint8_t *b = NULL;
    uint32_t k, n;

    base_spec(which, &s);
    if (ef_tfile_create(&t, &s, &m) != EF_OK) {
        fprintf(stderr, "make_corpus: %s\n", m.text);
        exit(EXIT_FAILURE);
    }
    n = t.view.nodes * t.view.ndof;
    for (k = 0; k < n; k++) {
        const int x2 = t.view.kind == EF_TABLE_G2_QUINTIC && (k & 1u);
        t.values[k] =
            x2 ? -2.0f + 0.25f * (float)((k * 3u) % 17u) : 0.5f + 0.125f * (float)((k * 5u) % 17u);
    }
    if (ef_tfile_serialize(&t, &b, len, &m) != EF_OK) {
        fprintf(stderr, "make_corpus: %s\n", m.text);
        exit(EXIT_FAILURE);
    }
    ef_tfile_free(&t);
    return b;
}

/* Near misses: one rule broken each, starting from a base table. */
enum {
    M_NONE,
    M_MAGIC,
    M_VERSION,
    M_KIND,
    M_AXES,
    M_SYMMETRY,
    M_QUAD,
    M_RESERVED,
    M_NODES,
    M_X1_BOUNDS,
    M_X2_BOUND,
    M_PROV_LEN,
    M_PERIOD,
    M_FOLD,
    M_MIRROR,
    M_UNUSED,
    M_AXIS_NODES,
    M_PROV_CHAR,
    M_PADDING,
    M_TRUNCATED,
    M_TRAILING,
    M_CRC,
    M_NAN,
    M_X1_RANGE,
    M_X2_RANGE
};

typedef struct {
    const char *name;
    int base;
    int mutation;
} seed_t;

static const seed_t seeds[] = {
    {"bad-magic.eft", T_G1_NONE, M_MAGIC},
    {"bad-version.eft", T_G1_NONE, M_VERSION},
    {"bad-kind.eft", T_G2_NONE, M_KIND},
    {"bad-axis-count.eft", T_G2_NONE, M_AXES},
    {"bad-symmetry-kind.eft", T_G2_NONE, M_SYMMETRY},
    {"bad-quad-nodes.eft", T_G1_FOLD, M_QUAD},
    {"bad-reserved.eft", T_G1_NONE, M_RESERVED},
    {"bad-node-count.eft", T_G2_MIRROR, M_NODES},
    {"bad-x1-bounds.eft", T_G1_PERIODIC, M_X1_BOUNDS},
    {"bad-x2-bound-g1.eft", T_G1_FOLD, M_X2_BOUND},
    {"bad-provenance-len.eft", T_G1_NONE, M_PROV_LEN},
    {"bad-periodic-span.eft", T_G1_PERIODIC, M_PERIOD},
    {"bad-fold-region.eft", T_G1_FOLD, M_FOLD},
    {"bad-mirror-lo.eft", T_G2_MIRROR, M_MIRROR},
    {"bad-unused-axis.eft", T_G1_NONE, M_UNUSED},
    {"bad-axis-nodes.eft", T_G2_NONE, M_AXIS_NODES},
    {"bad-provenance-char.eft", T_G2_NONE, M_PROV_CHAR},
    {"bad-padding.eft", T_G1_FOLD, M_PADDING},
    {"bad-truncated.eft", T_G2_MIRROR, M_TRUNCATED},
    {"bad-trailing.eft", T_G1_PERIODIC, M_TRAILING},
    {"bad-crc.eft", T_G2_NONE, M_CRC},
    {"bad-value-nan.eft", T_G1_FOLD, M_NAN},
    {"bad-value-x1.eft", T_G1_PERIODIC, M_X1_RANGE},
    {"bad-value-x2.eft", T_G2_MIRROR, M_X2_RANGE},
};

/* Apply a mutation; *len may change. The CRC is recomputed unless it is the target. */
static void mutate(uint8_t *b, size_t *len, int mutation)
{
    const uint32_t prov = b[56] | (uint32_t)b[57] << 8;
    const uint32_t data = 160u + ((prov + 7u) & ~7u);
    int fix = 1;

    switch (mutation) {
    case M_MAGIC:
        b[3] = 'X';
        break;
    case M_VERSION:
        put16(b + 8, 2);
        break;
    case M_KIND:
        put16(b + 12, 3);
        break;
    case M_AXES:
        b[16] = 2;
        break;
    case M_SYMMETRY:
        put16(b + 18, EF_SYM_G1_FOLD);
        break;
    case M_QUAD:
        put16(b + 24, 65);
        break;
    case M_RESERVED:
        put32(b + 60, 1);
        break;
    case M_NODES:
        put32(b + 28, 23);
        break;
    case M_X1_BOUNDS:
        putf64(b + 32, 0.0);
        break;
    case M_X2_BOUND:
        putf64(b + 48, 1.0);
        break;
    case M_PROV_LEN:
        put32(b + 56, EF_TABLE_MAX_PROVENANCE + 1);
        break;
    case M_PERIOD:
        putf64(b + 72, 6.28);
        break;
    case M_FOLD:
        putf64(b + 96, 3.0);
        break;
    case M_MIRROR:
        putf64(b + 64, -0.25);
        break;
    case M_UNUSED:
        b[64 + 2 * 24 + 16] = 1;
        break;
    case M_AXIS_NODES:
        put32(b + 64 + 24 + 16, 1);
        break;
    case M_PROV_CHAR:
        b[165] = '\n';
        break;
    case M_PADDING:
        b[data - 1] = 'x';
        break;
    case M_TRUNCATED:
        *len -= 4;
        fix = 0;
        break;
    case M_TRAILING:
        b[*len] = 0;
        *len += 1;
        fix = 0;
        break;
    case M_CRC:
        b[data + 5] ^= 0x10;
        fix = 0;
        break;
    case M_NAN:
        putf32(b + data + 4, NAN);
        break;
    case M_X1_RANGE:
        putf32(b + data + 8, 4.5f);
        break;
    case M_X2_RANGE:
        putf32(b + data + 4, -9.0f);
        break;
    default:
        break;
    }
    if (fix) {
        put32(b + *len - 4, ef_crc32(0, b, (uint32_t)(*len - 4)));
    }
}

/* Image of one seed (base table or near miss); one spare byte for M_TRAILING. */
static uint8_t *seed_image(int base, int mutation, size_t *len)
{
    uint8_t *img = base_image(base, len);
    uint8_t *b = malloc(*len + 1);
    if (b == NULL) {
        exit(EXIT_FAILURE);
    }
    memcpy(b, img, *len);
    free(img);
    mutate(b, len, mutation);
    return b;
}

/* Write, or compare against the existing file; returns 0 when fine. */
static int emit(const char *dir, const char *name, const uint8_t *b, size_t len, int check)
{
    char path[4096];
    FILE *f;
    int bad = 0;

    snprintf(path, sizeof path, "%s/%s", dir, name);
    if (check) {
        uint8_t *old = malloc(len + 1);
        f = fopen(path, "rb");
        if (old == NULL || f == NULL || fread(old, 1, len + 1, f) != len ||
            memcmp(old, b, len) != 0) {
            fprintf(stderr, "%s: missing or stale; regenerate with tfile_make_corpus %s\n", path,
                    dir);
            bad = 1;
        }
        if (f) {
            fclose(f);
        }
        free(old);
        return bad;
    }
    f = fopen(path, "wb");
    if (f == NULL || fwrite(b, 1, len, f) != len) {
        perror(path);
        bad = 1;
    }
    if (f && fclose(f) != 0) {
        perror(path);
        bad = 1;
    }
    return bad;
}

/* Write or check every seed: base tables first, then the near misses. */
int main(int argc, char **argv)
{
    const int check = argc == 3 && strcmp(argv[1], "--check") == 0;
    const char *dir = argv[argc - 1];
    size_t i, len;
    int bad = 0;

    if (!(argc == 2 && argv[1][0] != '-') && !check) {
        fprintf(stderr, "usage: %s [--check] DIR\n", argv[0]);
        return 2;
    }
    for (i = 0; i < T_COUNT; i++) {
        uint8_t *b = seed_image((int)i, M_NONE, &len);
        bad |= emit(dir, base_names[i], b, len, check);
        free(b);
    }
    for (i = 0; i < sizeof seeds / sizeof seeds[0]; i++) {
        uint8_t *b = seed_image(seeds[i].base, seeds[i].mutation, &len);
        bad |= emit(dir, seeds[i].name, b, len, check);
        free(b);
    }
    if (!bad) {
        printf("%s %zu seed files in %s\n", check ? "checked" : "wrote",
               (size_t)T_COUNT + sizeof seeds / sizeof seeds[0], dir);
    }
    return bad ? EXIT_FAILURE : EXIT_SUCCESS;
}
