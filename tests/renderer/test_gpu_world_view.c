/* One world, several views, on lavapipe at tiny sizes (validation layer on): views of different
 * sizes and cameras render their own images; rendering a view reads the world and never
 * changes it (update count, probe atlases, the other view's image); rd_world_update(w, n)
 * advances the field by exactly n updates whatever the number of views; the world's sky shows
 * in every view's miss pixels; and one readback ring carries frames of different sizes with
 * their records intact. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/mesh_builder.h"
#include "renderer/builtin/procedural.h"
#include "renderer/vk/readback.h"
#include "renderer/view.h"
#include "renderer/world.h"
#include "test_render_util.h"
#include "test_util.h"

#define AW 32
#define AH 24
#define BW 20
#define BH 12

static rd_vk vk;
static char err[512];

typedef struct fixture {
    rd_scene scene;
    rd_gpu_scene gs;
    rd_view_passes passes;
    rd_world world;
    rd_view a, b;
    rd_view_camera cam_a, cam_b;
    rd_view_settings set_a, set_b;
} fixture;

static bool fixture_create(fixture *f)
{
    memset(f, 0, sizeof *f);
    CHECKF(rd_procedural_build("shadow", &f->scene, err, sizeof err), "%s", err);
    /* two cameras over the plane (y = 0, |x|, |z| <= 5) that both see the horizon */
    f->cam_a = (rd_view_camera){
        .eye = {0, 1.5f, 6}, .forward = {0, -0.15f, -1}, .up = {0, 1, 0}, .yfov = 0.87f};
    f->cam_b = (rd_view_camera){
        .eye = {4, 2, 4}, .forward = {-4, -1.5f, -4}, .up = {0, 1, 0}, .yfov = 1.2f};
    rd_view_camera *cams[2] = {&f->cam_a, &f->cam_b};
    for (int i = 0; i < 2; i++) {
        rd_view_camera *c = cams[i];
        float len = sqrtf(c->forward[0] * c->forward[0] + c->forward[1] * c->forward[1] +
                          c->forward[2] * c->forward[2]);
        for (int k = 0; k < 3; k++)
            c->forward[k] /= len;
    }
    f->set_a = (rd_view_settings){.width = AW, .height = AH};
    f->set_b = (rd_view_settings){.width = BW, .height = BH, .exposure_ev = 1.0f};
    rd_ddgi_settings gi = {.mode = PC_GI_DDGI, .counts = {3, 2, 3}, .rays = 32, .seed = 5};
    const float sky[3] = {0.25f, 0.5f, 1.0f};
    bool ok = rd_gpu_scene_create(&vk, &f->gs, &f->scene, err, sizeof err) == RD_VK_OK &&
              rd_view_passes_create(&vk, &f->passes, err, sizeof err) == RD_VK_OK &&
              rd_world_create(&vk, &f->world, err, sizeof err) == RD_VK_OK &&
              rd_view_create(&vk, &f->passes, &f->a, err, sizeof err) == RD_VK_OK &&
              rd_view_create(&vk, &f->passes, &f->b, err, sizeof err) == RD_VK_OK &&
              rd_world_configure_gi(&f->world, f->scene.bounds_min, f->scene.bounds_max, &gi, err,
                                    sizeof err) == RD_VK_OK;
    CHECKF(ok, "%s", err);
    rd_world_set_scene(&f->world, &f->gs);
    rd_world_set_sky(&f->world, sky);
    return ok;
}

static void fixture_destroy(fixture *f)
{
    rd_view_destroy(&f->b);
    rd_view_destroy(&f->a);
    rd_view_destroy(&f->a); /* idempotent */
    rd_world_destroy(&f->world);
    rd_world_destroy(&f->world);
    rd_view_passes_destroy(&vk, &f->passes);
    rd_view_passes_destroy(&vk, &f->passes);
    rd_gpu_scene_destroy(&vk, &f->gs);
    rd_scene_destroy(&f->scene);
}

