/* probecast render --time on a skinned model, end to end on lavapipe (the executable, as a user
 * runs it): the two-bone arm of tests/renderer/skin_builder.h seen by a camera in front of it. At
 * 0 s the arm is straight along +X, at 1.5 s its forearm points up (+Y): the images differ where
 * the forearm was and is, and nothing says skinning is not supported. The CPU deformation itself
 * is checked vertex by vertex in test_skin. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

#include "renderer/skin_builder.h"
#include "server/cli/image_io.h"
#include "test_util.h"

#define W 64
#define H 48

/* Renders model at time t into lum (W x H luminances); returns false on failure, with the
 * command's output in out. */
static bool render(const char *model, double t, float *lum, char *out, size_t outlen)
{
    const char *hdr = test_tmp_path("skinned-arm.pfm");
    char cmd[2048];
    snprintf(cmd, sizeof cmd,
             "'%s' render '%s' --width %d --height %d --probes 2,2,2 --rays 16 --frames 2 "
             "--seed 1 --time %g --hdr '%s' 2>&1",
             PROBECAST_EXE, model, W, H, t, hdr);
    remove(hdr);
    FILE *p = popen(cmd, "r");
    out[0] = '\0';
    if (!p) return false;
    size_t n = fread(out, 1, outlen - 1, p);
    out[n] = '\0';
    int status = pclose(p);
    CHECKF(WIFEXITED(status) && WEXITSTATUS(status) == 0, "%s\n%s", cmd, out);
    float *rgb = NULL;
    uint32_t w = 0, h = 0;
    char err[256];
    if (rd_image_read_pfm(hdr, &rgb, &w, &h, err, sizeof err) != RD_IMAGE_OK || w != W || h != H) {
        CHECKF(0, "%s: %s", cmd, err);
        free(rgb);
        return false;
    }
    for (size_t i = 0; i < (size_t)W * H; i++)
        lum[i] = 0.2126f * rgb[3 * i] + 0.7152f * rgb[3 * i + 1] + 0.0722f * rgb[3 * i + 2];
    free(rgb);
    return true;
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
