/* test_gpu_pose_refit.c: a skinned mesh's poses through rd_gpu_scene_update_pose both ways, on
 * lavapipe: posed and refitted on the GPU in the scene's buffers (gpu_scene_deform.c) and
 * rebuilt on the CPU (PROBECAST_DEFORM=cpu). The two-bone arm's scene of skin_builder (camera,
 * skin, animation) with its mesh swapped for the bumpy skinned sheet of skinned_sheet.h (192
 * triangles, a BVH of several levels), tangents added, behind it a rigid backdrop that comes
 * first in the scene's buffers (so the sheet's nodes and triangles sit at offsets past 0), and a
 * point light that casts the sheet's shadow on the backdrop. At each pose after the
 * first: the GPU's triangle records hold the CPU deformation's positions, normals and tangents,
 * the refitted nodes bound their children and triangles with the root box the scene's bounds,
 * and the images traced through both scenes agree (different trees, the same hits). The same
 * records and trees for skin_builder's morphing cubes (morph targets with normal and tangent
 * deltas). The SAH check runs off the render thread: the sheet unfolded (a tree built with the
 * sheet folded back on itself, elbow at 170 degrees, its nodes mixing both halves, refitted
 * nearly straight) degrades, and the check's verdict rebuilds it on the GPU (the LBVH) at the
 * next pose, as the 64th pose after that rebuilds it again: each time the records, tree and hits
 * (ray by ray, against a fresh CPU build) of the all-CPU path's; a check still pending when the
 * scene is destroyed is waited for (ASan: nothing leaks, nothing is read after it is freed).
 * ctest runs it twice: test_gpu_pose_refit_ploc with PROBECAST_BLAS_BUILD=ploc, where the GPU
 * builder's PLOC method makes the rebuilds and the backdrop's BLAS. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "renderer/accel/gpu_scene.h"
#include "renderer/accel/gpu_scene_internal.h"
#include "renderer/gltf/gltf_loader.h"
#include "renderer/render.h"
#include "renderer/scene/animation_clip.h"
#include "renderer/scene/camera.h"
#include "renderer/scene/deform.h"
#include "skin_builder.h"
#include "skinned_sheet.h"
#include "test_render_util.h"
#include "test_util.h"

#define W 64
#define H 48
#define COLS 12
#define ROWS 8

static char err[512];

/* The arm's scene with its mesh replaced by the sheet (same joints: the second turns at x = 1). */
#define SHEET 1u /* the sheet's mesh */

static bool build_scene(rd_scene *s)
{
    char *text = gltf_arm_with_camera();
    rd_gltf_result g = rd_gltf_load_memory(text, strlen(text), NULL, NULL, s, err, sizeof err);
    free(text);
    CHECKF(g == RD_GLTF_OK && s->mesh_count == 1, "arm: %s", err);
    if (g != RD_GLTF_OK) return false;
    rd_mesh *m = &s->meshes[0], sheet;
    pc_skinned_sheet(&sheet, COLS, ROWS);
    char *name = m->name;
    m->name = NULL; /* the mesh keeps its name */
    rd_mesh_free_arrays(m);
    m->name = name;
    m->tri_count = sheet.tri_count;
    m->positions = sheet.positions;
    m->normals = sheet.normals;
    m->deform = sheet.deform;
    size_t nv = (size_t)m->tri_count * 3;
    m->uvs = calloc(nv * 2, sizeof(float));
    m->material = calloc(m->tri_count, sizeof(uint32_t));
    m->tangents = calloc(nv * 4, sizeof(float));
    m->deform->rest_tangents = calloc(nv * 4, sizeof(float));
    if (!m->uvs || !m->material || !m->tangents || !m->deform->rest_tangents) abort();
    for (size_t v = 0; v < nv; v++) { /* +X, handedness flipped on every third vertex */
        float *t = &m->deform->rest_tangents[v * 4];
        t[0] = 1, t[3] = v % 3 == 2 ? -1.0f : 1.0f;
        memcpy(&m->tangents[v * 4], t, 4 * sizeof(float));
    }
    /* the backdrop: mesh 0 (the sheet becomes mesh 1), at z = -1 facing the camera */
    uint32_t b = rd_scene_add_mesh(s, "backdrop", 2);
    const float quad[18] = {-2, -2, -1, 4, -2, -1, 4, 3, -1, -2, -2, -1, 4, 3, -1, -2, 3, -1};
    memcpy(s->meshes[b].positions, quad, sizeof quad);
    for (int v = 0; v < 6; v++)
        s->meshes[b].normals[v * 3 + 2] = 1;
    rd_mesh swap = s->meshes[0];
    s->meshes[0] = s->meshes[b], s->meshes[b] = swap;
    for (uint32_t i = 0; i < s->node_count; i++)
        if (s->nodes[i].mesh == 0) s->nodes[i].mesh = (int32_t)b;
    rd_node back = {
        .name = "backdrop", .parent = -1, .mesh = 0, .rotation = {0, 0, 0, 1}, .scale = {1, 1, 1}};
    rd_scene_add_node(s, &back);
    rd_light l = {.name = "lamp",
                  .type = RD_LIGHT_POINT,
                  .color = {1, 1, 1},
                  .intensity = 20,
                  .node = -1,
                  .position = {1, 0.4f, 3},
                  .direction = {0, 0, -1}};
    rd_scene_add_light(s, &l);
    return rd_scene_update(s, err, sizeof err);
}

