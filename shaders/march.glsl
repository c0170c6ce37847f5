// Volume sampling and front-to-back compositing shared by every mode. The including
// shader declares `frame` (leap_frame_gpu), `atlas`, `tf_table` and `pages[]`.
#ifndef LEAP_MARCH_GLSL
#define LEAP_MARCH_GLSL

// Specialisation constants: the renderer builds one composite pipeline per mode and opacity
// correction, so lavapipe compiles out the code a pipeline never runs (it executes every
// side of a branch that any lane takes, even when the condition is uniform).
// leap_tf_precorrected: the host corrected the table's opacities for the step
// (leap_tf_gpu_table), so no sample raises its opacity to a power, and the depth threshold
// is corrected likewise; false: each sample is corrected, for tables where the host's
// correction would be off (leap_tf_precorrect_ok).
layout(constant_id = 0) const bool leap_tf_precorrected = false;
layout(constant_id = 1) const uint leap_mode = LEAP_MODE_NAIVE;
// leap_labels: a label volume (object indices, nearest voxel; the object table's opacities are
// corrected for the step, so leap_tf_precorrected is set too).
layout(constant_id = 2) const bool leap_labels = false;
// leap_mip: maximum or minimum intensity projection (leap_march.mip; frame.image.z = 1 for the
// minimum): acc.color.r holds the largest table coordinate so far times the sign (-1 for the
// minimum; -2 before any sample), acc.depth_t the t of the first sample reaching it.
layout(constant_id = 3) const bool leap_mip = false;
// leap_shade: gradient shading (leap_march.shade; frame.normal_row*, shade, light).
layout(constant_id = 4) const bool leap_shade = false;
// The page table has middle levels (frame.keep_count.y of them): a long box.
layout(constant_id = 5) const bool leap_page_middle = false;
// The volume is read through the GPU brick cache: a cell may be missing (LEAP_PAGE_MISSING).
layout(constant_id = 9) const bool leap_cache = false;
// The modes that skip by the occupancy (octree, sparseleap, also a sparseleap frame's single
// chord, marched by the bbox code) pass the slot cells marked LEAP_PAGE_EMPTY when compositing.
layout(constant_id = 10) const bool leap_skip_empty = false;
const bool leap_skips_empty_slots = leap_skip_empty && !leap_labels && !leap_mip;

struct leap_ray {
    vec3 origin;
    vec3 dir;      // unit length in index space
};

struct leap_accum {
    vec4 color;    // premultiplied
    float transmittance;
    float depth_t; // t of the first sample above the depth opacity, or -1
    uint samples;
    float first_object; // label volumes: index of the first object drawn with opacity > 0, or -1
    bool waiting;       // stopped at a cell not resident in the brick cache (a data miss)
};

leap_ray leap_pixel_ray(vec2 pixel_centre)
{
    leap_ray r;
    r.origin = frame.origin0.xyz + pixel_centre.x * frame.origin_dx.xyz + pixel_centre.y * frame.origin_dy.xyz;
    r.dir = normalize(frame.dir0.xyz + pixel_centre.x * frame.dir_dx.xyz + pixel_centre.y * frame.dir_dy.xyz);
    return r;
}

// Slab test against [lo, hi]. A zero direction component never multiplies an infinity:
// a ray parallel to a slab is either inside it (no bound) or misses.
bool leap_clip_box(leap_ray r, vec3 lo, vec3 hi, out float t0, out float t1)
{
    t0 = 0.0;
    t1 = 3.0e38;
    if (any(greaterThan(lo, hi))) return false; // empty domain (empty grid)
    for (int a = 0; a < 3; ++a) {
        float o = r.origin[a], d = r.dir[a];
        if (d == 0.0) {
            if (o < lo[a] || o > hi[a]) return false;
        } else {
            float inv = 1.0 / d;
            float ta = (lo[a] - o) * inv, tb = (hi[a] - o) * inv;
            t0 = max(t0, min(ta, tb));
            t1 = min(t1, max(ta, tb));
        }
    }
    return t0 <= t1;
}

