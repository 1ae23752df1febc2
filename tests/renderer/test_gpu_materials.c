/* GPU checks of the glTF metallic-roughness BRDF (shaders/brdf.glsl) on lavapipe with the
 * validation layer on:
 *   - direct light: a rough metal and a glossy dielectric floor under a point light match
 *     Appendix B evaluated here in double precision, pixel by pixel;
 *   - a metallic sphere (roughness 0.1) renders measurably different from a dielectric one
 *     of the same base colour;
 *   - energy: in a uniform sky L, the path-traced white Lambertian sphere reflects L and
 *     white metals and a glTF dielectric reflect no more than L;
 *   - normal maps: a constant tangent-space normal tilted by theta changes N.L from cos(a) to
 *     cos(a - theta), with tangents derived from the UVs and from a TANGENT attribute;
 *   - indirect diffuse: occlusion maps darken the DDGI term only, metals take none of it;
 *   - the two compile-time variants of the tracing and shading passes (PC_MASKED_LANES,
 *     shaders/common.glsl: one call site in a loop on CPU devices, inlined call sites on GPUs)
 *     render the same image, bit for bit, of a room with all five textures, a partition that
 *     crosses probe cage edges (so the DDGI query's visibility rays run) and two alpha-masked
 *     screens. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/mesh_builder.h"
#include "test_render_util.h"
#include "test_util.h"

#define W 32
#define H 24

static rd_vk vk;

static uint32_t add_material(rd_scene *s, float base, float metallic, float roughness,
                             float specular)
{
    const float grey[3] = {base, base, base};
    rd_material m = test_material(grey, metallic, roughness, specular);
    return rd_scene_add_material(s, &m);
}

/* Renders s (updated here) from cam: direct light (plus one probe update and indirect diffuse
 * light, no reflections, when gi), or path traced with spp > 0 in a sky of radiance `sky`.
 * Returns W*H*3 linear floats (caller frees) or NULL after a failed CHECK. */
/* near-field rays of render_gi's frames (PC_NEAR_*: on by default) */
static unsigned near_field = PC_NEAR_AUTO;

static float *render_gi(rd_scene *s, const rd_view_camera *cam, unsigned spp, float sky, bool gi)
{
    char err[512] = "";
    CHECKF(rd_scene_update(s, err, sizeof err), "%s", err);
    rd_gpu_scene gs;
    rd_renderer r;
    float *rgb = calloc((size_t)W * H * 3, sizeof(float));
    /* indirect diffuse alone: reflections (and the probe-based specular of rough surfaces)
     * have their own test, test_gpu_reflections */
    rd_frame_settings fs = {.width = W,
                            .height = H,
                            .pathtrace_spp = spp,
                            .seed = 3,
                            .sky = {sky, sky, sky},
                            .reflections = PC_REFLECT_OFF,
                            .near_field = near_field};
    rd_vk_result res = rd_gpu_scene_create(&vk, &gs, s, err, sizeof err);
    CHECKF(res == RD_VK_OK, "%s", err);
    if (res != RD_VK_OK) {
        free(rgb);
        return NULL;
    }
    res = rd_renderer_create(&vk, &r, err, sizeof err);
    rd_ddgi_settings settings = {.mode = PC_GI_DDGI, .counts = {3, 3, 3}, .rays = 64, .seed = 5};
    if (res == RD_VK_OK && gi)
        res =
            rd_renderer_configure_gi(&r, s->bounds_min, s->bounds_max, &settings, err, sizeof err);
    if (res == RD_VK_OK) res = rd_renderer_render(&r, &gs, cam, &fs, err, sizeof err);
    if (res == RD_VK_OK) res = rd_renderer_read_hdr(&r, rgb, err, sizeof err);
    CHECKF(res == RD_VK_OK, "%s", err);
    rd_renderer_destroy(&r);
    rd_gpu_scene_destroy(&vk, &gs);
    if (res != RD_VK_OK) {
        free(rgb);
        return NULL;
    }
    return rgb;
}

