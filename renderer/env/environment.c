/* environment.c: environment models, format detection, the Radiance .hdr reader and the SH9
 * irradiance (the OpenEXR reader is environment_exr.c). */
#include "renderer/env/environment.h"
#include "renderer/env/environment_reduce.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI_F 3.14159265358979323846f

/* ---- formats ------------------------------------------------------------------------------ */

rd_env_format rd_env_image_format(const uint8_t *d, size_t len)
{
    static const uint8_t exr_magic[4] = {0x76, 0x2f, 0x31, 0x01};
    if (len >= sizeof exr_magic && memcmp(d, exr_magic, sizeof exr_magic) == 0)
        return RD_ENV_FORMAT_EXR;
    if (len >= 2 && d[0] == '#' && d[1] == '?') return RD_ENV_FORMAT_HDR;
    return RD_ENV_FORMAT_UNKNOWN;
}

const char *rd_env_format_extension(rd_env_format f)
{
    switch (f) {
    case RD_ENV_FORMAT_HDR:
        return "hdr";
    case RD_ENV_FORMAT_EXR:
        return "exr";
    default:
        return NULL;
    }
}

bool rd_env_image_parse(const uint8_t *d, size_t len, rd_env_read_desc *desc, rd_env_image *out,
                        char *err, size_t errlen)
{
    switch (rd_env_image_format(d, len)) {
    case RD_ENV_FORMAT_HDR:
        return rd_env_image_parse_hdr(d, len, desc, out, err, errlen);
    case RD_ENV_FORMAT_EXR:
        return rd_env_image_parse_exr(d, len, desc, out, err, errlen);
    default:
        memset(out, 0, sizeof *out);
        snprintf(err, errlen,
                 "the environment image is neither a Radiance .hdr file (beginning with #?) nor "
                 "an OpenEXR .exr file");
        return false;
    }
}

bool rd_env_image_size_ok(uint64_t w, uint64_t h, const char *format, char *err, size_t errlen)
{
    if (w < 2 || h < 1 || w > RD_ENV_MAX_DIM || h > RD_ENV_MAX_DIM) {
        snprintf(err, errlen, "%s size %llux%llu is out of range (2..%u wide, 1..%u high)", format,
                 (unsigned long long)w, (unsigned long long)h, RD_ENV_MAX_DIM, RD_ENV_MAX_DIM);
        return false;
    }
    if (w * h * 3 * sizeof(float) > RD_ENV_MAX_BYTES) {
        snprintf(err, errlen,
                 "%s size %llux%llu would take %llu MiB decoded (at most %llu MiB are accepted)",
                 format, (unsigned long long)w, (unsigned long long)h,
                 (unsigned long long)(w * h * 3 * sizeof(float) >> 20),
                 (unsigned long long)(RD_ENV_MAX_BYTES >> 20));
        return false;
    }
    return true;
}

/* ---- Radiance RGBE (.hdr) ---------------------------------------------------------------- */

/* The next header line (without its newline) into line; false at the end of data or for a line
 * longer than the buffer. */
static bool next_line(const uint8_t *d, size_t len, size_t *pos, char *line, size_t cap)
{
    size_t n = 0;
    while (*pos < len && d[*pos] != '\n') {
        if (n + 1 >= cap) return false;
        line[n++] = (char)d[(*pos)++];
    }
    if (*pos >= len) return false;
    (*pos)++; /* the newline */
    line[n] = 0;
    return true;
}

static void rgbe_to_float(const uint8_t *p, float *out)
{
    if (p[3] == 0) {
        out[0] = out[1] = out[2] = 0;
        return;
    }
    float f = ldexpf(1.0f, (int)p[3] - (128 + 8));
    out[0] = ((float)p[0] + 0.5f) * f;
    out[1] = ((float)p[1] + 0.5f) * f;
    out[2] = ((float)p[2] + 0.5f) * f;
}

/* One run-length encoded scanline (four planes of runs) into rgbe (width * 4 bytes). */
static bool read_rle_line(const uint8_t *d, size_t len, size_t *pos, uint32_t width, uint8_t *rgbe)
{
    for (int c = 0; c < 4; c++) {
        uint32_t x = 0;
        while (x < width) {
            if (*pos >= len) return false;
            uint32_t count = d[(*pos)++];
            if (count > 128) { /* a run of one value */
                count -= 128;
                if (count > width - x || *pos >= len) return false;
                uint8_t v = d[(*pos)++];
                for (uint32_t i = 0; i < count; i++)
                    rgbe[(x++) * 4 + (uint32_t)c] = v;
            } else { /* count literal values */
                if (count == 0 || count > width - x || len - *pos < count) return false;
                for (uint32_t i = 0; i < count; i++)
                    rgbe[(x++) * 4 + (uint32_t)c] = d[(*pos)++];
            }
        }
    }
    return true;
}

