/* image_io.h: writing rendered images (PNG, JPEG, little-endian PFM) and reading PFM back. */
#ifndef RD_IMAGE_IO_H
#define RD_IMAGE_IO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef enum rd_image_result {
    RD_IMAGE_OK = 0,
    RD_IMAGE_ERR_IO,
    RD_IMAGE_ERR_FORMAT, /* unknown extension or malformed file */
    RD_IMAGE_ERR_ENCODE,
} rd_image_result;

const char *rd_image_strerror(rd_image_result r);

/* Writes 8-bit RGBA pixels (top row first) as PNG or JPEG, chosen by the path's extension
 * (.png, .jpg, .jpeg). quality applies to JPEG (1..100). */
rd_image_result rd_image_write_rgba8(const char *path, const uint8_t *rgba, uint32_t width,
                                     uint32_t height, int quality, char *err, size_t errlen);
/* Writes linear RGB floats (3 per pixel, top row first) as a little-endian PFM ("PF",
 * scale -1.0, rows bottom to top as the format requires). */
rd_image_result rd_image_write_pfm(const char *path, const float *rgb, uint32_t width,
                                   uint32_t height, char *err, size_t errlen);
/* Reads a PFM written by rd_image_write_pfm (or any RGB PFM, either endianness); *rgb is
 * malloc'd, top row first. */
rd_image_result rd_image_read_pfm(const char *path, float **rgb, uint32_t *width, uint32_t *height,
                                  char *err, size_t errlen);

#endif
