/* `leap convert`: a scan (NIfTI) or any volume leap opens, written as an OpenVDB file. */
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "cli_common.h"
#include "leap/input.h"

static const char *convert_help =
    "usage: leap convert VOLUME -o OUT.vdb [options]\n"
    "\n"
    "Writes a volume leap opens (NIfTI, TIFF stack, folder of slices, raw, .vdb) as an OpenVDB\n"
    "file: voxels equal to the background (a scan's smallest value; 0 for label maps) become\n"
    "inactive, constant blocks become tiles, the voxel-to-world transform and the up axis are\n"
    "kept. Label maps (integer NIfTI data with a label intent) and --labels write an int64 grid\n"
    "of exact IDs; the rest a float grid. The file renders the image of the volume opened\n"
    "directly.\n"
    "\n"
    "options:\n"
    "  -o, --output OUT.vdb  the file to write (through a temporary file and a rename)\n"
    "  --threshold V       voxels below V become background (inactive)\n"
    "  --raw WxHxD:TYPE[:le|be]  VOLUME is a header-less file (see 'leap render --help')\n"
    "  --voxel X,Y,Z       raw files and image stacks: voxel size in world units (default\n"
    "                      1,1,1)\n"
    "  --labels            write integer values as a segmentation (int64 grid)\n"
    "  --grid NAME         grid to convert (default: the first scalar grid)\n"
    "  -q, --quiet         no progress or summary on stderr\n";

/* The stage bar on stderr (only on a terminal: a log gets the summary line alone). */
static void stage(int quiet, int done, const char *what)
{
    if (!quiet && isatty(2)) cli_progress(done, 3, what);
}

int cli_convert(int argc, char **argv)
{
    const char *input = NULL, *output = NULL, *grid_name = NULL;
    leap_input_options io = {0};
    int labels = 0, quiet = 0, rc = 0;
    for (int i = 2; i < argc; ++i) {
        const char *a = argv[i], *v;
        int missing = 0;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(convert_help, stdout);
            return 0;
        }
        if (!strcmp(a, "--labels")) labels = 1;
        else if (!strcmp(a, "-q") || !strcmp(a, "--quiet")) quiet = 1;
        else if ((v = cli_option_value(argc, argv, &i, "-o", &missing)) || missing ||
                 (v = cli_option_value(argc, argv, &i, "--output", &missing)) || missing) {
            if (missing) return cli_usage_error("convert", "option -o needs a value");
            if (output) return cli_usage_error("convert", "-o given twice ('%s', then '%s')", output, v);
            output = v;
        } else if ((rc = cli_input_option(argc, argv, &i, "convert", &io))) {
            if (rc >= CLI_OPTION_ERROR) return rc - CLI_OPTION_ERROR;
        } else if ((v = cli_option_value(argc, argv, &i, "--grid", &missing)) || missing) {
            if (missing) return cli_usage_error("convert", "option --grid needs a value");
            grid_name = v;
        } else if (a[0] == '-' && a[1]) {
            return cli_unknown_option("convert", a, &convert_help, 1);
        } else if (!input) {
            input = a;
        } else {
            return cli_usage_error("convert", "unexpected argument '%s' (one volume at a time)", a);
        }
    }
    if (!input) return cli_usage_error("convert", "no input volume given");
    if (cli_input_options_check("convert", input, &io)) return EXIT_USAGE;
    if (!output) return cli_usage_error("convert", "no output file given (-o OUT.vdb)");
    const size_t n = strlen(output);
    if (n < 4 || strcasecmp(output + n - 4, ".vdb") != 0)
        return cli_usage_error("convert", "'%s': the output must be a .vdb file", output);
    const char *inputs[] = {input};
    rc = cli_check_outputs("convert", inputs, 1, &output, 1);
    if (rc) return rc;
    if ((rc = cli_output_check(output, 0))) return rc;

    leap_error err = {{0}};
    leap_vdb_file *file = NULL;
    leap_grid *grid = NULL;
    leap_input_info source;
    double t0 = leap__now_ms();
    stage(quiet, 0, "reading");
    io.labels = labels;
    leap_result r = leap_input_open(input, &io, &file, &source, &err);
    const double t_read = leap__now_ms();
    int index = -1;
    if (!r && (index = leap_vdb_find_grid(file, grid_name)) < 0)
        r = grid_name ? leap_fail(&err, LEAP_ERR_FORMAT, "%s: no grid named '%s' (leap info lists them)", input, grid_name)
                      : leap_fail(&err, LEAP_ERR_FORMAT, "%s: no scalar grid to convert", input);
    if (!r) stage(quiet, 1, "building the grid");
    if (!r) r = leap_vdb_load_grid(file, index, &grid, &err);
    if (!r && labels && !leap_grid_has_labels(grid)) r = leap_grid_make_labels(grid, &err);
    const double t_build = leap__now_ms();
    if (!r) stage(quiet, 2, "writing");
    int writing = !r;
    if (!r) r = leap_grid_save(grid, source.up, output, &err);
    const double t_write = leap__now_ms();
    if (r) {
        if (!quiet && isatty(2)) fputc('\n', stderr);
        /* the output's error names the output, not the input */
        rc = writing ? cli_input_error("convert", output, NULL, r, err.msg) : cli_input_error("convert", input, NULL, r, err.msg);
    } else {
        stage(quiet, 3, "done");
        const leap_grid_info *gi = leap_grid_get_info(grid);
        uint64_t tiles = 0;
        for (int l = 0; l < LEAP_TILE_LEVELS; ++l) tiles += gi->active_tiles[l];
        if (!quiet)
            fprintf(stderr,
                    "leap: wrote %s (%s grid '%s', %llu active voxels, %llu leaves, %llu tiles; from %s; read %.0f ms, "
                    "built %.0f ms, written %.0f ms)\n",
                    output, leap_grid_has_labels(grid) ? "int64" : "float", gi->name,
                    (unsigned long long)gi->active_voxels, (unsigned long long)gi->leaf_count,
                    (unsigned long long)tiles, source.format, t_read - t0, t_build - t_read, t_write - t_build);
        /* One grid is written: the others of a file of several are named, not dropped unsaid. */
        char others[512] = "";
        int left = 0;
        for (int i = 0; i < leap_vdb_grid_count(file); ++i) {
            leap_grid_info other;
            leap_error ignore;
            if (i == index || leap_vdb_grid_info(file, i, &other, &ignore)) continue;
            if (left++ < 8)
                snprintf(others + strlen(others), sizeof others - strlen(others), "%s'%.60s'", left > 1 ? ", " : "",
                         other.name);
        }
        if (left)
            fprintf(stderr, "leap: warning: %s holds %d other grid%s (%s%s), not written: one grid a file (--grid "
                            "chooses it)\n", input, left, left == 1 ? "" : "s", others, left > 8 ? ", ..." : "");
    }
    leap_grid_destroy(grid);
    leap_vdb_close(file);
    return rc;
}
