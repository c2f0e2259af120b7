#!/usr/bin/env bash
# Formats packrt's C sources with the project's .clang-format (STYLE.md: no style debates).
# Usage: scripts/format.sh [--check]   (--check changes nothing: it shows each place that
# differs and exits 1 when there is one)
set -euo pipefail
cd "$(dirname "$0")/.."
command -v clang-format >/dev/null || { echo "format: clang-format is not installed (scripts/deps.sh --test)" >&2; exit 2; }
mapfile -t files < <(git ls-files '*.c' '*.h' '*.inc' 2>/dev/null || find src tools bench tests include python -name '*.[ch]' -o -name '*.inc')
if [ "${1:-}" = "--check" ]; then
  # One process for every file: it names each place that differs and exits non-zero.
  clang-format --dry-run --Werror "${files[@]}" || { echo "format: run scripts/format.sh" >&2; exit 1; }
  exit 0
fi
clang-format -i "${files[@]}"
