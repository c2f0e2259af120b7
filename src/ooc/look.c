/* LOD voxel shading (Áfra 2012 §4.2): what a kd cell looks like from each of its six
 * sides, and its 4-byte samples (Table 1).
 *
 * The paper rasterises the triangles onto the six faces with a depth test (out of core)
 * or casts sample rays into the built subtree (in core). We do the same thing at the
 * resolution of the tree: a leaf projects its triangles onto each face (one sample, no
 * depth test inside a leaf of at most a few hundred triangles); an inner node composites
 * its two children, the one nearer a face over the farther one along the split axis
 * ("over" with coverage as alpha), side by side across it. That is a depth-tested
 * rasterisation whose pixels are the kd cells, it costs O(1) per node, and it works the
 * same in and out of core. Normals keep the mesh's orientation: a face sees the triangles
 * turned towards it, or, when none are, the ones turned away. */
#include "ooc/ooc.h"

#include <math.h>

#define GREY 0.72f             /* the renderer's albedo for meshes without colours */
#define SINGLE_NORMAL_TOL 0.2f /* 1-sample voxel when all six normals are this close */
#define SINGLE_COLOR_TOL 0.1f

static void unpack_color(uint16_t c, float rgb[3]) {
    for (int k = 0; k < 3; k++) rgb[k] = (float)((c >> (5 * k)) & 31) / 31.0f;
}

static int quant6(float x) {
    int q = (int)lrintf(x * 31.0f);
    return q < -31 ? -31 : q > 31 ? 31 : q;
}

uint32_t ooc_sample_pack(const float n[3], const float rgb[3], bool single) {
    uint32_t s = 0;
    for (int k = 0; k < 3; k++) {
        int q = (int)lrintf(fminf(fmaxf(rgb[k], 0.0f), 1.0f) * 31.0f);
        s |= (uint32_t)q << (5 * k);
    }
    int a = 0;
    for (int k = 1; k < 3; k++)
        if (fabsf(n[k]) > fabsf(n[a])) a = k;
    float m = fabsf(n[a]);
    if (m > 0.0f) {
        int u = quant6(n[(a + 1) % 3] / m), v = quant6(n[(a + 2) % 3] / m);
        s |= (uint32_t)(n[a] < 0.0f) << 15 | (uint32_t)a << 16 | ((uint32_t)u & 63) << 18 | ((uint32_t)v & 63) << 24;
    } else {
        s |= 1u << 16; /* no normal known: +y */
    }
    return s | (uint32_t)single << 31;
}

/* q / 31 for the 6-bit two's complement q = j (j < 32) or j - 64: folded by the compiler,
 * correctly rounded as the division at run time, so a lookup gives the same bits. */
#define Q31(j) ((float)((j) < 32 ? (j) : (j)-64) / 31.0f)
#define Q31x8(j) Q31(j), Q31(j + 1), Q31(j + 2), Q31(j + 3), Q31(j + 4), Q31(j + 5), Q31(j + 6), Q31(j + 7)
const float ooc_q31[64] = {Q31x8(0), Q31x8(8), Q31x8(16), Q31x8(24), Q31x8(32), Q31x8(40), Q31x8(48), Q31x8(56)};
#undef Q31x8
#undef Q31

void ooc_sample_unpack(uint32_t s, float n[3], float rgb[3]) {
    for (int k = 0; k < 3; k++) rgb[k] = ooc_q31[(s >> (5 * k)) & 31];
    int a = (int)((s >> 16) & 3);
    if (a > 2) a = 1; /* only a corrupt sample has axis 3 */
    /* x[a] = w, x[(a + 1) % 3] = u, x[(a + 2) % 3] = v, by selects: through an array
     * indexed by a, the loads waited for the stores. */
    const float w = (s >> 15) & 1 ? -1.0f : 1.0f, u = ooc_q31[(s >> 18) & 63], v = ooc_q31[(s >> 24) & 63];
    const float x0 = a == 0 ? w : a == 1 ? v : u, x1 = a == 0 ? u : a == 1 ? w : v, x2 = a == 0 ? v : a == 1 ? u : w;
    float l = 1.0f / sqrtf(x0 * x0 + x1 * x1 + x2 * x2);
    n[0] = x0 * l, n[1] = x1 * l, n[2] = x2 * l;
}

static float face_area(const float b[6], int axis) {
    int u = (axis + 1) % 3, v = (axis + 2) % 3;
    return (b[3 + u] - b[u]) * (b[3 + v] - b[v]);
}

static void normalize_sides(ooc_look *l, const float w[6]) {
    for (int s = 0; s < 6; s++) {
        float len = sqrtf(l->n[s][0] * l->n[s][0] + l->n[s][1] * l->n[s][1] + l->n[s][2] * l->n[s][2]);
        for (int k = 0; k < 3; k++) {
            l->n[s][k] = len > 0.0f ? l->n[s][k] / len : 0.0f;
            l->rgb[s][k] = w[s] > 0.0f ? l->rgb[s][k] / w[s] : 0.0f;
        }
    }
}

