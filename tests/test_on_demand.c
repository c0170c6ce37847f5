/* Grids read on demand under a memory budget (leap_scene_desc.memory_budget, --memory-budget):
 * a generated fog whose values need more memory than the budget is read leaf by leaf from its
 * file; its atlas keeps no texels and reads a slot again when a ray misses it. The atlas is the
 * in-memory grid's (pages, slot ranges, every slot's texels); every mode, plain and MIP, gives
 * the in-memory grid's image through the same GPU cache bit for bit, also with the smallest cache
 * (one layer of the atlas's bricks), and each of those caches gives the whole atlas's image bit
 * for bit.
 * Shading and budgets too small are refused with the reason; LEAP_MEMORY_BUDGET is read. A file
 * changed or cut short while open fails the frames that read it, with the reason. Frames show
 * incomplete pictures while bricks load (leap_renderer_set_partial). The
 * program `leap render` renders a fog of 4x the budget's bytes with a peak resident memory
 * within the budget above what a tiny volume's render takes (the fixed overhead: libraries,
 * pipelines, image buffers), to the same image as in memory, and reads the whole file from
 * storage on its first open when the file's pages were dropped from the page cache (under the
 * sanitizers, whose shadow memory makes peaks meaningless, a fog of 0.8x the budget). */
#define W 96 /* the frames' size (gpu_fixture.h's frame_out) */
#define H 96
#include "cli_harness.h"
#include "gpu_fixture.h"
#include "leap/atlas.h"
#include "leap/image.h"
#include "leap/grid_index.h"
#include "leap/scene.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

/* leap_make_volumes --fog PATH --size N (`recorded` 0: --unrecorded, as files written elsewhere
 * come, whose first open reads every leaf); 0 when that fails. */
static int make_fog(const char *path, int n, int recorded)
{
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "'%s' --fog '%s' --size %d%s > /dev/null", LEAP_MAKE_VOLUMES, path, n,
             recorded ? "" : " --unrecorded");
    const int ok = system(cmd) == 0;
    CHECK_MSG(ok, "%s failed", cmd);
    return ok;
}

static leap_scene *load(const char *path, uint64_t budget, int mip, leap_error *err)
{
    leap_scene_desc d = {.path = path, .step = 0.5, .mip = mip, .memory_budget = budget};
    leap_scene *s = NULL;
    return leap_scene_create(&d, &s, err) ? NULL : s;
}

/* A view from `dist` bounding radii (0: the whole volume in view) with a vertical field of
 * `fov` degrees; the result. */
static leap_result render_result(leap_renderer *r, leap_scene *s, leap_mode mode, double dist, double fov, frame_out *out,
                                 leap_error *err)
{
    leap_camera cam;
    leap_rays view;
    leap_result lr = leap_renderer_bind_scene(r, s, err);
    if (!lr) lr = leap_camera_orbit(s->center, s->radius, 35, 25, dist, fov, 0, &cam, err);
    if (!lr) lr = leap_scene_rays(s, &cam, W, H, &view, err);
    if (!lr) lr = leap_renderer_render(r, &view, &s->march, mode, out->rgba, out->depth, out->samples, &out->st, err);
    return lr;
}

/* As render_result; 1 if it rendered, else 0 after printing why. */
static int render_view(leap_renderer *r, leap_scene *s, leap_mode mode, double dist, double fov, frame_out *out)
{
    leap_error err = {{0}};
    if (render_result(r, s, mode, dist, fov, out, &err)) {
        printf("FAIL: %s\n", err.msg);
        return 0;
    }
    return 1;
}

static int render(leap_renderer *r, leap_scene *s, leap_mode mode, frame_out *out)
{
    return render_view(r, s, mode, 0, 40, out);
}

/* The atlas read on demand is the in-memory one, texels included: the same entries, slots
 * numbered alike (a streamed atlas has no image, so its slot numbers pack another way). */
static void check_atlas(const leap_atlas *whole, const leap_atlas *lazy)
{
    CHECK(whole->slot_texels && !lazy->slot_texels && lazy->slot_cells);
    CHECK(whole->slot_count == lazy->slot_count && whole->page_words == lazy->page_words);
    if (whole->slot_count != lazy->slot_count || whole->page_words != lazy->page_words) return;
    size_t entries = 0;
    for (size_t w = 0; w < whole->page_words; ++w) {
        const uint32_t a = whole->pages[w], b = lazy->pages[w];
        if (w < whole->block_base || (a & LEAP_PAGE_CONST) || (b & LEAP_PAGE_CONST)) {
            entries += a != b;
            continue;
        }
        const uint32_t sa = leap_atlas_entry_slot(whole->slot_dims, a), sb = leap_atlas_entry_slot(lazy->slot_dims, b);
        entries += sa != sb || whole->slot_ranges[sa] != lazy->slot_ranges[sb];
    }
    CHECK_MSG(entries == 0, "%zu page entries differ", entries);
    static uint16_t a[LEAP_SLOT_TEXELS], b[LEAP_SLOT_TEXELS];
    uint32_t differ = 0;
    leap_error err = {{0}};
    for (uint32_t h = 0; h < whole->slot_count; ++h) {
        CHECK_OK(leap_atlas_read_slot(whole, h, a, &err), &err);
        CHECK_OK(leap_atlas_read_slot(lazy, h, b, &err), &err);
        differ += memcmp(a, b, sizeof a) != 0;
    }
    CHECK_MSG(differ == 0, "%u of %u slots read on demand differ", differ, whole->slot_count);
}

static int same_frames(const frame_out *a, const frame_out *b)
{
    return !memcmp(a->rgba, b->rgba, sizeof a->rgba) && !memcmp(a->depth, b->depth, sizeof a->depth);
}

/* Each mode of mode_mask (bit m: modes[m]) through the same cache: the grid read on demand
 * gives the in-memory image. */
static void check_frames(leap_renderer *cache, leap_scene *whole, leap_scene *lazy, const char *what, unsigned mode_mask)
{
    static frame_out a, b;
    for (size_t m = 0; m < sizeof modes / sizeof *modes; ++m) {
        if (!(mode_mask >> m & 1u)) continue;
        if (!render(cache, whole, modes[m], &a) || !render(cache, lazy, modes[m], &b)) continue;
        const int same = same_frames(&a, &b);
        printf("%-5s %-10s cache %5u of %6u bricks: %3u passes, %6llu loaded; on demand %s in memory\n", what,
               mode_names[m], b.st.cache_slots, lazy->atlas->slot_count, b.st.cache_passes,
               (unsigned long long)b.st.cache_loaded, same ? "equals" : "DIFFERS FROM");
        CHECK_MSG(same, "%s %s: the grid read on demand renders another image", what, mode_names[m]);
        CHECK(a.st.cache_slots == b.st.cache_slots && b.st.cache_passes > 1);
    }
}

