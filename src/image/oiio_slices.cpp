// Image slices through OpenImageIO: the pages of multi-page TIFFs and single-page images,
// in order, as the z slices of one volume. Values keep their stored scale (an 8- or 16-bit
// integer reads as that integer, never normalised). No exception crosses this file.
#include "oiio_module.h"

#include <OpenImageIO/imageio.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

namespace {

// Slice pixels of OIIO type `t` (one channel) into `values` or `ids`.
bool convert(OIIO::TypeDesc t, const std::vector<unsigned char> &buf, size_t count, float *values, int64_t *ids)
{
    for (size_t i = 0; i < count; ++i) {
        const unsigned char *p = buf.data() + i * t.size();
        double v;
        int64_t id = 0;
        bool integer = true;
        switch (t.basetype) {
        case OIIO::TypeDesc::UINT8: id = *p; break;
        case OIIO::TypeDesc::INT8: id = int8_t(*p); break;
        case OIIO::TypeDesc::UINT16: { uint16_t x; std::memcpy(&x, p, 2); id = x; break; }
        case OIIO::TypeDesc::INT16: { int16_t x; std::memcpy(&x, p, 2); id = x; break; }
        case OIIO::TypeDesc::UINT32: { uint32_t x; std::memcpy(&x, p, 4); id = x; break; }
        case OIIO::TypeDesc::INT32: { int32_t x; std::memcpy(&x, p, 4); id = x; break; }
        case OIIO::TypeDesc::FLOAT: { float x; std::memcpy(&x, p, 4); v = x; integer = false; break; }
        case OIIO::TypeDesc::DOUBLE: { std::memcpy(&v, p, 8); integer = false; break; }
        default: return false;
        }
        if (integer) v = double(id);
        if (ids) ids[i] = id;
        else values[i] = float(v);
    }
    return true;
}

bool supported(OIIO::TypeDesc t, bool *integer)
{
    switch (t.basetype) {
    case OIIO::TypeDesc::UINT8: case OIIO::TypeDesc::INT8: case OIIO::TypeDesc::UINT16: case OIIO::TypeDesc::INT16:
    case OIIO::TypeDesc::UINT32: case OIIO::TypeDesc::INT32:
        *integer = true;
        return true;
    case OIIO::TypeDesc::FLOAT: case OIIO::TypeDesc::DOUBLE:
        *integer = false;
        return true;
    default:
        return false;
    }
}

} // namespace

