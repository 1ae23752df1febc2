/* test_gpu_shadow_maps.c: the lights' distance maps that probe hits read for visibility
 * (renderer/gi/shadow_maps.h, shaders/shadow_map.glsl).
 *
 * 1. Against geometry: builtin:shadow's layout (a floor, a 0.5 x 0.2 x 0.5 m box above it, a
 *    point light above the box), the box its own instance, plus a slanted sun. For floor points on
 * a grid, the map's visibility of each light must match the analytic answer (a slab test of the
 * segment toward the light against the box, in C, sharing nothing with the GPU code) wherever the
 * answer is the same for every point within MARGIN (two map texels or more); the shadow ray must
 * match everywhere.
 * 2. What is built when: a new scene whose updates shade few hits traces shadow rays first
 *    (rent before buy); built maps stay: an update of an unchanged scene builds nothing (rays
 *    only for the few hits whose texels straddle a shadow edge); a colour change builds nothing.
 * 3. The pay rule, per light: while a light moves every update and an update shades far fewer
 *    hits than its map has texels, hits that chose it trace shadow rays instead of rebuilding
 *    (the sun keeps its map); once the light stays still long enough for the rebuild to pay,
 *    its map alone is rebuilt and matches the moved light's analytic shadow. In rebuild mode a
 *    moved light is re-mapped at once. An instance update that moves nothing stales nothing.
 * 4. --probe-shadows rays: no maps (and no memory for them); hits trace shadow rays.
 * 5. A moved object: the maps re-trace only the texels whose rays cross its old or new box,
 *    and then show its new shadow (checked against the moved box, analytically); moved out of
 *    the suns' frame, it makes every map stale.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/accel/bvh.h"
#include "renderer/scene/mesh_builder.h"
#include "renderer/world.h"
#include "shaders/test_shadow_map.spv.h"
#include "test_render_util.h"
#include "test_util.h"

enum { GRID = 64, POINTS = GRID * GRID };
static const float BOX_LO[3] = {-0.25f, 0.9f, -0.25f}, BOX_HI[3] = {0.25f, 1.1f, 0.25f};
static float box_shift[3]; /* where the box's node has moved it */
#define HALF 1.6f          /* floor points cover [-HALF, HALF]^2 */
#define MARGIN 0.09f /* point light: 2 texels at 2.4 m are 0.075 m; sun (r = 7.1 m): 0.028 m */

static char err[512];

/* Does the segment from p toward the light (dir unit, length len) cross the box? */
static bool box_blocks(const float p[3], const float dir[3], float len)
{
    float t0 = 1e-4f, t1 = len;
    for (int k = 0; k < 3; k++) {
        float lo = BOX_LO[k] + box_shift[k], hi = BOX_HI[k] + box_shift[k];
        if (fabsf(dir[k]) < 1e-12f) {
            if (p[k] < lo || p[k] > hi) return false;
            continue;
        }
        float a = (lo - p[k]) / dir[k], b = (hi - p[k]) / dir[k];
        if (a > b) {
            float t = a;
            a = b;
            b = t;
        }
        t0 = fmaxf(t0, a);
        t1 = fminf(t1, b);
    }
    return t0 <= t1;
}

/* Analytic visibility of light l from floor point (x, 0, z): 1 lit, 0 shadowed. */
static int analytic(const rd_light *l, float x, float z)
{
    float p[3] = {x, 0, z}, dir[3], len;
    if (l->type == RD_LIGHT_DIRECTIONAL) {
        for (int k = 0; k < 3; k++)
            dir[k] = -l->direction[k];
        len = 1e30f;
    } else {
        float d2 = 0;
        for (int k = 0; k < 3; k++) {
            dir[k] = l->position[k] - p[k];
            d2 += dir[k] * dir[k];
        }
        len = sqrtf(d2);
        for (int k = 0; k < 3; k++)
            dir[k] /= len;
    }
    return box_blocks(p, dir, len) ? 0 : 1;
}

/* The same answer everywhere within MARGIN of (x, z)? */
static bool clear_of_edges(const rd_light *l, float x, float z)
{
    int v = analytic(l, x, z);
    for (int i = -2; i <= 2; i++)
        for (int j = -2; j <= 2; j++)
            if (analytic(l, x + MARGIN * (float)i / 2, z + MARGIN * (float)j / 2) != v)
                return false;
    return true;
}

