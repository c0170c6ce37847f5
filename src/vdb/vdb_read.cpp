// OpenVDB behind the C API of include/leap/vdb.h: opening files and loading grids. No C++
// exception leaves the shim: every extern "C" function catches at its boundary and reports
// through leap_error.
#include "vdb_internal.h"

#include <openvdb/tools/Count.h>

#include <chrono>
#include <thread>

namespace leap_vdb_detail {

void init_openvdb()
{
    static std::once_flag once;
    std::call_once(once, [] {
        vdb::initialize();
        // Delayed-load metadata only speeds up delayed loading (which then steps over each
        // leaf's data by its stored size), and its reader sizes buffers from counts in the file
        // without checking them. As an unregistered type it is read as opaque bytes of a
        // checked length (and dropped).
        if (vdb::Metadata::isRegisteredType("__delayedload")) vdb::Metadata::unregisterType("__delayedload");
    });
}

std::string one_line(const char *s)
{
    std::string out = s ? s : "unknown error";
    std::replace(out.begin(), out.end(), '\n', ' ');
    return out;
}

} // namespace leap_vdb_detail

using namespace leap_vdb_detail;

extern "C" void leap_vdb_init(void)
{
    init_openvdb();
    tbb::parallel_for(0, 2, [](int) {}); // the pool's first use loads its allocator library
}

namespace {

void copy_str(char *dst, size_t cap, const std::string &s)
{
    std::snprintf(dst, cap, "%s", s.c_str());
}

bool is_scalar_type(const std::string &t)
{
    return t == "float" || t == "double" || t == "int32" || t == "int64";
}

// Row-major column-vector matrix (world = M * (i,j,k,1)) from an OpenVDB transform.
// OpenVDB's Mat4d uses row vectors (world = (i,j,k,1) * A), so M = A^T.
void transform_to_info(const vdb::math::Transform &xf, leap_grid_info *info)
{
    const vdb::math::Mat4d a = xf.baseMap()->getAffineMap()->getMat4();
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) info->index_to_world[r][c] = a(c, r);
    for (int axis = 0; axis < 3; ++axis) {
        double s = 0.0;
        for (int r = 0; r < 3; ++r) s += info->index_to_world[r][axis] * info->index_to_world[r][axis];
        info->voxel_size[axis] = std::sqrt(s);
    }
}

void meta_to_info(const vdb::GridBase &g, const std::string &name, leap_grid_info *info)
{
    copy_str(info->name, sizeof info->name, name);
    copy_str(info->value_type, sizeof info->value_type, g.valueType());
    copy_str(info->grid_class, sizeof info->grid_class,
             vdb::GridBase::gridClassToString(g.getGridClass()));
    info->scalar = is_scalar_type(g.valueType());
    info->labels = g.valueType() == "int32" || g.valueType() == "int64";
    info->saved_as_half = g.valueType() == "float" && g.saveFloatAsHalf();
    transform_to_info(g.constTransform(), info);
    if (auto up = g.getMetadata<vdb::Vec3DMetadata>("up")) {
        const vdb::Vec3d u = up->value();
        if (std::isfinite(u[0]) && std::isfinite(u[1]) && std::isfinite(u[2]) && u.lengthSqr() > 0)
            for (int a = 0; a < 3; ++a) info->up[a] = u[a];
    }
    info->bbox_min[0] = info->bbox_min[1] = info->bbox_min[2] = 0;
    info->bbox_max[0] = info->bbox_max[1] = info->bbox_max[2] = -1;
}

// Background of a scalar grid as float (how every scalar type is presented).
bool scalar_background(const vdb::GridBase &g, double *out)
{
    if (auto f = dynamic_cast<const vdb::FloatGrid *>(&g)) *out = f->background();
    else if (auto d = dynamic_cast<const vdb::DoubleGrid *>(&g)) *out = float(d->background());
    else if (auto i = dynamic_cast<const vdb::Int32Grid *>(&g)) *out = float(i->background());
    else if (auto l = dynamic_cast<const vdb::Int64Grid *>(&g)) *out = float(l->background());
    else return false;
    return true;
}

// A .vdb file read with OpenVDB's own readers (io::File keeps them private and sorts grids by
// name), after the checks above, through streams that throw at the first failed read:
// OpenVDB's tree readers do not check the stream and would go on building nodes from a
// failed one.
class VdbReader : public vdb::io::Archive {
public:
    VdbReader(const std::string &path, uint64_t size) : path_(path), size_(size) {}

    // Checks the structure, then reads the descriptors in file order and, for a file without
    // grid offsets (written to a stream), every grid.
    void open(std::vector<vdb::io::GridDescriptor> &descs, std::vector<vdb::GridBase::Ptr> &streamed)
    {
        const FileBytes m(path_, size_);
        Walker w(m, 0, size_);
        uint32_t version = 0;
        const bool offsets = walk_header(w, &version);
        walk_metamap(w, "file metadata");
        const int32_t count = w.value<int32_t>("grid count");
        if (count < 0) throw Corrupt("corrupt grid count " + std::to_string(count));
        if (offsets) {
            for (int i = 0; i < count; ++i) {
                int64_t pos[3];
                bool instance = false;
                const std::string label = walk_descriptor(w, i, pos, &instance);
                // grid start <= tree data start <= end (an instance stores no tree: 0 there)
                if (pos[0] < int64_t(w.pos()) || pos[2] < pos[0] ||
                    (!(instance && pos[1] == 0) && (pos[1] < pos[0] || pos[2] < pos[1])))
                    throw Corrupt("corrupt grid table (" + label + ")");
                if (uint64_t(pos[2]) > size_)
                    throw Corrupt("truncated: " + label + " ends at byte " + std::to_string(pos[2]) +
                                  " but the file has " + std::to_string(size_) + " bytes");
                Walker g(m, uint64_t(pos[0]), uint64_t(pos[2]));
                walk_grid_prefix(g, label);
                w.seek(uint64_t(pos[2]));
            }
        }

        Stream s;
        start(s);
        vdb::MetaMap file_meta;
        file_meta.readMeta(s.is);
        if (readGridCount(s.is) != count) throw Corrupt("grid count changed while reading");
        for (int i = 0; i < count; ++i) {
            const uint64_t at = uint64_t(s.is.tellg());
            std::string label;
            if (!offsets) {
                // Each grid follows its descriptor; check both where they start.
                Walker g(m, at, size_);
                int64_t pos[3];
                bool instance = false;
                label = walk_descriptor(g, i, pos, &instance);
                walk_grid_prefix(g, label);
            }
            vdb::io::GridDescriptor gd;
            gd.read(s.is);
            descs.push_back(gd);
            if (offsets) {
                gd.seekToEnd(s.is);
                continue;
            }
            const uint64_t grid_pos = uint64_t(s.is.tellg());
            if (!gd.isInstance()) check_tree(m, gd, grid_pos, size_, label + " tree", true);
            vdb::GridBase::Ptr grid = new_grid(gd);
            readGrid(grid, gd, s.is);
            if (gd.isInstance()) {
                const int parent = find_parent(descs, gd);
                grid->setTree(streamed[size_t(parent)]->baseTreePtr());
            }
            streamed.push_back(grid);
        }
    }

