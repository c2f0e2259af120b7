/* The marching-cubes case table, derived from first principles: on each cube face the
 * inside corners are cut off by segments, the segments chain into loops around the cube
 * and each loop is fanned into triangles (the construction behind Lorensen & Cline 1987). */
#include "mesh/marching_cubes.h"

#include <assert.h>
#include <string.h>

/* Edge joining corners a and b (which differ in exactly one coordinate). */
static int edge_of(int a, int b) {
    int d = a ^ b, axis = d == 1 ? 0 : (d == 2 ? 1 : 2);
    int lo = a & b, p[3] = {lo & 1, (lo >> 1) & 1, (lo >> 2) & 1};
    int u = axis == 0 ? 1 : 0, v = axis == 2 ? 1 : 2;
    return axis * 4 + p[u] + 2 * p[v];
}

/* The four corners of face f (axis f / 2 fixed at f % 2), in counter-clockwise order seen
 * from outside the cube. */
static void face_corners(int f, int q[4]) {
    int axis = f / 2, side = f % 2;
    int u = (axis + 1) % 3, v = (axis + 2) % 3;
    /* (u, v, axis) is a right-handed frame, so the loop (0,0) (1,0) (1,1) (0,1) in (u, v)
     * turns counter-clockwise about +axis: right for the side = 1 face, reversed for 0. */
    static const int uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (int i = 0; i < 4; i++) {
        int k = side ? i : 3 - i, p[3];
        p[axis] = side;
        p[u] = uv[k][0];
        p[v] = uv[k][1];
        q[i] = p[0] | p[1] << 1 | p[2] << 2;
    }
}

/* True when edges a and b lie on a common cube face. */
static int share_face(int a, int b) {
    int oa[3], ob[3], xa = gen_mc_edge_axis(a), xb = gen_mc_edge_axis(b);
    gen_mc_edge_origin(a, oa);
    gen_mc_edge_origin(b, ob);
    for (int k = 0; k < 3; k++)
        if (k != xa && k != xb && oa[k] == ob[k]) return 1;
    return 0;
}

/* Apex of the fan over loop[0..m): the first one whose diagonals all cross the cell's
 * interior. A diagonal between two points of one face would lie in that face, where the
 * neighbouring cell may put the same diagonal: the edge would then carry four triangles.
 * Every loop of this construction has such an apex (checked over all 256 cases). */
static int fan_apex(const int *loop, int m) {
    for (int k = 0; k < m; k++) {
        int ok = 1;
        for (int j = 2; j + 1 < m && ok; j++) ok = !share_face(loop[k], loop[(k + j) % m]);
        if (ok) return k;
    }
    assert(!"no fan apex");
    return 0;
}

static void build_case(int mask, uint8_t *count, uint8_t *out) {
    /* next[e]: the crossing edge that the loop visits after e; -1 when e is not crossed. */
    int next[12];
    for (int e = 0; e < 12; e++) next[e] = -1;
    for (int f = 0; f < 6; f++) {
        int q[4], in[4];
        face_corners(f, q);
        for (int i = 0; i < 4; i++) in[i] = (mask >> q[i]) & 1;
        for (int i = 0; i < 4; i++) {
            if (!in[i] || in[(i + 1) % 4]) continue;
            /* q[i] ends a run of inside corners (counter-clockwise); walk back to where the
             * run starts. The segment from this in->out crossing back to the run's out->in
             * crossing bounds the run with the inside on its left, so segments of
             * neighbouring faces chain head to tail. A face with two separate runs
             * (ambiguous) gets one segment per run: inside corners are cut off apart. */
            int j = i;
            while (in[(j + 3) % 4]) j = (j + 3) % 4;
            int from = edge_of(q[i], q[(i + 1) % 4]);
            int to = edge_of(q[(j + 3) % 4], q[j]);
            assert(next[from] < 0);
            next[from] = to;
        }
    }
    int n = 0;
    int done[12] = {0};
    for (int start = 0; start < 12; start++) {
        if (next[start] < 0 || done[start]) continue;
        int loop[12], m = 0;
        for (int e = start; !done[e]; e = next[e]) {
            done[e] = 1;
            loop[m++] = e;
        }
        assert(m >= 3);
        /* The loop runs counter-clockwise around the inside region of the cube's surface
         * as seen from outside the cube, so its right-hand normal points into the inside:
         * fan it in reverse for outward-facing triangles. */
        int a = fan_apex(loop, m);
        for (int k = 1; k + 1 < m; k++) {
            assert(n < GEN_MC_MAX_TRIS);
            out[3 * n + 0] = (uint8_t)loop[a];
            out[3 * n + 1] = (uint8_t)loop[(a + k + 1) % m];
            out[3 * n + 2] = (uint8_t)loop[(a + k) % m];
            n++;
        }
    }
    *count = (uint8_t)n;
}

void gen_mc_table_build(gen_mc_table *t) {
    memset(t, 0, sizeof *t);
    for (int mask = 0; mask < 256; mask++) build_case(mask, &t->count[mask], t->edges[mask]);
}
