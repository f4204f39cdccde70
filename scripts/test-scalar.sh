#!/usr/bin/env bash
# The ray core's scalar fallback (RTSIM_SIMD=OFF: intersect.h and the SAH bin sweep
# without SSE2, the path a machine without SSE2 takes), built apart and held to the
# same stored access streams and lane verdicts as the SSE2 build.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${RTSIM_SCALAR_BUILD_DIR:-build-scalar}
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DRTSIM_SIMD=OFF -DRTSIM_BUILD_BENCH=OFF
cmake --build "$build" -j "$(nproc)" --target model_test_core_access_streams model_test_core_wide \
  model_test_core_traversal
ctest --test-dir "$build" --output-on-failure -j "$(nproc)" --timeout 600 \
  -R '^(CoreAccessStreams|CoreWide|CoreTraversal)\.'
