/* SPDX-License-Identifier: Apache-2.0 */
/* Corners with arc/helix ends (ef_blend_prims()) and arc pieces as G2 quintics
 * (ef_blend_arc_piece()). Both build the quintic from exact end frames of the primitives
 * (ef_prim_frame()) through the G2 table and measure its deviation, since no closed form
 * exists for it; the distance from a point to a line or arc piece is in closed form
 * (ba_dist_piece(), the pieces prepared once per trial by ba_piece()), and the
 * quintic is evaluated in Bernstein form (ba_q5()). See ef_blend.h. */
#include "evenfeed/blend/ef_blend.h"
#include "evenfeed/geom/ef_bezier.h"
#include "evenfeed/core/ef_config.h"
#include "evenfeed/core/ef_err.h"

/* Share of the tolerance kept for float32 rounding, per unit of the coordinates' magnitude
 * (as ef_blend.c). */
#define EF_BA_ROUND_MARGIN (4.0f * 1.1920929e-7f)
/* Float32 error of ef_prim_frame()'s angle on an arc, in ulp of the angle (ba_piece()):
 * rounding s / len and sweep * frac, half an ulp each, doubled for len's own rounding.
 * Empirical, not proven: tests/blend/test_prim.c's 1500 arc pieces (up to 4 turns) find the true
 * deviation at most 0.998 x the reported one with it, 2.8 x without. */
#define EF_BA_ANGLE_ULP 2.0f
/* Newton steps on x1 = L per candidate curve of ba_even(). */
#ifndef EF_BA_NEWTON
#define EF_BA_NEWTON 3
#endif
/* Extra samples per refined interval, plus one (ba_try()). */
#define EF_BA_REFINE 8
/* Points of each replaced piece checked for their distance to the blend (ba_try()). */
#define EF_BA_PATH_PTS 3
/* Relative allowance over the blend's bounded deviation: the between-sample term is an
 * estimate (second differences), not a proof. tests/blend/test_prim.c (6000 random corners)
 * finds the true deviation at most 0.984 x the result (with the 0.99 target, all within
 * 0.981 tol). */
#define EF_BA_DEV_REL 1.02f
/* Tangent joins (turn below EF_BLEND_MIN_TURN, ef_blend_prims()): the curvature jump
 * dk = |kappa_in n_in - kappa_out n_out| is blended when dk tol >= EF_BLEND_MIN_TURN^2, i.e.
 * when a transition that deviates by tol (trims about sqrt(tol / dk), turning the tangent by
 * about sqrt(dk tol) across the jump) would turn it by at least what counts as a corner;
 * below that the jump is as negligible as a straight corner's kink. The jump must also
 * exceed EF_BA_KAPPA_REL of the larger curvature, well above float32's rounding of the
 * curvature vectors (an arc split into two at a vertex is no join to blend). */
#define EF_BA_TANGENT_MIN (EF_BLEND_MIN_TURN * EF_BLEND_MIN_TURN)
#define EF_BA_KAPPA_REL   1e-4f
/* First trim estimate for a tangent join: deviation ~ dk L^2 / EF_BA_TANGENT_GAIN. */
#define EF_BA_TANGENT_GAIN 1.0f
/* A blend's end speeds |f'(0)|, |f'(1)| are set to its arc length L as ef_seg_g2_even()
 * sets a segment's (ba_even()): a stepper that steps tau uniformly by the time law
 * (EF_STEP_UNIFORM, the drives' segment mode) moves at v |f'(tau)| / L, so at a junction
 * with a line (|f'| / L = 1) the feed would jump by v times the difference in one servo
 * period. The table's optimum for a lopsided
 * corner (one side trimmed far more than the other, or a tight arc on one side) can be far
 * off: 0.4 and 0.9 were seen, and at 9 mm/s the jump was 1 mm/s in 1 ms, 1000 mm/s^2
 * (tests/fuzz, issue 18). A trial whose ends ba_even() could not bring within
 * EF_SEG_END_SPEED_REL is not a blend. */

/* Finite test without libm (NaN fails x == x, inf fails x - x == 0). */
static int ba_finite(float x)
{
    return (x == x) & (x - x == 0.0f);
}

/* Zero a move, so a failed arc piece hands back no partial data. */
static void ba_zero_move(ef_move_t *m)
{
    ef_move_t zero = {0};
    *m = zero;
}

/* Zero the blend result and return rc: the single failure exit of ef_blend_prims(). */
static int ba_fail_blend(ef_blend_t *res, int rc)
{
    ef_blend_t zero = {0};
    *res = zero;
    return rc;
}

/* Largest coordinate magnitude, to scale the float32 rounding margin. */
static float ba_maxabs(ef_vec3_t a)
{
    return ef_maxf(ef_maxf(ef_fabsf(a.x), ef_fabsf(a.y)), ef_fabsf(a.z));
}

/* Start radius of an arc (perpendicular to the axis); 0 for a line. */
static float ba_radius(ef_vec3_t start, const ef_prim_t *pr)
{
    if (pr->kind != EF_PRIM_ARC)
        return 0.0f;
    float aa = ef_v3_dot(pr->axis, pr->axis);
    ef_vec3_t a = ef_v3_scale(pr->axis, 1.0f / ef_sqrtf(ef_maxf(aa, 1e-30f)));
    ef_vec3_t d0 = ef_v3_sub(start, pr->centre);
    return ef_v3_norm(ef_v3_axpy(d0, -ef_v3_dot(d0, a), a));
}

/* Point of the quintic b at t: the control points weighted by the degree-5 Bernstein
 * polynomials (all positive, so as accurate as de Casteljau's algorithm, without its
 * copies). */
static ef_vec3_t ba_q5(const ef_vec3_t *b, float t)
{
    float u = 1.0f - t, t2 = t * t, u2 = u * u;
    float w0 = u2 * u2 * u, w1 = 5.0f * u2 * u2 * t, w2 = 10.0f * u2 * u * t2;
    float w3 = 10.0f * u2 * t2 * t, w4 = 5.0f * u * t2 * t2, w5 = t2 * t2 * t;
    ef_vec3_t r = ef_v3_scale(b[0], w0);
    r = ef_v3_axpy(r, w1, b[1]);
    r = ef_v3_axpy(r, w2, b[2]);
    r = ef_v3_axpy(r, w3, b[3]);
    r = ef_v3_axpy(r, w4, b[4]);
    return ef_v3_axpy(r, w5, b[5]);
}

/* The same for the first (degree 4, h1) and second (degree 3, h2) hodographs. */
static void ba_d12(const ef_vec3_t *h1, const ef_vec3_t *h2, float t, ef_vec3_t *d1, ef_vec3_t *d2)
{
    float u = 1.0f - t, t2 = t * t, u2 = u * u;
    ef_vec3_t r = ef_v3_scale(h1[0], u2 * u2);
    r = ef_v3_axpy(r, 4.0f * u2 * u * t, h1[1]);
    r = ef_v3_axpy(r, 6.0f * u2 * t2, h1[2]);
    r = ef_v3_axpy(r, 4.0f * u * t2 * t, h1[3]);
    *d1 = ef_v3_axpy(r, t2 * t2, h1[4]);
    r = ef_v3_scale(h2[0], u2 * u);
    r = ef_v3_axpy(r, 3.0f * u2 * t, h2[1]);
    r = ef_v3_axpy(r, 3.0f * u * t2, h2[2]);
    *d2 = ef_v3_axpy(r, t2 * t, h2[3]);
}

