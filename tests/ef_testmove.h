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

/* Where a chain of moves (started at time 0) is at time T, in double. */
static inline void tm_chain_pos(const ef_move_t *mv, int n, double T, double out[3])
{
    double t0 = 0;
    out[0] = out[1] = out[2] = 0;
    for (int i = 0; i < n; i++) {
        if (T < t0 + mv[i].duration || i == n - 1) {
            tm_bz(mv[i].b, mv[i].degree, tm_law_tau(&mv[i], T - t0), out);
            return;
        }
        t0 += mv[i].duration;
    }
}

#endif /* EF_TESTMOVE_H */
