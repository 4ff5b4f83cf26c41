/* SPDX-License-Identifier: Apache-2.0 */
/* Drive: segment ring, interpolator and servo model (see ef_drive.h). */
#include <stddef.h>
#include "evenfeed/drive/ef_drive.h"
#include "evenfeed/core/ef_err.h"

/** Largest wn * period (s) accepted: the semi-implicit Euler loop is well damped below it. */
#define EF_DRIVE_WN_DT_MAX 0.5f

/** Share of the servo's a_lim the direct-mode profile uses: the servo model saturates at
 *  a_lim itself, so a profile using all of it leaves no room to correct the lag and the
 *  axis overshoots the target (by about 1.7 units at the defaults); half leaves room. */
#define EF_DRIVE_DIRECT_ACC 0.5f

/** Microseconds per millisecond, for the time_ms / time_us split. */
#define EF_DRIVE_US_PER_MS 1000u

/* The stop destination lives in ef_drive_t::pad (private, see ef_drive.h). */

/* A point finite and within EF_MAX_COORD on every axis, as the interpolator requires. */
static int drv_vok(ef_vec3_t v)
{
    return ef_finitef(v.x) & ef_finitef(v.y) & ef_finitef(v.z) & (ef_fabsf(v.x) <= EF_MAX_COORD) &
           (ef_fabsf(v.y) <= EF_MAX_COORD) & (ef_fabsf(v.z) <= EF_MAX_COORD);
}

/* A servo parameter must be positive and finite to give a stable, meaningful model. */
static int drv_pos(float x)
{
    return ef_finitef(x) && x > 0.0f;
}

/* Servo period in seconds, the step of every model in here. */
static float drv_dt(const ef_drive_t *d)
{
    return (float)d->period_us * 1e-6f;
}

/* Clamp to [-lim, lim], for the servo's velocity and acceleration limits. */
static float drv_clamp(float x, float lim)
{
    return ef_maxf(-lim, ef_minf(lim, x));
}

/* Defaults documented in ef_drive.h, so callers need set only what differs. */
void ef_servo_cfg_default(ef_servo_cfg_t *c)
{
    if (!c)
        return;
    c->wn = 2.0f * EF_PI_F * 40.0f;
    c->zeta = 1.0f;
    c->v_lim = 500.0f;
    c->a_lim = 20000.0f;
    c->ferr_lim = 1.0f;
    c->a_stop = 2000.0f;
}

/* Empty the ring and restart the interpolator at the command, so the next segment must
 * start where the drive actually is. */
static void drv_flush(ef_drive_t *d)
{
    d->ring_head = 0u;
    d->ring_count = 0u;
    d->moving = 0u;
    /* cmd is always finite and within range (it only moves along checked segments or
     * towards checked targets), so this cannot fail. */
    (void)ef_interp_init(&d->ip, d->cmd, d->period_us, EF_STEP_UNIFORM);
    /* Nothing moves after a flush, so the rate the hold asks for applies at once. */
    d->rate = d->rate0 = d->rate1 = d->hold ? 0.0f : 1.0f;
    d->ramp_u = 1.0f;
    d->v_law = 0.0f;
    d->held = d->hold;
}

/* Reset the queue and the counters a clear (or fault reset) starts from. */
static void drv_clear_all(ef_drive_t *d)
{
    drv_flush(d);
    d->next_seq = 0u;
    d->done_seq = 0u;
    d->done_any = 0u;
    d->exec_seq = 0u;
    d->ferr_max = 0.0f;
    d->time_ms = 0u;
    d->time_us = 0u;
    d->late_us = 0u;
}

/* Whether the command is moving now (a stop must then ramp down instead of halting). */
static int drv_cmd_moving(const ef_drive_t *d)
{
    return ef_v3_dot(d->cmd_vel, d->cmd_vel) > 0.0f;
}

/* Begin a controlled stop ending in state `to`; at rest it ends at once. */
static void drv_stop(ef_drive_t *d, uint8_t to)
{
    drv_flush(d);
    d->target = d->cmd;
    if (drv_cmd_moving(d)) {
        d->state = EF_DRV_STOPPING;
        d->pad = to;
    } else {
        d->cmd_vel = ef_v3(0.0f, 0.0f, 0.0f);
        d->state = to;
    }
}

