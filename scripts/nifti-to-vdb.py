#!/usr/bin/python3
"""Converts a NIfTI scan (.nii or .nii.gz) to an OpenVDB float grid named 'density', for
benchmarks on real data until leap opens NIfTI itself.

usage: scripts/nifti-to-vdb.py IN.nii.gz OUT.vdb

Needs Debian's python3-nibabel and python3-openvdb (run with /usr/bin/python3). Voxel (i,j,k)
of the NIfTI array becomes index (i,j,k) of the grid (nibabel's array is already x-fastest in
index order; no transpose). The grid's transform is the voxel size only (pixdim), not the
qform/sform rotation and origin. Values equal to the background (0) stay inactive; scl
slope/intercept are applied by nibabel.
"""
import sys

import nibabel
import numpy
import pyopenvdb


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    src, dst = sys.argv[1], sys.argv[2]
    image = nibabel.load(src)
    data = numpy.asarray(image.get_fdata(dtype=numpy.float32), dtype=numpy.float32)
    if data.ndim == 4:
        data = data[..., 0]
    if data.ndim != 3:
        sys.exit(f"{src}: expected a 3-D volume, got shape {data.shape}")
    data = numpy.nan_to_num(data, nan=0.0)
    grid = pyopenvdb.FloatGrid(0.0)
    grid.copyFromArray(numpy.ascontiguousarray(data), ijk=(0, 0, 0), tolerance=0.0)
    grid.name = "density"
    grid.gridClass = pyopenvdb.GridClass.FOG_VOLUME
    zooms = [float(z) for z in image.header.get_zooms()[:3]]
    if zooms[0] == zooms[1] == zooms[2]:
        grid.transform = pyopenvdb.createLinearTransform(voxelSize=zooms[0])
    else:
        m = [[zooms[0], 0, 0, 0], [0, zooms[1], 0, 0], [0, 0, zooms[2], 0], [0, 0, 0, 1]]
        grid.transform = pyopenvdb.createLinearTransform(m)
    pyopenvdb.write(dst, grids=[grid])
    print(f"{dst}: {data.shape[0]}x{data.shape[1]}x{data.shape[2]} voxels of {zooms}, "
          f"{grid.activeVoxelCount()} active, values {float(data.min())}..{float(data.max())}")


if __name__ == "__main__":
    main()