/* Both scenes' triangle records against the CPU deformation of s: the GPU's positions and
 * normals exactly where the CPU wrote them (float tolerance), tangents within a unit of their
 * 16-bit octahedral code, w words and UVs as the CPU build wrote them. */
/* The first triangle record of mesh m. */
static uint32_t tri_base(const rd_scene *s, uint32_t m)
{
    uint32_t base = 0;
    for (uint32_t i = 0; i < m; i++)
        base += s->meshes[i].tri_count;
    return base;
}

static void check_records(rd_vk *vk, const rd_scene *s, uint32_t mesh, const rd_gpu_scene *gpu,
                          const rd_gpu_scene *cpu, const char *what)
{
    uint32_t n = s->meshes[mesh].tri_count, base = tri_base(s, mesh);
    pc_tri *tg = calloc(n, sizeof *tg), *tc = calloc(n, sizeof *tc);
    pc_tri_attr *ag = calloc(n, sizeof *ag), *ac = calloc(n, sizeof *ac);
    uint32_t *at = calloc(n, sizeof *at); /* original triangle -> the CPU scene's record */
    if (!tg || !tc || !ag || !ac || !at) abort();
    CHECK(rd_buffer_download(vk, &gpu->tris, base * sizeof *tg, tg, n * sizeof *tg, err,
                             sizeof err) == RD_VK_OK);
    CHECK(rd_buffer_download(vk, &cpu->tris, base * sizeof *tc, tc, n * sizeof *tc, err,
                             sizeof err) == RD_VK_OK);
    CHECK(rd_buffer_download(vk, &gpu->tri_attrs, base * sizeof *ag, ag, n * sizeof *ag, err,
                             sizeof err) == RD_VK_OK);
    CHECK(rd_buffer_download(vk, &cpu->tri_attrs, base * sizeof *ac, ac, n * sizeof *ac, err,
                             sizeof err) == RD_VK_OK);
    for (uint32_t i = 0; i < n; i++)
        at[pc_f2u(tc[i].v2.w) < n ? pc_f2u(tc[i].v2.w) : 0] = i;
    const float *p = s->meshes[mesh].positions, *nn = s->meshes[mesh].normals;
    uint32_t bad_pos = 0, bad_attr = 0, bad_tan = 0;
    float worst = 0;
    for (uint32_t i = 0; i < n; i++) {
        uint32_t src = pc_f2u(tg[i].v2.w);
        if (src >= n) {
            bad_pos++;
            continue;
        }
        const pc_tri *c = &tc[at[src]];
        const pc_tri_attr *a = &ag[i], *b = &ac[at[src]];
        const pc_vec4 *v[3] = {&tg[i].v0, &tg[i].v1, &tg[i].v2};
        const pc_vec4 *nv[3] = {&a->n0, &a->n1, &a->n2};
        for (int k = 0; k < 3; k++) {
            const float *e = &p[src * 9 + k * 3], *en = &nn[src * 9 + k * 3];
            float d =
                fmaxf(fabsf(v[k]->x - e[0]), fmaxf(fabsf(v[k]->y - e[1]), fabsf(v[k]->z - e[2])));
            worst = fmaxf(worst, d);
            bad_pos += !(d <= 1e-5f);
            bad_attr += !(fabsf(nv[k]->x - en[0]) <= 1e-5f && fabsf(nv[k]->y - en[1]) <= 1e-5f &&
                          fabsf(nv[k]->z - en[2]) <= 1e-5f && nv[k]->w == 0);
        }
        bad_attr += memcmp(&tg[i].v0.w, &c->v0.w, 4) != 0 || memcmp(&tg[i].v1.w, &c->v1.w, 4) != 0;
        bad_attr += memcmp(&a->uv01, &b->uv01, sizeof a->uv01) != 0 ||
                    memcmp(&a->uv2, &b->uv2, sizeof a->uv2) != 0;
        const uint32_t ta[4] = {a->tangents.x, a->tangents.y, a->tangents.z, a->tangents.w};
        const uint32_t tb[4] = {b->tangents.x, b->tangents.y, b->tangents.z, b->tangents.w};
        bad_tan += ta[3] != tb[3] || !(tb[3] & PC_TANGENT_PRESENT);
        for (int k = 0; k < 3; k++)
            for (int h = 0; h < 2; h++) {
                int da = (int16_t)(ta[k] >> (16 * h)), db = (int16_t)(tb[k] >> (16 * h));
                bad_tan += abs(da - db) > 1;
            }
    }
    printf("%s: GPU records within %g of the CPU deformation\n", what, worst);
    CHECKF(bad_pos == 0, "%s: %u GPU-written positions differ from the CPU's", what, bad_pos);
    CHECKF(bad_attr == 0, "%s: %u normals, w words or UVs differ", what, bad_attr);
    CHECKF(bad_tan == 0, "%s: %u packed tangents differ", what, bad_tan);
    free(tg);
    free(tc);
    free(ag);
    free(ac);
    free(at);
}

