/* `leap pick`: what a pixel shows first: the object of a segmentation, or the value of a scalar
 * volume. */
#include <stdio.h>
#include <string.h>

#include "cli_common.h"
#include "leap/reference.h"

static const char *pick_help_head =
    "usage: leap pick VOLUME --pixel X,Y [options]\n"
    "\n"
    "Prints the first sample along the ray of pixel (X, Y) of the image the same options\n"
    "would render whose opacity exceeds --opacity (default 0): in a segmentation its object's\n"
    "ID, in a scalar volume its value; the world distance from the camera and the world\n"
    "position of that sample (the same lattice, interpolation and clipping as rendering,\n"
    "computed in double precision on the CPU). With --mip (--minip) it is the sample the\n"
    "pixel shows: the first reaching the ray's largest (smallest) value.\n"
    "\n";

static const char *pick_help_tail =
    "pick:\n"
    "  --pixel X,Y         pixel column and row, from the top-left corner (required)\n"
    "  --opacity A         the opacity per voxel a sample must exceed, in [0, 1) (default 0)\n"
    "  --json              machine-readable output on stdout\n";

int cli_pick(int argc, char **argv)
{
    cli_camera_options o;
    cli_camera_options_init(&o);
    double pixel[2] = {0, 0};
    int has_pixel = 0, json = 0;
    double min_opacity = 0.0;
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
        if ((v = cli_option_value(argc, argv, &i, "--opacity", &missing)) || missing) {
            if (missing || leap__parse_numbers(v, &min_opacity, 1, 1) != 1 || !(min_opacity >= 0 && min_opacity < 1))
                return cli_usage_error("pick", "--opacity must be a number in [0, 1)");
            continue;
        }
        if ((v = cli_option_value(argc, argv, &i, "--pixel", &missing)) || missing) {
            long long xy[2];
            if (missing || !cli_parse_pixel(v, xy))
                return cli_usage_error("pick", "--pixel must be X,Y (whole numbers: column, row from the top left)");
            pixel[0] = (double)xy[0];
            pixel[1] = (double)xy[1];
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
    if (pixel[0] < 0 || pixel[1] < 0 || pixel[0] >= o.width || pixel[1] >= o.height)
        return cli_usage_error("pick", "--pixel %.0f,%.0f lies outside the %dx%d image", pixel[0], pixel[1], o.width,
                               o.height);
    leap_error err = {{0}};
    leap_scene *scene = NULL;
    /* Shading changes colour only: the first sample above an opacity is the same without it,
     * and without its gradients the volume may be read on demand. */
    o.scene.shade.on = 0;
    leap_result r = cli_scene_create(&o.scene, 1, &scene, &err);
    if (r) return cli_input_error("pick", o.input, o.scene.tf, r, err.msg);
    rc = 0;
    leap_camera cam;
    leap_rays rays;
    leap_pick p;
    leap_reference_desc rd = {.grid = scene->grid, .tf = &scene->tf, .rays = &rays, .march = &scene->march,
                              .labels = scene->labels};
    if ((r = cli_camera(&o, scene, &cam, &err)) || (r = leap_scene_rays(scene, &cam, o.width, o.height, &rays, &err)) ||
        (r = leap_reference_pick(&rd, pixel[0] + 0.5, pixel[1] + 0.5, min_opacity, &p, &err))) {
        rc = cli_input_error("pick", o.input, o.scene.tf, r, err.msg);
        goto done;
    }
    if (json) {
        printf("{\"pixel\": [%.0f, %.0f], \"hit\": %s", pixel[0], pixel[1], p.hit ? "true" : "false");
        if (p.hit && scene->labels) printf(", \"id\": %lld", (long long)p.id);
        if (p.hit)
            printf(", \"value\": %.17g, \"opacity\": %.17g, \"depth\": %.17g, \"world\": [%.17g, %.17g, %.17g]",
                   p.value, p.opacity, p.depth, p.world[0], p.world[1], p.world[2]);
        printf("}\n");
    } else if (p.hit && scene->labels) {
        printf("pixel %.0f,%.0f: object %lld at depth %g, world (%g, %g, %g)\n", pixel[0], pixel[1], (long long)p.id,
               p.depth, p.world[0], p.world[1], p.world[2]);
    } else if (p.hit) {
        printf("pixel %.0f,%.0f: %svalue %g (opacity %g) at depth %g, world (%g, %g, %g)\n", pixel[0], pixel[1],
               scene->march.mip > 0 ? "largest " : scene->march.mip < 0 ? "smallest " : "", p.value, p.opacity,
               p.depth, p.world[0], p.world[1], p.world[2]);
    } else {
        printf("pixel %.0f,%.0f: no sample above opacity %g along the ray\n", pixel[0], pixel[1], min_opacity);
    }
done:
    leap_scene_destroy(scene);
    return rc;
}
