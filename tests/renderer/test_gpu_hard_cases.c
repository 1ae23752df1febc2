/* The reference path tracer against analytic values, and every hard case of the stability
 * suite at tiny sizes on lavapipe: finite output and its documented expectation. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "brdf_reference.h"
#include "gltf_builder.h"
#include "renderer/builtin/hard_cases.h"
#include "renderer/scene/mesh_builder.h"
#include "server/cli/image_metrics.h"
#include "test_render_util.h"
#include "test_util.h"

#define W 24
#define H 16
#define PX ((size_t)W * H)

static rd_vk vk;

/* small probe grids keep lavapipe fast; the fitted grids are exercised by probecast eval */
static const rd_ddgi_settings DDGI = {
    .mode = PC_GI_DDGI, .counts = {5, 4, 4}, .rays = 64, .seed = 5}; /* default hysteresis */

/* updates 0 with gi: until the field converges (as probecast render does by default) */
static float *render_case(const char *name, const rd_ddgi_settings *gi, unsigned updates,
                          unsigned spp, unsigned seed)
{
    char scene[64];
    snprintf(scene, sizeof scene, "hard:%s", name);
    test_render_desc d = {.scene = scene,
                          .width = W,
                          .height = H,
                          .updates = updates,
                          .converge = gi && updates == 0,
                          .pathtrace_spp = spp,
                          .seed = seed};
    if (gi) d.gi = *gi;
    return test_render(&vk, &d, NULL, NULL);
}

static size_t count_non_finite(const float *img)
{
    size_t bad = 0;
    test_image_mean(img, PX * 3, &bad);
    return bad;
}

static double rel_mse(const float *a, const float *b)
{
    rd_image_error e;
    rd_image_compare(a, b, PX, &e);
    return e.rel_mse;
}

/* Path tracer: point light over a plane (only next-event estimation at the first vertex
 * contributes: exact per pixel) and the closed furnace (2% of Le/(1-rho)). */
static void test_pathtracer_analytic(void)
{
    test_render_desc d = {.scene = "plane-point", .width = W, .height = H};
    float *direct = test_render(&vk, &d, NULL, NULL);
    d.pathtrace_spp = 4;
    float *pt = test_render(&vk, &d, NULL, NULL);
    if (direct && pt) {
        int bad = 0;
        for (size_t i = 0; i < PX * 3; i++)
            if (!test_close_rel(pt[i], direct[i], 0.01) && !(direct[i] == 0 && pt[i] == 0)) bad++;
        CHECKF(bad == 0, "%d path-traced channels differ from the analytic direct light", bad);
    }
    free(direct);
    free(pt);
    test_render_desc f = {
        .scene = "furnace", .width = W, .height = H, .pathtrace_spp = 256, .max_bounces = 256};
    float *furnace = test_render(&vk, &f, NULL, NULL);
    if (furnace) {
        double mean = test_image_mean(furnace, PX * 3, NULL);
        CHECKF(fabs(mean - 2.0) < 0.02 * 2.0, "path-traced furnace %g, expected 2", mean);
        CHECK(count_non_finite(furnace) == 0);
    }
    free(furnace);
    /* glTF materials: closed furnaces written as glTF (base 0.5 and 0.9, emission 0.1, the
     * dielectric lobe of Appendix B) against the radiance that Appendix B's albedo, integrated
     * here in C apart from the shaders, allows (brdf_reference.h); 1% for the samples' noise */
    const double bases[2] = {0.5, 0.9};
    for (int k = 0; k < 2; k++) {
        char *gltf = gltf_furnace((float)bases[k], 0.1f, 0.0f, 1.0f);
        test_render_desc g = {
            .gltf = gltf, .width = W, .height = H, .pathtrace_spp = 256, .max_bounces = 256};
        float *img = test_render(&vk, &g, NULL, NULL);
        double lo, hi;
        test_furnace_bounds(bases[k], 0, 1, 0.1, &lo, &hi);
        if (img) {
            double mean = test_image_mean(img, PX * 3, NULL);
            printf("path-traced glTF furnace base %.1f: %.5f (Appendix B: %.5f..%.5f)\n", bases[k],
                   mean, lo, hi);
            CHECKF(mean >= 0.99 * lo && mean <= 1.01 * hi,
                   "path-traced glTF furnace base %.1f: %g outside %g..%g", bases[k], mean, lo, hi);
        }
        free(img);
        free(gltf);
    }
}

