/* SPDX-License-Identifier: Apache-2.0 */
/* Canned cycles of the G-code reader (docs/gcode.md "Canned cycles"): G73, G81, G82, G83,
 * G85, G86, G87, G88 and G89 expanded into rapids, feeds, dwells and spindle events as LinuxCNC
 * expands them, in G17 (drilling along Z), G18 (along Y) and G19 (along X), with G98/G99
 * retract, sticky R/Z/Q/P, and L repeats (with G91 steps). The expansion runs in exact-stop
 * mode: a tolerance item "exact" before it and the mode in force restored after it.
 *
 * Per hole, with old the level the tool is at, r the R plane, z the bottom and clear the
 * retract level (r with G99, the initial level or r, whichever is higher, with G98):
 *   rapid across at old; rapid down to r (if old != r); then
 *   G81  feed z, rapid clear                 G82  feed z, dwell P, rapid clear
 *   G73  pecks of Q: feed, rapid up by d; feed z, rapid clear   (d = 0.010 in / 0.254 mm)
 *   G83  pecks of Q: feed, rapid r, rapid to d above the last depth; feed z, rapid clear
 *   G85  feed z, feed r, rapid clear         G89  feed z, dwell P, feed r, rapid clear
 *   G86  feed z, dwell P, spindle stop, rapid clear, spindle on again
 *   G88  feed z, dwell P, spindle stop, program stop (M0), spindle on again; no retract:
 *        LinuxCNC leaves it to the operator, and the next move starts at the bottom
 *   G87  (back boring; the spindle must turn) rapid to the offset point (hole + the plane
 *        offsets, I J in G17), spindle stop oriented, rapid down to z at the offset,
 *        rapid to the hole, spindle on, feed up to the middle level k (the drill axis'
 *        offset letter, K in G17; in G91 relative to z), feed back to z, spindle stop
 *        oriented, rapid to the offset, rapid up to clear, rapid to the hole, spindle on
 * Before the first hole, a tool below r rises to r first. */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "ef_gcode_int.h"

/* Drilling geometry: in-plane axes a, b and the drill axis c (program-frame indices). */
typedef struct {
    int a, b, c;
    char la, lb, lc;
} cy_axes_t;

static cy_axes_t cy_axes(int plane)
{
    cy_axes_t x;
    if (plane == 18) {
        x.a = 2, x.b = 0, x.c = 1, x.la = 'Z', x.lb = 'X', x.lc = 'Y';
    } else if (plane == 19) {
        x.a = 1, x.b = 2, x.c = 0, x.la = 'Y', x.lb = 'Z', x.lc = 'X';
    } else {
        x.a = 0, x.b = 1, x.c = 2, x.la = 'X', x.lb = 'Y', x.lc = 'Z';
    }
    return x;
}

/* A move to program point (a, b, c) of the cycle's axes. */
static int cy_move(ef_gcode_t *r, const cy_axes_t *x, int rapid, double a, double b, double c,
                   uint32_t col)
{
    double p[3], m[3];
    ef_gc_to_prog(r, r->cur, p);
    p[x->a] = a;
    p[x->b] = b;
    p[x->c] = c;
    ef_gc_from_prog(r, p, m);
    return ef_gc_emit_straight(r, rapid, m, NULL, col);
}

/* Spindle on again after a stop inside a cycle, in the direction it had. */
static int cy_spindle_on(ef_gcode_t *r, uint32_t col)
{
    return ef_gc_emit_event(r,
                            r->spindle == 4 ? "M4 (canned cycle: spindle on again)"
                                            : "M3 (canned cycle: spindle on again)",
                            col);
}

