/* GPU checks of the indirect specular term (shaders/reflect.comp, reflect_filter.comp and the
 * rough fallback of ddgi_sample.comp) on lavapipe with the validation layer on:
 *   - mirrors: a white metal mirror (roughness 0.05) facing an emitter of radiance L shows L
 *     (F = 1), a dielectric mirror (roughness 0) shows Schlick's F(N.V) L, per pixel;
 *   - a metal sphere in a uniform sky, glossy (traced) and rough (probe fallback): DDGI with
 *     reflections matches the path tracer, without them it is black;
 *   - the temporal history restarts when the world changes (the sky);
 *   - a Lambertian scene records no reflection pass and renders the same bits with
 *     reflections on and off; a glossy scene whose glossy surfaces are out of sight records
 *     the passes but traces no reflection ray. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/mesh_builder.h"
#include "test_render_util.h"
#include "test_util.h"

#define W 32
#define H 24

static rd_vk vk;

static uint32_t material(rd_scene *s, const float base[3], float metallic, float roughness,
                         float specular, const float emission[3])
{
    rd_material m = test_material(base, metallic, roughness, specular);
    if (emission) memcpy(m.emission, emission, sizeof m.emission);
    return rd_scene_add_material(s, &m);
}

static rd_view_camera camera_at(const float eye[3], const float fwd[3], float fov_deg)
{
    rd_view_camera c;
    memset(&c, 0, sizeof c);
    memcpy(c.eye, eye, sizeof c.eye);
    float len = sqrtf(fwd[0] * fwd[0] + fwd[1] * fwd[1] + fwd[2] * fwd[2]);
    for (int k = 0; k < 3; k++)
        c.forward[k] = fwd[k] / len;
    c.up[1] = 1;
    c.yfov = fov_deg * (float)M_PI / 180.0f;
    return c;
}

static void pixel_dir(const pc_view *v, int x, int y, double d[3])
{
    test_pixel_dir(v, W, H, x, y, d);
}

/* A scene on the GPU with a renderer whose probe grid (3^3 probes) covers [lo, hi]. */
typedef struct fixture {
    rd_scene s;
    rd_gpu_scene gs;
    rd_renderer r;
    bool ok;
} fixture;

static bool fixture_open(fixture *f, const float lo[3], const float hi[3])
{
    char err[512] = "";
    f->ok = false;
    CHECKF(rd_scene_update(&f->s, err, sizeof err), "%s", err);
    rd_vk_result res = rd_gpu_scene_create(&vk, &f->gs, &f->s, err, sizeof err);
    CHECKF(res == RD_VK_OK, "%s", err);
    if (res != RD_VK_OK) return false;
    res = rd_renderer_create(&vk, &f->r, err, sizeof err);
    rd_ddgi_settings gi = {.mode = PC_GI_DDGI, .counts = {3, 3, 3}, .rays = 64, .seed = 5};
    if (res == RD_VK_OK) res = rd_renderer_configure_gi(&f->r, lo, hi, &gi, err, sizeof err);
    CHECKF(res == RD_VK_OK, "%s", err);
    f->ok = res == RD_VK_OK;
    if (!f->ok) rd_gpu_scene_destroy(&vk, &f->gs);
    return f->ok;
}

static void fixture_close(fixture *f)
{
    if (f->ok) {
        rd_renderer_destroy(&f->r);
        rd_gpu_scene_destroy(&vk, &f->gs);
    }
    rd_scene_destroy(&f->s);
}

/* Renders `frames` frames (one probe update each; path traced with spp > 0) and returns the
 * last as W*H*3 floats (caller frees), or NULL after a failed CHECK. */
static float *render(fixture *f, const rd_view_camera *cam, unsigned frames, unsigned reflections,
                     unsigned spp, float sky)
{
    char err[512] = "";
    rd_frame_settings fs = {.width = W,
                            .height = H,
                            .seed = 7,
                            .pathtrace_spp = spp,
                            .reflections = reflections,
                            .sky = {sky, sky, sky}};
    rd_vk_result res = RD_VK_OK;
    for (unsigned i = 0; i < frames && res == RD_VK_OK; i++)
        res = rd_renderer_render(&f->r, &f->gs, cam, &fs, err, sizeof err);
    float *rgb = calloc((size_t)W * H * 3, sizeof(float));
    if (res == RD_VK_OK) res = rd_renderer_read_hdr(&f->r, rgb, err, sizeof err);
    CHECKF(res == RD_VK_OK, "%s", err);
    if (res != RD_VK_OK) {
        free(rgb);
        return NULL;
    }
    return rgb;
}

