/* SPDX-License-Identifier: Apache-2.0 */
/* Tests of the G-code reader (host/lib/program/ef_gcode.c, docs/gcode.md). */
#include <string.h>
#include <unistd.h>
#include "ef_test.h"
#include "evenfeed/host/program/ef_gcode.h"

#define MAXI 256

static ef_gcode_t R; /* about 50 kB: not on the stack */
static ef_gcode_item_t I[MAXI];
static ef_msg_t M;

static int EOT_NOTE; /* the last rd() saw the note of a program without M2/M30/% */

/* Read src to its end item; the item count, or the error code (message in M). The note of a
 * program that ends with its text is not counted (EOT_NOTE says whether it came). */
static int rd(const char *src)
{
    ef_gcode_item_t it;
    int n = 0;
    memset(&M, 0, sizeof M);
    EOT_NOTE = 0;
    if (R.queue)
        ef_gcode_free(&R);
    ef_gcode_init(&R, src, strlen(src), "t.ngc");
    for (;;) {
        int rc = ef_gcode_next(&R, &it, &M);
        if (rc)
            return rc;
        if (it.kind == EF_GC_NOTE && !strncmp(it.text, "no M2, M30", 10)) {
            EOT_NOTE = 1;
            continue;
        }
        if (n < MAXI)
            I[n++] = it;
        if (it.kind == EF_GC_END)
            return n;
    }
}

/* Expect an error whose message is exactly want. */
#define EXPECT_ERR(src, want)                                                                      \
    do {                                                                                           \
        int rc_ = rd(src);                                                                         \
        EF_CHECK_EQ(rc_, EF_ERR_GCODE);                                                            \
        if (strcmp(M.text, want)) {                                                                \
            ef_t_fail++;                                                                           \
            fprintf(stderr, "%s:%d: message '%s', want '%s'\n", __FILE__, __LINE__, M.text, want); \
        } else {                                                                                   \
            ef_t_pass++;                                                                           \
        }                                                                                          \
    } while (0)

/* Expect an error at a position, with a substring in the message. */
#define EXPECT_ERR_AT(src, pos, part)                                                              \
    do {                                                                                           \
        int rc_ = rd(src);                                                                         \
        EF_CHECK_EQ(rc_, EF_ERR_GCODE);                                                            \
        if (strncmp(M.text, "t.ngc:" pos ": ", strlen("t.ngc:" pos ": ")) ||                       \
            !strstr(M.text, part)) {                                                               \
            ef_t_fail++;                                                                           \
            fprintf(stderr, "%s:%d: message '%s', want t.ngc:%s: ...%s...\n", __FILE__, __LINE__,  \
                    M.text, pos, part);                                                            \
        } else {                                                                                   \
            ef_t_pass++;                                                                           \
        }                                                                                          \
    } while (0)

/* Value of X after "G0 X<expr>": evaluates one expression through the reader. */
static double xval(const char *expr)
{
    char src[512];
    snprintf(src, sizeof src, "G0 X%s\n", expr);
    int n = rd(src);
    if (n < 2 || I[0].kind != EF_GC_RAPID) {
        fprintf(stderr, "expression %s failed: %s\n", expr, M.text);
        return NAN;
    }
    return I[0].end[0];
}

/* Lines, rapids, modal carry-over, feeds, the origin start, end items. */
static void test_basic(void)
{
    int n = rd("G0 X10 Y5\nG1 Z-1 F300\nX20\nY15 F600\nG0 Z5\nM2\nG0 X99\n");
    EF_CHECK_EQ(n, 6);
    EF_CHECK_EQ(EOT_NOTE, 0);
    EF_CHECK_EQ(I[0].kind, EF_GC_RAPID);
    EF_CHECK_NEAR(I[0].start[0], 0, 0);
    EF_CHECK_NEAR(I[0].end[0], 10, 0);
    EF_CHECK_NEAR(I[0].end[1], 5, 0);
    EF_CHECK_EQ(I[0].line, 1);
    EF_CHECK_EQ(I[0].col, 1);
    EF_CHECK_EQ(I[1].kind, EF_GC_LINE);
    EF_CHECK_NEAR(I[1].feed, 300, 0);
    EF_CHECK_EQ(I[2].kind, EF_GC_LINE); /* G1 carried over */
    EF_CHECK_NEAR(I[2].start[2], -1, 0);
    EF_CHECK_NEAR(I[2].end[0], 20, 0);
    EF_CHECK_NEAR(I[2].feed, 300, 0); /* F carried over */
    EF_CHECK_EQ(I[2].col, 1);
    EF_CHECK_NEAR(I[3].feed, 600, 0);
    EF_CHECK_EQ(I[4].kind, EF_GC_RAPID);
    EF_CHECK_EQ(I[5].kind, EF_GC_END);
    EF_CHECK(!strcmp(I[5].text, "M2"));
    EF_CHECK_EQ(I[5].line, 6);
    /* after the end, END again; text after M2 is never read */
    ef_gcode_item_t it;
    EF_CHECK_EQ(ef_gcode_next(&R, &it, &M), EF_OK);
    EF_CHECK_EQ(it.kind, EF_GC_END);
    n = rd("G0 X1");
    EF_CHECK_EQ(n, 2);
    EF_CHECK_EQ(EOT_NOTE, 1); /* no M2/M30/%: read to the end of the text, with a note */
    EF_CHECK(!strcmp(I[1].text, "end of text"));
    EF_CHECK_EQ(rd(""), 1);
    n = rd("%\nG0 X1\n%\nG0 X2\n");
    EF_CHECK_EQ(n, 2);
    EF_CHECK(!strcmp(I[1].text, "%"));
    EF_CHECK_EQ(I[1].line, 3);
    n = rd("G0 X1\nM30\n");
    EF_CHECK(!strcmp(I[n - 1].text, "M30"));
}

/* Comments, line numbers, case, spaces inside numbers, block delete. */
static void test_lexical(void)
{
    int n = rd("(header) ; more\nn10 g0 x 1 0 (mid) y2 ;tail\n/G0 X3\n\r\n  \t\nN20 G0 X4\n");
    EF_CHECK_EQ(n, 5);
    EF_CHECK_NEAR(I[0].end[0], 10, 0);
    EF_CHECK_NEAR(I[0].end[1], 2, 0);
    EF_CHECK_EQ(I[0].line, 2);
    EF_CHECK_EQ(I[0].col, 5);
    EF_CHECK_EQ(I[1].kind, EF_GC_IGNORED); /* '/' reported once, the line is still read */
    EF_CHECK_EQ(I[2].kind, EF_GC_RAPID);
    EF_CHECK_NEAR(I[2].end[0], 3, 0);
    EF_CHECK_NEAR(I[3].end[0], 4, 0);
    EF_CHECK_EQ(I[3].line, 6);
}

/* Zero-length moves are a defined item, not dropped. */
static void test_zero(void)
{
    int n = rd("G1 X1 F100\nX1\nG0 X1 Y0\nX2\n");
    EF_CHECK_EQ(n, 5);
    EF_CHECK_EQ(I[1].kind, EF_GC_ZERO_MOVE);
    EF_CHECK(!strcmp(I[1].text, "G1"));
    EF_CHECK_EQ(I[2].kind, EF_GC_ZERO_MOVE);
    EF_CHECK(!strcmp(I[2].text, "G0"));
    EF_CHECK_NEAR(I[3].start[0], 1, 0);
}

/* G20 inches converted to mm, units recorded, feed converted; G91 incremental. */
static void test_units_incremental(void)
{
    int n = rd("G20 G0 X1 Y2\nG1 X2 F10\nG21 X3\nG91 X1 Y-1\nG20 X1\nG90 G21 G0 X0 Y0 Z0\n");
    EF_CHECK_EQ(n, 7);
    EF_CHECK_NEAR(I[0].end[0], 25.4, 1e-12);
    EF_CHECK_NEAR(I[0].end[1], 50.8, 1e-12);
    EF_CHECK_EQ(I[0].units, 20);
    EF_CHECK_NEAR(I[1].feed, 254, 1e-9);
    EF_CHECK_NEAR(I[2].end[0], 3, 0);
    EF_CHECK_EQ(I[2].units, 21);
    EF_CHECK_NEAR(I[2].feed, 254, 1e-9); /* the feed keeps its physical value */
    EF_CHECK_NEAR(I[3].end[0], 4, 1e-12);
    EF_CHECK_NEAR(I[3].end[1], 50.8 - 1, 1e-12);
    EF_CHECK_NEAR(I[4].end[0], 4 + 25.4, 1e-12);
    EF_CHECK_NEAR(I[5].end[0], 0, 0);
}