static bool render(fixture *f, rd_view *v)
{
    const rd_view_camera *cam = v == &f->a ? &f->cam_a : &f->cam_b;
    const rd_view_settings *s = v == &f->a ? &f->set_a : &f->set_b;
    rd_vk_result r = rd_view_render(v, &f->world, cam, s, err, sizeof err);
    CHECKF(r == RD_VK_OK, "%s", err);
    return r == RD_VK_OK;
}

static float *read_hdr(rd_view *v)
{
    float *rgb = malloc((size_t)v->width * v->height * 12);
    CHECK(rd_view_read_hdr(v, rgb, err, sizeof err) == RD_VK_OK);
    return rgb;
}

/* Raw bytes of the probe field: irradiance, distance and probe state atlases. */
static uint8_t *read_field(const rd_world *w, size_t *size)
{
    const rd_buffer *bufs[3] = {&w->ddgi.irradiance, &w->ddgi.distance, &w->ddgi.probes};
    *size = bufs[0]->size + bufs[1]->size + bufs[2]->size;
    uint8_t *out = malloc(*size), *p = out;
    for (int i = 0; i < 3; i++) {
        CHECK(rd_buffer_download(&vk, bufs[i], 0, p, bufs[i]->size, err, sizeof err) == RD_VK_OK);
        p += bufs[i]->size;
    }
    return out;
}

static bool has_pass(const rd_frame_stats *st, const char *name)
{
    for (unsigned i = 0; i < st->pass_count; i++)
        if (strcmp(st->pass_name[i], name) == 0) return true;
    return false;
}

/* Two views of different sizes and cameras; the world is untouched by rendering them. */
static void test_views_read_the_world(fixture *f)
{
    CHECKF(rd_world_update(&f->world, 2, err, sizeof err) == RD_VK_OK, "%s", err);
    CHECK(f->world.updates_total == 2);
    CHECK(has_pass(&f->world.stats, "probe trace") && has_pass(&f->world.stats, "borders"));
    CHECK(f->world.stats.rays.probe_rays > 0 && f->world.stats.rays.primary_rays == 0);

    size_t field_size, after_size;
    uint8_t *field = read_field(&f->world, &field_size);
    pc_ddgi_volume vol = f->world.ddgi.vol;
    unsigned ddgi_updates = f->world.ddgi.updates;

    if (!render(f, &f->a)) return;
    float *a1 = read_hdr(&f->a);
    for (int i = 0; i < 3; i++) /* many views, many frames: no probe update */
        if (!render(f, &f->b)) return;
    float *b1 = read_hdr(&f->b);
    if (!render(f, &f->a)) return;
    float *a2 = read_hdr(&f->a);

    CHECK(f->a.width == AW && f->a.height == AH && f->b.width == BW && f->b.height == BH);
    CHECK(f->a.stats.rays.primary_rays == AW * AH && f->b.stats.rays.primary_rays == BW * BH);
    CHECK(f->a.stats.rays.probe_rays == 0 && !has_pass(&f->a.stats, "probe trace"));
    CHECK(has_pass(&f->a.stats, "gi sample") && has_pass(&f->b.stats, "tonemap"));
    /* the world did not move: same update count, same field bits, same volume */
    CHECK(f->world.updates_total == 2 && f->world.ddgi.updates == ddgi_updates);
    CHECK(memcmp(&vol, &f->world.ddgi.vol, sizeof vol) == 0);
    uint8_t *after = read_field(&f->world, &after_size);
    CHECK(after_size == field_size);
    CHECKF(memcmp(field, after, field_size) == 0, "rendering a view changed the probe field");
    /* so view a renders the same image before and after view b's frames */
    CHECKF(memcmp(a1, a2, (size_t)AW * AH * 12) == 0, "view a changed between frames");

    /* different cameras give different images: view a's camera at view b's size differs */
    rd_view c;
    CHECK(rd_view_create(&vk, &f->passes, &c, err, sizeof err) == RD_VK_OK);
    rd_view_settings sc = f->set_a;
    sc.width = BW, sc.height = BH;
    CHECK(rd_view_render(&c, &f->world, &f->cam_a, &sc, err, sizeof err) == RD_VK_OK);
    float *c1 = read_hdr(&c);
    CHECK(memcmp(b1, c1, (size_t)BW * BH * 12) != 0);
    size_t bad = 0;
    CHECK(test_image_mean(a1, (size_t)AW * AH * 3, &bad) > 0 && bad == 0);
    CHECK(test_image_mean(b1, (size_t)BW * BH * 3, &bad) > 0 && bad == 0);
    rd_view_destroy(&c);
    free(c1);
    free(a1), free(a2), free(b1);
    free(field), free(after);
}