/* Record a fault (the first one sticks) and steer the drive to FAULT through a stop. */
static void drv_raise(ef_drive_t *d, uint8_t code)
{
    if (d->fault == EF_DRV_FAULT_NONE)
        d->fault = code;
    if (d->state == EF_DRV_FAULT)
        return;
    if (d->state == EF_DRV_STOPPING) {
        d->pad = EF_DRV_FAULT;
        return;
    }
    drv_stop(d, EF_DRV_FAULT);
}

/* Set up a static drive (contract in ef_drive.h). */
int ef_drive_init(ef_drive_t *d, const ef_servo_cfg_t *cfg, ef_vec3_t home, uint32_t period_us)
{
    if (!d || !cfg || period_us == 0u)
        return EF_ERR_ARG;
    if (!drv_pos(cfg->wn) || !drv_pos(cfg->zeta) || !drv_pos(cfg->v_lim) || !drv_pos(cfg->a_lim) ||
        !drv_pos(cfg->ferr_lim) || !drv_pos(cfg->a_stop))
        return EF_ERR_ARG;
    if (!(cfg->wn * ((float)period_us * 1e-6f) <= EF_DRIVE_WN_DT_MAX))
        return EF_ERR_ARG;
    if (!drv_vok(home))
        return EF_ERR_NONFINITE;
    *d = (ef_drive_t){0};
    d->cfg = *cfg;
    d->period_us = period_us;
    d->state = EF_DRV_DISABLED;
    d->fault = EF_DRV_FAULT_NONE;
    d->cmd = d->act = d->target = home;
    drv_clear_all(d);
    d->acc_us = 0u;
    return EF_OK;
}

/* Power stage on/off; off while moving goes through a controlled stop (ef_drive.h). */
int ef_drive_enable(ef_drive_t *d, int on)
{
    if (!d)
        return EF_ERR_ARG;
    if (on) {
        switch (d->state) {
        case EF_DRV_DISABLED:
            d->cmd = d->act;
            d->cmd_vel = ef_v3(0.0f, 0.0f, 0.0f);
            d->target = d->cmd;
            drv_flush(d);
            d->state = EF_DRV_ENABLED;
            return EF_OK;
        case EF_DRV_FAULT:
            return EF_ERR_STATE;
        case EF_DRV_STOPPING:
            if (d->pad == EF_DRV_FAULT)
                return EF_ERR_STATE;
            d->pad = EF_DRV_ENABLED; /* a pending disable is cancelled */
            return EF_OK;
        default:
            return EF_OK;
        }
    }
    switch (d->state) {
    case EF_DRV_ENABLED:
    case EF_DRV_RUNNING:
        drv_stop(d, EF_DRV_DISABLED);
        break;
    case EF_DRV_STOPPING:
        if (d->pad == EF_DRV_ENABLED)
            d->pad = EF_DRV_DISABLED;
        break;
    default:
        break;
    }
    return EF_OK;
}

/* ENABLED -> RUNNING: the queue starts executing (ef_drive.h). */
int ef_drive_start(ef_drive_t *d)
{
    if (!d)
        return EF_ERR_ARG;
    if (d->direct || (d->state != EF_DRV_ENABLED && d->state != EF_DRV_RUNNING))
        return EF_ERR_STATE;
    d->state = EF_DRV_RUNNING;
    return EF_OK;
}

/* Abandon the queue with a controlled stop, keeping next_seq (ef_drive.h). */
int ef_drive_quick_stop(ef_drive_t *d)
{
    if (!d)
        return EF_ERR_ARG;
    if (d->state == EF_DRV_RUNNING)
        drv_stop(d, EF_DRV_ENABLED);
    return EF_OK;
}

/* External fault input (ef_drive.h). */
int ef_drive_fault(ef_drive_t *d, int code)
{
    if (!d || code <= EF_DRV_FAULT_NONE || code > EF_DRV_FAULT_LAST)
        return EF_ERR_ARG;
    drv_raise(d, (uint8_t)code);
    return EF_OK;
}

/* FAULT -> DISABLED with a fresh queue and sequence (ef_drive.h). */
int ef_drive_fault_reset(ef_drive_t *d)
{
    if (!d)
        return EF_ERR_ARG;
    if (d->state != EF_DRV_FAULT)
        return EF_ERR_STATE;
    drv_clear_all(d);
    d->fault = EF_DRV_FAULT_NONE;
    d->cmd_vel = ef_v3(0.0f, 0.0f, 0.0f);
    d->state = EF_DRV_DISABLED;
    return EF_OK;
}

