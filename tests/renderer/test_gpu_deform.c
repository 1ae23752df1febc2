/* test_gpu_deform.c: deform.comp (renderer/accel/gpu_deform.h) against the CPU reference
 * (rd_mesh_deform_apply, run by rd_scene_update) on the two-bone arm (four and eight influences)
 * and the morphing cube that skin_builder writes, at several poses: positions, normals and
 * tangents within float tolerance; then each mesh's rest BVH, the CPU builder's and the GPU
 * LBVH's (children before their parent), refitted on the GPU to the pose: the CPU's refit's
 * boxes, a fresh build's hits. Runs with the validation layer on under ctest. */
#include "renderer/accel/bvh.h"
#include "renderer/accel/gpu_deform.h"
#include "renderer/accel/gpu_lbvh.h"
#include "renderer/accel/gpu_refit.h"
#include "renderer/gltf/gltf_loader.h"
#include "renderer/scene/animation_clip.h"
#include "renderer/scene/deform.h"
#include "renderer/vk/vk_context.h"
#include "skin_builder.h"
#include "skinned_sheet.h"
#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static char err[512];
static int close_to(const float *a, const float *b, size_t n, float tol)
{
    for (size_t i = 0; i < n; i++)
        if (!(fabsf(a[i] - b[i]) <= tol)) return 0;
    return 1;
}

static rd_gpu_refitter g_refit;
static rd_gpu_lbvh_builder g_lbvh;
static double g_worst_sah_ratio = 0;

/* The CPU's refit of bvh's node i over positions p (9 floats a triangle): every box the exact
 * union of its children's or its triangles' (recursive: the trees here are shallow). */
static void cpu_refit(rd_bvh *bvh, uint32_t i, const float *p)
{
    pc_bvh_node *n = &bvh->nodes[i];
    uint32_t first = rd_bvh_node_first(n), count = rd_bvh_node_count(n);
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t c = 0; count == 0 && c < 2; c++) {
        cpu_refit(bvh, first + c, p);
        const pc_bvh_node *ch = &bvh->nodes[first + c];
        for (int k = 0; k < 3; k++) {
            lo[k] = fminf(lo[k], (&ch->bmin.x)[k]);
            hi[k] = fmaxf(hi[k], (&ch->bmax.x)[k]);
        }
    }
    for (uint32_t t = first; t < first + count; t++)
        for (int v = 0; v < 9; v++) {
            float x = p[9 * (size_t)bvh->prim_index[t] + v];
            lo[v % 3] = fminf(lo[v % 3], x);
            hi[v % 3] = fmaxf(hi[v % 3], x);
        }
    n->bmin.x = lo[0], n->bmin.y = lo[1], n->bmin.z = lo[2];
    n->bmax.x = hi[0], n->bmax.y = hi[1], n->bmax.z = hi[2];
}

/* The BVH of the rest shape (the CPU builder's, or with lbvh the GPU LBVH's, whose children may
 * sit before their parent) refitted on the GPU over the GPU's deformed positions p (nt
 * triangles): its boxes those of the CPU's refit of the same tree, and against a fresh CPU
 * build over p the same closest hit (triangle and t) ray by ray, rays from a sphere around the
 * box through points inside it. */