/* sin x for |x| <= pi/4 (fdlibm's float kernel, about 1 ulp). */
static float ba_sin(float x)
{
    float z = x * x;
    return x + x * z *
                   (-1.6666667163e-01f +
                    z * (8.3333337680e-03f + z * (-1.9841270114e-04f + z * 2.7183114939e-06f)));
}

/* cos x for |x| <= pi/4 (fdlibm's float kernel). */
static float ba_cos(float x)
{
    float z = x * x;
    return 1.0f - 0.5f * z +
           z * z * (4.1666667908e-02f + z * (-1.3888889225e-03f + z * 2.4801587642e-05f));
}

/* A replaced piece [sa, sb] of a checked primitive, prepared once per trial for
 * ba_dist_piece(). Lines: start p0, unit direction t, length l. Arcs and helices (a piece
 * of at most EF_ARC_PIECE_SWEEP, plus rounding): the axis point cm level with the piece's
 * middle, the outward radial unit ex there, ey = +-(axis x ex) in the direction of travel,
 * the unit axis a, radius r, axial rise c per radian of travel, half sweep psi; a point of
 * the piece is cm + r (cos th ex + sin th ey) + c th a, |th| <= psi. pa, pb: its ends.
 * err: what ef_prim_frame()'s float32 angle (sweep * s / len, a few ulp of it) can move a
 * point along an arc, EF_BA_ANGLE_ULP ulp of the angle at the piece's far end times the
 * radius, added to every distance (the blend's ends come from those frames, so they may lie
 * that far beyond the true piece's ends); 0 for lines. q: EF_BA_PATH_PTS points of the piece,
 * evenly spaced (the path-to-blend check of ba_try()). */
typedef struct {
    ef_vec3_t p0, t, cm, ex, ey, a, pa, pb;
    ef_vec3_t q[EF_BA_PATH_PTS]; /* points at k / (EF_BA_PATH_PTS + 1) of the piece */
    float l, r, c, psi, err;
    int arc;
} ef_ba_piece_t;

/* Prepare the replaced piece [sa, sb] of a primitive for ba_dist_piece(). */
static void ba_piece(ef_vec3_t start, const ef_prim_t *pr, float len, float sa, float sb,
                     ef_ba_piece_t *pc)
{
    ef_frame_t f;
    ef_prim_frame(start, pr, sa, &f);
    pc->p0 = f.p;
    pc->pa = f.p;
    pc->t = f.t;
    pc->l = sb - sa;
    pc->arc = pr->kind == EF_PRIM_ARC;
    if (!pc->arc) {
        pc->pb = ef_v3_axpy(f.p, pc->l, f.t);
        pc->cm = pc->ex = pc->ey = pc->a = f.p;
        pc->r = pc->c = pc->psi = pc->err = 0.0f;
        for (int k = 0; k < EF_BA_PATH_PTS; k++)
            pc->q[k] = ef_v3_axpy(f.p, pc->l * ((float)(k + 1) / (float)(EF_BA_PATH_PTS + 1)), f.t);
        return;
    }
    ef_prim_frame(start, pr, sb, &f);
    pc->pb = f.p;
    float aa = ef_v3_dot(pr->axis, pr->axis);
    ef_vec3_t a = ef_v3_scale(pr->axis, 1.0f / ef_sqrtf(ef_maxf(aa, 1e-30f)));
    float r0 = ba_radius(start, pr);
    ef_prim_frame(start, pr, 0.5f * (sa + sb), &f);
    ef_vec3_t ex = ef_v3_scale(f.n, -1.0f);
    float asw = ef_fabsf(pr->sweep);
    float h = ef_v3_dot(ef_v3_sub(pr->end, start), a); /* axial rise of the whole primitive */
    pc->cm = ef_v3_axpy(f.p, -r0, ex);
    pc->ex = ex;
    pc->ey = ef_v3_scale(ef_v3_cross(a, ex), pr->sweep < 0.0f ? -1.0f : 1.0f);
    pc->a = a;
    pc->r = r0;
    pc->c = h / asw;
    pc->psi = 0.5f * asw * ((sb - sa) / len);
    pc->err = r0 * asw * (sb / len) * (EF_BA_ANGLE_ULP * 1.1920929e-7f);
    for (int k = 0; k < EF_BA_PATH_PTS; k++) {
        float th = pc->psi * ((float)(2 * (k + 1)) / (float)(EF_BA_PATH_PTS + 1) - 1.0f);
        float sn = ba_sin(th), cs = ba_cos(th);
        ef_vec3_t rad = ef_v3_axpy(ef_v3_scale(ex, cs), sn, pc->ey);
        pc->q[k] = ef_v3_axpy(ef_v3_axpy(pc->cm, r0, rad), pc->c * th, a);
    }
}

/* Distance from q to a piece, or an upper bound of it (the distance to a point of the
 * piece, so never below the true distance; up to float32 rounding). Lines: exact. Arcs:
 * with q's cylinder coordinates about the piece's middle (rho, phi, z), the nearer end, and
 * when |phi| <= psi also the point at angle phi, sqrt((rho - r)^2 + (z - c phi)^2), exact
 * for a circle; for a helix also the point one Newton step on from phi (clamped to the
 * piece), |q - P(th)|^2 = (rho - r)^2 + 4 rho r sin^2((th - phi) / 2) + (z - c th)^2. */
static float ba_dist_piece(ef_vec3_t q, const ef_ba_piece_t *pc)
{
    if (!pc->arc) {
        ef_vec3_t w = ef_v3_sub(q, pc->p0);
        float s = ef_minf(ef_maxf(ef_v3_dot(w, pc->t), 0.0f), pc->l);
        return ef_v3_norm(ef_v3_axpy(w, -s, pc->t));
    }
    ef_vec3_t da = ef_v3_sub(q, pc->pa), db = ef_v3_sub(q, pc->pb);
    float e2 = ef_minf(ef_v3_dot(da, da), ef_v3_dot(db, db));
    ef_vec3_t w = ef_v3_sub(q, pc->cm);
    float x = ef_v3_dot(w, pc->ex), y = ef_v3_dot(w, pc->ey), z = ef_v3_dot(w, pc->a);
    float rho = ef_sqrtf(x * x + y * y), r = pc->r, c = pc->c, psi = pc->psi;
    float phi = ef_atan2f(y, x);
    float dr = rho - r, dz = z - c * phi;
    float d1 = dr * dr + dz * dz;
    float th = ef_minf(ef_maxf(phi + c * dz / ef_maxf(rho * r + c * c, 1e-30f), -psi), psi);
    float sn = ba_sin(0.5f * (th - phi)), dz2 = z - c * th;
    float d2 = dr * dr + 4.0f * rho * r * sn * sn + dz2 * dz2;
    int inside = ef_fabsf(phi) <= psi;
    float din = ef_minf(d1, d2);
    return ef_sqrtf(ef_minf(e2, ef_selectf(inside, din, 3.4e38f))) + pc->err;
}

