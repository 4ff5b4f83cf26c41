/* SPDX-License-Identifier: Apache-2.0 */
/*
 * The golden cases (golden.h): the same source runs on the Cortex-M4F under QEMU and on the
 * host, and each case's digest must be the same bits on both.
 *
 * Inputs come from an integer PRNG (xorshift32) turned into floats by exact operations
 * (a 24-bit integer times a power of two, then float arithmetic, which IEEE 754 makes the
 * same on both sides while nothing is contracted into a fused multiply-add), so both sides
 * feed the library identical bits. Digests are FNV-1a over 32-bit words: every float's bit
 * pattern and every integer and status, field by field in the order below (never raw
 * structs: padding is not data).
 *
 * Freestanding like the firmware: no stdio, no libm; the console is ef_golden_puts().
 */
#include "golden.h"
#include <stdint.h>
#include <string.h>
#include "evenfeed/blend/ef_blend.h"
#include "evenfeed/canopen/ef_codrive.h"
#include "evenfeed/canopen/ef_comaster.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/drive/ef_drive.h"
#include "evenfeed/modbus/ef_modbus.h"
#include "evenfeed/motion/ef_interp.h"
#include "evenfeed/motion/ef_smooth.h"
#include "evenfeed/seg/ef_seg.h"
#include "evenfeed/table/ef_table.h"

extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;

/* ------------------------------------------------------------------ digest and output */

static uint32_t gd_h = 2166136261u; /* FNV-1a state of the running case */
static uint32_t gd_cases;           /* cases printed */
static int gd_fail;                 /* a case could not run */

static void gd_u(uint32_t v)
{
    for (int i = 0; i < 4; i++) {
        gd_h ^= (v >> (8 * i)) & 0xFFu;
        gd_h *= 16777619u;
    }
}

static void gd_i(int v)
{
    gd_u((uint32_t)v);
}

static void gd_f(float f)
{
    uint32_t v;
    memcpy(&v, &f, sizeof v);
    gd_u(v);
}

static void gd_v(ef_vec3_t v)
{
    gd_f(v.x);
    gd_f(v.y);
    gd_f(v.z);
}

static char *gd_fmt_u(char *p, uint32_t v)
{
    char tmp[10];
    int n = 0;
    do {
        tmp[n++] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v != 0u);
    while (n > 0)
        *p++ = tmp[--n];
    return p;
}

/* Print "case NAME n=COUNT digest=HEX" and start the next case's digest. */
static void gd_case(const char *name, uint32_t n)
{
    static const char hex[] = "0123456789abcdef";
    char buf[128];
    char *p = buf;
    const char *pre = "case ";
    while (*pre)
        *p++ = *pre++;
    for (uint32_t i = 0; name[i] && i < 64u; i++)
        *p++ = name[i];
    *p++ = ' ';
    *p++ = 'n';
    *p++ = '=';
    p = gd_fmt_u(p, n);
    const char *mid = " digest=";
    while (*mid)
        *p++ = *mid++;
    for (int i = 7; i >= 0; i--)
        *p++ = hex[(gd_h >> (4 * i)) & 0xFu];
    *p++ = '\n';
    *p = '\0';
    ef_golden_puts(buf);
    gd_cases++;
    gd_h = 2166136261u;
}

/* ------------------------------------------------------------------ inputs */

static uint32_t gd_rs;

static void gd_seed(uint32_t s)
{
    gd_rs = s ? s : 1u;
}

static uint32_t gd_rng(void)
{
    gd_rs ^= gd_rs << 13;
    gd_rs ^= gd_rs >> 17;
    gd_rs ^= gd_rs << 5;
    return gd_rs;
}

/* Uniform in [lo, hi): 24 random bits, exactly representable, scaled in float. */
static float gd_uni(float lo, float hi)
{
    float u = (float)(gd_rng() >> 8) * 0x1p-24f;
    return lo + (hi - lo) * u;
}

/* 10^k for k in [lo, hi] times [1, 10): log-uniform-ish magnitudes. */
static float gd_mag(int lo, int hi)
{
    static const float p10[] = {1e-4f, 1e-3f, 1e-2f, 1e-1f, 1.0f, 1e1f, 1e2f, 1e3f, 1e4f};
    int k = lo + (int)(gd_rng() % (uint32_t)(hi - lo + 1));
    return p10[k + 4] * gd_uni(1.0f, 10.0f);
}

static ef_vec3_t gd_unit(int planar)
{
    for (;;) {
        /* one draw per statement: the order in which function arguments are evaluated is
         * unspecified, and x86-64 and Arm GCC do pick different orders */
        float x = gd_uni(-1.0f, 1.0f);
        float y = gd_uni(-1.0f, 1.0f);
        float z = planar ? 0.0f : gd_uni(-1.0f, 1.0f);
        ef_vec3_t v = ef_v3(x, y, z);
        float n2 = ef_v3_dot(v, v);
        if (n2 > 0.01f && n2 <= 1.0f)
            return ef_v3_scale(v, 1.0f / ef_sqrtf(n2));
    }
}

static ef_vec3_t gd_point(float scale)
{
    float x = gd_uni(-scale, scale);
    float y = gd_uni(-scale, scale);
    float z = gd_uni(-scale, scale);
    return ef_v3(x, y, z);
}

static float gd_nan(void)
{
    uint32_t v = 0x7FC00000u;
    float f;
    memcpy(&f, &v, sizeof f);
    return f;
}

/* ------------------------------------------------------------------ hashing results */

static void gd_seg(int rc, const ef_seg_t *s)
{
    gd_i(rc);
    gd_u(s->degree);
    gd_u(s->ndof);
    gd_u(s->flags);
    gd_u(s->clamp);
    for (int i = 0; i < 6; i++)
        gd_v(s->b[i]);
    for (int i = 0; i < 4; i++)
        gd_f(s->dof[i]);
    if (rc == EF_OK) {
        gd_f(s->norm.alpha);
        gd_f(s->norm.beta);
        gd_f(s->norm.k0);
        gd_f(s->norm.k1);
        gd_f(s->norm.chord);
        gd_v(s->norm.e1);
        gd_v(s->norm.t0);
        gd_v(s->norm.t1);
    }
}

