/* SPDX-License-Identifier: Apache-2.0 */
/* Little-endian stores and loads shared by the host's file writers and readers (table
 * files, shards, journals): files are the same bytes on any host. Internal header. */
#ifndef EF_LE_INT_H
#define EF_LE_INT_H

#include <stdint.h>
#include <string.h>

/* 16-bit store. */
static inline void ef_le_put16(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}

/* 32-bit store. */
static inline void ef_le_put32(uint8_t *p, uint32_t v)
{
    ef_le_put16(p, v & 0xFFFFu);
    ef_le_put16(p + 2, v >> 16);
}

/* 16-bit load. */
static inline uint32_t ef_le_get16(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8);
}

/* 32-bit load. */
static inline uint32_t ef_le_get32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

/* f64 through its bit pattern, so every double (and -0) survives exactly. */
static inline void ef_le_putf64(uint8_t *p, double d)
{
    uint64_t u;
    memcpy(&u, &d, sizeof u);
    ef_le_put32(p, (uint32_t)u);
    ef_le_put32(p + 4, (uint32_t)(u >> 32));
}

/* f64 load. */
static inline double ef_le_getf64(const uint8_t *p)
{
    uint64_t u = (uint64_t)ef_le_get32(p) | ((uint64_t)ef_le_get32(p + 4) << 32);
    double d;
    memcpy(&d, &u, sizeof d);
    return d;
}

#endif /* EF_LE_INT_H */
