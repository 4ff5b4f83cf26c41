/* SPDX-License-Identifier: Apache-2.0 */
/* The smoothing run behind `evenfeed smooth` and `evenfeed demo` (cli_smooth_run()): the
 * pipeline's callbacks, the JSON (planned moves), CSV (setpoints) and SVG (XY plot) outputs
 * and the summary (docs/smoothing-cli.md). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include "cli.h"

/* Growable array of doubles. */
typedef struct {
    double *v;
    size_t n, cap;
} crep_dvec_t;

/* Append k doubles, growing the array geometrically; EF_ERR_NOMEM on failure. */
static int crep_dvec_push(crep_dvec_t *d, const double *x, size_t k)
{
    if (d->n + k > d->cap) {
        size_t cap = d->cap ? d->cap * 2 : 4096;
        while (cap < d->n + k)
            cap *= 2;
        double *nv = realloc(d->v, cap * sizeof *nv);
        if (!nv)
            return EF_ERR_NOMEM;
        d->v = nv;
        d->cap = cap;
    }
    memcpy(d->v + d->n, x, k * sizeof *x);
    d->n += k;
    return EF_OK;
}

/* Stride of the records below (doubles). */
#define PROG_REC  5 /* x0 y0 x1 y1 rapid */
#define SP_REC    4 /* x y v rapid */
#define BLEND_REC 2

typedef struct {
    const cli_smooth_opts_t *o;
    double f;  /* mm -> program units */
    int units; /* 20 or 21 */
    FILE *csv;
    FILE *segs; /* JSON segments (memory stream) */
    char *segbuf;
    size_t seglen;
    crep_dvec_t prog;   /* programmed path pieces (XY, program units) */
    crep_dvec_t sp;     /* setpoints */
    crep_dvec_t blends; /* blend curves as polylines, NAN-separated */
    crep_dvec_t stops;  /* exact-stop points */
    double vmax_seen;
    int have_prev;
    ef_setpoint_t prev;
    double dt;
} crep_ctx_t;

/* Fix the output units from the first units seen (mm unless G20) and the scale. */
static int crep_units(crep_ctx_t *c, int units)
{
    if (!c->units) {
        c->units = units == 20 ? 20 : 21;
        c->f = c->units == 20 ? 1.0 / 25.4 : 1.0;
    }
    return c->units;
}

/* Programmed path, for the SVG. */
static int crep_item(void *user, const ef_gcode_item_t *it)
{
    crep_ctx_t *c = user;
    if (it->kind != EF_GC_RAPID && it->kind != EF_GC_LINE && it->kind != EF_GC_ARC)
        return 0;
    crep_units(c, it->units);
    if (!c->o->svg)
        return 0;
    double f = c->f;
    if (it->kind != EF_GC_ARC) {
        double r[PROG_REC] = {it->start[0] * f, it->start[1] * f, it->end[0] * f, it->end[1] * f,
                              it->kind == EF_GC_RAPID};
        return crep_dvec_push(&c->prog, r, PROG_REC);
    }
    /* Arc / helix: rotate (start - centre) about the plane normal. */
    int ax = it->plane == 17 ? 2 : it->plane == 18 ? 1 : 0;
    int u = (ax + 1) % 3, w = (ax + 2) % 3; /* (u, w, ax) right-handed */
    double ru = it->start[u] - it->centre[u], rw = it->start[w] - it->centre[w];
    int n = (int)(fabs(it->sweep) / (2 * 3.14159265358979) * 96) + 8;
    if (n > 20000)
        n = 20000;
    double prev[3] = {it->start[0], it->start[1], it->start[2]};
    for (int k = 1; k <= n; k++) {
        double a = it->sweep * k / n, ca = cos(a), sa = sin(a);
        double p[3];
        p[u] = it->centre[u] + ca * ru - sa * rw;
        p[w] = it->centre[w] + sa * ru + ca * rw;
        p[ax] = it->start[ax] + (it->end[ax] - it->start[ax]) * k / n;
        if (k == n)
            memcpy(p, it->end, sizeof p);
        double r[PROG_REC] = {prev[0] * f, prev[1] * f, p[0] * f, p[1] * f, 0};
        int rc = crep_dvec_push(&c->prog, r, PROG_REC);
        if (rc)
            return rc;
        memcpy(prev, p, sizeof p);
    }
    return 0;
}