static void gd_seg_xy(int rc, const ef_seg_xy_t *s)
{
    gd_i(rc);
    for (int i = 0; i < 4; i++) {
        gd_f(s->x[i]);
        gd_f(s->y[i]);
    }
    gd_f(s->z);
    gd_f(s->dof[0]);
    gd_f(s->dof[1]);
    gd_f(s->alpha);
    gd_f(s->beta);
    gd_u(s->flags);
    gd_u(s->clamp);
}

static void gd_move(const ef_move_t *m)
{
    for (int i = 0; i < 6; i++)
        gd_v(m->b[i]);
    gd_u(m->degree);
    gd_u(m->kind);
    gd_u(m->flags);
    gd_u(m->seq);
    gd_u(m->tag);
    gd_f(m->length);
    gd_f(m->kappa_max);
    gd_v(m->tabs);
    gd_v(m->kabs);
    gd_v(m->kjerk);
    gd_f(m->dev);
    gd_f(m->feed);
    gd_f(m->v_max);
    gd_f(m->a_max);
    gd_f(m->j_max);
    gd_f(m->v_entry);
    gd_f(m->v_exit);
    gd_f(m->duration);
    for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
        gd_f(m->law.dt[k]);
        for (int j = 0; j < EF_TIMELAW_COEFFS; j++)
            gd_f(m->law.c[k][j]);
    }
}

static void gd_blend(int rc, const ef_blend_t *b)
{
    gd_seg(rc, &b->seg);
    gd_v(b->p_in);
    gd_v(b->p_out);
    gd_f(b->trim_in);
    gd_f(b->trim_out);
    gd_f(b->dev);
    gd_f(b->gain);
    gd_f(b->turn);
    gd_u(b->flags);
}

/* ------------------------------------------------------------------ table lookups */

#define GD_N_SEG 10000u

static void gd_case_lookup(void)
{
    gd_seed(0x1001u);
    uint32_t n = 0;
    for (uint32_t i = 0; i < GD_N_SEG; i++, n++) {
        float dof[2] = {0.0f, 0.0f};
        uint32_t fl = 0;
        float a = gd_uni(-4.0f, 4.0f), b = gd_uni(-4.0f, 4.0f);
        int rc = ef_table_lookup_g1(&ef_tbl_g1_default, a, b, dof, &fl);
        gd_i(rc);
        gd_f(dof[0]);
        gd_f(dof[1]);
        gd_u(fl);
    }
    /* the wrong kind of table, a NULL output */
    float d2[2];
    gd_i(ef_table_lookup_g1(&ef_tbl_g2_default, 0.5f, 0.5f, d2, NULL));
    gd_i(ef_table_lookup_g1(&ef_tbl_g1_default, 0.5f, 0.5f, NULL, NULL));
    gd_case("lookup_g1", n + 2u);

    gd_seed(0x1002u);
    n = 0;
    for (uint32_t i = 0; i < GD_N_SEG; i++, n++) {
        float c[4], dof[4] = {0.0f, 0.0f, 0.0f, 0.0f};
        uint32_t fl = 0;
        c[0] = gd_uni(-2.0f, 2.0f);
        c[1] = gd_uni(-2.0f, 2.0f);
        float kr = (i % 4u) == 0u ? 40.0f : 6.0f; /* a quarter far outside the domain */
        c[2] = gd_uni(-kr, kr);
        c[3] = gd_uni(-kr, kr);
        int rc = ef_table_lookup_g2(&ef_tbl_g2_default, c, dof, &fl);
        gd_i(rc);
        for (int k = 0; k < 4; k++)
            gd_f(dof[k]);
        gd_u(fl);
    }
    float c[4] = {0.1f, 0.2f, 0.3f, 0.4f}, d4[4];
    gd_i(ef_table_lookup_g2(&ef_tbl_g1_default, c, d4, NULL));
    gd_i(ef_table_lookup_g2(&ef_tbl_g2_default, NULL, d4, NULL));
    gd_case("lookup_g2", n + 2u);
}

/* ------------------------------------------------------------------ segments */

/* End data of configuration i: planar (even i) or 3-D, chords 1e-3..1e4, coordinates up to
 * 1e4, tangents anywhere (some along the chord), and for G2 normals perpendicular to the
 * tangents with curvature x chord of both signs (some 0 with a zero normal, some beyond the
 * table, a few beyond EF_MAX_NORM_CURVATURE). Every 250th is invalid in one of five ways. */
static void gd_ends(uint32_t i, int g2, ef_endpoint_t *e0, ef_endpoint_t *e1)
{
    int planar = (i & 1u) == 0u;
    float scale = gd_mag(-1, 3);
    ef_vec3_t p0 = gd_point(scale);
    if (planar)
        p0.z = 0.0f;
    float chord = gd_mag(-3, 3);
    ef_vec3_t d = gd_unit(planar);
    e0->p = p0;
    e1->p = ef_v3_axpy(p0, chord, d);
    e0->t = (i % 7u) == 0u ? d : gd_unit(planar);
    e1->t = (i % 11u) == 0u ? d : gd_unit(planar);
    e0->n = ef_v3(0.0f, 0.0f, 0.0f);
    e1->n = e0->n;
    e0->kappa = 0.0f;
    e1->kappa = 0.0f;
    if (g2) {
        ef_endpoint_t *e[2] = {e0, e1};
        for (int k = 0; k < 2; k++) {
            uint32_t r = gd_rng() % 16u;
            if (r == 0u)
                continue; /* straight end: kappa 0, n zero */
            ef_vec3_t n;
            if (planar) {
                n = ef_v3(-e[k]->t.y, e[k]->t.x, 0.0f);
            } else {
                ef_vec3_t w = ef_v3_cross(e[k]->t, gd_unit(0));
                float wn = ef_v3_norm(w);
                if (!(wn > 1e-3f))
                    continue;
                n = ef_v3_scale(w, 1.0f / wn);
            }
            float kc = r < 3u ? gd_uni(-30.0f, 30.0f) : gd_uni(-4.0f, 4.0f);
            if (r == 3u && (i % 50u) == 0u)
                kc = 1500.0f; /* beyond EF_MAX_NORM_CURVATURE: EF_ERR_DOMAIN */
            e[k]->n = n;
            e[k]->kappa = kc / chord;
        }
    }
    if ((i % 250u) == 125u) {
        switch ((i / 250u) % 5u) {
        case 0:
            e0->p.y = gd_nan();
            break;
        case 1:
            e1->t = ef_v3(0.0f, 0.0f, 0.0f);
            break;
        case 2:
            e1->p = e0->p;
            break;
        case 3:
            e0->t = ef_v3_scale(e0->t, 1.01f);
            break;
        default:
            e0->n = e0->t;
            e0->kappa = 1.0f;
            break;
        }
    }
}

