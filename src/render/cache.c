/* The GPU brick cache (see brick_cache in renderer_internal.h). The host atlas keeps every
 * slot's texels or reads them again from the grid (stream_texels); the atlas image holds
 * `capacity` of them, host slot h always in image slot h % capacity. A non-resident slot's
 * cell entry is LEAP_PAGE_MISSING | its host slot; a ray
 * reaching it reports the slot and waits at that sample (composite.comp), and the frame's
 * next pass goes on once it is loaded. Each pass lets every waiting ray whose slot was loaded
 * take at least that cell, so a frame ends with every ray finished on any capacity of at
 * least one slot. The image has a shape of its own (cache_shape); where a slot lies does not
 * change its samples (leap_cursor_seek), so every mode, through a cache of any size, gives the
 * whole atlas's image bit for bit. */
#include "renderer_internal.h"

#include <stdlib.h>
#include <string.h>

#include "leap/atlas.h"

/* The smallest cache image, 64 x 64 x 16 texels (49 slots): a cache of a few slots would load
 * one slot a pass (a 200 x 150 frame of cloud.vdb through one slot: 8,419 passes, 19 s). */
#define CACHE_EXTENT_MIN_XY 64

/* The cache's image: the shape within `room` bytes at `bytes` a texel that holds the most
 * slots up to `want` (leap_atlas_image_shape); the smallest when none fits, which may exceed a
 * smaller room. Returns its slots. */
static uint64_t cache_shape(uint64_t room, uint64_t bytes, uint64_t want, uint32_t slot_dims[3], uint32_t texel_dims[3])
{
    return leap_atlas_image_shape(want, room / bytes, CACHE_EXTENT_MIN_XY, slot_dims, texel_dims);
}

/* The slots a cache's image holds within `room` at `bytes` a texel (at most the atlas's). */
static uint64_t cache_slots(const leap_atlas *atlas, uint64_t room, uint64_t bytes)
{
    uint32_t slot_dims[3], texel_dims[3];
    return cache_shape(room, bytes, atlas->slot_count, slot_dims, texel_dims);
}

/* Float texels filter faster, 16-bit ones (the same values) hold twice the slots: float only
 * when it holds every slot. */
static uint64_t cache_texel_bytes(const leap_renderer *r, const leap_atlas *atlas)
{
    const int float_holds_all = cache_slots(atlas, r->cache_room, sizeof(float)) >= atlas->slot_count;
    return r->cache_room <= r->float_atlas_max_bytes && float_holds_all ? sizeof(float) : sizeof(uint16_t);
}

static uint32_t pack_slot(const uint32_t dims[3], uint32_t slot)
{
    const uint32_t x = slot % dims[0], y = slot / dims[0] % dims[1], z = slot / dims[0] / dims[1];
    return x | y << LEAP_SLOT_BITS | z << (2 * LEAP_SLOT_BITS);
}

typedef struct cache_fill {
    const leap_renderer *r;
    int as_float;
} cache_fill;

/* The image's texels (leap_texel_fill): each image slot's host slot, 0 where none. */
static void fill_texels(void *dst, size_t first, size_t count, const void *ctx)
{
    const cache_fill *f = ctx;
    const brick_cache *c = &f->r->cache;
    const uint32_t *td = f->r->texel_dims, *sd = f->r->slot_dims;
    for (size_t i = 0; i < count; ++i) {
        const size_t n = first + i, x = n % td[0], y = n / td[0] % td[1], z = n / td[0] / td[1];
        const uint32_t slot = (uint32_t)(x / LEAP_SLOT + sd[0] * (y / LEAP_SLOT + (size_t)sd[1] * (z / LEAP_SLOT)));
        const int spare = x >= sd[0] * LEAP_SLOT || y >= sd[1] * LEAP_SLOT; /* past the last slot of a row or column */
        const uint32_t host = !spare && slot < c->capacity ? c->host_of[slot] : CACHE_NONE;
        const uint16_t v = host == CACHE_NONE ? 0
                           : c->atlas->slot_texels[(size_t)host * LEAP_SLOT_TEXELS + x % LEAP_SLOT +
                                                   LEAP_SLOT * (y % LEAP_SLOT + LEAP_SLOT * (z % LEAP_SLOT))];
        if (f->as_float) ((float *)dst)[i] = renderer_texel_float(v);
        else ((uint16_t *)dst)[i] = v;
    }
}

