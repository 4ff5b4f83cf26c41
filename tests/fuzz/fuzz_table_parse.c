/* SPDX-License-Identifier: Apache-2.0 */
/*
 * libFuzzer target for the table parser: every input must either be rejected cleanly
 * (known code, offset inside the input, view zeroed) or yield a view that ef_table_check()
 * accepts, that points inside the input, and whose lookups return finite DOFs within the
 * table's bounds. Broken invariants abort, which libFuzzer reports as a crash.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "evenfeed/core/ef_err.h"
#include "evenfeed/table/ef_table.h"
#include "fuzz_table_parse.h"

/* Tolerance on lookup results, relative to the largest bound. Multilinear interpolation in
 * float (a + f (b - a), or weighted sums) is accurate to a few ulps of the largest value
 * involved, not of the result: a blend of 2.5 and 1e-38 at f = 1 can give 0. So results
 * are checked against the bounds widened by 1e-5 of the largest magnitude; x1 must also
 * never be negative, which interpolation of positive values guarantees exactly. */
#define EF_FUZZ_REL 1e-5

/* Report and crash, so the input is saved as a reproducer. */
static void ef_fuzz_fail(const char *what, long a, long b)
{
    fprintf(stderr, "table fuzz invariant broken: %s (%ld, %ld)\n", what, a, b);
    abort();
}

/* Finite without libm, as in the firmware. */
static int ef_fuzz_finite(float x)
{
    return x == x && x - x == 0.0f;
}

/* A failed parse leaves an all-zero view: nothing in it may point into rejected bytes. */
static void ef_fuzz_expect_zero(const ef_table_t *v)
{
    static const ef_table_t zero;
    int i;
    if (v->data != NULL || v->provenance != NULL || v->nodes != 0 || v->kind != 0 ||
        v->provenance_len != 0 || v->naxes != 0 || v->ndof != 0) {
        ef_fuzz_fail("view not zeroed on failure", v->kind, (long)v->nodes);
    }
    for (i = 0; i < EF_TABLE_MAX_AXES; i++) {
        if (memcmp(&v->axis[i], &zero.axis[i], sizeof zero.axis[i]) != 0) {
            ef_fuzz_fail("axis not zeroed on failure", i, 0);
        }
    }
}

/* Interpolated DOFs are convex combinations of stored values, so they obey the same box,
 * up to interpolation rounding. */
static void ef_fuzz_check_dofs(const ef_table_t *t, const float *dof, unsigned n, unsigned p)
{
    const double x1_tol = (double)t->x1_max * EF_FUZZ_REL;
    const double x1_lo = (double)t->x1_min * (1.0 - 1e-6) - x1_tol;
    const double x1_hi = (double)t->x1_max * (1.0 + 1e-6) + x1_tol;
    const double x2_hi = (double)t->x2_max * (1.0 + 1e-6 + EF_FUZZ_REL);
    unsigned k;

    for (k = 0; k < n; k++) {
        const double x = (double)dof[k];
        if (!ef_fuzz_finite(dof[k])) {
            ef_fuzz_fail("lookup returned a non-finite DOF", (long)p, (long)k);
        }
        if (n == 4 && (k & 1u)) {
            if (x > x2_hi || x < -x2_hi) {
                ef_fuzz_fail("lookup x2 outside the table's bound", (long)p, (long)k);
            }
        } else if (x < x1_lo || x > x1_hi || x < 0.0) {
            ef_fuzz_fail("lookup x1 outside the table's bounds", (long)p, (long)k);
        }
    }
}