    enum class Part { meta, topology, all };

    // Grid `gd` of this file: its metadata and transform, those and its topology (no leaf
    // values; a grid that is no instance), or everything. After the topology, `stream` gets the
    // stream's state (versions, compression, half floats, the tree's background), which reads of
    // a leaf's values take on.
    vdb::GridBase::Ptr read(const vdb::io::GridDescriptor &gd, Part part, vdb::io::StreamMetadata::Ptr *stream = nullptr)
    {
        if (part == Part::all) check(gd);
        Stream s;
        start(s);
        gd.seekToGrid(s.is);
        vdb::GridBase::Ptr grid = new_grid(gd);
        if (part == Part::all) {
            readGrid(grid, gd, s.is);
            return grid;
        }
        s.meta->setHalfFloat(gd.saveFloatAsHalf());
        readGridCompression(s.is);
        grid->readMeta(s.is);
        // Files older than grid instancing keep the transform after the topology.
        const bool transform_first = vdb::io::getFormatVersion(s.is) >= vdb::OPENVDB_FILE_VERSION_GRID_INSTANCING;
        if (transform_first || part == Part::meta) grid->readTransform(s.is);
        if (part == Part::topology) {
            grid->readTopology(s.is);
            if (!transform_first) grid->readTransform(s.is);
            if (stream) *stream = s.meta;
        }
        return grid;
    }

    // Checks the bytes of grid `gd`'s tree before OpenVDB reads them; `leaf_offsets` (when
    // given) gets where each leaf's values start (check_tree_data).
    void check(const vdb::io::GridDescriptor &gd, std::vector<uint64_t> *leaf_offsets = nullptr)
    {
        if (gd.isInstance()) return;
        const FileBytes m(path_, size_);
        check_tree(m, gd, uint64_t(gd.getGridPos()), uint64_t(gd.getEndPos()), "tree", false, leaf_offsets);
    }

    // Index of the instance parent of `gd` among `descs` (a grid that is no instance itself).
    static int find_parent(const std::vector<vdb::io::GridDescriptor> &descs, const vdb::io::GridDescriptor &gd)
    {
        for (size_t i = 0; i < descs.size(); ++i)
            if (descs[i].uniqueName() == gd.instanceParentName() && !descs[i].isInstance()) return int(i);
        throw Corrupt("grid '" + printable(vdb::io::GridDescriptor::nameAsString(gd.uniqueName())) +
                      "' is an instance of a missing grid: corrupt file");
    }

private:
    struct Stream {
        std::ifstream is;
        vdb::io::StreamMetadata::Ptr meta; // the stream holds its address
    };

    // Opens the file and tags the stream as io::File::open does.
    void start(Stream &s)
    {
        s.is.open(path_, std::ios_base::in | std::ios_base::binary);
        if (!s.is) OPENVDB_THROW(vdb::IoError, "cannot open the file");
        s.is.exceptions(std::ios_base::failbit | std::ios_base::badbit);
        readHeader(s.is);
        s.meta.reset(new vdb::io::StreamMetadata);
        s.meta->setSeekable(true);
        vdb::io::setStreamMetadataPtr(s.is, s.meta, /*transfer=*/false);
        setFormatVersion(s.is);
        setLibraryVersion(s.is);
        setDataCompression(s.is);
    }

    // Checks the tree of the grid that starts at `grid_pos` (its compression flags) and must
    // end by `limit`. The tree starts after the metadata and transform, whose extent OpenVDB
    // finds by reading them (already checked by walk_grid_prefix). `any_type`: a tree this
    // check does not know is an error (a file without offsets is read whole) rather than
    // left unread.
    void check_tree(const FileBytes &m, const vdb::io::GridDescriptor &gd, uint64_t grid_pos, uint64_t limit,
                    const std::string &label, bool any_type, std::vector<uint64_t> *leaf_offsets = nullptr)
    {
        const TreeFormat format = tree_format(gd.gridType(), gd.saveFloatAsHalf());
        if (!format.full) {
            if (any_type)
                throw Corrupt(label + " has grid type " + printable(gd.gridType()) +
                              ", which leap cannot check in a file without grid offsets");
            OPENVDB_THROW(vdb::TypeError, label << " has unsupported tree type " << gd.gridType());
        }
        Stream s;
        start(s);
        s.is.seekg(std::streamoff(grid_pos));
        readGridCompression(s.is);
        const uint32_t compression = vdb::io::getDataCompression(s.is);
        vdb::GridBase::Ptr meta = new_grid(gd);
        meta->readMeta(s.is);
        meta->readTransform(s.is);
        Walker w(m, uint64_t(s.is.tellg()), limit, label + " ");
        check_tree_data(w, format, compression, leaf_offsets);
    }

    static vdb::GridBase::Ptr new_grid(const vdb::io::GridDescriptor &gd)
    {
        vdb::GridBase::Ptr grid = vdb::GridBase::createGrid(gd.gridType());
        grid->setSaveFloatAsHalf(gd.saveFloatAsHalf());
        return grid;
    }

    std::string path_;
    uint64_t size_;
};

// Converts a double/int32 grid into a float tree of the same topology, tiles and background.
template <typename GridT>
FloatTree::Ptr convert_tree(const vdb::GridBase &g)
{
    const GridT &src = static_cast<const GridT &>(g);
    return FloatTree::Ptr(new FloatTree(src.tree()));
}

} // namespace

