/* SPDX-License-Identifier: Apache-2.0 */
/* Entry point shared by the libFuzzer target and the plain-C corpus replay driver. */
#ifndef EF_FUZZ_TABLE_PARSE_H
#define EF_FUZZ_TABLE_PARSE_H

#include <stddef.h>
#include <stdint.h>

/** libFuzzer entry: parse one input as a table blob and exercise the resulting view.
 *  Aborts on any broken invariant; returns 0 otherwise. */
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#endif /* EF_FUZZ_TABLE_PARSE_H */
