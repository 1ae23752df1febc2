/* gltf_loader.cpp: the glTF importer's one C++ file — the only code that sees tinygltf. It
 * parses with tinygltf and copies what was parsed into plain C views; everything else is C.
 *
 * Untrusted input passes three gates:
 *   1. our own checks of the GLB container (gltf_container.c) and a pre-scan of the JSON:
 *      parsed here with tinygltf's JSON parser, checked in gltf_prescan.c (nesting depth, asset
 *      version, extensionsRequired, buffers, buffer views and image buffer views), because
 *      tinygltf 2.7 trusts some of those values (image buffer views, the BIN chunk length);
 *   2. tinygltf parses the JSON and loads buffers through file callbacks that only open
 *      regular files below the base folder (gltf_uri.c); images are decoded by our callback
 *      (gltf_image.c: PNG/JPEG via stb_image, always to 8-bit RGBA, with size limits);
 *   3. the model is copied into an rd_gltf_document (gltf_document.h), which gltf_convert.c
 *      turns into the scene, validating every index, accessor range and value before reading.
 * Errors unwind as a C++ exception (LoadError) caught at the C boundary with everything else.
 */
#include "renderer/gltf/gltf_loader.h"

#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream> /* tiny_gltf.h 2.7 needs it even with TINYGLTF_NO_FS */
#include <map>
#include <memory>
#include <new>
#include <string>
#include <vector>

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

#include "renderer/gltf/gltf_document.h"