uint32_t renderer_cache_capacity(leap_renderer *r, const leap_atlas *atlas, uint64_t stream_bytes)
{
    const int streamed = !atlas->slot_texels && !atlas->labels;
    r->cache_room = r->cache_bytes;
    if (streamed && stream_bytes && (!r->cache_room || stream_bytes < r->cache_room)) r->cache_room = stream_bytes;
    if (atlas->labels || atlas->slot_count == 0) return 0;
    if (!r->cache_room) return streamed ? atlas->slot_count : 0;
    const uint64_t slots = cache_slots(atlas, r->cache_room, cache_texel_bytes(r, atlas));
    if (slots >= atlas->slot_count) return streamed ? atlas->slot_count : 0;
    return (uint32_t)slots;
}

void renderer_cache_release(leap_renderer *r)
{
    brick_cache *c = &r->cache;
    free(c->host_of);
    free(c->image_of);
    free(c->entry_word);
    free(c->loaded_in);
    memset(c, 0, sizeof *c);
}

leap_result renderer_cache_upload(leap_renderer *r, const leap_atlas *atlas, uint32_t capacity, leap_error *err)
{
    renderer_cache_release(r);
    if (atlas->slot_count > LEAP_PAGE_EMPTY) /* a missing cell's entry holds its host slot below that bit */
        return leap_fail(err, LEAP_ERR_UNSUPPORTED, "the volume has %u bricks; a brick cache numbers at most %u",
                         atlas->slot_count, LEAP_PAGE_EMPTY);
    brick_cache *c = &r->cache;
    c->capacity = capacity;
    c->host_slots = atlas->slot_count;
    c->atlas = atlas;
    c->host_of = malloc(capacity * sizeof *c->host_of);
    c->loaded_in = calloc(capacity, sizeof *c->loaded_in);
    c->image_of = malloc(atlas->slot_count * sizeof *c->image_of);
    c->entry_word = malloc(atlas->slot_count * sizeof *c->entry_word);
    if (!c->host_of || !c->loaded_in || !c->image_of || !c->entry_word) {
        renderer_cache_release(r);
        return leap_fail(err, LEAP_ERR_OOM, "renderer: out of host memory for a brick cache of %u slots", capacity);
    }
    /* At first the image holds the first host slots, in order; none of an atlas that keeps no
     * texels, whose slots are read as rays miss them. */
    const uint32_t resident = atlas->slot_texels ? capacity : 0;
    for (uint32_t i = 0; i < capacity; ++i) c->host_of[i] = i < resident ? i : CACHE_NONE;
    for (uint32_t h = 0; h < atlas->slot_count; ++h) c->image_of[h] = h < resident ? h : CACHE_NONE;
    r->texel_bytes = (uint32_t)cache_texel_bytes(r, atlas);
    const int as_float = r->texel_bytes == sizeof(float);
    cache_shape(r->cache_room, r->texel_bytes, capacity, r->slot_dims, r->texel_dims);
    const cache_fill fill = {r, as_float};
    leap_result lr = leap_gpu_image_fill(r->gpu, as_float ? VK_FORMAT_R32_SFLOAT : VK_FORMAT_R16_UNORM, r->texel_dims,
                                         r->texel_bytes, fill_texels, &fill, &r->atlas, err);
    const size_t range_bytes = (size_t)r->slot_dims[0] * r->slot_dims[1] * r->slot_dims[2] * sizeof(uint32_t);
    if (!lr) lr = leap_gpu_buffer_create(r->gpu, range_bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &r->slot_ranges, err);
    if (lr) {
        renderer_cache_release(r);
        return lr;
    }
    uint32_t *ranges = r->slot_ranges.mapped;
    memset(ranges, 0, range_bytes);
    for (uint32_t i = 0; i < resident; ++i) ranges[i] = atlas->slot_ranges[i];
    /* The cell entries follow the middle nodes; every one that is no constant is a slot. */
    uint32_t *pages = r->pages.mapped;
    memcpy(pages, atlas->pages, atlas->page_words * 4);
    for (size_t w = atlas->block_base; w < atlas->page_words; ++w) {
        if (pages[w] & LEAP_PAGE_CONST) continue;
        const uint32_t h = leap_atlas_entry_slot(atlas->slot_dims, pages[w]);
        c->entry_word[h] = (uint32_t)w;
        pages[w] = h < resident ? pack_slot(r->slot_dims, h) : LEAP_PAGE_MISSING | h;
    }
    return LEAP_OK;
}

int renderer_cache_missed(const leap_renderer *r)
{
    return r->cache.capacity && ((const uint32_t *)r->misses.mapped)[0] != 0;
}

void renderer_cache_forget_misses(leap_renderer *r)
{
    memset(r->misses.mapped, 0, (((size_t)r->cache.host_slots + 31) / 32 + 1) * sizeof(uint32_t));
}

