/* SPDX-License-Identifier: Apache-2.0 */
/* LinuxCNC-shaped trajectory planner on evenfeed's smoother and interpolator (ef_tp.h). */
#include "evenfeed/host/lcnc/ef_tp.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "evenfeed/core/ef_err.h"

#define TP_PI 3.14159265358979323846
/* A and the other non-XYZ axes count as unchanged within this (degrees or units). */
#define TP_AXIS_EPS 1e-9
#if EF_AUX < EF_TP_AXES - 3
#error "the planner module needs the firmware built with EF_AXES 9 (LinuxCNC's nine axes)"
#endif

/* Jerk of A B C U V W per unit of their acceleration limit (1/s): LinuxCNC gives their
 * speed and acceleration limits, not a jerk (X Y Z default to the same rule, ef_tp.h). */
#define TP_AUX_JERK 20.0

/* Smallest rate headroom share used for the follower's bounds (keeps it moving at r = 1). */
#define TP_HEAD_MIN 0.02

void ef_tp_cfg_default(ef_tp_cfg_t *cfg)
{
    if (!cfg)
        return;
    memset(cfg, 0, sizeof *cfg);
    for (int k = 0; k < 3; k++) {
        cfg->v_axis[k] = 100.0;
        cfg->a_axis[k] = 1000.0;
    }
    for (int k = 0; k < EF_TP_AXES - 3; k++) {
        cfg->v_aux[k] = 100.0;
        cfg->a_aux[k] = 1000.0;
    }
    cfg->aux_tol = 0.02;
    cfg->j_max = 20000.0;
    cfg->plan_share = 0.9;
    cfg->tol_default = 0.02;
    cfg->period_s = 1e-3;
    cfg->max_feed_scale = 1.0;
    cfg->start_wait_s = 0.02;
    cfg->guard_s = 0.01;
    cfg->units_per_cycle = 32;
    cfg->micro_len = 3.0;
}

static int lt_fail(ef_tp_t *tp, int rc, const char *what)
{
    snprintf(tp->msg, sizeof tp->msg, "%s", what);
    return rc;
}

static int lt_finite_pos(double x)
{
    return isfinite(x) && fabs(x) <= (double)EF_MAX_COORD;
}

/* Settings check; the message names the field. */
static int lt_cfg_check(ef_tp_t *tp, const ef_tp_cfg_t *c)
{
    if (!c->g2)
        return lt_fail(tp, EF_ERR_ARG, "evenfeed: no G2 table");
    for (int k = 0; k < 3; k++)
        if (!(c->v_axis[k] > 0.0 && c->a_axis[k] > 0.0 && isfinite(c->v_axis[k]) &&
              isfinite(c->a_axis[k])))
            return lt_fail(tp, EF_ERR_ARG,
                           "evenfeed: an X/Y/Z speed or acceleration limit is not > 0");
    for (int k = 0; k < EF_TP_AXES - 3; k++)
        if (!(c->v_aux[k] > 0.0 && c->a_aux[k] > 0.0 && isfinite(c->v_aux[k]) &&
              isfinite(c->a_aux[k])))
            return lt_fail(tp, EF_ERR_ARG,
                           "evenfeed: an A/B/C/U/V/W speed or acceleration limit is not > 0");
    if (!(c->aux_tol > 0.0 && isfinite(c->aux_tol)))
        return lt_fail(tp, EF_ERR_ARG, "evenfeed: A B C U V W tolerance not > 0");
    if (!(c->j_max > 0.0 && isfinite(c->j_max)))
        return lt_fail(tp, EF_ERR_ARG, "evenfeed: jerk limit not > 0");
    if (!(c->plan_share > 0.0 && c->plan_share <= 1.0))
        return lt_fail(tp, EF_ERR_ARG, "evenfeed: plan_share not in (0, 1]");
    if (!(c->tol_default > 0.0 && isfinite(c->tol_default)))
        return lt_fail(tp, EF_ERR_ARG, "evenfeed: default tolerance not > 0");
    if (!(c->period_s > 0.0 && c->period_s <= 0.1))
        return lt_fail(tp, EF_ERR_ARG, "evenfeed: servo period not in (0, 0.1] s");
    if (!(c->max_feed_scale >= 1.0 && c->max_feed_scale <= 100.0))
        return lt_fail(tp, EF_ERR_ARG, "evenfeed: max feed scale not in [1, 100]");
    if (!(c->start_wait_s >= 0.0 && c->start_wait_s <= 10.0 && c->guard_s >= 0.0 &&
          c->guard_s <= 10.0))
        return lt_fail(tp, EF_ERR_ARG, "evenfeed: start_wait or guard not in [0, 10] s");
    if (!(c->micro_len >= 0.0 && c->micro_len <= 1e3))
        return lt_fail(tp, EF_ERR_ARG, "evenfeed: micro_len not in [0, 1000]");
    if (c->units_per_cycle < 1u)
        return lt_fail(tp, EF_ERR_ARG, "evenfeed: units_per_cycle < 1");
    return EF_OK;
}

static ef_vec3_t lt_v3(const double p[3])
{
    ef_vec3_t v = {(float)p[0], (float)p[1], (float)p[2]};
    return v;
}

