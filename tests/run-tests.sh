#!/usr/bin/env bash
# Command 2 of the README: installs what is missing, builds everything (Release) and runs the whole
# test suite with CTest. Usage: bash tests/run-tests.sh   (env BUILD_DIR, default build/)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"
bash .ci/install-deps.sh
build="${BUILD_DIR:-build}"
jobs="$(nproc)"
source .ci/ccache.sh
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release "${launcher[@]}"
cmake --build "$build" -j"$jobs"
ctest --test-dir "$build" --output-on-failure -j"$jobs"
