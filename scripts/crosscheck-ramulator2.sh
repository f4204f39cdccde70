#!/usr/bin/env bash
# Our DRAM model beside Ramulator 2 on the same requests (docs/dram.md, "Checked against").
#
#   scripts/crosscheck-ramulator2.sh RAMULATOR2_DIR [micro | streams PRESET TRACE...]
#
# RAMULATOR2_DIR: a checkout of CMU-SAFARI/ramulator2 that its own build has already
# made libramulator.so in (this script builds nothing of it and copies nothing from
# it); its Python package (RAMULATOR2_DIR/python) writes the configuration. The script
# compiles our replay driver (scripts/crosscheck/ramulator2_replay.cpp, C++20) against
# it in a scratch folder ($RTSIM_CROSSCHECK_DIR, default /tmp/rtsim-crosscheck), and
# our side runs `rtsim dram-replay` ($RTSIM_BUILD/rtsim, default build/rtsim).
#   micro    the microbenchmarks on ddr4-2400 (Ramulator's DDR4_8Gb_x8 + DDR4_2400U),
#            gddr6 (GDDR6_8Gb_x16 + GDDR6_14000_1350mV_double) and lpddr5
#            (LPDDR5_8Gb_x16 + LPDDR5_6400): one channel, open page, FR-FCFS, all-bank
#            refresh, 32 lines of read and write buffer each
#   streams PRESET TRACE...  traces of `simulate --dram-trace-out` with PRESET
#            (desktop-gpu or mobile-gpu: Ramulator has no LPDDR4 and its DDR4 stands
#            for desktop)
# Ramulator keeps its own part presets (ours were taken from the same files for gddr6
# and lpddr5); docs/dram.md lists where they differ.
set -euo pipefail
ref=${1:?usage: $0 RAMULATOR2_DIR [micro | streams PRESET TRACE...]}
mode=${2:-micro}
shift 2 || shift $#
here=$(cd "$(dirname "$0")/.." && pwd)
work=${RTSIM_CROSSCHECK_DIR:-/tmp/rtsim-crosscheck}
rtsim=${RTSIM_BUILD:-$here/build}/rtsim
if [[ ! -f $ref/src/ramulator/base/factory.h || ! -f $ref/libramulator.so ]]; then
  echo "$ref: not a built Ramulator 2 checkout (src/ramulator and libramulator.so, made by its own build)" >&2
  exit 2
fi
[[ -x $rtsim ]] || { echo "$rtsim: build rtsim first (or set RTSIM_BUILD)" >&2; exit 2; }
mkdir -p "$work"
driver=$work/ramulator2_replay
"${CXX:-c++}" -std=c++20 -O2 -I"$ref/src" "$here/scripts/crosscheck/ramulator2_replay.cpp" -o "$driver" \
  -L"$ref" -lramulator -lyaml-cpp -lfmt -Wl,-rpath,"$ref"

# Ramulator's configuration for a part, CHANNELS channels and BUFFER requests per buffer.
config() {  # part channels buffer out.yaml
  local part=$1 channels=$2 buffer=$3 out=$4
  cat >"$work/config.py" <<PY
import ramulator
part, channels, buffer = "$part", $channels, $buffer
frontend = ramulator.frontend.External(clock_ratio=1)
def controller():
    kind = ramulator.controller.GenericDDR
    if part == "ddr4-2400":
        dram = ramulator.dram.DDR4(org_preset="DDR4_8Gb_x8", timing_preset="DDR4_2400U", rank=1)
    elif part == "gddr6":
        dram = ramulator.dram.GDDR6(org_preset="GDDR6_8Gb_x16", timing_preset="GDDR6_14000_1350mV_double")
    else:
        dram = ramulator.dram.LPDDR5(org_preset="LPDDR5_8Gb_x16", timing_preset="LPDDR5_6400")
        kind = ramulator.controller.LPDDR5
    return kind(dram=dram, scheduler=ramulator.scheduler.FRFCFS(),
                refresh_manager=ramulator.refresh_manager.AllBank(), row_policy=ramulator.row_policy.Open(),
                addr_mapper=ramulator.addr_mapper.PassThroughAddrMapper(),
                read_buffer_size=buffer, write_buffer_size=buffer)
mem = ramulator.memory_system.GenericDRAM(clock_ratio=1, controllers=[controller() for _ in range(channels)],
    channel_mapper=ramulator.channel_mapper.PassThroughChannelMapper())
sim = ramulator.Simulation(frontend, mem)
PY
  PYTHONPATH="$ref/python" python3 -m ramulator export "$work/config.py" -o "$out" >/dev/null
}

