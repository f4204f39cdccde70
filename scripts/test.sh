#!/usr/bin/env bash
# The README's test command: install what is missing, build (Release), run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
build=${RTSIM_BUILD_DIR:-build}
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build "$build" -j "$(nproc)"
ctest --test-dir "$build" --output-on-failure -j "$(nproc)" --timeout 600 "$@"
