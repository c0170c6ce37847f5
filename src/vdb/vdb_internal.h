// Private to src/vdb: what the check, read, statistics and write parts of the OpenVDB
// shim share. Not installed; the public API is include/leap/vdb.h.
#ifndef LEAP_VDB_INTERNAL_H
#define LEAP_VDB_INTERNAL_H

#include "leap/vdb.h"

#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>
#include <openvdb/io/GridDescriptor.h>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/sysmacros.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <ios>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <new>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>
#include <vector>

namespace vdb = openvdb;

// A named namespace (not an anonymous one) so that the parts can call each other.
namespace leap_vdb_detail {

using FloatTree = vdb::FloatTree;
using RootT = FloatTree::RootNodeType;
using Node2T = RootT::ChildNodeType;   // 4096^3 internal node
using Node1T = Node2T::ChildNodeType;  // 128^3 internal node
using LeafT = FloatTree::LeafNodeType; // 8^3 leaf

void init_openvdb();

// Exception text on one line (OpenVDB messages may contain newlines).
std::string one_line(const char *s);

// Runs f (returning leap_result) and turns any exception into `code` with a message
// that names `what` (usually the file).
template <typename F>
leap_result guarded(leap_error *err, leap_result code, const std::string &what, F &&f)
{
    try {
        return f();
    } catch (const std::bad_alloc &) {
        return leap_fail(err, LEAP_ERR_OOM, "%s: out of memory", what.c_str());
    } catch (const std::ios_base::failure &) {
        return leap_fail(err, code, "%s: data ends early or cannot be read (truncated or corrupt file)", what.c_str());
    } catch (const vdb::Exception &e) { // its own wording ("RuntimeError: Expected to decompress ..."), said whose
        return leap_fail(err, code, "%s: OpenVDB cannot read it (a corrupt or truncated file?): %s", what.c_str(),
                         one_line(e.what()).c_str());
    } catch (const std::exception &e) {
        return leap_fail(err, code, "%s: %s", what.c_str(), one_line(e.what()).c_str());
    } catch (...) {
        return leap_fail(err, code, "%s: unknown error", what.c_str());
    }
}

// A grid made from a dense box of voxels (leap_vdb_from_dense); throws on failure.
vdb::GridBase::Ptr dense_to_grid(const leap_dense_volume &volume);

// Writes grids to a .vdb file as io::File does (with grid offsets, so it can be read on demand),
// but on a stream whose failure is an error: io::File does not check its stream after writing,
// so a full disk or a file-size limit left a file cut short, reported as written. Throws.
// Each float grid with its scan recorded (with_recorded_scan) unless `record` is false.
void write_vdb_file(const std::string &path, const vdb::GridCPtrVec &grids, bool record = true);

// Damage found by the structure checks below, before OpenVDB reads the bytes.
struct Corrupt : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// A name read from a file, made safe for a one-line message.
std::string printable(const std::string &s);

// Reads up to n bytes at `offset` into buf, going on after interrupted and partial reads;
// returns the bytes read (fewer only where the file ends), or -1 with errno set.
inline ssize_t pread_full(int fd, void *buf, size_t n, uint64_t offset)
{
    size_t got = 0;
    while (got < n) {
        const ssize_t r = ::pread(fd, static_cast<char *>(buf) + got, n - got, off_t(offset + got));
        if (r < 0 && errno == EINTR) continue;
        if (r < 0) return -1;
        if (r == 0) break;
        got += size_t(r);
    }
    return ssize_t(got);
}

// The file the checks below read, open for pread(2): a file cut short while they read it is a
// short read and an error, where reading a mapping past its end would raise SIGBUS.
class FileBytes {
public:
    FileBytes(const std::string &path, uint64_t size) : size_(size)
    {
        fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd_ < 0) OPENVDB_THROW(vdb::IoError, "cannot open the file: " << std::strerror(errno));
    }
    ~FileBytes() { ::close(fd_); }
    FileBytes(const FileBytes &) = delete;
    FileBytes &operator=(const FileBytes &) = delete;
    int fd() const { return fd_; }
    uint64_t size() const { return size_; } // as the file was opened

private:
    int fd_ = -1;
    uint64_t size_;
};

