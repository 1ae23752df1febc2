/* probecast eval: speed against error. For each scene of the hard-case suite, a converged
 * path-traced reference is rendered once (cached by a hash of the scene and settings); then
 * DDGI settings (probe density, rays per probe, updates), classic probes and direct light are
 * swept, timing one steady-state frame with GPU timestamps and measuring the error against
 * the reference. Writes CSV, JSON and an SVG chart, and prints a table. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "server/cli/cli.h"
#include "server/api/settings.h"
#include "server/cli/eval_report.h"
#include "renderer/builtin/hard_cases.h"
#include "server/cli/image_io.h"
#include "renderer/builtin/procedural.h"
#include "renderer/render.h"
#include "server/cli/eval_internal.h"
#include "renderer/scene/default_lighting.h"

/* The settings eval sweeps: each flag takes a list, and every combination is rendered. */
#define EVAL_SWEEPS (SRV_SET_RAYS | SRV_SET_HYSTERESIS | SRV_SET_PROBE_COUNTS)
#define EVAL_LIST_MAX 8 /* values per list */

static void eval_defaults(eval_args *a)
{
    memset(a, 0, sizeof *a);
    a->width = 320, a->height = 180, a->ref_spp = 1024, a->timing_frames = 7;
    a->hysteresis[0] = 0.85f, a->hysteresis[1] = RD_DDGI_DEFAULT_HYSTERESIS, a->nhysteresis = 2;
    a->rays[0] = 64, a->rays[1] = 128, a->rays[2] = 256, a->nrays = 3;
    a->updates[0] = 8, a->updates[1] = 32, a->nupdates = 2;
    a->density[0] = 0.5f, a->density[1] = 1, a->density[2] = 2, a->ndensity = 3;
    a->out_dir = "eval-out";
    a->noise_floor = true;
    a->families = EVAL_LAMBERT | EVAL_GLTF;
}

/* The default of a setting flag as eval's usage shows it (a list for a sweep). */
static void eval_default_text(const eval_args *a, const srv_setting_info *d, char *buf, size_t len)
{
    size_t n = 0;
    buf[0] = '\0';
    if (d->bit == SRV_SET_WIDTH) snprintf(buf, len, "%u", a->width);
    if (d->bit == SRV_SET_HEIGHT) snprintf(buf, len, "%u", a->height);
    if (d->bit == SRV_SET_PROBE_COUNTS) snprintf(buf, len, "none: the grids of --density");
    for (unsigned k = 0; d->bit == SRV_SET_RAYS && k < a->nrays && n < len; k++)
        n += (size_t)snprintf(buf + n, len - n, "%s%u", k ? "," : "", a->rays[k]);
    for (unsigned k = 0; d->bit == SRV_SET_HYSTERESIS && k < a->nhysteresis && n < len; k++)
        n += (size_t)snprintf(buf + n, len - n, "%s%g", k ? "," : "", (double)a->hysteresis[k]);
}