static void test_scenes(const char *fog)
{
    leap_error err = {{0}};
    const uint64_t budget = 32u << 20; /* the fog needs about 2 x 31 MiB */
    leap_scene *whole = load(fog, 0, 0, &err), *lazy = load(fog, budget, 0, &err);
    CHECK_MSG(whole && lazy, "%s", err.msg);
    if (!whole || !lazy) goto done;
    CHECK(!leap_grid_on_demand(whole->grid) && leap_grid_on_demand(lazy->grid));
    CHECK(whole->gpu_cache_bytes == 0 && lazy->gpu_cache_bytes > 0 && lazy->gpu_cache_bytes < budget);
    printf("fog: %u bricks; on demand: %.1f MiB of the %.0f MiB budget left for the GPU cache\n",
           lazy->atlas->slot_count, (double)lazy->gpu_cache_bytes / (1 << 20), (double)budget / (1 << 20));
    check_atlas(whole->atlas, lazy->atlas);

    /* Three layers of the atlas's bricks, and one, the smallest cache (thrashing): the same
     * cache for both grids. */
    const leap_renderer_desc some = {.cache_bytes = 2u << 20}, few = {.cache_bytes = 64u << 10};
    leap_renderer *r_some = make_renderer_with(&some), *r_few = make_renderer_with(&few), *r_room = make_renderer();
    if (r_some && r_few && r_room) {
        check_frames(r_some, whole, lazy, "plain", 0xfu);
        check_frames(r_few, whole, lazy, "plain", 0xfu);
        /* MIP's rays never stop early, so they thrash this cache for long. Under the sanitizers,
         * which do not see into the shaders where the modes differ, naive and sparseleap (the
         * lists) cover the host's paths. */
#ifdef LEAP_SANITIZED
        const unsigned mip_modes = 0x9u;
#else
        const unsigned mip_modes = 0xfu;
#endif
        leap_scene *whole_mip = load(fog, 0, LEAP_MIP_MAX, &err), *lazy_mip = load(fog, budget, LEAP_MIP_MAX, &err);
        if (whole_mip && lazy_mip) check_frames(r_some, whole_mip, lazy_mip, "mip", mip_modes);
        leap_scene_destroy(whole_mip);
        leap_scene_destroy(lazy_mip);
        /* Where a brick sits in the GPU image does not change its samples: the grid read on
         * demand through the cache the budget leaves, and through the small ones, gives the
         * whole atlas's image bit for bit. */
        static frame_out a, b;
        leap_renderer *caches[3] = {r_room, r_some, r_few};
        if (render(r_room, whole, LEAP_RENDER_SPARSELEAP, &a)) {
            CHECK(a.st.cache_slots == 0);
            for (int i = 0; i < 3; ++i) {
                if (!render(caches[i], lazy, LEAP_RENDER_SPARSELEAP, &b)) continue;
                const image_diff d = compare_rgba(a.rgba, b.rgba, W * H);
                printf("cache of %u slots, %u passes: against the whole atlas max abs %.1e\n", b.st.cache_slots,
                       b.st.cache_passes, d.max_abs);
                CHECK(b.st.cache_slots > 0);
                CHECK_MSG(same_frames(&a, &b), "a cache of %u slots: max abs %g", b.st.cache_slots, d.max_abs);
            }
        }
    }
    leap_renderer_destroy(r_some);
    leap_renderer_destroy(r_few);
    leap_renderer_destroy(r_room);

    /* Shading needs the whole volume; a budget below the grid's bookkeeping is refused. */
    leap_shading shade = leap_shading_default();
    leap_result r = leap_scene_set_shading(lazy, &shade, &err);
    CHECK_MSG(r == LEAP_ERR_UNSUPPORTED && strstr(err.msg, "on demand"), "%d %s", r, err.msg);
    leap_scene *tiny = load(fog, 4u << 20, 0, &err);
    CHECK_MSG(!tiny && strstr(err.msg, "too small"), "%s", err.msg);
    leap_scene_destroy(tiny);
    /* LEAP_MEMORY_BUDGET when none is given. */
    setenv("LEAP_MEMORY_BUDGET", "lots", 1);
    tiny = load(fog, 0, 0, &err);
    CHECK_MSG(!tiny && strstr(err.msg, "LEAP_MEMORY_BUDGET"), "%s", err.msg);
    leap_scene_destroy(tiny);
    setenv("LEAP_MEMORY_BUDGET", "32MiB", 1);
    tiny = load(fog, 0, 0, &err);
    CHECK_MSG(tiny && leap_grid_on_demand(tiny->grid), "%s", err.msg);
    leap_scene_destroy(tiny);
    unsetenv("LEAP_MEMORY_BUDGET");
done:
    leap_scene_destroy(whole);
    leap_scene_destroy(lazy);
}

/* A copy of `path` whose recorded scan says its stored values end at half their largest (its
 * exponent's one less), as a file changed by another tool that kept the record would; 0 when
 * the record is not found. */
static int write_lying_copy(const char *path, const char *out)
{
    long n = 0;
    char *bytes = read_whole_file(path, &n);
    char *at = NULL;
    for (long i = 0; bytes && i + 9 < n && !at; ++i)
        if (!memcmp(bytes + i, "leap_scan", 9)) at = bytes + i;
    /* "leap_scan", the type's name, the value's length, then the tokens: the 4th is stored max. */
    char *value = at ? (char *)memchr(at + 9, '0', (size_t)(bytes + n - at - 9)) : NULL;
    for (int token = 0; value && token < 3; ++token) value = strchr(value, ' ') ? strchr(value, ' ') + 1 : NULL;
    char *exponent = value ? strstr(value, "p-1 ") : NULL;
    int ok = exponent && exponent - value < 16;
    if (ok) exponent[2] = '2';
    FILE *f = ok ? fopen(out, "wb") : NULL;
    ok = f && fwrite(bytes, 1, (size_t)n, f) == (size_t)n;
    if (f) ok &= fclose(f) == 0;
    free(bytes);
    return ok;
}

/* A grid that records its leaves' scan (files written by leap), over the budget and without an
 * index, is read lazily: its open reads no leaf, its cells next to data start UNKNOWN, and a
 * frame reads the leaves its rays reach. Every mode gives the in-memory image bit for bit, before
 * and after the cells learn their classes; once learned, sparseleap skips what is empty there;
 * a narrow view reads a small share of the leaves. A file whose values differ from its record
 * fails, read whole or lazily. */
