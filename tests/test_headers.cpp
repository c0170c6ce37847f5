/* Every public header under include/leap/ compiles as C++ and declares its functions with C
 * linkage: this translation unit includes all of them (a header that is not valid C++ fails
 * the build) and takes the address of functions from several libraries, so a missing
 * extern "C" guard fails the link (the C++ name would be mangled and not found). */
#include "leap/atlas.h"
#include "leap/camera.h"
#include "leap/cli.h"
#include "leap/dump.h"
#include "leap/error.h"
#include "leap/files.h"
#include "leap/gpu.h"
#include "leap/image.h"
#include "leap/march.h"
#include "leap/occupancy.h"
#include "leap/reference.h"
#include "leap/renderer.h"
#include "leap/scene.h"
#include "leap/tf.h"
#include "leap/vdb.h"
#include "leap/viewer.h"

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
        reinterpret_cast<const void *>(&leap_boxes_create),      /* occupancy.h */
        reinterpret_cast<const void *>(&leap_renderer_bind_scene), /* renderer.h (leap_render) */
        reinterpret_cast<const void *>(&leap_scene_create),      /* scene.h     (leap_render) */
        reinterpret_cast<const void *>(&leap_tf_preset),         /* tf.h        (leap_volume) */
        reinterpret_cast<const void *>(&leap_vdb_open),          /* vdb.h       (leap_vdb) */
        reinterpret_cast<const void *>(&leap_gpu_allocated_bytes), /* gpu.h     (leap_render) */
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