/* DDGI on the Cornell box against the reference. The threshold comes from the reference's
 * own noise floor n = relMSE(ref seed 1, ref seed 2): DDGI must remove at least half of the
 * error that missing indirect light causes beyond that floor,
 *   relMSE(ddgi) <= n + 0.5 * (relMSE(direct) - n). */
static void test_cornell_error(const char *name)
{
    float *ref1 = render_case(name, NULL, 0, 128, 1), *ref2 = render_case(name, NULL, 0, 128, 2);
    float *direct = render_case(name, NULL, 0, 0, 0);
    float *ddgi = render_case(name, &DDGI, 0, 0, 0); /* converged */
    if (ref1 && ref2 && direct && ddgi) {
        double noise = rel_mse(ref2, ref1), e_direct = rel_mse(direct, ref1),
               e_ddgi = rel_mse(ddgi, ref1);
        double limit = noise + 0.5 * (e_direct - noise);
        printf("%s: reference noise floor %.4g, direct %.4g, ddgi %.4g (limit %.4g)\n", name, noise,
               e_direct, e_ddgi, limit);
        CHECK(e_direct > noise); /* the case has indirect light to find */
        CHECKF(e_ddgi <= limit, "%s: ddgi relMSE %g above %g", name, e_ddgi, limit);
        CHECK(count_non_finite(ddgi) == 0 && count_non_finite(ref1) == 0);
    }
    free(ref1), free(ref2), free(direct), free(ddgi);
}

/* Scaled or far-away copies of the Cornell box render like the original: direct light to
 * float precision, DDGI within its own seed-to-seed noise (a float-level change in a ray
 * decides which probe ray hits what, so the Monte Carlo noise decorrelates). */
static void test_invariance(void)
{
    float *base = render_case("cornell", &DDGI, 6, 0, 0);
    float *direct = render_case("cornell", NULL, 0, 0, 0);
    rd_ddgi_settings other_seed = DDGI;
    other_seed.seed = 99;
    float *base2 = render_case("cornell", &other_seed, 6, 0, 0);
    double seed_noise = base && base2 ? rel_mse(base2, base) : 0;
    const char *variants[] = {"scaled-100", "scaled-0.01", "far-10km"};
    for (int i = 0; base && direct && base2 && i < 3; i++) {
        float *v = render_case(variants[i], &DDGI, 6, 0, 0);
        float *vd = render_case(variants[i], NULL, 0, 0, 0);
        if (!v || !vd) continue;
        double e = rel_mse(v, base), ed = rel_mse(vd, direct);
        printf("%s vs cornell: direct relMSE %.3g, ddgi relMSE %.3g (seed noise %.3g)\n",
               variants[i], ed, e, seed_noise);
        /* pixel-centre rays that graze an edge may pick the other surface once positions are
         * rounded differently: allow such silhouette pixels, nothing else */
        size_t differing = 0;
        for (size_t p = 0; p < PX; p++)
            for (int k = 0; k < 3; k++)
                if (!test_close_rel(vd[p * 3 + k], direct[p * 3 + k], 1e-2) &&
                    fabsf(vd[p * 3 + k] - direct[p * 3 + k]) > 1e-6f) {
                    differing++;
                    break;
                }
        CHECKF(differing <= PX / 25, "%s: %zu of %zu pixels of direct light differ from cornell",
               variants[i], differing, PX);
        CHECKF(e < 2 * seed_noise + 1e-4, "%s differs from cornell: relMSE %g", variants[i], e);
        CHECK(count_non_finite(v) == 0 && count_non_finite(vd) == 0);
        free(v), free(vd);
    }
    free(base), free(direct), free(base2);
}