/* Debugging a mismatch: build both sides with -DGD_TRACE to print the running digest after
 * every item of the segment and blend cases, then diff the two outputs. */
static void gd_trace(uint32_t i)
{
#ifdef GD_TRACE
    char buf[32];
    char *p = gd_fmt_u(buf, i);
    *p++ = ' ';
    p = gd_fmt_u(p, gd_h);
    *p++ = '\n';
    *p = '\0';
    ef_golden_puts(buf);
#else
    (void)i;
#endif
}

static void gd_case_seg(void)
{
    static ef_seg_t s;
    ef_endpoint_t e0, e1;
    gd_seed(0x2001u);
    for (uint32_t i = 0; i < GD_N_SEG; i++) {
        gd_ends(i, 0, &e0, &e1);
        memset(&s, 0, sizeof s);
        gd_seg(ef_seg_g1_cubic(&ef_tbl_g1_default, &e0, &e1, &s), &s);
        gd_trace(i);
    }
    memset(&s, 0, sizeof s);
    gd_seg(ef_seg_g1_cubic(&ef_tbl_g2_default, &e0, &e1, &s), &s);
    gd_case("seg_g1_cubic", GD_N_SEG + 1u);

    /* the planar path on the same end data (the 3-D ones read as their x, y and e0's z) */
    static ef_seg_xy_t xy;
    gd_seed(0x2001u);
    for (uint32_t i = 0; i < GD_N_SEG; i++) {
        gd_ends(i, 0, &e0, &e1);
        memset(&xy, 0, sizeof xy);
        gd_seg_xy(ef_seg_g1_cubic_xy(&ef_tbl_g1_default, &e0, &e1, &xy), &xy);
        gd_trace(i);
    }
    gd_case("seg_g1_cubic_xy", GD_N_SEG);

    gd_seed(0x2002u);
    for (uint32_t i = 0; i < GD_N_SEG; i++) {
        gd_ends(i, 1, &e0, &e1);
        memset(&s, 0, sizeof s);
        gd_seg(ef_seg_g2_quintic(&ef_tbl_g2_default, &e0, &e1, &s), &s);
        gd_trace(i);
    }
    memset(&s, 0, sizeof s);
    gd_seg(ef_seg_g2_quintic(&ef_tbl_g1_default, &e0, &e1, &s), &s);
    gd_case("seg_g2_quintic", GD_N_SEG + 1u);
}

/* ------------------------------------------------------------------ blends */

#define GD_N_CORNER 4000u

static void gd_case_corner(void)
{
    static ef_blend_t b;
    gd_seed(0x3001u);
    for (uint32_t i = 0; i < GD_N_CORNER; i++) {
        int planar = (i % 3u) == 0u;
        ef_vec3_t v = gd_point(gd_mag(-1, 3));
        ef_vec3_t ui = gd_unit(planar), uo;
        uint32_t r = i % 10u;
        ef_vec3_t w = gd_unit(planar);
        if (r == 0u) { /* nearly straight */
            float e = gd_mag(-4, -2);
            uo = ef_v3_axpy(ui, e, w);
        } else if (r == 1u) { /* nearly reversed */
            float e = gd_mag(-4, -1);
            uo = ef_v3_axpy(ef_v3_scale(ui, -1.0f), e, w);
        } else {
            uo = w;
        }
        float un = ef_v3_norm(uo);
        uo = un > 0.0f ? ef_v3_scale(uo, 1.0f / un) : ui;
        float tol = gd_mag(-4, -1);
        float mi = gd_mag(-3, 1), mo = gd_mag(-3, 1);
        if ((i % 200u) == 7u)
            tol = -tol;
        if ((i % 200u) == 17u)
            ui = ef_v3_scale(ui, 0.5f);
        if ((i % 200u) == 27u)
            mo = gd_nan();
        memset(&b, 0, sizeof b);
        gd_blend(ef_blend_corner(&ef_tbl_g2_default, v, ui, uo, tol, mi, mo, &b), &b);
    }
    gd_case("blend_corner", GD_N_CORNER);
}

/* Plane basis of an arc about axis kind a (0: +z, G17; 1: +y, G18; 2: +x, G19): positive
 * sweep turns ea towards eb. */
static void gd_basis(uint32_t a, ef_vec3_t *ax, ef_vec3_t *ea, ef_vec3_t *eb)
{
    if (a == 0u) {
        *ax = ef_v3(0.0f, 0.0f, 1.0f);
        *ea = ef_v3(1.0f, 0.0f, 0.0f);
        *eb = ef_v3(0.0f, 1.0f, 0.0f);
    } else if (a == 1u) {
        *ax = ef_v3(0.0f, 1.0f, 0.0f);
        *ea = ef_v3(0.0f, 0.0f, 1.0f);
        *eb = ef_v3(1.0f, 0.0f, 0.0f);
    } else {
        *ax = ef_v3(1.0f, 0.0f, 0.0f);
        *ea = ef_v3(0.0f, 1.0f, 0.0f);
        *eb = ef_v3(0.0f, 0.0f, 1.0f);
    }
}

