/* SPDX-License-Identifier: Apache-2.0 */
/* Tests of the host pipeline (host/lib/program/ef_pipeline.c, docs/smoothing-cli.md): item
 * conversion, tolerance modes, rapids and events as exact stops in order, notes, refused
 * primitives, and the sample program end to end through the interpolator. */
#include <string.h>
#include "ef_test.h"
#include "evenfeed/geom/ef_bezier.h"
#include "evenfeed/host/program/ef_pipeline.h"

extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;

#define MAXM   4096
#define MAXLOG 8192

static ef_gcode_t R; /* about 50 kB: not on the stack */

/* What a run produced, in callback order. */
typedef struct {
    ef_move_t mv[MAXM];
    ef_pipe_move_info_t mi[MAXM];
    int nm;
    char log[MAXLOG]; /* 'm' move, 'e' event, 'n' note, in order */
    uint32_t logline[MAXLOG];
    int nlog;
    char notes[16][256];
    int nnotes;
    /* setpoints */
    uint64_t nsp;
    ef_setpoint_t last;
    double last_t;
    double max_step;        /* largest |dp| between consecutive setpoints */
    double max_step_excess; /* largest |dp| - v_max dt (should be <= 0 + eps) */
    int sp_time_ok;
} ef_run_t;

static ef_run_t RUN;

static void logit(ef_run_t *r, char c, uint32_t line)
{
    if (r->nlog < MAXLOG) {
        r->log[r->nlog] = c;
        r->logline[r->nlog++] = line;
    }
}

static int cb_move(void *u, const ef_move_t *m, const ef_pipe_move_info_t *mi)
{
    ef_run_t *r = u;
    if (r->nm < MAXM) {
        r->mv[r->nm] = *m;
        r->mi[r->nm++] = *mi;
    }
    logit(r, 'm', m->tag);
    return 0;
}

static int cb_event(void *u, const ef_gcode_item_t *it)
{
    logit(u, 'e', it->line);
    return 0;
}

static int cb_note(void *u, const ef_gcode_item_t *it, const char *text)
{
    ef_run_t *r = u;
    if (r->nnotes < 16)
        snprintf(r->notes[r->nnotes++], 256, "%s", text);
    logit(r, 'n', it->line);
    return 0;
}

static double PERIOD = 1e-3;

static int cb_sp(void *u, double t, const ef_setpoint_t *sp, const ef_pipe_move_info_t *mi)
{
    ef_run_t *r = u;
    (void)mi;
    if (r->nsp) {
        double dx = (double)sp->p.x - r->last.p.x, dy = (double)sp->p.y - r->last.p.y,
               dz = (double)sp->p.z - r->last.p.z;
        double d = sqrt(dx * dx + dy * dy + dz * dz);
        if (d > r->max_step)
            r->max_step = d;
        if (fabs(t - r->last_t - PERIOD) > 1e-9)
            r->sp_time_ok = 0;
    }
    r->last = *sp;
    r->last_t = t;
    r->nsp++;
    return 0;
}

static ef_pipe_cb_t CB = {NULL, cb_move, NULL, cb_event, cb_note, &RUN};

static void cfg_init(ef_pipe_cfg_t *c)
{
    ef_pipe_cfg_default(c);
    /* the parts below test blends: every corner blended (test_slow_corners: the default) */
    c->keep_slow_blends = 1;
    c->g2 = &ef_tbl_g2_default;
    c->g1 = &ef_tbl_g1_default;
}

static ef_pipe_stats_t ST;
static ef_msg_t MSG;

/* Run a program text; the pipeline's result. */
static int run_cfg(const char *src, const ef_pipe_cfg_t *cfg, const ef_pipe_cb_t *cb)
{
    memset(&RUN, 0, sizeof RUN);
    RUN.sp_time_ok = 1;
    memset(&MSG, 0, sizeof MSG);
    ef_gcode_init(&R, src, strlen(src), "t.ngc");
    return ef_pipe_run(&R, cfg, cb, &ST, &MSG);
}

static int run(const char *src)
{
    ef_pipe_cfg_t c;
    cfg_init(&c);
    return run_cfg(src, &c, &CB);
}

static ef_vec3_t mend(const ef_move_t *m)
{
    return m->b[m->degree];
}

static double dist(ef_vec3_t a, ef_vec3_t b)
{
    double dx = (double)a.x - b.x, dy = (double)a.y - b.y, dz = (double)a.z - b.z;
    return sqrt(dx * dx + dy * dy + dz * dz);
}

/* Every move starts where the previous one ended (the first at start). */
static int joined(ef_vec3_t start, double tol)
{
    ef_vec3_t p = start;
    for (int k = 0; k < RUN.nm; k++) {
        if (dist(RUN.mv[k].b[0], p) > tol) {
            fprintf(stderr, "move %d (line %u) starts %.3g from the previous end\n", k,
                    (unsigned)RUN.mv[k].tag, dist(RUN.mv[k].b[0], p));
            return 0;
        }
        p = mend(&RUN.mv[k]);
    }
    return 1;
}

