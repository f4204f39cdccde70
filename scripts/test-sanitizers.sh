#!/usr/bin/env bash
# CI's sanitizer pass: builds the "asan" preset (clang, AddressSanitizer + UBSan,
# the libraries instrumented for libFuzzer, into build-asan) and runs the whole
# test suite under it. The same build holds the fuzz targets (scripts/fuzz.sh).
#   scripts/test-sanitizers.sh                # every test
#   scripts/test-sanitizers.sh -L robustness  # extra arguments go to ctest
set -euo pipefail
cd "$(dirname "$0")/.."
cmake --preset asan >/dev/null
cmake --build --preset asan -j "$(nproc)"
# The sanitizer environment is in the "asan" test preset (detect_leaks=0: Embree,
# TBB and SystemC keep process-lifetime allocations; every other report aborts).
ctest --preset asan -j "$(nproc)" "$@"
