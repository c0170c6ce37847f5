/* Never destroy an input, never hang on a file that is not a file, never leave a temporary
 * behind: the real `leap` binary against outputs that name its inputs (same path, other
 * spelling, symbolic and hard links, dump and bench folders), FIFOs and devices given as
 * transfer functions, configs and scripts, signals and file-size limits during the write,
 * constant grids, bad transforms, control characters in grid names and huge extents. */
#include <limits.h>
#include <math.h>
#include <signal.h>
#include <stdint.h>
#include <sys/resource.h>
#include <time.h>

#include "cli_harness.h"
#include "leap/image.h"

static int same_bytes(const char *a, const char *b)
{
    long na = 0, nb = 0;
    unsigned char *da = read_whole_file(a, &na), *db = read_whole_file(b, &nb);
    int same = da && db && na == nb && memcmp(da, db, (size_t)na) == 0;
    free(da);
    free(db);
    return same;
}

static void copy_file(const char *from, const char *to)
{
    long n = 0;
    unsigned char *d = read_whole_file(from, &n);
    CHECK_MSG(d != NULL, "cannot read %s", from);
    if (d) write_bytes(to, d, (size_t)n);
    free(d);
}

/* A clash must be a usage error naming both paths, and the input must be unchanged. */
static void expect_clash(const char *label, const char *input, const char *const *argv)
{
    ++case_count;
    char text[4096];
    args_text(argv, text, sizeof text);
    run_leap(argv);
    CHECK_MSG(res.code == 2, "[%s] leap %s -> exit %d, expected 2: %s", label, text, res.code, res.err);
    CHECK_MSG(line_count(res.err) == 1 && strstr(res.err, "same file"), "[%s] message: %s", label, res.err);
    CHECK_MSG(same_bytes(input, sphere), "[%s] leap %s changed the input %s", label, text, input);
    printf("[%s] exit %d: %s", label, res.code, res.err);
}