// Bounded reads of the byte range [pos, limit) of a file. OpenVDB allocates and fills a
// buffer for every string and metadata value it reads, loops over every count, and copies
// chunks whose sizes it takes from the file, before it notices that the file is shorter or
// that a size is wrong: one flipped byte costs gigabytes, minutes, or a write past a buffer.
// The checks below walk the same structures first and reject what does not fit. Messages
// are `prefix` followed by the `what` of the read that failed. A file is read through a window
// of WINDOW_BYTES (more for a longer read), so a walk holds little of it in memory; what
// bytes() returns stays valid until the next read.
class Walker {
public:
    Walker(const FileBytes &f, uint64_t pos, uint64_t limit, std::string prefix = "")
        : file_(&f), pos_(pos), limit_(std::min(limit, f.size())), prefix_(std::move(prefix))
    {
    }
    // The `size` bytes at `data` (copied from the file).
    Walker(const unsigned char *data, uint64_t size, std::string prefix)
        : data_(data), pos_(0), limit_(size), prefix_(std::move(prefix))
    {
    }
    uint64_t pos() const { return pos_; }
    void seek(uint64_t pos) { pos_ = pos; }
    uint64_t left() const { return pos_ < limit_ ? limit_ - pos_ : 0; }
    [[noreturn]] void fail(const std::string &what, const std::string &problem) const
    {
        throw Corrupt(prefix_ + what + ": " + problem);
    }
    void need(uint64_t n, const char *what) const
    {
        if (n > left())
            fail(what, "corrupt or truncated file (" + std::to_string(n) + " bytes needed, " + std::to_string(left()) +
                           " left)");
    }
    void need(uint64_t n, const std::string &what) const { need(n, what.c_str()); }
    template <typename W>
    const unsigned char *bytes(uint64_t n, const W &what)
    {
        need(n, what);
        const unsigned char *p = file_ ? in_window(n, what) : data_ + pos_;
        pos_ += n;
        return p;
    }
    template <typename W>
    void read(void *dst, size_t n, const W &what)
    {
        std::memcpy(dst, bytes(n, what), n);
    }
    template <typename T, typename W>
    T value(const W &what)
    {
        T v;
        read(&v, sizeof v, what);
        return v;
    }
    template <typename W>
    void skip(uint64_t n, const W &what)
    {
        need(n, what);
        pos_ += n;
    }
    // OpenVDB's string: a uint32 length, then the bytes.
    template <typename W>
    std::string str(const W &what)
    {
        const uint32_t n = value<uint32_t>(what);
        const unsigned char *p = bytes(n, what);
        return std::string(reinterpret_cast<const char *>(p), n);
    }

private:
    static constexpr uint64_t WINDOW_BYTES = 1u << 20;
    // The n bytes at pos_, read into the window unless it holds them.
    template <typename W>
    const unsigned char *in_window(uint64_t n, const W &what)
    {
        if (pos_ < window_pos_ || pos_ + n > window_pos_ + window_.size()) {
            const uint64_t want = std::min(std::max(n, WINDOW_BYTES), limit_ - pos_);
            window_.resize(size_t(want));
            window_pos_ = pos_;
            const ssize_t got = pread_full(file_->fd(), window_.data(), size_t(want), pos_);
            if (got < 0) fail(what, std::string("cannot be read: ") + std::strerror(errno));
            if (uint64_t(got) < want) {
                window_.clear();
                fail(what, "the file ends at byte " + std::to_string(pos_ + uint64_t(got)) + ", before the " +
                               std::to_string(file_->size()) + " bytes it had when opened (changed while read)");
            }
        }
        return window_.data() + (pos_ - window_pos_);
    }