/* One render of a builtin scene or a glTF text (scene NULL) at W x H: gi NULL and spp 0 for
 * direct light only, spp > 0 for the path tracer. */
static float *render_either(const char *scene, const char *gltf, const rd_ddgi_settings *gi,
                            unsigned updates, unsigned spp, unsigned seed)
{
    test_render_desc d = {.scene = scene,
                          .gltf = scene ? NULL : gltf,
                          .width = W,
                          .height = H,
                          .updates = updates,
                          .pathtrace_spp = spp,
                          .seed = seed};
    if (gi) d.gi = *gi;
    return test_render(&vk, &d, NULL, NULL);
}

static double luminance(const float *rgb)
{
    return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
}

/* Speckles: pixels of img under a tenth of ref's luminance where ref is lit (above a tenth of
 * its mean luminance). */
static size_t count_speckles(const float *img, const float *ref)
{
    double mean = 0;
    for (size_t p = 0; p < PX; p++)
        mean += luminance(ref + 3 * p) / PX;
    size_t n = 0;
    for (size_t p = 0; p < PX; p++)
        n += luminance(ref + 3 * p) > 0.1 * mean &&
             luminance(img + 3 * p) < 0.1 * luminance(ref + 3 * p);
    return n;
}

/* Issue 28: the Cornell box scaled x100 with its vertices baked 10 km from the origin (identity
 * nodes, as geo-referenced data comes) renders like the same box at the origin (scaled-100): no
 * speckles (shadow and bounce rays that hit the surface they leave: positions of 1e4 m hold
 * 1 mm, and the ray offset followed the floating origin's small world coordinates); the path
 * tracer and DDGI within their seed noise, direct light to float precision but for silhouette
 * pixels. Both as builtin scenes and as glTF files. */
static void test_far_baked(void)
{
    rd_ddgi_settings other_seed = DDGI;
    other_seed.seed = 99;
    for (int as_gltf = 0; as_gltf < 2; as_gltf++) {
        char *text[2] = {NULL, NULL};
        const char *name[2] = {"hard:scaled-100", "hard:far-10km-baked"};
        for (int i = 0; as_gltf && i < 2; i++) {
            rd_scene s;
            char err[256];
            CHECKF(rd_hard_case_build(name[i] + 5, &s, err, sizeof err), "%s", err);
            text[i] = gltf_from_scene(&s);
            rd_scene_destroy(&s);
        }
        const char *origin = as_gltf ? NULL : name[0], *far = as_gltf ? NULL : name[1];
        const char *kind = as_gltf ? "glTF" : "builtin";
        float *pt1 = render_either(origin, text[0], NULL, 0, 64, 1);
        float *pt2 = render_either(origin, text[0], NULL, 0, 64, 2);
        float *pt_far = render_either(far, text[1], NULL, 0, 64, 1);
        float *dl = render_either(origin, text[0], NULL, 0, 0, 0);
        float *dl_far = render_either(far, text[1], NULL, 0, 0, 0);
        float *dd1 = render_either(origin, text[0], &DDGI, 6, 0, 0);
        float *dd2 = render_either(origin, text[0], &other_seed, 6, 0, 0);
        float *dd_far = render_either(far, text[1], &DDGI, 6, 0, 0);
        if (pt1 && pt2 && pt_far && dl && dl_far && dd1 && dd2 && dd_far) {
            double pt_noise = rel_mse(pt2, pt1), pt_e = rel_mse(pt_far, pt1);
            double dd_noise = rel_mse(dd2, dd1), dd_e = rel_mse(dd_far, dd1);
            size_t sp_pt = count_speckles(pt_far, pt1), sp_dl = count_speckles(dl_far, dl),
                   sp_dd = count_speckles(dd_far, dd1);
            size_t differing = 0;
            for (size_t p = 0; p < PX; p++)
                for (int k = 0; k < 3; k++)
                    if (!test_close_rel(dl_far[p * 3 + k], dl[p * 3 + k], 1e-2) &&
                        fabsf(dl_far[p * 3 + k] - dl[p * 3 + k]) > 1e-6f) {
                        differing++;
                        break;
                    }
            printf("far-10km-baked (%s) vs scaled-100: path tracer relMSE %.3g (seed noise %.3g), "
                   "DDGI %.3g (seed noise %.3g), direct light %zu of %zu pixels differ; speckles: "
                   "path tracer %zu, direct %zu, DDGI %zu\n",
                   kind, pt_e, pt_noise, dd_e, dd_noise, differing, PX, sp_pt, sp_dl, sp_dd);
            CHECKF(sp_pt == 0 && sp_dl == 0 && sp_dd == 0, "%s: speckles %zu %zu %zu", kind, sp_pt,
                   sp_dl, sp_dd);
            CHECKF(pt_e <= pt_noise, "%s: path tracer relMSE %g above its seed noise %g", kind,
                   pt_e, pt_noise);
            CHECKF(dd_e <= dd_noise, "%s: DDGI relMSE %g above its seed noise %g", kind, dd_e,
                   dd_noise);
            CHECKF(differing <= PX / 25, "%s: %zu of %zu pixels of direct light differ", kind,
                   differing, PX);
            CHECK(count_non_finite(pt_far) == 0 && count_non_finite(dd_far) == 0);
        }
        free(pt1), free(pt2), free(pt_far), free(dl), free(dl_far), free(dd1), free(dd2);
        free(dd_far), free(text[0]), free(text[1]);
    }
}