/* Largest gap between an arc's end and its model circle (ef_prim_end_gap()) that the
 * closed-form piece carries, relative to the piece's length: the quintic's end speeds then
 * differ from its length by about that much, well within EF_SEG_END_SPEED_REL. */
#define EF_BA_PIECE_GAP_REL 2.5e-4f
/* Samples of a table-built piece's quintic for its deviation from the true arc. */
#define EF_BA_PIECE_SAMPLES 64

/* Fill a piece's move fields and measure it; the move is zeroed on failure. */
static int ba_piece_finish(const ef_prim_t *pr, float dev, ef_move_t *m)
{
    m->degree = 5;
    m->kind = EF_MOVE_ARC;
    m->tag = pr->tag;
    m->feed = pr->feed;
    m->dev = dev;
    int rc = ef_move_measure(m);
    if (rc != EF_OK)
        ba_zero_move(m);
    return rc;
}

/* The last piece of an arc whose end lies off its circle by more than
 * EF_BA_PIECE_GAP_REL of the piece (a short G-code arc with a radius error near the
 * tolerance; fuzzed: 0.0122 off after 5e-6 of arc): the table's quintic between the exact
 * end frames, evened (ef_seg_g2_even()), its deviation from the true piece measured at
 * EF_BA_PIECE_SAMPLES samples. About 65 k instructions against the closed form's 10 k. */
static int ba_piece_table(const ef_table_t *g2, ef_vec3_t start, const ef_prim_t *pr, float len,
                          float s0, float s1, const ef_frame_t *f0, const ef_frame_t *f1, float gap,
                          ef_move_t *m)
{
    ef_endpoint_t e0 = ef_frame_endpoint(f0), e1 = ef_frame_endpoint(f1);
    ef_seg_t seg;
    int rc = ef_seg_g2_quintic(g2, &e0, &e1, &seg);
    if (rc != EF_OK)
        return rc;
    ef_seg_g2_even(&e0, &e1, &seg, 0, 0);
    float dev = 0.0f;
    ef_ba_piece_t pc;
    ba_piece(start, pr, len, s0, s1, &pc);
    for (int i = 1; i <= EF_BA_PIECE_SAMPLES; i++) {
        float t = (float)i * (1.0f / (float)(EF_BA_PIECE_SAMPLES + 1));
        dev = ef_maxf(dev, ba_dist_piece(ba_q5(seg.b, t), &pc));
    }
    for (int i = 0; i < 6; i++)
        m->b[i] = seg.b[i];
    m->flags = (uint16_t)((seg.flags & EF_SEG_CLAMPED) ? EF_MOVE_CLAMPED : 0u);
    /* the samples measure against the circle, which misses the end by the gap */
    return ba_piece_finish(pr, dev + gap, m);
}

/* An arc piece as a G2 quintic move with a closed-form deviation bound (contract in
 * ef_blend.h). The quintic is the arc-length choice x1 = s1 - s0, x2 = 0: its end
 * derivatives f' = x1 t, f'' = x1^2 kappa n are exactly those of the arc (circle or helix)
 * parametrized by t = (s - s0) / (s1 - s0), so it is that parametrization's two-point
 * Hermite interpolant of order 3 at each end. The error of such an interpolant is
 * A^(6)(xi) t^3 (1 - t)^3 / 6! per component, with a Peano kernel of one sign, so for the
 * vector |f(t) - A(t)| <= max |A^(6)| / 6! / 64. The helix's axial part is linear in t and
 * reproduced exactly; its circular part has |A^(6)| = r sigma^6 (sigma the piece's sweep).
 * Hence dev <= r sigma^6 / 46080, no samples and no table needed; the same end data also
 * give end speeds equal to the arc's length, which is the quintic's to O(sigma^6).
 * The last piece ends on pr->end, which may lie off the circle by a gap g
 * (ef_prim_end_gap()): that moves b3, b4, b5 by the same vector, so the curve moves by at
 * most |g| (Bernstein weights sum to at most 1) and dev grows by |g|; a gap above
 * EF_BA_PIECE_GAP_REL of the piece takes the table route (ba_piece_table()). */
#define EF_BA_HERMITE_K (1.0f / 46080.0f)

int ef_blend_arc_piece(const ef_table_t *g2, ef_vec3_t start, const ef_prim_t *pr, float s0,
                       float s1, ef_move_t *m)
{
    if (!m)
        return EF_ERR_ARG;
    ba_zero_move(m);
    if (!g2 || !pr || pr->kind != EF_PRIM_ARC)
        return EF_ERR_ARG;
    if (g2->kind != EF_TABLE_G2_QUINTIC)
        return EF_ERR_KIND;
    float len;
    int rc = ef_prim_check(start, pr, &len);
    if (rc != EF_OK)
        return rc;
    if (!(s0 >= 0.0f) || !(s1 > s0) || !(s1 <= len))
        return EF_ERR_ARG;
    float asw = ef_fabsf(pr->sweep);
    float piece = asw * ((s1 - s0) / len);
    if (!(piece <= EF_ARC_PIECE_SWEEP * (1.0f + 1e-5f)))
        return EF_ERR_ARG;

    ef_frame_t f0, f1;
    ef_prim_frame(start, pr, s0, &f0);
    ef_prim_frame(start, pr, s1, &f1);
    float x1 = s1 - s0;
    /* computed for every piece, so the count stays the same for the last one */
    float gap = ef_selectf(s1 >= len, ef_prim_end_gap(start, pr), 0.0f);
    if (!(gap <= EF_BA_PIECE_GAP_REL * x1))
        return ba_piece_table(g2, start, pr, len, s0, s1, &f0, &f1, gap, m);
    ef_vec3_t d2a = ef_v3_scale(f0.n, f0.kappa * x1 * x1);
    ef_vec3_t d2b = ef_v3_scale(f1.n, f1.kappa * x1 * x1);
    m->b[0] = f0.p;
    m->b[5] = f1.p;
    m->b[1] = ef_v3_axpy(f0.p, 0.2f * x1, f0.t);
    m->b[4] = ef_v3_axpy(f1.p, -0.2f * x1, f1.t);
    m->b[2] = ef_v3_axpy(ef_v3_sub(ef_v3_scale(m->b[1], 2.0f), f0.p), 0.05f, d2a);
    m->b[3] = ef_v3_axpy(ef_v3_sub(ef_v3_scale(m->b[4], 2.0f), f1.p), 0.05f, d2b);
    /* The bound, plus what float32 adds: ef_prim_frame()'s angle (EF_BA_ANGLE_ULP ulp of the
     * angle at s1, times the radius, as ba_piece()) and the control points' rounding at the
     * coordinates' magnitude. */
    float r = ba_radius(start, pr);
    float s2 = piece * piece, s6 = s2 * s2 * s2;
    float ang = r * asw * (s1 / len) * (EF_BA_ANGLE_ULP * 1.1920929e-7f);
    float scale = ef_maxf(ba_maxabs(f0.p), ba_maxabs(f1.p));
    return ba_piece_finish(pr, r * s6 * EF_BA_HERMITE_K + ang + EF_BA_ROUND_MARGIN * scale + gap,
                           m);
}