/* rd_world_update(w, 3) advances the field by 3 whatever the number of views rendered. */
static void test_update_count(fixture *f)
{
    uint64_t before = f->world.updates_total;
    unsigned ddgi_before = f->world.ddgi.updates;
    size_t n0, n1;
    uint8_t *field0 = read_field(&f->world, &n0);
    CHECKF(rd_world_update(&f->world, 3, err, sizeof err) == RD_VK_OK, "%s", err);
    CHECK(f->world.updates_total == before + 3 && f->world.ddgi.updates == ddgi_before + 3);
    uint8_t *field1 = read_field(&f->world, &n1);
    CHECK(n0 == n1 && memcmp(field0, field1, n0) != 0); /* the updates did write the field */
    /* the stats sum all three updates: 3 x the rays of one (with 32 rays per probe, active and
     * inactive probes trace the same number, so every update traces as many) */
    unsigned rays3 = f->world.stats.rays.probe_rays;
    CHECK(rd_world_update(&f->world, 1, err, sizeof err) == RD_VK_OK);
    CHECKF(rays3 == 3 * f->world.stats.rays.probe_rays, "%u probe rays in 3 updates, %u in 1",
           rays3, f->world.stats.rays.probe_rays);
    CHECK(f->world.updates_total == before + 4);
    for (int i = 0; i < 2; i++) {
        render(f, &f->a);
        render(f, &f->b);
    }
    CHECK(f->world.updates_total == before + 4);
    CHECK(rd_world_update(&f->world, 0, err, sizeof err) == RD_VK_OK);
    CHECK(f->world.updates_total == before + 4 && f->world.stats.pass_count == 0);
    free(field0), free(field1);
}

/* Every miss pixel of every view shows the world's sky, and a new sky reaches both views. */
/* Renders v and reads back its G-buffer (misses: position.w < 0, position.xyz = the ray's
 * direction) and its linear radiance. False when rendering failed. */
static bool render_and_read(fixture *f, rd_view *v, pc_gbuffer_texel **gb, float **rgb)
{
    if (!render(f, v)) return false;
    size_t px = (size_t)v->width * v->height;
    *gb = malloc(px * sizeof **gb);
    CHECK(rd_buffer_download(&vk, &v->gbuffer, 0, *gb, px * sizeof **gb, err, sizeof err) ==
          RD_VK_OK);
    *rgb = read_hdr(v);
    return true;
}

static void check_sky(fixture *f, rd_view *v, const float sky[3])
{
    pc_gbuffer_texel *gb;
    float *rgb;
    if (!render_and_read(f, v, &gb, &rgb)) return;
    size_t px = (size_t)v->width * v->height;
    size_t misses = 0, wrong = 0;
    for (size_t i = 0; i < px; i++) {
        if (gb[i].position.w >= 0) continue;
        misses++;
        for (int c = 0; c < 3; c++)
            wrong += rgb[i * 3 + c] != sky[c];
    }
    CHECKF(misses > 0 && misses < px, "view %ux%u: %zu of %zu pixels miss", v->width, v->height,
           misses, px);
    CHECKF(wrong == 0, "view %ux%u: %zu miss channels differ from the sky", v->width, v->height,
           wrong);
    free(gb), free(rgb);
}

static void test_sky(fixture *f)
{
    check_sky(f, &f->a, f->world.env.sky);
    check_sky(f, &f->b, f->world.env.sky);
    const float sky2[3] = {2.0f, 0.125f, 0.0f};
    rd_world_set_sky(&f->world, sky2);
    check_sky(f, &f->a, sky2);
    check_sky(f, &f->b, sky2);
}

