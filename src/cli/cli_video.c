/* `leap render --turntable N -o spin.mp4|spin.gif`: the turntable's frames rendered into a
 * temporary folder beside the output, encoded by an installed ffmpeg, published by rename. */
#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "cli_common.h"
#include "leap/files.h"

int cli_is_video(const char *path)
{
    const char *dot = path ? strrchr(path, '.') : NULL;
    return dot && (!strcasecmp(dot, ".mp4") || !strcasecmp(dot, ".gif"));
}

/* 1 if an executable `name` is on PATH. */
static int on_path(const char *name)
{
    const char *path = getenv("PATH");
    char dir[4096], full[4200];
    while (path && *path) {
        size_t len = strcspn(path, ":");
        snprintf(dir, sizeof dir, "%.*s", (int)len, path);
        snprintf(full, sizeof full, "%s/%s", len ? dir : ".", name);
        if (access(full, X_OK) == 0) return 1;
        path += len + (path[len] == ':');
    }
    return 0;
}

/* Removes the folder of frames and everything in it (only files: it holds nothing else). */
static void remove_frames(const char *dir)
{
    DIR *d = opendir(dir);
    char file[4400];
    for (struct dirent *e; d && (e = readdir(d));) {
        if (e->d_name[0] == '.') continue;
        snprintf(file, sizeof file, "%s/%s", dir, e->d_name);
        remove(file);
    }
    if (d) closedir(d);
    rmdir(dir);
}

int cli_turntable_video(const cli_camera_options *o, int frames, const char *output, int quiet)
{
    const char *inputs[CLI_SCENE_INPUTS];
    cli_scene_inputs(o, inputs);
    int rc = cli_check_outputs("render", inputs, CLI_SCENE_INPUTS, &output, 1);
    if (rc) return rc;
    if (!on_path("ffmpeg"))
        return cli_runtime_error("%s: writing a video needs ffmpeg, which is not on PATH (Debian: apt-get install "
                                 "ffmpeg); or write the frames: -o frames/%%03d.png",
                                 output);
    if ((rc = cli_output_check(output, 0))) return rc;
    char dir[4096];
    const char *slash = strrchr(output, '/');
    snprintf(dir, sizeof dir, "%.*s.leap-tmp-frames-XXXXXX", slash ? (int)(slash - output + 1) : 0, output);
    if (!mkdtemp(dir)) return cli_runtime_error("%s: cannot make a folder for the frames: %s", output, strerror(errno));
    char pattern[4200];
    snprintf(pattern, sizeof pattern, "%s/%%05d.png", dir);
    rc = cli_turntable(o, frames, pattern, quiet);
    leap_error err = {{0}};
    leap_publish pub;
    if (!rc && leap_publish_begin(&pub, output, &err)) rc = cli_runtime_error("%s", err.msg);
    else if (!rc) {
        const int gif = !strcasecmp(strrchr(output, '.'), ".gif");
        /* Even sizes for H.264's 4:2:0; one palette for the whole GIF. */
        const char *filter = gif ? "split[a][b];[a]palettegen[p];[b][p]paletteuse"
                                 : "pad=ceil(iw/2)*2:ceil(ih/2)*2,format=yuv420p";
        char *const argv[] = {"ffmpeg", "-hide_banner", "-loglevel", "error", "-nostdin", "-y", "-framerate", "24",
                              "-i", pattern, "-vf", (char *)filter, gif ? "-loop" : "-movflags",
                              gif ? "0" : "+faststart", pub.tmp, NULL};
        pid_t pid = fork();
        if (pid == 0) {
            execvp("ffmpeg", argv);
            _exit(127);
        }
        int status = 0;
        if (pid < 0 || waitpid(pid, &status, 0) < 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
            leap_publish_abort(&pub);
            rc = cli_runtime_error("%s: ffmpeg failed to encode the %d frames (exit %d)", output, frames,
                                   WIFEXITED(status) ? WEXITSTATUS(status) : -1);
        } else if (leap_publish_commit(&pub, &err)) {
            rc = cli_runtime_error("%s", err.msg);
        } else if (!quiet) {
            const int w = gif ? o->width : (o->width + 1) / 2 * 2, h = gif ? o->height : (o->height + 1) / 2 * 2;
            fprintf(stderr, "leap: wrote %s (%d frames of %dx%d at 24 per second, encoded by ffmpeg%s)\n", output,
                    frames, w, h, w != o->width || h != o->height ? "; padded to even sides for H.264" : "");
        }
    }
    remove_frames(dir);
    return rc;
}