/* The hodograph of the G2 quintic between end frames (p0, t0, kappa0 n0) and (p1, t1,
 * kappa1 n1) with DOFs (x10, x20, x11, x21) (ef_seg.h's control points) is
 *
 *     f'(t) = B2 D + (x10 u0 + x20 w0 / 4) t0 + x10^2 w0 (kappa0 / 4) n0
 *                  + (x11 u1 + x21 w1 / 4) t1 + x11^2 w1 (kappa1 / 4) n1,
 *
 * D = 5 (p1 - p0), with the degree-4 Bernstein combinations u0 = B0 + B1 - 2 B2,
 * w0 = B1 - B2, u1 = B3 + B4 - 2 B2, w1 = B2 - B3: five fixed vectors per trial weighted by
 * scalars that depend only on t and the DOFs. ba_even() evaluates every candidate curve's
 * speed that way at fixed nodes, from these tables, with no control points built. Rows:
 * B2, u0, w0, u1, w1 at the 16 Gauss-Legendre nodes of ef_bezier_h4_length() (the pairs
 * 1/2 -+ offset; last column the weight) and at t = i / EF_SEG_SPEED_SAMPLES
 * (ef_seg_speed_stats()'s samples; EF_SEG_SPEED_SAMPLES must be 16). */
static const float ba_gl_basis[16][6] = {
    {3.682600273e-01f, -3.496051143e-01f, -7.120300264e-02f, -4.916950222e-01f, 1.653577987e-01f,
     9.472530523e-02f},
    {3.682600273e-01f, -4.916950222e-01f, -1.653577987e-01f, -3.496051143e-01f, 7.120300264e-02f,
     9.472530523e-02f},
    {3.178827972e-01f, -8.908715965e-02f, 6.018117391e-02f, -5.003268262e-01f, 1.990910577e-01f,
     9.130170752e-02f},
    {3.178827972e-01f, -5.003268262e-01f, -1.990910577e-01f, -8.908715965e-02f, -6.018117391e-02f,
     9.130170752e-02f},
    {2.341682424e-01f, 2.340713596e-01f, 1.857970654e-01f, -4.049125716e-01f, 1.761372419e-01f,
     8.457825970e-02f},
    {2.341682424e-01f, -4.049125716e-01f, -1.761372419e-01f, 2.340713596e-01f, -1.857970654e-01f,
     8.457825970e-02f},
    {1.433276364e-01f, 5.461162761e-01f, 2.612295691e-01f, -2.627544581e-01f, 1.207594106e-01f,
     7.479799441e-02f},
    {1.433276364e-01f, -2.627544581e-01f, -1.207594106e-01f, 5.461162761e-01f, -2.612295691e-01f,
     7.479799441e-02f},
    {6.913259958e-02f, 7.859566038e-01f, 2.616328877e-01f, -1.316196017e-01f, 6.271070651e-02f,
     6.231448563e-02f},
    {6.913259958e-02f, -1.316196017e-01f, -6.271070651e-02f, 7.859566038e-01f, -2.616328877e-01f,
     6.231448563e-02f},
    {2.356566626e-02f, 9.281511103e-01f, 1.945645498e-01f, -4.597944160e-02f, 2.243414922e-02f,
     4.757925584e-02f},
    {2.356566626e-02f, -4.597944160e-02f, -2.243414922e-02f, 9.281511103e-01f, -1.945645498e-01f,
     4.757925584e-02f},
    {4.356038577e-03f, 9.868485229e-01f, 9.753116433e-02f, -8.628715772e-03f, 4.273266991e-03f,
     3.112676197e-02f},
    {4.356038577e-03f, -8.628715772e-03f, -4.273266991e-03f, 9.868485229e-01f, -9.753116433e-02f,
     3.112676197e-02f},
    {1.667289496e-04f, 9.994992202e-01f, 2.069616341e-02f, -3.328649152e-04f, 1.661367543e-04f,
     1.357622971e-02f},
    {1.667289496e-04f, -3.328649152e-04f, -1.661367543e-04f, 9.994992202e-01f, -2.069616341e-02f,
     1.357622971e-02f},
};
_Static_assert(EF_SEG_SPEED_SAMPLES == 16, "ba_uni_basis holds ef_seg_speed_stats()'s 17 samples");
static const float ba_uni_basis[17][5] = {
    {0.000000000e+00f, 1.000000000e+00f, 0.000000000e+00f, 0.000000000e+00f, 0.000000000e+00f},
    {2.059936523e-02f, 9.372711182e-01f, 1.853942871e-01f, -4.026794434e-02f, 1.968383789e-02f},
    {7.177734375e-02f, 7.775878906e-01f, 2.631835938e-01f, -1.364746094e-01f, 6.494140625e-02f},
    {1.392517090e-01f, 5.595855713e-01f, 2.630310059e-01f, -2.558441162e-01f, 1.178283691e-01f},
    {2.109375000e-01f, 3.164062500e-01f, 2.109375000e-01f, -3.710937500e-01f, 1.640625000e-01f},
    {2.769470215e-01f, 7.569885254e-02f, 1.292419434e-01f, -4.604339600e-01f, 1.930236816e-01f},
    {3.295898438e-01f, -1.403808594e-01f, 3.662109375e-02f, -5.075683594e-01f, 1.977539062e-01f},
    {3.633728027e-01f, -3.151702881e-01f, -5.191040039e-02f, -5.016937256e-01f, 1.749572754e-01f},
    {3.750000000e-01f, -4.375000000e-01f, -1.250000000e-01f, -4.375000000e-01f, 1.250000000e-01f},
    {3.633728027e-01f, -5.016937256e-01f, -1.749572754e-01f, -3.151702881e-01f, 5.191040039e-02f},
    {3.295898438e-01f, -5.075683594e-01f, -1.977539062e-01f, -1.403808594e-01f, -3.662109375e-02f},
    {2.769470215e-01f, -4.604339600e-01f, -1.930236816e-01f, 7.569885254e-02f, -1.292419434e-01f},
    {2.109375000e-01f, -3.710937500e-01f, -1.640625000e-01f, 3.164062500e-01f, -2.109375000e-01f},
    {1.392517090e-01f, -2.558441162e-01f, -1.178283691e-01f, 5.595855713e-01f, -2.630310059e-01f},
    {7.177734375e-02f, -1.364746094e-01f, -6.494140625e-02f, 7.775878906e-01f, -2.631835938e-01f},
    {2.059936523e-02f, -4.026794434e-02f, -1.968383789e-02f, 9.372711182e-01f, -1.853942871e-01f},
    {0.000000000e+00f, 0.000000000e+00f, 0.000000000e+00f, 1.000000000e+00f, 0.000000000e+00f},
};

