/* SPDX-License-Identifier: Apache-2.0 */
/* Private to host/lib (ef_build.c, ef_shard.c): the build-spec record and the file prefix
 * shared by build journals (.partial) and shard files (.efs); docs/table-build.md has the
 * byte layouts. */
#ifndef EF_SHARD_INT_H
#define EF_SHARD_INT_H

#include <stddef.h>
#include <stdint.h>
#include "core/ef_le_int.h"
#include "evenfeed/host/tables/ef_build.h"
#include "core/ef_file_int.h"

/* Longest backend name a spec record holds. */
#define EF_SPEC_MAX_BACKEND 31u
/* Fixed part of the spec record; the backend name and provenance follow it. */
#define EF_SPEC_FIXED 140u
#define EF_SPEC_MAX   (EF_SPEC_FIXED + EF_SPEC_MAX_BACKEND + EF_TABLE_MAX_PROVENANCE)
/* File prefix: magic, version, reserved, spec length, shard index/count, row range. */
#define EF_EFILE_PREFIX 32u
/* Prefix + largest spec + header CRC. */
#define EF_EFILE_MAX_HEADER (EF_EFILE_PREFIX + EF_SPEC_MAX + 4u)
#define EF_EFILE_VERSION    1u

/* Everything that decides a build's bytes: the table header fields, the provenance and the
 * backend. Two builds with equal records produce equal tables. */
typedef struct {
    uint16_t kind, symmetry, quad_nodes;
    uint8_t naxes, ndof;
    uint32_t nodes, rows;
    double x1_min, x1_max, x2_max;
    double lo[EF_TABLE_MAX_AXES], hi[EF_TABLE_MAX_AXES];
    uint32_t axis_nodes[EF_TABLE_MAX_AXES], axis_flags[EF_TABLE_MAX_AXES];
    char backend[EF_SPEC_MAX_BACKEND + 1];
    char prov[EF_TABLE_MAX_PROVENANCE + 1];
    uint32_t prov_len;
} ef_spec_rec_t;

/* The decoded prefix of a journal or shard file. */
typedef struct {
    uint32_t index, count;       /* shard; 0/0 for a whole-table journal */
    uint32_t row_begin, row_end; /* rows the file is about */
    ef_spec_rec_t spec;
    size_t header_len; /* prefix + spec + header CRC */
} ef_efile_hdr_t;

extern const uint8_t ef_magic_journal[8];
extern const uint8_t ef_magic_shard[8];

/* The spec record of a created table built by a named backend; EF_ERR_ARG if the name is
 * empty, too long or not printable. */
int ef_spec_from_table(const ef_tfile_t *t, const char *backend, ef_spec_rec_t *s, ef_msg_t *m);
/* Describe how b differs from a, field by field, into out ("" when equal); returns the
 * number of differing fields. */
int ef_spec_diff(const ef_spec_rec_t *a, const ef_spec_rec_t *b, char *out, size_t size);
/* The ef_tfile_create() spec a record describes; s must outlive ts (provenance). */
void ef_spec_to_tfile(const ef_spec_rec_t *s, ef_tfile_spec_t *ts);

/* Serialize a file header (prefix, spec, CRC) into buf (EF_EFILE_MAX_HEADER bytes);
 * returns its length. */
size_t ef_efile_put_header(uint8_t *buf, const uint8_t magic[8], const ef_efile_hdr_t *h);
/* Parse and check a file header: magic (naming what the file is when it is another of
 * evenfeed's formats), version, lengths, header CRC, a sane spec, shard and rows. what is
 * "build journal" or "shard file" for messages. */
int ef_efile_get_header(const char *path, const uint8_t *buf, size_t len, const uint8_t magic[8],
                        const char *what, ef_efile_hdr_t *h, ef_msg_t *m);

/* Check n stored values (float32 little-endian bytes, or floats when raw is NULL) against a
 * spec's bounds, as the table parser will: finite, x1 within [x1_min, x1_max], x2 within
 * +-x2_max (with the parser's slack, narrowed so that passing here implies passing there).
 * Returns the index of the first bad value, or n when all are good. */
size_t ef_values_check(const ef_spec_rec_t *s, const uint8_t *raw, const float *vals, size_t n);

#endif /* EF_SHARD_INT_H */
