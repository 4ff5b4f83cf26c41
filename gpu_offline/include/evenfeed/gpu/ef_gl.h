/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_gl.h
 * @brief Headless OpenGL 4.3 compute: the table builder's GPU backend.
 *
 * A context is made through EGL with no display: the EGL device platform (NVIDIA and other
 * vendor drivers; one context per GPU) or Mesa's surfaceless platform (on a machine without
 * a GPU this is llvmpipe). The optimizer is gpu_offline/shaders/ef_opt.comp, one invocation
 * per configuration, in double precision (GL_ARB_gpu_shader_fp64, core since GL 4.0).
 *
 * Not thread-safe: a context belongs to the thread that opened it.
 */
#ifndef EF_GL_H
#define EF_GL_H

#include <stdint.h>
#include "evenfeed/host/tables/ef_build.h"
#include "evenfeed/host/tables/ef_ref.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ef_gl ef_gl_t;

/** Context options; zero-initialized means the defaults. */
typedef struct {
    const char *platform; /**< "auto" (NULL), "device" or "surfaceless"; the environment
                               variable EF_GL_PLATFORM overrides it */
    int device;           /**< EGL device index for "device" (default 0; EF_GL_DEVICE) */
    uint32_t local_size;  /**< invocations per workgroup (default 32) */
    double timeout_s;     /**< longest wait for one dispatch before the GPU counts as lost
                               (default 300 s) */
} ef_gl_opts_t;

/** Results per configuration, in doubles (the shader's output layout). */
#define EF_GL_RES_STRIDE 8

/**
 * @brief Open a headless GL >= 4.3 core context and make it current on this thread.
 * @param o  options, or NULL for the defaults
 * @retval EF_OK
 * @retval EF_ERR_ARG  out NULL, or an unknown platform name
 * @retval EF_ERR_IO   no EGL display, no GL 4.3 core context, or no fp64 support; the
 *                     message says which step failed and what the driver reported
 * @retval EF_ERR_NOMEM
 */
int ef_gl_open(ef_gl_t **out, const ef_gl_opts_t *o, ef_msg_t *m);

/** GL_RENDERER of the context (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"). */
const char *ef_gl_renderer(const ef_gl_t *gl);
/** The EGL platform used: "device" or "surfaceless". */
const char *ef_gl_platform(const ef_gl_t *gl);

/** Configurations solved on the CPU because the driver cut the shader's loops short
 *  (llvmpipe ends an invocation's loops after 65535 iterations; see ef_opt.comp). */
uint64_t ef_gl_fallbacks(const ef_gl_t *gl);

/** Release the context and its objects; NULL is fine. */
void ef_gl_close(ef_gl_t *gl);

/**
 * @brief Optimize n normalized configurations in one dispatch.
 * @param kind EF_TABLE_G1_CUBIC or EF_TABLE_G2_QUINTIC
 * @param cfg  n x 4 doubles: alpha, beta, k0, k1 (k ignored for G1)
 * @param o    bounds and iteration settings (x1_min, x1_max, x2_max, max_iter, tol); warm
 *             starts are not used on the GPU
 * @param res  n x EF_GL_RES_STRIDE doubles: DOFs per unit chord in [0..3] (G1: x1_0, x1_1),
 *             C in [4], converged in [5], at-bound bits in [6], starts run in [7];
 *             configurations the driver cut short are solved on the CPU reference
 *             (ef_gl_fallbacks() counts them), so every result is a complete solve
 * @retval EF_OK
 * @retval EF_ERR_ARG     NULL pointer, unknown kind, n == 0
 * @retval EF_ERR_IO      shader compile/link failure (with the driver's log), a GL error, a
 *                        lost context, or a dispatch that did not finish within the timeout
 * @retval EF_ERR_NOCONV  a result was not finite
 */
int ef_gl_solve(ef_gl_t *gl, int kind, const double *cfg, uint32_t n, const ef_ref_opts_t *o,
                double *res, ef_msg_t *m);

/**
 * @brief A table-build backend (ef_build.h) on a new context with default options; its
 * close() releases the context. Each solve_rows() call is one dispatch.
 * @retval EF_OK
 * @retval others as ef_gl_open()
 */
int ef_gl_backend_open(ef_build_backend_t *b, ef_msg_t *m);

#ifdef __cplusplus
}
#endif

#endif /* EF_GL_H */
