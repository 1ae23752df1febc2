/* ddgi_readback.c: the probe field read back to the CPU, for `render --dump-probes` and tests:
 * the atlases as images (rd_ddgi_read_atlases) and every probe's position, state and ages
 * (rd_ddgi_read_probes). The GPU side of the field is ddgi.c. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/gi/ddgi.h"

static float half_to_float(uint16_t h)
{
    uint32_t sign = (uint32_t)(h & 0x8000) << 16, exp = (h >> 10) & 0x1f, man = h & 0x3ff;
    float f;
    if (exp == 0) {
        f = ldexpf((float)man, -24);
    } else if (exp == 31) {
        f = man ? NAN : INFINITY;
    } else {
        uint32_t bits = ((exp + 112) << 23) | (man << 13);
        memcpy(&f, &bits, 4);
    }
    return sign ? -f : f;
}

/* Lays out per-probe square tiles of `side` texels into one image. */
rd_vk_result rd_ddgi_read_probes(rd_ddgi *d, rd_ddgi_probe_info **out, char *err, size_t errlen)
{
    unsigned n = rd_ddgi_probe_count(d);
    pc_vec4 *probes = malloc((size_t)n * sizeof *probes + 1);
    pc_vec4 *stats = malloc((size_t)n * sizeof *stats + 1);
    rd_ddgi_probe_info *info = calloc((size_t)n + 1, sizeof *info);
    if (!probes || !stats || !info) abort();
    rd_vk_result r = rd_buffer_download(d->vk, &d->probes, 0, probes, (size_t)n * 16, err, errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_download(d->vk, &d->stats, 0, stats, (size_t)n * 16, err, errlen);
    const unsigned c[3] = {d->vol.counts.x, d->vol.counts.y, d->vol.counts.z};
    for (unsigned i = 0; r == RD_VK_OK && i < n; i++) {
        unsigned coord[3] = {i % c[0], (i / c[0]) % c[1], i / (c[0] * c[1])};
        const float o[3] = {d->vol.origin.x, d->vol.origin.y, d->vol.origin.z};
        const float s[3] = {d->vol.spacing.x, d->vol.spacing.y, d->vol.spacing.z};
        const float off[3] = {probes[i].x, probes[i].y, probes[i].z};
        for (int k = 0; k < 3; k++)
            info[i].position[k] = o[k] + (float)coord[k] * s[k] + off[k];
        info[i].state = (unsigned)probes[i].w;
        info[i].age = stats[i].x;
        info[i].held = stats[i].y;
        info[i].edges = (unsigned)stats[i].z;
    }
    free(probes);
    free(stats);
    if (r != RD_VK_OK) {
        free(info);
        return r;
    }
    *out = info;
    return RD_VK_OK;
}

static float *tile_image(unsigned probes, unsigned side, unsigned *w, unsigned *h)
{
    unsigned per_row = (unsigned)ceil(sqrt((double)probes));
    if (per_row == 0) per_row = 1;
    unsigned rows = (probes + per_row - 1) / per_row;
    *w = per_row * side;
    *h = (rows ? rows : 1) * side;
    float *img = calloc((size_t)*w * *h * 3, sizeof(float));
    if (!img) abort();
    return img;
}

rd_vk_result rd_ddgi_read_atlases(rd_ddgi *d, float **irr_rgb, unsigned *irr_w, unsigned *irr_h,
                                  float **dist_rgb, unsigned *dist_w, unsigned *dist_h, char *err,
                                  size_t errlen)
{
    unsigned probes = rd_ddgi_probe_count(d);
    size_t irr_texels = (size_t)probes * RD_DDGI_IRR_SIDE * RD_DDGI_IRR_SIDE;
    size_t dist_texels = (size_t)probes * RD_DDGI_DIST_SIDE * RD_DDGI_DIST_SIDE;
    uint16_t *irr = malloc(irr_texels * 8);
    float *dist = malloc(dist_texels * 8);
    if (!irr || !dist) abort();
    rd_vk_result r = rd_buffer_download(d->vk, &d->irradiance, 0, irr, irr_texels * 8, err, errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_download(d->vk, &d->distance, 0, dist, dist_texels * 8, err, errlen);
    if (r != RD_VK_OK) {
        free(irr);
        free(dist);
        return r;
    }
    float *a = tile_image(probes, RD_DDGI_IRR_SIDE, irr_w, irr_h);
    float *b = tile_image(probes, RD_DDGI_DIST_SIDE, dist_w, dist_h);
    unsigned per_row_a = *irr_w / RD_DDGI_IRR_SIDE, per_row_b = *dist_w / RD_DDGI_DIST_SIDE;
    float e = (float)d->vol.encoding;
    for (unsigned p = 0; p < probes; p++)
        for (unsigned y = 0; y < RD_DDGI_IRR_SIDE; y++)
            for (unsigned x = 0; x < RD_DDGI_IRR_SIDE; x++) {
                const uint16_t *t =
                    &irr[(((size_t)p * RD_DDGI_IRR_SIDE + y) * RD_DDGI_IRR_SIDE + x) * 4];
                size_t o = ((size_t)((p / per_row_a) * RD_DDGI_IRR_SIDE + y) * *irr_w +
                            (p % per_row_a) * RD_DDGI_IRR_SIDE + x) *
                           3;
                for (int c = 0; c < 3; c++)
                    a[o + c] = powf(fmaxf(half_to_float(t[c]), 0), e);
            }
    for (unsigned p = 0; p < probes; p++)
        for (unsigned y = 0; y < RD_DDGI_DIST_SIDE; y++)
            for (unsigned x = 0; x < RD_DDGI_DIST_SIDE; x++) {
                const float *t =
                    &dist[(((size_t)p * RD_DDGI_DIST_SIDE + y) * RD_DDGI_DIST_SIDE + x) * 2];
                size_t o = ((size_t)((p / per_row_b) * RD_DDGI_DIST_SIDE + y) * *dist_w +
                            (p % per_row_b) * RD_DDGI_DIST_SIDE + x) *
                           3;
                b[o] = t[0];
                b[o + 1] = t[1];
            }
    free(irr);
    free(dist);
    *irr_rgb = a;
    *dist_rgb = b;
    return RD_VK_OK;
}
