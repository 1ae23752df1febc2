/* gltf_image.c: decoding a glTF image (PNG or JPEG, any channel count, 8 or 16 bit) to 8-bit
 * RGBA with stb_image, under size limits (see gltf_import.h). */
#include "renderer/gltf/gltf_import.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>

/* stb declares static functions it leaves undefined under STBI_ONLY_*; GCC reports those at the
 * end of the file, so this one stays off for the whole file. */
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wtype-limits"
#pragma GCC diagnostic ignored "-Wunused-but-set-variable"
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#define STBI_NO_STDIO
#include <stb/stb_image.h>
#pragma GCC diagnostic pop

enum { MAX_IMAGE_DIM = 16384 };
static const uint64_t kMaxImagePixels = 1ull << 26; /* 256 MiB as RGBA8 */

uint64_t rd_gltf_decode_limit(uint64_t bytes_in)
{
    uint64_t scaled = bytes_in > RD_GLTF_DECODE_MAX / RD_GLTF_DECODE_RATIO
                          ? RD_GLTF_DECODE_MAX
                          : bytes_in * RD_GLTF_DECODE_RATIO;
    return scaled < RD_GLTF_DECODE_FLOOR ? RD_GLTF_DECODE_FLOOR : scaled;
}

unsigned char *rd_gltf_decode_image(uint64_t *decoded_bytes, uint64_t bytes_in,
                                    const unsigned char *bytes, size_t size, int *w, int *h,
                                    rd_gltf_result *code, char *why, size_t whylen)
{
    int comp = 0;
    *code = RD_GLTF_ERR_INVALID;
    if (size == 0 || size > (size_t)INT_MAX) {
        snprintf(why, whylen, "%s", size ? "its data is too large" : "its data is empty");
        return NULL;
    }
    if (!stbi_info_from_memory(bytes, (int)size, w, h, &comp)) {
        const char *r = stbi_failure_reason();
        snprintf(why, whylen, "it is not a PNG or JPEG image stb_image can read (%s)",
                 r ? r : "unknown");
        return NULL;
    }
    if (*w < 1 || *h < 1 || *w > MAX_IMAGE_DIM || *h > MAX_IMAGE_DIM ||
        (uint64_t)*w * (uint64_t)*h > kMaxImagePixels) {
        *code = RD_GLTF_ERR_TOO_LARGE;
        snprintf(why, whylen,
                 "its size %dx%d exceeds the limit (%d pixels a side, %llu Mi pixels in all)", *w,
                 *h, MAX_IMAGE_DIM, (unsigned long long)(kMaxImagePixels >> 20));
        return NULL;
    }
    uint64_t bytes_out = (uint64_t)*w * (uint64_t)*h * 4;
    uint64_t limit = rd_gltf_decode_limit(bytes_in);
    if (*decoded_bytes + bytes_out > limit) {
        *code = RD_GLTF_ERR_TOO_LARGE;
        snprintf(why, whylen,
                 "its size %dx%d would take all decoded images together past %llu MiB (a file "
                 "of %llu KiB may decode to %u times its size, at least %llu MiB, at most %llu "
                 "MiB)",
                 *w, *h, (unsigned long long)(limit >> 20), (unsigned long long)(bytes_in >> 10),
                 RD_GLTF_DECODE_RATIO, (unsigned long long)(RD_GLTF_DECODE_FLOOR >> 20),
                 (unsigned long long)(RD_GLTF_DECODE_MAX >> 20));
        return NULL;
    }
    int w2 = 0, h2 = 0;
    unsigned char *px = stbi_load_from_memory(bytes, (int)size, &w2, &h2, &comp, 4);
    if (!px || w2 != *w || h2 != *h) {
        const char *r = stbi_failure_reason();
        snprintf(why, whylen, "it could not be decoded (%s)", r ? r : "unknown");
        stbi_image_free(px);
        return NULL;
    }
    *decoded_bytes += bytes_out;
    return px;
}