static float *render_scene(rd_scene *s, const rd_view_camera *cam, unsigned spp, float sky)
{
    return render_gi(s, cam, spp, sky, false);
}

static rd_view_camera look(float ex, float ey, float ez, const float fwd[3], const float up[3],
                           float fov_deg)
{
    rd_view_camera c;
    memset(&c, 0, sizeof c);
    c.eye[0] = ex, c.eye[1] = ey, c.eye[2] = ez;
    memcpy(c.forward, fwd, sizeof c.forward);
    memcpy(c.up, up, sizeof c.up);
    c.yfov = fov_deg * (float)M_PI / 180.0f;
    return c;
}

static void pixel_ray(const pc_view *v, int x, int y, double d[3])
{
    test_pixel_dir(v, W, H, x, y, d);
}

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* Appendix B of the glTF 2.0 specification for a grey base colour (the test oracle). */
static double appendix_b(double base, double metallic, double roughness, const double n[3],
                         const double v[3], const double l[3])
{
    double nl = dot3(n, l), nv = dot3(n, v);
    if (nl <= 0 || nv <= 0) return 0;
    double h[3] = {v[0] + l[0], v[1] + l[1], v[2] + l[2]}, hl = sqrt(dot3(h, h));
    for (int k = 0; k < 3; k++)
        h[k] /= hl;
    double a = roughness * roughness, a2 = a * a, nh = dot3(n, h), vh = dot3(v, h);
    double dd = nh * nh * (a2 - 1) + 1, d = a2 / (M_PI * dd * dd);
    double vis = 0.5 / (nl * sqrt(nv * nv * (1 - a2) + a2) + nv * sqrt(nl * nl * (1 - a2) + a2));
    double spec = d * vis, fw = pow(1 - vh, 5);
    double metal = spec * (base + (1 - base) * fw);
    double f = 0.04 + 0.96 * fw, dielectric = (1 - f) * base / M_PI + f * spec;
    return (1 - metallic) * dielectric + metallic * metal;
}

/* A 10 x 10 floor at y = 0 under a 100 cd point light at (0.5, 2, 0), seen from (0, 4, 1.5):
 * every floor pixel carries f(v, l) I cos / r^2 within 1%. */
static void test_direct_brdf(float metallic, float roughness)
{
    rd_scene s;
    rd_scene_init(&s);
    rd_tri_list t = {0};
    uint32_t mat = add_material(&s, 0.6f, metallic, roughness, 1);
    const float a[3] = {-5, 0, -5}, b[3] = {-5, 0, 5}, c[3] = {5, 0, 5}, d[3] = {5, 0, -5};
    rd_tris_quad(&t, a, b, c, d, mat);
    rd_tris_commit(&t, &s, "floor");
    rd_build_point_light(&s, 0.5f, 2, 0, 100);
    const float fwd[3] = {0, -0.9363292f, -0.3511234f}, up[3] = {0, 0.3511234f, -0.9363292f};
    rd_view_camera cam = look(0, 4, 1.5f, fwd, up, 50);
    float *img = render_scene(&s, &cam, 0, 0);
    if (img) {
        pc_view v;
        rd_camera_to_view(&cam, W, H, &v);
        const double eye[3] = {0, 4, 1.5}, light[3] = {0.5, 2, 0}, n[3] = {0, 1, 0};
        int bad = 0, checked = 0;
        double peak = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                double dir[3];
                pixel_ray(&v, x, y, dir);
                if (dir[1] >= -1e-3) continue;
                double tt = -eye[1] / dir[1];
                double p[3] = {eye[0] + tt * dir[0], 0, eye[2] + tt * dir[2]};
                if (fabs(p[0]) > 4.9 || fabs(p[2]) > 4.9) continue;
                double l[3] = {light[0] - p[0], light[1] - p[1], light[2] - p[2]};
                double r2 = dot3(l, l), r = sqrt(r2);
                double vv[3] = {-dir[0], -dir[1], -dir[2]};
                for (int k = 0; k < 3; k++)
                    l[k] /= r;
                double expect = appendix_b(0.6, metallic, roughness, n, vv, l) * 100 * l[1] / r2;
                float got = img[(y * W + x) * 3];
                checked++;
                if (expect > peak) peak = expect;
                if (!test_close_rel(got, expect, 0.01) && bad++ < 5)
                    fprintf(stderr, "metallic %g roughness %g pixel %d,%d: %g, expected %g\n",
                            metallic, roughness, x, y, got, expect);
            }
        CHECKF(bad == 0, "metallic %g roughness %g: %d of %d pixels off Appendix B", metallic,
               roughness, bad, checked);
        CHECK(checked > W * H / 2);
        printf("floor metallic %g roughness %g: %d pixels match Appendix B (peak %.3f)\n", metallic,
               roughness, checked, peak);
    }
    free(img);
    rd_scene_destroy(&s);
}

