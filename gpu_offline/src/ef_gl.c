/* SPDX-License-Identifier: Apache-2.0 */
/* Headless OpenGL 4.3 compute through EGL (device or surfaceless platform) via libepoxy. */
#include <epoxy/egl.h>
#include <epoxy/gl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "evenfeed/gpu/ef_gl.h"

/* The shader source, embedded at build time from gpu_offline/shaders/ef_opt.comp. */
extern const char ef_gl_shader_src[];

/* Doubles per configuration sent to the shader: alpha, beta, k0, k1, then cos/sin of
 * alpha and beta computed here with libm (GLSL 4.30 has no double-precision sin/cos). */
#define EF_GL_CFG_STRIDE 8

struct ef_gl {
    EGLDisplay dpy;
    EGLContext ctx;
    const char *platform;
    char renderer[256];
    GLuint prog[3]; /* per kind (1, 2), compiled on first use */
    GLuint buf[2];  /* configurations, results */
    uint32_t local_size;
    double timeout_s;
    int robust;         /* the context reports resets */
    uint64_t fallbacks; /* configurations the driver cut short, solved on the CPU */
};

/* EGL's last error as text for messages. */
static const char *gl_egl_err(void)
{
    switch (eglGetError()) {
    case EGL_SUCCESS:
        return "EGL_SUCCESS";
    case EGL_NOT_INITIALIZED:
        return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS:
        return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC:
        return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE:
        return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG:
        return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT:
        return "EGL_BAD_CONTEXT";
    case EGL_BAD_DISPLAY:
        return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH:
        return "EGL_BAD_MATCH";
    case EGL_BAD_PARAMETER:
        return "EGL_BAD_PARAMETER";
    default:
        return "EGL error";
    }
}

/* Whether a space-separated extension list names ext exactly. */
static int gl_has_ext(const char *list, const char *ext)
{
    size_t n = strlen(ext);
    for (const char *p = list; p && (p = strstr(p, ext)) != NULL; p += n)
        if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0'))
            return 1;
    return 0;
}

/* A display on the EGL device platform: the index-th device, skipping Mesa's software
 * device in "auto" mode so a real GPU wins and llvmpipe comes from the surfaceless path. */
static EGLDisplay gl_device_display(int index, int skip_software, char *why, size_t whylen)
{
    const char *cext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (!gl_has_ext(cext, "EGL_EXT_device_enumeration") ||
        !gl_has_ext(cext, "EGL_EXT_platform_device")) {
        snprintf(why, whylen, "EGL has no device platform (EGL_EXT_platform_device)");
        return EGL_NO_DISPLAY;
    }
    EGLDeviceEXT devs[16];
    EGLint count = 0;
    if (!eglQueryDevicesEXT(16, devs, &count) || count == 0) {
        snprintf(why, whylen, "no EGL devices");
        return EGL_NO_DISPLAY;
    }
    for (EGLint i = 0, seen = 0; i < count; i++) {
        const char *dext = eglQueryDeviceStringEXT(devs[i], EGL_EXTENSIONS);
        if (skip_software && gl_has_ext(dext, "EGL_MESA_device_software"))
            continue;
        if (seen++ == index)
            return eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, devs[i], NULL);
    }
    snprintf(why, whylen, "EGL device %d not found (%d devices%s)", index, (int)count,
             skip_software ? ", software ones skipped" : "");
    return EGL_NO_DISPLAY;
}