static leap_scene *load_window(const char *path, uint64_t budget, leap_error *err)
{
    /* The fog's values lie in [0.05, 0.95]: below 0.6 they are transparent, so cells are EMPTY too. */
    leap_scene_desc d = {.path = path, .step = 0.5, .memory_budget = budget, .has_range = 1, .range = {0.6, 0.95}};
    leap_scene *s = NULL;
    return leap_scene_create(&d, &s, err) ? NULL : s;
}

static void test_lazy(const char *fog)
{
    leap_error err = {{0}};
    const uint64_t budget = 32u << 20;
    static frame_out a, b, c;
    leap_renderer *r = make_renderer();
    leap_scene *whole = load_window(fog, 0, &err), *lazy = load_window(fog, budget, &err), *narrow = NULL;
    CHECK_MSG(r && whole && lazy, "%s", err.msg);
    if (!r || !whole || !lazy) goto done;
    CHECK_MSG(lazy->index.lazy && lazy->leaves_read_to_open == 0 && !strncmp(lazy->index.note, "not used: the grid records", 26),
              "index '%s', %llu leaves read to open", lazy->index.note, (unsigned long long)lazy->leaves_read_to_open);
    leap_occupancy_stats os;
    leap_occupancy_get_stats(lazy->occupancy, &os);
    const uint64_t unknown = os.cells[LEAP_CLASS_UNKNOWN];
    CHECK_MSG(unknown > 0 && os.cells[LEAP_CLASS_NONEMPTY] == 0 && lazy->cells_unknown_at_open >= whole->atlas->slot_count,
              "%llu UNKNOWN and %llu NONEMPTY cells at the open, %llu cells to learn, %u slots in memory",
              (unsigned long long)unknown, (unsigned long long)os.cells[LEAP_CLASS_NONEMPTY],
              (unsigned long long)lazy->cells_unknown_at_open, whole->atlas->slot_count);
    for (size_t m = 0; m < sizeof modes / sizeof *modes; ++m) {
        if (!render(r, whole, modes[m], &a) || !render(r, lazy, modes[m], &b)) continue;
        CHECK_MSG(same_frames(&a, &b), "lazily %s: another image than in memory", mode_names[m]);
    }
    /* The frames read the cells rays reached: their classes now, and the frame is the same. */
    CHECK_OK(leap_scene_learn(lazy, &err), &err);
    leap_occupancy_get_stats(lazy->occupancy, &os);
    printf("lazily: %llu cells UNKNOWN at the open, %llu learned by the frames (%llu leaves read of %llu), %llu still "
           "UNKNOWN\n", (unsigned long long)lazy->cells_unknown_at_open, (unsigned long long)lazy->cells_learned,
           (unsigned long long)leap_grid_leaves_read(lazy->grid), (unsigned long long)lazy->info->leaf_count,
           (unsigned long long)os.cells[LEAP_CLASS_UNKNOWN]);
    CHECK(lazy->cells_learned > 0 && lazy->cells_learned_last == lazy->cells_learned &&
          os.cells[LEAP_CLASS_UNKNOWN] < unknown && os.cells[LEAP_CLASS_NONEMPTY] > 0);
    if (render(r, lazy, LEAP_RENDER_SPARSELEAP, &c)) {
        CHECK_MSG(same_frames(&a, &c), "lazily, after learning: another image than in memory");
        printf("sparseleap lazily: %.1f samples a pixel before learning, %.1f after, %.1f in memory\n",
               b.st.samples_mean, c.st.samples_mean, a.st.samples_mean);
        /* Fewer than in memory, even: a learned cell's range is its footprint's, tighter than the
         * bricks' ranges with their aprons that the in-memory classes come from. */
        CHECK(c.st.samples_mean < b.st.samples_mean);
    }
    /* A narrow view reads the leaves its rays reach. */
    narrow = load_window(fog, budget, &err);
    if (narrow && render_view(r, whole, LEAP_RENDER_SPARSELEAP, 3, 4, &a) &&
        render_view(r, narrow, LEAP_RENDER_SPARSELEAP, 3, 4, &b)) {
        const uint64_t read = leap_grid_leaves_read(narrow->grid), leaves = narrow->info->leaf_count;
        CHECK_OK(leap_scene_learn(narrow, &err), &err);
        printf("a 4-degree view read %llu of %llu leaves lazily, and learned %llu of %llu cells\n",
               (unsigned long long)read, (unsigned long long)leaves, (unsigned long long)narrow->cells_learned,
               (unsigned long long)narrow->cells_unknown_at_open);
        CHECK_MSG(same_frames(&a, &b), "a narrow view read lazily: another image than in memory");
        /* Its rays march UNKNOWN cells until they are learned, transparent ones too (measured: 4.8 %). */
        CHECK_MSG(read > 0 && read * 10 <= leaves && narrow->cells_learned * 10 <= narrow->cells_unknown_at_open,
                  "a 4-degree view read %llu of %llu leaves", (unsigned long long)read, (unsigned long long)leaves);
    }
    /* A file whose values are not those it records: refused whole; lazily, the frame that reads
     * such a leaf fails (as a leaf that cannot be read does). */
    char lying[1200];
    snprintf(lying, sizeof lying, "%s.lying.vdb", fog);
    CHECK(write_lying_copy(fog, lying));
    leap_scene *bad = load(lying, 0, 0, &err);
    CHECK_MSG(!bad && strstr(err.msg, "metadata records"), "read whole: %s", err.msg);
    leap_scene_destroy(bad);
    bad = load(lying, budget, 0, &err);
    CHECK_MSG(bad != NULL, "%s", err.msg);
    if (bad) {
        const leap_result fr = render_result(r, bad, LEAP_RENDER_NAIVE, 0, 40, &b, &err);
        CHECK_MSG(fr == LEAP_ERR_FORMAT && strstr(err.msg, "metadata records"), "read lazily: %d %s", fr, err.msg);
    }
    leap_scene_destroy(bad);
    remove(lying);
done:
    leap_scene_destroy(narrow);
    leap_scene_destroy(whole);
    leap_scene_destroy(lazy);
    leap_renderer_destroy(r);
}

/* Opens the fog on demand and says what became of its index (leap_scene.index.note). */
static leap_scene *load_noting(const char *fog, uint64_t budget, const char *expect)
{
    leap_error err = {{0}};
    leap_scene *s = load(fog, budget, 0, &err);
    CHECK_MSG(s, "%s", err.msg);
    if (s) CHECK_MSG(!strncmp(s->index.note, expect, strlen(expect)), "index '%s', expected '%s'", s->index.note, expect);
    return s;
}