/* Write a point as a JSON [x, y, z] array in program units. */
static void crep_json_vec(FILE *fp, ef_vec3_t v, double f)
{
    fputc('[', fp);
    cli_json_num(fp, v.x * f);
    fputs(", ", fp);
    cli_json_num(fp, v.y * f);
    fputs(", ", fp);
    cli_json_num(fp, v.z * f);
    fputc(']', fp);
}

/* Bezier point (de Casteljau) of a move, in mm. */
static ef_vec3_t crep_bez(const ef_move_t *m, double t)
{
    ef_vec3_t q[6];
    int d = m->degree <= 5 ? m->degree : 5;
    memcpy(q, m->b, sizeof q);
    for (int r = 1; r <= d; r++)
        for (int i = 0; i <= d - r; i++) {
            q[i].x = (float)((1 - t) * q[i].x + t * q[i + 1].x);
            q[i].y = (float)((1 - t) * q[i].y + t * q[i + 1].y);
            q[i].z = (float)((1 - t) * q[i].z + t * q[i + 1].z);
        }
    return q[0];
}

/* Move callback: JSON segment record, blend polyline and stop point for the SVG. */
static int crep_move(void *user, const ef_move_t *m, const ef_pipe_move_info_t *mi)
{
    crep_ctx_t *c = user;
    crep_units(c, mi->units);
    double f = c->f;
    if (c->segs) {
        FILE *fp = c->segs;
        if (ftell(fp) > 0)
            fputs(",\n", fp);
        fprintf(fp, "    {\"seq\": %u, \"kind\": \"%s\", \"degree\": %u, \"control_points\": [",
                (unsigned)m->seq, ef_pipe_move_kind_name(m->kind), (unsigned)m->degree);
        for (int k = 0; k <= m->degree && k < 6; k++) {
            if (k)
                fputs(", ", fp);
            crep_json_vec(fp, m->b[k], f);
        }
        fputs("], \"duration\": ", fp);
        cli_json_num(fp, m->duration);
        fputs(", \"length\": ", fp);
        cli_json_num(fp, m->length * f);
        fputs(", \"v_entry\": ", fp);
        cli_json_num(fp, m->v_entry * f);
        fputs(", \"v_exit\": ", fp);
        cli_json_num(fp, m->v_exit * f);
        fputs(", \"v_max\": ", fp);
        cli_json_num(fp, m->v_max * f);
        fputs(", \"a_max\": ", fp);
        cli_json_num(fp, m->a_max * f);
        fputs(", \"j_max\": ", fp);
        cli_json_num(fp, m->j_max * f);
        fputs(", \"feed\": ", fp);
        cli_json_num(fp, m->feed * f);
        fputs(", \"dev\": ", fp);
        cli_json_num(fp, m->dev * f);
        fprintf(fp, ", \"stop_end\": %s, \"rapid\": %s, \"line\": %u, \"time_law\": {\"dt\": [",
                (m->flags & EF_MOVE_STOP_END) ? "true" : "false", mi->rapid ? "true" : "false",
                (unsigned)m->tag);
        for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
            if (k)
                fputs(", ", fp);
            cli_json_num(fp, m->law.dt[k]);
        }
        fputs("], \"c\": [", fp);
        for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
            fputs(k ? ", [" : "[", fp);
            for (int j = 0; j < EF_TIMELAW_COEFFS; j++) {
                if (j)
                    fputs(", ", fp);
                cli_json_num(fp, m->law.c[k][j]);
            }
            fputc(']', fp);
        }
        fputs("]}", fp);
        /* the auxiliary axes' control points (deg for A B C, mm for U V W), for a move where
         * one is not at 0: a program of X Y Z alone writes what it always did */
        int any = 0;
        for (int a = 0; a < c->o->cfg.naux; a++)
            for (int k = 0; k <= m->degree && k < 6; k++)
                any |= m->ab[a][k] != 0.0f;
        if (any) {
            fputs(", \"aux_control_points\": {", fp);
            for (int a = 0; a < c->o->cfg.naux; a++) {
                fprintf(fp, "%s\"%c\": [", a ? ", " : "", "abcuvw"[a]);
                for (int k = 0; k <= m->degree && k < 6; k++) {
                    if (k)
                        fputs(", ", fp);
                    cli_json_num(fp, m->ab[a][k]);
                }
                fputc(']', fp);
            }
            fprintf(fp, "}, \"aux_only\": %s", (m->flags & EF_MOVE_AUX_ONLY) ? "true" : "false");
        }
        fputc('}', fp);
    }
    if (c->o->svg && m->kind == EF_MOVE_BLEND) {
        for (int k = 0; k <= 16; k++) {
            ef_vec3_t p = crep_bez(m, k / 16.0);
            double r[BLEND_REC] = {p.x * f, p.y * f};
            if (crep_dvec_push(&c->blends, r, BLEND_REC))
                return EF_ERR_NOMEM;
        }
        double sep[BLEND_REC] = {NAN, NAN};
        if (crep_dvec_push(&c->blends, sep, BLEND_REC))
            return EF_ERR_NOMEM;
    }
    if (c->o->svg && (m->flags & EF_MOVE_STOP_END) && !mi->rapid) {
        ef_vec3_t e = m->b[m->degree <= 5 ? m->degree : 5];
        double r[2] = {e.x * f, e.y * f};
        if (crep_dvec_push(&c->stops, r, 2))
            return EF_ERR_NOMEM;
    }
    return 0;
}

