#!/usr/bin/env bash
# Every C source is as the project's .clang-format writes it (scripts/format.sh --check);
# skipped where clang-format is not installed. Usage: cli_format.sh PACKRT SOURCE_DIR
command -v clang-format >/dev/null || { echo "skipped: clang-format is not installed"; exit 77; }
exec bash "$2/scripts/format.sh" --check
