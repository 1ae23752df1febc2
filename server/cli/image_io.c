#include "server/cli/image_io.h"

#include <errno.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <turbojpeg.h>

const char *rd_image_strerror(rd_image_result r)
{
    switch (r) {
    case RD_IMAGE_OK: return "ok";
    case RD_IMAGE_ERR_IO: return "i/o error";
    case RD_IMAGE_ERR_FORMAT: return "unsupported or malformed image format";
    case RD_IMAGE_ERR_ENCODE: return "image encoding failed";
    }
    return "unknown image error";
}

static const char *extension(const char *path)
{
    const char *dot = strrchr(path, '.');
    return dot ? dot + 1 : "";
}

static rd_image_result write_png(const char *path, const uint8_t *rgba, uint32_t w, uint32_t h,
                                 char *err, size_t errlen)
{
    png_image img;
    memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    img.width = w;
    img.height = h;
    img.format = PNG_FORMAT_RGBA;
    if (!png_image_write_to_file(&img, path, 0, rgba, (png_int_32)(w * 4), NULL)) {
        snprintf(err, errlen, "cannot write PNG '%s': %s", path, img.message);
        png_image_free(&img);
        return RD_IMAGE_ERR_IO;
    }
    return RD_IMAGE_OK;
}

static rd_image_result write_jpeg(const char *path, const uint8_t *rgba, uint32_t w, uint32_t h,
                                  int quality, char *err, size_t errlen)
{
    tjhandle tj = tjInitCompress();
    if (!tj) {
        snprintf(err, errlen, "cannot initialise the JPEG encoder");
        return RD_IMAGE_ERR_ENCODE;
    }
    unsigned char *jpeg = NULL;
    unsigned long size = 0;
    if (quality < 1 || quality > 100) quality = 90;
    rd_image_result res = RD_IMAGE_OK;
    if (tjCompress2(tj, rgba, (int)w, 0, (int)h, TJPF_RGBA, &jpeg, &size, TJSAMP_420, quality,
                    TJFLAG_ACCURATEDCT) != 0) {
        snprintf(err, errlen, "JPEG encoding failed: %s", tjGetErrorStr2(tj));
        res = RD_IMAGE_ERR_ENCODE;
    } else {
        FILE *f = fopen(path, "wb");
        if (!f || fwrite(jpeg, 1, size, f) != size) {
            snprintf(err, errlen, "cannot write '%s': %s", path, strerror(errno));
            res = RD_IMAGE_ERR_IO;
        }
        if (f && fclose(f) != 0 && res == RD_IMAGE_OK) {
            snprintf(err, errlen, "cannot write '%s': %s", path, strerror(errno));
            res = RD_IMAGE_ERR_IO;
        }
    }
    tjFree(jpeg);
    tjDestroy(tj);
    return res;
}

rd_image_result rd_image_write_rgba8(const char *path, const uint8_t *rgba, uint32_t width,
                                     uint32_t height, int quality, char *err, size_t errlen)
{
    const char *ext = extension(path);
    if (strcasecmp(ext, "png") == 0) return write_png(path, rgba, width, height, err, errlen);
    if (strcasecmp(ext, "jpg") == 0 || strcasecmp(ext, "jpeg") == 0)
        return write_jpeg(path, rgba, width, height, quality, err, errlen);
    snprintf(err, errlen, "unknown image type '.%s' for '%s' (use .png, .jpg or .jpeg)", ext,
             path);
    return RD_IMAGE_ERR_FORMAT;
}

rd_image_result rd_image_write_pfm(const char *path, const float *rgb, uint32_t width,
                                   uint32_t height, char *err, size_t errlen)
{
    FILE *f = fopen(path, "wb");
    if (!f) {
        snprintf(err, errlen, "cannot write '%s': %s", path, strerror(errno));
        return RD_IMAGE_ERR_IO;
    }
    /* Negative scale = little endian; x86 and ARM Linux are little endian. */
    int ok = fprintf(f, "PF\n%u %u\n-1.0\n", width, height) > 0;
    for (uint32_t y = 0; ok && y < height; y++) {
        const float *row = rgb + (size_t)(height - 1 - y) * width * 3;
        ok = fwrite(row, sizeof(float) * 3, width, f) == width;
    }
    if (fclose(f) != 0) ok = 0;
    if (!ok) {
        snprintf(err, errlen, "cannot write '%s': %s", path, strerror(errno));
        return RD_IMAGE_ERR_IO;
    }
    return RD_IMAGE_OK;
}

static void swap32(void *p)
{
    uint8_t *b = p, t;
    t = b[0], b[0] = b[3], b[3] = t;
    t = b[1], b[1] = b[2], b[2] = t;
}

rd_image_result rd_image_read_pfm(const char *path, float **rgb, uint32_t *width,
                                  uint32_t *height, char *err, size_t errlen)
{
    *rgb = NULL;
    FILE *f = fopen(path, "rb");
    if (!f) {
        snprintf(err, errlen, "cannot open '%s': %s", path, strerror(errno));
        return RD_IMAGE_ERR_IO;
    }
    char magic[3] = {0};
    unsigned w = 0, h = 0;
    double scale = 0;
    if (fscanf(f, "%2s %u %u %lf", magic, &w, &h, &scale) != 4 || strcmp(magic, "PF") != 0 ||
        w == 0 || h == 0 || w > 65536 || h > 65536 || scale == 0 || fgetc(f) == EOF) {
        fclose(f);
        snprintf(err, errlen, "'%s' is not an RGB PFM file", path);
        return RD_IMAGE_ERR_FORMAT;
    }
    size_t n = (size_t)w * h * 3;
    float *data = malloc(n * sizeof(float));
    if (!data) abort();
    for (uint32_t y = 0; y < h; y++) {
        float *row = data + (size_t)(h - 1 - y) * w * 3;
        if (fread(row, sizeof(float) * 3, w, f) != w) {
            free(data);
            fclose(f);
            snprintf(err, errlen, "'%s' is truncated", path);
            return RD_IMAGE_ERR_FORMAT;
        }
    }
    fclose(f);
    if (scale > 0)
        for (size_t i = 0; i < n; i++) swap32(&data[i]);
    *rgb = data;
    *width = w;
    *height = h;
    return RD_IMAGE_OK;
}
