// Grids made from dense boxes of voxels (imported formats), and loaded grids written back
// as .vdb files (leap convert).
#include "vdb_internal.h"

#include <openvdb/tools/Dense.h>

#include "leap/files.h"

using namespace leap_vdb_detail;

namespace {

// OpenVDB multiplies row vectors from the left: its matrix is our transpose.
vdb::math::Transform::Ptr make_transform(const double m[4][4])
{
    vdb::math::Mat4d a;
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) a(c, r) = m[r][c];
    return vdb::math::Transform::createLinearTransform(a);
}

// A grid from voxels read a layer of leaves at a time (leap_dense_volume.read_planes): each
// layer's blocks are whole leaves, so the layers copy to the leaves and tiles one copy of the
// whole box would make.
template <typename GridT>
typename GridT::Ptr copy_planes(const leap_dense_volume &v)
{
    using V = typename GridT::ValueType;
    typename GridT::Ptr grid = GridT::create(V(v.background));
    std::vector<V> layer((size_t)v.dim[0] * (size_t)v.dim[1] * LEAP_DENSE_PLANES);
    for (int32_t z0 = 0; z0 < v.dim[2]; z0 += LEAP_DENSE_PLANES) {
        const int32_t nz = std::min<int32_t>(LEAP_DENSE_PLANES, v.dim[2] - z0);
        v.read_planes(v.ctx, z0, nz, layer.data());
        const vdb::CoordBBox box(vdb::Coord(0, 0, z0), vdb::Coord(v.dim[0] - 1, v.dim[1] - 1, z0 + nz - 1));
        // LayoutXYZ: x varies fastest (Dense's "XYZ" names the order of the strides' sizes).
        vdb::tools::Dense<V, vdb::tools::LayoutXYZ> dense(box, layer.data());
        // Tolerance 0: exactly the voxels equal to the background become inactive; constant
        // blocks become tiles.
        vdb::tools::copyFromDense(dense, *grid, V(0));
    }
    return grid;
}

} // namespace

namespace leap_vdb_detail {

vdb::GridBase::Ptr dense_to_grid(const leap_dense_volume &v)
{
    vdb::GridBase::Ptr grid;
    if (v.labels) grid = copy_planes<vdb::Int64Grid>(v);
    else grid = copy_planes<vdb::FloatGrid>(v);
    grid->setTransform(make_transform(v.index_to_world));
    grid->setName(v.grid_name && *v.grid_name ? v.grid_name : (v.labels ? "labels" : "density"));
    return grid;
}

} // namespace leap_vdb_detail

extern "C" {

static leap_result save(const leap_grid *grid, const double up[3], const char *path, bool record, leap_error *err)
{
    if (!grid || !path) return leap_fail(err, LEAP_ERR_USAGE, "leap_grid_save: NULL argument");
    leap_publish pub;
    leap_result r = leap_publish_begin(&pub, path, err);
    if (r) return r;
    r = guarded(err, LEAP_ERR_IO, std::string(path) + ": cannot write", [&]() -> leap_result {
        init_openvdb();
        vdb::GridBase::Ptr out;
        if (grid->labels) {
            out = vdb::Int64Grid::create(grid->labels);
            out->setTransform(grid->grid->constTransform().copy());
        } else {
            out = grid->grid->copyGrid(); // shares the tree: only the name is its own
        }
        out->setName(grid->info.name);
        if (up) out->insertMeta("up", vdb::Vec3DMetadata(vdb::Vec3d(up[0], up[1], up[2])));
        vdb::GridCPtrVec grids{out};
        write_vdb_file(pub.tmp, grids, record);
        return LEAP_OK;
    });
    if (r) {
        leap_publish_abort(&pub);
        return r;
    }
    return leap_publish_commit(&pub, err);
}

leap_result leap_grid_save(const leap_grid *grid, const double up[3], const char *path, leap_error *err)
{
    return save(grid, up, path, true, err);
}

leap_result leap_grid_save_unrecorded(const leap_grid *grid, const double up[3], const char *path, leap_error *err)
{
    return save(grid, up, path, false, err);
}

} // extern "C"