/* Issue 28: a closed room without a light inside (hard:no-lights: walls, floor and ceiling are
 * separate quads meeting at its edges) under a bright sky and a sun outside renders exactly
 * black in every mode: direct light, classic probes, DDGI, reflections (a glossy variant) and
 * the path tracer. At 32 x 24 the camera's pixel-centre rays meet the room's edges exactly:
 * rays leaving those hits started on the other wall's plane and escaped to the sky (before the
 * fix: the path tracer up to 0.39, the glossy variant's reflections up to 0.23). */
static void test_closed_room_sky(void)
{
    enum { RW = 32, RH = 24 };
    for (int glossy = 0; glossy < 2; glossy++) {
        rd_scene s;
        char err[256];
        CHECKF(rd_hard_case_build("no-lights", &s, err, sizeof err), "%s", err);
        const float dir[3] = {0.3f, -1.0f, -0.4f}, white[3] = {1, 1, 1};
        rd_build_sun(&s, dir, white, 10.0f);
        for (uint32_t m = 0; glossy && m < s.material_count; m++)
            s.materials[m].metallic = 0.5f, s.materials[m].roughness = 0.3f;
        CHECKF(rd_scene_update(&s, err, sizeof err), "%s", err);
        char *gltf = gltf_from_scene(&s);
        rd_scene_destroy(&s);
        const struct {
            unsigned gi, spp;
            const char *name;
        } modes[] = {{PC_GI_OFF, 0, "direct"},
                     {PC_GI_CLASSIC, 0, "classic"},
                     {PC_GI_DDGI, 0, "ddgi"},
                     {PC_GI_OFF, 64, "path tracer"}};
        for (size_t m = 0; m < sizeof modes / sizeof modes[0]; m++) {
            test_render_desc d = {.gltf = gltf,
                                  .width = RW,
                                  .height = RH,
                                  .sky = {1, 1, 1},
                                  .updates = 4,
                                  .pathtrace_spp = modes[m].spp,
                                  .seed = 1};
            if (modes[m].gi != PC_GI_OFF) {
                d.gi = DDGI;
                d.gi.mode = modes[m].gi;
            }
            float *img = test_render(&vk, &d, NULL, NULL);
            if (!img) continue;
            size_t nonzero = 0;
            float peak = 0;
            for (size_t i = 0; i < (size_t)RW * RH * 3; i++) {
                nonzero += img[i] != 0.0f;
                peak = fmaxf(peak, img[i]);
            }
            CHECKF(nonzero == 0, "closed room under the sky (%s, %s): %zu values above 0, up to %g",
                   glossy ? "glossy" : "diffuse", modes[m].name, nonzero, peak);
            free(img);
        }
        free(gltf);
    }
}