typedef struct harness {
    rd_vk *vk;
    rd_pipeline pipe;
    rd_buffer points, out;
    float *res;
} harness;

/* Compares map and ray visibility of light `index` over the floor grid with the analytic
 * answer; returns false (after failing checks) on a mismatch. */
static bool check_light(harness *h, rd_world *w, const rd_scene *s, uint32_t index,
                        const char *what)
{
    rd_cmd c;
    if (rd_cmd_begin(h->vk, &c, err, sizeof err) != RD_VK_OK) return false;
    pc_push push = {.globals = w->globals.address,
                    .buf0 = h->points.address,
                    .buf1 = h->out.address,
                    .params = {POINTS, index, 0, 0}};
    rd_cmd_dispatch(&c, &h->pipe, &push, (POINTS + PC_WG_1D - 1) / PC_WG_1D, 1, 1);
    rd_cmd_barrier(&c);
    if (rd_cmd_submit_wait(h->vk, &c, err, sizeof err) != RD_VK_OK) return false;
    memcpy(h->res, h->out.mapped, POINTS * 4 * sizeof(float));
    const rd_light *l = &s->lights[index];
    int clear = 0, shadowed = 0, map_bad = 0, ray_bad = 0, unmapped = 0, agree = 0;
    int culled = 0, culled_lit = 0; /* the view's cull (shadow_map_hidden: no shadow ray) */
    for (int i = 0; i < POINTS; i++) {
        float x = -HALF + 2 * HALF * (float)(i % GRID) / (GRID - 1);
        float z = -HALF + 2 * HALF * (float)(i / GRID) / (GRID - 1);
        const float *r = h->res + 4 * i;
        int want = analytic(l, x, z);
        if (r[0] < 0) unmapped++;
        if (r[1] != (float)want && clear_of_edges(l, x, z)) ray_bad++;
        agree += (r[0] >= 0.5f) == (want == 1);
        /* edges included: a cull there would darken a lit pixel for good */
        culled += r[3] == 1.0f;
        culled_lit += r[3] == 1.0f && want == 1;
        if (!clear_of_edges(l, x, z)) continue;
        clear++;
        shadowed += want == 0;
        if (fabsf(r[0] - (float)want) > 1e-6f) {
            if (map_bad < 5)
                fprintf(stderr, "%s, light %u at (%.3f, 0, %.3f): map %.3f, analytic %d\n", what,
                        index, x, z, r[0], want);
            map_bad++;
        }
    }
    printf("%s, light %u: %d of %d points clear of shadow edges (%d in shadow); map agrees "
           "with the analytic answer at %d of %d points; %d points culled\n",
           what, index, clear, POINTS, shadowed, agree, POINTS, culled);
    CHECKF(unmapped == 0, "%s, light %u: %d points without a map answer", what, index, unmapped);
    CHECKF(shadowed > 50 && clear - shadowed > 50, "%s, light %u: %d shadowed of %d", what, index,
           shadowed, clear);
    CHECKF(ray_bad == 0, "%s, light %u: the shadow ray is wrong at %d points", what, index,
           ray_bad);
    CHECKF(map_bad == 0, "%s, light %u: the map is wrong at %d points clear of edges", what, index,
           map_bad);
    CHECKF(agree >= POINTS * 98 / 100, "%s, light %u: the map agrees at only %d of %d points", what,
           index, agree, POINTS);
    /* camera pixels and reflection hits skip the shadow ray where the map shows the point
     * hidden (direct_radiance): that must never be a lit point, and must cull most of
     * the shadow */
    CHECKF(culled_lit == 0, "%s, light %u: %d lit points culled", what, index, culled_lit);
    CHECKF(culled > shadowed / 2, "%s, light %u: only %d of %d shadowed points culled", what, index,
           culled, shadowed);
    return map_bad == 0 && ray_bad == 0;
}

/* Opens builtin `scene` with a 4x4x4 field converged by its own measure, and checks that every
 * light then has its map. False (the rig closed) when that failed. */