/* Smoother and interpolator at rest at the current pose, with the current settings. */
static int lt_restart(ef_tp_t *tp)
{
    const ef_tp_cfg_t *c = &tp->cfg;
    ef_smooth_cfg_t *s = &tp->scfg;
    memset(s, 0, sizeof *s);
    s->g2 = c->g2;
    for (int k = 0; k < 3; k++) {
        s->lim.v_axis[k] = (float)c->v_axis[k];
        s->lim.a_axis[k] = (float)(c->a_axis[k] * c->plan_share);
    }
    /* A B C U V W through the smoother too (ef_smooth.h, "Auxiliary axes") */
    s->naux = EF_TP_AXES - 3;
    for (int k = 0; k < EF_TP_AXES - 3; k++) {
        /* 1 % under the limit: an axis turning at its speed limit along a blend is bounded
         * from 17 samples of the curve (ef_path.h), and LinuxCNC checks every period */
        s->lim.v_axis[3 + k] = (float)(0.99 * c->v_aux[k]);
        s->lim.a_axis[3 + k] = (float)(c->a_aux[k] * c->plan_share);
        s->aux_tol[k] = (float)c->aux_tol;
        s->lim.j_aux[k] = (float)(TP_AUX_JERK * c->a_aux[k] * c->plan_share);
    }
    s->lim.j_max = (float)(c->j_max * c->plan_share);
    s->lim.a_normal_frac = 0.5f;
    s->micro_len = (float)c->micro_len;
    s->micro_turn = 0.35f;
    s->smooth_degree = 5;
    /* LinuxCNC's interpreter has merged CAM micro-segments within G64 Q before they get
     * here: the chords' middles lie up to Q inside the curve their vertices sample */
    s->chord_shift = 1;
    ef_vec3_t p = lt_v3(tp->pos);
    tp->st.blends += tp->sm.st.blends; /* the smoother's counters restart with it */
    tp->st.smooth += tp->sm.st.smooth;
    tp->st.merged += tp->sm.st.merged;
    tp->st.stops += tp->sm.st.stops;
    tp->st.slow_corners += tp->sm.st.slow_corners;
    tp->st.aux_stops += tp->sm.st.aux_stops;
    tp->st.aux_dev_max = fmaxf(tp->st.aux_dev_max, tp->sm.st.aux_dev_max);
    int rc = ef_smooth_init(&tp->sm, s, p);
    for (int k = 0; k < EF_TP_AXES - 3; k++)
        tp->aux_f[k] = (float)tp->pos[3 + k];
    if (rc == EF_OK)
        rc = ef_smooth_set_aux(&tp->sm, tp->aux_f);
    if (rc != EF_OK)
        return lt_fail(tp, rc, "evenfeed: smoother settings refused");
    tp->period_us = (uint32_t)lround(c->period_s * 1e6);
    if (tp->period_us == 0u)
        tp->period_us = 1u;
    rc = ef_interp_init(&tp->ip, p, tp->period_us, EF_STEP_CORRECTED);
    if (rc == EF_OK)
        rc = ef_interp_set_aux(&tp->ip, tp->aux_f);
    if (rc != EF_OK)
        return lt_fail(tp, rc, "evenfeed: interpolator settings refused");
    tp->mh = tp->mn = 0;
    tp->t_fifo = tp->t_interp = 0.0;
    tp->finishing = 0;
    tp->rate_d = 0.0;
    tp->v_plan = 0.0;
    memcpy(tp->goal, tp->pos, sizeof tp->goal);
    return EF_OK;
}

int ef_tp_init(ef_tp_t *tp, const ef_tp_cfg_t *cfg, const ef_tp_ops_t *ops)
{
    if (!tp || !cfg)
        return EF_ERR_ARG;
    memset(tp, 0, sizeof *tp);
    int rc = lt_cfg_check(tp, cfg);
    if (rc != EF_OK)
        return rc;
    tp->cfg = *cfg;
    if (ops)
        tp->ops = *ops;
    tp->next_seq = 1;
    tp->term = EF_TP_TERM_BLEND;
    tp->rate = 1.0;
    return lt_restart(tp);
}

static int lt_at_rest(const ef_tp_t *tp)
{
    return tp->qn == 0 && tp->mn == 0 && ef_interp_space(&tp->ip) == EF_INTERP_QUEUE &&
           tp->state != EF_TP_STOPPING && !tp->aux_on;
}

int ef_tp_configure(ef_tp_t *tp, const ef_tp_cfg_t *cfg)
{
    if (!tp || !cfg)
        return EF_ERR_ARG;
    int rc = lt_cfg_check(tp, cfg);
    if (rc != EF_OK)
        return rc;
    ef_tp_cfg_t old = tp->cfg;
    tp->cfg = *cfg;
    if (memcmp(&old, cfg, sizeof old) != 0 && lt_at_rest(tp))
        return lt_restart(tp);
    return EF_OK; /* otherwise taken at the next rest (ef_tp_cycle()) */
}

int ef_tp_set_pos(ef_tp_t *tp, const double pos[EF_TP_AXES])
{
    if (!tp || !pos)
        return EF_ERR_ARG;
    for (int k = 0; k < EF_TP_AXES; k++)
        if (!lt_finite_pos(pos[k]))
            return lt_fail(tp, EF_ERR_NONFINITE, "evenfeed: position not finite");
    if (!lt_at_rest(tp))
        return lt_fail(tp, EF_ERR_STATE, "evenfeed: position set while moves are queued");
    memcpy(tp->pos, pos, sizeof tp->pos);
    tp->state = EF_TP_IDLE;
    return lt_restart(tp);
}

int ef_tp_set_term(ef_tp_t *tp, int cond, double tol)
{
    if (!tp || cond < EF_TP_TERM_STOP || cond > EF_TP_TERM_TANGENT || !(tol >= 0.0) ||
        !isfinite(tol))
        return EF_ERR_ARG;
    tp->term = cond;
    tp->tol = tol;
    return EF_OK;
}

int ef_tp_set_vlimit(ef_tp_t *tp, double vlimit)
{
    if (!tp || !isfinite(vlimit))
        return EF_ERR_ARG;
    tp->vlimit = vlimit > 0.0 ? vlimit : 0.0;
    return EF_OK;
}

void ef_tp_set_id(ef_tp_t *tp, int32_t id)
{
    if (tp)
        tp->next_id = id;
}

int ef_tp_set_dout(ef_tp_t *tp, int index, int value)
{
    if (!tp || index < 0 || index >= EF_TP_DIOS)
        return EF_ERR_ARG;
    uint64_t bit = (uint64_t)1 << index;
    tp->dio_mask |= bit;
    tp->dio_val = value ? (tp->dio_val | bit) : (tp->dio_val & ~bit);
    return EF_OK;
}

int ef_tp_set_aout(ef_tp_t *tp, int index, double value)
{
    if (!tp || index < 0 || index >= EF_TP_AIOS || !isfinite(value))
        return EF_ERR_ARG;
    tp->aio_mask |= (uint16_t)(1u << index);
    tp->aio[index] = value;
    return EF_OK;
}