/* IJK arcs in the three planes, G90.1 centres, full circles, turns, helix. */
static void test_arcs(void)
{
    int n = rd("G0 X10 Y0\nG3 X0 Y10 I-10 J0 F100\nG2 X10 Y0 I0 J-10\n");
    EF_CHECK_EQ(n, 4);
    EF_CHECK_EQ(I[1].kind, EF_GC_ARC);
    EF_CHECK_EQ(I[1].dir, 1);
    EF_CHECK_EQ(I[1].plane, 17);
    EF_CHECK_NEAR(I[1].centre[0], 0, 0);
    EF_CHECK_NEAR(I[1].radius, 10, 1e-12);
    EF_CHECK_NEAR(I[1].sweep, M_PI / 2, 1e-12);
    EF_CHECK_NEAR(I[1].feed, 100, 0);
    EF_CHECK_EQ(I[2].dir, -1);
    EF_CHECK_NEAR(I[2].sweep, -M_PI / 2, 1e-12);
    /* G18: ZX plane, offsets K (Z) and I (X), normal +Y */
    n = rd("G18 G0 X0 Z10\nG3 X10 Z0 I0 K-10 F100\n");
    EF_CHECK_EQ(I[1].plane, 18);
    EF_CHECK_NEAR(I[1].centre[0], 0, 0);
    EF_CHECK_NEAR(I[1].centre[2], 0, 0);
    EF_CHECK_NEAR(I[1].sweep, M_PI / 2, 1e-12); /* Z axis to X axis is CCW about +Y */
    /* G19: YZ plane, offsets J (Y) and K (Z), normal +X */
    n = rd("G19 G0 Y10 Z0\nG3 Y0 Z10 J-10 K0 F100\n");
    EF_CHECK_EQ(I[1].plane, 19);
    EF_CHECK_NEAR(I[1].sweep, M_PI / 2, 1e-12);
    EF_CHECK_NEAR(I[1].centre[1], 0, 0);
    /* G90.1: absolute centres */
    n = rd("G0 X10 Y10\nG90.1 G2 X20 Y20 I20 J10 F50\n");
    EF_CHECK_NEAR(I[1].centre[0], 20, 0);
    EF_CHECK_NEAR(I[1].centre[1], 10, 0);
    EF_CHECK_NEAR(I[1].sweep, -M_PI / 2, 1e-12);
    /* full circle, three turns as a helix */
    n = rd("G0 X5\nG2 X5 Y0 Z-3 I-5 J0 P3 F100\nG3 X5 I-5\n");
    EF_CHECK_EQ(n, 4);
    EF_CHECK_NEAR(I[1].sweep, -6 * M_PI, 1e-12);
    EF_CHECK_EQ(I[1].turns, 3);
    EF_CHECK_NEAR(I[1].end[2], -3, 0);
    EF_CHECK_NEAR(I[1].centre[2], 0, 0);
    EF_CHECK_NEAR(I[2].sweep, 2 * M_PI, 1e-12);
    /* radius within tolerance: accepted as given */
    n = rd("G0 X10\nG3 X-10.0015 I-10 F100\n");
    EF_CHECK_EQ(n, 3);
    EF_CHECK_NEAR(I[1].sweep, M_PI, 1e-3);
    /* relative tolerance for big arcs: 0.1% of 1000 mm = 1 mm */
    n = rd("G0 X1000\nG3 X-1000.9 I-1000 F100\n");
    EF_CHECK_EQ(n, 3);
}

/* R-form arcs: both directions, both signs (R < 0 takes the long way). */
static void test_r_form(void)
{
    rd("G0 X0 Y10\nG2 X10 Y0 R10 F100\n");
    EF_CHECK_NEAR(I[1].centre[0], 0, 1e-12);
    EF_CHECK_NEAR(I[1].centre[1], 0, 1e-12);
    EF_CHECK_NEAR(I[1].sweep, -M_PI / 2, 1e-12);
    rd("G0 X0 Y10\nG2 X10 Y0 R-10 F100\n");
    EF_CHECK_NEAR(I[1].centre[0], 10, 1e-12);
    EF_CHECK_NEAR(I[1].centre[1], 10, 1e-12);
    EF_CHECK_NEAR(I[1].sweep, -1.5 * M_PI, 1e-12);
    rd("G0 X10 Y0\nG3 X0 Y10 R10 F100\n");
    EF_CHECK_NEAR(I[1].centre[0], 0, 1e-12);
    EF_CHECK_NEAR(I[1].centre[1], 0, 1e-12);
    EF_CHECK_NEAR(I[1].sweep, M_PI / 2, 1e-12);
    rd("G0 X10 Y0\nG3 X0 Y10 R-10 F100\n");
    EF_CHECK_NEAR(I[1].centre[0], 10, 1e-12);
    EF_CHECK_NEAR(I[1].centre[1], 10, 1e-12);
    EF_CHECK_NEAR(I[1].sweep, 1.5 * M_PI, 1e-12);
    EF_CHECK_NEAR(I[1].radius, 10, 1e-12);
    /* half circle: R equal to half the chord (within tolerance) */
    int n = rd("G2 X10 R5.001 F100\n");
    EF_CHECK_EQ(n, 2);
    EF_CHECK_NEAR(fabs(I[0].sweep), M_PI, 0.05); /* h = 0.1: 0.04 rad short of pi */
}

/* Parameters and expressions. */
static void test_expressions(void)
{
    EF_CHECK_NEAR(xval("[1+2*3]"), 7, 1e-12);
    EF_CHECK_NEAR(xval("[[1+2]*3]"), 9, 1e-12);
    EF_CHECK_NEAR(xval("[2**3**2]"), 64, 1e-12); /* left-associative */
    EF_CHECK_NEAR(xval("[2*3**2]"), 18, 1e-12);
    EF_CHECK_NEAR(xval("[10-4-3]"), 3, 1e-12);
    EF_CHECK_NEAR(xval("[12/3/2]"), 2, 1e-12);
    EF_CHECK_NEAR(xval("[-2**2]"), 4, 1e-12); /* the sign belongs to the operand */
    EF_CHECK_NEAR(xval("-[2+3]"), -5, 1e-12);
    EF_CHECK_NEAR(xval("[7 MOD 3]"), 1, 1e-12);
    EF_CHECK_NEAR(xval("[-7 MOD 3]"), 2, 1e-12);
    EF_CHECK_NEAR(xval("[1+7 MOD 3]"), 2, 1e-12);
    EF_CHECK_NEAR(xval("SIN[30]"), 0.5, 1e-12);
    EF_CHECK_NEAR(xval("COS[60]"), 0.5, 1e-12);
    EF_CHECK_NEAR(xval("TAN[45]"), 1, 1e-12);
    EF_CHECK_NEAR(xval("ASIN[1]"), 90, 1e-12);
    EF_CHECK_NEAR(xval("ACOS[0]"), 90, 1e-12);
    EF_CHECK_NEAR(xval("ATAN[1]/[-1]"), 135, 1e-12);
    EF_CHECK_NEAR(xval("SQRT[16]"), 4, 1e-12);
    EF_CHECK_NEAR(xval("ABS[-3]"), 3, 1e-12);
    EF_CHECK_NEAR(xval("EXP[1]"), exp(1), 1e-12);
    EF_CHECK_NEAR(xval("LN[EXP[2]]"), 2, 1e-12);
    EF_CHECK_NEAR(xval("ROUND[2.5]"), 3, 0);
    EF_CHECK_NEAR(xval("FIX[-1.5]"), -2, 0);
    EF_CHECK_NEAR(xval("FUP[1.2]"), 2, 0);
    EF_CHECK_NEAR(xval("[2 GT 1]"), 1, 0);
    EF_CHECK_NEAR(xval("[1 EQ 2 OR 3 LE 3]"), 1, 0);
    EF_CHECK_NEAR(xval("[1+1 EQ 2]"), 1, 0);
    EF_CHECK_NEAR(xval("[[1 AND 0]+5]"), 5, 0);
    EF_CHECK_NEAR(xval("[1 XOR 0]"), 1, 0);
    EF_CHECK_NEAR(xval("[.5]"), 0.5, 0);
    /* numbered and named parameters; assignments take effect after their line */
    int n = rd("#1 = .5\nG0 X[#1*53.]\n#2=3 #1=#2 G0 Y#1\nY#1 Z##2\n#<Depth> = -2\nG0 Z#<depth>\n");
    EF_CHECK_EQ(n, 5);
    EF_CHECK_NEAR(I[0].end[0], 26.5, 1e-12);
    EF_CHECK_NEAR(I[1].end[1], 0.5, 0);
    EF_CHECK_NEAR(I[2].end[1], 0, 0); /* #1=#2 read the old #2 (0) */
    EF_CHECK_NEAR(I[2].end[2], 0, 0); /* ##2 is #3, never set: 0 */
    EF_CHECK_NEAR(I[3].end[2], -2, 0);
    n = rd("#5399 = 1\nG0 X#5399\n");
    EF_CHECK_NEAR(I[0].end[0], 1, 0);
}

