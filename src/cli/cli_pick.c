/* `leap pick`: which object of a segmentation a pixel shows. */
#include <stdio.h>
#include <string.h>

#include "cli_common.h"
#include "leap/reference.h"

static const char *pick_help_head =
    "usage: leap pick SEGMENTATION.vdb --pixel X,Y [options]\n"
    "\n"
    "Prints the first object drawn (opacity above 0) along the ray of pixel (X, Y) of the\n"
    "image the same options would render: its ID, the world distance from the camera and the\n"
    "world position of that sample (the same lattice and nearest-voxel rule as rendering,\n"
    "computed in double precision on the CPU).\n"
    "\n";

static const char *pick_help_tail =
    "pick:\n"
    "  --pixel X,Y         pixel column and row, from the top-left corner (required)\n"
    "  --json              machine-readable output on stdout\n";

int cli_pick(int argc, char **argv)
{
    cli_camera_options o;
    cli_camera_options_init(&o);
    double pixel[2];
    int has_pixel = 0, json = 0;
    for (int i = 2; i < argc; ++i) {
        const char *a = argv[i], *v;
        int missing = 0;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            cli_print_help(pick_help_head, pick_help_tail);
            return 0;
        }
        if (!strcmp(a, "--json")) {
            json = 1;
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "--pixel", &missing)) || missing) {
            if (missing || leap__parse_numbers(v, pixel, 2, 2) != 2 || pixel[0] != (int)pixel[0] ||
                pixel[1] != (int)pixel[1] || pixel[0] < 0 || pixel[1] < 0)
                return cli_usage_error("pick", "--pixel must be X,Y (non-negative integers)");
            has_pixel = 1;
            continue;
        }
        int c = cli_camera_option(argc, argv, &i, "pick", &o);
        if (c >= CLI_OPTION_ERROR) return c - CLI_OPTION_ERROR;
        if (c == 0) {
            const char *const helps[] = {pick_help_head, cli_camera_options_help, pick_help_tail};
            return cli_unknown_option("pick", a, helps, 3);
        }
    }
    int rc = cli_camera_options_check("pick", &o, 1);
    if (rc) return rc;
    if (!has_pixel) return cli_usage_error("pick", "no pixel given (--pixel X,Y)");
    if (pixel[0] >= o.width || pixel[1] >= o.height)
        return cli_usage_error("pick", "--pixel %.0f,%.0f lies outside the %dx%d image", pixel[0], pixel[1], o.width,
                               o.height);
    leap_error err = {{0}};
    leap_scene *scene = NULL;
    leap_result r = leap_scene_create(&o.scene, &scene, &err);
    if (r) return cli_input_error(o.input, o.scene.tf, r, err.msg);
    rc = 0;
    if (!scene->labels) {
        rc = cli_usage_error("pick", "%s is not a segmentation (an int32 or int64 grid, or --labels)", o.input);
        goto done;
    }
    leap_camera cam;
    leap_rays rays;
    leap_pick p;
    leap_reference_desc rd = {.grid = scene->grid, .tf = &scene->tf, .rays = &rays, .march = &scene->march,
                              .labels = scene->labels};
    if ((r = cli_camera(&o, scene, &cam, &err)) || (r = leap_scene_rays(scene, &cam, o.width, o.height, &rays, &err)) ||
        (r = leap_reference_pick(&rd, pixel[0] + 0.5, pixel[1] + 0.5, &p, &err))) {
        rc = cli_input_error(o.input, o.scene.tf, r, err.msg);
        goto done;
    }
    if (json) {
        printf("{\"pixel\": [%.0f, %.0f], \"hit\": %s", pixel[0], pixel[1], p.hit ? "true" : "false");
        if (p.hit)
            printf(", \"id\": %lld, \"depth\": %.17g, \"world\": [%.17g, %.17g, %.17g]", (long long)p.id, p.depth,
                   p.world[0], p.world[1], p.world[2]);
        printf("}\n");
    } else if (p.hit) {
        printf("pixel %.0f,%.0f: object %lld at depth %g, world (%g, %g, %g)\n", pixel[0], pixel[1], (long long)p.id,
               p.depth, p.world[0], p.world[1], p.world[2]);
    } else {
        printf("pixel %.0f,%.0f: no visible object along the ray\n", pixel[0], pixel[1]);
    }
done:
    leap_scene_destroy(scene);
    return rc;
}