/* Checks every add shares; fills the primitive's feed, tolerance and flags. */
static int lt_add_begin(ef_tp_t *tp, const double end[EF_TP_AXES], int type, double vel,
                        double ini_maxvel, ef_prim_t *pr)
{
    if (tp->error)
        return lt_fail(tp, EF_ERR_ARG, "evenfeed: planner stopped after an error (re-enable)");
    if (tp->state == EF_TP_STOPPING)
        return lt_fail(tp, EF_ERR_ARG, "evenfeed: planner is aborting");
    if (type == EF_TP_MOTION_INDEXROTARY)
        return lt_fail(tp, EF_ERR_ARG, "evenfeed: locking indexer moves are not supported");
    if (type < EF_TP_MOTION_TRAVERSE || type > EF_TP_MOTION_PROBING)
        return lt_fail(tp, EF_ERR_ARG, "evenfeed: unknown motion type");
    for (int k = 0; k < EF_TP_AXES; k++)
        if (!lt_finite_pos(end[k]))
            return lt_fail(tp, EF_ERR_NONFINITE, "evenfeed: move end not finite");
    if (!isfinite(vel) || !isfinite(ini_maxvel))
        return lt_fail(tp, EF_ERR_NONFINITE, "evenfeed: speed not finite");
    double feed = fmin(vel * tp->cfg.max_feed_scale, ini_maxvel);
    if (!(vel > 0.0) || !(feed > 0.0))
        return lt_fail(tp, EF_ERR_FEED, "evenfeed: speed not > 0");
    if (tp->qn >= EF_TP_QUEUE)
        return lt_fail(tp, EF_ERR_FULL, "evenfeed: planner queue overflow");
    memset(pr, 0, sizeof *pr);
    pr->feed = (float)(tp->vlimit > 0.0 ? fmin(feed, tp->vlimit) : feed);
    /* LinuxCNC's term condition says how a move ends; evenfeed's tolerance belongs to the
     * vertex where a primitive starts: the previous move's end. */
    double tol =
        tp->term >= EF_TP_TERM_BLEND ? (tp->tol > 0.0 ? tp->tol : tp->cfg.tol_default) : 0.0;
    pr->tol = (float)tp->prev_tol;
    pr->qtol = pr->tol; /* band decimation as the CLI (LinuxCNC: Q = P without Q) */
    tp->next_tol = tol;
    if (type == EF_TP_MOTION_PROBING || tp->prev_probe)
        pr->flags |= EF_PRIM_STOP_BEFORE;
    return EF_OK;
}

/* A queue item at the tail with what the next add gets (outputs, id), the goal moved on. */
static ef_tp_item_t *lt_enqueue(ef_tp_t *tp, const double end[EF_TP_AXES], int type, int enables,
                                int atspeed)
{
    ef_tp_item_t *it = &tp->q[(tp->qh + tp->qn) % EF_TP_QUEUE];
    memset(it, 0, sizeof *it);
    it->seq = tp->next_seq++;
    it->id = tp->next_id;
    it->motion_type = (uint8_t)type;
    it->enables = (uint8_t)enables;
    it->atspeed = atspeed != 0;
    it->dio_mask = tp->dio_mask;
    it->dio_val = tp->dio_val;
    it->aio_mask = tp->aio_mask;
    memcpy(it->aio, tp->aio, sizeof it->aio);
    tp->dio_mask = tp->dio_val = 0;
    tp->aio_mask = 0;
    tp->qn++;
    tp->prev_probe = type == EF_TP_MOTION_PROBING;
    memcpy(tp->goal, end, sizeof tp->goal);
    tp->last_enables = enables;
    tp->quiet_s = 0.0;
    if (tp->state == EF_TP_IDLE)
        tp->state = EF_TP_FILLING;
    tp->st.added++;
    tp->msg[0] = '\0';
    return it;
}

/* Queue a checked primitive. */
static int lt_add_end(ef_tp_t *tp, ef_prim_t *pr, const double end[EF_TP_AXES], int type,
                      int enables, int atspeed)
{
    if (atspeed)
        pr->flags |= EF_PRIM_STOP_BEFORE;
    float len = 0.0f;
    ef_vec3_t start = lt_v3(tp->goal);
    pr->tag = tp->next_seq;
    int rc = ef_prim_check(start, pr, &len);
    if (rc == EF_ERR_DEGENERATE && pr->kind == EF_PRIM_LINE) {
        tp->st.zero++;
        return lt_fail(tp, rc, "evenfeed: zero-length move");
    }
    if (rc != EF_OK) {
        tp->st.refused++;
        return lt_fail(tp, rc, "evenfeed: move refused by the firmware's checks");
    }
    ef_tp_item_t *it = lt_enqueue(tp, end, type, enables, atspeed);
    it->pr = *pr;
    tp->prev_tol = tp->next_tol;
    return EF_OK;
}

/* Queue a move of A B C U V W alone (ef_tp.h, "Axes"): everything before it ends at rest,
 * and so does it. */
static int lt_add_aux(ef_tp_t *tp, const double end[EF_TP_AXES], int type, int enables, double v,
                      double a)
{
    ef_tp_item_t *it = lt_enqueue(tp, end, type, enables, 0);
    it->aux = 1;
    memcpy(it->aux_to, end + 3, sizeof it->aux_to);
    it->aux_v = v;
    it->aux_a = a;
    it->pr.tag = it->seq;
    tp->prev_tol = 0.0; /* the next primitive starts at rest */
    return EF_OK;
}

/* Whether a move changes A B C U V W; *xyz whether it moves X Y Z (in float32, as the
 * smoother sees it). */
static int lt_aux_moves(const ef_tp_t *tp, const double end[EF_TP_AXES], int *xyz)
{
    ef_vec3_t a = lt_v3(tp->goal), b = lt_v3(end);
    *xyz = a.x != b.x || a.y != b.y || a.z != b.z;
    for (int k = 3; k < EF_TP_AXES; k++)
        if (fabs(end[k] - tp->goal[k]) > TP_AXIS_EPS * (1.0 + fabs(tp->goal[k])))
            return 1;
    return 0;
}

