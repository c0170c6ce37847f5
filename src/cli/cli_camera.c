/* The options every rendering verb shares (volume, look, camera): parsing, checks, help
 * text, and the camera they describe. */
#include "cli_common.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int parse_size(const char *s, int *w, int *h)
{
    char *end;
    errno = 0;
    long a = strtol(s, &end, 10);
    if (end == s || (*end != 'x' && *end != 'X')) return 0;
    const char *q = end + 1;
    long b = strtol(q, &end, 10);
    if (end == q || *end || errno) return 0;
    if (a <= 0 || b <= 0 || a > 16384 || b > 16384) return 0;
    *w = (int)a;
    *h = (int)b;
    return 1;
}

const char *cli_camera_options_help =
    "volume and look:\n"
    "  --grid NAME         grid to render (default: the first scalar grid)\n"
    "  --threshold V       imports (NIfTI, raw, image stacks): voxels below V become\n"
    "                      background (skipped)\n"
    "  --raw WxHxD:TYPE[:le|be]  the volume is a header-less file of W*H*D voxels, x fastest,\n"
    "                      y from 0 (an image slice's top row is its largest y)\n"
    "                      (TYPE: uint8, int8, uint16, int16, uint32, int32, uint64, int64,\n"
    "                      float32, float64; little-endian unless :be), opened Z-up\n"
    "  --voxel X,Y,Z       raw files and image stacks: voxel size in world units (default\n"
    "                      1,1,1; a TIFF's own resolution tags are not read)\n"
    "  --tf PRESET|FILE    transfer function: a preset (grey, viridis, hot, cloud, inferno,\n"
    "                      cool-to-warm, black-body, ct, labels, level-set; see --list-tf) or a\n"
    "                      ParaView JSON colour map, its points stretched over --range\n"
    "                      (default: viridis; level sets: level-set; segmentations: object\n"
    "                      colours)\n"
    "  --range LO,HI       values mapped onto the transfer function (default: grid range;\n"
    "                      level sets: -W,W, W the largest distance stored)\n"
    "  --mip               maximum intensity projection: each pixel shows the TF at the\n"
    "                      largest value along its ray (skipping stays exact)\n"
    "  --minip             minimum intensity projection: the TF at the smallest value\n"
    "  --shade             gradient shading: Blinn-Phong lighting from a headlight, weighted by\n"
    "                      the gradient's size so flat regions keep their colour; two-sided\n"
    "                      (a gradient does not say which side is outside); scalar volumes\n"
    "                      only (the options below imply it)\n"
    "  --light X,Y,Z       world direction towards the light (default: from the eye)\n"
    "  --ambient A --diffuse D --specular S   shading terms in [0, 10] (default 0.3, 0.7, 0.3)\n"
    "  --shininess N       specular exponent in [1, 1000] (default 30)\n"
    "  --clip AXIS<V       keep only world x, y or z below V (AXIS>V: above); quote it in a\n"
    "                      shell: --clip 'x<12.5'; up to 4 planes with --clip-plane\n"
    "  --clip-plane A,B,C,D  keep only A x + B y + C z + D >= 0 (world units); the clipped\n"
    "                      side is skipped, no sample is taken there\n"
    "  --step S            sample spacing in voxels (default 0.5)\n"
    "  --size WxH          image size in pixels (default 512x512)\n"
    "  --mode MODE         sparseleap (default: march only each pixel's non-empty ray\n"
    "                      segments), bbox (skip outside the non-empty bounding box),\n"
    "                      octree (per-ray traversal of the occupancy tree), naive\n"
    "                      (march the whole volume box)\n"
    "  --no-merge          do not merge same-class sibling boxes\n"
    "  --exact-boxes       one box per class change of the occupancy tree (default: a cut\n"
    "                      chosen by a cost model, which may march some empty space where\n"
    "                      skipping it costs more than it saves; same image)\n"
    "  --segments N        ray segments stored per pixel (1..12, default 12; fewer in an\n"
    "                      image too large for the device's buffers); pixels with more\n"
    "                      walk the occupancy tree instead (as --mode octree) and are\n"
    "                      counted as overflowed\n"
    "  --device NAME       Vulkan device whose name contains NAME (env LEAP_DEVICE)\n"
    "  --gpu-cache SIZE    room for the volume's bricks on the device, e.g. 64M or 2G; a\n"
    "                      volume that needs more is rendered through a cache of that size,\n"
    "                      loading bricks as rays miss them over several passes a frame\n"
    "                      (the same image, slower; not with --shade nor for segmentations;\n"
    "                      default: room for all);\n"
    "                      the cache holds at least one layer of the bricks' image, and\n"
    "                      leap render warns when that takes more than SIZE\n"
    "  --memory-budget SIZE  memory the volume may take (env LEAP_MEMORY_BUDGET; default:\n"
    "                      half of physical memory); a .vdb float grid needing more is read\n"
    "                      on demand, leaves from the file as rays reach them, through a\n"
    "                      GPU cache of what the budget leaves (the same image, slower);\n"
    "                      the first open indexes the grid, later ones read only the leaves\n"
    "                      rays reach (env LEAP_INDEX_DIR, default ~/.cache/leap; empty: off)\n"
    "segmentations (int32/int64 grids; each object in its own colour, nearest voxel):\n"
    "  --labels            render a grid of integer values as a segmentation\n"
    "  --show IDS          show only these objects, e.g. 12,57,300-400 (default: all;\n"
    "                      given again, the lists add up)\n"
    "  --hide IDS          hide these objects (after --show and --objects)\n"
    "  --show-all          show every object (the default)\n"
    "  --objects FILE      show the objects a file lists: one 'ID [#rrggbb|R,G,B] [OPACITY]'\n"
    "                      per line, or JSON: [ID, ...], {\"objects\": [ID | {\"id\", \"color\",\n"
    "                      \"opacity\"}, ...]} or a neuroglancer layer's {\"segments\": [...]};\n"
    "                      '# ' starts a comment; IDs the volume lacks are skipped (a warning)\n"
    "  --label-opacity A   objects' opacity per voxel of ray, in (0, 1] (default 0.5)\n"
    "camera (world space):\n"
    "  --orbit AZ,EL[,DIST]  azimuth and elevation in degrees about the --up axis, distance\n"
    "                      in bounding-sphere radii (default 35,25 at the distance that\n"
    "                      frames the volume)\n"
    "  --eye X,Y,Z --target X,Y,Z   explicit camera\n"
    "  --up X,Y,Z          the world's up direction (default: 0,0,1 for imports and for .vdb\n"
    "                      files leap wrote from them, else 0,1,0; 'leap info' shows it): the\n"
    "                      orbit turns about it and the picture keeps it upright\n"
    "  --fov DEG           vertical field of view (default 40; with --ortho it only sets how far\n"
    "                      the eye stands, where each ray's samples start)\n"
    "  --ortho             orthographic projection (framing the bounding sphere)\n"
    "  --ortho-height H    the orthographic view's height in world units (implies --ortho;\n"
    "                      default: the bounding sphere's diameter)\n";

