/* SPDX-License-Identifier: Apache-2.0 */
/* Table files on the host: build file images, validate them with the firmware parser,
 * write atomically, load and describe failures. */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L /* mkstemp-era POSIX: fsync, strnlen, strndup */
#endif

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

#include "evenfeed/host/tables/ef_tfile.h"
#include "core/ef_file_int.h"
#include "core/ef_le_int.h"

#define EF_TF_PAD8(n) (((n) + 7u) & ~(uint64_t)7u)
/* Largest file any valid table can be: reading stops before allocating more than this. */
#define EF_TF_MAX_FILE                                                                             \
    ((uint64_t)EF_TABLE_HEADER_SIZE + EF_TF_PAD8((uint64_t)EF_TABLE_MAX_PROVENANCE) +              \
     4u * (uint64_t)EF_TABLE_MAX_NODES * EF_TABLE_MAX_DOF + 4u)

/* One header field: where it is, how wide, how to print it. */
typedef struct {
    uint32_t off;
    uint32_t size;
    const char *name;
    char type; /* 'b' bytes, 'u' unsigned integer, 'd' f64 */
} ef_tf_field_t;

static const ef_tf_field_t ef_tf_fields[] = {
    {0, 8, "magic", 'b'},           {8, 2, "version", 'u'},         {10, 2, "header_size", 'u'},
    {12, 2, "kind", 'u'},           {14, 2, "value_type", 'u'},     {16, 1, "axis_count", 'u'},
    {17, 1, "dof_count", 'u'},      {18, 2, "symmetry", 'u'},       {20, 2, "functional", 'u'},
    {22, 2, "quadrature", 'u'},     {24, 2, "quad_nodes", 'u'},     {26, 2, "reserved0", 'u'},
    {28, 4, "node_count", 'u'},     {32, 8, "x1_min", 'd'},         {40, 8, "x1_max", 'd'},
    {48, 8, "x2_max", 'd'},         {56, 4, "provenance_len", 'u'}, {60, 4, "reserved1", 'u'},
    {64, 8, "axis[0].lo", 'd'},     {72, 8, "axis[0].hi", 'd'},     {80, 4, "axis[0].nodes", 'u'},
    {84, 4, "axis[0].flags", 'u'},  {88, 8, "axis[1].lo", 'd'},     {96, 8, "axis[1].hi", 'd'},
    {104, 4, "axis[1].nodes", 'u'}, {108, 4, "axis[1].flags", 'u'}, {112, 8, "axis[2].lo", 'd'},
    {120, 8, "axis[2].hi", 'd'},    {128, 4, "axis[2].nodes", 'u'}, {132, 4, "axis[2].flags", 'u'},
    {136, 8, "axis[3].lo", 'd'},    {144, 8, "axis[3].hi", 'd'},    {152, 4, "axis[3].nodes", 'u'},
    {156, 4, "axis[3].flags", 'u'},
};
#define EF_TF_NFIELDS (sizeof ef_tf_fields / sizeof ef_tf_fields[0])

/* The header values a file image is built from, independent of where they came from
 * (a spec being validated or a table being written). */
typedef struct {
    uint16_t kind, symmetry, quad_nodes;
    uint8_t naxes, ndof;
    uint32_t nodes;  /* node-count field */
    uint32_t values; /* floats that follow the provenance (nodes x ndof of the table) */
    double lo[EF_TABLE_MAX_AXES], hi[EF_TABLE_MAX_AXES];
    uint32_t axis_nodes[EF_TABLE_MAX_AXES], axis_flags[EF_TABLE_MAX_AXES];
    double x1_min, x1_max, x2_max;
    const char *prov;
    uint32_t prov_len;
} ef_tf_hdr_t;

/* Field lookup by any byte inside it, so corrupted multi-byte fields are named too. */
static const ef_tf_field_t *tf_field_at(uint32_t offset)
{
    size_t i;
    for (i = 0; i < EF_TF_NFIELDS; i++) {
        if (offset >= ef_tf_fields[i].off && offset < ef_tf_fields[i].off + ef_tf_fields[i].size) {
            return &ef_tf_fields[i];
        }
    }
    return NULL;
}

/* Public name lookup; past the header the layout depends on the file, hence "body". */
const char *ef_tfile_field_name(uint32_t offset)
{
    const ef_tf_field_t *f = tf_field_at(offset);
    return f ? f->name : "body";
}

