/* SPDX-License-Identifier: Apache-2.0 */
/* Branch-free scalar functions for the firmware (no libm). */
#include <stdint.h>
#include "evenfeed/core/ef_math.h"

/* atan(a) ~ a * P(a^2) on [0,1]; least-squares fit from tools/gen_fw_constants.c,
 * max error 1.8e-7 rad in float evaluation. */
static const float ef_atan_c[8] = {
    9.999999545e-01f, -3.333228719e-01f, 1.997350213e-01f, -1.403925361e-01f,
    9.965704541e-02f, -6.018953761e-02f, 2.473677233e-02f, -4.825772456e-03f,
};

/* Octant reduction by selects rather than branches, so the count never depends on data. */
float ef_atan2f(float y, float x)
{
    float ax = ef_fabsf(x), ay = ef_fabsf(y);
    int steep = ay > ax;
    float mx = ef_maxf(ax, ay), mn = ef_minf(ax, ay);
    float a = mn / ef_selectf(mx > 0.0f, mx, 1.0f);
    float s = a * a;
    /* Horner written out: gcc -O2 keeps the 7-step loop rolled, which costs about four
     * times the instructions of the arithmetic it carries. Same operations, same order. */
    float p = ef_atan_c[7];
    p = p * s + ef_atan_c[6];
    p = p * s + ef_atan_c[5];
    p = p * s + ef_atan_c[4];
    p = p * s + ef_atan_c[3];
    p = p * s + ef_atan_c[2];
    p = p * s + ef_atan_c[1];
    p = p * s + ef_atan_c[0];
    float r = a * p;
    r = ef_selectf(steep, 0.5f * EF_PI_F - r, r);
    r = ef_selectf(x < 0.0f, EF_PI_F - r, r);
    return ef_selectf(y < 0.0f, -r, r);
}

/* Cube root (contract in ef_math.h): the exponent divided by three through the bit
 * pattern gives a start within a few per cent, and Newton's step y = (2 y + x / y^2) / 3
 * squares the error each time: four steps reach float resolution from there. */
float ef_cbrtf(float x)
{
    if (!(x > 0.0f))
        return 0.0f;
    if (!(x <= 3.4028235e38f))
        return x;
    union {
        float f;
        uint32_t u;
    } b;
    b.f = x;
    b.u = b.u / 3u + 709921077u;
    float y = b.f;
    for (int i = 0; i < 4; i++)
        y = (2.0f * y + x / (y * y)) * (1.0f / 3.0f);
    return y;
}
