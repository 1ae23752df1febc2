/* probecast render --time on a skinned model, end to end on lavapipe (the executable, as a user
 * runs it): the two-bone arm of tests/renderer/skin_builder.h seen by a camera in front of it. At
 * 0 s the arm is straight along +X, at 1.5 s its forearm points up (+Y): the images differ where
 * the forearm was and is, and nothing says skinning is not supported. The CPU deformation itself
 * is checked vertex by vertex in test_skin. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/skin_builder.h"
#include "serve_util.h"
#include "test_util.h"

#define W 64
#define H 48

/* Renders model at time t into lum (W x H luminances); returns false on failure, with the
 * command's output in out. */
static bool render(const char *model, double t, float *lum, char *out, size_t outlen)
{
    char options[128];
    snprintf(options, sizeof options, "--probes 2,2,2 --rays 16 --frames 2 --seed 1 --time %g", t);
    float *l = pc_render_luminance(model, options, W, H, out, outlen);
    if (l) memcpy(lum, l, sizeof(float) * W * H);
    free(l);
    return l != NULL;
}

/* Pixels whose luminance differs by more than a tenth of the brighter image's largest. */
static int changed_pixels(const float *a, const float *b)
{
    float peak = 0;
    for (size_t i = 0; i < (size_t)W * H; i++)
        peak = a[i] > peak ? a[i] : b[i] > peak ? b[i] : peak;
    int n = 0;
    for (size_t i = 0; i < (size_t)W * H; i++)
        n += fabsf(a[i] - b[i]) > 0.1f * peak;
    return n;
}

int main(void)
{
    char model[256];
    snprintf(model, sizeof model, "%s", test_tmp_path("skinned-arm.gltf"));
    char *text = gltf_arm_with_camera();
    FILE *f = fopen(model, "w");
    CHECK(f != NULL && fputs(text, f) >= 0 && fclose(f) == 0);
    free(text);

    static char out[16384];
    static float straight[W * H], again[W * H], bent[W * H];
    bool ok = render(model, 0, straight, out, sizeof out);
    CHECKF(ok && !strstr(out, "not supported"), "%s", out);
    ok = ok && render(model, 0, again, out, sizeof out);
    ok = ok && render(model, 1.5, bent, out, sizeof out);
    CHECK(ok);
    if (ok) {
        int same = changed_pixels(straight, again), moved = changed_pixels(straight, bent);
        printf("pixels changed: the same time %d, 0 s against 1.5 s %d (of %d)\n", same, moved,
               W * H);
        CHECKF(same == 0, "the same time renders the same image (%d pixels differ)", same);
        /* the forearm covers about 3 x 16 pixels in either pose */
        CHECKF(moved >= 20, "the bent arm's image differs from the straight one's (%d pixels)",
               moved);
    }
    return test_finish();
}