    const FileBytes *file_ = nullptr;
    const unsigned char *data_ = nullptr;
    uint64_t pos_, limit_;
    std::vector<unsigned char> window_; // file bytes from window_pos_
    uint64_t window_pos_ = 0;
    std::string prefix_;
};

// ---- Structure checks before OpenVDB reads the bytes (vdb_check.cpp).

// The header as io::Archive::readHeader reads it. Returns whether the file has grid offsets.
bool walk_header(Walker &w, uint32_t *version);
// A MetaMap as MetaMap::readMeta reads it.
void walk_metamap(Walker &w, const std::string &what);
// What precedes a grid's tree: compression flags, metadata, and the transform's map type.
void walk_grid_prefix(Walker &w, const std::string &label);
// A grid descriptor as GridDescriptor::read reads it; returns the grid's label for messages.
std::string walk_descriptor(Walker &w, int index, int64_t pos[3], bool *instance);

// Bytes of one value of a tree type: in the root node (always full size) and in compressed
// node values (half size for real types of a grid saved as half). 0 for trees this check
// does not know.
struct TreeFormat {
    size_t full = 0, stored = 0;
};

TreeFormat tree_format(const std::string &type, bool half);

// Walks the values of one leaf with `active` active voxels (the bytes after its mask), as
// io::readCompressedValues reads them.
void check_leaf_values(Walker &w, const TreeFormat &format, uint32_t compression, uint64_t active);

// Walks a tree's topology and buffers from `w` (which carries the message prefix). `leaf_offsets`
// (when given) gets where each leaf's values start, past its mask, in the order OpenVDB reads
// the leaves (the tree's leaf order).
void check_tree_data(Walker &w, const TreeFormat &format, uint32_t compression,
                     std::vector<uint64_t> *leaf_offsets = nullptr);

// ---- Value ranges: per-brick in vdb_stats.cpp, the load-time scan in vdb_read.cpp.

struct Range {
    float lo = std::numeric_limits<float>::infinity();
    float hi = -std::numeric_limits<float>::infinity();
    void add(float v)
    {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
    }
    void add(const Range &r)
    {
        lo = std::min(lo, r.lo);
        hi = std::max(hi, r.hi);
    }
    bool empty() const { return lo > hi; }
};

// Per-leaf statistics for the load-time scan.
struct Scan {
    uint64_t nonfinite = 0;
    Range all;            // finite stored values
    Range active;         // finite active values
    bool active_nan = false, active_pinf = false, active_ninf = false;

    void add(float v, bool on)
    {
        if (std::isfinite(v)) {
            all.add(v);
            if (on) active.add(v);
            return;
        }
        ++nonfinite;
        if (!on) return;
        if (std::isnan(v)) active_nan = true;
        else if (v > 0) active_pinf = true;
        else active_ninf = true;
    }
    // A leaf's values as stored, with its active mask.
    void add_leaf(const float *v, const LeafT::NodeMaskType &mask)
    {
        for (vdb::Index n = 0; n < LeafT::SIZE; ++n) add(v[n], mask.isOn(n));
    }
    void merge(const Scan &o)
    {
        nonfinite += o.nonfinite;
        all.add(o.all);
        active.add(o.active);
        active_nan |= o.active_nan;
        active_pinf |= o.active_pinf;
        active_ninf |= o.active_ninf;
    }
};

