// OpenVDB behind the C API of include/leap/vdb.h. No C++ exception leaves this file:
// every extern "C" function catches at its boundary and reports through leap_error.

#include "leap/vdb.h"

#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>
#include <openvdb/io/GridDescriptor.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
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
#include <vector>

namespace vdb = openvdb;

namespace {

using FloatTree = vdb::FloatTree;
using RootT = FloatTree::RootNodeType;
using Node2T = RootT::ChildNodeType;   // 4096^3 internal node
using Node1T = Node2T::ChildNodeType;  // 128^3 internal node
using LeafT = FloatTree::LeafNodeType; // 8^3 leaf

void init_openvdb()
{
    static std::once_flag once;
    std::call_once(once, [] {
        vdb::initialize();
        // Delayed-load metadata serves only memory-mapped delayed loading, which leap does not
        // use, and its reader sizes buffers from counts in the file without checking them. As
        // an unregistered type it is read as opaque bytes of a checked length (and dropped).
        if (vdb::Metadata::isRegisteredType("__delayedload")) vdb::Metadata::unregisterType("__delayedload");
    });
}

// Exception text on one line (OpenVDB messages may contain newlines).
std::string one_line(const char *s)
{
    std::string out = s ? s : "unknown error";
    std::replace(out.begin(), out.end(), '\n', ' ');
    return out;
}

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
    } catch (const vdb::Exception &e) {
        return leap_fail(err, code, "%s: %s", what.c_str(), one_line(e.what()).c_str());
    } catch (const std::exception &e) {
        return leap_fail(err, code, "%s: %s", what.c_str(), one_line(e.what()).c_str());
    } catch (...) {
        return leap_fail(err, code, "%s: unknown error", what.c_str());
    }
}

void copy_str(char *dst, size_t cap, const std::string &s)
{
    std::snprintf(dst, cap, "%s", s.c_str());
}

bool is_scalar_type(const std::string &t)
{
    return t == "float" || t == "double" || t == "int32";
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
    info->saved_as_half = g.valueType() == "float" && g.saveFloatAsHalf();
    transform_to_info(g.constTransform(), info);
    info->bbox_min[0] = info->bbox_min[1] = info->bbox_min[2] = 0;
    info->bbox_max[0] = info->bbox_max[1] = info->bbox_max[2] = -1;
}

// Background of a scalar grid as float (how every scalar type is presented).
bool scalar_background(const vdb::GridBase &g, double *out)
{
    if (auto f = dynamic_cast<const vdb::FloatGrid *>(&g)) *out = f->background();
    else if (auto d = dynamic_cast<const vdb::DoubleGrid *>(&g)) *out = float(d->background());
    else if (auto i = dynamic_cast<const vdb::Int32Grid *>(&g)) *out = float(i->background());
    else return false;
    return true;
}

// Damage found by the structure checks below, before OpenVDB reads the bytes.
struct Corrupt : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// A name read from a file, made safe for a one-line message.
std::string printable(const std::string &s)
{
    std::string out;
    for (size_t i = 0; i < s.size() && i < 64; ++i) {
        const unsigned char c = static_cast<unsigned char>(s[i]);
        out += c >= 0x20 && c < 0x7f ? char(c) : '?';
    }
    if (s.size() > 64) out += "...";
    return out;
}

// The file's bytes, mapped read-only for the checks below.
class Mapping {
public:
    Mapping(const std::string &path, uint64_t size) : size_(size)
    {
        const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd < 0) OPENVDB_THROW(vdb::IoError, "cannot open the file: " << std::strerror(errno));
        void *p = size ? ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0) : MAP_FAILED;
        const int saved = errno;
        ::close(fd);
        if (p == MAP_FAILED) OPENVDB_THROW(vdb::IoError, "cannot map the file: " << std::strerror(saved));
        data_ = static_cast<const unsigned char *>(p);
    }
    ~Mapping() { ::munmap(const_cast<unsigned char *>(data_), size_); }
    Mapping(const Mapping &) = delete;
    Mapping &operator=(const Mapping &) = delete;
    const unsigned char *data() const { return data_; }
    uint64_t size() const { return size_; }

