/* SPDX-License-Identifier: Apache-2.0 */
/* Build-spec records, the header shared by build journals and shard files, shard files
 * themselves and their merge into one table (layouts: docs/table-build.md). */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/ef_file_int.h"
#include "tables/ef_shard_int.h"

const uint8_t ef_magic_journal[8] = {0x45, 0x46, 0x4A, 0x4E, 0x0D, 0x0A, 0x1A, 0x0A}; /* EFJN */
const uint8_t ef_magic_shard[8] = {0x45, 0x46, 0x53, 0x48, 0x0D, 0x0A, 0x1A, 0x0A};   /* EFSH */
static const uint8_t ef_magic_table[8] = {0x45, 0x46, 0x54, 0x42, 0x0D, 0x0A, 0x1A, 0x0A};

/* Largest shard file: header, every value of the largest table, CRC. */
#define EF_SHARD_MAX_FILE                                                                          \
    ((size_t)EF_EFILE_MAX_HEADER + 4u * (size_t)EF_TABLE_MAX_NODES * EF_TABLE_MAX_DOF + 4u)

/* Bitwise double equality: a spec is equal only if it encodes to the same bytes. */
static int shd_same_f64(double a, double b)
{
    return memcmp(&a, &b, sizeof a) == 0;
}

/* Printable ASCII only: names and provenance appear in messages and in table files. */
static int shd_printable(const char *s, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (s[i] < 0x20 || s[i] > 0x7e)
            return 0;
    return 1;
}

/* Spec record of a created table (the view holds the integers, the table the doubles). */
int ef_spec_from_table(const ef_tfile_t *t, const char *backend, ef_spec_rec_t *s, ef_msg_t *m)
{
    size_t blen = backend ? strlen(backend) : 0;
    if (!t || !s || blen == 0 || blen > EF_SPEC_MAX_BACKEND || !shd_printable(backend, blen))
        return ef_fail(m, EF_ERR_ARG,
                       "build: backend name '%s' is empty, longer than %u or "
                       "not printable",
                       backend ? backend : "(null)", EF_SPEC_MAX_BACKEND);
    memset(s, 0, sizeof *s);
    s->kind = t->view.kind;
    s->symmetry = t->view.symmetry;
    s->quad_nodes = t->view.quad_nodes;
    s->naxes = t->view.naxes;
    s->ndof = t->view.ndof;
    s->nodes = t->view.nodes;
    s->rows = t->view.axis[0].nodes ? t->view.nodes / t->view.axis[0].nodes : 0;
    s->x1_min = t->x1_min;
    s->x1_max = t->x1_max;
    s->x2_max = t->x2_max;
    for (int a = 0; a < EF_TABLE_MAX_AXES; a++) {
        s->lo[a] = t->lo[a];
        s->hi[a] = t->hi[a];
        s->axis_nodes[a] = t->view.axis[a].nodes;
        s->axis_flags[a] = t->view.axis[a].flags;
    }
    memcpy(s->backend, backend, blen);
    s->prov_len = (uint32_t)strnlen(t->provenance, EF_TABLE_MAX_PROVENANCE);
    memcpy(s->prov, t->provenance, s->prov_len);
    return EF_OK;
}

