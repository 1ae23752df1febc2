/* DDGI on lavapipe at tiny sizes (validation layer on): octahedral round trip, border texels
 * equal their octahedral wrap source, the ray set is uniform, the closed furnace converges to
 * Le/(1-rho), a thin wall stops light with visibility while classic probes leak, no NaN/Inf,
 * and the same seed gives the same image. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/builtin/procedural.h"
#include "shaders/test_ddgi_math.spv.h"
#include "test_render_util.h"
#include "test_util.h"

static rd_vk vk;
static char err[512];

static void test_octahedral_and_rays(void)
{
    enum { N = 4096 };
    rd_pipeline p;
    rd_buffer in, out, globals;
    CHECKF(rd_pipeline_create(&vk, &p, "test ddgi math", pc_spv_test_ddgi_math,
                              sizeof pc_spv_test_ddgi_math, sizeof(pc_push), err,
                              sizeof err) == RD_VK_OK,
           "%s", err);
    CHECK(rd_buffer_create(&vk, &in, N * 16, RD_MEMORY_UPLOAD, err, sizeof err) == RD_VK_OK);
    CHECK(rd_buffer_create(&vk, &out, N * 16, RD_MEMORY_READBACK, err, sizeof err) == RD_VK_OK);
    CHECK(rd_buffer_create(&vk, &globals, sizeof(pc_globals), RD_MEMORY_UPLOAD, err, sizeof err) ==
          RD_VK_OK);
    /* directions: random, the 6 axes, and the octahedron's edges (x or y or z = 0) */
    float *dirs = in.mapped;
    uint64_t state = 12345;
    for (int i = 0; i < N; i++) {
        float v[3];
        if (i < 6) {
            v[0] = v[1] = v[2] = 0;
            v[i / 2] = (i & 1) ? -1.0f : 1.0f;
        } else {
            float rot[3][3];
            rd_ddgi_random_rotation(&state, rot);
            memcpy(v, rot[0], sizeof v);
            if (i % 7 == 0) v[i % 3] = 0;
        }
        float len = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        for (int k = 0; k < 3; k++)
            dirs[i * 4 + k] = v[k] / len;
        dirs[i * 4 + 3] = 0;
    }
    rd_cmd c;
    pc_push push = {.globals = globals.address,
                    .buf0 = in.address,
                    .buf1 = out.address,
                    .params = {0, N, 0, 0}};
    CHECK(rd_cmd_begin(&vk, &c, err, sizeof err) == RD_VK_OK);
    rd_cmd_dispatch(&c, &p, &push, N / PC_WG_1D, 1, 1);
    rd_cmd_barrier(&c);
    CHECK(rd_cmd_submit_wait(&vk, &c, err, sizeof err) == RD_VK_OK);
    const float *res = out.mapped;
    double worst = 0;
    for (int i = 0; i < N; i++) {
        double dot = 0;
        for (int k = 0; k < 3; k++)
            dot += (double)res[i * 4 + k] * dirs[i * 4 + k];
        if (1 - dot > worst) worst = 1 - dot;
    }
    CHECKF(worst < 1e-5, "octahedral round trip error %g", worst);

    /* ray sets: mean direction ~ 0 and each hemisphere (of several axes) holds ~ half */
    unsigned counts[] = {64, 256, 1000};
    for (int t = 0; t < 3; t++) {
        pc_globals g;
        memset(&g, 0, sizeof g);
        g.ddgi.counts.w = counts[t];
        float rot[3][3];
        rd_ddgi_random_rotation(&state, rot);
        for (int r = 0; r < 3; r++)
            g.ddgi.rotation[r] = (pc_vec4){rot[r][0], rot[r][1], rot[r][2], 0};
        memcpy(globals.mapped, &g, sizeof g);
        push.params.x = 1;
        CHECK(rd_cmd_begin(&vk, &c, err, sizeof err) == RD_VK_OK);
        rd_cmd_dispatch(&c, &p, &push, (counts[t] + PC_WG_1D - 1) / PC_WG_1D, 1, 1);
        rd_cmd_barrier(&c);
        CHECK(rd_cmd_submit_wait(&vk, &c, err, sizeof err) == RD_VK_OK);
        double mean[3] = {0, 0, 0};
        const float axes[4][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.577f, 0.577f, 0.577f}};
        unsigned upper[4] = {0, 0, 0, 0};
        for (unsigned i = 0; i < counts[t]; i++) {
            const float *d = &res[i * 4];
            CHECK(fabs(sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) - 1) < 1e-5);
            for (int k = 0; k < 3; k++)
                mean[k] += d[k] / counts[t];
            for (int a = 0; a < 4; a++)
                if (d[0] * axes[a][0] + d[1] * axes[a][1] + d[2] * axes[a][2] > 0) upper[a]++;
        }
        double mlen = sqrt(mean[0] * mean[0] + mean[1] * mean[1] + mean[2] * mean[2]);
        CHECKF(mlen < 0.02, "%u rays: mean direction length %g", counts[t], mlen);
        for (int a = 0; a < 4; a++)
            CHECKF(fabs(upper[a] / (double)counts[t] - 0.5) < 0.06, "%u rays: %u in hemisphere %d",
                   counts[t], upper[a], a);
    }
    rd_buffer_destroy(&vk, &globals);
    rd_buffer_destroy(&vk, &out);
    rd_buffer_destroy(&vk, &in);
    rd_pipeline_destroy(&vk, &p);
}