/* Setpoint callback: CSV row with measured feed, and speed samples for the SVG. */
static int crep_setpoint(void *user, double t, const ef_setpoint_t *sp,
                         const ef_pipe_move_info_t *mi)
{
    crep_ctx_t *c = user;
    double f = c->f ? c->f : 1.0;
    double feed = 0;
    if (c->have_prev) {
        double dx = (double)sp->p.x - c->prev.p.x, dy = (double)sp->p.y - c->prev.p.y,
               dz = (double)sp->p.z - c->prev.p.z;
        feed = sqrt(dx * dx + dy * dy + dz * dz) / c->dt;
    }
    c->prev = *sp;
    c->have_prev = 1;
    if (c->csv) {
        fprintf(c->csv, "%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%u,%u", t, sp->p.x * f, sp->p.y * f,
                sp->p.z * f, sp->v_plan * f, feed * f, (unsigned)sp->seq, (unsigned)sp->tag);
        for (int a = 0; a < c->o->cfg.naux; a++)
            fprintf(c->csv, ",%.6f", sp->aux[a]);
        fputc('\n', c->csv);
    }
    if (c->o->svg) {
        double r[SP_REC] = {sp->p.x * f, sp->p.y * f, sp->v_plan * f, mi->rapid};
        if (!mi->rapid && sp->v_plan * f > c->vmax_seen)
            c->vmax_seen = sp->v_plan * f;
        if (crep_dvec_push(&c->sp, r, SP_REC))
            return EF_ERR_NOMEM;
    }
    return 0;
}

/* Note callback: print reader notes on stderr. */
static int crep_note(void *user, const ef_gcode_item_t *it, const char *text)
{
    (void)user;
    (void)it;
    fprintf(stderr, "evenfeed: note: %s\n", text);
    return 0;
}

/* Speed colour ramp (blue, cyan, green, yellow, red) for x in [0, 1]. */
static void crep_colour(double x, char out[8])
{
    static const double stops[5][3] = {
        {49, 54, 149}, {69, 160, 210}, {70, 180, 90}, {240, 200, 40}, {215, 40, 40}};
    if (!(x >= 0))
        x = 0;
    if (x > 1)
        x = 1;
    double s = x * 4;
    int i = (int)s;
    if (i > 3)
        i = 3;
    double a = s - i;
    int rgb[3];
    for (int k = 0; k < 3; k++)
        rgb[k] = (int)lround(stops[i][k] * (1 - a) + stops[i + 1][k] * a);
    snprintf(out, 8, "#%02x%02x%02x", rgb[0], rgb[1], rgb[2]);
}

