/*
 * Plain-C driver for the fuzz target: runs every file named on the command line (or found
 * in a named directory) through LLVMFuzzerTestOneInput, so the seed corpus and saved
 * reproducers run as an ordinary test under gcc and the sanitizer build, no libFuzzer
 * needed. Seeds named "ok-*" must parse and "bad-*" must be rejected.
 *
 * Usage: tfile_fuzz_replay DIR|FILE...
 */
#ifndef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 200809L
#endif

#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "evenfeed/ef_err.h"
#include "evenfeed/ef_table.h"
#include "fuzz_table_parse.h"

/* Inputs larger than this are not tables (the parser's own cap is 64 MiB). */
#define REPLAY_MAX_FILE ((size_t)80 << 20)

static int n_run, n_failed;

/* Whole file into memory; NULL (and a message) on failure. */
static uint8_t *read_file(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    uint8_t *buf = NULL;
    long size;

    if (f == NULL || fseek(f, 0, SEEK_END) != 0 || (size = ftell(f)) < 0 ||
        (size_t)size > REPLAY_MAX_FILE || fseek(f, 0, SEEK_SET) != 0) {
        fprintf(stderr, "%s: cannot read\n", path);
        if (f) {
            fclose(f);
        }
        return NULL;
    }
    buf = malloc((size_t)size + 1u);
    if (buf == NULL || fread(buf, 1, (size_t)size, f) != (size_t)size) {
        fprintf(stderr, "%s: cannot read\n", path);
        free(buf);
        fclose(f);
        return NULL;
    }
    fclose(f);
    *len = (size_t)size;
    return buf;
}

/* Run one file; the name prefix states what the parser must say about it. */
static void replay_file(const char *path)
{
    const char *base = strrchr(path, '/');
    size_t len = 0;
    uint8_t *buf = read_file(path, &len);
    ef_table_t v;
    uint32_t off = 0;
    int rc;

    base = base ? base + 1 : path;
    if (buf == NULL) {
        n_failed++;
        return;
    }
    LLVMFuzzerTestOneInput(buf, len); /* aborts on a broken invariant */
    n_run++;
    rc = ef_table_parse(buf, (uint32_t)len, &v, &off); /* malloc'd, hence aligned */
    if (strncmp(base, "ok-", 3) == 0 && rc != EF_OK) {
        fprintf(stderr, "%s: expected valid, got %s at offset %u\n", path, ef_err_str(rc),
                (unsigned)off);
        n_failed++;
    } else if (strncmp(base, "bad-", 4) == 0 && rc == EF_OK) {
        fprintf(stderr, "%s: expected rejection, parsed OK\n", path);
        n_failed++;
    }
    free(buf);
}

/* qsort comparator: replay in a stable order so failures reproduce identically. */
static int cmp_names(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* Every regular file in a directory, sorted by name. */
static void replay_dir(const char *dir)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    char **names = NULL;
    size_t n = 0, cap = 0, i;

    if (d == NULL) {
        fprintf(stderr, "%s: cannot open directory\n", dir);
        n_failed++;
        return;
    }
    while ((e = readdir(d)) != NULL) {
        char **grown;
        if (e->d_name[0] == '.') {
            continue;
        }
        if (n == cap) {
            cap = cap ? 2 * cap : 64;
            grown = realloc(names, cap * sizeof *names);
            if (grown == NULL) {
                break;
            }
            names = grown;
        }
        names[n] = malloc(strlen(dir) + strlen(e->d_name) + 2);
        if (names[n] == NULL) {
            break;
        }
        sprintf(names[n], "%s/%s", dir, e->d_name);
        n++;
    }
    closedir(d);
    if (n) {
        qsort(names, n, sizeof *names, cmp_names);
    }
    for (i = 0; i < n; i++) {
        struct stat st;
        if (stat(names[i], &st) == 0 && S_ISREG(st.st_mode)) {
            replay_file(names[i]);
        }
        free(names[i]);
    }
    free(names);
}

/* Replay every argument; fail on a broken expectation or when nothing ran. */
int main(int argc, char **argv)
{
    int i;

    if (argc < 2) {
        fprintf(stderr, "usage: %s DIR|FILE...\n", argv[0]);
        return 2;
    }
    for (i = 1; i < argc; i++) {
        struct stat st;
        if (stat(argv[i], &st) != 0) {
            fprintf(stderr, "%s: not found\n", argv[i]);
            n_failed++;
        } else if (S_ISDIR(st.st_mode)) {
            replay_dir(argv[i]);
        } else {
            replay_file(argv[i]);
        }
    }
    printf("replayed %d inputs, %d failed\n", n_run, n_failed);
    /* An empty corpus would make this test pass vacuously. */
    return n_failed || n_run == 0 ? EXIT_FAILURE : EXIT_SUCCESS;
}
