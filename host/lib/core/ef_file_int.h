/* SPDX-License-Identifier: Apache-2.0 */
/* Private to host/lib: capped whole-file reads and atomic writes (ef_file.c). */
#ifndef EF_FILE_INT_H
#define EF_FILE_INT_H

#include <stddef.h>
#include <stdint.h>
#include "evenfeed/host/core/ef_host.h"

/* Whole-file read, refusing files larger than max bytes (EF_ERR_TBL_SIZE). */
int ef_file_read(const char *path, size_t max, uint8_t **buf, size_t *len, ef_msg_t *m);
/* Write a file atomically: temporary file beside it, fsync, rename, directory sync. */
int ef_file_write_atomic(const char *path, const uint8_t *buf, size_t len, ef_msg_t *m);
/* fsync the directory holding path (best effort). */
void ef_file_sync_dir(const char *path);
/* EF_OK if a file can be created or replaced at path: its directory is writable and path is
 * not a directory. */
int ef_file_check_writable(const char *path, const char *what, ef_msg_t *m);

#endif /* EF_FILE_INT_H */
