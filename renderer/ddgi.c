#include "ddgi.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shaders/ddgi_blend.spv.h"
#include "shaders/ddgi_border.spv.h"
#include "shaders/ddgi_shade.spv.h"
#include "shaders/ddgi_trace.spv.h"

#define IRR_SIDE (PC_DDGI_IRR_INTERIOR + 2)
#define DIST_SIDE (PC_DDGI_DIST_INTERIOR + 2)
#define MAX_PROBES 65535u /* one workgroup row per probe: the guaranteed dispatch limit */

rd_vk_result rd_ddgi_create(rd_vk *vk, rd_ddgi *d, char *err, size_t errlen)
{
    memset(d, 0, sizeof *d);
    d->vk = vk;
    rd_vk_result r = rd_pipeline_create(vk, &d->trace, "probe trace", pc_spv_ddgi_trace,
                                        sizeof pc_spv_ddgi_trace, sizeof(pc_push), err, errlen);
    if (r == RD_VK_OK)
        r = rd_pipeline_create(vk, &d->shade, "probe shade", pc_spv_ddgi_shade,
                               sizeof pc_spv_ddgi_shade, sizeof(pc_push), err, errlen);
    if (r == RD_VK_OK)
        r = rd_pipeline_create(vk, &d->blend, "probe blend", pc_spv_ddgi_blend,
                               sizeof pc_spv_ddgi_blend, sizeof(pc_push), err, errlen);
    if (r == RD_VK_OK)
        r = rd_pipeline_create(vk, &d->border, "probe borders", pc_spv_ddgi_border,
                               sizeof pc_spv_ddgi_border, sizeof(pc_push), err, errlen);
    if (r != RD_VK_OK) rd_ddgi_destroy(d);
    return r;
}

static void free_buffers(rd_ddgi *d)
{
    rd_buffer_destroy(d->vk, &d->irradiance);
    rd_buffer_destroy(d->vk, &d->distance);
    rd_buffer_destroy(d->vk, &d->rays);
    rd_buffer_destroy(d->vk, &d->hits);
    rd_buffer_destroy(d->vk, &d->probes);
}

void rd_ddgi_destroy(rd_ddgi *d)
{
    if (!d->vk) return;
    free_buffers(d);
    rd_pipeline_destroy(d->vk, &d->border);
    rd_pipeline_destroy(d->vk, &d->blend);
    rd_pipeline_destroy(d->vk, &d->shade);
    rd_pipeline_destroy(d->vk, &d->trace);
    d->configured = false;
    d->vk = NULL; /* destroyed: rd_ddgi_create must run again before use */
}

unsigned rd_ddgi_probe_count(const rd_ddgi *d)
{
    return d->vol.counts.x * d->vol.counts.y * d->vol.counts.z;
}

/* Grid placement. Default: spacing = longest extent / 8 (at least 8 probes along the longest
 * axis), probes at cell centres so that none sits exactly on the bounding walls. */
static bool place_grid(const float bmin[3], const float bmax[3], const rd_ddgi_settings *s,
                       float origin[3], float spacing[3], unsigned counts[3], char *err,
                       size_t errlen)
{
    float ext[3], longest = 0;
    for (int k = 0; k < 3; k++) {
        ext[k] = bmax[k] - bmin[k];
        if (!(ext[k] > 0) || !isfinite(ext[k])) ext[k] = 0;
        if (ext[k] > longest) longest = ext[k];
    }
    if (!(longest > 0)) longest = 1;
    for (int k = 0; k < 3; k++) {
        if (s->spacing[k] < 0 || !isfinite(s->spacing[k])) {
            snprintf(err, errlen, "probe spacing must be positive");
            return false;
        }
        if (s->counts[k]) {
            counts[k] = s->counts[k];
            spacing[k] = s->spacing[k] > 0 ? s->spacing[k]
                                           : (ext[k] > 0 ? ext[k] : longest / 8) / counts[k];
        } else {
            float target = s->spacing[k] > 0 ? s->spacing[k] : longest / 8;
            double n = ceil(ext[k] / target);
            counts[k] = n < 1 ? 1 : n > 256 ? 256 : (unsigned)n;
            spacing[k] = s->spacing[k] > 0 ? s->spacing[k]
                                           : (ext[k] > 0 ? ext[k] / counts[k] : target);
        }
        if (counts[k] > 256) {
            snprintf(err, errlen, "at most 256 probes per axis (got %u)", counts[k]);
            return false;
        }
        float centre = 0.5f * (bmin[k] + bmax[k]);
        origin[k] = s->has_origin ? s->origin[k]
                                  : centre - 0.5f * spacing[k] * (float)(counts[k] - 1);
    }
    if ((uint64_t)counts[0] * counts[1] * counts[2] > MAX_PROBES) {
        snprintf(err, errlen, "%u x %u x %u probes exceed the limit of %u", counts[0], counts[1],
                 counts[2], MAX_PROBES);
        return false;
    }
    return true;
}

