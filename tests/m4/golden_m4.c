/* SPDX-License-Identifier: Apache-2.0 */
/* The golden cases on the Cortex-M4F (golden.h): the semihosting console, main's return value
 * is the image's exit status. */
#include "ef_m4.h"
#include "golden.h"

void ef_golden_puts(const char *s)
{
    ef_m4_puts(s);
}

int main(void)
{
    ef_m4_puts("m4_golden: start\n");
    int rc = ef_golden_run();
    ef_m4_puts(rc == 0 ? "m4_golden: done\n" : "m4_golden: FAILED\n");
    return rc;
}