static void test_no_lights(void)
{
    float *a = render_case("no-lights", NULL, 0, 0, 0);
    float *b = render_case("no-lights", &DDGI, 4, 0, 0);
    float *c = render_case("no-lights", NULL, 0, 16, 1);
    for (float *img = a; a && b && c && img; img = img == a ? b : img == b ? c : NULL) {
        size_t nonzero = 0;
        for (size_t i = 0; i < PX * 3; i++)
            nonzero += img[i] != 0.0f;
        CHECKF(nonzero == 0, "%zu non-zero values without any light", nonzero);
    }
    free(a), free(b), free(c);
}

/* Finite output in every mode; `lit_by` says which of DDGI (1) and the path tracer (2) must
 * produce light. */
static void test_finite_and_lit(const char *name, unsigned spp, int lit_by)
{
    float *d = render_case(name, &DDGI, 6, 0, 0);
    float *p = spp ? render_case(name, NULL, 0, spp, 1) : NULL;
    if (d) {
        CHECKF(count_non_finite(d) == 0, "%s: non-finite output", name);
        if (lit_by & 1) CHECKF(test_image_mean(d, PX * 3, NULL) > 0, "%s: black image", name);
    }
    if (p) {
        CHECKF(count_non_finite(p) == 0, "%s: non-finite path-traced output", name);
        if (lit_by & 2) CHECKF(test_image_mean(p, PX * 3, NULL) > 0, "%s: black reference", name);
    }
    free(d), free(p);
}

static void test_mirrored(void)
{
    test_render_desc d = {.scene = "plane-point", .width = W, .height = H};
    float *plain = test_render(&vk, &d, NULL, NULL);
    float *mirrored = render_case("mirrored", NULL, 0, 0, 0);
    if (plain && mirrored) {
        int bad = 0;
        for (size_t i = 0; i < PX * 3; i++)
            bad += !test_close_rel(mirrored[i], plain[i], 1e-4);
        CHECKF(bad == 0, "%d channels differ under the mirrored node", bad);
        CHECK(test_image_mean(mirrored, PX * 3, NULL) > 0); /* not culled: front face kept */
    }
    free(plain), free(mirrored);
}

/* Moving object: the sphere moves; GI that kept following it matches the reference of the
 * final pose as well as a field built from scratch there. */