/* A file of `bytes` bytes last modified age_s seconds ago. */
static int write_file(const char *path, size_t bytes, time_t age_s)
{
    char *data = malloc(bytes);
    if (!data) return 0;
    memset(data, 'x', bytes);
    write_bytes(path, data, bytes);
    free(data);
    const struct timespec t[2] = {{time(NULL) - age_s, 0}, {time(NULL) - age_s, 0}};
    return utimensat(AT_FDCWD, path, t, 0) == 0;
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* The index directory stays within LEAP_INDEX_MAX: a write removes the least recently used
 * other indexes until they fit, keeps the one written and every file that is not an index,
 * and reading an index marks it used. */
static void test_index_prune(const char *fog, const char *path)
{
    const struct timespec long_ago[2] = {{time(NULL) - 20000, 0}, {time(NULL) - 20000, 0}};
    CHECK(utimensat(AT_FDCWD, path, long_ago, 0) == 0);
    leap_scene_destroy(load_noting(fog, 32u << 20, "used"));
    struct stat st;
    CHECK(stat(path, &st) == 0 && st.st_mtime >= time(NULL) - 600);
    /* A directory of its own: old indexes, a file that is not one, then this grid's index. */
    char dir[800], old[3][1500], notes[1500], written[1500];
    snprintf(dir, sizeof dir, "%s/prune", tmp_dir);
    mkdir(dir, 0755);
    snprintf(written, sizeof written, "%s/%s", dir, strrchr(path, '/') + 1);
    snprintf(notes, sizeof notes, "%s/notes.txt", dir);
    remove(written);
    const size_t other = 400 << 10;
    int ok = write_file(notes, other, 9000);
    for (int k = 0; k < 3; ++k) {
        snprintf(old[k], sizeof old[k], "%s/old-%d.leapidx", dir, k);
        ok = ok && write_file(old[k], other, 3000 - 1000 * k); /* old-0 the least recent */
    }
    CHECK(ok);
    /* Room for the index and one more of those: the two least recently used go. */
    char max[32];
    snprintf(max, sizeof max, "%llu", (unsigned long long)st.st_size + other + 1024);
    setenv("LEAP_INDEX_MAX", max, 1);
    CHECK(leap_grid_index_max_bytes() == (uint64_t)st.st_size + other + 1024);
    leap_error err = {{0}};
    leap_file_stamp stamp;
    leap_grid_index *x = NULL;
    char why[160];
    CHECK_OK(leap_file_stamp_get(fog, &stamp, &err), &err);
    CHECK_OK(leap_grid_index_read(path, &stamp, "density", &x, why, sizeof why, &err), &err);
    if (x) CHECK_OK(leap_grid_index_write(written, fog, &stamp, "density", x, &err), &err);
    leap_grid_index_destroy(x);
    CHECK_MSG(!exists(old[0]) && !exists(old[1]) && exists(old[2]), "pruned: old-0 %d, old-1 %d, old-2 %d",
              exists(old[0]), exists(old[1]), exists(old[2]));
    CHECK(exists(written) && exists(notes));
    /* A limit below the one just written: it stays, alone. */
    CHECK(leap_grid_index_prune(written, 1) == 1 && exists(written) && !exists(old[2]));
    setenv("LEAP_INDEX_MAX", "lots", 1);
    CHECK(leap_grid_index_max_bytes() == LEAP_GRID_INDEX_MAX_DEFAULT);
    unsetenv("LEAP_INDEX_MAX");
    remove(notes);
    remove(written);
}

/* Two streamed atlases of one grid are the same: pages, slot cells and slot ranges. */
static void check_same_streamed(const leap_atlas *a, const leap_atlas *b)
{
    CHECK(a->slot_count == b->slot_count && a->page_words == b->page_words);
    if (a->slot_count != b->slot_count || a->page_words != b->page_words) return;
    CHECK(!memcmp(a->pages, b->pages, a->page_words * 4));
    CHECK(!memcmp(a->slot_cells, b->slot_cells, a->slot_count * 8));
    CHECK(!memcmp(a->slot_ranges, b->slot_ranges, a->slot_count * 4));
}

/* The grid index: the first open writes it; the next reads no leaf, builds the same atlas and
 * renders the same images, and a narrow view then reads only the leaves its rays reach. A
 * corrupt, truncated or stale index is rebuilt, an unwritable directory only noted. */
static void test_index(const char *fog)
{
    char dir[700], path[1400];
    const uint64_t budget = 32u << 20;
    leap_error err = {{0}};
    snprintf(dir, sizeof dir, "%s/index", tmp_dir);
    setenv("LEAP_INDEX_DIR", dir, 1);
    CHECK_OK(leap_grid_index_path(dir, fog, "density", path, sizeof path, &err), &err);
    remove(path);
    leap_scene *first = load_noting(fog, budget, "written"), *second = load_noting(fog, budget, "used");
    /* The second open through the cache its budget leaves, the first also through a smaller one:
     * where bricks sit does not change the image. */
    const leap_renderer_desc small_cache = {.cache_bytes = 1u << 20};
    leap_renderer *r = make_renderer(), *r_small = make_renderer_with(&small_cache);
    if (!first || !second || !r || !r_small) goto done;
    const uint64_t leaves = first->info->leaf_count;
    printf("index: the first open read %llu leaves of %llu, the second %llu\n",
           (unsigned long long)first->leaves_read_to_open, (unsigned long long)leaves,
           (unsigned long long)second->leaves_read_to_open);
    CHECK(first->leaves_read_to_open >= leaves && second->leaves_read_to_open == 0);
    CHECK(first->info->value_min == second->info->value_min && first->info->value_max == second->info->value_max);
    check_same_streamed(first->atlas, second->atlas);
    static frame_out a, b, ref;
    /* A narrow view first, on the fresh open: the leaves its rays reach. */
    const uint64_t before = leap_grid_leaves_read(second->grid);
    if (render_view(r, second, LEAP_RENDER_SPARSELEAP, 3, 4, &b) && render_view(r, first, LEAP_RENDER_SPARSELEAP, 3, 4, &a)) {
        const uint64_t read = leap_grid_leaves_read(second->grid) - before;
        printf("index: a 4-degree view read %llu leaves of %llu (%.2f %%)\n", (unsigned long long)read,
               (unsigned long long)leaves, 100.0 * (double)read / (double)leaves);
        CHECK_MSG(read > 0 && read * 50 < leaves, "the narrow view read %llu leaves", (unsigned long long)read);
        CHECK_MSG(same_frames(&a, &b), "the narrow view differs with the index");
    }
    for (size_t m = 0; m < sizeof modes / sizeof *modes; ++m)
        if (render(r_small, first, modes[m], &a) && render(r, second, modes[m], &b)) {
            CHECK_MSG(same_frames(&a, &b), "%s differs with the index", mode_names[m]);
            if (m == 0) printf("index: caches of %u and %u slots\n", a.st.cache_slots, b.st.cache_slots);
            CHECK(a.st.cache_slots > 0 && b.st.cache_slots > a.st.cache_slots);
        }
    const int have_ref = render(r, first, LEAP_RENDER_SPARSELEAP, &ref);
    leap_scene_destroy(second);
    leap_scene_destroy(first); /* before the file is touched below, which OpenVDB would warn of */
    first = NULL;

    /* A byte flipped, the file cut short, the grid's file changed: rebuilt, and used again. */
    FILE *f = fopen(path, "r+b");
    CHECK(f && fseek(f, -5, SEEK_END) == 0);
    if (f) {
        const int c = fgetc(f);
        fseek(f, -5, SEEK_END);
        fputc(c ^ 0x40, f);
        fclose(f);
    }
    leap_scene_destroy(load_noting(fog, budget, "rebuilt: its checksum"));
    CHECK(truncate(path, 100) == 0);
    leap_scene_destroy(load_noting(fog, budget, "rebuilt: it is truncated"));
    CHECK(utimensat(AT_FDCWD, fog, NULL, 0) == 0);
    second = load_noting(fog, budget, "rebuilt: the file changed");
    if (second && have_ref && render(r, second, LEAP_RENDER_SPARSELEAP, &b))
        CHECK_MSG(same_frames(&ref, &b), "the rebuilt index renders another image");
    leap_scene_destroy(second);
    /* An index that passes its checks but does not fit the grid (a cell missing): set aside. */
    leap_file_stamp stamp;
    leap_grid_index *x = NULL;
    char why[160];
    CHECK_OK(leap_file_stamp_get(fog, &stamp, &err), &err);
    CHECK_OK(leap_grid_index_read(path, &stamp, "density", &x, why, sizeof why, &err), &err);
    CHECK_MSG(x && x->cells.count > 1, "%s", why);
    if (x && x->cells.count > 1) {
        x->cells.count--;
        CHECK_OK(leap_grid_index_write(path, fog, &stamp, "density", x, &err), &err);
        second = load_noting(fog, budget, "rebuilt: atlas:");
        if (second && have_ref && render(r, second, LEAP_RENDER_SPARSELEAP, &b))
            CHECK_MSG(same_frames(&ref, &b), "the scene built past an index that did not fit renders another image");
        leap_scene_destroy(second);
    }
    leap_grid_index_destroy(x);
    second = load_noting(fog, budget, "used");
    leap_scene_destroy(second);
    second = NULL;
    test_index_prune(fog, path);
    /* No directory, or one that cannot be made: the grid is read as without an index. */
    setenv("LEAP_INDEX_DIR", "", 1);
    leap_scene_destroy(load_noting(fog, budget, "off"));
    setenv("LEAP_INDEX_DIR", fog, 1); /* a file where the directory would be */
    leap_scene_destroy(load_noting(fog, budget, "not written"));
done:
    setenv("LEAP_INDEX_DIR", dir, 1);
    leap_renderer_destroy(r);
    leap_renderer_destroy(r_small);
    leap_scene_destroy(first);
    leap_scene_destroy(second);
}

/* leap_renderer_set_partial: the first incomplete picture kept; stop: end the frame there. */
typedef struct partial_log {
    frame_out *out, first;
    uint32_t calls;
    uint64_t first_waiting, last_waiting;
    uint32_t stop; /* end the frame at this picture (0: never) */
} partial_log;

static int on_partial(void *user, const leap_frame_stats *so_far)
{
    partial_log *log = user;
    if (log->calls++ == 0) {
        memcpy(log->first.rgba, log->out->rgba, sizeof log->first.rgba);
        log->first_waiting = so_far->waiting_pixels;
    }
    log->last_waiting = so_far->waiting_pixels;
    return log->stop && log->calls >= log->stop;
}

/* Incomplete pictures: after every pass that leaves rays waiting, the picture so far, in which
 * only the waiting rays' pixels differ from the finished frame; a frame ended at its first
 * picture says how many rays wait, and the next frame (not ended) is the whole image again. */
static void test_partial(const char *fog)
{
    leap_error err = {{0}};
    leap_scene *s = load(fog, 32u << 20, 0, &err);
    const leap_renderer_desc few = {.cache_bytes = 64 * 64 * 64 * 4}; /* 343 slots */
    leap_renderer *r = make_renderer_with(&few);
    static frame_out ref, out;
    static partial_log log;
    if (!s || !r || !render(r, s, LEAP_RENDER_SPARSELEAP, &ref)) goto done;
    CHECK(ref.st.waiting_pixels == 0 && ref.st.cache_passes > 2);
    log = (partial_log){.out = &out};
    leap_renderer_set_partial(r, on_partial, &log, 0);
    if (render(r, s, LEAP_RENDER_SPARSELEAP, &out)) {
        uint64_t differ = 0;
        for (size_t i = 0; i < W * H; ++i) differ += memcmp(log.first.rgba + 4 * i, ref.rgba + 4 * i, 16) != 0;
        printf("partial pictures: %u in %u passes; the first with %llu rays waiting, %llu pixels differing from the "
               "finished frame\n", log.calls, out.st.cache_passes, (unsigned long long)log.first_waiting,
               (unsigned long long)differ);
        CHECK(log.calls == out.st.cache_passes - 1 && log.first_waiting > 0 && log.last_waiting > 0);
        CHECK(differ > 0 && differ <= log.first_waiting);
        CHECK(out.st.waiting_pixels == 0 && same_frames(&out, &ref));
    }
    log = (partial_log){.out = &out, .stop = 1};
    if (render(r, s, LEAP_RENDER_SPARSELEAP, &out)) {
        printf("a frame ended at its first picture: %llu rays waiting, %u passes\n",
               (unsigned long long)out.st.waiting_pixels, out.st.cache_passes);
        CHECK(log.calls == 1 && out.st.waiting_pixels == log.first_waiting && out.st.waiting_pixels > 0);
        CHECK(!memcmp(out.rgba, log.first.rgba, sizeof out.rgba) && !same_frames(&out, &ref));
    }
    leap_renderer_set_partial(r, NULL, NULL, 0);
    if (render(r, s, LEAP_RENDER_SPARSELEAP, &out)) CHECK(out.st.waiting_pixels == 0 && same_frames(&out, &ref));
    /* MIP: a waiting ray shows the colour of the largest value it met so far. Ended at its third
     * picture: at the first, rays may wait at their first brick, the cache holding only the
     * previous frame's last ones. */
    CHECK_OK(leap_scene_set_mip(s, LEAP_MIP_MAX, &err), &err);
    if (render(r, s, LEAP_RENDER_SPARSELEAP, &ref)) {
        log = (partial_log){.out = &out, .stop = 3};
        leap_renderer_set_partial(r, on_partial, &log, 0);
        if (render(r, s, LEAP_RENDER_SPARSELEAP, &out)) {
            uint64_t shown = 0, waiting = 0;
            for (size_t i = 0; i < W * H; ++i) {
                if (!isinf(out.depth[i]) || ref.rgba[4 * i + 3] == out.rgba[4 * i + 3]) continue;
                ++waiting;
                shown += out.rgba[4 * i + 3] > 0.0f;
            }
            printf("MIP, a frame ended at its third picture: %llu rays waiting, %llu pixels short of the finished "
                   "frame, %llu of them showing a colour\n", (unsigned long long)out.st.waiting_pixels,
                   (unsigned long long)waiting, (unsigned long long)shown);
            CHECK(out.st.waiting_pixels > 0 && shown > 0 && waiting <= out.st.waiting_pixels);
        }
        leap_renderer_set_partial(r, NULL, NULL, 0);
    }
done:
    CHECK_MSG(s && r, "%s", err.msg);
    leap_renderer_destroy(r);
    leap_scene_destroy(s);
}

static int copy_file(const char *from, const char *to)
{
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "cp '%s' '%s'", from, to);
    return system(cmd) == 0;
}