private:
    const unsigned char *data_ = nullptr;
    uint64_t size_;
};

// Bounded reads of the byte range [pos, limit) of a file. OpenVDB allocates and fills a
// buffer for every string and metadata value it reads, loops over every count, and copies
// chunks whose sizes it takes from the file, before it notices that the file is shorter or
// that a size is wrong: one flipped byte costs gigabytes, minutes, or a write past a buffer.
// The checks below walk the same structures first and reject what does not fit. Messages
// are `prefix` followed by the `what` of the read that failed.
class Walker {
public:
    Walker(const Mapping &m, uint64_t pos, uint64_t limit, std::string prefix = "")
        : data_(m.data()), pos_(pos), limit_(std::min(limit, m.size())), prefix_(std::move(prefix))
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
        const unsigned char *p = data_ + pos_;
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
        bytes(n, what);
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
    const unsigned char *data_;
    uint64_t pos_, limit_;
    std::string prefix_;
};

// The header as io::Archive::readHeader reads it, for format 222 (OpenVDB 2.0) and later.
// Returns whether the file has grid offsets.
bool walk_header(Walker &w, uint32_t *version)
{
    uint64_t magic = 0;
    if (w.left() >= 8) magic = w.value<uint64_t>("magic number");
    if (magic != uint64_t(vdb::OPENVDB_MAGIC)) throw Corrupt("not a VDB file (no VDB magic number)");
    *version = w.value<uint32_t>("format version");
    if (*version < vdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION || *version > vdb::OPENVDB_FILE_VERSION)
        throw Corrupt("unsupported VDB format version " + std::to_string(*version) + " (this build reads " +
                      std::to_string(vdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION) + " to " +
                      std::to_string(vdb::OPENVDB_FILE_VERSION) + "): corrupt or too new");
    w.skip(8, "library version");
    const bool offsets = w.value<char>("grid offsets flag") != 0;
    char uuid[36];
    w.read(uuid, sizeof uuid, "file UUID");
    for (int i = 0; i < 36; ++i) {
        const bool dash = i == 8 || i == 13 || i == 18 || i == 23;
        if (dash ? uuid[i] != '-' : !std::isxdigit(static_cast<unsigned char>(uuid[i])))
            throw Corrupt("corrupt header (file UUID)");
    }
    return offsets;
}

// A MetaMap as MetaMap::readMeta reads it: registered fixed-size types take their own size
// whatever the stored size says (so the stored size must match), strings and unknown types
// take the stored size.
void walk_metamap(Walker &w, const std::string &what)
{
    const uint32_t count = w.value<uint32_t>(what);
    for (uint32_t i = 0; i < count; ++i) {
        const std::string entry = what + " entry " + std::to_string(i);
        w.str(entry + " name");
        const std::string type = w.str(entry + " type");
        uint32_t size = w.value<uint32_t>(entry + " size");
        if (type != "string" && vdb::Metadata::isRegisteredType(type)) {
            const uint32_t fixed = vdb::Metadata::createMetadata(type)->size();
            if (size != fixed)
                throw Corrupt(entry + " (" + printable(type) + ") has size " + std::to_string(size) + ", expected " +
                              std::to_string(fixed) + ": corrupt file");
        }
        w.skip(size, entry + " value");
    }
}

// What precedes a grid's tree: compression flags, metadata, and the transform's map type
// (the maps themselves are fixed-size, except a frustum's second map type).
void walk_grid_prefix(Walker &w, const std::string &label)
{
    w.skip(4, label + " compression flags");
    walk_metamap(w, label + " metadata");
    const std::string map = w.str(label + " transform type");
    if (map == "NonlinearFrustumMap") {
        w.skip(48, label + " frustum box");
        w.skip(16, label + " frustum taper and depth");
        w.str(label + " frustum second map type");
    }
}