leap_result renderer_cache_service(leap_renderer *r, leap_frame_stats *st, leap_error *err)
{
    brick_cache *c = &r->cache;
    uint32_t *bits = (uint32_t *)r->misses.mapped + 1, *pages = r->pages.mapped, *ranges = r->slot_ranges.mapped;
    const uint32_t service = ++c->service;
    const size_t words = ((size_t)c->host_slots + 31) / 32;
    /* Room for the texels of every slot this service can load, before any page entry changes. */
    uint64_t missed = 0;
    for (size_t w = 0; w < words; ++w) missed += (uint64_t)__builtin_popcount(bits[w]);
    const uint32_t most = missed < c->capacity ? (uint32_t)missed : c->capacity;
    uint32_t(*origins)[3] = malloc((most ? most : 1) * sizeof *origins);
    uint32_t *hosts = malloc((most ? most : 1) * sizeof *hosts);
    void *texels = malloc((size_t)(most ? most : 1) * LEAP_SLOT_TEXELS * r->texel_bytes);
    if (!origins || !hosts || !texels) {
        free(origins);
        free(hosts);
        free(texels);
        return leap_fail(err, LEAP_ERR_OOM, "brick cache: out of host memory for %u slots", most);
    }
    /* A file cut short under its mapping would fault the reads: checked first. */
    leap_result lr = leap_atlas_check_source(c->atlas, err);
    /* The missed slots, in host order, each into its place; then their texels, cube by cube. */
    uint32_t n = 0;
    for (size_t w = 0; w < words && !lr; ++w)
        for (uint32_t b = bits[w]; b; b &= b - 1) {
            const uint32_t h = (uint32_t)(w * 32) + (uint32_t)__builtin_ctz(b);
            /* Its place, unless a slot missed before it took that place in this service: h then
             * waits for a later one. */
            const uint32_t slot = h % c->capacity, old = c->host_of[slot];
            if (c->loaded_in[slot] == service || c->image_of[h] != CACHE_NONE) continue;
            if (old != CACHE_NONE) {
                pages[c->entry_word[old]] = (pages[c->entry_word[old]] & LEAP_PAGE_EMPTY) | LEAP_PAGE_MISSING | old;
                c->image_of[old] = CACHE_NONE;
                ++st->cache_evicted;
            }
            c->host_of[slot] = h;
            c->image_of[h] = slot;
            c->loaded_in[slot] = service;
            pages[c->entry_word[h]] = (pages[c->entry_word[h]] & LEAP_PAGE_EMPTY) | pack_slot(r->slot_dims, slot);
            const uint32_t *d = r->slot_dims;
            origins[n][0] = slot % d[0] * LEAP_SLOT;
            origins[n][1] = slot / d[0] % d[1] * LEAP_SLOT;
            origins[n][2] = slot / d[0] / d[1] * LEAP_SLOT;
            hosts[n++] = h;
        }
    st->cache_misses += missed;
    /* Read as 16-bit texels at the front of the buffer; float images widen them in place, from
     * the last down (texel i's float covers 16-bit texels 2i and 2i + 1, already widened). A slot
     * that cannot be read ends the frame with that error. */
    if (!lr) lr = leap_atlas_read_slots(c->atlas, hosts, n, texels, err);
    /* After the read: a lazy atlas learns a slot's range as it is first read. A lazy atlas's slot
     * whose texels are one value becomes the constant entry the whole atlas's build would have
     * made of its cell (so the samples are the same) and gives its place back. */
    for (uint32_t i = 0; i < n && !lr; ++i) {
        const uint32_t h = hosts[i], slot = c->image_of[h], range = c->atlas->slot_ranges[h];
        ranges[slot] = range;
        if (!c->atlas->learning || (range & 0xffffu) != range >> 16) continue;
        pages[c->entry_word[h]] = LEAP_PAGE_CONST | (range & 0xffffu);
        c->image_of[h] = CACHE_CONSTANT;
        c->host_of[slot] = CACHE_NONE;
    }
    if (!lr && r->texel_bytes == sizeof(float))
        for (size_t i = (size_t)n * LEAP_SLOT_TEXELS; i-- > 0;)
            ((float *)texels)[i] = renderer_texel_float(((const uint16_t *)texels)[i]);
    if (!lr) lr = n ? leap_gpu_image_write_cubes(r->gpu, &r->atlas, r->texel_bytes, LEAP_SLOT, n,
                                                    (const uint32_t(*)[3])origins, texels, err)
                       : leap_fail(err, LEAP_ERR_UNSUPPORTED, "brick cache: rays wait on slots that are resident "
                                   "(no progress)");
    free(hosts);
    free(origins);
    free(texels);
    renderer_cache_forget_misses(r);
    st->cache_loaded += n;
    return lr;
}