/* Start a new job: empty queue, counters and sequence from 0 (ef_drive.h). */
int ef_drive_clear(ef_drive_t *d)
{
    if (!d)
        return EF_ERR_ARG;
    if (d->state == EF_DRV_STOPPING || (d->state == EF_DRV_RUNNING && d->moving))
        return EF_ERR_STATE;
    drv_clear_all(d);
    return EF_OK;
}

/* Switch between streamed segments and direct targets (ef_drive.h). */
int ef_drive_set_direct(ef_drive_t *d, int on)
{
    if (!d)
        return EF_ERR_ARG;
    if (d->state == EF_DRV_RUNNING || d->state == EF_DRV_STOPPING)
        return EF_ERR_STATE;
    uint8_t want = on ? 1u : 0u;
    if (want != d->direct) {
        if (want)
            d->hold = 0u; /* a hold is a segment-mode request */
        drv_flush(d);
        d->target = d->cmd;
        d->direct = want;
    }
    return EF_OK;
}

/* Direct mode: where the profile generator heads next (ef_drive.h). */
int ef_drive_set_target(ef_drive_t *d, ef_vec3_t p)
{
    if (!d)
        return EF_ERR_ARG;
    if (!drv_vok(p))
        return EF_ERR_NONFINITE;
    if (!d->direct || (d->state != EF_DRV_ENABLED && d->state != EF_DRV_RUNNING))
        return EF_ERR_STATE;
    d->target = p;
    return EF_OK;
}

/* Where the next queued segment must start: the last queued end, else the command. */
static ef_vec3_t drv_queue_end(const ef_drive_t *d)
{
    if (d->ring_count > 0u) {
        const ef_move_t *l = &d->ring[(d->ring_head + d->ring_count - 1u) % EF_DRIVE_SLOTS];
        return l->b[l->degree];
    }
    if (d->ip.count > 0u)
        return d->ip.end;
    return d->cmd;
}

/* Queue a received segment after the sequence and data checks (ef_drive.h). */
int ef_drive_push(ef_drive_t *d, const ef_move_t *m)
{
    if (!d || !m)
        return EF_ERR_ARG;
    if (d->direct || d->state == EF_DRV_DISABLED || d->state == EF_DRV_STOPPING ||
        d->state == EF_DRV_FAULT)
        return EF_ERR_STATE;
    if (m->seq < d->next_seq)
        return EF_ERR_DUP;
    if (m->seq > d->next_seq)
        return EF_ERR_SEQ;
    ef_move_t c = *m; /* checked as stored: the caller's copy may change */
    if (ef_interp_check(&c, drv_queue_end(d)) != EF_OK)
        return EF_ERR_ARG;
    if (d->ring_count >= EF_DRIVE_SLOTS)
        return EF_ERR_FULL;
    d->ring[(d->ring_head + d->ring_count) % EF_DRIVE_SLOTS] = c;
    d->ring_count++;
    d->next_seq++;
    return EF_OK;
}

/* Free ring places, what a transport reports as room (ef_drive.h). */
uint32_t ef_drive_free(const ef_drive_t *d)
{
    return d ? (uint32_t)EF_DRIVE_SLOTS - d->ring_count : 0u;
}

/* Keep the interpolator's queue topped up from the ring; a refused move is a fault. */
static void drv_feed(ef_drive_t *d)
{
    for (uint32_t i = 0; i < EF_DRIVE_SLOTS && d->ring_count > 0u && ef_interp_space(&d->ip) > 0u;
         i++) {
        if (ef_interp_push(&d->ip, &d->ring[d->ring_head]) != EF_OK) {
            drv_raise(d, EF_DRV_FAULT_SEGMENT);
            return;
        }
        d->ring_head = (d->ring_head + 1u) % EF_DRIVE_SLOTS;
        d->ring_count--;
    }
}

/* Feed hold or resume (ef_drive.h): a smoothstep ramp of the rate, long enough that the
 * deceleration it adds (1.5 v / T at its steepest) stays within a_stop / 2. */
