/* The GPU brick cache (leap_renderer_desc.cache_bytes): with room for only a few dozen or a
 * few hundred of a volume's bricks, over several passes a frame that load the bricks rays
 * missed, every mode, plain and MIP, gives naive's image through the same cache bit for bit
 * (colour and depth), and the whole atlas's image bit for bit (bricks sit elsewhere in the
 * image along z, which does not change their samples); a cache that holds every brick is no cache;
 * label volumes need none; shading refuses a cache with a clear error. */
#define W 64 /* the frames' size (gpu_fixture.h's frame_out) */
#define H 64
#include "gpu_fixture.h"
#include "leap/scene.h"

static leap_scene *load(const char *file, const char *grid, int mip)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", LEAP_VOLUMES, file);
    leap_scene_desc d = {.path = path, .grid = grid, .step = 0.5, .mip = mip};
    leap_scene *s = NULL;
    leap_error err = {{0}};
    CHECK_OK(leap_scene_create(&d, &s, &err), &err);
    return s;
}

static int render(leap_renderer *r, leap_scene *s, int camera, leap_mode mode, frame_out *out)
{
    leap_error err = {{0}};
    leap_camera cam;
    leap_rays view;
    if (leap_renderer_bind_scene(r, s, &err) ||
        leap_camera_orbit(s->center, s->radius, 35 + 120 * camera, 25 - 40 * camera, 0, 40, 0, &cam, &err) ||
        leap_scene_rays(s, &cam, W, H, &view, &err) ||
        leap_renderer_render(r, &view, &s->march, mode, out->rgba, out->depth, out->samples, &out->st, &err)) {
        printf("FAIL: %s\n", err.msg);
        return 0;
    }
    return 1;
}

/* The same frame from the whole atlas and through each cache. */
static void check_volume(leap_renderer *whole, leap_renderer *const *caches, int n_caches, const char *file,
                         const char *grid, int mip)
{
    leap_scene *s = load(file, grid, mip);
    if (!s) return;
    static frame_out ref, naive[2], got;
    int missed[2] = {0, 0}; /* frames per cache that needed bricks it did not hold at first */
    for (int c = 0; c < 2; ++c)
        for (size_t m = 0; m < sizeof modes / sizeof modes[0]; ++m) {
            if (!render(whole, s, c, modes[m], &ref)) continue;
            CHECK(ref.st.cache_slots == 0 && ref.st.cache_passes == 1);
            for (int k = 0; k < n_caches; ++k) {
                frame_out *out = m == 0 ? &naive[k] : &got; /* naive comes first */
                if (!render(caches[k], s, c, modes[m], out)) continue;
                const int same = !memcmp(naive[k].rgba, out->rgba, sizeof out->rgba) &&
                                 !memcmp(naive[k].depth, out->depth, sizeof out->depth);
                const int whole_same = !memcmp(ref.rgba, out->rgba, sizeof out->rgba) &&
                                       !memcmp(ref.depth, out->depth, sizeof out->depth);
                const image_diff d = compare_rgba(ref.rgba, out->rgba, W * H);
                printf("%-11s %-4s camera %d %-10s cache %4u of %4u bricks: %3u passes, %5llu misses, %5llu "
                       "loaded, %5llu evicted; %s naive's through it, against the whole atlas max abs %.1e\n", file,
                       mip ? "mip" : "", c, mode_names[m], out->st.cache_slots, s->atlas->slot_count,
                       out->st.cache_passes, (unsigned long long)out->st.cache_misses,
                       (unsigned long long)out->st.cache_loaded, (unsigned long long)out->st.cache_evicted,
                       same ? "equals" : "DIFFERS FROM", d.max_abs);
                CHECK_MSG(same, "%s %s camera %d %s: differs from naive through the same cache", file,
                          mip ? "mip" : "plain", c, mode_names[m]);
                CHECK_MSG(whole_same, "%s %s camera %d %s: max abs %g against the whole atlas", file,
                          mip ? "mip" : "plain", c, mode_names[m], d.max_abs);
                const frame_out *o = out;
                CHECK(o->st.cache_slots > 0 && o->st.cache_slots < s->atlas->slot_count);
                /* a pass more for each service, each loading at least one missed brick */
                CHECK((o->st.cache_passes > 1) == (o->st.cache_misses > 0));
                CHECK(o->st.cache_loaded >= o->st.cache_passes - 1 && o->st.cache_loaded <= o->st.cache_misses);
                missed[k] += o->st.cache_misses > 0;
            }
        }
    for (int k = 0; k < n_caches; ++k) CHECK_MSG(missed[k] > 0, "%s: no frame missed a brick of cache %d", file, k);
    leap_scene_destroy(s);
}

int main(void)
{
    leap_renderer *whole = make_renderer();
    /* a few dozen slots, and a few hundred */
    const leap_renderer_desc small = {.cache_bytes = 200u << 10}, medium = {.cache_bytes = 512u << 10};
    leap_renderer *caches[2] = {make_renderer_with(&small), make_renderer_with(&medium)};
    if (!whole || !caches[0] || !caches[1]) return 1;

    check_volume(whole, caches, 2, "cloud.vdb", NULL, 0);
    check_volume(whole, caches, 2, "blobs.vdb", NULL, 0);
    check_volume(whole, caches, 1, "rotated.vdb", "density", 0);
    check_volume(whole, caches, 1, "cloud.vdb", NULL, LEAP_MIP_MAX);

    leap_error err = {{0}};
    static frame_out out;
    /* The GPU volume follows the cache, not the atlas. */
    leap_scene *s = load("cloud.vdb", NULL, 0);
    if (s && render(whole, s, 0, LEAP_RENDER_SPARSELEAP, &out) && render(caches[0], s, 0, LEAP_RENDER_SPARSELEAP, &out)) {
        printf("GPU volume: whole %llu bytes, cache %llu bytes\n", (unsigned long long)leap_renderer_volume_bytes(whole),
               (unsigned long long)leap_renderer_volume_bytes(caches[0]));
        CHECK(leap_renderer_volume_bytes(caches[0]) < leap_renderer_volume_bytes(whole) / 4);
    }
    /* Shading refuses a cache, with the reason. */
    if (s) {
        leap_shading shade = leap_shading_default();
        CHECK_OK(leap_scene_set_shading(s, &shade, &err), &err);
        leap_result r = leap_renderer_bind_scene(caches[0], s, &err);
        CHECK_MSG(r == LEAP_ERR_UNSUPPORTED && strstr(err.msg, "cache"), "shading with a cache: %d %s", r, err.msg);
    }
    leap_scene_destroy(s);
    /* A cache that holds every brick is no cache. */
    const leap_renderer_desc roomy = {.cache_bytes = 1ull << 30};
    leap_renderer *big = make_renderer_with(&roomy);
    s = load("blobs.vdb", NULL, 0);
    if (big && s && render(big, s, 0, LEAP_RENDER_SPARSELEAP, &out)) CHECK(out.st.cache_slots == 0 && out.st.cache_passes == 1);
    leap_scene_destroy(s);
    /* Label volumes keep their cells in the page buffer: no atlas image, no cache. */
    s = load("labels.vdb", NULL, 0);
    if (s && render(caches[0], s, 0, LEAP_RENDER_SPARSELEAP, &out)) CHECK(out.st.cache_slots == 0);
    leap_scene_destroy(s);

    leap_renderer_destroy(big);
    leap_renderer_destroy(whole);
    leap_renderer_destroy(caches[0]);
    leap_renderer_destroy(caches[1]);
    return check_exit_code();
}
