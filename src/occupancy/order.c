/* The view DFS order of the emitted boxes, with entry and exit numbers (see
 * include/leap/boxes.h). */
#include "leap/boxes.h"
#include "util.h"

#include <string.h>

#include "boxes_internal.h"

typedef struct order_ctx {
    const bnode *n;
    const leap_boxes *boxes;
    double eye[3];
    int ortho;
    uint32_t ortho_oct;
    leap_box_gpu *out;
    leap_box_meta *meta;
    uint32_t counter, pos;
} order_ctx;

static void visit(order_ctx *c, uint32_t ni)
{
    const bnode *v = &c->n[ni];
    uint32_t my = 0;
    const int emitted = (v->flags & F_EMITTED) != 0;
    if (emitted) {
        my = c->pos++;
        leap_box_gpu *g = &c->out[my];
        float lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            lo[a] = (float)((double)v->lo[a] * LEAP_CELL);
            double h = (double)v->lo[a] + (double)((uint64_t)1 << v->ext[a]);
            if (c->boxes->clip && h > c->boxes->cells[a]) h = c->boxes->cells[a];
            hi[a] = (float)(h * LEAP_CELL);
            if (v->flags & F_TIGHT) lo[a] = (float)v->tlo[a], hi[a] = (float)v->thi[a];
        }
        g->lo.x = lo[0], g->lo.y = lo[1], g->lo.z = lo[2], g->lo.w = 0.0f;
        g->hi.x = hi[0], g->hi.y = hi[1], g->hi.z = hi[2], g->hi.w = 0.0f;
        g->info.x = c->counter++;
        g->info.y = 0;
        g->info.z = v->cls;
        g->info.w = v->pcls;
        if (c->meta) {
            c->meta[my].level = v->level;
            c->meta[my].id = v->id;
        }
    }
    if (v->mask) {
        uint32_t oct = c->ortho_oct;
        if (!c->ortho) {
            /* a node with children is a cube: its centre is lo + 2^(ext-1) cells */
            oct = 0;
            for (int a = 0; a < 3; ++a) {
                const double centre = ((double)v->lo[a] + (double)((uint64_t)1 << v->ext[a]) * 0.5) * LEAP_CELL;
                if (c->eye[a] >= centre) oct |= 1u << a;
            }
        }
        uint32_t slot_index[8];
        uint32_t idx = v->first;
        for (int k = 0; k < 8; ++k) slot_index[k] = (v->mask >> k & 1u) ? idx++ : NONE;
        for (uint32_t i = 0; i < 8; ++i) {
            const uint32_t ch = slot_index[i ^ oct];
            if (ch != NONE) visit(c, ch);
        }
    }
    if (emitted) c->out[my].info.y = c->counter++;
}

double leap_boxes_order(const leap_boxes *boxes, const double eye_or_dir[3], int ortho,
                        leap_box_gpu *out, leap_box_meta *meta)
{
    const double t0 = leap__now_ms();
    if (!boxes || !out || !boxes->n) return 0.0;
    order_ctx c;
    memset(&c, 0, sizeof c);
    c.n = boxes->n;
    c.boxes = boxes;
    c.ortho = ortho != 0;
    c.out = out;
    c.meta = meta;
    for (int a = 0; a < 3; ++a) {
        c.eye[a] = eye_or_dir[a];
        if (eye_or_dir[a] < 0.0) c.ortho_oct |= 1u << a;
    }
    visit(&c, 0);
    return leap__now_ms() - t0;
}
