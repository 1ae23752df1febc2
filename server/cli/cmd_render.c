/* probecast render: offline rendering of one scene to PNG/JPEG and/or linear PFM. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "server/cli/cli.h"
#include "server/api/settings.h"
#include "server/base/clock.h"
#include "renderer/scene/animation_clip.h"
#include "server/cli/image_io.h"
#include "renderer/builtin/procedural.h"
#include "renderer/render.h"
#include "renderer/scene/default_lighting.h"

#define RENDER_WARMUP_MS 500.0 /* --timings renders untimed frames this long first */

static void render_usage(FILE *f)
{
    fprintf(f,
            "usage: probecast render SCENE [OPTIONS]\n"
            "\n"
            "Renders SCENE, a .gltf/.glb file or builtin:NAME, to an image.\n"
            "Builtin scenes: %s\n"
            "\n"
            "Options:\n"
            "  --camera INDEX         the scene's camera to use (default: the first, else one\n"
            "                         framing the scene bounds)\n"
            "  --time T               pose the scene's glTF animations at T seconds (T >= 0;\n"
            "                         each animation loops over its own duration); without it\n"
            "                         nodes keep the file's static transforms\n"
            "  -o FILE                tone-mapped output, .png or .jpg (default render.png)\n"
            "  --hdr FILE             linear un-tonemapped radiance as little-endian PFM\n"
            "  --reflections on|off   ray-traced reflections of glossy materials (default on;\n"
            "                         off: no indirect specular, for comparisons)\n"
            "  --default-lighting on|off  a scene without lights, sky or emitters strong\n"
            "                         enough to light it gets a key light and a soft sky, as\n"
            "                         the daemon gives it (default on; a line says when, and\n"
            "                         why)\n"
            "  --quality Q            JPEG quality 1..100 (default 92)\n"
            "  --spp N                path-traced samples per pixel of --gi pathtrace (default\n"
            "                         256)\n"
            "  --max-bounces N        path length limit (default 64; Russian roulette after 3)\n"
            "  --frames N             probe updates before the image is taken (default: until\n"
            "                         every probe has converged, at most --max-updates)\n"
            "  --max-updates N        cap of the default convergence (default %u)\n"
            "  --probe-shadows maps|rays|rebuild  visibility of lights from probe-ray hits:\n"
            "                         point and spot lights' distance maps, rebuilt when the\n"
            "                         scene changes (default); a shadow ray per hit (exact);\n"
            "                         or maps rebuilt every update (benchmarks)\n"
            "  --seed S               seed of the probe ray rotations (same seed, same image)\n"
            "  --dump-probes PREFIX   write the probe atlases as PREFIX-irradiance.{pfm,png}\n"
            "                         and PREFIX-distance.pfm, and every probe's position,\n"
            "                         state and age as PREFIX-probes.csv\n"
            "  --timings              print BVH build time, per-pass GPU times and rays/s\n"
            "  --repeat N             frames to time for --timings, after 0.5 s of warm-up;\n"
            "                         each pass's median is reported (default 5)\n"
            "  --device INDEX|NAME    GPU to use (default: $PROBECAST_DEVICE, else a discrete\n"
            "                         GPU, else lavapipe)\n"
            "  --list-devices         list the Vulkan devices and exit\n"
            "  --help                 this text\n"
            "\n"
            "Settings (the daemon's, as GET and PATCH /v1/settings name them):\n",
            rd_procedural_names(), RD_WORLD_CONVERGE_CAP);
    srv_settings_print_usage(f, SRV_CLI_RENDER);
}

typedef struct render_args {
    const char *scene, *out, *hdr, *device, *dump;
    srv_settings set;     /* the settings flags (the settings table's rows for render) */
    rd_frame_settings fs; /* set's view settings, and the options of the frame */
    rd_ddgi_settings gi;  /* set's GI settings (srv_settings_to_gi), and the seed */
    unsigned frames, max_updates, spp; /* frames 0: converge (at most max_updates) */
    rd_probe_shadows probe_shadows;
    bool pathtrace; /* --gi pathtrace */
    int camera;
    bool has_time;
    double time;
    unsigned quality, repeat, seed;
    bool timings, list_devices;
    bool no_default_lighting;
} render_args;

