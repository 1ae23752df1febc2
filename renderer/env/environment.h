/* environment.h: the light that reaches the scene from outside it (issue "environment light"):
 * a uniform radiance, a two-colour gradient from nadir to zenith, or an equirectangular HDR
 * image (a Radiance .hdr or an OpenEXR .exr file). Primary misses, probe rays and the path tracer
 * see it through env_radiance() (shaders/environment.glsl); probe fallbacks use its irradiance,
 * kept as the nine spherical-harmonic coefficients of the cosine-convolved radiance (Ramamoorthi
 * and Hanrahan 2001), exact for the uniform and gradient skies (their radiance is linear in the
 * direction).
 *
 * Plain CPU code: parsing (environment_exr.c reads OpenEXR), the SH projection and the GPU
 * record (world.c uploads the image).
 */
#ifndef RD_ENVIRONMENT_H
#define RD_ENVIRONMENT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "shaders/gpu_types.h"

/* Images are reduced (2x2 box filter, by halves) while wider or taller than this; an
 * equirectangular image (twice as wide as high) ends at most 4096 x 2048. The readers reduce as
 * they decode, a stripe of rows at a time (environment_reduce.h), so a decode holds the reduced
 * image (at most 4096 x 4096 texels, 192 MiB) plus one stripe, whatever size the file declares.
 * Taller than wide images are the only ones halved for their height: a 4096 x 32768 file would
 * otherwise keep 1.5 GiB. */
#define RD_ENV_IMAGE_MAX_WIDTH 4096u
/* The largest image side a file may declare (.hdr resolution line, .exr windows), and the most
 * its texels may take as three floats each at the declared size. Nothing that large is allocated
 * any more; the limit stays (with its old value and message, so that it refuses no file it did
 * not refuse before) because it bounds the decoding work an upload can ask for: 179 million
 * texels. */
#define RD_ENV_MAX_DIM 32768u
#define RD_ENV_MAX_BYTES ((uint64_t)2 << 30)
/* The most one stripe may take decoded (three floats a texel): an .exr chunk's colour planes and
 * the full-width rows it covers (a block of scanlines, or a row of tiles). New with the striped
 * reading: every scanline file up to 21845 wide fits (the longest chunks, DWAB's, have 256
 * lines), so only unusually large tiles, or 256-line chunks wider than that, are refused. */
#define RD_ENV_MAX_STRIPE_BYTES ((uint64_t)64 << 20)
/* The most OpenEXRCore may unpack of one chunk (all its channels, before conversion). */
#define RD_ENV_MAX_CHUNK_BYTES ((uint64_t)128 << 20)

typedef enum rd_env_mode {
    RD_ENV_UNIFORM = PC_ENV_UNIFORM,
    RD_ENV_GRADIENT = PC_ENV_GRADIENT,
    RD_ENV_IMAGE = PC_ENV_IMAGE,
} rd_env_mode;

/* Linear RGB radiance per texel, equirectangular: row 0 looks at the zenith (+y), column 0 at
 * -z, u grows toward +x (u = atan2(x, -z) / 2pi + 1/2, v = acos(y) / pi). */
typedef struct rd_env_image {
    uint32_t width, height;
    float *rgb; /* width * height * 3 */
} rd_env_image;

typedef struct rd_environment {
    rd_env_mode mode;
    float sky[3];              /* uniform radiance, or the gradient's zenith radiance */
    float ground[3];           /* the gradient's nadir radiance */
    float intensity;           /* scales the image (1 = as stored) */
    float rotation;            /* of the image about +y, radians (the image turns toward +x) */
    const rd_env_image *image; /* RD_ENV_IMAGE only; not owned */
} rd_environment;

/* The file formats an environment image is read from, told apart by their first bytes. */
typedef enum rd_env_format {
    RD_ENV_FORMAT_UNKNOWN = 0,
    RD_ENV_FORMAT_HDR, /* Radiance RGBE: begins with "#?" */
    RD_ENV_FORMAT_EXR, /* OpenEXR: begins with the magic number 76 2f 31 01 */
    RD_ENV_FORMAT_COUNT,
} rd_env_format;

