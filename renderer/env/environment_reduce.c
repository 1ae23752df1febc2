/* environment_reduce.c: the striped 2x2 box reduction of environment images (see
 * environment_reduce.h). */
#include "renderer/env/environment_reduce.h"

#include <stdlib.h>
#include <string.h>

/* The size header in front of each counted block (keeps malloc's alignment). */
typedef union mem_header {
    size_t bytes;
    max_align_t align;
} mem_header;

void *rd_env_mem_alloc(rd_env_mem *m, size_t bytes, bool zero)
{
    mem_header *h = zero ? calloc(1, sizeof *h + bytes) : malloc(sizeof *h + bytes);
    if (!h) abort();
    h->bytes = bytes;
    rd_env_mem_count(m, bytes);
    return h + 1;
}

void rd_env_mem_free(rd_env_mem *m, void *p)
{
    if (!p) return;
    mem_header *h = (mem_header *)p - 1;
    m->now -= h->bytes;
    free(h);
}

void rd_env_mem_count(rd_env_mem *m, size_t bytes)
{
    m->now += bytes;
    if (m->now > m->peak) m->peak = m->now;
}

unsigned rd_env_reduced_size(uint32_t w, uint32_t h, uint32_t max_width, uint32_t *rw, uint32_t *rh)
{
    if (!max_width) max_width = RD_ENV_IMAGE_MAX_WIDTH;
    unsigned levels = 0;
    while ((w > max_width || h > max_width) && w >= 2 && h >= 2) {
        w /= 2;
        h /= 2;
        levels++;
    }
    *rw = w;
    *rh = h;
    return levels;
}

void rd_env_reducer_init(rd_env_reducer *r, uint32_t w, uint32_t h, uint32_t max_width,
                         rd_env_mem *mem, rd_env_image *out)
{
    memset(r, 0, sizeof *r);
    r->width = w;
    r->height = h;
    r->mem = mem;
    r->out = out;
    r->levels = rd_env_reduced_size(w, h, max_width, &out->width, &out->height);
    for (unsigned i = 0; i < r->levels; i++, w /= 2) {
        r->pending[i] = rd_env_mem_alloc(mem, (size_t)w * 3 * sizeof(float), false);
        if (i + 1 < r->levels)
            r->folded[i] = rd_env_mem_alloc(mem, (size_t)(w / 2) * 3 * sizeof(float), false);
    }
    size_t bytes = (size_t)out->width * out->height * 3 * sizeof(float);
    out->rgb = calloc(1, bytes);
    if (!out->rgb) abort();
    rd_env_mem_count(mem, bytes);
}

void rd_env_reducer_push(rd_env_reducer *r, const float *row)
{
    if (r->rows >= r->height) return;
    uint32_t y = r->rows++, w = r->width, h = r->height;
    for (unsigned i = 0; i < r->levels; i++, y /= 2, w /= 2, h /= 2) {
        if (y >= h / 2 * 2) return; /* the odd last row of this level */
        size_t bytes = (size_t)w * 3 * sizeof(float);
        if (!(y & 1)) {
            memcpy(r->pending[i], row, bytes);
            return;
        }
        /* rows y - 1 and y make row y / 2 of the next level (as rd_env_image_limit sums them) */
        const float *r0 = r->pending[i], *r1 = row;
        float *n =
            i + 1 < r->levels ? r->folded[i] : r->out->rgb + (size_t)(y / 2) * r->out->width * 3;
        for (uint32_t x = 0; x < w / 2; x++)
            for (int c = 0; c < 3; c++) {
                size_t a = (size_t)2 * x * 3 + (size_t)c;
                n[(size_t)x * 3 + (size_t)c] = 0.25f * (r0[a] + r0[a + 3] + r1[a] + r1[a + 3]);
            }
        row = n;
    }
    if (r->levels == 0) memcpy(r->out->rgb + (size_t)y * w * 3, row, (size_t)w * 3 * sizeof *row);
}

void rd_env_reducer_dispose(rd_env_reducer *r)
{
    for (unsigned i = 0; i < RD_ENV_REDUCE_MAX_LEVELS; i++) {
        rd_env_mem_free(r->mem, r->pending[i]);
        rd_env_mem_free(r->mem, r->folded[i]);
        r->pending[i] = r->folded[i] = NULL;
    }
}