// Where the samples of the current cell come from. Consecutive samples mostly stay in one
// cell, so the page table is read only when a ray enters a new cell.
struct leap_cell_cursor {
    ivec3 cell;
    ivec3 block;
    uint block_entry;
    bool constant;
    float value;     // constant cells
    vec3 texel_base; // slot cells: atlas texel coordinate = texel_base + q (leap_cursor_seek)
    uint slot;       // slot cells: the slot's index (LEAP_BINDING_SLOT_RANGES); missing ones: the host atlas's
    bool missing;    // slot cells not resident in the brick cache (LEAP_PAGE_MISSING)
    bool empty;      // slot cells classed EMPTY (LEAP_PAGE_EMPTY)
    uint object;     // label volumes, constant cells: the object index
    uint record;     // label volumes, other cells: the record's first word in pages[]
    uint header;     // and that word, read once per cell rather than at every sample
};

leap_cell_cursor leap_cursor_init()
{
    leap_cell_cursor c;
    c.cell = ivec3(-1);
    c.block = ivec3(-1);
    c.block_entry = 0u;
    c.constant = true;
    c.value = 0.0;
    c.texel_base = vec3(0.0);
    c.slot = 0u;
    c.missing = false;
    c.empty = false;
    c.object = 0u;
    c.record = 0u;
    c.header = 0u;
    return c;
}

void leap_cursor_seek(inout leap_cell_cursor cur, ivec3 cell)
{
    cur.cell = cell;
    int shift = int(frame.slot_dims.w);
    ivec3 block = cell >> shift;
    if (any(notEqual(block, cur.block))) {
        cur.block = block;
        if (leap_page_middle) {
            // A long box: the top level's entry, then middle nodes down to the block (a few
            // reads when a ray enters a new block, none per cell).
            int up = LEAP_PAGE_NODE_SHIFT * int(frame.keep_count.y);
            ivec3 top = block >> up;
            uint e = pages[top.x + frame.top_dims.x * (top.y + frame.top_dims.y * top.z)];
            for (int s = up - LEAP_PAGE_NODE_SHIFT; s >= 0 && (e & LEAP_PAGE_CONST) == 0u; s -= LEAP_PAGE_NODE_SHIFT) {
                ivec3 m = (block >> s) & ((1 << LEAP_PAGE_NODE_SHIFT) - 1);
                e = pages[e + uint(m.x | (m.y << LEAP_PAGE_NODE_SHIFT) | (m.z << (2 * LEAP_PAGE_NODE_SHIFT)))];
            }
            cur.block_entry = e;
        } else {
            cur.block_entry = pages[block.x + frame.top_dims.x * (block.y + frame.top_dims.y * block.z)];
        }
    }
    uint entry = cur.block_entry;
    if ((entry & LEAP_PAGE_CONST) == 0u) {
        ivec3 c = cell & ((1 << shift) - 1);
        entry = pages[frame.top_dims.w + (entry << (3 * shift)) + uint(c.x | (c.y << shift) | (c.z << (2 * shift)))];
    }
    cur.constant = (entry & LEAP_PAGE_CONST) != 0u;
    cur.missing = false;
    if (leap_labels) {
        cur.object = entry & LEAP_LABEL_INDEX_MASK;
        cur.record = frame.labels.x + entry;
        if (!cur.constant) cur.header = pages[cur.record];
    } else if (cur.constant) {
        cur.value = float(entry & 0xffffu) * (1.0 / 65535.0);
    } else {
        cur.empty = (entry & LEAP_PAGE_EMPTY) != 0u;
        entry &= ~LEAP_PAGE_EMPTY;
        uvec3 slot = uvec3(entry, entry >> LEAP_SLOT_BITS, entry >> (2 * LEAP_SLOT_BITS)) & LEAP_SLOT_MASK;
        // The image's extents are powers of two of at most M = LEAP_ATLAS_EXTENT_MAX and its
        // sampler repeats: a texel coordinate M above the slot's along every axis is the same
        // place, and puts every slot cell's samples in [M, 2M), where floats lie on one grid
        // (1/8192 of a texel apart). Rounded on that grid, a sample's offset in its cell does not
        // depend on where the slot lies or on the image's size, and scaling by the extents is
        // exact: a brick cache, another brick layout or a lazily read atlas gives the same image
        // bit for bit.
        cur.texel_base = vec3(slot * uint(LEAP_SLOT)) + vec3(float(LEAP_ATLAS_EXTENT_MAX) + 0.5) - vec3(cell * LEAP_CELL);
        if (leap_mip) cur.slot = slot.x + frame.slot_dims.x * (slot.y + frame.slot_dims.y * slot.z);
        cur.missing = leap_cache && (entry & LEAP_PAGE_MISSING) != 0u;
        if (cur.missing) cur.slot = entry & (LEAP_PAGE_MISSING - 1u);
    }
}