/* A B C U V W of a primitive: where the move takes them when it moves them (aux), else
 * exactly those of the one before, so the smoother sees them still. */
static void lt_prim_aux(const ef_tp_t *tp, ef_prim_t *pr, const double end[EF_TP_AXES], int aux)
{
    for (int k = 0; k < EF_TP_AXES - 3; k++)
        pr->aux[k] = aux ? (float)end[3 + k] : tp->aux_f[k];
}

/* A primitive was queued (rc EF_OK): its A B C U V W are where the next one starts; a
 * refused one leaves them (the next starts where the last queued one ended). */
static int lt_aux_taken(ef_tp_t *tp, const ef_prim_t *pr, int rc)
{
    if (rc == EF_OK)
        for (int k = 0; k < EF_TP_AXES - 3; k++)
            tp->aux_f[k] = pr->aux[k];
    return rc;
}

int ef_tp_add_line(ef_tp_t *tp, const double end[EF_TP_AXES], int motion_type, double vel,
                   double ini_maxvel, double acc, int enables, int atspeed)
{
    if (!tp || !end)
        return EF_ERR_ARG;
    ef_prim_t pr;
    int rc = lt_add_begin(tp, end, motion_type, vel, ini_maxvel, &pr);
    int xyz = 0, aux = rc == EF_OK && lt_aux_moves(tp, end, &xyz);
    if (rc != EF_OK) {
        tp->st.refused++;
        return rc;
    }
    pr.kind = EF_PRIM_LINE;
    pr.end = lt_v3(end);
    lt_prim_aux(tp, &pr, end, aux);
    if (aux && !xyz) {
        /* A B C U V W alone, at LinuxCNC's speed and acceleration along the move */
        double v = fmin(vel * tp->cfg.max_feed_scale, ini_maxvel), d2 = 0.0; /* (checked) */
        for (int k = 3; k < EF_TP_AXES; k++)
            d2 += (end[k] - tp->goal[k]) * (end[k] - tp->goal[k]);
        if (!(acc > 0.0) || !isfinite(acc)) {
            tp->st.refused++;
            return lt_fail(tp, EF_ERR_FEED, "evenfeed: acceleration not > 0");
        }
        if (!(d2 > 0.0))
            return lt_fail(tp, EF_ERR_DEGENERATE, "evenfeed: zero-length move");
        return lt_aux_taken(tp, &pr, lt_add_aux(tp, end, motion_type, enables, v, acc));
    }
    return lt_aux_taken(tp, &pr, lt_add_end(tp, &pr, end, motion_type, enables, atspeed));
}

int ef_tp_add_arc(ef_tp_t *tp, const double end[EF_TP_AXES], const double centre[3],
                  const double normal[3], int turn, int motion_type, double vel, double ini_maxvel,
                  int enables, int atspeed)
{
    if (!tp || !end || !centre || !normal)
        return EF_ERR_ARG;
    ef_prim_t pr;
    int rc = lt_add_begin(tp, end, motion_type, vel, ini_maxvel, &pr);
    int xyz = 0, aux = rc == EF_OK && lt_aux_moves(tp, end, &xyz);
    if (rc != EF_OK) {
        tp->st.refused++;
        return rc;
    }
    for (int k = 0; k < 3; k++)
        if (!lt_finite_pos(centre[k]) || !isfinite(normal[k])) {
            tp->st.refused++;
            return lt_fail(tp, EF_ERR_NONFINITE, "evenfeed: arc centre or normal not finite");
        }
    double nl = sqrt(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]);
    if (!(nl > 1e-12)) {
        tp->st.refused++;
        return lt_fail(tp, EF_ERR_ARC, "evenfeed: arc normal is zero");
    }
    double n[3], c[3], a[3], b[3];
    for (int k = 0; k < 3; k++)
        n[k] = normal[k] / nl;
    /* centre moved along the axis to the start's height; start and end radii in the plane */
    double hs = 0.0, he = 0.0;
    for (int k = 0; k < 3; k++) {
        hs += (tp->goal[k] - centre[k]) * n[k];
        he += (end[k] - tp->goal[k]) * n[k];
    }
    for (int k = 0; k < 3; k++) {
        c[k] = centre[k] + n[k] * hs;
        a[k] = tp->goal[k] - c[k];
        b[k] = end[k] - n[k] * he - c[k];
    }
    double cr[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                    a[0] * b[1] - a[1] * b[0]};
    double th =
        atan2(cr[0] * n[0] + cr[1] * n[1] + cr[2] * n[2], a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
    if (th < 0.0)
        th += 2.0 * TP_PI; /* counter-clockwise angle from start to end, [0, 2 pi) */
    double sweep;
    if (turn >= 0) {
        sweep = (th > 1e-12 ? th : 2.0 * TP_PI) + 2.0 * TP_PI * turn;
    } else {
        double cw = th > 1e-12 ? 2.0 * TP_PI - th : 2.0 * TP_PI;
        sweep = -(cw + 2.0 * TP_PI * (-(double)turn - 1.0));
    }
    pr.kind = EF_PRIM_ARC;
    pr.end = lt_v3(end);
    lt_prim_aux(tp, &pr, end, aux);
    pr.centre = lt_v3(c);
    pr.axis = lt_v3(n);
    pr.sweep = (float)sweep;
    return lt_aux_taken(tp, &pr, lt_add_end(tp, &pr, end, motion_type, enables, atspeed));
}

/* Drop everything queued and planned; at rest at the pose reached. */
static void lt_drop(ef_tp_t *tp)
{
    tp->qh = tp->qn = tp->qp = 0;
    tp->dio_mask = tp->dio_val = 0;
    tp->aio_mask = 0;
    tp->exec_seq = 0;
    tp->state = EF_TP_IDLE;
    tp->paused = 0;
    tp->aborting = 0;
    tp->rate = 0.0;
    tp->prev_tol = 0.0;
    tp->prev_probe = 0;
    tp->aux_on = 0;
    (void)lt_restart(tp);
}

void ef_tp_set_at_speed(ef_tp_t *tp, int at_speed)
{
    if (tp)
        tp->at_speed = at_speed != 0;
}

