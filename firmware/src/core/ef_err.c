/* SPDX-License-Identifier: Apache-2.0 */
/* Error code names. */
#include "evenfeed/core/ef_err.h"

/* Map a code to a fixed string; unknown codes get a generic one. */
const char *ef_err_str(int err)
{
    switch (err) {
    case EF_OK:
        return "ok";
    case EF_ERR_ARG:
        return "invalid argument";
    case EF_ERR_NONFINITE:
        return "NaN or infinite value in input";
    case EF_ERR_DEGENERATE:
        return "coincident endpoints (zero-length segment)";
    case EF_ERR_TANGENT:
        return "tangent is zero or not of unit length";
    case EF_ERR_NORMAL:
        return "curvature without a unit normal perpendicular to the tangent";
    case EF_ERR_DOMAIN:
        return "configuration outside the table domain";
    case EF_ERR_KIND:
        return "table of the wrong kind";
    case EF_ERR_NOCONV:
        return "optimizer did not converge";
    case EF_ERR_IO:
        return "I/O error";
    case EF_ERR_NOMEM:
        return "out of memory";
    case EF_ERR_GCODE:
        return "malformed or unsupported G-code";
    case EF_ERR_REVERSAL:
        return "corner reverses the path: exact stop at the vertex";
    case EF_ERR_FULL:
        return "buffer full: pull or process first";
    case EF_ERR_AGAIN:
        return "nothing to pull yet";
    case EF_ERR_ARC:
        return "inconsistent arc (radius, centre or axis)";
    case EF_ERR_FEED:
        return "feed or motion limit not positive and finite";
    case EF_ERR_UNDERRUN:
        return "interpolator ran out of moves while moving";
    case EF_ERR_STATE:
        return "call not allowed in the current state";
    case EF_ERR_CRC:
        return "checksum mismatch";
    case EF_ERR_SEQ:
        return "segment sequence number out of order";
    case EF_ERR_DUP:
        return "segment already accepted (duplicate)";
    case EF_ERR_TIMEOUT:
        return "timed out";
    case EF_ERR_PROTO:
        return "protocol error or exception reply";
    case EF_ERR_DRIVE:
        return "drive fault";
    case EF_ERR_DISCONNECT:
        return "connection lost";
    case EF_ERR_BUS:
        return "bus error (bus-off, error-passive or interface down)";
    case EF_ERR_HEARTBEAT:
        return "heartbeat lost or node never booted";
    case EF_ERR_ESTOP:
        return "e-stop or drive alarm";
    case EF_ERR_TBL_TRUNCATED:
        return "table truncated";
    case EF_ERR_TBL_MAGIC:
        return "not an evenfeed table (bad magic)";
    case EF_ERR_TBL_VERSION:
        return "unsupported table format version";
    case EF_ERR_TBL_HEADER:
        return "invalid table header size or reserved field";
    case EF_ERR_TBL_KIND:
        return "unknown table kind";
    case EF_ERR_TBL_VALUE_TYPE:
        return "unknown table value type";
    case EF_ERR_TBL_SHAPE:
        return "table axes/DOF/node counts inconsistent with its kind";
    case EF_ERR_TBL_AXIS:
        return "invalid table axis";
    case EF_ERR_TBL_SYMMETRY:
        return "invalid table symmetry";
    case EF_ERR_TBL_FUNCTIONAL:
        return "unknown functional or quadrature";
    case EF_ERR_TBL_SIZE:
        return "table size does not match its header";
    case EF_ERR_TBL_PROVENANCE:
        return "invalid provenance string";
    case EF_ERR_TBL_CRC:
        return "table CRC mismatch (corrupt)";
    case EF_ERR_TBL_VALUE:
        return "table value non-finite or out of bounds";
    default:
        return "unknown error";
    }
}