static void eval_usage(FILE *f)
{
    fprintf(
        f,
        "usage: probecast eval [OPTIONS]\n"
        "\n"
        "Renders each scene of the hard-case suite with a path-traced reference and a sweep of\n"
        "GI settings, and reports GPU time per frame against the error. Every case also gets\n"
        "the row a user gets without flags (mode default: the default probe grid converged by\n"
        "the default rule until it sleeps, with its updates and GPU ms to sleep).\n"
        "\n"
        "Options:\n"
        "  --cases A,B,...        scenes of the suite (default: all; --list shows them)\n"
        "  --materials A,B,...    material families: lambert (the builtin's own), gltf (its\n"
        "                         glTF twin: the default dielectric, Appendix B's specular),\n"
        "                         metal (metallic 0.5, roughness 0.5) (default lambert,gltf);\n"
        "                         twins only for cases whose materials are all Lambertian\n"
        "  --ref-spp N            reference samples per pixel (default 1024)\n"
        "  --updates A,B,...      probe updates before the image (default 8,32)\n"
        "  --density A,B,...      probe density factors over the fitted grid (default 0.5,1,2)\n"
        "  --no-noise-floor       skip the second reference (seed 2) that measures its noise\n"
        "  --timing-frames N      steady-state frames timed per setting, after two warm-up\n"
        "                         frames; the median is reported (default 7)\n"
        "  --out DIR              where eval.csv, eval.json, eval.svg go (default eval-out)\n"
        "  --cache DIR            reference cache (default DIR-of-out/cache)\n"
        "  --device INDEX|NAME    Vulkan device\n"
        "  --default-lighting on|off  light scenes without lights, sky or strong emitters\n"
        "                         as `probecast render` does (default on)\n"
        "  --reflections on|off   ray-traced reflections of glossy materials in every row\n"
        "                         (default on; off: no indirect specular, as in render;\n"
        "                         rows say refl-off)\n"
        "  --list                 list the suite with each case's expectation\n"
        "  --dynamic              instead of the suite: a light and an object move in a\n"
        "                         converged field; reports updates, GPU ms and error at\n"
        "                         fixed update counts after the change (eval-dynamic.csv)\n"
        "  --replot DIR           redraw DIR/eval.svg and the table from DIR/eval.csv\n"
        "\n"
        "Settings (the daemon's, as GET and PATCH /v1/settings name them; a list of up to %u\n"
        "values is swept, each combination a row):\n",
        EVAL_LIST_MAX);
    eval_args a;
    eval_defaults(&a);
    for (unsigned i = 0; i < SRV_SETTING_COUNT; i++) {
        const srv_setting_info *d = srv_setting_at(i);
        if (!(d->cli & SRV_CLI_EVAL)) continue;
        char def[96];
        eval_default_text(&a, d, def, sizeof def);
        /* settings eval does not sweep show the table's default */
        srv_setting_print_usage(f, d, (d->bit & EVAL_SWEEPS) != 0, def[0] ? def : NULL);
    }
}

static bool parse_uint_list(const char *opt, const char *s, unsigned *out, unsigned *n)
{
    *n = 0;
    char buf[256];
    snprintf(buf, sizeof buf, "%s", s);
    for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
        if (*n == EVAL_LIST_MAX || !srv_arg_uint(opt, tok, 1, 100000, &out[*n])) return false;
        (*n)++;
    }
    return *n > 0;
}

/* --materials: a comma-separated subset of lambert, gltf, metal. */
static bool parse_families(const char *s, unsigned *out)
{
    static const char *names[] = {"lambert", "gltf", "metal"};
    *out = 0;
    for (const char *p = s; *p;) {
        size_t len = strcspn(p, ",");
        unsigned bit = 0;
        for (unsigned k = 0; k < 3; k++)
            if (strlen(names[k]) == len && strncmp(names[k], p, len) == 0) bit = 1u << k;
        if (!bit) {
            fprintf(stderr,
                    "probecast eval: --materials: unknown family '%.*s' (lambert, gltf, "
                    "metal)\n",
                    (int)len, p);
            return false;
        }
        *out |= bit;
        p += len + (p[len] == ',');
    }
    if (!*out) fprintf(stderr, "probecast eval: --materials needs at least one family\n");
    return *out != 0;
}

/* A setting flag of eval (the settings table's rows for eval): one value, or a list of them for a
 * sweep, each checked against the table's range. */
static bool parse_setting(const srv_setting_info *d, const char *v, eval_args *a, srv_settings *set)
{
    static const char cmd[] = "probecast eval";
    srv_settings vals[EVAL_LIST_MAX];
    unsigned n = 1;
    if (d->bit != SRV_SET_WIDTH && d->bit != SRV_SET_HEIGHT && !(d->bit & EVAL_SWEEPS))
        return srv_setting_parse(cmd, d, v, set); /* into every row's base */
    if (d->bit & EVAL_SWEEPS) {
        if (!srv_setting_parse_list(cmd, d, v, vals, EVAL_LIST_MAX, &n)) return false;
    } else if (!srv_setting_parse(cmd, d, v, &vals[0])) {
        return false;
    }
    for (unsigned k = 0; k < n; k++) {
        if (d->bit == SRV_SET_WIDTH) a->width = vals[k].width;
        if (d->bit == SRV_SET_HEIGHT) a->height = vals[k].height;
        if (d->bit == SRV_SET_RAYS) a->rays[k] = vals[k].rays_per_probe;
        if (d->bit == SRV_SET_HYSTERESIS) a->hysteresis[k] = vals[k].hysteresis;
        if (d->bit == SRV_SET_PROBE_COUNTS)
            memcpy(a->probes[k], vals[k].probe_counts, sizeof a->probes[k]);
    }
    if (d->bit == SRV_SET_RAYS) a->nrays = n;
    if (d->bit == SRV_SET_HYSTERESIS) a->nhysteresis = n;
    if (d->bit == SRV_SET_PROBE_COUNTS) a->nprobes = n;
    return true;
}

