/* SPDX-License-Identifier: Apache-2.0 */
/* File helpers shared by host/lib: capped whole-file reads and atomic writes. */
#include <errno.h>
#include <fcntl.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include "core/ef_file_int.h"

/* Whole-file read with a size cap checked before allocating. */
int ef_file_read(const char *path, size_t max, uint8_t **buf, size_t *len, ef_msg_t *m)
{
    *buf = NULL;
    *len = 0;
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        int err = errno;
        return ef_fail(m, EF_ERR_IO, "%s: cannot open: %s", path, strerror(err));
    }
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        (void)close(fd);
        return ef_fail(m, EF_ERR_IO, "%s: not a regular file", path);
    }
    if ((uint64_t)st.st_size > (uint64_t)max) {
        (void)close(fd);
        return ef_fail(m, EF_ERR_TBL_SIZE, "%s: %lld bytes, larger than any such file can be (%zu)",
                       path, (long long)st.st_size, max);
    }
    size_t size = (size_t)st.st_size, got = 0;
    uint8_t *p = malloc(size ? size : 1);
    if (!p) {
        (void)close(fd);
        return ef_fail(m, EF_ERR_NOMEM, "%s: out of memory for %zu bytes", path, size);
    }
    while (got < size) {
        ssize_t r = read(fd, p + got, size - got);
        if (r < 0 && errno == EINTR)
            continue;
        if (r < 0) {
            int err = errno;
            (void)close(fd);
            free(p);
            return ef_fail(m, EF_ERR_IO, "%s: read: %s", path, strerror(err));
        }
        if (r == 0)
            break; /* shrank since fstat: parse what is there, it will be reported short */
        got += (size_t)r;
    }
    (void)close(fd);
    *buf = p;
    *len = got;
    return EF_OK;
}

/* write(2) until done, retrying interrupted and short writes. */
static int fil_write_all(int fd, const uint8_t *p, size_t n)
{
    while (n > 0) {
        ssize_t w = write(fd, p, n);
        if (w < 0 && errno == EINTR)
            continue;
        if (w < 0)
            return -1;
        p += w;
        n -= (size_t)w;
    }
    return 0;
}

/* The directory part of path as a new string ("." when there is none). */
static char *fil_dir_of(const char *path)
{
    const char *slash = strrchr(path, '/');
    if (!slash)
        return strdup(".");
    if (slash == path)
        return strdup("/");
    return strndup(path, (size_t)(slash - path));
}

/* Directory fsync makes a rename or unlink durable; refusal by the file system only
 * weakens durability, never atomicity, so it is not an error. */
void ef_file_sync_dir(const char *path)
{
    char *dir = fil_dir_of(path);
    if (!dir)
        return;
    int fd = open(dir, O_RDONLY | O_CLOEXEC);
    if (fd >= 0) {
        (void)fsync(fd);
        (void)close(fd);
    }
    free(dir);
}

/* Temporary file beside path (same file system, so rename is atomic), flushed, renamed. */
int ef_file_write_atomic(const char *path, const uint8_t *buf, size_t len, ef_msg_t *m)
{
    static atomic_uint counter;
    const size_t tsize = strlen(path) + 48;
    char *tmp = malloc(tsize);
    int fd = -1, err, rc = EF_OK;
    if (!tmp)
        return ef_fail(m, EF_ERR_NOMEM, "%s: out of memory", path);
    for (int tries = 0; tries < 100 && fd < 0; tries++) {
        snprintf(tmp, tsize, "%s.tmp.%ld.%u", path, (long)getpid(), atomic_fetch_add(&counter, 1u));
        fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd < 0 && errno != EEXIST)
            break;
    }
    if (fd < 0) {
        err = errno;
        rc = ef_fail(m, EF_ERR_IO, "%s: cannot create temporary file %s: %s", path, tmp,
                     strerror(err));
    } else if (fil_write_all(fd, buf, len) != 0 || fsync(fd) != 0) {
        err = errno;
        (void)close(fd);
        (void)unlink(tmp);
        rc = ef_fail(m, EF_ERR_IO, "%s: write %s: %s", path, tmp, strerror(err));
    } else if (close(fd) != 0) {
        err = errno;
        (void)unlink(tmp);
        rc = ef_fail(m, EF_ERR_IO, "%s: close %s: %s", path, tmp, strerror(err));
    } else if (rename(tmp, path) != 0) {
        err = errno;
        (void)unlink(tmp);
        rc = ef_fail(m, EF_ERR_IO, "%s: rename from %s: %s", path, tmp, strerror(err));
    } else {
        ef_file_sync_dir(path);
    }
    free(tmp);
    return rc;
}

/* Checked up front so a long build cannot end in "cannot write the output". */
int ef_file_check_writable(const char *path, const char *what, ef_msg_t *m)
{
    struct stat st;
    if (!path || !*path)
        return ef_fail(m, EF_ERR_ARG, "%s: empty path", what);
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        return ef_fail(m, EF_ERR_IO, "%s %s: is a directory", what, path);
    char *dir = fil_dir_of(path);
    if (!dir)
        return ef_fail(m, EF_ERR_NOMEM, "%s: out of memory", path);
    int rc = EF_OK;
    if (access(dir, W_OK | X_OK) != 0) {
        int err = errno;
        rc = ef_fail(m, EF_ERR_IO, "%s %s: cannot write in directory %s: %s", what, path, dir,
                     strerror(err));
    }
    free(dir);
    return rc;
}
