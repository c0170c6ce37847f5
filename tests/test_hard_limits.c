/* Hard cases, limits (labels gpu;hard;limits): per-pixel list overflow with the default
 * capacities (a comb of single voxels), one segment per pixel and 4 events per pixel; the
 * vdb writer's fill of a box in the last root node of the int32 index range (in a child
 * process). Every frame gets the checks of hard_cases.h. */
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include "hard_cases.h"

/* Renders v in every mode (all checks); returns the sparseleap frame's overflowed pixels. */
static uint64_t overflow_frame(gpu *g, const leap_scene *s, const leap_rays *v, const char *label)
{
    frame(g, s, v, 0.5, label);
    return g->st[LEAP_RENDER_SPARSELEAP].overflow_pixels;
}

/* Default capacities: the comb's exact boxes overflow the events a pixel can sort and its
 * segments (the cost-model cut merges the comb's teeth into fewer boxes). */
static uint64_t overflow_comb(gpu *g)
{
    leap_scene *c = load_tmp_exact("comb", &RAMP, 0.0, 1.0);
    uint64_t ovf = 0;
    if (!hc_bind(g, c)) return 0;
    printf("  comb: %u boxes\n", leap_boxes_count(c->boxes));
    leap_rays v = axis_ortho(c, 0, 1, 2, 2, 0.25, -40, 16, 16);
    ovf += overflow_frame(g, c, &v, "comb: ortho along the line of voxels");
    printf("  comb: events per pixel max %u, segments per pixel max %u\n",
           g->st[LEAP_RENDER_SPARSELEAP].events_max, g->st[LEAP_RENDER_SPARSELEAP].segments_max);
    double eye[3] = {-30, 4, 4};
    v = axis_persp(c, 0, 1, eye, 32, 32);
    ovf += overflow_frame(g, c, &v, "comb: perspective along the line of voxels");
    double eye2[3] = {500, 4.25, 4.125};
    v = axis_persp(c, 0, -1, eye2, 32, 32);
    ovf += overflow_frame(g, c, &v, "comb: perspective back along the line, eye inside");
    hc_release(g, c);
    return ovf;
}

/* Small capacities: the blocks' shared views (exact boxes: the cut's end at the blocks'
 * voxels, and fewer rays cross more than one) and the shipped blobs overflow. */
static uint64_t overflow_blocks(gpu *g)
{
    static const double zero[3] = {0, 0, 0};
    uint64_t ovf = 0;
    leap_scene *s = load_tmp_exact("blocks", &RAMP, 0.0, 1.0);
    if (!hc_bind(g, s)) s = NULL;
    if (s) {
        for (int k = 0; k < N_SHARED_VIEWS; ++k) {
            leap_rays v;
            if (!shared_view(s, k, zero, &v)) continue;
            ovf += overflow_frame(g, s, &v, fmt("blocks: %s", shared_view_names[k]));
        }
        hc_release(g, s);
    }
    s = load_shipped("blobs.vdb", NULL, NULL);
    if (hc_bind(g, s)) {
        leap_camera c = orbit(s, 35, 25, 0, 40, 0);
        frame_cam(g, s, &c, 48, 48, 2.0, "blobs.vdb: orbit");
        ovf += g->st[LEAP_RENDER_SPARSELEAP].overflow_pixels;
        hc_release(g, s);
    }
    return ovf;
}

static void case_overflow(gpu *g, const char *what)
{
    hc_begin(what);
    const int comb = g == &G;
    const uint64_t ovf = comb ? overflow_comb(g) : overflow_blocks(g);
    printf("  %llu pixels overflowed%s\n", (unsigned long long)ovf, comb ? "" : " in total");
    CHECK_MSG(ovf > 0, "%s: no pixel overflowed", what);
    hc_end();
}

/* Child process of case_fill_int32_end: fills one leaf in the last root node of the int32 index
 * range (x in [2^31 - 4096, 2^31 - 1]), saves and reads it back. Exit status 0 = all well. */
