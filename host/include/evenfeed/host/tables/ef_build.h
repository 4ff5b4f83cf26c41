/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_build.h
 * @brief Build a table's node values with an optimizer backend (CPU reference, or the
 * OpenGL compute builder in gpu_offline/).
 *
 * Work is cut into rows (the nodes along axis 0). A backend fills whole rows; a driver
 * (ef_build_run()) cuts the table, or one shard of it, into chunks of rows, so no single
 * call (one GPU dispatch) runs long enough to trip a watchdog, and records finished chunks
 * so an interrupted build resumes.
 */
#ifndef EF_BUILD_H
#define EF_BUILD_H

#include <stdint.h>
#include "evenfeed/host/tables/ef_ref.h"
#include "evenfeed/host/tables/ef_tfile.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Progress callback: nodes done so far of total, called from the driver's thread: once
 *  before any work (done = nodes resumed from a journal, 0 without one), then after each
 *  finished chunk. A rate should count only what was computed since the first call. */
typedef void (*ef_build_progress_fn)(void *ctx, uint32_t done, uint32_t total);

/** An optimizer backend, chosen at run time (ops struct, as libmodbus's backends). */
typedef struct {
    const char *name; /**< "cpu" or "gl" */
    /** Mandatory. Fill the values of rows [row_begin, row_end) of t with the optimum at each
     *  node's configuration (ef_build_node_config()), stored with ef_build_store(). Called
     *  from the driver's thread only; not interrupt context. Returns an ef_err code.
     *  A row's values must depend only on that row, never on row_begin, row_end or the
     *  other rows of the call: chunks, shards and resumed builds then give the same bytes.
     *  The driver fills the rows with NaN before the call, so a row left unwritten is
     *  caught, and checks every value (finite, within the bounds) after it. */
    int (*solve_rows)(void *ctx, ef_tfile_t *t, uint32_t row_begin, uint32_t row_end, ef_msg_t *m);
    /** Optional (may be NULL). Release ctx. */
    void (*close)(void *ctx);
    void *ctx;
    uint32_t chunk_nodes; /**< preferred nodes per chunk (the driver rounds down to whole
                               rows, at least one): short enough that one call (one GPU
                               dispatch) stays well under a watchdog's limit */
} ef_build_backend_t;

/**
 * @brief The configuration (alpha, beta, k0, k1) a node is optimized at: the node's own,
 * except that nodes on the edges of a G1 fold region are moved 1e-6 rad inside it, because
 * those edges are symmetry lines where two mirror-image optima tie and the lookup needs
 * the branch continuous with the inside.
 */
void ef_build_node_config(const ef_tfile_t *t, uint32_t node, double cfg[EF_TABLE_MAX_AXES]);

/** @brief Reference optimizer settings with the table's bounds (x1_min, x1_max, and x2_max
 *  for G2), the rest at their defaults; what both backends optimize under. */
void ef_build_ref_opts(const ef_tfile_t *t, ef_ref_opts_t *o);

/** @brief Store DOFs (per unit chord, double) at a node as float32, kept inside the
 *  table's bounds (float rounding could otherwise cross them). */
void ef_build_store(ef_tfile_t *t, uint32_t node, const double *dof);

/**
 * @brief The CPU reference backend: rows spread over threads, each row in order with a warm
 * start from its predecessor along axis 0, so results do not depend on the thread count.
 * @retval EF_OK
 * @retval EF_ERR_ARG  b NULL or threads outside 1..64
 */
int ef_build_backend_cpu(ef_build_backend_t *b, int threads);

/**
 * @brief Fill every node of t (created by ef_tfile_create()) with a backend, in one pass
 * (no shards, no journal, no output file): ef_build_run() with default options. Kept for
 * callers that need no resumability.
 * @retval EF_OK
 * @retval EF_ERR_ARG    NULL table or backend
 * @retval EF_ERR_NOCONV the optimizer failed at a node (message names the node and config)
 * @retval EF_ERR_TBL_VALUE the backend stored a non-finite or out-of-bounds value
 * @retval others        the backend's error (message says which)
 */
int ef_build_all(ef_tfile_t *t, ef_build_backend_t *b, ef_build_progress_fn progress, void *ctx,
                 ef_msg_t *m);

/** @brief ef_build_all() with the CPU backend (compatibility). */
int ef_build_cpu(ef_tfile_t *t, int threads, ef_build_progress_fn progress, void *ctx, ef_msg_t *m);

/* ---- Resumable, sharded builds ------------------------------------------------------- */

/** One shard of a build: shard `index` of `count`, both 1-based as the CLI writes them
 *  (`--shard 2/4`), so a batch scheduler's array index 1..count maps directly.
 *  count 0 (index 0) means the whole table. */
typedef struct {
    uint32_t index; /**< 1..count */
    uint32_t count; /**< 1..rows; 0 = not sharded */
} ef_build_shard_t;

/** Options of ef_build_check() and ef_build_run(); zero-initialized = the whole table, no
 *  journal, no output file, no progress. */
typedef struct {
    ef_build_shard_t shard;        /**< which rows to build; count 0 = all */
    const char *journal;           /**< journal of finished chunks (conventionally OUT.partial),
                                        or NULL for none (nothing survives a failure) */
    int fresh;                     /**< nonzero: discard an existing journal instead of resuming */
    const char *output;            /**< written atomically on success: a table file (.eft) for
                                        the whole table, a shard file (.efs) for a shard; NULL:
                                        the values stay in the table only */
    ef_build_progress_fn progress; /**< may be NULL */
    void *progress_ctx;
} ef_build_opts_t;