/* Lookups at fixed coordinates: inside, on edges, far outside (clamp), and huge. */
static void ef_fuzz_lookups(const ef_table_t *t)
{
    static const float g1[][2] = {
        {0.0f, 0.0f},      {0.5f, -1.0f}, {1.5707964f, -1.5707964f},
        {3.0f, 3.0f},      {-6.0f, 2.0f}, {6.2831855f, -0.0f},
        {100.0f, -100.0f}, {1e6f, -1e6f}, {3e38f, -3e38f},
    };
    static const float g2[][4] = {
        {0.0f, 0.0f, 0.0f, 0.0f},     {0.3f, -0.2f, 0.5f, -1.0f},
        {-1.0f, 1.0f, 0.0f, 0.0f},    {-3.1f, 3.1f, 999.0f, -999.0f},
        {10.0f, -10.0f, 5e3f, -5e3f}, {-3e38f, 3e38f, -3e38f, 3e38f},
    };
    float dof[4], c[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    uint32_t flags;
    unsigned i;
    int rc;

    if (t->kind == EF_TABLE_G1_CUBIC) {
        for (i = 0; i < sizeof g1 / sizeof g1[0]; i++) {
            flags = 0xFFFFFFFFu;
            rc = ef_table_lookup_g1(t, g1[i][0], g1[i][1], dof, &flags);
            if (rc != EF_OK || (flags & ~3u) != 0u) {
                ef_fuzz_fail("G1 lookup", rc, (long)flags);
            }
            ef_fuzz_check_dofs(t, dof, 2, i);
        }
        rc = ef_table_lookup_g2(t, c, dof, NULL);
        if (rc != EF_ERR_KIND) {
            ef_fuzz_fail("G2 lookup on a G1 table", rc, 0);
        }
    } else {
        for (i = 0; i < sizeof g2 / sizeof g2[0]; i++) {
            flags = 0xFFFFFFFFu;
            rc = ef_table_lookup_g2(t, g2[i], dof, &flags);
            if (rc != EF_OK || (flags & ~15u) != 0u) {
                ef_fuzz_fail("G2 lookup", rc, (long)flags);
            }
            ef_fuzz_check_dofs(t, dof, 4, i);
        }
        rc = ef_table_lookup_g1(t, 0.0f, 0.0f, dof, NULL);
        if (rc != EF_ERR_KIND) {
            ef_fuzz_fail("G1 lookup on a G2 table", rc, 0);
        }
    }
}

/* Parse one buffer and check every invariant of the result. */
static void ef_fuzz_one(uint8_t *buf, size_t size)
{
    ef_table_t v;
    uint32_t off = 0xDEADBEEFu;
    int rc = ef_table_parse(buf, (uint32_t)size, &v, &off);

    if (rc != EF_OK) {
        if (rc > EF_ERR_TBL_TRUNCATED || rc < EF_ERR_TBL_VALUE) {
            ef_fuzz_fail("unexpected error code", rc, 0);
        }
        if (off > size) {
            ef_fuzz_fail("bad_offset past the input", (long)off, (long)size);
        }
        ef_fuzz_expect_zero(&v);
        return;
    }
    {
        const uint8_t *d = (const uint8_t *)v.data;
        const uint64_t bytes = 4u * (uint64_t)v.nodes * v.ndof;
        if (off != 0) {
            ef_fuzz_fail("bad_offset set on success", (long)off, 0);
        }
        rc = ef_table_check(&v);
        if (rc != EF_OK) {
            ef_fuzz_fail("parsed view fails ef_table_check", rc, 0);
        }
        if (d < buf + EF_TABLE_HEADER_SIZE || (uint64_t)(d - buf) + bytes + 4u != size ||
            (const uint8_t *)v.provenance != buf + EF_TABLE_HEADER_SIZE) {
            ef_fuzz_fail("view does not point into the blob", (long)(d - buf), (long)size);
        }
    }
    ef_fuzz_lookups(&v);
    /* CRC-32 catches every single-bit error: one flip anywhere must be rejected. */
    {
        const size_t bit = (size_t)((size * 2654435761u) % (size * 8u));
        buf[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
        if (ef_table_parse(buf, (uint32_t)size, &v, NULL) == EF_OK) {
            ef_fuzz_fail("single bit flip accepted", (long)bit, 0);
        }
        buf[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
    }
}

/* The input runs twice: as given (random bytes almost never carry a valid CRC, so this
 * exercises everything up to the CRC check), then with the trailing CRC recomputed, so the
 * fuzzer also reaches the provenance and value checks and the lookups. The blob is copied
 * into an exact-size heap buffer: malloc gives the alignment the parser requires, and ASan
 * flags any read past the input's end. */
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    uint8_t *buf;
    ef_table_t v;

    if (size > 0xFFFFFFFFu) {
        return 0;
    }
    buf = malloc(size ? size : 1u);
    if (buf == NULL) {
        return 0;
    }
    if (size) {
        memcpy(buf, data, size);
    }
    ef_fuzz_one(buf, size);
    if (size >= 4u) {
        const uint32_t crc = ef_crc32(0, buf, (uint32_t)size - 4u);
        uint8_t *p = buf + size - 4u;
        const uint32_t old =
            (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
        if (old != crc) {
            p[0] = (uint8_t)crc;
            p[1] = (uint8_t)(crc >> 8);
            p[2] = (uint8_t)(crc >> 16);
            p[3] = (uint8_t)(crc >> 24);
            ef_fuzz_one(buf, size);
        }
    }
    /* A misaligned blob is refused before any byte is read. */
    if (size > 1 && ef_table_parse(buf + 1, (uint32_t)size - 1u, &v, NULL) != EF_ERR_ARG) {
        ef_fuzz_fail("misaligned blob not refused", 0, 0);
    }
    free(buf);
    return 0;
}