/* Item -> primitive: lines, rapids, arcs in the three planes, helix. */
static void test_item_prim(void)
{
    ef_gcode_item_t it;
    ef_prim_t pr;
    memset(&it, 0, sizeof it);
    it.kind = EF_GC_LINE;
    it.end[0] = 1;
    it.end[1] = 2;
    it.end[2] = 3;
    it.feed = 600;
    EF_CHECK_EQ(ef_pipe_item_prim(&it, 50, &pr), EF_OK);
    EF_CHECK_EQ(pr.kind, EF_PRIM_LINE);
    EF_CHECK_NEAR(pr.feed, 10, 1e-6);
    EF_CHECK_NEAR(pr.end.z, 3, 0);
    it.kind = EF_GC_RAPID;
    EF_CHECK_EQ(ef_pipe_item_prim(&it, 50, &pr), EF_OK);
    EF_CHECK_NEAR(pr.feed, 50, 0);
    EF_CHECK_EQ(ef_pipe_item_prim(NULL, 50, &pr), EF_ERR_ARG);
    it.kind = EF_GC_EVENT;
    EF_CHECK_EQ(ef_pipe_item_prim(&it, 50, &pr), EF_ERR_ARG);

    /* Through the reader: G17/G18/G19 arcs, axis and sweep sign, helix end. */
    int n = run("G1 X10 F600\nG3 X0 Y10 I-10 J0\n" /* G17 quarter ccw */
                "G18 G2 X-10 Z10 I0 K10\n"         /* ZX plane */
                "G19 G3 Y0 Z0 J-10 K0\n"           /* YZ plane */
                "G17 G2 X-10 Y0 Z-5 I5 J0 P2\n");  /* helix, two turns */
    EF_CHECK_EQ(n, EF_OK);
    ef_gcode_item_t its[8];
    int ni = 0;
    ef_gcode_init(&R,
                  "G1 X10 F600\nG3 X0 Y10 I-10 J0\nG18 G2 X-10 Z10 I0 K10\n"
                  "G19 G3 Y0 Z0 J-10 K0\nG17 G2 X-10 Y0 Z-5 I5 J0 P2\nM2\n",
                  strlen("G1 X10 F600\nG3 X0 Y10 I-10 J0\nG18 G2 X-10 Z10 I0 K10\n"
                         "G19 G3 Y0 Z0 J-10 K0\nG17 G2 X-10 Y0 Z-5 I5 J0 P2\nM2\n"),
                  "t.ngc");
    while (ni < 8 && ef_gcode_next(&R, &its[ni], NULL) == EF_OK && its[ni].kind != EF_GC_END)
        ni++;
    EF_CHECK_EQ(ni, 5);
    static const float axes[5][3] = {{0}, {0, 0, 1}, {0, 1, 0}, {1, 0, 0}, {0, 0, 1}};
    for (int k = 1; k < 5 && k < ni; k++) {
        EF_CHECK_EQ(ef_pipe_item_prim(&its[k], 50, &pr), EF_OK);
        EF_CHECK_EQ(pr.kind, EF_PRIM_ARC);
        EF_CHECK_NEAR(pr.axis.x, axes[k][0], 0);
        EF_CHECK_NEAR(pr.axis.y, axes[k][1], 0);
        EF_CHECK_NEAR(pr.axis.z, axes[k][2], 0);
        EF_CHECK_NEAR(pr.sweep, its[k].sweep, 1e-6);
        EF_CHECK_NEAR(pr.centre.x, its[k].centre[0], 1e-6);
        EF_CHECK_NEAR(pr.end.z, its[k].end[2], 1e-6);
        float len;
        ef_vec3_t st =
            ef_v3((float)its[k].start[0], (float)its[k].start[1], (float)its[k].start[2]);
        EF_CHECK_EQ(ef_prim_check(st, &pr, &len), EF_OK);
    }
    EF_CHECK_NEAR(its[1].sweep, M_PI / 2, 1e-9);
    EF_CHECK(its[2].sweep < 0);
    EF_CHECK_NEAR(its[4].sweep, -4 * M_PI, 1e-9);
    EF_CHECK_NEAR(pr.end.z, -5, 0);
    /* The whole run joined up and ends at the helix end. */
    EF_CHECK(joined(ef_v3(0, 0, 0), 1e-3));
    EF_CHECK_EQ(ST.arcs, 4);
    EF_CHECK_NEAR(ST.end[0], -10, 1e-3);
    EF_CHECK_NEAR(ST.end[2], -5, 1e-3);
}

/* G20: positions stay in mm inside; the stats record the program's units. */
static void test_units(void)
{
    EF_CHECK_EQ(run("G20 G1 X1 F10\nY1\nM2\n"), EF_OK);
    EF_CHECK_EQ(ST.units, 20);
    EF_CHECK(RUN.nm >= 2);
    EF_CHECK_NEAR(ST.end[0], 25.4, 1e-4);
    EF_CHECK_NEAR(ST.end[1], 25.4, 1e-4);
    EF_CHECK_EQ(RUN.mi[0].units, 20);
    EF_CHECK_NEAR(RUN.mv[0].feed, 254.0 / 60.0, 1e-4); /* 10 in/min */
    EF_CHECK_EQ(run("G1 X1 F10\nM2\n"), EF_OK);
    EF_CHECK_EQ(ST.units, 21);
}

static int count_kind(int kind)
{
    int n = 0;
    for (int k = 0; k < RUN.nm; k++)
        n += RUN.mv[k].kind == kind;
    return n;
}

/* G61 stops at every vertex; G64 P blends within P; P absent takes the default. */
static void test_tolerance_modes(void)
{
    const char *square = "G1 X10 F600\nY10\nX0\nY0\nM2\n";
    char src[256];
    snprintf(src, sizeof src, "G61\n%s", square);
    EF_CHECK_EQ(run(src), EF_OK);
    EF_CHECK_EQ(count_kind(EF_MOVE_BLEND), 0);
    for (int k = 0; k < RUN.nm; k++)
        EF_CHECK(RUN.mv[k].flags & EF_MOVE_STOP_END);
    EF_CHECK_EQ(ST.sm.blends, 0);

    snprintf(src, sizeof src, "G64 P0.05\n%s", square);
    EF_CHECK_EQ(run(src), EF_OK);
    EF_CHECK_EQ(count_kind(EF_MOVE_BLEND), 3);
    double dmax = 0;
    for (int k = 0; k < RUN.nm; k++) {
        if (RUN.mv[k].kind == EF_MOVE_BLEND)
            EF_CHECK_NEAR(RUN.mi[k].tol, 0.05, 1e-12);
        dmax = fmax(dmax, RUN.mv[k].dev);
    }
    EF_CHECK(dmax <= 0.05 + 1e-6);
    EF_CHECK(dmax > 0.03); /* the blend uses the tolerance it is given */
    EF_CHECK_EQ(ST.dev_over, 0);
    EF_CHECK(joined(ef_v3(0, 0, 0), 1e-4));

    /* G64 without P: the configured default (0.02 mm); program start is G64 too. */
    snprintf(src, sizeof src, "G64\n%s", square);
    EF_CHECK_EQ(run(src), EF_OK);
    EF_CHECK_EQ(count_kind(EF_MOVE_BLEND), 3);
    EF_CHECK(ST.dev_max <= 0.02 + 1e-6 && ST.dev_max > 0.01);
    EF_CHECK_EQ(run(square), EF_OK);
    EF_CHECK_EQ(count_kind(EF_MOVE_BLEND), 3);
    EF_CHECK(ST.dev_max <= 0.02 + 1e-6);

    /* Back from G61 to G64 P within one program. */
    EF_CHECK_EQ(run("G61 G1 X10 F600\nY10\nG64 P0.05 X0\nY0\nM2\n"), EF_OK);
    EF_CHECK_EQ(count_kind(EF_MOVE_BLEND), 2);
}

/* Corners where an exact stop is faster than the blend that fits (ef_smooth.h, rule 1),
 * the pipeline's default: a square at 10 mm/s in G64 P0.05 under the default jerk limit
 * has blends good for about 4 mm/s, so its three corners become exact stops, counted as
 * slow corners, and the program takes less time than with every corner blended; at P2 the
 * blends are fast and stay. */