#define SVG_BUCKETS 16

/* Write the XY plot: programmed path, speed-coloured setpoints, blends, stops. */
static int crep_write_svg(crep_ctx_t *c, const char *path, const char *title,
                          const ef_pipe_stats_t *st)
{
    FILE *fp = fopen(path, "w");
    if (!fp)
        return EF_ERR_IO;
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (size_t k = 0; k < c->prog.n; k += PROG_REC)
        for (int e = 0; e < 2; e++)
            for (int a = 0; a < 2; a++) {
                double v = c->prog.v[k + 2 * e + a];
                lo[a] = fmin(lo[a], v);
                hi[a] = fmax(hi[a], v);
            }
    for (size_t k = 0; k < c->sp.n; k += SP_REC)
        for (int a = 0; a < 2; a++) {
            lo[a] = fmin(lo[a], c->sp.v[k + a]);
            hi[a] = fmax(hi[a], c->sp.v[k + a]);
        }
    if (!(lo[0] <= hi[0])) {
        lo[0] = lo[1] = 0;
        hi[0] = hi[1] = 1;
    }
    double span = fmax(hi[0] - lo[0], hi[1] - lo[1]);
    if (!(span > 0))
        span = 1;
    const double W = 900, M = 30, LEG = 90;
    double s = (W - 2 * M) / span;
    double pw = (hi[0] - lo[0]) * s + 2 * M, ph = (hi[1] - lo[1]) * s + 2 * M;
    if (pw < 400)
        pw = 400;
    double H = ph + LEG;
#define SX(x) (M + ((x)-lo[0]) * s)
#define SY(y) (M + (hi[1] - (y)) * s)
    const char *u = c->units == 20 ? "in" : "mm";
    fprintf(fp,
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" "
            "viewBox=\"0 0 %.0f %.0f\" font-family=\"sans-serif\" font-size=\"12\">\n"
            "<title>evenfeed smooth: %s</title>\n"
            "<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n",
            pw, H, pw, H, title);
    /* Programmed path: thin grey, rapids dashed. */
    fputs("<g id=\"programmed\" fill=\"none\" stroke=\"#9a9a9a\" stroke-width=\"0.8\">\n", fp);
    /* Connected pieces of one kind form one polyline. */
    const double *last = NULL;
    for (size_t k = 0; k < c->prog.n; k += PROG_REC) {
        const double *r = c->prog.v + k;
        if (r[0] == r[2] && r[1] == r[3])
            continue;
        if (!last || last[2] != r[0] || last[3] != r[1] || last[4] != r[4]) {
            if (last)
                fputs("\"/>\n", fp);
            fprintf(fp, "<polyline%s points=\"%.2f,%.2f",
                    r[4] != 0 ? " stroke-dasharray=\"4 3\"" : "", SX(r[0]), SY(r[1]));
        }
        fprintf(fp, " %.2f,%.2f", SX(r[2]), SY(r[3]));
        last = r;
    }
    if (last)
        fputs("\"/>\n", fp);
    fputs("</g>\n", fp);
    /* Blends: wide translucent magenta under the speed-coloured path. */
    fputs("<g id=\"blends\" fill=\"none\" stroke=\"#d030c0\" stroke-opacity=\"0.45\" "
          "stroke-width=\"7\" stroke-linecap=\"round\">\n",
          fp);
    int open = 0;
    for (size_t k = 0; k < c->blends.n; k += BLEND_REC) {
        const double *r = c->blends.v + k;
        if (isnan(r[0])) {
            if (open)
                fputs("\"/>\n", fp);
            open = 0;
            continue;
        }
        fprintf(fp, open ? " %.2f,%.2f" : "<polyline points=\"%.2f,%.2f", SX(r[0]), SY(r[1]));
        open = 1;
    }
    if (open)
        fputs("\"/>\n", fp);
    fputs("</g>\n", fp);
    /* Smoothed path from the setpoints: polylines by speed bucket; rapids dashed. */
    double vtop = c->vmax_seen > 0 ? c->vmax_seen : 1;
    fputs("<g id=\"smoothed\" fill=\"none\" stroke-width=\"2\" stroke-linejoin=\"round\">\n", fp);
    int cur = -2;
    double lx = NAN, ly = NAN;
    char col[8];
    for (size_t k = 0; k < c->sp.n; k += SP_REC) {
        const double *r = c->sp.v + k;
        int b = r[3] != 0 ? -1 : (int)(r[2] / vtop * (SVG_BUCKETS - 1) + 0.5);
        if (b >= SVG_BUCKETS)
            b = SVG_BUCKETS - 1;
        if (b != cur) {
            if (cur != -2)
                fputs("\"/>\n", fp);
            if (b < 0)
                fputs("<polyline stroke=\"#5060a0\" stroke-width=\"1\" "
                      "stroke-dasharray=\"6 4\" points=\"",
                      fp);
            else {
                crep_colour((double)b / (SVG_BUCKETS - 1), col);
                fprintf(fp, "<polyline stroke=\"%s\" points=\"", col);
            }
            if (!isnan(lx))
                fprintf(fp, "%.2f,%.2f ", SX(lx), SY(ly));
            cur = b;
        } else if (!isnan(lx) && fabs(SX(r[0]) - SX(lx)) < 0.5 && fabs(SY(r[1]) - SY(ly)) < 0.5 &&
                   k + SP_REC < c->sp.n) {
            continue; /* below half a pixel: skip */
        }
        fprintf(fp, "%.2f,%.2f ", SX(r[0]), SY(r[1]));
        lx = r[0];
        ly = r[1];
    }
    if (cur != -2)
        fputs("\"/>\n", fp);
    fputs("</g>\n", fp);
    fputs("<g id=\"stops\" fill=\"black\">\n", fp);
    for (size_t k = 0; k < c->stops.n; k += 2)
        fprintf(fp, "<circle cx=\"%.2f\" cy=\"%.2f\" r=\"2.5\"/>\n", SX(c->stops.v[k]),
                SY(c->stops.v[k + 1]));
    fputs("</g>\n", fp);
    /* Legend: speed ramp, then the line styles. */
    double ly0 = ph + 10;
    fputs("<defs><linearGradient id=\"ramp\">", fp);
    for (int k = 0; k <= 8; k++) {
        crep_colour(k / 8.0, col);
        fprintf(fp, "<stop offset=\"%.3f\" stop-color=\"%s\"/>", k / 8.0, col);
    }
    fputs("</linearGradient></defs>\n", fp);
    fprintf(fp,
            "<g id=\"legend\">\n<text x=\"%.0f\" y=\"%.0f\">planned speed (%s/s)</text>\n"
            "<rect x=\"%.0f\" y=\"%.0f\" width=\"240\" height=\"12\" fill=\"url(#ramp)\"/>\n"
            "<text x=\"%.0f\" y=\"%.0f\">0</text><text x=\"%.0f\" y=\"%.0f\" "
            "text-anchor=\"end\">%.4g</text>\n",
            M, ly0 + 12, u, M, ly0 + 18, M, ly0 + 44, M + 240, ly0 + 44, vtop);
    double x2 = M + 280;
    fprintf(fp,
            "<line x1=\"%.0f\" y1=\"%.0f\" x2=\"%.0f\" y2=\"%.0f\" stroke=\"#9a9a9a\"/>"
            "<text x=\"%.0f\" y=\"%.0f\">programmed</text>\n"
            "<line x1=\"%.0f\" y1=\"%.0f\" x2=\"%.0f\" y2=\"%.0f\" stroke=\"#5060a0\" "
            "stroke-dasharray=\"6 4\"/><text x=\"%.0f\" y=\"%.0f\">rapid (G0)</text>\n"
            "<line x1=\"%.0f\" y1=\"%.0f\" x2=\"%.0f\" y2=\"%.0f\" stroke=\"#d030c0\" "
            "stroke-opacity=\"0.45\" stroke-width=\"7\"/><text x=\"%.0f\" y=\"%.0f\">corner "
            "blend</text>\n"
            "<circle cx=\"%.0f\" cy=\"%.0f\" r=\"2.5\"/><text x=\"%.0f\" y=\"%.0f\">exact "
            "stop</text>\n",
            x2, ly0 + 8, x2 + 30, ly0 + 8, x2 + 36, ly0 + 12, x2, ly0 + 26, x2 + 30, ly0 + 26,
            x2 + 36, ly0 + 30, x2 + 150, ly0 + 8, x2 + 180, ly0 + 8, x2 + 186, ly0 + 12, x2 + 165,
            ly0 + 26, x2 + 186, ly0 + 30);
    fprintf(fp,
            "<text x=\"%.0f\" y=\"%.0f\">%s: %u moves, %u blends, cycle %.2f s, "
            "max deviation %.4g %s</text>\n</g>\n</svg>\n",
            M, ly0 + 66, title, (unsigned)st->moves, (unsigned)st->sm.blends, st->cycle_time,
            st->dev_max * c->f, u);
#undef SX
#undef SY
    int bad = ferror(fp);
    if (fclose(fp) || bad)
        return EF_ERR_IO;
    return EF_OK;
}