/* A gradient and an HDR image environment: every miss pixel shows env_radiance toward its
 * direction as the CPU twin (rd_env_radiance) computes it (the image through half floats). */
static void check_env(fixture *f, rd_view *v, const char *what, float tol)
{
    pc_gbuffer_texel *gb;
    float *rgb;
    if (!render_and_read(f, v, &gb, &rgb)) return;
    size_t px = (size_t)v->width * v->height;
    size_t misses = 0, wrong = 0;
    double worst = 0;
    for (size_t i = 0; i < px; i++) {
        if (gb[i].position.w >= 0) continue;
        misses++;
        const float d[3] = {gb[i].position.x, gb[i].position.y, gb[i].position.z};
        float want[3];
        rd_env_radiance(&f->world.env, d, want);
        for (int c = 0; c < 3; c++) {
            double e = fabs(rgb[i * 3 + c] - want[c]) / fmax(fabs(want[c]), 0.05);
            worst = fmax(worst, e);
            wrong += e > tol;
        }
    }
    CHECKF(misses > 0 && wrong == 0, "%s, view %ux%u: %zu of %zu miss channels off (worst %.4f)",
           what, v->width, v->height, wrong, misses * 3, worst);
    free(gb), free(rgb);
}

static void test_environments(fixture *f)
{
    rd_environment g = {.mode = RD_ENV_GRADIENT,
                        .sky = {0.2f, 0.4f, 1.5f},
                        .ground = {0.3f, 0.1f, 0.0f},
                        .intensity = 1};
    rd_world_set_environment(&f->world, &g);
    check_env(f, &f->a, "gradient", 1e-4f);
    check_env(f, &f->b, "gradient", 1e-4f);
    /* an image with detail in both directions, turned by 40 degrees */
    rd_env_image img = {.width = 64, .height = 32};
    img.rgb = malloc(64 * 32 * 3 * sizeof(float));
    for (unsigned y = 0; y < 32; y++)
        for (unsigned x = 0; x < 64; x++) {
            float *t = img.rgb + (y * 64 + x) * 3;
            t[0] = 0.5f + 0.4f * sinf((float)x * 0.2f);
            t[1] = 0.2f + 0.02f * (float)y;
            t[2] = (x / 8 + y / 8) % 2 ? 2.0f : 0.25f;
        }
    CHECK(rd_world_set_environment_image(&f->world, &img, err, sizeof err) == RD_VK_OK);
    CHECK(img.rgb == NULL && f->world.env_width == 64);
    rd_environment im = {
        .mode = RD_ENV_IMAGE, .sky = {9, 9, 9}, .intensity = 1.5f, .rotation = 0.7f};
    rd_world_set_environment(&f->world, &im);
    check_env(f, &f->a, "image", 2e-3f);
    check_env(f, &f->b, "image", 2e-3f);
    /* without the image, image mode shows the sky */
    rd_env_image none = {0};
    CHECK(rd_world_set_environment_image(&f->world, &none, err, sizeof err) == RD_VK_OK);
    const float sky[3] = {9, 9, 9};
    check_sky(f, &f->a, sky);
    const float black[3] = {0, 0, 0};
    rd_world_set_sky(&f->world, black);
}

/* ---- readback ring ---------------------------------------------------------------------- */

typedef struct record {
    uint64_t id;
    char tag[40];
} record;

typedef struct delivered {
    unsigned count;
    record info[4];
    unsigned w[4], h[4];
    uint8_t *rgba[4];
    bool lease; /* keep the slots */
    unsigned slot[4];
    const uint8_t *mapped[4];
} delivered;

static bool on_frame(void *user, const void *info, unsigned w, unsigned h, const uint8_t *rgba,
                     size_t bytes, unsigned slot)
{
    CHECK(bytes == (size_t)w * h * 4);
    delivered *d = user;
    CHECK(d->count < 4);
    if (d->count >= 4) return false;
    d->slot[d->count] = slot;
    d->mapped[d->count] = rgba;
    memcpy(&d->info[d->count], info, sizeof(record));
    d->w[d->count] = w, d->h[d->count] = h;
    d->rgba[d->count] = malloc((size_t)w * h * 4);
    memcpy(d->rgba[d->count], rgba, (size_t)w * h * 4);
    d->count++;
    return d->lease;
}

