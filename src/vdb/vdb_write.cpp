// Writing .vdb files (tools and tests make their inputs with it).
#include <cerrno>
#include <cstring>
#include <fstream>

#include "vdb_internal.h"

using namespace leap_vdb_detail;

namespace leap_vdb_detail {

void write_vdb_file(const std::string &path, const vdb::GridCPtrVec &grids, bool record)
{
    // io::File's own writer is Archive's seekable one on an unchecked std::ofstream.
    struct SeekableWriter : vdb::io::Archive {
        void write_to(std::ostream &os, const vdb::GridCPtrVec &g) const { Archive::write(os, g, true); }
    };
    // Each grid with its scan recorded, on a copy that shares its tree.
    vdb::GridCPtrVec recorded;
    for (const vdb::GridBase::ConstPtr &g : grids) recorded.push_back(record ? with_recorded_scan(*g) : g);
    errno = 0;
    std::ofstream os(path, std::ios_base::out | std::ios_base::binary | std::ios_base::trunc);
    if (!os) throw std::runtime_error(std::strerror(errno ? errno : EIO));
    SeekableWriter().write_to(os, recorded);
    const int e = errno;
    if (os) os.close();
    if (!os) throw std::runtime_error(std::strerror(errno ? errno : e ? e : EIO));
}

} // namespace leap_vdb_detail

struct WriterGrid {
    vdb::GridBase::Ptr grid;
    leap_vdb_type type;
};

struct leap_vdb_writer {
    std::vector<WriterGrid> grids;
    std::string deferred_error; // first failure inside a void call, reported by save
};

namespace {

// Nearest int32 (NaN -> 0, out of range -> clamped), for writing label grids.
int32_t to_int32(double v)
{
    if (!std::isfinite(v)) return 0;
    v = std::min(std::max(std::round(v), double(INT32_MIN)), double(INT32_MAX));
    return int32_t(v);
}

// Nearest int64 (NaN -> 0, out of range -> clamped).
int64_t to_int64(double v)
{
    if (!std::isfinite(v)) return 0;
    v = std::round(v);
    if (v <= -9.2233720368547758e18) return INT64_MIN;
    if (v >= 9.2233720368547758e18) return INT64_MAX;
    return int64_t(v);
}

} // namespace

extern "C" {

leap_result leap_vdb_writer_create(leap_vdb_writer **out, leap_error *err)
{
    if (!out) return leap_fail(err, LEAP_ERR_USAGE, "leap_vdb_writer_create: NULL argument");
    *out = nullptr;
    return guarded(err, LEAP_ERR_OOM, "leap_vdb_writer_create", [&]() -> leap_result {
        init_openvdb();
        *out = new leap_vdb_writer;
        return LEAP_OK;
    });
}

void leap_vdb_writer_destroy(leap_vdb_writer *writer)
{
    delete writer;
}

int leap_vdb_writer_add_grid(leap_vdb_writer *writer, const char *name, leap_vdb_type type, double background,
                             const double index_to_world[4][4], int fog, leap_error *err)
{
    if (!writer || !name) {
        leap_fail(err, LEAP_ERR_USAGE, "leap_vdb_writer_add_grid: NULL argument");
        return -1;
    }
    if (index_to_world) {
        const double *last = index_to_world[3];
        if (last[0] != 0.0 || last[1] != 0.0 || last[2] != 0.0 || last[3] != 1.0) {
            leap_fail(err, LEAP_ERR_USAGE, "grid '%s': index_to_world is not affine (last row must be 0 0 0 1)", name);
            return -1;
        }
    }
    int handle = -1;
    leap_result r = guarded(err, LEAP_ERR_USAGE, std::string("grid '") + name + "'", [&]() -> leap_result {
        vdb::GridBase::Ptr g;
        switch (type) {
        case LEAP_VDB_FLOAT:
        case LEAP_VDB_HALF: g = vdb::FloatGrid::create(float(background)); break;
        case LEAP_VDB_DOUBLE: g = vdb::DoubleGrid::create(background); break;
        case LEAP_VDB_INT32: g = vdb::Int32Grid::create(to_int32(background)); break;
        case LEAP_VDB_INT64: g = vdb::Int64Grid::create(to_int64(background)); break;
        case LEAP_VDB_VEC3F: g = vdb::Vec3SGrid::create(vdb::Vec3s(float(background))); break;
        default: return leap_fail(err, LEAP_ERR_USAGE, "grid '%s': unknown value type %d", name, int(type));
        }
        g->setName(name);
        if (type == LEAP_VDB_HALF) g->setSaveFloatAsHalf(true);
        if (fog) g->setGridClass(vdb::GRID_FOG_VOLUME);
        if (index_to_world) {
            // OpenVDB multiplies row vectors from the left: its matrix is our transpose.
            vdb::math::Mat4d a;
            for (int r = 0; r < 4; ++r)
                for (int c = 0; c < 4; ++c) a(c, r) = index_to_world[r][c];
            g->setTransform(vdb::math::Transform::createLinearTransform(a));
        }
        writer->grids.push_back(WriterGrid{g, type});
        handle = int(writer->grids.size()) - 1;
        return LEAP_OK;
    });
    return r == LEAP_OK ? handle : -1;
}

} // extern "C"