/* A sphere of radius 1 at the origin (smooth normals when smooth, else flat facets). */
static void add_sphere(rd_scene *s, uint32_t mat, bool smooth)
{
    rd_tri_list t = {0};
    const float c[3] = {0, 0, 0};
    rd_tris_sphere(&t, c, 1.0f, 24, 48, mat);
    rd_tris_commit(&t, s, "sphere");
    rd_mesh *m = &s->meshes[s->mesh_count - 1];
    if (!smooth) return;
    for (uint32_t i = 0; i < m->tri_count * 3; i++) {
        const float *p = &m->positions[i * 3];
        float len = sqrtf(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        for (int k = 0; k < 3; k++)
            m->normals[i * 3 + k] = p[k] / len;
    }
}

static const float kFwd[3] = {0, 0, -1}, kUp[3] = {0, 1, 0};

/* Same base colour, metallic 1 vs 0 at roughness 0.1, under a point light: the metal has no
 * diffuse term and a coloured, much brighter highlight. */
static void test_metal_differs(void)
{
    float *img[2] = {NULL, NULL};
    for (int metal = 0; metal < 2; metal++) {
        rd_scene s;
        rd_scene_init(&s);
        add_sphere(&s, add_material(&s, 0.5f, (float)metal, 0.1f, 1), true);
        rd_build_point_light(&s, 1.5f, 2.0f, 3.0f, 20);
        rd_view_camera cam = look(0, 0, 4, kFwd, kUp, 40);
        img[metal] = render_scene(&s, &cam, 0, 0);
        rd_scene_destroy(&s);
    }
    if (img[0] && img[1]) {
        double diff = 0, sum0 = 0, max0 = 0, max1 = 0;
        int dark_metal = 0, lit = 0;
        for (int i = 0; i < W * H * 3; i += 3) {
            diff += fabs(img[1][i] - img[0][i]);
            sum0 += img[0][i];
            max0 = fmax(max0, img[0][i]), max1 = fmax(max1, img[1][i]);
            if (img[0][i] > 0.01) lit++, dark_metal += img[1][i] < 0.2 * img[0][i];
        }
        printf("sphere roughness 0.1: mean |metal - dielectric| / mean dielectric = %.3f, peaks "
               "%.3f vs %.3f, %d of %d lit pixels dark on the metal\n",
               diff / sum0, max1, max0, dark_metal, lit);
        CHECKF(diff / sum0 > 0.3, "metal and dielectric differ by only %.3f", diff / sum0);
        CHECKF(dark_metal > lit / 2, "only %d of %d pixels lose their diffuse light", dark_metal,
               lit);
    }
    free(img[0]);
    free(img[1]);
}

/* White furnace: a flat-faceted sphere alone in a sky of radiance 1, path traced. Pixels well
 * inside the silhouette: the white Lambertian reflects exactly 1 (every path's weight is 1);
 * materials with a specular lobe reflect at most 1 within noise, and smooth white metal
 * almost all of it (its VNDF weight F G2 / G1 is nearly 1). Rough white metal (alpha = 1)
 * keeps only what single-scattering GGX keeps: numerical integration of Appendix B gives a
 * directional albedo of 0.307 at normal incidence, 0.379 at cos 0.7 and 0.451 at cos 0.5. */
static void test_furnace(const char *what, float metallic, float roughness, float specular,
                         double lo, double hi)
{
    rd_scene s;
    rd_scene_init(&s);
    add_sphere(&s, add_material(&s, 1.0f, metallic, roughness, specular), false);
    rd_view_camera cam = look(0, 0, 4, kFwd, kUp, 35);
    float *img = render_scene(&s, &cam, 128, 1.0f);
    if (img) {
        pc_view v;
        rd_camera_to_view(&cam, W, H, &v);
        double sum = 0, mx = 0;
        int n = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                double d[3];
                pixel_ray(&v, x, y, d);
                /* distance of the ray from the sphere centre (eye at z = 4) */
                double b = -4 * d[2], dist2 = 16 - b * b;
                if (dist2 > 0.8 * 0.8) continue;
                const float *p = &img[(y * W + x) * 3];
                double m = (p[0] + p[1] + p[2]) / 3;
                sum += m, n++;
                mx = fmax(mx, m);
            }
        double mean = n ? sum / n : 0;
        printf("furnace %s: mean %.4f over %d pixels (max %.3f), expected [%g, %g]\n", what, mean,
               n, mx, lo, hi);
        CHECK(n > 50);
        CHECKF(mean >= lo && mean <= hi, "furnace %s: mean %g outside [%g, %g]", what, mean, lo,
               hi);
    }
    free(img);
    rd_scene_destroy(&s);
}