/* Events, ignored words, tolerance items. */
static void test_events(void)
{
    int n =
        rd("G21 G90 G17 G40 G49 G80 G94\nG64 P0.01 Q0.005\nN5 T1 M6\nS12000 M3\nG54\nM8\n"
           "G4 P0.5\nG43 H1 G0 Z10\nG40\nG61\nG20 G64 P0.001\nM0 G0 X1\nM5 M9\nG53 G0 Z0\nM30\n");
    EF_CHECK(n > 0);
    int k = 0;
    EF_CHECK_EQ(I[k].kind, EF_GC_IGNORED);
    EF_CHECK(!strcmp(I[k].text, "G40"));
    EF_CHECK_EQ(I[k].col, 13);
    k++;
    EF_CHECK_EQ(I[k].kind, EF_GC_TOLERANCE);
    EF_CHECK_EQ(I[k].path_mode, EF_GC_PATH_BLEND);
    EF_CHECK_NEAR(I[k].p_tol, 0.01, 1e-15);
    EF_CHECK_NEAR(I[k].q_tol, 0.005, 1e-15);
    k++;
    EF_CHECK(!strcmp(I[k].text, "T1 M6"));
    EF_CHECK_EQ(I[k].col, 4);
    k++;
    EF_CHECK(!strcmp(I[k++].text, "S12000 M3"));
    EF_CHECK(!strcmp(I[k++].text, "M8"));
    EF_CHECK(!strcmp(I[k++].text, "G4 P0.5"));
    /* tool 1 has no G10 L1 entry: its offset is 0, said once */
    EF_CHECK_EQ(I[k].kind, EF_GC_IGNORED);
    EF_CHECK(strstr(I[k++].text, "no G10 L1 entry") != NULL);
    EF_CHECK_EQ(I[k++].kind, EF_GC_RAPID);
    /* the second G40 gives no note */
    EF_CHECK_EQ(I[k].kind, EF_GC_TOLERANCE);
    EF_CHECK_EQ(I[k++].path_mode, EF_GC_PATH_EXACT);
    EF_CHECK_EQ(I[k].kind, EF_GC_TOLERANCE);
    EF_CHECK_NEAR(I[k].p_tol, 0.0254, 1e-12);
    EF_CHECK_EQ(I[k++].q_tol, 0);
    EF_CHECK_EQ(I[k++].kind, EF_GC_RAPID); /* M0 comes after the line's motion */
    EF_CHECK(!strcmp(I[k++].text, "M0"));
    EF_CHECK(!strcmp(I[k++].text, "M5 M9"));
    EF_CHECK_EQ(I[k].kind, EF_GC_RAPID); /* G53: a move to machine Z0 */
    EF_CHECK_NEAR(I[k++].end[2], 0, 0);
    EF_CHECK_EQ(I[k++].kind, EF_GC_END);
    EF_CHECK_EQ(k, n);
    /* G64 with no P: blend, no tolerance given; G64 Q alone: Q given, P unset */
    n = rd("G64\nG64 Q0.01\n");
    EF_CHECK_EQ(I[0].kind, EF_GC_TOLERANCE);
    EF_CHECK_EQ(I[0].p_tol, 0);
    EF_CHECK_EQ(I[1].kind, EF_GC_TOLERANCE);
    EF_CHECK_EQ(I[1].p_tol, 0);
    EF_CHECK_NEAR(I[1].q_tol, 0.01, 1e-15);
    /* M7 and M8 together are allowed */
    n = rd("M7 M8\n");
    EF_CHECK(!strcmp(I[0].text, "M7 M8"));
    /* G80 with a motion code on one line: the motion code wins, said once */
    n = rd("G0 G80 X1\nG80 G1 X2 F100\n");
    EF_CHECK_EQ(n, 4);
    EF_CHECK_EQ(I[0].kind, EF_GC_IGNORED);
    EF_CHECK(strstr(I[0].text, "motion code wins") != NULL);
    EF_CHECK_EQ(I[0].col, 4);
    EF_CHECK_EQ(I[1].kind, EF_GC_RAPID);
    EF_CHECK_EQ(I[2].kind, EF_GC_LINE);
    /* a feed above the limit: clamped, with a note on each line it happens */
    n = rd("G1 X1 F20000000\nX2\nG1 X3 F30000000\n");
    EF_CHECK_EQ(n, 6);
    EF_CHECK_EQ(I[0].kind, EF_GC_NOTE);
    EF_CHECK_EQ(I[0].line, 1);
    EF_CHECK_EQ(I[0].col, 7);
    EF_CHECK(strstr(I[0].text, "clamped") != NULL);
    EF_CHECK_NEAR(I[1].feed, EF_GCODE_MAX_FEED, 0);
    EF_CHECK_EQ(I[3].kind, EF_GC_NOTE);
    EF_CHECK_EQ(I[3].line, 3);
    ef_gcode_init(&R, "G1 X1 F500\n", 11, "t.ngc");
    EF_CHECK_EQ(ef_gcode_set_max_feed(&R, 300), EF_OK);
    EF_CHECK_EQ(ef_gcode_set_max_feed(&R, NAN), EF_ERR_ARG);
    EF_CHECK_EQ(ef_gcode_set_max_feed(NULL, 1), EF_ERR_ARG);
    ef_gcode_item_t it;
    EF_CHECK_EQ(ef_gcode_next(&R, &it, &M), EF_OK);
    EF_CHECK_EQ(it.kind, EF_GC_NOTE);
    EF_CHECK_EQ(ef_gcode_next(&R, &it, &M), EF_OK);
    EF_CHECK_NEAR(it.feed, 300, 0);
    ef_gcode_free(&R);
    /* sender lines and bare line numbers: reported once, never silently */
    n = rd("$H\n$X\nN10\nN20\nG0 X1\n");
    EF_CHECK_EQ(n, 4);
    EF_CHECK_EQ(I[0].kind, EF_GC_IGNORED);
    EF_CHECK(strstr(I[0].text, "$H") != NULL);
    EF_CHECK_EQ(I[1].kind, EF_GC_IGNORED);
    EF_CHECK_EQ(I[1].line, 3);
    EF_CHECK(strstr(I[1].text, "line number") != NULL);
    EF_CHECK_EQ(I[2].kind, EF_GC_RAPID);
}

