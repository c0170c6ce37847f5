// Leaves read on demand: the values of a grid opened with OpenVDB's delayed loading are read
// into short-lived copies, so memory holds only the leaves a reader uses at the moment.
#include "vdb_internal.h"

namespace leap_vdb_detail {

float sanitize(float v, float bg, const Range &finite)
{
    if (std::isnan(v)) return bg;
    if (std::isinf(v)) return v > 0 ? finite.hi : finite.lo;
    return v;
}

uint32_t LeafShell::key(float v)
{
    uint32_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    return bits & 0x80000000u ? ~bits : bits | 0x80000000u;
}

float LeafShell::value(uint32_t key)
{
    const uint32_t bits = key & 0x80000000u ? key & 0x7fffffffu : ~key;
    float v;
    std::memcpy(&v, &bits, sizeof v);
    return v;
}

void LeafShell::add(const Range &finite_part, uint32_t seen_part)
{
    if (!finite_part.empty()) {
        const uint32_t l = key(finite_part.lo), h = key(finite_part.hi);
        uint32_t now = lo.load(std::memory_order_relaxed);
        while (l < now && !lo.compare_exchange_weak(now, l, std::memory_order_relaxed)) {}
        now = hi.load(std::memory_order_relaxed);
        while (h > now && !hi.compare_exchange_weak(now, h, std::memory_order_relaxed)) {}
    }
    if (seen_part) seen.fetch_or(seen_part, std::memory_order_relaxed);
}

Range LeafShell::range(float bg, const Range &finite) const
{
    Range r;
    const uint32_t l = lo.load(), h = hi.load(), s = seen.load();
    if (l <= h) r.add(value(l)), r.add(value(h));
    if (s & NAN_SEEN) r.add(bg);
    if (s & PINF_SEEN) r.add(finite.hi);
    if (s & NINF_SEEN) r.add(finite.lo);
    return r;
}

// OpenVDB maps the whole file and keeps every page it touched mapped; past about this many
// bytes of pages read, they are dropped from the process (the kernel still caches them).
static constexpr uint64_t TRIM_BYTES = 4u << 20;

void OnDemand::fail(const std::string &why)
{
    std::lock_guard<std::mutex> lock(mutex);
    if (!failed.exchange(true)) error = why;
}

static bool same_time(const struct timespec &a, const struct timespec &b)
{
    return a.tv_sec == b.tv_sec && a.tv_nsec == b.tv_nsec;
}

bool OnDemand::check_source()
{
    if (failed.load()) return false;
    struct stat now;
    if (::fstat(fd, &now) != 0) {
        fail(std::string("the file cannot be checked: ") + std::strerror(errno));
        return false;
    }
    if (now.st_size == opened.st_size && same_time(now.st_mtim, opened.st_mtim) && same_time(now.st_ctim, opened.st_ctim))
        return true;
    fail("the file changed while it was open (" +
         (now.st_size != opened.st_size ? "its size went from " + std::to_string(opened.st_size) + " to " +
                                              std::to_string(now.st_size) + " bytes"
                                        : std::string("written to, same size")) +
         "); its leaves are no longer read: open it again");
    return false;
}

// A stream over bytes in memory.
class MemoryBuffer : public std::streambuf {
public:
    MemoryBuffer(char *data, size_t size) { setg(data, data, data + size); }
};

// A leaf's values are at most 512 four-byte values with OpenVDB's few bytes around them; a
// compressed chunk may be a little longer than what it holds.
static constexpr uint64_t LEAF_MAX_BYTES = 64u << 10;

// Reads `leaf`'s values into v (LeafT::SIZE of them) from its bytes in the file, checked before
// OpenVDB's reader of a leaf's values decodes them, in the stream state the topology was read in.
static void read_at_offset(const OnDemand &od, const LeafT &leaf, float *v)
{
    const auto at = std::lower_bound(od.leaf_order.begin(), od.leaf_order.end(), &leaf,
                                     [](const std::pair<const LeafT *, uint32_t> &e, const LeafT *l) {
                                         return std::less<const LeafT *>()(e.first, l);
                                     });
    if (at == od.leaf_order.end() || at->first != &leaf) throw std::runtime_error("the leaf has no offset");
    const size_t i = at->second;
    const uint64_t begin = od.leaf_offsets[i],
                   end = i + 1 < od.leaf_offsets.size() ? od.leaf_offsets[i + 1] - 64 : od.tree_end;
    if (!(begin < end && end - begin <= LEAF_MAX_BYTES))
        throw std::runtime_error("its offsets in the grid index are not those of a leaf");
    std::vector<char> bytes(size_t(end - begin));
    const ssize_t got = pread_full(od.fd, bytes.data(), bytes.size(), begin);
    if (got < 0) throw std::runtime_error(std::strerror(errno));
    if (size_t(got) < bytes.size()) throw std::runtime_error("the file ends before the leaf");
    Walker w(reinterpret_cast<const unsigned char *>(bytes.data()), bytes.size(), "");
    check_leaf_values(w, od.format, od.compression, leaf.getValueMask().countOn());
    MemoryBuffer buffer(bytes.data(), bytes.size());
    std::istream is(&buffer);
    is.exceptions(std::ios_base::failbit | std::ios_base::badbit);
    vdb::io::setVersion(is, od.library_version, od.file_version);
    vdb::io::setDataCompression(is, od.compression);
    vdb::io::setGridBackgroundValuePtr(is, od.stored_background_ptr);
    vdb::io::readCompressedValues(is, v, LeafT::SIZE, leaf.getValueMask(), od.format.stored != od.format.full);
}

static int64_t now_ns()
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return int64_t(t.tv_sec) * 1000000000 + t.tv_nsec;
}