static bool open_mapped_rig(rd_vk *vk, const char *scene, test_rig *rig)
{
    if (!test_rig_open(vk, scene, rig)) return false;
    rd_renderer *r = &rig->r;
    const rd_ddgi_settings gi = {.mode = PC_GI_DDGI, .counts = {4, 4, 4}, .rays = 64, .seed = 1};
    unsigned done = 0;
    VK_CHECK(
        rd_renderer_configure_gi(r, rig->s.bounds_min, rig->s.bounds_max, &gi, err, sizeof err));
    rd_world_set_scene(&r->world, &rig->gs);
    VK_CHECK(rd_world_converge(&r->world, RD_WORLD_CONVERGE_CAP, &done, err, sizeof err));
    unsigned lights = rig->s.light_count, mapped = rd_shadow_maps_valid(&r->world.shadow_maps);
    CHECKF(mapped == lights, "%s: after %u updates %u of %u lights have maps", scene, done, mapped,
           lights);
    if (mapped == lights) return true;
done:
    test_rig_close(vk, rig);
    return false;
}

/* 5. View frames: camera pixels cull their shadow rays by the maps (direct_radiance).
 * On the many-lights Cornell box (four lights, the blocks' shadows) a converged field has every
 * light's map; a frame with the cull must equal one without it exactly (a culled light is one
 * whose shadow ray would have been blocked) and trace fewer shadow rays. */
static void check_view_cull(rd_vk *vk)
{
    test_rig rig;
    if (!open_mapped_rig(vk, "hard:many-lights", &rig)) return;
    rd_renderer *r = &rig.r;
    enum { W = 48, H = 36 };
    float *img[2] = {malloc(W * H * 3 * sizeof(float)), malloc(W * H * 3 * sizeof(float))};
    unsigned shadow_rays[2] = {0, 0};
    for (int k = 0; k < 2; k++) {
        rd_frame_settings fs = {.width = W,
                                .height = H,
                                .seed = 1,
                                .near_field = PC_NEAR_OFF,
                                .reflections = PC_REFLECT_OFF,
                                .shadow_cull = k ? PC_SHADOW_CULL_OFF : PC_SHADOW_CULL_MAPS};
        VK_CHECK(rd_renderer_render(r, &rig.gs, &rig.cam, &fs, err, sizeof err));
        shadow_rays[k] = r->stats.rays.shadow_rays;
        VK_CHECK(rd_renderer_read_hdr(r, img[k], err, sizeof err));
    }
    int differ = 0;
    for (int i = 0; i < W * H * 3; i++)
        differ += img[0][i] != img[1][i];
    printf("view frame %dx%d: %u shadow rays with the cull, %u without; %d values differ\n", W, H,
           shadow_rays[0], shadow_rays[1], differ);
    CHECKF(differ == 0, "the cull changed %d values of the image", differ);
    CHECKF(shadow_rays[0] > 0 && shadow_rays[0] < shadow_rays[1] * 9 / 10,
           "the cull traced %u shadow rays, %u without it", shadow_rays[0], shadow_rays[1]);
done:
    free(img[0]);
    free(img[1]);
    test_rig_close(vk, &rig);
}

/* 6. Reflection hits read every light's visibility from its map where the map's texels agree
 * (direct_radiance, DIRECT_MAP_VISIBILITY), with a shadow ray elsewhere; --shadow-cull off
 * traces every ray. On the many-lights Cornell box with metallic 0.5, roughness 0.5 walls
 * (reflection rays everywhere), a converged field with every light's map: the maps spare most of the reflection
 * pass's shadow rays, and the image after FRAMES frames (each a reflection ray a pixel, averaged
 * by the view's history; another shadow cull starts another history) is the one exact rays give,
 * within the rays' sampling noise (this size, lavapipe: another seed of the same frames moves
 * the mean 0.3% with relMSE 0.0013; the maps against every ray: +0.10%, 0.0012). The scene's
 * reflections carry little shadow: a map lookup that took every hidden answer as lit moved the
 * mean only +0.55% (relMSE 0.0023), within these bounds; the lookup itself is checked point by
 * point above (parts 1-4), and the ray count shows that reflection hits read it. */
