#!/usr/bin/env bash
# Second command: builds (if needed) and runs the whole test suite: unit tests
# of libcalib and the end-to-end tests of the processes (these need root or
# user namespaces for their private network namespace).
#   scripts/test.sh [ctest options, e.g. -R e2e -V]
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release ${AGVCAL_CMAKE_ARGS:-} >/dev/null
cmake --build build -j"$(nproc)"
ctest --test-dir build --output-on-failure -j"$(nproc)" "$@"