/* Source texel of border texel (x, y) of a side x side tile (the rule in ddgi-reference.md). */
static void border_source(unsigned x, unsigned y, unsigned side, unsigned *sx, unsigned *sy)
{
    unsigned inner = side - 2, last = side - 1;
    int xb = x == 0 || x == last, yb = y == 0 || y == last;
    if (xb && yb)
        *sx = x > 0 ? 1 : inner, *sy = y > 0 ? 1 : inner;
    else if (yb)
        *sx = last - x, *sy = y == 0 ? 1 : inner;
    else
        *sx = x == 0 ? 1 : inner, *sy = last - y;
}

/* After real updates of the Cornell box, every border texel of both atlases holds exactly
 * the bits of its wrap source, and the interior is not trivially uniform. */
/* The ray order is a permutation, and it groups directions: the mean angle between a warp's
 * rays and their mean direction is far smaller than with the index order (the golden-angle
 * spiral spreads 32 consecutive rays around a whole band of the sphere). */
static double warp_spread(const uint32_t *order, unsigned n)
{
    double sum = 0;
    unsigned groups = 0;
    for (unsigned w = 0; w + 32 <= n; w += 32, groups++) {
        double d[32][3], m[3] = {0, 0, 0};
        for (unsigned k = 0; k < 32; k++) {
            unsigned i = order[w + k];
            double phi = 2 * M_PI * fmod(i * 0.61803398874989484820, 1.0);
            double z = 1 - (2.0 * i + 1) / n, r = sqrt(fmax(0, 1 - z * z));
            d[k][0] = cos(phi) * r, d[k][1] = sin(phi) * r, d[k][2] = z;
            for (int c = 0; c < 3; c++)
                m[c] += d[k][c];
        }
        double ml = sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
        for (unsigned k = 0; k < 32; k++)
            sum += acos(fmin(1.0, (d[k][0] * m[0] + d[k][1] * m[1] + d[k][2] * m[2]) / ml)) / 32;
    }
    return sum / groups;
}

static void test_ray_order(void)
{
    static const unsigned counts[] = {1, 32, 64, 100, 256, 1024};
    for (unsigned c = 0; c < sizeof counts / sizeof counts[0]; c++) {
        unsigned n = counts[c];
        uint32_t order[PC_DDGI_MAX_RAYS], identity[PC_DDGI_MAX_RAYS];
        unsigned char seen[PC_DDGI_MAX_RAYS] = {0};
        rd_ddgi_ray_order(n, order);
        bool perm = true;
        for (unsigned i = 0; i < n; i++) {
            identity[i] = i;
            if (order[i] >= n || seen[order[i]]++) perm = false;
        }
        CHECKF(perm, "ray order for %u rays is a permutation", n);
        if (n >= 256) { /* below 8 warps both orders split the sphere into halves or bands */
            double sorted = warp_spread(order, n), plain = warp_spread(identity, n);
            printf(
                "ray order, %u rays: mean angle to the warp's mean %.3f rad (index order %.3f)\n",
                n, sorted, plain);
            CHECKF(sorted < 0.6 * plain,
                   "%u rays: warp spread %.3f rad sorted, %.3f in index order", n, sorted, plain);
        }
    }
}

