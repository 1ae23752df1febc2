/* GPU calibration of the direct-lighting renderer on lavapipe (validation layer on):
 * radiometry against analytic values (point light over a plane, directional light),
 * emission seen directly, hard shadows, and a clean validation log. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/builtin/procedural.h"
#include "test_render_util.h"
#include "test_util.h"

#define W 48
#define H 32

static rd_vk vk;

/* Renders builtin scene `name` with direct light only; returns linear RGB (caller frees). */
static float *render(const char *name, pc_view *view_out)
{
    test_render_desc d = {.scene = name, .width = W, .height = H};
    rd_frame_stats st;
    float *rgb = test_render(&vk, &d, view_out, &st);
    if (rgb) CHECK(st.rays.primary_rays == W * H);
    return rgb;
}

static void pixel_ray(const pc_view *v, int x, int y, double d[3])
{
    double nx = 2.0 * (x + 0.5) / W - 1.0, ny = 1.0 - 2.0 * (y + 0.5) / H;
    d[0] = v->forward.x + nx * v->right.x + ny * v->up.x;
    d[1] = v->forward.y + nx * v->right.y + ny * v->up.y;
    d[2] = v->forward.z + nx * v->right.z + ny * v->up.z;
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; k++) d[k] /= len;
}

/* Does the segment a->b pass through the axis-aligned box? (slab test) */
static int segment_hits_box(const double a[3], const double b[3], const double lo[3],
                            const double hi[3])
{
    double t0 = 0, t1 = 1;
    for (int k = 0; k < 3; k++) {
        double d = b[k] - a[k];
        if (fabs(d) < 1e-12) {
            if (a[k] < lo[k] || a[k] > hi[k]) return 0;
            continue;
        }
        double ta = (lo[k] - a[k]) / d, tb = (hi[k] - a[k]) / d;
        if (ta > tb) { double t = ta; ta = tb; tb = t; }
        if (ta > t0) t0 = ta;
        if (tb < t1) t1 = tb;
    }
    return t0 <= t1;
}

/* Point light of 100 cd at (0,2,0) over a plane of albedo 0.5 (optionally with the
 * occluder box of the "shadow" scene): every pixel that sees the plane must carry
 * rho/pi * I * cos / r^2 within 1%, or exactly 0 when the box blocks the light. */
static void test_point_light(const char *name, int occluder)
{
    pc_view v;
    float *img = render(name, &v);
    if (!img) return;
    const double eye[3] = {v.eye.x, v.eye.y, v.eye.z}, light[3] = {0, 2, 0};
    const double lo[3] = {-0.25, 0.9, -0.25}, hi[3] = {0.25, 1.1, 0.25};
    int checked = 0, shadowed = 0, bad = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double d[3];
            pixel_ray(&v, x, y, d);
            double t = -eye[1] / d[1];
            double p[3] = {eye[0] + t * d[0], 0, eye[2] + t * d[2]};
            if (fabs(p[0]) > 4.9 || fabs(p[2]) > 4.9) continue;
            if (occluder && segment_hits_box(eye, p, lo, hi)) continue; /* sees the box */
            double l[3] = {light[0] - p[0], light[1] - p[1], light[2] - p[2]};
            double r2 = l[0] * l[0] + l[1] * l[1] + l[2] * l[2];
            double expect = 0.5 / M_PI * 100.0 * (l[1] / sqrt(r2)) / r2;
            int blocked = occluder && segment_hits_box(p, light, lo, hi);
            const float *px = &img[(y * W + x) * 3];
            checked++;
            if (blocked) {
                shadowed++;
                if (px[0] != 0 || px[1] != 0 || px[2] != 0) bad++;
            } else if (!test_close_rel(px[0], expect, 0.01) || !test_close_rel(px[1], expect, 0.01) ||
                       !test_close_rel(px[2], expect, 0.01)) {
                if (bad++ < 5)
                    fprintf(stderr, "%s pixel %d,%d: %g, expected %g\n", name, x, y, px[0], expect);
            }
        }
    CHECKF(bad == 0, "%s: %d of %d pixels off", name, bad, checked);
    CHECK(checked > W * H / 2);
    if (occluder) CHECKF(shadowed > 10, "only %d shadowed pixels", shadowed);
    free(img);
}

static void test_directional(void)
{
    pc_view v;
    float *img = render("plane-directional", &v);
    if (!img) return;
    double expect = 0.5 / M_PI * 3.0 * cos(60.0 * M_PI / 180.0);
    int bad = 0;
    for (int i = 0; i < W * H * 3; i++)
        if (!test_close_rel(img[i], expect, 0.01)) bad++;
    CHECKF(bad == 0, "%d channels differ from %g (e.g. %g)", bad, expect, img[0]);
    free(img);
}