void ef_tp_pause(ef_tp_t *tp)
{
    if (tp)
        tp->paused = 1;
}

void ef_tp_resume(ef_tp_t *tp)
{
    if (tp)
        tp->paused = 0;
}

void ef_tp_abort(ef_tp_t *tp)
{
    if (!tp)
        return;
    if (lt_at_rest(tp) && tp->v_plan == 0.0) {
        lt_drop(tp);
        tp->st.aborts++;
        return;
    }
    tp->aborting = 1;
    tp->state = EF_TP_STOPPING;
}

void ef_tp_clear(ef_tp_t *tp)
{
    if (!tp)
        return;
    tp->error = 0;
    lt_drop(tp);
}

/* Moves the planner released, into the FIFO; the FIFO into the interpolator. */
static int lt_feed(ef_tp_t *tp, int now)
{
    ef_move_t m;
    while (tp->mn < EF_TP_MOVES) {
        int rc = now ? ef_smooth_pull_now(&tp->sm, &m) : ef_smooth_pull(&tp->sm, &m);
        if (rc != EF_OK)
            break;
        tp->mv[(tp->mh + tp->mn) % EF_TP_MOVES] = m;
        tp->mn++;
        tp->t_fifo += m.duration;
        if (now) {
            tp->st.early++;
            break; /* one at a time: the caller checks the time ahead again */
        }
    }
    while (tp->mn > 0 && ef_interp_space(&tp->ip) > 0) {
        const ef_move_t *q = &tp->mv[tp->mh];
        const ef_tp_item_t *it = ef_tp_item(tp, q->tag);
        /* a move that waits for the spindle starts at rest (STOP_BEFORE): held here, the
         * interpolator idles at the previous move's end */
        if (it && it->atspeed && !tp->at_speed && q->v_entry == 0.0f)
            break;
        int rc = ef_interp_push(&tp->ip, q);
        if (rc != EF_OK)
            return rc;
        tp->t_fifo -= q->duration;
        tp->t_interp += q->duration;
        tp->mh = (tp->mh + 1u) % EF_TP_MOVES;
        tp->mn--;
        tp->st.moves++;
    }
    if (tp->mn == 0)
        tp->t_fifo = 0.0;
    return EF_OK;
}

/* An A B C U V W move is done: the smoother and the interpolator (both empty: it ran from
 * rest) go on from where it ended, as the next primitive's start. */
static void lt_aux_sync(ef_tp_t *tp, const ef_tp_item_t *it)
{
    float a[EF_TP_AXES - 3];
    for (int k = 0; k < EF_TP_AXES - 3; k++)
        a[k] = (float)it->aux_to[k];
    (void)ef_smooth_set_aux(&tp->sm, a);
    (void)ef_interp_set_aux(&tp->ip, a);
}

/* Start an A B C U V W move from rest: a degree-1 law along its straight line in those
 * axes' space (length in their units), at the planner's share of its acceleration and a
 * jerk of TP_AUX_JERK per second times that. A move below the firmware's resolution is
 * done at once (it moves less than one float32 step of the law). */
static void lt_aux_start(ef_tp_t *tp, const ef_tp_item_t *it)
{
    double d2 = 0.0;
    for (int k = 0; k < EF_TP_AXES - 3; k++) {
        tp->aux_from[k] = tp->pos[3 + k];
        d2 += (it->aux_to[k] - tp->pos[3 + k]) * (it->aux_to[k] - tp->pos[3 + k]);
    }
    ef_move_t *m = &tp->aux_m;
    memset(m, 0, sizeof *m);
    m->degree = 1;
    m->length = (float)sqrt(d2);
    m->v_max = (float)it->aux_v;
    m->a_max = (float)(it->aux_a * tp->cfg.plan_share);
    m->tag = it->seq;
    tp->aux_t = 0.0;
    tp->aux_on = ef_plan_timelaw(m, (float)(TP_AUX_JERK * m->a_max)) == EF_OK;
    if (!tp->aux_on) {
        memcpy(tp->pos + 3, it->aux_to, sizeof it->aux_to);
        lt_aux_sync(tp, it);
        tp->qp++;
    }
}

/* Advance the A B C U V W move by rate x period; done: at its end exactly, taken. */
static void lt_aux_step(ef_tp_t *tp)
{
    const ef_move_t *m = &tp->aux_m;
    const ef_tp_item_t *it = &tp->q[(tp->qh + tp->qp) % EF_TP_QUEUE];
    tp->aux_t += tp->rate * tp->cfg.period_s;
    if (tp->aux_t >= m->duration) {
        memcpy(tp->pos + 3, it->aux_to, sizeof it->aux_to);
        lt_aux_sync(tp, it);
        tp->aux_on = 0;
        tp->v_plan = 0.0;
        tp->qp++;
        return;
    }
    double u = tp->aux_t, tau = 0.0, v = 0.0;
    for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
        double d = m->law.dt[k];
        if (!(d > 0.0))
            continue;
        const float *c = m->law.c[k];
        if (u <= d) {
            tau = c[0] + u * (c[1] + u * (c[2] + u * c[3]));
            v = m->length * (c[1] + u * (2.0 * c[2] + u * 3.0 * c[3]));
            break;
        }
        u -= d;
    }
    for (int k = 0; k < EF_TP_AXES - 3; k++)
        tp->pos[3 + k] = tp->aux_from[k] + tau * (it->aux_to[k] - tp->aux_from[k]);
    tp->v_plan = v;
}