static void test_borders(void)
{
    char e[512];
    test_rig rig;
    if (!test_rig_open(&vk, "cornell", &rig)) return;
    rd_renderer *r = &rig.r;
    rd_ddgi_settings gi = {.mode = PC_GI_DDGI, .counts = {3, 2, 2}, .rays = 64, .seed = 7};
    CHECK(rd_renderer_configure_gi(r, rig.s.bounds_min, rig.s.bounds_max, &gi, e, sizeof e) ==
          RD_VK_OK);
    rd_frame_settings fs = {.width = 8, .height = 8, .gi_updates = 2};
    CHECKF(rd_renderer_render(r, &rig.gs, &rig.cam, &fs, e, sizeof e) == RD_VK_OK, "%s", e);
    unsigned probes = rd_ddgi_probe_count(&r->world.ddgi);
    CHECK(probes == 12);
    const unsigned sides[2] = {PC_DDGI_IRR_INTERIOR + 2, PC_DDGI_DIST_INTERIOR + 2};
    rd_buffer *bufs[2] = {&r->world.ddgi.irradiance, &r->world.ddgi.distance};
    for (int a = 0; a < 2; a++) {
        unsigned side = sides[a];
        size_t texels = (size_t)probes * side * side;
        uint64_t *t = malloc(texels * 8);
        CHECK(rd_buffer_download(&vk, bufs[a], 0, t, texels * 8, e, sizeof e) == RD_VK_OK);
        unsigned mismatches = 0, borders = 0, distinct = 0;
        for (unsigned p = 0; p < probes; p++)
            for (unsigned y = 0; y < side; y++)
                for (unsigned x = 0; x < side; x++) {
                    uint64_t v = t[((size_t)p * side + y) * side + x];
                    if (x == 0 || y == 0 || x == side - 1 || y == side - 1) {
                        unsigned sx, sy;
                        border_source(x, y, side, &sx, &sy);
                        borders++;
                        if (v != t[((size_t)p * side + sy) * side + sx]) mismatches++;
                    } else if (v != t[((size_t)p * side + 1) * side + 1]) {
                        distinct++;
                    }
                }
        CHECKF(mismatches == 0, "atlas %d: %u of %u border texels differ from their source", a,
               mismatches, borders);
        CHECK(borders == probes * 4 * (side - 1));
        CHECKF(distinct > 0, "atlas %d interior is uniform: nothing was blended", a);
        free(t);
    }
    test_rig_close(&vk, &rig);
}

static void test_furnace(void)
{
    test_render_desc d = {.scene = "furnace",
                          .width = 24,
                          .height = 16,
                          .updates = 40,
                          .gi = {.mode = PC_GI_DDGI,
                                 .counts = {2, 2, 2},
                                 .rays = 96,
                                 .hysteresis = 0.7f,
                                 .has_hysteresis = true,
                                 .seed = 1}};
    float *img = test_render(&vk, &d, NULL, NULL);
    if (!img) return;
    size_t n = (size_t)d.width * d.height * 3, bad;
    double mean = test_image_mean(img, n, &bad);
    CHECK(bad == 0);
    double expect = 1.0 / (1.0 - 0.5);
    CHECKF(fabs(mean - expect) <= 0.03 * expect, "furnace radiance %g, expected %g", mean, expect);
    for (size_t i = 0; i < n; i++)
        if (fabsf(img[i] - (float)expect) > 0.05f * (float)expect) {
            CHECKF(0, "furnace pixel value %g", img[i]);
            break;
        }
    free(img);
}

static void test_thin_wall(void)
{
    /* 8 x 4 x 4 probes over the two rooms: cages at the shared wall straddle it */
    test_render_desc d = {.scene = "two-rooms",
                          .width = 24,
                          .height = 16,
                          .updates = 12,
                          .gi = {.mode = PC_GI_CLASSIC,
                                 .counts = {8, 4, 4},
                                 .rays = 64,
                                 .hysteresis = 0.5f,
                                 .has_hysteresis = true,
                                 .seed = 3}};
    float *classic = test_render(&vk, &d, NULL, NULL);
    d.gi.mode = PC_GI_DDGI;
    float *ddgi = test_render(&vk, &d, NULL, NULL);
    d.gi.mode = PC_GI_OFF;
    float *direct = test_render(&vk, &d, NULL, NULL);
    if (!classic || !ddgi || !direct) return;
    size_t n = (size_t)d.width * d.height * 3, bad_c, bad_d;
    double mc = test_image_mean(classic, n, &bad_c), md = test_image_mean(ddgi, n, &bad_d);
    double m0 = test_image_mean(direct, n, NULL);
    printf("dark room mean radiance: direct %g, classic %g, ddgi %g\n", m0, mc, md);
    CHECK(bad_c == 0 && bad_d == 0);
    CHECK(m0 == 0.0); /* no direct light reaches the closed room */
    CHECKF(mc > 0.05, "classic probes should leak light through the wall (%g)", mc);
    CHECKF(md < 0.05 * mc, "ddgi leaks: %g vs classic %g", md, mc);
    free(classic);
    free(ddgi);
    free(direct);
}

