/* SPDX-License-Identifier: Apache-2.0 */
/* Validating parser for table blobs (format v1) and consistency check of table views.
 * Freestanding: no libc calls, no heap, no libm; every loop is bounded by a count that was
 * validated before the loop starts. */
#include <float.h>
#include <stddef.h>
#include <stdint.h>
#include "evenfeed/core/ef_err.h"
#include "evenfeed/table/ef_table.h"

/* Byte offsets of the header fields (see the table in ef_table.h). */
#define EF_OFF_MAGIC      0u
#define EF_OFF_VERSION    8u
#define EF_OFF_HSIZE      10u
#define EF_OFF_KIND       12u
#define EF_OFF_VTYPE      14u
#define EF_OFF_NAXES      16u
#define EF_OFF_NDOF       17u
#define EF_OFF_SYMMETRY   18u
#define EF_OFF_FUNCTIONAL 20u
#define EF_OFF_QUAD       22u
#define EF_OFF_QUAD_NODES 24u
#define EF_OFF_RESERVED0  26u
#define EF_OFF_NODES      28u
#define EF_OFF_X1_MIN     32u
#define EF_OFF_X1_MAX     40u
#define EF_OFF_X2_MAX     48u
#define EF_OFF_PROV_LEN   56u
#define EF_OFF_RESERVED1  60u
#define EF_OFF_AXES       64u
#define EF_AXIS_BYTES     24u
#define EF_AXIS_LO        0u
#define EF_AXIS_HI        8u
#define EF_AXIS_NODES     16u
#define EF_AXIS_FLAGS     20u

#define EF_TBL_PI  3.14159265358979323846
#define EF_TBL_2PI 6.28318530717958647692

/* Parser tolerances, from the format rules: periodic span and angle limits are exact up to
 * rounding of 2 pi in double; the fold region is given to 1e-6 so generators may write
 * float-derived bounds; values may sit a relative 1e-6 outside the optimizer bounds. */
#define EF_TBL_PERIOD_TOL  1e-9
#define EF_TBL_ANGLE_SLACK 1e-9
#define EF_TBL_FOLD_TOL    1e-6
#define EF_TBL_VALUE_REL   1e-6

/* Largest optimizer bound (x1_max, x2_max) per unit chord a table may declare. Real bounds
 * are O(10); the cap keeps every interpolated DOF, and its product with any chord up to
 * EF_MAX_COORD, far from float overflow (a 16-corner blend of values near FLT_MAX can round
 * to infinity). */
#ifndef EF_TABLE_MAX_DOF_BOUND
#define EF_TABLE_MAX_DOF_BOUND 1e6
#endif

/* ef_table_check() sees only float copies of the bounds, each rounded by up to half an ulp
 * (2.4e-7 near 2 pi); its slack covers that so every view the parser fills passes. */
#define EF_TBL_CHECK_SLACK   2e-6
#define EF_TBL_CHECK_INV_REL 1e-6

static const uint8_t ef_tbl_magic[EF_TABLE_MAGIC_LEN] = {0x45, 0x46, 0x54, 0x42,
                                                         0x0D, 0x0A, 0x1A, 0x0A};

/* Little-endian reads assembled byte by byte: independent of host order and alignment. */
static uint16_t tp_rd16(const uint8_t *p)
{
    return (uint16_t)((uint32_t)p[0] | ((uint32_t)p[1] << 8));
}

/* 32-bit little-endian read. */
static uint32_t tp_rd32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

/* f64 little-endian read; the union is the C11-sanctioned way to reinterpret bits. */
static double tp_rdf64(const uint8_t *p)
{
    union {
        uint64_t u;
        double d;
    } v;
    v.u = (uint64_t)tp_rd32(p) | ((uint64_t)tp_rd32(p + 4) << 32);
    return v.d;
}

/* Finite test on the exponent bits, since the firmware has no libm isfinite(). */
static int tp_finite64(double x)
{
    union {
        double d;
        uint64_t u;
    } v;
    v.d = x;
    return ((v.u >> 52) & 0x7FFu) != 0x7FFu;
}

/* Same for float. */
static int tp_finite32(float x)
{
    union {
        float f;
        uint32_t u;
    } v;
    v.f = x;
    return ((v.u >> 23) & 0xFFu) != 0xFFu;
}

/* |x| without libm. */
static double tp_abs64(double x)
{
    return x < 0.0 ? -x : x;
}

/* Zero the view without memset so the firmware keeps its no-libc promise. */
static void tp_tbl_zero(ef_table_t *t)
{
    static const ef_table_t zero;
    *t = zero;
}

