/* test_gpu_direct_light.c: the one-shadow-ray direct light of probe hits
 * (direct_radiance_sampled, shaders/common.glsl) is unbiased. On the many-lights hard case (the
 * Cornell box with four coloured lights, some hidden from some points by the blocks), rays from
 * the room's centre hit every surface; at each hit shaders/test_direct.comp returns the
 * all-lights sum with one shadow ray per light (direct_radiance) and the mean of the one-ray
 * estimate over n stratified choices u = (k + 1/2) / n. choose_light's one-pass choice (each
 * light takes u below w_i / (w_0 + ... + w_i) and u is rescaled) cuts [0, 1) into at most
 * 2^(L-1) intervals for L lights, each giving one light; stratification puts a number of
 * choices within 1 of n times its length into each interval, and a choice is worth at most W
 * per channel (its term divided by its probability), W the summed RGB of the unshadowed
 * terms. So the mean may differ from the sum by at most 2^(L-1) * W / n per channel: a biased
 * estimator (say, one that forgot to divide by the probability of its choice) misses by a
 * fraction of W.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/builtin/hard_cases.h"
#include "renderer/world.h"
#include "shaders/test_direct.spv.h"
#include "test_render_util.h"
#include "test_util.h"

/* 256 choices per hit: on lavapipe (Mesa 22.3) one invocation stopped tracing after about 850
 * calls of direct_radiance_sampled (844 of 4096, 861 of 1024; all of 16 and 256). */
enum { RAYS = 2048, CHOICES = 256 };

static char err[512];

int main(void)
{
    rd_vk vk;
    if (!test_vk_open(&vk)) return test_finish();
    rd_scene scene;
    if (!rd_hard_case_build("many-lights", &scene, err, sizeof err)) {
        CHECKF(false, "many-lights: %s", err);
        return test_vk_close(&vk);
    }
    const uint32_t lights = scene.light_count;
    CHECKF(lights >= 3 && lights <= 16, "many-lights has %u lights", lights);

    rd_gpu_scene gs = {0};
    rd_world world = {0};
    rd_pipeline pipe = {0};
    rd_buffer b_globals = {0}, b_rays = {0}, b_out = {0};
    float *rays = malloc(RAYS * 8 * sizeof(float));
    float *out = malloc(RAYS * 8 * sizeof(float));
    VK_CHECK(rd_gpu_scene_create(&vk, &gs, &scene, err, sizeof err));
    VK_CHECK(rd_world_create(&vk, &world, err, sizeof err));
    rd_world_set_scene(&world, &gs);
    pc_globals g = {0};
    rd_world_fill_globals(&world, &g);

    /* origins within 10 cm of the room's centre (the GPU frame's origin), directions uniform */
    uint32_t s = 12345u;
    for (int i = 0; i < RAYS; i++) {
        float r[5];
        for (int k = 0; k < 5; k++) {
            s = s * 1664525u + 1013904223u;
            r[k] = (float)(s >> 8) / 16777216.0f;
        }
        float z = 1.0f - 2.0f * r[0], phi = 6.2831853f * r[1], sxy = sqrtf(fmaxf(0.0f, 1 - z * z));
        float *o = rays + 8 * i;
        o[0] = 0.2f * (r[2] - 0.5f), o[1] = 0.2f * (r[3] - 0.5f), o[2] = 0.2f * (r[4] - 0.5f);
        o[3] = 0;
        o[4] = sxy * cosf(phi), o[5] = sxy * sinf(phi), o[6] = z, o[7] = 0;
    }
    VK_CHECK(rd_pipeline_create(&vk, &pipe, "test_direct", pc_spv_test_direct,
                                sizeof pc_spv_test_direct, sizeof(pc_push), err, sizeof err));
    VK_CHECK(rd_buffer_create(&vk, &b_globals, sizeof g, RD_MEMORY_DEVICE, err, sizeof err));
    VK_CHECK(rd_buffer_upload(&vk, &b_globals, 0, &g, sizeof g, err, sizeof err));
    VK_CHECK(rd_buffer_create(&vk, &b_rays, RAYS * 8 * sizeof(float), RD_MEMORY_DEVICE, err,
                              sizeof err));
    VK_CHECK(rd_buffer_upload(&vk, &b_rays, 0, rays, RAYS * 8 * sizeof(float), err, sizeof err));
    VK_CHECK(rd_buffer_create(&vk, &b_out, RAYS * 8 * sizeof(float), RD_MEMORY_READBACK, err,
                              sizeof err));
    rd_cmd c;
    VK_CHECK(rd_cmd_begin(&vk, &c, err, sizeof err));
    pc_push push = {.globals = b_globals.address,
                    .buf0 = b_rays.address,
                    .buf1 = b_out.address,
                    .params = {RAYS, CHOICES, 0, 0}};
    rd_cmd_dispatch(&c, &pipe, &push, (RAYS + PC_WG_1D - 1) / PC_WG_1D, 1, 1);
    rd_cmd_barrier(&c);
    VK_CHECK(rd_cmd_submit_wait(&vk, &c, err, sizeof err));
    VK_CHECK(rd_buffer_download(&vk, &b_out, 0, out, RAYS * 8 * sizeof(float), err, sizeof err));

    int hits = 0, lit = 0, partly_shadowed = 0, bad = 0;
    double worst = 0;
    for (int i = 0; i < RAYS; i++) {
        const float *exact = out + 8 * i, *mean = out + 8 * i + 4;
        float total = exact[3];
        if (total < 0) continue;
        hits++;
        float sum = exact[0] + exact[1] + exact[2];
        if (total > 0) lit++;
        if (sum > 0.02f * total && sum < 0.98f * total) partly_shadowed++;
        double tol = ldexp(1.0, (int)lights - 1) * total / CHOICES + 1e-6 * total + 1e-12;
        for (int k = 0; k < 3; k++) {
            double d = fabs((double)mean[k] - exact[k]);
            if (!(d <= tol)) bad++;
            if (total > 0 && d / total > worst) worst = d / total;
        }
        /* one shadow ray per choice, and none where no light reaches */
        CHECKF(mean[3] == (total > 0 ? (float)CHOICES : 0.0f), "ray %d: %g shadow rays, total %g",
               i, mean[3], total);
    }
    printf("%d hits of %d rays, %d lit, %d partly shadowed; worst |mean - sum| / W = %.3g "
           "(bound %u / %d)\n",
           hits, RAYS, lit, partly_shadowed, worst, lights > 0 ? 1u << (lights - 1) : 0u, CHOICES);
    CHECKF(hits > RAYS / 2, "only %d of %d rays hit", hits, RAYS);
    CHECKF(lit > hits / 2, "only %d of %d hits are lit", lit, hits);
    CHECKF(partly_shadowed > hits / 20, "only %d hits see some lights and not others",
           partly_shadowed);
    CHECKF(bad == 0, "%d channels: the one-ray mean misses the all-lights sum", bad);

done:
    rd_buffer_destroy(&vk, &b_globals);
    rd_buffer_destroy(&vk, &b_rays);
    rd_buffer_destroy(&vk, &b_out);
    rd_pipeline_destroy(&vk, &pipe);
    rd_world_destroy(&world);
    rd_gpu_scene_destroy(&vk, &gs);
    rd_scene_destroy(&scene);
    free(rays);
    free(out);
    return test_vk_close(&vk);
}
