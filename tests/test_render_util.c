#include "test_render_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/builtin/procedural.h"
#include "renderer/gltf/gltf_loader.h"
#include "test_util.h"

bool test_vk_open(rd_vk *vk)
{
    char err[512] = "";
    rd_vk_options opt = {0};
    rd_vk_result r = rd_vk_create(vk, &opt, err, sizeof err);
    CHECKF(r == RD_VK_OK, "%s", err);
    if (r == RD_VK_OK)
        printf("device: %s, validation %s\n", vk->device_name, vk->validation ? "on" : "off");
    return r == RD_VK_OK;
}

int test_vk_close(rd_vk *vk)
{
    CHECKF(rd_vk_validation_messages(vk) == 0, "%u validation messages",
           rd_vk_validation_messages(vk));
    rd_vk_destroy(vk);
    return test_finish();
}

bool test_rig_open(rd_vk *vk, const char *scene, test_rig *rig)
{
    char err[512] = "";
    memset(rig, 0, sizeof *rig);
    if (!rd_procedural_build(scene, &rig->s, err, sizeof err)) {
        CHECKF(0, "%s: %s", scene, err);
        return false;
    }
    bool ok = rd_camera_for_scene(&rig->s, -1, &rig->cam, err, sizeof err) &&
              rd_gpu_scene_create(vk, &rig->gs, &rig->s, err, sizeof err) == RD_VK_OK;
    if (ok && rd_renderer_create(vk, &rig->r, err, sizeof err) != RD_VK_OK) {
        rd_gpu_scene_destroy(vk, &rig->gs);
        ok = false;
    }
    CHECKF(ok, "%s: %s", scene, err);
    if (!ok) {
        rd_scene_destroy(&rig->s);
        return false;
    }
    rig->open = true;
    return true;
}

void test_rig_close(rd_vk *vk, test_rig *rig)
{
    if (!rig->open) return;
    rd_renderer_destroy(&rig->r);
    rd_gpu_scene_destroy(vk, &rig->gs);
    rd_scene_destroy(&rig->s);
    rig->open = false;
}

float *test_render(rd_vk *vk, const test_render_desc *d, pc_view *view_out,
                   rd_frame_stats *stats_out)
{
    char err[512] = "";
    rd_scene s;
    if (d->gltf) {
        if (rd_gltf_load_memory(d->gltf, strlen(d->gltf), NULL, NULL, &s, err, sizeof err) !=
            RD_GLTF_OK) {
            CHECKF(0, "glTF: %s", err);
            return NULL;
        }
    } else if (!rd_procedural_build(d->scene, &s, err, sizeof err)) {
        CHECKF(0, "%s", err);
        return NULL;
    }
    rd_view_camera cam;
    CHECK(rd_camera_for_scene(&s, d->camera > 0 ? d->camera : -1, &cam, err, sizeof err));
    rd_gpu_scene gs;
    rd_renderer r;
    float *rgb = calloc((size_t)d->width * d->height * 3, sizeof(float));
    rd_frame_settings fs = {.width = d->width,
                            .height = d->height,
                            .view = d->view,
                            .gi_updates = d->updates,
                            .pathtrace_spp = d->pathtrace_spp,
                            .max_bounces = d->max_bounces,
                            .seed = d->seed,
                            .reflections = d->reflections,
                            .near_field = d->near_field,
                            .sky = {d->sky[0], d->sky[1], d->sky[2]}};
    rd_vk_result res = rd_gpu_scene_create(vk, &gs, &s, err, sizeof err);
    CHECKF(res == RD_VK_OK, "%s", err);
    if (res == RD_VK_OK) res = rd_renderer_create(vk, &r, err, sizeof err);
    CHECKF(res == RD_VK_OK, "%s", err);
    if (res == RD_VK_OK)
        res = rd_renderer_configure_gi(&r, s.bounds_min, s.bounds_max, &d->gi, err, sizeof err);
    CHECKF(res == RD_VK_OK, "%s", err);
    if (res == RD_VK_OK && d->converge && r.world.gi) {
        unsigned done = 0;
        rd_world_set_scene(&r.world, &gs);
        res = rd_world_converge(&r.world, RD_WORLD_CONVERGE_CAP, &done, err, sizeof err);
        CHECKF(res == RD_VK_OK, "%s", err);
        CHECKF(rd_world_converged(&r.world), "%s: not converged after %u updates", d->scene, done);
        printf("%s: converged after %u probe updates\n", d->scene, done);
        if (d->converge_updates) *d->converge_updates = done;
    }
    for (unsigned f = 0; res == RD_VK_OK && f < (d->frames ? d->frames : 1); f++)
        res = rd_renderer_render(&r, &gs, &cam, &fs, err, sizeof err);
    CHECKF(res == RD_VK_OK, "%s", err);
    if (res == RD_VK_OK) res = rd_renderer_read_hdr(&r, rgb, err, sizeof err);
    CHECKF(res == RD_VK_OK, "%s", err);
    if (view_out) rd_camera_to_view(&cam, d->width, d->height, view_out);
    if (stats_out) *stats_out = r.stats;
    rd_renderer_destroy(&r);
    rd_gpu_scene_destroy(vk, &gs);
    rd_scene_destroy(&s);
    if (res != RD_VK_OK) {
        free(rgb);
        return NULL;
    }
    return rgb;
}

rd_material test_material(const float base[3], float metallic, float roughness, float specular)
{
    rd_material m = rd_material_default();
    m.name = "m";
    m.base_color[0] = base[0], m.base_color[1] = base[1], m.base_color[2] = base[2];
    m.metallic = metallic;
    m.roughness = roughness;
    m.specular = specular;
    return m;
}

