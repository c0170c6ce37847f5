# The histogram of a grid's active values, computed through OpenVDB's Python bindings as an
# independent reference for leap_grid_histogram: prints one count per bin.
# usage: python3 histogram.py FILE.vdb GRID LO HI BINS
import sys

import pyopenvdb

path, name, lo, hi, bins = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5])
counts = [0] * bins
for item in pyopenvdb.read(path, name).iterOnValues():
    v = float(item['value'])
    if lo <= v <= hi:
        t = (v - lo) / (hi - lo) * bins
        counts[bins - 1 if t >= bins else int(t)] += item['count']
print(' '.join(str(c) for c in counts))
