/* SPDX-License-Identifier: Apache-2.0 */
/* Host pipeline: G-code reader -> streaming smoother -> interpolator, through callbacks
 * (host/include/evenfeed/host/program/ef_pipeline.h, docs/smoothing-cli.md). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "evenfeed/host/program/ef_pipeline.h"

/* Primitives remembered by tag (source line) so moves can be given their tolerance,
 * units and rapid flag; far more than the smoother and planner hold at once. */
#define EF_PIPE_TAGS 1024u
/* Moves remembered by sequence number for the setpoints (the interpolator queues 8). */
#define EF_PIPE_SEQS 64u

typedef struct {
    uint32_t tag;
    ef_pipe_move_info_t mi;
} ef_pipe_tag_t;

typedef struct {
    uint32_t seq;
    int valid;
    float v_max;
    float feed;   /* programmed feed (units/s) */
    int aux_only; /* an auxiliary move: X Y Z still, its speeds in the axes' units */
    ef_pipe_move_info_t mi;
} ef_pipe_seq_t;

typedef struct {
    const ef_pipe_cfg_t *cfg;
    ef_pipe_cb_t cb;
    ef_gcode_t *r;
    ef_smooth_t sm;
    ef_interp_t ip[2];
    ef_setpoint_t prev[2];
    int have_prev[2];
    uint64_t tick[2];
    double sumsq[2];
    double pending_time; /* durations queued in the interpolators since the last rest */
    ef_pipe_tag_t tags[EF_PIPE_TAGS];
    uint32_t ntags;
    ef_pipe_seq_t seqs[EF_PIPE_SEQS];
    ef_pipe_stats_t st;
    double tol, qtol;
    int stop_next;
    int last_rapid; /* the last primitive pushed was a G0 */
    int units_set;
} ef_pipe_t;

#ifndef EF_PIPE_A_NORMAL_FRAC
#define EF_PIPE_A_NORMAL_FRAC 0.5f
#endif

/* Fill a pipeline configuration with the documented defaults (see ef_pipeline.h). */
void ef_pipe_cfg_default(ef_pipe_cfg_t *cfg)
{
    if (!cfg)
        return;
    memset(cfg, 0, sizeof *cfg);
    for (int k = 0; k < 3; k++) {
        cfg->lim.v_axis[k] = 100.0f;
        cfg->lim.a_axis[k] = 1000.0f;
    }
    for (int k = 0; k < EF_AUX; k++) {
        cfg->lim.v_axis[3 + k] = k < 3 ? 90.0f : 100.0f;
        cfg->lim.a_axis[3 + k] = k < 3 ? 900.0f : 1000.0f;
        cfg->aux_tol[k] = 0.02;
    }
    cfg->lim.j_max = 20000.0f;
    cfg->lim.a_normal_frac = EF_PIPE_A_NORMAL_FRAC;
    cfg->tol_default = 0.02;
    cfg->qtol_default = 0.0;
    cfg->micro_len = 1.0;
    cfg->micro_turn = 0.35;
    cfg->smooth_degree = 5;
    cfg->rapid_speed = 100.0;
    cfg->period_us = 1000;
    cfg->step_mode = EF_STEP_CORRECTED;
    cfg->interp_modes = 0;
}

/* Name of a move kind for JSON and messages (see ef_pipeline.h). */
const char *ef_pipe_move_kind_name(int kind)
{
    switch (kind) {
    case EF_MOVE_LINE:
        return "line";
    case EF_MOVE_ARC:
        return "arc";
    case EF_MOVE_BLEND:
        return "blend";
    case EF_MOVE_SMOOTH:
        return "smooth";
    default:
        return "?";
    }
}