int ef_drive_hold(ef_drive_t *d, int on)
{
    if (!d)
        return EF_ERR_ARG;
    uint8_t want = on != 0;
    if (want && d->direct)
        return EF_ERR_STATE;
    if (want == d->hold)
        return EF_OK;
    d->hold = want;
    d->rate0 = d->rate;
    d->rate1 = want ? 0.0f : 1.0f;
    if (!d->moving || d->direct) {
        d->rate = d->rate0 = d->rate1; /* nothing moves: nothing to ramp */
        d->ramp_u = 1.0f;
        d->held = want;
        return EF_OK;
    }
    float t = ef_maxf((float)EF_DRIVE_HOLD_RAMP_MIN_US * 1e-6f, 3.0f * d->v_law / d->cfg.a_stop);
    d->ramp_u = 0.0f;
    d->ramp_k = drv_dt(d) / t; /* t >= the minimum, a_stop > 0: finite */
    d->held = 0u;
    return EF_OK;
}

/* One period of the rate's ramp. */
static void drv_rate_step(ef_drive_t *d)
{
    if (d->ramp_u < 1.0f) {
        float u = ef_minf(1.0f, d->ramp_u + d->ramp_k);
        d->ramp_u = u;
        d->rate =
            u >= 1.0f ? d->rate1 : d->rate0 + (d->rate1 - d->rate0) * (u * u * (3.0f - 2.0f * u));
    }
    d->held = d->hold && d->rate == 0.0f;
}

/* One period of the stop ramp: same direction, speed down by a_stop * dt; at rest the
 * drive enters the stop's destination state. */
static void drv_stop_step(ef_drive_t *d, float dt)
{
    float speed = ef_v3_norm(d->cmd_vel);
    float ns = ef_maxf(0.0f, speed - d->cfg.a_stop * dt);
    if (speed > 0.0f && ns > 0.0f) {
        ef_vec3_t dir = ef_v3_scale(d->cmd_vel, 1.0f / speed);
        d->cmd_vel = ef_v3_scale(dir, ns);
        d->cmd = ef_v3_axpy(d->cmd, ns * dt, dir);
        return;
    }
    d->cmd_vel = ef_v3(0.0f, 0.0f, 0.0f);
    d->state = d->pad;
    drv_flush(d);
    d->target = d->cmd;
}

/* One axis of the direct profile: speed towards the target limited by v_lim, by what
 * still stops on the target in whole periods, and by what lands on it this period;
 * acceleration limited to EF_DRIVE_DIRECT_ACC * a_lim. */
static float drv_direct_axis(float *x, float v, float goal, const ef_servo_cfg_t *c, float dt)
{
    float err = goal - *x;
    float ae = ef_fabsf(err);
    float adt = EF_DRIVE_DIRECT_ACC * c->a_lim * dt;
    if (ae <= 0.5f * adt * dt && ef_fabsf(v) <= adt) {
        *x = goal; /* close enough to land exactly and rest */
        return 0.0f;
    }
    /* Stopping from n * a dt at a dt per period covers a dt^2 n (n + 1) / 2: the largest
     * real n within the error gives the speed that arrives without overshoot. */
    float n = 0.5f * (ef_sqrtf(1.0f + 8.0f * ae / (adt * dt)) - 1.0f);
    float vmag = ef_minf(ef_minf(c->v_lim, n * adt), ae / dt);
    float vdes = err > 0.0f ? vmag : -vmag;
    float nv = v + drv_clamp(vdes - v, adt);
    *x += nv * dt;
    return nv;
}

/* Direct mode: move the command one period towards the target. */
static void drv_direct_step(ef_drive_t *d, float dt)
{
    ef_vec3_t v = d->cmd_vel;
    v.x = drv_direct_axis(&d->cmd.x, v.x, d->target.x, &d->cfg, dt);
    v.y = drv_direct_axis(&d->cmd.y, v.y, d->target.y, &d->cfg, dt);
    v.z = drv_direct_axis(&d->cmd.z, v.z, d->target.z, &d->cfg, dt);
    d->cmd_vel = v;
}

/* RUNNING: the interpolator gives the command; finished segments are counted done. An
 * underrun faults and the stop ramp takes over in this same period. */
static void drv_run_step(ef_drive_t *d, float dt)
{
    drv_feed(d);
    if (d->state != EF_DRV_RUNNING) { /* the feed faulted */
        if (d->state == EF_DRV_STOPPING)
            drv_stop_step(d, dt);
        return;
    }
    ef_vec3_t prev = d->cmd;
    uint32_t before = d->ip.count;
    drv_rate_step(d);
    ef_setpoint_t sp;
    int rc = ef_interp_process_rate(&d->ip, d->period_us, d->rate, NULL, &sp);
    uint32_t popped = before - d->ip.count;
    if (popped > 0u) {
        d->done_any += popped;
        d->done_seq = d->ip.last_seq;
    }
    if (rc != EF_OK) {
        d->moving = 0u;
        drv_raise(d, EF_DRV_FAULT_UNDERRUN);
        if (d->state == EF_DRV_STOPPING)
            drv_stop_step(d, dt);
        return;
    }
    d->moving = sp.moving;
    d->v_law = sp.v_plan;
    if (sp.moving)
        d->exec_seq = sp.seq;
    d->cmd = sp.p;
    d->cmd_vel = ef_v3_scale(ef_v3_sub(d->cmd, prev), 1.0f / dt);
}

