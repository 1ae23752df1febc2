/* probecast_probe_bench: what probe states save, and how fast the default field converges.
 *
 *   probecast_probe_bench [--scene NAME] [--probes X,Y,Z] [--rays N] [--frames N]
 *                         [--width W --height H] [--ref-spp N] [--out FILE.csv] [--device D]
 *                         [--probe-shadows maps|rays]
 *
 * 1. Animated object: a small sphere added to the scene circles over the floor; the field first
 *    converges, then each frame moves the sphere (top-level rebuild), wakes the probes around
 *    its old and new bounds (as the daemon does) and runs one probe update. Reported: the mean
 *    fraction of probes awake and GI GPU ms per frame; then the same frames with every probe
 *    woken each frame (what the field cost before probe states).
 * 2. Cold convergence: updates and GPU ms until the field sleeps with the defaults, and the
 *    mean-luminance bias against a path-traced reference; against the old rule (a fixed 152
 *    updates at hysteresis 0.97: h^n < 0.01).
 * Prints a table and writes the rows as CSV. A benchmark, not a test. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/mesh_builder.h"
#include "renderer/builtin/procedural.h"
#include "renderer/render.h"

typedef struct bench_args {
    const char *scene, *out, *device;
    unsigned probes[3], rays, frames, width, height, ref_spp;
    rd_probe_shadows shadows; /* how probe hits see the lights (render --probe-shadows) */
} bench_args;

static char err[512];

static bool parse(int argc, char **argv, bench_args *a)
{
    *a = (bench_args){.scene = "spheres:1000000",
                      .probes = {32, 8, 32},
                      .frames = 60,
                      .width = 320,
                      .height = 180,
                      .ref_spp = 1024,
                      .out = "probe_states.csv"};
    for (int i = 1; i < argc; i++) {
        const char *o = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!v) return false;
        if (strcmp(o, "--scene") == 0)
            a->scene = strncmp(v, "builtin:", 8) == 0 ? v + 8 : v;
        else if (strcmp(o, "--probes") == 0) {
            if (sscanf(v, "%u,%u,%u", &a->probes[0], &a->probes[1], &a->probes[2]) != 3)
                return false;
        } else if (strcmp(o, "--rays") == 0)
            a->rays = (unsigned)atoi(v);
        else if (strcmp(o, "--frames") == 0)
            a->frames = (unsigned)atoi(v);
        else if (strcmp(o, "--width") == 0)
            a->width = (unsigned)atoi(v);
        else if (strcmp(o, "--height") == 0)
            a->height = (unsigned)atoi(v);
        else if (strcmp(o, "--ref-spp") == 0)
            a->ref_spp = (unsigned)atoi(v);
        else if (strcmp(o, "--out") == 0)
            a->out = v;
        else if (strcmp(o, "--device") == 0)
            a->device = v;
        else if (strcmp(o, "--probe-shadows") == 0 && strcmp(v, "maps") == 0)
            a->shadows = RD_PROBE_SHADOWS_MAPS;
        else if (strcmp(o, "--probe-shadows") == 0 && strcmp(v, "rays") == 0)
            a->shadows = RD_PROBE_SHADOWS_RAYS;
        else
            return false;
        i++;
    }
    return a->frames > 0 && a->width > 0 && a->height > 0;
}

static double mean_lum(const float *rgb, size_t px)
{
    double s = 0;
    for (size_t i = 0; i < px; i++)
        s += 0.2126 * rgb[3 * i] + 0.7152 * rgb[3 * i + 1] + 0.0722 * rgb[3 * i + 2];
    return s / px;
}

/* Renders the field as it is (no update) and returns its mean luminance. */
static double image_lum(rd_renderer *r, const rd_view_camera *cam, const bench_args *a)
{
    rd_view_settings vs = {.width = a->width, .height = a->height, .seed = 1};
    size_t px = (size_t)a->width * a->height;
    float *img = malloc(px * 12);
    if (!img) abort();
    double m = NAN;
    if (rd_view_render(&r->view, &r->world, cam, &vs, err, sizeof err) == RD_VK_OK &&
        rd_view_read_hdr(&r->view, img, err, sizeof err) == RD_VK_OK)
        m = mean_lum(img, px);
    free(img);
    return m;
}

