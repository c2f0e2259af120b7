/* libFuzzer target for mesh loading through prt_mesh_load_memory: gzip, format detection
 * and the PLY reader. Any input must load a valid mesh or fail with a message naming the
 * input, and leave no packrt allocation behind; the streaming reader must agree with it
 * (load_check.h). */
#include "load_check.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) { return fuzz_load_check(data, size, "fuzz.ply"); }