// A grid descriptor as GridDescriptor::read reads it. Returns the grid's label for messages;
// *instance tells whether the grid shares another grid's tree.
std::string walk_descriptor(Walker &w, int index, int64_t pos[3], bool *instance)
{
    const std::string name = w.str("grid descriptor " + std::to_string(index) + " name");
    const std::string label = "grid '" + printable(vdb::io::GridDescriptor::nameAsString(name)) + "'";
    std::string type = w.str(label + " type");
    const std::string half = "_HalfFloat"; // GridDescriptor's suffix for float grids saved as half
    if (type.size() > half.size() && type.compare(type.size() - half.size(), half.size(), half) == 0)
        type.resize(type.size() - half.size());
    if (!vdb::GridBase::isRegistered(type))
        throw Corrupt(label + " has an unknown grid type '" + printable(type) + "': corrupt file or unsupported type");
    *instance = !w.str(label + " instance parent").empty();
    for (int i = 0; i < 3; ++i) pos[i] = w.value<int64_t>(label + " offsets");
    return label;
}

// ---- The tree of a grid, as Tree/RootNode/InternalNode/LeafNode::readTopology and
// readBuffers read it (format >= 222, 5-4-3 trees of plain values). Chunk sizes are checked
// against what OpenVDB will expect, because OpenVDB 10 copies an uncompressed chunk of the
// size the file gives into a buffer of the size it expects before comparing the two, and
// hands compressed chunks to Blosc without their length.

// Bytes of one value of a tree type: in the root node (always full size) and in compressed
// node values (half size for real types of a grid saved as half). 0 for trees this check
// does not know.
struct TreeFormat {
    size_t full = 0, stored = 0;
};

TreeFormat tree_format(const std::string &type, bool half)
{
    static const struct {
        const char *name;
        size_t full, half;
    } known[] = {{"Tree_float_5_4_3", 4, 2},  {"Tree_double_5_4_3", 8, 4}, {"Tree_int32_5_4_3", 4, 4},
                 {"Tree_int64_5_4_3", 8, 8},  {"Tree_vec3s_5_4_3", 12, 6}, {"Tree_vec3d_5_4_3", 24, 12},
                 {"Tree_vec3i_5_4_3", 12, 12}};
    TreeFormat f;
    for (const auto &k : known)
        if (type == k.name) {
            f.full = k.full;
            f.stored = half ? k.half : k.full;
        }
    return f;
}

class TreeCheck {
public:
    // `w` carries the prefix for messages (the grid).
    TreeCheck(Walker &w, const TreeFormat &format, uint32_t compression)
        : w_(w), f_(format), compression_(compression)
    {
    }

    void run()
    {
        if (w_.value<int32_t>("buffer count") != 1) w_.fail("buffer count", "corrupt tree");
        w_.skip(f_.full, "background");
        const uint32_t tiles = w_.value<uint32_t>("root tile count");
        const uint32_t children = w_.value<uint32_t>("root child count");
        if (tiles == 0 && children == 0) return; // an empty tree: no buffers either
        // Each tile is an origin, a value and an active flag; the count must fit before it is used.
        w_.skip(uint64_t(tiles) * (12 + f_.full + 1), "root tiles");
        // The root keeps its children in a map keyed by the origin as stored: a later child
        // replaces an earlier one with the same key, and buffers follow in key order.
        std::map<std::tuple<int32_t, int32_t, int32_t>, size_t> order;
        std::vector<Upper> uppers;
        w_.need(uint64_t(children) * (12 + 2 * 4096), "root children");
        uppers.reserve(children);
        for (uint32_t i = 0; i < children; ++i) {
            int32_t o[3];
            w_.read(o, sizeof o, "root child origin");
            uppers.emplace_back();
            topology(uppers.back());
            order[std::make_tuple(o[0], o[1], o[2])] = uppers.size() - 1;
        }
        for (const auto &entry : order)
            for (const Lower &lower : uppers[entry.second].children)
                for (uint16_t active : lower.leaf_active) {
                    w_.skip(64, "leaf mask"); // read with the topology; skipped here
                    values(active, 512, "voxel values");
                }
    }

private:
    // What the buffers need from the topology: the number of active voxels of each leaf, in
    // the order of the leaves under their 16^3 (lower) and 32^3 (upper) internal nodes.
    struct Lower {
        std::vector<uint16_t> leaf_active;
    };
    struct Upper {
        std::vector<Lower> children;
    };

