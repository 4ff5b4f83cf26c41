/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_table.h
 * @brief Optimal-DOF tables: the binary format (v1), a validating parser that works on a
 * blob in memory, and constant-time bilinear (G1) / 4-linear (G2) lookup.
 *
 * Tables are read-only data. A firmware links one as generated C source (a `const`
 * ::ef_table_t plus its `const float` node array) or parses a blob it received with
 * ef_table_parse(); the host writes and loads files (host/include/evenfeed/host/tables/ef_tfile.h).
 *
 * ## File format, version 1 (all integers and floats little-endian)
 * | offset | size | field |
 * |---|---|---|
 * | 0   | 8  | magic `45 46 54 42 0D 0A 1A 0A` ("EFTB\r\n\x1a\n") |
 * | 8   | 2  | format version = 1 |
 * | 10  | 2  | header size = 160 |
 * | 12  | 2  | kind: 1 = G1 cubic (2 axes, 2 DOFs), 2 = G2 quintic (4 axes, 4 DOFs) |
 * | 14  | 2  | value type: 1 = float32 |
 * | 16  | 1  | axis count |
 * | 17  | 1  | DOF count per node |
 * | 18  | 2  | symmetry: 0 none, 1 G1 fold (u,v), 2 G2 mirror (alpha >= 0 stored) |
 * | 20  | 2  | functional id: 1 = constant-speed C |
 * | 22  | 2  | quadrature: 1 = Gauss–Legendre |
 * | 24  | 2  | quadrature node count (1..64) |
 * | 26  | 2  | reserved, 0 |
 * | 28  | 4  | node count = product of the axes' node counts |
 * | 32  | 8  | f64 x1 lower bound per unit chord used by the optimizer (> 0) |
 * | 40  | 8  | f64 x1 upper bound per unit chord (> lower, <= 1e6) |
 * | 48  | 8  | f64 bound on |x2| per unit chord (G2, <= 1e6; 0 for G1) |
 * | 56  | 4  | provenance length in bytes (0..EF_TABLE_MAX_PROVENANCE) |
 * | 60  | 4  | reserved, 0 |
 * | 64  | 96 | 4 axes x { f64 lo, f64 hi, u32 nodes, u32 flags (bit 0: periodic) };
 *              axes past the axis count are all zero |
 * | 160 | L  | provenance: printable ASCII (build command, version, date), zero-padded to a
 *              multiple of 8 |
 * | ... | 4·N·D | node values, node-major (D DOFs per node), axis 0 varying fastest |
 * | end-4 | 4 | CRC-32 (IEEE 802.3, as zlib) of every byte before it |
 *
 * Axes and DOFs per kind (DOFs are per unit chord):
 * - G1 cubic, no symmetry: axes (alpha, beta); periodic axes must span exactly 2 pi.
 *   G1 fold: axes (u, v) = ((alpha+beta)/2, (alpha-beta)/2) over exactly [0, pi/2] x [0, pi],
 *   the fundamental region of the mirror and reversal symmetries. DOFs (x1_0, x1_1).
 * - G2 quintic: axes (alpha, beta, k0, k1); mirror symmetry stores alpha >= 0 only
 *   (axis 0 starts at 0). DOFs (x1_0, x2_0, x1_1, x2_1).
 */
#ifndef EF_TABLE_H
#define EF_TABLE_H

#include <stdint.h>
#include "evenfeed/core/ef_config.h"