namespace leap_vdb_detail {

Scan scan_leaves(const FloatTree &tree)
{
    std::vector<const LeafT *> leaves;
    leaves.reserve(tree.leafCount());
    for (auto it = tree.cbeginLeaf(); it; ++it) leaves.push_back(it.getLeaf());
    using Blocks = tbb::blocked_range<size_t>;
    return tbb::parallel_reduce(
        Blocks(0, leaves.size(), 64), Scan(),
        [&](const Blocks &r, Scan s) {
            for (size_t i = r.begin(); i != r.end(); ++i) {
                s.add_leaf(leaves[i]->buffer().data(), leaves[i]->getValueMask());
            }
            return s;
        },
        [](Scan a, const Scan &b) {
            a.merge(b);
            return a;
        });
}

leap_grid_scan scan_summary(const Scan &s, uint64_t leaves)
{
    leap_grid_scan k{};
    k.leaf_count = leaves;
    k.nonfinite = s.nonfinite;
    k.stored_min = s.all.lo, k.stored_max = s.all.hi;
    k.active_min = s.active.lo, k.active_max = s.active.hi;
    k.active_nan = s.active_nan, k.active_pinf = s.active_pinf, k.active_ninf = s.active_ninf;
    return k;
}

bool recorded_scan(const vdb::GridBase &g, leap_grid_scan *out)
{
    // [leaves, non-finite values, stored min, stored max, active min, active max, active NaN,
    // +Inf, -Inf], as doubles: each count below 2^53, each float exact.
    const auto m = g.getMetadata<vdb::StringMetadata>(SCAN_META);
    if (!m) return false;
    double f[9];
    if (std::sscanf(m->value().c_str(), "%la %la %la %la %la %la %la %la %la", &f[0], &f[1], &f[2], &f[3], &f[4], &f[5],
                    &f[6], &f[7], &f[8]) != 9)
        return false;
    for (int i : {0, 1, 6, 7, 8})
        if (!(f[i] >= 0 && f[i] < 9007199254740992.0) || f[i] != std::floor(f[i])) return false;
    for (int i : {2, 3, 4, 5})
        if (std::isnan(f[i]) || double(float(f[i])) != f[i]) return false;
    if (f[6] > 1 || f[7] > 1 || f[8] > 1) return false;
    leap_grid_scan k{};
    k.leaf_count = uint64_t(f[0]);
    k.nonfinite = uint64_t(f[1]);
    k.stored_min = float(f[2]), k.stored_max = float(f[3]);
    k.active_min = float(f[4]), k.active_max = float(f[5]);
    k.active_nan = int32_t(f[6]), k.active_pinf = int32_t(f[7]), k.active_ninf = int32_t(f[8]);
    *out = k;
    return true;
}

std::string scan_record(const leap_grid_scan &k)
{
    char s[512];
    std::snprintf(s, sizeof s, "%a %a %a %a %a %a %a %a %a", double(k.leaf_count), double(k.nonfinite),
                  double(k.stored_min), double(k.stored_max), double(k.active_min), double(k.active_max),
                  double(k.active_nan), double(k.active_pinf), double(k.active_ninf));
    return s;
}

bool same_scan(const leap_grid_scan &a, const leap_grid_scan &b)
{
    return scan_record(a) == scan_record(b);
}

vdb::GridBase::ConstPtr with_recorded_scan(const vdb::GridBase &g)
{
    vdb::MetaMap meta(g);
    meta.removeMeta(SCAN_META);
    const auto *fg = dynamic_cast<const vdb::FloatGrid *>(&g);
    // A non-finite background is replaced as the grid is loaded, values that equal it too.
    if (fg && !fg->saveFloatAsHalf() && std::isfinite(fg->background()))
        meta.insertMeta(SCAN_META, vdb::StringMetadata(scan_record(
                                       scan_summary(scan_leaves(fg->tree()), fg->tree().leafCount()))));
    return g.copyGridReplacingMetadata(meta);
}

bool leaf_fits_scan(const float *v, const LeafT::NodeMaskType &active, const leap_grid_scan &k)
{
    Scan s;
    s.add_leaf(v, active);
    const auto within = [](const Range &r, float lo, float hi) { return r.empty() || (r.lo >= lo && r.hi <= hi); };
    return within(s.all, k.stored_min, k.stored_max) && within(s.active, k.active_min, k.active_max) &&
           (s.nonfinite == 0 || k.nonfinite > 0) && (!s.active_nan || k.active_nan) &&
           (!s.active_pinf || k.active_pinf) && (!s.active_ninf || k.active_ninf);
}

} // namespace leap_vdb_detail

namespace {

Scan scan_from(const leap_grid_scan &k)
{
    Scan s;
    s.nonfinite = k.nonfinite;
    s.all.lo = k.stored_min, s.all.hi = k.stored_max;
    s.active.lo = k.active_min, s.active.hi = k.active_max;
    s.active_nan = k.active_nan, s.active_pinf = k.active_pinf, s.active_ninf = k.active_ninf;
    return s;
}

// Adds a leaf's values to its LeafShell and its sides to those of its neighbour leaves whose
// bricks' aprons reach them, and keeps its low sides for the atlas cells' footprints (CellParts).
// The values are binned by (x, y, z) class (0 the first layer, 2 the last, 1 between); the side
// facing the neighbour at offset d in {-1, 0, 1}^3 is the union of some bins.
void gather_sides(const RootT &root, const LeafNumbers &numbers, const LeafT &leaf, uint32_t number,
                   const float *v, bool finite, LeafShell *shells, CellParts &cell)
{
    Range part[27];
    uint32_t seen[27] = {0};
    constexpr int last = int(LeafT::DIM) - 1;
    auto cls = [](int i) { return i == 0 ? 0 : i == last ? 2 : 1; };
    for (int x = 0; x <= last; ++x)
        for (int y = 0; y <= last; ++y) {
            const int bin_xy = cls(x) * 9 + cls(y) * 3;
            const float *row = v + (x << (2 * LeafT::LOG2DIM)) + (y << LeafT::LOG2DIM);
            if (finite) { // the common case, without a branch per value
                float lo = row[1], hi = row[1];
                for (int z = 2; z < last; ++z) lo = std::min(lo, row[z]), hi = std::max(hi, row[z]);
                part[bin_xy].add(row[0]);
                part[bin_xy + 1].add(Range{lo, hi});
                part[bin_xy + 2].add(row[last]);
                continue;
            }
            for (int z = 0; z <= last; ++z) {
                const int bin = bin_xy + cls(z);
                const float f = row[z];
                if (std::isfinite(f)) part[bin].add(f);
                else seen[bin] |= std::isnan(f) ? LeafShell::NAN_SEEN : f > 0 ? LeafShell::PINF_SEEN : LeafShell::NINF_SEEN;
            }
        }
    // The side facing offset d: class 0 on an axis where d is -1, 2 where +1, any where 0.
    const vdb::Coord o = leaf.origin();
    for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dz = -1; dz <= 1; ++dz) {
                const int d[3] = {dx, dy, dz};
                const bool low = dx <= 0 && dy <= 0 && dz <= 0; // a low side: kept for the cells
                int64_t to = number;
                if (dx || dy || dz) {
                    int64_t c[3];
                    bool inside = true;
                    for (int a = 0; a < 3; ++a) {
                        c[a] = int64_t(o[a]) + int64_t(d[a]) * LeafT::DIM;
                        inside &= c[a] >= std::numeric_limits<int32_t>::min() && c[a] <= std::numeric_limits<int32_t>::max();
                    }
                    // No leaf there: a tile or the background, from the topology when listed.
                    to = inside ? numbers.at(root, vdb::Coord(int(c[0]), int(c[1]), int(c[2]))) : -1;
                    if (to < 0 && !low) continue;
                }
                Range r;
                uint32_t s = 0;
                for (int b = 0; b < 27; ++b) {
                    const int bc[3] = {b / 9, b / 3 % 3, b % 3};
                    bool in = true;
                    for (int a = 0; a < 3; ++a) in &= d[a] == 0 || bc[a] == (d[a] < 0 ? 0 : 2);
                    if (in) r.add(part[b]), s |= seen[b];
                }
                if (low) cell.part[-dx - 2 * dy - 4 * dz] = r;
                if (to >= 0) shells[to].add(r, s);
            }
}