/* Convert a G-code path item to a firmware primitive in mm/s (see ef_pipeline.h). */
int ef_pipe_item_prim(const ef_gcode_item_t *it, double rapid_speed, ef_prim_t *pr)
{
    if (!it || !pr)
        return EF_ERR_ARG;
    memset(pr, 0, sizeof *pr);
    pr->end = ef_v3((float)it->end[0], (float)it->end[1], (float)it->end[2]);
    switch (it->kind) {
    case EF_GC_RAPID:
        pr->kind = EF_PRIM_LINE;
        pr->feed = (float)rapid_speed;
        return EF_OK;
    case EF_GC_LINE:
        pr->kind = EF_PRIM_LINE;
        pr->feed = (float)(it->feed / 60.0);
        return EF_OK;
    case EF_GC_ARC:
        pr->kind = EF_PRIM_ARC;
        pr->feed = (float)(it->feed / 60.0);
        pr->centre = ef_v3((float)it->centre[0], (float)it->centre[1], (float)it->centre[2]);
        pr->sweep = (float)it->sweep;
        if (it->plane == 17)
            pr->axis = ef_v3(0.0f, 0.0f, 1.0f);
        else if (it->plane == 18)
            pr->axis = ef_v3(0.0f, 1.0f, 0.0f);
        else if (it->plane == 19)
            pr->axis = ef_v3(1.0f, 0.0f, 0.0f);
        else
            return EF_ERR_ARG;
        return EF_OK;
    default:
        return EF_ERR_ARG;
    }
}

/* Q in force for G64 with tolerance tol and Q word q (0: not given): the word, else the
 * configured default, else P itself (LinuxCNC's default); the firmware caps the band at
 * EF_SMOOTH_BAND_SHARE x P. */
static double pipe_qtol(const ef_pipe_cfg_t *c, double tol, double q)
{
    if (q > 0)
        return q;
    return c->qtol_default > 0 ? c->qtol_default : tol;
}

/* What is known about the primitive with this tag (newest first). */
static ef_pipe_move_info_t pipe_tag_info(const ef_pipe_t *P, uint32_t tag)
{
    uint32_t n = P->ntags < EF_PIPE_TAGS ? P->ntags : EF_PIPE_TAGS;
    for (uint32_t k = 0; k < n; k++) {
        const ef_pipe_tag_t *t = &P->tags[(P->ntags - 1 - k) % EF_PIPE_TAGS];
        if (t->tag == tag)
            return t->mi;
    }
    ef_pipe_move_info_t none = {P->tol, P->st.units, 0};
    return none;
}

/* What is remembered about move seq for its setpoints; NULL once overwritten. */
static const ef_pipe_seq_t *pipe_seq_info(const ef_pipe_t *P, uint32_t seq)
{
    const ef_pipe_seq_t *s = &P->seqs[seq % EF_PIPE_SEQS];
    return s->valid && s->seq == seq ? s : NULL;
}

/* A callback's nonzero result ends the run. */
static int pipe_cb_fail(ef_msg_t *m, int rc, const char *what)
{
    return ef_fail(m, rc < 0 ? rc : EF_ERR_ARG, "%s callback stopped the run (%d)", what, rc);
}

