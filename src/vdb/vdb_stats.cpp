// Min/max statistics of grid values: per-brick ranges for leap_grid_bricks.
#include "vdb_internal.h"

using namespace leap_vdb_detail;

namespace {

// ---- min/max of all stored values (active or not, background where there is no data)
// inside an index box, descending only into the nodes that the box touches.

void range_in(LeafValues &values, const LeafT &leaf, const vdb::CoordBBox &b, Range &r)
{
    if (values.topology_only()) return;
    const float *data = values.get(leaf);
    const vdb::Coord o = leaf.origin();
    // Offsets inside the leaf, so that a leaf at the end of the index range cannot overflow.
    const vdb::Coord lo = b.min() - o, hi = b.max() - o;
    for (int x = lo.x(); x <= hi.x(); ++x)
        for (int y = lo.y(); y <= hi.y(); ++y) {
            const float *row = data + (x << (2 * LeafT::LOG2DIM)) + (y << LeafT::LOG2DIM);
            for (int z = lo.z(); z <= hi.z(); ++z) r.add(row[z]);
        }
}

template <typename NodeT>
void range_in(LeafValues &values, const NodeT &node, const vdb::CoordBBox &b, Range &r)
{
    using ChildT = typename NodeT::ChildNodeType;
    const vdb::Coord o = node.origin();
    const int sh = ChildT::TOTAL;
    const auto *table = node.getTable();
    for (int cx = (b.min().x() - o.x()) >> sh; cx <= (b.max().x() - o.x()) >> sh; ++cx)
        for (int cy = (b.min().y() - o.y()) >> sh; cy <= (b.max().y() - o.y()) >> sh; ++cy)
            for (int cz = (b.min().z() - o.z()) >> sh; cz <= (b.max().z() - o.z()) >> sh; ++cz) {
                const vdb::Index n = (cx << (2 * NodeT::LOG2DIM)) + (cy << NodeT::LOG2DIM) + cz;
                if (node.isChildMaskOn(n)) {
                    const ChildT &child = *table[n].getChild();
                    vdb::CoordBBox cb = child.getNodeBoundingBox();
                    cb.intersect(b);
                    range_in(values, child, cb, r);
                } else {
                    r.add(table[n].getValue());
                }
            }
}

// Box given in 64-bit so that callers may pass a box reaching past the int32 index range;
// the part outside holds no voxels and is dropped.
void range_in_box(LeafValues &values, const RootT &root, const int64_t lo[3], const int64_t hi[3], Range &r)
{
    const int64_t lim_lo = std::numeric_limits<int32_t>::min(), lim_hi = std::numeric_limits<int32_t>::max();
    int64_t a[3], b[3];
    for (int i = 0; i < 3; ++i) {
        a[i] = std::max(lo[i], lim_lo);
        b[i] = std::min(hi[i], lim_hi);
        if (a[i] > b[i]) return;
    }
    constexpr int64_t dim = Node2T::DIM;
    auto align = [](int64_t v) { return v - (((v % dim) + dim) % dim); };
    for (int64_t kx = align(a[0]); kx <= b[0]; kx += dim)
        for (int64_t ky = align(a[1]); ky <= b[1]; ky += dim)
            for (int64_t kz = align(a[2]); kz <= b[2]; kz += dim) {
                const vdb::Coord key{int(kx), int(ky), int(kz)};
                if (const Node2T *child = root.probeConstNode<Node2T>(key)) {
                    vdb::CoordBBox cb = child->getNodeBoundingBox();
                    cb.intersect(vdb::CoordBBox(int(a[0]), int(a[1]), int(a[2]), int(b[0]), int(b[1]), int(b[2])));
                    range_in(values, *child, cb, r);
                } else {
                    r.add(root.getValue(key)); // root tile, or background where there is none
                }
            }
}

// Value range of a brick: the box [o, o+size) plus a one-voxel apron. For a tile the
// interior is the tile value, so only the six faces of the apron shell are visited.
Range brick_range(LeafValues &values, const RootT &root, const vdb::Coord &o, int size, bool is_tile,
                  float tile_value)
{
    Range r;
    const int64_t lo[3] = {int64_t(o.x()) - 1, int64_t(o.y()) - 1, int64_t(o.z()) - 1};
    const int64_t hi[3] = {int64_t(o.x()) + size, int64_t(o.y()) + size, int64_t(o.z()) + size};
    if (!is_tile) {
        range_in_box(values, root, lo, hi, r);
        return r;
    }
    r.add(tile_value);
    for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side) {
            int64_t a[3], b[3];
            for (int i = 0; i < 3; ++i) {
                // Axes before `axis` are already covered by earlier faces: keep them inside.
                a[i] = i < axis ? lo[i] + 1 : lo[i];
                b[i] = i < axis ? hi[i] - 1 : hi[i];
            }
            a[axis] = b[axis] = side ? hi[axis] : lo[axis];
            range_in_box(values, root, a, b, r);
        }
    return r;
}

