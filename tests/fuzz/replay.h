/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Plain-C replay driver shared by the fuzz targets: runs every file named on the command
 * line (or found in a named directory, in name order) through a check, so seed corpora
 * and saved reproducers run as ordinary tests under gcc and the sanitizer build, without
 * libFuzzer. Files named "ok-*" must be accepted and "bad-*" (or "bad_*") rejected; others
 * only must not crash. A translation unit that defines EF_REPLAY_SUFFIX first replays only
 * the files of a directory whose names end in it. Include it from exactly one translation
 * unit and call ef_replay_main() from main().
 */
#ifndef EF_FUZZ_REPLAY_H
#define EF_FUZZ_REPLAY_H

#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* Larger inputs are no seed of ours (the table parser's own cap is 64 MiB). */
#define EF_REPLAY_MAX_FILE ((size_t)80 << 20)

/* Runs one input (aborting on a broken invariant); returns 0 when it was accepted,
 * otherwise nonzero with why[] saying how it was rejected. */
typedef int (*ef_replay_fn)(const uint8_t *buf, size_t len, char *why, size_t why_len);

static int ef_replay_run, ef_replay_failed;

/* Whole file into memory; NULL (and a message) on failure. */
static uint8_t *ef_replay_read(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    uint8_t *buf = NULL;
    long size;
    if (f == NULL || fseek(f, 0, SEEK_END) != 0 || (size = ftell(f)) < 0 ||
        (size_t)size > EF_REPLAY_MAX_FILE || fseek(f, 0, SEEK_SET) != 0) {
        fprintf(stderr, "%s: cannot read\n", path);
        if (f)
            fclose(f);
        return NULL;
    }
    buf = malloc((size_t)size + 1u); /* malloc'd, hence aligned for the table parser */
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

/* One file; its name prefix states the expected outcome. */
static void ef_replay_file(const char *path, ef_replay_fn fn)
{
    const char *base = strrchr(path, '/');
    size_t len = 0;
    uint8_t *buf = ef_replay_read(path, &len);
    char why[256] = "";
    base = base ? base + 1 : path;
    if (buf == NULL) {
        ef_replay_failed++;
        return;
    }
    int rejected = fn(buf, len, why, sizeof why);
    ef_replay_run++;
    if (strncmp(base, "ok-", 3) == 0 && rejected) {
        fprintf(stderr, "%s: expected acceptance, got: %s\n", path, why);
        ef_replay_failed++;
    } else if ((strncmp(base, "bad-", 4) == 0 || strncmp(base, "bad_", 4) == 0) && !rejected) {
        fprintf(stderr, "%s: expected rejection, accepted\n", path);
        ef_replay_failed++;
    }
    free(buf);
}

/* qsort comparator: a stable order, so failures reproduce identically. */
static int ef_replay_cmp(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* Every regular file in a directory, sorted by name; a directory that gives no input (empty,
 * or nothing in it readable) is a failure: a missing or emptied corpus must not pass. */
static void ef_replay_dir(const char *dir, ef_replay_fn fn)
{
    int run0 = ef_replay_run;
    DIR *d = opendir(dir);
    struct dirent *e;
    char **names = NULL;
    size_t n = 0, cap = 0;
    if (d == NULL) {
        fprintf(stderr, "%s: cannot open directory\n", dir);
        ef_replay_failed++;
        return;
    }
    while ((e = readdir(d)) != NULL) {
#ifdef EF_REPLAY_SUFFIX
        size_t nl = strlen(e->d_name), sl = strlen(EF_REPLAY_SUFFIX);
        if (nl < sl || strcmp(e->d_name + nl - sl, EF_REPLAY_SUFFIX) != 0)
            continue;
#endif
        if (e->d_name[0] == '.')
            continue;
        if (n == cap) {
            char **grown = realloc(names, (cap = cap ? 2 * cap : 64) * sizeof *names);
            if (grown == NULL)
                break;
            names = grown;
        }
        names[n] = malloc(strlen(dir) + strlen(e->d_name) + 2);
        if (names[n] == NULL)
            break;
        sprintf(names[n], "%s/%s", dir, e->d_name);
        n++;
    }
    closedir(d);
    if (n)
        qsort(names, n, sizeof *names, ef_replay_cmp);
    for (size_t i = 0; i < n; i++) {
        struct stat st;
        if (stat(names[i], &st) == 0 && S_ISREG(st.st_mode))
            ef_replay_file(names[i], fn);
        free(names[i]);
    }
    free(names);
    if (ef_replay_run == run0) {
        fprintf(stderr, "%s: no inputs replayed from this directory\n", dir);
        ef_replay_failed++;
    }
}

/* Replay every argument; fail on a broken expectation, on a directory that gave no input, or
 * when nothing ran at all (an empty corpus would pass vacuously). */
static int ef_replay_main(int argc, char **argv, ef_replay_fn fn)
{
    if (argc < 2) {
        fprintf(stderr, "usage: %s DIR|FILE...\n", argv[0]);
        return 2;
    }
    for (int i = 1; i < argc; i++) {
        struct stat st;
        if (stat(argv[i], &st) != 0) {
            fprintf(stderr, "%s: not found\n", argv[i]);
            ef_replay_failed++;
        } else if (S_ISDIR(st.st_mode)) {
            ef_replay_dir(argv[i], fn);
        } else {
            ef_replay_file(argv[i], fn);
        }
    }
    printf("replayed %d inputs, %d failed\n", ef_replay_run, ef_replay_failed);
    if (ef_replay_run == 0)
        fprintf(stderr, "no inputs replayed\n");
    return ef_replay_failed || ef_replay_run == 0 ? EXIT_FAILURE : EXIT_SUCCESS;
}

#endif /* EF_FUZZ_REPLAY_H */