rd_env_format rd_env_image_format(const uint8_t *data, size_t len);
/* The usual file name extension of a format ("hdr", "exr"); NULL for RD_ENV_FORMAT_UNKNOWN. */
const char *rd_env_format_extension(rd_env_format f);

/* How an image is read; zero (or a NULL desc) means the daemon's defaults. */
typedef struct rd_env_read_desc {
    uint32_t max_width; /* reduce as rd_env_image_limit to this; 0: RD_ENV_IMAGE_MAX_WIDTH
                         * (RD_ENV_MAX_DIM reads every file at its full size) */
    size_t peak_bytes;  /* out: the most bytes the read held at once (its buffers, the image
                         * and OpenEXRCore's allocations), for tests and benchmarks */
} rd_env_read_desc;

/* Parses an environment image in any format below (chosen by rd_env_image_format), reduced as
 * desc says. Same contract as the readers below; err says which formats are read when it is
 * none of them. */
bool rd_env_image_parse(const uint8_t *data, size_t len, rd_env_read_desc *desc, rd_env_image *out,
                        char *err, size_t errlen);

/* Parses a Radiance RGBE file (.hdr/.pic: "#?RADIANCE" or "#?RGBE", FORMAT=32-bit_rle_rgbe,
 * "-Y H +X W" orientation, flat or run-length encoded scanlines), one scanline at a time into
 * the reduction. Takes no ownership of data; out->rgb is malloc'd. False with a sentence in err
 * for anything else (truncated, other orientation or format, oversized, bad run lengths). */
bool rd_env_image_parse_hdr(const uint8_t *data, size_t len, rd_env_read_desc *desc,
                            rd_env_image *out, char *err, size_t errlen);
/* Parses an OpenEXR file (environment_exr.c): one part, scanline or tiled (level 0 of a mipmap
 * or ripmap), any compression OpenEXRCore decodes, one chunk (a block of scanlines) or one row
 * of tiles at a time into the reduction. Colour comes from the channels R, G and B (HALF, FLOAT
 * or UINT; A and others are ignored) or, without them, from a lone luminance channel Y as grey;
 * luminance-chroma (RY/BY), subsampled, deep and multi-part files are refused, and so are
 * stripes over RD_ENV_MAX_STRIPE_BYTES or chunks over RD_ENV_MAX_CHUNK_BYTES. The image is the
 * display window: data window pixels outside it are dropped, display pixels the data window
 * misses are black. Negative, NaN and infinite values become 0. Same ownership and error
 * contract as rd_env_image_parse_hdr. */
bool rd_env_image_parse_exr(const uint8_t *data, size_t len, rd_env_read_desc *desc,
                            rd_env_image *out, char *err, size_t errlen);
/* True when a w x h image is within RD_ENV_MAX_DIM (at least 2 wide, 1 high) and
 * RD_ENV_MAX_BYTES; else false with a sentence naming the format in err. */
bool rd_env_image_size_ok(uint64_t w, uint64_t h, const char *format, char *err, size_t errlen);
/* Halves a whole image in memory (2x2 box; an odd last row or column is dropped) while it is
 * wider or taller than max_width (and at least 2 x 2): what the readers do stripe by stripe. */
void rd_env_image_limit(rd_env_image *img, uint32_t max_width);
/* A copy of src box-filtered by a power of two until it is at most max_width wide and high
 * (blocks of f x f texels averaged; a remainder row or column is dropped), allocated at its own
 * size (src is only read): what the irradiance projection needs of a large image. */
void rd_env_image_shrunk(const rd_env_image *src, uint32_t max_width, rd_env_image *out);
void rd_env_image_free(rd_env_image *img);

/* Radiance of the environment toward unit direction d (the CPU twin of env_radiance, for
 * tests and references). */
void rd_env_radiance(const rd_environment *e, const float d[3], float out[3]);
/* The SH9 coefficients (RGB) of the irradiance E(n) = integral of L(w) max(0, n.w) dw. */
void rd_env_irradiance_sh(const rd_environment *e, float sh[9][3]);
/* E(n) from those coefficients. */
void rd_env_irradiance_eval(const float sh[9][3], const float n[3], float out[3]);

/* The GPU record (image address filled by the caller). */
void rd_env_fill_gpu(const rd_environment *e, const float sh[9][3], pc_environment *g);

#endif
