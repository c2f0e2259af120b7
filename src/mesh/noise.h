/* Deterministic 2D gradient noise and its fractal sum (fBm) for the terrain generator. */
#ifndef PRT_MESH_NOISE_H
#define PRT_MESH_NOISE_H

#include <stdint.h>

/* Gradient noise at (x, y) for lattice seed `seed`, in [-1, 1]; 0 at lattice points. */
float gen_noise2(float x, float y, uint32_t seed);

/* Sum of `octaves` noise layers, octave o at frequency 2^o and amplitude 2^-o, each layer
 * with its own lattice seed (derived from seed) and offset. Divided by 2, the sum of all
 * amplitudes of an infinite series, so the result stays in [-1, 1] and the coarse shape
 * does not change when octaves are added. */
float gen_fbm2(float x, float y, uint64_t seed, int octaves);

#endif