/* Record where a parse failed; keeps the failure paths one line each. */
static int tp_tbl_fail(ef_table_t *out, uint32_t *bad_offset, int code, uint32_t off)
{
    tp_tbl_zero(out);
    if (bad_offset) {
        *bad_offset = off;
    }
    return code;
}

/* Largest |bound| an axis of this kind may have: angles are meaningful only within one
 * turn either side of 0 (G1) or half a turn (G2); curvature beyond the endpoint limit is
 * rejected at input, so a table never needs to cover it. */
static double tp_tbl_axis_limit(unsigned kind, unsigned axis)
{
    if (kind == EF_TABLE_G1_CUBIC) {
        return EF_TBL_2PI;
    }
    return axis < 2u ? EF_TBL_PI : (double)EF_MAX_NORM_CURVATURE;
}

/* inv_step is derived from the float bounds the lookup uses, so that hi maps exactly to
 * the last node; computed in double so parse and check agree bit for bit. */
static double tp_tbl_inv_step(uint32_t nodes, float lo, float hi)
{
    return (double)(nodes - 1u) / ((double)hi - (double)lo);
}

/* Validate one used axis of the header and fill its view entry; returns 0 or a code. */
static int tp_tbl_parse_axis(const uint8_t *b, unsigned kind, unsigned sym, unsigned i,
                             ef_table_axis_t *ax, uint32_t *off)
{
    const uint32_t base = EF_OFF_AXES + i * EF_AXIS_BYTES;
    const double lo = tp_rdf64(b + base + EF_AXIS_LO);
    const double hi = tp_rdf64(b + base + EF_AXIS_HI);
    const uint32_t nodes = tp_rd32(b + base + EF_AXIS_NODES);
    const uint32_t flags = tp_rd32(b + base + EF_AXIS_FLAGS);
    const double lim = tp_tbl_axis_limit(kind, i);
    const double slack = kind == EF_TABLE_G1_CUBIC || i < 2u ? EF_TBL_ANGLE_SLACK : 0.0;
    double inv;
    float lo_f, hi_f;

    *off = base + EF_AXIS_LO;
    if (!tp_finite64(lo) || lo < -(lim + slack)) {
        return EF_ERR_TBL_AXIS;
    }
    *off = base + EF_AXIS_HI;
    if (!tp_finite64(hi) || !(hi > lo) || hi > lim + slack) {
        return EF_ERR_TBL_AXIS;
    }
    /* Bounds are now within +-1e3, so the float conversions below are defined. */
    lo_f = (float)lo;
    hi_f = (float)hi;
    if (!(hi_f > lo_f)) {
        return EF_ERR_TBL_AXIS; /* distinct in double, equal in float: no usable step */
    }
    *off = base + EF_AXIS_NODES;
    if (nodes < 2u || nodes > EF_TABLE_MAX_AXIS_NODES) {
        return EF_ERR_TBL_AXIS;
    }
    inv = tp_tbl_inv_step(nodes, lo_f, hi_f);
    if (!(inv <= (double)FLT_MAX)) {
        *off = base + EF_AXIS_HI; /* span too narrow for float */
        return EF_ERR_TBL_AXIS;
    }
    *off = base + EF_AXIS_FLAGS;
    if ((flags & ~EF_AXIS_PERIODIC) != 0u) {
        return EF_ERR_TBL_AXIS;
    }
    if ((flags & EF_AXIS_PERIODIC) != 0u) {
        /* Only the unfolded G1 angles wrap; a fold or G2 axis is a bounded interval. */
        if (kind != EF_TABLE_G1_CUBIC || sym != EF_SYM_NONE) {
            return EF_ERR_TBL_AXIS;
        }
        if (tp_abs64((hi - lo) - EF_TBL_2PI) > EF_TBL_PERIOD_TOL) {
            return EF_ERR_TBL_AXIS;
        }
    }
    ax->lo = lo_f;
    ax->hi = hi_f;
    ax->inv_step = (float)inv;
    ax->nodes = nodes;
    ax->flags = flags;
    return EF_OK;
}