/* The file of a grid read on demand changes while it is open: written over in place (same
 * size), or cut short (a read from the mapping beyond its new end would raise SIGBUS). Reads
 * of the atlas's cells and every later frame fail with a clear error, and nothing crashes.
 * A leaf corrupt from the start fails the program cleanly. */
static void test_changed_file(const char *fog)
{
    char path[700];
    snprintf(path, sizeof path, "%s/changed.vdb", tmp_dir);
    const leap_renderer_desc few = {.cache_bytes = 64 * 32 * 32 * 4};
    leap_renderer *r = make_renderer_with(&few);
    static frame_out out;
    static uint16_t texels[LEAP_SLOT_TEXELS];
    for (int cut = 0; cut < 2 && r; ++cut) {
        leap_error err = {{0}};
        if (!copy_file(fog, path)) {
            CHECK_MSG(0, "cannot copy %s", fog);
            break;
        }
        leap_scene *s = load(path, 32u << 20, 0, &err);
        CHECK_MSG(s && leap_grid_on_demand(s->grid), "%s", err.msg);
        if (!s) break;
        CHECK_OK(render_result(r, s, LEAP_RENDER_SPARSELEAP, 0, 40, &out, &err), &err);
        struct stat st;
        CHECK(stat(path, &st) == 0);
        if (cut) {
            CHECK(truncate(path, st.st_size / 2) == 0);
        } else { /* the second half of the file, leaves' values, overwritten with huge floats */
            const int fd = open(path, O_WRONLY);
            CHECK(fd >= 0);
            static uint32_t junk[16384];
            for (size_t i = 0; i < sizeof junk / sizeof *junk; ++i) junk[i] = 0x7f7f7f7fu;
            for (off_t at = st.st_size / 2; fd >= 0 && at < st.st_size; at += (off_t)sizeof junk) {
                const size_t n = st.st_size - at < (off_t)sizeof junk ? (size_t)(st.st_size - at) : sizeof junk;
                CHECK(pwrite(fd, junk, n, at) == (ssize_t)n);
            }
            if (fd >= 0) close(fd);
        }
        const char *what = cut ? "cut short" : "written over";
        /* The atlas's reads first. Before reads from a file that may be cut short, its size is
         * checked (the renderer does so before each batch). */
        if (cut) CHECK(leap_atlas_check_source(s->atlas, &err) == LEAP_ERR_FORMAT && strstr(err.msg, "its size went from"));
        uint32_t failed = 0;
        for (uint32_t h = 0; h < s->atlas->slot_count; ++h)
            if (leap_atlas_read_slot(s->atlas, h, texels, &err) != LEAP_OK && failed++ == 0)
                printf("file %s while open, the atlas's reads from cell %u of %u on: %s\n", what, h, s->atlas->slot_count,
                       err.msg);
        CHECK_MSG(failed == s->atlas->slot_count && strstr(err.msg, "changed while"), "%s: %u failed, %s", what, failed,
                  err.msg);
        for (int frame = 0; frame < 2; ++frame) {
            leap_result lr = render_result(r, s, LEAP_RENDER_SPARSELEAP, 0, 40, &out, &err);
            printf("file %s while open, frame %d: %s\n", what, frame, lr ? err.msg : "rendered");
            CHECK_MSG(lr == LEAP_ERR_FORMAT && strstr(err.msg, "changed while"), "%s: %d %s", what, lr, err.msg);
        }
        leap_scene_destroy(s);
    }
    leap_renderer_destroy(r);

    /* A leaf whose compressed values are corrupt from the start: exit 1 naming it, no image. */
    char out_png[700];
    snprintf(out_png, sizeof out_png, "%s/corrupt.png", tmp_dir);
    remove(out_png);
    if (copy_file(fog, path)) {
        FILE *f = fopen(path, "r+b");
        CHECK(f != NULL && fseek(f, 0, SEEK_END) == 0);
        const long size = f ? ftell(f) : 0;
        for (int k = 0; f && k < 40; ++k) {
            fseek(f, size / 2 + 1000L * k, SEEK_SET);
            fwrite("\xff\xff\xff\x7f", 1, 4, f);
        }
        if (f) fclose(f);
        const char *const args[] = {"render", path, "--size", "32x32", "--memory-budget", "32M", "-o", out_png, NULL};
        CHECK_MSG(run_leap(args) == 1 && strstr(res.err, "cannot be read") && strstr(res.err, "corrupt"), "%s", res.err);
        CHECK_MSG(access(out_png, F_OK) != 0, "an image was written from a corrupt file");
        printf("corrupt leaf values, read on demand: %s", res.err);
    }
    remove(path);
}