static void test_moving(void)
{
    char err[512];
    test_rig rig;
    if (!test_rig_open(&vk, "hard:moving", &rig)) return;
    rd_renderer *r = &rig.r;
    rd_scene *s = &rig.s;
    rd_frame_settings fs = {.width = W, .height = H, .gi_updates = 4};
    CHECK(rd_renderer_configure_gi(r, s->bounds_min, s->bounds_max, &DDGI, err, sizeof err) ==
          RD_VK_OK);
    float *img = malloc(PX * 12), *still = malloc(PX * 12);
    for (unsigned f = 0; f <= 4; f++) { /* move, update a few times, move again */
        rd_hard_case_pose("moving", s, f);
        CHECK(rd_gpu_scene_update_instances(&vk, &rig.gs, s, err, sizeof err) == RD_VK_OK);
        CHECK(rd_renderer_render(r, &rig.gs, &rig.cam, &fs, err, sizeof err) == RD_VK_OK);
        CHECK(rd_renderer_read_hdr(r, img, err, sizeof err) == RD_VK_OK);
        CHECKF(count_non_finite(img) == 0, "frame %u not finite", f);
    }
    fs.gi_updates = 16;
    CHECK(rd_renderer_render(r, &rig.gs, &rig.cam, &fs, err, sizeof err) == RD_VK_OK);
    CHECK(rd_renderer_read_hdr(r, img, err, sizeof err) == RD_VK_OK);
    CHECK(rd_renderer_configure_gi(r, s->bounds_min, s->bounds_max, &DDGI, err, sizeof err) ==
          RD_VK_OK);
    fs.gi_updates = 36; /* same number of updates, all at the final pose */
    CHECK(rd_renderer_render(r, &rig.gs, &rig.cam, &fs, err, sizeof err) == RD_VK_OK);
    CHECK(rd_renderer_read_hdr(r, still, err, sizeof err) == RD_VK_OK);
    double e = rel_mse(img, still);
    printf("moving: relMSE against a field converged at the final pose %.3g\n", e);
    CHECKF(e < 0.01, "GI did not follow the moved object (relMSE %g)", e);
    free(img), free(still);
    test_rig_close(&vk, &rig);
}

/* Thin walls (issue 28): a room of 5 cm walls on a sunlit terrace, lit inside only through a
 * door, with the fitted probe grid (8 x 2 x 8: probes 2.75 m apart, most of them outside). The
 * paper's Chebyshev test alone lets the sunlit side through the walls (+220% against the path
 * tracer on an H100 at 128 x 128); the default visibility rays keep it out (-3.3% there,
 * +2.4% at this size). The default 256 rays per probe: with 64 the dim room's probes blend
 * noisier values in their encoded space and end 35% dark, with the rays or without; the leak
 * shows at 64 as well. */
static void test_thin_walls(void)
{
    float *ref = render_case("thin-walls", NULL, 0, 2048, 1); /* the door-lit room is noisy */
    double r = ref ? test_image_mean(ref, PX * 3, NULL) : 0;
    const unsigned modes[2] = {PC_DDGI_VIS_ALL, PC_DDGI_VIS_OFF}, rays[2] = {256, 64};
    double bias[2] = {0, 0};
    for (int m = 0; m < 2 && ref; m++) {
        rd_ddgi_settings gi = {
            .mode = PC_GI_DDGI, .rays = rays[m], .seed = 5, .visibility = modes[m]};
        float *img = render_case("thin-walls", &gi, 0, 0, 0);
        if (!img) continue;
        double mean = test_image_mean(img, PX * 3, NULL);
        bias[m] = mean / r - 1;
        printf("thin-walls, visibility rays %s, %u rays: DDGI mean %.4f, path traced %.4f: "
               "bias %+.1f%%, relMSE %.3g\n",
               m == 0 ? "all" : "off", rays[m], mean, r, 100 * bias[m], rel_mse(img, ref));
        CHECK(count_non_finite(img) == 0);
        free(img);
    }
    if (ref) {
        CHECKF(fabs(bias[0]) < 0.05, "thin-walls with visibility rays: bias %+.1f%%",
               100 * bias[0]);
        CHECKF(bias[1] > 0.5, "thin-walls without rays should leak: bias %+.1f%%", 100 * bias[1]);
    }
    /* 12 x 3 x 12 probes (given counts): a probe at the far corner of a cell outside the room's
     * corner, joined to the probe inside by a face diagonal only, its own cage edges clear of the
     * building, got no visibility ray and let the sunlit side in through the corner (+105%
     * against the path tracer, H200 128 x 128); every active corner of a cell with a crossed
     * edge now gets its ray (+16%, the rest the coarse grid's: two probe columns in the room) */
    rd_ddgi_settings coarse = {.mode = PC_GI_DDGI, .rays = 256, .seed = 5, .counts = {12, 3, 12}};
    float *img = ref ? render_case("thin-walls", &coarse, 0, 0, 0) : NULL;
    if (img) {
        double b = test_image_mean(img, PX * 3, NULL) / r - 1;
        printf("thin-walls at 12 x 3 x 12 probes: bias %+.1f%%, relMSE %.3g\n", 100 * b,
               rel_mse(img, ref));
        CHECK(count_non_finite(img) == 0);
        CHECKF(fabs(b) < 0.3, "thin-walls at 12 x 3 x 12 probes: bias %+.1f%%", 100 * b);
    }
    free(img);
    free(ref);
}

