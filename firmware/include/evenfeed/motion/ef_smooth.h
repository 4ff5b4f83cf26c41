/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_smooth.h
 * @brief The streaming smoother: push path primitives, pull feed-planned moves.
 *
 * Fixed buffers only (sizes below); every call does a bounded amount of work and never
 * blocks, so it can run in a periodic task. Typical loop:
 *
 *     rc = ef_smooth_push(&s, &prim);
 *     while (rc == EF_ERR_FULL) {            // not taken yet: pull, then push it again
 *         while (ef_smooth_pull(&s, &m) == EF_OK) ef_interp_push(&ip, &m) ...;
 *         rc = ef_smooth_push(&s, &prim);
 *     }
 *     ...
 *     while (ef_smooth_finish(&s) == EF_ERR_FULL)   // end of program, or an event
 *         while (ef_smooth_pull(&s, &m) == EF_OK) ...;
 *     while (ef_smooth_pull(&s, &m) == EF_OK) ...;
 *
 * ## Work units
 * The geometry is done in units, each of bounded cost (docs: firmware/README.md, "Costs on a
 * Cortex-M4F"): ef_smooth_push(), ef_smooth_finish() and ef_smooth_work() each do at most
 * one, ef_smooth_pull() none (it only takes a final move out of the planner). A unit is the
 * first of these that can be done:
 * - the oldest staged move into the planner (ef_plan_push(): its backward pass);
 * - the next move of the oldest decided primitive onto the stage (a line, a kept section,
 *   a blend, one arc piece, or one trial piece while an arc body's piece count is sized);
 * - one phase of the decision of the oldest open vertex, in this order:
 *
 *   | phase        | does                                    | next                         |
 *   |--------------|-----------------------------------------|------------------------------|
 *   | VERTEX       | a stop wanted (finish, STOP_BEFORE,     | stop: CLOSE*; gate passed:   |
 *   |              | tol 0)? the smooth gate (rule 3)        | SMOOTH_ARC / SMOOTH; BLEND   |
 *   | SMOOTH_ARC   | section curve from the arc frame at a   | SMOOTH_ARC_M; none: SMOOTH   |
 *   |              | rest start to the gate's frame          |                              |
 *   | SMOOTH_ARC_M | that curve measured against the input   | fits: smooth vertex, closed; |
 *   |              |                                         | else SMOOTH                  |
 *   | SMOOTH       | section curve to the gate's frame       | SMOOTH_M; none: BLEND        |
 *   | SMOOTH_M     | measured                                | fits: smooth, closed; BLEND  |
 *   | BLEND        | ef_blend_prims_valid()                  | reversal, none: stop, CLOSE*;|
 *   |              |                                         | straight: CLOSE*; else PROBE |
 *   | PROBE        | the blend measured, range and speed     | stop or blend: CLOSE*        |
 *   | CLOSE_ARC    | closing section to the arc frame of a   | CLOSE_ARC_M; none: CLOSE     |
 *   |              | smooth start (end at an exact stop)     |                              |
 *   | CLOSE_ARC_M  | measured                                | fits: closed; else CLOSE     |
 *   | CLOSE        | closing section to the end as decided   | CLOSE_M; none: chord, closed |
 *   | CLOSE_M      | measured                                | fits or chord: closed        |
 *
 *   CLOSE* = CLOSE_ARC or CLOSE for a line with a smooth frame at either end and no section
 *   yet, otherwise closed at once. A vertex is decided once the primitive after it can no
 *   longer grow by decimation (one more primitive came, or a finish).
 *
 * ef_smooth_push() returns ::EF_ERR_FULL while the work behind it must go on first; each
 * such call has done a unit, or a pull has a move (ef_smooth_stats()::units counts units,
 * so a caller can tell progress from a stall). A caller waiting for input may call
 * ef_smooth_work() in its idle time, so the stage and planner fill ahead of the pulls.
 *
 * ## What happens at each vertex (docs/smoothing.md)
 * Vertex = where one primitive ends and the next begins. In this order:
 * 1. **Exact stop** when the next primitive has ::EF_PRIM_STOP_BEFORE or tol == 0, when the
 *    turn exceeds EF_BLEND_MAX_TURN (a reversal), when the blend that fits is below float32
 *    resolution, or (a slow corner, between two lines, unless keep_slow_blends) when the
 *    blend's speed limit (ef_plan_move_limits()) is so low that its length at that speed
 *    takes longer than the two ramps lose by going on to rest: the move ending there gets
 *    ::EF_MOVE_STOP_END.
 * 2. **Band decimation** (G64 Q; the host passes Q = P when the program gives none, as
 *    LinuxCNC does): consecutive lines, straight or gently curving, whose inner vertices all
 *    lie within the band min(qtol, ::EF_SMOOTH_BAND_SHARE x tol) of the chord from the
 *    run's first point to its last, running forward along that chord piece by piece (never
 *    a reversal), at the same feed, become one chord (at most ::EF_SMOOTH_MERGE_MAX inner
 *    vertices; qtol = 0 disables it). A run whose every inner vertex turns by 60 degrees or
 *    more is noise about a straight line (a zigzag of rounding or of a CAM post; a curving
 *    run never turns that much at a vertex): its band is min(qtol, tol), as LinuxCNC's Q.
 *    The dropped points are kept (ef_smooth_t::runs, until the chord's end vertex is
 *    decided) and every move built on the chord is measured against them, so the total
 *    deviation from every input point stays within tol: a line on the chord deviates by
 *    merge_dev, a blend at its ends gets tol - merge_dev, and a smooth section on it is
 *    measured against the input points themselves (the polyline through them, at equal
 *    distance along the chord).
 * 3. **Smooth vertex** (CAM micro-segments; the tolerance-gated rule): between two lines
 *    (decimated chords) whose input pieces are no longer than micro_len, turning by at most
 *    micro_turn, whose chord lengths differ by at most a factor ::EF_SMOOTH_LEN_RATIO, and
 *    where the circle through the vertex and its two neighbouring chord ends bulges from
 *    the longer chord by at most ::EF_SMOOTH_GATE_SHARE x tol (kappa L^2 / 8). The vertex is
 *    interpolated with that circle's tangent and curvature; the chord between two smooth
 *    vertices becomes a G2 quintic (or G1 cubic) segment through the table
 *    (::EF_MOVE_SMOOTH). The section ending at the vertex is built and measured when the
 *    vertex is decided: if it is not within tol of the input points the vertex is a corner
 *    instead (never an exact stop: noise in the points costs at most a blend). A section
 *    from or to an exact stop (speed 0, tangent free) continues the arc of its smooth end
 *    rather than turning into the chord's direction. Chords merged upstream (cfg.chord_shift:
 *    LinuxCNC's interpreter has dropped the points between them, within G64 Q) have their
 *    vertices on the curve and their middles up to Q inside it, so the circle through a
 *    vertex bulges from them by about Q, which may be all of tol: there the vertex moves
 *    towards the circle's centre by half the bulge (at most ::EF_SMOOTH_CHORD_SHIFT x tol) and
 *    the gate takes bulge - shift, so the section leaves chords and vertices by about half
 *    the bulge each instead of leaving the chords' middles by all of it.
 * 4. Otherwise a **corner**: a G2 blend within tol (ef_blend_prims()). Each primitive gives
 *    at most half its length to the blend at either end, so blends never overlap.
 * Arcs between vertices become equal G2 quintic pieces of at most ::EF_ARC_PIECE_SWEEP,
 * split further (doubling, at most ::EF_SMOOTH_ARC_SPLITS times) until a piece deviates from
 * the true arc by at most max(tol / 2, ::EF_SMOOTH_ARC_TOL_MIN). Equal pieces of one arc
 * have the same normalized configuration, so checking the first checks them all.
 *
 * ## Auxiliary axes (docs/axes.md)
 * With cfg.naux > 0 the primitives carry A B C U V W (ef_prim_t::aux). Each moves linearly
 * in its primitive's X Y Z arc length and every move carries it as a polynomial in the
 * move's own parameter (ef_move_t::ab), so it follows the tool tip's path parameter:
 * - lines and arc pieces: linear;
 * - a corner blend: the quintic that meets both neighbours' value, rate and zero second
 *   derivative by X Y Z arc length where the blend starts and ends (G2 on every axis); the
 *   blend's trims are capped per axis at aux_tol / (0.45 |dk|), dk the change of the axis's
 *   rate (units per unit of X Y Z length) at the vertex, so the axis deviates from its
 *   programmed value at the same share of the corner by at most aux_tol (a quintic over a
 *   kink of dk across trims d1 + d2 deviates by at most 0.192 dk (d1 + d2));
 * - a smooth section (G2 quintic sections only): the quintic from the value and rate where
 *   it starts to those where it ends, zero second derivative by arc length at both ends; at
 *   a smooth vertex both sections take the three-point rate (ra lb + rb la) / (la + lb), so
 *   the axis is G2 across it; a section whose axis leaves its programmed value (linear
 *   along the chord) by more than aux_tol does not fit (the vertex is a corner);
 * - an exact stop where an axis changes rate and aux_tol is 0 or the vertex is straight
 *   (no blend to carry it); no decimation across a primitive that moves an auxiliary axis;
 * - an auxiliary move (X Y Z still) is one degree-1 move between exact stops
 *   (::EF_MOVE_AUX_ONLY), its feed in the axes' units per second.
 * The planner limits each axis's speed, acceleration and jerk (ef_limits_t) from the
 * move's atabs, akabs and akjerk as it does X Y Z's.
 *
 * ## Errors
 * A primitive that fails validation is refused with its error (nothing of it is queued; the
 * path so far is unchanged); the caller reports it and normally calls ef_smooth_finish()
 * until EF_OK, which brings
 * everything accepted so far to an exact stop at the last accepted end. Nothing invalid is
 * ever emitted.
 */
#ifndef EF_SMOOTH_H
#define EF_SMOOTH_H

#include <stdint.h>
#include "evenfeed/blend/ef_blend.h"
#include "evenfeed/path/ef_path.h"
#include "evenfeed/motion/ef_plan.h"
#include "evenfeed/table/ef_table.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Primitives held by the geometry stage (pending vertex decisions). */
#ifndef EF_SMOOTH_PRIMS
#define EF_SMOOTH_PRIMS 8
#endif
/** Most inner vertices one decimated chord absorbs (rule 2); EF_SMOOTH_RUNS (3) runs are
 *  kept at 12 bytes a vertex (2.3 KB with the default). */
#ifndef EF_SMOOTH_MERGE_MAX
#define EF_SMOOTH_MERGE_MAX 64
#endif
/** Band of the decimation (rule 2) as a share of the path tolerance: the band is
 *  min(qtol, EF_SMOOTH_BAND_SHARE x tol), the rest of tol is left to the blends and smooth
 *  sections built on the decimated chords. */
#ifndef EF_SMOOTH_BAND_SHARE
#define EF_SMOOTH_BAND_SHARE 0.5f
#endif
/** Fewest input points (both chords' vertices) a smooth vertex's frame is fitted to
 *  (rule 3); with fewer it is the circle through the vertex and its neighbours. */
#ifndef EF_SMOOTH_FIT_MIN
#define EF_SMOOTH_FIT_MIN 9
#endif
/** Farthest a smooth vertex moves onto its fitted curve, as a share of tol (rule 3). */
#ifndef EF_SMOOTH_FIT_SHIFT
#define EF_SMOOTH_FIT_SHIFT 0.25f
#endif
/** Farthest a smooth vertex between chords merged upstream moves towards its circle's
 *  centre, as a share of tol (rule 3, cfg.chord_shift): with the gate's bulge - shift <= tol
 *  the vertices may then leave the path by half the tolerance, the chords' middles by all
 *  of it (both measured after). */
#ifndef EF_SMOOTH_CHORD_SHIFT
#define EF_SMOOTH_CHORD_SHIFT 0.5f
#endif
/** Smooth-vertex gate (rule 3): the circle through the vertex and its neighbours may bulge
 *  from the longer chord by at most this share of tol (the section is measured after). */
#ifndef EF_SMOOTH_GATE_SHARE
#define EF_SMOOTH_GATE_SHARE 1.0f
#endif
/** Smooth vertices need neighbouring chords whose lengths differ by at most this factor. */
#ifndef EF_SMOOTH_LEN_RATIO
#define EF_SMOOTH_LEN_RATIO 4.0f
#endif
/** Most doublings of an arc's piece count to meet the tolerance. */
#ifndef EF_SMOOTH_ARC_SPLITS
#define EF_SMOOTH_ARC_SPLITS 6
#endif
/** Deviation allowed to arc pieces where the tolerance is 0 (exact-stop mode), units. */
#ifndef EF_SMOOTH_ARC_TOL_MIN
#define EF_SMOOTH_ARC_TOL_MIN 1e-4f
#endif
/** Moves one pushed primitive may produce before the planner must take them (an arc is
 *  emitted piece by piece as the planner has room, so this bounds the staging buffer, not
 *  the arc). */
#ifndef EF_SMOOTH_STAGE
#define EF_SMOOTH_STAGE 8
#endif

/** Configuration. */
typedef struct {
    const ef_table_t *g2;     /**< G2 quintic table (required) */
    const ef_table_t *g1;     /**< G1 cubic table (required only when smooth_degree == 3) */
    ef_limits_t lim;          /**< motion limits for the planner */
    float micro_len;          /**< longest input line (before decimation) treated as a CAM
                                   micro-segment; 0 disables smooth sections */
    float micro_turn;         /**< largest turn (rad) at a smooth vertex, e.g. 0.35 (20 deg) */
    uint8_t smooth_degree;    /**< 5: G2 quintic smooth sections; 3: G1 cubic */
    uint8_t keep_slow_blends; /**< nonzero: blend every corner that fits, also where an exact
                                   stop is faster (rule 1; for tests of the blend geometry) */
    uint8_t chord_shift;      /**< nonzero: the chords come merged already (LinuxCNC's
                                   interpreter, G64 Q): a smooth vertex whose frame is not
                                   fitted to dropped points moves towards its circle's centre
                                   by half the circle's bulge from the longer chord (at most
                                   EF_SMOOTH_CHORD_SHIFT tol), rule 3 */
    uint8_t naux;             /**< auxiliary axes in use, 0..EF_AUX (A, then B, ...): the
                                   first naux of ef_prim_t::aux are read ("Auxiliary axes");
                                   0 reads none (an X Y Z machine) */
    float aux_tol[EF_AUX_N];  /**< per auxiliary axis in use, the largest deviation of a blend
                                   from the axis's programmed value at the same share of the
                                   corner, in the axis's units (degrees for A B C), >= 0;
                                   0: every vertex where the axis changes its rate is an
                                   exact stop */
} ef_smooth_cfg_t;

/** Counters, for summaries and tests. */
typedef struct {
    uint32_t prims;        /**< primitives accepted */
    uint32_t moves;        /**< moves emitted (pulled) */
    uint32_t blends;       /**< corners blended */
    uint32_t straight;     /**< vertices passed straight (turn below EF_BLEND_MIN_TURN) */
    uint32_t stops;        /**< exact stops (requested, reversal, too small, finish) */
    uint32_t reversals;    /**< of those, reversals */
    uint32_t slow_corners; /**< of those, corners where stopping is faster than the blend */
    uint32_t merged;       /**< vertices removed by band decimation (collinear collapse) */
    uint32_t smooth;       /**< smooth vertices */
    uint32_t arc_pieces;   /**< arc pieces emitted */
    uint32_t units;        /**< work units done (ef_smooth_work()) */
    uint32_t remnants;     /**< moves built shorter than EF_MIN_CHORD (what two blends leave of
                                a line, to rounding), not emitted: joined to the move before,
                                or, where that one has gone to the planner (it ended at a stop),
                                covered by the next move's start (the machine is at rest there,
                                within EF_MIN_CHORD of the remnant's end); remnants in a row
                                that leave it EF_MIN_CHORD or more from their end become a line
                                to it, ending at rest (counted in stops too); where only the
                                auxiliary axes are that far from theirs, a move of them alone
                                (counted in aux_moves too) */
    float dev_max;         /**< largest deviation of any emitted move from the programmed path */
    uint32_t aux_moves;    /**< auxiliary moves (X Y Z still) */
    uint32_t aux_stops;    /**< exact stops because an auxiliary axis changed its rate where
                                no blend could take it (aux_tol 0, or a straight vertex) */
    float aux_dev_max;     /**< largest deviation of a blend from an auxiliary axis's
                                programmed value, in that axis's units (ef_smooth_cfg_t) */
} ef_smooth_stats_t;

/** One held primitive with what the geometry stage has decided about it. */
typedef struct {
    ef_prim_t pr;
    ef_vec3_t start;                  /**< where it starts */
    float len;                        /**< its length */
    float trim_start;                 /**< length taken by the blend at its start */
    float trim_end;                   /**< length taken by the blend at its end */
    uint8_t end_kind;                 /**< how its end vertex was resolved (internal) */
    uint8_t fin_stop;                 /**< a finish came after it: its end is an exact stop */
    uint8_t closed;                   /**< end vertex decided and section built: emittable */
    uint8_t start_smooth, end_smooth; /**< smooth frame at start / end (a smooth vertex, or
                                           at an exact stop the arc of the other end's) */
    uint8_t start_stop;               /**< it starts at rest (an exact stop) */
    ef_frame_t fs, fe;                /**< smooth vertex frames at start / end */
    ef_blend_t blend;                 /**< blend at its end (when end_kind says so) */
    ef_vec3_t blend_in_end;           /**< where the blend at its start ended (its first point) */
    float blend_len;        /**< end blend's length (measured once, when the vertex is decided) */
    float blend_kmax;       /**< end blend's curvature bound (likewise) */
    ef_vec3_t blend_tabs;   /**< end blend's axis tangent bounds (likewise) */
    ef_vec3_t blend_kabs;   /**< end blend's axis curvature-vector bounds (likewise) */
    ef_vec3_t blend_kjerk;  /**< end blend's axis third-derivative bounds (likewise) */
    uint32_t nmerged;       /**< inner vertices merged into it (band decimation) */
    float merge_dev;        /**< largest distance of those vertices from it: the blends at
                                 its ends get only tol - merge_dev */
    float piece_max;        /**< longest input line merged into it (the micro_len test) */
    uint32_t id;            /**< sequence number: its run slot is id % EF_SMOOTH_RUNS */
    uint8_t sec;            /**< its smooth section: 0 none / not built yet, 1 fits, 2 does
                                 not (driven as its chord between exact stops) */
    float sec_dev;          /**< that section's measured deviation (when sec == 1) */
    ef_vec3_t sec_b[6];     /**< that section's control points (when sec == 1): emitted as
                                 built and measured, not built a second time */
    uint8_t sec_degree;     /**< its degree (5, or 3 for G1 cubic sections) */
    uint16_t sec_flags;     /**< its EF_MOVE_* flags (a clamped lookup) */
    float astart[EF_AUX_N]; /**< the auxiliary axes where it starts */
    uint8_t amove;          /**< an auxiliary axis moves along it */
    uint8_t aux_only;       /**< an auxiliary move: X Y Z still, len the axes' distance */
    ef_vec3_t zstart;       /**< where the primitive before it started (rule 3's fit takes
                                 it as one more point of the run, when zline) */
    uint8_t zline;          /**< the primitive before it is a line (not an auxiliary move)
                                 whose input pieces are micro-segments (micro_len) */
    float ar_s[EF_AUX_N];   /**< auxiliary axes' rates (units per unit of X Y Z length) at its
                                 start when that is a smooth vertex: the rates the sections
                                 on both sides share there */
    float ar_e[EF_AUX_N];   /**< likewise at its end */
    float sec_ab[EF_AUX_N][6]; /**< its section's auxiliary control values (when sec == 1) */
    float sec_atabs[EF_AUX_N]; /**< and their bounds (ef_move_measure_aux()) */
    float sec_akabs[EF_AUX_N];
    float sec_akjerk[EF_AUX_N];
    float sec_len;       /**< its measured length (ef_move_measure()) */
    float sec_kmax;      /**< its curvature bound (likewise) */
    ef_vec3_t sec_tabs;  /**< its axis tangent bounds (likewise) */
    ef_vec3_t sec_kabs;  /**< its axis curvature-vector bounds (likewise) */
    ef_vec3_t sec_kjerk; /**< its axis third-derivative bounds (likewise) */
} ef_smooth_prim_t;

/** Run slots: the vertices merged into a held line are needed until its end vertex is
 *  decided (the band test while it grows, then the measurement of its smooth section),
 *  which happens when the primitive after the next one arrives; so at most three held
 *  lines need theirs at once. Structural, not a tunable. */
#define EF_SMOOTH_RUNS 3

/** Smoother state (public for static allocation; treat as private). */
typedef struct {
    ef_smooth_cfg_t cfg;
    ef_plan_t plan;
    ef_smooth_prim_t pq[EF_SMOOTH_PRIMS]; /**< held primitives, oldest at ph */
    uint32_t ph, pn;
    uint32_t next_id; /**< id of the next held primitive */
    /** Vertices merged into the held lines whose end vertex is still open, in order. */
    ef_vec3_t runs[EF_SMOOTH_RUNS][EF_SMOOTH_MERGE_MAX];
    ef_vec3_t pos;            /**< end of the last accepted primitive */
    ef_vec3_t out_end;        /**< where the last emitted move ends (moves chain exactly) */
    float apos[EF_AUX_N];     /**< the auxiliary axes at the end of the last accepted one */
    float aout_end[EF_AUX_N]; /**< ... where the last emitted move ends */
    ef_move_t stage[EF_SMOOTH_STAGE];
    uint32_t sh, sn;     /**< staged moves waiting for planner room */
    uint32_t arc_next;   /**< arc emission cursor: next piece of the oldest primitive */
    uint32_t arc_n;      /**< pieces the oldest primitive's arc is split into */
    uint8_t arc_sized;   /**< arc_n is final (the sizing trials are done) */
    uint32_t arc_k;      /**< sizing: doublings tried so far */
    uint32_t arc_try;    /**< sizing: the piece count of the next trial */
    float arc_dev;       /**< sizing: the last trial's deviation */
    uint8_t job;         /**< phase of the oldest open vertex's decision ("Work units") */
    ef_frame_t jf;       /**< that decision's frame (the gate's, or an arc frame) */
    ef_frame_t jkeep;    /**< the start frame an arc frame trial replaced */
    float jar[EF_AUX_N]; /**< the auxiliary axes' rates at that vertex when smooth */
    ef_move_t jtrial;    /**< the curve between its two phases (or the blend probe) */
    int emitting;        /**< the oldest primitive is partly emitted */
    ef_smooth_stats_t st;
} ef_smooth_t;

/**
 * @brief Initialise at rest at `start`.
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL, missing table, smooth_degree not 3 or 5, micro_len < 0,
 *                          micro_turn outside [0, pi/2], naux above EF_AUX, an aux_tol < 0
 * @retval EF_ERR_KIND      a table of the wrong kind
 * @retval EF_ERR_NONFINITE start not finite / beyond EF_MAX_COORD, or a non-finite setting
 * @retval EF_ERR_FEED      as ef_limits_check(), or an auxiliary axis in use without a
 *                          speed and acceleration limit
 */
int ef_smooth_init(ef_smooth_t *s, const ef_smooth_cfg_t *cfg, ef_vec3_t start);

/**
 * @brief Where the auxiliary axes are (ef_smooth_init() puts them at 0), while nothing is
 * held, staged or planned (after init, or once a finish has been pulled empty).
 * @param aux cfg.naux positions (A B C U V W order; the rest are not read)
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL, or moves still in the smoother
 * @retval EF_ERR_NONFINITE a position not finite or beyond EF_MAX_COORD
 */
int ef_smooth_set_aux(ef_smooth_t *s, const float *aux);

/**
 * @brief Push the next primitive (it starts at the previous one's end), after one unit of
 * the work pending ("Work units").
 * @retval EF_OK        taken
 * @retval EF_ERR_FULL  not taken yet (buffers full, or decisions it waits for not done):
 *                      pull moves, then push the same primitive again
 * @retval EF_ERR_FEED, EF_ERR_NONFINITE  a staged move the planner refused (not expected:
 *                      every move is checked when built); nothing taken
 * @retval EF_ERR_ARG, EF_ERR_NONFINITE, EF_ERR_FEED, EF_ERR_DEGENERATE, EF_ERR_ARC
 *                      as ef_prim_check() (an auxiliary value in use not finite or beyond
 *                      EF_MAX_COORD: EF_ERR_NONFINITE; an auxiliary move: its flags and
 *                      feed checked as a line's): the primitive is refused, nothing of it
 *                      taken
 *                      (checked once there is room for it: a refusal may come after
 *                      EF_ERR_FULL; the unit done before it is the smoother's own work)
 */
int ef_smooth_push(ef_smooth_t *s, const ef_prim_t *pr);

/**
 * @brief Exact stop at the current end, then one unit of the work left: call it (pulling
 * in between) until it returns EF_OK; then everything pushed is pullable and ends at rest.
 * Pushing afterwards continues from rest (use it for events, and at program end).
 * @retval EF_OK        every pushed primitive is built into moves, all in the planner
 * @retval EF_ERR_FULL  work left: pull moves, then call it again
 * @retval EF_ERR_ARG   NULL
 * @retval EF_ERR_FEED, EF_ERR_NONFINITE  as ef_smooth_push()
 */
int ef_smooth_finish(ef_smooth_t *s);

/**
 * @brief One unit of pending work ("Work units"), for a caller's idle time: builds moves
 * ahead of the pulls while no input comes. Never needed for correctness (push and finish
 * do the same).
 * @retval EF_OK        a unit was done
 * @retval EF_ERR_AGAIN nothing to do without more input, a finish, or a pull
 * @retval EF_ERR_ARG   NULL
 * @retval EF_ERR_FEED, EF_ERR_NONFINITE  as ef_smooth_push()
 */
int ef_smooth_work(ef_smooth_t *s);

/**
 * @brief Pull the next planned move (no work unit: moves reach the planner through push,
 * finish and ef_smooth_work()).
 * @retval EF_OK        m filled
 * @retval EF_ERR_ARG   NULL pointer
 * @retval EF_ERR_AGAIN nothing final yet: push more, or finish
 */
int ef_smooth_pull(ef_smooth_t *s, ef_move_t *m);

/**
 * @brief ef_smooth_pull() that releases the planner's oldest move even while its window is
 * not full (ef_plan_pull_now()): for a caller about to run out of moves while its input
 * still comes in. What is still in the geometry stage is not released (a finish does that).
 * @retval EF_OK        m filled
 * @retval EF_ERR_ARG   NULL pointer
 * @retval EF_ERR_AGAIN the planner holds no move
 */
int ef_smooth_pull_now(ef_smooth_t *s, ef_move_t *m);

/** @brief Counters so far (zeroes for NULL). */
ef_smooth_stats_t ef_smooth_stats(const ef_smooth_t *s);

#ifdef __cplusplus
}
#endif

#endif /* EF_SMOOTH_H */