/* Reject the first nonzero byte of an unused axis, reporting the field it belongs to. */
static int tp_tbl_unused_axis(const uint8_t *b, unsigned i, uint32_t *off)
{
    const uint32_t base = EF_OFF_AXES + i * EF_AXIS_BYTES;
    uint32_t j;

    for (j = 0; j < EF_AXIS_BYTES; j++) {
        if (b[base + j] != 0u) {
            *off = base + (j < 8u    ? EF_AXIS_LO
                           : j < 16u ? EF_AXIS_HI
                           : j < 20u ? EF_AXIS_NODES
                                     : EF_AXIS_FLAGS);
            return EF_ERR_TBL_AXIS;
        }
    }
    return EF_OK;
}

/* Symmetric storage is only correct over the exact fundamental region the lookup folds
 * into; anything else would silently return DOFs for the wrong configuration. */
static int tp_tbl_parse_region(const uint8_t *b, unsigned sym, uint32_t *off)
{
    const uint32_t a0 = EF_OFF_AXES, a1 = EF_OFF_AXES + EF_AXIS_BYTES;

    if (sym == EF_SYM_G1_FOLD) {
        const double want[4] = {0.0, EF_TBL_PI / 2.0, 0.0, EF_TBL_PI};
        const uint32_t at[4] = {a0 + EF_AXIS_LO, a0 + EF_AXIS_HI, a1 + EF_AXIS_LO, a1 + EF_AXIS_HI};
        unsigned k;
        for (k = 0; k < 4u; k++) {
            if (tp_abs64(tp_rdf64(b + at[k]) - want[k]) > EF_TBL_FOLD_TOL) {
                *off = at[k];
                return EF_ERR_TBL_SYMMETRY;
            }
        }
    } else if (sym == EF_SYM_G2_MIRROR) {
        if (tp_rdf64(b + a0 + EF_AXIS_LO) != 0.0) {
            *off = a0 + EF_AXIS_LO;
            return EF_ERR_TBL_SYMMETRY;
        }
    }
    return EF_OK;
}

/* The optimizer bounds must describe a nonempty positive x1 range, capped so values stay
 * far from float overflow; G1 has no x2 so its bound is pinned to 0 to keep files
 * canonical. */
static int tp_tbl_parse_bounds(const uint8_t *b, unsigned kind, ef_table_t *v, uint32_t *off)
{
    const double x1_min = tp_rdf64(b + EF_OFF_X1_MIN);
    const double x1_max = tp_rdf64(b + EF_OFF_X1_MAX);
    const double x2_max = tp_rdf64(b + EF_OFF_X2_MAX);

    *off = EF_OFF_X1_MIN;
    if (!tp_finite64(x1_min) || !(x1_min > 0.0) || !(x1_min < EF_TABLE_MAX_DOF_BOUND) ||
        !((float)x1_min > 0.0f)) {
        return EF_ERR_TBL_VALUE;
    }
    *off = EF_OFF_X1_MAX;
    if (!tp_finite64(x1_max) || !(x1_max > x1_min) || !(x1_max <= EF_TABLE_MAX_DOF_BOUND) ||
        !((float)x1_max > (float)x1_min)) {
        return EF_ERR_TBL_VALUE;
    }
    *off = EF_OFF_X2_MAX;
    if (kind == EF_TABLE_G1_CUBIC) {
        if (x2_max != 0.0) {
            return EF_ERR_TBL_VALUE;
        }
    } else if (!tp_finite64(x2_max) || !(x2_max >= 0.0) || !(x2_max <= EF_TABLE_MAX_DOF_BOUND)) {
        return EF_ERR_TBL_VALUE;
    }
    v->x1_min = (float)x1_min;
    v->x1_max = (float)x1_max;
    v->x2_max = (float)x2_max;
    return EF_OK;
}

/* Smallest float >= d, for finite d >= 0 within float range. Comparing a float value with
 * it is exactly the comparison with d, without a double operation per value (soft-float
 * on a Cortex-M4F). */
static float tp_tbl_f32_ceil(double d)
{
    union {
        float f;
        uint32_t u;
    } v;
    v.f = (float)d;
    if ((double)v.f < d) {
        v.u++; /* positive and finite: the next pattern is the next float up */
    }
    return v.f;
}

/* Largest float <= d, for finite d >= 0 within float range. */
static float tp_tbl_f32_floor(double d)
{
    union {
        float f;
        uint32_t u;
    } v;
    v.f = (float)d;
    if ((double)v.f > d) {
        v.u--; /* v.f > d >= 0, so stepping down stays >= 0 */
    }
    return v.f;
}

/* Every stored value must be finite and inside the optimizer's box (with the relative
 * slack), so a lookup can never interpolate garbage. Returns the first bad index or -1. */