namespace {

// Applies op(grid, value) with the grid cast to its concrete type and the value converted.
template <typename Op>
void with_typed(leap_vdb_writer *w, int grid, double value, Op op)
{
    if (!w || grid < 0 || grid >= int(w->grids.size())) return;
    const WriterGrid &g = w->grids[size_t(grid)];
    try {
        switch (g.type) {
        case LEAP_VDB_FLOAT:
        case LEAP_VDB_HALF: op(static_cast<vdb::FloatGrid &>(*g.grid), float(value)); break;
        case LEAP_VDB_DOUBLE: op(static_cast<vdb::DoubleGrid &>(*g.grid), value); break;
        case LEAP_VDB_INT32: op(static_cast<vdb::Int32Grid &>(*g.grid), to_int32(value)); break;
        case LEAP_VDB_INT64: op(static_cast<vdb::Int64Grid &>(*g.grid), to_int64(value)); break;
        case LEAP_VDB_VEC3F: op(static_cast<vdb::Vec3SGrid &>(*g.grid), vdb::Vec3s(float(value))); break;
        }
    } catch (const std::exception &e) {
        if (w->deferred_error.empty()) w->deferred_error = one_line(e.what());
    } catch (...) {
        if (w->deferred_error.empty()) w->deferred_error = "unknown error";
    }
}

} // namespace

extern "C" {

void leap_vdb_writer_set(leap_vdb_writer *writer, int grid, int32_t i, int32_t j, int32_t k, double value)
{
    with_typed(writer, grid, value, [&](auto &g, auto v) { g.tree().setValueOn(vdb::Coord(i, j, k), v); });
}

void leap_vdb_writer_set_label(leap_vdb_writer *writer, int grid, int32_t i, int32_t j, int32_t k, int64_t label)
{
    if (!writer || grid < 0 || grid >= int(writer->grids.size())) return;
    const WriterGrid &g = writer->grids[size_t(grid)];
    if (g.type == LEAP_VDB_INT64) static_cast<vdb::Int64Grid &>(*g.grid).tree().setValueOn(vdb::Coord(i, j, k), label);
    else leap_vdb_writer_set(writer, grid, i, j, k, double(label));
}

void leap_vdb_writer_set_indexed(leap_vdb_writer *writer, int grid, const int32_t min[3], const int32_t dim[3],
                                 const uint32_t *index, const int64_t *table)
{
    if (!writer || grid < 0 || grid >= int(writer->grids.size()) || !index || !table) return;
    const WriterGrid &g = writer->grids[size_t(grid)];
    try {
        auto fill = [&](auto &typed) {
            using V = typename std::decay_t<decltype(typed)>::ValueType;
            auto acc = typed.getAccessor();
            size_t n = 0;
            for (int32_t z = 0; z < dim[2]; ++z)
                for (int32_t y = 0; y < dim[1]; ++y)
                    for (int32_t x = 0; x < dim[0]; ++x, ++n)
                        if (index[n]) acc.setValueOn(vdb::Coord(min[0] + x, min[1] + y, min[2] + z), V(table[index[n]]));
        };
        if (g.type == LEAP_VDB_INT64) fill(static_cast<vdb::Int64Grid &>(*g.grid));
        else if (g.type == LEAP_VDB_INT32) fill(static_cast<vdb::Int32Grid &>(*g.grid));
        else if (writer->deferred_error.empty()) writer->deferred_error = "indexed labels need an int32 or int64 grid";
    } catch (const std::exception &e) {
        if (writer->deferred_error.empty()) writer->deferred_error = one_line(e.what());
    }
}

void leap_vdb_writer_fill(leap_vdb_writer *writer, int grid, const int32_t min[3], const int32_t max[3],
                          double value, int active)
{
    if (!min || !max) return;
    // OpenVDB's fill steps from root tile to root tile (4096 voxels) and overflows int32 past
    // the last one: boxes there are set voxel by voxel, if small enough.
    if (writer && (max[0] == INT32_MAX || max[1] == INT32_MAX || max[2] == INT32_MAX)) {
        // Coordinates at INT32_MAX itself overflow OpenVDB's own node arithmetic: refused.
        if (writer->deferred_error.empty()) writer->deferred_error = "fill box reaches INT32_MAX";
        return;
    }
    const int32_t last_root = INT32_MAX - 4095;
    if (max[0] >= last_root || max[1] >= last_root || max[2] >= last_root) {
        int64_t voxels = 1;
        for (int a = 0; a < 3; ++a) voxels *= max[a] >= min[a] ? (int64_t)max[a] - min[a] + 1 : 0;
        if (voxels > (1 << 24)) {
            if (writer && writer->deferred_error.empty())
                writer->deferred_error = "fill box near INT32_MAX is too large to set voxel by voxel";
            return;
        }
        with_typed(writer, grid, value, [&](auto &g, auto v) {
            auto acc = g.getAccessor();
            for (int64_t z = min[2]; z <= max[2]; ++z)
                for (int64_t y = min[1]; y <= max[1]; ++y)
                    for (int64_t x = min[0]; x <= max[0]; ++x) {
                        const vdb::Coord c((int32_t)x, (int32_t)y, (int32_t)z);
                        if (active) acc.setValueOn(c, v);
                        else acc.setValueOff(c, v);
                    }
        });
        return;
    }
    with_typed(writer, grid, value, [&](auto &g, auto v) {
        g.tree().fill(vdb::CoordBBox(min[0], min[1], min[2], max[0], max[1], max[2]), v, active != 0);
    });
}

leap_result leap_vdb_writer_save(leap_vdb_writer *writer, const char *path, leap_error *err)
{
    if (!writer || !path) return leap_fail(err, LEAP_ERR_USAGE, "leap_vdb_writer_save: NULL argument");
    if (!writer->deferred_error.empty())
        return leap_fail(err, LEAP_ERR_USAGE, "cannot write '%s': an earlier edit failed: %s", path,
                         writer->deferred_error.c_str());
    return guarded(err, LEAP_ERR_IO, std::string(path) + ": cannot write", [&]() -> leap_result {
        vdb::GridCPtrVec grids;
        for (const WriterGrid &g : writer->grids) grids.push_back(g.grid);
        write_vdb_file(path, grids);
        return LEAP_OK;
    });
}

} // extern "C"
