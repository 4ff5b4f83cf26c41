/* SPDX-License-Identifier: GPL-2.0-or-later */
/*
 * evenfeedtp: evenfeed as LinuxCNC's trajectory planner ([TRAJ]TPMOD = evenfeedtp).
 *
 * This file includes LinuxCNC's headers (GPL-2.0-or-later), hence its licence; it only
 * converts LinuxCNC's types and calls the planner core, host/lib/lcnc/ef_tp.c (Apache-2.0),
 * which the host test suite runs under ASan/UBSan. How motmod loads and calls a planner
 * module: docs/linuxcnc-tpmod-interface.md; what is supported: docs/linuxcnc.md.
 *
 * Module parameters (halcmd loadrt evenfeedtp name=value, or after the name in TPMOD):
 *   jerk=J        jerk limit of every axis, units/s^3 (default: 20/s x the smallest X/Y/Z
 *                 acceleration limit)
 *   tolerance=P   path tolerance for G64 without P, units (default 0.02)
 *   plan_share=S  share of acceleration and jerk the planner plans to (default 0.9)
 *   aux_tolerance=T  largest deviation of a blend from A B C U V W, deg or units
 *                 (default 0.02; docs/axes.md)
 *   trace=FILE    record every call motmod makes, for tests/lcnc (not for production)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rtapi.h"
#include "rtapi_app.h"
#include "hal.h"
#include "motion.h"
#include "tp.h"

#include "evenfeed/host/lcnc/ef_tp.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/table/ef_table.h"

MODULE_AUTHOR("evenfeed");
MODULE_DESCRIPTION("evenfeed trajectory planner (G2 blends, jerk-limited feed)");
MODULE_LICENSE("GPL");

static char *jerk = "";
RTAPI_MP_STRING(jerk, "jerk limit of every axis (units/s^3)");
static char *tolerance = "";
RTAPI_MP_STRING(tolerance, "path tolerance for G64 without P (units)");
static char *plan_share = "";
RTAPI_MP_STRING(plan_share, "share of acceleration and jerk the planner plans to");
static char *aux_tolerance = "";
RTAPI_MP_STRING(aux_tolerance, "blend tolerance of A B C U V W (deg or units)");
static char *trace = "";
RTAPI_MP_STRING(trace, "file to record motmod's calls to (tests)");

extern const ef_table_t ef_tbl_g2_default;

static int comp_id;
static ef_tp_t ef;
static ef_tp_cfg_t cfg;
static int ready;
static struct state_tag_t tags[EF_TP_QUEUE];
static struct state_tag_t idle_tag;
static emcmot_status_t *mstat;
static emcmot_config_t *mcfg;
static void (*dio_write)(int, char);
static void (*aio_write)(int, double);
static double (*vel_limit)(int);
static double (*acc_limit)(int);
static int spindle_sync;
static double user_jerk, user_tol, user_share, user_aux_tol;

/* ---- call trace (tests/lcnc/: replayed by test_tp under ASan) ---- */
static FILE *tr;
static double tr_scale = -1.0;
static long tr_cycles;

static void tr_flush(void)
{
    if (tr && tr_cycles > 0) {
        fprintf(tr, "cycles %ld %.17g %d\n", tr_cycles, tr_scale, ef.at_speed);
        tr_cycles = 0;
    }
}

static void tr_pose(const char *what, const EmcPose *p)
{
    fprintf(tr, "%s %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g", what, p->tran.x,
            p->tran.y, p->tran.z, p->a, p->b, p->c, p->u, p->v, p->w);
}

static void pose_to(const EmcPose *p, double out[EF_TP_AXES])
{
    out[0] = p->tran.x;
    out[1] = p->tran.y;
    out[2] = p->tran.z;
    out[3] = p->a;
    out[4] = p->b;
    out[5] = p->c;
    out[6] = p->u;
    out[7] = p->v;
    out[8] = p->w;
}

static void pose_from(const double in[EF_TP_AXES], EmcPose *p)
{
    p->tran.x = in[0];
    p->tran.y = in[1];
    p->tran.z = in[2];
    p->a = in[3];
    p->b = in[4];
    p->c = in[5];
    p->u = in[6];
    p->v = in[7];
    p->w = in[8];
}