/* The five vectors of the hodograph (above) for a trial's end frames. */
static void ba_hodo_vectors(const ef_frame_t *f0, const ef_frame_t *f1, ef_vec3_t *v)
{
    v[0] = ef_v3_scale(ef_v3_sub(f1->p, f0->p), 5.0f);
    v[1] = f0->t;
    v[2] = ef_v3_scale(f0->n, 0.25f * f0->kappa);
    v[3] = f1->t;
    v[4] = ef_v3_scale(f1->n, 0.25f * f1->kappa);
}

/* f'(t) at a node r (a row of the tables above) for DOFs x = (x10, x20, x11, x21); with dd,
 * also d f'/d s where both end speeds move together (x10 = x11 = s). */
static ef_vec3_t ba_hodo_at(const ef_vec3_t *v, const float *r, const float *x, ef_vec3_t *dd)
{
    ef_vec3_t d = ef_v3_scale(v[0], r[0]);
    d = ef_v3_axpy(d, x[0] * r[1] + 0.25f * x[1] * r[2], v[1]);
    d = ef_v3_axpy(d, x[0] * x[0] * r[2], v[2]);
    d = ef_v3_axpy(d, x[2] * r[3] + 0.25f * x[3] * r[4], v[3]);
    d = ef_v3_axpy(d, x[2] * x[2] * r[4], v[4]);
    if (dd) {
        ef_vec3_t e = ef_v3_scale(v[1], r[1]);
        e = ef_v3_axpy(e, 2.0f * x[0] * r[2], v[2]);
        e = ef_v3_axpy(e, r[3], v[3]);
        *dd = ef_v3_axpy(e, 2.0f * x[2] * r[4], v[4]);
    }
    return d;
}

/* Arc length L of the curve with DOFs x (16-node Gauss-Legendre, ef_seg_length()'s rule);
 * with dl, also dL/ds for both end speeds moving together (integral of <f', df'/ds> / |f'|
 * at the same nodes). */
static float ba_len(const ef_vec3_t *v, const float *x, float *dl)
{
    float len = 0.0f, dlen = 0.0f;
    for (int i = 0; i < 16; i++) {
        ef_vec3_t dd;
        ef_vec3_t d = ba_hodo_at(v, ba_gl_basis[i], x, dl ? &dd : 0);
        float sp = ef_v3_norm(d);
        len += ba_gl_basis[i][5] * sp;
        if (dl)
            dlen += ba_gl_basis[i][5] * (ef_v3_dot(d, dd) / ef_maxf(sp, 1e-30f));
    }
    if (dl)
        *dl = dlen;
    return len;
}

/* ef_seg_speed_stats()'s evenness: the largest | |f'(t)| / len - 1 | at t = i / 16. */
static float ba_spread(const ef_vec3_t *v, const float *x, float len)
{
    float inv = 1.0f / ef_maxf(len, 1e-30f), m = 0.0f;
    for (int i = 0; i <= 16; i++)
        m = ef_maxf(m, ef_fabsf(ef_v3_norm(ba_hodo_at(v, ba_uni_basis[i], x, 0)) * inv - 1.0f));
    return m;
}

/* A candidate of ba_even(): both end speeds s = L (the curve's own length) with tangential
 * DOFs x20, x21, by EF_BA_NEWTON Newton steps on g(s) = L(s) - s from s0 (g' = L' - 1, near
 * -1: L moves little with s; a flat g' takes the fixed-point step instead). With both end
 * speeds s, f'(t) = a + s q + s^2 r at each node, so |f'|^2 is a quartic in s whose
 * coefficients (dot products of a, q, r) are computed once; each step is then a few
 * multiplies and a square root per node. x gets the DOFs, *len the curve's length at them;
 * returns its speed spread (ba_spread()). */
static float ba_even_ends(const ef_vec3_t *v, float s0, float x20, float x21, float *x, float *len)
{
    float c[16][5];
    for (int i = 0; i < 16; i++) {
        const float *r = ba_gl_basis[i];
        ef_vec3_t a = ef_v3_scale(v[0], r[0]);
        a = ef_v3_axpy(a, 0.25f * x20 * r[2], v[1]);
        a = ef_v3_axpy(a, 0.25f * x21 * r[4], v[3]);
        ef_vec3_t q = ef_v3_axpy(ef_v3_scale(v[1], r[1]), r[3], v[3]);
        ef_vec3_t rr = ef_v3_axpy(ef_v3_scale(v[2], r[2]), r[4], v[4]);
        c[i][0] = ef_v3_dot(a, a);
        c[i][1] = 2.0f * ef_v3_dot(a, q);
        c[i][2] = ef_v3_dot(q, q) + 2.0f * ef_v3_dot(a, rr);
        c[i][3] = 2.0f * ef_v3_dot(q, rr);
        c[i][4] = ef_v3_dot(rr, rr);
    }
    float s = s0;
    for (int it = 0; it <= EF_BA_NEWTON; it++) {
        float l = 0.0f, dl = 0.0f;
        for (int i = 0; i < 16; i++) {
            const float *k = c[i];
            float s2 = k[0] + s * (k[1] + s * (k[2] + s * (k[3] + s * k[4])));
            float ds2 = k[1] + s * (2.0f * k[2] + s * (3.0f * k[3] + s * 4.0f * k[4]));
            float sp = ef_sqrtf(ef_maxf(s2, 0.0f));
            l += ba_gl_basis[i][5] * sp;
            dl += ba_gl_basis[i][5] * (0.5f * ds2 / ef_maxf(sp, 1e-30f));
        }
        *len = l; /* the last pass only measures: L at the final s */
        float g = l - s, dg = dl - 1.0f;
        float sn = s - g / ef_selectf(dg < -0.1f, dg, -1.0f);
        int step = (it < EF_BA_NEWTON) & (sn > 0.0f);
        s = ef_selectf(step, sn, s);
    }
    x[0] = s;
    x[1] = x20;
    x[2] = s;
    x[3] = x21;
    return ba_spread(v, x, *len);
}

/* Control points of the G2 quintic with DOFs x between exact frames (ef_seg.h's formulas;
 * ef_seg_from_dofs()'s curve without its normalization). */