void OnDemand::read(const LeafT &leaf, std::unique_ptr<LeafT> &copy)
{
    // The file is checked at most every CHECK_NS (a read from a mapping of a file cut short
    // raises SIGBUS; callers check before each batch as well).
    const int64_t now = now_ns();
    if (now - checked_ns.load(std::memory_order_relaxed) > CHECK_NS) {
        checked_ns.store(now, std::memory_order_relaxed);
        check_source();
    }
    if (failed.load()) { // the file may be shorter than its mapping now: read nothing more
        copy.reset(new LeafT(leaf.origin(), background));
        return;
    }
    try {
        copy.reset(new LeafT(leaf)); // the copy's buffer still points into the file, or is empty
        float *v = copy->buffer().data(); // reads it (OpenVDB's LeafBuffer::doLoad), or allocates it
        if (by_offset) read_at_offset(*this, leaf, v);
        if (verify && !leaf_fits_scan(v, leaf.getValueMask(), recorded))
            throw std::runtime_error("its values lie outside those the grid's metadata records (the file was changed "
                                     "after leap wrote it, its metadata kept: `leap convert` it again)");
        if (reset_background) copy->resetBackground(stored_background, background);
        if (nonfinite)
            for (vdb::Index n = 0; n < LeafT::SIZE; ++n) v[n] = sanitize(v[n], background, finite);
    } catch (const std::exception &e) {
        const vdb::Coord o = leaf.origin();
        fail("the leaf at (" + std::to_string(o.x()) + ", " + std::to_string(o.y()) + ", " + std::to_string(o.z()) +
             ") cannot be read: " + one_line(e.what()) + " (a corrupt file, or one changed while it was open)");
        // A buffer whose load by OpenVDB threw still says it is in the file while it holds its
        // values' array, and its destructor would free that array as the file's bookkeeping
        // (OpenVDB 10): it is abandoned, one leaf's copy at most per reading thread, since no
        // read starts after a failure. One read at its offset holds an array of its own.
        if (by_offset) copy.reset();
        else (void)copy.release();
        copy.reset(new LeafT(leaf.origin(), background));
    }
    leaves_read.fetch_add(1, std::memory_order_relaxed);
    // A read maps the pages of the leaf's mask and of its values: count three.
    if (!by_offset && bytes_since_trim.fetch_add(3 * 4096, std::memory_order_relaxed) > TRIM_BYTES) trim();
}

