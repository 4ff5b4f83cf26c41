/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_config.h
 * @brief Compile-time limits and tolerances of the firmware. Every one may be overridden
 * with `-D` on the compiler command line; the defaults suit a Cortex-M4F class target.
 *
 * All storage in the firmware is static or on the caller's stack and sized by these
 * constants; nothing is allocated at run time.
 */
#ifndef EF_CONFIG_H
#define EF_CONFIG_H

/** Highest Bézier degree the evaluator, elevator and functional accept (stack arrays are
 *  sized `EF_BEZIER_MAX_DEGREE + 1` points). */
#ifndef EF_BEZIER_MAX_DEGREE
#define EF_BEZIER_MAX_DEGREE 7
#endif

/** Shortest chord (program units) of a segment; shorter is ::EF_ERR_DEGENERATE. */
#ifndef EF_MIN_CHORD
#define EF_MIN_CHORD 1e-6f
#endif

/** Chord must also be at least this fraction of the largest endpoint coordinate magnitude:
 *  below it float32 cannot resolve the segment's shape. */
#ifndef EF_MIN_CHORD_REL
#define EF_MIN_CHORD_REL 1e-5f
#endif

/** Largest coordinate magnitude accepted (program units). Beyond it float32 spacing exceeds
 *  about 0.1 unit and products overflow earlier than one would like. */
#ifndef EF_MAX_COORD
#define EF_MAX_COORD 1e6f
#endif

/** Allowed deviation of |t| and |n| from 1, and of <t,n> from 0. */
#ifndef EF_UNIT_TOL
#define EF_UNIT_TOL 1e-3f
#endif

/** Largest |curvature| x chord accepted as end data (beyond it the segment is a tight loop
 *  no table covers; it is an input error, not an out-of-domain lookup). */
#ifndef EF_MAX_NORM_CURVATURE
#define EF_MAX_NORM_CURVATURE 1e3f
#endif

/** Axes of a primitive, a move and a setpoint: X Y Z, then A B C U V W in that order
 *  (LinuxCNC's nine), 3 to 9; default 9, a 6-axis robot sets 6 (X Y Z A B C). The geometry
 *  (tables, blends, the tolerance P) acts on X Y Z, the tool tip; the others, the auxiliary
 *  axes, follow the same path parameter (docs/axes.md). Every per-axis array below is sized
 *  by it at compile time. */
#ifndef EF_AXES
#define EF_AXES 9
#endif
#if EF_AXES < 3 || EF_AXES > 9
#error "EF_AXES must be 3 to 9"
#endif
/** Auxiliary axes (A B C U V W, as many as EF_AXES has beyond X Y Z). */
#define EF_AUX (EF_AXES - 3)
/** Storage of a per-auxiliary-axis array: EF_AUX, at least 1 (C has no empty arrays; with
 *  EF_AXES 3 the one entry is unused and zero). */
#define EF_AUX_N (EF_AUX > 0 ? EF_AUX : 1)

/** Maximum number of table axes (G2 quintic uses 4). */
#define EF_TABLE_MAX_AXES 4
/** Maximum number of DOFs stored per table node (G2 quintic uses 4). */
#define EF_TABLE_MAX_DOF 4

/** Largest node count along one table axis. */
#ifndef EF_TABLE_MAX_AXIS_NODES
#define EF_TABLE_MAX_AXIS_NODES 4096u
#endif

/** Largest total node count of a table (bounds the blob size a loader accepts:
 *  4 Mi nodes x 4 DOFs x 4 bytes = 64 MiB). */
#ifndef EF_TABLE_MAX_NODES
#define EF_TABLE_MAX_NODES (1u << 22)
#endif

/** Largest provenance string in a table file, in bytes. */
#ifndef EF_TABLE_MAX_PROVENANCE
#define EF_TABLE_MAX_PROVENANCE 1024u
#endif

#endif /* EF_CONFIG_H */