// Completes a loaded grid: maps non-finite values, finds the value ranges, tiles, counts and
// bounds. A grid read on demand reads each leaf once here, into a copy, unless `known` says
// what that finds.
void scan_grid(leap_grid &g, const leap_grid_scan *known, const leap_grid_scan *recorded)
{
    OnDemand *od = g.on_demand.get();
    FloatTree &tree = g.grid->tree();

    uint64_t nonfinite = 0;
    float bg = tree.background();
    if (!std::isfinite(bg)) {
        // Nothing can stand in for a non-finite background; 0 is the neutral choice.
        ++nonfinite;
        if (od) {
            od->stored_background = bg;
            od->reset_background = true;
        }
        bg = 0.0f;
        tree.root().setBackground(bg, /*updateChildNodes=*/od == nullptr);
        if (od) { // the tiles as updateChildNodes sets them; leaves in the file as they are read
            auto off = tree.beginValueOff();
            off.setMaxDepth(off.getLeafDepth() - 1);
            for (; off; ++off) {
                if (vdb::math::isApproxEqual(*off, od->stored_background)) off.setValue(bg);
                else if (vdb::math::isApproxEqual(*off, -od->stored_background)) off.setValue(-bg);
            }
        }
    }
    if (od) od->background = bg;

    std::vector<LeafT *> leaves;
    leaves.reserve(tree.leafCount());
    for (auto it = tree.beginLeaf(); it; ++it) leaves.push_back(it.getLeaf());

    if (known && known->leaf_count != leaves.size())
        OPENVDB_THROW(vdb::IoError, "its index lists " << known->leaf_count << " leaves, the file " << leaves.size());
    using Blocks = tbb::blocked_range<size_t>;
    // A first open on demand gathers the bricks' ranges (LeafShell) and the atlas cells'
    // footprints (CellParts) as it reads.
    if (od && !known) {
        od->shells.reset(new LeafShell[leaves.size() ? leaves.size() : 1]);
        od->cell_parts.resize(leaves.size());
        od->numbers.reset(new LeafNumbers(tree));
    }
    const RootT &root = tree.root();
    Scan scan = known ? scan_from(*known) : tbb::parallel_reduce(
        Blocks(0, leaves.size(), 64), Scan(),
        [&](const Blocks &r, Scan s) {
            std::unique_ptr<LeafT> copy;
            for (size_t i = r.begin(); i != r.end(); ++i) {
                const LeafT &leaf = *leaves[i];
                if (od) od->read(leaf, copy);
                const float *v = od ? copy->buffer().data() : leaf.buffer().data();
                const uint64_t nonfinite = s.nonfinite;
                s.add_leaf(v, leaf.getValueMask());
                if (od)
                    gather_sides(root, *od->numbers, leaf, uint32_t(i), v, s.nonfinite == nonfinite, od->shells.get(),
                                 od->cell_parts[i]);
            }
            return s;
        },
        [](Scan a, const Scan &b) {
            a.merge(b);
            return a;
        });

    if (!known && recorded && !same_scan(scan_summary(scan, leaves.size()), *recorded))
        OPENVDB_THROW(vdb::IoError, "its leaves do not hold the values its metadata records for them (it was changed "
                                    "after leap wrote it, its metadata kept): `leap convert` it again");
    if (od && scan.nonfinite) od->cell_parts = std::vector<CellParts>(); // footprints read, values mapped
    if (od) g.scan = scan_summary(scan, leaves.size());

    // Tiles at every level (leaf depth excluded), active or not.
    auto tile_iter = tree.beginValueAll();
    tile_iter.setMaxDepth(tile_iter.getLeafDepth() - 1);
    for (auto it = tile_iter; it; ++it) scan.add(*it, it.isValueOn());

    nonfinite += scan.nonfinite;
    Range finite = scan.all;
    if (finite.empty()) finite.add(bg);
    if (scan.nonfinite > 0 && od) {
        od->finite = finite; // leaves in the file are mapped as they are read
        od->nonfinite = true;
    } else if (scan.nonfinite > 0) {
        tbb::parallel_for(Blocks(0, leaves.size(), 64), [&](const Blocks &r) {
            for (size_t i = r.begin(); i != r.end(); ++i) {
                float *v = leaves[i]->buffer().data();
                for (vdb::Index n = 0; n < LeafT::SIZE; ++n) v[n] = sanitize(v[n], bg, finite);
            }
        });
    }
    if (scan.nonfinite > 0) {
        for (auto it = tile_iter; it; ++it)
            if (!std::isfinite(*it)) it.setValue(sanitize(*it, bg, finite));
    }

    Range values = scan.active;
    if (scan.active_nan) values.add(bg);
    if (scan.active_pinf) values.add(finite.hi);
    if (scan.active_ninf) values.add(finite.lo);

    leap_grid_info &info = g.info;
    info.background = bg;
    info.nonfinite_values = nonfinite;
    info.leaf_count = leaves.size();
    auto on_tiles = tree.cbeginValueOn();
    on_tiles.setMaxDepth(on_tiles.getLeafDepth() - 1);
    for (auto it = on_tiles; it; ++it) {
        vdb::CoordBBox bb;
        it.getBoundingBox(bb);
        const int level = int(it.getLevel()) - 1;
        if (level < 0 || level >= LEAP_TILE_LEVELS) continue;
        ++info.active_tiles[level];
        g.tiles.push_back(TileRec{bb.min(), level, *it});
    }
    info.active_voxels = tree.activeVoxelCount();
    if (info.active_voxels > 0) {
        vdb::CoordBBox bb;
        tree.evalActiveVoxelBoundingBox(bb);
        for (int a = 0; a < 3; ++a) {
            info.bbox_min[a] = bb.min()[a];
            info.bbox_max[a] = bb.max()[a];
        }
    } else {
        info.bbox_min[0] = info.bbox_min[1] = info.bbox_min[2] = 0;
        info.bbox_max[0] = info.bbox_max[1] = info.bbox_max[2] = -1;
    }
    info.value_min = values.empty() ? bg : values.lo;
    info.value_max = values.empty() ? bg : values.hi;
    info.memory_bytes = tree.memUsage();
    if (od)
        info.memory_bytes += od->leaf_offsets.capacity() * sizeof(uint64_t) +
                             od->leaf_order.capacity() * sizeof(decltype(od->leaf_order)::value_type);
}

} // namespace

