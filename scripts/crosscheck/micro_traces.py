#!/usr/bin/env python3
"""The DRAM microbenchmarks of docs/dram.md ("Checked against") as dramsim3-format
traces of one channel, the fields encoded as our default mapping
row:rank:bank:column:bankgroup:channel lays them out (one rank, one channel).

    micro_traces.py PART OUT_DIR    (PART: ddr4-2400 | lpddr4-3200 | gddr6 | lpddr5)
"""
import random, sys
part, out = sys.argv[1:]
# part: (bank groups, banks per group, 64-byte lines in a row, peak lines per tCK, tRC in tCK)
org = {'ddr4-2400': (4, 4, 128, 1 / 4, 56), 'lpddr4-3200': (1, 8, 64, 1 / 8, 97), 'gddr6': (4, 4, 32, 1 / 4, 80),
       'lpddr5': (4, 4, 32, 1 / 4, 49)}[part]
groups, banks, cols, peak, trc = org
def addr(row, bank, col, group):
    # line offset 6 bits, then bankgroup, column, bank, row (one channel, one rank)
    a = group
    a = a * cols + col
    a = a * banks + bank
    a = a + row * (groups * cols * banks)
    return a << 6
n = 20000
rng = random.Random(37)
def write(name, reqs):
    with open('%s/%s.trace' % (out, name), 'w') as f:
        for cycle, a, w in reqs:
            f.write('0x%x %s %d\n' % (a, 'WRITE' if w else 'READ', cycle))
lines = groups * cols * banks * 4096
def seq_addr(i):
    # consecutive lines: bank groups, then columns, then banks, then rows
    return i << 6
gap_seq = int(round(1 / peak / 0.8))        # 80% of peak
gap_rand = int(round(1 / peak / 0.25))      # a quarter of peak
write('seq-read', [(i * gap_seq, seq_addr(i), False) for i in range(n)])
write('seq-read-saturated', [(0, seq_addr(i), False) for i in range(n)])
write('random-read', [(i * gap_rand, rng.randrange(lines) << 6, False) for i in range(n)])
# Every access a new row of one bank, at 80% of what tRC allows.
write('row-conflict', [(i * int(trc * 1.25), addr(i + 1, 0, 0, 0), False) for i in range(n // 4)])
write('random-30pct-writes', [(i * gap_rand, rng.randrange(lines) << 6, rng.random() < 0.3) for i in range(n)])
# Bursts that fill the queue: 256 random reads at once, every 4000 tCK.
write('queue-burst', [((i // 256) * 4000, rng.randrange(lines) << 6, False) for i in range(n // 4)])