/* A point of the unit circle without trigonometry (the rational parametrization with
 * t = tan(theta / 2)) and its angle. */
static ef_vec3_t gd_circ(float t, float *theta)
{
    float d = 1.0f + t * t;
    float c = (1.0f - t * t) / d, s = 2.0f * t / d;
    *theta = ef_atan2f(s, c);
    return ef_v3(c, s, 0.0f);
}

/* An arc (or helix when rise != 0) of radius r about axis kind a. at_end: it ends at v
 * (start returned in *start); else it starts at v. dir +1 / -1. */
static void gd_arc(ef_vec3_t v, int at_end, uint32_t a, float r, float rise, int dir, ef_prim_t *pr,
                   ef_vec3_t *start)
{
    ef_vec3_t ax, ea, eb;
    gd_basis(a, &ax, &ea, &eb);
    float th0, th1;
    ef_vec3_t c0 = gd_circ(gd_uni(-3.0f, 3.0f), &th0);
    ef_vec3_t c1 = gd_circ(gd_uni(-3.0f, 3.0f), &th1);
    float sw = th1 - th0;
    const float two_pi = 6.2831853f;
    if (dir > 0 && sw <= 0.05f)
        sw += two_pi;
    if (dir < 0 && sw >= -0.05f)
        sw -= two_pi;
    ef_vec3_t off0 = ef_v3_add(ef_v3_scale(ea, r * c0.x), ef_v3_scale(eb, r * c0.y));
    ef_vec3_t off1 = ef_v3_add(ef_v3_scale(ea, r * c1.x), ef_v3_scale(eb, r * c1.y));
    memset(pr, 0, sizeof *pr);
    pr->kind = EF_PRIM_ARC;
    pr->axis = ax;
    pr->sweep = sw;
    pr->feed = gd_uni(5.0f, 100.0f);
    pr->tol = 0.01f;
    if (at_end) {
        ef_vec3_t c = ef_v3_sub(v, off1); /* centre at v's height */
        *start = ef_v3_axpy(ef_v3_add(c, off0), -rise, ax);
        pr->centre = ef_v3_axpy(c, -rise, ax);
        pr->end = v;
    } else {
        ef_vec3_t c = ef_v3_sub(v, off0);
        *start = v;
        pr->centre = c;
        pr->end = ef_v3_axpy(ef_v3_add(c, off1), rise, ax);
    }
}

#define GD_N_PRIMS 2000u

static void gd_case_prims(void)
{
    static ef_blend_t b;
    static ef_move_t m;
    uint32_t npieces = 0;
    uint32_t hp = 0; /* digest of the arc pieces, folded in at the end of their case */
    gd_seed(0x4001u);
    for (uint32_t i = 0; i < GD_N_PRIMS; i++) {
        uint32_t kinds = i % 4u; /* 0 line-arc, 1 arc-line, 2 arc-arc, 3 helix ends */
        ef_vec3_t v = gd_point(gd_mag(-1, 2));
        float r0 = gd_mag(-1, 1), r1 = gd_mag(-1, 1);
        float rise0 = kinds == 3u ? gd_uni(-2.0f, 2.0f) : 0.0f;
        float rise1 = kinds == 3u ? gd_uni(-2.0f, 2.0f) : 0.0f;
        uint32_t a0 = gd_rng() % 3u, a1 = (i % 5u) == 0u ? a0 : gd_rng() % 3u;
        int d0 = (gd_rng() & 1u) ? 1 : -1, d1 = (gd_rng() & 1u) ? 1 : -1;
        ef_prim_t in, out;
        ef_vec3_t start_in, s_out;
        if (kinds == 0u) {
            memset(&in, 0, sizeof in);
            in.kind = EF_PRIM_LINE;
            in.end = v;
            in.feed = 50.0f;
            float l = gd_mag(-1, 1);
            start_in = ef_v3_axpy(v, -l, gd_unit(0));
        } else {
            gd_arc(v, 1, a0, r0, rise0, d0, &in, &start_in);
        }
        if (kinds == 1u) {
            memset(&out, 0, sizeof out);
            out.kind = EF_PRIM_LINE;
            out.feed = 50.0f;
            ef_vec3_t u = gd_unit(0);
            if ((i % 3u) == 0u) { /* tangent to the incoming arc: a tangent join */
                ef_frame_t f;
                float li;
                (void)ef_prim_check(start_in, &in, &li);
                (void)ef_prim_frame(start_in, &in, li, &f);
                u = f.t;
            }
            out.end = ef_v3_axpy(v, gd_mag(-1, 1), u);
        } else {
            gd_arc(v, 0, a1, r1, rise1, d1, &out, &s_out);
        }
        out.tol = gd_mag(-3, -1);
        float len_in = 0.0f, len_out = 0.0f;
        int rci = ef_prim_check(start_in, &in, &len_in);
        int rco = ef_prim_check(v, &out, &len_out);
        gd_i(rci);
        gd_i(rco);
        gd_f(len_in);
        gd_f(len_out);
        if (rci != EF_OK || rco != EF_OK)
            continue;
        float mi = len_in * gd_uni(0.1f, 0.5f), mo = len_out * gd_uni(0.1f, 0.5f);
        memset(&b, 0, sizeof b);
        gd_blend(ef_blend_prims(&ef_tbl_g2_default, start_in, &in, len_in, &out, len_out, out.tol,
                                mi, mo, &b),
                 &b);
        if (out.kind == EF_PRIM_ARC) {
            /* a piece of the outgoing arc: at most a quarter turn */
            float sw = ef_fabsf(out.sweep);
            float lmax = len_out * ef_minf(1.0f, 1.5f / sw);
            float s0 = gd_uni(0.0f, len_out - 0.5f * lmax);
            float s1 = ef_minf(len_out, s0 + lmax * gd_uni(0.05f, 1.0f));
            uint32_t hsave = gd_h;
            gd_h = hp;
            memset(&m, 0, sizeof m);
            gd_i(ef_blend_arc_piece(&ef_tbl_g2_default, v, &out, s0, s1, &m));
            gd_move(&m);
            hp = gd_h;
            gd_h = hsave;
            npieces++;
        }
    }
    gd_case("blend_prims", GD_N_PRIMS);
    gd_h = hp;
    gd_case("blend_arc_piece", npieces);
}