struct leap_vdb_file {
    std::string path;
    std::unique_ptr<VdbReader> reader;
    std::vector<vdb::io::GridDescriptor> descs; // in file order
    std::vector<vdb::GridBase::Ptr> streamed;   // every grid of a file without grid offsets
    bool in_memory = false;                     // made by leap_vdb_from_dense
    std::vector<std::string> names; // unique names ("name[N]" for duplicates)
    std::vector<std::string> plain; // grid names as written
    std::vector<uint64_t> memory;   // leap_vdb_grid_memory_estimate
    mutable std::vector<leap_grid_info> infos; // backgrounds are filled in lazily
    std::vector<leap_grid_scan> recorded;      // each grid's recorded scan (leaf_count 0: none)
    mutable std::vector<char> have_background;
    mutable int cached_index = -1; // grid read by leap_vdb_grid_info, not yet loaded
    mutable vdb::GridBase::Ptr cached_grid;
    mutable std::mutex mutex;
};


namespace {

// Grid `index` with its tree (an instance gets its parent's tree).
vdb::GridBase::Ptr read_full_grid(const leap_vdb_file *file, size_t index)
{
    // A grid made in memory is handed out as it is (its loads only ever clean it the same way).
    if (file->in_memory) return file->streamed[index];
    if (!file->streamed.empty()) return file->streamed[index]->deepCopyGrid();
    const vdb::io::GridDescriptor &gd = file->descs[index];
    vdb::GridBase::Ptr grid = file->reader->read(gd, VdbReader::Part::all);
    if (gd.isInstance()) {
        const int parent = VdbReader::find_parent(file->descs, gd);
        grid->setTree(file->reader->read(file->descs[size_t(parent)], VdbReader::Part::all)->baseTreePtr());
    }
    return grid;
}

} // namespace

extern "C" {

leap_result leap_vdb_open(const char *path, leap_vdb_file **out, leap_error *err)
{
    if (out) *out = nullptr;
    if (!path || !out) return leap_fail(err, LEAP_ERR_USAGE, "leap_vdb_open: NULL argument");
    struct stat st;
    if (stat(path, &st) != 0)
        return leap_fail(err, LEAP_ERR_IO, "cannot open '%s': %s", path, std::strerror(errno));
    if (S_ISDIR(st.st_mode)) return leap_fail(err, LEAP_ERR_IO, "'%s' is a directory, not a .vdb file", path);
    if (!S_ISREG(st.st_mode)) return leap_fail(err, LEAP_ERR_IO, "'%s' is not a regular file", path);
    if (FILE *f = std::fopen(path, "rb")) std::fclose(f);
    else return leap_fail(err, LEAP_ERR_IO, "cannot read '%s': %s", path, std::strerror(errno));
    if (st.st_size == 0) return leap_fail(err, LEAP_ERR_FORMAT, "'%s' is empty (0 bytes), not a VDB file", path);

    const std::string what = std::string("'") + path + "'";
    return guarded(err, LEAP_ERR_FORMAT, what, [&]() -> leap_result {
        init_openvdb();
        std::unique_ptr<leap_vdb_file> f(new leap_vdb_file);
        f->path = path;
        f->reader.reset(new VdbReader(path, uint64_t(st.st_size)));
        // No grid is read here: a load reads one whole, or its topology for reading on demand,
        // after checking its bytes.
        f->reader->open(f->descs, f->streamed);
        for (size_t i = 0; i < f->descs.size(); ++i) {
            const vdb::io::GridDescriptor &gd = f->descs[i];
            const std::string name = vdb::io::GridDescriptor::nameAsString(gd.uniqueName());
            f->names.push_back(name);
            f->plain.push_back(gd.gridName());
            leap_grid_info info;
            std::memset(&info, 0, sizeof info);
            vdb::GridBase::ConstPtr meta = f->streamed.empty() ? f->reader->read(gd, VdbReader::Part::meta) : f->streamed[i];
            meta_to_info(*meta, name, &info);
            f->infos.push_back(info);
            leap_grid_scan scan{};
            if (gd.isInstance() || !recorded_scan(*meta, &scan)) scan = leap_grid_scan{};
            f->recorded.push_back(scan);
            uint64_t bytes = uint64_t(gd.getEndPos() - gd.getGridPos()) * (gd.saveFloatAsHalf() ? 2 : 1);
            if (auto m = meta->getMetadata<vdb::Int64Metadata>(vdb::GridBase::META_FILE_MEM_BYTES))
                if (m->value() > 0) bytes = uint64_t(m->value());
            f->memory.push_back(bytes);
        }
        if (f->names.empty())
            return leap_fail(err, LEAP_ERR_FORMAT, "%s: no grids (an empty or truncated VDB file)", what.c_str());
        f->have_background.assign(f->names.size(), 0);
        *out = f.release();
        return LEAP_OK;
    });
}

leap_result leap_vdb_from_dense(const char *path, const leap_dense_volume *volume, leap_vdb_file **out,
                                leap_error *err)
{
    if (out) *out = nullptr;
    if (!path || !volume || !out || !volume->read_planes)
        return leap_fail(err, LEAP_ERR_USAGE, "leap_vdb_from_dense: bad arguments");
    for (int a = 0; a < 3; ++a)
        if (volume->dim[a] < 1)
            return leap_fail(err, LEAP_ERR_USAGE, "'%s': %d x %d x %d voxels: every size must be at least 1", path,
                             volume->dim[0], volume->dim[1], volume->dim[2]);
    const std::string what = std::string("'") + path + "'";
    return guarded(err, LEAP_ERR_FORMAT, what, [&]() -> leap_result {
        init_openvdb();
        std::unique_ptr<leap_vdb_file> f(new leap_vdb_file);
        f->path = path;
        vdb::GridBase::Ptr grid = dense_to_grid(*volume);
        const std::string name = grid->getName();
        f->names.push_back(name);
        f->plain.push_back(name);
        leap_grid_info info;
        std::memset(&info, 0, sizeof info);
        meta_to_info(*grid, name, &info);
        info.background = volume->background;
        f->infos.push_back(info);
        f->recorded.push_back(leap_grid_scan{});
        f->have_background.assign(1, 1);
        f->memory.push_back(uint64_t(grid->memUsage())); // the budget's estimate, as a file's records it
        f->streamed.push_back(grid);
        f->in_memory = true;
        *out = f.release();
        return LEAP_OK;
    });
}

void leap_vdb_close(leap_vdb_file *file)
{
    if (!file) return;
    delete file;
}

int leap_vdb_grid_count(const leap_vdb_file *file)
{
    return file ? int(file->names.size()) : 0;
}

const char *leap_vdb_grid_name(const leap_vdb_file *file, int index)
{
    return file && index >= 0 && index < int(file->names.size()) ? file->names[size_t(index)].c_str() : nullptr;
}

int leap_vdb_grid_labels(const leap_vdb_file *file, int index)
{
    return file && index >= 0 && index < int(file->infos.size()) ? file->infos[size_t(index)].labels : 0;
}

leap_result leap_vdb_grid_info(const leap_vdb_file *file, int index, leap_grid_info *out, leap_error *err)
{
    if (!file || !out) return leap_fail(err, LEAP_ERR_USAGE, "leap_vdb_grid_info: NULL argument");
    if (index < 0 || index >= int(file->names.size()))
        return leap_fail(err, LEAP_ERR_USAGE, "'%s': grid index %d out of range (%d grids)", file->path.c_str(),
                         index, int(file->names.size()));
    const size_t i = size_t(index);
    std::lock_guard<std::mutex> lock(file->mutex);
    if (!file->have_background[i] && file->infos[i].scalar) {
        // The background is stored with the tree, not with the metadata, so the grid is read
        // here and kept for a following leap_vdb_load_grid of the same index. (Delayed
        // loading would read less, but it trips assertions in OpenVDB on corrupt files.)
        const std::string what = "'" + file->path + "', grid '" + file->names[i] + "'";
        leap_result r = guarded(err, LEAP_ERR_FORMAT, what, [&]() -> leap_result {
            vdb::GridBase::Ptr g = read_full_grid(file, i);
            double bg = 0.0;
            if (scalar_background(*g, &bg)) file->infos[i].background = bg;
            file->cached_index = index;
            file->cached_grid = g;
            return LEAP_OK;
        });
        if (r != LEAP_OK) return r;
        file->have_background[i] = 1;
    }
    *out = file->infos[i];
    return LEAP_OK;
}

uint64_t leap_vdb_grid_memory_estimate(const leap_vdb_file *file, int index)
{
    if (!file || index < 0 || size_t(index) >= file->memory.size()) return 0;
    return file->memory[size_t(index)];
}

int leap_vdb_file_up(const leap_vdb_file *file, double up[3])
{
    for (size_t i = 0; file && i < file->infos.size(); ++i) {
        const double *u = file->infos[i].up;
        if (u[0] != 0 || u[1] != 0 || u[2] != 0) {
            std::memcpy(up, u, 3 * sizeof *up);
            return 1;
        }
    }
    return 0;
}

int leap_vdb_find_grid(const leap_vdb_file *file, const char *name)
{
    if (!file) return -1;
    for (size_t i = 0; i < file->infos.size(); ++i) {
        if (name ? file->names[i] == name : file->infos[i].scalar != 0) return int(i);
    }
    // Grids sharing a name are listed as "name[0]", "name[1]", ...; the bare name selects the first.
    for (size_t i = 0; name && i < file->plain.size(); ++i)
        if (file->plain[i] == name) return int(i);
    return -1;
}

} // extern "C"