leap_accum leap_accum_init()
{
    leap_accum a;
    a.color = vec4(0.0);
    a.transmittance = 1.0;
    a.depth_t = -1.0;
    a.samples = 0u;
    a.first_object = -1.0;
    a.waiting = false;
    return a;
}

bool leap_accum_done(leap_accum a)
{
    return a.transmittance < frame.limits.x;
}

// Cuts [t0, t1] to where the ray keeps the clipping planes (frame.keep); false if nothing is
// left. Every mode calls it on the domain interval, so all take the same samples.
bool leap_clip_keep(leap_ray r, inout float t0, inout float t1)
{
    for (uint k = 0u; k < frame.keep_count.x; ++k) {
        vec4 p = frame.keep[k];
        float at_origin = dot(p.xyz, r.origin) + p.w, along = dot(p.xyz, r.dir);
        if (along == 0.0) {
            if (at_origin < 0.0) return false;
        } else {
            float t = -at_origin / along;
            if (along > 0.0) t0 = max(t0, t);
            else t1 = min(t1, t);
        }
    }
    return t0 <= t1;
}

// The ray's sample lattice t_j = t0 + j * dt, j = 0, 1, ...: t0 is the lattice point k * dt
// (k integer) at or just below where the ray enters the domain, computed the same way in
// every mode, so j stays small and exact in float even far from the grid's origin.
struct leap_lattice {
    float t0;
    float dt;
};

leap_lattice leap_lattice_make(float t_enter)
{
    leap_lattice l;
    l.dt = frame.march.x;
    l.t0 = floor(max(t_enter, 0.0) / l.dt) * l.dt;
    return l;
}

// The first j whose sample is at or after ta.
float leap_lattice_first(leap_lattice l, float ta)
{
    return max(ceil((ta - l.t0) / l.dt), 0.0);
}

// One past the last j whose sample is at or before tb, by the same test the march loop uses.
float leap_lattice_end(leap_lattice l, float tb)
{
    float j = max(floor((tb - l.t0) / l.dt) + 1.0, 0.0);
    if (j > 0.0 && l.t0 + (j - 1.0) * l.dt > tb) j -= 1.0;
    if (l.t0 + j * l.dt <= tb) j += 1.0;
    return j;
}

// The event mask (LEAP_PIXEL_TILE in shared.h): the first of a tile's two words, a pixel's
// bit in its tile, and the pixel of a tile's bit.
uint leap_tile_word(uvec2 tile)
{
    return frame.image.x * frame.image.y + 2u * (tile.y * LEAP_MASK_TILES(frame.image.x) + tile.x);
}

uint leap_tile_bit(uvec2 pix)
{
    return (pix.y % LEAP_PIXEL_TILE) * LEAP_PIXEL_TILE + pix.x % LEAP_PIXEL_TILE;
}

uvec2 leap_tile_pixel(uvec2 tile, uint bit)
{
    return tile * LEAP_PIXEL_TILE + uvec2(bit % LEAP_PIXEL_TILE, bit / LEAP_PIXEL_TILE);
}