/* The summary on stdout. */
static void crep_summary(const crep_ctx_t *c, const char *title, const ef_pipe_stats_t *st,
                         const ef_pipe_cfg_t *cfg)
{
    double f = c->f ? c->f : 1.0;
    const char *u = c->units == 20 ? "in" : "mm";
    const ef_smooth_stats_t *sm = &st->sm;
    printf("program          %s (%s)\n", title, c->units == 20 ? "G20, inch" : "G21, mm");
    printf("primitives       %u (%u rapids, %u arcs), %u events, %u notes (%u zero-length "
           "moves)\n",
           (unsigned)st->prims, (unsigned)st->rapids, (unsigned)st->arcs, (unsigned)st->events,
           (unsigned)st->notes, (unsigned)st->zero_moves);
    printf("moves            %u: %u line, %u arc, %u blend, %u smooth\n", (unsigned)st->moves,
           (unsigned)st->moves_kind[EF_MOVE_LINE], (unsigned)st->moves_kind[EF_MOVE_ARC],
           (unsigned)st->moves_kind[EF_MOVE_BLEND], (unsigned)st->moves_kind[EF_MOVE_SMOOTH]);
    if (sm->remnants)
        printf("                 %u remnants under %g mm absorbed (not moves: joined to the "
               "move before, or at rest)\n",
               (unsigned)sm->remnants, (double)EF_MIN_CHORD);
    printf("vertices         %u blended, %u straight, %u exact stops (%u reversals, %u slow "
           "corners), %u merged, %u smooth\n",
           (unsigned)sm->blends, (unsigned)sm->straight, (unsigned)sm->stops,
           (unsigned)sm->reversals, (unsigned)sm->slow_corners, (unsigned)sm->merged,
           (unsigned)sm->smooth);
    printf("deviation        max %.4g %s at line %u (tolerance %.4g %s there), %u moves over "
           "tolerance\n",
           st->dev_max * f, u, (unsigned)st->dev_max_line, st->dev_max_tol * f, u,
           (unsigned)st->dev_over);
    if (sm->aux_moves || sm->aux_stops || sm->aux_dev_max > 0.0f)
        printf("axes A B C U V W %u moves of them alone, %u exact stops for their rate changes, "
               "blend deviation max %.4g (deg or mm; tolerance %.4g)\n",
               (unsigned)sm->aux_moves, (unsigned)sm->aux_stops, (double)sm->aux_dev_max,
               c->o->cfg.aux_tol[0]);
    printf("cycle time       %.3f s (rapids %.3f s), path length %.2f %s\n", st->cycle_time,
           st->rapid_time, st->length * f, u);
    printf("end position     %.4f %.4f %.4f %s\n", st->end[0] * f, st->end[1] * f, st->end[2] * f,
           u);
    if (!cfg->interp_modes)
        return;
    printf("feed fluctuation |dp|/dt vs planned speed, servo period %u us:\n",
           (unsigned)cfg->period_us);
    static const char *names[2] = {"uniform", "corrected"};
    for (int k = 0; k < 2; k++) {
        const ef_pipe_fluct_t *fl = &st->fl[k];
        if (!(cfg->interp_modes & (1u << k)))
            continue;
        printf("  %-10s     max %.3e  rms %.3e  (%llu samples, max at line %u, %u underruns)\n",
               names[k], fl->max_rel, fl->rms_rel, (unsigned long long)fl->samples,
               (unsigned)fl->max_line, (unsigned)fl->underruns);
        printf("  %-10s     at >= %.0f %% of the feed: max %.3e (%llu samples, line %u); "
               "largest speed error %.4f %s/s\n",
               "", 100.0 * EF_PIPE_FLUCT_FEED_SHARE, fl->max_rel_feed,
               (unsigned long long)fl->samples_feed, (unsigned)fl->max_line_feed, fl->max_abs * f,
               u);
    }
}