static void ba_build(const ef_frame_t *f0, const ef_frame_t *f1, const float *x, ef_vec3_t *b)
{
    ef_vec3_t d2a = ef_v3_axpy(ef_v3_scale(f0->t, x[1]), f0->kappa * x[0] * x[0], f0->n);
    ef_vec3_t d2b = ef_v3_axpy(ef_v3_scale(f1->t, x[3]), f1->kappa * x[2] * x[2], f1->n);
    b[0] = f0->p;
    b[5] = f1->p;
    b[1] = ef_v3_axpy(f0->p, 0.2f * x[0], f0->t);
    b[4] = ef_v3_axpy(f1->p, -0.2f * x[2], f1->t);
    b[2] = ef_v3_axpy(ef_v3_sub(ef_v3_scale(b[1], 2.0f), f0->p), 0.05f, d2a);
    b[3] = ef_v3_axpy(ef_v3_sub(ef_v3_scale(b[4], 2.0f), f1->p), 0.05f, d2b);
}

/* Largest | |f'| / len - 1 | at the two ends of the stored control points b. */
static float ba_end_err(const ef_vec3_t *b, float len)
{
    float inv = 5.0f / ef_maxf(len, 1e-30f);
    float e0 = ef_fabsf(ef_v3_norm(ef_v3_sub(b[1], b[0])) * inv - 1.0f);
    return ef_maxf(e0, ef_fabsf(ef_v3_norm(ef_v3_sub(b[5], b[4])) * inv - 1.0f));
}

/* ef_seg_g2_even()'s choice for a blend between exact frames, with its criteria (ef_seg.h:
 * the table's curve while its end speeds are within EF_SEG_END_SPEED_REL of its length, the
 * table's x2 with x1 = L, or the arc-length choice x1 = L, x2 = 0; the smallest spread of
 * |f'| / L over 17 equal steps wins) at a fraction of the cost: every speed from the
 * hodograph's five vectors (ba_hodo_at()), x1 = L by Newton steps with dL/dx from the same
 * nodes instead of five secant curves, control points built once, from the frames, for the
 * winner only. *uneven: the kept curve's end speed error relative to its length, from its
 * stored control points (ba_try() refuses it above EF_SEG_END_SPEED_REL). */
static void ba_even(const ef_frame_t *f0, const ef_frame_t *f1, ef_seg_t *seg, float *uneven)
{
    ef_vec3_t v[5];
    ba_hodo_vectors(f0, f1, v);
    float xt[4] = {seg->dof[0], seg->dof[1], seg->dof[2], seg->dof[3]};
    float l_t = ba_len(v, xt, 0);
    float d_t = ba_spread(v, xt, l_t);
    float end_t = ba_end_err(seg->b, l_t);
    float xa[4], xb[4], l_a, l_b; /* l_a, l_b: the candidates' lengths (unused here) */
    float d_a = ba_even_ends(v, l_t, xt[1], xt[3], xa, &l_a);
    float d_b = ba_even_ends(v, l_t, 0.0f, 0.0f, xb, &l_b);
    float d = ef_selectf(end_t <= EF_SEG_END_SPEED_REL, d_t, 3.4e38f);
    int pick = d_a < d ? 1 : 0;
    d = ef_minf(d, d_a);
    pick = d_b < d ? 2 : pick;
    const float *x = pick == 2 ? xb : xa;
    if (pick != 0) {
        ba_build(f0, f1, x, seg->b);
        for (int k = 0; k < 4; k++)
            seg->dof[k] = x[k];
    }
    /* The winner's end speeds against the length of the curve as stored, as
     * ef_seg_g2_even() measures them: on a tiny blend far from the origin the float32
     * control points move |f'(0)| and |f'(1)| by up to a few 1e-3 of L. */
    *uneven = ba_end_err(seg->b, ef_seg_length(seg->b, 0));
}

/* One trial blend for trims (li, lo): end frames, the quintic, its measured deviation. */
typedef struct {
    ef_seg_t seg;
    ef_vec3_t pa, pb;
    float li, lo, dev;
    int ok;
} ef_ba_trial_t;

/* Upper bounds of min(fa, fb) on each interval [i, i + 1] of n samples: each f by its linear
 * interpolant plus E = (largest |second difference| at the interval's two ends) / 8, the
 * interpolation error of a smooth function (second differences at the first and last sample
 * taken from their neighbours); the largest value of the smaller of the two bounds is at an
 * end or where they cross. */
static void ba_interval_bounds(const float *fa, const float *fb, int n, float *bnd)
{
    for (int i = 0; i + 1 < n; i++) {
        int k0 = i < 1 ? 1 : i, k1 = i + 1 > n - 2 ? n - 2 : i + 1;
        float ea = ef_maxf(ef_fabsf(fa[k0 - 1] - 2.0f * fa[k0] + fa[k0 + 1]),
                           ef_fabsf(fa[k1 - 1] - 2.0f * fa[k1] + fa[k1 + 1]));
        float eb = ef_maxf(ef_fabsf(fb[k0 - 1] - 2.0f * fb[k0] + fb[k0 + 1]),
                           ef_fabsf(fb[k1 - 1] - 2.0f * fb[k1] + fb[k1 + 1]));
        float a0 = fa[i] + 0.125f * ea, a1 = fa[i + 1] + 0.125f * ea;
        float b0 = fb[i] + 0.125f * eb, b1 = fb[i + 1] + 0.125f * eb;
        float m = ef_maxf(ef_minf(a0, b0), ef_minf(a1, b1));
        /* crossing of a0 + (a1 - a0) x and b0 + (b1 - b0) x, x in (0, 1) */
        float g0 = a0 - b0, g1 = a1 - b1;
        int cross = (g0 * g1) < 0.0f;
        float x = g0 / ef_selectf(cross, g0 - g1, 1.0f);
        bnd[i] = ef_maxf(m, ef_selectf(cross, a0 + (a1 - a0) * x, 0.0f));
    }
}

/* Distance from x to the quintic (samples cs[0..n-1] at i / (n - 1), hodographs h1, h2),
 * from above: the nearest sample, then one Newton step on |f(t) - x|^2 from it; the smaller
 * distance. */
static float ba_dist_curve(const ef_vec3_t *b, const ef_vec3_t *h1, const ef_vec3_t *h2,
                           const ef_vec3_t *cs, int n, ef_vec3_t x)
{
    int j = 0;
    float d2 = 3.4e38f;
    for (int i = 0; i < n; i++) {
        ef_vec3_t w = ef_v3_sub(cs[i], x);
        float e = ef_v3_dot(w, w);
        j = e < d2 ? i : j;
        d2 = ef_minf(d2, e);
    }
    float t = (float)j / (float)(n - 1);
    ef_vec3_t der1, der2;
    ba_d12(h1, h2, t, &der1, &der2);
    ef_vec3_t w = ef_v3_sub(cs[j], x);
    float g = ef_v3_dot(w, der1);
    float gg = ef_maxf(ef_v3_dot(der1, der1) + ef_v3_dot(w, der2), 1e-30f);
    float tn = ef_minf(ef_maxf(t - g / gg, 0.0f), 1.0f);
    return ef_minf(ef_v3_norm(ef_v3_sub(ba_q5(b, tn), x)), ef_sqrtf(d2));
}