// Appends the entry and exit events of box `box_index` to the pixel's list when the pixel's ray
// meets the box: t from the box planes (the slab test on the ray the composite pass marches).
// The raster pass calls it for each fragment, the rects pass for each pixel of a small box.
void leap_box_events(uvec2 pix, uint box_index)
{
    if (pix.x >= frame.image.x || pix.y >= frame.image.y) return;
    leap_ray ray = leap_pixel_ray(vec2(pix) + 0.5);
    leap_box_gpu b = boxes[box_index];
    float t0, t1;
    // A box touched only at the ray start (t1 == 0) is left out: with the eye on a node plane
    // no single view order could place it for rays on both sides; the boxes the ray runs
    // through are still entered at t = 0.
    if (!leap_clip_box(ray, b.lo.xyz, b.hi.xyz, t0, t1) || !(t1 > 0.0)) return;
    // The pixel's own slots: one atomic on its own counter (no shared pool). A count beyond
    // the capacity tells the resolve pass that the pixel overflowed.
    uint pixel = pix.y * frame.image.x + pix.x;
    uint n = atomicAdd(event_counts[pixel], 2u);
    if (n == 0u) { // the pixel's first event: mark it for the resolve pass
        uint bit = leap_tile_bit(pix);
        atomicOr(event_counts[leap_tile_word(pix / LEAP_PIXEL_TILE) + bit / 32u], 1u << (bit % 32u));
    }
    if (n + 2u > frame.lists.x) return;
    uint slot = pixel * frame.lists.x + n;
    event_t[slot] = t0;
    event_key[slot] = (b.info.x << 2) | b.info.z;
    event_t[slot + 1u] = t1;
    event_key[slot + 1u] = (b.info.y << 2) | b.info.w;
}

// Ray `index` of the resolve pass's list `list` (LEAP_RAYS_* in shared.h): false past the
// list's end.
bool leap_listed_ray(uint list, uint index, out uvec2 pix)
{
    pix = uvec2(0u);
    if (index >= ray_lists[4u * list + 3u]) return false;
    uint ray = ray_lists[LEAP_RAYS_HEADER + list * frame.image.x * frame.image.y + index];
    pix = uvec2(ray & 0xffffu, ray >> 16);
    return true;
}

// The lattice indices naive marching takes on the pixel's ray, for a ray that takes no
// sample (sparseleap: nothing to march); a marched ray reports them itself.
float leap_naive_samples(uvec2 pix)
{
    leap_ray ray = leap_pixel_ray(vec2(pix) + 0.5);
    float t_enter, t_exit;
    if (!leap_clip_box(ray, frame.domain_min.xyz, frame.domain_max.xyz, t_enter, t_exit) ||
        !leap_clip_keep(ray, t_enter, t_exit))
        return 0.0;
    leap_lattice lat = leap_lattice_make(t_enter);
    return max(leap_lattice_end(lat, t_exit) - leap_lattice_first(lat, t_enter), 0.0);
}

// The transfer function's colour of stored values: u in [0, 1] maps onto the first to the
// last texel centre of the table, folded into one multiply-add of the stored value s, then
// clamped.
struct leap_tf_map {
    float scale, offset, lo, hi;
};

leap_tf_map leap_tf_map_make()
{
    const float n = float(textureSize(tf_table, 0));
    leap_tf_map m;
    m.scale = frame.march.z * (n - 1.0) / n;
    m.offset = (frame.march.w * (n - 1.0) + 0.5) / n;
    m.lo = 0.5 / n;
    m.hi = (n - 0.5) / n;
    return m;
}

vec4 leap_tf_lookup(leap_tf_map m, float s)
{
    return textureLod(tf_table, clamp(s * m.scale + m.offset, m.lo, m.hi), 0.0);
}


