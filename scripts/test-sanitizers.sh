#!/usr/bin/env bash
# CI's sanitizer pass: builds the "asan" preset (AddressSanitizer + UBSan, into
# build-asan) and runs the unit and robustness tests under it once.
#   scripts/test-sanitizers.sh            # the labels CI runs
#   RTSIM_ASAN_LABELS='robustness' scripts/test-sanitizers.sh
# Only the test programs of those labels are built, to keep CI within its budget
# (the measured timings are in the issue 5 note).
set -euo pipefail
cd "$(dirname "$0")/.."
labels=${RTSIM_ASAN_LABELS:-robustness workloads builder model}
jobs=$(nproc)

cmake --preset asan >/dev/null
targets=(rtsim)
for label in $labels; do
  for source in tests/"$label"/test_*.cpp; do
    [ -f "$source" ] && targets+=("${label}_$(basename "$source" .cpp)")
  done
done
cmake --build --preset asan -j "$jobs" --target "${targets[@]}"
regex=$(echo "$labels" | tr ' ' '|')
# The sanitizer environment is in the "asan" test preset (detect_leaks=0: Embree,
# TBB and SystemC keep process-lifetime allocations; every other report aborts).
ctest --preset asan -L "^($regex)\$" -j "$jobs" ${RTSIM_ASAN_EXCLUDE:+-E "$RTSIM_ASAN_EXCLUDE"}