/* Turn a parser failure into one line naming the field, its offset and the bad value,
 * reading only bytes that exist. */
static int tf_report(ef_msg_t *m, int code, const char *who, const uint8_t *b, size_t len,
                     uint32_t off)
{
    const char *what = ef_err_str(code);
    const ef_tf_field_t *f;
    uint32_t prov_len, data_off, k, ndof;

    if (code == EF_ERR_TBL_TRUNCATED) {
        return ef_fail(m, code, "%s: %s: %zu bytes, shorter than its header requires", who, what,
                       len);
    }
    if (code == EF_ERR_TBL_SIZE && off >= EF_TABLE_HEADER_SIZE) {
        return ef_fail(m, code, "%s: %s: %zu bytes, header implies %" PRIu32, who, what, len, off);
    }
    f = tf_field_at(off);
    if (f != NULL && len >= (size_t)f->off + f->size) {
        const uint8_t *p = b + f->off;
        if (f->type == 'd') {
            return ef_fail(m, code, "%s: field '%s' (offset %" PRIu32 "): %s (%.17g)", who, f->name,
                           f->off, what, ef_le_getf64(p));
        }
        if (f->type == 'u') {
            uint32_t v = f->size == 1   ? p[0]
                         : f->size == 2 ? (uint32_t)p[0] | ((uint32_t)p[1] << 8)
                                        : ef_le_get32(p);
            return ef_fail(m, code, "%s: field '%s' (offset %" PRIu32 "): %s (%" PRIu32 ")", who,
                           f->name, f->off, what, v);
        }
        return ef_fail(m, code,
                       "%s: field '%s' (offset %" PRIu32 "): %s (%02x %02x %02x %02x %02x %02x "
                       "%02x %02x)",
                       who, f->name, f->off, what, p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]);
    }
    if (len < EF_TABLE_HEADER_SIZE || off >= len) {
        return ef_fail(m, code, "%s: offset %" PRIu32 ": %s", who, off, what);
    }
    /* Past the header: name the part of the body, which the parser has sized already. */
    prov_len = ef_le_get32(b + 56);
    data_off = EF_TABLE_HEADER_SIZE + (uint32_t)EF_TF_PAD8(prov_len);
    ndof = b[17] ? b[17] : 1u;
    if (code == EF_ERR_TBL_CRC) {
        return ef_fail(m, code,
                       "%s: field 'crc' (offset %" PRIu32 "): %s (stored %08" PRIx32
                       ", computed %08" PRIx32 ")",
                       who, off, what, ef_le_get32(b + off), ef_crc32(0, b, off));
    }
    if (off < EF_TABLE_HEADER_SIZE + prov_len) {
        return ef_fail(m, code,
                       "%s: field 'provenance[%" PRIu32 "]' (offset %" PRIu32 "): %s (byte 0x%02x)",
                       who, off - EF_TABLE_HEADER_SIZE, off, what, b[off]);
    }
    if (off < data_off) {
        return ef_fail(m, code,
                       "%s: field 'provenance padding' (offset %" PRIu32 "): %s (byte 0x%02x)", who,
                       off, what, b[off]);
    }
    k = (off - data_off) / 4u;
    if (off + 4u <= len) {
        float v;
        memcpy(&v, b + off, sizeof v);
        return ef_fail(m, code,
                       "%s: field 'values[node %" PRIu32 ", dof %" PRIu32 "]' (offset %" PRIu32
                       "): %s (%.9g)",
                       who, k / ndof, k % ndof, off, what, (double)v);
    }
    return ef_fail(m, code, "%s: offset %" PRIu32 ": %s", who, off, what);
}