/* A Lambertian floor (albedo 0.5) with a 1x1 normal map holding the tangent-space normal
 * (sin theta, 0, cos theta) or (0, sin theta, cos theta), lit by a directional light of 2 lux
 * at angle a from the geometric normal, tilted the same way: the radiance must be
 * 0.5/pi * 2 * cos(a - theta) (with the 8-bit texel's exact normal), not cos(a).
 * axis 0 tilts along u (+x), 1 along the bitangent ("up" in the map: -v = -z); tangent_w != 0
 * gives the mesh a TANGENT (+x, w) instead of deriving it from the UVs (w = -1 flips the
 * bitangent to +z). */
static void test_normal_map(int axis, float tangent_w)
{
    const double theta = 30 * M_PI / 180, alpha = 40 * M_PI / 180;
    uint8_t tx[4] = {128, 128, 255, 255};
    tx[axis] = (uint8_t)lrint((sin(theta) + 1) / 2 * 255);
    tx[2] = (uint8_t)lrint((cos(theta) + 1) / 2 * 255);
    double tn[3];
    for (int k = 0; k < 3; k++)
        tn[k] = tx[k] / 255.0 * 2 - 1;
    double len = sqrt(dot3(tn, tn));
    for (int k = 0; k < 3; k++)
        tn[k] /= len;
    /* world tangent frame: T = +x, B = -z (derived, or TANGENT w = +1) or +z (w = -1), N = +y */
    double bz = tangent_w < 0 ? 1 : -1;
    double n[3] = {tn[0], tn[2], bz * tn[1]};
    /* the light tilts toward the mapped normal's side */
    double l[3] = {axis == 0 ? sin(alpha) : 0, cos(alpha), axis == 1 ? bz * sin(alpha) : 0};
    double expect = 0.5 / M_PI * 2.0 * dot3(n, l), flat = 0.5 / M_PI * 2.0 * cos(alpha);

    rd_scene s;
    rd_scene_init(&s);
    rd_texture t = {.width = 1, .height = 1, .wrap_s = RD_WRAP_REPEAT, .wrap_t = RD_WRAP_REPEAT};
    t.rgba = malloc(4);
    memcpy(t.rgba, tx, 4);
    uint32_t mat = add_material(&s, 0.5f, 0, 1, 0);
    s.materials[mat].normal_texture = (int32_t)rd_scene_add_texture(&s, &t);
    rd_tri_list tl = {0};
    const float a[3] = {-5, 0, -5}, b[3] = {-5, 0, 5}, c[3] = {5, 0, 5}, d[3] = {5, 0, -5};
    rd_tris_quad(&tl, a, b, c, d, mat);
    rd_tris_commit(&tl, &s, "floor");
    rd_mesh *m = &s.meshes[0];
    for (uint32_t i = 0; i < m->tri_count * 3; i++) { /* u = x, v = z */
        m->uvs[i * 2] = m->positions[i * 3] * 0.1f;
        m->uvs[i * 2 + 1] = m->positions[i * 3 + 2] * 0.1f;
    }
    if (tangent_w != 0) {
        m->tangents = calloc((size_t)m->tri_count * 12, sizeof(float));
        for (uint32_t i = 0; i < m->tri_count * 3; i++)
            m->tangents[i * 4] = 1, m->tangents[i * 4 + 3] = tangent_w;
    }
    const float sun_dir[3] = {(float)-l[0], (float)-l[1], (float)-l[2]}, white[3] = {1, 1, 1};
    rd_build_sun(&s, sun_dir, white, 2);
    const float down[3] = {0, -1, 0}, negz[3] = {0, 0, -1};
    rd_view_camera cam = look(0, 3, 0, down, negz, 40);
    float *img = render_scene(&s, &cam, 0, 0);
    if (img) {
        int bad = 0;
        for (int i = 0; i < W * H * 3; i++)
            if (!test_close_rel(img[i], expect, 0.005)) bad++;
        printf("normal map axis %d tangent w %g: %.5f (expected %.5f = cos(a - theta) shading; "
               "unmapped %.5f)\n",
               axis, tangent_w, img[0], expect, flat);
        CHECKF(bad == 0, "normal map axis %d w %g: %d channels differ from %g (e.g. %g)", axis,
               tangent_w, bad, expect, img[0]);
        CHECK(fabs(expect - flat) > 0.1 * flat);
    }
    free(img);
    rd_scene_destroy(&s);
}