#ifdef __cplusplus
extern "C" {
#endif

#define EF_TABLE_MAGIC_LEN   8
#define EF_TABLE_VERSION     1u
#define EF_TABLE_HEADER_SIZE 160u

/** Table kinds (file field "kind"). */
enum {
    EF_TABLE_G1_CUBIC = 1,  /**< 2 axes (alpha, beta), DOFs (x1_0, x1_1) */
    EF_TABLE_G2_QUINTIC = 2 /**< 4 axes (alpha, beta, k0, k1), DOFs (x1_0, x2_0, x1_1, x2_1) */
};
/** Stored value types. */
enum { EF_TABLE_F32 = 1 };
/** Symmetry of the stored region. */
enum {
    EF_SYM_NONE = 0,     /**< the whole domain is stored */
    EF_SYM_G1_FOLD = 1,  /**< G1: (u,v) fundamental region, 4x smaller */
    EF_SYM_G2_MIRROR = 2 /**< G2: alpha >= 0 half, 2x smaller */
};
/** Functional ids. */
enum { EF_FUNCTIONAL_CONSTANT_SPEED = 1 };
/** Quadrature ids. */
enum { EF_QUAD_GAUSS_LEGENDRE = 1 };
/** Axis flags. */
#define EF_AXIS_PERIODIC 1u

/** Lookup result flags: bit i set = user coordinate i (alpha, beta, k0, k1) was outside the
 *  table domain and was clamped to it. */
#define EF_LOOKUP_CLAMP_ALPHA 1u
#define EF_LOOKUP_CLAMP_BETA  2u
#define EF_LOOKUP_CLAMP_K0    4u
#define EF_LOOKUP_CLAMP_K1    8u

/** One axis of a table as the lookup uses it. */
typedef struct {
    float lo;        /**< first node */
    float hi;        /**< last node */
    float inv_step;  /**< (nodes - 1) / (hi - lo) */
    uint32_t nodes;  /**< node count, 2..EF_TABLE_MAX_AXIS_NODES */
    uint32_t stride; /**< distance between neighbouring nodes along this axis, in nodes */
    uint32_t flags;  /**< EF_AXIS_PERIODIC */
} ef_table_axis_t;

/** A table ready for lookup. Generated C sources define these as `const`; ef_table_parse()
 *  fills one that points into the parsed blob. */
typedef struct {
    uint16_t kind;       /**< EF_TABLE_G1_CUBIC or EF_TABLE_G2_QUINTIC */
    uint16_t symmetry;   /**< EF_SYM_* */
    uint8_t naxes;       /**< 2 or 4 */
    uint8_t ndof;        /**< 2 or 4 */
    uint16_t quad_nodes; /**< Gauss–Legendre nodes used when building */
    uint32_t nodes;      /**< total node count */
    float x1_min;        /**< optimizer's x1 lower bound per unit chord */
    float x1_max;        /**< optimizer's x1 upper bound per unit chord */
    float x2_max;        /**< optimizer's |x2| bound per unit chord (G2) */
    ef_table_axis_t axis[EF_TABLE_MAX_AXES];
    const float *data;      /**< nodes x ndof values */
    const char *provenance; /**< not NUL-terminated */
    uint32_t provenance_len;
} ef_table_t;

/**
 * @brief CRC-32 (IEEE 802.3 polynomial, reflected, as zlib's crc32()).
 * @param crc previous value (0 to start)
 * @param buf bytes
 * @param len byte count
 * @return updated CRC
 */
uint32_t ef_crc32(uint32_t crc, const void *buf, uint32_t len);

/**
 * @brief Validate a table blob completely and fill a lookup view pointing into it.
 *
 * Reads only inside [blob, blob+len). Every header field, the exact size, the CRC and every
 * stored value are checked. The blob must stay alive and unchanged while the view is used.
 * The node values are used in place, so the blob must be 4-byte aligned and the target
 * little-endian.
 * @param blob bytes of a table file
 * @param len  byte count
 * @param out  filled on success; zeroed on failure
 * @param bad_offset out, may be NULL: on failure the byte offset of the offending field
 *             (the header table above names it), for diagnostics
 * @retval EF_OK
 * @retval EF_ERR_ARG            NULL pointer or blob not 4-byte aligned
 * @retval EF_ERR_TBL_TRUNCATED  shorter than the header, or than header + provenance + data + CRC
 * @retval EF_ERR_TBL_MAGIC      wrong magic bytes
 * @retval EF_ERR_TBL_VERSION    version other than 1
 * @retval EF_ERR_TBL_HEADER     header size other than 160, or a reserved field nonzero
 * @retval EF_ERR_TBL_KIND       unknown kind
 * @retval EF_ERR_TBL_VALUE_TYPE unknown value type
 * @retval EF_ERR_TBL_SHAPE      axis/DOF count not those of the kind, or node count not the
 *                               product of the axes' node counts
 * @retval EF_ERR_TBL_AXIS       an axis not finite and increasing, node count out of range,
 *                               bad flags, a periodic axis not spanning 2 pi, unused axis not 0
 * @retval EF_ERR_TBL_SYMMETRY   symmetry unknown, or its axes not the required region
 * @retval EF_ERR_TBL_FUNCTIONAL unknown functional or quadrature, or node count out of range
 * @retval EF_ERR_TBL_SIZE       longer than the header says, or more than EF_TABLE_MAX_NODES
 * @retval EF_ERR_TBL_PROVENANCE provenance longer than EF_TABLE_MAX_PROVENANCE, not printable
 *                               ASCII, or its padding not zero
 * @retval EF_ERR_TBL_CRC        CRC mismatch
 * @retval EF_ERR_TBL_VALUE      DOF bounds invalid, or a value non-finite or out of bounds
 */
int ef_table_parse(const void *blob, uint32_t len, ef_table_t *out, uint32_t *bad_offset);

/**
 * @brief Check a table view's internal consistency (derived fields, strides, bounds); for
 * views built by generated C sources. Does not read the node values.
 * @retval EF_OK
 * @retval EF_ERR_ARG         NULL pointer or data NULL
 * @retval EF_ERR_TBL_KIND, EF_ERR_TBL_SHAPE, EF_ERR_TBL_AXIS, EF_ERR_TBL_SYMMETRY  as
 * ef_table_parse()
 */
int ef_table_check(const ef_table_t *tbl);

/**
 * @brief Optimal G1 cubic DOFs per unit chord for tangent angles (alpha, beta): bilinear
 * interpolation, symmetry folding, periodic wrap, clamping. Fixed instruction count.
 * @param tbl   a G1 cubic table
 * @param alpha,beta  tangent angles (rad), finite
 * @param dof   out: x1_0, x1_1 per unit chord
 * @param flags out: EF_LOOKUP_CLAMP_* bits (0 when inside the domain); may be NULL
 * @retval EF_OK
 * @retval EF_ERR_ARG  NULL pointer
 * @retval EF_ERR_KIND not a G1 cubic table
 */
int ef_table_lookup_g1(const ef_table_t *tbl, float alpha, float beta, float dof[2],
                       uint32_t *flags);

/**
 * @brief Optimal G2 quintic DOFs per unit chord for (alpha, beta, k0, k1): 4-linear
 * interpolation over 16 nodes, mirror folding, clamping. Fixed instruction count.
 * @param tbl   a G2 quintic table
 * @param c     alpha, beta (rad), k0, k1 (curvature x chord), finite
 * @param dof   out: x1_0, x2_0, x1_1, x2_1 per unit chord
 * @param flags out: EF_LOOKUP_CLAMP_* bits; may be NULL
 * @retval EF_OK
 * @retval EF_ERR_ARG  NULL pointer
 * @retval EF_ERR_KIND not a G2 quintic table
 */
int ef_table_lookup_g2(const ef_table_t *tbl, const float c[4], float dof[4], uint32_t *flags);

/**
 * @brief ef_table_lookup_g2() at the symmetric corner (phi, -phi, 0, 0), the configuration
 * of every corner blend: the same DOFs (values equal; a zero may differ in sign), in about a
 * quarter of the work when curvature 0 is a node of both curvature axes (the shipped
 * tables: 9 nodes on [-2, 2]), since the 4-linear lerp then has weight 0 along them;
 * otherwise the general lookup. Fixed instruction count per table.
 * @param tbl   a G2 quintic table
 * @param phi   half the turn (rad), finite
 * @param dof   out: x1_0, x2_0, x1_1, x2_1 per unit chord
 * @param flags out: EF_LOOKUP_CLAMP_* bits; may be NULL
 * @retval EF_OK
 * @retval EF_ERR_ARG  NULL pointer
 * @retval EF_ERR_KIND not a G2 quintic table
 */
int ef_table_lookup_g2_corner(const ef_table_t *tbl, float phi, float dof[4], uint32_t *flags);

#ifdef __cplusplus
}
#endif

#endif /* EF_TABLE_H */
