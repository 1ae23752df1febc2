/* gltf_prescan.c: checks of the JSON members tinygltf 2.7 would use unchecked (asset version,
 * extensionsRequired, buffers, buffer views, image buffer views), run before tinygltf parses
 * the file, with messages that name the culprit (see gltf_document.h). */
#include "renderer/gltf/gltf_document.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define fail rd_gltf_fail

/* A member that must be absent (when not required) or an unsigned integer. */
static bool json_uint(rd_gltf_scan_uint u, bool required, uint64_t *out)
{
    if (!u.present) return !required;
    if (!u.is_uint) return false;
    *out = u.value;
    return true;
}

/* An index-valued member that must lie in [0, count). */
static bool json_index(rd_gltf_scan_uint u, size_t count, size_t *out)
{
    if (!u.present || !u.is_uint || u.value >= count) return false;
    *out = (size_t)u.value;
    return true;
}

static bool starts_with(rd_gltf_str s, const char *prefix)
{
    size_t n = strlen(prefix);
    return s.len >= n && memcmp(s.s, prefix, n) == 0;
}

/* Buffer i's byteLength against its data: URI, the GLB BIN chunk or its external file. */
static rd_gltf_result check_buffer(const rd_gltf_scan_buffer *b, size_t i,
                                   const rd_gltf_container *c, const rd_gltf_files *files,
                                   uint64_t *length, char *err, size_t errlen)
{
    uint64_t len = 0;
    if (!b->is_object || !json_uint(b->byte_length, true, &len) || len == 0)
        return fail(err, errlen, RD_GLTF_ERR_INVALID, "buffer %zu has no valid byteLength", i);
    *length = len;
    if (!b->has_uri) {
        if (!c->glb) return fail(err, errlen, RD_GLTF_ERR_INVALID, "buffer %zu has no uri", i);
        if (c->bin_size == 0)
            return fail(err, errlen, RD_GLTF_ERR_INVALID,
                        "buffer %zu has no uri and the GLB file has no BIN chunk", i);
        if (len > c->bin_size)
            return fail(err, errlen, RD_GLTF_ERR_INVALID,
                        "buffer %zu needs %llu bytes but the GLB BIN chunk holds only %zu", i,
                        (unsigned long long)len, c->bin_size);
        return RD_GLTF_OK;
    }
    if (b->data_size >= 0) {
        if ((uint64_t)b->data_size != len)
            return fail(err, errlen, RD_GLTF_ERR_INVALID,
                        "buffer %zu: its data URI holds %lld bytes but byteLength is %llu", i,
                        b->data_size, (unsigned long long)len);
        return RD_GLTF_OK;
    }
    char shown[65]; /* the URI, at most 64 bytes */
    size_t n = b->uri.len > 64 ? 61 : b->uri.len;
    memcpy(shown, b->uri.s, n);
    strcpy(shown + n, b->uri.len > 64 ? "..." : "");
    if (starts_with(b->uri, "data:"))
        return fail(err, errlen, RD_GLTF_ERR_UNSUPPORTED,
                    "buffer %zu has a data URI that is not base64 of a known media type", i);
    char why[256] = "";
    const char *refusal = rd_gltf_uri_refusal(files, b->rel.s, b->rel.len);
    struct stat st;
    if (refusal) {
        strcpy(why, refusal);
    } else {
        char *path = rd_gltf_files_join(files, b->rel.s, b->rel.len);
        if (stat(path, &st) != 0)
            rd_gltf_errno_text(errno, why, sizeof why);
        else if (!S_ISREG(st.st_mode))
            strcpy(why, "it is not a regular file");
        free(path);
    }
    if (why[0])
        return fail(err, errlen, RD_GLTF_ERR_IO, "buffer %zu '%s' could not be loaded: %s", i,
                    shown, why);
    if ((uint64_t)st.st_size != len)
        return fail(err, errlen, RD_GLTF_ERR_INVALID,
                    "buffer %zu '%s' has %lld bytes but byteLength is %llu", i, shown,
                    (long long)st.st_size, (unsigned long long)len);
    return RD_GLTF_OK;
}