static int same_pixels(const char *a, const char *b)
{
    leap_error err = {{0}};
    int wa, ha, ca, wb, hb, cb;
    float *pa = NULL, *pb = NULL;
    int same = !leap_image_read(a, &wa, &ha, &ca, &pa, &err) && !leap_image_read(b, &wb, &hb, &cb, &pb, &err) &&
               wa == wb && ha == hb && ca == cb && !memcmp(pa, pb, (size_t)wa * ha * ca * sizeof *pa);
    free(pa);
    free(pb);
    return same;
}

/* Drops path's pages from the page cache (written back first); 1 when mincore(2) then finds at
 * most a tenth of them cached (a file system may keep them: tmpfs does). */
static int drop_cached_pages(const char *path)
{
    const int fd = open(path, O_RDONLY);
    struct stat st;
    int dropped = 0;
    if (fd >= 0 && fstat(fd, &st) == 0 && st.st_size > 0 && fdatasync(fd) == 0 &&
        posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED) == 0) {
        const size_t page = (size_t)sysconf(_SC_PAGESIZE), pages = ((size_t)st.st_size + page - 1) / page;
        void *map = mmap(NULL, (size_t)st.st_size, PROT_READ, MAP_SHARED, fd, 0);
        unsigned char *cached = malloc(pages);
        if (map != MAP_FAILED && cached && mincore(map, (size_t)st.st_size, cached) == 0) {
            size_t n = 0;
            for (size_t i = 0; i < pages; ++i) n += cached[i] & 1;
            dropped = n * 10 <= pages;
        }
        free(cached);
        if (map != MAP_FAILED) munmap(map, (size_t)st.st_size);
    }
    if (fd >= 0) close(fd);
    return dropped;
}