rd_vk_result rd_ddgi_configure(rd_ddgi *d, const float bmin[3], const float bmax[3],
                               const rd_ddgi_settings *s, char *err, size_t errlen)
{
    float origin[3], spacing[3];
    unsigned counts[3];
    unsigned rays = s->rays ? s->rays : RD_DDGI_DEFAULT_RAYS;
    float hysteresis =
        s->has_hysteresis || s->hysteresis != 0 ? s->hysteresis : RD_DDGI_DEFAULT_HYSTERESIS;
    if (rays > PC_DDGI_MAX_RAYS) {
        snprintf(err, errlen, "at most %u rays per probe (got %u)", PC_DDGI_MAX_RAYS, rays);
        return RD_VK_ERR_UNSUPPORTED;
    }
    if (!(hysteresis >= 0 && hysteresis < 1)) {
        snprintf(err, errlen, "hysteresis must be in [0, 1) (got %g)", hysteresis);
        return RD_VK_ERR_UNSUPPORTED;
    }
    if (!place_grid(bmin, bmax, s, origin, spacing, counts, err, errlen))
        return RD_VK_ERR_UNSUPPORTED;
    uint64_t probes = (uint64_t)counts[0] * counts[1] * counts[2];
    bool realloc_needed = !d->configured || probes != rd_ddgi_probe_count(d) ||
                          rays != d->vol.counts.w;
    if (realloc_needed) {
        free_buffers(d);
        d->configured = false;
        rd_vk_result r = rd_buffer_create(d->vk, &d->irradiance, probes * IRR_SIDE * IRR_SIDE * 8,
                                          RD_MEMORY_DEVICE, err, errlen);
        if (r == RD_VK_OK)
            r = rd_buffer_create(d->vk, &d->distance, probes * DIST_SIDE * DIST_SIDE * 8,
                                 RD_MEMORY_DEVICE, err, errlen);
        if (r == RD_VK_OK)
            r = rd_buffer_create(d->vk, &d->rays, probes * rays * 16, RD_MEMORY_DEVICE, err, errlen);
        if (r == RD_VK_OK)
            r = rd_buffer_create(d->vk, &d->hits, probes * rays * 16, RD_MEMORY_DEVICE, err, errlen);
        if (r == RD_VK_OK)
            r = rd_buffer_create(d->vk, &d->probes, probes * 16, RD_MEMORY_DEVICE, err, errlen);
        if (r != RD_VK_OK) {
            free_buffers(d);
            return r;
        }
    }
    d->settings = *s;
    float min_spacing = fminf(spacing[0], fminf(spacing[1], spacing[2]));
    float max_dist = 1.5f * sqrtf(spacing[0] * spacing[0] + spacing[1] * spacing[1] +
                                  spacing[2] * spacing[2]);
    pc_ddgi_volume *v = &d->vol;
    memset(v, 0, sizeof *v);
    v->origin = (pc_vec4){origin[0], origin[1], origin[2], max_dist};
    v->spacing = (pc_vec4){spacing[0], spacing[1], spacing[2], 0};
    v->counts = (pc_uvec4){counts[0], counts[1], counts[2], rays};
    /* 2021 paper: bias = (0.2 n + 0.8 v) * 0.75 * min spacing * 0.3 */
    v->params = (pc_vec4){hysteresis, 0.75f * min_spacing * 0.3f, 0.10f, 5.0f};
    v->info = (pc_uvec4){s->mode, 0, IRR_SIDE, DIST_SIDE};
    v->irradiance = d->irradiance.address;
    v->distance = d->distance.address;
    v->rays = d->rays.address;
    v->probes = d->probes.address;
    d->configured = true;
    return rd_ddgi_reset(d, err, errlen);
}