void cli_camera_options_init(cli_camera_options *o)
{
    *o = (cli_camera_options){.width = 512, .height = 512, .fov = 40.0, .mode_name = "sparseleap", .up = {0, 1, 0}};
    o->scene.step = 0.5;
    o->scene.shade = leap_shading_default();
    o->scene.shade.on = 0;
}

#define OPT(name) ((v = cli_option_value(argc, argv, i, name, &missing)) != NULL || missing)
#define FAIL(...) return CLI_OPTION_ERROR + cli_usage_error(verb, __VA_ARGS__)

int cli_input_option(int argc, char **argv, int *i, const char *verb, leap_input_options *io)
{
    const char *v;
    int missing = 0;
    if (OPT("--threshold")) {
        double n;
        if (missing || leap__parse_numbers(v, &n, 1, 1) != 1 || !isfinite(n))
            FAIL("--threshold must be a number");
        io->has_threshold = 1;
        io->threshold = n;
        return 1;
    }
    if (OPT("--raw")) {
        leap_raw_layout layout;
        leap_error e;
        if (missing) FAIL("option --raw needs a value");
        if (leap_input_parse_raw(v, &layout, &e)) FAIL("%s", e.msg);
        io->raw = v;
        return 1;
    }
    if (OPT("--voxel")) {
        double *s = io->voxel;
        if (missing || leap__parse_numbers(v, s, 3, 3) != 3 || !(s[0] > 0 && s[1] > 0 && s[2] > 0) ||
            !(isfinite(s[0]) && isfinite(s[1]) && isfinite(s[2])))
            FAIL("--voxel must be X,Y,Z with positive finite sizes");
        if (s[0] * s[1] * s[2] < 1e-14) /* OpenVDB refuses a transform of determinant below 3e-15 */
            FAIL("--voxel %g,%g,%g: a voxel of volume %g is too small for an OpenVDB transform (at least 1e-14): "
                 "give the sizes in larger units", s[0], s[1], s[2], s[0] * s[1] * s[2]);
        return 1;
    }
    return 0;
}