/* Moves the mover to frame f of its circle and wakes the probes around both places. */
static bool move(rd_vk *vk, rd_renderer *r, rd_scene *s, rd_gpu_scene *gs, uint32_t node,
                 uint32_t inst, unsigned f, bool wake_all)
{
    float lo0[3], hi0[3], lo[3], hi[3];
    rd_gpu_scene_instance_bounds(gs, s, inst, lo0, hi0);
    double t = 2 * M_PI * f / 120.0;
    s->nodes[node].translation[0] = (float)(3.0 * cos(t));
    s->nodes[node].translation[2] = (float)(3.0 * sin(t));
    if (!rd_scene_update(s, err, sizeof err) ||
        rd_gpu_scene_update_instances(vk, gs, s, err, sizeof err) != RD_VK_OK)
        return false;
    rd_gpu_scene_instance_bounds(gs, s, inst, lo, hi);
    if (wake_all) {
        rd_world_wake_all(&r->world, PC_DDGI_WAKE_AGE_GEOMETRY);
    } else {
        rd_world_wake_box(&r->world, lo0, hi0, PC_DDGI_WAKE_AGE_GEOMETRY);
        rd_world_wake_box(&r->world, lo, hi, PC_DDGI_WAKE_AGE_GEOMETRY);
    }
    return true;
}