static void test_slow_corners(void)
{
    const char *tight = "G64 P0.05\nG1 X10 F600\nY10\nX0\nY0\nM2\n";
    const char *wide = "G64 P2\nG1 X10 F600\nY10\nX0\nY0\nM2\n";
    ef_pipe_cfg_t c;
    cfg_init(&c);
    c.keep_slow_blends = 0;
    EF_CHECK_EQ(run_cfg(tight, &c, &CB), EF_OK);
    double t_stop = ST.cycle_time;
    EF_CHECK_EQ(ST.sm.slow_corners, 3);
    EF_CHECK_EQ(ST.sm.blends, 0);
    EF_CHECK_EQ(count_kind(EF_MOVE_BLEND), 0);
    EF_CHECK_EQ(ST.dev_over, 0);
    EF_CHECK(joined(ef_v3(0, 0, 0), 1e-4));
    c.keep_slow_blends = 1;
    EF_CHECK_EQ(run_cfg(tight, &c, &CB), EF_OK);
    double t_blend = ST.cycle_time;
    EF_CHECK_EQ(ST.sm.blends, 3);
    printf("slow corners: square at 10 mm/s, P0.05: %.4f s stopping, %.4f s blended\n", t_stop,
           t_blend);
    EF_CHECK(t_stop < t_blend);
    c.keep_slow_blends = 0;
    EF_CHECK_EQ(run_cfg(wide, &c, &CB), EF_OK);
    EF_CHECK_EQ(ST.sm.slow_corners, 0);
    EF_CHECK_EQ(ST.sm.blends, 3);
}

/* Rapids are blended within P like any vertex (exact stops at both ends with
 * rapid_exact); events drain first and keep their order. */
static void test_rapids_events(void)
{
    const char *prog = "G1 X10 F600\nY10\nG0 X20 Y20\nG1 X30\nY30\nM2\n";
    EF_CHECK_EQ(run(prog), EF_OK);
    EF_CHECK_EQ(ST.rapids, 1);
    int rapid = -1;
    for (int k = 0; k < RUN.nm; k++)
        if (RUN.mi[k].rapid && RUN.mv[k].kind == EF_MOVE_LINE)
            rapid = k;
    EF_CHECK(rapid > 0 && rapid < RUN.nm - 1);
    if (rapid > 0 && rapid < RUN.nm - 1) {
        EF_CHECK(!(RUN.mv[rapid - 1].flags & EF_MOVE_STOP_END)); /* blended into the rapid */
        EF_CHECK(!(RUN.mv[rapid].flags & EF_MOVE_STOP_END));     /* and out of it */
        EF_CHECK_EQ(RUN.mv[rapid - 1].kind, EF_MOVE_BLEND);
        EF_CHECK_EQ(RUN.mv[rapid + 1].kind, EF_MOVE_BLEND);
        EF_CHECK_NEAR(RUN.mv[rapid].feed, 100, 1e-4); /* rapid speed */
        EF_CHECK(RUN.mv[rapid].v_entry > 0 && RUN.mv[rapid].v_exit > 0);
    }
    EF_CHECK_EQ(count_kind(EF_MOVE_BLEND), 4); /* every corner, the G0 ones too */
    EF_CHECK_EQ(ST.dev_over, 0);
    EF_CHECK(ST.dev_max <= 0.02 + 1e-6);
    EF_CHECK(joined(ef_v3(0, 0, 0), 1e-4));
    /* rapid_exact: exact stops at both ends of the rapid, as before. */
    ef_pipe_cfg_t c;
    cfg_init(&c);
    c.rapid_exact = 1;
    EF_CHECK_EQ(run_cfg(prog, &c, &CB), EF_OK);
    rapid = -1;
    for (int k = 0; k < RUN.nm; k++)
        if (RUN.mi[k].rapid)
            rapid = k;
    EF_CHECK(rapid > 0 && rapid < RUN.nm - 1);
    if (rapid > 0 && rapid < RUN.nm - 1) {
        EF_CHECK(RUN.mv[rapid - 1].flags & EF_MOVE_STOP_END); /* stop before the rapid */
        EF_CHECK(RUN.mv[rapid].flags & EF_MOVE_STOP_END);     /* and after it */
        EF_CHECK_EQ(RUN.mv[rapid].kind, EF_MOVE_LINE);
    }
    EF_CHECK_EQ(count_kind(EF_MOVE_BLEND), 2); /* Y10 and X30 corners only */
    /* G61: the rapid's corners stop too. */
    EF_CHECK_EQ(run("G61\nG1 X10 F600\nY10\nG0 X20 Y20\nG1 X30\nM2\n"), EF_OK);
    EF_CHECK_EQ(count_kind(EF_MOVE_BLEND), 0);
    for (int k = 0; k < RUN.nm; k++)
        EF_CHECK(RUN.mv[k].flags & EF_MOVE_STOP_END);

    /* Events: moves of earlier lines, then the event, then later moves; stop before it. */
    EF_CHECK_EQ(run("G1 X10 F600\nY10\nM8\nX0\nG4 P0.5\nY0\nT2 M6\nX5\nM2\n"), EF_OK);
    EF_CHECK_EQ(ST.events, 3);
    int events = 0, ok = 1;
    for (int k = 0; k < RUN.nlog; k++) {
        if (RUN.log[k] != 'e')
            continue;
        events++;
        for (int j = 0; j < RUN.nlog; j++)
            if (RUN.log[j] == 'm' && (j < k) != (RUN.logline[j] < RUN.logline[k]))
                ok = 0;
    }
    EF_CHECK_EQ(events, 3);
    EF_CHECK(ok);
    for (int k = 0; k + 1 < RUN.nm; k++)
        if (RUN.mv[k + 1].tag == 4 || RUN.mv[k + 1].tag == 6 || RUN.mv[k + 1].tag == 8)
            EF_CHECK(RUN.mv[k].flags & EF_MOVE_STOP_END);
    EF_CHECK(RUN.nm > 0 && (RUN.mv[RUN.nm - 1].flags & EF_MOVE_STOP_END));
    EF_CHECK(joined(ef_v3(0, 0, 0), 1e-4));
    EF_CHECK_NEAR(ST.end[0], 5, 1e-5);
}

