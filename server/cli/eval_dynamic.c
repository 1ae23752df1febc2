/* eval_dynamic.c: probecast eval --dynamic. A converged probe field meets a change (a light
 * moves, an object moves); the change wakes probes as the daemon's would, and the field is
 * followed update by update until it sleeps again: at fixed update counts the image is compared
 * with the path-traced reference of the new state. Reported per checkpoint: updates since the
 * change, GPU ms of those updates, probes awake, relMSE and mean-luminance bias. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "server/cli/eval_internal.h"
#include "renderer/builtin/hard_cases.h"
#include "server/cli/image_metrics.h"
#include "renderer/builtin/procedural.h"

#define DYN_CAP 3000 /* updates before giving up on convergence */

typedef struct dyn_row {
    const char *name;
    unsigned updates; /* since the change (0: the converged field of the old state) */
    double gpu_ms;    /* GPU time of those updates */
    unsigned awake, total;
    bool converged;
    double rel_mse, bias;
} dyn_row;

typedef struct dyn_case {
    const char *name, *scene, *change;
} dyn_case;

static const dyn_case CASES[] = {
    {"light-move", "white-room", "the point light moves 0.9 m across the closed white room"},
    {"object-move", "hard:moving", "the sphere moves to the moving case's final pose"},
};

static bool is_checkpoint(unsigned u)
{
    return u == 0 || (u & (u - 1)) == 0; /* 0, 1, 2, 4, 8, ... */
}

static double mean_lum(const float *rgb, size_t px)
{
    double s = 0;
    for (size_t i = 0; i < px; i++)
        s += 0.2126 * rgb[3 * i] + 0.7152 * rgb[3 * i + 1] + 0.0722 * rgb[3 * i + 2];
    return px ? s / px : 0;
}

/* Renders the view of the field as it is (no update) and compares it with ref. */
static bool measure(eval_ctx *c, const rd_view_camera *cam, const float *ref, dyn_row *row)
{
    const eval_args *a = c->a;
    rd_view_settings vs = {.width = a->width,
                           .height = a->height,
                           .seed = 1,
                           .near_field = a->near_field,
                           .shadow_cull = a->shadow_cull,
                           .reflections = a->reflections};
    if (rd_view_render_still(&c->r.view, &c->r.world, cam, &vs, c->err, sizeof c->err) != RD_VK_OK)
        return false;
    size_t px = (size_t)a->width * a->height;
    float *img = malloc(px * 12);
    if (!img) abort();
    bool ok = rd_view_read_hdr(&c->r.view, img, c->err, sizeof c->err) == RD_VK_OK;
    if (ok) {
        rd_image_error e;
        rd_image_compare(img, ref, px, &e);
        row->rel_mse = e.rel_mse;
        double m = mean_lum(img, px), mr = mean_lum(ref, px);
        row->bias = mr > 0 ? m / mr - 1 : 0;
    }
    free(img);
    const rd_ddgi *d = &c->r.world.ddgi;
    row->awake = d->census.awake;
    row->total = rd_ddgi_probe_count(d);
    row->converged = rd_world_converged(&c->r.world);
    return ok;
}

/* Applies the case's change to s and gs and wakes the probes it reaches. */
static bool change(eval_ctx *c, const dyn_case *dc, rd_scene *s, rd_gpu_scene *gs)
{
    rd_world *w = &c->r.world;
    if (strcmp(dc->name, "light-move") == 0) {
        rd_light *l = &s->lights[0];
        l->position[0] = -0.5f, l->position[1] = 1.2f, l->position[2] = -0.4f;
        rd_world_wake_all(w, PC_DDGI_WAKE_AGE_LIGHT);
        return rd_gpu_scene_update_lights(&c->vk, gs, s, c->err, sizeof c->err) == RD_VK_OK;
    }
    /* object: wake around every instance's old and new bounds */
    float(*old)[6] = calloc(s->instance_count ? s->instance_count : 1, sizeof *old);
    if (!old) abort();
    for (uint32_t i = 0; i < s->instance_count; i++)
        rd_gpu_scene_instance_bounds(gs, s, i, old[i], old[i] + 3);
    rd_hard_case_pose("moving", s, 4);
    bool ok = rd_gpu_scene_update_instances(&c->vk, gs, s, c->err, sizeof c->err) == RD_VK_OK;
    for (uint32_t i = 0; ok && i < s->instance_count; i++) {
        float lo[3], hi[3];
        rd_gpu_scene_instance_bounds(gs, s, i, lo, hi);
        if (memcmp(lo, old[i], sizeof lo) == 0 && memcmp(hi, old[i] + 3, sizeof hi) == 0)
            continue; /* this instance did not move */
        rd_world_wake_box(w, old[i], old[i] + 3, PC_DDGI_WAKE_AGE_GEOMETRY);
        rd_world_wake_box(w, lo, hi, PC_DDGI_WAKE_AGE_GEOMETRY);
    }
    free(old);
    return ok;
}

