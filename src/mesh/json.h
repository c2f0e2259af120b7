/* A small strict JSON reader for glTF (json.c): the text is split into a flat array of
 * tokens (as jsmn does), each knowing where its subtree ends, so lookups walk the array
 * without building a tree. Strings are left escaped in the text; keys are compared raw
 * (glTF's keys have no escapes). */
#ifndef PRT_MESH_JSON_H
#define PRT_MESH_JSON_H

#include "mesh/source.h"

enum { JSON_NULL, JSON_FALSE, JSON_TRUE, JSON_NUMBER, JSON_STRING, JSON_ARRAY, JSON_OBJECT };

typedef struct json_tok {
    uint32_t type;
    uint32_t size;     /* array: elements; object: key/value pairs */
    size_t start, end; /* the token's text (a string's without its quotes) */
    size_t next;       /* index of the token after this one's subtree */
    size_t elems;      /* array: where its elements' token indices start in json_doc.elem */
} json_tok;

typedef struct json_doc {
    const char *text;
    json_tok *tok;
    size_t n;
    size_t *elem; /* every array's element token indices, so json_at is O(1) */
} json_doc;

/* Parse text[0..len) (one value, whitespace around it); errors name `name` and the byte
 * offset (base is added to offsets, for JSON inside a GLB). Nesting deeper than 64 levels
 * is refused. s: for number parsing (mesh_parse_float). */
prt_status json_parse(mesh_source *s, const char *text, size_t len, uint64_t base, json_doc *doc);
void json_free(json_doc *doc);

/* The value of key in object token obj, or -1 (also when obj < 0 or not an object). */
long json_get(const json_doc *d, long obj, const char *key);
/* Element i of array token arr, or -1 (constant time). */
long json_at(const json_doc *d, long arr, size_t i);
/* Elements of an array (0 for anything else). */
size_t json_len(const json_doc *d, long arr);
/* A number; false when tok is not one. json_uint: a non-negative integer below 2^53. */
bool json_number(mesh_source *s, const json_doc *d, long tok, double *out);
bool json_uint(const json_doc *d, long tok, uint64_t *out);
/* Whether tok is the string lit (compared raw). */
bool json_is(const json_doc *d, long tok, const char *lit);

#endif