    // Reads a node mask of `bits` bits; returns the number of bits set.
    uint64_t mask(uint32_t bits, const char *what)
    {
        const unsigned char *p = w_.bytes(bits / 8, what);
        uint64_t n = 0;
        for (uint32_t i = 0; i < bits / 64; ++i) {
            uint64_t word;
            std::memcpy(&word, p + 8 * i, 8);
            n += uint64_t(__builtin_popcountll(word));
        }
        return n;
    }

    // An internal node: child mask, value mask, its values, then its children.
    void node_header(uint32_t bits, uint64_t *children)
    {
        *children = mask(bits, "node child mask");
        const uint64_t active = mask(bits, "node value mask");
        values(active, bits, "node values");
    }

    void topology(Upper &upper)
    {
        uint64_t n = 0;
        node_header(32768, &n);
        // Each child takes at least its masks: the count must fit before nodes are made for it.
        w_.need(n * 2 * 512, "child nodes");
        upper.children.resize(size_t(n));
        for (Lower &lower : upper.children) {
            uint64_t leaves = 0;
            node_header(4096, &leaves);
            w_.need(leaves * 64, "leaf nodes");
            lower.leaf_active.resize(size_t(leaves));
            for (uint16_t &active : lower.leaf_active) active = uint16_t(mask(512, "leaf mask"));
        }
    }

    // io::readCompressedValues for a node of `bits` values, `active` of them active.
    void values(uint64_t active, uint32_t bits, const char *what)
    {
        const int8_t meta = w_.value<int8_t>(what);
        if (meta == 2 || meta == 4 || meta == 5) w_.skip(meta == 5 ? 2 * f_.full : f_.full, what);
        if (meta == 3 || meta == 4 || meta == 5) w_.skip(bits / 8, what);
        uint64_t count = bits;
        if ((compression_ & vdb::io::COMPRESS_ACTIVE_MASK) && meta != 6) count = active;
        if (f_.stored != f_.full && count == 0) return; // the half reader reads nothing then
        chunk(count * f_.stored, what);
    }

    // io::readData: a Blosc or zip chunk (size, then data; a size <= 0 marks -size raw
    // bytes) or raw bytes.
    void chunk(uint64_t bytes, const char *what)
    {
        if (!(compression_ & (vdb::io::COMPRESS_BLOSC | vdb::io::COMPRESS_ZIP))) {
            w_.skip(bytes, what);
            return;
        }
        const int64_t n = w_.value<int64_t>(what);
        if (n <= 0) {
            if (n == std::numeric_limits<int64_t>::min()) w_.fail(what, "corrupt chunk size");
            if (uint64_t(-n) != bytes)
                w_.fail(what, "corrupt chunk (" + std::to_string(-n) + " bytes stored, " + std::to_string(bytes) +
                                  " expected)");
            w_.skip(bytes, what);
            return;
        }
        const unsigned char *p = w_.bytes(uint64_t(n), what);
        if (compression_ & vdb::io::COMPRESS_BLOSC) {
            // Blosc's header: version, format, flags, type size, then uncompressed size,
            // block size and compressed size (little-endian uint32s).
            const uint64_t header = 16;
            uint32_t nbytes = 0, cbytes = 0;
            if (uint64_t(n) >= header) {
                std::memcpy(&nbytes, p + 4, 4);
                std::memcpy(&cbytes, p + 12, 4);
            }
            const bool memcpyed = uint64_t(n) >= header && (p[2] & 0x2);
            if (uint64_t(n) < header || cbytes > uint64_t(n) || cbytes < header || nbytes != bytes ||
                (memcpyed && uint64_t(nbytes) + header > cbytes))
                w_.fail(what, "corrupt compressed chunk");
        }
    }