/* The number after "key": in a --stats text; -1 when it is not there. */
static double stats_number(const char *json, const char *key)
{
    char quoted[128];
    snprintf(quoted, sizeof quoted, "\"%s\":", key);
    const char *at = strstr(json, quoted);
    return at ? strtod(at + strlen(quoted), NULL) : -1;
}

/* The program: a fog of 4x the budget's bytes of values, rendered within the budget. */
static void test_program(void)
{
    char fog[700], base[700], lazy[700], whole[700], stats[700];
#ifdef LEAP_SANITIZED
    const int size = 256; /* 64 MiB of values, still read on demand: the peak is not checked here */
#else
    const int size = 440; /* 325 MiB of values */
#endif
    snprintf(fog, sizeof fog, "%s/fog%d.vdb", tmp_dir, size);
    snprintf(base, sizeof base, "%s/tiny.png", tmp_dir);
    snprintf(lazy, sizeof lazy, "%s/on_demand.png", tmp_dir);
    snprintf(whole, sizeof whole, "%s/in_memory.png", tmp_dir);
    snprintf(stats, sizeof stats, "%s/on_demand.json", tmp_dir);
    if (!make_fog(fog, size, 0)) return;
    const char *const tiny_args[] = {"render", sphere, "--size", "128x128", "-o", base, NULL};
    const char *const lazy_args[] = {"render", fog, "--size", "128x128", "--memory-budget", "80M", "--gpu-cache", "1M",
                                     "--stats", stats, "-o", lazy, NULL};
    const char *const whole_args[] = {"render", fog, "--size", "128x128", "--gpu-cache", "1M", "-o", whole, NULL};
    CHECK_MSG(run_leap(tiny_args) == 0, "%s", res.err);
    const long tiny_kb = res.max_rss_kb;
    const int cold = drop_cached_pages(fog);
    CHECK_MSG(run_leap_limit("300", lazy_args) == 0, "%s", res.err);
    CHECK_MSG(!strstr(res.err, "building the atlas"), "a progress bar went to a stderr that is not a terminal");
    const long lazy_kb = res.max_rss_kb;
    const double lazy_s = res.seconds;
    CHECK_MSG(run_leap_limit("300", whole_args) == 0, "%s", res.err);
    char json[16384];
    read_text(stats, json, sizeof json);
    const char *read = strstr(json, "\"leaves_read\"");
    printf("fog %d^3 (%.0f MiB of values), budget 80 MiB: peak %.0f MiB on demand (%.1f s), %.0f MiB in memory, "
           "%.0f MiB for a tiny volume; %.40s\n", size, 4.0 * size * size * size / (1 << 20), lazy_kb / 1024.0, lazy_s,
           res.max_rss_kb / 1024.0, tiny_kb / 1024.0, read ? read : "no leaves_read in --stats");
    CHECK(read != NULL);
    /* The first open reads every leaf: from storage, when the fog was not in the page cache. */
    const double file_bytes = stats_number(json, "input_file_bytes"), storage = stats_number(json, "storage_bytes_read");
    printf("storage read %.0f MiB of the %.0f MiB file (%s)\n", storage / (1 << 20), file_bytes / (1 << 20),
           cold ? "its pages dropped from the page cache first" : "its pages could not be dropped: not checked");
    CHECK(file_bytes > 0 && storage >= 0);
    if (cold) CHECK_MSG(storage >= 0.9 * file_bytes, "%.0f bytes read from storage, the file has %.0f", storage, file_bytes);
    /* "rebuilt": the index of an earlier run's fog, made again since */
    CHECK_MSG(strstr(json, "\"written\"") || strstr(json, "\"rebuilt: the file changed"),
              "the first open of the fog wrote no grid index");
    /* leap info over the budget: read on demand, its value range from the index just written. */
    const char *const info_args[] = {"info", fog, "--memory-budget", "80M", NULL};
    CHECK_MSG(run_leap_limit("300", info_args) == 0, "%s", res.err);
    printf("leap info on demand: peak %.0f MiB, %.2f s\n", res.max_rss_kb / 1024.0, res.seconds);
    CHECK_MSG(strstr(res.out, "0 leaves read (grid index: used)") && strstr(res.out, "values         0.05"), "%s", res.out);
    /* With the index, an open reads the topology alone (about 4 % of the file), and a narrow
     * view the leaves its rays reach, not the whole file (measured: 19 % of the 440^3 fog's
     * file, 36 % of the 256^3 one's). */
    char narrow_png[700], narrow_json[700];
    snprintf(narrow_png, sizeof narrow_png, "%s/narrow.png", tmp_dir);
    snprintf(narrow_json, sizeof narrow_json, "%s/narrow.json", tmp_dir);
    const char *const narrow_args[] = {"render", fog, "--size", "64x64", "--fov", "5", "--memory-budget", "80M",
                                       "--stats", narrow_json, "-o", narrow_png, NULL};
    const int narrow_cold = drop_cached_pages(fog);
    CHECK_MSG(run_leap_limit("300", narrow_args) == 0, "%s", res.err);
    read_text(narrow_json, json, sizeof json);
    const double narrow_storage = stats_number(json, "storage_bytes_read");
    printf("with the index, a 5-degree view read %.1f MiB of the %.0f MiB file from storage (%s), %.2f s\n",
           narrow_storage / (1 << 20), file_bytes / (1 << 20), narrow_cold ? "cold" : "pages not dropped: not checked",
           res.seconds);
    CHECK_MSG(strstr(json, "\"used\""), "the second open did not use the index");
    if (narrow_cold)
        CHECK_MSG(narrow_storage >= 0 && narrow_storage <= 0.5 * file_bytes, "%.0f bytes read from storage",
                  narrow_storage);

    /* On a terminal (script(1) gives it one) the first open and the frame show a progress bar,
     * cleared before the summary line (shown at once, LEAP_PROGRESS_DELAY_MS=0: after its
     * default second this small grid may be done; which stage it names depends on the
     * machine, as it is redrawn at most every 100 ms). */
    char index[1400], cmd[4096], bar[700];
    leap_error err = {{0}};
    CHECK_OK(leap_grid_index_path(getenv("LEAP_INDEX_DIR"), fog, "density", index, sizeof index, &err), &err);
    remove(index);
    snprintf(bar, sizeof bar, "%s/bar.txt", tmp_dir);
    snprintf(cmd, sizeof cmd, "LEAP_PROGRESS_DELAY_MS=0 script -qec \"'%s' render '%s' --size 64x64 --memory-budget 80M -o '%s/bar.png'\" /dev/null > '%s' 2>&1",
             LEAP_EXE, fog, tmp_dir, bar);
    CHECK_MSG(system(cmd) == 0, "%s failed", cmd);
    char shown[16384];
    read_text(bar, shown, sizeof shown);
    CHECK_MSG(strstr(shown, " % ") && strstr(shown, "\r\033[Kleap: wrote"), "%.300s", shown);

    /* An index that cannot be written is said, once, on stderr (a file where its directory would be). */
    char small[700];
    snprintf(small, sizeof small, "%s/fog192.vdb", tmp_dir);
    const char *const unwritable_args[] = {"render", small, "--size", "32x32", "--memory-budget", "32M", "-o", base, NULL};
    const char *dir = getenv("LEAP_INDEX_DIR");
    char kept[700];
    snprintf(kept, sizeof kept, "%s", dir ? dir : "");
    setenv("LEAP_INDEX_DIR", small, 1);
    CHECK_MSG(run_leap(unwritable_args) == 0, "%s", res.err);
    CHECK_MSG(strstr(res.err, "warning: grid index") && strstr(res.err, "not written"), "%s", res.err);
    setenv("LEAP_INDEX_DIR", kept, 1);
    CHECK_MSG(same_pixels(lazy, whole), "the image read on demand differs from the in-memory one");
#ifdef LEAP_SANITIZED
    printf("(AddressSanitizer build: its shadow memory makes peaks meaningless; not checked)\n");
#else
    CHECK_MSG(lazy_kb <= tiny_kb + 80 * 1024 + 8 * 1024, "peak %ld KiB, more than %ld KiB above a tiny volume's %ld",
              lazy_kb, 80L * 1024 + 8 * 1024, tiny_kb);
#endif
    remove(fog);
}