static void check_reflection_maps(rd_vk *vk)
{
    test_rig rig;
    if (!open_mapped_rig(vk, "hard:many-lights+metal", &rig)) return;
    rd_renderer *r = &rig.r;
    enum { W = 48, H = 36, FRAMES = 64 };
    float *img[2] = {malloc(W * H * 3 * sizeof(float)), malloc(W * H * 3 * sizeof(float))};
    unsigned reflect_rays[2] = {0, 0};
    for (int k = 0; k < 2; k++) {
        rd_frame_settings fs = {.width = W,
                                .height = H,
                                .seed = 1,
                                .near_field = PC_NEAR_OFF,
                                .reflections = PC_REFLECT_AUTO,
                                .shadow_cull = k ? PC_SHADOW_CULL_OFF : PC_SHADOW_CULL_MAPS};
        for (int f = 0; f < FRAMES; f++) {
            VK_CHECK(rd_renderer_render(r, &rig.gs, &rig.cam, &fs, err, sizeof err));
            reflect_rays[k] += r->stats.rays.reflect_rays;
        }
        VK_CHECK(rd_renderer_read_hdr(r, img[k], err, sizeof err));
    }
    double sum[2] = {0, 0}, rel = 0;
    for (int i = 0; i < W * H * 3; i++) {
        double d = img[0][i] - img[1][i];
        rel += d * d / ((double)img[1][i] * img[1][i] + 0.01);
        sum[0] += img[0][i];
        sum[1] += img[1][i];
    }
    rel /= W * H * 3;
    printf("reflections %dx%d, %d frames: %u rays in the reflection pass with the maps, %u with "
           "every shadow ray; mean %+.3f%%, relMSE %.2g\n",
           W, H, FRAMES, reflect_rays[0], reflect_rays[1], 100 * (sum[0] / sum[1] - 1), rel);
    CHECKF(fabs(sum[0] / sum[1] - 1) < 0.01, "the maps moved the mean by %+.3f%%",
           100 * (sum[0] / sum[1] - 1));
    CHECKF(rel < 0.004, "the maps changed the image: relMSE %g", rel);
    /* per hit: the reflection ray and up to four shadow rays without the maps */
    CHECKF(reflect_rays[0] > 0 && reflect_rays[0] < reflect_rays[1] * 2 / 3,
           "the reflection pass traced %u rays with the maps, %u without", reflect_rays[0],
           reflect_rays[1]);
done:
    free(img[0]);
    free(img[1]);
    test_rig_close(vk, &rig);
}