static void test_emissive(void)
{
    pc_view v;
    float *img = render("emissive", &v);
    if (!img) return;
    /* The quad spans +-1 at distance 3 with a 30 degree field of view: it covers the view
     * vertically (tan 15 deg * 3 = 0.80 < 1). Horizontally the centre columns see it. */
    const float expect[3] = {2.0f, 1.0f, 0.5f};
    int bad = 0;
    for (int y = 0; y < H; y++)
        for (int x = W / 4; x < 3 * W / 4; x++)
            for (int c = 0; c < 3; c++)
                if (img[(y * W + x) * 3 + c] != expect[c]) bad++;
    CHECKF(bad == 0, "%d emissive channels differ", bad);
    free(img);
}

/* Textures are sampled on the GPU: an emissive quad whose emissive texture is 2x2 texels
 * (nearest filtering) shows each texel's sRGB-decoded colour times the factor, in the right
 * quadrant; with repeat wrapping and UVs 0..2 the pattern tiles twice. */
static void test_texture(void)
{
    char err[512];
    rd_scene s;
    CHECK(rd_procedural_build("emissive", &s, err, sizeof err));
    rd_texture t = {.width = 2, .height = 2, .wrap_s = RD_WRAP_REPEAT, .wrap_t = RD_WRAP_REPEAT,
                    .nearest = true};
    const uint8_t texels[16] = {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 188, 188, 188, 255};
    t.rgba = malloc(16);
    memcpy(t.rgba, texels, 16);
    uint32_t tex = rd_scene_add_texture(&s, &t);
    rd_material *m = &s.materials[s.meshes[0].material[0]];
    m->emissive_texture = (int32_t)tex;
    m->emission[0] = m->emission[1] = m->emission[2] = 1.0f;
    /* the quad (-1,-1)..(1,1) at z = 0: u along x, v downward, from 0 to 2 */
    rd_mesh *mesh = &s.meshes[0];
    for (uint32_t i = 0; i < mesh->tri_count * 3; i++) {
        const float *p = &mesh->positions[i * 3];
        mesh->uvs[i * 2] = p[0] + 1.0f;
        mesh->uvs[i * 2 + 1] = 1.0f - p[1];
    }
    CHECK(rd_scene_update(&s, err, sizeof err));
    rd_view_camera cam;
    CHECK(rd_camera_for_scene(&s, -1, &cam, err, sizeof err));
    cam.eye[2] = 1.0f; /* close enough that the quad fills the view */
    rd_gpu_scene gs;
    rd_renderer r;
    float *img = calloc((size_t)W * H * 3, sizeof(float));
    rd_frame_settings fs = {.width = W, .height = H};
    CHECK(rd_gpu_scene_create(&vk, &gs, &s, err, sizeof err) == RD_VK_OK);
    CHECK(rd_renderer_create(&vk, &r, err, sizeof err) == RD_VK_OK);
    CHECK(rd_renderer_render(&r, &gs, &cam, &fs, err, sizeof err) == RD_VK_OK);
    CHECK(rd_renderer_read_hdr(&r, img, err, sizeof err) == RD_VK_OK);
    pc_view v;
    rd_camera_to_view(&cam, W, H, &v);
    double grey = pow((188 / 255.0 + 0.055) / 1.055, 2.4); /* sRGB decode */
    const double expect[4][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {grey, grey, grey}};
    int bad = 0, checked = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double d[3];
            pixel_ray(&v, x, y, d);
            double t = -cam.eye[2] / d[2];
            double px = cam.eye[0] + t * d[0], py = cam.eye[1] + t * d[1];
            double u = px + 1, vv = 1 - py; /* texel coordinates: fraction * 2 texels */
            double fu = (u - floor(u)) * 2, fv = (vv - floor(vv)) * 2;
            if (fabs(px) > 0.98 || fabs(py) > 0.98 || fabs(fu - 1) < 0.05 || fabs(fv - 1) < 0.05 ||
                fu < 0.05 || fv < 0.05 || fu > 1.95 || fv > 1.95)
                continue; /* stay away from texel edges */
            int texel = (fv >= 1) * 2 + (fu >= 1);
            const float *p = &img[(y * W + x) * 3];
            checked++;
            for (int c = 0; c < 3; c++)
                if (fabs(p[c] - expect[texel][c]) > 1e-3) bad++;
        }
    CHECKF(checked > W * H / 4, "only %d pixels checked", checked);
    CHECKF(bad == 0, "%d texture channels differ", bad);
    free(img);
    rd_renderer_destroy(&r);
    rd_gpu_scene_destroy(&vk, &gs);
    rd_scene_destroy(&s);
}

int main(void)
{
    if (!test_vk_open(&vk)) return test_finish();
    test_point_light("plane-point", 0);
    test_point_light("shadow", 1);
    test_directional();
    test_emissive();
    test_texture();
    return test_vk_close(&vk);
}
