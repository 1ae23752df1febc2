/* gltf_loader.cpp: glTF 2.0 -> rd_scene through tinygltf (the project's only C++ file).
 *
 * Untrusted input passes three gates:
 *   1. our own checks of the GLB container and a pre-scan of the JSON (nesting depth, asset
 *      version, extensionsRequired, buffers, buffer views and image buffer views), because
 *      tinygltf 2.7 trusts some of those values (image buffer views, the BIN chunk length);
 *   2. tinygltf parses the JSON and loads buffers through file callbacks that only open
 *      regular files below the base folder; images are decoded by our callback (PNG/JPEG via
 *      stb_image, always to 8-bit RGBA, with size limits);
 *   3. conversion validates every index, accessor range and value before reading a byte.
 * Errors unwind as a C++ exception (LoadError) caught at the C boundary with everything else.
 */
#include "gltf_loader.h"

#include <algorithm>
#include <cerrno>
#include <cfloat>
#include <climits>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream> /* tiny_gltf.h 2.7 needs it even with TINYGLTF_NO_FS */
#include <initializer_list>
#include <map>
#include <new>
#include <string>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wtype-limits"
#pragma GCC diagnostic ignored "-Wunused-but-set-variable"
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE       /* our callback decodes (gltf_image.c) */
#define TINYGLTF_NO_STB_IMAGE_WRITE /* we never write glTF */
#define TINYGLTF_NO_EXTERNAL_IMAGE  /* external images are read by us, under our rules */
#define TINYGLTF_NO_FS              /* no default host file access: only our callbacks */
#include <tiny_gltf.h>
#pragma GCC diagnostic pop

extern "C" {
#include "xform.h"
}
#include "gltf_import.h"

