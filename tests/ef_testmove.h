/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Test moves for the drive tests (test_drive.c, test_codrive.c): Bézier moves with a
 * one-phase time law built here, and an independent double-precision evaluation of where a
 * chain of them is at a given time, to compare a drive's execution against.
 */
#ifndef EF_TESTMOVE_H
#define EF_TESTMOVE_H

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "evenfeed/path/ef_path.h"

/* Bézier point in double by de Casteljau. */
static inline void tm_bz(const ef_vec3_t *b, int deg, double t, double out[3])
{
    double p[6][3];
    for (int i = 0; i <= deg; i++) {
        p[i][0] = b[i].x;
        p[i][1] = b[i].y;
        p[i][2] = b[i].z;
    }
    for (int r = 0; r < deg; r++)
        for (int i = 0; i < deg - r; i++)
            for (int c = 0; c < 3; c++)
                p[i][c] = (1 - t) * p[i][c] + t * p[i + 1][c];
    for (int c = 0; c < 3; c++)
        out[c] = p[0][c];
}

/* Arc length in double by dense chords. */
static inline double tm_arclen(const ef_vec3_t *b, int deg)
{
    double prev[3], cur[3], len = 0;
    tm_bz(b, deg, 0, prev);
    for (int i = 1; i <= 4000; i++) {
        tm_bz(b, deg, i / 4000.0, cur);
        len +=
            sqrt((cur[0] - prev[0]) * (cur[0] - prev[0]) + (cur[1] - prev[1]) * (cur[1] - prev[1]) +
                 (cur[2] - prev[2]) * (cur[2] - prev[2]));
        memcpy(prev, cur, sizeof prev);
    }
    return len;
}

/* Law kinds of the test moves: accelerate from rest, cruise, decelerate to rest. */
enum { LAW_ACCEL, LAW_CRUISE, LAW_DECEL };

/* A move through points b[0..deg] with a one-phase law at cruise speed v0 (or ramping). */
static inline ef_move_t tm_move(uint32_t seq, int deg, const ef_vec3_t *pts, int law, float v0)
{
    ef_move_t m;
    memset(&m, 0, sizeof m);
    m.degree = (uint8_t)deg;
    m.seq = seq;
    for (int i = 0; i <= deg; i++)
        m.b[i] = pts[i];
    double L = tm_arclen(pts, deg);
    m.length = (float)L;
    float D;
    if (law == LAW_CRUISE) {
        D = (float)(L / v0);
        m.law.c[0][1] = 1.0f / D;
        m.v_exit = v0;
    } else {
        D = (float)(2.0 * L / v0);
        if (law == LAW_ACCEL) {
            m.law.c[0][2] = 1.0f / (D * D); /* tau = (u/D)^2 */
            m.v_exit = v0;
        } else {
            m.law.c[0][1] = 2.0f / D; /* tau = 2u/D - (u/D)^2 */
            m.law.c[0][2] = -1.0f / (D * D);
            m.v_exit = 0.0f;
            m.flags = EF_MOVE_STOP_END;
        }
    }
    m.duration = D;
    m.law.dt[0] = D;
    m.v_entry = law == LAW_ACCEL ? 0.0f : v0;
    return m;
}

/* tau of a test move's law at time u in double. */
static inline double tm_law_tau(const ef_move_t *m, double u)
{
    if (u >= m->duration)
        return 1.0;
    const float *c = m->law.c[0];
    double t = c[0] + u * (c[1] + u * (c[2] + u * (double)c[3]));
    return t < 0 ? 0 : t > 1 ? 1 : t;
}

/* Arc-length tables of the moves tm_arc_point() has seen: parameter t_k = k / TM_ARC_N,
 * cumulative length by dense chords (double), keyed by the move's address. */
enum { TM_ARC_N = 2000, TM_ARC_MOVES = 64 };
static const ef_move_t *tm_arc_key[TM_ARC_MOVES];
static ef_vec3_t tm_arc_pts[TM_ARC_MOVES][6]; /* the curve the table is of */
static double tm_arc_cum[TM_ARC_MOVES][TM_ARC_N + 1];

/* The point at arc-length fraction f of move m (the drive steps by arc length,
 * EF_STEP_CORRECTED: its law's tau is the share of the length, not the curve parameter). */
static inline void tm_arc_point(const ef_move_t *m, double f, double out[3])
{
    int slot = -1;
    for (int i = 0; i < TM_ARC_MOVES && slot < 0; i++)
        if (tm_arc_key[i] == m &&
            !memcmp(tm_arc_pts[i], m->b, sizeof(ef_vec3_t) * (size_t)(m->degree + 1)))
            slot = i;
    if (slot < 0) {
        for (int i = 0; i < TM_ARC_MOVES && slot < 0; i++)
            if (!tm_arc_key[i] || tm_arc_key[i] == m)
                slot = i;
        if (slot < 0)
            slot = 0; /* more moves than slots: the oldest table is rebuilt */
        tm_arc_key[slot] = m;
        memcpy(tm_arc_pts[slot], m->b, sizeof(ef_vec3_t) * (size_t)(m->degree + 1));
        double prev[3], cur[3];
        tm_bz(m->b, m->degree, 0, prev);
        tm_arc_cum[slot][0] = 0;
        for (int k = 1; k <= TM_ARC_N; k++) {
            tm_bz(m->b, m->degree, (double)k / TM_ARC_N, cur);
            double dx = cur[0] - prev[0], dy = cur[1] - prev[1], dz = cur[2] - prev[2];
            tm_arc_cum[slot][k] = tm_arc_cum[slot][k - 1] + sqrt(dx * dx + dy * dy + dz * dz);
            memcpy(prev, cur, sizeof prev);
        }
    }
    const double *cum = tm_arc_cum[slot];
    double s = f * cum[TM_ARC_N];
    int lo = 0, hi = TM_ARC_N;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (cum[mid] <= s)
            lo = mid;
        else
            hi = mid;
    }
    double w = cum[hi] > cum[lo] ? (s - cum[lo]) / (cum[hi] - cum[lo]) : 0;
    tm_bz(m->b, m->degree, (lo + w) / TM_ARC_N, out);
}

/* Where a chain of moves (started at time 0) is at time T, in double, stepped by arc
 * length as the drive does. */
static inline void tm_chain_pos(const ef_move_t *mv, int n, double T, double out[3])
{
    double t0 = 0;
    out[0] = out[1] = out[2] = 0;
    for (int i = 0; i < n; i++) {
        if (T < t0 + mv[i].duration || i == n - 1) {
            tm_arc_point(&mv[i], tm_law_tau(&mv[i], T - t0), out);
            return;
        }
        t0 += mv[i].duration;
    }
}

#endif /* EF_TESTMOVE_H */