static void outputs_never_replace_inputs(void)
{
    /* 1. An image output that is the input, whatever its extension or spelling. */
    const char *png = in_path("vol.png"), *exr = in_path("vol.exr");
    copy_file(sphere, png);
    copy_file(sphere, exr);
    expect_clash("output = input (.png)", png, ARGV("render", png, "-o", png));
    char dotted[1200];
    snprintf(dotted, sizeof dotted, "%s/./vol.exr", in_dir);
    expect_clash("output = input (./ spelling)", exr, ARGV("render", exr, "-o", dotted));
    const char *sym = in_path("link.exr"), *hard = in_path("hard.tif");
    CHECK(symlink(exr, sym) == 0);
    CHECK(link(exr, hard) == 0);
    expect_clash("output is a symlink to the input", exr, ARGV("render", exr, "-o", sym));
    expect_clash("output is a hard link of the input", exr, ARGV("render", exr, "-o", hard));

    expect_clash("view --screenshot = volume", png, ARGV("view", png, "--screenshot", png));
    const char *script = in_path("shots.txt");
    char text[1400];
    snprintf(text, sizeof text, "orbit 10 0\nscreenshot %s\n", png);
    write_text(script, text);
    expect_clash("view script screenshot = volume", png, ARGV("view", png, "--script", script));

    /* 2. --stats onto the volume or the transfer function. */
    const char *vdb = in_path("X.vdb"), *tf = in_path("t.json");
    copy_file(sphere, vdb);
    copy_file(sphere, tf); /* the bytes only matter for the unchanged check */
    expect_clash("--stats = volume", vdb, ARGV("render", vdb, "-o", out_path("s.png"), "--stats", vdb));
    expect_clash("--stats = --tf file", tf, ARGV("render", vdb, "-o", out_path("s.png"), "--tf", tf, "--stats", tf));
    const char *objects = in_path("objects.txt");
    copy_file(sphere, objects);
    expect_clash("--stats = --objects file", objects,
                 ARGV("render", vdb, "-o", out_path("s.png"), "--objects", objects, "--stats", objects));
    snprintf(text, sizeof text, "tfsave %s\n", tf);
    write_text(script, text);
    expect_clash("view script tfsave = --tf file", tf, ARGV("view", vdb, "--tf", tf, "--script", script));

    /* 3. Dump and bench folders holding an input under a name they write. */
    char dir[1200];
    snprintf(dir, sizeof dir, "%s/D", in_dir);
    mkdir(dir, 0755);
    char seg[1300], obj[1300], csv[1300], report[1300];
    snprintf(seg, sizeof seg, "%s/segments.bin", dir);
    snprintf(obj, sizeof obj, "%s/boxes.obj", dir);
    snprintf(csv, sizeof csv, "%s/results.csv", dir);
    snprintf(report, sizeof report, "%s/speed_error_1.svg", dir);
    copy_file(sphere, seg);
    copy_file(sphere, obj);
    copy_file(sphere, csv);
    copy_file(sphere, report);
    expect_clash("segments input in its dump folder", seg, ARGV("segments", seg, "-o", dir));
    char dir_slash[1300];
    snprintf(dir_slash, sizeof dir_slash, "%s/", dir);
    expect_clash("segments boxes.obj in its dump folder", obj, ARGV("segments", obj, "-o", dir_slash, "--size", "8x8"));
    expect_clash("bench input = results.csv", csv, ARGV("bench", csv, "-o", dir, "--views", "1", "--no-reference"));
    expect_clash("bench input = second volume's plot", report,
                 ARGV("bench", sphere, report, "-o", dir, "--views", "1", "--no-reference"));
    /* a plot name beyond this run's volumes: a bench removes an earlier run's plots */
    char stale[1300];
    snprintf(stale, sizeof stale, "%s/speed_error_7.png", dir);
    copy_file(sphere, stale);
    expect_clash("bench input = an earlier run's plot", stale,
                 ARGV("bench", stale, "-o", dir, "--views", "1", "--no-reference"));
    char left[2048];
    const char *const kept[] = {"segments.bin", "boxes.obj", "results.csv", "speed_error_1.svg", "speed_error_7.png",
                                NULL};
    CHECK_MSG(unexpected_entries(dir, kept, left, sizeof left) == 0, "dump folder left behind: %s", left);

    /* A directory where the bench writes its report: refused before any frame, the previous
     * results kept. */
    char way[1300], way_csv[1400], way_report[1400];
    snprintf(way, sizeof way, "%s/W", in_dir);
    snprintf(way_csv, sizeof way_csv, "%s/results.csv", way);
    snprintf(way_report, sizeof way_report, "%s/report.md", way);
    mkdir(way, 0755);
    mkdir(way_report, 0755);
    copy_file(sphere, way_csv);
    FAIL("bench: a directory named report.md", 1, "report.md", "in the way", "bench", sphere, "-o", way, "--views", "1",
         "--no-reference");
    CHECK_MSG(same_bytes(way_csv, sphere), "bench replaced results.csv before failing on report.md");
    rmdir(way_report);

    /* The same output twice is still refused, and distinct names still render. */
    FAIL("--stats = -o", 2, "s.png", "same file", "render", sphere, "-o", out_path("s.png"), "--stats",
         out_path("s.png"));
    ++case_count;
    run_leap(ARGV("render", vdb, "-o", out_path("fine.png"), "--size", "16x16", "--stats", out_path("fine.json")));
    CHECK_MSG(res.code == 0, "distinct outputs: exit %d: %s", res.code, res.err);
    clean_dir(out_dir);
}

/* 4. A slice of an image stack (a folder or a pattern) named as an output: refused as the
 * input itself is, for -o, --stats and a turntable's frames. */
