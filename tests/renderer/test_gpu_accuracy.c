/* Accuracy of the defaults (issue: "defaults must be accurate, not only tuned flags"): with no
 * GI setting at all, the probe field converges by its own measure (as `probecast render` does
 * without --frames) and the image's mean luminance lands
 *   - within 5% of the path tracer in two closed rooms where most light is indirect: the
 *     white room (albedo 0.8, point light) and the lit room of two-rooms (camera 1);
 *   - within 2% of the exact Le / (1 - albedo) = 2 in the closed furnace.
 * The path tracer is itself checked against analytic cases (test_gpu_hard_cases). Slow on
 * lavapipe (the default grids: 512 probes x 256 rays): labelled "accuracy". */
#include <math.h>
#include <stdlib.h>

#include "test_render_util.h"
#include "test_util.h"

#define W 16
#define H 12

static rd_vk vk;

static double mean_luminance(const float *rgb)
{
    double sum = 0;
    for (size_t i = 0; i < (size_t)W * H; i++)
        sum += 0.2126 * rgb[3 * i] + 0.7152 * rgb[3 * i + 1] + 0.0722 * rgb[3 * i + 2];
    return sum / (W * H);
}

static float *render_default(const char *scene, int camera, unsigned *updates)
{
    test_render_desc d = {.scene = scene,
                          .width = W,
                          .height = H,
                          .camera = camera,
                          .gi = {.mode = PC_GI_DDGI},
                          .converge = true,
                          .converge_updates = updates};
    return test_render(&vk, &d, NULL, NULL);
}

static void test_room(const char *scene, int camera)
{
    unsigned updates = 0;
    float *ddgi = render_default(scene, camera, &updates);
    test_render_desc r = {.scene = scene,
                          .width = W,
                          .height = H,
                          .camera = camera,
                          .pathtrace_spp = 2048,
                          .seed = 7};
    float *ref = test_render(&vk, &r, NULL, NULL);
    if (ddgi && ref) {
        size_t bad;
        test_image_mean(ddgi, (size_t)W * H * 3, &bad);
        CHECKF(bad == 0, "%s: %zu non-finite values", scene, bad);
        double m = mean_luminance(ddgi), mr = mean_luminance(ref), bias = m / mr - 1;
        printf("%s (camera %d): DDGI %.4f after %u updates, path traced %.4f: bias %+.2f%%\n",
               scene, camera, m, updates, mr, 100 * bias);
        CHECKF(fabs(bias) <= 0.05, "%s: mean luminance %+.2f%% off the path tracer", scene,
               100 * bias);
    }
    free(ddgi);
    free(ref);
}

static void test_furnace(void)
{
    unsigned updates = 0;
    float *img = render_default("furnace", 0, &updates);
    if (!img) return;
    size_t bad;
    double mean = test_image_mean(img, (size_t)W * H * 3, &bad);
    printf("furnace: %.5f after %u updates (exact 2)\n", mean, updates);
    CHECK(bad == 0);
    CHECKF(fabs(mean - 2.0) <= 0.02 * 2.0, "furnace radiance %g, expected 2 within 2%%", mean);
    free(img);
}

int main(void)
{
    if (!test_vk_open(&vk)) return test_finish();
    test_furnace();
    test_room("white-room", 0);
    test_room("two-rooms", 1);
    return test_vk_close(&vk);
}