static int64_t tp_tbl_bad_value(const float *data, uint32_t count, unsigned kind, const uint8_t *b)
{
    const float x1_lo = tp_tbl_f32_ceil(tp_rdf64(b + EF_OFF_X1_MIN) * (1.0 - EF_TBL_VALUE_REL));
    const float x1_hi = tp_tbl_f32_floor(tp_rdf64(b + EF_OFF_X1_MAX) * (1.0 + EF_TBL_VALUE_REL));
    const float x2_hi = tp_tbl_f32_floor(tp_rdf64(b + EF_OFF_X2_MAX) * (1.0 + EF_TBL_VALUE_REL));
    uint32_t k;

    for (k = 0; k < count; k++) {
        const float x = data[k];
        if (!tp_finite32(x)) {
            return (int64_t)k;
        }
        /* G2 stores (x1_0, x2_0, x1_1, x2_1): odd slots are x2. */
        if (kind == EF_TABLE_G2_QUINTIC && (k & 1u) != 0u) {
            if (x > x2_hi || x < -x2_hi) {
                return (int64_t)k;
            }
        } else if (x < x1_lo || x > x1_hi) {
            return (int64_t)k;
        }
    }
    return -1;
}

/* Parse in the order cheapest/structural first, CRC before content, so that corruption is
 * reported as such and the value scan only runs on bytes known to be intact. */