/* Appends text to the string dst of capacity cap (cut at the capacity). */
static void append(char *dst, size_t cap, const char *text)
{
    size_t n = strlen(dst), k = strlen(text);
    if (n + 1 >= cap) return;
    if (k > cap - 1 - n) k = cap - 1 - n;
    memcpy(dst + n, text, k);
    dst[n + k] = '\0';
}

/* The base GI settings from the unswept flags, and their label. */
static void set_base(eval_args *a, const srv_settings *set)
{
    srv_settings_to_gi(set, &a->base);
    char *l = a->base_label;
    size_t cap = sizeof a->base_label;
    l[0] = '\0';
    if (a->base.visibility == PC_DDGI_VIS_OFF) append(l, cap, " vis-off");
    if (a->base.visibility == PC_DDGI_VIS_PROBES) append(l, cap, " vis-probes");
    if (a->base.relocation) append(l, cap, " relocate");
    a->near_field = set->near_field;
    if (a->near_field == PC_NEAR_OFF) append(l, cap, " near-off");
    a->shadow_cull = set->shadow_cull;
    if (a->shadow_cull == PC_SHADOW_CULL_OFF) append(l, cap, " cull-off");
    if (a->reflections == PC_REFLECT_OFF) append(l, cap, " refl-off");
    if (a->base.path_bounces != RD_DDGI_DEFAULT_PATH_BOUNCES) {
        char p[24];
        snprintf(p, sizeof p, " paths%u", a->base.path_bounces);
        append(l, cap, p);
    }
}

static int parse(int argc, char **argv, eval_args *a)
{
    eval_defaults(a);
    srv_settings set; /* the unswept setting flags, for every row's base */
    srv_settings_defaults(&set);
    for (int i = 1; i < argc; i++) {
        const char *o = argv[i], *v = NULL;
        bool takes = strcmp(o, "--help") && strcmp(o, "-h") && strcmp(o, "--list") &&
                     strcmp(o, "--no-noise-floor") && strcmp(o, "--dynamic");
        if (takes && !(v = srv_arg_value("probecast eval", argc, argv, &i))) return 2;
        const srv_setting_info *d = srv_setting_by_flag(o, SRV_CLI_EVAL);
        if (d) {
            if (!parse_setting(d, v, a, &set)) return 2;
        } else if (strcmp(o, "--help") == 0 || strcmp(o, "-h") == 0) {
            eval_usage(stdout);
            return 0;
        } else if (strcmp(o, "--list") == 0) {
            a->list = true;
        } else if (strcmp(o, "--dynamic") == 0) {
            a->dynamic = true;
        } else if (strcmp(o, "--no-noise-floor") == 0) {
            a->noise_floor = false;
        } else if (strcmp(o, "--cases") == 0) {
            a->cases = v;
        } else if (strcmp(o, "--materials") == 0) {
            if (!parse_families(v, &a->families)) return 2;
        } else if (strcmp(o, "--replot") == 0) {
            a->replot = v;
        } else if (strcmp(o, "--out") == 0) {
            a->out_dir = v;
        } else if (strcmp(o, "--cache") == 0) {
            a->cache_dir = v;
        } else if (strcmp(o, "--device") == 0) {
            a->device = v;
        } else if (strcmp(o, "--reflections") == 0) {
            bool on;
            if (!srv_arg_on_off(o, v, &on)) return 2;
            a->reflections = on ? PC_REFLECT_AUTO : PC_REFLECT_OFF;
        } else if (strcmp(o, "--default-lighting") == 0) {
            bool on;
            if (!srv_arg_on_off(o, v, &on)) return 2;
            a->no_default_lighting = !on;
        } else if (strcmp(o, "--ref-spp") == 0) {
            if (!srv_arg_uint(o, v, 1, 1u << 20, &a->ref_spp)) return 2;
        } else if (strcmp(o, "--timing-frames") == 0) {
            if (!srv_arg_uint(o, v, 1, 100, &a->timing_frames)) return 2;
        } else if (strcmp(o, "--updates") == 0) {
            if (!parse_uint_list(o, v, a->updates, &a->nupdates)) return 2;
        } else if (strcmp(o, "--density") == 0) {
            a->ndensity = 0;
            char buf[256];
            snprintf(buf, sizeof buf, "%s", v);
            for (char *t = strtok(buf, ","); t; t = strtok(NULL, ",")) {
                if (a->ndensity == EVAL_LIST_MAX ||
                    !srv_arg_float(o, t, &a->density[a->ndensity]) ||
                    !(a->density[a->ndensity] > 0)) {
                    fprintf(stderr, "probecast eval: --density expects positive factors\n");
                    return 2;
                }
                a->ndensity++;
            }
        } else {
            fprintf(stderr, "probecast eval: unknown option '%s' (see --help)\n", o);
            return 2;
        }
    }
    set_base(a, &set);
    return -1;
}