bool rd_env_image_parse_hdr(const uint8_t *d, size_t len, rd_env_read_desc *desc, rd_env_image *out,
                            char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    if (desc) desc->peak_bytes = 0;
    char line[512];
    size_t pos = 0;
    if (!next_line(d, len, &pos, line, sizeof line) || strncmp(line, "#?", 2) != 0) {
        snprintf(err, errlen, "not a Radiance HDR file (it must begin with #?RADIANCE)");
        return false;
    }
    for (;;) {
        if (!next_line(d, len, &pos, line, sizeof line)) {
            snprintf(err, errlen, "the HDR header ends before its blank line");
            return false;
        }
        if (!line[0]) break;
        if (strncmp(line, "FORMAT=", 7) == 0 && strcmp(line + 7, "32-bit_rle_rgbe") != 0) {
            snprintf(err, errlen, "HDR format '%.40s' is not supported (only 32-bit_rle_rgbe)",
                     line + 7);
            return false;
        }
    }
    unsigned w = 0, h = 0;
    char extra;
    if (!next_line(d, len, &pos, line, sizeof line) ||
        sscanf(line, "-Y %u +X %u%c", &h, &w, &extra) != 2) {
        snprintf(err, errlen,
                 "the HDR resolution line must read '-Y height +X width' (other orientations "
                 "are not supported)");
        return false;
    }
    if (!rd_env_image_size_ok(w, h, "HDR", err, errlen)) return false;
    /* every scanline is at least 4 bytes per pixel flat, or some bytes of runs: a file far too
     * short for its size is refused before the allocation */
    if ((uint64_t)(len - pos) * 128 < (uint64_t)w * h * 4 / 127) {
        snprintf(err, errlen, "the HDR file is too short for %ux%u pixels", w, h);
        return false;
    }
    /* one scanline (RGBE, then floats) at a time into the reduction */
    rd_env_mem mem = {0};
    rd_env_reducer red;
    rd_env_reducer_init(&red, w, h, desc ? desc->max_width : 0, &mem, out);
    uint8_t *rgbe = rd_env_mem_alloc(&mem, (size_t)w * 4, false);
    float *row = rd_env_mem_alloc(&mem, (size_t)w * 3 * sizeof *row, false);
    bool ok = true;
    for (unsigned y = 0; ok && y < h; y++) {
        if (w >= 8 && w <= 0x7fff && len - pos >= 4 && d[pos] == 2 && d[pos + 1] == 2 &&
            !(d[pos + 2] & 0x80)) {
            if (((unsigned)d[pos + 2] << 8 | d[pos + 3]) != w) {
                snprintf(err, errlen, "HDR scanline %u has the wrong length", y);
                ok = false;
            } else {
                pos += 4;
                ok = read_rle_line(d, len, &pos, w, rgbe);
                if (!ok) snprintf(err, errlen, "HDR scanline %u has bad or truncated runs", y);
            }
        } else {
            ok = len - pos >= (size_t)w * 4;
            if (ok) {
                memcpy(rgbe, d + pos, (size_t)w * 4);
                pos += (size_t)w * 4;
                /* the old format's repeat marker (1, 1, 1, n) is not read */
                for (unsigned x = 0; ok && x < w; x++)
                    ok = !(rgbe[x * 4] == 1 && rgbe[x * 4 + 1] == 1 && rgbe[x * 4 + 2] == 1);
                if (!ok)
                    snprintf(err, errlen,
                             "HDR scanline %u uses the old run-length format (re-save the file)",
                             y);
            } else {
                snprintf(err, errlen, "the HDR file ends in scanline %u of %u", y, h);
            }
        }
        if (!ok) break;
        for (unsigned x = 0; x < w; x++)
            rgbe_to_float(rgbe + x * 4, row + (size_t)x * 3);
        rd_env_reducer_push(&red, row);
    }
    rd_env_mem_free(&mem, rgbe);
    rd_env_mem_free(&mem, row);
    rd_env_reducer_dispose(&red);
    if (desc) desc->peak_bytes = mem.peak;
    if (!ok) rd_env_image_free(out);
    return ok;
}

