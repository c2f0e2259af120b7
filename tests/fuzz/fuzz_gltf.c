/* libFuzzer target for the glTF reader and its JSON tokenizer: inputs named "fuzz.gltf",
 * so those that no magic claims are read as glTF JSON; GLB is recognised by its magic
 * (load_check.h). External buffer files are refused for memory input, so nothing is read
 * from disk. */
#include "load_check.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) { return fuzz_load_check(data, size, "fuzz.gltf"); }
