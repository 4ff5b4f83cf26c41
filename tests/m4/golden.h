/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file golden.h
 * @brief Golden cases of the firmware, one source (golden.c) compiled for the Cortex-M4F image
 * (m4_golden, golden_m4.c) and for the host (golden_host, golden_host.c). Each case prints
 * one line `case <name> n=<count> digest=<8 hex>`: the digest is FNV-1a over the exact bit
 * patterns of every float and integer output in a fixed order, so the two sides agree
 * line by line when they compute the same bits (tests/m4/golden_compare.sh).
 *
 * The sample programs' primitive streams are generated on the host at build time
 * (golden_gen.c, from the .ngc files of samples/ and a gen_cam program) into golden_progs.c, which
 * both sides compile in: the same records in, whatever the G-code reader does.
 */
#ifndef EF_GOLDEN_H
#define EF_GOLDEN_H

#include <stdint.h>
#include "evenfeed/path/ef_path.h"

#ifdef __cplusplus
extern "C" {
#endif

/** What a program record asks of the chain. */
enum {
    EF_GOLDEN_PUSH = 0,   /**< push pr to the smoother */
    EF_GOLDEN_FINISH = 1, /**< an event (tool change, dwell): finish and run to rest */
};

/** One record of a program's primitive stream. */
typedef struct {
    uint32_t op; /**< EF_GOLDEN_* */
    ef_prim_t pr;
} ef_golden_rec_t;

/** A program: its records, starting at rest at the origin. */
typedef struct {
    const char *name;
    const ef_golden_rec_t *rec;
    uint32_t n;
} ef_golden_prog_t;

/** The generated programs (golden_progs.c). */
extern const ef_golden_prog_t ef_golden_progs[];
extern const uint32_t ef_golden_nprogs;

/** Write a NUL-terminated string to the console (golden_m4.c: semihosting, golden_host.c:
 *  stdout). */
void ef_golden_puts(const char *s);

/** Run every case, printing one line each; 0 when every case ran. */
int ef_golden_run(void);

#ifdef __cplusplus
}
#endif

#endif /* EF_GOLDEN_H */