/* The refitted tree in gpu's node buffer: every reachable node bounds its children's boxes or
 * its triangles' vertices (absolute indices), and the root is the scene's box of the mesh. */
static void check_tree(rd_vk *vk, const rd_gpu_scene *gs, const rd_scene *s, uint32_t mesh,
                       const char *what)
{
    uint64_t nn = gs->blas_node_count, all = gs->tri_count;
    uint32_t tris = s->meshes[mesh].tri_count, base = tri_base(s, mesh);
    pc_bvh_node *nodes = calloc(nn, sizeof *nodes);
    pc_tri *t = calloc(all, sizeof *t);
    if (!nodes || !t) abort();
    CHECK(rd_buffer_download(vk, &gs->blas_nodes, 0, nodes, nn * sizeof *nodes, err, sizeof err) ==
          RD_VK_OK);
    CHECK(rd_buffer_download(vk, &gs->tris, 0, t, all * sizeof *t, err, sizeof err) == RD_VK_OK);
    uint32_t stack[128], top = 0, bad = 0, seen = 0, leaf_tris = 0;
    CHECKF(mesh == 0 || (gs->mesh_root[mesh] > 0 && base > 0),
           "%s: mesh %u's BLAS and triangles come after others'", what, mesh);
    stack[top++] = gs->mesh_root[mesh];
    const pc_bvh_node *root = &nodes[gs->mesh_root[mesh]];
    const float *b = &gs->mesh_bounds[6 * mesh];
    CHECKF(root->bmin.x == b[0] && root->bmin.y == b[1] && root->bmin.z == b[2] &&
               root->bmax.x == b[3] && root->bmax.y == b[4] && root->bmax.z == b[5],
           "%s: the mesh's bounds are its refitted root box", what);
    while (top && seen < nn) {
        const pc_bvh_node *n = &nodes[stack[--top]];
        seen++;
        uint32_t first = pc_f2u(n->bmin.w), count = pc_f2u(n->bmax.w);
        const float lo[3] = {n->bmin.x, n->bmin.y, n->bmin.z},
                    hi[3] = {n->bmax.x, n->bmax.y, n->bmax.z};
        if (count == 0) {
            if (first + 1 >= nn || top + 2 > 128) {
                bad++;
                continue;
            }
            for (int c = 0; c < 2; c++) {
                const pc_bvh_node *ch = &nodes[first + c];
                for (int k = 0; k < 3; k++)
                    bad += (&ch->bmin.x)[k] < lo[k] || (&ch->bmax.x)[k] > hi[k];
                stack[top++] = first + c;
            }
            continue;
        }
        for (uint32_t i = first; i < first + count; i++) {
            if (i < base || i >= base + tris) {
                bad++;
                continue;
            }
            leaf_tris++;
            const pc_vec4 *v[3] = {&t[i].v0, &t[i].v1, &t[i].v2};
            for (int c = 0; c < 3; c++)
                for (int k = 0; k < 3; k++)
                    bad += (&v[c]->x)[k] < lo[k] || (&v[c]->x)[k] > hi[k];
        }
    }
    CHECKF(bad == 0 && leaf_tris == tris,
           "%s: %u boxes do not bound their contents (%u of %u triangles reached)", what, bad,
           leaf_tris, tris);
    free(nodes);
    free(t);
}