/* Every error, with its exact position. */
static void test_errors(void)
{
    EXPECT_ERR("G0 X10\nG2 X20 Y0.75 I5 F100\n",
               "t.ngc:2:1: G2 arc radius mismatch: start 5.0000 end 5.0559 (differ by 0.05594 "
               "mm; allowed 0.02828 mm, or 0.1% up to 2.828 mm)");
    EXPECT_ERR_AT("G0 X10\nN12 G2 X10.3 Y0 I-10 J0 F100\n", "2:5",
                  "G2 arc radius mismatch: start 10.0000 end 10.3000 (differ by 0.3 mm");
    EXPECT_ERR_AT("G0 X[SQRT[-1]]\n", "1:6", "SQRT of negative");
    EXPECT_ERR_AT("G0 X[1/0]\n", "1:7", "division by zero");
    EXPECT_ERR_AT("G0 X[1 MOD 0]\n", "1:8", "MOD by zero");
    EXPECT_ERR_AT("G0 X[EXP[1000]]\n", "1:6", "not finite");
    EXPECT_ERR_AT("G0 X[10**400]\n", "1:8", "not finite");
    EXPECT_ERR_AT("G0 X[LN[0]]\n", "1:6", "LN argument");
    EXPECT_ERR_AT("G0 X[ACOS[2]]\n", "1:6", "outside [-1, 1]");
    EXPECT_ERR_AT("G0 X2000000\n", "1:4", "outside +-1e+06 mm");
    EXPECT_ERR_AT("G20 G0 X50000\n", "1:8", "outside +-1e+06 mm");
    EXPECT_ERR_AT("G91 G0 X900000\nX900000\n", "2:1", "outside");
    EXPECT_ERR_AT("G1 X1\n", "1:1", "feed move with no feed rate");
    EXPECT_ERR_AT("F0\nG1 X1\n", "2:1", "feed move with no feed rate");
    EXPECT_ERR_AT("G1 X1 F-5\n", "1:7", "feed F-5 must not be negative");
    EXPECT_ERR_AT("G0 X1\nG2 X2 Y1 F0 I1\n", "2:1", "no feed rate");
    EXPECT_ERR_AT("G1 F1e9\n", "1:6", "unsupported word 'E'"); /* no exponents */
    EXPECT_ERR_AT("G0 X0\nG0 X1\nG0 G1 X2\n", "3:4",
                  "G0 and G1 on one line are in the same modal group");
    EXPECT_ERR_AT("G20 G21\n", "1:5", "same modal group");
    EXPECT_ERR_AT("M3 M5\n", "1:4", "M3 and M5 on one line");
    EXPECT_ERR_AT("G0 X[1+2\n", "1:5", "unbalanced brackets");
    EXPECT_ERR_AT("G0 X[1+2]]\n", "1:10", "expected a word letter");
    EXPECT_ERR_AT("G0 X[1 #2]\n", "1:8", "expected an operator or ']'");
    EXPECT_ERR_AT("G0 X#5602\n", "1:5", "parameter number 5602 out of range");
    EXPECT_ERR_AT("G0 X#0\n", "1:5", "out of range");
    EXPECT_ERR_AT("#1.5 = 2\n", "1:1", "out of range");
    EXPECT_ERR_AT("G0 X#<nope>\n", "1:5", "#<NOPE> is not defined");
    EXPECT_ERR_AT("#1 X2\n", "1:4", "expected '='");
    EXPECT_ERR_AT("G84 X1 Y1 Z-1 R1 F100\n", "1:1", "unsupported G84 (rigid tapping");
    EXPECT_ERR_AT("G87 X1 Y1 Z-1 R1 I1 J0 K0 F100\n", "1:1", "G87 with the spindle not turning");
    EXPECT_ERR_AT("S100 M3\nG87 X1 Y1 Z-1 R1 J0 K0 F100\n", "2:1", "G87 needs I (offset");
    EXPECT_ERR_AT("S100 M3\nG87 X1 Y1 Z-1 R1 I1 J0 F100\n", "2:1", "G87 needs K (middle level)");
    EXPECT_ERR_AT("G81 X1 Z-1 R1 I1 F100\n", "1:15", "I word with no G2/G3 arc or G87");
    EXPECT_ERR_AT("G0 X1\nG41 D1 X2\n", "2:1", "unsupported G41 (cutter radius compensation");
    EXPECT_ERR_AT("G33 Z-1 K1\n", "1:1", "unsupported G33 (threading");
    EXPECT_ERR_AT("G38.2 Z-10 F10\n", "1:1", "unsupported G38.2 (probing)");
    EXPECT_ERR_AT("G5.1 X1 I1 J1\n", "1:1", "unsupported G5.1 (spline)");
    EXPECT_ERR_AT("G93 G1 X1\n", "1:5", "G93 inverse-time feed: each G1/G2/G3 needs its F");
    EXPECT_ERR_AT("G95 G1 X1 F1\n", "1:1", "unsupported G95 (feed per revolution");
    EXPECT_ERR_AT("G52 X1\n", "1:1", "unsupported G52");
    EXPECT_ERR_AT("G1.5 X1\n", "1:1", "unsupported G1.5");
    EXPECT_ERR_AT("G1.55 X1\n", "1:1", "malformed G code");
    EXPECT_ERR_AT("M98 P100\n", "1:1", "unsupported M98");
    EXPECT_ERR_AT("G0 A10 E1\n", "1:8", "unsupported word 'E'"); /* A is read, E is not */
    EXPECT_ERR_AT("G0 X1 O100 sub\n", "1:7", "O-word not at the start");
    EXPECT_ERR_AT("G0 E1\n", "1:4", "unsupported word 'E'");
    EXPECT_ERR_AT("X10\n", "1:1", "axis word with no motion mode");
    EXPECT_ERR_AT("G0 X1\nG80\nX2\n", "3:1", "axis word with no motion mode");
    EXPECT_ERR_AT("G0 X1 (open\n", "1:7", "comment not closed");
    EXPECT_ERR_AT("G0 X1 X2\n", "1:7", "second X word");
    EXPECT_ERR_AT("G0 X1 Y\n", "1:7", "has no value");
    EXPECT_ERR_AT("G0 X1 $\n", "1:7", "expected a word letter");
    EXPECT_ERR_AT("G0 X1\x01\n", "1:6", "unexpected byte 0x01");
    EXPECT_ERR_AT("G0 X1\nG2 X0 Y1 I-1 K1 F1\n", "2:14", "K word on a G17-plane arc");
    EXPECT_ERR_AT("G0 X1\nG2 X1 R5 F1\n", "2:7", "R form with end equal to start");
    EXPECT_ERR_AT("G2 X10 R4 F1\n", "1:8", "radius 4.0000 smaller than half the chord 5.0000");
    EXPECT_ERR_AT("G2 X10 F1\n", "1:1", "G2 needs IJ offsets or R");
    EXPECT_ERR_AT("G2 X10 I5 R5 F1\n", "1:11", "both R and IJ");
    EXPECT_ERR_AT("G3 X0 Y0 I0 J0 F1\n", "1:1", "radius is zero");
    EXPECT_ERR_AT("G2 X0 I1 P1.5 F1\n", "1:10", "P (turns) must be a whole number");
    EXPECT_ERR_AT("G2 R1 F10\n", "1:4", "G2 with no X, Y or Z word");
    EXPECT_ERR_AT("G1 X1 I1 F10\n", "1:7", "I word with no G2/G3 arc");
    EXPECT_ERR_AT("G1 X1 P1 F10\n", "1:7", "P word with no G4");
    EXPECT_ERR_AT("G0 X1 Q1\n", "1:7", "Q word with no G64");
    EXPECT_ERR_AT("G0 X1 L1\n", "1:7", "L word with no G10");
    EXPECT_ERR_AT("G0 X1 H1\n", "1:7", "H word with no G43");
    EXPECT_ERR_AT("G64 P-1\n", "1:5", "must not be negative");
    EXPECT_ERR_AT("G4\n", "1:1", "G4 needs a dwell time");
    EXPECT_ERR_AT("G53 G2 X1 I1 F1\n", "1:1", "G53 needs G0 or G1");
    EXPECT_ERR_AT(
        "G0 "
        "X[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[1]]]]]]]]]]]]]]]]]]]]"
        "]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]\n",
        "1:69", "nested too deeply");
    EXPECT_ERR_AT("G0 X1\nG0 X1.2.3\n", "2:8", "expected a word letter");
    EXPECT_ERR_AT("G0 X1\n\nG0 X2 G1\n", "3:7", "G0 and G1");
    /* line too long */
    {
        static char big[EF_GCODE_LINE_MAX + 16];
        memset(big, ' ', sizeof big - 1);
        big[sizeof big - 1] = 0;
        EXPECT_ERR_AT(big, "1:4097", "line longer");
    }
    /* errors are sticky, and nothing of a bad line is emitted */
    int rc = rd("G0 X1\nG1 X2 Y1 G0\nG0 X3\n");
    EF_CHECK_EQ(rc, EF_ERR_GCODE);
    ef_gcode_item_t it;
    ef_msg_t m2;
    EF_CHECK_EQ(ef_gcode_next(&R, &it, &m2), EF_ERR_GCODE);
    EF_CHECK(!strcmp(m2.text, M.text));
    EF_CHECK_EQ(ef_gcode_next(NULL, &it, &m2), EF_ERR_ARG);
    EF_CHECK_EQ(ef_gcode_init(NULL, "", 0, NULL), EF_ERR_ARG);
}