// The scan of a float tree's leaves as a load finds it (leap_grid_scan), and a grid's record of
// it: write_vdb_file stores each float grid's in its metadata (SCAN_META), so that a
// load can read the grid on demand without reading every leaf first (leap_vdb_load_grid_lazily).
Scan scan_leaves(const FloatTree &tree);
leap_grid_scan scan_summary(const Scan &s, uint64_t leaves);
// The grid's recorded scan: false when it has none (or one that is not a scan).
bool recorded_scan(const vdb::GridBase &g, leap_grid_scan *out);
// A copy of the grid (sharing its tree) with its own scan recorded in place of any it had (none
// for a grid that is not float, or is saved as half, whose values are rounded as written).
vdb::GridBase::ConstPtr with_recorded_scan(const vdb::GridBase &g);
#define SCAN_META "leap_scan" /* hex floats: leaves, non-finite values, stored and active ranges, active NaN, +Inf, -Inf */
// Whether the scan a load found is the one recorded (a file whose values changed after leap
// wrote it, its metadata kept, is not).
bool same_scan(const leap_grid_scan &a, const leap_grid_scan &b);
// Whether a leaf's values (as stored: before non-finite values are mapped) fit a recorded scan.
bool leaf_fits_scan(const float *v, const LeafT::NodeMaskType &active, const leap_grid_scan &recorded);

struct TileRec {
    vdb::Coord origin;
    int level; // 0: 8^3, 1: 128^3, 2: 4096^3
    float value;
};

float sanitize(float v, float bg, const Range &finite);

// A brick's range gathered from the leaves as the load-time scan reads them (a grid read on
// demand), so that listing the bricks reads no leaf again: each leaf adds its values to its own
// brick and its sides to the bricks of the neighbour leaves whose one-voxel apron reaches them.
// Finite values as order-preserving keys (atomic min/max from every scanning thread), and which
// non-finite ones were met, mapped when the scan is done (range). Tiles and the background in
// the apron are found from the topology when the bricks are listed.
struct LeafShell {
    static constexpr uint32_t NAN_SEEN = 1, PINF_SEEN = 2, NINF_SEEN = 4;
    std::atomic<uint32_t> lo{~0u}, hi{0u}, seen{0u};
    static uint32_t key(float v);
    static float value(uint32_t key);
    void add(const Range &finite_part, uint32_t seen_part);
    Range range(float bg, const Range &finite) const; // with non-finite values mapped (sanitize)
};

// The leaf order (the tree's: by internal node, then by offset in it) of the leaf at a
// position, from the nodes above the leaves: each keeps its first leaf's number and how many
// leaves come before each word of its child mask.
class LeafNumbers {
public:
    explicit LeafNumbers(const FloatTree &tree)
    {
        uint32_t number = 0;
        for (auto it = tree.cbeginLeaf(); it; ++it, ++number) {
            const vdb::Coord o = it->origin() & ~(Node1T::DIM - 1);
            if (!nodes_.empty() && nodes_.back().node->origin() == o) continue;
            Node n{tree.root().probeConstNode<Node1T>(o), number, {}};
            const auto &mask = n.node->getChildMask();
            for (uint32_t w = 1; w < WORDS; ++w)
                n.before[w] = n.before[w - 1] + uint32_t(vdb::util::CountOn(mask.getWord<uint64_t>(w - 1)));
            nodes_.push_back(n);
        }
        std::sort(nodes_.begin(), nodes_.end(), [](const Node &a, const Node &b) { return a.node < b.node; });
    }
    // The number of the leaf at `c`, or -1 where there is none.
    int64_t at(const RootT &root, const vdb::Coord &c) const
    {
        const Node1T *node = root.probeConstNode<Node1T>(c);
        if (!node) return -1;
        const vdb::Index n = Node1T::coordToOffset(c);
        const uint64_t word = node->getChildMask().getWord<uint64_t>(n / 64);
        if (!(word >> (n % 64) & 1u)) return -1;
        auto at = std::lower_bound(nodes_.begin(), nodes_.end(), node,
                                   [](const Node &a, const Node1T *b) { return a.node < b; });
        return at->first + at->before[n / 64] + vdb::util::CountOn(word & ((uint64_t(1) << (n % 64)) - 1));
    }

private:
    static constexpr uint32_t WORDS = Node1T::NUM_VALUES / 64;
    struct Node {
        const Node1T *node;
        uint32_t first;
        uint32_t before[WORDS];
    };
    std::vector<Node> nodes_; // by address
};

