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

// OpenVDB maps the whole file and keeps every page it touched mapped; past about this many
// bytes of pages read, they are dropped from the process (the kernel still caches them).
static constexpr uint64_t TRIM_BYTES = 4u << 20;

void OnDemand::read(const LeafT &leaf, std::unique_ptr<LeafT> &copy)
{
    try {
        copy.reset(new LeafT(leaf)); // the copy's buffer still points into the file
        float *v = copy->buffer().data(); // reads it (OpenVDB's LeafBuffer::doLoad)
        if (reset_background) copy->resetBackground(stored_background, background);
        if (nonfinite)
            for (vdb::Index n = 0; n < LeafT::SIZE; ++n) v[n] = sanitize(v[n], background, finite);
    } catch (const std::exception &e) {
        std::lock_guard<std::mutex> lock(mutex);
        if (!failed.exchange(true)) {
            const vdb::Coord o = leaf.origin();
            error = "the leaf at (" + std::to_string(o.x()) + ", " + std::to_string(o.y()) + ", " +
                    std::to_string(o.z()) + ") cannot be read: " + one_line(e.what()) +
                    " (was the file changed while it was open?)";
        }
        copy.reset(new LeafT(leaf.origin(), background));
    }
    leaves_read.fetch_add(1, std::memory_order_relaxed);
    // A read maps the pages of the leaf's mask and of its values: count three.
    if (bytes_since_trim.fetch_add(3 * 4096, std::memory_order_relaxed) > TRIM_BYTES) trim();
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
            if (inode != ino || major != ::major(dev) || minor != ::minor(dev)) continue;
            // Leaves are read in no file order: without read-around a fault maps one page.
            ::madvise(reinterpret_cast<void *>(lo), hi - lo, MADV_RANDOM);
            mapped.emplace_back(lo, hi - lo);
        }
        std::fclose(maps);
    }
    for (const auto &range : mapped) ::madvise(reinterpret_cast<void *>(range.first), range.second, MADV_DONTNEED);
}

LeafValues::LeafValues(const leap_grid *grid) : on_demand_(grid->on_demand.get())
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
    on_demand_->read(leaf, s.copy);
    s.leaf = &leaf;
    index_[&leaf] = hand_;
    hand_ = (hand_ + 1) % KEPT;
    return &s;
}

} // namespace leap_vdb_detail
