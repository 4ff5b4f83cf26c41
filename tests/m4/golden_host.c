/* SPDX-License-Identifier: Apache-2.0 */
/* The golden cases on the host (golden.h): the same source as the M4 image's, printed on
 * stdout; tests/m4/golden_compare.sh compares the two line by line. */
#include <stdio.h>
#include "golden.h"

void ef_golden_puts(const char *s)
{
    fputs(s, stdout);
}

int main(void)
{
    int rc = ef_golden_run();
    fflush(stdout);
    return rc;
}
