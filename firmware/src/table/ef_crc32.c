/* SPDX-License-Identifier: Apache-2.0 */
/* CRC-32 (IEEE 802.3, reflected, zlib-compatible) for table blobs; freestanding. */
#include <stdint.h>
#include "evenfeed/table/ef_table.h"

/* Reflected polynomial 0xEDB88320 applied to every 4-bit value: 64 bytes of flash instead
 * of the 1 KiB byte table, at two lookups per byte, which is plenty for a once-per-boot
 * table check. */
static const uint32_t ef_crc32_nibble[16] = {
    0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu, 0x76DC4190u, 0x6B6B51F4u,
    0x4DB26158u, 0x5005713Cu, 0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu,
    0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu,
};

/* Continue a zlib-style CRC: the pre/post inversion lets callers chain calls from 0. */
uint32_t ef_crc32(uint32_t crc, const void *buf, uint32_t len)
{
    const uint8_t *p = (const uint8_t *)buf;
    uint32_t i;

    if (p == 0) {
        return crc;
    }
    crc = ~crc;
    for (i = 0; i < len; i++) {
        crc ^= p[i];
        crc = (crc >> 4) ^ ef_crc32_nibble[crc & 0x0Fu];
        crc = (crc >> 4) ^ ef_crc32_nibble[crc & 0x0Fu];
    }
    return ~crc;
}