void ooc_look_leaf(ooc_look *l, const float box[6], const ooc_btri *tris, const uint32_t *refs, size_t n) {
    /* Per side, front-facing and back-facing sums kept apart: [0] towards the face. */
    float nsum[6][2][3] = {{{0}}}, csum[6][2][3] = {{{0}}}, w[6][2] = {{0}};
    for (size_t i = 0; i < n; i++) {
        const ooc_btri *t = &tris[refs[i]];
        float e1[3], e2[3], c[3];
        for (int k = 0; k < 3; k++) e1[k] = t->v[3 + k] - t->v[k], e2[k] = t->v[6 + k] - t->v[k];
        c[0] = e1[1] * e2[2] - e1[2] * e2[1];
        c[1] = e1[2] * e2[0] - e1[0] * e2[2];
        c[2] = e1[0] * e2[1] - e1[1] * e2[0];
        float rgb[3];
        unpack_color(t->color, rgb);
        for (int s = 0; s < 6; s++) {
            int a = s >> 1;
            float d = (s & 1) ? c[a] : -c[a]; /* twice the projected area, signed */
            int back = d < 0.0f;
            float wt = fabsf(d) * 0.5f;
            for (int k = 0; k < 3; k++) nsum[s][back][k] += c[k] * 0.5f, csum[s][back][k] += rgb[k] * wt;
            w[s][back] += wt;
        }
    }
    float wt[6];
    for (int s = 0; s < 6; s++) {
        int use = w[s][0] > 0.0f ? 0 : 1;
        for (int k = 0; k < 3; k++) l->n[s][k] = nsum[s][use][k], l->rgb[s][k] = csum[s][use][k];
        wt[s] = w[s][use];
        float fa = face_area(box, s >> 1);
        l->cover[s] = fa > 0.0f ? fminf(1.0f, wt[s] / fa) : (wt[s] > 0.0f ? 1.0f : 0.0f);
    }
    normalize_sides(l, wt);
}

void ooc_look_compose(ooc_look *l, const float box[6], int axis, const ooc_look *lo, const float *lo_box,
                      const ooc_look *hi, const float *hi_box) {
    float wt[6];
    memset(l, 0, sizeof *l);
    for (int s = 0; s < 6; s++) {
        int a = s >> 1;
        float wl, wh;
        if (a == axis) {
            /* Along the split: the child at this face in front of the other. */
            const bool lo_front = !(s & 1);
            float cf = lo_front ? lo->cover[s] : hi->cover[s], cb = lo_front ? hi->cover[s] : lo->cover[s];
            float front = cf, back = (1.0f - cf) * cb;
            wl = lo_front ? front : back, wh = lo_front ? back : front;
        } else {
            /* Across it: the two children share the face in proportion to their areas. */
            float fa = face_area(box, a);
            wl = fa > 0.0f ? lo->cover[s] * face_area(lo_box, a) / fa : 0.5f * lo->cover[s];
            wh = fa > 0.0f ? hi->cover[s] * face_area(hi_box, a) / fa : 0.5f * hi->cover[s];
        }
        for (int k = 0; k < 3; k++) {
            l->n[s][k] = wl * lo->n[s][k] + wh * hi->n[s][k];
            l->rgb[s][k] = wl * lo->rgb[s][k] + wh * hi->rgb[s][k];
        }
        wt[s] = wl + wh;
        l->cover[s] = fminf(1.0f, wt[s]);
    }
    normalize_sides(l, wt);
}

int ooc_look_voxel(const ooc_look *l, uint32_t out[6]) {
    /* A side that sees nothing shows the best-covered side's sample. */
    int best = 0;
    for (int s = 1; s < 6; s++)
        if (l->cover[s] > l->cover[best]) best = s;
    float n[6][3], rgb[6][3];
    for (int s = 0; s < 6; s++) {
        int src = l->cover[s] > 0.0f ? s : best;
        memcpy(n[s], l->n[src], sizeof n[s]);
        memcpy(rgb[s], l->rgb[src], sizeof rgb[s]);
        if (n[s][0] == 0.0f && n[s][1] == 0.0f && n[s][2] == 0.0f) n[s][1] = 1.0f;
        if (l->cover[src] == 0.0f) rgb[s][0] = rgb[s][1] = rgb[s][2] = GREY;
    }
    float mean_n[3] = {0}, mean_c[3] = {0};
    for (int s = 0; s < 6; s++)
        for (int k = 0; k < 3; k++) mean_n[k] += n[s][k] / 6.0f, mean_c[k] += rgb[s][k] / 6.0f;
    float dn = 0.0f, dc = 0.0f;
    for (int s = 0; s < 6; s++)
        for (int k = 0; k < 3; k++)
            dn = fmaxf(dn, fabsf(n[s][k] - mean_n[k])), dc = fmaxf(dc, fabsf(rgb[s][k] - mean_c[k]));
    if (dn <= SINGLE_NORMAL_TOL && dc <= SINGLE_COLOR_TOL) {
        out[0] = ooc_sample_pack(mean_n, mean_c, true);
        return 1;
    }
    for (int s = 0; s < 6; s++) out[s] = ooc_sample_pack(n[s], rgb[s], false);
    return 6;
}