/* Write the 160-byte header; unused axes come out zero because hdr holds zeros there. */
static void tf_put_header(uint8_t *p, const ef_tf_hdr_t *h)
{
    static const uint8_t magic[EF_TABLE_MAGIC_LEN] = {0x45, 0x46, 0x54, 0x42,
                                                      0x0D, 0x0A, 0x1A, 0x0A};
    unsigned i;

    memset(p, 0, EF_TABLE_HEADER_SIZE);
    memcpy(p, magic, sizeof magic);
    ef_le_put16(p + 8, EF_TABLE_VERSION);
    ef_le_put16(p + 10, EF_TABLE_HEADER_SIZE);
    ef_le_put16(p + 12, h->kind);
    ef_le_put16(p + 14, EF_TABLE_F32);
    p[16] = h->naxes;
    p[17] = h->ndof;
    ef_le_put16(p + 18, h->symmetry);
    ef_le_put16(p + 20, EF_FUNCTIONAL_CONSTANT_SPEED);
    ef_le_put16(p + 22, EF_QUAD_GAUSS_LEGENDRE);
    ef_le_put16(p + 24, h->quad_nodes);
    ef_le_put32(p + 28, h->nodes);
    ef_le_putf64(p + 32, h->x1_min);
    ef_le_putf64(p + 40, h->x1_max);
    ef_le_putf64(p + 48, h->x2_max);
    ef_le_put32(p + 56, h->prov_len);
    for (i = 0; i < EF_TABLE_MAX_AXES; i++) {
        uint8_t *a = p + 64 + 24 * i;
        ef_le_putf64(a, h->lo[i]);
        ef_le_putf64(a + 8, h->hi[i]);
        ef_le_put32(a + 16, h->axis_nodes[i]);
        ef_le_put32(a + 20, h->axis_flags[i]);
    }
}

/* Build a complete file image. values NULL fills a valid placeholder (x1 = x1_min, x2 = 0)
 * so a spec can be validated end to end without the caller's values existing yet. The
 * header must already have passed the header-only parse, which bounds the size. */
static int tf_image(const ef_tf_hdr_t *h, const float *values, uint8_t **blob, size_t *len)
{
    const size_t prov_pad = (size_t)EF_TF_PAD8(h->prov_len);
    const size_t data_off = EF_TABLE_HEADER_SIZE + prov_pad;
    const size_t n = data_off + 4u * (size_t)h->values + 4u;
    uint8_t *p = malloc(n);
    uint32_t k;

    if (p == NULL) {
        return EF_ERR_NOMEM;
    }
    tf_put_header(p, h);
    memset(p + EF_TABLE_HEADER_SIZE, 0, prov_pad);
    if (h->prov_len) {
        memcpy(p + EF_TABLE_HEADER_SIZE, h->prov, h->prov_len);
    }
    if (values != NULL) {
        memcpy(p + data_off, values, 4u * (size_t)h->values); /* the target is little-endian */
    } else {
        const float x1 = (float)h->x1_min;
        for (k = 0; k < h->values; k++) {
            const float v = (h->kind == EF_TABLE_G2_QUINTIC && (k & 1u)) ? 0.0f : x1;
            memcpy(p + data_off + 4u * (size_t)k, &v, sizeof v);
        }
    }
    ef_le_put32(p + n - 4u, ef_crc32(0, p, (uint32_t)(n - 4u)));
    *blob = p;
    *len = n;
    return EF_OK;
}

/* Validate hdr the parser's way: header alone first (it must stop at the size check,
 * which proves every header field good and bounds the allocation), then the whole image.
 * On success *blob and *len hold the image and *view the parsed view into it. */
static int tf_validate(const ef_tf_hdr_t *h, const float *values, const char *who, uint8_t **blob,
                       size_t *len, ef_table_t *view, ef_msg_t *m)
{
    union {
        uint8_t b[EF_TABLE_HEADER_SIZE];
        uint64_t align;
    } hdr;
    uint32_t off = 0;
    int rc;

    *blob = NULL;
    *len = 0;
    tf_put_header(hdr.b, h);
    rc = ef_table_parse(hdr.b, EF_TABLE_HEADER_SIZE, view, &off);
    if (rc != EF_ERR_TBL_TRUNCATED) {
        if (rc == EF_OK) { /* cannot happen: data and CRC are missing */
            rc = EF_ERR_TBL_SIZE;
        }
        return tf_report(m, rc, who, hdr.b, EF_TABLE_HEADER_SIZE, off);
    }
    if ((uint64_t)h->values != (uint64_t)h->nodes * h->ndof) {
        return ef_fail(m, EF_ERR_TBL_SHAPE,
                       "%s: %" PRIu32 " values for %" PRIu32 " nodes x %u DOFs", who, h->values,
                       h->nodes, (unsigned)h->ndof);
    }
    rc = tf_image(h, values, blob, len);
    if (rc != EF_OK) {
        return ef_fail(m, rc, "%s: out of memory for a %" PRIu32 "-node table", who, h->nodes);
    }
    rc = ef_table_parse(*blob, (uint32_t)*len, view, &off);
    if (rc != EF_OK) {
        rc = tf_report(m, rc, who, *blob, *len, off);
        free(*blob);
        *blob = NULL;
        *len = 0;
    }
    return rc;
}