int cli_input_options_check(const char *verb, const char *input, const leap_input_options *io)
{
    if (io->voxel[0] > 0 && !io->raw && !(input && leap_input_is_slices(input)))
        return cli_usage_error(verb, "--voxel applies to --raw files and image stacks only (other files give their "
                                     "voxel size)");
    return 0;
}

int cli_camera_option(int argc, char **argv, int *i, const char *verb, cli_camera_options *o)
{
    const char *a = argv[*i], *v;
    int missing = 0;
    const int c = cli_input_option(argc, argv, i, verb, &o->scene.input);
    if (c) return c;
    if (!strcmp(a, "--ortho")) {
        o->ortho = 1;
        return 1;
    }
    if (!strcmp(a, "--no-merge")) {
        o->scene.no_merge = 1;
        return 1;
    }
    if (!strcmp(a, "--exact-boxes")) {
        o->scene.exact_boxes = 1;
        return 1;
    }
    if (!strcmp(a, "--labels")) {
        o->scene.labels = 1;
        return 1;
    }
    if (!strcmp(a, "--mip") || !strcmp(a, "--minip")) {
        const int mip = strcmp(a, "--minip") ? LEAP_MIP_MAX : LEAP_MIP_MIN;
        if (o->scene.mip && o->scene.mip != mip) FAIL("--mip and --minip exclude each other");
        o->scene.mip = mip;
        return 1;
    }
    if (!strcmp(a, "--shade")) {
        o->scene.shade.on = 1;
        return 1;
    }
    if (!strcmp(a, "--show-all")) {
        o->scene.show = o->scene.hide = o->scene.objects = NULL;
        o->show_ids[0] = o->hide_ids[0] = '\0';
        return 1;
    }
    enum { GRID, TF, RANGE, STEP, SIZE, MODE, SEGMENTS, DEVICE, GPU_CACHE, MEMORY_BUDGET, ORBIT, EYE, TARGET, UP, SHOW,
           HIDE, OBJECTS, OPACITY, ORTHO_HEIGHT, FOV, CLIP, CLIP_PLANE, LIGHT, AMBIENT, DIFFUSE, SPECULAR, SHININESS, COUNT };
    static const char *const names[COUNT] = {
        [GRID] = "--grid", [TF] = "--tf",         [RANGE] = "--range",   [STEP] = "--step",     [SIZE] = "--size",
        [MODE] = "--mode", [SEGMENTS] = "--segments", [DEVICE] = "--device", [GPU_CACHE] = "--gpu-cache",
        [MEMORY_BUDGET] = "--memory-budget", [ORBIT] = "--orbit", [EYE] = "--eye",
        [TARGET] = "--target", [UP] = "--up", [SHOW] = "--show", [HIDE] = "--hide", [OBJECTS] = "--objects",
        [OPACITY] = "--label-opacity", [ORTHO_HEIGHT] = "--ortho-height", [FOV] = "--fov", [CLIP] = "--clip", [CLIP_PLANE] = "--clip-plane",
        [LIGHT] = "--light", [AMBIENT] = "--ambient", [DIFFUSE] = "--diffuse", [SPECULAR] = "--specular",
        [SHININESS] = "--shininess", };
    int which = -1;
    for (int k = 0; k < COUNT && which < 0; ++k)
        if (OPT(names[k])) which = k;
    if (which < 0) {
        if (a[0] == '-' && a[1] != '\0') return 0;
        if (o->input) FAIL("unexpected argument '%s' (one volume at a time)", a);
        o->input = o->scene.path = a;
        return 1;
    }
    if (missing) FAIL("option %s needs a value", names[which]);
    double n;
    switch (which) {
    case GRID: o->scene.grid = v; break;

    case TF: o->scene.tf = v; break;
    case RANGE:
        if (leap__parse_numbers(v, o->scene.range, 2, 2) != 2 || !(o->scene.range[1] > o->scene.range[0]))
            FAIL("--range '%s' must be LO,HI with LO < HI", v);
        o->scene.has_range = 1;
        break;
    case STEP:
        if (leap__parse_numbers(v, &n, 1, 1) != 1 || !(n > 0)) FAIL("--step '%s' must be a positive number of voxels", v);
        if (n < 1e-3 || n > 1e6) FAIL("--step %g is outside [0.001, 1e6] voxels", n);
        o->scene.step = n;
        break;
    case SIZE:
        if (!parse_size(v, &o->width, &o->height)) FAIL("--size '%s' is not WxH with 1 <= W, H <= 16384", v);
        break;
    case MODE: o->mode_name = v; break;
    case SEGMENTS:
        if (leap__parse_numbers(v, &n, 1, 1) != 1 || n != floor(n) || n < 1 || n > LEAP_MAX_SEGMENTS)
            FAIL("--segments '%s' must be an integer in 1..%d", v, LEAP_MAX_SEGMENTS);
        o->max_segments = (int)n;
        break;
    case DEVICE: o->device = v; break;
    case GPU_CACHE:
        if (!(o->gpu_cache_bytes = leap__parse_bytes(v)))
            FAIL("--gpu-cache '%s' must be a size such as 64M, 1.5G or 500000 (bytes)", v);
        break;
    case MEMORY_BUDGET:
        if (!(o->scene.memory_budget = leap__parse_bytes(v)))
            FAIL("--memory-budget '%s' must be a size such as 512M, 2GiB or 500000000 (bytes)", v);
        break;
    case ORBIT:
        o->orbit_n = leap__parse_numbers(v, o->orbit, 2, 3);
        if (o->orbit_n < 0 || (o->orbit_n == 3 && !(o->orbit[2] > 0)))
            FAIL("--orbit '%s' must be AZ,EL[,DIST] with DIST > 0", v);
        if (o->orbit_n == 3 && o->orbit[2] > 1e6)
            FAIL("--orbit distance %g is more than 1e6 bounding-sphere radii (the volume would be below a pixel)",
                 o->orbit[2]);
        o->has_orbit = 1;
        break;
    case EYE:
    case TARGET: {
        double *p = which == EYE ? o->eye : o->target;
        if (leap__parse_numbers(v, p, 3, 3) != 3) FAIL("%s '%s' must be X,Y,Z", names[which], v);
        /* Beyond this, squared distances overflow and the view direction is lost. */
        for (int k = 0; k < 3; ++k)
            if (fabs(p[k]) > 1e100) FAIL("%s '%s': coordinates must be within +-1e100", names[which], v);
        *(which == EYE ? &o->has_eye : &o->has_target) = 1;
        break;
    }
    case UP:
        if (leap__parse_numbers(v, o->up, 3, 3) != 3) FAIL("--up '%s' must be X,Y,Z", v);
        o->has_up = 1;
        break;
    case LIGHT:
        if (leap__parse_numbers(v, o->scene.shade.light, 3, 3) != 3 || !(isfinite(o->scene.shade.light[0]) &&
                                                                          isfinite(o->scene.shade.light[1]) &&
                                                                          isfinite(o->scene.shade.light[2])))
            FAIL("--light '%s' must be X,Y,Z (a world direction towards the light)", v);
        if (o->scene.shade.light[0] == 0 && o->scene.shade.light[1] == 0 && o->scene.shade.light[2] == 0)
            FAIL("--light 0,0,0 has no direction (without --light the light comes from the eye)");
        o->scene.shade.on = 1;
        break;
    case AMBIENT:
    case DIFFUSE:
    case SPECULAR:
    case SHININESS: {
        const double lo = which == SHININESS ? 1 : 0, hi = which == SHININESS ? 1000 : 10;
        if (leap__parse_numbers(v, &n, 1, 1) != 1 || !(n >= lo && n <= hi))
            FAIL("%s '%s' must be a number in [%g, %g]", names[which], v, lo, hi);
        double *term = which == AMBIENT ? &o->scene.shade.ambient : which == DIFFUSE ? &o->scene.shade.diffuse
                     : which == SPECULAR ? &o->scene.shade.specular : &o->scene.shade.shininess;
        *term = n;
        o->scene.shade.on = 1;
        break;
    }
    case SHOW:
    case HIDE: { /* given again: the lists add up */
        char *ids = which == SHOW ? o->show_ids : o->hide_ids;
        const size_t used = strlen(ids);
        if (used + 1 + strlen(v) >= sizeof o->show_ids) FAIL("%s: the object lists given are too long", names[which]);
        snprintf(ids + used, sizeof o->show_ids - used, "%s%s", used ? "," : "", v);
        *(which == SHOW ? &o->scene.show : &o->scene.hide) = ids;
        break;
    }
    case OBJECTS: o->scene.objects = v; break;
    case OPACITY:
        if (leap__parse_numbers(v, &n, 1, 1) != 1 || !(n > 0 && n <= 1))
            FAIL("--label-opacity '%s' must be a number in (0, 1]", v);
        o->scene.label_opacity = n;
        break;
    case CLIP:
    case CLIP_PLANE: {
        if (o->scene.clip_count == LEAP_MAX_CLIPS) FAIL("at most %d clipping planes", LEAP_MAX_CLIPS);
        double *p = o->scene.clip[o->scene.clip_count];
        const char axis = (char)tolower((unsigned char)v[0]);
        if (which == CLIP) {
            /* AXIS<VALUE keeps the side below VALUE, AXIS>VALUE the side above, in world units. */
            if (!(axis == 'x' || axis == 'y' || axis == 'z') || (v[1] != '<' && v[1] != '>') ||
                leap__parse_numbers(v + 2, &n, 1, 1) != 1 || !isfinite(n))
                FAIL("--clip '%s' must be AXIS<VALUE or AXIS>VALUE (x, y or z; world units; quote it in a shell)", v);
            const double side = v[1] == '<' ? -1.0 : 1.0;
            p[0] = p[1] = p[2] = 0.0;
            p[axis - 'x'] = side;
            p[3] = -side * n;
        } else {
            if (leap__parse_numbers(v, p, 4, 4) != 4 || !(p[0] * p[0] + p[1] * p[1] + p[2] * p[2] > 0) ||
                !isfinite(p[3]))
                FAIL("--clip-plane '%s' must be A,B,C,D (keeps A x + B y + C z + D >= 0; A,B,C not all 0)", v);
        }
        o->scene.clip_count++;
        break;
    }
    case ORTHO_HEIGHT:
        if (leap__parse_numbers(v, &o->ortho_height, 1, 1) != 1 || !(o->ortho_height > 0) || !isfinite(o->ortho_height))
            FAIL("--ortho-height '%s' must be a positive number (world units)", v);
        o->ortho = 1;
        break;
    case FOV:
    default:
        if (leap__parse_numbers(v, &o->fov, 1, 1) != 1 || !(o->fov > 0 && o->fov < 180))
            FAIL("--fov '%s' must be in (0, 180) degrees", v);
        break;
    }
    return 1;
#undef OPT
#undef FAIL
}

