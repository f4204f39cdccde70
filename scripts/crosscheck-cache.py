#!/usr/bin/env python3
"""Our caches beside pycachesim on the same accesses (docs/dram.md, "Checked against").

    scripts/crosscheck-cache.py [--touch-on-store] PYCACHESIM_DIR TRACE...

PYCACHESIM_DIR: a checkout of RRZE-HPC/pycachesim whose C backend its own build has
made (`python3 setup.py build_ext --inplace` there); this script builds nothing of it
and copies nothing from it. TRACE: written by `rtsim simulate --cache-trace CACHE
--cache-trace-out TRACE` (best at the functional level, which has no MSHR merges).

Each instance of the cache (every core's L1, every L2 slice) is replayed alone through
one pycachesim Cache of the same sets, ways and line size, LRU, write-back with write
allocate. Our write misses install the line without a fill and pycachesim's load it
first; either way the line is in the set afterwards, so hits, misses and dirty
evictions must be identical. An L2 slice holds every interleave-th line and indexes
its sets by line / interleave, so its lines are given to pycachesim as that index.
Prints one row per trace; exits 1 at the first access whose outcome differs.
"""
import sys
from collections import defaultdict


def main():
    if len(sys.argv) < 3:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    # --touch-on-store: a store to a present line first loads it, which makes it the
    # most recently used line. pycachesim's store only marks a present line dirty
    # and leaves its replacement order; our caches (and LRU as usually defined) count
    # a write as a use. With the flag the replay follows our policy.
    touch = '--touch-on-store' in sys.argv
    sys.argv = [a for a in sys.argv if a != '--touch-on-store']
    sys.path.insert(0, sys.argv[1])
    try:
        from cachesim import Cache, CacheSimulator, MainMemory
    except ImportError as e:
        print('%s: no built pycachesim there (%s)' % (sys.argv[1], e), file=sys.stderr)
        return 2
    print('| trace | cache | instances | accesses | hits (ours/pycachesim) | misses | dirty evictions | per access |')
    print('|---|---|---|---|---|---|---|---|')
    worst = 0
    for path in sys.argv[2:]:
        header = {}
        sims = {}
        ours = defaultdict(lambda: [0, 0])  # instance -> [hits, misses]
        theirs_first_diff = None
        accesses = 0
        their = [0, 0]  # hits, misses
        with open(path) as f:
            for n, line in enumerate(f, 1):
                if line.startswith('# '):
                    parts = line[2:].split(None, 1)
                    if len(parts) == 2:
                        header[parts[0]] = parts[1].strip()
                    continue
                if not sims and 'line_bytes' in header:
                    line_bytes = int(header['line_bytes'])
                    ways = int(header['associativity'])
                    sets = int(header['size_bytes']) // (line_bytes * ways)
                    interleave = int(header.get('interleave', '1'))
                    for i in range(int(header['instances'])):
                        mem = MainMemory()
                        c = Cache('c%d' % i, sets, ways, line_bytes, 'LRU', write_back=True,
                                  write_allocate=True)
                        mem.load_to(c)
                        mem.store_from(c)
                        sims[i] = (CacheSimulator(c, mem), c)
                instance, op, address, outcome = line.split()
                instance = int(instance)
                a = int(address, 16)
                a = (a // line_bytes) // interleave * line_bytes
                cs, c = sims[instance]
                # Its outcome: was the line there (pycachesim counts a store that covers
                # a present line as neither hit nor miss, so its counters are not used).
                hit = bool(c.contains(a))
                if op == 'W':
                    if touch and hit:
                        cs.load(a, length=line_bytes)
                    cs.store(a, length=line_bytes)
                else:
                    cs.load(a, length=line_bytes)
                their[0 if hit else 1] += 1
                accesses += 1
                ours[instance][0 if outcome == 'hit' else 1] += 1
                if (outcome == 'hit') != hit and theirs_first_diff is None:
                    theirs_first_diff = '%s:%d (%s: ours %s, pycachesim %s)' % (
                        path, n, line.strip(), outcome, 'hit' if hit else 'miss')
        our_hits = sum(v[0] for v in ours.values())
        our_misses = sum(v[1] for v in ours.values())
        their_hits, their_misses = their
        their_evicts = sum(c.EVICT_count for _, c in sims.values())
        our_evicts = header.get('writebacks', '?')
        print('| %s | %s | %d | %d | %d/%d | %d/%d | %s/%d | %s |' % (
            path.split('/')[-1], header.get('cache', '?'), len(sims), accesses, our_hits, their_hits,
            our_misses, their_misses, our_evicts, their_evicts,
            'identical' if theirs_first_diff is None else 'first difference ' + theirs_first_diff))
        if theirs_first_diff is not None or our_hits != their_hits or our_misses != their_misses:
            worst = 1
    return worst


if __name__ == '__main__':
    sys.exit(main())