/* Header values of an existing table; the view holds the integers, the table the doubles. */
static void tf_hdr_from_table(const ef_tfile_t *t, ef_tf_hdr_t *h)
{
    unsigned i;

    memset(h, 0, sizeof *h);
    h->kind = t->view.kind;
    h->symmetry = t->view.symmetry;
    h->quad_nodes = t->view.quad_nodes;
    h->naxes = t->view.naxes;
    h->ndof = t->view.ndof;
    h->nodes = t->view.nodes;
    h->values = (uint32_t)((uint64_t)t->view.nodes * t->view.ndof);
    for (i = 0; i < EF_TABLE_MAX_AXES; i++) {
        h->lo[i] = t->lo[i];
        h->hi[i] = t->hi[i];
        h->axis_nodes[i] = t->view.axis[i].nodes;
        h->axis_flags[i] = t->view.axis[i].flags;
    }
    h->x1_min = t->x1_min;
    h->x1_max = t->x1_max;
    h->x2_max = t->x2_max;
    h->prov = t->provenance;
    h->prov_len = (uint32_t)strnlen(t->provenance, sizeof t->provenance - 1);
}

/* Build the header a spec describes and run it through the parser, so create accepts
 * exactly what load would. Values stay zero: they are not valid, so a table nobody
 * filled in cannot be written. */
int ef_tfile_create(ef_tfile_t *t, const ef_tfile_spec_t *spec, ef_msg_t *m)
{
    static const char who[] = "table spec";
    ef_tf_hdr_t h;
    uint64_t product = 1;
    uint8_t *blob;
    size_t len, prov_len, nvalues;
    ef_table_t view;
    unsigned i;
    int rc;

    if (t == NULL || spec == NULL) {
        return ef_fail(m, EF_ERR_ARG, "ef_tfile_create: NULL argument");
    }
    memset(t, 0, sizeof *t);
    /* Range-check before narrowing into 16-bit fields: 65537 must not become 1. */
    if (spec->kind != EF_TABLE_G1_CUBIC && spec->kind != EF_TABLE_G2_QUINTIC) {
        return ef_fail(m, EF_ERR_TBL_KIND, "%s: field 'kind' (offset 12): %s (%d)", who,
                       ef_err_str(EF_ERR_TBL_KIND), spec->kind);
    }
    if (spec->symmetry < 0 || spec->symmetry > 0xFFFF) {
        return ef_fail(m, EF_ERR_TBL_SYMMETRY, "%s: field 'symmetry' (offset 18): %s (%d)", who,
                       ef_err_str(EF_ERR_TBL_SYMMETRY), spec->symmetry);
    }
    if (spec->quad_nodes < 0 || spec->quad_nodes > 0xFFFF) {
        return ef_fail(m, EF_ERR_TBL_FUNCTIONAL, "%s: field 'quad_nodes' (offset 24): %s (%d)", who,
                       ef_err_str(EF_ERR_TBL_FUNCTIONAL), spec->quad_nodes);
    }
    prov_len = spec->provenance ? strlen(spec->provenance) : 0;
    if (prov_len > EF_TABLE_MAX_PROVENANCE) {
        return ef_fail(
            m, EF_ERR_TBL_PROVENANCE, "%s: field 'provenance_len' (offset 56): %s (%zu > %u bytes)",
            who, ef_err_str(EF_ERR_TBL_PROVENANCE), prov_len, (unsigned)EF_TABLE_MAX_PROVENANCE);
    }

    memset(&h, 0, sizeof h);
    h.kind = (uint16_t)spec->kind;
    h.symmetry = (uint16_t)spec->symmetry;
    h.quad_nodes = (uint16_t)spec->quad_nodes;
    h.naxes = h.ndof = spec->kind == EF_TABLE_G1_CUBIC ? 2 : 4;
    for (i = 0; i < EF_TABLE_MAX_AXES; i++) {
        h.lo[i] = spec->lo[i];
        h.hi[i] = spec->hi[i];
        h.axis_nodes[i] = spec->nodes[i];
        h.axis_flags[i] = spec->axis_flags[i];
        if (i < h.naxes) {
            /* Saturate at 32 bits: each factor is below 2^32, so the 64-bit product of
             * a saturated value and one more factor cannot wrap. */
            product *= spec->nodes[i];
            if (product > 0xFFFFFFFFu) {
                product = 0xFFFFFFFFu;
            }
        }
    }
    h.nodes = (uint32_t)product;
    h.values = 0;
    h.x1_min = spec->x1_min;
    h.x1_max = spec->x1_max;
    h.x2_max = spec->x2_max;
    h.prov = spec->provenance;
    h.prov_len = (uint32_t)prov_len;
    if (product <= EF_TABLE_MAX_NODES) {
        h.values = h.nodes * h.ndof;
    }

    rc = tf_validate(&h, NULL, who, &blob, &len, &view, m);
    if (rc != EF_OK) {
        if (rc == EF_ERR_TBL_SHAPE && product == 0xFFFFFFFFu) {
            /* The parser saw a saturated count; the real problem is the size. */
            return ef_fail(m, EF_ERR_TBL_SIZE,
                           "%s: field 'node_count' (offset 28): %s (product of the axes' node "
                           "counts exceeds %u)",
                           who, ef_err_str(EF_ERR_TBL_SIZE), (unsigned)EF_TABLE_MAX_NODES);
        }
        return rc;
    }
    free(blob);

    nvalues = (size_t)h.values;
    t->values = calloc(nvalues, sizeof *t->values);
    if (t->values == NULL) {
        return ef_fail(m, EF_ERR_NOMEM, "%s: out of memory for %zu values", who, nvalues);
    }
    for (i = 0; i < EF_TABLE_MAX_AXES; i++) {
        t->lo[i] = spec->lo[i];
        t->hi[i] = spec->hi[i];
    }
    t->x1_min = spec->x1_min;
    t->x1_max = spec->x1_max;
    t->x2_max = spec->x2_max;
    if (prov_len) {
        memcpy(t->provenance, spec->provenance, prov_len);
    }
    t->provenance[prov_len] = '\0';
    t->view = view;
    t->view.data = t->values;
    t->view.provenance = t->provenance;
    return EF_OK;
}