/* The up of an --eye/--target camera: `up`, unless the user gave none and the volume's lies
 * along the view (a top view of a Z-up scan): then the up an orbit has at that pole (azimuth 0),
 * by the test leap_rays_make refuses it with. */
static void eye_up(const cli_camera_options *o, double up[3])
{
    if (!o->has_up) leap_camera_up_off_view(o->eye, o->target, up);
}

int cli_camera_options_check(const char *verb, const cli_camera_options *o, int allow_reference)
{
    if (!o->input) return cli_usage_error(verb, "no input volume given");
    if (cli_input_options_check(verb, o->input, &o->scene.input)) return EXIT_USAGE;
    if (o->has_orbit && (o->has_eye || o->has_target)) return cli_usage_error(verb, "--orbit conflicts with --eye/--target");
    if (o->has_eye != o->has_target) return cli_usage_error(verb, "--eye and --target go together");
    if (o->has_up && !(o->up[0] * o->up[0] + o->up[1] * o->up[1] + o->up[2] * o->up[2] > 0))
        return cli_usage_error(verb, "--up %g,%g,%g: the up direction must not be zero", o->up[0], o->up[1], o->up[2]);
    if (o->has_eye) {
        /* The camera's own checks (eye == target, zero up, up along the view), in world space
         * like at render time, but reported here against the options. */
        static const double identity[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
        const double origin[3] = {0, 0, 0};
        leap_camera cam = {.fov_deg = o->fov, .ortho = o->ortho, .ortho_height = 1};
        memcpy(cam.eye, o->eye, sizeof cam.eye);
        memcpy(cam.target, o->target, sizeof cam.target);
        memcpy(cam.up, o->up, sizeof cam.up);
        eye_up(o, cam.up);
        leap_rays view;
        leap_error err = {{0}};
        if (leap_rays_make(&cam, o->width, o->height, identity, origin, &view, &err) != LEAP_OK)
            return cli_usage_error(verb, "--eye %g,%g,%g --target %g,%g,%g --up %g,%g,%g: %s", o->eye[0], o->eye[1],
                                   o->eye[2], o->target[0], o->target[1], o->target[2], o->up[0], o->up[1], o->up[2],
                                   err.msg);
    }
    int reference = allow_reference && strcmp(o->mode_name, "reference") == 0;
    if (!reference && leap_mode_from_name(o->mode_name) < 0) {
        static const char *const modes[] = {"sparseleap", "octree", "bbox", "naive", "reference"};
        const char *near = leap__closest(o->mode_name, modes, allow_reference ? 5 : 4);
        char hint[64] = "";
        if (near) snprintf(hint, sizeof hint, "did you mean '%s'? ", near);
        return cli_usage_error(verb, "unknown --mode '%s' (%ssparseleap, octree, bbox, naive%s)", o->mode_name, hint,
                               allow_reference ? ", reference" : "");
    }
    return 0;
}

void cli_up(const cli_camera_options *o, const leap_scene *s, double up[3])
{
    const double *u = o->has_up ? o->up : s->input.up;
    memcpy(up, u, 3 * sizeof *up);
    if (up[0] == 0 && up[1] == 0 && up[2] == 0) up[1] = 1; /* no hint: +Y */
}

leap_result cli_camera(const cli_camera_options *o, const leap_scene *s, leap_camera *cam, leap_error *err)
{
    double up[3];
    cli_up(o, s, up);
    if (o->has_eye) {
        *cam = (leap_camera){.fov_deg = o->fov, .ortho = o->ortho, .ortho_height = 2 * s->radius};
        memcpy(cam->eye, o->eye, sizeof cam->eye);
        memcpy(cam->target, o->target, sizeof cam->target);
        memcpy(cam->up, up, sizeof cam->up);
        eye_up(o, cam->up);
    } else {
        double az = o->has_orbit ? o->orbit[0] : 35, el = o->has_orbit ? o->orbit[1] : 25;
        double dist = o->orbit_n == 3 ? o->orbit[2] : 0;
        leap_result r = leap_camera_orbit_about(s->center, s->radius, up, az, el, dist, o->fov, o->ortho, cam, err);
        if (r) return r;
    }
    if (o->ortho_height > 0) cam->ortho_height = o->ortho_height;
    return LEAP_OK;
}