// A leaf's values and its low sides (CellParts::part[e], e = x + 2y + 4z over {0, 1}^3: the
// first layer on each axis whose bit is set, the whole leaf along the others; e = 0 the whole
// leaf), as the load-time scan found them: an atlas cell's footprint (the block of 9^3 voxels
// from a corner on the leaves' lattice) is the union of the blocks at +{0, 1}^3 leaves' parts.
struct CellParts {
    Range part[8];
};

// The file behind a grid read on demand (leap_vdb_load_grid_on_demand): OpenVDB's delayed
// loading keeps each leaf's buffer in the file; a leaf is read into a copy, never into the
// tree, so what was read can be dropped again.
struct OnDemand {
    vdb::io::File file; // keeps the mapping the leaves read from
    // The file as it was opened (its mapping is found by device and inode), held open: a read
    // from a mapping of a file cut short raises SIGBUS, so reads stop once it is found changed
    // (check_source).
    int fd = -1;
    struct stat opened = {};
    static constexpr int64_t CHECK_NS = 1000000;
    std::atomic<int64_t> checked_ns{0}; // CLOCK_MONOTONIC of the last check by a read
    // Values are mapped as the load maps a grid in memory: a non-finite background is
    // replaced (resetBackground), and non-finite values once the load-time scan saw one.
    float background = 0.0f, stored_background = 0.0f;
    bool reset_background = false;
    Range finite;
    bool nonfinite = false;
    std::atomic<uint64_t> leaves_read{0};
    std::atomic<uint64_t> bytes_since_trim{0};
    std::mutex mutex;   // guards error and the trim
    std::string error;  // the first failed read
    std::atomic<bool> failed{false};
    std::vector<std::pair<unsigned long, size_t>> mapped; // the file's mapping (trim)
    // The shared copies by leaf origin in (z, y, x) order; guarded by shared_mutex.
    std::mutex shared_mutex;
    std::atomic<size_t> shared_capacity{0}; // 0: nothing shared, and no lock taken
    std::map<std::tuple<int, int, int>, std::shared_ptr<const LeafT>> shared;
    // Where each leaf's values start in the file, in leaf order (leap_grid_leaf_offsets; empty:
    // not known).
    std::vector<uint64_t> leaf_offsets;
    // Each leaf's LeafShell, in leaf order (null: the scan was known, as from a grid index).
    std::unique_ptr<LeafShell[]> shells;
    // Each leaf's CellParts, in leaf order (empty: the scan was known, or met a value that was
    // not finite), and the numbers that find a leaf's (leap_grid_cell_range).
    std::vector<CellParts> cell_parts;
    std::unique_ptr<LeafNumbers> numbers;
    // A grid whose load read its topology alone (by_offset) reads a leaf's bytes (from its
    // offset to the next leaf's mask, or to the tree's end) with pread(2), checks them, and
    // decodes them with OpenVDB's reader in the stream state the topology was read in (versions,
    // compression, the tree's background); no mapping of the file. leaf_order: each leaf's index
    // in leaf_offsets, sorted by leaf.
    bool by_offset = false;
    std::vector<std::pair<const LeafT *, uint32_t>> leaf_order;
    TreeFormat format;
    uint32_t file_version = 0, compression = 0;
    vdb::VersionId library_version;
    const void *stored_background_ptr = nullptr; // the tree's background, which OpenVDB's reader takes
    uint64_t tree_end = 0;
    // A grid loaded lazily (leap_vdb_load_grid_lazily) takes the file's recorded scan on trust and
    // checks each leaf it reads against it (leaf_fits_scan): a leaf that does not fit fails.
    bool verify = false;
    leap_grid_scan recorded{};

