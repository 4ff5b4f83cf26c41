/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_host.h
 * @brief Host-side error convention: the firmware's ::ef_err_t codes plus a message.
 *
 * Every host function that can fail returns an ef_err_t code and, when given a non-NULL
 * ::ef_msg_t, writes one line saying what failed and where (file, line, field).
 */
#ifndef EF_HOST_H
#define EF_HOST_H

#include "evenfeed/core/ef_err.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Message buffer filled by failing host calls. */
typedef struct {
    char text[512];
} ef_msg_t;

/**
 * @brief Format a message into m (if not NULL) and return code, so callers can write
 * `return ef_fail(m, EF_ERR_IO, "open %s: %s", path, strerror(errno));`.
 */
int ef_fail(ef_msg_t *m, int code, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

#ifdef __cplusplus
}
#endif

#endif /* EF_HOST_H */