static void ef_dio(void *user, int index, int value)
{
    (void)user;
    if (dio_write)
        dio_write(index, (char)value);
}

static void ef_aio(void *user, int index, double value)
{
    (void)user;
    if (aio_write)
        aio_write(index, value);
}

static double param(const char *s, double dflt)
{
    if (!s || !*s)
        return dflt;
    char *e = NULL;
    double v = strtod(s, &e);
    return (e && *e == '\0' && isfinite(v)) ? v : NAN;
}

/* The settings from motion's configuration and the axes' limits (they arrive after
 * tpCreate, from task's commands). */
static void refresh_cfg(int force)
{
    ef_tp_cfg_t c = cfg;
    for (int k = 0; k < 3; k++) {
        double v = vel_limit ? vel_limit(k) : 0.0, a = acc_limit ? acc_limit(k) : 0.0;
        if (v > 0.0 && isfinite(v))
            c.v_axis[k] = v;
        if (a > 0.0 && isfinite(a))
            c.a_axis[k] = a;
    }
    for (int k = 3; k < EF_TP_AXES; k++) {
        double v = vel_limit ? vel_limit(k) : 0.0, a = acc_limit ? acc_limit(k) : 0.0;
        if (v > 0.0 && isfinite(v))
            c.v_aux[k - 3] = v;
        if (a > 0.0 && isfinite(a))
            c.a_aux[k - 3] = a;
    }
    double amin = fmin(c.a_axis[0], fmin(c.a_axis[1], c.a_axis[2]));
    c.j_max = user_jerk > 0.0 ? user_jerk : 20.0 * amin;
    if (mcfg && mcfg->maxFeedScale >= 1.0 && mcfg->maxFeedScale <= 100.0)
        c.max_feed_scale = mcfg->maxFeedScale;
    if (!force && memcmp(&c, &cfg, sizeof c) == 0)
        return;
    if (ef_tp_configure(&ef, &c) == EF_OK) {
        cfg = c;
        if (tr) {
            tr_flush();
            fprintf(tr, "cfg %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n",
                    c.period_s, c.max_feed_scale, c.v_axis[0], c.v_axis[1], c.v_axis[2],
                    c.a_axis[0], c.a_axis[1], c.a_axis[2], c.j_max, c.plan_share, c.tol_default);
            fprintf(tr, "cfgaux");
            for (int k = 0; k < EF_TP_AXES - 3; k++)
                fprintf(tr, " %.17g", c.v_aux[k]);
            for (int k = 0; k < EF_TP_AXES - 3; k++)
                fprintf(tr, " %.17g", c.a_aux[k]);
            fprintf(tr, " %.17g\n", c.aux_tol);
        }
    } else {
        rtapi_print_msg(RTAPI_MSG_ERR, "%s\n", ef_tp_msg(&ef));
    }
}

/* ---- module ---- */
int rtapi_app_main(void)
{
    comp_id = hal_init("evenfeedtp");
    if (comp_id < 0) {
        rtapi_print_msg(RTAPI_MSG_ERR, "evenfeedtp: hal_init() failed\n");
        return -1;
    }
    user_jerk = param(jerk, 0.0);
    user_tol = param(tolerance, 0.02);
    user_share = param(plan_share, 0.9);
    user_aux_tol = param(aux_tolerance, 0.02);
    if (!(user_jerk >= 0.0) || !(user_tol > 0.0) || !(user_share > 0.0 && user_share <= 1.0) ||
        !(user_aux_tol > 0.0)) {
        rtapi_print_msg(RTAPI_MSG_ERR, "evenfeedtp: bad parameter (jerk >= 0, tolerance > 0, 0 < "
                                       "plan_share <= 1, aux_tolerance > 0)\n");
        hal_exit(comp_id);
        return -1;
    }
    if (trace && *trace) {
        tr = fopen(trace, "w");
        if (!tr)
            rtapi_print_msg(RTAPI_MSG_ERR, "evenfeedtp: cannot write trace %s\n", trace);
        else
            fprintf(tr, "# evenfeed tp trace 2\n");
    }
    hal_ready(comp_id);
    return 0;
}

