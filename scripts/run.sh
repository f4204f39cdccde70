#!/usr/bin/env bash
# The README's main job: install what is missing, build, and run the main job on the
# embedded default scene: the patent's Table 1 (results/table1/). Extra arguments
# go to `rtsim table1`, e.g. --scene dragon after `rtsim scenes fetch dragon`.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
build=${RTSIM_BUILD_DIR:-build}
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build "$build" -j "$(nproc)" --target rtsim
exec "$build/rtsim" table1 --out-dir results/table1 "$@"