static void progress(unsigned done, unsigned total, const char *what)
{
    if (!isatty(2)) return;
    int width = 30, fill = total ? (int)(width * done / total) : width;
    fprintf(stderr, "\r[%.*s%*s] %3u/%u %-40.40s", fill, "##############################",
            width - fill, "", done, total, what);
    if (done == total) fputc('\n', stderr);
    fflush(stderr);
}

/* The median of n values (sorted in place; a handful of values: insertion sort). */
static double median(double *v, unsigned n)
{
    for (unsigned i = 1; i < n; i++)
        for (unsigned j = i; j > 0 && v[j] < v[j - 1]; j--) {
            double t = v[j];
            v[j] = v[j - 1], v[j - 1] = t;
        }
    return v[n / 2];
}

/* Renders the frame fs describes, compares it with ref (row->err), then times steady-state
 * frames of one update each (row->gpu_ms). GPU clocks ramp up under load: two warm-up frames,
 * then the median frame. */
static bool measure_frame(eval_ctx *c, rd_gpu_scene *gs, const rd_view_camera *cam,
                          rd_frame_settings *fs, const float *ref, eval_row *row)
{
    const eval_args *a = c->a;
    if (rd_renderer_render(&c->r, gs, cam, fs, c->err, sizeof c->err) != RD_VK_OK) return false;
    size_t px = (size_t)a->width * a->height;
    float *img = malloc(px * 12);
    if (!img) abort();
    if (rd_renderer_read_hdr(&c->r, img, c->err, sizeof c->err) != RD_VK_OK) {
        free(img);
        return false;
    }
    rd_image_compare(img, ref, px, &row->err);
    free(img);
    fs->gi_updates = 1;
    double times[100];
    for (unsigned f = 0; f < a->timing_frames + 2; f++) {
        if (rd_renderer_render(&c->r, gs, cam, fs, c->err, sizeof c->err) != RD_VK_OK) return false;
        if (f >= 2) times[f - 2] = rd_frame_stats_total_ms(&c->r.stats);
    }
    row->gpu_ms = median(times, a->timing_frames);
    return true;
}

/* One GI setting: converge for `updates` (the moving case moves half way through), measure
 * the error, then time steady-state frames of one update each. */