namespace {

// Numbers each leaf of the grid read on demand in leaf order (its index among `count` offsets);
// returns the grid's leaf count (the numbers serve only when it is `count`).
size_t order_leaves(const vdb::GridBase &base, size_t count, OnDemand &od)
{
    const vdb::FloatGrid *fg = dynamic_cast<const vdb::FloatGrid *>(&base);
    if (!fg) return 0;
    const size_t leaves = size_t(fg->tree().leafCount());
    od.leaf_order.clear();
    if (leaves != count || count > UINT32_MAX) return leaves;
    od.leaf_order.reserve(count);
    for (auto leaf = fg->tree().cbeginLeaf(); leaf; ++leaf)
        od.leaf_order.emplace_back(leaf.getLeaf(), uint32_t(od.leaf_order.size()));
    std::sort(od.leaf_order.begin(), od.leaf_order.end());
    return leaves;
}

// Grid `gi` with its leaf buffers left in the file, after the same checks of every byte of its
// tree as a full read (unless `checked`). Where each leaf's values start is known (the index's
// `leaf_offsets`, `leaf_count` of them, for a file checked before; else what the check found):
// only the topology is read, and leaves are read at their offsets later. Otherwise (an instance,
// or a tree whose check found no leaves) OpenVDB's delayed loading reads it, no offsets kept.
vdb::GridBase::Ptr read_on_demand(leap_vdb_file *file, size_t gi, bool checked, const uint64_t *leaf_offsets,
                                  uint64_t leaf_count, std::unique_ptr<OnDemand> &od)
{
    const vdb::io::GridDescriptor &gd = file->descs[gi];
    od.reset(new OnDemand(file->path));
    if (!checked) file->reader->check(gd, &od->leaf_offsets);
    if (!checked && gd.isInstance()) file->reader->check(file->descs[size_t(VdbReader::find_parent(file->descs, gd))]);
    od->fd = ::open(file->path.c_str(), O_RDONLY | O_CLOEXEC);
    if (od->fd < 0 || ::fstat(od->fd, &od->opened) != 0)
        OPENVDB_THROW(vdb::IoError, "cannot open the file: " << std::strerror(errno));
    if (!gd.isInstance() && (checked ? leaf_offsets != nullptr : !od->leaf_offsets.empty())) {
        if (checked) od->leaf_offsets.assign(leaf_offsets, leaf_offsets + leaf_count);
        // Leaves are read one at a time, in the order rays need them: read-ahead would bring in
        // their neighbours in the file, which no ray may need.
        ::posix_fadvise(od->fd, 0, 0, POSIX_FADV_RANDOM);
        vdb::io::StreamMetadata::Ptr stream;
        vdb::GridBase::Ptr base = file->reader->read(gd, VdbReader::Part::topology, &stream);
        od->format = tree_format(gd.gridType(), gd.saveFloatAsHalf());
        od->file_version = stream->fileVersion();
        od->library_version = stream->libraryVersion();
        od->compression = stream->compression();
        od->tree_end = uint64_t(gd.getEndPos());
        const size_t offsets = od->leaf_offsets.size(), leaves = order_leaves(*base, offsets, *od);
        if (const vdb::FloatGrid *fg = dynamic_cast<const vdb::FloatGrid *>(base.get()))
            od->stored_background_ptr = &fg->tree().background(); // as the topology read tags its stream
        if (leaves != offsets || od->leaf_order.size() != offsets)
            OPENVDB_THROW(vdb::IoError, "its " << (checked ? "index lists " : "structure check found ") << offsets
                                               << " leaves, its topology " << leaves);
        od->by_offset = true;
        return base;
    }
    od->file.setCopyMaxBytes(0); // map the file itself; OpenVDB would first copy a small one to /tmp
    od->file.open(/*delayLoad=*/true);
    // OpenVDB touches every page of the grid as it steps over the leaves' values (it reads each
    // chunk's size): a helper drops those pages while it reads, so the file is never all in memory.
    vdb::GridBase::Ptr base;
    {
        std::atomic<bool> done{false};
        OnDemand *on = od.get();
        std::thread trimmer([&done, on] {
            while (!done.load()) {
                std::this_thread::sleep_for(std::chrono::milliseconds(5));
                on->trim();
            }
        });
        struct Join {
            std::atomic<bool> &done;
            std::thread &t;
            ~Join()
            {
                done.store(true);
                t.join();
            }
        } join{done, trimmer};
        base = od->file.readGrid(file->names[gi]);
    }
    od->trim();
    if (const vdb::FloatGrid *fg = dynamic_cast<const vdb::FloatGrid *>(base.get())) {
        auto leaf = fg->tree().cbeginLeaf();
        if (leaf && !leaf->buffer().isOutOfCore())
            OPENVDB_THROW(vdb::IoError, "OpenVDB read the voxels at once (is OPENVDB_DISABLE_DELAYED_LOAD set?)");
    }
    return base;
}

// known: what the leaves hold (a grid index: the file's checks passed before; with `lazily`, the
// file's recorded scan: the checks run, and each leaf read is checked against it).
leap_result load_grid(leap_vdb_file *file, int index, bool on_demand, bool lazily, const leap_grid_scan *known,
                      const uint64_t *leaf_offsets, leap_grid **out, leap_error *err)
{
    if (out) *out = nullptr;
    if (!file || !out) return leap_fail(err, LEAP_ERR_USAGE, "leap_vdb_load_grid: NULL argument");
    if (index < 0 || index >= int(file->names.size()))
        return leap_fail(err, LEAP_ERR_USAGE, "'%s': grid index %d out of range (%d grids)", file->path.c_str(),
                         index, int(file->names.size()));
    const size_t gi = size_t(index);
    const leap_grid_info &meta = file->infos[gi];
    if (!meta.scalar)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "'%s': grid '%s' has value type %s; leap reads float, half, "
                         "double, int32 and int64 grids", file->path.c_str(), meta.name, meta.value_type);