int ef_gc_cycle(ef_gcode_t *r, const ef_gc_line_t *L, int motion, int same,
                const ef_gc_word_t *axis[3], double scale, uint32_t col)
{
    cy_axes_t x = cy_axes(r->plane);
    const ef_gc_word_t *wr = ef_gc_get(L, 'R'), *wq = ef_gc_get(L, 'Q'), *wp = ef_gc_get(L, 'P'),
                       *wl = ef_gc_get(L, 'L');
    char g[16];
    int rc, reps = 1;
    snprintf(g, sizeof g, "G%d", motion / 10);
    if (r->inverse_time)
        return ef_gc_err(r, col, "%s canned cycle in G93 inverse-time feed mode", g);
    if (r->diameter)
        return ef_gc_err(r, col, "%s canned cycle in G7 diameter mode", g);
    if (!(r->feed > 0))
        return ef_gc_err(r, col, "%s canned cycle with no feed rate (F missing or zero)", g);
    if (r->rot[r->cs - 1] != 0 && r->plane != 17)
        return ef_gc_err(r, col, "%s in G%d in a rotated coordinate system", g, r->plane);
    /* Sticky words: R and the bottom within the same cycle mode, Q and P within cycles. */
    if (wr) {
        r->cyc_r = wr->v * scale;
    } else if (!same) {
        return ef_gc_err(r, col, "%s needs an R word (retract plane)", g);
    }
    if (axis[x.c]) {
        r->cyc_z = axis[x.c]->v * scale;
    } else if (!same) {
        return ef_gc_err(r, col, "%s needs a %c word (the bottom of the hole)", g, x.lc);
    }
    if (wq) {
        if (!(wq->v > 0))
            return ef_gc_err(r, wq->col, "%s Q (peck depth) must be > 0", g);
        r->cyc_q = wq->v * scale;
        r->cyc_have_q = 1;
    }
    if (wp) {
        if (!(wp->v >= 0))
            return ef_gc_err(r, wp->col, "%s P (dwell) must be >= 0", g);
        r->cyc_p = wp->v;
        r->cyc_have_p = 1;
    }
    if ((motion == 730 || motion == 830) && !r->cyc_have_q)
        return ef_gc_err(r, col, "%s needs a Q word (peck depth)", g);
    /* G87: offsets in the plane (the letters of its axes) and the middle level (the letter
     * of the drill axis), sticky within the cycle mode */
    static const char off_letter[3] = {'I', 'J', 'K'};
    int ia = x.a, ib = x.b, ic = x.c; /* X->I, Y->J, Z->K */
    if (motion == 870) {
        if (r->spindle != 3 && r->spindle != 4)
            return ef_gc_err(r, col, "G87 with the spindle not turning (M3 or M4 first)");
        for (int k = 0; k < 3; k++) {
            const ef_gc_word_t *w = ef_gc_get(L, off_letter[k]);
            if (w) {
                r->cyc_ijk[k] = w->v * scale;
                r->cyc_have_ijk[k] = 1;
            }
        }
        for (int k = 0; k < 3; k++) {
            int idx = k == 0 ? ia : k == 1 ? ib : ic;
            if (!r->cyc_have_ijk[idx])
                return ef_gc_err(r, col, "G87 needs %c %s", off_letter[idx],
                                 k < 2 ? "(offset of the back boring bar)" : "(middle level)");
        }
    }
    if (wl) {
        if (wl->v != floor(wl->v) || wl->v < 1 || wl->v > 10000)
            return ef_gc_err(r, wl->col, "%s L (repeats) must be a whole number 1..10000", g);
        reps = (int)wl->v;
    }
    double dwell = r->cyc_have_p ? r->cyc_p : 0;

    double cp[3];
    ef_gc_to_prog(r, r->cur, cp);
    if (!r->cyc_il_flag) {
        r->cyc_il = cp[x.c];
        r->cyc_il_flag = 1;
    }
    double old = r->cyc_il, aa, bb, da = 0, db = 0, rr, zz;
    if (r->absolute) {
        rr = r->cyc_r;
        zz = r->cyc_z;
        aa = axis[x.a] ? axis[x.a]->v * scale : cp[x.a];
        bb = axis[x.b] ? axis[x.b]->v * scale : cp[x.b];
    } else {
        da = axis[x.a] ? axis[x.a]->v * scale : 0;
        db = axis[x.b] ? axis[x.b]->v * scale : 0;
        rr = r->cyc_r + old;
        zz = rr + r->cyc_z;
        aa = cp[x.a];
        bb = cp[x.b];
    }
    if (rr < zz)
        return ef_gc_err(r, col, "%s R %.4f below the bottom %c %.4f", g, rr / scale, x.lc,
                         zz / scale);
    double pecks = motion == 730 || motion == 830 ? (rr - zz) / r->cyc_q : 0;
    if (pecks > 100000)
        return ef_gc_err(r, col, "%s with %.0f pecks (Q too small for the depth)", g, pecks);

    int exact = r->path_mode == EF_GC_PATH_EXACT;
    if (!exact && (rc = ef_gc_emit_tolerance(r, EF_GC_PATH_EXACT, 0, 0, col)) != 0)
        return rc;
    if (old < rr) { /* first, rise to the R plane where the tool is */
        if ((rc = cy_move(r, &x, 1, cp[x.a], cp[x.b], rr, col)) != 0)
            return rc;
        old = rr;
    }
    double clear = r->retract_r ? rr : old;
    double delta = r->units == 20 ? 0.010 * EF_GC_INCH : 0.254;
    for (int k = 0; k < reps; k++) {
        aa += da;
        bb += db;
        if ((rc = cy_move(r, &x, 1, aa, bb, old, col)) != 0)
            return rc;
        if (old != rr && (rc = cy_move(r, &x, 1, aa, bb, rr, col)) != 0)
            return rc;
        switch (motion) {
        case 730:
        case 830:
            for (double d = rr - r->cyc_q; d > zz; d -= r->cyc_q) {
                if ((rc = cy_move(r, &x, 0, aa, bb, d, col)) != 0)
                    return rc;
                if (motion == 830 && (rc = cy_move(r, &x, 1, aa, bb, rr, col)) != 0)
                    return rc;
                if ((rc = cy_move(r, &x, 1, aa, bb, d + delta, col)) != 0)
                    return rc;
            }
            rc = cy_move(r, &x, 0, aa, bb, zz, col);
            break;
        case 810:
        case 820:
        case 850:
        case 860:
        case 880:
        case 890:
            rc = cy_move(r, &x, 0, aa, bb, zz, col);
            if (!rc && motion != 810 && motion != 850)
                rc = ef_gc_emit_dwell(r, dwell, col);
            if (!rc && (motion == 860 || motion == 880))
                rc = ef_gc_emit_event(r, "M5 (canned cycle: spindle stop)", col);
            if (!rc && motion == 880)
                rc = ef_gc_emit_event(r, "M0 (G88: program stop at the bottom)", col);
            if (!rc && (motion == 850 || motion == 890))
                rc = cy_move(r, &x, 0, aa, bb, rr, col);
            break;
        case 870: {
            double oa = aa + r->cyc_ijk[ia], ob = bb + r->cyc_ijk[ib];
            double mid = r->absolute ? r->cyc_ijk[ic] : zz + r->cyc_ijk[ic];
            static const char *orient = "M5 M19 (G87: spindle stop, oriented)";
            rc = cy_move(r, &x, 1, oa, ob, rr, col);
            if (!rc)
                rc = ef_gc_emit_event(r, orient, col);
            if (!rc)
                rc = cy_move(r, &x, 1, oa, ob, zz, col);
            if (!rc)
                rc = cy_move(r, &x, 1, aa, bb, zz, col);
            if (!rc)
                rc = cy_spindle_on(r, col);
            if (!rc)
                rc = cy_move(r, &x, 0, aa, bb, mid, col);
            if (!rc)
                rc = cy_move(r, &x, 0, aa, bb, zz, col);
            if (!rc)
                rc = ef_gc_emit_event(r, orient, col);
            if (!rc)
                rc = cy_move(r, &x, 1, oa, ob, zz, col);
            if (!rc)
                rc = cy_move(r, &x, 1, oa, ob, clear, col);
            break;
        }
        default:
            rc = ef_gc_err(r, col, "unsupported canned cycle %s", g);
            break;
        }
        if (!rc && motion != 880) /* G88: the operator retracts by hand after the stop */
            rc = cy_move(r, &x, 1, aa, bb, clear, col);
        if (!rc && (motion == 860 || motion == 870 || motion == 880))
            rc = cy_spindle_on(r, col);
        if (rc)
            return rc;
        old = clear;
    }
    if (!exact)
        return ef_gc_emit_tolerance(r, r->path_mode, r->path_p, r->path_q, col);
    return EF_OK;
}