/* Up to units_per_cycle smoother calls (each at most one work unit). */
static int lt_work(ef_tp_t *tp)
{
    uint32_t n = 0;
    for (; n < tp->cfg.units_per_cycle; n++) {
        int rc = lt_feed(tp, 0);
        if (rc != EF_OK)
            return rc;
        if (tp->qp < tp->qn && tp->q[(tp->qh + tp->qp) % EF_TP_QUEUE].aux) {
            /* an A B C U V W move: everything before it to rest first */
            if (tp->aux_on)
                break;
            if (tp->sm.pn > 0 || tp->sm.sn > 0) {
                rc = ef_smooth_finish(&tp->sm);
                if (rc != EF_OK && rc != EF_ERR_FULL)
                    return rc;
                continue;
            }
            if (tp->sm.plan.mcount > 0 || tp->sm.plan.rel_n > 0 || tp->mn > 0 ||
                ef_interp_space(&tp->ip) < EF_INTERP_QUEUE)
                break; /* its moves are still running */
            lt_aux_start(tp, &tp->q[(tp->qh + tp->qp) % EF_TP_QUEUE]);
            break;
        } else if (tp->qp < tp->qn) {
            const ef_tp_item_t *it = &tp->q[(tp->qh + tp->qp) % EF_TP_QUEUE];
            rc = ef_smooth_push(&tp->sm, &it->pr);
            if (rc == EF_OK)
                tp->qp++;
            else if (rc != EF_ERR_FULL)
                return rc;
        } else if (tp->finishing) {
            rc = ef_smooth_finish(&tp->sm);
            if (rc == EF_OK) {
                tp->finishing = 0;
                tp->st.finishes++;
            } else if (rc != EF_ERR_FULL) {
                return rc;
            }
        } else {
            rc = ef_smooth_work(&tp->sm);
            if (rc == EF_ERR_AGAIN)
                break;
            if (rc != EF_OK)
                return rc;
        }
        if (tp->mn >= EF_TP_MOVES && ef_interp_space(&tp->ip) == 0)
            break; /* everything downstream is full */
    }
    if (n > tp->st.max_units)
        tp->st.max_units = n;
    if (n >= tp->cfg.units_per_cycle)
        tp->st.stalls++;
    return lt_feed(tp, 0);
}

/* The time rate follows its target with r' and r'' bounded by what each axis's limits
 * leave at the current r (file comment of ef_tp.h). With the plan's largest axis
 * acceleration a_i and jerk j_i over the horizon below (its tangential acceleration and
 * jerk through the moves' tangent, curvature and third-derivative bounds) and the axis
 * speed t_i v: half of the acceleration left, A_i - r^2 a_i, for r' t_i v; half of the jerk
 * left, J - r^3 j_i, for r'' t_i v, a quarter for 3 r r' a_i. */
#define TP_HORIZON 0.5  /* s of known moves below which unknown ones are assumed at the limits */
#define TP_LIMIT   0.97 /* share of each limit the sum is kept within (sampling margin) */

/* Largest |a| and |j| of a move's law from time t on (a is linear in each phase, so its
 * extremes are at phase ends; j is constant in each); its remaining time. */
static double lt_law_max(const ef_move_t *m, double t, double *am, double *jm)
{
    double u = t, left = 0.0;
    for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
        double d = m->law.dt[k];
        if (!(d > 0.0))
            continue;
        if (u >= d) {
            u -= d;
            continue;
        }
        const float *c = m->law.c[k];
        double L = m->length;
        double a0 = L * (2.0 * c[2] + u * 6.0 * c[3]), a1 = L * (2.0 * c[2] + d * 6.0 * c[3]);
        *am = fmax(*am, fmax(fabs(a0), fabs(a1)));
        *jm = fmax(*jm, fabs(L * 6.0 * c[3]));
        left += d - u;
        u = 0.0;
    }
    return left;
}

/* Bounds on r' and r'' at rate r from the plan over the next TP_HORIZON seconds of
 * released moves (the executing one from now on, the queued ones whole, then the FIFO's)
 * and, where those last less, moves at the planner's limits after them: the rate's
 * changes take up to about that long, and the plan's acceleration and jerk must not catch
 * it by surprise. */
static void lt_rate_bounds(const ef_tp_t *tp, double r, double *r1, double *r2)
{
    const ef_tp_cfg_t *c = &tp->cfg;
    *r1 = *r2 = 1e30;
    if (tp->aux_on) { /* an A B C U V W move: a line at its own limits */
        const ef_move_t *m = &tp->aux_m;
        double s = c->plan_share, a = m->a_max / s, j = TP_AUX_JERK * m->a_max / s;
        double A = fmax(TP_LIMIT * a - r * r * s * a, TP_HEAD_MIN * a);
        double J = fmax(TP_LIMIT * j - r * r * r * s * j, TP_HEAD_MIN * j);
        double tv = fmax(m->v_max, 1e-9);
        *r1 = fmin(0.5 * A / tv, 0.25 * J / (3.0 * fmax(r, 0.05) * s * a));
        *r2 = 0.5 * J / tv;
        return;
    }
    uint32_t n = EF_INTERP_QUEUE - ef_interp_space(&tp->ip);
    if (n == 0)
        return; /* nothing executing: the rate moves nothing */
    if (tp->ip.t == 0.0f && tp->ip.q[tp->ip.head].v_entry == 0.0f)
        return; /* at rest where a move starts from rest (a program's start after LinuxCNC's
                 * feed inhibit): its time law starts with zero speed and acceleration and
                 * ramps within the limits at any rate up to 1, so the rate may step */
    double an[EF_TP_AXES] = {0}, jn[EF_TP_AXES] = {0}, tv[EF_TP_AXES] = {0}, known = 0.0;
    for (uint32_t q = 0; q < n + tp->mn && known < TP_HORIZON; q++) {
        const ef_move_t *m = q < n ? &tp->ip.q[(tp->ip.head + q) % EF_INTERP_QUEUE]
                                   : &tp->mv[(tp->mh + q - n) % EF_TP_MOVES];
        double am = 0.0, jm = 0.0;
        known += lt_law_max(m, q == 0 ? tp->ip.t : 0.0, &am, &jm);
        double v = fmin(m->v_max, fmax(m->feed, fmax(m->v_entry, m->v_exit)));
        float mt[EF_TP_AXES] = {m->tabs.x, m->tabs.y, m->tabs.z};
        float mk[EF_TP_AXES] = {m->kabs.x, m->kabs.y, m->kabs.z};
        float mg[EF_TP_AXES] = {m->kjerk.x, m->kjerk.y, m->kjerk.z};
        for (int i = 3; i < EF_TP_AXES; i++) {
            mt[i] = m->atabs[i - 3];
            mk[i] = m->akabs[i - 3];
            mg[i] = m->akjerk[i - 3];
        }
        for (int i = 0; i < EF_TP_AXES; i++) {
            an[i] = fmax(an[i], mt[i] * am + mk[i] * v * v);
            jn[i] = fmax(jn[i], mt[i] * jm + 3.0 * mk[i] * v * am + mg[i] * v * v * v);
            tv[i] = fmax(tv[i], mt[i] * v);
        }
    }
    for (int i = 0; i < EF_TP_AXES; i++) {
        double ai = i < 3 ? c->a_axis[i] : c->a_aux[i - 3];
        double vi = i < 3 ? c->v_axis[i] : c->v_aux[i - 3];
        if (known < TP_HORIZON && i < 3) { /* after the known moves: a line at the limits */
            an[i] = fmax(an[i], c->plan_share * ai);
            jn[i] = fmax(jn[i], c->plan_share * c->j_max);
            tv[i] = fmax(tv[i], vi);
        }
        if (i >= 3 && !(tv[i] > 0.0))
            continue; /* an axis the known moves leave still */
        double ji = i < 3 ? c->j_max : TP_AUX_JERK * ai;
        double A = fmax(TP_LIMIT * ai - r * r * an[i], TP_HEAD_MIN * ai);
        double J = fmax(TP_LIMIT * ji - r * r * r * jn[i], TP_HEAD_MIN * ji);
        double t = fmax(tv[i], 1e-9);
        *r1 = fmin(*r1, 0.5 * A / t);
        *r2 = fmin(*r2, 0.5 * J / t);
        if (an[i] > 0.0)
            *r1 = fmin(*r1, 0.25 * J / (3.0 * fmax(r, 0.05) * an[i]));
    }
}