/* One servo period of interpolator k: setpoint, feed fluctuation, callback. */
static int pipe_step(ef_pipe_t *P, int k, ef_msg_t *m)
{
    ef_setpoint_t sp;
    int rc = ef_interp_process(&P->ip[k], P->cfg->period_us, NULL, &sp);
    ef_pipe_fluct_t *fl = &P->st.fl[k];
    if (rc == EF_ERR_UNDERRUN)
        fl->underruns++;
    else if (rc != EF_OK)
        return ef_fail(m, rc, "interpolator: %s", ef_err_str(rc));
    P->tick[k]++;
    fl->setpoints++;
    double dt = P->cfg->period_us * 1e-6;
    double t = (double)P->tick[k] * dt;
    fl->end_time = t;
    const ef_pipe_seq_t *si = pipe_seq_info(P, sp.seq);
    if (P->have_prev[k] && P->prev[k].moving && sp.moving && si && !si->aux_only) {
        double dx = (double)sp.p.x - P->prev[k].p.x, dy = (double)sp.p.y - P->prev[k].p.y;
        double dz = (double)sp.p.z - P->prev[k].p.z;
        double vm = sqrt(dx * dx + dy * dy + dz * dz) / dt;
        double vref = 0.5 * ((double)P->prev[k].v_plan + sp.v_plan);
        if (fabs(vm - vref) > fl->max_abs)
            fl->max_abs = fabs(vm - vref);
        if (vref > 0 && vref >= EF_PIPE_FLUCT_FEED_SHARE * si->feed) {
            double rel = fabs(vm - vref) / vref;
            fl->samples_feed++;
            if (rel > fl->max_rel_feed) {
                fl->max_rel_feed = rel;
                fl->max_line_feed = sp.tag;
            }
        }
        if (vref > 0 && vref >= EF_PIPE_FLUCT_VMIN_FRAC * si->v_max) {
            double rel = fabs(vm - vref) / vref;
            fl->samples++;
            P->sumsq[k] += rel * rel;
            fl->rms_rel = sqrt(P->sumsq[k] / (double)fl->samples);
            if (rel > fl->max_rel) {
                fl->max_rel = rel;
                fl->max_line = sp.tag;
            }
        }
    }
    P->prev[k] = sp;
    P->have_prev[k] = 1;
    if (k == P->cfg->step_mode && P->cb.on_setpoint) {
        ef_pipe_move_info_t none = {P->tol, P->st.units, 0};
        rc = P->cb.on_setpoint(P->cb.user, t, &sp, si ? &si->mi : &none);
        if (rc)
            return pipe_cb_fail(m, rc, "setpoint");
    }
    return EF_OK;
}

/* A move pulled from the smoother: statistics, callback, interpolators. */
static int pipe_move(ef_pipe_t *P, const ef_move_t *mv, ef_msg_t *m)
{
    ef_pipe_move_info_t mi = pipe_tag_info(P, mv->tag);
    ef_pipe_stats_t *st = &P->st;
    st->moves++;
    if (mv->kind >= 1 && mv->kind <= 4)
        st->moves_kind[mv->kind]++;
    if (!(mv->flags & EF_MOVE_AUX_ONLY))
        st->length += mv->length; /* the X Y Z path */
    st->cycle_time += mv->duration;
    if (mi.rapid)
        st->rapid_time += mv->duration;
    if (mv->dev > st->dev_max || st->moves == 1) {
        st->dev_max = mv->dev;
        st->dev_max_tol = mi.tol;
        st->dev_max_line = mv->tag;
    }
    if (mv->dev > mi.tol + 1e-6)
        st->dev_over++;
    ef_vec3_t e = mv->b[mv->degree <= 5 ? mv->degree : 5];
    st->end[0] = e.x;
    st->end[1] = e.y;
    st->end[2] = e.z;
    ef_pipe_seq_t *s = &P->seqs[mv->seq % EF_PIPE_SEQS];
    s->seq = mv->seq;
    s->valid = 1;
    s->v_max = mv->v_max;
    s->feed = mv->feed;
    s->aux_only = (mv->flags & EF_MOVE_AUX_ONLY) != 0;
    s->mi = mi;
    if (P->cb.on_move) {
        int rc = P->cb.on_move(P->cb.user, mv, &mi);
        if (rc)
            return pipe_cb_fail(m, rc, "move");
    }
    for (int k = 0; k < 2; k++) {
        if (!(P->cfg->interp_modes & (1u << k)))
            continue;
        int rc;
        while ((rc = ef_interp_push(&P->ip[k], mv)) == EF_ERR_FULL) {
            rc = pipe_step(P, k, m);
            if (rc)
                return rc;
        }
        if (rc)
            return ef_fail(m, rc, "%s:%u: interpolator refused move %u: %s", P->r->name,
                           (unsigned)mv->tag, (unsigned)mv->seq, ef_err_str(rc));
    }
    P->pending_time += mv->duration;
    return EF_OK;
}