namespace
{

using njson = nlohmann::json;
using tinygltf::Model;

const uint64_t kDefaultMaxTriangles = 50000000ull;
const uint64_t kMaxExternalFile = 0xffffffffull; /* tinygltf sizes are 32-bit */

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

/* ---- files (rules in gltf_uri.c) -------------------------------------------------------- */

/* rd_gltf_read_file's allocator for tinygltf's vector. */
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
    VectorSink sink{out, false};
    char why[256] = "";
    rd_gltf_read_status st =
        rd_gltf_read_file(path.c_str(), kMaxExternalFile, vector_alloc, &sink, why, sizeof why);
    if (st == RD_GLTF_READ_NO_MEMORY) throw std::bad_alloc();
    if (st != RD_GLTF_READ_OK) {
        *err = why;
        snprintf(files->last_refusal, sizeof files->last_refusal, "%s", why);
        return false;
    }
    files->bytes_in += out->size();
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

/* tinygltf image callback (data URIs and buffer views; ranges were checked in prescan): PNG or
 * JPEG to 8-bit RGBA. Never fails the whole load: a broken image is an error only if a material
 * uses it. */
bool image_callback(tinygltf::Image *image, const int index, std::string *, std::string *, int, int,
                    const unsigned char *bytes, int size, void *user)
{
    LoadContext *ctx = static_cast<LoadContext *>(user);
    ImageFailure f{RD_GLTF_ERR_INVALID, ""};
    char why[256];
    int w = 0, h = 0;
    image->image.clear();
    unsigned char *px = size < 0
                            ? nullptr
                            : rd_gltf_decode_image(&ctx->decoded_bytes, ctx->files.bytes_in, bytes,
                                                   (size_t)size, &w, &h, &f.code, why, sizeof why);
    if (!px) {
        if (size >= 0) f.why = why;
        ctx->image_failures[index] = f;
        return true;
    }
    std::unique_ptr<unsigned char, decltype(&free)> owned(px, &free);
    image->image.assign(px, px + (size_t)w * (size_t)h * 4);
    image->width = w;
    image->height = h;
    image->component = 4;
    image->bits = 8;
    image->pixel_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
    return true;
}

/* ---- container and JSON pre-scan (checks in gltf_prescan.c) ------------------------------ */

/* Throws the C side's failure (gltf_import.h) as the loader's. */
void check(rd_gltf_result r, const char *err)
{
    if (r != RD_GLTF_OK) throw LoadError{r, err};
}

rd_gltf_scan_uint scan_uint(const njson &o, const char *key)
{
    rd_gltf_scan_uint u = {false, false, 0};
    auto it = o.find(key);
    if (it == o.end()) return u;
    u.present = true;
    u.is_uint = it->is_number_unsigned();
    if (u.is_uint) u.value = it->get<uint64_t>();
    return u;
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

/* The members rd_gltf_prescan checks, read with tinygltf's own JSON parser (so both see the
 * same values); strings borrow from doc. */
struct Scan {
    rd_gltf_scan s;
    njson doc;
    std::vector<rd_gltf_str> required;
    std::vector<std::string> rels;
    std::vector<rd_gltf_scan_buffer> buffers;
    std::vector<rd_gltf_scan_view> views;
    std::vector<rd_gltf_scan_image> images;
};

/* Parses the JSON (failing as tinygltf's parser says) and fills scan. */
void scan_json(const rd_gltf_container &c, Scan *scan)
{
    char err[256];
    check(rd_gltf_check_json_depth(c.json, c.json_size, err, sizeof err), err);
    njson::parser_callback_t keep = [](int depth, njson::parse_event_t ev, njson &v) {
        if (depth != 1 || ev != njson::parse_event_t::key || !v.is_string()) return true;
        const std::string &k = v.get_ref<const std::string &>();
        return k == "asset" || k == "buffers" || k == "bufferViews" || k == "images" ||
               k == "extensionsRequired";
    };
    njson &doc = scan->doc;
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

    rd_gltf_scan &s = scan->s;
    memset(&s, 0, sizeof s);
    auto asset = doc.find("asset");
    s.has_version = asset != doc.end() && asset->is_object() && asset->contains("version") &&
                    (*asset)["version"].is_string();
    if (s.has_version) {
        const std::string &version = (*asset)["version"].get_ref<const std::string &>();
        s.version = {version.c_str(), version.size()};
    }
    auto req = doc.find("extensionsRequired");
    s.has_required = req != doc.end();
    s.required_is_array = s.has_required && req->is_array();
    if (s.required_is_array)
        for (const njson &e : *req) {
            const std::string *name = e.is_string() ? &e.get_ref<const std::string &>() : nullptr;
            scan->required.push_back({name ? name->c_str() : nullptr, name ? name->size() : 0});
        }
    static const njson empty = njson::array();
    const char *const keys[3] = {"buffers", "bufferViews", "images"};
    const njson *members[3];
    for (int m = 0; m < 3; m++) {
        auto it = doc.find(keys[m]);
        s.not_array[m] = it != doc.end() && !it->is_array();
        members[m] = it != doc.end() && it->is_array() ? &*it : &empty;
    }
    scan->rels.reserve(members[0]->size());
    for (const njson &b : *members[0]) {
        rd_gltf_scan_buffer sb;
        memset(&sb, 0, sizeof sb);
        sb.is_object = b.is_object();
        sb.data_size = -1;
        auto uri = sb.is_object ? b.find("uri") : b.end();
        if (sb.is_object) sb.byte_length = scan_uint(b, "byteLength");
        sb.has_uri = sb.is_object && uri != b.end() && uri->is_string();
        if (sb.has_uri) {
            const std::string &u = uri->get_ref<const std::string &>();
            sb.uri = {u.c_str(), u.size()};
            sb.data_size = data_uri_size(u);
            if (sb.data_size < 0) {
                scan->rels.push_back(tinygltf::dlib::urldecode(u));
                sb.rel = {scan->rels.back().c_str(), scan->rels.back().size()};
            }
        }
        scan->buffers.push_back(sb);
    }
    for (const njson &v : *members[1]) {
        rd_gltf_scan_view sv;
        memset(&sv, 0, sizeof sv);
        sv.is_object = v.is_object();
        if (sv.is_object) {
            sv.buffer = scan_uint(v, "buffer");
            sv.byte_offset = scan_uint(v, "byteOffset");
            sv.byte_length = scan_uint(v, "byteLength");
        }
        scan->views.push_back(sv);
    }
    for (const njson &im : *members[2]) {
        rd_gltf_scan_image si;
        memset(&si, 0, sizeof si);
        si.is_object = im.is_object();
        si.has_view = si.is_object && im.contains("bufferView");
        if (si.has_view) si.view = scan_uint(im, "bufferView");
        scan->images.push_back(si);
    }
    s.required = scan->required.data();
    s.required_count = scan->required.size();
    s.buffers = scan->buffers.data();
    s.buffer_count = scan->buffers.size();
    s.views = scan->views.data();
    s.view_count = scan->views.size();
    s.images = scan->images.data();
    s.image_count = scan->images.size();
}

/* Checks what tinygltf would use unchecked, with messages that name the culprit. */
void prescan(const rd_gltf_container &c, LoadContext *ctx)
{
    Scan scan;
    scan_json(c, &scan);
    char err[1024];
    check(rd_gltf_prescan(&scan.s, &c, &ctx->files, err, sizeof err), err);
}

/* ---- the C view of tinygltf's model (gltf_document.h) ------------------------------------ */

static_assert(TINYGLTF_COMPONENT_TYPE_BYTE == RD_GLTF_BYTE &&
                  TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE == RD_GLTF_UNSIGNED_BYTE &&
                  TINYGLTF_COMPONENT_TYPE_SHORT == RD_GLTF_SHORT &&
                  TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT == RD_GLTF_UNSIGNED_SHORT &&
                  TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT == RD_GLTF_UNSIGNED_INT &&
                  TINYGLTF_COMPONENT_TYPE_FLOAT == RD_GLTF_FLOAT,
              "gltf_import.h numbers component types as tinygltf does");
static_assert(TINYGLTF_MODE_TRIANGLES == RD_GLTF_MODE_TRIANGLES &&
                  TINYGLTF_MODE_TRIANGLE_STRIP == RD_GLTF_MODE_TRIANGLE_STRIP &&
                  TINYGLTF_MODE_TRIANGLE_FAN == RD_GLTF_MODE_TRIANGLE_FAN &&
                  TINYGLTF_MODE_LINE_STRIP == RD_GLTF_MODE_LINE_STRIP,
              "gltf_import.h numbers primitive modes as tinygltf does");
static_assert(TINYGLTF_TYPE_SCALAR == RD_GLTF_TYPE_SCALAR &&
                  TINYGLTF_TYPE_VEC2 == RD_GLTF_TYPE_VEC2 &&
                  TINYGLTF_TYPE_VEC3 == RD_GLTF_TYPE_VEC3 &&
                  TINYGLTF_TYPE_VEC4 == RD_GLTF_TYPE_VEC4 &&
                  TINYGLTF_TYPE_MAT2 == RD_GLTF_TYPE_MAT2 &&
                  TINYGLTF_TYPE_MAT3 == RD_GLTF_TYPE_MAT3 &&
                  TINYGLTF_TYPE_MAT4 == RD_GLTF_TYPE_MAT4,
              "gltf_document.h numbers accessor types as tinygltf does");
static_assert(TINYGLTF_TEXTURE_WRAP_REPEAT == RD_GLTF_WRAP_REPEAT &&
                  TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE == RD_GLTF_WRAP_CLAMP &&
                  TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT == RD_GLTF_WRAP_MIRROR &&
                  TINYGLTF_TEXTURE_FILTER_NEAREST == RD_GLTF_FILTER_NEAREST,
              "gltf_document.h numbers sampler values as tinygltf does");

rd_gltf_str str(const std::string &s)
{
    return {s.c_str(), s.size()};
}

const char *name_or_null(const std::string &s)
{
    return s.empty() ? nullptr : s.c_str();
}

/* The arrays an rd_gltf_document points to; strings and data borrow from the model. */
struct Document {
    rd_gltf_document d;
    std::vector<rd_gltf_str> extensions_used, buffers;
    std::vector<rd_gltf_doc_buffer_view> views;
    std::vector<rd_gltf_doc_accessor> accessors;
    std::vector<std::string> rels; /* decoded image URIs (not data: URIs) */
    std::vector<rd_gltf_doc_image> images;
    std::vector<rd_gltf_doc_texture> textures;
    std::vector<rd_gltf_doc_sampler> samplers;
    std::vector<std::vector<rd_gltf_str>> material_extensions;
    std::vector<rd_gltf_doc_material> materials;
    std::vector<std::vector<rd_gltf_doc_primitive>> primitives;
    std::vector<std::vector<std::vector<rd_gltf_doc_target>>> targets; /* mesh, primitive */
    std::vector<rd_gltf_doc_mesh> meshes;
    std::vector<rd_gltf_doc_skin> skins;
    std::vector<rd_gltf_doc_node> nodes;
    std::vector<rd_gltf_node_list> children, scenes;
    std::vector<rd_gltf_doc_camera> cameras;
    std::vector<rd_gltf_doc_light> lights;
    std::vector<std::vector<rd_gltf_doc_channel>> channels;
    std::vector<std::vector<rd_gltf_doc_anim_sampler>> anim_samplers;
    std::vector<rd_gltf_doc_animation> animations;
};

template <class T> void set(const T **p, size_t *n, const std::vector<T> &v)
{
    *p = v.data();
    *n = v.size();
}

rd_gltf_texture_ref ref(const tinygltf::TextureInfo &t)
{
    return {t.index, t.texCoord};
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

/* Copies what the conversion reads out of m (no checks: gltf_convert.c does them). */
void make_document(const Model &m, const LoadContext &ctx, Document *doc)
{
    for (const std::string &e : m.extensionsUsed)
        doc->extensions_used.push_back(str(e));
    for (const tinygltf::Buffer &b : m.buffers)
        doc->buffers.push_back({reinterpret_cast<const char *>(b.data.data()), b.data.size()});
    for (const tinygltf::BufferView &v : m.bufferViews)
        doc->views.push_back({v.buffer, v.byteOffset, v.byteLength, v.byteStride});
    for (const tinygltf::Accessor &a : m.accessors)
        doc->accessors.push_back({a.bufferView, a.byteOffset, a.normalized, a.componentType, a.type,
                                  a.count, a.sparse.isSparse, a.sparse.count,
                                  a.sparse.indices.bufferView, a.sparse.indices.byteOffset,
                                  a.sparse.indices.componentType, a.sparse.values.bufferView,
                                  a.sparse.values.byteOffset});
    for (const tinygltf::Image &img : m.images) /* data: URIs are never opened as files */
        doc->rels.push_back(img.uri.compare(0, 5, "data:") == 0
                                ? std::string()
                                : tinygltf::dlib::urldecode(img.uri));
    for (size_t i = 0; i < m.images.size(); i++) {
        const tinygltf::Image &img = m.images[i];
        rd_gltf_doc_image di;
        memset(&di, 0, sizeof di);
        di.name = str(img.name);
        di.uri = str(img.uri);
        di.rel = str(doc->rels[i]);
        di.rgba = img.image.data();
        di.rgba_size = img.image.size();
        di.width = img.width;
        di.height = img.height;
        auto failed = ctx.image_failures.find((int)i);
        if (failed != ctx.image_failures.end()) {
            di.failed = true;
            di.failure = failed->second.code;
            di.why = failed->second.why.c_str();
        }
        doc->images.push_back(di);
    }
    for (const tinygltf::Texture &t : m.textures)
        doc->textures.push_back({t.source, t.sampler});
    for (const tinygltf::Sampler &s : m.samplers)
        doc->samplers.push_back({s.wrapS, s.wrapT, s.magFilter});
    doc->material_extensions.resize(m.materials.size());
    for (size_t i = 0; i < m.materials.size(); i++) {
        const tinygltf::Material &g = m.materials[i];
        for (const auto &e : g.extensions)
            doc->material_extensions[i].push_back(str(e.first));
        const tinygltf::PbrMetallicRoughness &pbr = g.pbrMetallicRoughness;
        doc->materials.push_back({name_or_null(g.name),
                                  factors(g),
                                  ref(pbr.baseColorTexture),
                                  ref(g.emissiveTexture),
                                  ref(pbr.metallicRoughnessTexture),
                                  {g.normalTexture.index, g.normalTexture.texCoord},
                                  {g.occlusionTexture.index, g.occlusionTexture.texCoord},
                                  doc->material_extensions[i].data(),
                                  doc->material_extensions[i].size()});
    }
    doc->primitives.resize(m.meshes.size());
    doc->targets.resize(m.meshes.size());
    for (size_t i = 0; i < m.meshes.size(); i++) {
        doc->targets[i].resize(m.meshes[i].primitives.size());
        for (const tinygltf::Primitive &gp : m.meshes[i].primitives) {
            rd_gltf_doc_primitive p;
            memset(&p, 0, sizeof p);
            p.mode = gp.mode;
            p.indices = gp.indices;
            p.material = gp.material;
            auto attr = [&](const char *name, bool *has, int *index) {
                auto it = gp.attributes.find(name);
                *has = it != gp.attributes.end();
                *index = *has ? it->second : -1;
            };
            attr("POSITION", &p.has_pos, &p.pos);
            attr("NORMAL", &p.has_nrm, &p.nrm);
            attr("TEXCOORD_0", &p.has_uv, &p.uv);
            attr("TANGENT", &p.has_tan, &p.tan);
            bool has; /* skins and morph targets: -1 where not given */
            const char *const sets[4] = {"JOINTS_0", "JOINTS_1", "WEIGHTS_0", "WEIGHTS_1"};
            for (int k = 0; k < 4; k++)
                attr(sets[k], &has, k < 2 ? &p.joints[k] : &p.weights[k - 2]);
            std::vector<rd_gltf_doc_target> &tv = doc->targets[i][doc->primitives[i].size()];
            for (const std::map<std::string, int> &t : gp.targets) {
                auto get = [&](const char *name) {
                    auto it = t.find(name);
                    return it == t.end() ? -1 : it->second;
                };
                tv.push_back({get("POSITION"), get("NORMAL"), get("TANGENT")});
            }
            p.targets = tv.data();
            p.target_count = tv.size();
            doc->primitives[i].push_back(p);
        }
        const std::vector<double> &w = m.meshes[i].weights;
        doc->meshes.push_back({str(m.meshes[i].name), doc->primitives[i].data(),
                               doc->primitives[i].size(), w.data(), w.size()});
    }
    for (const tinygltf::Skin &k : m.skins)
        doc->skins.push_back(
            {str(k.name), k.joints.data(), k.joints.size(), k.inverseBindMatrices});
    for (const tinygltf::Node &g : m.nodes) {
        rd_gltf_doc_node n;
        memset(&n, 0, sizeof n);
        n.name = str(g.name);
        n.mesh = g.mesh;
        n.camera = g.camera;
        auto ext = g.extensions.find("KHR_lights_punctual");
        n.has_light = ext != g.extensions.end();
        if (n.has_light) {
            const tinygltf::Value &li = ext->second.Get("light");
            n.light_is_int = li.IsInt();
            n.light = li.IsInt() ? li.GetNumberAsInt() : 0;
        }
        n.transform = {g.matrix.data(), g.translation.data(), g.rotation.data(), g.scale.data(),
                       g.matrix.size(), g.translation.size(), g.rotation.size(), g.scale.size()};
        n.skin = g.skin;
        n.weights = g.weights.data();
        n.weight_count = g.weights.size();
        doc->nodes.push_back(n);
        doc->children.push_back({g.children.data(), g.children.size()});
    }
    for (const tinygltf::Scene &s : m.scenes)
        doc->scenes.push_back({s.nodes.data(), s.nodes.size()});
    for (const tinygltf::Camera &c : m.cameras)
        doc->cameras.push_back({str(c.name), str(c.type), c.perspective.yfov, c.perspective.znear,
                                c.perspective.aspectRatio});
    for (const tinygltf::Light &l : m.lights)
        doc->lights.push_back(
            {name_or_null(l.name),
             {l.type.data(), l.type.size(), l.color.data(), l.color.size(), l.intensity, l.range,
              l.spot.innerConeAngle, l.spot.outerConeAngle}});
    doc->channels.resize(m.animations.size());
    doc->anim_samplers.resize(m.animations.size());
    for (size_t i = 0; i < m.animations.size(); i++) {
        const tinygltf::Animation &a = m.animations[i];
        for (const tinygltf::AnimationChannel &c : a.channels)
            doc->channels[i].push_back({c.sampler, c.target_node, str(c.target_path)});
        for (const tinygltf::AnimationSampler &s : a.samplers)
            doc->anim_samplers[i].push_back({s.input, s.output, str(s.interpolation)});
        doc->animations.push_back({str(a.name), doc->channels[i].data(), doc->channels[i].size(),
                                   doc->anim_samplers[i].data(), doc->anim_samplers[i].size()});
    }
    rd_gltf_document &d = doc->d;
    memset(&d, 0, sizeof d);
    set(&d.skins, &d.skin_count, doc->skins);
    d.default_scene = m.defaultScene;
    set(&d.extensions_used, &d.extensions_used_count, doc->extensions_used);
    set(&d.buffers, &d.buffer_count, doc->buffers);
    set(&d.views, &d.view_count, doc->views);
    set(&d.accessors, &d.accessor_count, doc->accessors);
    set(&d.images, &d.image_count, doc->images);
    set(&d.textures, &d.texture_count, doc->textures);
    set(&d.samplers, &d.sampler_count, doc->samplers);
    set(&d.materials, &d.material_count, doc->materials);
    set(&d.meshes, &d.mesh_count, doc->meshes);
    set(&d.children, &d.node_count, doc->children);
    set(&d.nodes, &d.node_count, doc->nodes);
    set(&d.scenes, &d.scene_count, doc->scenes);
    set(&d.cameras, &d.camera_count, doc->cameras);
    set(&d.lights, &d.light_count, doc->lights);
    set(&d.animations, &d.animation_count, doc->animations);
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
    ctx.files.bytes_in = size;
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
    Document doc;
    make_document(model, ctx, &doc);
    char err[1024];
    check(rd_gltf_convert(&doc.d, &ctx.files, &ctx.decoded_bytes, max_tris, out, err, sizeof err),
          err);
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
    rd_gltf_write_text(msg.data(), msg.size(), err, errlen);
    return code;
}

} // namespace

extern "C" rd_gltf_result rd_gltf_load_memory(const void *data, size_t size, const char *base_dir,
                                              const rd_gltf_options *opt, rd_scene *out, char *err,
                                              size_t errlen)
{
    if (!out) {
        rd_gltf_write_text("no output scene was given", 25, err, errlen);
        return RD_GLTF_ERR_INVALID;
    }
    rd_scene_init(out);
    return guarded(static_cast<const unsigned char *>(data), size, base_dir, opt, out, err, errlen);
}
