/* SPDX-License-Identifier: Apache-2.0 */
/* Emit a table as C source for firmware without a file system. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "evenfeed/host/tables/ef_tfile.h"

/* Longest accepted name; keeps NAME_provenance and friends within any compiler's limits. */
#define EF_EMIT_MAX_NAME 200u
/* Floats per line and provenance characters per string-literal piece in the output. */
#define EF_EMIT_PER_LINE   4u
#define EF_EMIT_PROV_CHUNK 64u

static const char *const ef_emit_keywords[] = {
    "auto",       "break",     "case",           "char",
    "const",      "continue",  "default",        "do",
    "double",     "else",      "enum",           "extern",
    "float",      "for",       "goto",           "if",
    "inline",     "int",       "long",           "register",
    "restrict",   "return",    "short",          "signed",
    "sizeof",     "static",    "struct",         "switch",
    "typedef",    "union",     "unsigned",       "void",
    "volatile",   "while",     "_Alignas",       "_Alignof",
    "_Atomic",    "_Bool",     "_Complex",       "_Generic",
    "_Imaginary", "_Noreturn", "_Static_assert", "_Thread_local",
};

/* A name that is not an identifier would make the output fail to compile far from the
 * cause; reject it here instead. Locale-independent on purpose. */
static int emit_is_identifier(const char *s)
{
    size_t i, n = strlen(s);

    if (n == 0 || n > EF_EMIT_MAX_NAME) {
        return 0;
    }
    for (i = 0; i < n; i++) {
        const char c = s[i];
        const int alpha = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
        const int digit = c >= '0' && c <= '9';
        if (!alpha && !(digit && i > 0)) {
            return 0;
        }
    }
    for (i = 0; i < sizeof ef_emit_keywords / sizeof ef_emit_keywords[0]; i++) {
        if (strcmp(s, ef_emit_keywords[i]) == 0) {
            return 0;
        }
    }
    return 1;
}

/* %a prints the exact binary value; the float->double widening is exact, and the 'f'
 * suffix reads it back as the same float, so values survive bit for bit. */
static void emit_float(FILE *out, float v)
{
    fprintf(out, "%af", (double)v);
}

/* Escape what C would misread inside a string: quote, backslash, and '?' because "??x"
 * is a trigraph in ISO C (gcc -std=c11 honours them). Input is printable ASCII only. */
static void emit_string(FILE *out, const char *s, uint32_t n)
{
    uint32_t i;

    if (n == 0) {
        fputs(" \"\"", out);
        return;
    }
    for (i = 0; i < n; i++) {
        const char c = s[i];
        if (i % EF_EMIT_PROV_CHUNK == 0) {
            fputs(i ? "\"\n    \"" : "\n    \"", out);
        }
        if (c == '"' || c == '\\' || c == '?') {
            fputc('\\', out);
        }
        fputc(c, out);
    }
    fputc('"', out);
}

/* Names used in the header comment, so a reader knows what the table is without the file. */
static const char *emit_kind_name(unsigned kind)
{
    return kind == EF_TABLE_G1_CUBIC ? "G1 cubic" : "G2 quintic";
}

/* Symmetry name for the header comment. */
static const char *emit_sym_name(unsigned sym)
{
    return sym == EF_SYM_G1_FOLD     ? "G1 fold (u, v)"
           : sym == EF_SYM_G2_MIRROR ? "G2 mirror (alpha >= 0)"
                                     : "none";
}

/* The table is serialized and parsed first so only a table the firmware would accept as a
 * file is emitted, and the derived fields (inv_step, strides) are the parser's own. */