static void test_readback_ring(fixture *f)
{
    if (!render(f, &f->a) || !render(f, &f->b)) return;
    uint8_t *img_a = malloc(AW * AH * 4), *img_b = malloc(BW * BH * 4);
    CHECK(rd_view_read_rgba8(&f->a, img_a, err, sizeof err) == RD_VK_OK);
    CHECK(rd_view_read_rgba8(&f->b, img_b, err, sizeof err) == RD_VK_OK);
    rd_readback rb;
    rd_readback_init(&rb, &vk);
    record ra = {.id = 0x1122334455667788ull, .tag = "view a, 32x24"};
    record rb_info = {.id = 42, .tag = "view b, 20x12"};
    char big[RD_READBACK_INFO_MAX + 1] = {0};
    CHECK(rd_readback_submit(&rb, &f->a.rgba8, AW * AH * 4, AW, AH, big, sizeof big, err,
                             sizeof err) != RD_VK_OK);
    CHECK(rd_readback_busy(&rb) == 0);
    /* round 1: small then large; round 2: large then small into the same slots (a slot grows
     * for the large frame and keeps its size for the small one) */
    for (int round = 0; round < 2; round++) {
        delivered d = {0};
        rd_view *first = round == 0 ? &f->b : &f->a, *second = round == 0 ? &f->a : &f->b;
        const record *i1 = round == 0 ? &rb_info : &ra, *i2 = round == 0 ? &ra : &rb_info;
        CHECK(rd_readback_submit(&rb, &first->rgba8, (size_t)first->width * first->height * 4,
                                 first->width, first->height, i1, sizeof *i1, err,
                                 sizeof err) == RD_VK_OK);
        CHECK(rd_readback_submit(&rb, &second->rgba8, (size_t)second->width * second->height * 4,
                                 second->width, second->height, i2, sizeof *i2, err,
                                 sizeof err) == RD_VK_OK);
        CHECK(rd_readback_busy(&rb) == 2 && rd_readback_has_free(&rb));
        for (int tries = 0; tries < 100 && d.count < 2; tries++)
            CHECK(rd_readback_poll(&rb, 100ull * 1000 * 1000, on_frame, &d, err, sizeof err) ==
                  RD_VK_OK);
        CHECK(d.count == 2 && rd_readback_busy(&rb) == 0);
        if (d.count != 2) return;
        CHECK(memcmp(&d.info[0], i1, sizeof *i1) == 0 && memcmp(&d.info[1], i2, sizeof *i2) == 0);
        for (int k = 0; k < 2; k++) {
            bool is_a = d.info[k].id == ra.id;
            CHECK(d.w[k] == (is_a ? AW : BW) && d.h[k] == (is_a ? AH : BH));
            CHECK(memcmp(d.rgba[k], is_a ? img_a : img_b, (size_t)d.w[k] * d.h[k] * 4) == 0);
            free(d.rgba[k]);
        }
    }
    /* slots 0 and 1 each carried both sizes: both hold the larger buffer now */
    CHECK(rb.slots[0].buffer.size == AW * AH * 4 && rb.slots[1].buffer.size == AW * AH * 4);
    /* a leased slot keeps its pixels while later frames take other slots, until released */
    delivered d = {.lease = true};
    CHECK(rd_readback_submit(&rb, &f->a.rgba8, AW * AH * 4, AW, AH, &ra, sizeof ra, err,
                             sizeof err) == RD_VK_OK);
    for (int tries = 0; tries < 100 && d.count < 1; tries++)
        CHECK(rd_readback_poll(&rb, 100ull * 1000 * 1000, on_frame, &d, err, sizeof err) ==
              RD_VK_OK);
    CHECK(d.count == 1 && rd_readback_free_count(&rb) == RD_READBACK_SLOTS - 1);
    d.lease = false;
    for (int k = 0; k < 2; k++) /* view b's frames must not land in the leased slot */
        CHECK(rd_readback_submit(&rb, &f->b.rgba8, BW * BH * 4, BW, BH, &rb_info, sizeof rb_info,
                                 err, sizeof err) == RD_VK_OK);
    for (int tries = 0; tries < 100 && d.count < 3; tries++)
        CHECK(rd_readback_poll(&rb, 100ull * 1000 * 1000, on_frame, &d, err, sizeof err) ==
              RD_VK_OK);
    CHECK(d.count == 3 && d.slot[1] != d.slot[0] && d.slot[2] != d.slot[0]);
    CHECKF(memcmp(d.mapped[0], img_a, AW * AH * 4) == 0, "the leased pixels are intact");
    rd_readback_release(&rb, d.slot[0]);
    CHECK(rd_readback_free_count(&rb) == RD_READBACK_SLOTS);
    for (unsigned k = 0; k < d.count; k++)
        free(d.rgba[k]);
    rd_readback_dispose(&rb);
    rd_readback_dispose(&rb); /* idempotent */
    free(img_a), free(img_b);
}