void test_pixel_dir(const pc_view *v, unsigned width, unsigned height, int x, int y, double d[3])
{
    double nx = 2.0 * (x + 0.5) / width - 1.0, ny = 1.0 - 2.0 * (y + 0.5) / height;
    d[0] = v->forward.x + nx * v->right.x + ny * v->up.x;
    d[1] = v->forward.y + nx * v->right.y + ny * v->up.y;
    d[2] = v->forward.z + nx * v->right.z + ny * v->up.z;
    double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; k++)
        d[k] /= len;
}

double test_image_mean(const float *rgb, size_t floats, size_t *non_finite)
{
    double sum = 0;
    size_t bad = 0;
    for (size_t i = 0; i < floats; i++) {
        if (!isfinite(rgb[i]))
            bad++;
        else
            sum += rgb[i];
    }
    if (non_finite) *non_finite = bad;
    return floats ? sum / floats : 0;
}

/* ---- convergence of noisy fields -------------------------------------------------------- */

static double mean_luminance(rd_renderer *r, const rd_view_camera *cam, char *err, size_t errlen)
{
    enum { W = 16, H = 12 };
    rd_view_settings vs = {.width = W, .height = H, .seed = 1};
    float img[W * H * 3];
    if (rd_view_render(&r->view, &r->world, cam, &vs, err, errlen) != RD_VK_OK ||
        rd_view_read_hdr(&r->view, img, err, errlen) != RD_VK_OK) {
        CHECKF(false, "render: %s", err);
        return NAN;
    }
    double s = 0;
    for (int i = 0; i < W * H; i++)
        s += 0.2126 * img[3 * i] + 0.7152 * img[3 * i + 1] + 0.0722 * img[3 * i + 2];
    return s / (W * H);
}

unsigned test_converge_noisy(rd_vk *vk, const char *label, rd_scene *s, const unsigned counts[3],
                             unsigned more, double max_bias, double sd_factor, double *mean)
{
    char err[512] = "";
    rd_view_camera cam;
    CHECKF(rd_camera_for_scene(s, -1, &cam, err, sizeof err), "%s", err);
    rd_gpu_scene gs;
    rd_renderer r;
    memset(&gs, 0, sizeof gs);
    memset(&r, 0, sizeof r);
    rd_ddgi_settings gi = {
        .mode = PC_GI_DDGI, .counts = {counts[0], counts[1], counts[2]}, .rays = 64, .seed = 1};
    unsigned updates = 0, bound = rd_ddgi_sleep_bound(RD_DDGI_DEFAULT_HYSTERESIS);
    *mean = NAN;
    VK_CHECK(rd_gpu_scene_create(vk, &gs, s, err, sizeof err));
    VK_CHECK(rd_renderer_create(vk, &r, err, sizeof err));
    VK_CHECK(rd_renderer_configure_gi(&r, s->bounds_min, s->bounds_max, &gi, err, sizeof err));
    rd_world *w = &r.world;
    rd_world_set_scene(w, &gs);
    const float black[3] = {0, 0, 0};
    rd_world_set_sky(w, black);
    VK_CHECK(rd_world_converge(w, RD_WORLD_CONVERGE_CAP, &updates, err, sizeof err));
    const rd_ddgi_census *c = &w->ddgi.census;
    printf("%s: %u probes, asleep after %u updates (sleep age %g, bound %u): %u asleep, %u off\n",
           label, rd_ddgi_probe_count(&w->ddgi), updates,
           (double)rd_ddgi_sleep_age(RD_DDGI_DEFAULT_HYSTERESIS), bound, c->sleeping, c->off);
    CHECKF(rd_world_converged(w), "%s: not asleep after %u updates (%u awake)", label, updates,
           c->awake);
    CHECKF(updates <= bound, "%s: asleep after %u updates, more than the bound %u", label, updates,
           bound);
    double at_sleep = *mean = mean_luminance(&r, &cam, err, sizeof err);
    CHECKF(isfinite(at_sleep), "%s: the image is not finite", label);
    if (!(at_sleep > 0) || more == 0) goto done;

    /* the longer run: every probe woken before each update without lowering its age (so it
     * blends at the maximum hysteresis and falls asleep again) */
    double sum = 0, sq = 0;
    unsigned n = 0;
    for (unsigned k = 1; k <= more; k++) {
        rd_world_wake_all(w, 1e30f);
        VK_CHECK(rd_world_update(w, 1, err, sizeof err));
        CHECKF(c->updated > 0, "%s: the longer run updates no probe", label);
        if (k > more / 2 && k % 4 == 0) {
            double l = mean_luminance(&r, &cam, err, sizeof err);
            sum += l, sq += l * l, n++;
        }
    }
    double ref = sum / n, sd = sqrt(fmax(0, sq / n - ref * ref)) / ref, bias = at_sleep / ref - 1;
    double allowed = fmax(max_bias, sd_factor * sd);
    printf("%s: mean luminance at sleep %.6g, after %u more updates %.6g (one image's sd %.1f%%): "
           "bias %+.2f%% (allowed %.0f%%)\n",
           label, at_sleep, more, ref, 100 * sd, 100 * bias, 100 * allowed);
    CHECKF(ref > 0, "%s: the longer run is black", label);
    CHECKF(fabs(bias) <= allowed, "%s: bias at sleep %+.2f%%", label, 100 * bias);
done:
    rd_renderer_destroy(&r);
    rd_gpu_scene_destroy(vk, &gs);
    return updates;
}
