/* JSON tokenizer (json.h) following RFC 8259 strictly: no comments, no trailing commas,
 * no control characters in strings, every escape checked. Iterative, with an explicit
 * stack of open containers, so hostile nesting cannot exhaust the C stack. */
#include "mesh/json.h"

#define JSON_MAX_DEPTH 64

typedef struct parser {
    const char *p, *e, *text;
    uint64_t base;
    const char *name;
    json_doc *d;
    size_t cap;
} parser;

static prt_status fail(parser *ps, const char *at, const char *what) {
    return prt__fail(PRT_ERROR_FORMAT, "%s: JSON byte %llu: %s", ps->name,
                     (unsigned long long)(ps->base + (uint64_t)(at - ps->text)), what);
}

static void skip_ws(parser *ps) {
    while (ps->p < ps->e && (*ps->p == ' ' || *ps->p == '\t' || *ps->p == '\n' || *ps->p == '\r')) ps->p++;
}

static prt_status push(parser *ps, uint32_t type, size_t start, size_t end, long *idx) {
    json_doc *d = ps->d;
    if (d->n == ps->cap) {
        size_t cap = ps->cap ? 2 * ps->cap : 256;
        json_tok *t = prt__realloc(d->tok, prt__mul_size(cap, sizeof *t));
        if (!t) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory for JSON tokens", ps->name);
        d->tok = t, ps->cap = cap;
    }
    d->tok[d->n] = (json_tok){type, 0, start, end, d->n + 1, 0};
    *idx = (long)d->n++;
    return PRT_OK;
}

static int hexval(char c) {
    return c >= '0' && c <= '9'   ? c - '0'
           : c >= 'a' && c <= 'f' ? c - 'a' + 10
           : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                  : -1;
}

static prt_status string(parser *ps, long *idx) {
    const char *q = ps->p + 1; /* after the opening quote */
    for (;;) {
        if (q >= ps->e) return fail(ps, ps->p, "unterminated string");
        unsigned char c = (unsigned char)*q;
        if (c == '"') break;
        if (c < 0x20) return fail(ps, q, "control character in a string");
        if (c == '\\') {
            if (q + 1 >= ps->e) return fail(ps, q, "unterminated escape");
            char x = q[1];
            if (x == 'u') {
                if (ps->e - q < 6) return fail(ps, q, "short \\u escape");
                for (int k = 2; k < 6; k++)
                    if (hexval(q[k]) < 0) return fail(ps, q, "bad \\u escape");
                q += 6;
                continue;
            }
            if (!strchr("\"\\/bfnrt", x) || !x) return fail(ps, q, "bad escape");
            q += 2;
            continue;
        }
        q++;
    }
    prt_status st = push(ps, JSON_STRING, (size_t)(ps->p + 1 - ps->text), (size_t)(q - ps->text), idx);
    ps->p = q + 1;
    return st;
}

static bool digit(char c) { return c >= '0' && c <= '9'; }

static prt_status number(parser *ps, long *idx) {
    const char *q = ps->p;
    if (q < ps->e && *q == '-') q++;
    if (q >= ps->e || !digit(*q)) return fail(ps, ps->p, "malformed value");
    if (*q == '0') q++;
    else
        while (q < ps->e && digit(*q)) q++;
    if (q < ps->e && *q == '.') {
        if (++q >= ps->e || !digit(*q)) return fail(ps, ps->p, "malformed number");
        while (q < ps->e && digit(*q)) q++;
    }
    if (q < ps->e && (*q == 'e' || *q == 'E')) {
        q++;
        if (q < ps->e && (*q == '+' || *q == '-')) q++;
        if (q >= ps->e || !digit(*q)) return fail(ps, ps->p, "malformed number");
        while (q < ps->e && digit(*q)) q++;
    }
    prt_status st = push(ps, JSON_NUMBER, (size_t)(ps->p - ps->text), (size_t)(q - ps->text), idx);
    ps->p = q;
    return st;
}

static prt_status literal(parser *ps, long *idx) {
    static const char *const lit[] = {"null", "false", "true"};
    for (uint32_t k = 0; k < 3; k++) {
        size_t n = strlen(lit[k]);
        if ((size_t)(ps->e - ps->p) >= n && !memcmp(ps->p, lit[k], n)) {
            prt_status st = push(ps, k, (size_t)(ps->p - ps->text), (size_t)(ps->p + n - ps->text), idx);
            ps->p += n;
            return st;
        }
    }
    return fail(ps, ps->p, "malformed value");
}

/* Every array's elements listed once, in one block: lookups by position in constant time
 * (glTF refers to nodes, meshes, accessors and views by index, and files hold millions). */
static prt_status index_arrays(json_doc *d, const char *name) {
    size_t total = 0;
    for (size_t t = 0; t < d->n; t++)
        if (d->tok[t].type == JSON_ARRAY) total += d->tok[t].size;
    d->elem = prt__alloc(prt__mul_size(total ? total : 1, sizeof *d->elem));
    if (!d->elem) return prt__fail(PRT_ERROR_NOMEM, "%s: out of memory for JSON arrays", name);
    size_t at = 0;
    for (size_t t = 0; t < d->n; t++) {
        if (d->tok[t].type != JSON_ARRAY) continue;
        d->tok[t].elems = at;
        for (size_t c = t + 1, k = 0; k < d->tok[t].size; k++, c = d->tok[c].next) d->elem[at++] = c;
    }
    return PRT_OK;
}