int ef_table_parse(const void *blob, uint32_t len, ef_table_t *out, uint32_t *bad_offset)
{
    const uint8_t *b = (const uint8_t *)blob;
    ef_table_t v;
    unsigned kind, sym, naxes, ndof, i;
    uint32_t off = 0, nodes, prov_len, prov_pad, stride, crc_at;
    uint64_t product, total, data_off;
    int64_t bad;
    int rc;

    if (bad_offset) {
        *bad_offset = 0;
    }
    if (out == NULL || b == NULL) {
        if (out) {
            tp_tbl_zero(out);
        }
        return EF_ERR_ARG;
    }
    tp_tbl_zero(out);
    if (((uintptr_t)blob & 3u) != 0u) {
        return EF_ERR_ARG; /* node values are used in place as floats */
    }
    tp_tbl_zero(&v);

    if (len < EF_TABLE_MAGIC_LEN) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_TRUNCATED, len);
    }
    for (i = 0; i < EF_TABLE_MAGIC_LEN; i++) {
        if (b[i] != ef_tbl_magic[i]) {
            return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_MAGIC, EF_OFF_MAGIC);
        }
    }
    if (len < EF_TABLE_HEADER_SIZE) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_TRUNCATED, len);
    }
    if (tp_rd16(b + EF_OFF_VERSION) != EF_TABLE_VERSION) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_VERSION, EF_OFF_VERSION);
    }
    if (tp_rd16(b + EF_OFF_HSIZE) != EF_TABLE_HEADER_SIZE) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_HEADER, EF_OFF_HSIZE);
    }
    if (tp_rd16(b + EF_OFF_RESERVED0) != 0u) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_HEADER, EF_OFF_RESERVED0);
    }
    if (tp_rd32(b + EF_OFF_RESERVED1) != 0u) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_HEADER, EF_OFF_RESERVED1);
    }
    kind = tp_rd16(b + EF_OFF_KIND);
    if (kind != EF_TABLE_G1_CUBIC && kind != EF_TABLE_G2_QUINTIC) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_KIND, EF_OFF_KIND);
    }
    if (tp_rd16(b + EF_OFF_VTYPE) != EF_TABLE_F32) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_VALUE_TYPE, EF_OFF_VTYPE);
    }
    naxes = b[EF_OFF_NAXES];
    ndof = b[EF_OFF_NDOF];
    if (naxes != (kind == EF_TABLE_G1_CUBIC ? 2u : 4u)) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_SHAPE, EF_OFF_NAXES);
    }
    if (ndof != (kind == EF_TABLE_G1_CUBIC ? 2u : 4u)) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_SHAPE, EF_OFF_NDOF);
    }
    sym = tp_rd16(b + EF_OFF_SYMMETRY);
    if (sym > EF_SYM_G2_MIRROR || (sym == EF_SYM_G1_FOLD && kind != EF_TABLE_G1_CUBIC) ||
        (sym == EF_SYM_G2_MIRROR && kind != EF_TABLE_G2_QUINTIC)) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_SYMMETRY, EF_OFF_SYMMETRY);
    }
    if (tp_rd16(b + EF_OFF_FUNCTIONAL) != EF_FUNCTIONAL_CONSTANT_SPEED) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_FUNCTIONAL, EF_OFF_FUNCTIONAL);
    }
    if (tp_rd16(b + EF_OFF_QUAD) != EF_QUAD_GAUSS_LEGENDRE) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_FUNCTIONAL, EF_OFF_QUAD);
    }
    v.quad_nodes = tp_rd16(b + EF_OFF_QUAD_NODES);
    if (v.quad_nodes < 1u || v.quad_nodes > 64u) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_FUNCTIONAL, EF_OFF_QUAD_NODES);
    }

    product = 1;
    stride = 1;
    for (i = 0; i < EF_TABLE_MAX_AXES; i++) {
        if (i < naxes) {
            rc = tp_tbl_parse_axis(b, kind, sym, i, &v.axis[i], &off);
            if (rc != EF_OK) {
                return tp_tbl_fail(out, bad_offset, rc, off);
            }
            v.axis[i].stride = stride;
            product *= v.axis[i].nodes; /* <= 4096^4 = 2^48: no overflow in 64 bits */
            /* Strides only matter while product is within EF_TABLE_MAX_NODES, checked
             * below before the view is used; the cast keeps the arithmetic defined. */
            stride = (uint32_t)(product & 0xFFFFFFFFu);
        } else {
            rc = tp_tbl_unused_axis(b, i, &off);
            if (rc != EF_OK) {
                return tp_tbl_fail(out, bad_offset, rc, off);
            }
        }
    }
    nodes = tp_rd32(b + EF_OFF_NODES);
    if (product != (uint64_t)nodes) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_SHAPE, EF_OFF_NODES);
    }
    if (nodes > EF_TABLE_MAX_NODES) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_SIZE, EF_OFF_NODES);
    }
    rc = tp_tbl_parse_region(b, sym, &off);
    if (rc != EF_OK) {
        return tp_tbl_fail(out, bad_offset, rc, off);
    }
    rc = tp_tbl_parse_bounds(b, kind, &v, &off);
    if (rc != EF_OK) {
        return tp_tbl_fail(out, bad_offset, rc, off);
    }
    prov_len = tp_rd32(b + EF_OFF_PROV_LEN);
    if (prov_len > EF_TABLE_MAX_PROVENANCE) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_PROVENANCE, EF_OFF_PROV_LEN);
    }

    /* All terms are bounded (1 KiB provenance, 2^22 x 4 x 4 data), so 64-bit sums are
     * exact and the result fits in 32 bits once it has been compared with len. */
    prov_pad = (prov_len + 7u) & ~7u;
    data_off = (uint64_t)EF_TABLE_HEADER_SIZE + prov_pad;
    total = data_off + 4u * (uint64_t)nodes * ndof + 4u;
    if ((uint64_t)len < total) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_TRUNCATED, len);
    }
    if ((uint64_t)len > total) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_SIZE, (uint32_t)total);
    }
    crc_at = len - 4u;
    if (ef_crc32(0, b, crc_at) != tp_rd32(b + crc_at)) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_CRC, crc_at);
    }
    for (i = 0; i < prov_pad; i++) {
        const uint8_t c = b[EF_TABLE_HEADER_SIZE + i];
        const int ok = i < prov_len ? (c >= 0x20u && c <= 0x7Eu) : c == 0u;
        if (!ok) {
            return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_PROVENANCE, EF_TABLE_HEADER_SIZE + i);
        }
    }
    /* data_off is a multiple of 8 and blob 4-aligned, so the floats are aligned; going
     * through void* states that the alignment was checked. */
    v.data = (const float *)(const void *)(b + data_off);
    bad = tp_tbl_bad_value(v.data, nodes * ndof, kind, b);
    if (bad >= 0) {
        return tp_tbl_fail(out, bad_offset, EF_ERR_TBL_VALUE,
                           (uint32_t)(data_off + 4u * (uint64_t)bad));
    }

    v.kind = (uint16_t)kind;
    v.symmetry = (uint16_t)sym;
    v.naxes = (uint8_t)naxes;
    v.ndof = (uint8_t)ndof;
    v.nodes = nodes;
    v.provenance = (const char *)(b + EF_TABLE_HEADER_SIZE);
    v.provenance_len = prov_len;
    *out = v;
    return EF_OK;
}

