/* gltf_container.c: the GLB container and the JSON nesting pre-check (see gltf_import.h); the
 * importer's messages (rd_gltf_fail, rd_gltf_write_text, rd_gltf_strerror). */
#include "renderer/gltf/gltf_import.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

rd_gltf_result rd_gltf_fail(char *err, size_t errlen, rd_gltf_result code, const char *fmt, ...)
{
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return code;
}

void rd_gltf_write_text(const char *msg, size_t len, char *err, size_t errlen)
{
    if (!err || errlen == 0) return;
    size_t n = len < errlen - 1 ? len : errlen - 1;
    for (size_t i = 0; i < n; i++) {
        unsigned char ch = (unsigned char)msg[i];
        err[i] = (ch < 0x20 || ch >= 0x7f) ? '?' : (char)ch;
    }
    err[n] = '\0';
}

const char *rd_gltf_strerror(rd_gltf_result r)
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

#define fail rd_gltf_fail

static uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

rd_gltf_result rd_gltf_parse_container(const unsigned char *data, size_t size, rd_gltf_container *c,
                                       char *err, size_t errlen)
{
    memset(c, 0, sizeof *c);
    if (size == 0) return fail(err, errlen, RD_GLTF_ERR_PARSE, "the file is empty");
    if (size < 4 || memcmp(data, "glTF", 4) != 0) {
        c->json = (const char *)data;
        c->json_size = size;
        return RD_GLTF_OK;
    }
    c->glb = true;
    if (size < 12)
        return fail(err, errlen, RD_GLTF_ERR_PARSE,
                    "the GLB file is truncated: its 12-byte header is incomplete");
    uint32_t version = le32(data + 4), length = le32(data + 8);
    if (version != 2)
        return fail(err, errlen, RD_GLTF_ERR_UNSUPPORTED,
                    "GLB version %u is not supported (only 2)", version);
    if (length > size)
        return fail(err, errlen, RD_GLTF_ERR_PARSE,
                    "the GLB file is truncated: its header declares %u bytes but only %zu are "
                    "present",
                    length, size);
    if (length < 20)
        return fail(err, errlen, RD_GLTF_ERR_PARSE,
                    "the GLB file is truncated: it has no JSON chunk");
    uint32_t json_len = le32(data + 12), json_type = le32(data + 16);
    if (json_type != 0x4E4F534Au)
        return fail(err, errlen, RD_GLTF_ERR_PARSE,
                    "the first chunk of the GLB file is not its JSON chunk");
    if (json_len == 0 || json_len % 4 != 0)
        return fail(err, errlen, RD_GLTF_ERR_PARSE,
                    "the GLB JSON chunk length %u is not a positive multiple of 4", json_len);
    if ((uint64_t)json_len > (uint64_t)length - 20)
        return fail(err, errlen, RD_GLTF_ERR_PARSE,
                    "the GLB file is truncated: its JSON chunk needs %u bytes but only %u remain",
                    json_len, length - 20);
    c->json = (const char *)data + 20;
    c->json_size = json_len;
    uint64_t at = 20ull + json_len;
    if (at < length) {
        if (length - at < 12)
            return fail(err, errlen, RD_GLTF_ERR_PARSE,
                        "the GLB file is truncated inside its BIN chunk header");
        uint32_t bin_len = le32(data + at), bin_type = le32(data + at + 4);
        if (bin_type != 0x004E4942u)
            return fail(err, errlen, RD_GLTF_ERR_PARSE,
                        "the second chunk of the GLB file is not a BIN chunk");
        if (bin_len < 4 || bin_len % 4 != 0)
            return fail(err, errlen, RD_GLTF_ERR_PARSE,
                        "the GLB BIN chunk length %u is not a positive multiple of 4", bin_len);
        if ((uint64_t)bin_len > length - at - 8)
            return fail(err, errlen, RD_GLTF_ERR_PARSE,
                        "the GLB file is truncated: its BIN chunk needs %u bytes but only %llu "
                        "remain",
                        bin_len, (unsigned long long)(length - at - 8));
        c->bin_size = bin_len;
    }
    return RD_GLTF_OK;
}

rd_gltf_result rd_gltf_check_json_depth(const char *s, size_t n, char *err, size_t errlen)
{
    int depth = 0;
    bool in_string = false, escaped = false;
    for (size_t i = 0; i < n; i++) {
        char ch = s[i];
        if (in_string) {
            if (escaped)
                escaped = false;
            else if (ch == '\\')
                escaped = true;
            else if (ch == '"')
                in_string = false;
        } else if (ch == '"') {
            in_string = true;
        } else if (ch == '[' || ch == '{') {
            if (++depth > RD_GLTF_MAX_JSON_DEPTH)
                return fail(err, errlen, RD_GLTF_ERR_PARSE,
                            "the glTF JSON nests deeper than %d levels", RD_GLTF_MAX_JSON_DEPTH);
        } else if (ch == ']' || ch == '}') {
            depth--;
        }
    }
    return RD_GLTF_OK;
}
