/* hdr_writer.h: Radiance .hdr files for tests (flat or new-style run-length scanlines, written
 * here with Ward's RGBE encoding, not by the reader under test), a growable byte buffer, and the
 * noisy test texels that make a reduction's summation order visible. */
#ifndef PC_HDR_WRITER_H
#define PC_HDR_WRITER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef struct pc_bytes {
    uint8_t *d;
    size_t n, cap;
} pc_bytes;

/* Appends n bytes (aborts when out of memory). */
void pc_bytes_put(pc_bytes *b, const void *p, size_t n);

/* RGBE of a float colour (Ward's encoding). */
void pc_rgbe(const float c[3], uint8_t out[4]);

/* A .hdr of w x h texels coloured by tex; rle: new-style run-length scanlines (runs of equal
 * bytes are written as runs, others as literals). The caller frees .d. */
pc_bytes pc_hdr_write(unsigned w, unsigned h, bool rle, void (*tex)(unsigned, unsigned, float[3]));

/* A run-length .hdr of w x h texels of one colour: a few bytes a scanline whatever its width
 * (runs of 127). The caller frees .d. */
pc_bytes pc_hdr_constant(unsigned w, unsigned h, const uint8_t rgbe[4]);

/* Texels of many magnitudes and full mantissas, whose 2x2 sums round: a reduction that adds
 * in another order than rd_env_image_limit gives other floats. */
void pc_noisy_texel(unsigned x, unsigned y, float c[3]);

#endif