/* Initialize dpy and create a 4.3 core context on it, current with no surface. */
static int gl_context(ef_gl_t *gl, EGLDisplay dpy, ef_msg_t *m)
{
    EGLint maj = 0, min = 0;
    if (dpy == EGL_NO_DISPLAY || !eglInitialize(dpy, &maj, &min))
        return ef_fail(m, EF_ERR_IO, "gl: cannot initialize the %s EGL display (%s)%s",
                       gl->platform, gl_egl_err(),
                       strcmp(gl->platform, "surfaceless") ? ""
                                                           : "; is libgl1-mesa-dri installed?");
    gl->dpy = dpy;
    const char *dext = eglQueryString(dpy, EGL_EXTENSIONS);
    if (!gl_has_ext(dext, "EGL_KHR_surfaceless_context"))
        return ef_fail(m, EF_ERR_IO, "gl: EGL %d.%d lacks EGL_KHR_surfaceless_context", maj, min);
    if (!eglBindAPI(EGL_OPENGL_API))
        return ef_fail(m, EF_ERR_IO, "gl: EGL cannot bind the OpenGL API (%s)", gl_egl_err());
    EGLConfig cfg = EGL_NO_CONFIG_KHR;
    if (!gl_has_ext(dext, "EGL_KHR_no_config_context")) {
        const EGLint ca[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
        EGLint n = 0;
        if (!eglChooseConfig(dpy, ca, &cfg, 1, &n) || n == 0)
            return ef_fail(m, EF_ERR_IO, "gl: no EGL config for desktop OpenGL");
    }
    /* Robustness when offered: a lost context then says so instead of returning garbage. */
    int robust = gl_has_ext(dext, "EGL_EXT_create_context_robustness");
    EGLint attr[16], k = 0;
    attr[k++] = EGL_CONTEXT_MAJOR_VERSION;
    attr[k++] = 4;
    attr[k++] = EGL_CONTEXT_MINOR_VERSION;
    attr[k++] = 3;
    attr[k++] = EGL_CONTEXT_OPENGL_PROFILE_MASK;
    attr[k++] = EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT;
    if (robust) {
        attr[k++] = EGL_CONTEXT_OPENGL_ROBUST_ACCESS_EXT;
        attr[k++] = EGL_TRUE;
        attr[k++] = EGL_CONTEXT_OPENGL_RESET_NOTIFICATION_STRATEGY_EXT;
        attr[k++] = EGL_LOSE_CONTEXT_ON_RESET_EXT;
    }
    attr[k] = EGL_NONE;
    gl->ctx = eglCreateContext(dpy, cfg, EGL_NO_CONTEXT, attr);
    if (gl->ctx == EGL_NO_CONTEXT && robust) { /* some drivers refuse robustness: retry */
        attr[6] = EGL_NONE;
        robust = 0;
        gl->ctx = eglCreateContext(dpy, cfg, EGL_NO_CONTEXT, attr);
    }
    if (gl->ctx == EGL_NO_CONTEXT)
        return ef_fail(m, EF_ERR_IO,
                       "gl: no OpenGL 4.3 core context (%s); compute shaders need GL 4.3",
                       gl_egl_err());
    if (!eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, gl->ctx))
        return ef_fail(m, EF_ERR_IO, "gl: cannot make the context current (%s)", gl_egl_err());
    GLint gmaj = 0, gmin = 0;
    glGetIntegerv(GL_MAJOR_VERSION, &gmaj);
    glGetIntegerv(GL_MINOR_VERSION, &gmin);
    if (gmaj * 10 + gmin < 43)
        return ef_fail(m, EF_ERR_IO, "gl: context is OpenGL %d.%d; 4.3 is needed", gmaj, gmin);
    gl->robust = robust && (gmaj * 10 + gmin >= 45 || epoxy_has_gl_extension("GL_KHR_robustness"));
    snprintf(gl->renderer, sizeof gl->renderer, "%s", (const char *)glGetString(GL_RENDERER));
    return EF_OK;
}

/* Options with defaults and the environment's overrides applied. */
static ef_gl_opts_t gl_defaults(const ef_gl_opts_t *o)
{
    ef_gl_opts_t r = {0};
    if (o)
        r = *o;
    const char *env = getenv("EF_GL_PLATFORM");
    if (env && *env)
        r.platform = env;
    env = getenv("EF_GL_DEVICE");
    if (env && *env)
        r.device = atoi(env);
    if (!r.platform)
        r.platform = "auto";
    if (r.local_size == 0)
        r.local_size = 32;
    if (!(r.timeout_s > 0))
        r.timeout_s = 300;
    return r;
}

