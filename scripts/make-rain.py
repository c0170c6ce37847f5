#!/usr/bin/python3
"""Writes a fragmented benchmark volume: N balls of radius R voxels scattered at random
(fixed seed) in a SIZE^3 box, as an OpenVDB float grid named 'density' (value 1 inside a
ball, inactive elsewhere; two corner voxels pin the bounding box to SIZE^3).

usage: scripts/make-rain.py OUT.vdb [SIZE=1024] [BALLS=2000] [RADIUS=3]

Needs Debian's python3-openvdb (run with /usr/bin/python3).
"""
import random
import sys

import pyopenvdb


def main():
    if len(sys.argv) < 2 or len(sys.argv) > 5:
        sys.exit(__doc__)
    out = sys.argv[1]
    size = int(sys.argv[2]) if len(sys.argv) > 2 else 1024
    balls = int(sys.argv[3]) if len(sys.argv) > 3 else 2000
    radius = int(sys.argv[4]) if len(sys.argv) > 4 else 3
    grid = pyopenvdb.FloatGrid(0.0)
    grid.name = "density"
    acc = grid.getAccessor()
    rng = random.Random(1)
    offsets = [(x, y, z) for x in range(-radius, radius + 1) for y in range(-radius, radius + 1)
               for z in range(-radius, radius + 1) if x * x + y * y + z * z <= radius * radius]
    for _ in range(balls):
        c = [rng.randint(radius, size - 1 - radius) for _ in range(3)]
        for x, y, z in offsets:
            acc.setValueOn((c[0] + x, c[1] + y, c[2] + z), 1.0)
    acc.setValueOn((0, 0, 0), 0.001)
    acc.setValueOn((size - 1, size - 1, size - 1), 0.001)
    pyopenvdb.write(out, grids=[grid])
    n = grid.activeVoxelCount()
    print(f"{out}: {size}^3 box, {balls} balls of radius {radius}, {n} active "
          f"({100.0 * n / size ** 3:.3f} %)")


if __name__ == "__main__":
    main()