/* ------------------------------------------------------------------ the chain */

static ef_smooth_t gd_sm;
static ef_interp_t gd_ip;

/* Moves of one program kept for the drive-side cases (the first, up to a restart). */
#define GD_KEEP 160u
static ef_move_t gd_keep[GD_KEEP];
static uint32_t gd_nkeep;
static int gd_keeping;

typedef struct {
    uint32_t moves, setpoints, refused;
} gd_chain_t;

static int gd_chain_init(const ef_smooth_cfg_t *cfg, int mode, ef_vec3_t p)
{
    int rc = ef_smooth_init(&gd_sm, cfg, p);
    gd_i(rc);
    int rc2 = ef_interp_init(&gd_ip, p, 1000u, mode);
    gd_i(rc2);
    return rc != EF_OK || rc2 != EF_OK;
}

/* Step the interpolator until its queue has room (until 0), until at rest (1), or until at
 * rest or dry (2). */
static int gd_interp_run(gd_chain_t *c, int until)
{
    for (uint32_t guard = 0; guard < 10000000u; guard++) {
        if (until == 0 && ef_interp_space(&gd_ip) > 0u)
            return 0;
        ef_setpoint_t sp;
        uint32_t next = 0;
        int rc = ef_interp_process(&gd_ip, 1000u, &next, &sp);
        gd_i(rc);
        if (rc == EF_ERR_UNDERRUN && until == 2)
            return 0;
        if (rc != EF_OK)
            return 1;
        c->setpoints++;
        gd_v(sp.p);
        gd_f(sp.v_plan);
        gd_u(sp.seq);
        gd_u(sp.tag);
        gd_u(sp.moving);
        gd_u(next);
        if (until != 0 && !sp.moving && ef_interp_space(&gd_ip) == EF_INTERP_QUEUE)
            return 0;
    }
    return 1;
}

static int gd_drain(gd_chain_t *c)
{
    ef_move_t m;
    while (ef_smooth_pull(&gd_sm, &m) == EF_OK) {
        c->moves++;
        gd_move(&m);
        if (gd_keeping && gd_nkeep < GD_KEEP)
            gd_keep[gd_nkeep++] = m;
        int rc;
        while ((rc = ef_interp_push(&gd_ip, &m)) == EF_ERR_FULL)
            if (gd_interp_run(c, 0))
                return 1;
        gd_i(rc);
        if (rc != EF_OK)
            return 1;
    }
    return 0;
}

/* Finish (one work unit a call), draining in between, until everything is built; its last
 * code goes into the digest. A call with no progress (no unit, no move) fails. */
static int gd_finish(gd_chain_t *c)
{
    for (;;) {
        ef_smooth_stats_t t0 = ef_smooth_stats(&gd_sm);
        int rc = ef_smooth_finish(&gd_sm);
        if (gd_drain(c))
            return 1;
        if (rc != EF_ERR_FULL) {
            gd_i(rc);
            return rc != EF_OK;
        }
        ef_smooth_stats_t t1 = ef_smooth_stats(&gd_sm);
        if (t1.units == t0.units && t1.moves == t0.moves)
            return 1;
    }
}

static void gd_stats(void)
{
    ef_smooth_stats_t st = ef_smooth_stats(&gd_sm);
    gd_u(st.prims);
    gd_u(st.moves);
    gd_u(st.blends);
    gd_u(st.straight);
    gd_u(st.stops);
    gd_u(st.reversals);
    gd_u(st.slow_corners);
    gd_u(st.merged);
    gd_u(st.smooth);
    gd_u(st.arc_pieces);
    gd_f(st.dev_max);
}

/* One program through smoother, planner and interpolator (1 ms); variant v picks the
 * limits and the step mode. */
static int gd_chain(const ef_golden_prog_t *pg, uint32_t v, gd_chain_t *c)
{
    ef_smooth_cfg_t cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.g2 = &ef_tbl_g2_default;
    cfg.g1 = &ef_tbl_g1_default;
    for (int k = 0; k < 3; k++) {
        cfg.lim.v_axis[k] = 200.0f;
        cfg.lim.a_axis[k] = 1000.0f;
    }
    cfg.lim.j_max = (v % 2u) ? 20000.0f : 0.0f;
    cfg.lim.a_normal_frac = 0.5f;
    cfg.micro_len = 1.0f;
    cfg.micro_turn = 0.35f;
    cfg.smooth_degree = (v % 3u) == 2u ? 3 : 5;
    int mode = (v % 2u) ? EF_STEP_CORRECTED : EF_STEP_UNIFORM;
    memset(c, 0, sizeof *c);
    if (gd_chain_init(&cfg, mode, ef_v3(0.0f, 0.0f, 0.0f)))
        return 1;
    int stop_next = 0;
    for (uint32_t i = 0; i < pg->n; i++) {
        const ef_golden_rec_t *r = &pg->rec[i];
        if (r->op == EF_GOLDEN_FINISH) {
            if (gd_finish(c) || gd_interp_run(c, 1))
                return 1;
            continue;
        }
        ef_prim_t pr = r->pr;
        if (stop_next)
            pr.flags |= EF_PRIM_STOP_BEFORE;
        stop_next = 0;
        int rc;
        while ((rc = ef_smooth_push(&gd_sm, &pr)) == EF_ERR_FULL)
            if (gd_drain(c))
                return 1;
        gd_i(rc);
        if (rc != EF_OK) {
            /* refused: bring what was accepted to rest, start again at its end */
            c->refused++;
            gd_keeping = 0;
            if (gd_finish(c))
                return 1;
            if (gd_interp_run(c, 2))
                return 1;
            gd_stats();
            if (gd_chain_init(&cfg, mode, pr.end))
                return 1;
            stop_next = 1;
            continue;
        }
        if (gd_drain(c))
            return 1;
    }
    if (gd_finish(c) || gd_interp_run(c, 1))
        return 1;
    gd_stats();
    return 0;
}