static bool run_setting(eval_ctx *c, const char *name, rd_scene *s, rd_gpu_scene *gs,
                        const rd_view_camera *cam, const rd_ddgi_settings *gi, unsigned updates,
                        const float *ref, eval_row *row)
{
    const eval_args *a = c->a;
    bool moving = rd_hard_case_pose(name, s, 0);
    if (moving && rd_gpu_scene_update_instances(&c->vk, gs, s, c->err, sizeof c->err) != RD_VK_OK)
        return false;
    if (rd_renderer_configure_gi(&c->r, s->bounds_min, s->bounds_max, gi, c->err, sizeof c->err) !=
        RD_VK_OK)
        return false;
    rd_frame_settings fs = {.width = a->width,
                            .height = a->height,
                            .seed = gi->seed,
                            .near_field = a->near_field,
                            .shadow_cull = a->shadow_cull,
                            .reflections = a->reflections};
    fs.env = &c->env;
    if (moving) {
        fs.gi_updates = updates / 2 ? updates / 2 : 1;
        if (rd_renderer_render(&c->r, gs, cam, &fs, c->err, sizeof c->err) != RD_VK_OK)
            return false;
        rd_hard_case_pose(name, s, 4);
        if (rd_gpu_scene_update_instances(&c->vk, gs, s, c->err, sizeof c->err) != RD_VK_OK)
            return false;
        fs.gi_updates = updates - fs.gi_updates ? updates - fs.gi_updates : 1;
    } else {
        fs.gi_updates = updates;
    }
    if (!measure_frame(c, gs, cam, &fs, ref, row)) return false;
    if (gi->mode != PC_GI_OFF) {
        row->probes[0] = c->r.world.ddgi.vol.counts.x;
        row->probes[1] = c->r.world.ddgi.vol.counts.y;
        row->probes[2] = c->r.world.ddgi.vol.counts.z;
        row->rays = c->r.world.ddgi.vol.counts.w;
    }
    row->updates = gi->mode != PC_GI_OFF ? updates : 0;
    return true;
}

/* The row a user gets without flags: the default probe grid and rays, converged by the default
 * rule until the field sleeps (at most RD_WORLD_CONVERGE_CAP updates), then the image; GPU ms of a
 * steady-state frame after that (probes asleep: shading only), the updates and GPU ms it took
 * to fall asleep. The moving case is measured in its final pose. */
static bool run_default(eval_ctx *c, rd_scene *s, rd_gpu_scene *gs, const rd_view_camera *cam,
                        const float *ref, eval_row *row)
{
    const eval_args *a = c->a;
    rd_ddgi_settings gi = a->base; /* the defaults, but for unswept flags */
    gi.mode = PC_GI_DDGI, gi.seed = 1;
    if (rd_renderer_configure_gi(&c->r, s->bounds_min, s->bounds_max, &gi, c->err, sizeof c->err) !=
        RD_VK_OK)
        return false;
    rd_world_set_scene(&c->r.world, gs);
    rd_world_set_environment(&c->r.world, &c->env);
    unsigned done = 0;
    if (rd_world_converge(&c->r.world, RD_WORLD_CONVERGE_CAP, &done, c->err, sizeof c->err) !=
        RD_VK_OK)
        return false;
    row->sleep_ms = rd_frame_stats_total_ms(&c->r.world.stats);
    row->slept = rd_world_converged(&c->r.world);
    row->updates = done;
    rd_frame_settings fs = {.width = a->width,
                            .height = a->height,
                            .seed = 1,
                            .env = &c->env,
                            .near_field = a->near_field,
                            .shadow_cull = a->shadow_cull,
                            .reflections = a->reflections};
    if (!measure_frame(c, gs, cam, &fs, ref, row)) return false;
    row->probes[0] = c->r.world.ddgi.vol.counts.x;
    row->probes[1] = c->r.world.ddgi.vol.counts.y;
    row->probes[2] = c->r.world.ddgi.vol.counts.z;
    row->rays = c->r.world.ddgi.vol.counts.w;
    row->hysteresis = RD_DDGI_DEFAULT_HYSTERESIS;
    snprintf(row->mode, sizeof row->mode, "default");
    snprintf(row->config, sizeof row->config, "default %ux%ux%u r%u", row->probes[0],
             row->probes[1], row->probes[2], row->rays);
    append(row->config, sizeof row->config, a->base_label);
    char at[24];
    snprintf(at, sizeof at, " %s%u", row->slept ? "sleeps@" : "awake@", row->updates);
    append(row->config, sizeof row->config, at);
    return true;
}

/* True when every material of s is Lambertian (no specular lobe, not metallic): the cases that
 * get glTF-material twins. */
static bool all_lambertian(const rd_scene *s)
{
    for (uint32_t m = 0; m < s->material_count; m++)
        if (s->materials[m].specular > 0 || s->materials[m].metallic > 0) return false;
    return true;
}

