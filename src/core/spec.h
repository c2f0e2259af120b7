/* Representation spec strings: "structure[:codec][,key=value]..." (the grammar: prt_build in include/packrt.h). */
#ifndef PRT_CORE_SPEC_H
#define PRT_CORE_SPEC_H

#include "core/common.h"

#define PRT_SPEC_MAX_KEYS 16

typedef struct prt_spec {
    char structure[32];
    char codec[32];
    int count;
    struct {
        char key[24];
        char value[40];
        bool used; /* set by lookups, so unknown keys can be reported */
    } kv[PRT_SPEC_MAX_KEYS];
} prt_spec;

/* Parse text into *out. PRT_ERROR_ARGUMENT with a message on malformed input. */
prt_status prt__spec_parse(const char *text, prt_spec *out);

/* Value of key, or NULL. Marks the key as used. */
const char *prt__spec_get(prt_spec *s, const char *key);

/* Integer option in [lo, hi], def when absent. PRT_ERROR_ARGUMENT when malformed. */
prt_status prt__spec_int(prt_spec *s, const char *key, int def, int lo, int hi, int *out);

/* Option from a fixed set of names: *out = index of the value in names, def when absent. */
prt_status prt__spec_enum(prt_spec *s, const char *key, const char *const *names, int count, int def, int *out);

/* After a representation has read its options: error naming the first unknown key. */
prt_status prt__spec_check_unused(const prt_spec *s);

/* Set or replace key=value (used to write the canonical spec with defaults filled in). */
void prt__spec_set(prt_spec *s, const char *key, const char *value);

/* Canonical text: structure[:codec] followed by every key in insertion order. */
void prt__spec_format(const prt_spec *s, char *buf, size_t size);

#endif