namespace
{

using njson = nlohmann::json;
using tinygltf::Model;

const uint64_t kDefaultMaxTriangles = 50000000ull;
const uint64_t kMaxExternalFile = 0xffffffffull; /* tinygltf sizes are 32-bit */
const uint64_t kMaxAnimationFloats = 1ull << 26; /* 256 MiB of animation keys and values */
const char *const kSupportedExtensions[] = {"KHR_lights_punctual",
                                            "KHR_materials_emissive_strength"};

struct LoadError {
    rd_gltf_result code;
    std::string msg;
};

std::string vfmt(const char *fmt, va_list ap)
{
    va_list ap2;
    va_copy(ap2, ap);
    int n = vsnprintf(nullptr, 0, fmt, ap2);
    va_end(ap2);
    std::string s(n > 0 ? (size_t)n : 0, '\0');
    if (n > 0) vsnprintf(&s[0], (size_t)n + 1, fmt, ap);
    return s;
}

std::string fmt(const char *f, ...) __attribute__((format(printf, 1, 2)));
std::string fmt(const char *f, ...)
{
    va_list ap;
    va_start(ap, f);
    std::string s = vfmt(f, ap);
    va_end(ap);
    return s;
}

[[noreturn]] void fail(rd_gltf_result code, const char *f, ...)
    __attribute__((format(printf, 2, 3)));
[[noreturn]] void fail(rd_gltf_result code, const char *f, ...)
{
    va_list ap;
    va_start(ap, f);
    LoadError e{code, vfmt(f, ap)};
    va_end(ap);
    throw e;
}

/* A file's string made safe for a message (rd_gltf_clean). */
std::string clean(const std::string &s, size_t max = 64)
{
    char buf[128];
    rd_gltf_clean(s.data(), s.size(), max, buf);
    return buf;
}

/* "mesh 3" or "mesh 3 'Cube'". */
std::string label(const char *kind, size_t index, const std::string &name)
{
    if (name.empty()) return fmt("%s %zu", kind, index);
    return fmt("%s %zu '%s'", kind, index, clean(name).c_str());
}

/* ---- files (rules in gltf_uri.c) -------------------------------------------------------- */

/* rd_gltf_read_file's allocator for a std::vector (out of memory is rethrown as bad_alloc). */
struct VectorSink {
    std::vector<unsigned char> *v;
    bool no_memory;
};

unsigned char *vector_alloc(void *user, size_t size)
{
    VectorSink *s = static_cast<VectorSink *>(user);
    try {
        s->v->resize(size);
    } catch (const std::bad_alloc &) {
        s->no_memory = true;
        return nullptr;
    }
    return s->v->data();
}

rd_gltf_read_status read_file(const char *path, uint64_t max_size, std::vector<unsigned char> *out,
                              std::string *why)
{
    VectorSink sink{out, false};
    char buf[256] = "";
    rd_gltf_read_status st =
        rd_gltf_read_file(path, max_size, vector_alloc, &sink, buf, sizeof buf);
    if (st == RD_GLTF_READ_NO_MEMORY) throw std::bad_alloc();
    *why = buf;
    return st;
}

bool fs_file_exists(const std::string &path, void *user)
{
    return rd_gltf_files_exists(static_cast<rd_gltf_files *>(user), path.c_str(), path.size());
}

std::string fs_expand(const std::string &path, void *)
{
    return path; /* no ~ or $VAR expansion */
}

bool fs_read(std::vector<unsigned char> *out, std::string *err, const std::string &path, void *user)
{
    rd_gltf_files *files = static_cast<rd_gltf_files *>(user);
    size_t rel;
    if (!rd_gltf_files_check_path(files, path.c_str(), path.size(), &rel)) {
        *err = files->last_refusal;
        return false;
    }
    std::string why;
    if (read_file(path.c_str(), kMaxExternalFile, out, &why) != RD_GLTF_READ_OK) {
        *err = why;
        snprintf(files->last_refusal, sizeof files->last_refusal, "%s", why.c_str());
        return false;
    }
    return true;
}

bool fs_write(std::string *err, const std::string &, const std::vector<unsigned char> &, void *)
{
    *err = "writing is disabled";
    return false;
}

/* ---- images (decoded in gltf_image.c) --------------------------------------------------- */

struct ImageFailure {
    rd_gltf_result code;
    std::string why;
};

struct LoadContext {
    rd_gltf_files files;
    std::map<int, ImageFailure> image_failures; /* decode failures, by image index */
    uint64_t decoded_bytes = 0;
    explicit LoadContext(const char *base_dir)
    {
        rd_gltf_files_init(&files, base_dir);
    }
    ~LoadContext()
    {
        rd_gltf_files_dispose(&files);
    }
    LoadContext(const LoadContext &) = delete;
    LoadContext &operator=(const LoadContext &) = delete;
};

/* PNG or JPEG -> 8-bit RGBA into *rgba (rd_gltf_decode_image). */
bool decode_image(LoadContext *ctx, const unsigned char *bytes, size_t size,
                  std::vector<unsigned char> *rgba, int *w, int *h, ImageFailure *f)
{
    char why[256];
    unsigned char *px =
        rd_gltf_decode_image(&ctx->decoded_bytes, bytes, size, w, h, &f->code, why, sizeof why);
    if (!px) {
        f->why = why;
        return false;
    }
    try {
        rgba->assign(px, px + (size_t)*w * (size_t)*h * 4);
    } catch (...) {
        free(px);
        throw;
    }
    free(px);
    return true;
}

/* tinygltf image callback (data URIs and buffer views; ranges were checked in prescan).
 * Never fails the whole load: a broken image is an error only if a material uses it. */
bool image_callback(tinygltf::Image *image, const int index, std::string *, std::string *, int, int,
                    const unsigned char *bytes, int size, void *user)
{
    LoadContext *ctx = static_cast<LoadContext *>(user);
    ImageFailure f{RD_GLTF_ERR_INVALID, ""};
    int w = 0, h = 0;
    image->image.clear();
    if (size < 0 ||
        !decode_image(ctx, bytes, (size_t)(size < 0 ? 0 : size), &image->image, &w, &h, &f)) {
        ctx->image_failures[index] = f;
        return true;
    }
    image->width = w;
    image->height = h;
    image->component = 4;
    image->bits = 8;
    image->pixel_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
    return true;
}

/* ---- container and JSON pre-scan ---------------------------------------------------- */

/* Throws the C side's failure (gltf_import.h) as the loader's. */
void check(rd_gltf_result r, const char *err)
{
    if (r != RD_GLTF_OK) throw LoadError{r, err};
}

bool json_uint(const njson &o, const char *key, uint64_t *out, bool required)
{
    auto it = o.find(key);
    if (it == o.end()) return !required;
    if (!it->is_number_unsigned()) return false;
    *out = it->get<uint64_t>();
    return true;
}

/* Index-valued member that must lie in [0, count). */
bool json_index(const njson &o, const char *key, size_t count, size_t *out)
{
    auto it = o.find(key);
    if (it == o.end() || !it->is_number_unsigned()) return false;
    uint64_t v = it->get<uint64_t>();
    if (v >= count) return false;
    *out = (size_t)v;
    return true;
}

/* Bytes a tinygltf data URI decodes to (its base64 decoder stops at '=' or a foreign
 * character), or -1 when tinygltf does not recognise the URI as data. */
long long data_uri_size(const std::string &uri)
{
    if (!tinygltf::IsDataURI(uri)) return -1;
    size_t comma = uri.find(',');
    size_t n = 0;
    for (size_t i = comma + 1; i < uri.size(); i++) {
        unsigned char ch = (unsigned char)uri[i];
        if (ch == '=' || !(isalnum(ch) || ch == '+' || ch == '/')) break;
        n++;
    }
    return (long long)(n / 4 * 3 + (n % 4 ? n % 4 - 1 : 0));
}

bool is_supported_extension(const std::string &name)
{
    for (const char *s : kSupportedExtensions)
        if (name == s) return true;
    return false;
}

/* Checks what tinygltf would use unchecked, with messages that name the culprit. */
void prescan(const rd_gltf_container &c, LoadContext *ctx)
{
    char err[256];
    check(rd_gltf_check_json_depth(c.json, c.json_size, err, sizeof err), err);
    njson::parser_callback_t keep = [](int depth, njson::parse_event_t ev, njson &v) {
        if (depth != 1 || ev != njson::parse_event_t::key || !v.is_string()) return true;
        const std::string &k = v.get_ref<const std::string &>();
        return k == "asset" || k == "buffers" || k == "bufferViews" || k == "images" ||
               k == "extensionsRequired";
    };
    njson doc;
    try {
        doc = njson::parse(c.json, c.json + c.json_size, keep, true, false);
    } catch (const njson::exception &e) {
        std::string what = e.what();
        size_t close = what.find("] ");
        if (what.compare(0, 1, "[") == 0 && close != std::string::npos)
            what = what.substr(close + 2);
        fail(RD_GLTF_ERR_PARSE, "the glTF JSON could not be parsed: %s", what.c_str());
    }
    if (!doc.is_object()) fail(RD_GLTF_ERR_PARSE, "the glTF JSON is not an object");

    auto asset = doc.find("asset");
    if (asset == doc.end() || !asset->is_object() || !asset->contains("version") ||
        !(*asset)["version"].is_string())
        fail(RD_GLTF_ERR_INVALID, "the file has no asset.version, so it is not a glTF file");
    const std::string &version = (*asset)["version"].get_ref<const std::string &>();
    if (version.compare(0, 2, "2.") != 0)
        fail(RD_GLTF_ERR_UNSUPPORTED, "glTF version '%.16s' is not supported (only 2.x)",
             version.c_str());

    auto req = doc.find("extensionsRequired");
    if (req != doc.end()) {
        if (!req->is_array()) fail(RD_GLTF_ERR_INVALID, "extensionsRequired is not an array");
        for (const njson &e : *req) {
            if (!e.is_string())
                fail(RD_GLTF_ERR_INVALID, "extensionsRequired holds a value that is not a name");
            const std::string &name = e.get_ref<const std::string &>();
            if (!is_supported_extension(name))
                fail(RD_GLTF_ERR_UNSUPPORTED,
                     "the file requires extension %.80s, which is not supported", name.c_str());
        }
    }

    static const njson empty = njson::array();
    auto member = [&](const char *key) -> const njson & {
        auto it = doc.find(key);
        if (it == doc.end()) return empty;
        if (!it->is_array()) fail(RD_GLTF_ERR_INVALID, "%s is not an array", key);
        return *it;
    };
    const njson &buffers = member("buffers");
    const njson &views = member("bufferViews");
    const njson &images = member("images");

    std::vector<uint64_t> buffer_len;
    for (size_t i = 0; i < buffers.size(); i++) {
        const njson &b = buffers[i];
        uint64_t len = 0;
        if (!b.is_object() || !json_uint(b, "byteLength", &len, true) || len == 0)
            fail(RD_GLTF_ERR_INVALID, "buffer %zu has no valid byteLength", i);
        buffer_len.push_back(len);
        auto uri_it = b.find("uri");
        if (uri_it == b.end() || !uri_it->is_string()) {
            if (!c.glb) fail(RD_GLTF_ERR_INVALID, "buffer %zu has no uri", i);
            if (c.bin_size == 0)
                fail(RD_GLTF_ERR_INVALID, "buffer %zu has no uri and the GLB file has no BIN chunk",
                     i);
            if (len > c.bin_size)
                fail(RD_GLTF_ERR_INVALID,
                     "buffer %zu needs %llu bytes but the GLB BIN chunk holds only %zu", i,
                     (unsigned long long)len, c.bin_size);
            continue;
        }
        const std::string &uri = uri_it->get_ref<const std::string &>();
        long long n = data_uri_size(uri);
        if (n >= 0) {
            if ((uint64_t)n != len)
                fail(RD_GLTF_ERR_INVALID,
                     "buffer %zu: its data URI holds %lld bytes but byteLength is %llu", i, n,
                     (unsigned long long)len);
            continue;
        }
        std::string shown = uri.size() > 64 ? uri.substr(0, 61) + "..." : uri;
        if (uri.compare(0, 5, "data:") == 0)
            fail(RD_GLTF_ERR_UNSUPPORTED,
                 "buffer %zu has a data URI that is not base64 of a known media type", i);
        std::string rel = tinygltf::dlib::urldecode(uri);
        const char *refusal = rd_gltf_uri_refusal(&ctx->files, rel.c_str(), rel.size());
        std::string why = refusal ? refusal : "";
        struct stat st;
        char ebuf[256];
        if (why.empty() && stat((ctx->files.prefix + rel).c_str(), &st) != 0)
            why = (rd_gltf_errno_text(errno, ebuf, sizeof ebuf), ebuf);
        else if (why.empty() && !S_ISREG(st.st_mode))
            why = "it is not a regular file";
        if (!why.empty())
            fail(RD_GLTF_ERR_IO, "buffer %zu '%s' could not be loaded: %s", i, shown.c_str(),
                 why.c_str());
        if ((uint64_t)st.st_size != len)
            fail(RD_GLTF_ERR_INVALID, "buffer %zu '%s' has %lld bytes but byteLength is %llu", i,
                 shown.c_str(), (long long)st.st_size, (unsigned long long)len);
    }

    std::vector<uint64_t> view_len;
    for (size_t i = 0; i < views.size(); i++) {
        const njson &v = views[i];
        size_t b = 0;
        uint64_t off = 0, len = 0;
        if (!v.is_object() || !json_index(v, "buffer", buffers.size(), &b))
            fail(RD_GLTF_ERR_INVALID, "buffer view %zu does not refer to an existing buffer", i);
        if (!json_uint(v, "byteOffset", &off, false) || !json_uint(v, "byteLength", &len, true) ||
            len == 0)
            fail(RD_GLTF_ERR_INVALID, "buffer view %zu has an invalid byteOffset or byteLength", i);
        if (off > buffer_len[b] || len > buffer_len[b] - off)
            fail(RD_GLTF_ERR_INVALID,
                 "buffer view %zu (offset %llu, length %llu) does not fit in buffer %zu (%llu "
                 "bytes)",
                 i, (unsigned long long)off, (unsigned long long)len, b,
                 (unsigned long long)buffer_len[b]);
        view_len.push_back(len);
    }

    for (size_t i = 0; i < images.size(); i++) {
        const njson &im = images[i];
        if (!im.is_object() || !im.contains("bufferView")) continue;
        size_t v = 0;
        if (!json_index(im, "bufferView", views.size(), &v))
            fail(RD_GLTF_ERR_INVALID, "image %zu does not refer to an existing buffer view", i);
        if (view_len[v] > (uint64_t)INT_MAX)
            fail(RD_GLTF_ERR_TOO_LARGE, "image %zu is larger than 2 GiB", i);
    }
}

/* ---- accessors ---------------------------------------------------------------------- */

const char *type_name(int type)
{
    switch (type) {
    case TINYGLTF_TYPE_SCALAR:
        return "SCALAR";
    case TINYGLTF_TYPE_VEC2:
        return "VEC2";
    case TINYGLTF_TYPE_VEC3:
        return "VEC3";
    case TINYGLTF_TYPE_VEC4:
        return "VEC4";
    case TINYGLTF_TYPE_MAT2:
        return "MAT2";
    case TINYGLTF_TYPE_MAT3:
        return "MAT3";
    case TINYGLTF_TYPE_MAT4:
        return "MAT4";
    default:
        return "unknown";
    }
}

static_assert(TINYGLTF_COMPONENT_TYPE_BYTE == RD_GLTF_BYTE &&
                  TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE == RD_GLTF_UNSIGNED_BYTE &&
                  TINYGLTF_COMPONENT_TYPE_SHORT == RD_GLTF_SHORT &&
                  TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT == RD_GLTF_UNSIGNED_SHORT &&
                  TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT == RD_GLTF_UNSIGNED_INT &&
                  TINYGLTF_COMPONENT_TYPE_FLOAT == RD_GLTF_FLOAT,
              "gltf_import.h numbers component types as tinygltf does");
static_assert(TINYGLTF_MODE_TRIANGLES == RD_GLTF_MODE_TRIANGLES &&
                  TINYGLTF_MODE_TRIANGLE_STRIP == RD_GLTF_MODE_TRIANGLE_STRIP &&
                  TINYGLTF_MODE_TRIANGLE_FAN == RD_GLTF_MODE_TRIANGLE_FAN,
              "gltf_import.h numbers primitive modes as tinygltf does");

/* A validated accessor (gltf_import.h) and the sparse indices it points to. Moves keep the
 * pointer valid; copies are not allowed. */
struct Accessor {
    rd_gltf_accessor c;
    std::vector<uint32_t> sparse_index;
    Accessor()
    {
        memset(&c, 0, sizeof c), c.index = -1;
    }
    Accessor(Accessor &&) = default;
    Accessor &operator=(Accessor &&) = default;
    Accessor(const Accessor &) = delete;
    Accessor &operator=(const Accessor &) = delete;
};

/* Start of `bytes` bytes at `offset` inside buffer view `view`, or null when out of range. */
const unsigned char *view_range(const Model &m, int view, uint64_t offset, uint64_t bytes,
                                int accessor, const char *what)
{
    if (view < 0 || (size_t)view >= m.bufferViews.size())
        fail(RD_GLTF_ERR_INVALID,
             "accessor %d (%s) refers to buffer view %d, but there are only %zu buffer views",
             accessor, what, view, m.bufferViews.size());
    const tinygltf::BufferView &bv = m.bufferViews[(size_t)view];
    if (bv.buffer < 0 || (size_t)bv.buffer >= m.buffers.size())
        fail(RD_GLTF_ERR_INVALID, "buffer view %d refers to buffer %d, which does not exist", view,
             bv.buffer);
    const std::vector<unsigned char> &data = m.buffers[(size_t)bv.buffer].data;
    if (bv.byteOffset > data.size() || bv.byteLength > data.size() - bv.byteOffset)
        fail(RD_GLTF_ERR_INVALID, "buffer view %d does not fit in buffer %d", view, bv.buffer);
    if (offset > bv.byteLength || bytes > bv.byteLength - offset)
        fail(RD_GLTF_ERR_INVALID, "accessor %d (%s) reads past the end of buffer view %d", accessor,
             what, view);
    return data.data() + bv.byteOffset + offset;
}

/* Validates accessor `index` for use as `what` (type and allowed component types). */
Accessor make_accessor(const Model &m, int index, const std::string &what_s, int type,
                       std::initializer_list<int> ctypes)
{
    const char *what = what_s.c_str();
    if (index < 0 || (size_t)index >= m.accessors.size())
        fail(RD_GLTF_ERR_INVALID, "%s refers to accessor %d, but there are only %zu accessors",
             what, index, m.accessors.size());
    const tinygltf::Accessor &a = m.accessors[(size_t)index];
    Accessor r;
    rd_gltf_accessor &c = r.c;
    c.index = index;
    if (a.type != type)
        fail(RD_GLTF_ERR_INVALID, "accessor %d (%s) has type %s, expected %s", index, what,
             type_name(a.type), type_name(type));
    if (std::find(ctypes.begin(), ctypes.end(), a.componentType) == ctypes.end())
        fail(RD_GLTF_ERR_INVALID,
             "accessor %d (%s) has component type %d, which is not allowed "
             "here",
             index, what, a.componentType);
    if (a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT && type != TINYGLTF_TYPE_SCALAR &&
        !a.normalized)
        fail(RD_GLTF_ERR_INVALID, "accessor %d (%s) holds integers but is not normalized", index,
             what);
    if (a.count == 0) fail(RD_GLTF_ERR_INVALID, "accessor %d (%s) has count 0", index, what);
    c.ctype = a.componentType;
    c.ncomp = type == TINYGLTF_TYPE_SCALAR ? 1
              : type == TINYGLTF_TYPE_VEC2 ? 2
              : type == TINYGLTF_TYPE_VEC3 ? 3
                                           : 4;
    c.elem = rd_gltf_component_size(a.componentType) * (size_t)c.ncomp;
    c.count = a.count;
    c.normalized = a.normalized;
    if (a.bufferView < -1)
        fail(RD_GLTF_ERR_INVALID, "accessor %d (%s) has buffer view %d", index, what, a.bufferView);
    if (a.bufferView >= 0) {
        const tinygltf::BufferView *bv = (size_t)a.bufferView < m.bufferViews.size()
                                             ? &m.bufferViews[(size_t)a.bufferView]
                                             : nullptr;
        c.stride = bv && bv->byteStride ? bv->byteStride : c.elem;
        if (c.stride < c.elem)
            fail(RD_GLTF_ERR_INVALID,
                 "buffer view %d has byteStride %zu, smaller than the %zu-byte elements of "
                 "accessor %d",
                 a.bufferView, c.stride, c.elem, index);
        uint64_t span;
        if (__builtin_mul_overflow((uint64_t)c.stride, (uint64_t)(c.count - 1), &span) ||
            __builtin_add_overflow(span, (uint64_t)c.elem, &span))
            fail(RD_GLTF_ERR_INVALID, "accessor %d (%s) reads past the end of buffer view %d",
                 index, what, a.bufferView);
        c.data = view_range(m, a.bufferView, a.byteOffset, span, index, what);
    }
    if (a.sparse.isSparse) {
        size_t n = a.sparse.count > 0 ? (size_t)a.sparse.count : 0;
        if (n == 0 || n > c.count)
            fail(RD_GLTF_ERR_INVALID, "accessor %d (%s) has an invalid sparse count %d", index,
                 what, a.sparse.count);
        int ict = a.sparse.indices.componentType;
        if (ict != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
            ict != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
            ict != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
            fail(RD_GLTF_ERR_INVALID, "accessor %d (%s) has sparse indices of component type %d",
                 index, what, ict);
        if (a.sparse.indices.byteOffset < 0 || a.sparse.values.byteOffset < 0)
            fail(RD_GLTF_ERR_INVALID, "accessor %d (%s) has a negative sparse byteOffset", index,
                 what);
        size_t isz = rd_gltf_component_size(ict);
        const unsigned char *ip =
            view_range(m, a.sparse.indices.bufferView, (uint64_t)a.sparse.indices.byteOffset,
                       (uint64_t)n * isz, index, what);
        c.sparse_values =
            view_range(m, a.sparse.values.bufferView, (uint64_t)a.sparse.values.byteOffset,
                       (uint64_t)n * c.elem, index, what);
        r.sparse_index.resize(n);
        if (!rd_gltf_read_sparse_indices(ip, ict, n, c.count, r.sparse_index.data()))
            fail(RD_GLTF_ERR_INVALID,
                 "the sparse indices of accessor %d (%s) are out of range or not increasing", index,
                 what);
        c.sparse_index = r.sparse_index.data();
        c.sparse_count = n;
    }
    return r;
}

void read_floats(const Accessor &a, size_t i, float *out)
{
    rd_gltf_read_floats(&a.c, i, out);
}

/* ---- conversion --------------------------------------------------------------------- */

struct Primitive {
    int mode = TINYGLTF_MODE_TRIANGLES;
    Accessor pos, nrm, uv, tan, idx;
    bool has_nrm = false, has_uv = false, has_tan = false, has_idx = false;
    uint64_t tris = 0;
    uint32_t material = 0;
};

class Converter
{
  public:
    Converter(const Model &m, LoadContext *ctx, uint64_t max_tris, rd_scene *out)
        : m_(m), ctx_(ctx), max_tris_(max_tris), s_(out)
    {
    }
    void run();

  private:
    void hierarchy();
    void materials();
    int32_t texture(int index, int tex_coord, size_t material, const char *slot);
    void meshes();
    std::vector<Primitive> plan_mesh(size_t mesh);
    void fill_mesh(size_t mesh, const std::vector<Primitive> &prims, rd_mesh *out);
    void node_transform(size_t index, rd_node *n);
    void lights_and_cameras();
    void animations();
    void anim_sampler(const std::string &where, const tinygltf::AnimationSampler &gs, bool rotation,
                      rd_anim_sampler *out, std::vector<float> *times, std::vector<float> *values);
    void warnings();

    const Model &m_;
    LoadContext *ctx_;
    uint64_t max_tris_;
    rd_scene *s_;
    std::vector<int> parent_;        /* glTF parent of each glTF node */
    std::vector<size_t> order_;      /* reachable glTF nodes, parents first */
    std::vector<int32_t> node_map_;  /* glTF node -> rd node (-1: not in the scene) */
    std::vector<int32_t> mesh_map_;  /* glTF mesh -> rd mesh (-1: unused or empty) */
    std::map<int, int32_t> tex_map_; /* glTF texture -> rd texture */
    uint64_t anim_floats_ = 0;       /* animation times and values kept so far */
};

void Converter::run()
{
    warnings();
    hierarchy();
    materials();
    meshes();
    node_map_.assign(m_.nodes.size(), -1);
    for (size_t gi : order_) {
        const tinygltf::Node &gn = m_.nodes[gi];
        rd_node n;
        memset(&n, 0, sizeof n);
        n.name = gn.name.empty() ? nullptr : const_cast<char *>(gn.name.c_str());
        n.parent = parent_[gi] >= 0 ? node_map_[(size_t)parent_[gi]] : -1;
        n.mesh = gn.mesh >= 0 ? mesh_map_[(size_t)gn.mesh] : -1;
        node_transform(gi, &n);
        node_map_[gi] = (int32_t)rd_scene_add_node(s_, &n);
    }
    lights_and_cameras();
    animations();
    char err[256];
    if (!rd_scene_update(s_, err, sizeof err)) fail(RD_GLTF_ERR_INVALID, "%s", err);
}

void Converter::warnings()
{
    for (const std::string &e : m_.extensionsUsed) {
        if (e.empty() || is_supported_extension(e)) continue;
        bool on_material = false; /* then materials() warns, saying how many use it */
        for (const tinygltf::Material &g : m_.materials)
            on_material = on_material || g.extensions.count(e) != 0;
        if (!on_material)
            rd_scene_warn(s_, "extension %s is not supported and was ignored",
                          clean(e, 80).c_str());
    }
    if (!m_.skins.empty())
        rd_scene_warn(s_,
                      "the file has %zu skin(s); skinning is not supported, skinned meshes "
                      "are drawn unskinned",
                      m_.skins.size());
}

/* The hierarchy and the reachable nodes' order (gltf_nodes.c). */
void Converter::hierarchy()
{
    size_t count = m_.nodes.size();
    std::vector<rd_gltf_node_list> children(count), scenes(m_.scenes.size());
    for (size_t i = 0; i < count; i++)
        children[i] = {m_.nodes[i].children.data(), m_.nodes[i].children.size()};
    for (size_t i = 0; i < scenes.size(); i++)
        scenes[i] = {m_.scenes[i].nodes.data(), m_.scenes[i].nodes.size()};
    parent_.assign(count, -1);
    order_.assign(count, 0);
    size_t reached = 0;
    char err[256];
    check(rd_gltf_hierarchy(count, children.data(), scenes.size(), scenes.data(), m_.defaultScene,
                            parent_.data(), order_.data(), &reached, err, sizeof err),
          err);
    order_.resize(reached);
}

void Converter::node_transform(size_t index, rd_node *n)
{
    const tinygltf::Node &g = m_.nodes[index];
    rd_gltf_transform t = {g.matrix.data(),   g.translation.data(), g.rotation.data(),
                           g.scale.data(),    g.matrix.size(),      g.translation.size(),
                           g.rotation.size(), g.scale.size()};
    char err[256];
    check(rd_gltf_node_transform(index, &t, n, err, sizeof err), err);
}

int32_t Converter::texture(int index, int tex_coord, size_t material, const char *slot)
{
    if (index < 0) return -1;
    if ((size_t)index >= m_.textures.size())
        fail(RD_GLTF_ERR_INVALID,
             "material %zu refers to texture %d, but there are only %zu "
             "textures",
             material, index, m_.textures.size());
    if (tex_coord != 0) {
        rd_scene_warn(s_,
                      "material %zu reads its %s texture with TEXCOORD_%d; only TEXCOORD_0 "
                      "is supported, so the texture is ignored",
                      material, slot, tex_coord);
        return -1;
    }
    auto found = tex_map_.find(index);
    if (found != tex_map_.end()) return found->second;

    const tinygltf::Texture &t = m_.textures[(size_t)index];
    if (t.source < 0 || (size_t)t.source >= m_.images.size())
        fail(RD_GLTF_ERR_INVALID, "texture %d refers to image %d, but there are only %zu images",
             index, t.source, m_.images.size());
    const tinygltf::Image &img = m_.images[(size_t)t.source];
    std::string what = label("image", (size_t)t.source, img.name);
    if (img.name.empty() && !img.uri.empty() && img.uri.compare(0, 5, "data:") != 0)
        what = label("image", (size_t)t.source, img.uri);

    std::vector<unsigned char> external;
    const std::vector<unsigned char> *rgba = &img.image;
    int w = img.width, h = img.height;
    auto failed = ctx_->image_failures.find(t.source);
    if (failed != ctx_->image_failures.end())
        fail(failed->second.code, "%s could not be decoded: %s", what.c_str(),
             failed->second.why.c_str());
    if (img.image.empty()) {
        if (img.uri.empty()) fail(RD_GLTF_ERR_INVALID, "%s has no data", what.c_str());
        /* an external file (tinygltf keeps only its URI) */
        if (img.uri.compare(0, 5, "data:") == 0)
            fail(RD_GLTF_ERR_UNSUPPORTED, "%s has a data URI that is not base64 PNG or JPEG data",
                 what.c_str());
        std::string rel = tinygltf::dlib::urldecode(img.uri);
        const char *refusal = rd_gltf_uri_refusal(&ctx_->files, rel.c_str(), rel.size());
        std::string why = refusal ? refusal : "";
        std::vector<unsigned char> file;
        rd_gltf_read_status st = RD_GLTF_READ_OK;
        if (why.empty() && (st = read_file((ctx_->files.prefix + rel).c_str(), kMaxExternalFile,
                                           &file, &why)) != RD_GLTF_READ_OK)
            fail(st == RD_GLTF_READ_TOO_LARGE ? RD_GLTF_ERR_TOO_LARGE : RD_GLTF_ERR_IO,
                 "%s could not be loaded: %s", what.c_str(), why.c_str());
        if (!why.empty())
            fail(RD_GLTF_ERR_IO, "%s could not be loaded: %s", what.c_str(), why.c_str());
        ImageFailure f;
        if (!decode_image(ctx_, file.data(), file.size(), &external, &w, &h, &f))
            fail(f.code, "%s could not be decoded: %s", what.c_str(), f.why.c_str());
        rgba = &external;
    }
    if (w < 1 || h < 1 || rgba->size() != (size_t)w * (size_t)h * 4)
        fail(RD_GLTF_ERR_INVALID, "%s has inconsistent decoded data", what.c_str());

    rd_texture rt;
    memset(&rt, 0, sizeof rt);
    rt.width = (uint32_t)w;
    rt.height = (uint32_t)h;
    rt.wrap_s = rt.wrap_t = RD_WRAP_REPEAT;
    if (t.sampler >= 0) {
        if ((size_t)t.sampler >= m_.samplers.size())
            fail(RD_GLTF_ERR_INVALID,
                 "texture %d refers to sampler %d, but there are only %zu samplers", index,
                 t.sampler, m_.samplers.size());
        const tinygltf::Sampler &smp = m_.samplers[(size_t)t.sampler];
        auto wrap = [&](int mode) -> uint32_t {
            switch (mode) {
            case TINYGLTF_TEXTURE_WRAP_REPEAT:
                return RD_WRAP_REPEAT;
            case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE:
                return RD_WRAP_CLAMP;
            case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT:
                return RD_WRAP_MIRROR;
            default:
                fail(RD_GLTF_ERR_INVALID, "sampler %d has an invalid wrap mode %d", t.sampler,
                     mode);
            }
        };
        rt.wrap_s = wrap(smp.wrapS);
        rt.wrap_t = wrap(smp.wrapT);
        rt.nearest = smp.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST;
    }
    rt.rgba = static_cast<uint8_t *>(malloc(rgba->size()));
    if (!rt.rgba) {
        fprintf(stderr, "probecast: out of memory (%zu bytes)\n", rgba->size());
        abort();
    }
    memcpy(rt.rgba, rgba->data(), rgba->size());
    int32_t out = (int32_t)rd_scene_add_texture(s_, &rt);
    tex_map_[index] = out;
    return out;
}

/* A material's factors for gltf_materials.c. */
rd_gltf_material_factors factors(const tinygltf::Material &g)
{
    rd_gltf_material_factors f;
    memset(&f, 0, sizeof f);
    const tinygltf::PbrMetallicRoughness &pbr = g.pbrMetallicRoughness;
    f.base_color = pbr.baseColorFactor.data();
    f.base_color_count = pbr.baseColorFactor.size();
    f.emissive = g.emissiveFactor.data();
    f.emissive_count = g.emissiveFactor.size();
    auto ext = g.extensions.find("KHR_materials_emissive_strength");
    if (ext != g.extensions.end() && ext->second.Has("emissiveStrength")) {
        const tinygltf::Value &v = ext->second.Get("emissiveStrength");
        f.has_strength = true;
        f.strength_is_number = v.IsNumber();
        f.strength = v.IsNumber() ? v.GetNumberAsDouble() : 0.0;
    }
    f.alpha_cutoff = g.alphaCutoff;
    f.alpha_mode = g.alphaMode.data();
    f.alpha_mode_len = g.alphaMode.size();
    f.double_sided = g.doubleSided;
    f.metallic = pbr.metallicFactor;
    f.roughness = pbr.roughnessFactor;
    f.normal_scale = g.normalTexture.scale;
    f.occlusion_strength = g.occlusionTexture.strength;
    return f;
}

/* Materials: factors in gltf_materials.c, textures here (texture() reads and decodes them),
 * in the order the checks always ran. */
void Converter::materials()
{
    size_t blend = 0;
    std::map<std::string, size_t> unsupported; /* material extension -> materials using it */
    char err[256];
    for (size_t i = 0; i < m_.materials.size(); i++) {
        const tinygltf::Material &g = m_.materials[i];
        const tinygltf::PbrMetallicRoughness &pbr = g.pbrMetallicRoughness;
        rd_material mt;
        memset(&mt, 0, sizeof mt);
        mt.name = g.name.empty() ? nullptr : const_cast<char *>(g.name.c_str());
        rd_gltf_material_factors f = factors(g);
        check(rd_gltf_material_colors(s_, i, &f, &mt, err, sizeof err), err);
        mt.base_color_texture =
            texture(pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord, i, "base colour");
        mt.emissive_texture =
            texture(g.emissiveTexture.index, g.emissiveTexture.texCoord, i, "emissive");
        check(rd_gltf_material_pbr(i, &f, &mt, err, sizeof err), err);
        mt.metallic_roughness_texture =
            texture(pbr.metallicRoughnessTexture.index, pbr.metallicRoughnessTexture.texCoord, i,
                    "metallic-roughness");
        mt.normal_texture = texture(g.normalTexture.index, g.normalTexture.texCoord, i, "normal");
        mt.occlusion_texture =
            texture(g.occlusionTexture.index, g.occlusionTexture.texCoord, i, "occlusion");
        if (mt.alpha_mode == RD_ALPHA_BLEND) blend++;
        for (const auto &e : g.extensions)
            if (!is_supported_extension(e.first)) unsupported[clean(e.first, 80)]++;
        rd_scene_add_material(s_, &mt); /* index 1 + i: materials[0] is the default */
    }
    rd_gltf_material_warnings(s_, blend);
    for (const auto &u : unsupported)
        rd_scene_warn(s_,
                      "material extension %s (on %zu material(s)) is not supported; those "
                      "materials are drawn with the core metallic-roughness model",
                      u.first.c_str(), u.second);
}

/* Validates a mesh's primitives and counts its triangles without reading vertex data. */
std::vector<Primitive> Converter::plan_mesh(size_t mesh)
{
    const tinygltf::Mesh &gm = m_.meshes[mesh];
    std::vector<Primitive> out;
    bool morph = false;
    for (size_t p = 0; p < gm.primitives.size(); p++) {
        const tinygltf::Primitive &gp = gm.primitives[p];
        std::string where = fmt("mesh %zu primitive %zu", mesh, p);
        Primitive pr;
        pr.mode = gp.mode < 0 ? TINYGLTF_MODE_TRIANGLES : gp.mode;
        morph = morph || !gp.targets.empty();
        if (pr.mode >= TINYGLTF_MODE_POINTS && pr.mode <= TINYGLTF_MODE_LINE_STRIP) {
            rd_scene_warn(s_,
                          "%s draws points or lines (mode %d), which are not supported; it "
                          "is skipped",
                          where.c_str(), pr.mode);
            continue;
        }
        if (pr.mode > TINYGLTF_MODE_TRIANGLE_FAN)
            fail(RD_GLTF_ERR_INVALID, "%s has an invalid mode %d", where.c_str(), pr.mode);
        auto pos = gp.attributes.find("POSITION");
        if (pos == gp.attributes.end())
            fail(RD_GLTF_ERR_INVALID, "%s has no POSITION attribute", where.c_str());
        pr.pos = make_accessor(m_, pos->second, "POSITION of " + where, TINYGLTF_TYPE_VEC3,
                               {TINYGLTF_COMPONENT_TYPE_FLOAT});
        auto nrm = gp.attributes.find("NORMAL");
        if (nrm != gp.attributes.end()) {
            pr.nrm = make_accessor(m_, nrm->second, "NORMAL of " + where, TINYGLTF_TYPE_VEC3,
                                   {TINYGLTF_COMPONENT_TYPE_FLOAT});
            pr.has_nrm = true;
        }
        auto uv = gp.attributes.find("TEXCOORD_0");
        if (uv != gp.attributes.end()) {
            pr.uv =
                make_accessor(m_, uv->second, "TEXCOORD_0 of " + where, TINYGLTF_TYPE_VEC2,
                              {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                               TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT});
            pr.has_uv = true;
        }
        auto tan = gp.attributes.find("TANGENT");
        if (tan != gp.attributes.end()) {
            pr.tan = make_accessor(m_, tan->second, "TANGENT of " + where, TINYGLTF_TYPE_VEC4,
                                   {TINYGLTF_COMPONENT_TYPE_FLOAT});
            pr.has_tan = true;
        }
        if ((pr.has_nrm && pr.nrm.c.count != pr.pos.c.count) ||
            (pr.has_uv && pr.uv.c.count != pr.pos.c.count) ||
            (pr.has_tan && pr.tan.c.count != pr.pos.c.count))
            fail(RD_GLTF_ERR_INVALID, "the attributes of %s have different vertex counts",
                 where.c_str());
        size_t n = pr.pos.c.count;
        if (gp.indices >= 0) {
            pr.idx = make_accessor(m_, gp.indices, "indices of " + where, TINYGLTF_TYPE_SCALAR,
                                   {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                                    TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                                    TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT});
            pr.has_idx = true;
            n = pr.idx.c.count;
        }
        if (pr.mode == TINYGLTF_MODE_TRIANGLES) {
            pr.tris = n / 3;
            if (n % 3 != 0)
                rd_scene_warn(s_,
                              "%s has %zu vertices, not a multiple of 3; the last %zu are "
                              "ignored",
                              where.c_str(), n, n % 3);
        } else {
            pr.tris = n >= 3 ? n - 2 : 0;
        }
        if (gp.material >= 0 && (size_t)gp.material >= m_.materials.size())
            fail(RD_GLTF_ERR_INVALID, "%s refers to material %d, but there are only %zu materials",
                 where.c_str(), gp.material, m_.materials.size());
        pr.material = gp.material >= 0 ? (uint32_t)gp.material + 1 : 0;
        if (pr.tris > 0) out.push_back(std::move(pr));
    }
    if (morph)
        rd_scene_warn(s_, "%s has morph targets, which are not supported; its base shape is used",
                      label("mesh", mesh, gm.name).c_str());
    return out;
}

void Converter::fill_mesh(size_t mesh, const std::vector<Primitive> &prims, rd_mesh *out)
{
    std::vector<rd_gltf_primitive> c(prims.size());
    for (size_t p = 0; p < prims.size(); p++) {
        const Primitive &pr = prims[p];
        c[p] =
            rd_gltf_primitive{pr.mode,    pr.pos.c,  pr.nrm.c,   pr.uv.c,    pr.tan.c, pr.idx.c,
                              pr.has_nrm, pr.has_uv, pr.has_tan, pr.has_idx, pr.tris,  pr.material};
    }
    char err[256];
    check(rd_gltf_fill_mesh(mesh, c.data(), c.size(), out, err, sizeof err), err);
}

void Converter::meshes()
{
    std::vector<uint8_t> used(m_.meshes.size(), 0);
    for (size_t gi : order_) {
        int mesh = m_.nodes[gi].mesh;
        if (mesh < -1 || (mesh >= 0 && (size_t)mesh >= m_.meshes.size()))
            fail(RD_GLTF_ERR_INVALID, "node %zu refers to mesh %d, but there are only %zu meshes",
                 gi, mesh, m_.meshes.size());
        if (mesh >= 0) used[(size_t)mesh] = 1;
    }
    std::vector<std::vector<Primitive>> plans(m_.meshes.size());
    uint64_t total = 0;
    for (size_t i = 0; i < m_.meshes.size(); i++) {
        if (!used[i]) continue;
        plans[i] = plan_mesh(i);
        uint64_t tris = 0;
        for (const Primitive &p : plans[i])
            tris += p.tris;
        if (tris > UINT32_MAX)
            fail(RD_GLTF_ERR_TOO_LARGE, "mesh %zu has %llu triangles, more than a mesh can hold", i,
                 (unsigned long long)tris);
        total += tris;
        if (total > max_tris_)
            fail(RD_GLTF_ERR_TOO_LARGE,
                 "the scene has more than %llu triangles (the limit), counting meshes up to "
                 "mesh %zu",
                 (unsigned long long)max_tris_, i);
    }
    mesh_map_.assign(m_.meshes.size(), -1);
    for (size_t i = 0; i < m_.meshes.size(); i++) {
        uint64_t tris = 0;
        for (const Primitive &p : plans[i])
            tris += p.tris;
        if (tris == 0) continue; /* unused, or nothing but points and lines */
        const std::string &name = m_.meshes[i].name;
        uint32_t idx = rd_scene_add_mesh(s_, name.empty() ? nullptr : name.c_str(), (uint32_t)tris);
        fill_mesh(i, plans[i], &s_->meshes[idx]);
        mesh_map_[i] = (int32_t)idx;
    }
}

void Converter::lights_and_cameras()
{
    std::vector<uint8_t> ortho_warned(m_.cameras.size(), 0);
    for (size_t gi : order_) {
        const tinygltf::Node &gn = m_.nodes[gi];
        int32_t node = node_map_[gi];
        if (gn.camera >= 0 || gn.camera < -1) {
            if (gn.camera < 0 || (size_t)gn.camera >= m_.cameras.size())
                fail(RD_GLTF_ERR_INVALID,
                     "node %zu refers to camera %d, but there are only %zu cameras", gi, gn.camera,
                     m_.cameras.size());
            size_t ci = (size_t)gn.camera;
            const tinygltf::Camera &gc = m_.cameras[ci];
            if (gc.type != "perspective") {
                if (!ortho_warned[ci])
                    rd_scene_warn(s_, "%s is %s, which is not supported; it is ignored",
                                  label("camera", ci, gc.name).c_str(), clean(gc.type, 16).c_str());
                ortho_warned[ci] = 1;
            } else {
                rd_camera c;
                memset(&c, 0, sizeof c);
                c.name = gc.name.empty() ? nullptr : const_cast<char *>(gc.name.c_str());
                const tinygltf::PerspectiveCamera &p = gc.perspective;
                char err[256];
                check(rd_gltf_perspective(ci, p.yfov, p.znear, p.aspectRatio, &c, err, sizeof err),
                      err);
                c.node = node;
                rd_scene_add_camera(s_, &c);
            }
        }
        auto ext = gn.extensions.find("KHR_lights_punctual");
        if (ext == gn.extensions.end()) continue;
        const tinygltf::Value &li = ext->second.Get("light");
        if (!li.IsInt() || li.GetNumberAsInt() < 0 ||
            (size_t)li.GetNumberAsInt() >= m_.lights.size())
            fail(RD_GLTF_ERR_INVALID,
                 "node %zu refers to a KHR_lights_punctual light that does "
                 "not exist (there are %zu lights)",
                 gi, m_.lights.size());
        size_t index = (size_t)li.GetNumberAsInt();
        const tinygltf::Light &gl = m_.lights[index];
        rd_light l;
        memset(&l, 0, sizeof l);
        l.name = gl.name.empty() ? nullptr : const_cast<char *>(gl.name.c_str());
        rd_gltf_light_params lp = {gl.type.data(),         gl.type.size(),        gl.color.data(),
                                   gl.color.size(),        gl.intensity,          gl.range,
                                   gl.spot.innerConeAngle, gl.spot.outerConeAngle};
        bool ignored;
        char err[256];
        check(rd_gltf_light(s_, index, &lp, &l, &ignored, err, sizeof err), err);
        if (ignored) continue;
        l.node = node;
        rd_scene_add_light(s_, &l);
    }
}

/* Validates an animation sampler for a translation/scale (VEC3 float) or rotation (VEC4 float
 * or normalized integers) channel and reads its keys (glTF 2.0 section 3.11). */
void Converter::anim_sampler(const std::string &where, const tinygltf::AnimationSampler &gs,
                             bool rotation, rd_anim_sampler *out, std::vector<float> *times,
                             std::vector<float> *values)
{
    const std::string &ip = gs.interpolation;
    out->interpolation = ip == "LINEAR"        ? (uint32_t)RD_INTERP_LINEAR
                         : ip == "STEP"        ? (uint32_t)RD_INTERP_STEP
                         : ip == "CUBICSPLINE" ? (uint32_t)RD_INTERP_CUBICSPLINE
                                               : UINT32_MAX;
    if (out->interpolation == UINT32_MAX)
        fail(RD_GLTF_ERR_INVALID, "%s has an unknown interpolation '%s'", where.c_str(),
             clean(ip, 32).c_str());
    Accessor in = make_accessor(m_, gs.input, "input of " + where, TINYGLTF_TYPE_SCALAR,
                                {TINYGLTF_COMPONENT_TYPE_FLOAT});
    Accessor val =
        rotation
            ? make_accessor(m_, gs.output, "output of " + where, TINYGLTF_TYPE_VEC4,
                            {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE,
                             TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_SHORT,
                             TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT})
            : make_accessor(m_, gs.output, "output of " + where, TINYGLTF_TYPE_VEC3,
                            {TINYGLTF_COMPONENT_TYPE_FLOAT});
    size_t keys = in.c.count, per_key = out->interpolation == RD_INTERP_CUBICSPLINE ? 3 : 1;
    if (val.c.count / per_key != keys || val.c.count % per_key != 0)
        fail(RD_GLTF_ERR_INVALID, "%s has %zu output values for %zu input times (%s needs %zu)",
             where.c_str(), val.c.count, keys, ip.c_str(), keys * per_key);
    out->components = rotation ? 4 : 3;
    if (val.c.count <= kMaxAnimationFloats) anim_floats_ += keys + val.c.count * out->components;
    if (val.c.count > kMaxAnimationFloats || anim_floats_ > kMaxAnimationFloats)
        fail(RD_GLTF_ERR_TOO_LARGE,
             "the animations hold more than %llu keys and values (the limit)",
             (unsigned long long)kMaxAnimationFloats);
    out->key_count = (uint32_t)keys;
    times->resize(keys);
    values->resize(val.c.count * out->components);
    char err[512];
    check(rd_gltf_read_keys(where.c_str(), &in.c, &val.c, out->components, times->data(),
                            values->data(), err, sizeof err),
          err);
}

/* Node animations (glTF 2.0 section 3.11). Channels that animate morph weights or an
 * extension's target are skipped with one warning; so are nodes outside the scene shown. */
void Converter::animations()
{
    size_t skipped_weights = 0, skipped_other = 0;
    for (size_t ai = 0; ai < m_.animations.size(); ai++) {
        const tinygltf::Animation &ga = m_.animations[ai];
        std::string an = label("animation", ai, ga.name);
        std::map<std::pair<int, uint32_t>, size_t> targets; /* (node, path) -> channel */
        std::map<std::pair<int, uint32_t>, uint32_t> kept;  /* (sampler, path) -> rd sampler */
        std::vector<rd_anim_sampler> samplers;
        std::vector<std::vector<float>> times, values;
        std::vector<rd_anim_channel> channels;
        std::vector<uint8_t> used(ga.samplers.size(), 0); /* by any channel, even skipped */
        for (size_t ci = 0; ci < ga.channels.size(); ci++) {
            const tinygltf::AnimationChannel &gc = ga.channels[ci];
            std::string where = fmt("%s channel %zu", an.c_str(), ci);
            const std::string &path = gc.target_path;
            int node = gc.target_node;
            if (gc.sampler < 0 || (size_t)gc.sampler >= ga.samplers.size())
                fail(RD_GLTF_ERR_INVALID, "%s refers to sampler %d, but %s has only %zu samplers",
                     where.c_str(), gc.sampler, an.c_str(), ga.samplers.size());
            if (node < -1 || (node >= 0 && (size_t)node >= m_.nodes.size()))
                fail(RD_GLTF_ERR_INVALID, "%s targets node %d, but there are only %zu nodes",
                     where.c_str(), node, m_.nodes.size());
            used[(size_t)gc.sampler] = 1;
            uint32_t p = path == "translation" ? (uint32_t)RD_ANIM_TRANSLATION
                         : path == "rotation"  ? (uint32_t)RD_ANIM_ROTATION
                         : path == "scale"     ? (uint32_t)RD_ANIM_SCALE
                                               : UINT32_MAX;
            if (path.empty()) fail(RD_GLTF_ERR_INVALID, "%s has no target path", where.c_str());
            skipped_weights += p == UINT32_MAX && path == "weights";
            skipped_other += p == UINT32_MAX && path != "weights";
            if (p == UINT32_MAX || node < 0) continue; /* no node: ignored, as the spec says */
            if (!m_.nodes[(size_t)node].matrix.empty())
                fail(RD_GLTF_ERR_INVALID,
                     "%s animates node %d, which has a matrix; glTF allows animating only "
                     "nodes given by translation, rotation and scale",
                     where.c_str(), node);
            auto dup = targets.emplace(std::make_pair(node, p), ci);
            if (!dup.second)
                fail(RD_GLTF_ERR_INVALID, "%s animates the %s of node %d, as channel %zu does",
                     where.c_str(), path.c_str(), node, dup.first->second);
            if (node_map_[(size_t)node] < 0) continue; /* not in the scene shown */
            auto k = kept.emplace(std::make_pair(gc.sampler, p), (uint32_t)samplers.size());
            if (k.second) {
                samplers.emplace_back();
                times.emplace_back();
                values.emplace_back();
                anim_sampler(fmt("%s sampler %d", an.c_str(), gc.sampler),
                             ga.samplers[(size_t)gc.sampler], p == RD_ANIM_ROTATION,
                             &samplers.back(), &times.back(), &values.back());
            }
            channels.push_back({(uint32_t)node_map_[(size_t)node], p, k.first->second});
        }
        if (channels.empty()) continue;
        for (size_t i = 0; i < samplers.size(); i++) {
            samplers[i].times = times[i].data();
            samplers[i].values = values[i].data();
        }
        rd_animation a;
        memset(&a, 0, sizeof a);
        /* the loop spans every channel's keys, skipped ones too (as viewers that play them) */
        for (size_t si = 0; si < ga.samplers.size(); si++) {
            if (!used[si]) continue;
            Accessor in = make_accessor(m_, ga.samplers[si].input,
                                        fmt("input of %s sampler %zu", an.c_str(), si),
                                        TINYGLTF_TYPE_SCALAR, {TINYGLTF_COMPONENT_TYPE_FLOAT});
            float last;
            read_floats(in, in.c.count - 1, &last);
            if (std::isfinite(last) && last > a.duration) a.duration = last;
        }
        a.name = ga.name.empty() ? nullptr : const_cast<char *>(ga.name.c_str());
        a.samplers = samplers.data();
        a.sampler_count = (uint32_t)samplers.size();
        a.channels = channels.data();
        a.channel_count = (uint32_t)channels.size();
        rd_scene_add_animation(s_, &a);
    }
    if (skipped_weights)
        rd_scene_warn(s_,
                      "%zu animation channel(s) animate morph target weights, which are not "
                      "supported; they are ignored",
                      skipped_weights);
    if (skipped_other)
        rd_scene_warn(s_, "%zu animation channel(s) have an unknown target path; they are ignored",
                      skipped_other);
}

/* One readable line, no control or non-ASCII bytes (messages may end up in JSON or logs). */
void write_message(const std::string &msg, char *err, size_t errlen)
{
    if (!err || errlen == 0) return;
    size_t n = std::min(msg.size(), errlen - 1);
    for (size_t i = 0; i < n; i++) {
        unsigned char ch = (unsigned char)msg[i];
        err[i] = (ch < 0x20 || ch >= 0x7f) ? '?' : (char)ch;
    }
    err[n] = '\0';
}

/* tinygltf's error text: its first non-empty line, shortened. */
std::string first_line(const std::string &text)
{
    size_t start = 0;
    while (start < text.size()) {
        size_t end = text.find('\n', start);
        if (end == std::string::npos) end = text.size();
        if (end > start) {
            std::string line = text.substr(start, std::min<size_t>(end - start, 160));
            return line;
        }
        start = end + 1;
    }
    return "unknown error";
}

void load(const unsigned char *data, size_t size, const char *base_dir, const rd_gltf_options *opt,
          rd_scene *out)
{
    if (size > 0xffffffffull) fail(RD_GLTF_ERR_TOO_LARGE, "the file is larger than 4 GiB");
    LoadContext ctx(base_dir);
    rd_gltf_container c;
    char cerr[256];
    check(rd_gltf_parse_container(data, size, &c, cerr, sizeof cerr), cerr);
    prescan(c, &ctx);

    tinygltf::TinyGLTF gltf;
    tinygltf::FsCallbacks fs = {&fs_file_exists, &fs_expand, &fs_read, &fs_write, &ctx.files};
    gltf.SetFsCallbacks(fs);
    gltf.SetImageLoader(&image_callback, &ctx);
    Model model;
    std::string terr, twarn;
    bool ok;
    if (c.glb)
        ok = gltf.LoadBinaryFromMemory(&model, &terr, &twarn, data, (unsigned int)size,
                                       ctx.files.base ? ctx.files.base : "");
    else
        ok = gltf.LoadASCIIFromString(&model, &terr, &twarn, c.json, (unsigned int)c.json_size,
                                      ctx.files.base ? ctx.files.base : "");
    if (!ok) {
        if (ctx.files.last_refusal[0])
            fail(RD_GLTF_ERR_IO, "an external file could not be loaded: %s (%s)",
                 ctx.files.last_refusal, first_line(terr).c_str());
        fail(RD_GLTF_ERR_INVALID, "the glTF file is invalid: %s", first_line(terr).c_str());
    }
    uint64_t max_tris = opt && opt->max_triangles ? opt->max_triangles : kDefaultMaxTriangles;
    Converter(model, &ctx, max_tris, out).run();
}

rd_gltf_result guarded(const unsigned char *data, size_t size, const char *base_dir,
                       const rd_gltf_options *opt, rd_scene *out, char *err, size_t errlen)
{
    rd_gltf_result code = RD_GLTF_OK;
    std::string msg;
    try {
        if (!data && size > 0) fail(RD_GLTF_ERR_INVALID, "no data was given");
        load(data, size, base_dir, opt, out);
    } catch (const LoadError &e) {
        code = e.code;
        msg = e.msg;
    } catch (const std::bad_alloc &) {
        code = RD_GLTF_ERR_TOO_LARGE;
        msg = "the file needs more memory than is available";
    } catch (const std::exception &e) {
        code = RD_GLTF_ERR_INVALID;
        msg = std::string("the glTF file is invalid: ") + e.what();
    } catch (...) {
        code = RD_GLTF_ERR_INVALID;
        msg = "the glTF file is invalid (unexpected error)";
    }
    if (code != RD_GLTF_OK) rd_scene_destroy(out);
    write_message(msg, err, errlen);
    return code;
}

} // namespace

extern "C" const char *rd_gltf_strerror(rd_gltf_result r)
{
    switch (r) {
    case RD_GLTF_OK:
        return "ok";
    case RD_GLTF_ERR_IO:
        return "io error";
    case RD_GLTF_ERR_PARSE:
        return "parse error";
    case RD_GLTF_ERR_INVALID:
        return "invalid glTF";
    case RD_GLTF_ERR_UNSUPPORTED:
        return "unsupported glTF feature";
    case RD_GLTF_ERR_TOO_LARGE:
        return "too large";
    }
    return "unknown error";
}

extern "C" rd_gltf_result rd_gltf_load_memory(const void *data, size_t size, const char *base_dir,
                                              const rd_gltf_options *opt, rd_scene *out, char *err,
                                              size_t errlen)
{
    if (!out) {
        write_message("no output scene was given", err, errlen);
        return RD_GLTF_ERR_INVALID;
    }
    rd_scene_init(out);
    return guarded(static_cast<const unsigned char *>(data), size, base_dir, opt, out, err, errlen);
}

extern "C" rd_gltf_result rd_gltf_load_file(const char *path, const rd_gltf_options *opt,
                                            rd_scene *out, char *err, size_t errlen)
{
    if (!out) {
        write_message("no output scene was given", err, errlen);
        return RD_GLTF_ERR_INVALID;
    }
    rd_scene_init(out);
    rd_gltf_result code;
    std::string msg;
    try {
        if (!path || !path[0]) fail(RD_GLTF_ERR_IO, "no file name was given");
        std::vector<unsigned char> data;
        std::string why;
        rd_gltf_read_status st = read_file(path, 0xffffffffull, &data, &why);
        if (st != RD_GLTF_READ_OK)
            fail(st == RD_GLTF_READ_TOO_LARGE ? RD_GLTF_ERR_TOO_LARGE : RD_GLTF_ERR_IO,
                 "'%s' could not be read: %s", path, why.c_str());
        std::string p = path, base;
        size_t slash = p.find_last_of('/');
        base = slash == std::string::npos ? "." : slash == 0 ? "/" : p.substr(0, slash);
        return guarded(data.data(), data.size(), base.c_str(), opt, out, err, errlen);
    } catch (const LoadError &e) {
        code = e.code;
        msg = e.msg;
    } catch (...) {
        code = RD_GLTF_ERR_TOO_LARGE;
        msg = "the file needs more memory than is available";
    }
    rd_scene_destroy(out);
    write_message(msg, err, errlen);
    return code;
}
