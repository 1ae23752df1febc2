#include "renderer/gi/ddgi.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shaders/ddgi_bin.spv.h"
#include "shaders/ddgi_blend_distance.spv.h"
#include "shaders/ddgi_blend_irradiance.spv.h"
#include "shaders/ddgi_border.spv.h"
#include "shaders/ddgi_scan.spv.h"
#include "shaders/ddgi_select.spv.h"
#include "shaders/ddgi_select.masked.spv.h"
#include "shaders/ddgi_shade.spv.h"
#include "shaders/ddgi_shade.masked.spv.h"
#include "shaders/ddgi_trace.spv.h"
#include "shaders/ddgi_trace.masked.spv.h"
#include "shaders/ddgi_wake.spv.h"
#include "shaders/ddgi_weights.spv.h"

/* The probe passes, one line each (rd_ddgi_update dispatches them). */
static const rd_pipeline_desc pipelines[] = {
    RD_PIPELINE_DESC_MASKED(rd_ddgi, trace, "probe trace", pc_spv_ddgi_trace, sizeof(pc_push)),
    RD_PIPELINE_DESC_MASKED(rd_ddgi, shade, "probe shade", pc_spv_ddgi_shade, sizeof(pc_push)),
    RD_PIPELINE_DESC(rd_ddgi, blend_distance, "probe blend distance", pc_spv_ddgi_blend_distance,
                     sizeof(pc_push)),
    RD_PIPELINE_DESC(rd_ddgi, blend_irradiance, "probe blend irradiance",
                     pc_spv_ddgi_blend_irradiance, sizeof(pc_push)),
    RD_PIPELINE_DESC(rd_ddgi, border, "probe borders", pc_spv_ddgi_border, sizeof(pc_push)),
    RD_PIPELINE_DESC_MASKED(rd_ddgi, select, "probe select", pc_spv_ddgi_select, sizeof(pc_push)),
    RD_PIPELINE_DESC(rd_ddgi, wake, "probe wake", pc_spv_ddgi_wake, sizeof(pc_push)),
    RD_PIPELINE_DESC(rd_ddgi, bin, "probe bin", pc_spv_ddgi_bin, sizeof(pc_push)),
    RD_PIPELINE_DESC(rd_ddgi, scan, "probe bin scan", pc_spv_ddgi_scan, sizeof(pc_push)),
    RD_PIPELINE_DESC(rd_ddgi, weights, "probe blend weights", pc_spv_ddgi_weights, sizeof(pc_push)),
};
#define PIPELINE_COUNT (sizeof pipelines / sizeof pipelines[0])

