// Allocation for the VDB fuzz target: operator new that throws std::bad_alloc when malloc
// fails, as it does in a normal build.
//
// OpenVDB sizes some buffers from counts in the file (a compressed chunk's byte count, for
// one) and relies on std::bad_alloc for absurd ones; leap reports that as an error. Under
// AddressSanitizer operator new never throws: an allocation beyond the allocator's limit
// ends the process with a report, so a fuzzer would stop at the first flipped size field
// instead of checking that leap turns it into an error. With this replacement the request
// goes to AddressSanitizer's malloc, which returns NULL beyond max_allocation_size_mb (set
// below, with allocator_may_return_null), and becomes std::bad_alloc. Everything else about
// the memory (bounds, use after free, leaks) is still checked. The aligned forms are left to
// AddressSanitizer; they pair with their own deletes.
#include <cstdlib>
#include <new>

extern "C" const char *__asan_default_options();
extern "C" const char *__asan_default_options()
{
    return "allocator_may_return_null=1:max_allocation_size_mb=4000";
}

static void *allocate(std::size_t n)
{
    void *p = std::malloc(n ? n : 1);
    if (!p) throw std::bad_alloc();
    return p;
}

void *operator new(std::size_t n) { return allocate(n); }
void *operator new[](std::size_t n) { return allocate(n); }
void *operator new(std::size_t n, const std::nothrow_t &) noexcept { return std::malloc(n ? n : 1); }
void *operator new[](std::size_t n, const std::nothrow_t &) noexcept { return std::malloc(n ? n : 1); }
void operator delete(void *p) noexcept { std::free(p); }
void operator delete[](void *p) noexcept { std::free(p); }
void operator delete(void *p, std::size_t) noexcept { std::free(p); }
void operator delete[](void *p, std::size_t) noexcept { std::free(p); }
void operator delete(void *p, const std::nothrow_t &) noexcept { std::free(p); }
void operator delete[](void *p, const std::nothrow_t &) noexcept { std::free(p); }