/* Zero-length moves and ignored words reach the note callback with line:col. */
static void test_notes(void)
{
    EF_CHECK_EQ(run("G1 X1 F100\nG40 X1\nG1 X1.0000001\nX2\nM2\n"), EF_OK);
    EF_CHECK_EQ(ST.zero_moves, 1);
    EF_CHECK_EQ(RUN.nnotes, 3);
    EF_CHECK(RUN.nnotes >= 1 && !strcmp(RUN.notes[0], "t.ngc:2:1: G40 ignored"));
    EF_CHECK(RUN.nnotes >= 2 && !strncmp(RUN.notes[1], "t.ngc:2:5: zero-length", 22));
    EF_CHECK(RUN.nnotes >= 3 && !strncmp(RUN.notes[2], "t.ngc:3:1: G1 move of 1e-07 mm", 30));
    EF_CHECK_EQ(ST.notes, 3);
    EF_CHECK_NEAR(ST.end[0], 2, 1e-6);
    EF_CHECK(joined(ef_v3(0, 0, 0), 1e-5));
    /* Notes come in program order with the moves around them. */
    EF_CHECK(RUN.nlog >= 4 && RUN.log[0] == 'n');
    /* A feed no direction of the machine reaches: clamped to the axes' limits together, with
     * a note naming the line and the F word (LinuxCNC clamps to its machine's limit). */
    EF_CHECK_EQ(run("G1 X10 F100\nG1 X20 F1000000\nM2\n"), EF_OK);
    EF_CHECK_EQ(RUN.nnotes, 1);
    EF_CHECK(RUN.nnotes >= 1 && !strncmp(RUN.notes[0], "t.ngc:2:8: feed 1e+06", 21) &&
             strstr(RUN.notes[0], "clamped") != NULL);
    EF_CHECK_NEAR(ST.end[0], 20, 1e-6);
}

/* Refused primitives: controlled stop after what was accepted, "name:line: error". */
static void test_refused(void)
{
    /* More than EF_ARC_MAX_SWEEP: the firmware's arc rule refuses it. */
    int rc = run("G1 X10 F600\nY10\nG2 X10 Y10 I-1 P2000\nG1 X20\nM2\n");
    EF_CHECK_EQ(rc, EF_ERR_ARC);
    EF_CHECK(!strcmp(MSG.text, "t.ngc:3: inconsistent arc (radius, centre or axis)") ||
             !strncmp(MSG.text, "t.ngc:3: ", 9));
    EF_CHECK(RUN.nm >= 2);
    EF_CHECK(RUN.nm > 0 && (RUN.mv[RUN.nm - 1].flags & EF_MOVE_STOP_END));
    EF_CHECK_NEAR(ST.end[0], 10, 1e-5);
    EF_CHECK_NEAR(ST.end[1], 10, 1e-5);
    EF_CHECK(joined(ef_v3(0, 0, 0), 1e-4));
    /* An arc below LinuxCNC's zero radius (0.00127 mm): the reader refuses it, at its line. */
    rc = run("G1 X1 F100\nG2 X1 Y0 I0.0000001\nG1 X2\n");
    EF_CHECK_EQ(rc, EF_ERR_GCODE);
    EF_CHECK(!strncmp(MSG.text, "t.ngc:2:1: G2 arc radius is zero", 32));
    EF_CHECK_NEAR(ST.end[0], 1, 1e-6);
    /* Reader errors also stop in a controlled way and keep the reader's message. */
    rc = run("G1 X10 F600\nY10\n#1=[0/0]\nX0\n");
    EF_CHECK_EQ(rc, EF_ERR_GCODE);
    EF_CHECK(!strcmp(MSG.text, "t.ngc:3:6: division by zero"));
    EF_CHECK(RUN.nm > 0 && (RUN.mv[RUN.nm - 1].flags & EF_MOVE_STOP_END));
    EF_CHECK_NEAR(ST.end[1], 10, 1e-5);
    rc = run("G1 X1 F0\n");
    EF_CHECK_EQ(rc, EF_ERR_GCODE);
    /* Bad configuration. */
    ef_pipe_cfg_t c;
    cfg_init(&c);
    c.rapid_speed = 0;
    EF_CHECK_EQ(run_cfg("G1 X1 F100\n", &c, &CB), EF_ERR_FEED);
    cfg_init(&c);
    c.g2 = NULL;
    EF_CHECK_EQ(run_cfg("G1 X1 F100\n", &c, &CB), EF_ERR_ARG);
    cfg_init(&c);
    c.lim.v_axis[1] = -1;
    EF_CHECK(run_cfg("G1 X1 F100\n", &c, &CB) < 0);
    ef_pipe_cb_t cb = CB;
    cb.on_setpoint = cb_sp;
    cfg_init(&c); /* setpoints asked for without interpolating */
    EF_CHECK_EQ(run_cfg("G1 X1 F100\n", &c, &cb), EF_ERR_ARG);
    EF_CHECK_EQ(ef_pipe_run(NULL, &c, &cb, &ST, &MSG), EF_ERR_ARG);
}

#define slurp ef_t_slurp

