/* SPDX-License-Identifier: Apache-2.0 */
/* Corners with arc/helix ends (ef_blend_prims()) and arc pieces as G2 quintics
 * (ef_blend_arc_piece()). Both build the quintic from exact end frames of the primitives
 * (ef_prim_frame()) and bound its deviation in closed form: a corner against the line–line
 * blend of its vertex tangents (ef_blend_prims()), a piece as the arc's Hermite
 * interpolant. Only an arc piece whose end lies off its circle takes the table's quintic
 * and measures it (ba_piece_table(): the distance from a point to an arc piece in closed
 * form, ba_dist_piece(), the quintic in Bernstein form, ba_q5()). See ef_blend.h. */
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
/* Newton steps on x1 = L in the first trial blend (from the table's x1 per unit chord) and in
 * each later one (from the previous trial's ratio x1 / chord) (ba_even_ends()). */
#ifndef EF_BA_NEWTON0
#define EF_BA_NEWTON0 2
#endif
#ifndef EF_BA_NEWTON
#define EF_BA_NEWTON 1
#endif
/* Tangent joins (turn below EF_BLEND_MIN_TURN, ef_blend_prims()): the curvature jump
 * dk = |kappa_in n_in - kappa_out n_out| is blended when dk tol >= EF_BLEND_MIN_TURN^2, i.e.
 * when a transition that deviates by tol (trims about sqrt(tol / dk), turning the tangent by
 * about sqrt(dk tol) across the jump) would turn it by at least what counts as a corner;
 * below that the jump is as negligible as a straight corner's kink. The jump must also
 * exceed EF_BA_KAPPA_REL of the larger curvature, well above float32's rounding of the
 * curvature vectors (an arc split into two at a vertex is no join to blend). */
#define EF_BA_TANGENT_MIN (EF_BLEND_MIN_TURN * EF_BLEND_MIN_TURN)
#define EF_BA_KAPPA_REL   1e-4f
/* Share of a trim limit above which a trial takes the limit itself (ba_corner_try()). */
#define EF_BA_CAP_SNAP 0.98f
/* First trim estimate for a tangent join: deviation ~ dk L^2 / EF_BA_TANGENT_GAIN. The
 * bound on tests/blend/test_prim.c's joins came out near dk L^2 / 53; 48 keeps the first
 * trial a little inside tol, so the second one, fitted through it, lands near 0.97 tol (with
 * 1 the first trial took 2 % of tol and the fit from there overshot, leaving the join at
 * 2 % of what it could have). */
