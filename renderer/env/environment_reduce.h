/* environment_reduce.h: the striped reduction shared by the environment image readers
 * (environment.c, environment_exr.c); internal to renderer/. A reader pushes the rows of the
 * full-size image in order, one stripe at a time, and the reducer folds each row pair straight
 * into the next halving level, so a decode holds the reduced image plus one stripe and a few
 * rows, whatever size the file declares. The result is bit for bit that of rd_env_image_limit on
 * the full image: the same 2x2 sums in the same order, odd last rows and columns dropped. */
#ifndef RD_ENVIRONMENT_REDUCE_H
#define RD_ENVIRONMENT_REDUCE_H

#include <stddef.h>
#include <stdint.h>

#include "renderer/env/environment.h"

/* Enough halvings to take RD_ENV_MAX_DIM down to 1. */
#define RD_ENV_REDUCE_MAX_LEVELS 16

/* Bytes a decode holds: its own buffers, the reduced image and OpenEXRCore's allocations. */
typedef struct rd_env_mem {
    size_t now, peak;
} rd_env_mem;

/* malloc/calloc that count into m (a size header in front; abort when out of memory), and the
 * matching free (NULL is ignored). */
void *rd_env_mem_alloc(rd_env_mem *m, size_t bytes, bool zero);
void rd_env_mem_free(rd_env_mem *m, void *p);
/* Counts bytes allocated elsewhere (the reduced image, which the caller frees with free). */
void rd_env_mem_count(rd_env_mem *m, size_t bytes);

/* The size a w x h image reduces to under max_width (0: RD_ENV_IMAGE_MAX_WIDTH) and the number
 * of halvings; the rule of rd_env_image_limit. */
unsigned rd_env_reduced_size(uint32_t w, uint32_t h, uint32_t max_width, uint32_t *rw,
                             uint32_t *rh);

typedef struct rd_env_reducer {
    uint32_t width, height; /* of the full image whose rows are pushed */
    unsigned levels;
    uint32_t rows; /* pushed so far */
    rd_env_image *out;
    rd_env_mem *mem;
    float *pending[RD_ENV_REDUCE_MAX_LEVELS]; /* level i's even row, waiting for its partner */
    float *folded[RD_ENV_REDUCE_MAX_LEVELS];  /* the row level i makes for level i + 1 */
} rd_env_reducer;

/* Sets up the reduction of a w x h image (w >= 2, h >= 1) and allocates out->rgb, zeroed,
 * at the reduced size (out owns it; rd_env_image_free frees it). */
void rd_env_reducer_init(rd_env_reducer *r, uint32_t w, uint32_t h, uint32_t max_width,
                         rd_env_mem *mem, rd_env_image *out);
/* Folds the next full-size row (width * 3 floats) in; rows past the height are ignored. */
void rd_env_reducer_push(rd_env_reducer *r, const float *row);
/* Frees the rows (not out). */
void rd_env_reducer_dispose(rd_env_reducer *r);

#endif