/* O-word, canned-cycle and offset errors: line:column of the word at fault, and nothing of
 * the bad line or after it comes out. */
static void test_dialect_errors(void)
{
    EXPECT_ERR("G0 X1\no100 endsub\nM2\n", "t.ngc:2:1: o100 ENDSUB outside a subroutine call");
    EXPECT_ERR_AT("G0 X1\no100 sub\nG1 X2 F1\nM2\n", "2:1", "no o100 ENDSUB before the end");
    EXPECT_ERR("o100 call\nM2\n",
               "t.ngc:1:1: call of o100: subroutine not defined in this program");
    EXPECT_ERR_AT("o<nope> call [1]\nM2\n", "1:1", "call of o<nope>: subroutine not defined");
    EXPECT_ERR_AT("o1 if [1]\nG0 X1\no2 endif\nM2\n", "3:1",
                  "o2 ENDIF inside o1 (opened on line 1)");
    EXPECT_ERR_AT("o1 sub\no1 call\no1 endsub\no1 call\nM2\n", "2:1",
                  "nested deeper than 10 levels");
    EXPECT_ERR_AT("o1 else\nM2\n", "1:1", "o1 ELSE without o1 if");
    EXPECT_ERR_AT("o1 endwhile\nM2\n", "1:1", "o1 ENDWHILE without o1 while");
    EXPECT_ERR_AT("o1 break\nM2\n", "1:1", "o1 BREAK outside a o1 loop");
    EXPECT_ERR_AT("o1 return\nM2\n", "1:1", "o1 RETURN outside a subroutine call");
    EXPECT_ERR_AT("o1 bogus\nM2\n", "1:4", "unknown O-word keyword 'BOGUS'");
    EXPECT_ERR_AT("o1 if\no1 endif\nM2\n", "1:4", "IF needs a bracketed expression");
    EXPECT_ERR_AT("o1 while [1]\nG0 X1\no1 endwhile\nM2\n", "1:1",
                  "o1 loop ran 1000000 times: a runaway loop");
    EXPECT_ERR_AT("o1 do\no1 while [1]\nM2\n", "1:1", "a runaway loop");
    EXPECT_ERR_AT("o1 repeat [2000000]\no1 endrepeat\nM2\n", "1:1",
                  "repeat count 2e+06 above 1000000");
    /* a runaway loop that moves: the moves before the bound came out, none after it */
    int n = rd("#1=0\no1 while [1]\n#1=[#1+1]\nG0 X[#1/1000]\no1 endwhile\nM2\n");
    EF_CHECK_EQ(n, EF_ERR_GCODE);
    EF_CHECK(strstr(M.text, "runaway") != NULL);
    EF_CHECK_NEAR(R.cur[0], EF_GCODE_MAX_ITER / 1000.0, 1e-9);
    /* a full circle in the modal arc mode, centre words only: placed at the first of them
     * (a fuzz find: the reader looked for a G or axis word there) */
    EXPECT_ERR_AT("G1 X1 F10\nG18 G2 X2 I.5\n I1 J1\nM2\n", "3:5", "J word on a G18-plane arc");
    EXPECT_ERR_AT("G1 X1 F10\nG93 G2 X2 I.5 F1\n I1\nM2\n", "3:2", "G93 inverse-time feed");
    n = rd("G1 X1 F10\nG2 X2 I.5\n I1\nM2\n");
    EF_CHECK_EQ(n, 4);
    EF_CHECK(n == 4 && I[2].kind == EF_GC_ARC && I[2].col == 2 && I[2].end[0] == 2);
    /* parameters */
    EXPECT_ERR_AT("#31=[#5999]\nM2\n", "1:6", "parameter number 5999 out of range (#1..#5601)");
    /* G10 */
    EXPECT_ERR("G10 L2 P10 X1\nM2\n", "t.ngc:1:8: G10 coordinate system P10: must be a whole "
                                      "number 0..9");
    EXPECT_ERR_AT("G10 L2 P-1 X1\nM2\n", "1:8", "G10 coordinate system P-1");
    EXPECT_ERR_AT("G10 L2 P1.5 X1\nM2\n", "1:8", "G10 coordinate system P1.5");
    EXPECT_ERR_AT("G10 L2 X1\nM2\n", "1:1", "G10 needs a P word");
    EXPECT_ERR_AT("G10 L3 P1 X1\nM2\n", "1:5", "G10 L3 not supported");
    EXPECT_ERR_AT("G10 L1 P0 Z1\nM2\n", "1:8", "G10 tool P0: must be a whole number 1..99999");
    EXPECT_ERR_AT("G43 H-1\nM2\n", "1:5", "G43 tool H-1");
    EXPECT_ERR_AT("G92\nM2\n", "1:1", "G92 needs at least one axis word");
    EXPECT_ERR_AT("G28 X[1/0]\nM2\n", "1:8", "division by zero");
    /* canned cycles */
    EXPECT_ERR_AT("G81 Z-1 F100\nM2\n", "1:1", "G81 needs an R word (retract plane)");
    EXPECT_ERR_AT("G81 X1 Z-1 R1\nM2\n", "1:1", "G81 canned cycle with no feed rate");
    EXPECT_ERR_AT("G83 X1 Z-1 R1 F100\nM2\n", "1:1", "G83 needs a Q word (peck depth)");
    EXPECT_ERR_AT("G83 X1 Z-1 R1 Q-1 F100\nM2\n", "1:15", "G83 Q (peck depth) must be > 0");
    EXPECT_ERR_AT("G81 X1 Z2 R1 F100\nM2\n", "1:1", "G81 R 1.0000 below the bottom Z 2.0000");
    EXPECT_ERR_AT("G81 X1 Z-1 R1 L0 F100\nM2\n", "1:15", "G81 L (repeats) must be a whole number");
    EXPECT_ERR_AT("G91 G81 X1 Z-1 R1 L1.5 F100\nM2\n", "1:19", "L (repeats)");
    /* a bad line in a cycle program: the holes before it were drilled, none after */
    n = rd("G0 Z5\nG81 X1 Z-1 R1 F100\nX2\nX3 Q-1 G83\nX4\nM2\n");
    EF_CHECK_EQ(n, EF_ERR_GCODE);
    EF_CHECK_NEAR(R.cur[0], 2, 0);
}

/* Canned cycles, offsets and spirals, item by item (the corpus in tests/data/gcode checks
 * whole programs against LinuxCNC; these pin the details). */
