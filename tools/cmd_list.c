/* packrt list: every representation name with its one-line description, name first. */
#include "cli.h"

#include <string.h>

int cmd_list(int argc, char **argv) {
    if (argc > 1 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        printf("usage: packrt list\n  prints every representation name (usable with -r), one per line, name first\n");
        return 0;
    }
    if (argc > 1) return cli_usage("list", "unexpected argument '%s'", argv[1]);
    for (size_t i = 0; i < prt_repr_count(); i++) printf("%-22s %s\n", prt_repr_name(i), prt_repr_description(i));
    return 0;
}