int main(void)
{
    rd_vk vk;
    if (!test_vk_open(&vk)) return test_finish();
    /* builtin:shadow's floor, box and point light, with the box its own instance (it moves in
     * part 5), and a slanted sun */
    rd_scene s;
    rd_scene_init(&s);
    rd_tri_list t = {0};
    uint32_t grey = rd_build_material(&s, "grey", 0.5f, 0.5f, 0.5f, 0, 0, 0);
    const float f0[3] = {-5, 0, -5}, f1[3] = {-5, 0, 5}, f2[3] = {5, 0, 5}, f3[3] = {5, 0, -5};
    rd_tris_quad(&t, f0, f1, f2, f3, grey);
    rd_tris_commit(&t, &s, "floor");
    rd_tris_box(&t, BOX_LO, BOX_HI, grey);
    uint32_t box = rd_tris_commit(&t, &s, "box");
    rd_build_point_light(&s, 0, 2, 0, 100);
    float a = 35.0f * (float)M_PI / 180.0f;
    const float sun_dir[3] = {sinf(a) * 0.8f, -cosf(a), sinf(a) * 0.6f}, white[3] = {1, 1, 1};
    rd_build_sun(&s, sun_dir, white, 2.0f);
    CHECKF(rd_scene_update(&s, err, sizeof err), "%s", err);
    CHECK(s.light_count == 2 && s.lights[0].type == RD_LIGHT_POINT && s.instance_count == 2);

    rd_gpu_scene gs = {0};
    rd_world w = {0};
    harness h = {.vk = &vk, .res = malloc(POINTS * 4 * sizeof(float))};
    float *pts = calloc(POINTS * 8, sizeof(float));
    VK_CHECK(rd_gpu_scene_create(&vk, &gs, &s, err, sizeof err));
    VK_CHECK(rd_world_create(&vk, &w, err, sizeof err));
    rd_world_set_scene(&w, &gs);
    rd_ddgi_settings gi = {.mode = PC_GI_DDGI, .counts = {3, 3, 3}, .rays = 64, .seed = 1};
    VK_CHECK(rd_world_configure_gi(&w, s.bounds_min, s.bounds_max, &gi, err, sizeof err));
    VK_CHECK(rd_pipeline_create(&vk, &h.pipe, "test_shadow_map", pc_spv_test_shadow_map,
                                sizeof pc_spv_test_shadow_map, sizeof(pc_push), err, sizeof err));
    for (int i = 0; i < POINTS; i++) { /* floor points, in the GPU frame */
        float *p = pts + 8 * i;
        p[0] = -HALF + 2 * HALF * (float)(i % GRID) / (GRID - 1) - gs.origin_shift[0];
        p[1] = 0 - gs.origin_shift[1];
        p[2] = -HALF + 2 * HALF * (float)(i / GRID) / (GRID - 1) - gs.origin_shift[2];
        p[5] = 1; /* normal +y */
        /* the ray offset surface_at gives a floor point (ray_offset_scale: its vertices, within
         * the scene's bounds, plus the point) */
        float scale = 0;
        for (int k = 0; k < 3; k++)
            scale = fmaxf(scale, fmaxf(fabsf(s.bounds_min[k] - gs.origin_shift[k]),
                                       fabsf(s.bounds_max[k] - gs.origin_shift[k])));
        p[7] = rd_ray_offset_distance(2 * scale);
    }
    VK_CHECK(rd_buffer_create(&vk, &h.points, POINTS * 8 * sizeof(float), RD_MEMORY_DEVICE, err,
                              sizeof err));
    VK_CHECK(rd_buffer_upload(&vk, &h.points, 0, pts, POINTS * 8 * sizeof(float), err, sizeof err));
    VK_CHECK(rd_buffer_create(&vk, &h.out, POINTS * 4 * sizeof(float), RD_MEMORY_READBACK, err,
                              sizeof err));

    /* 1. maps for both lights (forced: with 1728 hits per update a new scene rents rays for
     * hundreds of updates first), and they match the geometry */
    const uint64_t map_rays = 6ull * PC_SHADOW_MAP_SIDE * PC_SHADOW_MAP_SIDE +
                              (uint64_t)PC_SHADOW_MAP_SUN_SIDE * PC_SHADOW_MAP_SUN_SIDE;
    VK_CHECK(rd_world_update(&w, 1, err, sizeof err));
    CHECKF(w.shadow_maps.builds == 0 && w.stats.rays.probe_shadow_rays > 0,
           "a new scene with %u hits built %llu maps of %llu texels at once",
           rd_ddgi_probe_count(&w.ddgi) * gi.rays, (unsigned long long)w.shadow_maps.builds,
           (unsigned long long)map_rays);
    w.shadow_maps.mode = RD_PROBE_SHADOWS_REBUILD; /* rather than 660 updates of rent */
    VK_CHECK(rd_world_update(&w, 1, err, sizeof err));
    w.shadow_maps.mode = RD_PROBE_SHADOWS_MAPS;
    CHECKF(w.shadow_maps.builds == 1 && w.ddgi.vol.control.w == 2 && w.shadow_maps.complete,
           "builds %llu, mapped %u", (unsigned long long)w.shadow_maps.builds,
           w.ddgi.vol.control.w);
    CHECKF(w.stats.rays.shadow_map_rays == map_rays, "%u map rays, want %llu",
           w.stats.rays.shadow_map_rays, (unsigned long long)map_rays);
    /* with every light mapped, rays only for the few hits whose texels straddle a shadow edge */
    const unsigned edge_max = rd_ddgi_probe_count(&w.ddgi) * gi.rays / 20;
    CHECKF(w.stats.rays.probe_shadow_rays <= edge_max,
           "%u probe shadow rays with every light mapped (at most %u)",
           w.stats.rays.probe_shadow_rays, edge_max);
    CHECK(!w.ddgi.sort_hits);
    check_light(&h, &w, &s, 0, "point light");
    check_light(&h, &w, &s, 1, "sun");

    /* 2. an unchanged scene, and a colour change, build nothing; a moved light is re-mapped */
    VK_CHECK(rd_world_update(&w, 2, err, sizeof err));
    CHECKF(w.shadow_maps.builds == 1 && w.stats.rays.shadow_map_rays == 0,
           "static scene: builds %llu, %u map rays", (unsigned long long)w.shadow_maps.builds,
           w.stats.rays.shadow_map_rays);
    s.lights[0].color[1] = 0.5f;
    VK_CHECK(rd_gpu_scene_update_lights(&vk, &gs, &s, err, sizeof err));
    VK_CHECK(rd_world_update(&w, 1, err, sizeof err));
    CHECKF(w.shadow_maps.builds == 1, "a colour change rebuilt the maps");

    /* 3. a light that moves every update, few hits: its hits trace shadow rays while the sun
     * keeps its map; then still long enough: its map alone is rebuilt */
    const uint64_t point_rays = 6ull * PC_SHADOW_MAP_SIDE * PC_SHADOW_MAP_SIDE;
    s.lights[0].position[0] = 0.6f;
    s.lights[0].position[1] = 1.7f;
    for (int k = 0; k < 3; k++) {
        s.lights[0].position[2] = 0.05f * (float)(k + 1);
        VK_CHECK(rd_gpu_scene_update_lights(&vk, &gs, &s, err, sizeof err));
        VK_CHECK(rd_world_update(&w, 1, err, sizeof err));
    }
    uint64_t hits = (uint64_t)rd_ddgi_probe_count(&w.ddgi) * gi.rays;
    CHECKF(w.shadow_maps.builds == 1 && w.shadow_maps.table[0] == 0 &&
               w.shadow_maps.table[1] != 0 && w.ddgi.sort_hits &&
               w.stats.rays.probe_shadow_rays > 0,
           "moving every update with %llu hits against %llu map texels: builds %llu, offsets "
           "%u %u, %u shadow rays",
           (unsigned long long)hits, (unsigned long long)point_rays,
           (unsigned long long)w.shadow_maps.builds, w.shadow_maps.table[0], w.shadow_maps.table[1],
           w.stats.rays.probe_shadow_rays);
    check_light(&h, &w, &s, 1, "sun beside a moving light");
    unsigned still = 0;
    unsigned rebuilt_rays = 0;
    while (w.shadow_maps.builds == 1 && still < 1000) {
        VK_CHECK(rd_world_update(&w, 1, err, sizeof err));
        rebuilt_rays = w.stats.rays.shadow_map_rays;
        still++;
    }
    printf("maps rebuilt after %u still updates (%llu hits each at most, %llu map texels)\n", still,
           (unsigned long long)hits, (unsigned long long)point_rays);
    CHECKF(w.shadow_maps.builds == 2 && still + 1 >= point_rays / hits &&
               rebuilt_rays == point_rays && w.shadow_maps.complete && !w.ddgi.sort_hits,
           "still scene: builds %llu after %u updates, %u rays",
           (unsigned long long)w.shadow_maps.builds, still, rebuilt_rays);
    check_light(&h, &w, &s, 0, "moved point light");
    check_light(&h, &w, &s, 1, "sun");

    /* --probe-shadows rebuild: a moved light is re-mapped at the next update */
    w.shadow_maps.mode = RD_PROBE_SHADOWS_REBUILD;
    s.lights[0].position[0] = -0.4f;
    VK_CHECK(rd_gpu_scene_update_lights(&vk, &gs, &s, err, sizeof err));
    VK_CHECK(rd_world_update(&w, 1, err, sizeof err));
    CHECKF(w.shadow_maps.builds == 3 && w.shadow_maps.complete, "rebuild mode: builds %llu",
           (unsigned long long)w.shadow_maps.builds);
    check_light(&h, &w, &s, 0, "point light moved again");

    /* an instance update that moves nothing stales nothing */
    w.shadow_maps.mode = RD_PROBE_SHADOWS_MAPS;
    uint64_t builds = w.shadow_maps.builds;
    VK_CHECK(rd_gpu_scene_update_instances(&vk, &gs, &s, err, sizeof err));
    VK_CHECK(rd_world_update(&w, 1, err, sizeof err));
    CHECKF(w.shadow_maps.builds == builds && w.shadow_maps.complete &&
               w.stats.rays.probe_shadow_rays <= edge_max,
           "an update that moves nothing: builds %llu -> %llu, %u shadow rays",
           (unsigned long long)builds, (unsigned long long)w.shadow_maps.builds,
           w.stats.rays.probe_shadow_rays);

    /* 5. a moved box: after a whole rebuild, moving the box re-traces only the texels whose
     * rays cross its old or new box, and the maps show its new shadow */
    w.shadow_maps.mode = RD_PROBE_SHADOWS_REBUILD;
    VK_CHECK(rd_world_update(&w, 1, err, sizeof err));
    w.shadow_maps.mode = RD_PROBE_SHADOWS_MAPS;
    VK_CHECK(rd_world_update(&w, 40, err, sizeof err)); /* still: a rebuild will pay */
    uint64_t before = w.shadow_maps.builds;
    box_shift[0] = 0.4f;
    box_shift[2] = -0.2f;
    s.nodes[box].translation[0] = box_shift[0];
    s.nodes[box].translation[2] = box_shift[2];
    CHECKF(rd_scene_update(&s, err, sizeof err), "%s", err);
    VK_CHECK(rd_gpu_scene_update_instances(&vk, &gs, &s, err, sizeof err));
    VK_CHECK(rd_world_update(&w, 1, err, sizeof err));
    printf("moved box: %u of %llu map texels re-traced\n", w.stats.rays.shadow_map_rays,
           (unsigned long long)map_rays);
    CHECKF(w.shadow_maps.builds == before + 1 && w.shadow_maps.complete &&
               w.stats.rays.shadow_map_rays > 0 && w.stats.rays.shadow_map_rays < map_rays / 10,
           "moved box: builds %llu -> %llu, %u rays", (unsigned long long)before,
           (unsigned long long)w.shadow_maps.builds, w.stats.rays.shadow_map_rays);
    check_light(&h, &w, &s, 0, "point light over the moved box");
    check_light(&h, &w, &s, 1, "sun over the moved box");

    /* a box moved out of the suns' frame (the scene's bounding sphere): every map is stale,
     * and with few hits their lights trace shadow rays */
    s.nodes[box].translation[1] = 40;
    CHECKF(rd_scene_update(&s, err, sizeof err), "%s", err);
    VK_CHECK(rd_gpu_scene_update_instances(&vk, &gs, &s, err, sizeof err));
    VK_CHECK(rd_world_update(&w, 1, err, sizeof err));
    CHECKF(w.shadow_maps.table[0] == 0 && w.shadow_maps.table[1] == 0 && w.ddgi.sort_hits &&
               w.stats.rays.probe_shadow_rays > 0 && w.stats.rays.shadow_map_rays == 0,
           "box out of the frame: offsets %u %u, %u map rays", w.shadow_maps.table[0],
           w.shadow_maps.table[1], w.stats.rays.shadow_map_rays);

    /* 4. rays only: no maps and no memory for them */
    w.shadow_maps.mode = RD_PROBE_SHADOWS_RAYS;
    VK_CHECK(rd_world_update(&w, 1, err, sizeof err));
    CHECKF(w.shadow_maps.maps.buffer == VK_NULL_HANDLE && w.ddgi.vol.control.w == 0 &&
               w.stats.rays.probe_shadow_rays > 0 && w.stats.rays.shadow_map_rays == 0,
           "rays mode: maps kept or no shadow rays (%u)", w.stats.rays.probe_shadow_rays);

    check_view_cull(&vk);
    check_reflection_maps(&vk);

done:
    rd_buffer_destroy(&vk, &h.points);
    rd_buffer_destroy(&vk, &h.out);
    rd_pipeline_destroy(&vk, &h.pipe);
    rd_world_destroy(&w);
    rd_gpu_scene_destroy(&vk, &gs);
    rd_scene_destroy(&s);
    free(pts);
    free(h.res);
    return test_vk_close(&vk);
}