/* Append a formatted piece to a bounded buffer; output past the end is dropped. */
static void shd_cat(char *out, size_t size, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static void shd_cat(char *out, size_t size, const char *fmt, ...)
{
    size_t n = strlen(out);
    if (n + 1 >= size)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(out + n, size - n, fmt, ap);
    va_end(ap);
}

/* Field-by-field comparison so a refusal can say exactly what differs. */
int ef_spec_diff(const ef_spec_rec_t *a, const ef_spec_rec_t *b, char *out, size_t size)
{
    int n = 0;
    out[0] = '\0';
#define EF_DIFF_U(field, label)                                                                    \
    if (a->field != b->field) {                                                                    \
        shd_cat(out, size, "%s%s %lu vs %lu", n++ ? "; " : "", label, (unsigned long)a->field,     \
                (unsigned long)b->field);                                                          \
    }
#define EF_DIFF_D(field, label)                                                                    \
    if (!shd_same_f64(a->field, b->field)) {                                                       \
        shd_cat(out, size, "%s%s %.17g vs %.17g", n++ ? "; " : "", label, a->field, b->field);     \
    }
    EF_DIFF_U(kind, "kind")
    EF_DIFF_U(symmetry, "symmetry")
    EF_DIFF_U(naxes, "axis count")
    EF_DIFF_U(ndof, "DOF count")
    EF_DIFF_U(quad_nodes, "quadrature nodes")
    EF_DIFF_U(nodes, "node count")
    for (int i = 0; i < EF_TABLE_MAX_AXES; i++) {
        char label[32];
        snprintf(label, sizeof label, "axis[%d].nodes", i);
        EF_DIFF_U(axis_nodes[i], label)
        snprintf(label, sizeof label, "axis[%d].lo", i);
        EF_DIFF_D(lo[i], label)
        snprintf(label, sizeof label, "axis[%d].hi", i);
        EF_DIFF_D(hi[i], label)
        snprintf(label, sizeof label, "axis[%d].flags", i);
        EF_DIFF_U(axis_flags[i], label)
    }
    EF_DIFF_D(x1_min, "x1_min")
    EF_DIFF_D(x1_max, "x1_max")
    EF_DIFF_D(x2_max, "x2_max")
#undef EF_DIFF_U
#undef EF_DIFF_D
    if (strcmp(a->backend, b->backend))
        shd_cat(out, size, "%sbackend '%s' vs '%s'", n++ ? "; " : "", a->backend, b->backend);
    if (a->prov_len != b->prov_len || memcmp(a->prov, b->prov, a->prov_len)) {
        /* Provenance strings are long: show where they part. */
        uint32_t k = 0;
        while (k < a->prov_len && k < b->prov_len && a->prov[k] == b->prov[k])
            k++;
        uint32_t from = k > 20 ? k - 20 : 0;
        shd_cat(out, size, "%sprovenance differs at character %u ('...%.40s' vs '...%.40s')",
                n++ ? "; " : "", k, a->prov + from, b->prov + from);
    }
    return n;
}

/* ef_tfile_create() input of a record. */
void ef_spec_to_tfile(const ef_spec_rec_t *s, ef_tfile_spec_t *ts)
{
    memset(ts, 0, sizeof *ts);
    ts->kind = s->kind;
    ts->symmetry = s->symmetry;
    for (int a = 0; a < EF_TABLE_MAX_AXES; a++) {
        ts->lo[a] = s->lo[a];
        ts->hi[a] = s->hi[a];
        ts->nodes[a] = s->axis_nodes[a];
        ts->axis_flags[a] = s->axis_flags[a];
    }
    ts->x1_min = s->x1_min;
    ts->x1_max = s->x1_max;
    ts->x2_max = s->x2_max;
    ts->quad_nodes = s->quad_nodes;
    ts->provenance = s->prov;
}

/* Spec record bytes; returns the length (EF_SPEC_FIXED + backend + provenance). */
static size_t shd_spec_encode(const ef_spec_rec_t *s, uint8_t *p)
{
    const size_t blen = strlen(s->backend);
    memset(p, 0, EF_SPEC_FIXED);
    ef_le_put16(p + 0, s->kind);
    ef_le_put16(p + 2, s->symmetry);
    p[4] = s->naxes;
    p[5] = s->ndof;
    ef_le_put16(p + 6, s->quad_nodes);
    ef_le_put32(p + 8, s->nodes);
    ef_le_put32(p + 12, s->rows);
    ef_le_putf64(p + 16, s->x1_min);
    ef_le_putf64(p + 24, s->x1_max);
    ef_le_putf64(p + 32, s->x2_max);
    for (int a = 0; a < EF_TABLE_MAX_AXES; a++) {
        uint8_t *q = p + 40 + 24 * a;
        ef_le_putf64(q, s->lo[a]);
        ef_le_putf64(q + 8, s->hi[a]);
        ef_le_put32(q + 16, s->axis_nodes[a]);
        ef_le_put32(q + 20, s->axis_flags[a]);
    }
    p[136] = (uint8_t)blen;
    ef_le_put16(p + 138, s->prov_len);
    memcpy(p + EF_SPEC_FIXED, s->backend, blen);
    memcpy(p + EF_SPEC_FIXED + blen, s->prov, s->prov_len);
    return EF_SPEC_FIXED + blen + s->prov_len;
}

/* Decode a spec record of exactly len bytes; 0 if it is self-consistent, -1 if not. Full
 * validity as a table is ef_tfile_create()'s business; this only keeps the numbers sane
 * enough to size buffers and index rows. */
static int shd_spec_decode(const uint8_t *p, size_t len, ef_spec_rec_t *s)
{
    memset(s, 0, sizeof *s);
    if (len < EF_SPEC_FIXED)
        return -1;
    const uint32_t blen = p[136], plen = ef_le_get16(p + 138);
    if (p[137] != 0 || blen == 0 || blen > EF_SPEC_MAX_BACKEND || plen > EF_TABLE_MAX_PROVENANCE ||
        len != EF_SPEC_FIXED + blen + plen)
        return -1;
    s->kind = (uint16_t)ef_le_get16(p);
    s->symmetry = (uint16_t)ef_le_get16(p + 2);
    s->naxes = p[4];
    s->ndof = p[5];
    s->quad_nodes = (uint16_t)ef_le_get16(p + 6);
    s->nodes = ef_le_get32(p + 8);
    s->rows = ef_le_get32(p + 12);
    s->x1_min = ef_le_getf64(p + 16);
    s->x1_max = ef_le_getf64(p + 24);
    s->x2_max = ef_le_getf64(p + 32);
    uint64_t product = 1;
    for (int a = 0; a < EF_TABLE_MAX_AXES; a++) {
        const uint8_t *q = p + 40 + 24 * a;
        s->lo[a] = ef_le_getf64(q);
        s->hi[a] = ef_le_getf64(q + 8);
        s->axis_nodes[a] = ef_le_get32(q + 16);
        s->axis_flags[a] = ef_le_get32(q + 20);
        if (a < s->naxes && s->axis_nodes[a] <= EF_TABLE_MAX_AXIS_NODES)
            product *= s->axis_nodes[a];
    }
    memcpy(s->backend, p + EF_SPEC_FIXED, blen);
    memcpy(s->prov, p + EF_SPEC_FIXED + blen, plen);
    s->prov_len = plen;
    if ((s->naxes != 2 && s->naxes != 4) || s->ndof != s->naxes || s->axis_nodes[0] < 2 ||
        s->nodes == 0 || s->nodes > EF_TABLE_MAX_NODES || product != s->nodes ||
        s->rows != s->nodes / s->axis_nodes[0] || !shd_printable(s->backend, blen) ||
        !shd_printable(s->prov, plen))
        return -1;
    return 0;
}

/* Rows of shard index/count over rows (count 0: all); caller has checked the ranges. */
static void shd_range(uint32_t rows, uint32_t index, uint32_t count, uint32_t *b, uint32_t *e)
{
    if (count == 0) {
        *b = 0;
        *e = rows;
        return;
    }
    *b = (uint32_t)((uint64_t)(index - 1) * rows / count);
    *e = (uint32_t)((uint64_t)index * rows / count);
}

/* Strict "I/N": digits only, so "2/4x", "+1/2" and " 1/2" are refused, not half-read. */
int ef_build_shard_parse(const char *s, ef_build_shard_t *out, ef_msg_t *m)
{
    uint64_t v[2] = {0, 0};
    const char *p = s;
    if (!s || !out)
        return ef_fail(m, EF_ERR_ARG, "--shard: missing value");
    for (int k = 0; k < 2; k++) {
        const char *start = p;
        while (*p >= '0' && *p <= '9') {
            v[k] = v[k] * 10 + (uint64_t)(*p - '0');
            if (v[k] > 0xFFFFFFFFu)
                return ef_fail(m, EF_ERR_ARG, "--shard: '%s': number too large", s);
            p++;
        }
        if (p == start || (k == 0 ? *p != '/' : *p != '\0'))
            return ef_fail(m, EF_ERR_ARG,
                           "--shard: '%s' is not I/N (shard I of N, 1 <= I <= N, e.g. 2/4)", s);
        p++;
    }
    if (v[1] == 0)
        return ef_fail(m, EF_ERR_ARG, "--shard: '%s': N must be at least 1", s);
    if (v[0] < 1 || v[0] > v[1])
        return ef_fail(m, EF_ERR_ARG,
                       "--shard: '%s': I must be 1..%" PRIu64 " (shards count from 1)", s, v[1]);
    out->index = (uint32_t)v[0];
    out->count = (uint32_t)v[1];
    return EF_OK;
}

/* A shard's contiguous block of rows; refuses splits that would leave a shard empty. */
int ef_build_shard_rows(const ef_tfile_t *t, const ef_build_shard_t *s, uint32_t *row_begin,
                        uint32_t *row_end, ef_msg_t *m)
{
    if (!t || !row_begin || !row_end || t->view.axis[0].nodes == 0)
        return ef_fail(m, EF_ERR_ARG, "build: bad table");
    const uint32_t rows = t->view.nodes / t->view.axis[0].nodes;
    if (s && s->count != 0) {
        if (s->index < 1 || s->index > s->count)
            return ef_fail(m, EF_ERR_ARG, "--shard %u/%u: I must be 1..%u", s->index, s->count,
                           s->count);
        if (s->count > rows)
            return ef_fail(m, EF_ERR_ARG,
                           "--shard %u/%u: the table has only %u rows (a row is the %u nodes "
                           "along axis 0), so it splits into at most %u shards",
                           s->index, s->count, rows, t->view.axis[0].nodes, rows);
        shd_range(rows, s->index, s->count, row_begin, row_end);
    } else {
        shd_range(rows, 0, 0, row_begin, row_end);
    }
    return EF_OK;
}

/* Prefix, spec record and the CRC over both. */
size_t ef_efile_put_header(uint8_t *buf, const uint8_t magic[8], const ef_efile_hdr_t *h)
{
    memset(buf, 0, EF_EFILE_PREFIX);
    memcpy(buf, magic, 8);
    ef_le_put16(buf + 8, EF_EFILE_VERSION);
    const size_t slen = shd_spec_encode(&h->spec, buf + EF_EFILE_PREFIX);
    ef_le_put32(buf + 12, (uint32_t)slen);
    ef_le_put32(buf + 16, h->index);
    ef_le_put32(buf + 20, h->count);
    ef_le_put32(buf + 24, h->row_begin);
    ef_le_put32(buf + 28, h->row_end);
    const size_t n = EF_EFILE_PREFIX + slen;
    ef_le_put32(buf + n, ef_crc32(0, buf, (uint32_t)n));
    return n + 4;
}

/* What a file is, by its magic, for messages that refuse it. */
static const char *shd_efile_kind(const uint8_t *buf, size_t len)
{
    if (len < 8)
        return NULL;
    if (!memcmp(buf, ef_magic_table, 8))
        return "a table file (.eft)";
    if (!memcmp(buf, ef_magic_journal, 8))
        return "a build journal (.partial) of an unfinished build";
    if (!memcmp(buf, ef_magic_shard, 8))
        return "a shard file (.efs)";
    return NULL;
}

/* Header checks in file order, each failure naming the file, the field and its offset. */
int ef_efile_get_header(const char *path, const uint8_t *buf, size_t len, const uint8_t magic[8],
                        const char *what, ef_efile_hdr_t *h, ef_msg_t *m)
{
    memset(h, 0, sizeof *h);
    if (len < 8 || memcmp(buf, magic, 8)) {
        const char *is = shd_efile_kind(buf, len);
        if (len < 8 && !is)
            return ef_fail(m, EF_ERR_TBL_TRUNCATED, "%s: not a %s (%zu bytes, too short)", path,
                           what, len);
        return ef_fail(m, EF_ERR_TBL_MAGIC, "%s: not a %s (field 'magic', offset 0)%s%s", path,
                       what, is ? ": it is " : "", is ? is : "");
    }
    if (len < EF_EFILE_PREFIX)
        return ef_fail(m, EF_ERR_TBL_TRUNCATED, "%s: %s truncated (%zu bytes)", path, what, len);
    const uint32_t version = ef_le_get16(buf + 8), slen = ef_le_get32(buf + 12);
    if (version != EF_EFILE_VERSION)
        return ef_fail(m, EF_ERR_TBL_VERSION,
                       "%s: %s field 'version' (offset 8): %u, this evenfeed reads %u", path, what,
                       version, EF_EFILE_VERSION);
    if (ef_le_get16(buf + 10) != 0 || slen < EF_SPEC_FIXED || slen > EF_SPEC_MAX)
        return ef_fail(m, EF_ERR_TBL_HEADER, "%s: %s field '%s' (offset %d) invalid", path, what,
                       ef_le_get16(buf + 10) ? "reserved" : "spec_len",
                       ef_le_get16(buf + 10) ? 10 : 12);
    const size_t hlen = EF_EFILE_PREFIX + slen + 4u;
    if (len < hlen)
        return ef_fail(m, EF_ERR_TBL_TRUNCATED, "%s: %s truncated in its header (%zu of %zu bytes)",
                       path, what, len, hlen);
    const uint32_t stored = ef_le_get32(buf + hlen - 4),
                   crc = ef_crc32(0, buf, (uint32_t)(hlen - 4));
    if (stored != crc)
        return ef_fail(m, EF_ERR_TBL_CRC,
                       "%s: %s corrupt: header CRC (offset %zu) stored %08" PRIx32
                       ", computed %08" PRIx32,
                       path, what, hlen - 4, stored, crc);
    if (shd_spec_decode(buf + EF_EFILE_PREFIX, slen, &h->spec) != 0)
        return ef_fail(m, EF_ERR_TBL_HEADER, "%s: %s has an inconsistent table spec (offset %u)",
                       path, what, EF_EFILE_PREFIX);
    h->index = ef_le_get32(buf + 16);
    h->count = ef_le_get32(buf + 20);
    h->row_begin = ef_le_get32(buf + 24);
    h->row_end = ef_le_get32(buf + 28);
    h->header_len = hlen;
    uint32_t b = 0, e = 0;
    const int shard_ok = h->count == 0
                             ? h->index == 0
                             : h->index >= 1 && h->index <= h->count && h->count <= h->spec.rows;
    if (shard_ok)
        shd_range(h->spec.rows, h->index, h->count, &b, &e);
    if (!shard_ok || b != h->row_begin || e != h->row_end)
        return ef_fail(m, EF_ERR_TBL_HEADER,
                       "%s: %s fields 'shard' / 'rows' (offset 16) inconsistent: shard %u/%u, "
                       "rows %u..%u of %u",
                       path, what, h->index, h->count, h->row_begin, h->row_end, h->spec.rows);
    return EF_OK;
}

/* The parser's value rule (finite; x1 in [x1_min, x1_max]; |x2| <= x2_max; slack 1e-6),
 * with half the slack so whatever passes here also passes the parser. */
size_t ef_values_check(const ef_spec_rec_t *s, const uint8_t *raw, const float *vals, size_t n)
{
    const double lo1 = s->x1_min * (1 - 0.5e-6), hi1 = s->x1_max * (1 + 0.5e-6),
                 hi2 = s->x2_max * (1 + 0.5e-6);
    const int g2 = s->kind == EF_TABLE_G2_QUINTIC, ndof = s->ndof ? s->ndof : 1;
    for (size_t i = 0; i < n; i++) {
        float f;
        if (raw) {
            uint32_t u = ef_le_get32(raw + 4 * i);
            memcpy(&f, &u, sizeof f);
        } else {
            f = vals[i];
        }
        const double v = (double)f;
        const int k = (int)(i % (size_t)ndof), is_x2 = g2 && (k == 1 || k == 3);
        if (!isfinite(v) || (is_x2 ? fabs(v) > hi2 : (v < lo1 || v > hi1)))
            return i;
    }
    return n;
}

/* Header, the shard's values little-endian, CRC of everything before it. */
int ef_shard_write(const ef_tfile_t *t, const char *backend, const ef_build_shard_t *s,
                   const char *path, ef_msg_t *m)
{
    if (!t || !t->values || !s || !path)
        return ef_fail(m, EF_ERR_ARG, "ef_shard_write: NULL argument");
    if (s->count == 0)
        return ef_fail(m, EF_ERR_ARG, "ef_shard_write: shard count 0 (a whole table is a .eft)");
    ef_efile_hdr_t h;
    memset(&h, 0, sizeof h);
    int rc = ef_build_shard_rows(t, s, &h.row_begin, &h.row_end, m);
    if (rc == EF_OK)
        rc = ef_spec_from_table(t, backend, &h.spec, m);
    if (rc != EF_OK)
        return rc;
    h.index = s->index;
    h.count = s->count;
    const uint32_t per_row = t->view.axis[0].nodes * t->view.ndof;
    const size_t nval = (size_t)(h.row_end - h.row_begin) * per_row;
    const float *v = t->values + (size_t)h.row_begin * per_row;
    size_t bad = ef_values_check(&h.spec, NULL, v, nval);
    if (bad < nval)
        return ef_fail(m, EF_ERR_TBL_VALUE,
                       "%s: value of node %zu, DOF %zu is non-finite or out of bounds (%.9g)", path,
                       (size_t)h.row_begin * t->view.axis[0].nodes + bad / t->view.ndof,
                       bad % t->view.ndof, (double)v[bad]);
    uint8_t *buf = malloc(EF_EFILE_MAX_HEADER + 4 * nval + 4);
    if (!buf)
        return ef_fail(m, EF_ERR_NOMEM, "%s: out of memory", path);
    size_t n = ef_efile_put_header(buf, ef_magic_shard, &h);
    for (size_t i = 0; i < nval; i++, n += 4) {
        uint32_t u;
        memcpy(&u, &v[i], sizeof u);
        ef_le_put32(buf + n, u);
    }
    ef_le_put32(buf + n, ef_crc32(0, buf, (uint32_t)n));
    rc = ef_file_write_atomic(path, buf, n + 4, m);
    free(buf);
    return rc;
}

/* Read and fully check one shard file; *values points into *buf (little-endian floats). */
static int shd_load(const char *path, uint8_t **buf, ef_efile_hdr_t *h, const uint8_t **values,
                    size_t *nval, ef_msg_t *m)
{
    size_t len;
    int rc = ef_file_read(path, EF_SHARD_MAX_FILE, buf, &len, m);
    if (rc != EF_OK)
        return rc;
    rc = ef_efile_get_header(path, *buf, len, ef_magic_shard, "shard file", h, m);
    if (rc == EF_OK && h->count == 0)
        rc = ef_fail(m, EF_ERR_TBL_HEADER, "%s: shard file with shard count 0 (offset 20)", path);
    if (rc != EF_OK)
        return rc;
    *nval = (size_t)(h->row_end - h->row_begin) * h->spec.axis_nodes[0] * h->spec.ndof;
    const size_t want = h->header_len + 4 * *nval + 4;
    if (len < want)
        return ef_fail(m, EF_ERR_TBL_TRUNCATED, "%s: shard file truncated: %zu of %zu bytes", path,
                       len, want);
    if (len > want)
        return ef_fail(m, EF_ERR_TBL_SIZE, "%s: shard file has %zu trailing bytes after its CRC",
                       path, len - want);
    const uint32_t stored = ef_le_get32(*buf + want - 4),
                   crc = ef_crc32(0, *buf, (uint32_t)(want - 4));
    if (stored != crc)
        return ef_fail(m, EF_ERR_TBL_CRC,
                       "%s: shard file corrupt: CRC (offset %zu) stored %08" PRIx32
                       ", computed %08" PRIx32,
                       path, want - 4, stored, crc);
    *values = *buf + h->header_len;
    size_t bad = ef_values_check(&h->spec, *values, NULL, *nval);
    if (bad < *nval)
        return ef_fail(m, EF_ERR_TBL_VALUE,
                       "%s: value at offset %zu is non-finite or out of the table's bounds", path,
                       h->header_len + 4 * bad);
    return EF_OK;
}

/* Load each shard in turn, checking it against the first, copy its rows, then make sure
 * nothing is missing; memory stays at one table plus one shard. */
int ef_shard_merge(const char *const *paths, uint32_t npaths, ef_tfile_t *out, ef_msg_t *m)
{
    if (out)
        memset(out, 0, sizeof *out);
    if (!paths || !out || npaths == 0)
        return ef_fail(m, EF_ERR_ARG, "no shard files given");
    ef_efile_hdr_t *first = malloc(sizeof *first), *h = malloc(sizeof *h);
    uint32_t *seen = NULL; /* per shard: 1 + the index of the path that supplied it, or 0 */
    uint8_t *buf = NULL;
    char *diff = malloc(400);
    int rc = EF_OK;
    if (!first || !h || !diff) {
        rc = ef_fail(m, EF_ERR_NOMEM, "merge: out of memory");
        goto done;
    }
    for (uint32_t k = 0; k < npaths && rc == EF_OK; k++) {
        const uint8_t *vals = NULL; /* set by a successful load; gcc cannot tell */
        size_t nval = 0;
        free(buf);
        buf = NULL;
        rc = shd_load(paths[k], &buf, h, &vals, &nval, m);
        if (rc != EF_OK)
            break;
        if (k == 0) {
            *first = *h;
            ef_tfile_spec_t ts;
            ef_spec_to_tfile(&first->spec, &ts);
            ef_msg_t sub = {{0}};
            rc = ef_tfile_create(out, &ts, &sub);
            if (rc != EF_OK) {
                rc = ef_fail(m, rc, "%s: its table spec is not a valid table: %s", paths[k],
                             sub.text);
                break;
            }
            seen = calloc(first->count, sizeof *seen);
            if (!seen) {
                rc = ef_fail(m, EF_ERR_NOMEM, "merge: out of memory");
                break;
            }
        } else {
            if (ef_spec_diff(&first->spec, &h->spec, diff, 400)) {
                rc = ef_fail(m, EF_ERR_ARG, "%s: not from the same build as %s: %s", paths[k],
                             paths[0], diff);
                break;
            }
            if (h->count != first->count) {
                rc = ef_fail(m, EF_ERR_ARG,
                             "%s is shard %u/%u but %s is %u/%u: all shards of a table must come "
                             "from builds with the same --shard .../N",
                             paths[k], h->index, h->count, paths[0], first->index, first->count);
                break;
            }
        }
        if (seen[h->index - 1]) {
            rc = ef_fail(m, EF_ERR_ARG, "%s and %s are both shard %u/%u (rows %u..%u): overlap",
                         paths[seen[h->index - 1] - 1], paths[k], h->index, h->count, h->row_begin,
                         h->row_end - 1);
            break;
        }
        seen[h->index - 1] = k + 1;
        float *dst = out->values + (size_t)h->row_begin * h->spec.axis_nodes[0] * h->spec.ndof;
        for (size_t i = 0; i < nval; i++) {
            uint32_t u = ef_le_get32(vals + 4 * i);
            memcpy(&dst[i], &u, sizeof u);
        }
    }
    if (rc == EF_OK) {
        char list[300] = "";
        uint32_t missing = 0;
        for (uint32_t i = 0; i < first->count; i++) {
            if (seen[i])
                continue;
            uint32_t b, e;
            shd_range(first->spec.rows, i + 1, first->count, &b, &e);
            if (missing++ < 8)
                shd_cat(list, sizeof list, "%s%u/%u (rows %u..%u)", missing > 1 ? ", " : "", i + 1,
                        first->count, b, e - 1);
        }
        if (missing)
            rc = ef_fail(m, EF_ERR_ARG, "%u of %u shards missing: %s%s", missing, first->count,
                         list, missing > 8 ? ", ..." : "");
    }
done:
    if (rc != EF_OK)
        ef_tfile_free(out);
    free(buf);
    free(seen);
    free(first);
    free(h);
    free(diff);
    return rc;
}