/* Indirect diffuse (one probe update: the field holds direct light bounced once, which the
 * camera's materials do not change) in a closed white room lit by a point light:
 *   - an occlusion map (R = 128, strength 1) scales the indirect term alone by 128/255:
 *     occluded - direct = (128/255) (unoccluded - direct) per pixel;
 *   - a metal (metallic 1) has no diffuse albedo: its GI image equals its direct-only one.
 * Both are exact for the probe field's term; near-field rays are off here, since the walls they
 * meet carry the occlusion map too (it darkens their second bounce, as it should), which makes
 * the first check hold only within their noise. */
static void room(rd_scene *s, float metallic, int occlusion)
{
    rd_scene_init(s);
    uint32_t mat = add_material(s, 0.8f, metallic, 1, metallic > 0 ? 1 : 0);
    if (occlusion) {
        rd_texture t = {.width = 1, .height = 1};
        t.rgba = malloc(4);
        memcpy(t.rgba, (const uint8_t[4]){128, 255, 255, 255}, 4);
        s->materials[mat].occlusion_texture = (int32_t)rd_scene_add_texture(s, &t);
    }
    rd_tri_list t = {0};
    const float lo[3] = {-1, 0, -1}, hi[3] = {1, 2, 1};
    rd_tris_room(&t, lo, hi, mat);
    rd_tris_commit(&t, s, "room");
    rd_build_point_light(s, 0.3f, 1.6f, 0.2f, 20.0f);
}