/* The sample program end to end, both step modes. */
static void test_bracket(int degree)
{
    size_t len;
    char *src = slurp(EF_SOURCE_DIR "/samples/bracket.ngc", &len);
    EF_CHECK(src != NULL);
    if (!src)
        return;
    ef_pipe_cfg_t c;
    cfg_init(&c);
    c.smooth_degree = degree;
    c.interp_modes = EF_PIPE_INTERP_UNIFORM | EF_PIPE_INTERP_CORRECTED;
    ef_pipe_cb_t cb = CB;
    cb.on_setpoint = cb_sp;
    int rc = run_cfg(src, &c, &cb);
    EF_CHECK_EQ(rc, EF_OK);
    if (rc)
        fprintf(stderr, "bracket: %s\n", MSG.text);
    EF_CHECK(joined(ef_v3(0, 0, 0), 1e-3));
    /* Program end: X75 Y40 Z25. */
    EF_CHECK_NEAR(ST.end[0], 75, 1e-4);
    EF_CHECK_NEAR(ST.end[1], 40, 1e-4);
    EF_CHECK_NEAR(ST.end[2], 25, 1e-4);
    EF_CHECK_EQ(ST.units, 21);
    EF_CHECK_EQ(ST.events, 5); /* T1 M6, S M3, M8, M9, M5 (G54 is applied, not an event) */
    EF_CHECK_EQ(ST.rapids, 9);
    EF_CHECK_EQ(ST.arcs, 12);
    EF_CHECK_EQ(ST.dev_over, 0);
    EF_CHECK(ST.dev_max <= 0.01 + 1e-6);
    EF_CHECK(ST.sm.blends > 0);
    double cyc = 0;
    for (int k = 0; k < RUN.nm; k++) {
        const ef_move_t *m = &RUN.mv[k];
        EF_CHECK(m->dev <= RUN.mi[k].tol + 1e-6);
        EF_CHECK(m->duration > 0 && isfinite(m->duration));
        EF_CHECK(m->v_entry <= m->v_max * 1.0001f + 1e-4f &&
                 m->v_exit <= m->v_max * 1.0001f + 1e-4f);
        cyc += m->duration;
        /* Rapids are blended within P (not stopped at): no rapid line ends at rest unless
         * an event or the program end follows (checked below). */
        if (k + 1 < RUN.nm && RUN.mv[k + 1].seq != m->seq + 1)
            EF_CHECK(0);
    }
    EF_CHECK_NEAR(cyc, ST.cycle_time, 1e-6 * cyc);
    int rapid_blends = 0;
    for (int k = 0; k < RUN.nm; k++)
        rapid_blends += RUN.mi[k].rapid && RUN.mv[k].kind == EF_MOVE_BLEND;
    EF_CHECK(rapid_blends > 0); /* G0 corners and G0/G1 transitions blended */
    EF_CHECK(RUN.nm > 0 && (RUN.mv[RUN.nm - 1].flags & EF_MOVE_STOP_END));
    /* Each event comes after a move that ends at rest. */
    for (int k = 1; k < RUN.nlog; k++)
        if (RUN.log[k] == 'e') {
            int j = k - 1;
            while (j >= 0 && RUN.log[j] != 'm')
                j--;
            if (j >= 0) {
                int mi = 0;
                for (int q = 0; q < j; q++)
                    mi += RUN.log[q] == 'm';
                EF_CHECK(RUN.mv[mi].flags & EF_MOVE_STOP_END);
            }
        }
    /* Setpoints: regular times, no jump beyond the fastest move's step, end at rest at the
     * program end, no underrun, fluctuation small in both modes. */
    EF_CHECK(RUN.nsp > 1000);
    EF_CHECK(RUN.sp_time_ok);
    EF_CHECK(RUN.max_step <= 100 * PERIOD * 1.05);
    EF_CHECK_EQ(RUN.last.moving, 0);
    EF_CHECK_NEAR(RUN.last.p.x, 75, 1e-3);
    EF_CHECK_NEAR(RUN.last.p.y, 40, 1e-3);
    EF_CHECK_NEAR(RUN.last.p.z, 25, 1e-3);
    for (int k = 0; k < 2; k++) {
        EF_CHECK_EQ(ST.fl[k].underruns, 0);
        EF_CHECK(ST.fl[k].samples > 1000);
        EF_CHECK(ST.fl[k].max_rel < 0.1); /* float32 steps on slow ramps */
        EF_CHECK(ST.fl[k].rms_rel < 0.005);
        EF_CHECK(ST.fl[k].end_time >= ST.cycle_time * 0.99);
        /* at feed (planned speed >= half the programmed feed) a subset of those samples,
         * so never more than the whole figure; the absolute error is small and nonzero */
        EF_CHECK(ST.fl[k].samples_feed > ST.fl[k].samples / 2);
        EF_CHECK(ST.fl[k].samples_feed <= ST.fl[k].samples);
        EF_CHECK(ST.fl[k].max_rel_feed <= ST.fl[k].max_rel);
        /* Close to the float32 floor: |dp| / dt of float32 setpoints near X75 at the
         * bracket's slowest at-feed speed (1.25 mm/s, 1.25e-3 mm a period) carries up to
         * 2 ulp of 7.6e-6 mm, 1.2 %. A work-in-progress build of 4a8718b failed here at
         * 1.22 %; `evenfeed smooth` on the same program then put its worst sample (0.99 %,
         * 0.43 % before) on a blend whose planned move had not changed, only its sampling
         * phase: read a failure as rounding before reading it as an uneven curve. */
        EF_CHECK(ST.fl[k].max_rel_feed < 0.01);
        EF_CHECK(ST.fl[k].max_abs > 0 && ST.fl[k].max_abs < 0.5);
    }
    printf("bracket (degree %d): %u moves, %u blends, %u stops, cycle %.3f s, dev %.4g mm, "
           "fluct uniform %.3e/%.3e corrected %.3e/%.3e (max/rms), at feed %.3e/%.3e, speed "
           "error %.4f/%.4f mm/s\n",
           degree, (unsigned)ST.moves, (unsigned)ST.sm.blends, (unsigned)ST.sm.stops, ST.cycle_time,
           ST.dev_max, ST.fl[0].max_rel, ST.fl[0].rms_rel, ST.fl[1].max_rel, ST.fl[1].rms_rel,
           ST.fl[0].max_rel_feed, ST.fl[1].max_rel_feed, ST.fl[0].max_abs, ST.fl[1].max_abs);
    free(src);
}

/* CAM-style micro-segments: smooth sections, continuity, deviation within P. */
static void test_micro(void)
{
    char src[16384];
    size_t n = (size_t)snprintf(src, sizeof src, "G64 P0.01\nG1 X20 Y0 F1200\n");
    for (int k = 1; k <= 60; k++) {
        double a = k * (M_PI / 60);
        n += (size_t)snprintf(src + n, sizeof src - n, "X%.4f Y%.4f\n", 10 + 10 * cos(a),
                              10 * sin(a));
    }
    snprintf(src + n, sizeof src - n, "M2\n");
    EF_CHECK_EQ(run(src), EF_OK);
    EF_CHECK(ST.sm.smooth > 0);
    EF_CHECK(count_kind(EF_MOVE_SMOOTH) > 0);
    EF_CHECK(ST.dev_max <= 0.01 + 1e-6);
    EF_CHECK(joined(ef_v3(0, 0, 0), 1e-3));
    EF_CHECK_NEAR(ST.end[0], 0, 1e-3);
}

/* ---- programs of short lines, measured against their input points ---- */

#define MAXPTS 12000
static double PTS[MAXPTS][3]; /* input polyline: the start, then every G0/G1 end (mm) */
static int NPTS;
static char BIG[MAXPTS * 40];
static float SAMP[MAXM * 32 + 1][3]; /* the moves sampled in order */
static int NSAMP;

/* Append "G1 X.. Y.. Z.." to BIG with coordinates rounded as printed, and remember the
 * point as the reader will see it (in mm; scale 25.4 for G20). */