/* One frame of gs (direct light, no GI) through r: linear RGB, W x H (the caller frees). */
static float *render(rd_renderer *r, rd_gpu_scene *gs, const rd_view_camera *cam)
{
    float *rgb = calloc((size_t)W * H * 3, sizeof(float));
    if (!rgb) abort();
    rd_frame_settings fs = {.width = W, .height = H, .seed = 1, .sky = {0.05f, 0.05f, 0.05f}};
    rd_vk_result res = rd_renderer_render(r, gs, cam, &fs, err, sizeof err);
    if (res == RD_VK_OK) res = rd_renderer_read_hdr(r, rgb, err, sizeof err);
    CHECKF(res == RD_VK_OK, "render: %s", err);
    return rgb;
}

/* Pixels that differ by more than 1% of the peak luminance; *peak gets it. */
static int differing(const float *a, const float *b, float *peak)
{
    *peak = 0;
    for (size_t i = 0; i < (size_t)W * H * 3; i++)
        *peak = fmaxf(*peak, fmaxf(a[i], b[i]));
    int n = 0;
    for (size_t i = 0; i < (size_t)W * H; i++) {
        float d = 0;
        for (int c = 0; c < 3; c++)
            d = fmaxf(d, fabsf(a[i * 3 + c] - b[i * 3 + c]));
        n += d > 0.01f * *peak;
    }
    return n;
}

/* skin_builder's morphing cubes (three meshes, morph targets with normal and tangent deltas, no
 * skin) posed both ways at a few times: records and trees as for the sheet. */
static void morph_cubes(rd_vk *vk)
{
    rd_scene s;
    rd_gpu_scene gpu = {0}, cpu = {0};
    char *text = gltf_morph_cube();
    rd_gltf_result g = rd_gltf_load_memory(text, strlen(text), NULL, NULL, &s, err, sizeof err);
    free(text);
    CHECKF(g == RD_GLTF_OK && s.mesh_count >= 3, "cubes: %s", err);
    if (g != RD_GLTF_OK) return;
    CHECKF(rd_scene_update(&s, err, sizeof err), "%s", err);
    VK_CHECK(rd_gpu_scene_create(vk, &gpu, &s, err, sizeof err));
    setenv("PROBECAST_DEFORM", "cpu", 1);
    VK_CHECK(rd_gpu_scene_create(vk, &cpu, &s, err, sizeof err));
    unsetenv("PROBECAST_DEFORM");
    const double times[] = {0.5, 1.0, 1.5, 0.25};
    for (size_t p = 0; p < sizeof times / sizeof times[0]; p++) {
        char what[64];
        rd_scene_animate(&s, times[p]);
        CHECKF(rd_scene_update(&s, err, sizeof err), "%s", err);
        VK_CHECK(rd_gpu_scene_update_pose(vk, &gpu, &s, NULL, err, sizeof err));
        VK_CHECK(rd_gpu_scene_update_pose(vk, &cpu, &s, NULL, err, sizeof err));
        for (uint32_t m = 0; m < 3; m++) {
            snprintf(what, sizeof what, "cube %u at %.2f s", m, times[p]);
            check_records(vk, &s, m, &gpu, &cpu, what);
            check_tree(vk, &gpu, &s, m, what);
        }
    }
    printf("cubes: %llu refits, %llu rebuilds\n", (unsigned long long)gpu.deform_refits,
           (unsigned long long)gpu.deform_rebuilds);
    CHECKF(gpu.deform_refits >= 3, "the cubes were refitted on the GPU (%llu times)",
           (unsigned long long)gpu.deform_refits);
done:
    rd_gpu_scene_destroy(vk, &gpu);
    rd_gpu_scene_destroy(vk, &cpu);
    rd_scene_destroy(&s);
}

