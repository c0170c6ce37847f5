/* Every public header under include/leap/ compiles as C++ and declares its functions with C
 * linkage: this translation unit includes all of them (a header that is not valid C++ fails
 * the build; the list is generated from include/leap/ at configure time) and takes the address of functions from several libraries, so a missing
 * extern "C" guard fails the link (the C++ name would be mangled and not found). */
#include "all_public_headers.h"

#include <cstdio>

int main()
{
    /* One function of each library behind the headers (leap_cli_main lives in the leap
     * executable itself, not in a library a test links). */
    const void *fns[] = {
        reinterpret_cast<const void *>(&leap_atlas_create),      /* atlas.h     (leap_volume) */
        reinterpret_cast<const void *>(&leap_camera_orbit),      /* camera.h    (leap_render) */
        reinterpret_cast<const void *>(&leap_result_name),       /* error.h     (leap_base) */
        reinterpret_cast<const void *>(&leap_file_publish_text), /* files.h     (leap_base) */
        reinterpret_cast<const void *>(&leap_occupancy_create),  /* occupancy.h (leap_occupancy) */
        reinterpret_cast<const void *>(&leap_boxes_create),      /* boxes.h     (leap_occupancy) */
        reinterpret_cast<const void *>(&leap_resolve_events),    /* segments.h  (leap_occupancy) */
        reinterpret_cast<const void *>(&leap_renderer_bind_scene), /* renderer.h (leap_render) */
        reinterpret_cast<const void *>(&leap_scene_create),      /* scene.h     (leap_render) */
        reinterpret_cast<const void *>(&leap_tf_preset),         /* tf.h        (leap_volume) */
        reinterpret_cast<const void *>(&leap_vdb_open),          /* vdb.h       (leap_vdb) */
        reinterpret_cast<const void *>(&leap_presenter_create),  /* present.h   (leap_render) */
        reinterpret_cast<const void *>(&leap_bench_run),         /* bench.h     (leap_bench) */
        reinterpret_cast<const void *>(&leap_dump_frame_create), /* dump.h      (leap_output) */
        reinterpret_cast<const void *>(&leap_image_write),       /* image.h     (leap_output) */
        reinterpret_cast<const void *>(&leap_viewer_apply),      /* viewer.h    (leap_viewer) */
        reinterpret_cast<const void *>(&leap_reference_render),  /* reference.h (leap_render) */
    };
    int missing = 0;
    for (const void *f : fns) missing += f == nullptr;
    std::printf("%zu public functions linked from C++, %d missing\n", sizeof fns / sizeof fns[0], missing);
    return missing ? 1 : 0;
}