static void stack_slices_never_replaced(void)
{
    char dir[1200], slice[3][1300], pattern[1300], frames[1300];
    snprintf(dir, sizeof dir, "%s/stack", in_dir);
    mkdir(dir, 0755);
    float pixels[8 * 8];
    leap_error err;
    for (int k = 0; k < 3; ++k) {
        for (int i = 0; i < 64; ++i) pixels[i] = (float)(k * 64 + i) / 192.0f;
        snprintf(slice[k], sizeof slice[k], "%s/s%d.png", dir, k);
        CHECK_OK(leap_image_write(slice[k], 8, 8, 1, NULL, pixels, &err), &err);
    }
    char before[1200];
    snprintf(before, sizeof before, "%s", out_path("s1.before"));
    copy_file(slice[1], before);
    snprintf(pattern, sizeof pattern, "%s/s*.png", dir);
    snprintf(frames, sizeof frames, "%s/s%%d.png", dir);
    const char *const *cases[] = {
        ARGV("render", dir, "-o", slice[1]),
        ARGV("render", pattern, "-o", slice[1]),
        ARGV("render", dir, "-o", out_path("fine.png"), "--stats", slice[1]),
        ARGV("render", dir, "-o", frames, "--turntable", "2", "--size", "8x8"),
        ARGV("view", dir, "--screenshot", slice[1]),
    };
    for (size_t c = 0; c < sizeof cases / sizeof *cases; ++c) {
        ++case_count;
        char text[4096];
        args_text(cases[c], text, sizeof text);
        run_leap(cases[c]);
        CHECK_MSG(res.code == 2 && strstr(res.err, "is a slice of the input"), "leap %s -> exit %d: %s", text, res.code,
                  res.err);
        CHECK_MSG(same_bytes(slice[1], before), "leap %s changed a slice of its input", text);
    }
    ++case_count;
    run_leap(ARGV("render", dir, "-o", out_path("fine.png"), "--size", "8x8"));
    CHECK_MSG(res.code == 0, "a stack rendered beside it: exit %d: %s", res.code, res.err);
    clean_dir(out_dir);
}

/* 5. Files that are not regular files never block and never leave anything behind. */
static void non_regular_files(void)
{
    const char *fifo = in_path("pipe.json"), *script = in_path("pipe.txt"), *zero = in_path("zero.json");
    CHECK(mkfifo(fifo, 0644) == 0);
    CHECK(mkfifo(script, 0644) == 0);
    CHECK(symlink("/dev/zero", zero) == 0);
    FAIL("render --tf FIFO", 1, "pipe.json", "FIFO", "render", sphere, "-o", out_path("a.png"), "--tf", fifo);
    FAIL("info --tf FIFO", 1, "pipe.json", "FIFO", "info", sphere, "--tf", fifo);
    FAIL("bench --tf FIFO", 1, "pipe.json", "FIFO", "bench", sphere, "-o", out_path("B"), "--tf", fifo);
    FAIL("bench --config FIFO", 1, "pipe.json", "FIFO", "bench", sphere, "-o", out_path("B"), "--config", fifo);
    FAIL("view --script FIFO", 1, "pipe.txt", "FIFO", "view", sphere, "--script", script);
    FAIL("render --tf /dev/zero", 1, "zero.json", "device", "render", sphere, "-o", out_path("a.png"), "--tf", zero);
    const char *dir = in_path("folder.json");
    mkdir(dir, 0755);
    FAIL("render --tf directory", 1, "folder.json", "directory", "render", sphere, "-o", out_path("a.png"), "--tf", dir);
    /* A config larger than any fixed buffer is read whole (it was cut at 64 KiB before). */
    const char *big = in_path("big.json");
    size_t n = 200000;
    char *text = malloc(n + 64);
    int len = sprintf(text, "{\"views\": 1, \"bogus_key\": \"");
    memset(text + len, 'x', n);
    strcpy(text + len + n, "\"}");
    write_text(big, text);
    free(text);
    FAIL("bench config > 64 KiB", 2, "bogus_key", "unknown", "bench", sphere, "-o", out_path("B"), "--config", big);
}

/* Outputs that are not plain files: a link is written through (its file replaced, the link
 * kept), a FIFO given to --stats is written in place (a reader gets the JSON), an image onto a
 * FIFO is refused, and a directory where an output goes is refused before any work. (The temp-
 * and-rename replaced each of them with a regular file, /dev/null and /dev/stdout as root.) */
