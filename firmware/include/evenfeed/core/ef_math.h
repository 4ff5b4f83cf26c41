/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_math.h
 * @brief float32 vector helpers and branch-free scalar functions for the firmware.
 *
 * The firmware does not call libm: the scalar functions here have a fixed instruction
 * count for every finite input, which the constant-time lookup path relies on.
 * `ef_sqrtf` maps to the FPU's square-root instruction (the firmware is compiled with
 * `-fno-math-errno`, so no errno path exists).
 */
#ifndef EF_MATH_H
#define EF_MATH_H

#ifdef __cplusplus
extern "C" {
#endif

/** A point or vector in 3-D; planar data lives in z = 0. */
typedef struct {
    float x, y, z;
} ef_vec3_t;

#define EF_PI_F 3.14159265358979323846f

/** Whether x is finite (not NaN, not +-inf), without libm: x - x is NaN exactly then. The
 *  firmware is never built with -ffast-math, which would fold this to 1. */
static inline int ef_finitef(float x)
{
    return (x - x) == 0.0f;
}

static inline ef_vec3_t ef_v3(float x, float y, float z)
{
    ef_vec3_t r = {x, y, z};
    return r;
}
static inline ef_vec3_t ef_v3_add(ef_vec3_t a, ef_vec3_t b)
{
    return ef_v3(a.x + b.x, a.y + b.y, a.z + b.z);
}
static inline ef_vec3_t ef_v3_sub(ef_vec3_t a, ef_vec3_t b)
{
    return ef_v3(a.x - b.x, a.y - b.y, a.z - b.z);
}
static inline ef_vec3_t ef_v3_scale(ef_vec3_t a, float s)
{
    return ef_v3(a.x * s, a.y * s, a.z * s);
}
/** a + s*b */
static inline ef_vec3_t ef_v3_axpy(ef_vec3_t a, float s, ef_vec3_t b)
{
    return ef_v3(a.x + s * b.x, a.y + s * b.y, a.z + s * b.z);
}
static inline float ef_v3_dot(ef_vec3_t a, ef_vec3_t b)
{
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
static inline ef_vec3_t ef_v3_cross(ef_vec3_t a, ef_vec3_t b)
{
    return ef_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

/** Square root through the FPU instruction (no errno, no branch). */
static inline float ef_sqrtf(float x)
{
    return __builtin_sqrtf(x);
}
static inline float ef_fabsf(float x)
{
    return __builtin_fabsf(x);
}
/** Branch-free select: c ? a : b, for c in {0,1}. */
static inline float ef_selectf(int c, float a, float b)
{
    float m = (float)c; /* exact: 1*a + 0*b == a, unlike b + c*(a-b) */
    return m * a + (1.0f - m) * b;
}
static inline float ef_minf(float a, float b)
{
    return a < b ? a : b;
}
static inline float ef_maxf(float a, float b)
{
    return a > b ? a : b;
}
/** Largest integer value not above x, for |x| < 2^23, without libm. */
static inline float ef_floorf(float x)
{
    float t = (float)(int)x;
    return t - (float)(t > x);
}
static inline float ef_v3_norm(ef_vec3_t a)
{
    return ef_sqrtf(ef_v3_dot(a, a));
}

/**
 * @brief atan2 with a fixed instruction count; max error below 4e-7 rad over all finite
 * input. atan2(0, 0) returns 0.
 */
float ef_atan2f(float y, float x);

/**
 * @brief Cube root of x >= 0 with a fixed instruction count (exponent estimate and four
 * Newton steps; relative error below 1e-6). Returns 0 for x <= 0 or NaN, x for +inf.
 */
float ef_cbrtf(float x);

#ifdef __cplusplus
}
#endif

#endif /* EF_MATH_H */