prt_status json_parse(mesh_source *s, const char *text, size_t len, uint64_t base, json_doc *doc) {
    memset(doc, 0, sizeof *doc);
    doc->text = text;
    parser ps = {text, text + len, text, base, s->name, doc, 0};
    long stack[JSON_MAX_DEPTH];
    int depth = 0;
    prt_status st = PRT_OK;
    bool want_value = true; /* else: a ',' or the closing bracket */
    skip_ws(&ps);
    for (;;) {
        skip_ws(&ps);
        if (ps.p >= ps.e) {
            st = fail(&ps, ps.p, depth ? "truncated: unclosed array or object" : "no value");
            break;
        }
        json_tok *top = depth ? &doc->tok[stack[depth - 1]] : NULL;
        bool in_obj = top && top->type == JSON_OBJECT;
        if (!want_value) { /* after a value inside a container */
            char c = *ps.p;
            if (c == ',') {
                ps.p++, want_value = true;
                continue;
            }
            if (c == (in_obj ? '}' : ']')) {
                ps.p++;
                top->next = doc->n;
                top->end = (size_t)(ps.p - text);
                depth--;
                if (!depth) break;
                continue;
            }
            st = fail(&ps, ps.p, in_obj ? "expected ',' or '}'" : "expected ',' or ']'");
            break;
        }
        long idx;
        if (in_obj) { /* a key, then ':' */
            if (*ps.p == '}' && top->size == 0 && doc->n == (size_t)stack[depth - 1] + 1) {
                want_value = false;
                continue;
            }
            if (*ps.p != '"') {
                st = fail(&ps, ps.p, "expected a string key");
                break;
            }
            if ((st = string(&ps, &idx)) != PRT_OK) break;
            skip_ws(&ps);
            if (ps.p >= ps.e || *ps.p != ':') {
                st = fail(&ps, ps.p, "expected ':'");
                break;
            }
            ps.p++;
            skip_ws(&ps);
            if (ps.p >= ps.e) continue; /* reported as truncated above */
        } else if (top && *ps.p == ']' && top->size == 0 && doc->n == (size_t)stack[depth - 1] + 1) {
            want_value = false;
            continue;
        }
        if (top) top->size++;
        char c = *ps.p;
        if (c == '{' || c == '[') {
            if (depth == JSON_MAX_DEPTH) {
                st = fail(&ps, ps.p, "nested more than 64 levels deep");
                break;
            }
            if ((st = push(&ps, c == '{' ? JSON_OBJECT : JSON_ARRAY, (size_t)(ps.p - text), 0, &idx)) != PRT_OK) break;
            stack[depth++] = idx;
            ps.p++;
            continue; /* want_value stays: the first key or element (or the close) */
        }
        st = c == '"' ? string(&ps, &idx) : (c == '-' || digit(c)) ? number(&ps, &idx) : literal(&ps, &idx);
        if (st != PRT_OK) break;
        if (!depth) break;
        want_value = false;
    }
    if (st == PRT_OK) {
        skip_ws(&ps);
        if (ps.p != ps.e) st = fail(&ps, ps.p, "data after the JSON value");
    }
    if (st == PRT_OK) st = index_arrays(doc, ps.name);
    if (st != PRT_OK) json_free(doc);
    return st;
}

void json_free(json_doc *doc) {
    prt__free(doc->tok);
    prt__free(doc->elem);
    memset(doc, 0, sizeof *doc);
}

long json_get(const json_doc *d, long obj, const char *key) {
    if (obj < 0 || d->tok[obj].type != JSON_OBJECT) return -1;
    size_t n = strlen(key);
    long found = -1;
    for (size_t i = (size_t)obj + 1; i < d->tok[obj].next;) {
        const json_tok *k = &d->tok[i];
        size_t v = i + 1;
        if (k->end - k->start == n && !memcmp(d->text + k->start, key, n)) found = (long)v;
        i = d->tok[v].next; /* later duplicates win, as in most readers */
    }
    return found;
}

long json_at(const json_doc *d, long arr, size_t i) {
    if (arr < 0 || d->tok[arr].type != JSON_ARRAY || i >= d->tok[arr].size) return -1;
    return (long)d->elem[d->tok[arr].elems + i];
}

size_t json_len(const json_doc *d, long arr) {
    return arr >= 0 && d->tok[arr].type == JSON_ARRAY ? d->tok[arr].size : 0;
}

bool json_number(mesh_source *s, const json_doc *d, long tok, double *out) {
    if (tok < 0 || d->tok[tok].type != JSON_NUMBER) return false;
    const json_tok *t = &d->tok[tok];
    float f;
    if (!mesh_parse_float(s, d->text + t->start, t->end - t->start, &f)) return false;
    *out = f;
    return true;
}

bool json_uint(const json_doc *d, long tok, uint64_t *out) {
    if (tok < 0 || d->tok[tok].type != JSON_NUMBER) return false;
    const json_tok *t = &d->tok[tok];
    int64_t v;
    if (!mesh_parse_int(d->text + t->start, t->end - t->start, &v) || v < 0 || v > ((int64_t)1 << 53)) return false;
    *out = (uint64_t)v;
    return true;
}

bool json_is(const json_doc *d, long tok, const char *lit) {
    if (tok < 0 || d->tok[tok].type != JSON_STRING) return false;
    size_t n = strlen(lit);
    return d->tok[tok].end - d->tok[tok].start == n && !memcmp(d->text + d->tok[tok].start, lit, n);
}