int main(int argc, char **argv)
{
    bench_args a;
    if (!parse(argc, argv, &a)) {
        fprintf(stderr, "usage: probecast_probe_bench [--scene NAME] [--probes X,Y,Z] [--rays N] "
                        "[--frames N] [--width W --height H] [--ref-spp N] [--out FILE.csv] "
                        "[--device D] [--probe-shadows maps|rays]\n");
        return 2;
    }
    rd_scene s;
    if (!rd_procedural_build(a.scene, &s, err, sizeof err)) {
        fprintf(stderr, "probe_bench: %s\n", err);
        return 1;
    }
    /* the animated object: a 0.5 m sphere circling 3 m around the scene's centre axis */
    uint32_t white = rd_build_material(&s, "mover", 0.8f, 0.8f, 0.8f, 0, 0, 0);
    rd_tri_list t = {0};
    const float c0[3] = {0, 1.0f, 0};
    rd_tris_sphere(&t, c0, 0.5f, 16, 32, white);
    uint32_t node = rd_tris_commit(&t, &s, "mover");
    rd_view_camera cam;
    if (!rd_scene_update(&s, err, sizeof err) ||
        !rd_camera_for_scene(&s, -1, &cam, err, sizeof err)) {
        fprintf(stderr, "probe_bench: %s\n", err);
        return 1;
    }
    uint32_t inst = 0;
    for (uint32_t i = 0; i < s.instance_count; i++)
        if (s.instances[i].node == node) inst = i;
    rd_vk vk;
    rd_vk_options vo = {.device = a.device};
    rd_gpu_scene gs;
    rd_renderer r;
    if (rd_vk_create(&vk, &vo, err, sizeof err) != RD_VK_OK ||
        rd_gpu_scene_create(&vk, &gs, &s, err, sizeof err) != RD_VK_OK ||
        rd_renderer_create(&vk, &r, err, sizeof err) != RD_VK_OK) {
        fprintf(stderr, "probe_bench: %s\n", err);
        return 1;
    }
    r.world.shadow_maps.mode = a.shadows;
    printf("device %s, scene %s + mover, %llu triangles, probe hits see lights by %s\n",
           vk.device_name, a.scene, (unsigned long long)s.tri_total,
           a.shadows == RD_PROBE_SHADOWS_RAYS ? "shadow rays" : "distance maps");
    FILE *csv = fopen(a.out, "w");
    if (!csv) {
        fprintf(stderr, "probe_bench: cannot write %s\n", a.out);
        return 1;
    }
    fprintf(csv, "device,part,config,probes,rays,updates,awake_fraction,gi_ms_per_frame,"
                 "gi_ms_total,bias\n");

    /* path-traced reference (GI off while it renders) */
    rd_frame_settings pt = {
        .width = a.width, .height = a.height, .pathtrace_spp = a.ref_spp, .seed = 7};
    size_t px = (size_t)a.width * a.height;
    float *ref = malloc(px * 12);
    if (!ref) abort();
    rd_ddgi_settings off = {0};
    bool ok = rd_renderer_configure_gi(&r, s.bounds_min, s.bounds_max, &off, err, sizeof err) ==
                  RD_VK_OK &&
              rd_renderer_render(&r, &gs, &cam, &pt, err, sizeof err) == RD_VK_OK &&
              rd_renderer_read_hdr(&r, ref, err, sizeof err) == RD_VK_OK;
    double ref_lum = ok ? mean_lum(ref, px) : NAN;
    free(ref);

    rd_ddgi_settings gi = {.mode = PC_GI_DDGI,
                           .rays = a.rays,
                           .seed = 1,
                           .counts = {a.probes[0], a.probes[1], a.probes[2]}};
    rd_world *w = &r.world;
    printf("\n%-34s %8s %9s %10s %12s %8s\n", "cold convergence", "updates", "GPU ms", "ms/update",
           "bias vs PT", "probes");
    for (int rule = 0; ok && rule < 2; rule++) {
        rd_ddgi_settings g = gi;
        if (rule == 1) g.hysteresis = 0.97f, g.has_hysteresis = true;
        ok = rd_renderer_configure_gi(&r, s.bounds_min, s.bounds_max, &g, err, sizeof err) ==
             RD_VK_OK;
        rd_world_set_scene(w, &gs);
        unsigned n = 152;
        if (ok && rule == 0)
            ok = rd_world_converge(w, 3000, &n, err, sizeof err) == RD_VK_OK;
        else if (ok)
            ok = rd_world_update(w, n, err, sizeof err) == RD_VK_OK;
        double ms = rd_frame_stats_total_ms(&w->stats); /* both sum their updates */
        double bias = ok ? image_lum(&r, &cam, &a) / ref_lum - 1 : NAN;
        const char *cfg =
            rule == 0 ? "defaults, until every probe sleeps" : "old rule: 152 updates at h 0.97";
        printf("%-34s %8u %9.1f %10.3f %+11.2f%% %8u\n", cfg, n, ms, ms / n, 100 * bias,
               rd_ddgi_probe_count(&w->ddgi));
        fprintf(csv, "\"%s\",cold,\"%s\",%u,%u,%u,,,%.3f,%.5f\n", vk.device_name, cfg,
                rd_ddgi_probe_count(&w->ddgi), w->ddgi.vol.counts.w, n, ms, bias);
    }

    /* animated object: probe states against every probe awake */
    printf("\n%-34s %8s %9s %10s\n", "animated sphere, per frame", "frames", "awake", "GI ms");
    for (int all = 0; ok && all < 2; all++) {
        ok = rd_renderer_configure_gi(&r, s.bounds_min, s.bounds_max, &gi, err, sizeof err) ==
             RD_VK_OK;
        rd_world_set_scene(w, &gs);
        unsigned dummy;
        ok = ok && rd_world_converge(w, 3000, &dummy, err, sizeof err) == RD_VK_OK;
        double awake = 0, ms = 0;
        unsigned total = rd_ddgi_probe_count(&w->ddgi);
        for (unsigned f = 0; ok && f < a.frames; f++) {
            ok = move(&vk, &r, &s, &gs, node, inst, f, all == 1) &&
                 rd_world_update(w, 1, err, sizeof err) == RD_VK_OK;
            awake += (double)w->ddgi.census.updated / total;
            ms += rd_frame_stats_total_ms(&w->stats);
        }
        const char *cfg = all ? "every probe woken each frame" : "probe states (wake boxes)";
        printf("%-34s %8u %8.1f%% %10.3f\n", cfg, a.frames, 100 * awake / a.frames, ms / a.frames);
        fprintf(csv, "\"%s\",animated,\"%s\",%u,%u,%u,%.4f,%.4f,%.3f,\n", vk.device_name, cfg,
                total, w->ddgi.vol.counts.w, a.frames, awake / a.frames, ms / a.frames, ms);
    }
    fclose(csv);
    if (!ok)
        fprintf(stderr, "probe_bench: %s\n", err);
    else
        printf("\nwrote %s\n", a.out);
    rd_renderer_destroy(&r);
    rd_gpu_scene_destroy(&vk, &gs);
    rd_vk_destroy(&vk);
    rd_scene_destroy(&s);
    return ok ? 0 : 1;
}
