/* SPDX-License-Identifier: Apache-2.0 */
/* Private to host/lib: run workers on threads and report the first failure (ef_parallel.c). */
#ifndef EF_PARALLEL_INT_H
#define EF_PARALLEL_INT_H

#include <stddef.h>
#include "evenfeed/host/core/ef_host.h"

/* The first member of every job struct run by ef_parallel_run(): the worker's result. */
typedef struct {
    int rc;       /* EF_OK, or the worker's error */
    ef_msg_t msg; /* its message when rc != EF_OK */
} ef_job_t;

/* Start fn on each of n jobs (an array of structs of job_size bytes, each starting with an
 * ef_job_t), join them all, and return the first failure in job order (its message copied
 * to m), EF_ERR_NOMEM if a thread could not be started ("what" names the caller), or EF_OK.
 * *started receives how many ran (their jobs hold results even on failure). */
int ef_parallel_run(void *jobs, size_t job_size, int n, void *(*fn)(void *), const char *what,
                    int *started, ef_msg_t *m);

#endif /* EF_PARALLEL_INT_H */