void rd_env_image_limit(rd_env_image *img, uint32_t max_width)
{
    while ((img->width > max_width || img->height > max_width) && img->width >= 2 &&
           img->height >= 2) {
        uint32_t w = img->width / 2, h = img->height / 2;
        float *n = malloc((size_t)w * h * 3 * sizeof *n);
        if (!n) abort();
        for (uint32_t y = 0; y < h; y++)
            for (uint32_t x = 0; x < w; x++)
                for (int c = 0; c < 3; c++) {
                    const float *r0 = img->rgb + ((size_t)(2 * y) * img->width + 2 * x) * 3;
                    const float *r1 = r0 + (size_t)img->width * 3;
                    n[((size_t)y * w + x) * 3 + (size_t)c] =
                        0.25f * (r0[c] + r0[3 + c] + r1[c] + r1[3 + c]);
                }
        free(img->rgb);
        img->rgb = n;
        img->width = w;
        img->height = h;
    }
}

void rd_env_image_shrunk(const rd_env_image *src, uint32_t max_width, rd_env_image *out)
{
    uint32_t f = 1;
    while ((src->width / f > max_width || src->height / f > max_width) && src->width / f >= 2 &&
           src->height / f >= 2)
        f *= 2;
    out->width = src->width / f;
    out->height = src->height / f;
    out->rgb = malloc((size_t)out->width * out->height * 3 * sizeof *out->rgb);
    if (!out->rgb) abort();
    const float scale = 1.0f / (float)(f * f);
    for (uint32_t y = 0; y < out->height; y++)
        for (uint32_t x = 0; x < out->width; x++) {
            double acc[3] = {0, 0, 0};
            for (uint32_t j = 0; j < f; j++) {
                const float *row = src->rgb + ((size_t)(y * f + j) * src->width + x * f) * 3;
                for (uint32_t i = 0; i < f * 3; i += 3)
                    for (int c = 0; c < 3; c++)
                        acc[c] += row[i + (uint32_t)c];
            }
            for (int c = 0; c < 3; c++)
                out->rgb[((size_t)y * out->width + x) * 3 + (size_t)c] = (float)acc[c] * scale;
        }
}

void rd_env_image_free(rd_env_image *img)
{
    free(img->rgb);
    memset(img, 0, sizeof *img);
}

/* ---- radiance ----------------------------------------------------------------------------- */

static void image_lookup(const rd_environment *e, const float d[3], float out[3])
{
    const rd_env_image *im = e->image;
    float u = atan2f(d[0], -d[2]) / (2 * PI_F) + 0.5f - e->rotation / (2 * PI_F);
    float v = acosf(fminf(1.0f, fmaxf(-1.0f, d[1]))) / PI_F;
    u -= floorf(u);
    /* bilinear, wrapping in u and clamping in v, texel centres at +0.5 (as the shader) */
    float fx = u * (float)im->width - 0.5f, fy = v * (float)im->height - 0.5f;
    int x0 = (int)floorf(fx), y0 = (int)floorf(fy);
    float tx = fx - (float)x0, ty = fy - (float)y0;
    for (int c = 0; c < 3; c++)
        out[c] = 0;
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++) {
            int x = ((x0 + i) % (int)im->width + (int)im->width) % (int)im->width;
            int y = y0 + j < 0 ? 0 : y0 + j >= (int)im->height ? (int)im->height - 1 : y0 + j;
            float wgt = (i ? tx : 1 - tx) * (j ? ty : 1 - ty);
            const float *t = im->rgb + ((size_t)y * im->width + (size_t)x) * 3;
            for (int c = 0; c < 3; c++)
                out[c] += wgt * t[c];
        }
    for (int c = 0; c < 3; c++)
        out[c] *= e->intensity;
}

void rd_env_radiance(const rd_environment *e, const float d[3], float out[3])
{
    if (e->mode == RD_ENV_IMAGE && e->image && e->image->rgb) {
        image_lookup(e, d, out);
        return;
    }
    if (e->mode != RD_ENV_GRADIENT) { /* uniform (or an image that is missing) */
        memcpy(out, e->sky, 3 * sizeof *out);
        return;
    }
    float t = 0.5f + 0.5f * d[1];
    for (int c = 0; c < 3; c++)
        out[c] = e->ground[c] + (e->sky[c] - e->ground[c]) * t;
}

/* ---- spherical harmonics ------------------------------------------------------------------- */