/* The metallic thin-walls room (metallic 0.5, roughness 0.5: reflection rays): the probe
 * field's irradiance at reflection hits took the hit point back along the ray by the view bias,
 * past the pixel's own wall when the hit was a few centimetres away (corners), outside, where
 * the visibility rays found sunlit probes (H200 at 128x128: +142% against the path tracer; now
 * -2.9%). Lavapipe at 24x16, reflections averaged over 64 frames: +176% with the full bias,
 * +0.9% now (one frame: +28%, rare samples of the sunlit terrace through the door). */
static void test_thin_walls_metal(void)
{
    test_render_desc pt = {.scene = "hard:thin-walls+metal",
                           .width = W,
                           .height = H,
                           .pathtrace_spp = 2048,
                           .seed = 1};
    float *ref = test_render(&vk, &pt, NULL, NULL);
    test_render_desc dd = {.scene = "hard:thin-walls+metal",
                           .width = W,
                           .height = H,
                           .gi = {.mode = PC_GI_DDGI, .seed = 5},
                           .converge = true,
                           .frames = 64};
    float *img = ref ? test_render(&vk, &dd, NULL, NULL) : NULL;
    if (img) {
        double r = test_image_mean(ref, PX * 3, NULL), m = test_image_mean(img, PX * 3, NULL);
        printf("thin-walls+metal: DDGI mean %.4f, path traced %.4f: bias %+.1f%%, relMSE %.3g\n", m,
               r, 100 * (m / r - 1), rel_mse(img, ref));
        CHECKF(fabs(m / r - 1) < 0.10, "thin-walls+metal: bias %+.1f%%", 100 * (m / r - 1));
        CHECK(count_non_finite(img) == 0);
    }
    free(img);
    free(ref);
}

static void test_cornell_errors(void)
{
    test_cornell_error("cornell");
    test_cornell_error("thick-walls");
    test_cornell_error("many-lights");
}

static void test_finite_and_lit_cases(void)
{
    test_finite_and_lit("tiny-emitter", 64, 0);
    test_finite_and_lit("degenerate", 16, 3);
}

/* every check, in order; `test_gpu_hard_cases NAME` runs one (while working on it) */
static const struct {
    const char *name;
    void (*run)(void);
} checks[] = {
    {"pathtracer-analytic", test_pathtracer_analytic},
    {"cornell-errors", test_cornell_errors},
    {"thin-walls", test_thin_walls},
    {"thin-walls-metal", test_thin_walls_metal},
    {"invariance", test_invariance},
    {"far-baked", test_far_baked},
    {"no-lights", test_no_lights},
    {"closed-room-sky", test_closed_room_sky},
    {"finite-and-lit", test_finite_and_lit_cases},
    {"mirrored", test_mirrored},
    {"moving", test_moving},
};

int main(int argc, char **argv)
{
    if (!test_vk_open(&vk)) return test_finish();
    unsigned n, ran = 0;
    const rd_hard_case *cases = rd_hard_cases(&n);
    if (argc < 2)
        for (unsigned i = 0; i < n; i++)
            printf("case %-13s expects: %s\n", cases[i].name, cases[i].expect);
    for (size_t i = 0; i < sizeof checks / sizeof checks[0]; i++)
        if (argc < 2 || strcmp(argv[1], checks[i].name) == 0) {
            checks[i].run();
            ran++;
        }
    CHECKF(ran > 0, "no check named %s", argc > 1 ? argv[1] : "");
    return test_vk_close(&vk);
}