    Walker &w_;
    TreeFormat f_;
    uint32_t compression_;
};

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
        const Mapping m(path_, size_);
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

    // Grid `gd` of this file: everything, or only its metadata and transform.
    vdb::GridBase::Ptr read(const vdb::io::GridDescriptor &gd, bool full)
    {
        if (full && !gd.isInstance()) {
            const Mapping m(path_, size_);
            check_tree(m, gd, uint64_t(gd.getGridPos()), uint64_t(gd.getEndPos()), "tree", false);
        }
        Stream s;
        start(s);
        gd.seekToGrid(s.is);
        vdb::GridBase::Ptr grid = new_grid(gd);
        if (full) {
            readGrid(grid, gd, s.is);
        } else {
            readGridCompression(s.is);
            grid->readMeta(s.is);
            grid->readTransform(s.is);
        }
        return grid;
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
    void check_tree(const Mapping &m, const vdb::io::GridDescriptor &gd, uint64_t grid_pos, uint64_t limit,
                    const std::string &label, bool any_type)
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
        TreeCheck(w, format, compression).run();
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

// ---- min/max of all stored values (active or not, background where there is no data)
// inside an index box, descending only into the nodes that the box touches.

void range_in(const LeafT &leaf, const vdb::CoordBBox &b, Range &r)
{
    const float *data = leaf.buffer().data();
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
void range_in(const NodeT &node, const vdb::CoordBBox &b, Range &r)
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
                    range_in(child, cb, r);
                } else {
                    r.add(table[n].getValue());
                }
            }
}

// Box given in 64-bit so that callers may pass a box reaching past the int32 index range;
// the part outside holds no voxels and is dropped.
void range_in_box(const RootT &root, const int64_t lo[3], const int64_t hi[3], Range &r)
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
                    range_in(*child, cb, r);
                } else {
                    r.add(root.getValue(key)); // root tile, or background where there is none
                }
            }
}

// Value range of a brick: the box [o, o+size) plus a one-voxel apron. For a tile the
// interior is the tile value, so only the six faces of the apron shell are visited.
Range brick_range(const RootT &root, const vdb::Coord &o, int size, bool is_tile, float tile_value)
{
    Range r;
    const int64_t lo[3] = {int64_t(o.x()) - 1, int64_t(o.y()) - 1, int64_t(o.z()) - 1};
    const int64_t hi[3] = {int64_t(o.x()) + size, int64_t(o.y()) + size, int64_t(o.z()) + size};
    if (!is_tile) {
        range_in_box(root, lo, hi, r);
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
            range_in_box(root, a, b, r);
        }
    return r;
}

bool brick_before(const leap_brick &a, const leap_brick &b)
{
    if (a.origin[2] != b.origin[2]) return a.origin[2] < b.origin[2];
    if (a.origin[1] != b.origin[1]) return a.origin[1] < b.origin[1];
    return a.origin[0] < b.origin[0];
}

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

float sanitize(float v, float bg, const Range &finite)
{
    if (std::isnan(v)) return bg;
    if (std::isinf(v)) return v > 0 ? finite.hi : finite.lo;
    return v;
}

struct TileRec {
    vdb::Coord origin;
    int level; // 0: 8^3, 1: 128^3, 2: 4096^3
    float value;
};

// Nearest int32 (NaN -> 0, out of range -> clamped), for writing label grids.
int32_t to_int32(double v)
{
    if (!std::isfinite(v)) return 0;
    v = std::min(std::max(std::round(v), double(INT32_MIN)), double(INT32_MAX));
    return int32_t(v);
}