static void special_outputs(void)
{
    ++case_count;
    const char *target = out_path("target.json"), *link = out_path("link.json");
    write_text(target, "old\n");
    CHECK(symlink("target.json", link) == 0);
    const char *const through_link[] = {"render", sphere, "-o", out_path("a.png"), "--size", "16x16", "--stats", link,
                                        "-q", NULL};
    CHECK_MSG(run_leap(through_link) == 0, "--stats through a link: %s", res.err);
    struct stat st;
    char text[4096];
    read_text(target, text, sizeof text);
    CHECK_MSG(lstat(link, &st) == 0 && S_ISLNK(st.st_mode) && strstr(text, "\"input\""),
              "--stats through a link: the link %s, its file holds %.40s", S_ISLNK(st.st_mode) ? "kept" : "replaced",
              text);
    clean_dir(out_dir);

    ++case_count;
    const char *fifo = out_path("stats.json"), *got = out_path("got.json");
    CHECK(mkfifo(fifo, 0644) == 0);
    fflush(NULL);
    pid_t reader = fork();
    if (reader == 0) { /* system calls only: a forked child of a threaded process must not allocate */
        int in = open(fifo, O_RDONLY), out = open(got, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        char buf[4096];
        ssize_t n;
        while (in >= 0 && out >= 0 && (n = read(in, buf, sizeof buf)) > 0)
            if (write(out, buf, (size_t)n) != n) break;
        _exit(0);
    }
    const char *const into_fifo[] = {"render", sphere, "-o", out_path("a.png"), "--size", "16x16", "--stats", fifo,
                                     "-q", NULL};
    CHECK_MSG(run_leap(into_fifo) == 0, "--stats into a FIFO: %s", res.err);
    waitpid(reader, NULL, 0);
    read_text(got, text, sizeof text);
    CHECK_MSG(lstat(fifo, &st) == 0 && S_ISFIFO(st.st_mode) && strstr(text, "\"input\""),
              "--stats into a FIFO: the FIFO %s, its reader got %.40s", S_ISFIFO(st.st_mode) ? "kept" : "replaced",
              text);
    clean_dir(out_dir);

    const char *image_fifo = in_path("image.png"), *dir = in_path("dir.png"), *vdb_dir = in_path("dir.vdb");
    CHECK(mkfifo(image_fifo, 0644) == 0);
    mkdir(dir, 0755);
    mkdir(vdb_dir, 0755);
    FAIL("render -o FIFO", 1, "image.png", "not a regular file", "render", sphere, "-o", image_fifo);
    FAIL("render -o directory", 1, "dir.png", "is a directory", "render", sphere, "-o", dir);
    FAIL("convert -o directory", 1, "dir.vdb", "is a directory", "convert", sphere, "-o", vdb_dir);
    CHECK(lstat(image_fifo, &st) == 0 && S_ISFIFO(st.st_mode));

    /* A dump folder with a directory where one of its files goes: the run fails before any
     * work and the previous dump stays whole (its renamed files replaced the old, then were
     * removed as this run's). */
    ++case_count;
    const char *dump = out_path("dump"), *dump_args[] = {"segments", NULL, "--size", "16x16", "-o", NULL, "-q", NULL};
    char summary[1100], ply[1100], before[8192], after[8192];
    snprintf(summary, sizeof summary, "%s/summary.json", dump);
    snprintf(ply, sizeof ply, "%s/boxes.ply", dump);
    dump_args[1] = sphere;
    dump_args[5] = dump;
    CHECK_MSG(run_leap(dump_args) == 0, "segments -o: %s", res.err);
    read_text(summary, before, sizeof before);
    CHECK(remove(ply) == 0 && mkdir(ply, 0755) == 0);
    CHECK_MSG(run_leap(dump_args) == 1 && strstr(res.err, "boxes.ply"), "segments -o over a directory: %d %s", res.code,
              res.err);
    read_text(summary, after, sizeof after);
    int files = 0;
    DIR *dd = opendir(dump);
    for (struct dirent *e; dd && (e = readdir(dd));) files += e->d_name[0] != '.';
    if (dd) closedir(dd);
    CHECK_MSG(before[0] && strcmp(before, after) == 0 && files == 11, "the previous dump: %d entries, summary %s", files,
              strcmp(before, after) ? "changed" : "kept");
    clean_dir(out_dir);
}

static int count_temporaries(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return 0;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) n += strstr(e->d_name, "tmp") != NULL;
    closedir(d);
    return n;
}