static void gd_case_chain(void)
{
    for (uint32_t k = 0; k < ef_golden_nprogs; k++) {
        const ef_golden_prog_t *pg = &ef_golden_progs[k];
        gd_chain_t c;
        gd_keeping = k == 0u;
        int rc = gd_chain(pg, k, &c);
        gd_keeping = 0;
        gd_u(c.moves);
        gd_u(c.setpoints);
        gd_u(c.refused);
        char name[64] = "chain_";
        uint32_t j = 6;
        for (const char *s = pg->name; *s && j < sizeof name - 1u; s++)
            name[j++] = *s;
        name[j] = '\0';
        if (rc != 0) {
            gd_fail = 1;
            ef_golden_puts("golden: chain failed: ");
            ef_golden_puts(pg->name);
            ef_golden_puts("\n");
        }
        gd_case(name, c.setpoints);
    }
}

/* ------------------------------------------------------------------ drive model */

static ef_drive_t gd_drv;

static void gd_drive_state(const ef_drive_t *d)
{
    gd_v(d->cmd);
    gd_v(d->cmd_vel);
    gd_v(d->act);
    gd_v(d->act_vel);
    gd_f(d->ferr);
    gd_f(d->ferr_max);
    gd_f(d->rate);
    gd_u(d->state);
    gd_u(d->fault);
    gd_u(d->done_seq);
    gd_u(d->done_any);
    gd_u(d->exec_seq);
    gd_u(d->moving);
    gd_u(d->held);
}

/* How many of the kept moves to run, at most max: up to the last one that ends at rest (a
 * drive that runs out of moves while moving faults with an underrun). */
static uint32_t gd_cut(uint32_t max)
{
    uint32_t n = gd_nkeep < max ? gd_nkeep : max;
    while (n > 0u && (gd_keep[n - 1u].flags & EF_MOVE_STOP_END) == 0u)
        n--;
    return n;
}

/* The kept moves renumbered from 0 (the drives number their segments so). */
static ef_move_t gd_seg_move(uint32_t i)
{
    ef_move_t m = gd_keep[i];
    m.seq = i;
    return m;
}

static void gd_case_drive(void)
{
    ef_servo_cfg_t sc;
    ef_servo_cfg_default(&sc);
    uint32_t ticks = 0, nk = gd_cut(GD_KEEP);
    if (nk == 0u) {
        gd_fail = 1;
        gd_case("drive", 0u);
        return;
    }
    gd_i(ef_drive_init(&gd_drv, &sc, gd_keep[0].b[0], 1000u));
    gd_i(ef_drive_enable(&gd_drv, 1));
    uint32_t pushed = 0;
    int started = 0;
    for (; ticks < 200000u; ticks++) {
        while (pushed < nk && ef_drive_free(&gd_drv) > 0u) {
            ef_move_t m = gd_seg_move(pushed);
            gd_i(ef_drive_push(&gd_drv, &m));
            pushed++;
        }
        if (!started) {
            gd_i(ef_drive_start(&gd_drv));
            started = 1;
        }
        if (ticks == 2000u)
            gd_i(ef_drive_hold(&gd_drv, 1));
        if (ticks == 2600u)
            gd_i(ef_drive_hold(&gd_drv, 0));
        uint32_t next = 0;
        gd_i(ef_drive_process(&gd_drv, 1000u, &next));
        gd_u(next);
        gd_drive_state(&gd_drv);
        if (pushed == nk && gd_drv.done_any == nk && !gd_drv.moving)
            break;
    }
    if (gd_drv.done_any != nk || gd_drv.fault != 0u) {
        gd_fail = 1;
        ef_golden_puts("golden: drive did not execute every segment\n");
    }
    /* then a quick stop on a fresh run of the first moves */
    gd_i(ef_drive_clear(&gd_drv));
    gd_i(ef_drive_init(&gd_drv, &sc, gd_keep[0].b[0], 1000u));
    gd_i(ef_drive_enable(&gd_drv, 1));
    for (uint32_t i = 0; i < nk && ef_drive_free(&gd_drv) > 0u; i++) {
        ef_move_t m = gd_seg_move(i);
        gd_i(ef_drive_push(&gd_drv, &m));
    }
    gd_i(ef_drive_start(&gd_drv));
    for (uint32_t t = 0; t < 3000u; t++, ticks++) {
        if (t == 700u)
            gd_i(ef_drive_quick_stop(&gd_drv));
        uint32_t next = 0;
        gd_i(ef_drive_process(&gd_drv, 1000u, &next));
        gd_drive_state(&gd_drv);
    }
    gd_case("drive", ticks);
}

/* ------------------------------------------------------------------ Modbus device */

static ef_mbdev_t gd_mb;

