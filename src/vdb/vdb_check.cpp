// Structure checks of a .vdb file before OpenVDB reads it (see Walker in vdb_internal.h).
#include "vdb_internal.h"

namespace leap_vdb_detail {

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

namespace {

class TreeCheck {
public:
    // `w` carries the prefix for messages (the grid).
    TreeCheck(Walker &w, const TreeFormat &format, uint32_t compression, std::vector<uint64_t> *leaf_offsets)
        : w_(w), f_(format), compression_(compression), leaf_offsets_(leaf_offsets)
    {
    }

    void leaf(uint64_t active)
    {
        values(active, 512, "voxel values");
        if (w_.left()) w_.fail("voxel values", "corrupt leaf (" + std::to_string(w_.left()) + " bytes left over)");
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
                    if (leaf_offsets_) leaf_offsets_->push_back(w_.pos());
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
    std::vector<uint64_t> *leaf_offsets_;
};

} // namespace

void check_leaf_values(Walker &w, const TreeFormat &format, uint32_t compression, uint64_t active)
{
    TreeCheck(w, format, compression, nullptr).leaf(active);
}

void check_tree_data(Walker &w, const TreeFormat &format, uint32_t compression, std::vector<uint64_t> *leaf_offsets)
{
    TreeCheck(w, format, compression, leaf_offsets).run();
}

} // namespace leap_vdb_detail
