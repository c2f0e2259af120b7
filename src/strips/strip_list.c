/* Growing lists of strips (vertex indices and per-triangle ids) that the stripifiers
 * append to and the encoder reads. */
#include "strips/strips.h"

static bool reserve(uint32_t **p, size_t *cap, size_t need) {
    if (need <= *cap) return true;
    size_t c = *cap ? *cap : 64;
    while (c < need) c *= 2;
    uint32_t *q = prt__realloc(*p, prt__mul_size(c, sizeof(uint32_t)));
    if (!q) return false;
    *p = q, *cap = c;
    return true;
}

void rs_strip_list_free(rs_strip_list *l) {
    prt__free(l->index);
    prt__free(l->id);
    prt__free(l->first);
    memset(l, 0, sizeof *l);
}

bool rs_strip_list_push(rs_strip_list *l, const uint32_t *index, const uint32_t *id, size_t count) {
    if (!reserve(&l->index, &l->index_cap, l->index_count + count) ||
        !reserve(&l->id, &l->id_cap, l->id_count + count - 2) || !reserve(&l->first, &l->first_cap, l->strip_count + 2))
        return false;
    if (l->strip_count == 0) l->first[0] = 0;
    memcpy(l->index + l->index_count, index, count * sizeof *index);
    memcpy(l->id + l->id_count, id, (count - 2) * sizeof *id);
    l->index_count += count, l->id_count += count - 2;
    l->first[++l->strip_count] = (uint32_t)l->index_count;
    return true;
}

bool rs_strip_list_append(rs_strip_list *into, const rs_strip_list *l) {
    for (size_t s = 0; s < l->strip_count; s++) {
        size_t f = l->first[s], count = l->first[s + 1] - f;
        if (!rs_strip_list_push(into, l->index + f, l->id + f - 2 * s, count)) return false;
    }
    return true;
}