/* Device platform first (a real GPU), then Mesa's surfaceless platform. */
int ef_gl_open(ef_gl_t **out, const ef_gl_opts_t *opts, ef_msg_t *m)
{
    if (!out)
        return ef_fail(m, EF_ERR_ARG, "gl: NULL output");
    *out = NULL;
    ef_gl_opts_t o = gl_defaults(opts);
    int want_dev = !strcmp(o.platform, "device"), want_sl = !strcmp(o.platform, "surfaceless");
    int is_auto = !strcmp(o.platform, "auto");
    if (!want_dev && !want_sl && !is_auto)
        return ef_fail(m, EF_ERR_ARG, "gl: unknown EGL platform '%s' (auto, device, surfaceless)",
                       o.platform);
    ef_gl_t *gl = calloc(1, sizeof *gl);
    if (!gl)
        return ef_fail(m, EF_ERR_NOMEM, "gl: out of memory");
    gl->local_size = o.local_size;
    gl->timeout_s = o.timeout_s;
    char why[600] = "";
    int rc = EF_ERR_IO;
    if (want_dev || is_auto) {
        EGLDisplay d = gl_device_display(o.device, is_auto, why, sizeof why);
        if (d != EGL_NO_DISPLAY) {
            gl->platform = "device";
            rc = gl_context(gl, d, m);
            if (rc != EF_OK && is_auto) { /* fall back to surfaceless */
                snprintf(why, sizeof why, "%s", m ? m->text : "device platform failed");
                if (gl->dpy != EGL_NO_DISPLAY)
                    eglTerminate(gl->dpy);
                gl->dpy = EGL_NO_DISPLAY;
                gl->ctx = EGL_NO_CONTEXT;
            }
        } else if (want_dev) {
            rc = ef_fail(m, EF_ERR_IO, "gl: %s", why);
        }
    }
    if (rc != EF_OK && (want_sl || is_auto)) {
        const char *cext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
        if (!gl_has_ext(cext, "EGL_MESA_platform_surfaceless"))
            rc = ef_fail(m, EF_ERR_IO,
                         "gl: no headless EGL platform: %s%sand no Mesa surfaceless "
                         "platform (install libegl-mesa0 and libgl1-mesa-dri)",
                         why, *why ? "; " : "");
        else {
            gl->platform = "surfaceless";
            rc = gl_context(
                gl,
                eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL),
                m);
        }
    }
    if (rc != EF_OK) {
        ef_gl_close(gl);
        return rc;
    }
    glGenBuffers(2, gl->buf);
    *out = gl;
    return EF_OK;
}

const char *ef_gl_renderer(const ef_gl_t *gl)
{
    return gl ? gl->renderer : "";
}

const char *ef_gl_platform(const ef_gl_t *gl)
{
    return gl && gl->platform ? gl->platform : "";
}

