/* bench_frame.h: frames for probecast_jpegbench: generated like the renderer's, or read from a
 * file and resampled to the sizes measured. RGBA8, rows top to bottom; the caller frees. */
#ifndef BENCH_FRAME_H
#define BENCH_FRAME_H

#include <stdint.h>

/* A frame like the renderer's: a sky gradient, a checkered floor in perspective, three shaded
 * spheres with soft shadows, and path-tracing grain (a few levels of noise on every pixel). */
uint8_t *bench_make_frame(unsigned w, unsigned h);
/* Reads a PNG or a binary PPM (P6); NULL on failure. */
uint8_t *bench_read_image(const char *path, unsigned *w, unsigned *h);
/* Bilinear resampling to w x h. */
uint8_t *bench_resample(const uint8_t *src, unsigned sw, unsigned sh, unsigned w, unsigned h);

#endif
