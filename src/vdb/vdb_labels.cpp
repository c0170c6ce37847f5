// Label grids (segmentations): exact integer object IDs next to the float view of the grid.
#include "vdb_internal.h"

#include <unordered_map>

using namespace leap_vdb_detail;

namespace {

using LabelTree = vdb::Int64Tree;
using LabelLeaf = LabelTree::LeafNodeType;

struct ObjectAcc {
    uint64_t voxels = 0;
    vdb::Coord lo = vdb::Coord::max(), hi = vdb::Coord::min();
    void add_active(const vdb::Coord &a, const vdb::Coord &b, uint64_t n)
    {
        voxels += n;
        lo.minComponent(a);
        hi.maxComponent(b);
    }
    void merge(const ObjectAcc &o)
    {
        voxels += o.voxels;
        lo.minComponent(o.lo);
        hi.maxComponent(o.hi);
    }
};

using ObjectMap = std::unordered_map<int64_t, ObjectAcc>;

} // namespace

extern "C" {

int leap_grid_has_labels(const leap_grid *grid)
{
    return grid && grid->labels ? 1 : 0;
}

int64_t leap_grid_background_label(const leap_grid *grid)
{
    return grid && grid->labels ? grid->labels->background() : 0;
}

leap_result leap_grid_make_labels(leap_grid *grid, leap_error *err)
{
    if (!grid) return leap_fail(err, LEAP_ERR_USAGE, "leap_grid_make_labels: NULL grid");
    if (grid->labels) return LEAP_OK;
    if (grid->on_demand)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "a segmentation (--labels) is read whole, and this grid is read "
                         "on demand under the memory budget (raise --memory-budget)");
    return guarded(err, LEAP_ERR_OOM, "labels", [&]() -> leap_result {
        const FloatTree &tree = grid->grid->constTree();
        // Every value the renderer can read must be an integer a float holds exactly.
        auto bad = [](float v) { return !(std::fabs(v) <= 16777216.0f) || v != std::floor(v); };
        if (bad(tree.background()))
            return leap_fail(err, LEAP_ERR_USAGE, "--labels: the background %g is not an integer",
                             double(tree.background()));
        for (auto it = tree.cbeginValueAll(); it; ++it)
            if (bad(*it)) {
                const vdb::Coord c = it.getCoord();
                return leap_fail(err, LEAP_ERR_USAGE,
                                 "--labels: grid '%s' holds the value %g at (%d, %d, %d), not an integer label "
                                 "(below 2^24); render it without --labels",
                                 grid->info.name, double(*it), c.x(), c.y(), c.z());
            }
        grid->labels.reset(new LabelTree(tree));
        grid->info.labels = 1;
        grid->info.label_min = int64_t(grid->info.value_min); // integers below 2^24: exact
        grid->info.label_max = int64_t(grid->info.value_max);
        return LEAP_OK;
    });
}

leap_result leap_grid_label_objects(const leap_grid *grid, leap_label_object **out, size_t *count, leap_error *err)
{
    *out = nullptr;
    *count = 0;
    if (!grid || !grid->labels) return leap_fail(err, LEAP_ERR_USAGE, "objects: the grid holds no labels");
    return guarded(err, LEAP_ERR_OOM, "objects", [&]() -> leap_result {
        const LabelTree &tree = *grid->labels;
        std::vector<const LabelLeaf *> leaves;
        leaves.reserve(tree.leafCount());
        for (auto it = tree.cbeginLeaf(); it; ++it) leaves.push_back(it.getLeaf());
        using Blocks = tbb::blocked_range<size_t>;
        ObjectMap all = tbb::parallel_reduce(
            Blocks(0, leaves.size(), 64), ObjectMap(),
            [&](const Blocks &r, ObjectMap m) {
                for (size_t i = r.begin(); i != r.end(); ++i) {
                    const LabelLeaf &leaf = *leaves[i];
                    const int64_t *v = leaf.buffer().data();
                    ObjectAcc *o = nullptr;
                    for (vdb::Index n = 0; n < LabelLeaf::SIZE; ++n) {
                        if (!o || v[n] != v[n - 1]) o = &m[v[n]]; /* runs of one label are common */
                        if (leaf.isValueOn(n)) {
                            const vdb::Coord c = leaf.offsetToGlobalCoord(n);
                            o->add_active(c, c, 1);
                        }
                    }
                }
                return m;
            },
            [](ObjectMap a, const ObjectMap &b) {
                for (const auto &kv : b) a[kv.first].merge(kv.second);
                return a;
            });
        all[tree.background()];
        auto tiles = tree.cbeginValueAll();
        tiles.setMaxDepth(tiles.getLeafDepth() - 1);
        for (auto it = tiles; it; ++it) {
            ObjectAcc &o = all[*it];
            if (!it.isValueOn()) continue;
            vdb::CoordBBox bb;
            it.getBoundingBox(bb);
            o.add_active(bb.min(), bb.max(), bb.volume());
        }
        leap_label_object *objs = static_cast<leap_label_object *>(std::malloc(all.size() * sizeof *objs));
        if (!objs) return leap_fail(err, LEAP_ERR_OOM, "objects: out of memory for %zu objects", all.size());
        size_t n = 0;
        for (const auto &kv : all) {
            leap_label_object &o = objs[n++];
            o.id = kv.first;
            o.voxels = kv.second.voxels;
            for (int a = 0; a < 3; ++a) {
                o.bbox_min[a] = kv.second.voxels ? kv.second.lo[a] : 0;
                o.bbox_max[a] = kv.second.voxels ? kv.second.hi[a] : -1;
            }
        }
        std::sort(objs, objs + n, [](const leap_label_object &a, const leap_label_object &b) { return a.id < b.id; });
        *out = objs;
        *count = n;
        return LEAP_OK;
    });
}

void leap_grid_reader_labels(leap_grid_reader *reader, const int32_t min[3], const int32_t dim[3], int64_t *out)
{
    // As leap_grid_reader_box: runs inside one 8-voxel block, one lookup per run.
    auto &acc = *reader->labels;
    size_t n = 0;
    for (int32_t z = 0; z < dim[2]; ++z)
        for (int32_t y = 0; y < dim[1]; ++y)
            for (int32_t x = 0; x < dim[0];) {
                const vdb::Coord c(min[0] + x, min[1] + y, min[2] + z);
                const int32_t run = std::min(dim[0] - x, int32_t(LabelLeaf::DIM) - (c.x() & int32_t(LabelLeaf::DIM - 1)));
                if (const LabelLeaf *leaf = acc.probeConstLeaf(c)) {
                    const int64_t *v = leaf->buffer().data() + LabelLeaf::coordToOffset(c);
                    for (int32_t k = 0; k < run; ++k) out[n++] = v[k << (2 * LabelLeaf::LOG2DIM)];
                } else {
                    const int64_t v = acc.getValue(c);
                    for (int32_t k = 0; k < run; ++k) out[n++] = v;
                }
                x += run;
            }
}

} // extern "C"