/* Delete GL objects, then the context and display. */
void ef_gl_close(ef_gl_t *gl)
{
    if (!gl)
        return;
    if (gl->ctx != EGL_NO_CONTEXT && gl->ctx) {
        for (int k = 0; k < 3; k++)
            if (gl->prog[k])
                glDeleteProgram(gl->prog[k]);
        if (gl->buf[0])
            glDeleteBuffers(2, gl->buf);
        eglMakeCurrent(gl->dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        eglDestroyContext(gl->dpy, gl->ctx);
    }
    if (gl->dpy != EGL_NO_DISPLAY && gl->dpy)
        eglTerminate(gl->dpy);
    free(gl);
}

/* Compile and link the optimizer for a kind, with the driver's log on failure. */
static int gl_program(ef_gl_t *gl, int kind, ef_msg_t *m)
{
    if (gl->prog[kind])
        return EF_OK;
    char pre[256];
    snprintf(pre, sizeof pre,
             "#version 430\n#extension GL_ARB_gpu_shader_fp64 : require\n#define EF_KIND %d\n"
             "#define EF_LOCAL_SIZE %u\n#define EF_CFG_STRIDE %d\n#line 1\n",
             kind, gl->local_size, EF_GL_CFG_STRIDE);
    const char *src[2] = {pre, ef_gl_shader_src};
    GLuint sh = glCreateShader(GL_COMPUTE_SHADER);
    glShaderSource(sh, 2, src, NULL);
    glCompileShader(sh);
    GLint ok = 0;
    char log[2048] = "";
    glGetShaderiv(sh, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        glGetShaderInfoLog(sh, sizeof log, NULL, log);
        glDeleteShader(sh);
        return ef_fail(m, EF_ERR_IO, "gl: compute shader (kind %d) does not compile: %s", kind,
                       log);
    }
    GLuint p = glCreateProgram();
    glAttachShader(p, sh);
    glLinkProgram(p);
    glDeleteShader(sh);
    glGetProgramiv(p, GL_LINK_STATUS, &ok);
    if (!ok) {
        glGetProgramInfoLog(p, sizeof log, NULL, log);
        glDeleteProgram(p);
        return ef_fail(m, EF_ERR_IO, "gl: compute program (kind %d) does not link: %s", kind, log);
    }
    gl->prog[kind] = p;
    return EF_OK;
}

/* A pending GL error, or a reset of the context, as a message. */
static int gl_check(ef_gl_t *gl, const char *step, ef_msg_t *m)
{
    if (gl->robust) {
        GLenum reset = glGetGraphicsResetStatus();
        if (reset != GL_NO_ERROR)
            return ef_fail(m, EF_ERR_IO, "gl: context lost during %s (reset status 0x%x)", step,
                           (unsigned)reset);
    }
    GLenum e = glGetError();
    if (e != GL_NO_ERROR)
        return ef_fail(m, EF_ERR_IO, "gl: GL error 0x%x during %s", (unsigned)e, step);
    return EF_OK;
}

/* Set a double uniform by name (absent uniforms are optimized away: fine). */
static void gl_set_d(GLuint p, const char *name, double v)
{
    GLint loc = glGetUniformLocation(p, name);
    if (loc >= 0)
        glUniform1d(loc, v);
}

/* The CPU reference for one configuration, in the shader's result layout. */
static int gl_cpu_solve(int kind, const double *c, const ef_ref_opts_t *o, double *r, ef_msg_t *m)
{
    ef_dend_t e0, e1;
    const int g2 = kind == EF_TABLE_G2_QUINTIC;
    ef_ref_config(c[0], c[1], g2 ? c[2] : 0, g2 ? c[3] : 0, &e0, &e1);
    ef_ref_result_t rr;
    int rc = ef_ref_optimize(g2 ? EF_REF_G2_QUINTIC : EF_REF_G1_CUBIC, &e0, &e1, o, &rr, m);
    if (rc != EF_OK)
        return rc;
    for (int k = 0; k < 4; k++)
        r[k] = k < rr.ndof ? rr.dof[k] : 0.0;
    r[4] = rr.C;
    r[5] = rr.converged;
    r[6] = rr.at_bound;
    r[7] = rr.starts;
    return EF_OK;
}

/* Upload, dispatch, wait with a timeout, read back; configurations the driver cut short are
 * solved on the CPU (counted), anything else not finite is an error. */
int ef_gl_solve(ef_gl_t *gl, int kind, const double *cfg, uint32_t n, const ef_ref_opts_t *opts,
                double *res, ef_msg_t *m)
{
    if (!gl || !cfg || !res || n == 0 || (kind != EF_TABLE_G1_CUBIC && kind != EF_TABLE_G2_QUINTIC))
        return ef_fail(m, EF_ERR_ARG, "gl: bad arguments to solve");
    ef_ref_opts_t o;
    ef_ref_opts_default(&o);
    if (opts)
        o = *opts;
    int rc = gl_program(gl, kind, m);
    if (rc != EF_OK)
        return rc;
    double *in = malloc(sizeof(double) * EF_GL_CFG_STRIDE * n);
    if (!in)
        return ef_fail(m, EF_ERR_NOMEM, "gl: out of memory for %u configurations", n);
    for (uint32_t i = 0; i < n; i++) {
        const double *c = cfg + 4 * (size_t)i;
        double *d = in + EF_GL_CFG_STRIDE * (size_t)i;
        d[0] = c[0], d[1] = c[1], d[2] = c[2], d[3] = c[3];
        d[4] = cos(c[0]), d[5] = sin(c[0]), d[6] = cos(c[1]), d[7] = sin(c[1]);
    }
    GLuint p = gl->prog[kind];
    glUseProgram(p);
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, gl->buf[0]);
    glBufferData(GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)(sizeof(double) * EF_GL_CFG_STRIDE * n), in,
                 GL_STREAM_DRAW);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, gl->buf[0]);
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, gl->buf[1]);
    glBufferData(GL_SHADER_STORAGE_BUFFER, (GLsizeiptr)(sizeof(double) * EF_GL_RES_STRIDE * n),
                 NULL, GL_STREAM_READ);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, gl->buf[1]);
    free(in);
    glUniform1ui(glGetUniformLocation(p, "ef_count"), n);
    glUniform1i(glGetUniformLocation(p, "ef_max_iter"), o.max_iter);
    gl_set_d(p, "ef_x1_min", o.x1_min);
    gl_set_d(p, "ef_x1_max", o.x1_max);
    gl_set_d(p, "ef_x2_max", o.x2_max);
    gl_set_d(p, "ef_tol", o.tol);
    if ((rc = gl_check(gl, "upload", m)) != EF_OK)
        return rc;
    glDispatchCompute((n + gl->local_size - 1) / gl->local_size, 1, 1);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    GLsync fence = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
    GLenum w = glClientWaitSync(fence, GL_SYNC_FLUSH_COMMANDS_BIT, (GLuint64)(gl->timeout_s * 1e9));
    glDeleteSync(fence);
    if (w == GL_TIMEOUT_EXPIRED)
        return ef_fail(m, EF_ERR_IO,
                       "gl: a dispatch of %u configurations did not finish in %.0f s "
                       "(GPU hung or lost); use smaller chunks",
                       n, gl->timeout_s);
    if (w == GL_WAIT_FAILED)
        return ef_fail(m, EF_ERR_IO, "gl: waiting for the dispatch failed (context lost?)");
    if ((rc = gl_check(gl, "dispatch", m)) != EF_OK)
        return rc;
    glGetBufferSubData(GL_SHADER_STORAGE_BUFFER, 0,
                       (GLsizeiptr)(sizeof(double) * EF_GL_RES_STRIDE * n), res);
    if ((rc = gl_check(gl, "read-back", m)) != EF_OK)
        return rc;
    for (uint32_t i = 0; i < n; i++) {
        double *r = res + EF_GL_RES_STRIDE * (size_t)i;
        const double *c = cfg + 4 * (size_t)i;
        if (r[7] < 0) { /* the driver cut this invocation's loops short: solve it here */
            if ((rc = gl_cpu_solve(kind, c, &o, r, m)) != EF_OK)
                return rc;
            gl->fallbacks++;
            continue;
        }
        for (int k = 0; k < 5; k++)
            if (!isfinite(r[k]))
                return ef_fail(m, EF_ERR_NOCONV,
                               "gl: configuration (%.6g, %.6g, %.6g, %.6g) gave a "
                               "non-finite result",
                               c[0], c[1], c[2], c[3]);
    }
    return EF_OK;
}