    const std::string what = "'" + file->path + "', grid '" + file->names[gi] + "'";
    if (on_demand && (file->in_memory || !file->streamed.empty()))
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "only a .vdb file with grid offsets can be read on demand (this "
                         "one is %s; `leap convert` writes one)", file->in_memory ? "imported" : "written to a stream");
    if (on_demand && std::strcmp(meta.value_type, "float") != 0)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "only float grids can be read on demand (grid '%s' holds %s)",
                         file->names[gi].c_str(), meta.value_type);
    return guarded(err, LEAP_ERR_FORMAT, what, [&]() -> leap_result {
        vdb::GridBase::Ptr base;
        std::unique_ptr<OnDemand> od;
        {
            std::lock_guard<std::mutex> lock(file->mutex);
            if (on_demand)
                base = read_on_demand(file, gi, known != nullptr && !lazily, known ? leaf_offsets : nullptr,
                                      known ? known->leaf_count : 0, od);
            else if (file->cached_index == index) base = std::move(file->cached_grid);
            else base = read_full_grid(file, gi);
            if (!on_demand || file->cached_index == index) {
                file->cached_index = -1;
                file->cached_grid.reset();
            }
        }
        if (lazily && !od->by_offset)
            OPENVDB_THROW(vdb::IoError, "its leaves' offsets were not found, so it cannot be read lazily");
        if (lazily) {
            od->recorded = *known;
            od->verify = true;
        }
        if (!base->constTransform().isLinear())
            return leap_fail(err, LEAP_ERR_UNSUPPORTED, "%s: non-linear (frustum) transform is not supported",
                             what.c_str());

        std::unique_ptr<leap_grid> g(new leap_grid);
        g->info = meta;
        if (base->isType<vdb::FloatGrid>()) {
            g->grid = vdb::gridPtrCast<vdb::FloatGrid>(base);
        } else {
            FloatTree::Ptr tree;
            if (base->isType<vdb::DoubleGrid>()) {
                tree = convert_tree<vdb::DoubleGrid>(*base);
            } else if (base->isType<vdb::Int32Grid>()) {
                tree = convert_tree<vdb::Int32Grid>(*base);
                g->labels.reset(new vdb::Int64Tree(static_cast<const vdb::Int32Grid &>(*base).tree()));
            } else if (base->isType<vdb::Int64Grid>()) {
                tree = convert_tree<vdb::Int64Grid>(*base);
                g->labels = vdb::gridPtrCast<vdb::Int64Grid>(base)->treePtr();
            } else return leap_fail(err, LEAP_ERR_UNSUPPORTED, "%s: unsupported grid type %s", what.c_str(),
                                  base->type().c_str());
            g->grid = vdb::FloatGrid::create(tree);
            g->grid->setTransform(base->constTransform().copy());
        }
        base.reset();
        g->on_demand = std::move(od);
        const leap_grid_scan *recorded = file->recorded[gi].leaf_count ? &file->recorded[gi] : nullptr;
        scan_grid(*g, on_demand ? known : nullptr, recorded);
        if (g->labels) { // exact IDs: the scan's range is of the float tree
            const vdb::math::MinMax<int64_t> ids = vdb::tools::minMax(*g->labels);
            const bool any = g->info.active_voxels > 0;
            g->info.label_min = any ? ids.min() : g->labels->background();
            g->info.label_max = any ? ids.max() : g->labels->background();
        }
        leap_result r = leap_grid_read_status(g.get(), err);
        if (r) return r;
        *out = g.release();
        return LEAP_OK;
    });
}

} // namespace