static size_t add_pt(size_t n, const char *word, double x, double y, double z, double scale)
{
    char buf[128];
    snprintf(buf, sizeof buf, "%s X%.4f Y%.4f Z%.4f\n", word, x, y, z);
    double v[3];
    sscanf(buf + strlen(word), " X%lf Y%lf Z%lf", &v[0], &v[1], &v[2]);
    if (NPTS < MAXPTS) {
        for (int i = 0; i < 3; i++)
            PTS[NPTS][i] = v[i] * scale;
        NPTS++;
    }
    return n + (size_t)snprintf(BIG + n, sizeof BIG - n, "%s", buf);
}

static double dist_seg3(const double *x, const double *a, const double *b)
{
    double ab[3], ax[3], l2 = 0, t = 0;
    for (int i = 0; i < 3; i++) {
        ab[i] = b[i] - a[i];
        ax[i] = x[i] - a[i];
        l2 += ab[i] * ab[i];
        t += ax[i] * ab[i];
    }
    t = l2 > 0 ? t / l2 : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    double d = 0;
    for (int i = 0; i < 3; i++)
        d += (ax[i] - t * ab[i]) * (ax[i] - t * ab[i]);
    return sqrt(d);
}

/* Sample every move of the last run densely (32 per move) into SAMP. */
static void sample_moves(void)
{
    NSAMP = 0;
    for (int k = 0; k < RUN.nm && NSAMP < MAXM * 32; k++) {
        const ef_move_t *m = &RUN.mv[k];
        for (int j = k == 0 ? 0 : 1; j <= 32; j++) {
            ef_vec3_t q;
            ef_bezier_eval(m->b, m->degree, (float)j / 32.0f, 0, &q);
            SAMP[NSAMP][0] = q.x;
            SAMP[NSAMP][1] = q.y;
            SAMP[NSAMP][2] = q.z;
            NSAMP++;
        }
    }
}

static double dist3(const double *a, const double *b)
{
    return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                (a[2] - b[2]) * (a[2] - b[2]));
}

/* Both directions of the deviation, in double: the largest distance of a move sample from
 * the input polyline, and of an input point from the sampled moves, leaving out what lies
 * within skip_r of skip (NULL: nothing). Both sequences run along the path, so each search
 * is a window around the last nearest index. */
static void poly_devs_skip(double *curve_to_pts, double *pts_to_curve, const double *skip,
                           double skip_r)
{
    sample_moves();
    double worst = 0;
    int at = 0;
    for (int j = 0; j < NSAMP; j++) {
        double x[3] = {SAMP[j][0], SAMP[j][1], SAMP[j][2]}, best = 1e300;
        int lo = at - 160 < 0 ? 0 : at - 160, hi = at + 160 > NPTS - 1 ? NPTS - 1 : at + 160;
        for (int i = lo; i < hi; i++) {
            double d = dist_seg3(x, PTS[i], PTS[i + 1]);
            if (d < best) {
                best = d;
                at = i;
            }
        }
        if (!skip || dist3(x, skip) > skip_r)
            worst = fmax(worst, best);
    }
    *curve_to_pts = worst;
    worst = 0;
    at = 0;
    for (int i = 0; i < NPTS; i++) {
        double best = 1e300;
        int lo = at - 400 < 0 ? 0 : at - 400, hi = at + 400 > NSAMP - 1 ? NSAMP - 1 : at + 400;
        for (int j = lo; j < hi; j++) {
            double a[3] = {SAMP[j][0], SAMP[j][1], SAMP[j][2]},
                   b[3] = {SAMP[j + 1][0], SAMP[j + 1][1], SAMP[j + 1][2]};
            double d = dist_seg3(PTS[i], a, b);
            if (d < best) {
                best = d;
                at = j;
            }
        }
        if (!skip || dist3(PTS[i], skip) > skip_r)
            worst = fmax(worst, best);
    }
    *pts_to_curve = worst;
}

static void poly_devs(double *curve_to_pts, double *pts_to_curve)
{
    poly_devs_skip(curve_to_pts, pts_to_curve, NULL, 0);
}

/* Dense CAM output with quantization noise (issue 18): a circle r = 1 in from 0.016 mm
 * chords, coordinates rounded to 0.0001 in, G64 P0.001 (0.0254 mm), no Q. The vertices are
 * decimated within the band and approximated by G2 smooth sections: no exact stop but at
 * the end, the feed held (no move planned below 90 % of it away from the ends, nor any
 * move's speed limit), every input point within P of the path and the path within P of
 * the points. */
static void test_quantized_circle(void)
{
    const double r = 1.0, chord = 0.016 / 25.4, feed_ipm = 120;
    int n = (int)(2 * M_PI * r / chord);
    NPTS = 0;
    PTS[NPTS][0] = PTS[NPTS][1] = PTS[NPTS][2] = 0;
    NPTS++;
    size_t len = (size_t)snprintf(BIG, sizeof BIG, "G20 G17 G90\nG64 P0.001\n");
    len = add_pt(len, "G0", r, 0, 0, 25.4);
    len += (size_t)snprintf(BIG + len, sizeof BIG - len, "G1 F%g\n", feed_ipm);
    for (int i = 1; i <= n && NPTS < MAXPTS; i++) {
        double a = 2 * M_PI * i / n;
        len = add_pt(len, "G1", r * cos(a), r * sin(a), 0, 25.4);
    }
    snprintf(BIG + len, sizeof BIG - len, "M2\n");
    EF_CHECK_EQ(run(BIG), EF_OK);
    const double P = 0.0254, feed = feed_ipm * 25.4 / 60;
    int stops = 0, slow = 0, vlim = 0;
    double sdist = 0, total = ST.length, vmin = 1e9;
    for (int k = 0; k < RUN.nm; k++) {
        const ef_move_t *m = &RUN.mv[k];
        stops += (m->flags & EF_MOVE_STOP_END) != 0;
        /* Away from the ends: the rapid (25.4 mm) and 25 mm of the circle after it (the
         * G0/G1 corner and the ramp from it), 25 mm before the end (the ramp to rest). */
        if (sdist > 25.4 + 25 && total - sdist > 25 + m->length) {
            vmin = fmin(vmin, fmin(m->v_entry, m->v_exit));
            slow += m->v_entry < 0.9 * feed || m->v_exit < 0.9 * feed;
            vlim += m->v_max < 0.9f * (float)feed;
        }
        sdist += m->length;
    }
    EF_CHECK_EQ(stops, 1);
    EF_CHECK(RUN.nm > 0 && (RUN.mv[RUN.nm - 1].flags & EF_MOVE_STOP_END));
    EF_CHECK_EQ(slow, 0);
    EF_CHECK_EQ(vlim, 0);
    EF_CHECK(ST.sm.merged > (uint32_t)n / 2);
    EF_CHECK(ST.sm.smooth > 0);
    EF_CHECK(RUN.nm < n / 10);
    EF_CHECK_EQ(ST.dev_over, 0);
    double c2p, p2c, c2p_arc, p2c_arc;
    poly_devs(&c2p, &p2c);
    EF_CHECK(c2p <= P * (1 + 1e-4));
    EF_CHECK(p2c <= P * (1 + 1e-4));
    /* Away from the G0/G1 corner (blended within P) the path follows the points to about
     * the rounding (0.0018 mm at most, 0.07 P) plus what the smooth sections leave. */
    poly_devs_skip(&c2p_arc, &p2c_arc, PTS[1], 0.5);
    EF_CHECK(c2p_arc <= 0.25 * P);
    EF_CHECK(p2c_arc <= 0.25 * P);
    printf("quantized circle: %d points -> %d moves (%u merged, %u smooth, %d stops), "
           "slowest away from the ends %.3f of the feed, deviation / P: path->points %.3f, "
           "points->path %.3f (on the circle, away from the G0 corner: %.3f, %.3f), own bound "
           "%.3f; cycle %.3f s\n",
           n, RUN.nm, (unsigned)ST.sm.merged, (unsigned)ST.sm.smooth, stops, vmin / feed, c2p / P,
           p2c / P, c2p_arc / P, p2c_arc / P, ST.dev_max / P, ST.cycle_time);
}