/* Pull every final move; *n counts them. */
static int pipe_pull(ef_pipe_t *P, uint32_t *n, ef_msg_t *m)
{
    ef_move_t mv;
    int rc;
    while ((rc = ef_smooth_pull(&P->sm, &mv)) == EF_OK) {
        if (n)
            ++*n;
        rc = pipe_move(P, &mv, m);
        if (rc)
            return rc;
    }
    if (rc != EF_ERR_AGAIN)
        return ef_fail(m, rc, "smoother pull: %s", ef_err_str(rc));
    return EF_OK;
}

/* A call that returned EF_ERR_FULL: a stall when it did no work unit (ef_smooth.h) and
 * the pulls after it found no move. */
static int pipe_stalled(ef_pipe_t *P, uint32_t units, uint32_t pulled)
{
    return !pulled && ef_smooth_stats(&P->sm).units == units;
}

/* Finish the smoother (one work unit a call) and pull every move. */
static int pipe_finish(ef_pipe_t *P, ef_msg_t *m)
{
    for (;;) {
        uint32_t units = ef_smooth_stats(&P->sm).units, n = 0;
        int rc = ef_smooth_finish(&P->sm);
        if (rc != EF_OK && rc != EF_ERR_FULL)
            return ef_fail(m, rc, "smoother finish: %s", ef_err_str(rc));
        int rc2 = pipe_pull(P, &n, m);
        if (rc2)
            return rc2;
        if (rc == EF_OK)
            return EF_OK;
        if (pipe_stalled(P, units, n))
            return ef_fail(m, EF_ERR_STATE, "smoother finish: no progress");
    }
}

/* Exact stop: finish the smoother, emit every move, run the interpolators to rest. */
static int pipe_drain(ef_pipe_t *P, ef_msg_t *m)
{
    int rc = pipe_finish(P, m);
    if (rc)
        return rc;
    for (int k = 0; k < 2; k++) {
        if (!(P->cfg->interp_modes & (1u << k)))
            continue;
        /* Bound the loop by the queued time (a stuck interpolator is an error). */
        double budget = P->pending_time / (P->cfg->period_us * 1e-6) + 1000.0;
        for (double n = 0;
             ef_interp_space(&P->ip[k]) < EF_INTERP_QUEUE || (P->have_prev[k] && P->prev[k].moving);
             n++) {
            if (n > budget)
                return ef_fail(m, EF_ERR_STATE, "interpolator did not come to rest");
            rc = pipe_step(P, k, m);
            if (rc)
                return rc;
        }
    }
    P->pending_time = 0;
    P->stop_next = 1;
    return EF_OK;
}

/* Count a note and pass it to the note callback as "file:line:col: text". */
static int pipe_note(ef_pipe_t *P, const ef_gcode_item_t *it, const char *text, ef_msg_t *m)
{
    P->st.notes++;
    if (!P->cb.on_note)
        return EF_OK;
    char buf[sizeof P->r->name + 256];
    snprintf(buf, sizeof buf, "%s:%u:%u: %s", P->r->name, (unsigned)it->line, (unsigned)it->col,
             text);
    int rc = P->cb.on_note(P->cb.user, it, buf);
    return rc ? pipe_cb_fail(m, rc, "note") : EF_OK;
}