// Converts a double/int32 grid into a float tree of the same topology, tiles and background.
template <typename GridT>
FloatTree::Ptr convert_tree(const vdb::GridBase &g)
{
    const GridT &src = static_cast<const GridT &>(g);
    return FloatTree::Ptr(new FloatTree(src.tree()));
}

} // namespace

struct leap_vdb_file {
    std::string path;
    std::unique_ptr<VdbReader> reader;
    std::vector<vdb::io::GridDescriptor> descs; // in file order
    std::vector<vdb::GridBase::Ptr> streamed;   // every grid of a file without grid offsets
    std::vector<std::string> names; // unique names ("name[N]" for duplicates)
    std::vector<std::string> plain; // grid names as written
    mutable std::vector<leap_grid_info> infos; // backgrounds are filled in lazily
    mutable std::vector<char> have_background;
    mutable int cached_index = -1; // grid read by leap_vdb_grid_info, not yet loaded
    mutable vdb::GridBase::Ptr cached_grid;
    mutable std::mutex mutex;
};

struct leap_grid {
    vdb::FloatGrid::Ptr grid;
    leap_grid_info info;
    std::vector<TileRec> tiles; // active tiles, in iteration order
};

struct leap_grid_reader {
    explicit leap_grid_reader(const FloatTree &t) : acc(t) {}
    vdb::tree::ValueAccessor<const FloatTree> acc;
};

namespace {

// Grid `index` with its tree (an instance gets its parent's tree).
vdb::GridBase::Ptr read_full_grid(const leap_vdb_file *file, size_t index)
{
    if (!file->streamed.empty()) return file->streamed[index]->deepCopyGrid();
    const vdb::io::GridDescriptor &gd = file->descs[index];
    vdb::GridBase::Ptr grid = file->reader->read(gd, true);
    if (gd.isInstance()) {
        const int parent = VdbReader::find_parent(file->descs, gd);
        grid->setTree(file->reader->read(file->descs[size_t(parent)], true)->baseTreePtr());
    }
    return grid;
}

} // namespace

struct WriterGrid {
    vdb::GridBase::Ptr grid;
    leap_vdb_type type;
};

struct leap_vdb_writer {
    std::vector<WriterGrid> grids;
    std::string deferred_error; // first failure inside a void call, reported by save
};

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
        // No delayed loading: a grid is read completely and checked once, at load time.
        f->reader->open(f->descs, f->streamed);
        for (size_t i = 0; i < f->descs.size(); ++i) {
            const vdb::io::GridDescriptor &gd = f->descs[i];
            const std::string name = vdb::io::GridDescriptor::nameAsString(gd.uniqueName());
            f->names.push_back(name);
            f->plain.push_back(gd.gridName());
            leap_grid_info info;
            std::memset(&info, 0, sizeof info);
            vdb::GridBase::ConstPtr meta = f->streamed.empty() ? f->reader->read(gd, false) : f->streamed[i];
            meta_to_info(*meta, name, &info);
            f->infos.push_back(info);
        }
        if (f->names.empty())
            return leap_fail(err, LEAP_ERR_FORMAT, "%s: no grids (an empty or truncated VDB file)", what.c_str());
        f->have_background.assign(f->names.size(), 0);
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