static bool has_pass(const rd_frame_stats *st, const char *name)
{
    for (unsigned i = 0; i < st->pass_count; i++)
        if (strcmp(st->pass_name[i], name) == 0) return true;
    return false;
}

/* A mirror floor (y = 0) in front of a wall (z = -5) that emits L toward it, no lights, black
 * sky, seen from (0, 1.5, 3). Every floor pixel whose mirror direction meets the wall shows
 * L times the Fresnel term: 1 for white metal, Schlick's 0.04 + 0.96 (1 - N.V)^5 for a
 * dielectric with a black base colour (no diffuse term). The lobes (alpha 0.0025 and 0.002)
 * integrate to F(N.V) within 0.1% (the albedo table), but single samples of the dielectric's
 * F(V.H) are skewed (most microfacets seen at grazing angles face the viewer: F below F(N.V),
 * rare ones far above), so after 16 frames a pixel is within 3% and the mean within 1%. */
static void test_mirror(bool metal)
{
    const float white[3] = {1, 1, 1}, black[3] = {0, 0, 0}, L[3] = {1.5f, 1.0f, 0.5f};
    fixture f;
    rd_scene_init(&f.s);
    uint32_t mirror =
        metal ? material(&f.s, white, 1, 0.05f, 1, NULL) : material(&f.s, black, 0, 0, 1, NULL);
    uint32_t emitter = material(&f.s, black, 0, 1, 0, L);
    rd_tri_list t = {0};
    rd_tris_quad(&t, (const float[3]){-10, 0, -5}, (const float[3]){-10, 0, 10},
                 (const float[3]){10, 0, 10}, (const float[3]){10, 0, -5}, mirror);
    rd_tris_commit(&t, &f.s, "floor");
    rd_tris_quad(&t, (const float[3]){-10, 0, -5}, (const float[3]){10, 0, -5},
                 (const float[3]){10, 20, -5}, (const float[3]){-10, 20, -5}, emitter);
    rd_tris_commit(&t, &f.s, "wall");
    const float eye[3] = {0, 1.5f, 3}, fwd[3] = {0, -1.5f, -4};
    rd_view_camera cam = camera_at(eye, fwd, 50);
    float *img = NULL;
    if (fixture_open(&f, (const float[3]){-10, 0, -5}, (const float[3]){10, 20, 10}))
        img = render(&f, &cam, 16, PC_REFLECT_AUTO, 0, 0);
    if (img) {
        CHECK(has_pass(&f.r.stats, "reflect") && has_pass(&f.r.stats, "reflect filter"));
        CHECK(f.r.stats.rays.reflect_rays > 0);
        pc_view v;
        rd_camera_to_view(&cam, W, H, &v);
        int checked = 0, bad = 0;
        double fmin = 1, fmax = 0, ratio = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                double d[3];
                pixel_dir(&v, x, y, d);
                if (d[1] >= -1e-3) continue;
                double tf = -eye[1] / d[1];
                double p[3] = {eye[0] + tf * d[0], 0, eye[2] + tf * d[2]};
                double r[3] = {d[0], -d[1], d[2]}; /* mirror direction */
                if (p[2] < -4.8 || r[2] >= 0) continue;
                double tw = (-5 - p[2]) / r[2], wx = p[0] + tw * r[0], wy = tw * r[1];
                if (fabs(wx) > 9.5 || wy < 0.5 || wy > 19.5) continue;
                double nv = -d[1];
                double fresnel = metal ? 1.0 : 0.04 + 0.96 * pow(1 - nv, 5);
                fmin = fmin < fresnel ? fmin : fresnel, fmax = fmax > fresnel ? fmax : fresnel;
                checked++;
                for (int c = 0; c < 3; c++) {
                    double got = img[(y * W + x) * 3 + c], expect = fresnel * L[c];
                    ratio += got / expect;
                    if (!test_close_rel(got, expect, 0.03) && bad++ < 5)
                        fprintf(stderr, "%s mirror pixel %d,%d channel %d: %g, expected %g\n",
                                metal ? "metal" : "dielectric", x, y, c, got, expect);
                }
            }
        ratio /= 3.0 * checked;
        printf("%s mirror: %d floor pixels show F L within 3%% (F from %.4f to %.4f), %d off; "
               "mean of image / (F L) %.4f\n",
               metal ? "metal" : "dielectric", checked, fmin, fmax, bad, ratio);
        CHECK(checked > W * H / 4);
        /* GGX's long tail sends a rare sample far from the mirror direction (to the black sky
         * or below the floor): allow 2% of the channels to be outliers */
        CHECKF(bad <= checked * 3 / 50, "%d channels off", bad);
        CHECKF(fabs(ratio - 1) < 0.01, "mean ratio %g", ratio);
    }
    free(img);
    fixture_close(&f);
}