leap_result read_slices(const leap_image_slices_request *request, leap_image_slices *out, leap_error *err)
{
    const char *what = request->what;
    const char *const *files = request->files;
    const size_t file_count = request->file_count;
    int32_t *dim = out->dim;
    try {
        struct Page {
            size_t file;
            int subimage;
        };
        std::vector<Page> pages;
        OIIO::TypeDesc type;
        bool integer = false;
        int width = 0, height = 0;
        // Pass 1: every page's size, channels and type, before anything large is allocated.
        for (size_t f = 0; f < file_count; ++f) {
            auto in = OIIO::ImageInput::open(files[f]);
            if (!in) {
                std::string e = OIIO::geterror();
                return host->fail(err, LEAP_ERR_FORMAT, "'%s': not a readable image (%s)", files[f],
                                 e.empty() ? "unknown format" : e.c_str());
            }
            for (int s = 0; in->seek_subimage(s, 0); ++s) {
                const OIIO::ImageSpec &spec = in->spec();
                if (spec.depth > 1)
                    return host->fail(err, LEAP_ERR_UNSUPPORTED, "'%s', page %d: a 3-D image; leap reads 2-D slices",
                                     files[f], s);
                if (spec.nchannels != 1)
                    return host->fail(err, LEAP_ERR_UNSUPPORTED,
                                     "'%s', page %d: %d channels; leap reads single-channel (grey) slices", files[f],
                                     s, spec.nchannels);
                bool page_integer;
                if (!supported(spec.format, &page_integer))
                    return host->fail(err, LEAP_ERR_UNSUPPORTED, "'%s', page %d: pixels of type %s cannot be read",
                                     files[f], s, spec.format.c_str());
                if (pages.empty()) {
                    width = spec.width;
                    height = spec.height;
                    type = spec.format;
                    integer = page_integer;
                } else if (spec.width != width || spec.height != height) {
                    return host->fail(err, LEAP_ERR_FORMAT, "'%s', page %d: %d x %d pixels, but the first slice has %d x %d",
                                     files[f], s, spec.width, spec.height, width, height);
                } else if (spec.format != type) {
                    return host->fail(err, LEAP_ERR_FORMAT, "'%s', page %d: pixels of type %s, but the first slice has %s",
                                     files[f], s, spec.format.c_str(), type.c_str());
                }
                pages.push_back(Page{f, s});
            }
            // The pages end where the next one cannot be read. Past the last page OIIO 2.4 gives
            // the file's name as the error; anything else is libtiff's (a page the chain names
            // is missing: a truncated or corrupt file, whose later pages would be lost unsaid).
            std::string e = in->geterror();
            if (!e.empty() && e != files[f])
                return host->fail(err, LEAP_ERR_FORMAT, "'%s': the page after page %zu cannot be read (truncated or "
                                 "corrupt?): %s", files[f], pages.empty() || pages.back().file != f ? size_t(0) :
                                 size_t(pages.back().subimage), e.c_str());
        }
        if (pages.empty()) return host->fail(err, LEAP_ERR_FORMAT, "%s: no image slices", what);
        if (pages.size() > size_t(INT32_MAX / 2) || width > INT32_MAX / 2 || height > INT32_MAX / 2)
            return host->fail(err, LEAP_ERR_FORMAT, "%s: too many slices or pixels", what);
        dim[0] = width;
        dim[1] = height;
        dim[2] = int32_t(pages.size());
        const size_t slice = size_t(width) * size_t(height);
        const bool as_labels = request->labels && integer;
        leap_result r = request->check_memory(what, dim, double(slice) * pages.size() * (as_labels ? 8.0 : 4.0), err);
        if (r) return r;
        // malloc: the caller frees them.
        std::unique_ptr<float, decltype(&std::free)> v(
            as_labels ? nullptr : static_cast<float *>(std::malloc(slice * pages.size() * sizeof(float))), &std::free);
        std::unique_ptr<int64_t, decltype(&std::free)> l(
            as_labels ? static_cast<int64_t *>(std::malloc(slice * pages.size() * sizeof(int64_t))) : nullptr,
            &std::free);
        if (!v && !l) throw std::bad_alloc();
        std::vector<unsigned char> buf(slice * type.size());
        // Pass 2: the pixels; image row 0 is the top, which becomes y = height - 1 (y up).
        std::unique_ptr<OIIO::ImageInput> in;
        size_t open_file = SIZE_MAX;
        for (size_t z = 0; z < pages.size(); ++z) {
            if (pages[z].file != open_file) {
                in = OIIO::ImageInput::open(files[pages[z].file]);
                open_file = pages[z].file;
                if (!in) return host->fail(err, LEAP_ERR_IO, "'%s': cannot be read again", files[open_file]);
            }
            // A short strip reads "successfully", with an error left behind (OIIO 2.4).
            const bool read = in->read_image(pages[z].subimage, 0, 0, 1, type, buf.data());
            std::string e = in->geterror();
            e = e.substr(0, e.find('\n')); // the first of libtiff's lines, one per strip
            if (!read || !e.empty())
                return host->fail(err, LEAP_ERR_FORMAT, "'%s', page %d: pixels cannot be read (truncated or corrupt): %s",
                                 files[open_file], pages[z].subimage, e.empty() ? "no reason given" : e.c_str());
            std::vector<unsigned char> flipped(buf.size());
            const size_t row = size_t(width) * type.size();
            for (int y = 0; y < height; ++y)
                std::memcpy(flipped.data() + size_t(height - 1 - y) * row, buf.data() + size_t(y) * row, row);
            convert(type, flipped, slice, v ? v.get() + z * slice : nullptr, l ? l.get() + z * slice : nullptr);
        }
        std::snprintf(out->description, sizeof out->description, "%s, %d x %d x %d slices from %zu file%s%s", type.c_str(), width,
                      height, dim[2], file_count, file_count == 1 ? "" : "s", as_labels ? ", labels" : "");
        out->values = v.release();
        out->ids = l.release();
        return LEAP_OK;
    } catch (const std::bad_alloc &) {
        return host->fail(err, LEAP_ERR_OOM, "%s: out of memory for the slices", what);
    } catch (const std::exception &e) {
        return host->fail(err, LEAP_ERR_FORMAT, "%s: %s", what, e.what());
    }
}
