#!/usr/bin/python3
"""Writes a NIfTI-1 scan with uniform noise in [0, AMPLITUDE) added to every voxel, as a raw
float32 file (x fastest), and prints the `leap convert` line that makes it a .vdb: a scan whose
empty space is noise rather than one value, as scans come before their background is cleaned
(no cell of it is one value, so only the occupancy can skip it). Fixed seed: the same file
every time.

usage: scripts/add-noise.py SCAN.nii[.gz] OUT.raw [AMPLITUDE=4] [SEED=1]

Example (Debian mricron-data):
  scripts/add-noise.py /usr/share/mricron/templates/ch2.nii.gz ch2noisy.raw
"""
import array
import gzip
import random
import struct
import sys

TYPES = {2: "B", 4: "h", 16: "f", 512: "H"}  # NIfTI datatype -> array type


def main():
    if len(sys.argv) < 3 or len(sys.argv) > 5:
        sys.exit(__doc__)
    scan, out = sys.argv[1], sys.argv[2]
    amplitude = float(sys.argv[3]) if len(sys.argv) > 3 else 4.0
    rng = random.Random(int(sys.argv[4]) if len(sys.argv) > 4 else 1)
    opener = gzip.open if scan.endswith(".gz") else open
    with opener(scan, "rb") as f:
        data = f.read()
    if len(data) < 352 or struct.unpack("<i", data[0:4])[0] != 348:
        sys.exit(f"{scan}: not a little-endian NIfTI-1 file")
    dim = struct.unpack("<8h", data[40:56])
    datatype = struct.unpack("<h", data[70:72])[0]
    offset = int(struct.unpack("<f", data[108:112])[0])
    if datatype not in TYPES:
        sys.exit(f"{scan}: datatype {datatype} is not one of {sorted(TYPES)}")
    if dim[0] < 3 or any(d > 1 for d in dim[4:dim[0] + 1]):
        sys.exit(f"{scan}: not a single 3D volume (dim {dim})")
    nx, ny, nz = dim[1], dim[2], dim[3]
    voxels = array.array(TYPES[datatype])
    voxels.frombytes(data[offset:offset + nx * ny * nz * voxels.itemsize])
    if len(voxels) != nx * ny * nz:
        sys.exit(f"{scan}: the file ends before its {nx * ny * nz} voxels")
    noisy = array.array("f", (v + amplitude * rng.random() for v in voxels))
    with open(out, "wb") as f:
        noisy.tofile(f)
    print(f"leap convert {out} --raw {nx}x{ny}x{nz}:float32 -o OUT.vdb")


if __name__ == "__main__":
    main()