/* Relative error of a against b over the pixels well inside the silhouette of the unit sphere
 * at the origin seen from (0, 0, 4): of the mean (per channel, the worst) and RMS per pixel. */
static void sphere_error(const float *a, const float *b, const rd_view_camera *cam,
                         double *mean_err, double *rms_err)
{
    pc_view v;
    rd_camera_to_view(cam, W, H, &v);
    double sa[3] = {0}, sb[3] = {0}, sq = 0;
    int n = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double d[3];
            pixel_dir(&v, x, y, d);
            double bb = -4 * d[2];
            if (16 - bb * bb > 0.8 * 0.8) continue;
            n++;
            for (int c = 0; c < 3; c++) {
                double pa = a[(y * W + x) * 3 + c], pb = b[(y * W + x) * 3 + c];
                sa[c] += pa, sb[c] += pb;
                sq += (pa - pb) * (pa - pb) / (pb * pb + 1e-12);
            }
        }
    *mean_err = 0;
    for (int c = 0; c < 3; c++)
        *mean_err = fmax(*mean_err, fabs(sa[c] - sb[c]) / (sb[c] + 1e-12));
    *rms_err = n ? sqrt(sq / (3 * n)) : 1;
    CHECK(n > 50);
}

/* A copper-coloured metal sphere alone in a uniform sky of radiance 1: every interior pixel
 * reflects E_spec(N.V) of the sky (no interreflection on a convex object), which the path
 * tracer (256 samples) estimates. Glossy (0.3): the traced reflections average 32 frames of
 * one ray; rough (0.8): the probe-field fallback. Without reflections the metal is black.
 * Tolerances: the mean over the sphere carries the albedo table's interpolation (<= 1.1% for
 * metals) and, for the fallback, the probes' view of the sphere itself in E(d) (probe rays
 * that hit it see less than the sky); the per-pixel RMS is dominated by the reference's noise
 * (256 paths of a GGX/cosine mixture: ~2%) plus the 32-frame average (~1%). Measured on
 * lavapipe: glossy mean 0.13%, RMS 2.3%; rough mean 0.44%, RMS 4.2%. */