static void test_indirect_diffuse(void)
{
    const float negz[3] = {0, 0, -1}, up[3] = {0, 1, 0};
    rd_view_camera cam = look(0, 1, 0.95f, negz, up, 70);
    float *img[5];
    rd_scene s;
    const struct {
        float metallic;
        int occlusion;
        bool gi;
    } v[5] = {{0, 0, false}, {0, 0, true}, {0, 1, true}, {1, 0, false}, {1, 0, true}};
    near_field = PC_NEAR_OFF;
    for (int i = 0; i < 5; i++) {
        room(&s, v[i].metallic, v[i].occlusion);
        img[i] = render_gi(&s, &cam, 0, 0, v[i].gi);
        rd_scene_destroy(&s);
    }
    if (img[0] && img[1] && img[2] && img[3] && img[4]) {
        const double occ = 128 / 255.0;
        double indirect = 0;
        int bad_occ = 0, bad_metal = 0;
        for (int i = 0; i < W * H * 3; i++) {
            double ind = img[1][i] - img[0][i], ind_occ = img[2][i] - img[0][i];
            indirect += ind;
            if (fabs(ind_occ - occ * ind) > 1e-4 * img[1][i] + 1e-6) bad_occ++;
            if (fabs(img[4][i] - img[3][i]) > 1e-6 * img[3][i] + 1e-7) bad_metal++;
        }
        printf("indirect diffuse: mean %.4f; occlusion and metal checks: %d and %d off\n",
               indirect / (W * H * 3), bad_occ, bad_metal);
        CHECKF(indirect / (W * H * 3) > 0.01, "no indirect light (%g)", indirect);
        CHECKF(bad_occ == 0, "%d channels: occlusion does not scale the indirect term alone",
               bad_occ);
        CHECKF(bad_metal == 0, "%d channels: a metal receives indirect diffuse light", bad_metal);
    }
    for (int i = 0; i < 5; i++)
        free(img[i]);
    near_field = PC_NEAR_AUTO;
}

/* A texture of w x h texels, each (r, g, b, a) + k * step. */
static int32_t add_texture(rd_scene *s, uint32_t w, uint32_t h, const uint8_t rgba[4], int step)
{
    rd_texture t = {.width = w, .height = h, .wrap_s = RD_WRAP_REPEAT, .wrap_t = RD_WRAP_REPEAT};
    t.rgba = malloc((size_t)w * h * 4);
    for (uint32_t k = 0; k < w * h; k++)
        for (int c = 0; c < 4; c++)
            t.rgba[k * 4 + c] = (uint8_t)(rgba[c] + (int)k * step);
    return (int32_t)rd_scene_add_texture(s, &t);
}