/* One case of the suite in one material family (bit index f of eval_args.families): its
 * references, the direct, classic and default rows and the sweep, appended at rows[*nrows]. A
 * twin (f > 0) of a case that is not all Lambertian is skipped. False after an error (printed). */
static bool run_case(eval_ctx *c, const rd_hard_case *hc, unsigned f, eval_row *rows,
                     unsigned *nrows, unsigned *done, unsigned total)
{
    static const char *suffix[3] = {"", "+gltf", "+metal"};
    const eval_args *a = c->a;
    const char *name = hc->name;
    char label[48], spec[64];
    snprintf(label, sizeof label, "%s%s", name, suffix[f]);
    snprintf(spec, sizeof spec, "hard:%s%s", name, suffix[f]);
    unsigned ngrids = a->nprobes ? a->nprobes : a->ndensity;
    unsigned sweep = ngrids * a->nrays * a->nupdates * a->nhysteresis;
    rd_scene s;
    rd_gpu_scene gs;
    rd_view_camera cam;
    if (f > 0) {
        bool lambertian = rd_hard_case_build(name, &s, c->err, sizeof c->err) && all_lambertian(&s);
        rd_scene_destroy(&s);
        if (!lambertian) {
            *done += 3 + sweep + (a->noise_floor ? 1 : 0) + 1;
            progress(*done, total, label);
            return true;
        }
    }
    if (!rd_procedural_build(spec, &s, c->err, sizeof c->err) ||
        !rd_camera_for_scene(&s, -1, &cam, c->err, sizeof c->err)) {
        fprintf(stderr, "probecast eval: %s: %s\n", label, c->err);
        return false;
    }
    eval_default_lighting(c, label, &s, &cam);
    if (rd_gpu_scene_create(&c->vk, &gs, &s, c->err, sizeof c->err) != RD_VK_OK) {
        fprintf(stderr, "probecast eval: %s: %s\n", label, c->err);
        rd_scene_destroy(&s);
        return false;
    }
    bool ok = true;
    rd_hard_case_pose(name, &s, 4); /* the reference shows the final pose */
    if (rd_gpu_scene_update_instances(&c->vk, &gs, &s, c->err, sizeof c->err) != RD_VK_OK)
        ok = false;
    progress(*done, total, label);
    double ref_ms = 0, noise_ms = 0, noise = 0;
    float *ref = ok ? eval_reference(c, label, &s, &gs, &cam, 1, &ref_ms) : NULL;
    progress(++*done, total, label);
    if (ref && a->noise_floor) {
        float *ref2 = eval_reference(c, label, &s, &gs, &cam, 2, &noise_ms);
        if (ref2) {
            rd_image_error e;
            rd_image_compare(ref2, ref, (size_t)a->width * a->height, &e);
            noise = e.rel_mse;
            free(ref2);
        }
        progress(++*done, total, label);
    }
    if (!ref) {
        fprintf(stderr, "probecast eval: %s: reference failed: %s\n", label, c->err);
        ok = false;
    }
    /* the fitted grid, for density factors */
    rd_ddgi_settings fit = {.mode = PC_GI_DDGI};
    unsigned fitted[3] = {1, 1, 1};
    if (ok && rd_renderer_configure_gi(&c->r, s.bounds_min, s.bounds_max, &fit, c->err,
                                       sizeof c->err) == RD_VK_OK) {
        fitted[0] = c->r.world.ddgi.vol.counts.x, fitted[1] = c->r.world.ddgi.vol.counts.y,
        fitted[2] = c->r.world.ddgi.vol.counts.z;
    }
    for (unsigned k = 0; ok && k < 3 + sweep; k++) {
        eval_row *row = &rows[*nrows];
        memset(row, 0, sizeof *row);
        snprintf(row->scene, sizeof row->scene, "%s", label);
        snprintf(row->expect, sizeof row->expect, "%s", hc->expect);
        rd_ddgi_settings gi = a->base;
        gi.mode = PC_GI_OFF, gi.seed = 1;
        unsigned updates = a->updates[a->nupdates - 1];
        if (k == 2) {
            ok = run_default(c, &s, &gs, &cam, ref, row);
        } else {
            if (k == 0) {
                snprintf(row->mode, sizeof row->mode, "direct");
                snprintf(row->config, sizeof row->config, "direct light only");
            } else if (k == 1) {
                gi.mode = PC_GI_CLASSIC;
                gi.rays = a->rays[a->nrays - 1];
                snprintf(row->mode, sizeof row->mode, "classic");
            } else {
                unsigned j = k - 3, g = j / (a->nrays * a->nupdates * a->nhysteresis);
                gi.mode = PC_GI_DDGI;
                gi.rays = a->rays[(j / (a->nupdates * a->nhysteresis)) % a->nrays];
                updates = a->updates[(j / a->nhysteresis) % a->nupdates];
                gi.hysteresis = a->hysteresis[j % a->nhysteresis];
                gi.has_hysteresis = true; /* 0 too: no history */
                for (int ax = 0; ax < 3; ax++) {
                    double n = a->nprobes ? a->probes[g][ax]
                                          : fmax(1.0, round(fitted[ax] * a->density[g]));
                    gi.counts[ax] = (unsigned)fmin(n, RD_DDGI_MAX_AXIS_PROBES);
                }
                snprintf(row->mode, sizeof row->mode, "ddgi");
            }
            ok = run_setting(c, name, &s, &gs, &cam, &gi, updates, ref, row);
            row->hysteresis = gi.has_hysteresis ? gi.hysteresis : RD_DDGI_DEFAULT_HYSTERESIS;
            if (k >= 1) {
                snprintf(row->config, sizeof row->config, "%s %ux%ux%u r%u u%u h%.2f", row->mode,
                         row->probes[0], row->probes[1], row->probes[2], row->rays, row->updates,
                         row->hysteresis);
                append(row->config, sizeof row->config, a->base_label);
            }
        }
        if (!ok) {
            fprintf(stderr, "\nprobecast eval: %s: %s\n", label, c->err);
            break;
        }
        row->ref_ms = ref_ms;
        row->noise_rel_mse = noise;
        (*nrows)++;
        progress(++*done, total, row->config);
    }
    free(ref);
    rd_gpu_scene_destroy(&c->vk, &gs);
    rd_scene_destroy(&s);
    return ok;
}