/* Write the JSON file: program, units, tolerance, the buffered segments, the summary and
 * the run's status (rc: ef_pipe_run()'s result). */
static int crep_write_json(const crep_ctx_t *c, const char *path, const char *title,
                           const ef_pipe_stats_t *st, int rc)
{
    FILE *fp = fopen(path, "w");
    if (!fp)
        return EF_ERR_IO;
    const cli_smooth_opts_t *o = c->o;
    double f = c->f;
    fputs("{\n  \"program\": ", fp);
    cli_json_str(fp, title);
    fprintf(fp, ",\n  \"units\": \"%s\",\n  \"tolerance\": ", c->units == 20 ? "inch" : "mm");
    cli_json_num(fp, (st->tol_max > 0 ? st->tol_max : o->cfg.tol_default) * f);
    fputs(",\n  \"segments\": [\n", fp);
    if (c->seglen)
        fwrite(c->segbuf, 1, c->seglen, fp);
    fprintf(fp,
            "\n  ],\n  \"summary\": {\"primitives\": %u, \"rapids\": %u, \"arcs\": %u, "
            "\"events\": %u, \"notes\": %u, \"moves\": %u, \"lines\": %u, "
            "\"arc_pieces\": %u, \"blends\": %u, \"smooth_moves\": %u, "
            "\"exact_stops\": %u, \"reversals\": %u, \"slow_corners\": %u, \"merged\": %u, "
            "\"smooth_vertices\": %u, \"remnants\": %u, \"dev_max\": ",
            (unsigned)st->prims, (unsigned)st->rapids, (unsigned)st->arcs, (unsigned)st->events,
            (unsigned)st->notes, (unsigned)st->moves, (unsigned)st->moves_kind[EF_MOVE_LINE],
            (unsigned)st->moves_kind[EF_MOVE_ARC], (unsigned)st->moves_kind[EF_MOVE_BLEND],
            (unsigned)st->moves_kind[EF_MOVE_SMOOTH], (unsigned)st->sm.stops,
            (unsigned)st->sm.reversals, (unsigned)st->sm.slow_corners, (unsigned)st->sm.merged,
            (unsigned)st->sm.smooth, (unsigned)st->sm.remnants);
    cli_json_num(fp, st->dev_max * f);
    fprintf(fp, ", \"dev_over\": %u, \"cycle_time\": ", (unsigned)st->dev_over);
    cli_json_num(fp, st->cycle_time);
    fputs(", \"length\": ", fp);
    cli_json_num(fp, st->length * f);
    static const char *names[2] = {"uniform", "corrected"};
    for (int k = 0; k < 2; k++) {
        if (!(o->cfg.interp_modes & (1u << k)))
            continue;
        fprintf(fp, ", \"fluctuation_%s\": {\"max\": ", names[k]);
        cli_json_num(fp, st->fl[k].max_rel);
        fputs(", \"rms\": ", fp);
        cli_json_num(fp, st->fl[k].rms_rel);
        fprintf(fp,
                ", \"samples\": %llu, \"max_at_feed\": ", (unsigned long long)st->fl[k].samples);
        cli_json_num(fp, st->fl[k].max_rel_feed);
        fprintf(fp, ", \"samples_at_feed\": %llu, \"max_speed_error\": ",
                (unsigned long long)st->fl[k].samples_feed);
        cli_json_num(fp, st->fl[k].max_abs * f);
        fputc('}', fp);
    }
    fprintf(fp, ", \"status\": \"%s\"}\n}\n", rc ? ef_err_str(rc) : "ok");
    int bad = ferror(fp);
    if (fclose(fp) || bad)
        return EF_ERR_IO;
    return EF_OK;
}