# The driver's view of our mapping for a part: groups, banks per group, lines per row,
# has a rank level, transactions per line, row bits.
shape() {
  case $1 in
    ddr4-2400) echo "4 4 128 1 1 16" ;;
    gddr6) echo "4 4 32 0 2 14" ;;
    lpddr5) echo "4 4 32 1 2 15" ;;
  esac
}

row() {  # name trace our-config yaml part channel-bits
  read -r groups per cols rank splits rows <<<"$(shape "$5")"
  python3 "$here/scripts/crosscheck/compare.py" "$1" \
    "$("$rtsim" dram-replay --trace "$2" --config "$3")" \
    "$("$driver" "$4" "$2" "$groups" "$per" "$cols" "$6" "$rank" "$splits" "$rows")"
}

header() {
  echo
  echo "$1 (each cell: ours/Ramulator 2 (difference); ! past the goal: bandwidth 5%, row-hit rate 5 points,"
  echo "mean read latency 10%; Ramulator's activates are its row misses and conflicts, its refreshes its maintenance requests)"
  echo "| trace | GB/s | mean read ns | p50 ns | p99 ns | row-hit rate | activates | refreshes | mean write wait ns |"
  echo "|---|---|---|---|---|---|---|---|---|"
}

case $mode in
  micro)
    for part in ddr4-2400 gddr6 lpddr5; do
      dir=$work/micro-$part
      mkdir -p "$dir"
      python3 "$here/scripts/crosscheck/micro_traces.py" "$part" "$dir"
      case $part in ddr4-2400) base=desktop ;; gddr6) base=desktop-gpu ;; lpddr5) base=mobile-gpu ;; esac
      printf 'preset = "%s"\n[dram]\nchannels = 1\npage_policy = "open"\nqueue_entries = 32\n' "$base" >"$dir/config.toml"
      read -r _ _ _ _ splits _ <<<"$(shape $part)"
      config "$part" 1 $((32 * splits)) "$dir/ramulator2.yaml"
      header "$part, one channel, open page, 32-line queues"
      for bench in seq-read random-read row-conflict random-30pct-writes queue-burst; do
        row "$bench" "$dir/$bench.trace" "$dir/config.toml" "$dir/ramulator2.yaml" "$part" 0
      done
    done
    ;;
  streams)
    preset=${1:?streams PRESET TRACE...}
    shift
    case $preset in desktop-gpu) part=gddr6 ;; mobile-gpu) part=lpddr5 ;; desktop) part=ddr4-2400 ;;
      *) echo "streams: $preset has no Ramulator 2 part here (desktop, desktop-gpu, mobile-gpu)" >&2; exit 2 ;; esac
    # The trace's channel is a bit field: the preset's channels rounded up to a power of two.
    dram_key() { awk -v k="$1" '/^\[/{d = ($0 == "[dram]")} d && $1 == k {print $3}' "$here/model/presets/$preset.toml"; }
    channels=$(dram_key channels)
    pow=1; while (( pow < channels )); do pow=$((pow * 2)); done
    channels=$pow
    bits=0; while (( (1 << bits) < channels )); do bits=$((bits + 1)); done
    printf 'preset = "%s"\n[dram]\nchannels = %s\npage_policy = "open"\n' "$preset" "$channels" >"$work/streams.toml"
    queue=$(dram_key queue_entries)
    read -r _ _ _ _ splits _ <<<"$(shape $part)"
    config "$part" "$channels" $((queue * splits)) "$work/streams.yaml"
    header "workload streams, $preset (open page in both; channels = $channels; $queue-line queues)"
    for trace in "$@"; do row "$(basename "$trace" .trace)" "$trace" "$work/streams.toml" "$work/streams.yaml" "$part" "$bits"; done
    ;;
  *) echo "unknown mode '$mode' (micro | streams)" >&2; exit 2 ;;
esac