static bool case_selected(const char *list, const char *name)
{
    if (!list) return true;
    size_t n = strlen(name);
    for (const char *p = list; (p = strstr(p, name)) != NULL; p += n)
        if ((p == list || p[-1] == ',') && (p[n] == '\0' || p[n] == ',')) return true;
    return false;
}

int cli_eval(int argc, char **argv)
{
    eval_args a;
    int status = parse(argc, argv, &a);
    if (status >= 0) return status;
    unsigned ncases;
    const rd_hard_case *cases = rd_hard_cases(&ncases);
    if (a.replot) {
        char path[1024];
        eval_row *rows = NULL;
        unsigned n = 0;
        snprintf(path, sizeof path, "%s/eval.csv", a.replot);
        if (!eval_read_csv(path, &rows, &n)) {
            fprintf(stderr, "probecast eval: cannot read '%s'\n", path);
            return 1;
        }
        eval_print_table(stdout, rows, n);
        snprintf(path, sizeof path, "%s/eval.svg", a.replot);
        char device[128] = "unknown device";
        snprintf(path, sizeof path, "%s/eval.json", a.replot);
        FILE *jf = fopen(path, "r");
        char head[512] = "";
        if (jf) {
            size_t got = fread(head, 1, sizeof head - 1, jf);
            head[got] = '\0';
            fclose(jf);
            const char *d = strstr(head, "\"device\": \"");
            if (d) sscanf(d + 11, "%127[^\"]", device);
        }
        snprintf(path, sizeof path, "%s/eval.svg", a.replot);
        bool ok = eval_write_svg(path, rows, n, device);
        free(rows);
        return ok ? 0 : 1;
    }
    if (a.list) {
        for (unsigned i = 0; i < ncases; i++)
            printf("%-14s %s\n", cases[i].name, cases[i].expect);
        return 0;
    }
    char cache[1024];
    if (!a.cache_dir) {
        snprintf(cache, sizeof cache, "%s/cache", a.out_dir);
        a.cache_dir = cache;
    }
    if ((mkdir(a.out_dir, 0755) != 0 && errno != EEXIST) ||
        (mkdir(a.cache_dir, 0755) != 0 && errno != EEXIST)) {
        fprintf(stderr, "probecast eval: cannot create '%s': %s\n", a.out_dir, strerror(errno));
        return 1;
    }
    for (const char *p = a.cases; p && *p;) { /* every named case must exist */
        size_t len = strcspn(p, ",");
        bool found = false;
        for (unsigned i = 0; i < ncases; i++)
            if (strlen(cases[i].name) == len && strncmp(cases[i].name, p, len) == 0) found = true;
        if (!found) {
            fprintf(stderr, "probecast eval: unknown case '%.*s' (see --list)\n", (int)len, p);
            return 2;
        }
        p += len + (p[len] == ',');
    }

    eval_ctx c = {.a = &a};
    rd_vk_options vo = {.device = a.device};
    if (rd_vk_create(&c.vk, &vo, c.err, sizeof c.err) != RD_VK_OK) {
        fprintf(stderr, "probecast: %s\n", c.err);
        return 1;
    }
    if (rd_renderer_create(&c.vk, &c.r, c.err, sizeof c.err) != RD_VK_OK) {
        fprintf(stderr, "probecast: %s\n", c.err);
        rd_vk_destroy(&c.vk);
        return 1;
    }
    if (a.dynamic) {
        int drc = eval_dynamic_run(&c);
        rd_renderer_destroy(&c.r);
        unsigned validation = rd_vk_validation_messages(&c.vk);
        rd_vk_destroy(&c.vk);
        if (drc == 0 && validation) {
            fprintf(stderr, "probecast eval: %u Vulkan validation message(s)\n", validation);
            drc = 1;
        }
        return drc;
    }
    unsigned ngrids = a.nprobes ? a.nprobes : a.ndensity;
    unsigned sweep = ngrids * a.nrays * a.nupdates * a.nhysteresis;
    unsigned per_case = 3 + sweep + (a.noise_floor ? 1 : 0) + 1;
    unsigned selected = 0, nfamilies = 0;
    for (unsigned f = 0; f < 3; f++)
        nfamilies += (a.families >> f) & 1u;
    for (unsigned i = 0; i < ncases; i++)
        selected += case_selected(a.cases, cases[i].name) * nfamilies;
    unsigned total = selected * per_case, done = 0, nrows = 0;
    eval_row *rows = calloc((size_t)selected * per_case, sizeof *rows);
    if (!rows) abort();
    int rc = 0;
    for (unsigned ci = 0; ci < ncases && rc == 0; ci++) {
        if (!case_selected(a.cases, cases[ci].name)) continue;
        for (unsigned f = 0; f < 3 && rc == 0; f++)
            if (a.families & (1u << f))
                rc = run_case(&c, &cases[ci], f, rows, &nrows, &done, total) ? 0 : 1;
    }
    if (rc == 0) {
        char path[1024];
        eval_mark_pareto(rows, nrows);
        eval_print_table(stdout, rows, nrows);
        snprintf(path, sizeof path, "%s/eval.csv", a.out_dir);
        bool ok = eval_write_csv(path, rows, nrows);
        snprintf(path, sizeof path, "%s/eval.json", a.out_dir);
        ok = ok &&
             eval_write_json(path, rows, nrows, c.vk.device_name, a.width, a.height, a.ref_spp);
        snprintf(path, sizeof path, "%s/eval.svg", a.out_dir);
        ok = ok && eval_write_svg(path, rows, nrows, c.vk.device_name);
        if (!ok) {
            fprintf(stderr, "probecast eval: cannot write results to '%s'\n", a.out_dir);
            rc = 1;
        } else {
            printf("wrote %s/eval.csv, eval.json, eval.svg (%s)\n", a.out_dir, c.vk.device_name);
        }
    }
    free(rows);
    rd_renderer_destroy(&c.r);
    unsigned validation = rd_vk_validation_messages(&c.vk);
    rd_vk_destroy(&c.vk);
    if (rc == 0 && validation) {
        fprintf(stderr, "probecast eval: %u Vulkan validation message(s)\n", validation);
        rc = 1;
    }
    return rc;
}