/* Returns -1 when parsing succeeded, else the exit status to use. */
static int parse(int argc, char **argv, render_args *a)
{
    memset(a, 0, sizeof *a);
    srv_settings_defaults(&a->set);
    unsigned given = 0;
    a->camera = -1;
    a->quality = 92;
    a->repeat = 5;
    a->frames = 0;
    a->max_updates = RD_WORLD_CONVERGE_CAP;
    a->spp = 256;
    for (int i = 1; i < argc; i++) {
        int setting = srv_settings_parse_flag("probecast render", SRV_CLI_RENDER, argc, argv, &i,
                                              &a->set, &given);
        if (setting < 0) return 2;
        if (setting > 0) continue;
        const char *o = argv[i];
        const char *v = NULL;
#define NEED_VALUE                                                                                 \
    if (!(v = srv_arg_value("probecast render", argc, argv, &i))) return 2;
        if (strcmp(o, "--help") == 0 || strcmp(o, "-h") == 0) {
            render_usage(stdout);
            return 0;
        } else if (strcmp(o, "--timings") == 0) {
            a->timings = true;
        } else if (strcmp(o, "--list-devices") == 0) {
            a->list_devices = true;
        } else if (strcmp(o, "--camera") == 0) {
            NEED_VALUE
            unsigned c;
            if (!srv_arg_uint(o, v, 0, 1u << 20, &c)) return 2;
            a->camera = (int)c;
        } else if (strcmp(o, "--time") == 0) {
            NEED_VALUE
            char *end = NULL;
            errno = 0;
            a->time = strtod(v, &end);
            if (end == v || *end != '\0' || errno || !isfinite(a->time) || a->time < 0) {
                fprintf(stderr, "probecast render: --time expects seconds >= 0, got '%s'\n", v);
                return 2;
            }
            a->has_time = true;
        } else if (strcmp(o, "-o") == 0 || strcmp(o, "--output") == 0) {
            NEED_VALUE
            a->out = v;
        } else if (strcmp(o, "--hdr") == 0) {
            NEED_VALUE
            a->hdr = v;
        } else if (strcmp(o, "--reflections") == 0) {
            NEED_VALUE
            bool on;
            if (!srv_arg_on_off(o, v, &on)) return 2;
            a->fs.reflections = on ? PC_REFLECT_AUTO : PC_REFLECT_OFF;
        } else if (strcmp(o, "--default-lighting") == 0) {
            NEED_VALUE
            bool on;
            if (!srv_arg_on_off(o, v, &on)) return 2;
            a->no_default_lighting = !on;
        } else if (strcmp(o, "--quality") == 0) {
            NEED_VALUE
            if (!srv_arg_uint(o, v, 1, 100, &a->quality)) return 2;
        } else if (strcmp(o, "--repeat") == 0) {
            NEED_VALUE
            if (!srv_arg_uint(o, v, 1, 1000, &a->repeat)) return 2;
        } else if (strcmp(o, "--spp") == 0) {
            NEED_VALUE
            if (!srv_arg_uint(o, v, 1, 1u << 20, &a->spp)) return 2;
        } else if (strcmp(o, "--max-bounces") == 0) {
            NEED_VALUE
            if (!srv_arg_uint(o, v, 1, 1024, &a->fs.max_bounces)) return 2;
        } else if (strcmp(o, "--frames") == 0) {
            NEED_VALUE
            if (!srv_arg_uint(o, v, 1, 100000, &a->frames)) return 2;
        } else if (strcmp(o, "--probe-shadows") == 0) {
            NEED_VALUE
            if (strcmp(v, "maps") == 0)
                a->probe_shadows = RD_PROBE_SHADOWS_MAPS;
            else if (strcmp(v, "rays") == 0)
                a->probe_shadows = RD_PROBE_SHADOWS_RAYS;
            else if (strcmp(v, "rebuild") == 0)
                a->probe_shadows = RD_PROBE_SHADOWS_REBUILD;
            else {
                fprintf(stderr,
                        "probecast render: --probe-shadows expects maps, rays or rebuild\n");
                return 2;
            }
        } else if (strcmp(o, "--max-updates") == 0) {
            NEED_VALUE
            if (!srv_arg_uint(o, v, 1, 100000, &a->max_updates)) return 2;
        } else if (strcmp(o, "--seed") == 0) {
            NEED_VALUE
            if (!srv_arg_uint(o, v, 0, 0xffffffffu, &a->seed)) return 2;
        } else if (strcmp(o, "--dump-probes") == 0) {
            NEED_VALUE
            a->dump = v;
        } else if (strcmp(o, "--device") == 0) {
            NEED_VALUE
            a->device = v;
        } else if (o[0] == '-' && o[1] != '\0') {
            fprintf(stderr, "probecast render: unknown option '%s' (see --help)\n", o);
            return 2;
        } else if (!a->scene) {
            a->scene = o;
        } else {
            fprintf(stderr, "probecast render: more than one scene given ('%s')\n", o);
            return 2;
        }
#undef NEED_VALUE
    }
    if (!a->list_devices && !a->scene) {
        fprintf(stderr, "probecast render: no scene given (see --help)\n");
        return 2;
    }
    if (!a->out && !a->hdr) a->out = "render.png";
    /* the settings as the daemon hands them to the renderer */
    srv_settings_to_gi(&a->set, &a->gi);
    a->gi.seed = a->fs.seed = a->seed;
    a->pathtrace = a->set.gi_mode == SRV_GI_PATHTRACE;
    if (a->pathtrace) a->fs.pathtrace_spp = a->spp;
    a->fs.width = a->set.width;
    a->fs.height = a->set.height;
    a->fs.exposure_ev = a->set.exposure_ev;
    a->fs.tonemap = a->set.tonemap;
    a->fs.view = a->set.view;
    a->fs.near_field = a->set.near_field;
    a->fs.shadow_cull = a->set.shadow_cull;
    memcpy(a->fs.sky, a->set.sky, sizeof a->fs.sky);
    if (a->gi.mode == PC_GI_OFF && (a->fs.view != PC_VIEW_FINAL || a->dump)) {
        fprintf(stderr, "probecast render: --view and --dump-probes need --gi classic or ddgi\n");
        return 2;
    }
    return -1;
}

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, unsigned n)
{
    qsort(v, n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static void print_timings(const rd_vk *vk, const rd_scene *s, const rd_gpu_scene *gs,
                          const rd_frame_stats *avg, unsigned frames, unsigned w, unsigned h,
                          unsigned mapped, unsigned cull)
{
    printf("device      %s\n", vk->device_name);
    printf("scene       %llu triangles, %u instances, %u lights\n",
           (unsigned long long)gs->tri_count, s->instance_count, s->light_count);
    printf("bvh build   %.1f ms bottom level (%llu nodes, depth %u), %.3f ms top level, "
           "%.1f ms upload\n",
           gs->blas_build_ms, (unsigned long long)gs->blas_node_count, gs->max_blas_depth,
           gs->tlas_build_ms, gs->upload_ms);
    if (gs->blas_gpu_meshes) /* part of the bottom level's time (PROBECAST_BLAS_BUILD) */
        printf("bvh gpu     %.1f ms building %u meshes' bottom levels on the GPU (LBVH: build, "
               "placing, node count and depth read back), the rest on the CPU\n",
               gs->blas_gpu_build_ms, gs->blas_gpu_meshes);
    printf("frame       %ux%u, median of %u frames after %.1f s of warm-up\n", w, h, frames,
           RENDER_WARMUP_MS / 1000.0);
    /* how camera pixels and reflection hits chose their shadow rays (direct_radiance, and
     * direct_radiance_mapped at reflection hits) */
    if (s->light_count == 0)
        printf("shadows     no lights\n");
    else if (cull == PC_SHADOW_CULL_OFF)
        printf("shadows     a ray to every light in front of a point (--shadow-cull off)\n");
    else if (mapped == 0)
        printf("shadows     a ray to every light in front of a point (no distance maps: GI off, "
               "or not worth building yet)\n");
    else
        printf("shadows     camera pixels: no ray where the distance maps (%u of %u lights) "
               "show a point hidden, a ray elsewhere; reflection hits: the maps' answer where "
               "their texels agree\n",
               mapped, s->light_count);
    if (!avg->timed) {
        printf("(this device has no GPU timestamps)\n");
        return;
    }
    printf("%-17s %10s %12s %12s\n", "pass", "GPU ms", "rays", "Mrays/s");
    double total = 0;
    for (unsigned i = 0; i < avg->pass_count; i++) {
        double rays = 0;
        if (strcmp(avg->pass_name[i], "primary") == 0) rays = avg->rays.primary_rays;
        if (strcmp(avg->pass_name[i], "shade") == 0) rays = avg->rays.shadow_rays;
        if (strcmp(avg->pass_name[i], "probe shade") == 0)
            rays = avg->rays.probe_shadow_rays + avg->rays.probe_path_rays;
        if (strcmp(avg->pass_name[i], "probe trace") == 0) rays = avg->rays.probe_rays;
        if (strcmp(avg->pass_name[i], "path trace") == 0) rays = avg->rays.path_rays;
        if (strcmp(avg->pass_name[i], "shadow maps") == 0) rays = avg->rays.shadow_map_rays;
        if (strcmp(avg->pass_name[i], "reflect") == 0) rays = avg->rays.reflect_rays;
        if (strcmp(avg->pass_name[i], "near field") == 0) rays = avg->rays.near_rays;
        total += avg->pass_ms[i];
        if (rays > 0)
            printf("%-17s %10.3f %12.0f %12.1f\n", avg->pass_name[i], avg->pass_ms[i], rays,
                   avg->pass_ms[i] > 0 ? rays / (avg->pass_ms[i] * 1e3) : 0.0);
        else
            printf("%-17s %10.3f %12s %12s\n", avg->pass_name[i], avg->pass_ms[i], "-", "-");
    }
    printf("%-17s %10.3f\n", "total", total);
}

static rd_vk_result dump_probes(rd_renderer *r, const char *prefix, char *err, size_t errlen)
{
    float *irr = NULL, *dist = NULL;
    unsigned iw, ih, dw, dh;
    rd_vk_result vr =
        rd_ddgi_read_atlases(&r->world.ddgi, &irr, &iw, &ih, &dist, &dw, &dh, err, errlen);
    if (vr != RD_VK_OK) return vr;
    char path[1024];
    uint8_t *rgba = malloc((size_t)iw * ih * 4);
    if (!rgba) abort();
    for (size_t i = 0; i < (size_t)iw * ih; i++) {
        for (int c = 0; c < 3; c++) {
            float v = irr[i * 3 + c] / (1.0f + irr[i * 3 + c]); /* Reinhard, for a quick look */
            rgba[i * 4 + c] = (uint8_t)(255.0f * powf(v, 1 / 2.2f) + 0.5f);
        }
        rgba[i * 4 + 3] = 255;
    }
    bool ok = true;
    snprintf(path, sizeof path, "%s-irradiance.pfm", prefix);
    ok = ok && rd_image_write_pfm(path, irr, iw, ih, err, errlen) == RD_IMAGE_OK;
    snprintf(path, sizeof path, "%s-irradiance.png", prefix);
    ok = ok && rd_image_write_rgba8(path, rgba, iw, ih, 0, err, errlen) == RD_IMAGE_OK;
    snprintf(path, sizeof path, "%s-distance.pfm", prefix);
    ok = ok && rd_image_write_pfm(path, dist, dw, dh, err, errlen) == RD_IMAGE_OK;
    free(rgba);
    free(irr);
    free(dist);
    rd_ddgi_probe_info *probes = NULL;
    if (ok) vr = rd_ddgi_read_probes(&r->world.ddgi, &probes, err, errlen);
    if (!ok || vr != RD_VK_OK) return ok ? vr : RD_VK_ERR_VULKAN;
    snprintf(path, sizeof path, "%s-probes.csv", prefix);
    FILE *f = fopen(path, "w");
    if (f) {
        static const char *const state_names[] = {"off", "awake", "?", "sleeping"};
        fprintf(f, "probe,x,y,z,state,age,held,crossed_edges\n");
        for (unsigned i = 0; i < rd_ddgi_probe_count(&r->world.ddgi); i++) {
            const rd_ddgi_probe_info *p = &probes[i];
            fprintf(f, "%u,%.4f,%.4f,%.4f,%s,%.0f,%.0f,%u\n", i, p->position[0], p->position[1],
                    p->position[2], p->state < 4 ? state_names[p->state] : "?", p->age, p->held,
                    p->edges);
        }
        ok = fclose(f) == 0;
    } else {
        ok = false;
    }
    if (!ok) snprintf(err, errlen, "cannot write %.400s", path);
    free(probes);
    return ok ? RD_VK_OK : RD_VK_ERR_VULKAN;
}

int cli_render(int argc, char **argv)
{
    render_args a;
    int status = parse(argc, argv, &a);
    if (status >= 0) return status;
    char err[512] = "";
    if (a.list_devices) {
        char list[4096];
        if (rd_vk_list_devices(list, sizeof list, err, sizeof err) != RD_VK_OK) {
            fprintf(stderr, "probecast: %s\n", err);
            return 1;
        }
        fputs(list, stdout);
        return 0;
    }

    rd_scene scene;
    double t0 = now_ms();
    if (!srv_arg_scene(a.scene, &scene)) return 1;
    if (a.has_time) {
        if (scene.animation_count == 0)
            fprintf(stderr, "probecast: warning: the scene has no animations; --time changes "
                            "nothing\n");
        rd_scene_animate(&scene, a.time);
        if (!rd_scene_update(&scene, err, sizeof err)) {
            fprintf(stderr, "probecast: %s\n", err);
            rd_scene_destroy(&scene);
            return 1;
        }
    }
    double load_ms = now_ms() - t0;

    rd_view_camera cam;
    if (!rd_camera_for_scene(&scene, a.camera, &cam, err, sizeof err)) {
        fprintf(stderr, "probecast: %s\n", err);
        rd_scene_destroy(&scene);
        return 1;
    }

    /* --sky, or the default lighting (default_lighting.h), which adds its key light to the
     * scene before the GPU gets it */
    rd_environment env = {.mode = RD_ENV_UNIFORM, .intensity = 1};
    memcpy(env.sky, a.fs.sky, sizeof env.sky);
    a.fs.env = &env;
    rd_default_lighting_check lighting;
    if (!a.no_default_lighting && rd_default_lighting_apply(&scene, &cam, &env, &lighting)) {
        char why[160];
        rd_default_lighting_describe(&lighting, why, sizeof why);
        fprintf(stderr, "probecast: default lighting added (%s)\n", why);
    }

    rd_vk vk;
    rd_gpu_scene gs;
    rd_renderer r;
    memset(&gs, 0, sizeof gs);
    memset(&r, 0, sizeof r);
    rd_vk_options vo = {.device = a.device};
    rd_vk_result vr = rd_vk_create(&vk, &vo, err, sizeof err);
    if (vr != RD_VK_OK) {
        fprintf(stderr, "probecast: %s\n", err);
        rd_scene_destroy(&scene);
        return 1;
    }
    vr = rd_gpu_scene_create(&vk, &gs, &scene, err, sizeof err);
    if (vr == RD_VK_OK) vr = rd_renderer_create(&vk, &r, err, sizeof err);
    if (vr == RD_VK_OK) r.world.shadow_maps.mode = a.probe_shadows;
    if (vr == RD_VK_OK)
        vr = rd_renderer_configure_gi(&r, scene.bounds_min, scene.bounds_max, &a.gi, err,
                                      sizeof err);
    if (vr == RD_VK_OK && r.world.gi && !a.pathtrace && a.frames == 0) {
        /* no --frames: update until every probe has converged (they then sleep) */
        unsigned done = 0;
        rd_world_set_scene(&r.world, &gs);
        rd_world_set_environment(&r.world, &env);
        vr = rd_world_converge(&r.world, a.max_updates, &done, err, sizeof err);
        const rd_ddgi_census *c = &r.world.ddgi.census;
        if (vr == RD_VK_OK && !rd_world_converged(&r.world))
            fprintf(stderr,
                    "probecast: GI not converged after %u probe updates (--max-updates): %u of "
                    "%u probes still change; the image shows the field as it is\n",
                    done, c->awake, rd_ddgi_probe_count(&r.world.ddgi));
        else if (vr == RD_VK_OK)
            fprintf(stderr,
                    "probecast: GI converged after %u probe updates (%u probes asleep, %u off "
                    "inside geometry)\n",
                    done, c->sleeping, c->off);
    }
    unsigned frames = a.timings ? a.repeat : 1;
    rd_frame_stats med = {0};
    /* per timed frame and pass; the report gives each pass's median */
    double *samples = malloc((size_t)frames * RD_TIMER_MAX * sizeof *samples);
    if (!samples) abort();
    for (size_t k = 0; k < (size_t)frames * RD_TIMER_MAX; k++)
        samples[k] = -1; /* the pass did not run in that frame */
    double warm_until = 0;
    unsigned timed = 0;
    for (unsigned f = 0; vr == RD_VK_OK && timed < frames; f++) {
        /* the first frame takes --frames updates (after the convergence above: one, which
         * finds every probe asleep); frames after it do one update each */
        a.fs.gi_updates = f == 0 && a.frames ? a.frames : 1;
        vr = rd_renderer_render(&r, &gs, &cam, &a.fs, err, sizeof err);
        if (vr != RD_VK_OK) break;
        if (!a.timings) {
            med.pass_count = 0;
            timed++;
            continue;
        }
        /* warm up for 0.5 s first (at least 2 frames): a GPU idle before the run starts at low
         * clocks, which made short runs read 2-5 times slower on the H200 */
        double now = srv_mono_ms();
        if (f == 0) warm_until = now + RENDER_WARMUP_MS;
        if (f < 2 || now < warm_until) continue;
        const rd_frame_stats *st = &r.stats;
        med.timed = st->timed;
        /* passes by name: a frame may run passes others do not (a distance-map rebuild) */
        for (unsigned i = 0; i < st->pass_count; i++) {
            int j = rd_frame_stats_pass(&med, st->pass_name[i]);
            if (j >= 0) samples[(size_t)timed * RD_TIMER_MAX + (unsigned)j] = st->pass_ms[i];
        }
        med.rays = st->rays;
        timed++;
    }
    for (unsigned i = 0; timed && i < med.pass_count; i++) {
        double col[1000];
        unsigned n = 0; /* the median over the frames that ran the pass */
        for (unsigned k = 0; k < timed; k++)
            if (samples[(size_t)k * RD_TIMER_MAX + i] >= 0)
                col[n++] = samples[(size_t)k * RD_TIMER_MAX + i];
        med.pass_ms[i] = n ? median(col, n) : 0;
    }
    free(samples);
    size_t px = (size_t)a.fs.width * a.fs.height;
    if (vr == RD_VK_OK && a.out) {
        uint8_t *rgba = malloc(px * 4);
        if (!rgba) abort();
        vr = rd_renderer_read_rgba8(&r, rgba, err, sizeof err);
        if (vr == RD_VK_OK && rd_image_write_rgba8(a.out, rgba, a.fs.width, a.fs.height,
                                                   (int)a.quality, err, sizeof err) != RD_IMAGE_OK)
            vr = RD_VK_ERR_VULKAN; /* reported below through err */
        free(rgba);
    }
    if (vr == RD_VK_OK && a.hdr) {
        float *rgb = malloc(px * 12);
        if (!rgb) abort();
        vr = rd_renderer_read_hdr(&r, rgb, err, sizeof err);
        if (vr == RD_VK_OK &&
            rd_image_write_pfm(a.hdr, rgb, a.fs.width, a.fs.height, err, sizeof err) != RD_IMAGE_OK)
            vr = RD_VK_ERR_VULKAN;
        free(rgb);
    }
    if (vr == RD_VK_OK && a.dump) vr = dump_probes(&r, a.dump, err, sizeof err);
    if (vr == RD_VK_OK && a.timings) {
        printf("scene load  %.1f ms\n", load_ms);
        unsigned mapped = r.world.gi ? rd_shadow_maps_view_lights(&r.world.shadow_maps, &gs) : 0;
        print_timings(&vk, &scene, &gs, &med, frames, a.fs.width, a.fs.height, mapped,
                      a.fs.shadow_cull);
    }
    if (vr != RD_VK_OK) fprintf(stderr, "probecast: %s\n", err);
    rd_renderer_destroy(&r);
    rd_gpu_scene_destroy(&vk, &gs);
    unsigned validation = rd_vk_validation_messages(&vk);
    rd_vk_destroy(&vk);
    rd_scene_destroy(&scene);
    if (vr == RD_VK_OK && validation > 0) {
        fprintf(stderr, "probecast: %u Vulkan validation message(s)\n", validation);
        return 1;
    }
    return vr == RD_VK_OK ? 0 : 1;
}