/* Builds the case's scene in its first state (gs uploaded), with its default lighting. */
static bool build(eval_ctx *c, const dyn_case *dc, rd_scene *s, rd_gpu_scene *gs,
                  rd_view_camera *cam)
{
    if (!rd_procedural_build(dc->scene, s, c->err, sizeof c->err)) return false;
    if (strcmp(dc->name, "object-move") == 0) rd_hard_case_pose("moving", s, 0);
    if (!rd_camera_for_scene(s, -1, cam, c->err, sizeof c->err)) {
        rd_scene_destroy(s);
        return false;
    }
    eval_default_lighting(c, dc->name, s, cam);
    rd_world_set_environment(&c->r.world, &c->env); /* the field converges under it */
    if (rd_gpu_scene_create(&c->vk, gs, s, c->err, sizeof c->err) != RD_VK_OK) {
        rd_scene_destroy(s);
        return false;
    }
    return true;
}

static bool run_case(eval_ctx *c, const dyn_case *dc, dyn_row *rows, unsigned *nrows,
                     unsigned max_rows)
{
    rd_scene s;
    rd_gpu_scene gs;
    rd_view_camera cam;
    /* the reference of the state after the change (rendered first: it turns GI off) */
    if (!build(c, dc, &s, &gs, &cam)) return false;
    double ref_ms = 0;
    char refname[64];
    snprintf(refname, sizeof refname, "dynamic-%s", dc->name);
    rd_world *w = &c->r.world;
    rd_world_set_scene(w, &gs);
    bool ok = change(c, dc, &s, &gs);
    float *ref = ok ? eval_reference(c, refname, &s, &gs, &cam, 1, &ref_ms) : NULL;
    rd_gpu_scene_destroy(&c->vk, &gs);
    rd_scene_destroy(&s);
    if (!ref) return false;

    /* the field converges in the first state, then follows the change */
    if (!build(c, dc, &s, &gs, &cam)) {
        free(ref);
        return false;
    }
    rd_world_set_scene(w, &gs);
    rd_ddgi_settings gi = c->a->base; /* the defaults, but for eval's unswept flags */
    gi.mode = PC_GI_DDGI, gi.seed = 1;
    unsigned done = 0;
    double ms = 0;
    ok = rd_world_configure_gi(w, s.bounds_min, s.bounds_max, &gi, c->err, sizeof c->err) ==
         RD_VK_OK;
    ok = ok && rd_world_converge(w, DYN_CAP, &done, c->err, sizeof c->err) == RD_VK_OK;
    ms = rd_frame_stats_total_ms(&w->stats);
    if (ok)
        printf("%s: %s\n  from cold: converged after %u updates, %.1f ms of GPU time\n", dc->name,
               dc->change, done, ms);
    ok = ok && change(c, dc, &s, &gs);
    unsigned u = 0;
    ms = 0;
    while (ok && *nrows < max_rows) {
        if (is_checkpoint(u) || rd_world_converged(w) || u == DYN_CAP) {
            dyn_row *r = &rows[(*nrows)++];
            memset(r, 0, sizeof *r);
            r->name = dc->name;
            r->updates = u;
            r->gpu_ms = ms;
            ok = measure(c, &cam, ref, r);
            if (!ok || r->converged || u == DYN_CAP) break;
        }
        ok = rd_world_update(w, 1, c->err, sizeof c->err) == RD_VK_OK;
        ms += rd_frame_stats_total_ms(&w->stats);
        u++;
    }
    free(ref);
    rd_world_set_scene(w, NULL);
    rd_gpu_scene_destroy(&c->vk, &gs);
    rd_scene_destroy(&s);
    return ok;
}

int eval_dynamic_run(eval_ctx *c)
{
    const eval_args *a = c->a;
    unsigned ncases = sizeof CASES / sizeof CASES[0], max_rows = 64 * ncases, n = 0;
    dyn_row *rows = calloc(max_rows, sizeof *rows);
    if (!rows) abort();
    int rc = 0;
    for (unsigned i = 0; i < ncases && rc == 0; i++) {
        unsigned first = n;
        if (!run_case(c, &CASES[i], rows, &n, n + 64)) {
            fprintf(stderr, "probecast eval: %s: %s\n", CASES[i].name, c->err);
            rc = 1;
            break;
        }
        printf("  %-8s %10s %8s %8s %10s\n", "updates", "GPU ms", "awake", "relMSE", "bias");
        for (unsigned k = first; k < n; k++)
            printf("  %-8u %10.2f %8u %8.4f %+9.2f%%%s\n", rows[k].updates, rows[k].gpu_ms,
                   rows[k].awake, rows[k].rel_mse, 100 * rows[k].bias,
                   rows[k].converged ? "  converged" : "");
    }
    if (rc == 0) {
        char path[1024];
        snprintf(path, sizeof path, "%s/eval-dynamic.csv", a->out_dir);
        FILE *f = fopen(path, "w");
        if (!f) {
            fprintf(stderr, "probecast eval: cannot write '%s': %s\n", path, strerror(errno));
            rc = 1;
        } else {
            fprintf(f, "case,updates_after_change,gpu_ms,awake,probes,converged,rel_mse,bias,"
                       "device,width,height,ref_spp\n");
            for (unsigned k = 0; k < n; k++)
                fprintf(f, "%s,%u,%.4f,%u,%u,%d,%.6g,%.6g,\"%s\",%u,%u,%u\n", rows[k].name,
                        rows[k].updates, rows[k].gpu_ms, rows[k].awake, rows[k].total,
                        rows[k].converged, rows[k].rel_mse, rows[k].bias, c->vk.device_name,
                        a->width, a->height, a->ref_spp);
            fclose(f);
            printf("wrote %s (%s)\n", path, c->vk.device_name);
        }
    }
    free(rows);
    return rc;
}