/* Values either live in the loaded file image or in their own allocation, never both. */
void ef_tfile_free(ef_tfile_t *t)
{
    if (t == NULL) {
        return;
    }
    if (t->blob != NULL) {
        free(t->blob);
    } else {
        free(t->values);
    }
    memset(t, 0, sizeof *t);
}

/* Node coordinates from the exact double domains; the last node is hi itself so rounding
 * never pushes a configuration past the domain. */
void ef_tfile_node_config(const ef_tfile_t *t, uint32_t node, double cfg[EF_TABLE_MAX_AXES])
{
    unsigned i;

    if (cfg == NULL) {
        return;
    }
    for (i = 0; i < EF_TABLE_MAX_AXES; i++) {
        cfg[i] = 0.0;
    }
    if (t == NULL || node >= t->view.nodes || t->view.naxes > EF_TABLE_MAX_AXES) {
        return;
    }
    for (i = 0; i < t->view.naxes; i++) {
        const ef_table_axis_t *ax = &t->view.axis[i];
        uint32_t k;
        if (ax->stride == 0u || ax->nodes < 2u) {
            return;
        }
        k = (node / ax->stride) % ax->nodes;
        cfg[i] = k + 1u == ax->nodes
                     ? t->hi[i]
                     : t->lo[i] + (t->hi[i] - t->lo[i]) * (double)k / (double)(ax->nodes - 1u);
    }
    if (t->view.kind == EF_TABLE_G1_CUBIC && t->view.symmetry == EF_SYM_G1_FOLD) {
        /* (u, v) = ((alpha + beta) / 2, (alpha - beta) / 2) inverted. */
        const double u = cfg[0], v = cfg[1];
        cfg[0] = u + v;
        cfg[1] = u - v;
    }
}

/* Serialize, then parse the image with the firmware parser: a table is written only if
 * the firmware would accept it, so unfilled or out-of-bound values are refused here. */
int ef_tfile_serialize(const ef_tfile_t *t, uint8_t **blob, size_t *len, ef_msg_t *m)
{
    ef_tf_hdr_t h;
    ef_table_t view;

    if (blob) {
        *blob = NULL;
    }
    if (len) {
        *len = 0;
    }
    if (t == NULL || blob == NULL || len == NULL || t->values == NULL) {
        return ef_fail(m, EF_ERR_ARG, "ef_tfile_serialize: NULL argument or table without values");
    }
    tf_hdr_from_table(t, &h);
    return tf_validate(&h, t->values, "table", blob, len, &view, m);
}

