/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_err.h
 * @brief Error codes shared by every evenfeed layer.
 *
 * Convention: functions return `int`; 0 (::EF_OK) is success, a negative value is one of
 * the ::ef_err_t codes below. The firmware returns the bare code; host code returns the
 * same code and additionally fills a message buffer (see host headers). Positive values
 * are never used as errors.
 */
#ifndef EF_ERR_H
#define EF_ERR_H

#ifdef __cplusplus
extern "C" {
#endif

/** Error codes. Values are stable: they appear in logs and in the CLI's exit status. */
typedef enum {
    EF_OK = 0,              /**< success */
    EF_ERR_ARG = -1,        /**< NULL pointer or argument outside its documented range */
    EF_ERR_NONFINITE = -2,  /**< NaN or infinity in input data */
    EF_ERR_DEGENERATE = -3, /**< coincident endpoints: chord below ::EF_MIN_CHORD */
    EF_ERR_TANGENT = -4,    /**< tangent zero or not of unit length */
    EF_ERR_NORMAL = -5,     /**< curvature given with no normal, or normal not unit/perpendicular */
    EF_ERR_DOMAIN = -6,     /**< configuration outside the table domain (strict callers only) */
    EF_ERR_KIND = -7,       /**< table of the wrong kind for this call */
    EF_ERR_NOCONV = -8,     /**< optimizer did not converge (host) */
    EF_ERR_IO = -9,         /**< file or device I/O failed (host) */
    EF_ERR_NOMEM = -10,     /**< allocation failed (host only; firmware never allocates) */
    EF_ERR_GCODE = -11,     /**< malformed or unsupported G-code (host; message has line:col) */
    EF_ERR_REVERSAL = -12,  /**< a corner turns back on itself (near 180 degrees): no blend;
                                 the defined safe behaviour is an exact stop at the vertex */
    EF_ERR_FULL = -13,      /**< a fixed buffer (look-ahead window, queue) is full: pull or
                                 process first, then push the same item again */
    EF_ERR_AGAIN = -14,     /**< nothing to pull yet: push more input or finish the stream */
    EF_ERR_ARC = -15,       /**< arc data inconsistent: radii at start and end differ, zero
                                 radius, or axis not unit / not perpendicular */
    EF_ERR_FEED = -16,      /**< feed or a motion limit <= 0 or non-finite */
    EF_ERR_UNDERRUN = -17,  /**< the interpolator ran out of moves while moving */
    EF_ERR_STATE = -18,     /**< call not allowed in the object's current state (e.g. push
                                 after finish, or after a sticky error) */
    EF_ERR_CRC = -19,       /**< checksum mismatch in received data (segment slot, frame) */
    EF_ERR_TBL_TRUNCATED = -20,  /**< table blob shorter than its header says */
    EF_ERR_TBL_MAGIC = -21,      /**< not a table file (magic bytes) */
    EF_ERR_TBL_VERSION = -22,    /**< format version not supported */
    EF_ERR_TBL_HEADER = -23,     /**< header size or reserved fields invalid */
    EF_ERR_TBL_KIND = -24,       /**< unknown table kind */
    EF_ERR_TBL_VALUE_TYPE = -25, /**< unknown stored value type */
    EF_ERR_TBL_SHAPE = -26,      /**< axis or DOF count does not match the kind */
    EF_ERR_TBL_AXIS = -27,     /**< axis domain not finite/increasing, or node count out of range */
    EF_ERR_TBL_SYMMETRY = -28, /**< symmetry flags unknown or inconsistent with kind/axes */
    EF_ERR_TBL_FUNCTIONAL = -29, /**< unknown functional id or quadrature */
    EF_ERR_TBL_SIZE = -30,       /**< blob size does not match header (trailing bytes, too big) */
    EF_ERR_TBL_PROVENANCE = -31, /**< provenance string too long or not printable text */
    EF_ERR_TBL_CRC = -32,        /**< CRC-32 mismatch: corrupt data */
    EF_ERR_TBL_VALUE = -33,      /**< stored DOF value non-finite or outside its bounds */
    EF_ERR_SEQ = -40,            /**< segment sequence number out of order (a gap) */
    EF_ERR_DUP = -41,            /**< segment already accepted (a retried write): not queued again;
                                      callers treat it as success */
    EF_ERR_TIMEOUT = -42,        /**< no answer in time (host transports) */
    EF_ERR_PROTO = -43,          /**< malformed or unexpected reply, or an exception/abort from
                                      the other side (host transports; message names it) */
    EF_ERR_DRIVE = -44,          /**< the drive reports a fault, or restarted (message names it) */
    EF_ERR_DISCONNECT = -45,     /**< connection lost and could not be re-established */
    EF_ERR_BUS = -46,            /**< the field bus failed: CAN bus-off or error-passive, or the
                                      interface went down (message names it) */
    EF_ERR_HEARTBEAT = -47,      /**< a node's heartbeat stopped, or it never booted */
    EF_ERR_ESTOP = -48,          /**< e-stop or a drive alarm input stopped motion, or keeps
                                      it from starting (host machine I/O; message names it) */
} ef_err_t;

/**
 * @brief Short, static, human-readable name of an error code.
 * @param err a value returned by any evenfeed function.
 * @return a constant string; "unknown error" for values not in ::ef_err_t. Never NULL.
 */
const char *ef_err_str(int err);

#ifdef __cplusplus
}
#endif

#endif /* EF_ERR_H */