/* The streamed atlas of a grid read on demand: from the cells' footprints its load gathered
 * (leap_grid_cell_range: no leaf read), and, once those are dropped, built by reading with room
 * for the leaves its threads share (leap_atlas_desc.share_bytes, as the scene builds it) and
 * without: the same pages, slots and recorded cells; shared, the cells read each leaf about once. */
static void test_shared_leaves(const char *fog)
{
    leap_error err = {{0}};
    leap_vdb_file *file = NULL;
    leap_grid *grid = NULL;
    leap_brick *bricks = NULL;
    leap_atlas *atlas[3] = {NULL, NULL, NULL};
    leap_atlas_cells cells[3] = {{0}, {0}, {0}};
    uint64_t reads[3] = {0, 0, 0};
    CHECK_OK(leap_vdb_open(fog, &file, &err), &err);
    if (file) CHECK_OK(leap_vdb_load_grid_on_demand(file, 0, NULL, NULL, &grid, &err), &err);
    const size_t n = grid ? leap_grid_brick_count(grid) : 0;
    if (grid) bricks = malloc(n * sizeof *bricks);
    if (!bricks || leap_grid_bricks(grid, bricks, &err)) goto done;
    for (int k = 0; k < 3; ++k) { /* gathered, read per thread, read shared */
        if (k == 1) leap_grid_release_scan(grid);
        const uint64_t before = leap_grid_leaves_read(grid);
        leap_atlas_desc ad = {.grid = grid, .stream_texels = 1, .share_bytes = k == 2 ? (uint64_t)64 << 20 : 0,
                              .bricks = bricks, .brick_count = n, .record_cells = &cells[k]};
        CHECK_OK(leap_atlas_create(&ad, &atlas[k], &err), &err);
        reads[k] = leap_grid_leaves_read(grid) - before;
    }
    const uint64_t leaves = leap_grid_get_info(grid)->leaf_count;
    printf("atlas cells: %zu; from the open's scan %llu leaves read; read again, %llu of %llu leaves shared, %llu with "
           "per-thread copies\n", cells[0].count, (unsigned long long)reads[0], (unsigned long long)reads[2],
           (unsigned long long)leaves, (unsigned long long)reads[1]);
    CHECK_MSG(reads[0] == 0 && reads[2] >= leaves && reads[2] * 20 <= leaves * 21 && reads[1] > reads[2],
              "gathered: %llu reads, shared: %llu, per thread: %llu, %llu leaves", (unsigned long long)reads[0],
              (unsigned long long)reads[2], (unsigned long long)reads[1], (unsigned long long)leaves);
    for (int k = 1; k < 3; ++k) {
        if (!atlas[0] || !atlas[k]) continue;
        check_same_streamed(atlas[0], atlas[k]);
        CHECK(cells[0].count == cells[k].count);
        if (cells[0].count == cells[k].count) {
            CHECK(!memcmp(cells[0].entries, cells[k].entries, cells[0].count * 4));
            CHECK(!memcmp(cells[0].ranges, cells[k].ranges, cells[0].count * 4));
        }
    }
done:
    for (int i = 0; i < 3; ++i) {
        leap_atlas_destroy(atlas[i]);
        leap_atlas_cells_free(&cells[i]);
    }
    free(bricks);
    leap_grid_destroy(grid);
    leap_vdb_close(file);
}

int main(void)
{
    snprintf(tmp_dir, sizeof tmp_dir, "%s", LEAP_TEST_TMP);
    if (mkdir(tmp_dir, 0755) != 0 && errno != EEXIST) return 1;
    snprintf(sphere, sizeof sphere, "%s/sphere.vdb", LEAP_VOLUMES);
    char fog[700];
    snprintf(fog, sizeof fog, "%s/fog192.vdb", tmp_dir);
    char index_dir[700];
    snprintf(index_dir, sizeof index_dir, "%s/index", tmp_dir);
    setenv("LEAP_INDEX_DIR", index_dir, 1); /* not the user's cache */
    if (make_fog(fog, 192, 0)) {
        test_scenes(fog);
        test_index(fog);
        test_shared_leaves(fog);
        test_partial(fog);
        test_changed_file(fog);
    }
    char recorded[760];
    snprintf(recorded, sizeof recorded, "%s/fog192_recorded.vdb", tmp_dir);
    if (make_fog(recorded, 192, 1)) test_lazy(recorded);
    remove(recorded);
    test_program();
    return check_exit_code();
}