void rtapi_app_exit(void)
{
    if (tr) {
        tr_flush();
        fclose(tr);
        tr = NULL;
    }
    hal_exit(comp_id);
}

void tpMotFunctions(void (*pDioWrite)(int, char), void (*pAioWrite)(int, double),
                    void (*pSetRotaryUnlock)(int, int), int (*pGetRotaryUnlock)(int),
                    double (*paxis_get_vel_limit)(int), double (*paxis_get_acc_limit)(int))
{
    (void)pSetRotaryUnlock;
    (void)pGetRotaryUnlock;
    dio_write = pDioWrite;
    aio_write = pAioWrite;
    vel_limit = paxis_get_vel_limit;
    acc_limit = paxis_get_acc_limit;
}

void tpMotData(emcmot_status_t *pstatus, emcmot_config_t *pconfig)
{
    mstat = pstatus;
    mcfg = pconfig;
}

static void sync_tp(TP_STRUCT *tp)
{
    double p[EF_TP_AXES];
    memcpy(p, ef.pos, sizeof p);
    pose_from(p, &tp->currentPos);
    pose_from(ef.goal, &tp->goalPos);
    tp->depth = (int)ef_tp_depth(&ef);
    tp->reverse_run = 0;
}

int tpCreate(TP_STRUCT *const tp, int _queueSize, int id)
{
    (void)_queueSize;
    (void)id;
    if (!tp)
        return -1;
    ef_tp_cfg_default(&cfg);
    cfg.g2 = &ef_tbl_g2_default;
    cfg.tol_default = user_tol;
    cfg.aux_tol = user_aux_tol;
    cfg.plan_share = user_share;
    if (user_jerk > 0.0)
        cfg.j_max = user_jerk;
    ef_tp_ops_t ops = {ef_dio, ef_aio, NULL};
    if (ef_tp_init(&ef, &cfg, &ops) != EF_OK) {
        rtapi_print_msg(RTAPI_MSG_ERR, "evenfeedtp: %s\n", ef_tp_msg(&ef));
        return -1;
    }
    memset(tp, 0, sizeof *tp);
    tp->done = 1;
    tp->termCond = TC_TERM_COND_PARABOLIC;
    ready = 1;
    if (tr)
        fprintf(tr, "create\n");
    return 0;
}

int tpClear(TP_STRUCT *const tp)
{
    if (tr) {
        tr_flush();
        fprintf(tr, "clear\n");
    }
    ef_tp_clear(&ef);
    spindle_sync = 0;
    if (tp) {
        sync_tp(tp);
        tp->done = 1;
        tp->execId = 0;
        tp->motionType = 0;
        tp->activeDepth = 0;
    }
    if (mstat) {
        mstat->current_vel = mstat->requested_vel = mstat->distance_to_go = 0.0;
        memset(&mstat->dtg, 0, sizeof mstat->dtg);
    }
    return 0;
}

int tpClearDIOs(TP_STRUCT *const tp)
{
    (void)tp;
    return 0;
}

int tpSetCycleTime(TP_STRUCT *tp, double secs)
{
    (void)tp;
    if (!(secs > 0.0))
        return -1;
    cfg.period_s = secs;
    if (ready)
        refresh_cfg(1);
    return 0;
}

int tpSetVmax(TP_STRUCT *tp, double vmax, double ini_maxvel)
{
    (void)tp;
    (void)ini_maxvel;
    return vmax > 0.0 ? 0 : -1; /* per-move speeds come with each move */
}

int tpSetVlimit(TP_STRUCT *tp, double limit)
{
    (void)tp;
    if (tr) {
        tr_flush();
        fprintf(tr, "vlimit %.17g\n", limit);
    }
    return ef_tp_set_vlimit(&ef, limit) == EF_OK ? 0 : -1;
}

int tpSetAmax(TP_STRUCT *tp, double amax)
{
    (void)tp;
    return amax > 0.0 ? 0 : -1;
}