/* Bound on |axis bound| for the float view: the parser's limit plus rounding slack. */
static int tp_tbl_check_axis(const ef_table_t *t, unsigned i)
{
    const ef_table_axis_t *ax = &t->axis[i];
    const double lim = tp_tbl_axis_limit(t->kind, i) + EF_TBL_CHECK_SLACK;
    double inv;

    if (!tp_finite32(ax->lo) || !tp_finite32(ax->hi) || !tp_finite32(ax->inv_step) ||
        !(ax->hi > ax->lo)) {
        return EF_ERR_TBL_AXIS;
    }
    if ((double)ax->lo < -lim || (double)ax->hi > lim) {
        return EF_ERR_TBL_AXIS;
    }
    if (ax->nodes < 2u || ax->nodes > EF_TABLE_MAX_AXIS_NODES) {
        return EF_ERR_TBL_AXIS;
    }
    /* A stale inv_step would make the lookup index past the last node. */
    inv = tp_tbl_inv_step(ax->nodes, ax->lo, ax->hi);
    if (!(tp_abs64((double)ax->inv_step - inv) <= EF_TBL_CHECK_INV_REL * inv)) {
        return EF_ERR_TBL_AXIS;
    }
    if ((ax->flags & ~EF_AXIS_PERIODIC) != 0u) {
        return EF_ERR_TBL_AXIS;
    }
    if ((ax->flags & EF_AXIS_PERIODIC) != 0u) {
        if (t->kind != EF_TABLE_G1_CUBIC || t->symmetry != EF_SYM_NONE) {
            return EF_ERR_TBL_AXIS;
        }
        if (tp_abs64(((double)ax->hi - (double)ax->lo) - EF_TBL_2PI) > EF_TBL_CHECK_SLACK) {
            return EF_ERR_TBL_AXIS;
        }
    }
    return EF_OK;
}

/* The same rules as the parser, restated on the float view (with rounding slack), for
 * tables compiled in as C where no file and no CRC exist. */
int ef_table_check(const ef_table_t *tbl)
{
    unsigned i, want;
    uint64_t product = 1;
    int rc;

    if (tbl == NULL || tbl->data == NULL ||
        (tbl->provenance == NULL && tbl->provenance_len != 0u)) {
        return EF_ERR_ARG;
    }
    if (tbl->kind != EF_TABLE_G1_CUBIC && tbl->kind != EF_TABLE_G2_QUINTIC) {
        return EF_ERR_TBL_KIND;
    }
    want = tbl->kind == EF_TABLE_G1_CUBIC ? 2u : 4u;
    if (tbl->naxes != want || tbl->ndof != want) {
        return EF_ERR_TBL_SHAPE;
    }
    if (tbl->symmetry > EF_SYM_G2_MIRROR ||
        (tbl->symmetry == EF_SYM_G1_FOLD && tbl->kind != EF_TABLE_G1_CUBIC) ||
        (tbl->symmetry == EF_SYM_G2_MIRROR && tbl->kind != EF_TABLE_G2_QUINTIC)) {
        return EF_ERR_TBL_SYMMETRY;
    }
    for (i = 0; i < EF_TABLE_MAX_AXES; i++) {
        const ef_table_axis_t *ax = &tbl->axis[i];
        if (i >= want) {
            if (ax->lo != 0.0f || ax->hi != 0.0f || ax->inv_step != 0.0f || ax->nodes != 0u ||
                ax->stride != 0u || ax->flags != 0u) {
                return EF_ERR_TBL_AXIS;
            }
            continue;
        }
        rc = tp_tbl_check_axis(tbl, i);
        if (rc != EF_OK) {
            return rc;
        }
        if ((uint64_t)ax->stride != product) {
            return EF_ERR_TBL_SHAPE;
        }
        product *= ax->nodes;
    }
    if (product != (uint64_t)tbl->nodes || tbl->nodes > EF_TABLE_MAX_NODES) {
        return EF_ERR_TBL_SHAPE;
    }
    if (tbl->symmetry == EF_SYM_G1_FOLD) {
        const float got[4] = {tbl->axis[0].lo, tbl->axis[0].hi, tbl->axis[1].lo, tbl->axis[1].hi};
        const double want_b[4] = {0.0, EF_TBL_PI / 2.0, 0.0, EF_TBL_PI};
        for (i = 0; i < 4u; i++) {
            if (tp_abs64((double)got[i] - want_b[i]) > EF_TBL_FOLD_TOL + EF_TBL_CHECK_SLACK) {
                return EF_ERR_TBL_SYMMETRY;
            }
        }
    } else if (tbl->symmetry == EF_SYM_G2_MIRROR && tbl->axis[0].lo != 0.0f) {
        return EF_ERR_TBL_SYMMETRY;
    }
    return EF_OK;
}
