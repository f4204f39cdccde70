#!/usr/bin/env bash
# Our DRAM model beside DRAMsim3 on the same requests (docs/dram.md, "Checked against").
#
#   scripts/crosscheck-dram.sh DRAMSIM3_DIR [micro|streams TRACE...]
#
# DRAMSIM3_DIR: a checkout of umd-memsys/DRAMsim3 that its own build has already made
# libdramsim3.so in (this script builds nothing of it and copies nothing from it). The
# script configures an rtsim with -DRTSIM_DRAMSIM3=DRAMSIM3_DIR in a scratch folder
# ($RTSIM_CROSSCHECK_DIR, default /tmp/rtsim-crosscheck), so that `rtsim dram-replay`
# can feed one trace to either model through the same seam, and prints one table:
#   micro    (default) the microbenchmarks below on ddr4-2400 (DRAMsim3's
#            DDR4_8Gb_x8_2400), lpddr4-3200 and gddr6, one channel, open page
#   streams PRESET TRACE...  traces written by `rtsim simulate --dram-trace-out`
#            with PRESET (a preset name or TOML file: its DRAM keys)
# Both models get the same part (DRAMsim3's .ini is written from our keys:
# dramsim3_ini), address mapping, page policy and queue size; the policies that
# still differ are listed in docs/dram.md.
set -euo pipefail
ref=${1:?usage: $0 DRAMSIM3_DIR [micro|streams TRACE...]}
mode=${2:-micro}
shift 2 || shift $#
here=$(cd "$(dirname "$0")/.." && pwd)
work=${RTSIM_CROSSCHECK_DIR:-/tmp/rtsim-crosscheck}
if [[ ! -f $ref/src/dramsim3.h ]] || [[ ! -f $ref/libdramsim3.so && ! -f $ref/build/libdramsim3.so ]]; then
  echo "$ref: not a built DRAMsim3 checkout (src/dramsim3.h and libdramsim3.so, made by its own build)" >&2
  exit 2
fi
mkdir -p "$work"
# RTSIM_BUILD: an rtsim build folder already configured with -DRTSIM_DRAMSIM3 (saves a build).
build=${RTSIM_BUILD:-$work/build}
if [[ -z ${RTSIM_BUILD:-} ]]; then
  cmake -S "$here" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DRTSIM_BUILD_TESTS=OFF \
    -DRTSIM_BUILD_BENCH=OFF -DRTSIM_DRAMSIM3="$(cd "$ref" && pwd)" >"$work/configure.log"
  cmake --build "$build" -j"${JOBS:-2}" --target rtsim >"$work/build.log"
fi
rtsim=$build/rtsim

# Our DRAMsim3 .ini for ddr4-2400 against DRAMsim3's own DDR4_8Gb_x8_2400.ini: every
# timing key they both set, so that a difference in the results is not one of inputs.
check_timings() {
  local theirs=$ref/configs/DDR4_8Gb_x8_2400.ini
  [[ -f $theirs ]] || return 0
  printf 'preset = "desktop"\n[dram]\nchannels = 1\npage_policy = "open"\n' >"$work/ddr4.toml"
  python3 - "$theirs" "$rtsim" "$work/ddr4.toml" <<'EOF'
import subprocess, sys, re, configparser
theirs, rtsim, toml = sys.argv[1:]
def timing(text):
    out = {}
    sec = None
    for line in text.splitlines():
        line = line.split(';')[0].strip()
        if line.startswith('['): sec = line.strip('[]'); continue
        if sec == 'timing' and '=' in line:
            k, v = [x.strip() for x in line.split('=', 1)]
            out[k] = float(v)
    return out
ours = timing(subprocess.run([rtsim, 'dram-replay', '--print-dramsim3-ini', '--config', toml, '--trace', '/dev/null'],
                             capture_output=True, text=True, check=True).stdout)
ref = timing(open(theirs).read())
diff = [(k, ref[k], ours[k]) for k in sorted(ref) if k in ours and abs(ref[k] - ours[k]) > 0.005]
print('ddr4-2400 timings vs DDR4_8Gb_x8_2400.ini: ' + ('identical' if not diff else
      ', '.join('%s %g (theirs) vs %g (ours)' % d for d in diff)))
EOF
}

# The microbenchmarks: scripts/crosscheck/micro_traces.py.
make_micro() { python3 "$here/scripts/crosscheck/micro_traces.py" "$1" "$2"; }

row() {  # bench, trace, config: ours beside DRAMsim3
  python3 "$here/scripts/crosscheck/compare.py" "$1" \
    "$("$rtsim" dram-replay --trace "$2" --config "$3" --model rtsim)" \
    "$("$rtsim" dram-replay --trace "$2" --config "$3" --model dramsim3)"
}

header() {
  echo
  echo "$1 (each cell: ours/DRAMsim3 (difference); ! past the goal: bandwidth 5%, row-hit rate 5 points, mean"
  echo "read latency 10%; latencies count from the trace cycle, 16384 ns is the histograms' top bucket)"
  echo "| trace | GB/s | mean read ns | p50 ns | p99 ns | row-hit rate | activates | refreshes | mean write wait ns |"
  echo "|---|---|---|---|---|---|---|---|---|"
}

case $mode in
  micro)
    check_timings
    for part in ddr4-2400 lpddr4-3200 gddr6; do
      dir=$work/micro-$part
      mkdir -p "$dir"
      make_micro "$part" "$dir"
      case $part in ddr4-2400) base=desktop ;; lpddr4-3200) base=mobile ;; gddr6) base=desktop-gpu ;; esac
      printf 'preset = "%s"\n[dram]\nchannels = 1\npage_policy = "open"\nqueue_entries = 32\n' "$base" >"$dir/config.toml"
      header "$part, one channel, open page, 32-entry queue"
      for bench in seq-read seq-read-saturated random-read row-conflict random-30pct-writes queue-burst; do
        row "$bench" "$dir/$bench.trace" "$dir/config.toml"
      done
    done
    ;;
  streams)
    # streams PRESET TRACE...: the traces' own preset. The trace's addresses carry the
    # channel as a bit field (rounded up to a power of two: 12 -> 16), so both models
    # get that many channels, the extra ones idle.
    preset=${1:?streams PRESET TRACE...}
    shift
    channels=$("$rtsim" dram-replay --print-dramsim3-ini --config "$preset" --trace /dev/null 2>/dev/null |
               sed -n 's/^channels = //p')
    # PAGE_POLICY=open: ours with DRAMsim3's policy (the presets' timeout has no DRAMsim3
    # counterpart).
    printf 'preset = "%s"\n[dram]\nchannels = %s\n' "$preset" "${channels:-1}" >"$work/streams.toml"
    [[ -z ${PAGE_POLICY:-} ]] || printf 'page_policy = "%s"\n' "$PAGE_POLICY" >>"$work/streams.toml"
    header "workload streams, $preset (page policy ${PAGE_POLICY:-of the preset}; channels = ${channels:-1})"
    for trace in "$@"; do row "$(basename "$trace" .trace)" "$trace" "$work/streams.toml"; done
    ;;
  *) echo "unknown mode '$mode' (micro | streams)" >&2; exit 2 ;;
esac