static double mean_of(const float *rgb, size_t n)
{
    double sum = 0;
    for (size_t i = 0; i < n; i++)
        sum += rgb[i];
    return sum / n;
}

/* Light changes within the buffer's capacity are recorded into the next frame's command buffer
 * (no wait); switching the light off and on again gives the first image back bit for bit; growing
 * past the capacity reallocates. */
static void test_light_updates(fixture *f)
{
    size_t n = (size_t)AW * AH * 3;
    CHECK(f->scene.light_count >= 1);
    if (!render(f, &f->a)) return;
    float *lit = read_hdr(&f->a);
    float intensity = f->scene.lights[0].intensity;
    f->scene.lights[0].intensity = 0;
    CHECK(rd_gpu_scene_update_lights(&vk, &f->gs, &f->scene, err, sizeof err) == RD_VK_OK);
    CHECKF(f->gs.lights_pending != NULL, "a change within capacity is pending");
    render(f, &f->a);
    CHECKF(f->gs.lights_pending == NULL, "the frame recorded it");
    float *dark = read_hdr(&f->a);
    double m_lit = mean_of(lit, n), m_dark = mean_of(dark, n);
    CHECKF(m_dark < 0.8 * m_lit, "light off: mean %g against %g", m_dark, m_lit);
    f->scene.lights[0].intensity = intensity;
    CHECK(rd_gpu_scene_update_lights(&vk, &f->gs, &f->scene, err, sizeof err) == RD_VK_OK);
    render(f, &f->a);
    float *again = read_hdr(&f->a);
    CHECKF(memcmp(lit, again, n * sizeof *lit) == 0, "light on again: the same image");
    /* past the capacity: the buffer grows (waiting for the device), no pending copy */
    uint32_t cap = f->gs.light_capacity, before = f->scene.light_count;
    while (f->scene.light_count <= cap)
        rd_build_point_light(&f->scene, 100, 100, 100, 0); /* far away and dark */
    CHECK(rd_gpu_scene_update_lights(&vk, &f->gs, &f->scene, err, sizeof err) == RD_VK_OK);
    CHECKF(f->gs.light_capacity > cap && f->gs.lights_pending == NULL, "capacity %u -> %u", cap,
           f->gs.light_capacity);
    render(f, &f->a);
    float *grown = read_hdr(&f->a);
    CHECKF(fabs(mean_of(grown, n) - m_lit) < 1e-6 * m_lit + 1e-9, "dark lights add nothing");
    f->scene.light_count = before;
    CHECK(rd_gpu_scene_update_lights(&vk, &f->gs, &f->scene, err, sizeof err) == RD_VK_OK);
    free(lit);
    free(dark);
    free(again);
    free(grown);
}

int main(void)
{
    if (!test_vk_open(&vk)) return test_finish();
    fixture f;
    if (fixture_create(&f)) {
        test_views_read_the_world(&f);
        test_update_count(&f);
        test_sky(&f);
        test_environments(&f);
        test_readback_ring(&f);
        test_light_updates(&f);
    }
    fixture_destroy(&f);
    return test_vk_close(&vk);
}