static void gd_case_modbus(void)
{
    ef_servo_cfg_t sc;
    ef_servo_cfg_default(&sc);
    uint32_t nk = gd_cut(80u);
    if (nk == 0u) {
        gd_fail = 1;
        gd_case("modbus", 0u);
        return;
    }
    uint8_t exc = 0;
    gd_i(ef_mbdev_init(&gd_mb, &sc, gd_keep[0].b[0], 1000u, 0x1234u));
    uint16_t ctl = EF_MB_CTL_ENABLE;
    gd_i(ef_mbdev_write(&gd_mb, EF_MB_REG_CONTROL, 1u, &ctl, &exc));
    gd_u(exc);
    static uint16_t slot[EF_MB_SLOT_WORDS];
    static ef_move_t back;
    uint32_t sent = 0, ticks = 0, done = 0;
    int started = 0;
    for (; ticks < 100000u; ticks++) {
        /* up to two slot writes per tick while the ring has room */
        for (int w = 0; w < 2 && sent < nk; w++) {
            ef_move_t m = gd_seg_move(sent);
            int rc = ef_mb_slot_encode(&m, slot);
            gd_i(rc);
            for (uint32_t k = 0; k < EF_MB_SLOT_WORDS; k++)
                gd_u(slot[k]);
            memset(&back, 0, sizeof back);
            gd_i(ef_mb_slot_decode(slot, &back));
            gd_move(&back);
            uint16_t addr =
                (uint16_t)(EF_MB_REG_SLOT0 + (sent % EF_DRIVE_SLOTS) * EF_MB_SLOT_WORDS);
            rc = ef_mbdev_write(&gd_mb, addr, EF_MB_SLOT_WORDS, slot, &exc);
            gd_i(rc);
            gd_u(exc);
            if (rc == EF_ERR_FULL)
                break;
            sent++;
        }
        if (!started && (sent > 4u || sent == nk)) {
            ctl = EF_MB_CTL_ENABLE | EF_MB_CTL_START;
            gd_i(ef_mbdev_write(&gd_mb, EF_MB_REG_CONTROL, 1u, &ctl, &exc));
            started = 1;
        }
        uint32_t next = 0;
        gd_i(ef_mbdev_process(&gd_mb, 1000u, &next));
        uint16_t regs[32];
        gd_i(ef_mbdev_read(&gd_mb, EF_MB_REG_STATUS, 32u, regs, &exc));
        for (int k = 0; k < 32; k++)
            gd_u(regs[k]);
        done = ef_mb_get_u32(&regs[EF_MB_REG_DONE_COUNT - EF_MB_REG_STATUS]);
        if (sent == nk && done == nk && (regs[0] & EF_MB_ST_MOVING) == 0u)
            break;
    }
    /* a corrupted slot: CRC error and its exception */
    ef_move_t m = gd_seg_move(0);
    (void)ef_mb_slot_encode(&m, slot);
    slot[7] ^= 0x0100u;
    gd_i(ef_mbdev_write(&gd_mb, EF_MB_REG_SLOT0, EF_MB_SLOT_WORDS, slot, &exc));
    gd_u(exc);
    gd_u(done);
    if (done != nk) {
        gd_fail = 1;
        ef_golden_puts("golden: modbus device did not execute every segment\n");
    }
    gd_case("modbus", ticks);
}

/* ------------------------------------------------------------------ CANopen */

/* An in-memory bus: every frame sent by one node is received by all the others, in the
 * order sent; each frame is in the digest as it goes on the bus. Node 0 is the master,
 * 1..3 the drives. */
#define GD_BUSQ    256u
#define GD_DRIVES  3
#define GD_CO_TICK 250u
typedef struct {
    ef_can_frame_t f;
    uint32_t from;
} gd_busf_t;
static gd_busf_t gd_bus[GD_BUSQ];
static uint32_t gd_bus_head, gd_bus_count, gd_frames;
static uint32_t gd_node_ids[1 + GD_DRIVES] = {0u, 1u, 2u, 3u};
static ef_comaster_t gd_master;
static ef_codrive_t gd_codrv[GD_DRIVES];

static int gd_can_send(void *ctx, const ef_can_frame_t *f)
{
    const uint32_t *from = ctx;
    if (gd_bus_count == GD_BUSQ)
        return EF_ERR_AGAIN;
    gd_busf_t *b = &gd_bus[(gd_bus_head + gd_bus_count) % GD_BUSQ];
    b->f = *f;
    b->from = *from;
    gd_bus_count++;
    return EF_OK;
}

static void gd_can_deliver(void)
{
    while (gd_bus_count > 0u) {
        gd_busf_t b = gd_bus[gd_bus_head];
        gd_bus_head = (gd_bus_head + 1u) % GD_BUSQ;
        gd_bus_count--;
        gd_frames++;
        gd_u(b.from);
        gd_u(b.f.id);
        gd_u(b.f.dlc);
        gd_u(b.f.flags);
        for (uint32_t k = 0; k < b.f.dlc && k < EF_CAN_MAX_DLC; k++)
            gd_u(b.f.data[k]);
        if (b.from != 0u)
            gd_i(ef_comaster_rx(&gd_master, &b.f));
        for (uint32_t k = 0; k < GD_DRIVES; k++)
            if (b.from != k + 1u)
                gd_i(ef_codrive_rx(&gd_codrv[k], &b.f));
    }
}

static int gd_co_setup(int mode)
{
    gd_bus_head = gd_bus_count = gd_frames = 0u;
    ef_com_cfg_t mc;
    ef_comaster_cfg_default(&mc, mode);
    mc.n_nodes = GD_DRIVES;
    for (int k = 0; k < GD_DRIVES; k++)
        mc.nodes[k] = (uint8_t)(k + 1);
    ef_can_port_t pm = {gd_can_send, &gd_node_ids[0]};
    int rc = ef_comaster_init(&gd_master, &mc, &pm);
    gd_i(rc);
    const float *home = &gd_keep[0].b[0].x;
    for (int k = 0; k < GD_DRIVES; k++) {
        ef_codrive_cfg_t dc;
        ef_codrive_cfg_default(&dc, (uint8_t)(k + 1));
        dc.home = home[k];
        ef_can_port_t pd = {gd_can_send, &gd_node_ids[k + 1]};
        int r = ef_codrive_init(&gd_codrv[k], &dc, &pd);
        gd_i(r);
        rc |= r;
    }
    return rc != EF_OK;
}

