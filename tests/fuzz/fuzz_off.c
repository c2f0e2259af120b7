/* libFuzzer target for the OFF reader: inputs named "fuzz.off", so those that no magic
 * claims are read as OFF (load_check.h). */
#include "load_check.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) { return fuzz_load_check(data, size, "fuzz.off"); }