leap_result leap_vdb_load_grid(leap_vdb_file *file, int index, leap_grid **out, leap_error *err)
{
    if (out) *out = nullptr;
    if (!file || !out) return leap_fail(err, LEAP_ERR_USAGE, "leap_vdb_load_grid: NULL argument");
    if (index < 0 || index >= int(file->names.size()))
        return leap_fail(err, LEAP_ERR_USAGE, "'%s': grid index %d out of range (%d grids)", file->path.c_str(),
                         index, int(file->names.size()));
    const size_t gi = size_t(index);
    const leap_grid_info &meta = file->infos[gi];
    if (!meta.scalar)
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "'%s': grid '%s' has value type %s; only float, half, double "
                         "and int32 grids can be rendered", file->path.c_str(), meta.name, meta.value_type);

    const std::string what = "'" + file->path + "', grid '" + file->names[gi] + "'";
    return guarded(err, LEAP_ERR_FORMAT, what, [&]() -> leap_result {
        vdb::GridBase::Ptr base;
        {
            std::lock_guard<std::mutex> lock(file->mutex);
            if (file->cached_index == index) base = std::move(file->cached_grid);
            else base = read_full_grid(file, gi);
            file->cached_index = -1;
            file->cached_grid.reset();
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
            if (base->isType<vdb::DoubleGrid>()) tree = convert_tree<vdb::DoubleGrid>(*base);
            else if (base->isType<vdb::Int32Grid>()) tree = convert_tree<vdb::Int32Grid>(*base);
            else return leap_fail(err, LEAP_ERR_UNSUPPORTED, "%s: unsupported grid type %s", what.c_str(),
                                  base->type().c_str());
            g->grid = vdb::FloatGrid::create(tree);
            g->grid->setTransform(base->constTransform().copy());
        }
        base.reset();
        FloatTree &tree = g->grid->tree();

        uint64_t nonfinite = 0;
        float bg = tree.background();
        if (!std::isfinite(bg)) {
            // Nothing can stand in for a non-finite background; 0 is the neutral choice.
            ++nonfinite;
            bg = 0.0f;
            tree.root().setBackground(bg, /*updateChildNodes=*/true);
        }

        std::vector<LeafT *> leaves;
        leaves.reserve(tree.leafCount());
        for (auto it = tree.beginLeaf(); it; ++it) leaves.push_back(it.getLeaf());

        using Blocks = tbb::blocked_range<size_t>;
        Scan scan = tbb::parallel_reduce(
            Blocks(0, leaves.size(), 64), Scan(),
            [&](const Blocks &r, Scan s) {
                for (size_t i = r.begin(); i != r.end(); ++i) {
                    const LeafT &leaf = *leaves[i];
                    const float *v = leaf.buffer().data();
                    const auto &mask = leaf.getValueMask();
                    for (vdb::Index n = 0; n < LeafT::SIZE; ++n) s.add(v[n], mask.isOn(n));
                }
                return s;
            },
            [](Scan a, const Scan &b) {
                a.merge(b);
                return a;
            });

        // Tiles at every level (leaf depth excluded), active or not.
        auto tile_iter = tree.beginValueAll();
        tile_iter.setMaxDepth(tile_iter.getLeafDepth() - 1);
        for (auto it = tile_iter; it; ++it) scan.add(*it, it.isValueOn());

        nonfinite += scan.nonfinite;
        Range finite = scan.all;
        if (finite.empty()) finite.add(bg);
        if (scan.nonfinite > 0) {
            tbb::parallel_for(Blocks(0, leaves.size(), 64), [&](const Blocks &r) {
                for (size_t i = r.begin(); i != r.end(); ++i) {
                    float *v = leaves[i]->buffer().data();
                    for (vdb::Index n = 0; n < LeafT::SIZE; ++n) v[n] = sanitize(v[n], bg, finite);
                }
            });
            for (auto it = tile_iter; it; ++it)
                if (!std::isfinite(*it)) it.setValue(sanitize(*it, bg, finite));
        }

        Range values = scan.active;
        if (scan.active_nan) values.add(bg);
        if (scan.active_pinf) values.add(finite.hi);
        if (scan.active_ninf) values.add(finite.lo);

        leap_grid_info &info = g->info;
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
            g->tiles.push_back(TileRec{bb.min(), level, *it});
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
        *out = g.release();
        return LEAP_OK;
    });
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