rd_vk_result rd_ddgi_reset(rd_ddgi *d, char *err, size_t errlen)
{
    d->updates = 0;
    d->vol.info.y = 0;
    rd_vk_result r = rd_buffer_fill(d->vk, &d->irradiance, 0, err, errlen);
    if (r == RD_VK_OK) r = rd_buffer_fill(d->vk, &d->distance, 0, err, errlen);
    /* every probe starts active (w = 1.0f) with no offset */
    if (r == RD_VK_OK) r = rd_buffer_fill(d->vk, &d->probes, 0, err, errlen);
    unsigned n = rd_ddgi_probe_count(d);
    for (unsigned i = 0; r == RD_VK_OK && i < n; i += 4096) {
        pc_vec4 chunk[4096];
        unsigned m = n - i < 4096 ? n - i : 4096;
        for (unsigned k = 0; k < m; k++) chunk[k] = (pc_vec4){0, 0, 0, (float)PC_DDGI_PROBE_ACTIVE};
        r = rd_buffer_upload(d->vk, &d->probes, (VkDeviceSize)i * 16, chunk, (VkDeviceSize)m * 16,
                             err, errlen);
    }
    return r;
}

static uint64_t splitmix64(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static double uniform01(uint64_t *s)
{
    return (double)(splitmix64(s) >> 11) * (1.0 / 9007199254740992.0);
}

void rd_ddgi_random_rotation(uint64_t *state, float m[3][3])
{
    /* Shoemake, "Uniform random rotations" (Graphics Gems III): a uniform unit quaternion. */
    double u1 = uniform01(state), u2 = uniform01(state), u3 = uniform01(state);
    double a = sqrt(1 - u1), b = sqrt(u1);
    double x = a * sin(2 * M_PI * u2), y = a * cos(2 * M_PI * u2);
    double z = b * sin(2 * M_PI * u3), w = b * cos(2 * M_PI * u3);
    m[0][0] = (float)(1 - 2 * (y * y + z * z));
    m[0][1] = (float)(2 * (x * y - z * w));
    m[0][2] = (float)(2 * (x * z + y * w));
    m[1][0] = (float)(2 * (x * y + z * w));
    m[1][1] = (float)(1 - 2 * (x * x + z * z));
    m[1][2] = (float)(2 * (y * z - x * w));
    m[2][0] = (float)(2 * (x * z - y * w));
    m[2][1] = (float)(2 * (y * z + x * w));
    m[2][2] = (float)(1 - 2 * (x * x + y * y));
}

void rd_ddgi_begin_update(rd_ddgi *d)
{
    /* The rotation depends only on (seed, update index): same seed, same image. */
    uint64_t state = ((uint64_t)d->settings.seed << 32) ^ (uint64_t)d->updates * 0x632be59bd9b4e019ull;
    float m[3][3];
    rd_ddgi_random_rotation(&state, m);
    for (int r = 0; r < 3; r++) d->vol.rotation[r] = (pc_vec4){m[r][0], m[r][1], m[r][2], 0};
    d->vol.info.y = d->updates;
}

void rd_ddgi_record_update(rd_ddgi *d, rd_cmd *c, rd_timer *timer, VkDeviceAddress globals,
                           VkDeviceAddress counters)
{
    unsigned probes = rd_ddgi_probe_count(d), rays = d->vol.counts.w;
    pc_push push = {.globals = globals, .buf0 = d->hits.address, .buf1 = counters};
    uint32_t ray_groups = (rays + PC_WG_1D - 1) / PC_WG_1D;
    rd_cmd_dispatch(c, &d->trace, &push, ray_groups, probes, 1);
    rd_cmd_barrier(c);
    if (timer) rd_timer_mark(c, timer, "probe trace");
    push.params.y = d->updates > 0;
    rd_cmd_dispatch(c, &d->shade, &push, ray_groups, probes, 1);
    rd_cmd_barrier(c);
    if (timer) rd_timer_mark(c, timer, "probe shade");
    /* distance first: the irradiance blend re-classifies probes, and both must see the
     * classification the trace used */
    push.params = (pc_uvec4){1, 0, 0, 0};
    rd_cmd_dispatch(c, &d->blend, &push, probes, 1, 1);
    rd_cmd_barrier(c);
    if (timer) rd_timer_mark(c, timer, "blend distance");
    push.params.x = 0;
    rd_cmd_dispatch(c, &d->blend, &push, probes, 1, 1);
    rd_cmd_barrier(c);
    if (timer) rd_timer_mark(c, timer, "blend irradiance");
    push.params.x = 0;
    rd_cmd_dispatch(c, &d->border, &push, (probes * 4 * (IRR_SIDE - 1) + PC_WG_1D - 1) / PC_WG_1D, 1, 1);
    push.params.x = 1;
    rd_cmd_dispatch(c, &d->border, &push, (probes * 4 * (DIST_SIDE - 1) + PC_WG_1D - 1) / PC_WG_1D, 1, 1);
    rd_cmd_barrier(c);
    if (timer) rd_timer_mark(c, timer, "borders");
}

void rd_ddgi_end_update(rd_ddgi *d)
{
    d->updates++;
}

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
                                  float **dist_rgb, unsigned *dist_w, unsigned *dist_h,
                                  char *err, size_t errlen)
{
    unsigned probes = rd_ddgi_probe_count(d);
    size_t irr_texels = (size_t)probes * IRR_SIDE * IRR_SIDE;
    size_t dist_texels = (size_t)probes * DIST_SIDE * DIST_SIDE;
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
    float *a = tile_image(probes, IRR_SIDE, irr_w, irr_h);
    float *b = tile_image(probes, DIST_SIDE, dist_w, dist_h);
    unsigned per_row_a = *irr_w / IRR_SIDE, per_row_b = *dist_w / DIST_SIDE;
    float e = d->vol.params.w;
    for (unsigned p = 0; p < probes; p++)
        for (unsigned y = 0; y < IRR_SIDE; y++)
            for (unsigned x = 0; x < IRR_SIDE; x++) {
                const uint16_t *t = &irr[(((size_t)p * IRR_SIDE + y) * IRR_SIDE + x) * 4];
                size_t o = ((size_t)((p / per_row_a) * IRR_SIDE + y) * *irr_w +
                            (p % per_row_a) * IRR_SIDE + x) * 3;
                for (int c = 0; c < 3; c++) a[o + c] = powf(fmaxf(half_to_float(t[c]), 0), e);
            }
    for (unsigned p = 0; p < probes; p++)
        for (unsigned y = 0; y < DIST_SIDE; y++)
            for (unsigned x = 0; x < DIST_SIDE; x++) {
                const float *t = &dist[(((size_t)p * DIST_SIDE + y) * DIST_SIDE + x) * 2];
                size_t o = ((size_t)((p / per_row_b) * DIST_SIDE + y) * *dist_w +
                            (p % per_row_b) * DIST_SIDE + x) * 3;
                b[o] = t[0];
                b[o + 1] = t[1];
            }
    free(irr);
    free(dist);
    *irr_rgb = a;
    *dist_rgb = b;
    return RD_VK_OK;
}