/* One axis of the servo model: PD with velocity feed-forward, limited, semi-implicit. */
static void drv_servo_axis(float *x, float *v, float cmd, float cmd_v, const ef_servo_cfg_t *c,
                           float dt)
{
    float acc = c->wn * c->wn * (cmd - *x) + 2.0f * c->zeta * c->wn * (cmd_v - *v);
    acc = drv_clamp(acc, c->a_lim);
    *v = drv_clamp(*v + acc * dt, c->v_lim);
    *x += *v * dt;
}

/* Advance the whole drive by one servo period. */
static void drv_step(ef_drive_t *d)
{
    float dt = drv_dt(d);
    uint8_t st = d->state;
    switch (st) {
    case EF_DRV_RUNNING:
        drv_run_step(d, dt);
        break;
    case EF_DRV_STOPPING:
        drv_stop_step(d, dt);
        break;
    case EF_DRV_ENABLED:
        if (d->direct)
            drv_direct_step(d, dt);
        else
            d->cmd_vel = ef_v3(0.0f, 0.0f, 0.0f);
        break;
    default: /* DISABLED, FAULT: the command is frozen */
        d->cmd_vel = ef_v3(0.0f, 0.0f, 0.0f);
        break;
    }
    drv_servo_axis(&d->act.x, &d->act_vel.x, d->cmd.x, d->cmd_vel.x, &d->cfg, dt);
    drv_servo_axis(&d->act.y, &d->act_vel.y, d->cmd.y, d->cmd_vel.y, &d->cfg, dt);
    drv_servo_axis(&d->act.z, &d->act_vel.z, d->cmd.z, d->cmd_vel.z, &d->cfg, dt);
    d->ferr = ef_v3_norm(ef_v3_sub(d->cmd, d->act));
    d->ferr_max = ef_maxf(d->ferr_max, d->ferr);
    int powered =
        d->state == EF_DRV_ENABLED || d->state == EF_DRV_RUNNING || d->state == EF_DRV_STOPPING;
    if (powered && !(d->ferr <= d->cfg.ferr_lim))
        drv_raise(d, EF_DRV_FAULT_FOLLOWING);
    if (st == EF_DRV_RUNNING || st == EF_DRV_STOPPING) {
        uint32_t us = d->time_us + d->period_us;
        d->time_ms += us / EF_DRIVE_US_PER_MS;
        d->time_us = us % EF_DRIVE_US_PER_MS;
    }
}

/* Step every elapsed period (at most EF_DRIVE_MAX_STEPS), keep the remainder (ef_drive.h). */
int ef_drive_process(ef_drive_t *d, uint32_t dt_us, uint32_t *next_us)
{
    if (!d)
        return EF_ERR_ARG;
    uint8_t fault0 = d->fault;
    uint32_t p = d->period_us;
    uint32_t steps = dt_us / p;
    uint32_t rem = dt_us % p;
    /* acc_us < p and rem < p: the sum cannot wrap unless p > 2^31, then it is split. */
    if (rem >= p - d->acc_us) {
        d->acc_us = rem - (p - d->acc_us);
        steps++;
    } else {
        d->acc_us += rem;
    }
    if (steps > EF_DRIVE_MAX_STEPS) {
        uint32_t drop = steps - EF_DRIVE_MAX_STEPS;
        uint32_t lost = drop > UINT32_MAX / p ? UINT32_MAX : drop * p;
        d->late_us = lost > UINT32_MAX - d->late_us ? UINT32_MAX : d->late_us + lost;
        steps = EF_DRIVE_MAX_STEPS;
    }
    for (uint32_t i = 0; i < steps; i++)
        drv_step(d);
    if (next_us)
        *next_us = p - d->acc_us;
    return (fault0 == EF_DRV_FAULT_NONE && d->fault != EF_DRV_FAULT_NONE) ? EF_ERR_DRIVE : EF_OK;
}