static void test_determinism(void)
{
    test_render_desc d = {.scene = "cornell",
                          .width = 16,
                          .height = 12,
                          .updates = 3,
                          .gi = {.mode = PC_GI_DDGI, .counts = {3, 3, 3}, .rays = 32, .seed = 42}};
    float *a = test_render(&vk, &d, NULL, NULL);
    float *b = test_render(&vk, &d, NULL, NULL);
    d.gi.seed = 43;
    float *c = test_render(&vk, &d, NULL, NULL);
    if (!a || !b || !c) return;
    size_t n = (size_t)d.width * d.height * 3, bad;
    test_image_mean(a, n, &bad);
    CHECK(bad == 0);
    CHECK(memcmp(a, b, n * sizeof(float)) == 0);
    CHECK(memcmp(a, c, n * sizeof(float)) != 0); /* the seed does matter */
    free(a);
    free(b);
    free(c);
}

static void test_debug_views(void)
{
    test_render_desc d = {.scene = "cornell",
                          .width = 16,
                          .height = 12,
                          .updates = 2,
                          .view = PC_VIEW_IRRADIANCE,
                          .gi = {.mode = PC_GI_DDGI, .counts = {3, 3, 3}, .rays = 32}};
    float *irr = test_render(&vk, &d, NULL, NULL);
    d.view = PC_VIEW_PROBES;
    float *probes = test_render(&vk, &d, NULL, NULL);
    if (!irr || !probes) return;
    size_t n = (size_t)d.width * d.height * 3, bad1, bad2;
    CHECK(test_image_mean(irr, n, &bad1) > 0);
    CHECK(test_image_mean(probes, n, &bad2) > 0);
    CHECK(bad1 == 0 && bad2 == 0);
    free(irr);
    free(probes);

    /* the probe spheres show their stored irradiance: every probe of the Cornell box's 3x3x3 grid
     * is active, so none is drawn in the marker colour of an off probe (0.3, 0, 0) — they all were
     * once, when the sphere loop looked the probe up inside its own body */
    d.width = 64, d.height = 48;
    d.view = PC_VIEW_FINAL;
    float *final = test_render(&vk, &d, NULL, NULL);
    d.view = PC_VIEW_PROBES;
    probes = test_render(&vk, &d, NULL, NULL);
    if (!final || !probes) return;
    unsigned spheres = 0, off_marker = 0, awake_rim = 0;
    for (size_t i = 0; i < (size_t)d.width * d.height; i++) {
        const float *p = &probes[i * 3], *f = &final[i * 3];
        if (p[0] != f[0] || p[1] != f[1] || p[2] != f[2]) spheres++;
        if (p[0] == 0.3f && p[1] == 0.0f && p[2] == 0.0f) off_marker++;
        if (p[0] == 1.0f && p[1] == 0.8f && p[2] == 0.0f) awake_rim++;
    }
    CHECKF(spheres > 20, "%u pixels show probe spheres", spheres);
    CHECKF(off_marker == 0, "%u sphere pixels in the off-probe colour", off_marker);
    CHECKF(awake_rim > 0, "after 2 updates every probe is awake: no yellow rim drawn");
    free(final);
    free(probes);

    /* once the field has converged every probe sleeps: no awake rim is left */
    d.updates = 0;
    d.converge = true;
    d.gi.hysteresis = 0.5f, d.gi.has_hysteresis = true;
    probes = test_render(&vk, &d, NULL, NULL);
    if (!probes) return;
    awake_rim = 0;
    for (size_t i = 0; i < (size_t)d.width * d.height; i++)
        awake_rim += probes[i * 3] == 1.0f && probes[i * 3 + 1] == 0.8f && probes[i * 3 + 2] == 0;
    CHECKF(awake_rim == 0, "%u awake-rim pixels in a converged field", awake_rim);
    free(probes);
}

int main(void)
{
    if (!test_vk_open(&vk)) return test_finish();
    test_ray_order();
    test_octahedral_and_rays();
    test_borders();
    test_furnace();
    test_thin_wall();
    test_determinism();
    test_debug_views();
    return test_vk_close(&vk);
}
