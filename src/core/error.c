/* Status names and the per-thread last-error message. */
#include "core/common.h"

#include <stdio.h>

static _Thread_local char g_message[1024];

const char *prt_status_string(prt_status s) {
    switch (s) {
    case PRT_OK: return "ok";
    case PRT_ERROR_ARGUMENT: return "invalid argument";
    case PRT_ERROR_IO: return "i/o error";
    case PRT_ERROR_FORMAT: return "format error";
    case PRT_ERROR_MESH: return "invalid mesh";
    case PRT_ERROR_CORRUPT: return "corrupt file";
    case PRT_ERROR_UNSUPPORTED: return "unsupported";
    case PRT_ERROR_NOMEM: return "out of memory";
    case PRT_ERROR_LIMIT: return "limit exceeded";
    }
    return "unknown status";
}

const char *prt_last_error(void) { return g_message; }

void prt__clear_error(void) { g_message[0] = 0; }

prt_status prt__fail(prt_status s, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(g_message, sizeof g_message, fmt, ap);
    va_end(ap);
    return s;
}
