/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Deterministic CAM-like part program for the smoother throughput benchmark
 * (tests/bench/bench_smooth.c, docs/benchmarks-smoothing.md).
 *
 * Usage: gen_cam [-n LINES] [-s SEED] [-o FILE]     (defaults 100000, 1, stdout)
 *
 * Exactly LINES lines (at least 100) of the RS274NGC subset evenfeed's reader accepts
 * (docs/gcode.md), the same bytes for the same LINES and SEED on every platform (the
 * random numbers are integer splitmix64; the geometry is double and printed with 4
 * decimals): a header (G21 G90 G17 G64 P Q, tool, spindle), then pockets: a turtle walks
 * inside each pocket's disc producing
 *   - curved runs of G1 micro-segments (chords 0.05-1 mm, slowly varying curvature),
 *   - straight runs split into collinear pieces,
 *   - sharp corners (20-150 degrees),
 *   - G2/G3 arcs tangent to the path (IJK, sometimes R), radius 0.5-20 mm,
 * with Z steps down every few hundred lines, occasional retract / rapid / plunge, feed
 * changes, tool changes with new G64 tolerances, and the end (M30, %).
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static unsigned long long rs;
static FILE *out;
static long nlines, maxlines;

static unsigned long long rng(void)
{
    unsigned long long z = (rs += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static double uni(double lo, double hi)
{
    return lo + (hi - lo) * (double)(rng() >> 11) * (1.0 / 9007199254740992.0);
}

static int pick(int n)
{
    return (int)(rng() % (unsigned long long)n);
}

/* One output line (counted). */
#if defined(__GNUC__)
static void emit(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
#endif
static void emit(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vfprintf(out, fmt, ap);
    va_end(ap);
    fputc('\n', out);
    nlines++;
}

/* Position as printed (4 decimals), so the turtle continues from what the reader sees. */
static double q4(double v)
{
    return floor(v * 1e4 + 0.5) / 1e4;
}

/* Turtle state. */
static double px, py, pz, hd; /* position, heading (rad) */
static double cx, cy, crad;   /* pocket centre and radius */
static int feed, feed_pending;

/* Print a G1 to (x, y) with the feed if it changed. */
static void line_to(double x, double y)
{
    x = q4(x);
    y = q4(y);
    if (fabs(x - px) < 1e-4 && fabs(y - py) < 1e-4)
        return;
    if (feed_pending) {
        emit("G1 X%.4f Y%.4f F%d", x, y, feed);
        feed_pending = 0;
    } else {
        emit("X%.4f Y%.4f", x, y);
    }
    px = x;
    py = y;
}

/* Turn sign that steers back towards the pocket centre (+1 left). */
static double steer(void)
{
    double tx = cos(hd), ty = sin(hd), dx = cx - px, dy = cy - py;
    return tx * dy - ty * dx >= 0 ? 1 : -1;
}

static int far_out(void)
{
    return hypot(px - cx, py - cy) > crad;
}

static int room(void)
{
    return nlines < maxlines - 12;
}

/* Curved run of micro-segments with curvature going linearly from k0 to k1. */
static void curve_run(void)
{
    int k = 10 + pick(111);
    double c0 = exp(uni(log(0.05), log(1.0)));
    double kmax = fmin(0.5, 0.3 / c0); /* turn per chord at most 0.3 rad */
    double k0 = uni(-kmax, kmax), k1 = uni(-kmax, kmax);
    if (far_out()) {
        k0 = steer() * fabs(k0);
        k1 = steer() * fabs(k1);
    }
    for (int i = 0; i < k && room(); i++) {
        double c = c0 * uni(0.9, 1.1), kap = k0 + (k1 - k0) * i / k;
        hd += c * kap;
        line_to(px + c * cos(hd), py + c * sin(hd));
    }
}

/* Straight run split into collinear pieces. */
static void straight_run(void)
{
    double len = uni(3, 30);
    if (far_out())
        hd += steer() * uni(0.5, 1.5);
    int parts = 1 + pick(6);
    double x0 = px, y0 = py, tx = cos(hd), ty = sin(hd);
    for (int i = 1; i <= parts && room(); i++)
        line_to(x0 + tx * len * i / parts, y0 + ty * len * i / parts);
}

/* Sharp corner, then a straight piece. */
static void corner(void)
{
    double t = uni(20, 150) * M_PI / 180;
    hd += (far_out() || pick(3) ? steer() : -steer()) * t;
    double len = uni(0.5, 10);
    line_to(px + len * cos(hd), py + len * sin(hd));
}

/* Arc tangent to the heading, IJK (or R for sweeps below 180 degrees). */
static void arc(void)
{
    double r = exp(uni(log(0.5), log(20))), sw = uni(10, 270) * M_PI / 180;
    double dir = far_out() ? steer() : (pick(2) ? 1 : -1);
    /* Centre to the left (G3, dir +1) or right (G2) of the heading. */
    double ccx = px - dir * r * sin(hd), ccy = py + dir * r * cos(hd);
    double a0 = atan2(py - ccy, px - ccx), a1 = a0 + dir * sw;
    double ex = q4(ccx + r * cos(a1)), ey = q4(ccy + r * sin(a1));
    const char *g = dir > 0 ? "G3" : "G2";
    char fbuf[32] = "";
    if (feed_pending) {
        snprintf(fbuf, sizeof fbuf, " F%d", feed);
        feed_pending = 0;
    }
    if (sw < M_PI * 0.95 && pick(4) == 0)
        emit("%s X%.4f Y%.4f R%.4f%s", g, ex, ey, r, fbuf);
    else
        emit("%s X%.4f Y%.4f I%.4f J%.4f%s", g, ex, ey, q4(ccx - px), q4(ccy - py), fbuf);
    px = ex;
    py = ey;
    hd = atan2(ey - ccy, ex - ccx) + dir * M_PI / 2;
    feed_pending = 1; /* the next G1 needs its G word back after an arc */
}

/* Retract, rapid to a new point of the pocket, plunge. */
static void reposition(double depth)
{
    double a = uni(0, 2 * M_PI), d = uni(0, crad * 0.7);
    emit("G0 Z2.0000");
    px = q4(cx + d * cos(a));
    py = q4(cy + d * sin(a));
    emit("X%.4f Y%.4f", px, py);
    emit("G1 Z%.4f F%d", depth, 200 + 50 * pick(5));
    pz = depth;
    feed_pending = 1;
}

static void tool_change(int tool)
{
    emit("G0 Z25.0000");
    emit("M5");
    emit("T%d M6", tool);
    emit("S%d M3", 8000 + 1000 * pick(10));
    emit("G64 P%.3f Q%.3f", 0.005 * (1 + pick(10)), 0.001 * (1 + pick(5)));
    emit("M8");
}

int main(int argc, char **argv)
{
    maxlines = 100000;
    rs = 1;
    const char *path = NULL;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "-n") == 0 && i + 1 < argc)
            maxlines = strtol(argv[++i], NULL, 10);
        else if (strcmp(argv[i], "-s") == 0 && i + 1 < argc)
            rs = strtoull(argv[++i], NULL, 0);
        else if (strcmp(argv[i], "-o") == 0 && i + 1 < argc)
            path = argv[++i];
        else {
            fprintf(stderr, "usage: %s [-n LINES] [-s SEED] [-o FILE]\n", argv[0]);
            return 2;
        }
    }
    if (maxlines < 100) {
        fprintf(stderr, "gen_cam: at least 100 lines\n");
        return 2;
    }
    unsigned long long seed = rs;
    out = path ? fopen(path, "w") : stdout;
    if (!out) {
        perror(path);
        return 1;
    }
    emit("%%");
    emit("(gen_cam: CAM-like benchmark program, %ld lines, seed %llu)", maxlines, seed);
    emit("G21 G90 G17 G94 G40 G49 G80");
    emit("G64 P0.010 Q0.005");
    emit("T1 M6");
    emit("S12000 M3");
    emit("G54");
    emit("M8");
    int tool = 1;
    long next_tool = 20000;
    while (nlines < maxlines - 40) {
        /* A pocket: centre and radius in a 400 x 300 field, a few layers. */
        cx = uni(40, 360);
        cy = uni(40, 260);
        crad = uni(10, 40);
        double depth = 0;
        int layers = 1 + pick(4);
        emit("G0 Z5.0000");
        px = q4(cx);
        py = q4(cy);
        emit("X%.4f Y%.4f", px, py);
        hd = uni(0, 2 * M_PI);
        for (int l = 0; l < layers && room(); l++) {
            depth = q4(depth - uni(0.5, 2.0));
            emit("G1 Z%.4f F%d", depth, 150 + 50 * pick(4));
            pz = depth;
            feed = 600 + 100 * pick(20);
            feed_pending = 1;
            long layer_end = nlines + 300 + pick(900);
            while (nlines < layer_end && room()) {
                int f = pick(100);
                if (f < 45)
                    curve_run();
                else if (f < 60)
                    straight_run();
                else if (f < 75)
                    corner();
                else if (f < 95)
                    arc();
                else if (f < 98) {
                    feed = 600 + 100 * pick(20);
                    feed_pending = 1;
                } else
                    reposition(depth);
            }
        }
        if (nlines >= next_tool && nlines < maxlines - 40) {
            tool = tool % 8 + 1;
            tool_change(tool);
            next_tool += 20000;
        }
    }
    emit("G0 Z25.0000");
    emit("M5");
    emit("M9");
    while (nlines < maxlines - 2)
        emit("(padding)");
    emit("M30");
    emit("%%");
    if (path && fclose(out) != 0) {
        perror(path);
        return 1;
    }
    return 0;
}
