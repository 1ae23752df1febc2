/* exr_writer.h: OpenEXR files for tests, written by OpenEXRCore's own writing API (exr_start_write
 * and its encoding pipeline) into memory, so that what the reader under test decodes is checked
 * against values that never passed through it. */
#ifndef PC_EXR_WRITER_H
#define PC_EXR_WRITER_H

#include <openexr.h>
#include <stddef.h>
#include <stdint.h>

typedef struct pc_exr_desc {
    uint32_t width, height; /* of the data window */
    int32_t x, y;           /* the data window's top-left pixel */
    uint32_t display_width; /* 0: the display window is the data window */
    uint32_t display_height;
    int32_t display_x, display_y; /* the display window's top-left pixel (when given) */
    exr_pixel_type_t type;        /* of every channel */
    exr_compression_t compression;
    uint32_t tile;               /* > 0: tiled, tile x tile pixels, one level; 0: scanlines */
    int channel_count;           /* 0: three channels R, G, B */
    const char *const *channels; /* names, channel_count of them (when channel_count > 0) */
    const float *pixels;         /* width * height * channels, interleaved in the order above */
} pc_exr_desc;

/* The file as malloc'd bytes (*size of them), or NULL after printing the library's complaint.
 * HALF and UINT channels get the values converted (exactly, when they are representable). */
uint8_t *pc_exr_write(const pc_exr_desc *d, size_t *size);

/* The EXR test texel: quarters, small integers and powers of two, exact in HALF. */
float pc_exr_test_texel(unsigned x, unsigned y, int c);
/* w x h interleaved pixels of `channels` channels (the test texel for the first three, 7 after);
 * malloc'd, aborts when out of memory. */
float *pc_exr_test_pixels(unsigned w, unsigned h, int channels);

#endif