static void check_refit(rd_vk *vk, const rd_gpu_deform_mesh *gm, const rd_mesh_deform *d,
                        const float *p, bool lbvh, const char *what)
{
    uint32_t nt = d->vertex_count / 3;
    rd_bvh rest, fresh;
    if (lbvh) {
        rd_vk_result lr = rd_gpu_lbvh_build_download(vk, &g_lbvh, d->rest_positions, nt, 0, NULL,
                                                     &rest, NULL, err, sizeof err);
        CHECKF(lr == RD_VK_OK, "%s: LBVH: %s", what, err);
        if (lr != RD_VK_OK) return;
    } else {
        CHECK(rd_bvh_build_triangles(&rest, d->rest_positions, nt, NULL));
    }
    CHECK(rd_bvh_build_triangles(&fresh, p, nt, NULL));
    rd_bvh ref = rest; /* the CPU's refit of the same tree */
    ref.nodes = malloc(rest.node_count * sizeof *ref.nodes);
    if (!ref.nodes) abort();
    memcpy(ref.nodes, rest.nodes, rest.node_count * sizeof *ref.nodes);
    if (rest.prim_count) cpu_refit(&ref, 0, p);
    uint32_t child_first = 0; /* interior nodes whose children sit before them */
    for (uint32_t i = 0; i < rest.node_count; i++)
        child_first += rd_bvh_node_count(&rest.nodes[i]) == 0 && nt > 1 &&
                       rd_bvh_node_first(&rest.nodes[i]) < i;
    rd_gpu_refit_blas b;
    rd_vk_result r = rd_gpu_refit_blas_create(vk, &b, &rest, err, sizeof err);
    CHECKF(r == RD_VK_OK, "%s", err);
    rd_cmd c;
    r = rd_cmd_begin(vk, &c, err, sizeof err);
    CHECKF(r == RD_VK_OK, "%s", err);
    rd_gpu_refit_record(&c, &g_refit, &b, gm->out.address + gm->out_positions);
    r = rd_cmd_submit_wait(vk, &c, err, sizeof err);
    CHECKF(r == RD_VK_OK, "%s", err);
    CHECK(rd_buffer_download(vk, &b.nodes, 0, rest.nodes, rest.node_count * sizeof(pc_bvh_node),
                             err, sizeof err) == RD_VK_OK);
    float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
    for (uint32_t i = 0; i < nt * 3; i++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fminf(lo[k], p[i * 3 + k]);
            hi[k] = fmaxf(hi[k], p[i * 3 + k]);
        }
    CHECKF(close_to(&rest.nodes[0].bmin.x, lo, 3, 0) && close_to(&rest.nodes[0].bmax.x, hi, 3, 0),
           "%s: refitted root box", what);
    uint32_t boxes_differ = 0;
    for (uint32_t i = 0; i < rest.node_count; i++)
        boxes_differ += !close_to(&rest.nodes[i].bmin.x, &ref.nodes[i].bmin.x, 3, 0) ||
                        !close_to(&rest.nodes[i].bmax.x, &ref.nodes[i].bmax.x, 3, 0);
    CHECKF(boxes_differ == 0, "%s%s: %u of %u GPU-refitted boxes differ from the CPU's refit", what,
           lbvh ? " (LBVH)" : "", boxes_differ, rest.node_count);
    if (lbvh && nt >= 64)
        CHECKF(child_first > 0, "%s: the LBVH puts some children before their parent", what);
    free(ref.nodes); /* its prim_index is rest's */
    uint32_t state = 7u, rays = 0, hits = 0, bad = 0;
    for (int i = 0; i < 400; i++) {
        float u[6];
        for (int k = 0; k < 6; k++) {
            state = state * 1664525u + 1013904223u;
            u[k] = (float)(state >> 8) / 16777216.0f;
        }
        float ctr[3], org[3], dir[3], target[3], rad = 0;
        for (int k = 0; k < 3; k++) {
            ctr[k] = 0.5f * (lo[k] + hi[k]);
            rad += (hi[k] - lo[k]) * (hi[k] - lo[k]);
        }
        float z = 2 * u[0] - 1, ph = 6.2831853f * u[1], s = sqrtf(fmaxf(0, 1 - z * z));
        float sd[3] = {s * cosf(ph), s * sinf(ph), z};
        for (int k = 0; k < 3; k++) {
            org[k] = ctr[k] + 2 * sqrtf(rad) * sd[k];
            target[k] = lo[k] + u[3 + k] * (hi[k] - lo[k]);
            dir[k] = target[k] - org[k];
        }
        float ta = 0, tb = 0;
        int64_t ha = rd_bvh_closest_triangle(&rest, p, org, dir, 0, 1e30f, &ta);
        int64_t hb = rd_bvh_closest_triangle(&fresh, p, org, dir, 0, 1e30f, &tb);
        rays++;
        hits += hb >= 0;
        bad += ha != hb || (ha >= 0 && ta != tb);
    }
    CHECKF(bad == 0 && hits > 0, "%s%s: %u of %u rays differ after refit (%u hits)", what,
           lbvh ? " (LBVH)" : "", bad, rays, hits);
    double sah_refit = rd_bvh_sah_cost(&rest), sah_fresh = rd_bvh_sah_cost(&fresh);
    /* the rebuild policy: the small bends of these tests stay refitted (the CPU builder's) */
    if (!lbvh && strstr(what, "150") == NULL)
        CHECKF(!rd_gpu_refit_should_rebuild(sah_refit, sah_fresh), "%s: SAH %g over %g", what,
               sah_refit, sah_fresh);
    if (!lbvh && sah_fresh > 0 && sah_refit / sah_fresh > g_worst_sah_ratio)
        g_worst_sah_ratio = sah_refit / sah_fresh;
    rd_gpu_refit_blas_destroy(vk, &b);
    rd_gpu_refit_blas_destroy(vk, &b); /* idempotent */
    rd_bvh_destroy(&rest);
    rd_bvh_destroy(&fresh);
}

static int load(char *text, rd_scene *s)
{
    err[0] = '\0';
    rd_gltf_result r = rd_gltf_load_memory(text, strlen(text), NULL, NULL, s, err, sizeof err);
    free(text);
    return r == RD_GLTF_OK;
}

/* Mesh m posed on the GPU (weights, joint matrices as rd_mesh_deform_apply takes them) against
 * the CPU's result already in m's arrays, then its rest BVH refitted (check_refit). */