/* A path item: convert, push (draining while the smoother is full). */
static int pipe_prim(ef_pipe_t *P, const ef_gcode_item_t *it, ef_msg_t *m)
{
    ef_prim_t pr;
    int rc = ef_pipe_item_prim(it, P->cfg->rapid_speed, &pr);
    if (rc)
        return ef_fail(m, rc, "%s:%u: bad path item", P->r->name, (unsigned)it->line);
    int rapid = it->kind == EF_GC_RAPID;
    for (int k = 0; k < EF_GCODE_AUX; k++) {
        if (k < P->cfg->naux) {
            pr.aux[k] = (float)it->aend[k];
            continue;
        }
        if (it->aend[k] != it->astart[k]) {
            ef_msg_t dm;
            int rc2 = pipe_drain(P, &dm); /* controlled stop at the last accepted end */
            const char *axes = "XYZABCUVW";
            if (rc2)
                return ef_fail(m, rc2, "%s:%u: axis %c moves; then %s", P->r->name,
                               (unsigned)it->line, axes[3 + k], dm.text);
            return ef_fail(m, EF_ERR_ARG, "%s:%u: axis %c moves, the machine has X Y Z%s%.*s only",
                           P->r->name, (unsigned)it->line, axes[3 + k], P->cfg->naux ? " " : "",
                           P->cfg->naux, axes + 3);
        }
    }
    pr.tag = it->line;
    pr.tol = (float)P->tol;
    pr.qtol = (float)P->qtol;
    /* Exact stops: at program start and after events (stop_next), and around every G0
     * only when rapids are configured to stop; otherwise a G0 corner, and a G0/G1
     * transition, is blended within the active P like any other vertex (tol 0, i.e. G61,
     * still stops everywhere). */
    if (P->stop_next || (P->cfg->rapid_exact && (rapid || P->last_rapid)))
        pr.flags |= EF_PRIM_STOP_BEFORE;
    if (!P->units_set) {
        P->st.units = it->units;
        P->units_set = 1;
    }
    ef_pipe_tag_t *t = &P->tags[P->ntags++ % EF_PIPE_TAGS];
    t->tag = pr.tag;
    t->mi.tol = P->tol;
    t->mi.units = it->units;
    t->mi.rapid = rapid;
    for (;;) {
        uint32_t units = ef_smooth_stats(&P->sm).units, n = 0;
        rc = ef_smooth_push(&P->sm, &pr);
        if (rc != EF_ERR_FULL)
            break;
        rc = pipe_pull(P, &n, m);
        if (rc)
            return rc;
        if (pipe_stalled(P, units, n))
            return ef_fail(m, EF_ERR_STATE, "%s:%u: smoother full but nothing to pull", P->r->name,
                           (unsigned)it->line);
    }
    if (rc == EF_ERR_DEGENERATE && pr.kind == EF_PRIM_LINE) {
        /* Shorter than float32 resolves here: reported, not silently dropped. */
        double d[3] = {it->end[0] - it->start[0], it->end[1] - it->start[1],
                       it->end[2] - it->start[2]};
        char txt[128];
        snprintf(txt, sizeof txt, "%s move of %.3g mm too short to represent, skipped",
                 rapid ? "G0" : "G1", sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]));
        P->ntags--;
        return pipe_note(P, it, txt, m);
    }
    if (rc) {
        P->ntags--;
        ef_msg_t dm;
        int rc2 = pipe_drain(P, &dm); /* controlled stop at the last accepted end */
        if (rc2)
            return ef_fail(m, rc2, "%s:%u: %s; then %s", P->r->name, (unsigned)it->line,
                           ef_err_str(rc), dm.text);
        return ef_fail(m, rc, "%s:%u: %s", P->r->name, (unsigned)it->line, ef_err_str(rc));
    }
    P->st.prims++;
    if (rapid)
        P->st.rapids++;
    if (pr.kind == EF_PRIM_ARC)
        P->st.arcs++;
    if (P->tol > P->st.tol_max)
        P->st.tol_max = P->tol;
    P->stop_next = 0;
    P->last_rapid = rapid;
    return pipe_pull(P, NULL, m);
}

/* Pieces a spiral arc is cut into: at most 45 degrees each, and enough that the circle
 * through each piece's ends and middle stays within EF_PIPE_SPIRAL_DEV of the spiral (its
 * error is about |dr| theta^2 / (24 n^3) for a sweep theta and radius change dr). */
int ef_pipe_spiral_pieces(double sweep, double dr)
{
    double th = fabs(sweep), n1 = ceil(th / (0.25 * M_PI)),
           n2 = ceil(cbrt(fabs(dr) * th * th / (24.0 * EF_PIPE_SPIRAL_DEV)));
    double n = fmax(1.0, fmax(n1, n2));
    return n > EF_PIPE_SPIRAL_MAX ? EF_PIPE_SPIRAL_MAX : (int)n;
}

