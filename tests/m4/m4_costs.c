/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Costs of the per-move functions on the Cortex-M4F (issue 17), measured under QEMU with the
 * exact instruction counter of ef_m4.h, on the inputs of the x86 benchmark
 * (tests/bench/ct_cases.h: the same generators and seed as tests/bench/bench_ct.c).
 *
 * For each function it generates the inputs first (soft-float double, not measured), paints
 * the stack, makes every call between ef_m4_icount_begin() / _end(), and prints
 *   cost <func> n=<calls> min=<> median=<> max=<> ratio=<max/min>
 * then, per entry point, the deepest stack any of its calls used below the caller's frame
 *   stack <entry> used=<bytes>
 * (<entry> a+b where calls of a and b were measured together: the smoother's push and pull,
 * the interpolator's push and process)
 * (tests/m4/stack_check.sh compares these with the static bound from -fcallgraph-info).
 * The figures are reported, not judged: the targets are in tests/bench/run_all.sh.
 * Exit 0 when every call succeeded and every line was printed, 1 otherwise.
 */
#include <stdint.h>
#include <string.h>
#include "../bench/ct_cases.h"
#include "ef_m4.h"
#include "evenfeed/blend/ef_blend.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/motion/ef_interp.h"
#include "evenfeed/motion/ef_smooth.h"
#include "evenfeed/path/ef_path.h"
#include "evenfeed/seg/ef_seg.h"
#include "evenfeed/table/ef_table.h"
#ifdef COSTS_PROGS
#include "golden.h"
#endif

extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;

/** Calls per function (the first COSTS_N inputs of bench_ct's sequence for each kind). */
#ifndef COSTS_N
#define COSTS_N 1000
#endif
/** Primitives of the CAM-like stream through the smoother (bench_ct smooth's N). */
#ifndef COSTS_CAM_N
#define COSTS_CAM_N 1000
#endif
/* The images' static data stays under 1.5 MB: with 3 MB of .bss the run faulted under QEMU's
 * mps2-an386 (writes past about 2 MB of SSRAM2/3 did not read back). */
/** Most moves kept for the interpolator pass. */
#ifndef COSTS_MOVES_MAX
#define COSTS_MOVES_MAX 1536
#endif
/** Most push / pull / process calls recorded per stream. */
#ifndef COSTS_CALLS_MAX
#define COSTS_CALLS_MAX 100000
#endif

static int costs_fails;
static uint32_t costs_v[COSTS_CALLS_MAX];
static uint32_t costs_v2[COSTS_CALLS_MAX];
/** Finish calls timed per stream (each does one work unit; ef_smooth.h). */
#ifndef COSTS_FINISH_MAX
#define COSTS_FINISH_MAX 20000
#endif
static uint32_t costs_v3[COSTS_FINISH_MAX];

/* Pre-generated inputs of one kind (one of these at a time). */
static union {
    struct {
        ef_endpoint_t e0, e1;
    } seg[COSTS_N];
    struct {
        ef_vec3_t v, ui, uo;
        float tol, mi, mo;
    } corner[COSTS_N];
    ct_bprim_t bprim[COSTS_N];
    ct_arcpiece_t piece[COSTS_N];
    ef_move_t measure[COSTS_N];
    ef_prim_t cam[COSTS_CAM_N];
} costs_in;
static ef_move_t costs_moves[COSTS_MOVES_MAX];
static uint32_t costs_nmoves;
static ef_smooth_t costs_sm;
static ef_interp_t costs_ip;

/* Entry points whose stack high-water is reported. */
enum {
    CS_G1,
    CS_G2,
    CS_CORNER,
    CS_PRIMS,
    CS_PRIMS_VALID,
    CS_PIECE,
    CS_MEASURE,
    CS_SSTREAM,
    CS_ISTREAM,
    CS_COUNT
};
static const char *const costs_stack_name[CS_COUNT] = {
    "ef_seg_g1_cubic+ef_seg_g1_cubic_xy",
    "ef_seg_g2_quintic",
    "ef_blend_corner",
    "ef_blend_prims",
    "ef_blend_prims_valid",
    "ef_blend_arc_piece",
    "ef_move_measure",
    "ef_smooth_push+ef_smooth_pull+ef_smooth_finish",
    "ef_interp_push+ef_interp_process"};
static uint32_t costs_stack[CS_COUNT];

static void costs_stack_note(int entry, uint32_t used)
{
    if (used > costs_stack[entry]) {
        costs_stack[entry] = used;
    }
}

static void costs_fail(const char *what, long i, int rc)
{
    char buf[16];
    costs_fails++;
    ef_m4_puts("m4_costs: FAIL ");
    ef_m4_puts(what);
    ef_m4_puts(" call ");
    ef_m4_fmt_u32(buf, (uint32_t)i);
    ef_m4_puts(buf);
    ef_m4_puts(": ");
    ef_m4_puts(ef_err_str(rc));
    ef_m4_puts("\n");
}

/* Shell sort, ascending. */
static void costs_sort(uint32_t *v, uint32_t n)
{
    static const uint32_t gaps[] = {1750u, 701u, 301u, 132u, 57u, 23u, 10u, 4u, 1u};
    for (uint32_t g = 0; g < sizeof gaps / sizeof gaps[0]; g++) {
        uint32_t gap = gaps[g];
        for (uint32_t i = gap; i < n; i++) {
            uint32_t x = v[i], j = i;
            while (j >= gap && v[j - gap] > x) {
                v[j] = v[j - gap];
                j -= gap;
            }
            v[j] = x;
        }
    }
}

static char *costs_cat(char *p, const char *s)
{
    while (*s != '\0') {
        *p++ = *s++;
    }
    *p = '\0';
    return p;
}

/* "cost FUNC n=N min=A median=M max=B ratio=R.RRRR" of the n counts in v (sorted here). */
static void costs_report(const char *func, uint32_t *v, uint32_t n)
{
    char line[160];
    char *p = costs_cat(line, "cost ");
    p = costs_cat(p, func);
    if (n == 0u) {
        ef_m4_puts("m4_costs: FAIL no calls of ");
        ef_m4_puts(func);
        ef_m4_puts("\n");
        costs_fails++;
        return;
    }
    costs_sort(v, n);
    uint32_t med = (n % 2u) != 0u ? v[n / 2u] : (v[n / 2u - 1u] + v[n / 2u]) / 2u;
    p = costs_cat(p, " n=");
    p = ef_m4_fmt_u32(p, n);
    p = costs_cat(p, " min=");
    p = ef_m4_fmt_u32(p, v[0]);
    p = costs_cat(p, " median=");
    p = ef_m4_fmt_u32(p, med);
    p = costs_cat(p, " max=");
    p = ef_m4_fmt_u32(p, v[n - 1u]);
    p = costs_cat(p, " ratio=");
    uint32_t r = v[0] > 0u ? (uint32_t)(((uint64_t)v[n - 1u] * 10000u + v[0] / 2u) / v[0]) : 0u;
    p = ef_m4_fmt_u32(p, r / 10000u);
    *p++ = '.';
    char frac[12];
    ef_m4_fmt_u32(frac, 10000u + r % 10000u); /* 1dddd: keeps the leading zeros */
    p = costs_cat(p, frac + 1);
    costs_cat(p, "\n");
    ef_m4_puts(line);
}

/* ef_seg_g1_cubic_xy (g1_path 1: the coplanar kinds in planes z = const, as bench_ct g1p),
 * ef_seg_g1_cubic (g1_path 2: 3-D data) or ef_seg_g2_quintic (g1_path 0). */
__attribute__((noinline)) static void costs_seg(const char *name, int g1_path)
{
    unsigned long long rs = CT_SEED;
    int g2 = g1_path == 0;
    ct_xy = g1_path == 1;
    for (long i = 0; i < COSTS_N; i++) {
        (void)ct_make_seg(&rs, i, g1_path, g2, &costs_in.seg[i].e0, &costs_in.seg[i].e1);
    }
    const ef_table_t *tbl = g2 ? &ef_tbl_g2_default : &ef_tbl_g1_default;
    ef_seg_t seg;
    ef_seg_xy_t xy;
    ef_m4_stack_paint();
    for (long i = 0; i < COSTS_N; i++) {
        uint32_t t0 = ef_m4_icount_begin();
        int rc = g2 ? ef_seg_g2_quintic(tbl, &costs_in.seg[i].e0, &costs_in.seg[i].e1, &seg)
                 : g1_path == 1
                     ? ef_seg_g1_cubic_xy(tbl, &costs_in.seg[i].e0, &costs_in.seg[i].e1, &xy)
                     : ef_seg_g1_cubic(tbl, &costs_in.seg[i].e0, &costs_in.seg[i].e1, &seg);
        costs_v[i] = ef_m4_icount_end(t0);
        if (rc != EF_OK) {
            costs_fail(name, i, rc);
        }
    }
    costs_stack_note(g2 ? CS_G2 : CS_G1, ef_m4_stack_used());
    costs_report(name, costs_v, COSTS_N);
}

__attribute__((noinline)) static void costs_corner(void)
{
    unsigned long long rs = CT_SEED;
    for (long i = 0; i < COSTS_N; i++) {
        ct_make_corner(&rs, i, &costs_in.corner[i].v, &costs_in.corner[i].ui,
                       &costs_in.corner[i].uo, &costs_in.corner[i].tol, &costs_in.corner[i].mi,
                       &costs_in.corner[i].mo);
    }
    ef_blend_t bl;
    ef_m4_stack_paint();
    for (long i = 0; i < COSTS_N; i++) {
        uint32_t t0 = ef_m4_icount_begin();
        int rc = ef_blend_corner(&ef_tbl_g2_default, costs_in.corner[i].v, costs_in.corner[i].ui,
                                 costs_in.corner[i].uo, costs_in.corner[i].tol,
                                 costs_in.corner[i].mi, costs_in.corner[i].mo, &bl);
        costs_v[i] = ef_m4_icount_end(t0);
        if (rc != EF_OK) {
            costs_fail("ef_blend_corner", i, rc);
        }
    }
    costs_stack_note(CS_CORNER, ef_m4_stack_used());
    costs_report("ef_blend_corner", costs_v, COSTS_N);
}

/* ef_blend_prims() (valid 0) or ef_blend_prims_valid() (valid 1, the smoother's call) on
 * COSTS_N corners of one kind. */
__attribute__((noinline)) static void costs_bprim(const char *name, int kind, int valid)
{
    unsigned long long rs = CT_SEED;
    for (long i = 0; i < COSTS_N; i++) {
        int rc = ct_make_bprim(&rs, kind, &costs_in.bprim[i]);
        if (rc != EF_OK) {
            costs_fail("primitive of ct_make_bprim", i, rc);
        }
    }
    ef_blend_t bl;
    ef_m4_stack_paint();
    for (long i = 0; i < COSTS_N; i++) {
        const ct_bprim_t *c = &costs_in.bprim[i];
        uint32_t t0 = ef_m4_icount_begin();
        int rc = valid
                     ? ef_blend_prims_valid(&ef_tbl_g2_default, c->s_in, &c->in, c->len_in, &c->out,
                                            c->len_out, c->tol, c->max_in, c->max_out, &bl)
                     : ef_blend_prims(&ef_tbl_g2_default, c->s_in, &c->in, c->len_in, &c->out,
                                      c->len_out, c->tol, c->max_in, c->max_out, &bl);
        costs_v[i] = ef_m4_icount_end(t0);
        /* A reversal (turn beyond EF_BLEND_MAX_TURN at an arc end) is valid input too. */
        if (rc != EF_OK && rc != EF_ERR_REVERSAL) {
            costs_fail(name, i, rc);
        }
    }
    costs_stack_note(valid ? CS_PRIMS_VALID : CS_PRIMS, ef_m4_stack_used());
    costs_report(name, costs_v, COSTS_N);
}

__attribute__((noinline)) static void costs_piece(void)
{
    unsigned long long rs = CT_SEED;
    for (long i = 0; i < COSTS_N; i++) {
        int rc = ct_make_arcpiece(&rs, &costs_in.piece[i]);
        if (rc != EF_OK) {
            costs_fail("arc of ct_make_arcpiece", i, rc);
        }
    }
    ef_move_t m;
    ef_m4_stack_paint();
    for (long i = 0; i < COSTS_N; i++) {
        const ct_arcpiece_t *c = &costs_in.piece[i];
        uint32_t t0 = ef_m4_icount_begin();
        int rc = ef_blend_arc_piece(&ef_tbl_g2_default, c->start, &c->pr, c->s0, c->s1, &m);
        costs_v[i] = ef_m4_icount_end(t0);
        if (rc != EF_OK) {
            costs_fail("ef_blend_arc_piece", i, rc);
        }
    }
    costs_stack_note(CS_PIECE, ef_m4_stack_used());
    costs_report("ef_blend_arc_piece", costs_v, COSTS_N);
}

__attribute__((noinline)) static void costs_measure(void)
{
    unsigned long long rs = CT_SEED;
    for (long i = 0; i < COSTS_N; i++) {
        ct_make_measure(&rs, &costs_in.measure[i]);
    }
    ef_m4_stack_paint();
    for (long i = 0; i < COSTS_N; i++) {
        uint32_t t0 = ef_m4_icount_begin();
        int rc = ef_move_measure(&costs_in.measure[i]);
        costs_v[i] = ef_m4_icount_end(t0);
        if (rc != EF_OK) {
            costs_fail("ef_move_measure", i, rc);
        }
    }
    costs_stack_note(CS_MEASURE, ef_m4_stack_used());
    costs_report("ef_move_measure", costs_v, COSTS_N);
}

/* One pull, timed into costs_v2[*np] (moves only: an empty pull is not a move's cost);
 * keeps the move for the interpolator pass when `keep`. Returns 1 when a move came out. */
static int costs_pull(uint32_t *np, int keep)
{
    ef_move_t m;
    uint32_t t0 = ef_m4_icount_begin();
    int rc = ef_smooth_pull(&costs_sm, &m);
    uint32_t n = ef_m4_icount_end(t0);
    if (rc != EF_OK) {
        return 0;
    }
    if (*np < COSTS_CALLS_MAX) {
        costs_v2[(*np)++] = n;
    }
    if (keep && costs_nmoves < COSTS_MOVES_MAX) {
        costs_moves[costs_nmoves++] = m;
    }
    return 1;
}

/* Finish, timed per call into costs_v3[*nf], pulling after each call as the loop in
 * ef_smooth.h does, until everything is built. Returns the last code. */
static int costs_finish(uint32_t *nf, uint32_t *np, int keep)
{
    for (;;) {
        ef_smooth_stats_t t0s = ef_smooth_stats(&costs_sm);
        uint32_t t0 = ef_m4_icount_begin();
        int rc = ef_smooth_finish(&costs_sm);
        uint32_t n = ef_m4_icount_end(t0);
        if (*nf < COSTS_FINISH_MAX) {
            costs_v3[(*nf)++] = n;
        }
        uint32_t pulled = 0;
        while (costs_pull(np, keep)) {
            pulled++;
        }
        if (rc != EF_ERR_FULL) {
            return rc;
        }
        if (!pulled && ef_smooth_stats(&costs_sm).units == t0s.units) {
            return EF_ERR_STATE; /* no progress */
        }
    }
}

/* Record i of a primitive stream: its op (0 push, 1 finish, as golden.h's) and primitive. */
typedef uint32_t (*costs_rec_fn)(uint32_t i, const ef_prim_t **pr);

static uint32_t costs_cam_rec(uint32_t i, const ef_prim_t **pr)
{
    *pr = &costs_in.cam[i];
    return 0u;
}

/* A primitive stream through ef_smooth_push / ef_smooth_pull, pulling after every push (as
 * bench_ct smooth), finishing at the end; `keep`: the moves are kept for the interpolator. */
__attribute__((noinline)) static void costs_stream(const char *tag, costs_rec_fn rec, uint32_t nrec,
                                                   int keep)
{
    ef_smooth_cfg_t cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.g2 = &ef_tbl_g2_default;
    for (int k = 0; k < 3; k++) {
        cfg.lim.v_axis[k] = 200.0f;
        cfg.lim.a_axis[k] = 1000.0f;
    }
    cfg.lim.a_normal_frac = 0.5f;
    cfg.lim.j_max = 20000.0f; /* the CLI's default: jerk-limited ramps cost most */
    cfg.micro_len = 1.0f;
    cfg.micro_turn = 0.35f;
    cfg.smooth_degree = 5;
    int rc = ef_smooth_init(&costs_sm, &cfg, ef_v3(0.0f, 0.0f, 0.0f));
    if (rc != EF_OK) {
        costs_fail("ef_smooth_init", 0, rc);
        return;
    }
    uint32_t npush = 0, npull = 0, nfin = 0;
    if (keep) {
        costs_nmoves = 0;
    }
    ef_m4_stack_paint();
    for (uint32_t i = 0; i < nrec; i++) {
        const ef_prim_t *pr;
        if (rec(i, &pr) != 0u) {
            rc = costs_finish(&nfin, &npull, keep);
            if (rc != EF_OK) {
                costs_fail("ef_smooth_finish", (long)i, rc);
                break;
            }
            continue;
        }
        for (;;) {
            uint32_t t0 = ef_m4_icount_begin();
            rc = ef_smooth_push(&costs_sm, pr);
            uint32_t n = ef_m4_icount_end(t0);
            if (npush < COSTS_CALLS_MAX) {
                costs_v[npush++] = n;
            }
            if (rc != EF_ERR_FULL) {
                break;
            }
            while (costs_pull(&npull, keep)) {
            }
        }
        if (rc != EF_OK) {
            costs_fail(tag, (long)i, rc);
            break;
        }
        while (costs_pull(&npull, keep)) {
        }
    }
    rc = costs_finish(&nfin, &npull, keep);
    if (rc != EF_OK) {
        costs_fail("ef_smooth_finish", 0, rc);
    }
    /* push, pull and finish share one painted stretch: one line for the three (the check
     * compares it with the largest of their bounds). */
    costs_stack_note(CS_SSTREAM, ef_m4_stack_used());
    char name[64];
    costs_cat(costs_cat(name, "ef_smooth_push/"), tag);
    costs_report(name, costs_v, npush);
    costs_cat(costs_cat(name, "ef_smooth_pull/"), tag);
    costs_report(name, costs_v2, npull);
    costs_cat(costs_cat(name, "ef_smooth_finish/"), tag);
    costs_report(name, costs_v3, nfin);
    if (keep && costs_nmoves >= COSTS_MOVES_MAX) {
        ef_m4_puts("m4_costs: more moves than COSTS_MOVES_MAX, the interpolator pass is short\n");
    }
}

/* The CAM-like stream of bench_ct smooth. */
__attribute__((noinline)) static void costs_cam(void)
{
    unsigned long long rs = CT_SEED;
    ct_cam_t cam;
    ct_cam_init(&cam);
    for (long i = 0; i < COSTS_CAM_N; i++) {
        ct_cam_next(&rs, &cam, i, &costs_in.cam[i]);
    }
    costs_stream("cam", costs_cam_rec, COSTS_CAM_N, 1);
}

#ifdef COSTS_PROGS
/* The sample programs' streams, generated on the host by tests/m4/golden_gen.c. */
static const ef_golden_prog_t *costs_prog;

static uint32_t costs_prog_rec(uint32_t i, const ef_prim_t **pr)
{
    *pr = &costs_prog->rec[i].pr;
    return costs_prog->rec[i].op == EF_GOLDEN_FINISH ? 1u : 0u;
}

static void costs_progs(void)
{
    for (uint32_t p = 0; p < ef_golden_nprogs; p++) {
        char tag[48];
        costs_prog = &ef_golden_progs[p];
        /* "prog-NAME": the golden programs include a generated CAM one named cam too. */
        costs_cat(costs_cat(tag, "prog-"), costs_prog->name);
        costs_stream(tag, costs_prog_rec, costs_prog->n, 0);
    }
}
#endif

/* The moves of the CAM stream through the interpolator at a 1 ms servo period, every
 * ef_interp_process() call timed (pushes not included). With `late`, every 50th call comes
 * COSTS_LATE_US late (a missed servo deadline), and only those calls are recorded: in
 * corrected stepping they take the resynchronization path (ef_interp.c: the parameter found
 * by Newton steps with quadrature), whose cost the regular period's figure does not show. */
#define COSTS_LATE_US 10000u
__attribute__((noinline)) static void costs_interp(const char *name, int mode, int late)
{
    int rc = ef_interp_init(&costs_ip, costs_moves[0].b[0], 1000u, mode);
    if (rc != EF_OK || costs_nmoves == 0u) {
        costs_fail(name, 0, rc != EF_OK ? rc : EF_ERR_ARG);
        return;
    }
    /* Up to the last kept move that ends at rest (all of them unless COSTS_MOVES_MAX cut). */
    uint32_t nm = costs_nmoves;
    while (nm > 1u && costs_moves[nm - 1u].v_exit > 0.0f) {
        nm--;
    }
    uint32_t next = 0, k = 0, n = 0, underruns = 0, calls = 0;
    ef_setpoint_t sp;
    ef_m4_stack_paint();
    for (;;) {
        while (k < nm && ef_interp_space(&costs_ip) > 0u) {
            rc = ef_interp_push(&costs_ip, &costs_moves[k]);
            if (rc != EF_OK) {
                costs_fail("ef_interp_push", (long)k, rc);
                return;
            }
            k++;
        }
        uint32_t dt = (late && calls % 50u == 49u) ? COSTS_LATE_US : 1000u;
        calls++;
        uint32_t t0 = ef_m4_icount_begin();
        rc = ef_interp_process(&costs_ip, dt, &next, &sp);
        uint32_t c = ef_m4_icount_end(t0);
        if (rc == EF_ERR_UNDERRUN) {
            underruns++;
        } else if (rc != EF_OK) {
            costs_fail(name, (long)n, rc);
            return;
        }
        int keep = !late || dt != 1000u;
        if (keep && sp.moving && n < COSTS_CALLS_MAX) { /* periods of motion, not the idle end */
            costs_v[n++] = c;
        }
        if (k == nm && !sp.moving) {
            break;
        }
    }
    costs_stack_note(CS_ISTREAM, ef_m4_stack_used());
    if (underruns != 0u) {
        ef_m4_put_u32("m4_costs: FAIL interpolator underruns: ", underruns);
        costs_fails++;
    }
    costs_report(name, costs_v, n);
}

int main(void)
{
    ef_m4_puts("m4_costs: instructions per call on the Cortex-M4F (QEMU icount), inputs of "
               "tests/bench/ct_cases.h\n");
    ef_m4_icount_calibrate();
    int rc = ef_table_check(&ef_tbl_g1_default);
    if (rc == EF_OK) {
        rc = ef_table_check(&ef_tbl_g2_default);
    }
    if (rc != EF_OK) {
        costs_fail("ef_table_check", 0, rc);
        return 1;
    }
    costs_seg("ef_seg_g1_cubic_xy", 1);
    costs_seg("ef_seg_g1_cubic/3d", 2);
    costs_seg("ef_seg_g2_quintic", 0);
    costs_corner();
    costs_bprim("ef_blend_prims/line-arc", CT_BPRIM_LA, 0);
    costs_bprim("ef_blend_prims/arc-line", CT_BPRIM_AL, 0);
    costs_bprim("ef_blend_prims/arc-arc", CT_BPRIM_AA, 0);
    costs_bprim("ef_blend_prims/helix-helix", CT_BPRIM_HH, 0);
    costs_bprim("ef_blend_prims_valid/line-arc", CT_BPRIM_LA, 1);
    costs_bprim("ef_blend_prims_valid/arc-line", CT_BPRIM_AL, 1);
    costs_bprim("ef_blend_prims_valid/arc-arc", CT_BPRIM_AA, 1);
    costs_bprim("ef_blend_prims_valid/helix-helix", CT_BPRIM_HH, 1);
    costs_piece();
    costs_measure();
    costs_cam();
#ifdef COSTS_PROGS
    costs_progs();
#else
    ef_m4_puts("m4_costs: no sample programs compiled in (golden_progs.c not generated)\n");
#endif
    costs_interp("ef_interp_process/uniform", EF_STEP_UNIFORM, 0);
    costs_interp("ef_interp_process/corrected", EF_STEP_CORRECTED, 0);
    costs_interp("ef_interp_process/corrected-late", EF_STEP_CORRECTED, 1);
    for (int e = 0; e < CS_COUNT; e++) {
        ef_m4_puts("stack ");
        ef_m4_puts(costs_stack_name[e]);
        ef_m4_put_u32(" used=", costs_stack[e]);
    }
    if (ef_m4_stack_intact() != 0) {
        ef_m4_puts("m4_costs: FAIL stack overflow (bottom paint gone)\n");
        costs_fails++;
    }
    if (costs_fails != 0) {
        ef_m4_put_u32("m4_costs: FAILED: ", (uint32_t)costs_fails);
        return 1;
    }
    ef_m4_puts("m4_costs: ok\n");
    return 0;
}