/* 1000 short collinear G1 (0.1 mm, a diagonal, rounded to 0.001 mm) without Q: merged
 * within a share of P into a few moves; with a Q below the rounding nothing merges. */
static void test_collinear_run(void)
{
    for (int withq = 0; withq < 2; withq++) {
        NPTS = 0;
        PTS[NPTS][0] = PTS[NPTS][1] = PTS[NPTS][2] = 0;
        NPTS++;
        size_t len = (size_t)snprintf(BIG, sizeof BIG, "G21 G90\n%s\nG1 F6000\n",
                                      withq ? "G64 P0.02 Q0.00001" : "G64 P0.02");
        for (int i = 1; i <= 1000; i++) {
            char w[64];
            double x = 0.1 * i * cos(0.3), y = 0.1 * i * sin(0.3);
            snprintf(w, sizeof w, "G1 X%.3f Y%.3f", x, y);
            double v[2];
            sscanf(w, "G1 X%lf Y%lf", &v[0], &v[1]);
            PTS[NPTS][0] = v[0];
            PTS[NPTS][1] = v[1];
            PTS[NPTS][2] = 0;
            NPTS++;
            len += (size_t)snprintf(BIG + len, sizeof BIG - len, "%s\n", w);
        }
        snprintf(BIG + len, sizeof BIG - len, "M2\n");
        EF_CHECK_EQ(run(BIG), EF_OK);
        int stops = 0;
        for (int k = 0; k < RUN.nm; k++)
            stops += (RUN.mv[k].flags & EF_MOVE_STOP_END) != 0;
        EF_CHECK_EQ(stops, 1);
        EF_CHECK_EQ(ST.dev_over, 0);
        if (!withq) {
            EF_CHECK(RUN.nm <= 1000 / EF_SMOOTH_MERGE_MAX + 4);
            EF_CHECK(ST.sm.merged >= 1000 - 1000 / EF_SMOOTH_MERGE_MAX - 4);
            double c2p, p2c;
            poly_devs(&c2p, &p2c);
            EF_CHECK(c2p <= 0.02 && p2c <= 0.02);
            printf("collinear run: 1000 G1 -> %d moves, cycle %.3f s, deviation %.2g / %.2g mm\n",
                   RUN.nm, ST.cycle_time, c2p, p2c);
        } else {
            /* Q keeps its meaning when given: only vertices the rounding left exactly on
             * the line (within 1e-5 mm) merge. */
            EF_CHECK(ST.sm.merged < 100);
            EF_CHECK(RUN.nm >= 900);
        }
    }
}

static uint64_t XS = 0x9e3779b97f4a7c15ull;
static double xs_unit(void)
{
    XS ^= XS << 13;
    XS ^= XS >> 7;
    XS ^= XS << 17;
    return (double)(XS >> 11) / 9007199254740992.0;
}

/* Rapids with 3-D corners under G64 P: a walk of 40 G0 of 5-20 mm, each turning by
 * 20-90 degrees about a random axis, with a G1 plunge and a G1 feed move after every eighth.
 * Every corner blended (the G0/G1 transitions too), no exact stop but at the end, the path
 * within P of the programmed rapids; with rapid_exact, exact stops around every G0. */
static void rapid_corners(double P)
{
    XS = 0x9e3779b97f4a7c15ull;
    NPTS = 0;
    PTS[NPTS][0] = PTS[NPTS][1] = 0;
    PTS[NPTS][2] = 0;
    NPTS++;
    size_t len = (size_t)snprintf(BIG, sizeof BIG, "G21 G90 G64 P%g\n", P);
    double p[3] = {0, 0, 10}, d[3] = {1, 0, 0};
    len = add_pt(len, "G0", p[0], p[1], p[2], 1.0);
    for (int i = 0; i < 40; i++) {
        double ax[3] = {xs_unit() - 0.5, xs_unit() - 0.5, xs_unit() - 0.5};
        double dot = ax[0] * d[0] + ax[1] * d[1] + ax[2] * d[2], n = 0;
        for (int k = 0; k < 3; k++) {
            ax[k] -= dot * d[k];
            n += ax[k] * ax[k];
        }
        double th = (20 + 70 * xs_unit()) * M_PI / 180, step = 5 + 15 * xs_unit();
        for (int k = 0; k < 3; k++) {
            d[k] = cos(th) * d[k] + sin(th) * ax[k] / sqrt(n);
            p[k] += step * d[k];
        }
        len = add_pt(len, "G0", p[0], p[1], p[2], 1.0);
        if (i % 8 == 7) {
            len = add_pt(len, "G1 F600", p[0], p[1], p[2] - 3, 1.0);
            len = add_pt(len, "G1 F1200", p[0] + 5, p[1], p[2] - 3, 1.0);
            p[0] += 5;
            p[2] -= 3;
        }
    }
    snprintf(BIG + len, sizeof BIG - len, "M2\n");
    EF_CHECK_EQ(run(BIG), EF_OK);
    int stops = 0;
    for (int k = 0; k < RUN.nm; k++)
        stops += (RUN.mv[k].flags & EF_MOVE_STOP_END) != 0;
    EF_CHECK_EQ(stops, 1 + (int)ST.sm.reversals);
    EF_CHECK_EQ(ST.sm.reversals, 0);
    EF_CHECK_EQ(ST.sm.blends, (uint32_t)NPTS - 2);
    EF_CHECK_EQ(ST.dev_over, 0);
    EF_CHECK(ST.dev_max <= P + 1e-6);
    double c2p, p2c;
    poly_devs(&c2p, &p2c);
    EF_CHECK(c2p <= P * (1 + 1e-4));
    EF_CHECK(joined(ef_v3(0, 0, 0), 1e-4));
    double blended = ST.cycle_time;
    unsigned blends = ST.sm.blends;
    ef_pipe_cfg_t c;
    cfg_init(&c);
    c.rapid_exact = 1;
    EF_CHECK_EQ(run_cfg(BIG, &c, &CB), EF_OK);
    /* Both cycle times are printed, not compared (the rule: no timed tests). With
     * J = 20 000 mm/s^3 a blend at such corners is driven at a few mm/s over its whole
     * length, which can take longer than stopping (docs/smoothing.md). */
    EF_CHECK(ST.sm.stops > 30);
    printf("rapid corners, P %g: %u blends, deviation %.4f mm, cycle %.3f s (%.3f s with "
           "exact stops at rapids)\n",
           P, blends, c2p, blended, ST.cycle_time);
}