/* The follower: r' toward the fastest approach that can still brake to the target (the
 * curve sqrt(2 r2 e)), changed by at most r2 dt per period. Towards a higher rate the
 * jerk left shrinks as r grows, so the braking curve takes r2 at the target; r1 is taken
 * at the current r (it shrinks on the way up too, within the halves and quarter of the
 * headroom each term is given). */
static void lt_rate(ef_tp_t *tp, double target)
{
    double dt = tp->cfg.period_s, r = tp->rate;
    double r1, r2, r1h, r2h = 1e30;
    lt_rate_bounds(tp, r, &r1, &r2);
    if (target > r)
        lt_rate_bounds(tp, target, &r1h, &r2h); /* only r2h is used: the braking */
    double r2b = fmin(r2, r2h);
    double e = target - r;
    double lim = r2 * dt;
    double brake = fmax(sqrt(2.0 * r2b * fabs(e)) - r2b * dt, 0.0);
    double want = copysign(fmin(r1, brake), e);
    double d = want - tp->rate_d;
    tp->rate_d += d > lim ? lim : (d < -lim ? -lim : d);
    double rn = r + tp->rate_d * dt;
    /* arrived (or passed by the last, small step, or within a step the braking curve
     * resolves no more): settle on the target */
    if ((e >= 0.0 && rn >= target) || (e <= 0.0 && rn <= target) ||
        (fabs(target - rn) <= r2 * dt * dt && fabs(tp->rate_d) <= lim)) {
        rn = target;
        tp->rate_d = 0.0;
    }
    tp->rate = rn < 0.0 ? 0.0 : (rn > 1.0 ? 1.0 : rn);
}

/* Outputs of items up to seq, once each. */
static void lt_fire(ef_tp_t *tp, uint32_t seq)
{
    for (uint32_t k = 0; k < tp->qp; k++) {
        ef_tp_item_t *it = &tp->q[(tp->qh + k) % EF_TP_QUEUE];
        if (it->seq > seq)
            break;
        if (it->fired)
            continue;
        it->fired = 1;
        for (int i = 0; i < EF_TP_DIOS && it->dio_mask; i++)
            if ((it->dio_mask >> i) & 1u) {
                if (tp->ops.dio_write)
                    tp->ops.dio_write(tp->ops.user, i, (int)((it->dio_val >> i) & 1u));
            }
        for (int i = 0; i < EF_TP_AIOS && it->aio_mask; i++)
            if ((it->aio_mask >> i) & 1u) {
                if (tp->ops.aio_write)
                    tp->ops.aio_write(tp->ops.user, i, it->aio[i]);
            }
    }
}

/* Items before the executing one leave the queue; all pushed ones once everything ran. */
static void lt_retire(ef_tp_t *tp, uint32_t upto_seq, int all)
{
    while (tp->qp > 0) {
        ef_tp_item_t *it = &tp->q[tp->qh];
        if (!all && it->seq >= upto_seq)
            break;
        tp->qh = (tp->qh + 1u) % EF_TP_QUEUE;
        tp->qn--;
        tp->qp--;
    }
}

