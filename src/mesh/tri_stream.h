/* Triangle streams: meshes larger than memory handed over in batches of triangles, so an
 * out-of-core builder (src/ooc/) never holds the whole model. A producer (a PLY on disk,
 * a generator) calls the sink once per batch, in order; triangle ids are positions in the
 * stream (the first triangle of the first batch is 0), as mesh triangle ids are. */
#ifndef PRT_MESH_TRI_STREAM_H
#define PRT_MESH_TRI_STREAM_H

#include "core/common.h"

/* One batch: count triangles of 9 floats each (x0 y0 z0 x1 y1 z1 x2 y2 z2), first_id the
 * stream id of tris[0]. The memory is the producer's and is valid only during the call.
 * A sink that returns anything but PRT_OK stops the producer, which returns that status. */
typedef prt_status (*tri_sink_fn)(void *user, const float *tris, size_t count, uint64_t first_id);

#endif