// Evicting the copy lowest in (z, y, x) order drops first what a pass sweeping cells in that
// order is done with: the atlas reads a cell's leaf and its +x, +y, +z neighbours, so about one
// layer of leaves stays live (least recently used needed two, as layers alternate in use).
static std::tuple<int, int, int> sweep_key(const LeafT &leaf)
{
    const vdb::Coord o = leaf.origin();
    return {o.z(), o.y(), o.x()};
}

std::shared_ptr<const LeafT> OnDemand::values(const LeafT &leaf)
{
    std::unique_ptr<LeafT> copy;
    if (shared_capacity.load(std::memory_order_relaxed) == 0) {
        read(leaf, copy);
        return std::shared_ptr<const LeafT>(std::move(copy));
    }
    const auto key = sweep_key(leaf);
    {
        std::lock_guard<std::mutex> lock(shared_mutex);
        auto at = shared.find(key);
        if (at != shared.end()) return at->second;
    }
    read(leaf, copy); // outside the lock: two threads may read one leaf, rarely
    std::shared_ptr<const LeafT> values(std::move(copy));
    std::shared_ptr<const LeafT> evicted; // freed after the lock is released
    std::lock_guard<std::mutex> lock(shared_mutex);
    if (shared_capacity.load() == 0 || !shared.emplace(key, values).second) return values;
    if (shared.size() > shared_capacity) {
        evicted = std::move(shared.begin()->second);
        shared.erase(shared.begin());
    }
    return values;
}

void OnDemand::share(size_t leaves)
{
    std::lock_guard<std::mutex> lock(shared_mutex);
    shared_capacity.store(leaves);
    while (shared.size() > leaves) shared.erase(shared.begin());
}

void OnDemand::trim()
{
    std::unique_lock<std::mutex> lock(mutex, std::try_to_lock);
    if (!lock.owns_lock()) return; // another thread trims
    bytes_since_trim.store(0);
    if (mapped.empty()) { // the mapping stays where it is once made: found once
        FILE *maps = std::fopen("/proc/self/maps", "r");
        if (!maps) return;
        char line[4096];
        while (std::fgets(line, sizeof line, maps)) {
            unsigned long lo = 0, hi = 0, inode = 0;
            unsigned major = 0, minor = 0;
            if (std::sscanf(line, "%lx-%lx %*s %*s %x:%x %lu", &lo, &hi, &major, &minor, &inode) != 5) continue;
            if (inode != opened.st_ino || major != ::major(opened.st_dev) || minor != ::minor(opened.st_dev)) continue;
            // Leaves are read in no file order: without read-around a fault maps one page.
            ::madvise(reinterpret_cast<void *>(lo), hi - lo, MADV_RANDOM);
            mapped.emplace_back(lo, hi - lo);
        }
        std::fclose(maps);
    }
    for (const auto &range : mapped) ::madvise(reinterpret_cast<void *>(range.first), range.second, MADV_DONTNEED);
}

LeafValues::LeafValues(const leap_grid *grid) : on_demand_(grid->on_demand.get()), topology_only_(false)
{
    if (on_demand_) slots_.resize(KEPT);
}

LeafValues::Slot *LeafValues::load(const LeafT &leaf)
{
    while (slots_[hand_].used) { // clock: a slot used since the hand passed gets another round
        slots_[hand_].used = false;
        hand_ = (hand_ + 1) % KEPT;
    }
    Slot &s = slots_[hand_];
    if (s.leaf) index_.erase(s.leaf);
    s.copy = on_demand_->values(leaf);
    s.leaf = &leaf;
    index_[&leaf] = hand_;
    hand_ = (hand_ + 1) % KEPT;
    return &s;
}

} // namespace leap_vdb_detail