int tpSetId(TP_STRUCT *tp, int id)
{
    (void)tp;
    if (!MOTION_ID_VALID(id))
        return -1;
    if (tr) {
        tr_flush();
        fprintf(tr, "id %d\n", id);
    }
    ef_tp_set_id(&ef, id);
    return 0;
}

int tpGetExecId(TP_STRUCT *tp)
{
    return tp ? tp->execId : 0;
}

struct state_tag_t tpGetExecTag(TP_STRUCT *const tp)
{
    return tp ? tp->execTag : idle_tag;
}

int tpSetTermCond(TP_STRUCT *tp, int cond, double tolerance_)
{
    if (tr) {
        tr_flush();
        fprintf(tr, "term %d %.17g\n", cond, tolerance_);
    }
    if (ef_tp_set_term(&ef, cond, tolerance_) != EF_OK)
        return -1;
    if (tp) {
        tp->termCond = cond;
        tp->tolerance = tolerance_;
    }
    return 0;
}

int tpSetPos(TP_STRUCT *tp, EmcPose const *const pos)
{
    if (!tp || !pos)
        return -1;
    if (tr) {
        tr_flush();
        tr_pose("pos", pos);
        fputc('\n', tr);
    }
    double p[EF_TP_AXES];
    pose_to(pos, p);
    if (ef_tp_set_pos(&ef, p) != EF_OK) {
        rtapi_print_msg(RTAPI_MSG_ERR, "%s\n", ef_tp_msg(&ef));
        return -1;
    }
    sync_tp(tp);
    return 0;
}

int tpAddCurrentPos(TP_STRUCT *const tp, EmcPose const *const disp)
{
    (void)tp;
    (void)disp;
    return -1; /* not used by motmod */
}

int tpSetCurrentPos(TP_STRUCT *const tp, EmcPose const *const pos)
{
    return tpSetPos(tp, pos);
}

/* An add's result in LinuxCNC's terms; the reason goes to LinuxCNC's error display. */
static int add_result(TP_STRUCT *tp, int rc, struct state_tag_t tag)
{
    if (rc == EF_OK) {
        tags[ef_tp_slot(ef.next_seq - 1u)] = tag;
        tp->done = 0;
        sync_tp(tp);
        return 0;
    }
    if (rc == EF_ERR_DEGENERATE && strstr(ef_tp_msg(&ef), "zero-length"))
        return TP_ERR_ZERO_LENGTH;
    rtapi_print_msg(RTAPI_MSG_ERR, "%s (%s)\n", ef_tp_msg(&ef), ef_err_str(rc));
    return -1;
}

static int refuse_sync(void)
{
    rtapi_print_msg(RTAPI_MSG_ERR,
                    "evenfeed: spindle-synchronized motion (G33, G33.1, G76, G95) is not "
                    "supported by the evenfeed planner\n");
    return -1;
}

int tpAddLine(TP_STRUCT *const tp, EmcPose end, int canon_motion_type, double vel,
              double ini_maxvel, double acc, unsigned char enables, char atspeed, int indexrotary,
              struct state_tag_t tag)
{
    if (!tp)
        return -1;
    if (tr) {
        tr_flush();
        tr_pose("line", &end);
        fprintf(tr, " %d %.17g %.17g %d %d %d %.17g\n", canon_motion_type, vel, ini_maxvel,
                (int)enables, (int)atspeed, indexrotary, acc);
    }
    if (spindle_sync)
        return refuse_sync();
    double e[EF_TP_AXES];
    pose_to(&end, e);
    int type = indexrotary >= 0 ? EF_TP_MOTION_INDEXROTARY : canon_motion_type;
    int rc = ef_tp_add_line(&ef, e, type, vel, ini_maxvel, acc, enables, atspeed);
    return add_result(tp, rc, tag);
}