#define EF_BA_TANGENT_GAIN 48.0f
/* A blend's end speeds |f'(0)|, |f'(1)| are set to its arc length L as ef_seg_g2_even()
 * sets a segment's (ba_even_ends()): a stepper that steps tau uniformly by the time law
 * (EF_STEP_UNIFORM, the drives' segment mode) moves at v |f'(tau)| / L, so at a junction
 * with a line (|f'| / L = 1) the feed would jump by v times the difference in one servo
 * period. The table's optimum for a lopsided
 * corner (one side trimmed far more than the other, or a tight arc on one side) was far
 * off: 0.4 and 0.9 were seen, and at 9 mm/s the jump was 1 mm/s in 1 ms, 1000 mm/s^2
 * (tests/fuzz, issue 18). A trial whose ends ba_even_ends() could not bring within
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

/* sin x for |x| <= pi/4 (fdlibm's float kernel, about 1 ulp). */
static float ba_sin(float x)
{
    float z = x * x;
    return x + x * z *
                   (-1.6666667163e-01f +
                    z * (8.3333337680e-03f + z * (-1.9841270114e-04f + z * 2.7183114939e-06f)));
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
 * that far beyond the true piece's ends); 0 for lines. */
typedef struct {
    ef_vec3_t p0, t, cm, ex, ey, a, pa, pb;
    float l, r, c, psi, err;
    int arc;
} ef_ba_piece_t;

/* Prepare the replaced piece [sa, sb] of a primitive for ba_dist_piece(). */
static void ba_piece(ef_vec3_t start, const ef_prim_t *pr, const ef_prim_geo_t *geo, float len,
                     float sa, float sb, ef_ba_piece_t *pc)
{
    ef_frame_t f;
    ef_prim_frame_geo(start, pr, geo, sa, &f);
    pc->p0 = f.p;
    pc->pa = f.p;
    pc->t = f.t;
    pc->l = sb - sa;
    pc->arc = pr->kind == EF_PRIM_ARC;
    if (!pc->arc) {
        pc->pb = ef_v3_axpy(f.p, pc->l, f.t);
        pc->cm = pc->ex = pc->ey = pc->a = f.p;
        pc->r = pc->c = pc->psi = pc->err = 0.0f;
        return;
    }
    ef_prim_frame_geo(start, pr, geo, sb, &f);
    pc->pb = f.p;
    ef_vec3_t a = geo->a;
    float r0 = geo->r0;
    ef_prim_frame_geo(start, pr, geo, 0.5f * (sa + sb), &f);
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
static int ba_piece_table(const ef_table_t *g2, ef_vec3_t start, const ef_prim_t *pr,
                          const ef_prim_geo_t *geo, float len, float s0, float s1,
                          const ef_frame_t *f0, const ef_frame_t *f1, float gap, ef_move_t *m)
{
    ef_endpoint_t e0 = ef_frame_endpoint(f0), e1 = ef_frame_endpoint(f1);
    ef_seg_t seg;
    int rc = ef_seg_g2_quintic(g2, &e0, &e1, &seg);
    if (rc != EF_OK)
        return rc;
    float ends = 0.0f;
    ef_seg_g2_even(&e0, &e1, &seg, 0, &ends);
    /* End data that admit no quintic with end speeds equal to its length (ef_seg_g2_even():
     * the fuzzer's piece of an arc of radius 1.7e-5 whose end lies far off the circle)
     * would step the feed at both junctions in segment mode: refused. */
    if (!(ends <= ef_seg_end_allow(f0->p, f1->p)))
        return EF_ERR_DOMAIN;
    float dev = 0.0f;
    ef_ba_piece_t pc;
    ba_piece(start, pr, geo, len, s0, s1, &pc);
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
    ef_prim_geo_t geo;
    int rc = ef_prim_check_geo(start, pr, &len, &geo);
    if (rc != EF_OK)
        return rc;
    if (!(s0 >= 0.0f) || !(s1 > s0) || !(s1 <= len))
        return EF_ERR_ARG;
    float asw = ef_fabsf(pr->sweep);
    float piece = asw * ((s1 - s0) / len);
    if (!(piece <= EF_ARC_PIECE_SWEEP * (1.0f + 1e-5f)))
        return EF_ERR_ARG;

    ef_frame_t f0, f1;
    ef_prim_frame_geo(start, pr, &geo, s0, &f0);
    ef_prim_frame_geo(start, pr, &geo, s1, &f1);
    float x1 = s1 - s0;
    /* computed for every piece, so the count stays the same for the last one */
    float gap = ef_selectf(s1 >= len, ef_prim_end_gap_geo(pr, &geo), 0.0f);
    if (!(gap <= EF_BA_PIECE_GAP_REL * x1))
        return ba_piece_table(g2, start, pr, &geo, len, s0, s1, &f0, &f1, gap, m);
    const float x[4] = {x1, 0.0f, x1, 0.0f};
    ba_build(&f0, &f1, x, m->b);
    /* The bound, plus what float32 adds: ef_prim_frame()'s angle (EF_BA_ANGLE_ULP ulp of the
     * angle at s1, times the radius, as ba_piece()) and the control points' rounding at the
     * coordinates' magnitude. */
    float r = geo.r0;
    float s2 = piece * piece, s6 = s2 * s2 * s2;
    float ang = r * asw * (s1 / len) * (EF_BA_ANGLE_ULP * 1.1920929e-7f);
    float scale = ef_maxf(ba_maxabs(f0.p), ba_maxabs(f1.p));
    return ba_piece_finish(pr, r * s6 * EF_BA_HERMITE_K + ang + EF_BA_ROUND_MARGIN * scale + gap,
                           m);
}

/* The five vectors of a trial's hodograph (ef_seg_even_speed()) from its end frames. */
static void ba_hodo_vectors(const ef_frame_t *f0, const ef_frame_t *f1, ef_vec3_t *v)
{
    v[0] = ef_v3_scale(ef_v3_sub(f1->p, f0->p), 5.0f);
    v[1] = f0->t;
    v[2] = ef_v3_scale(f0->n, 0.25f * f0->kappa);
    v[3] = f1->t;
    v[4] = ef_v3_scale(f1->n, 0.25f * f1->kappa);
}

/* Both end speeds s = L (the curve's own length) with tangential DOFs x20, x21, by `steps`
 * Newton steps of ef_seg_even_speed() from s0. The first trial starts from the table's x1
 * per unit chord times its chord and takes EF_BA_NEWTON0 (2) steps (one step left 3 % more
 * of test_prim's corners uneven, a stop); later trials start from the previous trial's
 * ratio and take EF_BA_NEWTON (1). The winner's stored control points are measured once
 * more at the end (ef_seg_end_err()), so a step that fell short is a stop, never an uneven
 * blend. x gets the DOFs. */
static void ba_even_ends(const ef_vec3_t *v, float s0, float x20, float x21, int steps, float *x)
{
    float s = ef_seg_even_speed(v, s0, x20, x21, steps);
    x[0] = s;
    x[1] = x20;
    x[2] = s;
    x[3] = x21;
}

/* What every trial of one corner shares (ef_blend_prims()): the primitives, their geometry
 * (ef_prim_geo(): gi, go; radius r0, 0 for a line), the vertex v and
 * its frames fi, fo on the two primitives (unit tangents u_in = fi.t, u_out = fo.t),
 * 2 sin(phi) = |u_out - u_in|, the table's tangential DOF per unit trim x2u, the largest
 * curvature kap of the two primitives (constant along a line, arc or helix), eps_t the
 * float32 error of the frames' tangents (rad), m0 the part of the bound that does not
 * depend on the trim (control point rounding and the incoming arc's end gap); per side the
 * sweep per unit length w, the trim limit cap, and the float32 error of the
 * frames' points (ba_piece()'s err): in all on the incoming side (ang_in), per unit trim on
 * the outgoing one (ang_out). */
typedef struct {
    ef_vec3_t start_in, v;
    ef_frame_t fi, fo;
    ef_prim_geo_t gi, go;
    const ef_prim_t *in, *out;
    float len_in, len_out, two_sin, x2u, kap, eps_t, m0;
    float w_in, w_out, ang_in, ang_out, cap_in, cap_out;
} ef_ba_corner_t;

/* The two halves of the quintic b at t = 1/2 (de Casteljau): lh on [0, 1/2], rh on [1/2, 1],
 * each as a quintic in its own parameter. */
static ef_vec3_t ba_mid(ef_vec3_t a, ef_vec3_t b)
{
    return ef_v3_scale(ef_v3_add(a, b), 0.5f);
}

static void ba_halves(const ef_vec3_t *b, ef_vec3_t *lh, ef_vec3_t *rh)
{
    /* the triangle of midpoints, row by row (written out: the loops' copies cost more than
     * the 15 midpoints themselves) */
    ef_vec3_t a0 = ba_mid(b[0], b[1]), a1 = ba_mid(b[1], b[2]), a2 = ba_mid(b[2], b[3]);
    ef_vec3_t a3 = ba_mid(b[3], b[4]), a4 = ba_mid(b[4], b[5]);
    ef_vec3_t c0 = ba_mid(a0, a1), c1 = ba_mid(a1, a2), c2 = ba_mid(a2, a3), c3 = ba_mid(a3, a4);
    ef_vec3_t d0 = ba_mid(c0, c1), d1 = ba_mid(c1, c2), d2 = ba_mid(c2, c3);
    ef_vec3_t e0 = ba_mid(d0, d1), e1 = ba_mid(d1, d2);
    ef_vec3_t m = ba_mid(e0, e1);
    lh[0] = b[0];
    lh[1] = a0;
    lh[2] = c0;
    lh[3] = d0;
    lh[4] = e0;
    lh[5] = m;
    rh[0] = m;
    rh[1] = e1;
    rh[2] = d2;
    rh[3] = c3;
    rh[4] = a4;
    rh[5] = b[5];
}

/* The arc-length Hermite quintic of a primitive's piece of length l between its frames f0,
 * f1 (ef_blend_arc_piece()'s curve: x1 = l, x2 = 0); its largest difference from the
 * quintic q at equal parameters. q shares one end point with it exactly (the blend's own
 * end, b0 or b5), so only the five others, from `first` (1 or 0) on, are compared. */
static float ba_hermite_diff(const ef_frame_t *f0, const ef_frame_t *f1, float l,
                             const ef_vec3_t *q, int first)
{
    float x[4] = {l, 0.0f, l, 0.0f};
    ef_vec3_t h[6];
    ba_build(f0, f1, x, h);
    float d = 0.0f;
    for (int i = first; i < first + 5; i++)
        d = ef_maxf(d, ef_v3_norm(ef_v3_sub(q[i], h[i])));
    return d;
}

/* One trial blend for trim l on both sides: its curve, its end speed per unit chord (x), the
 * reference's deviation per unit trim (g), its deviation bound, and whether it is usable. */
typedef struct {
    ef_seg_t seg;
    float l, li, lo, x, g, dev;
    int ok;
} ef_ba_trial_t;

/* Build the trial blend for trim l, starting the evening from x1 = x chord, and bound its
 * deviation (the file's closed form, see ef_blend_prims()). */
static void ba_corner_try(const ef_ba_corner_t *k, float l, float x, int steps, ef_ba_trial_t *tr)
{
    /* A side whose own limit is within EF_BA_CAP_SNAP of l takes that limit: two blends that
     * each take half of a primitive then meet, instead of leaving between them a sliver of
     * half the difference of the neighbours' lengths (arcs equal but for rounding left
     * pieces of a few ulp, whose quintic's curvature is rounding noise). */
    float li = ef_selectf(l >= EF_BA_CAP_SNAP * k->cap_in, k->cap_in, l);
    float lo = ef_selectf(l >= EF_BA_CAP_SNAP * k->cap_out, k->cap_out, l);
    li = ef_maxf(li, l);
    lo = ef_maxf(lo, l);
    ef_frame_t ga, gb;
    ef_prim_frame_geo(k->start_in, k->in, &k->gi, k->len_in - li, &ga);
    ef_prim_frame_geo(k->v, k->out, &k->go, lo, &gb);
    ef_vec3_t hv[5];
    ba_hodo_vectors(&ga, &gb, hv);
    float x2l = k->x2u * l, xs[4];
    float chord = ef_v3_norm(ef_v3_sub(gb.p, ga.p));
    ba_even_ends(hv, x * chord, x2l, -x2l, steps, xs);
    ef_vec3_t *b = tr->seg.b;
    ba_build(&ga, &gb, xs, b);
    /* the line–line blend with the same DOFs on the tangent lines through v */
    float s = xs[0], a = 0.4f * s + 0.05f * x2l;
    ef_vec3_t ui = k->fi.t, uo = k->fo.t;
    ef_vec3_t pa = ef_v3_axpy(k->v, -l, ui), pb = ef_v3_axpy(k->v, l, uo);
    ef_vec3_t c[6] = {pa,
                      ef_v3_axpy(pa, 0.2f * s, ui),
                      ef_v3_axpy(pa, a, ui),
                      ef_v3_axpy(pb, -a, uo),
                      ef_v3_axpy(pb, -0.2f * s, uo),
                      pb};
    float db = 0.0f;
    for (int i = 0; i < 6; i++)
        db = ef_maxf(db, ef_v3_norm(ef_v3_sub(b[i], c[i])));
    float il = 1.0f / ef_maxf(l, 1e-30f);
    float g = ef_fabsf(16.0f - (s + 10.0f * a) * il) * k->two_sin * (1.0f / 32.0f);
    /* (symmetric trims only) */
    float dev_ll = ef_selectf(li == lo, g * l + db + 0.5f * k->kap * l * l, 3.4e38f);
    /* each half of the blend against its side's own Hermite quintic (to v) */
    ef_vec3_t lh[6], rh[6];
    ba_halves(b, lh, rh);
    float si = k->w_in * li, so = k->w_out * lo;
    float si2 = si * si, so2 = so * so;
    float h_in = k->gi.r0 * si2 * si2 * si2 * EF_BA_HERMITE_K;
    float h_out = k->go.r0 * so2 * so2 * so2 * EF_BA_HERMITE_K;
    float d_in = ba_hermite_diff(&ga, &k->fi, li, lh, 1) + h_in + k->ang_in;
    float d_out = ba_hermite_diff(&k->fo, &gb, lo, rh, 0) + h_out + k->ang_out * lo;
    float dev_split = ef_maxf(d_in, d_out);
    float dev = ef_minf(dev_ll, dev_split) + k->eps_t * ef_maxf(li, lo) + k->m0;
    tr->seg.degree = 5;
    tr->seg.ndof = 4;
    for (int i = 0; i < 4; i++)
        tr->seg.dof[i] = xs[i];
    tr->l = l;
    tr->li = li;
    tr->lo = lo;
    tr->x = s / ef_maxf(chord, 1e-30f);
    tr->g = g;
    tr->dev = dev;
    tr->ok = ba_finite(dev);
}

/* The checks both blend calls make first, in their order: NULL pointers, the table's kind,
 * finite numbers. */
static int ba_args(const ef_table_t *g2, const ef_prim_t *in, const ef_prim_t *out, float len_in,
                   float len_out, float tol, float max_in, float max_out)
{
    if (!g2 || !in || !out)
        return EF_ERR_ARG;
    if (g2->kind != EF_TABLE_G2_QUINTIC)
        return EF_ERR_KIND;
    int finite = ba_finite(len_in) & ba_finite(len_out) & ba_finite(tol) & ba_finite(max_in) &
                 ba_finite(max_out);
    return finite ? EF_OK : EF_ERR_NONFINITE;
}

/* tol > 0 and both trim limits in (0, their primitive's length]. */
static int ba_range(float tol, float max_in, float max_out, float len_in, float len_out)
{
    return (tol > 0.0f) & (max_in > 0.0f) & (max_out > 0.0f) & (max_in <= len_in) &
           (max_out <= len_out);
}

/* G2 blend of a corner or tangent join with arc ends (contract in ef_blend.h).
 *
 * The blend trims l on both sides (symmetric, as ef_blend_corner()) and is the G2 quintic
 * between the primitives' exact frames at arc length l before and after the vertex v, with
 * the line–line blend's DOFs for the vertex tangents (the table's optimum for (phi, -phi,
 * 0, 0)): x2 = +-x2u l, and both end speeds x1 set to the curve's own length
 * (ba_even_ends(); why: ef_seg_g2_even()). Its deviation is bounded in closed form, both
 * ways (blend to path and path to blend), by comparing three curves at equal parameters:
 *
 *   - r, the line–line blend with the same DOFs on the tangent lines through v (control
 *     points c_i: v - l u_in + (0, x1/5, a) u_in, v + l u_out - (a, x1/5, 0) u_out), whose
 *     deviation from the two line pieces is its midpoint's distance from v,
 *     l |16 - (x1 + 10 a) / l| 2 sin(phi) / 32 (docs/math.md, "Corner blends": symmetry,
 *     plus the numerical check that the midpoint is the nearest point to v);
 *   - |f(t) - r(t)| <= max_i |b_i - c_i|: the Bernstein weights are positive and sum to 1;
 *   - the primitive's piece against its tangent line piece, point for point at equal arc
 *     length s: |P(s) - v - s u| <= kap s^2 / 2 for a unit-speed curve of curvature at most
 *     kap (|t(u) - t(0)| <= kap u), plus s eps_t for the float32 vertex tangent, plus the
 *     incoming arc's end gap (ef_prim_end_gap(): the frames put its end on v, its model
 *     circle misses v by that much).
 *
 * Together with 4 eps of the coordinates for the control points' rounding,
 * dev = g l + max|b_i - c_i| + kap l^2 / 2 + eps_t l + m0, no samples. Most of it is
 * O(kap l^2) with small coefficients (the G2 end data follow the arc), so near the line–line
 * trim the bound is close to the true deviation (tests/blend/test_prim.c prints the ratio).
 * The trim: EF_BLEND_ITER trials (2: about 4.5 k M4 instructions each), each after the
 * first fitting dev ~ m0 + g l + A l^2 to the last one and solving it for 0.99 tol (a third
 * and later 0.97 tol); the longest feasible trial is kept. Three trials (the previous
 * default) blended 7 more of test_prim's 6000 random corners and left the arc–arc blends'
 * median deviation 3 % nearer tol. */
static int ba_prims(const ef_table_t *g2, ef_vec3_t start_in, const ef_prim_t *in, float len_in,
                    const ef_prim_t *out, float len_out, float tol, float max_in, float max_out,
                    ef_ba_corner_t *k, ef_blend_t *res);

int ef_blend_prims(const ef_table_t *g2, ef_vec3_t start_in, const ef_prim_t *in, float len_in,
                   const ef_prim_t *out, float len_out, float tol, float max_in, float max_out,
                   ef_blend_t *res)
{
    if (!res)
        return EF_ERR_ARG;
    int rc = ba_args(g2, in, out, len_in, len_out, tol, max_in, max_out);
    if (rc != EF_OK)
        return ba_fail_blend(res, rc);
    float cl_in, cl_out;
    ef_ba_corner_t k;
    /* the check computes each arc's geometry: kept for the frames (ef_prim_check_geo()) */
    rc = ef_prim_check_geo(start_in, in, &cl_in, &k.gi);
    if (rc != EF_OK)
        return ba_fail_blend(res, rc);
    rc = ef_prim_check_geo(in->end, out, &cl_out, &k.go);
    if (rc != EF_OK)
        return ba_fail_blend(res, rc);
    /* The lengths must be the primitives' (ef_prim_check()'s, up to rounding). */
    int lens_in = ef_fabsf(len_in - cl_in) <= 1e-5f * cl_in;
    int lens_out = ef_fabsf(len_out - cl_out) <= 1e-5f * cl_out;
    int lens = lens_in & lens_out;
    if (!(lens & ba_range(tol, max_in, max_out, len_in, len_out)))
        return ba_fail_blend(res, EF_ERR_ARG);
    /* From here on the lengths as this code computes them, so s = len is exactly the end.
     * ef_blend_prims_valid()'s own argument checks hold for these (finite, 0 < min(max, cl)
     * <= cl): not made again. */
    return ba_prims(g2, start_in, in, cl_in, out, cl_out, tol, ef_minf(max_in, cl_in),
                    ef_minf(max_out, cl_out), &k, res);
}

/* ef_blend_prims() for primitives the caller has checked (contract in ef_blend.h). */
int ef_blend_prims_valid(const ef_table_t *g2, ef_vec3_t start_in, const ef_prim_t *in,
                         float len_in, const ef_prim_t *out, float len_out, float tol, float max_in,
                         float max_out, ef_blend_t *res)
{
    if (!res)
        return EF_ERR_ARG;
    int rc = ba_args(g2, in, out, len_in, len_out, tol, max_in, max_out);
    if (rc != EF_OK)
        return ba_fail_blend(res, rc);
    if (!ba_range(tol, max_in, max_out, len_in, len_out))
        return ba_fail_blend(res, EF_ERR_ARG);
    ef_ba_corner_t k;
    ef_prim_geo(start_in, in, &k.gi);
    ef_prim_geo(in->end, out, &k.go);
    return ba_prims(g2, start_in, in, len_in, out, len_out, tol, max_in, max_out, &k, res);
}

/* The blend for checked arguments, the primitives' geometry in k->gi, k->go. */
static int ba_prims(const ef_table_t *g2, ef_vec3_t start_in, const ef_prim_t *in, float len_in,
                    const ef_prim_t *out, float len_out, float tol, float max_in, float max_out,
                    ef_ba_corner_t *k, ef_blend_t *res)
{
    int rc;
    ef_vec3_t v = in->end;
    ef_frame_t fi, fo;
    ef_prim_frame_end_geo(start_in, in, &k->gi, 1, &fi);
    ef_prim_frame_end_geo(v, out, &k->go, 0, &fo);
    if (in->kind == EF_PRIM_LINE && out->kind == EF_PRIM_LINE)
        return ef_blend_corner(g2, v, fi.t, fo.t, tol, max_in, max_out, res);

    /* The vertex turn and the line–line blend's DOFs (ef_blend_vertex(), as
     * ef_blend_corner()): the table at (phi, -phi, 0, 0), per unit chord; times the chord
     * per unit trim, 2 cos(phi), per unit trim. */
    ef_vec3_t ui = fi.t, uo = fo.t;
    ef_blend_vertex_t vx;
    rc = ef_blend_vertex(g2, ui, uo, &vx);
    if (rc != EF_OK)
        return ba_fail_blend(res, rc);
    float theta = vx.theta, two_cos = vx.two_cos, phi = vx.phi;
    uint32_t tclamp = vx.tclamp;
    int straight = theta < EF_BLEND_MIN_TURN;
    /* A tangent join: straight, but the curvature vectors differ (a line tangent to an arc,
     * arcs of different radii or turning ways): blended for G2 like a corner, or left
     * straight (G1, safe) when no blend fits; never a stop. Lines have kappa 0, n 0. */
    ef_vec3_t kjump = ef_v3_sub(ef_v3_scale(fi.n, fi.kappa), ef_v3_scale(fo.n, fo.kappa));
    float dk = ef_v3_norm(kjump);
    int jump_tol = dk * tol >= EF_BA_TANGENT_MIN;
    int jump_rel = dk > EF_BA_KAPPA_REL * ef_maxf(fi.kappa, fo.kappa);
    int tangent = straight & jump_tol & jump_rel;

    /* Arc sides are trimmed by at most EF_ARC_PIECE_SWEEP of their sweep, so the replaced
     * piece stays a gentle curve; both sides by the same l, within both limits. */
    float cap_in = max_in, cap_out = max_out;
    if (in->kind == EF_PRIM_ARC)
        cap_in = ef_minf(cap_in, len_in * (EF_ARC_PIECE_SWEEP / ef_fabsf(in->sweep)));
    if (out->kind == EF_PRIM_ARC)
        cap_out = ef_minf(cap_out, len_out * (EF_ARC_PIECE_SWEEP / ef_fabsf(out->sweep)));
    cap_in = ef_minf(cap_in, EF_MAX_COORD);
    cap_out = ef_minf(cap_out, EF_MAX_COORD);
    float cap = ef_minf(cap_in, cap_out);

    k->start_in = start_in;
    k->v = v;
    k->in = in;
    k->out = out;
    k->len_in = len_in;
    k->len_out = len_out;
    k->cap_in = cap_in;
    k->cap_out = cap_out;
    k->two_sin = vx.two_sin;
    k->x2u = vx.x2c * two_cos;
    /* kappa is constant along each primitive; 1e-5 for its float32 rounding */
    k->kap = ef_maxf(fi.kappa, fo.kappa) * (1.0f + 1e-5f);
    /* the frames' tangent angle: EF_BA_ANGLE_ULP ulp of the sweep, plus normalization */
    float sw_in = ef_selectf(in->kind == EF_PRIM_ARC, ef_fabsf(in->sweep), 0.0f);
    float sw_out = ef_selectf(out->kind == EF_PRIM_ARC, ef_fabsf(out->sweep), 0.0f);
    k->eps_t = (EF_BA_ANGLE_ULP * (sw_in + sw_out) + 4.0f) * 1.1920929e-7f;
    float r_in = k->gi.r0, r_out = k->go.r0;
    k->fi = fi;
    k->fo = fo;
    k->w_in = sw_in / len_in;
    k->w_out = sw_out / len_out;
    k->ang_in = r_in * sw_in * (EF_BA_ANGLE_ULP * 1.1920929e-7f);
    k->ang_out = r_out * k->w_out * (EF_BA_ANGLE_ULP * 1.1920929e-7f);
    float scale = ba_maxabs(v) + r_in + r_out;
    k->m0 = EF_BA_ROUND_MARGIN * scale + ef_prim_end_gap_geo(in, &k->gi);

    /* First trim: the line–line trim for the table's DOFs (its deviation per unit trim g0),
     * or for a tangent join sqrt(EF_BA_TANGENT_GAIN tol / dk), where a curvature jump's
     * transition deviates by about tol. */
    float xc = vx.x1c; /* x1 per unit chord: the evening's first guess */
    float x = xc * two_cos;
    float a0 = 0.4f * x + 0.05f * k->x2u;
    float g0 = ef_fabsf(16.0f - x - 10.0f * a0) * k->two_sin * (1.0f / 32.0f);
    float room = 0.99f * tol - k->m0;
    float l_tan = ef_sqrtf(EF_BA_TANGENT_GAIN * ef_maxf(room, 0.0f) / ef_maxf(dk, 1e-30f));
    float l_corner = ef_maxf(room, 0.0f) / ef_maxf(g0, 1e-30f);
    float l = ef_minf(ef_selectf(straight, l_tan, l_corner), cap);
    /* every trial kept, the winner picked by index: no copies of whole trials */
    ef_ba_trial_t trs[EF_BLEND_ITER];
    int bi = 0, have = 0;
    float best_l = 0.0f;
    for (int it = 0; it < EF_BLEND_ITER; it++) {
        l = ef_maxf(l, 1e-30f);
        ef_ba_trial_t *t = &trs[it];
        ba_corner_try(k, l, xc, it == 0 ? EF_BA_NEWTON0 : EF_BA_NEWTON, t);
        int feasible = t->ok & (t->dev <= tol);
        int better = feasible & (t->l > best_l);
        bi = better ? it : bi;
        best_l = ef_selectf(better, t->l, best_l);
        have |= better;
        /* dev ~ m0 + g l + A l^2 through this trial, solved for the next target; a trial that
         * failed shrinks by at least a tenth */
        float A = ef_maxf(t->dev - k->m0 - t->g * l, 0.0f) / ef_maxf(l * l, 1e-36f);
        float goal = ef_maxf((it == 0 ? 0.99f : 0.97f) * tol - k->m0, 0.0f);
        float next = 2.0f * goal / (t->g + ef_sqrtf(t->g * t->g + 4.0f * A * goal) + 1e-30f);
        next = ef_selectf(feasible, next, ef_minf(next, 0.9f * l));
        next = ef_selectf(next >= EF_BA_CAP_SNAP * cap, cap, next);
        l = ef_minf(next, cap);
        xc = ef_selectf(ba_finite(t->x) & (t->x > 0.0f), t->x, xc);
    }
    /* The winner's end speeds against the length of the curve as stored, as
     * ef_seg_g2_even() measures them: on a tiny blend far from the origin the float32
     * control points move |f'(0)| and |f'(1)| by up to a few 1e-3 of L. */
    const ef_ba_trial_t *best = &trs[bi];
    int even = ef_seg_end_err(best->seg.b) <= EF_SEG_END_SPEED_REL;
    /* As ef_blend_corner(): a chord float32 cannot resolve at the corner's coordinates is no
     * blend, whatever the rounding noise made its end speeds look like. */
    float bchord = ef_v3_norm(ef_v3_sub(best->seg.b[5], best->seg.b[0]));
    int resolved = (bchord >= EF_MIN_CHORD) & (bchord >= EF_MIN_CHORD_REL * ba_maxabs(v));
    int blend = have & even & resolved & ((straight ^ 1) | tangent);
    int stop = (straight ^ 1) & (blend ^ 1);
    if (!blend) {
        ef_blend_t zero = {0};
        *res = zero;
        res->p_in = v;
        res->p_out = v;
        res->gain = g0;
        res->turn = theta;
        res->flags = (uint32_t)straight * EF_BLEND_STRAIGHT + (uint32_t)stop * EF_BLEND_STOP;
        return EF_OK;
    }
    res->seg = best->seg;
    res->seg.flags = (uint32_t)(tclamp != 0u) * EF_SEG_CLAMPED;
    res->seg.clamp = tclamp;
    /* the configuration the DOFs were looked up for: the vertex tangents' corner */
    res->seg.norm.alpha = phi;
    res->seg.norm.beta = -phi;
    res->seg.norm.k0 = 0.0f;
    res->seg.norm.k1 = 0.0f;
    res->seg.norm.chord = bchord;
    res->seg.norm.e1 = ef_v3_scale(vx.sum, 1.0f / ef_maxf(two_cos, 1e-30f));
    res->seg.norm.t0 = ui;
    res->seg.norm.t1 = uo;
    res->p_in = best->seg.b[0];
    res->p_out = best->seg.b[5];
    res->trim_in = best->li;
    res->trim_out = best->lo;
    res->dev = best->dev;
    res->gain = best->g;
    res->turn = theta;
    /* A limit, not the tolerance, bounded the trim: max_in / max_out or the arc cap. */
    int clamped = best->l >= cap;
    res->flags =
        (uint32_t)clamped * EF_BLEND_CLAMPED + (uint32_t)(tclamp != 0u) * EF_BLEND_TBL_CLAMPED;
    return EF_OK;
}
