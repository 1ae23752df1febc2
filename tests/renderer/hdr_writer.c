/* hdr_writer.c: see hdr_writer.h. */
#include "hdr_writer.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* RGBE of a float colour (Ward's encoding). */
void pc_rgbe(const float c[3], uint8_t out[4])
{
    float m = fmaxf(c[0], fmaxf(c[1], c[2]));
    if (m < 1e-32f) {
        memset(out, 0, 4);
        return;
    }
    int e;
    float f = frexpf(m, &e) * 256.0f / m;
    for (int i = 0; i < 3; i++)
        out[i] = (uint8_t)(c[i] * f);
    out[3] = (uint8_t)(e + 128);
}

void pc_bytes_put(pc_bytes *b, const void *p, size_t n)
{
    if (b->n + n > b->cap) {
        b->cap = (b->n + n) * 2;
        b->d = realloc(b->d, b->cap);
        if (!b->d) abort();
    }
    memcpy(b->d + b->n, p, n);
    b->n += n;
}

static uint32_t noise(uint32_t x, uint32_t y, uint32_t c)
{
    uint32_t h = x * 0x9e3779b1u ^ y * 0x85ebca77u ^ c * 0xc2b2ae3du;
    h ^= h >> 15;
    h *= 0x2c1b3c6du;
    h ^= h >> 12;
    return h;
}

void pc_noisy_texel(unsigned x, unsigned y, float c[3])
{
    for (uint32_t i = 0; i < 3; i++) {
        uint32_t h = noise(x, y, i);
        c[i] = ldexpf(1.0f + (float)(h & 0xffffff) / 16777216.0f, (int)(h >> 24) % 16 - 8);
    }
}

pc_bytes pc_hdr_write(unsigned w, unsigned h, bool rle, void (*tex)(unsigned, unsigned, float[3]))
{
    pc_bytes b = {0};
    char head[128];
    int k = snprintf(head, sizeof head,
                     "#?RADIANCE\n# a comment\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=1\n\n-Y %u +X %u\n",
                     h, w);
    pc_bytes_put(&b, head, (size_t)k);
    uint8_t *line = malloc((size_t)w * 4);
    for (unsigned y = 0; y < h; y++) {
        for (unsigned x = 0; x < w; x++) {
            float c[3];
            tex(x, y, c);
            pc_rgbe(c, line + x * 4);
        }
        if (!rle) {
            pc_bytes_put(&b, line, (size_t)w * 4);
            continue;
        }
        uint8_t mark[4] = {2, 2, (uint8_t)(w >> 8), (uint8_t)(w & 255)};
        pc_bytes_put(&b, mark, 4);
        for (int c = 0; c < 4; c++) {
            unsigned x = 0;
            while (x < w) {
                unsigned run = 1;
                while (x + run < w && run < 127 && line[(x + run) * 4 + c] == line[x * 4 + c])
                    run++;
                if (run >= 3) {
                    uint8_t r[2] = {(uint8_t)(128 + run), line[x * 4 + c]};
                    pc_bytes_put(&b, r, 2);
                    x += run;
                } else {
                    unsigned lit = 0;
                    while (x + lit < w && lit < 128) {
                        unsigned same = 1;
                        while (x + lit + same < w && same < 3 &&
                               line[(x + lit + same) * 4 + c] == line[(x + lit) * 4 + c])
                            same++;
                        if (same >= 3) break;
                        lit++;
                    }
                    uint8_t n = (uint8_t)lit;
                    pc_bytes_put(&b, &n, 1);
                    for (unsigned i = 0; i < lit; i++)
                        pc_bytes_put(&b, &line[(x + i) * 4 + c], 1);
                    x += lit;
                }
            }
        }
    }
    free(line);
    return b;
}

pc_bytes pc_hdr_constant(unsigned w, unsigned h, const uint8_t rgbe[4])
{
    pc_bytes b = {0};
    char head[96];
    int k =
        snprintf(head, sizeof head, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %u +X %u\n", h, w);
    pc_bytes_put(&b, head, (size_t)k);
    for (unsigned y = 0; y < h; y++) {
        uint8_t mark[4] = {2, 2, (uint8_t)(w >> 8), (uint8_t)(w & 255)};
        pc_bytes_put(&b, mark, 4);
        for (int c = 0; c < 4; c++)
            for (unsigned x = 0; x < w;) {
                unsigned run = w - x < 127 ? w - x : 127;
                uint8_t r[2] = {(uint8_t)(128 + run), rgbe[c]};
                pc_bytes_put(&b, r, 2);
                x += run;
            }
    }
    return b;
}