bool brick_before(const leap_brick &a, const leap_brick &b)
{
    if (a.origin[2] != b.origin[2]) return a.origin[2] < b.origin[2];
    if (a.origin[1] != b.origin[1]) return a.origin[1] < b.origin[1];
    return a.origin[0] < b.origin[0];
}

// ranges: 1 = read each brick's range, 0 = none (NaN; known, if given, fills them in).
leap_result list_bricks(const leap_grid *grid, int ranges, const float *known, leap_brick *out, leap_error *err)
{
    if (!grid || !out) return leap_fail(err, LEAP_ERR_USAGE, "leap_grid_bricks: NULL argument");
    return guarded(err, LEAP_ERR_FORMAT, std::string("grid '") + grid->info.name + "'", [&]() -> leap_result {
        const FloatTree &tree = grid->grid->constTree();
        const RootT &root = tree.root();
        std::vector<const LeafT *> leaves;
        leaves.reserve(size_t(grid->info.leaf_count));
        for (auto it = tree.cbeginLeaf(); it; ++it) leaves.push_back(it.getLeaf());
        const size_t nl = leaves.size(), nt = grid->tiles.size();

        // Each thread keeps the leaves it read last: a brick's apron reads its neighbours. A leaf's
        // brick after a first open on demand: what its scan gathered (LeafShell), and the tiles
        // and background its apron reaches.
        const OnDemand *od = grid->on_demand.get();
        const LeafShell *shells = od && ranges ? od->shells.get() : nullptr;
        tbb::enumerable_thread_specific<LeafValues> values(grid);
        LeafValues topology;
        tbb::parallel_for(tbb::blocked_range<size_t>(0, nl + nt, 16), [&](const tbb::blocked_range<size_t> &r) {
            LeafValues &mine = values.local();
            for (size_t i = r.begin(); i != r.end(); ++i) {
                leap_brick &b = out[i];
                std::memset(&b, 0, sizeof b);
                vdb::Coord o;
                Range v;
                if (i < nl) {
                    o = leaves[i]->origin();
                    b.size = int32_t(LeafT::DIM);
                    if (shells) {
                        v = brick_range(topology, root, o, b.size, false, 0.0f);
                        v.add(shells[i].range(od->background, od->finite));
                    } else if (ranges) v = brick_range(mine, root, o, b.size, false, 0.0f);
                } else {
                    const TileRec &t = grid->tiles[i - nl];
                    o = t.origin;
                    b.size = t.level == 0 ? int32_t(Node1T::ChildNodeType::DIM)
                           : t.level == 1 ? int32_t(Node1T::DIM) : int32_t(Node2T::DIM);
                    b.is_tile = 1;
                    b.tile_value = t.value;
                    if (ranges) v = brick_range(mine, root, o, b.size, true, t.value);
                }
                for (int a = 0; a < 3; ++a) b.origin[a] = o[a];
                b.value_min = ranges ? v.lo : NAN;
                b.value_max = ranges ? v.hi : NAN;
            }
        });
        leap_result status = leap_grid_read_status(grid, err);
        if (status) return status;
        std::sort(out, out + nl, brick_before);
        std::sort(out + nl, out + nl + nt, brick_before);
        for (size_t i = 0; known && i < nl + nt; ++i) {
            out[i].value_min = known[2 * i];
            out[i].value_max = known[2 * i + 1];
        }
        return LEAP_OK;
    });
}

} // namespace