/* Spiral arcs (LinuxCNC's near-circular arcs, radius linear in the angle): the circular pieces
 * join end to end, end exactly where the arc does, stay within EF_PIPE_SPIRAL_DEV of the
 * spiral, and the whole program runs to its end through the smoother. */
static void spiral_check(int plane, double r0, double r1, double sweep, double dz)
{
    ef_gcode_item_t it, pc;
    memset(&it, 0, sizeof it);
    int a = plane == 18 ? 2 : plane == 19 ? 1 : 0, b = plane == 18 ? 0 : plane == 19 ? 2 : 1;
    int c = 3 - a - b;
    it.kind = EF_GC_ARC;
    it.plane = plane;
    it.radius = r0;
    it.radius_end = r1;
    it.sweep = sweep;
    it.turns = 1;
    it.feed = 300;
    it.centre[a] = 1;
    it.centre[b] = -2;
    it.start[a] = 1 + r0;
    it.start[b] = -2;
    it.end[a] = 1 + r1 * cos(sweep);
    it.end[b] = -2 + r1 * sin(sweep);
    it.end[c] = dz;
    int n = ef_pipe_spiral_pieces(sweep, r1 - r0);
    EF_CHECK(n >= 1 && n <= EF_PIPE_SPIRAL_MAX);
    EF_CHECK(n >= (int)ceil(fabs(sweep) / (M_PI / 4) - 1e-9));
    double prev[3], worst = 0;
    memcpy(prev, it.start, sizeof prev);
    for (int k = 0; k < n; k++) {
        EF_CHECK_EQ(ef_pipe_spiral_piece(&it, k, n, &pc), EF_OK);
        for (int q = 0; q < 3; q++)
            EF_CHECK_NEAR(pc.start[q], prev[q], 1e-12);
        EF_CHECK_NEAR(pc.radius, pc.radius_end, 0);
        EF_CHECK(pc.sweep * sweep > 0);
        /* sample the piece; compare with the spiral at the same angle about its centre */
        double s0 = atan2(pc.start[b] - pc.centre[b], pc.start[a] - pc.centre[a]);
        for (int j = 0; j <= 16; j++) {
            double u = s0 + pc.sweep * j / 16, x = pc.centre[a] + pc.radius * cos(u),
                   y = pc.centre[b] + pc.radius * sin(u);
            double ang = atan2(y + 2, x - 1), f = (ang - 0) / sweep;
            /* unwrap the angle into the piece's share of the sweep */
            double f0 = (double)k / n;
            while (f < f0 - 0.5 / n)
                f += 2 * M_PI / fabs(sweep);
            while (f > f0 + 1.5 / n)
                f -= 2 * M_PI / fabs(sweep);
            double rho = r0 + f * (r1 - r0);
            worst = fmax(worst, fabs(hypot(x - 1, y + 2) - rho));
        }
        memcpy(prev, pc.end, sizeof prev);
    }
    for (int q = 0; q < 3; q++)
        EF_CHECK_NEAR(prev[q], it.end[q], 0);
    EF_CHECK(worst <= EF_PIPE_SPIRAL_DEV * 1.05);
    printf("spiral G%d r %.4f -> %.4f over %.0f deg: %d pieces, worst %.2e mm\n", plane, r0, r1,
           sweep * 180 / M_PI, n, worst);
}

static void test_spiral(void)
{
    spiral_check(17, 10, 10.02, 1.5 * M_PI, 0);
    spiral_check(17, 5, 4.99, -0.7 * M_PI, -1);
    spiral_check(18, 20, 20.5, -1.9 * M_PI, 0); /* up to 100 x the tolerance, 0.1 % rule met */
    spiral_check(19, 2, 2.028, 0.25 * M_PI, 3);
    EF_CHECK_EQ(ef_pipe_spiral_pieces(2 * M_PI, 0), 8);
    EF_CHECK_EQ(ef_pipe_spiral_piece(NULL, 0, 1, NULL), EF_ERR_ARG);
    /* through the pipeline: a spiral G2 ends where it says, within P everywhere */
    EF_CHECK_EQ(run("G1 X10 F600\nG2 X20 Y0.02 I5\nG1 X30\nM2\n"), EF_OK);
    EF_CHECK_NEAR(ST.end[0], 30, 1e-6);
    EF_CHECK_EQ(ST.dev_over, 0);
    EF_CHECK(joined(ef_v3(0, 0, 0), 1e-5));
}

static void test_rapid_corners(void)
{
    rapid_corners(0.05);
    rapid_corners(0.2);
}

/* test_bracket with each of its two degrees. */
static void test_bracket_5(void)
{
    test_bracket(5);
}

static void test_bracket_3(void)
{
    test_bracket(3);
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"item_prim", test_item_prim},
        {"units", test_units},
        {"tolerance_modes", test_tolerance_modes},
        {"slow_corners", test_slow_corners},
        {"rapids_events", test_rapids_events},
        {"notes", test_notes},
        {"refused", test_refused},
        {"micro", test_micro},
        {"quantized_circle", test_quantized_circle},
        {"collinear_run", test_collinear_run},
        {"rapid_corners", test_rapid_corners},
        {"spiral", test_spiral},
        {"bracket", test_bracket_5},
        {"bracket", test_bracket_3},
    };
    return EF_TEST_RUN(argc, argv, 1, parts);
}
