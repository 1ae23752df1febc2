/* Probe states and convergence (renderer/gi/ddgi.c): a field converges by its own measure and then
 * does no probe work at all; moving one small object wakes only the probes around it; a light
 * change wakes every probe; the atlases stay finite throughout; a field that keeps drifting still
 * sleeps within rd_ddgi_sleep_bound. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/scene/mesh_builder.h"
#include "renderer/world.h"
#include "test_render_util.h"
#include "test_util.h"

static rd_vk vk;
static char err[512];

/* A 12 x 12 m floor, a 0.3 m box standing on it (its own node) and a point light. */
static uint32_t build_scene(rd_scene *s)
{
    rd_scene_init(s);
    uint32_t white = rd_build_material(s, "white", 0.8f, 0.8f, 0.8f, 0, 0, 0);
    rd_tri_list t = {0};
    const float a[3] = {-6, 0, 6}, b[3] = {6, 0, 6}, c[3] = {6, 0, -6}, d[3] = {-6, 0, -6};
    rd_tris_quad(&t, a, b, c, d, white);
    const float wlo[3] = {-6, 0, -6.2f}, whi[3] = {6, 3, -6}; /* a back wall: bounds 3 m high */
    rd_tris_box(&t, wlo, whi, white);
    rd_tris_commit(&t, s, "floor");
    const float lo[3] = {-0.15f, 0, -0.15f}, hi[3] = {0.15f, 0.3f, 0.15f};
    rd_tris_box(&t, lo, hi, white);
    uint32_t box = rd_tris_commit(&t, s, "box");
    s->nodes[box].translation[0] = 2.0f;
    rd_build_point_light(s, 0, 2.5f, 0, 60);
    CHECK(rd_scene_update(s, err, sizeof err));
    return box;
}

/* Probes whose grid position lies within one spacing of [lo, hi] (what a wake box reaches). */
static unsigned probes_near(const rd_ddgi *d, const float lo[3], const float hi[3])
{
    const pc_ddgi_volume *v = &d->vol;
    unsigned n = 0;
    for (unsigned z = 0; z < v->counts.z; z++)
        for (unsigned y = 0; y < v->counts.y; y++)
            for (unsigned x = 0; x < v->counts.x; x++) {
                float p[3] = {v->origin.x + x * v->spacing.x, v->origin.y + y * v->spacing.y,
                              v->origin.z + z * v->spacing.z};
                const float sp[3] = {v->spacing.x, v->spacing.y, v->spacing.z};
                bool in = true;
                for (int k = 0; k < 3; k++)
                    in = in && p[k] >= lo[k] - sp[k] && p[k] <= hi[k] + sp[k];
                n += in;
            }
    return n;
}

static bool atlases_finite(rd_ddgi *d)
{
    float *irr, *dist;
    unsigned iw, ih, dw, dh;
    if (rd_ddgi_read_atlases(d, &irr, &iw, &ih, &dist, &dw, &dh, err, sizeof err) != RD_VK_OK)
        return false;
    bool ok = true;
    for (size_t i = 0; i < (size_t)iw * ih * 3; i++)
        ok = ok && isfinite(irr[i]);
    for (size_t i = 0; i < (size_t)dw * dh * 3; i++)
        ok = ok && isfinite(dist[i]);
    free(irr);
    free(dist);
    return ok;
}

/* The most off probes one update re-checks: off probes of one index residue modulo
 * PC_DDGI_OFF_RECHECK (each is re-checked once in that many updates, by its index). */
static unsigned off_recheck_max(rd_ddgi *d)
{
    rd_ddgi_probe_info *probes = NULL;
    unsigned due[PC_DDGI_OFF_RECHECK] = {0}, most = 0, n = rd_ddgi_probe_count(d);
    if (rd_ddgi_read_probes(d, &probes, err, sizeof err) != RD_VK_OK) return 0;
    for (unsigned i = 0; i < n; i++)
        if (!(probes[i].state & PC_DDGI_PROBE_ACTIVE)) due[i % PC_DDGI_OFF_RECHECK]++;
    for (unsigned r = 0; r < PC_DDGI_OFF_RECHECK; r++)
        most = due[r] > most ? due[r] : most;
    free(probes);
    return most;
}