/** What ef_build_check() found. */
typedef struct {
    uint32_t rows;      /**< rows of the table (nodes / axis 0 nodes) */
    uint32_t row_begin; /**< the shard's rows: [row_begin, row_end) */
    uint32_t row_end;
    uint32_t n0;          /**< nodes per row */
    int journal_exists;   /**< a journal will be resumed */
    uint32_t rows_done;   /**< rows of the shard already finished in that journal */
    uint32_t chunks_done; /**< chunk records in that journal */
} ef_build_plan_t;

/**
 * @brief Parse a shard spec "I/N" (decimal, 1 <= I <= N, no sign, spaces or suffix).
 * Whether N fits the table is checked by ef_build_shard_rows().
 * @retval EF_OK
 * @retval EF_ERR_ARG  malformed, N = 0 or I outside 1..N (the message says which)
 */
int ef_build_shard_parse(const char *s, ef_build_shard_t *out, ef_msg_t *m);

/**
 * @brief The rows of a shard: rows are split into count contiguous blocks as evenly as
 * possible, shard i (1-based) getting [floor((i-1) rows / n), floor(i rows / n)), so block
 * sizes differ by at most one and every row is in exactly one shard.
 * @param s  NULL or count 0: the whole table
 * @retval EF_OK
 * @retval EF_ERR_ARG  index outside 1..count, or count > rows (a shard would be empty)
 */
int ef_build_shard_rows(const ef_tfile_t *t, const ef_build_shard_t *s, uint32_t *row_begin,
                        uint32_t *row_end, ef_msg_t *m);

/**
 * @brief Everything ef_build_run() would refuse, checked without a backend, so a bad
 * request fails before a GPU is touched: the shard fits the table, the output and journal
 * locations are writable (and distinct), and an existing journal (unless o->fresh) is intact
 * and belongs to this very build: same table spec, provenance, backend and shard. Reads the
 * journal; writes nothing.
 * @param backend the backend's name as ef_build_backend_t.name will give it ("cpu", "gl")
 * @param plan    out, may be NULL: the shard's rows and what the journal already holds
 * @retval EF_OK
 * @retval EF_ERR_ARG   NULL argument, bad shard, journal of a different build or equal to
 *                      the output path (message names the file and the fields that differ)
 * @retval EF_ERR_IO    a directory not writable, a path that is a directory, a read error
 * @retval EF_ERR_TBL_* the journal is corrupt (message names the file, the offset and says
 *                      how to start over: --fresh)
 */
int ef_build_check(const ef_tfile_t *t, const char *backend, const ef_build_opts_t *o,
                   ef_build_plan_t *plan, ef_msg_t *m);

/**
 * @brief Build the rows of a table or of one shard in chunks, resumably.
 *
 * The shard's rows are cut into chunks of whole rows (b->chunk_nodes, rounded down to
 * rows, at least one). With a journal, the finished rows it holds are loaded, not
 * recomputed; after each chunk its values are appended to the journal and fsync'ed, so a
 * crash or a backend failure loses at most the chunk in flight. On success the output (if
 * any) is written atomically, then the journal is deleted. On failure nothing is written
 * but the journal, and the message says how many chunks it holds and how to resume. The
 * backend is used, not closed. Results do not depend on chunk size, shard split, thread
 * count or on being resumed (see ef_build_backend_t.solve_rows).
 * @param t  created by ef_tfile_create(); values outside the shard are left alone
 * @retval EF_OK
 * @retval EF_ERR_ARG, EF_ERR_IO, EF_ERR_TBL_*  as ef_build_check(); also EF_ERR_IO when the
 *                       journal is in use by another build or cannot be written
 * @retval EF_ERR_TBL_VALUE the backend stored a non-finite or out-of-bounds value
 * @retval EF_ERR_NOMEM
 * @retval others        the backend's error
 */
int ef_build_run(ef_tfile_t *t, ef_build_backend_t *b, const ef_build_opts_t *o, ef_msg_t *m);

/**
 * @brief Write the rows of one shard of t as a shard file (atomically). ef_build_run()
 * does this for its output; exposed for tools and tests.
 * @param backend name recorded in the file; shards of different backends do not merge
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL argument, shard count 0 or not fitting the table
 * @retval EF_ERR_TBL_VALUE a value of the shard non-finite or out of bounds
 * @retval EF_ERR_IO, EF_ERR_NOMEM
 */
int ef_shard_write(const ef_tfile_t *t, const char *backend, const ef_build_shard_t *s,
                   const char *path, ef_msg_t *m);

/**
 * @brief Merge shard files into one table. All files must hold the same spec (kind,
 * symmetry, axes, bounds, quadrature, backend, provenance) and shard count N, and between
 * them each shard 1..N exactly once; the result is byte for byte the table an unsharded
 * build with the same options writes.
 * @param out created here (ef_tfile_free() it); zeroed on failure
 * @retval EF_OK
 * @retval EF_ERR_ARG   no files, a spec or shard count differing from the first file's
 *                      (fields named), a shard given twice, a shard missing (which ones)
 * @retval EF_ERR_IO    cannot read a file
 * @retval EF_ERR_TBL_MAGIC      not a shard file (says what it is when it knows: a table
 *                               file, a build journal)
 * @retval EF_ERR_TBL_VERSION, EF_ERR_TBL_TRUNCATED, EF_ERR_TBL_SIZE, EF_ERR_TBL_HEADER,
 *         EF_ERR_TBL_CRC, EF_ERR_TBL_VALUE  a damaged shard file (message names it)
 * @retval EF_ERR_NOMEM
 */
int ef_shard_merge(const char *const *paths, uint32_t npaths, ef_tfile_t *out, ef_msg_t *m);

#ifdef __cplusplus
}
#endif

#endif /* EF_BUILD_H */