static void test_dialect(void)
{
    /* G81 G98 from Z5 with R1: rapid XY, rapid to R, feed to Z, rapid back to the initial Z */
    int n = rd("G0 Z5\nG98 G81 X1 Y2 Z-1 R1 F100\nM2\n");
    EF_CHECK(n >= 5);
    int k = 1;
    while (k < n && I[k].kind != EF_GC_RAPID)
        k++;
    EF_CHECK(k + 3 < n);
    if (k + 3 < n) {
        EF_CHECK_NEAR(I[k].end[0], 1, 0);
        EF_CHECK_NEAR(I[k].end[1], 2, 0);
        EF_CHECK_NEAR(I[k].end[2], 5, 0);
        EF_CHECK_EQ(I[k + 1].kind, EF_GC_RAPID);
        EF_CHECK_NEAR(I[k + 1].end[2], 1, 0);
        EF_CHECK_EQ(I[k + 2].kind, EF_GC_LINE);
        EF_CHECK_NEAR(I[k + 2].end[2], -1, 0);
        EF_CHECK_NEAR(I[k + 2].feed, 100, 0);
        EF_CHECK_EQ(I[k + 3].kind, EF_GC_RAPID);
        EF_CHECK_NEAR(I[k + 3].end[2], 5, 0);
    }
    /* G87 back boring: the spindle stops oriented before the bar goes down off centre and
     * again before it comes out; it turns again at the bottom and at the end */
    n = rd("G0 Z10\nS500 M4\nG98 G87 X5 Y5 Z-10 R2 I1 J0.5 K-4 F100\nM2\n");
    {
        static const char *want[] = {"rapid", "event", "tolerance", "rapid", "rapid",
                                     "rapid", "event", "rapid",     "rapid", "event",
                                     "line",  "line",  "event",     "rapid", "rapid",
                                     "rapid", "event", "tolerance", "end"};
        int nw = (int)(sizeof want / sizeof want[0]);
        EF_CHECK_EQ(n, nw);
        for (int j = 0; j < n && j < nw; j++)
            if (strcmp(ef_gcode_kind_name(I[j].kind), want[j])) {
                ef_t_fail++;
                fprintf(stderr, "%s:%d: G87 item %d is %s, want %s\n", __FILE__, __LINE__, j,
                        ef_gcode_kind_name(I[j].kind), want[j]);
            }
        EF_CHECK(n == nw && !strncmp(I[6].text, "M5 M19", 6) && !strncmp(I[9].text, "M4 ", 3));
        EF_CHECK(n == nw && I[10].end[2] == -4 && I[11].end[2] == -10 && I[14].end[2] == 10);
    }
    /* G92 in a rotated G54 lives before the rotation: X0 reads where the tool is */
    n = rd("G10 L2 P1 X10 Y5 R90\nG0 X1 Y0\nG92 X0 Y0\nG0 X0 Y1\nM2\n");
    EF_CHECK(n >= 3);
    EF_CHECK_NEAR(R.cur[0], 10 - 1, 1e-12);
    EF_CHECK_NEAR(R.cur[1], 5 + 1, 1e-12);
    /* G10 L20 X alone in a rotated system moves both X and Y of the offset */
    rd("G10 L2 P1 X10 Y5 R30\nG0 X3 Y4\nG10 L20 P1 X1\nM2\n");
    EF_CHECK_NEAR(R.g5x[0][0], 11.732050807568877, 1e-9);
    EF_CHECK_NEAR(R.g5x[0][1], 6.0, 1e-9);
    /* tool length: G43 H applies the G10 L1 entry to Z; G49 removes it */
    n = rd("G10 L1 P3 Z2.5\nT3 M6\nG43 H3\nG0 Z0\nG49\nG0 Z0\nM2\n");
    EF_CHECK_NEAR(R.cur[2], 0, 0);
    EF_CHECK_NEAR(R.tlo[2], 0, 0);
    /* a spiral: the end radius is kept, not snapped to the start radius */
    n = rd("G1 X10 F100\nG2 X20 Y0.02 I5\nM2\n");
    EF_CHECK(n >= 2 && I[1].kind == EF_GC_ARC);
    if (n >= 2) {
        EF_CHECK_NEAR(I[1].radius, 5, 1e-12);
        EF_CHECK_NEAR(I[1].radius_end, hypot(5, 0.02), 1e-12);
        EF_CHECK_NEAR(I[1].end[1], 0.02, 0);
    }
    /* sender lines: each kind reported once */
    n = rd("$H\n$X\nN10\nN20\nG0 X1\nM2\n");
    EF_CHECK_EQ(n, 4);
    EF_CHECK(n == 4 && I[0].kind == EF_GC_IGNORED && I[1].kind == EF_GC_IGNORED);
}

/* The axes beyond X Y Z: A B C (degrees, never scaled) and U V W (mm, G20 converted), in
 * astart/aend of every item with a start and an end, with LinuxCNC's offsets and feeds. */