/* Starts `leap render` of a 1024x1024 EXR (a 25 MB write), stops it as soon as its temporary
 * file appears, sends `sig` and lets it go on: it must exit 128 + sig and leave nothing. */
static int signal_during_write(int sig)
{
    const char *exr = out_path("sig.exr");
    pid_t pid = fork();
    if (pid == 0) {
        int z = open("/dev/null", O_RDWR);
        dup2(z, 0);
        dup2(z, 1);
        dup2(z, 2);
        execl(LEAP_EXE, LEAP_EXE, "render", sphere, "-o", exr, "--size", "1024x1024", "--mode", "naive", "-q",
              (char *)NULL);
        _exit(127);
    }
    int caught = 0, status = 0;
    struct timespec nap = {0, 200000}, start, now;
    clock_gettime(CLOCK_MONOTONIC, &start);
    for (;;) {
        if (count_temporaries(out_dir) > 0) {
            kill(pid, SIGSTOP);
            caught = 1;
            break;
        }
        if (waitpid(pid, &status, WNOHANG) == pid) break;
        clock_gettime(CLOCK_MONOTONIC, &now);
        if (now.tv_sec - start.tv_sec > 120) break;
        nanosleep(&nap, NULL);
    }
    if (caught) {
        kill(pid, sig);
        kill(pid, SIGCONT);
        waitpid(pid, &status, 0);
        CHECK_MSG(WIFEXITED(status) && WEXITSTATUS(status) == 128 + sig, "signal %d during the write: status %#x", sig,
                  status);
        CHECK_MSG(count_temporaries(out_dir) == 0, "signal %d left a temporary file", sig);
        /* The image writer is a process of its own: it may publish the whole image before the
         * signal reaches it (the test stops only leap). Absent or whole, never partial. */
        int w = 0, h = 0, c = 0;
        float *px = NULL;
        leap_error err;
        const int whole = access(exr, F_OK) == 0 && leap_image_read(exr, &w, &h, &c, &px, &err) == LEAP_OK &&
                          w == 1024 && h == 1024;
        free(px);
        CHECK_MSG(access(exr, F_OK) != 0 || whole, "signal %d: a partial output exists", sig);
    } else if (waitpid(pid, &status, WNOHANG) == 0) {
        kill(pid, SIGKILL);
        waitpid(pid, &status, 0);
    }
    clean_dir(out_dir);
    return caught;
}

/* Runs argv (argv[0] the program) under a file-size limit of `bytes` (leap ignores SIGXFSZ, so
 * a write past it fails); its stderr into text; returns the wait status. */