/* Build one trial blend for trims (li, lo) and bound its two-way deviation. */
static void ba_try(const ef_table_t *g2, ef_vec3_t start_in, const ef_prim_t *in, float len_in,
                   const ef_prim_t *out, float len_out, float li, float lo, ef_ba_trial_t *tr)
{
    ef_vec3_t v = in->end;
    ef_frame_t ga, gb;
    ef_prim_frame(start_in, in, len_in - li, &ga);
    ef_prim_frame(v, out, lo, &gb);
    ef_endpoint_t e0 = ef_frame_endpoint(&ga), e1 = ef_frame_endpoint(&gb);
    int rc = ef_seg_g2_quintic(g2, &e0, &e1, &tr->seg);
    float uneven = 0.0f;
    if (rc == EF_OK)
        ba_even(&ga, &gb, &tr->seg, &uneven);
    tr->pa = ga.p;
    tr->pb = gb.p;
    tr->li = li;
    tr->lo = lo;
    ef_ba_piece_t pin, pout;
    ba_piece(start_in, in, len_in, len_in - li, len_in, &pin);
    ba_piece(v, out, len_out, 0.0f, lo, &pout);
    const ef_vec3_t *b = tr->seg.b;
    /* Deviation, blend to path: max_t min(f_in(t), f_out(t)), f the distances to the replaced
     * pieces (each an upper bound, see ba_dist_piece()); its top is usually a kink where
     * the two cross, not a sample. EF_BLEND_DEV_SAMPLES + 2 samples (ends included) and a
     * bound per interval (ba_interval_bounds()); then the interval with the largest bound
     * is sampled EF_BA_REFINE - 1 times more and its bound replaced by the finer one. */
    enum { NS = EF_BLEND_DEV_SAMPLES + 2 };
    float fa[NS], fb[NS], bnd[NS - 1];
    ef_vec3_t cs[NS];
    const float h = 1.0f / (float)(NS - 1);
    for (int i = 0; i < NS; i++) {
        cs[i] = ba_q5(b, (float)i * h);
        fa[i] = ba_dist_piece(cs[i], &pin);
        fb[i] = ba_dist_piece(cs[i], &pout);
    }
    ba_interval_bounds(fa, fb, NS, bnd);
    int jm = 0;
    for (int i = 1; i < NS - 1; i++)
        jm = bnd[i] > bnd[jm] ? i : jm;
    float ga_[EF_BA_REFINE + 1], gb_[EF_BA_REFINE + 1], gbnd[EF_BA_REFINE];
    ga_[0] = fa[jm];
    gb_[0] = fb[jm];
    ga_[EF_BA_REFINE] = fa[jm + 1];
    gb_[EF_BA_REFINE] = fb[jm + 1];
    for (int k = 1; k < EF_BA_REFINE; k++) {
        float t = ((float)jm + (float)k * (1.0f / (float)EF_BA_REFINE)) * h;
        ef_vec3_t pt = ba_q5(b, t);
        ga_[k] = ba_dist_piece(pt, &pin);
        gb_[k] = ba_dist_piece(pt, &pout);
    }
    ba_interval_bounds(ga_, gb_, EF_BA_REFINE + 1, gbnd);
    float fine = 0.0f;
    for (int k = 0; k < EF_BA_REFINE; k++)
        fine = ef_maxf(fine, gbnd[k]);
    bnd[jm] = fine;
    float dev = 0.0f;
    for (int i = 0; i < NS - 1; i++)
        dev = ef_maxf(dev, bnd[i]);
    /* The other way: the path's points must be within the tolerance of the blend too (a
     * lopsided hairpin blend could otherwise cut the tip short while staying close to one of
     * the two nearly parallel pieces). Checked for the vertex and EF_BA_PATH_PTS points of
     * each replaced piece, by ba_dist_curve() (an upper bound). */
    ef_vec3_t h1[5], h2[4];
    for (int i = 0; i < 5; i++)
        h1[i] = ef_v3_scale(ef_v3_sub(b[i + 1], b[i]), 5.0f);
    for (int i = 0; i < 4; i++)
        h2[i] = ef_v3_scale(ef_v3_sub(h1[i + 1], h1[i]), 4.0f);
    dev = ef_maxf(dev, ba_dist_curve(b, h1, h2, cs, NS, v));
    for (int k = 0; k < EF_BA_PATH_PTS; k++) {
        dev = ef_maxf(dev, ba_dist_curve(b, h1, h2, cs, NS, pin.q[k]) + pin.err);
        dev = ef_maxf(dev, ba_dist_curve(b, h1, h2, cs, NS, pout.q[k]) + pout.err);
    }
    tr->dev = dev * EF_BA_DEV_REL;
    /* A configuration whose tangent angles the table had to clamp (a lopsided hairpin: a
     * tangent beyond 90 degrees from the chord) gives a poor curve; such a trial does not
     * count. (A clamped curvature, a tight arc, is fine: the curve still meets the end data
     * exactly and its deviation is measured.) Nor does one whose end speeds ba_even()
     * could not bring within EF_SEG_END_SPEED_REL of its mean. */
    uint32_t bad = EF_LOOKUP_CLAMP_ALPHA | EF_LOOKUP_CLAMP_BETA;
    int even = uneven <= EF_SEG_END_SPEED_REL;
    tr->ok = (rc == EF_OK) & (tr->seg.degree == 5) & ba_finite(tr->dev) &
             ((tr->seg.clamp & bad) == 0u) & even;
}