// The object index of the voxel nearest to q (floor(q + 0.5)) in the cursor's record cell: one
// of the voxels 8c .. 8c + 8 per axis, all in the record (LEAP_LABEL_HEADER in shared.h).
uint leap_label_at(leap_cell_cursor cur, vec3 q)
{
    ivec3 v = ivec3(floor(q + 0.5)) - cur.cell * LEAP_CELL;
    uint index = uint(v.x + LEAP_SLOT * (v.y + LEAP_SLOT * v.z));
    uint header = cur.header;
    uint bits = header & 0xffu, palette = cur.record + uint(LEAP_LABEL_HEADER);
    uint bit = index * bits;
    uint word = pages[palette + (header >> 8) + (bit >> 5)];
    uint slot = (word >> (bit & 31u)) & ((1u << bits) - 1u);
    return pages[palette + slot];
}

// Opacity of one sample of TF colour c, corrected for the step. A zero opacity gives 0
// exactly (pow(1, x) == 1), leaving the sums untouched.
float leap_sample_alpha(vec4 c)
{
    return leap_tf_precorrected ? c.a : 1.0 - pow(1.0 - min(c.a, 1.0), frame.march.y);
}

// Composites one sample at t of colour rgb and corrected opacity alpha; `opaque`: the
// table's opacity is above the depth threshold. Branch-free: lavapipe runs all lanes
// through every branch any lane takes.
void leap_composite(inout leap_accum acc, vec3 rgb, float alpha, bool opaque, float t)
{
    acc.samples++;
    if (acc.depth_t < 0.0 && opaque) acc.depth_t = t;
    acc.color.rgb += acc.transmittance * alpha * rgb;
    acc.transmittance *= 1.0 - alpha;
}

void leap_composite_tf(inout leap_accum acc, vec4 c, float t)
{
    leap_composite(acc, c.rgb, leap_sample_alpha(c), c.a > frame.limits.y, t);
}

// A label sample of object `object`: composited, and the first object with any opacity kept
// for picking (indices below 2^24 are exact in float; the occupancy refuses more).
void leap_composite_object(inout leap_accum acc, uint object, float t)
{
    vec4 c = objects[object];
    leap_composite_tf(acc, c, t);
    if (acc.first_object < 0.0 && c.a > 0.0) acc.first_object = float(object);
}

// MIP: the highest (signed) table coordinate any sample of the cursor's slot cell can reach: its
// stored values' range, mapped as samples are.
float leap_mip_cell_bound(leap_cell_cursor cur, leap_tf_map tf)
{
    uint range = slot_ranges[cur.slot];
    float a = clamp(float(range & 0xffffu) * (1.0 / 65535.0) * tf.scale + tf.offset, tf.lo, tf.hi);
    float b = clamp(float(range >> 16) * (1.0 / 65535.0) * tf.scale + tf.offset, tf.lo, tf.hi);
    return frame.image.z != 0u ? -min(a, b) : max(a, b);
}

// One MIP sample at table coordinate x, in [lo, hi]; minIP keeps -x, so both keep the largest.
// Once the extreme of the table is reached no later sample can change the colour or the first
// t, so the ray is done (transmittance 0 marks it).
void leap_mip_sample(inout leap_accum acc, float x, float t, leap_tf_map tf)
{
    acc.samples++;
    bool minimum = frame.image.z != 0u;
    float signed_x = minimum ? -x : x;
    if (signed_x > acc.color.r) {
        acc.color.r = signed_x;
        acc.depth_t = t;
    }
    if (acc.color.r >= (minimum ? -tf.lo : tf.hi)) acc.transmittance = 0.0;
}

// World directions of one ray's shading (leap_shading): v towards the eye, l towards the
// light, h their half vector (0 when they are opposite: no highlight).
struct leap_light {
    vec3 v, l, h;
};

leap_light leap_light_make(leap_ray r)
{
    leap_light k;
    k.v = -normalize(vec3(dot(frame.world_row0.xyz, r.dir), dot(frame.world_row1.xyz, r.dir),
                          dot(frame.world_row2.xyz, r.dir)));
    k.l = frame.light.xyz == vec3(0.0) ? k.v : frame.light.xyz;
    vec3 h = k.l + k.v;
    k.h = dot(h, h) > 0.0 ? normalize(h) : vec3(0.0);
    return k;
}