/* Piece k of n of a spiral arc item: the circle through its ends and middle on the spiral
 * (radius linear in the angle, rise linear in the angle). */
int ef_pipe_spiral_piece(const ef_gcode_item_t *it, int k, int n, ef_gcode_item_t *out)
{
    if (!it || !out || it->kind != EF_GC_ARC || n < 1 || k < 0 || k >= n)
        return EF_ERR_ARG;
    int a = it->plane == 18 ? 2 : it->plane == 19 ? 1 : 0;
    int b = it->plane == 18 ? 0 : it->plane == 19 ? 2 : 1;
    int c = 3 - a - b;
    double phi0 = atan2(it->start[b] - it->centre[b], it->start[a] - it->centre[a]);
    double pt[3][3];
    for (int j = 0; j < 3; j++) {
        double f = (k + 0.5 * j) / n, ang = phi0 + f * it->sweep,
               rho = it->radius + f * (it->radius_end - it->radius);
        pt[j][a] = it->centre[a] + rho * cos(ang);
        pt[j][b] = it->centre[b] + rho * sin(ang);
        pt[j][c] = it->start[c] + f * (it->end[c] - it->start[c]);
    }
    if (k == n - 1)
        memcpy(pt[2], it->end, sizeof pt[2]); /* the end exactly as given */
    if (k == 0)
        memcpy(pt[0], it->start, sizeof pt[0]);
    /* circumcentre of the three in-plane points */
    double ax = pt[0][a], ay = pt[0][b], bx = pt[1][a] - ax, by = pt[1][b] - ay, cx = pt[2][a] - ax,
           cy = pt[2][b] - ay, d = 2 * (bx * cy - by * cx);
    if (fabs(d) < 1e-300)
        return EF_ERR_DEGENERATE;
    double b2 = bx * bx + by * by, c2 = cx * cx + cy * cy;
    double ux = (cy * b2 - by * c2) / d, uy = (bx * c2 - cx * b2) / d;
    *out = *it;
    memcpy(out->start, pt[0], sizeof out->start);
    memcpy(out->end, pt[2], sizeof out->end);
    out->centre[a] = ax + ux;
    out->centre[b] = ay + uy;
    out->centre[c] = pt[0][c];
    out->radius = out->radius_end = hypot(ux, uy);
    double s0 = atan2(-uy, -ux), s1 = atan2(cy - uy, cx - ux), sw = s1 - s0;
    if (it->sweep > 0)
        while (sw <= 0)
            sw += 2 * M_PI;
    else
        while (sw >= 0)
            sw -= 2 * M_PI;
    out->sweep = sw;
    out->turns = 1;
    return EF_OK;
}

/* A path item; a spiral arc goes in as its circular pieces. */
static int pipe_item(ef_pipe_t *P, const ef_gcode_item_t *it, ef_msg_t *m)
{
    if (it->kind != EF_GC_ARC || it->radius_end == it->radius)
        return pipe_prim(P, it, m);
    int n = ef_pipe_spiral_pieces(it->sweep, it->radius_end - it->radius), rc;
    for (int k = 0; k < n; k++) {
        ef_gcode_item_t piece;
        if ((rc = ef_pipe_spiral_piece(it, k, n, &piece)) != 0)
            return ef_fail(m, rc, "%s:%u: spiral arc piece %d of %d is degenerate", P->r->name,
                           (unsigned)it->line, k + 1, n);
        /* the auxiliary axes linear in the angle, as over the whole arc */
        for (int j = 0; j < EF_GCODE_AUX; j++) {
            double d = it->aend[j] - it->astart[j];
            piece.astart[j] = it->astart[j] + d * k / n;
            piece.aend[j] = k == n - 1 ? it->aend[j] : it->astart[j] + d * (k + 1) / n;
        }
        if ((rc = pipe_prim(P, &piece, m)) != 0)
            return rc;
    }
    return EF_OK;
}