/* G2 blend of a corner or tangent join with arc ends (contract in ef_blend.h). */
int ef_blend_prims(const ef_table_t *g2, ef_vec3_t start_in, const ef_prim_t *in, float len_in,
                   const ef_prim_t *out, float len_out, float tol, float max_in, float max_out,
                   ef_blend_t *res)
{
    if (!res)
        return EF_ERR_ARG;
    if (!g2 || !in || !out)
        return ba_fail_blend(res, EF_ERR_ARG);
    if (g2->kind != EF_TABLE_G2_QUINTIC)
        return ba_fail_blend(res, EF_ERR_KIND);
    int finite = ba_finite(len_in) & ba_finite(len_out) & ba_finite(tol) & ba_finite(max_in) &
                 ba_finite(max_out);
    if (!finite)
        return ba_fail_blend(res, EF_ERR_NONFINITE);
    float cl_in, cl_out;
    int rc = ef_prim_check(start_in, in, &cl_in);
    if (rc != EF_OK)
        return ba_fail_blend(res, rc);
    rc = ef_prim_check(in->end, out, &cl_out);
    if (rc != EF_OK)
        return ba_fail_blend(res, rc);
    /* The lengths must be the primitives' (ef_prim_check()'s, up to rounding). */
    int lens_in = ef_fabsf(len_in - cl_in) <= 1e-5f * cl_in;
    int lens_out = ef_fabsf(len_out - cl_out) <= 1e-5f * cl_out;
    int lens = lens_in & lens_out;
    int range = (tol > 0.0f) & (max_in > 0.0f) & (max_out > 0.0f) & (max_in <= len_in) &
                (max_out <= len_out);
    if (!(lens & range))
        return ba_fail_blend(res, EF_ERR_ARG);
    /* From here on the lengths as this code computes them, so s = len is exactly the end. */
    len_in = cl_in;
    len_out = cl_out;
    max_in = ef_minf(max_in, cl_in);
    max_out = ef_minf(max_out, cl_out);

    ef_vec3_t v = in->end;
    ef_frame_t fi, fo;
    ef_prim_frame(start_in, in, len_in, &fi);
    ef_prim_frame(v, out, 0.0f, &fo);
    if (in->kind == EF_PRIM_LINE && out->kind == EF_PRIM_LINE)
        return ef_blend_corner(g2, v, fi.t, fo.t, tol, max_in, max_out, res);

    /* The line–line blend with the vertex tangents: turn, outcome for reversals and straight
     * corners, gain g and the first trim estimate (no neighbour limit). */
    ef_blend_t ll;
    rc = ef_blend_corner(g2, v, fi.t, fo.t, tol, EF_MAX_COORD, EF_MAX_COORD, &ll);
    if (rc != EF_OK)
        return ba_fail_blend(res, rc);
    float theta = ll.turn;
    int straight = (ll.flags & EF_BLEND_STRAIGHT) != 0u;
    /* A tangent join: straight, but the curvature vectors differ (a line tangent to an arc,
     * arcs of different radii or turning ways): blended for G2 like a corner, or left
     * straight (G1, safe) when no blend fits; never a stop. Lines have kappa 0, n 0. */
    ef_vec3_t kjump = ef_v3_sub(ef_v3_scale(fi.n, fi.kappa), ef_v3_scale(fo.n, fo.kappa));
    float dk = ef_v3_norm(kjump);
    int jump_tol = dk * tol >= EF_BA_TANGENT_MIN;
    int jump_rel = dk > EF_BA_KAPPA_REL * ef_maxf(fi.kappa, fo.kappa);
    int tangent = straight & jump_tol & jump_rel;

    /* Arc sides are trimmed by at most EF_ARC_PIECE_SWEEP of their sweep, so the replaced
     * piece stays a gentle curve the table can follow. */
    float cap_in = max_in, cap_out = max_out;
    if (in->kind == EF_PRIM_ARC)
        cap_in = ef_minf(cap_in, len_in * (EF_ARC_PIECE_SWEEP / ef_fabsf(in->sweep)));
    if (out->kind == EF_PRIM_ARC)
        cap_out = ef_minf(cap_out, len_out * (EF_ARC_PIECE_SWEEP / ef_fabsf(out->sweep)));
    float r_in = ba_radius(start_in, in), r_out = ba_radius(v, out);
    float scale = ba_maxabs(v) + r_in + r_out;
    float tol_geo = tol - EF_BA_ROUND_MARGIN * scale;

    /* Trims as a scale lambda of the line–line trim, each side clamped by its own limit.
     * Fixed EF_BLEND_ITER steps: secant through the origin towards 0.99 (tol - q), kept
     * inside the bracket [feasible, infeasible] (geometric bisection when it leaves it);
     * the longest feasible trial is the result. A tangent join has no line–line trim (its
     * turn is ~0): it starts from sqrt(EF_BA_TANGENT_GAIN tol / dk), where the deviation
     * of a curvature jump's transition is about tol, and its secant takes the square root
     * (deviation ~ dk L^2, quadratic in lambda). */
    float l0 = ll.trim_in;
    int have_l0 = (ll.flags & (EF_BLEND_STRAIGHT | EF_BLEND_STOP)) == 0u;
    float l_tan = ef_sqrtf(EF_BA_TANGENT_GAIN * tol / ef_maxf(dk, 1e-30f));
    float l_none = ef_selectf(tangent, l_tan, ef_minf(cap_in, cap_out));
    l0 = have_l0 ? l0 : l_none; /* STOP from line–line: still try */
    l0 = ef_minf(ef_maxf(l0, 1e-30f), EF_MAX_COORD);
    float lam_cap = ef_maxf(cap_in, cap_out) / l0;
    float lam_sym = ef_minf(cap_in, cap_out) / l0; /* largest lambda with equal trims */
    float lam = ef_minf(1.0f, lam_cap), lo_ok = 0.0f, hi_bad = 3.4e38f;
    ef_ba_trial_t tr = {0}, best = {0};
    for (int it = 0; it < EF_BLEND_ITER; it++) {
        float li = ef_minf(lam * l0, cap_in), lo = ef_minf(lam * l0, cap_out);
        ba_try(g2, start_in, in, len_in, out, len_out, li, lo, &tr);
        int feasible = tr.ok & (tr.dev <= tol_geo);
        if (feasible && lam > lo_ok) {
            lo_ok = lam;
            best = tr;
        }
        if (!feasible)
            hi_bad = ef_minf(hi_bad, lam);
        float ratio = 0.99f * tol_geo / ef_maxf(tr.dev, 1e-30f);
        int grow_tan = tangent & (ratio > 1.0f);
        float next = lam * ef_selectf(grow_tan, ef_sqrtf(ratio), ratio);
        /* a failed trial: back towards symmetric trims (in the table's domain), or halve */
        float back = lam > lam_sym ? ef_maxf(lam_sym, 0.5f * lam) : 0.5f * lam;
        next = tr.ok ? next : back;
        next = ef_minf(next, lam_cap);
        int inside = (next > lo_ok) & (next < hi_bad);
        float mid = tr.ok ? 0.5f * ef_minf(hi_bad, lam) : back;
        mid = lo_ok > 0.0f ? ef_sqrtf(lo_ok * ef_minf(hi_bad, lam_cap)) : mid;
        lam = inside ? next : mid;
        lam = ef_maxf(lam, 1e-30f);
    }

    int blend = best.ok & ((straight ^ 1) | tangent) & (tol_geo > 0.0f);
    int stop = (straight ^ 1) & (blend ^ 1);
    if (!blend) {
        ef_blend_t zero = {0};
        *res = zero;
        res->p_in = v;
        res->p_out = v;
        res->gain = ll.gain;
        res->turn = theta;
        res->flags = (uint32_t)straight * EF_BLEND_STRAIGHT + (uint32_t)stop * EF_BLEND_STOP;
        return EF_OK;
    }
    res->seg = best.seg;
    res->p_in = best.pa;
    res->p_out = best.pb;
    res->trim_in = best.li;
    res->trim_out = best.lo;
    res->dev = best.dev;
    res->gain = ll.gain;
    res->turn = theta;
    /* A limit, not the tolerance, bounded a side: max_in / max_out or the arc cap. */
    int clamped = (best.li >= cap_in) | (best.lo >= cap_out);
    res->flags = (uint32_t)clamped * EF_BLEND_CLAMPED +
                 (uint32_t)((best.seg.flags & EF_SEG_CLAMPED) != 0u) * EF_BLEND_TBL_CLAMPED;
    return EF_OK;
}