/* Poses the sheet of s by turning the elbow (node "elbow") deg degrees about +Z. */
static void bend(rd_scene *s, float deg)
{
    float h = deg * 3.14159265f / 360.0f;
    for (uint32_t i = 0; i < s->node_count; i++) {
        if (!s->nodes[i].name || strcmp(s->nodes[i].name, "elbow") != 0) continue;
        const float q[4] = {0, 0, sinf(h), cosf(h)};
        memcpy(s->nodes[i].rotation, q, sizeof q);
    }
    CHECKF(rd_scene_update(s, err, sizeof err), "%s", err);
}

/* Mesh m's BLAS as gs holds it now, read back into a tree of its own (indices relative to the
 * mesh, prim_index from the records' original triangles, node_count its 2 n slots: only what
 * the root reaches counts), over the positions its records hold (pos, 9 floats a triangle in
 * the original order): against a fresh CPU build over pos, the same closest hit (triangle and
 * t) ray by ray, rays from a sphere around the root box through points inside it. */
static void check_hits(rd_vk *vk, const rd_gpu_scene *gs, const rd_scene *s, uint32_t mesh,
                       const char *what)
{
    uint32_t n = s->meshes[mesh].tri_count, base = tri_base(s, mesh), root = gs->mesh_root[mesh];
    rd_bvh tree = {.node_count = 2 * n, .prim_count = n}, fresh;
    tree.nodes = calloc(2 * n, sizeof *tree.nodes);
    tree.prim_index = calloc(n, sizeof *tree.prim_index);
    pc_tri *t = calloc(n, sizeof *t);
    float *pos = calloc((size_t)n * 9, sizeof *pos);
    if (!tree.nodes || !tree.prim_index || !t || !pos) abort();
    CHECK(rd_buffer_download(vk, &gs->blas_nodes, sizeof *tree.nodes * root, tree.nodes,
                             sizeof *tree.nodes * 2 * n, err, sizeof err) == RD_VK_OK);
    CHECK(rd_buffer_download(vk, &gs->tris, sizeof *t * base, t, sizeof *t * n, err, sizeof err) ==
          RD_VK_OK);
    uint32_t bad = 0, rays = 0, hits = 0;
    for (uint32_t i = 0; i < n; i++) {
        uint32_t src = pc_f2u(t[i].v2.w);
        bad += src >= n;
        tree.prim_index[i] = src < n ? src : 0;
        const pc_vec4 *v[3] = {&t[i].v0, &t[i].v1, &t[i].v2};
        for (int c = 0; src < n && c < 3; c++)
            memcpy(&pos[9 * (size_t)src + 3 * c], &v[c]->x, 3 * sizeof(float));
    }
    for (uint32_t i = 0; i < 2 * n; i++) { /* absolute indices back to the mesh's own */
        pc_bvh_node *nd = &tree.nodes[i];
        uint32_t first = pc_f2u(nd->bmin.w), count = pc_f2u(nd->bmax.w);
        nd->bmin.w = pc_u2f(count ? first - base : first - root);
    }
    CHECK(rd_bvh_build_triangles(&fresh, pos, n, NULL));
    const float *lo = &tree.nodes[0].bmin.x, *hi = &tree.nodes[0].bmax.x;
    uint32_t state = 3u;
    for (int i = 0; i < 400 && bad == 0; i++) {
        float u[6], org[3], dir[3], rad = 0;
        for (int k = 0; k < 6; k++) {
            state = state * 1664525u + 1013904223u;
            u[k] = (float)(state >> 8) / 16777216.0f;
        }
        for (int k = 0; k < 3; k++)
            rad += (hi[k] - lo[k]) * (hi[k] - lo[k]);
        float z = 2 * u[0] - 1, ph = 6.2831853f * u[1], sn = sqrtf(fmaxf(0, 1 - z * z));
        const float sd[3] = {sn * cosf(ph), sn * sinf(ph), z};
        for (int k = 0; k < 3; k++) {
            org[k] = 0.5f * (lo[k] + hi[k]) + 2 * sqrtf(rad) * sd[k];
            dir[k] = lo[k] + u[3 + k] * (hi[k] - lo[k]) - org[k];
        }
        float ta = 0, tb = 0;
        int64_t ha = rd_bvh_closest_triangle(&tree, pos, org, dir, 0, 1e30f, &ta);
        int64_t hb = rd_bvh_closest_triangle(&fresh, pos, org, dir, 0, 1e30f, &tb);
        rays++;
        hits += hb >= 0;
        bad += ha != hb || (ha >= 0 && ta != tb);
    }
    printf("%s: %u of %u rays hit, %u differ from a fresh CPU build's\n", what, hits, rays, bad);
    CHECKF(bad == 0 && hits > 0, "%s: %u of %u rays differ from a fresh CPU build (%u hits)", what,
           bad, rays, hits);
    rd_bvh_destroy(&fresh);
    rd_bvh_destroy(&tree);
    free(t);
    free(pos);
}

