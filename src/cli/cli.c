/* The `leap` command line: dispatch to the verbs. */
#include "leap/cli.h"

#include <stdio.h>
#include <string.h>

#include "cli_common.h"

int cli_render(int argc, char **argv);
int cli_info(int argc, char **argv);
int cli_segments(int argc, char **argv);
int cli_bench(int argc, char **argv);
int cli_view(int argc, char **argv);
int cli_pick(int argc, char **argv);
int cli_convert(int argc, char **argv);

static const char *main_help =
    "usage: leap <command> [options]\n"
    "\n"
    "Renders sparse volumes (OpenVDB, NIfTI) with empty-space skipping (Vulkan; lavapipe by\n"
    "default).\n"
    "\n"
    "commands:\n"
    "  render VOLUME.vdb -o OUT.{png,exr,tif}   render one image\n"
    "  info VOLUME.vdb [--json] [--tf T ...]    describe the grids in a file\n"
    "  segments VOLUME.vdb --pixel X,Y | -o DIR explain the ray events and segment lists\n"
    "  bench VOLUME.vdb ... -o DIR              time every mode against the reference\n"
    "  view VOLUME.vdb                          interactive window (orbit, modes, transfer functions)\n"
    "  pick VOLUME.vdb --pixel X,Y              what a pixel shows first (object ID or value, position)\n"
    "  convert SCAN.nii.gz -o OUT.vdb           write a volume as an OpenVDB file\n"
    "\n"
    "VOLUME: an OpenVDB file (.vdb); a NIfTI-1/2 scan (.nii, .nii.gz), a TIFF stack, a folder of\n"
    "slices, a quoted pattern of slices ('scan/*.png', natural order: 2 before 10) or a raw file\n"
    "(--raw), opened Z-up. Slices are single-channel (grey) TIFF or PNG images of one size; slice\n"
    "0 is the bottom, and an image's top row the largest y.\n"
    "\n"
    "Run 'leap <command> --help' for the options of a command.\n"
    "Exit codes: 0 success, 1 runtime failure, 2 usage error.\n";

int leap_cli_main(int argc, char **argv)
{
    if (argc < 2) {
        fputs(main_help, stderr);
        return EXIT_USAGE;
    }
    const char *verb = argv[1];
    cli_check_environment();
    if (!strcmp(verb, "help") && argc >= 3) { /* leap help VERB: that verb's help */
        char *verb_help[] = {argv[0], argv[2], "--help", NULL};
        return leap_cli_main(3, verb_help);
    }
    if (!strcmp(verb, "--help") || !strcmp(verb, "-h") || !strcmp(verb, "help")) {
        fputs(main_help, stdout);
        return 0;
    }
    if (!strcmp(verb, "--version")) {
        puts("leap 0.1.0");
        return 0;
    }
    if (!strcmp(verb, "render")) return cli_render(argc, argv);
    if (!strcmp(verb, "info")) return cli_info(argc, argv);
    if (!strcmp(verb, "segments")) return cli_segments(argc, argv);
    if (!strcmp(verb, "bench")) return cli_bench(argc, argv);
    if (!strcmp(verb, "view")) return cli_view(argc, argv);
    if (!strcmp(verb, "pick")) return cli_pick(argc, argv);
    if (!strcmp(verb, "convert")) return cli_convert(argc, argv);
    static const char *const verbs[] = {"render", "info", "segments", "bench", "view", "pick", "convert"};
    const char *near = leap__closest(verb, verbs, sizeof verbs / sizeof verbs[0]);
    if (near) return cli_usage_error(NULL, "unknown command '%s' (did you mean '%s'?)", verb, near);
    return cli_usage_error(NULL, "unknown command '%s'", verb);
}