int ef_tp_cycle(ef_tp_t *tp, double scale, ef_tp_status_t *st)
{
    if (!tp)
        return EF_ERR_ARG;
    int rc = EF_OK;
    tp->quiet_s += tp->cfg.period_s;
    if (!tp->error && tp->state != EF_TP_STOPPING) {
        rc = lt_work(tp);
        if (rc == EF_OK && tp->state == EF_TP_FILLING &&
            (tp->qn >= EF_TP_START_MOVES || tp->quiet_s >= tp->cfg.start_wait_s || tp->mn > 0 ||
             ef_interp_space(&tp->ip) < EF_INTERP_QUEUE))
            tp->state = EF_TP_RUNNING;
        if (rc == EF_OK && tp->state == EF_TP_RUNNING) {
            /* keep guard_s of released motion ahead of the setpoint (while it advances:
             * at rate 0, a pause or LinuxCNC's feed inhibit, nothing is consumed, and an
             * early release would only cut the look-ahead of moves still coming in) */
            while (rc == EF_OK && tp->t_fifo + tp->t_interp < tp->cfg.guard_s &&
                   tp->mn < EF_TP_MOVES && tp->rate > 0.0) {
                uint32_t before = tp->st.early;
                rc = lt_feed(tp, 1);
                if (tp->st.early == before)
                    break;
            }
            /* nothing left to release, no input for two periods: bring the rest in */
            if (rc == EF_OK && !tp->finishing && tp->qp == tp->qn &&
                tp->t_fifo + tp->t_interp < tp->cfg.guard_s && tp->sm.plan.mcount == 0 &&
                tp->sm.plan.rel_n == 0 && (tp->sm.pn > 0 || tp->sm.sn > 0) &&
                tp->quiet_s >= 2.0 * tp->cfg.period_s)
                tp->finishing = 1;
        }
        if (rc != EF_OK) {
            /* the smoother refused its own data: stop where we are */
            tp->error = 1;
            snprintf(tp->msg, sizeof tp->msg, "evenfeed: planner failed (%s): stopping",
                     ef_err_str(rc));
            tp->aborting = 1;
            tp->state = EF_TP_STOPPING;
        }
    }
    double target = (tp->paused || tp->aborting || !(scale > 0.0))
                        ? 0.0
                        : fmin(scale / tp->cfg.max_feed_scale, 1.0);
    lt_rate(tp, target);
    ef_setpoint_t sp;
    int irc = ef_interp_process_rate(&tp->ip, tp->period_us, (float)tp->rate, NULL, &sp);
    if (irc == EF_ERR_UNDERRUN) {
        tp->st.underruns++;
        rc = rc == EF_OK ? EF_ERR_UNDERRUN : rc;
    }
    tp->t_interp -= tp->rate * tp->cfg.period_s;
    if (tp->t_interp < 0.0 || ef_interp_space(&tp->ip) == EF_INTERP_QUEUE)
        tp->t_interp = 0.0;
    tp->pos[0] = sp.p.x;
    tp->pos[1] = sp.p.y;
    tp->pos[2] = sp.p.z;
    if (!tp->aux_on) /* (during one the interpolator idles where it began) */
        for (int k = 0; k < EF_TP_AXES - 3; k++)
            tp->pos[3 + k] = sp.aux[k];
    tp->v_plan = sp.moving ? sp.v_plan : 0.0;
    if (sp.moving) {
        tp->exec_seq = sp.tag;
        lt_fire(tp, sp.tag);
        lt_retire(tp, sp.tag, 0);
    }
    uint32_t aux_seq = 0; /* the A B C U V W move this period (0: none) */
    if (tp->aux_on) {
        aux_seq = tp->q[(tp->qh + tp->qp) % EF_TP_QUEUE].seq;
        tp->exec_seq = aux_seq;
        lt_fire(tp, aux_seq);
        lt_retire(tp, aux_seq, 0);
        lt_aux_step(tp);
    }
    int idle = !sp.moving && !aux_seq && ef_interp_space(&tp->ip) == EF_INTERP_QUEUE && tp->mn == 0;
    if (idle && tp->qp == tp->qn && tp->sm.plan.mcount == 0 && tp->sm.plan.rel_n == 0 &&
        tp->sm.pn == 0 && tp->sm.sn == 0) {
        lt_fire(tp, UINT32_MAX);
        lt_retire(tp, 0, 1);
    }
    if (tp->state == EF_TP_STOPPING && tp->rate == 0.0 && tp->rate_d == 0.0) {
        lt_drop(tp); /* at rest on the path: everything else goes */
        tp->st.aborts++;
        tp->rate = 0.0;
    } else if (tp->state != EF_TP_STOPPING && tp->qn == 0 && idle && !tp->error) {
        if (tp->state != EF_TP_IDLE) {
            tp->state = EF_TP_IDLE;
            (void)lt_restart(tp); /* settings that came while moving */
        }
    }
    if (st) {
        memset(st, 0, sizeof *st);
        memcpy(st->pos, tp->pos, sizeof st->pos);
        st->rate = tp->rate;
        st->v = tp->rate * tp->v_plan;
        st->moving = sp.moving || aux_seq;
        st->done = tp->qn == 0 && idle && tp->state != EF_TP_STOPPING;
        st->underrun = irc == EF_ERR_UNDERRUN;
        st->enables = tp->last_enables;
        if (sp.moving) {
            const ef_tp_item_t *it = ef_tp_item(tp, sp.tag);
            const ef_move_t *m = &tp->ip.q[tp->ip.head];
            st->exec_seq = sp.tag;
            st->v_req = m->v_max;
            double dx = m->b[m->degree].x - sp.p.x, dy = m->b[m->degree].y - sp.p.y,
                   dz = m->b[m->degree].z - sp.p.z;
            st->dtg = sqrt(dx * dx + dy * dy + dz * dz);
            if (it) {
                st->exec_id = it->id;
                st->motion_type = it->motion_type;
                st->enables = it->enables;
            }
        } else if (aux_seq) {
            const ef_tp_item_t *it = ef_tp_item(tp, aux_seq);
            double d2 = 0.0;
            for (int k = 3; it && k < EF_TP_AXES; k++)
                d2 += (it->aux_to[k - 3] - tp->pos[k]) * (it->aux_to[k - 3] - tp->pos[k]);
            st->exec_seq = aux_seq;
            st->v_req = tp->aux_m.v_max;
            st->dtg = sqrt(d2);
            if (it) {
                st->exec_id = it->id;
                st->motion_type = it->motion_type;
                st->enables = it->enables;
            }
        }
    }
    return rc;
}

int ef_tp_full(const ef_tp_t *tp)
{
    return !tp || tp->error || tp->qn + EF_TP_QUEUE_MARGIN >= EF_TP_QUEUE;
}

uint32_t ef_tp_depth(const ef_tp_t *tp)
{
    return tp ? tp->qn : 0u;
}

const char *ef_tp_msg(const ef_tp_t *tp)
{
    return tp ? tp->msg : "";
}

const ef_tp_item_t *ef_tp_item(const ef_tp_t *tp, uint32_t seq)
{
    if (!tp || tp->qn == 0)
        return NULL;
    uint32_t first = tp->q[tp->qh].seq;
    if (seq < first || seq - first >= tp->qn)
        return NULL;
    return &tp->q[(tp->qh + (seq - first)) % EF_TP_QUEUE];
}