static int run_fsize_limited(rlim_t bytes, const char *const *argv, char *text, size_t cap)
{
    char err_path[1100];
    snprintf(err_path, sizeof err_path, "%s/stderr.txt", tmp_dir);
    pid_t pid = fork();
    if (pid == 0) {
        struct rlimit rl = {bytes, bytes};
        setrlimit(RLIMIT_FSIZE, &rl);
        int e = open(err_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        dup2(e, 2);
        execv(argv[0], (char *const *)argv);
        _exit(127);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    read_text(err_path, text, cap);
    return status;
}

/* 9. Signals and the file-size limit. */
static void signals_and_limits(void)
{
    const int sigs[] = {SIGINT, SIGTERM, SIGHUP};
    for (int i = 0; i < 3; ++i) {
        ++case_count;
        int caught = 0;
        for (int attempt = 0; attempt < 5 && !caught; ++attempt) caught = signal_during_write(sigs[i]);
        CHECK_MSG(caught, "signal %d: never caught leap while its temporary file existed", sigs[i]);
        printf("[signal %d during the write] %s\n", sigs[i], caught ? "exit 128+n, nothing left" : "not caught");
    }
    /* RLIMIT_FSIZE: SIGXFSZ is ignored, so the write fails with the user's file named. */
    const char *names[] = {"big.exr", "big.png", "big.tif"};
    for (int i = 0; i < 3; ++i) {
        ++case_count;
        char text[4096];
        const int status = run_fsize_limited(2048, ARGV(LEAP_EXE, "render", sphere, "-o", out_path(names[i]), "--size",
                                                        "256x256", "-q"), text, sizeof text);
        CHECK_MSG(WIFEXITED(status) && WEXITSTATUS(status) == 1, "[file-size limit %s] status %#x: %s", names[i],
                  status, text);
        CHECK_MSG(strstr(text, names[i]) && !strstr(text, "leap-tmp"), "[file-size limit %s] message: %s", names[i],
                  text);
        char left[2048];
        CHECK_MSG(unexpected_entries(out_dir, NULL, left, sizeof left) == 0, "[file-size limit %s] left behind: %s",
                  names[i], left);
        printf("[file-size limit %s] %s", names[i], text);
        clean_dir(out_dir);
    }
    /* leap convert under the limit: OpenVDB's writer does not check its stream, so the file
     * was cut short and reported as written, replacing a good one. The good one stays. */
    ++case_count;
    const char *good = out_path("good.vdb");
    write_text(good, "a good file\n");
    char text[4096], kept[64];
    const int status = run_fsize_limited(4096, ARGV(LEAP_EXE, "convert", sphere, "-o", good, "-q"), text, sizeof text);
    read_text(good, kept, sizeof kept);
    CHECK_MSG(WIFEXITED(status) && WEXITSTATUS(status) == 1 && strstr(text, "good.vdb: cannot write: File too large"),
              "[file-size limit, convert] status %#x: %s", status, text);
    CHECK_MSG(strcmp(kept, "a good file\n") == 0, "[file-size limit, convert] the good file was replaced");
    const char *allowed[] = {"good.vdb", NULL};
    char left[2048];
    CHECK_MSG(unexpected_entries(out_dir, allowed, left, sizeof left) == 0, "[file-size limit, convert] left behind: %s",
              left);
    printf("[file-size limit good.vdb] %s", text);
    clean_dir(out_dir);
}

/* 10. A small address-space limit is refused before the CPU Vulkan driver is created (it
 * corrupted its heap instead of failing). An AddressSanitizer build cannot run under such a
 * limit at all (its shadow memory), so the case is for the plain build only. */
static void address_space_limit(void)
{
#ifdef LEAP_SANITIZED
    printf("[address-space limit] skipped: AddressSanitizer build\n");
#else
    ++case_count;
    char err_path[1100], text[4096];
    snprintf(err_path, sizeof err_path, "%s/stderr.txt", tmp_dir);
    pid_t pid = fork();
    if (pid == 0) {
        struct rlimit rl = {(rlim_t)750000 << 10, (rlim_t)750000 << 10};
        setrlimit(RLIMIT_AS, &rl);
        int e = open(err_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        dup2(e, 2);
        execl(LEAP_EXE, LEAP_EXE, "render", sphere, "-o", out_path("as.png"), "--size", "16x16", (char *)NULL);
        _exit(127);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    read_text(err_path, text, sizeof text);
    CHECK_MSG(WIFEXITED(status) && WEXITSTATUS(status) == 1 && strstr(text, "address-space limit"),
              "[address-space limit] status %#x: %s", status, text);
    CHECK(access(out_path("as.png"), F_OK) != 0);
    printf("[address-space limit] %s", text);
    clean_dir(out_dir);
#endif
}

/* Mean alpha of an EXR render (or -1). */
static double mean_alpha(const char *exr)
{
    int w = 0, h = 0, c = 0;
    float *px = NULL;
    leap_error err = {{0}};
    if (leap_image_read(exr, &w, &h, &c, &px, &err) != LEAP_OK || c < 4) return -1;
    double sum = 0;
    for (int i = 0; i < w * h; ++i) sum += px[(size_t)c * i + 3];
    free(px);
    return sum / (w * h);
}

/* 8. A grid of one value renders by default, the same as the reference. */
static void constant_grids(void)
{
    const double values[] = {0.7, 5.0, -3.0, 1e20};
    const leap_vdb_type types[] = {LEAP_VDB_FLOAT, LEAP_VDB_INT32, LEAP_VDB_FLOAT, LEAP_VDB_FLOAT};
    for (int i = 0; i < 4; ++i) {
        ++case_count;
        leap_vdb_writer *w = new_writer();
        leap_error err = {{0}};
        int g = leap_vdb_writer_add_grid(w, "constant", types[i], 0, NULL, 1, &err);
        const int32_t lo[3] = {0, 0, 0}, hi[3] = {15, 15, 15};
        leap_vdb_writer_fill(w, g, lo, hi, values[i], 1);
        char name[64];
        snprintf(name, sizeof name, "constant%d.vdb", i);
        save(w, in_path(name));
        double alpha[2];
        const char *modes[2] = {"naive", "reference"};
        for (int m = 0; m < 2; ++m) {
            run_leap(ARGV("render", in_path(name), "-o", out_path("c.exr"), "--size", "32x32", "--mode", modes[m], "-q"));
            CHECK_MSG(res.code == 0, "[constant %g %s] exit %d: %s", values[i], modes[m], res.code, res.err);
            alpha[m] = mean_alpha(out_path("c.exr"));
        }
        CHECK_MSG(alpha[0] > 0.05, "[constant %g] mean alpha %g: the constant does not render", values[i], alpha[0]);
        CHECK_MSG(fabs(alpha[0] - alpha[1]) < 1e-3, "[constant %g] mean alpha %g against the reference's %g",
                  values[i], alpha[0], alpha[1]);
        printf("[constant grid %g] mean alpha %.4f (reference %.4f)\n", values[i], alpha[0], alpha[1]);
        clean_dir(out_dir);
    }
    /* single_voxel.vdb-like: one voxel. */
    ++case_count;
    leap_vdb_writer *w = new_writer();
    leap_error err = {{0}};
    int g = leap_vdb_writer_add_grid(w, "one", LEAP_VDB_FLOAT, 0, NULL, 1, &err);
    leap_vdb_writer_set(w, g, 3, 4, 5, 2.5);
    save(w, in_path("one.vdb"));
    run_leap(ARGV("render", in_path("one.vdb"), "-o", out_path("c.exr"), "--size", "32x32", "--mode", "naive", "-q"));
    CHECK_MSG(res.code == 0 && mean_alpha(out_path("c.exr")) > 0, "[single voxel] exit %d, alpha %g: %s", res.code,
              mean_alpha(out_path("c.exr")), res.err);
    clean_dir(out_dir);
}

/* 11, 12, 14: transforms, extents and names from the file. */
static void file_contents(void)
{
    /* 12. Transforms OpenVDB refuses (a NaN translation: a singular map) and ones it reads
     * but no camera can work with (a translation 1e15 times the grid's size; world
     * coordinates that overflow): a runtime error (exit 1) naming the file, whatever the
     * camera options. */
    struct {
        const char *name, *problem;
        double scale, shift;
        int32_t at;
    } transforms[] = {{"nan.vdb", "", 1, NAN, 0}, {"far.vdb", "precision", 1, 1e15, 0},
                      {"huge.vdb", "transform", 1e300, 0, 1 << 30}};
    for (int i = 0; i < 3; ++i) {
        double s = transforms[i].scale;
        double m[4][4] = {{s, 0, 0, transforms[i].shift}, {0, s, 0, 0}, {0, 0, s, 0}, {0, 0, 0, 1}};
        leap_vdb_writer *w = new_writer();
        leap_error err = {{0}};
        int g = leap_vdb_writer_add_grid(w, "density", LEAP_VDB_FLOAT, 0, m, 1, &err);
        leap_vdb_writer_set(w, g, transforms[i].at, 0, 0, 1);
        save(w, in_path(transforms[i].name));
        char label[64];
        snprintf(label, sizeof label, "%s, orbit", transforms[i].name);
        FAIL(label, 1, transforms[i].name, transforms[i].problem, "render", in_path(transforms[i].name), "-o",
             out_path("t.png"));
        snprintf(label, sizeof label, "%s, explicit camera", transforms[i].name);
        FAIL(label, 1, transforms[i].name, transforms[i].problem, "render", in_path(transforms[i].name), "-o",
             out_path("t.png"), "--eye", "0,0,10", "--target", "0,0,0");
    }
    FAIL("--orbit distance 1e300", 2, "--orbit", "distance", "render", sphere, "-o", out_path("t.png"), "--orbit",
         "0,0,1e300");
    FAIL("--eye 1e300", 2, "--eye", "1e", "render", sphere, "-o", out_path("t.png"), "--eye", "1e300,0,0", "--target",
         "0,0,0");

    /* 11. Extents beyond 32 bits print as 64-bit numbers. */
    leap_vdb_writer *w = new_writer();
    leap_error err = {{0}};
    int g = leap_vdb_writer_add_grid(w, "wide", LEAP_VDB_FLOAT, 0, NULL, 1, &err);
    leap_vdb_writer_set(w, g, INT32_MAX - 100, 0, 0, 1);
    leap_vdb_writer_set(w, g, INT32_MIN + 100, 0, 0, 1);
    save(w, in_path("wide.vdb"));
    ++case_count;
    run_leap(ARGV("info", in_path("wide.vdb")));
    CHECK_MSG(res.code == 0 && strstr(res.out, "(4294967096 x 1 x 1)"), "[info extents] exit %d: %s%s", res.code,
              res.out, res.err);

    /* 14. Control characters in a grid name are escaped on stdout as on stderr. */
    w = new_writer();
    g = leap_vdb_writer_add_grid(w, "evil\nname\r\x1b[31mred", LEAP_VDB_FLOAT, 0, NULL, 1, &err);
    leap_vdb_writer_set(w, g, 0, 0, 0, 1);
    save(w, in_path("evil.vdb"));
    ++case_count;
    run_leap(ARGV("info", in_path("evil.vdb")));
    CHECK_MSG(res.code == 0 && !strchr(res.out, '\r') && !strchr(res.out, '\x1b') && strstr(res.out, "evil?name?"),
              "[control characters] exit %d: %s", res.code, res.out);
    run_leap(ARGV("info", in_path("evil.vdb"), "--tf", "grey"));
    CHECK_MSG(res.code == 0 && !strchr(res.out, '\x1b'), "[control characters, --tf] exit %d", res.code);
}

/* 15. Only the formats the help lists are written. */
static void output_formats(void)
{
    const char *bad[] = {"x.jpg", "x.bmp", "x.hdr", "x.gif", "x"};
    for (int i = 0; i < 5; ++i) {
        char label[64];
        snprintf(label, sizeof label, "output %s", bad[i]);
        FAIL(label, 2, bad[i], "format", "render", sphere, "-o", out_path(bad[i]), "--size", "8x8");
    }
    const char *good[] = {"x.PNG", "x.Exr", "x.tiff"};
    for (int i = 0; i < 3; ++i) {
        ++case_count;
        run_leap(ARGV("render", sphere, "-o", out_path(good[i]), "--size", "8x8", "-q"));
        CHECK_MSG(res.code == 0 && access(out_path(good[i]), F_OK) == 0, "[output %s] exit %d: %s", good[i], res.code,
                  res.err);
        clean_dir(out_dir);
    }
}

int main(void)
{
    harness_init();
    outputs_never_replace_inputs();
    stack_slices_never_replaced();
    non_regular_files();
    special_outputs();
    signals_and_limits();
    address_space_limit();
    constant_grids();
    file_contents();
    output_formats();
    printf("%d cases\n", case_count);
    return check_exit_code();
}
