/* libFuzzer target for the STL reader, binary and ASCII: inputs named "fuzz.stl", so those
 * that no magic claims are read as binary STL (load_check.h). */
#include "load_check.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) { return fuzz_load_check(data, size, "fuzz.stl"); }