/* Reject a bad configuration with a message before anything is allocated. */
static int pipe_check_cfg(const ef_pipe_cfg_t *c, const ef_pipe_cb_t *cb, ef_msg_t *m)
{
    if (!c->g2)
        return ef_fail(m, EF_ERR_ARG, "pipeline: no G2 table");
    if (c->smooth_degree != 3 && c->smooth_degree != 5)
        return ef_fail(m, EF_ERR_ARG, "pipeline: smooth degree %d (3 or 5)", c->smooth_degree);
    if (c->smooth_degree == 3 && !c->g1)
        return ef_fail(m, EF_ERR_ARG, "pipeline: G1 smooth sections need a G1 table");
    if (!(c->rapid_speed > 0) || !isfinite(c->rapid_speed))
        return ef_fail(m, EF_ERR_FEED, "pipeline: rapid speed %g (must be > 0)", c->rapid_speed);
    if (!(c->tol_default >= 0) || !isfinite(c->tol_default) || !(c->qtol_default >= 0) ||
        !isfinite(c->qtol_default))
        return ef_fail(m, EF_ERR_ARG, "pipeline: tolerance P %g / Q %g (must be >= 0)",
                       c->tol_default, c->qtol_default);
    if (c->naux < 0 || c->naux > EF_AUX)
        return ef_fail(m, EF_ERR_ARG, "pipeline: %d auxiliary axes (0 to %d)", c->naux, EF_AUX);
    if (!c->period_us)
        return ef_fail(m, EF_ERR_ARG, "pipeline: servo period 0");
    if (c->step_mode != EF_STEP_UNIFORM && c->step_mode != EF_STEP_CORRECTED)
        return ef_fail(m, EF_ERR_ARG, "pipeline: step mode %d", c->step_mode);
    if (c->interp_modes & ~3u)
        return ef_fail(m, EF_ERR_ARG, "pipeline: interp modes 0x%x", c->interp_modes);
    if (cb && cb->on_setpoint && !(c->interp_modes & (1u << c->step_mode)))
        return ef_fail(m, EF_ERR_ARG, "pipeline: setpoints asked for a mode not interpolated");
    return EF_OK;
}

/* The item loop; the caller frees P. */
static int pipe_loop(ef_pipe_t *P, ef_msg_t *m)
{
    ef_gcode_item_t it;
    ef_msg_t gm = {{0}};
    char txt[192];
    for (;;) {
        int rc = ef_gcode_next(P->r, &it, &gm);
        if (rc) {
            ef_msg_t dm;
            int rc2 = pipe_drain(P, &dm); /* controlled stop */
            if (rc2)
                return ef_fail(m, rc2, "%s; then %s", gm.text, dm.text);
            return ef_fail(m, rc, "%s", gm.text);
        }
        P->st.items++;
        if (P->cb.on_item) {
            rc = P->cb.on_item(P->cb.user, &it);
            if (rc)
                return pipe_cb_fail(m, rc, "item");
        }
        switch (it.kind) {
        case EF_GC_RAPID:
        case EF_GC_LINE:
        case EF_GC_ARC:
            rc = pipe_item(P, &it, m);
            break;
        case EF_GC_ZERO_MOVE:
            P->st.zero_moves++;
            snprintf(txt, sizeof txt, "zero-length %s move (end = start), skipped",
                     it.text[0] ? it.text : "G0/G1");
            rc = pipe_note(P, &it, txt, m);
            break;
        case EF_GC_IGNORED:
            snprintf(txt, sizeof txt, "%s ignored", it.text);
            rc = pipe_note(P, &it, txt, m);
            break;
        case EF_GC_NOTE:
            rc = pipe_note(P, &it, it.text, m);
            break;
        case EF_GC_TOLERANCE:
            if (it.path_mode == EF_GC_PATH_EXACT) {
                P->tol = 0;
                P->qtol = 0;
            } else {
                P->tol = it.p_tol > 0 ? it.p_tol : P->cfg->tol_default;
                P->qtol = pipe_qtol(P->cfg, P->tol, it.q_tol);
            }
            break;
        case EF_GC_EVENT:
        case EF_GC_END:
            rc = pipe_drain(P, m);
            if (rc)
                return rc;
            if (it.kind == EF_GC_END)
                return EF_OK;
            P->st.events++;
            if (P->cb.on_event) {
                rc = P->cb.on_event(P->cb.user, &it);
                if (rc)
                    rc = pipe_cb_fail(m, rc, "event");
            }
            break;
        default:
            break;
        }
        if (rc)
            return rc;
    }
}

