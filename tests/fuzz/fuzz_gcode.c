/* SPDX-License-Identifier: Apache-2.0 */
/*
 * libFuzzer target for the G-code reader: every input must either be read to an end item
 * or be rejected with EF_ERR_GCODE and a "fuzz:line:col: " message; every item must have a
 * known kind, a line inside the input, finite positions within the coordinate limit, and
 * feeds that are positive on feed moves. Broken invariants abort (a libFuzzer crash).
 *
 * Built with -DEF_FUZZ_REPLAY_MAIN it is also a plain-C replay driver (gcode_fuzz_replay
 * DIR|FILE...): seeds named "ok-*" must read to the end, "bad-*" must be rejected; the
 * path corpus tests/data/gcode is replayed with it ("bad_*" rejected, the others accepted
 * or rejected without a crash; gcode_path_* checks their paths).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "evenfeed/host/program/ef_gcode.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Report and crash, so the input is saved as a reproducer. */
static void ef_fuzz_fail(const char *what, long a)
{
    fprintf(stderr, "gcode fuzz invariant broken: %s (%ld)\n", what, a);
    abort();
}

/* Position within the reader's documented limits (n axes). */
static void ef_fuzz_axes(const double *v, int n, const char *what)
{
    for (int k = 0; k < n; k++)
        if (!isfinite(v[k]) || fabs(v[k]) > EF_GCODE_MAX_COORD * (1 + 1e-12))
            ef_fuzz_fail(what, k);
}

static void ef_fuzz_vec(const double *v, const char *what)
{
    ef_fuzz_axes(v, 3, what);
}

/* Read the whole input; 0 when it read to an end item, else the error code. */
static int ef_fuzz_read1(ef_gcode_t *rp, const uint8_t *data, size_t size);

static int ef_fuzz_read(const uint8_t *data, size_t size)
{
    static ef_gcode_t r; /* large: keep it off the stack */
    int rc = ef_fuzz_read1(&r, data, size);
    ef_gcode_free(&r); /* the queue of a long expansion */
    return rc;
}

static int ef_fuzz_read1(ef_gcode_t *rp, const uint8_t *data, size_t size)
{
    ef_gcode_t *r = rp;
    ef_gcode_item_t it;
    ef_msg_t m = {{0}};
    size_t lines = 1;
    int rc;

    for (size_t k = 0; k < size; k++)
        lines += data[k] == '\n';
    if (ef_gcode_init(r, (const char *)data, size, "fuzz") != EF_OK)
        ef_fuzz_fail("init", 0);
    for (;;) {
        rc = ef_gcode_next(r, &it, &m);
        if (rc != EF_OK) {
            if (rc != EF_ERR_GCODE || strncmp(m.text, "fuzz:", 5) != 0)
                ef_fuzz_fail("bad error code or message", rc);
            if (ef_gcode_next(r, &it, &m) != rc) /* errors are sticky */
                ef_fuzz_fail("error not sticky", rc);
            return rc;
        }
        if (it.kind < EF_GC_RAPID || it.kind > EF_GC_NOTE)
            ef_fuzz_fail("unknown kind", it.kind);
        if (it.line < 1 || it.line > lines || it.col < 1)
            ef_fuzz_fail("line/col outside the input", (long)it.line);
        if (it.units != 20 && it.units != 21)
            ef_fuzz_fail("units", it.units);
        if (memchr(it.text, 0, sizeof it.text) == NULL)
            ef_fuzz_fail("text not terminated", 0);
        ef_fuzz_vec(it.start, "start");
        ef_fuzz_vec(it.end, "end");
        ef_fuzz_vec(it.centre, "centre");
        ef_fuzz_axes(it.astart, EF_GCODE_AUX, "astart");
        ef_fuzz_axes(it.aend, EF_GCODE_AUX, "aend");
        if ((it.kind == EF_GC_LINE || it.kind == EF_GC_ARC) &&
            !(it.feed > 0 && it.feed <= EF_GCODE_MAX_FEED))
            ef_fuzz_fail("feed", it.kind);
        if (it.kind == EF_GC_ARC &&
            (!(it.radius > 0) || !(it.radius_end > 0) || !isfinite(it.radius_end) ||
             fabs(it.radius_end - it.radius) > 100.0001 * EF_GCODE_ARC_ABS_TOL_IN ||
             !isfinite(it.sweep) || it.sweep == 0 || it.turns < 1 || it.dir * it.sweep < 0))
            ef_fuzz_fail("arc", it.turns);
        if (it.kind == EF_GC_END) {
            ef_gcode_item_t again;
            if (ef_gcode_next(r, &again, &m) != EF_OK || again.kind != EF_GC_END)
                ef_fuzz_fail("end not repeated", 0);
            return 0;
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    ef_fuzz_read(data, size);
    return 0;
}

#ifdef EF_FUZZ_REPLAY_MAIN
#define EF_REPLAY_SUFFIX ".ngc" /* the path corpus keeps its expected paths (.path) beside */
#include "replay.h"

/* Accepted when the reader reaches the end of the program without an error. */
static int replay_gcode(const uint8_t *buf, size_t len, char *why, size_t why_len)
{
    int rc = ef_fuzz_read(buf, len);
    if (rc != 0)
        snprintf(why, why_len, "error %d", rc);
    return rc != 0;
}

int main(int argc, char **argv)
{
    return ef_replay_main(argc, argv, replay_gcode);
}
#endif