int tpAddCircle(TP_STRUCT *const tp, EmcPose end, PmCartesian center, PmCartesian normal, int turn,
                int canon_motion_type, double vel, double ini_maxvel, double acc,
                unsigned char enables, char atspeed, struct state_tag_t tag)
{
    (void)acc;
    if (!tp)
        return -1;
    if (tr) {
        tr_flush();
        tr_pose("circle", &end);
        fprintf(tr, " %d %.17g %.17g %d %d %d %.17g %.17g %.17g %.17g %.17g %.17g\n",
                canon_motion_type, vel, ini_maxvel, (int)enables, (int)atspeed, turn, center.x,
                center.y, center.z, normal.x, normal.y, normal.z);
    }
    if (spindle_sync)
        return refuse_sync();
    double e[EF_TP_AXES], c[3] = {center.x, center.y, center.z},
                          n[3] = {normal.x, normal.y, normal.z};
    pose_to(&end, e);
    int rc =
        ef_tp_add_arc(&ef, e, c, n, turn, canon_motion_type, vel, ini_maxvel, enables, atspeed);
    return add_result(tp, rc, tag);
}

int tpAddRigidTap(TP_STRUCT *const tp, EmcPose end, double vel, double ini_maxvel, double acc,
                  unsigned char enables, double scale, struct state_tag_t tag)
{
    (void)tp;
    (void)end;
    (void)vel;
    (void)ini_maxvel;
    (void)acc;
    (void)enables;
    (void)scale;
    (void)tag;
    if (tr) {
        tr_flush();
        fprintf(tr, "rigidtap\n");
    }
    rtapi_print_msg(RTAPI_MSG_ERR,
                    "evenfeed: rigid tapping (G33.1) is not supported by the evenfeed planner\n");
    return -1;
}

int tpRunCycle(TP_STRUCT *tp, long period)
{
    (void)period; /* one traj period per call, as LinuxCNC's own planner */
    if (!tp || !mstat)
        return -1;
    refresh_cfg(0);
    int at_speed = 1;
    if (mcfg)
        for (int s = 0; s < mcfg->numSpindles && s < EMCMOT_MAX_SPINDLES; s++)
            at_speed = at_speed && mstat->spindle_status[s].at_speed;
    ef_tp_set_at_speed(&ef, at_speed);
    double scale = mstat->net_feed_scale;
    if (tr) {
        if (tr_cycles > 0 && scale != tr_scale)
            tr_flush();
        tr_scale = scale;
        tr_cycles++;
    }
    ef_tp_status_t st;
    int rc = ef_tp_cycle(&ef, scale, &st);
    if (rc != EF_OK && rc != EF_ERR_UNDERRUN) {
        rtapi_print_msg(RTAPI_MSG_ERR, "%s\n", ef_tp_msg(&ef));
    }
    pose_from(st.pos, &tp->currentPos);
    pose_from(ef.goal, &tp->goalPos);
    tp->done = st.done;
    tp->depth = (int)ef_tp_depth(&ef);
    tp->activeDepth = st.moving ? 1 : 0;
    tp->execId = st.exec_id;
    tp->motionType = st.motion_type;
    tp->execTag = st.exec_seq ? tags[ef_tp_slot(st.exec_seq)] : idle_tag;
    tp->reverse_run = 0;
    tp->aborting = ef.state == EF_TP_STOPPING;
    tp->pausing = ef.paused;
    mstat->tcqlen = (unsigned)tp->depth;
    mstat->current_vel = st.v;
    mstat->requested_vel = st.moving ? st.v_req : 0.0;
    mstat->distance_to_go = st.dtg;
    memset(&mstat->dtg, 0, sizeof mstat->dtg);
    mstat->enables_queued = st.done ? mstat->enables_new : (unsigned char)st.enables;
    mstat->spindleSync = 0;
    return 0;
}

int tpPause(TP_STRUCT *tp)
{
    (void)tp;
    if (tr) {
        tr_flush();
        fprintf(tr, "pause\n");
    }
    ef_tp_pause(&ef);
    return 0;
}

int tpResume(TP_STRUCT *tp)
{
    (void)tp;
    if (tr) {
        tr_flush();
        fprintf(tr, "resume\n");
    }
    ef_tp_resume(&ef);
    return 0;
}

int tpAbort(TP_STRUCT *tp)
{
    (void)tp;
    if (tr) {
        tr_flush();
        fprintf(tr, "abort\n");
    }
    ef_tp_abort(&ef);
    spindle_sync = 0;
    return 0;
}