extern "C" {

leap_result leap_grid_bricks(const leap_grid *grid, leap_brick *out, leap_error *err)
{
    return list_bricks(grid, 1, nullptr, out, err);
}

leap_result leap_grid_brick_layout(const leap_grid *grid, leap_brick *out, leap_error *err)
{
    return list_bricks(grid, 0, nullptr, out, err);
}

int leap_grid_cell_range(const leap_grid *grid, const int32_t min[3], float *lo, float *hi)
{
    const OnDemand *od = grid ? grid->on_demand.get() : nullptr;
    if (!od || od->cell_parts.empty()) return 0; // its numbers go with the parts
    for (int a = 0; a < 3; ++a)
        if ((min[a] & int32_t(LeafT::DIM - 1)) || int64_t(min[a]) + int64_t(LeafT::DIM) > std::numeric_limits<int32_t>::max())
            return 0;
    const RootT &root = grid->grid->constTree().root();
    Range r;
    for (int e = 0; e < 8; ++e) {
        const vdb::Coord c(min[0] + (e & 1) * int32_t(LeafT::DIM), min[1] + (e >> 1 & 1) * int32_t(LeafT::DIM),
                           min[2] + (e >> 2 & 1) * int32_t(LeafT::DIM));
        const int64_t n = od->numbers->at(root, c);
        if (n >= 0) r.add(od->cell_parts[size_t(n)].part[e]);
        else r.add(root.getValue(c)); // a tile or the background: one value over the block
    }
    *lo = r.lo;
    *hi = r.hi;
    return 1;
}

leap_result leap_grid_bricks_known(const leap_grid *grid, const float *ranges, leap_brick *out, leap_error *err)
{
    if (!ranges) return leap_fail(err, LEAP_ERR_USAGE, "leap_grid_bricks_known: NULL ranges");
    return list_bricks(grid, 0, ranges, out, err);
}

leap_result leap_grid_histogram(const leap_grid *grid, double lo, double hi, int bins, uint64_t *counts,
                                leap_error *err)
{
    if (!grid || !counts || bins < 1 || !(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi))
        return leap_fail(err, LEAP_ERR_USAGE, "histogram: needs a grid, at least one bin and a finite range lo < hi");
    std::fill(counts, counts + bins, uint64_t(0));
    return guarded(err, LEAP_ERR_FORMAT, std::string("grid '") + grid->info.name + "'", [&]() -> leap_result {
        auto add = [&](double v, uint64_t n) {
            if (v < lo || v > hi) return;
            const double t = (v - lo) / (hi - lo) * bins;
            counts[t >= bins ? bins - 1 : int(t)] += n;
        };
        // Leaves through LeafValues (a grid read on demand reads them), then the tiles.
        LeafValues values(grid);
        for (auto leaf = grid->grid->constTree().cbeginLeaf(); leaf; ++leaf) {
            const float *v = values.get(*leaf);
            for (auto on = leaf->getValueMask().beginOn(); on; ++on) add(double(v[on.pos()]), 1);
        }
        auto tiles = grid->grid->cbeginValueOn();
        tiles.setMaxDepth(tiles.getLeafDepth() - 1);
        for (auto it = tiles; it; ++it) add(double(*it), it.getVoxelCount());
        return leap_grid_read_status(grid, err);
    });
}

} // extern "C"