/* Built folded, then unfolded: the check at the eighth refit (in flight until waited for)
 * finds the tree degraded, and the pose after it rebuilds the sheet on the GPU (the LBVH, in
 * place: the records, tree and hits of a CPU rebuild's, checked against the all-CPU path's
 * scene); the next check is left pending at destroy... after the rebuild every
 * RD_GPU_SCENE_REFIT_MAX-th pose since (64), on the GPU too, with the same checks. */
static void fold(rd_vk *vk)
{
    rd_scene s;
    rd_gpu_scene gpu = {0}, cpu = {0};
    if (!build_scene(&s)) return;
    bend(&s, 0);
    VK_CHECK(rd_gpu_scene_create(vk, &gpu, &s, err, sizeof err));
    setenv("PROBECAST_DEFORM", "cpu", 1);
    VK_CHECK(rd_gpu_scene_create(vk, &cpu, &s, err, sizeof err));
    unsetenv("PROBECAST_DEFORM");
    uint32_t p = 0;
    for (; p <= 8; p++) { /* pose 0 rebuilds (the first), 1-8 refit, 8 starts a check */
        bend(&s, p ? 0.5f * (float)p : 170.0f);
        VK_CHECK(rd_gpu_scene_update_pose(vk, &gpu, &s, NULL, err, sizeof err));
    }
    CHECKF(gpu.deform_refits == 8 && gpu.deform_rebuilds == 1,
           "fold: 8 refits, 1 rebuild before the check applies (%llu, %llu)",
           (unsigned long long)gpu.deform_refits, (unsigned long long)gpu.deform_rebuilds);
    rd_gpu_scene_deform_wait_checks(&gpu);
    CHECKF(gpu.deform_sah_checks == 1, "fold: one check finished (%llu)",
           (unsigned long long)gpu.deform_sah_checks);
    bend(&s, 5.0f);
    VK_CHECK(rd_gpu_scene_update_pose(vk, &gpu, &s, NULL, err, sizeof err));
    VK_CHECK(rd_gpu_scene_update_pose(vk, &cpu, &s, NULL, err, sizeof err));
    printf("fold: %llu refits, %llu CPU rebuilds, %llu GPU rebuilds, %llu SAH checks\n",
           (unsigned long long)gpu.deform_refits, (unsigned long long)gpu.deform_rebuilds,
           (unsigned long long)gpu.deform_gpu_rebuilds, (unsigned long long)gpu.deform_sah_checks);
    CHECKF(gpu.deform_rebuilds == 1 && gpu.deform_gpu_rebuilds == 1 && gpu.deform_refits == 8,
           "fold: the degraded tree is rebuilt on the GPU at the pose after its check (%llu CPU "
           "rebuilds, %llu GPU)",
           (unsigned long long)gpu.deform_rebuilds, (unsigned long long)gpu.deform_gpu_rebuilds);
    check_tree(vk, &gpu, &s, SHEET, "fold, rebuilt on the GPU");
    check_records(vk, &s, SHEET, &gpu, &cpu, "fold, rebuilt on the GPU");
    check_hits(vk, &gpu, &s, SHEET, "fold, rebuilt on the GPU");
    for (p = 0; p < 8; p++) { /* 8 refits of the new tree: a check starts, nobody waits */
        bend(&s, p % 2 ? 10.0f : 20.0f);
        VK_CHECK(rd_gpu_scene_update_pose(vk, &gpu, &s, NULL, err, sizeof err));
    }
    CHECK(gpu.deform_refits == 16 && gpu.deform != NULL);
    check_tree(vk, &gpu, &s, SHEET, "fold, the GPU build refitted");
    check_hits(vk, &gpu, &s, SHEET, "fold, the GPU build refitted");
    /* on to the 64th pose since the GPU build (8 done): rebuilt on the GPU again */
    for (p = 8; p < 64; p++) {
        bend(&s, 10.0f + 0.25f * (float)p);
        VK_CHECK(rd_gpu_scene_update_pose(vk, &gpu, &s, NULL, err, sizeof err));
    }
    VK_CHECK(rd_gpu_scene_update_pose(vk, &cpu, &s, NULL, err, sizeof err));
    printf("fold, 64 poses on: %llu refits, %llu CPU rebuilds, %llu GPU rebuilds, %llu SAH "
           "checks\n",
           (unsigned long long)gpu.deform_refits, (unsigned long long)gpu.deform_rebuilds,
           (unsigned long long)gpu.deform_gpu_rebuilds, (unsigned long long)gpu.deform_sah_checks);
    CHECKF(gpu.deform_rebuilds == 1 && gpu.deform_gpu_rebuilds == 2 && gpu.deform_refits == 16 + 55,
           "fold: the 64th pose since the GPU build rebuilt on the GPU (%llu GPU rebuilds, %llu "
           "refits)",
           (unsigned long long)gpu.deform_gpu_rebuilds, (unsigned long long)gpu.deform_refits);
    check_tree(vk, &gpu, &s, SHEET, "fold, 64th pose");
    check_records(vk, &s, SHEET, &gpu, &cpu, "fold, 64th pose");
    check_hits(vk, &gpu, &s, SHEET, "fold, 64th pose");
done:
    rd_gpu_scene_destroy(vk, &gpu); /* waits for the check */
    CHECK(gpu.deform == NULL);
    rd_gpu_scene_destroy(vk, &cpu);
    rd_scene_destroy(&s);
}

