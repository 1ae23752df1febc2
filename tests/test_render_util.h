/* test_render_util.h: renders a builtin scene end to end (scene -> BVH -> GPU -> passes ->
 * linear radiance) for GPU tests. */
#ifndef PC_TEST_RENDER_UTIL_H
#define PC_TEST_RENDER_UTIL_H

#include "renderer/render.h"

typedef struct test_render_desc {
    const char *scene; /* builtin scene name (NAME, NAME+gltf, ...), or NULL with gltf */
    const char *gltf;  /* a glTF JSON text to load instead of a builtin scene */
    unsigned width, height;
    rd_ddgi_settings gi;        /* mode 0 = no GI */
    unsigned updates;           /* probe updates before the image */
    bool converge;              /* first update until the field converges (as `probecast render`
                                   without --frames), at most 2000 updates */
    unsigned *converge_updates; /* optional: receives the updates convergence took */
    int camera;                 /* the scene's camera index (0: the first, or a framing one) */
    unsigned view;              /* PC_VIEW_* */
    unsigned pathtrace_spp;     /* > 0: path-traced reference instead */
    unsigned max_bounces;
    unsigned seed;
    unsigned reflections; /* PC_REFLECT_* (0 = auto) */
    unsigned near_field;  /* PC_NEAR_* (0 = auto: on) */
    unsigned frames;      /* frames rendered of the still camera (0 = 1): reflections average
                             one sample per pixel and frame */
    float sky[3];         /* radiance of rays that escape (default black) */
} test_render_desc;

/* Creates the device for a GPU test (the environment picks lavapipe and validation) and
 * prints it; false after a failed CHECK. */
bool test_vk_open(rd_vk *vk);
/* Checks an rd_vk_result call; on failure reports it with the test's `err` buffer (a char array
 * in scope, passed to the call) and jumps to the test's `done:` clean-up label. */
#define VK_CHECK(call)                                                                             \
    do {                                                                                           \
        rd_vk_result rc_ = (call);                                                                 \
        CHECKF(rc_ == RD_VK_OK, "%s: %s", #call, err);                                             \
        if (rc_ != RD_VK_OK) goto done;                                                            \
    } while (0)
/* Checks that the validation layer reported nothing, destroys the device and returns the
 * test's exit status. */
int test_vk_close(rd_vk *vk);

/* Returns width*height*3 linear floats (caller frees) or NULL after a failed CHECK.
 * view_out (optional) receives the camera's pc_view; stats_out the frame statistics. */
float *test_render(rd_vk *vk, const test_render_desc *d, pc_view *view_out,
                   rd_frame_stats *stats_out);
/* A glTF metallic-roughness material without textures (every texture index -1), opaque,
 * single sided, normal scale and occlusion strength 1. */
rd_material test_material(const float base[3], float metallic, float roughness, float specular);
/* The unit direction of the camera ray through pixel (x, y) of a width x height image, as
 * shaders/common.glsl's camera_dir computes it. */
void test_pixel_dir(const pc_view *v, unsigned width, unsigned height, int x, int y, double d[3]);
/* Converges the field of s (GI with `counts` probes, 64 rays, seed 1, default hysteresis, black
 * sky) and checks that it sleeps within rd_ddgi_sleep_bound; then, unless `more` is 0 or the
 * image is black, keeps every probe updating for `more` updates (each woken without lowering its
 * age, so it blends at the maximum hysteresis) and checks the mean luminance of a 16 x 12 image
 * at sleep against the mean over the second half of that longer run: |bias| <= max_bias, or
 * <= sd_factor standard deviations of one image of the longer run when that is larger. Prints
 * both. Returns the updates to sleep; *mean gets the mean at sleep. */
unsigned test_converge_noisy(rd_vk *vk, const char *label, rd_scene *s, const unsigned counts[3],
                             unsigned more, double max_bias, double sd_factor, double *mean);
/* What a GPU test that drives the renderer itself sets up: a builtin scene (NAME, hard:NAME,
 * NAME+gltf, ...), its GPU copy, a renderer and the scene's framing camera. */
typedef struct test_rig {
    rd_scene s;
    rd_gpu_scene gs;
    rd_renderer r;
    rd_view_camera cam;
    bool open;
} test_rig;
/* Builds it; false after a failed CHECK (nothing is left to close). */
bool test_rig_open(rd_vk *vk, const char *scene, test_rig *rig);
/* Idempotent. */
void test_rig_close(rd_vk *vk, test_rig *rig);

/* Mean of all channels; number of non-finite values. */
double test_image_mean(const float *rgb, size_t floats, size_t *non_finite);

#endif