// A slot cell's sample colour rgb, shaded by the rule of leap/march.h (leap_shading). `stored` is
// the gradient part of the sample's one filtered read (LEAP_BINDING_VALUE_GRADIENTS): the
// voxels' half central differences, whose interpolation equals the central difference of the
// trilinear field. Read back through the UNORM conversion, a zero difference can come out a
// few thousandths of a unit off; parts below 1/16 of a unit (1e-6 of the range) are taken as 0.
// A shaded scene's constant cells have a zero gradient (leap_atlas_desc.wide): they keep their
// colour, as the rule gives for g = 0.
vec3 leap_shade_rgb(vec3 rgb, vec3 stored, leap_light k)
{
    vec3 g = stored * 65535.0 - float(LEAP_GRADIENT_ZERO);
    g = mix(g, vec3(0.0), lessThan(abs(g), vec3(1.0 / 16.0))) * (1.0 / 65535.0);
    float w = min(length(g) * frame.light.w, 1.0);
    vec3 n = vec3(dot(frame.normal_row0.xyz, g), dot(frame.normal_row1.xyz, g), dot(frame.normal_row2.xyz, g));
    if (!(w > 0.0) || dot(n, n) == 0.0) return rgb;
    n = normalize(n);
    float diffuse = abs(dot(n, k.l)), specular = pow(abs(dot(n, k.h)), frame.shade.w);
    vec3 lit = min(rgb * (frame.shade.x + frame.shade.y * diffuse) + frame.shade.z * specular, vec3(1.0));
    return rgb + w * (lit - rgb);
}

// Class of the occupancy-tree leaf holding cell c, and that leaf's cube [lo, lo + size) in
// cells, found by descending from node 0 (frame.tree_top: the smallest node around every cell
// that is not EMPTY).
uint leap_tree_leaf(ivec3 c, out ivec3 lo, out int size)
{
    const int level = int(frame.tree_top.w);
    const ivec3 top = ivec3(frame.tree_top.xyz);
    if (any(lessThan(c, top)) || any(greaterThanEqual(c, top + (1 << level)))) {
        // Rays are clipped to the box of the non-empty cells, inside node 0: a cell outside it
        // comes from float rounding at that box (or at the domain) and is marched.
        lo = c;
        size = 1;
        return LEAP_CLASS_NONEMPTY;
    }
    size = 1 << level;
    lo = top;
    uint node = 0u;
    for (;;) {
        size >>= 1;
        ivec3 upper = ivec3(greaterThanEqual(c, lo + size));
        lo += upper * size;
        uint word = tree[node * 8u + uint(upper.x + 2 * upper.y + 4 * upper.z)];
        if ((word & LEAP_TREE_LEAF) != 0u) return word & 3u;
        node = word;
    }
}

// The t where a ray inside the cube of `size` cells from cell `lo` leaves it: the least t of its
// exit walls (exit_side: 1 where the ray leaves by the upper wall), from the ray's reciprocal
// direction (1e30 along an axis it does not move on), without leap_clip_box's divisions and
// per-axis branches, which made octree's frame 4-8 % longer on the scans.
float leap_cube_exit(leap_ray r, ivec3 lo, int size, ivec3 exit_side, vec3 inv_dir)
{
    vec3 tw = (vec3((lo + exit_side * size) * LEAP_CELL) - r.origin) * inv_dir;
    return min(min(tw.x, tw.y), tw.z);
}

// One past the last lattice index of the run from j (whose sample lies in `cell`) through the
// cell: the sample at the computed exit wall's lattice index less one must lie in the cell too,
// else the run is j alone, so the run j .. k-1 is the cell's (a cell is convex) however the exit
// rounds. Sample k may still lie in the cell when the exit rounds down; the march then goes on
// from it.
float leap_cell_run_end(leap_ray r, leap_lattice lat, float j, ivec3 cell, ivec3 exit_side, vec3 inv_dir)
{
    float k = max(leap_lattice_first(lat, leap_cube_exit(r, cell, 1, exit_side, inv_dir)), j + 1.0);
    vec3 last = r.origin + (lat.t0 + (k - 1.0) * lat.dt) * r.dir;
    return any(notEqual(ivec3(floor(last)) >> LEAP_CELL_SHIFT, cell)) ? j + 1.0 : k;
}