int tpGetPos(TP_STRUCT const *const tp, EmcPose *const pos)
{
    if (!tp || !pos) {
        if (pos)
            memset(pos, 0, sizeof *pos);
        return -1;
    }
    *pos = tp->currentPos;
    return 0;
}

int tpIsDone(TP_STRUCT *const tp)
{
    return tp ? tp->done : 0;
}

int tpQueueDepth(TP_STRUCT *const tp)
{
    return tp ? tp->depth : 0;
}

int tpActiveDepth(TP_STRUCT *const tp)
{
    return tp ? tp->activeDepth : 0;
}

int tpGetMotionType(TP_STRUCT *const tp)
{
    return tp ? tp->motionType : 0;
}

int tpSetSpindleSync(TP_STRUCT *const tp, int spindle, double sync, int wait)
{
    (void)tp;
    (void)spindle;
    (void)wait;
    if (tr) {
        tr_flush();
        fprintf(tr, "spindlesync %.17g\n", sync);
    }
    spindle_sync = sync != 0.0; /* the next add is refused with a message */
    return 0;
}

int tpSetAout(TP_STRUCT *const tp, unsigned char index, double start, double end)
{
    (void)tp;
    (void)end;
    if (tr) {
        tr_flush();
        fprintf(tr, "aout %d %.17g\n", (int)index, start);
    }
    return ef_tp_set_aout(&ef, index, start) == EF_OK ? 0 : -1;
}

int tpSetDout(TP_STRUCT *const tp, int index, unsigned char start, unsigned char end)
{
    (void)tp;
    (void)end;
    if (tr) {
        tr_flush();
        fprintf(tr, "dout %d %d\n", index, (int)start);
    }
    return ef_tp_set_dout(&ef, index, start) == EF_OK ? 0 : -1;
}

int tpSetRunDir(TP_STRUCT *const tp, tc_direction_t dir)
{
    (void)tp;
    return dir == TC_DIR_FORWARD ? 0 : -1; /* no reverse run: motmod forces adaptive feed 0 */
}

int tpIsMoving(TP_STRUCT const *const tp)
{
    (void)tp;
    return !ef_tp_depth(&ef) ? 0 : 1;
}

int tpInit(TP_STRUCT *const tp)
{
    return tpClear(tp);
}

void tpToggleDIOs(TC_STRUCT *const tc)
{
    (void)tc;
}

/* LinuxCNC's queue full test, on the planner's own queue (motmod passes &tp->queue). */
int tcqFull(TC_QUEUE_STRUCT const *const tcq)
{
    (void)tcq;
    return ef_tp_full(&ef);
}

EXPORT_SYMBOL(tpMotFunctions);
EXPORT_SYMBOL(tpMotData);
EXPORT_SYMBOL(tpCreate);
EXPORT_SYMBOL(tpClear);
EXPORT_SYMBOL(tpSetCycleTime);
EXPORT_SYMBOL(tpSetVmax);
EXPORT_SYMBOL(tpSetVlimit);
EXPORT_SYMBOL(tpSetAmax);
EXPORT_SYMBOL(tpSetId);
EXPORT_SYMBOL(tpGetExecId);
EXPORT_SYMBOL(tpGetExecTag);
EXPORT_SYMBOL(tpSetTermCond);
EXPORT_SYMBOL(tpSetPos);
EXPORT_SYMBOL(tpRunCycle);
EXPORT_SYMBOL(tpPause);
EXPORT_SYMBOL(tpResume);
EXPORT_SYMBOL(tpAbort);
EXPORT_SYMBOL(tpAddRigidTap);
EXPORT_SYMBOL(tpAddLine);
EXPORT_SYMBOL(tpAddCircle);
EXPORT_SYMBOL(tpGetPos);
EXPORT_SYMBOL(tpIsDone);
EXPORT_SYMBOL(tpQueueDepth);
EXPORT_SYMBOL(tpActiveDepth);
EXPORT_SYMBOL(tpGetMotionType);
EXPORT_SYMBOL(tpSetSpindleSync);
EXPORT_SYMBOL(tpSetAout);
EXPORT_SYMBOL(tpSetDout);
EXPORT_SYMBOL(tpSetRunDir);
EXPORT_SYMBOL(tcqFull);
