/* The host view of shaders/shared.h must match the std140 offsets the shaders use. */
#include <stddef.h>

#include "check.h"
#include "leap/march.h"
#include "shared.h"

int main(void)
{
    CHECK(sizeof(leap_vec4) == 16);
    CHECK(sizeof(leap_uvec4) == 16);
    CHECK(offsetof(leap_frame_gpu, origin0) == 0);
    CHECK(offsetof(leap_frame_gpu, origin_dx) == 16);
    CHECK(offsetof(leap_frame_gpu, origin_dy) == 32);
    CHECK(offsetof(leap_frame_gpu, dir0) == 48);
    CHECK(offsetof(leap_frame_gpu, dir_dx) == 64);
    CHECK(offsetof(leap_frame_gpu, dir_dy) == 80);
    CHECK(offsetof(leap_frame_gpu, world_row0) == 96);
    CHECK(offsetof(leap_frame_gpu, world_row1) == 112);
    CHECK(offsetof(leap_frame_gpu, world_row2) == 128);
    CHECK(offsetof(leap_frame_gpu, domain_min) == 144);
    CHECK(offsetof(leap_frame_gpu, domain_max) == 160);
    CHECK(offsetof(leap_frame_gpu, atlas_inv_size) == 176);
    CHECK(offsetof(leap_frame_gpu, march) == 192);
    CHECK(offsetof(leap_frame_gpu, limits) == 208);
    CHECK(offsetof(leap_frame_gpu, top_dims) == 224);
    CHECK(offsetof(leap_frame_gpu, slot_dims) == 240);
    CHECK(offsetof(leap_frame_gpu, image) == 256);
    CHECK(offsetof(leap_frame_gpu, clip_x) == 272);
    CHECK(offsetof(leap_frame_gpu, clip_y) == 288);
    CHECK(offsetof(leap_frame_gpu, clip_z) == 304);
    CHECK(offsetof(leap_frame_gpu, clip_w) == 320);
    CHECK(offsetof(leap_frame_gpu, raster) == 336);
    CHECK(offsetof(leap_frame_gpu, bbox_min) == 352);
    CHECK(offsetof(leap_frame_gpu, bbox_max) == 368);
    CHECK(offsetof(leap_frame_gpu, lists) == 384);
    CHECK(offsetof(leap_frame_gpu, labels) == 400);
    CHECK(offsetof(leap_frame_gpu, keep) == 416);
    CHECK(offsetof(leap_frame_gpu, keep_count) == 480);
    CHECK(offsetof(leap_frame_gpu, normal_row0) == 496);
    CHECK(offsetof(leap_frame_gpu, normal_row1) == 512);
    CHECK(offsetof(leap_frame_gpu, normal_row2) == 528);
    CHECK(offsetof(leap_frame_gpu, shade) == 544);
    CHECK(offsetof(leap_frame_gpu, light) == 560);
    CHECK(offsetof(leap_frame_gpu, overflow) == 576);
    CHECK(offsetof(leap_frame_gpu, mip_floor) == 592);
    CHECK(sizeof(leap_frame_gpu) == 624);
    CHECK(sizeof(((leap_frame_gpu *)0)->keep) / sizeof(leap_vec4) == LEAP_MAX_CLIPS);
    CHECK(sizeof(leap_push_gpu) == 16 && offsetof(leap_push_gpu, chunk) == 0);
    CHECK(offsetof(leap_box_gpu, lo) == 0);
    CHECK(offsetof(leap_box_gpu, hi) == 16);
    CHECK(offsetof(leap_box_gpu, info) == 32);
    CHECK(sizeof(leap_box_gpu) == 48);
    /* The resolve pass keeps a pixel's events in registers: the capacity is a small even number. */
    CHECK(LEAP_PIXEL_EVENTS % 2 == 0 && LEAP_PIXEL_EVENTS <= 32);
    /* Event keys hold order << 2 | class: classes fit in two bits. */
    CHECK(LEAP_CLASS_COUNT <= 4);
    CHECK(LEAP_MAX_SEGMENTS <= 16); /* the UNKNOWN mask is 16 bits of a uint */
    /* Page entries: the constant flag must leave room for any slot or block index. */
    CHECK((LEAP_PAGE_CONST & (LEAP_PAGE_CONST - 1)) == 0);
    CHECK(LEAP_CELL == 1 << LEAP_CELL_SHIFT && LEAP_BLOCK_SHIFT_MIN <= LEAP_BLOCK_SHIFT_MAX);
    CHECK(LEAP_SLOT == LEAP_CELL + 1);
    return check_exit_code();
}
