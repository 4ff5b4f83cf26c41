/* SPDX-License-Identifier: Apache-2.0 */
/* CAN bus-time arithmetic (ef_can.h); freestanding. */
#include <stdint.h>
#include "evenfeed/hal/ef_can.h"

/* Bits one frame occupies on the bus, worst-case stuffing included (formula in ef_can.h). */
uint32_t ef_can_frame_bits(const ef_can_frame_t *f)
{
    uint32_t dlc, fixed, stuffable;

    if (f == 0) {
        return 0u;
    }
    dlc = f->dlc > EF_CAN_MAX_DLC ? (uint32_t)EF_CAN_MAX_DLC : (uint32_t)f->dlc;
    if (f->flags & EF_CAN_FLAG_EFF) {
        fixed = 67u;
        stuffable = 54u;
    } else {
        fixed = 47u;
        stuffable = 34u;
    }
    return fixed + 8u * dlc + (stuffable + 8u * dlc - 1u) / 4u;
}
