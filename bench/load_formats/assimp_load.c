/* Assimp's load of a mesh file, for comparison with packrt's readers (docs/results/formats.md):
 * aiImportFile with aiProcess_Triangulate only (no vertex joining), wall and CPU time.
 * Not part of the build: cc -O2 bench/load_formats/assimp_load.c -lassimp -o assimp_load */
#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <stdio.h>
#include <time.h>
static double c(clockid_t k) {
    struct timespec t;
    clock_gettime(k, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}
int main(int argc, char **argv) {
    double w = c(CLOCK_MONOTONIC), u = c(CLOCK_PROCESS_CPUTIME_ID);
    const struct aiScene *s = aiImportFile(argv[1], aiProcess_Triangulate);
    if (!s) {
        printf("%s: %s\n", argv[1], aiGetErrorString());
        return 1;
    }
    size_t tris = 0, verts = 0;
    for (unsigned i = 0; i < s->mNumMeshes; i++) tris += s->mMeshes[i]->mNumFaces, verts += s->mMeshes[i]->mNumVertices;
    printf("%-8s assimp %zu tris %zu verts wall %.3f s cpu %.3f s\n", argv[1], tris, verts, c(CLOCK_MONOTONIC) - w,
           c(CLOCK_PROCESS_CPUTIME_ID) - u);
    aiReleaseImport(s);
    return 0;
}
