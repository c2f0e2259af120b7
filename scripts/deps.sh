#!/usr/bin/env bash
# Installs the Debian packages packrt needs (see README "Dependencies"). Skips apt
# entirely when everything is already there; otherwise runs apt-get update first.
# Usage: scripts/deps.sh [--test]   (--test adds clang for the libFuzzer targets and Xvfb
# for the headless viewer test)
set -euo pipefail
pkgs=(cmake make gcc pkg-config zlib1g-dev liblz4-dev libmeshoptimizer-dev libembree-dev libpng-dev libsdl2-dev libassimp-dev)
# python3-numpy, python3-cffi: the Python package in python/ (run time, with /usr/bin/python3).
pkgs+=(python3-numpy python3-cffi)
# libomp-14-dev: clang's OpenMP for the libFuzzer build (gcc uses its own libgomp);
# python3: the CLI tests read .hits, PNG and JSON output with it.
if [ "${1:-}" = "--test" ]; then pkgs+=(clang libclang-rt-14-dev libomp-14-dev xvfb xauth python3); fi
# clang-format: tests/cli_format.sh checks the sources against .clang-format (scripts/format.sh).
if [ "${1:-}" = "--test" ]; then pkgs+=(clang-format); fi
# python3-pytest: the Python package's tests (ctest python_tests).
if [ "${1:-}" = "--test" ]; then pkgs+=(python3-pytest); fi
# libopenmpi-dev, openmpi-bin: packrt-mpi and its test (tests/cli_mpi.sh); optional to build.
if [ "${1:-}" = "--test" ]; then pkgs+=(libopenmpi-dev openmpi-bin); fi
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  echo "deps: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null
fi
