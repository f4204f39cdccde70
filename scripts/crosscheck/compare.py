#!/usr/bin/env python3
"""One row of the crosscheck tables (docs/dram.md, "Checked against"): two
`rtsim dram-replay`-style JSON results, ours then the reference's.

    compare.py NAME OURS_JSON THEIRS_JSON

A figure a reference does not give (absent from its JSON) shows as n/a.
"""
import json, sys
name, a, b = sys.argv[1], json.loads(sys.argv[2]), json.loads(sys.argv[3])
keys = [('bandwidth_gbs', 'GB/s', 5), ('read_latency_mean_ns', 'mean', 10), ('read_latency_p50_ns', 'p50', None),
        ('read_latency_p99_ns', 'p99', None), ('row_hit_rate', 'row hit', 5), ('activates', 'ACT', None),
        ('refreshes', 'REF', None), ('write_latency_mean_ns', 'write', None)]
cells = []
for k, label, goal in keys:
    if k not in b:
        cells.append('%s/n/a' % (('%.3f' if k == 'row_hit_rate' else '%.1f' if isinstance(a[k], float) else '%d') % a[k]))
        continue
    x, y = a[k], b[k]
    if k == 'row_hit_rate':
        # in points: a relative difference of two rates near 0 says nothing
        d = (x - y) * 100
        cells.append('%.3f/%.3f (%+.1f pt%s)' % (x, y, d, '' if abs(d) <= goal else ' !'))
        continue
    d = (x - y) / y * 100 if y else 0.0
    mark = '' if goal is None or abs(d) <= goal else ' !'
    fmt = '%.1f' if isinstance(x, float) else '%d'
    cells.append((fmt % x) + '/' + (fmt % y) + ' (%+.0f%%%s)' % (d, mark))
print('| %s | %s |' % (name, ' | '.join(cells)))
