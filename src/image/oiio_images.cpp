// The image module: OpenImageIO behind the table of image_module.h (writing and reading single
// images here, slices in oiio_slices.cpp). No exception crosses the boundary.
#include "oiio_module.h"

#include <OpenImageIO/imageio.h>

#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <unistd.h>
#include <vector>

OIIO_NAMESPACE_USING

namespace {

std::string extension_of(const std::string &path)
{
    size_t slash = path.find_last_of('/');
    size_t dot = path.find_last_of('.');
    if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
    std::string ext = path.substr(dot);
    for (char &c : ext) c = (char)std::tolower((unsigned char)c);
    return ext;
}

// OpenImageIO's message names the temporary file and may be empty on a short write
// (disk full, file-size limit): errno says more then.
std::string io_reason(const std::string &oiio_message)
{
    std::string why = errno ? std::strerror(errno) : "";
    if (!oiio_message.empty() && oiio_message.find(".leap-tmp-") == std::string::npos)
        why = why.empty() ? oiio_message : why + " (" + oiio_message + ")";
    return why.empty() ? "unknown error" : why;
}

} // namespace

// Arguments and extension were checked by the host (image.c: leap_image_write).
static leap_result write_image(const char *path, int width, int height, int channels, const char *const *names,
                        const float *pixels, leap_error *err)
{
    try {
        std::string target(path);
        std::string ext = extension_of(target);
        std::unique_ptr<ImageOutput> out = ImageOutput::create(ext.substr(1));
        if (!out)
            return host->fail(err, LEAP_ERR_UNSUPPORTED, "%s: this OpenImageIO has no writer for '%s'", path,
                              ext.c_str());
        TypeDesc format = TypeDesc::UINT8;
        if (ext == ".exr") format = TypeDesc::FLOAT;
        else if (ext == ".tif" || ext == ".tiff") format = TypeDesc::UINT16;
        ImageSpec spec(width, height, channels, format);
        spec.channelnames.clear();
        for (int c = 0; c < channels; ++c) {
            if (names && names[c]) spec.channelnames.emplace_back(names[c]);
            else spec.channelnames.emplace_back(std::string(1, "RGBA"[c < 4 ? c : 3]) + (c < 4 ? "" : std::to_string(c)));
        }
        spec.alpha_channel = -1;
        for (int c = 0; c < channels; ++c)
            if (spec.channelnames[c] == "A") spec.alpha_channel = c;
        if (spec.alpha_channel >= 0 && format != TypeDesc::FLOAT)
            spec.attribute("oiio:UnassociatedAlpha", 1); // we pass straight colour for 8/16-bit files
        // The temporary keeps the extension, so OpenImageIO still picks the right format.
        leap_publish pub;
        if (leap_result lr = host->publish_begin(&pub, path, err)) return lr;
        const std::string tmp(pub.tmp);
        // Messages name the user's path; the temporary name would mean nothing to them.
        auto fail = [&](const char *what, const std::string &why) {
            host->publish_abort(&pub);
            return host->fail(err, LEAP_ERR_IO, "%s: %s: %s", path, what, why.c_str());
        };
        errno = 0;
        if (!out->open(tmp, spec)) return fail("cannot write", io_reason(out->geterror()));
        bool ok = out->write_image(TypeDesc::FLOAT, pixels);
        ok = out->close() && ok;
        if (!ok) return fail("write failed", io_reason(out->geterror()));
        // Some writers (PNG) do not report a short write (disk full, file-size limit): read
        // the file back before it replaces anything, so a truncated image is never published.
        errno = 0;
        auto check = ImageInput::open(tmp);
        std::vector<float> back;
        if (check) back.resize((size_t)width * height * channels);
        if (!check || !check->read_image(0, 0, 0, channels, TypeDesc::FLOAT, back.data()))
            return fail("write failed", std::string("the written file does not read back") +
                                            (errno ? std::string(": ") + std::strerror(errno) : std::string("")));
        check->close();
        return host->publish_commit(&pub, err);
    } catch (const std::exception &e) {
        return host->fail(err, LEAP_ERR_IO, "%s: %s", path, e.what());
    } catch (...) {
        return host->fail(err, LEAP_ERR_IO, "%s: unknown image library error", path);
    }
}

static leap_result read_image(const char *path, int *width, int *height, int *channels, float **pixels, leap_error *err)
{
    if (!path || !width || !height || !channels || !pixels)
        return host->fail(err, LEAP_ERR_USAGE, "image: invalid arguments");
    *pixels = nullptr;
    try {
        auto in = ImageInput::open(path);
        if (!in)
            return host->fail(err, LEAP_ERR_IO, "%s: cannot read image: %s", path, OIIO::geterror().c_str());
        const ImageSpec &spec = in->spec();
        size_t count = (size_t)spec.width * spec.height * spec.nchannels;
        if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 || count > (size_t)1 << 31)
            return host->fail(err, LEAP_ERR_FORMAT, "%s: unsupported image size", path);
        float *data = static_cast<float *>(std::malloc(count * sizeof(float)));
        if (!data) return host->fail(err, LEAP_ERR_OOM, "%s: out of memory", path);
        if (!in->read_image(0, 0, 0, spec.nchannels, TypeDesc::FLOAT, data)) {
            std::free(data);
            return host->fail(err, LEAP_ERR_FORMAT, "%s: %s", path, in->geterror().c_str());
        }
        *width = spec.width;
        *height = spec.height;
        *channels = spec.nchannels;
        *pixels = data;
        return LEAP_OK;
    } catch (const std::exception &e) {
        return host->fail(err, LEAP_ERR_FORMAT, "%s: %s", path, e.what());
    } catch (...) {
        return host->fail(err, LEAP_ERR_FORMAT, "%s: unknown image library error", path);
    }
}

const leap_image_host *host;

extern "C" __attribute__((visibility("default"))) const leap_image_module *leap_image_module_open(const leap_image_host *h)
{
    static const leap_image_module table = {write_image, read_image, read_slices};
    host = h;
    return &table;
}
