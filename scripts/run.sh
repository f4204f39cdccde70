#!/usr/bin/env bash
# The README's main job: install what is missing, build, run the main job on the
# embedded default scene. Extra arguments go to the main job.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
build=${RTSIM_BUILD_DIR:-build}
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build "$build" -j "$(nproc)" --target rtsim
exec "$build/rtsim" scenes info interior "$@"