/* Whether s ends in ext (case-insensitive), to pick the -o output format. */
static int crep_ends(const char *s, const char *ext)
{
    size_t n = strlen(s), e = strlen(ext);
    return n >= e && !strcasecmp(s + n - e, ext);
}

void cli_smooth_opts_default(cli_smooth_opts_t *o)
{
    memset(o, 0, sizeof *o);
    ef_pipe_cfg_default(&o->cfg);
    o->cfg.g2 = cli_default_table(EF_TABLE_G2_QUINTIC);
    o->cfg.g1 = cli_default_table(EF_TABLE_G1_CUBIC);
    o->cfg.interp_modes = EF_PIPE_INTERP_UNIFORM | EF_PIPE_INTERP_CORRECTED;
    o->cfg.naux = EF_AUX; /* all nine axes unless --axes says fewer */
}

int cli_smooth_run(ef_gcode_t *r, const char *title, const cli_smooth_opts_t *o)
{
    if (!o->cfg.g2 || (o->cfg.smooth_degree == 3 && !o->cfg.g1))
        return cli_error(EF_ERR_ARG, "smooth: this build has no built-in tables");
    crep_ctx_t c;
    memset(&c, 0, sizeof c);
    c.o = o;
    c.dt = o->cfg.period_us * 1e-6;
    int rc = EF_OK;
    if (o->out && crep_ends(o->out, ".json")) {
        c.segs = open_memstream(&c.segbuf, &c.seglen);
        if (!c.segs)
            return cli_error(EF_ERR_NOMEM, "smooth: out of memory");
    } else if (o->out && crep_ends(o->out, ".csv")) {
        c.csv = fopen(o->out, "w");
        if (!c.csv)
            return cli_error(EF_ERR_IO, "smooth: cannot write %s", o->out);
        fputs("t,x,y,z,v_plan,feed,seq,line", c.csv);
        for (int a = 0; a < o->cfg.naux; a++)
            fprintf(c.csv, ",%c", "abcuvw"[a]);
        fputc('\n', c.csv);
    } else if (o->out) {
        return cli_error(EF_ERR_ARG, "smooth: -o %s: the name must end in .json or .csv", o->out);
    }
    ef_pipe_cb_t cb = {crep_item, crep_move, crep_setpoint, NULL, crep_note, &c};
    ef_pipe_stats_t st;
    ef_msg_t m = {{0}};
    rc = ef_pipe_run(r, &o->cfg, &cb, &st, &m);
    crep_units(&c, st.units);
    int wrc = EF_OK;
    const char *werr = NULL;
    if (c.segs) {
        fclose(c.segs);
        wrc = crep_write_json(&c, o->out, title, &st, rc);
        if (wrc)
            werr = o->out;
        free(c.segbuf);
    }
    if (c.csv) {
        int bad = ferror(c.csv);
        if (fclose(c.csv) || bad) {
            wrc = EF_ERR_IO;
            werr = o->out;
        }
    }
    if (o->svg && !wrc) {
        wrc = crep_write_svg(&c, o->svg, title, &st);
        if (wrc)
            werr = o->svg;
    }
    free(c.prog.v);
    free(c.sp.v);
    free(c.blends.v);
    free(c.stops.v);
    fflush(stdout);
    if (rc)
        return cli_error(rc, "%s", m.text);
    if (wrc)
        return cli_error(wrc, "smooth: cannot write %s", werr);
    crep_summary(&c, title, &st, &o->cfg);
    return EF_OK;
}
