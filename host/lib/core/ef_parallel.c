/* SPDX-License-Identifier: Apache-2.0 */
/* Thread fan-out shared by the CPU table builder and the accuracy harness. */
#include <pthread.h>
#include "core/ef_parallel_int.h"

#define EF_PARALLEL_MAX 64

/* Start, join, then report the first failed job so results do not depend on timing. */
int ef_parallel_run(void *jobs, size_t job_size, int n, void *(*fn)(void *), const char *what,
                    int *started, ef_msg_t *m)
{
    pthread_t tid[EF_PARALLEL_MAX];
    unsigned char *base = jobs;
    int count = 0, rc = EF_OK;
    if (n < 1 || n > EF_PARALLEL_MAX)
        rc = ef_fail(m, EF_ERR_ARG, "%s: thread count %d outside 1..%d", what, n, EF_PARALLEL_MAX);
    for (int i = 0; rc == EF_OK && i < n; i++) {
        ef_job_t *j = (ef_job_t *)(void *)(base + (size_t)i * job_size);
        j->rc = EF_OK;
        if (pthread_create(&tid[i], NULL, fn, j) != 0) {
            rc = ef_fail(m, EF_ERR_NOMEM, "%s: cannot start thread %d", what, i);
            break;
        }
        count++;
    }
    for (int i = 0; i < count; i++)
        pthread_join(tid[i], NULL);
    for (int i = 0; i < count && rc == EF_OK; i++) {
        const ef_job_t *j = (const ef_job_t *)(const void *)(base + (size_t)i * job_size);
        if (j->rc != EF_OK) {
            rc = j->rc;
            if (m)
                *m = j->msg;
        }
    }
    if (started)
        *started = count;
    return rc;
}