static void check_mesh(rd_vk *vk, const rd_gpu_deformer *g, const rd_mesh *m, const float *weights,
                       uint32_t weight_count, const float *mats, uint32_t jc, const char *what)
{
    const rd_mesh_deform *d = m->deform;
    rd_gpu_deform_mesh gm;
    rd_vk_result r = rd_gpu_deform_mesh_create(vk, &gm, m, jc, err, sizeof err);
    CHECKF(r == RD_VK_OK, "%s", err);
    if (r != RD_VK_OK) return;
    rd_gpu_deform_set_pose(&gm, d, weights, weight_count, mats, jc);
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
    CHECKF(close_to(p, m->positions, nv * 3, 1e-5f), "%s: positions differ", what);
    CHECKF(close_to(nn, m->normals, nv * 3, 1e-5f), "%s: normals differ", what);
    if (gm.has_tangents && m->tangents) {
        CHECK(rd_buffer_download(vk, &gm.out, gm.out_tangents, t, nv * 16, err, sizeof err) ==
              RD_VK_OK);
        CHECKF(close_to(t, m->tangents, nv * 4, 1e-5f), "%s: tangents differ", what);
    }
    check_refit(vk, &gm, d, p, false, what);
    check_refit(vk, &gm, d, p, true, what);
    free(p);
    free(nn);
    free(t);
    rd_gpu_deform_mesh_destroy(vk, &gm);
    rd_gpu_deform_mesh_destroy(vk, &gm); /* idempotent */
}

/* Every deforming instance of s posed from s's current pose; returns how many were checked. */
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
        check_mesh(vk, g, m, n->weights, n->weight_count, k ? mats : NULL, jc, what);
        free(mats);
        checked++;
    }
    return checked;
}

/* The skinned sheet (skinned_sheet.h) bent to each of a few angles: enough triangles for a BVH
 * of several levels, and a large bend for the SAH ratio. */
static void run_sheet(rd_vk *vk, const rd_gpu_deformer *g, uint32_t cols, uint32_t rows)
{
    rd_mesh m;
    pc_skinned_sheet(&m, cols, rows);
    CHECK(m.positions && m.normals && m.deform);
    const double angles[] = {0, 30, 90, 150};
    for (size_t i = 0; i < sizeof angles / sizeof angles[0]; i++) {
        double a = angles[i] * M_PI / 180;
        float mats[32] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
        float cs = (float)cos(a), sn = (float)sin(a);
        /* joint 1: rotate about +Z around (1, 0, 0), column-major */
        const float j1[16] = {cs, sn, 0, 0, -sn, cs, 0, 0, 0, 0, 1, 0, 1 - cs, -sn, 0, 1};
        memcpy(mats + 16, j1, sizeof j1);
        rd_mesh_deform_apply(&m, NULL, 0, mats, 2);
        char what[64];
        snprintf(what, sizeof what, "sheet %ux%u at %g degrees", cols, rows, angles[i]);
        check_mesh(vk, g, &m, NULL, 0, mats, 2, what);
    }
    rd_mesh_deform_free(m.deform);
    free(m.positions);
    free(m.normals);
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
    rd_vk_result rr = rd_gpu_refitter_create(&vk, &g_refit, err, sizeof err);
    CHECKF(rr == RD_VK_OK, "%s", err);
    if (rr == RD_VK_OK) rr = rd_gpu_lbvh_builder_create(&vk, &g_lbvh, err, sizeof err);
    CHECKF(rr == RD_VK_OK, "%s", err);
    if (rc == RD_VK_OK && rr == RD_VK_OK) {
        run_file(&vk, &g, gltf_arm(ARM_FLOAT), "arm", 1);
        run_file(&vk, &g, gltf_arm(ARM_TWO_SETS), "arm, eight influences", 1);
        run_file(&vk, &g, gltf_morph_cube(), "morph cube", 3);
        run_sheet(&vk, &g, 32, 8);
    }
    CHECK(rd_gpu_refit_should_rebuild(1.3, 1.0) && !rd_gpu_refit_should_rebuild(1.2, 1.0));
    CHECK(rd_gpu_refit_should_rebuild(1.0, 0.0));
    fprintf(stderr, "worst SAH cost of a refitted BVH over a fresh build: %.3f\n",
            g_worst_sah_ratio);
    rd_gpu_lbvh_builder_destroy(&vk, &g_lbvh);
    rd_gpu_refitter_destroy(&vk, &g_refit);
    rd_gpu_deformer_destroy(&vk, &g);
    rd_gpu_deformer_destroy(&vk, &g); /* idempotent */
    CHECK(rd_vk_validation_messages(&vk) == 0);
    rd_vk_destroy(&vk);
    return test_finish();
}