static void test_masked_lanes(void)
{
    rd_scene s;
    rd_scene_init(&s);
    uint32_t mat = add_material(&s, 0.8f, 0.5f, 0.6f, 1);
    rd_material *m = &s.materials[mat];
    m->base_color_texture = add_texture(&s, 2, 2, (const uint8_t[4]){200, 120, 60, 255}, 20);
    m->metallic_roughness_texture = add_texture(&s, 2, 2, (const uint8_t[4]){0, 180, 40, 255}, 30);
    m->normal_texture = add_texture(&s, 2, 1, (const uint8_t[4]){150, 128, 240, 255}, -30);
    m->occlusion_texture = add_texture(&s, 2, 2, (const uint8_t[4]){160, 0, 0, 255}, 25);
    m->emissive_texture = add_texture(&s, 1, 2, (const uint8_t[4]){40, 20, 10, 255}, 10);
    m->emission[0] = m->emission[1] = m->emission[2] = 0.05f;
    /* alpha-masked screens: a checker of holes (the masked variant defers their alpha tests,
     * and a ray through a hole of one meets the other: trace.glsl's passes) */
    uint32_t screen = add_material(&s, 0.7f, 0, 0.8f, 1);
    rd_texture checker = {.width = 4,
                          .height = 4,
                          .wrap_s = RD_WRAP_REPEAT,
                          .wrap_t = RD_WRAP_REPEAT,
                          .nearest = true};
    checker.rgba = malloc(64);
    for (int k = 0; k < 16; k++) {
        memcpy(&checker.rgba[k * 4], (const uint8_t[3]){180, 200, 220}, 3);
        checker.rgba[k * 4 + 3] = ((k & 1) ^ ((k >> 2) & 1)) ? 255 : 0;
    }
    s.materials[screen].base_color_texture = (int32_t)rd_scene_add_texture(&s, &checker);
    s.materials[screen].alpha_mode = RD_ALPHA_MASK;
    s.materials[screen].alpha_cutoff = 0.5f;
    rd_tri_list t = {0};
    const float lo[3] = {-1, 0, -1}, hi[3] = {1, 2, 1};
    rd_tris_room(&t, lo, hi, mat);
    /* a partition with a doorway gap, across the middle probe layer's cage edges */
    const float w_lo[3] = {0.28f, 0, -1}, w_hi[3] = {0.32f, 2, 0.3f};
    rd_tris_box(&t, w_lo, w_hi, mat);
    const float s_lo[3] = {-0.9f, 0.2f, -0.31f}, s_hi[3] = {0.2f, 1.6f, -0.3f};
    const float s2_lo[3] = {-0.9f, 0.3f, -0.61f}, s2_hi[3] = {0.25f, 1.5f, -0.6f};
    rd_tris_box(&t, s_lo, s_hi, screen);
    rd_tris_box(&t, s2_lo, s2_hi, screen);
    rd_tris_commit(&t, &s, "room");
    rd_mesh *mesh = &s.meshes[0];
    for (uint32_t i = 0; i < mesh->tri_count * 3; i++) {
        const float *p = &mesh->positions[i * 3];
        mesh->uvs[i * 2] = 0.7f * p[0] + 0.3f * p[2];
        mesh->uvs[i * 2 + 1] = 0.5f * p[1] + 0.4f * p[2];
    }
    rd_build_point_light(&s, -0.5f, 1.6f, 0.2f, 20.0f);
    const float negz[3] = {0, 0, -1}, up[3] = {0, 1, 0};
    rd_view_camera cam = look(0.5f, 1, 0.95f, negz, up, 90);
    bool was = vk.masked_lanes;
    float *img[2];
    for (int k = 0; k < 2; k++) {
        vk.masked_lanes = k == 0;
        img[k] = render_gi(&s, &cam, 0, 0, true);
    }
    vk.masked_lanes = was;
    if (img[0] && img[1]) {
        int differ = 0;
        double mean = 0;
        for (int i = 0; i < W * H * 3; i++) {
            differ += img[0][i] != img[1][i];
            mean += img[0][i] / (W * H * 3);
        }
        printf("masked lanes against inlined call sites: %d of %d channels differ (mean %.4f)\n",
               differ, W * H * 3, mean);
        CHECKF(differ == 0, "%d channels differ between the two shader forms", differ);
        CHECKF(mean > 0.01, "the textured room is dark (%g)", mean);
    }
    free(img[0]);
    free(img[1]);
    rd_scene_destroy(&s);
}

int main(void)
{
    if (!test_vk_open(&vk)) return test_finish();
    test_direct_brdf(1.0f, 0.5f);
    test_direct_brdf(0.0f, 0.3f);
    test_direct_brdf(0.5f, 0.8f);
    test_metal_differs();
    test_furnace("white Lambertian", 0, 1, 0, 0.999, 1.001);
    test_furnace("white metal roughness 1", 1, 1, 1, 0.31, 0.40);
    test_furnace("white metal roughness 0.1", 1, 0.1f, 1, 0.93, 1.01);
    test_furnace("white glTF dielectric roughness 0.5", 0, 0.5f, 1, 0.85, 1.01);
    test_normal_map(0, 0);
    test_normal_map(1, 0);
    test_normal_map(1, 1);
    test_normal_map(1, -1);
    test_indirect_diffuse();
    test_masked_lanes();
    return test_vk_close(&vk);
}
