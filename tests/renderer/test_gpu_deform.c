/* test_gpu_deform.c: deform.comp (renderer/accel/gpu_deform.h) against the CPU reference
 * (rd_mesh_deform_apply, run by rd_scene_update) on the two-bone arm (four and eight influences)
 * and the morphing cube that skin_builder writes, at several poses: positions, normals and
 * tangents within float tolerance. Runs with the validation layer on under ctest. */
#include "renderer/accel/gpu_deform.h"
#include "renderer/gltf/gltf_loader.h"
#include "renderer/scene/animation_clip.h"
#include "renderer/scene/deform.h"
#include "renderer/vk/vk_context.h"
#include "skin_builder.h"
#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static char err[512];

static int load(char *text, rd_scene *s)
{
    err[0] = '\0';
    rd_gltf_result r = rd_gltf_load_memory(text, strlen(text), NULL, NULL, s, err, sizeof err);
    free(text);
    return r == RD_GLTF_OK;
}

static int close_to(const float *a, const float *b, size_t n, float tol)
{
    for (size_t i = 0; i < n; i++)
        if (!(fabsf(a[i] - b[i]) <= tol)) return 0;
    return 1;
}

/* Every deforming instance of s posed on the GPU from s's current pose, checked against the
 * CPU's result in the mesh arrays; returns how many meshes were checked. */
static int check_scene(rd_vk *vk, const rd_gpu_deformer *g, const rd_scene *s, const char *what)
{
    int checked = 0;
    for (uint32_t i = 0; i < s->instance_count; i++) {
        uint32_t node = s->instances[i].node;
        const rd_mesh *m = &s->meshes[s->instances[i].mesh];
        const rd_mesh_deform *d = m->deform;
        if (!d) continue;
        const rd_node *n = &s->nodes[node];
        const rd_skin *k =
            n->skin && n->skin <= s->skin_count && d->influences ? &s->skins[n->skin - 1] : NULL;
        uint32_t jc = k ? k->joint_count : 0;
        float *mats = calloc((size_t)jc * 16 + 1, sizeof(float));
        CHECK(mats != NULL);
        if (k) rd_skin_joint_matrices(s, k, node, mats);

        rd_gpu_deform_mesh gm;
        rd_vk_result r = rd_gpu_deform_mesh_create(vk, &gm, m, jc, err, sizeof err);
        CHECKF(r == RD_VK_OK, "%s", err);
        rd_gpu_deform_set_pose(&gm, d, n->weights, n->weight_count, k ? mats : NULL, jc);
        rd_cmd c;
        r = rd_cmd_begin(vk, &c, err, sizeof err);
        CHECKF(r == RD_VK_OK, "%s", err);
        rd_gpu_deform_record(&c, g, &gm);
        r = rd_cmd_submit_wait(vk, &c, err, sizeof err);
        CHECKF(r == RD_VK_OK, "%s", err);

        size_t nv = d->vertex_count;
        float *p = malloc(nv * 3 * sizeof(float)), *nn = malloc(nv * 3 * sizeof(float));
        float *t = malloc(nv * 4 * sizeof(float));
        CHECK(p && nn && t);
        CHECK(rd_buffer_download(vk, &gm.out, gm.out_positions, p, nv * 12, err, sizeof err) ==
              RD_VK_OK);
        CHECK(rd_buffer_download(vk, &gm.out, gm.out_normals, nn, nv * 12, err, sizeof err) ==
              RD_VK_OK);
        CHECKF(close_to(p, m->positions, nv * 3, 1e-5f), "%s: positions differ (mesh %u)", what,
               s->instances[i].mesh);
        CHECKF(close_to(nn, m->normals, nv * 3, 1e-5f), "%s: normals differ", what);
        if (gm.has_tangents && m->tangents) {
            CHECK(rd_buffer_download(vk, &gm.out, gm.out_tangents, t, nv * 16, err, sizeof err) ==
                  RD_VK_OK);
            CHECKF(close_to(t, m->tangents, nv * 4, 1e-5f), "%s: tangents differ", what);
        }
        free(p);
        free(nn);
        free(t);
        free(mats);
        rd_gpu_deform_mesh_destroy(vk, &gm);
        rd_gpu_deform_mesh_destroy(vk, &gm); /* idempotent */
        checked++;
    }
    return checked;
}

static void run_file(rd_vk *vk, const rd_gpu_deformer *g, char *text, const char *what,
                     int want_meshes)
{
    rd_scene s;
    CHECKF(load(text, &s), "%s: %s", what, err);
    const double times[] = {0.0, 0.3, 0.5, 1.0, 1.5, 1.9};
    for (size_t i = 0; i < sizeof times / sizeof times[0]; i++) {
        rd_scene_animate(&s, times[i]);
        CHECKF(rd_scene_update(&s, err, sizeof err), "%s", err);
        int n = check_scene(vk, g, &s, what);
        CHECKF(n == want_meshes, "%s at %g s: %d meshes checked, expected %d", what, times[i], n,
               want_meshes);
    }
    rd_scene_destroy(&s);
}

int main(void)
{
    rd_vk vk;
    rd_vk_result rc = rd_vk_create(&vk, NULL, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    if (rc != RD_VK_OK) return test_finish();
    rd_gpu_deformer g;
    rc = rd_gpu_deformer_create(&vk, &g, err, sizeof err);
    CHECKF(rc == RD_VK_OK, "%s", err);
    if (rc == RD_VK_OK) {
        run_file(&vk, &g, gltf_arm(ARM_FLOAT), "arm", 1);
        run_file(&vk, &g, gltf_arm(ARM_TWO_SETS), "arm, eight influences", 1);
        run_file(&vk, &g, gltf_morph_cube(), "morph cube", 3);
    }
    rd_gpu_deformer_destroy(&vk, &g);
    rd_gpu_deformer_destroy(&vk, &g); /* idempotent */
    CHECK(rd_vk_validation_messages(&vk) == 0);
    rd_vk_destroy(&vk);
    return test_finish();
}