uint64_t ef_gl_fallbacks(const ef_gl_t *gl)
{
    return gl ? gl->fallbacks : 0;
}

/* Backend: the rows' node configurations in one dispatch, stored as the CPU backend does. */
static int gl_solve_rows(void *ctx, ef_tfile_t *t, uint32_t row_begin, uint32_t row_end,
                         ef_msg_t *m)
{
    ef_gl_t *gl = ctx;
    const uint32_t n0 = t->view.axis[0].nodes, first = row_begin * n0;
    const uint32_t n = (row_end - row_begin) * n0;
    double *cfg = malloc(sizeof(double) * 4 * n),
           *res = malloc(sizeof(double) * EF_GL_RES_STRIDE * n);
    if (!cfg || !res) {
        free(cfg);
        free(res);
        return ef_fail(m, EF_ERR_NOMEM, "gl: out of memory for %u nodes", n);
    }
    for (uint32_t i = 0; i < n; i++)
        ef_build_node_config(t, first + i, cfg + 4 * (size_t)i);
    ef_ref_opts_t o;
    ef_build_ref_opts(t, &o);
    int rc = ef_gl_solve(gl, t->view.kind, cfg, n, &o, res, m);
    if (rc == EF_OK)
        for (uint32_t i = 0; i < n; i++) {
            const double *r = res + EF_GL_RES_STRIDE * (size_t)i;
            double dof[4] = {r[0], r[1], r[2], r[3]};
            ef_build_store(t, first + i, dof);
        }
    free(cfg);
    free(res);
    return rc;
}

static void gl_backend_close(void *ctx)
{
    ef_gl_close(ctx);
}

/* GL backend on a fresh default context. */
int ef_gl_backend_open(ef_build_backend_t *b, ef_msg_t *m)
{
    if (!b)
        return ef_fail(m, EF_ERR_ARG, "gl: NULL backend");
    ef_gl_t *gl;
    int rc = ef_gl_open(&gl, NULL, m);
    if (rc != EF_OK)
        return rc;
    *b = (ef_build_backend_t){.name = "gl",
                              .solve_rows = gl_solve_rows,
                              .close = gl_backend_close,
                              .ctx = gl,
                              .chunk_nodes = 2048};
    return EF_OK;
}