int ef_tfile_emit_c(const ef_tfile_t *t, const char *name, FILE *out, ef_msg_t *m)
{
    uint8_t *blob = NULL;
    size_t len = 0;
    ef_table_t v;
    uint32_t k, count, crc;
    unsigned i;
    int rc;

    if (t == NULL || name == NULL || out == NULL) {
        return ef_fail(m, EF_ERR_ARG, "ef_tfile_emit_c: NULL argument");
    }
    if (!emit_is_identifier(name)) {
        return ef_fail(m, EF_ERR_ARG, "ef_tfile_emit_c: '%.*s' is not a C identifier",
                       (int)EF_EMIT_MAX_NAME, name);
    }
    rc = ef_tfile_serialize(t, &blob, &len, m);
    if (rc != EF_OK) {
        return rc;
    }
    rc = ef_table_parse(blob, (uint32_t)len, &v, NULL);
    if (rc != EF_OK) { /* serialize has just parsed the same bytes */
        free(blob);
        return ef_fail(m, rc, "ef_tfile_emit_c: %s", ef_err_str(rc));
    }
    crc = ef_crc32(0, blob, (uint32_t)(len - 4u));
    count = v.nodes * v.ndof;

    fprintf(out,
            "/* SPDX-License-Identifier: Apache-2.0 */\n"
            "/*\n"
            " * GENERATED FILE - DO NOT EDIT.\n"
            " * Written by evenfeed %s (host/lib/tables/ef_tfile_emit.c) from a table file;\n"
            " * regenerate it from the .eft file instead of editing: hand edits bypass the\n"
            " * file's CRC and the parser's value checks.\n"
            " *\n"
            " * Table: %s, symmetry %s, %u nodes x %u DOFs; file CRC-32 %08lx.\n",
            "ef_tfile_emit_c()", emit_kind_name(v.kind), emit_sym_name(v.symmetry),
            (unsigned)v.nodes, (unsigned)v.ndof, (unsigned long)crc);
    for (i = 0; i < v.naxes; i++) {
        fprintf(out, " * Axis %u: [%.17g, %.17g], %u nodes%s.\n", i, t->lo[i], t->hi[i],
                (unsigned)v.axis[i].nodes,
                (v.axis[i].flags & EF_AXIS_PERIODIC) ? ", periodic" : "");
    }
    fprintf(out,
            " */\n"
            "#include \"evenfeed/table/ef_table.h\"\n"
            "\n"
            "extern const ef_table_t %s;\n"
            "\n"
            "static const float %s_data[%lu] = {",
            name, name, (unsigned long)count);
    for (k = 0; k < count; k++) {
        fputs(k % EF_EMIT_PER_LINE == 0 ? "\n    " : " ", out);
        emit_float(out, v.data[k]);
        fputc(',', out);
    }
    fprintf(out, "\n};\n\nstatic const char %s_provenance[] =", name);
    emit_string(out, v.provenance, v.provenance_len);
    fprintf(out,
            ";\n"
            "\n"
            "const ef_table_t %s = {\n"
            "    .kind = %uu,\n"
            "    .symmetry = %uu,\n"
            "    .naxes = %uu,\n"
            "    .ndof = %uu,\n"
            "    .quad_nodes = %uu,\n"
            "    .nodes = %luu,\n",
            name, (unsigned)v.kind, (unsigned)v.symmetry, (unsigned)v.naxes, (unsigned)v.ndof,
            (unsigned)v.quad_nodes, (unsigned long)v.nodes);
    fputs("    .x1_min = ", out);
    emit_float(out, v.x1_min);
    fputs(",\n    .x1_max = ", out);
    emit_float(out, v.x1_max);
    fputs(",\n    .x2_max = ", out);
    emit_float(out, v.x2_max);
    fputs(",\n    .axis = {\n", out);
    for (i = 0; i < v.naxes; i++) {
        const ef_table_axis_t *ax = &v.axis[i];
        fprintf(out, "        [%u] = {.lo = ", i);
        emit_float(out, ax->lo);
        fputs(", .hi = ", out);
        emit_float(out, ax->hi);
        fputs(", .inv_step = ", out);
        emit_float(out, ax->inv_step);
        fprintf(out, ",\n               .nodes = %luu, .stride = %luu, .flags = %luu},\n",
                (unsigned long)ax->nodes, (unsigned long)ax->stride, (unsigned long)ax->flags);
    }
    fprintf(out,
            "    },\n"
            "    .data = %s_data,\n"
            "    .provenance = %s_provenance,\n"
            "    .provenance_len = %luu,\n"
            "};\n",
            name, name, (unsigned long)v.provenance_len);
    free(blob);
    if (fflush(out) != 0 || ferror(out)) {
        return ef_fail(m, EF_ERR_IO, "ef_tfile_emit_c: writing the C source for '%s' failed", name);
    }
    return EF_OK;
}
