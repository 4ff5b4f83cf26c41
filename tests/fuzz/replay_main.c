/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Plain-C driver for the fuzz target: runs every file named on the command line (or found
 * in a named directory) through LLVMFuzzerTestOneInput, so the seed corpus and saved
 * reproducers run as an ordinary test under gcc and the sanitizer build, no libFuzzer
 * needed. Seeds named "ok-*" must parse and "bad-*" must be rejected.
 *
 * Usage: tfile_fuzz_replay DIR|FILE...
 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "evenfeed/core/ef_err.h"
#include "evenfeed/table/ef_table.h"
#include "fuzz_table_parse.h"
#include "replay.h"

/* Accepted when the table parser accepts it; the fuzz entry point runs first and aborts
 * on a broken invariant. */
static int replay_table(const uint8_t *buf, size_t len, char *why, size_t why_len)
{
    ef_table_t v;
    uint32_t off = 0;
    LLVMFuzzerTestOneInput(buf, len);
    int rc = ef_table_parse(buf, (uint32_t)len, &v, &off);
    if (rc != EF_OK)
        snprintf(why, why_len, "%s at offset %u", ef_err_str(rc), (unsigned)off);
    return rc != EF_OK;
}

int main(int argc, char **argv)
{
    return ef_replay_main(argc, argv, replay_table);
}