/* Readers see the old file or the complete new one: the image goes to a temporary file
 * beside PATH (same file system, so rename is atomic), is flushed, then renamed over. */
int ef_tfile_write(const ef_tfile_t *t, const char *path, ef_msg_t *m)
{
    uint8_t *blob = NULL;
    size_t len = 0;
    if (t == NULL || path == NULL || path[0] == '\0') {
        return ef_fail(m, EF_ERR_ARG, "ef_tfile_write: NULL argument or empty path");
    }
    int rc = ef_tfile_serialize(t, &blob, &len, m);
    if (rc == EF_OK) {
        rc = ef_file_write_atomic(path, blob, len, m);
    }
    free(blob);
    return rc;
}

/* Read exactly n bytes unless the file ends first; returns bytes read or -1. */
static ssize_t tf_read_all(int fd, uint8_t *p, size_t n)
{
    size_t got = 0;
    while (got < n) {
        ssize_t r = read(fd, p + got, n - got);
        if (r < 0) {
            if (errno == EINTR) {
                continue;
            }
            return -1;
        }
        if (r == 0) {
            break;
        }
        got += (size_t)r;
    }
    return (ssize_t)got;
}

/* Whole-file read into a malloc'd (hence suitably aligned) buffer, size-capped before any
 * allocation, then the firmware parser decides; the doubles come from the header bytes
 * because the view only keeps float copies. */
int ef_tfile_load(const char *path, ef_tfile_t *t, ef_msg_t *m)
{
    struct stat st;
    uint8_t *buf;
    size_t size;
    ssize_t got;
    ef_table_t view;
    uint32_t off = 0, data_off;
    unsigned i;
    int fd, rc, err;

    if (t != NULL) {
        memset(t, 0, sizeof *t);
    }
    if (path == NULL || t == NULL) {
        return ef_fail(m, EF_ERR_ARG, "ef_tfile_load: NULL argument");
    }
    fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        err = errno;
        return ef_fail(m, EF_ERR_IO, "%s: cannot open: %s", path, strerror(err));
    }
    if (fstat(fd, &st) != 0) {
        err = errno;
        (void)close(fd);
        return ef_fail(m, EF_ERR_IO, "%s: cannot stat: %s", path, strerror(err));
    }
    if (!S_ISREG(st.st_mode)) {
        (void)close(fd);
        return ef_fail(m, EF_ERR_IO, "%s: not a regular file", path);
    }
    if ((uint64_t)st.st_size > EF_TF_MAX_FILE) {
        (void)close(fd);
        return ef_fail(m, EF_ERR_TBL_SIZE,
                       "%s: %s: %lld bytes, larger than any valid table "
                       "(%" PRIu64 ")",
                       path, ef_err_str(EF_ERR_TBL_SIZE), (long long)st.st_size,
                       (uint64_t)EF_TF_MAX_FILE);
    }
    size = (size_t)st.st_size;
    buf = malloc(size ? size : 1u);
    if (buf == NULL) {
        (void)close(fd);
        return ef_fail(m, EF_ERR_NOMEM, "%s: out of memory for %zu bytes", path, size);
    }
    got = tf_read_all(fd, buf, size);
    err = errno;
    (void)close(fd);
    if (got < 0) {
        free(buf);
        return ef_fail(m, EF_ERR_IO, "%s: read: %s", path, strerror(err));
    }
    /* A file that shrank since fstat is parsed as read and reported truncated. */
    rc = ef_table_parse(buf, (uint32_t)got, &view, &off);
    if (rc != EF_OK) {
        rc = tf_report(m, rc, path, buf, (size_t)got, off);
        free(buf);
        return rc;
    }
    data_off = EF_TABLE_HEADER_SIZE + (uint32_t)EF_TF_PAD8(view.provenance_len);
    t->blob = buf;
    t->view = view;
    t->values = (float *)(void *)(buf + data_off);
    for (i = 0; i < EF_TABLE_MAX_AXES; i++) {
        t->lo[i] = ef_le_getf64(buf + 64 + 24 * i);
        t->hi[i] = ef_le_getf64(buf + 64 + 24 * i + 8);
    }
    t->x1_min = ef_le_getf64(buf + 32);
    t->x1_max = ef_le_getf64(buf + 40);
    t->x2_max = ef_le_getf64(buf + 48);
    memcpy(t->provenance, view.provenance, view.provenance_len);
    t->provenance[view.provenance_len] = '\0';
    return EF_OK;
}