int main(void)
{
    rd_vk vk;
    if (!test_vk_open(&vk)) return test_finish();
    rd_scene s;
    rd_gpu_scene gpu = {0}, cpu = {0};
    rd_renderer rg = {0}, rc = {0};
    rd_view_camera cam;
    float *first = NULL;
    bool have_s = build_scene(&s);
    CHECKF(have_s, "%s", err);
    if (!have_s) goto done;
    CHECKF(rd_camera_for_scene(&s, -1, &cam, err, sizeof err), "%s", err);
    VK_CHECK(rd_gpu_scene_create(&vk, &gpu, &s, err, sizeof err));
    setenv("PROBECAST_DEFORM", "cpu", 1);
    VK_CHECK(rd_gpu_scene_create(&vk, &cpu, &s, err, sizeof err));
    unsetenv("PROBECAST_DEFORM");
    CHECK(!gpu.deform_on_cpu && cpu.deform_on_cpu);
    const rd_ddgi_settings off = {0};
    VK_CHECK(rd_renderer_create(&vk, &rg, err, sizeof err));
    VK_CHECK(rd_renderer_create(&vk, &rc, err, sizeof err));
    VK_CHECK(rd_renderer_configure_gi(&rg, s.bounds_min, s.bounds_max, &off, err, sizeof err));
    VK_CHECK(rd_renderer_configure_gi(&rc, s.bounds_min, s.bounds_max, &off, err, sizeof err));
    /* 0.25 s: the first pose, rebuilt on the CPU by both; then bent to 54 and 90 degrees (the
     * GPU refits), straight again, and on until the eighth refit, whose tree is checked against
     * a fresh build (gpu_scene_deform.c): a 90 degree bend of a tree built at 22.5 degrees stays
     * within RD_GPU_REFIT_REBUILD_SAH_RATIO (probecast_deformbench: only folds pass it) */
    const double times[] = {0.25, 0.6, 1.0, 0.0, 0.2, 0.4, 0.8, 0.9, 1.0};
    for (size_t p = 0; p < sizeof times / sizeof times[0]; p++) {
        char what[64];
        snprintf(what, sizeof what, "pose at %.2f s", times[p]);
        rd_scene_animate(&s, times[p]);
        CHECKF(rd_scene_update(&s, err, sizeof err), "%s", err);
        uint32_t changed = 0;
        VK_CHECK(rd_gpu_scene_update_pose(&vk, &gpu, &s, &changed, err, sizeof err));
        rd_gpu_scene_deform_wait_checks(&gpu); /* the eighth refit's check: counted now */
        CHECKF(changed == 1, "%s: the sheet changed (%u)", what, changed);
        VK_CHECK(rd_gpu_scene_update_pose(&vk, &cpu, &s, NULL, err, sizeof err));
        printf("%s: %llu refits, %llu rebuilds, %llu SAH checks on the GPU scene; deform %.3f "
               "ms, refit %.3f ms, all %.3f ms\n",
               what, (unsigned long long)gpu.deform_refits, (unsigned long long)gpu.deform_rebuilds,
               (unsigned long long)gpu.deform_sah_checks, gpu.deform_ms, gpu.refit_ms,
               gpu.deform_build_ms);
        CHECKF(
            gpu.deform_refits == p && gpu.deform_rebuilds == 1 && gpu.deform_sah_checks == (p >= 8),
            "%s: the first pose rebuilt, the later ones refitted (%llu refits, %llu rebuilds)",
            what, (unsigned long long)gpu.deform_refits, (unsigned long long)gpu.deform_rebuilds);
        CHECK(cpu.deform_refits == 0 && cpu.deform_rebuilds == p + 1);
        check_records(&vk, &s, SHEET, &gpu, &cpu, what);
        check_tree(&vk, &gpu, &s, SHEET, what);
        float *a = render(&rg, &gpu, &cam), *b = render(&rc, &cpu, &cam), peak;
        int diff = differing(a, b, &peak);
        printf("%s: %d pixels differ between the GPU and CPU paths (peak %g)\n", what, diff, peak);
        CHECKF(peak > 0 && diff <= 2, "%s: the refitted scene's image differs in %d pixels", what,
               diff);
        if (first) {
            int moved = differing(first, a, &peak);
            CHECKF(moved >= 20 || (p != 1 && p != 2), "%s: the pose shows (%d pixels changed)",
                   what, moved);
        } else {
            first = a, a = NULL;
        }
        free(a);
        free(b);
    }
    morph_cubes(&vk);
    fold(&vk);
done:
    free(first);
    rd_renderer_destroy(&rg);
    rd_renderer_destroy(&rc);
    rd_gpu_scene_destroy(&vk, &gpu);
    rd_gpu_scene_destroy(&vk, &gpu); /* idempotent */
    rd_gpu_scene_destroy(&vk, &cpu);
    if (have_s) rd_scene_destroy(&s);
    return test_vk_close(&vk);
}