static void test_probe_states(void)
{
    rd_scene s;
    uint32_t box = build_scene(&s);
    rd_gpu_scene gs;
    rd_world w;
    CHECKF(rd_gpu_scene_create(&vk, &gs, &s, err, sizeof err) == RD_VK_OK, "%s", err);
    CHECKF(rd_world_create(&vk, &w, err, sizeof err) == RD_VK_OK, "%s", err);
    rd_world_set_scene(&w, &gs);
    /* 16 x 4 x 16 probes, few rays and a low maximum hysteresis keep lavapipe quick */
    rd_ddgi_settings gi = {.mode = PC_GI_DDGI,
                           .counts = {16, 4, 16},
                           .rays = 32,
                           .hysteresis = 0.5f,
                           .has_hysteresis = true,
                           .seed = 3};
    CHECKF(rd_world_configure_gi(&w, s.bounds_min, s.bounds_max, &gi, err, sizeof err) == RD_VK_OK,
           "%s", err);
    unsigned total = rd_ddgi_probe_count(&w.ddgi), done = 0;
    CHECK(!rd_world_converged(&w)); /* a fresh field wants updates */

    /* 1. converges by its own measure, within a bound */
    CHECKF(rd_world_converge(&w, 500, &done, err, sizeof err) == RD_VK_OK, "%s", err);
    const rd_ddgi_census *c = &w.ddgi.census;
    printf("converged after %u updates: %u asleep, %u off of %u\n", done, c->sleeping, c->off,
           total);
    CHECKF(rd_world_converged(&w), "not converged after %u updates (%u awake)", done, c->awake);
    CHECK(done >= rd_ddgi_sleep_age(0.5f)); /* nobody sleeps before its hysteresis settled */
    CHECK(c->awake == 0 && c->sleeping + c->off == total && c->sleeping > total / 2);

    /* the grid's back layer lies in the 0.2 m back wall (its outermost layers stand 0.15 of a
     * spacing inside the bounds): those probes are off, and an update re-checks each of them
     * once every PC_DDGI_OFF_RECHECK updates with PC_DDGI_INACTIVE_RAYS rays, unshaded */
    unsigned recheck = off_recheck_max(&w.ddgi);

    /* 2. a converged field does no probe work: no awake probe is listed, no probe is shaded;
     * only off probes due for their re-check trace their few rays */
    for (int u = 0; u < 2; u++) {
        CHECKF(rd_world_update(&w, 1, err, sizeof err) == RD_VK_OK, "%s", err);
        CHECKF(c->updated <= recheck &&
                   w.stats.rays.probe_rays == c->updated * PC_DDGI_INACTIVE_RAYS &&
                   w.stats.rays.probe_shadow_rays == 0,
               "converged field still works: %u probes (%u off re-checks at most), %u rays",
               c->updated, recheck, w.stats.rays.probe_rays);
    }
    CHECK(rd_world_converged(&w));

    /* 3. moving the small box wakes the probes around its old and new place, no others */
    float old_lo[3], old_hi[3], lo[3], hi[3];
    for (int k = 0; k < 3; k++) {
        old_lo[k] = gs.mesh_bounds[6 * s.instances[1].mesh + k] + s.nodes[box].translation[k];
        old_hi[k] = gs.mesh_bounds[6 * s.instances[1].mesh + 3 + k] + s.nodes[box].translation[k];
    }
    s.nodes[box].translation[0] += 0.5f;
    CHECK(rd_scene_update(&s, err, sizeof err));
    CHECKF(rd_gpu_scene_update_instances(&vk, &gs, &s, err, sizeof err) == RD_VK_OK, "%s", err);
    for (int k = 0; k < 3; k++)
        lo[k] = old_lo[k], hi[k] = old_hi[k];
    lo[0] += 0.5f, hi[0] += 0.5f;
    rd_world_wake_box(&w, old_lo, old_hi, PC_DDGI_WAKE_AGE_GEOMETRY);
    rd_world_wake_box(&w, lo, hi, PC_DDGI_WAKE_AGE_GEOMETRY);
    CHECK(!rd_world_converged(&w));
    float u_lo[3] = {old_lo[0], old_lo[1], old_lo[2]}, u_hi[3] = {hi[0], hi[1], hi[2]};
    unsigned near = probes_near(&w.ddgi, u_lo, u_hi);
    CHECKF(rd_world_update(&w, 1, err, sizeof err) == RD_VK_OK, "%s", err);
    printf("box moved: %u probes updated (%u within a spacing of it), %u of %u awake\n", c->updated,
           near, c->awake, total);
    CHECKF(c->updated > 0 && c->updated <= near + recheck,
           "%u probes updated, %u near the box, %u off re-checks at most", c->updated, near,
           recheck);
    CHECKF(near * 10 < total, "the wake box covers %u of %u probes: not a local test", near, total);
    CHECK(w.stats.rays.probe_rays <= near * gi.rays + recheck * PC_DDGI_INACTIVE_RAYS);
    CHECKF(rd_world_converge(&w, 500, &done, err, sizeof err) == RD_VK_OK, "%s", err);
    CHECKF(rd_world_converged(&w), "not converged again after %u updates", done);

    /* 4. a light change wakes every probe; off ones are re-checked */
    s.lights[0].intensity *= 2;
    CHECKF(rd_gpu_scene_update_lights(&vk, &gs, &s, err, sizeof err) == RD_VK_OK, "%s", err);
    rd_world_wake_all(&w, PC_DDGI_WAKE_AGE_LIGHT);
    CHECKF(rd_world_update(&w, 1, err, sizeof err) == RD_VK_OK, "%s", err);
    CHECKF(c->updated == total, "light change: %u of %u probes updated", c->updated, total);
    CHECKF(rd_world_converge(&w, 500, &done, err, sizeof err) == RD_VK_OK, "%s", err);
    CHECK(rd_world_converged(&w));
    CHECK(atlases_finite(&w.ddgi));

    /* 5. a field that never stops drifting (the light brightens 3% every update and nobody
     * calls a wake) holds its ages, but only for PC_DDGI_HOLD_FACTOR sleep ages: it sleeps at
     * the bound (a coarse grid: this part only counts updates) */
    gi.counts[0] = gi.counts[2] = 4, gi.counts[1] = 2;
    CHECKF(rd_world_configure_gi(&w, s.bounds_min, s.bounds_max, &gi, err, sizeof err) == RD_VK_OK,
           "%s", err);
    unsigned bound = rd_ddgi_sleep_bound(0.5f), n = 0, held = 0;
    while (!rd_world_converged(&w) && n < 2 * bound) {
        s.lights[0].intensity *= 1.03f;
        CHECKF(rd_gpu_scene_update_lights(&vk, &gs, &s, err, sizeof err) == RD_VK_OK, "%s", err);
        CHECKF(rd_world_update(&w, 1, err, sizeof err) == RD_VK_OK, "%s", err);
        held += w.ddgi.hold;
        n++;
    }
    printf("drifting field: asleep after %u updates (held %u; sleep age %g, bound %u)\n", n, held,
           (double)rd_ddgi_sleep_age(0.5f), bound);
    CHECKF(rd_world_converged(&w) && n <= bound, "drifting field: %u updates, bound %u", n, bound);
    CHECKF(n > bound / 2, "drifting field slept after %u updates: its drift held nothing", n);

    rd_world_destroy(&w);
    rd_gpu_scene_destroy(&vk, &gs);
    rd_scene_destroy(&s);
}

int main(void)
{
    if (!test_vk_open(&vk)) return test_finish();
    test_probe_states();
    return test_vk_close(&vk);
}