static void test_axes(void)
{
    /* G90 and G91; a move of A B C U V W alone is a rapid or line with X Y Z still */
    int n = rd("G0 A10\nG91 A5 B-2\nG90 G1 A90 F100\nG1 X10 A0 W3\nM2\n");
    EF_CHECK_EQ(n, 5);
    EF_CHECK(n == 5 && I[0].kind == EF_GC_RAPID && I[0].aend[0] == 10 && I[0].astart[0] == 0);
    EF_CHECK(n == 5 && I[0].end[0] == I[0].start[0] && I[0].end[2] == I[0].start[2]);
    EF_CHECK(n == 5 && I[1].astart[0] == 10 && I[1].aend[0] == 15 && I[1].aend[1] == -2);
    EF_CHECK(n == 5 && I[2].kind == EF_GC_LINE && I[2].aend[0] == 90 && I[2].aend[1] == -2);
    EF_CHECK(n == 5 && I[2].start[0] == 0 && I[2].end[0] == 0 && I[2].feed == 100);
    /* X with A: the feed is along X Y Z, A follows */
    EF_CHECK(n == 5 && I[3].kind == EF_GC_LINE && I[3].end[0] == 10 && I[3].aend[0] == 0);
    EF_CHECK(n == 5 && I[3].aend[5] == 3 && I[3].astart[0] == 90 && I[3].feed == 100);
    /* an arc moves A linearly beside its X Y arc */
    n = rd("G0 X10 A5\nG3 X-10 Y0 I-10 A185 F100\nM2\n");
    EF_CHECK_EQ(n, 3);
    EF_CHECK(n == 3 && I[1].kind == EF_GC_ARC && I[1].astart[0] == 5 && I[1].aend[0] == 185);
    if (n == 3) {
        EF_CHECK_NEAR(I[1].end[0], -10, 1e-12);
        EF_CHECK_NEAR(I[1].sweep, M_PI, 1e-12);
        EF_CHECK_NEAR(I[1].feed, 100, 0);
        EF_CHECK_NEAR(R.acur[0], 185, 0);
    }
    /* a full circle with only A: IJK, end = start on X Y Z */
    n = rd("G1 X1 F10\nG2 I-1 A90\nM2\n");
    EF_CHECK(n == 3 && I[1].kind == EF_GC_ARC && I[1].aend[0] == 90);
    EF_CHECK_NEAR(n == 3 ? I[1].sweep : 0, -2 * M_PI, 1e-12);
    /* zero moves only when all nine axes stay */
    n = rd("G0 A10\nA10\nG1 A10 F1\nX0 W1\nB0 C0 U0 V0 W1\nM2\n");
    EF_CHECK_EQ(n, 6);
    EF_CHECK(n == 6 && I[1].kind == EF_GC_ZERO_MOVE && I[2].kind == EF_GC_ZERO_MOVE);
    EF_CHECK(n == 6 && I[1].aend[0] == 10 && I[2].astart[0] == 10);
    EF_CHECK(n == 6 && I[3].kind == EF_GC_LINE && I[3].aend[5] == 1 && I[3].feed == 1);
    EF_CHECK(n == 6 && I[4].kind == EF_GC_ZERO_MOVE);
    /* work offsets: G10 L2 (no XY rotation of A), L20, #5224.. and G55's #5244 */
    n = rd("G10 L2 P1 X0 Y0 R90 A30 U5\nG0 X1 A10 U1\nG10 L20 P1 A0\nG0 A5\n#5244=7\nG55 G0 "
           "A0\nG53 G0 A2\nG54 G0 X#5224 Y#5227\nM2\n");
    EF_CHECK_EQ(n, 6);
    if (n == 6) {
        EF_CHECK_NEAR(I[0].end[1], 1, 1e-12); /* X1 rotated by 90 degrees: machine Y */
        EF_CHECK_NEAR(I[0].aend[0], 40, 0);
        EF_CHECK_NEAR(I[0].aend[3], 6, 0);
        EF_CHECK_NEAR(I[1].aend[0], 45, 0); /* L20 A0 here: offset 40 */
        EF_CHECK_NEAR(I[2].aend[0], 7, 0);
        EF_CHECK_NEAR(I[3].aend[0], 2, 0);     /* G53: machine A */
        EF_CHECK_NEAR(I[4].end[1], 40, 1e-12); /* #5224 (A of G54) read as X */
        EF_CHECK_NEAR(I[4].end[0], -5, 1e-12); /* #5227 (U of G54) read as Y, rotated */
    }
    /* G92 A, its #5214, G92.1 */
    n = rd("G0 A10\nG92 A0\nG0 A5\nG0 X#5214\nG92.1\nG0 A5\nM2\n");
    EF_CHECK_EQ(n, 5);
    EF_CHECK(n == 5 && I[1].aend[0] == 15 && I[2].end[0] == 10 && I[3].aend[0] == 5);
    /* G28 through an intermediate A, then to the stored A only; G28 alone: all nine axes */
    n = rd("#5164=45\n#5169=2\nG0 X5 A10 W9\nG28 A20\nG28\nG0 A33\nG28.1\nM2\n");
    EF_CHECK_EQ(n, 6);
    if (n == 6) {
        EF_CHECK(I[1].kind == EF_GC_RAPID && I[1].aend[0] == 20 && I[1].end[0] == 5);
        EF_CHECK(I[2].kind == EF_GC_RAPID && I[2].aend[0] == 45 && I[2].aend[5] == 9);
        EF_CHECK(I[2].end[0] == 5);
        EF_CHECK(I[3].kind == EF_GC_RAPID && I[3].end[0] == 0 && I[3].aend[5] == 2);
        EF_CHECK_NEAR(R.g28[3], 33, 0);
    }
    /* G20: U converted, A not; the A feed is the F number; #5423.. and #<_a> */
    n = rd("G20 G0 U1 A2\nG0 X#5426 Y#5423 Z#<_a>\nG1 A10 F10\nG1 U2\nG21 G1 A20\nF10 A30\nM2\n");
    EF_CHECK_EQ(n, 7);
    if (n == 7) {
        EF_CHECK_NEAR(I[0].aend[3], 25.4, 1e-12);
        EF_CHECK_NEAR(I[0].aend[0], 2, 0);
        EF_CHECK_NEAR(I[1].end[0], 25.4, 1e-12);
        EF_CHECK_NEAR(I[1].end[1], 50.8, 1e-12);
        EF_CHECK_NEAR(I[1].end[2], 50.8, 1e-12);
        EF_CHECK_NEAR(I[2].feed, 10, 0);     /* deg/min */
        EF_CHECK_NEAR(I[3].feed, 254, 1e-9); /* mm/min along U */
        EF_CHECK_NEAR(I[4].feed, 10, 0);     /* the angular rate stays as written */
        EF_CHECK_NEAR(I[5].feed, 10, 0);
    }
    /* G93: F x the X Y Z length, else the U V W length, else the A B C length (degrees) */
    n = rd("G93 G1 A90 F2\nG1 X3 Y4 A0 F2\nG1 U3 V4 A90 F2\nG1 A120 B40 F0.5\nM2\n");
    EF_CHECK_EQ(n, 5);
    if (n == 5) {
        EF_CHECK_NEAR(I[0].feed, 180, 1e-12);
        EF_CHECK_NEAR(I[1].feed, 10, 1e-12);
        EF_CHECK_NEAR(I[2].feed, 10, 1e-12);
        EF_CHECK_NEAR(I[3].feed, 25, 1e-12);
    }
    /* refusals: canned cycles, tool offsets of A..W, bad values as for X Y Z */
    EXPECT_ERR("G81 X1 Y1 Z-1 R1 A5 F100\nM2\n",
               "t.ngc:1:18: axis word 'A' not supported in a canned cycle");
    EXPECT_ERR_AT("G0 Z5\nG81 X1 Z-1 R1 F100\nX2 V1\n", "3:4",
                  "axis word 'V' not supported in a canned");
    EXPECT_ERR_AT("G43.1 Z1 B2\nM2\n", "1:10", "axis word 'B' not supported in a tool offset");
    EXPECT_ERR_AT("G10 L1 P1 Z1 C2\nM2\n", "1:14", "axis word 'C' not supported in a tool offset");
    EXPECT_ERR_AT("G0 A[SQRT[-1]]\n", "1:6", "SQRT of negative");
    EXPECT_ERR_AT("G0 A[EXP[1000]]\n", "1:6", "not finite");
    EXPECT_ERR_AT("G0 B[0/0]\n", "1:7", "division by zero");
    EXPECT_ERR_AT("G0 A2000000\n", "1:4", "coordinate A 2e+06 deg outside +-1e+06 deg");
    EXPECT_ERR_AT("G20 G0 U50000\n", "1:8", "coordinate U 1.27e+06 mm outside +-1e+06 mm");
    EXPECT_ERR_AT("G91 G0 W900000\nW900000\n", "2:1", "outside");
    EXPECT_ERR_AT("G10 L2 P1 C2000000\n", "1:11", "work offset C 2e+06 deg outside");
    EXPECT_ERR_AT("A10\n", "1:1", "axis word with no motion mode");
    n = rd("G92 A0 X0\nM2\n"); /* G92 with only A: allowed */
    EF_CHECK_EQ(n, 1);
}

/* Write text to a fresh temporary file; its path in buf. */
static void tmpfile_with(char *buf, size_t n, const char *text)
{
    snprintf(buf, n, "/tmp/ef_gcode_machine_XXXXXX");
    int fd = mkstemp(buf);
    if (fd < 0) {
        perror("mkstemp");
        buf[0] = 0;
        return;
    }
    FILE *f = fdopen(fd, "w");
    fputs(text, f);
    fclose(f);
}

/* Load a parameter and a tool table file into a reader of src, then read it; the items in
 * I, the count (or the error) returned; lrc the loaders' status. */
static int rd_machine(const char *src, const char *params, const char *tools, int *lrc)
{
    char pp[64] = "", tp[64] = "";
    if (params)
        tmpfile_with(pp, sizeof pp, params);
    if (tools)
        tmpfile_with(tp, sizeof tp, tools);
    memset(&M, 0, sizeof M);
    ef_gcode_free(&R);
    ef_gcode_init(&R, src, strlen(src), "t.ngc");
    *lrc = EF_OK;
    if (params)
        *lrc = ef_gcode_load_params(&R, pp, &M);
    if (*lrc == EF_OK && tools)
        *lrc = ef_gcode_load_tools(&R, tp, &M);
    if (pp[0])
        unlink(pp);
    if (tp[0])
        unlink(tp);
    if (*lrc != EF_OK)
        return *lrc;
    int n = 0;
    ef_gcode_item_t it;
    for (;;) {
        int rc = ef_gcode_next(&R, &it, &M);
        if (rc)
            return rc;
        if (n < MAXI)
            I[n++] = it;
        if (it.kind == EF_GC_END)
            return n;
    }
}

/* The machine's files: a LinuxCNC parameter file (offsets, G28 position, coordinate system)
 * and tool table give the start state; bad lines are refused with file:line, nothing applied. */