/* One bus tick: everyone's time, then the bus; the drives' positions into the digest. */
static int gd_co_tick(void)
{
    uint32_t next = 0;
    gd_i(ef_comaster_process(&gd_master, GD_CO_TICK, &next));
    gd_u(next);
    for (int k = 0; k < GD_DRIVES; k++) {
        gd_i(ef_codrive_process(&gd_codrv[k], GD_CO_TICK, &next));
        gd_u(next);
    }
    gd_can_deliver();
    for (int k = 0; k < GD_DRIVES; k++) {
        gd_f(ef_codrive_position(&gd_codrv[k]));
        gd_f(gd_codrv[k].drv.cmd.x);
        gd_u(gd_codrv[k].statusword);
    }
    int st = ef_comaster_state(&gd_master);
    gd_i(st);
    return st;
}

/* "golden: LABEL: state S error -C what W node N" for a run that did not end in DONE. */
static void gd_co_report(const char *label)
{
    const ef_com_error_t *e = ef_comaster_error(&gd_master);
    char buf[96], *p = buf;
    const char *parts[] = {" state ", " error -", " what ", " node "};
    uint32_t vals[] = {(uint32_t)ef_comaster_state(&gd_master), (uint32_t)-e->code, e->what,
                       e->node};
    for (int k = 0; k < 4; k++) {
        for (const char *q = parts[k]; *q; q++)
            *p++ = *q;
        p = gd_fmt_u(p, vals[k]);
    }
    *p++ = '\n';
    *p = '\0';
    ef_golden_puts("golden: ");
    ef_golden_puts(label);
    ef_golden_puts(buf);
}

static void gd_co_end(void)
{
    const ef_com_error_t *e = ef_comaster_error(&gd_master);
    gd_i(e->code);
    gd_u(e->what);
    gd_u(e->node);
    for (int k = 0; k < GD_DRIVES; k++) {
        const ef_com_node_t *nd = ef_comaster_node(&gd_master, k);
        gd_f(nd->pos);
        gd_i(nd->pos_inc);
        gd_u(nd->resends);
        gd_u(gd_codrv[k].drv.done_any);
        gd_u(gd_codrv[k].seg_dups);
        gd_u(gd_codrv[k].seg_dropped);
    }
}

static void gd_case_canopen(void)
{
    /* CSP: targets are the interpolator's setpoints over the kept moves */
    uint32_t nk = gd_cut(80u);
    int st = EF_COM_ERROR;
    uint32_t ticks = 0;
    if (nk == 0u || gd_co_setup(EF_COM_MODE_CSP)) {
        gd_fail = 1;
    } else {
        gd_i(ef_interp_init(&gd_ip, gd_keep[0].b[0], 1000u, EF_STEP_UNIFORM));
        uint32_t qi = 0;
        int dry = 0, finished = 0;
        for (; ticks < 400000u; ticks++) {
            st = gd_co_tick();
            if (st == EF_COM_DONE || st == EF_COM_ERROR)
                break;
            if (st != EF_COM_RUN)
                continue;
            while (qi < nk && ef_interp_space(&gd_ip) > 0u) {
                ef_move_t m = gd_keep[qi++];
                gd_i(ef_interp_push(&gd_ip, &m));
            }
            while (!dry && ef_comaster_space(&gd_master) > 0u) {
                ef_setpoint_t sp;
                uint32_t nx;
                int rc = ef_interp_process(&gd_ip, 1000u, &nx, &sp);
                gd_i(rc);
                float pos[3] = {sp.p.x, sp.p.y, sp.p.z};
                gd_i(ef_comaster_push_target(&gd_master, pos));
                if (qi == nk && !sp.moving && ef_interp_space(&gd_ip) == EF_INTERP_QUEUE)
                    dry = 1;
                if (qi < nk && ef_interp_space(&gd_ip) > 0u)
                    break;
            }
            if (dry && !finished) {
                gd_i(ef_comaster_finish(&gd_master));
                finished = 1;
            }
        }
        gd_co_end();
    }
    if (st != EF_COM_DONE) {
        gd_fail = 1;
        gd_co_report("canopen CSP did not finish:");
    }
    gd_u(gd_frames);
    gd_case("canopen_csp", gd_frames);

    /* segment mode: the kept moves streamed, with a feed hold on the way */
    nk = gd_cut(80u);
    st = EF_COM_ERROR;
    if (nk == 0u || gd_co_setup(EF_COM_MODE_SEGMENT)) {
        gd_fail = 1;
    } else {
        uint32_t i = 0, run_ticks = 0;
        for (ticks = 0; ticks < 400000u; ticks++) {
            st = gd_co_tick();
            if (st == EF_COM_DONE || st == EF_COM_ERROR)
                break;
            if (st != EF_COM_RUN && st != EF_COM_FINISH)
                continue;
            run_ticks++;
            while (st == EF_COM_RUN && i < nk && ef_comaster_space(&gd_master) > 0u) {
                ef_move_t m = gd_seg_move(i++);
                gd_i(ef_comaster_push_move(&gd_master, &m));
            }
            if (st == EF_COM_RUN && i == nk)
                gd_i(ef_comaster_finish(&gd_master));
            if (run_ticks == 8000u)
                gd_i(ef_comaster_hold(&gd_master, 1));
            if (run_ticks == 12000u)
                gd_i(ef_comaster_hold(&gd_master, 0));
        }
        gd_co_end();
    }
    if (st != EF_COM_DONE) {
        gd_fail = 1;
        gd_co_report("canopen segment mode did not finish:");
    }
    gd_u(gd_frames);
    gd_case("canopen_segment", gd_frames);
}

/* ------------------------------------------------------------------ all */

int ef_golden_run(void)
{
    gd_case_lookup();
    gd_case_seg();
    gd_case_corner();
    gd_case_prims();
    gd_case_chain();
    gd_case_drive();
    gd_case_modbus();
    gd_case_canopen();
    return gd_fail != 0 || gd_cases == 0u;
}
