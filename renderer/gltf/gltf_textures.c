/* gltf_textures.c: a material's texture to an rd_texture — its image (decoded while parsing,
 * or an external file read and decoded here under gltf_uri.c's rules) and its sampler (see
 * gltf_document.h). */
#include "renderer/gltf/gltf_document.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const uint64_t kMaxExternalFile = 0xffffffffull; /* tinygltf sizes are 32-bit */

/* wrapS/wrapT of sampler `sampler` to RD_WRAP_*. */
static rd_gltf_result wrap(rd_gltf_conv *c, int sampler, int mode, uint32_t *out)
{
    switch (mode) {
    case RD_GLTF_WRAP_REPEAT:
        *out = RD_WRAP_REPEAT;
        return RD_GLTF_OK;
    case RD_GLTF_WRAP_CLAMP:
        *out = RD_WRAP_CLAMP;
        return RD_GLTF_OK;
    case RD_GLTF_WRAP_MIRROR:
        *out = RD_WRAP_MIRROR;
        return RD_GLTF_OK;
    default:
        return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                            "sampler %d has an invalid wrap mode %d", sampler, mode);
    }
}

/* Reads and decodes the external image file img names into *rgba (malloc'd). */
static rd_gltf_result read_external(rd_gltf_conv *c, const rd_gltf_doc_image *img, const char *what,
                                    unsigned char **rgba, int *w, int *h)
{
    if (img->uri.len == 0)
        return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID, "%s has no data", what);
    if (img->uri.len >= 5 && memcmp(img->uri.s, "data:", 5) == 0)
        return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_UNSUPPORTED,
                            "%s has a data URI that is not base64 PNG or JPEG data", what);
    const char *refusal = rd_gltf_uri_refusal(c->files, img->rel.s, img->rel.len);
    if (refusal)
        return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_IO, "%s could not be loaded: %s", what,
                            refusal);
    char why[256] = "";
    unsigned char *file;
    size_t size;
    char *path = rd_gltf_files_join(c->files, img->rel.s, img->rel.len);
    rd_gltf_read_status st =
        rd_gltf_read_file_malloc(path, kMaxExternalFile, &file, &size, why, sizeof why);
    free(path);
    if (st != RD_GLTF_READ_OK) {
        if (st == RD_GLTF_READ_NO_MEMORY)
            return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_TOO_LARGE,
                                "the file needs more memory than is available");
        return rd_gltf_fail(c->err, c->errlen,
                            st == RD_GLTF_READ_TOO_LARGE ? RD_GLTF_ERR_TOO_LARGE : RD_GLTF_ERR_IO,
                            "%s could not be loaded: %s", what, why);
    }
    rd_gltf_result code;
    c->files->bytes_in += size;
    *rgba = rd_gltf_decode_image(c->decoded_bytes, c->files->bytes_in, file, size, w, h, &code,
                                 why, sizeof why);
    free(file);
    if (!*rgba)
        return rd_gltf_fail(c->err, c->errlen, code, "%s could not be decoded: %s", what, why);
    return RD_GLTF_OK;
}

rd_gltf_result rd_gltf_conv_texture(rd_gltf_conv *c, rd_gltf_texture_ref ref, size_t material,
                                    const char *slot, int32_t *out)
{
    const rd_gltf_document *d = c->doc;
    int index = ref.index;
    *out = -1;
    if (index < 0) return RD_GLTF_OK;
    if ((size_t)index >= d->texture_count)
        return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                            "material %zu refers to texture %d, but there are only %zu textures",
                            material, index, d->texture_count);
    if (ref.tex_coord != 0) {
        rd_scene_warn(c->s,
                      "material %zu reads its %s texture with TEXCOORD_%d; only TEXCOORD_0 "
                      "is supported, so the texture is ignored",
                      material, slot, ref.tex_coord);
        return RD_GLTF_OK;
    }
    if (c->tex_map[index] >= 0) {
        *out = c->tex_map[index];
        return RD_GLTF_OK;
    }

    const rd_gltf_doc_texture *t = &d->textures[index];
    if (t->source < 0 || (size_t)t->source >= d->image_count)
        return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                            "texture %d refers to image %d, but there are only %zu images", index,
                            t->source, d->image_count);
    const rd_gltf_doc_image *img = &d->images[t->source];
    char what[RD_GLTF_LABEL_MAX];
    bool by_uri = img->name.len == 0 && img->uri.len > 0 &&
                  !(img->uri.len >= 5 && memcmp(img->uri.s, "data:", 5) == 0);
    rd_gltf_label("image", (size_t)t->source, by_uri ? img->uri : img->name, what);
    if (img->failed)
        return rd_gltf_fail(c->err, c->errlen, img->failure, "%s could not be decoded: %s", what,
                            img->why);

    rd_texture rt;
    memset(&rt, 0, sizeof rt);
    int w = img->width, h = img->height;
    size_t size = img->rgba_size;
    if (size == 0) { /* an external file (tinygltf keeps only its URI) */
        rd_gltf_result r = read_external(c, img, what, &rt.rgba, &w, &h);
        if (r != RD_GLTF_OK) return r;
        size = (size_t)w * (size_t)h * 4;
    }
    if (w < 1 || h < 1 || size != (size_t)w * (size_t)h * 4) {
        free(rt.rgba);
        return rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                            "%s has inconsistent decoded data", what);
    }
    rt.width = (uint32_t)w;
    rt.height = (uint32_t)h;
    rt.wrap_s = rt.wrap_t = RD_WRAP_REPEAT;
    if (t->sampler >= 0) {
        rd_gltf_result r = RD_GLTF_OK;
        if ((size_t)t->sampler >= d->sampler_count)
            r = rd_gltf_fail(c->err, c->errlen, RD_GLTF_ERR_INVALID,
                             "texture %d refers to sampler %d, but there are only %zu samplers",
                             index, t->sampler, d->sampler_count);
        const rd_gltf_doc_sampler *smp = r == RD_GLTF_OK ? &d->samplers[t->sampler] : NULL;
        if (r == RD_GLTF_OK) r = wrap(c, t->sampler, smp->wrap_s, &rt.wrap_s);
        if (r == RD_GLTF_OK) r = wrap(c, t->sampler, smp->wrap_t, &rt.wrap_t);
        if (r != RD_GLTF_OK) {
            free(rt.rgba);
            return r;
        }
        rt.nearest = smp->mag_filter == RD_GLTF_FILTER_NEAREST;
    }
    if (!rt.rgba) {
        rt.rgba = malloc(size);
        if (!rt.rgba) {
            fprintf(stderr, "probecast: out of memory (%zu bytes)\n", size);
            abort();
        }
        memcpy(rt.rgba, img->rgba, size);
    }
    *out = (int32_t)rd_scene_add_texture(c->s, &rt);
    c->tex_map[index] = *out;
    return RD_GLTF_OK;
}