static void test_machine_files(void)
{
    int lrc;
    /* G55 active at start (#5220 = 2) with X10 Y20 Z-50; G28 at machine Z-1 */
    int n = rd_machine("G0 X1 Y2 Z3\nG28\nM2\n",
                       "5161 0\n5162 0\n5163 -1\n; comment line\n\n5220 2\n5241 10\n5242 20\n"
                       "5243 -50\n",
                       NULL, &lrc);
    EF_CHECK_EQ(lrc, EF_OK);
    EF_CHECK_EQ(n, 3);
    EF_CHECK(n == 3 && I[0].end[0] == 11 && I[0].end[1] == 22 && I[0].end[2] == -47);
    EF_CHECK(n == 3 && I[1].kind == EF_GC_RAPID && I[1].end[2] == -1 && I[1].end[0] == 0);
    /* a tool table: G43 H3 applies tool 3's Z; T4 M6 G43 the tool in the spindle */
    n = rd_machine("G43 H3\nG0 Z0\nT4 M6\nG43\nG0 Z0\nM2\n", NULL,
                   "T3 P3 Z25.4 D6 ;end mill\nT4 P1 X0 Z-2.5 D3.175 I0 J0 Q0\n\n", &lrc);
    EF_CHECK_EQ(lrc, EF_OK);
    EF_CHECK_NEAR(R.tools[0].off[2], 25.4, 0);
    EF_CHECK_NEAR(R.tlo[2], -2.5, 0);
    EF_CHECK_NEAR(R.cur[2], -2.5, 0);
    /* bad files: an error naming the line; the reader keeps its start state */
    struct {
        const char *params, *tools, *want;
    } bad[] = {
        {"5221 1\n5222\n", NULL, ":2: expected 'NUMBER VALUE'"},
        {"5221 1 2\n", NULL, ":1: expected 'NUMBER VALUE'"},
        {"0 1\n", NULL, ":1: parameter number '0' not a whole number 1..5601"},
        {"5602 1\n", NULL, "not a whole number 1..5601"},
        {"52.5 1\n", NULL, "not a whole number"},
        {"5221 nan\n", NULL, ":1: value 'nan' of #5221 not a number"},
        {"5221 2e7\n", NULL, "not a number within"},
        {"5220 10\n", NULL, ":1: #5220 (coordinate system) 10 not 1..9"},
        {NULL, "T1 P1 Z1\nT1 P2 Z2\n", ":2: tool 1 listed twice"},
        {NULL, "P1 Z1\n", ":1: no T word"},
        {NULL, "T1 R5\n", ":1: 'R5' is not a tool table word"},
        {NULL, "T1 Zabc\n", "'Zabc' is not a tool table word"},
        {NULL, "T1 A5\n", "offsets of axes other than X Y Z"},
        {NULL, "T-1 Z1\n", "tool number -1 not 0..99999"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        n = rd_machine("G0 X1\nM2\n", bad[k].params, bad[k].tools, &lrc);
        EF_CHECK_EQ(lrc, EF_ERR_ARG);
        if (!strstr(M.text, bad[k].want) || strncmp(M.text, "/tmp/ef_gcode_machine_", 22)) {
            ef_t_fail++;
            fprintf(stderr, "%s:%d: case %zu: message '%s', want ...%s\n", __FILE__, __LINE__, k,
                    M.text, bad[k].want);
        } else {
            ef_t_pass++;
        }
        EF_CHECK_EQ(R.cs, 1);
        EF_CHECK_EQ(R.ntools, 0);
    }
    /* nothing of a bad parameter file is applied, not even its good lines */
    n = rd_machine("G0 X1\nM2\n", "5221 7\n5222 x\n", NULL, &lrc);
    EF_CHECK_EQ(lrc, EF_ERR_ARG);
    EF_CHECK_NEAR(R.g5x[0][0], 0, 0);
    /* offsets of A B C U V W from the file take effect (#5224-5229, G28 #5164-5169) */
    n = rd_machine("G0 A1 U1\nG28\nM2\n", "5224 90\n5227 -5\n5164 12\n5229 3\n", NULL, &lrc);
    EF_CHECK_EQ(lrc, EF_OK);
    EF_CHECK_EQ(n, 3);
    EF_CHECK(n == 3 && I[0].aend[0] == 91 && I[0].aend[3] == -4 && I[0].aend[5] == 0);
    EF_CHECK_NEAR(R.g5x[0][8], 3, 0);
    EF_CHECK(n == 3 && I[1].aend[0] == 12 && I[1].aend[3] == 0);
    /* a missing file, and loading after the program started */
    ef_gcode_free(&R);
    ef_gcode_init(&R, "G0 X1\nM2\n", 9, "t.ngc");
    EF_CHECK_EQ(ef_gcode_load_params(&R, "/nonexistent/x.var", &M), EF_ERR_IO);
    EF_CHECK(strstr(M.text, "/nonexistent/x.var") != NULL);
    EF_CHECK_EQ(ef_gcode_load_tools(&R, "/nonexistent/x.tbl", &M), EF_ERR_IO);
    ef_gcode_item_t it;
    EF_CHECK_EQ(ef_gcode_next(&R, &it, &M), EF_OK);
    EF_CHECK_EQ(ef_gcode_load_params(&R, "/dev/null", &M), EF_ERR_ARG);
    EF_CHECK_EQ(ef_gcode_load_tools(NULL, "/dev/null", &M), EF_ERR_ARG);
    ef_gcode_free(&R);
}

/* Errors that come with a name and the file loader. */
static void test_file(void)
{
    ef_msg_t m = {{0}};
    EF_CHECK_EQ(ef_gcode_open(&R, "/nonexistent/part.ngc", &m), EF_ERR_IO);
    EF_CHECK(strstr(m.text, "/nonexistent/part.ngc") != NULL);
    int rc = ef_gcode_open(&R, EF_SOURCE_DIR "/samples/bracket.ngc", &m);
    EF_CHECK_EQ(rc, EF_OK);
    if (rc)
        return;
    int n = 0, kinds[EF_GC_NOTE + 1] = {0};
    ef_gcode_item_t it;
    double len = 0;
    do {
        rc = ef_gcode_next(&R, &it, &m);
        if (rc) {
            fprintf(stderr, "%s\n", m.text);
            break;
        }
        n++;
        kinds[it.kind]++;
        if (it.kind == EF_GC_ARC)
            len += fabs(it.sweep) * it.radius;
    } while (it.kind != EF_GC_END);
    ef_gcode_free(&R);
    EF_CHECK_EQ(rc, EF_OK);
    EF_CHECK_EQ(n, 42);
    EF_CHECK_EQ(kinds[EF_GC_RAPID], 9);
    EF_CHECK_EQ(kinds[EF_GC_LINE], 13);
    EF_CHECK_EQ(kinds[EF_GC_ARC], 12);
    EF_CHECK_EQ(kinds[EF_GC_ZERO_MOVE], 0);
    EF_CHECK_EQ(kinds[EF_GC_EVENT], 5);   /* G49 and G54 are applied, not passed on */
    EF_CHECK_EQ(kinds[EF_GC_IGNORED], 1); /* G40 (G94 and G80 are modes now) */
    EF_CHECK_EQ(kinds[EF_GC_TOLERANCE], 1);
    EF_CHECK_EQ(kinds[EF_GC_END], 1);
    EF_CHECK(!strcmp(it.text, "M30"));
    /* 8 quarter circles r 5, 3 + 1 turns r 4, a quarter r 3, three quarters r 5 */
    EF_CHECK_NEAR(len, 8 * M_PI / 2 * 5 + 4 * 2 * M_PI * 4 + M_PI / 2 * 3 + 1.5 * M_PI * 5, 1e-9);
    /* named errors carry the file name */
    rd("G1 X1\n");
    EF_CHECK(!strncmp(M.text, "t.ngc:1:1: ", 11));
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"basic", test_basic},
        {"lexical", test_lexical},
        {"zero", test_zero},
        {"units_incremental", test_units_incremental},
        {"arcs", test_arcs},
        {"r_form", test_r_form},
        {"expressions", test_expressions},
        {"events", test_events},
        {"errors", test_errors},
        {"dialect_errors", test_dialect_errors},
        {"dialect", test_dialect},
        {"axes", test_axes},
        {"machine_files", test_machine_files},
        {"file", test_file},
    };
    return EF_TEST_RUN(argc, argv, 1, parts);
}
