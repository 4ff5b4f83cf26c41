/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_tfile.h
 * @brief Table files on the host: create, fill, serialize, write, load, emit C source.
 *
 * The byte layout is documented in firmware/include/evenfeed/table/ef_table.h; loading goes
 * through the firmware's own validating parser, so host and firmware accept exactly the
 * same files.
 */
#ifndef EF_TFILE_H
#define EF_TFILE_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include "evenfeed/table/ef_table.h"
#include "evenfeed/host/core/ef_host.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Parameters of a table to create. Domains are in storage coordinates (for a G1 fold
 *  table: u in [0, pi/2], v in [0, pi]). */
typedef struct {
    int kind;                               /**< EF_TABLE_G1_CUBIC / EF_TABLE_G2_QUINTIC */
    int symmetry;                           /**< EF_SYM_* */
    double lo[EF_TABLE_MAX_AXES];           /**< first node per axis */
    double hi[EF_TABLE_MAX_AXES];           /**< last node per axis */
    uint32_t nodes[EF_TABLE_MAX_AXES];      /**< node count per axis */
    uint32_t axis_flags[EF_TABLE_MAX_AXES]; /**< EF_AXIS_PERIODIC */
    double x1_min, x1_max, x2_max;          /**< optimizer bounds per unit chord */
    int quad_nodes;                         /**< Gauss–Legendre nodes of the functional */
    const char *provenance;                 /**< printable ASCII, <= EF_TABLE_MAX_PROVENANCE */
} ef_tfile_spec_t;

/** A table owned by the host. `view` is the firmware lookup view onto `values`. */
typedef struct {
    ef_table_t view;
    float *values;                /**< nodes x ndof, owned */
    double lo[EF_TABLE_MAX_AXES]; /**< exact domains (the view holds float copies) */
    double hi[EF_TABLE_MAX_AXES];
    double x1_min, x1_max, x2_max;
    char provenance[EF_TABLE_MAX_PROVENANCE + 1];
    void *blob; /**< owned file image after ef_tfile_load() */
} ef_tfile_t;

/**
 * @brief Create an empty table (values zero) from a spec, validated as the parser would.
 * @retval EF_OK
 * @retval EF_ERR_ARG     NULL pointer
 * @retval EF_ERR_NOMEM   allocation failed
 * @retval EF_ERR_TBL_*   the spec would make an invalid file (same codes as ef_table_parse())
 */
int ef_tfile_create(ef_tfile_t *t, const ef_tfile_spec_t *spec, ef_msg_t *m);

/** Release what a table owns; safe on a zeroed or already freed table. */
void ef_tfile_free(ef_tfile_t *t);

/**
 * @brief The configuration a node stands for, in user coordinates: (alpha, beta) for G1
 * (unfolded from (u, v) for a fold table), (alpha, beta, k0, k1) for G2.
 */
void ef_tfile_node_config(const ef_tfile_t *t, uint32_t node, double cfg[EF_TABLE_MAX_AXES]);

/**
 * @brief Serialize to a file image (malloc'd; caller frees).
 * @retval EF_OK
 * @retval EF_ERR_ARG, EF_ERR_NOMEM
 * @retval EF_ERR_TBL_VALUE  a value is non-finite or out of its bounds
 */
int ef_tfile_serialize(const ef_tfile_t *t, uint8_t **blob, size_t *len, ef_msg_t *m);

/**
 * @brief Write the file atomically (temporary file in the same directory, then rename).
 * @retval EF_OK
 * @retval EF_ERR_IO   open/write/rename failed (message names path and errno text)
 * @retval others      as ef_tfile_serialize()
 */
int ef_tfile_write(const ef_tfile_t *t, const char *path, ef_msg_t *m);

/**
 * @brief Load and fully validate a table file.
 * @retval EF_OK
 * @retval EF_ERR_IO          cannot open or read
 * @retval EF_ERR_NOMEM
 * @retval EF_ERR_TBL_*       as ef_table_parse(); the message names the path, the field
 *                            and its byte offset
 */
int ef_tfile_load(const char *path, ef_tfile_t *t, ef_msg_t *m);

/**
 * @brief Emit C source defining `const ef_table_t NAME` and its `static const float` node
 * array (exact hex-float literals), linkable by a firmware with no file system.
 * @param name a C identifier
 * @retval EF_OK
 * @retval EF_ERR_ARG  NULL pointer or name not a C identifier
 * @retval EF_ERR_IO   write failed
 */
int ef_tfile_emit_c(const ef_tfile_t *t, const char *name, FILE *out, ef_msg_t *m);

/** Name of the header field at a byte offset of the file layout (for messages). */
const char *ef_tfile_field_name(uint32_t offset);

#ifdef __cplusplus
}
#endif

#endif /* EF_TFILE_H */