static void test_sphere(float roughness, double tol_mean, double tol_rms)
{
    const float copper[3] = {0.95f, 0.64f, 0.54f};
    fixture f;
    rd_scene_init(&f.s);
    rd_tri_list t = {0};
    uint32_t mat = material(&f.s, copper, 1, roughness, 1, NULL);
    rd_tris_sphere(&t, (const float[3]){0, 0, 0}, 1.0f, 24, 48, mat);
    rd_tris_commit(&t, &f.s, "sphere");
    rd_mesh *m = &f.s.meshes[0];
    for (uint32_t i = 0; i < m->tri_count * 3; i++) { /* smooth normals */
        const float *p = &m->positions[i * 3];
        float len = sqrtf(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        for (int k = 0; k < 3; k++)
            m->normals[i * 3 + k] = p[k] / len;
    }
    const float eye[3] = {0, 0, 4}, fwd[3] = {0, 0, -1};
    rd_view_camera cam = camera_at(eye, fwd, 35);
    float *ref = NULL, *off = NULL, *on = NULL, *brighter = NULL;
    if (fixture_open(&f, (const float[3]){-2, -2, -2}, (const float[3]){2, 2, 2})) {
        ref = render(&f, &cam, 1, PC_REFLECT_AUTO, 256, 1);
        off = render(&f, &cam, 1, PC_REFLECT_OFF, 0, 1);
        on = render(&f, &cam, 32, PC_REFLECT_AUTO, 0, 1);
        CHECK(has_pass(&f.r.stats, "reflect") == (roughness < PC_REFLECT_MAX_ROUGHNESS));
        /* a changed world restarts the history: one frame in a sky of 2 shows twice the light */
        brighter = render(&f, &cam, 1, PC_REFLECT_AUTO, 0, 2);
    }
    if (ref && off && on && brighter) {
        double mean_on, rms_on, mean_off, rms_off, mean_b, rms_b;
        sphere_error(on, ref, &cam, &mean_on, &rms_on);
        sphere_error(off, ref, &cam, &mean_off, &rms_off);
        for (int i = 0; i < W * H * 3; i++)
            brighter[i] *= 0.5f;
        sphere_error(brighter, on, &cam, &mean_b, &rms_b);
        printf("metal sphere roughness %.1f vs path traced: with reflections mean %.4f rms "
               "%.4f (tolerance %.3f, %.3f); without mean %.4f; sky 1 -> 2 after one frame: "
               "mean %.4f off 2x\n",
               roughness, mean_on, rms_on, tol_mean, tol_rms, mean_off, mean_b);
        CHECKF(mean_on < tol_mean && rms_on < tol_rms, "reflections off the reference");
        CHECKF(mean_off > 0.9, "no reflections should leave the metal black (%g)", mean_off);
        /* traced reflections restart their history (the probe fallback follows the field's
         * own hysteresis instead) */
        if (roughness < PC_REFLECT_MAX_ROUGHNESS)
            CHECKF(mean_b < 0.05, "the history outlived a sky change (%g)", mean_b);
    }
    free(ref);
    free(off);
    free(on);
    free(brighter);
    fixture_close(&f);
}

/* Lambertian only (builtin:cornell: specular weight 0, metallic 0): no reflection pass, and
 * the same bits with reflections on and off. */
static void test_lambertian_untouched(void)
{
    float *img[2];
    rd_frame_stats st[2];
    for (int i = 0; i < 2; i++) {
        test_render_desc d = {
            .scene = "cornell",
            .width = W,
            .height = H,
            .gi = {.mode = PC_GI_DDGI, .counts = {4, 4, 4}, .rays = 64, .seed = 5},
            .updates = 2,
            .reflections = i ? PC_REFLECT_OFF : PC_REFLECT_AUTO};
        img[i] = test_render(&vk, &d, NULL, &st[i]);
    }
    if (img[0] && img[1]) {
        CHECK(has_pass(&st[0], "gi sample"));
        CHECK(!has_pass(&st[0], "reflect") && !has_pass(&st[0], "reflect filter"));
        CHECK(!has_pass(&st[1], "reflect") && st[0].rays.reflect_rays == 0);
        CHECK(memcmp(img[0], img[1], (size_t)W * H * 3 * sizeof(float)) == 0);
        printf("cornell (Lambertian): no reflection pass, identical with reflections on/off\n");
    }
    free(img[0]);
    free(img[1]);
}

/* A mirror floor the camera does not see (it looks up into the sky): the scene has a glossy
 * material, so the passes are recorded, but their indirect dispatch is empty. */
static void test_glossy_out_of_sight(void)
{
    const float white[3] = {1, 1, 1};
    fixture f;
    rd_scene_init(&f.s);
    rd_tri_list t = {0};
    rd_tris_quad(&t, (const float[3]){-5, 0, -5}, (const float[3]){-5, 0, 5},
                 (const float[3]){5, 0, 5}, (const float[3]){5, 0, -5},
                 material(&f.s, white, 1, 0.1f, 1, NULL));
    rd_tris_commit(&t, &f.s, "floor");
    const float eye[3] = {0, 1, 0}, fwd[3] = {0, 1, 0.2f};
    rd_view_camera cam = camera_at(eye, fwd, 40);
    float *img = NULL;
    if (fixture_open(&f, (const float[3]){-5, 0, -5}, (const float[3]){5, 2, 5}))
        img = render(&f, &cam, 1, PC_REFLECT_AUTO, 0, 1);
    if (img) {
        CHECK(has_pass(&f.r.stats, "reflect"));
        CHECKF(f.r.stats.rays.reflect_rays == 0, "%u reflection rays", f.r.stats.rays.reflect_rays);
        CHECK(f.r.stats.rays.primary_rays == W * H);
        printf("glossy floor out of sight: reflection passes recorded, %u rays traced\n",
               f.r.stats.rays.reflect_rays);
    }
    free(img);
    fixture_close(&f);
}

int main(void)
{
    if (!test_vk_open(&vk)) return test_finish();
    test_mirror(true);
    test_mirror(false);
    test_sphere(0.3f, 0.02, 0.05);
    test_sphere(0.8f, 0.03, 0.08);
    test_lambertian_untouched();
    test_glossy_out_of_sight();
    return test_vk_close(&vk);
}