/* Run a whole program through smoother and interpolators (see ef_pipeline.h). */
int ef_pipe_run(ef_gcode_t *r, const ef_pipe_cfg_t *cfg, const ef_pipe_cb_t *cb,
                ef_pipe_stats_t *st, ef_msg_t *m)
{
    if (st)
        memset(st, 0, sizeof *st);
    if (!r || !cfg)
        return ef_fail(m, EF_ERR_ARG, "pipeline: NULL reader or configuration");
    int rc = pipe_check_cfg(cfg, cb, m);
    if (rc)
        return rc;
    ef_pipe_t *P = calloc(1, sizeof *P);
    if (!P)
        return ef_fail(m, EF_ERR_NOMEM, "pipeline: out of memory");
    P->cfg = cfg;
    if (cb)
        P->cb = *cb;
    P->r = r;
    /* The machine's limit for the reader's feed clamp (a note on each line that asks more):
     * no direction is faster than all axes at their limits together. */
    double vm = 0;
    for (int k = 0; k < 3; k++)
        vm += (double)cfg->lim.v_axis[k] * cfg->lim.v_axis[k];
    if (vm > 0 && sqrt(vm) * 60 < r->max_feed)
        ef_gcode_set_max_feed(r, sqrt(vm) * 60);
    P->tol = cfg->tol_default;
    P->qtol = pipe_qtol(cfg, P->tol, 0.0);
    P->stop_next = 1;
    P->st.units = r->units ? r->units : 21;
    ef_vec3_t start = ef_v3((float)r->cur[0], (float)r->cur[1], (float)r->cur[2]);
    for (int k = 0; k < 3; k++)
        P->st.start[k] = P->st.end[k] = r->cur[k];
    ef_smooth_cfg_t sc;
    memset(&sc, 0, sizeof sc);
    sc.g2 = cfg->g2;
    sc.g1 = cfg->g1;
    sc.lim = cfg->lim;
    sc.micro_len = (float)cfg->micro_len;
    sc.micro_turn = (float)cfg->micro_turn;
    sc.smooth_degree = (uint8_t)cfg->smooth_degree;
    sc.keep_slow_blends = cfg->keep_slow_blends != 0;
    sc.naux = (uint8_t)(cfg->naux > 0 ? cfg->naux : 0);
    float astart[EF_AUX_N] = {0};
    for (int k = 0; k < EF_AUX; k++) {
        sc.aux_tol[k] = (float)cfg->aux_tol[k];
        astart[k] = k < cfg->naux ? (float)r->acur[k] : 0.0f;
    }
    rc = ef_smooth_init(&P->sm, &sc, start);
    if (!rc)
        rc = ef_smooth_set_aux(&P->sm, astart);
    if (rc) {
        rc = ef_fail(m, rc, "smoother configuration: %s", ef_err_str(rc));
    } else {
        for (int k = 0; k < 2 && !rc; k++) {
            if (!(cfg->interp_modes & (1u << k)))
                continue;
            rc = ef_interp_init(&P->ip[k], start, cfg->period_us, k);
            if (!rc)
                rc = ef_interp_set_aux(&P->ip[k], astart);
            if (rc)
                rc = ef_fail(m, rc, "interpolator configuration: %s", ef_err_str(rc));
        }
    }
    if (!rc)
        rc = pipe_loop(P, m);
    P->st.sm = ef_smooth_stats(&P->sm);
    if (st)
        *st = P->st;
    free(P);
    return rc;
}