extern "C" {

leap_result leap_vdb_load_grid(leap_vdb_file *file, int index, leap_grid **out, leap_error *err)
{
    return load_grid(file, index, false, false, nullptr, nullptr, out, err);
}

leap_result leap_vdb_load_grid_on_demand(leap_vdb_file *file, int index, const leap_grid_scan *known,
                                         const uint64_t *leaf_offsets, leap_grid **out, leap_error *err)
{
    return load_grid(file, index, true, false, known, leaf_offsets, out, err);
}

int leap_vdb_grid_recorded_scan(const leap_vdb_file *file, int index, leap_grid_scan *out)
{
    if (!file || index < 0 || size_t(index) >= file->recorded.size() || !file->recorded[size_t(index)].leaf_count)
        return 0;
    if (out) *out = file->recorded[size_t(index)];
    return 1;
}

leap_result leap_vdb_load_grid_lazily(leap_vdb_file *file, int index, leap_grid **out, leap_error *err)
{
    leap_grid_scan recorded;
    if (!leap_vdb_grid_recorded_scan(file, index, &recorded)) {
        if (out) *out = nullptr;
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "'%s': grid %d records no scan of its values (files written by "
                         "leap do)", file ? file->path.c_str() : "?", index);
    }
    return load_grid(file, index, true, true, &recorded, nullptr, out, err);
}

const uint64_t *leap_grid_leaf_offsets(const leap_grid *grid)
{
    if (!grid || !grid->on_demand) return nullptr;
    const std::vector<uint64_t> &o = grid->on_demand->leaf_offsets;
    return !o.empty() && o.size() == grid->scan.leaf_count ? o.data() : nullptr;
}

void leap_grid_get_scan(const leap_grid *grid, leap_grid_scan *out)
{
    *out = grid ? grid->scan : leap_grid_scan{};
}

int leap_grid_on_demand(const leap_grid *grid)
{
    return grid && grid->on_demand;
}

void leap_grid_release_scan(leap_grid *grid)
{
    OnDemand *od = grid ? grid->on_demand.get() : nullptr;
    if (!od) return;
    od->shells.reset();
    od->cell_parts = std::vector<CellParts>();
    od->numbers.reset();
}

uint64_t leap_grid_leaves_read(const leap_grid *grid)
{
    return grid && grid->on_demand ? grid->on_demand->leaves_read.load() : 0;
}

uint64_t leap_grid_shared_leaf_bytes(void)
{
    return sizeof(LeafT) + LeafT::SIZE * sizeof(float) + 128; // the leaf, its values, keeping it
}

void leap_grid_share_leaves(const leap_grid *grid, size_t leaves)
{
    if (grid && grid->on_demand) grid->on_demand->share(leaves);
}

leap_result leap_grid_check_source(const leap_grid *grid, leap_error *err)
{
    if (grid && grid->on_demand) grid->on_demand->check_source();
    return leap_grid_read_status(grid, err);
}

leap_result leap_grid_read_status(const leap_grid *grid, leap_error *err)
{
    if (!grid || !grid->on_demand || !grid->on_demand->failed.load()) return LEAP_OK;
    std::lock_guard<std::mutex> lock(grid->on_demand->mutex);
    return leap_fail(err, LEAP_ERR_FORMAT, "'%s', grid '%s': %s", grid->on_demand->file.filename().c_str(),
                     grid->info.name, grid->on_demand->error.c_str());
}

void leap_grid_destroy(leap_grid *grid)
{
    delete grid;
}

const leap_grid_info *leap_grid_get_info(const leap_grid *grid)
{
    return grid ? &grid->info : nullptr;
}

size_t leap_grid_brick_count(const leap_grid *grid)
{
    return grid ? size_t(grid->info.leaf_count) + grid->tiles.size() : 0;
}

leap_result leap_grid_reader_create(const leap_grid *grid, leap_grid_reader **out, leap_error *err)
{
    if (out) *out = nullptr;
    if (!grid || !out) return leap_fail(err, LEAP_ERR_USAGE, "leap_grid_reader_create: NULL argument");
    return guarded(err, LEAP_ERR_OOM, "leap_grid_reader_create", [&]() -> leap_result {
        *out = new leap_grid_reader(*grid);
        return LEAP_OK;
    });
}

void leap_grid_reader_destroy(leap_grid_reader *reader)
{
    delete reader;
}

} // extern "C"

namespace {

// The box is read in blocks that stay inside one leaf's 8^3 voxels: one lookup per block (a
// cell's box of 9^3 voxels meets at most eight), then either the leaf's values or the single
// value of a block that has no leaf.
template <typename Accessor>
void reader_box(Accessor &acc, LeafValues &values, const int32_t min[3], const int32_t dim[3], float *out)
{
    constexpr int32_t D = int32_t(LeafT::DIM);
    auto run = [](int32_t at, int32_t left) { return std::min(left, D - (at & (D - 1))); };
    for (int32_t bz = 0, nz; bz < dim[2]; bz += nz) {
        const int32_t z0 = min[2] + bz;
        nz = run(z0, dim[2] - bz);
        for (int32_t by = 0, ny; by < dim[1]; by += ny) {
            const int32_t y0 = min[1] + by;
            ny = run(y0, dim[1] - by);
            for (int32_t bx = 0, nx; bx < dim[0]; bx += nx) {
                const int32_t x0 = min[0] + bx;
                nx = run(x0, dim[0] - bx);
                const vdb::Coord c(x0, y0, z0);
                const LeafT *leaf = acc.probeConstLeaf(c);
                const float *v = leaf ? values.get(*leaf) : nullptr;
                const float tile = leaf ? 0.0f : acc.getValue(c);
                for (int32_t z = 0; z < nz; ++z)
                    for (int32_t y = 0; y < ny; ++y) {
                        float *o = out + (size_t(bz + z) * size_t(dim[1]) + size_t(by + y)) * size_t(dim[0]) + size_t(bx);
                        if (!v) {
                            std::fill(o, o + nx, tile);
                            continue;
                        }
                        const float *src = v + LeafT::coordToOffset(vdb::Coord(x0, y0 + y, z0 + z));
                        for (int32_t x = 0; x < nx; ++x) o[x] = src[x << (2 * LeafT::LOG2DIM)];
                    }
            }
        }
    }
}

} // namespace

extern "C" {

float leap_grid_reader_value(leap_grid_reader *reader, int32_t i, int32_t j, int32_t k)
{
    const vdb::Coord c(i, j, k);
    if (!reader->node_acc) return reader->acc.getValue(c); // every value in memory: one lookup
    if (const LeafT *leaf = reader->node_acc->probeConstLeaf(c))
        return reader->values.get(*leaf)[LeafT::coordToOffset(c)];
    return reader->node_acc->getValue(c);
}

void leap_grid_reader_box(leap_grid_reader *reader, const int32_t min[3], const int32_t dim[3], float *out)
{
    if (reader->node_acc) reader_box(*reader->node_acc, reader->values, min, dim, out);
    else reader_box(reader->acc, reader->values, min, dim, out);
}

} // extern "C"
