/* SPDX-License-Identifier: Apache-2.0 */
/* Host error messages. */
#include <stdarg.h>
#include <stdio.h>
#include "evenfeed/host/core/ef_host.h"

/* Format the message (when asked for) and hand the code back to the caller. */
int ef_fail(ef_msg_t *m, int code, const char *fmt, ...)
{
    if (m) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(m->text, sizeof m->text, fmt, ap);
        va_end(ap);
    }
    return code;
}