static int fill_int32_end_child(void)
{
    leap_error err = {{0}};
    leap_vdb_writer *w = NULL;
    if (leap_vdb_writer_create(&w, &err) != LEAP_OK) return 2;
    int g = leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, 0.0, NULL, 1, &err);
    const int32_t lo[3] = {2147479552, 0, 0}, hi[3] = {2147479559, 7, 7};
    leap_vdb_writer_fill(w, g, lo, hi, 1.0, 1);
    char path[1024];
    tmp_path("fill_int32_end", path, sizeof path);
    leap_result r = leap_vdb_writer_save(w, path, &err);
    leap_vdb_writer_destroy(w);
    if (r != LEAP_OK) {
        fprintf(stderr, "fill near INT32_MAX: %s\n", err.msg);
        return 3;
    }
    leap_vdb_file *f = NULL;
    leap_grid *grid = NULL;
    if (leap_vdb_open(path, &f, &err) != LEAP_OK || leap_vdb_load_grid(f, 0, &grid, &err) != LEAP_OK) return 4;
    uint64_t n = leap_grid_get_info(grid)->active_voxels;
    leap_grid_destroy(grid);
    leap_vdb_close(f);
    return n == 512 ? 0 : 5;
}

#define FILL_CHILD_ARG "--fill-int32-end-child"

/* The writer's fill of a box in the last 4096 voxels of the int32 range: OpenVDB's fill loop
 * advances to the next tile with tile_max + 1, which overflows there, so it never ends (and
 * allocates without bound). Run in a child process with an address-space limit and an alarm,
 * so that a failure costs seconds, not the machine. The child is this program run again, not
 * a bare fork: libraries start threads when they load (OpenVDB's logging pool), and a fork
 * taken while one of them holds an allocator lock hangs the child. */
static void case_fill_int32_end(void)
{
    hc_begin("vdb writer: a fill box in the last root node of the int32 index range");
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) {
#ifndef LEAP_SANITIZED
        /* (AddressSanitizer reserves far more address space than this: no limit there) */
        struct rlimit rl = {(rlim_t)1 << 31, (rlim_t)1 << 31};
        setrlimit(RLIMIT_AS, &rl);
#endif
        alarm(8);
        execl("/proc/self/exe", "test_hard_limits", FILL_CHILD_ARG, (char *)NULL);
        _exit(127);
    }
    int status = 0;
    int ok = pid > 0 && waitpid(pid, &status, 0) == pid && WIFEXITED(status) && WEXITSTATUS(status) == 0;
    if (WIFSIGNALED(status))
        printf("  fill of x in [2147479552, 2147479559]: child killed by signal %d (%s)\n", WTERMSIG(status),
               WTERMSIG(status) == SIGALRM ? "still filling after 8 s" : "crashed");
    else
        printf("  fill of x in [2147479552, 2147479559]: child exit status %d\n", WEXITSTATUS(status));
    CHECK_MSG(ok, "leap_vdb_writer_fill of a leaf at x = 2^31 - 4096 does not complete (status 0x%x)", status);
    hc_end();
}

int main(int argc, char **argv)
{
    if (argc == 2 && !strcmp(argv[1], FILL_CHILD_ARG)) return fill_int32_end_child();
    hc_start();
    case_fill_int32_end();
    if (!hc_gpu_start()) return hc_finish();
    case_overflow(&G, "per-pixel list overflow: more than 16 events and 12 segments on a ray (default capacities)");
    leap_renderer_desc one_seg = {.max_segments = 1, .keep_lists = 1};
    if (gpu_init(&G_small, &one_seg)) {
        case_overflow(&G_small, "per-pixel list overflow: one segment per pixel");
        gpu_free(&G_small);
    }
    leap_renderer_desc tiny_pool = {.max_segments = 2, .pixel_events = 4, .keep_lists = 1};
    if (gpu_init(&G_small, &tiny_pool)) {
        case_overflow(&G_small, "per-pixel list overflow: 4 events per pixel");
        gpu_free(&G_small);
    }
    return hc_finish();
}
