/* Representation spec strings: parsing, typed lookups and canonical formatting. */
#include "core/spec.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>

static bool is_name_char(char c) { return isalnum((unsigned char)c) || c == '-' || c == '_' || c == '.'; }

static prt_status copy_token(const char *b, const char *e, char *dst, size_t cap, const char *what, const char *text) {
    size_t n = (size_t)(e - b);
    if (n == 0) return prt__fail(PRT_ERROR_ARGUMENT, "spec '%s': empty %s", text, what);
    if (n >= cap) return prt__fail(PRT_ERROR_ARGUMENT, "spec '%s': %s too long", text, what);
    for (const char *p = b; p < e; p++)
        if (!is_name_char(*p))
            return prt__fail(PRT_ERROR_ARGUMENT, "spec '%s': bad character '%c' in %s", text, *p, what);
    memcpy(dst, b, n);
    dst[n] = 0;
    return PRT_OK;
}

prt_status prt__spec_parse(const char *text, prt_spec *out) {
    memset(out, 0, sizeof *out);
    if (!text || !*text) return prt__fail(PRT_ERROR_ARGUMENT, "empty representation spec");
    const char *p = text;
    const char *end = p + strcspn(p, ",");
    const char *colon = memchr(p, ':', (size_t)(end - p));
    prt_status st = copy_token(p, colon ? colon : end, out->structure, sizeof out->structure, "structure name", text);
    if (st) return st;
    if (colon && (st = copy_token(colon + 1, end, out->codec, sizeof out->codec, "codec name", text))) return st;
    p = end;
    while (*p == ',') {
        p++;
        end = p + strcspn(p, ",");
        const char *eq = memchr(p, '=', (size_t)(end - p));
        if (!eq) return prt__fail(PRT_ERROR_ARGUMENT, "spec '%s': option without '=' near '%s'", text, p);
        if (out->count == PRT_SPEC_MAX_KEYS) return prt__fail(PRT_ERROR_ARGUMENT, "spec '%s': too many options", text);
        int i = out->count++;
        if ((st = copy_token(p, eq, out->kv[i].key, sizeof out->kv[i].key, "option name", text)) ||
            (st = copy_token(eq + 1, end, out->kv[i].value, sizeof out->kv[i].value, "option value", text)))
            return st;
        for (int j = 0; j < i; j++)
            if (!strcmp(out->kv[j].key, out->kv[i].key))
                return prt__fail(PRT_ERROR_ARGUMENT, "spec '%s': option '%s' given twice", text, out->kv[i].key);
        p = end;
    }
    if (*p) return prt__fail(PRT_ERROR_ARGUMENT, "spec '%s': unexpected '%s'", text, p);
    return PRT_OK;
}

const char *prt__spec_get(prt_spec *s, const char *key) {
    for (int i = 0; i < s->count; i++)
        if (!strcmp(s->kv[i].key, key)) {
            s->kv[i].used = true;
            return s->kv[i].value;
        }
    return NULL;
}

prt_status prt__spec_int(prt_spec *s, const char *key, int def, int lo, int hi, int *out) {
    const char *v = prt__spec_get(s, key);
    if (!v) {
        *out = def;
        return PRT_OK;
    }
    char *e;
    long x = strtol(v, &e, 10);
    if (*e || e == v || x < lo || x > hi)
        return prt__fail(PRT_ERROR_ARGUMENT, "option %s=%s: expected an integer in [%d, %d]", key, v, lo, hi);
    *out = (int)x;
    return PRT_OK;
}

prt_status prt__spec_enum(prt_spec *s, const char *key, const char *const *names, int count, int def, int *out) {
    const char *v = prt__spec_get(s, key);
    if (!v) {
        *out = def;
        return PRT_OK;
    }
    for (int i = 0; i < count; i++)
        if (!strcmp(v, names[i])) {
            *out = i;
            return PRT_OK;
        }
    char list[256] = "";
    for (int i = 0; i < count; i++) {
        strncat(list, names[i], sizeof list - strlen(list) - 1);
        if (i + 1 < count) strncat(list, "|", sizeof list - strlen(list) - 1);
    }
    return prt__fail(PRT_ERROR_ARGUMENT, "option %s=%s: expected one of %s", key, v, list);
}

prt_status prt__spec_check_unused(const prt_spec *s) {
    for (int i = 0; i < s->count; i++)
        if (!s->kv[i].used)
            return prt__fail(PRT_ERROR_ARGUMENT, "representation '%s' has no option '%s'", s->structure, s->kv[i].key);
    return PRT_OK;
}

void prt__spec_set(prt_spec *s, const char *key, const char *value) {
    for (int i = 0; i < s->count; i++)
        if (!strcmp(s->kv[i].key, key)) {
            snprintf(s->kv[i].value, sizeof s->kv[i].value, "%s", value);
            s->kv[i].used = true;
            return;
        }
    if (s->count == PRT_SPEC_MAX_KEYS) return;
    int i = s->count++;
    snprintf(s->kv[i].key, sizeof s->kv[i].key, "%s", key);
    snprintf(s->kv[i].value, sizeof s->kv[i].value, "%s", value);
    s->kv[i].used = true;
}

void prt__spec_format(const prt_spec *s, char *buf, size_t size) {
    int n = snprintf(buf, size, "%s%s%s", s->structure, s->codec[0] ? ":" : "", s->codec);
    for (int i = 0; i < s->count && n >= 0 && (size_t)n < size; i++)
        n += snprintf(buf + n, size - (size_t)n, ",%s=%s", s->kv[i].key, s->kv[i].value);
}