rd_vk_result rd_ddgi_create(rd_vk *vk, rd_ddgi *d, char *err, size_t errlen)
{
    memset(d, 0, sizeof *d);
    d->vk = vk;
    rd_vk_result r = rd_pipelines_create(vk, d, pipelines, PIPELINE_COUNT, err, errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_create(vk, &d->bins, PC_DDGI_BINS * 4, RD_MEMORY_DEVICE, err, errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_create(vk, &d->ctrl, sizeof(pc_ddgi_control), RD_MEMORY_UPLOAD, err, errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_create(vk, &d->wake_boxes, sizeof(pc_ddgi_wake) * PC_DDGI_WAKE_MAX,
                             RD_MEMORY_UPLOAD, err, errlen);
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
    rd_buffer_destroy(d->vk, &d->stats);
    rd_buffer_destroy(d->vk, &d->list);
    rd_buffer_destroy(d->vk, &d->order);
    rd_buffer_destroy(d->vk, &d->sorted);
    rd_buffer_destroy(d->vk, &d->weight_lists);
}

void rd_ddgi_destroy(rd_ddgi *d)
{
    if (!d->vk) return;
    free_buffers(d);
    rd_buffer_destroy(d->vk, &d->ctrl);
    rd_buffer_destroy(d->vk, &d->wake_boxes);
    rd_buffer_destroy(d->vk, &d->bins);
    rd_pipelines_destroy(d->vk, d, pipelines, PIPELINE_COUNT);
    d->configured = false;
    d->vk = NULL; /* destroyed: rd_ddgi_create must run again before use */
}

unsigned rd_ddgi_probe_count(const rd_ddgi *d)
{
    return d->vol.counts.x * d->vol.counts.y * d->vol.counts.z;
}

/* Grid placement. Default: about 8 probes along the longest axis, the outermost layers 15% of
 * that axis's spacing inside the scene bounds on every axis, so that surfaces on the bounds lie
 * nearly between probes instead of half a spacing outside the outermost layer. Irradiance grows
 * toward a room's interior (bright spots get closer), so layers half a spacing inside over-light
 * every wall and the bounces amplify it. Measured (H200, 64x48, converged, mean luminance against
 * the path tracer; margin in spacings): margin 0.5 (cell centres, the old rule): white-room +6.5%,
 * two-rooms lit room +12.1%, hard:cornell +4.1%, thick-walls +2.8%; margin 0.15: +1.2%, +2.7%,
 * +1.7%, +0.8%; margin 0.05: +1.3%, +1.4%, +2.2% (relMSE of cornell 25% higher: probes
 * hugging an emitter over-light its neighbours), -0.3%. Given counts keep the margin in their
 * own spacing (below). */
#define PROBE_MARGIN 0.15f /* outermost layers inside the bounds, in spacings */
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
    float default_spacing = longest / 7, margin = PROBE_MARGIN * default_spacing;
    for (int k = 0; k < 3; k++) {
        if (s->spacing[k] < 0 || !isfinite(s->spacing[k])) {
            snprintf(err, errlen, "probe spacing must be positive");
            return false;
        }
        float span = ext[k] - 2 * margin; /* where probes may go */
        if (span < 0) span = 0;
        if (s->counts[k]) {
            counts[k] = s->counts[k];
        } else {
            /* A fitted spacing stretches to the span. A given one is kept, and its outermost
             * layers lie between 2% and 52% of a spacing inside the bounds: rounded up to the
             * span, they reached past it, and with a spacing that divides the bounds (1 m in
             * an 8 x 3 x 4 m room) lay on the walls, half their rays outside the room (33% dark,
             * and the field never slept); rounded down to the span, they could stop a whole
             * spacing short of the floor, where the query fades toward the sky (0.25 m: 63%
             * dark; tests/bench/results/h200/narrow_gap_spacing.txt). */
            double given = ext[k] / (s->spacing[k] > 0 ? s->spacing[k] : 1);
            double n = s->spacing[k] > 0 ? (given > 0.04 ? floor(given - 0.04) + 1 : 1)
                       : span <= 0       ? 1
                                         : floor(span / default_spacing + 0.999) + 1;
            counts[k] = n < 1                         ? 1
                        : n > RD_DDGI_MAX_AXIS_PROBES ? RD_DDGI_MAX_AXIS_PROBES
                                                      : (unsigned)n;
        }
        if (counts[k] > RD_DDGI_MAX_AXIS_PROBES) {
            snprintf(err, errlen, "at most %u probes per axis (got %u)", RD_DDGI_MAX_AXIS_PROBES,
                     counts[k]);
            return false;
        }
        if (s->spacing[k] > 0)
            spacing[k] = s->spacing[k];
        else if (counts[k] > 1 && span > 0)
            /* Given counts keep their outermost layers 0.15 of their own spacing inside the
             * bounds. With the fitted grid's margin they stood up to 1.8 spacings inside, so
             * that the floor and ceiling were queried outside the grid, where the field fades
             * (thin-walls at 4x the fitted density, 32 x 8 x 32: -23% against the path
             * tracer, floor 0.37 and ceiling 0.11 of it; with this margin narrow-gap at 4x
             * comes to -3.8% and the lamp room to -0.4%: H200,
             * tests/bench/results/h200/probe_margin_stop42.txt). The fitted grid keeps its
             * rule: the own-spacing margin measured worse there (thin-walls -3.0 -> -4.4%). */
            spacing[k] = s->counts[k] ? ext[k] / ((float)(counts[k] - 1) + 2 * PROBE_MARGIN)
                                      : span / (float)(counts[k] - 1);
        else
            spacing[k] = ext[k] > 0 ? ext[k] : default_spacing;
        float centre = 0.5f * (bmin[k] + bmax[k]);
        origin[k] =
            s->has_origin ? s->origin[k] : centre - 0.5f * spacing[k] * (float)(counts[k] - 1);
    }
    if ((uint64_t)counts[0] * counts[1] * counts[2] > RD_DDGI_MAX_PROBES) {
        snprintf(err, errlen, "%u x %u x %u probes exceed the limit of %u", counts[0], counts[1],
                 counts[2], RD_DDGI_MAX_PROBES);
        return false;
    }
    return true;
}

/* Ray order (pc_ddgi_volume.order): the spherical Fibonacci directions of shaders/ddgi.glsl
 * (unrotated; the update's rotation moves patches as a whole) sorted by the Morton code of their
 * octahedral coordinates, so consecutive threads, and so each warp, take neighbouring directions.
 * Index order spirals around the sphere by the golden angle: a warp's 32 rays would be spread
 * over a whole band of it. */
typedef struct ray_key {
    uint32_t code, ray;
} ray_key;

static int cmp_ray_key(const void *a, const void *b)
{
    const ray_key *x = a, *y = b;
    if (x->code != y->code) return x->code < y->code ? -1 : 1;
    return x->ray < y->ray ? -1 : x->ray > y->ray;
}

static uint32_t spread_bits(uint32_t v) /* 16 bits -> even bits of 32 */
{
    v &= 0xffff;
    v = (v | (v << 8)) & 0x00ff00ff;
    v = (v | (v << 4)) & 0x0f0f0f0f;
    v = (v | (v << 2)) & 0x33333333;
    v = (v | (v << 1)) & 0x55555555;
    return v;
}

void rd_ddgi_ray_order(unsigned rays, uint32_t *order)
{
    ray_key keys[PC_DDGI_MAX_RAYS];
    const double golden = 0.61803398874989484820;
    for (unsigned i = 0; i < rays; i++) {
        double phi = 2.0 * M_PI * fmod(i * golden, 1.0);
        double z = 1.0 - (2.0 * i + 1.0) / rays, r = sqrt(fmax(0.0, 1.0 - z * z));
        double x = cos(phi) * r, y = sin(phi) * r;
        double l1 = fabs(x) + fabs(y) + fabs(z), u = x / l1, v = y / l1;
        if (z < 0) { /* fold the lower hemisphere onto the square's corners */
            double fu = (1.0 - fabs(v)) * (u >= 0 ? 1 : -1),
                   fv = (1.0 - fabs(u)) * (v >= 0 ? 1 : -1);
            u = fu, v = fv;
        }
        uint32_t qu = (uint32_t)fmin(65535.0, (u * 0.5 + 0.5) * 65536.0);
        uint32_t qv = (uint32_t)fmin(65535.0, (v * 0.5 + 0.5) * 65536.0);
        keys[i] = (ray_key){spread_bits(qu) | spread_bits(qv) << 1, i};
    }
    qsort(keys, rays, sizeof keys[0], cmp_ray_key);
    for (unsigned i = 0; i < rays; i++)
        order[i] = keys[i].ray;
}

static rd_vk_result upload_ray_order(rd_ddgi *d, unsigned rays, char *err, size_t errlen)
{
    uint32_t order[PC_DDGI_MAX_RAYS];
    rd_ddgi_ray_order(rays, order);
    rd_vk_result r =
        rd_buffer_create(d->vk, &d->order, (VkDeviceSize)rays * 4, RD_MEMORY_DEVICE, err, errlen);
    if (r == RD_VK_OK)
        r = rd_buffer_upload(d->vk, &d->order, 0, order, (VkDeviceSize)rays * 4, err, errlen);
    return r;
}

rd_vk_result rd_ddgi_configure(rd_ddgi *d, const float bmin[3], const float bmax[3],
                               const rd_ddgi_settings *s, char *err, size_t errlen)
{
    float origin[3], spacing[3];
    unsigned counts[3];
    unsigned rays = s->rays ? s->rays : RD_DDGI_DEFAULT_RAYS;
    float hysteresis = s->has_hysteresis ? s->hysteresis : RD_DDGI_DEFAULT_HYSTERESIS;
    if (rays > PC_DDGI_MAX_RAYS) {
        snprintf(err, errlen, "at most %u rays per probe (got %u)", PC_DDGI_MAX_RAYS, rays);
        return RD_VK_ERR_UNSUPPORTED;
    }
    if (s->visibility > PC_DDGI_VIS_OFF) {
        snprintf(err, errlen, "unknown visibility rays mode %u", s->visibility);
        return RD_VK_ERR_UNSUPPORTED;
    }
    unsigned bounces = s->has_path_bounces ? s->path_bounces : RD_DDGI_DEFAULT_PATH_BOUNCES;
    if (bounces > RD_DDGI_MAX_PATH_BOUNCES) {
        snprintf(err, errlen, "probe paths take at most %u bounces (got %u)",
                 RD_DDGI_MAX_PATH_BOUNCES, bounces);
        return RD_VK_ERR_UNSUPPORTED;
    }
    if (!(hysteresis >= 0 && hysteresis <= RD_DDGI_MAX_HYSTERESIS)) {
        snprintf(err, errlen, "hysteresis must be in [0, %g] (got %g)",
                 (double)RD_DDGI_MAX_HYSTERESIS, hysteresis);
        return RD_VK_ERR_UNSUPPORTED;
    }
    if (!place_grid(bmin, bmax, s, origin, spacing, counts, err, errlen))
        return RD_VK_ERR_UNSUPPORTED;
    uint64_t probes = (uint64_t)counts[0] * counts[1] * counts[2];
    bool realloc_needed =
        !d->configured || probes != rd_ddgi_probe_count(d) || rays != d->vol.counts.w;
    if (realloc_needed) {
        free_buffers(d);
        d->configured = false;
        rd_vk_result r = rd_buffer_create(d->vk, &d->irradiance,
                                          probes * RD_DDGI_IRR_SIDE * RD_DDGI_IRR_SIDE * 8,
                                          RD_MEMORY_DEVICE, err, errlen);
        if (r == RD_VK_OK)
            r = rd_buffer_create(d->vk, &d->distance,
                                 probes * RD_DDGI_DIST_SIDE * RD_DDGI_DIST_SIDE * 8,
                                 RD_MEMORY_DEVICE, err, errlen);
        if (r == RD_VK_OK)
            r = rd_buffer_create(d->vk, &d->rays, probes * rays * 16, RD_MEMORY_DEVICE, err,
                                 errlen);
        if (r == RD_VK_OK)
            r = rd_buffer_create(d->vk, &d->hits, probes * rays * 16, RD_MEMORY_DEVICE, err,
                                 errlen);
        if (r == RD_VK_OK)
            r = rd_buffer_create(d->vk, &d->probes, probes * 16, RD_MEMORY_DEVICE, err, errlen);
        if (r == RD_VK_OK)
            r = rd_buffer_create(d->vk, &d->stats, probes * 16, RD_MEMORY_DEVICE, err, errlen);
        if (r == RD_VK_OK)
            r = rd_buffer_create(d->vk, &d->list, probes * 4, RD_MEMORY_DEVICE, err, errlen);
        if (r == RD_VK_OK) r = upload_ray_order(d, rays, err, errlen);
        if (r == RD_VK_OK)
            r = rd_buffer_create(d->vk, &d->sorted, probes * rays * 4, RD_MEMORY_DEVICE, err,
                                 errlen);
        if (r == RD_VK_OK)
            r = rd_buffer_create(d->vk, &d->weight_lists,
                                 PC_DDGI_WEIGHT_HEADER +
                                     (VkDeviceSize)PC_DDGI_WEIGHT_TEXELS * rays * 8,
                                 RD_MEMORY_DEVICE, err, errlen);
        if (r != RD_VK_OK) {
            free_buffers(d);
            return r;
        }
    }
    d->settings = *s;
    float min_spacing = fminf(spacing[0], fminf(spacing[1], spacing[2]));
    float max_dist =
        1.5f * sqrtf(spacing[0] * spacing[0] + spacing[1] * spacing[1] + spacing[2] * spacing[2]);
    pc_ddgi_volume *v = &d->vol;
    memset(v, 0, sizeof *v);
    v->origin = (pc_vec4){origin[0], origin[1], origin[2], max_dist};
    v->spacing = (pc_vec4){spacing[0], spacing[1], spacing[2], (float)s->visibility};
    v->counts = (pc_uvec4){counts[0], counts[1], counts[2], rays};
    /* 2021 paper: bias = (0.2 n + 0.8 v) * 0.75 * min spacing * 0.3 */
    v->params = (pc_vec4){hysteresis, 0.75f * min_spacing * 0.3f, 0.10f, 0.0f};
    v->info = (pc_uvec4){s->mode, 0, RD_DDGI_IRR_SIDE, RD_DDGI_DIST_SIDE};
    v->irradiance = d->irradiance.address;
    v->distance = d->distance.address;
    v->rays = d->rays.address;
    v->probes = d->probes.address;
    v->control = (pc_uvec4){0, 0, 0, 0};
    float sleep_age = rd_ddgi_sleep_age(hysteresis);
    memcpy(&v->control.y, &sleep_age, sizeof sleep_age);
    v->stats = d->stats.address;
    v->list = d->list.address;
    v->ctrl = d->ctrl.address;
    v->wake = d->wake_boxes.address;
    v->order = d->order.address;
    v->weights = d->weight_lists.address;
    v->relocate = s->relocation;
    v->blend_lists = d->vk->is_cpu;
    v->path_bounces = bounces;
    /* continued paths need the linear blend, first hits keep the paper's encoding (gpu_types.h) */
    v->encoding = bounces > 0 ? 1u : PC_DDGI_ENCODING_PAPER;
    d->configured = true;
    return rd_ddgi_reset(d, err, errlen);
}

/* Forgets the drift statistics (a new set of awake probes is measured from scratch). */
static void drift_restart(rd_ddgi *d)
{
    d->drift = d->drift_var = 0;
    d->drift_measures = 0;
    d->hold = false;
}

/* Fixed-point units per unit of encoded luminance (pc_ddgi_volume.params.w) for probe tiles of
 * mean encoded luminance `mean` (summed over the tile's texels): such a probe contributes 1/64
 * of the per-probe limit, so probes up to 64 times brighter than the mean sum exactly. */
static double drift_unit(const rd_ddgi *d, double mean)
{
    unsigned probes = rd_ddgi_probe_count(d);
    double limit = (double)(PC_DDGI_DRIFT_RANGE / (probes ? probes : 1u));
    return limit / 64.0 / mean;
}

rd_vk_result rd_ddgi_reset(rd_ddgi *d, char *err, size_t errlen)
{
    d->updates = 0;
    d->vol.info.y = 0;
    d->census = (rd_ddgi_census){.awake = rd_ddgi_probe_count(d)};
    drift_restart(d);
    d->drift_unit = drift_unit(d, 64.0); /* until measured: encoded luminance 1 per texel */
    d->wake_count = 0;
    rd_vk_result r = rd_buffer_fill(d->vk, &d->irradiance, 0, err, errlen);
    if (r == RD_VK_OK) r = rd_buffer_fill(d->vk, &d->distance, 0, err, errlen);
    if (r == RD_VK_OK) r = rd_buffer_fill(d->vk, &d->stats, 0, err, errlen); /* age 0 */
    /* every probe starts awake with no offset */
    if (r == RD_VK_OK) r = rd_buffer_fill(d->vk, &d->probes, 0, err, errlen);
    unsigned n = rd_ddgi_probe_count(d);
    for (unsigned i = 0; r == RD_VK_OK && i < n; i += 4096) {
        pc_vec4 chunk[4096];
        unsigned m = n - i < 4096 ? n - i : 4096;
        for (unsigned k = 0; k < m; k++)
            chunk[k] = (pc_vec4){0, 0, 0, (float)PC_DDGI_PROBE_AWAKE};
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

/* ---- convergence ----------------------------------------------------------------------------
 *
 * Each update blends a probe's fresh estimate F into its stored value S with weight 1 - h. Light
 * reaches a probe's value one bounce per update (the shading of probe rays reads S), so with a
 * fixed h the field approaches its fixed point by a factor h + (1 - h) rho per update, rho being
 * the scene's bounce albedo: with h = 0.97 and rho = 0.8, 200 updates leave 30% of the error
 * (measured: a closed white room 38% too dark; the old default stopped after 152). A low h
 * converges the bounces fast but keeps the Monte Carlo noise of each update.
 *
 * The rule: every probe has an age a (updates since a wake event) and blends with
 * h = min(h_max, a / (a + 4)): h = 0 for a fresh probe, 0.5 after 4 updates, h_max (0.97) after
 * 130. A probe falls asleep 16 updates after its h reached h_max (PC_DDGI_SETTLE_UPDATES); wake
 * events (lights, sky, moved nodes) lower the age of the probes they reach. Ages advance only
 * while the awake field does not drift, so h stays low while the bounces still add light and
 * rises to average the noise away once only noise is left:
 *  - the measure: each update, the blend sums over the awake probes the gap between fresh and
 *    stored encoded luminance of their tiles (the step the stored half floats really made,
 *    divided by 1 - h) and the stored luminance; D = e x gap sum / stored sum (e the encoding
 *    exponent: 5, or 1 when the blend is linear, gpu_types.h) is the relative
 *    change of the field's luminance per update that the fresh values ask for. In the encoded
 *    space the stored value is the mean of the fresh ones, and a ratio of sums has no bias from
 *    noise, so a settled field measures 0 however noisy single probes are (a sun patch, rare
 *    hits of a small emitter), and dark probes weigh little. The old measure, the mean over
 *    probes of each probe's change relative to max(fresh, stored), was biased by the noise
 *    itself (a probe's relative change has a negative mean when its noise is large): a sunlit
 *    room measured -0.75% per update forever, a 1 cm emitter -56%. A gap a half float cannot
 *    close (a few 1/10000 relative, over 1 - h) is no drift either: taken as fresh minus
 *    stored, a white room whose field stood still read +0.4% per update (H200, ages held at
 *    h 0.86). The blend reads the stored bits back through a volatile reference for this: the
 *    NVIDIA compiler folds unpackHalf2x16(packHalf2x16(x)) into x.
 *  - the test: the CPU keeps an exponential mean of D (weight 1/8) and a noise variance from
 *    D's second differences (weight 1/16: it remembers the rare big measures of a field lit by
 *    a small emitter, whose drift between hits is a sawtooth of no mean; smooth drift adds
 *    little to second differences), and holds the ages while |mean| > max(0.2%, 2 standard
 *    errors). Drift restarts from scratch when a sleeping field wakes.
 *  - the bound: a probe's age holds for at most PC_DDGI_HOLD_FACTOR (3) sleep ages after its
 *    last wake (stats.y counts), so every probe sleeps within 4 sleep ages (584 updates at
 *    h_max 0.97), whatever the measure says; 601 with the re-check period a probe that flips
 *    between off and awake may add (rd_ddgi_sleep_bound). Holding longer would not help:
 *    while ages hold, h stays low and the bounces converge by h + (1 - h) rho per update.
 *
 * Why the age ramp with a hold (a scalar model of the coupled field, 6% noise per update, mean
 * over trials):
 *   rule                               rho 0.8: updates, bias     rho 0.9: updates, bias
 *   fixed h = 0.97 (the old default)   152, -32%                  152, -57%
 *   age ramp c = 4, no drift hold      147, -3.6%                 147, -19.5%
 *   age ramp c = 8, no drift hold      276, -0.2%                 276, -4.7%
 *   age ramp c = 4 with drift hold     168, -0.0% (200 probes)    177, -0.9% (200 probes)
 * The drift hold is what makes the short ramp accurate for bright closed rooms; the stored noise
 * at sleep is the same (0.7%) for all ramps since they end at h_max.
 *
 * Measured (NVIDIA H200, defaults: 256 rays, h_max 0.97, fitted grids, 64x48 pixels; updates to
 * sleep, and the bias: mean luminance at sleep against the mean of 60 images of the same field
 * kept updating for 600 more updates; tests/bench/results/h200/convergence_bound.txt):
 *   scene                         old rule                  this rule
 *   hard:sun-room (320 probes)    never (2000: 320 awake)   183, -0.37% (seeds 2, 3: 189, 222)
 *   DamagedHelmet, emission only  never (2000: 398 awake)   172, +0.06%
 *   hard:tiny-emitter             never (2000: 475 awake)   151, +54% (one image's sd: 47%);
 *                                                           seeds 0, 2-4: 467-584 (bound)
 *   hard:cornell                  183, -0.05%               185, -0.05%
 *   white-room                    178, -0.00%               196, -0.00%
 *   furnace                       168, 0.00%                188, 0.00%
 *   two-rooms (dark room seen)    327, -0.89%               195, -0.17%
 *   hard:many-lights              173, -0.08%               186, -0.08%
 *   hard:thick-walls              204, -0.06%               187, -0.10%
 * The 1 cm emitter's image never settles (a ray finds it a few times per update over 475
 * probes): between hits its drift reads as drift, and the bound ends it. Noise-free fields
 * stop where their half floats stick, and longer runs do not move them: the
 * furnace sleeps at 1.9946 against 1.9989 with the old rule (exact: 2), one step of the stored
 * encoding apart; that is the atlas's precision, not the rule's.
 * tests/renderer/test_gpu_converge_sun.c and test_gpu_converge_emitter.c check the bound and the
 * bias on lavapipe, test_gpu_converge.c the bound of a field that never stops drifting. */

float rd_ddgi_sleep_age(float h_max)
{
    double h = h_max < 0.999f ? h_max : 0.999;
    return (float)ceil(PC_DDGI_AGE_RAMP * h / (1.0 - h)) + (float)PC_DDGI_SETTLE_UPDATES;
}

unsigned rd_ddgi_sleep_bound(float h_max)
{
    /* each update that blends a probe adds 1 to its age or to its held count, and the held
     * count stops at HOLD_FACTOR sleep ages. A probe on a surface may flip between off and
     * awake: each periodic re-check of it while off adds the updates since the last one to its
     * age (ddgi_blend.glsl), so it can be off for at most one re-check period past the sleep
     * age and then comes back for the one blend that puts it to sleep. */
    double a = rd_ddgi_sleep_age(h_max);
    return (unsigned)ceil(a) + (unsigned)ceil(PC_DDGI_HOLD_FACTOR * a) + PC_DDGI_OFF_RECHECK + 1;
}

bool rd_ddgi_converged(const rd_ddgi *d)
{
    return d->configured && d->updates > 0 && d->census.awake == 0 && d->wake_count == 0;
}

/* Pending boxes only ever combine by taking the lowest age per probe (the wake pass), so the
 * order of wake calls does not matter. When the list is full it collapses into one box over
 * everything with the lowest age of all. */
void rd_ddgi_wake_box(rd_ddgi *d, const float lo[3], const float hi[3], float age)
{
    if (!d->configured) return;
    if (d->wake_count == PC_DDGI_WAKE_MAX) {
        float a = age;
        for (unsigned i = 0; i < d->wake_count; i++)
            a = fminf(a, d->wakes[i].lo.w);
        d->wake_count = 0;
        rd_ddgi_wake_all(d, a);
        return;
    }
    d->wakes[d->wake_count++] =
        (pc_ddgi_wake){{lo[0], lo[1], lo[2], age}, {hi[0], hi[1], hi[2], 0}};
}

void rd_ddgi_wake_all(rd_ddgi *d, float age)
{
    const float lo[3] = {-3e38f, -3e38f, -3e38f}, hi[3] = {3e38f, 3e38f, 3e38f};
    rd_ddgi_wake_box(d, lo, hi, age);
}

void rd_ddgi_begin_update(rd_ddgi *d)
{
    /* The rotation depends only on (seed, update index): same seed, same image. */
    uint64_t state =
        ((uint64_t)d->settings.seed << 32) ^ (uint64_t)d->updates * 0x632be59bd9b4e019ull;
    float m[3][3];
    rd_ddgi_random_rotation(&state, m);
    for (int r = 0; r < 3; r++)
        d->vol.rotation[r] = (pc_vec4){m[r][0], m[r][1], m[r][2], 0};
    d->vol.info.y = d->updates;
    /* a field that slept and is woken: its awake probes are new ones */
    if (d->census.awake == 0) drift_restart(d);
    d->vol.control.x = d->hold;
    d->vol.params.w = (float)d->drift_unit;
    d->vol.control.z = d->wake_count;
    memcpy(d->wake_boxes.mapped, d->wakes, sizeof(pc_ddgi_wake) * d->wake_count);
    d->wake_count = 0;
    unsigned ray_groups = (d->vol.counts.w + PC_WG_1D - 1) / PC_WG_1D;
    unsigned border_groups = (4 * (RD_DDGI_DIST_SIDE - 1) + PC_WG_1D - 1) / PC_WG_1D;
    pc_ddgi_control c = {.trace_args = {ray_groups, 0, 1, 0},
                         .blend_args = {0, 1, 1, 0},
                         .border_args = {border_groups, 0, 1, 0}};
    memcpy(d->ctrl.mapped, &c, sizeof c);
}

void rd_ddgi_record_update(rd_ddgi *d, rd_cmd *c, rd_timer *timer, VkDeviceAddress globals,
                           VkDeviceAddress counters)
{
    unsigned probes = rd_ddgi_probe_count(d);
    pc_push push = {.globals = globals, .buf0 = d->hits.address, .buf1 = counters};
    uint32_t probe_groups = (probes + PC_WG_1D - 1) / PC_WG_1D;
    if (d->vol.control.z) {
        rd_cmd_dispatch(c, &d->wake, &push, probe_groups, 1, 1);
        rd_cmd_barrier(c);
    }
    rd_cmd_dispatch(c, &d->select, &push, probe_groups, 1, 1);
    /* the blends' weights for this update's rotation (read by the blends, after the barriers
     * below) */
    rd_cmd_dispatch(c, &d->weights, &push, PC_DDGI_WEIGHT_TEXELS, 1, 1);
    rd_cmd_barrier(c);
    /* everything below works on the listed probes only (indirect sizes) */
    rd_cmd_dispatch_indirect(c, &d->trace, &push, &d->ctrl, offsetof(pc_ddgi_control, trace_args));
    rd_cmd_barrier(c);
    if (timer) rd_timer_mark(c, timer, "probe trace");
    push.params.y = d->updates > 0;
    if (d->sort_hits) {
        /* the hits sorted by place (a counting sort over a grid of cells), then shaded in that
         * order */
        vkCmdFillBuffer(c->cb, d->bins.buffer, 0, VK_WHOLE_SIZE, 0);
        rd_cmd_barrier(c);
        pc_push bin = {.globals = globals,
                       .buf0 = d->bins.address,
                       .buf1 = d->hits.address,
                       .buf2 = d->sorted.address};
        rd_cmd_dispatch_indirect(c, &d->bin, &bin, &d->ctrl, offsetof(pc_ddgi_control, trace_args));
        rd_cmd_barrier(c);
        rd_cmd_dispatch(c, &d->scan, &bin, 1, 1, 1);
        rd_cmd_barrier(c);
        bin.params.x = 1;
        rd_cmd_dispatch_indirect(c, &d->bin, &bin, &d->ctrl, offsetof(pc_ddgi_control, trace_args));
        rd_cmd_barrier(c);
        if (timer) rd_timer_mark(c, timer, "probe sort");
        push.params.z = 1;
        push.buf2 = d->sorted.address;
        rd_cmd_dispatch_indirect(c, &d->shade, &push, &d->ctrl,
                                 offsetof(pc_ddgi_control, shade_args));
    } else {
        rd_cmd_dispatch_indirect(c, &d->shade, &push, &d->ctrl,
                                 offsetof(pc_ddgi_control, trace_args));
    }
    rd_cmd_barrier(c);
    push.params.z = 0;
    push.buf2 = 0;
    if (timer) rd_timer_mark(c, timer, "probe shade");
    /* distance first: the irradiance blend re-classifies probes, and both must see the
     * classification the trace used */
    push.params = (pc_uvec4){0, 0, 0, 0};
    rd_cmd_dispatch_indirect(c, &d->blend_distance, &push, &d->ctrl,
                             offsetof(pc_ddgi_control, blend_args));
    rd_cmd_barrier(c);
    if (timer) rd_timer_mark(c, timer, "blend distance");
    rd_cmd_dispatch_indirect(c, &d->blend_irradiance, &push, &d->ctrl,
                             offsetof(pc_ddgi_control, blend_args));
    rd_cmd_barrier(c);
    if (timer) rd_timer_mark(c, timer, "blend irradiance");
    rd_cmd_dispatch_indirect(c, &d->border, &push, &d->ctrl,
                             offsetof(pc_ddgi_control, border_args));
    push.params.x = 1;
    rd_cmd_dispatch_indirect(c, &d->border, &push, &d->ctrl,
                             offsetof(pc_ddgi_control, border_args));
    rd_cmd_barrier(c);
    if (timer) rd_timer_mark(c, timer, "borders");
}

/* The drift statistics (the rule: "convergence" above). */
#define DRIFT_TOLERANCE 0.002   /* relative change per update that never holds ages */
#define DRIFT_BETA 0.125        /* weight of a measure in the drift's exponential mean */
#define DRIFT_NOISE_BETA 0.0625 /* ... in the noise variance's, which remembers longer */
#define DRIFT_MAX 100.0         /* measures are clamped to +-this (a field lit from black) */

static void drift_measure(rd_ddgi *d, double D)
{
    if (d->drift_measures == 0) {
        d->drift = D;
        d->drift_var = 0;
    } else {
        d->drift = (1 - DRIFT_BETA) * d->drift + DRIFT_BETA * D;
    }
    if (d->drift_measures >= 2) {
        /* second differences: a smooth drift (the bounces filling in, geometric in the
         * update) hardly adds to them, noise does; for independent measures of variance v
         * their square has mean 6 v */
        double c = D - 2 * d->drift_recent[0] + d->drift_recent[1];
        d->drift_var = (1 - DRIFT_NOISE_BETA) * d->drift_var + DRIFT_NOISE_BETA * c * c / 6;
    }
    d->drift_recent[1] = d->drift_recent[0];
    d->drift_recent[0] = D;
    d->drift_measures++;
    /* the standard error of the exponential mean of independent measures */
    double se = sqrt(d->drift_var * DRIFT_BETA / (2 - DRIFT_BETA));
    d->hold = fabs(d->drift) > fmax(DRIFT_TOLERANCE, 2 * se);
}

void rd_ddgi_end_update(rd_ddgi *d)
{
    d->updates++;
    pc_ddgi_control c;
    memcpy(&c, d->ctrl.mapped, sizeof c);
    unsigned total = rd_ddgi_probe_count(d);
    d->census.awake = c.after.x;
    d->census.sleeping = c.before.y + c.after.y;
    d->census.off = total - d->census.awake - d->census.sleeping;
    d->census.updated = c.before.w;
    int32_t gap, stored, n, fresh;
    memcpy(&gap, &c.drift.x, 4);
    memcpy(&stored, &c.drift.y, 4);
    memcpy(&n, &c.drift.z, 4);
    memcpy(&fresh, &c.drift.w, 4);
    /* the next update's fixed point, from this one's mean fresh tile */
    if (fresh > 0 && c.before.x > 0)
        d->drift_unit = drift_unit(d, fresh / d->drift_unit / c.before.x);
    if (n <= 0) { /* nothing measured: the first update, or only probes seen for the first time */
        d->hold = false;
        return;
    }
    /* the relative change of the field's (decoded) luminance per update that this update's
     * fresh values ask for: the encoded ratio times the encoding exponent */
    double D = stored > 0 ? (double)d->vol.encoding * gap / stored : gap > 0 ? 1 : 0;
    drift_measure(d, fmax(-DRIFT_MAX, fmin(DRIFT_MAX, D)));
}