// Takes the lattice samples in [ta, tb], skipping indices below j_next (so adjacent intervals
// never take a sample twice); j_next ends one past the last index visited.
// One outer iteration per cell: the page table is read once per cell, and a constant cell's
// colour once, so its samples only composite (lavapipe runs every side of a branch that
// any lane takes, so per-sample branches would cost both sides). Every mode runs this loop:
// measured on lavapipe, it beat a loop that checks the cell at every sample in all of them.
void leap_march_interval(leap_ray r, leap_lattice lat, float ta, float tb, inout float j_next, inout leap_accum acc)
{
    float j = max(leap_lattice_first(lat, ta), j_next);
    leap_tf_map tf = leap_tf_map_make();
    leap_light light;
    if (leap_shade) light = leap_light_make(r);
    leap_cell_cursor cur = leap_cursor_init();
    float t = lat.t0 + j * lat.dt;
    bool more = t <= tb && !acc.waiting;
    // Cell exits (leap_cell_run_end): the walls a ray leaves cells by (an axis it does not
    // move along never bounds the exit).
    ivec3 exit_side = ivec3(greaterThanEqual(r.dir, vec3(0.0)));
    vec3 inv_dir = vec3(1.0e30);
    for (int a = 0; a < 3; ++a)
        if (r.dir[a] != 0.0) inv_dir[a] = 1.0 / r.dir[a];
    // Octree: the tree leaf last looked up (none yet), found again only when a sample leaves it.
    ivec3 leaf_lo = ivec3(0);
    int leaf_size = 0;
    uint leaf_class = LEAP_CLASS_NONEMPTY;
    while (more) {
        // Cells whose samples cannot change the pixel are passed whole, and a ray passes all it
        // meets before its next samples, so the lanes of a SIMD vector pass cells side by side
        // and take samples side by side (lavapipe runs every lane through every branch any lane
        // takes: a lane taking samples while its neighbours pass held them all).
        vec3 q;
        ivec3 cell;
        bool constant = true, opaque = false, found = false;
        vec4 c = vec4(0.0);
        float alpha = 0.0, x = 0.0, bound = 0.0;
        while (more) {
            // No clamp: q stays within float rounding of the domain box, and the page grid has
            // at least one spare cell on every side of it (see leap_atlas). Voxel centres sit at
            // integer q; a slot cell's samples read the atlas at texel_base + q.
            q = r.origin + t * r.dir;
            cell = ivec3(floor(q)) >> LEAP_CELL_SHIFT;
            leap_cursor_seek(cur, cell);
            // A slot cell the occupancy classes EMPTY: the skipping modes pass it unread.
            const bool skip = leap_skips_empty_slots && !cur.constant && cur.empty;
            if (leap_cache && cur.missing && !skip) { // a data miss: report the slot; the ray waits at sample j for a later pass
                atomicOr(misses[1u + cur.slot / 32u], 1u << (cur.slot % 32u));
                misses[0] = 1u;
                acc.waiting = true;
                more = false;
                break;
            }
            constant = cur.constant;
            if (!leap_mip) c = leap_labels ? objects[cur.object] : leap_tf_lookup(tf, cur.value);
            alpha = leap_sample_alpha(c);
            opaque = c.a > frame.limits.y;
            x = clamp(cur.value * tf.scale + tf.offset, tf.lo, tf.hi); // MIP's table coordinate
            // MIP passes a cell none of whose samples can raise the extreme above what the ray
            // holds (a tie keeps the first t), constant or not. Compositing passes a constant
            // cell of zero opacity, and the skipping modes an EMPTY slot cell, whose samples add
            // nothing; they are lattice samples the ray takes, so they are counted (as the
            // segments' lattice points are: leap_dump_frame_pixel).
            if (leap_mip) bound = constant ? (frame.image.z != 0u ? -x : x) : leap_mip_cell_bound(cur, tf);
            const bool pass = leap_mip ? bound <= acc.color.r : (constant && c.a == 0.0) || skip;
            // A segmentation's cells of hidden objects are rarely one object each (a cell mixes
            // objects and background), so while objects are hidden the octree mode asks the tree
            // at every cell (with every object shown, that cost 14 % of aal's frame for nothing).
            if (!pass && !(leap_mode == LEAP_MODE_OCTREE && leap_labels && frame.labels.z != 0u)) {
                found = true;
                break;
            }
            if (leap_mode == LEAP_MODE_OCTREE) {
                // Elsewhere the octree mode asks the tree only where the march passes a cell
                // anyway, and then skips every sample of the EMPTY leaf around it, up to the
                // leaf's exit: asked at every cell, the walk cost more than it saved (ch2:
                // 0.88-0.94x naive's frame, against 0.94-0.98x; the same samples on the scans,
                // fogs and blobs). The sample at t lies in the leaf, so the skip makes progress
                // unless the exit rounds to t or before; then the cell is passed as any mode
                // passes it, or, a segmentation's, sampled.
                if (any(lessThan(cell, leaf_lo)) || any(greaterThanEqual(cell, leaf_lo + leaf_size)))
                    leaf_class = leap_tree_leaf(cell, leaf_lo, leaf_size);
                float b1 = leap_cube_exit(r, leaf_lo, leaf_size, exit_side, inv_dir);
                if (leaf_class == LEAP_CLASS_EMPTY && b1 > t) {
                    j = max(leap_lattice_first(lat, b1), j + 1.0);
                    t = lat.t0 + j * lat.dt;
                    more = t <= tb;
                    continue;
                }
                if (leap_labels && !pass) {
                    found = true;
                    break;
                }
            }
            float k = leap_cell_run_end(r, lat, j, cell, exit_side, inv_dir);
            if (!leap_mip) acc.samples += uint(min(k, leap_lattice_end(lat, tb)) - j);
            j = k;
            t = lat.t0 + j * lat.dt;
            more = t <= tb;
        }
        if (!found) break;
        // Two inner loops rather than one with a branch per sample: see above.
        if (constant) {
            for (;;) {
                if (leap_mip) leap_mip_sample(acc, x, t, tf);
                else leap_composite(acc, c.rgb, alpha, opaque, t);
                if (leap_labels && acc.first_object < 0.0 && c.a > 0.0) acc.first_object = float(cur.object);
                j += 1.0;
                t = lat.t0 + j * lat.dt;
                if (leap_accum_done(acc) || t > tb) { more = false; break; }
                q = r.origin + t * r.dir;
                if (any(notEqual(ivec3(floor(q)) >> LEAP_CELL_SHIFT, cell))) break;
            }
        } else {
            for (;;) {
                if (leap_labels) {
                    leap_composite_object(acc, leap_label_at(cur, q), t);
                } else {
                    // Shaded: the value and its gradient in one fetch.
                    vec3 at = (cur.texel_base + q) * frame.atlas_inv_size.xyz;
                    vec4 vg = leap_shade ? textureLod(value_gradients, at, 0.0) : vec4(0.0);
                    float s = leap_shade ? vg.x : textureLod(atlas, at, 0.0).r;
                    if (leap_mip) leap_mip_sample(acc, clamp(s * tf.scale + tf.offset, tf.lo, tf.hi), t, tf);
                    else {
                        vec4 cs = leap_tf_lookup(tf, s);
                        if (leap_shade && cs.a > 0.0)
                            cs.rgb = leap_shade_rgb(cs.rgb, vg.yzw, light);
                        leap_composite_tf(acc, cs, t);
                    }
                }
                j += 1.0;
                t = lat.t0 + j * lat.dt;
                if (leap_accum_done(acc) || t > tb) { more = false; break; }
                q = r.origin + t * r.dir;
                if (any(notEqual(ivec3(floor(q)) >> LEAP_CELL_SHIFT, cell))) break;
            }
        }
    }
    j_next = j;
}

#endif