leap_result leap_grid_bricks(const leap_grid *grid, leap_brick *out, leap_error *err)
{
    if (!grid || !out) return leap_fail(err, LEAP_ERR_USAGE, "leap_grid_bricks: NULL argument");
    return guarded(err, LEAP_ERR_FORMAT, std::string("grid '") + grid->info.name + "'", [&]() -> leap_result {
        const FloatTree &tree = grid->grid->constTree();
        const RootT &root = tree.root();
        std::vector<const LeafT *> leaves;
        leaves.reserve(size_t(grid->info.leaf_count));
        for (auto it = tree.cbeginLeaf(); it; ++it) leaves.push_back(it.getLeaf());
        const size_t nl = leaves.size(), nt = grid->tiles.size();

        tbb::parallel_for(tbb::blocked_range<size_t>(0, nl + nt, 16), [&](const tbb::blocked_range<size_t> &r) {
            for (size_t i = r.begin(); i != r.end(); ++i) {
                leap_brick &b = out[i];
                std::memset(&b, 0, sizeof b);
                vdb::Coord o;
                Range v;
                if (i < nl) {
                    o = leaves[i]->origin();
                    b.size = int32_t(LeafT::DIM);
                    v = brick_range(root, o, b.size, false, 0.0f);
                } else {
                    const TileRec &t = grid->tiles[i - nl];
                    o = t.origin;
                    b.size = t.level == 0 ? int32_t(Node1T::ChildNodeType::DIM)
                           : t.level == 1 ? int32_t(Node1T::DIM) : int32_t(Node2T::DIM);
                    b.is_tile = 1;
                    b.tile_value = t.value;
                    v = brick_range(root, o, b.size, true, t.value);
                }
                for (int a = 0; a < 3; ++a) b.origin[a] = o[a];
                b.value_min = v.lo;
                b.value_max = v.hi;
            }
        });
        std::sort(out, out + nl, brick_before);
        std::sort(out + nl, out + nl + nt, brick_before);
        return LEAP_OK;
    });
}

leap_result leap_grid_reader_create(const leap_grid *grid, leap_grid_reader **out, leap_error *err)
{
    if (out) *out = nullptr;
    if (!grid || !out) return leap_fail(err, LEAP_ERR_USAGE, "leap_grid_reader_create: NULL argument");
    return guarded(err, LEAP_ERR_OOM, "leap_grid_reader_create", [&]() -> leap_result {
        *out = new leap_grid_reader(grid->grid->constTree());
        return LEAP_OK;
    });
}

void leap_grid_reader_destroy(leap_grid_reader *reader)
{
    delete reader;
}

float leap_grid_reader_value(leap_grid_reader *reader, int32_t i, int32_t j, int32_t k)
{
    return reader->acc.getValue(vdb::Coord(i, j, k));
}

void leap_grid_reader_box(leap_grid_reader *reader, const int32_t min[3], const int32_t dim[3], float *out)
{
    // Rows are read in runs that stay inside one 8-voxel block: one lookup per run, then
    // either the leaf's values or the single value of a block that has no leaf.
    auto &acc = reader->acc;
    size_t n = 0;
    for (int32_t z = 0; z < dim[2]; ++z)
        for (int32_t y = 0; y < dim[1]; ++y)
            for (int32_t x = 0; x < dim[0];) {
                const vdb::Coord c(min[0] + x, min[1] + y, min[2] + z);
                const int32_t run = std::min(dim[0] - x, int32_t(LeafT::DIM) - (c.x() & int32_t(LeafT::DIM - 1)));
                if (const LeafT *leaf = acc.probeConstLeaf(c)) {
                    const float *v = leaf->buffer().data() + LeafT::coordToOffset(c);
                    for (int32_t k = 0; k < run; ++k) out[n++] = v[k << (2 * LeafT::LOG2DIM)];
                } else {
                    const float v = acc.getValue(c);
                    for (int32_t k = 0; k < run; ++k) out[n++] = v;
                }
                x += run;
            }
}

/* ---- Writing ---------------------------------------------------------------------- */

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
    return guarded(err, LEAP_ERR_IO, std::string("cannot write '") + path + "'", [&]() -> leap_result {
        vdb::GridCPtrVec grids;
        for (const WriterGrid &g : writer->grids) grids.push_back(g.grid);
        vdb::io::File(path).write(grids);
        return LEAP_OK;
    });
}

} // extern "C"
