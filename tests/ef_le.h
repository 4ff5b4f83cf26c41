/* SPDX-License-Identifier: Apache-2.0 */
/* Little-endian stores and loads for tests that craft or corrupt file images byte by byte,
 * independently of the library's own writer (so a writer bug cannot hide in both). */
#ifndef EF_LE_H
#define EF_LE_H

#include <stdint.h>
#include <string.h>

static inline void put16(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}

static inline void put32(uint8_t *p, uint32_t v)
{
    put16(p, v & 0xFFFFu);
    put16(p + 2, v >> 16);
}

/* f64 through its bit pattern. */
static inline void putf64(uint8_t *p, double d)
{
    uint64_t u;
    memcpy(&u, &d, sizeof u);
    put32(p, (uint32_t)u);
    put32(p + 4, (uint32_t)(u >> 32));
}

/* float32 through its bit pattern. */
static inline void putf32(uint8_t *p, float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    put32(p, u);
}

static inline uint32_t get32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

#endif /* EF_LE_H */