static void sh_basis(const float n[3], float y[9])
{
    float x = n[0], yy = n[1], z = n[2];
    y[0] = 0.282095f;
    y[1] = 0.488603f * yy;
    y[2] = 0.488603f * z;
    y[3] = 0.488603f * x;
    y[4] = 1.092548f * x * yy;
    y[5] = 1.092548f * yy * z;
    y[6] = 0.315392f * (3 * z * z - 1);
    y[7] = 1.092548f * x * z;
    y[8] = 0.546274f * (x * x - yy * yy);
}

/* the cosine lobe's zonal factors per band (Ramamoorthi and Hanrahan 2001) */
static const float band_factor[9] = {PI_F,     2 * PI_F / 3, 2 * PI_F / 3, 2 * PI_F / 3, PI_F / 4,
                                     PI_F / 4, PI_F / 4,     PI_F / 4,     PI_F / 4};

void rd_env_irradiance_sh(const rd_environment *e, float sh[9][3])
{
    memset(sh, 0, 9 * sizeof sh[0]);
    if (e->mode == RD_ENV_IMAGE && e->image && e->image->rgb) {
        const rd_env_image *im = e->image;
        double acc[9][3] = {{0}};
        /* every step-th texel in both directions (SH9 has no detail finer than ~30 degrees),
         * weighted by the solid angle it stands for */
        uint32_t step = im->width > 512 ? im->width / 512 : 1;
        for (uint32_t y = 0; y < im->height; y += step) {
            float theta = PI_F * ((float)y + 0.5f) / (float)im->height;
            uint32_t rows = im->height - y < step ? im->height - y : step;
            float dw = (2 * PI_F / (float)im->width) * (PI_F / (float)im->height) * sinf(theta) *
                       (float)step * (float)rows;
            for (uint32_t x = 0; x < im->width; x += step) {
                /* the texel's direction, with the rotation applied as image_lookup reads it */
                float u = ((float)x + 0.5f) / (float)im->width;
                float phi = (u - 0.5f) * 2 * PI_F + e->rotation;
                float d[3] = {sinf(theta) * sinf(phi), cosf(theta), -sinf(theta) * cosf(phi)};
                float b[9];
                sh_basis(d, b);
                const float *t = im->rgb + ((size_t)y * im->width + x) * 3;
                for (int k = 0; k < 9; k++)
                    for (int c = 0; c < 3; c++)
                        acc[k][c] += (double)(b[k] * t[c] * dw * e->intensity);
            }
        }
        for (int k = 0; k < 9; k++)
            for (int c = 0; c < 3; c++)
                sh[k][c] = (float)acc[k][c] * band_factor[k];
        return;
    }
    /* L(d) = a + b d.y exactly: L00 = a sqrt(4 pi), L1,-1 = b sqrt(4 pi / 3) */
    for (int c = 0; c < 3; c++) {
        float a = e->mode == RD_ENV_GRADIENT ? 0.5f * (e->sky[c] + e->ground[c]) : e->sky[c];
        float b = e->mode == RD_ENV_GRADIENT ? 0.5f * (e->sky[c] - e->ground[c]) : 0.0f;
        sh[0][c] = a * sqrtf(4 * PI_F) * band_factor[0];
        sh[1][c] = b * sqrtf(4 * PI_F / 3) * band_factor[1];
    }
}

void rd_env_irradiance_eval(const float sh[9][3], const float n[3], float out[3])
{
    float y[9];
    sh_basis(n, y);
    for (int c = 0; c < 3; c++) {
        out[c] = 0;
        for (int k = 0; k < 9; k++)
            out[c] += sh[k][c] * y[k];
        if (out[c] < 0) out[c] = 0;
    }
}

void rd_env_fill_gpu(const rd_environment *e, const float sh[9][3], pc_environment *g)
{
    memset(g, 0, sizeof *g);
    g->sky = (pc_vec4){e->sky[0], e->sky[1], e->sky[2], e->intensity};
    g->ground = (pc_vec4){e->ground[0], e->ground[1], e->ground[2], e->rotation};
    for (int k = 0; k < 9; k++)
        g->irradiance[k] = (pc_vec4){sh[k][0], sh[k][1], sh[k][2], 0};
    bool image = e->mode == RD_ENV_IMAGE && e->image && e->image->rgb;
    g->mode = image ? PC_ENV_IMAGE : (uint32_t)(e->mode == RD_ENV_IMAGE ? RD_ENV_UNIFORM : e->mode);
    if (image) {
        g->width = e->image->width;
        g->height = e->image->height;
    }
}