    explicit OnDemand(const std::string &path) : file(path) {}
    ~OnDemand()
    {
        if (fd >= 0) ::close(fd);
    }
    // Reads `leaf`'s values into `copy` (a leaf of the background if they cannot be read, or
    // once the file was found changed: the failure is kept for leap_grid_read_status).
    void read(const LeafT &leaf, std::unique_ptr<LeafT> &copy);
    // `leaf`'s values: from the leaves shared by every reader (leap_grid_share_leaves), else
    // read (and shared when sharing is on).
    std::shared_ptr<const LeafT> values(const LeafT &leaf);
    // At most `leaves` copies kept for every reader, the lowest in (z, y, x) order out first
    // (0: none).
    void share(size_t leaves);
    // Whether the file still has the size and times it had when opened; records the failure
    // when not. Called before each batch of reads, and by reads every CHECK_NS.
    bool check_source();
    void fail(const std::string &why);
    // Drops the file's pages from this process's memory (they stay in the page cache).
    void trim();
};

// Values of leaves for one thread: the tree's own buffers for a grid in memory; for a grid
// read on demand, copies read from the file (or shared by the grid's readers), of which the
// last LeafValues::KEPT stay (clock eviction; about 2 MiB). That holds a brick's apron
// neighbours in the tree's order and the next row of cells in the atlas's.
class LeafValues {
public:
    static constexpr size_t KEPT = 1024;
    explicit LeafValues(const leap_grid *grid);
    LeafValues() = default; // reads no leaf: range_in passes leaves by (the topology alone)
    bool topology_only() const { return topology_only_; }
    const float *get(const LeafT &leaf)
    {
        if (!on_demand_) return leaf.buffer().data();
        if (&leaf == last_) return last_values_;
        auto at = index_.find(&leaf);
        Slot *s = at != index_.end() ? &slots_[at->second] : load(leaf);
        s->used = true;
        last_ = &leaf;
        return last_values_ = s->copy->buffer().data();
    }

private:
    struct Slot {
        const LeafT *leaf = nullptr;
        std::shared_ptr<const LeafT> copy;
        bool used = false;
    };
    Slot *load(const LeafT &leaf);
    OnDemand *on_demand_ = nullptr;
    bool topology_only_ = true;
    std::vector<Slot> slots_;
    std::unordered_map<const LeafT *, size_t> index_;
    size_t hand_ = 0;
    const LeafT *last_ = nullptr;
    const float *last_values_ = nullptr;
};

} // namespace leap_vdb_detail

struct leap_grid {
    vdb::FloatGrid::Ptr grid;
    vdb::Int64Tree::Ptr labels; // exact values of a label grid (null otherwise)
    leap_grid_info info;
    std::vector<leap_vdb_detail::TileRec> tiles; // active tiles, in iteration order
    std::unique_ptr<leap_vdb_detail::OnDemand> on_demand; // null: every voxel is in memory
    leap_grid_scan scan{}; // a grid read on demand: what its load found in the leaves
};

// Per-thread accessors (exact labels too for a label grid). OpenVDB's accessor reads the
// buffer of every leaf it caches, so a grid read on demand gets one that caches nodes above
// the leaves only (node_acc).
struct leap_grid_reader {
    explicit leap_grid_reader(const leap_grid &g) : acc(g.grid->constTree()), values(&g)
    {
        if (g.labels) labels.reset(new vdb::tree::ValueAccessor<const vdb::Int64Tree>(*g.labels));
        if (g.on_demand) node_acc.reset(new NodeAccessor(g.grid->constTree()));
    }
    using NodeAccessor = vdb::tree::ValueAccessor1<const leap_vdb_detail::FloatTree, true, 1>;
    vdb::tree::ValueAccessor<const leap_vdb_detail::FloatTree> acc;
    std::unique_ptr<NodeAccessor> node_acc;
    std::unique_ptr<vdb::tree::ValueAccessor<const vdb::Int64Tree>> labels;
    leap_vdb_detail::LeafValues values;
};

#endif