rd_gltf_result rd_gltf_prescan(const rd_gltf_scan *s, const rd_gltf_container *c,
                               const rd_gltf_files *files, char *err, size_t errlen)
{
    if (!s->has_version)
        return fail(err, errlen, RD_GLTF_ERR_INVALID,
                    "the file has no asset.version, so it is not a glTF file");
    if (!starts_with(s->version, "2."))
        return fail(err, errlen, RD_GLTF_ERR_UNSUPPORTED,
                    "glTF version '%.16s' is not supported (only 2.x)", s->version.s);
    if (s->has_required) {
        if (!s->required_is_array)
            return fail(err, errlen, RD_GLTF_ERR_INVALID, "extensionsRequired is not an array");
        for (size_t i = 0; i < s->required_count; i++) {
            rd_gltf_str name = s->required[i];
            if (!name.s)
                return fail(err, errlen, RD_GLTF_ERR_INVALID,
                            "extensionsRequired holds a value that is not a name");
            if (!rd_gltf_extension_supported(name.s, name.len))
                return fail(err, errlen, RD_GLTF_ERR_UNSUPPORTED,
                            "the file requires extension %.80s, which is not supported", name.s);
        }
    }
    static const char *const members[] = {"buffers", "bufferViews", "images"};
    for (size_t m = 0; m < 3; m++)
        if (s->not_array[m])
            return fail(err, errlen, RD_GLTF_ERR_INVALID, "%s is not an array", members[m]);

    uint64_t *buffer_len = calloc(s->buffer_count + 1, sizeof *buffer_len);
    uint64_t *view_len = calloc(s->view_count + 1, sizeof *view_len);
    if (!buffer_len || !view_len) {
        fprintf(stderr, "probecast: out of memory (%zu buffers, %zu views)\n", s->buffer_count,
                s->view_count);
        abort();
    }
    rd_gltf_result r = RD_GLTF_OK;
    for (size_t i = 0; i < s->buffer_count && r == RD_GLTF_OK; i++)
        r = check_buffer(&s->buffers[i], i, c, files, &buffer_len[i], err, errlen);
    for (size_t i = 0; i < s->view_count && r == RD_GLTF_OK; i++) {
        const rd_gltf_scan_view *v = &s->views[i];
        size_t b = 0;
        uint64_t off = 0, len = 0;
        if (!v->is_object || !json_index(v->buffer, s->buffer_count, &b))
            r = fail(err, errlen, RD_GLTF_ERR_INVALID,
                     "buffer view %zu does not refer to an existing buffer", i);
        else if (!json_uint(v->byte_offset, false, &off) ||
                 !json_uint(v->byte_length, true, &len) || len == 0)
            r = fail(err, errlen, RD_GLTF_ERR_INVALID,
                     "buffer view %zu has an invalid byteOffset or byteLength", i);
        else if (off > buffer_len[b] || len > buffer_len[b] - off)
            r = fail(err, errlen, RD_GLTF_ERR_INVALID,
                     "buffer view %zu (offset %llu, length %llu) does not fit in buffer %zu (%llu "
                     "bytes)",
                     i, (unsigned long long)off, (unsigned long long)len, b,
                     (unsigned long long)buffer_len[b]);
        view_len[i] = len;
    }
    for (size_t i = 0; i < s->image_count && r == RD_GLTF_OK; i++) {
        const rd_gltf_scan_image *im = &s->images[i];
        size_t v = 0;
        if (!im->is_object || !im->has_view) continue;
        if (!json_index(im->view, s->view_count, &v))
            r = fail(err, errlen, RD_GLTF_ERR_INVALID,
                     "image %zu does not refer to an existing buffer view", i);
        else if (view_len[v] > (uint64_t)INT_MAX)
            r = fail(err, errlen, RD_GLTF_ERR_TOO_LARGE, "image %zu is larger than 2 GiB", i);
    }
    free(buffer_len);
    free(view_len);
    return r;
}
